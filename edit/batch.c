/*
 * Atomic batches: an EDIT's operations apply whole or not at all, and an
 * applied batch can be undone. A batch of SETs changes the tree in place
 * (parameter edits keep the layout, which is what makes them cheap) and
 * saves each node first; a batch with a structural operation works on a
 * copy that replaces the tree only when every operation succeeded, and,
 * asked to, notes operation by operation what undoes it (inverse.c).
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "edit_impl.h"

/* Puts back the saved nodes, newest first: each restore writes a state
 * that was valid, so it cannot fail. */
static void restore(struct bc_tree *t, const struct bc_edit_saved *s,
                    uint32_t n)
{
	while (n-- > 0) {
		bc_edit_saved_restore(t, &s[n]);
	}
}

/* Prefixes ei's text with the failing operation's index. */
static int at_op(struct bc_errinfo *ei, int rc, uint32_t i)
{
	char why[sizeof(ei->msg)];
	memcpy(why, ei->msg, sizeof(why));
	return bc_errinfo_set(ei, rc, "operation %u: %.200s", i, why);
}

/* Operation i of a structural batch applied to work, with its inverse
 * noted when inv is given (op n - 1 - i of it: the inverse runs newest
 * first). */
static int apply_op(struct bc_edit_inverse *inv, struct bc_tree *work,
                    const struct bc_proto_edit_op *ops, uint32_t i, uint32_t n,
                    struct bc_errinfo *ei)
{
	struct bc_edit_saved was;
	int rc;
	if (inv &&
	    (rc = bc__inverse_before(inv, work, &ops[i], n - 1 - i, &was))) {
		return bc_errinfo_set(ei, rc,
		                      "operation %u: %s keeping what undoes it",
		                      i, bc_strerror(rc));
	}
	if ((rc = bc_edit_apply_op(work, &ops[i], ei))) {
		return at_op(ei, rc, i);
	}
	if (inv &&
	    (rc = bc__inverse_after(inv, work, &ops[i], n - 1 - i, &was))) {
		return bc_errinfo_set(ei, rc,
		                      "operation %u: %s keeping what undoes it",
		                      i, bc_strerror(rc));
	}
	return 0;
}

static int batch_apply(struct bc_edit_batch *b, struct bc_tree **tp,
                       const struct bc_proto_edit_op *ops, uint32_t n,
                       bool undoable, struct bc_errinfo *ei)
{
	struct bc_tree *t = *tp, *work = t;
	struct bc_edit_inverse *inv = NULL;
	int rc = 0;
	memset(b, 0, sizeof(*b));
	for (uint32_t i = 0; i < n; i++) {
		if (ops[i].kind != BC_PROTO_EDIT_SET) {
			b->structural = true;
		}
	}
	if (b->structural) {
		if (undoable && bc__inverse_init(&b->inv, n) == 0) {
			inv = &b->inv;
		}
		if ((undoable && !inv) || !(work = bc_tree_create())) {
			bc_edit_batch_finish(b);
			return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		}
		if ((rc = bc_tree_copy(work, t, ei))) {
			bc_tree_destroy(work);
			bc_edit_batch_finish(b);
			return rc;
		}
	} else if (n > 0 && !(b->saved = bc_calloc(n, sizeof(*b->saved)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (uint32_t i = 0; i < n && !rc; i++) {
		if (b->structural) {
			rc = apply_op(inv, work, ops, i, n, ei);
			continue;
		}
		{
			struct bc_edit_saved *s = &b->saved[b->nsaved];
			s->id = ops[i].node;
			if (bc_tree_get(work, ops[i].node, &s->p, &s->op)) {
				bc_tree_get_unary(work, ops[i].node, &s->un);
				b->nsaved++;
			}
		}
		if ((rc = bc_edit_apply_op(work, &ops[i], ei))) {
			rc = at_op(ei, rc, i);
		}
	}
	if (rc) {
		if (b->structural) {
			bc_tree_destroy(work);
		} else {
			restore(t, b->saved, b->nsaved);
		}
		bc_edit_batch_finish(b);
		return rc;
	}
	if (inv && (rc = bc__inverse_bound(inv, t, work))) {
		bc_tree_destroy(work);
		bc_edit_batch_finish(b);
		return bc_errinfo_set(ei, rc, "no memory for what undoes it");
	}
	if (b->structural) {
		b->old = t;
		*tp = work;
	}
	return 0;
}

int bc_edit_batch_apply(struct bc_edit_batch *b, struct bc_tree **tp,
                        const struct bc_proto_edit_op *ops, uint32_t n,
                        struct bc_errinfo *ei)
{
	return batch_apply(b, tp, ops, n, false, ei);
}

int bc_edit_batch_apply_undoable(struct bc_edit_batch *b, struct bc_tree **tp,
                                 const struct bc_proto_edit_op *ops, uint32_t n,
                                 struct bc_errinfo *ei)
{
	return batch_apply(b, tp, ops, n, true, ei);
}

void bc_edit_batch_undo(struct bc_edit_batch *b, struct bc_tree **tp)
{
	if (b->structural && b->old) {
		bc_tree_destroy(*tp);
		*tp = b->old;
		b->old = NULL;
	} else if (!b->structural) {
		restore(*tp, b->saved, b->nsaved);
	}
	bc_edit_batch_finish(b);
}

void bc_edit_batch_finish(struct bc_edit_batch *b)
{
	if (!b) {
		return;
	}
	bc_tree_destroy(b->old);
	bc_free(b->saved);
	bc_edit_inverse_finish(&b->inv);
	memset(b, 0, sizeof(*b));
}

int bc_edit_replay(struct bc_tree **tp, const struct bc_msg_edit_applied *ea,
                   struct bc_errinfo *ei)
{
	struct bc_edit_batch b;
	int rc = bc_edit_batch_apply(&b, tp, ea->ops, ea->nops, ei);
	bc_edit_batch_finish(&b);
	return rc;
}
