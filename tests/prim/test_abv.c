/*
 * World-space bounding shapes (ABVs): their AABBs, ray clipping against
 * brute-force point sampling along the ray (axis-parallel and grazing rays
 * included), and box overlap queries, which must never answer "no" where
 * the shape and the box share a point.
 */
#include "blobcast/blobtree.h"

#include <math.h>
#include <string.h>

#include "test.h"

static uint64_t rng_state = 0x2545f4914f6cdd1dull;

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

/* Rows of the rotation of a random unit quaternion. */
static void random_axes(float axis[3][3])
{
	double q[4], n;
	do {
		n = 0;
		for (int i = 0; i < 4; i++) {
			q[i] = rnd(-1, 1);
			n += q[i] * q[i];
		}
	} while (n < 0.05 || n > 1.0);
	n = sqrt(n);
	double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
	double m[3][3] = {
	    {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
	    {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
	    {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)},
	};
	for (int i = 0; i < 3; i++) {
		for (int j = 0; j < 3; j++) {
			axis[i][j] = (float)m[j][i]; /* columns: local axes */
		}
	}
}

static void random_abv(struct bc_abv *b, enum bc_abv_shape shape)
{
	memset(b, 0, sizeof(*b));
	b->shape = shape;
	for (int i = 0; i < 3; i++) {
		b->center[i] = rnd(-1.5f, 1.5f);
	}
	switch (shape) {
	case BC_ABV_SPHERE:
		b->radius = rnd(0.05f, 1.5f);
		break;
	case BC_ABV_BOX:
		if (rng_u32() % 4 == 0) {
			for (int i = 0; i < 3; i++) {
				b->axis[i][i] = 1.0f;
			}
		} else {
			random_axes(b->axis);
		}
		for (int i = 0; i < 3; i++) {
			b->half[i] = rnd(0.02f, 1.5f);
		}
		break;
	default:
		if (rng_u32() % 5 == 0) {
			memcpy(b->end, b->center, sizeof(b->end));
		} else if (rng_u32() % 4 == 0) {
			/* Along a world axis: rays may run parallel to it. */
			memcpy(b->end, b->center, sizeof(b->end));
			b->end[rng_u32() % 3] += rnd(0.2f, 2.0f);
		} else {
			for (int i = 0; i < 3; i++) {
				b->end[i] = rnd(-1.5f, 1.5f);
			}
		}
		b->radius = rnd(0.05f, 1.0f);
		break;
	}
}

/* Signed distance to the shape, in double, written apart from abv.c. */
static double shape_sdf(const struct bc_abv *b, const double p[3])
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
		double out = 0, in = -INFINITY;
		for (int i = 0; i < 3; i++) {
			double l = q[0] * b->axis[i][0] + q[1] * b->axis[i][1] +
			           q[2] * b->axis[i][2];
			double e = fabs(l) - b->half[i];
			out += e > 0 ? e * e : 0;
			in = e > in ? e : in;
		}
		return sqrt(out) + (in < 0 ? in : 0);
	}
	case BC_ABV_CAPSULE: {
		double e[3], ee = 0, t = 0, d2 = 0;
		for (int i = 0; i < 3; i++) {
			e[i] = (double)b->end[i] - b->center[i];
			ee += e[i] * e[i];
			t += q[i] * e[i];
		}
		t = ee > 0 ? t / ee : 0;
		t = t < 0 ? 0 : (t > 1 ? 1 : t);
		for (int i = 0; i < 3; i++) {
			double w = q[i] - t * e[i];
			d2 += w * w;
		}
		return sqrt(d2) - b->radius;
	}
	default:
		return INFINITY;
	}
}

/* A random point of the solid shape, by construction. */
static void random_inside(const struct bc_abv *b, double p[3])
{
	double u[3], l;
	do {
		for (int i = 0; i < 3; i++) {
			u[i] = rnd(-1, 1);
		}
		l = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
	} while (l > 1.0);
	switch (b->shape) {
	case BC_ABV_SPHERE:
		for (int i = 0; i < 3; i++) {
			p[i] = b->center[i] + b->radius * u[i];
		}
		break;
	case BC_ABV_BOX: {
		double s[3] = {rnd(-1, 1), rnd(-1, 1), rnd(-1, 1)};
		for (int i = 0; i < 3; i++) {
			p[i] = b->center[i];
			for (int j = 0; j < 3; j++) {
				p[i] += b->axis[j][i] * b->half[j] * s[j];
			}
		}
		break;
	}
	default: {
		double t = rnd(0, 1);
		for (int i = 0; i < 3; i++) {
			p[i] = b->center[i] +
			       t * ((double)b->end[i] - b->center[i]) +
			       b->radius * u[i];
		}
		break;
	}
	}
}

static const enum bc_abv_shape shapes[] = {BC_ABV_SPHERE, BC_ABV_BOX,
                                           BC_ABV_CAPSULE};

/* ---- AABBs -------------------------------------------------------------- */

static void aabb_holds_the_shape_and_touches_it(void)
{
	for (int n = 0; n < 300; n++) {
		struct bc_abv b;
		float lo[3], hi[3];
		random_abv(&b, shapes[n % 3]);
		bc_abv_aabb(&b, lo, hi);
		for (int i = 0; i < 500; i++) {
			double p[3];
			random_inside(&b, p);
			for (int k = 0; k < 3; k++) {
				CHECK(p[k] >= lo[k] - 1e-5 &&
				      p[k] <= hi[k] + 1e-5);
			}
		}
		/* Extreme points of the shape reach each face. */
		for (int k = 0; k < 3; k++) {
			double top = -INFINITY, bot = INFINITY;
			if (b.shape == BC_ABV_BOX) {
				for (int c = 0; c < 8; c++) {
					double v = b.center[k];
					for (int j = 0; j < 3; j++) {
						double sg =
						    (c >> j) & 1 ? 1 : -1;
						v += sg * b.axis[j][k] *
						     b.half[j];
					}
					top = fmax(top, v);
					bot = fmin(bot, v);
				}
			} else {
				double e = b.shape == BC_ABV_CAPSULE
				               ? b.end[k]
				               : b.center[k];
				top = fmax(b.center[k], e) + b.radius;
				bot = fmin(b.center[k], e) - b.radius;
			}
			CHECK_NEAR(hi[k], top, 1e-5);
			CHECK_NEAR(lo[k], bot, 1e-5);
		}
	}
	/* Not a shape: empty. */
	struct bc_abv none = {0};
	float lo[3], hi[3];
	bc_abv_aabb(&none, lo, hi);
	CHECK(lo[0] > hi[0]);
}

/* ---- Rays --------------------------------------------------------------- */

static void random_dir(float d[3])
{
	uint32_t kind = rng_u32() % 6;
	memset(d, 0, 3 * sizeof(float));
	if (kind == 0) {
		/* Along a world axis: two zero components. */
		d[rng_u32() % 3] = rng_u32() % 2 ? 1.0f : -1.0f;
		return;
	}
	if (kind == 1) {
		/* In a coordinate plane: one zero component. */
		uint32_t z = rng_u32() % 3;
		d[(z + 1) % 3] = 0.70710678f;
		d[(z + 2) % 3] = rng_u32() % 2 ? 0.70710678f : -0.70710678f;
		return;
	}
	double l;
	do {
		l = 0;
		for (int i = 0; i < 3; i++) {
			d[i] = rnd(-1, 1);
			l += (double)d[i] * d[i];
		}
	} while (l < 0.01 || l > 1.0);
	for (int i = 0; i < 3; i++) {
		d[i] = (float)(d[i] / sqrt(l));
	}
}

/* Checks one ray against sampling along it; returns whether it hit. */
static bool check_ray(const struct bc_abv *b, const float o[3],
                      const float d[3])
{
	float t0 = NAN, t1 = NAN;
	bool hit = bc_abv_ray(b, o, d, &t0, &t1);
	if (hit) {
		CHECK(isfinite(t0) && isfinite(t1));
		CHECK(t0 <= t1);
		CHECK(t1 >= 0.0f);
		/* Entry and exit are on the boundary; between is inside. */
		double pe[3], px[3], pm[3];
		for (int i = 0; i < 3; i++) {
			pe[i] = o[i] + (double)t0 * d[i];
			px[i] = o[i] + (double)t1 * d[i];
			pm[i] = o[i] + 0.5 * ((double)t0 + t1) * d[i];
		}
		CHECK(fabs(shape_sdf(b, pe)) <= 1e-4);
		CHECK(fabs(shape_sdf(b, px)) <= 1e-4);
		CHECK(shape_sdf(b, pm) <= 1e-5);
	}
	for (int s = 0; s <= 2000; s++) {
		double t = 10.0 * s / 2000.0, p[3];
		for (int i = 0; i < 3; i++) {
			p[i] = o[i] + t * d[i];
		}
		if (shape_sdf(b, p) < -1e-5) {
			if (!hit || t < t0 - 1e-5 || t > t1 + 1e-5) {
				fprintf(stderr,
				        "  shape %d: inside at t=%g, ray says "
				        "%d [%g, %g]\n",
				        b->shape, t, hit, t0, t1);
				bc_test_failures++;
				break;
			}
		}
	}
	return hit;
}

static void rays_agree_with_sampling(void)
{
	int hits = 0, rays = 0;
	for (int n = 0; n < 150; n++) {
		struct bc_abv b;
		random_abv(&b, shapes[n % 3]);
		for (int r = 0; r < 20; r++) {
			float o[3], d[3];
			for (int i = 0; i < 3; i++) {
				o[i] = rnd(-4.0f, 4.0f);
			}
			if (r % 5 == 0) {
				/* From inside. */
				double p[3];
				random_inside(&b, p);
				for (int i = 0; i < 3; i++) {
					o[i] = (float)p[i];
				}
			}
			random_dir(d);
			if (r % 3 == 0) {
				/* Aimed near the centre: more hits. */
				double l = 0;
				for (int i = 0; i < 3; i++) {
					d[i] = b.center[i] + rnd(-0.5f, 0.5f) -
					       o[i];
					l += (double)d[i] * d[i];
				}
				for (int i = 0; i < 3; i++) {
					d[i] = (float)(d[i] / sqrt(l));
				}
			}
			hits += check_ray(&b, o, d);
			rays++;
		}
	}
	/* Both outcomes are exercised. */
	CHECK(hits > rays / 5);
	CHECK(hits < rays);
}

static void axis_parallel_and_grazing_rays(void)
{
	struct bc_abv box = {.shape = BC_ABV_BOX};
	float t0, t1;
	for (int i = 0; i < 3; i++) {
		box.axis[i][i] = 1.0f;
		box.half[i] = 1.0f;
	}
	/* Along z, on the plane x = 1 of a face: still touching. */
	REQUIRE(bc_abv_ray(&box, (float[]){1, 0, -5}, (float[]){0, 0, 1}, &t0,
	                   &t1));
	CHECK_NEAR(t0, 4.0, 1e-5);
	CHECK_NEAR(t1, 6.0, 1e-5);
	CHECK(!bc_abv_ray(&box, (float[]){1.0001f, 0, -5}, (float[]){0, 0, 1},
	                  &t0, &t1));
	/* Along an edge, and backwards. */
	REQUIRE(bc_abv_ray(&box, (float[]){-1, 1, 5}, (float[]){0, 0, -1}, &t0,
	                   &t1));
	CHECK_NEAR(t0, 4.0, 1e-5);
	CHECK_NEAR(t1, 6.0, 1e-5);
	/* Every axis-parallel ray from a grid that includes the planes. */
	for (int i = 0; i < 7; i++) {
		for (int j = 0; j < 7; j++) {
			for (int ax = 0; ax < 3; ax++) {
				float o[3], d[3] = {0, 0, 0};
				o[ax] = -3.0f;
				o[(ax + 1) % 3] = -1.5f + 0.5f * (float)i;
				o[(ax + 2) % 3] = -1.5f + 0.5f * (float)j;
				d[ax] = 1.0f;
				check_ray(&box, o, d);
			}
		}
	}

	/* A capsule along y, rays parallel to its axis. */
	struct bc_abv cap = {.shape = BC_ABV_CAPSULE,
	                     .center = {0, -1, 0},
	                     .end = {0, 1, 0},
	                     .radius = 0.5f};
	double h = sqrt(0.25 - 0.04);
	REQUIRE(bc_abv_ray(&cap, (float[]){0.2f, -5, 0}, (float[]){0, 1, 0},
	                   &t0, &t1));
	CHECK_NEAR(t0, 4.0 - h, 1e-5);
	CHECK_NEAR(t1, 6.0 + h, 1e-5);
	REQUIRE(bc_abv_ray(&cap, (float[]){0.5f, -5, 0}, (float[]){0, 1, 0},
	                   &t0, &t1));
	CHECK_NEAR(t0, 4.0, 1e-5);
	CHECK_NEAR(t1, 6.0, 1e-5);
	CHECK(!bc_abv_ray(&cap, (float[]){0.5001f, -5, 0}, (float[]){0, 1, 0},
	                  &t0, &t1));
	REQUIRE(bc_abv_ray(&cap, (float[]){-5, 0, 0}, (float[]){1, 0, 0}, &t0,
	                   &t1));
	CHECK_NEAR(t0, 4.5, 1e-5);
	CHECK_NEAR(t1, 5.5, 1e-5);
	for (int i = 0; i < 9; i++) {
		float o[3] = {-1.0f + 0.25f * (float)i, -5.0f, 0.0f};
		check_ray(&cap, o, (float[]){0, 1, 0});
		check_ray(&cap, o, (float[]){0, 0, 1});
	}
	/* A point capsule is a ball. */
	struct bc_abv dot = {.shape = BC_ABV_CAPSULE,
	                     .center = {1, 1, 1},
	                     .end = {1, 1, 1},
	                     .radius = 0.5f};
	REQUIRE(bc_abv_ray(&dot, (float[]){1, 1, -5}, (float[]){0, 0, 1}, &t0,
	                   &t1));
	CHECK_NEAR(t0, 5.5, 1e-5);
	CHECK_NEAR(t1, 6.5, 1e-5);

	/* No direction: no ray. */
	struct bc_abv ball = {.shape = BC_ABV_SPHERE, .radius = 1.0f};
	CHECK(!bc_abv_ray(&ball, (float[]){0, 0, 0}, (float[]){0, 0, 0}, &t0,
	                  &t1));
	/* Not a shape. */
	struct bc_abv none = {0};
	CHECK(!bc_abv_ray(&none, (float[]){0, 0, -5}, (float[]){0, 0, 1}, &t0,
	                  &t1));
}

static void shapes_behind_the_origin_are_missed(void)
{
	struct bc_abv ball = {
	    .shape = BC_ABV_SPHERE, .center = {0, 0, -5}, .radius = 1.0f};
	float t0, t1;
	CHECK(!bc_abv_ray(&ball, (float[]){0, 0, 0}, (float[]){0, 0, 1}, &t0,
	                  &t1));
	REQUIRE(bc_abv_ray(&ball, (float[]){0, 0, 0}, (float[]){0, 0, -1}, &t0,
	                   &t1));
	CHECK_NEAR(t0, 4.0, 1e-5);
	CHECK_NEAR(t1, 6.0, 1e-5);
	/* From inside: entry behind, exit ahead. */
	REQUIRE(bc_abv_ray(&ball, (float[]){0, 0, -5}, (float[]){1, 0, 0}, &t0,
	                   &t1));
	CHECK_NEAR(t0, -1.0, 1e-5);
	CHECK_NEAR(t1, 1.0, 1e-5);
	/* A far origin does not lose the hit to cancellation. */
	REQUIRE(bc_abv_ray(&ball, (float[]){0, 0.999f, 1e5f},
	                   (float[]){0, 0, -1}, &t0, &t1));
	CHECK(t0 < 1e5f + 5.0f && t1 > 1e5f + 5.0f);
}

/* ---- Boxes -------------------------------------------------------------- */

static void random_box(float lo[3], float hi[3])
{
	for (int i = 0; i < 3; i++) {
		float a = rnd(-2.5f, 1.5f),
		      e = rng_u32() % 8 ? rnd(0, 2) : 0.0f;
		lo[i] = a;
		hi[i] = a + e;
	}
}

static void sphere_box_test_is_exact(void)
{
	int meets = 0, n = 0;
	for (int i = 0; i < 20000; i++) {
		struct bc_abv b;
		float lo[3], hi[3];
		random_abv(&b, BC_ABV_SPHERE);
		random_box(lo, hi);
		double d2 = 0;
		for (int k = 0; k < 3; k++) {
			double c = b.center[k];
			double e =
			    c < lo[k] ? lo[k] - c : (c > hi[k] ? c - hi[k] : 0);
			d2 += e * e;
		}
		double d = sqrt(d2);
		if (fabs(d - b.radius) < 1e-5) {
			continue; /* on the boundary: either answer */
		}
		bool want = d < b.radius;
		CHECK(bc_abv_meets_box(&b, lo, hi) == want);
		meets += want;
		n++;
	}
	printf("  %d of %d meet\n", meets, n);
	CHECK(meets > n / 10 && meets < n - n / 10);
}

static void boxes_sharing_a_point_always_meet(void)
{
	int checked = 0, rejected = 0;
	for (int i = 0; i < 3000; i++) {
		struct bc_abv b;
		float lo[3], hi[3];
		random_abv(&b, shapes[i % 3]);
		random_box(lo, hi);
		if (i % 2) {
			/* A small box near the shape's boundary. */
			double q[3];
			random_inside(&b, q);
			for (int k = 0; k < 3; k++) {
				float c = (float)q[k] + rnd(-0.6f, 0.6f);
				lo[k] = c - rnd(0, 0.3f);
				hi[k] = c + rnd(0, 0.3f);
			}
		}
		bool meets = bc_abv_meets_box(&b, lo, hi);
		for (int j = 0; j < 300; j++) {
			double p[3];
			random_inside(&b, p);
			if (p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] &&
			    p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2]) {
				CHECK(meets);
				checked++;
				break;
			}
		}
		rejected += !meets;
		/* A point box at a point of the solid. */
		double p[3];
		random_inside(&b, p);
		float pt[3] = {(float)p[0], (float)p[1], (float)p[2]};
		if (shape_sdf(&b, (double[]){pt[0], pt[1], pt[2]}) < -1e-5) {
			CHECK(bc_abv_meets_box(&b, pt, pt));
		}
	}
	printf("  %d shared a sampled point, %d refused\n", checked, rejected);
	CHECK(checked > 300);
	CHECK(rejected > 300);
}

static void separated_boxes_are_refused(void)
{
	/* A thin box turned 45 degrees about z: its AABB covers the query
	 * box, one of its own axes separates them. */
	struct bc_abv slab = {.shape = BC_ABV_BOX, .half = {1, 0.1f, 1}};
	float c = 0.70710678f;
	slab.axis[0][0] = c, slab.axis[0][1] = c;
	slab.axis[1][0] = -c, slab.axis[1][1] = c;
	slab.axis[2][2] = 1;
	CHECK(!bc_abv_meets_box(&slab, (float[]){0.6f, -0.75f, -0.1f},
	                        (float[]){0.75f, -0.6f, 0.1f}));
	CHECK(bc_abv_meets_box(&slab, (float[]){0.5f, 0.5f, -0.1f},
	                       (float[]){0.6f, 0.6f, 0.1f}));
	/* A diagonal capsule and a box in a far corner of its AABB. */
	struct bc_abv cap = {.shape = BC_ABV_CAPSULE,
	                     .center = {-1, -1, -1},
	                     .end = {1, 1, 1},
	                     .radius = 0.1f};
	CHECK(!bc_abv_meets_box(&cap, (float[]){0.6f, -1, -0.2f},
	                        (float[]){1, -0.6f, 0.2f}));
	CHECK(bc_abv_meets_box(&cap, (float[]){0.45f, 0.45f, 0.45f},
	                       (float[]){0.5f, 0.5f, 0.5f}));
	/* A ball and a box in the corner of its AABB. */
	struct bc_abv ball = {.shape = BC_ABV_SPHERE, .radius = 1};
	CHECK(!bc_abv_meets_box(&ball, (float[]){0.8f, 0.8f, 0.8f},
	                        (float[]){1, 1, 1}));
	/* Far away, and not a shape. */
	CHECK(!bc_abv_meets_box(&ball, (float[]){5, 5, 5}, (float[]){6, 6, 6}));
	struct bc_abv none = {0};
	CHECK(!bc_abv_meets_box(&none, (float[]){-1, -1, -1},
	                        (float[]){1, 1, 1}));
}

static const struct bc_test tests[] = {
    {"aabb_holds_the_shape_and_touches_it",
     aabb_holds_the_shape_and_touches_it},
    {"rays_agree_with_sampling", rays_agree_with_sampling},
    {"axis_parallel_and_grazing_rays", axis_parallel_and_grazing_rays},
    {"shapes_behind_the_origin_are_missed",
     shapes_behind_the_origin_are_missed},
    {"sphere_box_test_is_exact", sphere_box_test_is_exact},
    {"boxes_sharing_a_point_always_meet", boxes_sharing_a_point_always_meet},
    {"separated_boxes_are_refused", separated_boxes_are_refused},
};

BC_TEST_MAIN(tests)
