/*
 * Windows of a larger view (bc_frame_window), the way the daemon renders a
 * snapshot bigger than one frame: in tiles, each a window of the big
 * picture. In every backend built in (naive, tiled with vector kernels off
 * and on, svo, and gl where a context can be made), a small scene is drawn
 * whole at 200x120 and then as windows: four tiles that cover it, a ragged
 * tile at the bottom right edge, a small one inside, one as large as the
 * view; each must equal the crop of the whole render bit for bit (rgba,
 * depth compared as bytes, ids). Window origins are multiples of the tile
 * (8), as the daemon's are, so that tiled, svo and gl form the same tiles
 * (tile lists, packets) as the whole render and refinement levels pick the
 * same pixels; naive, whose pixels are each their own, is also checked at
 * an origin that is not. A window refined from level 3 to 0 equals the
 * crop too. The frame's key follows the window (a region drawn into a
 * frame of another window draws the whole frame), and bc_frame_window and
 * the front refuse windows that do not lie inside their view.
 *
 * The A-buffer bands of tiled and gl (a view whose tile lists pass the
 * A-buffer's limit is drawn a band of tile rows at a time) draw the
 * pixels of one pass, whole, refined, as a range of tiles and after
 * edits.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/render.h"
#include "compare.h"
#include "scenes.h"
#include "test.h"

#define FULL_W 200u
#define FULL_H 120u

/* The renderers compared: naive, tiled's scalar path and its vector
 * kernels (the A-buffer's ray directions are computed inline there), svo
 * and gl. */
struct setup {
	const char *label;
	enum bc_backend backend;
	enum bc_simd simd;
};

static const struct setup setups[] = {
    {"naive", BC_BACKEND_NAIVE, BC_SIMD_AUTO},
    {"tiled simd off", BC_BACKEND_TILED, BC_SIMD_OFF},
    {"tiled simd auto", BC_BACKEND_TILED, BC_SIMD_AUTO},
    {"svo", BC_BACKEND_SVO, BC_SIMD_AUTO},
    {"gl", BC_BACKEND_GL, BC_SIMD_AUTO},
};

struct win {
	uint32_t x, y, w, h;
};

/* Origins at multiples of 8: four tiles covering the view (the right and
 * bottom ones ragged: 200 = 104 + 96, 120 = 64 + 56), a ragged edge tile,
 * a small inner one, and the whole view as a window. */
static const struct win windows[] = {
    {0, 0, 104, 64},   {104, 0, 96, 64}, {0, 64, 104, 56}, {104, 64, 96, 56},
    {136, 72, 64, 48}, {8, 16, 40, 24},  {0, 0, 200, 120},
};

/* Wall-clock seconds, for the timing lines. */
static double now_s(void)
{
	struct timespec ts;
	if (timespec_get(&ts, TIME_UTC) != TIME_UTC) {
		return 0.0;
	}
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The renderer of s, or NULL when its backend is not built in or (gl) no
 * context can be made here: the setup is then skipped. */
static struct bc_renderer *open_setup(const struct setup *s,
                                      const struct bc_tree *t)
{
	struct bc_render_opts o = {.simd = s->simd};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (!bc_backend_available(s->backend)) {
		return NULL;
	}
	if (bc_renderer_create(&r, s->backend, &o, &ei)) {
		fprintf(stderr, "  %s: skipped: %s\n", s->label, ei.msg);
		return NULL;
	}
	if (bc_renderer_sync(r, t, NULL, &ei)) {
		fprintf(stderr, "  %s: sync: %s\n", s->label, ei.msg);
		bc_test_failures++;
		bc_renderer_destroy(r);
		return NULL;
	}
	return r;
}

/* The scene: 16 spheres blended smoothly (fig18), framed from the front. */
static struct bc_tree *make_scene(struct bc_camera *cam)
{
	struct bc_tree *t = bc_tree_create();
	if (!t) {
		return NULL;
	}
	if (sc_fig18(t, 16, false, true, 2) != 0) {
		bc_tree_destroy(t);
		return NULL;
	}
	sc_frame(bc_tree_lin(t), cam);
	/* Closer, so that the surfaces reach the view's edges and corners
	 * (the ragged corner window among them). */
	for (int i = 0; i < 3; i++) {
		cam->eye[i] =
		    cam->target[i] + 0.5f * (cam->eye[i] - cam->target[i]);
	}
	return t;
}

/* Pixels of window f that differ from their pixel of the whole render,
 * the first few printed. */
static uint32_t diff_crop(const struct bc_frame *f,
                          const struct bc_frame *whole, const char *what)
{
	uint32_t bad = 0;
	for (uint32_t y = 0; y < f->height; y++) {
		for (uint32_t x = 0; x < f->width; x++) {
			size_t i = (size_t)y * f->width + x;
			size_t j = (size_t)(f->win_y + y) * whole->width +
			           f->win_x + x;
			if (pixel_equal_at(f, i, whole, j)) {
				continue;
			}
			if (bad++ < 4) {
				fprintf(stderr,
				        "  %s: pixel (%u, %u) of the view: "
				        "depth %.9g vs %.9g, id %u vs %u, "
				        "rgb %u,%u,%u vs %u,%u,%u\n",
				        what, f->win_x + x, f->win_y + y,
				        (double)f->depth[i],
				        (double)whole->depth[j], f->ids[i],
				        whole->ids[j], f->rgba[4 * i],
				        f->rgba[4 * i + 1], f->rgba[4 * i + 2],
				        whole->rgba[4 * j],
				        whole->rgba[4 * j + 1],
				        whole->rgba[4 * j + 2]);
			}
		}
	}
	if (bad) {
		fprintf(stderr, "  %s: %u of %u pixels differ\n", what, bad,
		        f->width * f->height);
	}
	return bad;
}

/* Fills every plane with a pattern no render writes. */
static void fill_sentinel(struct bc_frame *f)
{
	size_t n = (size_t)f->width * f->height;
	memset(f->rgba, 0x5a, 4 * n);
	for (size_t i = 0; i < n; i++) {
		f->depth[i] = -1.0f;
		f->ids[i] = 0xdeadbeefu;
	}
}

/* Renders window w of the view into a fresh frame, whole or refined from
 * level 3 to 0, and compares it with the crop of `whole`. */
static void check_window(struct bc_renderer *r, const struct setup *s,
                         const struct bc_camera *cam,
                         const struct bc_frame *whole, struct win w,
                         bool refined)
{
	struct bc_frame f = {0};
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	char what[96];
	snprintf(what, sizeof(what), "%s %ux%u at (%u, %u)%s", s->label, w.w,
	         w.h, w.x, w.y, refined ? " refined" : "");
	REQUIRE(bc_frame_init(&f, w.w, w.h) == 0);
	REQUIRE(bc_frame_window(&f, w.x, w.y, FULL_W, FULL_H) == 0);
	fill_sentinel(&f);
	if (!refined) {
		CHECK(bc_renderer_render(r, cam, &f, &st, &ei) == 0);
		CHECK_EQ_INT(st.rays, (uint64_t)w.w * w.h);
	} else {
		uint64_t rays = 0;
		for (int level = (int)BC_RENDER_MAX_LEVEL; level >= 0;
		     level--) {
			struct bc_render_region rg = {
			    .level = (uint32_t)level,
			    .refine = level != (int)BC_RENDER_MAX_LEVEL};
			CHECK(bc_renderer_render_region(r, cam, &f, &rg, &st,
			                                &ei) == 0);
			CHECK(!st.whole);
			rays += st.rays;
		}
		CHECK_EQ_INT(rays, (uint64_t)w.w * w.h);
	}
	CHECK(!st.incomplete);
	CHECK_EQ_INT(diff_crop(&f, whole, what), 0);

	bc_frame_finish(&f);
}

static void test_windows_equal_the_whole_render(void)
{
	struct bc_camera cam;
	struct bc_tree *t = make_scene(&cam);
	int ran = 0;
	REQUIRE(t);
	for (size_t k = 0; k < sizeof(setups) / sizeof(setups[0]); k++) {
		const struct setup *s = &setups[k];
		struct bc_renderer *r = open_setup(s, t);
		struct bc_frame whole = {0};
		struct bc_errinfo ei = {0};
		double t0;
		if (!r) {
			continue;
		}
		ran++;
		t0 = now_s();
		if (bc_frame_init(&whole, FULL_W, FULL_H) != 0 ||
		    bc_renderer_render(r, &cam, &whole, NULL, &ei) != 0) {
			fprintf(stderr, "  %s: whole render: %s\n", s->label,
			        ei.msg);
			bc_test_failures++;
		} else {
			/* Surfaces and background both, so the windows
			 * compare shading, depth, ids and the gradient. */
			uint32_t hits = 0;
			for (size_t i = 0; i < (size_t)FULL_W * FULL_H; i++) {
				hits += whole.ids[i] != 0;
			}
			CHECK(hits > FULL_W * FULL_H / 2);
			CHECK(hits < FULL_W * FULL_H);
			for (size_t i = 0;
			     i < sizeof(windows) / sizeof(windows[0]); i++) {
				if (s->backend == BC_BACKEND_NAIVE &&
				    windows[i].w == FULL_W) {
					continue; /* the slowest: time */
				}
				check_window(r, s, &cam, &whole, windows[i],
				             false);
			}
			/* Levels count in the window's pixels: at an
			 * origin of a multiple of 8 they are the view's. */
			check_window(r, s, &cam, &whole, windows[4], true);
			if (s->backend == BC_BACKEND_NAIVE) {
				/* Each pixel its own ray: any origin. */
				check_window(r, s, &cam, &whole,
				             (struct win){13, 7, 50, 33},
				             false);
				check_window(r, s, &cam, &whole,
				             (struct win){199, 119, 1, 1},
				             false);
			}
		}
		fprintf(stderr, "  %-16s %.2f s\n", s->label, now_s() - t0);
		bc_frame_finish(&whole);
		bc_renderer_destroy(r);
	}
	bc_tree_destroy(t);
	if (!ran) {
		BC_SKIP("no backend built in");
	}
}

/* A region drawn into a frame rendered as another window (or as the
 * whole view) draws the whole frame: the key holds the window. */
static void test_key_follows_the_window(void)
{
	struct bc_camera cam;
	struct bc_tree *t = make_scene(&cam);
	struct bc_renderer *r = NULL;
	struct bc_frame f = {0};
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	uint8_t tiles[12 * 8];
	struct bc_render_region rg = {.tiles = tiles};
	uint64_t k_whole, k_a;
	REQUIRE(t);
	r = open_setup(&setups[1], t); /* tiled */
	if (!r) {
		bc_tree_destroy(t);
		BC_SKIP("tiled is not built in");
	}
	memset(tiles, 0, sizeof(tiles));
	tiles[0] = 1;
	REQUIRE(bc_frame_init(&f, 96, 64) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, NULL, &ei) == 0);
	k_whole = f.key;
	CHECK(k_whole != 0);
	/* Setting a window forgets what the frame held. */
	REQUIRE(bc_frame_window(&f, 8, 16, FULL_W, FULL_H) == 0);
	CHECK_EQ_INT(f.key, 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, NULL, &ei) == 0);
	k_a = f.key;
	CHECK(k_a != 0 && k_a != k_whole);
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(!st.whole);
	CHECK_EQ_INT(f.key, k_a);
	/* The window moved behind bc_frame_window's back (the key kept):
	 * the region becomes the whole frame. */
	f.win_x = 16;
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK(f.key != k_a && f.key != 0);
	/* So does the same window of a view of another size. */
	k_a = f.key;
	f.full_height = FULL_H + 8;
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK(f.key != k_a);
	/* And back to the whole view: the key of a plain frame. */
	REQUIRE(bc_frame_window(&f, 0, 0, 0, 0) == 0);
	CHECK_EQ_INT(f.full_width, 0);
	CHECK_EQ_INT(f.win_x, 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, NULL, &ei) == 0);
	CHECK_EQ_INT(f.key, k_whole);
	bc_frame_finish(&f);
	bc_renderer_destroy(r);
	bc_tree_destroy(t);
}

static void test_frame_window_range(void)
{
	struct bc_frame f = {0};
	struct bc_camera cam;
	struct bc_tree *t = make_scene(&cam);
	struct bc_renderer *r = NULL;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	REQUIRE(bc_frame_init(&f, 64, 48) == 0);
	f.key = 42;
	/* Inside, up to the view's edges. */
	CHECK_EQ_INT(bc_frame_window(&f, 136, 72, FULL_W, FULL_H), 0);
	CHECK_EQ_INT(f.key, 0);
	CHECK_EQ_INT(f.win_x, 136);
	CHECK_EQ_INT(f.win_y, 72);
	CHECK_EQ_INT(f.full_width, FULL_W);
	CHECK_EQ_INT(f.full_height, FULL_H);
	CHECK_EQ_INT(bc_frame_window(&f, 0, 0, 64, 48), 0);
	CHECK_EQ_INT(bc_frame_window(&f, BC_RENDER_MAX_DIM - 64,
	                             BC_RENDER_MAX_DIM - 48, BC_RENDER_MAX_DIM,
	                             BC_RENDER_MAX_DIM),
	             0);
	/* Past an edge, by one pixel or by wrapping around. */
	CHECK_EQ_INT(bc_frame_window(&f, 137, 72, FULL_W, FULL_H), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, 136, 73, FULL_W, FULL_H), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, FULL_W, 0, FULL_W, FULL_H), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, 0, FULL_H, FULL_W, FULL_H), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, UINT32_MAX, 0, FULL_W, FULL_H),
	             BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, 0, 0, 63, 48), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, 0, 0, 64, 47), BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, 0, 0, 64, 0), BC_ERANGE);
	/* A view over the largest frame. */
	CHECK_EQ_INT(bc_frame_window(&f, 0, 0, BC_RENDER_MAX_DIM + 1, FULL_H),
	             BC_ERANGE);
	CHECK_EQ_INT(bc_frame_window(&f, 0, 0, FULL_W, BC_RENDER_MAX_DIM + 1),
	             BC_ERANGE);
	/* A refused window leaves the last one. */
	CHECK_EQ_INT(f.win_x, BC_RENDER_MAX_DIM - 64);
	CHECK_EQ_INT(f.full_width, BC_RENDER_MAX_DIM);
	/* The front refuses a window set by hand that does not fit. */
	r = open_setup(&setups[0], t);
	if (r) {
		REQUIRE(bc_frame_window(&f, 136, 72, FULL_W, FULL_H) == 0);
		CHECK_EQ_INT(bc_renderer_render(r, &cam, &f, NULL, &ei), 0);
		f.win_x = 137;
		CHECK_EQ_INT(bc_renderer_render(r, &cam, &f, NULL, &ei),
		             BC_EINVAL);
		f.win_x = 136;
		f.full_height = 0;
		CHECK_EQ_INT(bc_renderer_render(r, &cam, &f, NULL, &ei),
		             BC_EINVAL);
		f.full_height = FULL_H;
		f.full_width = BC_RENDER_MAX_DIM + 1;
		CHECK_EQ_INT(bc_renderer_render(r, &cam, &f, NULL, &ei),
		             BC_EINVAL);
		bc_renderer_destroy(r);
	}
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

/* ---- A-buffer bands ----------------------------------------------------- */

/* A renderer of s whose A-buffer holds at most `limit` primitive-tile
 * pairs at once (0: the backend's own limit), synced to t; NULL when it
 * cannot be made (a sync that fails is a failure). */
static struct bc_renderer *open_limited(const struct setup *s, uint32_t limit,
                                        const struct bc_tree *t)
{
	struct bc_render_opts o = {.simd = s->simd, .abuffer_limit = limit};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, s->backend, &o, &ei)) {
		fprintf(stderr, "  %s, limit %u: %s\n", s->label, limit,
		        ei.msg);
		return NULL;
	}
	if (bc_renderer_sync(r, t, NULL, &ei)) {
		fprintf(stderr, "  %s, limit %u: sync: %s\n", s->label, limit,
		        ei.msg);
		bc_test_failures++;
		bc_renderer_destroy(r);
		return NULL;
	}
	return r;
}

/* Pixels of f that differ from whole in tiles [a, z) or from the
 * sentinel outside them. */
static uint32_t diff_tile_range(const struct bc_frame *f,
                                const struct bc_frame *whole, uint32_t a,
                                uint32_t z)
{
	static const uint8_t sentinel_rgba[4] = {0x5a, 0x5a, 0x5a, 0x5a};
	uint32_t bad = 0, tw = bc_render_tiles_x(f->width);
	for (uint32_t y = 0; y < f->height; y++) {
		for (uint32_t x = 0; x < f->width; x++) {
			size_t i = (size_t)y * f->width + x;
			uint32_t t =
			    (y / BC_RENDER_TILE) * tw + x / BC_RENDER_TILE;
			bool ok = t >= a && t < z
			              ? pixel_equal(f, whole, i)
			              : memcmp(f->rgba + 4 * i, sentinel_rgba,
			                       4) == 0 &&
			                    f->depth[i] == -1.0f &&
			                    f->ids[i] == 0xdeadbeefu;
			bad += !ok;
		}
	}
	return bad;
}

/* Draws tiles [a, z) of the view into f, then the NEXT_TILES after them
 * (the daemon's next slice, in the row the first call's band ended
 * with: drawn from the lists that call kept), and returns the pixels
 * that differ from whole in [a, z + NEXT_TILES) or from the sentinel
 * elsewhere. */
#define NEXT_TILES 5u

static uint32_t draw_ranges(struct bc_renderer *r, const struct bc_camera *cam,
                            struct bc_frame *f, const struct bc_frame *whole,
                            uint32_t a, uint32_t z)
{
	struct bc_errinfo ei = {0};
	struct bc_render_stats st;
	uint32_t bad = 0;
	fill_sentinel(f);
	f->key = 0;
	uint8_t *tiles = calloc((size_t)bc_render_tiles_x(f->width) *
	                            bc_render_tiles_y(f->height),
	                        1);
	if (!tiles) {
		return UINT32_MAX;
	}
	for (int i = 0; i < 2; i++) {
		/* The range as a mask too: gl draws the tiles of a mask. */
		struct bc_render_region rg = {.tiles = tiles,
		                              .tile_first = i ? z : a,
		                              .tile_count =
		                                  i ? NEXT_TILES : z - a,
		                              .adopt_key = true};
		memset(tiles + a, 0, z - a);
		memset(tiles + rg.tile_first, 1, rg.tile_count);
		if (bc_renderer_render_region(r, cam, f, &rg, &st, &ei) != 0) {
			fprintf(stderr, "  range: %s\n", ei.msg);
			free(tiles);
			return UINT32_MAX;
		}
		bad += st.whole;
	}
	free(tiles);
	return bad + diff_tile_range(f, whole, a, z + NEXT_TILES);
}

/* Moves the scene's k-th primitive by a fraction of the scene's size. */
static int move_prim(struct bc_tree *t, uint32_t k, float by)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t id = l->node_id[l->prim_slot[k % l->nprims]];
	struct bc_prim_data p;
	if (!bc_tree_get(t, id, &p, NULL)) {
		return BC_ENONODE;
	}
	p.translate[k % 3] += by * l->size;
	return bc_tree_set_prim(t, id, &p, NULL);
}

/* A view whose tile lists pass the A-buffer's limit is drawn in bands of
 * tile rows (opts.abuffer_limit lowers the limit to this small scene's
 * size), in tiled (vector kernels off and on) and in gl where a context
 * can be made: whole, refined, as a range of tiles and after parameter
 * and structural edits synced with their dirty ranges, the pixels equal a
 * renderer's of the same backend that holds every list at once, bit for
 * bit. A tile row whose lists alone pass the limit is refused with
 * BC_ELIMIT. */
static void test_abuffer_bands_equal_one_pass(void)
{
	static const struct setup *const banded[] = {&setups[1], &setups[2],
	                                             &setups[4]};
	struct bc_camera cam;
	struct bc_tree *t = make_scene(&cam);
	struct bc_frame f = {0}, g = {0};
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	if (!bc_backend_available(BC_BACKEND_TILED)) {
		bc_tree_destroy(t);
		BC_SKIP("tiled is not built in");
	}
	REQUIRE(bc_frame_init(&f, FULL_W, FULL_H) == 0);
	REQUIRE(bc_frame_init(&g, FULL_W, FULL_H) == 0);
	for (size_t s = 0; s < sizeof(banded) / sizeof(banded[0]); s++) {
		const struct setup *su = banded[s];
		struct bc_renderer *ref = open_limited(su, 0, t), *r;
		uint32_t limit = 16, a = 2 * 25 + 3, z = a + 60;
		uint64_t rays = 0;
		if (!ref && su->backend == BC_BACKEND_GL) {
			continue; /* no context here: said above */
		}
		REQUIRE(ref);
		REQUIRE(bc_renderer_render(ref, &cam, &g, &st, &ei) == 0);
		CHECK_EQ_INT(st.bands, 1);
		/* The smallest power of two the busiest row fits in. */
		for (;; limit *= 2) {
			REQUIRE(limit <= (1u << 20));
			REQUIRE((r = open_limited(su, limit, t)));
			int rc = bc_renderer_render(r, &cam, &f, &st, &ei);
			if (rc == 0) {
				break;
			}
			CHECK_EQ_INT(rc, BC_ELIMIT);
			CHECK(strstr(ei.msg, "tile row") != NULL);
			ei = (struct bc_errinfo){0};
			bc_renderer_destroy(r);
		}
		CHECK(limit > 16);
		/* With room to spare for the edits below. */
		bc_renderer_destroy(r);
		REQUIRE((r = open_limited(su, 2 * limit, t)));
		fill_sentinel(&f);
		REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
		CHECK(st.bands >= 3);
		CHECK_EQ_INT(st.rays, (uint64_t)FULL_W * FULL_H);
		CHECK_EQ_INT(diff_crop(&f, &g, "bands, whole"), 0);
		fprintf(stderr, "  %s: limit %u, %u bands\n", su->label,
		        2 * limit, st.bands);
		/* Refined from level 3: each level's call in bands. */
		fill_sentinel(&f);
		f.key = 0;
		for (int level = (int)BC_RENDER_MAX_LEVEL; level >= 0;
		     level--) {
			struct bc_render_region rg = {
			    .level = (uint32_t)level,
			    .refine = level != (int)BC_RENDER_MAX_LEVEL};
			CHECK(bc_renderer_render_region(r, &cam, &f, &rg, &st,
			                                &ei) == 0);
			rays += st.rays;
		}
		CHECK_EQ_INT(rays, (uint64_t)FULL_W * FULL_H);
		CHECK_EQ_INT(diff_crop(&f, &g, "bands, refined"), 0);
		/* Ranges of tiles starting and ending inside a row. */
		CHECK_EQ_INT(draw_ranges(r, &cam, &f, &g, a, z), 0);
		/* Parameter edits (the kept rectangles follow the dirty
		 * primitives), then a structural one alone (a splice that
		 * leaves no dirty primitive). */
		for (uint32_t i = 0; i < 9; i++) {
			struct bc_dirty dirty;
			char what[48];
			if (i < 8) {
				REQUIRE(move_prim(t, 5 * i + (uint32_t)s,
				                  i % 2 ? 0.12f : -0.15f) == 0);
			} else {
				const struct bc_lin *l = bc_tree_lin(t);
				REQUIRE(bc_tree_remove(
				            t, l->node_id[l->prim_slot[3]],
				            NULL) == 0);
			}
			bc_tree_take_dirty(t, &dirty);
			REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) == 0);
			REQUIRE(bc_renderer_sync(ref, t, NULL, &ei) == 0);
			REQUIRE(bc_renderer_render(ref, &cam, &g, NULL, &ei) ==
			        0);
			/* Ranges first: the band the ranges kept before the
			 * edit must not be drawn from. */
			CHECK_EQ_INT(draw_ranges(r, &cam, &f, &g, a, z), 0);
			REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
			CHECK(st.bands >= 2);
			snprintf(what, sizeof(what), "bands, edit %u", i);
			CHECK_EQ_INT(diff_crop(&f, &g, what), 0);
			/* The ranges' band is kept for the next edit. */
			CHECK_EQ_INT(draw_ranges(r, &cam, &f, &g, a, z), 0);
		}
		bc_renderer_destroy(r);
		bc_renderer_destroy(ref);
	}
	bc_frame_finish(&f);
	bc_frame_finish(&g);
	bc_tree_destroy(t);
}

/* A banded view whose calls draw a few tile rows at a time (the
 * daemon's slices) keeps a row index of its primitives; a drag's moves
 * patch it (the rows the moved primitives' old and new rectangles hold),
 * where it was sorted again from every primitive at each edit. After
 * each of a drag's moves, ranges of two tile rows here and there equal a
 * one-pass renderer's whole frame, bit for bit. */
static void test_bands_follow_a_drag(void)
{
	static const struct setup *const banded[] = {&setups[1], &setups[2]};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_frame f = {0}, g = {0};
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	const uint32_t w = 160, h = 480, tw = w / 8, th = h / 8;
	REQUIRE(t && sc_fig18(t, 400, false, true, 5) == 0);
	sc_frame(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&f, w, h) == 0 && bc_frame_init(&g, w, h) == 0);
	for (size_t s = 0; s < sizeof(banded) / sizeof(banded[0]); s++) {
		const struct setup *su = banded[s];
		struct bc_renderer *ref = open_limited(su, 0, t), *r = NULL;
		uint32_t limit = 64;
		REQUIRE(ref);
		REQUIRE(bc_renderer_render(ref, &cam, &g, &st, &ei) == 0);
		/* Twice the smallest power of two the busiest row fits. */
		for (;; limit *= 2) {
			REQUIRE(limit <= (1u << 22));
			REQUIRE((r = open_limited(su, limit, t)));
			if (bc_renderer_render(r, &cam, &f, &st, &ei) == 0) {
				break;
			}
			ei = (struct bc_errinfo){0};
			bc_renderer_destroy(r);
		}
		bc_renderer_destroy(r);
		REQUIRE((r = open_limited(su, 2 * limit, t)));
		REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
		CHECK(st.bands >= 3);
		for (uint32_t i = 0; i < 16; i++) {
			struct bc_dirty dirty;
			uint32_t y = (7u * i) % (th - 2), a = y * tw;
			if (i > 0) {
				REQUIRE(move_prim(t, 37u * i,
				                  i % 2 ? 0.03f : -0.04f) == 0);
				bc_tree_take_dirty(t, &dirty);
				REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) ==
				        0);
				REQUIRE(bc_renderer_sync(ref, t, NULL, &ei) ==
				        0);
				REQUIRE(bc_renderer_render(ref, &cam, &g, NULL,
				                           &ei) == 0);
			}
			if (draw_ranges(r, &cam, &f, &g, a,
			                a + 2 * tw - NEXT_TILES) != 0) {
				fprintf(stderr,
				        "  %s: move %u, rows %u-%u differ\n",
				        su->label, i, y, y + 1);
				bc_test_failures++;
			}
		}
		bc_renderer_destroy(r);
		bc_renderer_destroy(ref);
	}
	bc_frame_finish(&f);
	bc_frame_finish(&g);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"abuffer_bands_equal_one_pass", test_abuffer_bands_equal_one_pass},
    {"bands_follow_a_drag", test_bands_follow_a_drag},
    {"frame_window_range", test_frame_window_range},
    {"key_follows_the_window", test_key_follows_the_window},
    {"windows_equal_the_whole_render", test_windows_equal_the_whole_render},
};

BC_TEST_MAIN(tests)
