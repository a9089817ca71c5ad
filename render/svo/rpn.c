/*
 * The blobtree as an RPN sequence (Chulkov 2025, §5.1-5.2): compilation from
 * the linearized post-order tree, bitmasks that select pruned variants, the
 * next/previous set bit walks (Alg. 5.2), the subtree clearing walk (Alg.
 * 5.5) and the stack evaluation of a variant (Alg. 5.3), for dense masks and
 * for the compressed masks the octree stores.
 *
 * The linearized form is already post-order, which is RPN; compiling only
 * adds a negation in front of every difference (see struct bc_svo_term) and
 * copies the parameter records so that the RPN does not depend on the tree
 * staying unchanged.
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

_Static_assert(BC_SVO_PRIM_REC == 4 * BC_PRIM_RECORD_VEC4,
               "an svo record is a layout record in the long form");

/* Position of the lowest bit of a power of two, indexed by the top five bits
 * of its product with the de Bruijn sequence 0x077CB531. */
const uint8_t bc__svo_debruijn_lo[32] = {
    0,  1,  28, 2,  29, 14, 24, 3, 30, 22, 20, 15, 25, 17, 4,  8,
    31, 27, 13, 23, 21, 19, 16, 7, 26, 12, 18, 6,  11, 5,  10, 9};
/* Position of the highest bit of x once x is smeared to 2^(k+1) - 1,
 * indexed by the top five bits of its product with 0x07C4ACDD. */
const uint8_t bc__svo_debruijn_hi[32] = {
    0, 9,  1,  10, 13, 21, 2,  29, 11, 14, 16, 18, 22, 25, 3, 30,
    8, 12, 20, 28, 15, 17, 24, 7,  19, 27, 23, 6,  26, 5,  4, 31};

/* Is the domain chain from d outward 1-Lipschitz? Elongate, mirror and
 * scale (with its value factor) are; twist and bend stretch space away
 * from their axis, and the nearest copy of a repeat jumps where the
 * copies' cells meet. */
static bool chain_lip1(const struct bc_svo_rpn *r, uint32_t d)
{
	for (uint32_t n = 0; d != BC_NONE && n < BC_DOMAIN_MAX_CHAIN;
	     d = r->udom[d], n++) {
		enum bc_op k = (enum bc_op)r->ukind[d];
		if (k == BC_OP_TWIST || k == BC_OP_BEND || k == BC_OP_REPEAT) {
			return false;
		}
	}
	return true;
}

void bc__svo_domain_map(const struct bc_svo_rpn *r, uint32_t d,
                        const float p[3], float out[3])
{
	uint32_t chain[BC_DOMAIN_MAX_CHAIN];
	uint32_t n = 0;
	memcpy(out, p, 3 * sizeof(float));
	for (; d != BC_NONE && n < BC_DOMAIN_MAX_CHAIN; d = r->udom[d]) {
		chain[n++] = d;
	}
	while (n-- > 0) {
		bc_domain_apply(r->ukind[chain[n]],
		                r->urec + (size_t)chain[n] * BC_SVO_UNARY_REC,
		                out);
	}
}

float bc__svo_unary_value(const struct bc_svo_rpn *r, uint32_t u, float f,
                          const float p[3])
{
	float q[3] = {0.0f, 0.0f, 0.0f};
	if (bc_unary_reads_point(r->ukind[u])) {
		bc__svo_domain_map(r, r->udom[u], p, q);
	}
	return bc_unary_apply(r->ukind[u],
	                      r->urec + (size_t)u * BC_SVO_UNARY_REC, f, q);
}

int bc_svo_rpn_init(struct bc_svo_rpn *out, const struct bc_lin *l)
{
	uint32_t fst[BC_EVAL_STACK];
	uint32_t n = 0, ndiff = 0, nops = 0, nval = 0, sp = 0, most = 0, t = 0;
	uint32_t prec = 0, orec;
	memset(out, 0, sizeof(*out));
	if (!l || l->count == 0 || l->nprims == 0) {
		return BC_EINVAL;
	}
	for (uint32_t s = 0; s < l->count; s++) {
		if (!bc_lin_is_leaf(l, s)) {
			enum bc_op k = (enum bc_op)bc_lin_kind(l, s);
			nops++;
			ndiff += bc_op_class(k) == BC_OPCLASS_DIFFERENCE;
		}
		for (uint32_t u = l->nunary ? l->wrap[s] : BC_NONE;
		     u != BC_NONE; u = l->unary_outer[u]) {
			nval += bc_op_has_value((enum bc_op)l->unary_kind[u]);
		}
	}
	n = l->count + ndiff + nval;
	out->terms = bc_calloc(n, sizeof(*out->terms));
	out->rec = bc_calloc((size_t)l->nprims * BC_SVO_PRIM_REC + 2u * nops,
	                     sizeof(float));
	out->prim_id = bc_calloc(l->nprims, sizeof(*out->prim_id));
	out->prim_size = bc_calloc(l->nprims, sizeof(*out->prim_size));
	out->color = bc_calloc(l->nprims, sizeof(*out->color));
	out->steep = bc_calloc((n + 31u) / 32u, sizeof(*out->steep));
	if (!out->terms || !out->rec || !out->prim_id || !out->prim_size ||
	    !out->color || !out->steep) {
		bc_svo_rpn_finish(out);
		return BC_ENOMEM;
	}
	if (l->nunary) {
		out->nunary = l->nunary;
		out->ukind = bc_calloc(l->nunary, sizeof(*out->ukind));
		out->urec = bc_calloc((size_t)l->nunary * BC_SVO_UNARY_REC,
		                      sizeof(*out->urec));
		out->udom = bc_calloc(l->nunary, sizeof(*out->udom));
		out->prim_dom = bc_calloc(l->nprims, sizeof(*out->prim_dom));
		if (!out->ukind || !out->urec || !out->udom || !out->prim_dom) {
			bc_svo_rpn_finish(out);
			return BC_ENOMEM;
		}
		for (uint32_t u = 0; u < l->nunary; u++) {
			out->ukind[u] = (uint8_t)l->unary_kind[u];
			memcpy(out->urec + (size_t)u * BC_SVO_UNARY_REC,
			       l->param + 4u * (size_t)l->unary_param[u],
			       BC_SVO_UNARY_REC * sizeof(float));
			out->udom[u] = l->unary_dom[u];
		}
	}
	orec = l->nprims * BC_SVO_PRIM_REC;
	for (uint32_t s = 0; s < l->count; s++) {
		const float *src = bc_lin_param(l, s);
		struct bc_svo_term *tm;
		if (bc_lin_is_leaf(l, s)) {
			if (sp >= BC_EVAL_STACK) {
				bc_svo_rpn_finish(out);
				return BC_EDEPTH;
			}
			tm = &out->terms[t];
			tm->type = BC_SVO_TERM_PRIM;
			tm->kind = (uint8_t)bc_lin_kind(l, s);
			tm->first = t;
			tm->prim = bc_lin_leaf_prim(l, s);
			tm->rec = prec;
			bc_prim_record_long(tm->kind, src, out->rec + prec);
			{
				const struct bc_prim_info *info =
				    bc_prim_info((enum bc_prim)tm->kind);
				uint32_t d = l->nunary ? l->dom[s] : BC_NONE;
				if (out->prim_dom) {
					out->prim_dom[tm->prim] = d;
				}
				if (!info || !info->exact ||
				    !chain_lip1(out, d)) {
					out->steep[t >> 5] |= 1u << (t & 31u);
				}
			}
			prec += BC_SVO_PRIM_REC;
			fst[sp++] = t++;
			most = sp > most ? sp : most;
		} else {
			enum bc_op k = (enum bc_op)bc_lin_kind(l, s);
			if (sp < 2) {
				bc_svo_rpn_finish(out);
				return BC_EINVAL;
			}
			if (bc_op_class(k) == BC_OPCLASS_DIFFERENCE) {
				tm = &out->terms[t];
				tm->type = BC_SVO_TERM_NEG;
				tm->first = fst[sp - 1];
				tm->prim = BC_NONE;
				t++;
				k = k == BC_OP_DIFFERENCE
				        ? BC_OP_INTERSECTION
				        : BC_OP_SMOOTH_INTERSECTION;
			}
			tm = &out->terms[t];
			tm->type = BC_SVO_TERM_OP;
			tm->kind = (uint8_t)k;
			tm->first = fst[sp - 2];
			tm->prim = BC_NONE;
			tm->rec = orec;
			/* Sharp records hold zeros: bc_op_eval ignores them. */
			out->rec[orec] = bc_op_is_smooth(k) ? src[0] : 0.0f;
			out->rec[orec + 1] = bc_op_is_smooth(k) ? src[1] : 0.0f;
			if (bc_op_is_smooth(k)) {
				out->steep[t >> 5] |= 1u << (t & 31u);
			}
			orec += 2;
			t++;
			sp--;
		}
		/* The value-changing wrappers of slot s, innermost first; the
		 * pure domain nodes act on the primitives' points instead. */
		for (uint32_t u = l->nunary ? l->wrap[s] : BC_NONE;
		     u != BC_NONE; u = l->unary_outer[u]) {
			enum bc_op k = (enum bc_op)l->unary_kind[u];
			if (!bc_op_has_value(k)) {
				continue;
			}
			tm = &out->terms[t];
			tm->type = BC_SVO_TERM_UNARY;
			tm->kind = (uint8_t)k;
			tm->first = fst[sp - 1];
			tm->prim = BC_NONE;
			tm->rec = u;
			if (k == BC_OP_TWIST || k == BC_OP_BEND) {
				/* Its value map is L(R)/L(r) <= 1 times the
				 * child's, r the distance from the axis. */
				out->steep[t >> 5] |= 1u << (t & 31u);
			}
			t++;
		}
	}
	if (sp != 1 || t != n) {
		bc_svo_rpn_finish(out);
		return BC_EINVAL;
	}
	for (uint32_t k = 0; k < l->nprims; k++) {
		float lo[3], hi[3], d2 = 0.0f;
		struct bc_abv abv = bc_lin_abv(l, k);
		bc_abv_aabb(&abv, lo, hi);
		for (int i = 0; i < 3; i++) {
			d2 += (hi[i] - lo[i]) * (hi[i] - lo[i]);
		}
		out->prim_size[k] = 0.5f * sqrtf(d2);
		out->prim_id[k] = l->node_id[l->prim_slot[k]];
		memcpy(out->color[k], l->color[k], sizeof(out->color[k]));
	}
	out->n = n;
	out->nwords = (n + 31u) / 32u;
	out->nprims = l->nprims;
	out->stack = most;
	out->lip = l->lip > 0.0f ? l->lip : 1.0f;
	memcpy(out->lo, l->lo, sizeof(out->lo));
	memcpy(out->hi, l->hi, sizeof(out->hi));
	out->size = l->size;
	return 0;
}

void bc_svo_rpn_finish(struct bc_svo_rpn *r)
{
	if (!r) {
		return;
	}
	bc_free(r->terms);
	bc_free(r->rec);
	bc_free(r->prim_id);
	bc_free(r->prim_size);
	bc_free(r->color);
	bc_free(r->steep);
	bc_free(r->ukind);
	bc_free(r->urec);
	bc_free(r->udom);
	bc_free(r->prim_dom);
	memset(r, 0, sizeof(*r));
}

void bc_svo_mask_fill(const struct bc_svo_rpn *r, uint32_t *mask)
{
	if (r->nwords == 0) {
		return;
	}
	memset(mask, 0xff, (size_t)r->nwords * sizeof(*mask));
	if (r->n & 31u) {
		mask[r->nwords - 1] = (1u << (r->n & 31u)) - 1u;
	}
}

uint32_t bc_svo_mask_count(const uint32_t *mask, uint32_t nwords)
{
	uint32_t c = 0;
	for (uint32_t w = 0; w < nwords; w++) {
		/* Parallel bit count: no builtins in portable C11. */
		uint32_t v = mask[w];
		v = v - ((v >> 1) & 0x55555555u);
		v = (v & 0x33333333u) + ((v >> 2) & 0x33333333u);
		c += (((v + (v >> 4)) & 0x0f0f0f0fu) * 0x01010101u) >> 24;
	}
	return c;
}

uint32_t bc_svo_bits_next(const uint32_t *mask, uint32_t nwords, uint32_t i)
{
	uint32_t n = i >> 5, b;
	if (n >= nwords) {
		return UINT32_MAX;
	}
	b = mask[n];
	if (b & (1u << (i & 31u))) {
		return i; /* the trivial case: the current bit is set */
	}
	b &= 0xffffffffu << (i & 31u);
	while (b == 0) {
		if (++n >= nwords) {
			return UINT32_MAX;
		}
		b = mask[n];
	}
	return (n << 5) + bc__svo_lowest(b);
}

uint32_t bc_svo_bits_prev(const uint32_t *mask, uint32_t i)
{
	uint32_t n, b;
	if (i == UINT32_MAX) {
		return UINT32_MAX;
	}
	n = i >> 5;
	b = mask[n] & (0xffffffffu >> (31u - (i & 31u)));
	while (b == 0) {
		if (n == 0) {
			return UINT32_MAX;
		}
		b = mask[--n];
	}
	return (n << 5) + bc__svo_highest(b);
}

static inline uint32_t arity(const struct bc_svo_term *t)
{
	return t->type == BC_SVO_TERM_OP
	           ? 2u
	           : (t->type == BC_SVO_TERM_PRIM ? 0u : 1u);
}

void bc_svo_rpn_clear_subtree(const struct bc_svo_rpn *r, uint32_t *mask,
                              uint32_t i)
{
	/* Terms still owed to the subtree: each visited term pays one and
	 * asks for its operands. */
	uint32_t owed = 1;
	for (;;) {
		bc__svo_clear(mask, i);
		owed = owed - 1u + arity(&r->terms[i]);
		if (owed == 0 || i == 0) {
			break;
		}
		i = bc_svo_bits_prev(mask, i - 1u);
		if (i == UINT32_MAX) {
			break; /* not a well-formed variant: nothing left */
		}
	}
}

/* ---- Evaluation --------------------------------------------------------- */

/* One step of the stack machine. `unary` is false for an RPN without unary
 * and domain nodes: the loops are compiled twice, and the common one skips
 * their checks. */
static inline void step(const struct bc_svo_rpn *r, uint32_t i, float *st,
                        uint32_t *who, uint32_t *sp, const float p[3], bool ids,
                        bool unary)
{
	const struct bc_svo_term *t = &r->terms[i];
	uint32_t s = *sp;
	switch (t->type) {
	case BC_SVO_TERM_PRIM:
		st[s] = unary ? bc__svo_prim_eval(r, t, p)
		              : bc__svo_prim_eval_at(r, t, p);
		if (ids) {
			who[s] = t->prim;
		}
		*sp = s + 1;
		break;
	case BC_SVO_TERM_NEG:
		st[s - 1] = -st[s - 1];
		break;
	case BC_SVO_TERM_UNARY:
		st[s - 1] = bc__svo_unary_value(r, t->rec, st[s - 1], p);
		break;
	default: {
		const float *rec = r->rec + t->rec;
		float f1 = st[s - 1], f0 = st[s - 2];
		/* Sharp operators inline, as fminf and fmaxf answer (a NaN
		 * operand yields the other); blends through ops.c. */
		if (t->kind == BC_OP_UNION) {
			st[s - 2] = bc_op_min(f0, f1);
		} else if (t->kind == BC_OP_INTERSECTION) {
			st[s - 2] = bc_op_max(f0, f1);
		} else {
			st[s - 2] = bc_op_eval((enum bc_op)t->kind, rec[0],
			                       rec[1], f0, f1);
		}
		if (ids) {
			/* The operand the value follows, as eval.c decides. */
			bool right = t->kind == BC_OP_UNION ||
			                     t->kind == BC_OP_SMOOTH_UNION
			                 ? f1 < f0
			                 : f1 > f0;
			if (right) {
				who[s - 2] = who[s - 1];
			}
		}
		*sp = s - 1;
		break;
	}
	}
}

static float eval_dense(const struct bc_svo_rpn *r, const uint32_t *mask,
                        const float p[3], uint32_t *prim)
{
	float st[BC_EVAL_STACK];
	uint32_t who[BC_EVAL_STACK];
	uint32_t sp = 0;
	for (uint32_t i = bc_svo_bits_next(mask, r->nwords, 0); i != UINT32_MAX;
	     i = bc_svo_bits_next(mask, r->nwords, i + 1u)) {
		step(r, i, st, who, &sp, p, prim != NULL, r->nunary != 0);
	}
	if (prim) {
		*prim = sp ? who[0] : BC_NONE;
	}
	return sp ? st[0] : INFINITY;
}

float bc_svo_rpn_eval(const struct bc_svo_rpn *r, const uint32_t *mask,
                      const float p[3])
{
	return eval_dense(r, mask, p, NULL);
}

float bc_svo_rpn_eval_id(const struct bc_svo_rpn *r, const uint32_t *mask,
                         const float p[3], uint32_t *prim)
{
	return eval_dense(r, mask, p, prim);
}

static inline float eval_cmask_k(const struct bc_svo_rpn *r,
                                 struct bc_svo_cmask m, const float p[3],
                                 uint32_t *prim, bool unary)
{
	float st[BC_EVAL_STACK];
	uint32_t who[BC_EVAL_STACK];
	uint32_t sp = 0;
	for (uint32_t w = 0; w < m.nwords; w++) {
		uint32_t base = m.pairs[2 * w] << 5, b = m.pairs[2 * w + 1];
		while (b) {
			step(r, base + bc__svo_lowest(b), st, who, &sp, p,
			     prim != NULL, unary);
			b &= b - 1u;
		}
	}
	if (prim) {
		*prim = sp ? who[0] : BC_NONE;
	}
	return sp ? st[0] : INFINITY;
}

static float eval_cmask(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                        const float p[3], uint32_t *prim)
{
	return r->nunary ? eval_cmask_k(r, m, p, prim, true)
	                 : eval_cmask_k(r, m, p, prim, false);
}

static inline float eval_list_k(const struct bc_svo_rpn *r, const uint32_t *idx,
                                uint32_t n, const float p[3], bool unary)
{
	float st[BC_EVAL_STACK];
	uint32_t sp = 0;
	for (uint32_t k = 0; k < n; k++) {
		step(r, idx[k], st, NULL, &sp, p, false, unary);
	}
	return sp ? st[0] : INFINITY;
}

float bc__svo_list_eval(const struct bc_svo_rpn *r, const uint32_t *idx,
                        uint32_t n, const float p[3])
{
	return r->nunary ? eval_list_k(r, idx, n, p, true)
	                 : eval_list_k(r, idx, n, p, false);
}

float bc_svo_cmask_eval(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                        const float p[3])
{
	return r->nunary ? eval_cmask_k(r, m, p, NULL, true)
	                 : eval_cmask_k(r, m, p, NULL, false);
}

float bc_svo_cmask_eval_id(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                           const float p[3], uint32_t *prim)
{
	return eval_cmask(r, m, p, prim);
}

/* One term of the stack machine at BC__SVO_LANES points at once: step()
 * lane by lane, operation for operation (the same float in every lane),
 * with the term's record read and dispatched once for all of them. The
 * arithmetic loops run over every lane and are what the compiler
 * vectorizes; the kinds that call out (primitives other than spheres,
 * domain maps, value maps, blends) run only the lanes of `live` and leave
 * 0 in the others, so a packet of one or two rays does not pay for eight. */
static inline void lanes_step(const struct bc_svo_rpn *r, uint32_t i,
                              float (*st)[BC__SVO_LANES], uint32_t *sp,
                              const float *px, const float *py, const float *pz,
                              uint32_t live, uint32_t (*who)[BC__SVO_LANES])
{
	const struct bc_svo_term *t = &r->terms[i];
	const float *rec = r->rec + t->rec;
	uint32_t s = *sp;
	if (who && t->type == BC_SVO_TERM_PRIM) {
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			who[s][j] = t->prim;
		}
	}
	if (t->type == BC_SVO_TERM_PRIM && r->prim_dom &&
	    r->prim_dom[t->prim] != BC_NONE) {
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			const float p[3] = {px[j], py[j], pz[j]};
			st[s][j] = (live >> j) & 1u ? bc__svo_prim_eval(r, t, p)
			                            : 0.0f;
		}
		*sp = s + 1;
	} else if (t->type == BC_SVO_TERM_PRIM && t->kind == BC_PRIM_SPHERE) {
		/* A sphere's rows are the identity (bc_prim_record_long):
		 * p + (-c) per axis, the floats of the whole map (1 * p plus
		 * zeros) and of eval.c's p - c, without nine products. */
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			float x = px[j] + rec[3], y = py[j] + rec[7],
			      z = pz[j] + rec[11];
			st[s][j] = sqrtf(x * x + y * y + z * z) - rec[12];
		}
		*sp = s + 1;
	} else if (t->type == BC_SVO_TERM_PRIM) {
		float x[BC__SVO_LANES], y[BC__SVO_LANES], z[BC__SVO_LANES];
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			x[j] = rec[0] * px[j] + rec[1] * py[j] +
			       rec[2] * pz[j] + rec[3];
			y[j] = rec[4] * px[j] + rec[5] * py[j] +
			       rec[6] * pz[j] + rec[7];
			z[j] = rec[8] * px[j] + rec[9] * py[j] +
			       rec[10] * pz[j] + rec[11];
		}
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			st[s][j] = (live >> j) & 1u
			               ? bc_prim_sdf((enum bc_prim)t->kind,
			                             rec + 12, x[j], y[j], z[j])
			               : 0.0f;
		}
		*sp = s + 1;
	} else if (t->type == BC_SVO_TERM_NEG) {
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			st[s - 1][j] = -st[s - 1][j];
		}
	} else if (t->type == BC_SVO_TERM_UNARY) {
		for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
			const float p[3] = {px[j], py[j], pz[j]};
			st[s - 1][j] = (live >> j) & 1u
			                   ? bc__svo_unary_value(
			                         r, t->rec, st[s - 1][j], p)
			                   : 0.0f;
		}
	} else {
		float *f0 = st[s - 2], *f1 = st[s - 1];
		if (who) {
			/* The operand the value follows, as step() decides
			 * (before f0 is overwritten). */
			bool un = t->kind == BC_OP_UNION ||
			          t->kind == BC_OP_SMOOTH_UNION;
			for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
				bool right = un ? f1[j] < f0[j] : f1[j] > f0[j];
				who[s - 2][j] =
				    right ? who[s - 1][j] : who[s - 2][j];
			}
		}
		/* step()'s sharp operators, as selects (bc_op_min), so the
		 * loops vectorize. */
		if (t->kind == BC_OP_UNION) {
			for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
				f0[j] = bc_op_min(f0[j], f1[j]);
			}
		} else if (t->kind == BC_OP_INTERSECTION) {
			for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
				f0[j] = bc_op_max(f0[j], f1[j]);
			}
		} else {
			for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
				f0[j] = (live >> j) & 1u
				            ? bc_op_eval((enum bc_op)t->kind,
				                         rec[0], rec[1], f0[j],
				                         f1[j])
				            : 0.0f;
			}
		}
		*sp = s - 1;
	}
}

/* The two entry points below: prim NULL or not is a constant in each, and
 * the inlining makes two copies, so the ids cost the other nothing. */
static inline void list_lanes(const struct bc_svo_rpn *r, const uint32_t *idx,
                              uint32_t n, const float *px, const float *py,
                              const float *pz, uint32_t live, float *out,
                              uint32_t *prim)
{
	float st[BC_EVAL_STACK][BC__SVO_LANES];
	uint32_t who[BC_EVAL_STACK][BC__SVO_LANES];
	uint32_t sp = 0;
	for (uint32_t k = 0; k < n; k++) {
		lanes_step(r, idx[k], st, &sp, px, py, pz, live,
		           prim ? who : NULL);
	}
	for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
		out[j] = sp ? st[0][j] : INFINITY;
		if (prim) {
			prim[j] = sp ? who[0][j] : BC_NONE;
		}
	}
}

void bc__svo_list_eval_lanes(const struct bc_svo_rpn *r, const uint32_t *idx,
                             uint32_t n, const float *px, const float *py,
                             const float *pz, uint32_t live, float *out)
{
	list_lanes(r, idx, n, px, py, pz, live, out, NULL);
}

void bc__svo_list_eval_lanes_id(const struct bc_svo_rpn *r, const uint32_t *idx,
                                uint32_t n, const float *px, const float *py,
                                const float *pz, uint32_t live, float *out,
                                uint32_t *prim)
{
	list_lanes(r, idx, n, px, py, pz, live, out, prim);
}

void bc_svo_cmask_eval_n(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                         const float (*p)[3], uint32_t n, float *out)
{
	/* The n points fill the first n lanes (and, for the loops that run
	 * every lane, the others again). */
	float px[BC__SVO_LANES], py[BC__SVO_LANES], pz[BC__SVO_LANES];
	float st[BC_EVAL_STACK][BC__SVO_LANES];
	uint32_t sp = 0, live;
	if (n == 0) {
		return;
	}
	n = n < BC__SVO_LANES ? n : BC__SVO_LANES;
	live = (uint32_t)((1ull << n) - 1u);
	for (uint32_t j = 0; j < BC__SVO_LANES; j++) {
		px[j] = p[j % n][0];
		py[j] = p[j % n][1];
		pz[j] = p[j % n][2];
	}
	for (uint32_t w = 0; w < m.nwords; w++) {
		uint32_t base = m.pairs[2 * w] << 5, b = m.pairs[2 * w + 1];
		while (b) {
			lanes_step(r, base + bc__svo_lowest(b), st, &sp, px, py,
			           pz, live, NULL);
			b &= b - 1u;
		}
	}
	for (uint32_t j = 0; j < n; j++) {
		out[j] = sp ? st[0][j] : INFINITY;
	}
}

void bc_svo_cmask_eval4(const struct bc_svo_rpn *r, struct bc_svo_cmask m,
                        const float p[4][3], float out[4])
{
	bc_svo_cmask_eval_n(r, m, p, 4, out);
}
