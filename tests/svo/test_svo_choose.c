/*
 * The per-scene choice of the pruning arithmetic (docs/svo.md, "IA against
 * RevAA"): the rule's inputs and its choice. A trial's counts are
 * consistent level to level; the rule weighs the terms each arithmetic
 * keeps by what a term costs; on a sharp scene and on a smooth one RevAA
 * keeps no fewer terms than IA, so IA is chosen, and forcing either
 * arithmetic still works; only scenes with smooth operators or an
 * ellipsoid are given a trial.
 */
#include <stdio.h>

#include "blobcast/svo.h"
#include "svo_util.h"
#include "test.h"

/* Trials of one level whose last level kept kia and krev terms. */
static enum bc_range_arith choose(uint64_t kia, uint64_t krev)
{
	struct bc_svo_trial a = {.arith = BC_RANGE_IA, .levels = 1};
	struct bc_svo_trial b = {.arith = BC_RANGE_REVAA, .levels = 1};
	a.level[0].terms_out = kia;
	b.level[0].terms_out = krev;
	return bc_svo_arith_choose(&a, &b);
}

static void rule_weighs_kept_terms_by_cost(void)
{
	struct bc_svo_trial a = {.levels = 2}, b = {.levels = 3};
	CHECK(choose(100, 100) == BC_RANGE_IA);
	CHECK(choose(100, 200) == BC_RANGE_IA);
	CHECK(choose(0, 0) == BC_RANGE_IA);
	/* At the cost ratio it is a tie, which goes to the cheaper IA. */
	CHECK(choose((uint64_t)(BC_SVO_REVAA_COST * 100.0), 100) ==
	      BC_RANGE_IA);
	CHECK(choose((uint64_t)(BC_SVO_REVAA_COST * 100.0) + 1, 100) ==
	      BC_RANGE_REVAA);
	CHECK(choose(1000, 10) == BC_RANGE_REVAA);
	CHECK(choose(1, 0) == BC_RANGE_REVAA);
	/* Trials of different depths are not compared. */
	a.level[1].terms_out = 1000;
	CHECK(bc_svo_arith_choose(&a, &b) == BC_RANGE_IA);
}

/* Trial counts: each active cell of a level is split into eight cells of
 * the next, which receive the terms it kept. */
static void check_trial(const struct bc_svo_trial *t, uint32_t levels,
                        uint32_t n)
{
	CHECK(t->levels == levels);
	CHECK(t->level[0].cells == 1);
	CHECK(t->level[0].terms_in == n);
	for (uint32_t l = 0; l + 1 < levels; l++) {
		const struct bc_svo_trial_level *p = &t->level[l];
		const struct bc_svo_trial_level *c = &t->level[l + 1];
		CHECK(c->cells == 8 * (p->cells - p->decided));
		CHECK(c->terms_in == 8 * p->terms_out);
		CHECK(p->terms_out <= p->terms_in);
	}
}

static void trial_on(const char *name, const struct bc_gen_opts *o)
{
	struct bc_tree *t = gen_tree(name, o);
	struct bc_svo_rpn rpn;
	struct bc_svo_trial ia, rev;
	struct bc_svo_opts so = {.max_depth = 4};
	struct bc_svo *sv = NULL;
	struct bc_svo_stats st;
	uint32_t last = BC_SVO_TRIAL_LEVELS - 1;
	CHECK(t != NULL);
	if (!t) {
		return;
	}
	CHECK(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	CHECK(bc_svo_trial_run(&rpn, BC_RANGE_IA, 0.0f, BC_SVO_TRIAL_LEVELS,
	                       &ia) == 0);
	CHECK(bc_svo_trial_run(&rpn, BC_RANGE_REVAA, 0.0f, BC_SVO_TRIAL_LEVELS,
	                       &rev) == 0);
	check_trial(&ia, BC_SVO_TRIAL_LEVELS, rpn.n);
	check_trial(&rev, BC_SVO_TRIAL_LEVELS, rpn.n);
	CHECK(ia.arith == BC_RANGE_IA && rev.arith == BC_RANGE_REVAA);
	/* Something was pruned, and RevAA kept no fewer terms. */
	CHECK(ia.level[last].terms_out < ia.level[last].terms_in);
	CHECK(rev.level[last].terms_out >= ia.level[last].terms_out);
	printf("  %s: level %u keeps %llu terms in IA, %llu in RevAA\n", name,
	       last, (unsigned long long)ia.level[last].terms_out,
	       (unsigned long long)rev.level[last].terms_out);
	CHECK(bc_svo_arith_choose(&ia, &rev) == BC_RANGE_IA);
	/* The octree's default makes the same choice; a forced arithmetic
	 * is kept. */
	CHECK(bc_svo_build(&sv, &rpn, &so, NULL) == 0);
	bc_svo_get_stats(sv, &st);
	CHECK(st.arith == BC_RANGE_IA);
	bc_svo_destroy(sv);
	so.arith = BC_RANGE_REVAA;
	CHECK(bc_svo_build(&sv, &rpn, &so, NULL) == 0);
	bc_svo_get_stats(sv, &st);
	CHECK(st.arith == BC_RANGE_REVAA);
	bc_svo_destroy(sv);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

static void trial_picks_ia_on_sharp_and_smooth_scenes(void)
{
	struct bc_gen_opts gears = {.teeth = 24};
	struct bc_gen_opts smooth = {.count = 24};
	trial_on("gears", &gears);
	trial_on("fig18", &smooth);
}

/* Which scenes need a trial at all: smooth operators or an ellipsoid. */
static void only_smooth_or_ellipsoid_scenes_need_a_trial(void)
{
	static const struct {
		const char *gen;
		struct bc_gen_opts o;
		bool differ;
	} cases[] = {
	    {"gears", {.teeth = 24}, false},
	    {"many-spheres", {.count = 50}, false},
	    {"fig18", {.count = 24, .blend = BC_GEN_BLEND_SHARP}, false},
	    {"fig18", {.count = 24}, true},
	    {"comb", {.count = 16, .blend = BC_GEN_BLEND_SMOOTH}, true},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bc_tree *t = gen_tree(cases[i].gen, &cases[i].o);
		struct bc_svo_rpn rpn;
		enum bc_range_arith a = BC_RANGE_DEFAULT;
		CHECK(t != NULL);
		if (!t) {
			continue;
		}
		CHECK(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
		CHECK(bc_svo_arith_may_differ(&rpn) == cases[i].differ);
		CHECK(bc_svo_arith_default(&rpn, 0.0f, &a) == 0);
		CHECK(a == BC_RANGE_IA);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
	/* One ellipsoid is enough. */
	{
		struct rng r = {7};
		struct bc_tree *t = prim_tree(BC_PRIM_ELLIPSOID, &r);
		struct bc_svo_rpn rpn;
		CHECK(t != NULL);
		if (t) {
			CHECK(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
			CHECK(bc_svo_arith_may_differ(&rpn));
			bc_svo_rpn_finish(&rpn);
			bc_tree_destroy(t);
		}
	}
}

static void trial_refuses_bad_levels(void)
{
	struct bc_tree *t = gen_tree("fig18", NULL);
	struct bc_svo_rpn rpn;
	struct bc_svo_trial tr;
	CHECK(t != NULL);
	if (!t) {
		return;
	}
	CHECK(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	CHECK(bc_svo_trial_run(&rpn, BC_RANGE_IA, 0.0f, 0, &tr) == BC_EINVAL);
	CHECK(bc_svo_trial_run(&rpn, BC_RANGE_IA, 0.0f,
	                       BC_SVO_TRIAL_MAX_LEVELS + 1, &tr) == BC_EINVAL);
	CHECK(bc_svo_trial_run(&rpn, BC_RANGE_IA, -1.0f, 2, &tr) == BC_EINVAL);
	CHECK(bc_svo_trial_run(&rpn, BC_RANGE_COUNT, 0.0f, 2, &tr) != 0);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"rule_weighs_kept_terms_by_cost", rule_weighs_kept_terms_by_cost},
    {"trial_picks_ia_on_sharp_and_smooth_scenes",
     trial_picks_ia_on_sharp_and_smooth_scenes},
    {"only_smooth_or_ellipsoid_scenes_need_a_trial",
     only_smooth_or_ellipsoid_scenes_need_a_trial},
    {"trial_refuses_bad_levels", trial_refuses_bad_levels},
};

BC_TEST_MAIN(tests)
