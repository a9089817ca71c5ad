/*
 * Affine arithmetic (thesis §4.3, after Stolfi and de Figueiredo): a range is
 * x0 + sum x_i e_i over noise symbols shared between forms; every non-affine
 * operation adds a fresh symbol for its approximation error. Forms live in
 * the ranger's arena, used as a stack: a computation marks the top, builds
 * its temporaries, and keeps only its result (f_mark / f_keep), so the arena
 * holds the evaluation stack's forms and one computation's scratch.
 *
 * A form whose length passes BC_SVO_AA_MAX_TERMS is condensed: every symbol
 * but the region's own three is folded into one fresh symbol (sound, and it
 * keeps the cost of a long union chain linear). A form that cannot get
 * arena space (never expected: the arena is sized for the worst case) is the
 * whole real line, marked by a NaN centre. Products and non-affine functions
 * use the same approximations as revaa.c; computed in double (svo_impl.h).
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

#define RT struct bc__aa

/* Noise symbols 1..3 are the region's (box axes, or the segment's t on 1). */
#define AA_INPUT_SYMBOLS 3u

static inline RT whole(void)
{
	RT r = {NAN, 0, 0};
	return r;
}

static inline bool is_whole(RT a)
{
	return a.c != a.c;
}

/* n arena slots, or UINT32_MAX when the arena is full. */
static inline uint32_t alloc(struct bc_svo_ranger *g, uint32_t n)
{
	uint32_t off = g->aa_top;
	if (n > g->aa_cap - off) {
		return UINT32_MAX;
	}
	g->aa_top = off + n;
	return off;
}

static inline RT f_const(struct bc_svo_ranger *g, double v)
{
	RT r = {v, g->aa_top, 0};
	return r;
}

static inline RT f_from(struct bc_svo_ranger *g, double lo, double hi)
{
	RT r;
	if (!isfinite(lo) || !isfinite(hi)) {
		return whole();
	}
	r.c = 0.5 * (lo + hi);
	r.n = 1;
	r.off = alloc(g, 1);
	if (r.off == UINT32_MAX) {
		return whole();
	}
	g->aa_sym[r.off] = g->aa_next++;
	g->aa_coef[r.off] = 0.5 * (hi - lo);
	return r;
}

static inline double rad(const struct bc_svo_ranger *g, RT a)
{
	double r = 0.0;
	for (uint32_t i = 0; i < a.n; i++) {
		r += fabs(g->aa_coef[a.off + i]);
	}
	return r;
}

static inline struct bc_svo_ivl f_range(struct bc_svo_ranger *g, RT a)
{
	struct bc_svo_ivl v = {-INFINITY, INFINITY};
	double r;
	if (is_whole(a)) {
		return v;
	}
	r = rad(g, a);
	if (r == r) {
		v.lo = a.c - r;
		v.hi = a.c + r;
	}
	return v;
}

/* sa a + sb b (+ a fresh symbol of coefficient extra, when non-zero). */
static RT combine(struct bc_svo_ranger *g, RT a, double sa, RT b, double sb,
                  double extra)
{
	RT r;
	uint32_t i = 0, j = 0, k;
	if (is_whole(a) || is_whole(b) || !isfinite(extra)) {
		return whole();
	}
	r.off = alloc(g, a.n + b.n + 1u);
	if (r.off == UINT32_MAX) {
		return whole();
	}
	r.c = sa * a.c + sb * b.c;
	k = r.off;
	while (i < a.n || j < b.n) {
		uint32_t s1 = i < a.n ? g->aa_sym[a.off + i] : UINT32_MAX;
		uint32_t s2 = j < b.n ? g->aa_sym[b.off + j] : UINT32_MAX;
		if (s1 == s2) {
			g->aa_sym[k] = s1;
			g->aa_coef[k++] = sa * g->aa_coef[a.off + i++] +
			                  sb * g->aa_coef[b.off + j++];
		} else if (s1 < s2) {
			g->aa_sym[k] = s1;
			g->aa_coef[k++] = sa * g->aa_coef[a.off + i++];
		} else {
			g->aa_sym[k] = s2;
			g->aa_coef[k++] = sb * g->aa_coef[b.off + j++];
		}
	}
	if (extra != 0.0) {
		/* Fresh symbols are the largest yet: order is kept. */
		g->aa_sym[k] = g->aa_next++;
		g->aa_coef[k++] = fabs(extra);
	}
	r.n = k - r.off;
	g->aa_top = k;
	return r;
}

static inline RT f_add(struct bc_svo_ranger *g, RT a, RT b)
{
	return combine(g, a, 1.0, b, 1.0, 0.0);
}

static inline RT f_sub(struct bc_svo_ranger *g, RT a, RT b)
{
	return combine(g, a, 1.0, b, -1.0, 0.0);
}

static inline RT f_scale(struct bc_svo_ranger *g, RT a, double s)
{
	return combine(g, a, s, f_const(g, 0.0), 0.0, 0.0);
}

static inline RT f_neg(struct bc_svo_ranger *g, RT a)
{
	return f_scale(g, a, -1.0);
}

static inline RT f_addc(struct bc_svo_ranger *g, RT a, double c)
{
	(void)g;
	a.c += c; /* shares a's terms: forms are never written after */
	return a;
}

static inline RT f_add_ivl(struct bc_svo_ranger *g, RT a, double lo, double hi)
{
	RT r = combine(g, a, 1.0, f_const(g, 0.0), 0.0, 0.5 * (hi - lo));
	r.c += 0.5 * (lo + hi);
	return r;
}

/* alpha a + zeta +- delta. */
static inline RT cheb(struct bc_svo_ranger *g, RT a, double alpha, double zeta,
                      double delta)
{
	RT r = combine(g, a, alpha, f_const(g, 0.0), 0.0, delta);
	r.c += zeta;
	return r;
}

static inline RT f_mul(struct bc_svo_ranger *g, RT a, RT b)
{
	/* a0 b0 + a0 (b - b0) + b0 (a - a0) + rad(a) rad(b) e_new */
	RT r;
	if (is_whole(a) || is_whole(b)) {
		return whole();
	}
	r = combine(g, a, b.c, b, a.c, rad(g, a) * rad(g, b));
	r.c = a.c * b.c;
	return r;
}

static inline RT f_sqr(struct bc_svo_ranger *g, RT a)
{
	/* (a0 + u)^2 = a0^2 + 2 a0 u + u^2, u^2 in [0, rad^2]. */
	double r2;
	RT r;
	if (is_whole(a)) {
		return whole();
	}
	r2 = rad(g, a) * rad(g, a);
	r = combine(g, a, 2.0 * a.c, f_const(g, 0.0), 0.0, 0.5 * r2);
	r.c = a.c * a.c + 0.5 * r2;
	return r;
}

static inline RT f_sqrt(struct bc_svo_ranger *g, RT a)
{
	struct bc_svo_ivl v = f_range(g, a);
	double lo = bc__dmax(v.lo, 0.0), hi = bc__dmax(v.hi, 0.0), alpha, d1,
	       d2;
	if (!isfinite(hi)) {
		return whole();
	}
	if (hi - lo <= 1.0e-12 * hi || hi <= 0.0) {
		return f_from(g, sqrt(lo), sqrt(hi));
	}
	alpha = (sqrt(hi) - sqrt(lo)) / (hi - lo);
	d1 = sqrt(lo) - alpha * lo;
	d2 = 0.25 / alpha;
	return cheb(g, a, alpha, 0.5 * (d1 + d2), 0.5 * (d2 - d1));
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
		return whole();
	}
	alpha = (v.hi + v.lo) / (v.hi - v.lo);
	d = -2.0 * v.lo * v.hi / (v.hi - v.lo);
	return cheb(g, a, alpha, 0.5 * d, 0.5 * d);
}

static inline RT f_recip(struct bc_svo_ranger *g, RT a)
{
	struct bc_svo_ivl v = f_range(g, a);
	double lo, hi, alpha, dt, de;
	bool neg = v.hi < 0.0;
	if (!(v.lo > 0.0 || v.hi < 0.0) || !isfinite(v.lo) || !isfinite(v.hi)) {
		return whole();
	}
	lo = neg ? -v.hi : v.lo;
	hi = neg ? -v.lo : v.hi;
	if (hi - lo <= 1.0e-12 * hi) {
		return neg ? f_from(g, -1.0 / lo, -1.0 / hi)
		           : f_from(g, 1.0 / hi, 1.0 / lo);
	}
	alpha = -1.0 / (lo * hi);
	de = 1.0 / lo + 1.0 / hi;
	dt = 2.0 / sqrt(lo * hi);
	if (neg) {
		return f_neg(g, cheb(g, f_neg(g, a), alpha, 0.5 * (dt + de),
		                     0.5 * (de - dt)));
	}
	return cheb(g, a, alpha, 0.5 * (dt + de), 0.5 * (de - dt));
}

#include "range_affine.h"

static void f_input(struct bc_svo_ranger *g, const struct bc_svo_region *rg,
                    RT p[3])
{
	double tm = 0.5 * ((double)rg->t0 + rg->t1);
	double tr = 0.5 * ((double)rg->t1 - rg->t0);
	for (int i = 0; i < 3; i++) {
		uint32_t off = alloc(g, 1);
		if (off == UINT32_MAX) {
			p[i] = whole();
			continue;
		}
		p[i].off = off;
		p[i].n = 1;
		if (rg->segment) {
			p[i].c = (double)rg->o[i] + tm * rg->d[i];
			g->aa_sym[off] = 1;
			g->aa_coef[off] = tr * rg->d[i];
		} else {
			p[i].c = 0.5 * ((double)rg->lo[i] + rg->hi[i]);
			g->aa_sym[off] = 1u + (uint32_t)i;
			g->aa_coef[off] = 0.5 * ((double)rg->hi[i] - rg->lo[i]);
		}
	}
}

static inline uint32_t f_mark(struct bc_svo_ranger *g)
{
	return g->aa_top;
}

/* Moves a's terms down to mark, releasing everything above, and condenses
 * a form that grew past the cap. */
static RT f_keep(struct bc_svo_ranger *g, uint32_t mark, RT a)
{
	if (is_whole(a)) {
		g->aa_top = mark;
		return a;
	}
	if (a.off != mark) {
		memmove(g->aa_sym + mark, g->aa_sym + a.off,
		        a.n * sizeof(*g->aa_sym));
		memmove(g->aa_coef + mark, g->aa_coef + a.off,
		        a.n * sizeof(*g->aa_coef));
		a.off = mark;
	}
	if (a.n > BC_SVO_AA_MAX_TERMS) {
		uint32_t k = 0;
		double folded = 0.0;
		for (uint32_t i = 0; i < a.n; i++) {
			uint32_t s = g->aa_sym[a.off + i];
			if (s <= AA_INPUT_SYMBOLS) {
				g->aa_sym[a.off + k] = s;
				g->aa_coef[a.off + k++] = g->aa_coef[a.off + i];
			} else {
				folded += fabs(g->aa_coef[a.off + i]);
			}
		}
		g->aa_sym[a.off + k] = g->aa_next++;
		g->aa_coef[a.off + k++] = folded;
		a.n = k;
	}
	g->aa_top = mark + a.n;
	return a;
}

/* Primitives fall back on the interval extension where it is narrower. */
#define RP_INTERVAL_FALLBACK 1
#include "range_tmpl.h"

struct bc_svo_ivl bc__svo_aa_run(struct bc_svo_ranger *g, const uint32_t *idx,
                                 uint32_t n, const struct bc_svo_region *rg)
{
	g->aa_top = 0;
	g->aa_next = AA_INPUT_SYMBOLS + 1u;
	return t_run(g, idx, n, rg);
}

struct bc_svo_ivl bc__svo_aa_prim(struct bc_svo_ranger *g, uint32_t term,
                                  const struct bc_svo_region *rg)
{
	g->aa_top = 0;
	g->aa_next = AA_INPUT_SYMBOLS + 1u;
	return t_prim_only(g, term, rg);
}
