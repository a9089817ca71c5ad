/*
 * The svo module's foundations: the bitmask walks (thesis Alg. 5.2 and its
 * reverse) against a plain scan, the RPN's full evaluation against the
 * blobtree's reference evaluator, subtree clearing (Alg. 5.5), and the
 * enclosure property of the three range arithmetics -- every sampled value
 * of every primitive kind, every operator and whole random trees lies in
 * the range computed over the region it was sampled from.
 */
#include <stdio.h>

#include "blobcast/svo.h"
#include "svo_util.h"
#include "test.h"

static const enum bc_range_arith ariths[] = {BC_RANGE_IA, BC_RANGE_AA,
                                             BC_RANGE_REVAA};
static const char *const arith_names[] = {"", "ia", "aa", "revaa"};

static uint32_t scan_next(const uint32_t *m, uint32_t nwords, uint32_t i)
{
	for (; i < nwords * 32u; i++) {
		if ((m[i >> 5] >> (i & 31u)) & 1u) {
			return i;
		}
	}
	return UINT32_MAX;
}

static uint32_t scan_prev(const uint32_t *m, uint32_t i)
{
	for (;;) {
		if ((m[i >> 5] >> (i & 31u)) & 1u) {
			return i;
		}
		if (i == 0) {
			return UINT32_MAX;
		}
		i--;
	}
}

static void bits_walks_match_a_plain_scan(void)
{
	struct rng r = {1};
	uint32_t m[9];
	for (int round = 0; round < 400; round++) {
		/* Densities from empty to full, single bits at word edges. */
		int kind = round % 5;
		for (int w = 0; w < 9; w++) {
			uint64_t v = rng_next(&r);
			m[w] = kind == 0   ? 0u
			       : kind == 1 ? (uint32_t)v & (uint32_t)(v >> 32) &
			                         (uint32_t)(v >> 16)
			       : kind == 2 ? (uint32_t)v
			       : kind == 3 ? (1u << (v % 32u)) * (v % 3u == 0)
			                   : 0xffffffffu;
		}
		if (round % 7 == 0) {
			m[0] = 1u;
			m[8] = 0x80000000u;
		}
		for (uint32_t i = 0; i < 9 * 32; i++) {
			CHECK_EQ_INT(bc_svo_bits_next(m, 9, i),
			             scan_next(m, 9, i));
			CHECK_EQ_INT(bc_svo_bits_prev(m, i), scan_prev(m, i));
		}
		CHECK_EQ_INT(bc_svo_bits_next(m, 9, 9 * 32), UINT32_MAX);
	}
	CHECK_EQ_INT(bc_svo_bits_prev(m, UINT32_MAX), UINT32_MAX);
}

static void mask_fill_sets_exactly_the_terms(void)
{
	struct bc_gen_opts o = {.count = 40, .seed = 3};
	struct bc_tree *t = gen_tree("random", &o);
	struct bc_svo_rpn rpn;
	uint32_t *m;
	REQUIRE(t);
	REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	m = calloc(rpn.nwords, sizeof(*m));
	REQUIRE(m);
	bc_svo_mask_fill(&rpn, m);
	CHECK_EQ_INT(bc_svo_mask_count(m, rpn.nwords), rpn.n);
	CHECK_EQ_INT(scan_prev(m, rpn.nwords * 32u - 1u), rpn.n - 1u);
	free(m);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

/* The RPN (with differences as negation + intersection) computes the same
 * floats as the post-order reference evaluator, and decides the same
 * primitive. */
static void full_variant_equals_reference_evaluator(void)
{
	static const char *const names[] = {
	    "random", "random", "gears", "fig16", "fig18", "comb", "catalogue"};
	struct rng r = {7};
	for (size_t s = 0; s < sizeof(names) / sizeof(names[0]); s++) {
		struct bc_gen_opts o = {0};
		struct bc_tree *t;
		const struct bc_lin *l;
		struct bc_svo_rpn rpn;
		struct bc_svo_cmask cm;
		float q4[4][3], f4ref[4];
		uint32_t *m, *pairs, bad = 0, badid = 0, bad4 = 0;
		if (s < 2) {
			o.count = 60;
			o.seed = 11 + s;
		} else if (s == 3) {
			o.level = 1;
		} else if (s == 4) {
			o.count = 40;
		}
		t = gen_tree(names[s], &o);
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
		m = calloc(rpn.nwords, sizeof(*m));
		REQUIRE(m);
		bc_svo_mask_fill(&rpn, m);
		pairs = calloc(2u * rpn.nwords, sizeof(*pairs));
		REQUIRE(pairs);
		for (uint32_t w = 0; w < rpn.nwords; w++) {
			pairs[2 * w] = w;
			pairs[2 * w + 1] = m[w];
		}
		cm.pairs = pairs;
		cm.nwords = rpn.nwords;
		for (int i = 0; i < 3000; i++) {
			float p[3], f4[4];
			uint32_t a = 0, b = 0;
			rng_point(&r, l, 0.1f * l->size, p);
			float fa = bc_eval_full_id(l, p, &a);
			float fb = bc_svo_rpn_eval_id(&rpn, m, p, &b);
			bad += !(fa == fb);
			badid += a != b;
			/* The four-point batch of the normals, on the
			 * compressed form of the same variant. */
			memcpy(q4[i % 4], p, sizeof(p));
			f4ref[i % 4] = fa;
			if (i % 4 == 3) {
				bc_svo_cmask_eval4(&rpn, cm, q4, f4);
				for (int j = 0; j < 4; j++) {
					bad4 += !(f4[j] == f4ref[j]);
				}
			}
		}
		CHECK_EQ_INT(bad, 0);
		CHECK_EQ_INT(badid, 0);
		CHECK_EQ_INT(bad4, 0);
		free(m);
		free(pairs);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

static void clear_subtree_clears_exactly_the_subtree(void)
{
	struct bc_gen_opts o = {.count = 80, .seed = 5};
	struct bc_tree *t = gen_tree("random", &o);
	struct bc_svo_rpn rpn;
	struct rng r = {9};
	uint32_t *m;
	REQUIRE(t);
	REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	m = calloc(rpn.nwords, sizeof(*m));
	REQUIRE(m);
	for (int round = 0; round < 300; round++) {
		uint32_t i = rng_below(&r, rpn.n), first = rpn.terms[i].first;
		bc_svo_mask_fill(&rpn, m);
		bc_svo_rpn_clear_subtree(&rpn, m, i);
		for (uint32_t k = 0; k < rpn.n; k++) {
			bool set = (m[k >> 5] >> (k & 31u)) & 1u;
			CHECK(set == (k < first || k > i));
		}
	}
	free(m);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

/* Picks a sample of the region: a random point, or now and then a corner
 * (or an end), where extremes of monotone pieces lie. */
static void sample(struct rng *r, const struct bc_svo_region *rg, float p[3])
{
	uint32_t c = rng_below(r, 10);
	if (c >= 8) {
		rng_in(r, rg, p);
		return;
	}
	if (rg->segment) {
		float t = (c & 1u) ? rg->t1 : rg->t0;
		for (int i = 0; i < 3; i++) {
			p[i] = rg->o[i] + t * rg->d[i];
		}
		return;
	}
	for (int i = 0; i < 3; i++) {
		p[i] = (c >> i) & 1u ? rg->hi[i] : rg->lo[i];
	}
	if (rng_below(r, 2)) {
		rng_in(r, rg, p);
	}
}

static void ranges_enclose_every_primitive_kind(void)
{
	struct rng r = {21};
	for (int k = BC_PRIM_INVALID + 1; k < BC_PRIM_COUNT; k++) {
		for (size_t a = 0; a < 3; a++) {
			uint32_t bad = 0, n = 0;
			double width = 0.0;
			for (int tr = 0; tr < 6; tr++) {
				struct bc_tree *t =
				    prim_tree((enum bc_prim)k, &r);
				const struct bc_lin *l;
				struct bc_svo_rpn rpn;
				struct bc_svo_ranger *g;
				REQUIRE(t);
				l = bc_tree_lin(t);
				REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
				REQUIRE(bc_svo_ranger_create(&g, &rpn,
				                             ariths[a]) == 0);
				for (int b = 0; b < 60; b++) {
					struct bc_svo_region rg;
					struct bc_svo_ivl v;
					if (b & 1) {
						rng_segment(&r, l, 1.0f, &rg);
					} else {
						rng_box(&r, l, 1.0f, &rg);
					}
					v = bc_svo_range_prim(g, 0, &rg);
					width += v.hi - v.lo;
					for (int s = 0; s < 24; s++) {
						float p[3], f;
						sample(&r, &rg, p);
						f = bc_eval_prim(l, 0, p);
						n++;
						if (!(f >= v.lo && f <= v.hi)) {
							if (bad++ < 3) {
								fprintf(
								    stderr,
								    "  %s %s: "
								    "%.9g not "
								    "in [%.9g, "
								    "%.9g]\n",
								    bc_prim_info(
								        (enum bc_prim)
								            k)
								        ->name,
								    arith_names
								        [ariths
								             [a]],
								    (double)f,
								    v.lo, v.hi);
							}
						}
					}
				}
				bc_svo_ranger_destroy(g);
				bc_svo_rpn_finish(&rpn);
				bc_tree_destroy(t);
			}
			CHECK_EQ_INT(bad, 0);
			/* A range must say something: not the whole line. */
			if (!isfinite(width)) {
				fprintf(stderr, "  %s %s: unbounded range\n",
				        bc_prim_info((enum bc_prim)k)->name,
				        arith_names[ariths[a]]);
			}
			CHECK(isfinite(width));
			(void)n;
		}
	}
}

static void ranges_enclose_every_operator(void)
{
	struct rng r = {33};
	/* The binary operators; the unary nodes' rules are checked over
	 * whole trees (test_svo_unary.c). */
	for (int k = BC_OP_INVALID + 1; k < BC_OP_FIRST_UNARY; k++) {
		uint32_t bad = 0;
		for (int round = 0; round < 4000; round++) {
			float beta = rng_f(&r, 0.02f, 1.0f);
			float ro = rng_f(&r, beta / 6.0f * 1.05f, 2.0f * beta);
			struct bc_svo_ivl A, B, v;
			/* Operand ranges around the blend zone, of every
			 * width from a point to several blends. */
			float ca = rng_f(&r, -2.0f, 2.0f) * ro;
			float cb = rng_f(&r, -2.0f, 2.0f) * ro;
			float wa = rng_f(&r, 0.0f, 2.0f) * ro *
			           (rng_below(&r, 4) == 0 ? 0.0f : 1.0f);
			float wb = rng_f(&r, 0.0f, 2.0f) * ro;
			A.lo = ca - wa;
			A.hi = ca + wa;
			B.lo = cb - wb;
			B.hi = cb + wb;
			v = bc_svo_range_op((enum bc_op)k, beta, ro, A, B);
			for (int s = 0; s < 16; s++) {
				float f0 = s == 0   ? (float)A.lo
				           : s == 1 ? (float)A.hi
				                    : rng_f(&r, (float)A.lo,
				                            (float)A.hi);
				float f1 = s == 2   ? (float)B.lo
				           : s == 3 ? (float)B.hi
				                    : rng_f(&r, (float)B.lo,
				                            (float)B.hi);
				float f =
				    bc_op_eval((enum bc_op)k, beta, ro, f0, f1);
				if (!(f >= v.lo && f <= v.hi) && bad++ < 3) {
					fprintf(stderr,
					        "  %s(%g, %g) = %.9g not in "
					        "[%.9g, %.9g]\n",
					        bc_op_name((enum bc_op)k),
					        (double)f0, (double)f1,
					        (double)f, v.lo, v.hi);
				}
			}
		}
		CHECK_EQ_INT(bad, 0);
	}
}

/* Whole trees: every operator nested over every kind, long smooth chains
 * (which make AA condense its forms), in all three arithmetics. */
static void ranges_enclose_whole_trees(void)
{
	static const char *const names[] = {
	    "random", "random", "random", "fig16", "fig18", "comb", "gears"};
	struct rng r = {45};
	for (size_t s = 0; s < sizeof(names) / sizeof(names[0]); s++) {
		struct bc_gen_opts o = {0};
		struct bc_tree *t;
		const struct bc_lin *l;
		struct bc_svo_rpn rpn;
		uint32_t *idx;
		if (s < 3) {
			o.count = 40;
			o.seed = 100 + s;
		} else if (s == 3) {
			o.level = 1;
		} else if (s == 4) {
			o.count = 30;
			o.blend = BC_GEN_BLEND_SMOOTH;
			o.kind = BC_GEN_KIND_SPHERES;
		} else if (s == 5) {
			o.count = 120;
			o.blend = BC_GEN_BLEND_SMOOTH;
		} else {
			o.teeth = 12;
		}
		t = gen_tree(names[s], &o);
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
		idx = calloc(rpn.n, sizeof(*idx));
		REQUIRE(idx);
		for (uint32_t i = 0; i < rpn.n; i++) {
			idx[i] = i;
		}
		for (size_t a = 0; a < 3; a++) {
			struct bc_svo_ranger *g;
			uint32_t bad = 0;
			REQUIRE(bc_svo_ranger_create(&g, &rpn, ariths[a]) == 0);
			for (int b = 0; b < 40; b++) {
				struct bc_svo_region rg;
				struct bc_svo_ivl v;
				if (b & 1) {
					rng_segment(&r, l, 0.5f, &rg);
				} else {
					rng_box(&r, l, 0.5f, &rg);
				}
				v = bc_svo_range(g, idx, rpn.n, &rg);
				for (int k = 0; k < 20; k++) {
					float p[3], f;
					sample(&r, &rg, p);
					f = bc_eval_full(l, p);
					if (!(f >= v.lo && f <= v.hi) &&
					    bad++ < 3) {
						fprintf(stderr,
						        "  %s %s: %.9g not in "
						        "[%.9g, %.9g]\n",
						        names[s],
						        arith_names[ariths[a]],
						        (double)f, v.lo, v.hi);
					}
				}
			}
			CHECK_EQ_INT(bad, 0);
			bc_svo_ranger_destroy(g);
		}
		free(idx);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

/* Ranges tighten as regions shrink: over a box a thousandth of the scene
 * wide, every arithmetic gives a sphere's field within a few box widths. */
static void ranges_shrink_with_the_region(void)
{
	struct rng r = {57};
	struct bc_tree *t = prim_tree(BC_PRIM_SPHERE, &r);
	struct bc_svo_rpn rpn;
	const struct bc_lin *l;
	REQUIRE(t);
	l = bc_tree_lin(t);
	REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
	for (size_t a = 0; a < 3; a++) {
		struct bc_svo_ranger *g;
		REQUIRE(bc_svo_ranger_create(&g, &rpn, ariths[a]) == 0);
		for (int b = 0; b < 50; b++) {
			struct bc_svo_region rg;
			struct bc_svo_ivl v;
			float c[3];
			memset(&rg, 0, sizeof(rg));
			rng_point(&r, l, 0.0f, c);
			for (int i = 0; i < 3; i++) {
				rg.lo[i] = c[i] - 1e-3f;
				rg.hi[i] = c[i] + 1e-3f;
			}
			v = bc_svo_range_prim(g, 0, &rg);
			CHECK(v.hi - v.lo < 8e-3);
		}
		bc_svo_ranger_destroy(g);
	}
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"bits_walks_match_a_plain_scan", bits_walks_match_a_plain_scan},
    {"mask_fill_sets_exactly_the_terms", mask_fill_sets_exactly_the_terms},
    {"full_variant_equals_reference_evaluator",
     full_variant_equals_reference_evaluator},
    {"clear_subtree_clears_exactly_the_subtree",
     clear_subtree_clears_exactly_the_subtree},
    {"ranges_enclose_every_primitive_kind",
     ranges_enclose_every_primitive_kind},
    {"ranges_enclose_every_operator", ranges_enclose_every_operator},
    {"ranges_enclose_whole_trees", ranges_enclose_whole_trees},
    {"ranges_shrink_with_the_region", ranges_shrink_with_the_region},
};

BC_TEST_MAIN(tests)
