/*
 * Over-relaxed sphere tracing of one ray interval (Zanni 2024 §7, after the
 * enhanced sphere tracing of Keinert et al.): steps of 1.7 times the field
 * divided by the Lipschitz bound 1.45; when two consecutive unbounding
 * spheres do not overlap the relaxed step may have jumped over a surface, so
 * the tracer falls back to the plain step for the rest of the interval. A
 * hit is a field below half the pixel footprint at t (never below the
 * minimal step), or a sign change; both are refined to the crossing by
 * bisection. Both CPU
 * backends trace through here, so their depths agree to the refinement
 * tolerance wherever they find the same surface. A region's evaluation
 * bound stops a ray before any sample past it (BC__TRACE_SHORT); a ray it
 * does not stop takes the samples it takes without one.
 */
#include "cpu.h"

#include <math.h>

/* The field over the bounds at o + t d into *v; false, with nothing
 * evaluated, when the ray has spent its bound. Every sample of a ray goes
 * through here, so the bound covers the steps, the refinement and the
 * bisection alike. */
static inline bool eval_at(struct bc__field *f, const float o[3],
                           const float d[3], float t, float *v)
{
	float p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
	if (f->max_evals && f->evals >= f->max_evals) {
		return false;
	}
	/* The tree's own bound (above 1 under twist and bend) multiplies
	 * the operators'. */
	*v = bc__field_eval(f, p) * (1.0f / BC_CPU_LIPSCHITZ) / f->lin->lip;
	return true;
}

/* Bisects [a, b] with f(a) > 0 > f(b) down to the refinement tolerance, then
 * interpolates linearly inside the last bracket into *t_hit. Returns
 * BC__TRACE_HIT, or BC__TRACE_SHORT when the bound stopped it. */
static enum bc__trace_result bisect(struct bc__field *f,
                                    const struct bc__frame_ctx *fc,
                                    const float o[3], const float d[3], float a,
                                    float fa, float b, float fb, float *t_hit)
{
	/* The bracket halves per step: 40 steps reach float resolution from
	 * any interval a scene can produce. */
	for (int i = 0; i < 40 && b - a > fc->refine_tol; i++) {
		float m = 0.5f * (a + b), fm;
		if (!(m > a && m < b)) {
			break; /* float resolution reached */
		}
		if (!eval_at(f, o, d, m, &fm)) {
			return BC__TRACE_SHORT;
		}
		if (fm < 0.0f) {
			b = m;
			fb = fm;
		} else {
			a = m;
			fa = fm;
		}
	}
	*t_hit = a;
	if (fa - fb > 0.0f && isfinite(fa - fb)) {
		float t = a + (b - a) * fa / (fa - fb);
		*t_hit = t < a ? a : (t > b ? b : t);
	}
	return BC__TRACE_HIT;
}

/* The ray passes a surface by without crossing it: the field along it
 * has a minimum in [a, b] (v(a), v(b) >= the samples inside). Golden
 * section search narrows it so the silhouette's depth is the closest
 * approach, wherever the steps landed; a negative sample on the way is a
 * crossing after all and is bisected. Returns as bisect() does. */
static enum bc__trace_result closest(struct bc__field *f,
                                     const struct bc__frame_ctx *fc,
                                     const float o[3], const float d[3],
                                     float a, float va, float b, float *t_hit)
{
	const float g = 0.618034f;
	float c = b - g * (b - a), e = a + g * (b - a);
	float vc, ve;
	if (!eval_at(f, o, d, c, &vc)) {
		return BC__TRACE_SHORT;
	}
	if (vc < 0.0f) {
		return bisect(f, fc, o, d, a, va, c, vc, t_hit);
	}
	if (!eval_at(f, o, d, e, &ve)) {
		return BC__TRACE_SHORT;
	}
	if (ve < 0.0f) {
		return bisect(f, fc, o, d, a, va, e, ve, t_hit);
	}
	/* Six steps shrink the bracket twenty-fold. */
	for (int i = 0; i < 6; i++) {
		if (vc < ve) {
			b = e;
			e = c;
			ve = vc;
			c = b - g * (b - a);
			if (!eval_at(f, o, d, c, &vc)) {
				return BC__TRACE_SHORT;
			}
			if (vc < 0.0f) {
				return bisect(f, fc, o, d, a, va, c, vc, t_hit);
			}
		} else {
			a = c;
			va = vc;
			c = e;
			vc = ve;
			e = a + g * (b - a);
			if (!eval_at(f, o, d, e, &ve)) {
				return BC__TRACE_SHORT;
			}
			if (ve < 0.0f) {
				return bisect(f, fc, o, d, a, va, e, ve, t_hit);
			}
		}
	}
	*t_hit = vc < ve ? c : e;
	return BC__TRACE_HIT;
}

/* The ray came within the hit epsilon of a surface at t (field v >= 0).
 * Look for the crossing beyond, so that the depth is the surface's and not
 * wherever the last step landed (which differs between a tracer that
 * approached from afar and one whose depth range began right there). The
 * field's slope along the ray (the cosine of the incidence, for a distance
 * field) predicts where it reaches zero: a secant march probes a little
 * past that prediction and bisects as soon as the sign changes; where the
 * field rises again the ray only grazes the surface, and its hit is the
 * closest approach, within the hit epsilon of the silhouette. */
static enum bc__trace_result refine(struct bc__field *f,
                                    const struct bc__frame_ctx *fc,
                                    const float o[3], const float d[3], float t,
                                    float v, float t_prev, float v_prev,
                                    float eps, float t1, float *t_hit)
{
	/* Beyond this the ray is so oblique that the silhouette is as good
	 * an answer as any. */
	float cap = t + 64.0f * BC_CPU_LIPSCHITZ * f->lin->lip * eps;
	float limit = bc__minf(cap, t1);
	for (int i = 0; i < 8; i++) {
		float reach, probe, vp;
		if (t > t_prev && v_prev > v) {
			reach = 1.5f * v * (t - t_prev) / (v_prev - v);
		} else if (i == 0) {
			reach = v; /* no slope yet: the plain, safe step */
		} else {
			break;
		}
		probe = bc__minf(t + bc__maxf(reach, fc->min_step), limit);
		if (!(probe > t)) {
			/* Still descending at the interval's end: the
			 * crossing, if any, lies beyond it. */
			*t_hit = t;
			return t1 < cap ? BC__TRACE_NEAR_END : BC__TRACE_HIT;
		}
		if (!eval_at(f, o, d, probe, &vp)) {
			return BC__TRACE_SHORT;
		}
		if (vp < 0.0f) {
			return bisect(f, fc, o, d, t, v, probe, vp, t_hit);
		}
		if (!(vp < v)) {
			/* Rising: the ray passes the surface by, closest
			 * somewhere between the previous sample and here. */
			return closest(f, fc, o, d, t_prev < t ? t_prev : t,
			               t_prev < t ? v_prev : v, probe, t_hit);
		}
		t_prev = t;
		v_prev = v;
		t = probe;
		v = vp;
	}
	*t_hit = t;
	return BC__TRACE_HIT;
}

enum bc__trace_result bc__trace(struct bc__field *f,
                                const struct bc__frame_ctx *fc,
                                const float o[3], const float d[3], float t0,
                                float t1, float *t_hit)
{
	float omega = BC_CPU_OVERRELAX;
	float t = t0, v, t_prev = t0, v_prev = 0.0f;
	if (!(t1 >= t0)) {
		return BC__TRACE_MISS;
	}
	if (!eval_at(f, o, d, t, &v)) {
		return BC__TRACE_SHORT;
	}
	if (v < 0.0f) {
		/* Inside at the interval's start: the surface is here. */
		*t_hit = t0;
		return BC__TRACE_HIT;
	}
	for (;;) {
		/* Hit epsilon: half a pixel at t, never below the minimal
		 * step (which therefore bounds the steps per ray). */
		float eps = bc__maxf(BC_CPU_HIT_FOOTPRINT * fc->pix_angle * t,
		                     fc->min_step);
		/* Steps are divided by the tree's Lipschitz bound, the hit
		 * band is not: a hit stays a field below 1.45 eps. */
		eps /= f->lin->lip;
		float step, tn, vn;
		if (v < eps) {
			return refine(f, fc, o, d, t, v, t_prev, v_prev, eps,
			              t1, t_hit);
		}
		if (t >= t1) {
			return BC__TRACE_MISS;
		}
		/* The step never drops below float resolution at t, so the
		 * loop advances even far from the origin. */
		step = bc__maxf(omega * v, 1.0e-6f * t);
		tn = bc__minf(t + step, t1);
		if (!eval_at(f, o, d, tn, &vn)) {
			return BC__TRACE_SHORT;
		}
		if (omega > 1.0f && v + fabsf(vn) < tn - t) {
			/* The unbounding spheres at t and tn are disjoint: the
			 * gap between them was never proven empty. Take the
			 * plain step, which is. */
			omega = 1.0f;
			tn = bc__minf(t + bc__maxf(v, 1.0e-6f * t), t1);
			if (!eval_at(f, o, d, tn, &vn)) {
				return BC__TRACE_SHORT;
			}
		}
		if (vn < 0.0f) {
			return bisect(f, fc, o, d, t, v, tn, vn, t_hit);
		}
		if (!(vn == vn)) {
			return BC__TRACE_MISS; /* NaN: give up on this ray */
		}
		t_prev = t;
		v_prev = v;
		t = tn;
		v = vn;
	}
}
