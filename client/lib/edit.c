/*
 * Edits as people type them: `radius=0.4`, `translate=0.1,0,0`,
 * `blend=0.2` turned into the numbered fields of a SET operation, using the
 * kind of the node in the scene mirror to find which parameter a name means.
 * Also the replay of EDIT_APPLIED on the mirror, which maps fields back onto
 * a node the same way the server does.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/scene.h"
#include "client_impl.h"

/* A key a node of some kind accepts, and the field it sets. */
struct key {
	const char *name;
	uint8_t field;
	uint8_t count;
};

/* Fills keys[] with what a node accepts (prim or op), returns how many. */
static uint32_t node_keys(const struct bc_prim_data *p, bool is_op,
			  struct key *keys)
{
	const struct bc_prim_info *info;
	uint32_t n = 0;
	if (is_op) {
		keys[n++] = (struct key){"blend", BC_PROTO_FIELD_BLEND, 1};
		keys[n++] = (struct key){"range", BC_PROTO_FIELD_RANGE, 1};
		keys[n++] = (struct key){"kind", BC_PROTO_FIELD_OP_KIND, 1};
		return n;
	}
	keys[n++] = (struct key){"translate", BC_PROTO_FIELD_TRANSLATE, 3};
	keys[n++] = (struct key){"rotate", BC_PROTO_FIELD_ROTATE, 4};
	keys[n++] = (struct key){"color", BC_PROTO_FIELD_COLOR, 3};
	info = bc_prim_info(p->kind);
	for (uint32_t k = 0; info && k < info->nparams &&
			     k < BC_PROTO_MAX_PRIM_PARAMS;
	     k++) {
		keys[n++] = (struct key){info->params[k].name,
					 (uint8_t)(BC_PROTO_FIELD_PARAM0 + k),
					 info->params[k].count};
	}
	return n;
}

/* "translate rotate color radius" for error messages. */
static void key_list(const struct key *keys, uint32_t n, char *buf,
		     size_t cap)
{
	size_t used = 0;
	buf[0] = '\0';
	for (uint32_t i = 0; i < n && used < cap; i++) {
		int w = snprintf(buf + used, cap - used, "%s%s", i ? " " : "",
				 keys[i].name);
		if (w < 0) {
			break;
		}
		used += (size_t)w;
	}
}

/* Parses the comma-separated floats of value into v[0..want). */
static int parse_values(const char *key, const char *value, uint8_t want,
			float *v, struct bc_errinfo *ei)
{
	const char *s = value;
	uint8_t n = 0;
	for (;;) {
		char *end;
		float f;
		if (*s == '\0' || *s == ',' || *s == ' ' || *s == '\t') {
			return bc_errinfo_set(ei, BC_EPARSE,
					      "%s: \"%s\" is not a list of "
					      "numbers",
					      key, value);
		}
		errno = 0;
		f = strtof(s, &end);
		if (end == s || (*end != ',' && *end != '\0')) {
			return bc_errinfo_set(ei, BC_EPARSE,
					      "%s: \"%s\" is not a list of "
					      "numbers",
					      key, value);
		}
		if (!isfinite(f)) {
			return bc_errinfo_set(ei, BC_ENONFINITE,
					      "%s: values must be finite", key);
		}
		if (fabsf(f) > BC_PROTO_MAX_ABS) {
			return bc_errinfo_set(ei, BC_ERANGE,
					      "%s: %g is beyond +-%g", key,
					      (double)f,
					      (double)BC_PROTO_MAX_ABS);
		}
		if (n == want) {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "%s takes %u value%s, got more",
					      key, (unsigned)want,
					      want == 1 ? "" : "s");
		}
		v[n++] = f;
		if (*end == '\0') {
			break;
		}
		s = end + 1;
	}
	if (n != want) {
		return bc_errinfo_set(ei, BC_EINVAL,
				      "%s takes %u value%s, got %u", key,
				      (unsigned)want, want == 1 ? "" : "s",
				      (unsigned)n);
	}
	return 0;
}

/* kind=smooth_union or kind=4. */
static int parse_op_kind(const char *value, float *v, struct bc_errinfo *ei)
{
	enum bc_op op = bc_op_from_name(value);
	char *end;
	long k;
	if (op != BC_OP_INVALID) {
		*v = (float)op;
		return 0;
	}
	errno = 0;
	k = strtol(value, &end, 10);
	if (end != value && *end == '\0' && errno == 0 && k >= 1 &&
	    k < BC_OP_COUNT) {
		*v = (float)k;
		return 0;
	}
	return bc_errinfo_set(ei, BC_EINVAL,
			      "kind: \"%s\" is not an operator (union, "
			      "intersection, difference, smooth_union, "
			      "smooth_intersection, smooth_difference)",
			      value);
}

int bc_client_edit_parse(const struct bc_tree *scene, uint32_t node,
			 const char *const *kv, size_t n,
			 struct bc_proto_field *fields, uint8_t *nfields,
			 struct bc_errinfo *ei)
{
	struct key keys[3 + BC_PROTO_MAX_PRIM_PARAMS];
	struct bc_prim_data p;
	struct bc_op_data op;
	const char *what;
	uint32_t nkeys;
	uint64_t seen = 0;
	bool is_op;
	*nfields = 0;
	if (!scene || !bc_tree_get(scene, node, &p, &op)) {
		return bc_errinfo_set(ei, BC_ENONODE,
				      "no node with id %u in the scene", node);
	}
	is_op = op.kind != BC_OP_INVALID;
	what = is_op ? bc_op_name(op.kind) : NULL;
	if (!is_op) {
		const struct bc_prim_info *info = bc_prim_info(p.kind);
		what = info ? info->name : NULL;
	}
	what = what ? what : "node";
	nkeys = node_keys(&p, is_op, keys);
	if (n == 0) {
		char list[256];
		key_list(keys, nkeys, list, sizeof(list));
		return bc_errinfo_set(ei, BC_EINVAL,
				      "nothing to set on node %u (%s); keys: "
				      "%s",
				      node, what, list);
	}
	if (n > BC_CLIENT_MAX_EDIT_ARGS) {
		return bc_errinfo_set(ei, BC_ELIMIT,
				      "%zu key=value arguments, at most %u", n,
				      BC_CLIENT_MAX_EDIT_ARGS);
	}
	for (size_t i = 0; i < n; i++) {
		const char *eq = kv[i] ? strchr(kv[i], '=') : NULL;
		const struct key *k = NULL;
		struct bc_proto_field *f = &fields[*nfields];
		char name[64];
		size_t len;
		int rc;
		if (!eq || eq == kv[i]) {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "\"%.64s\" is not key=value",
					      kv[i] ? kv[i] : "(null)");
		}
		len = (size_t)(eq - kv[i]);
		if (len < sizeof(name)) {
			memcpy(name, kv[i], len);
			name[len] = '\0';
			for (uint32_t j = 0; j < nkeys; j++) {
				if (strcmp(keys[j].name, name) == 0) {
					k = &keys[j];
				}
			}
		}
		if (!k) {
			char list[256];
			key_list(keys, nkeys, list, sizeof(list));
			return bc_errinfo_set(ei, BC_EINVAL,
					      "node %u (%s) has no \"%.*s\"; "
					      "keys: %s",
					      node, what,
					      (int)(len < 64 ? len : 64), kv[i],
					      list);
		}
		if (seen & (UINT64_C(1) << k->field)) {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "%s given twice", k->name);
		}
		seen |= UINT64_C(1) << k->field;
		memset(f, 0, sizeof(*f));
		f->field = k->field;
		f->count = k->count;
		rc = k->field == BC_PROTO_FIELD_OP_KIND
			     ? parse_op_kind(eq + 1, &f->v[0], ei)
			     : parse_values(k->name, eq + 1, k->count, f->v,
					    ei);
		if (rc) {
			return rc;
		}
		(*nfields)++;
	}
	return 0;
}

/* ---- replay on the mirror ------------------------------------------------ */

/* Writes a SET operation's fields into the node's data, as the server does.
 * Field numbers and counts were checked by the decoder; whether they fit
 * this kind of node is checked here. */
static int set_fields(const struct bc_proto_edit_op *e, bool is_op,
		      struct bc_prim_data *p, struct bc_op_data *op,
		      struct bc_errinfo *ei)
{
	const struct bc_prim_info *info = is_op ? NULL : bc_prim_info(p->kind);
	for (uint32_t i = 0; i < e->nfields; i++) {
		const struct bc_proto_field *f = &e->fields[i];
		float *dst = NULL;
		uint32_t want = 0;
		if (!is_op && f->field == BC_PROTO_FIELD_TRANSLATE) {
			dst = p->translate;
			want = 3;
		} else if (!is_op && f->field == BC_PROTO_FIELD_ROTATE) {
			dst = p->rotate;
			want = 4;
		} else if (!is_op && f->field == BC_PROTO_FIELD_COLOR) {
			dst = p->color;
			want = 3;
			p->has_color = true;
		} else if (!is_op && info && f->field >= BC_PROTO_FIELD_PARAM0 &&
			   f->field < BC_PROTO_FIELD_PARAM0 + info->nparams) {
			const struct bc_param_desc *d =
				&info->params[f->field - BC_PROTO_FIELD_PARAM0];
			dst = p->params + d->offset;
			want = d->count;
		} else if (is_op && f->field == BC_PROTO_FIELD_BLEND) {
			dst = &op->blend;
			want = 1;
		} else if (is_op && f->field == BC_PROTO_FIELD_RANGE) {
			dst = &op->range;
			want = 1;
		} else if (is_op && f->field == BC_PROTO_FIELD_OP_KIND) {
			op->kind = (enum bc_op)(int)f->v[0];
			continue;
		}
		if (!dst || f->count != want) {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "node %u: field %u does not fit "
					      "it",
					      e->node, (unsigned)f->field);
		}
		memcpy(dst, f->v, want * sizeof(float));
	}
	return 0;
}

static uint32_t le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	       (uint32_t)p[3] << 24;
}

/* Whether a subtree's scene encoding (PROTOCOL.md section 8) has a node
 * with id 0. The server gives such nodes ids that EDIT_APPLIED does not
 * carry (it repeats the operation as sent), so a mirror cannot follow.
 * Anything that does not parse counts as yes: the mirror is then dropped,
 * which is always safe. */
static bool has_unnamed_node(const uint8_t *b, size_t len)
{
	size_t pos = 1;
	uint32_t n;
	if (len < 1) {
		return true;
	}
	if (b[0] & BC_SCENE_FLAG_CAMERA) {
		pos += 40;
	}
	if (pos + 4 > len) {
		return true;
	}
	n = le32(b + pos);
	pos += 4;
	for (uint32_t i = 0; i < n; i++) {
		uint8_t tag;
		if (len - pos < 5 || le32(b + pos + 1) == 0) {
			return true;
		}
		tag = b[pos];
		if (tag & BC_SCENE_TAG_OP) {
			/* tag, id, blend, range, child_count */
			pos += 17;
			continue;
		}
		/* tag, id, translate, rotate, has_color [color] nfloats
		 * params */
		pos += 33;
		if (pos >= len) {
			return true;
		}
		pos += 1u + (b[pos] ? 12u : 0u);
		if (pos >= len) {
			return true;
		}
		pos += 1u + 4u * (size_t)b[pos];
		if (pos > len) {
			return true;
		}
	}
	return false;
}

static int replay_op(struct bc_tree *t, const struct bc_proto_edit_op *e,
		     struct bc_errinfo *ei)
{
	struct bc_prim_data p;
	struct bc_op_data op;
	struct bc_tree *sub;
	int rc;
	switch (e->kind) {
	case BC_PROTO_EDIT_SET:
		if (!bc_tree_get(t, e->node, &p, &op)) {
			return bc_errinfo_set(ei, BC_ENONODE, "no node %u",
					      e->node);
		}
		if ((rc = set_fields(e, op.kind != BC_OP_INVALID, &p, &op,
				     ei))) {
			return rc;
		}
		return op.kind != BC_OP_INVALID
			       ? bc_tree_set_op(t, e->node, &op, ei)
			       : bc_tree_set_prim(t, e->node, &p, ei);
	case BC_PROTO_EDIT_REMOVE:
		return bc_tree_remove(t, e->node, ei);
	case BC_PROTO_EDIT_INSERT:
	case BC_PROTO_EDIT_REPLACE:
		if (has_unnamed_node(e->subtree.ptr, e->subtree.len)) {
			return bc_errinfo_set(ei, BC_ENOTSUP,
					      "node %u: a subtree with nodes "
					      "of id 0 (ids only the server "
					      "knows)",
					      e->node);
		}
		if (!(sub = bc_tree_create())) {
			return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		}
		rc = bc_scene_decode(e->subtree.ptr, e->subtree.len, sub, NULL,
				     NULL, ei);
		if (!rc) {
			rc = e->kind == BC_PROTO_EDIT_INSERT
				     ? bc_tree_insert(t, e->node, e->position,
						      sub, ei)
				     : bc_tree_replace(t, e->node, sub, ei);
		}
		bc_tree_destroy(sub);
		return rc;
	default:
		return bc_errinfo_set(ei, BC_EENUM, "operation kind %d",
				      (int)e->kind);
	}
}

int bc__client_replay(struct bc_tree *t, const struct bc_msg_edit_applied *ea,
		      struct bc_errinfo *ei)
{
	for (uint32_t i = 0; i < ea->nops; i++) {
		int rc = replay_op(t, &ea->ops[i], ei);
		if (rc) {
			return rc;
		}
	}
	return 0;
}
