/*
 * Adaptive CSG after Chulkov 2025: the blobtree as an RPN sequence whose
 * pruned variants are bitmasks (thesis §5.1-5.2), range arithmetic over
 * boxes and ray segments (IA, AA and revised AA, §4.3), pruning of a region
 * (§5.3, extended to the compact smooth operators outside their blend
 * range), a sparse voxel octree with a node-count threshold (§5.4) through
 * which points are evaluated, and interval ray casting through its leaves
 * (§5.6) with a secant refinement of the bracketed root.
 *
 * Everything here reads the linearized tree (struct bc_lin) once, when an
 * RPN is compiled from it, and copies what it needs: an RPN, and what is
 * built from it, stays valid after the tree changes (and describes the old
 * tree). docs/svo.md explains the design choices.
 */
#ifndef BLOBCAST_SVO_H
#define BLOBCAST_SVO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/render.h"

/* ---- Limits and defaults ------------------------------------------------ */

/* Default node-count threshold tau: a region whose pruned RPN has more
 * active terms than this is subdivided. The thesis finds the fastest
 * evaluation between 2 and 10 on its large scenes (§6.5). */
#define BC_SVO_DEFAULT_THRESHOLD 8u
/* Default and largest octree depth. The thesis fixes 15 for its tables;
 * 2^15 cells per axis is already far below float resolution of a scene a
 * few units wide at the leaves' corners, so deeper trees buy nothing. */
#define BC_SVO_DEFAULT_MAX_DEPTH 10u
#define BC_SVO_MAX_DEPTH 15u
/* Memory an octree may take (nodes, leaves and stored masks) before it stops
 * subdividing: the thesis's Many Gears at the smallest threshold needs
 * 3.5 GB, more than a render server should spend on one scene. Leaves made
 * after the budget is spent keep more terms than tau: slower, still exact. */
#define BC_SVO_DEFAULT_MAX_BYTES ((uint64_t)512u << 20)
/* The arithmetic of a range evaluator when none is asked for: interval
 * arithmetic. The octree chooses per scene (bc_svo_arith_default).
 * Measured side by side on our scenes it builds the same octrees 1.1-5.4
 * times faster than RevAA and traces frames through them up to 2.9 times
 * faster (docs/svo.md, docs/benchmarks.md); the thesis's opposite finding
 * rests on a costlier IA and on polynomial fields. */
#define BC_SVO_DEFAULT_ARITH BC_RANGE_IA
/* Largest uniform grid side (eval-bench --grid): 256^3 voxels of compressed
 * masks stay within a few hundred MB for the scenes we benchmark. */
#define BC_SVO_MAX_GRID 256u
/* Noise symbols an AA form keeps before the non-input ones are condensed
 * into a single fresh symbol (see docs/svo.md: without a cap the forms of a
 * long union chain grow with the tree and pruning becomes quadratic). */
#define BC_SVO_AA_MAX_TERMS 48u

/* The hit criterion of the ray caster, chosen equal to the CPU sphere
 * tracer's so that both renderers draw the same silhouettes: a ray hits
 * where the field drops below BC_SVO_HIT_LIPSCHITZ * max(BC_SVO_HIT_FOOTPRINT
 * * pixel angle * t, minimal step), the minimal step and the refinement
 * tolerance being fractions of the scene's diagonal. */
#define BC_SVO_HIT_LIPSCHITZ 1.45f
#define BC_SVO_HIT_FOOTPRINT 0.5f
#define BC_SVO_MIN_STEP_REL 1.0e-4f
#define BC_SVO_REFINE_REL 1.0e-5f

/* ---- RPN and bitmasks (rpn.c) ------------------------------------------- */

enum bc_svo_term_type {
	BC_SVO_TERM_INVALID = 0,
	BC_SVO_TERM_PRIM,  /* a primitive: pushes its field */
	BC_SVO_TERM_NEG,   /* negates the top of the stack */
	BC_SVO_TERM_OP,    /* a binary operator: pops two, pushes one */
	BC_SVO_TERM_UNARY, /* a unary node that changes its child's value
	                      (offset, onion, twist, bend, scale): maps the
	                      top of the stack */
	BC_SVO_TERM_TYPE_COUNT
};

/* One RPN term. Differences are compiled as a negation of the right operand
 * followed by the matching intersection (sharp or smooth: Zanni's G\ equals
 * G∩ of (f0, -f1) exactly), so a pruned variant can keep the negated right
 * operand alone -- the common case inside the left operand of a cut. */
struct bc_svo_term {
	uint8_t type; /* enum bc_svo_term_type */
	uint8_t kind; /* bc_prim for PRIM; BC_OP_UNION / _INTERSECTION or their
	                 smooth forms for OP */
	uint16_t pad;
	uint32_t first; /* first term of this term's subtree */
	uint32_t prim;  /* primitive index for PRIM, BC_NONE otherwise */
	uint32_t rec;   /* PRIM: offset of its record in rpn->rec (12 affine
	                   floats then BC_PRIM_PACKED shape floats); OP: offset
	                   of (blend, range); UNARY: the unary node's index
	                   (rpn->ukind, urec, udom) */
};

/* Floats of a unary node's record (blobtree's BC_UNARY_RECORD_VEC4). */
#define BC_SVO_UNARY_REC (4u * BC_UNARY_RECORD_VEC4)

/* Floats of a primitive record: world-to-local rows then packed shape. */
#define BC_SVO_PRIM_REC (12u + BC_PRIM_PACKED)

struct bc_svo_rpn {
	struct bc_svo_term *terms;
	uint32_t n;      /* terms */
	uint32_t nwords; /* 32-bit words of a dense bitmask */
	uint32_t nprims;
	uint32_t stack;     /* evaluation stack entries needed */
	float *rec;         /* records (see struct bc_svo_term.rec) */
	uint32_t *prim_id;  /* stable id of primitive k */
	float *prim_size;   /* half diagonal of primitive k's ABV box: the
	                       length scale of its field (rounding margins) */
	float (*color)[3];  /* colour of primitive k */
	uint32_t *steep;    /* dense mask of the terms that may make a
	                       variant steeper than 1-Lipschitz: primitives
	                       whose field is not an exact distance, smooth
	                       operators. A variant without any is
	                       1-Lipschitz (min, max and negation keep the
	                       bound), and the caster steps through it. */
	float lo[3], hi[3]; /* the tree's AABB (bc_lin lo/hi) */
	float size;         /* its diagonal */
	/* Unary and domain nodes (blobtree's bc_lin, copied): every unary
	 * node's kind, record and the domain node around it (the map of its
	 * input frame, BC_NONE); per primitive the innermost domain node
	 * around it (BC_NONE: the world point). A primitive's point is mapped
	 * through its chain, outermost first, as bc_domain_map does. */
	uint32_t nunary;
	uint8_t *ukind; /* enum bc_op */
	float *urec;    /* BC_SVO_UNARY_REC floats each */
	uint32_t *udom;
	uint32_t *prim_dom; /* NULL when nunary is 0 */
	float lip;          /* the tree's Lipschitz bound over its
	                       primitives' (bc_lin lip, 1 without twist or
	                       bend) */
};

/* Compiles the linearized tree l into *out (bc_svo_rpn_finish frees it).
 * Returns 0, BC_EINVAL (l NULL or empty), BC_EDEPTH (a stack deeper than
 * BC_EVAL_STACK) or BC_ENOMEM. */
int bc_svo_rpn_init(struct bc_svo_rpn *out, const struct bc_lin *l);
/* Frees an RPN; accepts a zeroed one. */
void bc_svo_rpn_finish(struct bc_svo_rpn *r);

/* Sets every bit of mask[0..nwords) that names a term (the unpruned
 * variant) and clears the padding bits of the last word. */
void bc_svo_mask_fill(const struct bc_svo_rpn *r, uint32_t *mask);
/* Number of set bits of mask[0..nwords). */
uint32_t bc_svo_mask_count(const uint32_t *mask, uint32_t nwords);

/* Thesis Alg. 5.2: the first set bit at or after i, or UINT32_MAX when there
 * is none below nwords * 32. The lowest bit of a word is found with the
 * de Bruijn multiplication, without branches. */
uint32_t bc_svo_bits_next(const uint32_t *mask, uint32_t nwords, uint32_t i);
/* The reverse walk: the last set bit at or before i, or UINT32_MAX when
 * there is none (i may be any value; bits at or beyond nwords*32 are not
 * read, the caller passes i < nwords * 32). */
uint32_t bc_svo_bits_prev(const uint32_t *mask, uint32_t i);

/* Thesis Alg. 5.5: clears the bits of the active subtree rooted at term i
 * (i itself and, walking backwards with bc_svo_bits_prev, every active term
 * its operands need). */
void bc_svo_rpn_clear_subtree(const struct bc_svo_rpn *r, uint32_t *mask,
                              uint32_t i);

/* Thesis Alg. 5.3: evaluates the variant selected by a dense mask at p;
 * +INFINITY for an empty mask. The _id form also returns the primitive
 * index that decides the value (as bc_eval_full_id does) or BC_NONE. */
float bc_svo_rpn_eval(const struct bc_svo_rpn *r, const uint32_t *mask,
                      const float p[3]);
float bc_svo_rpn_eval_id(const struct bc_svo_rpn *r, const uint32_t *mask,
                         const float p[3], uint32_t *prim);

/* ---- Compressed masks (rpn.c) ------------------------------------------- */

/* A stored variant: its non-zero mask words as (word index, bits) pairs in
 * increasing word order, so iteration costs the active terms only, however
 * long the RPN is (the dense form of a 30 000-term tree is 3.7 KB per
 * variant; thesis §7.2 names this cost). */
struct bc_svo_cmask {
	const uint32_t *pairs; /* 2 * nwords entries */
	uint32_t nwords;
};

float bc_svo_cmask_eval(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                        const float p[3]);
float bc_svo_cmask_eval_id(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                           const float p[3], uint32_t *prim);
/* The same at four points at once (the tetrahedral normal's samples):
 * out[j] equals bc_svo_cmask_eval at p[j], bit for bit. */
void bc_svo_cmask_eval4(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                        const float p[4][3], float out[4]);
/* The same at n points, n <= BC_SVO_PACKET (two normals' samples at
 * once, say): out[j] for j < n; more than BC_SVO_PACKET are not
 * evaluated (the first BC_SVO_PACKET are). */
void bc_svo_cmask_eval_n(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                         const float (*p)[3], uint32_t n, float *out);

/* ---- Range arithmetic (ia.c, aa.c, revaa.c) ----------------------------- */

/* A closed interval in double precision. Ranges computed here enclose the
 * values the single-precision point evaluator returns (bc_prim_sdf,
 * bc_op_eval) over the whole region: see docs/svo.md, "Rounding". */
struct bc_svo_ivl {
	double lo, hi;
};

/* The region a range is computed over: an axis-aligned box, or the segment
 * o + t d, t in [t0, t1] (d unit). */
struct bc_svo_region {
	bool segment;
	float lo[3], hi[3]; /* box */
	float o[3], d[3];   /* segment */
	float t0, t1;
};

struct bc_svo_ranger;

/* A range evaluator for one arithmetic over one RPN (scratch memory sized
 * for it; one per thread). arith BC_RANGE_DEFAULT means
 * BC_SVO_DEFAULT_ARITH. Returns 0,
 * BC_EENUM or BC_ENOMEM. */
int bc_svo_ranger_create(struct bc_svo_ranger **out, const struct bc_svo_rpn *r,
                         enum bc_range_arith arith);
void bc_svo_ranger_destroy(struct bc_svo_ranger *g);
enum bc_range_arith bc_svo_ranger_arith(const struct bc_svo_ranger *g);

/* Range of the variant whose active terms are idx[0..n) (increasing) over
 * region; n == 0 gives [+inf, +inf]. Also records every active term's range
 * and operands for bc_svo_prune (the same ranger). */
struct bc_svo_ivl bc_svo_range(struct bc_svo_ranger *g, const uint32_t *idx,
                               uint32_t n, const struct bc_svo_region *region);

/* Range of one primitive term (a PRIM term index of the ranger's RPN) over
 * region, and of one operator given its operands' ranges as intervals:
 * what the enclosure tests check. */
struct bc_svo_ivl bc_svo_range_prim(struct bc_svo_ranger *g, uint32_t term,
                                    const struct bc_svo_region *region);
struct bc_svo_ivl bc_svo_range_op(enum bc_op kind, float blend, float range,
                                  struct bc_svo_ivl a, struct bc_svo_ivl b);

/* Kinds whose range is the Lipschitz enclosure f(c) +- r rather than a
 * natural extension of their formula (docs/svo.md lists why). */
bool bc_svo_prim_uses_lipschitz(enum bc_prim kind);

/* ---- Pruning (prune.c) -------------------------------------------------- */

enum bc_svo_state {
	BC_SVO_STATE_INVALID = 0,
	BC_SVO_STATE_ACTIVE, /* the region holds part of the surface band */
	BC_SVO_STATE_EMPTY,  /* the field is above the band everywhere */
	BC_SVO_STATE_FULL,   /* the field is below zero everywhere */
	BC_SVO_STATE_COUNT
};

struct bc_svo_prune_result {
	enum bc_svo_state state;
	uint32_t nterms;        /* active terms left (0 unless ACTIVE) */
	struct bc_svo_ivl root; /* range of the variant before pruning */
};

/* Thesis Alg. 5.4-5.5, extended: prunes the variant mask_in over region into
 * mask_out (nwords words; may equal mask_in). The pruned variant has, at
 * every point of the region, the same sign as the input variant minus c for
 * every level c in [0, band] (band >= 0: the caster's hit thickness; 0 keeps
 * the plain sign), and the same value under every smooth operator that
 * blends there. Returns 0 or BC_EINVAL. */
int bc_svo_prune(struct bc_svo_ranger *g, const uint32_t *mask_in,
                 uint32_t *mask_out, const struct bc_svo_region *region,
                 float band, struct bc_svo_prune_result *res);

/* ---- Choosing the arithmetic (choose.c) --------------------------------- */

/* Levels a trial may prune, and the levels the octree's default choice
 * prunes (the root and its eight children). */
#define BC_SVO_TRIAL_MAX_LEVELS 8u
#define BC_SVO_TRIAL_LEVELS 2u
/* What pruning one term costs in RevAA, in IA terms: measured on the
 * bench's scenes (docs/svo.md, "IA against RevAA"), 1.9-3.6. */
#define BC_SVO_REVAA_COST 3.0

/* Per level of a trial: cells pruned, those found empty or full, and the
 * active terms they received and kept. */
struct bc_svo_trial_level {
	uint64_t cells, decided, terms_in, terms_out;
};
struct bc_svo_trial {
	enum bc_range_arith arith; /* resolved (never BC_RANGE_DEFAULT) */
	uint32_t levels;
	struct bc_svo_trial_level level[BC_SVO_TRIAL_MAX_LEVELS];
};

/* Prunes the octree's top `levels` levels (1..BC_SVO_TRIAL_MAX_LEVELS)
 * over the same root cube as bc_svo_build, splitting every active cell,
 * with arithmetic arith. Returns 0, BC_EINVAL, BC_EENUM or BC_ENOMEM. */
int bc_svo_trial_run(const struct bc_svo_rpn *rpn, enum bc_range_arith arith,
                     float band, uint32_t levels, struct bc_svo_trial *out);
/* The rule: RevAA when IA's trial keeps more than BC_SVO_REVAA_COST times
 * the terms RevAA's keeps at the last level (each deeper cell evaluates
 * what its parent kept), IA otherwise. ia and rev are trials of the same
 * levels with IA and RevAA. */
enum bc_range_arith bc_svo_arith_choose(const struct bc_svo_trial *ia,
                                        const struct bc_svo_trial *rev);
/* Whether rpn has what lets RevAA prune differently from IA: a smooth
 * operator (RevAA keeps the sharp result's form under the blend) or an
 * ellipsoid (the one natural extension whose formula repeats a variable,
 * where a form may beat the interval). Without them RevAA's primitive
 * ranges fall back on the intervals (docs/svo.md, "Interval fallback")
 * and sharp operators decide on the same bounds: measured identical on
 * every generator family (docs/svo.md, "IA against RevAA"). */
bool bc_svo_arith_may_differ(const struct bc_svo_rpn *rpn);
/* The octree's default arithmetic for rpn: IA where the two cannot
 * differ, else the rule on trials of BC_SVO_TRIAL_LEVELS levels. Returns
 * 0 or a trial's error. */
int bc_svo_arith_default(const struct bc_svo_rpn *rpn, float band,
                         enum bc_range_arith *out);

/* ---- Sparse voxel octree (octree.c) ------------------------------------- */

/* Zero means default for every field. */
struct bc_svo_opts {
	enum bc_range_arith arith; /* pruning arithmetic (default: chosen per
	                              scene by a trial, bc_svo_arith_choose) */
	uint32_t threshold;        /* tau */
	uint32_t max_depth;        /* <= BC_SVO_MAX_DEPTH */
	float band;                /* hit thickness preserved (0: sign only) */
	uint64_t max_bytes;        /* memory budget */
	bool no_step; /* the caster searches every leaf by interval bisection
	                 (thesis Alg. 5.7), 1-Lipschitz ones included: what
	                 the tests and benchmarks compare stepping with */
};

struct bc_svo_stats {
	uint32_t nodes, leaves;
	uint32_t empty, full, active; /* leaves by state */
	uint32_t max_depth;
	uint32_t max_terms;    /* most active terms in a leaf */
	double avg_depth;      /* leaf depth averaged over volume (a random
	                          point's leaf, thesis eq. 5.6) */
	double avg_terms;      /* active terms likewise (0 for empty/full) */
	double avg_depth_leaf; /* plain averages over leaves */
	double avg_terms_leaf; /* over active leaves */
	uint64_t bytes;        /* nodes + leaves + stored masks + RPN */
	uint64_t pruned;       /* regions pruned while building */
	double build_ms;
	uint32_t stalled; /* leaves kept over tau because splitting
	                     stopped removing terms (octree.c) */
	uint32_t stepped; /* active leaves whose variant is 1-Lipschitz: the
	                     caster steps through them (cast.c) */
	bool truncated;   /* the memory budget stopped subdivision */
	enum bc_range_arith arith; /* the arithmetic that pruned (the trial's
	                              choice when none was asked for) */
};

struct bc_svo;

/* Builds the octree of rpn (which must outlive it) over the tree's AABB
 * grown by the band. Returns 0, BC_EINVAL, BC_EENUM, BC_ERANGE (depth over
 * BC_SVO_MAX_DEPTH, negative band) or BC_ENOMEM with a reason in ei. */
int bc_svo_build(struct bc_svo **out, const struct bc_svo_rpn *rpn,
                 const struct bc_svo_opts *opts, struct bc_errinfo *ei);
void bc_svo_destroy(struct bc_svo *s);
void bc_svo_get_stats(const struct bc_svo *s, struct bc_svo_stats *st);
const struct bc_svo_rpn *bc_svo_rpn(const struct bc_svo *s);
/* The octree's root box. */
void bc_svo_bounds(const struct bc_svo *s, float lo[3], float hi[3]);

/* A leaf found by a point or a ray. */
struct bc_svo_leaf_ref {
	enum bc_svo_state state;
	struct bc_svo_cmask mask;
	uint32_t nterms;
	uint32_t depth;
	float value; /* field bound standing for an empty or full leaf */
	float lo[3], hi[3];
};

/* The leaf containing p; false when p is outside the root box. */
bool bc_svo_locate(const struct bc_svo *s, const float p[3],
                   struct bc_svo_leaf_ref *leaf);
/* The field through the octree: the pruned variant of p's leaf (a bound of
 * the right sign for empty and full leaves; the full tree outside the root
 * box). Its sign equals the full field's everywhere. */
float bc_svo_eval(const struct bc_svo *s, const float p[3]);
float bc_svo_eval_id(const struct bc_svo *s, const float p[3], uint32_t *prim);

/* ---- Uniform grid of pruned variants (grid.c; thesis §6.1) -------------- */

struct bc_svo_grid;

/* Prunes every voxel of an n^3 grid over the tree's AABB from the full
 * variant and stores the compressed masks. *prune_ms gets the total pruning
 * time. Returns 0, BC_ERANGE (n = 0 or over BC_SVO_MAX_GRID), BC_EENUM or
 * BC_ENOMEM. */
int bc_svo_grid_build(struct bc_svo_grid **out, const struct bc_svo_rpn *rpn,
                      enum bc_range_arith arith, uint32_t n, double *prune_ms);
void bc_svo_grid_destroy(struct bc_svo_grid *g);
float bc_svo_grid_eval(const struct bc_svo_grid *g, const float p[3]);
/* Active terms averaged over voxels, largest, and bytes stored. */
void bc_svo_grid_stats(const struct bc_svo_grid *g, double *avg_terms,
                       uint32_t *max_terms, uint64_t *bytes);

/* ---- Ray casting (cast.c) ----------------------------------------------- */

struct bc_svo_cast_params {
	float pix_angle;  /* pixel footprint per unit of t */
	float min_step;   /* world units */
	float refine_tol; /* world units */
	/* The most evaluations, point and range together (evals +
	 * range_evals of struct bc_svo_hit), a ray may spend; 0: no bound.
	 * A ray stops before one past it and reports ran_out. */
	uint32_t max_evals;
};

struct bc_svo_hit {
	float t;
	uint32_t prim; /* primitive deciding the value, BC_NONE if unknown */
	/* The variant the hit lies in (its leaf's, or the full tree's): the
	 * field to take normals from. Points into the octree. */
	struct bc_svo_cmask mask;
	uint32_t leaf_terms;  /* active terms of the leaf hit */
	uint32_t evals;       /* point evaluations spent on the ray */
	uint32_t range_evals; /* range evaluations spent on the ray */
	/* The ray stopped at cp->max_evals before it was decided: neither
	 * a hit nor a miss (the cast returns false). */
	bool ran_out;
};

/* Per-thread scratch of the caster. */
struct bc_svo_caster;
int bc_svo_caster_create(struct bc_svo_caster **out, const struct bc_svo *s);
void bc_svo_caster_destroy(struct bc_svo_caster *c);

/* The hit thickness the caster needs at ray parameter t: the octree must
 * have been built with a band at least this large for every t it casts. */
float bc_svo_hit_band(const struct bc_svo_cast_params *cp, float t);

/* Thesis Alg. 5.7-5.8: casts o + t d (d unit), t in [t0, t1], through the
 * leaves of the octree front to back. In a leaf holding surface, interval
 * bisection in the octree's arithmetic (or, where the leaf's variant is
 * 1-Lipschitz, steps by its value: docs/svo.md) brackets the first point
 * where the field drops below the hit band, and the Illinois variant of
 * the secant method refines it; the depth is then refined to the field's zero
 * crossing behind the band's entry, or on a ray that only grazes the
 * surface to its closest approach (docs/svo.md). Returns true and fills *hit on
 * a hit; hit->evals and range_evals are filled either way. A ray that would
 * spend more than cp->max_evals stops before it: false, hit->ran_out set. */
bool bc_svo_cast(struct bc_svo_caster *c, const float o[3], const float d[3],
                 float t0, float t1, const struct bc_svo_cast_params *cp,
                 struct bc_svo_hit *hit);

/* Rays of one packet at most. */
#define BC_SVO_PACKET 8u

/* Casts the n <= BC_SVO_PACKET rays o + t d[i] together: they walk the
 * octree as one (a node is visited once for all the rays that cross it),
 * and in a leaf that they step through, each round of their samples is one
 * evaluation of the leaf's variant over all of them. hits[i] is what
 * bc_svo_cast fills for ray i, bit for bit (the tests compare them), but
 * for its counts and, under an evaluation bound, whether it ran out: the
 * packet's beam tests count for each of its rays and spare them samples,
 * so a ray may run out in a packet and not alone, or the other way.
 * Returns the rays that hit, bit i for ray i. Coherent rays (a block of
 * neighbouring pixels) gain; any rays are allowed: a ray that runs the
 * other way along an axis than the others (so that their common order of
 * children is not front to back for it) is cast alone. n above
 * BC_SVO_PACKET casts nothing: every hits[i] is cleared (a miss, no
 * evaluations) and 0 returned. */
uint32_t bc_svo_cast_packet(struct bc_svo_caster *c, const float o[3],
                            const float (*d)[3], uint32_t n, float t0, float t1,
                            const struct bc_svo_cast_params *cp,
                            struct bc_svo_hit *hits);
/* Forgets the leaf where this caster's last packet hit. A packet skips the
 * range test of its beam (a test that cannot clear a leaf where rays hit)
 * in that leaf; the hits do not depend on it, the evaluation counts do:
 * calling this before each tile keeps them independent of which tiles a
 * thread took before. */
void bc_svo_caster_forget(struct bc_svo_caster *c);
/* Rays this caster's packets have cast so far together (*packed) and
 * alone (*alone; bc_svo_cast_packet). */
void bc_svo_caster_counts(const struct bc_svo_caster *c, uint64_t *packed,
                          uint64_t *alone);

/* ---- Measurements (measure.c) ------------------------------------------- */

/* Evaluation cost at random points of the tree's box (the thesis's §6.1
 * and §6.3 protocol): the same points through the full tree and through
 * the pruned variants, on this thread. */
struct bc_svo_timing {
	uint32_t points;      /* points evaluated through the variants */
	uint32_t full_points; /* of which through the full tree too */
	double full_ns;       /* bc_eval_full, per point */
	double pruned_ns;     /* finding the variant and evaluating it */
	double locate_ns;     /* finding it only (octree walk, voxel index) */
	uint64_t mismatches;  /* full_points whose signs differ: always 0 */
};

/* Times `points` random points (from seed) through s (or the grid g), and
 * the full tree of l (the tree s or g was built from) on as many of them as
 * fit in about BC_SVO_FULL_TIME_MS. Returns 0, BC_EINVAL or BC_ENOMEM. */
#define BC_SVO_FULL_TIME_MS 300.0
int bc_svo_time_octree(const struct bc_svo *s, const struct bc_lin *l,
                       uint32_t points, uint64_t seed,
                       struct bc_svo_timing *out);
int bc_svo_time_grid(const struct bc_svo_grid *g, const struct bc_lin *l,
                     uint32_t points, uint64_t seed, struct bc_svo_timing *out);

/* ---- The backend (backend.c) -------------------------------------------- */

extern const struct bc_backend_ops bc_backend_svo_ops;

#endif
