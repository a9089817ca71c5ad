/*
 * The svo evaluator on trees with unary and domain nodes (offset, onion,
 * elongate, twist, bend, mirror, repeat, scale), one scene per kind plus
 * one that stacks several: the RPN's field equals the reference
 * evaluator's bit for bit (ids too); the ranges of every arithmetic enclose
 * the field over random boxes and ray segments; the octree keeps the
 * field's sign (and its sign against every level of a band); and the `svo`
 * backend draws what `tiled` draws (hit masks differ on < 0.5 % of the
 * pixels, the depths of most pixels both hit agree).
 */
#include <stdio.h>
#include <stdlib.h>

#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "blobcast/svo.h"
#include "svo_util.h"
#include "test.h"

#define W 96
#define H 72

/* A subtree with a sharp and a smooth operator, a cut and three kinds of
 * primitive: what every unary node below wraps. */
#define INNER                                                                  \
	"{\"type\": \"smooth_union\", \"blend\": 0.15, \"range\": 0.2, "       \
	"\"children\": [{\"type\": \"difference\", \"children\": ["            \
	"{\"type\": \"box\", \"half_extents\": [0.45, 0.3, 0.35], "            \
	"\"translate\": [0.35, 0.1, 0.05]}, {\"type\": \"sphere\", "           \
	"\"radius\": 0.3, \"translate\": [0.6, 0.3, 0.2]}]}, "                 \
	"{\"type\": \"torus\", \"major\": 0.35, \"minor\": "                   \
	"0.1, \"translate\": [-0.1, 0.4, 0.1]}]}"

/* The unary node(s) opened by OPEN and closed by CLOSE wrap INNER, beside
 * a capsule. */
#define SCENE2(OPEN, CLOSE)                                                    \
	"{\"blobcast\": 1, \"camera\": {\"eye\": [1.9, 1.6, 2.5], "            \
	"\"target\": [0, 0.1, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 45}, "     \
	"\"root\": {\"type\": \"union\", \"children\": [" OPEN INNER CLOSE     \
	", {\"type\": \"capsule\", \"a\": [-1.1, -0.3, -0.4], \"b\": "         \
	"[-0.6, 0.5, -0.2], \"radius\": 0.2}]}}"
#define SCENE(OPEN) SCENE2(OPEN, "]}")

static const struct {
	const char *name;
	const char *json;
} scenes[] = {
    {"offset", SCENE("{\"type\": \"offset\", \"amount\": 0.08, "
                     "\"children\": [")},
    {"onion", SCENE("{\"type\": \"onion\", \"thickness\": 0.05, "
                    "\"children\": [")},
    {"elongate", SCENE("{\"type\": \"elongate\", \"half_extents\": "
                       "[0.3, 0, 0.15], \"children\": [")},
    {"twist", SCENE("{\"type\": \"twist\", \"rate\": 1.3, "
                    "\"children\": [")},
    {"bend", SCENE("{\"type\": \"bend\", \"rate\": 0.7, "
                   "\"children\": [")},
    {"mirror", SCENE("{\"type\": \"mirror\", \"axes\": \"xz\", "
                     "\"children\": [")},
    {"repeat", SCENE("{\"type\": \"repeat\", \"spacing\": [1.2, 1, 1.1], "
                     "\"count\": [2, 1, 3], \"children\": [")},
    {"scale", SCENE("{\"type\": \"scale\", \"factor\": 0.7, "
                    "\"children\": [")},
    {"stacked",
     SCENE2("{\"type\": \"offset\", \"amount\": 0.03, \"children\": ["
            "{\"type\": \"mirror\", \"axes\": \"x\", \"children\": ["
            "{\"type\": \"scale\", \"factor\": 1.2, \"children\": ["
            "{\"type\": \"twist\", \"rate\": -0.8, \"children\": [",
            "]}]}]}]}")},
};

#define NSCENES (sizeof(scenes) / sizeof(scenes[0]))

static struct bc_tree *load(size_t i, struct bc_camera *cam)
{
	struct bc_errinfo ei = {0};
	struct bc_tree *t = bc_tree_create();
	const char *j = scenes[i].json;
	if (!t || bc_scene_parse_json(j, strlen(j), t, cam, &ei)) {
		fprintf(stderr, "  %s: %s\n", scenes[i].name, ei.msg);
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

/* Every scene parses into a tree that has unary nodes at all. */
static void scenes_parse_with_unary_nodes(void)
{
	for (size_t i = 0; i < NSCENES; i++) {
		struct bc_camera cam;
		struct bc_tree *t = load(i, &cam);
		REQUIRE(t);
		CHECK(bc_tree_lin(t)->nunary >= 1);
		bc_tree_destroy(t);
	}
}

static void rpn_equals_reference_evaluator(void)
{
	struct rng r = {5};
	for (size_t i = 0; i < NSCENES; i++) {
		struct bc_camera cam;
		struct bc_tree *t = load(i, &cam);
		struct bc_svo_rpn rpn;
		const struct bc_lin *l;
		uint32_t *m, bad = 0, badid = 0, nunary = 0;
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
		for (uint32_t k = 0; k < rpn.n; k++) {
			nunary += rpn.terms[k].type == BC_SVO_TERM_UNARY;
		}
		m = calloc(rpn.nwords, sizeof(*m));
		REQUIRE(m);
		bc_svo_mask_fill(&rpn, m);
		for (int k = 0; k < 4000; k++) {
			float p[3];
			uint32_t a = 0, b = 0;
			rng_point(&r, l, 0.2f * l->size, p);
			float fa = bc_eval_full_id(l, p, &a);
			float fb = bc_svo_rpn_eval_id(&rpn, m, p, &b);
			bad += !(fa == fb);
			badid += a != b;
		}
		printf("  %-8s %u terms (%u value maps): %u values and %u "
		       "ids differ\n",
		       scenes[i].name, rpn.n, nunary, bad, badid);
		CHECK_EQ_INT(bad, 0);
		CHECK_EQ_INT(badid, 0);
		free(m);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

static void ranges_enclose_the_field(void)
{
	static const enum bc_range_arith ariths[] = {BC_RANGE_IA, BC_RANGE_AA,
	                                             BC_RANGE_REVAA};
	struct rng r = {9};
	for (size_t i = 0; i < NSCENES; i++) {
		struct bc_camera cam;
		struct bc_tree *t = load(i, &cam);
		struct bc_svo_rpn rpn;
		const struct bc_lin *l;
		uint32_t *idx, bad = 0, tight = 0, regions = 0;
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
		idx = calloc(rpn.n, sizeof(*idx));
		REQUIRE(idx);
		for (uint32_t k = 0; k < rpn.n; k++) {
			idx[k] = k;
		}
		for (size_t a = 0; a < 3; a++) {
			struct bc_svo_ranger *g = NULL;
			REQUIRE(bc_svo_ranger_create(&g, &rpn, ariths[a]) == 0);
			for (int k = 0; k < 300; k++) {
				struct bc_svo_region rg;
				struct bc_svo_ivl v;
				if (k & 1) {
					rng_segment(&r, l, 0.5f, &rg);
				} else {
					rng_box(&r, l, 0.5f, &rg);
				}
				v = bc_svo_range(g, idx, rpn.n, &rg);
				regions++;
				/* Not the whole line: the rules bound the
				 * field to within the scene's size. */
				tight += v.hi - v.lo < 2.0 * (double)l->size;
				for (int s = 0; s < 24; s++) {
					float p[3], f;
					rng_in(&r, &rg, p);
					f = bc_eval_full(l, p);
					if (!(f >= v.lo && f <= v.hi) &&
					    bad++ < 3) {
						fprintf(stderr,
						        "  %s arith %d: %.9g "
						        "not in [%.9g, %.9g]\n",
						        scenes[i].name,
						        (int)ariths[a],
						        (double)f, v.lo, v.hi);
					}
				}
			}
			bc_svo_ranger_destroy(g);
		}
		printf("  %-8s %u regions, %u narrower than twice the "
		       "diagonal, %u values outside\n",
		       scenes[i].name, regions, tight, bad);
		CHECK_EQ_INT(bad, 0);
		CHECK(tight * 10u >= 9u * regions);
		free(idx);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

static void octree_keeps_the_sign(void)
{
	struct rng r = {13};
	for (size_t i = 0; i < NSCENES; i++) {
		struct bc_camera cam;
		struct bc_tree *t = load(i, &cam);
		struct bc_svo_rpn rpn;
		const struct bc_lin *l;
		uint32_t bad = 0, badband = 0, near = 0;
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_svo_rpn_init(&rpn, l) == 0);
		for (int a = BC_RANGE_IA; a <= BC_RANGE_REVAA; a++) {
			float band = 0.01f * l->size;
			/* A small threshold: these trees have a dozen
			 * terms, the default would keep them whole. */
			struct bc_svo_opts o = {.arith = (enum bc_range_arith)a,
			                        .threshold = 2,
			                        .band = band};
			struct bc_svo *s = NULL;
			struct bc_errinfo ei = {0};
			struct bc_svo_stats st;
			REQUIRE(bc_svo_build(&s, &rpn, &o, &ei) == 0);
			/* Pruning works through the unary nodes: surface
			 * leaves keep fewer terms than the tree has. */
			bc_svo_get_stats(s, &st);
			CHECK(st.active > 0);
			CHECK(st.avg_terms_leaf < 0.75 * (double)rpn.n);
			if (a == BC_RANGE_IA) {
				printf("  %-8s ia: %u leaves, %u on the "
				       "surface, %.2f of %u terms on average\n",
				       scenes[i].name, st.leaves, st.active,
				       st.avg_terms_leaf, rpn.n);
			}
			for (int k = 0; k < 6000; k++) {
				float p[3], f, v;
				rng_point(&r, l, 0.05f * l->size, p);
				f = bc_eval_full(l, p);
				if (k & 1) {
					/* Pull half the points next to the
					 * surface. */
					for (int j = 0;
					     j < 3 &&
					     fabsf(f) > 0.02f * l->size;
					     j++) {
						rng_point(&r, l,
						          0.05f * l->size, p);
						f = bc_eval_full(l, p);
					}
				}
				near += fabsf(f) <= 0.02f * l->size;
				v = bc_svo_eval(s, p);
				bad += (f < 0.0f) != (v < 0.0f);
				/* Every level of the band. */
				for (int q = 1; q <= 2; q++) {
					float c = band * (float)q * 0.5f;
					badband += (f < c) != (v < c);
				}
			}
			bc_svo_destroy(s);
		}
		printf("  %-8s 18000 points (%u near the surface): %u signs "
		       "and %u band signs differ\n",
		       scenes[i].name, near, bad, badband);
		CHECK_EQ_INT(bad, 0);
		CHECK_EQ_INT(badband, 0);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

static void svo_draws_what_tiled_draws(void)
{
	for (size_t i = 0; i < NSCENES; i++) {
		struct bc_camera cam;
		struct bc_tree *t = load(i, &cam);
		struct bc_frame a, b;
		struct bc_render_opts ot = {.threads = 2};
		struct bc_render_opts os = {.threads = 2};
		struct bc_errinfo ei = {0};
		struct bc_render_stats st;
		const struct bc_lin *l;
		uint32_t diff = 0, both = 0, close = 0;
		REQUIRE(t);
		l = bc_tree_lin(t);
		REQUIRE(bc_frame_init(&a, W, H) == 0);
		REQUIRE(bc_frame_init(&b, W, H) == 0);
		REQUIRE(bc_render_once(BC_BACKEND_TILED, &ot, t, &cam, &a, &st,
		                       &ei) == 0);
		if (bc_render_once(BC_BACKEND_SVO, &os, t, &cam, &b, &st,
		                   &ei)) {
			fprintf(stderr, "  %s: %s\n", scenes[i].name, ei.msg);
			CHECK(false);
		}
		for (uint32_t k = 0; k < W * H; k++) {
			bool ha = isfinite(a.depth[k]),
			     hb = isfinite(b.depth[k]);
			diff += ha != hb;
			if (ha && hb) {
				both++;
				close += fabsf(a.depth[k] - b.depth[k]) <=
				         1e-3f * l->size;
			}
		}
		printf("  %-8s hit masks differ on %u of %u px; of %u both "
		       "hit, %u within 1e-3 of the diagonal\n",
		       scenes[i].name, diff, W * H, both, close);
		CHECK(diff * 200u < W * H); /* < 0.5 % */
		CHECK(both > W * H / 20);
		CHECK(close * 5u >= 4u * both);
		bc_frame_finish(&a);
		bc_frame_finish(&b);
		bc_tree_destroy(t);
	}
}

/* The caster's ray packets find what single rays find, bit for bit, on
 * every kind of node (domain-mapped primitives and value maps in the
 * packets' lane evaluation, stepped and bisected leaves). */
static void packets_match_single_rays(void)
{
	for (size_t i = 0; i < NSCENES; i++) {
		struct bc_camera cam;
		struct bc_tree *t = load(i, &cam);
		struct bc_svo_rpn rpn;
		struct bc_svo_cast_params cp;
		struct bc_svo *s = NULL;
		struct bc_errinfo ei = {0};
		struct bc_svo_opts o = {.threshold = 2};
		char label[32];
		REQUIRE(t);
		REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
		o.band = frame_cast_params(&rpn, &cam, W, H, &cp);
		REQUIRE(bc_svo_build(&s, &rpn, &o, &ei) == 0);
		snprintf(label, sizeof(label), "%-8s", scenes[i].name);
		CHECK(packets_agree(s, &rpn, &cam, W, H, &cp, 11u + i, label));
		bc_svo_destroy(s);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

static const struct bc_test tests[] = {
    {"packets_match_single_rays", packets_match_single_rays},
    {"scenes_parse_with_unary_nodes", scenes_parse_with_unary_nodes},
    {"rpn_equals_reference_evaluator", rpn_equals_reference_evaluator},
    {"ranges_enclose_the_field", ranges_enclose_the_field},
    {"octree_keeps_the_sign", octree_keeps_the_sign},
    {"svo_draws_what_tiled_draws", svo_draws_what_tiled_draws},
};

BC_TEST_MAIN(tests)
