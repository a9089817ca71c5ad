/*
 * PROTOCOL.md documents the scene encoding that blobtree owns, and
 * bc_proto_scene_scan() makes the checks the document lists in blobtree's
 * order. This test keeps the three in step: every scene vector, and scenes
 * encoded by blobtree itself, get the same verdict and the same error code
 * from the scanner and from blobtree's decoder. The one difference allowed
 * is the one the document states: blobtree requires each primitive kind's
 * exact parameter count, which the scanner only bounds.
 */
#include <jansson.h>
#include <stdint.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/proto.h"
#include "blobcast/scene.h"
#include "test.h"

#ifndef BC_VECTORS_DIR
#define BC_VECTORS_DIR "protocol/vectors"
#endif

static size_t unhex(const char *hex, uint8_t *out, size_t cap)
{
	size_t n = strlen(hex) / 2;
	for (size_t i = 0; i < n && i < cap; i++) {
		unsigned v = 0;
		sscanf(hex + 2 * i, "%2x", &v);
		out[i] = (uint8_t)v;
	}
	return n < cap ? n : cap;
}

static int blobtree_verdict(const uint8_t *b, size_t n, struct bc_errinfo *ei)
{
	struct bc_tree *t = bc_tree_create();
	if (!t) {
		return BC_ENOMEM;
	}
	int rc = bc_scene_decode(b, n, t, NULL, NULL, ei);
	bc_tree_destroy(t);
	return rc;
}

static void test_scene_vectors_agree_with_blobtree(void)
{
	static uint8_t b[1 << 16];
	json_error_t jerr;
	json_t *doc = json_load_file(BC_VECTORS_DIR "/scene.json", 0, &jerr);
	REQUIRE(doc);
	const char *lists[2] = {"valid", "invalid"};
	int n = 0;
	for (int l = 0; l < 2; l++) {
		size_t i;
		json_t *e;
		json_array_foreach(json_object_get(doc, lists[l]), i, e)
		{
			const char *hex =
			    json_string_value(json_object_get(e, "hex"));
			size_t len = unhex(hex, b, sizeof(b));
			struct bc_errinfo e1 = {0}, e2 = {0};
			int scan = bc_proto_scene_scan(b, len, NULL, &e1);
			int tree = blobtree_verdict(b, len, &e2);
			if (scan != tree) {
				fprintf(
				    stderr,
				    "  %s: scan %s (%s), blobtree %s (%s)\n",
				    json_string_value(
				        json_object_get(e, "name")),
				    bc_err_name(scan), e1.msg,
				    bc_err_name(tree), e2.msg);
				bc_test_failures++;
			}
			n++;
		}
	}
	CHECK(n >= 25);
	json_decref(doc);
}

/* Scenes blobtree writes scan cleanly, to blobtree's own counts. */
static void test_blobtree_encodings_scan(void)
{
	static const float r1[1] = {1.0f};
	for (uint32_t width = 2; width <= 40; width += 7) {
		struct bc_tree *t = bc_tree_create();
		struct bc_errinfo ei = {0};
		struct bc_prim_data p;
		struct bc_op_data op = {BC_OP_SMOOTH_UNION, 0.25f, 0.25f};
		REQUIRE(t);
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		memcpy(p.params, r1, sizeof(r1));
		CHECK(bc_tree_begin(t) == 0);
		CHECK(bc_tree_push_op(t, 0, &op, &ei) == 0);
		for (uint32_t k = 0; k < width; k++) {
			p.translate[0] = (float)k;
			CHECK(bc_tree_put_prim(t, 0, &p, &ei) == 0);
		}
		CHECK(bc_tree_pop_op(t, &ei) == 0);
		int rc = bc_tree_end(t, &ei);
		if (rc) {
			fprintf(stderr, "  build: %s\n", ei.msg);
		}
		REQUIRE(rc == 0);
		uint8_t *bytes = NULL;
		size_t len = 0;
		struct bc_camera cam;
		bc_camera_default(&cam);
		REQUIRE(bc_scene_encode(t, &cam, &bytes, &len) == 0);
		struct bc_proto_scene_info info;
		CHECK(bc_proto_scene_scan(bytes, len, &info, &ei) == 0);
		CHECK(info.has_camera);
		CHECK(info.nodes == bc_tree_node_count(t));
		CHECK(info.prims == bc_tree_prim_count(t));
		CHECK(info.depth == 2);
		bc_free(bytes);
		bc_tree_destroy(t);
	}
}

/* The parameters of every primitive and unary kind, as blobtree describes
 * them, fit the table's parameter fields (proto_fields.h): as many fields
 * as the PARAM0 row has numbers, each with a value count the decoder
 * accepts, and no parameter named like a fixed key (the key=value parser
 * would find the fixed field first). */
static bool named_key(const char *name)
{
	for (unsigned f = 1; f < 64; f++) {
		const struct bc_proto_field_info *r = bc_proto_field_info(f);
		if (r && r->key && strcmp(r->key, name) == 0) {
			return true;
		}
	}
	return false;
}

static void test_kind_params_fit_the_field_table(void)
{
	const struct bc_proto_field_info *par =
	    bc_proto_field_info(BC_PROTO_FIELD_PARAM0);
	REQUIRE(par && !par->key);
	CHECK(par->flags & BC_PROTO_ON_PRIM);
	CHECK(par->flags & BC_PROTO_ON_UNARY);
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		REQUIRE(info);
		CHECK(info->nparams <= par->numbers);
		for (uint32_t i = 0; i < info->nparams; i++) {
			const struct bc_param_desc *d = &info->params[i];
			CHECK(d->count >= par->min_values &&
			      d->count <= par->max_values);
			if (named_key(d->name)) {
				fprintf(stderr, "  %s.%s is a fixed key\n",
				        info->name, d->name);
				CHECK(false);
			}
		}
	}
	for (int k = BC_OP_FIRST_UNARY; k < BC_OP_COUNT; k++) {
		const struct bc_unary_info *u = bc_unary_info((enum bc_op)k);
		REQUIRE(u);
		/* repeat: spacing and count, 3 values each; the others one
		 * field of nparams values (edit/fields.c). */
		uint32_t per = k == BC_OP_REPEAT ? 3u : u->nparams;
		CHECK(per >= par->min_values && per <= par->max_values);
		CHECK(u->nparams <= BC_PROTO_MAX_UNARY_PARAMS);
		CHECK(!named_key(u->param));
	}
	/* Each operator kind is a valid OP_KIND value; the table says which
	 * nodes the kind field applies to. */
	const struct bc_proto_field_info *kind =
	    bc_proto_field_info(BC_PROTO_FIELD_OP_KIND);
	REQUIRE(kind);
	CHECK(kind->flags & BC_PROTO_ON_OP);
	CHECK(kind->flags & BC_PROTO_ON_UNARY);
	CHECK(!(kind->flags & BC_PROTO_ON_PRIM));
	CHECK(!(kind->flags & BC_PROTO_IN_SCENE));
	CHECK(!bc_proto_field_info(0));
	CHECK(!bc_proto_field_info(BC_PROTO_FIELD_PARAM0 +
	                           BC_PROTO_MAX_PRIM_PARAMS));
	CHECK(!bc_proto_field_info(255));
}

/* The keys the table marks as scene file members are the members
 * blobtree's JSON writer uses for them: a coloured, moved, turned sphere
 * under a smooth union has exactly its table keys, its parameters, "type"
 * and "id"; the union has its table keys, "type", "id" and "children". */
static void check_members(json_t *node, unsigned on, const char *const *more,
                          size_t nmore)
{
	const char *key;
	json_t *v;
	size_t want = nmore;
	REQUIRE(json_is_object(node));
	for (unsigned f = 1; f < 64; f++) {
		const struct bc_proto_field_info *r = bc_proto_field_info(f);
		if (!r || !r->key || f != r->first || !(r->flags & on) ||
		    !(r->flags & BC_PROTO_IN_SCENE)) {
			continue;
		}
		want++;
		if (!json_object_get(node, r->key)) {
			fprintf(stderr, "  no \"%s\" in the scene file\n",
			        r->key);
			CHECK(false);
		}
	}
	json_object_foreach(node, key, v)
	{
		bool known = false;
		for (size_t i = 0; i < nmore; i++) {
			known = known || strcmp(key, more[i]) == 0;
		}
		known = known || named_key(key);
		if (!known) {
			fprintf(stderr, "  \"%s\" is not in the table\n", key);
			CHECK(false);
		}
	}
	CHECK_EQ_INT(json_object_size(node), want);
}

static void test_scene_file_keys_match_the_field_table(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_prim_data p;
	struct bc_op_data op = {BC_OP_SMOOTH_UNION, 0.25f, 0.5f};
	struct bc_camera cam;
	json_error_t jerr;
	REQUIRE(t);
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 1.0f;
	p.translate[0] = 0.5f;
	p.rotate[2] = 0.6f;
	p.rotate[3] = 0.8f;
	p.color[0] = 1.0f;
	p.has_color = true;
	CHECK(bc_tree_begin(t) == 0);
	CHECK(bc_tree_push_op(t, 1, &op, &ei) == 0);
	CHECK(bc_tree_put_prim(t, 2, &p, &ei) == 0);
	p.translate[0] = -0.5f;
	CHECK(bc_tree_put_prim(t, 3, &p, &ei) == 0);
	CHECK(bc_tree_pop_op(t, &ei) == 0);
	REQUIRE(bc_tree_end(t, &ei) == 0);
	bc_camera_default(&cam);
	char *text = bc_scene_to_json(t, &cam);
	REQUIRE(text);
	json_t *doc = json_loads(text, 0, &jerr);
	REQUIRE(doc);
	json_t *root = json_object_get(doc, "root");
	static const char *const op_more[] = {"type", "id", "children"};
	check_members(root, BC_PROTO_ON_OP, op_more, 3);
	json_t *kids = json_object_get(root, "children");
	REQUIRE(json_is_array(kids) && json_array_size(kids) == 2);
	const struct bc_prim_info *info = bc_prim_info(BC_PRIM_SPHERE);
	REQUIRE(info && info->nparams == 1);
	const char *prim_more[] = {"type", "id", info->params[0].name};
	check_members(json_array_get(kids, 0), BC_PROTO_ON_PRIM, prim_more, 3);
	json_decref(doc);
	bc_free(text);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"kind_params_fit_the_field_table", test_kind_params_fit_the_field_table},
    {"scene_file_keys_match_the_field_table",
     test_scene_file_keys_match_the_field_table},
    {"scene_vectors_agree_with_blobtree",
     test_scene_vectors_agree_with_blobtree},
    {"blobtree_encodings_scan", test_blobtree_encodings_scan},
};

BC_TEST_MAIN(tests)
