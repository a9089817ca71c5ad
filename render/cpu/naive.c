/*
 * The naive CPU backend: every pixel's ray is clipped to the scene's AABB
 * and sphere traced in the full tree (bc_eval_full), with no acceleration
 * structure at all. It is the baseline the tiled backend is measured
 * against and the oracle the tests compare it with. Bands of a tile's
 * height are shared among the worker threads. Because each step sees every
 * primitive, an edit anywhere can change any pixel in the last bits: naive
 * has no local damage (the front marks every tile). A region's evaluation
 * bound stops a ray inside bc__trace, or before the five samples that
 * shade its hit; its pixel is left as it was.
 */
#include "cpu.h"

#include <math.h>
#include <stdatomic.h>

#include "blobcast/blobtree.h"
#include "blobcast/clock.h"

struct naive_frame {
	const struct bc__frame_ctx *fc;
	const struct bc_render_region *region;
	struct bc_render_progress progress;
	atomic_uint next_band;
	uint64_t evals[BC_CPU_MAX_THREADS];
	uint64_t rays[BC_CPU_MAX_THREADS];
	uint64_t short_rays[BC_CPU_MAX_THREADS];
};

/* Traces pixel (x, y) and writes it, unless the region's bound stops its
 * ray. Returns false for such a short ray. */
static bool naive_pixel(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                        uint64_t *evals)
{
	const struct bc_lin *lin = fc->lin;
	uint32_t overlaps = lin ? lin->nprims : 0;
	struct bc__field f = {lin, NULL, 0, fc->max_evals};
	enum bc__trace_result res = BC__TRACE_MISS;
	float d[3], t0 = 0.0f, t1 = INFINITY, t = 0.0f;
	bc_view_rays_dir(&fc->vr, (float)x + 0.5f, (float)y + 0.5f, d);
	if (lin && bc_ray_box_clip(lin->lo, lin->hi, fc->vr.eye, d, &t0, &t1)) {
		res = bc__trace(&f, fc, fc->vr.eye, d, t0, t1, &t);
	}
	/* Near the end of the scene's box counts: no surface lies beyond
	 * it. A hit takes five more samples to shade, within the bound. */
	if (res == BC__TRACE_SHORT ||
	    (res != BC__TRACE_MISS && !bc__field_can(&f, 5))) {
		*evals += f.evals;
		return false;
	}
	if (res != BC__TRACE_MISS) {
		bc__put_hit(fc, &f, x, y, d, t, overlaps);
	} else {
		bc__put_miss(fc, x, y, f.evals, overlaps);
	}
	*evals += f.evals;
	return true;
}

/* Rows are handed out a tile's height at a time, so that one thread owns
 * each tile's byte of short_tiles. */
static void naive_rows(void *arg, uint32_t thread)
{
	struct naive_frame *nf = arg;
	const struct bc__frame_ctx *fc = nf->fc;
	uint32_t w = fc->out->width, h = fc->out->height;
	uint64_t evals = 0, rays = 0, short_rays = 0;
	const struct bc_render_region *rg = nf->region;
	uint32_t tw = bc_render_tiles_x(w);
	for (;;) {
		uint32_t band = atomic_fetch_add(&nf->next_band, 1u);
		uint32_t y0 = band * BC_CPU_TILE;
		if (y0 >= h) {
			break;
		}
		for (uint32_t y = y0; y < y0 + BC_CPU_TILE && y < h; y++) {
			for (uint32_t x = 0; x < w; x++) {
				size_t tile =
				    (size_t)band * tw + x / BC_CPU_TILE;
				if ((rg->tiles && !rg->tiles[tile]) ||
				    !bc_render_level_has(x, y, rg->level,
				                         rg->refine)) {
					continue;
				}
				rays++;
				if (naive_pixel(fc, x, y, &evals)) {
					continue;
				}
				short_rays++;
				if (fc->short_tiles) {
					fc->short_tiles[tile] = 1;
				}
			}
		}
		if (thread == 0) {
			bc_render_progress_tick(
			    &nf->progress,
			    BC_CPU_TILE * atomic_load(&nf->next_band));
		}
	}
	nf->evals[thread] = evals;
	nf->rays[thread] = rays;
	nf->short_rays[thread] = short_rays;
}

static int naive_create(struct bc_renderer **out,
                        const struct bc_render_opts *opts,
                        struct bc_errinfo *ei)
{
	return bc__cpu_create(out, BC__CPU_NAIVE, opts, ei);
}

static int naive_render(struct bc_renderer *base, const struct bc_camera *cam,
                        struct bc_frame *out,
                        const struct bc_render_region *region,
                        struct bc_render_stats *stats, struct bc_errinfo *ei)
{
	struct bc__cpu *r = bc__cpu_of(base);
	struct bc__frame_ctx fc;
	struct naive_frame nf = {0};
	double t0 = bc_clock_ms();
	(void)ei;
	bc__frame_setup(&fc, bc_tree_lin(base->tree), cam, out,
	                base->opts.debug);
	fc.max_evals = region->max_evals;
	fc.short_tiles = region->short_tiles;
	nf.fc = &fc;
	nf.region = region;
	atomic_init(&nf.next_band, 0u);
	bc_render_progress_init(&nf.progress, &r->base, out->height);
	bc_pool_run(bc_render_region_threads(region, r->threads), naive_rows,
	            &nf);
	for (uint32_t i = 0; i < BC_CPU_MAX_THREADS; i++) {
		stats->field_evals += nf.evals[i];
		stats->rays += nf.rays[i];
		stats->short_rays += nf.short_rays[i];
	}
	stats->tiles =
	    bc_render_tiles_x(out->width) * bc_render_tiles_y(out->height);
	stats->max_overlap = fc.lin ? fc.lin->nprims : 0;
	stats->ms_trace = bc_clock_ms() - t0;
	stats->ms_total = stats->ms_trace;
	return 0;
}

const struct bc_backend_ops bc_backend_naive_ops = {
    .name = "naive",
    .create = naive_create,
    .destroy = bc__cpu_destroy,
    .render = naive_render,
    .key = bc_render_scale_key,
    /* No damage hook: a step of the full tree's sphere tracing is the
     * distance to the nearest surface, wherever it is, so every pixel
     * can depend on every primitive. */
};
