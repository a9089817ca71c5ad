/*
 * libblobcast installs blobtree.h and scene.h (the scene mirror's types and
 * the functions that read and encode it), whose declarations do not carry
 * BC_API. The library's build puts this header in front of every blobtree
 * source file (-include), so that those two headers' functions get default
 * visibility; the rest of blobtree (bc__ helpers, generators, meshes) stays
 * internal to libblobcast like every unmarked function.
 */
#ifndef BLOBCAST_CLIENT_BLOBTREE_API_H
#define BLOBCAST_CLIENT_BLOBTREE_API_H

#pragma GCC visibility push(default)
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#pragma GCC visibility pop

#endif
