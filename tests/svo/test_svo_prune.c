/*
 * Pruning and the octree: at random points of every generator family the
 * field evaluated through the octree (each leaf's pruned variant) has the
 * same sign as the full field -- against every level of the hit band when
 * the octree keeps one -- in all three arithmetics; pruning counts what it
 * keeps, respects the threshold, depth and memory budget, and frees all it
 * took when an allocation fails.
 */
#include <stdio.h>

#include "blobcast/alloc.h"
#include "blobcast/svo.h"
#include "svo_util.h"
#include "test.h"

struct family {
	const char *name;
	struct bc_gen_opts o;
	enum bc_range_arith arith;
};

/* Every generator family, sharp and smooth variants, spread over the
 * arithmetics. 15 000 points each: 1.65 * 10^5 in all. */
static const struct family families[] = {
    {"fig16", {.level = 2}, BC_RANGE_REVAA},
    {"fig18", {.count = 96}, BC_RANGE_IA},
    {"fig18",
     {.count = 96, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SHARP},
     BC_RANGE_REVAA},
    {"fig18", {.count = 48, .kind = BC_GEN_KIND_LENSES}, BC_RANGE_AA},
    {"comb", {.count = 64, .blend = BC_GEN_BLEND_SMOOTH}, BC_RANGE_REVAA},
    /* Random trees are mostly empty (intersections of random shapes):
     * these seeds make some solid. */
    {"random", {.count = 60, .seed = 17}, BC_RANGE_REVAA},
    {"random", {.count = 60, .seed = 18}, BC_RANGE_AA},
    {"random", {.count = 60, .seed = 28}, BC_RANGE_IA},
    {"gears", {.teeth = 24}, BC_RANGE_REVAA},
    {"many-gears", {.count = 9}, BC_RANGE_IA},
    {"many-spheres", {.count = 400}, BC_RANGE_REVAA},
};
#define POINTS_PER_FAMILY 15000

static const char *const arith_names[] = {"", "ia", "aa", "revaa"};

/* Every other sample is uniform in the scene's box; the others are drawn
 * until one lands within 2% of the diagonal from the surface (a few dozen
 * tries at most), where pruning decisions are closest to wrong. */
static void near_surface_point(struct rng *r, const struct bc_lin *l, int i,
                               float p[3])
{
	rng_point(r, l, 0.05f * l->size, p);
	for (int k = 0; (i & 1) && k < 64; k++) {
		if (fabsf(bc_eval_full(l, p)) < 0.02f * l->size) {
			return;
		}
		rng_point(r, l, 0.05f * l->size, p);
	}
}

static void octree_sign_equals_full_sign_for_every_family(void)
{
	uint64_t total = 0;
	for (size_t f = 0; f < sizeof(families) / sizeof(families[0]); f++) {
		const struct family *fam = &families[f];
		struct bc_tree *t = gen_tree(fam->name, &fam->o);
		/* Depth 7 (cells 1/128 of the scene) keeps the dense smooth
		 * scenes' octrees small enough for a sanitizer build. */
		struct bc_svo_opts so = {.arith = fam->arith, .max_depth = 7};
		struct bc_svo_rpn rpn;
		struct bc_svo *s = NULL;
		struct bc_svo_stats st;
		struct bc_errinfo ei = {0};
		const struct bc_lin *l;
		struct rng r = {1000 + f};
		uint32_t bad = 0, inside = 0;
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
		REQUIRE(bc_svo_build(&s, &rpn, &so, &ei) == 0);
		bc_svo_get_stats(s, &st);
		for (int i = 0; i < POINTS_PER_FAMILY; i++) {
			float p[3], a, b;
			near_surface_point(&r, l, i, p);
			a = bc_eval_full(l, p);
			b = bc_svo_eval(s, p);
			inside += a < 0.0f;
			if ((a < 0.0f) != (b < 0.0f) && bad++ < 3) {
				fprintf(stderr,
				        "  %s/%s at (%g %g %g): full %.9g, svo "
				        "%.9g\n",
				        fam->name, arith_names[fam->arith],
				        (double)p[0], (double)p[1],
				        (double)p[2], (double)a, (double)b);
			}
		}
		total += POINTS_PER_FAMILY;
		CHECK_EQ_INT(bad, 0);
		/* The sample must see both sides of the surface. */
		CHECK(inside > 0 && inside < POINTS_PER_FAMILY);
		/* Leaves obey the threshold unless the depth stopped them. */
		CHECK(st.max_terms <= BC_SVO_DEFAULT_THRESHOLD ||
		      st.max_depth == 7 || st.stalled > 0);
		/* Pruning removed most of the tree at a random point. */
		CHECK(st.avg_terms < 0.5 * rpn.n || rpn.n <= 16);
		printf("  %-12s %-5s terms %6u  leaves %6u  avg terms %6.2f  "
		       "avg depth %4.2f\n",
		       fam->name, arith_names[fam->arith], rpn.n, st.leaves,
		       st.avg_terms, st.avg_depth);
		bc_svo_destroy(s);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
	CHECK(total >= 100000);
}

/* With a band b the octree keeps the sign of f - c for every c in [0, b]:
 * what the ray caster's hit criterion needs. */
static void octree_keeps_the_sign_against_every_band_level(void)
{
	static const struct family fams[] = {
	    {"gears", {.teeth = 16}, BC_RANGE_REVAA},
	    {"random", {.count = 50, .seed = 9}, BC_RANGE_IA},
	    {"fig18", {.count = 64}, BC_RANGE_AA},
	};
	for (size_t f = 0; f < sizeof(fams) / sizeof(fams[0]); f++) {
		struct bc_tree *t = gen_tree(fams[f].name, &fams[f].o);
		struct bc_svo_rpn rpn;
		struct bc_svo *s = NULL;
		const struct bc_lin *l;
		struct rng r = {77 + f};
		uint32_t bad = 0;
		float band;
		REQUIRE(t);
		l = bc_tree_lin(t);
		band = 0.02f * l->size;
		{
			struct bc_svo_opts so = {.arith = fams[f].arith,
			                         .band = band,
			                         .max_depth = 7};
			REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
			REQUIRE(bc_svo_build(&s, &rpn, &so, NULL) == 0);
		}
		for (int i = 0; i < 6000; i++) {
			float p[3], a, b, c = band * (float)(i % 4) / 3.0f;
			near_surface_point(&r, l, i, p);
			a = bc_eval_full(l, p);
			b = bc_svo_eval(s, p);
			bad += (a < c) != (b < c);
		}
		CHECK_EQ_INT(bad, 0);
		bc_svo_destroy(s);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

/* bc_svo_prune reports the terms it keeps, never keeps more than it got,
 * and its variant has the input's sign over the region. */
static void prune_counts_what_it_keeps(void)
{
	struct bc_gen_opts o = {.count = 80, .seed = 4};
	struct bc_tree *t = gen_tree("random", &o);
	struct bc_svo_rpn rpn;
	struct bc_svo_ranger *g;
	const struct bc_lin *l;
	uint32_t *full, *m;
	struct rng r = {5};
	uint32_t bad = 0;
	REQUIRE(t);
	l = bc_tree_lin(t);
	REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
	REQUIRE(bc_svo_ranger_create(&g, &rpn, BC_RANGE_REVAA) == 0);
	full = calloc(rpn.nwords, sizeof(*full));
	m = calloc(rpn.nwords, sizeof(*m));
	REQUIRE(full && m);
	bc_svo_mask_fill(&rpn, full);
	for (int round = 0; round < 300; round++) {
		struct bc_svo_region rg;
		struct bc_svo_prune_result res;
		rng_box(&r, l, 0.3f, &rg);
		REQUIRE(bc_svo_prune(g, full, m, &rg, 0.0f, &res) == 0);
		CHECK(res.state > BC_SVO_STATE_INVALID &&
		      res.state < BC_SVO_STATE_COUNT);
		CHECK_EQ_INT(bc_svo_mask_count(m, rpn.nwords), res.nterms);
		CHECK(res.nterms <= rpn.n);
		for (int k = 0; k < 30; k++) {
			float p[3], a, b;
			rng_in(&r, &rg, p);
			a = bc_eval_full(l, p);
			b = res.state == BC_SVO_STATE_ACTIVE
			        ? bc_svo_rpn_eval(&rpn, m, p)
			        : (res.state == BC_SVO_STATE_EMPTY ? 1.0f
			                                           : -1.0f);
			bad += (a < 0.0f) != (b < 0.0f);
		}
	}
	CHECK_EQ_INT(bad, 0);
	{
		struct bc_svo_region rg;
		struct bc_svo_prune_result res;
		rng_box(&r, l, 0.3f, &rg);
		CHECK(bc_svo_prune(g, full, m, &rg, -1.0f, &res) == BC_EINVAL);
	}
	free(full);
	free(m);
	bc_svo_ranger_destroy(g);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

/* The thesis's uniform grid: every voxel pruned from the full tree. */
static void grid_sign_equals_full_sign(void)
{
	struct bc_gen_opts o = {.teeth = 12};
	struct bc_tree *t = gen_tree("gears", &o);
	struct bc_svo_rpn rpn;
	struct bc_svo_grid *gr = NULL;
	const struct bc_lin *l;
	struct rng r = {13};
	double ms, avg;
	uint32_t most, bad = 0;
	uint64_t bytes;
	REQUIRE(t);
	l = bc_tree_lin(t);
	REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
	REQUIRE(bc_svo_grid_build(&gr, &rpn, BC_RANGE_REVAA, 10, &ms) == 0);
	for (int i = 0; i < 10000; i++) {
		float p[3];
		rng_point(&r, l, 0.05f * l->size, p);
		bad += (bc_eval_full(l, p) < 0.0f) !=
		       (bc_svo_grid_eval(gr, p) < 0.0f);
	}
	CHECK_EQ_INT(bad, 0);
	bc_svo_grid_stats(gr, &avg, &most, &bytes);
	CHECK(avg < 0.25 * rpn.n);
	CHECK(most <= rpn.n);
	CHECK(bytes > 0);
	CHECK(ms >= 0.0);
	bc_svo_grid_destroy(gr);
	CHECK(bc_svo_grid_build(&gr, &rpn, BC_RANGE_IA, 0, &ms) == BC_ERANGE);
	CHECK(bc_svo_grid_build(&gr, &rpn, BC_RANGE_IA, BC_SVO_MAX_GRID + 1,
	                        &ms) == BC_ERANGE);
	CHECK(gr == NULL);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

/* Threshold and depth shape the octree as the thesis's tables show: a
 * smaller threshold gives deeper trees with shorter variants. */
static void threshold_trades_depth_for_terms(void)
{
	struct bc_gen_opts o = {.count = 16};
	struct bc_tree *t = gen_tree("many-gears", &o);
	struct bc_svo_rpn rpn;
	struct bc_svo_stats prev = {0};
	static const uint32_t taus[] = {64, 16, 4};
	REQUIRE(t);
	REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	for (size_t i = 0; i < 3; i++) {
		struct bc_svo_opts so = {.threshold = taus[i], .max_depth = 8};
		struct bc_svo *s = NULL;
		struct bc_svo_stats st;
		REQUIRE(bc_svo_build(&s, &rpn, &so, NULL) == 0);
		bc_svo_get_stats(s, &st);
		CHECK(st.max_depth <= 8);
		CHECK(st.max_terms <= taus[i] || st.max_depth == 8);
		CHECK(st.leaves == st.empty + st.full + st.active);
		CHECK(st.nodes == 8 * ((st.nodes - 1) / 8) + 1);
		if (i > 0) {
			CHECK(st.avg_depth >= prev.avg_depth);
			CHECK(st.avg_terms <= prev.avg_terms);
			CHECK(st.bytes >= prev.bytes);
		}
		prev = st;
		bc_svo_destroy(s);
	}
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

/* A memory budget too small for the threshold stops subdivision early:
 * leaves keep more terms, signs stay right. */
static void memory_budget_truncates_but_stays_exact(void)
{
	struct bc_gen_opts o = {.count = 16};
	struct bc_tree *t = gen_tree("many-gears", &o);
	struct bc_svo_rpn rpn;
	struct bc_svo_opts so = {.threshold = 2, .max_bytes = 200000};
	struct bc_svo *s = NULL;
	struct bc_svo_stats st;
	const struct bc_lin *l;
	struct rng r = {3};
	uint32_t bad = 0;
	REQUIRE(t);
	l = bc_tree_lin(t);
	REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
	REQUIRE(bc_svo_build(&s, &rpn, &so, NULL) == 0);
	bc_svo_get_stats(s, &st);
	CHECK(st.truncated);
	CHECK(st.bytes < 2 * so.max_bytes);
	for (int i = 0; i < 5000; i++) {
		float p[3];
		rng_point(&r, l, 0.0f, p);
		bad +=
		    (bc_eval_full(l, p) < 0.0f) != (bc_svo_eval(s, p) < 0.0f);
	}
	CHECK_EQ_INT(bad, 0);
	bc_svo_destroy(s);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

static void bad_options_are_refused(void)
{
	struct bc_gen_opts o = {.count = 10, .seed = 1};
	struct bc_tree *t = gen_tree("random", &o);
	struct bc_svo_rpn rpn;
	struct bc_svo *s = NULL;
	struct bc_svo_ranger *g = NULL;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	CHECK(bc_svo_build(
	          &s, &rpn,
	          &(struct bc_svo_opts){.max_depth = BC_SVO_MAX_DEPTH + 1},
	          &ei) == BC_ERANGE);
	CHECK(strstr(ei.msg, "depth") != NULL);
	CHECK(bc_svo_build(&s, &rpn, &(struct bc_svo_opts){.band = -1.0f},
	                   &ei) == BC_ERANGE);
	CHECK(bc_svo_build(&s, &rpn,
	                   &(struct bc_svo_opts){.arith = BC_RANGE_COUNT},
	                   &ei) == BC_EENUM);
	CHECK(s == NULL);
	CHECK(bc_svo_ranger_create(&g, &rpn, (enum bc_range_arith)77) ==
	      BC_EENUM);
	CHECK(g == NULL);
	{
		struct bc_svo_rpn none;
		CHECK(bc_svo_rpn_init(&none, NULL) == BC_EINVAL);
		bc_svo_rpn_finish(&none);
	}
	bc_svo_rpn_finish(&rpn);
	bc_svo_destroy(NULL);
	bc_svo_ranger_destroy(NULL);
	bc_tree_destroy(t);
}

/* Every allocation of compiling and building, failed in turn: each failure
 * is reported and frees what it took (ASan's leak check watches). */
static void allocation_failures_free_everything(void)
{
	struct bc_gen_opts o = {.count = 30, .seed = 8};
	struct bc_tree *t = gen_tree("random", &o);
	bool done = false;
	REQUIRE(t);
	for (unsigned long n = 1; n < 10000 && !done; n++) {
		struct bc_svo_rpn rpn;
		struct bc_svo *s = NULL;
		struct bc_svo_opts so = {.arith = n % 2 ? BC_RANGE_AA
		                                        : BC_RANGE_REVAA};
		int rc;
		bc_alloc_fail_after(n);
		rc = bc_svo_rpn_init(&rpn, bc_tree_lin(t));
		if (rc == 0) {
			rc = bc_svo_build(&s, &rpn, &so, NULL);
			bc_svo_destroy(s);
			bc_svo_rpn_finish(&rpn);
		}
		bc_alloc_fail_after(0);
		CHECK(rc == 0 || rc == BC_ENOMEM);
		done = rc == 0;
	}
	CHECK(done);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"octree_sign_equals_full_sign_for_every_family",
     octree_sign_equals_full_sign_for_every_family},
    {"octree_keeps_the_sign_against_every_band_level",
     octree_keeps_the_sign_against_every_band_level},
    {"prune_counts_what_it_keeps", prune_counts_what_it_keeps},
    {"grid_sign_equals_full_sign", grid_sign_equals_full_sign},
    {"threshold_trades_depth_for_terms", threshold_trades_depth_for_terms},
    {"memory_budget_truncates_but_stays_exact",
     memory_budget_truncates_but_stays_exact},
    {"bad_options_are_refused", bad_options_are_refused},
    {"allocation_failures_free_everything",
     allocation_failures_free_everything},
};

BC_TEST_MAIN(tests)
