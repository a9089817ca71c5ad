/*
 * The tiled backend's tracer for one tile (Zanni 2024 §6.2): the tile's
 * fragments sorted by entry, depth ranges walked as eq. 21-22 say (drop
 * active primitives whose exit is <= the previous range end; start the
 * next range there, or at the next entry if nothing is active; fetch while
 * the next entry is <= the largest active exit, fewer than M_overlap (128)
 * are active and fewer than 8 were fetched this turn; the range ends at
 * min(next entry, largest active exit)), a pruned view built for each
 * range's active set, and every asked pixel without a hit yet sphere traced
 * inside the range: one ray at a time through bc__trace (opts.simd off), or
 * in packets of 8 or 16 rays through a vector kernel (packet.h). Packets
 * take the range's pixels in row-major order and a lane whose ray ends
 * takes the next pixel; each lane's arithmetic is its own, so a pixel's
 * value does not depend on which other pixels are traced. A region's
 * evaluation bound counts each pixel's samples over all its ranges, the
 * shading's five included; a lane checks it where the scalar tracer would
 * and the kernel steps a lane on only within it, so a ray stops after the
 * samples the scalar tracer would stop it after (given the same values),
 * and is left undrawn.
 */
#include "tiled.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "packet.h"

static int frag_cmp(const void *pa, const void *pb)
{
	const struct bc__frag *a = pa, *b = pb;
	if (a->q0 != b->q0) {
		return a->q0 < b->q0 ? -1 : 1;
	}
	return (a->prim > b->prim) - (a->prim < b->prim);
}

/* Whether list is in frag_cmp's order already: a kept list, sorted in
 * place by an earlier render of the view (warm frames sorted their lists
 * again: a tenth of a frame of a million spheres). */
static bool frags_sorted(const struct bc__frag *list, uint32_t n)
{
	for (uint32_t i = 1; i < n; i++) {
		if (frag_cmp(&list[i - 1], &list[i]) > 0) {
			return false;
		}
	}
	return true;
}

/* Lists from this length on are sorted by counting, not by qsort. */
#define RADIX_MIN 256u

/* A list is listed in primitive order (its candidates are): two stable
 * counting passes over its entries' bytes then give the order of (entry,
 * primitive), qsort's, at a fraction of its time (sorting the lists of a
 * million spheres' new view was a fifth of the frame). A short list, or
 * one not in primitive order, takes qsort. */
void bc__frags_sort(struct bc__frag *list, uint32_t n, struct bc__frag *tmp)
{
	uint32_t at[256];
	bool by_prim = n >= RADIX_MIN && tmp;
	for (uint32_t i = 1; by_prim && i < n; i++) {
		by_prim = list[i - 1].prim < list[i].prim;
	}
	if (!by_prim) {
		qsort(list, n, sizeof(*list), frag_cmp);
		return;
	}
	for (unsigned shift = 0; shift < 16; shift += 8) {
		const struct bc__frag *src = shift ? tmp : list;
		struct bc__frag *dst = shift ? list : tmp;
		uint32_t sum = 0;
		memset(at, 0, sizeof(at));
		for (uint32_t i = 0; i < n; i++) {
			at[(src[i].q0 >> shift) & 255u]++;
		}
		for (uint32_t k = 0; k < 256; k++) {
			uint32_t c = at[k];
			at[k] = sum;
			sum += c;
		}
		for (uint32_t i = 0; i < n; i++) {
			dst[at[(src[i].q0 >> shift) & 255u]++] = src[i];
		}
	}
}

/* Adds list entry e (exit t1) to the active set, keeping it sorted by
 * primitive. */
static void activate(struct bc__tile_worker *wk, uint32_t *na,
                     const struct bc__frag *e, float t1)
{
	uint32_t i = *na;
	while (i > 0 && wk->act[i - 1] > e->prim) {
		wk->act[i] = wk->act[i - 1];
		wk->act_t1[i] = wk->act_t1[i - 1];
		i--;
	}
	wk->act[i] = e->prim;
	wk->act_t1[i] = t1;
	(*na)++;
}

static int cmp_u32(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return (x > y) - (x < y);
}

/* The view of every primitive in the tile's list, built on first need in
 * a tile (bc__trace_tile forgets it at its start). NULL when it cannot be
 * built or prunes everything: the caller then takes the full tree. */
static const struct bc_view *tile_view(struct bc__tile_worker *wk,
                                       const struct bc__tile_job *job)
{
	uint32_t m = 0;
	if (wk->tile_view_state != 0) {
		return wk->tile_view_state > 0 ? &wk->tile_view : NULL;
	}
	wk->tile_view_state = -1;
	if (job->n > wk->tile_cap) {
		uint32_t *act = bc_calloc(job->n, sizeof(*act));
		if (!act) {
			return NULL;
		}
		bc_free(wk->tile_act);
		wk->tile_act = act;
		wk->tile_cap = job->n;
	}
	for (uint32_t i = 0; i < job->n; i++) {
		wk->tile_act[i] = job->list[i].prim;
	}
	qsort(wk->tile_act, job->n, sizeof(*wk->tile_act), cmp_u32);
	for (uint32_t i = 0; i < job->n; i++) {
		if (m == 0 || wk->tile_act[i] != wk->tile_act[m - 1]) {
			wk->tile_act[m++] = wk->tile_act[i];
		}
	}
	if (bc_view_build(&wk->tile_view, job->fc->lin, wk->tile_act, m) != 0 ||
	    wk->tile_view.empty) {
		return NULL;
	}
	wk->tile_view_state = 1;
	return &wk->tile_view;
}

/* Samples that shade a hit: its primitive and four for the normal
 * (bc__put_hit). */
#define SHADE_EVALS 5u

/* Whether a ray that spent `evals` may still take n samples within the
 * frame's bound. */
static inline bool within(const struct bc__frame_ctx *fc, uint32_t evals,
                          uint32_t n)
{
	struct bc__field f = {fc->lin, NULL, evals, fc->max_evals};
	return bc__field_can(&f, n);
}

/* A near hit that no following range took over: shade it in the view of
 * the tile's whole list, since the range whose view held there is gone (a
 * few pixels per frame, on silhouettes). Not in the full tree: that would
 * let a primitive the tile does not list (an edit far away) change the
 * pixel, and damage renders could not be exact. Returns false, drawing
 * nothing, when the shading would go past the ray's bound. */
static bool settle(const struct bc__tile_job *job, struct bc__tile_worker *wk,
                   uint32_t x, uint32_t y, const float d[3], float t,
                   uint32_t *evals)
{
	const struct bc__frame_ctx *fc = job->fc;
	struct bc__field f = {fc->lin, NULL, *evals, fc->max_evals};
	if (!bc__field_can(&f, SHADE_EVALS)) {
		return false;
	}
	f.view = tile_view(wk, job);
	bc__put_hit(fc, &f, x, y, d, t, job->n);
	wk->evals += f.evals - *evals;
	*evals = f.evals;
	return true;
}

/* What one tile's trace keeps per pixel across its depth ranges. */
struct tile_px {
	uint32_t evals[BC_CPU_TILE * BC_CPU_TILE];
	bool done[BC_CPU_TILE * BC_CPU_TILE];
	/* Rays that ended a range within the hit epsilon, still approaching
	 * (BC__TRACE_NEAR_END): the next range decides, or if none follows
	 * right there, the near hit stands. */
	float pending[BC_CPU_TILE * BC_CPU_TILE];
	bool has_pending[BC_CPU_TILE * BC_CPU_TILE];
	uint32_t left;
	/* Rays that ran out of the frame's bound: done, not drawn. */
	uint64_t cut;
};

/* Ends pixel p's ray, which ran out of its bound. */
static void cut(struct tile_px *px, uint32_t p)
{
	px->done[p] = true;
	px->left--;
	px->cut |= 1ull << p;
}

/* Ends pixel p's ray at its near hit (settle), or cuts it when shading
 * the hit would go past its bound. */
static void settle_px(const struct bc__tile_job *job,
                      struct bc__tile_worker *wk, struct tile_px *px,
                      uint32_t p, uint32_t x, uint32_t y, const float d[3])
{
	if (!settle(job, wk, x, y, d, px->pending[p], &px->evals[p])) {
		cut(px, p);
		return;
	}
	px->done[p] = true;
	px->left--;
}

/* Evaluations a lane may take in the kernel before the state machine
 * must see it again: what its bound leaves after `spent`, and at
 * most 2^24, up to which the kernel's float count is exact. */
static float lane_budget(const struct bc__frame_ctx *fc, uint32_t spent)
{
	const uint32_t most = 1u << 24;
	uint32_t left = most;
	if (fc->max_evals) {
		left = fc->max_evals > spent ? fc->max_evals - spent : 0u;
		left = left < most ? left : most;
	}
	return (float)left;
}

/* The kind of lane a ray waiting in `state` makes; false for a state
 * only the state machine takes (none waits in one now: a start lane is
 * a marching one, start_lanes). */
static bool lane_kind_of(uint8_t state, int *kind)
{
	switch (state) {
	case BC__PK_GOLD_C0:
	case BC__PK_GOLD_E0:
	case BC__PK_GOLD_C:
	case BC__PK_GOLD_E:
		*kind = BC__PK_LANE_GOLD;
		return true;
	case BC__PK_STEP:
	case BC__PK_STEP2:
		*kind = BC__PK_LANE_MARCH;
		return true;
	case BC__PK_BISECT:
		*kind = BC__PK_LANE_BISECT;
		return true;
	case BC__PK_REFINE:
		*kind = BC__PK_LANE_REFINE;
		return true;
	default:
		return false;
	}
}

/* A lane's state moves between the ray (the state machine's) and the
 * packet's arrays (the kernel's): a marching or refining lane keeps t, v,
 * t_prev and v_prev in the m* arrays (a marching one its omega and t1
 * there too, a refining one its round, cap and limit in the r* ones), a
 * bisecting one its bracket in the b* ones, a searching one its bracket,
 * samples, round and phase in the g* ones; each starts with its budget
 * and no sample counted. */
static void to_lanes(const struct bc__pk_ray *r, struct bc__pk_lanes *ln,
                     uint32_t i, int kind, float budget)
{
	if (kind == BC__PK_LANE_GOLD) {
		ln->ga[i] = r->a;
		ln->gfa[i] = r->fa;
		ln->gb[i] = r->b;
		ln->gc[i] = r->c;
		ln->ge[i] = r->e;
		ln->gvc[i] = r->vc;
		ln->gve[i] = r->ve;
		ln->gi[i] = (float)r->i;
		ln->gph[i] = (float)(r->state - BC__PK_GOLD_C0);
	} else if (kind == BC__PK_LANE_BISECT) {
		ln->ba[i] = r->a;
		ln->bfa[i] = r->fa;
		ln->bb[i] = r->b;
		ln->bfb[i] = r->fb;
		ln->bi[i] = (float)r->i;
	} else {
		ln->mt[i] = r->t;
		ln->mv[i] = r->v;
		ln->mt_prev[i] = r->t_prev;
		ln->mv_prev[i] = r->v_prev;
		if (kind == BC__PK_LANE_MARCH) {
			ln->momega[i] = r->omega;
			ln->mt1[i] = r->t1;
		} else {
			ln->ri[i] = (float)r->i;
			ln->rcap[i] = r->cap;
			ln->rlimit[i] = r->limit;
		}
	}
	ln->mevals[i] = 0.0f;
	ln->mbudget[i] = budget;
}

/* A ray just started (waiting for its value at t0) as a marching lane:
 * the state its first value gives it in packet.c (t_prev = t = t0,
 * v_prev = 0, the over-relaxed omega), so that the kernel's ordinary step
 * from there is the one that value leads to; any other outcome (a value
 * below zero or within the hit epsilon, t0 at t1) is the state machine's,
 * from the start state. */
static void start_lanes(const struct bc__pk_ray *r, struct bc__pk_lanes *ln,
                        uint32_t i, float budget)
{
	struct bc__pk_ray head = *r;
	head.t = head.t_prev = r->t0;
	head.v = head.v_prev = 0.0f;
	head.omega = BC_CPU_OVERRELAX;
	to_lanes(&head, ln, i, BC__PK_LANE_MARCH, budget);
}

/* The ray of a lane of that kind, back from the kernel (which may have
 * turned it into that kind). A marching lane the kernel stepped waits at
 * an ordinary step (S_STEP), whichever state it entered in (the start,
 * S_STEP, or S_STEP2 whose omega is 1). */
static void from_lanes(struct bc__pk_ray *r, const struct bc__pk_lanes *ln,
                       uint32_t i, int kind)
{
	if (kind == BC__PK_LANE_GOLD) {
		r->state = (uint8_t)(BC__PK_GOLD_C0 + (int)ln->gph[i]);
		r->a = ln->ga[i];
		r->fa = ln->gfa[i];
		r->b = ln->gb[i];
		r->c = ln->gc[i];
		r->e = ln->ge[i];
		r->vc = ln->gvc[i];
		r->ve = ln->gve[i];
		r->i = (uint8_t)ln->gi[i];
	} else if (kind == BC__PK_LANE_BISECT) {
		r->state = BC__PK_BISECT;
		r->a = ln->ba[i];
		r->fa = ln->bfa[i];
		r->b = ln->bb[i];
		r->fb = ln->bfb[i];
		r->i = (uint8_t)ln->bi[i];
	} else {
		r->t = ln->mt[i];
		r->v = ln->mv[i];
		r->t_prev = ln->mt_prev[i];
		r->v_prev = ln->mv_prev[i];
		if (kind == BC__PK_LANE_REFINE) {
			r->state = BC__PK_REFINE;
			r->i = (uint8_t)ln->ri[i];
			r->cap = ln->rcap[i];
			r->limit = ln->rlimit[i];
		} else {
			r->tn = ln->t[i];
			if (ln->mevals[i] > 0.0f) {
				r->state = BC__PK_STEP;
				r->omega = ln->momega[i];
			}
		}
	}
	r->q = ln->t[i];
	r->evals += (uint32_t)ln->mevals[i];
}

/* Index of the lowest set bit of x (x != 0). */
static inline uint32_t lowest_bit(uint32_t x)
{
	/* One instruction (tzcnt or bsf); a loop over the bits was a
	 * tenth of a gears frame on the vector path. */
	return (uint32_t)__builtin_ctz(x);
}

/* Shades the hits of one range in its view as bc__put_hit does, the
 * samples and the colours taken by the kernel, a lane a hit. */
static void shade_packets(struct bc__tile_worker *wk,
                          const struct bc__tile_job *job,
                          struct bc__pk_kernel k, struct tile_px *px,
                          const uint8_t *hit_px, const float *hit_t,
                          uint32_t nh)
{
	const struct bc__frame_ctx *fc = job->fc;
	const float *eye = fc->vr.eye;
	uint32_t nv = (nh + k.lanes - 1) / k.lanes * k.lanes;
	struct bc__pk_lanes ln;
	struct bc__pk_shade sh;
	for (uint32_t i = 0; i < nv; i++) {
		static const float pad[3] = {0.0f, 0.0f, 0.0f};
		const float *d = pad; /* up to the kernel's width: unused */
		float t = 0.0f;
		if (i < nh) {
			uint32_t x = job->x0 + hit_px[i] % BC_CPU_TILE;
			uint32_t y = job->y0 + hit_px[i] / BC_CPU_TILE;
			d = bc__job_dir(job, x, y);
			t = hit_t[i];
		}
		for (int c = 0; c < 3; c++) {
			sh.d[c][i] = d[c];
			sh.o[c][i] = eye[c] + t * d[c];
			sh.albedo[c][i] = 0.0f;
		}
		sh.step[i] = bc__maxf(BC_CPU_HIT_FOOTPRINT * fc->pix_angle * t,
		                      fc->min_step);
	}
	k.hits(&wk->view, fc->lin, &ln, &sh, nh);
	if (fc->debug == BC_DEBUG_NONE) {
		for (uint32_t i = 0; i < nh; i++) {
			const float *a = bc__albedo(fc->lin, sh.prim[i]);
			for (int c = 0; c < 3; c++) {
				sh.albedo[c][i] = a[c];
			}
		}
		k.shade(&fc->shade, &sh, nh);
	}
	for (uint32_t i = 0; i < nh; i++) {
		uint32_t p = hit_px[i];
		uint32_t x = job->x0 + p % BC_CPU_TILE;
		uint32_t y = job->y0 + p / BC_CPU_TILE;
		px->evals[p] += SHADE_EVALS;
		wk->evals += SHADE_EVALS;
		if (fc->debug == BC_DEBUG_NONE) {
			float lit[3] = {sh.lit[0][i], sh.lit[1][i],
			                sh.lit[2][i]};
			bc__put_lit(fc, x, y, hit_t[i], lit, sh.prim[i]);
		} else {
			float n[3] = {sh.g[0][i], sh.g[1][i], sh.g[2][i]};
			bc__put_shaded(fc, x, y, bc__job_dir(job, x, y),
			               hit_t[i], n, sh.prim[i], px->evals[p],
			               job->n);
		}
	}
}

/* A lane's ray r, traced to its result, for pixel p: its evaluations
 * counted, a hit queued for shading (or cut where the bound leaves no
 * room for the shading's samples), a ray that reached the range's end
 * near a surface left pending for the next range. */
static inline void lane_done(const struct bc__frame_ctx *fc,
                             struct bc__tile_worker *wk, struct tile_px *px,
                             uint32_t p, const struct bc__pk_ray *r,
                             uint8_t *hit_px, float *hit_t, uint32_t *nh)
{
	px->evals[p] += r->evals;
	wk->evals += r->evals;
	px->has_pending[p] = r->res == BC__TRACE_NEAR_END;
	px->pending[p] = r->t_hit;
	if (r->res == BC__TRACE_HIT && !within(fc, px->evals[p], SHADE_EVALS)) {
		cut(px, p);
	} else if (r->res == BC__TRACE_HIT) {
		hit_px[*nh] = (uint8_t)p;
		hit_t[(*nh)++] = r->t_hit;
		px->done[p] = true;
		px->left--;
	}
}

/* Traces the tile's pixels that are still open through [z_begin, z_end]
 * in the range's view, in packets of kernel k's width, and shades those
 * that hit. */
static void trace_range_packets(struct bc__tile_worker *wk,
                                const struct bc__tile_job *job,
                                struct bc__pk_kernel k, struct tile_px *px,
                                float z_begin, float z_end)
{
	const struct bc__frame_ctx *fc = job->fc;
	uint8_t queue[BC_CPU_TILE * BC_CPU_TILE];
	uint8_t hit_px[BC_CPU_TILE * BC_CPU_TILE];
	float hit_t[BC_CPU_TILE * BC_CPU_TILE];
	uint32_t nq = 0, head = 0, nh = 0, active = 0, slow,
	         lanes = k.lanes >= 32 ? UINT32_MAX : (1u << k.lanes) - 1u;
	struct bc__pk_kinds kinds = {{0}, 0, 0}; /* the lanes of each kind */
	const struct bc__pk_steps st = {
	    .eps_per_t = BC_CPU_HIT_FOOTPRINT * fc->pix_angle,
	    .min_step = fc->min_step,
	    .refine_tol = fc->refine_tol,
	};
	struct bc__pk_lanes ln;
	struct bc__pk_ray ray[BC_PK_MAX_LANES];
	uint8_t lane_px[BC_PK_MAX_LANES];
	for (uint32_t y = job->y0; y < job->y1; y++) {
		for (uint32_t x = job->x0; x < job->x1; x++) {
			uint32_t p =
			    (y - job->y0) * BC_CPU_TILE + (x - job->x0);
			if (px->done[p]) {
				continue;
			}
			if (px->has_pending[p] && z_begin > px->pending[p]) {
				settle_px(job, wk, px, p, x, y,
				          bc__job_dir(job, x, y));
				continue;
			}
			queue[nq++] = (uint8_t)p;
		}
	}
	for (uint32_t i = 0; i < k.lanes; i++) {
		ln.ox[i] = fc->vr.eye[0];
		ln.oy[i] = fc->vr.eye[1];
		ln.oz[i] = fc->vr.eye[2];
		ln.t[i] = 0.0f;
		ln.dx[i] = ln.dy[i] = ln.dz[i] = 0.0f;
	}
	for (;;) {
		/* Free lanes, lowest first, take the next pixels, in queue
		 * order; a new ray's first value is a marching one. */
		for (uint32_t free = lanes & ~active; free && head < nq;) {
			uint32_t i = lowest_bit(free), p = queue[head++];
			uint32_t x = job->x0 + p % BC_CPU_TILE;
			uint32_t y = job->y0 + p / BC_CPU_TILE;
			const float *d = bc__job_dir(job, x, y);
			if (bc__pk_ray_start(&ray[i], fc, z_begin, z_end)) {
				/* An empty interval: a miss. */
				px->has_pending[p] = false;
				continue;
			}
			if (!within(fc, px->evals[p], 1)) {
				cut(px, p);
				continue;
			}
			lane_px[i] = (uint8_t)p;
			ln.dx[i] = d[0];
			ln.dy[i] = d[1];
			ln.dz[i] = d[2];
			ln.t[i] = ray[i].q;
			start_lanes(&ray[i], &ln, i,
			            lane_budget(fc, px->evals[p]));
			active |= 1u << i;
			kinds.of[BC__PK_LANE_MARCH] |= 1u << i;
			free &= free - 1u;
		}
		if (!active) {
			break;
		}
		slow = k.march(&wk->view, fc->lin, &ln, active, &kinds, &st);
		/* Bisections the kernel ended (hits) and marches that reached
		 * the range's end (misses), as the state machine would have
		 * finished them (from_lanes and a feed spared). */
		for (uint32_t bits = kinds.hit | kinds.miss; bits;
		     bits &= bits - 1) {
			uint32_t i = lowest_bit(bits);
			struct bc__pk_ray *r = &ray[i];
			bool hit = (kinds.hit >> i) & 1u;
			r->evals += (uint32_t)ln.mevals[i];
			r->res = hit ? BC__TRACE_HIT : BC__TRACE_MISS;
			r->t_hit = hit ? ln.t[i] : 0.0f;
			active &= ~(1u << i);
			lane_done(fc, wk, px, lane_px[i], r, hit_px, hit_t,
			          &nh);
		}
		for (uint32_t bits = slow; bits; bits &= bits - 1) {
			uint32_t i = lowest_bit(bits), p;
			struct bc__pk_ray *r = &ray[i];
			int kind;
			for (kind = BC__PK_LANE_MARCH; kind < BC__PK_LANE_KINDS;
			     kind++) {
				if ((kinds.of[kind] >> i) & 1u) {
					from_lanes(r, &ln, i, kind);
					kinds.of[kind] &= ~(1u << i);
					break;
				}
			}
			/* trace.c's eval_at: the field over the bounds. */
			p = lane_px[i];
			if (!bc__pk_ray_feed(r, fc,
			                     ln.v[i] *
			                         (1.0f / BC_CPU_LIPSCHITZ) /
			                         fc->lin->lip)) {
				uint32_t spent = px->evals[p] + r->evals;
				if (within(fc, spent, 1)) {
					ln.t[i] = r->q;
					if (lane_kind_of(r->state, &kind)) {
						to_lanes(
						    r, &ln, i, kind,
						    lane_budget(fc, spent));
						kinds.of[kind] |= 1u << i;
					}
					continue;
				}
				/* The bound stops the ray where the scalar
				 * tracer's eval_at would. */
				active &= ~(1u << i);
				px->evals[p] = spent;
				wk->evals += r->evals;
				cut(px, p);
				continue;
			}
			active &= ~(1u << i);
			lane_done(fc, wk, px, p, r, hit_px, hit_t, &nh);
		}
	}
	if (nh > 0) {
		shade_packets(wk, job, k, px, hit_px, hit_t, nh);
	}
}

uint64_t bc__trace_tile(struct bc__tile_worker *wk,
                        const struct bc__tile_job *job)
{
	const struct bc__frame_ctx *fc = job->fc;
	const struct bc_lin *lin = fc->lin;
	uint32_t x0 = job->x0, y0 = job->y0, x1 = job->x1, y1 = job->y1;
	struct bc__frag *list = job->list;
	uint32_t n = job->n;
	struct bc__zq zq = job->zq;
	struct bc__pk_kernel k = bc__pk_kernel_for(wk->simd);
	struct tile_px px;
	uint32_t na = 0, next = 0;
	float z_end = 0.0f;
	wk->tile_view_state = 0; /* built again for this tile's list */
	if (n == 0) {
		/* Nothing listed (most of a frame's background): every
		 * asked pixel misses without a sample. */
		bc__put_miss_tile(fc, x0, y0, x1, y1, job->mask);
		return 0;
	}
	px.left = 0;
	px.cut = 0;
	for (uint32_t p = 0; p < BC_CPU_TILE * BC_CPU_TILE; p++) {
		px.evals[p] = 0;
		px.has_pending[p] = false;
		px.pending[p] = 0.0f;
		px.done[p] = !((job->mask >> p) & 1u);
		px.left += px.done[p] ? 0u : 1u;
	}
	if (px.left == 0) {
		return 0;
	}
	if (n > 1 && !frags_sorted(list, n)) {
		bc__frags_sort(list, n, n <= wk->sort_cap ? wk->sort : NULL);
	}
	while (px.left > 0) {
		float z_begin, max_exit = -INFINITY;
		uint32_t kept = 0, fetched = 0;
		struct bc__field f = {lin, &wk->view, 0, fc->max_evals};
		/* Retire primitives that ended with the previous range. */
		for (uint32_t i = 0; i < na; i++) {
			if (wk->act_t1[i] > z_end) {
				wk->act[kept] = wk->act[i];
				wk->act_t1[kept] = wk->act_t1[i];
				max_exit = bc__maxf(max_exit, wk->act_t1[i]);
				kept++;
			}
		}
		na = kept;
		if (na == 0) {
			if (next >= n) {
				break;
			}
			/* eq. 21: skip empty space */
			z_begin = bc__frag_t0(zq, &list[next]);
		} else {
			z_begin = z_end;
		}
		while (next < n && fetched < BC_CPU_MAX_FETCH &&
		       na < BC_CPU_M_OVERLAP &&
		       (na == 0 || bc__frag_t0(zq, &list[next]) <= max_exit)) {
			float t1 = bc__frag_t1(zq, &list[next]);
			activate(wk, &na, &list[next], t1);
			max_exit = bc__maxf(max_exit, t1);
			next++;
			fetched++;
		}
		if (na >= BC_CPU_M_OVERLAP && next < n &&
		    bc__frag_t0(zq, &list[next]) <= z_begin) {
			/* Over M_overlap at this very depth: degrade (see
			 * tiled.c's file comment). */
			while (next < n &&
			       bc__frag_t0(zq, &list[next]) <= z_begin) {
				float t1 = bc__frag_t1(zq, &list[next]);
				activate(wk, &na, &list[next], t1);
				max_exit = bc__maxf(max_exit, t1);
				next++;
			}
			wk->overflows++;
		}
		/* eq. 22 */
		z_end = next < n
		            ? bc__minf(bc__frag_t0(zq, &list[next]), max_exit)
		            : max_exit;
		if (!(z_end > z_begin)) {
			continue;
		}
		if (bc_view_build(&wk->view, lin, wk->act, na) != 0) {
			/* Cannot happen for a valid tree; the full tree is
			 * always right, only slower. */
			f.view = NULL;
		} else if (wk->view.empty) {
			continue; /* no surface can be in this range */
		}
		if (k.march && f.view) {
			trace_range_packets(wk, job, k, &px, z_begin, z_end);
			continue;
		}
		for (uint32_t y = y0; y < y1; y++) {
			for (uint32_t x = x0; x < x1; x++) {
				uint32_t p = (y - y0) * BC_CPU_TILE + (x - x0);
				const float *d = bc__job_dir(job, x, y);
				float t = 0.0f;
				enum bc__trace_result res;
				if (px.done[p]) {
					continue;
				}
				if (px.has_pending[p] &&
				    z_begin > px.pending[p]) {
					settle_px(job, wk, &px, p, x, y, d);
					continue;
				}
				f.evals = px.evals[p];
				res = bc__trace(&f, fc, fc->vr.eye, d, z_begin,
				                z_end, &t);
				px.has_pending[p] = res == BC__TRACE_NEAR_END;
				px.pending[p] = t;
				if (res == BC__TRACE_SHORT ||
				    (res == BC__TRACE_HIT &&
				     !bc__field_can(&f, SHADE_EVALS))) {
					cut(&px, p);
				} else if (res == BC__TRACE_HIT) {
					bc__put_hit(fc, &f, x, y, d, t, n);
					px.done[p] = true;
					px.left--;
				}
				wk->evals += f.evals - px.evals[p];
				px.evals[p] = f.evals;
			}
		}
	}
	for (uint32_t y = y0; y < y1; y++) {
		uint64_t miss = 0;
		for (uint32_t x = x0; x < x1; x++) {
			uint32_t p = (y - y0) * BC_CPU_TILE + (x - x0);
			if (px.done[p]) {
				continue;
			}
			if (px.has_pending[p]) {
				settle_px(job, wk, &px, p, x, y,
				          bc__job_dir(job, x, y));
			} else if (fc->debug != BC_DEBUG_NONE) {
				/* Coloured by its own counts. */
				bc__put_miss(fc, x, y, px.evals[p], n);
			} else {
				miss |= 1ull << (x - x0);
			}
		}
		if (miss) {
			bc__put_miss_row(fc, x0, y, miss);
		}
	}
	return px.cut;
}
