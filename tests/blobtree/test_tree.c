/*
 * The blobtree model and its linearized form: builder rules, the GPU layout
 * (node words, shared operator records, ROIs, jump pointers), and edits --
 * a parameter edit rewrites only its own record and ABV, every edit leaves
 * the same layout as building the edited scene afresh, and a failed edit
 * changes nothing.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h"

#include "randtree.h"

static void sphere(struct bc_prim_data *p, float r, float x)
{
	bc_prim_data_init(p, BC_PRIM_SPHERE);
	p->params[0] = r;
	p->translate[0] = x;
}

/* union#1(A#2, B#3, smooth_difference#4(C#5, D#6)) */
static struct bc_tree *small_tree(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	struct bc_op_data d = {BC_OP_SMOOTH_DIFFERENCE, 0.2f, 0.3f};
	struct bc_prim_data p;
	if (!t) {
		return NULL;
	}
	bc_tree_begin(t);
	bc_tree_push_op(t, 1, &u, NULL);
	sphere(&p, 0.5f, -1.0f);
	bc_tree_put_prim(t, 2, &p, NULL);
	sphere(&p, 0.5f, 0.0f);
	bc_tree_put_prim(t, 3, &p, NULL);
	bc_tree_push_op(t, 4, &d, NULL);
	sphere(&p, 0.5f, 1.0f);
	bc_tree_put_prim(t, 5, &p, NULL);
	sphere(&p, 0.25f, 1.3f);
	bc_tree_put_prim(t, 6, &p, NULL);
	bc_tree_pop_op(t, NULL);
	bc_tree_pop_op(t, NULL);
	if (bc_tree_end(t, NULL)) {
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

static void layout_follows_the_paper(void)
{
	struct bc_tree *t = small_tree();
	const struct bc_lin *l;
	REQUIRE(t);
	l = bc_tree_lin(t);
	REQUIRE(l);
	/* Post-order: A0 B1 u2 C3 D4 d5 u6 -- the n-ary union folds left. */
	CHECK_EQ_INT(l->count, 7);
	CHECK_EQ_INT(l->nprims, 4);
	CHECK_EQ_INT(l->node_id[2], 1);
	CHECK_EQ_INT(l->node_id[6], 1);
	CHECK_EQ_INT(l->node_id[5], 4);
	CHECK(bc_lin_is_leaf(l, 0) && bc_lin_is_leaf(l, 4));
	CHECK(!bc_lin_is_leaf(l, 2) && !bc_lin_is_leaf(l, 6));
	CHECK_EQ_INT(bc_lin_parent(l, 0), 2);
	CHECK_EQ_INT(bc_lin_parent(l, 2), 6);
	CHECK_EQ_INT(bc_lin_parent(l, 5), 6);
	CHECK_EQ_INT(bc_lin_parent(l, 6), BC_NONE);
	CHECK((l->node[0] & BC_WORD_LEFT) != 0);
	CHECK((l->node[2] & BC_WORD_LEFT) == 0);
	CHECK((l->node[2 * 2] & BC_WORD_LEFT) != 0);
	CHECK_EQ_INT(bc_lin_kind(l, 5), BC_OP_SMOOTH_DIFFERENCE);
	CHECK_EQ_INT(bc_lin_type(l, 5) >> 6, BC_OPCLASS_DIFFERENCE);
	/* Both fold slots of the union share one parameter record. */
	CHECK_EQ_INT(l->node[2 * 2 + 1], l->node[2 * 6 + 1]);
	CHECK_EQ_INT(bc_lin_first(l, 6), 0);
	CHECK_EQ_INT(bc_lin_first(l, 5), 3);
	/* A leaf is its own first slot and has a primitive; an operator has
	 * none, and its subtree's primitives start at its first leaf's. */
	CHECK_EQ_INT(bc_lin_first(l, 4), 4);
	CHECK_EQ_INT(bc_lin_prim(l, 0), 0);
	CHECK_EQ_INT(bc_lin_prim(l, 4), 3);
	CHECK_EQ_INT(bc_lin_prim(l, 5), BC_NONE);
	CHECK_EQ_INT(bc_lin_first_prim(l, 5), 2);
	CHECK_EQ_INT(bc_lin_first_prim(l, 6), 0);
	CHECK_EQ_INT(bc_lin_first_prim(l, 3), 2);
	/* Four spheres: a vec4 each, (centre, radius). */
	CHECK_EQ_INT(l->nparam,
	             4 * BC_SPHERE_RECORD_VEC4 + 2 * BC_OP_RECORD_VEC4);
	CHECK(bc_lin_param(l, 0)[0] == -1.0f && bc_lin_param(l, 0)[3] == 0.5f);
	/* ROIs (eq. 13-16): root [0,0]; under the sharp union [0,0]; the
	 * difference's left child [min(0,-ro), 0], right [-0, max(0, ro)]. */
	CHECK(bc_lin_roi_lo(l, 6) == 0.0f && l->roi_hi[6] == 0.0f);
	CHECK(bc_lin_roi_lo(l, 3) == -0.3f && l->roi_hi[3] == 0.0f);
	CHECK(bc_lin_roi_lo(l, 4) == 0.0f && l->roi_hi[4] == 0.3f);
	/* ABV of D is its sphere grown by r+ = 0.3. */
	CHECK_NEAR(bc_lin_abv(l, 3).radius, 0.25f + 0.3f, 1e-6f);
	CHECK(l->kills != NULL);
	CHECK_EQ_INT(bc_lin_kills(l, 4), 1);
	CHECK_EQ_INT(bc_lin_kills(l, 3), 0);
	bc_tree_destroy(t);
}

static void builder_rejects_malformed_trees(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	struct bc_prim_data p;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	sphere(&p, 1.0f, 0.0f);
	/* An operator with one child. */
	bc_tree_begin(t);
	bc_tree_push_op(t, 0, &u, NULL);
	bc_tree_put_prim(t, 0, &p, NULL);
	CHECK(bc_tree_pop_op(t, &ei) == BC_EINVAL);
	CHECK(strstr(ei.msg, "two or more") != NULL);
	/* Two roots. */
	bc_tree_begin(t);
	bc_tree_put_prim(t, 0, &p, NULL);
	CHECK(bc_tree_put_prim(t, 0, &p, &ei) == BC_EINVAL);
	/* Duplicate ids. */
	bc_tree_begin(t);
	bc_tree_push_op(t, 5, &u, NULL);
	CHECK(bc_tree_put_prim(t, 5, &p, &ei) == BC_EDUPID);
	/* Unclosed operator. */
	bc_tree_begin(t);
	bc_tree_push_op(t, 0, &u, NULL);
	bc_tree_put_prim(t, 0, &p, NULL);
	bc_tree_put_prim(t, 0, &p, NULL);
	CHECK(bc_tree_end(t, &ei) == BC_EINVAL);
	/* Nesting over the limit. */
	bc_tree_begin(t);
	{
		int rc = 0;
		for (uint32_t d = 0; d <= BC_TREE_MAX_DEPTH && !rc; d++) {
			rc = bc_tree_push_op(t, 0, &u, &ei);
		}
		CHECK(rc == BC_EDEPTH);
	}
	/* Bad parameters: a smooth operator with no blend. */
	bc_tree_begin(t);
	CHECK(bc_tree_push_op(t, 0,
	                      &(struct bc_op_data){BC_OP_SMOOTH_UNION, 0, 0},
	                      &ei) == BC_ERANGE);
	/* A single primitive is a valid tree. */
	bc_tree_begin(t);
	CHECK(bc_tree_put_prim(t, 9, &p, NULL) == 0);
	CHECK(bc_tree_end(t, NULL) == 0);
	CHECK_EQ_INT(bc_tree_root(t), 9);
	CHECK_EQ_INT(bc_tree_lin(t)->count, 1);
	bc_tree_destroy(t);
}

/* Compares every array of two layouts; returns the number of differences. */
static int lin_diff(const struct bc_lin *a, const struct bc_lin *b)
{
	int diffs = 0;
	if (a->count != b->count || a->nprims != b->nprims ||
	    a->nparam != b->nparam) {
		return 1000;
	}
	diffs += memcmp(a->node, b->node, 8u * a->count) != 0;
	diffs += memcmp(a->lead, b->lead, 4u * a->count) != 0;
	diffs += memcmp(a->jump, b->jump, 4u * a->count) != 0;
	diffs += memcmp(a->fast, b->fast, 4u * a->count) != 0;
	for (uint32_t s = 0; s < a->count; s++) {
		float lo_a = bc_lin_roi_lo(a, s), lo_b = bc_lin_roi_lo(b, s);
		if (bc_lin_kills(a, s) != bc_lin_kills(b, s) ||
		    memcmp(&lo_a, &lo_b, sizeof(lo_a)) != 0) {
			diffs++;
			break;
		}
	}
	diffs += memcmp(a->node_id, b->node_id, 4u * a->count) != 0;
	diffs += memcmp(a->roi_hi, b->roi_hi, 4u * a->count) != 0;
	diffs += memcmp(a->param, b->param, 16u * a->nparam) != 0;
	diffs += memcmp(a->color, b->color, 12u * a->nprims) != 0;
	for (uint32_t k = 0; k < a->nprims; k++) {
		struct bc_abv x = bc_lin_abv(a, k), y = bc_lin_abv(b, k);
		diffs += memcmp(&x, &y, sizeof(x)) != 0;
	}
	return diffs;
}

/* Ids of the tree's primitives and operators in slot order. */
static uint32_t pick(const struct bc_tree *t, bool want_op)
{
	const struct bc_lin *l = bc_tree_lin(t);
	for (uint32_t tries = 0; tries < 1000; tries++) {
		uint32_t s = rt_below(l->count);
		if (bc_lin_is_leaf(l, s) != want_op) {
			return l->node_id[s];
		}
	}
	return 0;
}

static void parameter_edit_rewrites_only_its_own_record(void)
{
	struct bc_tree *t = bc_tree_create(), *fresh = bc_tree_create();
	REQUIRE(t && fresh);
	for (int i = 0; i < 50; i++) {
		const struct bc_lin *l;
		struct bc_lin before;
		struct bc_prim_data p;
		struct bc_dirty dirty;
		uint32_t id, k, s;
		float *params;
		REQUIRE(rt_build(t, 300u + (uint64_t)i, 2 + (uint32_t)i) == 0);
		l = bc_tree_lin(t);
		before = *l;
		params = bc_malloc(16u * l->nparam);
		REQUIRE(params);
		memcpy(params, l->param, 16u * l->nparam);
		bc_tree_take_dirty(t, &dirty);
		id = pick(t, false);
		REQUIRE(bc_tree_get(t, id, &p, NULL));
		p.translate[0] += 0.25f;
		p.params[0] *= 1.1f;
		REQUIRE(bc_tree_set_prim(t, id, &p, NULL) == 0);
		l = bc_tree_lin(t);
		/* Same arrays: nothing was re-linearized. */
		CHECK(l->node == before.node && l->param == before.param);
		bc_tree_take_dirty(t, &dirty);
		CHECK(!dirty.structure);
		s = 0;
		while (l->node_id[s] != id) {
			s++;
		}
		k = bc_lin_prim(l, s);
		CHECK_EQ_INT(dirty.prim_lo, k);
		CHECK_EQ_INT(dirty.prim_hi, k + 1);
		CHECK_EQ_INT(dirty.param_hi - dirty.param_lo,
		             bc_prim_record_vec4(p.kind));
		CHECK_EQ_INT(dirty.param_lo, l->node[2 * s + 1]);
		for (uint32_t v = 0; v < l->nparam; v++) {
			bool inside = v >= dirty.param_lo && v < dirty.param_hi;
			if (!inside) {
				CHECK(memcmp(params + 4 * v, l->param + 4 * v,
				             16) == 0);
			}
		}
		/* And the result is what a fresh build gives. */
		REQUIRE(bc_tree_copy(fresh, t, NULL) == 0);
		CHECK(lin_diff(bc_tree_lin(fresh), l) == 0);
		bc_free(params);
	}
	bc_tree_destroy(fresh);
	bc_tree_destroy(t);
}

static void operator_edit_equals_a_fresh_build(void)
{
	struct bc_tree *t = bc_tree_create(), *fresh = bc_tree_create();
	REQUIRE(t && fresh);
	for (int i = 0; i < 100; i++) {
		struct bc_op_data op;
		struct bc_dirty dirty;
		uint32_t id;
		REQUIRE(rt_build(t, 700u + (uint64_t)i, 3 + (uint32_t)i % 60) ==
		        0);
		bc_tree_take_dirty(t, &dirty);
		id = pick(t, true);
		REQUIRE(bc_tree_get(t, id, NULL, &op));
		rt_random_op(&op);
		REQUIRE(bc_tree_set_op(t, id, &op, NULL) == 0);
		bc_tree_take_dirty(t, &dirty);
		CHECK(!dirty.structure && dirty.edits == 1);
		CHECK(dirty.slot_hi > dirty.slot_lo);
		/* The dirty primitives are exactly the subtree's leaves. */
		{
			const struct bc_lin *l = bc_tree_lin(t);
			uint32_t s = bc_tree_slot(t, id), leaves = 0;
			for (uint32_t x = bc_lin_first(l, s); x <= s; x++) {
				leaves += bc_lin_is_leaf(l, x) ? 1u : 0u;
			}
			CHECK_EQ_INT(dirty.prim_hi - dirty.prim_lo, leaves);
			CHECK_EQ_INT(dirty.prim_lo, bc_lin_first_prim(l, s));
		}
		REQUIRE(bc_tree_copy(fresh, t, NULL) == 0);
		CHECK(lin_diff(bc_tree_lin(fresh), bc_tree_lin(t)) == 0);
	}
	bc_tree_destroy(fresh);
	bc_tree_destroy(t);
}

static void structural_edits_keep_ids_and_order(void)
{
	struct bc_tree *t = small_tree(), *sub = bc_tree_create();
	struct bc_prim_data p;
	struct bc_errinfo ei = {0};
	REQUIRE(t && sub);
	/* Insert a sphere (auto id) as child 1 of the union. */
	bc_tree_begin(sub);
	sphere(&p, 0.3f, 2.0f);
	bc_tree_put_prim(sub, 0, &p, NULL);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
	REQUIRE(bc_tree_insert(t, 1, 1, sub, NULL) == 0);
	CHECK_EQ_INT(bc_tree_child_count(t, 1), 4);
	CHECK_EQ_INT(bc_tree_child(t, 1, 0), 2);
	CHECK(bc_tree_child(t, 1, 1) > 6);
	CHECK_EQ_INT(bc_tree_child(t, 1, 2), 3);
	CHECK_EQ_INT(bc_tree_lin(t)->nprims, 5);
	/* Inserting a chosen id that exists fails and changes nothing. */
	bc_tree_begin(sub);
	bc_tree_put_prim(sub, 3, &p, NULL);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
	CHECK(bc_tree_insert(t, 1, 0, sub, &ei) == BC_EDUPID);
	CHECK_EQ_INT(bc_tree_child_count(t, 1), 4);
	/* Inserting under a primitive or past the end fails. */
	CHECK(bc_tree_insert(t, 2, 0, sub, &ei) == BC_EINVAL);
	CHECK(bc_tree_insert(t, 1, 9, sub, &ei) == BC_ERANGE);
	/* Removing C leaves the difference with one child: D takes its
	 * place and the operator's id is gone. */
	REQUIRE(bc_tree_remove(t, 5, NULL) == 0);
	CHECK(!bc_tree_get(t, 4, NULL, NULL));
	CHECK_EQ_INT(bc_tree_child(t, 1, 3), 6);
	CHECK_EQ_INT(bc_tree_parent(t, 6), 1);
	/* Replace B by a subtree reusing its id. */
	bc_tree_begin(sub);
	bc_tree_push_op(sub, 3, &(struct bc_op_data){BC_OP_INTERSECTION, 0, 0},
	                NULL);
	sphere(&p, 0.4f, 0.0f);
	bc_tree_put_prim(sub, 40, &p, NULL);
	sphere(&p, 0.4f, 0.2f);
	bc_tree_put_prim(sub, 41, &p, NULL);
	bc_tree_pop_op(sub, NULL);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
	REQUIRE(bc_tree_replace(t, 3, sub, NULL) == 0);
	CHECK_EQ_INT(bc_tree_child(t, 1, 2), 3);
	CHECK_EQ_INT(bc_tree_child_count(t, 3), 2);
	CHECK_EQ_INT(bc_tree_parent(t, 41), 3);
	CHECK_EQ_INT(bc_tree_prim_count(t), 5);
	/* Unknown ids. */
	CHECK(bc_tree_remove(t, 999, &ei) == BC_ENONODE);
	CHECK(bc_tree_set_prim(t, 999, &p, &ei) == BC_ENONODE);
	/* Removing the root empties the tree. */
	REQUIRE(bc_tree_remove(t, 1, NULL) == 0);
	CHECK(bc_tree_lin(t) == NULL);
	CHECK_EQ_INT(bc_tree_node_count(t), 0);
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

static void structural_edits_equal_a_fresh_build(void)
{
	struct bc_tree *t = bc_tree_create(), *fresh = bc_tree_create();
	struct bc_tree *sub = bc_tree_create();
	REQUIRE(t && fresh && sub);
	for (int i = 0; i < 100; i++) {
		uint32_t target, op;
		REQUIRE(rt_build(t, 40u + (uint64_t)i, 4 + (uint32_t)i % 40) ==
		        0);
		REQUIRE(rt_build(sub, 90000u + (uint64_t)i,
		                 1 + (uint32_t)i % 5) == 0);
		target = pick(t, false);
		op = pick(t, true);
		switch (i % 3) {
		case 0:
			REQUIRE(bc_tree_insert(t, op, 0, sub, NULL) == 0);
			break;
		case 1:
			REQUIRE(bc_tree_remove(t, target, NULL) == 0);
			break;
		default:
			REQUIRE(bc_tree_replace(t, target, sub, NULL) == 0);
			break;
		}
		REQUIRE(bc_tree_copy(fresh, t, NULL) == 0);
		CHECK(lin_diff(bc_tree_lin(fresh), bc_tree_lin(t)) == 0);
		CHECK_EQ_INT(bc_tree_lin(t)->count,
		             2 * bc_tree_prim_count(t) - 1);
	}
	bc_tree_destroy(sub);
	bc_tree_destroy(fresh);
	bc_tree_destroy(t);
}

/* Fails the Nth allocation for every N until the sequence succeeds: each
 * failure must return an error and leak nothing (ASan's leak check). */
static void allocation_failures_are_clean(void)
{
	int rounds = 0;
	for (unsigned long n = 1; n < 10000; n++) {
		struct bc_tree *t, *sub;
		int rc = BC_ENOMEM;
		bc_alloc_fail_after(n);
		t = bc_tree_create();
		sub = bc_tree_create();
		if (t && sub && rt_build(t, 1, 30) == 0 &&
		    rt_build(sub, 2, 4) == 0) {
			uint32_t op = bc_tree_root(t);
			rc = bc_tree_insert(t, op, 0, sub, NULL);
			if (rc == 0) {
				rc = bc_tree_remove(t, bc_tree_child(t, op, 0),
				                    NULL);
			}
			if (rc) {
				/* A failed edit leaves a usable tree. */
				bc_alloc_fail_after(0);
				CHECK(bc_tree_lin(t) != NULL);
				CHECK_EQ_INT(bc_tree_lin(t)->count,
				             2 * bc_tree_prim_count(t) - 1);
			}
		}
		bc_alloc_fail_after(0);
		bc_tree_destroy(sub);
		bc_tree_destroy(t);
		rounds++;
		if (rc == 0) {
			break;
		}
	}
	CHECK(rounds > 5);
	CHECK(rounds < 10000);
}

/* ---- ids found in place and in the map ---------------------------------- */

static uint32_t id_rng = 12345u;

static uint32_t id_rand(uint32_t n)
{
	id_rng = id_rng * 1664525u + 1013904223u;
	return (id_rng >> 8) % n;
}

/* A sphere whose radius tells its id apart. */
static void id_sphere(struct bc_prim_data *p, uint32_t id)
{
	sphere(p, 0.01f + 1e-5f * (float)id, 0.01f * (float)(id % 97));
}

/* A sub-scene to insert: one sphere, or an operator over two (ids 0 ask
 * the tree for fresh ones; root_id may reuse the id a replace frees). */
static struct bc_tree *id_sub(uint32_t root_id, uint32_t a, uint32_t b, bool op)
{
	struct bc_tree *s = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	struct bc_prim_data p;
	int rc = s ? bc_tree_begin(s) : BC_ENOMEM;
	if (op) {
		rc = rc ? rc : bc_tree_push_op(s, root_id, &u, NULL);
		id_sphere(&p, a);
		rc = rc ? rc : bc_tree_put_prim(s, a, &p, NULL);
		id_sphere(&p, b);
		rc = rc ? rc : bc_tree_put_prim(s, b, &p, NULL);
		rc = rc ? rc : bc_tree_pop_op(s, NULL);
	} else {
		id_sphere(&p, root_id);
		rc = rc ? rc : bc_tree_put_prim(s, root_id, &p, NULL);
	}
	rc = rc ? rc : bc_tree_end(s, NULL);
	if (rc) {
		bc_tree_destroy(s);
		return NULL;
	}
	return s;
}

/* Every node the pre-order walk (the model's links, not the ids) reaches
 * is what bc_tree_get finds under its id, the counts agree, and ids seen
 * before and gone are not found. Returns the mismatches. */
static uint32_t id_check(const struct bc_tree *t, uint8_t *live, uint32_t nids)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	uint32_t bad = 0, walked = 0;
	memset(live, 0, nids);
	if (bc_scene_walk_init(&w, t) == 0) {
		while (bc_scene_walk_next(&w, &n)) {
			struct bc_prim_data p;
			struct bc_op_data o;
			walked++;
			if (n.id < nids) {
				live[n.id] = 1;
			}
			if (!bc_tree_get(t, n.id, &p, &o) ||
			    (n.is_op ? o.kind != n.op.kind
			             : memcmp(&p, &n.prim, sizeof(p)) != 0)) {
				bad++;
			}
		}
		bc_scene_walk_finish(&w);
	}
	bad += walked != bc_tree_node_count(t);
	for (uint32_t id = 1; id < nids; id++) {
		bad += !live[id] && bc_tree_get(t, id, NULL, NULL);
	}
	return bad;
}

/* A tree loaded with ids in pre-order from 1 finds its nodes in place
 * (no id map); inserts with fresh and chosen ids, removals and
 * replacements whose root reuses the id of the node it replaces mix the
 * two ways of finding a node, in laid-out and bare trees. */
static void ids_found_in_place_and_in_the_map(void)
{
	enum { N = 300, STEPS = 3000, IDS = 20000 };
	static uint8_t live[IDS];
	for (int bare = 0; bare < 2; bare++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_op_data u = {BC_OP_UNION, 0, 0};
		struct bc_prim_data p;
		uint32_t bad = 0, chosen = 10000;
		REQUIRE(t != NULL);
		REQUIRE(bc_tree_set_layout(t, !bare) == 0);
		bc_tree_begin(t);
		REQUIRE(bc_tree_push_op(t, 1, &u, NULL) == 0);
		for (uint32_t id = 2; id <= N; id++) {
			id_sphere(&p, id);
			REQUIRE(bc_tree_put_prim(t, id, &p, NULL) == 0);
		}
		REQUIRE(bc_tree_pop_op(t, NULL) == 0);
		REQUIRE(bc_tree_end(t, NULL) == 0);
		bad += id_check(t, live, IDS);
		for (int step = 0; step < STEPS; step++) {
			uint32_t pick = 0, count = 0, kind = id_rand(3);
			struct bc_tree *s = NULL;
			/* A random live node other than the root. */
			for (uint32_t id = 2; id < IDS; id++) {
				if (live[id] && id_rand(++count) == 0) {
					pick = id;
				}
			}
			if (kind == 0 || pick == 0) {
				/* Insert under the root: a fresh id, or one
				 * chosen above any the tree assigns. */
				bool fresh = id_rand(2) == 0;
				s = id_sub(fresh ? 0 : chosen, 0, 0, false);
				chosen += fresh ? 0 : 1;
				CHECK_EQ_INT(
				    bc_tree_insert(t, 1,
				                   bc_tree_child_count(t, 1), s,
				                   NULL),
				    0);
			} else if (kind == 1 && bc_tree_child_count(t, 1) > 2) {
				(void)bc_tree_remove(t, pick, NULL);
			} else if (kind == 2) {
				/* The replacement's root takes pick's id. */
				s = id_sub(pick, chosen, chosen + 1, true);
				chosen += 2;
				CHECK_EQ_INT(bc_tree_replace(t, pick, s, NULL),
				             0);
			}
			bc_tree_destroy(s);
			if (chosen + 2 >= IDS) {
				break;
			}
			bad += id_check(t, live, IDS);
		}
		printf("  %s: %u nodes after %d edits, %u ids wrong\n",
		       bare ? "bare" : "laid out", bc_tree_node_count(t), STEPS,
		       bad);
		CHECK_EQ_INT(bad, 0);
		bc_tree_destroy(t);
	}
}

/* ---- a primitive's data as the pool keeps it ----------------------------- */

/* One primitive as a scene of its own, under id (for insert and replace). */
static struct bc_tree *prim_sub(uint32_t id, const struct bc_prim_data *p)
{
	struct bc_tree *s = bc_tree_create();
	int rc = s ? bc_tree_begin(s) : BC_ENOMEM;
	rc = rc ? rc : bc_tree_put_prim(s, id, p, NULL);
	rc = rc ? rc : bc_tree_end(s, NULL);
	if (rc) {
		bc_tree_destroy(s);
		return NULL;
	}
	return s;
}

/* The fields a scene carries of p (its kind's parameter floats, not the
 * zeros past them) equal want's; rotations within float rounding. */
static bool same_prim(const struct bc_prim_data *p,
                      const struct bc_prim_data *want)
{
	uint32_t nf = bc_scene_prim_nfloats(want->kind);
	if (p->kind != want->kind || p->has_color != want->has_color ||
	    memcmp(p->params, want->params, nf * sizeof(float)) != 0 ||
	    memcmp(p->translate, want->translate, sizeof(p->translate)) != 0 ||
	    (want->has_color &&
	     memcmp(p->color, want->color, sizeof(p->color)) != 0)) {
		return false;
	}
	for (uint32_t i = nf; i < BC_PRIM_MAX_PARAMS; i++) {
		if (p->params[i] != 0.0f) {
			return false;
		}
	}
	for (int i = 0; i < 4; i++) {
		if (fabsf(p->rotate[i] - want->rotate[i]) > 1e-6f) {
			return false;
		}
	}
	return true;
}

/* rt_random_prim's primitive, rotated or not (whatever its kind) by a
 * coin's toss. */
static void any_prim(struct bc_prim_data *p)
{
	rt_random_prim(p);
	if (rt_below(2)) {
		rt_random_quat(p->rotate);
	} else {
		memset(p->rotate, 0, sizeof(p->rotate));
		p->rotate[3] = 1.0f;
	}
}

/* A node keeps a primitive's parameters past the first and its rotation
 * in a chunk of a store beside the pool, taken when the node is made or a
 * parameter edit rotates a primitive that had none, and given back when
 * it goes: 3000 random inserts, removals, replacements (of another kind)
 * and parameter edits over primitives of one to seven parameter floats,
 * rotated or not, laid out and bare, and every live primitive reads back
 * as it was last set, and the layout equals a fresh build's after each
 * step. */
static void prim_data_kept_through_edits(void)
{
	enum { NIDS = 4000, STEPS = 3000 };
	static struct bc_prim_data want[NIDS];
	static uint8_t live[NIDS];
	for (int lay = 0; lay < 2; lay++) {
		struct bc_tree *t = bc_tree_create(), *fresh = bc_tree_create();
		struct bc_op_data u = {BC_OP_UNION, 0, 0};
		uint32_t next = 2, bad = 0, nlive = 0;
		REQUIRE(t && fresh);
		memset(live, 0, sizeof(live));
		REQUIRE(bc_tree_set_layout(t, lay == 0) == 0);
		REQUIRE(bc_tree_begin(t) == 0);
		REQUIRE(bc_tree_push_op(t, 1, &u, NULL) == 0);
		for (; next < 10; next++) {
			any_prim(&want[next]);
			REQUIRE(bc_tree_put_prim(t, next, &want[next], NULL) ==
			        0);
			live[next] = 1;
			nlive++;
		}
		REQUIRE(bc_tree_pop_op(t, NULL) == 0);
		REQUIRE(bc_tree_end(t, NULL) == 0);
		for (int step = 0; step < STEPS; step++) {
			uint32_t what = rt_below(4), id = 2, seen = 0;
			struct bc_prim_data p;
			struct bc_tree *sub = NULL;
			/* A random live primitive. */
			for (uint32_t i = 2; i < next; i++) {
				if (live[i] && rt_below(++seen) == 0) {
					id = i;
				}
			}
			any_prim(&p);
			if (what == 0 && next < NIDS) {
				REQUIRE((sub = prim_sub(next, &p)) != NULL);
				REQUIRE(bc_tree_insert(t, 1,
				                       rt_below(nlive + 1), sub,
				                       NULL) == 0);
				want[next] = p;
				live[next++] = 1;
				nlive++;
			} else if (what == 1 && nlive > 2) {
				REQUIRE(bc_tree_remove(t, id, NULL) == 0);
				live[id] = 0;
				nlive--;
			} else if (what == 2 && next < NIDS) {
				REQUIRE((sub = prim_sub(next, &p)) != NULL);
				REQUIRE(bc_tree_replace(t, id, sub, NULL) == 0);
				live[id] = 0;
				want[next] = p;
				live[next++] = 1;
			} else {
				struct bc_prim_data q;
				do {
					any_prim(&q);
				} while (q.kind != want[id].kind);
				REQUIRE(bc_tree_set_prim(t, id, &q, NULL) == 0);
				want[id] = q;
			}
			bc_tree_destroy(sub);
			for (uint32_t i = 2; i < next; i++) {
				struct bc_prim_data got;
				if (live[i] &&
				    (!bc_tree_get(t, i, &got, NULL) ||
				     !same_prim(&got, &want[i]))) {
					bad++;
				}
			}
			if (lay == 0 && step % 97 == 0) {
				REQUIRE(bc_tree_copy(fresh, t, NULL) == 0);
				CHECK(lin_diff(bc_tree_lin(fresh),
				               bc_tree_lin(t)) == 0);
			}
		}
		CHECK_EQ_INT(bad, 0);
		CHECK_EQ_INT(bc_tree_prim_count(t), nlive);
		bc_tree_destroy(fresh);
		bc_tree_destroy(t);
	}
}

/* A sphere's record is its centre and radius, one vec4, whatever its
 * rotation: its field is |p - c| - r, bit for bit, and the long form
 * (bc_prim_record_long: identity rows) evaluates to the same. Beside it a
 * box keeps the affine rows and shape (5 vec4), and a parameter edit of
 * each rewrites exactly its own record. */
static void a_sphere_record_is_one_vec4(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	struct bc_prim_data sp, bx;
	const struct bc_lin *l;
	struct bc_dirty d;
	float lng[4 * BC_PRIM_RECORD_VEC4];
	REQUIRE(t);
	bc_prim_data_init(&sp, BC_PRIM_SPHERE);
	sp.params[0] = 0.4f;
	sp.translate[0] = 0.3f;
	sp.translate[1] = -0.2f;
	sp.translate[2] = 0.7f;
	sp.rotate[0] = 0.6f; /* 0.6^2 + 0.8^2 = 1 */
	sp.rotate[3] = 0.8f;
	bc_prim_data_init(&bx, BC_PRIM_BOX);
	bx.params[0] = bx.params[1] = bx.params[2] = 0.3f;
	bx.translate[0] = -1.0f;
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 1, &u, NULL) == 0);
	REQUIRE(bc_tree_put_prim(t, 2, &sp, NULL) == 0);
	REQUIRE(bc_tree_put_prim(t, 3, &bx, NULL) == 0);
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	l = bc_tree_lin(t);
	REQUIRE(l);
	CHECK_EQ_INT(l->nparam, BC_SPHERE_RECORD_VEC4 + BC_PRIM_RECORD_VEC4 +
	                            BC_OP_RECORD_VEC4);
	CHECK_EQ_INT(l->node[2 * 1 + 1] - l->node[2 * 0 + 1], 1);
	for (int i = 0; i < 3; i++) {
		CHECK(bc_lin_param(l, 0)[i] == sp.translate[i]);
	}
	CHECK(bc_lin_param(l, 0)[3] == sp.params[0]);
	bc_prim_record_long(BC_PRIM_SPHERE, bc_lin_param(l, 0), lng);
	for (int k = 0; k < 200; k++) {
		float p[3] = {(float)(k % 7) * 0.3f - 1.0f,
		              (float)(k % 11) * 0.2f - 1.0f,
		              (float)(k % 13) * 0.15f - 0.9f};
		float x = p[0] - sp.translate[0], y = p[1] - sp.translate[1],
		      z = p[2] - sp.translate[2];
		float want = sqrtf(x * x + y * y + z * z) - sp.params[0];
		float ax =
		    lng[0] * p[0] + lng[1] * p[1] + lng[2] * p[2] + lng[3];
		float ay =
		    lng[4] * p[0] + lng[5] * p[1] + lng[6] * p[2] + lng[7];
		float az =
		    lng[8] * p[0] + lng[9] * p[1] + lng[10] * p[2] + lng[11];
		CHECK(bc_eval_prim(l, 0, p) == want);
		CHECK(bc_prim_sdf(BC_PRIM_SPHERE, lng + 12, ax, ay, az) ==
		      want);
	}
	/* Parameter edits: each record alone, at its own size. */
	bc_tree_take_dirty(t, &d);
	sp.params[0] = 0.5f;
	REQUIRE(bc_tree_set_prim(t, 2, &sp, NULL) == 0);
	bc_tree_take_dirty(t, &d);
	CHECK_EQ_INT(d.param_lo, l->node[2 * 0 + 1]);
	CHECK_EQ_INT(d.param_hi - d.param_lo, BC_SPHERE_RECORD_VEC4);
	CHECK(bc_lin_param(l, 0)[3] == 0.5f);
	bx.params[0] = 0.35f;
	REQUIRE(bc_tree_set_prim(t, 3, &bx, NULL) == 0);
	bc_tree_take_dirty(t, &d);
	CHECK_EQ_INT(d.param_lo, l->node[2 * 1 + 1]);
	CHECK_EQ_INT(d.param_hi - d.param_lo, BC_PRIM_RECORD_VEC4);
	bc_tree_destroy(t);
}

/* One primitive (id 0: the tree picks) as the whole of sub. */
static void one_prim(struct bc_tree *sub, const struct bc_prim_data *p)
{
	bc_tree_begin(sub);
	bc_tree_put_prim(sub, 0, p, NULL);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
}

/* The layout of t against one laid out whole from a copy of it. */
static int differs_from_a_copy(const struct bc_tree *t)
{
	struct bc_tree *fresh = bc_tree_create();
	int diffs = 1000;
	if (fresh && bc_tree_copy(fresh, t, NULL) == 0) {
		diffs = lin_diff(bc_tree_lin(fresh), bc_tree_lin(t));
	}
	bc_tree_destroy(fresh);
	return diffs;
}

/* A layout of spheres alone keeps their ABVs as centre and radius (16
 * bytes, not 68), read back as the sphere ABVs a full layout places; a
 * parameter edit and a spliced sphere keep that form, a spliced box turns
 * it into whole ABVs once (equal to a full layout's), the box's removal
 * leaves them so until a layout whole picks again, and a unary node's
 * layout keeps whole ABVs. */
static void spheres_alone_keep_sphere_abvs(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_op_data u = {BC_OP_SMOOTH_UNION, 0.2f, 0.3f};
	struct bc_prim_data p;
	const struct bc_lin *l;
	uint32_t box;
	REQUIRE(t && sub);
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 1, &u, NULL) == 0);
	for (uint32_t i = 0; i < 40; i++) {
		sphere(&p, 0.1f + 0.01f * (float)i, 0.2f * (float)i);
		p.translate[1] = (float)(i % 3);
		REQUIRE(bc_tree_put_prim(t, 2 + i, &p, NULL) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->sabv && !l->abv);
	for (uint32_t k = 0; k < l->nprims; k++) {
		struct bc_abv a = bc_lin_abv(l, k);
		CHECK(a.shape == BC_ABV_SPHERE);
		CHECK_NEAR(a.radius, 0.1f + 0.01f * (float)k + 0.3f, 1e-6f);
	}
	REQUIRE(bc_tree_get(t, 7, &p, NULL));
	p.params[0] = 0.9f;
	REQUIRE(bc_tree_set_prim(t, 7, &p, NULL) == 0);
	sphere(&p, 0.5f, -3.0f);
	one_prim(sub, &p);
	REQUIRE(bc_tree_insert(t, 1, 5, sub, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->sabv && !l->abv);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	bc_prim_data_init(&p, BC_PRIM_BOX);
	p.params[0] = p.params[1] = p.params[2] = 0.3f;
	one_prim(sub, &p);
	REQUIRE(bc_tree_insert(t, 1, 10, sub, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->abv && !l->sabv);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	box = bc_tree_child(t, 1, 10);
	CHECK(bc_tree_get(t, box, &p, NULL) && p.kind == BC_PRIM_BOX);
	REQUIRE(bc_tree_remove(t, box, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->abv && !l->sabv);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	REQUIRE(bc_tree_relayout(t, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->sabv && !l->abv);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	{
		struct bc_unary off;
		bc_unary_init(&off, BC_OP_OFFSET);
		off.u[0] = 0.1f;
		bc_tree_begin(sub);
		REQUIRE(bc_tree_push_unary(sub, 0, &off, NULL) == 0);
		sphere(&p, 0.2f, 5.0f);
		REQUIRE(bc_tree_put_prim(sub, 0, &p, NULL) == 0);
		REQUIRE(bc_tree_pop_op(sub, NULL) == 0);
		REQUIRE(bc_tree_end(sub, NULL) == 0);
	}
	REQUIRE(bc_tree_insert(t, 1, 0, sub, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->abv && !l->sabv);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* A layout whose tree has no intersection or difference (nor unary node)
 * keeps no kill counts and no r- (all 0: 16 bytes a primitive); an
 * intersection spliced in, an operator turned into a difference, or one
 * laid out whole gives it both, equal to a full layout's. Removing the
 * last one leaves them (all 0 again) until a layout whole drops them. */
static void kill_counts_only_where_an_operand_can_die(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_op_data u = {BC_OP_SMOOTH_UNION, 0.2f, 0.3f};
	struct bc_op_data in = {BC_OP_INTERSECTION, 0.0f, 0.0f};
	struct bc_prim_data p;
	const struct bc_lin *l;
	uint32_t cut;
	REQUIRE(t && sub);
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 1, &u, NULL) == 0);
	REQUIRE(bc_tree_push_op(t, 2, &u, NULL) == 0);
	for (uint32_t i = 0; i < 20; i++) {
		sphere(&p, 0.3f, 0.2f * (float)i);
		REQUIRE(bc_tree_put_prim(t, 10 + i, &p, NULL) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	sphere(&p, 0.4f, 1.0f);
	REQUIRE(bc_tree_put_prim(t, 3, &p, NULL) == 0);
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->kills == NULL && l->roi_lo == NULL);
	for (uint32_t s = 0; s < l->count; s++) {
		CHECK_EQ_INT(bc_lin_kills(l, s), 0);
	}
	/* An intersection of two spheres spliced in at the union's front. */
	bc_tree_begin(sub);
	REQUIRE(bc_tree_push_op(sub, 0, &in, NULL) == 0);
	sphere(&p, 0.5f, -1.0f);
	REQUIRE(bc_tree_put_prim(sub, 0, &p, NULL) == 0);
	sphere(&p, 0.5f, -0.6f);
	REQUIRE(bc_tree_put_prim(sub, 0, &p, NULL) == 0);
	REQUIRE(bc_tree_pop_op(sub, NULL) == 0);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
	REQUIRE(bc_tree_insert(t, 1, 0, sub, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->kills != NULL && l->roi_lo != NULL);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	cut = bc_tree_child(t, 1, 0);
	CHECK_EQ_INT(bc_lin_kills(l, bc_tree_slot(t, cut) - 1), 1);
	CHECK_EQ_INT(bc_lin_kills(l, bc_tree_slot(t, cut)), 0);
	/* Gone again: the counts stay, all 0, until a whole layout. */
	REQUIRE(bc_tree_remove(t, cut, NULL) == 0);
	l = bc_tree_lin(t);
	CHECK(l->kills != NULL);
	CHECK_EQ_INT(differs_from_a_copy(t), 0);
	REQUIRE(bc_tree_relayout(t, NULL) == 0);
	CHECK(bc_tree_lin(t)->kills == NULL && bc_tree_lin(t)->roi_lo == NULL);
	/* The inner union made a difference by an operator edit. */
	{
		struct bc_op_data d = {BC_OP_SMOOTH_DIFFERENCE, 0.1f, 0.15f};
		uint32_t top;
		REQUIRE(bc_tree_set_op(t, 2, &d, NULL) == 0);
		l = bc_tree_lin(t);
		CHECK(l->kills != NULL && l->roi_lo != NULL);
		CHECK_EQ_INT(differs_from_a_copy(t), 0);
		/* Its right operand (the last sphere) dies with it. */
		top = bc_tree_slot(t, 2);
		CHECK_EQ_INT(bc_lin_kills(l, top - 1), 1);
		CHECK_EQ_INT(bc_lin_kills(l, top), 0);
	}
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* A primitive has no children, whatever its data: an operator's children
 * share the room of a primitive's data in a pool node (tree_impl.h), so
 * a coloured primitive, whose colour floats lie where an operator's child
 * count is, must still count none, and give no child. An operator
 * copied in from another tree (an INSERT's subtree) starts with none of
 * that tree's children and gains its own; the primitives in it keep
 * their data. Checked bare and laid out. */
static void primitives_have_no_children(void)
{
	for (int bare = 0; bare < 2; bare++) {
		struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
		struct bc_op_data u = {BC_OP_UNION, 0, 0};
		struct bc_op_data s = {BC_OP_SMOOTH_UNION, 0.2f, 0.3f};
		struct bc_prim_data p, back;
		REQUIRE(t && sub);
		if (bare) {
			REQUIRE(bc_tree_set_layout(t, false) == 0);
		}
		sphere(&p, 0.3f, 0.0f);
		p.has_color = true;
		p.color[0] = 0.25f;
		p.color[1] = 0.5f;
		p.color[2] = 0.75f;
		bc_tree_begin(t);
		REQUIRE(bc_tree_push_op(t, 1, &u, NULL) == 0);
		REQUIRE(bc_tree_put_prim(t, 2, &p, NULL) == 0);
		REQUIRE(bc_tree_put_prim(t, 3, &p, NULL) == 0);
		REQUIRE(bc_tree_pop_op(t, NULL) == 0);
		REQUIRE(bc_tree_end(t, NULL) == 0);
		CHECK_EQ_INT(bc_tree_child_count(t, 1), 2);
		CHECK_EQ_INT(bc_tree_child_count(t, 2), 0);
		CHECK_EQ_INT(bc_tree_child(t, 2, 0), 0);
		/* A smooth union of three coloured spheres, copied in. */
		bc_tree_begin(sub);
		REQUIRE(bc_tree_push_op(sub, 10, &s, NULL) == 0);
		for (uint32_t i = 0; i < 3; i++) {
			sphere(&p, 0.2f, 1.0f + (float)i);
			p.has_color = true;
			p.color[2] = 0.125f * (float)(i + 1);
			REQUIRE(bc_tree_put_prim(sub, 11 + i, &p, NULL) == 0);
		}
		REQUIRE(bc_tree_pop_op(sub, NULL) == 0);
		REQUIRE(bc_tree_end(sub, NULL) == 0);
		REQUIRE(bc_tree_insert(t, 1, 1, sub, NULL) == 0);
		CHECK_EQ_INT(bc_tree_child_count(t, 1), 3);
		CHECK_EQ_INT(bc_tree_child(t, 1, 1), 10);
		CHECK_EQ_INT(bc_tree_child_count(t, 10), 3);
		for (uint32_t i = 0; i < 3; i++) {
			CHECK_EQ_INT(bc_tree_child(t, 10, i), 11 + i);
			CHECK_EQ_INT(bc_tree_child_count(t, 11 + i), 0);
			CHECK_EQ_INT(bc_tree_parent(t, 11 + i), 10);
			REQUIRE(bc_tree_get(t, 11 + i, &back, NULL));
			CHECK(back.has_color &&
			      back.color[2] == 0.125f * (float)(i + 1));
			CHECK(back.translate[0] == 1.0f + (float)i);
		}
		if (!bare) {
			CHECK_EQ_INT(differs_from_a_copy(t), 0);
		}
		bc_tree_destroy(sub);
		bc_tree_destroy(t);
	}
}

static const struct bc_test tests[] = {
    {"layout_follows_the_paper", layout_follows_the_paper},
    {"ids_found_in_place_and_in_the_map", ids_found_in_place_and_in_the_map},
    {"builder_rejects_malformed_trees", builder_rejects_malformed_trees},
    {"parameter_edit_rewrites_only_its_own_record",
     parameter_edit_rewrites_only_its_own_record},
    {"operator_edit_equals_a_fresh_build", operator_edit_equals_a_fresh_build},
    {"structural_edits_keep_ids_and_order",
     structural_edits_keep_ids_and_order},
    {"structural_edits_equal_a_fresh_build",
     structural_edits_equal_a_fresh_build},
    {"allocation_failures_are_clean", allocation_failures_are_clean},
    {"prim_data_kept_through_edits", prim_data_kept_through_edits},
    {"a_sphere_record_is_one_vec4", a_sphere_record_is_one_vec4},
    {"spheres_alone_keep_sphere_abvs", spheres_alone_keep_sphere_abvs},
    {"kill_counts_only_where_an_operand_can_die",
     kill_counts_only_where_an_operand_can_die},
    {"primitives_have_no_children", primitives_have_no_children},
};
BC_TEST_MAIN(tests)
