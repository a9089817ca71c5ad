// What every stage of the gl backend shares: the pipeline constants (the
// same values as the CPU renderers', render/cpu/cpu.h, so the two give the
// same pictures), the per-frame uniform block, and the storage buffers with
// their binding points. render/gl/gl_priv.h mirrors the bindings, the
// layouts and the limits, and checks the enum values copied here.

// ---- Constants -----------------------------------------------------------

// Tile edge in pixels: one 8x8 workgroup per tile (Zanni 2024 Sec. 6).
#define BC_TILE 8u
#define BC_TILE_RAYS 64u
// Active primitives held in shared memory per depth range (paper Sec. 7). More
// than this at one depth spill to the tile's global scratch: slower, never
// wrong.
#define BC_M_OVERLAP 128u
// Primitives fetched into the active set per range (paper Sec. 6.2).
#define BC_MAX_FETCH 8u
// Pruned view instructions kept in shared memory: a view of M_overlap
// primitives has at most 2 M_overlap - 1. Longer views (after an overflow)
// continue in global scratch.
#define BC_VIEW_SHARED 255u
// Node parameter cache (D_cache), in vec4: 8 KiB, room for about a hundred
// primitive records. Records that do not fit are read from global memory.
#define BC_CACHE_VEC4 512u
// Evaluation and traversal stack entries: blobtree.h's BC_EVAL_STACK, enough
// for any tree within its depth limit.
#define BC_EVAL_STACK 130u
// Sphere tracing (paper Sec. 7): over-relaxation, Lipschitz bound.
#define BC_OVERRELAX 1.7
#define BC_LIPSCHITZ 1.45
// Hit epsilon as a fraction of the pixel footprint at t.
#define BC_HIT_FOOTPRINT 0.5
// Debug colour ramps saturate here (as the CPU renderers').
#define BC_DEBUG_EVALS_MAX 128.0
#define BC_DEBUG_OVERLAPS_MAX 32.0
// Tiles sorted in shared memory; longer lists are heap-sorted in place.
#define BC_SORT_SHARED 1024u

#define BC_NONE 0xffffffffu
#define BC_INF uintBitsToFloat(0x7f800000u)

// Node words (blobtree.h).
#define BC_WORD_LEAF 0x80000000u
#define BC_WORD_TYPE_SHIFT 22u
#define BC_WORD_TYPE_MASK 0xffu
#define BC_WORD_ANCESTOR_MASK 0x3fffffu
#define BC_PRIM_RECORD_VEC4 5u
#define BC_SPHERE_RECORD_VEC4 1u

// enum bc_op and enum bc_op_class.
#define BC_OP_UNION 1u
#define BC_OP_INTERSECTION 2u
#define BC_OP_DIFFERENCE 3u
#define BC_OP_SMOOTH_UNION 4u
#define BC_OP_SMOOTH_INTERSECTION 5u
#define BC_OP_SMOOTH_DIFFERENCE 6u
#define BC_OPCLASS_UNION 0u
#define BC_OPCLASS_INTERSECTION 1u
#define BC_OPCLASS_DIFFERENCE 2u

// enum bc_abv_shape.
#define BC_ABV_SPHERE 1u
#define BC_ABV_BOX 2u
#define BC_ABV_CAPSULE 3u

// enum bc_debug_mode.
#define BC_DEBUG_NONE 0u
#define BC_DEBUG_EVALS 1u
#define BC_DEBUG_OVERLAPS 2u

// Slots of the statistics buffer.
#define BC_STAT_FRAGMENTS 0u   // fragments produced (stored or not)
#define BC_STAT_MAX_OVERLAP 1u // longest tile list
#define BC_STAT_OVER_M 2u      // ranges that went over M_overlap
#define BC_STAT_OVER_CACHE 3u  // ranges whose records did not all fit
#define BC_STAT_RANGES 4u      // depth ranges traced
#define BC_STAT_SUSPENDED 5u   // tiles that suspended in this dispatch
#define BC_STAT_SLOTS 6u       // suspension slots taken (all dispatches)
#define BC_STAT_NO_SLOT 7u     // suspensions refused: the pool was full
#define BC_STAT_OVER_BUDGET 8u // loop budget exceeded where no split exists
#define BC_STAT_DISPATCHES 9u  // tracing dispatches that did work
#define BC_STAT_GENERAL 10u    // ranges evaluated by the general path
#define BC_STAT_OVER_VIEW 11u  // views longer than the tile's room
#define BC_STAT_EVALS 16u      // 256 buckets of field evaluation counts
#define BC_STAT_EVAL_BUCKETS 256u

// Tile status (the fourth word of a tile's entry): fresh, suspended with
// its state in scratch slot (word >> 2), finished.
#define BC_TILE_FRESH 0u
#define BC_TILE_SUSPENDED 1u
#define BC_TILE_FINISHED 2u
// Words of one suspension slot: the tile's walk, then nine per ray (its
// flags and the sphere tracing state a paused ray resumes from).
#define BC_SLOT_TILE_WORDS 8u
#define BC_SLOT_RAY_WORDS 9u
#define BC_SLOT_WORDS (BC_SLOT_TILE_WORDS + BC_SLOT_RAY_WORDS * BC_TILE_RAYS)
// Words per tile of the Short buffer: a bit for each of its 64 rays.
#define BC_SHORT_WORDS 2u
// Coarsest refinement level (blobcast/render.h's BC_RENDER_MAX_LEVEL).
#define BC_MAX_LEVEL 3u

// ---- Per-frame uniforms ----------------------------------------------------

layout(std140, binding = 0) uniform Frame {
	vec4 u_eye;     // xyz: eye; w: tan(fov_y / 2)
	vec4 u_forward; // xyz: unit view direction; w: aspect of the whole view
	vec4 u_right;   // xyz: unit right; w: minimal step (world units)
	vec4 u_up;      // xyz: unit up; w: pixel footprint per unit of t
	vec4 u_light;   // xyz: unit vector toward the light; w: ambient
	vec4 u_misc;    // x: bisection tolerance (world units), y: scene size,
			// z: the tree's Lipschitz bound (blobtree's lin->lip),
			// w: 1 / z (a product, exact for 1: no division,
			// which drivers may approximate)
	uvec4 u_size;   // width, height, tiles across, tiles down
	uvec4 u_counts; // primitives, fragment capacity, debug mode, and the
			// slot count when the tree has unary nodes (else 0)
	// Suspension (trace.comp): scratch word where the slots begin, slots,
	// loop iterations one invocation may spend per dispatch (0: no limit),
	// and 1 when the frame is out of time: suspended tiles then finish
	// with what they found.
	uvec4 u_pool;
	// The region drawn (blobcast/render.h): refinement level, refine
	// (1: skip the pixels of the level above), tiles listed in b_region,
	// and 1 when the list is used (0: every tile, in row-major order).
	uvec4 u_region;
	// x: the most field evaluations one ray may spend (0: no bound); a ray
	// that would go past it stops, undrawn, and its bit is set in b_short.
	// y, z: with a tile list (u_region.w == 1), the listed tiles' bounding
	// box in tiles, x0 | y0 << 16 and x1 | y1 << 16, half-open
	// (abuffer.geom clips imposters to it).
	uvec4 u_bound;
	// The frame as a window of the whole view (blobcast/render.h's
	// bc_frame_window): x0, y0, full width, full height; (0, 0, width,
	// height) for a frame that is the whole view. Rays, projections and
	// the background are the whole view's; pixels, tiles and refinement
	// levels count in the frame.
	uvec4 u_window;
};

// ---- Storage buffers -------------------------------------------------------

// The linearized blobtree (paper Sec. 7): per slot the node word and the offset
// of its parameter record, in vec4 units.
layout(std430, binding = 0) readonly buffer Nodes { uvec2 b_node[]; };
layout(std430, binding = 1) readonly buffer Params { vec4 b_param[]; };
// Per slot: leftmost slot of the subtree, fast ancestor, jump pointer, kills.
layout(std430, binding = 2) readonly buffer Topo { uvec4 b_topo[]; };
// Per primitive: (slot, stable id of its scene node, 0, 0) and its colour.
struct bc_prim_rec {
	uvec4 info;
	vec4 color;
};
layout(std430, binding = 3) readonly buffer Prims { bc_prim_rec b_prim[]; };
// Per primitive: its world ABV and that ABV's world AABB (lo, hi). lo.w is
// the shape as a float (1.0, 2.0, 3.0: bit patterns of small integers are
// denormals, which some drivers flush), hi.w the radius; a is
// the centre (capsule: end a), b the capsule's end b or the box's half
// extents, ax0..2 the box's unit axes.
struct bc_abv_rec {
	vec4 lo;
	vec4 hi;
	vec4 a;
	vec4 b;
	vec4 ax0;
	vec4 ax1;
	vec4 ax2;
};
layout(std430, binding = 4) readonly buffer Abvs { bc_abv_rec b_abv[]; };
// A-buffer fragments as rasterized: entry, exit (float bits), primitive,
// next fragment of the same tile (BC_NONE ends the list).
layout(std430, binding = 5) buffer Links { uvec4 b_link[]; };
// Per tile: list head, fragments stored, offset of its sorted list, 0.
layout(std430, binding = 6) buffer Tiles { uvec4 b_tile[]; };
// Sorted per-tile lists: entry, exit (float bits), primitive, 0.
layout(std430, binding = 7) buffer Sorted { uvec4 b_frag[]; };
// Global scratch of the tracing pass, indexed by the tile's list offset:
// active primitives and their exits beyond M_overlap, view instructions
// beyond BC_VIEW_SHARED. See trace.comp.
layout(std430, binding = 8) buffer Scratch { uint b_scratch[]; };
layout(std430, binding = 9) buffer Stats { uint b_stat[]; };
// The tiles a region lists (u_region.w == 1): their indices, in row-major
// order (u_region.z of them), then a bit per tile of the frame.
layout(std430, binding = 10) readonly buffer Region { uint b_region[]; };
// Per tile, two words: a bit per pixel (bit (y % 8) * 8 + x % 8, the
// invocation index) whose ray ran out of the evaluation bound (u_bound.x).
// Cleared by the host for bounded frames; the copy to the caller's frame
// skips those pixels.
layout(std430, binding = 11) buffer Short { uint b_short[]; };

// ---- Regions ------------------------------------------------------------------

// The tile of workgroup wg (gl_WorkGroupID) of a per-tile dispatch: (tiles
// across) x (rows needed) workgroups walk the tile list, or every tile of
// the frame when no list is used. BC_NONE: a workgroup past the list's end.
uint bc_region_tile(uvec3 wg)
{
	uint i = wg.y * u_size.z + wg.x;
	if (u_region.w == 0u) {
		return i;
	}
	return i < u_region.z ? b_region[i] : BC_NONE;
}

// Does the region list tile (every tile without a list)?
bool bc_region_listed(uint tile)
{
	if (u_region.w == 0u) {
		return true;
	}
	return ((b_region[u_region.z + tile / 32u] >> (tile % 32u)) & 1u) != 0u;
}

// bc_render_level_has: is pixel (x, y) traced at the region's level?
bool bc_region_has(uint x, uint y)
{
	uint level = u_region.x;
	uint m = (1u << level) - 1u, m2 = (2u << level) - 1u;
	if ((x & m) != 0u || (y & m) != 0u) {
		return false;
	}
	return !(u_region.y != 0u && level < BC_MAX_LEVEL && (x & m2) == 0u &&
		 (y & m2) == 0u);
}

// ---- ABVs as the A-buffer sees them -------------------------------------------

// A ray counts as a hit within the hit epsilon of the surface, which can lie
// just outside the ABV; so ABVs are widened by the epsilon (times the
// Lipschitz bound) at their far side from the eye, as the tiled CPU renderer
// widens them. Returns that margin for the ABV with world AABB [lo, hi].
float bc_abv_margin(vec3 lo, vec3 hi)
{
	vec3 c = 0.5 * (lo + hi) - u_eye.xyz, e = 0.5 * (hi - lo);
	float far = length(c) + length(e);
	return BC_LIPSCHITZ * u_misc.z *
	       max(BC_HIT_FOOTPRINT * u_up.w * far, u_right.w);
}

// ---- Camera rays ------------------------------------------------------------

// Direction through the fractional pixel position (x, y) of the frame, y
// counted from the top row: the formula of bc_view_rays_dir, which adds the
// window's origin (whole numbers: the sum is exact).
vec3 bc_ray_dir(float x, float y)
{
	float w = float(u_window.z), h = float(u_window.w);
	float sx = (2.0 * (x + float(u_window.x)) / w - 1.0) * u_eye.w *
		   u_forward.w;
	float sy = (1.0 - 2.0 * (y + float(u_window.y)) / h) * u_eye.w;
	return normalize(u_forward.xyz + sx * u_right.xyz + sy * u_up.xyz);
}
