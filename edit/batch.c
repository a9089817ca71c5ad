/*
 * Atomic batches: an EDIT's operations apply whole or not at all, and an
 * applied batch can be undone. A batch of SETs changes the tree in place
 * (parameter edits keep the layout, which is what makes them cheap) and
 * saves each node first; a batch with a structural operation works on a
 * copy that replaces the tree only when every operation succeeded.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"

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

int bc_edit_batch_apply(struct bc_edit_batch *b, struct bc_tree **tp,
                        const struct bc_proto_edit_op *ops, uint32_t n,
                        struct bc_errinfo *ei)
{
	struct bc_tree *t = *tp, *work = t;
	int rc = 0;
	memset(b, 0, sizeof(*b));
	for (uint32_t i = 0; i < n; i++) {
		if (ops[i].kind != BC_PROTO_EDIT_SET) {
			b->structural = true;
		}
	}
	if (b->structural) {
		if (!(work = bc_tree_create())) {
			return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		}
		if ((rc = bc_tree_copy(work, t, ei))) {
			bc_tree_destroy(work);
			return rc;
		}
	} else if (n > 0 && !(b->saved = bc_calloc(n, sizeof(*b->saved)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (uint32_t i = 0; i < n && !rc; i++) {
		if (!b->structural) {
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
	if (b->structural) {
		b->old = t;
		*tp = work;
	}
	return 0;
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
