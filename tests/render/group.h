/*
 * Moving a group of neighbouring primitives of a fig18 scene at once (its
 * root union's children k, which are its primitives k), with the damage a
 * caller draws: shared by test_damage and bench/bench_relocate.c.
 */
#ifndef BLOBCAST_TESTS_RENDER_GROUP_H
#define BLOBCAST_TESTS_RENDER_GROUP_H

#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/render.h"

/* Moves primitives [first, first + n) by d along x, marking in tiles (of
 * a w x h frame through cam) the tiles of their ABVs before and after.
 * Returns 0, BC_EINVAL when child k of the root is not primitive k, or
 * the edit's error (with ei). */
static inline int group_move(struct bc_tree *t, struct bc_renderer *r,
                             const struct bc_camera *cam, uint32_t w,
                             uint32_t h, uint32_t first, uint32_t n, float d,
                             uint8_t *tiles, struct bc_errinfo *ei)
{
	uint32_t root = bc_tree_root(t);
	for (uint32_t k = first; k < first + n; k++) {
		const struct bc_lin *l = bc_tree_lin(t);
		uint32_t id = bc_tree_child(t, root, k);
		struct bc_prim_data p;
		struct bc_abv a;
		int rc;
		if (!id || !bc_tree_get(t, id, &p, NULL) ||
		    l->node_id[l->prim_slot[k]] != id) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "child %u of the root is not "
			                      "primitive %u",
			                      k, k);
		}
		a = bc_lin_abv(l, k);
		bc_renderer_damage(r, cam, w, h, &a, tiles);
		p.translate[0] += d;
		if ((rc = bc_tree_set_prim(t, id, &p, ei))) {
			return rc;
		}
		a = bc_lin_abv(bc_tree_lin(t), k);
		bc_renderer_damage(r, cam, w, h, &a, tiles);
	}
	return 0;
}

#endif
