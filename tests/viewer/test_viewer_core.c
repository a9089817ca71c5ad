/*
 * blobcast-view's windowless parts (bc_viewer_core): the camera and its
 * projection against blobtree's own ray generator, bounding boxes against
 * the primitives' fields, the meters, the edit queue's one-in-flight rule
 * and latency matching, frame assembly (rectangles, downscaled frames, the
 * stale-base case, errors, allocation failures), the bitmap font, and
 * Alt+wheel's rules for unary nodes (which node, what a notch gives).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "test.h"
#include "viewer.h"

/* A small deterministic generator (xorshift32), for repeatable cases. */
static uint32_t rng_state = 2463534242u;

static float frand(float lo, float hi)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 17;
	rng_state ^= rng_state << 5;
	return lo + (hi - lo) * (float)(rng_state >> 8) / 16777216.0f;
}

static float dot3(const float a[3], const float b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static float dist3(const float a[3], const float b[3])
{
	float d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
	return sqrtf(dot3(d, d));
}

static void random_camera(struct bc_camera *c)
{
	do {
		for (int i = 0; i < 3; i++) {
			c->eye[i] = frand(-8.0f, 8.0f);
			c->target[i] = frand(-1.0f, 1.0f);
		}
		c->up[0] = frand(-0.3f, 0.3f);
		c->up[1] = 1.0f;
		c->up[2] = frand(-0.3f, 0.3f);
		c->fov_y_deg = frand(20.0f, 90.0f);
	} while (bc_camera_validate(c, NULL) != 0 ||
	         dist3(c->eye, c->target) < 1.0f);
}

/* ---- camera -------------------------------------------------------------- */

/* A point on the ray bc_view_rays_dir() gives for (x, y) projects back to
 * (x, y): the viewer and the server agree on every pixel. */
static void test_project_inverts_view_rays(void)
{
	for (int n = 0; n < 200; n++) {
		struct bc_camera c;
		struct bc_view_rays vr;
		uint32_t w = 64u + (uint32_t)frand(0.0f, 900.0f);
		uint32_t h = 48u + (uint32_t)frand(0.0f, 700.0f);
		float x = frand(0.0f, (float)w), y = frand(0.0f, (float)h);
		float t = frand(0.5f, 30.0f), dir[3], p[3], out[3];
		random_camera(&c);
		bc_view_rays_init(&vr, &c, w, h);
		bc_view_rays_dir(&vr, x, y, dir);
		for (int i = 0; i < 3; i++) {
			p[i] = c.eye[i] + t * dir[i];
		}
		REQUIRE(bc_viewer_project(&c, w, h, p, out));
		CHECK_NEAR(out[0], x, 0.02 * (1.0 + t));
		CHECK_NEAR(out[1], y, 0.02 * (1.0 + t));
		CHECK_NEAR(out[2], t * dot3(dir, vr.forward), 1e-3 * t);
	}
}

static void test_project_refuses_points_behind_the_eye(void)
{
	struct bc_camera c;
	float p[3], out[3] = {7.0f, 7.0f, 7.0f};
	bc_camera_default(&c); /* eye (0,0,6) looking at the origin */
	p[0] = 0.0f;
	p[1] = 0.0f;
	p[2] = 7.0f;
	CHECK(!bc_viewer_project(&c, 100, 100, p, out));
	p[2] = 6.0f; /* at the eye */
	CHECK(!bc_viewer_project(&c, 100, 100, p, out));
	p[2] = 0.0f; /* the target: the centre */
	REQUIRE(bc_viewer_project(&c, 100, 80, p, out));
	CHECK_NEAR(out[0], 50.0, 1e-4);
	CHECK_NEAR(out[1], 40.0, 1e-4);
	CHECK_NEAR(out[2], 6.0, 1e-5);
}

/* Horizontal motion turns about up: the height above the target and the
 * distance stay, the angle is dx * BC_VIEWER_ORBIT_PER_PX. */
static void test_orbit_turns_about_up(void)
{
	struct bc_camera c;
	float before[3], after[3], h0, h1, cosang;
	bc_camera_default(&c);
	c.eye[1] = 2.0f;
	for (int i = 0; i < 3; i++) {
		before[i] = c.eye[i] - c.target[i];
	}
	bc_viewer_orbit(&c, 100.0f, 0.0f);
	for (int i = 0; i < 3; i++) {
		after[i] = c.eye[i] - c.target[i];
	}
	h0 = before[1];
	h1 = after[1];
	CHECK_NEAR(h1, h0, 1e-5);
	CHECK_NEAR(sqrtf(dot3(after, after)), sqrtf(dot3(before, before)),
	           1e-4);
	/* The angle between the horizontal parts. */
	cosang = (before[0] * after[0] + before[2] * after[2]) /
	         (before[0] * before[0] + before[2] * before[2]);
	CHECK_NEAR(acosf(cosang), 100.0f * BC_VIEWER_ORBIT_PER_PX, 1e-3);
	CHECK(bc_camera_validate(&c, NULL) == 0);
}

/* Vertical motion never carries the eye over a pole, however far the
 * mouse goes: the camera stays valid for the server. */
static void test_orbit_stops_at_the_poles(void)
{
	struct bc_camera c;
	bc_camera_default(&c);
	for (int k = 0; k < 400; k++) {
		float off[3], cosv;
		bc_viewer_orbit(&c, 0.0f, 37.0f);
		for (int i = 0; i < 3; i++) {
			off[i] = c.eye[i] - c.target[i];
		}
		cosv = off[1] / sqrtf(dot3(off, off));
		CHECK(fabsf(cosv) <= BC_VIEWER_ORBIT_MAX_COS + 1e-4f);
		CHECK_NEAR(sqrtf(dot3(off, off)), 6.0, 1e-3);
		CHECK(bc_camera_validate(&c, NULL) == 0);
	}
	/* It did climb: the eye ended up high above the target. */
	CHECK(c.eye[1] > 5.0f);
	for (int k = 0; k < 400; k++) {
		bc_viewer_orbit(&c, 0.0f, -41.0f);
		CHECK(bc_camera_validate(&c, NULL) == 0);
	}
	CHECK(c.eye[1] < -5.0f);
}

/* Panning moves eye and target together so that a point at the target's
 * depth follows the mouse exactly. */
static void test_pan_follows_the_mouse(void)
{
	for (int n = 0; n < 50; n++) {
		struct bc_camera c, old;
		float dx = frand(-200.0f, 200.0f), dy = frand(-200.0f, 200.0f);
		float out[3], eye_shift[3], target_shift[3];
		random_camera(&c);
		old = c;
		bc_viewer_pan(&c, dx, dy, 480);
		REQUIRE(bc_viewer_project(&c, 640, 480, old.target, out));
		CHECK_NEAR(out[0], 320.0 + dx, 0.05);
		CHECK_NEAR(out[1], 240.0 + dy, 0.05);
		for (int i = 0; i < 3; i++) {
			eye_shift[i] = c.eye[i] - old.eye[i];
			target_shift[i] = c.target[i] - old.target[i];
		}
		CHECK_NEAR(dist3(eye_shift, target_shift), 0.0, 1e-4);
	}
}

static void test_zoom_scales_the_distance(void)
{
	struct bc_camera c;
	bc_camera_default(&c);
	bc_viewer_zoom(&c, 1.0f);
	CHECK_NEAR(dist3(c.eye, c.target), 6.0 * exp(0.1), 1e-4);
	bc_viewer_zoom(&c, -2.0f);
	CHECK_NEAR(dist3(c.eye, c.target), 6.0 * exp(-0.1), 1e-4);
	for (int k = 0; k < 1000; k++) {
		bc_viewer_zoom(&c, -5.0f);
	}
	CHECK_NEAR(dist3(c.eye, c.target), BC_VIEWER_ZOOM_MIN, 1e-5);
	CHECK(bc_camera_validate(&c, NULL) == 0);
	for (int k = 0; k < 1000; k++) {
		bc_viewer_zoom(&c, 5.0f);
	}
	CHECK_NEAR(dist3(c.eye, c.target), BC_VIEWER_ZOOM_MAX, 1.0);
	bc_viewer_cam_clamp(&c);
	for (int i = 0; i < 3; i++) {
		CHECK(fabsf(c.eye[i]) <= 1.0e6f);
	}
}

/* A point moved in the view plane by (dx, dy) pixels projects (dx, dy)
 * pixels away, at the same depth. */
static void test_move_in_plane_tracks_pixels(void)
{
	for (int n = 0; n < 100; n++) {
		struct bc_camera c;
		float p[3], a[3], b[3], q[3];
		float dx = frand(-300.0f, 300.0f), dy = frand(-300.0f, 300.0f);
		random_camera(&c);
		for (int i = 0; i < 3; i++) {
			p[i] = c.target[i] + frand(-0.5f, 0.5f);
		}
		REQUIRE(bc_viewer_project(&c, 800, 600, p, a));
		bc_viewer_move_in_plane(&c, 600, p, a[2], dx, dy, q);
		REQUIRE(bc_viewer_project(&c, 800, 600, q, b));
		CHECK_NEAR(b[0] - a[0], dx, 0.05);
		CHECK_NEAR(b[1] - a[1], dy, 0.05);
		CHECK_NEAR(b[2], a[2], 1e-3 * a[2]);
	}
}

/* Every point inside a primitive (its field negative) lies in the box the
 * highlight draws, for every kind, rotated and moved. */
static void test_box_contains_every_primitive(void)
{
	for (int kind = 1; kind < BC_PRIM_COUNT; kind++) {
		struct bc_prim_data p;
		float packed[BC_PRIM_PACKED], corners[8][3], e[3][3];
		float len2[3], q[4], n = 0.0f;
		int inside = 0;
		bc_prim_data_init(&p, (enum bc_prim)kind);
		for (int i = 0; i < 4; i++) {
			q[i] = frand(-1.0f, 1.0f);
			n += q[i] * q[i];
		}
		for (int i = 0; i < 4; i++) {
			p.rotate[i] = q[i] / sqrtf(n);
		}
		for (int i = 0; i < 3; i++) {
			p.translate[i] = frand(-3.0f, 3.0f);
		}
		REQUIRE(bc_prim_validate(&p, NULL) == 0);
		bc_prim_pack(&p, packed);
		bc_viewer_box_corners(&p, corners);
		for (int a = 0; a < 3; a++) {
			int c = 1 << a;
			for (int i = 0; i < 3; i++) {
				e[a][i] = corners[c][i] - corners[0][i];
			}
			len2[a] = dot3(e[a], e[a]);
			REQUIRE(len2[a] > 0.0f);
		}
		for (int s = 0; s < 4000; s++) {
			float l[3], w[3], d[3], t[3], u[3];
			for (int i = 0; i < 3; i++) {
				l[i] = frand(-2.5f, 2.5f);
			}
			if (!(bc_prim_sdf((enum bc_prim)kind, packed, l[0],
			                  l[1], l[2]) < 0.0f)) {
				continue;
			}
			inside++;
			/* World point: R l + t (the quaternion by hand). */
			{
				const float *r = p.rotate;
				float cx[3] = {r[1] * l[2] - r[2] * l[1],
				               r[2] * l[0] - r[0] * l[2],
				               r[0] * l[1] - r[1] * l[0]};
				for (int i = 0; i < 3; i++) {
					t[i] = 2.0f * cx[i];
				}
				float ct[3] = {r[1] * t[2] - r[2] * t[1],
				               r[2] * t[0] - r[0] * t[2],
				               r[0] * t[1] - r[1] * t[0]};
				for (int i = 0; i < 3; i++) {
					w[i] = l[i] + r[3] * t[i] + ct[i] +
					       p.translate[i];
				}
			}
			for (int i = 0; i < 3; i++) {
				d[i] = w[i] - corners[0][i];
			}
			for (int a = 0; a < 3; a++) {
				u[a] = dot3(d, e[a]) / len2[a];
				CHECK(u[a] >= -1e-3f && u[a] <= 1.0f + 1e-3f);
			}
		}
		CHECK(inside > 0);
	}
}

/* The box of a box is the box itself. */
static void test_box_of_a_box_is_tight(void)
{
	struct bc_prim_data p;
	float corners[8][3];
	bc_prim_data_init(&p, BC_PRIM_BOX);
	p.params[0] = 0.5f;
	p.params[1] = 1.0f;
	p.params[2] = 1.5f;
	p.translate[0] = 2.0f;
	bc_viewer_box_corners(&p, corners);
	CHECK_NEAR(corners[0][0], 1.5, 1e-6);
	CHECK_NEAR(corners[0][1], -1.0, 1e-6);
	CHECK_NEAR(corners[0][2], -1.5, 1e-6);
	CHECK_NEAR(corners[7][0], 2.5, 1e-6);
	CHECK_NEAR(corners[7][1], 1.0, 1e-6);
	CHECK_NEAR(corners[7][2], 1.5, 1e-6);
	for (int e = 0; e < 12; e++) {
		int a = bc_viewer_box_edges[e][0],
		    b = bc_viewer_box_edges[e][1];
		int diff = a ^ b;
		/* Each edge joins corners differing in exactly one axis. */
		CHECK(diff == 1 || diff == 2 || diff == 4);
	}
}

static void test_size_parameter_of_every_kind(void)
{
	const struct bc_prim_info *info;
	CHECK_EQ_INT(bc_viewer_size_param(BC_PRIM_SPHERE), 0);
	CHECK_EQ_INT(bc_viewer_size_param(BC_PRIM_BOX), 0);
	info = bc_prim_info(BC_PRIM_CAPSULE);
	REQUIRE(info);
	CHECK(strcmp(info->params[bc_viewer_size_param(BC_PRIM_CAPSULE)].name,
	             "radius") == 0);
	info = bc_prim_info(BC_PRIM_ROUND_CONE);
	REQUIRE(info);
	CHECK(
	    strcmp(info->params[bc_viewer_size_param(BC_PRIM_ROUND_CONE)].name,
	           "radius_a") == 0);
	CHECK_EQ_INT(bc_viewer_size_param(BC_PRIM_INVALID), -1);
	CHECK_EQ_INT(bc_viewer_size_param(BC_PRIM_COUNT), -1);
	for (int kind = 1; kind < BC_PRIM_COUNT; kind++) {
		int k = bc_viewer_size_param((enum bc_prim)kind);
		info = bc_prim_info((enum bc_prim)kind);
		REQUIRE(info && k >= 0 && k < (int)info->nparams);
		CHECK(info->params[k].flags &
		      (BC_PARAM_POSITIVE | BC_PARAM_NONNEG));
	}
}

/* ---- unary nodes (Alt+wheel) --------------------------------------------- */

/* Every unary kind has its rule: signed values step, sizes scale, mirror
 * has nothing to change; binary operators are not unary. */
static void test_unary_param_of_every_kind(void)
{
	static const struct {
		enum bc_op kind;
		enum bc_viewer_notch rule;
		uint8_t count;
		const char *name;
	} want[] = {
	    {BC_OP_OFFSET, BC_VIEWER_NOTCH_ADD, 1, "amount"},
	    {BC_OP_ONION, BC_VIEWER_NOTCH_SCALE, 1, "thickness"},
	    {BC_OP_ELONGATE, BC_VIEWER_NOTCH_SCALE, 3, "half_extents"},
	    {BC_OP_TWIST, BC_VIEWER_NOTCH_ADD, 1, "rate"},
	    {BC_OP_BEND, BC_VIEWER_NOTCH_ADD, 1, "rate"},
	    {BC_OP_REPEAT, BC_VIEWER_NOTCH_SCALE, 3, "spacing"},
	    {BC_OP_SCALE, BC_VIEWER_NOTCH_SCALE, 1, "factor"},
	};
	struct bc_viewer_unary_param p;
	for (size_t i = 0; i < sizeof(want) / sizeof(want[0]); i++) {
		REQUIRE(bc_viewer_unary_param(want[i].kind, &p));
		CHECK_EQ_INT(p.rule, want[i].rule);
		CHECK_EQ_INT(p.count, want[i].count);
		CHECK_STREQ(p.name, want[i].name);
		CHECK(p.rule != BC_VIEWER_NOTCH_SCALE || p.lo > 0.0f);
	}
	CHECK(bc_viewer_unary_param(BC_OP_SCALE, &p) && p.lo == 1e-3f);
	CHECK(!bc_viewer_unary_param(BC_OP_MIRROR, &p));
	CHECK(p.rule == BC_VIEWER_NOTCH_NONE && p.count == 0);
	for (int k = 0; k <= BC_OP_SMOOTH_DIFFERENCE; k++) {
		CHECK(!bc_viewer_unary_param((enum bc_op)k, &p));
	}
	CHECK(!bc_viewer_unary_param(BC_OP_COUNT, &p));
}

/* What one notch gives, kind by kind, with an extent of 3. */
static void test_unary_notch_values(void)
{
	const float ext = 3.0f, up = expf(0.1f);
	float v[BC_UNARY_MAX_PARAMS];

	/* Offset: 0.02 extent a notch, either sign, across 0. */
	v[0] = 0.1f;
	bc_viewer_unary_notch(BC_OP_OFFSET, v, 2.0f, ext);
	CHECK_NEAR(v[0], 0.1f + 2.0f * 0.06f, 1e-6);
	bc_viewer_unary_notch(BC_OP_OFFSET, v, -5.0f, ext);
	CHECK_NEAR(v[0], 0.1f - 3.0f * 0.06f, 1e-6);
	CHECK(v[0] < 0.0f);

	/* Twist and bend: 0.3 radians over the extent a notch, signed. */
	for (int k = 0; k < 2; k++) {
		enum bc_op kind = k ? BC_OP_BEND : BC_OP_TWIST;
		v[0] = 1.0f;
		bc_viewer_unary_notch(kind, v, 3.0f, ext);
		CHECK_NEAR(v[0], 1.0f + 3.0f * 0.1f, 1e-6);
		bc_viewer_unary_notch(kind, v, -20.0f, ext);
		CHECK_NEAR(v[0], 1.3f - 2.0f, 1e-5);
		/* A larger shape turns as much over its length with a
		 * smaller rate step. */
		v[0] = 0.0f;
		bc_viewer_unary_notch(kind, v, 1.0f, 30.0f);
		CHECK_NEAR(v[0], 0.01f, 1e-7);
	}

	/* Onion: scales; 0 starts at 0.01 extent going up, stays going
	 * down. */
	v[0] = 0.05f;
	bc_viewer_unary_notch(BC_OP_ONION, v, 2.0f, ext);
	CHECK_NEAR(v[0], 0.05f * up * up, 1e-6);
	bc_viewer_unary_notch(BC_OP_ONION, v, -2.0f, ext);
	CHECK_NEAR(v[0], 0.05f, 1e-6);
	v[0] = 0.0f;
	bc_viewer_unary_notch(BC_OP_ONION, v, -1.0f, ext);
	CHECK(v[0] == 0.0f);
	bc_viewer_unary_notch(BC_OP_ONION, v, 1.0f, ext);
	CHECK_NEAR(v[0], 0.03f, 1e-7);

	/* Elongate: every component scales, a 0 axis stays 0. */
	v[0] = 0.5f;
	v[1] = 0.0f;
	v[2] = 0.2f;
	bc_viewer_unary_notch(BC_OP_ELONGATE, v, 1.0f, ext);
	CHECK_NEAR(v[0], 0.5f * up, 1e-6);
	CHECK(v[1] == 0.0f);
	CHECK_NEAR(v[2], 0.2f * up, 1e-6);

	/* Repeat: the spacing scales, the counts after it are not
	 * touched. */
	v[0] = 2.0f;
	v[1] = 1.5f;
	v[2] = 0.0f;
	v[3] = 3.0f;
	v[4] = 2.0f;
	v[5] = 1.0f;
	bc_viewer_unary_notch(BC_OP_REPEAT, v, -1.0f, ext);
	CHECK_NEAR(v[0], 2.0f / up, 1e-6);
	CHECK_NEAR(v[1], 1.5f / up, 1e-6);
	CHECK(v[2] == 0.0f);
	CHECK(v[3] == 3.0f && v[4] == 2.0f && v[5] == 1.0f);

	/* Scale: scales, never below 1e-3 nor above the parameter limit. */
	v[0] = 1.0f;
	bc_viewer_unary_notch(BC_OP_SCALE, v, 1.0f, ext);
	CHECK_NEAR(v[0], up, 1e-6);
	bc_viewer_unary_notch(BC_OP_SCALE, v, -500.0f, ext);
	CHECK(v[0] == 1e-3f);
	bc_viewer_unary_notch(BC_OP_SCALE, v, 5000.0f, ext);
	CHECK(v[0] == BC_PARAM_MAX_ABS);

	/* Mirror: nothing to change. */
	v[0] = 5.0f;
	bc_viewer_unary_notch(BC_OP_MIRROR, v, 3.0f, ext);
	CHECK(v[0] == 5.0f);
}

/* Whatever the notches, a node that was valid stays valid: the rules keep
 * blobtree's bounds (onion and elongate >= 0, repeat spacing > 0 where it
 * repeats, scale >= 1e-3, |values| <= BC_PARAM_MAX_ABS). */
static void test_unary_notch_keeps_bounds(void)
{
	for (int kind = BC_OP_FIRST_UNARY; kind < BC_OP_COUNT; kind++) {
		bool bad = false;
		/* One report per kind is enough. */
		for (int n = 0; n < 50 && !bad; n++) {
			struct bc_unary u;
			float ext = expf(frand(-6.0f, 10.0f));
			bc_unary_init(&u, (enum bc_op)kind);
			for (int step = 0; step < 40 && !bad; step++) {
				struct bc_errinfo ei = {0};
				/* Big runs reach the limits; small ones
				 * wander. */
				float notches = frand(-1.0f, 1.0f) *
				                (n % 2 ? 400.0f : 4.0f);
				bc_viewer_unary_notch(u.kind, u.u, notches,
				                      ext);
				if (bc_unary_validate(&u, &ei) != 0) {
					fprintf(stderr,
					        "kind %d after %g: %s\n", kind,
					        (double)notches, ei.msg);
					CHECK(0);
					bad = true;
				}
			}
		}
	}
}

/* A tree of unary nodes for the target and extent tests:
 *   smooth_union 1
 *     sphere 2
 *     twist 5 (rate 0.5) > mirror 6 (x) > box 4
 *     offset 7 > union 8 { sphere 9, scale 11 (2) > onion 12 > sphere 13 }
 *     mirror 14 > sphere 15
 */
static struct bc_tree *unary_tree(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data su = {BC_OP_SMOOTH_UNION, 0.3f, 0.4f};
	struct bc_op_data un = {BC_OP_UNION, 0.0f, 0.0f};
	struct bc_prim_data sphere, box;
	struct bc_unary tw, mi, off, sc, on;
	int rc = 0;
	if (!t) {
		return NULL;
	}
	bc_prim_data_init(&sphere, BC_PRIM_SPHERE);
	bc_prim_data_init(&box, BC_PRIM_BOX);
	bc_unary_init(&tw, BC_OP_TWIST);
	tw.u[0] = 0.5f;
	bc_unary_init(&mi, BC_OP_MIRROR);
	bc_unary_init(&off, BC_OP_OFFSET);
	bc_unary_init(&sc, BC_OP_SCALE);
	sc.u[0] = 2.0f;
	bc_unary_init(&on, BC_OP_ONION);
	rc |= bc_tree_begin(t);
	rc |= bc_tree_push_op(t, 1, &su, NULL);
	rc |= bc_tree_put_prim(t, 2, &sphere, NULL);
	rc |= bc_tree_push_unary(t, 5, &tw, NULL);
	rc |= bc_tree_push_unary(t, 6, &mi, NULL);
	rc |= bc_tree_put_prim(t, 4, &box, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_push_unary(t, 7, &off, NULL);
	rc |= bc_tree_push_op(t, 8, &un, NULL);
	rc |= bc_tree_put_prim(t, 9, &sphere, NULL);
	rc |= bc_tree_push_unary(t, 11, &sc, NULL);
	rc |= bc_tree_push_unary(t, 12, &on, NULL);
	rc |= bc_tree_put_prim(t, 13, &sphere, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_push_unary(t, 14, &mi, NULL);
	rc |= bc_tree_put_prim(t, 15, &sphere, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_pop_op(t, NULL);
	rc |= bc_tree_end(t, NULL);
	if (rc) {
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

/* The innermost unary ancestor with a value: mirrors passed over, binary
 * operators climbed through, none above a plain operand. */
static void test_unary_target_skips_mirror(void)
{
	struct bc_tree *t = unary_tree();
	struct bc_unary u;
	REQUIRE(t);
	CHECK_EQ_INT(bc_viewer_unary_target(t, 4, &u), 5);
	CHECK(u.kind == BC_OP_TWIST && u.u[0] == 0.5f);
	CHECK_EQ_INT(bc_viewer_unary_target(t, 13, &u), 12);
	CHECK(u.kind == BC_OP_ONION);
	CHECK_EQ_INT(bc_viewer_unary_target(t, 9, &u), 7);
	CHECK(u.kind == BC_OP_OFFSET);
	/* Only a mirror above, or nothing: no target, u zeroed. */
	CHECK_EQ_INT(bc_viewer_unary_target(t, 15, &u), 0);
	CHECK(u.kind == BC_OP_INVALID && u.u[0] == 0.0f);
	CHECK_EQ_INT(bc_viewer_unary_target(t, 2, &u), 0);
	CHECK_EQ_INT(bc_viewer_unary_target(t, 1, &u), 0);
	CHECK_EQ_INT(bc_viewer_unary_target(t, 999, &u), 0);
	CHECK_EQ_INT(bc_viewer_unary_target(NULL, 4, &u), 0);
	bc_tree_destroy(t);
}

/* The extent is the wrapped shape's box diagonal in the node's own units
 * (its primitives' ABVs: their bounds grown by the blend's reach, r+ 0.4
 * here, then mapped out through the domain nodes), and a scale node above
 * does not change it. */
static void test_unary_extent_in_node_units(void)
{
	struct bc_tree *t = unary_tree();
	float twist, onion, offset;
	REQUIRE(t);
	/* Twist 5 wraps a box of half extents 1 (1.4 grown), mapped to a
	 * cylinder about y of radius 1.4 sqrt 2: diagonal 6.26. */
	twist = bc_viewer_unary_extent(t, 5);
	CHECK(twist > 2.0f * sqrtf(5.0f) && twist < 7.0f);
	/* Offset 7 wraps a unit sphere and another drawn twice as large by
	 * scale 11, whose box holds the first. */
	offset = bc_viewer_unary_extent(t, 7);
	CHECK(offset > 4.0f * sqrtf(3.0f) && offset < 10.5f);
	/* Onion 12 wraps only that large sphere, but in its own units,
	 * inside scale 11, the sphere is half as large. */
	onion = bc_viewer_unary_extent(t, 12);
	CHECK_NEAR(onion, offset / 2.0f, 1e-3 * offset);
	/* Not a unary node, or no tree: a unit extent. */
	CHECK(bc_viewer_unary_extent(t, 1) == 1.0f);
	CHECK(bc_viewer_unary_extent(NULL, 5) == 1.0f);
	bc_tree_destroy(t);
}

/* A node's box holds the ABVs of the primitives below it; a unary node's
 * is its child's; the root's is the whole scene's, the linearized form's
 * own box. The viewer's mirror is bare (no layout): every node's box of
 * a bare copy is the laid-out tree's. */
static void test_node_box_holds_the_subtree(void)
{
	struct bc_tree *t = unary_tree(), *bare = bc_tree_create();
	const struct bc_lin *l;
	float lo[3], hi[3], clo[3], chi[3];
	REQUIRE(t && bare && bc_tree_set_layout(bare, false) == 0);
	REQUIRE(bc_tree_copy(bare, t, NULL) == 0 && !bc_tree_lin(bare));
	for (uint32_t id = 1; id <= bc_tree_node_count(t); id++) {
		bool got = bc_viewer_node_box(t, id, lo, hi);
		CHECK(bc_viewer_node_box(bare, id, clo, chi) == got);
		CHECK(!got || (memcmp(lo, clo, sizeof(lo)) == 0 &&
		               memcmp(hi, chi, sizeof(hi)) == 0));
	}
	bc_tree_destroy(bare);
	l = bc_tree_lin(t);
	REQUIRE(l);
	REQUIRE(bc_viewer_node_box(t, 1, lo, hi));
	for (int i = 0; i < 3; i++) {
		CHECK_NEAR(lo[i], l->lo[i], 1e-5);
		CHECK_NEAR(hi[i], l->hi[i], 1e-5);
	}
	/* The twist's box is its mirror's, which is the box's ABV. */
	REQUIRE(bc_viewer_node_box(t, 5, lo, hi));
	REQUIRE(bc_viewer_node_box(t, 4, clo, chi));
	CHECK_MEMEQ(lo, clo, sizeof(lo));
	CHECK_MEMEQ(hi, chi, sizeof(hi));
	/* The union 8 holds both of its spheres' boxes. */
	REQUIRE(bc_viewer_node_box(t, 8, lo, hi));
	REQUIRE(bc_viewer_node_box(t, 13, clo, chi));
	for (int i = 0; i < 3; i++) {
		CHECK(lo[i] <= clo[i] && hi[i] >= chi[i]);
	}
	CHECK(!bc_viewer_node_box(t, 999, lo, hi));
	CHECK(!bc_viewer_node_box(NULL, 1, lo, hi));
	bc_tree_destroy(t);
}

/* Zoom to fit from far away and from too close: the box's corners all
 * project inside the view, the camera's direction and up are kept, and
 * the box's sphere spans most of the view's narrower side. */
static void test_frame_box_fits_the_view(void)
{
	const float lo[3] = {-3.0f, -1.0f, -0.5f}, hi[3] = {1.0f, 2.0f, 0.5f};
	const float dists[2] = {200.0f, 0.2f};
	const uint32_t sizes[2][2] = {{320, 240}, {200, 400}};
	for (int d = 0; d < 2; d++) {
		for (int s = 0; s < 2; s++) {
			struct bc_camera c;
			float dir0[3], dir1[3], c0[3], n0, n1,
			    xmin = 1e9f, xmax = -1e9f, ymin = 1e9f,
			    ymax = -1e9f;
			uint32_t w = sizes[s][0], h = sizes[s][1];
			bc_camera_default(&c);
			c.eye[0] = dists[d] * 0.6f;
			c.eye[2] = dists[d] * 0.8f;
			for (int i = 0; i < 3; i++) {
				dir0[i] = c.eye[i] - c.target[i];
			}
			n0 = sqrtf(dot3(dir0, dir0));
			bc_viewer_frame_box(&c, lo, hi, (float)w / (float)h);
			for (int i = 0; i < 3; i++) {
				dir1[i] = c.eye[i] - c.target[i];
				CHECK_NEAR(c.target[i], 0.5f * (lo[i] + hi[i]),
				           1e-5);
			}
			n1 = sqrtf(dot3(dir1, dir1));
			for (int i = 0; i < 3; i++) {
				CHECK_NEAR(dir1[i] / n1, dir0[i] / n0, 1e-5);
			}
			CHECK(c.up[1] == 1.0f && c.fov_y_deg == 45.0f);
			for (int k = 0; k < 8; k++) {
				float p[3], px[3];
				for (int i = 0; i < 3; i++) {
					p[i] = ((k >> i) & 1) ? hi[i] : lo[i];
				}
				REQUIRE(bc_viewer_project(&c, w, h, p, px));
				CHECK(px[0] >= 0.0f && px[0] <= (float)w);
				CHECK(px[1] >= 0.0f && px[1] <= (float)h);
				xmin = fminf(xmin, px[0]);
				xmax = fmaxf(xmax, px[0]);
				ymin = fminf(ymin, px[1]);
				ymax = fmaxf(ymax, px[1]);
			}
			/* The sphere around the box is larger than the
			 * box: its corners span at least half the narrower
			 * side. */
			CHECK(fmaxf(xmax - xmin, ymax - ymin) >
			      0.5f * (float)(w < h ? w : h));
			memcpy(c0, c.eye, sizeof(c0));
			/* Fitting again changes nothing. */
			bc_viewer_frame_box(&c, lo, hi, (float)w / (float)h);
			for (int i = 0; i < 3; i++) {
				CHECK_NEAR(c.eye[i], c0[i], 1e-3);
			}
		}
	}
}

/* Counts the lines of text (the panel's). */
static uint32_t text_lines(const char *text)
{
	uint32_t n = 1;
	for (const char *c = text; *c; c++) {
		n += *c == '\n';
	}
	return n;
}

/* The sessions panel keeps a SESSIONS answer, puts the cursor on the
 * window's own session, moves it round, and says each session as the
 * page does: members, shapes, order and age of a loaded one, "on disk,
 * not loaded yet" for another, "(this window)" for its own; the scene
 * memory STATS told; at most BC_VIEWER_SESSIONS_ROWS rows around the
 * cursor; and of an answer longer than it keeps, how many it shows. */
static void test_sessions_panel_lists_and_chooses(void)
{
	static struct bc_viewer_sessions s;
	static struct bc_proto_session_entry e[300];
	static char names[300][16];
	char text[2048];
	const uint64_t now = 1800000000000ull;
	struct bc_msg_stats st = {0};
	struct bc_msg_sessions m = {.nsessions = 3, .sessions = e};
	char long_name[BC_PROTO_MAX_NAME + 1];
	memset(long_name, 'n', BC_PROTO_MAX_NAME);
	long_name[BC_PROTO_MAX_NAME] = '\0';
	memset(&s, 0, sizeof(s));
	bc_viewer_sessions_text(&s, "beta", now, text, sizeof(text));
	CHECK(strstr(text, "no list came") != NULL);
	s.asked = 7;
	bc_viewer_sessions_text(&s, "beta", now, text, sizeof(text));
	CHECK(strstr(text, "asking the daemon") != NULL);
	CHECK(bc_viewer_sessions_chosen(&s) == NULL);
	bc_viewer_sessions_move(&s, 1); /* nothing listed: nothing moves */
	CHECK_EQ_INT(s.cur, 0);

	e[0] = (struct bc_proto_session_entry){
	    .name = {"alpha", 5},
	    .members = 2,
	    .prims = 1024000,
	    .order = 17,
	    .last_edit_ms = now - 3u * 60u * 1000u - 5u,
	    .flags = BC_PROTO_SESSION_LOADED | BC_PROTO_SESSION_KNOWN};
	e[1] =
	    (struct bc_proto_session_entry){.name = {"beta", 4}, .members = 1};
	e[2] = (struct bc_proto_session_entry){
	    .name = {long_name, BC_PROTO_MAX_NAME},
	    .members = 0,
	    .prims = 1,
	    .order = 0,
	    .last_edit_ms = now - 12000u,
	    .flags = BC_PROTO_SESSION_LOADED | BC_PROTO_SESSION_KNOWN};
	bc_viewer_sessions_take(&s, &m, "beta");
	CHECK_EQ_INT(s.n, 3);
	CHECK_EQ_INT(s.cur, 1);
	CHECK_STREQ(bc_viewer_sessions_chosen(&s), "beta");
	CHECK_STREQ(s.row[2].name, long_name);
	st.has_memory = true;
	st.memory.scene_nodes = 100001;
	st.memory.scene_nodes_cap = 149796;
	bc_viewer_sessions_stats(&s, &st);
	bc_viewer_sessions_text(&s, "beta", now, text, sizeof(text));
	CHECK(strstr(text, "3 sessions on this daemon  scene memory 100,001 "
	                   "of 149,796 nodes (67 %)") != NULL);
	CHECK(strstr(text, "\n  alpha  2 members  1,024,000 shapes  order 17  "
	                   "changed 3 min ago\n") != NULL);
	CHECK(strstr(text, "\n> beta  1 member  on disk, not loaded yet  "
	                   "(this window)\n") != NULL);
	CHECK(strstr(text, "1 shape  order 0  changed 12 s ago") != NULL);
	CHECK(strstr(text, long_name) != NULL);
	CHECK_EQ_INT(text_lines(text), 5);
	/* A STATS without the memory section keeps what the last said. */
	st.has_memory = false;
	bc_viewer_sessions_stats(&s, &st);
	CHECK(s.has_memory && s.memory.scene_nodes == 100001);

	bc_viewer_sessions_move(&s, 1);
	CHECK_STREQ(bc_viewer_sessions_chosen(&s), long_name);
	bc_viewer_sessions_move(&s, 1);
	CHECK_STREQ(bc_viewer_sessions_chosen(&s), "alpha");
	bc_viewer_sessions_move(&s, -1);
	CHECK_STREQ(bc_viewer_sessions_chosen(&s), long_name);
	/* A name with a line break and a byte past ASCII: shown as '?'. */
	e[1].name = (struct bc_proto_str){"be\nt\xc3", 5};
	bc_viewer_sessions_take(&s, &m, "beta");
	CHECK_STREQ(s.row[1].name, "be?t?");
	bc_viewer_sessions_text(&s, NULL, now, text, sizeof(text));
	CHECK_EQ_INT(text_lines(text), 5);
	/* A session the answer does not name: the cursor on the first. */
	bc_viewer_sessions_take(&s, &m, "gone");
	CHECK_EQ_INT(s.cur, 0);

	/* 300 sessions: BC_VIEWER_SESSIONS_MAX kept, the rows around the
	 * cursor shown, the window full at the end. */
	for (uint32_t i = 0; i < 300; i++) {
		snprintf(names[i], sizeof(names[i]), "s%03u", i);
		e[i] = (struct bc_proto_session_entry){
		    .name = {names[i], (uint32_t)strlen(names[i])}};
	}
	m.nsessions = 300;
	bc_viewer_sessions_take(&s, &m, "s250");
	CHECK_EQ_INT(s.n, BC_VIEWER_SESSIONS_MAX);
	CHECK_EQ_INT(s.listed_n, 300);
	CHECK_EQ_INT(s.cur, 250);
	bc_viewer_sessions_text(&s, "s250", now, text, sizeof(text));
	CHECK(
	    strstr(text, "300 sessions on this daemon (the first 256 shown)") !=
	    NULL);
	CHECK_EQ_INT(text_lines(text), 2 + BC_VIEWER_SESSIONS_ROWS);
	/* The cursor in the middle: 246 .. 254. */
	CHECK(strstr(text, "\n> s250 ") != NULL);
	CHECK(strstr(text, "\n  s246 ") != NULL);
	CHECK(strstr(text, "\n  s254 ") != NULL);
	CHECK(strstr(text, "s245") == NULL && strstr(text, "s255") == NULL);
	/* Near the end the window stays full: 247 .. 255. */
	bc_viewer_sessions_move(&s, 3);
	bc_viewer_sessions_text(&s, "s250", now, text, sizeof(text));
	CHECK(strstr(text, "\n> s253 ") != NULL);
	CHECK(strstr(text, "\n  s247 ") != NULL);
	CHECK(strstr(text, "\n  s255 ") != NULL);
	CHECK(strstr(text, "s246") == NULL);
	CHECK_EQ_INT(text_lines(text), 2 + BC_VIEWER_SESSIONS_ROWS);
	bc_viewer_sessions_take(&s, &m, "s299"); /* not kept: the first */
	CHECK_EQ_INT(s.cur, 0);
	bc_viewer_sessions_text(&s, NULL, now, text, sizeof(text));
	CHECK(strstr(text, "\n> s000 ") != NULL);
	CHECK(strstr(text, "s008") != NULL && strstr(text, "s009") == NULL);
	/* A small buffer is cut, never overrun. */
	bc_viewer_sessions_text(&s, NULL, now, text, 40);
	CHECK_EQ_INT(strlen(text), 39);

	/* A first Delete marks the row; moving or a new list forgets it. */
	snprintf(s.doomed, sizeof(s.doomed), "%s", "s001");
	bc_viewer_sessions_text(&s, NULL, now, text, sizeof(text));
	CHECK(strstr(text, "s001  0 members  on disk, not loaded yet  - "
	                   "Delete again deletes it for everyone") != NULL);
	bc_viewer_sessions_move(&s, 1);
	CHECK(s.doomed[0] == '\0');
	snprintf(s.doomed, sizeof(s.doomed), "%s", "s001");
	s.delete_seq = 9; /* on its way: kept for the answer's words */
	bc_viewer_sessions_move(&s, 1);
	bc_viewer_sessions_take(&s, &m, NULL);
	CHECK_STREQ(s.doomed, "s001");
	s.delete_seq = 0;
	bc_viewer_sessions_take(&s, &m, NULL);
	CHECK(s.doomed[0] == '\0');
}

/* N: a new session's name takes the protocol's characters only, never
 * a '.' first, at most BC_PROTO_MAX_NAME bytes; Backspace takes one off;
 * the panel shows the entry while it is open. */
/* The history panel: rows as `blobcast history` words them, text
 * outside printable ASCII made safe, scrolling held within the list. */
static void test_history_panel_rows(void)
{
	static struct bc_viewer_history h;
	static struct bc_proto_history_entry e[BC_PROTO_MAX_HISTORY];
	char text[4096], line[64];
	/* 2027-01-15 08:00:00 UTC. */
	const uint64_t now = 1800000000000ull;
	struct bc_msg_history m = {.order = 42, .nentries = 3, .entries = e};
	char long_what[BC_PROTO_MAX_HISTORY_TEXT + 1];
	memset(long_what, 'w', BC_PROTO_MAX_HISTORY_TEXT);
	long_what[BC_PROTO_MAX_HISTORY_TEXT] = '\0';
	memset(&h, 0, sizeof(h));
	bc_viewer_history_text(&h, now, text, sizeof(text));
	CHECK(strstr(text, "no history came") != NULL);
	h.asked = 3;
	bc_viewer_history_text(&h, now, text, sizeof(text));
	CHECK(strstr(text, "asking the daemon") != NULL);

	e[0] = (struct bc_proto_history_entry){
	    .order = 42,
	    .time_ms = now - 5000u,
	    .state = BC_PROTO_HISTORY_APPLIED,
	    .flags = BC_PROTO_HISTORY_YOURS | BC_PROTO_HISTORY_NEXT,
	    .author = {"alice", 5},
	    .what = {"SET node 12 translate", 21}};
	e[1] = (struct bc_proto_history_entry){
	    .order = 40,
	    .time_ms = now - 2u * 86400000u,
	    .built_on = 42,
	    .state = BC_PROTO_HISTORY_UNDONE,
	    .author = {"b\x01"
	               "b\xc3\xa9",
	               5},
	    .what = {long_what, BC_PROTO_MAX_HISTORY_TEXT}};
	e[2] = (struct bc_proto_history_entry){
	    .order = 7,
	    .state = BC_PROTO_HISTORY_UNDONE,
	    .flags = BC_PROTO_HISTORY_YOURS | BC_PROTO_HISTORY_NEXT,
	    .author = {"alice", 5},
	    .what = {"INSERT under node 1", 19}};
	bc_viewer_history_take(&h, &m);
	CHECK_EQ_INT(h.n, 3);
	CHECK(h.listed);
	CHECK_STREQ(h.row[1].author, "b?b??");
	CHECK_EQ_INT(strlen(h.row[1].what), BC_PROTO_MAX_HISTORY_TEXT);
	bc_viewer_history_text(&h, now, text, sizeof(text));
	CHECK(strstr(text, "3 changes undo and redo can take, newest first; "
	                   "the session is at edit order 42") != NULL);
	CHECK(strstr(text, "    42  07:59:55  applied  alice (you)  SET node "
	                   "12 translate  <- your undo\n") != NULL);
	CHECK(strstr(text, "    40  2027-01-13 08:00:00  undone   b?b??  ") !=
	      NULL);
	CHECK(strstr(text, "  built on by 42\n") != NULL);
	CHECK(strstr(text, "     7  --:--:--  undone   alice (you)  INSERT "
	                   "under node 1  <- your redo") != NULL);
	/* The newest first, in the order the daemon listed them. */
	CHECK(strstr(text, "    42 ") < strstr(text, "    40 "));
	CHECK(strstr(text, "    40 ") < strstr(text, "     7 "));
	CHECK(strstr(text, "shown)") == NULL);

	/* A full list: rows from the first shown, scrolling held. */
	for (uint32_t i = 0; i < BC_PROTO_MAX_HISTORY; i++) {
		e[i] = (struct bc_proto_history_entry){
		    .order = 1000u - i,
		    .time_ms = now,
		    .author = {"carol", 5},
		    .what = {"SET node 3 radius", 17}};
	}
	m.nentries = BC_PROTO_MAX_HISTORY;
	bc_viewer_history_take(&h, &m);
	CHECK_EQ_INT(h.n, BC_PROTO_MAX_HISTORY);
	bc_viewer_history_scroll(&h, -1);
	CHECK_EQ_INT(h.top, 0);
	bc_viewer_history_scroll(&h, 5);
	CHECK_EQ_INT(h.top, 5);
	bc_viewer_history_text(&h, now, text, sizeof(text));
	CHECK(strstr(text, "(6-14 shown)") != NULL);
	CHECK(strstr(text, "   995  ") != NULL);
	CHECK(strstr(text, "   996  ") == NULL);
	snprintf(line, sizeof(line), "   %u  ",
	         995u - BC_VIEWER_HISTORY_ROWS + 1u);
	CHECK(strstr(text, line) != NULL);
	snprintf(line, sizeof(line), "   %u  ", 995u - BC_VIEWER_HISTORY_ROWS);
	CHECK(strstr(text, line) == NULL);
	bc_viewer_history_scroll(&h, 1000);
	CHECK_EQ_INT(h.top, BC_PROTO_MAX_HISTORY - BC_VIEWER_HISTORY_ROWS);
	bc_viewer_history_text(&h, now, text, sizeof(text));
	CHECK(strstr(text, "   801  ") != NULL); /* the oldest */
	/* A small buffer is cut, never overrun. */
	memset(text, 'x', sizeof(text));
	bc_viewer_history_text(&h, now, text, 40);
	CHECK_EQ_INT(strlen(text), 39);
	/* An answer taken again starts from the newest. */
	bc_viewer_history_take(&h, &m);
	CHECK_EQ_INT(h.top, 0);
}

static void test_sessions_panel_new_name(void)
{
	static struct bc_viewer_sessions s;
	char text[512];
	memset(&s, 0, sizeof(s));
	s.naming = true;
	CHECK(!bc_viewer_sessions_name_char(&s, '.'));
	CHECK(bc_viewer_sessions_name_char(&s, 'r'));
	CHECK(bc_viewer_sessions_name_char(&s, 'E'));
	CHECK(bc_viewer_sessions_name_char(&s, '-'));
	CHECK(bc_viewer_sessions_name_char(&s, '2'));
	CHECK(bc_viewer_sessions_name_char(&s, '.'));
	CHECK(bc_viewer_sessions_name_char(&s, '_'));
	CHECK(!bc_viewer_sessions_name_char(&s, ' '));
	CHECK(!bc_viewer_sessions_name_char(&s, '/'));
	CHECK(!bc_viewer_sessions_name_char(&s, 0xe9)); /* é */
	CHECK_STREQ(s.name, "rE-2._");
	bc_viewer_sessions_name_back(&s);
	CHECK_STREQ(s.name, "rE-2.");
	bc_viewer_sessions_text(&s, NULL, 0, text, sizeof(text));
	CHECK(strncmp(text, "New session: rE-2._\n", 20) == 0);
	while (s.name_len) {
		bc_viewer_sessions_name_back(&s);
	}
	bc_viewer_sessions_name_back(&s); /* nothing left: nothing happens */
	CHECK_EQ_INT(s.name_len, 0);
	for (uint32_t i = 0; i < BC_PROTO_MAX_NAME; i++) {
		CHECK(bc_viewer_sessions_name_char(&s, 'x'));
	}
	CHECK(!bc_viewer_sessions_name_char(&s, 'x'));
	CHECK_EQ_INT(strlen(s.name), BC_PROTO_MAX_NAME);
}

/* The palette lists every primitive, operator and unary kind once, by
 * its scene-file name; the cursor moves round, by section and by
 * initial; the panel marks the cursor's entry. */
static void test_palette_lists_every_kind(void)
{
	struct bc_viewer_palette p = {0};
	struct bc_viewer_pal_entry e;
	uint32_t n = bc_viewer_palette_count(),
	         counts[BC_VIEWER_PAL_COUNT] = {0};
	char text[1024];
	CHECK_EQ_INT(n, (BC_PRIM_COUNT - 1) + 6 + (BC_OP_COUNT - BC_OP_OFFSET));
	for (uint32_t i = 0; i < n; i++) {
		REQUIRE(bc_viewer_palette_entry(i, &e));
		counts[e.section]++;
		if (e.section == BC_VIEWER_PAL_SHAPE) {
			CHECK_STREQ(e.name,
			            bc_prim_info((enum bc_prim)e.kind)->name);
		} else {
			CHECK_STREQ(e.name, bc_op_name((enum bc_op)e.kind));
			CHECK(bc_op_is_unary((enum bc_op)e.kind) ==
			      (e.section == BC_VIEWER_PAL_UNARY));
		}
	}
	CHECK_EQ_INT(counts[BC_VIEWER_PAL_SHAPE], BC_PRIM_COUNT - 1);
	CHECK_EQ_INT(counts[BC_VIEWER_PAL_OPERATOR], 6);
	CHECK_EQ_INT(counts[BC_VIEWER_PAL_UNARY], BC_OP_COUNT - BC_OP_OFFSET);
	CHECK(!bc_viewer_palette_entry(n, &e) && e.name == NULL);

	bc_viewer_palette_open(&p, BC_VIEWER_PAL_SHAPE);
	CHECK(p.open && p.cur == 0);
	bc_viewer_palette_move(&p, -1);
	CHECK_EQ_INT(p.cur, n - 1);
	bc_viewer_palette_move(&p, 2);
	CHECK_EQ_INT(p.cur, 1);
	bc_viewer_palette_entry(p.cur, &e);
	CHECK_STREQ(e.name, "box");
	bc_viewer_palette_page(&p, 1);
	bc_viewer_palette_entry(p.cur, &e);
	CHECK(e.section == BC_VIEWER_PAL_OPERATOR && e.kind == BC_OP_UNION);
	bc_viewer_palette_page(&p, 1);
	bc_viewer_palette_entry(p.cur, &e);
	CHECK(e.section == BC_VIEWER_PAL_UNARY && e.kind == BC_OP_OFFSET);
	bc_viewer_palette_page(&p, 1);
	CHECK_EQ_INT(p.cur, 0);
	bc_viewer_palette_page(&p, -1);
	bc_viewer_palette_entry(p.cur, &e);
	CHECK(e.section == BC_VIEWER_PAL_UNARY);
	/* 't' from the unary section: twist, then round to torus. */
	CHECK(bc_viewer_palette_jump(&p, 'T'));
	bc_viewer_palette_entry(p.cur, &e);
	CHECK_STREQ(e.name, "twist");
	CHECK(bc_viewer_palette_jump(&p, 't'));
	bc_viewer_palette_entry(p.cur, &e);
	CHECK_STREQ(e.name, "torus");
	CHECK(!bc_viewer_palette_jump(&p, 'j'));
	CHECK_STREQ(e.name, "torus");
	bc_viewer_palette_text(&p, text, sizeof(text));
	CHECK(strstr(text, "> shape    torus") != NULL);
	CHECK(strstr(text, "  shape    cylinder") != NULL);
	/* At the ends the window stays full. */
	p.cur = n - 1;
	bc_viewer_palette_text(&p, text, sizeof(text));
	CHECK(strstr(text, "> wrap in  scale") != NULL);
	CHECK(strstr(text, "  wrap in  offset") != NULL);
	bc_viewer_palette_text(&p, text, 40);
	CHECK_EQ_INT(strlen(text), 39);
}

static void test_unary_text(void)
{
	struct bc_unary u;
	char line[64], small[8];
	bc_unary_init(&u, BC_OP_TWIST);
	u.u[0] = 1.3f;
	CHECK_STREQ(bc_viewer_unary_text(&u, line, sizeof(line)),
	            "twist rate 1.3");
	bc_unary_init(&u, BC_OP_REPEAT);
	CHECK_STREQ(bc_viewer_unary_text(&u, line, sizeof(line)),
	            "repeat spacing 2,2,2");
	bc_unary_init(&u, BC_OP_ELONGATE);
	CHECK_STREQ(bc_viewer_unary_text(&u, line, sizeof(line)),
	            "elongate half_extents 0.5,0,0");
	bc_unary_init(&u, BC_OP_MIRROR);
	u.u[0] = 5.0f;
	CHECK_STREQ(bc_viewer_unary_text(&u, line, sizeof(line)),
	            "mirror axes xz");
	bc_unary_init(&u, BC_OP_OFFSET);
	u.u[0] = -0.25f;
	CHECK_STREQ(bc_viewer_unary_text(&u, line, sizeof(line)),
	            "offset amount -0.25");
	/* Cut, never overrun. */
	CHECK(strlen(bc_viewer_unary_text(&u, small, sizeof(small))) ==
	      sizeof(small) - 1);
	u.kind = BC_OP_UNION;
	CHECK_STREQ(bc_viewer_unary_text(&u, line, sizeof(line)), "");
}

/* ---- meter --------------------------------------------------------------- */

static void test_meter_counts_the_last_second(void)
{
	struct bc_viewer_meter m;
	bc_viewer_meter_init(&m);
	CHECK_NEAR(bc_viewer_meter_fps(&m, 1000.0), 0.0, 0.0);
	CHECK_NEAR(bc_viewer_meter_kb(&m), 0.0, 0.0);
	CHECK(bc_viewer_meter_latency_avg(&m) < 0.0);
	for (int i = 0; i < 90; i++) {
		bc_viewer_meter_frame(&m, (uint32_t)(1000 * (i + 1)),
		                      1000.0 + 1000.0 * i / 30.0);
	}
	/* 30 frames per second: in the second before the last one, 30. */
	CHECK_NEAR(bc_viewer_meter_fps(&m, 1000.0 + 89000.0 / 30.0), 30.0, 1.0);
	/* A stalled stream reads 0 once a second has passed. */
	CHECK_NEAR(bc_viewer_meter_fps(&m, 10000.0), 0.0, 0.0);
	/* The last 30 frames were 61..90 kB: 75.5 on average. */
	CHECK_NEAR(bc_viewer_meter_kb(&m), 75.5, 1e-9);
	CHECK_EQ_INT(m.frames, 90);
	for (int i = 0; i < 60; i++) {
		bc_viewer_meter_latency(&m, (double)i);
	}
	CHECK_NEAR(m.last_latency, 59.0, 0.0);
	/* The last 50: 10..59. */
	CHECK_NEAR(bc_viewer_meter_latency_avg(&m), 34.5, 1e-9);
}

/* ---- edits --------------------------------------------------------------- */

static struct bc_viewer_edit move_edit(uint32_t node, float x, bool interacting)
{
	struct bc_viewer_edit e = {
	    .node = node, .nfields = 1, .interacting = interacting};
	e.fields[0].field = BC_PROTO_FIELD_TRANSLATE;
	e.fields[0].count = 3;
	e.fields[0].v[0] = x;
	return e;
}

/* Interacting edits go one at a time, the newest values replacing those
 * not sent; a final edit goes at once; latencies settle on the first frame
 * whose order reaches the edit's. */
static void test_edits_one_in_flight(void)
{
	struct bc_viewer_edits q;
	struct bc_viewer_meter m;
	struct bc_viewer_edit e;
	bc_viewer_edits_init(&q);
	bc_viewer_meter_init(&m);
	CHECK(!bc_viewer_edits_ready(&q));
	e = move_edit(5, 1.0f, true);
	bc_viewer_edits_queue(&q, &e);
	REQUIRE(bc_viewer_edits_ready(&q));
	bc_viewer_edits_sent(&q, 10, 100.0);
	CHECK_EQ_INT(q.inflight, 10);
	e = move_edit(5, 2.0f, true);
	bc_viewer_edits_queue(&q, &e);
	e = move_edit(5, 3.0f, true);
	bc_viewer_edits_queue(&q, &e);
	CHECK(!bc_viewer_edits_ready(&q));
	CHECK_NEAR(q.pending.fields[0].v[0], 3.0, 0.0);
	/* Someone else's order does not free the slot: only ours does. */
	CHECK(!bc_viewer_edits_applied(&q, 99, 6));
	CHECK(!bc_viewer_edits_ready(&q));
	CHECK(bc_viewer_edits_applied(&q, 10, 7));
	CHECK(bc_viewer_edits_ready(&q));
	bc_viewer_edits_sent(&q, 11, 130.0);
	/* A final edit does not wait for the one in flight. */
	e = move_edit(5, 4.0f, false);
	bc_viewer_edits_queue(&q, &e);
	CHECK(bc_viewer_edits_ready(&q));
	bc_viewer_edits_sent(&q, 12, 140.0);
	CHECK_EQ_INT(q.inflight, 11);
	CHECK(!bc_viewer_edits_ready(&q));
	/* A frame older than the edit settles nothing. */
	CHECK_EQ_INT(bc_viewer_edits_frame(&q, 6, 150.0, &m), 0);
	CHECK_EQ_INT(bc_viewer_edits_frame(&q, 7, 160.0, &m), 1);
	CHECK_NEAR(m.last_latency, 60.0, 1e-9);
	CHECK(bc_viewer_edits_applied(&q, 11, 8));
	CHECK(!bc_viewer_edits_applied(&q, 12, 9));
	CHECK_EQ_INT(q.inflight, 0);
	CHECK_EQ_INT(bc_viewer_edits_frame(&q, 9, 200.0, &m), 2);
	CHECK_NEAR(m.last_latency, 60.0, 1e-9); /* 200 - 140 */
	CHECK_NEAR(bc_viewer_meter_latency_avg(&m), (60.0 + 70.0 + 60.0) / 3,
	           1e-9);
	CHECK_EQ_INT(q.nsent, 0);
	CHECK_EQ_INT(q.nshown, 0);
}

/* A refused edit frees the slot and is never measured. */
/* A fresh queue and meter with an interacting edit in flight (seq 3, sent
 * at 0 ms) and the next one pending. */
static void one_in_flight(struct bc_viewer_edits *q, struct bc_viewer_meter *m)
{
	struct bc_viewer_edit e = move_edit(5, 1.0f, true);
	bc_viewer_edits_init(q);
	bc_viewer_meter_init(m);
	bc_viewer_edits_queue(q, &e);
	bc_viewer_edits_sent(q, 3, 0.0);
	bc_viewer_edits_queue(q, &e);
}

/* A modelling EDIT sent around the queue is matched to its answer and
 * its frame like the queue's own, and leaves a pending drag edit alone. */
static void test_edits_track_leaves_the_pending_edit(void)
{
	struct bc_viewer_edits q;
	struct bc_viewer_meter m;
	one_in_flight(&q, &m);
	bc_viewer_edits_track(&q, 4, 1.0);
	CHECK(q.has_pending && q.inflight == 3);
	CHECK(!bc_viewer_edits_applied(&q, 4, 7));
	CHECK(q.has_pending && !bc_viewer_edits_ready(&q));
	CHECK_EQ_INT(bc_viewer_edits_frame(&q, 7, 21.0, &m), 1);
	CHECK_NEAR(m.last_latency, 20.0, 1e-9);
	bc_viewer_edits_track(&q, 5, 2.0);
	CHECK(bc_viewer_edits_refused(&q, 5));
	CHECK(!bc_viewer_edits_refused(&q, 5));
}

static void test_edits_refused(void)
{
	struct bc_viewer_edits q;
	struct bc_viewer_meter m;
	one_in_flight(&q, &m);
	CHECK(!bc_viewer_edits_ready(&q));
	CHECK(!bc_viewer_edits_refused(&q, 4));
	CHECK(bc_viewer_edits_refused(&q, 3));
	CHECK(bc_viewer_edits_ready(&q));
	CHECK_EQ_INT(bc_viewer_edits_frame(&q, 100, 10.0, &m), 0);
	CHECK(bc_viewer_meter_latency_avg(&m) < 0.0);
}

/* Answers that never come do not grow anything. */
static void test_edits_bounded(void)
{
	struct bc_viewer_edits q;
	bc_viewer_edits_init(&q);
	for (uint32_t s = 1; s <= 3 * BC_VIEWER_EDITS_SENT; s++) {
		struct bc_viewer_edit e = move_edit(5, (float)s, false);
		bc_viewer_edits_queue(&q, &e);
		bc_viewer_edits_sent(&q, s, (double)s);
		CHECK(q.nsent <= BC_VIEWER_EDITS_SENT);
	}
	/* The oldest were forgotten, the newest kept. */
	CHECK(!bc_viewer_edits_applied(&q, 1, 1));
	CHECK_EQ_INT(q.nshown, 0);
	CHECK(!bc_viewer_edits_applied(&q, 3 * BC_VIEWER_EDITS_SENT, 2));
	CHECK_EQ_INT(q.nshown, 1);
	for (uint32_t s = 1; s <= 3 * BC_VIEWER_EDITS_SENT; s++) {
		bc_viewer_edits_applied(&q, s, s);
		CHECK(q.nshown <= BC_VIEWER_EDITS_SENT);
	}
}

/* ---- frames -------------------------------------------------------------- */

static void fill(uint8_t *rgba, uint32_t w, uint32_t h, uint32_t seed)
{
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			uint8_t *p = rgba + ((size_t)y * w + x) * 4u;
			p[0] = (uint8_t)(x * 20u + seed);
			p[1] = (uint8_t)(y * 30u + seed * 3u);
			p[2] = (uint8_t)(seed * 11u);
			p[3] = 255;
		}
	}
}

/* A raw FRAME of a w x h view, image iw x ih, with the given rectangles
 * (their data taken from src, an iw x ih image). The data live in store. */
static struct bc_msg raw_frame(uint16_t w, uint16_t h, uint16_t iw, uint16_t ih,
                               bool still, struct bc_proto_rect *r, uint16_t n,
                               const uint8_t *src, uint8_t *store)
{
	struct bc_msg m = {.type = BC_MSG_FRAME};
	size_t at = 0;
	m.flags = still ? BC_PROTO_FLAG_STILL : 0;
	m.frame.encoding = BC_PROTO_ENC_RAW;
	m.frame.width = w;
	m.frame.height = h;
	m.frame.image_width = iw;
	m.frame.image_height = ih;
	m.frame.nrects = n;
	m.frame.rects = r;
	for (uint16_t i = 0; i < n; i++) {
		bc_viewer_copy_rect(src, iw, r[i].x, r[i].y, r[i].w, r[i].h,
		                    store + at);
		r[i].data.ptr = store + at;
		r[i].data.len = (uint32_t)r[i].w * r[i].h * 4u;
		at += r[i].data.len;
	}
	return m;
}

static bool px_eq(const uint8_t *a, uint32_t aw, uint32_t x, uint32_t y,
                  const uint8_t *b, uint32_t bw)
{
	return memcmp(a + ((size_t)y * aw + x) * 4u,
	              b + ((size_t)y * bw + x) * 4u, 4) == 0;
}

static void test_frames_rectangles_and_downscale(void)
{
	enum { W = 8, H = 6 };
	uint8_t a[W * H * 4], b[W * H * 4], s[4 * 3 * 4], up_s[W * H * 4];
	uint8_t store[W * H * 4 * 2];
	struct bc_viewer_frames f;
	struct bc_viewer_update up;
	struct bc_proto_rect r[2];
	struct bc_msg m;
	bc_viewer_frames_init(&f);
	fill(a, W, H, 1);
	fill(b, W, H, 77);
	fill(s, 4, 3, 150);

	/* A whole still: a new texture, uploaded whole. */
	r[0] = (struct bc_proto_rect){0, 0, W, H, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, a, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK_EQ_INT(up.tex, BC_VIEWER_TEX_FULL);
	CHECK(up.resized && up.whole && !up.want_refresh);
	CHECK(memcmp(f.comp, a, sizeof(a)) == 0);
	CHECK(!f.showing_small);

	/* A partial still on top of it: only its rectangles change and only
	 * they are uploaded. */
	r[0] = (struct bc_proto_rect){4, 2, 2, 2, {NULL, 0}};
	r[1] = (struct bc_proto_rect){0, 5, 3, 1, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 2, b, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(!up.resized && !up.whole && !up.want_refresh);
	CHECK_EQ_INT(up.nrects, 2);
	for (uint32_t y = 0; y < H; y++) {
		for (uint32_t x = 0; x < W; x++) {
			bool in = (x >= 4 && x < 6 && y >= 2 && y < 4) ||
			          (y == 5 && x < 3);
			CHECK(px_eq(f.comp, W, x, y, in ? b : a, W));
		}
	}

	/* A downscaled interactive frame goes to the small texture. */
	r[0] = (struct bc_proto_rect){0, 0, 4, 3, {NULL, 0}};
	m = raw_frame(W, H, 4, 3, false, r, 1, s, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK_EQ_INT(up.tex, BC_VIEWER_TEX_SMALL);
	CHECK(up.resized && up.whole);
	CHECK(f.showing_small && f.comp_stale);
	CHECK(memcmp(f.small.rgba, s, sizeof(s)) == 0);

	/* A partial still after it: laid over the small image scaled up,
	 * not over the still from before, and a whole still is wanted. */
	r[0] = (struct bc_proto_rect){0, 0, 2, 2, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, a, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK_EQ_INT(up.tex, BC_VIEWER_TEX_FULL);
	CHECK(up.whole && up.want_refresh && !up.resized);
	CHECK(!f.showing_small && !f.comp_stale);
	bc_viewer_upscale(s, 4, 3, up_s, W, H);
	for (uint32_t y = 0; y < H; y++) {
		for (uint32_t x = 0; x < W; x++) {
			bool in = x < 2 && y < 2;
			CHECK(px_eq(f.comp, W, x, y, in ? a : up_s, W));
		}
	}

	/* The whole still that answers the refresh replaces everything. */
	r[0] = (struct bc_proto_rect){0, 0, W, H, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, b, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(!up.want_refresh && !up.resized);
	CHECK(memcmp(f.comp, b, sizeof(b)) == 0);

	/* Whole interactive frames at full size, then a partial still: the
	 * server's damage covers only the last change; ask again. */
	m = raw_frame(W, H, W, H, false, r, 1, a, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(!up.want_refresh);
	r[0] = (struct bc_proto_rect){1, 1, 2, 2, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, b, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(up.want_refresh && !up.whole);

	/* A new view size: a new picture. */
	r[0] = (struct bc_proto_rect){0, 0, 4, 3, {NULL, 0}};
	m = raw_frame(4, 3, 4, 3, true, r, 1, s, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(up.resized && up.whole);
	CHECK_EQ_INT(f.width, 4);
	CHECK(memcmp(f.comp, s, sizeof(s)) == 0);
	bc_viewer_frames_finish(&f);
	bc_viewer_frames_finish(NULL);
}

/* Refinement levels: a level-2 frame of a 7 x 5 view is a 2 x 2 image,
 * shown on the small texture with the top-left 7/8 x 5/8 of it spanning
 * the view; the viewer says "refining (level 2)" until a finished level-0
 * frame arrives, and a partial still after it starts from the level image
 * scaled by its blocks, not stretched. */
static void test_frames_levels(void)
{
	enum { W = 7, H = 5 };
	uint8_t c[2 * 2 * 4], a[W * H * 4], want[W * H * 4];
	uint8_t store[W * H * 4];
	struct bc_viewer_frames f;
	struct bc_viewer_update up;
	struct bc_proto_rect r[1];
	struct bc_msg m;
	char text[48];
	bc_viewer_frames_init(&f);
	fill(c, 2, 2, 40);
	fill(a, W, H, 90);

	r[0] = (struct bc_proto_rect){0, 0, 2, 2, {NULL, 0}};
	m = raw_frame(W, H, 2, 2, false, r, 1, c, store);
	m.flags = bc_proto_flags_with_level(0, 2);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK_EQ_INT(up.tex, BC_VIEWER_TEX_SMALL);
	CHECK(f.showing_small && f.comp_stale);
	CHECK_EQ_INT(f.level, 2);
	CHECK(f.refining);
	CHECK_NEAR(f.small_u, 7.0 / 8.0, 1e-6);
	CHECK_NEAR(f.small_v, 5.0 / 8.0, 1e-6);
	CHECK(strcmp(bc_viewer_refining_text(m.flags, text, sizeof(text)),
	             "refining (level 2)") == 0);

	/* A partial still: the rest comes from the level image, each of its
	 * pixels a 4 x 4 block from the top-left. Column 3 samples source
	 * x = 3.5 * 8 / 4 / 7 ... = 0.375, not 0.5 as a stretch would. */
	r[0] = (struct bc_proto_rect){0, 0, 1, 1, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, a, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(up.whole && up.want_refresh);
	CHECK_EQ_INT(f.level, 0);
	CHECK(!f.refining);
	CHECK(strcmp(bc_viewer_refining_text(m.flags, text, sizeof(text)),
	             "") == 0);
	bc_viewer_upscale_part(c, 2, 2, 7.0f / 8.0f, 5.0f / 8.0f, want, W, H);
	for (uint32_t y = 0; y < H; y++) {
		for (uint32_t x = 0; x < W; x++) {
			CHECK(px_eq(f.comp, W, x, y, x < 1 && y < 1 ? a : want,
			            W));
		}
	}
	/* Red of c: 40 at x 0, 60 at x 1; view column 3 is 0.375 of the
	 * way: 47.5, where stretching 2 over 7 would give 50. */
	CHECK_EQ_INT(f.comp[(size_t)3 * 4u], 48);

	/* Level 0 cut by the budget is still refining, at level 0. */
	r[0] = (struct bc_proto_rect){0, 0, W, H, {NULL, 0}};
	m = raw_frame(W, H, W, H, false, r, 1, a, store);
	m.flags = BC_PROTO_FLAG_INCOMPLETE;
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK(f.refining);
	CHECK_EQ_INT(f.level, 0);
	CHECK(strcmp(bc_viewer_refining_text(m.flags, text, sizeof(text)),
	             "refining (level 0, cut by budget)") == 0);
	/* A level-1 frame after a downscaled level-0 one: the same small
	 * texture, new extents. */
	r[0] = (struct bc_proto_rect){0, 0, 4, 3, {NULL, 0}};
	m = raw_frame(W, H, 4, 3, false, r, 1, a, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK_NEAR(f.small_u, 1.0, 1e-6);
	m.flags = bc_proto_flags_with_level(BC_PROTO_FLAG_INCOMPLETE, 1);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	CHECK_EQ_INT(f.level, 1);
	CHECK_NEAR(f.small_u, 7.0 / 8.0, 1e-6);
	CHECK_NEAR(f.small_v, 5.0 / 6.0, 1e-6);
	bc_viewer_frames_finish(&f);
}

/* Bad rectangles are refused and leave the picture alone. */
static void test_frames_refuse_bad_rectangles(void)
{
	enum { W = 8, H = 6 };
	uint8_t a[W * H * 4], b[W * H * 4], store[W * H * 4];
	struct bc_viewer_frames f;
	struct bc_viewer_update up;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r[1];
	struct bc_msg m;
	bc_viewer_frames_init(&f);
	fill(a, W, H, 3);
	fill(b, W, H, 9);
	r[0] = (struct bc_proto_rect){0, 0, W, H, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, a, store);
	REQUIRE(bc_viewer_frames_apply(&f, &m, &up, NULL) == 0);
	r[0] = (struct bc_proto_rect){6, 4, 2, 2, {NULL, 0}};
	m = raw_frame(W, H, W, H, true, r, 1, b, store);
	r[0].x = 7; /* now past the right edge */
	CHECK(bc_viewer_frames_apply(&f, &m, &up, &ei) == BC_ERANGE);
	CHECK(ei.msg[0] != '\0');
	CHECK_EQ_INT(up.tex, BC_VIEWER_TEX_NONE);
	CHECK(memcmp(f.comp, a, sizeof(a)) == 0);
	r[0].x = 6;
	r[0].data.len -= 4; /* one pixel short */
	CHECK(bc_viewer_frames_apply(&f, &m, &up, NULL) < 0);
	CHECK(memcmp(f.comp, a, sizeof(a)) == 0);
	m.type = BC_MSG_PING;
	CHECK(bc_viewer_frames_apply(&f, &m, &up, NULL) == BC_EINVAL);
	bc_viewer_frames_finish(&f);
}

/* Every allocation can fail: the error comes back and nothing leaks (the
 * sanitizer build checks the second half). */
static void test_frames_allocation_failures(void)
{
	enum { W = 16, H = 12 };
	uint8_t a[W * H * 4], store[W * H * 4];
	bool done = false;
	for (unsigned long n = 1; n < 100 && !done; n++) {
		struct bc_viewer_frames f;
		struct bc_viewer_update up;
		struct bc_proto_rect r[1] = {{2, 2, 5, 5, {NULL, 0}}};
		struct bc_msg m;
		int rc;
		fill(a, W, H, (uint32_t)n);
		bc_viewer_frames_init(&f);
		m = raw_frame(W, H, W, H, true, r, 1, a, store);
		bc_alloc_fail_after(n);
		rc = bc_viewer_frames_apply(&f, &m, &up, NULL);
		bc_alloc_fail_after(0);
		if (rc == 0) {
			done = true;
			CHECK(px_eq(f.comp, W, 3, 3, a, W));
		} else {
			CHECK_EQ_INT(rc, BC_ENOMEM);
			CHECK_EQ_INT(up.tex, BC_VIEWER_TEX_NONE);
		}
		bc_viewer_frames_finish(&f);
	}
	CHECK(done);
}

static void test_upscale_samples_pixel_centres(void)
{
	const uint8_t src[8] = {0, 100, 200, 255, 200, 20, 40, 255};
	uint8_t dst[16], one[4] = {9, 8, 7, 255}, big[6 * 5 * 4];
	bc_viewer_upscale(src, 2, 1, dst, 4, 1);
	/* Centres 0.5..3.5 map to -0.25 (clamped), 0.25, 0.75, 1.25
	 * (clamped). */
	CHECK_EQ_INT(dst[0], 0);
	CHECK_EQ_INT(dst[4], 50);
	CHECK_EQ_INT(dst[8], 150);
	CHECK_EQ_INT(dst[12], 200);
	CHECK_EQ_INT(dst[5], 80); /* 0.75 * 100 + 0.25 * 20 */
	CHECK_EQ_INT(dst[13], 20);
	bc_viewer_upscale(one, 1, 1, big, 6, 5);
	for (int i = 0; i < 30; i++) {
		CHECK(memcmp(big + i * 4, one, 4) == 0);
	}
	/* Same size: an exact copy. */
	bc_viewer_upscale(src, 2, 1, dst, 2, 1);
	CHECK(memcmp(dst, src, 8) == 0);
}

/* ---- font ---------------------------------------------------------------- */

static int lit(char ch)
{
	int n = 0;
	for (int r = 0; r < BC_VIEWER_GLYPH_H; r++) {
		for (int c = 0; c < BC_VIEWER_GLYPH_W; c++) {
			n += bc_viewer_glyph_bit(ch, c, r);
		}
	}
	return n;
}

static void test_font_glyphs(void)
{
	const char *all = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.:/>-()%#";
	/* Every glyph the overlay uses is drawn, and no two are the same. */
	for (const char *p = all; *p; p++) {
		CHECK(lit(*p) > 0);
		for (const char *q = p + 1; *q; q++) {
			bool same = true;
			for (int r = 0; r < BC_VIEWER_GLYPH_H && same; r++) {
				for (int c = 0; c < BC_VIEWER_GLYPH_W; c++) {
					if (bc_viewer_glyph_bit(*p, c, r) !=
					    bc_viewer_glyph_bit(*q, c, r)) {
						same = false;
						break;
					}
				}
			}
			CHECK(!same);
		}
	}
	CHECK_EQ_INT(lit(' '), 0);
	CHECK_EQ_INT(lit('a'), lit('A'));
	CHECK_EQ_INT(lit('\x7f'), lit('?'));
	CHECK(bc_viewer_glyph_bit('I', 2, 3));
	CHECK(!bc_viewer_glyph_bit('I', 0, 3));
	CHECK(!bc_viewer_glyph_bit('I', 5, 0));
	CHECK(!bc_viewer_glyph_bit('I', 2, -1));
}

static void test_font_triangles(void)
{
	float buf[4096];
	size_t need =
	    bc_viewer_text_tris("fps 1", 10.0f, 20.0f, 2.0f, buf, 4096);
	CHECK_EQ_INT(need,
	             12u * (size_t)(lit('F') + lit('P') + lit('S') + lit('1')));
	/* The first quad: the first lit pixel of 'F' (top-left corner). */
	CHECK_NEAR(buf[0], 10.0, 0.0);
	CHECK_NEAR(buf[1], 20.0, 0.0);
	CHECK_NEAR(buf[4], 12.0, 0.0);
	CHECK_NEAR(buf[5], 22.0, 0.0);
	/* Too little room: the size needed, nothing written past cap. */
	buf[24] = -1.0f;
	CHECK_EQ_INT(bc_viewer_text_tris("fps 1", 0.0f, 0.0f, 1.0f, buf, 24),
	             need);
	CHECK_NEAR(buf[24], -1.0, 0.0);
	/* A second line starts LINE_ADVANCE lower. */
	need = bc_viewer_text_tris("\n.", 0.0f, 0.0f, 1.0f, buf, 4096);
	REQUIRE(need >= 12);
	CHECK(buf[1] >= (float)BC_VIEWER_LINE_ADVANCE);
	CHECK_NEAR(bc_viewer_text_width("ab\nlonger\nx", 2.0f),
	           6.0 * BC_VIEWER_GLYPH_ADVANCE * 2.0, 0.0);
	CHECK_NEAR(bc_viewer_text_width("", 1.0f), 0.0, 0.0);
}

/* The member line: names and roles from the roster, "you" for this
 * client, unnamed members by id, the last editor kept after leaving, and
 * a line too long for its buffer cut with "...". */
static void test_roster_names_members_and_last_editor(void)
{
	const struct bc_client_member mem[3] = {
	    {.id = 4, .role = BC_PROTO_ROLE_EDITOR, .name = "alice"},
	    {.id = 7, .role = BC_PROTO_ROLE_VIEWER, .name = ""},
	    {.id = 9, .role = BC_PROTO_ROLE_EDITOR, .name = "carol"},
	};
	struct bc_viewer_roster r;
	char line[200], small[24];
	memset(&r, 0, sizeof(r));
	r.m = mem;
	r.n = 3;
	r.self = 7;
	CHECK(strcmp(bc_viewer_roster_text(&r, line, sizeof(line)),
	             "3 members: alice (editor), you (viewer), carol "
	             "(editor)") == 0);
	bc_viewer_roster_edit(&r, 9, 12);
	/* carol leaves: the list shrinks, her edit keeps her name. */
	r.n = 2;
	CHECK(strcmp(bc_viewer_roster_text(&r, line, sizeof(line)),
	             "2 members: alice (editor), you (viewer)\nlast edit: "
	             "carol, order 12") == 0);
	bc_viewer_roster_edit(&r, 7, 13);
	CHECK(strstr(bc_viewer_roster_text(&r, line, sizeof(line)),
	             "last edit: you, order 13") != NULL);
	bc_viewer_roster_edit(&r, 30, 14);
	CHECK(strstr(bc_viewer_roster_text(&r, line, sizeof(line)),
	             "last edit: member 30, order 14") != NULL);
	bc_viewer_roster_text(&r, small, sizeof(small));
	CHECK(strlen(small) < sizeof(small));
	CHECK(strcmp(small + strlen(small) - 3, "...") == 0);
}

/* Who presents, on the member list and a line of its own: followed or
 * not, or presented by this client. */
static void test_roster_names_the_presenter(void)
{
	const struct bc_client_member mem[2] = {
	    {.id = 4, .role = BC_PROTO_ROLE_EDITOR, .name = "alice"},
	    {.id = 7, .role = BC_PROTO_ROLE_VIEWER, .name = "bob"},
	};
	struct bc_viewer_roster r;
	char line[200];
	memset(&r, 0, sizeof(r));
	r.m = mem;
	r.n = 2;
	r.self = 7;
	r.presenter = 4;
	CHECK_STREQ(bc_viewer_roster_text(&r, line, sizeof(line)),
	            "2 members: alice (editor, presenting), you (viewer)\n"
	            "alice presents (F follows)");
	r.following = true;
	CHECK_STREQ(bc_viewer_roster_text(&r, line, sizeof(line)),
	            "2 members: alice (editor, presenting), you (viewer)\n"
	            "following alice (F stops)");
	/* A new member list keeps the presenter. */
	r.m = mem;
	r.n = 2;
	r.presenter = 7;
	r.following = false;
	CHECK_STREQ(bc_viewer_roster_text(&r, line, sizeof(line)),
	            "2 members: alice (editor), you (viewer, presenting)\n"
	            "you present (Shift-F stops)");
	r.presenter = 0;
	CHECK_STREQ(bc_viewer_roster_text(&r, line, sizeof(line)),
	            "2 members: alice (editor), you (viewer)");
}

/* The undo/redo notice: the sender by its member name (by id without
 * one), the edit taken back by order and its author as the server names
 * it; REDO says "redid"; an empty author reads "an unnamed member's". */
static void test_undo_text_names_both_members(void)
{
	const struct bc_client_member mem[2] = {
	    {.id = 4, .role = BC_PROTO_ROLE_EDITOR, .name = "alice"},
	    {.id = 9, .role = BC_PROTO_ROLE_EDITOR, .name = "bob"},
	};
	struct bc_viewer_roster r;
	struct bc_msg m = {.type = BC_MSG_EDIT_APPLIED,
	                   .flags = BC_PROTO_FLAG_UNDO};
	char line[200], small[12];
	memset(&r, 0, sizeof(r));
	r.m = mem;
	r.n = 2;
	r.self = 4;
	m.edit_applied.order = 13;
	m.edit_applied.author = 9;
	m.edit_applied.target_order = 12;
	m.edit_applied.target_author.ptr = "alice";
	m.edit_applied.target_author.len = 5;
	CHECK_STREQ(bc_viewer_undo_text(&r, &m, line, sizeof(line)),
	            "bob undid alice's edit 12");
	m.flags = BC_PROTO_FLAG_REDO;
	m.edit_applied.author = 4;
	CHECK_STREQ(bc_viewer_undo_text(&r, &m, line, sizeof(line)),
	            "alice redid alice's edit 12");
	m.flags = BC_PROTO_FLAG_UNDO;
	m.edit_applied.author = 30;
	m.edit_applied.target_author.len = 0;
	CHECK_STREQ(bc_viewer_undo_text(&r, &m, line, sizeof(line)),
	            "member 30 undid an unnamed member's edit 12");
	/* A short buffer is cut, never overrun. */
	CHECK(strlen(bc_viewer_undo_text(&r, &m, small, sizeof(small))) ==
	      sizeof(small) - 1);
}

/* ---- the screenshot's wait and the view size ----------------------------- */

static uint16_t level_flags(unsigned level, bool incomplete)
{
	return (uint16_t)((level << 3) |
	                  (incomplete ? BC_PROTO_FLAG_INCOMPLETE : 0u));
}

/* Level 0 without INCOMPLETE ends the wait at once; a level above 0 or
 * INCOMPLETE does not. */
static void test_shot_waits_for_the_finished_picture(void)
{
	struct bc_viewer_shot s;
	double due;
	bc_viewer_shot_start(&s, 1000.0);
	CHECK(!bc_viewer_shot_finished(&s));
	CHECK(bc_viewer_shot_check(&s, 1000.0, 1000.0, 60000.0, &due) ==
	      BC_VIEWER_SHOT_WAITING);
	CHECK_NEAR(due, 60000.0, 1e-6);
	bc_viewer_shot_frame(&s, level_flags(2, false), 1100.0);
	CHECK(bc_viewer_shot_check(&s, 1100.0, 0.0, 60000.0, &due) ==
	      BC_VIEWER_SHOT_WAITING);
	bc_viewer_shot_frame(&s, level_flags(0, true), 1200.0);
	CHECK(!bc_viewer_shot_finished(&s));
	CHECK(bc_viewer_shot_check(&s, 1200.0, 0.0, 60000.0, &due) ==
	      BC_VIEWER_SHOT_WAITING);
	bc_viewer_shot_frame(&s, level_flags(0, false) | BC_PROTO_FLAG_STILL,
	                     1300.0);
	CHECK(bc_viewer_shot_finished(&s));
	CHECK(bc_viewer_shot_check(&s, 1300.0, 0.0, 60000.0, &due) ==
	      BC_VIEWER_SHOT_FINISHED);
	CHECK(due < 0.0);
}

/* INCOMPLETE frames that stop coming while nothing changes: the picture
 * is settled after the quiet time, not before, and not while a request of
 * ours waits for its frame. */
static void test_shot_settles_when_incomplete_frames_stop(void)
{
	struct bc_viewer_shot s;
	char text[160];
	double due;
	bc_viewer_shot_start(&s, 0.0);
	for (int i = 1; i <= 7; i++) {
		bc_viewer_shot_frame(&s, level_flags(1, true), 50.0 * i);
	}
	CHECK_NEAR(bc_viewer_shot_quiet_ms(&s), BC_VIEWER_SHOT_QUIET_MS, 1e-6);
	CHECK(bc_viewer_shot_check(&s, 350.0 + BC_VIEWER_SHOT_QUIET_MS - 1.0,
	                           0.0, 60000.0,
	                           &due) == BC_VIEWER_SHOT_WAITING);
	CHECK_NEAR(due, 1.0, 1e-6);
	/* A camera of ours without its frame yet: the daemon will answer. */
	CHECK(bc_viewer_shot_check(&s, 350.0 + BC_VIEWER_SHOT_QUIET_MS, 300.0,
	                           60000.0, &due) == BC_VIEWER_SHOT_WAITING);
	CHECK(bc_viewer_shot_check(&s, 350.0 + BC_VIEWER_SHOT_QUIET_MS, 0.0,
	                           60000.0, &due) == BC_VIEWER_SHOT_SETTLED);
	CHECK_STREQ(bc_viewer_shot_text(&s, BC_VIEWER_SHOT_SETTLED, 60000.0,
	                                text, sizeof(text)),
	            "level 1, INCOMPLETE: no better frame for 5.0 s (the "
	            "daemon stopped refining it)");
}

/* A daemon whose steps take long (a frame budget of 4 s) is given three
 * times its longest gap before its silence counts. */
static void test_shot_quiet_time_follows_the_gaps(void)
{
	struct bc_viewer_shot s;
	double due;
	bc_viewer_shot_start(&s, 0.0);
	bc_viewer_shot_frame(&s, level_flags(2, false), 500.0);
	bc_viewer_shot_frame(&s, level_flags(1, true), 4500.0);
	CHECK_NEAR(bc_viewer_shot_quiet_ms(&s), 12000.0, 1e-6);
	CHECK(bc_viewer_shot_check(&s, 4500.0 + 11999.0, 0.0, 60000.0, &due) ==
	      BC_VIEWER_SHOT_WAITING);
	CHECK(bc_viewer_shot_check(&s, 4500.0 + 12000.0, 0.0, 60000.0, &due) ==
	      BC_VIEWER_SHOT_SETTLED);
}

/* Frames that keep coming unfinished, or none at all: the wait ends the
 * picture. */
static void test_shot_wait_runs_out(void)
{
	struct bc_viewer_shot s;
	char text[160];
	double due, t;
	bc_viewer_shot_start(&s, 0.0);
	CHECK(bc_viewer_shot_check(&s, 9999.0, 0.0, 10000.0, &due) ==
	      BC_VIEWER_SHOT_WAITING);
	CHECK(bc_viewer_shot_check(&s, 10000.0, 0.0, 10000.0, &due) ==
	      BC_VIEWER_SHOT_TIMEOUT);
	CHECK_STREQ(bc_viewer_shot_text(&s, BC_VIEWER_SHOT_TIMEOUT, 10000.0,
	                                text, sizeof(text)),
	            "no frame within 10 s");
	for (t = 1000.0; t <= 12000.0; t += 1000.0) {
		bc_viewer_shot_frame(&s, level_flags(0, true), t);
		CHECK(bc_viewer_shot_check(&s, t, 0.0, 10000.0, &due) ==
		      (t < 10000.0 ? BC_VIEWER_SHOT_WAITING
		                   : BC_VIEWER_SHOT_TIMEOUT));
	}
	CHECK_STREQ(bc_viewer_shot_text(&s, BC_VIEWER_SHOT_TIMEOUT, 10000.0,
	                                text, sizeof(text)),
	            "level 0, INCOMPLETE: still refining after 10 s");
	/* A new picture (a camera turn) starts the wait again. */
	bc_viewer_shot_start(&s, 12000.0);
	CHECK(bc_viewer_shot_check(&s, 12001.0, 12000.0, 10000.0, &due) ==
	      BC_VIEWER_SHOT_WAITING);
	CHECK_NEAR(due, 9999.0, 1e-6);
}

/* The VIEW is the framebuffer's size unless a side exceeds the daemon's
 * max_dim; then the longer side is max_dim and the aspect ratio stays. */
static void test_view_size_follows_the_framebuffer(void)
{
	uint32_t w, h;
	CHECK(!bc_viewer_view_size(1920, 1200, 4096, &w, &h));
	CHECK_EQ_INT(w, 1920);
	CHECK_EQ_INT(h, 1200);
	CHECK(!bc_viewer_view_size(4096, 4096, 4096, &w, &h));
	CHECK_EQ_INT(w, 4096);
	CHECK_EQ_INT(h, 4096);
	/* A 2x HiDPI 2880x1800 window (5760x3600 pixels). */
	CHECK(bc_viewer_view_size(5760, 3600, 4096, &w, &h));
	CHECK_EQ_INT(w, 4096);
	CHECK_EQ_INT(h, 2560);
	CHECK(bc_viewer_view_size(100, 8000, 4096, &w, &h));
	CHECK_EQ_INT(w, 51);
	CHECK_EQ_INT(h, 4096);
	CHECK(bc_viewer_view_size(8192, 1, 4096, &w, &h));
	CHECK_EQ_INT(w, 4096);
	CHECK_EQ_INT(h, 1);
	CHECK(!bc_viewer_view_size(300, 200, 0, &w, &h));
	CHECK_EQ_INT(w, 300);
}

static const struct bc_test tests[] = {
    {"project_inverts_view_rays", test_project_inverts_view_rays},
    {"project_refuses_points_behind_the_eye",
     test_project_refuses_points_behind_the_eye},
    {"orbit_turns_about_up", test_orbit_turns_about_up},
    {"orbit_stops_at_the_poles", test_orbit_stops_at_the_poles},
    {"pan_follows_the_mouse", test_pan_follows_the_mouse},
    {"zoom_scales_the_distance", test_zoom_scales_the_distance},
    {"move_in_plane_tracks_pixels", test_move_in_plane_tracks_pixels},
    {"box_contains_every_primitive", test_box_contains_every_primitive},
    {"box_of_a_box_is_tight", test_box_of_a_box_is_tight},
    {"size_parameter_of_every_kind", test_size_parameter_of_every_kind},
    {"unary_param_of_every_kind", test_unary_param_of_every_kind},
    {"unary_notch_values", test_unary_notch_values},
    {"unary_notch_keeps_bounds", test_unary_notch_keeps_bounds},
    {"unary_target_skips_mirror", test_unary_target_skips_mirror},
    {"unary_extent_in_node_units", test_unary_extent_in_node_units},
    {"unary_text", test_unary_text},
    {"node_box_holds_the_subtree", test_node_box_holds_the_subtree},
    {"frame_box_fits_the_view", test_frame_box_fits_the_view},
    {"palette_lists_every_kind", test_palette_lists_every_kind},
    {"sessions_panel_lists_and_chooses", test_sessions_panel_lists_and_chooses},
    {"sessions_panel_new_name", test_sessions_panel_new_name},
    {"history_panel_rows", test_history_panel_rows},
    {"meter_counts_the_last_second", test_meter_counts_the_last_second},
    {"edits_one_in_flight", test_edits_one_in_flight},
    {"edits_refused", test_edits_refused},
    {"edits_track_leaves_the_pending_edit",
     test_edits_track_leaves_the_pending_edit},
    {"edits_bounded", test_edits_bounded},
    {"frames_rectangles_and_downscale", test_frames_rectangles_and_downscale},
    {"frames_levels", test_frames_levels},
    {"frames_refuse_bad_rectangles", test_frames_refuse_bad_rectangles},
    {"frames_allocation_failures", test_frames_allocation_failures},
    {"upscale_samples_pixel_centres", test_upscale_samples_pixel_centres},
    {"font_glyphs", test_font_glyphs},
    {"font_triangles", test_font_triangles},
    {"roster_names_members_and_last_editor",
     test_roster_names_members_and_last_editor},
    {"undo_text_names_both_members", test_undo_text_names_both_members},
    {"roster_names_the_presenter", test_roster_names_the_presenter},
    {"shot_waits_for_the_finished_picture",
     test_shot_waits_for_the_finished_picture},
    {"shot_settles_when_incomplete_frames_stop",
     test_shot_settles_when_incomplete_frames_stop},
    {"shot_quiet_time_follows_the_gaps", test_shot_quiet_time_follows_the_gaps},
    {"shot_wait_runs_out", test_shot_wait_runs_out},
    {"view_size_follows_the_framebuffer",
     test_view_size_follows_the_framebuffer},
};

BC_TEST_MAIN(tests)
