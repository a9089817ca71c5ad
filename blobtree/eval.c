/*
 * Field evaluation on the linearized tree: full bottom-up evaluation (the
 * reference), and the sparse bottom-up traversal over a set of active
 * primitives (Zanni 2024, §5) that builds a pruned tree view (§6.2).
 *
 * The sparse traversal. The paper's text omits its Algorithm 2; this is our
 * formulation. A primitive outside the query volume's ABV set is "missing":
 * its value is taken as +inf. Then an operator with one missing operand is a
 * selector: union passes the other operand through; intersection becomes
 * missing; difference passes its left operand and becomes missing when only
 * its right one is present. Active primitives are visited in post-order with
 * a stack of complete subtrees, each marked present or missing. After a
 * push, the top entry climbs: while its parent holds no other active
 * primitive (the parent's subtree starts after the entry below and ends
 * before the next active primitive), it stands for its parent -- becoming
 * missing if the edge kills. That climb is monotone, so jump pointers make it
 * O(log depth) (a left comb is one jump, not a walk). When the parent does
 * hold the entry below, both are its operands: the parent is evaluated (an
 * instruction) or selects. Entries that become missing take back the
 * instructions they had emitted, which are always the program's tail.
 */
#include "blobcast/blobtree.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

static inline float eval_record(uint32_t kind, const float *rec, const float p[3])
{
	float x = rec[0] * p[0] + rec[1] * p[1] + rec[2] * p[2] + rec[3];
	float y = rec[4] * p[0] + rec[5] * p[1] + rec[6] * p[2] + rec[7];
	float z = rec[8] * p[0] + rec[9] * p[1] + rec[10] * p[2] + rec[11];
	return bc_prim_sdf((enum bc_prim)kind, rec + 12, x, y, z);
}

float bc_eval_prim(const struct bc_lin *l, uint32_t k, const float p[3])
{
	uint32_t s = l->prim_slot[k];
	return eval_record(bc_lin_kind(l, s), bc_lin_param(l, s), p);
}

/* Which operand an operator's value follows, for colours and ids: the one
 * with the smaller value for unions, the larger for intersections, and for
 * differences the left unless the negated right one wins. */
static inline bool follows_right(enum bc_op op, float f0, float f1)
{
	switch (bc_op_class(op)) {
	case BC_OPCLASS_UNION:
		return f1 < f0;
	case BC_OPCLASS_INTERSECTION:
		return f1 > f0;
	case BC_OPCLASS_DIFFERENCE:
	default:
		return -f1 > f0;
	}
}

static float full(const struct bc_lin *l, const float p[3], uint32_t *prim)
{
	float val[BC_EVAL_STACK];
	uint32_t who[BC_EVAL_STACK];
	uint32_t sp = 0;
	for (uint32_t s = 0; s < l->count; s++) {
		uint32_t kind = bc_lin_kind(l, s);
		const float *rec = bc_lin_param(l, s);
		if (bc_lin_is_leaf(l, s)) {
			val[sp] = eval_record(kind, rec, p);
			who[sp++] = l->prim_of[s];
		} else {
			float f1 = val[--sp];
			float f0 = val[sp - 1];
			val[sp - 1] = bc_op_eval((enum bc_op)kind, rec[0],
						 rec[1], f0, f1);
			if (prim && follows_right((enum bc_op)kind, f0, f1)) {
				who[sp - 1] = who[sp];
			}
		}
	}
	if (prim) {
		*prim = sp ? who[0] : BC_NONE;
	}
	return sp ? val[0] : INFINITY;
}

float bc_eval_full(const struct bc_lin *l, const float p[3])
{
	return full(l, p, NULL);
}

float bc_eval_full_id(const struct bc_lin *l, const float p[3], uint32_t *prim)
{
	return full(l, p, prim);
}

/* ---- views -------------------------------------------------------------- */

void bc_view_init(struct bc_view *v)
{
	memset(v, 0, sizeof(*v));
}

void bc_view_finish(struct bc_view *v)
{
	if (v) {
		bc_free(v->instr);
		memset(v, 0, sizeof(*v));
	}
}

static int reserve(struct bc_view *v, uint32_t n)
{
	struct bc_view_instr *grown;
	uint32_t cap = v->cap ? v->cap : 64;
	if (n <= v->cap) {
		return 0;
	}
	while (cap < n) {
		cap *= 2;
	}
	grown = bc_reallocarray(v->instr, cap, sizeof(*grown));
	if (!grown) {
		return BC_ENOMEM;
	}
	v->instr = grown;
	v->cap = cap;
	return 0;
}

struct entry {
	uint32_t slot;
	uint32_t start; /* first instruction of its code */
	bool missing;
};

static void emit(struct bc_view *v, const struct bc_lin *l, uint32_t s)
{
	struct bc_view_instr *in = &v->instr[v->n++];
	in->slot = s;
	in->param = l->node[2 * s + 1];
	in->kind = (uint16_t)bc_lin_kind(l, s);
	in->leaf = bc_lin_is_leaf(l, s) ? 1 : 0;
	in->pad = 0;
}

/* Can the entry climb to ancestor a? a must be complete (before the next
 * active slot q) and hold nothing of the entry below (first >= lo). */
static inline bool may_climb(const struct bc_lin *l, uint32_t a, uint32_t q,
			     uint32_t lo)
{
	return a < q && l->first[a] >= lo;
}

/* Combines the two top entries as the operands of slot a (both complete). */
static void combine(struct bc_view *v, const struct bc_lin *l,
		    struct entry *left, const struct entry *right, uint32_t a)
{
	enum bc_op_class cls = bc_op_class((enum bc_op)bc_lin_kind(l, a));
	bool missing;
	if (!left->missing && !right->missing) {
		emit(v, l, a);
		missing = false;
	} else if (left->missing && right->missing) {
		missing = true;
	} else if (left->missing) {
		/* Only the right operand: unions pass it on. */
		missing = cls != BC_OPCLASS_UNION;
	} else {
		/* Only the left operand: intersections lose it. */
		missing = cls == BC_OPCLASS_INTERSECTION;
	}
	if (missing) {
		v->n = left->start;
	}
	left->slot = a;
	left->missing = missing;
}

int bc_view_build(struct bc_view *v, const struct bc_lin *l,
		  const uint32_t *active, uint32_t n)
{
	struct entry st[BC_EVAL_STACK];
	uint32_t sp = 0, depth = 0;
	int rc;
	bool empty;
	v->n = 0;
	v->stack = 0;
	v->empty = true;
	if (!l || n == 0) {
		return 0;
	}
	/* At most 2n - 1 instructions: n leaves and n - 1 operators. */
	if ((rc = reserve(v, 2 * n))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		uint32_t k = active[i];
		uint32_t q;
		if (k >= l->nprims || (i > 0 && k <= active[i - 1])) {
			v->n = 0;
			return BC_EINVAL;
		}
		q = (i + 1 < n) ? l->prim_slot[active[i + 1]] : UINT32_MAX;
		if (i + 1 < n && active[i + 1] >= l->nprims) {
			v->n = 0;
			return BC_EINVAL;
		}
		if (sp >= BC_EVAL_STACK) {
			/* Unreachable for trees within the depth limit. */
			v->n = 0;
			return BC_EDEPTH;
		}
		st[sp].slot = l->prim_slot[k];
		st[sp].start = v->n;
		st[sp].missing = false;
		sp++;
		emit(v, l, l->prim_slot[k]);
		for (;;) {
			struct entry *top = &st[sp - 1];
			uint32_t lo = sp >= 2 ? st[sp - 2].slot + 1 : 0;
			uint32_t x = top->slot, a;
			/* Climb through ancestors that hold no other operand:
			 * the fast index first (whole same-side runs), then
			 * the jump pointer, then the parent. */
			for (;;) {
				uint32_t j = l->fast[x];
				if (j != BC_NONE && may_climb(l, j, q, lo)) {
					x = j;
					continue;
				}
				j = l->jump[x];
				if (j != BC_NONE && may_climb(l, j, q, lo)) {
					x = j;
					continue;
				}
				a = bc_lin_parent(l, x);
				if (a != BC_NONE && may_climb(l, a, q, lo)) {
					x = a;
					continue;
				}
				break;
			}
			if (x != top->slot && l->kills[top->slot] != l->kills[x] &&
			    !top->missing) {
				top->missing = true;
				v->n = top->start;
			}
			top->slot = x;
			a = bc_lin_parent(l, x);
			if (a == BC_NONE || a >= q) {
				break;
			}
			/* The parent holds the entry below: both operands. */
			combine(v, l, &st[sp - 2], top, a);
			sp--;
		}
	}
	empty = sp == 0 || st[0].missing;
	v->empty = empty;
	if (empty) {
		v->n = 0;
	}
	/* The evaluation stack the program needs. */
	for (uint32_t i = 0; i < v->n; i++) {
		depth = v->instr[i].leaf ? depth + 1 : depth - 1;
		if (depth > v->stack) {
			v->stack = depth;
		}
	}
	return 0;
}

static float run(const struct bc_view *v, const struct bc_lin *l,
		 const float p[3], uint32_t *prim)
{
	float val[BC_EVAL_STACK];
	uint32_t who[BC_EVAL_STACK];
	uint32_t sp = 0;
	if (v->empty || v->n == 0) {
		if (prim) {
			*prim = BC_NONE;
		}
		return INFINITY;
	}
	for (uint32_t i = 0; i < v->n; i++) {
		const struct bc_view_instr *in = &v->instr[i];
		const float *rec = l->param + 4u * (size_t)in->param;
		if (in->leaf) {
			val[sp] = eval_record(in->kind, rec, p);
			who[sp++] = l->prim_of[in->slot];
		} else {
			float f1 = val[--sp];
			float f0 = val[sp - 1];
			val[sp - 1] = bc_op_eval((enum bc_op)in->kind, rec[0],
						 rec[1], f0, f1);
			if (prim && follows_right((enum bc_op)in->kind, f0, f1)) {
				who[sp - 1] = who[sp];
			}
		}
	}
	if (prim) {
		*prim = who[0];
	}
	return val[0];
}

float bc_view_eval(const struct bc_view *v, const struct bc_lin *l,
		   const float p[3])
{
	return run(v, l, p, NULL);
}

float bc_view_eval_id(const struct bc_view *v, const struct bc_lin *l,
		      const float p[3], uint32_t *prim)
{
	return run(v, l, p, prim);
}

float bc_eval_sparse(const struct bc_lin *l, const uint32_t *active, uint32_t n,
		     struct bc_view *scratch, const float p[3])
{
	if (bc_view_build(scratch, l, active, n)) {
		return NAN;
	}
	return bc_view_eval(scratch, l, p);
}
