/*
 * What an edit means (PROTOCOL.md section 9), in one place for the daemon
 * and every C client:
 *  - the SET fields: which field applies to which node and how its values
 *    land in the node's data (bc_edit_set_fields);
 *  - the key=value syntax people type (bc_edit_parse_kv);
 *  - atomic batches: an EDIT applies whole or not at all, and an applied
 *    batch can be undone (the daemon does when its journal write fails);
 *  - the replay of EDIT_APPLIED into a mirror, with the very code the
 *    server applied it with, so that mirrors cannot drift.
 * Damage (which pixels an edit changes) is not here: the daemon's render
 * thread computes it from the renderer's view of the scene.
 */
#ifndef BLOBCAST_EDIT_H
#define BLOBCAST_EDIT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/proto.h"

/* Writes the fields of SET e into the node's data: p when the node is a
 * primitive, op when it is an operator (is_op). Checks what the decoder
 * leaves to the server: that each field applies to this kind of node, its
 * value count, an operator kind that is an integer 1..6 (EENUM), and that
 * a sharp operator gets no blend or range: a SET that gives a sharp
 * operator (or makes one) a non-zero blend or range, and a SET that makes
 * a smooth operator sharp without giving blend 0 and range 0, are refused
 * (EINVAL), so that no field changes unless the SET names it. Range checks
 * are blobtree's (bc_tree_set_prim/op). Returns 0 or a BC_E* code with
 * the reason in ei. */
int bc_edit_set_fields(const struct bc_proto_edit_op *e, bool is_op,
                       struct bc_prim_data *p, struct bc_op_data *op,
                       struct bc_errinfo *ei);

/* The same for a unary node (u holds its current kind and parameters):
 * OP_KIND is an integer 7..14 (EENUM otherwise) and a new kind starts from
 * its defaults (bc_unary_init); PARAM0 is the kind's parameter (repeat:
 * PARAM0 spacing and PARAM0 + 1 count, 3 values each; elongate 3 values;
 * mirror the axes mask 1..7; the others 1 value). Range checks are
 * blobtree's (bc_tree_set_unary). */
int bc_edit_set_unary_fields(const struct bc_proto_edit_op *e,
                             struct bc_unary *u, struct bc_errinfo *ei);

/* Applies one operation to t, not atomically (a failure may leave t
 * changed for structural operations: use a batch). Refuses, besides what
 * blobtree refuses: a subtree with a node of id 0 (EINVAL; EDIT_APPLIED
 * repeats the subtree as sent, so every member must name its nodes alike)
 * and the removal of the root (EINVAL; a scene is never empty). Returns 0
 * or a BC_E* code. */
int bc_edit_apply_op(struct bc_tree *t, const struct bc_proto_edit_op *e,
                     struct bc_errinfo *ei);

/* Saved data of one node, to undo a parameter batch. */
struct bc_edit_saved {
	uint32_t id;
	struct bc_prim_data p;
	struct bc_op_data op;
	struct bc_unary un; /* when op.kind is a unary kind */
};

/* Puts a saved node's state back into t (a state that was valid: cannot
 * fail). */
void bc_edit_saved_restore(struct bc_tree *t, const struct bc_edit_saved *s);

/* A SET of node s->id that gives it back the saved state: every field of
 * the primitive (translate, rotate, each parameter, the colour when it has
 * one) or of the operator (kind, blend, range), written into *e and
 * fields (BC_PROTO_MAX_SET_FIELDS entries, which e points to). is_op: the
 * node is an operator. A SET cannot take a colour away: when s->p has none
 * and the node now has one, the caller needs a structural undo. */
void bc_edit_state_set(const struct bc_edit_saved *s, bool is_op,
                       struct bc_proto_edit_op *e,
                       struct bc_proto_field *fields);

/*
 * Operations that undo a change: applied as one batch (bc_edit_batch_apply)
 * to the tree the change made, they give back the tree before it, node for
 * node, ids included, and take memory and bytes on the wire in proportion
 * to the change, not the scene. An INSERT is undone by a REMOVE, a REMOVE
 * by an INSERT of the removed subtree with its ids at its place, a REPLACE
 * by a REPLACE with the earlier subtree, a SET by a SET of every field of
 * the earlier state. Two cases need a REPLACE of a bigger subtree, the
 * smallest that is exact: a REMOVE that took an operator left with one
 * child (undone by a REPLACE of that child by the operator's earlier
 * subtree) and a SET that gave a primitive its first colour (a REPLACE of
 * the primitive by itself without it). Each operation owns its fields or
 * subtree bytes; bc_edit_inverse_finish() frees them.
 */
struct bc_edit_inverse {
	struct bc_proto_edit_op *ops; /* in the order to apply them */
	void **owned;                 /* per operation: what it points to */
	uint32_t nops;
	size_t bytes; /* memory held, everything counted */
};

/* Frees what inv holds; accepts a zeroed inv. */
void bc_edit_inverse_finish(struct bc_edit_inverse *inv);

/* The operations that put the saved states s[0..n) back on their nodes in
 * t (distinct ids; t holds the nodes as they are now): a SET each, or the
 * one-node REPLACE above where a SET cannot take a colour away. inv is
 * reset on entry. Returns 0 or BC_ENOMEM (inv then empty). */
int bc_edit_inverse_of_states(struct bc_edit_inverse *inv,
                              const struct bc_tree *t,
                              const struct bc_edit_saved *s, uint32_t n);

/* What an applied batch needs to be undone. Zero it before use;
 * bc_edit_batch_finish() frees it. */
struct bc_edit_batch {
	bool structural; /* some operation changed the tree's shape */
	/* Structural: the caller's tree object. Emptied when the batch
	 * applied in place (in_place: its contents moved to the new *tp,
	 * and inv is what puts them back); the whole tree before the batch
	 * when it applied to a copy. */
	struct bc_tree *old;
	bool in_place;
	struct bc_edit_saved *saved; /* parameter batch: nodes before it */
	uint32_t nsaved;
	/* Structural, bc_edit_batch_apply_undoable() or applied in place:
	 * what undoes it. */
	struct bc_edit_inverse inv;
	/* Set by a failed apply that ran out of memory putting *tp back
	 * (BC_ENOMEM): *tp is then a valid tree, but not the one before. */
	bool lost;
};

/*
 * Applies ops[0..n) to *tp whole or not at all. A batch of SETs only is
 * applied in place (and put back if one fails). A batch with a structural
 * operation is applied in place too, each operation's inverse noted
 * first; a failure puts the earlier ones back with those notes (only out
 * of memory can stop that: the error then says so). On success *tp
 * becomes another tree object holding the result (O(1)) and b->old is the
 * caller's object, emptied; where the notes cannot be kept the batch is
 * applied to a copy instead, and b->old is the whole tree before it. The
 * error's text starts with "operation i:". Returns 0 or a BC_E* code; on
 * failure b holds nothing and *tp is as before, unless putting it back ran
 * out of memory (BC_ENOMEM with b->lost set).
 */
int bc_edit_batch_apply(struct bc_edit_batch *b, struct bc_tree **tp,
                        const struct bc_proto_edit_op *ops, uint32_t n,
                        struct bc_errinfo *ei);

/* As bc_edit_batch_apply(), and for a structural batch also writes into
 * b->inv the operations that undo it, computed operation by operation as
 * the batch applies (the earlier subtrees encoded from the tree before
 * each operation). A batch whose inverse cannot be kept fails (BC_ENOMEM;
 * BC_ELIMIT when a subtree it removes or replaces is over one message). */
int bc_edit_batch_apply_undoable(struct bc_edit_batch *b, struct bc_tree **tp,
                                 const struct bc_proto_edit_op *ops, uint32_t n,
                                 struct bc_errinfo *ei);

/* Undoes the batch b applied to *tp: it only puts back states that were
 * valid, into room the batch freed, so only memory can fail it, and only
 * for a structural batch applied in place (decoding the subtrees its
 * inverse puts back: memory in proportion to the change). b is then
 * empty. Returns 0, or BC_ENOMEM when it failed so: *tp is then a valid
 * tree but not the one before the batch (reload it). */
int bc_edit_batch_undo(struct bc_edit_batch *b, struct bc_tree **tp);

/* Frees what b holds (the old tree, the saved nodes, the inverse); accepts
 * a zeroed b. */
void bc_edit_batch_finish(struct bc_edit_batch *b);

/* Replays EDIT_APPLIED's operations into a mirror, atomically, with the
 * rules the server applied them with. Returns 0 or a BC_E* code (then *tp
 * is unchanged and the mirror should be dropped or reloaded). */
int bc_edit_replay(struct bc_tree **tp, const struct bc_msg_edit_applied *ea,
                   struct bc_errinfo *ei);

/* Most key=value arguments of one SET: one per field. */
#define BC_EDIT_MAX_KV BC_PROTO_MAX_SET_FIELDS

/*
 * Turns key=value texts (`radius=0.4`, `translate=0.1,0,0`,
 * `kind=smooth_union`) into the fields of a SET of node, using the node's
 * kind in scene to know which keys it has. Keys: translate, rotate, color
 * and the kind's parameter names for primitives; blend, range and kind
 * (a name or 1..6) for operators. `kind` naming a sharp operator on a
 * smooth one, with neither blend nor range given, also sets both to 0 (a
 * sharp operator has neither). fields holds BC_PROTO_MAX_SET_FIELDS;
 * *nfields is reset on entry. Returns 0, BC_ENONODE, BC_EINVAL (unknown
 * key, wrong value count, a key twice), BC_EPARSE (not a number),
 * BC_ENONFINITE, BC_ERANGE or BC_ELIMIT, with a sentence in ei.
 */
int bc_edit_parse_kv(const struct bc_tree *scene, uint32_t node,
                     const char *const *kv, size_t n,
                     struct bc_proto_field *fields, uint8_t *nfields,
                     struct bc_errinfo *ei);

/* A camera between its message form (CAMERA, FOLLOW_CAMERA, SESSION_CAMERA
 * and SESSION_CAMERA_SET carry it) and blobtree's: the same four fields. */
static inline void bc_edit_camera_from_msg(const struct bc_msg_camera *m,
                                           struct bc_camera *c)
{
	memcpy(c->eye, m->eye, sizeof(c->eye));
	memcpy(c->target, m->target, sizeof(c->target));
	memcpy(c->up, m->up, sizeof(c->up));
	c->fov_y_deg = m->fov_y_deg;
}

static inline void bc_edit_camera_to_msg(const struct bc_camera *c,
                                         struct bc_msg_camera *m)
{
	memcpy(m->eye, c->eye, sizeof(m->eye));
	memcpy(m->target, c->target, sizeof(m->target));
	memcpy(m->up, c->up, sizeof(m->up));
	m->fov_y_deg = c->fov_y_deg;
}

#endif
