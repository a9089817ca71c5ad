/*
 * Renderers behind one small interface. A backend receives the tree (and what
 * changed since it last saw it), a camera and a frame to fill: RGBA8, depth
 * (ray parameter t along unit directions: world distance; +inf on a miss)
 * and the stable id of the primitive hit (0 on a miss). Every backend gives
 * these the same meaning so they can be compared pixel by pixel.
 */
#ifndef BLOBCAST_RENDER_H
#define BLOBCAST_RENDER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/limits.h"

/* Largest width or height of a frame: BC_LIMIT_DIM (blobcast/limits.h:
 * w*h*16 bytes stays far below 2^32, the largest texture GL drivers
 * guarantee), the same as the protocol's BC_PROTO_MAX_DIM. */
#define BC_RENDER_MAX_DIM BC_LIMIT_DIM

/* Tile edge in pixels (paper §6: 8x8 rays share one workgroup and one
 * A-buffer list). Every backend renders in these tiles, so regions, damage
 * and refinement levels are counted in them. */
#define BC_RENDER_TILE 8u
/* Coarsest refinement level: one ray per 2^3 x 2^3 = 8x8 block, the tile. */
#define BC_RENDER_MAX_LEVEL 3u

/* Row 0 is the top row. Any of the three planes may be NULL when the caller
 * does not want it (rgba is always allocated by bc_frame_init). `key` names
 * the conditions the planes were rendered under (camera, size, debug mode,
 * scene structure, the backend's frame constants): a render of a region
 * into a frame whose key no longer matches renders the whole frame instead
 * (stats.whole), so a caller can never assemble pixels of two different
 * renderings. 0: nothing rendered yet. */
struct bc_frame {
	uint32_t width, height;
	uint8_t *rgba; /* width * height * 4 */
	float *depth;  /* width * height */
	uint32_t *ids; /* width * height */
	uint64_t key;
	/* A window of a larger picture (a tile of a big snapshot): the frame
	 * holds pixels [win_x, win_x + width) x [win_y, win_y + height) of a
	 * full_width x full_height view of the camera, each pixel exactly as
	 * a render of the whole view would give it. full_width 0 (as
	 * bc_frame_init leaves it): the frame is the whole view. Set with
	 * bc_frame_window. Tiles, regions and refinement levels count in
	 * the frame's own pixels: with an origin at a multiple of
	 * BC_RENDER_TILE (8) they are the view's tiles and levels, and
	 * every backend's window equals the crop of the whole render bit
	 * for bit (naive's at any origin); at other origins the tiled, svo
	 * and gl tiles group other rays and pixels may differ in their
	 * last bits. */
	uint32_t win_x, win_y, full_width, full_height;
};

/* Allocates all three planes. Returns 0, BC_ERANGE (size 0 or over
 * BC_RENDER_MAX_DIM) or BC_ENOMEM. bc_frame_finish accepts a zeroed frame. */
int bc_frame_init(struct bc_frame *f, uint32_t width, uint32_t height);
void bc_frame_finish(struct bc_frame *f);
/* Makes f (of its width x height) the window at (x, y) of a full_width x
 * full_height view; full_width 0 makes it the whole view again. Returns 0,
 * or BC_ERANGE when the window does not lie inside the view or the view
 * is over BC_RENDER_MAX_DIM. Changes the frame's key (0: nothing of the
 * new window is rendered yet). */
int bc_frame_window(struct bc_frame *f, uint32_t x, uint32_t y,
                    uint32_t full_width, uint32_t full_height);

enum bc_debug_mode {
	BC_DEBUG_NONE = 0,
	BC_DEBUG_EVALS,    /* colour = field evaluations per ray */
	BC_DEBUG_OVERLAPS, /* colour = primitives listed in the pixel's tile */
	BC_DEBUG_COUNT
};

enum bc_backend {
	BC_BACKEND_INVALID = 0,
	BC_BACKEND_NAIVE, /* CPU sphere tracing of the full tree: the baseline
	                   */
	BC_BACKEND_TILED, /* CPU synchronized tile tracing (paper §6) */
	BC_BACKEND_GL,    /* OpenGL compute through EGL or OSMesa */
	BC_BACKEND_SVO,   /* CPU adaptive octree + interval ray casting */
	BC_BACKEND_COUNT
};

enum bc_range_arith {
	BC_RANGE_DEFAULT = 0, /* the backend's choice (IA: svo.h) */
	BC_RANGE_IA,
	BC_RANGE_AA,
	BC_RANGE_REVAA,
	BC_RANGE_COUNT
};

/* Vector instructions of the CPU tracers. */
enum bc_simd {
	BC_SIMD_AUTO = 0, /* the widest the CPU has (AVX-512, AVX2), else off */
	BC_SIMD_OFF,      /* the portable scalar path */
	BC_SIMD_AVX2,     /* 8-ray packets; the scalar path without AVX2 */
	BC_SIMD_AVX512,   /* 16-ray packets; scalar without AVX-512F */
	BC_SIMD_COUNT
};

/* Zero means default for every field. */
struct bc_render_opts {
	enum bc_debug_mode debug;
	uint32_t threads; /* CPU threads, 0 = one per core */
	const char
	    *gl_platform; /* "auto" | "device" | "surfaceless" | "osmesa" */
	enum bc_range_arith svo_range;
	uint32_t svo_threshold; /* node-count threshold tau, 0 = default */
	uint32_t svo_max_depth; /* 0 = default */
	/* Milliseconds a frame may take, 0 = no limit. Past it the tiled
	 * tracer starts no new tile: the rest is background and the stats
	 * say incomplete (one pathological scene cannot stall a server). */
	uint32_t budget_ms;
	enum bc_simd simd;
	/* Primitive-tile pairs the A-buffer lists of tiled and gl may hold
	 * at once; 0, or any value over 2^24: 2^24 (BC_CPU_MAX_FRAGMENTS,
	 * BC_GL_MAX_FRAGMENTS; gl's may be lower still, the driver's storage
	 * block size). A view whose lists would hold more is drawn in bands
	 * of whole tile rows, each within the limit (the same pixels, bit
	 * for bit); the limit bounds the lists' memory (tiled 12 bytes a
	 * pair, with room to grow; gl 56 bytes of GPU memory), and lowering
	 * it trades speed for memory: a banded view keeps no lists between
	 * frames. */
	uint32_t abuffer_limit;
};

/* Timings of one frame, milliseconds, and work counters. */
struct bc_render_stats {
	double ms_total;
	double ms_abuffer; /* building per-tile lists (tiled, gl) */
	double ms_trace;
	double ms_upload; /* gl: data sent to the GPU for this frame */
	uint64_t field_evals;
	uint64_t rays;        /* pixels traced by this call */
	uint32_t max_overlap; /* most primitives listed in one tile */
	uint32_t tiles;       /* tiles rendered by this call */
	bool incomplete;      /* cut short by a time budget */
	bool whole;           /* a region was asked, the whole frame drawn */
	uint64_t short_rays;  /* rays that ran out of max_evals, not drawn */
	/* tiled, gl: the bands of tile rows the call's A-buffer was built
	 * in (1 when the lists fit at once; opts.abuffer_limit). */
	uint32_t bands;
	/* tiled: times the call's new tile lists did not fit the room kept
	 * for lists, which was then grown, or compacted when lists that
	 * outgrew their room had left enough of it behind; each time, the
	 * tiles whose lists did not fit are listed again. */
	uint32_t lists_grown, lists_compacted;
	/* tiled: the pairs of tile and primitive that a new view's
	 * primitives' rectangles of tiles make, and of a call that built
	 * every tile's candidates at once (a new view, or an edit of many
	 * primitives), the candidates kept (those whose bounding sphere the
	 * tile's cone meets); 0 otherwise (a banded view's). */
	uint64_t ab_pairs, ab_candidates;
};

/*
 * Which pixels a render call draws. Tiles are BC_RENDER_TILE squares in
 * row-major order, ceil(width / 8) x ceil(height / 8) of them.
 *
 * Refinement levels nest: level n traces the pixels (x, y) whose x and y
 * are both multiples of 2^n (one ray per 2^n x 2^n block, at the block's
 * top-left pixel); a level-n `refine` call traces only those of them that
 * level n + 1 did not (three of every four), so a frame refined from level
 * 3 down to 0 traces every pixel exactly once. Each pixel's value does not
 * depend on the level it was traced at: a frame refined to level 0 is the
 * same, bit for bit, as a whole render.
 *
 * An evaluation bound (max_evals) makes a call's cost follow the pixels it
 * asks for, whatever the scene: a ray stops before its first evaluation
 * past the bound, so a call spends at most max_evals per ray plus each
 * tile's setup (its list and the views of its depth ranges; svo: the
 * octree walk, and the octree's build after a sync). The evaluations
 * counted are those of stats.field_evals, and everything a ray's pixel
 * takes counts, shading included:
 *   naive, tiled: one value of the field (the full tree, a depth range's
 *     pruned view or the tile's view) at one point: each sphere tracing
 *     step; each sample of the refinement, bisection and closest-approach
 *     searches and of settling a near hit; the five samples that shade a
 *     hit (its primitive, its normal). Packets count the samples as the
 *     scalar path does (the vector kernels' rounding, which may move a
 *     pixel in its last bits, may also move a ray's count).
 *   gl: the same samples as tiled (trace.comp is trace.c step by step),
 *     per invocation; a near hit at a depth range's end is shaded there.
 *   svo: a point evaluation of a variant (a leaf's or the full tree's) or
 *     a range evaluation (interval bisection's, or a packet's beam test,
 *     which each ray of the packet counts), and the four samples of a
 *     hit's normal. A ray that leaves its packet (it runs against the
 *     packet's order) is cast again alone with the whole bound, so it may
 *     spend up to twice the bound.
 * A ray that does not run out is drawn bit for bit as without a bound.
 * Whether a ray runs out depends only on the ray in naive, tiled and gl;
 * in svo on the rays cast in its packet too (their beam tests are shared;
 * a region fixes the packets, so a call is still deterministic).
 */
struct bc_render_region {
	const uint8_t *tiles; /* non-zero byte: draw the tile; NULL: all */
	uint32_t level;       /* 0..BC_RENDER_MAX_LEVEL */
	bool refine;          /* skip the pixels level + 1 traced */
	/* The most field evaluations one ray of this call may spend, 0: no
	 * bound. A ray that would need more stops before the first one past
	 * the bound and its pixel is not written: colour, depth and id keep
	 * what the frame held (a coarser level's value, say), so one scene
	 * whose rays crawl cannot hold a render for long. */
	uint32_t max_evals;
	/* NULL, or ceil(width / 8) x ceil(height / 8) bytes: the renderer
	 * sets byte t to 1 when a ray of tile t ran out and never clears a
	 * byte (the caller zeroes them). */
	uint8_t *short_tiles;
	/* Tiles [tile_first, tile_first + tile_count) hold every tile the
	 * region draws (0 count: any tile may): a call of a few tiles of a
	 * large frame then looks at those only (the tiled backend; others
	 * look at every tile). Past the frame's tiles: BC_EINVAL. */
	uint32_t tile_first, tile_count;
	/* The caller keeps track of which of the frame's tiles hold what
	 * (the daemon's views: a level per tile). A frame drawn under other
	 * conditions (another key, or none yet) then takes this rendering's
	 * key and only the region is drawn, instead of the whole frame. */
	bool adopt_key;
	/* Threads of the renderer's (opts.threads) this call may use, 0:
	 * all of them. A caller that schedules its own workers gives a call
	 * the cores that are free at the time, and pixels do not depend on
	 * it (the CPU backends hand out tiles or rows, not pixels, to
	 * threads; gl ignores it). */
	uint32_t threads;
};

/* The threads a call of a renderer with `threads` threads may use under
 * region (NULL: all). */
static inline uint32_t
bc_render_region_threads(const struct bc_render_region *region,
                         uint32_t threads)
{
	return region && region->threads && region->threads < threads
	           ? region->threads
	           : threads;
}

struct bc_renderer;

/* "naive", "tiled", "gl", "svo" <-> enum; BC_BACKEND_INVALID if unknown. */
enum bc_backend bc_backend_from_name(const char *name);
const char *bc_backend_name(enum bc_backend b);
/* Whether backend b is built in. */
bool bc_backend_available(enum bc_backend b);

/* Creates a renderer of backend b (opts may be NULL: defaults). Returns 0,
 * BC_ENOTSUP when b is not built in, or the backend's error; *out is NULL
 * on failure. bc_renderer_destroy accepts NULL. */
int bc_renderer_create(struct bc_renderer **out, enum bc_backend b,
                       const struct bc_render_opts *opts,
                       struct bc_errinfo *ei);
void bc_renderer_destroy(struct bc_renderer *r);
enum bc_backend bc_renderer_backend(const struct bc_renderer *r);

/* Tells r the tree to draw and what changed since the previous sync
 * (dirty == NULL or dirty->structure: everything, and every frame's key
 * changes; but see bc_renderer_follows). The tree must outlive its use by
 * r. */
int bc_renderer_sync(struct bc_renderer *r, const struct bc_tree *t,
                     const struct bc_dirty *dirty, struct bc_errinfo *ei);

/* Whether r, synced before, follows the spliced structure change dirty
 * describes (struct bc_dirty, spliced): then bc_renderer_sync keeps the
 * frame key, and a frame of the state before needs only the tiles that
 * bc_renderer_damage marks for dirty's gone ABVs and for the new ABVs of
 * its primitives [prim_lo, prim_hi) drawn again. The tree given to that
 * sync may be another object holding the same scene (bc_tree_swap, as an
 * edit batch hands its result out). tiled follows splices; gl, svo and
 * naive start over. */
bool bc_renderer_follows(const struct bc_renderer *r,
                         const struct bc_dirty *dirty);

/* Whether each bc_renderer_render_region call of r costs a whole frame's
 * setup however few tiles it asks for (gl), so that a frame drawn in parts
 * should be drawn in few, large ones. false for NULL. */
bool bc_renderer_wants_large_regions(const struct bc_renderer *r);

/* Draws the whole frame (every pixel) of the last synced tree. Returns 0,
 * BC_EINVAL (bad frame), BC_ERANGE (bad camera), BC_ESTATE (nothing synced)
 * or the backend's error. */
int bc_renderer_render(struct bc_renderer *r, const struct bc_camera *cam,
                       struct bc_frame *out, struct bc_render_stats *stats,
                       struct bc_errinfo *ei);

/* Draws only region's pixels into out, leaving the others as they are.
 * When out->key differs from this rendering's, draws every tile at the
 * region's level without `refine` instead and sets stats->whole. */
int bc_renderer_render_region(struct bc_renderer *r,
                              const struct bc_camera *cam, struct bc_frame *out,
                              const struct bc_render_region *region,
                              struct bc_render_stats *stats,
                              struct bc_errinfo *ei);

/* Frees what r keeps between renders for its last view (tiled: ray
 * directions, tile lists and candidates, per-thread scratch; svo: the
 * octree; gl: the frame's images, readback and A-buffer storage), so that
 * a caller holding many renderers can give memory back. r stays usable:
 * the next render rebuilds what it needs and draws the same pixels, bit
 * for bit. Accepts NULL. */
void bc_renderer_release(struct bc_renderer *r);

/* Returns the bytes r keeps for views between renders, estimated from its
 * buffers' capacities: what bc_renderer_release would give back (gl: GPU
 * memory, host memory on llvmpipe). 0 after a release, for NULL, and for
 * backends that keep nothing (naive). */
size_t bc_renderer_kept_bytes(const struct bc_renderer *r);

/* Called from the rendering thread while a long call draws: `done` of
 * `total` work items are finished (naive: rows; tiled: tiles; gl: the
 * tile rows of a call drawn in A-buffer bands, the only gl calls that
 * report; svo: none). Calls are at least a quarter of a second apart and
 * none comes in a call's first second. */
typedef void (*bc_render_progress_fn)(void *user, uint32_t done,
                                      uint32_t total);

/* Installs (or, with fn NULL, removes) r's progress callback. Accepts
 * NULL. */
void bc_renderer_set_progress(struct bc_renderer *r, bc_render_progress_fn fn,
                              void *user);

/* Marks (sets to 1) in tiles, ceil(width / 8) x ceil(height / 8) bytes,
 * every tile of a width x height frame through cam (the whole view: for a
 * window at an origin of multiples of 8, its tiles are the view's tiles
 * from (win_x / 8, win_y / 8) on) whose pixels can depend
 * on a primitive with world ABV abv, margins of the backend's own tile
 * lists included. A parameter edit that changes only primitives' ABVs and
 * data changes a frame only in the tiles marked for their ABVs before and
 * after the edit. Backends whose pixels see every primitive (naive and
 * svo: a sphere tracing step or an octree cell depends on all of them)
 * mark every tile. */
void bc_renderer_damage(struct bc_renderer *r, const struct bc_camera *cam,
                        uint32_t width, uint32_t height,
                        const struct bc_abv *abv, uint8_t *tiles);

/* Tiles across and down a width x height frame. */
static inline uint32_t bc_render_tiles_x(uint32_t width)
{
	return (width + BC_RENDER_TILE - 1) / BC_RENDER_TILE;
}
static inline uint32_t bc_render_tiles_y(uint32_t height)
{
	return (height + BC_RENDER_TILE - 1) / BC_RENDER_TILE;
}

/* Whether pixel (x, y) is traced by a call at `level` (with `refine`). */
static inline bool bc_render_level_has(uint32_t x, uint32_t y, uint32_t level,
                                       bool refine)
{
	uint32_t m = (1u << level) - 1u, m2 = (2u << level) - 1u;
	if ((x & m) || (y & m)) {
		return false;
	}
	return !(refine && level < BC_RENDER_MAX_LEVEL && !(x & m2) &&
	         !(y & m2));
}

/* Convenience: create, sync, render once, destroy. */
int bc_render_once(enum bc_backend b, const struct bc_render_opts *opts,
                   const struct bc_tree *t, const struct bc_camera *cam,
                   struct bc_frame *out, struct bc_render_stats *stats,
                   struct bc_errinfo *ei);

#endif
