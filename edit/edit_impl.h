/*
 * Names shared inside the edit module (not part of its API).
 */
#ifndef BLOBCAST_EDIT_IMPL_H
#define BLOBCAST_EDIT_IMPL_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/edit.h"

/* The node a REMOVE of id takes out: id, or the top of the chain of unary
 * nodes above it (a unary node cannot lose its only child, PROTOCOL.md
 * 9); 0 for an unknown id. */
uint32_t bc__edit_removed_top(const struct bc_tree *t, uint32_t id);

/* Sets inv up for n operations (each a REMOVE of id 0 until written).
 * Returns 0 or BC_ENOMEM. */
int bc__inverse_init(struct bc_edit_inverse *inv, uint32_t n);

/* Before operation e of a batch is applied to t: notes in *was, or in
 * inv's operation k, what its inverse needs from the tree as it is (the
 * batch's inverse runs newest first: operation i of n has k = n - 1 - i).
 * An operation that t will refuse is passed over. Returns 0, BC_ENOMEM or
 * BC_ELIMIT (a subtree over one message). */
int bc__inverse_before(struct bc_edit_inverse *inv, const struct bc_tree *t,
                       const struct bc_proto_edit_op *e, uint32_t k,
                       struct bc_edit_saved *was);
/* After e applied to t: completes inv's operation k. Returns 0 or
 * BC_ENOMEM. */
int bc__inverse_after(struct bc_edit_inverse *inv, const struct bc_tree *t,
                      const struct bc_proto_edit_op *e, uint32_t k,
                      const struct bc_edit_saved *was);

/* Whether inv's subtrees stay within what a scene of old_nodes nodes
 * encodes to at least, so that bc__inverse_bound would leave inv as it
 * is. */
bool bc__inverse_fits(const struct bc_edit_inverse *inv, uint32_t old_nodes);

/* When the subtrees of inv (the inverse of the batch that made now from
 * old) add up past old's own encoding, makes inv one REPLACE of now's root
 * by old. Returns 0 or BC_ENOMEM (inv as it was). */
int bc__inverse_bound(struct bc_edit_inverse *inv, const struct bc_tree *old,
                      const struct bc_tree *now);

#endif
