/*
 * Atomic batches: an EDIT's operations apply whole or not at all, and an
 * applied batch can be undone. A batch of SETs changes the tree in place
 * (parameter edits keep the layout, which is what makes them cheap) and
 * saves each node first. A batch with a structural operation changes the
 * tree in place too, noting before each operation what undoes it
 * (inverse.c): when an operation fails, the notes of those before it are
 * applied, newest first, and give back the tree as it was, node for node
 * and (blobtree lays out one tree one way, whatever edits made it) slot
 * for slot. Nothing is copied, so a structural edit costs what it changes,
 * not the scene. The result is handed out as another tree object
 * (bc_tree_swap, O(1)) and the caller's object, emptied, is kept in
 * b->old, as when the batch worked on a copy. Where the notes cannot be
 * kept (a removed subtree over one message; out of memory), or where an
 * undoable batch's notes outgrow the scene (bc__inverse_bound needs the
 * tree before), the batch is put back and applied to a copy instead.
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
 * first). *noted is set when the inverse could not be kept. */
static int apply_op(struct bc_edit_inverse *inv, struct bc_tree *work,
                    const struct bc_proto_edit_op *ops, uint32_t i, uint32_t n,
                    bool *noted, struct bc_errinfo *ei)
{
	struct bc_edit_saved was;
	int rc;
	*noted = false;
	if (inv &&
	    (rc = bc__inverse_before(inv, work, &ops[i], n - 1 - i, &was))) {
		*noted = true;
		return bc_errinfo_set(ei, rc,
		                      "operation %u: %s keeping what undoes it",
		                      i, bc_strerror(rc));
	}
	if ((rc = bc_edit_apply_op(work, &ops[i], ei))) {
		return at_op(ei, rc, i);
	}
	if (inv &&
	    (rc = bc__inverse_after(inv, work, &ops[i], n - 1 - i, &was))) {
		/* Only a SET's note needs memory here: its node's state
		 * goes back directly, so the batch stands as before it. */
		if (ops[i].kind == BC_PROTO_EDIT_SET) {
			bc_edit_saved_restore(work, &was);
		}
		*noted = true;
		return bc_errinfo_set(ei, rc,
		                      "operation %u: %s keeping what undoes it",
		                      i, bc_strerror(rc));
	}
	return 0;
}

/* Applies the inverse's operations k0..nops-1 to t in order: undoes the
 * batch's operations nops-1-k0 .. 0, newest first. They put back states
 * that were valid, so only memory can fail (the nodes freed by what they
 * undo are there again for the taking). */
static int put_back(struct bc_tree *t, const struct bc_edit_inverse *inv,
                    uint32_t k0)
{
	struct bc_errinfo ei = {0};
	int rc = 0;
	for (uint32_t k = k0; k < inv->nops && !rc; k++) {
		rc = bc_edit_apply_op(t, &inv->ops[k], &ei);
	}
	return rc;
}

/* The structural batch on a copy of *tp that replaces it when every
 * operation succeeded. */
static int apply_on_copy(struct bc_edit_batch *b, struct bc_tree **tp,
                         const struct bc_proto_edit_op *ops, uint32_t n,
                         bool undoable, struct bc_errinfo *ei)
{
	struct bc_tree *t = *tp, *work;
	struct bc_edit_inverse *inv = NULL;
	bool noted;
	int rc = 0;
	if (undoable && bc__inverse_init(&b->inv, n) == 0) {
		inv = &b->inv;
	}
	if ((undoable && !inv) || !(work = bc_tree_create())) {
		bc_edit_batch_finish(b);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	/* The copy is laid out, or bare, as the tree it replaces. */
	bc_tree_set_layout(work, bc_tree_lays_out(t));
	if ((rc = bc_tree_copy(work, t, ei))) {
		bc_tree_destroy(work);
		bc_edit_batch_finish(b);
		return rc;
	}
	for (uint32_t i = 0; i < n && !rc; i++) {
		rc = apply_op(inv, work, ops, i, n, &noted, ei);
	}
	if (!rc && inv && (rc = bc__inverse_bound(inv, t, work))) {
		rc = bc_errinfo_set(ei, rc, "no memory for what undoes it");
	}
	if (rc) {
		bc_tree_destroy(work);
		bc_edit_batch_finish(b);
		return rc;
	}
	b->structural = true;
	b->old = t;
	*tp = work;
	return 0;
}

/* The structural batch in place (the file's comment). Returns 0, a BC_E*
 * code, or 1 when the batch, put back, must go to a copy. */
static int apply_in_place(struct bc_edit_batch *b, struct bc_tree **tp,
                          const struct bc_proto_edit_op *ops, uint32_t n,
                          bool undoable, struct bc_errinfo *ei)
{
	struct bc_tree *t = *tp, *shell = NULL;
	uint32_t old_nodes = bc_tree_node_count(t), i;
	bool noted = false;
	int rc = 0;
	if (bc__inverse_init(&b->inv, n) || !(shell = bc_tree_create())) {
		bc_edit_batch_finish(b);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (i = 0; i < n && !rc; i++) {
		rc = apply_op(&b->inv, t, ops, i, n, &noted, ei);
	}
	if (rc) {
		i--; /* the operation that failed did not apply */
	} else if (undoable && !bc__inverse_fits(&b->inv, old_nodes)) {
		noted = true;
		rc = 1;
	}
	if (rc && put_back(t, &b->inv, n - i)) {
		bc_tree_destroy(shell);
		bc_edit_batch_finish(b);
		b->lost = true;
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "out of memory putting the scene back "
		                      "after a refused edit: reload the scene");
	}
	if (rc) {
		bc_tree_destroy(shell);
		bc_edit_batch_finish(b);
		/* Notes that could not be kept: a batch that need not be
		 * undoable, or whose notes only outgrew the scene, still
		 * applies on a copy. */
		return noted && (!undoable || rc == 1) ? 1 : rc;
	}
	bc_tree_swap(shell, t);
	b->structural = true;
	b->in_place = true;
	b->old = t;
	*tp = shell;
	return 0;
}

static int batch_apply(struct bc_edit_batch *b, struct bc_tree **tp,
                       const struct bc_proto_edit_op *ops, uint32_t n,
                       bool undoable, struct bc_errinfo *ei)
{
	struct bc_tree *t = *tp;
	bool structural = false;
	int rc = 0;
	memset(b, 0, sizeof(*b));
	for (uint32_t i = 0; i < n; i++) {
		if (ops[i].kind != BC_PROTO_EDIT_SET) {
			structural = true;
		}
	}
	if (structural) {
		rc = apply_in_place(b, tp, ops, n, undoable, ei);
		return rc == 1 ? apply_on_copy(b, tp, ops, n, undoable, ei)
		               : rc;
	}
	if (n > 0 && !(b->saved = bc_calloc(n, sizeof(*b->saved)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (uint32_t i = 0; i < n && !rc; i++) {
		struct bc_edit_saved *s = &b->saved[b->nsaved];
		s->id = ops[i].node;
		if (bc_tree_get(t, ops[i].node, &s->p, &s->op)) {
			bc_tree_get_unary(t, ops[i].node, &s->un);
			b->nsaved++;
		}
		if ((rc = bc_edit_apply_op(t, &ops[i], ei))) {
			rc = at_op(ei, rc, i);
		}
	}
	if (rc) {
		restore(t, b->saved, b->nsaved);
		bc_edit_batch_finish(b);
		return rc;
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

int bc_edit_batch_undo(struct bc_edit_batch *b, struct bc_tree **tp)
{
	int rc = 0;
	if (b->structural && b->old && b->in_place) {
		/* Applied in place: its notes put the tree back, which goes
		 * into the caller's object again. */
		rc = put_back(*tp, &b->inv, 0);
		bc_tree_swap(b->old, *tp);
		bc_tree_destroy(*tp);
		*tp = b->old;
		b->old = NULL;
	} else if (b->structural && b->old) {
		bc_tree_destroy(*tp);
		*tp = b->old;
		b->old = NULL;
	} else if (!b->structural) {
		restore(*tp, b->saved, b->nsaved);
	}
	bc_edit_batch_finish(b);
	return rc;
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
