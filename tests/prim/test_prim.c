/*
 * Primitives: the parameter table, defaults and validation, every field
 * against closed-form values and alternative formulas, the exact fields
 * against brute-force distances to their own surface, the Lipschitz bound,
 * the ellipsoid's bound against an exact root finder, and the local
 * bounding shapes (they hold the solid, touch it, and never exceed the
 * field: the ABV invariant).
 */
#include "blobcast/blobtree.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "test.h"

/* ---- Helpers ------------------------------------------------------------ */

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;

static void rng_seed(uint64_t s)
{
	rng_state = s * 0x9e3779b97f4a7c15ull + 1u;
}

static uint32_t rng_u32(void)
{
	rng_state ^= rng_state >> 12;
	rng_state ^= rng_state << 25;
	rng_state ^= rng_state >> 27;
	return (uint32_t)((rng_state * 0x2545f4914f6cdd1dull) >> 32);
}

static float rnd(float lo, float hi)
{
	return lo + (hi - lo) * (float)((double)rng_u32() / 4294967296.0);
}

/* A primitive with its packed record, ready to evaluate. */
struct shape {
	struct bc_prim_data d;
	float k[BC_PRIM_PACKED];
	struct bc_abv bound;
};

/* Sets s to kind with params v[0..n) (the rest at defaults); returns the
 * validation result. */
static int shape_make(struct shape *s, enum bc_prim kind, const float *v, int n)
{
	struct bc_errinfo ei = {0};
	bc_prim_data_init(&s->d, kind);
	for (int i = 0; i < n; i++) {
		s->d.params[i] = v[i];
	}
	int rc = bc_prim_validate(&s->d, &ei);
	if (rc) {
		fprintf(stderr, "  validate: %s\n", ei.msg);
	}
	bc_prim_pack(&s->d, s->k);
	bc_prim_bound(&s->d, &s->bound);
	return rc;
}

static float sdf(const struct shape *s, double x, double y, double z)
{
	return bc_prim_sdf(s->d.kind, s->k, (float)x, (float)y, (float)z);
}

static float sdfv(const struct shape *s, const double p[3])
{
	return sdf(s, p[0], p[1], p[2]);
}

static const double R3 = 1.7320508075688772;
static const double PI = 3.14159265358979324;

/*
 * Random valid parameters of kind, about unit size, kept in the ranges
 * where the field is documented as exact (tubes thinner than their ring,
 * capped tori whose end caps stay apart).
 */
static void shape_random(struct shape *s, enum bc_prim kind)
{
	float v[BC_PRIM_MAX_PARAMS] = {0};
	int n = 0;
	switch (kind) {
	case BC_PRIM_SPHERE:
	case BC_PRIM_OCTAHEDRON:
		v[n++] = rnd(0.3f, 1.2f);
		break;
	case BC_PRIM_BOX:
		for (int i = 0; i < 3; i++) {
			v[n++] = rnd(0.3f, 1.2f);
		}
		v[n++] = rng_u32() % 2 ? rnd(0.0f, 0.25f) : 0.0f;
		break;
	case BC_PRIM_CAPSULE:
	case BC_PRIM_ROUND_CONE:
		for (int i = 0; i < 6; i++) {
			v[n++] = rnd(-0.8f, 0.8f);
		}
		v[n++] = rnd(0.15f, 0.6f);
		if (kind == BC_PRIM_ROUND_CONE) {
			v[n++] = rng_u32() % 4 ? rnd(0.0f, 0.6f) : 0.0f;
		}
		break;
	case BC_PRIM_CYLINDER:
	case BC_PRIM_HEX_PRISM:
	case BC_PRIM_TRI_PRISM:
	case BC_PRIM_PYRAMID:
		v[n++] = rnd(0.3f, 1.2f);
		v[n++] = rnd(0.3f, 1.2f);
		break;
	case BC_PRIM_TORUS:
		v[n++] = rnd(0.6f, 1.2f);
		v[n++] = v[0] * rnd(0.1f, 0.6f);
		break;
	case BC_PRIM_CONE:
		v[n++] = rnd(0.3f, 1.2f);
		v[n++] = rng_u32() % 3 ? rnd(0.0f, 1.0f) : 0.0f;
		v[n++] = v[1] == 0.0f ? rnd(0.2f, 1.0f) : rnd(0.0f, 1.0f);
		break;
	case BC_PRIM_ELLIPSOID:
		for (int i = 0; i < 3; i++) {
			v[n++] = rnd(0.3f, 1.2f);
		}
		break;
	case BC_PRIM_BOX_FRAME:
		for (int i = 0; i < 3; i++) {
			v[n++] = rnd(0.4f, 1.2f);
		}
		v[n++] = rnd(0.05f, 0.35f);
		break;
	case BC_PRIM_CAPPED_TORUS:
		v[n++] = rnd(0.6f, 1.2f);
		v[n++] = v[0] * rnd(0.1f, 0.4f);
		v[n++] = rnd(10.0f, 150.0f);
		break;
	case BC_PRIM_LINK:
		v[n++] = rnd(0.0f, 0.8f);
		v[n++] = rnd(0.4f, 0.9f);
		v[n++] = v[1] * rnd(0.1f, 0.6f);
		break;
	case BC_PRIM_SOLID_ANGLE:
		v[n++] = rnd(0.5f, 1.2f);
		v[n++] = rnd(5.0f, 170.0f);
		break;
	case BC_PRIM_CUT_SPHERE:
	case BC_PRIM_CUT_HOLLOW_SPHERE:
		v[n++] = rnd(0.5f, 1.2f);
		v[n++] = v[0] * rnd(-0.9f, 0.9f);
		if (kind == BC_PRIM_CUT_HOLLOW_SPHERE) {
			v[n++] = v[0] * rnd(0.03f, 0.2f);
		}
		break;
	case BC_PRIM_DEATH_STAR:
		v[n++] = rnd(0.6f, 1.2f);
		v[n++] = v[0] * rnd(0.4f, 1.2f);
		v[n++] = fabsf(v[0] - v[1]) +
		         rnd(0.1f, 0.9f) * (v[0] + v[1] - fabsf(v[0] - v[1]));
		break;
	case BC_PRIM_ROUNDED_CYLINDER:
		v[n++] = rnd(0.3f, 1.0f);
		v[n++] = 0.0f;
		v[n++] = rnd(0.3f, 1.0f);
		v[1] = fminf(v[0], v[2]) * rnd(0.0f, 1.0f);
		break;
	case BC_PRIM_CAPPED_CYLINDER:
	case BC_PRIM_CAPPED_CONE:
	case BC_PRIM_VESICA_SEGMENT: {
		float l2 = 0.0f;
		do {
			l2 = 0.0f;
			for (int i = 0; i < 3; i++) {
				v[i] = rnd(-0.8f, 0.8f);
				v[3 + i] = rnd(-0.8f, 0.8f);
				l2 += (v[3 + i] - v[i]) * (v[3 + i] - v[i]);
			}
		} while (l2 < 0.09f);
		n = 6;
		if (kind == BC_PRIM_VESICA_SEGMENT) {
			v[n++] = 0.5f * sqrtf(l2) * rnd(0.1f, 1.0f);
		} else {
			v[n++] = rnd(0.1f, 0.6f);
		}
		if (kind == BC_PRIM_CAPPED_CONE) {
			v[n++] = rng_u32() % 4 ? rnd(0.0f, 0.6f) : 0.0f;
		}
		break;
	}
	case BC_PRIM_RHOMBUS:
		v[n++] = rnd(0.3f, 1.2f);
		v[n++] = rnd(0.3f, 1.2f);
		v[n++] = rnd(0.1f, 0.8f);
		v[n++] = rng_u32() % 2 ? rnd(0.0f, 0.2f) : 0.0f;
		break;
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_EXTRUDE_STAR:
	case BC_PRIM_REVOLVE_CIRCLE:
	case BC_PRIM_REVOLVE_RECT:
	case BC_PRIM_REVOLVE_POLYGON:
	case BC_PRIM_REVOLVE_STAR: {
		bool rev = kind >= BC_PRIM_REVOLVE_CIRCLE;
		enum bc_prim base = rev ? (enum bc_prim)(kind - 4) : kind;
		float extent;
		v[n++] = rnd(0.2f, 0.8f);
		extent = v[0];
		if (base == BC_PRIM_EXTRUDE_RECT) {
			v[n++] = rnd(0.2f, 0.8f);
			extent = v[0];
		} else if (base == BC_PRIM_EXTRUDE_POLYGON) {
			v[n++] = (float)(3 + rng_u32() % 8);
		} else if (base == BC_PRIM_EXTRUDE_STAR) {
			v[n++] = (float)(2 + rng_u32() % 8);
			v[n++] = rnd(0.2f, 0.9f);
		}
		/* Revolved profiles stay clear of the axis: exact there. */
		v[n++] = rev ? extent + rnd(0.05f, 0.6f) : rnd(0.1f, 0.8f);
		break;
	}
	default:
		break;
	}
	(void)shape_make(s, kind, v, n);
}

/* Signed distance to a local bounding shape, in double (independent of the
 * code under test). */
static double bound_sdf(const struct bc_abv *b, const double p[3])
{
	double q[3];
	for (int i = 0; i < 3; i++) {
		q[i] = p[i] - b->center[i];
	}
	switch (b->shape) {
	case BC_ABV_SPHERE:
		return sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) -
		       b->radius;
	case BC_ABV_BOX: {
		double out = 0.0, in = -INFINITY;
		for (int i = 0; i < 3; i++) {
			double l = q[0] * b->axis[i][0] + q[1] * b->axis[i][1] +
			           q[2] * b->axis[i][2];
			double e = fabs(l) - b->half[i];
			out += e > 0.0 ? e * e : 0.0;
			in = e > in ? e : in;
		}
		return sqrt(out) + (in < 0.0 ? in : 0.0);
	}
	case BC_ABV_CAPSULE: {
		double e[3], ee = 0.0, t = 0.0, d2 = 0.0;
		for (int i = 0; i < 3; i++) {
			e[i] = (double)b->end[i] - b->center[i];
			ee += e[i] * e[i];
			t += q[i] * e[i];
		}
		t = ee > 0.0 ? t / ee : 0.0;
		t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
		for (int i = 0; i < 3; i++) {
			double w = q[i] - t * e[i];
			d2 += w * w;
		}
		return sqrt(d2) - b->radius;
	}
	default:
		return NAN;
	}
}

/* A random point within margin of the bounding shape's AABB. */
static void random_near(const struct shape *s, double margin, double p[3])
{
	float lo[3], hi[3];
	bc_abv_aabb(&s->bound, lo, hi);
	for (int i = 0; i < 3; i++) {
		p[i] = rnd((float)(lo[i] - margin), (float)(hi[i] + margin));
	}
}

/* Central-difference gradient. */
static void grad(const struct shape *s, const double p[3], double h,
                 double g[3])
{
	for (int i = 0; i < 3; i++) {
		double a[3] = {p[0], p[1], p[2]}, b[3] = {p[0], p[1], p[2]};
		a[i] += h;
		b[i] -= h;
		g[i] = ((double)sdfv(s, a) - (double)sdfv(s, b)) / (2.0 * h);
	}
}

static double dist3(const double a[3], const double b[3])
{
	double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
	return sqrt(x * x + y * y + z * z);
}

/* Floats used by kind's parameter layout. */
static uint32_t layout_end(const struct bc_prim_info *info)
{
	uint32_t n = 0;
	for (uint32_t i = 0; i < info->nparams; i++) {
		uint32_t e =
		    (uint32_t)info->params[i].offset + info->params[i].count;
		n = e > n ? e : n;
	}
	return n;
}

/* Kinds whose field is exact inside for the random_shape ranges. */
static bool exact_inside(enum bc_prim kind)
{
	return bc_prim_info(kind)->exact && kind != BC_PRIM_BOX_FRAME;
}

#define NEAR(a, b) CHECK_NEAR(a, b, 2e-5)

/* ---- The table ---------------------------------------------------------- */

static void table_covers_every_kind_contiguously(void)
{
	const char *seen[BC_PRIM_COUNT] = {0};
	CHECK(bc_prim_info(BC_PRIM_INVALID) == NULL);
	CHECK(bc_prim_info(BC_PRIM_COUNT) == NULL);
	CHECK(bc_prim_info((enum bc_prim) - 1) == NULL);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		REQUIRE(info != NULL);
		REQUIRE(info->name != NULL);
		CHECK(info->nparams >= 1);
		uint32_t off = 0;
		for (uint32_t i = 0; i < info->nparams; i++) {
			const struct bc_param_desc *d = &info->params[i];
			CHECK_EQ_INT(d->offset, off);
			CHECK(d->count == 1 || d->count == 3);
			CHECK(d->name != NULL && d->name[0] != '\0');
			/* Not both sign rules. */
			CHECK(!((d->flags & BC_PARAM_POSITIVE) &&
			        (d->flags & BC_PARAM_NONNEG)));
			off += d->count;
		}
		CHECK(off <= BC_PRIM_MAX_PARAMS);
		for (int j = 1; j < k; j++) {
			CHECK(strcmp(seen[j], info->name) != 0);
		}
		seen[k] = info->name;
		CHECK_EQ_INT(bc_prim_from_name(info->name), k);
	}
	CHECK_EQ_INT(bc_prim_from_name("spheres"), BC_PRIM_INVALID);
	CHECK_EQ_INT(bc_prim_from_name(""), BC_PRIM_INVALID);
	CHECK_EQ_INT(bc_prim_from_name("SPHERE"), BC_PRIM_INVALID);
	/* Only the ellipsoid is a bound. */
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		CHECK(bc_prim_info((enum bc_prim)k)->exact ==
		      (k != BC_PRIM_ELLIPSOID));
	}
}

/* Checks that param i of kind is called name with count floats at off. */
static void check_param(enum bc_prim kind, uint32_t i, const char *name,
                        uint32_t off, uint32_t count)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	if (i >= info->nparams) {
		fprintf(stderr, "  %s has no parameter %u\n", info->name, i);
		bc_test_failures++;
		return;
	}
	const struct bc_param_desc *d = &info->params[i];
	if (strcmp(d->name, name) != 0 || d->offset != off ||
	    d->count != count) {
		fprintf(stderr,
		        "  %s parameter %u: %s@%u x%u, want %s@%u x%u\n",
		        info->name, i, d->name, d->offset, d->count, name, off,
		        count);
		bc_test_failures++;
	}
}

static void scene_format_names_are_fixed(void)
{
	CHECK_EQ_INT(bc_prim_from_name("sphere"), BC_PRIM_SPHERE);
	CHECK_EQ_INT(bc_prim_from_name("round_cone"), BC_PRIM_ROUND_CONE);
	CHECK_EQ_INT(bc_prim_from_name("tri_prism"), BC_PRIM_TRI_PRISM);
	check_param(BC_PRIM_SPHERE, 0, "radius", 0, 1);
	check_param(BC_PRIM_BOX, 0, "half_extents", 0, 3);
	check_param(BC_PRIM_BOX, 1, "round", 3, 1);
	CHECK(bc_prim_info(BC_PRIM_BOX)->params[1].flags & BC_PARAM_OPTIONAL);
	CHECK(bc_prim_info(BC_PRIM_BOX)->params[1].def == 0.0f);
	check_param(BC_PRIM_CAPSULE, 0, "a", 0, 3);
	check_param(BC_PRIM_CAPSULE, 1, "b", 3, 3);
	check_param(BC_PRIM_CAPSULE, 2, "radius", 6, 1);
	check_param(BC_PRIM_CYLINDER, 0, "radius", 0, 1);
	check_param(BC_PRIM_CYLINDER, 1, "half_height", 1, 1);
	check_param(BC_PRIM_TORUS, 0, "major", 0, 1);
	check_param(BC_PRIM_TORUS, 1, "minor", 1, 1);
	check_param(BC_PRIM_CONE, 0, "half_height", 0, 1);
	check_param(BC_PRIM_CONE, 1, "radius_bottom", 1, 1);
	check_param(BC_PRIM_CONE, 2, "radius_top", 2, 1);
	check_param(BC_PRIM_ROUND_CONE, 3, "radius_b", 7, 1);
	check_param(BC_PRIM_CAPPED_TORUS, 2, "angle_deg", 2, 1);
	check_param(BC_PRIM_SOLID_ANGLE, 1, "angle_deg", 1, 1);
	check_param(BC_PRIM_PYRAMID, 1, "height", 1, 1);
	check_param(BC_PRIM_CUT_HOLLOW_SPHERE, 2, "thickness", 2, 1);
	check_param(BC_PRIM_DEATH_STAR, 2, "d", 2, 1);
	check_param(BC_PRIM_CAPPED_CONE, 3, "rb", 7, 1);
	check_param(BC_PRIM_RHOMBUS, 3, "round", 3, 1);
	check_param(BC_PRIM_VESICA_SEGMENT, 2, "w", 6, 1);
	check_param(BC_PRIM_EXTRUDE_STAR, 3, "half_depth", 3, 1);
	check_param(BC_PRIM_REVOLVE_STAR, 3, "offset", 3, 1);
	check_param(BC_PRIM_REVOLVE_POLYGON, 1, "sides", 1, 1);
	/* Only the documented optional parameters (the box's and the
	 * rhombus's rounding) are optional. */
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		for (uint32_t i = 0; i < info->nparams; i++) {
			bool opt = info->params[i].flags & BC_PARAM_OPTIONAL;
			CHECK(opt == ((k == BC_PRIM_BOX && i == 1) ||
			              (k == BC_PRIM_RHOMBUS && i == 3)));
		}
	}
}

static void init_gives_valid_unit_shapes(void)
{
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		struct bc_prim_data p;
		struct bc_errinfo ei = {0};
		memset(&p, 0xff, sizeof(p));
		bc_prim_data_init(&p, (enum bc_prim)k);
		CHECK_EQ_INT(p.kind, k);
		CHECK(p.rotate[0] == 0.0f && p.rotate[1] == 0.0f &&
		      p.rotate[2] == 0.0f && p.rotate[3] == 1.0f);
		CHECK(p.translate[0] == 0.0f && p.translate[1] == 0.0f &&
		      p.translate[2] == 0.0f);
		CHECK(!p.has_color);
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		for (uint32_t i = 0; i < info->nparams; i++) {
			const struct bc_param_desc *d = &info->params[i];
			for (uint32_t c = 0; c < d->count; c++) {
				CHECK(p.params[d->offset + c] == d->def);
			}
		}
		/* Floats past the layout are zero, not garbage. */
		for (uint32_t i = layout_end(info); i < BC_PRIM_MAX_PARAMS;
		     i++) {
			CHECK(p.params[i] == 0.0f);
		}
		int rc = bc_prim_validate(&p, &ei);
		if (rc) {
			fprintf(stderr, "  %s: %s\n", info->name, ei.msg);
		}
		CHECK_EQ_INT(rc, 0);
		/* A default shape is solid at its bound's centre region. */
		struct shape s;
		s.d = p;
		bc_prim_pack(&p, s.k);
		bc_prim_bound(&p, &s.bound);
		double inside = 0;
		for (int i = 0; i < 2000; i++) {
			double q[3];
			random_near(&s, 0.0, q);
			inside += sdfv(&s, q) < 0.0f;
		}
		CHECK(inside > 0);
	}
}

/* ---- Closed-form values ------------------------------------------------- */

static void sphere_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_SPHERE, (float[]){1.5f}, 1) == 0);
	NEAR(sdf(&s, 0, 0, 0), -1.5);
	NEAR(sdf(&s, 3, 0, 0), 1.5);
	NEAR(sdf(&s, 0, -2, 0), 0.5);
	NEAR(sdf(&s, 1.5 / R3, 1.5 / R3, -1.5 / R3), 0.0);
}

static void box_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_BOX, (float[]){1, 2, 3}, 3) == 0);
	NEAR(sdf(&s, 0, 0, 0), -1.0);
	NEAR(sdf(&s, 2, 0, 0), 1.0);
	NEAR(sdf(&s, 2, 3, 4), R3);
	NEAR(sdf(&s, -1, 2, -3), 0.0);
	NEAR(sdf(&s, 0.5, 0, 0), -0.5);
	NEAR(sdf(&s, 0, 1.5, 2.9), -0.1);
	NEAR(sdf(&s, 0, 2.5, 3.5), sqrt(0.5));
	/* Rounding keeps the outer size and rounds edges and corners. */
	REQUIRE(shape_make(&s, BC_PRIM_BOX, (float[]){1, 2, 3, 0.5f}, 4) == 0);
	NEAR(sdf(&s, 1, 0, 0), 0.0);
	NEAR(sdf(&s, 0, 0, -3), 0.0);
	NEAR(sdf(&s, 0, 0, 0), -1.0);
	NEAR(sdf(&s, 3, 0, 0), 2.0);
	NEAR(sdf(&s, 1, 2, 3), sqrt(0.75) - 0.5);
	NEAR(sdf(&s, 0.5 + 0.5 / R3, 1.5 + 0.5 / R3, 2.5 + 0.5 / R3), 0.0);
}

static void capsule_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_CAPSULE,
	                   (float[]){0, -1, 0, 0, 1, 0, 0.5f}, 7) == 0);
	NEAR(sdf(&s, 0, 0, 0), -0.5);
	NEAR(sdf(&s, 2, 0, 0), 1.5);
	NEAR(sdf(&s, 0, 3, 0), 1.5);
	NEAR(sdf(&s, 0, -1.5, 0), 0.0);
	NEAR(sdf(&s, 1, 2, 0), sqrt(2.0) - 0.5);
	NEAR(sdf(&s, 0, 0.7, 0.3), -0.2);
	/* a == b is allowed: a sphere. */
	REQUIRE(shape_make(&s, BC_PRIM_CAPSULE,
	                   (float[]){1, 1, 1, 1, 1, 1, 0.5f}, 7) == 0);
	NEAR(sdf(&s, 1, 1, 1), -0.5);
	NEAR(sdf(&s, 1, 3, 1), 1.5);
	NEAR(sdf(&s, 1, 1, 0), 0.5);
}

static void cylinder_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_CYLINDER, (float[]){1, 2}, 2) == 0);
	NEAR(sdf(&s, 0, 0, 0), -1.0);
	NEAR(sdf(&s, 3, 0, 0), 2.0);
	NEAR(sdf(&s, 0, 5, 0), 3.0);
	NEAR(sdf(&s, 0, -5, 0), 3.0);
	NEAR(sdf(&s, 2, 3, 0), sqrt(2.0));
	NEAR(sdf(&s, 0.5, 0, 0), -0.5);
	NEAR(sdf(&s, 0, 1.8, 0), -0.2);
	NEAR(sdf(&s, 0.6, 0, 0.8), 0.0);
	NEAR(sdf(&s, 0.6, 2, 0.8), 0.0);
}

static void torus_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_TORUS, (float[]){2, 0.5f}, 2) == 0);
	NEAR(sdf(&s, 2, 0, 0), -0.5);
	NEAR(sdf(&s, 0, 0, -2), -0.5);
	NEAR(sdf(&s, 0, 0, 0), 1.5);
	NEAR(sdf(&s, 0, 0, 3), 0.5);
	NEAR(sdf(&s, 2, 1, 0), 0.5);
	NEAR(sdf(&s, 0, 1, 0), sqrt(5.0) - 0.5);
	NEAR(sdf(&s, 0, 0, 2.5), 0.0);
	NEAR(sdf(&s, sqrt(2.0), 0.5, sqrt(2.0)), 0.0);
}

static void cone_values(void)
{
	struct shape s;
	double n = 1.0 / sqrt(5.0); /* side normal (2, 1) / sqrt 5 */
	REQUIRE(shape_make(&s, BC_PRIM_CONE, (float[]){1, 1, 0}, 3) == 0);
	NEAR(sdf(&s, 0, 1, 0), 0.0); /* apex */
	NEAR(sdf(&s, 0, 2, 0), 1.0);
	NEAR(sdf(&s, 0, -2, 0), 1.0);
	NEAR(sdf(&s, 2, -1, 0), 1.0);
	NEAR(sdf(&s, 0, 0, 0), -n);
	NEAR(sdf(&s, 0.5, 0, 0), 0.0);
	NEAR(sdf(&s, 0.5 + 0.6 * n, 0.3 * n, 0), 0.3);
	NEAR(sdf(&s, 0, -0.9, 0), -0.1);
	NEAR(sdf(&s, 0.5, 1.5, 0), sqrt(0.5));
	NEAR(sdf(&s, 0, -1, 0.7), 0.0);
	/* Truncated, wider at the top. */
	REQUIRE(shape_make(&s, BC_PRIM_CONE, (float[]){1, 0.5f, 1}, 3) == 0);
	NEAR(sdf(&s, 0, 2, 0), 1.0);
	NEAR(sdf(&s, 0.5, -1, 0), 0.0);
	NEAR(sdf(&s, 1, 1, 0), 0.0);
	NEAR(sdf(&s, 0.75, 0, 0), 0.0);
	NEAR(sdf(&s, 2, 1, 0), 1.0);
}

static void round_cone_values(void)
{
	struct shape s;
	double sa = 0.25, ca = sqrt(15.0) / 4.0;
	REQUIRE(shape_make(&s, BC_PRIM_ROUND_CONE,
	                   (float[]){0, 0, 0, 0, 2, 0, 1, 0.5f}, 8) == 0);
	NEAR(sdf(&s, 0, 0, 0), -1.0);
	NEAR(sdf(&s, 0, -2, 0), 1.0);
	NEAR(sdf(&s, 0, 3, 0), 0.5);
	NEAR(sdf(&s, 0, 2.5, 0), 0.0);
	NEAR(sdf(&s, 0, 1, 0), sa - 1.0);
	NEAR(sdf(&s, ca, sa, 0), 0.0);
	NEAR(sdf(&s, 1.5 * ca, 1.5 * sa, 0), 0.5);
	NEAR(sdf(&s, 0, 2 + 0.5 * sa, -0.5 * ca), 0.0);
	/* One sphere inside the other: the larger sphere. */
	REQUIRE(shape_make(&s, BC_PRIM_ROUND_CONE,
	                   (float[]){0, 0, 0, 0, 0.5f, 0, 1, 0.25f}, 8) == 0);
	NEAR(sdf(&s, 0, 0, 2), 1.0);
	NEAR(sdf(&s, 0, 2, 0), 1.0);
	NEAR(sdf(&s, 0, 0, 0), -1.0);
	REQUIRE(shape_make(&s, BC_PRIM_ROUND_CONE,
	                   (float[]){0, 0, 0, 0, 0.5f, 0, 0.25f, 1}, 8) == 0);
	NEAR(sdf(&s, 0, 0.5, 2), 1.0);
	NEAR(sdf(&s, 0, -2, 0), 1.5);
	/* A sharp end: radius_a 0. */
	REQUIRE(shape_make(&s, BC_PRIM_ROUND_CONE,
	                   (float[]){0, 0, 0, 0, 2, 0, 0, 1}, 8) == 0);
	NEAR(sdf(&s, 0, 0, 0), 0.0);
	NEAR(sdf(&s, 0, -1, 0), 1.0);
	NEAR(sdf(&s, 0, 3, 0), 0.0);
}

static void ellipsoid_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_ELLIPSOID, (float[]){3, 2, 1}, 3) == 0);
	NEAR(sdf(&s, 3, 0, 0), 0.0);
	NEAR(sdf(&s, 0, -2, 0), 0.0);
	NEAR(sdf(&s, 0, 0, 1), 0.0);
	NEAR(sdf(&s, 4, 0, 0), 1.0);
	NEAR(sdf(&s, 0, 3, 0), 1.0);
	NEAR(sdf(&s, 0, 0, -2), 1.0);
	NEAR(sdf(&s, 0, 0, 0), -1.0);
	CHECK(sdf(&s, 2.9, 0, 0) < 0.0f);
	CHECK(sdf(&s, 3.0 * 0.6, 2.0 * 0.8 * 1.001, 0) > 0.0f);
	CHECK(sdf(&s, 3.0 * 0.6, 2.0 * 0.8 * 0.999, 0) < 0.0f);
}

static void hex_prism_values(void)
{
	struct shape s;
	double c30 = R3 / 2.0;
	REQUIRE(shape_make(&s, BC_PRIM_HEX_PRISM, (float[]){1, 0.5f}, 2) == 0);
	NEAR(sdf(&s, 0, 0, 0), -0.5);
	NEAR(sdf(&s, 0, 2, 0), 1.0);
	NEAR(sdf(&s, 0, -1, 0), 0.0);
	NEAR(sdf(&s, 2.0 / R3 + 1.0, 0, 0), 1.0);
	NEAR(sdf(&s, 2.0 / R3, 0, 0), 0.0);
	NEAR(sdf(&s, 0, 0, 1.5), 1.0);
	NEAR(sdf(&s, c30, 0.5, 0), 0.0);
	NEAR(sdf(&s, -2 * c30, 1.0, 0), 1.0);
	NEAR(sdf(&s, 0, 0.9, 0), -0.1);
	NEAR(sdf(&s, 0, 0, -0.4), -0.1);
	NEAR(sdf(&s, 1.0 / R3, 1.0, 0.5), 0.0);
}

static void octahedron_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_OCTAHEDRON, (float[]){1}, 1) == 0);
	NEAR(sdf(&s, 1, 0, 0), 0.0);
	NEAR(sdf(&s, 0, -2, 0), 1.0);
	NEAR(sdf(&s, 1, 1, 1), 2.0 / R3);
	NEAR(sdf(&s, 0, 0, 0), -1.0 / R3);
	NEAR(sdf(&s, 1, -1, 0), sqrt(0.5));
	NEAR(sdf(&s, 1.0 / 3, 1.0 / 3, -1.0 / 3), 0.0);
	NEAR(sdf(&s, 0.5, 0, 0.5), 0.0);
	NEAR(sdf(&s, 0, 0, 3), 2.0);
}

static void box_frame_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_BOX_FRAME, (float[]){1, 1, 1, 0.2f},
	                   4) == 0);
	NEAR(sdf(&s, 0, 0, 0), sqrt(1.28));
	NEAR(sdf(&s, 1, 1, 1), 0.0);
	NEAR(sdf(&s, 0, 1, -1), 0.0);
	NEAR(sdf(&s, 0, 0.9, 0.9), -0.1);
	NEAR(sdf(&s, 0, 2, 2), sqrt(2.0));
	NEAR(sdf(&s, 1, 0, 0), 0.8);
	NEAR(sdf(&s, 1.5, 0, 0), sqrt(0.25 + 0.64));
	NEAR(sdf(&s, 0, 0.7, 1), 0.1);
	NEAR(sdf(&s, 0.9, 0.9, 0), -0.1);
	/* A frame as thick as the box is wide fills its faces' rims. */
	REQUIRE(shape_make(&s, BC_PRIM_BOX_FRAME, (float[]){1, 2, 3, 1}, 4) ==
	        0);
	NEAR(sdf(&s, 0, 2.5, 3), 0.5);
	NEAR(sdf(&s, 0, 0, 0), 1.0); /* the z bars reach x = 0 */
}

static void capped_torus_values(void)
{
	struct shape s;
	double h = sqrt(0.5);
	REQUIRE(shape_make(&s, BC_PRIM_CAPPED_TORUS, (float[]){1, 0.2f, 90},
	                   3) == 0);
	NEAR(sdf(&s, 0, 0, 1), -0.2);
	NEAR(sdf(&s, 0, 0, -1), sqrt(2.0) - 0.2);
	NEAR(sdf(&s, 0, 0, 0), 0.8);
	NEAR(sdf(&s, 1, 0, 0), -0.2);
	NEAR(sdf(&s, -1.2, 0, 0), 0.0);
	NEAR(sdf(&s, 0, 0, 1.2), 0.0);
	NEAR(sdf(&s, 0, 0.2, 1), 0.0);
	NEAR(sdf(&s, h, 0, h), -0.2);
	REQUIRE(shape_make(&s, BC_PRIM_CAPPED_TORUS, (float[]){1, 0.2f, 45},
	                   3) == 0);
	NEAR(sdf(&s, 1, 0, 0), sqrt((1 - h) * (1 - h) + 0.5) - 0.2);
	NEAR(sdf(&s, 0, 0, -1), sqrt(0.5 + (1 + h) * (1 + h)) - 0.2);
	NEAR(sdf(&s, -h, 0, h), -0.2);
	NEAR(sdf(&s, 0, 0, 1), -0.2);
}

static void link_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_LINK, (float[]){1, 1, 0.25f}, 3) == 0);
	NEAR(sdf(&s, 1, 0, 0), -0.25);
	NEAR(sdf(&s, -1, 0.5, 0), -0.25);
	NEAR(sdf(&s, 0, 2, 0), -0.25);
	NEAR(sdf(&s, 0, -2.25, 0), 0.0);
	NEAR(sdf(&s, 0, 0, 0), 0.75);
	NEAR(sdf(&s, 0, 0.5, 0), 0.75);
	NEAR(sdf(&s, 0, 0, 1), sqrt(2.0) - 0.25);
	NEAR(sdf(&s, 2, 1.5, 0), sqrt(4.25) - 1.25);
	NEAR(sdf(&s, 1, 0, 0.25), 0.0);
}

static void solid_angle_values(void)
{
	struct shape s;
	double c30 = R3 / 2.0;
	REQUIRE(shape_make(&s, BC_PRIM_SOLID_ANGLE, (float[]){1, 30}, 2) == 0);
	NEAR(sdf(&s, 0, 0.5, 0), -0.25);
	NEAR(sdf(&s, 0, 2, 0), 1.0);
	NEAR(sdf(&s, 0, -1, 0), 1.0);
	NEAR(sdf(&s, 0, 1, 0), 0.0);
	NEAR(sdf(&s, 0, 0, 0), 0.0);
	NEAR(sdf(&s, 0.25, 0.5 * c30, 0), 0.0);
	NEAR(sdf(&s, 0.25 + 0.2 * c30, 0.5 * c30 - 0.1, 0), 0.2);
	NEAR(sdf(&s, 0, 0.95, 0), -0.05);
	REQUIRE(shape_make(&s, BC_PRIM_SOLID_ANGLE, (float[]){1, 90}, 2) == 0);
	NEAR(sdf(&s, 2, -1, 0), sqrt(2.0));
	NEAR(sdf(&s, 0, -1, 0), 1.0);
	NEAR(sdf(&s, 0, 0.5, 0), -0.5);
	NEAR(sdf(&s, 0, 0.1, 0.3), -0.1);
	REQUIRE(shape_make(&s, BC_PRIM_SOLID_ANGLE, (float[]){1, 150}, 2) == 0);
	NEAR(sdf(&s, 0, -0.5, 0), 0.25);
	NEAR(sdf(&s, 0, 0.5, 0), -0.5);
	NEAR(sdf(&s, 0, 0, 1), 0.0);
	NEAR(sdf(&s, 0, -2, 0), sqrt(0.25 + (2 - c30) * (2 - c30)));
}

static void pyramid_values(void)
{
	struct shape s;
	double n = 1.0 / sqrt(5.0);
	REQUIRE(shape_make(&s, BC_PRIM_PYRAMID, (float[]){1, 2}, 2) == 0);
	NEAR(sdf(&s, 0, 2, 0), 0.0);
	NEAR(sdf(&s, 0, 3, 0), 1.0);
	NEAR(sdf(&s, 0, -1, 0), 1.0);
	NEAR(sdf(&s, 0, 1, 0), -n);
	NEAR(sdf(&s, 2, -1, 2), R3);
	NEAR(sdf(&s, 0.5, 1, 0), 0.0);
	NEAR(sdf(&s, 0.3, 1, -0.5), 0.0);
	NEAR(sdf(&s, -0.5 - 0.6 * n, 1 + 0.3 * n, 0.1), 0.3);
	NEAR(sdf(&s, 0, 0.1, 0), -0.1);
	NEAR(sdf(&s, 1, 0, 1), 0.0);
	NEAR(sdf(&s, 0, -0.5, 0.5), 0.5);
}

static void tri_prism_values(void)
{
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_TRI_PRISM, (float[]){0.5f, 1}, 2) == 0);
	NEAR(sdf(&s, 0, 0, 0), -0.5);
	NEAR(sdf(&s, 0, -1, 0), 0.5);
	NEAR(sdf(&s, 0, 2, 0), 1.0);
	NEAR(sdf(&s, 0, 1, 0), 0.0);
	NEAR(sdf(&s, 0, 0, 2), 1.0);
	NEAR(sdf(&s, 0, 0, -0.8), -0.2);
	NEAR(sdf(&s, R3 / 2 + 1, -0.5, 0), 1.0);
	NEAR(sdf(&s, R3 / 2, -0.5, 1), 0.0);
	NEAR(sdf(&s, R3 / 4, 0.25, 0), 0.0);
	NEAR(sdf(&s, -R3 / 4 - R3 / 2 * 0.3, 0.25 + 0.15, 0), 0.3);
}

/* ---- Alternative formulas ----------------------------------------------- */

/* Independent oracles, in double: convex polygons and polyhedra given by
 * their vertices, distances as the minimum over edges or triangles. */
static double seg_dist2d(double px, double py, double ax, double ay, double bx,
                         double by)
{
	double ex = bx - ax, ey = by - ay, wx = px - ax, wy = py - ay;
	double t = (wx * ex + wy * ey) / (ex * ex + ey * ey);
	t = t < 0 ? 0 : (t > 1 ? 1 : t);
	return hypot(wx - ex * t, wy - ey * t);
}

/* Signed distance to a convex polygon with counter-clockwise vertices. */
static double poly_sdf(const double (*v)[2], int n, double x, double y)
{
	double d = INFINITY;
	bool inside = true;
	for (int i = 0; i < n; i++) {
		const double *a = v[i], *b = v[(i + 1) % n];
		double e = seg_dist2d(x, y, a[0], a[1], b[0], b[1]);
		d = e < d ? e : d;
		/* Right of the edge (outward for counter-clockwise order). */
		if ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) <
		    0) {
			inside = false;
		}
	}
	return inside ? -d : d;
}

static double extrude_d(double d2, double dz)
{
	double ox = d2 > 0 ? d2 : 0, oz = dz > 0 ? dz : 0;
	double in = d2 > dz ? d2 : dz;
	return hypot(ox, oz) + (in < 0 ? in : 0);
}

static double seg_dist3(const double p[3], const double a[3], const double b[3])
{
	double e[3], w[3], ee = 0, we = 0;
	for (int i = 0; i < 3; i++) {
		e[i] = b[i] - a[i];
		w[i] = p[i] - a[i];
		ee += e[i] * e[i];
		we += w[i] * e[i];
	}
	double t = we / ee;
	t = t < 0 ? 0 : (t > 1 ? 1 : t);
	for (int i = 0; i < 3; i++) {
		w[i] -= t * e[i];
	}
	return sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
}

/* Unsigned distance to a triangle; *side gets the signed plane distance
 * along the normal (b - a) x (c - a). */
static double tri_dist(const double p[3], const double a[3], const double b[3],
                       const double c[3], double *side)
{
	double e1[3], e2[3], w[3], n[3];
	for (int i = 0; i < 3; i++) {
		e1[i] = b[i] - a[i];
		e2[i] = c[i] - a[i];
		w[i] = p[i] - a[i];
	}
	n[0] = e1[1] * e2[2] - e1[2] * e2[1];
	n[1] = e1[2] * e2[0] - e1[0] * e2[2];
	n[2] = e1[0] * e2[1] - e1[1] * e2[0];
	double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
	double h = (w[0] * n[0] + w[1] * n[1] + w[2] * n[2]) / nl;
	*side = h;
	/* Barycentric coordinates of the projection. */
	double d11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
	double d22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
	double d12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2];
	double w1 = w[0] * e1[0] + w[1] * e1[1] + w[2] * e1[2];
	double w2 = w[0] * e2[0] + w[1] * e2[1] + w[2] * e2[2];
	double den = d11 * d22 - d12 * d12;
	double u = (d22 * w1 - d12 * w2) / den, v = (d11 * w2 - d12 * w1) / den;
	if (u >= 0 && v >= 0 && u + v <= 1) {
		return fabs(h);
	}
	double d = seg_dist3(p, a, b);
	double d2 = seg_dist3(p, b, c), d3 = seg_dist3(p, c, a);
	d = d2 < d ? d2 : d;
	return d3 < d ? d3 : d;
}

/* Signed distance to a convex polyhedron given as triangles, with a point
 * known to be inside to tell the sides apart. */
static double polyhedron_sdf(const double (*tri)[3][3], int n,
                             const double in[3], const double p[3])
{
	double d = INFINITY;
	bool inside = true;
	for (int i = 0; i < n; i++) {
		double side, ref;
		double e = tri_dist(p, tri[i][0], tri[i][1], tri[i][2], &side);
		(void)tri_dist(in, tri[i][0], tri[i][1], tri[i][2], &ref);
		d = e < d ? e : d;
		if (side * ref < 0) {
			inside = false;
		}
	}
	return inside ? -d : d;
}

static void fields_match_independent_formulas(void)
{
	struct shape a;
	rng_seed(11);
	for (int trial = 0; trial < 40; trial++) {
		float r = rnd(0.2f, 1.0f), h = rnd(0.2f, 1.0f);
		float big = rnd(0.5f, 1.0f), small = big * rnd(0.1f, 0.9f);
		float p0[3] = {rnd(-1, 1), rnd(-1, 1), rnd(-1, 1)};
		float p1[3] = {rnd(-1, 1), rnd(-1, 1), rnd(-1, 1)};
		float r2 = rnd(0.0f, 1.0f);
		struct shape cone, cone_flip, cyl, rc, cap, ct, tor, lnk, ell,
		    sph, cap0, hex, tri, pyr, oct, frame;
		REQUIRE(shape_make(&cone, BC_PRIM_CONE, (float[]){h, r, r},
		                   3) == 0);
		REQUIRE(shape_make(&cyl, BC_PRIM_CYLINDER, (float[]){r, h},
		                   2) == 0);
		REQUIRE(shape_make(&a, BC_PRIM_CONE, (float[]){h, r, r2}, 3) ==
		        0);
		REQUIRE(shape_make(&cone_flip, BC_PRIM_CONE,
		                   (float[]){h, r2, r}, 3) == 0);
		REQUIRE(shape_make(&rc, BC_PRIM_ROUND_CONE,
		                   (float[]){p0[0], p0[1], p0[2], p1[0], p1[1],
		                             p1[2], r, r},
		                   8) == 0);
		REQUIRE(shape_make(&cap, BC_PRIM_CAPSULE,
		                   (float[]){p0[0], p0[1], p0[2], p1[0], p1[1],
		                             p1[2], r},
		                   7) == 0);
		REQUIRE(shape_make(&cap0, BC_PRIM_CAPSULE,
		                   (float[]){p0[0], p0[1], p0[2], p0[0], p0[1],
		                             p0[2], r},
		                   7) == 0);
		REQUIRE(shape_make(&ct, BC_PRIM_CAPPED_TORUS,
		                   (float[]){big, small, 180}, 3) == 0);
		REQUIRE(shape_make(&tor, BC_PRIM_TORUS, (float[]){big, small},
		                   2) == 0);
		REQUIRE(shape_make(&lnk, BC_PRIM_LINK, (float[]){0, big, small},
		                   3) == 0);
		REQUIRE(shape_make(&ell, BC_PRIM_ELLIPSOID, (float[]){r, r, r},
		                   3) == 0);
		REQUIRE(shape_make(&sph, BC_PRIM_SPHERE, (float[]){r}, 1) == 0);
		REQUIRE(shape_make(&hex, BC_PRIM_HEX_PRISM, (float[]){r, h},
		                   2) == 0);
		REQUIRE(shape_make(&tri, BC_PRIM_TRI_PRISM, (float[]){r, h},
		                   2) == 0);
		REQUIRE(shape_make(&pyr, BC_PRIM_PYRAMID, (float[]){r, h}, 2) ==
		        0);
		REQUIRE(shape_make(&oct, BC_PRIM_OCTAHEDRON, (float[]){r}, 1) ==
		        0);
		float fb[3] = {rnd(0.3f, 1), rnd(0.3f, 1), rnd(0.3f, 1)};
		float th = rnd(0.02f, 0.3f);
		REQUIRE(shape_make(&frame, BC_PRIM_BOX_FRAME,
		                   (float[]){fb[0], fb[1], fb[2], th}, 4) == 0);

		/* Polygons and polyhedra for the oracles. */
		double hx[6][2], tr[3][2];
		for (int i = 0; i < 6; i++) {
			double ang = (double)i * PI / 3.0;
			double cr = 2.0 * r / R3; /* circumradius */
			hx[i][0] = cr * cos(ang);
			hx[i][1] = cr * sin(ang);
		}
		tr[0][0] = 0, tr[0][1] = 2.0 * r;
		tr[1][0] = -R3 * r, tr[1][1] = -r;
		tr[2][0] = R3 * r, tr[2][1] = -r;
		double apex[3] = {0, h, 0};
		double bc[4][3] = {
		    {r, 0, r}, {-r, 0, r}, {-r, 0, -r}, {r, 0, -r}};
		double pt[6][3][3];
		for (int i = 0; i < 4; i++) {
			/* Outward: base edge i -> i+1 seen from outside. */
			memcpy(pt[i][0], bc[i], sizeof(bc[i]));
			memcpy(pt[i][1], bc[(i + 1) % 4], sizeof(bc[i]));
			memcpy(pt[i][2], apex, sizeof(apex));
		}
		memcpy(pt[4][0], bc[0], sizeof(bc[0]));
		memcpy(pt[4][1], bc[2], sizeof(bc[0]));
		memcpy(pt[4][2], bc[1], sizeof(bc[0]));
		memcpy(pt[5][0], bc[0], sizeof(bc[0]));
		memcpy(pt[5][1], bc[3], sizeof(bc[0]));
		memcpy(pt[5][2], bc[2], sizeof(bc[0]));
		double pin[3] = {0, 0.25 * h, 0}, origin[3] = {0, 0, 0};
		double ot[8][3][3];
		for (int i = 0; i < 8; i++) {
			double sx = i & 1 ? -1 : 1, sy = i & 2 ? -1 : 1,
			       sz = i & 4 ? -1 : 1;
			double vx[3] = {sx * r, 0, 0}, vy[3] = {0, sy * r, 0},
			       vz[3] = {0, 0, sz * r};
			memcpy(ot[i][0], vx, sizeof(vx));
			memcpy(ot[i][1], vy, sizeof(vx));
			memcpy(ot[i][2], vz, sizeof(vx));
		}

		for (int i = 0; i < 200; i++) {
			double p[3] = {rnd(-2, 2), rnd(-2, 2), rnd(-2, 2)};
			double x = p[0], y = p[1], z = p[2];
			NEAR(sdfv(&cone, p), sdfv(&cyl, p));
			NEAR(sdfv(&a, p), sdf(&cone_flip, x, -y, z));
			NEAR(sdfv(&rc, p), sdfv(&cap, p));
			NEAR(sdfv(&ct, p), sdfv(&tor, p));
			NEAR(sdfv(&lnk, p), sdf(&tor, x, z, y));
			NEAR(sdfv(&ell, p), sdfv(&sph, p));
			NEAR(sdfv(&cap0, p),
			     sdf(&sph, x - p0[0], y - p0[1], z - p0[2]));
			NEAR(sdfv(&hex, p),
			     extrude_d(poly_sdf(hx, 6, x, y), fabs(z) - h));
			NEAR(sdfv(&tri, p),
			     extrude_d(poly_sdf(tr, 3, x, y), fabs(z) - h));
			NEAR(sdfv(&pyr, p), polyhedron_sdf(pt, 6, pin, p));
			NEAR(sdfv(&oct, p), polyhedron_sdf(ot, 8, origin, p));
			/* Box frame: the twelve bars as separate boxes;
			 * the union's distance outside is their minimum. */
			double fm = INFINITY;
			for (int ax = 0; ax < 3; ax++) {
				for (int sg = 0; sg < 4; sg++) {
					double c[3], hh[3], q[3], o = 0,
					                          in = -1e9;
					for (int k = 0; k < 3; k++) {
						hh[k] = 0.5 * th;
						c[k] = fb[k] - 0.5 * th;
					}
					hh[ax] = fb[ax];
					c[ax] = 0;
					c[(ax + 1) % 3] *= sg & 1 ? -1 : 1;
					c[(ax + 2) % 3] *= sg & 2 ? -1 : 1;
					for (int k = 0; k < 3; k++) {
						q[k] =
						    fabs(p[k] - c[k]) - hh[k];
						o += q[k] > 0 ? q[k] * q[k] : 0;
						in = q[k] > in ? q[k] : in;
					}
					double bd = sqrt(o) + (in < 0 ? in : 0);
					fm = bd < fm ? bd : fm;
				}
			}
			NEAR(sdfv(&frame, p), fm);
		}
	}
}

/* ---- Brute force: the fields against their own surfaces ----------------- */

#define NSURF 3000
#define NQUERY 80

/*
 * Points of the zero set: half by bisection between an inside and an
 * outside point (independent of the field being a distance), half by
 * Newton projection along the numerical gradient (dense where the surface
 * is nearest to the space around it: edges, corners).
 */
static int surface_samples(const struct shape *s, double (*out)[3], int n)
{
	int m = 0, guard = 0;
	while (m < n && guard++ < 50 * n) {
		double a[3], b[3], g[3];
		if (m % 2 == 0) {
			random_near(s, 0.0, a);
			random_near(s, 0.4, b);
			if (!(sdfv(s, a) < 0.0f) || !(sdfv(s, b) > 0.0f)) {
				continue;
			}
			for (int it = 0; it < 60; it++) {
				double c[3] = {0.5 * (a[0] + b[0]),
				               0.5 * (a[1] + b[1]),
				               0.5 * (a[2] + b[2])};
				if (sdfv(s, c) < 0.0f) {
					memcpy(a, c, sizeof(c));
				} else {
					memcpy(b, c, sizeof(c));
				}
			}
			memcpy(out[m++], b, sizeof(b));
		} else {
			random_near(s, 0.4, a);
			for (int it = 0; it < 8; it++) {
				double f = sdfv(s, a), gg;
				grad(s, a, 1e-3, g);
				gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
				gg = gg > 0.25 ? gg : 0.25;
				for (int i = 0; i < 3; i++) {
					a[i] -= f * g[i] / gg;
				}
			}
			if (fabs(sdfv(s, a)) < 1e-5) {
				memcpy(out[m++], a, sizeof(a));
			}
		}
	}
	return m;
}

static double nearest(const double (*pts)[3], int n, const double q[3])
{
	double best = INFINITY;
	for (int i = 0; i < n; i++) {
		double x = pts[i][0] - q[0], y = pts[i][1] - q[1],
		       z = pts[i][2] - q[2];
		double d2 = x * x + y * y + z * z;
		best = d2 < best ? d2 : best;
	}
	return sqrt(best);
}

/* Keeps p as the best sample when it is nearer to q. */
static void keep(double *best, double s0[3], const double p[3],
                 const double q[3])
{
	double d = dist3(p, q);
	if (d < *best) {
		*best = d;
		memcpy(s0, p, 3 * sizeof(double));
	}
}

/* Adds surface samples packed within rad of s0: bisections, and
 * projections, which land exactly on edges and corners that bisection only
 * grazes. */
static void refine(const struct shape *s, const double q[3], double rad,
                   double *best, double s0[3])
{
	double c0[3];
	memcpy(c0, s0, sizeof(c0));
	for (int i = 0, tries = 0; i < 40 && tries < 1500; tries++) {
		double a[3], b[3];
		for (int j = 0; j < 3; j++) {
			a[j] = c0[j] + rnd(-1, 1) * rad;
			b[j] = c0[j] + rnd(-1, 1) * rad;
		}
		if (!(sdfv(s, a) < 0.0f) || !(sdfv(s, b) > 0.0f)) {
			continue;
		}
		for (int it = 0; it < 30; it++) {
			double c[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]),
			               0.5 * (a[2] + b[2])};
			if (sdfv(s, c) < 0.0f) {
				memcpy(a, c, sizeof(c));
			} else {
				memcpy(b, c, sizeof(c));
			}
		}
		keep(best, s0, b, q);
		i++;
	}
	for (int i = 0; i < 20; i++) {
		double a[3], g[3];
		for (int j = 0; j < 3; j++) {
			a[j] = c0[j] + rnd(-1, 1) * 2.0 * rad;
		}
		for (int it = 0; it < 6; it++) {
			double f = sdfv(s, a), gg;
			grad(s, a, 1e-4, g);
			gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
			/* On an edge the difference quotient mixes the faces'
			 * normals and shrinks; f is tiny there anyway. */
			gg = gg > 0.25 ? gg : 0.25;
			for (int j = 0; j < 3; j++) {
				a[j] -= f * g[j] / gg;
			}
		}
		if (fabs(sdfv(s, a)) < 1e-5) {
			keep(best, s0, a, q);
		}
	}
}

/*
 * The brute-force distance from q: the nearest of the global samples, then
 * refined with samples packed around the best one so far at shrinking
 * radii, so that the sampling gap no longer dominates the comparison.
 */
static double brute_distance(const struct shape *s, const double (*pts)[3],
                             int n, const double q[3])
{
	/* Seeds: the nearest samples that lie apart, since q may be almost
	 * as near to another part of the surface as to the nearest sample. */
	double seed[3][3], sd[3] = {INFINITY, INFINITY, INFINITY};
	for (int i = 0; i < n; i++) {
		double d = dist3(pts[i], q);
		int j = 0;
		while (j < 3 && !(d < sd[j] &&
		                  (j == 0 || dist3(pts[i], seed[0]) > 0.1))) {
			j++;
		}
		if (j < 3) {
			for (int m = 2; m > j; m--) {
				sd[m] = sd[m - 1];
				memcpy(seed[m], seed[m - 1], sizeof(seed[m]));
			}
			sd[j] = d;
			memcpy(seed[j], pts[i], sizeof(seed[j]));
		}
	}
	double best = INFINITY;
	for (int j = 0; j < 3 && sd[j] < INFINITY; j++) {
		double b = sd[j];
		refine(s, q, 0.08, &b, seed[j]);
		refine(s, q, 0.02, &b, seed[j]);
		refine(s, q, 0.005, &b, seed[j]);
		best = fmin(best, b);
	}
	return best;
}

static void fields_agree_with_brute_force_distance(void)
{
	static double pts[NSURF][3];
	double worst_over = 0, worst_under = 0;
	int worst_kind = 0;
	rng_seed(21);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		for (int trial = 0; trial < 1; trial++) {
			struct shape s;
			shape_random(&s, (enum bc_prim)k);
			int n = surface_samples(&s, pts, NSURF);
			REQUIRE(n == NSURF);
			for (int i = 0; i < NQUERY; i++) {
				double q[3];
				random_near(&s, 0.5, q);
				double f = sdfv(&s, q);
				if (fabs(f) < 0.05) {
					continue;
				}
				double bf = brute_distance(&s, pts, n, q);
				/* Never beyond the surface: a bound. */
				if (fabs(f) > bf + 1e-5 * (1.0 + bf)) {
					fprintf(stderr,
					        "  %s: |f| %g > brute %g at "
					        "(%g %g %g)\n",
					        bc_prim_info(s.d.kind)->name, f,
					        bf, q[0], q[1], q[2]);
					bc_test_failures++;
				}
				worst_over = fmax(worst_over, fabs(f) - bf);
				bool exact = bc_prim_info(s.d.kind)->exact &&
				             (f > 0 || exact_inside(s.d.kind));
				/* Exact: a surface point as near as the
				 * field says, up to the local sampling gap. */
				if (exact && bf > fabs(f) + 5e-4) {
					fprintf(stderr,
					        "  %s: brute %g > |f| %g at "
					        "(%g %g %g)\n",
					        bc_prim_info(s.d.kind)->name,
					        bf, f, q[0], q[1], q[2]);
					bc_test_failures++;
				}
				if (exact && bf - fabs(f) > worst_under) {
					worst_under = bf - fabs(f);
					worst_kind = k;
				}
			}
		}
	}
	printf("  worst |f| - brute %.2g, brute - |f| %.2g (%s)\n", worst_over,
	       worst_under,
	       worst_kind ? bc_prim_info((enum bc_prim)worst_kind)->name : "-");
}

/*
 * For an exact distance, one step against the gradient by the field's value
 * lands on the surface; an underestimate lands short. Points within the
 * finite-difference step of a gradient kink (the medial axis) show a
 * gradient shorter than 1 and are counted apart.
 */
static void exact_fields_project_onto_their_surface(void)
{
	rng_seed(22);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		if (!bc_prim_info((enum bc_prim)k)->exact) {
			continue;
		}
		int tried = 0, kinks = 0;
		for (int trial = 0; trial < 20; trial++) {
			struct shape s;
			shape_random(&s, (enum bc_prim)k);
			for (int i = 0; i < 200; i++) {
				double q[3], g[3], gl;
				random_near(&s, 0.6, q);
				double f = sdfv(&s, q);
				if (fabs(f) < 0.01 ||
				    (f < 0 && !exact_inside(s.d.kind))) {
					continue;
				}
				tried++;
				grad(&s, q, 1e-3, g);
				gl = sqrt(g[0] * g[0] + g[1] * g[1] +
				          g[2] * g[2]);
				if (fabs(gl - 1.0) > 2e-4) {
					kinks++;
					continue;
				}
				{
					/* Within the step of a crease the two
					 * steps see different gradients. */
					double g2[3];
					grad(&s, q, 3e-4, g2);
					if (fabs(g2[0] - g[0]) +
					        fabs(g2[1] - g[1]) +
					        fabs(g2[2] - g[2]) >
					    5e-3) {
						kinks++;
						continue;
					}
				}
				double p[3];
				for (int j = 0; j < 3; j++) {
					p[j] = q[j] - f * g[j] / gl;
				}
				if (fabs(sdfv(&s, p)) > 1e-4 + 2e-3 * fabs(f)) {
					fprintf(stderr,
					        "  %s: f(%g %g %g) = %g, "
					        "projected f = %g\n",
					        bc_prim_info(s.d.kind)->name,
					        q[0], q[1], q[2], f,
					        sdfv(&s, p));
					bc_test_failures++;
				}
			}
		}
		/* Exact fields have |grad| = 1 almost everywhere. */
		if (kinks * 20 > tried) {
			fprintf(
			    stderr, "  %s: %d of %d points off |grad| = 1\n",
			    bc_prim_info((enum bc_prim)k)->name, kinks, tried);
			bc_test_failures++;
		}
	}
}

static void fields_are_1_lipschitz(void)
{
	rng_seed(23);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		double worst = 0;
		bool exact = bc_prim_info((enum bc_prim)k)->exact;
		for (int trial = 0; trial < 20; trial++) {
			struct shape s;
			shape_random(&s, (enum bc_prim)k);
			for (int i = 0; i < 1000; i++) {
				double p[3], q[3];
				random_near(&s, 0.8, p);
				double len = rnd(0.02f, 0.5f);
				double dir[3] = {rnd(-1, 1), rnd(-1, 1),
				                 rnd(-1, 1)};
				double dl =
				    sqrt(dir[0] * dir[0] + dir[1] * dir[1] +
				         dir[2] * dir[2]);
				for (int j = 0; j < 3; j++) {
					q[j] = p[j] + len * dir[j] / dl;
				}
				double d = dist3(p, q);
				double df = fabs((double)sdfv(&s, p) -
				                 (double)sdfv(&s, q));
				worst = fmax(worst, (df - 4e-6) / d);
			}
		}
		/* The ellipsoid's bound converges to the distance; for the
		 * aspect ratios here it is within 1%. */
		if (worst > (exact ? 1.0001 : 1.01)) {
			fprintf(stderr, "  %s: Lipschitz constant %g\n",
			        bc_prim_info((enum bc_prim)k)->name, worst);
			bc_test_failures++;
		}
	}
}

/* ---- The ellipsoid ------------------------------------------------------ */

/* Exact distance from an outside point to the ellipsoid: Newton on
 * F(t) = sum (r_i p_i / (r_i^2 + t))^2 = 1 from a point left of the root,
 * where the convex decreasing F makes the iteration monotone. */
static double ellipsoid_distance(const float *r, const double p[3])
{
	double a[3] = {fabs(p[0]), fabs(p[1]), fabs(p[2])};
	double t = 0.0;
	for (int it = 0; it < 500; it++) {
		double f = -1.0, df = 0.0;
		for (int i = 0; i < 3; i++) {
			double d = (double)r[i] * r[i] + t;
			double u = r[i] * a[i] / d;
			f += u * u;
			df -= 2.0 * u * u / d;
		}
		double nt = t - f / df;
		if (!(nt > t)) {
			break;
		}
		t = nt;
	}
	double d2 = 0.0;
	for (int i = 0; i < 3; i++) {
		double rr = (double)r[i] * r[i];
		double x = rr * a[i] / (rr + t) - a[i];
		d2 += x * x;
	}
	return sqrt(d2);
}

static void ellipsoid_is_a_tight_lower_bound(void)
{
	static double pts[NSURF][3];
	rng_seed(24);
	for (int trial = 0; trial < 20; trial++) {
		struct shape s;
		shape_random(&s, BC_PRIM_ELLIPSOID);
		const float *r = s.d.params;
		/* On the surface. */
		for (int i = 0; i < 200; i++) {
			double u[3] = {rnd(-1, 1), rnd(-1, 1), rnd(-1, 1)};
			double l =
			    sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
			CHECK(fabs(sdf(&s, r[0] * u[0] / l, r[1] * u[1] / l,
			               r[2] * u[2] / l)) < 1e-5);
		}
		/* Outside: below the distance, and close to it. */
		for (int i = 0; i < 500; i++) {
			double q[3];
			random_near(&s, 2.0, q);
			double f = sdfv(&s, q);
			double k0 =
			    sqrt(pow(q[0] / r[0], 2) + pow(q[1] / r[1], 2) +
			         pow(q[2] / r[2], 2));
			if (k0 <= 1.0) {
				CHECK(f <= 1e-6);
				continue;
			}
			double e = ellipsoid_distance(r, q);
			CHECK(f > 0.0f);
			CHECK(f <= e + 1e-5 * (1.0 + e));
			CHECK(f >= 0.98 * e);
		}
		/* Inside: no deeper than the nearest surface point. */
		if (trial % 4) {
			continue;
		}
		int n = surface_samples(&s, pts, NSURF);
		REQUIRE(n == NSURF);
		for (int i = 0; i < 200; i++) {
			double q[3];
			random_near(&s, 0.0, q);
			double f = sdfv(&s, q);
			if (f < 0.0f) {
				CHECK(-f <= nearest(pts, n, q) + 1e-4);
			}
		}
	}
}

/* ---- Bounding shapes ---------------------------------------------------- */

/* The ABV invariant: a field never below its bound's distance, so a
 * primitive's ABV (the bound offset by r) holds every point where its
 * field is below r. */
static void fields_never_drop_below_their_bound(void)
{
	rng_seed(31);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		for (int trial = 0; trial < 30; trial++) {
			struct shape s;
			shape_random(&s, (enum bc_prim)k);
			for (int i = 0; i < 2000; i++) {
				double q[3];
				random_near(&s, i % 4 == 0 ? 5.0 : 0.5, q);
				double f = sdfv(&s, q);
				double b = bound_sdf(&s.bound, q);
				double tol = 2e-6 * (1.0 + fabs(b));
				if (f < b - tol) {
					fprintf(stderr,
					        "  %s: f %g < bound %g at "
					        "(%g %g %g)\n",
					        bc_prim_info(s.d.kind)->name, f,
					        b, q[0], q[1], q[2]);
					bc_test_failures++;
					break;
				}
				if (f <= 0.0f) {
					CHECK(b <= tol);
				}
			}
		}
	}
}

/* Minimum of the field over points on the bound's surface: near 0 when the
 * bound touches the solid. face selects one face of a box (0..5) or -1. */
static double min_on_bound(const struct shape *s, int face)
{
	const struct bc_abv *b = &s->bound;
	double best = INFINITY;
	if (b->shape == BC_ABV_BOX) {
		int ax = face / 2, u = (ax + 1) % 3, v = (ax + 2) % 3;
		for (int i = 0; i <= 100; i++) {
			for (int j = 0; j <= 100; j++) {
				double p[3];
				p[ax] = b->center[ax] +
				        (face % 2 ? -1.0 : 1.0) * b->half[ax];
				p[u] = b->center[u] +
				       b->half[u] * (i / 50.0 - 1.0);
				p[v] = b->center[v] +
				       b->half[v] * (j / 50.0 - 1.0);
				best = fmin(best, sdfv(s, p));
			}
		}
		return best;
	}
	for (int i = 0; i < 40000; i++) {
		double p[3], c[3], w[3], l;
		if (b->shape == BC_ABV_SPHERE) {
			memcpy(c,
			       (double[]){b->center[0], b->center[1],
			                  b->center[2]},
			       sizeof(c));
		} else {
			double t = rnd(0, 1);
			for (int j = 0; j < 3; j++) {
				c[j] = b->center[j] +
				       t * ((double)b->end[j] - b->center[j]);
			}
		}
		do {
			for (int j = 0; j < 3; j++) {
				w[j] = rnd(-1, 1);
			}
			l = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
		} while (l < 0.1 || l > 1.0);
		for (int j = 0; j < 3; j++) {
			p[j] = c[j] + b->radius * w[j] / l;
		}
		/* Capsule: keep points on its surface only. */
		if (b->shape == BC_ABV_CAPSULE &&
		    fabs(bound_sdf(b, p)) > 1e-6) {
			continue;
		}
		best = fmin(best, sdfv(s, p));
	}
	return best;
}

static void bounds_touch_the_solid(void)
{
	rng_seed(32);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		for (int trial = 0; trial < 3; trial++) {
			struct shape s;
			shape_random(&s, (enum bc_prim)k);
			const struct bc_abv *b = &s.bound;
			REQUIRE(b->shape > BC_ABV_INVALID &&
			        b->shape < BC_ABV_SHAPE_COUNT);
			if (b->shape == BC_ABV_BOX) {
				double size = fmax(
				    b->half[0], fmax(b->half[1], b->half[2]));
				for (int face = 0; face < 6; face++) {
					double m = min_on_bound(&s, face);
					if (m > 0.02 * size) {
						fprintf(stderr,
						        "  %s: face %d is %g "
						        "from the solid\n",
						        bc_prim_info(s.d.kind)
						            ->name,
						        face, m);
						bc_test_failures++;
					}
				}
			} else {
				double m = min_on_bound(&s, -1);
				if (m > 0.05 * b->radius) {
					fprintf(stderr,
					        "  %s: bound is %g from the "
					        "solid\n",
					        bc_prim_info(s.d.kind)->name,
					        m);
					bc_test_failures++;
				}
			}
		}
	}
}

static void bounds_have_the_documented_shapes(void)
{
	static const enum bc_abv_shape want[BC_PRIM_COUNT] = {
	    [BC_PRIM_SPHERE] = BC_ABV_SPHERE,
	    [BC_PRIM_OCTAHEDRON] = BC_ABV_SPHERE,
	    [BC_PRIM_SOLID_ANGLE] = BC_ABV_SPHERE,
	    [BC_PRIM_CAPSULE] = BC_ABV_CAPSULE,
	    [BC_PRIM_ROUND_CONE] = BC_ABV_CAPSULE,
	    [BC_PRIM_BOX] = BC_ABV_BOX,
	    [BC_PRIM_BOX_FRAME] = BC_ABV_BOX,
	    [BC_PRIM_CYLINDER] = BC_ABV_BOX,
	    [BC_PRIM_CONE] = BC_ABV_BOX,
	    [BC_PRIM_ELLIPSOID] = BC_ABV_BOX,
	    [BC_PRIM_HEX_PRISM] = BC_ABV_BOX,
	    [BC_PRIM_PYRAMID] = BC_ABV_BOX,
	    [BC_PRIM_TRI_PRISM] = BC_ABV_BOX,
	    [BC_PRIM_TORUS] = BC_ABV_BOX,
	    [BC_PRIM_CAPPED_TORUS] = BC_ABV_BOX,
	    [BC_PRIM_LINK] = BC_ABV_BOX,
	    [BC_PRIM_CUT_SPHERE] = BC_ABV_BOX,
	    [BC_PRIM_CUT_HOLLOW_SPHERE] = BC_ABV_BOX,
	    [BC_PRIM_DEATH_STAR] = BC_ABV_SPHERE,
	    [BC_PRIM_ROUNDED_CYLINDER] = BC_ABV_BOX,
	    [BC_PRIM_CAPPED_CYLINDER] = BC_ABV_CAPSULE,
	    [BC_PRIM_CAPPED_CONE] = BC_ABV_CAPSULE,
	    [BC_PRIM_RHOMBUS] = BC_ABV_BOX,
	    [BC_PRIM_VESICA_SEGMENT] = BC_ABV_CAPSULE,
	    [BC_PRIM_EXTRUDE_CIRCLE] = BC_ABV_BOX,
	    [BC_PRIM_EXTRUDE_RECT] = BC_ABV_BOX,
	    [BC_PRIM_EXTRUDE_POLYGON] = BC_ABV_BOX,
	    [BC_PRIM_EXTRUDE_STAR] = BC_ABV_BOX,
	    [BC_PRIM_REVOLVE_CIRCLE] = BC_ABV_BOX,
	    [BC_PRIM_REVOLVE_RECT] = BC_ABV_BOX,
	    [BC_PRIM_REVOLVE_POLYGON] = BC_ABV_BOX,
	    [BC_PRIM_REVOLVE_STAR] = BC_ABV_BOX,
	};
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		struct bc_prim_data p;
		struct bc_abv b;
		bc_prim_data_init(&p, (enum bc_prim)k);
		bc_prim_bound(&p, &b);
		CHECK_EQ_INT(b.shape, want[k]);
		if (b.shape == BC_ABV_BOX) {
			/* Local boxes are axis-aligned in the local frame. */
			for (int i = 0; i < 3; i++) {
				for (int j = 0; j < 3; j++) {
					CHECK(b.axis[i][j] ==
					      (i == j ? 1.0f : 0.0f));
				}
			}
		}
	}
	/* The solid angle's sphere is the smallest one. */
	struct shape s;
	REQUIRE(shape_make(&s, BC_PRIM_SOLID_ANGLE, (float[]){2, 30}, 2) == 0);
	NEAR(s.bound.center[1], 1.0 / cos(PI / 6.0));
	NEAR(s.bound.radius, 1.0 / cos(PI / 6.0));
	REQUIRE(shape_make(&s, BC_PRIM_SOLID_ANGLE, (float[]){2, 60}, 2) == 0);
	NEAR(s.bound.center[1], 1.0);
	NEAR(s.bound.radius, R3);
	REQUIRE(shape_make(&s, BC_PRIM_SOLID_ANGLE, (float[]){2, 120}, 2) == 0);
	NEAR(s.bound.center[1], 0.0);
	NEAR(s.bound.radius, 2.0);
}

/* ---- Validation --------------------------------------------------------- */

/* Validates p and checks the code and that the reason names what. */
static void expect_reject(struct bc_prim_data p, int code, const char *what)
{
	struct bc_errinfo ei = {0};
	int rc = bc_prim_validate(&p, &ei);
	if (rc != code || !strstr(ei.msg, what) ||
	    !strstr(ei.msg,
	            bc_prim_info(p.kind) ? bc_prim_info(p.kind)->name : "")) {
		fprintf(stderr, "  got %d \"%s\", want %d naming \"%s\"\n", rc,
		        ei.msg, code, what);
		bc_test_failures++;
	}
	CHECK_EQ_INT(ei.code, code);
}

static void expect_accept(struct bc_prim_data p)
{
	struct bc_errinfo ei = {0};
	int rc = bc_prim_validate(&p, &ei);
	if (rc != 0) {
		fprintf(stderr, "  rejected: %s\n", ei.msg);
		bc_test_failures++;
	}
}

static void validation_rejects_nonfinite_and_bad_sizes(void)
{
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		for (uint32_t i = 0; i < info->nparams; i++) {
			const struct bc_param_desc *d = &info->params[i];
			for (uint32_t c = 0; c < d->count; c++) {
				struct bc_prim_data p;
				bc_prim_data_init(&p, (enum bc_prim)k);
				float *v = &p.params[d->offset + c];
				*v = NAN;
				expect_reject(p, BC_ENONFINITE, d->name);
				*v = INFINITY;
				expect_reject(p, BC_ENONFINITE, d->name);
				*v = -INFINITY;
				expect_reject(p, BC_ENONFINITE, d->name);
				*v = 2.0f * BC_PARAM_MAX_ABS;
				expect_reject(p, BC_ERANGE, d->name);
				*v = -2.0f * BC_PARAM_MAX_ABS;
				expect_reject(p, BC_ERANGE, d->name);
				if (d->flags & BC_PARAM_POSITIVE) {
					*v = 0.0f;
					expect_reject(p, BC_ERANGE, d->name);
					*v = -1.0f;
					expect_reject(p, BC_ERANGE, d->name);
					*v = 1e-9f;
					expect_reject(p, BC_ERANGE, d->name);
				}
				if (d->flags & BC_PARAM_NONNEG) {
					*v = -0.01f;
					expect_reject(p, BC_ERANGE, d->name);
				}
				if (d->count == 3) {
					/* The component is named too. */
					char idx[8];
					snprintf(idx, sizeof(idx), "[%u]", c);
					*v = NAN;
					expect_reject(p, BC_ENONFINITE, idx);
				}
			}
		}
	}
}

static void validation_applies_shape_rules(void)
{
	struct bc_prim_data p;
	bc_prim_data_init(&p, BC_PRIM_BOX);
	p.params[0] = 0.5f;
	p.params[3] = 0.7f;
	expect_reject(p, BC_ERANGE, "round");
	p.params[3] = 0.5f;
	expect_accept(p);

	bc_prim_data_init(&p, BC_PRIM_BOX_FRAME);
	p.params[1] = 0.3f;
	p.params[3] = 0.31f;
	expect_reject(p, BC_ERANGE, "thickness");
	p.params[3] = 0.3f;
	expect_accept(p);

	bc_prim_data_init(&p, BC_PRIM_CONE);
	p.params[1] = 0.0f;
	p.params[2] = 0.0f;
	expect_reject(p, BC_ERANGE, "radius");
	p.params[2] = 0.5f;
	expect_accept(p);

	bc_prim_data_init(&p, BC_PRIM_ROUND_CONE);
	p.params[6] = 0.0f;
	p.params[7] = 0.0f;
	expect_reject(p, BC_ERANGE, "radius_a");
	p.params[7] = 0.1f;
	expect_accept(p);
	/* Coincident ends are a sphere, for capsules and round cones. */
	memcpy(p.params + 3, p.params, 3 * sizeof(float));
	expect_accept(p);
	bc_prim_data_init(&p, BC_PRIM_CAPSULE);
	memcpy(p.params + 3, p.params, 3 * sizeof(float));
	expect_accept(p);

	/* A self-intersecting (spindle) torus is still a solid. */
	bc_prim_data_init(&p, BC_PRIM_TORUS);
	p.params[1] = 2.0f * p.params[0];
	expect_accept(p);

	bc_prim_data_init(&p, BC_PRIM_CAPPED_TORUS);
	p.params[2] = 180.0f;
	expect_accept(p);
	p.params[2] = 180.5f;
	expect_reject(p, BC_ERANGE, "angle_deg");
	p.params[2] = 0.0f;
	expect_reject(p, BC_ERANGE, "angle_deg");
	p.params[2] = -10.0f;
	expect_reject(p, BC_ERANGE, "angle_deg");

	bc_prim_data_init(&p, BC_PRIM_SOLID_ANGLE);
	p.params[1] = 179.0f;
	expect_accept(p);
	p.params[1] = 180.0f;
	expect_reject(p, BC_ERANGE, "angle_deg");
	p.params[1] = 0.0f;
	expect_reject(p, BC_ERANGE, "angle_deg");

	bc_prim_data_init(&p, BC_PRIM_LINK);
	p.params[0] = 0.0f;
	expect_accept(p);
}

static void validation_checks_transform_and_colour(void)
{
	struct bc_prim_data p;
	struct bc_errinfo ei = {0};

	/* Near-unit quaternions are renormalized in place. */
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.rotate[0] = 0.6f * 1.0008f;
	p.rotate[1] = 0.0f;
	p.rotate[2] = 0.0f;
	p.rotate[3] = 0.8f * 1.0008f;
	REQUIRE(bc_prim_validate(&p, &ei) == 0);
	CHECK_NEAR(p.rotate[0], 0.6, 1e-7);
	CHECK_NEAR(p.rotate[3], 0.8, 1e-7);
	p.rotate[0] = 0.6f * 1.002f;
	p.rotate[3] = 0.8f * 1.002f;
	expect_reject(p, BC_ERANGE, "rotate");
	p.rotate[0] = 0.0f;
	p.rotate[3] = 0.0f;
	expect_reject(p, BC_ERANGE, "rotate");
	p.rotate[3] = NAN;
	expect_reject(p, BC_ENONFINITE, "rotate");

	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.translate[1] = INFINITY;
	expect_reject(p, BC_ENONFINITE, "translate[1]");
	p.translate[1] = -1.5f * BC_PARAM_MAX_ABS;
	expect_reject(p, BC_ERANGE, "translate[1]");
	p.translate[1] = -BC_PARAM_MAX_ABS;
	expect_accept(p);

	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.color[2] = 1.5f;
	expect_accept(p); /* no colour: ignored */
	p.has_color = true;
	expect_reject(p, BC_ERANGE, "color[2]");
	p.color[2] = -0.1f;
	expect_reject(p, BC_ERANGE, "color[2]");
	p.color[2] = NAN;
	expect_reject(p, BC_ENONFINITE, "color[2]");
	p.color[2] = 1.0f;
	expect_accept(p);

	/* The reason reads as a sentence about the parameter. */
	bc_prim_data_init(&p, BC_PRIM_BOX);
	p.params[0] = 0.5f;
	p.params[3] = 0.7f;
	REQUIRE(bc_prim_validate(&p, &ei) == BC_ERANGE);
	CHECK(strcmp(ei.msg, "box: round 0.7 exceeds the smallest half "
	                     "extent 0.5") == 0);
}

static void unknown_kinds_are_refused(void)
{
	struct bc_prim_data p;
	struct bc_errinfo ei = {0};
	struct bc_abv b;
	float k[BC_PRIM_PACKED];
	bc_prim_data_init(&p, BC_PRIM_INVALID);
	CHECK_EQ_INT(bc_prim_validate(&p, &ei), BC_EENUM);
	p.kind = BC_PRIM_COUNT;
	CHECK_EQ_INT(bc_prim_validate(&p, &ei), BC_EENUM);
	bc_prim_bound(&p, &b);
	CHECK_EQ_INT(b.shape, BC_ABV_INVALID);
	bc_prim_pack(&p, k);
	CHECK(isinf(bc_prim_sdf(BC_PRIM_COUNT, k, 0, 0, 0)));
	CHECK(isinf(bc_prim_sdf(BC_PRIM_INVALID, k, 0, 0, 0)));
}

/* Extreme but valid parameters and far points never produce NaN. */
static void fields_stay_finite_at_the_limits(void)
{
	int checked = 0;
	rng_seed(41);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		for (int trial = 0; trial < 40; trial++) {
			struct shape s;
			shape_random(&s, (enum bc_prim)k);
			float scale = trial % 2 ? 1e-6f : 1e5f;
			const struct bc_prim_info *info =
			    bc_prim_info((enum bc_prim)k);
			for (uint32_t i = 0; i < info->nparams; i++) {
				const struct bc_param_desc *d =
				    &info->params[i];
				if (strcmp(d->name, "angle_deg") == 0) {
					continue;
				}
				for (uint32_t c = 0; c < d->count; c++) {
					float *v = &s.d.params[d->offset + c];
					*v = (d->flags & BC_PARAM_POSITIVE)
					         ? fmaxf(*v * scale, 1e-6f)
					         : *v * scale;
				}
			}
			struct bc_errinfo ei = {0};
			if (bc_prim_validate(&s.d, &ei) != 0) {
				continue; /* a scaled rule may not hold */
			}
			checked++;
			bc_prim_pack(&s.d, s.k);
			for (int i = 0; i < 200; i++) {
				double far = i % 3 == 0
				                 ? 1e7
				                 : (i % 3 == 1 ? 1.0 : 1e-6);
				double q[3] = {rnd(-1, 1) * far,
				               rnd(-1, 1) * far,
				               rnd(-1, 1) * far};
				if (i == 0) {
					q[0] = q[1] = q[2] = 0.0;
				}
				float f = sdfv(&s, q);
				if (isnan(f)) {
					fprintf(stderr,
					        "  %s: NaN at (%g %g %g)\n",
					        info->name, q[0], q[1], q[2]);
					bc_test_failures++;
					break;
				}
			}
		}
	}
	/* Most scaled shapes stay valid, so the loop did test them. */
	CHECK(checked > 15 * 40 * 3 / 4);
	printf("  %d extreme shapes checked\n", checked);
}

static const struct bc_test tests[] = {
    {"table_covers_every_kind_contiguously",
     table_covers_every_kind_contiguously},
    {"scene_format_names_are_fixed", scene_format_names_are_fixed},
    {"init_gives_valid_unit_shapes", init_gives_valid_unit_shapes},
    {"sphere_values", sphere_values},
    {"box_values", box_values},
    {"capsule_values", capsule_values},
    {"cylinder_values", cylinder_values},
    {"torus_values", torus_values},
    {"cone_values", cone_values},
    {"round_cone_values", round_cone_values},
    {"ellipsoid_values", ellipsoid_values},
    {"hex_prism_values", hex_prism_values},
    {"octahedron_values", octahedron_values},
    {"box_frame_values", box_frame_values},
    {"capped_torus_values", capped_torus_values},
    {"link_values", link_values},
    {"solid_angle_values", solid_angle_values},
    {"pyramid_values", pyramid_values},
    {"tri_prism_values", tri_prism_values},
    {"fields_match_independent_formulas", fields_match_independent_formulas},
    {"fields_agree_with_brute_force_distance",
     fields_agree_with_brute_force_distance},
    {"exact_fields_project_onto_their_surface",
     exact_fields_project_onto_their_surface},
    {"fields_are_1_lipschitz", fields_are_1_lipschitz},
    {"ellipsoid_is_a_tight_lower_bound", ellipsoid_is_a_tight_lower_bound},
    {"fields_never_drop_below_their_bound",
     fields_never_drop_below_their_bound},
    {"bounds_touch_the_solid", bounds_touch_the_solid},
    {"bounds_have_the_documented_shapes", bounds_have_the_documented_shapes},
    {"validation_rejects_nonfinite_and_bad_sizes",
     validation_rejects_nonfinite_and_bad_sizes},
    {"validation_applies_shape_rules", validation_applies_shape_rules},
    {"validation_checks_transform_and_colour",
     validation_checks_transform_and_colour},
    {"unknown_kinds_are_refused", unknown_kinds_are_refused},
    {"fields_stay_finite_at_the_limits", fields_stay_finite_at_the_limits},
};

BC_TEST_MAIN(tests)
