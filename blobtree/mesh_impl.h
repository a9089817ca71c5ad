/*
 * What blobtree's mesh files share inside the library (mesh.c builds,
 * mesh_collapse.c thins out, mesh_write.c writes).
 */
#ifndef BLOBCAST_BLOBTREE_MESH_IMPL_H
#define BLOBCAST_BLOBTREE_MESH_IMPL_H

#include "blobcast/mesh.h"

/* Collapses edges shorter than max_len of the closed 2-manifold m, in at
 * most passes passes, keeping it a closed 2-manifold of the same topology
 * with no flat or flipped triangle (mesh_collapse.c says how); progress
 * (may be NULL) hears the fraction of the passes done. Returns 0 or
 * BC_ENOMEM (m is then a closed 2-manifold still, partly thinned). */
int bc_mesh_collapse_short(struct bc_mesh *m, float max_len, int passes,
                           void (*progress)(void *ctx, double done), void *ctx);

#endif
