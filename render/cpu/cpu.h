/*
 * What the two CPU backends share: the renderer object, the tracing
 * constants of Zanni 2024 §7, the field handle (the full tree or a pruned
 * view), sphere tracing, shading and pixel output (so naive and tiled write
 * identical pixels for identical hits) and the worker threads.
 */
#ifndef BLOBCAST_RENDER_CPU_PRIV_H
#define BLOBCAST_RENDER_CPU_PRIV_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/render.h"
#include "blobcast/render_backend.h"
#include "blobcast/render_common.h"
#include "blobcast/shade.h"

/* ---- Constants ---------------------------------------------------------- */

/* Tile edge in pixels (paper §6: 8x8 rays per workgroup). */
#define BC_CPU_TILE BC_RENDER_TILE
/* Most primitives active in one depth range (paper §7: M_overlap = 128).
 * A tile whose overlaps exceed it is not failed: see tiled.c. */
#define BC_CPU_M_OVERLAP 128u
/* Most primitives fetched into the active set per range (paper §6.2). */
#define BC_CPU_MAX_FETCH 8u
/* Over-relaxation factor and Lipschitz bound of the sphere tracer (paper
 * §7): the bound covers the field compression of the compact operators. */
#define BC_CPU_OVERRELAX 1.7f
#define BC_CPU_LIPSCHITZ 1.45f
/* Minimal step, as a fraction of the scene's AABB diagonal (lin->size). The
 * paper uses a fixed 0.005 world units, 1/22000 to 1/64000 of its scenes'
 * depth; our scenes span a few units, so 1e-4 of the diagonal is of the
 * same order and scales with the scene. It also bounds the hit epsilon
 * from below and hence the number of steps per ray. */
#define BC_CPU_MIN_STEP_REL 1.0e-4f
/* A ray hits when the field is below this fraction of the pixel footprint
 * at t (the width a pixel covers at that distance): finer would only add
 * steps along grazing rays without changing the image. */
#define BC_CPU_HIT_FOOTPRINT 0.5f
/* Crossings are refined by bisection to this fraction of the scene's
 * diagonal, so depth does not depend on where the steps happened to land. */
#define BC_CPU_REFINE_REL 1.0e-5f
/* Worker threads at most, whatever opts.threads asks. */
#define BC_CPU_MAX_THREADS BC_POOL_MAX_THREADS
/* Tile fragments (primitive x tile pairs) the A-buffer holds at once:
 * 2^24 are 200 MiB of lists (candidates and fragments), far above most
 * scenes (a 4096-primitive scene at 512^2 makes ~10^5). A view that
 * needs more, a million spheres at 3840x2160, is drawn in bands of tile
 * rows within it (tiled.c, draw_bands); only a single tile row over it
 * fails, with BC_ELIMIT. opts.abuffer_limit lowers it. */
#define BC_CPU_MAX_FRAGMENTS (1u << 24)
/* Primitives a parameter edit may move for the tiled tracer to patch the
 * candidates of the tiles they cover instead of building every tile's
 * again (tiled.c, patch_cand): a drag moves one, a selection a few. An
 * edit of more, whose primitives' indices span at most 1 /
 * BC_CPU_PATCH_SHARE of the scene's, patches too where that costs less
 * (patch_pays): a group of neighbouring primitives in a big scene. */
#define BC_CPU_PATCH_PRIMS 64u
#define BC_CPU_PATCH_SHARE 16u
/* Debug colour ramps saturate here, clamped for readability like the
 * paper's Fig. 15 (whose overlap scale ends at a quarter of M_overlap):
 * field evaluations per ray, primitives per tile list. */
#define BC_CPU_DEBUG_EVALS_MAX 128u
#define BC_CPU_DEBUG_OVERLAPS_MAX 32u

/* ---- The renderer ------------------------------------------------------- */

enum bc__cpu_kind {
	BC__CPU_INVALID = 0,
	BC__CPU_NAIVE,
	BC__CPU_TILED,
	BC__CPU_KIND_COUNT
};

struct bc__tiled_bufs; /* tiled.c: buffers kept between frames */

/* A CPU renderer: the front's base first (options, synced tree). */
struct bc__cpu {
	struct bc_renderer base;
	enum bc__cpu_kind kind;
	uint32_t threads;
	struct bc__tiled_bufs *tiled;
};

static inline struct bc__cpu *bc__cpu_of(struct bc_renderer *r)
{
	return (struct bc__cpu *)r; /* base is the first member */
}

int bc__cpu_create(struct bc_renderer **out, enum bc__cpu_kind kind,
                   const struct bc_render_opts *opts, struct bc_errinfo *ei);
void bc__cpu_destroy(struct bc_renderer *r);
/* Reads the region's tile byte for tile t (NULL tiles: all). Returns the
 * mask of the tile's 64 pixels (bit (y % 8) * 8 + x % 8) the region
 * traces, 0 for none; bits of pixels beyond the frame's edge are clear. */
uint64_t bc__region_mask(const struct bc_render_region *region, uint32_t tx,
                         uint32_t ty, uint32_t width, uint32_t height);
/* tiled.c frees its buffers through this. */
void bc__tiled_free(struct bc__tiled_bufs *b);

/* fminf and fmaxf without their NaN rules, which GCC will not inline:
 * these compile to one instruction in the tracing loops. */
static inline float bc__minf(float a, float b)
{
	return a < b ? a : b;
}

static inline float bc__maxf(float a, float b)
{
	return a > b ? a : b;
}

/* Bits set in x: a few instructions (a loop over the bits cost a full
 * tile 64 rounds, 2-4 % of a gears frame). */
static inline uint32_t bc__popcount64(uint64_t x)
{
	return (uint32_t)__builtin_popcountll(x);
}

/* ---- The field ---------------------------------------------------------- */

/* The field a ray is traced in: the whole tree, or a pruned view that
 * equals it inside the current depth range. evals counts calls, those of
 * earlier ranges of the ray included. */
struct bc__field {
	const struct bc_lin *lin;
	const struct bc_view *view; /* NULL: the full tree */
	uint32_t evals;
	/* The region's bound on evals (0: none): bc__trace stops before
	 * an evaluation past it, and callers check it before shading. */
	uint32_t max_evals;
};

/* Whether the ray may still spend n evaluations of f within its bound. */
static inline bool bc__field_can(const struct bc__field *f, uint32_t n)
{
	return f->max_evals == 0 ||
	       (f->evals <= f->max_evals && f->max_evals - f->evals >= n);
}

static inline float bc__field_eval(struct bc__field *f, const float p[3])
{
	f->evals++;
	return f->view ? bc_view_eval(f->view, f->lin, p)
	               : bc_eval_full(f->lin, p);
}

static inline float bc__field_eval_id(struct bc__field *f, const float p[3],
                                      uint32_t *prim)
{
	f->evals++;
	return f->view ? bc_view_eval_id(f->view, f->lin, p, prim)
	               : bc_eval_full_id(f->lin, p, prim);
}

/* ---- One frame ---------------------------------------------------------- */

/* Per-frame constants shared by every thread. */
struct bc__frame_ctx {
	const struct bc_lin *lin; /* NULL for an empty tree */
	struct bc_view_rays vr;
	struct bc_frame *out;
	enum bc_debug_mode debug;
	float min_step;   /* world units */
	float pix_angle;  /* pixel footprint per unit of t */
	float refine_tol; /* world units */
	struct bc_shade shade;
	/* The region's max_evals (0: no bound) and short_tiles (may be
	 * NULL): set by the backend after bc__frame_setup. */
	uint32_t max_evals;
	uint8_t *short_tiles;
};

/* Fills fc for a frame. lin may be NULL (empty tree). */
void bc__frame_setup(struct bc__frame_ctx *fc, const struct bc_lin *lin,
                     const struct bc_camera *cam, struct bc_frame *out,
                     enum bc_debug_mode debug);

enum bc__trace_result {
	BC__TRACE_INVALID = 0,
	BC__TRACE_MISS,
	BC__TRACE_HIT, /* *t_hit is on the surface (or its silhouette) */
	/* The ray is within the hit epsilon at the interval's end and still
	 * approaching the surface: the crossing, if any, is beyond t1, where
	 * the field traced may no longer hold. *t_hit is the closest point;
	 * a caller without a following interval takes it as a hit. */
	BC__TRACE_NEAR_END,
	/* The ray reached its bound (bc__field's max_evals) before an
	 * answer: its pixel is left as it is. */
	BC__TRACE_SHORT,
	BC__TRACE_RESULT_COUNT
};

/* Sphere traces o + t d (d unit) over [t0, t1] in field f, within f's
 * bound (BC__TRACE_SHORT when it ran out). */
enum bc__trace_result bc__trace(struct bc__field *f,
                                const struct bc__frame_ctx *fc,
                                const float o[3], const float d[3], float t0,
                                float t1, float *t_hit);

/* bc__put_hit's tetrahedral offsets, in the order its samples are summed
 * (the packet kernels take the same samples in the same order). */
extern const float bc__tet[4][3];
/* Writes pixel (x, y) of the frame for a ray d that hit at t in field f:
 * identity of the primitive, shaded colour (or the debug colour from the
 * evaluations counted in f, or from `overlaps`), depth and id. */
void bc__put_hit(const struct bc__frame_ctx *fc, struct bc__field *f,
                 uint32_t x, uint32_t y, const float d[3], float t,
                 uint32_t overlaps);
/* The second half of bc__put_hit, for tracers that took the gradient
 * samples (bc__put_hit's tetrahedral differences, summed in its order) and
 * the primitive themselves: writes pixel (x, y) from normal n (not
 * necessarily unit), primitive index prim and the ray's evaluations. */
void bc__put_shaded(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                    const float d[3], float t, const float n[3], uint32_t prim,
                    uint32_t evals, uint32_t overlaps);
/* bc__put_shaded without the debug views, for tracers that shaded the
 * hit themselves (blobcast/shade_lanes.h): writes pixel (x, y) from its
 * linear colour lit. */
void bc__put_lit(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                 float t, const float lit[3], uint32_t prim);
/* The albedo of primitive index prim (grey for BC_NONE). */
const float *bc__albedo(const struct bc_lin *lin, uint32_t prim);
/* Writes pixel (x, y) for a ray that missed after `evals` evaluations. */
void bc__put_miss(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                  uint32_t evals, uint32_t overlaps);
/* bc__put_miss for the pixels x0 + i of row y whose bit i is set in
 * bits, outside the debug views (which colour each by its own count). */
void bc__put_miss_row(const struct bc__frame_ctx *fc, uint32_t x0, uint32_t y,
                      uint64_t bits);
/* bc__put_miss, no evaluation taken and overlaps 0, for the pixels of
 * tile [x0, x1) x [y0, y1) (at most BC_CPU_TILE on a side) whose bit
 * (y - y0) * BC_CPU_TILE + (x - x0) is set in mask, a row's colour
 * computed once. */
void bc__put_miss_tile(const struct bc__frame_ctx *fc, uint32_t x0, uint32_t y0,
                       uint32_t x1, uint32_t y1, uint64_t mask);

#endif
