/*
 * The `svo` backend against the CPU `tiled` renderer on the same scenes and
 * cameras: hit masks differ on fewer than 0.5 % of the pixels, the primitive
 * ids and depths of pixels both hit agree, in every range arithmetic; and
 * the backend's contract: empty trees, syncs after edits, bad options.
 */
#include <stdio.h>
#include <string.h>

#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "blobcast/svo.h"
#include "svo_util.h"
#include "test.h"

#define W 96
#define H 72

struct cmp {
	uint32_t mask_diff, both, id_diff, depth_close, depth_bad;
};

/* Renders t with cam through tiled and svo (arith) and compares. */
static int compare(const struct bc_tree *t, const struct bc_camera *cam,
                   enum bc_range_arith arith, struct cmp *c)
{
	struct bc_frame a, b;
	struct bc_render_opts ot = {.threads = 2};
	struct bc_render_opts os = {.threads = 2, .svo_range = arith};
	struct bc_errinfo ei = {0};
	struct bc_render_stats st;
	struct bc_view_rays vr;
	const struct bc_lin *l = bc_tree_lin(t);
	float pix;
	int rc;
	memset(c, 0, sizeof(*c));
	bc_view_rays_init(&vr, cam, W, H);
	pix = 2.0f * vr.tan_half_y / (float)H;
	if (bc_frame_init(&a, W, H) || bc_frame_init(&b, W, H)) {
		return BC_ENOMEM;
	}
	rc = bc_render_once(BC_BACKEND_TILED, &ot, t, cam, &a, &st, &ei);
	if (rc == 0) {
		rc = bc_render_once(BC_BACKEND_SVO, &os, t, cam, &b, &st, &ei);
	}
	if (rc) {
		fprintf(stderr, "  render: %s\n", ei.msg);
	}
	for (uint32_t i = 0; rc == 0 && i < W * H; i++) {
		bool ha = isfinite(a.depth[i]), hb = isfinite(b.depth[i]);
		c->mask_diff += ha != hb;
		if (ha && hb) {
			c->both++;
			float band =
			    BC_SVO_HIT_LIPSCHITZ *
			    fmaxf(BC_SVO_HIT_FOOTPRINT * pix * a.depth[i],
			          BC_SVO_MIN_STEP_REL * l->size);
			c->id_diff += a.ids[i] != b.ids[i];
			/* Where a ray crosses the surface both refine to the
			 * crossing. Where it only grazes it (within the hit
			 * band), the sphere tracer stops wherever a step
			 * lands in the band -- up to about two bands past
			 * its entry, where the caster stops -- or steps over
			 * a short dip and goes on to what lies behind. */
			c->depth_close +=
			    fabsf(a.depth[i] - b.depth[i]) <= 1e-3f * l->size;
			c->depth_bad +=
			    fabsf(a.depth[i] - b.depth[i]) > 3.0f * band;
		}
	}
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	return rc;
}

static void check_scene(const char *what, const struct bc_tree *t,
                        const struct bc_camera *cam, enum bc_range_arith arith)
{
	struct cmp c;
	REQUIRE(compare(t, cam, arith, &c) == 0);
	printf("  %-13s %-5s: mask diff %2u/%u, of %4u hits: ids differ %3u, "
	       "depth within 1e-3 %4u, beyond 3 bands %3u\n",
	       what,
	       arith == BC_RANGE_IA ? "ia"
	                            : (arith == BC_RANGE_AA ? "aa" : "revaa"),
	       c.mask_diff, W * H, c.both, c.id_diff, c.depth_close,
	       c.depth_bad);
	CHECK(c.mask_diff * 200u < W * H); /* < 0.5 % */
	CHECK(c.both > W * H / 20);        /* the scene is in view */
	/* Grazing rays (see compare()) are a minority at this size. */
	CHECK(c.id_diff * 5u <= c.both);
	CHECK(c.depth_close * 5u >= 2u * c.both);
	CHECK(c.depth_bad * 5u <= c.both);
}

static void svo_matches_tiled_on_generated_scenes(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
		enum bc_range_arith arith;
	} scenes[] = {
	    {"gears", {.teeth = 24}, BC_RANGE_REVAA},
	    {"gears", {.teeth = 16}, BC_RANGE_IA},
	    {"gears", {.teeth = 12}, BC_RANGE_AA},
	    {"many-gears", {.count = 9}, BC_RANGE_REVAA},
	    {"many-spheres", {.count = 300}, BC_RANGE_REVAA},
	    {"fig18",
	     {.count = 48, .kind = BC_GEN_KIND_SPHERES},
	     BC_RANGE_REVAA},
	    {"fig18", {.count = 32}, BC_RANGE_REVAA},
	    {"fig16", {.level = 2}, BC_RANGE_REVAA},
	    {"random", {.count = 60, .seed = 18}, BC_RANGE_REVAA},
	    /* Every primitive kind (the later ones through the Lipschitz
	     * enclosure). */
	    {"catalogue", {0}, BC_RANGE_IA},
	    {"catalogue", {.blend = BC_GEN_BLEND_SMOOTH}, BC_RANGE_REVAA},
	};
	for (size_t i = 0; i < sizeof(scenes) / sizeof(scenes[0]); i++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		REQUIRE(t);
		REQUIRE(bc_gen(scenes[i].name, &scenes[i].o, t, &cam, &ei) ==
		        0);
		check_scene(scenes[i].name, t, &cam, scenes[i].arith);
		bc_tree_destroy(t);
	}
}

static void svo_matches_tiled_on_the_default_scene(void)
{
	const char *json = bc_scene_default_json();
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	REQUIRE(bc_scene_parse_json(json, strlen(json), t, &cam, &ei) == 0);
	check_scene("default scene", t, &cam, BC_RANGE_REVAA);
	check_scene("default scene", t, &cam, BC_RANGE_IA);
	check_scene("default scene", t, &cam, BC_RANGE_AA);
	bc_tree_destroy(t);
}

/* A camera inside a solid sees its inside: the hit is at the near end of
 * every ray, as with the sphere tracer. */
static void camera_inside_a_solid_hits_at_once(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_camera cam;
	struct bc_frame f;
	REQUIRE(t);
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 2.0f;
	REQUIRE(bc_tree_begin(t) == 0 &&
	        bc_tree_put_prim(t, 7, &p, NULL) == 0 &&
	        bc_tree_end(t, NULL) == 0);
	bc_camera_default(&cam);
	cam.eye[2] = 0.5f;
	REQUIRE(bc_frame_init(&f, 16, 16) == 0);
	REQUIRE(bc_render_once(BC_BACKEND_SVO, NULL, t, &cam, &f, NULL, NULL) ==
	        0);
	for (uint32_t i = 0; i < 16 * 16; i++) {
		CHECK(f.depth[i] == 0.0f);
		CHECK(f.ids[i] == 7);
	}
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* The backend through its ops: an empty tree is all background; an edit
 * synced with its dirty ranges is drawn, an empty dirty set keeps the
 * octree; bad options and a render before sync are refused. */
static void backend_follows_syncs_and_refuses_bad_input(void)
{
	struct bc_renderer *r = NULL;
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_camera cam;
	struct bc_frame f;
	struct bc_render_stats st;
	struct bc_dirty d;
	struct bc_errinfo ei = {0};
	uint32_t hits = 0, hits2 = 0;
	REQUIRE(t && bc_backend_available(BC_BACKEND_SVO));
	CHECK(bc_renderer_create(
	          &r, BC_BACKEND_SVO,
	          &(struct bc_render_opts){.svo_range = BC_RANGE_COUNT},
	          &ei) == BC_EENUM);
	CHECK(r == NULL);
	CHECK(bc_renderer_create(&r, BC_BACKEND_SVO,
	                         &(struct bc_render_opts){
	                             .svo_max_depth = BC_SVO_MAX_DEPTH + 1},
	                         &ei) == BC_ERANGE);
	REQUIRE(bc_renderer_create(&r, BC_BACKEND_SVO,
	                           &(struct bc_render_opts){.threads = 1},
	                           &ei) == 0);
	CHECK(bc_renderer_backend(r) == BC_BACKEND_SVO);
	bc_camera_default(&cam);
	REQUIRE(bc_frame_init(&f, 32, 32) == 0);
	CHECK(bc_renderer_render(r, &cam, &f, &st, &ei) == BC_ESTATE);
	/* An empty tree. */
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
	for (uint32_t i = 0; i < 32 * 32; i++) {
		CHECK(f.ids[i] == 0 && isinf(f.depth[i]));
	}
	/* A sphere. */
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 1.0f;
	REQUIRE(bc_tree_begin(t) == 0 &&
	        bc_tree_put_prim(t, 5, &p, NULL) == 0 &&
	        bc_tree_end(t, NULL) == 0);
	bc_tree_take_dirty(t, &d);
	REQUIRE(bc_renderer_sync(r, t, &d, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
	for (uint32_t i = 0; i < 32 * 32; i++) {
		hits += f.ids[i] == 5;
	}
	CHECK(hits > 50);
	CHECK(st.ms_total >= st.ms_trace);
	CHECK(st.field_evals > 0);
	/* Nothing changed: the octree stays (no build time). */
	bc_tree_take_dirty(t, &d);
	REQUIRE(bc_renderer_sync(r, t, &d, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
	CHECK(st.ms_abuffer < 1.0);
	/* A parameter edit: the sphere grows. */
	p.params[0] = 1.5f;
	REQUIRE(bc_tree_set_prim(t, 5, &p, &ei) == 0);
	bc_tree_take_dirty(t, &d);
	REQUIRE(bc_renderer_sync(r, t, &d, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
	for (uint32_t i = 0; i < 32 * 32; i++) {
		hits2 += f.ids[i] == 5;
	}
	CHECK(hits2 > hits);
	/* Debug views colour every pixel. */
	bc_renderer_destroy(r);
	REQUIRE(bc_renderer_create(
	            &r, BC_BACKEND_SVO,
	            &(struct bc_render_opts){.debug = BC_DEBUG_EVALS},
	            &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
	CHECK(f.rgba[3] == 255);
	cam.fov_y_deg = 0.0f;
	CHECK(bc_renderer_render(r, &cam, &f, &st, &ei) == BC_ERANGE);
	bc_renderer_destroy(r);
	bc_renderer_destroy(NULL);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* A frame over its time budget starts no more tiles: what is left is
 * background and the stats say the frame is incomplete. Building the
 * octree of a few hundred spheres alone takes longer than 1 ms. */
static void frame_over_budget_is_incomplete(void)
{
	struct bc_gen_opts o = {.count = 300};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_frame f;
	struct bc_render_stats st;
	struct bc_render_opts ro = {.threads = 1, .budget_ms = 1};
	uint32_t hits = 0;
	REQUIRE(t);
	REQUIRE(bc_gen("many-spheres", &o, t, &cam, NULL) == 0);
	REQUIRE(bc_frame_init(&f, 32, 32) == 0);
	REQUIRE(bc_render_once(BC_BACKEND_SVO, &ro, t, &cam, &f, &st, NULL) ==
	        0);
	CHECK(st.incomplete);
	for (uint32_t i = 0; i < 32 * 32; i++) {
		hits += f.ids[i] != 0;
	}
	CHECK(hits == 0);
	ro.budget_ms = 0;
	REQUIRE(bc_render_once(BC_BACKEND_SVO, &ro, t, &cam, &f, &st, NULL) ==
	        0);
	CHECK(!st.incomplete);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* A packet skips its beam test in the leaf where the caster's previous
 * packet hit, and every thread has its own caster: the evaluation counts
 * (the stats, the debug view's colours) must still not depend on which
 * tiles a thread took (svo.h, bc_svo_caster_forget). One to four threads,
 * twice each: the same counts and the same debug frame. */
static void evaluation_counts_do_not_depend_on_threads(void)
{
	struct bc_gen_opts o = {.count = 64,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SHARP};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_frame f, g;
	struct bc_render_stats st;
	uint64_t evals = 0;
	REQUIRE(t);
	REQUIRE(bc_gen("fig18", &o, t, &cam, NULL) == 0);
	REQUIRE(bc_frame_init(&f, W, H) == 0);
	REQUIRE(bc_frame_init(&g, W, H) == 0);
	for (uint32_t k = 0; k < 8; k++) {
		struct bc_render_opts ro = {.threads = 1 + k % 4,
		                            .debug = BC_DEBUG_EVALS};
		REQUIRE(bc_render_once(BC_BACKEND_SVO, &ro, t, &cam,
		                       k ? &g : &f, &st, NULL) == 0);
		if (k == 0) {
			evals = st.field_evals;
			continue;
		}
		CHECK(st.field_evals == evals);
		CHECK(memcmp(f.rgba, g.rgba, (size_t)W * H * 4) == 0);
	}
	CHECK(evals > (uint64_t)W * H);
	bc_frame_finish(&f);
	bc_frame_finish(&g);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"evaluation_counts_do_not_depend_on_threads",
     evaluation_counts_do_not_depend_on_threads},
    {"frame_over_budget_is_incomplete", frame_over_budget_is_incomplete},
    {"svo_matches_tiled_on_generated_scenes",
     svo_matches_tiled_on_generated_scenes},
    {"svo_matches_tiled_on_the_default_scene",
     svo_matches_tiled_on_the_default_scene},
    {"camera_inside_a_solid_hits_at_once", camera_inside_a_solid_hits_at_once},
    {"backend_follows_syncs_and_refuses_bad_input",
     backend_follows_syncs_and_refuses_bad_input},
};

BC_TEST_MAIN(tests)
