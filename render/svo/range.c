/*
 * What the three range arithmetics share: the range evaluator object and its
 * dispatch, the region geometry, and the rules for operators -- when a
 * compact smooth operator provably acts as its sharp counterpart over a
 * region, and how far its blend can move the sharp result elsewhere. The
 * pruner relies on the same rules, so they live in one place.
 *
 * Operators (Zanni 2024, eq. 8-18, as blobtree/ops.c evaluates them), with
 * m the sharp result, beta the blend and r_o the range, d = 6 r_o - beta:
 *   union         G = m - A,  A = b/6 h^3,  b = beta max(0, 1 - 6 g/d),
 *                 g = m - A_beta in [m - beta/6, m], applied only where both
 *                 operands are <= r_o; so 0 <= A <= beta/6 max(0, 1 + (beta
 *                 - 6 m)/d), and A = 0 once |f0 - f1| >= b.
 *   intersection  G = m + A, b = beta max(0, 1 - 6 |g|/d) <= beta, g in
 *                 [m, m + beta/6], applied only where |f0|, |f1| <= r_o.
 * docs/svo.md gives the derivation.
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

/* Float evaluation of the blend can land a few ulps beyond the exact-math
 * thresholds used below; every threshold is taken this much further. */
#define SAFE (1.0 + 1.0e-5)

static inline bool is_union(enum bc_op k)
{
	return k == BC_OP_UNION || k == BC_OP_SMOOTH_UNION;
}

bool bc__svo_op_sharp_in(enum bc_op kind, double blend, double range,
                         struct bc_svo_ivl a, struct bc_svo_ivl b)
{
	double bmax, dlo, dhi;
	if (!bc_op_is_smooth(kind)) {
		return true;
	}
	if (is_union(kind)) {
		double mlo = a.lo < b.lo ? a.lo : b.lo;
		/* ops.c blends only where both operands are <= r_o. */
		if (a.lo > range || b.lo > range) {
			return true;
		}
		bmax = blend * bc__dmax(0.0, 1.0 + (blend - 6.0 * mlo) /
		                                       (6.0 * range - blend));
	} else {
		if (a.lo > range || a.hi < -range || b.lo > range ||
		    b.hi < -range) {
			return true;
		}
		bmax = blend;
	}
	/* The blend amount vanishes once |f0 - f1| >= b. */
	dlo = a.lo - b.hi;
	dhi = a.hi - b.lo;
	return dlo >= bmax * SAFE || dhi <= -bmax * SAFE;
}

double bc__svo_op_blend_bound(enum bc_op kind, double blend, double range,
                              struct bc_svo_ivl m, struct bc_svo_ivl a,
                              struct bc_svo_ivl b)
{
	double d = 6.0 * range - blend, t, bmax, dlo, dhi, dmin, h;
	if (is_union(kind)) {
		t = 1.0 + (blend - 6.0 * m.lo) / d;
	} else {
		/* |g| is at least the distance of [m.lo, m.hi + beta/6] to 0.
		 */
		double glo = m.lo, ghi = m.hi + blend / 6.0;
		double gmin = glo > 0.0 ? glo : (ghi < 0.0 ? -ghi : 0.0);
		t = 1.0 - 6.0 * gmin / d;
	}
	if (!(t > 0.0)) {
		return 0.0;
	}
	bmax = blend * t * SAFE;
	/* A = b/6 (1 - |f0 - f1| / b)^3 grows with b, so the largest b and
	 * the smallest |f0 - f1| bound it. */
	dlo = a.lo - b.hi;
	dhi = a.hi - b.lo;
	dmin = dlo > 0.0 ? dlo : (dhi < 0.0 ? -dhi : 0.0);
	if (dmin >= bmax) {
		return 0.0;
	}
	h = 1.0 - dmin / bmax;
	return bmax / 6.0 * h * h * h * SAFE;
}

double bc__svo_op_margin(double blend, struct bc_svo_ivl m)
{
	double s = bc__dmax(fabs(m.lo), fabs(m.hi));
	if (!isfinite(s)) {
		return 0.0; /* an infinite bound needs no widening */
	}
	return BC__SVO_ROUND_REL * (s + 2.0 * blend) + BC__SVO_ROUND_ABS;
}

struct bc_svo_ivl bc_svo_range_op(enum bc_op kind, float blend, float range,
                                  struct bc_svo_ivl a, struct bc_svo_ivl b)
{
	struct bc_svo_ivl m;
	if (kind == BC_OP_DIFFERENCE || kind == BC_OP_SMOOTH_DIFFERENCE) {
		/* G\ (f0, f1) is G∩ (f0, -f1) exactly (ops.c). */
		struct bc_svo_ivl nb = {-b.hi, -b.lo};
		return bc_svo_range_op(kind == BC_OP_DIFFERENCE
		                           ? BC_OP_INTERSECTION
		                           : BC_OP_SMOOTH_INTERSECTION,
		                       blend, range, a, nb);
	}
	if (is_union(kind)) {
		m.lo = bc__dmin(a.lo, b.lo);
		m.hi = bc__dmin(a.hi, b.hi);
	} else {
		m.lo = bc__dmax(a.lo, b.lo);
		m.hi = bc__dmax(a.hi, b.hi);
	}
	if (bc_op_is_smooth(kind) &&
	    !bc__svo_op_sharp_in(kind, blend, range, a, b)) {
		double amax =
		    bc__svo_op_blend_bound(kind, blend, range, m, a, b);
		double mg = bc__svo_op_margin(blend + amax, m);
		if (is_union(kind)) {
			m.lo -= amax + mg;
			m.hi += mg;
		} else {
			m.lo -= mg;
			m.hi += amax + mg;
		}
	}
	return m;
}

void bc__svo_geo_init(struct bc__svo_geo *geo, const struct bc_svo_region *rg)
{
	double r2 = 0.0;
	if (rg->segment) {
		float tm = 0.5f * (rg->t0 + rg->t1);
		double e0 = 0.0, e1 = 0.0;
		for (int i = 0; i < 3; i++) {
			geo->c[i] = rg->o[i] + tm * rg->d[i];
		}
		/* The farthest point of a segment from any point is an end. */
		for (int i = 0; i < 3; i++) {
			double p0 =
			    (double)rg->o[i] + (double)rg->t0 * rg->d[i];
			double p1 =
			    (double)rg->o[i] + (double)rg->t1 * rg->d[i];
			e0 += (p0 - geo->c[i]) * (p0 - geo->c[i]);
			e1 += (p1 - geo->c[i]) * (p1 - geo->c[i]);
		}
		r2 = bc__dmax(e0, e1);
	} else {
		for (int i = 0; i < 3; i++) {
			double h;
			geo->c[i] = 0.5f * (rg->lo[i] + rg->hi[i]);
			h = bc__dmax((double)geo->c[i] - rg->lo[i],
			             (double)rg->hi[i] - geo->c[i]);
			r2 += h * h;
		}
	}
	geo->radius = sqrt(r2);
}

/* ---- The range evaluator ------------------------------------------------ */

int bc_svo_ranger_create(struct bc_svo_ranger **out, const struct bc_svo_rpn *r,
                         enum bc_range_arith arith)
{
	struct bc_svo_ranger *g;
	*out = NULL;
	if (arith == BC_RANGE_DEFAULT) {
		arith = BC_SVO_DEFAULT_ARITH;
	}
	if ((int)arith <= BC_RANGE_DEFAULT || arith >= BC_RANGE_COUNT) {
		return BC_EENUM;
	}
	if (!r || r->n == 0) {
		return BC_EINVAL;
	}
	g = bc_calloc(1, sizeof(*g));
	if (!g) {
		return BC_ENOMEM;
	}
	g->rpn = r;
	g->arith = arith;
	g->ivl = bc_calloc(r->n, sizeof(*g->ivl));
	g->kid0 = bc_calloc(r->n, sizeof(*g->kid0));
	g->kid1 = bc_calloc(r->n, sizeof(*g->kid1));
	g->idx = bc_calloc(r->n, sizeof(*g->idx));
	g->mark = bc_calloc(r->n, sizeof(*g->mark));
	g->mode = bc_calloc(r->n, sizeof(*g->mode));
	if (!g->ivl || !g->kid0 || !g->kid1 || !g->idx || !g->mark ||
	    !g->mode) {
		bc_svo_ranger_destroy(g);
		return BC_ENOMEM;
	}
	if (arith == BC_RANGE_AA) {
		/* The stack of forms, each capped, plus the temporaries of one
		 * primitive or operator (a few dozen, each at most two capped
		 * forms merged). */
		g->aa_cap =
		    (BC_EVAL_STACK + 64u) * (2u * BC_SVO_AA_MAX_TERMS + 8u);
		g->aa_sym = bc_calloc(g->aa_cap, sizeof(*g->aa_sym));
		g->aa_coef = bc_calloc(g->aa_cap, sizeof(*g->aa_coef));
		if (!g->aa_sym || !g->aa_coef) {
			bc_svo_ranger_destroy(g);
			return BC_ENOMEM;
		}
	}
	*out = g;
	return 0;
}

void bc_svo_ranger_destroy(struct bc_svo_ranger *g)
{
	if (!g) {
		return;
	}
	bc_free(g->ivl);
	bc_free(g->kid0);
	bc_free(g->kid1);
	bc_free(g->idx);
	bc_free(g->mark);
	bc_free(g->mode);
	bc_free(g->aa_sym);
	bc_free(g->aa_coef);
	bc_free(g);
}

enum bc_range_arith bc_svo_ranger_arith(const struct bc_svo_ranger *g)
{
	return g->arith;
}

struct bc_svo_ivl bc_svo_range(struct bc_svo_ranger *g, const uint32_t *idx,
                               uint32_t n, const struct bc_svo_region *region)
{
	struct bc_svo_ivl none = {INFINITY, INFINITY};
	if (n == 0) {
		return none;
	}
	switch (g->arith) {
	case BC_RANGE_IA:
		return bc__svo_ia_run(g, idx, n, region);
	case BC_RANGE_AA:
		return bc__svo_aa_run(g, idx, n, region);
	default:
		return bc__svo_rev_run(g, idx, n, region);
	}
}

struct bc_svo_ivl bc_svo_range_prim(struct bc_svo_ranger *g, uint32_t term,
                                    const struct bc_svo_region *region)
{
	switch (g->arith) {
	case BC_RANGE_IA:
		return bc__svo_ia_prim(g, term, region);
	case BC_RANGE_AA:
		return bc__svo_aa_prim(g, term, region);
	default:
		return bc__svo_rev_prim(g, term, region);
	}
}

bool bc_svo_prim_uses_lipschitz(enum bc_prim kind)
{
	/* Must agree with t_natural() in range_prims.h. */
	switch (kind) {
	case BC_PRIM_SPHERE:
	case BC_PRIM_BOX:
	case BC_PRIM_CAPSULE:
	case BC_PRIM_CYLINDER:
	case BC_PRIM_TORUS:
	case BC_PRIM_ELLIPSOID:
	case BC_PRIM_BOX_FRAME:
	case BC_PRIM_LINK:
		return false;
	default:
		return true;
	}
}
