/*
 * gl backend benchmark: `gl` (OpenGL compute, here on whatever driver the
 * context gets: llvmpipe on a CPU-only host) against the CPU `tiled`
 * renderer, side by side in one run, at 512x512 on the paper's synthetic
 * scenes; and the cost of keeping the GPU copy of the tree current: a
 * parameter edit (the edited records only) against a full upload, as the
 * tree grows.
 *
 * Each frame is timed by wall clock and by process CPU time (which counts
 * llvmpipe's worker threads as well as the tiled renderer's). The gl
 * backend draws one frame first, untimed, so that shader compilation and
 * buffer allocation are not counted; both then report the fastest of
 * `reps` frames. The gl split (A-buffer, tracing) comes from GPU timer
 * queries; `disp` is the number of tracing dispatches the frame needed
 * (llvmpipe's loop limit makes dense tiles suspend and resume); `gl L3` is
 * the coarsest refinement level alone (one ray per 8x8 tile, the first
 * picture a progressive client gets).
 *
 * Usage: bench_gl [--size N] [--reps R] [--platform P] [--quick]
 *   --size N      frame edge (default 512)
 *   --reps R      frames per measurement, the fastest is kept (3)
 *   --platform P  auto | device | surfaceless | osmesa (auto)
 *   --quick       the first two scenes and the smallest edit sizes only
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

#if defined(__has_include)
#if __has_include("blobcast/render_gl.h")
#include "blobcast/render_gl.h"
#define HAVE_GL 1
#endif
#endif

#if defined(HAVE_GL)

struct scene {
	const char *label;
	const char *gen;
	struct bc_gen_opts opts;
};

static const struct scene scenes[] = {
    {"fig18 smooth spheres 256",
     "fig18",
     {.count = 256, .kind = BC_GEN_KIND_SPHERES}},
    {"fig16 L2 smooth", "fig16", {.level = 2}},
    {"fig18 smooth boxes 256",
     "fig18",
     {.count = 256, .kind = BC_GEN_KIND_BOXES}},
    {"fig18 smooth spheres 1024",
     "fig18",
     {.count = 1024, .kind = BC_GEN_KIND_SPHERES}},
    {"fig16 L3 smooth", "fig16", {.level = 3}},
    {"gears (24 teeth)", "gears", {.teeth = 24}},
    {"many-spheres 2745", "many-spheres", {.count = 2745}},
};

static double clock_ms(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

struct timing {
	double wall, cpu; /* ms, of the fastest run by wall time */
	struct bc_render_stats st;
	int rc;
};

/* Fastest of reps frames of r (already synced): whole frames, or the
 * pixels of region when it is not NULL. */
static struct timing
time_frames(struct bc_renderer *r, const struct bc_camera *cam,
            struct bc_frame *f, const struct bc_render_region *region, int reps)
{
	struct timing best = {.wall = INFINITY, .cpu = INFINITY};
	for (int i = 0; i < reps; i++) {
		struct bc_errinfo ei = {0};
		struct bc_render_stats st;
		double w0 = clock_ms(CLOCK_MONOTONIC);
		double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		int rc = bc_renderer_render_region(r, cam, f, region, &st, &ei);
		double w1 = clock_ms(CLOCK_MONOTONIC);
		double c1 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		if (rc) {
			fprintf(stderr, "%s: %s\n",
			        bc_backend_name(bc_renderer_backend(r)),
			        ei.msg);
			best.rc = rc;
			return best;
		}
		if (w1 - w0 < best.wall) {
			best.wall = w1 - w0;
			best.cpu = c1 - c0;
			best.st = st;
		}
	}
	return best;
}

static struct bc_renderer *open_backend(enum bc_backend b,
                                        const struct bc_render_opts *o)
{
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, b, o, &ei)) {
		fprintf(stderr, "%s: %s\n", bc_backend_name(b), ei.msg);
		return NULL;
	}
	return r;
}

static int frames(const char *platform, uint32_t size, int reps, bool quick)
{
	/* The coarsest refinement level: one ray per tile. */
	const struct bc_render_region coarse = {.level = BC_RENDER_MAX_LEVEL};
	struct bc_render_opts go = {.gl_platform = platform};
	struct bc_render_opts to = {0};
	struct bc_renderer *rg, *rt;
	struct bc_frame f;
	struct bc_gl_info info;
	size_t n = quick ? 2 : sizeof(scenes) / sizeof(scenes[0]);
	if (!bc_backend_available(BC_BACKEND_GL) ||
	    !bc_backend_available(BC_BACKEND_TILED)) {
		fprintf(stderr, "bench_gl: gl or tiled backend not built in\n");
		return 1;
	}
	if (bc_frame_init(&f, size, size)) {
		return 1;
	}
	rg = open_backend(BC_BACKEND_GL, &go);
	rt = open_backend(BC_BACKEND_TILED, &to);
	if (!rg || !rt) {
		bc_renderer_destroy(rg);
		bc_renderer_destroy(rt);
		bc_frame_finish(&f);
		return 1;
	}
	bc_render_gl_info(rg, &info);
	printf("gl: %s platform, %s, %s\n", bc_gl_platform_name(info.platform),
	       info.renderer, info.version);
	printf("frame %ux%u, fastest of %d; tiled on every core; ms; gl L3: "
	       "refinement level 3 (one ray per tile)\n\n",
	       size, size, reps);
	printf("%-26s %6s | %8s %8s %7s %7s | %8s %8s %7s %7s %4s %7s | %7s "
	       "%7s\n",
	       "scene", "prims", "tiled", "cpu", "abuf", "trace", "gl", "cpu",
	       "abuf", "trace", "disp", "gl L3", "gl/tld", "cpu");
	for (size_t s = 0; s < n; s++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct timing tt, tg, tc;
		if (!t ||
		    bc_gen(scenes[s].gen, &scenes[s].opts, t, &cam, &ei)) {
			fprintf(stderr, "%s: %s\n", scenes[s].label, ei.msg);
			bc_tree_destroy(t);
			continue;
		}
		if (bc_renderer_sync(rt, t, NULL, &ei) ||
		    bc_renderer_sync(rg, t, NULL, &ei)) {
			fprintf(stderr, "%s: %s\n", scenes[s].label, ei.msg);
			bc_tree_destroy(t);
			continue;
		}
		/* Warm-up: compilation, allocation, caches. */
		(void)time_frames(rg, &cam, &f, NULL, 1);
		tg = time_frames(rg, &cam, &f, NULL, reps);
		bc_render_gl_info(rg, &info);
		tc = time_frames(rg, &cam, &f, &coarse, reps);
		tt = time_frames(rt, &cam, &f, NULL, reps);
		if (tg.rc == 0 && tt.rc == 0 && tc.rc == 0) {
			printf("%-26s %6u | %8.1f %8.1f %7.1f %7.1f | %8.1f "
			       "%8.1f %7.1f %7.1f %4u %7.1f | %6.2fx %6.2fx\n",
			       scenes[s].label, bc_tree_prim_count(t), tt.wall,
			       tt.cpu, tt.st.ms_abuffer, tt.st.ms_trace,
			       tg.wall, tg.cpu, tg.st.ms_abuffer,
			       tg.st.ms_trace, info.dispatches, tc.wall,
			       tg.wall / tt.wall, tg.cpu / tt.cpu);
		}
		bc_tree_destroy(t);
	}
	bc_renderer_destroy(rg);
	bc_renderer_destroy(rt);
	bc_frame_finish(&f);
	return 0;
}

/* Parameter edits against full uploads, as the tree grows. */
static int edits(const char *platform, bool quick)
{
	static const uint32_t counts[] = {256, 4096, 65536, 262144};
	struct bc_render_opts go = {.gl_platform = platform};
	struct bc_renderer *r = open_backend(BC_BACKEND_GL, &go);
	size_t n = quick ? 2 : sizeof(counts) / sizeof(counts[0]);
	if (!r) {
		return 1;
	}
	printf("\nkeeping the GPU tree current (fig18 spheres; mean of 200 "
	       "edits; ms and bytes per sync)\n");
	printf("%8s | %10s %10s %9s | %10s %12s\n", "prims", "edit+sync",
	       "bytes", "full", "full bytes", "full/edit");
	for (size_t c = 0; c < n; c++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_gen_opts o = {.count = counts[c],
		                        .kind = BC_GEN_KIND_SPHERES};
		struct bc_errinfo ei = {0};
		struct bc_dirty dirty;
		struct bc_gl_info info;
		double t0, edit_ms, full_ms;
		uint64_t edit_bytes, full_bytes;
		const int rounds = 200;
		if (!t || bc_gen("fig18", &o, t, NULL, &ei)) {
			fprintf(stderr, "fig18 %u: %s\n", counts[c], ei.msg);
			bc_tree_destroy(t);
			continue;
		}
		bc_tree_take_dirty(t, &dirty);
		t0 = clock_ms(CLOCK_MONOTONIC);
		if (bc_renderer_sync(r, t, NULL, &ei)) {
			fprintf(stderr, "sync: %s\n", ei.msg);
			bc_tree_destroy(t);
			break;
		}
		full_ms = clock_ms(CLOCK_MONOTONIC) - t0;
		bc_render_gl_info(r, &info);
		full_bytes = info.upload_bytes;
		edit_bytes = 0;
		t0 = clock_ms(CLOCK_MONOTONIC);
		for (int i = 0; i < rounds; i++) {
			/* A different primitive each time, moved a little. */
			const struct bc_lin *l = bc_tree_lin(t);
			uint32_t k =
			    (uint32_t)(((uint64_t)i * 2654435761u) % l->nprims);
			uint32_t id = l->node_id[l->prim_slot[k]];
			struct bc_prim_data p;
			bc_tree_get(t, id, &p, NULL);
			p.translate[0] += 0.001f;
			if (bc_tree_set_prim(t, id, &p, &ei)) {
				fprintf(stderr, "edit: %s\n", ei.msg);
				break;
			}
			bc_tree_take_dirty(t, &dirty);
			if (bc_renderer_sync(r, t, &dirty, &ei)) {
				fprintf(stderr, "sync: %s\n", ei.msg);
				break;
			}
			bc_render_gl_info(r, &info);
			edit_bytes += info.upload_bytes;
		}
		edit_ms = (clock_ms(CLOCK_MONOTONIC) - t0) / rounds;
		printf("%8u | %10.4f %10.0f %9.2f | %10llu %11.0fx\n",
		       counts[c], edit_ms, (double)edit_bytes / rounds, full_ms,
		       (unsigned long long)full_bytes, full_ms / edit_ms);
		bc_tree_destroy(t);
	}
	bc_renderer_destroy(r);
	return 0;
}

int main(int argc, char **argv)
{
	uint32_t size = 512, reps = 3;
	bool quick = false;
	const char *platform = NULL;
	const struct bc_opt opts[] = {
	    {.name = "size",
	     .kind = BC_OPT_U32,
	     .dst = &size,
	     .lo = 1,
	     .hi = BC_RENDER_MAX_DIM,
	     .arg = "N",
	     .help = "square frame side, {range} (default {default})"},
	    {.name = "reps",
	     .kind = BC_OPT_U32,
	     .dst = &reps,
	     .lo = 1,
	     .hi = 1000,
	     .arg = "R",
	     .help = "runs per measurement, the best kept (default "
	             "{default})"},
	    {.name = "platform",
	     .kind = BC_OPT_STRING,
	     .dst = &platform,
	     .arg = "P",
	     .help = "GL platform: auto | device | surfaceless | osmesa\n"
	             "(default auto)"},
	    {.name = "quick",
	     .kind = BC_OPT_FLAG,
	     .dst = &quick,
	     .help = "the first two scenes and the smallest edit\n"
	             "sizes only"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args args = {
	    .prog = "bench_gl", .usage = "bench_gl [options]", .opts = opts};
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (args.npos) {
		return bc_args_error(&args, "unexpected argument '%s'",
		                     args.pos[0]);
	}
	if (frames(platform, size, (int)reps, quick)) {
		return 1;
	}
	return edits(platform, quick);
}

#else

int main(void)
{
	fprintf(stderr, "bench_gl: the gl backend is not built in\n");
	return 0;
}

#endif
