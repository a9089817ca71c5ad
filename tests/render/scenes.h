/*
 * Test scenes for the renderer tests: the generators of blobcast/gen.h in
 * small sizes (the paper's Fig. 16 aggregates and Fig. 18 instances, a left
 * comb, random trees with every operator), a coloured sphere for scenes
 * built by hand, and a camera that frames any scene more tightly than the
 * generators' own (more pixels on the surfaces, fewer on the background).
 */
#ifndef BLOBCAST_TESTS_RENDER_SCENES_H
#define BLOBCAST_TESTS_RENDER_SCENES_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include <stdio.h>

#include "blobcast/blobtree.h"
#include "blobcast/gen.h"

static inline void sc_sphere(struct bc_prim_data *p, float x, float y, float z,
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

static inline struct bc_op_data sc_op(bool smooth, float blend)
{
	struct bc_op_data op = {BC_OP_UNION, 0.0f, 0.0f};
	if (smooth) {
		op.kind = BC_OP_SMOOTH_UNION;
		op.blend = blend;
		op.range = bc_op_default_range(blend);
	}
	return op;
}

/* A generated scene (blobcast/gen.h). Returns 0 or the generator's error. */
static inline int sc_gen(struct bc_tree *t, const char *name,
                         struct bc_gen_opts opts)
{
	struct bc_errinfo ei = {0};
	int rc = bc_gen(name, &opts, t, NULL, &ei);
	if (rc) {
		fprintf(stderr, "  %s: %s\n", name, ei.msg);
	}
	return rc;
}

/* Fig. 16: recursive aggregates (level 1: 10 primitives, 2: 110). */
static inline int sc_fig16(struct bc_tree *t, uint32_t level, bool smooth)
{
	return sc_gen(t, "fig16",
	              (struct bc_gen_opts){.level = level,
	                                   .blend = smooth
	                                                ? BC_GEN_BLEND_SMOOTH
	                                                : BC_GEN_BLEND_SHARP});
}

/* Fig. 18: n instances in a cube under one n-ary (left comb) union. */
static inline int sc_fig18(struct bc_tree *t, uint32_t n, bool boxes,
                           bool smooth, uint64_t seed)
{
	return sc_gen(
	    t, "fig18",
	    (struct bc_gen_opts){
	        .count = n,
	        .seed = seed,
	        .kind = boxes ? BC_GEN_KIND_BOXES : BC_GEN_KIND_SPHERES,
	        .blend = smooth ? BC_GEN_BLEND_SMOOTH : BC_GEN_BLEND_SHARP});
}

/* A left comb of n spheres. */
static inline int sc_comb(struct bc_tree *t, uint32_t n, bool smooth)
{
	return sc_gen(t, "comb",
	              (struct bc_gen_opts){.count = n,
	                                   .blend = smooth
	                                                ? BC_GEN_BLEND_SMOOTH
	                                                : BC_GEN_BLEND_SHARP});
}

/* A random tree with every operator kind. */
static inline int sc_random(struct bc_tree *t, uint32_t n, uint64_t seed)
{
	return sc_gen(t, "random",
	              (struct bc_gen_opts){.count = n, .seed = seed});
}

/* One scene with every kind of unary and domain node (twist, onion over a
 * cut, repeat of a scale, offset of a bend of a mirror of an elongate),
 * JSON text. */
#define SC_UNARY_JSON                                                          \
	"{\"blobcast\": 1, \"root\": {\"type\": \"union\", "                   \
	"\"children\": ["                                                      \
	"{\"type\": \"twist\", \"rate\": 1.2, \"children\": "                  \
	"[{\"type\": \"box\", \"half_extents\": [0.4, 1.2, 0.4], "             \
	"\"translate\": [-1.5, 0, 0]}]},"                                      \
	"{\"type\": \"onion\", \"thickness\": 0.05, \"children\": "            \
	"[{\"type\": \"difference\", \"children\": [{\"type\": "               \
	"\"sphere\", \"radius\": 0.6}, {\"type\": \"box\", "                   \
	"\"half_extents\": [1, 1, 1], \"translate\": [0, 0, 1]}]}]},"          \
	"{\"type\": \"repeat\", \"spacing\": [0.6, 1, 0.6], \"count\": "       \
	"[3, 1, 2], \"children\": [{\"type\": \"scale\", \"factor\": "         \
	"0.5, \"children\": [{\"type\": \"sphere\", \"radius\": 0.4, "         \
	"\"translate\": [3.2, -1.6, 0]}]}]},"                                  \
	"{\"type\": \"offset\", \"amount\": 0.1, \"children\": "               \
	"[{\"type\": \"bend\", \"rate\": 0.6, \"children\": "                  \
	"[{\"type\": \"mirror\", \"axes\": \"x\", \"children\": "              \
	"[{\"type\": \"elongate\", \"half_extents\": [0.3, 0, 0], "            \
	"\"children\": [{\"type\": \"capsule\", \"a\": [0.5, 0, 0], "          \
	"\"b\": [0.9, 0, 0], \"radius\": 0.1, \"translate\": [0, 1.2, "        \
	"0]}]}]}]}]}"                                                          \
	"]}}"

/* A camera looking at the scene's AABB from the front, a little from above
 * and the right, close enough to fill most of a 40 degree field of view. */
static inline void sc_frame(const struct bc_lin *l, struct bc_camera *cam)
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
