/*
 * Every primitive kind through both scene encodings: the catalogue scene
 * (each kind once, random rotations, colours) written to JSON and parsed
 * back, and encoded to the binary form and decoded, gives the same kinds,
 * parameters, transforms and colours bit for bit; each kind with one
 * parameter component missing from its JSON object, or its binary float
 * count off by one, is refused with a reason.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "test.h"

/* The catalogue's primitives are its root's children, ids 2.. in kind
 * order. */
static void same_prims(const struct bc_tree *a, const struct bc_tree *b)
{
	uint32_t n = bc_tree_child_count(a, bc_tree_root(a));
	bool kinds[BC_PRIM_COUNT] = {0};
	CHECK_EQ_INT(n, BC_PRIM_COUNT - 1);
	CHECK_EQ_INT(bc_tree_child_count(b, bc_tree_root(b)), n);
	for (uint32_t i = 0; i < n; i++) {
		uint32_t id = bc_tree_child(a, bc_tree_root(a), i);
		struct bc_prim_data pa, pb;
		REQUIRE(bc_tree_get(a, id, &pa, NULL));
		REQUIRE(bc_tree_get(b, id, &pb, NULL));
		kinds[pa.kind] = true;
		CHECK_EQ_INT(pa.kind, pb.kind);
		CHECK(memcmp(pa.params, pb.params, sizeof(pa.params)) == 0);
		CHECK(memcmp(pa.translate, pb.translate,
		             sizeof(pa.translate)) == 0);
		CHECK(memcmp(pa.rotate, pb.rotate, sizeof(pa.rotate)) == 0);
		CHECK(pa.has_color == pb.has_color);
		CHECK(memcmp(pa.color, pb.color, sizeof(pa.color)) == 0);
	}
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		CHECK(kinds[k]);
	}
}

static void every_kind_round_trips(void)
{
	struct bc_tree *t = bc_tree_create(), *u = bc_tree_create(),
	               *v = bc_tree_create();
	struct bc_camera cam, cam2;
	struct bc_errinfo ei = {0};
	uint8_t *bin = NULL;
	size_t len = 0;
	char *json;
	REQUIRE(t && u && v);
	REQUIRE(bc_gen("catalogue", &(struct bc_gen_opts){.seed = 5}, t, &cam,
	               &ei) == 0);
	json = bc_scene_to_json(t, &cam);
	REQUIRE(json);
	if (bc_scene_parse_json(json, strlen(json), u, &cam2, &ei)) {
		fprintf(stderr, "  json: %s\n", ei.msg);
		CHECK(0);
	} else {
		same_prims(t, u);
	}
	REQUIRE(bc_scene_encode(t, &cam, &bin, &len) == 0);
	if (bc_scene_decode(bin, len, v, &cam2, NULL, &ei)) {
		fprintf(stderr, "  binary: %s\n", ei.msg);
		CHECK(0);
	} else {
		same_prims(t, v);
	}
	bc_free(bin);
	bc_free(json);
	bc_tree_destroy(t);
	bc_tree_destroy(u);
	bc_tree_destroy(v);
}

/* A JSON scene of one primitive of kind at its defaults, with parameter
 * skip left out (-1: none). */
static void one_prim_json(enum bc_prim kind, int skip, char *buf, size_t cap)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	struct bc_prim_data p;
	size_t o;
	bc_prim_data_init(&p, kind);
	o = (size_t)snprintf(buf, cap,
	                     "{\"blobcast\": 1, \"root\": {\"type\": \"%s\"",
	                     info->name);
	for (int i = 0; i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		if (i == skip) {
			continue;
		}
		o += (size_t)snprintf(buf + o, cap - o, ", \"%s\": ", d->name);
		if (d->count == 3) {
			o += (size_t)snprintf(buf + o, cap - o,
			                      "[%.9g, %.9g, %.9g]",
			                      (double)p.params[d->offset],
			                      (double)p.params[d->offset + 1],
			                      (double)p.params[d->offset + 2]);
		} else {
			o += (size_t)snprintf(buf + o, cap - o, "%.9g",
			                      (double)p.params[d->offset]);
		}
	}
	snprintf(buf + o, cap - o, "}}");
}

static void missing_parameters_are_refused(void)
{
	char buf[1024];
	for (int k = BC_PRIM_CUT_SPHERE; k < BC_PRIM_COUNT; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		struct bc_tree *t = bc_tree_create();
		struct bc_errinfo ei = {0};
		REQUIRE(t);
		one_prim_json((enum bc_prim)k, -1, buf, sizeof(buf));
		CHECK(bc_scene_parse_json(buf, strlen(buf), t, NULL, &ei) == 0);
		for (int i = 0; i < info->nparams; i++) {
			if (info->params[i].flags & BC_PARAM_OPTIONAL) {
				continue;
			}
			one_prim_json((enum bc_prim)k, i, buf, sizeof(buf));
			memset(&ei, 0, sizeof(ei));
			CHECK(bc_scene_parse_json(buf, strlen(buf), t, NULL,
			                          &ei) != 0);
			CHECK(strstr(ei.msg, info->params[i].name) != NULL);
		}
		bc_tree_destroy(t);
	}
}

static const struct bc_test tests[] = {
    {"every_kind_round_trips", every_kind_round_trips},
    {"missing_parameters_are_refused", missing_parameters_are_refused},
};

BC_TEST_MAIN(tests)
