/*
 * Where a node's surface lies, read from the model alone: bc_tree_node_box
 * gives the AABB of the world ABVs that a layout gives the primitives of a
 * node's subtree, the same floats, whether the tree is laid out or bare.
 *
 * A layout places primitive k's ABV from the ROI of its slot (paper eq.
 * 13-16: each operator's rule from its parent's ROI down to the slot,
 * then the slot's unary wrappers outermost first) and the domain nodes
 * around it (the shape mapped through each, innermost first). The walk
 * here carries the same two things down the model: the ROI of a node's
 * value as its parent gives it, and the records of the domain nodes above
 * it, using the layout's own rules (bc__roi_operand, bc__roi_unary,
 * bc__abv_preimage). In the left-folded chain of an n-ary operator every
 * rule is idempotent, so its first operand gets the rule's left ROI and
 * every other the right one, as if the operator were one slot; a unary
 * node takes no slot (its rule is a wrapper's on its child's).
 *
 * Without recursion (trees nest 2^20 deep): one frame per operator of
 * several operands on the way down, and a stack of domain records.
 */
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "tree_impl.h"

/* A domain node above the walk, its kind and record. */
struct dom {
	enum bc_op kind;
	float rec[4 * BC_UNARY_RECORD_VEC4];
};

/* An operator of several operands the walk is inside: its next operand
 * to visit, its ROI and the domain nodes above it. */
struct frame {
	uint32_t op, next;
	float lo, hi;
	uint32_t ndom;
};

struct walk {
	const struct bc_tree *t;
	struct dom *dom;
	struct frame *fr;
	uint32_t ndom, nfr;
	float lo[3], hi[3];
};

/* The ROI operand c of operator p gets from p's [lo, hi]. */
static void operand_roi(const struct bc__node *p, uint32_t c, float *lo,
                        float *hi)
{
	enum bc_op op = p->u.op.kind;
	if (p->u.nchildren < 2) {
		return; /* a unary node: no rule of an operator */
	}
	bc__roi_operand(op, bc_op_is_smooth(op) ? p->u.op.range : 0.0f,
	                p->u.first_child == c, lo, hi);
}

/* Unary node n on the way down: its rule on [lo, hi], and its record on
 * the domain stack when it is a domain node. */
static void enter_unary(struct walk *w, const struct bc__node *n, float *lo,
                        float *hi)
{
	float rec[4 * BC_UNARY_RECORD_VEC4];
	bc__unary_record(rec, w->t, n);
	bc__roi_unary(n->u.op.kind, rec, lo, hi);
	if (bc_op_is_domain(n->u.op.kind)) {
		w->dom[w->ndom].kind = n->u.op.kind;
		memcpy(w->dom[w->ndom].rec, rec, sizeof(rec));
		w->ndom++;
	}
}

/* Primitive n, its slot's ROI upper bound hi: its ABV as a layout places
 * it, grown into the box. */
static void add_prim(struct walk *w, const struct bc__node *n, float hi)
{
	struct bc_abv abv;
	float a[3], b[3];
	struct bc_prim_data p;
	bc__prim_read(w->t, n, &p);
	bc__abv_place(&p, hi, &abv);
	for (uint32_t d = w->ndom; d-- > 0;) {
		(void)bc__abv_preimage(w->dom[d].kind, w->dom[d].rec, &abv);
	}
	bc_abv_aabb(&abv, a, b);
	for (int i = 0; i < 3; i++) {
		w->lo[i] = fminf(w->lo[i], a[i]);
		w->hi[i] = fmaxf(w->hi[i], b[i]);
	}
}

/* The subtree at pool node n, entered with ROI [lo, hi] and the domain
 * stack of its ancestors. */
static void walk_subtree(struct walk *w, uint32_t n, float lo, float hi)
{
	const struct bc__node *pool = w->t->pool;
	uint32_t base = w->nfr;
	for (;;) {
		const struct bc__node *nd = &pool[n];
		if (!nd->is_op) {
			add_prim(w, nd, hi);
		} else if (nd->u.first_child != BC_NONE) {
			if (bc__node_unary(nd)) {
				enter_unary(w, nd, &lo, &hi);
			} else if (nd->u.nchildren > 1) {
				w->fr[w->nfr++] = (struct frame){
				    .op = n,
				    .next = pool[nd->u.first_child].next,
				    .lo = lo,
				    .hi = hi,
				    .ndom = w->ndom};
			}
			operand_roi(nd, nd->u.first_child, &lo, &hi);
			n = nd->u.first_child;
			continue;
		}
		/* Up to the innermost operator with an operand left. */
		while (w->nfr > base && w->fr[w->nfr - 1].next == BC_NONE) {
			w->nfr--;
		}
		if (w->nfr == base) {
			return;
		}
		{
			struct frame *f = &w->fr[w->nfr - 1];
			n = f->next;
			f->next = pool[n].next;
			lo = f->lo;
			hi = f->hi;
			w->ndom = f->ndom;
			operand_roi(&pool[f->op], n, &lo, &hi);
		}
	}
}

int bc_tree_node_box(const struct bc_tree *t, uint32_t id, float lo[3],
                     float hi[3])
{
	struct walk w = {.t = t};
	uint32_t n = t ? bc__id_find(t, id) : BC_NONE, depth = 0, *path;
	float rlo = 0.0f, rhi = 0.0f;
	int rc = 0;
	if (n == BC_NONE) {
		return BC_ENOTFOUND;
	}
	/* Nodes on the longest path bound every stack below. */
	path = bc_malloc(((size_t)t->nesting + 1u) * sizeof(*path));
	w.dom = bc_malloc(((size_t)t->nesting + 1u) * sizeof(*w.dom));
	w.fr = bc_malloc(((size_t)t->nesting + 1u) * sizeof(*w.fr));
	if (!path || !w.dom || !w.fr) {
		rc = BC_ENOMEM;
		goto out;
	}
	for (uint32_t a = n; a != BC_NONE && depth <= t->nesting;
	     a = t->pool[a].parent) {
		path[depth++] = a;
	}
	/* From the root down to n's parent: the ROI n gets, and the domain
	 * nodes above it. */
	for (uint32_t i = depth; i-- > 1;) {
		const struct bc__node *a = &t->pool[path[i]];
		if (bc__node_unary(a)) {
			enter_unary(&w, a, &rlo, &rhi);
		}
		operand_roi(a, path[i - 1], &rlo, &rhi);
	}
	for (int i = 0; i < 3; i++) {
		w.lo[i] = INFINITY;
		w.hi[i] = -INFINITY;
	}
	walk_subtree(&w, n, rlo, rhi);
	for (int i = 0; i < 3; i++) {
		if (!(isfinite(w.lo[i]) && isfinite(w.hi[i]) &&
		      w.lo[i] <= w.hi[i])) {
			rc = BC_ERANGE;
		}
		lo[i] = w.lo[i];
		hi[i] = w.hi[i];
	}
out:
	bc_free(path);
	bc_free(w.dom);
	bc_free(w.fr);
	return rc;
}
