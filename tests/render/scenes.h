/*
 * Test scenes for the renderer tests, built with the public builder: the
 * paper's synthetic families in small sizes (Fig. 16 recursive aggregates,
 * Fig. 18 instances in a cube under one n-ary union, a left comb) plus the
 * random trees of the blobtree tests, and a camera that frames any scene.
 * Deterministic from their seeds.
 */
#ifndef BLOBCAST_TESTS_RENDER_SCENES_H
#define BLOBCAST_TESTS_RENDER_SCENES_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/blobtree.h"

#include "../blobtree/randtree.h"

static void sc_sphere(struct bc_prim_data *p, float x, float y, float z,
		      float r)
{
	bc_prim_data_init(p, BC_PRIM_SPHERE);
	p->params[0] = r;
	p->translate[0] = x;
	p->translate[1] = y;
	p->translate[2] = z;
	p->has_color = true;
	p->color[0] = 0.3f + 0.7f * fabsf(sinf(3.0f * x + 1.0f));
	p->color[1] = 0.3f + 0.7f * fabsf(sinf(5.0f * y + 2.0f));
	p->color[2] = 0.3f + 0.7f * fabsf(sinf(7.0f * z + 3.0f));
}

static void sc_box(struct bc_prim_data *p, float x, float y, float z, float h)
{
	bc_prim_data_init(p, BC_PRIM_BOX);
	p->params[0] = h;
	p->params[1] = 0.7f * h;
	p->params[2] = 0.5f * h;
	p->translate[0] = x;
	p->translate[1] = y;
	p->translate[2] = z;
	rt_random_quat(p->rotate);
}

static struct bc_op_data sc_op(bool smooth, float blend)
{
	struct bc_op_data op = {BC_OP_UNION, 0.0f, 0.0f};
	if (smooth) {
		op.kind = BC_OP_SMOOTH_UNION;
		op.blend = blend;
		op.range = bc_op_default_range(blend);
	}
	return op;
}

/* Fig. 16: an aggregate of 10 primitives; at level > 0, 10 sub-aggregates
 * around it, one level down and smaller, combined largest first. */
static int sc_fig16_agg(struct bc_tree *t, int level, const float c[3],
			float s, bool smooth)
{
	struct bc_op_data op = sc_op(smooth, 0.25f * s);
	int rc;
	if ((rc = bc_tree_push_op(t, 0, &op, NULL))) {
		return rc;
	}
	for (int i = 0; i < 10; i++) {
		struct bc_prim_data p;
		float a = 0.628f * (float)i, b = 0.9f * (float)i;
		float x = c[0] + 0.6f * s * cosf(a) * cosf(b);
		float y = c[1] + 0.6f * s * sinf(b);
		float z = c[2] + 0.6f * s * sinf(a) * cosf(b);
		if (i % 3 == 2) {
			sc_box(&p, x, y, z, 0.3f * s);
		} else {
			sc_sphere(&p, x, y, z, 0.35f * s);
		}
		if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
			return rc;
		}
	}
	for (int i = 0; level > 0 && i < 10; i++) {
		float a = 0.628f * (float)i + 0.3f, e = 0.5f * sinf(2.1f * (float)i);
		float sub[3] = {c[0] + 1.3f * s * cosf(a) * cosf(e),
				c[1] + 1.3f * s * sinf(e),
				c[2] + 1.3f * s * sinf(a) * cosf(e)};
		if ((rc = sc_fig16_agg(t, level - 1, sub, 0.3f * s, smooth))) {
			return rc;
		}
	}
	return bc_tree_pop_op(t, NULL);
}

static int sc_fig16(struct bc_tree *t, int level, bool smooth)
{
	static const float origin[3] = {0.0f, 0.0f, 0.0f};
	int rc;
	rt_state = 16;
	bc_tree_begin(t);
	if ((rc = sc_fig16_agg(t, level, origin, 1.0f, smooth))) {
		return rc;
	}
	return bc_tree_end(t, NULL);
}

/* Fig. 18: n instances uniformly placed in a cube, sized to overlap
 * moderately, under one n-ary (left comb) union. */
static int sc_fig18(struct bc_tree *t, uint32_t n, bool boxes, bool smooth,
		    uint64_t seed)
{
	float side = 2.0f, s = side / cbrtf((float)n);
	struct bc_op_data op = sc_op(smooth, 0.2f * s);
	int rc;
	rt_state = seed;
	bc_tree_begin(t);
	if ((rc = bc_tree_push_op(t, 0, &op, NULL))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_prim_data p;
		float x = rt_float(-1.0f, 1.0f) * 0.5f * side;
		float y = rt_float(-1.0f, 1.0f) * 0.5f * side;
		float z = rt_float(-1.0f, 1.0f) * 0.5f * side;
		if (boxes) {
			sc_box(&p, x, y, z, 0.45f * s);
		} else {
			sc_sphere(&p, x, y, z, 0.5f * s);
		}
		if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
			return rc;
		}
	}
	if ((rc = bc_tree_pop_op(t, NULL))) {
		return rc;
	}
	return bc_tree_end(t, NULL);
}

/* A left comb of n spheres along a diagonal line. */
static int sc_comb(struct bc_tree *t, uint32_t n, bool smooth)
{
	struct bc_op_data op = sc_op(smooth, 0.1f);
	int rc;
	bc_tree_begin(t);
	if ((rc = bc_tree_push_op(t, 0, &op, NULL))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_prim_data p;
		float u = (float)i / (float)(n - 1) - 0.5f;
		sc_sphere(&p, 3.0f * u, 1.0f * u, 0.5f * sinf(9.0f * u),
			  0.12f + 0.05f * (float)(i % 3));
		if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
			return rc;
		}
	}
	if ((rc = bc_tree_pop_op(t, NULL))) {
		return rc;
	}
	return bc_tree_end(t, NULL);
}

/* A camera looking at the scene's AABB from the front, a little from above
 * and the right, close enough to fill most of a 40 degree field of view. */
static void sc_frame(const struct bc_lin *l, struct bc_camera *cam)
{
	float c[3], r = 0.5f * l->size;
	float dir[3] = {0.35f, 0.45f, 1.0f};
	float n = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
	/* The bounding sphere of the AABB is loose: 0.75 of the distance
	 * that fits it keeps the scene's body in frame, filling more of it. */
	float dist = 0.75f * r / sinf(20.0f * 3.14159265f / 180.0f);
	bc_camera_default(cam);
	for (int i = 0; i < 3; i++) {
		c[i] = 0.5f * (l->lo[i] + l->hi[i]);
		cam->target[i] = c[i];
		cam->eye[i] = c[i] + dir[i] / n * dist;
	}
	cam->fov_y_deg = 40.0f;
}

#endif
