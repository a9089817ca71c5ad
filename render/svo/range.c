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

/* ---- Unary and domain nodes -------------------------------------------- */

/* cos over [a, b] (radians), widened by eps and clamped to [-1, 1]: the
 * ends, and +1 / -1 where the interval holds a multiple of 2 pi / an odd
 * multiple of pi. */
static struct bc_svo_ivl ivl_cos(double a, double b, double eps)
{
	const double pi = 3.14159265358979323846;
	struct bc_svo_ivl r = {-1.0, 1.0};
	double ca, cb;
	if (!(b - a < 2.0 * pi) || !isfinite(a) || !isfinite(b)) {
		return r;
	}
	ca = cos(a);
	cb = cos(b);
	r.lo = bc__dmin(ca, cb);
	r.hi = bc__dmax(ca, cb);
	if (floor(a / (2.0 * pi)) != floor(b / (2.0 * pi))) {
		r.hi = 1.0;
	}
	if (floor(a / (2.0 * pi) - 0.5) != floor(b / (2.0 * pi) - 0.5)) {
		r.lo = -1.0;
	}
	r.lo = bc__dmax(r.lo - eps, -1.0);
	r.hi = bc__dmin(r.hi + eps, 1.0);
	return r;
}

static struct bc_svo_ivl ivl_mul(struct bc_svo_ivl a, struct bc_svo_ivl b)
{
	double p0 = a.lo * b.lo, p1 = a.lo * b.hi, p2 = a.hi * b.lo,
	       p3 = a.hi * b.hi;
	struct bc_svo_ivl r = {bc__dmin(bc__dmin(p0, p1), bc__dmin(p2, p3)),
	                       bc__dmax(bc__dmax(p0, p1), bc__dmax(p2, p3))};
	return r;
}

/* Rotation of (u, v) by an angle in [a0, a1]: (c u + s v, -s u + c v),
 * each also within the largest radius of the box. */
static void rotate_box(double *ulo, double *uhi, double *vlo, double *vhi,
                       double a0, double a1, double eps)
{
	const double half_pi = 1.57079632679489661923;
	struct bc_svo_ivl c = ivl_cos(a0, a1, eps);
	struct bc_svo_ivl s = ivl_cos(a0 - half_pi, a1 - half_pi, eps);
	struct bc_svo_ivl ns = {-s.hi, -s.lo};
	struct bc_svo_ivl u = {*ulo, *uhi}, v = {*vlo, *vhi};
	struct bc_svo_ivl cu = ivl_mul(c, u), sv = ivl_mul(s, v);
	struct bc_svo_ivl nsu = ivl_mul(ns, u), cv = ivl_mul(c, v);
	double um = bc__dmax(fabs(u.lo), fabs(u.hi));
	double vm = bc__dmax(fabs(v.lo), fabs(v.hi));
	double rad = sqrt(um * um + vm * vm);
	*ulo = bc__dmax(cu.lo + sv.lo, -rad);
	*uhi = bc__dmin(cu.hi + sv.hi, rad);
	*vlo = bc__dmax(nsu.lo + cv.lo, -rad);
	*vhi = bc__dmin(nsu.hi + cv.hi, rad);
}

/* x - clamp(x, -h, h): non-decreasing. */
static double elongate1(double x, double h)
{
	return x - bc__dmin(bc__dmax(x, -h), h);
}

/* One domain node's map of the box [lo, hi] (docs/svo.md, "Unary and
 * domain nodes"). */
static void domain_box(uint32_t kind, const float *rec, double lo[3],
                       double hi[3])
{
	double m = 0.0, amax = 0.0, mg;
	for (int i = 0; i < 3; i++) {
		m = bc__dmax(m, bc__dmax(fabs(lo[i]), fabs(hi[i])));
	}
	switch (kind) {
	case BC_OP_ELONGATE:
		for (int i = 0; i < 3; i++) {
			lo[i] = elongate1(lo[i], rec[i]);
			hi[i] = elongate1(hi[i], rec[i]);
		}
		break;
	case BC_OP_MIRROR: {
		uint32_t mask = (uint32_t)rec[0];
		for (int i = 0; i < 3; i++) {
			if (!(mask & (1u << i))) {
				continue;
			}
			if (lo[i] >= 0.0) {
				continue;
			}
			if (hi[i] <= 0.0) {
				double t = -hi[i];
				hi[i] = -lo[i];
				lo[i] = t;
			} else {
				hi[i] = bc__dmax(-lo[i], hi[i]);
				lo[i] = 0.0;
			}
		}
		break;
	}
	case BC_OP_SCALE:
		for (int i = 0; i < 3; i++) {
			lo[i] *= rec[1];
			hi[i] *= rec[1];
		}
		break;
	case BC_OP_REPEAT:
		for (int i = 0; i < 3; i++) {
			double n = rec[3 + i], sp = rec[i], o, a, b, ka, kb;
			if (!(n > 1.0)) {
				continue;
			}
			o = 0.5 * (n - 1.0);
			/* The copy index of each end, taken a little wider:
			 * the float evaluation may round a point near a cell
			 * boundary into the neighbouring copy. */
			mg = BC__SVO_ROUND_REL * (m + sp);
			a = lo[i] - mg;
			b = hi[i] + mg;
			ka = bc__dmin(bc__dmax(floor(a / sp + o + 0.5), 0.0),
			              n - 1.0);
			kb = bc__dmin(bc__dmax(floor(b / sp + o + 0.5), 0.0),
			              n - 1.0);
			if (ka == kb) {
				lo[i] -= sp * (ka - o);
				hi[i] -= sp * (ka - o);
			} else {
				/* The lowest copy's piece runs up to its cell's
				 * top, the highest's from its cell's bottom,
				 * middle ones fill a cell. */
				lo[i] =
				    bc__dmin(lo[i] - sp * (ka - o), -0.5 * sp);
				hi[i] =
				    bc__dmax(hi[i] - sp * (kb - o), 0.5 * sp);
			}
		}
		break;
	case BC_OP_TWIST: {
		/* About y by rate * y. */
		double a0 = rec[0] * lo[1], a1 = rec[0] * hi[1];
		amax = bc__dmax(fabs(a0), fabs(a1));
		rotate_box(&lo[0], &hi[0], &lo[2], &hi[2], bc__dmin(a0, a1),
		           bc__dmax(a0, a1), 1.0e-6 * (1.0 + amax));
		break;
	}
	case BC_OP_BEND: {
		/* In the xy plane by rate * x. */
		double a0 = rec[0] * lo[0], a1 = rec[0] * hi[0];
		amax = bc__dmax(fabs(a0), fabs(a1));
		rotate_box(&lo[0], &hi[0], &lo[1], &hi[1], bc__dmin(a0, a1),
		           bc__dmax(a0, a1), 1.0e-6 * (1.0 + amax));
		break;
	}
	default:
		break;
	}
	/* The float map rounds at the scale of its input (a rotation's
	 * angle too); 2^-17 of it is 64 float ulps. */
	mg = BC__SVO_ROUND_REL * m * (1.0 + amax) + BC__SVO_ROUND_ABS;
	for (int i = 0; i < 3; i++) {
		lo[i] -= mg;
		hi[i] += mg;
	}
}

void bc__svo_domain_region(const struct bc_svo_rpn *r, uint32_t d,
                           const struct bc_svo_region *rg,
                           struct bc_svo_region *out)
{
	uint32_t chain[BC_DOMAIN_MAX_CHAIN];
	uint32_t n = 0;
	double lo[3], hi[3];
	for (int i = 0; i < 3; i++) {
		if (rg->segment) {
			double a = (double)rg->o[i] + (double)rg->t0 * rg->d[i];
			double b = (double)rg->o[i] + (double)rg->t1 * rg->d[i];
			lo[i] = bc__dmin(a, b);
			hi[i] = bc__dmax(a, b);
		} else {
			lo[i] = rg->lo[i];
			hi[i] = rg->hi[i];
		}
	}
	for (; d != BC_NONE && n < BC_DOMAIN_MAX_CHAIN; d = r->udom[d]) {
		chain[n++] = d;
	}
	while (n-- > 0) {
		domain_box(r->ukind[chain[n]],
		           r->urec + (size_t)chain[n] * BC_SVO_UNARY_REC, lo,
		           hi);
	}
	memset(out, 0, sizeof(*out));
	for (int i = 0; i < 3; i++) {
		/* Outward to float. */
		out->lo[i] = (float)lo[i];
		out->hi[i] = (float)hi[i];
		if ((double)out->lo[i] > lo[i]) {
			out->lo[i] = nextafterf(out->lo[i], -INFINITY);
		}
		if ((double)out->hi[i] < hi[i]) {
			out->hi[i] = nextafterf(out->hi[i], INFINITY);
		}
	}
}

/* Twist's and bend's own Lipschitz bound at distance r from the axis, in
 * double (blobtree's bc_unary_own_lip). */
static double own_lip(uint32_t kind, double rate, double r)
{
	double m = fabs(rate) * r;
	return kind == BC_OP_TWIST ? 0.5 * (m + sqrt(m * m + 4.0)) : 1.0 + m;
}

struct bc_svo_ivl bc__svo_unary_range(const struct bc_svo_rpn *r, uint32_t u,
                                      struct bc_svo_ivl a,
                                      const struct bc_svo_region *rg)
{
	const float *rec = r->urec + (size_t)u * BC_SVO_UNARY_REC;
	double m = bc__dmax(fabs(a.lo), fabs(a.hi)), mg;
	struct bc_svo_ivl v = a;
	if (!isfinite(m)) {
		m = 0.0; /* an infinite bound needs no widening */
	}
	mg = BC__SVO_ROUND_REL * (m + fabs((double)rec[0])) + BC__SVO_ROUND_ABS;
	switch (r->ukind[u]) {
	case BC_OP_OFFSET:
		v.lo = a.lo - rec[0] - mg;
		v.hi = a.hi - rec[0] + mg;
		break;
	case BC_OP_ONION: {
		double alo = a.lo >= 0.0 ? a.lo : (a.hi <= 0.0 ? -a.hi : 0.0);
		double ahi = bc__dmax(fabs(a.lo), fabs(a.hi));
		v.lo = alo - rec[0] - mg;
		v.hi = ahi - rec[0] + mg;
		break;
	}
	case BC_OP_SCALE:
		mg = BC__SVO_ROUND_REL * m * rec[0] + BC__SVO_ROUND_ABS;
		v.lo = a.lo * rec[0] - mg;
		v.hi = a.hi * rec[0] + mg;
		break;
	case BC_OP_TWIST:
	case BC_OP_BEND: {
		/* f L(R) / L(r) beyond the radius R where f > 0, else f: a
		 * factor in [L(R) / L(r_max), 1], r_max the farthest the
		 * region's points (in the node's input frame) are from its
		 * axis. */
		struct bc_svo_region q;
		double rx, ry, rmax, ratio;
		bc__svo_domain_region(r, r->udom[u], rg, &q);
		rx = bc__dmax(fabs((double)q.lo[0]), fabs((double)q.hi[0]));
		ry =
		    r->ukind[u] == BC_OP_TWIST
		        ? bc__dmax(fabs((double)q.lo[2]), fabs((double)q.hi[2]))
		        : bc__dmax(fabs((double)q.lo[1]),
		                   fabs((double)q.hi[1]));
		rmax = bc__dmax(sqrt(rx * rx + ry * ry), (double)rec[1]);
		ratio = own_lip(r->ukind[u], rec[0], rec[1]) /
		        own_lip(r->ukind[u], rec[0], rmax) * (1.0 - 1.0e-5);
		mg = 4.0 * BC__SVO_ROUND_REL * m + BC__SVO_ROUND_ABS;
		v.lo = (a.lo > 0.0 ? a.lo * ratio : a.lo) - mg;
		v.hi = a.hi + mg;
		break;
	}
	default:
		break;
	}
	return v;
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
	g->dom_d = BC_NONE;
	g->ivl = bc_calloc(r->n, sizeof(*g->ivl));
	g->kid0 = bc_calloc(r->n, sizeof(*g->kid0));
	g->kid1 = bc_calloc(r->n, sizeof(*g->kid1));
	g->idx = bc_calloc(r->n, sizeof(*g->idx));
	g->mark = bc_calloc(r->n, sizeof(*g->mark));
	g->mode = bc_calloc(r->n, sizeof(*g->mode));
	g->lev = bc_calloc(r->n, sizeof(*g->lev));
	if (!g->ivl || !g->kid0 || !g->kid1 || !g->idx || !g->mark ||
	    !g->mode || !g->lev) {
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
	bc_free(g->lev);
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
