/*
 * Benchmarks of the adaptive CSG evaluator (render/svo) in the shape of the
 * thesis's tables (Chulkov 2025, §6), on our analogues of its scenes:
 *
 *   grid    Table 6.1/6.2: uniform grids of n^3 voxels, each pruned from the
 *           whole tree; pruning time per voxel for IA, AA and RevAA, and
 *           evaluation time per random point through the voxels' variants
 *           against the unpruned tree.
 *   sweep   Tables 6.4-6.7: the adaptive octree (RevAA, depth limit 15)
 *           over a range of thresholds: average depth, largest and average
 *           RPN length, construction time, traversal and evaluation time
 *           per point, memory, and render time per pixel.
 *   arith   the octree built with each arithmetic at one threshold: what
 *           better ranges buy in construction time and leaf size.
 *   prune   IA against RevAA level by level: the top levels of the octree
 *           pruned with each (every active cell split), cells, terms
 *           received and kept per cell, CPU time per term; the default
 *           octree with each and the per-scene choice (docs/svo.md).
 *   render  `svo` against the CPU `tiled` renderer on the same scenes,
 *           cameras and thread count, side by side in one run, the svo
 *           octree pruned with RevAA and with IA (build and trace each).
 *   files   `svo` frames of scene files with their own cameras: a fresh
 *           renderer per repetition (compiling the RPN untimed, as
 *           libfive's tape), the frame's octree build and trace timed in
 *           process CPU time; one line per repetition, then the median.
 *           bench/libfive/svo_vs_libfive.sh interleaves it with libfive.
 *
 * Scenes: Gears is `gen gears --teeth 100` (RPN length 482; the thesis's
 * has 506-571), Many Spheres `gen many-spheres` (5489, as the thesis's),
 * Many Gears `gen many-gears --count 625` (28 234; the thesis's 30 377).
 *
 * Usage: bench_svo [grid|sweep|arith|prune|render|all] [--quick]
 *        bench_svo files [--size N] [--reps R] [--threads T] [--range A]
 *                  [--threshold TAU] SCENE.json...
 * Every time is measured in this process, one thread unless stated; ratios
 * compare numbers taken side by side in the same run. The machine is shared,
 * so every time is the smallest of several repetitions (REPEATS, or as many
 * as fit in MIN_MS for short ones): others' load only ever adds time.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "blobcast/svo.h"

#define REPEATS 3
#define MIN_MS 300.0

struct scene {
	const char *label; /* as the tables name it */
	const char *gen;
	struct bc_gen_opts o;
};

static double now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static double cpu_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static struct bc_tree *make(const struct scene *sc, struct bc_camera *cam)
{
	struct bc_errinfo ei = {0};
	struct bc_tree *t = bc_tree_create();
	if (!t || bc_gen(sc->gen, &sc->o, t, cam, &ei)) {
		fprintf(stderr, "bench_svo: %s: %s\n", sc->label, ei.msg);
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

/* The smallest of REPEATS timings of the same points. */
static int time_min(const struct bc_svo *sv, const struct bc_svo_grid *g,
                    const struct bc_lin *l, uint32_t points,
                    struct bc_svo_timing *best)
{
	for (int r = 0; r < REPEATS; r++) {
		struct bc_svo_timing tm;
		int rc = sv ? bc_svo_time_octree(sv, l, points, 7, &tm)
		            : bc_svo_time_grid(g, l, points, 7, &tm);
		if (rc || tm.mismatches) {
			fprintf(stderr,
			        "bench_svo: timing failed (%d, %llu "
			        "sign mismatches)\n",
			        rc, (unsigned long long)tm.mismatches);
			return 1;
		}
		if (r == 0) {
			*best = tm;
			continue;
		}
		best->full_ns = fmin(best->full_ns, tm.full_ns);
		best->pruned_ns = fmin(best->pruned_ns, tm.pruned_ns);
		best->locate_ns = fmin(best->locate_ns, tm.locate_ns);
	}
	return 0;
}

/* ---- Table 6.1 / 6.2 ------------------------------------------------------
 */

static int bench_grid(bool quick)
{
	static const struct scene scenes[] = {
	    {"Gears", "gears", {.teeth = 100}},
	    {"Many Gears 16", "many-gears", {.count = 16}},
	    {"Fig18 smooth 64", "fig18", {.count = 64}},
	};
	static const uint32_t sizes[] = {5, 10, 20, 40, 80};
	/* Scenes of the thesis's Table 6.1 are 2D; ours are its 3D Gears,
	 * a small Many Gears and a smooth scene (blends pruned). */
	uint32_t nsizes = quick ? 3 : 5;
	printf("## Uniform grids (thesis Table 6.1)\n\n");
	printf("| Scene | RPN len. | N voxels | prune IA (ms) | prune AA (ms) "
	       "| prune RevAA (ms) | eval IA (ns) | eval AA (ns) "
	       "| eval RevAA (ns) | Original (ns) | avg terms RevAA |\n");
	printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
	for (size_t s = 0; s < sizeof(scenes) / sizeof(scenes[0]); s++) {
		struct bc_tree *t = make(&scenes[s], NULL);
		struct bc_svo_rpn rpn;
		const struct bc_lin *l;
		double lo = INFINITY, hi = 0.0, sum = 0.0;
		uint32_t lo_n = 0, hi_n = 0, nrat = 0;
		if (!t) {
			return 1;
		}
		l = bc_tree_lin(t);
		if (bc_svo_rpn_init(&rpn, l)) {
			return 1;
		}
		for (uint32_t k = 0; k < nsizes; k++) {
			uint32_t n = sizes[k];
			double prune[4] = {0}, eval[4] = {0}, full = 0.0;
			double avg = 0.0;
			uint32_t most;
			uint64_t bytes;
			for (int a = BC_RANGE_IA; a <= BC_RANGE_REVAA; a++) {
				struct bc_svo_grid *g = NULL;
				struct bc_svo_timing tm;
				double ms;
				/* AA costs several times more: as in the
				 * thesis, it is left out on the finest grids.
				 */
				if (a == BC_RANGE_AA && n > 20) {
					prune[a] = eval[a] = NAN;
					continue;
				}
				/* Rebuild until MIN_MS has passed and keep the
				 * fastest build. */
				{
					double total = 0.0, best = INFINITY;
					for (int r = 0; r < 50; r++) {
						bc_svo_grid_destroy(g);
						g = NULL;
						if (bc_svo_grid_build(
						        &g, &rpn,
						        (enum bc_range_arith)a,
						        n, &ms)) {
							return 1;
						}
						best = fmin(best, ms);
						total += ms;
						if (total > MIN_MS && r >= 1) {
							break;
						}
					}
					ms = best;
				}
				if (time_min(NULL, g, l,
				             quick ? 200000 : 1000000, &tm)) {
					return 1;
				}
				prune[a] = ms / ((double)n * n * n);
				eval[a] = tm.pruned_ns;
				full = tm.full_ns;
				if (a == BC_RANGE_REVAA) {
					bc_svo_grid_stats(g, &avg, &most,
					                  &bytes);
					double r = tm.full_ns / tm.pruned_ns;
					sum += r;
					nrat++;
					if (r < lo) {
						lo = r;
						lo_n = n;
					}
					if (r > hi) {
						hi = r;
						hi_n = n;
					}
				}
				bc_svo_grid_destroy(g);
			}
			printf("| %s | %u | %u^3 | %.6f | %.6f | %.6f | %.2f | "
			       "%.2f | %.2f | %.1f | %.2f |\n",
			       scenes[s].label, rpn.n, n, prune[1], prune[2],
			       prune[3], eval[1], eval[2], eval[3], full, avg);
			fflush(stdout);
		}
		printf("| %s: RevAA speedup lowest %.1fx at %u^3, highest "
		       "%.1fx at %u^3, average %.1fx |||||||||||\n",
		       scenes[s].label, lo, lo_n, hi, hi_n, sum / nrat);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
	printf("\n");
	return 0;
}

/* ---- Tables 6.4-6.7 -------------------------------------------------------
 */

/* Trace time per pixel (the smallest of REPEATS frames) and the first
 * frame's acceleration structure time (the octree's build; tiled builds
 * its A-buffer every frame). */
static double render_us_per_pixel(const struct bc_tree *t,
                                  const struct bc_camera *cam,
                                  const struct bc_render_opts *o, uint32_t side,
                                  double *build_ms)
{
	enum bc_backend b = o->svo_range ? BC_BACKEND_SVO : BC_BACKEND_TILED;
	struct bc_renderer *r = NULL;
	struct bc_frame f;
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	double best = INFINITY;
	if (bc_frame_init(&f, side, side)) {
		return NAN;
	}
	if (bc_renderer_create(&r, b, o, &ei) ||
	    bc_renderer_sync(r, t, NULL, &ei)) {
		fprintf(stderr, "bench_svo: render: %s\n", ei.msg);
		bc_renderer_destroy(r);
		bc_frame_finish(&f);
		return NAN;
	}
	for (int k = 0; k < REPEATS; k++) {
		if (bc_renderer_render(r, cam, &f, &st, &ei)) {
			fprintf(stderr, "bench_svo: render: %s\n", ei.msg);
			best = NAN;
			break;
		}
		if (k == 0 && build_ms) {
			*build_ms = st.ms_abuffer;
		}
		best = fmin(best, st.ms_trace);
	}
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	return best * 1e3 / ((double)side * side);
}

static const struct scene big[] = {
    {"Gears", "gears", {.teeth = 100}},
    {"Many Spheres", "many-spheres", {0}},
    {"Many Gears", "many-gears", {.count = 625}},
};

static int bench_sweep(bool quick)
{
	const struct scene *scenes = big;
	static const uint32_t taus[] = {200, 160, 120, 80, 60, 40, 20, 10, 5};
	for (size_t s = 0; s < sizeof(big) / sizeof(big[0]); s++) {
		struct bc_camera cam;
		struct bc_tree *t = make(&scenes[s], &cam);
		struct bc_svo_rpn rpn;
		const struct bc_lin *l;
		struct bc_svo_timing tm0;
		if (!t) {
			return 1;
		}
		l = bc_tree_lin(t);
		if (bc_svo_rpn_init(&rpn, l)) {
			return 1;
		}
		printf("## %s: %u primitives, RPN length %u (thesis Tables "
		       "6.4-6.7)\n\n",
		       scenes[s].label, rpn.nprims, rpn.n);
		printf(
		    "| Thresh. | Avg depth (vol.) | Avg depth (leaves) | Max "
		    "RPN "
		    "len. | Avg RPN len. | SVO constr. (ms) | Avg trav. (ns) "
		    "| Avg eval. (ns) | Avg total (ns) | Speedup | Memory (MB) "
		    "| Render (us/px) |\n");
		printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
		for (size_t k = 0; k < sizeof(taus) / sizeof(taus[0]); k++) {
			struct bc_svo_opts so = {.arith = BC_RANGE_REVAA,
			                         .threshold = taus[k],
			                         .max_depth = BC_SVO_MAX_DEPTH,
			                         .max_bytes = (uint64_t)1
			                                      << 30};
			struct bc_render_opts ro = {.threads = 1,
			                            .svo_range = BC_RANGE_REVAA,
			                            .svo_threshold = taus[k],
			                            .svo_max_depth =
			                                BC_SVO_MAX_DEPTH};
			struct bc_svo *sv = NULL;
			struct bc_svo_stats st;
			struct bc_errinfo ei = {0};
			double px;
			if (quick && k % 3 != 0) {
				continue;
			}
			if (bc_svo_build(&sv, &rpn, &so, &ei) ||
			    time_min(sv, NULL, l, quick ? 200000 : 1000000,
			             &tm0)) {
				fprintf(stderr, "bench_svo: %s\n", ei.msg);
				return 1;
			}
			bc_svo_get_stats(sv, &st);
			px = render_us_per_pixel(t, &cam, &ro, quick ? 64 : 128,
			                         NULL);
			printf("| %u | %.2f | %.2f | %u | %.2f | %.1f | %.1f | "
			       "%.1f | %.1f | %.0fx | %.1f | %.2f |%s\n",
			       taus[k], st.avg_depth, st.avg_depth_leaf,
			       st.max_terms, st.avg_terms, st.build_ms,
			       tm0.locate_ns, tm0.pruned_ns - tm0.locate_ns,
			       tm0.pruned_ns, tm0.full_ns / tm0.pruned_ns,
			       (double)st.bytes / (1024.0 * 1024.0), px,
			       st.truncated ? " (memory budget reached)" : "");
			fflush(stdout);
			bc_svo_destroy(sv);
		}
		printf("\nUnpruned evaluation: %.0f ns per point.\n\n",
		       tm0.full_ns);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
	return 0;
}

/* ---- the arithmetics on the octree ----------------------------------------
 */

static int bench_arith(bool quick)
{
	static const char *const names[] = {"", "IA", "AA", "RevAA"};
	printf("## Octree by arithmetic, threshold 10, depth limit 15\n\n");
	printf("| Scene | Arith. | SVO constr. (ms) | Regions pruned | "
	       "Prune (us/region) | Leaves | Avg RPN len. | Avg total (ns) "
	       "| Speedup |\n");
	printf("|---|---|---|---|---|---|---|---|---|\n");
	for (size_t s = 0; s < sizeof(big) / sizeof(big[0]); s++) {
		struct bc_tree *t = make(&big[s], NULL);
		struct bc_svo_rpn rpn;
		const struct bc_lin *l;
		if (!t) {
			return 1;
		}
		l = bc_tree_lin(t);
		if (bc_svo_rpn_init(&rpn, l)) {
			return 1;
		}
		for (int a = BC_RANGE_IA; a <= BC_RANGE_REVAA; a++) {
			struct bc_svo_opts so = {
			    .arith = (enum bc_range_arith)a,
			    .threshold = 10,
			    .max_depth = BC_SVO_MAX_DEPTH,
			    .max_bytes = (uint64_t)1 << 30};
			struct bc_svo *sv = NULL;
			struct bc_svo_stats st;
			struct bc_svo_timing tm;
			if (bc_svo_build(&sv, &rpn, &so, NULL) ||
			    time_min(sv, NULL, l, quick ? 200000 : 1000000,
			             &tm)) {
				return 1;
			}
			bc_svo_get_stats(sv, &st);
			printf(
			    "| %s | %s | %.1f | %llu | %.2f | %u | %.2f | %.1f "
			    "| %.0fx |\n",
			    big[s].label, names[a], st.build_ms,
			    (unsigned long long)st.pruned,
			    st.build_ms * 1e3 / (double)st.pruned, st.leaves,
			    st.avg_terms, tm.pruned_ns,
			    tm.full_ns / tm.pruned_ns);
			fflush(stdout);
			bc_svo_destroy(sv);
		}
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
	printf("\n");
	return 0;
}

/* ---- IA against RevAA, level by level -------------------------------------
 */

/* The smallest process CPU time of REPEATS trials (or octree builds when
 * tr is NULL: st gets the last build's statistics). */
static double prune_cpu(const struct bc_svo_rpn *rpn, enum bc_range_arith a,
                        uint32_t levels, struct bc_svo_trial *tr,
                        struct bc_svo_stats *st)
{
	double best = INFINITY;
	for (int r = 0; r < REPEATS; r++) {
		double t0 = cpu_ms(), t1;
		struct bc_svo *sv = NULL;
		struct bc_svo_opts so = {.arith = a};
		int rc = tr ? bc_svo_trial_run(rpn, a, 0.0f, levels, tr)
		            : bc_svo_build(&sv, rpn, &so, NULL);
		t1 = cpu_ms();
		if (rc) {
			fprintf(stderr, "bench_svo: pruning failed (%d)\n", rc);
			return -1.0;
		}
		if (sv) {
			bc_svo_get_stats(sv, st);
			bc_svo_destroy(sv);
		}
		best = fmin(best, t1 - t0);
	}
	return best;
}

/* Every active cell of the top levels split and pruned from its parent's
 * variant, with each arithmetic: cells per level, terms received and kept
 * per cell, CPU time and time per term received; then the default octree
 * (threshold 8, depth 10) built with each, and the trial's choice. */
static int bench_prune(bool quick)
{
	static const struct scene scenes[] = {
	    {"Gears", "gears", {.teeth = 100}},
	    {"Fig18 smooth 64", "fig18", {.count = 64}},
	    {"Many Gears 16", "many-gears", {.count = 16}},
	    {"Many Spheres", "many-spheres", {0}},
	    {"Many Gears", "many-gears", {.count = 625}},
	};
	static const char *const names[] = {"default", "IA", "AA", "RevAA"};
	size_t nsc = quick ? 3 : sizeof(scenes) / sizeof(scenes[0]);
	uint32_t levels = quick ? 4 : 5;
	printf("## Pruning by level, IA against RevAA (CPU time)\n\n");
	printf("| Scene | Arith. | level | cells | empty/full | terms in / "
	       "cell | terms kept / cell | kept / in |\n");
	printf("|---|---|---|---|---|---|---|---|\n");
	for (size_t s = 0; s < nsc; s++) {
		struct bc_tree *t = make(&scenes[s], NULL);
		struct bc_svo_rpn rpn;
		struct bc_svo_trial tr[2];
		double ms[2], ns_term[2], build[3];
		struct bc_svo_stats st[3];
		enum bc_range_arith ar[2] = {BC_RANGE_IA, BC_RANGE_REVAA};
		if (!t || bc_svo_rpn_init(&rpn, bc_tree_lin(t))) {
			return 1;
		}
		for (int k = 0; k < 2; k++) {
			uint64_t in = 0;
			ms[k] = prune_cpu(&rpn, ar[k], levels, &tr[k], NULL);
			if (ms[k] < 0.0) {
				return 1;
			}
			for (uint32_t l = 0; l < levels; l++) {
				const struct bc_svo_trial_level *lv =
				    &tr[k].level[l];
				double c = lv->cells ? (double)lv->cells : 1.0;
				in += lv->terms_in;
				printf("| %s | %s | %u | %llu | %llu | %.1f | "
				       "%.1f | %.3f |\n",
				       scenes[s].label, names[ar[k]], l,
				       (unsigned long long)lv->cells,
				       (unsigned long long)lv->decided,
				       (double)lv->terms_in / c,
				       (double)lv->terms_out / c,
				       lv->terms_in ? (double)lv->terms_out /
				                          (double)lv->terms_in
				                    : 0.0);
			}
			ns_term[k] = ms[k] * 1e6 / (double)(in ? in : 1);
		}
		for (int k = 0; k < 3; k++) {
			enum bc_range_arith a =
			    k == 2 ? BC_RANGE_DEFAULT : ar[k];
			build[k] = prune_cpu(&rpn, a, 0, NULL, &st[k]);
			if (build[k] < 0.0) {
				return 1;
			}
		}
		printf("\n%s: RPN %u terms; top %u levels: IA %.1f ms, RevAA "
		       "%.1f ms CPU, %.1f / %.1f ns per term received "
		       "(RevAA / IA %.2f); octree (tau 8, depth 10): IA %.1f "
		       "ms, %llu cells, %u leaves, %.2f terms; RevAA %.1f ms, "
		       "%llu cells, %u leaves, %.2f terms (RevAA / IA %.2f); "
		       "default picks %s, %.1f ms (rule and any trial "
		       "included)\n\n",
		       scenes[s].label, rpn.n, levels, ms[0], ms[1], ns_term[0],
		       ns_term[1], ns_term[1] / ns_term[0], build[0],
		       (unsigned long long)st[0].pruned, st[0].leaves,
		       st[0].avg_terms, build[1],
		       (unsigned long long)st[1].pruned, st[1].leaves,
		       st[1].avg_terms, build[1] / build[0], names[st[2].arith],
		       build[2]);
		fflush(stdout);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
	return 0;
}

/* ---- svo against tiled ----------------------------------------------------
 */

static int bench_render(bool quick)
{
	static const struct scene scenes[] = {
	    {"Gears", "gears", {.teeth = 100}},
	    {"Many Spheres", "many-spheres", {0}},
	    {"Many Gears", "many-gears", {.count = 625}},
	    {"Fig18 smooth 256", "fig18", {0}},
	    {"Fig16 level 3", "fig16", {.level = 3}},
	};
	uint32_t side = quick ? 128 : 256;
	printf("## svo against tiled, %ux%u, 1 thread\n\n", side, side);
	printf("| Scene | prims | tiled (ms) | svo RevAA build (ms) | "
	       "svo IA build (ms) | svo RevAA trace (ms) | svo IA trace (ms) "
	       "| RevAA / IA build | RevAA / IA trace | tiled / svo IA trace "
	       "|\n");
	printf("|---|---|---|---|---|---|---|---|---|---|\n");
	for (size_t s = 0; s < sizeof(scenes) / sizeof(scenes[0]); s++) {
		struct bc_camera cam;
		struct bc_tree *t = make(&scenes[s], &cam);
		struct bc_render_opts tiled = {.threads = 1};
		struct bc_render_opts rev = {.threads = 1,
		                             .svo_range = BC_RANGE_REVAA};
		struct bc_render_opts ia = {.threads = 1,
		                            .svo_range = BC_RANGE_IA};
		double build = 0.0, tt, tr, ti, b2;
		if (!t) {
			return 1;
		}
		tt = render_us_per_pixel(t, &cam, &tiled, side, NULL);
		tr = render_us_per_pixel(t, &cam, &rev, side, &build);
		ti = render_us_per_pixel(t, &cam, &ia, side, &b2);
		tt *= (double)side * side / 1e3;
		tr *= (double)side * side / 1e3;
		ti *= (double)side * side / 1e3;
		printf("| %s | %u | %.1f | %.1f | %.1f | %.1f | %.1f | %.2f "
		       "| %.2f | %.2f |\n",
		       scenes[s].label, bc_tree_prim_count(t), tt, build, b2,
		       tr, ti, build / b2, tr / ti, tt / ti);
		fflush(stdout);
		bc_tree_destroy(t);
	}
	printf("\n");
	return 0;
}

/* ---- scene files, for the libfive comparison ------------------------------
 */

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return x < y ? -1 : (x > y ? 1 : 0);
}

static int bench_files(int argc, char **argv)
{
	uint32_t side = 512, reps = 5, threads = 1, tau = 0;
	enum bc_range_arith arith = BC_RANGE_DEFAULT;
	int nfiles = 0;
	for (int i = 2; i < argc; i++) {
		bool more = i + 1 < argc;
		if (strcmp(argv[i], "--size") == 0 && more) {
			side = (uint32_t)strtoul(argv[++i], NULL, 10);
		} else if (strcmp(argv[i], "--reps") == 0 && more) {
			reps = (uint32_t)strtoul(argv[++i], NULL, 10);
		} else if (strcmp(argv[i], "--threads") == 0 && more) {
			threads = (uint32_t)strtoul(argv[++i], NULL, 10);
		} else if (strcmp(argv[i], "--threshold") == 0 && more) {
			tau = (uint32_t)strtoul(argv[++i], NULL, 10);
		} else if (strcmp(argv[i], "--range") == 0 && more) {
			i++;
			arith = strcmp(argv[i], "ia") == 0   ? BC_RANGE_IA
			        : strcmp(argv[i], "aa") == 0 ? BC_RANGE_AA
			        : strcmp(argv[i], "revaa") == 0
			            ? BC_RANGE_REVAA
			            : BC_RANGE_COUNT;
		} else if (argv[i][0] == '-') {
			fprintf(stderr, "bench_svo files: unknown option %s\n",
			        argv[i]);
			return 2;
		} else {
			nfiles++;
		}
	}
	if (side == 0 || side > 8192 || reps == 0 || reps > 1000 ||
	    arith == BC_RANGE_COUNT || nfiles == 0) {
		fprintf(stderr,
		        "bench_svo files: needs scene files, a size in "
		        "1..8192, 1..1000 reps and a range ia|aa|revaa\n");
		return 2;
	}
	for (int i = 2; i < argc; i++) {
		struct bc_errinfo ei = {0};
		struct bc_camera cam;
		struct bc_tree *t;
		struct bc_frame f;
		double *ms;
		uint64_t hits = 0;
		if (argv[i][0] == '-') {
			i += strcmp(argv[i], "--size") == 0 ||
			     strcmp(argv[i], "--reps") == 0 ||
			     strcmp(argv[i], "--threads") == 0 ||
			     strcmp(argv[i], "--threshold") == 0 ||
			     strcmp(argv[i], "--range") == 0;
			continue;
		}
		t = bc_tree_create();
		ms = calloc(reps, sizeof(*ms));
		if (!t || !ms || bc_frame_init(&f, side, side)) {
			fprintf(stderr, "bench_svo: out of memory\n");
			bc_tree_destroy(t);
			free(ms);
			return 1;
		}
		if (bc_scene_load_json(argv[i], t, &cam, &ei)) {
			fprintf(stderr, "bench_svo: %s: %s\n", argv[i], ei.msg);
			bc_tree_destroy(t);
			bc_frame_finish(&f);
			free(ms);
			return 1;
		}
		for (uint32_t k = 0; k < reps; k++) {
			struct bc_render_opts o = {.threads = threads,
			                           .svo_range = arith,
			                           .svo_threshold = tau};
			struct bc_renderer *r = NULL;
			struct bc_render_stats st;
			double c0, c1;
			if (bc_renderer_create(&r, BC_BACKEND_SVO, &o, &ei) ||
			    bc_renderer_sync(r, t, NULL, &ei)) {
				fprintf(stderr, "bench_svo: %s\n", ei.msg);
				bc_renderer_destroy(r);
				bc_tree_destroy(t);
				bc_frame_finish(&f);
				free(ms);
				return 1;
			}
			c0 = cpu_ms();
			if (bc_renderer_render(r, &cam, &f, &st, &ei)) {
				fprintf(stderr, "bench_svo: %s\n", ei.msg);
				bc_renderer_destroy(r);
				bc_tree_destroy(t);
				bc_frame_finish(&f);
				free(ms);
				return 1;
			}
			c1 = cpu_ms();
			ms[k] = c1 - c0;
			hits = 0;
			for (size_t p = 0; p < (size_t)side * side; p++) {
				hits += isfinite(f.depth[p]);
			}
			printf("svo %s: rep %u: %.1f ms CPU (octree %.1f ms, "
			       "trace %.1f ms wall), %llu evaluations, hit "
			       "%.1f%%\n",
			       argv[i], k, ms[k], st.ms_abuffer, st.ms_trace,
			       (unsigned long long)st.field_evals,
			       100.0 * (double)hits / ((double)side * side));
			fflush(stdout);
			bc_renderer_destroy(r);
		}
		qsort(ms, reps, sizeof(*ms), cmp_double);
		printf("svo %s: %ux%u, %u thread(s): median of %u %.1f ms CPU, "
		       "fastest %.1f ms\n",
		       argv[i], side, side, threads, reps,
		       reps % 2 ? ms[reps / 2]
		                : 0.5 * (ms[reps / 2 - 1] + ms[reps / 2]),
		       ms[0]);
		bc_tree_destroy(t);
		bc_frame_finish(&f);
		free(ms);
	}
	return 0;
}

int main(int argc, char **argv)
{
	const char *what = "all";
	bool quick = false;
	double t0 = now_ms();
	int rc = 0;
	if (argc > 1 && strcmp(argv[1], "files") == 0) {
		return bench_files(argc, argv);
	}
	for (int i = 1; i < argc; i++) {
		if (strcmp(argv[i], "--quick") == 0) {
			quick = true;
		} else {
			what = argv[i];
		}
	}
	if (strcmp(what, "grid") == 0 || strcmp(what, "all") == 0) {
		rc |= bench_grid(quick);
	}
	if (strcmp(what, "sweep") == 0 || strcmp(what, "all") == 0) {
		rc |= bench_sweep(quick);
	}
	if (strcmp(what, "arith") == 0 || strcmp(what, "all") == 0) {
		rc |= bench_arith(quick);
	}
	if (strcmp(what, "prune") == 0 || strcmp(what, "all") == 0) {
		rc |= bench_prune(quick);
	}
	if (strcmp(what, "render") == 0 || strcmp(what, "all") == 0) {
		rc |= bench_render(quick);
	}
	fprintf(stderr, "bench_svo: %.1f s\n", (now_ms() - t0) / 1e3);
	return rc;
}
