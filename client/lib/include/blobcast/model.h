/*
 * Modelling with libblobcast: the actions of an outliner and an Add menu
 * (add, remove, move, wrap, duplicate, change an operator) turned into one
 * EDIT each, so that every member sees each action at once and each undoes
 * as one step.
 *
 * Each function reads the client's scene mirror (bc_client_scene), checks
 * the action there first and refuses, before anything is sent, what the
 * daemon would refuse (with a sentence that says what to do instead):
 * adding under a primitive or a unary node, moving a node under itself or
 * one of its descendants, removing the root (or a chain of unary nodes up
 * to it), a result over the depth limits (BC_TREE_MAX_DEPTH, the
 * evaluation stack BC_EVAL_STACK, BC_DOMAIN_MAX_CHAIN domain nodes on a
 * path) or the node limit (the server's max_nodes), unknown kinds and
 * keys. The last check applies the operations to the mirror with the
 * daemon's own edit code and puts it back, so what passes here is what
 * the daemon applies, unless another member's edit reaches it first.
 * (Should putting it back run out of memory, the mirror is dropped and
 * the action fails with BC_ENOMEM: join the session again.)
 *
 * Each function sends the EDIT and returns without waiting: *out says the
 * EDIT's seq and the ids the action created. bc_client_wait_applied(c,
 * out->seq, ...) waits for it to be applied (a tool); a program with its
 * own loop sees the EDIT_APPLIED, or an ERROR with that seq, arrive. The
 * mirror changes only when the EDIT_APPLIED arrives: an action on a node
 * the previous one created needs it first.
 *
 * New ids. PROTOCOL.md 7.12: every node of an inserted subtree carries an
 * explicit id new to the scene, so that every member names it alike. The
 * ids chosen are the next ones above both the largest id in the mirror and
 * the last id this client handed out, consecutive, in the pre-order of the
 * new subtree: first_id, first_id + 1, ... When two editors add at the
 * same moment they pick the same ids; the daemon applies the first EDIT
 * and refuses the second whole with ERROR EDUPID ("id N is already in the
 * scene"), so nothing is half applied or silently merged: the second
 * editor's mirror has the first edit by the time that ERROR arrives, and
 * the same call made again picks fresh ids. (Ids above 2^32 - 1 - n do
 * not exist: in a scene that already uses the top id, the lowest free run
 * of ids is taken.)
 *
 * Move and wrap send the subtree they move as the mirror holds it
 * (REMOVE and INSERT of the same ids, or a REPLACE): a change that another
 * member made inside that subtree and that reached the daemon after this
 * client's mirror was updated is overwritten by it. out->base_order is the
 * order the action was built on; the EDIT_APPLIED's order tells whether
 * anything came in between.
 *
 * Kinds are named as in scene files: primitives ("sphere", "box", ...,
 * bc_prim_info), operators ("union", "intersection", "difference",
 * "smooth_union", "smooth_intersection", "smooth_difference") and unary
 * nodes ("offset", "onion", "elongate", "twist", "bend", "mirror",
 * "repeat", "scale"). key=value parameters are those of
 * bc_client_edit_parse() for the new node's kind.
 *
 * Names (PROTOCOL.md 8). A node may carry a name, 1..BC_TREE_NAME_MAX
 * bytes of UTF-8; bc_tree_name() reads it from the mirror. Every action
 * keeps the names of the nodes it keeps: move and wrap send the subtree
 * they take with its names table (a REMOVE takes the names of what it
 * removes, a subtree brings its own), so a moved or wrapped node keeps
 * its name. A duplicate's nodes keep their names, except that the copy of
 * the node asked for, when named, is named "NAME copy" (NAME cut by whole
 * characters so that the whole stays within BC_TREE_NAME_MAX bytes), as
 * the web page names its copies. bc_model_rename() names a node; add and
 * wrap may name the node they make in the same EDIT. Names go only to a
 * server that granted NAMES (bc_client_info()->features): to an earlier
 * one a name is refused with BC_ENOTSUP before anything is sent.
 *
 * Every function returns 0 or a negative BC_E* code with the reason in ei
 * (which may be NULL); *out (which may be NULL) is reset on entry. Codes:
 * BC_ESTATE (no scene: join a session first), BC_ENONODE (a node the mirror
 * does not have), BC_EINVAL (the action is not possible on these nodes, an
 * unknown kind or key), BC_ERANGE (a position or value out of range, a
 * name over BC_TREE_NAME_MAX bytes), BC_ESTRING (a name that is not
 * UTF-8), BC_ENOTSUP (a name for a server that does not know names),
 * BC_EDEPTH and BC_ELIMIT (the result would be over a limit), BC_EPARSE,
 * BC_ENONFINITE, BC_ENOMEM, or what bc_client_send() returns.
 */
#ifndef BLOBCAST_MODEL_H
#define BLOBCAST_MODEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/client.h"

/* The blend a smooth operator gets when added (or made smooth from a sharp
 * one) without a blend=: a tenth of the unit-sized default primitives,
 * visible without swallowing their shapes. */
#define BC_MODEL_DEFAULT_BLEND 0.1f

/* How far apart the two primitives an added operator starts with are
 * placed, along the camera's right: the default primitives are about one
 * unit wide, so the pair overlaps a little and the operator shows. */
#define BC_MODEL_PAIR_SPACING 1.0f

/* What an action did. */
struct bc_model_result {
	/* The EDIT's seq, for bc_client_wait_applied(). */
	uint32_t seq;
	/* The node the action is about: the new subtree's root (add,
	 * duplicate), the new node above the wrapped one (wrap), the node
	 * moved or removed (the top of its chain of unary nodes, which go
	 * with it), the operator changed (set_operator). */
	uint32_t node;
	/* The ids the action created: first_id .. first_id + nids - 1, in
	 * the pre-order of the new subtree (add: the node, then its new
	 * primitives, then the union made to hold it beside the root if
	 * one was; wrap: the new node, then a new primitive beside the
	 * wrapped one; duplicate: the copy). nids 0: none. */
	uint32_t first_id, nids;
	/* Where node is once applied: its parent (0: it is the root) and
	 * its index among the parent's children. remove: where it was. */
	uint32_t parent, position;
	/* The mirror's order (bc_client_info()->order) it was built on. */
	uint64_t base_order;
};

/* Adding a node under an operator. Zero means default for every field but
 * kind. */
struct bc_model_add {
	/* A primitive, operator or unary kind. An operator starts with two
	 * new primitives of child_kind, BC_MODEL_PAIR_SPACING apart; a unary
	 * node with one, which it wraps (a unary node has exactly one
	 * child: to wrap an existing node, use bc_model_wrap()). */
	const char *kind;
	/* key=value parameters of the new node (translate=, radius=,
	 * blend=, ...); the others take the kind's defaults (a smooth
	 * operator: blend BC_MODEL_DEFAULT_BLEND). */
	const char *const *kv;
	size_t nkv;
	/* The operator to add under; 0: the root, or the operator under
	 * the unary nodes at the top of the scene, or, when there is none
	 * (the scene is one primitive, perhaps inside unary nodes), beside
	 * the root in a new union: one REPLACE of the root, the union's id
	 * the last of the new ids and out->parent. */
	uint32_t parent;
	/* The child index to insert at (0 first, up to the parent's child
	 * count; beside the root, 0 before it or 1 after it); without
	 * has_position: after the last child. */
	bool has_position;
	uint32_t position;
	/* Where new primitives are placed when kv gives no translate= (an
	 * operator's two children: either side of it); without has_at: the
	 * session camera's target, the centre of what members look at. */
	bool has_at;
	float at[3];
	/* The kind of the primitives an operator or unary node starts with;
	 * NULL: "sphere". */
	const char *child_kind;
	/* The new node's name, sent in the same INSERT (its subtree's names
	 * table); NULL or "": none. */
	const char *name;
};

/* Adds a->kind under a->parent: one INSERT (one REPLACE of the root when
 * the scene has no operator to add under). */
BC_API int bc_model_add(struct bc_client *c, const struct bc_model_add *a,
                        struct bc_model_result *out, struct bc_errinfo *ei);

/* Removes node and its subtree: one REMOVE. An operator left with one
 * child is replaced by that child; a node wrapped by unary nodes goes with
 * them (PROTOCOL.md 9). Refused for the root and a unary chain up to it (a
 * scene is never empty: replace or change it instead). */
BC_API int bc_model_remove(struct bc_client *c, uint32_t node,
                           struct bc_model_result *out, struct bc_errinfo *ei);

/* Moving a node (with its subtree and ids) under another operator. */
struct bc_model_move {
	/* The node to move; a node wrapped by unary nodes moves with them
	 * (out->node is the top of the chain). */
	uint32_t node;
	/* The operator to move it under (not node itself, nor one of its
	 * descendants, nor a primitive or unary node). */
	uint32_t parent;
	/* The index among parent's children as they are now (0 first, up
	 * to the child count; under its own parent, counting node itself);
	 * without has_position: after the last child. */
	bool has_position;
	uint32_t position;
};

/* Moves m->node: one EDIT of a REMOVE and an INSERT of the same subtree
 * with the same ids (PROTOCOL.md 9 applies a batch in order, so the ids
 * are free again when the INSERT comes). When the REMOVE would dissolve
 * the operator the node is taken out of (it has two children) and that
 * operator is the destination, the EDIT is one REPLACE of that operator
 * by itself with its children in the new order. */
BC_API int bc_model_move(struct bc_client *c, const struct bc_model_move *m,
                         struct bc_model_result *out, struct bc_errinfo *ei);

/* Wrapping a node in a new unary node or operator. */
struct bc_model_wrap {
	uint32_t node;
	/* A unary kind (node becomes its one child) or an operator kind
	 * (node becomes its first child, and a new primitive of child_kind
	 * at `at` its second: "subtract a sphere from this"). */
	const char *kind;
	/* key=value parameters of the new node. */
	const char *const *kv;
	size_t nkv;
	/* For an operator: the new primitive's kind (NULL: "sphere") and
	 * place (without has_at: the session camera's target). */
	const char *child_kind;
	bool has_at;
	float at[3];
	/* The new node's name, sent in the same REPLACE; NULL or "":
	 * none. */
	const char *name;
};

/* Wraps w->node: one REPLACE of the node by new(node), every id of node's
 * subtree kept. */
BC_API int bc_model_wrap(struct bc_client *c, const struct bc_model_wrap *w,
                         struct bc_model_result *out, struct bc_errinfo *ei);

/* Duplicating a node. */
struct bc_model_duplicate {
	/* The node to copy; a node wrapped by unary nodes is copied with
	 * them (the copy goes where a child of an operator can). */
	uint32_t node;
	/* Added to the translate of every primitive of the copy; without
	 * has_offset the copy lies exactly on the original. */
	bool has_offset;
	float offset[3];
};

/* Inserts a copy of d->node with fresh ids right after it, under the same
 * operator: one INSERT. The copy's nodes keep their names; the copy of
 * d->node, when it is named, is named "NAME copy" (above). Refused for the
 * root (wrap it in an operator first). */
BC_API int bc_model_duplicate(struct bc_client *c,
                              const struct bc_model_duplicate *d,
                              struct bc_model_result *out,
                              struct bc_errinfo *ei);

/* Makes operator node an operator of kind (an operator name, sharp or
 * smooth) with blend and range: one SET. For a smooth kind, blend 0 keeps
 * the node's blend when it is smooth (else BC_MODEL_DEFAULT_BLEND), and
 * range 0 keeps its range when the blend is kept, else asks for the
 * default (PROTOCOL.md 8); a sharp kind takes blend and range to 0. */
BC_API int bc_model_set_operator(struct bc_client *c, uint32_t node,
                                 const char *kind, float blend, float range,
                                 struct bc_model_result *out,
                                 struct bc_errinfo *ei);

/* Names node name (NUL-terminated UTF-8, at most BC_TREE_NAME_MAX bytes;
 * "" or NULL takes its name away): one EDIT of one NAME operation, one
 * step of undo. out->node is node, out->parent and out->position where it
 * is. Refused before sending: a server without NAMES (BC_ENOTSUP), an
 * unknown node (BC_ENONODE), a name over the limit (BC_ERANGE) or not
 * UTF-8 (BC_ESTRING), and a name the node already has, or removing the
 * name of a node that has none (BC_EINVAL: nothing to change). */
BC_API int bc_model_rename(struct bc_client *c, uint32_t node, const char *name,
                           struct bc_model_result *out, struct bc_errinfo *ei);

#endif
