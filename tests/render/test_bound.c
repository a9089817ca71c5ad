/*
 * The evaluation bound of a region (max_evals, short_tiles, short_rays)
 * and the release of what a renderer keeps for its view, on every backend
 * built in, through the front (blobcast/render.h) only.
 *
 * Bound: a sphere under a twist or a bend of rate 1e6 has a Lipschitz
 * bound near 1e6, so sphere tracing steps a millionth of the scene at a
 * time (unbounded, a 64x64 frame of it takes tiled more than five
 * minutes). Drawn with a bound of 256, whole and as a refining level of
 * some tiles, it spends at most 256 evaluations a ray, leaves the pixels
 * of the rays that ran out as the frame held them (a sentinel, in all
 * three planes) and marks exactly the tiles holding one. On an ordinary
 * scene a bound nothing reaches changes no pixel, whole or refined level
 * by level, and a tight one changes none of the pixels it lets through;
 * which rays it stops does not depend on how the frame is cut into calls
 * (but in svo, whose packets share beam tests), and tiled's two vector
 * widths stop the same ones.
 *
 * Release: nothing is kept before a render, kept_bytes is above 0 after
 * one (tiled, svo, gl) and 0 after a release, and the renders after a
 * release draw the same pixels.
 *
 * Sizes stay small: the file takes a few seconds under a sanitizer, but
 * for gl with the driver's shader cache cold, when llvmpipe compiling the
 * tracer (and its variant for unary nodes) takes some twenty more.
 */
#include <math.h>
#include <stdlib.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "scenes.h"
#include "test.h"

#include "compare.h"

/* The heavy scenes' frame and bound. */
#define HEAVY_W 64u
#define HEAVY_H 64u
#define HEAVY_BOUND 256u
/* The ordinary scene's frame: not a multiple of the tile. */
#define PLAIN_W 61u
#define PLAIN_H 47u
/* A bound no ray of the ordinary scene reaches, and one that stops about
 * a quarter of them (most take 10 to 30 evaluations, shading included). */
#define LOOSE_BOUND (1u << 30)
#define TIGHT_BOUND 20u

/* ---- Small helpers ------------------------------------------------------ */

static double now_ms(void)
{
	struct timespec ts;
	if (timespec_get(&ts, TIME_UTC) != TIME_UTC) {
		return 0.0;
	}
	return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

static size_t npix(const struct bc_frame *f)
{
	return (size_t)f->width * f->height;
}

static size_t ntiles(const struct bc_frame *f)
{
	return (size_t)bc_render_tiles_x(f->width) *
	       bc_render_tiles_y(f->height);
}

static size_t tile_of(const struct bc_frame *f, uint32_t x, uint32_t y)
{
	return (size_t)(y / BC_RENDER_TILE) * bc_render_tiles_x(f->width) +
	       x / BC_RENDER_TILE;
}

/* A pattern no renderer writes in any plane: odd bytes (alpha 0xa5, drawn
 * pixels are opaque), a NaN with a payload, an id no scene here has. The
 * key is left as it is. */
static const uint32_t sentinel_nan = 0x7fc0beefu;
static const uint32_t sentinel_id = 0xdeadbeefu;

static void fill_sentinel(struct bc_frame *f)
{
	float nan;
	memcpy(&nan, &sentinel_nan, sizeof(nan));
	memset(f->rgba, 0xa5, 4 * npix(f));
	for (size_t i = 0; i < npix(f); i++) {
		f->depth[i] = nan;
		f->ids[i] = sentinel_id;
	}
}

/* How many of pixel i's planes still hold the sentinel: 0 (drawn) or 3
 * (left alone) are the only right answers. */
static int sentinel_planes(const struct bc_frame *f, size_t i)
{
	static const uint8_t rgba[4] = {0xa5, 0xa5, 0xa5, 0xa5};
	uint32_t bits;
	memcpy(&bits, &f->depth[i], sizeof(bits));
	return (memcmp(f->rgba + 4 * i, rgba, 4) == 0) +
	       (bits == sentinel_nan) + (f->ids[i] == sentinel_id);
}

/* Pixels of got that differ from want; the first one is reported. */
static uint64_t diff_frames(const struct bc_frame *got,
                            const struct bc_frame *want, const char *what)
{
	uint64_t bad = 0;
	for (size_t i = 0; i < npix(got); i++) {
		if (!pixel_equal(got, want, i) && bad++ == 0) {
			fprintf(stderr,
			        "  %s: first differing pixel (%zu, %zu)\n",
			        what, i % got->width, i / got->width);
		}
	}
	return bad;
}

/* What a bounded call left in a frame pre-filled with the sentinel, checked
 * against the call's own report: every pixel is drawn or wholly the
 * sentinel, and only an asked pixel may be either (*asked_only); the
 * sentinel pixels are the short rays, and the marked tiles are exactly
 * those holding one. Returns the mismatches; *left gets the sentinel
 * pixels. */
static uint64_t check_short(const struct bc_frame *f,
                            const struct bc_render_region *rg,
                            const struct bc_render_stats *st, const char *what,
                            uint64_t *left)
{
	uint64_t bad = 0, n = 0;
	uint32_t per_tile[(HEAVY_W / 8) * (HEAVY_H / 8)] = {0};
	if (ntiles(f) > sizeof(per_tile) / sizeof(per_tile[0])) {
		fprintf(stderr, "  %s: frame too large for the check\n", what);
		return 1;
	}
	for (uint32_t y = 0; y < f->height; y++) {
		for (uint32_t x = 0; x < f->width; x++) {
			size_t i = (size_t)y * f->width + x;
			int planes = sentinel_planes(f, i);
			bool asked =
			    (!rg->tiles || rg->tiles[tile_of(f, x, y)]) &&
			    bc_render_level_has(x, y, rg->level, rg->refine);
			if (planes != 0 && planes != 3) {
				if (bad++ == 0) {
					fprintf(stderr,
					        "  %s: pixel (%u, %u) keeps %d "
					        "sentinel planes of 3\n",
					        what, x, y, planes);
				}
			} else if (planes == 3 && asked) {
				per_tile[tile_of(f, x, y)]++;
				n++;
			} else if (planes == 0 && !asked) {
				if (bad++ == 0) {
					fprintf(stderr,
					        "  %s: pixel (%u, %u) drawn "
					        "but not "
					        "asked for\n",
					        what, x, y);
				}
			}
		}
	}
	if (n != st->short_rays) {
		fprintf(stderr, "  %s: %llu pixels left, %llu short rays\n",
		        what, (unsigned long long)n,
		        (unsigned long long)st->short_rays);
		bad++;
	}
	for (size_t t = 0; t < ntiles(f); t++) {
		if ((per_tile[t] > 0) != (rg->short_tiles[t] != 0)) {
			if (bad++ == 0) {
				fprintf(stderr,
				        "  %s: tile %zu has %u short rays, "
				        "marked %u\n",
				        what, t, per_tile[t],
				        rg->short_tiles[t]);
			}
		}
	}
	*left = n;
	return bad;
}

/* ---- Scenes ------------------------------------------------------------- */

/* One sphere under a twist or a bend of the given rate. */
static int build_heavy(struct bc_tree *t, enum bc_op kind, float rate)
{
	struct bc_errinfo ei = {0};
	struct bc_unary u;
	struct bc_prim_data p;
	int rc;
	bc_unary_init(&u, kind);
	u.u[0] = rate;
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 0.8f;
	bc_tree_begin(t);
	if ((rc = bc_tree_push_unary(t, 1, &u, &ei)) ||
	    (rc = bc_tree_put_prim(t, 2, &p, &ei)) ||
	    (rc = bc_tree_pop_op(t, &ei)) || (rc = bc_tree_end(t, &ei))) {
		fprintf(stderr, "  heavy scene: %s\n", ei.msg);
	}
	return rc;
}

/* The ordinary scene: fig18's 24 smooth spheres. */
static int build_plain(struct bc_tree *t)
{
	struct bc_gen_opts o = {.count = 24,
	                        .seed = 2,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SMOOTH};
	struct bc_errinfo ei = {0};
	int rc = bc_gen("fig18", &o, t, NULL, &ei);
	if (rc) {
		fprintf(stderr, "  fig18: %s\n", ei.msg);
	}
	return rc;
}

/* A renderer of backend b, or NULL (a gl context may be missing). */
static struct bc_renderer *open_renderer(enum bc_backend b, enum bc_simd simd)
{
	struct bc_render_opts o = {.simd = simd};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, b, &o, &ei)) {
		fprintf(stderr, "  no %s renderer: %s\n", bc_backend_name(b),
		        ei.msg);
		return NULL;
	}
	return r;
}

/* ---- The bound on scenes that crawl ------------------------------------- */

/* Twist and bend of rate 1e6: the whole frame, then a refining level of
 * some of its tiles, both with the bound of HEAVY_BOUND. */
static void heavy_one(struct bc_renderer *r, const char *label, enum bc_op kind)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame f = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint8_t shorts[(HEAVY_W / 8) * (HEAVY_H / 8)] = {0};
	uint8_t tiles[sizeof(shorts)];
	struct bc_render_region rg = {.max_evals = HEAVY_BOUND,
	                              .short_tiles = shorts};
	uint64_t left = 0;
	double ms;
	char what[96];
	snprintf(what, sizeof(what), "%s %s", label,
	         kind == BC_OP_TWIST ? "twist" : "bend");
	REQUIRE(t);
	REQUIRE(build_heavy(t, kind, 1.0e6f) == 0);
	REQUIRE(bc_tree_lin(t)->lip > 1.0e5f);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&f, HEAVY_W, HEAVY_H) == 0);
	fill_sentinel(&f);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	ms = now_ms();
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	ms = now_ms() - ms;
	printf("  %s: %.0f ms, %llu evaluations for %llu rays (%.1f a ray), "
	       "%llu ran out\n",
	       what, ms, (unsigned long long)st.field_evals,
	       (unsigned long long)st.rays,
	       st.rays ? (double)st.field_evals / (double)st.rays : 0.0,
	       (unsigned long long)st.short_rays);
	CHECK_EQ_INT(st.rays, (uint64_t)HEAVY_W * HEAVY_H);
	/* The bound counts every evaluation a ray's pixel takes, shading
	 * included, in the units of field_evals (render.h): the constant is
	 * 1. (svo's rays that leave their packet are counted for their cast
	 * alone; their packet's work before it is not in field_evals.) */
	CHECK(st.field_evals <= st.rays * HEAVY_BOUND);
	CHECK(st.short_rays > 0);
	CHECK(!st.incomplete);
	CHECK_EQ_INT(check_short(&f, &rg, &st, what, &left), 0);

	/* Level 1, refining, in every other tile: short rays and marks
	 * only there. The frame is this view's now (its key), so the
	 * region is drawn as asked. */
	for (size_t k = 0; k < sizeof(tiles); k++) {
		tiles[k] = (uint8_t)(k % 2 == 0);
	}
	memset(shorts, 0, sizeof(shorts));
	fill_sentinel(&f);
	rg = (struct bc_render_region){.tiles = tiles,
	                               .level = 1,
	                               .refine = true,
	                               .max_evals = HEAVY_BOUND,
	                               .short_tiles = shorts};
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(!st.whole);
	CHECK(st.rays > 0 && st.field_evals <= st.rays * HEAVY_BOUND);
	CHECK(st.short_rays > 0);
	CHECK_EQ_INT(check_short(&f, &rg, &st, what, &left), 0);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* A region into a frame of another rendering is drawn whole, at its
 * level and within its bound. */
static void test_region_made_whole_keeps_its_bound(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = open_renderer(BC_BACKEND_TILED, BC_SIMD_AUTO);
	struct bc_frame f = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint8_t shorts[(HEAVY_W / 8) * (HEAVY_H / 8)] = {0};
	uint8_t tiles[sizeof(shorts)] = {1};
	struct bc_render_region rg = {
	    .tiles = tiles, .max_evals = HEAVY_BOUND, .short_tiles = shorts};
	uint64_t left = 0;
	REQUIRE(t && r);
	REQUIRE(build_heavy(t, BC_OP_TWIST, 1.0e6f) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&f, HEAVY_W, HEAVY_H) == 0);
	fill_sentinel(&f);
	f.key = 0;
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK_EQ_INT(st.rays, (uint64_t)HEAVY_W * HEAVY_H);
	CHECK(st.field_evals <= st.rays * HEAVY_BOUND);
	rg.tiles = NULL; /* what was drawn: every tile */
	CHECK_EQ_INT(check_short(&f, &rg, &st, "made whole", &left), 0);
	CHECK_EQ_INT(left, st.rays); /* tiled: every ray crawls here */
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* ---- The bound on ordinary scenes --------------------------------------- */

/* Draws levels 3 down to 0 (refining) of every tile (a list of them) into
 * f within bound. Returns 0 or the first error. */
static int refine_all(struct bc_renderer *r, const struct bc_camera *cam,
                      struct bc_frame *f, uint32_t bound, uint8_t *shorts,
                      uint64_t *short_rays)
{
	uint8_t tiles[8 * 6];
	struct bc_errinfo ei = {0};
	*short_rays = 0;
	if (ntiles(f) > sizeof(tiles)) {
		return BC_ERANGE;
	}
	memset(tiles, 1, sizeof(tiles));
	for (int level = (int)BC_RENDER_MAX_LEVEL; level >= 0; level--) {
		struct bc_render_region rg = {
		    .tiles = tiles,
		    .level = (uint32_t)level,
		    .refine = level != (int)BC_RENDER_MAX_LEVEL,
		    .max_evals = bound,
		    .short_tiles = shorts};
		struct bc_render_stats st;
		int rc = bc_renderer_render_region(r, cam, f, &rg, &st, &ei);
		if (rc) {
			fprintf(stderr, "  refine: %s\n", ei.msg);
			return rc;
		}
		*short_rays += st.short_rays;
	}
	return 0;
}

/* A bound nothing reaches draws the unbounded frame, whole and refined; a
 * tight one draws the unbounded pixels of the rays it lets through, and
 * (with same_short) stops the same rays however the frame is cut into
 * calls. Then a release: kept_bytes above 0 before it (with keeps), 0
 * after, and the same pixels after it. *tight gets the tight frame (sized
 * already). */
static void plain_backend(struct bc_renderer *r, const char *label,
                          bool same_short, bool keeps, struct bc_frame *tight)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_frame ref = {0}, f = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint8_t shorts[8 * 6] = {0};
	struct bc_render_region rg = {.max_evals = LOOSE_BOUND,
	                              .short_tiles = shorts};
	uint64_t left = 0, refined_short = 0;
	char what[96];
	REQUIRE(t);
	REQUIRE(build_plain(t) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&ref, PLAIN_W, PLAIN_H) == 0);
	REQUIRE(bc_frame_init(&f, PLAIN_W, PLAIN_H) == 0);
	REQUIRE(ntiles(&f) <= sizeof(shorts));
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &ref, &st, &ei) == 0);
	CHECK_EQ_INT(st.short_rays, 0);

	/* Loose, whole. */
	snprintf(what, sizeof(what), "%s loose bound", label);
	fill_sentinel(&f);
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK_EQ_INT(st.short_rays, 0);
	CHECK_EQ_INT(diff_frames(&f, &ref, what), 0);
	for (size_t k = 0; k < sizeof(shorts); k++) {
		CHECK_EQ_INT(shorts[k], 0);
	}

	/* Loose, tiles and levels, refining. */
	snprintf(what, sizeof(what), "%s loose bound, refined", label);
	fill_sentinel(&f);
	f.key = ref.key;
	REQUIRE(refine_all(r, &cam, &f, LOOSE_BOUND, shorts, &left) == 0);
	CHECK_EQ_INT(left, 0);
	CHECK_EQ_INT(diff_frames(&f, &ref, what), 0);

	/* Tight, whole: drawn pixels are the unbounded ones. */
	snprintf(what, sizeof(what), "%s tight bound", label);
	memset(shorts, 0, sizeof(shorts));
	fill_sentinel(tight);
	tight->key = ref.key;
	rg.max_evals = TIGHT_BOUND;
	REQUIRE(bc_renderer_render_region(r, &cam, tight, &rg, &st, &ei) == 0);
	printf("  %s: %llu of %llu rays ran out\n", what,
	       (unsigned long long)st.short_rays, (unsigned long long)st.rays);
	CHECK(st.short_rays > 0 && st.short_rays < st.rays);
	CHECK(st.field_evals <= st.rays * TIGHT_BOUND);
	{
		uint32_t per_tile[8 * 6] = {0};
		uint64_t bad = 0, n = 0;
		for (size_t i = 0; i < npix(tight); i++) {
			int planes = sentinel_planes(tight, i);
			size_t tile = tile_of(tight, (uint32_t)(i % PLAIN_W),
			                      (uint32_t)(i / PLAIN_W));
			if (planes == 3) {
				per_tile[tile]++;
				n++;
			} else if (planes != 0 ||
			           !pixel_equal(tight, &ref, i)) {
				bad++;
			}
		}
		for (size_t k = 0; k < ntiles(tight); k++) {
			bad += (per_tile[k] > 0) != (shorts[k] != 0);
		}
		CHECK_EQ_INT(n, st.short_rays);
		CHECK_EQ_INT(bad, 0);
	}

	/* Tight, refined: which rays run out does not depend on the calls
	 * (levels nest, and a ray's count is its own). */
	if (same_short) {
		snprintf(what, sizeof(what), "%s tight bound, refined", label);
		fill_sentinel(&f);
		f.key = ref.key;
		REQUIRE(refine_all(r, &cam, &f, TIGHT_BOUND, shorts,
		                   &refined_short) == 0);
		CHECK_EQ_INT(refined_short, st.short_rays);
		CHECK_EQ_INT(diff_frames(&f, tight, what), 0);
	}

	/* Release: nothing kept, the same pixels after. */
	snprintf(what, sizeof(what), "%s after a release", label);
	printf("  %s: %zu bytes kept for the view\n", label,
	       bc_renderer_kept_bytes(r));
	CHECK(!keeps || bc_renderer_kept_bytes(r) > 0);
	bc_renderer_release(r);
	CHECK_EQ_INT(bc_renderer_kept_bytes(r), 0);
	bc_renderer_release(r); /* twice: nothing left to free */
	fill_sentinel(&f);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
	CHECK_EQ_INT(diff_frames(&f, &ref, what), 0);
	CHECK_EQ_INT(f.key, ref.key);
	bc_renderer_release(r);
	fill_sentinel(&f);
	f.key = ref.key;
	REQUIRE(refine_all(r, &cam, &f, LOOSE_BOUND, shorts, &left) == 0);
	CHECK_EQ_INT(diff_frames(&f, &ref, what), 0);
	bc_frame_finish(&ref);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* Every check of this file on one renderer of backend b, which keeps
 * nothing before its first render: the scenes that crawl, then the
 * ordinary one, its release last. (One renderer: creating a gl one, and on
 * llvmpipe compiling its tracer for unary nodes, is what costs there.)
 * *tight gets the ordinary scene's frame under TIGHT_BOUND. */
static void check_backend(enum bc_backend b, enum bc_simd simd,
                          const char *label, struct bc_frame *tight)
{
	struct bc_renderer *r = open_renderer(b, simd);
	if (!r) {
		if (b == BC_BACKEND_GL) {
			BC_SKIP("no GL context");
		}
		REQUIRE(r);
	}
	CHECK_EQ_INT(bc_renderer_kept_bytes(r), 0);
	heavy_one(r, label, BC_OP_TWIST);
	heavy_one(r, label, BC_OP_BEND);
	/* svo's packets share beam tests; naive keeps nothing. */
	plain_backend(r, label, b != BC_BACKEND_SVO, b != BC_BACKEND_NAIVE,
	              tight);
	bc_renderer_destroy(r);
}

static void check_one(enum bc_backend b, const char *label)
{
	struct bc_frame tight = {0};
	REQUIRE(bc_frame_init(&tight, PLAIN_W, PLAIN_H) == 0);
	check_backend(b, BC_SIMD_AUTO, label, &tight);
	bc_frame_finish(&tight);
}

static void test_naive_bounds_rays_and_releases_memory(void)
{
	check_one(BC_BACKEND_NAIVE, "naive");
}

static void test_tiled_bounds_rays_and_releases_memory(void)
{
	check_one(BC_BACKEND_TILED, "tiled");
}

static void test_svo_bounds_rays_and_releases_memory(void)
{
	check_one(BC_BACKEND_SVO, "svo");
}

static void test_gl_bounds_rays_and_releases_memory(void)
{
	if (!bc_backend_available(BC_BACKEND_GL)) {
		BC_SKIP("gl not built in");
	}
	check_one(BC_BACKEND_GL, "gl");
}

/* tiled's scalar path and its packets, at every vector width this CPU
 * has (a width it lacks falls back to scalar), each pass every check. The
 * two widths' kernels do the same operations in the same order
 * (packet_kernel.h), so they stop the same rays and draw the same pixels.
 * (The scalar path's pixels may differ from theirs in the last bits,
 * test_simd.c, and so may which rays run out.) */
static void test_tiled_scalar_and_packets_bound_rays_alike(void)
{
	static const enum bc_simd widths[] = {BC_SIMD_OFF, BC_SIMD_AVX2,
	                                      BC_SIMD_AVX512};
	static const char *const names[] = {"tiled scalar", "tiled avx2",
	                                    "tiled avx-512"};
	struct bc_frame f[3] = {{0}};
	for (size_t k = 0; k < 3; k++) {
		REQUIRE(bc_frame_init(&f[k], PLAIN_W, PLAIN_H) == 0);
		check_backend(BC_BACKEND_TILED, widths[k], names[k], &f[k]);
	}
	CHECK_EQ_INT(diff_frames(&f[2], &f[1], "avx-512 against avx2"), 0);
	for (size_t k = 0; k < 3; k++) {
		bc_frame_finish(&f[k]);
	}
}

/* ---- A call's share of the threads -------------------------------------- */

/* A renderer of four threads draws the same pixels whether a call uses
 * all of them or one (the daemon lends a slice the idle workers' cores),
 * in one call or in slices of tiles. */
static void threads_one(enum bc_backend b)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_render_opts o = {.threads = 4};
	struct bc_renderer *all = NULL, *one = NULL;
	struct bc_frame fa = {0}, f1 = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint32_t n = bc_render_tiles_x(PLAIN_W) * bc_render_tiles_y(PLAIN_H);
	REQUIRE(t && build_plain(t) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_renderer_create(&all, b, &o, &ei) == 0);
	REQUIRE(bc_renderer_create(&one, b, &o, &ei) == 0);
	REQUIRE(bc_frame_init(&fa, PLAIN_W, PLAIN_H) == 0);
	REQUIRE(bc_frame_init(&f1, PLAIN_W, PLAIN_H) == 0);
	REQUIRE(bc_renderer_sync(all, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_sync(one, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(all, &cam, &fa, &st, &ei) == 0);
	fill_sentinel(&f1);
	f1.key = 0;
	for (uint32_t first = 0; first < n; first += 37) {
		struct bc_render_region rg = {
		    .tile_first = first,
		    .tile_count = n - first < 37 ? n - first : 37,
		    .adopt_key = true,
		    .threads = first % 2 ? 1u : 3u};
		uint8_t *tiles = calloc(n, 1);
		REQUIRE(tiles);
		memset(tiles + first, 1, rg.tile_count);
		rg.tiles = tiles;
		memset(&st, 0, sizeof(st));
		CHECK_EQ_INT(
		    bc_renderer_render_region(one, &cam, &f1, &rg, &st, &ei),
		    0);
		free(tiles);
	}
	CHECK_EQ_INT(diff_frames(&f1, &fa, bc_backend_name(b)), 0);
	bc_renderer_destroy(all);
	bc_renderer_destroy(one);
	bc_frame_finish(&fa);
	bc_frame_finish(&f1);
	bc_tree_destroy(t);
}

static void test_a_calls_threads_do_not_change_pixels(void)
{
	threads_one(BC_BACKEND_NAIVE);
	threads_one(BC_BACKEND_TILED);
	threads_one(BC_BACKEND_SVO);
}

static void test_release_and_kept_bytes_accept_null(void)
{
	bc_renderer_release(NULL);
	CHECK_EQ_INT(bc_renderer_kept_bytes(NULL), 0);
}

static const struct bc_test tests[] = {
    {"release_and_kept_bytes_accept_null",
     test_release_and_kept_bytes_accept_null},
    {"region_made_whole_keeps_its_bound",
     test_region_made_whole_keeps_its_bound},
    {"naive_bounds_rays_and_releases_memory",
     test_naive_bounds_rays_and_releases_memory},
    {"tiled_bounds_rays_and_releases_memory",
     test_tiled_bounds_rays_and_releases_memory},
    {"tiled_scalar_and_packets_bound_rays_alike",
     test_tiled_scalar_and_packets_bound_rays_alike},
    {"svo_bounds_rays_and_releases_memory",
     test_svo_bounds_rays_and_releases_memory},
    {"gl_bounds_rays_and_releases_memory",
     test_gl_bounds_rays_and_releases_memory},
    {"a_calls_threads_do_not_change_pixels",
     test_a_calls_threads_do_not_change_pixels},
};

BC_TEST_MAIN(tests)
