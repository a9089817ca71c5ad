/*
 * The CPU renderers. `tiled` (A-buffer, depth ranges, pruned views) must
 * draw what `naive` (full tree per pixel) draws on the paper's scene
 * families: hit masks equal on all but 0.5 % of pixels, median depth
 * difference under 1e-3 of the scene size, the same primitive ids on at
 * least 90 % of the pixels both hit (ids flip along seams and silhouettes,
 * which small test frames are full of). Plus the camera's geometry against
 * analytic values, the M_overlap degradation, thread-count independence, debug
 * modes, the dispatcher, and allocation failures at every step of a tiled
 * frame.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/render.h"
#include "blobcast/render_common.h"
#include "blobcast/scene.h"
#include "blobcast/shade.h"
#include "test.h"

#include "compare.h"
#include "scenes.h"

#include "blobtree/randtree.h"

/* Renders t with naive and tiled at w x h and checks they agree; at least
 * 1/cover of the pixels must show the scene. */
static void check_agree_cover(const char *what, struct bc_tree *t, uint32_t w,
                              uint32_t h, uint32_t cover)
{
	struct bc_frame fn = {0}, ft = {0};
	struct bc_render_stats sn, st;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	const struct bc_lin *l = bc_tree_lin(t);
	struct cmp c;
	REQUIRE(l != NULL);
	sc_frame(l, &cam);
	REQUIRE(bc_frame_init(&fn, w, h) == 0);
	REQUIRE(bc_frame_init(&ft, w, h) == 0);
	CHECK_EQ_INT(
	    bc_render_once(BC_BACKEND_NAIVE, NULL, t, &cam, &fn, &sn, &ei), 0);
	CHECK_EQ_INT(
	    bc_render_once(BC_BACKEND_TILED, NULL, t, &cam, &ft, &st, &ei), 0);
	c = compare(&fn, &ft);
	printf("  %-22s prims %5u: mask %.4f%%, depth median %.2e (size %.2f),"
	       " ids %.2f%%, hit %u px, evals naive %llu tiled %llu, "
	       "max overlap %u\n",
	       what, l->nprims, 100.0 * c.mask_frac, c.depth_med,
	       (double)l->size, 100.0 * c.id_frac, c.both,
	       (unsigned long long)sn.field_evals,
	       (unsigned long long)st.field_evals, st.max_overlap);
	/* The scene must be on screen, or agreement would be vacuous. */
	CHECK(c.both > w * h / cover);
	CHECK(c.mask_frac < 0.005);
	CHECK(c.depth_med < 1e-3 * (double)l->size);
	CHECK(c.id_frac > 0.90);
	CHECK(st.max_overlap >= 1);
	bc_frame_finish(&fn);
	bc_frame_finish(&ft);
}

static void check_agree(const char *what, struct bc_tree *t, uint32_t w,
                        uint32_t h)
{
	check_agree_cover(what, t, w, h, 20);
}

static void test_tiled_matches_naive_fig16(void)
{
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (uint32_t level = 1; level <= 2; level++) {
		for (int smooth = 0; smooth <= 1; smooth++) {
			char what[32];
			snprintf(what, sizeof(what), "fig16 L%u %s", level,
			         smooth ? "smooth" : "sharp");
			REQUIRE(sc_fig16(t, level, smooth) == 0);
			check_agree(what, t, 96 + 32 * (level - 1),
			            80 + 32 * (level - 1));
		}
	}
	bc_tree_destroy(t);
}

static void test_tiled_matches_naive_fig18(void)
{
	static const uint32_t counts[] = {16, 64, 256};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < 3; i++) {
		for (int kind = 0; kind < 4; kind++) {
			bool boxes = kind & 1, smooth = kind & 2;
			char what[48];
			snprintf(what, sizeof(what), "fig18 %s %s %u",
			         boxes ? "boxes" : "spheres",
			         smooth ? "smooth" : "sharp", counts[i]);
			REQUIRE(sc_fig18(t, counts[i], boxes, smooth, 18 + i) ==
			        0);
			check_agree(what, t, 64 + 12 * (uint32_t)i,
			            64 + 12 * (uint32_t)i);
		}
	}
	bc_tree_destroy(t);
}

static void test_tiled_matches_naive_comb_and_random(void)
{
	struct bc_tree *t = bc_tree_create();
	int tested = 0;
	REQUIRE(t);
	/* The comb's spheres shrink as they multiply: 24 keeps them several
	 * pixels wide here. */
	REQUIRE(sc_comb(t, 24, true) == 0);
	check_agree_cover("comb 24 smooth", t, 160, 64, 40);
	REQUIRE(sc_comb(t, 24, false) == 0);
	check_agree_cover("comb 24 sharp", t, 160, 64, 40);
	/* Random trees with every operator; many are nearly empty (their
	 * intersections and differences remove most), so take the first six
	 * that fill a fair part of the frame. */
	for (uint64_t seed = 1; seed <= 100 && tested < 6; seed++) {
		char what[32];
		struct bc_frame f = {0};
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		uint32_t hit = 0;
		REQUIRE(sc_random(t, 8 + 3 * (uint32_t)seed, seed) == 0);
		sc_frame(bc_tree_lin(t), &cam);
		REQUIRE(bc_frame_init(&f, 24, 24) == 0);
		REQUIRE(bc_render_once(BC_BACKEND_NAIVE, NULL, t, &cam, &f,
		                       NULL, &ei) == 0);
		for (uint32_t i = 0; i < 24 * 24; i++) {
			hit += f.ids[i] != 0;
		}
		bc_frame_finish(&f);
		if (hit < 24 * 24 / 8) {
			continue;
		}
		snprintf(what, sizeof(what), "random seed %u", (unsigned)seed);
		check_agree(what, t, 72, 72);
		tested++;
	}
	CHECK_EQ_INT(tested, 6);
	bc_tree_destroy(t);
}

/* Trees with unary and domain nodes (every kind, random, over every
 * operator): tiled (culling by the nodes' world ABVs, the sparse view's
 * unary instructions, steps divided by the tree's Lipschitz bound) agrees
 * with naive (the full tree). */
static void test_tiled_matches_naive_unary_nodes(void)
{
	static const char scene[] = SC_UNARY_JSON;
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	int tested = 0;
	REQUIRE(t);
	REQUIRE(bc_scene_parse_json(scene, sizeof(scene) - 1, t, NULL, &ei) ==
	        0);
	CHECK(bc_tree_lin(t)->lip > 1.0f);
	check_agree("every unary kind", t, 96, 80);
	rt_unary_rate = 0.4f;
	for (uint64_t seed = 1; seed <= 100 && tested < 6; seed++) {
		char what[32];
		struct bc_frame f = {0};
		struct bc_camera cam;
		uint32_t hit = 0;
		REQUIRE(rt_build(t, 500 + seed, 6 + (uint32_t)(seed % 10)) ==
		        0);
		if (bc_tree_lin(t)->nunary == 0) {
			continue;
		}
		sc_frame(bc_tree_lin(t), &cam);
		REQUIRE(bc_frame_init(&f, 24, 24) == 0);
		REQUIRE(bc_render_once(BC_BACKEND_NAIVE, NULL, t, &cam, &f,
		                       NULL, &ei) == 0);
		for (uint32_t i = 0; i < 24 * 24; i++) {
			hit += f.ids[i] != 0;
		}
		bc_frame_finish(&f);
		if (hit < 24 * 24 / 8) {
			continue;
		}
		snprintf(what, sizeof(what), "unary random %u", (unsigned)seed);
		check_agree(what, t, 48, 48);
		tested++;
	}
	rt_unary_rate = 0.0f;
	CHECK_EQ_INT(tested, 6);
	bc_tree_destroy(t);
}

/* offset and scale of a sphere are spheres: analytic depth at the centre
 * pixel, from both CPU tracers. */
static void test_depth_through_offset_and_scale_is_analytic(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_unary off, sc;
	struct bc_camera cam;
	REQUIRE(t);
	bc_unary_init(&off, BC_OP_OFFSET);
	off.u[0] = 0.25f;
	bc_unary_init(&sc, BC_OP_SCALE);
	sc.u[0] = 1.5f;
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 0.5f;
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_unary(t, 0, &off, NULL) == 0);
	REQUIRE(bc_tree_push_unary(t, 0, &sc, NULL) == 0);
	REQUIRE(bc_tree_put_prim(t, 9, &p, NULL) == 0);
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	bc_camera_default(&cam);
	for (int b = BC_BACKEND_NAIVE; b <= BC_BACKEND_TILED; b++) {
		struct bc_frame f = {0};
		struct bc_errinfo ei = {0};
		REQUIRE(bc_frame_init(&f, 33, 33) == 0);
		REQUIRE(bc_render_once((enum bc_backend)b, NULL, t, &cam, &f,
		                       NULL, &ei) == 0);
		/* Radius 1.5 * 0.5 + 0.25 = 1, seen from 6 away. */
		CHECK_NEAR(f.depth[16 * 33 + 16], 5.0, 1e-3);
		CHECK_EQ_INT(f.ids[16 * 33 + 16], 9);
		bc_frame_finish(&f);
	}
	bc_tree_destroy(t);
}

/* 300 spheres around one spot: every tile near the centre lists more than
 * M_overlap primitives entering at nearly the same depth, so the range
 * walk must degrade rather than fail or drop primitives. */
static void test_over_m_overlap_degrades_exactly(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data op = sc_op(true, 0.05f);
	REQUIRE(t);
	uint64_t x = 99;
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 0, &op, NULL) == 0);
	for (int i = 0; i < 300; i++) {
		struct bc_prim_data p;
		float u[4];
		for (int k = 0; k < 4; k++) {
			/* xorshift: uniform in [0, 1) */
			x ^= x << 13;
			x ^= x >> 7;
			x ^= x << 17;
			u[k] = (float)(x >> 40) / 16777216.0f;
		}
		sc_sphere(&p, 0.2f * u[0] - 0.1f, 0.2f * u[1] - 0.1f,
		          0.2f * u[2] - 0.1f, 0.5f + 0.3f * u[3]);
		REQUIRE(bc_tree_put_prim(t, 0, &p, NULL) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	check_agree("300 overlapping", t, 48, 48);
	bc_tree_destroy(t);
}

/* A unit sphere at the origin seen from (0, 0, 6): every hit pixel's depth
 * equals the analytic ray-sphere intersection. */
static void test_depth_of_sphere_is_analytic(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_camera cam;
	struct bc_view_rays vr;
	const uint32_t w = 101, h = 101;
	float foot;
	REQUIRE(t);
	bc_tree_begin(t);
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 1.0f;
	REQUIRE(bc_tree_put_prim(t, 77, &p, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	bc_camera_default(&cam);
	bc_view_rays_init(&vr, &cam, w, h);
	foot = 5.0f * 2.0f * vr.tan_half_y / (float)h;
	for (int b = BC_BACKEND_NAIVE; b <= BC_BACKEND_TILED; b++) {
		struct bc_frame f = {0};
		struct bc_errinfo ei = {0};
		uint32_t hits = 0, bad = 0;
		REQUIRE(bc_frame_init(&f, w, h) == 0);
		REQUIRE(bc_render_once((enum bc_backend)b, NULL, t, &cam, &f,
		                       NULL, &ei) == 0);
		/* The centre pixel looks straight at the sphere. */
		CHECK_NEAR(f.depth[(h / 2) * w + w / 2], 5.0, 1e-3);
		CHECK_EQ_INT(f.ids[(h / 2) * w + w / 2], 77);
		for (uint32_t y = 0; y < h; y++) {
			for (uint32_t x = 0; x < w; x++) {
				float d[3], bq, disc, miss, expect;
				size_t i = (size_t)y * w + x;
				bc_view_rays_dir(&vr, (float)x + 0.5f,
				                 (float)y + 0.5f, d);
				bq = cam.eye[0] * d[0] + cam.eye[1] * d[1] +
				     cam.eye[2] * d[2];
				disc = bq * bq - 35.0f;
				/* How far the ray passes from the sphere,
				 * relative to a pixel's footprint there. */
				miss = (sqrtf(36.0f - bq * bq) - 1.0f) / foot;
				if (miss > 1.0f) {
					bad += isfinite(f.depth[i]);
					continue;
				}
				if (miss > -2.0f) {
					/* The silhouette: a ray within the hit
					 * epsilon may or may not count. */
					continue;
				}
				expect = -bq - sqrtf(disc);
				hits++;
				if (!(fabsf(f.depth[i] - expect) < 1e-3f)) {
					bad++;
				}
			}
		}
		if (bad) {
			fprintf(stderr, "  %s: %u of %u pixels off\n",
			        bc_backend_name((enum bc_backend)b), bad, hits);
		}
		CHECK(hits > 1000);
		CHECK_EQ_INT(bad, 0);
		bc_frame_finish(&f);
	}
	bc_tree_destroy(t);
}

static void test_centre_ray_points_at_target(void)
{
	struct bc_camera cam = {
	    .eye = {1.0f, 2.0f, 3.0f},
	    .target = {-2.0f, 0.5f, -1.0f},
	    .up = {0.0f, 1.0f, 0.0f},
	    .fov_y_deg = 50.0f,
	};
	struct bc_view_rays vr;
	float d[3], f[3], n = 0.0f;
	for (int i = 0; i < 3; i++) {
		f[i] = cam.target[i] - cam.eye[i];
		n += f[i] * f[i];
	}
	n = sqrtf(n);
	/* 101 x 61: the middle pixel (50, 30) has its centre at (50.5, 30.5).
	 */
	bc_view_rays_init(&vr, &cam, 101, 61);
	bc_view_rays_dir(&vr, 50.5f, 30.5f, d);
	CHECK_NEAR(d[0], f[0] / n, 1e-5);
	CHECK_NEAR(d[1], f[1] / n, 1e-5);
	CHECK_NEAR(d[2], f[2] / n, 1e-5);
	/* The top row looks up (positive along the camera's up). */
	bc_view_rays_dir(&vr, 50.5f, 0.5f, d);
	CHECK(d[0] * vr.up[0] + d[1] * vr.up[1] + d[2] * vr.up[2] > 0.0f);
}

static bool frames_equal(const struct bc_frame *a, const struct bc_frame *b)
{
	size_t n = (size_t)a->width * a->height;
	return memcmp(a->rgba, b->rgba, 4 * n) == 0 &&
	       memcmp(a->depth, b->depth, n * sizeof(float)) == 0 &&
	       memcmp(a->ids, b->ids, n * sizeof(uint32_t)) == 0;
}

static void test_threads_do_not_change_pixels(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame a = {0}, b = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	REQUIRE(t && sc_fig18(t, 64, false, true, 5) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&a, 77, 45) == 0 &&
	        bc_frame_init(&b, 77, 45) == 0);
	/* 3 and 7 threads split the 60 tiles unevenly; 64 threads are more
	 * than the tiles (empty shares). */
	static const uint32_t counts[] = {3, 7, 64};
	for (int be = BC_BACKEND_NAIVE; be <= BC_BACKEND_TILED; be++) {
		for (size_t c = 0; c < sizeof(counts) / sizeof(counts[0]);
		     c++) {
			struct bc_render_opts one = {.threads = 1},
			                      many = {.threads = counts[c]};
			struct bc_render_stats sa, sb;
			CHECK(bc_render_once((enum bc_backend)be, &one, t, &cam,
			                     &a, &sa, &ei) == 0);
			CHECK(bc_render_once((enum bc_backend)be, &many, t,
			                     &cam, &b, &sb, &ei) == 0);
			CHECK(frames_equal(&a, &b));
			/* Each thread counts its own rays: the sums agree,
			 * so no tile was drawn twice or left out. */
			CHECK(sa.rays == 77u * 45u && sb.rays == sa.rays);
			CHECK(be == BC_BACKEND_NAIVE || sb.tiles == sa.tiles);
		}
	}
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_tree_destroy(t);
}

/* A scene of more primitives than VISIT_SHARED_PRIMS (tiled.c): the pass
 * over every primitive's rectangle that counts and writes the tiles'
 * candidates runs in shares of the primitives, one per thread, and the
 * frame must be the one thread's, bit for bit: whole, and in bands of
 * rows under a small A-buffer limit (counted in shares, filled band by
 * band in one pass); 3 and 7 shares split the primitives unevenly, 64
 * give each about 300. Then drags of single spheres, patched into the
 * kept candidates, draw what a fresh one-thread render does. */
static void test_threads_do_not_change_a_big_scenes_lists(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = NULL;
	struct bc_frame a = {0}, b = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	static const uint32_t counts[] = {2, 3, 7, 64};
	static const uint32_t limits[] = {0, 20000};
	REQUIRE(t && sc_fig18(t, 20000, false, true, 11) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&a, 203, 150) == 0 &&
	        bc_frame_init(&b, 203, 150) == 0);
	for (size_t l = 0; l < sizeof(limits) / sizeof(limits[0]); l++) {
		struct bc_render_opts one = {.threads = 1,
		                             .abuffer_limit = limits[l]};
		struct bc_render_stats sa, sb;
		REQUIRE(bc_render_once(BC_BACKEND_TILED, &one, t, &cam, &a, &sa,
		                       &ei) == 0);
		CHECK(limits[l] == 0 ? sa.bands == 1 : sa.bands > 2);
		for (size_t c = 0; c < sizeof(counts) / sizeof(counts[0]);
		     c++) {
			struct bc_render_opts many = one;
			many.threads = counts[c];
			CHECK(bc_render_once(BC_BACKEND_TILED, &many, t, &cam,
			                     &b, &sb, &ei) == 0);
			CHECK(frames_equal(&a, &b));
			CHECK(sb.tiles == sa.tiles && sb.bands == sa.bands);
		}
	}
	/* A drag after a shared build: the patch merges the tiles' kept
	 * candidates, which must be increasing as one pass leaves them. */
	REQUIRE(bc_renderer_create(&r, BC_BACKEND_TILED,
	                           &(struct bc_render_opts){.threads = 2},
	                           &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0 &&
	        bc_renderer_render(r, &cam, &b, NULL, &ei) == 0);
	for (uint32_t k = 0; k < 20000; k += 4999) {
		uint32_t id = bc_tree_child(t, bc_tree_root(t), k);
		struct bc_prim_data p;
		struct bc_dirty dirty;
		REQUIRE(bc_tree_get(t, id, &p, NULL));
		p.translate[0] += 0.02f * bc_tree_lin(t)->size;
		REQUIRE(bc_tree_set_prim(t, id, &p, &ei) == 0);
		bc_tree_take_dirty(t, &dirty);
		REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) == 0 &&
		        bc_renderer_render(r, &cam, &b, NULL, &ei) == 0);
		REQUIRE(bc_render_once(BC_BACKEND_TILED,
		                       &(struct bc_render_opts){.threads = 1},
		                       t, &cam, &a, NULL, &ei) == 0);
		CHECK(frames_equal(&a, &b));
	}
	bc_renderer_destroy(r);
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_tree_destroy(t);
}

/* A renderer gives back what it kept for a view of many more pairs (the
 * same camera on a frame 16 times the size, each sphere covering many
 * more tiles) when it draws a view of fewer: after it, it keeps less than
 * twice what a fresh renderer keeps for the view, and draws what that
 * one draws. (The eye inside the cloud made such a view once, each
 * sphere that straddles the eye plane a candidate of every tile; the
 * whole-tile cone test keeps those to the tiles they can be seen in.) */
static void test_a_narrower_view_gives_room_back(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = NULL, *fresh = NULL;
	struct bc_render_opts ro = {.threads = 2};
	struct bc_frame a = {0}, b = {0}, big = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	size_t out0, in, out1, out_fresh;
	REQUIRE(t && sc_fig18(t, 4096, false, true, 12) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&a, 320, 240) == 0 &&
	        bc_frame_init(&b, 320, 240) == 0 &&
	        bc_frame_init(&big, 1280, 960) == 0);
	REQUIRE(bc_renderer_create(&r, BC_BACKEND_TILED, &ro, &ei) == 0 &&
	        bc_renderer_create(&fresh, BC_BACKEND_TILED, &ro, &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0 &&
	        bc_renderer_sync(fresh, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &a, NULL, &ei) == 0);
	out0 = bc_renderer_kept_bytes(r);
	REQUIRE(bc_renderer_render(r, &cam, &big, NULL, &ei) == 0);
	in = bc_renderer_kept_bytes(r);
	REQUIRE(bc_renderer_render(r, &cam, &a, NULL, &ei) == 0);
	out1 = bc_renderer_kept_bytes(r);
	REQUIRE(bc_renderer_render(fresh, &cam, &b, NULL, &ei) == 0);
	out_fresh = bc_renderer_kept_bytes(fresh);
	fprintf(stderr, "  kept: %zu, big %zu, back %zu, fresh %zu\n", out0, in,
	        out1, out_fresh);
	CHECK(in > 4 * out_fresh);
	CHECK(out1 < 2 * out_fresh);
	CHECK(frames_equal(&a, &b));
	bc_renderer_destroy(r);
	bc_renderer_destroy(fresh);
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_frame_finish(&big);
	bc_tree_destroy(t);
}

/* A new view's candidates are the pairs of tile and rectangle that pass
 * the tile's cone test: with the eye among a cloud of spheres, those
 * near its plane cover many tiles' rectangles and few tiles' cones (here
 * the pairs are more than twice the candidates' room). Such a view whose
 * pairs pass the A-buffer's limit but whose candidates (and their
 * slack, a quarter and 4 a tile) fit is drawn at once, not in bands
 * (surely_over estimates the share of pairs that pass), and a limit
 * below its candidates bands it; the pixels are the same every way. */
static void test_a_view_whose_candidates_fit_is_not_banded(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame a = {0}, b = {0};
	struct bc_camera cam, inside;
	struct bc_render_stats st = {0};
	struct bc_errinfo ei = {0};
	const uint64_t ntiles = (320 / 8) * (240 / 8);
	uint64_t pairs, cands, room;
	REQUIRE(t && sc_fig18(t, 4096, false, true, 12) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	inside = cam;
	for (int i = 0; i < 3; i++) {
		inside.eye[i] =
		    cam.target[i] + 0.3f * (cam.eye[i] - cam.target[i]);
	}
	REQUIRE(bc_frame_init(&a, 320, 240) == 0 &&
	        bc_frame_init(&b, 320, 240) == 0);
	REQUIRE(bc_render_once(BC_BACKEND_TILED,
	                       &(struct bc_render_opts){.threads = 2}, t,
	                       &inside, &a, &st, &ei) == 0);
	pairs = st.ab_pairs;
	cands = st.ab_candidates;
	room = cands + cands / 4u + 4u * ntiles;
	fprintf(stderr, "  pairs %llu, candidates %llu, room %llu\n",
	        (unsigned long long)pairs, (unsigned long long)cands,
	        (unsigned long long)room);
	CHECK(st.bands == 1);
	/* The view this test needs: its pairs pass twice the room its
	 * candidates take. */
	REQUIRE(cands > 0 && pairs + 4u * ntiles > 2u * room);
	REQUIRE(
	    bc_render_once(BC_BACKEND_TILED,
	                   &(struct bc_render_opts){
	                       .threads = 2, .abuffer_limit = (uint32_t)room},
	                   t, &inside, &b, &st, &ei) == 0);
	CHECK(st.bands == 1);
	CHECK(st.ab_candidates == cands);
	CHECK(frames_equal(&a, &b));
	REQUIRE(bc_render_once(BC_BACKEND_TILED,
	                       &(struct bc_render_opts){
	                           .threads = 2,
	                           .abuffer_limit = (uint32_t)(room * 3 / 4)},
	                       t, &inside, &b, &st, &ei) == 0);
	CHECK(st.bands > 1);
	CHECK(frames_equal(&a, &b));
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_tree_destroy(t);
}

/* One renderer, several frames and an edit in between: buffers kept from
 * the previous frame must not leak into the next. */
struct pool_count {
	atomic_uint ran[8];
};

static void count_share(void *ctx, uint32_t i)
{
	struct pool_count *c = ctx;
	atomic_fetch_add(&c->ran[i], 1u);
}

/* Every share of every pool run runs once, and a run returns only when
 * all are done: runs of 1 to 5 shares back to back (the workers poll
 * between runs) and after pauses longer than they poll (they sleep). */
static void test_pool_runs_every_share_once(void)
{
	for (uint32_t round = 0; round < 400; round++) {
		uint32_t n = 1 + round % 5;
		struct pool_count c;
		for (uint32_t i = 0; i < 8; i++) {
			atomic_init(&c.ran[i], 0u);
		}
		if (round % 40 == 39) {
			struct timespec pause = {0, 2000000};
			nanosleep(&pause, NULL);
		}
		bc_pool_run(n, count_share, &c);
		for (uint32_t i = 0; i < 8; i++) {
			CHECK(atomic_load(&c.ran[i]) == (i < n ? 1u : 0u));
		}
	}
}

/* Progress reports (bc_renderer_set_progress, paced by render_common's
 * bc_render_progress): none in a call's first second, then at most one a
 * quarter of a second, done clamped to total; a renderer without a
 * callback reports nothing. The clock is moved by hand (start and last
 * set back), so no timing of this machine enters. */
struct progress_log {
	uint32_t calls, done, total;
};

static void log_progress(void *user, uint32_t done, uint32_t total)
{
	struct progress_log *g = user;
	g->calls++;
	g->done = done;
	g->total = total;
}

static void test_progress_is_paced(void)
{
	struct bc_render_opts o = {0};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	struct bc_render_progress p;
	struct progress_log g = {0};
	REQUIRE(bc_renderer_create(&r, BC_BACKEND_NAIVE, &o, &ei) == 0);
	bc_render_progress_init(&p, r, 10);
	bc_render_progress_tick(&p, 3);
	CHECK_EQ_INT(g.calls, 0); /* no callback */
	bc_renderer_set_progress(r, log_progress, &g);
	bc_render_progress_init(&p, r, 10);
	bc_render_progress_tick(&p, 3);
	CHECK_EQ_INT(g.calls, 0); /* the first second */
	p.start -= 1500.0;
	p.last = p.start;
	bc_render_progress_tick(&p, 4);
	CHECK_EQ_INT(g.calls, 1);
	CHECK_EQ_INT(g.done, 4);
	CHECK_EQ_INT(g.total, 10);
	bc_render_progress_tick(&p, 5);
	CHECK_EQ_INT(g.calls, 1); /* a quarter of a second apart */
	p.last -= 300.0;
	bc_render_progress_tick(&p, 12);
	CHECK_EQ_INT(g.calls, 2);
	CHECK_EQ_INT(g.done, 10); /* clamped */
	bc_renderer_set_progress(r, NULL, NULL);
	bc_render_progress_init(&p, r, 10);
	p.start -= 1500.0;
	p.last = p.start;
	bc_render_progress_tick(&p, 4);
	CHECK_EQ_INT(g.calls, 2);                         /* removed */
	bc_renderer_set_progress(NULL, log_progress, &g); /* accepted */
	bc_renderer_destroy(r);
}

static void test_renderer_reuse_follows_edits(void)
{
	struct bc_renderer *r = NULL;
	struct bc_tree *t = bc_tree_create();
	struct bc_frame a = {0}, b = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_prim_data p;
	uint32_t id;
	REQUIRE(t && sc_fig18(t, 16, false, false, 3) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&a, 40, 40) == 0 &&
	        bc_frame_init(&b, 64, 48) == 0);
	REQUIRE(bc_renderer_create(&r, BC_BACKEND_TILED,
	                           &(struct bc_render_opts){0}, &ei) == 0);
	CHECK(bc_renderer_render(r, &cam, &a, NULL, &ei) == BC_ESTATE);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	CHECK(bc_renderer_render(r, &cam, &b, NULL, &ei) == 0);
	CHECK(bc_renderer_render(r, &cam, &a, NULL, &ei) == 0);
	/* Move one sphere far out of view: its ids must disappear. */
	id = bc_tree_child(t, bc_tree_root(t), 0);
	REQUIRE(bc_tree_get(t, id, &p, NULL));
	p.translate[0] += 100.0f;
	REQUIRE(bc_tree_set_prim(t, id, &p, &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	CHECK(bc_renderer_render(r, &cam, &b, NULL, &ei) == 0);
	{
		struct bc_frame fresh = {0};
		bool gone = true;
		REQUIRE(bc_frame_init(&fresh, 64, 48) == 0);
		CHECK(bc_render_once(BC_BACKEND_TILED, NULL, t, &cam, &fresh,
		                     NULL, &ei) == 0);
		CHECK(frames_equal(&b, &fresh));
		for (size_t i = 0; i < 64u * 48u; i++) {
			gone = gone && b.ids[i] != id;
		}
		CHECK(gone);
		bc_frame_finish(&fresh);
	}
	bc_renderer_destroy(r);
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_tree_destroy(t);
}

static void test_debug_modes(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame plain = {0}, ev = {0}, ov = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_render_stats st;
	size_t n = 64 * 64, changed = 0, distinct_tiles = 0;
	REQUIRE(t && sc_fig18(t, 64, true, true, 8) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&plain, 64, 64) == 0 &&
	        bc_frame_init(&ev, 64, 64) == 0 &&
	        bc_frame_init(&ov, 64, 64) == 0);
	CHECK(bc_render_once(BC_BACKEND_TILED, NULL, t, &cam, &plain, NULL,
	                     &ei) == 0);
	CHECK(bc_render_once(BC_BACKEND_TILED,
	                     &(struct bc_render_opts){.debug = BC_DEBUG_EVALS},
	                     t, &cam, &ev, NULL, &ei) == 0);
	CHECK(
	    bc_render_once(BC_BACKEND_TILED,
	                   &(struct bc_render_opts){.debug = BC_DEBUG_OVERLAPS},
	                   t, &cam, &ov, &st, &ei) == 0);
	/* Debug modes change colours only. */
	CHECK_MEMEQ(plain.depth, ev.depth, n * sizeof(float));
	CHECK_MEMEQ(plain.ids, ov.ids, n * sizeof(uint32_t));
	for (size_t i = 0; i < n; i++) {
		changed += memcmp(plain.rgba + 4 * i, ev.rgba + 4 * i, 3) != 0;
	}
	CHECK(changed > n / 2);
	/* Overlaps are per tile: every pixel of a tile has its colour, and
	 * tiles differ. */
	for (uint32_t ty = 0; ty < 8; ty++) {
		for (uint32_t tx = 0; tx < 8; tx++) {
			const uint8_t *c0 =
			    ov.rgba + 4 * (ty * 8 * 64 + tx * 8);
			for (uint32_t y = 0; y < 8; y++) {
				for (uint32_t x = 0; x < 8; x++) {
					const uint8_t *c =
					    ov.rgba + 4 * ((ty * 8 + y) * 64 +
					                   tx * 8 + x);
					CHECK_MEMEQ(c, c0, 4);
				}
			}
			distinct_tiles += memcmp(c0, ov.rgba, 4) != 0;
		}
	}
	CHECK(distinct_tiles > 4);
	CHECK(st.max_overlap > 1);
	bc_frame_finish(&plain);
	bc_frame_finish(&ev);
	bc_frame_finish(&ov);
	bc_tree_destroy(t);
}

static void test_dispatcher_and_frames(void)
{
	struct bc_frame f = {0};
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (int b = BC_BACKEND_INVALID + 1; b < BC_BACKEND_COUNT; b++) {
		CHECK_EQ_INT(
		    bc_backend_from_name(bc_backend_name((enum bc_backend)b)),
		    b);
	}
	CHECK_EQ_INT(bc_backend_from_name("cpu"), BC_BACKEND_INVALID);
	CHECK_EQ_INT(bc_backend_from_name(NULL), BC_BACKEND_INVALID);
	CHECK_STREQ(bc_backend_name(BC_BACKEND_COUNT), "invalid");
	CHECK(!bc_backend_available(BC_BACKEND_INVALID));
	CHECK(bc_backend_available(BC_BACKEND_NAIVE));
	CHECK(bc_backend_available(BC_BACKEND_TILED));
	CHECK_STREQ(bc_backend_name(BC_BACKEND_TILED), "tiled");
	CHECK_EQ_INT(bc_frame_init(&f, 0, 10), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_init(&f, 10, BC_RENDER_MAX_DIM + 1), BC_ERANGE);
	CHECK(f.rgba == NULL);
	bc_frame_finish(&f);
	bc_frame_finish(NULL);
	REQUIRE(bc_frame_init(&f, 16, 16) == 0);
	bc_camera_default(&cam);
	CHECK_EQ_INT(
	    bc_render_once(BC_BACKEND_INVALID, NULL, t, &cam, &f, NULL, &ei),
	    BC_ENOTSUP);
	/* A bad camera is refused with a reason. */
	memcpy(cam.target, cam.eye, sizeof(cam.eye));
	REQUIRE(sc_comb(t, 4, false) == 0);
	CHECK_EQ_INT(
	    bc_render_once(BC_BACKEND_TILED, NULL, t, &cam, &f, NULL, &ei),
	    BC_ERANGE);
	CHECK(ei.msg[0] != '\0');
	/* An empty tree renders background. */
	bc_camera_default(&cam);
	bc_tree_begin(t);
	for (int b = BC_BACKEND_NAIVE; b <= BC_BACKEND_TILED; b++) {
		CHECK_EQ_INT(bc_render_once((enum bc_backend)b, NULL, t, &cam,
		                            &f, NULL, &ei),
		             0);
		CHECK(isinf(f.depth[0]) && f.ids[255] == 0);
	}
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* Every allocation of a tiled frame fails in turn: the render reports
 * BC_ENOMEM and frees what it took (ASan's leak check sees the rest). */
static void test_tiled_allocation_failures(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame f = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	unsigned long n;
	int rc = -1;
	REQUIRE(t && sc_fig18(t, 16, false, true, 4) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&f, 24, 24) == 0);
	for (n = 1; n < 200 && rc != 0; n++) {
		bc_alloc_fail_after(n);
		rc = bc_render_once(BC_BACKEND_TILED,
		                    &(struct bc_render_opts){.threads = 2}, t,
		                    &cam, &f, NULL, &ei);
		bc_alloc_fail_after(0);
		CHECK(rc == 0 || rc == BC_ENOMEM);
	}
	CHECK_EQ_INT(rc, 0);
	CHECK(n > 3);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* The sRGB transfer function rounded to a byte, written out here as the
 * oracle of the shader's table. */
static uint8_t srgb8_oracle(float c)
{
	float s;
	if (!(c > 0.0f)) {
		return 0;
	}
	if (c >= 1.0f) {
		return 255;
	}
	s = c <= 0.0031308f ? 12.92f * c
	                    : 1.055f * powf(c, 1.0f / 2.4f) - 0.055f;
	return (uint8_t)(s * 255.0f + 0.5f);
}

static float float_bits(uint32_t b)
{
	float f;
	memcpy(&f, &b, sizeof(f));
	return f;
}

/* bc_shade_srgb8 is a table: it must give the formula's byte for every
 * float. A sweep over [0, 1] in steps of 61 bit patterns, and wherever the
 * byte changes between two samples, the exact float where it changes
 * (bisection) and its neighbours; every byte value must be met. */
static void test_srgb_table_matches_formula(void)
{
	static const float odd[] = {-1.0f, -0.0f,     0.0f,     1.0f,  1.5f,
	                            1e30f, -INFINITY, INFINITY, 1e-45f};
	uint32_t one, prev_b = 0, mismatches = 0, edges = 0;
	uint8_t prev = 0;
	bool seen[256] = {false};
	memcpy(&one, &(float){1.0f}, sizeof(one));
	for (size_t i = 0; i < sizeof(odd) / sizeof(odd[0]); i++) {
		CHECK_EQ_INT(bc_shade_srgb8(odd[i]), srgb8_oracle(odd[i]));
	}
	CHECK_EQ_INT(bc_shade_srgb8(NAN), 0);
	for (uint32_t b = 0;; b = b + 61u < one ? b + 61u : one) {
		float c = float_bits(b);
		uint8_t want = srgb8_oracle(c);
		mismatches += bc_shade_srgb8(c) != want;
		seen[want] = true;
		if (want != prev) {
			/* The first float of the new byte in (prev_b, b]. */
			uint32_t lo = prev_b + 1u, hi = b;
			while (lo < hi) {
				uint32_t mid = lo + (hi - lo) / 2u;
				if (srgb8_oracle(float_bits(mid)) == want) {
					hi = mid;
				} else {
					lo = mid + 1u;
				}
			}
			for (uint32_t e = lo - 1u; e <= lo + 1u; e++) {
				float f = float_bits(e);
				mismatches +=
				    bc_shade_srgb8(f) != srgb8_oracle(f);
			}
			edges++;
		}
		prev = want;
		prev_b = b;
		if (b == one) {
			break;
		}
	}
	CHECK_EQ_INT(mismatches, 0);
	CHECK_EQ_INT(edges, 255);
	for (int k = 0; k < 256; k++) {
		CHECK(seen[k]);
	}
}

static const struct bc_test tests[] = {
    {"srgb_table_matches_formula", test_srgb_table_matches_formula},
    {"tiled_matches_naive_unary_nodes", test_tiled_matches_naive_unary_nodes},
    {"depth_through_offset_and_scale_is_analytic",
     test_depth_through_offset_and_scale_is_analytic},
    {"tiled_matches_naive_fig16", test_tiled_matches_naive_fig16},
    {"tiled_matches_naive_fig18", test_tiled_matches_naive_fig18},
    {"tiled_matches_naive_comb_and_random",
     test_tiled_matches_naive_comb_and_random},
    {"over_m_overlap_degrades_exactly", test_over_m_overlap_degrades_exactly},
    {"depth_of_sphere_is_analytic", test_depth_of_sphere_is_analytic},
    {"centre_ray_points_at_target", test_centre_ray_points_at_target},
    {"threads_do_not_change_pixels", test_threads_do_not_change_pixels},
    {"threads_do_not_change_a_big_scenes_lists",
     test_threads_do_not_change_a_big_scenes_lists},
    {"a_narrower_view_gives_room_back", test_a_narrower_view_gives_room_back},
    {"a_view_whose_candidates_fit_is_not_banded",
     test_a_view_whose_candidates_fit_is_not_banded},
    {"pool_runs_every_share_once", test_pool_runs_every_share_once},
    {"progress_is_paced", test_progress_is_paced},
    {"renderer_reuse_follows_edits", test_renderer_reuse_follows_edits},
    {"debug_modes", test_debug_modes},
    {"dispatcher_and_frames", test_dispatcher_and_frames},
    {"tiled_allocation_failures", test_tiled_allocation_failures},
};

BC_TEST_MAIN(tests)
