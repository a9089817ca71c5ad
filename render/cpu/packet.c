/*
 * The portable half of packet tracing (packet.h): the choice of kernel for
 * this CPU, and one lane's sphere tracing as a state machine. The machine
 * is bc__trace (trace.c) cut at each field evaluation: every state below
 * that waits for a value is one eval_at call there, and the transitions
 * between them are that code's statements in the same order, with the same
 * float expressions, so a lane steps, falls back, refines and bisects as
 * the scalar tracer does (its values differ from the scalar field's only
 * by the rounding of the vector kernel).
 */
#include "packet.h"

#include <math.h>

enum state {
	S_DONE = 0,
	S_INIT = BC__PK_INIT,       /* value at t0 */
	S_STEP = BC__PK_STEP,       /* value at the step tn (packet.h) */
	S_STEP2 = BC__PK_STEP2,     /* value at the plain step after a failed
	                               relaxed one */
	S_REFINE = BC__PK_REFINE,   /* value at the secant probe q */
	S_BISECT = BC__PK_BISECT,   /* value at the midpoint q */
	S_GOLD_C0 = BC__PK_GOLD_C0, /* closest(): first value, at c */
	S_GOLD_E0 = BC__PK_GOLD_E0, /* closest(): second value, at e */
	S_GOLD_C = BC__PK_GOLD_C,   /* closest(): new value at c */
	S_GOLD_E = BC__PK_GOLD_E,   /* closest(): new value at e */
};

/* The states packet.h names are these, and none other takes their values. */
_Static_assert(S_STEP2 == S_STEP + 1 && S_REFINE + 1 == S_BISECT &&
                   S_GOLD_C0 == S_BISECT + 1 && S_GOLD_E == S_GOLD_C0 + 3,
               "packet.h's state numbers");

/* Golden section ratio of trace.c's closest(). */
#define GOLD 0.618034f

static bool finish(struct bc__pk_ray *r, enum bc__trace_result res, float t)
{
	r->state = S_DONE;
	r->res = (uint8_t)res;
	r->t_hit = t;
	return true;
}

static bool await(struct bc__pk_ray *r, enum state s, float q)
{
	r->state = (uint8_t)s;
	r->q = q;
	return false;
}

/* trace.c's bisect(): the loop head, then the final interpolation. */
static bool bisect_head(struct bc__pk_ray *r, const struct bc__frame_ctx *fc)
{
	float a = r->a, b = r->b, fa = r->fa, fb = r->fb;
	if (r->i < 40 && b - a > fc->refine_tol) {
		float m = 0.5f * (a + b);
		if (m > a && m < b) {
			return await(r, S_BISECT, m);
		}
	}
	if (fa - fb > 0.0f && isfinite(fa - fb)) {
		float t = a + (b - a) * fa / (fa - fb);
		return finish(r, BC__TRACE_HIT, t < a ? a : (t > b ? b : t));
	}
	return finish(r, BC__TRACE_HIT, a);
}

static bool bisect_start(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                         float a, float fa, float b, float fb)
{
	r->a = a;
	r->fa = fa;
	r->b = b;
	r->fb = fb;
	r->i = 0;
	return bisect_head(r, fc);
}

/* trace.c's closest(), from its loop head. a, fa (its va), b, c, e, vc and
 * ve are the bracket. */
static bool gold_head(struct bc__pk_ray *r)
{
	if (r->i >= 6) {
		return finish(r, BC__TRACE_HIT, r->vc < r->ve ? r->c : r->e);
	}
	if (r->vc < r->ve) {
		r->b = r->e;
		r->e = r->c;
		r->ve = r->vc;
		r->c = r->b - GOLD * (r->b - r->a);
		return await(r, S_GOLD_C, r->c);
	}
	r->a = r->c;
	r->fa = r->vc;
	r->c = r->e;
	r->vc = r->ve;
	r->e = r->a + GOLD * (r->b - r->a);
	return await(r, S_GOLD_E, r->e);
}

static bool gold_start(struct bc__pk_ray *r, float a, float va, float b)
{
	r->a = a;
	r->fa = va;
	r->b = b;
	r->c = b - GOLD * (b - a);
	r->e = a + GOLD * (b - a);
	return await(r, S_GOLD_C0, r->c);
}

/* trace.c's refine(), from its loop head; t, v, t_prev, v_prev are its
 * running values. */
static bool refine_head(struct bc__pk_ray *r, const struct bc__frame_ctx *fc)
{
	float reach, probe;
	if (r->i >= 8) {
		return finish(r, BC__TRACE_HIT, r->t);
	}
	if (r->t > r->t_prev && r->v_prev > r->v) {
		reach = 1.5f * r->v * (r->t - r->t_prev) / (r->v_prev - r->v);
	} else if (r->i == 0) {
		reach = r->v;
	} else {
		return finish(r, BC__TRACE_HIT, r->t);
	}
	probe = bc__minf(r->t + bc__maxf(reach, fc->min_step), r->limit);
	if (!(probe > r->t)) {
		return finish(
		    r, r->t1 < r->cap ? BC__TRACE_NEAR_END : BC__TRACE_HIT,
		    r->t);
	}
	return await(r, S_REFINE, probe);
}

/* bc__trace's loop head at (t, v). */
static bool march_head(struct bc__pk_ray *r, const struct bc__frame_ctx *fc)
{
	float eps =
	    bc__maxf(BC_CPU_HIT_FOOTPRINT * fc->pix_angle * r->t, fc->min_step);
	float step;
	eps /= fc->lin->lip;
	if (r->v < eps) {
		r->cap = r->t + 64.0f * BC_CPU_LIPSCHITZ * fc->lin->lip * eps;
		r->limit = bc__minf(r->cap, r->t1);
		r->i = 0;
		return refine_head(r, fc);
	}
	if (r->t >= r->t1) {
		return finish(r, BC__TRACE_MISS, 0.0f);
	}
	step = bc__maxf(r->omega * r->v, 1.0e-6f * r->t);
	r->tn = bc__minf(r->t + step, r->t1);
	return await(r, S_STEP, r->tn);
}

/* bc__trace after the step's value vn is known. */
static bool step_check(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                       float vn)
{
	if (vn < 0.0f) {
		return bisect_start(r, fc, r->t, r->v, r->tn, vn);
	}
	if (!(vn == vn)) {
		return finish(r, BC__TRACE_MISS, 0.0f);
	}
	r->t_prev = r->t;
	r->v_prev = r->v;
	r->t = r->tn;
	r->v = vn;
	return march_head(r, fc);
}

bool bc__pk_ray_start(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                      float t0, float t1)
{
	(void)fc;
	r->evals = 0;
	r->t0 = t0;
	r->t1 = t1;
	if (!(t1 >= t0)) {
		return finish(r, BC__TRACE_MISS, 0.0f);
	}
	return await(r, S_INIT, t0);
}

bool bc__pk_ray_feed(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                     float value)
{
	r->evals++;
	switch ((enum state)r->state) {
	case S_INIT:
		if (value < 0.0f) {
			return finish(r, BC__TRACE_HIT, r->t0);
		}
		r->t = r->t0;
		r->v = value;
		r->t_prev = r->t0;
		r->v_prev = 0.0f;
		r->omega = BC_CPU_OVERRELAX;
		return march_head(r, fc);
	case S_STEP:
		if (r->omega > 1.0f && r->v + fabsf(value) < r->tn - r->t) {
			r->omega = 1.0f;
			r->tn = bc__minf(r->t + bc__maxf(r->v, 1.0e-6f * r->t),
			                 r->t1);
			return await(r, S_STEP2, r->tn);
		}
		return step_check(r, fc, value);
	case S_STEP2:
		return step_check(r, fc, value);
	case S_REFINE:
		if (value < 0.0f) {
			return bisect_start(r, fc, r->t, r->v, r->q, value);
		}
		if (!(value < r->v)) {
			bool back = r->t_prev < r->t;
			return gold_start(r, back ? r->t_prev : r->t,
			                  back ? r->v_prev : r->v, r->q);
		}
		r->t_prev = r->t;
		r->v_prev = r->v;
		r->t = r->q;
		r->v = value;
		r->i++;
		return refine_head(r, fc);
	case S_BISECT:
		if (value < 0.0f) {
			r->b = r->q;
			r->fb = value;
		} else {
			r->a = r->q;
			r->fa = value;
		}
		r->i++;
		return bisect_head(r, fc);
	case S_GOLD_C0:
		if (value < 0.0f) {
			return bisect_start(r, fc, r->a, r->fa, r->c, value);
		}
		r->vc = value;
		return await(r, S_GOLD_E0, r->e);
	case S_GOLD_E0:
		if (value < 0.0f) {
			return bisect_start(r, fc, r->a, r->fa, r->e, value);
		}
		r->ve = value;
		r->i = 0;
		return gold_head(r);
	case S_GOLD_C:
		r->vc = value;
		if (value < 0.0f) {
			return bisect_start(r, fc, r->a, r->fa, r->c, value);
		}
		r->i++;
		return gold_head(r);
	case S_GOLD_E:
		r->ve = value;
		if (value < 0.0f) {
			return bisect_start(r, fc, r->a, r->fa, r->e, value);
		}
		r->i++;
		return gold_head(r);
	case S_DONE:
	default:
		return true;
	}
}

struct bc__pk_kernel bc__pk_kernel_for(enum bc_simd simd)
{
	struct bc__pk_kernel none = {NULL, NULL, NULL, 1};
#if defined(BLOBCAST_SIMD_X86)
#define AVX2                                                                   \
	((struct bc__pk_kernel){bc__pk_march_avx2, bc__pk_hits_avx2,           \
	                        bc__pk_shade_avx2, 8})
#define AVX512                                                                 \
	((struct bc__pk_kernel){bc__pk_march_avx512, bc__pk_hits_avx512,       \
	                        bc__pk_shade_avx512, 16})
	bool avx2, avx512;
	__builtin_cpu_init();
	avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
	avx512 = avx2 && __builtin_cpu_supports("avx512f");
	switch (simd) {
	case BC_SIMD_AUTO:
		if (avx512) {
			return AVX512;
		}
		if (avx2) {
			return AVX2;
		}
		return none;
	case BC_SIMD_AVX2:
		return avx2 ? AVX2 : none;
	case BC_SIMD_AVX512:
		return avx512 ? AVX512 : none;
	default:
		return none;
	}
#else
	(void)simd;
	return none;
#endif
}
