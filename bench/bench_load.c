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
 * Usage: bench_load PATH/TO/blobcastd [runs] [spheres ...]
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
};

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

static int run_one(const uint8_t *bytes, size_t len, int k, struct one *o)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	struct daemon d;
	struct conn c;
	char dir[64], cmd[160];
	int64_t t0, first, still;
	uint64_t order;
	int rc = -1;
	snprintf(dir, sizeof(dir), "/tmp/bc-bench-load-%d-%d", (int)getpid(),
	         k);
	if (daemon_start(&d, dir) != 0) {
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
	m.scene_load.scene.ptr = bytes;
	m.scene_load.scene.len = (uint32_t)len;
	o->cpu_ms = cpu_of(d.pid);
	t0 = t_now_ms();
	if (!conn_send(&c, &m) ||
	    conn_expect(&c, BC_MSG_SCENE_STATE, 300000) != 1) {
		fprintf(stderr, "no SCENE_STATE\n");
		goto out;
	}
	o->state_ms = t_now_ms() - t0;
	o->cpu_ms = cpu_of(d.pid) - o->cpu_ms;
	order = c.m.scene_state.order;
	if (still_of(&c, order, t0, &o->frame_ms, &o->still_ms)) {
		fprintf(stderr, "no frame of the loaded scene\n");
		goto out;
	}
	latency_rss_of(d.pid, &o->rss_kb, &o->hwm_kb);
	rc = 0;
out:
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
	    hwm[MAX_RUNS], cpu[MAX_RUNS];
	if (!t || bc_gen("fig18", &go, t, &cam, NULL) ||
	    bc_scene_encode(t, &cam, &bytes, &len)) {
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
		printf("  run %d: spheres=%u state_ms=%lld daemon_cpu_ms=%lld "
		       "first_frame_ms=%lld still_ms=%lld rss_mib=%.0f "
		       "hwm_mib=%.0f\n",
		       k + 1, spheres, (long long)st[k], (long long)cpu[k],
		       (long long)fr[k], (long long)sl[k],
		       (double)rss[k] / 1024.0, (double)hwm[k] / 1024.0);
		fflush(stdout);
	}
	bc_free(bytes);
	{
		int64_t r = median(rss, runs), h = median(hwm, runs);
		printf("load spheres=%u prims=%u bytes=%zu runs=%d "
		       "state_ms=%lld daemon_cpu_ms=%lld first_frame_ms=%lld "
		       "still_ms=%lld "
		       "rss_mib=%.0f hwm_mib=%.0f rss_bytes_per_prim=%.0f "
		       "hwm_bytes_per_prim=%.0f\n",
		       spheres, prims, len, runs, (long long)median(st, runs),
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
	int runs = argc > 2 ? atoi(argv[2]) : 3;
	if (argc < 2 || runs < 1 || runs > MAX_RUNS) {
		fprintf(stderr,
		        "usage: bench_load PATH/TO/blobcastd [runs 1-%d] "
		        "[spheres ...]\n",
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
