/*
 * What the backends share besides shading (blobcast/shade.h): one
 * process-wide pool of worker threads (CPU backends), the scene scale
 * that frame constants derive from, and the pacing of progress reports.
 * Only the render modules include this.
 */
#ifndef BLOBCAST_RENDER_COMMON_H
#define BLOBCAST_RENDER_COMMON_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/render.h"

/* Worker threads at most, whatever a renderer's opts.threads asks. */
#define BC_POOL_MAX_THREADS 64u

/* One share of a parallel run: fn(ctx, thread) for thread in [0, n). */
typedef void (*bc_pool_fn)(void *ctx, uint32_t thread);

/* Runs fn(ctx, i) for i in [0, n) concurrently and returns when all are
 * done; i = 0 runs on the calling thread, the others on the pool's
 * workers, which are started once and kept. Work is handed out by the
 * functions themselves (atomic counters), so a worker that cannot be
 * started only costs speed: its share runs on the calling thread. Runs
 * from several threads at once are serialized. n is clamped to
 * [1, BC_POOL_MAX_THREADS]. */
void bc_pool_run(uint32_t n, bc_pool_fn fn, void *ctx);

/* The threads a renderer uses for opts.threads == 0: one per online
 * core, at least 1, at most BC_POOL_MAX_THREADS. */
uint32_t bc_pool_default_threads(void);

/* The scene scale that frame constants (minimal steps, tolerances) derive
 * from: the scene's AABB diagonal rounded up to a power of two, so that
 * parameter edits that move the scene's bounds a little keep every pixel's
 * computation as it was (damage renders stay exact); 1 for an empty or
 * degenerate tree. */
float bc_render_scale(const struct bc_lin *lin);

/* The key hook (render_backend.h) of the backends whose frame constants
 * derive from the scene's scale above and the tree's Lipschitz bound,
 * which divides every step (a parameter edit under a twist or bend that
 * changes it changes every pixel): both, bit for bit. */
uint64_t bc_render_scale_key(struct bc_renderer *r, const struct bc_camera *cam,
                             uint32_t width, uint32_t height);

/* Narrows [*t0, *t1] to the parameters t at which o + t d is inside the
 * box [lo, hi] (slabs; on an axis the ray runs parallel to, all of them
 * or none). Returns whether any is left; on a parallel axis that misses,
 * false with *t0, *t1 as they were. The comparisons are plain (no NaN
 * handling): box and ray are finite. */
static inline bool bc_ray_box_clip(const float lo[3], const float hi[3],
                                   const float o[3], const float d[3],
                                   float *t0, float *t1)
{
	float a = *t0, b = *t1;
	for (int i = 0; i < 3; i++) {
		if (d[i] != 0.0f) {
			float inv = 1.0f / d[i];
			float ta = (lo[i] - o[i]) * inv,
			      tb = (hi[i] - o[i]) * inv;
			if (ta > tb) {
				float s = ta;
				ta = tb;
				tb = s;
			}
			a = a > ta ? a : ta;
			b = b < tb ? b : tb;
		} else if (o[i] < lo[i] || o[i] > hi[i]) {
			return false;
		}
	}
	*t0 = a;
	*t1 = b;
	return a <= b;
}

/* One call's progress reports (bc_renderer_set_progress): init with the
 * renderer and the call's work items, then tick with the items done;
 * ticks report at most every 250 ms, and none in the call's first
 * second. Ticks come from one thread. */
struct bc_render_progress {
	bc_render_progress_fn fn;
	void *user;
	uint32_t total;
	double start, last;
};
void bc_render_progress_init(struct bc_render_progress *p,
                             const struct bc_renderer *r, uint32_t total);
void bc_render_progress_tick(struct bc_render_progress *p, uint32_t done);

#endif
