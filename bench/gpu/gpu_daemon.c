/*
 * The GPU run's `daemon` step: edit -> frame through blobcastd --backend gl
 * with the raw protocol over its Unix socket (tests/server/daemon.h) and
 * bench/latency.h's measurement, at each asked view size, JPEG.
 */
#include <stdlib.h>
#include <string.h>

#include "../../tests/server/daemon.h"
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "gpu.h"
#include "latency.h"

/* ---- daemon ------------------------------------------------------------- */

static struct bc_prim_data original;

static void send_view(struct conn *c, uint32_t w, uint32_t h)
{
	struct bc_msg v = {.type = BC_MSG_VIEW};
	v.view.width = (uint16_t)w;
	v.view.height = (uint16_t)h;
	v.view.encoding = BC_PROTO_ENC_JPEG;
	v.view.quality_interactive = 70;
	v.view.quality_still = 90;
	v.view.downscale = 8;
	conn_send(c, &v);
}

/* Reads frames until the still of the current state. */
static int settle(struct conn *c, int timeout_ms)
{
	int64_t end = t_now_ms() + timeout_ms;
	while (t_now_ms() < end && conn_recv(c, 1000) >= 0) {
		if (c->m.type == BC_MSG_FRAME &&
		    (c->m.flags & BC_PROTO_FLAG_STILL)) {
			return 0;
		}
		if (c->m.type == BC_MSG_ERROR) {
			fprintf(stderr,
			        "bench_gpu: the daemon answered ERROR %u: "
			        "%.*s\n",
			        (unsigned)c->m.error.code,
			        (int)c->m.error.text.len, c->m.error.text.ptr);
			return -1;
		}
	}
	return -1;
}

/* Reads what the daemon still sends (refinements, the still frame) until
 * it has been quiet for quiet_ms, at most max_ms. */
static void drain(struct conn *c, int quiet_ms, int max_ms)
{
	int64_t end = t_now_ms() + max_ms;
	while (t_now_ms() < end && conn_recv(c, quiet_ms) == 1) {
	}
}

static void daemon_row(struct gpu_out *o, const char *mode, uint32_t w,
                       uint32_t h, const struct latency *l, int asked,
                       bool first)
{
	printf("daemon %ux%u %-5s: %d of %d edits, p50 %lld ms, p99 %lld ms, "
	       "max %lld ms, %.0f bytes per frame\n",
	       w, h, mode, l->n, asked, (long long)l->p50, (long long)l->p99,
	       (long long)l->max, l->bytes);
	fprintf(o->json,
	        "%s{\"size\":\"%ux%u\",\"mode\":\"%s\",\"encoding\":\"jpeg\","
	        "\"edits\":%d,\"frames\":%d,\"p50_ms\":%lld,\"p99_ms\":%lld,"
	        "\"max_ms\":%lld,\"bytes_per_frame\":%.0f}",
	        first ? "" : ",", w, h, mode, asked, l->n, (long long)l->p50,
	        (long long)l->p99, (long long)l->max, l->bytes);
	fprintf(o->md, "| %ux%u | %s | %d / %d | %lld | %lld | %lld | %.0f |\n",
	        w, h, mode, l->n, asked, (long long)l->p50, (long long)l->p99,
	        (long long)l->max, l->bytes);
	if (l->n < asked) {
		gpu_fail(o, "%ux%u %s: %d of %d edits got their frame", w, h,
		         mode, l->n, asked);
	}
}

int gpu_cmd_daemon(const struct gpu_opts *op)
{
	struct gpu_out o;
	struct daemon d = {0};
	struct conn c = {.fd = -1};
	uint32_t id = 0, count = op->ncounts ? op->counts[0] : 1024;
	char dir[64];
	const char *extra[5] = {"--backend", "gl", NULL, NULL, NULL};
	bool first = true, up = false;
	if (!op->blobcastd) {
		fprintf(stderr, "bench_gpu daemon: --blobcastd PATH is "
		                "required\n");
		return 2;
	}
	if (gpu_out_open(&o, op)) {
		return 1;
	}
	if (op->platform) {
		extra[2] = "--gl-platform";
		extra[3] = op->platform;
	}
	daemon_path = op->blobcastd;
	signal(SIGPIPE, SIG_IGN);
	/* The daemon's log goes to our stderr (the step's log). */
	setenv("BLOBCAST_TEST_VERBOSE", "1", 1);
	snprintf(dir, sizeof(dir), "/tmp/bc-gpu-%d", (int)getpid());
	fprintf(o.json, "{\"scene\":\"fig18 smooth spheres %u\",\"rows\":[",
	        count);
	fprintf(o.md,
	        "blobcastd --backend gl, fig18 smooth spheres %u, JPEG; each "
	        "edit moves one sphere and waits for the first FRAME that "
	        "reflects it (bench/latency.h). still: plain edits; drag: "
	        "INTERACTING edits. ms.\n\n"
	        "| view | mode | frames / edits | p50 | p99 | max | bytes / "
	        "frame |\n|---|---|---:|---:|---:|---:|---:|\n",
	        count);
	if (daemon_start_with(&d, dir, extra) != 0) {
		gpu_fail(&o, "cannot start %s", op->blobcastd);
	} else if (conn_open(&c, &d) || conn_hello(&c, "bench_gpu") ||
	           conn_join(&c, "gpu", BC_PROTO_ROLE_EDITOR, true)) {
		gpu_fail(&o, "cannot join a session of %s", op->blobcastd);
	} else if (latency_load_fig18(&c, count, &id, &original, NULL)) {
		gpu_fail(&o, "loading fig18 %u into the daemon failed", count);
	} else {
		up = true;
	}
	for (uint32_t s = 0; up && s < op->nsizes; s++) {
		uint32_t w = op->sizes[s][0], h = op->sizes[s][1];
		static const float dx[2] = {-0.02f, 0.02f};
		float drag[25];
		struct latency l;
		for (int i = 0; i < 25; i++) {
			drag[i] = 0.004f * (float)i;
		}
		/* 30 s, and 30 s more per 600 000 primitives (a million
		 * take seconds to reach the renderer). */
		int wait_s = 30 + (int)(count / 20000u);
		send_view(&c, w, h);
		if (settle(&c, wait_s * 1000)) {
			gpu_fail(
			    &o,
			    "%ux%u: no still frame from the daemon in %d s "
			    "(its log says why)",
			    w, h, wait_s);
			break;
		}
		/* Warm-up edits, not counted. */
		latency_edits(&c, id, &original, dx, 2, 3, false, &l);
		latency_edits(&c, id, &original, dx, 2, op->edits, false, &l);
		daemon_row(&o, "still", w, h, &l, op->edits, first);
		first = false;
		drain(&c, 500, 60000);
		latency_edits(&c, id, &original, drag, 25, op->edits, true, &l);
		daemon_row(&o, "drag", w, h, &l, op->edits, false);
		drain(&c, 500, 60000);
	}
	fputc(']', o.json);
	gpu_json_errors(o.json);
	fputs("}\n", o.json);
	conn_close(&c);
	if (d.pid > 0) {
		int status = daemon_stop(&d, SIGTERM);
		if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
			gpu_fail(&o,
			         "blobcastd did not exit cleanly (status %d)",
			         status);
		}
	}
	{
		char cmd[160];
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock", dir, dir);
		if (system(cmd) != 0) {
			gpu_fail(&o, "cannot remove %s", dir);
		}
	}
	/* Helpers of daemon.h this driver does without. */
	(void)t_sleep_ms;
	(void)daemon_start;
	(void)conn_view;
	return gpu_out_close(&o);
}
