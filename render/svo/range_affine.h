/*
 * min and max for the affine arithmetics (aa.c, revaa.c), written once on
 * their form operations: include after defining RT, f_range, f_from,
 * f_add, f_sub, f_abs and f_scale.
 */
#ifndef BLOBCAST_SVO_RANGE_AFFINE_H
#define BLOBCAST_SVO_RANGE_AFFINE_H

/* The form f, or a fresh one for [lo, hi] (the interval rule's result)
 * when that is narrower: for operands with little correlation the interval
 * min and max are tighter than (a + b -+ |a - b|) / 2 (two independent
 * [0, 1] give [0, 1.5] for the latter), and a narrower range prunes more
 * than the correlations it forgets. */
static inline RT narrower(struct bc_svo_ranger *g, RT f, double lo, double hi)
{
	struct bc_svo_ivl v = f_range(g, f);
	if (hi - lo < v.hi - v.lo) {
		return f_from(g, lo, hi);
	}
	return f;
}

static inline RT f_min(struct bc_svo_ranger *g, RT a, RT b)
{
	struct bc_svo_ivl va = f_range(g, a), vb = f_range(g, b);
	if (va.hi <= vb.lo) {
		return a;
	}
	if (vb.hi <= va.lo) {
		return b;
	}
	return narrower(
	    g,
	    f_scale(g, f_sub(g, f_add(g, a, b), f_abs(g, f_sub(g, a, b))), 0.5),
	    bc__dmin(va.lo, vb.lo), bc__dmin(va.hi, vb.hi));
}

static inline RT f_max(struct bc_svo_ranger *g, RT a, RT b)
{
	struct bc_svo_ivl va = f_range(g, a), vb = f_range(g, b);
	if (va.lo >= vb.hi) {
		return a;
	}
	if (vb.lo >= va.hi) {
		return b;
	}
	return narrower(
	    g,
	    f_scale(g, f_add(g, f_add(g, a, b), f_abs(g, f_sub(g, a, b))), 0.5),
	    bc__dmax(va.lo, vb.lo), bc__dmax(va.hi, vb.hi));
}

#endif
