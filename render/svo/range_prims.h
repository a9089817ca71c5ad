/*
 * Natural range extensions of the primitives' fields, written once over the
 * operations of range_tmpl.h (included from there, with RT and the f_*
 * operations of one arithmetic in scope). Each follows the point formula of
 * blobtree/prim.c term by term, on the same packed floats, so its range
 * encloses the evaluator's value. Kinds whose formula branches on the
 * point's position (a fold, a nearest-piece choice) have none here and use
 * the Lipschitz enclosure instead: bc_svo_prim_uses_lipschitz() says which,
 * and docs/svo.md why.
 */
#ifndef BLOBCAST_SVO_RANGE_PRIMS_H
#define BLOBCAST_SVO_RANGE_PRIMS_H

static inline bool bc__svo_prim_exact(enum bc_prim kind)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	return info && info->exact;
}

static inline RT t_len2(struct bc_svo_ranger *g, RT a, RT b)
{
	return f_sqrt(g, f_add(g, f_sqr(g, a), f_sqr(g, b)));
}

static inline RT t_len3(struct bc_svo_ranger *g, RT a, RT b, RT c)
{
	return f_sqrt(
	    g, f_add(g, f_add(g, f_sqr(g, a), f_sqr(g, b)), f_sqr(g, c)));
}

static inline RT t_max0(struct bc_svo_ranger *g, RT a)
{
	return f_max(g, a, f_const(g, 0.0));
}

static inline RT t_min0(struct bc_svo_ranger *g, RT a)
{
	return f_min(g, a, f_const(g, 0.0));
}

static inline RT t_clamp(struct bc_svo_ranger *g, RT a, double lo, double hi)
{
	return f_min(g, f_max(g, a, f_const(g, lo)), f_const(g, hi));
}

/* prim.c box_d: distance to the box [-h, h] from d = |p| - h. */
static inline RT t_box_d(struct bc_svo_ranger *g, RT dx, RT dy, RT dz)
{
	RT out = t_len3(g, t_max0(g, dx), t_max0(g, dy), t_max0(g, dz));
	return f_add(g, out, t_min0(g, f_max(g, dx, f_max(g, dy, dz))));
}

/* prim.c extrude. */
static inline RT t_extrude(struct bc_svo_ranger *g, RT d2, RT dz)
{
	return f_add(g, t_min0(g, f_max(g, d2, dz)),
	             t_len2(g, t_max0(g, d2), t_max0(g, dz)));
}

/* The hull of two forms: a fresh form (correlations are lost). */
static inline RT t_hull(struct bc_svo_ranger *g, RT a, RT b)
{
	struct bc_svo_ivl va = f_range(g, a), vb = f_range(g, b);
	return f_from(g, bc__dmin(va.lo, vb.lo), bc__dmax(va.hi, vb.hi));
}

static RT t_ellipsoid(struct bc_svo_ranger *g, const float *k, const RT l[3])
{
	RT u[3], w[3], k0, f;
	struct bc_svo_ivl v0;
	for (int i = 0; i < 3; i++) {
		u[i] = f_scale(g, l[i], k[3 + i]);
		w[i] = f_scale(g, u[i], k[3 + i]);
	}
	k0 = t_len3(g, u[0], u[1], u[2]);
	v0 = f_range(g, k0);
	if (v0.hi < 1.0) {
		f = f_scale(g, f_addc(g, k0, -1.0), k[6]);
	} else {
		/* k0 (k0 - 1) / k1. Since |u| / max r <= k1 <= |u| / min r,
		 * that lies in [(k0 - 1) min r, (k0 - 1) max r] where k0 >= 1:
		 * a bound needing no division, used when the quotient's
		 * range is wider (or k1's reaches 0). */
		RT km = f_addc(g, k0, -1.0);
		struct bc_svo_ivl vk = f_range(g, km), vq;
		double rmax = bc__dmax(bc__dmax(k[0], k[1]), k[2]);
		double blo = bc__dmax(vk.lo, 0.0) * k[6],
		       bhi = bc__dmax(vk.hi, 0.0) * rmax;
		RT k1 = t_len3(g, w[0], w[1], w[2]);
		RT outer;
		if (f_range(g, k1).lo > 0.0) {
			outer = f_mul(g, f_mul(g, k0, km), f_recip(g, k1));
			vq = f_range(g, outer);
			if (!(vq.hi - vq.lo <= bhi - blo)) {
				outer = f_from(g, blo, bhi);
			}
		} else {
			outer = f_from(g, blo, bhi);
		}
		if (v0.lo >= 1.0) {
			f = outer;
		} else {
			/* Both branches may be taken in the region. */
			f = t_hull(g, f_scale(g, km, k[6]), outer);
		}
	}
	return f_max(g, f,
	             t_box_d(g, f_addc(g, f_abs(g, l[0]), -(double)k[0]),
	                     f_addc(g, f_abs(g, l[1]), -(double)k[1]),
	                     f_addc(g, f_abs(g, l[2]), -(double)k[2])));
}

static RT t_box_frame(struct bc_svo_ranger *g, const float *k, const RT l[3])
{
	double e = k[3];
	RT p[3], q[3], d;
	for (int i = 0; i < 3; i++) {
		p[i] = f_addc(g, f_abs(g, l[i]), -(double)k[i]);
		q[i] = f_addc(g, f_abs(g, f_addc(g, p[i], e)), -e);
	}
	d = t_box_d(g, p[0], q[1], q[2]);
	d = f_min(g, d, t_box_d(g, q[0], p[1], q[2]));
	return f_min(g, d, t_box_d(g, q[0], q[1], p[2]));
}

/* Writes the natural range form of kind at local forms l into *out and
 * returns true, or returns false when kind has none. */
static bool t_natural(struct bc_svo_ranger *g, enum bc_prim kind,
                      const float *k, const RT l[3], RT *out)
{
	switch (kind) {
	case BC_PRIM_SPHERE:
		*out = f_addc(g, t_len3(g, l[0], l[1], l[2]), -(double)k[0]);
		return true;
	case BC_PRIM_BOX:
		*out =
		    f_addc(g,
		           t_box_d(g, f_addc(g, f_abs(g, l[0]), -(double)k[0]),
		                   f_addc(g, f_abs(g, l[1]), -(double)k[1]),
		                   f_addc(g, f_abs(g, l[2]), -(double)k[2])),
		           -(double)k[3]);
		return true;
	case BC_PRIM_CAPSULE: {
		RT p[3], t, dot;
		for (int i = 0; i < 3; i++) {
			p[i] = f_addc(g, l[i], -(double)k[i]);
		}
		dot = f_add(
		    g, f_add(g, f_scale(g, p[0], k[3]), f_scale(g, p[1], k[4])),
		    f_scale(g, p[2], k[5]));
		t = t_clamp(g, f_scale(g, dot, k[7]), 0.0, 1.0);
		for (int i = 0; i < 3; i++) {
			p[i] = f_sub(g, p[i], f_scale(g, t, k[3 + i]));
		}
		*out = f_addc(g, t_len3(g, p[0], p[1], p[2]), -(double)k[6]);
		return true;
	}
	case BC_PRIM_CYLINDER:
		*out = t_extrude(
		    g, f_addc(g, t_len2(g, l[0], l[2]), -(double)k[0]),
		    f_addc(g, f_abs(g, l[1]), -(double)k[1]));
		return true;
	case BC_PRIM_TORUS:
		*out = f_addc(
		    g,
		    t_len2(g, f_addc(g, t_len2(g, l[0], l[2]), -(double)k[0]),
		           l[1]),
		    -(double)k[1]);
		return true;
	case BC_PRIM_ELLIPSOID:
		*out = t_ellipsoid(g, k, l);
		return true;
	case BC_PRIM_BOX_FRAME:
		*out = t_box_frame(g, k, l);
		return true;
	case BC_PRIM_LINK: {
		RT qy = t_max0(g, f_addc(g, f_abs(g, l[1]), -(double)k[0]));
		*out = f_addc(
		    g,
		    t_len2(g, f_addc(g, t_len2(g, l[0], qy), -(double)k[1]),
		           l[2]),
		    -(double)k[2]);
		return true;
	}
	default:
		return false;
	}
}

#define RP_NATURAL(g, kind, pk, l, out) t_natural(g, kind, pk, l, out)

#endif
