/*
 * Tests of the gl backend against the CPU renderers: every generator family
 * agrees with the tiled CPU renderer at 64x64 (silhouettes on < 0.5 % of
 * pixels, median depth difference < 1e-3 of the scene's size, ids), a
 * parameter edit then a frame equals a fresh load of the edited scene bit
 * for bit and sends only the edited bytes, the overflow paths (M_overlap,
 * the node cache, the A-buffer's capacity) still draw the right picture,
 * the three platforms draw the same, the debug modes and odd frame sizes
 * mean what they mean on the CPU, and frames assembled from regions
 * (refinement levels, tile masks, damage after random parameter edits)
 * equal whole renders bit for bit, and so does a view drawn in bands of
 * tile rows because its lists pass the A-buffer's limit.
 *
 * Sizes stay small: llvmpipe shares two cores with everything else. Every
 * test is skipped (exit 77) only when no GL context can be created at all.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "blobcast/render_gl.h"
#include "blobcast/scene.h"
#include "blobtree/randtree.h"
#include "test.h"

#define W 64
#define H 64

/* A renderer on platform (NULL: auto), or NULL with the reason printed. */
static struct bc_renderer *open_gl(const char *platform, enum bc_debug_mode dbg)
{
	struct bc_render_opts o = {.gl_platform = platform, .debug = dbg};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, BC_BACKEND_GL, &o, &ei)) {
		fprintf(stderr, "  no gl context (%s): %s\n",
		        platform ? platform : "auto", ei.msg);
		return NULL;
	}
	return r;
}

static int draw(struct bc_renderer *r, const struct bc_tree *t,
                const struct bc_dirty *dirty, const struct bc_camera *cam,
                struct bc_frame *f)
{
	struct bc_errinfo ei = {0};
	int rc = bc_renderer_sync(r, t, dirty, &ei);
	if (rc == 0) {
		rc = bc_renderer_render(r, cam, f, NULL, &ei);
	}
	if (rc) {
		fprintf(stderr, "  gl: %s\n", ei.msg);
	}
	return rc;
}

static int draw_cpu(enum bc_debug_mode dbg, const struct bc_tree *t,
                    const struct bc_camera *cam, struct bc_frame *f)
{
	struct bc_render_opts o = {.debug = dbg};
	struct bc_errinfo ei = {0};
	int rc = bc_render_once(BC_BACKEND_TILED, &o, t, cam, f, NULL, &ei);
	if (rc) {
		fprintf(stderr, "  tiled: %s\n", ei.msg);
	}
	return rc;
}

static int cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;
	return (x > y) - (x < y);
}

struct agreement {
	uint32_t mask_diff; /* pixels hit by one and not the other */
	uint32_t both;      /* pixels hit by both */
	float median_dz;    /* over `both` */
	uint32_t id_diff;   /* of `both` */
	uint32_t rgba_diff; /* pixels whose colour differs */
};

static void compare(const struct bc_frame *a, const struct bc_frame *b,
                    struct agreement *out)
{
	size_t n = (size_t)a->width * a->height;
	float *dz = malloc(n * sizeof(*dz));
	memset(out, 0, sizeof(*out));
	for (size_t i = 0; i < n; i++) {
		bool ha = isfinite(a->depth[i]), hb = isfinite(b->depth[i]);
		if (ha != hb) {
			out->mask_diff++;
		} else if (ha) {
			if (dz) {
				dz[out->both] =
				    fabsf(a->depth[i] - b->depth[i]);
			}
			out->both++;
			out->id_diff += a->ids[i] != b->ids[i];
		}
		out->rgba_diff +=
		    memcmp(a->rgba + 4 * i, b->rgba + 4 * i, 4) != 0;
	}
	if (dz && out->both) {
		qsort(dz, out->both, sizeof(*dz), cmp_float);
		out->median_dz = dz[out->both / 2];
	}
	free(dz);
}

static bool frames_equal(const struct bc_frame *a, const struct bc_frame *b)
{
	size_t n = (size_t)a->width * a->height;
	return memcmp(a->rgba, b->rgba, 4 * n) == 0 &&
	       memcmp(a->depth, b->depth, 4 * n) == 0 &&
	       memcmp(a->ids, b->ids, 4 * n) == 0;
}

/* ---- Families ------------------------------------------------------------ */

struct family {
	const char *gen;
	struct bc_gen_opts opts;
	uint32_t min_hits; /* pixels the scene covers at least */
};

static const struct family families[] = {
    {"fig16", {.level = 2}, 400},
    {"fig16", {.level = 1, .blend = BC_GEN_BLEND_SHARP}, 400},
    {"fig18", {.count = 64, .kind = BC_GEN_KIND_BOXES}, 400},
    {"fig18",
     {.count = 64, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SHARP},
     400},
    {"fig18", {.count = 64, .kind = BC_GEN_KIND_LENSES}, 400},
    {"comb", {.count = 32}, 100},
    {"comb", {.count = 32, .blend = BC_GEN_BLEND_SMOOTH}, 100},
    /* Every primitive kind under every operator kind (most seeds
     * intersect away to nothing: these two do not). */
    {"random", {.seed = 0}, 100},
    {"random", {.seed = 4}, 100},
    {"random", {.seed = 4, .count = 60, .depth = 40}, 16},
    {"gears", {.teeth = 12}, 400},
    {"many-gears", {.count = 6}, 200},
    {"many-spheres", {.count = 300}, 400},
    /* Every primitive kind, sharp and blended. */
    {"catalogue", {0}, 400},
    {"catalogue", {.blend = BC_GEN_BLEND_SMOOTH, .seed = 3}, 400},
};

/* Nested binary operators leaning right, n deep: every view's stack grows
 * with the depth, past what the fast evaluation keeps in registers. */
static int right_comb(struct bc_tree *t, uint32_t n)
{
	int rc;
	bc_tree_begin(t);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_op_data op = {
		    i % 3 == 2 ? BC_OP_SMOOTH_UNION : BC_OP_UNION, 0.0f, 0.0f};
		struct bc_prim_data p;
		if (op.kind == BC_OP_SMOOTH_UNION) {
			op.blend = 0.15f;
			op.range = bc_op_default_range(op.blend);
		}
		if (i + 1 < n && (rc = bc_tree_push_op(t, 0, &op, NULL))) {
			return rc;
		}
		bc_prim_data_init(&p, i % 2 ? BC_PRIM_BOX : BC_PRIM_SPHERE);
		p.params[0] = 0.3f;
		p.params[1] = 0.2f;
		p.params[2] = 0.25f;
		p.translate[0] = 0.09f * (float)i - 0.9f;
		p.translate[1] = 0.4f * sinf((float)i);
		if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
			return rc;
		}
	}
	for (uint32_t i = 0; i + 1 < n; i++) {
		if ((rc = bc_tree_pop_op(t, NULL))) {
			return rc;
		}
	}
	return bc_tree_end(t, NULL);
}
static void test_families_agree_with_tiled(void)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, c = {0};
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, W, H) == 0 &&
	        bc_frame_init(&c, W, H) == 0);
	for (size_t i = 0; i < sizeof(families) / sizeof(families[0]); i++) {
		const struct family *fam = &families[i];
		struct bc_errinfo ei = {0};
		struct bc_camera cam;
		struct agreement a;
		float size;
		if (bc_gen(fam->gen, &fam->opts, t, &cam, &ei)) {
			fprintf(stderr, "  %s: %s\n", fam->gen, ei.msg);
			CHECK(0);
			continue;
		}
		size = bc_tree_lin(t)->size;
		CHECK(draw(r, t, NULL, &cam, &g) == 0);
		CHECK(draw_cpu(BC_DEBUG_NONE, t, &cam, &c) == 0);
		compare(&g, &c, &a);
		printf(
		    "  %-12s %2zu: mask %u/%u, median |dz| %.2g (limit %.2g), "
		    "ids %u/%u, colours %u\n",
		    fam->gen, i, a.mask_diff, W * H, (double)a.median_dz,
		    1e-3 * (double)size, a.id_diff, a.both, a.rgba_diff);
		CHECK(a.both >= fam->min_hits); /* the scene is in view */
		CHECK(a.mask_diff * 200 < W * H);
		CHECK(a.median_dz < 1e-3f * size);
		CHECK(a.id_diff * 20 <= a.both);
	}
	{
		struct bc_camera cam;
		struct agreement a;
		bc_camera_default(&cam);
		REQUIRE(right_comb(t, 24) == 0);
		CHECK(draw(r, t, NULL, &cam, &g) == 0);
		CHECK(draw_cpu(BC_DEBUG_NONE, t, &cam, &c) == 0);
		compare(&g, &c, &a);
		printf(
		    "  right comb  : mask %u/%u, median |dz| %.2g, ids %u/%u, "
		    "colours %u\n",
		    a.mask_diff, W * H, (double)a.median_dz, a.id_diff, a.both,
		    a.rgba_diff);
		struct bc_gl_info info;
		REQUIRE(bc_render_gl_info(r, &info) == 0);
		CHECK(info.ranges_general > 0);
		CHECK(a.both >= 200);
		CHECK(a.mask_diff * 200 < W * H);
		CHECK(a.median_dz < 1e-3f * bc_tree_lin(t)->size);
		CHECK(a.id_diff * 20 <= a.both);
	}
	bc_frame_finish(&g);
	bc_frame_finish(&c);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* GLSL vs C images of trees with unary and domain nodes: a scene of every
 * kind (twist, bend and a stack of them make the Lipschitz bound > 1),
 * then after a parameter edit under the twist (its radius and bound move)
 * and a unary edit, and random trees with them over every operator. */
static void test_unary_nodes_agree_with_tiled(void)
{
	static const char scene[] =
	    "{\"blobcast\": 1, \"root\": {\"type\": \"union\", "
	    "\"children\": ["
	    "{\"type\": \"twist\", \"id\": 2, \"rate\": 1.2, \"children\": "
	    "[{\"type\": \"box\", \"id\": 3, \"half_extents\": [0.4, 1.2, "
	    "0.4], \"translate\": [-1.5, 0, 0]}]},"
	    "{\"type\": \"onion\", \"id\": 4, \"thickness\": 0.05, "
	    "\"children\": [{\"type\": \"difference\", \"children\": "
	    "[{\"type\": \"sphere\", \"radius\": 0.6}, {\"type\": \"box\", "
	    "\"half_extents\": [1, 1, 1], \"translate\": [0, 0, 1]}]}]},"
	    "{\"type\": \"repeat\", \"spacing\": [0.6, 1, 0.6], \"count\": "
	    "[3, 1, 2], \"children\": [{\"type\": \"scale\", \"factor\": "
	    "0.5, \"children\": [{\"type\": \"sphere\", \"radius\": 0.4, "
	    "\"translate\": [3.2, -1.6, 0]}]}]},"
	    "{\"type\": \"offset\", \"amount\": 0.1, \"children\": "
	    "[{\"type\": \"bend\", \"rate\": 0.6, \"children\": "
	    "[{\"type\": \"mirror\", \"axes\": \"x\", \"children\": "
	    "[{\"type\": \"elongate\", \"half_extents\": [0.3, 0, 0], "
	    "\"children\": [{\"type\": \"capsule\", \"a\": [0.5, 0, 0], "
	    "\"b\": [0.9, 0, 0], \"radius\": 0.1, \"translate\": [0, 1.2, "
	    "0]}]}]}]}]}]}}";
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, c = {0};
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	int tested = 0;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, W, H) == 0 &&
	        bc_frame_init(&c, W, H) == 0);
	REQUIRE(bc_scene_parse_json(scene, sizeof(scene) - 1, t, NULL, &ei) ==
	        0);
	bc_camera_default(&cam);
	for (int step = 0; step < 3 + 2; step++) {
		struct agreement a;
		struct bc_dirty d;
		if (step == 1) {
			struct bc_prim_data b;
			REQUIRE(bc_tree_get(t, 3, &b, NULL));
			b.params[0] = 0.6f; /* the twist's radius grows */
			REQUIRE(bc_tree_set_prim(t, 3, &b, &ei) == 0);
		} else if (step == 2) {
			struct bc_unary u;
			REQUIRE(bc_tree_get_unary(t, 4, &u));
			u.u[0] = 0.12f;
			REQUIRE(bc_tree_set_unary(t, 4, &u, &ei) == 0);
		} else if (step >= 3) {
			/* Random trees with unary nodes that fill the view. */
			uint64_t seed = 40 + (uint64_t)step;
			rt_unary_rate = 0.4f;
			do {
				REQUIRE(rt_build(t, seed,
				                 6 + (uint32_t)(seed % 6)) ==
				        0);
				seed += 7;
			} while (bc_tree_lin(t)->nunary == 0);
			rt_unary_rate = 0.0f;
		}
		bc_tree_take_dirty(t, &d);
		if (step >= 3) {
			const struct bc_lin *l = bc_tree_lin(t);
			float dist = 1.6f * l->size;
			bc_camera_default(&cam);
			for (int i = 0; i < 3; i++) {
				cam.target[i] = 0.5f * (l->lo[i] + l->hi[i]);
				cam.eye[i] = cam.target[i];
			}
			cam.eye[2] += dist;
			cam.eye[1] += 0.4f * dist;
		}
		CHECK(draw(r, t, step >= 1 && step <= 2 ? &d : NULL, &cam,
		           &g) == 0);
		CHECK(draw_cpu(BC_DEBUG_NONE, t, &cam, &c) == 0);
		compare(&g, &c, &a);
		printf("  unary %d: lip %.2f, mask %u/%u, median |dz| %.2g, "
		       "ids %u/%u, colours %u\n",
		       step, (double)bc_tree_lin(t)->lip, a.mask_diff, W * H,
		       (double)a.median_dz, a.id_diff, a.both, a.rgba_diff);
		if (step < 3) {
			CHECK(a.both >= 400);
		} else if (a.both < 40) {
			continue; /* mostly out of view: nothing to compare */
		}
		tested++;
		CHECK(a.mask_diff * 200 < W * H);
		CHECK(a.median_dz < 1e-3f * bc_tree_lin(t)->size);
		CHECK(a.id_diff * 20 <= a.both);
	}
	CHECK_EQ_INT(tested, 5);
	bc_frame_finish(&g);
	bc_frame_finish(&c);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* ---- Edits --------------------------------------------------------------- */

/* Renders t fresh in a new renderer. */
static int fresh(const struct bc_tree *t, const struct bc_camera *cam,
                 struct bc_frame *f)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *copy = bc_tree_create();
	int rc = -1;
	if (r && copy && bc_tree_copy(copy, t, NULL) == 0) {
		rc = draw(r, copy, NULL, cam, f);
	}
	bc_tree_destroy(copy);
	if (r) {
		bc_renderer_destroy(r);
	}
	return rc;
}

/* The id of the first primitive and of the first operator of t. */
static void find_nodes(const struct bc_tree *t, uint32_t *prim, uint32_t *op)
{
	const struct bc_lin *l = bc_tree_lin(t);
	*prim = 0;
	*op = 0;
	for (uint32_t s = 0; s < l->count && (!*prim || !*op); s++) {
		if (bc_lin_is_leaf(l, s) && !*prim) {
			*prim = l->node_id[s];
		} else if (!bc_lin_is_leaf(l, s) && !*op) {
			*op = l->node_id[s];
		}
	}
}

static void test_param_edit_equals_fresh_load(void)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame a = {0}, b = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_dirty dirty;
	struct bc_gl_info info;
	struct bc_prim_data p;
	struct bc_op_data op;
	uint32_t prim_id, op_id;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&a, W, H) == 0 &&
	        bc_frame_init(&b, W, H) == 0);
	REQUIRE(bc_gen("fig16", &(struct bc_gen_opts){.level = 1}, t, &cam,
	               &ei) == 0);
	bc_tree_take_dirty(t, &dirty);
	REQUIRE(draw(r, t, NULL, &cam, &a) == 0);
	find_nodes(t, &prim_id, &op_id);
	REQUIRE(prim_id && op_id);

	/* A primitive grows and moves: one record, one ABV go up. */
	REQUIRE(bc_tree_get(t, prim_id, &p, NULL));
	p.translate[1] += 0.15f;
	p.params[0] *= 1.3f;
	REQUIRE(bc_tree_set_prim(t, prim_id, &p, &ei) == 0);
	bc_tree_take_dirty(t, &dirty);
	CHECK(!dirty.structure && dirty.edits == 1);
	REQUIRE(draw(r, t, &dirty, &cam, &a) == 0);
	REQUIRE(bc_render_gl_info(r, &info) == 0);
	CHECK(!info.upload_full);
	CHECK_EQ_INT(info.full_uploads, 1);
	CHECK_EQ_INT(info.program_builds, 1);
	/* The record (5 vec4, a sphere's 1), the primitive's entry (32
	 * bytes) and its ABV (112 bytes): nothing else. */
	CHECK_EQ_INT(info.upload_bytes,
	             16 * bc_prim_record_vec4(p.kind) + 32 + 112);
	REQUIRE(fresh(t, &cam, &b) == 0);
	CHECK(frames_equal(&a, &b));

	/* An operator changes kind (union to intersection): node words, kill
	 * counts and the subtree's ABVs go up, not the whole tree. */
	REQUIRE(bc_tree_get(t, op_id, NULL, &op));
	op.kind = op.kind == BC_OP_SMOOTH_UNION ? BC_OP_SMOOTH_INTERSECTION
	                                        : BC_OP_INTERSECTION;
	REQUIRE(bc_tree_set_op(t, op_id, &op, &ei) == 0);
	op.kind = BC_OP_SMOOTH_UNION;
	op.blend = 0.2f;
	op.range = 0.0f;
	REQUIRE(bc_tree_set_op(t, op_id, &op, &ei) == 0);
	bc_tree_take_dirty(t, &dirty);
	CHECK(!dirty.structure && dirty.edits == 2);
	REQUIRE(draw(r, t, &dirty, &cam, &a) == 0);
	REQUIRE(bc_render_gl_info(r, &info) == 0);
	CHECK(!info.upload_full);
	CHECK(info.upload_bytes > 0);
	CHECK_EQ_INT(info.program_builds, 1);
	REQUIRE(fresh(t, &cam, &b) == 0);
	CHECK(frames_equal(&a, &b));

	/* A structural edit uploads everything, and still draws right. */
	REQUIRE(bc_tree_remove(t, prim_id, &ei) == 0);
	bc_tree_take_dirty(t, &dirty);
	CHECK(dirty.structure);
	REQUIRE(draw(r, t, &dirty, &cam, &a) == 0);
	REQUIRE(bc_render_gl_info(r, &info) == 0);
	CHECK(info.upload_full);
	CHECK_EQ_INT(info.full_uploads, 2);
	CHECK_EQ_INT(info.program_builds, 1);
	REQUIRE(fresh(t, &cam, &b) == 0);
	CHECK(frames_equal(&a, &b));

	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* ---- Limits ---------------------------------------------------------------
 */

/* n spheres of one radius around nearly one centre: every one enters every
 * tile at the same depth, so the active set passes M_overlap at one range
 * start and the view's records outgrow the node cache. */
static int crowd(struct bc_tree *t, uint32_t n)
{
	struct bc_op_data u = {BC_OP_UNION, 0.0f, 0.0f};
	int rc;
	bc_tree_begin(t);
	if ((rc = bc_tree_push_op(t, 0, &u, NULL))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_prim_data p;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		p.params[0] = 1.0f;
		p.translate[0] = 0.3f * sinf(0.7f * (float)i);
		p.translate[1] = 0.3f * cosf(1.3f * (float)i);
		p.has_color = true;
		p.color[0] = (float)(i % 7) / 7.0f;
		p.color[1] = 0.5f;
		p.color[2] = (float)(i % 3) / 3.0f;
		if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
			return rc;
		}
	}
	if ((rc = bc_tree_pop_op(t, NULL))) {
		return rc;
	}
	return bc_tree_end(t, NULL);
}

static void test_overflows_degrade_not_fail(void)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, c = {0}, again = {0};
	struct bc_camera cam;
	struct bc_gl_info info;
	struct agreement a;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, 32, 32) == 0 &&
	        bc_frame_init(&c, 32, 32) == 0 &&
	        bc_frame_init(&again, 32, 32) == 0);
	REQUIRE(crowd(t, 160) == 0);
	bc_camera_default(&cam);
	REQUIRE(draw(r, t, NULL, &cam, &g) == 0);
	REQUIRE(bc_render_gl_info(r, &info) == 0);
	printf("  %u fragments, %u ranges, %u over M_overlap, %u over the "
	       "cache, %u tiles suspended, %u dispatches\n",
	       info.fragments, info.ranges, info.over_m, info.over_cache,
	       info.suspensions, info.dispatches);
	CHECK(info.over_m > 0);
	CHECK(info.over_cache > 0);
	CHECK(info.ranges_general > 0);
	/* llvmpipe's loop limit: the crowded tiles suspend and resume. */
	if (info.loop_budget) {
		CHECK(info.suspensions > 0);
		CHECK(info.dispatches > 1);
	}
	CHECK(draw_cpu(BC_DEBUG_NONE, t, &cam, &c) == 0);
	compare(&g, &c, &a);
	CHECK(a.mask_diff * 200 < 32 * 32);
	CHECK(a.median_dz < 1e-3f * bc_tree_lin(t)->size);

	/* Too small an A-buffer: counted, grown, drawn again, same frame.
	 * The count is read before tracing, so the frame that did not fit
	 * is not traced: its tracing dispatches are those of a frame drawn
	 * at once with room to spare. */
	CHECK(bc_render_gl_set_capacity(r, 64) == 0);
	CHECK(bc_render_gl_set_capacity(r, 0) == BC_EINVAL);
	REQUIRE(draw(r, t, NULL, &cam, &again) == 0);
	REQUIRE(bc_render_gl_info(r, &info) == 0);
	CHECK_EQ_INT(info.retries, 1);
	CHECK(info.fragments > 64);
	CHECK(frames_equal(&g, &again));
	{
		uint32_t dispatches = info.dispatches;
		REQUIRE(draw(r, t, NULL, &cam, &again) == 0);
		REQUIRE(bc_render_gl_info(r, &info) == 0);
		CHECK_EQ_INT(info.retries, 0);
		CHECK_EQ_INT(info.dispatches, dispatches);
		CHECK(frames_equal(&g, &again));
	}

	/* Out of time (1 ms): with a loop budget the suspended tiles finish
	 * with what they found -- hits as in the full frame, provisional
	 * near hits never behind the full frame's surface, the rest
	 * background -- and the frame says it is incomplete. */
	if (info.loop_budget) {
		struct bc_render_opts o = {.budget_ms = 1};
		struct bc_renderer *rb = NULL;
		struct bc_render_stats st;
		struct bc_errinfo ei = {0};
		uint32_t bg = 0, wrong = 0;
		REQUIRE(bc_renderer_create(&rb, BC_BACKEND_GL, &o, &ei) == 0);
		REQUIRE(bc_renderer_sync(rb, t, NULL, &ei) == 0);
		REQUIRE(bc_renderer_render(rb, &cam, &again, &st, &ei) == 0);
		CHECK(st.incomplete);
		for (size_t i = 0; i < 32 * 32; i++) {
			if (memcmp(again.rgba + 4 * i, g.rgba + 4 * i, 4) ==
			    0) {
				continue;
			}
			if (isinf(again.depth[i]) && again.ids[i] == 0) {
				bg++;
			} else if (!(again.depth[i] <=
			             g.depth[i] +
			                 1e-3f * bc_tree_lin(t)->size)) {
				wrong++;
			}
		}
		CHECK(bg > 0);
		CHECK_EQ_INT(wrong, 0);
		bc_renderer_destroy(rb);
	}
	bc_frame_finish(&g);
	bc_frame_finish(&c);
	bc_frame_finish(&again);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* n small spheres on the view axis, one behind the other: every tile near
 * the middle lists all of them, at distinct depths. */
static int queue(struct bc_tree *t, uint32_t n)
{
	struct bc_op_data u = {BC_OP_UNION, 0.0f, 0.0f};
	int rc;
	bc_tree_begin(t);
	if ((rc = bc_tree_push_op(t, 0, &u, NULL))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_prim_data p;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		p.params[0] = 0.02f + 0.01f * (float)(i % 5);
		p.translate[0] = 0.03f * sinf((float)i);
		p.translate[1] = 0.03f * cosf((float)i);
		p.translate[2] = 2.0f - 4.0f * (float)i / (float)n;
		if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
			return rc;
		}
	}
	if ((rc = bc_tree_pop_op(t, NULL))) {
		return rc;
	}
	return bc_tree_end(t, NULL);
}

static void test_long_tile_lists(void)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, c = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct agreement a;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, 16, 16) == 0 &&
	        bc_frame_init(&c, 16, 16) == 0);
	REQUIRE(queue(t, 1200) == 0);
	bc_camera_default(&cam);
	cam.fov_y_deg = 4.0f;
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &g, &st, &ei) == 0);
	/* Past the 1024 sorted in shared memory: the heap sort's lists. */
	printf("  longest tile list %u\n", st.max_overlap);
	CHECK(st.max_overlap > 1024);
	REQUIRE(draw_cpu(BC_DEBUG_NONE, t, &cam, &c) == 0);
	compare(&g, &c, &a);
	CHECK(a.both > 16);
	CHECK(a.mask_diff * 200 < 16 * 16);
	CHECK(a.median_dz < 1e-3f * bc_tree_lin(t)->size);
	CHECK(a.id_diff * 20 <= a.both);
	bc_frame_finish(&g);
	bc_frame_finish(&c);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* ---- Regions --------------------------------------------------------------
 */

/* Pixels where a and b differ in colour, depth or id (bit for bit). */
static uint32_t mismatches(const struct bc_frame *a, const struct bc_frame *b)
{
	size_t n = (size_t)a->width * a->height;
	uint32_t bad = 0;
	for (size_t i = 0; i < n; i++) {
		bad += memcmp(a->rgba + 4 * i, b->rgba + 4 * i, 4) != 0 ||
		       memcmp(&a->depth[i], &b->depth[i], 4) != 0 ||
		       a->ids[i] != b->ids[i];
	}
	return bad;
}

/* Fills every plane with a pattern no render produces. */
static void scribble(struct bc_frame *f)
{
	size_t n = (size_t)f->width * f->height;
	memset(f->rgba, 0xa5, 4 * n);
	memset(f->depth, 0xa5, 4 * n);
	memset(f->ids, 0xa5, 4 * n);
}

static int draw_region(struct bc_renderer *r, const struct bc_camera *cam,
                       struct bc_frame *f, const uint8_t *tiles, uint32_t level,
                       bool refine, struct bc_render_stats *st)
{
	struct bc_render_region reg = {
	    .tiles = tiles, .level = level, .refine = refine};
	struct bc_errinfo ei = {0};
	int rc = bc_renderer_render_region(r, cam, f, &reg, st, &ei);
	if (rc) {
		fprintf(stderr, "  gl region: %s\n", ei.msg);
	}
	return rc;
}

/* Level 3, then 2, 1, 0 refining: once over every tile, and once more
 * with each level split between two random halves of the tiles. Both
 * must give the whole frame bit for bit, and draw nothing twice. Returns
 * the mismatching pixels. */
static uint32_t refine_vs_whole(struct bc_renderer *r,
                                const struct bc_camera *cam, uint32_t w,
                                uint32_t h, uint32_t *frames)
{
	struct bc_frame ref = {0}, acc = {0};
	uint32_t tw = bc_render_tiles_x(w), th = bc_render_tiles_y(h);
	uint8_t *half = calloc((size_t)tw * th, 1);
	uint32_t bad = 0, calls = 0;
	struct bc_gl_info before, after;
	if (!half || bc_frame_init(&ref, w, h) || bc_frame_init(&acc, w, h)) {
		bad = w * h;
		goto out;
	}
	if (bc_renderer_render(r, cam, &ref, NULL, NULL)) {
		bad = w * h;
		goto out;
	}
	/* The whole frame built the view's A-buffer; every region call
	 * below traces those lists without building them again. */
	if (bc_render_gl_info(r, &before)) {
		bad = w * h;
		goto out;
	}
	for (int split = 0; split < 2; split++) {
		uint64_t rays = 0;
		scribble(&acc);
		acc.key = 0;
		for (int level = 3; level >= 0; level--) {
			struct bc_render_stats st;
			bool refine = level < 3;
			if (!split || level == 3) {
				if (draw_region(r, cam, &acc, NULL,
				                (uint32_t)level, refine, &st)) {
					bad = w * h;
					goto out;
				}
				CHECK(!st.whole);
				rays += st.rays;
				calls++;
				continue;
			}
			for (size_t i = 0; i < (size_t)tw * th; i++) {
				half[i] = (uint8_t)rt_below(2);
			}
			for (int pass = 0; pass < 2; pass++) {
				if (draw_region(r, cam, &acc, half,
				                (uint32_t)level, refine, &st)) {
					bad = w * h;
					goto out;
				}
				CHECK(!st.whole);
				rays += st.rays;
				calls++;
				for (size_t i = 0; i < (size_t)tw * th; i++) {
					half[i] = !half[i];
				}
			}
		}
		CHECK_EQ_INT(rays, (uint64_t)w * h); /* each pixel once */
		bad += mismatches(&acc, &ref);
		(*frames)++;
	}
	CHECK(bc_render_gl_info(r, &after) == 0);
	CHECK_EQ_INT(after.lists_built, before.lists_built);
	CHECK_EQ_INT(after.lists_reused - before.lists_reused, calls);
out:
	free(half);
	bc_frame_finish(&ref);
	bc_frame_finish(&acc);
	return bad;
}

static void test_refinement_equals_whole(void)
{
	static const uint32_t sizes[][2] = {{64, 48}, {37, 23}, {24, 16}};
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint32_t bad = 0, frames = 0;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t);
	rt_state = 7;
	for (int scene = 0; scene < 3; scene++) {
		if (scene == 0) {
			REQUIRE(bc_gen("fig18",
			               &(struct bc_gen_opts){.count = 27}, t,
			               &cam, &ei) == 0);
		} else if (scene == 1) {
			REQUIRE(rt_build(t, 11, 14) == 0);
			bc_camera_default(&cam);
		} else {
			/* Dense tiles: on llvmpipe they pause and suspend,
			 * at other points with fewer rays asked. */
			REQUIRE(crowd(t, 160) == 0);
			bc_camera_default(&cam);
		}
		REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
		{
			uint32_t w = sizes[scene][0], h = sizes[scene][1];
			uint32_t b = refine_vs_whole(r, &cam, w, h, &frames);
			struct bc_gl_info info;
			REQUIRE(bc_render_gl_info(r, &info) == 0);
			printf("  scene %d at %ux%u: %u pixels differ; last "
			       "render %u dispatches, %u suspensions\n",
			       scene, w, h, b, info.dispatches,
			       info.suspensions);
			bad += b;
		}
	}
	/* A sync drops the kept lists: the next frame builds them. */
	{
		struct bc_gl_info a, b;
		struct bc_frame f = {0};
		REQUIRE(bc_frame_init(&f, 24, 16) == 0);
		REQUIRE(bc_render_gl_info(r, &a) == 0);
		REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
		REQUIRE(draw_region(r, &cam, &f, NULL, 0, false, NULL) == 0);
		REQUIRE(bc_render_gl_info(r, &b) == 0);
		CHECK_EQ_INT(b.lists_built, a.lists_built + 1);
		CHECK_EQ_INT(b.lists_reused, a.lists_reused);
		bc_frame_finish(&f);
	}
	/* The loop budget hook: refused below its floor, 0 restores the
	 * driver's. (A budget small enough to suspend tiles mid-frame is
	 * known not to keep pixels exact: docs/gl.md, known gaps.) */
	CHECK(bc_render_gl_set_loop_budget(r, 1) == BC_EINVAL);
	CHECK(bc_render_gl_set_loop_budget(r, BC_GL_MIN_LOOP_BUDGET) == 0);
	CHECK(bc_render_gl_set_loop_budget(r, 0) == 0);
	printf("  %u refined frames compared with whole ones, %u pixels "
	       "differ\n",
	       frames, bad);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(frames, 6);

	/* Pixels a region does not ask for keep what the frame held. */
	{
		struct bc_frame ref = {0}, f = {0};
		uint32_t tw = bc_render_tiles_x(37), th = bc_render_tiles_y(23);
		uint8_t tiles[5 * 3] = {0};
		uint32_t kept = 0, drawn = 0, wrong = 0;
		REQUIRE(tw * th == sizeof(tiles));
		REQUIRE(bc_frame_init(&ref, 37, 23) == 0 &&
		        bc_frame_init(&f, 37, 23) == 0);
		REQUIRE(rt_build(t, 11, 14) == 0);
		REQUIRE(draw(r, t, NULL, &cam, &ref) == 0);
		REQUIRE(bc_renderer_render(r, &cam, &f, NULL, &ei) == 0);
		scribble(&f); /* the key stays: the region is drawn as one */
		tiles[1] = tiles[7] = tiles[14] = 1;
		REQUIRE(draw_region(r, &cam, &f, tiles, 1, true, NULL) == 0);
		for (uint32_t y = 0; y < 23; y++) {
			for (uint32_t x = 0; x < 37; x++) {
				size_t i = (size_t)y * 37 + x;
				bool asked = tiles[(y / 8) * tw + x / 8] &&
				             bc_render_level_has(x, y, 1, true);
				if (asked) {
					drawn++;
					wrong +=
					    memcmp(f.rgba + 4 * i,
					           ref.rgba + 4 * i, 4) != 0 ||
					    f.ids[i] != ref.ids[i];
				} else {
					kept++;
					wrong += f.ids[i] != 0xa5a5a5a5u;
				}
			}
		}
		CHECK(drawn > 0 && kept > 0);
		CHECK_EQ_INT(wrong, 0);
		bc_frame_finish(&ref);
		bc_frame_finish(&f);
	}
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* Marks in tiles the damage of primitives [k0, k1) with ABVs before and
 * after an edit. */
static void mark_damage(struct bc_renderer *r, const struct bc_camera *cam,
                        uint32_t w, uint32_t h, const struct bc_abv *before,
                        const struct bc_lin *after, uint32_t k0, uint32_t k1,
                        uint8_t *tiles)
{
	for (uint32_t k = k0; k < k1; k++) {
		struct bc_abv a = bc_lin_abv(after, k);
		bc_renderer_damage(r, cam, w, h, &before[k], tiles);
		bc_renderer_damage(r, cam, w, h, &a, tiles);
	}
}

/* One random parameter edit of a random node of t (a primitive three
 * times in four): a primitive moves (a little, or far: then the tiles it
 * leaves must be redrawn too), grows or shrinks and may change colour; an
 * operator changes its blend or its kind. [*k0, *k1) receives the
 * primitives whose ABVs can change. Returns 0, or non-zero when the tree
 * refused the edit. */
static int random_edit(struct bc_tree *t, uint32_t *k0, uint32_t *k1)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t s = rt_below(4) ? l->prim_slot[rt_below(l->nprims)]
	                         : rt_below(l->count);
	uint32_t id = l->node_id[s], top;
	struct bc_prim_data p;
	struct bc_op_data op;
	if (!bc_tree_get(t, id, &p, &op)) {
		return -1;
	}
	top = bc_tree_slot(t, id);
	*k0 = bc_lin_first_prim(l, top);
	*k1 = *k0 + (top - bc_lin_first(l, top)) / 2 + 1;
	if (p.kind != BC_PRIM_INVALID) {
		bool far = rt_below(3) == 0;
		for (int i = 0; i < 3; i++) {
			p.translate[i] =
			    far ? rt_float(-1.5f, 1.5f)
			        : p.translate[i] + rt_float(-0.15f, 0.15f);
		}
		float grow = rt_float(0.85f, 1.15f);
		for (int i = 0; i < BC_PRIM_MAX_PARAMS; i++) {
			p.params[i] *= grow; /* lengths, for the kinds here */
		}
		if (rt_below(3) == 0) {
			p.has_color = true;
			p.color[rt_below(3)] = rt_float(0.0f, 1.0f);
		}
		return bc_tree_set_prim(t, id, &p, NULL);
	}
	if (rt_below(2) == 0) {
		rt_random_op(&op); /* another kind, perhaps another class */
	} else if (bc_op_is_smooth(op.kind)) {
		op.blend *= rt_float(0.7f, 1.4f);
		op.range = op.blend * rt_float(1.2f, 2.0f);
	}
	return bc_tree_set_op(t, id, &op, NULL);
}

static void test_damage_regions_equal_whole(void)
{
	/* Small frames: llvmpipe's cost is per tile, whatever the pixels
	 * asked (docs/gl.md), and two renders per edit add up. */
	static const uint32_t sizes[][2] = {{48, 32}, {37, 27}};
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame acc = {0}, ref = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_abv *before = NULL;
	uint8_t *tiles = NULL;
	uint32_t tried = 0, refused = 0, frames = 0, regions = 0, bad = 0;
	uint64_t tiles_drawn = 0, tiles_all = 0;
	double ms_region = 0.0, ms_whole = 0.0;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t);
	rt_state = 3;
	for (int scene = 0; scene < 4; scene++) {
		uint32_t w = sizes[scene % 2][0], h = sizes[scene % 2][1];
		uint32_t ntiles = bc_render_tiles_x(w) * bc_render_tiles_y(h);
		const struct bc_lin *l;
		switch (scene) {
		case 0:
			REQUIRE(
			    bc_gen("fig18",
			           &(struct bc_gen_opts){
			               .count = 8, .kind = BC_GEN_KIND_SPHERES},
			           t, &cam, &ei) == 0);
			break;
		case 1:
			REQUIRE(bc_gen("fig18",
			               &(struct bc_gen_opts){
			                   .count = 8,
			                   .kind = BC_GEN_KIND_SPHERES,
			                   .blend = BC_GEN_BLEND_SHARP},
			               t, &cam, &ei) == 0);
			break;
		default:
			REQUIRE(rt_build(t, 100 + (uint64_t)scene, 12) == 0);
			bc_camera_default(&cam);
			break;
		}
		l = bc_tree_lin(t);
		REQUIRE(l);
		bc_frame_finish(&acc);
		bc_frame_finish(&ref);
		free(before);
		free(tiles);
		before = calloc(l->nprims, sizeof(*before));
		tiles = calloc(ntiles, 1);
		REQUIRE(before && tiles && bc_frame_init(&acc, w, h) == 0 &&
		        bc_frame_init(&ref, w, h) == 0);
		{
			struct bc_dirty clean;
			bc_tree_take_dirty(t, &clean);
		}
		REQUIRE(draw(r, t, NULL, &cam, &acc) == 0);
		for (int e = 0; e < 50; e++) {
			struct bc_render_stats st;
			struct bc_dirty dirty;
			uint32_t k0, k1, lo, hi, b;
			for (uint32_t k = 0; k < l->nprims; k++) {
				before[k] = bc_lin_abv(l, k);
			}
			tried++;
			if (random_edit(t, &k0, &k1)) {
				refused++;
				continue;
			}
			bc_tree_take_dirty(t, &dirty);
			REQUIRE(!dirty.structure);
			REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) == 0);
			l = bc_tree_lin(t);
			lo = dirty.prim_lo < dirty.prim_hi && dirty.prim_lo < k0
			         ? dirty.prim_lo
			         : k0;
			hi = dirty.prim_lo < dirty.prim_hi && dirty.prim_hi > k1
			         ? dirty.prim_hi
			         : k1;
			memset(tiles, 0, ntiles);
			mark_damage(r, &cam, w, h, before, l, lo, hi, tiles);
			REQUIRE(draw_region(r, &cam, &acc, tiles, 0, false,
			                    &st) == 0);
			ms_region += st.ms_total;
			if (!st.whole) {
				regions++;
				tiles_drawn += st.tiles;
				tiles_all += ntiles;
			}
			REQUIRE(bc_renderer_render(r, &cam, &ref, &st, &ei) ==
			        0);
			ms_whole += st.ms_total;
			b = mismatches(&acc, &ref);
			if (b) {
				fprintf(stderr,
				        "  scene %d edit %d (node range "
				        "%u..%u): %u pixels differ\n",
				        scene, e, lo, hi, b);
			}
			bad += b;
			frames++;
		}
	}
	printf("  %u edits tried (%u refused), %u frames compared, %u drawn "
	       "as regions (%.0f %% of the tiles), %u pixels differ; "
	       "%.1f ms per region, %.1f ms per whole frame\n",
	       tried, refused, frames, regions,
	       tiles_all ? 100.0 * (double)tiles_drawn / (double)tiles_all
	                 : 0.0,
	       bad, frames ? ms_region / frames : 0.0,
	       frames ? ms_whole / frames : 0.0);
	CHECK_EQ_INT(bad, 0);
	CHECK(frames >= tried * 3 / 4);
	CHECK(regions >= frames / 2);
	bc_frame_finish(&acc);
	bc_frame_finish(&ref);
	free(before);
	free(tiles);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* ---- Platforms --------------------------------------------------------------
 */

static void test_platforms_draw_the_same(void)
{
	static const char *const names[] = {"surfaceless", "device", "osmesa"};
	struct bc_tree *t = bc_tree_create();
	struct bc_frame ref = {0}, f = {0};
	struct bc_camera cam;
	struct bc_render_opts bad = {.gl_platform = "vulkan"};
	struct bc_renderer *r = NULL;
	struct bc_errinfo ei = {0};
	bool any = false;
	REQUIRE(t && bc_frame_init(&ref, 32, 32) == 0 &&
	        bc_frame_init(&f, 32, 32) == 0);
	REQUIRE(bc_gen("fig18", &(struct bc_gen_opts){.count = 27}, t, &cam,
	               NULL) == 0);
	if (bc_backend_available(BC_BACKEND_GL)) {
		CHECK(bc_renderer_create(&r, BC_BACKEND_GL, &bad, &ei) ==
		      BC_EINVAL);
		CHECK(r == NULL);
	}
	for (size_t i = 0; i < 3; i++) {
		struct bc_renderer *pr = open_gl(names[i], BC_DEBUG_NONE);
		struct bc_gl_info info;
		if (!pr) {
			/* This machine has surfaceless llvmpipe and OSMesa
			 * (see PLATFORM.md): only a host without any GL may
			 * lack them, and then no platform opens. */
			CHECK(!any);
			continue;
		}
		REQUIRE(bc_render_gl_info(pr, &info) == 0);
		printf("  %s: %s, %s (%d.%d), robust access %s, reset %s\n",
		       names[i], info.renderer, info.version, info.major,
		       info.minor, info.robust_access ? "yes" : "no",
		       info.lose_on_reset ? "loses context" : "no");
		CHECK(strcmp(bc_gl_platform_name(info.platform), names[i]) ==
		      0);
		CHECK(info.major > 4 || (info.major == 4 && info.minor >= 3));
		CHECK(info.renderer[0] != '\0');
		CHECK(info.shared_bytes >= 16384);
		CHECK(draw(pr, t, NULL, &cam, any ? &f : &ref) == 0);
		/* Same driver underneath here: the same picture. Another
		 * driver (a GPU) would only have to agree like the CPU. */
		if (any && strstr(info.renderer, "llvmpipe")) {
			CHECK(frames_equal(&ref, &f));
		}
		any = true;
		bc_renderer_destroy(pr);
	}
	bc_frame_finish(&ref);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
	if (!any) {
		BC_SKIP("no GL context");
	}
}

/* ---- Debug modes, sizes, empty scenes, errors --------------------------- */

static void test_debug_modes_match_cpu(void)
{
	struct bc_renderer *ov = open_gl(NULL, BC_DEBUG_OVERLAPS);
	struct bc_renderer *ev = open_gl(NULL, BC_DEBUG_EVALS);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, c = {0};
	struct bc_camera cam;
	struct agreement a;
	uint32_t ramp_px = 0;
	if (!ov || !ev) {
		if (ov) {
			bc_renderer_destroy(ov);
		}
		if (ev) {
			bc_renderer_destroy(ev);
		}
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, W, H) == 0 &&
	        bc_frame_init(&c, W, H) == 0);
	REQUIRE(bc_gen("fig18", &(struct bc_gen_opts){.count = 64}, t, &cam,
	               NULL) == 0);
	/* Overlaps: the tile lists' lengths, so the same colours. */
	REQUIRE(draw(ov, t, NULL, &cam, &g) == 0);
	REQUIRE(draw_cpu(BC_DEBUG_OVERLAPS, t, &cam, &c) == 0);
	compare(&g, &c, &a);
	printf("  overlaps: %u of %u pixels differ\n", a.rgba_diff, W * H);
	CHECK(a.rgba_diff * 100 <= W * H);
	/* Evaluations: counts differ a little between tracers; the corner
	 * tiles list nothing and cost nothing, the middle is coloured. */
	REQUIRE(draw(ev, t, NULL, &cam, &g) == 0);
	REQUIRE(draw_cpu(BC_DEBUG_EVALS, t, &cam, &c) == 0);
	CHECK(memcmp(g.rgba, c.rgba, 4) == 0);
	for (size_t i = 0; i < (size_t)W * H; i++) {
		ramp_px += memcmp(g.rgba + 4 * i, g.rgba, 3) != 0;
	}
	CHECK(ramp_px > W * H / 10);
	compare(&g, &c, &a);
	CHECK(a.mask_diff * 200 < W * H);
	bc_frame_finish(&g);
	bc_frame_finish(&c);
	bc_tree_destroy(t);
	bc_renderer_destroy(ov);
	bc_renderer_destroy(ev);
}

static void test_odd_sizes_and_empty_scene(void)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, c = {0};
	struct bc_camera cam;
	struct agreement a;
	uint8_t *rgba;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, 37, 23) == 0 &&
	        bc_frame_init(&c, 37, 23) == 0);
	REQUIRE(bc_gen("fig16", &(struct bc_gen_opts){.level = 1}, t, &cam,
	               NULL) == 0);
	REQUIRE(draw(r, t, NULL, &cam, &g) == 0);
	REQUIRE(draw_cpu(BC_DEBUG_NONE, t, &cam, &c) == 0);
	compare(&g, &c, &a);
	CHECK(a.mask_diff * 200 < 37 * 23);
	CHECK(a.median_dz < 1e-3f * bc_tree_lin(t)->size);
	CHECK(a.both > 0);

	/* Depth and ids are optional. */
	rgba = malloc(4 * 37 * 23);
	REQUIRE(rgba);
	{
		struct bc_frame only = {
		    .width = 37, .height = 23, .rgba = rgba};
		struct bc_errinfo ei = {0};
		CHECK(bc_renderer_render(r, &cam, &only, NULL, &ei) == 0);
		CHECK(memcmp(rgba, g.rgba, 4 * 37 * 23) == 0);
	}
	free(rgba);

	/* An empty tree: the background, exactly the CPU's. */
	{
		struct bc_tree *empty = bc_tree_create();
		REQUIRE(empty && bc_tree_lin(empty) == NULL);
		REQUIRE(draw(r, empty, NULL, &cam, &g) == 0);
		REQUIRE(draw_cpu(BC_DEBUG_NONE, empty, &cam, &c) == 0);
		CHECK(frames_equal(&g, &c));
		CHECK(isinf(g.depth[0]) && g.ids[0] == 0);
		bc_tree_destroy(empty);
	}
	bc_frame_finish(&g);
	bc_frame_finish(&c);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

/* A gl renderer whose A-buffer holds at most limit fragments, synced to
 * t; NULL (said why) when it cannot be made. */
static struct bc_renderer *open_limited(uint32_t limit, const struct bc_tree *t)
{
	struct bc_render_opts o = {.abuffer_limit = limit};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, BC_BACKEND_GL, &o, &ei) ||
	    bc_renderer_sync(r, t, NULL, &ei)) {
		fprintf(stderr, "  gl, limit %u: %s\n", limit, ei.msg);
		bc_renderer_destroy(r);
		return NULL;
	}
	return r;
}

/* A view whose lists pass the A-buffer's limit (opts.abuffer_limit raised
 * from a third of this view's fragments until each tile row fits) is
 * drawn in bands of tile rows, the pixels of one pass bit for bit. The
 * next whole frame of the view goes to bands at once: no A-buffer of
 * every tile is built to count it again. A limit under one tile row's
 * lists is refused with BC_ELIMIT.
 * (tests/render/test_window.c compares bands with one pass in regions,
 * refinement and edits, for tiled and gl alike.) */
static void test_view_over_the_limit_in_bands(void)
{
	static const struct bc_gen_opts fig = {.count = 64,
	                                       .kind = BC_GEN_KIND_SPHERES};
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE), *rb = NULL;
	struct bc_tree *t = bc_tree_create();
	struct bc_frame g = {0}, f = {0};
	struct bc_errinfo ei = {0};
	struct bc_render_stats st;
	struct bc_gl_info info;
	struct bc_camera cam;
	uint32_t limit, built;
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("no GL context");
	}
	REQUIRE(t && bc_frame_init(&g, W, H) == 0 &&
	        bc_frame_init(&f, W, H) == 0);
	REQUIRE(bc_gen("fig18", &fig, t, &cam, &ei) == 0);
	REQUIRE(draw(r, t, NULL, &cam, &g) == 0);
	REQUIRE(bc_render_gl_info(r, &info) == 0);
	REQUIRE(info.fragments > 30);
	for (limit = info.fragments / 3;; limit += limit / 4) {
		REQUIRE(limit < info.fragments);
		REQUIRE((rb = open_limited(limit, t)));
		if (bc_renderer_render(rb, &cam, &f, &st, &ei) == 0) {
			break;
		}
		CHECK(strstr(ei.msg, "tile row") != NULL);
		ei = (struct bc_errinfo){0};
		bc_renderer_destroy(rb);
	}
	printf("  %u fragments, limit %u: %u bands\n", info.fragments, limit,
	       st.bands);
	CHECK(st.bands >= 3);
	CHECK(frames_equal(&f, &g));
	REQUIRE(bc_render_gl_info(rb, &info) == 0);
	built = info.lists_built;
	CHECK(info.fragments <= limit * st.bands);
	memset(f.rgba, 0, 4 * (size_t)W * H);
	REQUIRE(bc_renderer_render(rb, &cam, &f, &st, &ei) == 0);
	CHECK(st.bands >= 3);
	CHECK(frames_equal(&f, &g));
	REQUIRE(bc_render_gl_info(rb, &info) == 0);
	CHECK_EQ_INT(info.lists_built, built);
	bc_renderer_destroy(rb);
	/* Buffers a quarter of the limit: bands are drawn in them (fewer
	 * rows where a band would pass them, larger buffers only for a row
	 * that does), the same pixels. */
	REQUIRE((rb = open_limited(limit, t)));
	REQUIRE(bc_render_gl_set_capacity(rb, limit / 4) == 0);
	memset(f.rgba, 0, 4 * (size_t)W * H);
	REQUIRE(bc_renderer_render(rb, &cam, &f, &st, &ei) == 0);
	printf("  buffers of %u fragments: %u bands\n", limit / 4, st.bands);
	CHECK(st.bands >= 6);
	CHECK(frames_equal(&f, &g));
	bc_renderer_destroy(rb);
	/* One fragment: no row fits. */
	REQUIRE((rb = open_limited(1, t)));
	CHECK_EQ_INT(bc_renderer_render(rb, &cam, &f, &st, &ei), BC_ELIMIT);
	CHECK(strstr(ei.msg, "tile row") != NULL);
	bc_renderer_destroy(rb);
	bc_frame_finish(&g);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
	bc_renderer_destroy(r);
}

static void test_bad_calls_are_refused(void)
{
	struct bc_renderer *r = open_gl(NULL, BC_DEBUG_NONE);
	struct bc_render_opts bad_dbg = {.debug = BC_DEBUG_COUNT};
	struct bc_renderer *nr = NULL;
	struct bc_frame f = {0}, zero = {0};
	struct bc_camera cam, same;
	struct bc_errinfo ei = {0};
	if (!r) {
		BC_SKIP("no GL context");
	}
	REQUIRE(bc_frame_init(&f, 16, 16) == 0);
	bc_camera_default(&cam);
	CHECK(bc_renderer_create(&nr, BC_BACKEND_GL, &bad_dbg, &ei) ==
	          BC_EENUM &&
	      !nr);
	CHECK(bc_renderer_render(r, &cam, &f, NULL, &ei) == BC_ESTATE);
	CHECK(bc_renderer_sync(r, NULL, NULL, &ei) == BC_EINVAL);
	{
		struct bc_tree *t = bc_tree_create();
		REQUIRE(t);
		REQUIRE(bc_gen("comb", &(struct bc_gen_opts){.count = 4}, t,
		               &cam, NULL) == 0);
		CHECK(bc_renderer_sync(r, t, NULL, &ei) == 0);
		CHECK(bc_renderer_render(r, &cam, &zero, NULL, &ei) ==
		      BC_EINVAL);
		same = cam;
		memcpy(same.target, same.eye, sizeof(same.eye));
		CHECK(bc_renderer_render(r, &same, &f, NULL, &ei) == BC_ERANGE);
		if (bc_renderer_render(r, &cam, &f, NULL, &ei) != 0) {
			fprintf(stderr, "  render: %s\n", ei.msg);
			CHECK(0);
		}
		bc_tree_destroy(t);
	}
	bc_renderer_destroy(NULL);
	/* The gl calls refuse another backend's renderer. */
	if (bc_renderer_create(&nr, BC_BACKEND_TILED, NULL, &ei) == 0) {
		struct bc_gl_info info;
		CHECK(bc_render_gl_info(nr, &info) == BC_EINVAL);
		CHECK(bc_render_gl_set_capacity(nr, 64) == BC_EINVAL);
		bc_renderer_destroy(nr);
	}
	bc_frame_finish(&f);
	bc_renderer_destroy(r);
}

static const struct bc_test tests[] = {
    {"unary_nodes_agree_with_tiled", test_unary_nodes_agree_with_tiled},
    {"families_agree_with_tiled", test_families_agree_with_tiled},
    {"param_edit_equals_fresh_load", test_param_edit_equals_fresh_load},
    {"overflows_degrade_not_fail", test_overflows_degrade_not_fail},
    {"long_tile_lists", test_long_tile_lists},
    {"platforms_draw_the_same", test_platforms_draw_the_same},
    {"debug_modes_match_cpu", test_debug_modes_match_cpu},
    {"odd_sizes_and_empty_scene", test_odd_sizes_and_empty_scene},
    {"refinement_equals_whole", test_refinement_equals_whole},
    {"damage_regions_equal_whole", test_damage_regions_equal_whole},
    {"view_over_the_limit_in_bands", test_view_over_the_limit_in_bands},
    {"bad_calls_are_refused", test_bad_calls_are_refused},
};

BC_TEST_MAIN(tests)
