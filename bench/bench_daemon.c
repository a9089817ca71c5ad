/*
 * blobcastd benchmarks, through its Unix socket with the raw protocol:
 *  - edit -> frame latency (p50/p99) and bytes per frame for one-primitive
 *    edits at 512^2 on a 1024-primitive fig18 scene, CPU backend: the still
 *    frames carry damaged blocks only; a full still frame of the same view
 *    for comparison;
 *  - frames per second received by 1, 4 and 16 viewers sharing one view
 *    while an editor drags a primitive (INTERACTING edits);
 *  - the same latency with a second client that stops reading (it must be
 *    spoiled, then dropped, without slowing the first).
 *
 * Usage: bench_daemon PATH/TO/blobcastd [edits]
 * (BENCH_FPS_ONLY=1 in the environment skips the latency runs.)
 */
#include <stdint.h>

#include "../tests/server/daemon.h"
#include "blobcast/alloc.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "latency.h"

static struct bc_prim_data original;

/* Edits then waits for the frame reflecting each edit. */
static void latency(struct conn *c, uint32_t id, int edits, const char *label)
{
	static const float dx[2] = {-0.02f, 0.02f};
	struct latency l;
	latency_edits(c, id, &original, dx, 2, edits, false, &l);
	if (l.n) {
		printf("%s edits=%d p50_ms=%lld p99_ms=%lld "
		       "bytes_per_frame=%.0f rects_per_frame=%.1f\n",
		       label, l.n, (long long)l.p50, (long long)l.p99, l.bytes,
		       l.rects);
	}
}

static void fps(struct daemon *d, uint32_t id, int viewers)
{
	struct conn ed, *vs = bc_calloc((size_t)viewers, sizeof(struct conn));
	int64_t t0, seconds = 4;
	long frames = 0;
	if (conn_open(&ed, d) || conn_hello(&ed, "editor") ||
	    conn_join(&ed, "bench", BC_PROTO_ROLE_EDITOR, false)) {
		fprintf(stderr, "editor connect failed\n");
	}
	for (int v = 0; v < viewers; v++) {
		conn_open(&vs[v], d);
		conn_hello(&vs[v], "viewer");
		conn_join(&vs[v], "bench", BC_PROTO_ROLE_VIEWER, false);
		conn_view(&vs[v], 512, 512, BC_PROTO_ENC_JPEG);
		if (conn_expect(&vs[v], BC_MSG_FRAME, 30000) != 1) {
			fprintf(stderr, "viewer %d: no first frame\n", v);
		}
	}
	t0 = t_now_ms();
	for (int i = 0; t_now_ms() - t0 < seconds * 1000; i++) {
		conn_move(&ed, id,
		          original.translate[0] + 0.001f * (float)(i % 50),
		          original.translate[1], original.translate[2], true);
		t_sleep_ms(16);
		while (conn_recv(&ed, 0) == 1) {
		}
		for (int v = 0; v < viewers; v++) {
			while (conn_recv(&vs[v], 0) == 1) {
				frames += vs[v].m.type == BC_MSG_FRAME;
			}
		}
	}
	printf("viewers=%d frames_per_second_per_viewer=%.1f\n", viewers,
	       (double)frames / (double)viewers / (double)seconds);
	for (int v = 0; v < viewers; v++) {
		conn_close(&vs[v]);
	}
	conn_close(&ed);
	bc_free(vs);
}

int main(int argc, char **argv)
{
	struct daemon d;
	struct conn c;
	uint32_t id;
	int edits = argc > 2 ? atoi(argv[2]) : 100;
	char dir[64];
	if (argc < 2) {
		fprintf(stderr,
		        "usage: bench_daemon PATH/TO/blobcastd [edits]\n");
		return 2;
	}
	daemon_path = argv[1];
	signal(SIGPIPE, SIG_IGN);
	snprintf(dir, sizeof(dir), "/tmp/bc-bench-%d", (int)getpid());
	if (daemon_start(&d, dir) != 0) {
		fprintf(stderr, "cannot start %s\n", argv[1]);
		return 1;
	}
	conn_open(&c, &d);
	conn_hello(&c, "bench");
	conn_join(&c, "bench", BC_PROTO_ROLE_EDITOR, true);
	if (latency_load_fig18(&c, 1024, &id, &original, NULL)) {
		fprintf(stderr, "scene load failed\n");
		return 1;
	}
	conn_view(&c, 512, 512, BC_PROTO_ENC_JPEG);
	/* Coarse pictures first, then the still: the edits start from it. */
	do {
		if (conn_expect(&c, BC_MSG_FRAME, 30000) != 1) {
			fprintf(stderr, "no still frame\n");
			return 1;
		}
	} while (!(c.m.flags & BC_PROTO_FLAG_STILL));
	printf("full_still_frame bytes=%.0f\n", latency_frame_bytes(&c.m));
	if (!getenv("BENCH_FPS_ONLY")) {
		latency(&c, id, edits, "solo");
	}
	{
		/* A second member with the same view that never reads. */
		struct conn lazy;
		conn_open(&lazy, &d);
		conn_hello(&lazy, "lazy");
		conn_join(&lazy, "bench", BC_PROTO_ROLE_VIEWER, false);
		{
			struct bc_msg v = {.type = BC_MSG_VIEW};
			v.view.width = 1024;
			v.view.height = 1024;
			v.view.encoding = BC_PROTO_ENC_RAW;
			v.view.quality_interactive = 50;
			v.view.quality_still = 90;
			v.view.downscale = 1;
			conn_send(&lazy, &v);
		}
		if (!getenv("BENCH_FPS_ONLY")) {
			/* Its one render (its first frame, never taken) is
			 * warm-up; then the steady state is measured, and solo
			 * again after it to bound the machine's drift. */
			latency(&c, id, 5, "warmup_with_stalled_client");
			latency(&c, id, edits, "with_stalled_client");
		}
		conn_close(&lazy);
	}
	if (!getenv("BENCH_FPS_ONLY")) {
		latency(&c, id, edits, "solo_again");
	}
	fps(&d, id, 1);
	fps(&d, id, 4);
	fps(&d, id, 16);
	conn_close(&c);
	daemon_stop(&d, SIGTERM);
	{
		char cmd[160];
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock", dir, dir);
		if (system(cmd) != 0) {
			return 1;
		}
	}
	return 0;
}
