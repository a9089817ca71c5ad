/*
 * CPU renderer benchmark: `tiled` (Zanni 2024 §6 on CPU threads) against
 * `naive` (full-tree sphere tracing per pixel) at 512x512 on the paper's
 * synthetic scenes -- Fig. 18 smooth spheres (256, 1024, 4096) and Fig. 16
 * levels 1-4 -- with the same thread count, side by side in one run.
 *
 * Naive on these scenes takes minutes per frame, so both backends are also
 * timed on a band of the frame: the central `rows` rows of the 512x512
 * image, rendered as a 512 x rows frame whose vertical field of view is cut
 * to match (the same pixel rays exactly). The speedup column is naive over
 * tiled on that band; the naive full-frame figure is the band time scaled
 * by 512 / rows and is marked as an estimate. Tiled is also timed on the
 * full frame, which the growth figure uses. Times are process CPU time
 * (the wall time of the same run is shown beside the full-frame figure):
 * with one thread they are the renderer's own work, whatever else the
 * machine runs.
 *
 * With --frames it times instead what a user of the tiled tracer waits
 * for: the cold frame of a new view (its tile lists built, counted in)
 * and the warm frames after it (lists kept), with the scalar and the
 * vector path (opts.simd off and auto) and with one and two threads, side
 * by side in one run (see frames_main).
 *
 * With --big it times the cold and warm 1024x1024 frames of the two
 * scenes of a million primitives (see big_main).
 *
 * Usage: bench_render [--size N] [--threads T] [--reps R] [--quick]
 *                     [--frames [--scene TEXT] [--loop N]] [--big]
 *   --size N     frame edge (default 512)
 *   --threads T  threads for both backends (default 1: steadier on a
 *                shared machine; 0 = one per core; CPU time then sums
 *                the threads); --frames always runs 1 and 2
 *   --reps R     tiled runs per measurement, the fastest is kept (3);
 *                --frames: rounds, the median is kept
 *   --quick      only the first three scenes (--frames: four of them)
 *   --frames     cold and warm frames, scalar and vector, 1 and 2 threads
 *   --scene TEXT --frames of the scenes whose name holds TEXT only
 *   --loop N     --frames: N warm vector frames a scene, one thread, and
 *                their CPU time instead of the table (for a profiler)
 *   --big        fig18 1 000 000 spheres and fig16 L6, 1024 by default
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "tiled_confs.h"

struct scene {
	const char *label;
	const char *gen;
	struct bc_gen_opts opts;
	uint32_t band; /* rows of the naive band; 0: not in the naive table */
	int frames;    /* in --frames: 0 no, 1 yes, 2 also with --quick */
};

/* Every scene of both tables; the first three are fig18's. */
static const struct scene scenes[] = {
    {"fig18 smooth spheres 256",
     "fig18",
     {.count = 256, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SMOOTH},
     32,
     2},
    {"fig18 smooth spheres 1024",
     "fig18",
     {.count = 1024, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SMOOTH},
     16,
     1},
    {"fig18 smooth spheres 4096",
     "fig18",
     {.count = 4096, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SMOOTH},
     8,
     2},
    {"gears 24 teeth", "gears", {.teeth = 24}, 0, 2},
    {"fig16 L1 smooth",
     "fig16",
     {.level = 1, .blend = BC_GEN_BLEND_SMOOTH},
     32,
     0},
    {"fig16 L2 smooth",
     "fig16",
     {.level = 2, .blend = BC_GEN_BLEND_SMOOTH},
     16,
     1},
    {"fig16 L3 smooth",
     "fig16",
     {.level = 3, .blend = BC_GEN_BLEND_SMOOTH},
     8,
     2},
    {"fig16 L4 smooth",
     "fig16",
     {.level = 4, .blend = BC_GEN_BLEND_SMOOTH},
     4,
     1},
};

static double clock_ms(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

struct timing {
	double cpu, wall; /* ms, of the fastest run by CPU time */
	struct bc_render_stats st;
};

/* Fastest of reps renders by process CPU time: on a machine shared with
 * other work, wall time mostly measures the neighbours, while CPU time of
 * this process (all its threads) measures the renderer. */
static struct timing time_render(enum bc_backend b,
                                 const struct bc_render_opts *o,
                                 const struct bc_tree *t,
                                 const struct bc_camera *cam,
                                 struct bc_frame *f, int reps)
{
	struct timing best = {.cpu = INFINITY, .wall = INFINITY};
	for (int i = 0; i < reps; i++) {
		struct bc_errinfo ei = {0};
		struct bc_render_stats s;
		double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		double w0 = clock_ms(CLOCK_MONOTONIC), cpu;
		if (bc_render_once(b, o, t, cam, f, &s, &ei)) {
			fprintf(stderr, "render failed: %s\n", ei.msg);
			exit(1);
		}
		cpu = clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
		if (cpu < best.cpu) {
			best.cpu = cpu;
			best.wall = clock_ms(CLOCK_MONOTONIC) - w0;
			best.st = s;
		}
	}
	return best;
}

/* The camera whose w x rows frame holds exactly the central rows of the
 * w x h frame of cam: same eye and axes, vertical extent cut. */
static struct bc_camera band_camera(const struct bc_camera *cam, uint32_t h,
                                    uint32_t rows)
{
	struct bc_camera c = *cam;
	double half = (double)cam->fov_y_deg * 3.14159265358979 / 360.0;
	double t = tan(half) * (double)rows / (double)h;
	c.fov_y_deg = (float)(atan(t) * 360.0 / 3.14159265358979);
	return c;
}

static uint32_t hits(const struct bc_frame *f)
{
	uint32_t n = 0;
	for (size_t i = 0; i < (size_t)f->width * f->height; i++) {
		n += f->ids[i] != 0;
	}
	return n;
}

/* ---- --frames: cold and warm frames ------------------------------------- */

/* One configuration's samples: cold and warm frames, wall and CPU time,
 * and the cold frames' A-buffer wall time (ms), one per round. */
struct samples {
	double *cold_w, *cold_c, *cold_ab, *warm_w, *warm_c;
};

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

/* The median of n values (sorts them). */
static double median(double *v, int n)
{
	qsort(v, (size_t)n, sizeof(*v), cmp_double);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The CPU's model name (first "model name" of /proc/cpuinfo). */
static void cpu_model(char *out, size_t cap)
{
	FILE *f = fopen("/proc/cpuinfo", "r");
	char line[512];
	snprintf(out, cap, "unknown");
	if (!f) {
		return;
	}
	while (fgets(line, sizeof(line), f)) {
		char *colon = strchr(line, ':');
		if (strncmp(line, "model name", 10) == 0 && colon) {
			colon += 1 + (colon[1] == ' ');
			colon[strcspn(colon, "\n")] = '\0';
			snprintf(out, cap, "%s", colon);
			break;
		}
	}
	fclose(f);
}

/* The three load averages of /proc/loadavg, or "unknown". */
static void load_avg(char *out, size_t cap)
{
	FILE *f = fopen("/proc/loadavg", "r");
	double l[3];
	if (f && fscanf(f, "%lf %lf %lf", &l[0], &l[1], &l[2]) == 3) {
		snprintf(out, cap, "%.2f %.2f %.2f", l[0], l[1], l[2]);
	} else {
		snprintf(out, cap, "unknown");
	}
	if (f) {
		fclose(f);
	}
}

/* One frame of r into f: wall and process CPU time (ms) into w and c,
 * the A-buffer's wall time into ab. A cold frame first syncs the tree as
 * a structural change, which drops every kept tile list: the frame then
 * builds them again, as after a new view, in the buffers already there. */
static void frame_timed(struct bc_renderer *r, const struct bc_tree *t,
                        bool cold, const struct bc_camera *cam,
                        struct bc_frame *f, double *w, double *c, double *ab)
{
	struct bc_errinfo ei = {0};
	struct bc_render_stats st;
	double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
	double w0 = clock_ms(CLOCK_MONOTONIC);
	if ((cold && bc_renderer_sync(r, t, NULL, &ei)) ||
	    bc_renderer_render(r, cam, f, &st, &ei)) {
		fprintf(stderr, "bench_render: render failed: %s\n", ei.msg);
		exit(1);
	}
	*c = clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
	*w = clock_ms(CLOCK_MONOTONIC) - w0;
	if (ab) {
		*ab = st.ms_abuffer;
	}
}

/* Pixels whose colour, depth or primitive differ between a and b. */
static uint64_t frame_diff(const struct bc_frame *a, const struct bc_frame *b)
{
	uint64_t n = 0;
	for (size_t i = 0; i < (size_t)a->width * a->height; i++) {
		n += memcmp(a->rgba + 4 * i, b->rgba + 4 * i, 4) != 0 ||
		     memcmp(&a->depth[i], &b->depth[i], sizeof(float)) != 0 ||
		     a->ids[i] != b->ids[i];
	}
	return n;
}

/*
 * For each scene, one tiled renderer per configuration (simd off and auto,
 * 1 and 2 threads) is created and synced and draws one untimed frame (the
 * buffers' allocation, the pool's threads). Then `reps` rounds; in each,
 * the configurations take turns, each drawing a cold frame (a structural
 * sync first: every tile list is built again, in the kept buffers, as on
 * a new view of the daemon's renderer) and then `warm` frames of the same
 * view, the fastest of which counts for the round. The table gives the
 * median over the rounds of wall and process CPU time (CPU time sums the
 * threads), and the cold frame's A-buffer wall time (rays, cones and
 * lists; the rest is tracing). Ratios are of medians of the same run:
 * vector = off / auto at one thread, by CPU time; threads = 1 thread / 2
 * threads by wall time, with the second thread's extra CPU time
 * (cpu 2 / cpu 1) beside it. `same` checks that 1 and 2 threads drew the
 * same pixels, bit for bit, and that the cold frame equals the warm one.
 */
/* Frees a scene's renderers and frames (one per configuration), the
 * cold frame kept and the tree. */
static void scene_finish(struct bc_renderer **r, struct bc_frame *f,
                         struct bc_frame *cold, struct bc_tree *t)
{
	for (int c = 0; c < CONF_COUNT; c++) {
		bc_renderer_destroy(r[c]);
		bc_frame_finish(&f[c]);
	}
	bc_frame_finish(cold);
	bc_tree_destroy(t);
}

/* --frames --loop: n warm frames of scene s's vector path, one thread
 * (CONF_AUTO1's renderer r, its view drawn once), by process CPU time:
 * what a profiler samples (`perf record`) and a change's before and
 * after compares. */
static void warm_loop(const char *label, struct bc_renderer *r,
                      const struct bc_tree *t, const struct bc_camera *cam,
                      struct bc_frame *f, uint32_t n)
{
	double sum = 0.0;
	for (uint32_t k = 0; k < n; k++) {
		double w, cpu;
		frame_timed(r, t, false, cam, f, &w, &cpu, NULL);
		sum += cpu;
	}
	printf("%-26s %s: %u warm frames, %.1f ms of CPU (%.2f ms a frame)\n",
	       label, confs[CONF_AUTO1].name, n, sum, sum / (double)n);
}

static int frames_main(uint32_t size, int reps, bool quick, const char *only,
                       uint32_t loop)
{
	const int warm = 3;
	char model[256], load[64];
	struct samples sm[CONF_COUNT];
	cpu_model(model, sizeof(model));
	load_avg(load, sizeof(load));
	for (int c = 0; c < CONF_COUNT; c++) {
		double **v[5] = {&sm[c].cold_w, &sm[c].cold_c, &sm[c].cold_ab,
		                 &sm[c].warm_w, &sm[c].warm_c};
		for (int i = 0; i < 5; i++) {
			if (!(*v[i] = calloc((size_t)reps, sizeof(double)))) {
				fprintf(stderr,
				        "bench_render: out of memory\n");
				return 1;
			}
		}
	}
	printf("tiled, frame %ux%u; CPU: %s, %ld online; load average at "
	       "start: %s\n",
	       size, size, model, sysconf(_SC_NPROCESSORS_ONLN), load);
	printf("median of %d rounds (configurations interleaved); cold = "
	       "new view, tile lists built; warm = fastest of %d frames of "
	       "the same view; wall / cpu = wall clock / process CPU time "
	       "(ms); abuf = cold A-buffer wall time\n\n",
	       reps, warm);
	printf("%-26s %6s %-6s | %8s %8s %7s | %8s %8s\n", "scene", "prims",
	       "conf", "cold", "cpu", "abuf", "warm", "cpu");
	for (size_t s = 0; s < sizeof(scenes) / sizeof(scenes[0]); s++) {
		struct bc_tree *t;
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct bc_renderer *r[CONF_COUNT] = {0};
		struct bc_frame f[CONF_COUNT] = {{0}}, cold = {0};
		double med[CONF_COUNT][5];
		uint64_t diff_thr = 0, diff_cold = 0;
		if (!scenes[s].frames || (quick && scenes[s].frames < 2) ||
		    (only && !strstr(scenes[s].label, only))) {
			continue;
		}
		t = bc_tree_create();
		if (!t ||
		    bc_gen(scenes[s].gen, &scenes[s].opts, t, &cam, &ei)) {
			fprintf(stderr, "bench_render: %s: %s\n",
			        scenes[s].label, t ? ei.msg : "out of memory");
			return 1;
		}
		if (bc_frame_init(&cold, size, size)) {
			fprintf(stderr, "bench_render: out of memory\n");
			return 1;
		}
		for (int c = 0; c < CONF_COUNT; c++) {
			struct bc_render_opts o = {.threads = confs[c].threads,
			                           .simd = confs[c].simd};
			double w, cpu;
			if (bc_frame_init(&f[c], size, size)) {
				fprintf(stderr,
				        "bench_render: out of memory\n");
				return 1;
			}
			if (bc_renderer_create(&r[c], BC_BACKEND_TILED, &o,
			                       &ei) ||
			    bc_renderer_sync(r[c], t, NULL, &ei)) {
				fprintf(stderr, "bench_render: %s: %s\n",
				        confs[c].name, ei.msg);
				return 1;
			}
			frame_timed(r[c], t, false, &cam, &f[c], &w, &cpu,
			            NULL);
		}
		if (loop) {
			warm_loop(scenes[s].label, r[CONF_AUTO1], t, &cam,
			          &f[CONF_AUTO1], loop);
			scene_finish(r, f, &cold, t);
			continue; /* no table */
		}
		for (int i = 0; i < reps; i++) {
			for (int c = 0; c < CONF_COUNT; c++) {
				struct samples *p = &sm[c];
				frame_timed(r[c], t, true, &cam, &f[c],
				            &p->cold_w[i], &p->cold_c[i],
				            &p->cold_ab[i]);
				if (i == 0 && c == CONF_AUTO1) {
					memcpy(cold.rgba, f[c].rgba,
					       (size_t)size * size * 4);
					memcpy(cold.depth, f[c].depth,
					       (size_t)size * size *
					           sizeof(float));
					memcpy(cold.ids, f[c].ids,
					       (size_t)size * size *
					           sizeof(uint32_t));
				}
				p->warm_w[i] = p->warm_c[i] = INFINITY;
				for (int k = 0; k < warm; k++) {
					double w, cpu;
					frame_timed(r[c], t, false, &cam, &f[c],
					            &w, &cpu, NULL);
					if (w < p->warm_w[i]) {
						p->warm_w[i] = w;
						p->warm_c[i] = cpu;
					}
				}
			}
		}
		diff_thr = frame_diff(&f[CONF_OFF1], &f[CONF_OFF2]) +
		           frame_diff(&f[CONF_AUTO1], &f[CONF_AUTO2]);
		diff_cold = frame_diff(&cold, &f[CONF_AUTO1]);
		for (int c = 0; c < CONF_COUNT; c++) {
			struct samples *p = &sm[c];
			med[c][0] = median(p->cold_w, reps);
			med[c][1] = median(p->cold_c, reps);
			med[c][2] = median(p->cold_ab, reps);
			med[c][3] = median(p->warm_w, reps);
			med[c][4] = median(p->warm_c, reps);
			printf("%-26s %6u %-6s | %8.1f %8.1f %7.1f | %8.1f "
			       "%8.1f\n",
			       c == 0 ? scenes[s].label : "",
			       bc_tree_prim_count(t), confs[c].name, med[c][0],
			       med[c][1], med[c][2], med[c][3], med[c][4]);
		}
		printf("%-26s vector (off/auto, 1 thread, cpu): cold %.2fx, "
		       "warm %.2fx\n",
		       "", med[CONF_OFF1][1] / med[CONF_AUTO1][1],
		       med[CONF_OFF1][4] / med[CONF_AUTO1][4]);
		for (int c = CONF_OFF1; c <= CONF_AUTO1; c++) {
			int c2 = c == CONF_OFF1 ? CONF_OFF2 : CONF_AUTO2;
			printf("%-26s 2 threads (%s, wall 1/2): cold %.2fx, "
			       "warm %.2fx; cpu 2/1: cold %.2f, warm %.2f\n",
			       "",
			       confs[c].simd == BC_SIMD_OFF ? "off" : "auto",
			       med[c][0] / med[c2][0], med[c][3] / med[c2][3],
			       med[c2][1] / med[c][1], med[c2][4] / med[c][4]);
		}
		printf("%-26s same pixels: 1 and 2 threads %s, cold and warm "
		       "%s\n",
		       "", diff_thr ? "DIFFER" : "yes",
		       diff_cold ? "DIFFER" : "yes");
		fflush(stdout);
		scene_finish(r, f, &cold, t);
		if (diff_thr || diff_cold) {
			fprintf(stderr, "bench_render: %s: frames differ\n",
			        scenes[s].label);
			return 1;
		}
	}
	load_avg(load, sizeof(load));
	printf("\nload average at the end: %s\n", load);
	for (int c = 0; c < CONF_COUNT; c++) {
		free(sm[c].cold_w);
		free(sm[c].cold_c);
		free(sm[c].cold_ab);
		free(sm[c].warm_w);
		free(sm[c].warm_c);
	}
	return 0;
}

/*
 * --big: the scenes of a million primitives the scale goal names -- fig18
 * with 1 000 000 smooth spheres and Fig. 16's level 6 (1 111 110
 * primitives) -- at size x size (1024 by default here), the vector path
 * with one and two threads: the cold frame (tile lists built) and the
 * fastest of two warm frames, wall and process CPU time, per round, and
 * the time the generator and the layout took.
 */
static int big_main(uint32_t size, int reps)
{
	static const struct scene big[] = {
	    {"fig18 smooth spheres 1M",
	     "fig18",
	     {.count = 1000000,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     0,
	     1},
	    {"fig16 L6 smooth",
	     "fig16",
	     {.level = 6, .blend = BC_GEN_BLEND_SMOOTH},
	     0,
	     1},
	};
	static const int use[2] = {CONF_AUTO1, CONF_AUTO2};
	char model[256], load[64];
	cpu_model(model, sizeof(model));
	load_avg(load, sizeof(load));
	printf("tiled, vector path, frame %ux%u; CPU: %s, %ld online; load "
	       "average at start: %s\n",
	       size, size, model, sysconf(_SC_NPROCESSORS_ONLN), load);
	printf("%-24s %8s %7s %-6s %5s | %8s %8s %7s | %8s %8s\n", "scene",
	       "prims", "gen", "conf", "round", "cold", "cpu", "abuf", "warm",
	       "cpu");
	for (size_t s = 0; s < sizeof(big) / sizeof(big[0]); s++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct bc_renderer *r[2] = {0};
		struct bc_frame f = {0};
		double g0 = clock_ms(CLOCK_MONOTONIC), gen;
		if (!t || bc_gen(big[s].gen, &big[s].opts, t, &cam, &ei) ||
		    bc_frame_init(&f, size, size)) {
			fprintf(stderr, "bench_render: %s: %s\n", big[s].label,
			        t ? ei.msg : "out of memory");
			return 1;
		}
		gen = clock_ms(CLOCK_MONOTONIC) - g0;
		for (int c = 0; c < 2; c++) {
			struct bc_render_opts o = {.threads =
			                               confs[use[c]].threads,
			                           .simd = confs[use[c]].simd};
			if (bc_renderer_create(&r[c], BC_BACKEND_TILED, &o,
			                       &ei) ||
			    bc_renderer_sync(r[c], t, NULL, &ei)) {
				fprintf(stderr, "bench_render: %s\n", ei.msg);
				return 1;
			}
		}
		for (int i = 0; i < reps; i++) {
			for (int c = 0; c < 2; c++) {
				double cw, cc, ab, ww = INFINITY, wc = 0.0;
				frame_timed(r[c], t, true, &cam, &f, &cw, &cc,
				            &ab);
				for (int k = 0; k < 2; k++) {
					double w, cpu;
					frame_timed(r[c], t, false, &cam, &f,
					            &w, &cpu, NULL);
					if (w < ww) {
						ww = w;
						wc = cpu;
					}
				}
				printf("%-24s %8u %7.0f %-6s %5d | %8.1f %8.1f "
				       "%7.1f | %8.1f %8.1f\n",
				       big[s].label, bc_tree_prim_count(t), gen,
				       confs[use[c]].name, i + 1, cw, cc, ab,
				       ww, wc);
				fflush(stdout);
			}
		}
		bc_renderer_destroy(r[0]);
		bc_renderer_destroy(r[1]);
		bc_frame_finish(&f);
		bc_tree_destroy(t);
	}
	load_avg(load, sizeof(load));
	printf("load average at the end: %s\n", load);
	return 0;
}

int main(int argc, char **argv)
{
	size_t nscenes = sizeof(scenes) / sizeof(scenes[0]);
	uint32_t size = 512;
	int reps = 3;
	struct bc_render_opts opts = {.threads = 1};
	double tiled256 = 0.0, tiled4096 = 0.0;
	uint32_t nreps = 3;
	bool quick = false, frames = false, big = false;
	const char *only = NULL;
	uint32_t loop = 0;
	const struct bc_opt opts_table[] = {
	    {.name = "size",
	     .kind = BC_OPT_U32,
	     .dst = &size,
	     .lo = 64,
	     .hi = BC_RENDER_MAX_DIM,
	     .arg = "N",
	     .help = "square frame side, {range} (default {default})"},
	    {.name = "threads",
	     .kind = BC_OPT_U32,
	     .dst = &opts.threads,
	     .hi = 1024,
	     .arg = "T",
	     .help = "CPU threads, 0 = one per core (default {default})"},
	    {.name = "reps",
	     .kind = BC_OPT_U32,
	     .dst = &nreps,
	     .lo = 1,
	     .hi = 1000,
	     .arg = "R",
	     .help = "tiled runs per scene, the best kept; --frames: "
	             "rounds, the median kept (default {default})"},
	    {.name = "quick",
	     .kind = BC_OPT_FLAG,
	     .dst = &quick,
	     .help = "the first three scenes only (--frames: four of "
	             "them)"},
	    {.name = "frames",
	     .kind = BC_OPT_FLAG,
	     .dst = &frames,
	     .help = "cold and warm frames of tiled, simd off and auto, 1 "
	             "and 2 threads (the median of R rounds)"},
	    {.name = "scene",
	     .kind = BC_OPT_STRING,
	     .dst = &only,
	     .arg = "TEXT",
	     .help = "--frames: only the scenes whose name holds TEXT "
	             "(\"gears\", \"4096\")"},
	    {.name = "loop",
	     .kind = BC_OPT_U32,
	     .dst = &loop,
	     .hi = 100000,
	     .arg = "N",
	     .help = "--frames: instead of the table, N warm frames of "
	             "each scene's vector path, one thread, and their CPU "
	             "time (for a profiler; default 0: the table)"},
	    {.name = "big",
	     .kind = BC_OPT_FLAG,
	     .dst = &big,
	     .help = "cold and warm frames of fig18 with 1 000 000 spheres "
	             "and fig16 level 6, vector path, 1 and 2 threads "
	             "(--size defaults to 1024 here)"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args args = {.prog = "bench_render",
	                       .usage = "bench_render [options]",
	                       .opts = opts_table};
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (args.npos) {
		return bc_args_error(&args, "unexpected argument '%s'",
		                     args.pos[0]);
	}
	reps = (int)nreps;
	if (big) {
		return big_main(bc_args_given(&args, "size") ? size : 1024,
		                reps);
	}
	if (frames) {
		return frames_main(size, reps, quick, only, loop);
	}
	if (quick) {
		nscenes = 3;
	}
	printf("frame %ux%u, %u thread(s), best of %d tiled / 1 naive run by "
	       "process CPU time (ms); naive and the speedup on the central "
	       "band of `band` rows; (wall), abuf-w and trace-w are wall "
	       "clock of the same run\n\n",
	       size, size, opts.threads, reps);
	printf("%-26s %6s %5s | %8s %8s %7s %7s %6s | %4s %8s %9s %8s\n",
	       "scene", "prims", "hit%", "tiled", "(wall)", "abuf-w", "trace-w",
	       "maxovl", "band", "tiled", "naive", "speedup");
	for (size_t s = 0; s < nscenes; s++) {
		struct bc_tree *t;
		struct bc_camera cam, bcam;
		struct bc_errinfo ei = {0};
		struct bc_frame full = {0}, band = {0};
		struct timing tiled, tiled_band, naive_band;
		uint32_t rows = scenes[s].band * size / 512;
		if (!scenes[s].band) {
			continue; /* not in this table */
		}
		rows = rows < 2 ? 2 : rows;
		t = bc_tree_create();
		if (!t ||
		    bc_gen(scenes[s].gen, &scenes[s].opts, t, &cam, &ei)) {
			fprintf(stderr, "%s: %s\n", scenes[s].label, ei.msg);
			return 1;
		}
		if (bc_frame_init(&full, size, size) ||
		    bc_frame_init(&band, size, rows)) {
			fprintf(stderr, "out of memory\n");
			return 1;
		}
		bcam = band_camera(&cam, size, rows);
		tiled =
		    time_render(BC_BACKEND_TILED, &opts, t, &cam, &full, reps);
		tiled_band =
		    time_render(BC_BACKEND_TILED, &opts, t, &bcam, &band, reps);
		naive_band =
		    time_render(BC_BACKEND_NAIVE, &opts, t, &bcam, &band, 1);
		printf("%-26s %6u %4.1f%% | %8.1f %8.1f %7.1f %7.1f %6u | %4u "
		       "%8.1f %9.1f %7.1fx\n",
		       scenes[s].label, bc_tree_prim_count(t),
		       100.0 * hits(&full) / ((double)size * size), tiled.cpu,
		       tiled.wall, tiled.st.ms_abuffer, tiled.st.ms_trace,
		       tiled.st.max_overlap, rows, tiled_band.cpu,
		       naive_band.cpu, naive_band.cpu / tiled_band.cpu);
		printf(
		    "%-26s   naive full frame estimated %.0f ms (band x "
		    "%u/%u); field evaluations per pixel: naive %.1f (band), "
		    "tiled %.1f\n",
		    "", naive_band.cpu * size / rows, size, rows,
		    (double)naive_band.st.field_evals / ((double)size * rows),
		    (double)tiled.st.field_evals / ((double)size * size));
		if (bc_tree_prim_count(t) <= 16) {
			/* Small enough to check the band estimate against a
			 * whole naive frame, and the speedup with it. */
			struct timing nf = time_render(BC_BACKEND_NAIVE, &opts,
			                               t, &cam, &full, 1);
			printf("%-26s   naive full frame measured %.0f ms: "
			       "full-frame speedup %.1fx\n",
			       "", nf.cpu, nf.cpu / tiled.cpu);
		}
		if (s == 0) {
			tiled256 = tiled.cpu;
		}
		if (s == 2) {
			tiled4096 = tiled.cpu;
		}
		fflush(stdout);
		bc_frame_finish(&full);
		bc_frame_finish(&band);
		bc_tree_destroy(t);
	}
	if (tiled256 > 0.0 && tiled4096 > 0.0) {
		printf(
		    "\ntiled growth, fig18 smooth spheres 256 -> 4096: %.2fx "
		    "(%.1f -> %.1f ms CPU)\n",
		    tiled4096 / tiled256, tiled256, tiled4096);
	}
	return 0;
}
