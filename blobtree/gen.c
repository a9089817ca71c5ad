/*
 * Scene generators (gen.h): the synthetic scenes of Zanni 2024 (Fig. 16:
 * recursive aggregates; Fig. 18: many instances under one left-heavy
 * operator), analogues of the thesis' Gears, Many Gears and Many Spheres
 * scenes, a left comb, and random trees that use every primitive and
 * operator kind. Everything is built through the public builder, and every
 * random choice comes from one xoshiro256** stream seeded with splitmix64
 * from the options, so a scene is a pure function of its options.
 *
 * Primitive parameters are set by name through bc_prim_info(), so the
 * generators follow the parameter table instead of assuming its layout.
 */
#include "blobcast/gen.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/vec.h"

#define PI_F 3.14159265358979f

/* ---- random numbers ------------------------------------------------------ */

struct rng {
	uint64_t s[4];
};

static uint64_t splitmix64(uint64_t *x)
{
	uint64_t z = (*x += 0x9e3779b97f4a7c15ull);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

static void rng_seed(struct rng *r, uint64_t seed)
{
	for (int i = 0; i < 4; i++) {
		r->s[i] = splitmix64(&seed);
	}
}

static uint64_t rotl(uint64_t x, int k)
{
	return (x << k) | (x >> (64 - k));
}

/* xoshiro256** (Blackman and Vigna). */
static uint64_t rng_next(struct rng *r)
{
	uint64_t result = rotl(r->s[1] * 5, 7) * 9;
	uint64_t t = r->s[1] << 17;
	r->s[2] ^= r->s[0];
	r->s[3] ^= r->s[1];
	r->s[1] ^= r->s[2];
	r->s[0] ^= r->s[3];
	r->s[2] ^= t;
	r->s[3] = rotl(r->s[3], 45);
	return result;
}

/* Uniform in [lo, hi), from the top 24 bits. */
static float rng_float(struct rng *r, float lo, float hi)
{
	float u = (float)(rng_next(r) >> 40) * (1.0f / 16777216.0f);
	return lo + (hi - lo) * u;
}

/* Uniform in [0, n), n > 0. The bias of a modulo over 2^64 is negligible. */
static uint32_t rng_below(struct rng *r, uint32_t n)
{
	return (uint32_t)(rng_next(r) % n);
}

/* ---- random rotations (the rest of the quaternion helpers: vec.h) ------- */

/* Uniformly random unit quaternion (Shoemake's subgroup algorithm). */
static void quat_random(struct rng *r, float q[4])
{
	float u1 = rng_float(r, 0.0f, 1.0f);
	float a = 2.0f * PI_F * rng_float(r, 0.0f, 1.0f);
	float b = 2.0f * PI_F * rng_float(r, 0.0f, 1.0f);
	float s1 = sqrtf(1.0f - u1), s2 = sqrtf(u1);
	q[0] = s1 * sinf(a);
	q[1] = s1 * cosf(a);
	q[2] = s2 * sinf(b);
	q[3] = s2 * cosf(b);
	bc_quat_normalize(q);
}

/* ---- building context ---------------------------------------------------- */

struct gen {
	struct bc_tree *t;
	struct bc_errinfo *ei;
	struct rng rng;
	const struct bc_gen_opts *o;
	uint32_t next_id;
};

/* A local frame: world = translate + scale * rotate(local). */
struct frame {
	float t[3];
	float q[4];
	float s;
};

static void frame_init(struct frame *f)
{
	memset(f, 0, sizeof(*f));
	bc_quat_identity(f->q);
	f->s = 1.0f;
}

/* Sets parameter name of p (count floats). Fails if the parameter table has
 * no such parameter of that size: a generator out of step with prim.c is a
 * bug that tests must see. */
static int set_param(struct gen *g, struct bc_prim_data *p, const char *name,
                     const float *v, uint32_t count)
{
	const struct bc_prim_info *info = bc_prim_info(p->kind);
	for (uint32_t i = 0; info && i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		if (strcmp(d->name, name) == 0 && d->count == count &&
		    (uint32_t)d->offset + count <= BC_PRIM_MAX_PARAMS) {
			memcpy(p->params + d->offset, v, count * sizeof(float));
			return 0;
		}
	}
	return bc_errinfo_set(g->ei, BC_EINVAL,
	                      "generator: a %s has no %u-float parameter %s",
	                      info ? info->name : "?", count, name);
}

static int set1(struct gen *g, struct bc_prim_data *p, const char *name,
                float v)
{
	return set_param(g, p, name, &v, 1);
}

static int set3(struct gen *g, struct bc_prim_data *p, const char *name,
                float x, float y, float z)
{
	float v[3] = {x, y, z};
	return set_param(g, p, name, v, 3);
}

/* Places p (built in local coordinates with its own offset and rotation)
 * into frame f. Sizes were already scaled by the caller. */
static void place(struct bc_prim_data *p, const struct frame *f,
                  const float local_pos[3], const float local_q[4])
{
	float v[3] = {local_pos[0] * f->s, local_pos[1] * f->s,
	              local_pos[2] * f->s};
	float w[3];
	bc_quat_rotate(f->q, v, w);
	for (int i = 0; i < 3; i++) {
		p->translate[i] = f->t[i] + w[i];
	}
	bc_quat_mul(f->q, local_q, p->rotate);
	bc_quat_normalize(p->rotate);
}

static void set_color(struct bc_prim_data *p, float r, float g, float b)
{
	p->color[0] = fminf(fmaxf(r, 0.0f), 1.0f);
	p->color[1] = fminf(fmaxf(g, 0.0f), 1.0f);
	p->color[2] = fminf(fmaxf(b, 0.0f), 1.0f);
	p->has_color = true;
}

static int put(struct gen *g, const struct bc_prim_data *p)
{
	return bc_tree_put_prim(g->t, g->next_id++, p, g->ei);
}

static int push(struct gen *g, enum bc_op kind, float blend)
{
	struct bc_op_data op = {
	    kind, bc_op_is_smooth(kind) ? blend : 0.0f,
	    bc_op_is_smooth(kind) ? bc_op_default_range(blend) : 0.0f};
	return bc_tree_push_op(g->t, g->next_id++, &op, g->ei);
}

static int pop(struct gen *g)
{
	return bc_tree_pop_op(g->t, g->ei);
}

static bool smooth_of(const struct bc_gen_opts *o, bool dflt)
{
	return o->blend == BC_GEN_BLEND_DEFAULT
	           ? dflt
	           : o->blend == BC_GEN_BLEND_SMOOTH;
}

/* A camera looking at centre from direction dir (need not be unit), far
 * enough for a sphere of radius to fill most of a 40 degree view. */
static void frame_camera(struct bc_camera *cam, const float centre[3],
                         float radius, float dx, float dy, float dz)
{
	float n = sqrtf(dx * dx + dy * dy + dz * dz);
	float fov = 40.0f;
	float dist = radius / sinf(0.5f * fov * PI_F / 180.0f) * 1.05f;
	cam->eye[0] = centre[0] + dx / n * dist;
	cam->eye[1] = centre[1] + dy / n * dist;
	cam->eye[2] = centre[2] + dz / n * dist;
	memcpy(cam->target, centre, sizeof(cam->target));
	cam->up[0] = 0.0f;
	cam->up[1] = 1.0f;
	cam->up[2] = 0.0f;
	cam->fov_y_deg = fov;
}

/* ---- fig16: recursive aggregates ----------------------------------------- */

/* One aggregate: its frame (scale = size) and its level (0 = base). */
struct agg {
	struct frame f;
	uint32_t level;
};

/* Ten directions spread over the sphere (a Fibonacci lattice), where the
 * sub-objects of an aggregate sit. */
static void fib_dir(uint32_t i, uint32_t n, float out[3])
{
	float y = 1.0f - 2.0f * ((float)i + 0.5f) / (float)n;
	float r = sqrtf(fmaxf(0.0f, 1.0f - y * y));
	float a = (float)i * 2.39996323f; /* golden angle */
	out[0] = r * cosf(a);
	out[1] = y;
	out[2] = r * sinf(a);
}

/* Sub-object scale and distance, relative to their parent. An aggregate
 * reaches about 0.8 of its scale; with children at 0.85 of size 0.38 the
 * whole object stays within 0.85 / (1 - 0.38) ~ 1.37 of the base scale,
 * and within about 1.15 in practice (the outer sub-objects point away from
 * the view only partly): the camera frames that. */
#define FIG16_CHILD_SCALE 0.38f
#define FIG16_CHILD_DIST 0.85f
#define FIG16_EXTENT 1.15f

static const float fig16_palette[BC_GEN_MAX_LEVEL][3] = {
    {0.85f, 0.33f, 0.25f}, {0.93f, 0.62f, 0.22f}, {0.30f, 0.62f, 0.78f},
    {0.45f, 0.75f, 0.40f}, {0.72f, 0.48f, 0.82f}, {0.90f, 0.85f, 0.55f},
};

/* Emits the ten primitives of an aggregate as one operator: a body sphere,
 * a ring around it, four knobs, two rounded blocks and two arms. */
static int fig16_aggregate(struct gen *g, const struct agg *a, bool smooth)
{
	static const float knob[4][3] = {{0.38f, 0.38f, 0.38f},
	                                 {-0.38f, -0.38f, 0.38f},
	                                 {-0.38f, 0.38f, -0.38f},
	                                 {0.38f, -0.38f, -0.38f}};
	const float *base = fig16_palette[a->level % BC_GEN_MAX_LEVEL];
	const float zero[3] = {0.0f, 0.0f, 0.0f};
	float s = a->f.s, q[4], pos[3];
	struct bc_prim_data p;
	int rc;

	if ((rc = push(g, smooth ? BC_OP_SMOOTH_UNION : BC_OP_UNION,
	               0.12f * s))) {
		return rc;
	}
	bc_quat_identity(q);
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	if ((rc = set1(g, &p, "radius", 0.5f * s))) {
		return rc;
	}
	place(&p, &a->f, zero, q);
	set_color(&p, base[0], base[1], base[2]);
	if ((rc = put(g, &p))) {
		return rc;
	}

	bc_prim_data_init(&p, BC_PRIM_TORUS);
	if ((rc = set1(g, &p, "major", 0.58f * s)) ||
	    (rc = set1(g, &p, "minor", 0.07f * s))) {
		return rc;
	}
	bc_quat_axis_angle(q, 1.0f, 0.0f, 0.0f, 0.35f);
	place(&p, &a->f, zero, q);
	set_color(&p, 0.9f * base[1], 0.9f * base[2], 0.9f * base[0]);
	if ((rc = put(g, &p))) {
		return rc;
	}

	bc_quat_identity(q);
	for (int k = 0; k < 4; k++) {
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		if ((rc = set1(g, &p, "radius", 0.16f * s))) {
			return rc;
		}
		place(&p, &a->f, knob[k], q);
		set_color(&p, 0.6f * base[0] + 0.4f, 0.6f * base[1] + 0.4f,
		          0.6f * base[2] + 0.4f);
		if ((rc = put(g, &p))) {
			return rc;
		}
	}

	for (int k = 0; k < 2; k++) {
		bc_prim_data_init(&p, BC_PRIM_BOX);
		if ((rc = set3(g, &p, "half_extents", 0.16f * s, 0.16f * s,
		               0.16f * s)) ||
		    (rc = set1(g, &p, "round", 0.03f * s))) {
			return rc;
		}
		pos[0] = k ? -0.55f : 0.55f;
		pos[1] = 0.0f;
		pos[2] = 0.0f;
		bc_quat_axis_angle(q, 0.0f, 0.0f, 1.0f, 0.6f);
		place(&p, &a->f, pos, q);
		set_color(&p, base[2], base[0], base[1]);
		if ((rc = put(g, &p))) {
			return rc;
		}
	}

	bc_quat_identity(q);
	for (int k = 0; k < 2; k++) {
		float sign = k ? -1.0f : 1.0f;
		bc_prim_data_init(&p, BC_PRIM_CAPSULE);
		if ((rc = set3(g, &p, "a", 0.0f, 0.3f * sign * s, 0.0f)) ||
		    (rc =
		         set3(g, &p, "b", 0.0f, 0.72f * sign * s, 0.18f * s)) ||
		    (rc = set1(g, &p, "radius", 0.09f * s))) {
			return rc;
		}
		place(&p, &a->f, zero, q);
		set_color(&p, base[1], base[2], base[0]);
		if ((rc = put(g, &p))) {
			return rc;
		}
	}
	return pop(g);
}

/*
 * Level L: the base aggregate, its ten sub-objects, theirs, ... down to L
 * levels of aggregates (10 (10^L - 1) / 9 primitives). The tree combines
 * them from largest to smallest, as the paper does to limit ROI
 * propagation: each level is one operator whose first child is everything
 * larger, and whose blend is proportional to that level's scale -- so the
 * operators near the root, which propagate their range down the tree, are
 * those with the smallest blends.
 */
static int gen_fig16(struct gen *g, struct bc_camera *cam)
{
	const struct bc_gen_opts *o = g->o;
	uint32_t level = o->level ? o->level : 2;
	bool smooth = smooth_of(o, true);
	struct agg *aggs = NULL;
	uint32_t start[BC_GEN_MAX_LEVEL + 1], total = 0, n = 1;
	int rc = 0;

	if (level < 1 || level > BC_GEN_MAX_LEVEL) {
		return bc_errinfo_set(g->ei, BC_ERANGE,
		                      "fig16: level %u outside 1..%d", level,
		                      BC_GEN_MAX_LEVEL);
	}
	for (uint32_t k = 0; k < level; k++) {
		start[k] = total;
		total += n;
		n *= 10;
	}
	start[level] = total;
	aggs = bc_calloc(total, sizeof(*aggs));
	if (!aggs) {
		return bc_errinfo_set(g->ei, BC_ENOMEM, "fig16: out of memory");
	}
	frame_init(&aggs[0].f);
	quat_random(&g->rng, aggs[0].f.q);
	for (uint32_t k = 1; k < level; k++) {
		for (uint32_t i = start[k - 1]; i < start[k]; i++) {
			const struct agg *pa = &aggs[i];
			for (uint32_t c = 0; c < 10; c++) {
				struct agg *ch =
				    &aggs[start[k] + (i - start[k - 1]) * 10 +
				          c];
				float d[3], w[3];
				fib_dir(c, 10, d);
				bc_quat_rotate(pa->f.q, d, w);
				for (int j = 0; j < 3; j++) {
					ch->f.t[j] =
					    pa->f.t[j] +
					    FIG16_CHILD_DIST * pa->f.s * w[j];
				}
				ch->f.s = pa->f.s * FIG16_CHILD_SCALE;
				quat_random(&g->rng, ch->f.q);
				ch->level = k;
			}
		}
	}

	/* Outermost operator first: the root combines level L-1 with all
	 * that is larger, and so on down to level 1. */
	for (uint32_t k = level - 1; k >= 1; k--) {
		float s = aggs[start[k]].f.s;
		if ((rc = push(g, smooth ? BC_OP_SMOOTH_UNION : BC_OP_UNION,
		               0.08f * s))) {
			goto cleanup;
		}
	}
	for (uint32_t k = 0; k < level; k++) {
		for (uint32_t i = start[k]; i < start[k + 1]; i++) {
			if ((rc = fig16_aggregate(g, &aggs[i], smooth))) {
				goto cleanup;
			}
		}
		if (k > 0 && (rc = pop(g))) {
			goto cleanup;
		}
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, level == 1 ? 0.8f : FIG16_EXTENT, 0.55f,
		             0.45f, 1.0f);
	}
cleanup:
	bc_free(aggs);
	return rc;
}

/* ---- fig18, many-spheres, comb: many instances under one operator -------- */

/* Emits one fig18 instance of the given kind at position pos with size r. */
static int fig18_instance(struct gen *g, enum bc_gen_kind kind, bool smooth,
                          const float pos[3], float r, const float col[3])
{
	struct bc_prim_data p;
	int rc;
	if (kind == BC_GEN_KIND_BOXES) {
		bc_prim_data_init(&p, BC_PRIM_BOX);
		if ((rc = set3(g, &p, "half_extents",
		               r * rng_float(&g->rng, 0.45f, 0.8f),
		               r * rng_float(&g->rng, 0.45f, 0.8f),
		               r * rng_float(&g->rng, 0.45f, 0.8f)))) {
			return rc;
		}
		quat_random(&g->rng, p.rotate);
	} else if (kind == BC_GEN_KIND_SPHERES) {
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		if ((rc = set1(g, &p, "radius",
		               r * rng_float(&g->rng, 0.6f, 0.9f)))) {
			return rc;
		}
	} else {
		/* A lens: two spheres of radius r whose centres are 1.2 r
		 * apart along a random axis, intersected. */
		float q[4], axis[3], z[3] = {0.0f, 0.0f, 1.0f};
		quat_random(&g->rng, q);
		bc_quat_rotate(q, z, axis);
		if ((rc = push(g,
		               smooth ? BC_OP_SMOOTH_INTERSECTION
		                      : BC_OP_INTERSECTION,
		               0.1f * r))) {
			return rc;
		}
		for (int k = 0; k < 2; k++) {
			float sign = k ? -1.0f : 1.0f;
			bc_prim_data_init(&p, BC_PRIM_SPHERE);
			if ((rc = set1(g, &p, "radius", r))) {
				return rc;
			}
			for (int j = 0; j < 3; j++) {
				p.translate[j] =
				    pos[j] + sign * 0.6f * r * axis[j];
			}
			set_color(&p, col[0], col[1], col[2]);
			if ((rc = put(g, &p))) {
				return rc;
			}
		}
		return pop(g);
	}
	memcpy(p.translate, pos, sizeof(p.translate));
	set_color(&p, col[0], col[1], col[2]);
	return put(g, &p);
}

/* Uniform positions in the cube [-1, 1]^3; the instance size follows the
 * mean spacing 2 / cbrt(N) so that neighbours overlap moderately whatever
 * the count. */
static int gen_fig18(struct gen *g, struct bc_camera *cam)
{
	const struct bc_gen_opts *o = g->o;
	uint32_t count = o->count ? o->count : 256;
	enum bc_gen_kind kind = o->kind ? o->kind : BC_GEN_KIND_BOXES;
	bool smooth = smooth_of(o, true);
	uint32_t per = kind == BC_GEN_KIND_LENSES ? 2 : 1;
	float r = 0.75f * 2.0f / cbrtf((float)count);
	int rc;

	if (kind >= BC_GEN_KIND_COUNT) {
		return bc_errinfo_set(g->ei, BC_ERANGE,
		                      "fig18: unknown kind %d", (int)kind);
	}
	if ((uint64_t)count * per > BC_GEN_MAX_PRIMS) {
		return bc_errinfo_set(
		    g->ei, BC_ELIMIT,
		    "fig18: %u instances exceed %u primitives", count,
		    BC_GEN_MAX_PRIMS);
	}
	if (count > 1 &&
	    (rc = push(g, smooth ? BC_OP_SMOOTH_UNION : BC_OP_UNION,
	               0.3f * r))) {
		return rc;
	}
	for (uint32_t i = 0; i < count; i++) {
		float pos[3], col[3];
		for (int j = 0; j < 3; j++) {
			pos[j] = rng_float(&g->rng, -1.0f, 1.0f);
		}
		/* Teal, as the paper shows its smooth variants, varied. */
		col[0] = rng_float(&g->rng, 0.05f, 0.25f);
		col[1] = rng_float(&g->rng, 0.5f, 0.7f);
		col[2] = rng_float(&g->rng, 0.55f, 0.75f);
		if ((rc = fig18_instance(g, kind, smooth, pos, r, col))) {
			return rc;
		}
	}
	if (count > 1 && (rc = pop(g))) {
		return rc;
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, 1.75f * (1.0f + r), 0.6f, 0.5f, 1.0f);
	}
	return 0;
}

static int gen_many_spheres(struct gen *g, struct bc_camera *cam)
{
	uint32_t count = g->o->count ? g->o->count : 2745;
	float r = 0.6f * 2.0f / cbrtf((float)count);
	int rc;
	if (count > BC_GEN_MAX_PRIMS) {
		return bc_errinfo_set(g->ei, BC_ELIMIT,
		                      "many-spheres: %u spheres exceed %u",
		                      count, BC_GEN_MAX_PRIMS);
	}
	if (count > 1 && (rc = push(g, BC_OP_UNION, 0.0f))) {
		return rc;
	}
	for (uint32_t i = 0; i < count; i++) {
		struct bc_prim_data p;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		if ((rc = set1(g, &p, "radius",
		               r * rng_float(&g->rng, 0.4f, 1.0f)))) {
			return rc;
		}
		for (int j = 0; j < 3; j++) {
			p.translate[j] = rng_float(&g->rng, -1.0f, 1.0f);
		}
		set_color(&p, rng_float(&g->rng, 0.2f, 1.0f),
		          rng_float(&g->rng, 0.2f, 1.0f),
		          rng_float(&g->rng, 0.2f, 1.0f));
		if ((rc = put(g, &p))) {
			return rc;
		}
	}
	if (count > 1 && (rc = pop(g))) {
		return rc;
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, 1.75f * (1.0f + r), 0.6f, 0.5f, 1.0f);
	}
	return 0;
}

/* Spheres along the x axis over a length of 4, neighbours overlapping:
 * one n-ary operator, whose linearized form is the paper's left comb. */
static int gen_comb(struct gen *g, struct bc_camera *cam)
{
	uint32_t count = g->o->count ? g->o->count : 64;
	bool smooth = smooth_of(g->o, false);
	float step = 4.0f / (float)count;
	float r = fminf(0.75f * step, 0.5f);
	int rc;
	if (count > BC_GEN_MAX_PRIMS) {
		return bc_errinfo_set(g->ei, BC_ELIMIT,
		                      "comb: %u spheres exceed %u", count,
		                      BC_GEN_MAX_PRIMS);
	}
	if (count > 1 &&
	    (rc = push(g, smooth ? BC_OP_SMOOTH_UNION : BC_OP_UNION,
	               0.5f * r))) {
		return rc;
	}
	for (uint32_t i = 0; i < count; i++) {
		struct bc_prim_data p;
		float u = count > 1 ? (float)i / (float)(count - 1) : 0.5f;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		if ((rc = set1(g, &p, "radius", r))) {
			return rc;
		}
		p.translate[0] = -2.0f + step * ((float)i + 0.5f);
		set_color(&p, 0.9f - 0.6f * u, 0.35f + 0.3f * u,
		          0.3f + 0.6f * u);
		if ((rc = put(g, &p))) {
			return rc;
		}
	}
	if (count > 1 && (rc = pop(g))) {
		return rc;
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, 2.0f + r, 0.0f, 0.35f, 1.0f);
	}
	return 0;
}

/* ---- gears ----------------------------------------------------------------
 */

/* Lightening holes in gears with this many teeth or more. */
#define GEAR_HOLES_MIN_TEETH 12u
#define GEAR_HOLES 4u

/* Primitives of one gear with teeth teeth. */
static uint32_t gear_prims(uint32_t teeth)
{
	return 2u + teeth + (teeth >= GEAR_HOLES_MIN_TEETH ? GEAR_HOLES : 0u);
}

/*
 * One gear in the xy plane, facing +z, centred at c: difference(union(disc,
 * teeth...), hub, holes...). Tooth pitch is module m (the pitch radius is
 * m teeth / 2), so gears of one module mesh. phase turns the gear.
 */
static int gear(struct gen *g, const float c[3], uint32_t teeth, float m,
                float phase, const float col[3])
{
	/* The cylinder's axis is its local y: turn it onto z. */
	float to_z[4];
	float rp = 0.5f * m * (float)teeth, h = 0.35f * m + 0.02f * rp;
	struct bc_prim_data p;
	int rc;

	bc_quat_axis_angle(to_z, 1.0f, 0.0f, 0.0f, 0.5f * PI_F);
	if ((rc = push(g, BC_OP_DIFFERENCE, 0.0f)) ||
	    (rc = push(g, BC_OP_UNION, 0.0f))) {
		return rc;
	}
	bc_prim_data_init(&p, BC_PRIM_CYLINDER);
	if ((rc = set1(g, &p, "radius", rp - 0.45f * m)) ||
	    (rc = set1(g, &p, "half_height", h))) {
		return rc;
	}
	memcpy(p.translate, c, sizeof(p.translate));
	memcpy(p.rotate, to_z, sizeof(p.rotate));
	set_color(&p, col[0], col[1], col[2]);
	if ((rc = put(g, &p))) {
		return rc;
	}
	for (uint32_t i = 0; i < teeth; i++) {
		float a = phase + 2.0f * PI_F * (float)i / (float)teeth;
		bc_prim_data_init(&p, BC_PRIM_BOX);
		/* About half the circular pitch (pi m) wide, reaching
		 * 0.44 m past the pitch circle: meshing teeth clear the
		 * other gear's disc. */
		if ((rc =
		         set3(g, &p, "half_extents", 0.47f * m, 0.7f * m, h))) {
			return rc;
		}
		/* Radial along local x, then turned by a about z. */
		p.translate[0] = c[0] + (rp - 0.03f * m) * cosf(a);
		p.translate[1] = c[1] + (rp - 0.03f * m) * sinf(a);
		p.translate[2] = c[2];
		bc_quat_axis_angle(p.rotate, 0.0f, 0.0f, 1.0f, a);
		set_color(&p, col[0], col[1], col[2]);
		if ((rc = put(g, &p))) {
			return rc;
		}
	}
	if ((rc = pop(g))) {
		return rc;
	}
	bc_prim_data_init(&p, BC_PRIM_CYLINDER);
	if ((rc = set1(g, &p, "radius", 0.18f * rp)) ||
	    (rc = set1(g, &p, "half_height", 2.0f * h))) {
		return rc;
	}
	memcpy(p.translate, c, sizeof(p.translate));
	memcpy(p.rotate, to_z, sizeof(p.rotate));
	set_color(&p, 0.3f, 0.3f, 0.32f);
	if ((rc = put(g, &p))) {
		return rc;
	}
	if (teeth >= GEAR_HOLES_MIN_TEETH) {
		for (uint32_t i = 0; i < GEAR_HOLES; i++) {
			float a = phase + 2.0f * PI_F * ((float)i + 0.5f) /
			                      (float)GEAR_HOLES;
			bc_prim_data_init(&p, BC_PRIM_CYLINDER);
			if ((rc = set1(g, &p, "radius", 0.2f * rp)) ||
			    (rc = set1(g, &p, "half_height", 2.0f * h))) {
				return rc;
			}
			p.translate[0] = c[0] + 0.55f * rp * cosf(a);
			p.translate[1] = c[1] + 0.55f * rp * sinf(a);
			p.translate[2] = c[2];
			memcpy(p.rotate, to_z, sizeof(p.rotate));
			set_color(&p, 0.3f, 0.3f, 0.32f);
			if ((rc = put(g, &p))) {
				return rc;
			}
		}
	}
	return pop(g);
}

/* Three meshing gears of T, 2T/3 and T/2 teeth (at least 6), one module. */
static int gen_gears(struct gen *g, struct bc_camera *cam)
{
	static const float col[3][3] = {{0.80f, 0.62f, 0.25f},
	                                {0.62f, 0.66f, 0.72f},
	                                {0.78f, 0.42f, 0.28f}};
	uint32_t t0 = g->o->teeth ? g->o->teeth : 24, tt[3];
	float m, r[3], c[3][3] = {{0}}, centre[3], dir[2];
	int rc;
	if (t0 < 6 || t0 > BC_GEN_MAX_TEETH) {
		return bc_errinfo_set(g->ei, BC_ERANGE,
		                      "gears: %u teeth outside 6..%u", t0,
		                      BC_GEN_MAX_TEETH);
	}
	tt[0] = t0;
	tt[1] = t0 * 2 / 3 > 6 ? t0 * 2 / 3 : 6;
	tt[2] = t0 / 2 > 6 ? t0 / 2 : 6;
	/* Whole train about 4 units wide. */
	m = 4.0f / (float)(tt[0] + tt[1] + tt[2] / 2 + 6);
	for (int i = 0; i < 3; i++) {
		r[i] = 0.5f * m * (float)tt[i];
	}
	/* The second gear meshes with the first along +x, the third at
	 * about 63 degrees: both on directions where the first has a
	 * tooth, and each turned so that a gap faces the first. */
	dir[0] = 0.0f;
	dir[1] = 2.0f * PI_F *
	         floorf(1.1f * (float)tt[0] / (2.0f * PI_F) + 0.5f) /
	         (float)tt[0];
	c[0][0] = -0.5f * (r[0] + r[1]);
	for (int i = 1; i < 3; i++) {
		c[i][0] = c[0][0] + (r[0] + r[i]) * cosf(dir[i - 1]);
		c[i][1] = (r[0] + r[i]) * sinf(dir[i - 1]);
	}
	if ((rc = push(g, BC_OP_UNION, 0.0f))) {
		return rc;
	}
	for (int i = 0; i < 3; i++) {
		float phase =
		    i == 0 ? 0.0f : dir[i - 1] + PI_F + PI_F / (float)tt[i];
		if ((rc = gear(g, c[i], tt[i], m, phase, col[i]))) {
			return rc;
		}
	}
	if ((rc = pop(g))) {
		return rc;
	}
	if (cam) {
		/* The box around the three outer circles. */
		float lo[2] = {1e30f, 1e30f}, hi[2] = {-1e30f, -1e30f};
		for (int i = 0; i < 3; i++) {
			for (int j = 0; j < 2; j++) {
				lo[j] = fminf(lo[j], c[i][j] - r[i] - m);
				hi[j] = fmaxf(hi[j], c[i][j] + r[i] + m);
			}
		}
		centre[0] = 0.5f * (lo[0] + hi[0]);
		centre[1] = 0.5f * (lo[1] + hi[1]);
		centre[2] = 0.0f;
		frame_camera(cam, centre,
		             0.5f * hypotf(hi[0] - lo[0], hi[1] - lo[1]), 0.25f,
		             0.35f, 1.0f);
	}
	return 0;
}

/* N gears on a square grid, 10 to 20 teeth each (or --teeth), random
 * phases and colours, one sharp union. */
static int gen_many_gears(struct gen *g, struct bc_camera *cam)
{
	uint32_t count = g->o->count ? g->o->count : 64;
	uint32_t fixed = g->o->teeth, cols = 1;
	uint64_t prims = 0;
	float m = 0.1f, pitch;
	int rc;
	if (fixed && (fixed < 6 || fixed > BC_GEN_MAX_TEETH)) {
		return bc_errinfo_set(g->ei, BC_ERANGE,
		                      "many-gears: %u teeth outside 6..%u",
		                      fixed, BC_GEN_MAX_TEETH);
	}
	prims = (uint64_t)count * gear_prims(fixed ? fixed : 20);
	if (prims > BC_GEN_MAX_PRIMS) {
		return bc_errinfo_set(g->ei, BC_ELIMIT,
		                      "many-gears: %u gears exceed %u "
		                      "primitives",
		                      count, BC_GEN_MAX_PRIMS);
	}
	while (cols * cols < count) {
		cols++;
	}
	/* Largest outer radius is m (T / 2 + 0.6); leave a small gap. */
	pitch = m * ((float)(fixed ? fixed : 20) + 1.6f);
	if (count > 1 && (rc = push(g, BC_OP_UNION, 0.0f))) {
		return rc;
	}
	for (uint32_t i = 0; i < count; i++) {
		uint32_t teeth = fixed ? fixed : 10 + rng_below(&g->rng, 11);
		float c[3], col[3];
		c[0] = ((float)(i % cols) - 0.5f * (float)(cols - 1)) * pitch;
		c[1] = ((float)(i / cols) - 0.5f * (float)(cols - 1)) * pitch;
		c[2] = 0.0f;
		col[0] = rng_float(&g->rng, 0.35f, 0.95f);
		col[1] = rng_float(&g->rng, 0.35f, 0.85f);
		col[2] = rng_float(&g->rng, 0.25f, 0.75f);
		if ((rc = gear(g, c, teeth, m,
		               rng_float(&g->rng, 0.0f, 2.0f * PI_F), col))) {
			return rc;
		}
	}
	if (count > 1 && (rc = pop(g))) {
		return rc;
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, 0.75f * pitch * (float)cols, 0.2f, 0.3f,
		             1.0f);
	}
	return 0;
}

/* ---- random trees ----------------------------------------------------------
 */

/* Random trees draw from the first sixteen kinds only, the catalogue the
 * generator was written with: a seed names the same scene in every version
 * (tests and benchmarks pin seeds), which drawing from kinds added later
 * would break. */
#define GEN_RANDOM_KINDS ((uint32_t)BC_PRIM_TRI_PRISM)

/* Fills p with random parameters of a random kind. Shapes have rules of
 * their own (angles, radii orders), so draws are checked with
 * bc_prim_validate() and repeated; a sphere is the fallback that keeps the
 * generator total. */
static void random_prim(struct gen *g, struct bc_prim_data *p, float spread)
{
	enum bc_prim kind =
	    (enum bc_prim)(1 + rng_below(&g->rng, GEN_RANDOM_KINDS));
	for (int attempt = 0; attempt < 64; attempt++) {
		const struct bc_prim_info *info = bc_prim_info(kind);
		bc_prim_data_init(p, kind);
		for (uint32_t i = 0; info && i < info->nparams; i++) {
			const struct bc_param_desc *d = &info->params[i];
			for (uint32_t k = 0; k < d->count; k++) {
				float v;
				if (d->flags & BC_PARAM_POSITIVE) {
					v = rng_float(&g->rng, 0.1f, 0.6f);
				} else if (d->flags & BC_PARAM_NONNEG) {
					v = rng_float(&g->rng, 0.0f, 0.15f);
				} else {
					v = rng_float(&g->rng, -0.6f, 0.6f);
				}
				if (d->offset + k < BC_PRIM_MAX_PARAMS) {
					p->params[d->offset + k] = v;
				}
			}
		}
		quat_random(&g->rng, p->rotate);
		for (int j = 0; j < 3; j++) {
			p->translate[j] = rng_float(&g->rng, -spread, spread);
		}
		if (rng_below(&g->rng, 4) != 0) {
			set_color(p, rng_float(&g->rng, 0.0f, 1.0f),
			          rng_float(&g->rng, 0.0f, 1.0f),
			          rng_float(&g->rng, 0.0f, 1.0f));
		}
		if (bc_prim_validate(p, NULL) == 0) {
			return;
		}
	}
	bc_prim_data_init(p, BC_PRIM_SPHERE);
	p->params[0] = 0.3f;
}

/* Emits a subtree of budget primitives (>= 1) at depth (0 = root). Every
 * operator has 2..budget children; a node whose children would pass the
 * depth limit takes all its primitives as direct children. Recursion is
 * bounded by the depth limit (<= BC_GEN_RANDOM_MAX_DEPTH). */
static int random_emit(struct gen *g, uint32_t budget, uint32_t depth,
                       uint32_t max_depth, float spread)
{
	struct bc_op_data op;
	uint32_t nchild, left = budget;
	int rc;
	if (budget == 1) {
		struct bc_prim_data p;
		random_prim(g, &p, spread);
		return put(g, &p);
	}
	/* Binary operators only (unary kinds came later: seeds keep naming
	 * the same scenes). */
	op.kind = (enum bc_op)(1 + rng_below(&g->rng, BC_OP_FIRST_UNARY - 1));
	op.blend = 0.0f;
	op.range = 0.0f;
	if (bc_op_is_smooth(op.kind)) {
		op.blend = rng_float(&g->rng, 0.05f, 0.3f);
		op.range = op.blend * rng_float(&g->rng, 1.0f, 2.0f);
	}
	if ((rc = bc_tree_push_op(g->t, g->next_id++, &op, g->ei))) {
		return rc;
	}
	if (depth + 2 >= max_depth) {
		nchild = budget;
	} else if (rng_below(&g->rng, 8) == 0) {
		/* Now and then a wide operator (a comb when folded). */
		nchild = 2 + rng_below(&g->rng, budget - 1);
	} else {
		nchild = 2 + rng_below(&g->rng, budget < 4 ? budget - 1 : 3);
	}
	for (uint32_t c = 0; c < nchild; c++) {
		uint32_t share =
		    c + 1 == nchild
		        ? left
		        : 1 + rng_below(&g->rng, left - (nchild - c - 1));
		if ((rc =
		         random_emit(g, share, depth + 1, max_depth, spread))) {
			return rc;
		}
		left -= share;
	}
	return pop(g);
}

static int gen_random(struct gen *g, struct bc_camera *cam)
{
	uint32_t count = g->o->count ? g->o->count : 50;
	uint32_t depth = g->o->depth ? g->o->depth : 12;
	float spread = 0.5f * cbrtf((float)count);
	if (count > BC_GEN_MAX_PRIMS) {
		return bc_errinfo_set(g->ei, BC_ELIMIT,
		                      "random: %u primitives exceed %u", count,
		                      BC_GEN_MAX_PRIMS);
	}
	if (depth < 2 || depth > BC_GEN_RANDOM_MAX_DEPTH) {
		return bc_errinfo_set(g->ei, BC_ERANGE,
		                      "random: depth %u outside 2..%u", depth,
		                      BC_GEN_RANDOM_MAX_DEPTH);
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, 1.8f * spread + 0.6f, 0.6f, 0.5f, 1.0f);
	}
	return random_emit(g, count, 0, depth, spread);
}

/* ---- the catalogue ---------------------------------------------------------
 */

/* Every primitive kind once, at its default parameters, on a square grid in
 * the xz plane 2.5 apart (the defaults are unit-sized), each turned by a
 * random rotation (seeded) so that no view sees only faces, under one sharp
 * union or, with --blend smooth, one smooth union. The scene every renderer
 * and encoding is compared on when kinds are added. */
static int gen_catalogue(struct gen *g, struct bc_camera *cam)
{
	uint32_t n = BC_PRIM_COUNT - 1, side = 1;
	bool smooth = smooth_of(g->o, false);
	float spacing = 2.5f, half;
	int rc;
	while (side * side < n) {
		side++;
	}
	half = 0.5f * spacing * (float)(side - 1);
	if ((rc = push(g, smooth ? BC_OP_SMOOTH_UNION : BC_OP_UNION,
	               smooth ? 0.3f : 0.0f))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_prim_data p;
		float h = (float)i / (float)n;
		bc_prim_data_init(&p, (enum bc_prim)(i + 1));
		quat_random(&g->rng, p.rotate);
		p.translate[0] = spacing * (float)(i % side) - half;
		p.translate[2] = spacing * (float)(i / side) - half;
		set_color(&p, 0.5f + 0.5f * cosf(6.2831853f * h),
		          0.5f + 0.5f * cosf(6.2831853f * (h + 0.33f)),
		          0.5f + 0.5f * cosf(6.2831853f * (h + 0.67f)));
		if ((rc = put(g, &p))) {
			return rc;
		}
	}
	if ((rc = pop(g))) {
		return rc;
	}
	if (cam) {
		const float c[3] = {0.0f, 0.0f, 0.0f};
		frame_camera(cam, c, 1.05f * (half + 1.5f), 0.3f, 0.9f, 1.0f);
	}
	return 0;
}

/* ---- table and entry point ------------------------------------------------
 */

/* The table, and beside it (same order) the function behind each entry. */
static const struct bc_gen_info infos[] = {
    {"fig16", "[--level L] [--blend sharp|smooth] [--seed S]",
     "recursive aggregates of the paper's Fig. 16: level L (1..6, "
     "default 2) has 10 (10^L - 1) / 9 primitives; smooth by default",
     BC_GEN_OPT_LEVEL | BC_GEN_OPT_BLEND | BC_GEN_OPT_SEED},
    {"fig18",
     "[--count N] [--kind boxes|spheres|lenses] [--blend sharp|smooth] "
     "[--seed S]",
     "N (default 256) randomly rotated instances uniform in a cube under "
     "one left-heavy operator, as in the paper's Fig. 18; boxes and "
     "smooth by default; a lens is two intersected spheres",
     BC_GEN_OPT_COUNT | BC_GEN_OPT_KIND | BC_GEN_OPT_BLEND | BC_GEN_OPT_SEED},
    {"comb", "[--count N] [--blend sharp|smooth]",
     "N (default 64) overlapping spheres along a line under one n-ary "
     "union: a left comb once linearized; sharp by default",
     BC_GEN_OPT_COUNT | BC_GEN_OPT_BLEND},
    {"random", "[--count N] [--seed S] [--depth D]",
     "N (default 50) primitives of the first sixteen kinds (sphere to "
     "tri_prism) under operators of every kind, randomly nested at most D "
     "(2..128, default 12) deep, random transforms and colours",
     BC_GEN_OPT_COUNT | BC_GEN_OPT_SEED | BC_GEN_OPT_DEPTH},
    {"gears", "[--teeth T]",
     "three meshing gears of T (6..1000, default 24), 2T/3 and T/2 teeth: "
     "discs and teeth boxes unioned, minus hub and lightening holes",
     BC_GEN_OPT_TEETH},
    {"many-gears", "[--count N] [--teeth T] [--seed S]",
     "N (default 64) gears on a grid, 10 to 20 teeth each unless --teeth "
     "is given, one sharp union",
     BC_GEN_OPT_COUNT | BC_GEN_OPT_TEETH | BC_GEN_OPT_SEED},
    {"many-spheres", "[--count N] [--seed S]",
     "N (default 2745) spheres random in a cube, one sharp union",
     BC_GEN_OPT_COUNT | BC_GEN_OPT_SEED},
    {"catalogue", "[--blend sharp|smooth] [--seed S]",
     "every primitive kind once at its default size, randomly turned, on "
     "a grid in the xz plane under one union; sharp by default",
     BC_GEN_OPT_BLEND | BC_GEN_OPT_SEED},
};

static int (*const fns[])(struct gen *g, struct bc_camera *cam) = {
    gen_fig16, gen_fig18,      gen_comb,         gen_random,
    gen_gears, gen_many_gears, gen_many_spheres, gen_catalogue,
};

#define NGENS (sizeof(infos) / sizeof(infos[0]))

_Static_assert(sizeof(fns) / sizeof(fns[0]) == NGENS,
               "one function per generator");

const struct bc_gen_info *bc_gen_list(size_t *n)
{
	*n = NGENS;
	return infos;
}

static int find(const char *name)
{
	for (size_t i = 0; name && i < NGENS; i++) {
		if (strcmp(infos[i].name, name) == 0) {
			return (int)i;
		}
	}
	return -1;
}

const struct bc_gen_info *bc_gen_find(const char *name)
{
	int i = find(name);
	return i < 0 ? NULL : &infos[i];
}

enum bc_gen_kind bc_gen_kind_from_name(const char *name)
{
	static const char *const names[BC_GEN_KIND_COUNT] = {
	    NULL, "boxes", "spheres", "lenses"};
	for (int i = 1; name && i < BC_GEN_KIND_COUNT; i++) {
		if (strcmp(name, names[i]) == 0) {
			return (enum bc_gen_kind)i;
		}
	}
	return BC_GEN_KIND_DEFAULT;
}

enum bc_gen_blend bc_gen_blend_from_name(const char *name)
{
	if (name && strcmp(name, "sharp") == 0) {
		return BC_GEN_BLEND_SHARP;
	}
	if (name && strcmp(name, "smooth") == 0) {
		return BC_GEN_BLEND_SMOOTH;
	}
	return BC_GEN_BLEND_DEFAULT;
}

int bc_gen(const char *name, const struct bc_gen_opts *opts, struct bc_tree *t,
           struct bc_camera *cam, struct bc_errinfo *ei)
{
	static const struct bc_gen_opts none;
	int idx = find(name);
	const struct bc_gen_info *e = idx < 0 ? NULL : &infos[idx];
	const struct bc_gen_opts *o = opts ? opts : &none;
	struct gen g;
	unsigned given = 0;
	int rc;

	bc_tree_begin(t);
	if (cam) {
		bc_camera_default(cam);
	}
	if (!e) {
		return bc_errinfo_set(ei, BC_ENOTFOUND,
		                      "no generator called \"%s\"",
		                      name ? name : "(null)");
	}
	given |= o->level ? BC_GEN_OPT_LEVEL : 0u;
	given |= o->count ? BC_GEN_OPT_COUNT : 0u;
	given |= o->seed ? BC_GEN_OPT_SEED : 0u;
	given |= o->kind ? BC_GEN_OPT_KIND : 0u;
	given |= o->blend ? BC_GEN_OPT_BLEND : 0u;
	given |= o->teeth ? BC_GEN_OPT_TEETH : 0u;
	given |= o->depth ? BC_GEN_OPT_DEPTH : 0u;
	if (given & ~e->takes) {
		return bc_errinfo_set(ei, BC_EINVAL, "%s: takes only %s",
		                      e->name, e->usage);
	}
	if ((unsigned)o->kind >= BC_GEN_KIND_COUNT ||
	    (unsigned)o->blend >= BC_GEN_BLEND_COUNT) {
		return bc_errinfo_set(
		    ei, BC_ERANGE, "%s: kind or blend out of range", e->name);
	}
	memset(&g, 0, sizeof(g));
	g.t = t;
	g.ei = ei;
	g.o = o;
	g.next_id = 1;
	rng_seed(&g.rng, o->seed);
	if ((rc = fns[idx](&g, cam)) || (rc = bc_tree_end(t, ei))) {
		bc_tree_begin(t);
		if (cam) {
			bc_camera_default(cam);
		}
		return rc;
	}
	return 0;
}
