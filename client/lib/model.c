/*
 * Modelling actions (model.h): each builds the operations of one EDIT from
 * the scene mirror, checks them there (first the refusals people meet,
 * each with what to do instead, then the operations applied to a copy of
 * the mirror with the daemon's own edit code) and sends them.
 *
 * New nodes are built with blobtree's builder, so their parameters are
 * checked by the code that checks scene files, and key=value parameters go
 * through the edit module's parser (bc_edit_parse_kv) on a scratch tree
 * holding a node of the new kind: one syntax and one set of checks for
 * `blobcast edit` and `blobcast add`.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/edit.h"
#include "blobcast/model.h"
#include "blobcast/scene.h"
#include "client_impl.h"

/* The most operations an action sends (move: REMOVE and INSERT). */
#define MODEL_MAX_OPS 2u

/* What the copy of a named node's name ends with (bc_model_duplicate),
 * as the web page names its copies. */
#define MODEL_COPY_SUFFIX " copy"

/* ---- reading the mirror ---------------------------------------------------- */

/* The mirror and its camera, or BC_ESTATE. */
static int mirror(const struct bc_client *c, const struct bc_tree **t,
                  struct bc_camera *cam, struct bc_errinfo *ei)
{
	*t = NULL;
	if (c->err) {
		return bc_errinfo_set(ei, c->err, "%s", c->errstr);
	}
	*t = bc_client_scene(c, cam);
	if (!*t || bc_tree_root(*t) == 0) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "no scene yet: join a session first");
	}
	return 0;
}

enum node_class { NODE_NONE = 0, NODE_PRIM, NODE_OP, NODE_UNARY };

/* What node id is in t, and its data (any of p, op, u may be NULL). */
static enum node_class classify(const struct bc_tree *t, uint32_t id,
                                struct bc_prim_data *p, struct bc_op_data *op,
                                struct bc_unary *u)
{
	struct bc_prim_data pp;
	struct bc_op_data oo;
	if (id == 0 || !bc_tree_get(t, id, &pp, &oo)) {
		return NODE_NONE;
	}
	if (p) {
		*p = pp;
	}
	if (op) {
		*op = oo;
	}
	if (oo.kind == BC_OP_INVALID) {
		return NODE_PRIM;
	}
	if (bc_op_is_unary(oo.kind)) {
		if (u) {
			bc_tree_get_unary(t, id, u);
		}
		return NODE_UNARY;
	}
	return NODE_OP;
}

/* "sphere" or "smooth_union" for messages. */
static const char *kind_name(const struct bc_tree *t, uint32_t id)
{
	struct bc_prim_data p;
	struct bc_op_data op;
	const char *name = NULL;
	switch (classify(t, id, &p, &op, NULL)) {
	case NODE_PRIM:
		name = bc_prim_info(p.kind) ? bc_prim_info(p.kind)->name : NULL;
		break;
	case NODE_OP:
	case NODE_UNARY:
		name = bc_op_name(op.kind);
		break;
	case NODE_NONE:
		break;
	}
	return name ? name : "node";
}

static int no_node(uint32_t id, struct bc_errinfo *ei)
{
	return bc_errinfo_set(ei, BC_ENONODE,
	                      "no node %u in the session's scene", id);
}

/* The node a REMOVE or move of id takes: id, or the top of the chain of
 * unary nodes above it (a unary node cannot lose its one child). */
static uint32_t chain_top(const struct bc_tree *t, uint32_t id)
{
	uint32_t p;
	while ((p = bc_tree_parent(t, id)) != 0 &&
	       classify(t, p, NULL, NULL, NULL) == NODE_UNARY) {
		id = p;
	}
	return id;
}

/* Whether a is id or one of its ancestors. */
static bool is_ancestor(const struct bc_tree *t, uint32_t a, uint32_t id)
{
	for (; id != 0; id = bc_tree_parent(t, id)) {
		if (id == a) {
			return true;
		}
	}
	return false;
}

/* Nodes on the path from the root to id, the root counting 1. */
static uint32_t depth_of(const struct bc_tree *t, uint32_t id)
{
	uint32_t d = 0;
	for (; id != 0; id = bc_tree_parent(t, id)) {
		d++;
	}
	return d;
}

/* What one walk over the mirror says about a node. */
struct survey {
	uint32_t max_id; /* the largest id in the tree */
	uint32_t index;  /* the node's place among its parent's children */
	uint32_t nodes;  /* nodes of its subtree */
	uint32_t height; /* nodes on its subtree's longest path */
	bool seen;       /* the node was found */
};

/* One pre-order walk of t: the largest id, and node's index, subtree size
 * and height (node may be 0). The model's child k costs O(k), so places
 * are counted on the walk rather than looked up. */
static int survey(const struct bc_tree *t, uint32_t node, struct survey *s,
                  struct bc_errinfo *ei)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	uint32_t parent = node ? bc_tree_parent(t, node) : 0;
	uint32_t depth = 0, pdepth = 0, k = 0;
	bool in = false, under = false, done = false;
	int rc;
	memset(s, 0, sizeof(*s));
	if ((rc = bc_scene_walk_init(&w, t))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	while (bc_scene_walk_next(&w, &n)) {
		if (n.id > s->max_id) {
			s->max_id = n.id;
		}
		if (done) {
			continue;
		}
		if (in && n.depth <= depth) {
			in = false;
			done = true;
			continue;
		}
		if (!in && n.id == node) {
			in = true;
			s->seen = true;
			depth = n.depth;
			s->index = k;
		}
		if (in) {
			s->nodes++;
			if (n.depth - depth + 1 > s->height) {
				s->height = n.depth - depth + 1;
			}
		} else if (parent != 0 && n.id == parent) {
			under = true;
			pdepth = n.depth;
		} else if (under && n.depth == pdepth + 1) {
			k++;
		}
	}
	bc_scene_walk_finish(&w);
	return 0;
}

/* ---- new ids ---------------------------------------------------------------- */

static int cmp_u32(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return (x > y) - (x < y);
}

/* The lowest run of n free ids in t (for a scene that uses the top id). */
static int lowest_free_run(const struct bc_tree *t, uint32_t n, uint32_t *first,
                           struct bc_errinfo *ei)
{
	uint32_t count = bc_tree_node_count(t), have = 0, prev = 0;
	struct bc_scene_walk w;
	struct bc_scene_node sn;
	uint32_t *ids = bc_malloc((size_t)count * sizeof(*ids));
	int rc;
	if (!ids) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	if ((rc = bc_scene_walk_init(&w, t))) {
		bc_free(ids);
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	while (have < count && bc_scene_walk_next(&w, &sn)) {
		ids[have++] = sn.id;
	}
	bc_scene_walk_finish(&w);
	qsort(ids, have, sizeof(*ids), cmp_u32);
	for (uint32_t i = 0; i <= have; i++) {
		uint64_t next = i < have ? ids[i] : (uint64_t)UINT32_MAX + 1u;
		if (next - prev - 1u >= n) {
			*first = prev + 1u;
			bc_free(ids);
			return 0;
		}
		prev = i < have ? ids[i] : prev;
	}
	bc_free(ids);
	return bc_errinfo_set(ei, BC_ELIMIT,
	                      "no run of %u free node ids is left in the "
	                      "scene",
	                      n);
}

/* n consecutive ids new to t and above any this client handed out. */
static int fresh_ids(struct bc_client *c, const struct bc_tree *t,
                     uint32_t max_id, uint32_t n, uint32_t *first,
                     struct bc_errinfo *ei)
{
	uint64_t from = (uint64_t)max_id + 1u;
	if (c->model_next_id > from) {
		from = c->model_next_id;
	}
	if (from + n - 1u <= UINT32_MAX) {
		*first = (uint32_t)from;
		return 0;
	}
	return lowest_free_run(t, n, first, ei);
}

/* ---- building subtrees -------------------------------------------------- */

/* Gives node id of the builder dst the name node src_id of src has, if
 * any. */
static int keep_name(struct bc_tree *dst, uint32_t id,
                     const struct bc_tree *src, uint32_t src_id,
                     struct bc_errinfo *ei)
{
	const char *name = bc_tree_name(src, src_id);
	return name ? bc_tree_set_name(dst, id, name, strlen(name), ei) : 0;
}

/* Emits the subtree of node of src into the builder dst, in pre-order:
 * with ids as in src, or (renumber) first_id, first_id + 1, ...; with
 * offset (may be NULL) added to every primitive's translate. Each node
 * keeps its name (PROTOCOL.md 9: a REMOVE takes the names of what it
 * removes and a subtree brings its own, so a move or a wrap that did not
 * carry them would drop them). One walk of src; the builder's nesting
 * follows the walk's depths. */
static int put_subtree(struct bc_tree *dst, const struct bc_tree *src,
                       uint32_t node, bool renumber, uint32_t first_id,
                       const float *offset, struct bc_errinfo *ei)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	uint32_t depth = 0, open = 0, k = 0;
	bool in = false;
	int rc;
	if ((rc = bc_scene_walk_init(&w, src))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	while (!rc && bc_scene_walk_next(&w, &n)) {
		uint32_t rel, id;
		if (in && n.depth <= depth) {
			break;
		}
		if (!in && n.id != node) {
			continue;
		}
		if (!in) {
			in = true;
			depth = n.depth;
		}
		rel = n.depth - depth;
		while (!rc && open > rel) {
			rc = bc_tree_pop_op(dst, ei);
			open--;
		}
		id = renumber ? first_id + k : n.id;
		k++;
		if (rc) {
			break;
		}
		if (!n.is_op) {
			if (offset) {
				for (int i = 0; i < 3; i++) {
					n.prim.translate[i] += offset[i];
				}
			}
			rc = bc_tree_put_prim(dst, id, &n.prim, ei);
		} else if (bc_op_is_unary(n.op.kind)) {
			rc = bc_tree_push_unary(dst, id, &n.unary, ei);
			open++;
		} else {
			rc = bc_tree_push_op(dst, id, &n.op, ei);
			open++;
		}
		rc = rc ? rc : keep_name(dst, id, src, n.id, ei);
	}
	bc_scene_walk_finish(&w);
	while (!rc && open > 0) {
		rc = bc_tree_pop_op(dst, ei);
		open--;
	}
	if (!rc && !in) {
		rc = no_node(node, ei);
	}
	return rc;
}

/* The comma-separated names of the primitive kinds, for messages. */
static void prim_names(char *buf, size_t cap)
{
	size_t used = 0;
	buf[0] = '\0';
	for (int k = 1; k < BC_PRIM_COUNT && used < cap; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		int w = snprintf(buf + used, cap - used, "%s%s",
		                 k > 1 ? ", " : "", info ? info->name : "?");
		if (w < 0) {
			break;
		}
		used += (size_t)w;
	}
}

/* A new node of a kind, with its key=value parameters applied. */
struct new_node {
	enum node_class cls;
	struct bc_prim_data p; /* NODE_PRIM */
	struct bc_op_data op;  /* NODE_OP */
	struct bc_unary u;     /* NODE_UNARY */
	bool has_translate;    /* kv gave translate= */
};

static int unknown_kind(const char *kind, const char *what,
                        struct bc_errinfo *ei)
{
	char names[400];
	prim_names(names, sizeof(names));
	return bc_errinfo_set(ei, BC_EINVAL,
	                      "unknown %s kind \"%.40s\": give a primitive "
	                      "(%.60s..., docs/primitives.md)%s",
	                      what, kind ? kind : "(none)", names,
	                      strcmp(what, "node") == 0
	                          ? ", an operator (union, smooth_union, "
	                            "...) or a unary node (offset, twist, "
	                            "...)"
	                          : "");
}

/* A key=value refusal for the scratch node 1 is about the new node:
 * "node 1 (sphere) has no ..." becomes "a new sphere has no ...", and
 * "node 1: ..." "the new node: ...". */
static int about_new(int rc, struct bc_errinfo *ei)
{
	const char *lead = "node 1 (", *close;
	char msg[sizeof(ei->msg)];
	if (!ei) {
		return rc;
	}
	if (strncmp(ei->msg, "node 1: ", 8) == 0) {
		snprintf(msg, sizeof(msg), "the new node: %s", ei->msg + 8);
		return bc_errinfo_set(ei, rc, "%s", msg);
	}
	if (strncmp(ei->msg, lead, strlen(lead)) != 0 ||
	    !(close = strchr(ei->msg, ')'))) {
		return rc;
	}
	snprintf(msg, sizeof(msg), "a new %.*s%s",
	         (int)(close - ei->msg - strlen(lead)), ei->msg + strlen(lead),
	         close + 1);
	return bc_errinfo_set(ei, rc, "%s", msg);
}

/* Resolves kind and applies kv to a node of that kind: on a scratch tree
 * (node 1, with default children where the kind needs them) through the
 * edit module's parser and SET, so keys, counts and ranges are checked as
 * `blobcast edit` checks them. */
static int new_node(const char *kind, const char *const *kv, size_t nkv,
                    struct new_node *nn, struct bc_errinfo *ei)
{
	enum bc_prim pk = kind ? bc_prim_from_name(kind) : BC_PRIM_INVALID;
	enum bc_op ok = kind ? bc_op_from_name(kind) : BC_OP_INVALID;
	struct bc_prim_data child;
	struct bc_tree *t;
	int rc;
	memset(nn, 0, sizeof(*nn));
	if (pk == BC_PRIM_INVALID && ok == BC_OP_INVALID) {
		return unknown_kind(kind, "node", ei);
	}
	if (!(t = bc_tree_create())) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	bc_prim_data_init(&child, BC_PRIM_SPHERE);
	bc_tree_begin(t);
	if (pk != BC_PRIM_INVALID) {
		nn->cls = NODE_PRIM;
		bc_prim_data_init(&nn->p, pk);
		rc = bc_tree_put_prim(t, 1, &nn->p, ei);
	} else if (bc_op_is_unary(ok)) {
		nn->cls = NODE_UNARY;
		bc_unary_init(&nn->u, ok);
		rc = bc_tree_push_unary(t, 1, &nn->u, ei);
		rc = rc ? rc : bc_tree_put_prim(t, 2, &child, ei);
		rc = rc ? rc : bc_tree_pop_op(t, ei);
	} else {
		nn->cls = NODE_OP;
		nn->op.kind = ok;
		if (bc_op_is_smooth(ok)) {
			nn->op.blend = BC_MODEL_DEFAULT_BLEND;
		}
		rc = bc_tree_push_op(t, 1, &nn->op, ei);
		rc = rc ? rc : bc_tree_put_prim(t, 2, &child, ei);
		rc = rc ? rc : bc_tree_put_prim(t, 3, &child, ei);
		rc = rc ? rc : bc_tree_pop_op(t, ei);
	}
	rc = rc ? rc : bc_tree_end(t, ei);
	if (!rc && nkv > 0) {
		struct bc_proto_field fields[BC_PROTO_MAX_SET_FIELDS];
		struct bc_proto_edit_op set = {.kind = BC_PROTO_EDIT_SET,
		                               .node = 1};
		if ((rc = bc_edit_parse_kv(t, 1, kv, nkv, fields, &set.nfields,
		                           ei)) == 0) {
			set.fields = fields;
			rc = bc_edit_apply_op(t, &set, ei);
		}
		rc = about_new(rc, ei);
		for (uint8_t i = 0; !rc && i < set.nfields; i++) {
			if (fields[i].field == BC_PROTO_FIELD_TRANSLATE) {
				nn->has_translate = true;
			}
		}
	}
	if (!rc) {
		/* A SET of kind= may have turned it into another kind of
		 * the same class. */
		bc_tree_get(t, 1, &nn->p, &nn->op);
		if (nn->cls == NODE_UNARY) {
			bc_tree_get_unary(t, 1, &nn->u);
		}
	}
	bc_tree_destroy(t);
	return rc;
}

/* A primitive kind by name (NULL: sphere) at its defaults. */
static int child_prim(const char *kind, struct bc_prim_data *p,
                      struct bc_errinfo *ei)
{
	enum bc_prim k =
	    kind ? bc_prim_from_name(kind) : (enum bc_prim)BC_PRIM_SPHERE;
	if (k == BC_PRIM_INVALID) {
		return unknown_kind(kind, "child primitive", ei);
	}
	bc_prim_data_init(p, k);
	return 0;
}

/* Where new primitives go: at, or the session camera's target; right:
 * the camera's right, for placing a pair side by side. */
static void placement(const struct bc_camera *cam, bool has_at, const float *at,
                      float pos[3], float right[3])
{
	float f[3], r[3], len;
	for (int i = 0; i < 3; i++) {
		pos[i] = has_at ? at[i] : cam->target[i];
		f[i] = cam->target[i] - cam->eye[i];
	}
	r[0] = f[1] * cam->up[2] - f[2] * cam->up[1];
	r[1] = f[2] * cam->up[0] - f[0] * cam->up[2];
	r[2] = f[0] * cam->up[1] - f[1] * cam->up[0];
	len = sqrtf(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
	for (int i = 0; i < 3; i++) {
		right[i] = len > 0.0f ? r[i] / len : (i == 0 ? 1.0f : 0.0f);
	}
}

/* Puts primitive p at pos + s * right (unless it was given a translate). */
static int put_placed(struct bc_tree *dst, uint32_t id, struct bc_prim_data p,
                      bool keep, const float pos[3], const float right[3],
                      float s, struct bc_errinfo *ei)
{
	if (!keep) {
		for (int i = 0; i < 3; i++) {
			p.translate[i] = pos[i] + s * right[i];
		}
	}
	return bc_tree_put_prim(dst, id, &p, ei);
}

/* ---- checking and sending --------------------------------------------------- */

/* The most nodes the server takes in a scene. */
static uint32_t node_limit(const struct bc_client *c)
{
	uint32_t m = bc_client_info(c)->max_nodes;
	return m && m < BC_PROTO_SCENE_MAX_NODES ? m : BC_PROTO_SCENE_MAX_NODES;
}

/* BC_ENOTSUP unless the server granted NAMES: an earlier daemon refuses a
 * names table and the NAME operation (PROTOCOL.md 4.1). */
static int need_names(const struct bc_client *c, struct bc_errinfo *ei)
{
	if (bc_client_info(c)->features & BC_PROTO_FEATURE_NAMES) {
		return 0;
	}
	return bc_errinfo_set(ei, BC_ENOTSUP,
	                      "the server does not know node names (an older "
	                      "blobcastd): upgrade it");
}

/* Checks name (len bytes; 0: no name) as the daemon checks a node name:
 * the server must know names, at most BC_TREE_NAME_MAX bytes, strict
 * UTF-8 without NUL. */
static int check_name(const struct bc_client *c, const char *name, size_t len,
                      struct bc_errinfo *ei)
{
	size_t bad;
	int rc;
	if ((rc = need_names(c, ei))) {
		return rc;
	}
	if (len > BC_TREE_NAME_MAX) {
		return bc_errinfo_set(
		    ei, BC_ERANGE,
		    "the name is %zu bytes, over the limit of "
		    "%u bytes (of UTF-8) a node name may have: "
		    "shorten it",
		    len, BC_TREE_NAME_MAX);
	}
	if ((bad = bc_utf8_check((const uint8_t *)name, len)) < len) {
		return bc_errinfo_set(ei, BC_ESTRING,
		                      "the name is not valid UTF-8 (byte %zu "
		                      "%s): give it as UTF-8 text",
		                      bad + 1,
		                      name[bad] ? "breaks it" : "is NUL");
	}
	return 0;
}

/* Names node id of the builder sub (added already) name, when one is
 * given (NULL or "": none). */
static int name_new(struct bc_tree *sub, uint32_t id, const char *name,
                    struct bc_errinfo *ei)
{
	if (!name || !name[0]) {
		return 0;
	}
	return bc_tree_set_name(sub, id, name, strlen(name), ei);
}

/* A copy's name, "<name> copy", name cut at a character boundary so that
 * the whole stays within BC_TREE_NAME_MAX bytes. */
static void copy_name(const char *name, char out[BC_TREE_NAME_MAX + 1])
{
	size_t keep = strlen(name);
	size_t room = BC_TREE_NAME_MAX - (sizeof(MODEL_COPY_SUFFIX) - 1u);
	if (keep > room) {
		keep = room;
		/* Back to the first byte of the character cut. */
		while (keep > 0 &&
		       ((unsigned char)name[keep] & 0xc0u) == 0x80u) {
			keep--;
		}
	}
	memcpy(out, name, keep);
	memcpy(out + keep, MODEL_COPY_SUFFIX, sizeof(MODEL_COPY_SUFFIX));
}

/* Applies ops to the mirror with the daemon's edit code, checks the
 * result against the server's node limit, and puts the mirror back. In
 * place, as the daemon applies a batch: a copy of a million-node mirror
 * for each check cost more than the rest of the command. */
static int dry_run(struct bc_client *c, const struct bc_proto_edit_op *ops,
                   uint32_t n, struct bc_errinfo *ei)
{
	struct bc_edit_batch b;
	struct bc_errinfo why = {0};
	uint32_t nodes = 0;
	int rc = bc_edit_batch_apply(&b, &c->scene, ops, n, &why);
	if (!rc) {
		nodes = bc_tree_node_count(c->scene);
		b.lost = bc_edit_batch_undo(&b, &c->scene) != 0;
	}
	if (b.lost) {
		c->has_scene = false;
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "out of memory putting the scene mirror "
		                      "back after checking an edit: join the "
		                      "session again");
	}
	if (!rc && nodes > node_limit(c)) {
		rc = bc_errinfo_set(&why, BC_ELIMIT,
		                    "the scene would have %u nodes, more than "
		                    "the server's %u",
		                    nodes, node_limit(c));
	}
	if (rc == BC_EDEPTH) {
		return bc_errinfo_set(ei, rc,
		                      "refused before sending: %.180s; keep "
		                      "operators nested in first children, or "
		                      "flatten a group",
		                      why.msg);
	}
	if (rc == BC_ELIMIT) {
		return bc_errinfo_set(ei, rc,
		                      "refused before sending: %.180s; remove "
		                      "nodes first",
		                      why.msg);
	}
	if (rc) {
		return bc_errinfo_set(ei, rc, "refused before sending: %.200s",
		                      why.msg);
	}
	return 0;
}

/* Checks ops on the mirror, sends them as one EDIT and fills out. */
static int send_ops(struct bc_client *c, const struct bc_proto_edit_op *ops,
                    uint32_t n, struct bc_model_result *out,
                    struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	size_t bytes = 0;
	int rc;
	for (uint32_t i = 0; i < n; i++) {
		bytes += ops[i].subtree.len;
	}
	if (bc_client_info(c)->max_payload &&
	    bytes + 64u > bc_client_info(c)->max_payload) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "the edit would be %zu bytes, over the "
		                      "server's message limit of %u: act on a "
		                      "smaller part of the tree",
		                      bytes, bc_client_info(c)->max_payload);
	}
	if ((rc = dry_run(c, ops, n, ei))) {
		return rc;
	}
	out->base_order = bc_client_info(c)->order;
	m.edit.nops = (uint16_t)n;
	m.edit.ops = ops;
	if ((rc = bc_client_send(c, &m, &out->seq))) {
		if (bc_client_error(c, ei) == 0) {
			bc_errinfo_set(ei, rc, "the edit could not be sent: %s",
			               bc_strerror(rc));
		}
		return rc;
	}
	if (out->nids > 0) {
		c->model_next_id = out->first_id + out->nids;
	}
	return 0;
}

static void reset(struct bc_model_result *out)
{
	memset(out, 0, sizeof(*out));
}

/* Sends op, which changes op->node in place and creates nothing: out says
 * where the node is. out is reset on failure. */
static int send_on_node(struct bc_client *c, const struct bc_tree *t,
                        const struct bc_proto_edit_op *op,
                        struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct survey sv;
	int rc = survey(t, op->node, &sv, ei);
	if (!rc) {
		out->node = op->node;
		out->parent = bc_tree_parent(t, op->node);
		out->position = sv.index;
		rc = send_ops(c, op, 1, out, ei);
	}
	if (rc) {
		reset(out);
	}
	return rc;
}

/* A new builder in *sub (bc_tree_begin done). Returns 0 or BC_ENOMEM. */
static int new_builder(struct bc_tree **sub, struct bc_errinfo *ei)
{
	if (!(*sub = bc_tree_create())) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	return bc_tree_begin(*sub);
}

/* Ends an action whose last operation carries the subtree built in sub
 * (rc: how building it went; sub may be NULL after a failure): finishes
 * and encodes it, checks and sends ops (send_ops), frees sub. out, filled
 * by the caller, is reset on failure. */
static int send_built(struct bc_client *c, struct bc_tree *sub, int rc,
                      struct bc_proto_edit_op *ops, uint32_t nops,
                      struct bc_model_result *out, struct bc_errinfo *ei)
{
	uint8_t *bytes = NULL;
	size_t len = 0;
	rc = rc ? rc : bc_tree_end(sub, ei);
	if (!rc && (rc = bc_scene_encode(sub, NULL, &bytes, &len))) {
		bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	if (!rc) {
		ops[nops - 1].subtree =
		    (struct bc_proto_bytes){.ptr = bytes, .len = (uint32_t)len};
		rc = send_ops(c, ops, nops, out, ei);
	}
	bc_free(bytes);
	bc_tree_destroy(sub);
	if (rc) {
		reset(out);
	}
	return rc;
}

/* The operator new nodes go under: parent, or the first operator below
 * the unary nodes at the top; refusals say what to do instead. */
static int add_parent(const struct bc_tree *t, uint32_t parent, uint32_t *out,
                      struct bc_errinfo *ei)
{
	uint32_t p = parent ? parent : bc_tree_root(t);
	enum node_class cls = classify(t, p, NULL, NULL, NULL);
	while (!parent && cls == NODE_UNARY) {
		p = bc_tree_child(t, p, 0);
		cls = classify(t, p, NULL, NULL, NULL);
	}
	if (!parent && cls == NODE_PRIM) {
		/* No operator at the top: beside the root, in a new union. */
		*out = 0;
		return 0;
	}
	switch (cls) {
	case NODE_NONE:
		return no_node(p, ei);
	case NODE_PRIM:
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is a %s, a primitive: nodes go "
		                      "under operators; wrap it in one first "
		                      "(blobcast wrap %u union)",
		                      p, kind_name(t, p), p);
	case NODE_UNARY:
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is a %s node, which has exactly "
		                      "one child: add under an operator, or "
		                      "wrap its child in one (blobcast wrap %u "
		                      "union)",
		                      p, kind_name(t, p),
		                      bc_tree_child(t, p, 0));
	case NODE_OP:
		break;
	}
	*out = p;
	return 0;
}

static int check_position(const struct bc_tree *t, uint32_t parent, bool has,
                          uint32_t pos, uint32_t *out, struct bc_errinfo *ei)
{
	uint32_t n = bc_tree_child_count(t, parent);
	if (has && pos > n) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "position %u is beyond the %u children "
		                      "of node %u: give 0..%u",
		                      pos, n, parent, n);
	}
	*out = has ? pos : n;
	return 0;
}

/* ---- the actions ---------------------------------------------------------------- */

/* Emits the node nn with id first (and the primitives it starts with,
 * first + 1 ...) into the builder sub, placed around pos. */
static int put_new(struct bc_tree *sub, const struct new_node *nn,
                   uint32_t first, const struct bc_prim_data *child,
                   const float pos[3], const float right[3],
                   struct bc_errinfo *ei)
{
	float half = 0.5f * BC_MODEL_PAIR_SPACING;
	int rc;
	if (nn->cls == NODE_PRIM) {
		return put_placed(sub, first, nn->p, nn->has_translate, pos,
		                  right, 0.0f, ei);
	}
	if (nn->cls == NODE_UNARY) {
		rc = bc_tree_push_unary(sub, first, &nn->u, ei);
		rc = rc ? rc
		        : put_placed(sub, first + 1, *child, false, pos, right,
		                     0.0f, ei);
		return rc ? rc : bc_tree_pop_op(sub, ei);
	}
	rc = bc_tree_push_op(sub, first, &nn->op, ei);
	rc = rc ? rc
	        : put_placed(sub, first + 1, *child, false, pos, right, -half,
	                     ei);
	rc = rc ? rc
	        : put_placed(sub, first + 2, *child, false, pos, right, half,
	                     ei);
	return rc ? rc : bc_tree_pop_op(sub, ei);
}

/* The root with the new node beside it, under a new union of id uid (the
 * new node at position pos, 0 or 1): a REPLACE of the root. */
static int put_beside_root(struct bc_tree *sub, const struct bc_tree *t,
                           uint32_t uid, uint32_t at, const struct new_node *nn,
                           uint32_t first, const struct bc_prim_data *child,
                           const float pos[3], const float right[3],
                           struct bc_errinfo *ei)
{
	const struct bc_op_data u = {.kind = BC_OP_UNION};
	int rc = bc_tree_push_op(sub, uid, &u, ei);
	if (!rc && at == 0) {
		rc = put_new(sub, nn, first, child, pos, right, ei);
	}
	rc = rc ? rc : put_subtree(sub, t, bc_tree_root(t), false, 0, NULL, ei);
	if (!rc && at == 1) {
		rc = put_new(sub, nn, first, child, pos, right, ei);
	}
	return rc ? rc : bc_tree_pop_op(sub, ei);
}

int bc_model_add(struct bc_client *c, const struct bc_model_add *a,
                 struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT};
	const struct bc_tree *t = NULL;
	struct bc_tree *sub = NULL;
	struct bc_prim_data child;
	struct new_node nn;
	struct bc_camera cam;
	struct survey sv;
	float pos[3], right[3];
	uint32_t parent, first, nids, own;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	if ((rc = mirror(c, &t, &cam, ei)) ||
	    (rc = add_parent(t, a->parent, &parent, ei))) {
		return rc;
	}
	if (parent != 0) {
		rc = check_position(t, parent, a->has_position, a->position,
		                    &op.position, ei);
	} else if (a->has_position && a->position > 1) {
		rc = bc_errinfo_set(ei, BC_ERANGE,
		                    "position %u: the scene's root is not an "
		                    "operator, so the new node goes beside it "
		                    "in a new union: give 0 (before it) or 1",
		                    a->position);
	} else {
		op.position = a->has_position ? a->position : 1u;
	}
	if (rc || (rc = new_node(a->kind, a->kv, a->nkv, &nn, ei)) ||
	    (rc = child_prim(a->child_kind, &child, ei)) ||
	    (a->name && a->name[0] &&
	     (rc = check_name(c, a->name, strlen(a->name), ei))) ||
	    (rc = survey(t, 0, &sv, ei))) {
		return rc;
	}
	own = nn.cls == NODE_PRIM ? 1u : nn.cls == NODE_UNARY ? 2u : 3u;
	nids = own + (parent == 0 ? 1u : 0u);
	if ((rc = fresh_ids(c, t, sv.max_id, nids, &first, ei))) {
		return rc;
	}
	*out = (struct bc_model_result){.node = first,
	                                .first_id = first,
	                                .nids = nids,
	                                .parent = parent ? parent : first + own,
	                                .position = op.position};
	placement(&cam, a->has_at, a->at, pos, right);
	rc = new_builder(&sub, ei);
	if (!rc && parent == 0) {
		op.kind = BC_PROTO_EDIT_REPLACE;
		op.node = bc_tree_root(t);
		rc = put_beside_root(sub, t, first + own, op.position, &nn,
		                     first, &child, pos, right, ei);
	} else if (!rc) {
		op.node = parent;
		rc = put_new(sub, &nn, first, &child, pos, right, ei);
	}
	rc = rc ? rc : name_new(sub, first, a->name, ei);
	return send_built(c, sub, rc, &op, 1, out, ei);
}

/* The refusal for removing or moving the root (or a chain up to it). */
static int root_refusal(const struct bc_tree *t, uint32_t node,
                        const char *action, struct bc_errinfo *ei)
{
	uint32_t root = bc_tree_root(t);
	if (node == root) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is the root: a scene is never "
		                      "empty and the root has no parent to %s "
		                      "from; change it (blobcast edit), or %s "
		                      "its children",
		                      node, action, action);
	}
	return bc_errinfo_set(ei, BC_EINVAL,
	                      "node %u is wrapped by unary nodes up to the "
	                      "root (%u), which would go with it: a scene is "
	                      "never empty; change node %u instead "
	                      "(blobcast edit)",
	                      node, root, node);
}

int bc_model_remove(struct bc_client *c, uint32_t node,
                    struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REMOVE};
	const struct bc_tree *t = NULL;
	struct survey sv;
	uint32_t top;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	if ((rc = mirror(c, &t, NULL, ei))) {
		return rc;
	}
	if (classify(t, node, NULL, NULL, NULL) == NODE_NONE) {
		return no_node(node, ei);
	}
	if ((top = chain_top(t, node)) == bc_tree_root(t)) {
		return root_refusal(t, node, "remove", ei);
	}
	if ((rc = survey(t, top, &sv, ei))) {
		return rc;
	}
	op.node = node;
	out->node = top;
	out->parent = bc_tree_parent(t, top);
	out->position = sv.index;
	rc = send_ops(c, &op, 1, out, ei);
	if (rc) {
		reset(out);
	}
	return rc;
}

/* The destination of a move: an operator outside top's subtree. */
static int move_target(const struct bc_tree *t, uint32_t top, uint32_t parent,
                       struct bc_errinfo *ei)
{
	switch (classify(t, parent, NULL, NULL, NULL)) {
	case NODE_NONE:
		return no_node(parent, ei);
	case NODE_PRIM:
	case NODE_UNARY:
		if (!is_ancestor(t, top, parent)) {
			uint32_t ignored;
			return add_parent(t, parent, &ignored, ei);
		}
		break;
	case NODE_OP:
		break;
	}
	if (is_ancestor(t, top, parent)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is %s %u: a node cannot move "
		                      "under itself or one of its descendants; "
		                      "pick an operator outside its subtree",
		                      parent,
		                      parent == top ? "the node to move,"
		                                    : "inside the subtree of",
		                      top);
	}
	return 0;
}

/* Builds in *sub operator p (two children) as itself with its children
 * swapped, for a REPLACE: the move within p that a REMOVE cannot make. */
static int swap_children(const struct bc_tree *t, uint32_t p,
                         struct bc_tree **sub, struct bc_errinfo *ei)
{
	struct bc_op_data op;
	int rc = new_builder(sub, ei);
	bc_tree_get(t, p, NULL, &op);
	rc = rc ? rc : bc_tree_push_op(*sub, p, &op, ei);
	/* A REPLACE takes the replaced node's name: give it back. */
	rc = rc ? rc : keep_name(*sub, p, t, p, ei);
	rc = rc ? rc
	        : put_subtree(*sub, t, bc_tree_child(t, p, 1), false, 0, NULL,
	                      ei);
	rc = rc ? rc
	        : put_subtree(*sub, t, bc_tree_child(t, p, 0), false, 0, NULL,
	                      ei);
	return rc ? rc : bc_tree_pop_op(*sub, ei);
}

int bc_model_move(struct bc_client *c, const struct bc_model_move *m,
                  struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_edit_op ops[MODEL_MAX_OPS];
	const struct bc_tree *t = NULL;
	struct bc_tree *sub = NULL;
	struct survey sv;
	uint32_t top, from, pos = 0, nops = 0;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	memset(ops, 0, sizeof(ops));
	if ((rc = mirror(c, &t, NULL, ei))) {
		return rc;
	}
	if (classify(t, m->node, NULL, NULL, NULL) == NODE_NONE) {
		return no_node(m->node, ei);
	}
	top = chain_top(t, m->node);
	if (top == bc_tree_root(t)) {
		return root_refusal(t, m->node, "move", ei);
	}
	if ((rc = move_target(t, top, m->parent, ei)) ||
	    (rc = check_position(t, m->parent, m->has_position, m->position,
	                         &pos, ei)) ||
	    (rc = survey(t, top, &sv, ei))) {
		return rc;
	}
	from = bc_tree_parent(t, top);
	if (from == m->parent && (pos == sv.index || pos == sv.index + 1u)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is already child %u of node %u: "
		                      "nothing to move",
		                      top, sv.index, from);
	}
	*out = (struct bc_model_result){.node = top, .parent = m->parent};
	if (from == m->parent && bc_tree_child_count(t, from) == 2) {
		/* Taking one of two children out would dissolve the
		 * operator it is to go back into. */
		rc = swap_children(t, from, &sub, ei);
		ops[nops++] = (struct bc_proto_edit_op){
		    .kind = BC_PROTO_EDIT_REPLACE, .node = from};
		out->position = 1u - sv.index;
	} else {
		rc = new_builder(&sub, ei);
		rc = rc ? rc : put_subtree(sub, t, top, false, 0, NULL, ei);
		if (from == m->parent && sv.index < pos) {
			pos--;
		}
		ops[nops++] = (struct bc_proto_edit_op){
		    .kind = BC_PROTO_EDIT_REMOVE, .node = top};
		ops[nops++] =
		    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
		                              .node = m->parent,
		                              .position = pos};
		out->position = pos;
	}
	return send_built(c, sub, rc, ops, nops, out, ei);
}

int bc_model_wrap(struct bc_client *c, const struct bc_model_wrap *w,
                  struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REPLACE};
	const struct bc_tree *t = NULL;
	struct bc_tree *sub = NULL;
	struct bc_prim_data child;
	struct new_node nn;
	struct bc_camera cam;
	struct survey sv;
	float pos[3], right[3];
	uint32_t first, nids;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	if ((rc = mirror(c, &t, &cam, ei))) {
		return rc;
	}
	if (classify(t, w->node, NULL, NULL, NULL) == NODE_NONE) {
		return no_node(w->node, ei);
	}
	if ((rc = new_node(w->kind, w->kv, w->nkv, &nn, ei)) ||
	    (rc = child_prim(w->child_kind, &child, ei)) ||
	    (w->name && w->name[0] &&
	     (rc = check_name(c, w->name, strlen(w->name), ei))) ||
	    (rc = survey(t, w->node, &sv, ei))) {
		return rc;
	}
	if (nn.cls == NODE_PRIM) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "a %s is a primitive and holds no other "
		                      "node: wrap in a unary node (offset, "
		                      "twist, ...) or an operator (union, ...)",
		                      w->kind);
	}
	if ((uint64_t)depth_of(t, w->node) + sv.height > BC_TREE_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_EDEPTH,
		                      "wrapping node %u would nest the tree "
		                      "deeper than %u levels: wrap a node "
		                      "nearer the root",
		                      w->node, BC_TREE_MAX_DEPTH);
	}
	nids = nn.cls == NODE_UNARY ? 1u : 2u;
	if ((rc = fresh_ids(c, t, sv.max_id, nids, &first, ei))) {
		return rc;
	}
	*out = (struct bc_model_result){.node = first,
	                                .first_id = first,
	                                .nids = nids,
	                                .parent = bc_tree_parent(t, w->node),
	                                .position = sv.index};
	op.node = w->node;
	placement(&cam, w->has_at, w->at, pos, right);
	rc = new_builder(&sub, ei);
	if (!rc) {
		rc = nn.cls == NODE_UNARY
		         ? bc_tree_push_unary(sub, first, &nn.u, ei)
		         : bc_tree_push_op(sub, first, &nn.op, ei);
	}
	rc = rc ? rc : put_subtree(sub, t, w->node, false, 0, NULL, ei);
	if (!rc && nn.cls == NODE_OP) {
		rc = put_placed(sub, first + 1, child, false, pos, right, 0.0f,
		                ei);
	}
	rc = rc ? rc : bc_tree_pop_op(sub, ei);
	rc = rc ? rc : name_new(sub, first, w->name, ei);
	return send_built(c, sub, rc, &op, 1, out, ei);
}

int bc_model_duplicate(struct bc_client *c, const struct bc_model_duplicate *d,
                       struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT};
	const struct bc_tree *t = NULL;
	struct bc_tree *sub = NULL;
	struct survey sv;
	const char *name;
	uint32_t top, first;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	if ((rc = mirror(c, &t, NULL, ei))) {
		return rc;
	}
	if (classify(t, d->node, NULL, NULL, NULL) == NODE_NONE) {
		return no_node(d->node, ei);
	}
	if ((top = chain_top(t, d->node)) == bc_tree_root(t)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u %s: a copy needs an operator to "
		                      "sit under; wrap it in one first "
		                      "(blobcast wrap %u union)",
		                      d->node,
		                      top == d->node ? "is the root"
		                                     : "is wrapped up to the "
		                                       "root",
		                      top);
	}
	if ((rc = survey(t, top, &sv, ei)) ||
	    (rc = fresh_ids(c, t, sv.max_id, sv.nodes, &first, ei))) {
		return rc;
	}
	op.node = bc_tree_parent(t, top);
	op.position = sv.index + 1u;
	*out = (struct bc_model_result){.node = first,
	                                .first_id = first,
	                                .nids = sv.nodes,
	                                .parent = op.node,
	                                .position = op.position};
	rc = new_builder(&sub, ei);
	rc = rc ? rc
	        : put_subtree(sub, t, top, true, first,
	                      d->has_offset ? d->offset : NULL, ei);
	if (!rc && (name = bc_tree_name(t, d->node)) != NULL) {
		/* d->node is the last of the unary chain from top, each
		 * node's one child next in pre-order. */
		char copy[BC_TREE_NAME_MAX + 1];
		copy_name(name, copy);
		rc = bc_tree_set_name(
		    sub, first + depth_of(t, d->node) - depth_of(t, top), copy,
		    strlen(copy), ei);
	}
	return send_built(c, sub, rc, &op, 1, out, ei);
}

int bc_model_set_operator(struct bc_client *c, uint32_t node, const char *kind,
                          float blend, float range, struct bc_model_result *out,
                          struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_field fields[3];
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET,
	                              .fields = fields};
	const struct bc_tree *t = NULL;
	struct bc_op_data cur;
	enum bc_op k = kind ? bc_op_from_name(kind) : BC_OP_INVALID;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	if ((rc = mirror(c, &t, NULL, ei))) {
		return rc;
	}
	switch (classify(t, node, NULL, &cur, NULL)) {
	case NODE_NONE:
		return no_node(node, ei);
	case NODE_OP:
		break;
	case NODE_PRIM:
	case NODE_UNARY:
		return bc_errinfo_set(
		    ei, BC_EINVAL,
		    "node %u is a %s, not an operator: change "
		    "its parameters with blobcast edit",
		    node, kind_name(t, node));
	}
	if (k == BC_OP_INVALID || bc_op_is_unary(k)) {
		return bc_errinfo_set(
		    ei, BC_EINVAL,
		    "\"%.40s\" is not an operator: union, "
		    "intersection, difference, smooth_union, "
		    "smooth_intersection or smooth_difference",
		    kind ? kind : "(none)");
	}
	if (!isfinite(blend) || !isfinite(range) || blend < 0.0f ||
	    range < 0.0f) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "blend and range must be finite and >= 0 "
		                      "(0: the default)");
	}
	if (!bc_op_is_smooth(k)) {
		blend = range = 0.0f;
	} else if (blend == 0.0f) {
		bool keep = bc_op_is_smooth(cur.kind);
		blend = keep ? cur.blend : BC_MODEL_DEFAULT_BLEND;
		range = range == 0.0f && keep ? cur.range : range;
	}
	fields[0] = (struct bc_proto_field){
	    .field = BC_PROTO_FIELD_OP_KIND, .count = 1, .v = {(float)k}};
	fields[1] = (struct bc_proto_field){
	    .field = BC_PROTO_FIELD_BLEND, .count = 1, .v = {blend}};
	fields[2] = (struct bc_proto_field){
	    .field = BC_PROTO_FIELD_RANGE, .count = 1, .v = {range}};
	op.node = node;
	op.nfields = 3;
	return send_on_node(c, t, &op, out, ei);
}

int bc_model_rename(struct bc_client *c, uint32_t node, const char *name,
                    struct bc_model_result *out, struct bc_errinfo *ei)
{
	struct bc_model_result dummy;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_NAME, .node = node};
	const struct bc_tree *t = NULL;
	size_t len = name ? strlen(name) : 0;
	const char *now;
	int rc;
	out = out ? out : &dummy;
	reset(out);
	if ((rc = mirror(c, &t, NULL, ei)) || (rc = need_names(c, ei))) {
		return rc;
	}
	if (classify(t, node, NULL, NULL, NULL) == NODE_NONE) {
		return no_node(node, ei);
	}
	if ((rc = check_name(c, name ? name : "", len, ei))) {
		return rc;
	}
	now = bc_tree_name(t, node);
	if (len == 0 && !now) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u has no name: nothing to remove",
		                      node);
	}
	if (len > 0 && now && strcmp(now, name) == 0) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u already has that name: nothing "
		                      "to change",
		                      node);
	}
	op.name = (struct bc_proto_str){.ptr = name, .len = (uint32_t)len};
	return send_on_node(c, t, &op, out, ei);
}
