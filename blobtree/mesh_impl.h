/*
 * What blobtree's mesh files share inside the library (mesh.c builds,
 * mesh_collapse.c thins out, mesh_write.c writes).
 */
#ifndef BLOBCAST_BLOBTREE_MESH_IMPL_H
#define BLOBCAST_BLOBTREE_MESH_IMPL_H

#include "blobcast/mesh.h"

/* n = (b - a) x (c - a) in double: the normal of triangle a, b, c scaled by
 * twice its area. */
static inline void bc_mesh_cross3(const float *a, const float *b,
                                  const float *c, double n[3])
{
	double u[3], v[3];
	for (int x = 0; x < 3; x++) {
		u[x] = (double)b[x] - a[x];
		v[x] = (double)c[x] - a[x];
	}
	n[0] = u[1] * v[2] - u[2] * v[1];
	n[1] = u[2] * v[0] - u[0] * v[2];
	n[2] = u[0] * v[1] - u[1] * v[0];
}

/* Collapses edges shorter than max_len of the closed 2-manifold m, in at
 * most passes passes, keeping it a closed 2-manifold of the same topology
 * with no flat or flipped triangle (mesh_collapse.c says how); progress
 * (may be NULL) hears the fraction of the passes done after each, and
 * stops the rest by answering true. Returns 0, BC_ENOMEM or BC_ECLOSED
 * (stopped; m is a closed 2-manifold still, partly thinned, either way). */
int bc_mesh_collapse_short(struct bc_mesh *m, float max_len, int passes,
                           bool (*progress)(void *ctx, double done), void *ctx);

#endif
