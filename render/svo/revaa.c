/*
 * Revised affine arithmetic (thesis §4.3, after Vu et al.): a range is
 * x0 + x1 e1 + x2 e2 + x3 e3 + e [-1, 1], the three noise symbols being the
 * region's own (the box's three axes, or the segment's parameter on e1) and
 * e the magnitude of every error made since. Forms have fixed size, so every
 * operation costs O(1).
 *
 * Multiplication follows eq. 4.15-4.16. Non-affine functions of one argument
 * use their Chebyshev (minimax) linear approximation over the argument's
 * range, alpha x + zeta +- delta, and fold delta into e. Computed in double;
 * see svo_impl.h for the rounding margin.
 */
#include "svo_impl.h"

#include <math.h>

#define RT struct bc__rev

static inline RT f_const(struct bc_svo_ranger *g, double v)
{
	RT r = {v, {0.0, 0.0, 0.0}, 0.0};
	(void)g;
	return r;
}

static inline RT f_from(struct bc_svo_ranger *g, double lo, double hi)
{
	RT r = {0.5 * (lo + hi), {0.0, 0.0, 0.0}, 0.5 * (hi - lo)};
	(void)g;
	if (!isfinite(r.c) || !isfinite(r.e)) {
		r.c = 0.0;
		r.e = INFINITY;
	}
	return r;
}

static inline double radius(const RT *a)
{
	return fabs(a->x[0]) + fabs(a->x[1]) + fabs(a->x[2]) + a->e;
}

static inline struct bc_svo_ivl f_range(struct bc_svo_ranger *g, RT a)
{
	double r = radius(&a);
	struct bc_svo_ivl v = {a.c - r, a.c + r};
	(void)g;
	return v;
}

static inline RT f_add(struct bc_svo_ranger *g, RT a, RT b)
{
	(void)g;
	a.c += b.c;
	for (int i = 0; i < 3; i++) {
		a.x[i] += b.x[i];
	}
	a.e += b.e;
	return a;
}

static inline RT f_neg(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	a.c = -a.c;
	for (int i = 0; i < 3; i++) {
		a.x[i] = -a.x[i];
	}
	return a;
}

static inline RT f_sub(struct bc_svo_ranger *g, RT a, RT b)
{
	return f_add(g, a, f_neg(g, b));
}

static inline RT f_addc(struct bc_svo_ranger *g, RT a, double c)
{
	(void)g;
	a.c += c;
	return a;
}

static inline RT f_scale(struct bc_svo_ranger *g, RT a, double s)
{
	(void)g;
	a.c *= s;
	for (int i = 0; i < 3; i++) {
		a.x[i] *= s;
	}
	a.e *= fabs(s);
	return a;
}

static inline RT f_add_ivl(struct bc_svo_ranger *g, RT a, double lo, double hi)
{
	(void)g;
	a.c += 0.5 * (lo + hi);
	a.e += 0.5 * (hi - lo);
	return a;
}

/* Eq. 4.15-4.16. */
static inline RT f_mul(struct bc_svo_ranger *g, RT a, RT b)
{
	RT r;
	double u = 0.0, v = 0.0, half = 0.0, habs = 0.0;
	(void)g;
	if (!isfinite(a.e) || !isfinite(b.e)) {
		return f_from(g, -INFINITY, INFINITY);
	}
	for (int i = 0; i < 3; i++) {
		u += fabs(a.x[i]);
		v += fabs(b.x[i]);
		half += a.x[i] * b.x[i];
		habs += fabs(a.x[i] * b.x[i]);
		r.x[i] = a.c * b.x[i] + b.c * a.x[i];
	}
	r.c = a.c * b.c + 0.5 * half;
	r.e = a.e * b.e + b.e * (fabs(a.c) + u) + a.e * (fabs(b.c) + v) +
	      u * v - 0.5 * habs;
	return r;
}

static inline RT f_sqr(struct bc_svo_ranger *g, RT a)
{
	return f_mul(g, a, a);
}

/* alpha a + zeta +- delta. */
static inline RT cheb(RT a, double alpha, double zeta, double delta)
{
	RT r;
	r.c = alpha * a.c + zeta;
	for (int i = 0; i < 3; i++) {
		r.x[i] = alpha * a.x[i];
	}
	r.e = fabs(alpha) * a.e + delta;
	return r;
}

static inline RT f_sqrt(struct bc_svo_ranger *g, RT a)
{
	struct bc_svo_ivl v = f_range(g, a);
	double lo = bc__dmax(v.lo, 0.0), hi = bc__dmax(v.hi, 0.0), alpha, d1,
	       d2;
	if (!isfinite(hi)) {
		return f_from(g, sqrt(lo), INFINITY);
	}
	if (hi - lo <= 1.0e-12 * hi || hi <= 0.0) {
		return f_from(g, sqrt(lo), sqrt(hi));
	}
	/* Concave: the chord lies below; the tangent of the chord's slope
	 * touches at u = 1 / (4 alpha^2), where sqrt(u) - alpha u = 1/(4a). */
	alpha = (sqrt(hi) - sqrt(lo)) / (hi - lo);
	d1 = sqrt(lo) - alpha * lo;
	d2 = 0.25 / alpha;
	return cheb(a, alpha, 0.5 * (d1 + d2), 0.5 * (d2 - d1));
}

static inline RT f_abs(struct bc_svo_ranger *g, RT a)
{
	struct bc_svo_ivl v = f_range(g, a);
	double alpha, d;
	if (v.lo >= 0.0) {
		return a;
	}
	if (v.hi <= 0.0) {
		return f_neg(g, a);
	}
	if (!isfinite(v.lo) || !isfinite(v.hi)) {
		return f_from(g, 0.0, INFINITY);
	}
	/* Convex: |x| - alpha x is 0 at 0 and d at both ends. */
	alpha = (v.hi + v.lo) / (v.hi - v.lo);
	d = -2.0 * v.lo * v.hi / (v.hi - v.lo);
	return cheb(a, alpha, 0.5 * d, 0.5 * d);
}

static inline RT f_recip(struct bc_svo_ranger *g, RT a)
{
	struct bc_svo_ivl v = f_range(g, a);
	double lo, hi, alpha, dt, de;
	bool neg = v.hi < 0.0;
	if (!(v.lo > 0.0 || v.hi < 0.0) || !isfinite(v.lo) || !isfinite(v.hi)) {
		return f_from(g, -INFINITY, INFINITY);
	}
	lo = neg ? -v.hi : v.lo;
	hi = neg ? -v.lo : v.hi;
	if (hi - lo <= 1.0e-12 * hi) {
		return neg ? f_from(g, -1.0 / lo, -1.0 / hi)
		           : f_from(g, 1.0 / hi, 1.0 / lo);
	}
	/* Convex and decreasing on [lo, hi]: chord above, tangent of the
	 * chord's slope at sqrt(lo hi). */
	alpha = -1.0 / (lo * hi);
	de = 1.0 / lo + 1.0 / hi;
	dt = 2.0 / sqrt(lo * hi);
	if (neg) {
		/* 1/x = -(1/(-x)). */
		RT r =
		    cheb(f_neg(g, a), alpha, 0.5 * (dt + de), 0.5 * (de - dt));
		return f_neg(g, r);
	}
	return cheb(a, alpha, 0.5 * (dt + de), 0.5 * (de - dt));
}

#include "range_affine.h"

static void f_input(struct bc_svo_ranger *g, const struct bc_svo_region *rg,
                    RT p[3])
{
	double tm = 0.5 * ((double)rg->t0 + rg->t1);
	double tr = 0.5 * ((double)rg->t1 - rg->t0);
	(void)g;
	for (int i = 0; i < 3; i++) {
		p[i] = f_const(g, 0.0);
		if (rg->segment) {
			p[i].c = (double)rg->o[i] + tm * rg->d[i];
			p[i].x[0] = tr * rg->d[i];
		} else {
			p[i].c = 0.5 * ((double)rg->lo[i] + rg->hi[i]);
			p[i].x[i] = 0.5 * ((double)rg->hi[i] - rg->lo[i]);
		}
	}
}

static inline uint32_t f_mark(struct bc_svo_ranger *g)
{
	(void)g;
	return 0;
}

static inline RT f_keep(struct bc_svo_ranger *g, uint32_t mark, RT a)
{
	(void)g;
	(void)mark;
	return a;
}

/* Primitives fall back on the interval extension where it is narrower. */
#define RP_INTERVAL_FALLBACK 1
#include "range_tmpl.h"

struct bc_svo_ivl bc__svo_rev_run(struct bc_svo_ranger *g, const uint32_t *idx,
                                  uint32_t n, const struct bc_svo_region *rg)
{
	return t_run(g, idx, n, rg);
}

struct bc_svo_ivl bc__svo_rev_prim(struct bc_svo_ranger *g, uint32_t term,
                                   const struct bc_svo_region *rg)
{
	return t_prim_only(g, term, rg);
}
