/*
 * Node names in the model and its encodings (PROTOCOL.md 8, 9): set, take
 * away and read back; a REMOVE takes the names of what it removes (the
 * operator it collapses included), a REPLACE drops the replaced nodes'
 * names (reused ids too) and brings the subtree's, an INSERT brings the
 * subtree's, a copy keeps them; the binary and JSON encodings carry them
 * bit for bit (quotes, backslashes, control characters, non-ASCII); bad
 * names are refused with their codes; and the operations that undo a
 * batch give every name back, through a mirror replaying them. A tree
 * told to keep none (a server's render copy) keeps none.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "test.h"

/* union 1 (sphere 2, smooth_union 3 (sphere 4, sphere 5), sphere 6) */
static const char *const json =
    "{\"blobcast\": 1, \"root\": {\"type\": \"union\", \"id\": 1, "
    "\"name\": \"all\", \"children\": [\n"
    "  {\"type\": \"sphere\", \"id\": 2, \"radius\": 0.5, \"name\": "
    "\"left \\\"one\\\"\"},\n"
    "  {\"type\": \"smooth_union\", \"id\": 3, \"blend\": 0.2, "
    "\"name\": \"pair\\\\\\u0001\", \"children\": [\n"
    "    {\"type\": \"sphere\", \"id\": 4, \"radius\": 0.5, \"name\": "
    "\"\\u00e9t\\u00e9\"},\n"
    "    {\"type\": \"sphere\", \"id\": 5, \"radius\": 0.5, "
    "\"translate\": [1, 0, 0]}]},\n"
    "  {\"type\": \"sphere\", \"name\": \"no id\", \"radius\": 0.3}]}}\n";

static struct bc_tree *load(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	if (!t || bc_scene_parse_json(json, strlen(json), t, NULL, &ei)) {
		fprintf(stderr, "  %s\n", ei.msg);
		abort();
	}
	return t;
}

static bool named(const struct bc_tree *t, uint32_t id, const char *want)
{
	const char *got = bc_tree_name(t, id);
	return want ? got && strcmp(got, want) == 0 : got == NULL;
}

/* Every node's name in a and b is the same, and so are the trees' bytes. */
static bool same(const struct bc_tree *a, const struct bc_tree *b)
{
	uint8_t *x = NULL, *y = NULL;
	size_t nx = 0, ny = 0;
	bool eq = bc_scene_encode(a, NULL, &x, &nx) == 0 &&
	          bc_scene_encode(b, NULL, &y, &ny) == 0 && nx == ny &&
	          memcmp(x, y, nx) == 0;
	bc_free(x);
	bc_free(y);
	return eq;
}

static void names_are_set_read_and_taken_away(void)
{
	struct bc_tree *t = load();
	struct bc_errinfo ei = {0};
	uint32_t n, *ids;
	CHECK(named(t, 1, "all"));
	CHECK(named(t, 2, "left \"one\""));
	CHECK(named(t, 3, "pair\\\x01"));
	CHECK(named(t, 4, "\xc3\xa9t\xc3\xa9"));
	CHECK(named(t, 5, NULL));
	/* The node without an id got one and kept its name. */
	CHECK_EQ_INT(bc_tree_name_count(t), 5);
	ids = bc_tree_name_ids(t, &n);
	REQUIRE(ids && n == 5);
	for (uint32_t i = 1; i < n; i++) {
		CHECK(ids[i - 1] < ids[i]);
	}
	CHECK(named(t, ids[4], "no id"));
	bc_free(ids);
	CHECK_EQ_INT(bc_tree_set_name(t, 5, "five", 4, &ei), 0);
	CHECK(named(t, 5, "five"));
	CHECK_EQ_INT(bc_tree_set_name(t, 5, "", 0, &ei), 0);
	CHECK(named(t, 5, NULL));
	CHECK_EQ_INT(bc_tree_set_name(t, 77, "x", 1, &ei), BC_ENONODE);
	CHECK_EQ_INT(bc_tree_set_name(t, 5, "a\0b", 3, &ei), BC_ESTRING);
	CHECK_EQ_INT(bc_tree_set_name(t, 5, "\xc3(", 2, &ei), BC_ESTRING);
	{
		char long_name[65];
		memset(long_name, 'n', sizeof(long_name));
		CHECK_EQ_INT(bc_tree_set_name(t, 5, long_name, 65, &ei),
		             BC_ERANGE);
		CHECK_EQ_INT(bc_tree_set_name(t, 5, long_name, 64, &ei), 0);
	}
	bc_tree_destroy(t);
}

static const char *const empty_name =
    "{\"blobcast\": 1, \"root\": {\"type\": \"sphere\", \"radius\": 1, "
    "\"name\": \"\"}}";
static const char *const number_name =
    "{\"blobcast\": 1, \"root\": {\"type\": \"sphere\", \"radius\": 1, "
    "\"name\": 4}}";

static void encodings_carry_names_bit_for_bit(void)
{
	struct bc_tree *t = load(), *u = bc_tree_create();
	struct bc_errinfo ei = {0};
	uint8_t *bytes = NULL;
	size_t len = 0;
	char *text;
	REQUIRE(u);
	REQUIRE(bc_scene_encode(t, NULL, &bytes, &len) == 0);
	CHECK(bytes[0] & BC_SCENE_FLAG_NAMES);
	CHECK_EQ_INT(bc_scene_decode(bytes, len, u, NULL, NULL, &ei), 0);
	CHECK(same(t, u));
	CHECK(named(u, 3, "pair\\\x01"));
	bc_free(bytes);
	text = bc_scene_to_json(t, NULL);
	REQUIRE(text);
	CHECK(strstr(text, "\"name\": \"pair\\\\\\u0001\"") != NULL);
	CHECK_EQ_INT(bc_scene_parse_json(text, strlen(text), u, NULL, &ei), 0);
	CHECK(same(t, u));
	bc_free(text);
	/* A scene without names has no table. */
	for (uint32_t id = 1; id <= 6; id++) {
		bc_tree_set_name(u, id, "", 0, NULL);
	}
	bc_tree_set_name(u, bc_tree_child(u, 1, 2), "", 0, NULL);
	CHECK_EQ_INT(bc_tree_name_count(u), 0);
	REQUIRE(bc_scene_encode(u, NULL, &bytes, &len) == 0);
	CHECK_EQ_INT(bytes[0], 0);
	bc_free(bytes);
	/* JSON refuses an empty name and a name that is not a string. */
	CHECK_EQ_INT(
	    bc_scene_parse_json(empty_name, strlen(empty_name), u, NULL, &ei),
	    BC_ERANGE);
	CHECK_EQ_INT(
	    bc_scene_parse_json(number_name, strlen(number_name), u, NULL, &ei),
	    BC_EPARSE);
	bc_tree_destroy(u);
	bc_tree_destroy(t);
}

/* A scene (flags 0 or names) of one sphere with id and, when name is not
 * NULL, that name. */
static struct bc_proto_bytes sphere_scene(uint32_t id, const char *name,
                                          struct bc_proto_buf *b)
{
	static const float zero[3] = {0, 0, 0}, ident[4] = {0, 0, 0, 1};
	static const float radius = 0.25f;
	bc_proto_buf_init(b, 0);
	if (bc_proto_scene_begin(b, NULL, 1) ||
	    bc_proto_scene_prim(b, 1, id, zero, ident, NULL, 1, &radius) ||
	    (name && (bc_proto_scene_names(b, 0, 1) ||
	              bc_proto_scene_name(b, id, name, strlen(name))))) {
		abort();
	}
	return (struct bc_proto_bytes){b->data, (uint32_t)b->len};
}

static void edits_move_names_with_their_nodes(void)
{
	struct bc_tree *t = load(), *c = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_proto_buf b;
	struct bc_proto_edit_op op = {0};
	struct bc_edit_batch batch;
	REQUIRE(c);
	/* A copy keeps them. */
	REQUIRE(bc_tree_copy(c, t, NULL) == 0);
	CHECK(same(t, c));
	/* REMOVE of 4 collapses operator 3: both names go. */
	op = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 4};
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), 0);
	CHECK(named(c, 4, NULL) && named(c, 3, NULL));
	CHECK(bc_tree_get(c, 5, NULL, NULL));
	/* REPLACE of 2 by a sphere reusing id 2: the old name goes, the
	 * subtree's comes. */
	op =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REPLACE, .node = 2};
	op.subtree = sphere_scene(2, NULL, &b);
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), 0);
	bc_proto_buf_finish(&b);
	CHECK(named(c, 2, NULL));
	op.subtree = sphere_scene(2, "new two", &b);
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), 0);
	bc_proto_buf_finish(&b);
	CHECK(named(c, 2, "new two"));
	/* INSERT brings the subtree's names. */
	op = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT, .node = 1, .position = 0};
	op.subtree = sphere_scene(40, "forty", &b);
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), 0);
	bc_proto_buf_finish(&b);
	CHECK(named(c, 40, "forty"));
	/* NAME of an unknown node: ENONODE. */
	op = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_NAME, .node = 99};
	op.name.ptr = "x";
	op.name.len = 1;
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), BC_ENONODE);

	/* What undoes a batch gives every name back, in a mirror too. */
	{
		struct bc_tree *before = bc_tree_create(), *mirror;
		struct bc_proto_edit_op ops[3];
		struct bc_msg_edit_applied ea = {.order = 1, .author = 1};
		REQUIRE(before && bc_tree_copy(before, t, NULL) == 0);
		ops[0] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_NAME,
		                                   .node = 5};
		ops[0].name.ptr = "five";
		ops[0].name.len = 4;
		ops[1] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_NAME,
		                                   .node = 1};
		ops[2] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
		                                   .node = 3};
		memset(&batch, 0, sizeof(batch));
		REQUIRE(bc_edit_batch_apply_undoable(&batch, &t, ops, 3, &ei) ==
		        0);
		CHECK(named(t, 1, NULL) && named(t, 3, NULL) &&
		      named(t, 4, NULL));
		mirror = bc_tree_create();
		REQUIRE(mirror && bc_tree_copy(mirror, t, NULL) == 0);
		ea.nops = (uint16_t)batch.inv.nops;
		ea.ops = batch.inv.ops;
		CHECK_EQ_INT(bc_edit_replay(&mirror, &ea, &ei), 0);
		CHECK(same(mirror, before));
		CHECK(named(mirror, 3, "pair\\\x01") &&
		      named(mirror, 4, "\xc3\xa9t\xc3\xa9") &&
		      named(mirror, 1, "all") && named(mirror, 5, NULL));
		bc_edit_batch_finish(&batch);
		bc_tree_destroy(mirror);
		bc_tree_destroy(before);
	}
	bc_tree_destroy(c);
	bc_tree_destroy(t);
}

static void allocation_failures_keep_the_tree(void)
{
	struct bc_tree *t = load(), *c = bc_tree_create();
	struct bc_errinfo ei = {0};
	int failures = 0;
	REQUIRE(c);
	for (unsigned long k = 1; k < 64; k++) {
		int rc;
		bc_alloc_fail_after(k);
		rc = bc_tree_copy(c, t, &ei);
		bc_alloc_fail_after(0);
		if (rc == 0) {
			CHECK(same(c, t));
			break;
		}
		CHECK_EQ_INT(rc, BC_ENOMEM);
		CHECK_EQ_INT(bc_tree_node_count(c), 0);
		failures++;
	}
	CHECK(failures > 1);
	bc_tree_destroy(c);
	bc_tree_destroy(t);
}

/* A tree told to keep no names (a server's render copy): a copy, a parse,
 * INSERT, REPLACE and NAME bring none, while every edit applies as in a
 * tree with names, refusals included, and the layout is the same; the
 * choice survives being emptied, and only an empty tree changes it. */
static void a_nameless_tree_keeps_none(void)
{
	struct bc_tree *t = load(), *c = bc_tree_create(), *named_copy;
	struct bc_errinfo ei = {0};
	struct bc_proto_buf b;
	struct bc_proto_edit_op op = {0};
	REQUIRE(c && (named_copy = bc_tree_create()));
	CHECK_EQ_INT(bc_tree_set_names(t, false), BC_ESTATE);
	REQUIRE(bc_tree_set_names(c, false) == 0);
	REQUIRE(bc_tree_copy(c, t, NULL) == 0);
	CHECK_EQ_INT(bc_tree_name_count(c), 0);
	CHECK(named(c, 1, NULL) && named(c, 2, NULL));
	CHECK_EQ_INT(bc_tree_node_count(c), bc_tree_node_count(t));
	REQUIRE(bc_tree_copy(named_copy, t, NULL) == 0);
	/* Edits apply alike; names are checked, not kept. */
	op = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT, .node = 1, .position = 0};
	op.subtree = sphere_scene(40, "forty", &b);
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), 0);
	CHECK_EQ_INT(bc_edit_apply_op(named_copy, &op, &ei), 0);
	bc_proto_buf_finish(&b);
	CHECK(named(c, 40, NULL) && named(named_copy, 40, "forty"));
	op = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_NAME, .node = 5};
	op.name.ptr = "five";
	op.name.len = 4;
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), 0);
	CHECK(named(c, 5, NULL));
	op.node = 99;
	CHECK_EQ_INT(bc_edit_apply_op(c, &op, &ei), BC_ENONODE);
	CHECK_EQ_INT(bc_tree_set_name(c, 5, "a\0b", 3, &ei), BC_ESTRING);
	CHECK_EQ_INT(bc_tree_name_count(c), 0);
	{
		const struct bc_lin *x = bc_tree_lin(c),
		                    *y = bc_tree_lin(named_copy);
		REQUIRE(x && y);
		CHECK(x->count == y->count && x->nparam == y->nparam &&
		      memcmp(x->node, y->node,
		             2u * x->count * sizeof(uint32_t)) == 0 &&
		      memcmp(x->param, y->param,
		             4u * x->nparam * sizeof(float)) == 0);
	}
	/* Emptied and filled again by a parse: still none. */
	REQUIRE(bc_scene_parse_json(json, strlen(json), c, NULL, &ei) == 0);
	CHECK_EQ_INT(bc_tree_name_count(c), 0);
	CHECK_EQ_INT(bc_tree_node_count(c), bc_tree_node_count(t));
	bc_tree_destroy(named_copy);
	bc_tree_destroy(c);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"names_are_set_read_and_taken_away", names_are_set_read_and_taken_away},
    {"encodings_carry_names_bit_for_bit", encodings_carry_names_bit_for_bit},
    {"edits_move_names_with_their_nodes", edits_move_names_with_their_nodes},
    {"allocation_failures_keep_the_tree", allocation_failures_keep_the_tree},
    {"a_nameless_tree_keeps_none", a_nameless_tree_keeps_none},
};

BC_TEST_MAIN(tests)
