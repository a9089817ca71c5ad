/*
 * The binary scene encoding (docs/scene-format.md, quoted by PROTOCOL.md):
 * the compact form of a scene that SCENE_LOAD and SCENE_STATE carry, and of
 * the subtrees that structural edits insert. This file owns its encoder, its
 * decoder and the linear-time pre-order walk both encodings use.
 *
 * Decoding reads untrusted bytes in two passes. The first checks everything
 * the bytes alone decide -- lengths, counts, tags, flags, finiteness, the
 * shape of the pre-order -- with an explicit heap stack (any depth up to
 * BC_TREE_MAX_DEPTH), and allocates nothing but that stack and an id array,
 * both sized from a count already checked against the bytes left. Only then
 * does the second pass build the tree, where the builder validates parameters
 * and ids. A node costs at least BC_SCENE_NODE_MIN_BYTES, so no count can make
 * us loop or allocate beyond what the input's length pays for.
 */
#include "blobcast/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/num.h"
#include "blobcast/buf.h"
#include "blobcast/bytes.h"
#include "tree_impl.h"

/* ---- pre-order walk ------------------------------------------------------ */

/* The walk follows the model's links (first child, next sibling, parent):
 * O(1) a step however wide an operator is, no memory of its own, and the
 * same for a bare tree as for a laid-out one. */
static int walk_start(struct bc_scene_walk *w, const struct bc_tree *t,
                      uint32_t top)
{
	memset(w, 0, sizeof(*w));
	if (t->building || top == BC_NONE) {
		return BC_EINVAL;
	}
	w->t = t;
	w->top = top;
	w->next = top;
	return 0;
}

int bc_scene_walk_init(struct bc_scene_walk *w, const struct bc_tree *t)
{
	return walk_start(w, t, t->root);
}

int bc_scene_walk_init_at(struct bc_scene_walk *w, const struct bc_tree *t,
                          uint32_t id)
{
	return walk_start(w, t, t->building ? BC_NONE : bc__id_find(t, id));
}

bool bc_scene_walk_next(struct bc_scene_walk *w, struct bc_scene_node *out)
{
	const struct bc_tree *t = w->t;
	const struct bc__node *nd;
	uint32_t n = w->next;
	memset(out, 0, sizeof(*out));
	if (n == BC_NONE) {
		return false;
	}
	nd = &t->pool[n];
	out->id = nd->id;
	out->index = w->index++;
	out->depth = w->depth;
	out->is_op = nd->is_op;
	if (nd->is_op) {
		out->nchildren = nd->u.nchildren;
		if (bc__node_unary(nd)) {
			out->op.kind = nd->u.op.kind;
			out->unary.kind = nd->u.op.kind;
			memcpy(out->unary.u, bc__uparam(t, nd),
			       sizeof(out->unary.u));
		} else {
			out->op = nd->u.op;
		}
		w->next = nd->u.first_child;
		w->depth++;
		return true;
	}
	bc__prim_read(t, nd, &out->prim);
	/* A leaf closes every operator it ends: up to the first ancestor
	 * with a sibling after it, or to the walk's top. */
	while (n != w->top && t->pool[n].next == BC_NONE) {
		n = t->pool[n].parent;
		out->closes++;
		w->depth--;
	}
	w->next = n == w->top ? BC_NONE : t->pool[n].next;
	return true;
}

void bc_scene_walk_finish(struct bc_scene_walk *w)
{
	memset(w, 0, sizeof(*w));
}

uint32_t bc_scene_prim_nfloats(enum bc_prim kind)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	uint32_t n = 0;
	if (!info || kind == BC_PRIM_INVALID) {
		return 0;
	}
	for (uint32_t i = 0; i < info->nparams; i++) {
		uint32_t end =
		    (uint32_t)info->params[i].offset + info->params[i].count;
		if (end > n) {
			n = end;
		}
	}
	return n;
}

/* ---- writing ------------------------------------------------------------- */

static void put_u8(struct bc_buf *b, uint8_t v)
{
	bc_buf_append(b, &v, 1);
}

static void put_u32(struct bc_buf *b, uint32_t v)
{
	uint8_t w[4];
	bc_put_le32(w, v);
	bc_buf_append(b, w, sizeof(w));
}

static void put_f32(struct bc_buf *b, float f)
{
	uint8_t w[4];
	bc_put_f32(w, f);
	bc_buf_append(b, w, sizeof(w));
}

static void put_f32s(struct bc_buf *b, const float *f, uint32_t n)
{
	for (uint32_t i = 0; i < n; i++) {
		put_f32(b, f[i]);
	}
}

/* The most bytes one node takes: a primitive with a colour and every
 * parameter (a unary node or an operator takes fewer). */
#define NODE_MAX_BYTES (1u + 4u + 12u + 16u + 1u + 12u + 1u + 4u * 255u)

/* Writes n floats at p; returns the end. */
static uint8_t *at_f32s(uint8_t *p, const float *f, uint32_t n)
{
	for (uint32_t i = 0; i < n; i++, p += 4) {
		bc_put_f32(p, f[i]);
	}
	return p;
}

/* Pool node nd's bytes, composed in one buffer and appended once (a
 * million nodes' fields appended one by one took most of an encode). */
static void put_node(struct bc_buf *b, const struct bc_tree *t,
                     const struct bc__node *nd)
{
	uint8_t w[NODE_MAX_BYTES], *p = w;
	if (bc__node_unary(nd)) {
		/* Unary: tag, id, nfloats, floats; its one child follows. */
		uint32_t nf = bc_unary_info(nd->u.op.kind)->nparams;
		*p++ = (uint8_t)(BC_SCENE_TAG_OP | (uint32_t)nd->u.op.kind);
		bc_put_le32(p, nd->id);
		p += 4;
		*p++ = (uint8_t)nf;
		p = at_f32s(p, bc__uparam(t, nd), nf);
	} else if (nd->is_op) {
		*p++ = (uint8_t)(BC_SCENE_TAG_OP | (uint32_t)nd->u.op.kind);
		bc_put_le32(p, nd->id);
		bc_put_f32(p + 4, nd->u.op.blend);
		bc_put_f32(p + 8, nd->u.op.range);
		bc_put_le32(p + 12, nd->u.nchildren);
		p += 16;
	} else {
		struct bc_prim_data prd;
		const struct bc_prim_data *pr = &prd;
		uint32_t nf;
		bc__prim_read(t, nd, &prd);
		nf = bc_scene_prim_nfloats(pr->kind);
		*p++ = (uint8_t)pr->kind;
		bc_put_le32(p, nd->id);
		p = at_f32s(p + 4, pr->translate, 3);
		p = at_f32s(p, pr->rotate, 4);
		*p++ = pr->has_color ? 1 : 0;
		if (pr->has_color) {
			p = at_f32s(p, pr->color, 3);
		}
		*p++ = (uint8_t)nf;
		p = at_f32s(p, pr->params, nf);
	}
	bc_buf_append(b, w, (size_t)(p - w));
}

/* Where a streamed encoding goes (bc_scene_write_binary): b is handed to
 * fn and emptied whenever it holds a piece. NULL: b holds it all. */
#define PIECE_BYTES (256u * 1024u)
struct pieces {
	bc_scene_sink fn;
	void *ctx;
	int rc; /* the sink's error, which stops the writing */
};

/* Hands b to the sink (when there is one and b holds at least least
 * bytes) and empties it. False once the writing must stop. */
static bool pass_on(struct bc_buf *b, struct pieces *ps, size_t least)
{
	if (b->err) {
		return false;
	}
	if (!ps || b->len < least || b->len == 0) {
		return true;
	}
	ps->rc = ps->fn(ps->ctx, b->data, b->len);
	b->len = 0;
	return ps->rc == 0;
}

/* The nodes in pre-order, straight from the pool's child lists (the
 * order the layout folds them in, and bc_scene_walk gives): no id lookup
 * per node, and a decoded tree's pool is read front to back. */
static void put_nodes(struct bc_buf *b, const struct bc_tree *t,
                      struct pieces *ps)
{
	uint32_t n = t->root;
	for (;;) {
		put_node(b, t, &t->pool[n]);
		if (!pass_on(b, ps, PIECE_BYTES)) {
			return;
		}
		if (t->pool[n].is_op) {
			n = t->pool[n].u.first_child;
			continue;
		}
		while (n != t->root && t->pool[n].next == BC_NONE) {
			n = t->pool[n].parent;
		}
		if (n == t->root) {
			return;
		}
		n = t->pool[n].next;
	}
}

/* The names table (PROTOCOL.md 8): count, then (id, name) by id. */
static void put_names(struct bc_buf *b, const struct bc_tree *t)
{
	uint32_t n, *ids = bc_tree_name_ids(t, &n);
	if (!ids) {
		b->err = BC_ENOMEM;
		return;
	}
	put_u32(b, n);
	for (uint32_t i = 0; i < n; i++) {
		const char *name = bc_tree_name(t, ids[i]);
		uint8_t w[2];
		size_t k = strlen(name);
		put_u32(b, ids[i]);
		bc_put_le16(w, (uint16_t)k);
		bc_buf_append(b, w, sizeof(w));
		bc_buf_append(b, name, k);
	}
	bc_free(ids);
}

/* The encoding after head zero bytes (the caller's to fill) into b, or
 * through ps in pieces (head 0). */
static int encode_into(const struct bc_tree *t, const struct bc_camera *cam,
                       bool scene, size_t head, struct bc_buf *b,
                       struct pieces *ps)
{
	bool names = scene && bc_tree_name_count(t) > 0;
	if (t->building || bc_tree_node_count(t) == 0 || t->root == BC_NONE) {
		return BC_EINVAL;
	}
	/* The final size, but for unary nodes' floats and the names: one
	 * allocation, no growth (a piece and a node when streamed). */
	{
		uint32_t colored = 0, nodes = bc_tree_node_count(t);
		uint32_t prims = bc_tree_prim_count(t);
		uint64_t floats = 0;
		bc_tree_counts(t, &colored, &floats);
		if (!bc_buf_reserve(
		        b, ps ? PIECE_BYTES + NODE_MAX_BYTES
		              : head + 64u + (size_t)(nodes - prims) * 17u +
		                    (size_t)prims * 35u +
		                    (size_t)colored * 12u + 4u * floats)) {
			memset(b->data, 0, head);
			b->len = head;
		}
	}
	if (scene) {
		put_u8(b, (uint8_t)((cam ? BC_SCENE_FLAG_CAMERA : 0) |
		                    (names ? BC_SCENE_FLAG_NAMES : 0)));
		if (cam) {
			put_f32s(b, cam->eye, 3);
			put_f32s(b, cam->target, 3);
			put_f32s(b, cam->up, 3);
			put_f32(b, cam->fov_y_deg);
		}
	}
	put_u32(b, bc_tree_node_count(t));
	if (!b->err) {
		put_nodes(b, t, ps);
	}
	if (names && !b->err && (!ps || !ps->rc)) {
		put_names(b, t);
	}
	if (ps && !ps->rc) {
		pass_on(b, ps, 0);
	}
	/* No ceiling of its own: BC_ENOMEM is the failure left. */
	return b->err ? b->err : ps ? ps->rc : 0;
}

static int encode(const struct bc_tree *t, const struct bc_camera *cam,
                  bool scene, size_t head, uint8_t **out, size_t *len)
{
	struct bc_buf b;
	int rc;
	*out = NULL;
	*len = 0;
	bc_buf_init(&b, SIZE_MAX);
	if ((rc = encode_into(t, cam, scene, head, &b, NULL))) {
		bc_buf_finish(&b);
		return rc;
	}
	return bc_buf_take(&b, out, len);
}

int bc_scene_write_binary(const struct bc_tree *t, const struct bc_camera *cam,
                          bc_scene_sink sink, void *ctx)
{
	struct pieces ps = {sink, ctx, 0};
	struct bc_buf b;
	int rc;
	bc_buf_init(&b, SIZE_MAX);
	rc = encode_into(t, cam, true, 0, &b, &ps);
	bc_buf_finish(&b);
	return rc;
}

int bc_scene_encode(const struct bc_tree *t, const struct bc_camera *cam,
                    uint8_t **out, size_t *len)
{
	return encode(t, cam, true, 0, out, len);
}

int bc_scene_encode_after(const struct bc_tree *t, const struct bc_camera *cam,
                          size_t head, uint8_t **out, size_t *len)
{
	return encode(t, cam, true, head, out, len);
}

int bc_tree_encode(const struct bc_tree *t, uint8_t **out, size_t *len)
{
	return encode(t, NULL, false, 0, out, len);
}

/* ---- reading ------------------------------------------------------------- */

/* Each get_* checks the bytes left first and fails with
 * BC_EPROTO_TRUNCATED naming the node and field. */
static int need(const struct bc_rd *r, size_t n, uint32_t node,
                const char *what, struct bc_errinfo *ei)
{
	if (n > bc_rd_left(r)) {
		return bc_errinfo_set(ei, BC_EPROTO_TRUNCATED,
		                      "node %u: %s needs %zu bytes, %zu left",
		                      node, what, n, bc_rd_left(r));
	}
	return 0;
}

static int get_u8(struct bc_rd *r, uint8_t *v, uint32_t node, const char *what,
                  struct bc_errinfo *ei)
{
	int rc = need(r, 1, node, what, ei);
	if (!rc) {
		*v = bc_rd_u8(r);
	}
	return rc;
}

static int get_u32(struct bc_rd *r, uint32_t *v, uint32_t node,
                   const char *what, struct bc_errinfo *ei)
{
	int rc = need(r, 4, node, what, ei);
	if (!rc) {
		*v = bc_rd_u32(r);
	}
	return rc;
}

/* Reads n finite floats. */
static int get_f32s(struct bc_rd *r, float *f, uint32_t n, uint32_t node,
                    const char *what, struct bc_errinfo *ei)
{
	int rc = need(r, 4 * (size_t)n, node, what, ei);
	if (rc) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		f[i] = bc_rd_f32(r);
		if (!isfinite(f[i])) {
			return bc_errinfo_set(ei, BC_ENONFINITE,
			                      "node %u: %s[%u] is not finite",
			                      node, what, i);
		}
	}
	return 0;
}

/* One node as the bytes give it. */
struct dnode {
	uint32_t id;
	bool is_op;
	uint32_t nchildren;
	struct bc_prim_data prim;
	struct bc_op_data op;
	struct bc_unary unary;
};

/* Reads node number index of count, checking everything the bytes decide. */
static int read_node(struct bc_rd *r, uint32_t index, uint32_t count,
                     struct dnode *n, struct bc_errinfo *ei)
{
	uint8_t tag, flag, nf;
	int rc;
	if ((rc = get_u8(r, &tag, index, "tag", ei)) ||
	    (rc = get_u32(r, &n->id, index, "id", ei))) {
		return rc;
	}
	n->is_op = (tag & BC_SCENE_TAG_OP) != 0;
	if (n->is_op) {
		uint32_t kind = tag & ~BC_SCENE_TAG_OP;
		uint32_t after = count - 1 - index;
		if (kind == BC_OP_INVALID || kind >= BC_OP_COUNT) {
			return bc_errinfo_set(ei, BC_EENUM,
			                      "node %u: unknown operator tag "
			                      "0x%02x",
			                      index, tag);
		}
		memset(&n->op, 0, sizeof(n->op));
		n->op.kind = (enum bc_op)kind;
		if (bc_op_is_unary(n->op.kind)) {
			const struct bc_unary_info *info =
			    bc_unary_info(n->op.kind);
			memset(&n->unary, 0, sizeof(n->unary));
			n->unary.kind = n->op.kind;
			if ((rc = get_u8(r, &nf, index, "nfloats", ei))) {
				return rc;
			}
			if (nf != info->nparams) {
				return bc_errinfo_set(
				    ei, BC_EPROTO_COUNT,
				    "node %u: nfloats is %u but "
				    "a %s has %u",
				    index, nf, info->name, info->nparams);
			}
			if ((rc = get_f32s(r, n->unary.u, nf, index, "params",
			                   ei))) {
				return rc;
			}
			if (after < 1) {
				return bc_errinfo_set(ei, BC_EPROTO_COUNT,
				                      "node %u: a %s needs its "
				                      "child after it",
				                      index, info->name);
			}
			n->nchildren = 1;
			return 0;
		}
		if ((rc = get_f32s(r, &n->op.blend, 1, index, "blend", ei)) ||
		    (rc = get_f32s(r, &n->op.range, 1, index, "range", ei)) ||
		    (rc =
		         get_u32(r, &n->nchildren, index, "child_count", ei))) {
			return rc;
		}
		/* Each child is at least one more node of the encoding. */
		if (n->nchildren < 2 || n->nchildren > after) {
			return bc_errinfo_set(ei, BC_EPROTO_COUNT,
			                      "node %u: child_count %u outside "
			                      "2..%u (the nodes that follow)",
			                      index, n->nchildren, after);
		}
		if (!bc_op_is_smooth(n->op.kind) &&
		    (n->op.blend != 0.0f || n->op.range != 0.0f)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "node %u: %s takes no blend or "
			                      "range (both must be 0)",
			                      index, bc_op_name(n->op.kind));
		}
		return 0;
	}
	if (tag == BC_PRIM_INVALID || tag >= BC_PRIM_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM,
		                      "node %u: unknown primitive tag 0x%02x",
		                      index, tag);
	}
	n->nchildren = 0;
	bc_prim_data_init(&n->prim, (enum bc_prim)tag);
	if ((rc = get_f32s(r, n->prim.translate, 3, index, "translate", ei)) ||
	    (rc = get_f32s(r, n->prim.rotate, 4, index, "rotate", ei)) ||
	    (rc = get_u8(r, &flag, index, "has_color", ei))) {
		return rc;
	}
	if (flag > 1) {
		return bc_errinfo_set(ei, BC_EPROTO_FLAGS,
		                      "node %u: has_color is %u, not 0 or 1",
		                      index, flag);
	}
	n->prim.has_color = flag == 1;
	if (n->prim.has_color &&
	    (rc = get_f32s(r, n->prim.color, 3, index, "color", ei))) {
		return rc;
	}
	if ((rc = get_u8(r, &nf, index, "nfloats", ei))) {
		return rc;
	}
	if (nf != bc_scene_prim_nfloats(n->prim.kind)) {
		return bc_errinfo_set(ei, BC_EPROTO_COUNT,
		                      "node %u: nfloats is %u but a %s has %u",
		                      index, nf,
		                      bc_prim_info(n->prim.kind)->name,
		                      bc_scene_prim_nfloats(n->prim.kind));
	}
	return get_f32s(r, n->prim.params, nf, index, "params", ei);
}

/* Fresh ids for nodes encoded with id 0: the smallest ids that no node of
 * the encoding names, so an explicit id later in the stream never collides
 * with one handed out earlier. */
struct fresh {
	const uint32_t *ids; /* explicit ids, sorted */
	uint32_t n, p;
	uint32_t next;
};

static uint32_t fresh_next(struct fresh *f)
{
	for (;;) {
		uint32_t c = f->next++;
		while (f->p < f->n && f->ids[f->p] < c) {
			f->p++;
		}
		if (f->p == f->n || f->ids[f->p] != c) {
			return c;
		}
	}
}

/* Adds builder error context: which node failed. */
static int at_node(struct bc_errinfo *ei, int rc, uint32_t index, uint32_t id)
{
	char reason[sizeof(ei->msg)];
	if (!ei) {
		return rc;
	}
	memcpy(reason, ei->msg, sizeof(reason));
	reason[sizeof(reason) - 1] = '\0';
	return bc_errinfo_set(ei, rc, "node %u (id %u): %s", index, id, reason);
}

/* Pass 1 over the names table (PROTOCOL.md 8, check 6): the bytes alone.
 * Leaves r after it and *count its entries. */
static int scan_names(struct bc_rd *r, uint32_t nodes, uint32_t *count,
                      struct bc_errinfo *ei)
{
	uint32_t prev = 0;
	if (bc_rd_left(r) < 4) {
		return bc_errinfo_set(ei, BC_EPROTO_TRUNCATED,
		                      "names: name_count needs 4 bytes, %zu "
		                      "left",
		                      bc_rd_left(r));
	}
	*count = bc_rd_u32(r);
	if (*count == 0 || *count > nodes ||
	    *count > bc_rd_left(r) / BC_SCENE_NAME_MIN_BYTES) {
		return bc_errinfo_set(ei, BC_EPROTO_COUNT,
		                      "names: name_count %u is outside 1..%u "
		                      "(the node count) or beyond the %zu "
		                      "bytes left",
		                      *count, nodes, bc_rd_left(r));
	}
	for (uint32_t i = 0; i < *count; i++) {
		uint32_t id;
		uint16_t n;
		if (bc_rd_left(r) < 6) {
			return bc_errinfo_set(ei, BC_EPROTO_TRUNCATED,
			                      "name %u: id and length need 6 "
			                      "bytes, %zu left",
			                      i, bc_rd_left(r));
		}
		id = bc_rd_u32(r);
		n = bc_rd_u16(r);
		if (id == 0 || id <= prev) {
			return bc_errinfo_set(
			    ei, id != 0 && id == prev ? BC_EDUPID : BC_ERANGE,
			    "name %u: id %u after id %u (ids must increase "
			    "from 1)",
			    i, id, prev);
		}
		prev = id;
		if (n == 0 || n > BC_TREE_NAME_MAX) {
			return bc_errinfo_set(ei, BC_EPROTO_LENGTH,
			                      "name %u (node %u): length %u is "
			                      "outside 1..%u",
			                      i, id, (unsigned)n,
			                      BC_TREE_NAME_MAX);
		}
		if (bc_rd_left(r) < n) {
			return bc_errinfo_set(
			    ei, BC_EPROTO_TRUNCATED,
			    "name %u (node %u): needs %u bytes, "
			    "%zu left",
			    i, id, (unsigned)n, bc_rd_left(r));
		}
		if (bc_utf8_check(r->p + r->pos, n) < n) {
			return bc_errinfo_set(
			    ei, BC_ESTRING,
			    "name %u (node %u) breaks UTF-8 or "
			    "holds NUL",
			    i, id);
		}
		r->pos += n;
	}
	return 0;
}

/* Pass 2: names the nodes; ids are the scene's own, sorted (an id the
 * decoder chose for a node sent with id 0 is not one). */
static int put_names_in(struct bc_rd *r, struct bc_tree *t, uint32_t count,
                        const uint32_t *ids, uint32_t nids,
                        struct bc_errinfo *ei)
{
	r->pos += 4;
	for (uint32_t i = 0; i < count; i++) {
		uint32_t id = bc_rd_u32(r);
		uint16_t n = bc_rd_u16(r);
		int rc;
		if (!bsearch(&id, ids, nids, sizeof(*ids), bc_cmp_u32)) {
			return bc_errinfo_set(ei, BC_ENONODE,
			                      "name %u: no node has id %u", i,
			                      id);
		}
		if ((rc = bc_tree_set_name(t, id, (const char *)r->p + r->pos,
		                           n, ei))) {
			return rc;
		}
		r->pos += n;
	}
	return 0;
}

static int decode_tree(struct bc_rd *r, bool names, struct bc_tree *t,
                       struct bc_errinfo *ei)
{
	uint32_t count, nopen = 0, nids = 0, nzero = 0, nnames = 0;
	uint32_t *left = NULL, *opener = NULL; /* per open operator */
	uint32_t *ids = NULL;
	struct dnode n;
	struct fresh fr = {0};
	size_t start, names_at = 0;
	int rc;

	if ((rc = need(r, 4, 0, "node_count", ei))) {
		return rc;
	}
	count = bc_rd_u32(r);
	if (count == 0 || count > BC_TREE_MAX_NODES) {
		return bc_errinfo_set(ei, BC_EPROTO_COUNT,
		                      "node_count %u outside 1..%u", count,
		                      BC_TREE_MAX_NODES);
	}
	if (count > bc_rd_left(r) / BC_SCENE_NODE_MIN_BYTES) {
		return bc_errinfo_set(ei, BC_EPROTO_COUNT,
		                      "node_count %u needs at least %zu bytes, "
		                      "%zu left",
		                      count,
		                      (size_t)count * BC_SCENE_NODE_MIN_BYTES,
		                      bc_rd_left(r));
	}
	/* Bounded by the input: count <= len / 5. */
	ids = bc_malloc(sizeof(uint32_t) * (size_t)count);
	left = bc_malloc(sizeof(uint32_t) * (size_t)count);
	opener = bc_malloc(sizeof(uint32_t) * (size_t)count);
	if (!ids || !left || !opener) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "scene: out of memory");
		goto cleanup;
	}

	/* Pass 1: the bytes alone. */
	start = r->pos;
	for (uint32_t i = 0; i < count; i++) {
		if (i > 0 && nopen == 0) {
			rc = bc_errinfo_set(ei, BC_EPROTO_COUNT,
			                    "node %u: the root's subtree ended "
			                    "at node %u but node_count is %u",
			                    i, i - 1, count);
			goto cleanup;
		}
		/* Node i would be number nopen + 1 on its path: the
		 * builder's own count. */
		if (nopen + 1u > BC_TREE_MAX_DEPTH) {
			rc = bc_errinfo_set(ei, BC_EDEPTH,
			                    "node %u: nesting deeper than %u "
			                    "levels",
			                    i, BC_TREE_MAX_DEPTH);
			goto cleanup;
		}
		if ((rc = read_node(r, i, count, &n, ei))) {
			goto cleanup;
		}
		if (n.id) {
			ids[nids++] = n.id;
		} else {
			nzero++;
		}
		if (nopen) {
			left[nopen - 1]--;
		}
		if (n.is_op) {
			opener[nopen] = i;
			left[nopen++] = n.nchildren;
		} else {
			while (nopen && left[nopen - 1] == 0) {
				nopen--;
			}
		}
	}
	if (nopen) {
		rc = bc_errinfo_set(ei, BC_EPROTO_COUNT,
		                    "node %u: %u of its children are missing "
		                    "after the last node",
		                    opener[nopen - 1], left[nopen - 1]);
		goto cleanup;
	}
	names_at = r->pos;
	if (names && (rc = scan_names(r, count, &nnames, ei))) {
		goto cleanup;
	}
	if (bc_rd_left(r)) {
		rc = bc_errinfo_set(ei, BC_EPROTO_TRAILING,
		                    "%zu bytes after the %s", bc_rd_left(r),
		                    names ? "names" : "last node");
		goto cleanup;
	}
	if (nzero || nnames) {
		qsort(ids, nids, sizeof(uint32_t), bc_cmp_u32);
		fr.ids = ids;
		fr.n = nids;
		fr.next = 1;
	}

	/* Pass 2: build; the builder validates parameters and ids. */
	if ((rc = bc__tree_reserve(t, count))) {
		rc = bc_errinfo_set(ei, rc, "scene: %s", bc_strerror(rc));
		goto cleanup;
	}
	r->pos = start;
	for (uint32_t i = 0; i < count; i++) {
		uint32_t id;
		if ((rc = read_node(r, i, count, &n, ei))) {
			goto cleanup;
		}
		id = n.id ? n.id : fresh_next(&fr);
		if (nopen) {
			left[nopen - 1]--;
		}
		if (n.is_op) {
			if ((rc = bc_op_is_unary(n.op.kind)
			              ? bc_tree_push_unary(t, id, &n.unary, ei)
			              : bc_tree_push_op(t, id, &n.op, ei))) {
				rc = at_node(ei, rc, i, id);
				goto cleanup;
			}
			left[nopen++] = n.nchildren;
			continue;
		}
		if ((rc = bc_tree_put_prim(t, id, &n.prim, ei))) {
			rc = at_node(ei, rc, i, id);
			goto cleanup;
		}
		while (nopen && left[nopen - 1] == 0) {
			nopen--;
			if ((rc = bc_tree_pop_op(t, ei))) {
				goto cleanup;
			}
		}
	}
	if ((rc = bc_tree_end(t, ei)) == 0 && nnames) {
		r->pos = names_at;
		rc = put_names_in(r, t, nnames, ids, nids, ei);
	}
cleanup:
	bc_free(ids);
	bc_free(left);
	bc_free(opener);
	return rc;
}

static int decode(const uint8_t *buf, size_t len, bool scene, struct bc_tree *t,
                  struct bc_camera *cam, bool *has_camera,
                  struct bc_errinfo *ei)
{
	struct bc_rd r = bc_rd_init(buf, buf ? len : 0);
	struct bc_camera c;
	bool with_cam = false, names = false;
	int rc;
	bc_camera_default(&c);
	if (cam) {
		*cam = c;
	}
	if (has_camera) {
		*has_camera = false;
	}
	if (ei) {
		ei->code = 0;
		ei->msg[0] = '\0';
	}
	bc_tree_begin(t);
	if (scene) {
		uint8_t flags;
		if (r.len < 1) {
			return bc_errinfo_set(ei, BC_EPROTO_TRUNCATED,
			                      "scene: empty (no flags byte)");
		}
		flags = bc_rd_u8(&r);
		if (flags & ~(BC_SCENE_FLAG_CAMERA | BC_SCENE_FLAG_NAMES)) {
			return bc_errinfo_set(
			    ei, BC_EPROTO_FLAGS,
			    "scene: reserved flag bits 0x%02x "
			    "set",
			    flags &
			        ~(BC_SCENE_FLAG_CAMERA | BC_SCENE_FLAG_NAMES));
		}
		names = (flags & BC_SCENE_FLAG_NAMES) != 0;
		with_cam = (flags & BC_SCENE_FLAG_CAMERA) != 0;
		if (with_cam) {
			float f[BC_SCENE_CAMERA_BYTES / 4u];
			if (bc_rd_left(&r) < sizeof(f)) {
				return bc_errinfo_set(
				    ei, BC_EPROTO_TRUNCATED,
				    "camera: needs %zu bytes, %zu left",
				    sizeof(f), bc_rd_left(&r));
			}
			for (int i = 0; i < (int)(sizeof(f) / 4u); i++) {
				f[i] = bc_rd_f32(&r);
				if (!isfinite(f[i])) {
					return bc_errinfo_set(
					    ei, BC_ENONFINITE,
					    "camera: float %d is not "
					    "finite",
					    i);
				}
			}
			memcpy(c.eye, f, sizeof(c.eye));
			memcpy(c.target, f + 3, sizeof(c.target));
			memcpy(c.up, f + 6, sizeof(c.up));
			c.fov_y_deg = f[9];
			if ((rc = bc_camera_validate(&c, ei))) {
				return rc;
			}
		}
	}
	if ((rc = decode_tree(&r, names, t, ei))) {
		/* Leave the tree empty, not half built. */
		bc_tree_begin(t);
		return rc;
	}
	if (cam) {
		*cam = c;
	}
	if (has_camera) {
		*has_camera = with_cam;
	}
	return 0;
}

int bc_scene_decode(const uint8_t *buf, size_t len, struct bc_tree *t,
                    struct bc_camera *cam, bool *has_camera,
                    struct bc_errinfo *ei)
{
	return decode(buf, len, true, t, cam, has_camera, ei);
}

int bc_tree_decode(const uint8_t *buf, size_t len, struct bc_tree *t,
                   struct bc_errinfo *ei)
{
	return decode(buf, len, false, t, NULL, NULL, ei);
}

uint32_t bc_scene_head_count(const uint8_t *head, size_t len, size_t total)
{
	size_t at = 1u;
	uint32_t n;
	if (len > total) {
		len = total;
	}
	if (len && (head[0] & BC_SCENE_FLAG_CAMERA)) {
		at += BC_SCENE_CAMERA_BYTES;
	}
	if (len < at + 4u) {
		return 0;
	}
	n = bc_get_le32(head + at);
	return n <= BC_TREE_MAX_NODES &&
	               n <= (total - at - 4u) / BC_SCENE_NODE_MIN_BYTES
	           ? n
	           : 0u;
}
