/*
 * Between the tiled backend's A-buffer (tiled.c) and its tile tracer
 * (tile_trace.c): one tile's depth-sorted list of primitive fragments, the
 * per-thread scratch of the tracer, and the call that walks a tile's depth
 * ranges and traces the pixels asked of it.
 */
#ifndef BLOBCAST_RENDER_CPU_TILED_H
#define BLOBCAST_RENDER_CPU_TILED_H

#include <math.h>
#include <stdint.h>

#include "blobcast/alloc.h"
#include "cpu.h"

/* A primitive's depth interval over a tile's rays, min entry and max exit,
 * in steps of the tile's depth scale (struct bc__zq): 8 bytes where two
 * floats and the index took 12. A view of a million primitives keeps room
 * for some ten million between frames (its lists), 40 MB less now. The
 * steps round outward (by at most three steps, a 20 000th of the tile's
 * depth range), so an interval only widens: a depth range holds every
 * primitive it held with the floats. */
struct bc__frag {
	uint16_t q0, q1;
	uint32_t prim;
};

/* The depth scale of one tile's list: step q is depth base + q * step,
 * computed by bc__zq_at alone, where the lists are written (tiled.c) and
 * where they are read (tile_trace.c), so that both round it alike
 * (neither is built with FMA contraction). */
#define BC__ZQ_MAX 65535u
struct bc__zq {
	float base, step;
};

static inline float bc__zq_at(struct bc__zq z, uint32_t q)
{
	return z.base + (float)q * z.step;
}
/* The depth scale of a list whose entries are at least lo and exits at
 * most hi: 2^16 steps over [lo, hi], each at least 4 ulps of the depths'
 * magnitude so that a step always moves bc__zq_at. */
static inline struct bc__zq bc__zq_for(float lo, float hi)
{
	float mag = bc__maxf(fabsf(lo), fabsf(hi));
	struct bc__zq z = {lo, (hi - lo) / (float)BC__ZQ_MAX};
	z.step = bc__maxf(z.step, 4.0f * (nextafterf(mag, INFINITY) - mag));
	for (int i = 0; bc__zq_at(z, BC__ZQ_MAX) < hi; i++) {
		/* The division's rounding: an ulp or two of step. */
		z.step = i < 8 ? nextafterf(z.step, INFINITY) : 2.0f * z.step;
	}
	return z;
}

/* A step at or below t, and one at or above it, at most three steps
 * away (t within the scale's range; inv is 1 / z.step). Why two steps of
 * margin are enough: f = (t - base) * inv is within 0.02 of the exact
 * quotient e (three roundings of at most 2^-24 of e <= 65535), so the
 * truncated guess is floor(e) - 1, floor(e) or floor(e) + 1, and two
 * steps down is at most e - 0.98 steps: bc__zq_at rounds at most 3 ulps
 * of the depths' magnitude there, and a step is at least 4 of them. The
 * same holds upward. No loops and no floor call (a library call in the
 * baseline x86-64 build): a cold frame lists tens of millions. */
static inline uint32_t bc__zq_guess(struct bc__zq z, float inv, float t)
{
	float f = (t - z.base) * inv;
	if (!(f > 0.0f)) {
		return 0u; /* also NaN: 0 * inf when a list has one depth */
	}
	return f >= (float)BC__ZQ_MAX ? BC__ZQ_MAX : (uint32_t)f;
}
static inline uint16_t bc__zq_down(struct bc__zq z, float inv, float t)
{
	uint32_t q = bc__zq_guess(z, inv, t);
	return (uint16_t)(q > 2u ? q - 2u : 0u);
}
static inline uint16_t bc__zq_up(struct bc__zq z, float inv, float t)
{
	uint32_t q = bc__zq_guess(z, inv, t) + 2u;
	return (uint16_t)(q < BC__ZQ_MAX ? q : BC__ZQ_MAX);
}

static inline float bc__frag_t0(struct bc__zq z, const struct bc__frag *f)
{
	return bc__zq_at(z, f->q0);
}
static inline float bc__frag_t1(struct bc__zq z, const struct bc__frag *f)
{
	return bc__zq_at(z, f->q1);
}

/* Sorts a tile's list (n fragments) by entry, then primitive, through tmp
 * (room for n fragments, or NULL). */
void bc__frags_sort(struct bc__frag *list, uint32_t n, struct bc__frag *tmp);

/* One thread's scratch, reserved before a frame so tracing never
 * allocates. */
struct bc__tile_worker {
	struct bc_view view;
	uint32_t *act; /* active primitive indices, increasing */
	float *act_t1; /* their exits */
	uint32_t cap;  /* room in act and act_t1 */
	/* The entry and exit of each fragment of the tile being listed,
	 * before the tile's depth scale is known: 2 * tz_cap floats; and
	 * the list itself (tz_cap fragments), until it has its place among
	 * the kept lists (tiled.c, place_list). */
	float *tz;
	struct bc__frag *lst;
	uint32_t tz_cap;
	/* Room to sort the longest list of the frame (tile_trace.c). */
	struct bc__frag *sort;
	uint32_t sort_cap;
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
	/* Unit ray directions, 3 per pixel of the tile, in rows of
	 * BC_CPU_TILE pixels from (x0, y0): bc__job_dir. */
	const float *dirs;
	struct bc__frag *list; /* the tile's fragments (sorted in place) */
	uint32_t n;
	struct bc__zq zq;        /* their depth scale */
	uint32_t x0, y0, x1, y1; /* the tile's pixels [x0, x1) x [y0, y1) */
	/* Pixels to trace: bit (y - y0) * 8 + (x - x0). Others are left as
	 * they are. Which pixels are traced does not change any pixel's
	 * value: the depth ranges follow from the list alone. */
	uint64_t mask;
};

/* The unit ray direction of the job's pixel (x, y) (frame coordinates). */
static inline const float *bc__job_dir(const struct bc__tile_job *job,
                                       uint32_t x, uint32_t y)
{
	return job->dirs +
	       3 * ((size_t)(y - job->y0) * BC_CPU_TILE + (x - job->x0));
}

/* Walks the tile's depth ranges (paper §6.2, eq. 21-22) and sphere traces
 * its masked pixels in each range's pruned view; writes their colour,
 * depth and id. Returns the pixels (bits as in job->mask) whose rays ran
 * out of the frame's bound (fc->max_evals) and were left as they were. */
uint64_t bc__trace_tile(struct bc__tile_worker *wk,
                        const struct bc__tile_job *job);

#endif
