/*
 * Scene files: the version-1 JSON format (docs/scene-format.md), read with
 * jansson and written by a streaming writer, plus atomic saving and the
 * built-in default scene.
 *
 * Reading is strict so that typos are caught rather than ignored: unknown
 * keys, wrong types, missing keys, non-finite numbers and nesting over
 * BC_SCENE_JSON_MAX_DEPTH (what jansson's parser can hold) are errors, and
 * every message starts with the JSON path of the offending value
 * ("root.children[2].half_extents[1]: ..."). A first walk over the document
 * only gathers the ids the file names, so that nodes without an id can be given
 * ids no later node claims; the second walk feeds the builder, which validates
 * every parameter.
 *
 * Writing does not go through jansson objects: a 10^6-node scene would
 * need about a gigabyte of them just to print a few hundred megabytes, and
 * jansson's pretty printer puts every number of a vector on its own line.
 * The writer emits one primitive per line; the only strings it writes are
 * key and type names from our own tables (plain ASCII identifiers), so no
 * escaping is involved. Floats are written with the fewest digits that
 * read back to the same bits (at most 9, "%.9g").
 */
#include "blobcast/scene.h"
#include "file_impl.h"

#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <jansson.h>

#include "blobcast/alloc.h"
#include "blobcast/io.h"
#include "blobcast/num.h"
#include "blobcast/buf.h"

#if defined(__GNUC__)
#define JSON_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define JSON_PRINTF(a, b)
#endif

/* Capacity of an error reason (struct bc_errinfo's message). */
#define MSG_CAP sizeof(((struct bc_errinfo *)NULL)->msg)

/* ---- jansson set-up ------------------------------------------------------ */

static pthread_once_t alloc_once = PTHREAD_ONCE_INIT;

/* Set when an allocation made for jansson fails. jansson does not report
 * running out of memory reliably (a failed buffer reads as a syntax error,
 * a failed object insertion as an empty message), so the parser asks this
 * flag instead. Per thread: parses on other threads do not disturb it. */
static _Thread_local bool jansson_oom;

/*
 * A scene's document lives in an arena while it is read: jansson makes
 * some twenty small objects of every node (the object, its keys, each
 * number), and a million spheres' 25 million malloc calls, their headers
 * and the free of each at the end took most of reading a 166 MB scene and
 * a GiB and a half. The arena hands out the thread's allocations from big
 * blocks and frees them all at once; jansson's own frees while it is
 * active (its buffers growing) are left to that. The document never
 * leaves the thread that parses it (bc_scene_parse_json).
 */
#define JARENA_BLOCK (4u << 20)
#define JARENA_ALIGN 16u

struct jblock {
	struct jblock *next;
	size_t used, cap;
	_Alignas(JARENA_ALIGN) unsigned char data[];
};

struct jarena {
	struct jblock *blocks; /* the one in use first */
};

static _Thread_local struct jarena *jarena;

static void *jarena_alloc(struct jarena *a, size_t size)
{
	struct jblock *b = a->blocks;
	size = (size + JARENA_ALIGN - 1u) & ~(size_t)(JARENA_ALIGN - 1u);
	if (size > JARENA_BLOCK / 4u) {
		/* A big request (a long array's items) gets a block of its
		 * own, behind the one in use. */
		struct jblock *own = bc_malloc(sizeof(*own) + size);
		if (!own) {
			return NULL;
		}
		own->used = own->cap = size;
		if (b) {
			own->next = b->next;
			b->next = own;
		} else {
			own->next = NULL;
			a->blocks = own;
		}
		return own->data;
	}
	if (!b || b->cap - b->used < size) {
		if (!(b = bc_malloc(sizeof(*b) + JARENA_BLOCK))) {
			return NULL;
		}
		b->next = a->blocks;
		b->used = 0;
		b->cap = JARENA_BLOCK;
		a->blocks = b;
	}
	b->used += size;
	return b->data + b->used - size;
}

static void jarena_release(struct jarena *a)
{
	while (a->blocks) {
		struct jblock *next = a->blocks->next;
		bc_free(a->blocks);
		a->blocks = next;
	}
}

static void *jansson_malloc(size_t size)
{
	void *p = jarena ? jarena_alloc(jarena, size) : bc_malloc(size);
	if (!p) {
		jansson_oom = true;
	}
	return p;
}

static void jansson_free(void *p)
{
	if (!jarena) {
		bc_free(p);
	}
}

/* jansson allocates through our hooks, so the allocation-failure tests
 * reach its failure paths too. Outside an arena they are bc_malloc and
 * bc_free, which is free(): objects jansson made before this (or for
 * other callers) are released correctly either way. */
static void route_jansson_alloc(void)
{
	json_set_alloc_funcs(jansson_malloc, jansson_free);
}

/* ---- reading: context and errors ---------------------------------------- */

/* Fresh ids for nodes without one: the smallest ids the file does not name
 * anywhere, so an explicit id later in the file never collides with one
 * handed out earlier. */
struct fresh {
	uint32_t *ids; /* explicit ids, sorted */
	uint32_t n, cap, p;
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

struct jctx {
	struct bc_tree *t;
	struct bc_errinfo *ei;
	struct fresh fr;
	uint32_t nodes;
	/* idx[d] is the child index of the node at depth d (d >= 1) on the
	 * path from the root to the node being read. */
	uint32_t idx[BC_SCENE_JSON_MAX_DEPTH + 1];
	uint32_t depth;
	bool in_tree; /* paths start at "root", else at a top-level key */
};

/* Copies s for an error message: at most 40 characters, anything not
 * printable ASCII shown as '?'. */
static void quote_untrusted(char *out, size_t cap, const char *s)
{
	size_t i = 0;
	for (; s[i] && i + 4 < cap && i < 40; i++) {
		unsigned char ch = (unsigned char)s[i];
		out[i] = (ch >= 0x20 && ch < 0x7f) ? (char)ch : '?';
	}
	if (s[i]) {
		out[i++] = '.';
		out[i++] = '.';
		out[i++] = '.';
	}
	out[i] = '\0';
}

/*
 * Records code with "PATH: reason" where PATH is the current node's path,
 * then .key and [elem] when given (elem < 0: none). A path too long for the
 * message keeps its end, where the offending value is.
 */
static int jfail(struct jctx *c, int code, const char *key, long elem,
                 const char *fmt, ...) JSON_PRINTF(5, 6);

static int jfail(struct jctx *c, int code, const char *key, long elem,
                 const char *fmt, ...)
{
	/* Only the path's end fits a message: at most PATH_LEVELS levels are
	 * printed, after "root...". */
	enum { PATH_LEVELS = 24 };
	char path[24 * (PATH_LEVELS + 4)];
	char reason[MSG_CAP];
	size_t plen = 0, rlen, budget;
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(reason, sizeof(reason), fmt, ap);
	va_end(ap);
	path[0] = '\0';
	if (!c->in_tree && key) {
		/* A top-level key: the path is the key itself. */
		plen = bc_str_appendf(path, sizeof(path), plen, "%s", key);
		key = NULL;
	} else {
		uint32_t d = 1;
		plen = bc_str_appendf(path, sizeof(path), plen, "root");
		if (c->depth > PATH_LEVELS) {
			d = c->depth - PATH_LEVELS + 1;
			plen = bc_str_appendf(path, sizeof(path), plen, "...");
		}
		for (; d <= c->depth; d++) {
			plen = bc_str_appendf(path, sizeof(path), plen,
			                      ".children[%u]", c->idx[d]);
		}
	}
	if (key) {
		plen = bc_str_appendf(path, sizeof(path), plen, ".%s", key);
	}
	if (elem >= 0) {
		plen = bc_str_appendf(path, sizeof(path), plen, "[%ld]", elem);
	}
	rlen = strlen(reason);
	budget = rlen + 3 < sizeof(reason) ? sizeof(reason) - 3 - rlen : 0;
	if (plen > budget && budget > 16) {
		/* "root..." then the tail of the path. */
		size_t keep = budget - 7;
		return bc_errinfo_set(c->ei, code, "root...%s: %s",
		                      path + plen - keep, reason);
	}
	return bc_errinfo_set(c->ei, code, "%s: %s", path, reason);
}

static const char *json_kind(const json_t *v)
{
	switch (json_typeof(v)) {
	case JSON_OBJECT:
		return "object";
	case JSON_ARRAY:
		return "array";
	case JSON_STRING:
		return "string";
	case JSON_INTEGER:
		return "integer";
	case JSON_REAL:
		return "real number";
	case JSON_TRUE:
		return "true";
	case JSON_FALSE:
		return "false";
	default:
		return "null";
	}
}

/* Reads a number member into a finite float. */
static int get_float(struct jctx *c, const json_t *v, const char *key,
                     long elem, float *out)
{
	double d;
	if (!json_is_number(v)) {
		return jfail(c, BC_EPARSE, key, elem,
		             "expected a number, got %s", json_kind(v));
	}
	d = json_number_value(v);
	/* Checked before converting: a double beyond the float range has no
	 * float value. */
	if (!isfinite(d) || fabs(d) > (double)FLT_MAX) {
		return jfail(c, BC_ENONFINITE, key, elem,
		             "%g is not a finite 32-bit float", d);
	}
	*out = (float)d;
	if (!isfinite(*out)) {
		return jfail(c, BC_ENONFINITE, key, elem,
		             "%g is not a finite 32-bit float", d);
	}
	return 0;
}

/* Reads a member holding n numbers: a plain number when n == 1, an array of
 * exactly n numbers otherwise. */
static int get_floats(struct jctx *c, const json_t *v, const char *key,
                      uint32_t n, float *out)
{
	int rc;
	if (n == 1) {
		return get_float(c, v, key, -1, out);
	}
	if (!json_is_array(v)) {
		return jfail(c, BC_EPARSE, key, -1,
		             "expected an array of %u numbers, got %s", n,
		             json_kind(v));
	}
	if (json_array_size(v) != n) {
		return jfail(c, BC_EPARSE, key, -1,
		             "expected an array of %u numbers, got %zu", n,
		             json_array_size(v));
	}
	for (uint32_t i = 0; i < n; i++) {
		if ((rc = get_float(c, json_array_get(v, i), key, (long)i,
		                    &out[i]))) {
			return rc;
		}
	}
	return 0;
}

static int get_id(struct jctx *c, const json_t *obj, uint32_t *id)
{
	const json_t *v = json_object_get(obj, "id");
	json_int_t x;
	if (!v) {
		*id = 0;
		return 0;
	}
	if (!json_is_integer(v)) {
		return jfail(c, BC_EPARSE, "id", -1,
		             "expected an integer, got %s", json_kind(v));
	}
	x = json_integer_value(v);
	if (x < 1 || x > (json_int_t)UINT32_MAX) {
		return jfail(c, BC_ERANGE, "id", -1,
		             "%lld is outside 1..4294967295", (long long)x);
	}
	*id = (uint32_t)x;
	return 0;
}

/* Rejects keys outside allowed[0..n); extra names a key that would be
 * allowed on a smooth operator, for a clearer message. */
static int check_keys(struct jctx *c, json_t *obj, const char *const *allowed,
                      size_t n, const char *what)
{
	const char *key;
	json_t *v;
	json_object_foreach(obj, key, v)
	{
		bool ok = false;
		char q[48];
		for (size_t i = 0; i < n && !ok; i++) {
			ok = strcmp(key, allowed[i]) == 0;
		}
		/* Every node may carry a name (set_name). */
		if (ok || strcmp(key, "name") == 0) {
			continue;
		}
		quote_untrusted(q, sizeof(q), key);
		if (strcmp(key, "blend") == 0 || strcmp(key, "range") == 0) {
			return jfail(c, BC_EPARSE, NULL, -1,
			             "\"%s\" is only for smooth operators, "
			             "not %s",
			             q, what);
		}
		return jfail(c, BC_EPARSE, NULL, -1,
		             "unknown key \"%s\" for %s", q, what);
	}
	return 0;
}

/* Adds the node path to an error the builder reported. */
static int builder_fail(struct jctx *c, int rc)
{
	char reason[MSG_CAP];
	if (!c->ei) {
		return rc;
	}
	memcpy(reason, c->ei->msg, sizeof(reason));
	reason[sizeof(reason) - 1] = '\0';
	return jfail(c, rc, NULL, -1, "%s", reason);
}

/* The node just added with id takes obj's "name", when it has one: a
 * string of 1..BC_TREE_NAME_MAX bytes (jansson has checked the UTF-8; a
 * \u0000 escape is refused here). */
static int set_name(struct jctx *c, const json_t *obj, uint32_t id)
{
	const json_t *v = json_object_get(obj, "name");
	size_t len;
	int rc;
	if (!v) {
		return 0;
	}
	if (!json_is_string(v)) {
		return jfail(c, BC_EPARSE, "name", -1,
		             "expected a string, got %s", json_kind(v));
	}
	len = json_string_length(v);
	if (len == 0) {
		return jfail(c, BC_ERANGE, "name", -1,
		             "a name is 1..%u bytes; leave the key out for "
		             "none",
		             BC_TREE_NAME_MAX);
	}
	if ((rc = bc_tree_set_name(c->t, id, json_string_value(v), len,
	                           c->ei))) {
		return builder_fail(c, rc);
	}
	return 0;
}

/* ---- reading: nodes ------------------------------------------------------ */

static int parse_node(struct jctx *c, json_t *obj);

static int parse_prim(struct jctx *c, json_t *obj, enum bc_prim kind)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	const char *allowed[5 + BC_PRIM_MAX_PARAMS];
	size_t nallowed = 0;
	struct bc_prim_data p;
	const json_t *v;
	uint32_t id;
	int rc;

	allowed[nallowed++] = "type";
	allowed[nallowed++] = "id";
	allowed[nallowed++] = "translate";
	allowed[nallowed++] = "rotate";
	allowed[nallowed++] = "color";
	for (uint32_t i = 0;
	     i < info->nparams && nallowed < 5 + BC_PRIM_MAX_PARAMS; i++) {
		allowed[nallowed++] = info->params[i].name;
	}
	if ((rc = check_keys(c, obj, allowed, nallowed, info->name))) {
		return rc;
	}
	bc_prim_data_init(&p, kind);
	for (uint32_t i = 0; i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		v = json_object_get(obj, d->name);
		if (!v) {
			if (d->flags & BC_PARAM_OPTIONAL) {
				continue;
			}
			return jfail(c, BC_EPARSE, NULL, -1,
			             "missing key \"%s\" (a %s needs it)",
			             d->name, info->name);
		}
		if ((uint32_t)d->offset + d->count > BC_PRIM_MAX_PARAMS) {
			return jfail(c, BC_EINVAL, d->name, -1,
			             "parameter layout out of bounds");
		}
		if ((rc = get_floats(c, v, d->name, d->count,
		                     p.params + d->offset))) {
			return rc;
		}
	}
	if ((v = json_object_get(obj, "translate")) &&
	    (rc = get_floats(c, v, "translate", 3, p.translate))) {
		return rc;
	}
	if ((v = json_object_get(obj, "rotate")) &&
	    (rc = get_floats(c, v, "rotate", 4, p.rotate))) {
		return rc;
	}
	if ((v = json_object_get(obj, "color"))) {
		if ((rc = get_floats(c, v, "color", 3, p.color))) {
			return rc;
		}
		p.has_color = true;
	}
	if ((rc = get_id(c, obj, &id))) {
		return rc;
	}
	id = id ? id : fresh_next(&c->fr);
	if ((rc = bc_tree_put_prim(c->t, id, &p, c->ei))) {
		return builder_fail(c, rc);
	}
	return set_name(c, obj, id);
}

static int parse_op(struct jctx *c, json_t *obj, enum bc_op kind)
{
	static const char *const allowed[] = {"type", "id", "children", "blend",
	                                      "range"};
	bool smooth = bc_op_is_smooth(kind);
	struct bc_op_data op = {kind, 0.0f, 0.0f};
	json_t *children, *v;
	uint32_t id;
	size_t n;
	int rc;

	if ((rc = check_keys(c, obj, allowed, smooth ? 5 : 3,
	                     bc_op_name(kind)))) {
		return rc;
	}
	if (smooth) {
		if (!(v = json_object_get(obj, "blend"))) {
			return jfail(c, BC_EPARSE, NULL, -1,
			             "missing key \"blend\" (a %s needs it)",
			             bc_op_name(kind));
		}
		if ((rc = get_float(c, v, "blend", -1, &op.blend))) {
			return rc;
		}
		if ((v = json_object_get(obj, "range"))) {
			if ((rc = get_float(c, v, "range", -1, &op.range))) {
				return rc;
			}
			/* The builder reads 0 as "default": an explicit 0
			 * is a mistake, not a request for the default. */
			if (!(op.range > 0.0f)) {
				return jfail(c, BC_ERANGE, "range", -1,
				             "%g must be positive",
				             (double)op.range);
			}
		}
	}
	children = json_object_get(obj, "children");
	if (!children) {
		return jfail(c, BC_EPARSE, NULL, -1,
		             "missing key \"children\" (a %s needs it)",
		             bc_op_name(kind));
	}
	if (!json_is_array(children)) {
		return jfail(c, BC_EPARSE, "children", -1,
		             "expected an array, got %s", json_kind(children));
	}
	n = json_array_size(children);
	if (n < 2) {
		return jfail(c, BC_EINVAL, "children", -1,
		             "an operator needs two or more children, got %zu",
		             n);
	}
	if ((rc = get_id(c, obj, &id))) {
		return rc;
	}
	id = id ? id : fresh_next(&c->fr);
	if ((rc = bc_tree_push_op(c->t, id, &op, c->ei))) {
		return builder_fail(c, rc);
	}
	if ((rc = set_name(c, obj, id))) {
		return rc;
	}
	c->depth++;
	for (size_t i = 0; i < n; i++) {
		c->idx[c->depth] = (uint32_t)i;
		if ((rc = parse_node(c, json_array_get(children, i)))) {
			return rc;
		}
	}
	c->depth--;
	if ((rc = bc_tree_pop_op(c->t, c->ei))) {
		return builder_fail(c, rc);
	}
	return 0;
}

/* A unary node: {"type": "offset", "id": 3, "amount": 0.1, "children":
 * [one node]}; every parameter key is required (docs/scene-format.md). */
static int parse_unary(struct jctx *c, json_t *obj, enum bc_op kind)
{
	const struct bc_unary_info *info = bc_unary_info(kind);
	bool repeat = kind == BC_OP_REPEAT;
	const char *allowed[] = {"type", "id", "children", info->param,
	                         "count"};
	struct bc_unary un;
	json_t *children, *v;
	uint32_t id;
	int rc;

	memset(&un, 0, sizeof(un));
	un.kind = kind;
	if ((rc = check_keys(c, obj, allowed, repeat ? 5 : 4, info->name))) {
		return rc;
	}
	if (!(v = json_object_get(obj, info->param))) {
		return jfail(c, BC_EPARSE, NULL, -1,
		             "missing key \"%s\" (a %s needs it)", info->param,
		             info->name);
	}
	if (kind == BC_OP_MIRROR) {
		uint32_t mask;
		if (!json_is_string(v)) {
			return jfail(c, BC_EPARSE, "axes", -1,
			             "expected a string such as \"xz\", got %s",
			             json_kind(v));
		}
		mask = bc_mirror_axes_parse(json_string_value(v));
		if (!mask) {
			return jfail(c, BC_ERANGE, "axes", -1,
			             "expected 1 to 3 distinct letters of x, "
			             "y, z");
		}
		un.u[0] = (float)mask;
	} else if ((rc = get_floats(c, v, info->param,
	                            repeat ? 3 : info->nparams, un.u))) {
		return rc;
	}
	if (repeat) {
		if (!(v = json_object_get(obj, "count"))) {
			return jfail(c, BC_EPARSE, NULL, -1,
			             "missing key \"count\" (a repeat needs "
			             "it)");
		}
		if ((rc = get_floats(c, v, "count", 3, un.u + 3))) {
			return rc;
		}
	}
	children = json_object_get(obj, "children");
	if (!children) {
		return jfail(c, BC_EPARSE, NULL, -1,
		             "missing key \"children\" (a %s needs it)",
		             info->name);
	}
	if (!json_is_array(children) || json_array_size(children) != 1) {
		return jfail(c, BC_EINVAL, "children", -1,
		             "a %s takes an array of exactly one child",
		             info->name);
	}
	if ((rc = get_id(c, obj, &id))) {
		return rc;
	}
	id = id ? id : fresh_next(&c->fr);
	if ((rc = bc_tree_push_unary(c->t, id, &un, c->ei))) {
		return builder_fail(c, rc);
	}
	if ((rc = set_name(c, obj, id))) {
		return rc;
	}
	c->depth++;
	c->idx[c->depth] = 0;
	if ((rc = parse_node(c, json_array_get(children, 0)))) {
		return rc;
	}
	c->depth--;
	if ((rc = bc_tree_pop_op(c->t, c->ei))) {
		return builder_fail(c, rc);
	}
	return 0;
}

/* Recursion is bounded: depth is checked against BC_SCENE_JSON_MAX_DEPTH
 * first (jansson itself holds no deeper document). */
static int parse_node(struct jctx *c, json_t *obj)
{
	const json_t *type;
	const char *name;
	char q[48];
	enum bc_prim pk;
	enum bc_op ok;

	if (c->depth >= BC_SCENE_JSON_MAX_DEPTH) {
		return jfail(c, BC_EDEPTH, NULL, -1,
		             "nesting deeper than %u levels (the most a JSON "
		             "scene carries; use the binary form)",
		             BC_SCENE_JSON_MAX_DEPTH);
	}
	if (!json_is_object(obj)) {
		return jfail(c, BC_EPARSE, NULL, -1,
		             "expected a node object, got %s", json_kind(obj));
	}
	if (++c->nodes > BC_TREE_MAX_NODES) {
		return jfail(c, BC_ELIMIT, NULL, -1, "more than %u nodes",
		             BC_TREE_MAX_NODES);
	}
	type = json_object_get(obj, "type");
	if (!type) {
		return jfail(c, BC_EPARSE, NULL, -1, "missing key \"type\"");
	}
	if (!json_is_string(type)) {
		return jfail(c, BC_EPARSE, "type", -1,
		             "expected a string, got %s", json_kind(type));
	}
	name = json_string_value(type);
	if ((pk = bc_prim_from_name(name)) != BC_PRIM_INVALID) {
		return parse_prim(c, obj, pk);
	}
	if ((ok = bc_op_from_name(name)) != BC_OP_INVALID) {
		return bc_op_is_unary(ok) ? parse_unary(c, obj, ok)
		                          : parse_op(c, obj, ok);
	}
	quote_untrusted(q, sizeof(q), name);
	return jfail(
	    c, BC_EENUM, NULL, -1, "unknown %s type \"%s\"",
	    json_object_get(obj, "children") ? "operator" : "primitive", q);
}

/* First walk: gathers the ids the file names. Malformed parts are skipped
 * here and reported by the second walk. */
static int collect_ids(struct jctx *c, const json_t *obj, uint32_t depth)
{
	const json_t *v, *children;
	if (depth >= BC_SCENE_JSON_MAX_DEPTH || !json_is_object(obj)) {
		return 0;
	}
	if (++c->nodes > BC_TREE_MAX_NODES) {
		return 0;
	}
	v = json_object_get(obj, "id");
	if (v && json_is_integer(v) && json_integer_value(v) >= 1 &&
	    json_integer_value(v) <= (json_int_t)UINT32_MAX) {
		struct fresh *f = &c->fr;
		if (f->n == f->cap) {
			uint32_t cap = f->cap ? 2 * f->cap : 256;
			uint32_t *grown =
			    bc_reallocarray(f->ids, cap, sizeof(uint32_t));
			if (!grown) {
				return bc_errinfo_set(c->ei, BC_ENOMEM,
				                      "scene: out of memory");
			}
			f->ids = grown;
			f->cap = cap;
		}
		f->ids[f->n++] = (uint32_t)json_integer_value(v);
	}
	children = json_object_get(obj, "children");
	if (json_is_array(children)) {
		for (size_t i = 0; i < json_array_size(children); i++) {
			int rc = collect_ids(c, json_array_get(children, i),
			                     depth + 1);
			if (rc) {
				return rc;
			}
		}
	}
	return 0;
}

static int parse_camera(struct jctx *c, json_t *obj, struct bc_camera *cam)
{
	static const char *const allowed[] = {"eye", "target", "up",
	                                      "fov_y_deg"};
	const char *key;
	json_t *v;
	int rc;
	if (!json_is_object(obj)) {
		return jfail(c, BC_EPARSE, "camera", -1,
		             "expected an object, got %s", json_kind(obj));
	}
	json_object_foreach(obj, key, v)
	{
		char q[48], path[64];
		float *dst = NULL;
		uint32_t n = 3;
		for (size_t i = 0; i < 4; i++) {
			if (strcmp(key, allowed[i]) == 0) {
				dst = i == 0   ? cam->eye
				      : i == 1 ? cam->target
				      : i == 2 ? cam->up
				               : &cam->fov_y_deg;
				n = i == 3 ? 1 : 3;
			}
		}
		if (!dst) {
			quote_untrusted(q, sizeof(q), key);
			return jfail(c, BC_EPARSE, "camera", -1,
			             "unknown key \"%s\"", q);
		}
		snprintf(path, sizeof(path), "camera.%s", key);
		if ((rc = get_floats(c, v, path, n, dst))) {
			return rc;
		}
	}
	{
		struct bc_errinfo local = {0};
		/* Its reason already starts with "camera: ". */
		if ((rc = bc_camera_validate(cam, &local))) {
			return bc_errinfo_set(c->ei, rc, "%s", local.msg);
		}
	}
	return 0;
}

/* bc_scene_parse_json with the document in the thread's arena (which
 * frees it). */
static int parse_doc(const char *text, size_t len, struct bc_tree *t,
                     struct bc_camera *cam, struct bc_errinfo *ei)
{
	static const char *const top_keys[] = {"blobcast", "camera", "root"};
	struct jctx c;
	struct bc_camera view;
	json_error_t jerr;
	json_t *doc = NULL, *v;
	const char *key;
	int rc = 0;

	memset(&c, 0, sizeof(c));
	c.t = t;
	c.ei = ei;
	if (ei) {
		ei->code = 0;
		ei->msg[0] = '\0';
	}
	bc_camera_default(&view);
	if (cam) {
		*cam = view;
	}
	bc_tree_begin(t);
	if (len > BC_SCENE_JSON_MAX_BYTES) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT, "scene: %zu bytes, over the %u byte limit",
		    len, BC_SCENE_JSON_MAX_BYTES);
	}
	if (!text) {
		return bc_errinfo_set(ei, BC_EINVAL, "scene: no text");
	}
	jansson_oom = false;
	doc = json_loadb(text, len, JSON_REJECT_DUPLICATES, &jerr);
	if (!doc && jansson_oom) {
		return bc_errinfo_set(ei, BC_ENOMEM, "scene: out of memory");
	}
	if (!doc) {
		switch (json_error_code(&jerr)) {
		case json_error_out_of_memory:
			rc = BC_ENOMEM;
			break;
		case json_error_stack_overflow:
			rc = BC_EDEPTH;
			break;
		case json_error_numeric_overflow:
			/* "real number overflow" is a number that only
			 * infinity could hold; integers out of range are
			 * plain range errors. */
			rc = strstr(jerr.text, "real") ? BC_ENONFINITE
			                               : BC_ERANGE;
			break;
		default:
			rc = BC_EPARSE;
			break;
		}
		if (rc == BC_EDEPTH) {
			return bc_errinfo_set(
			    ei, rc,
			    "line %d column %d: %s: a JSON scene nests at "
			    "most %u levels (use the binary form)",
			    jerr.line, jerr.column, jerr.text,
			    BC_SCENE_JSON_MAX_DEPTH);
		}
		return bc_errinfo_set(ei, rc, "line %d column %d: %s",
		                      jerr.line, jerr.column, jerr.text);
	}
	if (!json_is_object(doc)) {
		rc = bc_errinfo_set(ei, BC_EPARSE,
		                    "(document): expected an object, got %s",
		                    json_kind(doc));
		goto cleanup;
	}
	json_object_foreach(doc, key, v)
	{
		bool known = false;
		for (size_t i = 0; i < 3; i++) {
			known = known || strcmp(key, top_keys[i]) == 0;
		}
		if (!known) {
			char q[48];
			quote_untrusted(q, sizeof(q), key);
			rc = bc_errinfo_set(
			    ei, BC_EPARSE, "(document): unknown key \"%s\"", q);
			goto cleanup;
		}
	}
	v = json_object_get(doc, "blobcast");
	if (!v) {
		rc = bc_errinfo_set(ei, BC_EPARSE,
		                    "(document): missing key \"blobcast\" (the "
		                    "format version)");
		goto cleanup;
	}
	if (!json_is_integer(v)) {
		rc = jfail(&c, BC_EPARSE, "blobcast", -1,
		           "expected an integer, got %s", json_kind(v));
		goto cleanup;
	}
	if (json_integer_value(v) != BC_SCENE_JSON_VERSION) {
		rc = jfail(&c, BC_ENOTSUP, "blobcast", -1,
		           "version %lld is not supported (this build reads "
		           "%d)",
		           (long long)json_integer_value(v),
		           BC_SCENE_JSON_VERSION);
		goto cleanup;
	}
	if ((v = json_object_get(doc, "camera")) &&
	    (rc = parse_camera(&c, v, &view))) {
		goto cleanup;
	}
	v = json_object_get(doc, "root");
	if (!v) {
		rc = bc_errinfo_set(ei, BC_EPARSE,
		                    "(document): missing key \"root\"");
		goto cleanup;
	}
	if ((rc = collect_ids(&c, v, 0))) {
		goto cleanup;
	}
	if (c.fr.n) {
		qsort(c.fr.ids, c.fr.n, sizeof(uint32_t), bc_cmp_u32);
	}
	c.fr.next = 1;
	c.nodes = 0;
	c.in_tree = true;
	if ((rc = parse_node(&c, v)) || (rc = bc_tree_end(t, ei))) {
		goto cleanup;
	}
	if (cam) {
		*cam = view;
	}
cleanup:
	/* doc goes with the arena, whole. */
	bc_free(c.fr.ids);
	if (rc) {
		/* Leave the tree empty, not half built. */
		bc_tree_begin(t);
	}
	return rc;
}

int bc_scene_parse_json(const char *text, size_t len, struct bc_tree *t,
                        struct bc_camera *cam, struct bc_errinfo *ei)
{
	struct jarena arena = {0};
	int rc;
	pthread_once(&alloc_once, route_jansson_alloc);
	jarena = &arena;
	rc = parse_doc(text, len, t, cam, ei);
	jarena = NULL;
	jarena_release(&arena);
	return rc;
}

static void errno_text(int err, char *buf, size_t cap)
{
	if (strerror_r(err, buf, cap) != 0) {
		snprintf(buf, cap, "errno %d", err);
	}
}

int bc__read_file(const char *path, size_t max, char **out, size_t *len,
                  struct bc_errinfo *ei)
{
	struct stat st;
	char *text = NULL, why[128];
	size_t got = 0, size;
	int fd, rc = 0;

	*out = NULL;
	*len = 0;
	fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0) {
		errno_text(errno, why, sizeof(why));
		return bc_errinfo_set(ei,
		                      errno == ENOENT ? BC_ENOTFOUND : BC_EIO,
		                      "%s: %s", path, why);
	}
	if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: not a regular file", path);
		goto cleanup;
	}
	if ((uint64_t)st.st_size > max) {
		rc = bc_errinfo_set(ei, BC_ELIMIT,
		                    "%s: %lld bytes, over the %zu byte limit",
		                    path, (long long)st.st_size, max);
		goto cleanup;
	}
	size = (size_t)st.st_size;
	text = bc_malloc(size + 1);
	if (!text) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "%s: out of memory", path);
		goto cleanup;
	}
	/* A file that shrinks while read is taken as far as it goes; one
	 * that grows is read up to the size fstat gave. */
	while (got < size) {
		ssize_t n = read(fd, text + got, size - got);
		if (n < 0 && errno == EINTR) {
			continue;
		}
		if (n < 0) {
			errno_text(errno, why, sizeof(why));
			rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", path, why);
			goto cleanup;
		}
		if (n == 0) {
			break;
		}
		got += (size_t)n;
	}
	text[got] = '\0';
	*out = text;
	*len = got;
	text = NULL;
cleanup:
	bc_free(text);
	close(fd);
	return rc;
}

int bc_scene_load_json(const char *path, struct bc_tree *t,
                       struct bc_camera *cam, struct bc_errinfo *ei)
{
	char *text;
	size_t len;
	int rc;
	if (cam) {
		bc_camera_default(cam);
	}
	bc_tree_begin(t);
	if ((rc = bc__read_file(path, BC_SCENE_JSON_MAX_BYTES, &text, &len,
	                        ei))) {
		return rc;
	}
	rc = bc_scene_parse_json(text, len, t, cam, ei);
	bc_free(text);
	return rc;
}

/* ---- writing ------------------------------------------------------------- */

static void sb_put(struct bc_buf *b, const char *s, size_t n)
{
	bc_buf_append(b, s, n);
}

static void sb_puts(struct bc_buf *b, const char *s)
{
	sb_put(b, s, strlen(s));
}

/* Indentation shows the first levels only: a 1000-deep chain indented in
 * full would be quadratic in size. */
#define INDENT_LEVELS 32u

static uint32_t indent_of(uint32_t depth)
{
	return 2u + 2u * (depth < INDENT_LEVELS ? depth : INDENT_LEVELS);
}

static void sb_indent(struct bc_buf *b, uint32_t n)
{
	if (!bc_buf_reserve(b, n)) {
		memset(b->data + b->len, ' ', n);
		b->len += n;
	}
}

static void sb_uint(struct bc_buf *b, uint32_t v)
{
	char tmp[16];
	int n = snprintf(tmp, sizeof(tmp), "%u", v);
	sb_put(b, tmp, (size_t)n);
}

/* 10^k, 0 <= k <= 22: exact in a double. */
static const double exact_pow10[23] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* Whether the decimal n * 10^k (|k| <= 22) reads back as a (> 0) the way
 * jansson reads it (strtod's correctly rounded double, then a float
 * conversion): with n below 2^53 and 10^|k| exact, one multiplication or
 * division is that same correctly rounded double. */
static bool reads_back(uint64_t n, int k, float a)
{
	double v =
	    k < 0 ? (double)n / exact_pow10[-k] : (double)n * exact_pow10[k];
	return (float)v == a;
}

/* a (> 0) to p significant digits: *n (p digits) times 10^(*e - p + 1),
 * *e the exponent of the first digit. Rounded from a double product, so a
 * value within a hair of a half may round the other way; reads_back
 * decides what is written. */
static void to_digits(double a, int p, uint64_t *n, int *e)
{
	int x = (int)floor(log10(a)), s;
	double scaled;
	uint64_t top = (uint64_t)exact_pow10[p], low = top / 10u;
	s = p - 1 - x;
	scaled = s >= 0 ? (s <= 22 ? a * exact_pow10[s] : a * pow(10.0, s))
	                : (-s <= 22 ? a / exact_pow10[-s] : a / pow(10.0, -s));
	{
		/* Halves to even, as printf rounds an exact half. */
		double whole = floor(scaled), frac = scaled - whole;
		*n = (uint64_t)whole;
		*n += frac > 0.5 || (frac == 0.5 && (*n & 1u)) ? 1u : 0u;
	}
	if (*n >= top) {
		*n = (*n + 5u) / 10u;
		x++;
	} else if (*n < low) {
		/* log10 came out one high. */
		*n = (uint64_t)(scaled * 10.0 + 0.5);
		x--;
	}
	*e = x;
}

/* n (p digits) times 10^(e - p + 1) as printf's %.{p}g writes it. */
static int g_text(char *out, bool neg, uint64_t n, int e, int p)
{
	char d[24];
	int nd = p, k = 0;
	for (int i = p - 1; i >= 0; i--) {
		d[i] = (char)('0' + n % 10u);
		n /= 10u;
	}
	while (nd > 1 && d[nd - 1] == '0') {
		nd--;
	}
	if (neg) {
		out[k++] = '-';
	}
	if (e < -4 || e >= p) {
		int ae = e < 0 ? -e : e;
		out[k++] = d[0];
		if (nd > 1) {
			out[k++] = '.';
			memcpy(out + k, d + 1, (size_t)(nd - 1));
			k += nd - 1;
		}
		out[k++] = 'e';
		out[k++] = e < 0 ? '-' : '+';
		if (ae >= 100) {
			out[k++] = (char)('0' + ae / 100);
		}
		out[k++] = (char)('0' + ae / 10 % 10);
		out[k++] = (char)('0' + ae % 10);
	} else if (e >= 0) {
		for (int i = 0; i <= e; i++) {
			out[k++] = i < nd ? d[i] : '0';
		}
		if (nd > e + 1) {
			out[k++] = '.';
			memcpy(out + k, d + e + 1, (size_t)(nd - e - 1));
			k += nd - e - 1;
		}
	} else {
		out[k++] = '0';
		out[k++] = '.';
		for (int i = 0; i < -e - 1; i++) {
			out[k++] = '0';
		}
		memcpy(out + k, d, (size_t)nd);
		k += nd;
	}
	return k;
}

/* f (finite, not 0) as sb_float's printf would write it, without printf
 * (which took two thirds of a million-primitive snapshot): six digits
 * when they read back, else nine; 0 when this cannot tell (a value far
 * from 1, or within a hair of a rounding half), and printf decides. */
static int fast_float(char *out, float f)
{
	float a = fabsf(f);
	uint64_t n;
	int e;
	for (int p = 6; p <= 9; p += 3) {
		to_digits((double)a, p, &n, &e);
		if (e - p + 1 < -22 || e - p + 1 > 22) {
			return 0;
		}
		if (reads_back(n, e - p + 1, a)) {
			return g_text(out, f < 0.0f, n, e, p);
		}
	}
	return 0;
}

/* Writes f with the fewest digits that read back (as jansson reads: strtod,
 * then a float conversion) to the same bits: six significant digits when
 * they suffice (values typed by hand stay as typed), nine otherwise, which
 * always suffice for binary32. */
static void sb_float(struct bc_buf *b, float f)
{
	char tmp[40];
	int n;
	if (f == 0.0f && signbit(f)) {
		/* "-0" would read back as the integer 0. */
		sb_puts(b, "-0.0");
		return;
	}
	if (f != 0.0f && isfinite(f) && (n = fast_float(tmp, f)) > 0) {
		sb_put(b, tmp, (size_t)n);
		return;
	}
	n = snprintf(tmp, sizeof(tmp), "%.6g", (double)f);
	if ((float)strtod(tmp, NULL) != f) {
		n = snprintf(tmp, sizeof(tmp), "%.9g", (double)f);
	}
	/* Under a locale with a decimal comma printf writes "0,5". */
	for (int i = 0; i < n; i++) {
		if (tmp[i] == ',') {
			tmp[i] = '.';
		}
	}
	sb_put(b, tmp, (size_t)n);
}

static void sb_floats(struct bc_buf *b, const float *f, uint32_t n)
{
	if (n == 1) {
		sb_float(b, f[0]);
		return;
	}
	sb_puts(b, "[");
	for (uint32_t i = 0; i < n; i++) {
		if (i) {
			sb_puts(b, ", ");
		}
		sb_float(b, f[i]);
	}
	sb_puts(b, "]");
}

/* `, "key": value`; key is one of our own identifiers. */
static void sb_member(struct bc_buf *b, const char *key, const float *f,
                      uint32_t n)
{
	sb_puts(b, ", \"");
	sb_puts(b, key);
	sb_puts(b, "\": ");
	sb_floats(b, f, n);
}

/* Bit equality: -0.0 is not the default 0.0, and must be written. */
static bool same_bits(const float *a, const float *b, uint32_t n)
{
	return memcmp(a, b, n * sizeof(float)) == 0;
}

/* `, "name": "..."` when node id has a name: JSON's escapes for the
 * quote, the backslash and control characters; other UTF-8 as it is. */
static void sb_name(struct bc_buf *b, const struct bc_tree *t, uint32_t id)
{
	const char *s = bc_tree_name(t, id);
	if (!s) {
		return;
	}
	sb_puts(b, ", \"name\": \"");
	for (; *s; s++) {
		unsigned char ch = (unsigned char)*s;
		char esc[8];
		if (ch == '"' || ch == '\\') {
			esc[0] = '\\';
			esc[1] = (char)ch;
			esc[2] = '\0';
			sb_puts(b, esc);
		} else if (ch < 0x20 || ch == 0x7f) {
			snprintf(esc, sizeof(esc), "\\u%04x", ch);
			sb_puts(b, esc);
		} else {
			bc_buf_append(b, s, 1);
		}
	}
	sb_puts(b, "\"");
}

static void write_prim(struct bc_buf *b, const struct bc_tree *t,
                       const struct bc_scene_node *n)
{
	static const float zero[3] = {0.0f, 0.0f, 0.0f};
	static const float identity[4] = {0.0f, 0.0f, 0.0f, 1.0f};
	const struct bc_prim_info *info = bc_prim_info(n->prim.kind);
	sb_puts(b, "{\"type\": \"");
	sb_puts(b, info->name);
	sb_puts(b, "\", \"id\": ");
	sb_uint(b, n->id);
	sb_name(b, t, n->id);
	for (uint32_t i = 0; i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		const float *v = n->prim.params + d->offset;
		if (d->flags & BC_PARAM_OPTIONAL) {
			float def[3] = {d->def, d->def, d->def};
			if (same_bits(v, def, d->count)) {
				continue;
			}
		}
		sb_member(b, d->name, v, d->count);
	}
	if (!same_bits(n->prim.translate, zero, 3)) {
		sb_member(b, "translate", n->prim.translate, 3);
	}
	if (!same_bits(n->prim.rotate, identity, 4)) {
		sb_member(b, "rotate", n->prim.rotate, 4);
	}
	if (n->prim.has_color) {
		sb_member(b, "color", n->prim.color, 3);
	}
	sb_puts(b, "}");
}

static void write_op(struct bc_buf *b, const struct bc_tree *t,
                     const struct bc_scene_node *n)
{
	sb_puts(b, "{\"type\": \"");
	sb_puts(b, bc_op_name(n->op.kind));
	sb_puts(b, "\", \"id\": ");
	sb_uint(b, n->id);
	sb_name(b, t, n->id);
	if (bc_op_is_unary(n->op.kind)) {
		const struct bc_unary_info *info = bc_unary_info(n->op.kind);
		if (n->op.kind == BC_OP_MIRROR) {
			char axes[4];
			bc_mirror_axes_name((uint32_t)n->unary.u[0], axes);
			sb_puts(b, ", \"axes\": \"");
			sb_puts(b, axes);
			sb_puts(b, "\"");
		} else if (n->op.kind == BC_OP_REPEAT) {
			sb_member(b, "spacing", n->unary.u, 3);
			sb_member(b, "count", n->unary.u + 3, 3);
		} else {
			sb_member(b, info->param, n->unary.u, info->nparams);
		}
	}
	if (bc_op_is_smooth(n->op.kind)) {
		sb_member(b, "blend", &n->op.blend, 1);
		sb_member(b, "range", &n->op.range, 1);
	}
	sb_puts(b, ", \"children\": [\n");
}

/* Pieces a sink receives: about this many bytes each. */
#define JSON_PIECE (256u * 1024u)

/* Writes the scene into b; with a sink, hands b's bytes to it whenever
 * they pass JSON_PIECE and at the end, so b never holds more than a piece
 * and a node. Returns 0, the sink's error or b's. */
static int write_scene(const struct bc_tree *t, const struct bc_camera *cam,
                       struct bc_buf *b, bc_scene_sink sink, void *ctx)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	uint32_t rem[BC_SCENE_JSON_MAX_DEPTH], nopen = 0;
	int rc;

	if ((rc = bc_scene_walk_init(&w, t))) {
		return rc;
	}
	sb_puts(b, "{\n  \"blobcast\": 1,\n");
	if (cam) {
		sb_puts(b, "  \"camera\": {\"eye\": ");
		sb_floats(b, cam->eye, 3);
		sb_member(b, "target", cam->target, 3);
		sb_member(b, "up", cam->up, 3);
		sb_member(b, "fov_y_deg", &cam->fov_y_deg, 1);
		sb_puts(b, "},\n");
	}
	sb_puts(b, "  \"root\": ");
	while (!b->err && !rc && bc_scene_walk_next(&w, &n)) {
		if (sink && b->len >= JSON_PIECE) {
			rc = sink(ctx, b->data, b->len);
			b->len = 0;
		}
		if (n.depth) {
			sb_indent(b, indent_of(n.depth));
		}
		if (n.is_op) {
			write_op(b, t, &n);
			rem[nopen++] = n.nchildren;
			continue;
		}
		write_prim(b, t, &n);
		/* A finished node: separate it from its next sibling, or
		 * close every operator it was the last descendant of. */
		while (nopen) {
			if (--rem[nopen - 1] > 0) {
				sb_puts(b, ",\n");
				break;
			}
			nopen--;
			sb_puts(b, "\n");
			sb_indent(b, indent_of(nopen));
			sb_puts(b, "]}");
		}
	}
	bc_scene_walk_finish(&w);
	sb_puts(b, "\n}\n");
	if (!rc && b->err) {
		rc = b->err;
	}
	if (!rc && sink && b->len) {
		rc = sink(ctx, b->data, b->len);
		b->len = 0;
	}
	return rc;
}

char *bc_scene_to_json(const struct bc_tree *t, const struct bc_camera *cam)
{
	struct bc_buf b;
	uint8_t *text;
	size_t len;

	if (bc_tree_nesting(t) > BC_SCENE_JSON_MAX_DEPTH) {
		return NULL;
	}
	/* About 100 bytes per node: start near the final size. */
	bc_buf_init(&b, SIZE_MAX);
	bc_buf_reserve(&b, 256 + 100 * (size_t)bc_tree_node_count(t));
	if (write_scene(t, cam, &b, NULL, NULL) ||
	    bc_buf_take(&b, &text, &len)) {
		bc_buf_finish(&b);
		return NULL;
	}
	return (char *)text;
}

int bc_scene_write_json(const struct bc_tree *t, const struct bc_camera *cam,
                        bc_scene_sink sink, void *ctx)
{
	struct bc_buf b;
	int rc;
	if (bc_tree_root(t) == 0) {
		return BC_EINVAL;
	}
	if (bc_tree_nesting(t) > BC_SCENE_JSON_MAX_DEPTH) {
		return BC_EDEPTH;
	}
	bc_buf_init(&b, SIZE_MAX);
	if ((rc = bc_buf_reserve(&b, 2u * JSON_PIECE)) == 0) {
		rc = write_scene(t, cam, &b, sink, ctx);
	}
	bc_buf_finish(&b);
	return rc;
}

/* A file sink: errno says why on BC_EIO. */
static int fd_sink(void *ctx, const void *bytes, size_t len)
{
	return bc_write_all(*(int *)ctx, bytes, len) ? 0 : BC_EIO;
}

int bc__save_atomic(const char *path, bc__file_fill fill, void *ctx,
                    struct bc_errinfo *ei)
{
	char *tmp = NULL, *dir = NULL, why[128];
	size_t plen = strlen(path);
	int fd = -1, dfd, rc = 0;
	char *slash;

	tmp = bc_malloc(plen + 48);
	dir = bc_malloc(plen + 2);
	if (tmp) {
		tmp[0] = '\0'; /* no temporary file yet */
	}
	if (!tmp || !dir) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "%s: out of memory", path);
		goto cleanup;
	}
	/* The temporary file sits beside the target so that rename() stays
	 * within one file system and is atomic. O_EXCL with a pid-and-try
	 * name keeps concurrent savers apart; open() honours the umask. */
	for (unsigned attempt = 0; fd < 0 && attempt < 64; attempt++) {
		snprintf(tmp, plen + 48, "%s.tmp.%ld.%u", path, (long)getpid(),
		         attempt);
		fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
		if (fd < 0 && errno != EEXIST) {
			break;
		}
	}
	if (fd < 0) {
		errno_text(errno, why, sizeof(why));
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, why);
		goto cleanup;
	}
	if ((rc = fill(fd, ctx))) {
		if (rc == BC_EIO) {
			errno_text(errno, why, sizeof(why));
			rc = bc_errinfo_set(ei, BC_EIO, "%s: write: %s", tmp,
			                    why);
		} else if (rc == BC_ELIMIT) {
			rc =
			    bc_errinfo_set(ei, rc,
			                   "%s: the scene is over the %u bytes "
			                   "its file holds",
			                   path, BC_SCENE_FILE_MAX_BYTES);
		} else {
			rc = bc_errinfo_set(ei, rc, "%s: %s", path,
			                    bc_strerror(rc));
		}
		goto cleanup;
	}
	if (fsync(fd) != 0) {
		errno_text(errno, why, sizeof(why));
		rc = bc_errinfo_set(ei, BC_EIO, "%s: fsync: %s", tmp, why);
		goto cleanup;
	}
	if (close(fd) != 0) {
		fd = -1;
		errno_text(errno, why, sizeof(why));
		rc = bc_errinfo_set(ei, BC_EIO, "%s: close: %s", tmp, why);
		goto cleanup;
	}
	fd = -1;
	if (rename(tmp, path) != 0) {
		errno_text(errno, why, sizeof(why));
		rc = bc_errinfo_set(ei, BC_EIO, "%s: rename: %s", path, why);
		goto cleanup;
	}
	tmp[0] = '\0'; /* nothing left to remove */
	/* The rename is durable only once the directory entry is. */
	memcpy(dir, path, plen + 1);
	slash = strrchr(dir, '/');
	if (!slash) {
		strcpy(dir, ".");
	} else if (slash == dir) {
		dir[1] = '\0';
	} else {
		*slash = '\0';
	}
	dfd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (dfd < 0 || fsync(dfd) != 0) {
		errno_text(errno, why, sizeof(why));
		rc = bc_errinfo_set(ei, BC_EIO, "%s: directory fsync: %s", dir,
		                    why);
	}
	if (dfd >= 0) {
		close(dfd);
	}
cleanup:
	if (fd >= 0) {
		close(fd);
	}
	if (rc && tmp && tmp[0]) {
		unlink(tmp);
	}
	bc_free(tmp);
	bc_free(dir);
	return rc;
}

struct json_fill {
	const struct bc_tree *t;
	const struct bc_camera *cam;
};

/* The text goes to the file as it is made: a big scene's is never whole
 * in memory. */
static int fill_json(int fd, void *ctx)
{
	const struct json_fill *j = ctx;
	return bc_scene_write_json(j->t, j->cam, fd_sink, &fd);
}

int bc_scene_save_json(const char *path, const struct bc_tree *t,
                       const struct bc_camera *cam, struct bc_errinfo *ei)
{
	if (bc_tree_root(t) == 0) {
		return bc_errinfo_set(ei, BC_EINVAL, "%s: empty scene", path);
	}
	if (bc_tree_nesting(t) > BC_SCENE_JSON_MAX_DEPTH) {
		return bc_errinfo_set(
		    ei, BC_EDEPTH,
		    "%s: the scene nests %u levels, more than "
		    "the %u a JSON scene carries",
		    path, bc_tree_nesting(t), BC_SCENE_JSON_MAX_DEPTH);
	}
	return bc__save_atomic(path, fill_json, &(struct json_fill){t, cam},
	                       ei);
}

/* ---- the built-in scene ---------------------------------------------------
 */

/*
 * A small workshop on a grooved slab: the classic CSG emblem (a rounded cube
 * smoothly intersected with a sphere, minus three cylinders), a blob
 * creature (smooth union, with sharp eyes), a ring on a stand, and three
 * marbles. 18 primitives of five kinds under every operator but the sharp
 * intersection; cylinders and tori stand on their local y axis.
 */
static const char default_scene[] =
    "{\n"
    "  \"blobcast\": 1,\n"
    "  \"camera\": {\"eye\": [2.4, 2.0, 5.0], \"target\": [0, -0.4, 0.15], "
    "\"up\": [0, 1, 0], \"fov_y_deg\": 38},\n"
    "  \"root\": {\"type\": \"union\", \"id\": 1, \"children\": [\n"
    "    {\"type\": \"smooth_difference\", \"id\": 10, \"blend\": 0.05, "
    "\"range\": 0.0625, \"children\": [\n"
    "      {\"type\": \"box\", \"id\": 11, \"half_extents\": [2.3, 0.12, "
    "1.3], \"round\": 0.04, \"translate\": [0, -1, 0], "
    "\"color\": [0.36, 0.42, 0.52]},\n"
    "      {\"type\": \"cylinder\", \"id\": 12, \"radius\": 0.08, "
    "\"half_height\": 2.5, \"translate\": [0, -0.88, 0.95], "
    "\"rotate\": [0, 0, 0.707106781, 0.707106781], "
    "\"color\": [0.2, 0.22, 0.28]}\n"
    "    ]},\n"
    "    {\"type\": \"difference\", \"id\": 20, \"children\": [\n"
    "      {\"type\": \"smooth_intersection\", \"id\": 21, \"blend\": 0.06, "
    "\"children\": [\n"
    "        {\"type\": \"box\", \"id\": 22, \"half_extents\": [0.55, 0.55, "
    "0.55], \"round\": 0.02, \"translate\": [-1.15, -0.33, 0.1], "
    "\"rotate\": [0, 0.258819045, 0, 0.965925826], "
    "\"color\": [0.93, 0.55, 0.18]},\n"
    "        {\"type\": \"sphere\", \"id\": 23, \"radius\": 0.75, "
    "\"translate\": [-1.15, -0.33, 0.1], \"color\": [0.86, 0.25, 0.22]}\n"
    "      ]},\n"
    "      {\"type\": \"union\", \"id\": 24, \"children\": [\n"
    "        {\"type\": \"cylinder\", \"id\": 25, \"radius\": 0.26, "
    "\"half_height\": 0.9, \"translate\": [-1.15, -0.33, 0.1], "
    "\"rotate\": [0.183012702, 0.183012702, 0.683012702, 0.683012702], "
    "\"color\": [0.25, 0.45, 0.75]},\n"
    "        {\"type\": \"cylinder\", \"id\": 26, \"radius\": 0.26, "
    "\"half_height\": 0.9, \"translate\": [-1.15, -0.33, 0.1], "
    "\"rotate\": [0, 0.258819045, 0, 0.965925826], "
    "\"color\": [0.25, 0.45, 0.75]},\n"
    "        {\"type\": \"cylinder\", \"id\": 27, \"radius\": 0.26, "
    "\"half_height\": 0.9, \"translate\": [-1.15, -0.33, 0.1], "
    "\"rotate\": [0.683012702, 0.183012702, -0.183012702, 0.683012702], "
    "\"color\": [0.25, 0.45, 0.75]}\n"
    "      ]}\n"
    "    ]},\n"
    "    {\"type\": \"union\", \"id\": 30, \"children\": [\n"
    "      {\"type\": \"smooth_union\", \"id\": 31, \"blend\": 0.25, "
    "\"children\": [\n"
    "        {\"type\": \"sphere\", \"id\": 32, \"radius\": 0.5, "
    "\"translate\": [1.1, -0.38, 0.2], \"color\": [0.42, 0.74, 0.45]},\n"
    "        {\"type\": \"sphere\", \"id\": 33, \"radius\": 0.32, "
    "\"translate\": [1.1, 0.32, 0.25], \"color\": [0.5, 0.8, 0.5]},\n"
    "        {\"type\": \"capsule\", \"id\": 34, \"a\": [0.35, 0.05, 0], "
    "\"b\": [0.75, 0.35, 0.1], \"radius\": 0.1, "
    "\"translate\": [1.1, -0.3, 0.2], \"color\": [0.38, 0.68, 0.42]},\n"
    "        {\"type\": \"capsule\", \"id\": 35, \"a\": [-0.35, 0.05, 0], "
    "\"b\": [-0.72, 0.4, 0.05], \"radius\": 0.1, "
    "\"translate\": [1.1, -0.3, 0.2], \"color\": [0.38, 0.68, 0.42]}\n"
    "      ]},\n"
    "      {\"type\": \"sphere\", \"id\": 36, \"radius\": 0.07, "
    "\"translate\": [1.0, 0.38, 0.54], \"color\": [0.08, 0.08, 0.1]},\n"
    "      {\"type\": \"sphere\", \"id\": 37, \"radius\": 0.07, "
    "\"translate\": [1.2, 0.38, 0.54], \"color\": [0.08, 0.08, 0.1]}\n"
    "    ]},\n"
    "    {\"type\": \"smooth_union\", \"id\": 40, \"blend\": 0.1, "
    "\"children\": [\n"
    "      {\"type\": \"torus\", \"id\": 41, \"major\": 0.45, \"minor\": 0.09, "
    "\"translate\": [0, 0, -0.55], "
    "\"rotate\": [0.707106781, 0, 0, 0.707106781], "
    "\"color\": [0.95, 0.78, 0.3]},\n"
    "      {\"type\": \"capsule\", \"id\": 42, \"a\": [0, -0.88, 0], "
    "\"b\": [0, -0.45, 0], \"radius\": 0.07, "
    "\"translate\": [0, 0, -0.55], \"color\": [0.7, 0.6, 0.35]}\n"
    "    ]},\n"
    "    {\"type\": \"sphere\", \"id\": 50, \"radius\": 0.14, "
    "\"translate\": [-0.2, -0.74, 0.75], \"color\": [0.9, 0.2, 0.3]},\n"
    "    {\"type\": \"sphere\", \"id\": 51, \"radius\": 0.12, "
    "\"translate\": [0.15, -0.76, 0.98], \"color\": [0.95, 0.85, 0.25]},\n"
    "    {\"type\": \"sphere\", \"id\": 52, \"radius\": 0.1, "
    "\"translate\": [0.45, -0.78, 0.7], \"color\": [0.25, 0.5, 0.95]}\n"
    "  ]}\n"
    "}\n";

const char *bc_scene_default_json(void)
{
	return default_scene;
}
