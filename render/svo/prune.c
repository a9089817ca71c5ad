/*
 * Pruning a variant over a region (thesis §5.3, Alg. 5.4-5.5), extended to
 * the compact smooth operators.
 *
 * The thesis prunes bottom-up while it evaluates ranges: with Boolean
 * operators only, every node needs nothing but its operands' signs, so a
 * decision at a node never depends on what lies above it. With blending
 * operators that is no longer true: under an operator that blends in the
 * region, its operands' values matter, not only their signs. So we prune in
 * two passes. The first is the thesis's bottom-up range evaluation (range
 * of every active term, and its operands). The second walks top-down from
 * the root carrying a mode:
 *   SIGN   the node's sign against every level c of a band must be kept
 *          (the band is [0, b] at the root: b is the caster's hit
 *          thickness; a negation flips it to [-b, 0], a unary value map
 *          moves it);
 *   VALUE  the node's value must be kept.
 * At a sharp operator (or a smooth one that provably acts sharp over the
 * region, range.c) an operand is dropped, together with the operator, when
 *   - the other operand's range lies entirely on the selected side (the
 *     result is that operand's value: valid in both modes), or
 *   - in SIGN mode, it lies beyond every level on the neutral side (above
 *     the band for a union, below it for an intersection): the result then
 *     has the other operand's sign against every level.
 * A blending operator keeps both operands and puts them in VALUE mode; so
 * does a smooth operator that acts sharp but keeps both operands, since its
 * formula would blend operands whose values sign pruning had changed.
 * Operands that are dropped go with their whole active subtree (Alg. 5.5,
 * bc_svo_rpn_clear_subtree).
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

enum {
	MODE_VALUE = 1u, /* else SIGN, against the levels in g->lev */
};

static inline bool is_union(uint8_t kind)
{
	return kind == BC_OP_UNION || kind == BC_OP_SMOOTH_UNION;
}

int bc_svo_prune(struct bc_svo_ranger *g, const uint32_t *mask_in,
                 uint32_t *mask_out, const struct bc_svo_region *region,
                 float band, struct bc_svo_prune_result *res)
{
	const struct bc_svo_rpn *r = g->rpn;
	uint32_t *stk = g->mark;
	uint8_t *mode = g->mode;
	struct bc_svo_ivl *lev = g->lev;
	uint32_t n = 0, sp = 0, count = 0;
	memset(res, 0, sizeof(*res));
	if (!(band >= 0.0f) || !isfinite(band)) {
		return BC_EINVAL;
	}
	/* The active terms, in order (Alg. 5.2 iteration). */
	for (uint32_t i = bc_svo_bits_next(mask_in, r->nwords, 0);
	     i != UINT32_MAX;
	     i = bc_svo_bits_next(mask_in, r->nwords, i + 1u)) {
		if (i >= r->n) {
			return BC_EINVAL; /* padding bits set */
		}
		g->idx[n++] = i;
	}
	if (mask_out != mask_in) {
		memcpy(mask_out, mask_in,
		       (size_t)r->nwords * sizeof(*mask_out));
	}
	if (n == 0) {
		res->state = BC_SVO_STATE_EMPTY;
		res->root.lo = res->root.hi = INFINITY;
		return 0;
	}
	res->root = bc_svo_range(g, g->idx, n, region);
	if (res->root.lo > (double)band || res->root.hi < 0.0) {
		/* The thesis's last step: the whole region is on one side of
		 * every level, nothing needs evaluating. */
		res->state = res->root.lo > (double)band ? BC_SVO_STATE_EMPTY
		                                         : BC_SVO_STATE_FULL;
		memset(mask_out, 0, (size_t)r->nwords * sizeof(*mask_out));
		return 0;
	}
	stk[sp] = g->idx[n - 1];
	lev[sp].lo = 0.0;
	lev[sp].hi = (double)band;
	mode[sp++] = 0;
	while (sp) {
		uint32_t i = stk[--sp];
		uint8_t m = mode[sp];
		struct bc_svo_ivl L = lev[sp];
		const struct bc_svo_term *t = &r->terms[i];
		uint32_t a, b, keep = UINT32_MAX;
		struct bc_svo_ivl A, B;
		const float *rec;
		double lo, hi;
		bool sharp;
		if (t->type == BC_SVO_TERM_PRIM) {
			count++;
			continue;
		}
		if (t->type == BC_SVO_TERM_NEG) {
			count++;
			stk[sp] = g->kid0[i];
			lev[sp].lo = -L.hi;
			lev[sp].hi = -L.lo;
			mode[sp++] = m;
			continue;
		}
		if (t->type == BC_SVO_TERM_UNARY) {
			/* A value map moves the levels its child's sign is
			 * taken against: f - a against c is f against c + a
			 * (offset), k f against c is f against c / k (scale),
			 * |f| - t against c is f against +-(t + c), all
			 * within [-(t + max |c|), t + max |c|] (onion).
			 * Twist's and bend's factor varies over the region:
			 * there the child keeps its value, which every
			 * decision below still allows when one operand is
			 * wholly on the selected side. */
			const float *ur =
			    r->urec + (size_t)t->rec * BC_SVO_UNARY_REC;
			struct bc_svo_ivl cl = L;
			uint8_t cm = m;
			switch (t->kind) {
			case BC_OP_OFFSET:
				cl.lo = L.lo + ur[0];
				cl.hi = L.hi + ur[0];
				break;
			case BC_OP_SCALE:
				cl.lo = L.lo / ur[0];
				cl.hi = L.hi / ur[0];
				break;
			case BC_OP_ONION:
				cl.hi =
				    ur[0] + bc__dmax(fabs(L.lo), fabs(L.hi));
				cl.lo = -cl.hi;
				break;
			default:
				cm = (uint8_t)(m | MODE_VALUE);
				break;
			}
			/* The float map rounds: a level may move by its
			 * margin (range.c uses the same). */
			{
				double mg =
				    BC__SVO_ROUND_REL *
				        (bc__dmax(fabs(cl.lo), fabs(cl.hi)) +
				         fabs((double)ur[0])) +
				    BC__SVO_ROUND_ABS;
				cl.lo -= mg;
				cl.hi += mg;
			}
			count++;
			stk[sp] = g->kid0[i];
			lev[sp] = cl;
			mode[sp++] = cm;
			continue;
		}
		a = g->kid0[i];
		b = g->kid1[i];
		A = g->ivl[a];
		B = g->ivl[b];
		rec = r->rec + t->rec;
		lo = L.lo;
		hi = L.hi;
		sharp = bc__svo_op_sharp_in((enum bc_op)t->kind, rec[0], rec[1],
		                            A, B);
		if (sharp) {
			if (is_union(t->kind)) {
				keep = A.hi <= B.lo ? a
				                    : (B.hi <= A.lo ? b : keep);
				if (keep == UINT32_MAX && !(m & MODE_VALUE)) {
					keep = A.lo > hi
					           ? b
					           : (B.lo > hi ? a : keep);
				}
			} else {
				keep = A.lo >= B.hi ? a
				                    : (B.lo >= A.hi ? b : keep);
				if (keep == UINT32_MAX && !(m & MODE_VALUE)) {
					keep = A.hi < lo
					           ? b
					           : (B.hi < lo ? a : keep);
				}
			}
		}
		if (keep != UINT32_MAX) {
			bc__svo_clear(mask_out, i);
			bc_svo_rpn_clear_subtree(r, mask_out,
			                         keep == a ? b : a);
			stk[sp] = keep;
			lev[sp] = L;
			mode[sp++] = m;
			continue;
		}
		count++;
		if (bc_op_is_smooth((enum bc_op)t->kind)) {
			m |= MODE_VALUE;
		}
		stk[sp] = a;
		lev[sp] = L;
		mode[sp++] = m;
		stk[sp] = b;
		lev[sp] = L;
		mode[sp++] = m;
	}
	res->state = BC_SVO_STATE_ACTIVE;
	res->nterms = count;
	return 0;
}
