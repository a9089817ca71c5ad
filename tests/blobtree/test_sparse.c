/*
 * Property tests of the sparse bottom-up traversal (pruned tree views):
 * over 1000 random trees with every operator, the view built from the
 * primitives whose ABV meets a query box has the sign of the full field
 * everywhere inside the box, and dropping a primitive changes no sign outside
 * its ABV. Plus exactness checks (all primitives active == full evaluation)
 * and the left-comb case the jump pointers exist for. The three properties
 * run again over trees where a third of the subtrees sit under random unary
 * and domain nodes (offset, onion, elongate, twist, bend, mirror, repeat,
 * scale), with a comb under a unary node for the climb that must stop.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "test.h"

#include "randtree.h"

#define NTREES 1000
/* Signs are compared where the full field is not within rounding of 0. */
#define SIGN_EPS 1e-4f

static int sign_of(float f)
{
	return f < 0.0f ? -1 : 1;
}

static void random_point(const float lo[3], const float hi[3], float p[3])
{
	for (int i = 0; i < 3; i++) {
		p[i] = rt_float(lo[i], hi[i]);
	}
}

static void random_box(const struct bc_lin *l, float lo[3], float hi[3])
{
	for (int i = 0; i < 3; i++) {
		float ext = l->hi[i] - l->lo[i];
		float size = rt_float(0.02f, 0.6f) * ext;
		lo[i] = rt_float(l->lo[i] - 0.1f * ext, l->hi[i] - size);
		hi[i] = lo[i] + size;
	}
}

static void sign_props(int ntrees, float rate);

static void sparse_sign_matches_full_inside_query_boxes(void)
{
	sign_props(NTREES, 0.0f);
}

static void sparse_sign_with_unary_nodes(void)
{
	sign_props(NTREES / 2, 0.35f);
	rt_unary_rate = 0.0f;
}

static void sign_props(int ntrees, float rate)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_view v;
	uint32_t *active = bc_calloc(64, sizeof(uint32_t));
	long checked = 0, mismatches = 0, pruned = 0, total = 0;
	bc_view_init(&v);
	REQUIRE(t && active);
	rt_unary_rate = rate;
	for (int tree = 0; tree < ntrees; tree++) {
		const struct bc_lin *l;
		REQUIRE(rt_build(t, 1000u + (uint64_t)tree,
		                 1 + (uint32_t)(tree % 64)) == 0);
		l = bc_tree_lin(t);
		REQUIRE(l != NULL);
		for (int q = 0; q < 6; q++) {
			float lo[3], hi[3];
			uint32_t n = 0;
			random_box(l, lo, hi);
			for (uint32_t k = 0; k < l->nprims; k++) {
				struct bc_abv a = bc_lin_abv(l, k);
				if (bc_abv_meets_box(&a, lo, hi)) {
					active[n++] = k;
				}
			}
			total += l->nprims;
			pruned += l->nprims - n;
			REQUIRE(bc_view_build(&v, l, active, n) == 0);
			for (int s = 0; s < 40; s++) {
				float p[3], full, sparse;
				random_point(lo, hi, p);
				full = bc_eval_full(l, p);
				sparse = bc_view_eval(&v, l, p);
				if (fabsf(full) < SIGN_EPS) {
					continue;
				}
				checked++;
				if (sign_of(full) != sign_of(sparse)) {
					mismatches++;
					if (mismatches < 5) {
						fprintf(stderr,
						        "  tree %d: full %g "
						        "sparse %g "
						        "(%u of %u active)\n",
						        tree, (double)full,
						        (double)sparse, n,
						        l->nprims);
					}
				}
			}
		}
	}
	printf("  %ld points checked, %ld sign mismatches, %.1f%% of "
	       "primitives pruned\n",
	       checked, mismatches, 100.0 * (double)pruned / (double)total);
	CHECK(checked > 100 * ntrees);
	CHECK(mismatches == 0);
	/* The boxes are small: pruning must actually remove primitives. */
	CHECK(pruned > total / 5);
	bc_view_finish(&v);
	bc_free(active);
	bc_tree_destroy(t);
}

static void drop_props(int ntrees, float rate);

static void dropping_a_primitive_changes_nothing_outside_its_abv(void)
{
	drop_props(NTREES, 0.0f);
}

static void dropping_under_unary_nodes_changes_nothing_outside_abv(void)
{
	drop_props(NTREES / 2, 0.35f);
	rt_unary_rate = 0.0f;
}

static void drop_props(int ntrees, float rate)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_view v;
	uint32_t *active = bc_calloc(64, sizeof(uint32_t));
	long checked = 0, mismatches = 0;
	bc_view_init(&v);
	REQUIRE(t && active);
	rt_unary_rate = rate;
	for (int tree = 0; tree < ntrees; tree++) {
		const struct bc_lin *l;
		uint32_t drop, n = 0;
		REQUIRE(rt_build(t, 5000u + (uint64_t)tree,
		                 2 + (uint32_t)(tree % 63)) == 0);
		l = bc_tree_lin(t);
		drop = rt_below(l->nprims);
		for (uint32_t k = 0; k < l->nprims; k++) {
			if (k != drop) {
				active[n++] = k;
			}
		}
		REQUIRE(bc_view_build(&v, l, active, n) == 0);
		for (int s = 0; s < 60; s++) {
			float p[3], full, sparse;
			random_point(l->lo, l->hi, p);
			struct bc_abv a = bc_lin_abv(l, drop);
			if (bc_abv_meets_box(&a, p, p)) {
				continue;
			}
			full = bc_eval_full(l, p);
			if (fabsf(full) < SIGN_EPS) {
				continue;
			}
			sparse = bc_view_eval(&v, l, p);
			checked++;
			mismatches += sign_of(full) != sign_of(sparse);
		}
	}
	printf("  %ld points checked, %ld sign mismatches\n", checked,
	       mismatches);
	CHECK(checked > 20 * ntrees);
	CHECK(mismatches == 0);
	bc_view_finish(&v);
	bc_free(active);
	bc_tree_destroy(t);
}

static void all_active_props(float rate);

static void all_active_view_equals_full_evaluation(void)
{
	all_active_props(0.0f);
}

static void all_active_view_with_unary_nodes_equals_full(void)
{
	all_active_props(0.35f);
	rt_unary_rate = 0.0f;
}

/* Value-changing unary nodes of l: each is one view instruction. */
static uint32_t value_unaries(const struct bc_lin *l)
{
	uint32_t n = 0;
	for (uint32_t u = 0; u < l->nunary; u++) {
		n += bc_op_has_value((enum bc_op)l->unary_kind[u]) ? 1u : 0u;
	}
	return n;
}

static void all_active_props(float rate)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_view v;
	uint32_t active[64];
	bc_view_init(&v);
	REQUIRE(t);
	rt_unary_rate = rate;
	for (int tree = 0; tree < 200; tree++) {
		const struct bc_lin *l;
		REQUIRE(rt_build(t, 9000u + (uint64_t)tree,
		                 1 + (uint32_t)(tree % 64)) == 0);
		l = bc_tree_lin(t);
		for (uint32_t k = 0; k < l->nprims; k++) {
			active[k] = k;
		}
		REQUIRE(bc_view_build(&v, l, active, l->nprims) == 0);
		CHECK_EQ_INT(v.n, l->count + value_unaries(l));
		CHECK(v.stack <= l->stack);
		for (int s = 0; s < 20; s++) {
			float p[3];
			uint32_t id_full, id_view;
			random_point(l->lo, l->hi, p);
			CHECK(bc_eval_full_id(l, p, &id_full) ==
			      bc_view_eval_id(&v, l, p, &id_view));
			CHECK(id_full == id_view);
		}
	}
	bc_view_finish(&v);
	bc_tree_destroy(t);
}

static void views_reject_unsorted_or_out_of_range_sets(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_view v;
	uint32_t bad_order[2] = {3, 1}, bad_index[1] = {99};
	bc_view_init(&v);
	REQUIRE(t && rt_build(t, 7, 8) == 0);
	CHECK(bc_view_build(&v, bc_tree_lin(t), bad_order, 2) == BC_EINVAL);
	CHECK(bc_view_build(&v, bc_tree_lin(t), bad_index, 1) == BC_EINVAL);
	CHECK(bc_view_build(&v, bc_tree_lin(t), NULL, 0) == 0);
	CHECK(v.empty);
	CHECK(isinf(bc_view_eval(&v, bc_tree_lin(t), (float[3]){0, 0, 0})));
	bc_view_finish(&v);
	bc_tree_destroy(t);
}

/* A left comb of spheres on the x axis: one n-ary union. */
static struct bc_tree *comb(uint32_t n, enum bc_op op)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {op, 0.1f, 0.2f};
	struct bc_prim_data s;
	if (!t) {
		return NULL;
	}
	bc_tree_begin(t);
	bc_tree_push_op(t, 0, &u, NULL);
	bc_prim_data_init(&s, BC_PRIM_SPHERE);
	s.params[0] = 0.4f;
	for (uint32_t i = 0; i < n; i++) {
		s.translate[0] = 0.5f * (float)i;
		if (bc_tree_put_prim(t, 0, &s, NULL)) {
			bc_tree_destroy(t);
			return NULL;
		}
	}
	bc_tree_pop_op(t, NULL);
	if (bc_tree_end(t, NULL)) {
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

static void comb_views_are_short_whatever_the_comb_length(void)
{
	enum bc_op ops[2] = {BC_OP_UNION, BC_OP_SMOOTH_UNION};
	for (int o = 0; o < 2; o++) {
		struct bc_tree *t = comb(20000, ops[o]);
		const struct bc_lin *l;
		struct bc_view v;
		uint32_t active[2] = {777, 778};
		float p[3] = {0.5f * 777.5f, 0.1f, 0.0f};
		REQUIRE(t);
		l = bc_tree_lin(t);
		bc_view_init(&v);
		REQUIRE(bc_view_build(&v, l, active, 2) == 0);
		/* Two leaves and the one operator joining them. */
		CHECK_EQ_INT(v.n, 3);
		CHECK_NEAR(bc_view_eval(&v, l, p), bc_eval_full(l, p), 1e-6f);
		bc_view_finish(&v);
		bc_tree_destroy(t);
	}
}

/* offset(union(comb)) and an onion inside it: a view over two far-apart
 * comb members must stop at the offset (and apply it) however long the
 * comb, and equal the full field. */
static void comb_under_unary_nodes_keeps_their_values(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	struct bc_unary off, tw;
	struct bc_prim_data s;
	struct bc_view v;
	const struct bc_lin *l;
	uint32_t active[2] = {300, 1700};
	REQUIRE(t);
	bc_unary_init(&off, BC_OP_OFFSET);
	off.u[0] = 0.25f;
	bc_unary_init(&tw, BC_OP_ONION);
	tw.u[0] = 0.1f;
	bc_prim_data_init(&s, BC_PRIM_BOX);
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_unary(t, 0, &off, NULL) == 0);
	REQUIRE(bc_tree_push_op(t, 0, &u, NULL) == 0);
	for (uint32_t i = 0; i < 2000; i++) {
		s.translate[0] = 3.0f * (float)i;
		if (i == 1700) {
			REQUIRE(bc_tree_push_unary(t, 0, &tw, NULL) == 0);
		}
		REQUIRE(bc_tree_put_prim(t, 0, &s, NULL) == 0);
		if (i == 1700) {
			REQUIRE(bc_tree_pop_op(t, NULL) == 0);
		}
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	l = bc_tree_lin(t);
	bc_view_init(&v);
	REQUIRE(bc_view_build(&v, l, active, 2) == 0);
	/* leaf, leaf, onion, union, offset. */
	CHECK_EQ_INT(v.n, 5);
	for (int i = 0; i < 200; i++) {
		float p[3] = {rt_float(899.0f, 901.0f), rt_float(-1.0f, 1.0f),
		              rt_float(-1.0f, 1.0f)};
		if (i & 1) {
			p[0] += 4200.0f;
		}
		/* The other comb members are 1.5 or more away, farther than
		 * these two: the view equals the full field. */
		CHECK_NEAR(bc_view_eval(&v, l, p), bc_eval_full(l, p), 1e-5f);
	}
	bc_view_finish(&v);
	bc_tree_destroy(t);
}

static void intersection_and_difference_prune_to_missing(void)
{
	/* difference(A, B) with only B active is missing (+inf); with only A
	 * active it is A. intersection with one operand is missing. */
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data d = {BC_OP_DIFFERENCE, 0, 0};
	struct bc_prim_data s;
	struct bc_view v;
	uint32_t a = 0, b = 1;
	float p[3] = {0, 0, 0};
	REQUIRE(t);
	bc_view_init(&v);
	bc_tree_begin(t);
	bc_tree_push_op(t, 10, &d, NULL);
	bc_prim_data_init(&s, BC_PRIM_SPHERE);
	s.params[0] = 1.0f;
	bc_tree_put_prim(t, 11, &s, NULL);
	s.params[0] = 0.5f;
	s.translate[0] = 0.8f;
	bc_tree_put_prim(t, 12, &s, NULL);
	bc_tree_pop_op(t, NULL);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	REQUIRE(bc_view_build(&v, bc_tree_lin(t), &b, 1) == 0);
	CHECK(v.empty);
	REQUIRE(bc_view_build(&v, bc_tree_lin(t), &a, 1) == 0);
	CHECK(!v.empty && v.n == 1);
	CHECK_NEAR(bc_view_eval(&v, bc_tree_lin(t), p), -1.0f, 1e-6f);
	bc_view_finish(&v);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"sparse_sign_matches_full_inside_query_boxes",
     sparse_sign_matches_full_inside_query_boxes},
    {"dropping_a_primitive_changes_nothing_outside_its_abv",
     dropping_a_primitive_changes_nothing_outside_its_abv},
    {"all_active_view_equals_full_evaluation",
     all_active_view_equals_full_evaluation},
    {"views_reject_unsorted_or_out_of_range_sets",
     views_reject_unsorted_or_out_of_range_sets},
    {"comb_views_are_short_whatever_the_comb_length",
     comb_views_are_short_whatever_the_comb_length},
    {"intersection_and_difference_prune_to_missing",
     intersection_and_difference_prune_to_missing},
    {"sparse_sign_with_unary_nodes", sparse_sign_with_unary_nodes},
    {"dropping_under_unary_nodes_changes_nothing_outside_abv",
     dropping_under_unary_nodes_changes_nothing_outside_abv},
    {"all_active_view_with_unary_nodes_equals_full",
     all_active_view_with_unary_nodes_equals_full},
    {"comb_under_unary_nodes_keeps_their_values",
     comb_under_unary_nodes_keeps_their_values},
};
BC_TEST_MAIN(tests)
