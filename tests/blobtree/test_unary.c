/*
 * Unary and domain nodes (offset, onion, elongate, twist, bend, mirror,
 * repeat, scale): their fields against closed forms at sample points, their
 * Lipschitz bounds on random pairs (and the sphere-tracing step that relies
 * on the tree's bound), ABV containment over random trees that mix them with
 * every operator, the edits that keep their one child, and both scene
 * encodings round trip.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/mesh.h"
#include "blobcast/scene.h"
#include "test.h"

#include "randtree.h"

/* A tree of one unary node over one primitive (translated by t). */
static struct bc_tree *wrap1(const struct bc_unary *u,
                             const struct bc_prim_data *p)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	if (!t) {
		return NULL;
	}
	bc_tree_begin(t);
	if (bc_tree_push_unary(t, 1, u, &ei) ||
	    bc_tree_put_prim(t, 2, p, &ei) || bc_tree_pop_op(t, &ei) ||
	    bc_tree_end(t, &ei)) {
		fprintf(stderr, "  build: %s\n", ei.msg);
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

static void sphere(struct bc_prim_data *p, float r, float x)
{
	bc_prim_data_init(p, BC_PRIM_SPHERE);
	p->params[0] = r;
	p->translate[0] = x;
}

static float len3(float x, float y, float z)
{
	return sqrtf(x * x + y * y + z * z);
}

static void rnd(float p[3], float ext)
{
	for (int i = 0; i < 3; i++) {
		p[i] = rt_float(-ext, ext);
	}
}

/* Exact closed forms at 2000 points each. */
static void fields_match_closed_forms(void)
{
	struct bc_unary u;
	struct bc_prim_data s;
	struct bc_tree *t;
	const struct bc_lin *l;
	float p[3];
	rt_state = 11;

	/* offset: a sphere of radius r + a. */
	bc_unary_init(&u, BC_OP_OFFSET);
	u.u[0] = 0.3f;
	sphere(&s, 0.5f, 0.0f);
	REQUIRE((t = wrap1(&u, &s)));
	l = bc_tree_lin(t);
	for (int i = 0; i < 2000; i++) {
		rnd(p, 3.0f);
		CHECK_NEAR(bc_eval_full(l, p), len3(p[0], p[1], p[2]) - 0.8f,
		           2e-6f);
	}
	bc_tree_destroy(t);

	/* onion: a shell ||p| - r| - t. */
	bc_unary_init(&u, BC_OP_ONION);
	u.u[0] = 0.1f;
	REQUIRE((t = wrap1(&u, &s)));
	l = bc_tree_lin(t);
	for (int i = 0; i < 2000; i++) {
		rnd(p, 3.0f);
		CHECK_NEAR(bc_eval_full(l, p),
		           fabsf(len3(p[0], p[1], p[2]) - 0.5f) - 0.1f, 2e-6f);
	}
	bc_tree_destroy(t);

	/* elongate: outside the core box, the rounded box of half extents h
	 * and radius r: |max(|p| - h, 0)| - r. */
	bc_unary_init(&u, BC_OP_ELONGATE);
	u.u[0] = 0.6f;
	u.u[1] = 0.0f;
	u.u[2] = 0.3f;
	REQUIRE((t = wrap1(&u, &s)));
	l = bc_tree_lin(t);
	for (int i = 0; i < 2000; i++) {
		float q[3], out = -INFINITY;
		rnd(p, 3.0f);
		for (int k = 0; k < 3; k++) {
			q[k] = fmaxf(fabsf(p[k]) - u.u[k], 0.0f);
			out = fmaxf(out, fabsf(p[k]) - u.u[k]);
		}
		if (out < 0.0f) {
			/* Inside the core the field is -r (a bound). */
			CHECK_NEAR(bc_eval_full(l, p), -0.5f, 1e-6f);
			continue;
		}
		CHECK_NEAR(bc_eval_full(l, p), len3(q[0], q[1], q[2]) - 0.5f,
		           2e-6f);
	}
	bc_tree_destroy(t);

	/* mirror x of a sphere at x = 1: the union of it and its image. */
	bc_unary_init(&u, BC_OP_MIRROR);
	u.u[0] = 1.0f;
	sphere(&s, 0.5f, 1.0f);
	REQUIRE((t = wrap1(&u, &s)));
	l = bc_tree_lin(t);
	for (int i = 0; i < 2000; i++) {
		rnd(p, 3.0f);
		CHECK_NEAR(bc_eval_full(l, p),
		           fminf(len3(p[0] - 1.0f, p[1], p[2]),
		                 len3(p[0] + 1.0f, p[1], p[2])) -
		               0.5f,
		           2e-6f);
	}
	bc_tree_destroy(t);

	/* repeat: 4 x 1 x 3 copies, spacing 1.5, of a sphere of 0.4: the
	 * union of the copies (the nearest centre decides). */
	bc_unary_init(&u, BC_OP_REPEAT);
	u.u[0] = 1.5f;
	u.u[1] = 0.0f;
	u.u[2] = 1.5f;
	u.u[3] = 4.0f;
	u.u[4] = 1.0f;
	u.u[5] = 3.0f;
	sphere(&s, 0.4f, 0.0f);
	REQUIRE((t = wrap1(&u, &s)));
	l = bc_tree_lin(t);
	for (int i = 0; i < 2000; i++) {
		float best = INFINITY;
		rnd(p, 5.0f);
		for (int a = 0; a < 4; a++) {
			for (int c = 0; c < 3; c++) {
				float cx = 1.5f * ((float)a - 1.5f);
				float cz = 1.5f * ((float)c - 1.0f);
				best = fminf(best,
				             len3(p[0] - cx, p[1], p[2] - cz));
			}
		}
		CHECK_NEAR(bc_eval_full(l, p), best - 0.4f, 4e-6f);
	}
	bc_tree_destroy(t);

	/* scale: factor k of a sphere r is the sphere k r. */
	bc_unary_init(&u, BC_OP_SCALE);
	u.u[0] = 2.5f;
	sphere(&s, 0.5f, 0.0f);
	REQUIRE((t = wrap1(&u, &s)));
	l = bc_tree_lin(t);
	for (int i = 0; i < 2000; i++) {
		rnd(p, 5.0f);
		CHECK_NEAR(bc_eval_full(l, p), len3(p[0], p[1], p[2]) - 1.25f,
		           4e-6f);
	}
	bc_tree_destroy(t);
}

/* Twist and bend are not exact: their sign is the sign of the child at the
 * rotated point (a closed form for a box), and within their radius R the
 * value is the child's. */
static void twist_and_bend_rotate_the_child(void)
{
	enum bc_op kinds[2] = {BC_OP_TWIST, BC_OP_BEND};
	rt_state = 12;
	for (int k = 0; k < 2; k++) {
		struct bc_unary u;
		struct bc_prim_data b;
		struct bc_tree *t;
		const struct bc_lin *l;
		bc_unary_init(&u, kinds[k]);
		u.u[0] = 0.9f;
		bc_prim_data_init(&b, BC_PRIM_BOX);
		b.params[0] = 0.3f;
		b.params[1] = 1.0f;
		b.params[2] = 0.5f;
		REQUIRE((t = wrap1(&u, &b)));
		l = bc_tree_lin(t);
		for (int i = 0; i < 4000; i++) {
			float p[3], q[3], a, c, s, d[3], box;
			rnd(p, 2.0f);
			if (kinds[k] == BC_OP_TWIST) {
				a = 0.9f * p[1];
				c = cosf(a);
				s = sinf(a);
				q[0] = c * p[0] + s * p[2];
				q[1] = p[1];
				q[2] = -s * p[0] + c * p[2];
			} else {
				a = 0.9f * p[0];
				c = cosf(a);
				s = sinf(a);
				q[0] = c * p[0] + s * p[1];
				q[1] = -s * p[0] + c * p[1];
				q[2] = p[2];
			}
			for (int j = 0; j < 3; j++) {
				d[j] = fabsf(q[j]) - b.params[j];
			}
			box = len3(fmaxf(d[0], 0.0f), fmaxf(d[1], 0.0f),
			           fmaxf(d[2], 0.0f)) +
			      fminf(fmaxf(d[0], fmaxf(d[1], d[2])), 0.0f);
			if (fabsf(box) > 1e-4f) {
				CHECK((bc_eval_full(l, p) < 0.0f) ==
				      (box < 0.0f));
			}
		}
		/* Twist and bend make the field steeper than 1. */
		CHECK(l->lip > 1.0f);
		bc_tree_destroy(t);
	}
}

#define KIND_BIT(k) (1u << ((k)-BC_OP_FIRST_UNARY))

/* |f(a) - f(b)| <= L |a - b| over random pairs of nearby points, for random
 * trees of every operator and the nodes that keep the child's bound
 * (offset, onion, elongate, mirror, scale): L is 1, or the smooth
 * operators' 1.45. (Repeat is 1-Lipschitz where each copy fits its cell,
 * fields_match_closed_forms; twist and bend below.) */
static void lipschitz_bound_holds_on_random_pairs(void)
{
	struct bc_tree *t = bc_tree_create();
	long pairs = 0, bad = 0;
	REQUIRE(t);
	rt_unary_rate = 0.4f;
	rt_unary_kinds = KIND_BIT(BC_OP_OFFSET) | KIND_BIT(BC_OP_ONION) |
	                 KIND_BIT(BC_OP_ELONGATE) | KIND_BIT(BC_OP_MIRROR) |
	                 KIND_BIT(BC_OP_SCALE);
	for (int tree = 0; tree < 300; tree++) {
		const struct bc_lin *l;
		bool smooth = false;
		REQUIRE(rt_build(t, 77000u + (uint64_t)tree,
		                 1 + (uint32_t)(tree % 12)) == 0);
		l = bc_tree_lin(t);
		CHECK(l->lip == 1.0f);
		for (uint32_t s = 0; s < l->count; s++) {
			smooth |=
			    !bc_lin_is_leaf(l, s) &&
			    bc_op_is_smooth((enum bc_op)bc_lin_kind(l, s));
		}
		for (int i = 0; i < 200; i++) {
			float a[3], b[3], fa, fb, dist = 0.0f;
			float lip = smooth ? 1.45f : 1.0f;
			for (int j = 0; j < 3; j++) {
				a[j] = rt_float(l->lo[j], l->hi[j]);
				b[j] = a[j] + rt_float(-0.05f, 0.05f);
				dist += (a[j] - b[j]) * (a[j] - b[j]);
			}
			dist = sqrtf(dist);
			fa = bc_eval_full(l, a);
			fb = bc_eval_full(l, b);
			pairs++;
			if (fabsf(fa - fb) > lip * dist * 1.001f + 1e-5f) {
				bad++;
			}
		}
	}
	rt_unary_rate = 0.0f;
	rt_unary_kinds = 0;
	printf("  %ld pairs, %ld over the bound\n", pairs, bad);
	CHECK(pairs == 60000);
	CHECK(bad == 0);
	bc_tree_destroy(t);
}

/* Twist and bend (nested too) within the radius R their bound is stated
 * for: |f(a) - f(b)| <= L |a - b| with L the tree's (lin->lip), which is
 * above 1. */
static void twist_and_bend_bound_holds_within_their_radius(void)
{
	long pairs = 0, bad = 0;
	rt_state = 14;
	for (int trial = 0; trial < 60; trial++) {
		struct bc_unary tw, bd;
		struct bc_prim_data b;
		struct bc_tree *t = bc_tree_create();
		const struct bc_lin *l;
		float rmax;
		REQUIRE(t);
		bc_unary_init(&tw, BC_OP_TWIST);
		tw.u[0] = rt_float(-2.5f, 2.5f);
		bc_unary_init(&bd, BC_OP_BEND);
		bd.u[0] = rt_float(-1.5f, 1.5f);
		bc_prim_data_init(&b, BC_PRIM_BOX);
		b.params[0] = rt_float(0.1f, 0.6f);
		b.params[1] = rt_float(0.3f, 1.0f);
		b.params[2] = rt_float(0.1f, 0.6f);
		b.translate[0] = rt_float(-0.3f, 0.3f);
		bc_tree_begin(t);
		REQUIRE(bc_tree_push_unary(t, 0, trial % 3 ? &tw : &bd, NULL) ==
		        0);
		if (trial % 3 == 2) {
			REQUIRE(bc_tree_push_unary(t, 0, &bd, NULL) == 0);
		}
		REQUIRE(bc_tree_put_prim(t, 0, &b, NULL) == 0);
		REQUIRE(bc_tree_pop_op(t, NULL) == 0);
		if (trial % 3 == 2) {
			REQUIRE(bc_tree_pop_op(t, NULL) == 0);
		}
		REQUIRE(bc_tree_end(t, NULL) == 0);
		l = bc_tree_lin(t);
		CHECK(l->lip > 1.0f);
		/* The outer node's radius (its record's second float). */
		rmax = l->param[4u * (size_t)l->unary_param[0] + 1];
		for (int i = 0; i < 2000; i++) {
			float a[3], c[3], fa, fc, dist = 0.0f;
			int ax = trial % 3 ? 2 : 1;
			for (int j = 0; j < 3; j++) {
				a[j] = rt_float(-rmax, rmax);
				c[j] = a[j] + rt_float(-0.05f, 0.05f);
				dist += (a[j] - c[j]) * (a[j] - c[j]);
			}
			if (len3(a[0], ax == 1 ? a[1] : 0.0f,
			         ax == 2 ? a[2] : 0.0f) > rmax ||
			    len3(c[0], ax == 1 ? c[1] : 0.0f,
			         ax == 2 ? c[2] : 0.0f) > rmax) {
				continue;
			}
			dist = sqrtf(dist);
			fa = bc_eval_full(l, a);
			fc = bc_eval_full(l, c);
			pairs++;
			bad += fabsf(fa - fc) > l->lip * dist * 1.001f + 1e-5f;
		}
		bc_tree_destroy(t);
	}
	printf("  %ld pairs, %ld over the bound\n", pairs, bad);
	CHECK(pairs > 50000);
	CHECK(bad == 0);
}

/* Where the tracers trust it: for twist and bend trees, a step of f / L
 * from any point never crosses the surface (no sample in the ball has the
 * other sign). */
static void tracer_step_never_overshoots_twist_or_bend(void)
{
	enum bc_op kinds[2] = {BC_OP_TWIST, BC_OP_BEND};
	long checked = 0, over = 0;
	rt_state = 13;
	for (int k = 0; k < 2; k++) {
		for (int trial = 0; trial < 20; trial++) {
			struct bc_unary u;
			struct bc_prim_data b;
			struct bc_tree *t;
			const struct bc_lin *l;
			bc_unary_init(&u, kinds[k]);
			u.u[0] = rt_float(-2.5f, 2.5f);
			bc_prim_data_init(&b, BC_PRIM_BOX);
			b.params[0] = rt_float(0.1f, 0.6f);
			b.params[1] = rt_float(0.3f, 1.5f);
			b.params[2] = rt_float(0.1f, 0.6f);
			b.translate[0] = rt_float(-0.5f, 0.5f);
			REQUIRE((t = wrap1(&u, &b)));
			l = bc_tree_lin(t);
			for (int i = 0; i < 300; i++) {
				float p[3], f, step;
				rnd(p, 4.0f);
				f = bc_eval_full(l, p);
				if (!(f > 1e-3f)) {
					continue;
				}
				step = f / l->lip;
				for (int j = 0; j < 20; j++) {
					float d[3], n, q[3];
					rnd(d, 1.0f);
					n = len3(d[0], d[1], d[2]);
					if (n < 1e-3f) {
						continue;
					}
					for (int c = 0; c < 3; c++) {
						q[c] =
						    p[c] +
						    d[c] / n * step *
						        rt_float(0.0f, 0.999f);
					}
					checked++;
					over += bc_eval_full(l, q) < -1e-5f;
				}
			}
			bc_tree_destroy(t);
		}
	}
	printf("  %ld samples in step balls, %ld inside the solid\n", checked,
	       over);
	CHECK(checked > 100000);
	CHECK(over == 0);
}

/* Outside primitive k's world ABV its field (through its domain nodes) is
 * above its ROI bound r+: what the A-buffer and the sparse traversal rely
 * on, over random trees of every node and operator. */
static void abvs_contain_every_point_within_the_roi(void)
{
	struct bc_tree *t = bc_tree_create();
	long checked = 0, bad = 0;
	REQUIRE(t);
	rt_unary_rate = 0.4f;
	for (int tree = 0; tree < 400; tree++) {
		const struct bc_lin *l;
		REQUIRE(rt_build(t, 31000u + (uint64_t)tree,
		                 1 + (uint32_t)(tree % 16)) == 0);
		l = bc_tree_lin(t);
		for (int i = 0; i < 200; i++) {
			float p[3];
			uint32_t k = rt_below(l->nprims);
			uint32_t s = l->prim_slot[k];
			for (int j = 0; j < 3; j++) {
				float ext = l->hi[j] - l->lo[j];
				p[j] = rt_float(l->lo[j] - 0.2f * ext,
				                l->hi[j] + 0.2f * ext);
			}
			struct bc_abv a = bc_lin_abv(l, k);
			if (bc_abv_meets_box(&a, p, p)) {
				continue;
			}
			checked++;
			if (!(bc_eval_prim(l, k, p) > l->roi_hi[s] - 1e-5f)) {
				bad++;
			}
		}
	}
	rt_unary_rate = 0.0f;
	printf("  %ld points outside ABVs, %ld within the ROI\n", checked, bad);
	CHECK(checked > 30000);
	CHECK(bad == 0);
	bc_tree_destroy(t);
}

/* One unary node per kind in one scene: JSON and binary round trips give
 * the same tree (same encodings back), and the same field. */
static struct bc_tree *all_kinds(void)
{
	static const char json[] =
	    "{\"blobcast\": 1, \"root\": {\"type\": \"union\", \"id\": 1, "
	    "\"children\": ["
	    "{\"type\": \"offset\", \"id\": 2, \"amount\": 0.1, \"children\": "
	    "[{\"type\": \"sphere\", \"id\": 3, \"radius\": 0.4}]},"
	    "{\"type\": \"onion\", \"id\": 4, \"thickness\": 0.05, "
	    "\"children\": [{\"type\": \"box\", \"id\": 5, \"half_extents\": "
	    "[0.3, 0.2, 0.3], \"translate\": [1, 0, 0]}]},"
	    "{\"type\": \"elongate\", \"id\": 6, \"half_extents\": [0.2, 0, "
	    "0.1], \"children\": [{\"type\": \"twist\", \"id\": 7, \"rate\": "
	    "1.5, \"children\": [{\"type\": \"bend\", \"id\": 8, \"rate\": "
	    "-0.4, \"children\": [{\"type\": \"torus\", \"id\": 9, \"major\": "
	    "0.5, \"minor\": 0.15, "
	    "\"translate\": [0, 1, 0]}]}]}]},"
	    "{\"type\": \"mirror\", \"id\": 10, \"axes\": \"zx\", "
	    "\"children\": "
	    "[{\"type\": \"repeat\", \"id\": 11, \"spacing\": [0.5, 0, 0.5], "
	    "\"count\": [2, 1, 3], \"children\": [{\"type\": \"scale\", "
	    "\"id\": "
	    "12, \"factor\": 0.5, \"children\": [{\"type\": \"union\", \"id\": "
	    "13, \"children\": [{\"type\": \"sphere\", \"id\": 14, \"radius\": "
	    "0.3}, {\"type\": \"capsule\", \"id\": 15, \"a\": [0, 0, 0], "
	    "\"b\": [0, 0.5, 0], \"radius\": 0.1, \"translate\": [0, "
	    "-1, 0]}]}]}]}]}]}}";
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	if (!t) {
		return NULL;
	}
	if (bc_scene_parse_json(json, sizeof(json) - 1, t, NULL, &ei)) {
		fprintf(stderr, "  parse: %s\n", ei.msg);
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

static void every_kind_round_trips_through_json_and_binary(void)
{
	struct bc_tree *t = all_kinds(), *u = bc_tree_create(),
	               *w = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_unary un;
	char *j1 = NULL, *j2 = NULL;
	uint8_t *b1 = NULL, *b2 = NULL;
	size_t n1 = 0, n2 = 0;
	REQUIRE(t && u && w);
	CHECK_EQ_INT(bc_tree_node_count(t), 15);
	CHECK_EQ_INT(bc_tree_lin(t)->nunary, 8);
	REQUIRE(bc_tree_get_unary(t, 10, &un));
	CHECK(un.kind == BC_OP_MIRROR && un.u[0] == 5.0f);
	REQUIRE((j1 = bc_scene_to_json(t, NULL)));
	CHECK(strstr(j1, "\"axes\": \"xz\"") != NULL);
	REQUIRE(bc_scene_parse_json(j1, strlen(j1), u, NULL, &ei) == 0);
	REQUIRE((j2 = bc_scene_to_json(u, NULL)));
	CHECK_STREQ(j1, j2);
	REQUIRE(bc_tree_encode(t, &b1, &n1) == 0);
	REQUIRE(bc_tree_decode(b1, n1, w, &ei) == 0);
	REQUIRE(bc_tree_encode(w, &b2, &n2) == 0);
	CHECK_EQ_INT(n1, n2);
	CHECK(n1 == n2 && memcmp(b1, b2, n1) == 0);
	rt_state = 5;
	for (int i = 0; i < 500; i++) {
		float p[3];
		rnd(p, 3.0f);
		CHECK(bc_eval_full(bc_tree_lin(t), p) ==
		      bc_eval_full(bc_tree_lin(w), p));
	}
	/* A unary node's tag with a wrong float count, and one without its
	 * child, are refused. */
	{
		uint8_t bad[64];
		size_t len = 0;
		bad[len++] = 1;
		bad[len++] = 0;
		bad[len++] = 0;
		bad[len++] = 0; /* one node */
		bad[len++] = 0x80 | BC_OP_OFFSET;
		memset(bad + len, 0, 4); /* id */
		len += 4;
		bad[len++] = 1; /* nfloats */
		memset(bad + len, 0, 4);
		len += 4;
		CHECK(bc_tree_decode(bad, len, w, &ei) == BC_EPROTO_COUNT);
		bad[0] = 2;
		bad[9] = 2; /* wrong nfloats */
		CHECK(bc_tree_decode(bad, len, w, &ei) == BC_EPROTO_COUNT);
	}
	bc_free(j1);
	bc_free(j2);
	bc_free(b1);
	bc_free(b2);
	bc_tree_destroy(t);
	bc_tree_destroy(u);
	bc_tree_destroy(w);
}

static void bad_parameters_and_shapes_are_refused(void)
{
	static const char *const bad[] = {
	    /* two children */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"offset\", \"amount\": 1, "
	    "\"children\": [{\"type\": \"sphere\"}, {\"type\": \"sphere\"}]}}",
	    /* missing parameter */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"twist\", \"children\": "
	    "[{\"type\": \"sphere\"}]}}",
	    /* bad axes */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"mirror\", \"axes\": "
	    "\"xx\", \"children\": [{\"type\": \"sphere\"}]}}",
	    /* fractional count */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"repeat\", \"spacing\": "
	    "[1, 1, 1], \"count\": [1.5, 1, 1], \"children\": [{\"type\": "
	    "\"sphere\"}]}}",
	    /* spacing 0 with several copies */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"repeat\", \"spacing\": "
	    "[0, 1, 1], \"count\": [2, 1, 1], \"children\": [{\"type\": "
	    "\"sphere\"}]}}",
	    /* scale 0 */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"scale\", \"factor\": 0, "
	    "\"children\": [{\"type\": \"sphere\"}]}}",
	    /* negative onion */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"onion\", \"thickness\": "
	    "-0.1, \"children\": [{\"type\": \"sphere\"}]}}",
	    /* blend on a unary node */
	    "{\"blobcast\": 1, \"root\": {\"type\": \"offset\", \"amount\": 1, "
	    "\"blend\": 1, \"children\": [{\"type\": \"sphere\"}]}}",
	};
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_op_data op = {BC_OP_OFFSET, 0, 0};
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		int rc =
		    bc_scene_parse_json(bad[i], strlen(bad[i]), t, NULL, &ei);
		if (rc == 0) {
			fprintf(stderr, "  accepted: %s\n", bad[i]);
		}
		CHECK(rc != 0);
	}
	/* Unary kinds are not binary operators. */
	bc_tree_begin(t);
	CHECK(bc_tree_push_op(t, 0, &op, &ei) == BC_EINVAL);
	bc_tree_destroy(t);
}

/* Edits keep the one child: insert under a unary node is refused, removing
 * its child removes it, set_unary changes the field and the ABVs in place,
 * and a domain chain over BC_DOMAIN_MAX_CHAIN is refused. */
static void edits_keep_one_child(void)
{
	struct bc_tree *t = all_kinds(), *sub = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_prim_data s;
	struct bc_unary u;
	struct bc_dirty d;
	float p[3] = {0.0f, 0.45f, 0.0f};
	REQUIRE(t && sub);
	sphere(&s, 0.2f, 0.0f);
	bc_tree_begin(sub);
	bc_tree_put_prim(sub, 100, &s, NULL);
	REQUIRE(bc_tree_end(sub, NULL) == 0);
	CHECK(bc_tree_insert(t, 2, 1, sub, &ei) == BC_EINVAL);
	/* Offset 0.1 over a sphere of 0.4: -0.05 at radius 0.45 unless other
	 * members reach there (they do not). */
	CHECK_NEAR(bc_eval_full(bc_tree_lin(t), p), 0.45f - 0.5f, 1e-6f);
	bc_tree_take_dirty(t, &d);
	REQUIRE(bc_tree_get_unary(t, 2, &u));
	u.u[0] = -0.1f;
	REQUIRE(bc_tree_set_unary(t, 2, &u, &ei) == 0);
	bc_tree_take_dirty(t, &d);
	CHECK(!d.structure && d.edits == 1);
	CHECK_NEAR(bc_eval_full(bc_tree_lin(t), p), 0.45f - 0.3f, 1e-6f);
	/* An operator edit is refused on a unary node and vice versa. */
	CHECK(bc_tree_set_op(t, 2, &(struct bc_op_data){BC_OP_UNION, 0, 0},
	                     &ei) == BC_EINVAL);
	CHECK(bc_tree_set_unary(t, 1, &u, &ei) == BC_EINVAL);
	/* Removing the torus removes bend 8, twist 7 and elongate 6. */
	REQUIRE(bc_tree_remove(t, 9, &ei) == 0);
	CHECK(!bc_tree_get(t, 6, NULL, NULL) && !bc_tree_get(t, 8, NULL, NULL));
	CHECK_EQ_INT(bc_tree_node_count(t), 11);
	CHECK_EQ_INT(bc_tree_child_count(t, 1), 3);
	CHECK(bc_tree_lin(t)->lip == 1.0f);
	bc_tree_destroy(t);

	/* 33 nested scales over one sphere: over the domain chain limit. */
	t = bc_tree_create();
	REQUIRE(t);
	bc_tree_begin(t);
	bc_unary_init(&u, BC_OP_SCALE);
	for (uint32_t i = 0; i <= BC_DOMAIN_MAX_CHAIN; i++) {
		REQUIRE(bc_tree_push_unary(t, 0, &u, &ei) == 0);
	}
	REQUIRE(bc_tree_put_prim(t, 0, &s, &ei) == 0);
	for (uint32_t i = 0; i <= BC_DOMAIN_MAX_CHAIN; i++) {
		REQUIRE(bc_tree_pop_op(t, &ei) == 0);
	}
	CHECK(bc_tree_end(t, &ei) == BC_EDEPTH);
	bc_tree_destroy(t);
	bc_tree_destroy(sub);
}

/* A primitive edit under no twist or bend stays O(1) (its own record and
 * ABV); under a twist it updates the twist's radius and bound too. */
static void primitive_edit_under_twist_updates_its_bound(void)
{
	struct bc_tree *t = all_kinds();
	struct bc_prim_data s;
	struct bc_errinfo ei = {0};
	struct bc_dirty d;
	float before;
	REQUIRE(t);
	before = bc_tree_lin(t)->lip;
	REQUIRE(bc_tree_get(t, 9, &s, NULL));
	s.params[0] *= 3.0f; /* the torus's major radius */
	bc_tree_take_dirty(t, &d);
	REQUIRE(bc_tree_set_prim(t, 9, &s, &ei) == 0);
	bc_tree_take_dirty(t, &d);
	CHECK(bc_tree_lin(t)->lip > before);
	CHECK(d.param_lo == 0 && d.param_hi == bc_tree_lin(t)->nparam);
	REQUIRE(bc_tree_get(t, 3, &s, NULL));
	s.params[0] = 0.45f;
	REQUIRE(bc_tree_set_prim(t, 3, &s, &ei) == 0);
	bc_tree_take_dirty(t, &d);
	CHECK_EQ_INT(d.param_hi - d.param_lo, bc_prim_record_vec4(s.kind));
	bc_tree_destroy(t);
}

static int cmp_edge(const void *a, const void *b)
{
	const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return (x > y) - (x < y);
}

/* blobcast mesh through every kind: the mesh of all_kinds() is closed and
 * consistently oriented (each directed edge once, its reverse once), and
 * every vertex lies within a cell of the zero set (|f| <= L cell). The
 * onion's shell is 0.1 thick: 96 cells across make it two or more cells
 * (at 48, thinner than two cells, a few edges go non-manifold). */
static void mesh_through_unary_nodes_is_closed(void)
{
	struct bc_tree *t = all_kinds();
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	uint64_t *dir, *rev;
	uint32_t n, unmatched = 0, far = 0;
	REQUIRE(t);
	memset(&m, 0, sizeof(m));
	REQUIRE(bc_mesh_build(&m, t, &(struct bc_mesh_opts){.resolution = 96},
	                      &ei) == 0);
	CHECK(m.ntris > 1000);
	n = 3 * m.ntris;
	dir = bc_calloc(n, sizeof(uint64_t));
	rev = bc_calloc(n, sizeof(uint64_t));
	REQUIRE(dir && rev);
	for (uint32_t i = 0; i < m.ntris; i++) {
		for (int e = 0; e < 3; e++) {
			uint64_t a = m.tri[i][e], b = m.tri[i][(e + 1) % 3];
			dir[3 * i + (uint32_t)e] = a << 32 | b;
			rev[3 * i + (uint32_t)e] = b << 32 | a;
		}
	}
	qsort(dir, n, sizeof(uint64_t), cmp_edge);
	qsort(rev, n, sizeof(uint64_t), cmp_edge);
	for (uint32_t i = 0; i < n; i++) {
		unmatched += dir[i] != rev[i] || (i && dir[i] == dir[i - 1]);
	}
	for (uint32_t v = 0; v < m.nverts; v++) {
		float f = bc_eval_full(bc_tree_lin(t), m.pos[v]);
		far += fabsf(f) > 1.45f * bc_tree_lin(t)->lip * m.cell;
	}
	printf("  %u triangles, %u unmatched edges, %u far vertices\n", m.ntris,
	       unmatched, far);
	CHECK_EQ_INT(unmatched, 0);
	CHECK_EQ_INT(far, 0);
	bc_free(dir);
	bc_free(rev);
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
}

/* Node id's box as the layout holds it: the AABB of its primitives'
 * ABVs (consecutive in post-order below its slot; a node of one child,
 * unary or not, takes no slot of its own). Returns false for no box. */
static bool layout_box(const struct bc_tree *t, uint32_t id, float lo[3],
                       float hi[3])
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t slot, first, k0, n;
	while (bc_tree_child_count(t, id) == 1) {
		id = bc_tree_child(t, id, 0);
	}
	if (!l || (slot = bc_tree_slot(t, id)) >= l->count) {
		return false;
	}
	first = bc_lin_first(l, slot);
	k0 = bc_lin_prim(l, first);
	n = (slot - first) / 2u + 1u;
	for (int i = 0; i < 3; i++) {
		lo[i] = INFINITY;
		hi[i] = -INFINITY;
	}
	for (uint32_t k = k0; k < k0 + n; k++) {
		float a[3], b[3];
		struct bc_abv v = bc_lin_abv(l, k);
		bc_abv_aabb(&v, a, b);
		for (int i = 0; i < 3; i++) {
			lo[i] = fminf(lo[i], a[i]);
			hi[i] = fmaxf(hi[i], b[i]);
		}
	}
	return true;
}

/* Every node of t: bc_tree_node_box of t and of bare, a copy without a
 * layout, equal the layout's box bit for bit. Counts nodes and the
 * mismatches. */
static void boxes_match(const struct bc_tree *t, const struct bc_tree *bare,
                        long *nodes, long *bad)
{
	uint32_t n = bc_tree_node_count(t);
	for (uint32_t id = 1; id <= n + 1; id++) {
		float lo[3], hi[3], mlo[3], mhi[3], blo[3], bhi[3];
		int rc = bc_tree_node_box(t, id, mlo, mhi);
		int brc = bc_tree_node_box(bare, id, blo, bhi);
		if (!bc_tree_get(t, id, NULL, NULL)) {
			*bad += rc != BC_ENOTFOUND || brc != BC_ENOTFOUND;
			continue;
		}
		(*nodes)++;
		if (rc || brc || !layout_box(t, id, lo, hi) ||
		    memcmp(lo, mlo, sizeof(lo)) ||
		    memcmp(hi, mhi, sizeof(hi)) ||
		    memcmp(lo, blo, sizeof(lo)) ||
		    memcmp(hi, bhi, sizeof(hi))) {
			if (*bad < 5) {
				printf("  node %u: rc %d/%d, layout [%g %g %g] "
				       "[%g %g %g], model [%g %g %g] [%g %g "
				       "%g]\n",
				       id, rc, brc, lo[0], lo[1], lo[2], hi[0],
				       hi[1], hi[2], mlo[0], mlo[1], mlo[2],
				       mhi[0], mhi[1], mhi[2]);
			}
			(*bad)++;
		}
	}
}

/* bc_tree_node_box reads the model alone (the viewer's bare mirror asks
 * it for Home, fit and Alt+wheel) and must give the layout's box of every
 * node: random trees with every operator and unary kind, before and
 * after parameter edits of primitives, operators and unary nodes. */
static void node_boxes_from_the_model_equal_the_layouts(void)
{
	struct bc_tree *t = bc_tree_create(), *bare = bc_tree_create();
	long nodes = 0, bad = 0;
	REQUIRE(t && bare && bc_tree_set_layout(bare, false) == 0);
	rt_unary_rate = 0.4f;
	for (int tree = 0; tree < 300; tree++) {
		REQUIRE(rt_build(t, 47000u + (uint64_t)tree,
		                 1 + (uint32_t)(tree % 24)) == 0);
		REQUIRE(bc_tree_copy(bare, t, NULL) == 0);
		boxes_match(t, bare, &nodes, &bad);
		for (int e = 0; e < 6; e++) {
			uint32_t id = 1 + rt_below(bc_tree_node_count(t));
			struct bc_prim_data p;
			struct bc_op_data op;
			struct bc_unary u;
			if (!bc_tree_get(t, id, &p, &op)) {
				continue;
			}
			if (p.kind != BC_PRIM_INVALID) {
				struct bc_prim_data q;
				rt_random_prim(&q);
				if (q.kind == p.kind) {
					p = q;
				}
				p.translate[0] += 0.25f;
				REQUIRE(bc_tree_set_prim(t, id, &p, NULL) == 0);
				REQUIRE(bc_tree_set_prim(bare, id, &p, NULL) ==
				        0);
			} else if (bc_tree_get_unary(t, id, &u)) {
				enum bc_op kind = u.kind;
				rt_random_unary(&u);
				if (u.kind == kind) {
					REQUIRE(bc_tree_set_unary(t, id, &u,
					                          NULL) == 0);
					REQUIRE(bc_tree_set_unary(bare, id, &u,
					                          NULL) == 0);
				}
			} else {
				rt_random_op(&op);
				REQUIRE(bc_tree_set_op(t, id, &op, NULL) == 0);
				REQUIRE(bc_tree_set_op(bare, id, &op, NULL) ==
				        0);
			}
		}
		boxes_match(t, bare, &nodes, &bad);
	}
	rt_unary_rate = 0.0f;
	printf("  %ld node boxes, %ld unlike the layout's\n", nodes, bad);
	CHECK(nodes > 10000);
	CHECK(bad == 0);
	bc_tree_destroy(t);
	bc_tree_destroy(bare);
}

static const struct bc_test tests[] = {
    {"mesh_through_unary_nodes_is_closed", mesh_through_unary_nodes_is_closed},
    {"fields_match_closed_forms", fields_match_closed_forms},
    {"twist_and_bend_rotate_the_child", twist_and_bend_rotate_the_child},
    {"lipschitz_bound_holds_on_random_pairs",
     lipschitz_bound_holds_on_random_pairs},
    {"twist_and_bend_bound_holds_within_their_radius",
     twist_and_bend_bound_holds_within_their_radius},
    {"tracer_step_never_overshoots_twist_or_bend",
     tracer_step_never_overshoots_twist_or_bend},
    {"abvs_contain_every_point_within_the_roi",
     abvs_contain_every_point_within_the_roi},
    {"every_kind_round_trips_through_json_and_binary",
     every_kind_round_trips_through_json_and_binary},
    {"bad_parameters_and_shapes_are_refused",
     bad_parameters_and_shapes_are_refused},
    {"edits_keep_one_child", edits_keep_one_child},
    {"primitive_edit_under_twist_updates_its_bound",
     primitive_edit_under_twist_updates_its_bound},
    {"node_boxes_from_the_model_equal_the_layouts",
     node_boxes_from_the_model_equal_the_layouts},
};
BC_TEST_MAIN(tests)
