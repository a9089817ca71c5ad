/*
 * The tiled backend's packet tracer (opts.simd) against its scalar one
 * (BC_SIMD_OFF), for every width this CPU runs (auto, AVX2, AVX-512; a
 * width the CPU lacks falls back to scalar and compares trivially). On the
 * generator families (Fig. 16 aggregates, Fig. 18 spheres, boxes and
 * lenses, sharp and smooth, a comb, random trees with every primitive and
 * operator kind) the two must agree within the tolerances the tiled-vs-naive
 * tests use (test_render.c): hit masks equal on all but 0.5 % of pixels,
 * median depth difference under 1e-3 of the scene size, the same ids on at
 * least 90 % of the pixels both hit. With packets, a pixel's value must
 * still not depend on which other pixels are traced: regions of tiles and
 * the refinement levels reassemble the whole render bit for bit, and the
 * thread count changes nothing.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "test.h"

#include "../../render/cpu/abuffer.h"
#include "../../render/cpu/packet.h"
#include "blobtree/randtree.h"
#include "compare.h"
#include "scenes.h"

static const struct {
	enum bc_simd simd;
	const char *name;
} modes[] = {
    {BC_SIMD_AUTO, "auto"},
    {BC_SIMD_AVX2, "avx2"},
    {BC_SIMD_AVX512, "avx512"},
};
#define NMODES (sizeof(modes) / sizeof(modes[0]))

static int render(struct bc_tree *t, enum bc_simd simd, uint32_t threads,
                  const struct bc_camera *cam, struct bc_frame *f)
{
	struct bc_render_opts o = {.simd = simd, .threads = threads};
	struct bc_errinfo ei = {0};
	return bc_render_once(BC_BACKEND_TILED, &o, t, cam, f, NULL, &ei);
}

/* Whether t, framed by sc_frame, covers at least 1/cover of an n x n
 * scalar frame. */
static bool fills(struct bc_tree *t, uint32_t n, uint32_t cover)
{
	struct bc_frame f = {0};
	struct bc_camera cam;
	uint32_t hit = 0;
	sc_frame(bc_tree_lin(t), &cam);
	if (bc_frame_init(&f, n, n) || render(t, BC_SIMD_OFF, 1, &cam, &f)) {
		bc_frame_finish(&f);
		return false;
	}
	for (uint32_t i = 0; i < n * n; i++) {
		hit += f.ids[i] != 0;
	}
	bc_frame_finish(&f);
	return hit >= n * n / cover;
}

/* Renders t at w x h with simd off and with each mode; checks they agree.
 * At least 1/cover of the pixels must show the scene. *differ (unless NULL)
 * gets the pixels whose depth differs in any bit between off and auto: the
 * vector kernels round differently (fused multiply-adds), so a frame they
 * traced differs somewhere, and one they did not trace is the scalar frame
 * again. */
static void check_agree_cover(const char *what, struct bc_tree *t, uint32_t w,
                              uint32_t h, uint32_t cover, uint32_t *differ)
{
	uint32_t bits = 0;
	struct bc_frame off = {0}, on = {0};
	struct bc_camera cam;
	const struct bc_lin *l = bc_tree_lin(t);
	REQUIRE(l != NULL);
	sc_frame(l, &cam);
	REQUIRE(bc_frame_init(&off, w, h) == 0);
	REQUIRE(bc_frame_init(&on, w, h) == 0);
	CHECK_EQ_INT(render(t, BC_SIMD_OFF, 1, &cam, &off), 0);
	for (size_t m = 0; m < NMODES; m++) {
		struct cmp c;
		CHECK_EQ_INT(render(t, modes[m].simd, 1, &cam, &on), 0);
		c = compare(&off, &on);
		if (modes[m].simd == BC_SIMD_AUTO) {
			for (uint32_t i = 0; i < w * h; i++) {
				bits += memcmp(&off.depth[i], &on.depth[i],
				               sizeof(float)) != 0;
			}
		}
		printf("  %-22s %-6s prims %5u: mask %.4f%%, depth median "
		       "%.2e (size %.2f), ids %.2f%%, hit %u px\n",
		       what, modes[m].name, l->nprims, 100.0 * c.mask_frac,
		       c.depth_med, (double)l->size, 100.0 * c.id_frac, c.both);
		CHECK(c.both > w * h / cover);
		CHECK(c.mask_frac < 0.005);
		CHECK(c.depth_med < 1e-3 * (double)l->size);
		CHECK(c.id_frac > 0.90);
	}
	bc_frame_finish(&off);
	bc_frame_finish(&on);
	if (differ) {
		*differ = bits;
	}
}

static void test_simd_matches_scalar_fig18(void)
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
			check_agree_cover(what, t, 64 + 12 * (uint32_t)i,
			                  64 + 12 * (uint32_t)i, 20, NULL);
		}
	}
	/* Lenses: two spheres under an intersection each. */
	REQUIRE(sc_gen(t, "fig18",
	               (struct bc_gen_opts){.count = 64,
	                                    .seed = 3,
	                                    .kind = BC_GEN_KIND_LENSES}) == 0);
	check_agree_cover("fig18 lenses 64", t, 80, 80, 20, NULL);
	bc_tree_destroy(t);
}

static void test_simd_matches_scalar_fig16_comb_random(void)
{
	struct bc_tree *t = bc_tree_create();
	int tested = 0;
	REQUIRE(t);
	for (uint32_t level = 1; level <= 2; level++) {
		for (int smooth = 0; smooth <= 1; smooth++) {
			char what[32];
			snprintf(what, sizeof(what), "fig16 L%u %s", level,
			         smooth ? "smooth" : "sharp");
			REQUIRE(sc_fig16(t, level, smooth) == 0);
			check_agree_cover(what, t, 96 + 32 * (level - 1),
			                  80 + 32 * (level - 1), 20, NULL);
		}
	}
	REQUIRE(sc_comb(t, 24, true) == 0);
	check_agree_cover("comb 24 smooth", t, 160, 64, 40, NULL);
	/* Random trees: every primitive kind (those without a vector form
	 * go through the scalar field lane by lane) and every operator. Take
	 * the first eight that fill a fair part of the frame. */
	for (uint64_t seed = 1; seed <= 100 && tested < 8; seed++) {
		char what[32];
		REQUIRE(sc_random(t, 8 + 3 * (uint32_t)seed, seed) == 0);
		if (!fills(t, 24, 8)) {
			continue;
		}
		snprintf(what, sizeof(what), "random seed %u", (unsigned)seed);
		check_agree_cover(what, t, 72, 72, 20, NULL);
		tested++;
	}
	CHECK_EQ_INT(tested, 8);
	bc_tree_destroy(t);
}

/* 300 smooth-unioned spheres around one spot: ranges past M_overlap, so
 * the packets run views of hundreds of instructions. */
static void test_simd_matches_scalar_over_m_overlap(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data op = sc_op(true, 0.05f);
	uint64_t x = 99;
	REQUIRE(t);
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
	check_agree_cover("300 overlapping", t, 48, 48, 20, NULL);
	bc_tree_destroy(t);
}

static size_t frames_differ(const struct bc_frame *a, const struct bc_frame *b)
{
	size_t n = (size_t)a->width * a->height, bad = 0;
	for (size_t i = 0; i < n; i++) {
		bad += !pixel_equal(a, b, i);
	}
	return bad;
}

/* Whole render, then (1) the refinement levels 3, 2, 1, 0 into a fresh
 * frame and (2) a scattered subset of tiles redrawn over a scrambled copy:
 * both must equal the whole render bit for bit. */
static void check_regions(const char *what, struct bc_tree *t, uint32_t w,
                          uint32_t h, enum bc_simd simd)
{
	struct bc_renderer *r = NULL;
	struct bc_frame whole = {0}, f = {0};
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	struct bc_render_opts o = {.simd = simd, .threads = 2};
	uint32_t tx = bc_render_tiles_x(w), ty = bc_render_tiles_y(h);
	uint8_t *tiles = bc_calloc((size_t)tx * ty, 1);
	size_t n = (size_t)w * h, bad;
	REQUIRE(tiles);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&whole, w, h) == 0);
	REQUIRE(bc_frame_init(&f, w, h) == 0);
	REQUIRE(bc_renderer_create(&r, BC_BACKEND_TILED, &o, &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	CHECK_EQ_INT(bc_renderer_render(r, &cam, &whole, &st, &ei), 0);
	/* (1) Progressive refinement: level 3 traces one pixel per tile. */
	for (int level = 3; level >= 0; level--) {
		struct bc_render_region rg = {.level = (uint32_t)level,
		                              .refine = level < 3};
		CHECK_EQ_INT(
		    bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei), 0);
	}
	bad = frames_differ(&whole, &f);
	printf("  %-22s simd %d: levels 3..0 differ on %zu px\n", what,
	       (int)simd, bad);
	CHECK(bad == 0);
	/* (2) Every third tile, over a scrambled copy of the whole frame. */
	memcpy(f.rgba, whole.rgba, 4 * n);
	memcpy(f.depth, whole.depth, n * sizeof(float));
	memcpy(f.ids, whole.ids, n * sizeof(uint32_t));
	f.key = whole.key;
	for (uint32_t i = 0; i < tx * ty; i++) {
		tiles[i] = i % 3 == 1;
	}
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			size_t i = (size_t)y * w + x;
			if (tiles[(y / BC_RENDER_TILE) * tx +
			          x / BC_RENDER_TILE]) {
				memset(f.rgba + 4 * i, 0x5a, 4);
				f.depth[i] = -1.0f;
				f.ids[i] = 0xdeadbeefu;
			}
		}
	}
	{
		struct bc_render_region rg = {.tiles = tiles};
		CHECK_EQ_INT(
		    bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei), 0);
		CHECK(!st.whole);
	}
	bad = frames_differ(&whole, &f);
	printf("  %-22s simd %d: tile subset differs on %zu px\n", what,
	       (int)simd, bad);
	CHECK(bad == 0);
	bc_renderer_destroy(r);
	bc_frame_finish(&whole);
	bc_frame_finish(&f);
	bc_free(tiles);
}

static void test_region_equals_whole_with_simd(void)
{
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t m = 0; m < NMODES; m++) {
		REQUIRE(sc_fig18(t, 64, false, true, 7) == 0);
		check_regions("fig18 spheres smooth", t, 83, 61, modes[m].simd);
		REQUIRE(sc_fig18(t, 64, true, false, 8) == 0);
		check_regions("fig18 boxes sharp", t, 64, 72, modes[m].simd);
		REQUIRE(sc_random(t, 40, 5) == 0);
		check_regions("random 40", t, 57, 49, modes[m].simd);
	}
	bc_tree_destroy(t);
}

static void test_threads_do_not_change_simd_pixels(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame a = {0}, b = {0};
	struct bc_camera cam;
	REQUIRE(t && sc_fig18(t, 64, false, true, 5) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&a, 77, 45) == 0 &&
	        bc_frame_init(&b, 77, 45) == 0);
	for (size_t m = 0; m < NMODES; m++) {
		CHECK_EQ_INT(render(t, modes[m].simd, 1, &cam, &a), 0);
		CHECK_EQ_INT(render(t, modes[m].simd, 3, &cam, &b), 0);
		CHECK(frames_differ(&a, &b) == 0);
	}
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	bc_tree_destroy(t);
}

/* Trees with unary and domain nodes trace in packets too: the kernels map
 * a primitive's points through its domain nodes and apply the value maps
 * lane by lane, and divide the steps by the tree's Lipschitz bound as the
 * scalar tracer does. On a scene with every kind and on random trees with
 * them, packets agree with the scalar tracer as on the other scenes, and
 * they did trace (where the CPU has AVX2: depths differ in some bits). */
static void test_simd_matches_scalar_unary_nodes(void)
{
	static const char scene[] = SC_UNARY_JSON;
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	bool vec = false;
	uint32_t bits;
	int tested = 0;
#if defined(__x86_64__) && defined(__GNUC__)
	__builtin_cpu_init();
	vec = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#endif
	REQUIRE(t);
	REQUIRE(bc_scene_parse_json(scene, sizeof(scene) - 1, t, NULL, &ei) ==
	        0);
	CHECK(bc_tree_lin(t)->lip > 1.0f);
	check_agree_cover("every unary kind", t, 96, 80, 20, &bits);
	printf("  every unary kind: %u px differ in some bit\n", bits);
	if (vec) {
		CHECK(bits > 0);
	}
	rt_unary_rate = 0.4f;
	for (uint64_t seed = 1; seed <= 100 && tested < 6; seed++) {
		char what[32];
		REQUIRE(rt_build(t, 500 + seed, 6 + (uint32_t)(seed % 10)) ==
		        0);
		if (bc_tree_lin(t)->nunary == 0 || !fills(t, 24, 8)) {
			continue;
		}
		snprintf(what, sizeof(what), "unary random %u", (unsigned)seed);
		check_agree_cover(what, t, 48, 48, 20, NULL);
		tested++;
	}
	rt_unary_rate = 0.0f;
	CHECK_EQ_INT(tested, 6);
	bc_tree_destroy(t);
}

/* A deterministic generator for the A-buffer test's shapes and rays. */
static float ab_rand(uint64_t *state)
{
	*state = *state * 6364136223846793005ull + 1442695040888963407ull;
	return (float)(*state >> 40) / (float)(1u << 24) * 2.0f - 1.0f;
}

static void ab_unit(float v[3])
{
	float n = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
	for (int i = 0; i < 3; i++) {
		v[i] /= n;
	}
}

/* The A-buffer's vector clipping of rays against box and capsule ABVs
 * (bc_abv_ray in double precision, 8 rays at a time) gives every ray's
 * fragment bit for bit as the scalar form: random rotated boxes and
 * capsules, degenerate capsules (both ends equal), rays along a box's
 * axes and a capsule's axis (abv.c's parallel cases), eyes inside. */
static void test_abuffer_abv_kernel_matches_scalar(void)
{
	struct bc__ab_kernel scalar = bc__ab_kernel_for(BC_SIMD_OFF);
	struct bc__ab_kernel vec = bc__ab_kernel_for(BC_SIMD_AUTO);
	uint64_t state = 12345;
	uint32_t hits = 0;
	if (vec.abv == scalar.abv) {
		BC_SKIP("no vector A-buffer clipping on this CPU");
	}
	for (int n = 0; n < 400; n++) {
		struct bc_abv abv = {0};
		struct bc__ab_rays rays;
		float eye[3], c[3];
		for (int i = 0; i < 3; i++) {
			eye[i] = 4.0f * ab_rand(&state);
			c[i] = eye[i] +
			       (n % 7 == 0 ? 0.2f : 3.0f) * ab_rand(&state);
		}
		if (n % 2 == 0) {
			float a[3] = {ab_rand(&state), ab_rand(&state),
			              ab_rand(&state)};
			abv.shape = BC_ABV_BOX;
			memcpy(abv.center, c, sizeof(c));
			if (n % 4 == 0) { /* rotated: Gram-Schmidt */
				float b[3] = {ab_rand(&state), ab_rand(&state),
				              ab_rand(&state)};
				float ab;
				ab_unit(a);
				ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
				for (int i = 0; i < 3; i++) {
					b[i] -= ab * a[i];
				}
				ab_unit(b);
				memcpy(abv.axis[0], a, sizeof(a));
				memcpy(abv.axis[1], b, sizeof(b));
				abv.axis[2][0] = a[1] * b[2] - a[2] * b[1];
				abv.axis[2][1] = a[2] * b[0] - a[0] * b[2];
				abv.axis[2][2] = a[0] * b[1] - a[1] * b[0];
			} else {
				for (int i = 0; i < 3; i++) {
					abv.axis[i][i] = 1.0f;
				}
			}
			for (int i = 0; i < 3; i++) {
				abv.half[i] = 0.05f + fabsf(ab_rand(&state));
			}
		} else {
			abv.shape = BC_ABV_CAPSULE;
			memcpy(abv.center, c, sizeof(c));
			for (int i = 0; i < 3; i++) {
				abv.end[i] =
				    n % 5 == 1 ? c[i] : c[i] + ab_rand(&state);
			}
			abv.radius = 0.05f + 0.5f * fabsf(ab_rand(&state));
		}
		for (uint32_t q = 0; q < 4; q++) {
			for (uint32_t l = 0; l < BC__AB_QUARTER_RAYS; l++) {
				float d[3];
				uint32_t j = q * BC__AB_QUARTER_RAYS + l;
				if (j < 3) { /* along a box axis */
					memcpy(d, abv.axis[j], sizeof(d));
				} else if (j < 6 &&
				           abv.shape == BC_ABV_CAPSULE) {
					/* along the capsule's axis */
					for (int i = 0; i < 3; i++) {
						d[i] =
						    abv.end[i] - abv.center[i];
					}
					if (j == 4) {
						d[0] = -d[0];
						d[1] = -d[1];
						d[2] = -d[2];
					}
				} else {
					/* towards the shape, scattered */
					for (int i = 0; i < 3; i++) {
						d[i] = c[i] - eye[i] +
						       0.8f * ab_rand(&state);
					}
				}
				if (d[0] == 0.0f && d[1] == 0.0f &&
				    d[2] == 0.0f) {
					d[0] = 1.0f;
				}
				ab_unit(d);
				for (int i = 0; i < 3; i++) {
					rays.d[q][i][l] = d[i];
				}
			}
		}
		for (uint32_t j = 0; j <= 64; j++) {
			/* Each ray alone, then all of them. */
			uint64_t lanes = j < 64 ? 1ull << j : ~0ull;
			float ts[2] = {INFINITY, -INFINITY};
			float tv[2] = {INFINITY, -INFINITY};
			scalar.abv(&rays, lanes, &abv, eye, ts);
			vec.abv(&rays, lanes, &abv, eye, tv);
			CHECK(memcmp(ts, tv, sizeof(ts)) == 0);
			hits += j < 64 && ts[1] >= ts[0];
		}
	}
	/* The shapes were met, not only missed. */
	CHECK(hits > 4000);
}

/* ---- The kernel's own steps against the state machine ------------------ */

/* Lane kinds of test_kernel_steps_match_state_machine: a ray waiting for
 * its first value, at a relaxed marching step, at a plain one after a
 * failed relaxed step, at a bisection's midpoint, at a secant probe, at a
 * golden-section sample. */
enum { K_START, K_STEP, K_STEP2, K_BISECT, K_REFINE, K_GOLD, K_KINDS };

/* The unit sphere's field at t along d from (0, 0, -5). */
static float sphere_at(const float d[3], float t)
{
	float x = t * d[0], y = t * d[1], z = -5.0f + t * d[2];
	return sqrtf(x * x + y * y + z * z) - 1.0f;
}

/* A refining ray r made to search its closest approach: a probe that did
 * not come closer starts the golden section (S_GOLD_C0), and zero to
 * three of its samples, the sphere's field there, take it on; some
 * searches are put at their last round. */
static bool steer_gold(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                       const float d[3], uint64_t *state)
{
	int more = (int)(fabsf(ab_rand(state)) * 4.0f);
	if (bc__pk_ray_feed(r, fc, r->v * (1.0f + fabsf(ab_rand(state)))) ||
	    r->state != BC__PK_GOLD_C0) {
		return false;
	}
	for (int j = 0; j < more; j++) {
		if (bc__pk_ray_feed(r, fc,
		                    sphere_at(d, r->q) / BC_CPU_LIPSCHITZ) ||
		    r->state < BC__PK_GOLD_C0) {
			return false;
		}
	}
	if (r->state >= BC__PK_GOLD_C && ab_rand(state) > 0.3f) {
		r->i = 5; /* the next value ends the search */
	}
	return true;
}

/* Ray i of the kernel steps test, made by feeding the state machine the
 * values it asks for (the field of the one-sphere tree, or made up to
 * steer it); false when it did not reach kind's state. */
static bool steer_ray(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                      int kind, float ts, const float d[3], uint64_t *state)
{
	float t0 = ts - 1.5f * fabsf(ab_rand(state)), t1;
	if (t0 < 0.0f || ab_rand(state) > 0.8f) {
		t0 = ts + 0.05f * ab_rand(state); /* at the surface */
	}
	t1 = ab_rand(state) > 0.9f ? t0 : t0 + 3.0f * fabsf(ab_rand(state));
	if (bc__pk_ray_start(r, fc, t0, t1)) {
		return false;
	}
	if (kind == K_START) {
		return true;
	}
	if (kind == K_REFINE || kind == K_GOLD) {
		/* A relaxed step past the surface, the plain one just before
		 * it, and there the field's value, within the hit epsilon. */
		float u = 0.02f * fabsf(ab_rand(state));
		if (ts - t0 - u <= 0.0f ||
		    bc__pk_ray_feed(r, fc, ts - t0 - u) ||
		    r->state != BC__PK_STEP ||
		    bc__pk_ray_feed(r, fc, 1e-3f * r->v) ||
		    r->state != BC__PK_STEP2 ||
		    bc__pk_ray_feed(r, fc,
		                    sphere_at(d, r->tn) / BC_CPU_LIPSCHITZ) ||
		    r->state != BC__PK_REFINE) {
			return false;
		}
		if (kind == K_GOLD) {
			return steer_gold(r, fc, d, state);
		}
		if (ab_rand(state) > 0.6f) {
			r->i = 7; /* the last round */
		}
		return true;
	}
	/* A positive first value that steps past the surface. */
	if (bc__pk_ray_feed(r, fc,
	                    (ts - t0 + 0.2f * fabsf(ab_rand(state))) / 1.7f) ||
	    r->state != BC__PK_STEP) {
		return false;
	}
	if (kind == K_STEP) {
		return true;
	}
	if (kind == K_STEP2) {
		/* Too small for the relaxed step taken. */
		return !bc__pk_ray_feed(r, fc, 0.01f * r->v) &&
		       r->state == BC__PK_STEP2;
	}
	if (bc__pk_ray_feed(r, fc, -0.5f * fabsf(ab_rand(state))) ||
	    r->state != BC__PK_BISECT) {
		return false;
	}
	if (ab_rand(state) > 0.6f) {
		r->i = ab_rand(state) > 0.0f ? 39 : 38; /* near the limit */
	}
	return true;
}

/* Whether two floats are the same bit for bit. */
static bool same_bits(float a, float b)
{
	return memcmp(&a, &b, sizeof(a)) == 0;
}

/* Whether lane i of every state array of a and b is the same, bit for
 * bit. */
static bool same_lane(const struct bc__pk_lanes *a,
                      const struct bc__pk_lanes *b, uint32_t i)
{
	const float *fa[] = {
	    a->t,      a->mt,   a->mv,     a->mt_prev, a->mv_prev, a->momega,
	    a->mevals, a->ba,   a->bfa,    a->bb,      a->bfb,     a->bi,
	    a->ri,     a->rcap, a->rlimit, a->ga,      a->gfa,     a->gb,
	    a->gc,     a->ge,   a->gvc,    a->gve,     a->gi,      a->gph};
	const float *fb[] = {
	    b->t,      b->mt,   b->mv,     b->mt_prev, b->mv_prev, b->momega,
	    b->mevals, b->ba,   b->bfa,    b->bb,      b->bfb,     b->bi,
	    b->ri,     b->rcap, b->rlimit, b->ga,      b->gfa,     b->gb,
	    b->gc,     b->ge,   b->gvc,    b->gve,     b->gi,      b->gph};
	for (size_t k = 0; k < sizeof(fa) / sizeof(fa[0]); k++) {
		if (memcmp(&fa[k][i], &fb[k][i], sizeof(float)) != 0) {
			return false;
		}
	}
	return true;
}

/* The packet kernels take a ray's first value, its ordinary marching
 * steps, the plain step after an overshot relaxed one and its
 * bisection's halvings themselves, and end a bisection with its hit and
 * a march at its interval's end with a miss (packet.h). Lane by lane,
 * what a kernel did must be what the state machine (packet.c) does with
 * the same value, bit for bit: a lane it stepped holds the state the
 * machine reaches and asks for the same next sample; a lane it ended is
 * the machine's hit at the same depth, or its miss; a lane it left is
 * untouched, and is one the machine ends or moves to another kind of
 * state (or that had no sample left in its budget). Rays of a unit sphere
 * seen from z = -5, in every kind of state, at every budget. */
static void test_kernel_steps_match_state_machine(void)
{
	uint32_t was_march, was_bisect, was_refine, was_gold;
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data sp;
	struct bc_errinfo ei = {0};
	struct bc_frame f = {0};
	struct bc_camera cam;
	struct bc__frame_ctx fc;
	struct bc_view view;
	const struct bc_lin *l;
	const uint32_t act[1] = {0};
	const float eye[3] = {0.0f, 0.0f, -5.0f};
	uint32_t widths = 0;
	REQUIRE(t != NULL);
	sc_sphere(&sp, 0.0f, 0.0f, 0.0f, 1.0f);
	REQUIRE(bc_tree_begin(t) == 0 &&
	        bc_tree_put_prim(t, 0, &sp, &ei) == 0 &&
	        bc_tree_end(t, &ei) == 0);
	l = bc_tree_lin(t);
	REQUIRE(l != NULL);
	sc_frame(l, &cam);
	REQUIRE(bc_frame_init(&f, 64, 64) == 0);
	bc__frame_setup(&fc, l, &cam, &f, BC_DEBUG_NONE);
	bc_view_init(&view);
	REQUIRE(bc_view_build(&view, l, act, 1) == 0);
	for (size_t m = 1; m < NMODES; m++) {
		struct bc__pk_kernel k = bc__pk_kernel_for(modes[m].simd);
		const struct bc__pk_steps st = {BC_CPU_HIT_FOOTPRINT *
		                                    fc.pix_angle,
		                                fc.min_step, fc.refine_tol};
		uint32_t stepped[K_KINDS] = {0}, left[K_KINDS] = {0};
		uint32_t finished = 0, missed = 0, searched = 0;
		uint64_t state = 99 + m;
		if (!k.march) {
			continue;
		}
		widths++;
		for (int trial = 0; trial < 6000; trial++) {
			struct bc__pk_lanes ln, before;
			struct bc__pk_ray ray[BC_PK_MAX_LANES];
			int kind[BC_PK_MAX_LANES];
			float budget[BC_PK_MAX_LANES];
			uint32_t active = 0, march = 0, bisect = 0, refine = 0,
			         gold = 0, slow, hit, miss;
			struct bc__pk_kinds kk;
			memset(&ln, 0, sizeof(ln));
			for (uint32_t i = 0; i < k.lanes; i++) {
				float d[3] = {0.3f * ab_rand(&state),
				              0.3f * ab_rand(&state), 1.0f};
				float b, disc, ts;
				struct bc__pk_ray *r = &ray[i];
				ab_unit(d);
				/* Where the ray meets the sphere, or its
				 * closest approach. */
				b = eye[0] * d[0] + eye[1] * d[1] +
				    eye[2] * d[2];
				disc = b * b - (25.0f - 1.0f);
				ts = disc > 0.0f ? -b - sqrtf(disc) : -b;
				kind[i] =
				    (int)((ab_rand(&state) + 1.0f) * 3.0f) %
				    K_KINDS;
				budget[i] =
				    ab_rand(&state) > 0.8f
				        ? (ab_rand(&state) > 0.0f ? 1.0f : 2.0f)
				        : 1e6f;
				if (!steer_ray(r, &fc, kind[i], ts, d,
				               &state)) {
					continue;
				}
				ln.ox[i] = eye[0];
				ln.oy[i] = eye[1];
				ln.oz[i] = eye[2];
				ln.dx[i] = d[0];
				ln.dy[i] = d[1];
				ln.dz[i] = d[2];
				ln.t[i] = r->q;
				ln.mevals[i] = 0.0f;
				ln.mbudget[i] = budget[i];
				if (kind[i] == K_GOLD) {
					ln.ga[i] = r->a;
					ln.gfa[i] = r->fa;
					ln.gb[i] = r->b;
					ln.gc[i] = r->c;
					ln.ge[i] = r->e;
					ln.gvc[i] = r->vc;
					ln.gve[i] = r->ve;
					ln.gi[i] = (float)r->i;
					ln.gph[i] =
					    (float)(r->state - BC__PK_GOLD_C0);
					gold |= 1u << i;
				} else if (kind[i] == K_REFINE) {
					ln.mt[i] = r->t;
					ln.mv[i] = r->v;
					ln.mt_prev[i] = r->t_prev;
					ln.mv_prev[i] = r->v_prev;
					ln.ri[i] = (float)r->i;
					ln.rcap[i] = r->cap;
					ln.rlimit[i] = r->limit;
					refine |= 1u << i;
				} else if (kind[i] == K_BISECT) {
					ln.ba[i] = r->a;
					ln.bfa[i] = r->fa;
					ln.bb[i] = r->b;
					ln.bfb[i] = r->fb;
					ln.bi[i] = (float)r->i;
					bisect |= 1u << i;
				} else {
					/* The start lane holds the state its
					 * first value gives (tile_trace.c). */
					bool st0 = kind[i] == K_START;
					ln.mt[i] = st0 ? r->t0 : r->t;
					ln.mv[i] = st0 ? 0.0f : r->v;
					ln.mt_prev[i] = st0 ? r->t0 : r->t_prev;
					ln.mv_prev[i] = st0 ? 0.0f : r->v_prev;
					ln.momega[i] =
					    st0 ? BC_CPU_OVERRELAX : r->omega;
					ln.mt1[i] = r->t1;
					march |= 1u << i;
				}
				active |= 1u << i;
			}
			before = ln;
			was_march = march;
			was_bisect = bisect;
			was_refine = refine;
			was_gold = gold;
			kk = (struct bc__pk_kinds){
			    {march, bisect, refine, gold}, 0, 0};
			slow = k.march(&view, l, &ln, active, &kk, &st);
			march = kk.of[BC__PK_LANE_MARCH];
			bisect = kk.of[BC__PK_LANE_BISECT];
			refine = kk.of[BC__PK_LANE_REFINE];
			gold = kk.of[BC__PK_LANE_GOLD];
			hit = kk.hit;
			miss = kk.miss;
			CHECK((slow & ~active) == 0);
			CHECK((hit & ~(was_bisect | was_gold)) == 0 &&
			      (hit & slow) == 0 &&
			      (hit & (bisect | gold)) == 0);
			CHECK((miss & ~was_march) == 0 && (miss & slow) == 0 &&
			      (miss & march) == 0);
			for (uint32_t i = 0; i < k.lanes; i++) {
				struct bc__pk_ray ref = ray[i];
				float value = ln.v[i] *
				              (1.0f / BC_CPU_LIPSCHITZ) /
				              l->lip;
				uint32_t bit = 1u << i;
				bool done;
				if (!(active & bit)) {
					continue;
				}
				done = bc__pk_ray_feed(&ref, &fc, value);
				if (hit & bit) {
					/* A bisection or a search ended: the
					 * machine's hit, at the same depth. */
					finished++;
					searched += (was_gold & bit) != 0;
					CHECK(done && ref.res == BC__TRACE_HIT);
					CHECK(memcmp(&ln.t[i], &ref.t_hit, 4) ==
					      0);
					CHECK(ln.mevals[i] == 1.0f);
					continue;
				}
				if (miss & bit) {
					/* A march at the interval's end: the
					 * machine's miss. */
					missed++;
					CHECK(done &&
					      ref.res == BC__TRACE_MISS);
					CHECK(ln.mevals[i] == 1.0f);
					continue;
				}
				if (slow & bit) {
					left[kind[i]]++;
					/* Untouched, of the same kind, and not
					 * a step the kernel should have taken.
					 */
					CHECK(same_lane(&ln, &before, i));
					CHECK((march & bit) ==
					          (was_march & bit) &&
					      (bisect & bit) ==
					          (was_bisect & bit) &&
					      (refine & bit) ==
					          (was_refine & bit) &&
					      (gold & bit) == (was_gold & bit));
					/* A bisection with a sample left
					 * in its budget goes on or ends in
					 * the kernel. */
					CHECK(kind[i] != K_BISECT ||
					      budget[i] < 1.5f);
					/* A search too, but for a value that
					 * is not a number or a crossing too
					 * narrow to bisect (the machine's). */
					CHECK(kind[i] != K_GOLD ||
					      budget[i] < 1.5f ||
					      !(value >= 0.0f));
					CHECK(done || budget[i] < 2.5f ||
					      (ref.state != BC__PK_STEP &&
					       ref.state != BC__PK_STEP2 &&
					       ref.state != BC__PK_BISECT &&
					       ref.state != BC__PK_REFINE &&
					       ref.state < BC__PK_GOLD_C0));
					continue;
				}
				stepped[kind[i]]++;
				CHECK(!done);
				CHECK(budget[i] >= 2.0f);
				CHECK(ln.mevals[i] == 1.0f);
				CHECK(memcmp(&ln.t[i], &ref.q, 4) == 0);
				/* Of the kind the machine's state says, holding
				 * that state. */
				CHECK(((march & bit) != 0) +
				          ((bisect & bit) != 0) +
				          ((refine & bit) != 0) +
				          ((gold & bit) != 0) ==
				      1);
				if (gold & bit) {
					CHECK(ref.state >= BC__PK_GOLD_C0 &&
					      ln.gph[i] ==
					          (float)(ref.state -
					                  BC__PK_GOLD_C0));
					CHECK(same_bits(ln.ga[i], ref.a) &&
					      same_bits(ln.gfa[i], ref.fa) &&
					      same_bits(ln.gb[i], ref.b) &&
					      same_bits(ln.gc[i], ref.c) &&
					      same_bits(ln.ge[i], ref.e));
					/* vc and ve as far as the phase
					 * has them. */
					CHECK(ref.state == BC__PK_GOLD_C0 ||
					      same_bits(ln.gvc[i], ref.vc));
					CHECK(ref.state < BC__PK_GOLD_C ||
					      same_bits(ln.gve[i], ref.ve));
					CHECK(ref.state < BC__PK_GOLD_C ||
					      ln.gi[i] == (float)ref.i);
					continue;
				}
				if (bisect & bit) {
					CHECK(ref.state == BC__PK_BISECT);
					CHECK(memcmp(&ln.ba[i], &ref.a, 4) ==
					      0);
					CHECK(memcmp(&ln.bfa[i], &ref.fa, 4) ==
					      0);
					CHECK(memcmp(&ln.bb[i], &ref.b, 4) ==
					      0);
					CHECK(memcmp(&ln.bfb[i], &ref.fb, 4) ==
					      0);
					CHECK(ln.bi[i] == (float)ref.i);
					continue;
				}
				CHECK(memcmp(&ln.mt[i], &ref.t, 4) == 0);
				CHECK(memcmp(&ln.mv[i], &ref.v, 4) == 0);
				CHECK(memcmp(&ln.mt_prev[i], &ref.t_prev, 4) ==
				      0);
				CHECK(memcmp(&ln.mv_prev[i], &ref.v_prev, 4) ==
				      0);
				if (refine & bit) {
					CHECK(ref.state == BC__PK_REFINE);
					CHECK(ln.ri[i] == (float)ref.i);
					CHECK(memcmp(&ln.rcap[i], &ref.cap,
					             4) == 0);
					CHECK(memcmp(&ln.rlimit[i], &ref.limit,
					             4) == 0);
				} else {
					/* An ordinary step, or the plain one
					 * after an overshot relaxed step. */
					CHECK(ref.state == BC__PK_STEP ||
					      ref.state == BC__PK_STEP2);
					CHECK(ln.momega[i] == ref.omega);
				}
			}
		}
		printf("  %-6s stepped / left: start %u / %u, step %u / %u, "
		       "step2 %u / %u, bisect %u / %u, refine %u / %u\n",
		       modes[m].name, stepped[K_START], left[K_START],
		       stepped[K_STEP], left[K_STEP], stepped[K_STEP2],
		       left[K_STEP2], stepped[K_BISECT], left[K_BISECT],
		       stepped[K_REFINE], left[K_REFINE]);
		/* Every kind was met both ways, and bisections ended. */
		for (int kd = 0; kd < K_KINDS; kd++) {
			CHECK(stepped[kd] > 100 && left[kd] > 100);
		}
		printf("  %-6s ended in the kernel: %u bisections and "
		       "searches (%u searches), %u marches; %u / %u "
		       "searches stepped / left\n",
		       modes[m].name, finished, searched, missed,
		       stepped[K_GOLD], left[K_GOLD]);
		CHECK(finished > 100 && missed > 100 && searched > 100);
	}
	if (widths == 0) {
		printf("  no packet kernel on this CPU: nothing to compare\n");
	}
	bc_view_finish(&view);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* Compares kernel k's hit samples (packet.h's bc__pk_hits_fn) with the
 * scalar evaluator's at random points of t's bounds: the primitive the
 * view names there, and the sum of tet[k] times the field at the four
 * tetrahedral offsets. The kernel's fields round their own way (fused
 * multiply-adds), so values agree within a tolerance and primitives on
 * all but near-ties. Adds the samples compared to *total. */
static void check_hits(struct bc__pk_kernel k, const char *mode,
                       const char *what, struct bc_tree *t, uint64_t *state,
                       uint32_t *total)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t *act = malloc(sizeof(uint32_t) * (l->nprims + 1u));
	uint32_t compared = 0, same_prim = 0;
	struct bc_view view;
	struct bc__pk_lanes ln;
	struct bc__pk_shade sh;
	REQUIRE(act != NULL);
	for (uint32_t i = 0; i < l->nprims; i++) {
		act[i] = i;
	}
	bc_view_init(&view);
	REQUIRE(bc_view_build(&view, l, act, l->nprims) == 0);
	for (int trial = 0; trial < 30; trial++) {
		uint32_t n = 1 + (uint32_t)((ab_rand(state) + 1.0f) * 0.5f *
		                            (BC_PK_SHADE_MAX - 1));
		uint32_t nv = (n + k.lanes - 1) / k.lanes * k.lanes;
		for (uint32_t i = 0; i < nv; i++) {
			for (int c = 0; c < 3; c++) {
				float u = 0.5f * (ab_rand(state) + 1.0f);
				sh.o[c][i] =
				    l->lo[c] + u * (l->hi[c] - l->lo[c]);
			}
			sh.step[i] =
			    l->size * (0.001f + 0.05f * fabsf(ab_rand(state)));
		}
		k.hits(&view, l, &ln, &sh, n);
		for (uint32_t i = 0; i < n; i++) {
			float o[3] = {sh.o[0][i], sh.o[1][i], sh.o[2][i]};
			float g[3] = {0.0f, 0.0f, 0.0f}, scale = 1.0f;
			uint32_t prim = BC_NONE;
			(void)bc_view_eval_id(&view, l, o, &prim);
			for (int s = 0; s < 4; s++) {
				float q[3], v;
				for (int c = 0; c < 3; c++) {
					q[c] =
					    o[c] + sh.step[i] * bc__tet[s][c];
				}
				v = bc_view_eval(&view, l, q);
				scale += fabsf(v);
				for (int c = 0; c < 3; c++) {
					g[c] += bc__tet[s][c] * v;
				}
			}
			for (int c = 0; c < 3; c++) {
				CHECK_NEAR(sh.g[c][i], g[c], 1e-5f * scale);
			}
			same_prim += sh.prim[i] == prim;
			compared++;
		}
	}
	printf("  %-6s %-14s %u samples, %u with the same primitive\n", mode,
	       what, compared, same_prim);
	CHECK(same_prim >= compared - compared / 100u);
	bc_view_finish(&view);
	free(act);
	*total += compared;
}

/* The packet kernels take a tile's hit samples for shading themselves
 * (the primitive at the hit and bc__put_hit's tetrahedral differences):
 * they must be the scalar evaluator's on Fig. 18 spheres and boxes and
 * on random trees with unary and domain nodes (the kernels' lane-by-lane
 * paths, under partial masks), for any hit count. */
static void test_hits_kernel_matches_scalar(void)
{
	struct bc_tree *t = bc_tree_create();
	uint64_t state = 11;
	uint32_t compared = 0;
	REQUIRE(t != NULL);
	for (size_t m = 1; m < NMODES; m++) {
		struct bc__pk_kernel k = bc__pk_kernel_for(modes[m].simd);
		if (!k.hits) {
			continue;
		}
		REQUIRE(sc_fig18(t, 64, false, true, 3) == 0);
		check_hits(k, modes[m].name, "fig18 spheres", t, &state,
		           &compared);
		REQUIRE(sc_fig18(t, 64, true, false, 4) == 0);
		check_hits(k, modes[m].name, "fig18 boxes", t, &state,
		           &compared);
		rt_unary_rate = 0.4f;
		for (uint64_t seed = 1; seed <= 4; seed++) {
			REQUIRE(rt_build(t, 900 + seed, 12) == 0);
			CHECK(bc_tree_lin(t)->nunary > 0 || seed > 1);
			check_hits(k, modes[m].name, "random, unary", t, &state,
			           &compared);
		}
		rt_unary_rate = 0.0f;
	}
	if (compared == 0) {
		fprintf(stderr, "  no vector kernel on this CPU\n");
	}
	bc_tree_destroy(t);
}

/* A gradient for the shading test: mostly random, sometimes one the
 * shading must replace (zero, infinite, NaN) or an extreme length. */
static void shade_grad(uint64_t *state, float g[3])
{
	float pick = ab_rand(state);
	for (int c = 0; c < 3; c++) {
		g[c] = ab_rand(state);
	}
	if (pick > 0.9f) {
		g[0] = g[1] = g[2] = 0.0f;
	} else if (pick > 0.8f) {
		g[(int)(ab_rand(state) * 1.4f + 1.5f)] =
		    ab_rand(state) > 0.0f ? INFINITY : -INFINITY;
	} else if (pick > 0.7f) {
		g[1] = NAN;
	} else if (pick > 0.6f) {
		g[2] *= 1e-42f; /* subnormal */
		g[0] = g[1] = 0.0f;
	} else if (pick > 0.5f) {
		g[0] *= 3e37f; /* |g|^2 overflows */
	}
}

/* The packet kernels shade a tile's hits (packet.h's bc__pk_shade_fn):
 * each hit's bytes must be bc_shade_hit's, bit for bit, for gradients
 * of every kind (unusable ones included), rays seen from inside and
 * from outside, lit and unlit sides, random lights and albedos, and any
 * count of hits (the lanes past the count are padding). */
static void test_shade_kernel_matches_shade_hit(void)
{
	uint64_t state = 7;
	uint32_t widths = 0, inside = 0, bad_grad = 0;
	for (size_t m = 1; m < NMODES; m++) {
		struct bc__pk_kernel k = bc__pk_kernel_for(modes[m].simd);
		if (!k.shade) {
			continue;
		}
		widths++;
		for (int trial = 0; trial < 400; trial++) {
			struct bc__pk_shade sh;
			struct bc_shade s;
			uint32_t n = 1 + (uint32_t)((ab_rand(&state) + 1.0f) *
			                            0.5f * BC_PK_SHADE_MAX);
			uint32_t nv = (n + k.lanes - 1) / k.lanes * k.lanes;
			n = n > BC_PK_SHADE_MAX ? BC_PK_SHADE_MAX : n;
			nv = nv > BC_PK_SHADE_MAX ? BC_PK_SHADE_MAX : nv;
			for (int c = 0; c < 3; c++) {
				s.light[c] = ab_rand(&state);
			}
			ab_unit(s.light);
			s.ambient = 0.18f * (ab_rand(&state) + 1.0f);
			(void)bc_shade_srgb8(0.5f); /* builds the table */
			for (uint32_t i = 0; i < nv; i++) {
				float g[3], d[3];
				shade_grad(&state, g);
				for (int c = 0; c < 3; c++) {
					d[c] = ab_rand(&state);
				}
				ab_unit(d);
				for (int c = 0; c < 3; c++) {
					sh.g[c][i] = g[c];
					sh.d[c][i] = d[c];
					sh.albedo[c][i] =
					    (ab_rand(&state) + 1.0f) * 0.6f;
				}
			}
			k.shade(&s, &sh, n);
			for (uint32_t i = 0; i < n; i++) {
				float g[3] = {sh.g[0][i], sh.g[1][i],
				              sh.g[2][i]};
				float d[3] = {sh.d[0][i], sh.d[1][i],
				              sh.d[2][i]};
				float a[3] = {sh.albedo[0][i], sh.albedo[1][i],
				              sh.albedo[2][i]};
				float lit[3] = {sh.lit[0][i], sh.lit[1][i],
				                sh.lit[2][i]};
				uint8_t want[4], got[4];
				bool usable =
				    isfinite(g[0]) && isfinite(g[1]) &&
				    isfinite(g[2]) &&
				    g[0] * g[0] + g[1] * g[1] + g[2] * g[2] >
				        0.0f;
				bc_shade_hit(&s, g, d, a, want);
				bc_shade_put_lit(lit, got);
				if (memcmp(want, got, 4) != 0) {
					fprintf(stderr,
					        "  %s hit %u of %u: g (%g %g "
					        "%g) gives %u %u %u, "
					        "bc_shade_hit %u %u %u\n",
					        modes[m].name, i, n, g[0], g[1],
					        g[2], got[0], got[1], got[2],
					        want[0], want[1], want[2]);
				}
				CHECK_MEMEQ(want, got, 4);
				bad_grad += usable ? 0u : 1u;
				inside += usable && g[0] * d[0] + g[1] * d[1] +
				                            g[2] * d[2] >
				                        0.0f;
			}
		}
	}
	if (widths == 0) {
		fprintf(stderr, "  no vector kernel on this CPU\n");
		return;
	}
	/* The cases the comparison must have met. */
	CHECK(bad_grad > 100);
	CHECK(inside > 100);
}

static const struct bc_test tests[] = {
    {"simd_matches_scalar_unary_nodes", test_simd_matches_scalar_unary_nodes},
    {"simd_matches_scalar_fig18", test_simd_matches_scalar_fig18},
    {"simd_matches_scalar_fig16_comb_random",
     test_simd_matches_scalar_fig16_comb_random},
    {"simd_matches_scalar_over_m_overlap",
     test_simd_matches_scalar_over_m_overlap},
    {"region_equals_whole_with_simd", test_region_equals_whole_with_simd},
    {"abuffer_abv_kernel_matches_scalar",
     test_abuffer_abv_kernel_matches_scalar},
    {"kernel_steps_match_state_machine", test_kernel_steps_match_state_machine},
    {"hits_kernel_matches_scalar", test_hits_kernel_matches_scalar},
    {"shade_kernel_matches_shade_hit", test_shade_kernel_matches_shade_hit},
    {"threads_do_not_change_simd_pixels",
     test_threads_do_not_change_simd_pixels},
};

BC_TEST_MAIN(tests)
