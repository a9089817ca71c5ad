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
#include "wire.h"

#include <stdarg.h>
#include <stdio.h>

#define PRIM_MIN 35u /* tag, id, translate, rotate, has_color=0, nfloats=0 */
#define OP_MIN 17u   /* tag, id, blend, range, child_count */
#define OP_TAG 0x80u

struct scan {
	struct bc__cur c;
	struct bc_errinfo *ei;
	uint32_t node; /* index of the node being read */
};

static int sfail(struct scan *s, int code, const char *fmt, ...)
	BC__ERRINFO_PRINTF;

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

static int s_u8(struct scan *s, uint8_t *v)
{
	if (!bc__get_u8(&s->c, v)) {
		return sfail(s, BC_EPROTO_TRUNCATED, "bytes end inside it");
	}
	return 0;
}

static int s_u32(struct scan *s, uint32_t *v)
{
	if (!bc__get_u32(&s->c, v)) {
		return sfail(s, BC_EPROTO_TRUNCATED, "bytes end inside it");
	}
	return 0;
}

static int s_floats(struct scan *s, unsigned n, const char *what)
{
	for (unsigned i = 0; i < n; i++) {
		uint32_t u;
		int rc = s_u32(s, &u);
		if (rc < 0) {
			return rc;
		}
		if (!bc__bits_finite(u)) {
			return sfail(s, BC_ENONFINITE,
				     "%s[%u] is not finite", what, i);
		}
	}
	return 0;
}

#define TRY(expr)                                                              \
	do {                                                                   \
		int rc_ = (expr);                                              \
		if (rc_ < 0) {                                                 \
			return rc_;                                            \
		}                                                              \
	} while (0)

int bc_proto_scene_scan(const uint8_t *bytes, size_t len,
			struct bc_proto_scene_info *info, struct bc_errinfo *ei)
{
	struct scan s = {.c = {.buf = bytes, .len = len}, .ei = ei};
	struct bc_proto_scene_info out = {0};
	/* Children still expected by each open operator, innermost last. */
	uint32_t open[BC_PROTO_SCENE_MAX_DEPTH];
	uint32_t depth = 0;
	if (info) {
		memset(info, 0, sizeof(*info));
	}
	uint8_t flags;
	TRY(s_u8(&s, &flags));
	if (flags & ~1u) {
		return sfail(&s, BC_EPROTO_FLAGS, "scene flags 0x%02x",
			     (unsigned)flags);
	}
	out.has_camera = flags & 1u;
	if (out.has_camera) {
		TRY(s_floats(&s, 10, "camera"));
	}
	uint32_t count;
	TRY(s_u32(&s, &count));
	if (count == 0 || count > BC_PROTO_SCENE_MAX_NODES) {
		return sfail(&s, BC_EPROTO_COUNT,
			     "node_count %u is outside 1..%u", count,
			     BC_PROTO_SCENE_MAX_NODES);
	}
	if ((uint64_t)count * OP_MIN > bc__cur_left(&s.c)) {
		return sfail(&s, BC_EPROTO_COUNT,
			     "node_count %u needs at least %llu bytes, %zu left",
			     count, (unsigned long long)count * OP_MIN,
			     bc__cur_left(&s.c));
	}
	/* Child slots still to fill, the root's included. Each needs at
	 * least one node, which is what makes a lying child_count fail as
	 * soon as it is read. */
	uint64_t slots = 1;
	for (s.node = 0; s.node < count; s.node++) {
		if (slots == 0) {
			return sfail(&s, BC_EPROTO_COUNT,
				     "the tree ended after %u of node_count %u "
				     "nodes",
				     s.node, count);
		}
		uint32_t left = count - s.node - 1; /* nodes after this one */
		uint8_t tag;
		uint32_t id;
		TRY(s_u8(&s, &tag));
		bool is_op = (tag & OP_TAG) != 0;
		unsigned kind = tag & ~OP_TAG;
		if (is_op ? (kind == 0 || kind > BC_PROTO_OP_KIND_MAX)
			  : (kind == 0 || kind > BC_PROTO_PRIM_KIND_MAX)) {
			return sfail(&s, BC_EENUM, "tag 0x%02x is unknown",
				     (unsigned)tag);
		}
		if (is_op && depth == BC_PROTO_SCENE_MAX_DEPTH) {
			return sfail(&s, BC_EDEPTH,
				     "operator nested deeper than %u",
				     BC_PROTO_SCENE_MAX_DEPTH);
		}
		TRY(s_u32(&s, &id));
		slots--;
		if (is_op) {
			uint32_t children;
			TRY(s_floats(&s, 2, "blend/range"));
			TRY(s_u32(&s, &children));
			if (children < 2 || slots + children > left) {
				return sfail(&s, BC_EPROTO_COUNT,
					     "child_count %u (at least 2, and "
					     "%llu open slots in %u nodes left)",
					     children,
					     (unsigned long long)(slots + children),
					     left);
			}
			slots += children;
			open[depth++] = children;
			out.ops++;
			if (depth > out.depth) {
				out.depth = depth;
			}
			continue;
		}
		uint8_t has_color, nfloats;
		TRY(s_floats(&s, 3, "translate"));
		TRY(s_floats(&s, 4, "rotate"));
		TRY(s_u8(&s, &has_color));
		if (has_color > 1) {
			return sfail(&s, BC_EENUM, "has_color is %u",
				     (unsigned)has_color);
		}
		if (has_color) {
			TRY(s_floats(&s, 3, "color"));
		}
		TRY(s_u8(&s, &nfloats));
		if (nfloats > BC_PROTO_MAX_PRIM_PARAMS) {
			return sfail(&s, BC_EPROTO_COUNT,
				     "nfloats %u is over %u", (unsigned)nfloats,
				     BC_PROTO_MAX_PRIM_PARAMS);
		}
		if ((size_t)nfloats * 4u > bc__cur_left(&s.c)) {
			return sfail(&s, BC_EPROTO_COUNT,
				     "nfloats %u needs %u bytes, %zu left",
				     (unsigned)nfloats, 4u * nfloats,
				     bc__cur_left(&s.c));
		}
		TRY(s_floats(&s, nfloats, "params"));
		out.prims++;
		/* A primitive completes its parent, which may complete its
		 * own parent, and so on up. */
		while (depth > 0 && --open[depth - 1] == 0) {
			depth--;
		}
	}
	if (bc__cur_left(&s.c)) {
		return sfail(&s, BC_EPROTO_TRAILING,
			     "%zu bytes after the last node",
			     bc__cur_left(&s.c));
	}
	out.nodes = count;
	if (info) {
		*info = out;
	}
	return 0;
}

/* ---- Writers ---------------------------------------------------------------- */

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
