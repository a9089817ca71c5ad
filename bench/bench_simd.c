/*
 * CPU tracer ratio benchmark: the `tiled` renderer with vector instructions
 * on and off (`opts.simd`, BC_SIMD_AUTO against BC_SIMD_OFF) and with one
 * and two threads, side by side in one run, at 512x512 on the paper's
 * synthetic scenes (Zanni 2024 Fig. 18 smooth spheres 256/1024/4096 and
 * Fig. 16 levels 1-4), on the Lipschitz Pruning scenes converted into
 * bench/scenes/lipschitz/ (Trees, Molecule), and on two trees with unary
 * and domain nodes (bench/scenes/unary/, written by make_unary.sh).
 *
 * It reports ratios, not absolute times: this machine is shared and has no
 * GPU. For each scene and each of the four configurations one renderer is
 * created and synced once, renders one untimed frame (allocation, the
 * thread pool's start), then the configurations take turns, `reps` rounds,
 * so that drift of the machine's load touches all four alike; the fastest
 * frame of each is kept. One-thread figures are process CPU time (the
 * renderer's own work, whatever else runs); two-thread figures are wall
 * time (CPU time would sum the threads), so the thread ratio is only as
 * good as the machine is quiet.
 *
 * Columns: ms per frame of each configuration; simd = off / auto at one
 * thread (> 1: the vector path is faster); thr = one thread / two threads,
 * both auto, by wall time; ns/ev = trace-phase wall time per field
 * evaluation at one thread (off, then auto); ev/px = field evaluations per
 * pixel; diff = pixels whose primitive id differs between off and auto at
 * one thread (the vector path must draw the same picture).
 *
 * A scene file that does not load is an error: the program stops with
 * status 1, naming the file and the reason, so a converter regression is
 * seen here rather than measured as an empty frame.
 *
 * Usage: bench_simd [--size N] [--reps R] [--scenes DIR] [--quick]
 *                   [--scene FILE]...
 *   --size N      frame edge (default 512)
 *   --reps R      timed rounds per configuration, the fastest kept (3)
 *   --scenes DIR  directory holding lipschitz/{trees,molecule}.json
 *                 (default: the source tree's bench/scenes)
 *   --quick       fig18 256, the Lipschitz and the unary scenes only
 *   --scene FILE  time this scene file (with its camera) instead of the
 *                 built-in list; may be repeated (up to 16)
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "tiled_confs.h"

#ifndef BC_BENCH_SCENES_DIR
#define BC_BENCH_SCENES_DIR "bench/scenes"
#endif

struct scene {
	const char *label;
	const char *gen;  /* generator name, or NULL: file */
	const char *file; /* under the scenes directory */
	struct bc_gen_opts opts;
	int quick; /* part of --quick */
};

struct timing {
	double cpu, wall;          /* ms, fastest run */
	struct bc_render_stats st; /* of the fastest run */
};

static double clock_ms(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static void die(const char *what, const struct bc_errinfo *ei)
{
	fprintf(stderr, "bench_simd: %s: %s\n", what, ei->msg);
	exit(1);
}

/* Renders one frame with r and keeps it in *best when it is the fastest:
 * by CPU time for one thread, by wall time otherwise. */
static void render_timed(struct bc_renderer *r, uint32_t threads,
                         const struct bc_camera *cam, struct bc_frame *f,
                         struct timing *best)
{
	struct bc_errinfo ei = {0};
	struct bc_render_stats st;
	double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
	double w0 = clock_ms(CLOCK_MONOTONIC), cpu, wall;
	if (bc_renderer_render(r, cam, f, &st, &ei)) {
		die("render", &ei);
	}
	cpu = clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
	wall = clock_ms(CLOCK_MONOTONIC) - w0;
	if (threads == 1 ? cpu < best->cpu : wall < best->wall) {
		best->cpu = cpu;
		best->wall = wall;
		best->st = st;
	}
}

/* The time a configuration is compared by (see render_timed). */
static double conf_ms(int c, const struct timing *t)
{
	return confs[c].threads == 1 ? t->cpu : t->wall;
}

static double ns_per_eval(const struct timing *t)
{
	return t->st.field_evals
	           ? t->st.ms_trace * 1e6 / (double)t->st.field_evals
	           : 0.0;
}

static int load_scene(const struct scene *s, const char *dir, struct bc_tree *t,
                      struct bc_camera *cam)
{
	struct bc_errinfo ei = {0};
	char path[4096];
	if (s->gen) {
		if (bc_gen(s->gen, &s->opts, t, cam, &ei)) {
			die(s->label, &ei);
		}
		return 0;
	}
	if (snprintf(path, sizeof(path), "%s%s%s", dir ? dir : "",
	             dir ? "/" : "", s->file) >= (int)sizeof(path)) {
		fprintf(stderr, "bench_simd: scene path too long\n");
		exit(2);
	}
	if (bc_scene_load_json(path, t, cam, &ei)) {
		fprintf(stderr,
		        "bench_simd: %s does not load (%s): %s\n"
		        "  (regenerate it with bench/scenes/"
		        "convert_lipschitz.py or make_unary.sh, or pass "
		        "--scenes DIR)\n",
		        path, bc_err_name(ei.code), ei.msg);
		exit(1);
	}
	if (bc_tree_prim_count(t) == 0) {
		fprintf(stderr, "bench_simd: %s loads as an empty tree\n",
		        path);
		exit(1);
	}
	return 0;
}

static uint64_t id_diff(const struct bc_frame *a, const struct bc_frame *b)
{
	uint64_t n = 0;
	for (size_t i = 0; i < (size_t)a->width * a->height; i++) {
		n += a->ids[i] != b->ids[i];
	}
	return n;
}

int main(int argc, char **argv)
{
	const struct scene scenes[] = {
	    {"fig18 smooth spheres 256",
	     "fig18",
	     NULL,
	     {.count = 256,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     1},
	    {"fig18 smooth spheres 1024",
	     "fig18",
	     NULL,
	     {.count = 1024,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     0},
	    {"fig18 smooth spheres 4096",
	     "fig18",
	     NULL,
	     {.count = 4096,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     0},
	    {"fig16 L1 smooth",
	     "fig16",
	     NULL,
	     {.level = 1, .blend = BC_GEN_BLEND_SMOOTH},
	     0},
	    {"fig16 L2 smooth",
	     "fig16",
	     NULL,
	     {.level = 2, .blend = BC_GEN_BLEND_SMOOTH},
	     0},
	    {"fig16 L3 smooth",
	     "fig16",
	     NULL,
	     {.level = 3, .blend = BC_GEN_BLEND_SMOOTH},
	     0},
	    {"fig16 L4 smooth",
	     "fig16",
	     NULL,
	     {.level = 4, .blend = BC_GEN_BLEND_SMOOTH},
	     0},
	    {"lipschitz trees", NULL, "lipschitz/trees.json", {0}, 1},
	    {"lipschitz molecule", NULL, "lipschitz/molecule.json", {0}, 1},
	    {"unary twist (fig18 256)", NULL, "unary/twist.json", {0}, 1},
	    {"unary repeat (fig18 64)", NULL, "unary/repeat.json", {0}, 1},
	};
	size_t nscenes = sizeof(scenes) / sizeof(scenes[0]);
	struct scene files[16];
	size_t nfiles = 0;
	const struct scene *list = scenes;
	const char *dir = BC_BENCH_SCENES_DIR;
	uint32_t size = 512;
	int reps = 3, quick = 0;
	for (int i = 1; i < argc; i++) {
		if (strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
			size = (uint32_t)atoi(argv[++i]);
		} else if (strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
			reps = atoi(argv[++i]);
		} else if (strcmp(argv[i], "--scenes") == 0 && i + 1 < argc) {
			dir = argv[++i];
		} else if (strcmp(argv[i], "--quick") == 0) {
			quick = 1;
		} else if (strcmp(argv[i], "--scene") == 0 && i + 1 < argc &&
		           nfiles < sizeof(files) / sizeof(files[0])) {
			i++;
			files[nfiles++] =
			    (struct scene){argv[i], NULL, argv[i], {0}, 1};
		} else {
			fprintf(stderr,
			        "usage: bench_simd [--size N] [--reps R] "
			        "[--scenes DIR] [--quick] "
			        "[--scene FILE]...\n");
			return 2;
		}
	}
	if (size < 64 || size > BC_RENDER_MAX_DIM || reps < 1) {
		fprintf(stderr, "bench_simd: bad --size or --reps\n");
		return 2;
	}
	if (nfiles > 0) {
		list = files;
		nscenes = nfiles;
		dir = NULL;
	}
	printf("tiled, frame %ux%u, fastest of %d rounds (configurations "
	       "interleaved); simd/threads: 1 thread by process CPU time, 2 "
	       "threads by wall time (ms)\n\n",
	       size, size, reps);
	printf("%-26s %6s | %8s %8s %8s %8s | %5s %5s | %6s %6s | %5s | %s\n",
	       "scene", "prims", "off/1", "auto/1", "off/2", "auto/2", "simd",
	       "thr", "ns/ev", "(auto)", "ev/px", "diff");
	for (size_t s = 0; s < nscenes; s++) {
		struct bc_tree *t;
		struct bc_camera cam;
		struct bc_renderer *r[CONF_COUNT] = {0};
		struct bc_frame f[CONF_COUNT] = {{0}};
		struct timing tm[CONF_COUNT];
		if (quick && !list[s].quick) {
			continue;
		}
		t = bc_tree_create();
		if (!t) {
			fprintf(stderr, "bench_simd: out of memory\n");
			return 1;
		}
		load_scene(&list[s], dir, t, &cam);
		for (int c = 0; c < CONF_COUNT; c++) {
			struct bc_errinfo ei = {0};
			struct bc_render_opts o = {.threads = confs[c].threads,
			                           .simd = confs[c].simd};
			if (bc_frame_init(&f[c], size, size)) {
				fprintf(stderr, "bench_simd: out of memory\n");
				return 1;
			}
			if (bc_renderer_create(&r[c], BC_BACKEND_TILED, &o,
			                       &ei) ||
			    bc_renderer_sync(r[c], t, NULL, &ei)) {
				die(confs[c].name, &ei);
			}
			tm[c] =
			    (struct timing){.cpu = INFINITY, .wall = INFINITY};
			/* Untimed: first-frame allocation, pool start. */
			render_timed(r[c], confs[c].threads, &cam, &f[c],
			             &(struct timing){.cpu = INFINITY,
			                              .wall = INFINITY});
		}
		for (int i = 0; i < reps; i++) {
			for (int c = 0; c < CONF_COUNT; c++) {
				render_timed(r[c], confs[c].threads, &cam,
				             &f[c], &tm[c]);
			}
		}
		printf("%-26s %6u | %8.1f %8.1f %8.1f %8.1f | %4.2fx %4.2fx "
		       "| %6.1f %6.1f | %5.1f | %" PRIu64 "\n",
		       list[s].label, bc_tree_prim_count(t),
		       conf_ms(CONF_OFF1, &tm[CONF_OFF1]),
		       conf_ms(CONF_AUTO1, &tm[CONF_AUTO1]),
		       conf_ms(CONF_OFF2, &tm[CONF_OFF2]),
		       conf_ms(CONF_AUTO2, &tm[CONF_AUTO2]),
		       tm[CONF_OFF1].cpu / tm[CONF_AUTO1].cpu,
		       tm[CONF_AUTO1].wall / tm[CONF_AUTO2].wall,
		       ns_per_eval(&tm[CONF_OFF1]),
		       ns_per_eval(&tm[CONF_AUTO1]),
		       (double)tm[CONF_AUTO1].st.field_evals /
		           ((double)size * size),
		       id_diff(&f[CONF_OFF1], &f[CONF_AUTO1]));
		fflush(stdout);
		for (int c = 0; c < CONF_COUNT; c++) {
			bc_renderer_destroy(r[c]);
			bc_frame_finish(&f[c]);
		}
		bc_tree_destroy(t);
	}
	return 0;
}
