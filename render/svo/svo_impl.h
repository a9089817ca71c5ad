/*
 * What the sources of the svo module share and nobody else needs: the range
 * evaluator's scratch, the entry points of the three arithmetics, the
 * operator-range rules that all of them and the pruner must agree on, the
 * rounding margins, and inline helpers for the point evaluator.
 */
#ifndef BLOBCAST_SVO_IMPL_H
#define BLOBCAST_SVO_IMPL_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "blobcast/svo.h"

/*
 * Rounding margin. Ranges are computed in double precision; the values they
 * must enclose come from the single-precision evaluator. Each primitive and
 * each blending operator widens its range outward by BC__SVO_ROUND_REL times
 * the magnitude scale of the computation (largest local coordinate plus the
 * primitive's size, or largest operand plus the blend). 2^-17 is 64
 * float ulps of that scale: it covers the float evaluator's own rounding
 * (a few tens of operations of at most half an ulp each, docs/svo.md) and
 * dwarfs the double rounding of the range computation (2^-53 per step).
 */
#define BC__SVO_ROUND_REL (1.0 / 131072.0)
/* Absolute floor of the margin: scales of zero still round. */
#define BC__SVO_ROUND_ABS 1.0e-30

/* max and min of doubles without libm's fmax/fmin, which are calls (they
 * must ignore a NaN operand): range code runs them by the million. A NaN
 * operand gives the second operand back. */
static inline double bc__dmax(double a, double b)
{
	return a > b ? a : b;
}
static inline double bc__dmin(double a, double b)
{
	return a < b ? a : b;
}

/* Dense-mask helpers. */
static inline bool bc__svo_bit(const uint32_t *mask, uint32_t i)
{
	return (mask[i >> 5] >> (i & 31u)) & 1u;
}
static inline void bc__svo_clear(uint32_t *mask, uint32_t i)
{
	mask[i >> 5] &= ~(1u << (i & 31u));
}

/* Index of the lowest set bit of a non-zero word (de Bruijn, thesis Alg.
 * 5.2) and of the highest (the matching reverse table). The casters' lane
 * loops take the lowest bit several million times a frame: where the
 * compiler has a count-trailing-zeros instruction for it (GCC and Clang;
 * a builtin, not ISO C, so behind the test) that is one instruction
 * instead of a multiply and a table load (3.5 % of a frame's
 * instructions, docs/svo.md). The same goes for counting bits. */
extern const uint8_t bc__svo_debruijn_lo[32];
extern const uint8_t bc__svo_debruijn_hi[32];
static inline uint32_t bc__svo_lowest(uint32_t b)
{
#if defined(__GNUC__) || defined(__clang__)
	return (uint32_t)__builtin_ctz(b);
#else
	return bc__svo_debruijn_lo[((b & (0u - b)) * 0x077CB531u) >> 27];
#endif
}
static inline uint32_t bc__svo_popcount(uint32_t b)
{
#if defined(__GNUC__) || defined(__clang__)
	return (uint32_t)__builtin_popcount(b);
#else
	uint32_t n = 0;
	for (; b; b &= b - 1u) {
		n++;
	}
	return n;
#endif
}
static inline uint32_t bc__svo_highest(uint32_t b)
{
	b |= b >> 1;
	b |= b >> 2;
	b |= b >> 4;
	b |= b >> 8;
	b |= b >> 16;
	return bc__svo_debruijn_hi[(b * 0x07C4ACDDu) >> 27];
}

/* World point p mapped through the domain chain from d (rpn->udom, applied
 * outermost first) and unary node u's value map of its child's value f at
 * p: blobtree's bc_domain_map and bc_unary_value on the RPN's copies. */
void bc__svo_domain_map(const struct bc_svo_rpn *r, uint32_t d,
                        const float p[3], float out[3]);
float bc__svo_unary_value(const struct bc_svo_rpn *r, uint32_t u, float f,
                          const float p[3]);

/* The variant whose active terms are idx[0..n) (increasing) at p: what
 * bc_svo_cmask_eval computes, without decoding the mask at every point
 * (the caster decodes a leaf's once and samples it several times). */
float bc__svo_list_eval(const struct bc_svo_rpn *r, const uint32_t *idx,
                        uint32_t n, const float p[3]);

/* The same at BC__SVO_LANES points at once, (px[j], py[j], pz[j]): for
 * every lane j of `live`, out[j] is bc__svo_list_eval's value at that
 * point, bit for bit (the other lanes' out is meaningless). The ray
 * packets of the caster (cast.c) evaluate a leaf's variant for all their
 * rays with one call: each term is read and dispatched once, and the
 * arithmetic runs over the lanes. */
#define BC__SVO_LANES BC_SVO_PACKET
void bc__svo_list_eval_lanes(const struct bc_svo_rpn *r, const uint32_t *idx,
                             uint32_t n, const float *px, const float *py,
                             const float *pz, uint32_t live, float *out);
/* The same, and prim[j] the primitive that decides the value in lane j
 * (bc_svo_cmask_eval_id's, bit for bit). */
void bc__svo_list_eval_lanes_id(const struct bc_svo_rpn *r, const uint32_t *idx,
                                uint32_t n, const float *px, const float *py,
                                const float *pz, uint32_t live, float *out,
                                uint32_t *prim);

/* A primitive term's field at point p of its own input frame (the world
 * mapped through its domain nodes), exactly as eval.c computes it (same
 * operation order, so the same float). */
static inline float bc__svo_prim_eval_at(const struct bc_svo_rpn *r,
                                         const struct bc_svo_term *t,
                                         const float p[3])
{
	const float *rec = r->rec + t->rec;
	if (t->kind == BC_PRIM_SPHERE) {
		/* The commonest kind without the call and the switch:
		 * prim.c's formula, operation for operation, at p + (-c)
		 * (a sphere's rows are the identity, bc_prim_record_long:
		 * the floats of the whole map, and of eval.c's p - c). */
		float x = p[0] + rec[3], y = p[1] + rec[7], z = p[2] + rec[11];
		return sqrtf(x * x + y * y + z * z) - rec[12];
	}
	float x = rec[0] * p[0] + rec[1] * p[1] + rec[2] * p[2] + rec[3];
	float y = rec[4] * p[0] + rec[5] * p[1] + rec[6] * p[2] + rec[7];
	float z = rec[8] * p[0] + rec[9] * p[1] + rec[10] * p[2] + rec[11];
	return bc_prim_sdf((enum bc_prim)t->kind, rec + 12, x, y, z);
}

/* A primitive term's field at world point p. */
static inline float bc__svo_prim_eval(const struct bc_svo_rpn *r,
                                      const struct bc_svo_term *t,
                                      const float p[3])
{
	if (r->prim_dom && r->prim_dom[t->prim] != BC_NONE) {
		float q[3];
		bc__svo_domain_map(r, r->prim_dom[t->prim], p, q);
		return bc__svo_prim_eval_at(r, t, q);
	}
	return bc__svo_prim_eval_at(r, t, p);
}

/* ---- Range evaluator ---------------------------------------------------- */

/* An AA form in the ranger's arena: centre and n (symbol, coefficient)
 * pairs from off, symbols increasing. */
struct bc__aa {
	double c;
	uint32_t off, n;
};

/* A revised affine form: centre, the three input symbols, and the
 * magnitude of the accumulated error term (thesis eq. 4.14). */
struct bc__rev {
	double c;
	double x[3];
	double e;
};

struct bc_svo_ranger {
	const struct bc_svo_rpn *rpn;
	enum bc_range_arith arith;
	/* Per term, written for the active terms of the last bc_svo_range
	 * call: the range and the operand terms (NEG: kid0 only). */
	struct bc_svo_ivl *ivl;
	uint32_t *kid0, *kid1;
	uint32_t *idx;  /* scratch list of active terms */
	uint32_t *mark; /* scratch for the top-down pass */
	uint8_t *mode;
	struct bc_svo_ivl *lev; /* per stack entry of that pass: the levels
	                           whose sign must be kept */
	/* Set while a domain-mapped primitive's range is computed over its
	 * mapped box (range_tmpl.h): that box is the primitive's own input. */
	bool in_domain;
	/* The current pass's region mapped through the domain chain from
	 * dom_d (BC_NONE: none yet). Primitives under one innermost domain
	 * node come in a row and share the box; every pass over a new
	 * region starts afresh (range_tmpl.h). */
	uint32_t dom_d;
	struct bc_svo_region dom_q;
	/* AA arena, used as a stack. */
	uint32_t *aa_sym;
	double *aa_coef;
	uint32_t aa_cap, aa_top, aa_next;
};

/* The region's geometry every arithmetic needs. */
struct bc__svo_geo {
	float c[3];    /* centre of the box, midpoint of the segment */
	double radius; /* half diagonal, half length */
};
void bc__svo_geo_init(struct bc__svo_geo *geo, const struct bc_svo_region *rg);

/* The arithmetics. record: store every term's range and operands. */
struct bc_svo_ivl bc__svo_ia_run(struct bc_svo_ranger *g, const uint32_t *idx,
                                 uint32_t n, const struct bc_svo_region *rg);
struct bc_svo_ivl bc__svo_aa_run(struct bc_svo_ranger *g, const uint32_t *idx,
                                 uint32_t n, const struct bc_svo_region *rg);
struct bc_svo_ivl bc__svo_rev_run(struct bc_svo_ranger *g, const uint32_t *idx,
                                  uint32_t n, const struct bc_svo_region *rg);
struct bc_svo_ivl bc__svo_ia_prim(struct bc_svo_ranger *g, uint32_t term,
                                  const struct bc_svo_region *rg);
struct bc_svo_ivl bc__svo_aa_prim(struct bc_svo_ranger *g, uint32_t term,
                                  const struct bc_svo_region *rg);
struct bc_svo_ivl bc__svo_rev_prim(struct bc_svo_ranger *g, uint32_t term,
                                   const struct bc_svo_region *rg);

/* The interval extension of a primitive term's natural formula over rg,
 * without rounding margin (the caller adds its own): the whole line for a
 * kind that has none. AA and RevAA fall back on it where it is narrower. */
struct bc_svo_ivl bc__svo_ia_natural(struct bc_svo_ranger *g,
                                     const struct bc_svo_term *t,
                                     const struct bc_svo_region *rg);

/* ---- Unary and domain nodes (range.c) ----------------------------------- */

/* A box holding every point of region rg mapped through the domain chain
 * from d (outermost first), widened for the float evaluation of the maps;
 * out is a box region. */
void bc__svo_domain_region(const struct bc_svo_rpn *r, uint32_t d,
                           const struct bc_svo_region *rg,
                           struct bc_svo_region *out);
/* Range of unary node u's value map (a value-changing kind) over region rg
 * given its child's range a. */
struct bc_svo_ivl bc__svo_unary_range(const struct bc_svo_rpn *r, uint32_t u,
                                      struct bc_svo_ivl a,
                                      const struct bc_svo_region *rg);

/* ---- Operator rules (ia.c) ---------------------------------------------- */

/*
 * Where a compact smooth operator with operand ranges a, b provably equals
 * its sharp counterpart (docs/svo.md derives each test): union when an
 * operand is above r_o, or the blend width b_r can no longer reach the
 * operands' difference; intersection when an operand is outside
 * [-r_o, r_o] or likewise. Sharp kinds always answer true.
 */
bool bc__svo_op_sharp_in(enum bc_op kind, double blend, double range,
                         struct bc_svo_ivl a, struct bc_svo_ivl b);
/* Upper bound of the blend amount a smooth operator adds (intersection) or
 * subtracts (union) given the range of the sharp result m and of the
 * operands a, b (for intersection-like kinds, b is the already negated
 * right operand of a difference); 0 where sharp. */
double bc__svo_op_blend_bound(enum bc_op kind, double blend, double range,
                              struct bc_svo_ivl m, struct bc_svo_ivl a,
                              struct bc_svo_ivl b);
/* Outward widening of a blended result for the float evaluator. */
double bc__svo_op_margin(double blend, struct bc_svo_ivl m);

/* The octree's root cube for rpn and band (choose.c). */
void bc__svo_root_box(const struct bc_svo_rpn *rpn, float band, float lo[3],
                      float hi[3]);

static inline struct bc_svo_ivl bc__svo_ivl_meet(struct bc_svo_ivl a,
                                                 struct bc_svo_ivl b)
{
	struct bc_svo_ivl r = {a.lo > b.lo ? a.lo : b.lo,
	                       a.hi < b.hi ? a.hi : b.hi};
	/* Both enclose the same values, so they meet unless one of them is
	 * wrong; should that ever happen, the hull is still an enclosure. */
	if (r.lo > r.hi) {
		r.lo = a.lo < b.lo ? a.lo : b.lo;
		r.hi = a.hi > b.hi ? a.hi : b.hi;
	}
	return r;
}

/* ---- Stored masks (octree.c) -------------------------------------------- */

/* A growing array of (word index, bits) pairs holding compressed masks. */
struct bc__svo_pool {
	uint32_t *v;
	size_t n, cap; /* in uint32 units */
};

/* Appends the non-zero words of mask[0..nwords) and sets *off (in pairs)
 * and *npairs. Returns 0 or BC_ENOMEM. */
int bc__svo_pool_put(struct bc__svo_pool *pool, const uint32_t *mask,
                     uint32_t nwords, uint32_t *off, uint32_t *npairs);
void bc__svo_pool_finish(struct bc__svo_pool *pool);

/* ---- The octree (octree.c; cast.c walks it) ---------------------------- */

struct bc__svo_node {
	uint32_t child; /* first of eight children; 0 for a leaf */
	uint32_t leaf;  /* leaf record of a leaf */
};

enum {
	/* The leaf's variant is 1-Lipschitz (no term of rpn->steep): the
	 * caster may step through it by its value. */
	BC__SVO_LEAF_LIP1 = 1u,
};

struct bc__svo_leaf {
	uint32_t off;    /* first pair in the pool */
	uint32_t npairs; /* non-zero mask words */
	uint32_t nterms;
	uint8_t state;
	uint8_t depth;
	uint16_t flags; /* BC__SVO_LEAF_* */
	float value;
};

struct bc_svo {
	const struct bc_svo_rpn *rpn;
	struct bc_svo_opts opts;
	float lo[3], hi[3];
	struct bc__svo_node *nodes;
	uint32_t nnodes, capnodes;
	struct bc__svo_leaf *leaves;
	uint32_t nleaves, capleaves;
	struct bc__svo_pool pool;
	uint32_t *full; /* the unpruned mask, for points outside the root */
	struct bc_svo_cmask full_c; /* the same, compressed (after build) */
	uint32_t full_off;          /* its place in the pool */
	struct bc_svo_stats stats;
};

/* A stand-in value of an empty or full region's sign. */
float bc__svo_state_value(enum bc_svo_state st, struct bc_svo_ivl root);

#endif
