/*
 * The blobtree: a CSG tree of approximate signed distance primitives combined
 * with sharp and compact smooth operators (Zanni 2024, §4-§7).
 *
 * A struct bc_tree holds two forms of one scene:
 *  - the editable model: n-ary nodes with stable 32-bit ids chosen by the
 *    scene (0 is invalid), primitives with parameters and a rigid transform,
 *    operators with their blend parameters;
 *  - the linearized form (struct bc_lin): the binary post-order layout of the
 *    paper's §7 that renderers read. An n-ary operator is folded left,
 *    ((c0 op c1) op c2)..., into binary nodes that all share one parameter
 *    record, so editing the operator writes one place.
 *
 * Editing a primitive's parameters rewrites that primitive's parameter record
 * and its ABV only; editing an operator's parameters recomputes the ROIs and
 * ABVs of its subtree; INSERT, REMOVE and REPLACE splice the layout in
 * place (splice.c: memory moves and index fixes linear in the scene, the
 * rest in proportion to the change; trees with unary nodes, and a new
 * root, are laid out again in linear time). Nothing
 * else is re-processed, and the dirty ranges say what changed.
 */
#ifndef BLOBCAST_BLOBTREE_H
#define BLOBCAST_BLOBTREE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/error.h"
#include "blobcast/export.h"
#include "blobcast/limits.h"

/* ---- Limits ------------------------------------------------------------ */

/* Linearized nodes are addressed by a 22-bit ancestor field in the GPU node
 * word (paper §7); the all-ones value marks "no ancestor". */
#define BC_TREE_MAX_NODES BC_LIMIT_NODES
/* Nesting of the n-ary scene tree: nodes on the longest path from the root,
 * the root counting 1. Every walk over the tree is iterative (explicit heap
 * stacks or parent links) and every per-level array is allocated per node,
 * so depth costs memory in proportion to the tree, never C stack. The limit
 * only keeps one number meaningful for every encoding; a 2^20-deep chain is
 * far beyond what programs emit (Lipschitz Pruning's Molecule is a 1001-deep
 * chain of pairwise unions) and far below the node limit. Checked
 * identically by the builder (and so both decoders) and by the edits that
 * graft subtrees. JSON scene files carry less: BC_SCENE_JSON_MAX_DEPTH. */
#define BC_TREE_MAX_DEPTH (1u << 20)
/* Evaluation stack entries any program over a tree may need: the linearized
 * post-order is evaluated with a stack (paper Alg. 4), on the GPU in
 * per-invocation memory of this fixed size (shaders/common.glsl). A binary
 * node needs max(left, right + 1) entries, so left combs -- the chains
 * n-ary operators fold into and that programs emit -- need 2 at any depth;
 * only operands nested on the right side add up. Trees needing more are
 * refused (BC_EDEPTH) by the builder and by edits, so every evaluator can
 * keep a fixed stack. Pruned views never need more than their tree. */
#define BC_EVAL_STACK 130u
/* Largest primitive size parameter (world units) and largest |coordinate|:
 * keeps squared distances far from float overflow. */
#define BC_PARAM_MAX_ABS 1.0e6f
/* Floats of shape parameters a primitive may have (round cone and capped
 * cone: a, b, two radii). */
#define BC_PRIM_MAX_PARAMS 8
/* Floats of packed shape data in a primitive's parameter record. */
#define BC_PRIM_PACKED 8

#define BC_NONE UINT32_MAX

/* ---- Node kinds -------------------------------------------------------- */

/* Primitive kinds (docs/primitives.md). The EXTRUDE_ and REVOLVE_ kinds are
 * 2D profiles in the xy plane extruded along z by half_depth, or revolved
 * about the y axis with the profile's origin offset from the axis. */

enum bc_prim {
	BC_PRIM_INVALID = 0,
	BC_PRIM_SPHERE,
	BC_PRIM_BOX,
	BC_PRIM_CAPSULE,
	BC_PRIM_CYLINDER,
	BC_PRIM_TORUS,
	BC_PRIM_CONE,
	BC_PRIM_ROUND_CONE,
	BC_PRIM_ELLIPSOID,
	BC_PRIM_HEX_PRISM,
	BC_PRIM_OCTAHEDRON,
	BC_PRIM_BOX_FRAME,
	BC_PRIM_CAPPED_TORUS,
	BC_PRIM_LINK,
	BC_PRIM_SOLID_ANGLE,
	BC_PRIM_PYRAMID,
	BC_PRIM_TRI_PRISM,
	BC_PRIM_CUT_SPHERE,
	BC_PRIM_CUT_HOLLOW_SPHERE,
	BC_PRIM_DEATH_STAR,
	BC_PRIM_ROUNDED_CYLINDER,
	BC_PRIM_CAPPED_CYLINDER,
	BC_PRIM_CAPPED_CONE,
	BC_PRIM_RHOMBUS,
	BC_PRIM_VESICA_SEGMENT,
	BC_PRIM_EXTRUDE_CIRCLE,
	BC_PRIM_EXTRUDE_RECT,
	BC_PRIM_EXTRUDE_POLYGON,
	BC_PRIM_EXTRUDE_STAR,
	BC_PRIM_REVOLVE_CIRCLE,
	BC_PRIM_REVOLVE_RECT,
	BC_PRIM_REVOLVE_POLYGON,
	BC_PRIM_REVOLVE_STAR,
	BC_PRIM_COUNT
};

/* Binary operators 1..6, then the unary and domain nodes 7..14: exactly
 * one child each (docs/scene-format.md, "Unary and domain nodes"), their
 * parameters in struct bc_unary's u[]. */
enum bc_op {
	BC_OP_INVALID = 0,
	BC_OP_UNION,
	BC_OP_INTERSECTION,
	BC_OP_DIFFERENCE,
	BC_OP_SMOOTH_UNION,
	BC_OP_SMOOTH_INTERSECTION,
	BC_OP_SMOOTH_DIFFERENCE,
	BC_OP_OFFSET,   /* u[0] amount: f - amount */
	BC_OP_ONION,    /* u[0] thickness: |f| - thickness */
	BC_OP_ELONGATE, /* u[0..2] half extents h: child at p - clamp(p to h) */
	BC_OP_TWIST,    /* u[0] rate: child at rot_y(rate y) p */
	BC_OP_BEND,     /* u[0] rate: child at rot_z(rate x) p (opCheapBend) */
	BC_OP_MIRROR,   /* u[0] axes mask 1..7 (x 1 y 2 z 4): child at |p| */
	BC_OP_REPEAT,   /* u[0..2] spacing and u[3..5] count (opRepLim) */
	BC_OP_SCALE,    /* u[0] factor: factor child(p / factor) */
	BC_OP_COUNT
};

#define BC_OP_FIRST_UNARY BC_OP_OFFSET
/* Floats of a unary node's parameters (repeat: spacing[3], count[3]). */
#define BC_UNARY_MAX_PARAMS 6
/* Copies per axis a repeat node may make: a count is an integer in
 * 1..BC_REPEAT_MAX_COUNT, so the copies' union box stays meaningful. */
#define BC_REPEAT_MAX_COUNT 4096
/* Domain nodes (elongate, twist, bend, mirror, repeat, scale) on any path
 * from the root to a primitive: every evaluator maps a primitive's point
 * through them with a fixed array of this size (also in the shaders). */
#define BC_DOMAIN_MAX_CHAIN 32u

/* How an operator selects an operand when the other is missing (outside all
 * its ABVs, i.e. treated as +inf): the paper's ignoreMod. */
enum bc_op_class {
	BC_OPCLASS_UNION = 0,        /* pass the present operand through */
	BC_OPCLASS_INTERSECTION = 1, /* the node itself becomes missing */
	BC_OPCLASS_DIFFERENCE = 2,   /* left missing: missing; right: pass */
};

/* ---- Primitive descriptions (blobtree/prim.c) --------------------------- */

enum bc_param_flags {
	BC_PARAM_OPTIONAL = 1u << 0, /* may be absent: takes def */
	BC_PARAM_POSITIVE = 1u << 1, /* every component > 0 */
	BC_PARAM_NONNEG = 1u << 2,   /* every component >= 0 */
};

/* One named parameter of a primitive: `count` floats at params[offset]. */
struct bc_param_desc {
	const char *name; /* scene-file key, e.g. "half_extents" */
	uint8_t offset;
	uint8_t count; /* 1 or 3 */
	uint8_t flags; /* enum bc_param_flags */
	float def;     /* default of every component when optional */
};

struct bc_prim_info {
	const char *name; /* scene-file "type", e.g. "round_cone" */
	uint8_t nparams;
	const struct bc_param_desc *params;
	bool exact; /* the field is the exact Euclidean distance */
};

/* Returns the description of kind, or NULL when kind is out of range. */
BC_API const struct bc_prim_info *bc_prim_info(enum bc_prim kind);
/* Returns the kind named name ("sphere"), or BC_PRIM_INVALID. */
BC_API enum bc_prim bc_prim_from_name(const char *name);

/* ---- Operators (blobtree/ops.c) ----------------------------------------- */

/* Returns "union", "smooth_union", ... or NULL when out of range. */
BC_API const char *bc_op_name(enum bc_op kind);
BC_API enum bc_op bc_op_from_name(const char *name);
BC_API enum bc_op_class bc_op_class(enum bc_op kind);
BC_API bool bc_op_is_smooth(enum bc_op kind);
/* Unary nodes (one child): offset .. scale. */
BC_API bool bc_op_is_unary(enum bc_op kind);
/* Unary nodes that map the point their subtree sees (all but offset and
 * onion). */
BC_API bool bc_op_is_domain(enum bc_op kind);
/* Unary nodes that change the value their child returns (offset, onion,
 * twist, bend, scale); the others pass it through. */
BC_API bool bc_op_has_value(enum bc_op kind);

/* One named parameter of a unary node: `count` floats at u[offset]. */
struct bc_unary_info {
	const char *name;  /* "offset" */
	uint8_t nparams;   /* floats */
	const char *param; /* scene-file key of u[0..nparams) ("spacing" and
	                      "count" for repeat: two keys of 3) */
};
/* Returns the description of a unary kind, NULL for any other kind. */
BC_API const struct bc_unary_info *bc_unary_info(enum bc_op kind);

/* Evaluates operator kind on operands f0 (left) and f1 (right). blend = β
 * and range = r_o (paper eq. 8-18) are ignored by the sharp operators.
 * Either operand may be +INFINITY (a missing operand): the result is then
 * the operand selection of enum bc_op_class. Never returns NaN for non-NaN
 * inputs. */
BC_API float bc_op_eval(enum bc_op kind, float blend, float range, float f0,
                        float f1);

/* The sharp union's and intersection's values: fminf's and fmaxf's (the
 * other operand where one is NaN) without their library calls, which GCC
 * makes unless told that no NaN or signed zero occurs. bc_op_eval's, and
 * the svo lanes' (written as selects, so loops of them vectorize). */
static inline float bc_op_min(float a, float b)
{
	return ((b < a) | (a != a)) ? b : a;
}
static inline float bc_op_max(float a, float b)
{
	return ((b > a) | (a != a)) ? b : a;
}

/* ---- Model data -------------------------------------------------------- */

struct bc_prim_data {
	enum bc_prim kind;
	float params[BC_PRIM_MAX_PARAMS]; /* laid out by bc_prim_info */
	float translate[3];
	float rotate[4]; /* unit quaternion (x, y, z, w) */
	float color[3];  /* linear RGB in [0, 1] */
	bool has_color;
};

struct bc_op_data {
	enum bc_op kind;
	float blend; /* β > 0 for smooth operators, 0 otherwise */
	float range; /* r_o > blend / 6; continuous for r_o >= 7/6 blend */
};

/* A unary or domain node: its kind (BC_OP_OFFSET .. BC_OP_SCALE) and its
 * parameters (enum bc_op's comments; unused floats 0). bc_tree_get reports
 * such a node as an operator of that kind with blend and range 0. */
struct bc_unary {
	enum bc_op kind;
	float u[BC_UNARY_MAX_PARAMS];
};

/* Mirror axes: "x", "yz", "xyz"... (each letter at most once, any order)
 * to the mask 1..7, 0 when s is not such a string; and back ("x", "xy",
 * in x, y, z order; out holds 4 bytes). */
BC_API uint32_t bc_mirror_axes_parse(const char *s);
BC_API void bc_mirror_axes_name(uint32_t mask, char out[4]);

/* Sets *u to kind's defaults (offset 0.1, onion 0.05, elongate 0.5 0 0,
 * twist 1, bend 0.5, mirror x, repeat spacing 2 and count 3 1 1, scale 1;
 * docs/scene-format.md). kind must be unary. */
BC_API void bc_unary_init(struct bc_unary *u, enum bc_op kind);
/* Checks a unary node's parameters: finite, |values| <= BC_PARAM_MAX_ABS,
 * onion thickness >= 0, elongate half extents >= 0, mirror axes an integer
 * 1..7, repeat counts integers 1..BC_REPEAT_MAX_COUNT with spacing > 0 on
 * each axis whose count exceeds 1 (and >= 0 elsewhere), scale factor > 0
 * and >= 1e-3. Returns 0, BC_EENUM, BC_ERANGE or BC_ENONFINITE. */
BC_API int bc_unary_validate(const struct bc_unary *u, struct bc_errinfo *ei);

/* Sets *p to a primitive of kind with every parameter at its default (a
 * valid unit-sized shape, docs/primitives.md), identity transform and no
 * colour. */
BC_API void bc_prim_data_init(struct bc_prim_data *p, enum bc_prim kind);

/* The default r_o of a smooth operator with blend β when the scene gives
 * none: r_o = β, the smallest range for which G is continuous (docs). */
BC_API float bc_op_default_range(float blend);

/* Checks a primitive's or operator's parameters against the limits (finite,
 * positive sizes, |values| <= BC_PARAM_MAX_ABS, unit quaternion within 1e-3
 * -- which is then renormalized --, shape-specific rules). Returns 0,
 * BC_EENUM (unknown kind), BC_ERANGE or BC_ENONFINITE with the reason in
 * ei. */
BC_API int bc_prim_validate(struct bc_prim_data *p, struct bc_errinfo *ei);
BC_API int bc_op_validate(const struct bc_op_data *op, struct bc_errinfo *ei);

/* ---- Augmented bounding volumes ---------------------------------------- */

enum bc_abv_shape {
	BC_ABV_INVALID = 0,
	BC_ABV_SPHERE,
	BC_ABV_BOX, /* oriented box */
	BC_ABV_CAPSULE,
	BC_ABV_SHAPE_COUNT
};

/* A bounding shape, in a primitive's local frame (bc_prim_bound) or in world
 * space (an ABV: already transformed and offset by the ROI's upper bound). */
struct bc_abv {
	enum bc_abv_shape shape;
	float center[3]; /* sphere and box centre, capsule end a */
	/* One shape's, sharing their room: a layout keeps an ABV per
	 * primitive (68 bytes, not 80). */
	union {
		float end[3];  /* capsule end b */
		float half[3]; /* box half extents */
	};
	float axis[3][3]; /* box: unit axes (rows) */
	float radius;     /* sphere and capsule radius */
};

/* Writes the local-frame bounding shape of primitive p (untransformed). */
BC_API void bc_prim_bound(const struct bc_prim_data *p, struct bc_abv *out);
/* Writes the world AABB of a world-space bounding shape. */
BC_API void bc_abv_aabb(const struct bc_abv *abv, float lo[3], float hi[3]);
/* Clips the ray o + t d (d unit) against the shape. Returns true and the
 * entry/exit parameters (t0 may be negative when o is inside) on a hit; a
 * shape wholly behind the origin is a miss. */
BC_API bool bc_abv_ray(const struct bc_abv *abv, const float o[3],
                       const float d[3], float *t0, float *t1);
/* Returns true when the shape may meet the axis-aligned box [lo, hi]
 * (conservative: never false when they meet). */
BC_API bool bc_abv_meets_box(const struct bc_abv *abv, const float lo[3],
                             const float hi[3]);

/* ---- Primitive fields (blobtree/prim.c) -------------------------------- */

/* Packs p's shape parameters into the BC_PRIM_PACKED floats the evaluator
 * reads (derived values such as sines are precomputed here). */
BC_API void bc_prim_pack(const struct bc_prim_data *p,
                         float packed[BC_PRIM_PACKED]);
/* Field of primitive kind at local point (x, y, z), from packed data. Exact
 * SDF where bc_prim_info says so; otherwise a bound that is never below the
 * exact distance to the shape's bounding volume (so ABVs stay valid). */
BC_API float bc_prim_sdf(enum bc_prim kind, const float packed[BC_PRIM_PACKED],
                         float x, float y, float z);

/* ---- Camera ------------------------------------------------------------ */

struct bc_camera {
	float eye[3];
	float target[3];
	float up[3];
	float fov_y_deg; /* vertical field of view, (0, 180) */
};

/* The default camera (eye (0,0,6) looking at the origin, up +y, 45 deg). */
BC_API void bc_camera_default(struct bc_camera *cam);
/* Returns 0 or BC_ERANGE when eye == target, up is parallel to the view
 * direction, or the fov is outside (0, 180). */
BC_API int bc_camera_validate(const struct bc_camera *cam,
                              struct bc_errinfo *ei);

/* A camera prepared for an image size: ray for pixel (i, j), j counted from
 * the top row, passes through the pixel centre; directions are unit. */
struct bc_view_rays {
	float eye[3];
	float forward[3], right[3], up[3]; /* orthonormal */
	float tan_half_y, aspect;          /* of the whole view */
	uint32_t width, height;            /* of the whole view */
	/* The window drawn, in pixels of the whole view: (x0, y0) is the
	 * window's top-left pixel; both 0 for the whole view. */
	uint32_t x0, y0;
};
BC_API void bc_view_rays_init(struct bc_view_rays *vr,
                              const struct bc_camera *cam, uint32_t width,
                              uint32_t height);
/* bc_view_rays_init for the window at (x0, y0) of a width x height view
 * (a tile of a big picture): pixel (i, j) of the window gets the ray of
 * pixel (x0 + i, y0 + j) of the view. */
BC_API void bc_view_rays_init_window(struct bc_view_rays *vr,
                                     const struct bc_camera *cam,
                                     uint32_t width, uint32_t height,
                                     uint32_t x0, uint32_t y0);
/* Direction for the (fractional) pixel coordinate (x, y) of the window:
 * pixel centres are at (i + 0.5, j + 0.5). */
BC_API void bc_view_rays_dir(const struct bc_view_rays *vr, float x, float y,
                             float dir[3]);

/* ---- The tree ---------------------------------------------------------- */

struct bc_tree;

/* Returns a new empty tree, or NULL on allocation failure. Free with
 * bc_tree_destroy (which accepts NULL). */
BC_API struct bc_tree *bc_tree_create(void);
BC_API void bc_tree_destroy(struct bc_tree *t);
/* A tree is laid out for the renderers (bc_tree_lin) unless told not to.
 * A bare tree (on = false) keeps the model alone: everything but the
 * layout works as before (bc_tree_lin and bc_tree_slot answer NULL and
 * BC_NONE), at well under half the memory, and a structural edit costs
 * the model's change alone (no layout spliced or rebuilt). A server
 * session's tree is bare; its render copy is laid out. Only an empty tree
 * changes (BC_ESTATE otherwise); it keeps the choice through
 * bc_tree_begin and as bc_tree_copy's destination, and bc_tree_swap
 * exchanges it with the contents. */
BC_API int bc_tree_set_layout(struct bc_tree *t, bool on);
BC_API bool bc_tree_lays_out(const struct bc_tree *t);

/*
 * Building, in pre-order: bc_tree_begin() clears the tree; then operators are
 * opened with bc_tree_push_op(), their children given (primitives with
 * bc_tree_put_prim(), nested operators), and closed with bc_tree_pop_op();
 * bc_tree_end() checks the whole and linearizes. id 0 asks for a fresh id.
 * A tree with a single primitive and no operator is valid.
 * Each returns 0 or an error with the reason in ei; after an error the
 * builder must be restarted with bc_tree_begin().
 */
BC_API int bc_tree_begin(struct bc_tree *t);
BC_API int bc_tree_push_op(struct bc_tree *t, uint32_t id,
                           const struct bc_op_data *op, struct bc_errinfo *ei);
BC_API int bc_tree_pop_op(struct bc_tree *t, struct bc_errinfo *ei);
/* Opens a unary node (closed with bc_tree_pop_op, which then requires
 * exactly one child: a primitive or any subtree). */
BC_API int bc_tree_push_unary(struct bc_tree *t, uint32_t id,
                              const struct bc_unary *u, struct bc_errinfo *ei);
BC_API int bc_tree_put_prim(struct bc_tree *t, uint32_t id,
                            const struct bc_prim_data *p,
                            struct bc_errinfo *ei);
BC_API int bc_tree_end(struct bc_tree *t, struct bc_errinfo *ei);

/* Does any node carry an id the tree assigned (the scene gave 0)? */
BC_API bool bc_tree_has_auto_ids(const struct bc_tree *t);

/* Counts of the model: scene nodes, primitives, operators. */
BC_API uint32_t bc_tree_node_count(const struct bc_tree *t);
BC_API uint32_t bc_tree_prim_count(const struct bc_tree *t);
/* What the scene encoding's size follows besides the node counts, in O(1):
 * the primitives that carry a colour, and the shape floats of every
 * primitive (bc_scene_prim_nfloats of each). Out-parameters may be NULL. */
BC_API void bc_tree_counts(const struct bc_tree *t, uint32_t *colored,
                           uint64_t *floats);
/* Nodes on the longest path from the root (the root counting 1), 0 for an
 * empty tree. */
BC_API uint32_t bc_tree_nesting(const struct bc_tree *t);
/* Returns the root's id, 0 for an empty tree. */
BC_API uint32_t bc_tree_root(const struct bc_tree *t);

/* Reading the model (for writers and encoders). Returns false if id is
 * unknown. Exactly one of prim/op is filled (the other's kind set to
 * INVALID); out-parameters may be NULL. */
BC_API bool bc_tree_get(const struct bc_tree *t, uint32_t id,
                        struct bc_prim_data *prim, struct bc_op_data *op);
/* Number of children of id (0 for primitives and unknown ids) and the id of
 * child k (0 when out of range). */
BC_API uint32_t bc_tree_child_count(const struct bc_tree *t, uint32_t id);
BC_API uint32_t bc_tree_child(const struct bc_tree *t, uint32_t id, uint32_t k);
/* Position of node id among its parent's children (0 for the root or an
 * unknown id); O(1) from the layout, as bc_tree_child(parent, k) == id. */
BC_API uint32_t bc_tree_child_index(const struct bc_tree *t, uint32_t id);
/* Returns the parent's id, 0 for the root or an unknown id. */
BC_API uint32_t bc_tree_parent(const struct bc_tree *t, uint32_t id);
/* Returns node id's top slot in the linearized form (an n-ary operator's
 * last fold slot), BC_NONE for an unknown id. Its primitives are the
 * indices bc_lin_first_prim(l, slot) .. + (slot - bc_lin_first(l, slot)) / 2.
 */
BC_API uint32_t bc_tree_slot(const struct bc_tree *t, uint32_t id);
/* The world box [lo, hi] of node id's surface: the AABB of the ABVs that
 * a layout of t gives the primitives of its subtree (the same floats),
 * read from the model, so a bare tree answers too (bounds.c); O(the
 * subtree and the path to the root). A unary node's box is its
 * subtree's. Returns 0, BC_ENOTFOUND (no such id), BC_ERANGE (no finite
 * box: no primitive) or BC_ENOMEM. */
BC_API int bc_tree_node_box(const struct bc_tree *t, uint32_t id, float lo[3],
                            float hi[3]);

/* ---- Names -------------------------------------------------------------- */

/* A node may carry a name (PROTOCOL.md 8: a label people give it, never an
 * address): 1..BC_TREE_NAME_MAX bytes of strict UTF-8 without NUL. Names
 * need not be unique. Removing a node takes its name; a grafted subtree
 * (insert, replace, copy) brings its own. */
#define BC_TREE_NAME_MAX 64u

/* Node id's name, NUL-terminated, or NULL when it has none (or id is
 * unknown). Valid until the next change of t's names. */
BC_API const char *bc_tree_name(const struct bc_tree *t, uint32_t id);
/* Names node id (also while building, once the node is added); len 0 takes
 * its name away. Returns 0, BC_ENONODE, BC_ERANGE (over BC_TREE_NAME_MAX
 * bytes), BC_ESTRING (not strict UTF-8, or a NUL) or BC_ENOMEM. */
BC_API int bc_tree_set_name(struct bc_tree *t, uint32_t id, const char *name,
                            size_t len, struct bc_errinfo *ei);
BC_API uint32_t bc_tree_name_count(const struct bc_tree *t);
/* The ids of the named nodes, increasing, into a bc_malloc'd array the
 * caller bc_free's (*n set; NULL with *n 0 when none, or out of memory:
 * then *n is the count). */
BC_API uint32_t *bc_tree_name_ids(const struct bc_tree *t, uint32_t *n);
/* A tree keeps its nodes' names unless told not to (keep = false): then
 * bc_tree_set_name checks its arguments as before and keeps nothing,
 * grafts and copies bring none, and bc_tree_name answers NULL. A server's
 * render copy, which nothing asks for names, keeps none (a name costs
 * some 90 bytes with its map entry). Only an empty tree changes
 * (BC_ESTATE otherwise); it keeps the choice as bc_tree_set_layout's. */
BC_API int bc_tree_set_names(struct bc_tree *t, bool keep);

/* ---- Edits -------------------------------------------------------------- */

/* Replaces the parameters of primitive id (kind must be unchanged). Only its
 * parameter record and ABV are rewritten. */
BC_API int bc_tree_set_prim(struct bc_tree *t, uint32_t id,
                            const struct bc_prim_data *p,
                            struct bc_errinfo *ei);
/* Replaces the parameters of operator id; the kind may change among
 * operators (the subtree's ROIs and ABVs are recomputed, the layout stays). */
BC_API int bc_tree_set_op(struct bc_tree *t, uint32_t id,
                          const struct bc_op_data *op, struct bc_errinfo *ei);
/* Replaces the parameters of unary node id; the kind may change among the
 * unary kinds. Rewrites its record, then the ROIs and ABVs of its subtree
 * and the Lipschitz bounds of its domain ancestors (the layout stays). */
BC_API int bc_tree_set_unary(struct bc_tree *t, uint32_t id,
                             const struct bc_unary *u, struct bc_errinfo *ei);
/* Reads unary node id into *out. Returns false (out zeroed) when id is not
 * a unary node. */
BC_API bool bc_tree_get_unary(const struct bc_tree *t, uint32_t id,
                              struct bc_unary *out);

/* Inserts a copy of the whole of sub as child number pos of operator
 * parent_id (pos may equal the child count: append). Ids of sub must not
 * exist in t (BC_EDUPID); sub's ids are kept. Splices the subtree into the
 * layout (blobtree/splice.c; re-linearizes when t or sub has unary
 * nodes). */
BC_API int bc_tree_insert(struct bc_tree *t, uint32_t parent_id, uint32_t pos,
                          const struct bc_tree *sub, struct bc_errinfo *ei);
/* Removes node id and its subtree. An operator left with one child is
 * replaced by that child (operators always have two or more). Removing the
 * root empties the tree. Splices the layout (re-linearizes when t has
 * unary nodes). */
BC_API int bc_tree_remove(struct bc_tree *t, uint32_t id,
                          struct bc_errinfo *ei);
/* Replaces node id (and its subtree) with a copy of sub at the same place.
 * sub's ids must be new to t, except that sub's root may reuse id. Splices
 * the layout (re-linearizes for the root, or with unary nodes). */
BC_API int bc_tree_replace(struct bc_tree *t, uint32_t id,
                           const struct bc_tree *sub, struct bc_errinfo *ei);
/* Lays t out again from its model, as a whole (what every structural edit
 * did before INSERT and REMOVE learned to splice the layout; benches and
 * tests compare the two). Returns 0 or BC_ENOMEM (t as it was). */
BC_API int bc_tree_relayout(struct bc_tree *t, struct bc_errinfo *ei);
/* Exchanges the contents of a and b (model, layout, names, dirty state)
 * in O(1): a caller that edits a tree in place can hand the result out as
 * another object and keep the first, emptied, as the one it replaced. */
BC_API void bc_tree_swap(struct bc_tree *a, struct bc_tree *b);
/* Copies the whole tree src into dst (dst is cleared first, and laid out
 * unless it is bare). */
BC_API int bc_tree_copy(struct bc_tree *dst, const struct bc_tree *src,
                        struct bc_errinfo *ei);

/* Primitives [at, at + del) became [at, at + ins); those past them moved
 * by ins - del. */
struct bc_dirty_splice {
	uint32_t at, del, ins;
};
/* Moves the half-open range [*lo, *hi) of primitive indices through sp:
 * indices past the splice shift with it, those it removed drop out, and a
 * range it empties becomes [0, 0). */
static inline void bc_dirty_splice_range(const struct bc_dirty_splice *sp,
                                         uint32_t *lo, uint32_t *hi)
{
	uint32_t end = sp->at + sp->del;
	if (*lo >= *hi) {
		return;
	}
	*lo = *lo < sp->at ? *lo : *lo < end ? sp->at : *lo - sp->del + sp->ins;
	*hi = *hi <= sp->at ? *hi
	      : *hi < end   ? sp->at
	                    : *hi - sp->del + sp->ins;
	if (*lo >= *hi) {
		*lo = *hi = 0;
	}
}

/* Splices and gone ABVs one dirty record holds; past either, spliced is
 * cleared (everything changed). */
#define BC_DIRTY_SPLICES 16
#define BC_DIRTY_GONE 64

/*
 * What changed since the last bc_tree_take_dirty(): ranges are half-open,
 * [lo, hi) with lo == hi meaning nothing; structure means everything.
 *
 * A structural change made only of splices (INSERT, REMOVE and REPLACE on
 * a tree without unary nodes, splice.c) also says what it did, so that a
 * renderer keeping state per primitive can follow it and redraw only
 * what it can change (spliced true): the splices of the primitives'
 * indices in the order made, and the world ABVs that went (removed
 * primitives', and the old ABVs of those placed again). [prim_lo,
 * prim_hi) then also covers, in the indices after, every inserted
 * primitive and every primitive whose pixels the change can reach
 * outside those ABVs (the whole subtree of an intersection or difference
 * that gained or lost an operand). A pixel can change only where the
 * gone ABVs or the new ABVs of [prim_lo, prim_hi) reach.
 */
struct bc_dirty {
	bool structure; /* laid out again or spliced: upload everything */
	bool spliced;   /* structure changed by the splices below alone */
	uint32_t slot_lo, slot_hi;   /* node words (an operator kind changed) */
	uint32_t param_lo, param_hi; /* parameter records, in vec4 units */
	uint32_t prim_lo, prim_hi;   /* primitives whose ABV changed */
	uint32_t edits;              /* edits applied since the last take */
	uint32_t nsplices, ngone;
	struct bc_dirty_splice splice[BC_DIRTY_SPLICES];
	struct bc_abv gone[BC_DIRTY_GONE];
};
BC_API void bc_tree_take_dirty(struct bc_tree *t, struct bc_dirty *out);
/* What bc_tree_take_dirty() would take now, left in place. */
BC_API const struct bc_dirty *bc_tree_dirty(const struct bc_tree *t);

/* ---- The linearized form (read-only for renderers) --------------------- */

/* GPU node word (paper §7), most significant bit first:
 * isLeaf(1) isLeft(1) type(8) ancestor(22). For operators type is
 * ignoreMod(2) isUnary(1) nodeop(5). */
#define BC_WORD_LEAF (1u << 31)
#define BC_WORD_LEFT (1u << 30)
#define BC_WORD_TYPE_SHIFT 22
#define BC_WORD_TYPE_MASK 0xffu
#define BC_WORD_ANCESTOR_MASK 0x3fffffu
#define BC_WORD_NO_ANCESTOR BC_WORD_ANCESTOR_MASK

/* Parameter record sizes, in vec4 (16-byte) units. A primitive's record is
 * the world-to-local affine map (three rows: R^T and -R^T t) followed by
 * its packed shape data, except a sphere's: (centre, radius), one vec4, as
 * no rotation moves a sphere (a million spheres keep 64 MB less). An
 * operator's is (blend, range, 0, 0). A leaf's size follows from its kind
 * (bc_prim_record_vec4), which its node word holds. */
#define BC_PRIM_RECORD_VEC4 5
#define BC_SPHERE_RECORD_VEC4 1
#define BC_OP_RECORD_VEC4 1

static inline uint32_t bc_prim_record_vec4(uint32_t kind)
{
	return kind == BC_PRIM_SPHERE ? BC_SPHERE_RECORD_VEC4
	                              : BC_PRIM_RECORD_VEC4;
}

/* Writes primitive kind's record rec in the long form (affine rows, then
 * packed shape: 4 * BC_PRIM_RECORD_VEC4 floats) into out: a sphere's as
 * the identity rows, minus its centre, and its radius. */
BC_API void bc_prim_record_long(uint32_t kind, const float *rec,
                                float out[4 * BC_PRIM_RECORD_VEC4]);

struct bc_lin {
	uint32_t count;  /* linearized (binary) nodes, post-order slots */
	uint32_t nprims; /* primitives, in post-order */
	/* Per slot. */
	uint32_t *node; /* 2 per slot: GPU node word, parameter offset */
	/* An operator slot's leftmost slot of its subtree, a leaf slot's
	 * primitive index (a leaf is its own first slot, an operator has no
	 * primitive: one array, not two, 8 bytes a primitive). Read it
	 * through bc_lin_first() and bc_lin_prim(). */
	uint32_t *lead;
	uint32_t *fast; /* paper's fast ancestor: top of the run of same-side
	                   edges above the slot, BC_NONE at the root */
	uint32_t *jump; /* skew-binary jump pointer, BC_NONE at the root */
	/* Number of operand-killing edges up to the root (the right operand
	 * of a difference, either of an intersection): NULL in a layout
	 * whose tree has no intersection or difference, where every count
	 * is 0 (8 bytes a primitive for the union-only scenes big scenes
	 * mostly are). Read it through bc_lin_kills(). */
	uint32_t *kills;
	uint32_t *depth;   /* binary depth, 0 at the root */
	uint32_t *node_id; /* stable id of the scene node it comes from */
	/* Per slot: the ROI [r-, r+] (paper eq. 13-16). r- is NULL where
	 * every r- is 0 (a layout without intersection, difference or unary
	 * node: 4 bytes a slot); read it through bc_lin_roi_lo(). */
	float *roi_lo, *roi_hi;
	/* Per primitive. */
	uint32_t *prim_slot; /* slot of primitive k */
	/* World ABV of primitive k: read it through bc_lin_abv(). A layout
	 * of spheres alone, without unary nodes, whose ABVs are all spheres,
	 * keeps their centres and radii in sabv (16 bytes a primitive) and
	 * abv is NULL; any other keeps the whole ABV in abv (68 bytes) and
	 * sabv is NULL. */
	struct bc_abv *abv;
	float (*sabv)[4];
	float (*color)[3]; /* colour of primitive k */
	/* Parameter records: vec4 stride, nparam vec4s. */
	float *param;
	uint32_t nparam;
	/* AABB of every ABV (the volume rays must cross), and its diagonal. */
	float lo[3], hi[3];
	float size;
	/* Stack entries a full evaluation needs (<= BC_EVAL_STACK), and the
	 * model's nesting (nodes on the longest path, the root counting 1). */
	uint32_t stack;
	uint32_t nesting;

	/*
	 * Unary and domain nodes (docs/scene-format.md). They take no slot:
	 * unary node u wraps the value of slot unary_slot[u] (the top slot of
	 * its child); the wrappers of one slot chain innermost first through
	 * unary_outer. Domain nodes map the point every slot below them sees:
	 * a slot's point is the world point mapped through dom[slot], then
	 * unary_dom[...] outward, applied outermost first. Records are
	 * BC_UNARY_RECORD_VEC4 vec4s (bc_unary_record_* below).
	 */
	uint32_t nunary;
	/* The per-slot arrays are NULL in a layout of a tree without unary
	 * or domain nodes (every entry would be BC_NONE, or 0): read them
	 * through bc_lin_wrap() and the like below, or after checking
	 * nunary. */
	uint32_t *wrap;     /* per slot: innermost wrapper, BC_NONE */
	uint32_t *wrap_top; /* per slot: outermost wrapper, BC_NONE */
	uint32_t *dom;      /* per slot: innermost domain node around it */
	uint32_t *ucount;   /* per slot: ancestors whose wrappers change the
	                       value (offset, onion, twist, bend, scale); a
	                       sparse climb may not jump over them */
	uint32_t *unary_slot, *unary_outer, *unary_inner, *unary_dom;
	uint32_t *unary_param; /* record offset, vec4 units */
	uint32_t *unary_kind;  /* enum bc_op */
	uint32_t *unary_id;    /* stable id */
	/* A splice's scratch (blobtree/splice.c): one bit a slot, all clear
	 * between edits. */
	uint64_t *marks;
	/* Lipschitz bound of the whole field relative to its primitives' own
	 * (1 without twist or bend; docs/scene-format.md): the tracers divide
	 * every step by it. */
	float lip;
};

/* Unary record (2 vec4): the parameters u[0..5], except twist and bend:
 * (rate, R, L, r+, 0...) with R the radius about the axis of the child's
 * ABVs in the node's frame, L the Lipschitz bound of the node's value
 * (its own map's within R times its subtree's) and r+ the child's ROI
 * bound; scale: (factor, 1 / factor). */
#define BC_UNARY_RECORD_VEC4 2

/* Returns the tree's linearized form (valid until the next structural edit;
 * parameter edits update it in place). NULL for an empty tree. */
BC_API const struct bc_lin *bc_tree_lin(const struct bc_tree *t);

static inline uint32_t bc_lin_parent(const struct bc_lin *l, uint32_t slot)
{
	uint32_t a = l->node[2 * slot] & BC_WORD_ANCESTOR_MASK;
	return a == BC_WORD_NO_ANCESTOR ? BC_NONE : a;
}
/* Slot s's innermost and outermost wrappers, its innermost domain node
 * (BC_NONE for none) and its count of value-changing ancestors (struct
 * bc_lin's per-slot unary arrays, which a layout without unary nodes
 * does not keep). */
static inline uint32_t bc_lin_wrap(const struct bc_lin *l, uint32_t s)
{
	return l->wrap ? l->wrap[s] : BC_NONE;
}
static inline uint32_t bc_lin_wrap_top(const struct bc_lin *l, uint32_t s)
{
	return l->wrap_top ? l->wrap_top[s] : BC_NONE;
}
static inline uint32_t bc_lin_dom(const struct bc_lin *l, uint32_t s)
{
	return l->dom ? l->dom[s] : BC_NONE;
}
static inline uint32_t bc_lin_ucount(const struct bc_lin *l, uint32_t s)
{
	return l->ucount ? l->ucount[s] : 0u;
}
static inline uint32_t bc_lin_kills(const struct bc_lin *l, uint32_t s)
{
	return l->kills ? l->kills[s] : 0u;
}
static inline float bc_lin_roi_lo(const struct bc_lin *l, uint32_t s)
{
	return l->roi_lo ? l->roi_lo[s] : 0.0f;
}
static inline bool bc_lin_is_leaf(const struct bc_lin *l, uint32_t slot)
{
	return (l->node[2 * slot] & BC_WORD_LEAF) != 0;
}
static inline uint32_t bc_lin_type(const struct bc_lin *l, uint32_t slot)
{
	return (l->node[2 * slot] >> BC_WORD_TYPE_SHIFT) & BC_WORD_TYPE_MASK;
}
/* Leftmost slot of slot's subtree (the slot itself for a leaf). */
static inline uint32_t bc_lin_first(const struct bc_lin *l, uint32_t slot)
{
	return bc_lin_is_leaf(l, slot) ? slot : l->lead[slot];
}
/* Primitive index of leaf slot `slot` (which must be a leaf). */
static inline uint32_t bc_lin_leaf_prim(const struct bc_lin *l, uint32_t slot)
{
	return l->lead[slot];
}
/* Primitive index of a leaf slot, BC_NONE for an operator's. */
static inline uint32_t bc_lin_prim(const struct bc_lin *l, uint32_t slot)
{
	return bc_lin_is_leaf(l, slot) ? l->lead[slot] : BC_NONE;
}
/* The first primitive of slot's subtree: its primitives are this one and
 * the (slot - bc_lin_first(l, slot)) / 2 after it. */
static inline uint32_t bc_lin_first_prim(const struct bc_lin *l, uint32_t slot)
{
	return l->lead[bc_lin_first(l, slot)];
}
/* Primitive k's world ABV. */
static inline struct bc_abv bc_lin_abv(const struct bc_lin *l, uint32_t k)
{
	if (l->abv) {
		return l->abv[k];
	}
	return (struct bc_abv){
	    .shape = BC_ABV_SPHERE,
	    .center = {l->sabv[k][0], l->sabv[k][1], l->sabv[k][2]},
	    .radius = l->sabv[k][3]};
}

/* Primitive kind of a leaf, operator kind of an operator slot. */
static inline uint32_t bc_lin_kind(const struct bc_lin *l, uint32_t slot)
{
	uint32_t type = bc_lin_type(l, slot);
	return bc_lin_is_leaf(l, slot) ? type : (type & 0x1fu);
}
static inline const float *bc_lin_param(const struct bc_lin *l, uint32_t slot)
{
	return l->param + 4u * (size_t)l->node[2 * slot + 1];
}

/* ---- Field evaluation (blobtree/eval.c) --------------------------------- */

/* Maps p, in place, through one domain node of kind `kind` (enum bc_op)
 * whose record is rec: from the node's frame to its child's. The one
 * implementation of these maps; the svo tape calls it too, so both
 * evaluators see the same point bit for bit. Other kinds leave p. */
BC_API void bc_domain_apply(uint32_t kind, const float *rec, float p[3]);
/* Maps world point p through the domain nodes from d (a unary index, or
 * BC_NONE: no map) outward: the point the slots below d see. */
BC_API void bc_domain_map(const struct bc_lin *l, uint32_t d, const float p[3],
                          float out[3]);
/* The value map of a unary node of kind `kind` whose record is rec, over
 * its child's value f; q is the point in the node's frame (the world
 * point mapped through the domain chain around it), read by twist and
 * bend only (bc_unary_reads_point). The one implementation; the svo tape
 * calls it too. Identity for the pure domain nodes. */
BC_API float bc_unary_apply(uint32_t kind, const float *rec, float f,
                            const float q[3]);
static inline bool bc_unary_reads_point(uint32_t kind)
{
	return kind == BC_OP_TWIST || kind == BC_OP_BEND;
}
/* Applies unary node u's value map to its child's value f at world point
 * p (identity for the pure domain nodes). */
BC_API float bc_unary_value(const struct bc_lin *l, uint32_t u, float f,
                            const float p[3]);

/* The Lipschitz bound of a twist or bend map (kind) of the given rate
 * within distance r of its axis. */
BC_API float bc_unary_own_lip(uint32_t kind, float rate, float r);

/* Field of primitive k (world point p), and of the whole tree. The _id
 * variants also return the primitive index that decides the value (the
 * operand each operator selects or weights most). */
BC_API float bc_eval_prim(const struct bc_lin *l, uint32_t k, const float p[3]);
BC_API float bc_eval_full(const struct bc_lin *l, const float p[3]);
BC_API float bc_eval_full_id(const struct bc_lin *l, const float p[3],
                             uint32_t *prim);

/* A pruned tree view (paper §6.2, Fig. 11): the straight-line program that
 * evaluates the field equivalent to the tree's inside the volume where only
 * the given primitives are active. Operators with a missing operand act as
 * selectors at build time and cost nothing at evaluation time. */
struct bc_view_instr {
	uint32_t slot;  /* slot of the leaf or operator; unary index */
	uint32_t param; /* parameter offset, vec4 units */
	uint16_t kind;  /* bc_prim or bc_op */
	uint8_t leaf;   /* 1 leaf, 0 binary operator, BC_VIEW_UNARY */
	uint8_t pad;
};
/* A view instruction that maps the top of the stack through a unary node
 * (offset, onion, twist, bend, scale; the others change no value). */
#define BC_VIEW_UNARY 2

struct bc_view {
	struct bc_view_instr *instr;
	uint32_t n, cap;
	uint32_t stack; /* entries the evaluation needs */
	bool empty;     /* every active primitive was pruned: field is +inf */
};

/* init/finish work on caller memory; finish accepts a zeroed view. */
BC_API void bc_view_init(struct bc_view *v);
BC_API void bc_view_finish(struct bc_view *v);
/* Builds the view for the active primitive indices active[0..n) (strictly
 * increasing). A missing subtree under a unary node leaves the node
 * missing; a present one is followed by the node's instruction. Cost is
 * O(n log depth) -- independent of tree size -- using the jump pointers,
 * plus one step per value-changing unary node on the way. Returns 0, BC_EINVAL
 * (unsorted or out of range) or BC_ENOMEM. */
BC_API int bc_view_build(struct bc_view *v, const struct bc_lin *l,
                         const uint32_t *active, uint32_t n);
/* Evaluates a view at p; +INFINITY for an empty view. */
BC_API float bc_view_eval(const struct bc_view *v, const struct bc_lin *l,
                          const float p[3]);
BC_API float bc_view_eval_id(const struct bc_view *v, const struct bc_lin *l,
                             const float p[3], uint32_t *prim);

/* Sparse evaluation in one call: builds a view of active[0..n) into scratch
 * (a bc_view reused by the caller) and evaluates it at p. */
BC_API float bc_eval_sparse(const struct bc_lin *l, const uint32_t *active,
                            uint32_t n, struct bc_view *scratch,
                            const float p[3]);

#endif
