/*
 * The tiled backend's tracer for one tile (Zanni 2024 §6.2): the tile's
 * fragments sorted by entry, depth ranges walked as eq. 21-22 say (drop
 * active primitives whose exit is <= the previous range end; start the
 * next range there, or at the next entry if nothing is active; fetch while
 * the next entry is <= the largest active exit, fewer than M_overlap (128)
 * are active and fewer than 8 were fetched this turn; the range ends at
 * min(next entry, largest active exit)), a pruned view built for each
 * range's active set, and every asked pixel without a hit yet sphere traced
 * inside the range.
 */
#include "tiled.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

static int frag_cmp(const void *pa, const void *pb)
{
	const struct bc__frag *a = pa, *b = pb;
	if (a->t0 != b->t0) {
		return a->t0 < b->t0 ? -1 : 1;
	}
	return (a->prim > b->prim) - (a->prim < b->prim);
}

/* Adds list entry e to the active set, keeping it sorted by primitive. */
static void activate(struct bc__tile_worker *wk, uint32_t *na, const struct bc__frag *e)
{
	uint32_t i = *na;
	while (i > 0 && wk->act[i - 1] > e->prim) {
		wk->act[i] = wk->act[i - 1];
		wk->act_t1[i] = wk->act_t1[i - 1];
		i--;
	}
	wk->act[i] = e->prim;
	wk->act_t1[i] = e->t1;
	(*na)++;
}

/* A near hit that no following range took over: shade it in the full
 * tree, since the range whose view held there is gone (a few pixels per
 * frame, on silhouettes). */
static void settle(const struct bc__frame_ctx *fc, struct bc__tile_worker *wk,
		   uint32_t x, uint32_t y, const float d[3], float t,
		   uint32_t *evals, uint32_t overlaps)
{
	struct bc__field f = {fc->lin, NULL, *evals};
	bc__put_hit(fc, &f, x, y, d, t, overlaps);
	wk->evals += f.evals - *evals;
	*evals = f.evals;
}

void bc__trace_tile(struct bc__tile_worker *wk, const struct bc__tile_job *job)
{
	const struct bc__frame_ctx *fc = job->fc;
	const struct bc_lin *lin = fc->lin;
	uint32_t w = fc->out->width;
	uint32_t x0 = job->x0, y0 = job->y0, x1 = job->x1, y1 = job->y1;
	struct bc__frag *list = job->list;
	uint32_t n = job->n;
	uint32_t evals[BC_CPU_TILE * BC_CPU_TILE] = {0};
	bool done[BC_CPU_TILE * BC_CPU_TILE];
	/* Rays that ended a range within the hit epsilon, still approaching
	 * (BC__TRACE_NEAR_END): the next range decides, or if none follows
	 * right there, the near hit stands. */
	float pending[BC_CPU_TILE * BC_CPU_TILE];
	bool has_pending[BC_CPU_TILE * BC_CPU_TILE] = {false};
	uint32_t left = 0;
	uint32_t na = 0, next = 0;
	float z_end = 0.0f;
	for (uint32_t p = 0; p < BC_CPU_TILE * BC_CPU_TILE; p++) {
		done[p] = !((job->mask >> p) & 1u);
		left += done[p] ? 0u : 1u;
	}
	if (left == 0) {
		return;
	}
	if (n > 1) {
		qsort(list, n, sizeof(*list), frag_cmp);
	}
	while (left > 0) {
		float z_begin, max_exit = -INFINITY;
		uint32_t kept = 0, fetched = 0;
		struct bc__field f = {lin, &wk->view, 0};
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
			z_begin = list[next].t0; /* eq. 21: skip empty space */
		} else {
			z_begin = z_end;
		}
		while (next < n && fetched < BC_CPU_MAX_FETCH &&
		       na < BC_CPU_M_OVERLAP &&
		       (na == 0 || list[next].t0 <= max_exit)) {
			activate(wk, &na, &list[next]);
			max_exit = bc__maxf(max_exit, list[next].t1);
			next++;
			fetched++;
		}
		if (na >= BC_CPU_M_OVERLAP && next < n &&
		    list[next].t0 <= z_begin) {
			/* Over M_overlap at this very depth: degrade (see
			 * tiled.c's file comment). */
			while (next < n && list[next].t0 <= z_begin) {
				activate(wk, &na, &list[next]);
				max_exit = bc__maxf(max_exit, list[next].t1);
				next++;
			}
			wk->overflows++;
		}
		/* eq. 22 */
		z_end = next < n ? bc__minf(list[next].t0, max_exit) : max_exit;
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
		for (uint32_t y = y0; y < y1; y++) {
			for (uint32_t x = x0; x < x1; x++) {
				uint32_t p = (y - y0) * BC_CPU_TILE + (x - x0);
				const float *d =
					job->dirs + 3 * ((size_t)y * w + x);
				float t = 0.0f;
				enum bc__trace_result res;
				if (done[p]) {
					continue;
				}
				if (has_pending[p] && z_begin > pending[p]) {
					settle(fc, wk, x, y, d, pending[p],
					       &evals[p], n);
					done[p] = true;
					left--;
					continue;
				}
				f.evals = evals[p];
				res = bc__trace(&f, fc, fc->vr.eye, d, z_begin,
						z_end, &t);
				has_pending[p] = res == BC__TRACE_NEAR_END;
				pending[p] = t;
				if (res == BC__TRACE_HIT) {
					bc__put_hit(fc, &f, x, y, d, t, n);
					done[p] = true;
					left--;
				}
				wk->evals += f.evals - evals[p];
				evals[p] = f.evals;
			}
		}
	}
	for (uint32_t y = y0; y < y1; y++) {
		for (uint32_t x = x0; x < x1; x++) {
			uint32_t p = (y - y0) * BC_CPU_TILE + (x - x0);
			if (done[p]) {
				continue;
			}
			if (has_pending[p]) {
				settle(fc, wk, x, y,
				       job->dirs + 3 * ((size_t)y * w + x),
				       pending[p], &evals[p], n);
			} else {
				bc__put_miss(fc, x, y, evals[p], n);
			}
		}
	}
}
