/*
 * Helpers shared by the scene tests: bit-exact comparison of two trees
 * (ids, structure, kinds, parameters, transforms, colours) and of cameras,
 * and a checker that a failed decode left its tree empty.
 */
#ifndef BLOBCAST_TESTS_SCENE_UTIL_H
#define BLOBCAST_TESTS_SCENE_UTIL_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/blobtree.h"
#include "blobcast/scene.h"

static inline bool same_floats(const float *a, const float *b, size_t n)
{
	return memcmp(a, b, n * sizeof(float)) == 0;
}

static inline bool same_camera(const struct bc_camera *a,
                               const struct bc_camera *b)
{
	return same_floats(a->eye, b->eye, 3) &&
	       same_floats(a->target, b->target, 3) &&
	       same_floats(a->up, b->up, 3) &&
	       same_floats(&a->fov_y_deg, &b->fov_y_deg, 1);
}

/*
 * The builder renormalizes every quaternion it is given (bc_prim_validate
 * divides by the norm), and doing that to a quaternion that is already
 * normalized in float may move a component by one unit in the last place.
 * So a decoded rotation is exactly the one written, or exactly what
 * validating the written one gives -- never anything else.
 */
static inline bool same_rotation(const struct bc_prim_data *written,
                                 const float read[4])
{
	struct bc_prim_data v = *written;
	if (same_floats(written->rotate, read, 4)) {
		return true;
	}
	return bc_prim_validate(&v, NULL) == 0 &&
	       same_floats(v.rotate, read, 4);
}

/* Returns 0 when a and b are the same scene bit for bit, else the pre-order
 * index + 1 of the first node that differs (or UINT32_MAX for counts).
 * Children order is compared through the pre-order id sequence; parents
 * and child counts through the model's own accessors. */
static inline uint32_t tree_diff(const struct bc_tree *a,
                                 const struct bc_tree *b)
{
	struct bc_scene_walk wa, wb;
	struct bc_scene_node na, nb;
	uint32_t bad = 0;
	if (bc_tree_node_count(a) != bc_tree_node_count(b) ||
	    bc_tree_prim_count(a) != bc_tree_prim_count(b) ||
	    bc_tree_root(a) != bc_tree_root(b)) {
		return UINT32_MAX;
	}
	if (bc_scene_walk_init(&wa, a) || bc_scene_walk_init(&wb, b)) {
		bc_scene_walk_finish(&wa);
		return UINT32_MAX;
	}
	while (!bad && bc_scene_walk_next(&wa, &na)) {
		struct bc_prim_data pb;
		struct bc_op_data ob;
		bool ok =
		    bc_scene_walk_next(&wb, &nb) && na.id == nb.id &&
		    na.is_op == nb.is_op && na.depth == nb.depth &&
		    na.nchildren == nb.nchildren &&
		    bc_tree_get(b, na.id, &pb, &ob) &&
		    bc_tree_parent(a, na.id) == bc_tree_parent(b, na.id) &&
		    bc_tree_child_count(a, na.id) ==
		        bc_tree_child_count(b, na.id);
		if (ok && na.is_op) {
			ok = na.op.kind == ob.kind &&
			     same_floats(&na.op.blend, &ob.blend, 1) &&
			     same_floats(&na.op.range, &ob.range, 1);
		} else if (ok) {
			ok = na.prim.kind == pb.kind &&
			     same_floats(na.prim.params, pb.params,
			                 BC_PRIM_MAX_PARAMS) &&
			     same_floats(na.prim.translate, pb.translate, 3) &&
			     same_rotation(&na.prim, pb.rotate) &&
			     na.prim.has_color == pb.has_color &&
			     (!na.prim.has_color ||
			      same_floats(na.prim.color, pb.color, 3));
		}
		if (!ok) {
			bad = na.index + 1;
		}
	}
	bc_scene_walk_finish(&wa);
	bc_scene_walk_finish(&wb);
	return bad;
}

static inline bool tree_is_empty(const struct bc_tree *t)
{
	return bc_tree_node_count(t) == 0 && bc_tree_root(t) == 0 &&
	       bc_tree_lin(t) == NULL;
}

#endif
