/*
 * Deep trees: chains far past the old 128-level limit through the binary
 * encoding, the builder, linearization, full and sparse evaluation, edits
 * and JSON (up to what jansson can hold); the graft check at exactly the
 * depth limit; the evaluation-stack limit; and Lipschitz Pruning's Molecule
 * as its 1001-deep chain of pairwise smooth unions.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "scene_util.h"
#include "test.h"

#ifndef DEEP
#define DEEP 100000u
#endif

static double now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec / 1e6;
}

static void sphere_at(struct bc_prim_data *p, float x, float y)
{
	bc_prim_data_init(p, BC_PRIM_SPHERE);
	p->params[0] = 0.3f;
	p->translate[0] = x;
	p->translate[1] = y;
}

/* A left chain of n pairwise smooth unions (as programs emit them:
 * u(u(u(s, s), s), s)...): ops get ids 1..n from the root down, spheres
 * n + 1 onwards; the spheres walk along a spiral so that blends overlap. */
static int left_chain(struct bc_tree *t, uint32_t n, enum bc_op kind)
{
	struct bc_op_data op = {kind, 0.0f, 0.0f};
	struct bc_prim_data p;
	uint32_t id = n + 1;
	int rc = 0;
	if (bc_op_is_smooth(kind)) {
		op.blend = 0.2f;
	}
	bc_tree_begin(t);
	for (uint32_t i = 0; i < n && !rc; i++) {
		rc = bc_tree_push_op(t, i + 1, &op, NULL);
	}
	for (uint32_t i = 0; i <= n && !rc; i++) {
		float a = 0.37f * (float)(i % 1000);
		sphere_at(&p, cosf(a) * (1.0f + (float)(i % 7)),
		          sinf(a) * (1.0f + (float)(i % 5)));
		rc = bc_tree_put_prim(t, id++, &p, NULL);
		if (!rc && i > 0) {
			rc = bc_tree_pop_op(t, NULL);
		}
	}
	return rc ? rc : bc_tree_end(t, NULL);
}

/* Encodes t, decodes it into a fresh tree and re-encodes: the bytes must
 * agree. Returns true when they do. */
static bool round_trips(const struct bc_tree *t)
{
	uint8_t *a = NULL, *b = NULL;
	size_t na = 0, nb = 0;
	struct bc_tree *u = bc_tree_create();
	struct bc_errinfo ei = {0};
	bool ok = u && bc_tree_encode(t, &a, &na) == 0 &&
	          bc_tree_decode(a, na, u, &ei) == 0 &&
	          bc_tree_encode(u, &b, &nb) == 0 && na == nb &&
	          memcmp(a, b, na) == 0;
	if (!ok) {
		fprintf(stderr, "  round trip: %s\n", ei.msg);
	}
	bc_free(a);
	bc_free(b);
	bc_tree_destroy(u);
	return ok;
}

static void deep_chain_round_trips_through_binary(void)
{
	struct bc_tree *t = bc_tree_create();
	double t0;
	REQUIRE(t);
	t0 = now_ms();
	REQUIRE(left_chain(t, DEEP, BC_OP_SMOOTH_UNION) == 0);
	printf("  %u-deep chain built and linearized in %.0f ms\n", DEEP + 1,
	       now_ms() - t0);
	CHECK_EQ_INT(bc_tree_nesting(t), DEEP + 1);
	/* A left comb evaluates with two entries at any depth. */
	CHECK(bc_tree_lin(t)->stack <= 2);
	t0 = now_ms();
	CHECK(round_trips(t));
	printf("  encoded, decoded, re-encoded in %.0f ms\n", now_ms() - t0);
	bc_tree_destroy(t);
}

/* Sparse evaluation with every primitive active equals the full one; with
 * the primitives near a point active it has the full field's sign there.
 * The fast ancestor index makes a view of the whole chain one climb per
 * primitive, not a walk. */
static void deep_chain_sparse_agrees_with_full(void)
{
	struct bc_tree *t = bc_tree_create();
	const struct bc_lin *l;
	struct bc_view v, scratch;
	uint32_t *all, *near, nnear;
	double t0, build_ms;
	REQUIRE(t);
	REQUIRE(left_chain(t, DEEP, BC_OP_SMOOTH_UNION) == 0);
	l = bc_tree_lin(t);
	all = bc_malloc(sizeof(uint32_t) * l->nprims);
	near = bc_malloc(sizeof(uint32_t) * l->nprims);
	REQUIRE(all && near);
	for (uint32_t k = 0; k < l->nprims; k++) {
		all[k] = k;
	}
	bc_view_init(&v);
	bc_view_init(&scratch);
	t0 = now_ms();
	REQUIRE(bc_view_build(&v, l, all, l->nprims) == 0);
	build_ms = now_ms() - t0;
	printf("  view of %u active primitives built in %.1f ms\n", l->nprims,
	       build_ms);
	CHECK(v.stack <= l->stack);
	for (int i = 0; i < 20; i++) {
		float p[3] = {-6.0f + 0.6f * (float)i, 0.5f * (float)(i % 3),
		              0.1f};
		uint32_t who_full, who_view;
		float f = bc_eval_full_id(l, p, &who_full);
		float s = bc_view_eval_id(&v, l, p, &who_view);
		CHECK(f == s);
		CHECK_EQ_INT(who_full, who_view);
		/* The primitives whose ABVs hold p. */
		nnear = 0;
		for (uint32_t k = 0; k < l->nprims; k++) {
			float lo[3], hi[3];
			struct bc_abv a = bc_lin_abv(l, k);
			bc_abv_aabb(&a, lo, hi);
			if (p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] &&
			    p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2]) {
				near[nnear++] = k;
			}
		}
		s = bc_eval_sparse(l, near, nnear, &scratch, p);
		CHECK((f < 0.0f) == (s < 0.0f));
	}
	bc_view_finish(&v);
	bc_view_finish(&scratch);
	bc_free(all);
	bc_free(near);
	bc_tree_destroy(t);
}

static void sub_pair(struct bc_tree *sub, uint32_t id0)
{
	struct bc_op_data u = {BC_OP_UNION, 0.0f, 0.0f};
	struct bc_prim_data p;
	sphere_at(&p, 0.0f, 0.0f);
	bc_tree_begin(sub);
	bc_tree_push_op(sub, id0, &u, NULL);
	bc_tree_put_prim(sub, id0 + 1, &p, NULL);
	bc_tree_put_prim(sub, id0 + 2, &p, NULL);
	bc_tree_pop_op(sub, NULL);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
}

/* Edits at the bottom of a 100 000-deep chain: each result encodes and
 * decodes. */
static void deep_chain_edits(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_prim_data p;
	struct bc_op_data op = {BC_OP_SMOOTH_UNION, 0.4f, 0.0f};
	double t0;
	REQUIRE(t && sub);
	REQUIRE(left_chain(t, DEEP, BC_OP_SMOOTH_UNION) == 0);
	sphere_at(&p, 1.0f, 2.0f);
	/* The deepest sphere is id DEEP + 1, under op DEEP. */
	t0 = now_ms();
	CHECK_EQ_INT(bc_tree_set_prim(t, DEEP + 1, &p, &ei), 0);
	printf("  parameter edit at depth %u: %.3f ms\n", DEEP + 1,
	       now_ms() - t0);
	CHECK_EQ_INT(bc_tree_set_op(t, DEEP, &op, &ei), 0);
	CHECK_EQ_INT(bc_tree_set_op(t, 1, &op, &ei), 0);
	sub_pair(sub, 5000000);
	t0 = now_ms();
	CHECK_EQ_INT(bc_tree_insert(t, DEEP, 1, sub, &ei), 0);
	printf("  insert at depth %u: %.0f ms\n", DEEP + 1, now_ms() - t0);
	CHECK_EQ_INT(bc_tree_nesting(t), DEEP + 2);
	CHECK(round_trips(t));
	CHECK_EQ_INT(bc_tree_remove(t, 5000001, &ei), 0);
	CHECK(round_trips(t));
	/* Replacing a middle operator drops the chain below it. */
	sub_pair(sub, 6000000);
	CHECK_EQ_INT(bc_tree_replace(t, DEEP / 2, sub, &ei), 0);
	CHECK_EQ_INT(bc_tree_nesting(t), DEEP / 2 + 1);
	CHECK(round_trips(t));
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* The graft check counts what the builder counts: a subtree may land with
 * its deepest node exactly at BC_TREE_MAX_DEPTH, not one level past it. */
static void graft_reaches_the_limit_and_not_past(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_errinfo ei = {0};
	uint32_t n = BC_TREE_MAX_DEPTH - 2; /* nesting n + 1 */
	REQUIRE(t && sub);
	REQUIRE(left_chain(t, n, BC_OP_UNION) == 0);
	CHECK_EQ_INT(bc_tree_nesting(t), BC_TREE_MAX_DEPTH - 1);
	sub_pair(sub, 0x70000000u);
	/* Under the deepest operator (depth n): leaves at n + 2 = limit. */
	CHECK_EQ_INT(bc_tree_insert(t, n, 0, sub, &ei), 0);
	CHECK_EQ_INT(bc_tree_nesting(t), BC_TREE_MAX_DEPTH);
	CHECK(round_trips(t));
	/* Under the inserted operator: one past. Nothing changes. */
	sub_pair(sub, 0x71000000u);
	CHECK_EQ_INT(bc_tree_insert(t, 0x70000000u, 0, sub, &ei), BC_EDEPTH);
	CHECK(strstr(ei.msg, "deeper than") != NULL);
	/* Replacing a deepest sphere by an operator: also one past. */
	CHECK_EQ_INT(bc_tree_replace(t, 0x70000001u, sub, &ei), BC_EDEPTH);
	CHECK_EQ_INT(bc_tree_nesting(t), BC_TREE_MAX_DEPTH);
	CHECK(round_trips(t));
	/* The builder (and so the decoder) refuses the same depth. */
	CHECK_EQ_INT(left_chain(t, BC_TREE_MAX_DEPTH, BC_OP_UNION), BC_EDEPTH);
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* n unions nested in right operands, u(s, u(s, ... u(s, s))): the
 * operators get ids id0, id0 + 2, ..., their left spheres the ids between,
 * the last sphere id0 + 2n; need n + 1. Returns bc_tree_end's answer,
 * or the builder's error before it. */
static int right_chain(struct bc_tree *t, uint32_t n, uint32_t id0,
                       struct bc_errinfo *ei)
{
	struct bc_op_data u = {BC_OP_UNION, 0.0f, 0.0f};
	struct bc_prim_data p;
	uint32_t id = id0;
	int rc = 0;
	sphere_at(&p, 0.0f, 0.0f);
	bc_tree_begin(t);
	for (uint32_t i = 0; i < n && !rc; i++) {
		rc = bc_tree_push_op(t, id++, &u, NULL);
		rc = rc ? rc : bc_tree_put_prim(t, id++, &p, NULL);
	}
	rc = rc ? rc : bc_tree_put_prim(t, id++, &p, NULL);
	for (uint32_t i = 0; i < n && !rc; i++) {
		rc = bc_tree_pop_op(t, NULL);
	}
	return rc ? rc : bc_tree_end(t, ei);
}

/* Right operands nested past the evaluation stack are refused by the
 * builder and by edits, which then change nothing. */
static void right_nesting_is_bounded_by_the_eval_stack(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_errinfo ei = {0};
	uint32_t n = BC_EVAL_STACK;
	REQUIRE(t && sub);
	CHECK_EQ_INT(right_chain(t, n, 1, &ei), BC_EDEPTH);
	CHECK(strstr(ei.msg, "stack") != NULL);
	/* One level less fits; grafting a pair onto its deepest right
	 * operand (sphere 2 (n - 1) + 1) does not. */
	REQUIRE(right_chain(t, n - 1, 1, &ei) == 0);
	CHECK_EQ_INT(bc_tree_lin(t)->stack, BC_EVAL_STACK);
	sub_pair(sub, 90000);
	CHECK_EQ_INT(bc_tree_replace(t, 2 * (n - 1) + 1, sub, &ei), BC_EDEPTH);
	CHECK_EQ_INT(bc_tree_lin(t)->stack, BC_EVAL_STACK);
	CHECK(round_trips(t));
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* A node keeps its need in a byte, saturated far past BC_EVAL_STACK: a
 * graft whose need passes the byte's range (130 entries onto 129 right
 * operands deep: 259) is refused as one just past the stack is, saying
 * "or more", and changes nothing; a replacement that shrinks the need,
 * and a graft after it, are measured exactly. Laid out and bare. */
static void a_need_past_a_byte_is_refused_alike(void)
{
	for (int bare = 0; bare < 2; bare++) {
		struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
		struct bc_prim_data p;
		struct bc_errinfo ei = {0};
		uint32_t n = BC_EVAL_STACK - 1;
		REQUIRE(t && sub);
		if (bare) {
			REQUIRE(bc_tree_set_layout(t, false) == 0);
		}
		REQUIRE(right_chain(t, n, 1, NULL) == 0);
		REQUIRE(right_chain(sub, n, 100000, NULL) == 0);
		CHECK(bare || bc_tree_lin(t)->stack == BC_EVAL_STACK);
		/* The deepest sphere, 2n + 1, becomes a 130-entry subtree. */
		CHECK_EQ_INT(bc_tree_replace(t, 2 * n + 1, sub, &ei),
		             BC_EDEPTH);
		CHECK(strstr(ei.msg, "255 or more entries") != NULL);
		CHECK(bc_tree_get(t, 2 * n + 1, NULL, NULL));
		CHECK(!bc_tree_get(t, 100000, NULL, NULL));
		CHECK(bare || bc_tree_lin(t)->stack == BC_EVAL_STACK);
		CHECK(round_trips(t));
		/* The union at level 60 (id 119) becomes one sphere: 59
		 * unions above it, a need of 60. */
		bc_tree_destroy(sub);
		sub = bc_tree_create();
		REQUIRE(sub);
		sphere_at(&p, 1.0f, 0.0f);
		bc_tree_begin(sub);
		REQUIRE(bc_tree_put_prim(sub, 200000, &p, NULL) == 0);
		REQUIRE(bc_tree_end(sub, NULL) == 0);
		CHECK_EQ_INT(bc_tree_replace(t, 119, sub, &ei), 0);
		CHECK(bare || bc_tree_lin(t)->stack == 60);
		/* 59 + 71 = 130 fits; 59 + 72 does not. */
		bc_tree_destroy(sub);
		sub = bc_tree_create();
		REQUIRE(sub);
		REQUIRE(right_chain(sub, 71, 300000, NULL) == 0);
		CHECK_EQ_INT(bc_tree_replace(t, 200000, sub, &ei), BC_EDEPTH);
		CHECK(strstr(ei.msg, "131 entries") != NULL);
		bc_tree_destroy(sub);
		sub = bc_tree_create();
		REQUIRE(sub);
		REQUIRE(right_chain(sub, 70, 300000, NULL) == 0);
		CHECK_EQ_INT(bc_tree_replace(t, 200000, sub, &ei), 0);
		CHECK(bare || bc_tree_lin(t)->stack == BC_EVAL_STACK);
		CHECK(round_trips(t));
		bc_tree_destroy(sub);
		bc_tree_destroy(t);
	}
}

/* JSON carries BC_SCENE_JSON_MAX_DEPTH levels (jansson's parser limit);
 * the writer refuses deeper trees rather than write what cannot be read. */
static void json_carries_chains_up_to_its_limit(void)
{
	struct bc_tree *t = bc_tree_create(), *u = bc_tree_create();
	struct bc_errinfo ei = {0};
	char *text;
	REQUIRE(t && u);
	REQUIRE(left_chain(t, BC_SCENE_JSON_MAX_DEPTH - 1,
	                   BC_OP_SMOOTH_UNION) == 0);
	text = bc_scene_to_json(t, NULL);
	REQUIRE(text);
	CHECK_EQ_INT(bc_scene_parse_json(text, strlen(text), u, NULL, &ei), 0);
	CHECK_EQ_INT(bc_tree_nesting(u), BC_SCENE_JSON_MAX_DEPTH);
	/* The same tree: not flattened into an n-ary operator. */
	CHECK_EQ_INT(bc_tree_node_count(u), bc_tree_node_count(t));
	CHECK(round_trips(u));
	bc_free(text);
	REQUIRE(left_chain(t, BC_SCENE_JSON_MAX_DEPTH, BC_OP_SMOOTH_UNION) ==
	        0);
	CHECK(bc_scene_to_json(t, NULL) == NULL);
	CHECK_EQ_INT(bc_scene_save_json("/nonexistent/x.json", t, NULL, &ei),
	             BC_EDEPTH);
	bc_tree_destroy(u);
	bc_tree_destroy(t);
}

/* Lipschitz Pruning's Molecule converted with --no-flatten: 1001 spheres
 * under their 1000-deep chain of pairwise smooth unions, as they are. */
static void molecule_chain_loads(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	double t0 = now_ms();
	REQUIRE(t);
	CHECK_EQ_INT(bc_scene_load_json(BC_TEST_DATA "/molecule_chain.json", t,
	                                NULL, &ei),
	             0);
	printf("  molecule chain loaded in %.1f ms\n", now_ms() - t0);
	CHECK_EQ_INT(bc_tree_prim_count(t), 1001);
	CHECK_EQ_INT(bc_tree_nesting(t), 1001);
	CHECK(bc_tree_lin(t) && bc_tree_lin(t)->stack <= 2);
	CHECK(round_trips(t));
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"deep_chain_round_trips_through_binary",
     deep_chain_round_trips_through_binary},
    {"deep_chain_sparse_agrees_with_full", deep_chain_sparse_agrees_with_full},
    {"deep_chain_edits", deep_chain_edits},
    {"graft_reaches_the_limit_and_not_past",
     graft_reaches_the_limit_and_not_past},
    {"a_need_past_a_byte_is_refused_alike",
     a_need_past_a_byte_is_refused_alike},
    {"right_nesting_is_bounded_by_the_eval_stack",
     right_nesting_is_bounded_by_the_eval_stack},
    {"json_carries_chains_up_to_its_limit",
     json_carries_chains_up_to_its_limit},
    {"molecule_chain_loads", molecule_chain_loads},
};

BC_TEST_MAIN(tests)
