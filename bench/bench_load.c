/*
 * Loading a large scene through blobcastd's Unix socket: fig18 with N
 * smooth spheres, generated and encoded in the binary scene encoding
 * (PROTOCOL.md section 8) here, then SCENE_LOAD into a fresh daemon
 * whose client already has a VIEW (1024x768 JPEG). Timed from the first
 * byte of the SCENE_LOAD sent to its SCENE_STATE received, to the first
 * FRAME of the new scene and to its still frame, with the daemon's CPU
 * time (user + system, all threads) until SCENE_STATE, which a busy
 * machine does not inflate as it does the wall time; the daemon's resident
 * memory (VmRSS, VmHWM of /proc/PID/status) after the still frame, and
 * per primitive. Each size runs in `runs` fresh daemons; the medians are
 * printed.
 *
 * A scene larger than one message (64 MiB, about 1.3 million spheres)
 * goes in parts (PROTOCOL.md 7.10.1) to a daemon started with
 * --max-scene 256, and its SCENE_STATE comes back in parts; a second
 * client that did not announce PARTS then joins and must be told ENOTSUP
 * (fatal), which the bench checks and prints.
 *
 * With --idle S the daemon runs with --render-idle S, and after the still
 * frame a second member joins without a view and the first leaves:
 * nobody looks, so the session's render copy and the renderer's lists go
 * after S seconds. The lowest VmRSS of the S + 10 seconds after is
 * reported (idle_rss_mib, and per primitive), then the second member asks
 * for the same view: its first frame and its still, the copy made again
 * (back_frame_ms, back_still_ms), and VmRSS after (back_rss_mib).
 *
 * With --named every node has a name ("node 123456", as an imported model's
 * parts may): the session keeps them, its render copy does not.
 *
 * Usage: bench_load [--idle S] [--named] PATH/TO/blobcastd [runs]
 *                   [spheres ...]
 * (default: 3 runs of 100000, 700000 and 1000000 spheres)
 */
#include <stdint.h>

#include "../tests/server/daemon.h"
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "latency.h"

#define W 1024u
#define H 768u
#define MAX_RUNS 15

struct one {
	int64_t state_ms, frame_ms, still_ms;
	int64_t
	    cpu_ms; /* the daemon's CPU time from SCENE_LOAD to SCENE_STATE */
	long rss_kb, hwm_kb;
	int parts; /* the SCENE_STATE's parts (1: whole) */
	/* --idle: the lowest VmRSS once nobody looked, and the view after. */
	long idle_kb, back_kb;
	int64_t back_frame_ms, back_still_ms;
};

static int idle_s; /* --idle S; 0: no idle phase */
static bool named; /* --named */

/* Names every node of t "node ID"; false when one could not be. */
static bool name_all(struct bc_tree *t)
{
	uint32_t n = bc_tree_node_count(t);
	for (uint32_t id = 1; id <= n; id++) {
		char name[24];
		int len = snprintf(name, sizeof(name), "node %u", id);
		if (bc_tree_set_name(t, id, name, (size_t)len, NULL)) {
			return false;
		}
	}
	return true;
}

/* CPU time (user + system) pid has used, in ms; 0 when unreadable. */
static int64_t cpu_of(pid_t pid)
{
	char path[64], buf[1024], *p;
	unsigned long long ut = 0, st = 0;
	FILE *f;
	size_t n;
	snprintf(path, sizeof(path), "/proc/%d/stat", (int)pid);
	if (!(f = fopen(path, "r"))) {
		return 0;
	}
	n = fread(buf, 1, sizeof(buf) - 1, f);
	fclose(f);
	buf[n] = '\0';
	/* Fields 14 and 15, after the command's closing parenthesis. */
	if (!(p = strrchr(buf, ')')) ||
	    sscanf(p + 2,
	           "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &ut,
	           &st) != 2) {
		return 0;
	}
	return (int64_t)((ut + st) * 1000u /
	                 (unsigned long long)sysconf(_SC_CLK_TCK));
}

/* Reads frames until the still frame of order (or later). */
static int still_of(struct conn *c, uint64_t order, int64_t t0, int64_t *first,
                    int64_t *still)
{
	*first = -1;
	while (conn_recv(c, 300000) == 1) {
		if (c->m.type != BC_MSG_FRAME || c->m.frame.order < order) {
			continue;
		}
		if (*first < 0) {
			*first = t_now_ms() - t0;
		}
		if (c->m.flags & BC_PROTO_FLAG_STILL) {
			*still = t_now_ms() - t0;
			return 0;
		}
	}
	return -1;
}

/* The SCENE_STATE answering author_seq, whole or in parts (assembled in
 * p); its order in *order, the parts it came in in *nparts. */
static int state_of(struct conn *c, struct bc_proto_parts *p,
                    uint32_t author_seq, uint64_t *order, int *nparts)
{
	struct bc_msg whole;
	struct bc_errinfo ei = {0};
	*nparts = 0;
	while (conn_recv(c, 300000) == 1) {
		int rc = bc_proto_parts_add(p, &c->m, &whole, &ei);
		*nparts += c->m.type == BC_MSG_SCENE_STATE;
		if (rc < 0) {
			fprintf(stderr, "bad SCENE_STATE parts: %s\n", ei.msg);
			return -1;
		}
		if (rc == 1 && whole.type == BC_MSG_SCENE_STATE &&
		    whole.scene_state.author_seq == author_seq) {
			*order = whole.scene_state.order;
			return 0;
		}
		if (rc == 1 && whole.type == BC_MSG_SCENE_STATE) {
			*nparts = 0;
		}
	}
	return -1;
}

/* A client without PARTS joining a session whose scene passes one
 * message: ERROR ENOTSUP, fatal (PROTOCOL.md 4.1). */
static int no_parts_refused(const struct daemon *d)
{
	struct conn c;
	int ok = 0;
	if (conn_open(&c, d) ||
	    conn_hello_as(&c, "old", BC_PROTO_ENCODINGS_ALL, true,
	                  BC_PROTO_FEATURES_READ & ~BC_PROTO_FEATURE_PARTS) ||
	    !conn_send(
	        &c, &(struct bc_msg){.type = BC_MSG_SESSION_JOIN,
	                             .session = {.role = BC_PROTO_ROLE_VIEWER,
	                                         .name = {"bench", 5}}})) {
		return -1;
	}
	while (conn_recv(&c, 300000) == 1) {
		if (c.m.type == BC_MSG_SCENE_STATE) {
			break; /* sent whole: wrong */
		}
		if (c.m.type == BC_MSG_ERROR) {
			ok = c.m.error.code == (uint16_t)-BC_ENOTSUP &&
			     (c.m.flags & BC_PROTO_FLAG_FATAL);
			break;
		}
	}
	conn_close(&c);
	return ok ? 0 : -1;
}

/* The idle phase (--idle): c, which views, leaves and member c2 stays
 * without a view until the render copy has gone; then c2 views. */
static int idle_phase(const struct daemon *d, struct conn *c, uint64_t order,
                      struct one *o)
{
	struct conn c2;
	long rss, hwm;
	int64_t t0;
	int rc = -1;
	if (conn_open(&c2, d) || conn_hello(&c2, "bench-2") ||
	    conn_join(&c2, "bench", BC_PROTO_ROLE_EDITOR, false) ||
	    conn_expect(&c2, BC_MSG_SCENE_STATE, 60000) != 1) {
		return -1;
	}
	conn_close(c);
	o->idle_kb = -1;
	for (int64_t end = t_now_ms() + (idle_s + 10) * 1000; t_now_ms() < end;
	     t_sleep_ms(100)) {
		latency_rss_of(d->pid, &rss, &hwm);
		if (o->idle_kb < 0 || rss < o->idle_kb) {
			o->idle_kb = rss;
		}
	}
	t0 = t_now_ms();
	if (conn_view(&c2, W, H, BC_PROTO_ENC_JPEG) &&
	    !still_of(&c2, order, t0, &o->back_frame_ms, &o->back_still_ms)) {
		latency_rss_of(d->pid, &o->back_kb, &hwm);
		rc = 0;
	}
	conn_close(&c2);
	return rc;
}

static int run_one(const uint8_t *bytes, size_t len, int k, struct one *o)
{
	static const char *const big[] = {"--max-scene", "256", NULL};
	char idle_arg[16];
	const char *idle[] = {"--render-idle", idle_arg, NULL, NULL, NULL};
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	struct bc_proto_parts parts;
	struct daemon d;
	struct conn c;
	char dir[64], cmd[160];
	int64_t t0, first, still;
	uint64_t order;
	size_t piece = BC_PROTO_MAX_PAYLOAD - 4u;
	bool in_parts = len > piece;
	uint32_t seq = 0;
	int rc = -1, nparts = 0;
	snprintf(dir, sizeof(dir), "/tmp/bc-bench-load-%d-%d", (int)getpid(),
	         k);
	bc_proto_parts_init(&parts, 0, false);
	snprintf(idle_arg, sizeof(idle_arg), "%d", idle_s);
	if (in_parts) {
		idle[2] = big[0];
		idle[3] = big[1];
	}
	if (daemon_start_with(&d, dir,
	                      idle_s     ? idle
	                      : in_parts ? big
	                                 : NULL) != 0) {
		fprintf(stderr, "cannot start %s\n", daemon_path);
		return -1;
	}
	if (conn_open(&c, &d) || conn_hello(&c, "bench") ||
	    conn_join(&c, "bench", BC_PROTO_ROLE_EDITOR, true) ||
	    !conn_view(&c, W, H, BC_PROTO_ENC_JPEG) ||
	    still_of(&c, 0, t_now_ms(), &first, &still)) {
		fprintf(stderr, "cannot join the daemon's session\n");
		goto out;
	}
	o->cpu_ms = cpu_of(d.pid);
	t0 = t_now_ms();
	for (size_t at = 0; at < len; at += piece) {
		size_t n = len - at < piece ? len - at : piece;
		m.flags = (uint16_t)((at ? BC_PROTO_FLAG_CONT : 0u) |
		                     (at + n < len ? BC_PROTO_FLAG_MORE : 0u));
		m.scene_load.scene.ptr = bytes + at;
		m.scene_load.scene.len = (uint32_t)n;
		if (!(seq = conn_send(&c, &m))) {
			break;
		}
	}
	if (!seq || state_of(&c, &parts, seq, &order, &nparts)) {
		fprintf(stderr, "no SCENE_STATE\n");
		goto out;
	}
	o->state_ms = t_now_ms() - t0;
	o->cpu_ms = cpu_of(d.pid) - o->cpu_ms;
	o->parts = nparts;
	bc_proto_parts_drop(&parts);
	if (still_of(&c, order, t0, &o->frame_ms, &o->still_ms)) {
		fprintf(stderr, "no frame of the loaded scene\n");
		goto out;
	}
	latency_rss_of(d.pid, &o->rss_kb, &o->hwm_kb);
	if (in_parts && no_parts_refused(&d)) {
		fprintf(stderr,
		        "a client without PARTS was not told ENOTSUP\n");
		goto out;
	}
	if (idle_s && idle_phase(&d, &c, order, o)) {
		fprintf(stderr, "no frame after the idle phase\n");
		goto out;
	}
	rc = 0;
out:
	bc_proto_parts_finish(&parts);
	conn_close(&c);
	daemon_stop(&d, SIGTERM);
	snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock", dir, dir);
	if (system(cmd) != 0) {
		rc = -1;
	}
	return rc;
}

static int64_t median(int64_t *v, int n)
{
	qsort(v, (size_t)n, sizeof(*v), latency_cmp_i64);
	return v[n / 2];
}

static int bench(uint32_t spheres, int runs)
{
	struct bc_gen_opts go = {.count = spheres,
	                         .kind = BC_GEN_KIND_SPHERES,
	                         .blend = BC_GEN_BLEND_SMOOTH};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint32_t prims;
	struct one o[MAX_RUNS];
	int64_t st[MAX_RUNS], fr[MAX_RUNS], sl[MAX_RUNS], rss[MAX_RUNS],
	    hwm[MAX_RUNS], cpu[MAX_RUNS], idle[MAX_RUNS], bf[MAX_RUNS],
	    bs[MAX_RUNS], brss[MAX_RUNS];
	if (!t || bc_gen("fig18", &go, t, &cam, NULL) ||
	    (named && !name_all(t)) || bc_scene_encode(t, &cam, &bytes, &len)) {
		fprintf(stderr, "cannot make fig18 with %u spheres\n", spheres);
		bc_tree_destroy(t);
		return -1;
	}
	prims = bc_tree_prim_count(t);
	bc_tree_destroy(t);
	for (int k = 0; k < runs; k++) {
		if (run_one(bytes, len, k, &o[k])) {
			bc_free(bytes);
			return -1;
		}
		st[k] = o[k].state_ms;
		cpu[k] = o[k].cpu_ms;
		fr[k] = o[k].frame_ms;
		sl[k] = o[k].still_ms;
		rss[k] = o[k].rss_kb;
		hwm[k] = o[k].hwm_kb;
		idle[k] = o[k].idle_kb;
		bf[k] = o[k].back_frame_ms;
		bs[k] = o[k].back_still_ms;
		brss[k] = o[k].back_kb;
		printf("  run %d: spheres=%u state_parts=%d state_ms=%lld "
		       "daemon_cpu_ms=%lld "
		       "first_frame_ms=%lld still_ms=%lld rss_mib=%.0f "
		       "hwm_mib=%.0f\n",
		       k + 1, spheres, o[k].parts, (long long)st[k],
		       (long long)cpu[k], (long long)fr[k], (long long)sl[k],
		       (double)rss[k] / 1024.0, (double)hwm[k] / 1024.0);
		if (idle_s) {
			printf("  run %d: idle_rss_mib=%.0f back_frame_ms=%lld "
			       "back_still_ms=%lld back_rss_mib=%.0f\n",
			       k + 1, (double)idle[k] / 1024.0,
			       (long long)bf[k], (long long)bs[k],
			       (double)brss[k] / 1024.0);
		}
		fflush(stdout);
	}
	bc_free(bytes);
	if (idle_s) {
		int64_t i = median(idle, runs);
		printf("idle spheres=%u render_idle_s=%d idle_rss_mib=%.0f "
		       "idle_bytes_per_prim=%.0f back_frame_ms=%lld "
		       "back_still_ms=%lld back_rss_mib=%.0f\n",
		       spheres, idle_s, (double)i / 1024.0,
		       (double)i * 1024.0 / prims, (long long)median(bf, runs),
		       (long long)median(bs, runs),
		       (double)median(brss, runs) / 1024.0);
	}
	{
		int64_t r = median(rss, runs), h = median(hwm, runs);
		printf("load spheres=%u named=%d prims=%u bytes=%zu runs=%d "
		       "state_ms=%lld daemon_cpu_ms=%lld first_frame_ms=%lld "
		       "still_ms=%lld "
		       "rss_mib=%.0f hwm_mib=%.0f rss_bytes_per_prim=%.0f "
		       "hwm_bytes_per_prim=%.0f\n",
		       spheres, named ? 1 : 0, prims, len, runs,
		       (long long)median(st, runs),
		       (long long)median(cpu, runs),
		       (long long)median(fr, runs), (long long)median(sl, runs),
		       (double)r / 1024.0, (double)h / 1024.0,
		       (double)r * 1024.0 / prims, (double)h * 1024.0 / prims);
	}
	return 0;
}

int main(int argc, char **argv)
{
	static const uint32_t def[] = {100000, 700000, 1000000};
	int runs;
	for (;;) {
		if (argc > 2 && strcmp(argv[1], "--idle") == 0) {
			idle_s = atoi(argv[2]);
			argc -= 2;
			argv += 2;
		} else if (argc > 1 && strcmp(argv[1], "--named") == 0) {
			named = true;
			argc--;
			argv++;
		} else {
			break;
		}
	}
	runs = argc > 2 ? atoi(argv[2]) : 3;
	if (argc < 2 || runs < 1 || runs > MAX_RUNS || idle_s < 0 ||
	    idle_s > 600) {
		fprintf(stderr,
		        "usage: bench_load [--idle S (1-600)] [--named] "
		        "PATH/TO/blobcastd [runs 1-%d] [spheres ...]\n",
		        MAX_RUNS);
		return 2;
	}
	daemon_path = argv[1];
	signal(SIGPIPE, SIG_IGN);
	if (argc > 3) {
		for (int i = 3; i < argc; i++) {
			if (bench((uint32_t)strtoul(argv[i], NULL, 10), runs)) {
				return 1;
			}
		}
		return 0;
	}
	for (size_t i = 0; i < sizeof(def) / sizeof(def[0]); i++) {
		if (bench(def[i], runs)) {
			return 1;
		}
	}
	return 0;
}
