/*
 * The node listing of `blobcast nodes`: every node of a scene in pre-order
 * with its id, type, parent, name and parameters, as aligned text for
 * people or as a JSON array for scripts. Parameter keys are those `blobcast
 * edit` takes (docs/client.md), so a line says how to change what it shows.
 */
#include "cmd_inspect.h"

#include <jansson.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/error.h"
#include "blobcast/scene.h"

/* Floats keep 9 significant digits: the fewest that always give the same
 * IEEE single back. */
#define FLOAT_DIGITS 9

/* Whether v printed with p significant digits reads back as v; *d is
 * what it reads back as a double. */
static bool round_trips(float v, int p, double *d)
{
	char buf[32];
	snprintf(buf, sizeof(buf), "%.*g", p, (double)v);
	*d = strtod(buf, NULL);
	return strtof(buf, NULL) == v;
}

/* The double nearest to the shortest decimal that gives v back as a float:
 * 0.3f prints as 0.3, not 0.300000012. A bisection over the digits (more
 * digits are never farther from v), so a listing of many floats costs a
 * few conversions each, not nine. */
static double shortest(float v)
{
	int lo = 1, hi = FLOAT_DIGITS;
	double d, best = (double)v;
	while (lo < hi) {
		int mid = lo + (hi - lo) / 2;
		if (round_trips(v, mid, &d)) {
			hi = mid;
			best = d;
		} else {
			lo = mid + 1;
		}
	}
	if (hi == FLOAT_DIGITS) {
		return (double)v;
	}
	return best;
}

static bool is_identity_rotation(const float q[4])
{
	return q[0] == 0.0f && q[1] == 0.0f && q[2] == 0.0f && q[3] == 1.0f;
}

static bool is_zero3(const float v[3])
{
	return v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f;
}

/* ---- text ---------------------------------------------------------------- */

/* Writes s into out (cap bytes) with control characters as \\xHH (C1
 * controls \\u00HH) and, with quote, in double quotes with '"' and '\\'
 * escaped. Output stops short rather than overflow. */
static const char *escape(const char *s, bool quote, char *out, size_t cap)
{
	const unsigned char *p = (const unsigned char *)s;
	size_t used = 0;
	if (cap < 3) {
		return cap ? (out[0] = '\0', out) : out;
	}
	if (quote) {
		out[used++] = '"';
	}
	for (; *p && used + 7 < cap; p++) {
		if (quote && (*p == '"' || *p == '\\')) {
			out[used++] = '\\';
			out[used++] = (char)*p;
		} else if (*p < 0x20u || *p == 0x7fu) {
			used += (size_t)snprintf(out + used, cap - used,
			                         "\\x%02x", *p);
		} else if (*p == 0xc2u && p[1] >= 0x80u && p[1] <= 0x9fu) {
			/* C1 controls (U+0080..U+009F) steer terminals too. */
			used += (size_t)snprintf(out + used, cap - used,
			                         "\\u%04x", p[1]);
			p++;
		} else {
			out[used++] = (char)*p;
		}
	}
	if (quote) {
		out[used++] = '"';
	}
	out[used] = '\0';
	return out;
}

const char *bc_cli_quote_name(const char *name, char *out, size_t cap)
{
	return escape(name, true, out, cap);
}

const char *bc_cli_printable(const char *text, char *out, size_t cap)
{
	return escape(text, false, out, cap);
}

static void put_floats(FILE *out, const char *key, const float *v, int n)
{
	fprintf(out, " %s=", key);
	for (int i = 0; i < n; i++) {
		fprintf(out, "%s%.*g", i ? "," : "", FLOAT_DIGITS,
		        shortest(v[i]));
	}
}

static void text_node(FILE *out, const struct bc_tree *t, uint32_t id)
{
	struct bc_prim_data p;
	struct bc_op_data op;
	uint32_t parent = bc_tree_parent(t, id);
	const char *name = bc_tree_name(t, id);
	char pbuf[16], quoted[BC_CLI_QUOTED_NAME];
	snprintf(pbuf, sizeof(pbuf), "%u", parent);
	bc_tree_get(t, id, &p, &op);
	if (p.kind != BC_PRIM_INVALID) {
		const struct bc_prim_info *info = bc_prim_info(p.kind);
		fprintf(out, "%-8u %-19s %-8s", id, info ? info->name : "?",
		        parent ? pbuf : "-");
		if (name) {
			fprintf(
			    out, " %s",
			    bc_cli_quote_name(name, quoted, sizeof(quoted)));
		}
		for (uint8_t k = 0; info && k < info->nparams; k++) {
			const struct bc_param_desc *d = &info->params[k];
			put_floats(out, d->name, &p.params[d->offset],
			           d->count);
		}
		if (!is_zero3(p.translate)) {
			put_floats(out, "translate", p.translate, 3);
		}
		if (!is_identity_rotation(p.rotate)) {
			put_floats(out, "rotate", p.rotate, 4);
		}
		if (p.has_color) {
			put_floats(out, "color", p.color, 3);
		}
	} else {
		const char *kind = bc_op_name(op.kind);
		fprintf(out, "%-8u %-19s %-8s", id, kind ? kind : "?",
		        parent ? pbuf : "-");
		if (name) {
			fprintf(
			    out, " %s",
			    bc_cli_quote_name(name, quoted, sizeof(quoted)));
		}
		fprintf(out, " children=%u", bc_tree_child_count(t, id));
		if (bc_op_is_smooth(op.kind)) {
			put_floats(out, "blend", &op.blend, 1);
			put_floats(out, "range", &op.range, 1);
		}
	}
	fputc('\n', out);
}

/* ---- JSON ---------------------------------------------------------------- */

static json_t *json_floats(const float *v, int n)
{
	json_t *a;
	if (n == 1) {
		return json_real(shortest(v[0]));
	}
	if (!(a = json_array())) {
		return NULL;
	}
	for (int i = 0; i < n; i++) {
		if (json_array_append_new(a, json_real(shortest(v[i])))) {
			json_decref(a);
			return NULL;
		}
	}
	return a;
}

/* The nodes of a tree in pre-order: ids[i] and end[i], the index after
 * node i's subtree, so that node i's children are ids[i + 1], then
 * ids[end[i + 1]], ... up to end[i]: every listing costs time linear in
 * the tree (the model's child k costs O(k), which made wide operators
 * quadratic). */
struct order {
	uint32_t *ids, *end;
	uint32_t n;
};

/* Returns node i's object, NULL when memory runs out. */
static json_t *json_node(const struct bc_tree *t, const struct order *ord,
                         uint32_t i)
{
	uint32_t id = ord->ids[i];
	struct bc_prim_data p;
	struct bc_op_data op;
	json_t *o = json_object();
	bool ok = o != NULL;
	const char *name = bc_tree_name(t, id);
	bc_tree_get(t, id, &p, &op);
	ok = ok && !json_object_set_new(o, "id", json_integer(id));
	if (p.kind != BC_PRIM_INVALID) {
		const struct bc_prim_info *info = bc_prim_info(p.kind);
		ok = ok && info &&
		     !json_object_set_new(o, "type", json_string(info->name)) &&
		     !json_object_set_new(o, "parent",
		                          json_integer(bc_tree_parent(t, id)));
		for (uint8_t k = 0; ok && k < info->nparams; k++) {
			const struct bc_param_desc *d = &info->params[k];
			ok = !json_object_set_new(
			    o, d->name,
			    json_floats(&p.params[d->offset], d->count));
		}
		ok = ok && !json_object_set_new(o, "translate",
		                                json_floats(p.translate, 3));
		ok = ok && !json_object_set_new(o, "rotate",
		                                json_floats(p.rotate, 4));
		if (ok && p.has_color) {
			ok = !json_object_set_new(o, "color",
			                          json_floats(p.color, 3));
		}
	} else {
		const char *kind = bc_op_name(op.kind);
		json_t *kids = json_array();
		ok = ok && kind && kids &&
		     !json_object_set_new(o, "type", json_string(kind)) &&
		     !json_object_set_new(o, "parent",
		                          json_integer(bc_tree_parent(t, id)));
		for (uint32_t k = i + 1; ok && k < ord->end[i];
		     k = ord->end[k]) {
			ok = !json_array_append_new(kids,
			                            json_integer(ord->ids[k]));
		}
		ok = ok && !json_object_set(o, "children", kids);
		json_decref(kids);
		if (ok && bc_op_is_smooth(op.kind)) {
			ok = !json_object_set_new(
			         o, "blend", json_real(shortest(op.blend))) &&
			     !json_object_set_new(
			         o, "range", json_real(shortest(op.range)));
		}
	}
	/* Only on named nodes: a listing without names reads as before. */
	if (ok && name) {
		ok = !json_object_set_new(o, "name", json_string(name));
	}
	if (!ok) {
		json_decref(o);
		return NULL;
	}
	return o;
}

/* ---- the walk --------------------------------------------------------------
 */

/* Fills o with t's nodes in pre-order (one walk). Returns 0, BC_ENOMEM or
 * the walk's error. */
static int order_init(struct order *o, const struct bc_tree *t)
{
	uint32_t n = bc_tree_node_count(t), depth = bc_tree_nesting(t);
	/* open[d]: the node open at depth d, its subtree not yet ended. */
	uint32_t *open = bc_calloc(depth ? depth : 1, sizeof(*open));
	uint32_t nopen = 0;
	struct bc_scene_walk w;
	struct bc_scene_node sn;
	int rc;
	memset(o, 0, sizeof(*o));
	o->ids = bc_calloc(n ? n : 1, sizeof(*o->ids));
	o->end = bc_calloc(n ? n : 1, sizeof(*o->end));
	if (!open || !o->ids || !o->end) {
		rc = BC_ENOMEM;
		goto out;
	}
	if (n == 0) {
		rc = 0;
		goto out;
	}
	if ((rc = bc_scene_walk_init(&w, t))) {
		goto out;
	}
	while (o->n < n && bc_scene_walk_next(&w, &sn)) {
		/* A node at depth d ends the subtrees open at d and below. */
		while (nopen > sn.depth) {
			o->end[open[--nopen]] = o->n;
		}
		if (sn.depth < depth) {
			open[nopen++] = o->n;
		}
		o->ids[o->n++] = sn.id;
	}
	bc_scene_walk_finish(&w);
	while (nopen > 0) {
		o->end[open[--nopen]] = o->n;
	}
out:
	bc_free(open);
	return rc;
}

static void order_finish(struct order *o)
{
	bc_free(o->ids);
	bc_free(o->end);
	memset(o, 0, sizeof(*o));
}

int bc_cli_print_nodes(FILE *out, const struct bc_tree *t, bool json)
{
	struct order o;
	int rc = order_init(&o, t);
	if (rc) {
		order_finish(&o);
		return rc;
	}
	if (json) {
		fputs("[", out);
	} else {
		fprintf(out, "%-8s %-19s %-8s %s\n", "id", "type", "parent",
		        "parameters");
	}
	for (uint32_t i = 0; i < o.n; i++) {
		if (json) {
			/* One compact object per line: easy to grep, and
			 * still one JSON document. */
			json_t *obj = json_node(t, &o, i);
			fputs(i == 0 ? "\n" : ",\n", out);
			if (!obj) {
				rc = BC_ENOMEM;
				goto out;
			}
			rc = json_dumpf(obj, out,
			                JSON_COMPACT | JSON_PRESERVE_ORDER |
			                    JSON_REAL_PRECISION(FLOAT_DIGITS));
			json_decref(obj);
			if (rc) {
				rc = BC_EIO;
				goto out;
			}
		} else {
			text_node(out, t, o.ids[i]);
		}
	}
	if (json) {
		fputs("\n]\n", out);
	}
	if (fflush(out) != 0 || ferror(out)) {
		rc = BC_EIO;
	}
out:
	order_finish(&o);
	return rc;
}
