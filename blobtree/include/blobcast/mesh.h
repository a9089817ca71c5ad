/*
 * Triangle meshes of a blobtree's surface: marching tetrahedra on a uniform
 * grid over a box, visited through an octree of regions so that only the
 * cells near the surface are evaluated, each region through the pruned
 * view of the primitives whose ABVs meet it (blobtree's sparse
 * evaluation); and writers for OBJ, PLY, STL and binary glTF 2.0. The mesh
 * is a closed 2-manifold: every edge is used by exactly two triangles, in
 * opposite directions, and no triangle is degenerate. docs/mesh.md
 * explains the method and what the output guarantees.
 */
#ifndef BLOBCAST_MESH_H
#define BLOBCAST_MESH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"

/* Largest grid: cells along the box's longest side. 4096^2 surface cells
 * already make a mesh of tens of millions of triangles. */
#define BC_MESH_MAX_RESOLUTION 4096u
#define BC_MESH_DEFAULT_RESOLUTION 128u
/* The least resolution of a scene's own box: its longest side is the
 * scene's in res - 4 cells and two cells of margin at each end. */
#define BC_MESH_MIN_SCENE_RESOLUTION 5u

struct bc_mesh_opts {
	/* Cells along the longest side of the box (0: default). */
	uint32_t resolution;
	/* The box to mesh; all zero: the tree's box grown by two cells. The
	 * solid is clipped to it (closed by the box's faces). */
	float lo[3], hi[3];
	/* Keep every triangle marching tetrahedra make: no collapse of the
	 * edges shorter than half a cell (faster, about twice the
	 * triangles; closed 2-manifold either way). */
	bool raw;
	/* Called now and then with the fraction done (may be NULL). */
	void (*progress)(void *ctx, double done);
	/* Asked as often (may be NULL): true stops the build, which then
	 * returns BC_ECLOSED. */
	bool (*stop)(void *ctx);
	void *ctx;
};

struct bc_mesh {
	float (*pos)[3];    /* vertices */
	uint8_t (*rgb)[3];  /* per-vertex colour (the primitive's) */
	uint32_t (*tri)[3]; /* triangles, counter-clockwise seen from outside */
	uint32_t nverts, ntris;
	uint32_t cap_verts, cap_tris;
	float cell;             /* grid cell size (world units) */
	uint64_t evals;         /* field evaluations spent */
	uint64_t cells_visited; /* grid cells in regions that were evaluated */
};

/* Meshes the surface of t into *m (init/finish on caller memory;
 * bc_mesh_finish frees). Returns 0, BC_EINVAL (empty tree, or a box with
 * no volume), BC_ERANGE (resolution above BC_MESH_MAX_RESOLUTION),
 * BC_ENOMEM or BC_ECLOSED (opts->stop), with the reason in ei. */
int bc_mesh_build(struct bc_mesh *m, const struct bc_tree *t,
                  const struct bc_mesh_opts *opts, struct bc_errinfo *ei);
void bc_mesh_finish(struct bc_mesh *m);

enum bc_mesh_format {
	BC_MESH_FORMAT_INVALID = 0,
	BC_MESH_FORMAT_OBJ, /* text, v x y z r g b (colours in [0, 1]) */
	BC_MESH_FORMAT_PLY, /* binary little endian, uchar colours */
	BC_MESH_FORMAT_STL, /* binary, facet normals */
	BC_MESH_FORMAT_GLB, /* binary glTF 2.0: normals, COLOR_0, indices */
	BC_MESH_FORMAT_COUNT
};

/* The format a file name's extension names (.obj, .ply, .stl, .glb, any
 * case), BC_MESH_FORMAT_INVALID otherwise. */
enum bc_mesh_format bc_mesh_format_of(const char *path);
/* The format named "obj", "ply", "stl" or "glb" (any case), else
 * BC_MESH_FORMAT_INVALID. */
enum bc_mesh_format bc_mesh_format_named(const char *name);

/* Writes m to path in format, atomically (a temporary file renamed over
 * path). Returns 0, BC_EINVAL (format; an empty mesh as glTF, which has no
 * empty accessors), BC_ERANGE (a .glb over 4 GiB), BC_ENOMEM or BC_EIO
 * with the reason in ei. */
int bc_mesh_write(const struct bc_mesh *m, const char *path,
                  enum bc_mesh_format format, struct bc_errinfo *ei);
/* Writes a mesh file made elsewhere (len bytes; a server's MESH_DATA) to
 * path as bc_mesh_write does: atomically. Returns 0, BC_EINVAL, BC_ENOMEM
 * or BC_EIO with the reason in ei. */
int bc_mesh_write_file(const char *path, const uint8_t *bytes, size_t len,
                       struct bc_errinfo *ei);
/* The same bytes in memory: *out (bc_free) holds head bytes left for the
 * caller (a message's head), then the file; *len counts both. Returns 0,
 * BC_EINVAL, BC_ERANGE or BC_ENOMEM as bc_mesh_write. */
int bc_mesh_write_mem(const struct bc_mesh *m, enum bc_mesh_format format,
                      size_t head, uint8_t **out, size_t *len,
                      struct bc_errinfo *ei);

#endif
