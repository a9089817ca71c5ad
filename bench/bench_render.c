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
 * Usage: bench_render [--size N] [--threads T] [--reps R] [--quick]
 *   --size N     frame edge (default 512)
 *   --threads T  threads for both backends (default 1: steadier on a
 *                shared machine; 0 = one per core; CPU time then sums
 *                the threads)
 *   --reps R     tiled runs per measurement, the fastest is kept (3)
 *   --quick      only the first three scenes
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"

struct scene {
	const char *label;
	const char *gen;
	struct bc_gen_opts opts;
	uint32_t band; /* rows of the naive band */
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

int main(int argc, char **argv)
{
	struct scene scenes[] = {
	    {"fig18 smooth spheres 256",
	     "fig18",
	     {.count = 256,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     32},
	    {"fig18 smooth spheres 1024",
	     "fig18",
	     {.count = 1024,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     16},
	    {"fig18 smooth spheres 4096",
	     "fig18",
	     {.count = 4096,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH},
	     8},
	    {"fig16 L1 smooth",
	     "fig16",
	     {.level = 1, .blend = BC_GEN_BLEND_SMOOTH},
	     32},
	    {"fig16 L2 smooth",
	     "fig16",
	     {.level = 2, .blend = BC_GEN_BLEND_SMOOTH},
	     16},
	    {"fig16 L3 smooth",
	     "fig16",
	     {.level = 3, .blend = BC_GEN_BLEND_SMOOTH},
	     8},
	    {"fig16 L4 smooth",
	     "fig16",
	     {.level = 4, .blend = BC_GEN_BLEND_SMOOTH},
	     4},
	};
	size_t nscenes = sizeof(scenes) / sizeof(scenes[0]);
	uint32_t size = 512;
	int reps = 3;
	struct bc_render_opts opts = {.threads = 1};
	double tiled256 = 0.0, tiled4096 = 0.0;
	uint32_t nreps = 3;
	bool quick = false;
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
	     .help = "tiled runs per scene, the best kept (default "
	             "{default})"},
	    {.name = "quick",
	     .kind = BC_OPT_FLAG,
	     .dst = &quick,
	     .help = "the first three scenes only"},
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
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam, bcam;
		struct bc_errinfo ei = {0};
		struct bc_frame full = {0}, band = {0};
		struct timing tiled, tiled_band, naive_band;
		uint32_t rows = scenes[s].band * size / 512;
		rows = rows < 2 ? 2 : rows;
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
