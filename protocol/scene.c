/*
 * The binary scene encoding as PROTOCOL.md documents it: a structural
 * scanner and writers. The encoding belongs to blobtree/, whose decoder
 * builds trees from it and checks what the bytes mean; this file only
 * checks the shape the document promises (tags, counts, nesting, finite
 * floats, exact length), so that clients, tests and the benchmark can build
 * and check scene bytes without linking blobtree, and so that the document's
 * description is executable.
 *
 * The scanner is iterative with a fixed stack of BC_PROTO_SCENE_MAX_DEPTH
 * open operators: no recursion, no allocation, one pass.
 */
#include "blobcast/alloc.h"
#include "wire.h"

#include <stdarg.h>
#include <stdio.h>

#define NODE_MIN 5u /* tag and id: the least any node takes */
#define OP_MIN 17u  /* tag, id, blend, range, child_count */
#define OP_TAG 0x80u

struct scan {
	struct bc_rd c;
	struct bc_errinfo *ei;
	uint32_t node;     /* index of the node being read */
	uint32_t features; /* BC_PROTO_FEATURE_KINDS when it uses them */
	bool (*visit)(void *ud, uint32_t id); /* bc_proto_scene_scan_ids */
	void *ud;
};

static int sfail(struct scan *s, int code, const char *fmt,
                 ...) BC__ERRINFO_PRINTF;

static int sfail(struct scan *s, int code, const char *fmt, ...)
{
	char reason[160];
	va_list ap;
	if (!s->ei) {
		return code;
	}
	va_start(ap, fmt);
	vsnprintf(reason, sizeof(reason), fmt, ap);
	va_end(ap);
	return bc_errinfo_set(s->ei, code, "scene: node %u: %s (byte %zu)",
	                      s->node, reason, s->c.pos);
}

static int s_need(struct scan *s, size_t n, const char *what)
{
	if (n > bc_rd_left(&s->c)) {
		return sfail(s, BC_EPROTO_TRUNCATED,
		             "%s needs %zu bytes, %zu left", what, n,
		             bc_rd_left(&s->c));
	}
	return 0;
}

static int s_u8(struct scan *s, const char *what, uint8_t *v)
{
	*v = 0;
	int rc = s_need(s, 1, what);
	if (rc == 0) {
		*v = bc_rd_u8(&s->c);
	}
	return rc;
}

static int s_u32(struct scan *s, const char *what, uint32_t *v)
{
	*v = 0;
	int rc = s_need(s, 4, what);
	if (rc == 0) {
		*v = bc_rd_u32(&s->c);
	}
	return rc;
}

/* A group of n floats: its length is checked as a whole first, then each
 * float must be finite (the order blobtree's decoder uses). */
static int s_floats(struct scan *s, unsigned n, const char *what, float *out)
{
	int rc = s_need(s, 4u * (size_t)n, what);
	for (unsigned i = 0; rc == 0 && i < n; i++) {
		uint32_t u = bc_rd_u32(&s->c);
		if (!bc__bits_finite(u)) {
			return sfail(s, BC_ENONFINITE, "%s[%u] is not finite",
			             what, i);
		}
		if (out) {
			out[i] = bc__bits_f32(u);
		}
	}
	return rc;
}

#define TRY(expr)                                                              \
	do {                                                                   \
		int rc_ = (expr);                                              \
		if (rc_ < 0) {                                                 \
			return rc_;                                            \
		}                                                              \
	} while (0)

/* Sharp operators (union, intersection, difference) have no blend. */
static bool op_is_sharp(unsigned kind)
{
	return kind >= 1 && kind <= 3;
}

static int scan_op(struct scan *s, uint8_t tag, uint32_t after,
                   uint32_t *children)
{
	unsigned kind = tag & ~OP_TAG;
	float br[2];
	if (kind == 0 || kind > BC_PROTO_OP_KIND_MAX) {
		return sfail(s, BC_EENUM, "operator tag 0x%02x is unknown",
		             (unsigned)tag);
	}
	if (kind >= BC_PROTO_OP_KIND_FIRST_UNARY) {
		s->features |= BC_PROTO_FEATURE_KINDS;
		/* A unary node: nfloats, its floats, and one child. blobtree
		 * requires exactly the kind's count. */
		uint8_t nfloats;
		TRY(s_u8(s, "nfloats", &nfloats));
		if (nfloats > BC_PROTO_MAX_UNARY_PARAMS) {
			return sfail(s, BC_EPROTO_COUNT,
			             "nfloats %u is over %u", (unsigned)nfloats,
			             BC_PROTO_MAX_UNARY_PARAMS);
		}
		TRY(s_floats(s, nfloats, "params", NULL));
		*children = 1;
		if (after < 1) {
			return sfail(s, BC_EPROTO_COUNT,
			             "a unary node needs its child after it");
		}
		return 0;
	}
	TRY(s_floats(s, 1, "blend", &br[0]));
	TRY(s_floats(s, 1, "range", &br[1]));
	TRY(s_u32(s, "child_count", children));
	/* Each child is at least one more node of the encoding. */
	if (*children < 2 || *children > after) {
		return sfail(s, BC_EPROTO_COUNT,
		             "child_count %u is outside 2..%u (the nodes that "
		             "follow)",
		             *children, after);
	}
	if (op_is_sharp(kind) && (br[0] != 0.0f || br[1] != 0.0f)) {
		return sfail(s, BC_ERANGE,
		             "a sharp operator has blend and range 0");
	}
	return 0;
}

static int scan_prim(struct scan *s, uint8_t tag)
{
	uint8_t has_color, nfloats;
	if (tag == 0 || tag > BC_PROTO_PRIM_KIND_MAX) {
		return sfail(s, BC_EENUM, "primitive tag 0x%02x is unknown",
		             (unsigned)tag);
	}
	if (tag > BC_PROTO_PRIM_KIND_MAX_FIRST) {
		s->features |= BC_PROTO_FEATURE_KINDS;
	}
	TRY(s_floats(s, 3, "translate", NULL));
	TRY(s_floats(s, 4, "rotate", NULL));
	TRY(s_u8(s, "has_color", &has_color));
	if (has_color > 1) {
		return sfail(s, BC_EPROTO_FLAGS, "has_color is %u, not 0 or 1",
		             (unsigned)has_color);
	}
	if (has_color) {
		TRY(s_floats(s, 3, "color", NULL));
	}
	TRY(s_u8(s, "nfloats", &nfloats));
	/* blobtree requires exactly the kind's count (docs/primitives.md),
	 * which is at most BC_PROTO_MAX_PRIM_PARAMS. */
	if (nfloats > BC_PROTO_MAX_PRIM_PARAMS) {
		return sfail(s, BC_EPROTO_COUNT, "nfloats %u is over %u",
		             (unsigned)nfloats, BC_PROTO_MAX_PRIM_PARAMS);
	}
	return s_floats(s, nfloats, "params", NULL);
}

/* Children still expected by each open operator, innermost last: on the
 * heap, grown as the nesting deepens (up to BC_PROTO_SCENE_MAX_DEPTH), so
 * a deep chain costs memory per level, never C stack. */
struct open_stack {
	uint32_t *v;
	uint32_t n, cap;
};

static int open_push(struct scan *s, struct open_stack *o, uint32_t children)
{
	if (o->n == o->cap) {
		uint32_t cap = o->cap ? o->cap * 2u : 64u;
		uint32_t *v;
		if (cap > BC_PROTO_SCENE_MAX_DEPTH) {
			cap = BC_PROTO_SCENE_MAX_DEPTH;
		}
		if (!(v = bc_realloc(o->v, (size_t)cap * sizeof(*v)))) {
			return sfail(s, BC_ENOMEM, "out of memory");
		}
		o->v = v;
		o->cap = cap;
	}
	o->v[o->n++] = children;
	return 0;
}

static int scan_nodes(struct scan *s, uint32_t count, struct open_stack *o,
                      struct bc_proto_scene_info *out)
{
	for (s->node = 0; s->node < count; s->node++) {
		if (s->node > 0 && o->n == 0) {
			return sfail(s, BC_EPROTO_COUNT,
			             "the root's subtree ended after %u of "
			             "node_count %u nodes",
			             s->node, count);
		}
		/* This node would be number o->n + 1 on its path. */
		if (o->n >= BC_PROTO_SCENE_MAX_DEPTH) {
			return sfail(s, BC_EDEPTH, "nested deeper than %u",
			             BC_PROTO_SCENE_MAX_DEPTH);
		}
		uint8_t tag;
		uint32_t id, children = 0;
		TRY(s_u8(s, "tag", &tag));
		TRY(s_u32(s, "id", &id));
		if (id == 0) {
			out->zero_ids++;
		}
		if (s->visit && !s->visit(s->ud, id)) {
			return sfail(s, BC_ENOMEM, "out of memory");
		}
		if (o->n) {
			o->v[o->n - 1]--;
		}
		if (tag & OP_TAG) {
			TRY(scan_op(s, tag, count - 1 - s->node, &children));
			TRY(open_push(s, o, children));
			out->ops++;
			continue;
		}
		TRY(scan_prim(s, tag));
		out->prims++;
		if (o->n + 1 > out->depth) {
			out->depth = o->n + 1;
		}
		/* The last child of an operator completes it, which may
		 * complete its parent, and so on up. */
		while (o->n && o->v[o->n - 1] == 0) {
			o->n--;
		}
	}
	if (o->n) {
		return sfail(s, BC_EPROTO_COUNT,
		             "%u children of an operator are missing after the "
		             "last node",
		             o->v[o->n - 1]);
	}
	return 0;
}

/* The names table (PROTOCOL.md 8, check 6): count, then (id, name) pairs
 * with strictly increasing ids. */
static int scan_names(struct scan *s, uint32_t nodes, uint32_t *count)
{
	uint32_t prev = 0;
	s->node = nodes;
	TRY(s_u32(s, "name_count", count));
	if (*count == 0 || *count > nodes) {
		return sfail(s, BC_EPROTO_COUNT,
		             "name_count %u is outside 1..%u (the node count)",
		             *count, nodes);
	}
	if (*count > bc_rd_left(&s->c) / BC_PROTO_SCENE_NAME_MIN) {
		return sfail(
		    s, BC_EPROTO_COUNT,
		    "name_count %u needs at least %llu bytes, %zu left", *count,
		    (unsigned long long)*count * BC_PROTO_SCENE_NAME_MIN,
		    bc_rd_left(&s->c));
	}
	for (uint32_t i = 0; i < *count; i++) {
		uint32_t id;
		uint16_t n;
		TRY(s_need(s, 6, "a name's id and length"));
		id = bc_rd_u32(&s->c);
		n = bc_rd_u16(&s->c);
		if (id == 0) {
			return sfail(s, BC_ERANGE, "name %u: id 0", i);
		}
		if (id <= prev) {
			return sfail(s, id == prev ? BC_EDUPID : BC_ERANGE,
			             "name %u: id %u after id %u (ids must "
			             "increase)",
			             i, id, prev);
		}
		prev = id;
		if (n == 0 || n > BC_PROTO_MAX_NAME) {
			return sfail(s, BC_EPROTO_LENGTH,
			             "name %u (node %u): length %u is outside "
			             "1..%u",
			             i, id, (unsigned)n, BC_PROTO_MAX_NAME);
		}
		TRY(s_need(s, n, "a name"));
		if (bc_utf8_check(s->c.p + s->c.pos, n) < n) {
			return sfail(
			    s, BC_ESTRING,
			    "name %u (node %u) breaks UTF-8 or holds NUL", i,
			    id);
		}
		s->c.pos += n;
	}
	return 0;
}

static int scan_scene(struct scan s, struct bc_proto_scene_info *info)
{
	struct bc_proto_scene_info out = {0};
	struct open_stack o = {0};
	int rc;
	if (info) {
		memset(info, 0, sizeof(*info));
	}
	uint8_t flags;
	TRY(s_u8(&s, "flags", &flags));
	if (flags & ~(BC_PROTO_SCENE_FLAG_CAMERA | BC_PROTO_SCENE_FLAG_NAMES)) {
		return sfail(&s, BC_EPROTO_FLAGS, "scene flags 0x%02x",
		             (unsigned)flags);
	}
	out.has_camera = flags & BC_PROTO_SCENE_FLAG_CAMERA;
	if (out.has_camera) {
		TRY(s_floats(&s, 10, "camera", NULL));
	}
	uint32_t count;
	TRY(s_u32(&s, "node_count", &count));
	if (count == 0 || count > BC_PROTO_SCENE_MAX_NODES) {
		return sfail(&s, BC_EPROTO_COUNT,
		             "node_count %u is outside 1..%u", count,
		             BC_PROTO_SCENE_MAX_NODES);
	}
	if (count > bc_rd_left(&s.c) / NODE_MIN) {
		return sfail(
		    &s, BC_EPROTO_COUNT,
		    "node_count %u needs at least %llu bytes, %zu left", count,
		    (unsigned long long)count * NODE_MIN, bc_rd_left(&s.c));
	}
	rc = scan_nodes(&s, count, &o, &out);
	bc_free(o.v);
	if (rc) {
		return rc;
	}
	out.names_at = s.c.pos;
	if (flags & BC_PROTO_SCENE_FLAG_NAMES) {
		TRY(scan_names(&s, count, &out.names));
		s.features |= BC_PROTO_FEATURE_NAMES;
	}
	if (bc_rd_left(&s.c)) {
		return sfail(&s, BC_EPROTO_TRAILING, "%zu bytes after the %s",
		             bc_rd_left(&s.c),
		             out.names ? "names" : "last node");
	}
	out.nodes = count;
	out.features = s.features;
	if (info) {
		*info = out;
	}
	return 0;
}

int bc_proto_scene_scan(const uint8_t *bytes, size_t len,
                        struct bc_proto_scene_info *info, struct bc_errinfo *ei)
{
	return scan_scene((struct scan){.c = bc_rd_init(bytes, len), .ei = ei},
	                  info);
}

int bc_proto_scene_scan_ids(const uint8_t *bytes, size_t len,
                            bool (*visit)(void *ud, uint32_t id), void *ud,
                            struct bc_errinfo *ei)
{
	return scan_scene((struct scan){.c = bc_rd_init(bytes, len),
	                                .ei = ei,
	                                .visit = visit,
	                                .ud = ud},
	                  NULL);
}

/* ---- Writers ----------------------------------------------------------------
 */

/* Appends the k bytes w measured; b is unchanged on failure. */
static int commit(struct bc_proto_buf *b, const struct bc__w *w)
{
	int rc = bc__buf_reserve(b, w->n);
	if (rc < 0) {
		return rc;
	}
	memcpy(b->data + b->len, w->p, w->n);
	b->len += w->n;
	return 0;
}

int bc_proto_scene_begin(struct bc_proto_buf *b, const float *camera,
                         uint32_t node_count)
{
	uint8_t tmp[1 + 40 + 4];
	struct bc__w w = {.p = tmp, .cap = sizeof(tmp)};
	bc__put_u8(&w, camera ? 1u : 0u);
	for (int i = 0; camera && i < 10; i++) {
		bc__put_f32(&w, camera[i]);
	}
	bc__put_u32(&w, node_count);
	return commit(b, &w);
}

int bc_proto_scene_names(struct bc_proto_buf *b, size_t scene_at,
                         uint32_t count)
{
	uint8_t tmp[4];
	struct bc__w w = {.p = tmp, .cap = sizeof(tmp)};
	int rc;
	if (scene_at >= b->len) {
		return BC_EINVAL;
	}
	bc__put_u32(&w, count);
	if ((rc = commit(b, &w)) == 0) {
		b->data[scene_at] |= BC_PROTO_SCENE_FLAG_NAMES;
	}
	return rc;
}

int bc_proto_scene_name(struct bc_proto_buf *b, uint32_t id, const char *name,
                        size_t len)
{
	uint8_t tmp[4 + 2 + BC_PROTO_MAX_NAME];
	struct bc__w w = {.p = tmp, .cap = sizeof(tmp)};
	if (len > BC_PROTO_MAX_NAME) {
		return BC_ELIMIT;
	}
	bc__put_u32(&w, id);
	bc__put_u16(&w, (uint16_t)len);
	bc__put_raw(&w, name, len);
	return commit(b, &w);
}

size_t bc_proto_scene_strip_names(uint8_t *bytes, size_t len)
{
	struct bc_proto_scene_info info;
	if (len == 0 || !(bytes[0] & BC_PROTO_SCENE_FLAG_NAMES) ||
	    bc_proto_scene_scan(bytes, len, &info, NULL)) {
		return len;
	}
	bytes[0] &= (uint8_t)~BC_PROTO_SCENE_FLAG_NAMES;
	return info.names_at;
}

int bc_proto_scene_prim(struct bc_proto_buf *b, uint8_t kind, uint32_t id,
                        const float translate[3], const float rotate[4],
                        const float *color, uint8_t nparams,
                        const float *params)
{
	uint8_t tmp[1 + 4 + 12 + 16 + 1 + 12 + 1 + 4 * 255];
	struct bc__w w = {.p = tmp, .cap = sizeof(tmp)};
	bc__put_u8(&w, kind);
	bc__put_u32(&w, id);
	for (int i = 0; i < 3; i++) {
		bc__put_f32(&w, translate[i]);
	}
	for (int i = 0; i < 4; i++) {
		bc__put_f32(&w, rotate[i]);
	}
	bc__put_u8(&w, color ? 1u : 0u);
	for (int i = 0; color && i < 3; i++) {
		bc__put_f32(&w, color[i]);
	}
	bc__put_u8(&w, nparams);
	for (unsigned i = 0; i < nparams; i++) {
		bc__put_f32(&w, params[i]);
	}
	return commit(b, &w);
}

int bc_proto_scene_op(struct bc_proto_buf *b, uint8_t kind, uint32_t id,
                      float blend, float range, uint32_t child_count)
{
	uint8_t tmp[OP_MIN];
	struct bc__w w = {.p = tmp, .cap = sizeof(tmp)};
	bc__put_u8(&w, (uint8_t)(OP_TAG | kind));
	bc__put_u32(&w, id);
	bc__put_f32(&w, blend);
	bc__put_f32(&w, range);
	bc__put_u32(&w, child_count);
	return commit(b, &w);
}

int bc_proto_scene_unary(struct bc_proto_buf *b, uint8_t kind, uint32_t id,
                         uint8_t nparams, const float *params)
{
	uint8_t tmp[1 + 4 + 1 + 4 * BC_PROTO_MAX_UNARY_PARAMS];
	struct bc__w w = {.p = tmp, .cap = sizeof(tmp)};
	if (nparams > BC_PROTO_MAX_UNARY_PARAMS) {
		return BC_ELIMIT;
	}
	bc__put_u8(&w, (uint8_t)(OP_TAG | kind));
	bc__put_u32(&w, id);
	bc__put_u8(&w, nparams);
	for (uint8_t i = 0; i < nparams; i++) {
		bc__put_f32(&w, params[i]);
	}
	return commit(b, &w);
}
