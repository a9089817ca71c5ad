/*
 * Interval arithmetic (thesis §4.3): a range is its bounds. Computed in
 * double precision; svo_impl.h's rounding margin, applied by the template to
 * every primitive and blending operator, makes the bounds enclose the single
 * precision evaluator's values. The operations here are the classic ones;
 * products involving an infinite bound and zero count as zero, the limit
 * that interval semantics gives them.
 */
#include "svo_impl.h"

#include <math.h>

#define RT struct bc_svo_ivl

static inline RT mk(double lo, double hi)
{
	RT r = {lo, hi};
	return r;
}

static inline RT f_const(struct bc_svo_ranger *g, double v)
{
	(void)g;
	return mk(v, v);
}

static inline RT f_from(struct bc_svo_ranger *g, double lo, double hi)
{
	(void)g;
	return mk(lo, hi);
}

static inline struct bc_svo_ivl f_range(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	return a;
}

static inline RT f_add(struct bc_svo_ranger *g, RT a, RT b)
{
	(void)g;
	return mk(a.lo + b.lo, a.hi + b.hi);
}

static inline RT f_sub(struct bc_svo_ranger *g, RT a, RT b)
{
	(void)g;
	return mk(a.lo - b.hi, a.hi - b.lo);
}

static inline RT f_neg(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	return mk(-a.hi, -a.lo);
}

static inline RT f_addc(struct bc_svo_ranger *g, RT a, double c)
{
	(void)g;
	return mk(a.lo + c, a.hi + c);
}

static inline RT f_scale(struct bc_svo_ranger *g, RT a, double s)
{
	(void)g;
	if (s == 0.0) {
		return mk(0.0, 0.0);
	}
	return s > 0.0 ? mk(a.lo * s, a.hi * s) : mk(a.hi * s, a.lo * s);
}

static inline RT f_add_ivl(struct bc_svo_ranger *g, RT a, double lo, double hi)
{
	(void)g;
	return mk(a.lo + lo, a.hi + hi);
}

static inline double prod(double x, double y)
{
	double p = x * y;
	return p == p ? p : 0.0; /* 0 * inf */
}

static inline RT f_mul(struct bc_svo_ranger *g, RT a, RT b)
{
	double p0 = prod(a.lo, b.lo), p1 = prod(a.lo, b.hi);
	double p2 = prod(a.hi, b.lo), p3 = prod(a.hi, b.hi);
	(void)g;
	return mk(bc__dmin(bc__dmin(p0, p1), bc__dmin(p2, p3)),
	          bc__dmax(bc__dmax(p0, p1), bc__dmax(p2, p3)));
}

static inline RT f_sqr(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	if (a.lo >= 0.0) {
		return mk(a.lo * a.lo, a.hi * a.hi);
	}
	if (a.hi <= 0.0) {
		return mk(a.hi * a.hi, a.lo * a.lo);
	}
	return mk(0.0, bc__dmax(a.lo * a.lo, a.hi * a.hi));
}

static inline RT f_sqrt(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	return mk(sqrt(bc__dmax(a.lo, 0.0)), sqrt(bc__dmax(a.hi, 0.0)));
}

static inline RT f_abs(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	if (a.lo >= 0.0) {
		return a;
	}
	if (a.hi <= 0.0) {
		return mk(-a.hi, -a.lo);
	}
	return mk(0.0, bc__dmax(-a.lo, a.hi));
}

static inline RT f_min(struct bc_svo_ranger *g, RT a, RT b)
{
	(void)g;
	return mk(bc__dmin(a.lo, b.lo), bc__dmin(a.hi, b.hi));
}

static inline RT f_max(struct bc_svo_ranger *g, RT a, RT b)
{
	(void)g;
	return mk(bc__dmax(a.lo, b.lo), bc__dmax(a.hi, b.hi));
}

static inline RT f_recip(struct bc_svo_ranger *g, RT a)
{
	(void)g;
	if (a.lo > 0.0 || a.hi < 0.0) {
		return mk(1.0 / a.hi, 1.0 / a.lo);
	}
	return mk(-INFINITY, INFINITY);
}

static void f_input(struct bc_svo_ranger *g, const struct bc_svo_region *rg,
                    RT p[3])
{
	(void)g;
	for (int i = 0; i < 3; i++) {
		if (rg->segment) {
			double a = (double)rg->o[i] + (double)rg->t0 * rg->d[i];
			double b = (double)rg->o[i] + (double)rg->t1 * rg->d[i];
			p[i] = mk(bc__dmin(a, b), bc__dmax(a, b));
		} else {
			p[i] = mk(rg->lo[i], rg->hi[i]);
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

#define RP_INTERVAL_FALLBACK 0
#include "range_tmpl.h"

struct bc_svo_ivl bc__svo_ia_natural(struct bc_svo_ranger *g,
                                     const struct bc_svo_term *t,
                                     const struct bc_svo_region *rg)
{
	const float *rec = g->rpn->rec + t->rec;
	RT p[3], loc[3], f;
	f_input(g, rg, p);
	for (int k = 0; k < 3; k++) {
		loc[k] = t_local(g, rec, k, p);
	}
	if (!t_natural(g, (enum bc_prim)t->kind, rec + 12, loc, &f)) {
		return mk(-INFINITY, INFINITY);
	}
	return f;
}

struct bc_svo_ivl bc__svo_ia_run(struct bc_svo_ranger *g, const uint32_t *idx,
                                 uint32_t n, const struct bc_svo_region *rg)
{
	return t_run(g, idx, n, rg);
}

struct bc_svo_ivl bc__svo_ia_prim(struct bc_svo_ranger *g, uint32_t term,
                                  const struct bc_svo_region *rg)
{
	return t_prim_only(g, term, rg);
}
