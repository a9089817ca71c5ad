/*
 * Between the tiled backend's A-buffer (tiled.c) and its tile tracer
 * (tile_trace.c): one tile's depth-sorted list of primitive fragments, the
 * per-thread scratch of the tracer, and the call that walks a tile's depth
 * ranges and traces the pixels asked of it.
 */
#ifndef BLOBCAST_RENDER_CPU_TILED_H
#define BLOBCAST_RENDER_CPU_TILED_H

#include <stdint.h>

#include "blobcast/alloc.h"
#include "cpu.h"

/* A primitive's depth interval over a tile's rays: min entry, max exit. */
struct bc__frag {
	float t0, t1;
	uint32_t prim;
};

/* One thread's scratch, reserved before a frame so tracing never
 * allocates. */
struct bc__tile_worker {
	struct bc_view view;
	uint32_t *act; /* active primitive indices, increasing */
	float *act_t1; /* their exits */
	uint32_t cap;  /* room in act and act_t1 */
	uint64_t evals;
	uint64_t short_rays;  /* rays that ran out of the frame's bound */
	uint32_t tiles_asked; /* tiles of the region this thread took */
	uint64_t rays;        /* their pixels asked */
	uint32_t overflows;
	/* The renderer's opts.simd, set before each frame (0: AUTO). */
	enum bc_simd simd;
	/* The view of a tile's whole list, for near hits settled after
	 * their range (tile_trace.c): 0 not built for this tile yet, 1
	 * built, -1 unusable. */
	struct bc_view tile_view;
	uint32_t *tile_act;
	uint32_t tile_cap;
	int tile_view_state;
	/* Keeps the counters above, which a thread writes per tile, off the
	 * cache lines of the next thread's (the workers lie side by side). */
	char pad[BC_CACHE_LINE];
};

/* One tile's work. */
struct bc__tile_job {
	const struct bc__frame_ctx *fc;
	const float *dirs;     /* unit ray directions, 3 per frame pixel */
	struct bc__frag *list; /* the tile's fragments (sorted in place) */
	uint32_t n;
	uint32_t x0, y0, x1, y1; /* the tile's pixels [x0, x1) x [y0, y1) */
	/* Pixels to trace: bit (y - y0) * 8 + (x - x0). Others are left as
	 * they are. Which pixels are traced does not change any pixel's
	 * value: the depth ranges follow from the list alone. */
	uint64_t mask;
};

/* Walks the tile's depth ranges (paper §6.2, eq. 21-22) and sphere traces
 * its masked pixels in each range's pruned view; writes their colour,
 * depth and id. Returns the pixels (bits as in job->mask) whose rays ran
 * out of the frame's bound (fc->max_evals) and were left as they were. */
uint64_t bc__trace_tile(struct bc__tile_worker *wk,
                        const struct bc__tile_job *job);

#endif
