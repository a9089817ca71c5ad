/*
 * Edits as people type them: `radius=0.4`, `translate=0.1,0,0`,
 * `kind=smooth_union` turned into the numbered fields of a SET operation,
 * using the kind of the node in a scene to find which parameter a name
 * means. The CLI, libblobcast and the viewer all parse through here.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/edit.h"

/* A key a node of some kind accepts, and the field it sets. */
struct key {
	const char *name;
	uint8_t field;
	uint8_t count;
};

/* Fills keys[0..cap) with what a node accepts (prim, op or unary node:
 * op's kind), returns how many: the named fields of proto_fields.h's
 * table that apply to the node, then the parameters its kind names. A
 * unary node's kind thus comes before the parameters it decides. */
static uint32_t node_keys(const struct bc_prim_data *p, bool is_op,
                          enum bc_op op, struct key *keys, uint32_t cap)
{
	unsigned on = !is_op               ? BC_PROTO_ON_PRIM
	              : bc_op_is_unary(op) ? BC_PROTO_ON_UNARY
	                                   : BC_PROTO_ON_OP;
	uint32_t n = 0;
#define NAMED(name, k, lo, hi, numbers, flags)                                 \
	if ((k) != NULL && (on & (flags)) && n < cap) {                        \
		keys[n++] = (struct key){(k), BC_PROTO_FIELD_##name, (hi)};    \
	}
	BC_PROTO_FIELDS(NAMED)
#undef NAMED
	if (on == BC_PROTO_ON_UNARY) {
		const struct bc_unary_info *u = bc_unary_info(op);
		if (op == BC_OP_REPEAT && n + 2 <= cap) {
			keys[n++] =
			    (struct key){"spacing", BC_PROTO_FIELD_PARAM0, 3};
			keys[n++] =
			    (struct key){"count", BC_PROTO_FIELD_PARAM0 + 1, 3};
		} else if (u && n < cap) {
			keys[n++] = (struct key){
			    u->param, BC_PROTO_FIELD_PARAM0, u->nparams};
		}
	} else if (on == BC_PROTO_ON_PRIM) {
		const struct bc_prim_info *info = bc_prim_info(p->kind);
		for (uint32_t k = 0; info && k < info->nparams &&
		                     k < BC_PROTO_MAX_PRIM_PARAMS && n < cap;
		     k++) {
			keys[n++] =
			    (struct key){info->params[k].name,
			                 (uint8_t)(BC_PROTO_FIELD_PARAM0 + k),
			                 info->params[k].count};
		}
	}
	return n;
}

/* "translate rotate color radius" for error messages. */
static void key_list(const struct key *keys, uint32_t n, char *buf, size_t cap)
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
			return bc_errinfo_set(
			    ei, BC_ERANGE, "%s: %g is beyond +-%g", key,
			    (double)f, (double)BC_PROTO_MAX_ABS);
		}
		if (n == want) {
			return bc_errinfo_set(
			    ei, BC_EINVAL, "%s takes %u value%s, got more", key,
			    (unsigned)want, want == 1 ? "" : "s");
		}
		v[n++] = f;
		if (*end == '\0') {
			break;
		}
		s = end + 1;
	}
	if (n != want) {
		return bc_errinfo_set(
		    ei, BC_EINVAL, "%s takes %u value%s, got %u", key,
		    (unsigned)want, want == 1 ? "" : "s", (unsigned)n);
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
	                      "smooth_intersection, smooth_difference) or a "
	                      "unary node (offset, onion, elongate, twist, "
	                      "bend, mirror, repeat, scale)",
	                      value);
}

/* kind=union on a smooth operator with neither blend nor range given: a
 * sharp operator has neither, so the SET says both go to 0 (the server
 * refuses a SET that would drop them silently). */
static int sharp_fill(const struct bc_op_data *op, bool is_op,
                      struct bc_proto_field *fields, uint8_t *nfields,
                      uint64_t seen)
{
	const uint64_t blend = UINT64_C(1) << BC_PROTO_FIELD_BLEND;
	const uint64_t range = UINT64_C(1) << BC_PROTO_FIELD_RANGE;
	bool to_sharp = false;
	if (!is_op || !bc_op_is_smooth(op->kind) || (seen & (blend | range))) {
		return 0;
	}
	for (uint8_t i = 0; i < *nfields; i++) {
		if (fields[i].field == BC_PROTO_FIELD_OP_KIND &&
		    !bc_op_is_smooth((enum bc_op)(int)fields[i].v[0])) {
			to_sharp = true;
		}
	}
	if (!to_sharp || *nfields + 2u > BC_PROTO_MAX_SET_FIELDS) {
		return 0;
	}
	fields[*nfields] =
	    (struct bc_proto_field){.field = BC_PROTO_FIELD_BLEND, .count = 1};
	fields[*nfields + 1] =
	    (struct bc_proto_field){.field = BC_PROTO_FIELD_RANGE, .count = 1};
	*nfields = (uint8_t)(*nfields + 2);
	return 0;
}

int bc_edit_parse_kv(const struct bc_tree *scene, uint32_t node,
                     const char *const *kv, size_t n,
                     struct bc_proto_field *fields, uint8_t *nfields,
                     struct bc_errinfo *ei)
{
	/* One key per field number at most. */
	struct key keys[BC_PROTO_MAX_SET_FIELDS];
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
	nkeys = node_keys(&p, is_op, op.kind, keys,
	                  (uint32_t)(sizeof(keys) / sizeof(keys[0])));
	if (n == 0) {
		char list[256];
		key_list(keys, nkeys, list, sizeof(list));
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "nothing to set on node %u (%s); keys: "
		                      "%s",
		                      node, what, list);
	}
	if (n > BC_EDIT_MAX_KV) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "%zu key=value arguments, at most %u", n,
		                      BC_EDIT_MAX_KV);
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
			return bc_errinfo_set(ei, BC_EINVAL, "%s given twice",
			                      k->name);
		}
		seen |= UINT64_C(1) << k->field;
		memset(f, 0, sizeof(*f));
		f->field = k->field;
		f->count = k->count;
		if (k->field == BC_PROTO_FIELD_OP_KIND) {
			rc = parse_op_kind(eq + 1, &f->v[0], ei);
		} else if (is_op && op.kind == BC_OP_MIRROR) {
			/* axes=xz, or the mask as a number. */
			uint32_t mask = bc_mirror_axes_parse(eq + 1);
			f->v[0] = (float)mask;
			rc = mask ? 0
			          : parse_values(k->name, eq + 1, 1, f->v, ei);
		} else {
			rc = parse_values(k->name, eq + 1, k->count, f->v, ei);
		}
		if (rc) {
			return rc;
		}
		(*nfields)++;
	}
	return sharp_fill(&op, is_op, fields, nfields, seen);
}
