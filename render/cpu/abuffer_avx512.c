/*
 * The A-buffer's AVX-512 kernels (abuffer.h): 16 rays, a quarter tile, per
 * vector. This file alone is compiled with -mavx512f -mavx2
 * -ffp-contract=off (render/cpu/CMakeLists.txt) and is only called when
 * the CPU has AVX-512F (abuffer.c checks).
 */
#include "abuffer.h"

#include "vec_avx512.h"

#define AB_LANES 16u
#define AB_DIRS bc__ab_dirs_avx512
#define AB_SPHERE bc__ab_sphere_avx512

#include "abuffer_kernel.h"

/* ---- Box and capsule ABVs, 8 rays in double precision ------------------ */

#include <immintrin.h>
#include <stdint.h>

typedef __m512d vd;
typedef __mmask8 md;

/* A span (abv.c's struct span) per lane: empty when !(lo <= hi). */
struct vspan {
	vd lo, hi;
};

static inline vd dset(double a)
{
	return _mm512_set1_pd(a);
}

static inline vd dadd(vd a, vd b)
{
	return _mm512_add_pd(a, b);
}

static inline vd dsub(vd a, vd b)
{
	return _mm512_sub_pd(a, b);
}

static inline vd dmul(vd a, vd b)
{
	return _mm512_mul_pd(a, b);
}

static inline vd ddiv(vd a, vd b)
{
	return _mm512_div_pd(a, b);
}

/* -a, exactly (the sign flipped, as C's unary minus). */
static inline vd dneg(vd a)
{
	return _mm512_castsi512_pd(_mm512_xor_si512(
	    _mm512_castpd_si512(a), _mm512_set1_epi64(INT64_MIN)));
}

/* m ? a : b */
static inline vd dsel(md m, vd a, vd b)
{
	return _mm512_mask_blend_pd(m, b, a);
}

static inline md dlt(vd a, vd b)
{
	return _mm512_cmp_pd_mask(a, b, _CMP_LT_OQ);
}

static inline md dle(vd a, vd b)
{
	return _mm512_cmp_pd_mask(a, b, _CMP_LE_OQ);
}

static inline md deq(vd a, vd b)
{
	return _mm512_cmp_pd_mask(a, b, _CMP_EQ_OQ);
}

/* a[0] * b[0] + a[1] * b[1] + a[2] * b[2], in abv.c's order. */
static inline vd ddot(const vd a[3], const vd b[3])
{
	return dadd(dadd(dmul(a[0], b[0]), dmul(a[1], b[1])), dmul(a[2], b[2]));
}

static inline double sdot(const double a[3], const double b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline md dempty(struct vspan s)
{
	return (md)~dle(s.lo, s.hi);
}

static inline struct vspan dspan_if(md m, struct vspan a, struct vspan b)
{
	struct vspan s = {dsel(m, a.lo, b.lo), dsel(m, a.hi, b.hi)};
	return s;
}

static const struct vspan *no_vspan(struct vspan *s)
{
	s->lo = dset(INFINITY);
	s->hi = dset(-INFINITY);
	return s;
}

/* span_cut: a.lo > b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi. */
static inline struct vspan dcut(struct vspan a, struct vspan b)
{
	struct vspan s = {dsel(dlt(b.lo, a.lo), a.lo, b.lo),
	                  dsel(dlt(a.hi, b.hi), a.hi, b.hi)};
	return s;
}

/* span_hull: b when a is empty, a when b is, else the hull. */
static inline struct vspan dhull(struct vspan a, struct vspan b)
{
	struct vspan h = {dsel(dlt(a.lo, b.lo), a.lo, b.lo),
	                  dsel(dlt(b.hi, a.hi), a.hi, b.hi)};
	h = dspan_if(dempty(b), a, h);
	return dspan_if(dempty(a), b, h);
}

/* ball_span for the line eye + t d: oc = eye - c (the same for every
 * ray), r2 = r * r. */
static inline struct vspan dball(const vd oc[3], vd r2, const vd d[3], vd dd)
{
	struct vspan s, none;
	vd b = ddiv(ddot(oc, d), dd), v[3], h2, h;
	md ok;
	for (int k = 0; k < 3; k++) {
		v[k] = dsub(oc[k], dmul(b, d[k]));
	}
	h2 = ddiv(dsub(r2, ddot(v, v)), dd);
	ok = (md)~dlt(h2, dset(0.0));
	h = _mm512_sqrt_pd(dsel(ok, h2, dset(0.0)));
	b = dneg(b);
	s.lo = dsub(b, h);
	s.hi = dadd(b, h);
	return dspan_if(ok, s, *no_vspan(&none));
}

/* slab_span(s0, ds, lo, hi): s0, lo and hi the same for every ray. */
static inline struct vspan dslab(double s0, vd ds, double lo, double hi)
{
	struct vspan s, flat;
	vd ta = ddiv(dset(lo - s0), ds), tb = ddiv(dset(hi - s0), ds);
	md lt = dlt(ta, tb), zero = deq(ds, dset(0.0));
	s.lo = dsel(lt, ta, tb);
	s.hi = dsel(lt, tb, ta);
	if (s0 < lo || s0 > hi) {
		no_vspan(&flat);
	} else {
		flat.lo = dset(-INFINITY);
		flat.hi = dset(INFINITY);
	}
	return dspan_if(zero, flat, s);
}

static inline struct vspan dbox(const struct bc_abv *abv, const double o[3],
                                const vd d[3])
{
	struct vspan s = {dset(-INFINITY), dset(INFINITY)};
	double oc[3];
	for (int k = 0; k < 3; k++) {
		oc[k] = o[k] - (double)abv->center[k];
	}
	/* abv.c stops at the first empty slab: a span once empty stays
	 * empty under further cuts (no NaN arises), so cutting by all three
	 * gives the same hits. */
	for (int i = 0; i < 3; i++) {
		double ax[3] = {abv->axis[i][0], abv->axis[i][1],
		                abv->axis[i][2]};
		vd vax[3] = {dset(ax[0]), dset(ax[1]), dset(ax[2])};
		double h = abv->half[i];
		s = dcut(s, dslab(sdot(oc, ax), ddot(d, vax), -h, h));
	}
	return s;
}

static inline struct vspan dcapsule(const struct bc_abv *abv, const double o[3],
                                    const vd d[3], vd dd)
{
	double a[3], b[3], w[3], r = abv->radius, l, oc[3], ow, op[3], qc;
	vd va[3], vb[3], vw[3], vop[3], dw, dp[3], qa, qb, disc, sq, q, r2;
	struct vspan s, cyl, quad, none;
	md neg, qzero, flat;
	for (int k = 0; k < 3; k++) {
		a[k] = abv->center[k];
		b[k] = abv->end[k];
		va[k] = dset(o[k] - a[k]);
		vb[k] = dset(o[k] - b[k]);
	}
	r2 = dset(r * r);
	s = dhull(dball(va, r2, d, dd), dball(vb, r2, d, dd));
	for (int k = 0; k < 3; k++) {
		w[k] = b[k] - a[k];
	}
	l = sqrt(sdot(w, w));
	if (l == 0.0) {
		return s;
	}
	for (int k = 0; k < 3; k++) {
		w[k] /= l;
		vw[k] = dset(w[k]);
		oc[k] = o[k] - a[k];
	}
	ow = sdot(oc, w);
	dw = ddot(d, vw);
	for (int k = 0; k < 3; k++) {
		dp[k] = dsub(d[k], dmul(dw, vw[k]));
		op[k] = oc[k] - ow * w[k];
		vop[k] = dset(op[k]);
	}
	qa = ddot(dp, dp);
	qb = ddot(vop, dp);
	qc = sdot(op, op) - r * r;
	/* quad_span(qa, qb, qc): none when disc < 0, [0, 0] when q == 0. */
	disc = dsub(dmul(qb, qb), dmul(qa, dset(qc)));
	neg = dlt(disc, dset(0.0));
	sq = _mm512_sqrt_pd(dsel(neg, dset(0.0), disc));
	q = dneg(dadd(qb, dsel(dlt(qb, dset(0.0)), dneg(sq), sq)));
	qzero = deq(q, dset(0.0));
	{
		vd t0 = ddiv(q, qa), t1 = ddiv(dset(qc), q);
		md lt = dlt(t0, t1);
		quad.lo = dsel(lt, t0, t1);
		quad.hi = dsel(lt, t1, t0);
	}
	quad = dspan_if(qzero, (struct vspan){dset(0.0), dset(0.0)}, quad);
	quad = dspan_if(neg, *no_vspan(&none), quad);
	/* Parallel to the axis (qa == 0): inside the tube everywhere or
	 * nowhere. */
	if (qc <= 0.0) {
		cyl.lo = dset(-INFINITY);
		cyl.hi = dset(INFINITY);
	} else {
		no_vspan(&cyl);
	}
	flat = deq(qa, dset(0.0));
	cyl = dspan_if(flat, cyl, quad);
	/* abv.c cuts only a non-empty span; an empty one stays empty. */
	cyl = dcut(cyl, dslab(ow, dw, 0.0, l));
	return dhull(s, cyl);
}

void bc__ab_abv_avx512(const struct bc__ab_rays *rays, uint64_t lanes,
                       const struct bc_abv *abv, const float eye[3], float t[2])
{
	double o[3] = {eye[0], eye[1], eye[2]};
	float t0 = t[0], t1 = t[1];
	if (abv->shape != BC_ABV_BOX && abv->shape != BC_ABV_CAPSULE) {
		bc__ab_abv_scalar(rays, lanes, abv, eye, t);
		return;
	}
	for (uint32_t q = 0; q < 4; q++) {
		for (uint32_t k = 0; k < BC__AB_QUARTER_RAYS; k += 8) {
			uint32_t shift = q * BC__AB_QUARTER_RAYS + k;
			uint32_t bits = (uint32_t)(lanes >> shift) & 0xffu;
			_Alignas(64) double lo[8], hi[8];
			vd d[3], dd;
			struct vspan s;
			md hit;
			if (!bits) {
				continue;
			}
			for (int i = 0; i < 3; i++) {
				d[i] = _mm512_cvtps_pd(
				    _mm256_loadu_ps(&rays->d[q][i][k]));
			}
			dd = ddot(d, d);
			s = abv->shape == BC_ABV_BOX ? dbox(abv, o, d)
			                             : dcapsule(abv, o, d, dd);
			/* bc_abv_ray: a direction, a span, not wholly
			 * behind the eye. */
			hit =
			    (md)(bits &
			         _mm512_cmp_pd_mask(dd, dset(0.0), _CMP_GT_OQ) &
			         dle(s.lo, s.hi) & (md)~dlt(s.hi, dset(0.0)));
			if (!hit) {
				continue;
			}
			_mm512_store_pd(lo, s.lo);
			_mm512_store_pd(hi, s.hi);
			for (uint32_t i = 0; i < 8; i++) {
				float a, e;
				if (!((hit >> i) & 1u)) {
					continue;
				}
				a = nextafterf((float)lo[i], -INFINITY);
				e = nextafterf((float)hi[i], INFINITY);
				if (e > 0.0f) {
					a = a > 0.0f ? a : 0.0f;
					t0 = a < t0 ? a : t0;
					t1 = e > t1 ? e : t1;
				}
			}
		}
	}
	t[0] = t0;
	t[1] = t1;
}
