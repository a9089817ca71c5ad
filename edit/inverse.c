/*
 * What undoes an edit, as edit operations (PROTOCOL.md section 9) that
 * every member can replay: for each operation of a structural batch the
 * operation that takes it back, computed against the tree just before it
 * (bc__inverse_before) and just after (bc__inverse_after), and for saved
 * node states the operations that put them back. The daemon keeps these in
 * its undo history and applies them as an ordinary EDIT, so what is
 * journaled and broadcast for an undo follows the change, not the scene:
 *
 *   INSERT of subtree X     REMOVE of X's root (its parent keeps two
 *                           children or more: operators have two)
 *   REMOVE of node N        INSERT of N's subtree, ids kept, at its place
 *                           (N: the top of the chain of unary nodes the
 *                           REMOVE takes); when N's parent had two
 *                           children it went too, its other child S taking
 *                           its place, and no operation wraps a node that
 *                           exists: REPLACE of S by the parent's whole
 *                           subtree, the smallest exact one
 *   REPLACE of N by X       REPLACE of X's root by N's subtree
 *   SET of N                SET of every field of N's earlier state, or,
 *                           when it gave a primitive its first colour
 *                           (no SET takes one away), REPLACE of N by a
 *                           one-node subtree of that state
 *
 * Each inverse is at most the subtree of the change, but a batch can make
 * them add up past the scene (REMOVEs down a chain of two-child operators
 * each put back all below): the inverse is then one REPLACE of the root
 * by the scene before (bc__inverse_bound), the smallest exact one.
 */
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/num.h"
#include "blobcast/bytes.h"
#include "blobcast/scene.h"
#include "edit_impl.h"

void bc_edit_inverse_finish(struct bc_edit_inverse *inv)
{
	if (!inv) {
		return;
	}
	for (uint32_t i = 0; inv->owned && i < inv->nops; i++) {
		bc_free(inv->owned[i]);
	}
	bc_free(inv->ops);
	bc_free(inv->owned);
	memset(inv, 0, sizeof(*inv));
}

int bc__inverse_init(struct bc_edit_inverse *inv, uint32_t n)
{
	memset(inv, 0, sizeof(*inv));
	if (n == 0) {
		return 0;
	}
	inv->ops = bc_calloc(n, sizeof(*inv->ops));
	inv->owned = bc_calloc(n, sizeof(*inv->owned));
	if (!inv->ops || !inv->owned) {
		bc_free(inv->ops);
		bc_free(inv->owned);
		inv->ops = NULL;
		inv->owned = NULL;
		return BC_ENOMEM;
	}
	inv->nops = n;
	inv->bytes = (size_t)n * (sizeof(*inv->ops) + sizeof(*inv->owned));
	return 0;
}

/* Operation k of inv owns mem (size bytes) from now on. */
static void own(struct bc_edit_inverse *inv, uint32_t k, void *mem, size_t size)
{
	bc_free(inv->owned[k]);
	inv->owned[k] = mem;
	inv->bytes += size;
}

/* ---- subtrees as scene bytes ---------------------------------------------- */

static int put_prim(struct bc_proto_buf *b, uint32_t id,
                    const struct bc_prim_data *p)
{
	return bc_proto_scene_prim(b, (uint8_t)p->kind, id, p->translate,
	                           p->rotate, p->has_color ? p->color : NULL,
	                           (uint8_t)bc_scene_prim_nfloats(p->kind),
	                           p->params);
}

/* One node as the scene encoding writes it (blobtree's own encoder). */
static int put_node(struct bc_proto_buf *b, const struct bc_scene_node *n)
{
	if (!n->is_op) {
		return put_prim(b, n->id, &n->prim);
	}
	if (bc_op_is_unary(n->op.kind)) {
		return bc_proto_scene_unary(
		    b, (uint8_t)n->op.kind, n->id,
		    (uint8_t)bc_unary_info(n->op.kind)->nparams, n->unary.u);
	}
	return bc_proto_scene_op(b, (uint8_t)n->op.kind, n->id, n->op.blend,
	                         n->op.range, n->nchildren);
}

/* The ids of a subtree's named nodes, gathered as it is written. */
struct named {
	uint32_t *ids;
	uint32_t n, cap;
};

static int named_add(struct named *nm, const struct bc_tree *t, uint32_t id)
{
	if (!bc_tree_name(t, id)) {
		return 0;
	}
	if (nm->n == nm->cap) {
		uint32_t cap = nm->cap ? 2 * nm->cap : 8;
		uint32_t *grown = bc_reallocarray(nm->ids, cap, sizeof(*grown));
		if (!grown) {
			return BC_ENOMEM;
		}
		nm->ids = grown;
		nm->cap = cap;
	}
	nm->ids[nm->n++] = id;
	return 0;
}

/* Ends the scene that starts at b->data[0] with the names table of the
 * nodes in nm (PROTOCOL.md 8: a subtree brings its names), and frees nm. */
static int put_names(struct bc_proto_buf *b, const struct bc_tree *t,
                     struct named *nm)
{
	int rc = 0;
	if (nm->n) {
		qsort(nm->ids, nm->n, sizeof(*nm->ids), bc_cmp_u32);
		rc = bc_proto_scene_names(b, 0, nm->n);
		for (uint32_t i = 0; i < nm->n && !rc; i++) {
			const char *s = bc_tree_name(t, nm->ids[i]);
			rc = bc_proto_scene_name(b, nm->ids[i], s, strlen(s));
		}
	}
	bc_free(nm->ids);
	return rc;
}

/* Writes the nodes of id's subtree, in pre-order, after b's scene header,
 * and their count into it; with pos, id's place among its parent's
 * children too. One walk of t in pre-order: a wide operator's children
 * are not indexed (the model's child k costs O(k)), and a structural edit
 * already takes time linear in the tree. */
static int walk_subtree(struct bc_proto_buf *b, const struct bc_tree *t,
                        uint32_t id, uint32_t *pos)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	struct named nm = {0};
	uint32_t count = 0;
	/* Only the subtree is walked: what an inverse costs follows the
	 * change, not the scene. */
	int rc = bc_scene_walk_init_at(&w, t, id);
	if (pos) {
		*pos = bc_tree_child_index(t, id);
	}
	while (!rc && bc_scene_walk_next(&w, &n)) {
		if (!(rc = put_node(b, &n))) {
			rc = named_add(&nm, t, n.id);
		}
		count++;
	}
	bc_scene_walk_finish(&w);
	if (!rc && count == 0) {
		rc = BC_ENONODE;
	}
	if (!rc) {
		bc_put_le32(b->data + 1, count);
	}
	if (rc) {
		bc_free(nm.ids);
		return rc;
	}
	return put_names(b, t, &nm);
}

/* One primitive as a whole scene, its name with it. */
static int put_lone_prim(struct bc_proto_buf *b, const struct bc_tree *t,
                         uint32_t id, const struct bc_prim_data *p)
{
	struct named nm = {0};
	int rc;
	if ((rc = bc_proto_scene_begin(b, NULL, 1)) ||
	    (rc = put_prim(b, id, p)) || (rc = named_add(&nm, t, id))) {
		bc_free(nm.ids);
		return rc;
	}
	return put_names(b, t, &nm);
}

/* The subtree of node id of t as scene bytes (flags 0, ids as in t), in a
 * bc_malloc'd *out of *len bytes; with pos, id's place among its parent's
 * children. Returns 0, BC_ENOMEM or BC_ELIMIT (over one message). */
static int encode_subtree(const struct bc_tree *t, uint32_t id, uint32_t *pos,
                          uint8_t **out, size_t *len)
{
	struct bc_proto_buf b;
	struct bc_prim_data p;
	struct bc_op_data op;
	uint8_t *fit;
	int rc;
	*out = NULL;
	*len = 0;
	bc_proto_buf_init(&b, 0);
	if (!pos && bc_tree_get(t, id, &p, &op) && op.kind == BC_OP_INVALID) {
		rc = put_lone_prim(&b, t, id, &p);
	} else if ((rc = bc_proto_scene_begin(&b, NULL, 1)) == 0) {
		rc = walk_subtree(&b, t, id, pos);
	}
	if (rc) {
		bc_proto_buf_finish(&b);
		return rc;
	}
	/* Kept for long: no slack. */
	if ((fit = bc_realloc(b.data, b.len))) {
		b.data = fit;
	}
	*out = b.data;
	*len = b.len;
	return 0;
}

/* The id of the root of scene bytes that an operation has applied (so
 * they are well formed): after the flags, the camera when there is one,
 * and the node count, the root's tag and then its id. */
static uint32_t root_id(const struct bc_proto_bytes *sub)
{
	size_t at = 1u + 4u + 1u;
	if (sub->ptr[0] & BC_SCENE_FLAG_CAMERA) {
		at += 40u;
	}
	return bc_get_le32(sub->ptr + at);
}

/* ---- one operation at a time ---------------------------------------------- */

/* Operation k of inv: the state s back on its node, t being the tree with
 * the node as it is now. */
static int put_state(struct bc_edit_inverse *inv, uint32_t k,
                     const struct bc_tree *t, const struct bc_edit_saved *s)
{
	struct bc_proto_edit_op *e = &inv->ops[k];
	struct bc_proto_field fields[BC_PROTO_MAX_SET_FIELDS], *kept;
	struct bc_prim_data now;
	bool is_op = s->op.kind != BC_OP_INVALID;
	if (!is_op && !s->p.has_color && bc_tree_get(t, s->id, &now, NULL) &&
	    now.has_color) {
		struct bc_proto_buf b;
		uint8_t *fit;
		int rc;
		bc_proto_buf_init(&b, 0);
		if ((rc = put_lone_prim(&b, t, s->id, &s->p))) {
			bc_proto_buf_finish(&b);
			return rc;
		}
		if ((fit = bc_realloc(b.data, b.len))) {
			b.data = fit;
		}
		*e = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REPLACE,
		                               .node = s->id};
		e->subtree.ptr = b.data;
		e->subtree.len = (uint32_t)b.len;
		own(inv, k, b.data, b.len);
		return 0;
	}
	bc_edit_state_set(s, is_op, e, fields);
	if (!(kept = bc_malloc(e->nfields * sizeof(*kept)))) {
		return BC_ENOMEM;
	}
	memcpy(kept, fields, e->nfields * sizeof(*kept));
	e->fields = kept;
	own(inv, k, kept, e->nfields * sizeof(*kept));
	return 0;
}

/* Operation k of inv: puts back the node a REMOVE of e->node takes. */
static int put_unremove(struct bc_edit_inverse *inv, uint32_t k,
                        const struct bc_tree *t, uint32_t top)
{
	struct bc_proto_edit_op *e = &inv->ops[k];
	uint32_t parent = bc_tree_parent(t, top), pos = 0;
	uint8_t *bytes;
	size_t len;
	int rc;
	if (bc_tree_child_count(t, parent) > 2) {
		rc = encode_subtree(t, top, &pos, &bytes, &len);
		*e = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
		                               .node = parent,
		                               .position = pos};
	} else {
		/* The parent goes too, its other child in its place. */
		uint32_t other = bc_tree_child(t, parent, 0);
		if (other == top) {
			other = bc_tree_child(t, parent, 1);
		}
		rc = encode_subtree(t, parent, NULL, &bytes, &len);
		*e = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REPLACE,
		                               .node = other};
	}
	if (rc) {
		return rc;
	}
	e->subtree.ptr = bytes;
	e->subtree.len = (uint32_t)len;
	own(inv, k, bytes, len);
	return 0;
}

int bc__inverse_before(struct bc_edit_inverse *inv, const struct bc_tree *t,
                       const struct bc_proto_edit_op *e, uint32_t k,
                       struct bc_edit_saved *was)
{
	uint32_t top;
	uint8_t *bytes;
	size_t len;
	int rc;
	/* An operation that t refuses fails the batch: nothing to note. */
	switch (e->kind) {
	case BC_PROTO_EDIT_SET:
		memset(was, 0, sizeof(*was));
		was->id = e->node;
		if (bc_tree_get(t, e->node, &was->p, &was->op)) {
			bc_tree_get_unary(t, e->node, &was->un);
		}
		return 0;
	case BC_PROTO_EDIT_REMOVE:
		top = bc__edit_removed_top(t, e->node);
		if (top == 0 || top == bc_tree_root(t)) {
			return 0;
		}
		return put_unremove(inv, k, t, top);
	case BC_PROTO_EDIT_NAME: {
		/* A NAME giving the earlier name back (empty: none). */
		const char *old = bc_tree_name(t, e->node);
		size_t nlen = old ? strlen(old) : 0;
		char *kept = NULL;
		if (nlen && !(kept = bc_malloc(nlen))) {
			return BC_ENOMEM;
		}
		if (nlen) {
			memcpy(kept, old, nlen);
		}
		inv->ops[k] = (struct bc_proto_edit_op){
		    .kind = BC_PROTO_EDIT_NAME,
		    .node = e->node,
		    .name = {.ptr = kept, .len = (uint32_t)nlen}};
		own(inv, k, kept, nlen);
		return 0;
	}
	case BC_PROTO_EDIT_REPLACE:
		if (!bc_tree_get(t, e->node, NULL, NULL)) {
			return 0;
		}
		if ((rc = encode_subtree(t, e->node, NULL, &bytes, &len))) {
			return rc;
		}
		/* The node to replace is known once the new one is in. */
		inv->ops[k] = (struct bc_proto_edit_op){
		    .kind = BC_PROTO_EDIT_REPLACE,
		    .subtree = {.ptr = bytes, .len = (uint32_t)len}};
		own(inv, k, bytes, len);
		return 0;
	default:
		return 0;
	}
}

int bc__inverse_after(struct bc_edit_inverse *inv, const struct bc_tree *t,
                      const struct bc_proto_edit_op *e, uint32_t k,
                      const struct bc_edit_saved *was)
{
	switch (e->kind) {
	case BC_PROTO_EDIT_SET:
		return put_state(inv, k, t, was);
	case BC_PROTO_EDIT_INSERT:
		inv->ops[k] = (struct bc_proto_edit_op){
		    .kind = BC_PROTO_EDIT_REMOVE, .node = root_id(&e->subtree)};
		return 0;
	case BC_PROTO_EDIT_REPLACE:
		inv->ops[k].node = root_id(&e->subtree);
		return 0;
	default:
		return 0;
	}
}

/* Smallest bytes a scene of n nodes encodes to: an operator, 17 bytes, has
 * two children or more, a primitive takes 35 bytes and more. */
static size_t scene_bytes_at_least(uint32_t n)
{
	return 5u + (size_t)n * 26u;
}

/* Subtree bytes inv's operations carry. */
static size_t carried_bytes(const struct bc_edit_inverse *inv)
{
	size_t carried = 0;
	for (uint32_t i = 0; i < inv->nops; i++) {
		carried += inv->ops[i].subtree.len;
	}
	return carried;
}

bool bc__inverse_fits(const struct bc_edit_inverse *inv, uint32_t old_nodes)
{
	return carried_bytes(inv) <= scene_bytes_at_least(old_nodes);
}

int bc__inverse_bound(struct bc_edit_inverse *inv, const struct bc_tree *old,
                      const struct bc_tree *now)
{
	struct bc_edit_inverse whole;
	size_t carried = carried_bytes(inv);
	uint8_t *bytes;
	size_t len;
	int rc;
	if (bc__inverse_fits(inv, bc_tree_node_count(old))) {
		return 0;
	}
	if ((rc = bc_scene_encode(old, NULL, &bytes, &len)) ||
	    (rc = bc__inverse_init(&whole, 1))) {
		bc_free(bytes);
		return rc;
	}
	if (len >= carried) {
		bc_free(bytes);
		bc_edit_inverse_finish(&whole);
		return 0;
	}
	whole.ops[0] = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_REPLACE,
	    .node = bc_tree_root(now),
	    .subtree = {.ptr = bytes, .len = (uint32_t)len}};
	own(&whole, 0, bytes, len);
	bc_edit_inverse_finish(inv);
	*inv = whole;
	return 0;
}

int bc_edit_inverse_of_states(struct bc_edit_inverse *inv,
                              const struct bc_tree *t,
                              const struct bc_edit_saved *s, uint32_t n)
{
	int rc = bc__inverse_init(inv, n);
	for (uint32_t i = 0; i < n && !rc; i++) {
		rc = put_state(inv, i, t, &s[i]);
	}
	if (rc) {
		bc_edit_inverse_finish(inv);
	}
	return rc;
}
