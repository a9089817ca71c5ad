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

static const struct bc_test tests[] = {
    {"scene_vectors_agree_with_blobtree",
     test_scene_vectors_agree_with_blobtree},
    {"blobtree_encodings_scan", test_blobtree_encodings_scan},
};

BC_TEST_MAIN(tests)
