/*
 * The range evaluation written once for the three arithmetics. ia.c, aa.c
 * and revaa.c each define a form type RT and the operations below, then
 * include this file, which builds on them: the world-to-local transform,
 * the primitives' range forms, the operators', and the bottom-up stack
 * evaluation of a variant (thesis Alg. 5.4, first half).
 *
 * Operations each arithmetic provides (g is the struct bc_svo_ranger):
 *   RT f_const(g, double v);            RT f_from(g, lo, hi);
 *   struct bc_svo_ivl f_range(g, RT a);
 *   RT f_add(g, a, b); f_sub; f_neg(g, a); f_addc(g, a, c); f_scale(g, a, s);
 *   RT f_add_ivl(g, a, lo, hi);        a plus an independent [lo, hi]
 *   RT f_mul(g, a, b); f_sqr(g, a); f_sqrt(g, a); f_abs(g, a);
 *   RT f_min(g, a, b); f_max(g, a, b);
 *   RT f_recip(g, a);                   for ranges not containing 0
 *   void f_input(g, const struct bc_svo_region *rg, RT p[3]);
 *   uint32_t f_mark(g);  RT f_keep(g, uint32_t mark, RT a);
 * f_mark/f_keep let AA release the temporaries of a computation, keeping
 * its result; the other arithmetics ignore them.
 */
#ifndef BLOBCAST_SVO_RANGE_TMPL_H
#define BLOBCAST_SVO_RANGE_TMPL_H

#include "range_prims.h"

/* Local coordinate k of a primitive record: row k of the world-to-local
 * map applied to the world forms. */
static inline RT t_local(struct bc_svo_ranger *g, const float *rec, int k,
                         const RT p[3])
{
	const float *row = rec + 4 * k;
	RT v = f_scale(g, p[0], row[0]);
	v = f_add(g, v, f_scale(g, p[1], row[1]));
	v = f_add(g, v, f_scale(g, p[2], row[2]));
	return f_addc(g, v, row[3]);
}

static inline double t_mag(struct bc_svo_ivl v)
{
	return bc__dmax(fabs(v.lo), fabs(v.hi));
}

/* Range form of primitive term t over the region whose world forms are p
 * and geometry geo. */
static RT t_prim(struct bc_svo_ranger *g, const struct bc_svo_term *t,
                 const RT p[3], const struct bc__svo_geo *geo,
                 const struct bc_svo_region *rg)
{
	const struct bc_svo_rpn *r = g->rpn;
	const float *rec = r->rec + t->rec;
	const float *pk = rec + 12;
	enum bc_prim kind = (enum bc_prim)t->kind;
	RT loc[3], f = f_const(g, 0.0);
	double scale = 0.0, margin;
	bool natural;
	if (r->prim_dom && r->prim_dom[t->prim] != BC_NONE && !g->in_domain) {
		/* Under domain nodes the primitive sees the region mapped
		 * through them: its interval range over a box holding that
		 * image (range.c), as a fresh form (the maps are not affine:
		 * folds, clamps, rotations by a varying angle). */
		struct bc_svo_ivl v;
		if (g->dom_d != r->prim_dom[t->prim]) {
			g->dom_d = r->prim_dom[t->prim];
			bc__svo_domain_region(r, g->dom_d, rg, &g->dom_q);
		}
		g->in_domain = true;
		v = bc__svo_ia_prim(g, (uint32_t)(t - r->terms), &g->dom_q);
		g->in_domain = false;
		return f_from(g, v.lo, v.hi);
	}
	for (int k = 0; k < 3; k++) {
		loc[k] = t_local(g, rec, k, p);
		scale = bc__dmax(scale, t_mag(f_range(g, loc[k])));
	}
	/* Lengths of the field are the point's distance from the local
	 * origin and the primitive's own size (not its packed floats: some
	 * are reciprocals, large for small shapes). An infinite or NaN size
	 * (a degenerate ABV) falls back on the packed floats. */
	if (isfinite(r->prim_size[t->prim])) {
		scale += (double)r->prim_size[t->prim];
	} else {
		for (uint32_t k = 0; k < BC_PRIM_PACKED; k++) {
			scale = bc__dmax(scale, fabs((double)pk[k]));
		}
	}
	margin = BC__SVO_ROUND_REL * scale + BC__SVO_ROUND_ABS;
	natural = !bc_svo_prim_uses_lipschitz(kind) &&
	          RP_NATURAL(g, kind, pk, loc, &f);
#if RP_INTERVAL_FALLBACK
	if (natural) {
		/* Distance formulas are made of kinks (|x|, max(x, 0)) that
		 * affine forms straddle badly over any region the size of a
		 * feature; the interval extension of the same formula is then
		 * tighter. Keep the form only while it is the narrower. */
		struct bc_svo_ivl iv = bc__svo_ia_natural(g, t, rg);
		struct bc_svo_ivl fv = f_range(g, f);
		if (iv.hi - iv.lo < fv.hi - fv.lo) {
			f = f_from(g, iv.lo, iv.hi);
		}
	}
#else
	(void)rg;
#endif
	if (bc__svo_prim_exact(kind)) {
		/* An exact SDF is 1-Lipschitz: f(region) lies within the
		 * radius of its value at the centre. Rigid transforms keep
		 * distances, so the world radius holds in local space. */
		/* The centre of the region in the primitive's own frame
		 * (of the mapped box under domain nodes). */
		float v = bc__svo_prim_eval_at(r, t, geo->c);
		double rad = geo->radius + margin;
		if (!isfinite(v)) {
			return f_from(g, -INFINITY, INFINITY);
		}
		if (natural) {
			struct bc_svo_ivl nv = f_range(g, f);
			/* Keep the natural form (its correlations) unless the
			 * Lipschitz interval is narrower. */
			if (nv.hi - nv.lo + 2.0 * margin <= 2.0 * rad) {
				return f_add_ivl(g, f, -margin, margin);
			}
		}
		return f_from(g, (double)v - rad, (double)v + rad);
	}
	if (natural) {
		return f_add_ivl(g, f, -margin, margin);
	}
	/* No sound enclosure is known: the whole line. */
	return f_from(g, -INFINITY, INFINITY);
}

/* Range form of operator term t on operand forms a, b with recorded
 * intervals ia, ib; *out gets the interval to record. */
static RT t_op(struct bc_svo_ranger *g, const struct bc_svo_term *t, RT a, RT b,
               struct bc_svo_ivl ia, struct bc_svo_ivl ib,
               struct bc_svo_ivl *out)
{
	const float *rec = g->rpn->rec + t->rec;
	enum bc_op k = (enum bc_op)t->kind;
	bool uni = k == BC_OP_UNION || k == BC_OP_SMOOTH_UNION;
	struct bc_svo_ivl box = bc_svo_range_op(k, rec[0], rec[1], ia, ib);
	RT m = uni ? f_min(g, a, b) : f_max(g, a, b);
	if (bc_op_is_smooth(k) &&
	    !bc__svo_op_sharp_in(k, rec[0], rec[1], ia, ib)) {
		struct bc_svo_ivl mi = f_range(g, m);
		double amax =
		    bc__svo_op_blend_bound(k, rec[0], rec[1], mi, ia, ib);
		double mg = bc__svo_op_margin((double)rec[0] + amax, mi);
		m = uni ? f_add_ivl(g, m, -amax - mg, mg)
		        : f_add_ivl(g, m, -mg, amax + mg);
	}
	*out = bc__svo_ivl_meet(f_range(g, m), box);
	return m;
}

/* Bottom-up evaluation of the variant idx[0..n) over rg; records every
 * term's range and operands in g. */
static struct bc_svo_ivl t_run(struct bc_svo_ranger *g, const uint32_t *idx,
                               uint32_t n, const struct bc_svo_region *rg)
{
	const struct bc_svo_rpn *r = g->rpn;
	RT st[BC_EVAL_STACK];
	uint32_t si[BC_EVAL_STACK];
	uint32_t mk[BC_EVAL_STACK];
	RT p[3];
	struct bc__svo_geo geo;
	uint32_t sp = 0;
	bc__svo_geo_init(&geo, rg);
	f_input(g, rg, p);
	g->dom_d = BC_NONE; /* a new region */
	for (uint32_t k = 0; k < n; k++) {
		uint32_t i = idx[k];
		const struct bc_svo_term *t = &r->terms[i];
		switch (t->type) {
		case BC_SVO_TERM_PRIM: {
			uint32_t m0 = f_mark(g);
			RT f = t_prim(g, t, p, &geo, rg);
			st[sp] = f_keep(g, m0, f);
			mk[sp] = m0;
			si[sp++] = i;
			g->ivl[i] = f_range(g, st[sp - 1]);
			break;
		}
		case BC_SVO_TERM_NEG: {
			struct bc_svo_ivl v = g->ivl[si[sp - 1]];
			st[sp - 1] =
			    f_keep(g, mk[sp - 1], f_neg(g, st[sp - 1]));
			g->ivl[i].lo = -v.hi;
			g->ivl[i].hi = -v.lo;
			g->kid0[i] = si[sp - 1];
			si[sp - 1] = i;
			break;
		}
		case BC_SVO_TERM_UNARY: {
			/* Offset, onion and scale keep the child's form
			 * (affine maps of it, |.| for onion); twist's and
			 * bend's factor depends on the point: an interval. */
			uint32_t a = si[sp - 1];
			struct bc_svo_ivl v =
			    bc__svo_unary_range(r, t->rec, g->ivl[a], rg);
			RT f;
			const float *ur =
			    r->urec + (size_t)t->rec * BC_SVO_UNARY_REC;
			if (t->kind == BC_OP_OFFSET) {
				f = f_addc(g, st[sp - 1], -(double)ur[0]);
			} else if (t->kind == BC_OP_ONION) {
				f = f_addc(g, f_abs(g, st[sp - 1]),
				           -(double)ur[0]);
			} else if (t->kind == BC_OP_SCALE) {
				f = f_scale(g, st[sp - 1], (double)ur[0]);
			} else {
				f = f_from(g, v.lo, v.hi);
			}
			if (t->kind != BC_OP_TWIST && t->kind != BC_OP_BEND) {
				/* The float evaluation's rounding, as the
				 * interval rule widens (range.c). */
				double m = t_mag(g->ivl[a]), mg;
				if (!isfinite(m)) {
					m = 0.0;
				}
				mg = BC__SVO_ROUND_REL *
				         (m + fabs((double)ur[0])) *
				         (t->kind == BC_OP_SCALE
				              ? (double)ur[0] + 1.0
				              : 1.0) +
				     BC__SVO_ROUND_ABS;
				f = f_add_ivl(g, f, -mg, mg);
			}
			st[sp - 1] = f_keep(g, mk[sp - 1], f);
			g->ivl[i] = bc__svo_ivl_meet(f_range(g, st[sp - 1]), v);
			g->kid0[i] = a;
			si[sp - 1] = i;
			break;
		}
		default: {
			uint32_t a = si[sp - 2], b = si[sp - 1];
			struct bc_svo_ivl out;
			RT f = t_op(g, t, st[sp - 2], st[sp - 1], g->ivl[a],
			            g->ivl[b], &out);
			sp--;
			st[sp - 1] = f_keep(g, mk[sp - 1], f);
			g->ivl[i] = out;
			g->kid0[i] = a;
			g->kid1[i] = b;
			si[sp - 1] = i;
			break;
		}
		}
	}
	return g->ivl[si[0]];
}

static struct bc_svo_ivl t_prim_only(struct bc_svo_ranger *g, uint32_t term,
                                     const struct bc_svo_region *rg)
{
	RT p[3], f;
	struct bc__svo_geo geo;
	uint32_t m0;
	struct bc_svo_ivl v;
	bc__svo_geo_init(&geo, rg);
	m0 = f_mark(g);
	f_input(g, rg, p);
	if (!g->in_domain) {
		g->dom_d = BC_NONE; /* a new region */
	}
	f = t_prim(g, &g->rpn->terms[term], p, &geo, rg);
	v = f_range(g, f);
	(void)f_keep(g, m0, f_const(g, 0.0));
	return v;
}

#endif
