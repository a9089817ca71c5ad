/*
 * Scene generators: the primitive counts each one promises (fig16 level L
 * has 10 (10^L - 1) / 9, fig18 count N has N instances, ...), the shape of
 * their trees, determinism (same options, same bytes; another seed, another
 * scene), coverage of every primitive and operator kind by `random`, cameras
 * that look at the scene from outside it, and option checking.
 */
#include <stdint.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "scene_util.h"
#include "test.h"

/* The camera is valid, its eye outside the scene's bounds and its target
 * inside them. */
static void check_camera_frames(const struct bc_tree *t,
                                const struct bc_camera *cam)
{
	const struct bc_lin *l = bc_tree_lin(t);
	bool eye_out = false, target_in = true;
	CHECK_EQ_INT(bc_camera_validate(cam, NULL), 0);
	REQUIRE(l);
	for (int i = 0; i < 3; i++) {
		eye_out =
		    eye_out || cam->eye[i] < l->lo[i] || cam->eye[i] > l->hi[i];
		target_in = target_in && cam->target[i] >= l->lo[i] &&
		            cam->target[i] <= l->hi[i];
	}
	CHECK(eye_out);
	CHECK(target_in);
}

static uint32_t fig16_prims(uint32_t level)
{
	uint32_t p = 1;
	for (uint32_t i = 0; i < level; i++) {
		p *= 10;
	}
	return 10 * (p - 1) / 9;
}

static void fig16_levels_have_the_papers_counts(void)
{
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (uint32_t level = 1; level <= 3; level++) {
		for (int smooth = 0; smooth < 2; smooth++) {
			struct bc_gen_opts o = {
			    .level = level,
			    .blend = smooth ? BC_GEN_BLEND_SMOOTH
			                    : BC_GEN_BLEND_SHARP};
			struct bc_camera cam;
			struct bc_op_data op;
			uint32_t aggs = fig16_prims(level) / 10;
			uint32_t last = aggs - fig16_prims(level - 1) / 10;
			CHECK_EQ_INT(bc_gen("fig16", &o, t, &cam, NULL), 0);
			CHECK_EQ_INT(bc_tree_prim_count(t), fig16_prims(level));
			/* One operator per aggregate, one per level above
			 * the base. */
			CHECK_EQ_INT(bc_tree_node_count(t),
			             fig16_prims(level) + aggs + level - 1);
			REQUIRE(bc_tree_get(t, bc_tree_root(t), NULL, &op));
			CHECK_EQ_INT(op.kind,
			             smooth ? BC_OP_SMOOTH_UNION : BC_OP_UNION);
			/* The root holds everything larger, then the
			 * smallest level's 10^(L-1) aggregates. */
			CHECK_EQ_INT(bc_tree_child_count(t, bc_tree_root(t)),
			             level == 1 ? 10 : 1 + last);
			check_camera_frames(t, &cam);
		}
	}
	bc_tree_destroy(t);
}

static void fig18_has_count_instances(void)
{
	static const uint32_t counts[] = {1, 2, 17, 256};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(counts) / sizeof(counts[0]); i++) {
		for (int kind = 1; kind < BC_GEN_KIND_COUNT; kind++) {
			struct bc_gen_opts o = {.count = counts[i],
			                        .kind = (enum bc_gen_kind)kind,
			                        .blend = BC_GEN_BLEND_SMOOTH};
			struct bc_camera cam;
			uint32_t per = kind == BC_GEN_KIND_LENSES ? 2 : 1;
			uint32_t root;
			CHECK_EQ_INT(bc_gen("fig18", &o, t, &cam, NULL), 0);
			CHECK_EQ_INT(bc_tree_prim_count(t), counts[i] * per);
			root = bc_tree_root(t);
			/* One n-ary operator over all instances: a left
			 * comb once linearized. */
			if (counts[i] > 1) {
				CHECK_EQ_INT(bc_tree_child_count(t, root),
				             counts[i]);
			}
			check_camera_frames(t, &cam);
		}
	}
	bc_tree_destroy(t);
}

static void comb_and_many_spheres_counts(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_gen_opts o = {.count = 1000};
	struct bc_op_data op;
	REQUIRE(t);
	CHECK_EQ_INT(bc_gen("comb", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 1000);
	CHECK_EQ_INT(bc_tree_child_count(t, bc_tree_root(t)), 1000);
	REQUIRE(bc_tree_get(t, bc_tree_root(t), NULL, &op));
	CHECK_EQ_INT(op.kind, BC_OP_UNION);
	check_camera_frames(t, &cam);
	o.blend = BC_GEN_BLEND_SMOOTH;
	CHECK_EQ_INT(bc_gen("comb", &o, t, &cam, NULL), 0);
	REQUIRE(bc_tree_get(t, bc_tree_root(t), NULL, &op));
	CHECK_EQ_INT(op.kind, BC_OP_SMOOTH_UNION);
	o.blend = 0;
	o.count = 0;
	CHECK_EQ_INT(bc_gen("many-spheres", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 2745);
	o.count = 5;
	CHECK_EQ_INT(bc_gen("many-spheres", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 5);
	check_camera_frames(t, &cam);
	bc_tree_destroy(t);
}

/* Primitives of a gear with n teeth: disc, teeth, hub, and four holes from
 * 12 teeth on (documented in docs/scene-format.md). */
static uint32_t gear_prims(uint32_t n)
{
	return 2 + n + (n >= 12 ? 4 : 0);
}

static void gears_have_their_parts(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_gen_opts o = {.teeth = 30};
	REQUIRE(t);
	CHECK_EQ_INT(bc_gen("gears", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t),
	             gear_prims(30) + gear_prims(20) + gear_prims(15));
	CHECK_EQ_INT(bc_tree_child_count(t, bc_tree_root(t)), 3);
	check_camera_frames(t, &cam);
	o.teeth = 6;
	CHECK_EQ_INT(bc_gen("gears", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 3 * gear_prims(6));
	o.teeth = 16;
	o.count = 10;
	CHECK_EQ_INT(bc_gen("many-gears", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 10 * gear_prims(16));
	CHECK_EQ_INT(bc_tree_child_count(t, bc_tree_root(t)), 10);
	check_camera_frames(t, &cam);
	bc_tree_destroy(t);
}

static void random_uses_every_kind_within_the_depth(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_gen_opts o = {.count = 3000, .seed = 42, .depth = 9};
	struct bc_camera cam;
	struct bc_scene_walk w;
	struct bc_scene_node n;
	bool kinds[BC_PRIM_COUNT] = {0}, ops[BC_OP_COUNT] = {0};
	uint32_t deepest = 0;
	REQUIRE(t);
	CHECK_EQ_INT(bc_gen("random", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 3000);
	REQUIRE(bc_scene_walk_init(&w, t) == 0);
	while (bc_scene_walk_next(&w, &n)) {
		if (n.is_op) {
			ops[n.op.kind] = true;
		} else {
			kinds[n.prim.kind] = true;
		}
		deepest = n.depth > deepest ? n.depth : deepest;
	}
	bc_scene_walk_finish(&w);
	/* The sixteen kinds random trees draw from (gen.c keeps seeds
	 * naming the same scenes as kinds are added; the catalogue generator
	 * has every kind). */
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		if (!kinds[k] && k <= BC_PRIM_TRI_PRISM) {
			fprintf(stderr, "  no %s\n", bc_prim_info(k)->name);
		}
		CHECK(kinds[k] == (k <= BC_PRIM_TRI_PRISM));
	}
	for (int k = 1; k < BC_OP_FIRST_UNARY; k++) {
		CHECK(ops[k]);
	}
	CHECK(deepest < 9);
	CHECK(deepest >= 5);

	/* Deep trees up to the model's limit. */
	o.count = 400;
	o.depth = BC_GEN_RANDOM_MAX_DEPTH;
	for (uint64_t seed = 0; seed < 8; seed++) {
		o.seed = seed;
		CHECK_EQ_INT(bc_gen("random", &o, t, &cam, NULL), 0);
		CHECK_EQ_INT(bc_tree_prim_count(t), 400);
	}
	o.count = 1;
	CHECK_EQ_INT(bc_gen("random", &o, t, &cam, NULL), 0);
	CHECK_EQ_INT(bc_tree_node_count(t), 1);
	bc_tree_destroy(t);
}

/* Same options give the same bytes; another seed gives another scene. */
static void generators_are_deterministic(void)
{
	size_t n;
	const struct bc_gen_info *list = bc_gen_list(&n);
	struct bc_tree *a = bc_tree_create(), *b = bc_tree_create();
	REQUIRE(a && b);
	CHECK(n >= 7);
	for (size_t i = 0; i < n; i++) {
		struct bc_gen_opts o = {0};
		struct bc_camera ca, cb;
		uint8_t *ba = NULL, *bb = NULL;
		size_t la = 0, lb = 0;
		if (list[i].takes & BC_GEN_OPT_COUNT) {
			o.count = 40;
		}
		CHECK_EQ_INT(bc_gen(list[i].name, &o, a, &ca, NULL), 0);
		CHECK_EQ_INT(bc_gen(list[i].name, &o, b, &cb, NULL), 0);
		REQUIRE(bc_scene_encode(a, &ca, &ba, &la) == 0);
		REQUIRE(bc_scene_encode(b, &cb, &bb, &lb) == 0);
		CHECK(la == lb && memcmp(ba, bb, la) == 0);
		bc_free(bb);
		bb = NULL;
		if (list[i].takes & BC_GEN_OPT_SEED) {
			o.seed = 987654321;
			CHECK_EQ_INT(bc_gen(list[i].name, &o, b, &cb, NULL), 0);
			REQUIRE(bc_scene_encode(b, &cb, &bb, &lb) == 0);
			CHECK(la != lb || memcmp(ba, bb, la) != 0);
		}
		CHECK(bc_gen_find(list[i].name) == &list[i]);
		bc_free(ba);
		bc_free(bb);
	}
	bc_tree_destroy(a);
	bc_tree_destroy(b);
}

static void bad_options_are_refused(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
		int code;
	} cases[] = {
	    {"fig17", {0}, BC_ENOTFOUND},
	    {"fig16", {.level = BC_GEN_MAX_LEVEL + 1}, BC_ERANGE},
	    {"fig16", {.count = 5}, BC_EINVAL},
	    {"fig16", {.kind = BC_GEN_KIND_BOXES}, BC_EINVAL},
	    {"fig18", {.level = 2}, BC_EINVAL},
	    {"fig18", {.count = BC_GEN_MAX_PRIMS + 1}, BC_ELIMIT},
	    {"fig18",
	     {.count = BC_GEN_MAX_PRIMS / 2 + 1, .kind = BC_GEN_KIND_LENSES},
	     BC_ELIMIT},
	    {"fig18", {.kind = BC_GEN_KIND_COUNT}, BC_ERANGE},
	    {"comb", {.seed = 3}, BC_EINVAL},
	    {"comb", {.blend = BC_GEN_BLEND_COUNT}, BC_ERANGE},
	    {"random", {.depth = 1}, BC_ERANGE},
	    {"random", {.depth = BC_GEN_RANDOM_MAX_DEPTH + 1}, BC_ERANGE},
	    {"random", {.teeth = 12}, BC_EINVAL},
	    {"gears", {.teeth = 5}, BC_ERANGE},
	    {"gears", {.teeth = BC_GEN_MAX_TEETH + 1}, BC_ERANGE},
	    {"gears", {.count = 2}, BC_EINVAL},
	    {"many-gears", {.count = 200000}, BC_ELIMIT},
	    {"many-spheres", {.blend = BC_GEN_BLEND_SMOOTH}, BC_EINVAL},
	};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bc_errinfo ei = {0};
		struct bc_camera cam;
		int rc = bc_gen(cases[i].name, &cases[i].o, t, &cam, &ei);
		if (rc != cases[i].code) {
			fprintf(stderr, "  case %zu (%s): got %s \"%s\"\n", i,
			        cases[i].name, bc_err_name(rc), ei.msg);
		}
		CHECK_EQ_INT(rc, cases[i].code);
		CHECK(ei.msg[0] != '\0');
		CHECK(tree_is_empty(t));
	}
	CHECK(bc_gen_find("nope") == NULL);
	CHECK_EQ_INT(bc_gen_kind_from_name("lenses"), BC_GEN_KIND_LENSES);
	CHECK_EQ_INT(bc_gen_kind_from_name("cubes"), BC_GEN_KIND_DEFAULT);
	CHECK_EQ_INT(bc_gen_blend_from_name("smooth"), BC_GEN_BLEND_SMOOTH);
	CHECK_EQ_INT(bc_gen_blend_from_name(""), BC_GEN_BLEND_DEFAULT);
	bc_tree_destroy(t);
}

static void generation_failures_free_everything(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_gen_opts o = {.level = 2};
	unsigned long n;
	REQUIRE(t);
	for (n = 1; n < 100000; n++) {
		int rc;
		bc_alloc_fail_after(n);
		rc = bc_gen("fig16", &o, t, NULL, NULL);
		bc_alloc_fail_after(0);
		if (rc == 0) {
			break;
		}
		CHECK_EQ_INT(rc, BC_ENOMEM);
		CHECK(tree_is_empty(t));
	}
	CHECK(n > 1);
	CHECK_EQ_INT(bc_tree_prim_count(t), 110);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"fig16_levels_have_the_papers_counts",
     fig16_levels_have_the_papers_counts},
    {"fig18_has_count_instances", fig18_has_count_instances},
    {"comb_and_many_spheres_counts", comb_and_many_spheres_counts},
    {"gears_have_their_parts", gears_have_their_parts},
    {"random_uses_every_kind_within_the_depth",
     random_uses_every_kind_within_the_depth},
    {"generators_are_deterministic", generators_are_deterministic},
    {"bad_options_are_refused", bad_options_are_refused},
    {"generation_failures_free_everything",
     generation_failures_free_everything},
};

BC_TEST_MAIN(tests)
