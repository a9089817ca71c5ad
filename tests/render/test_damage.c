/*
 * Edit-local rendering and progressive refinement, proved exact on the CPU
 * backends (tiled, naive, svo) through the front (blobcast/render.h) only.
 *
 * Damage: thousands of random parameter edits (move, resize, rotate and
 * recolour a primitive; change an operator's blend, range or kind) on the
 * generator families and on random trees. After each edit only the tiles
 * bc_renderer_damage marks for the changed primitives' old and new ABVs are
 * redrawn into the previous frame, and the result must equal a whole render
 * of the new state bit for bit: rgba, depth (memcmp, so NaN and infinity
 * patterns count) and ids. A single differing pixel fails, with the edit
 * and whether its tile was marked. naive and svo mark every tile by design,
 * so for them a random subset of tiles is also drawn into a stale frame:
 * drawn tiles must equal the whole render, the others must keep the stale
 * pixels.
 *
 * Groups: edits that move up to 1024 neighbouring spheres of 4096 at
 * once (the tiled backend patches the candidates of their tiles where that
 * costs less than building every tile's) are drawn the same way and must
 * equal a whole render too.
 *
 * Regions: pixels outside a region are left alone (a sentinel survives),
 * and a region into a frame of another rendering (fresh frame, new camera,
 * structural change, scene scale) draws the whole frame instead.
 *
 * Refinement: levels 3, 2, 1, 0 (the last three with refine) trace every
 * pixel exactly once and assemble the whole render, bit for bit.
 *
 * The edit counts keep the file near a minute in a sanitizer build;
 * BLOBCAST_DAMAGE_SOAK=N in the environment multiplies them (at most 1000)
 * for a long soak run, with a fresh sequence of edits.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "test.h"

#include "blobtree/randtree.h"
#include "compare.h"
#include "group.h"

/* ---- Small helpers ------------------------------------------------------ */

/* The test's own PRNG (randtree.h's state is reset by rt_build). */
static uint64_t dmg_state = 0x5eed0001u;

static uint64_t dmg_next(void)
{
	uint64_t z = (dmg_state += 0x9e3779b97f4a7c15ull);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

static float dmg_float(float lo, float hi)
{
	return lo + (hi - lo) * (float)(dmg_next() >> 40) / (float)(1u << 24);
}

static uint32_t dmg_below(uint32_t n)
{
	return (uint32_t)(dmg_next() % n);
}

static void dmg_quat(float q[4])
{
	float n;
	do {
		n = 0.0f;
		for (int i = 0; i < 4; i++) {
			q[i] = dmg_float(-1.0f, 1.0f);
			n += q[i] * q[i];
		}
	} while (n < 0.05f || n > 1.0f);
	n = sqrtf(n);
	for (int i = 0; i < 4; i++) {
		q[i] /= n;
	}
}

/* A camera on the scene's AABB from the front, a little from above and
 * the right, filling most of a 40 degree field of view. */
static void frame_scene(const struct bc_lin *l, struct bc_camera *cam)
{
	float r = 0.5f * l->size;
	float dir[3] = {0.35f, 0.45f, 1.0f};
	float n = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
	float dist = 0.75f * r / sinf(20.0f * 3.14159265f / 180.0f);
	bc_camera_default(cam);
	for (int i = 0; i < 3; i++) {
		float c = 0.5f * (l->lo[i] + l->hi[i]);
		cam->target[i] = c;
		cam->eye[i] = c + dir[i] / n * dist;
	}
	cam->fov_y_deg = 40.0f;
}

/* Wall-clock seconds, for the summary lines. */
static double now_s(void)
{
	struct timespec ts;
	if (timespec_get(&ts, TIME_UTC) != TIME_UTC) {
		return 0.0;
	}
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static size_t npix(const struct bc_frame *f)
{
	return (size_t)f->width * f->height;
}

static size_t ntiles(uint32_t w, uint32_t h)
{
	return (size_t)bc_render_tiles_x(w) * bc_render_tiles_y(h);
}

static size_t tile_of(uint32_t w, uint32_t x, uint32_t y)
{
	return (size_t)(y / BC_RENDER_TILE) * bc_render_tiles_x(w) +
	       x / BC_RENDER_TILE;
}

/* Copies every plane and the key of src into dst (same size). */
static void copy_frame(struct bc_frame *dst, const struct bc_frame *src)
{
	size_t n = npix(src);
	memcpy(dst->rgba, src->rgba, 4 * n);
	memcpy(dst->depth, src->depth, n * sizeof(*dst->depth));
	memcpy(dst->ids, src->ids, n * sizeof(*dst->ids));
	dst->key = src->key;
}

/* A pattern no renderer writes: odd bytes, a NaN with a payload, an id no
 * scene here has. The key is left as it is. */
static void fill_sentinel(struct bc_frame *f)
{
	uint32_t nan_bits = 0x7fc0beefu;
	float nan;
	memcpy(&nan, &nan_bits, sizeof(nan));
	memset(f->rgba, 0xa5, 4 * npix(f));
	for (size_t i = 0; i < npix(f); i++) {
		f->depth[i] = nan;
		f->ids[i] = 0xdeadbeefu;
	}
}

static void print_pixel(const char *what, const struct bc_frame *f, size_t i)
{
	uint32_t bits;
	memcpy(&bits, &f->depth[i], sizeof(bits));
	fprintf(stderr,
	        "    %-6s rgba %3u %3u %3u %3u depth %.9g (0x%08x) id %u\n",
	        what, f->rgba[4 * i], f->rgba[4 * i + 1], f->rgba[4 * i + 2],
	        f->rgba[4 * i + 3], (double)f->depth[i], bits, f->ids[i]);
}

/* Pixels of got that differ from want; the first is reported with what
 * and, when tiles is given, whether its tile was marked. */
static uint64_t diff_frames(const struct bc_frame *got,
                            const struct bc_frame *want, const uint8_t *tiles,
                            const char *what)
{
	uint64_t bad = 0;
	for (uint32_t y = 0; y < got->height; y++) {
		for (uint32_t x = 0; x < got->width; x++) {
			size_t i = (size_t)y * got->width + x;
			if (pixel_equal(got, want, i)) {
				continue;
			}
			if (bad++ == 0) {
				fprintf(stderr,
				        "  %s: first differing pixel (%u, %u) "
				        "of %ux%u, tile %zu %s\n",
				        what, x, y, got->width, got->height,
				        tile_of(got->width, x, y),
				        !tiles ? "(no mask)"
				        : tiles[tile_of(got->width, x, y)]
				            ? "marked"
				            : "NOT marked");
				print_pixel("got", got, i);
				print_pixel("want", want, i);
			}
		}
	}
	return bad;
}

/* Draws the tiles marked in tiles into f (a region render), which must
 * finish; false (and a failed check) when it cannot. */
static bool draw_marked(struct bc_renderer *r, const struct bc_camera *cam,
                        struct bc_frame *f, uint8_t *tiles,
                        struct bc_render_stats *st)
{
	struct bc_errinfo ei = {0};
	if (bc_renderer_render_region(
	        r, cam, f, &(struct bc_render_region){.tiles = tiles}, st,
	        &ei)) {
		fprintf(stderr, "  region: %s\n", ei.msg);
		CHECK(0 && "region render");
		return false;
	}
	CHECK(!st->incomplete);
	return true;
}

/* ---- Scenes ------------------------------------------------------------- */

/* A generated scene (gen), or a random tree of randtree.h (rt_prims > 0),
 * rendered at w x h (0: both 61x47 and 96x64) with `edits` random edits
 * on tiled. */
struct scene {
	const char *label;
	const char *gen;
	struct bc_gen_opts opts;
	uint32_t rt_prims;
	uint64_t rt_seed;
	uint32_t w, h;
	uint32_t edits; /* on tiled; naive and svo do a fraction */
	bool fig18;     /* counts towards the usefulness of damage */
};

#define SHARP BC_GEN_BLEND_SHARP
#define SMOOTH BC_GEN_BLEND_SMOOTH
#define SPHERES BC_GEN_KIND_SPHERES
#define BOXES BC_GEN_KIND_BOXES

static const struct scene scenes[] = {
    {.label = "fig18 spheres sharp",
     .gen = "fig18",
     .opts = {.count = 24, .seed = 1, .kind = SPHERES, .blend = SHARP},
     .w = 61,
     .h = 47,
     .edits = 260,
     .fig18 = true},
    {.label = "fig18 spheres smooth",
     .gen = "fig18",
     .opts = {.count = 24, .seed = 2, .kind = SPHERES, .blend = SMOOTH},
     .w = 96,
     .h = 64,
     .edits = 220,
     .fig18 = true},
    {.label = "fig18 boxes sharp",
     .gen = "fig18",
     .opts = {.count = 24, .seed = 3, .kind = BOXES, .blend = SHARP},
     .w = 96,
     .h = 64,
     .edits = 200,
     .fig18 = true},
    {.label = "fig18 boxes smooth",
     .gen = "fig18",
     .opts = {.count = 24, .seed = 4, .kind = BOXES, .blend = SMOOTH},
     .w = 61,
     .h = 47,
     .edits = 220,
     .fig18 = true},
    {.label = "fig16 L1 sharp",
     .gen = "fig16",
     .opts = {.level = 1, .blend = SHARP},
     .w = 61,
     .h = 47,
     .edits = 150},
    {.label = "fig16 L1 smooth",
     .gen = "fig16",
     .opts = {.level = 1, .blend = SMOOTH},
     .w = 96,
     .h = 64,
     .edits = 150},
    {.label = "fig16 L2 smooth",
     .gen = "fig16",
     .opts = {.level = 2, .blend = SMOOTH},
     .w = 61,
     .h = 47,
     .edits = 100},
    {.label = "comb smooth",
     .gen = "comb",
     .opts = {.count = 16, .blend = SMOOTH},
     .w = 96,
     .h = 64,
     .edits = 140},
    {.label = "comb sharp",
     .gen = "comb",
     .opts = {.count = 16, .blend = SHARP},
     .w = 61,
     .h = 47,
     .edits = 120},
    {.label = "gears",
     .gen = "gears",
     .opts = {.teeth = 6},
     .w = 96,
     .h = 64,
     .edits = 140},
    {.label = "many-spheres",
     .gen = "many-spheres",
     .opts = {.count = 40, .seed = 5},
     .w = 61,
     .h = 47,
     .edits = 160},
    {.label = "random",
     .gen = "random",
     .opts = {.count = 20, .seed = 6},
     .w = 96,
     .h = 64,
     .edits = 160},
    {.label = "randtree 12", .rt_prims = 12, .rt_seed = 7, .edits = 150},
    {.label = "randtree 16",
     .rt_prims = 16,
     .rt_seed = 8,
     .w = 96,
     .h = 64,
     .edits = 160},
};

/* Indices into scenes[] of the scenes the other tests reuse. */
#define SCENE_FIG18_SPHERES_SHARP 0
#define SCENE_FIG18_SPHERES_SMOOTH 1
#define SCENE_GEARS 9
#define SCENE_RANDTREE_16 13

static int build_scene(const struct scene *s, struct bc_tree *t)
{
	struct bc_errinfo ei = {0};
	int rc;
	struct bc_dirty dirty;
	if (s->rt_prims > 0) {
		rc = rt_build(t, s->rt_seed, s->rt_prims);
	} else if ((rc = bc_gen(s->gen, &s->opts, t, NULL, &ei))) {
		fprintf(stderr, "  %s: %s\n", s->label, ei.msg);
	}
	/* The build itself is a structural change: taken here, so that the
	 * first edit's dirty set holds that edit alone. */
	bc_tree_take_dirty(t, &dirty);
	return rc;
}

/* Every node id of t, pre-order, into ids (at most cap). Returns the count. */
static uint32_t collect_ids(const struct bc_tree *t, uint32_t *ids,
                            uint32_t cap)
{
	uint32_t n = 0, done = 0;
	if (bc_tree_root(t) == 0 || cap == 0) {
		return 0;
	}
	ids[n++] = bc_tree_root(t);
	/* Breadth first, using ids itself as the queue. */
	while (done < n) {
		uint32_t id = ids[done++];
		uint32_t nc = bc_tree_child_count(t, id);
		for (uint32_t k = 0; k < nc && n < cap; k++) {
			ids[n++] = bc_tree_child(t, id, k);
		}
	}
	return n;
}

/* ---- Random parameter edits --------------------------------------------- */

enum edit_kind {
	EDIT_INVALID = 0,
	EDIT_MOVE,
	EDIT_RESIZE,
	EDIT_ROTATE,
	EDIT_COLOUR,
	EDIT_BLEND,
	EDIT_RANGE,
	EDIT_OP_KIND,
	EDIT_COUNT
};

static const char *const edit_names[EDIT_COUNT] = {
    [EDIT_MOVE] = "move",       [EDIT_RESIZE] = "resize",
    [EDIT_ROTATE] = "rotate",   [EDIT_COLOUR] = "colour",
    [EDIT_BLEND] = "blend",     [EDIT_RANGE] = "range",
    [EDIT_OP_KIND] = "op kind",
};

struct edit {
	uint32_t id;
	enum edit_kind kind;
	bool is_prim;
	char desc[200];
};

/* Picks a random node of ids[0..n) and applies a random parameter edit to
 * it. Returns 0 when applied, else the tree's error (an invalid edit,
 * which the caller skips). */
static int random_edit(struct bc_tree *t, const uint32_t *ids, uint32_t n,
                       float size, struct edit *e)
{
	struct bc_prim_data p;
	struct bc_op_data o;
	memset(e, 0, sizeof(*e));
	e->id = ids[dmg_below(n)];
	if (!bc_tree_get(t, e->id, &p, &o)) {
		return BC_ENONODE;
	}
	if (p.kind != BC_PRIM_INVALID) {
		const struct bc_prim_info *info = bc_prim_info(p.kind);
		e->is_prim = true;
		e->kind = (enum edit_kind)(EDIT_MOVE + dmg_below(4));
		switch (e->kind) {
		case EDIT_MOVE: {
			/* Mostly small moves, sometimes across the scene. */
			float reach = dmg_below(4) ? 0.05f : 0.4f;
			for (int i = 0; i < 3; i++) {
				p.translate[i] +=
				    dmg_float(-reach, reach) * size;
			}
			snprintf(e->desc, sizeof(e->desc),
			         "%s %u: move to (%g, %g, %g)", info->name,
			         e->id, (double)p.translate[0],
			         (double)p.translate[1],
			         (double)p.translate[2]);
			break;
		}
		case EDIT_RESIZE: {
			float s = dmg_float(0.7f, 1.35f);
			if (dmg_below(2) && info->nparams > 0) {
				/* One component of one parameter. */
				const struct bc_param_desc *d =
				    &info->params[dmg_below(info->nparams)];
				uint32_t c = d->offset + dmg_below(d->count);
				if (p.params[c] == 0.0f) {
					p.params[c] = 0.02f * size;
				} else {
					p.params[c] *= s;
				}
				snprintf(e->desc, sizeof(e->desc),
				         "%s %u: %s[%u] = %g", info->name,
				         e->id, d->name, c - d->offset,
				         (double)p.params[c]);
			} else {
				/* The whole shape, uniformly. */
				for (uint32_t i = 0; i < info->nparams; i++) {
					const struct bc_param_desc *d =
					    &info->params[i];
					for (uint32_t c = 0; c < d->count;
					     c++) {
						p.params[d->offset + c] *= s;
					}
				}
				snprintf(e->desc, sizeof(e->desc),
				         "%s %u: scale by %g", info->name,
				         e->id, (double)s);
			}
			break;
		}
		case EDIT_ROTATE:
			dmg_quat(p.rotate);
			snprintf(e->desc, sizeof(e->desc),
			         "%s %u: rotate to (%g, %g, %g, %g)",
			         info->name, e->id, (double)p.rotate[0],
			         (double)p.rotate[1], (double)p.rotate[2],
			         (double)p.rotate[3]);
			break;
		default:
			e->kind = EDIT_COLOUR;
			p.has_color = true;
			for (int i = 0; i < 3; i++) {
				p.color[i] = dmg_float(0.0f, 1.0f);
			}
			snprintf(e->desc, sizeof(e->desc),
			         "%s %u: colour (%g, %g, %g)", info->name,
			         e->id, (double)p.color[0], (double)p.color[1],
			         (double)p.color[2]);
			break;
		}
		return bc_tree_set_prim(t, e->id, &p, NULL);
	}
	e->kind = (enum edit_kind)(EDIT_BLEND + dmg_below(3));
	if (!bc_op_is_smooth(o.kind)) {
		e->kind = EDIT_OP_KIND;
	}
	switch (e->kind) {
	case EDIT_BLEND: {
		/* Half the time the range follows, half it stays (and may
		 * fall under blend / 6: then the edit is refused). */
		float s = dmg_float(0.5f, 1.6f);
		o.blend *= s;
		if (dmg_below(2)) {
			o.range *= s;
		}
		break;
	}
	case EDIT_RANGE:
		o.range *= dmg_float(0.3f, 1.8f);
		break;
	default: {
		enum bc_op was = o.kind;
		/* Any other kind: among the smooth ones mostly, sometimes to
		 * or from a sharp one. */
		if (bc_op_is_smooth(was) && dmg_below(4)) {
			do {
				o.kind = (enum bc_op)(BC_OP_SMOOTH_UNION +
				                      dmg_below(3));
			} while (o.kind == was);
		} else {
			do {
				o.kind = (enum bc_op)(
				    1 + dmg_below(BC_OP_FIRST_UNARY - 1));
			} while (o.kind == was);
		}
		if (bc_op_is_smooth(o.kind) && !bc_op_is_smooth(was)) {
			o.blend = dmg_float(0.01f, 0.08f) * size;
			o.range = o.blend * dmg_float(1.0f, 2.0f);
		}
		break;
	}
	}
	snprintf(e->desc, sizeof(e->desc), "%s %u: %s blend %g range %g",
	         bc_op_name(o.kind), e->id, edit_names[e->kind],
	         (double)o.blend, (double)o.range);
	return bc_tree_set_op(t, e->id, &o, NULL);
}

/* ---- Damage exactness --------------------------------------------------- */

struct tally {
	uint64_t edits, skipped, frames, mismatches, wholes;
	uint64_t marked, tiles;
	uint64_t subset_frames, subset_mismatches;
	uint64_t by_kind[EDIT_COUNT];
};

/* Damaged fractions of single-primitive edits of fig18 on tiled. */
static float fig18_frac[1u << 16];
static uint32_t fig18_nfrac;

/* One scene on one backend: n random edits, each drawn as damage into F
 * and compared with a whole render G. */
static void damage_scene(enum bc_backend b, const struct scene *s, uint32_t n,
                         struct tally *ty)
{
	struct bc_tree *t = bc_tree_create();
	/* ref draws the reference from scratch each time (a structural
	 * sync drops whatever it kept), so state r keeps between renders
	 * (the tiled backend's tile lists) is checked too. */
	struct bc_renderer *r = NULL, *ref = NULL;
	struct bc_frame f = {0}, g = {0}, stale = {0}, sub = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_abv *old = NULL;
	uint32_t ids[1024], nids;
	uint8_t *tiles = NULL, *subset = NULL;
	const struct bc_lin *l;
	uint32_t w = s->w ? s->w : 61, h = s->h ? s->h : 47;
	size_t nt;
	bool all_tiles = b != BC_BACKEND_TILED;
	float size;
	if (b != BC_BACKEND_TILED) {
		/* naive and svo trace every pixel through the whole scene:
		 * about half the size keeps them fast, still with partial
		 * tiles on the right and bottom edges (61x47 -> 33x25, 96x64
		 * -> 49x33). */
		w = w / 2 + 3;
		h = h / 2 + 1;
	}
	nt = ntiles(w, h);
	REQUIRE(t);
	if (build_scene(s, t) != 0) {
		CHECK(0 && "scene builds");
		goto done;
	}
	l = bc_tree_lin(t);
	if (!l) {
		CHECK(0 && "scene not empty");
		goto done;
	}
	size = l->size;
	frame_scene(l, &cam);
	nids = collect_ids(t, ids, 1024);
	old = bc_calloc(l->nprims, sizeof(*old));
	tiles = bc_calloc(nt, 1);
	subset = bc_calloc(nt, 1);
	if (!old || !tiles || !subset || bc_frame_init(&f, w, h) ||
	    bc_frame_init(&g, w, h) || bc_frame_init(&stale, w, h) ||
	    bc_frame_init(&sub, w, h)) {
		CHECK(0 && "memory");
		goto done;
	}
	if (bc_renderer_create(&r, b, NULL, &ei) ||
	    bc_renderer_create(&ref, b, NULL, &ei) ||
	    bc_renderer_sync(r, t, NULL, &ei) ||
	    bc_renderer_render(r, &cam, &f, &st, &ei)) {
		fprintf(stderr, "  %s: %s\n", s->label, ei.msg);
		CHECK(0 && "first frame");
		goto done;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_dirty dirty;
		struct edit e;
		uint64_t bad, marked = 0;
		for (uint32_t k = 0; k < l->nprims; k++) {
			old[k] = bc_lin_abv(l, k);
		}
		if (random_edit(t, ids, nids, size, &e) != 0) {
			ty->skipped++;
			continue;
		}
		bc_tree_take_dirty(t, &dirty);
		REQUIRE(!dirty.structure);
		REQUIRE(bc_tree_lin(t) == l);
		if (bc_renderer_sync(r, t, &dirty, &ei)) {
			fprintf(stderr, "  sync: %s\n", ei.msg);
			CHECK(0 && "sync");
			break;
		}
		memset(tiles, 0, nt);
		for (uint32_t k = dirty.prim_lo; k < dirty.prim_hi; k++) {
			struct bc_abv now = bc_lin_abv(l, k);
			bc_renderer_damage(r, &cam, w, h, &old[k], tiles);
			bc_renderer_damage(r, &cam, w, h, &now, tiles);
		}
		for (size_t k = 0; k < nt; k++) {
			marked += tiles[k] != 0;
		}
		if (all_tiles) {
			/* By design: every pixel sees every primitive. */
			CHECK_EQ_INT(marked, nt);
		}
		if (bc_renderer_sync(ref, t, NULL, &ei) ||
		    bc_renderer_render(ref, &cam, &g, &st, &ei)) {
			fprintf(stderr, "  render: %s\n", ei.msg);
			CHECK(0 && "whole render");
			break;
		}
		CHECK(!st.incomplete);
		ty->frames++;
		if (all_tiles) {
			/* A random subset of tiles into the stale frame: drawn
			 * tiles must be the new state's, the others must
			 * keep the stale pixels. */
			copy_frame(&stale, &f);
			copy_frame(&sub, &f);
			for (size_t k = 0; k < nt; k++) {
				subset[k] = dmg_below(3) == 0;
			}
			if (bc_renderer_render_region(
			        r, &cam, &sub,
			        &(struct bc_render_region){.tiles = subset},
			        &st, &ei)) {
				CHECK(0 && "subset render");
				break;
			}
			ty->subset_frames++;
			for (uint32_t y = 0; y < h; y++) {
				for (uint32_t x = 0; x < w; x++) {
					size_t p = (size_t)y * w + x;
					bool drawn = st.whole ||
					             subset[tile_of(w, x, y)];
					if (!pixel_equal(
					        &sub, drawn ? &g : &stale, p)) {
						if (ty->subset_mismatches++ ==
						    0) {
							fprintf(
							    stderr,
							    "  %s %s: "
							    "subset pixel "
							    "(%u, %u) "
							    "(drawn %d) "
							    "after %s\n",
							    bc_backend_name(b),
							    s->label, x, y,
							    drawn, e.desc);
							print_pixel("got", &sub,
							            p);
							print_pixel(
							    "want",
							    drawn ? &g : &stale,
							    p);
						}
					}
				}
			}
		}
		if (!draw_marked(r, &cam, &f, tiles, &st)) {
			break;
		}
		ty->edits++;
		ty->by_kind[e.kind]++;
		ty->wholes += st.whole;
		ty->marked += st.whole ? nt : marked;
		ty->tiles += nt;
		if (s->fig18 && e.is_prim && b == BC_BACKEND_TILED &&
		    !st.whole &&
		    fig18_nfrac < sizeof(fig18_frac) / sizeof(fig18_frac[0])) {
			fig18_frac[fig18_nfrac++] = (float)marked / (float)nt;
		}
		bad = diff_frames(&f, &g, tiles, e.desc);
		if (bad) {
			fprintf(stderr,
			        "  %s %s %ux%u edit %u (%s, %s): %llu pixels "
			        "differ; prims [%u, %u) damaged, %llu of %zu "
			        "tiles marked, whole %d\n",
			        bc_backend_name(b), s->label, w, h, i,
			        edit_names[e.kind], e.desc,
			        (unsigned long long)bad, dirty.prim_lo,
			        dirty.prim_hi, (unsigned long long)marked, nt,
			        st.whole);
			ty->mismatches += bad;
			/* Carry on from the right frame, so one failure is
			 * reported once. */
			copy_frame(&f, &g);
		}
	}
done:
	bc_renderer_destroy(ref);
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	bc_frame_finish(&g);
	bc_frame_finish(&stale);
	bc_frame_finish(&sub);
	bc_free(old);
	bc_free(tiles);
	bc_free(subset);
	bc_tree_destroy(t);
}

static void damage_backend(enum bc_backend b, uint32_t divisor)
{
	struct tally ty = {0};
	double t0 = now_s();
	const char *env = getenv("BLOBCAST_DAMAGE_SOAK");
	uint32_t soak = env ? (uint32_t)strtoul(env, NULL, 10) : 1u;
	if (!bc_backend_available(b)) {
		BC_SKIP("backend not built in");
	}
	soak = soak < 1 ? 1 : (soak > 1000 ? 1000 : soak);
	dmg_state = 0x5eed0000u + (uint64_t)b + 0x100u * soak;
	for (size_t i = 0; i < sizeof(scenes) / sizeof(scenes[0]); i++) {
		struct scene s = scenes[i];
		uint32_t n = s.edits;
		n = (n * soak + divisor - 1) / divisor;
		damage_scene(b, &s, n, &ty);
		/* A scene without a size gets both. */
		if (s.w == 0) {
			s.w = 96;
			s.h = 64;
			damage_scene(b, &s, n, &ty);
		}
	}
	printf("  %s: %llu edits (%llu invalid skipped), %llu frames "
	       "compared, %llu mismatching pixels, damage %.1f%% of tiles on "
	       "average, %llu regions drawn whole; subset checks %llu, "
	       "%llu mismatching pixels; %.1f s\n",
	       bc_backend_name(b), (unsigned long long)ty.edits,
	       (unsigned long long)ty.skipped, (unsigned long long)ty.frames,
	       (unsigned long long)ty.mismatches,
	       ty.tiles ? 100.0 * (double)ty.marked / (double)ty.tiles : 0.0,
	       (unsigned long long)ty.wholes,
	       (unsigned long long)ty.subset_frames,
	       (unsigned long long)ty.subset_mismatches, now_s() - t0);
	printf("  %s: edits by kind:", bc_backend_name(b));
	for (int k = EDIT_MOVE; k < EDIT_COUNT; k++) {
		printf(" %s %llu%s", edit_names[k],
		       (unsigned long long)ty.by_kind[k],
		       k + 1 < EDIT_COUNT ? "," : "\n");
	}
	CHECK(ty.edits > 0);
	CHECK_EQ_INT(ty.mismatches, 0);
	CHECK_EQ_INT(ty.subset_mismatches, 0);
}

static void test_tiled_damage_is_exact(void)
{
	fig18_nfrac = 0;
	damage_backend(BC_BACKEND_TILED, 1);
	if (bc_test_skipped) {
		return;
	}
	/* Damage must be useful, not merely exact: moving one of 24
	 * instances redraws a small part of the frame. */
	REQUIRE(fig18_nfrac > 100);
	qsort(fig18_frac, fig18_nfrac, sizeof(float), cmp_float);
	printf("  tiled: fig18 single-primitive edits: median damage %.1f%%, "
	       "quartiles %.1f%% .. %.1f%% (%u edits)\n",
	       100.0 * (double)fig18_frac[fig18_nfrac / 2],
	       100.0 * (double)fig18_frac[fig18_nfrac / 4],
	       100.0 * (double)fig18_frac[3 * fig18_nfrac / 4], fig18_nfrac);
	CHECK(fig18_frac[fig18_nfrac / 2] < 0.30f);
}

static void test_naive_damage_and_subsets_are_exact(void)
{
	damage_backend(BC_BACKEND_NAIVE, 12);
}

static void test_svo_damage_and_subsets_are_exact(void)
{
	damage_backend(BC_BACKEND_SVO, 25);
}

/* ---- Structural edits followed splice by splice ------------------------- */

struct splice_tally {
	uint64_t edits, followed, wholes, mismatches, marked, tiles;
};

/* One random structural edit of t (the tree kept between 2 and 40
 * primitives): a REMOVE, an INSERT of a random subtree under a random
 * binary operator at a random place, or a REPLACE. 0 or the tree's
 * error (the caller skips such an edit). */
static int splice_edit(struct bc_tree *t, struct bc_tree *sub, char *desc,
                       size_t cap)
{
	uint32_t ids[1024], n = collect_ids(t, ids, 1024);
	uint32_t prims = bc_tree_prim_count(t), pick = dmg_below(10);
	uint32_t id = n > 1 ? ids[1 + dmg_below(n - 1)] : 0;
	if (id && (prims > 40 || (prims > 2 && pick < 4))) {
		snprintf(desc, cap, "REMOVE node %u", id);
		return bc_tree_remove(t, id, NULL);
	}
	if (rt_build(sub, dmg_next(), 1 + dmg_below(3))) {
		return BC_ENOMEM;
	}
	if (id && pick == 9) {
		snprintf(desc, cap, "REPLACE node %u", id);
		return bc_tree_replace(t, id, sub, NULL);
	}
	for (int tries = 0; tries < 32; tries++) {
		struct bc_op_data op;
		uint32_t p = ids[dmg_below(n)];
		if (bc_tree_get(t, p, NULL, &op) && op.kind != BC_OP_INVALID &&
		    !bc_op_is_unary(op.kind)) {
			uint32_t at = dmg_below(bc_tree_child_count(t, p) + 1);
			snprintf(desc, cap, "INSERT under %s node %u at %u",
			         bc_op_name(op.kind), p, at);
			return bc_tree_insert(t, p, at, sub, NULL);
		}
	}
	return BC_EINVAL;
}

static void splice_scene(const struct scene *s, uint32_t n,
                         struct splice_tally *ty)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_renderer *r = NULL, *ref = NULL;
	struct bc_frame f = {0}, f2 = {0}, g = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint32_t w = s->w ? s->w : 61, h = s->h ? s->h : 47;
	size_t nt = ntiles(w, h);
	uint8_t *tiles = bc_calloc(nt, 1);
	REQUIRE(t && sub && tiles);
	if (build_scene(s, t) != 0 || !bc_tree_lin(t)) {
		CHECK(0 && "scene builds");
		goto done;
	}
	frame_scene(bc_tree_lin(t), &cam);
	if (bc_frame_init(&f, w, h) || bc_frame_init(&f2, w, h) ||
	    bc_frame_init(&g, w, h) ||
	    bc_renderer_create(&r, BC_BACKEND_TILED, NULL, &ei) ||
	    bc_renderer_create(&ref, BC_BACKEND_TILED, NULL, &ei) ||
	    bc_renderer_sync(r, t, NULL, &ei) ||
	    bc_renderer_render(r, &cam, &f, &st, &ei)) {
		CHECK(0 && "first frame");
		goto done;
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_dirty dirty;
		const struct bc_lin *l;
		char desc[96];
		uint64_t bad, marked = 0;
		bool follows;
		if (splice_edit(t, sub, desc, sizeof(desc)) != 0) {
			continue;
		}
		if (i % 4 == 0) {
			/* As an edit batch hands its result out: the same
			 * scene in another object. */
			struct bc_tree *u = bc_tree_create();
			REQUIRE(u);
			bc_tree_swap(u, t);
			bc_tree_destroy(t);
			t = u;
		}
		bc_tree_take_dirty(t, &dirty);
		l = bc_tree_lin(t);
		follows = bc_renderer_follows(r, &dirty);
		CHECK(follows == dirty.spliced);
		if (bc_renderer_sync(r, t, &dirty, &ei) ||
		    bc_renderer_sync(ref, t, NULL, &ei) ||
		    bc_renderer_render(ref, &cam, &g, &st, &ei)) {
			fprintf(stderr, "  %s: %s\n", s->label, ei.msg);
			CHECK(0 && "sync and whole render");
			break;
		}
		memset(tiles, !follows, nt);
		for (uint32_t k = 0; follows && k < dirty.ngone; k++) {
			bc_renderer_damage(r, &cam, w, h, &dirty.gone[k],
			                   tiles);
		}
		for (uint32_t k = dirty.prim_lo; follows && k < dirty.prim_hi;
		     k++) {
			struct bc_abv now = bc_lin_abv(l, k);
			bc_renderer_damage(r, &cam, w, h, &now, tiles);
		}
		for (size_t k = 0; k < nt; k++) {
			marked += tiles[k] != 0;
		}
		if (!draw_marked(r, &cam, &f, tiles, &st)) {
			break;
		}
		ty->edits++;
		ty->followed += follows;
		ty->wholes += st.whole;
		ty->marked += st.whole ? nt : marked;
		ty->tiles += nt;
		if ((bad = diff_frames(&f, &g, tiles, desc)) != 0) {
			fprintf(stderr,
			        "  %s edit %u (%s): %llu pixels differ, %u "
			        "splices, %u ABVs gone, primitives [%u, %u) "
			        "dirty, %llu of %zu tiles marked, whole %d\n",
			        s->label, i, desc, (unsigned long long)bad,
			        dirty.nsplices, dirty.ngone, dirty.prim_lo,
			        dirty.prim_hi, (unsigned long long)marked, nt,
			        st.whole);
			ty->mismatches += bad;
			copy_frame(&f, &g);
		}
		/* Every tile through what r kept (lists of tiles the edit
		 * did not reach, renumbered), as refinement draws them. */
		if (i % 2 == 0 &&
		    (bc_renderer_render(r, &cam, &f2, &st, &ei) ||
		     (bad = diff_frames(&f2, &g, NULL, desc)) != 0)) {
			fprintf(stderr,
			        "  %s edit %u (%s): whole frame from "
			        "kept lists differs\n",
			        s->label, i, desc);
			ty->mismatches += bad ? bad : 1;
		}
	}
done:
	bc_renderer_destroy(ref);
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	bc_frame_finish(&f2);
	bc_frame_finish(&g);
	bc_free(tiles);
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* INSERTs, REMOVEs and REPLACEs on trees without unary nodes are followed
 * by the tiled backend (struct bc_dirty's splices): the frame before,
 * with only the tiles marked for the gone ABVs and for the dirty
 * primitives' new ABVs drawn again, equals a whole render of the scene
 * after, bit for bit, and the frame key stays unless the scene's scale
 * moved. */
static void test_tiled_follows_structural_edits(void)
{
	struct splice_tally ty = {0};
	double t0 = now_s();
	dmg_state = 0x5eed5000u;
	for (size_t i = 0; i < sizeof(scenes) / sizeof(scenes[0]); i++) {
		splice_scene(&scenes[i], 60, &ty);
	}
	printf("  tiled: %llu structural edits, %llu followed by splices, "
	       "%llu drawn whole, damage %.1f%% of tiles on average, %llu "
	       "mismatching pixels; %.1f s\n",
	       (unsigned long long)ty.edits, (unsigned long long)ty.followed,
	       (unsigned long long)ty.wholes,
	       ty.tiles ? 100.0 * (double)ty.marked / (double)ty.tiles : 0.0,
	       (unsigned long long)ty.mismatches, now_s() - t0);
	CHECK(ty.edits > 600);
	CHECK(ty.followed > ty.edits / 2);
	CHECK(ty.wholes < ty.followed / 2);
	CHECK_EQ_INT(ty.mismatches, 0);
}

/* ---- Regions and frame keys --------------------------------------------- */

static const enum bc_backend cpu_backends[] = {
    BC_BACKEND_TILED,
    BC_BACKEND_NAIVE,
    BC_BACKEND_SVO,
};

/* Checks that f holds ref where the region draws and the sentinel
 * elsewhere. Returns the pixels that do not. */
static uint64_t check_region_pixels(const struct bc_frame *f,
                                    const struct bc_frame *ref,
                                    const struct bc_frame *sentinel,
                                    const struct bc_render_region *rg,
                                    const char *what)
{
	uint64_t bad = 0;
	for (uint32_t y = 0; y < f->height; y++) {
		for (uint32_t x = 0; x < f->width; x++) {
			size_t i = (size_t)y * f->width + x;
			bool drawn =
			    (!rg->tiles ||
			     rg->tiles[tile_of(f->width, x, y)]) &&
			    bc_render_level_has(x, y, rg->level, rg->refine);
			const struct bc_frame *want = drawn ? ref : sentinel;
			if (!pixel_equal(f, want, i) && bad++ == 0) {
				fprintf(stderr,
				        "  %s: pixel (%u, %u) (drawn %d)\n",
				        what, x, y, drawn);
				print_pixel("got", f, i);
				print_pixel("want", want, i);
			}
		}
	}
	return bad;
}

static void region_backend(enum bc_backend b)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = NULL;
	struct bc_frame ref = {0}, f = {0}, sen = {0}, ref2 = {0};
	struct bc_render_stats st;
	struct bc_camera cam, cam2;
	struct bc_errinfo ei = {0};
	struct bc_dirty dirty;
	uint32_t w = 61, h = 47;
	size_t nt = ntiles(w, h);
	uint8_t tiles[64];
	struct bc_render_region rg = {.tiles = tiles};
	const char *name = bc_backend_name(b);
	REQUIRE(t);
	REQUIRE(nt <= sizeof(tiles));
	REQUIRE(build_scene(&scenes[SCENE_FIG18_SPHERES_SMOOTH], t) == 0);
	frame_scene(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&ref, w, h) == 0);
	REQUIRE(bc_frame_init(&ref2, w, h) == 0);
	REQUIRE(bc_frame_init(&f, w, h) == 0);
	REQUIRE(bc_frame_init(&sen, w, h) == 0);
	fill_sentinel(&sen);
	REQUIRE(bc_renderer_create(&r, b, NULL, &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &ref, &st, &ei) == 0);
	CHECK(ref.key != 0);
	CHECK(!st.whole); /* a whole render is not a region made whole */
	for (size_t k = 0; k < nt; k++) {
		tiles[k] = (uint8_t)(k % 3 == 1 || k == nt - 1);
	}

	/* A fresh frame (key 0): the region becomes the whole frame. */
	copy_frame(&f, &sen);
	f.key = 0;
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK_EQ_INT(st.rays, (uint64_t)w * h);
	CHECK_EQ_INT(diff_frames(&f, &ref, NULL, name), 0);
	CHECK_EQ_INT(f.key, ref.key);

	/* The same view: only the region is drawn, the sentinel stays. */
	copy_frame(&f, &sen);
	f.key = ref.key;
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(!st.whole);
	CHECK_EQ_INT(check_region_pixels(&f, &ref, &sen, &rg, name), 0);
	CHECK_EQ_INT(f.key, ref.key);

	/* At a coarser level, only that level's pixels of the region. */
	for (uint32_t level = 1; level <= BC_RENDER_MAX_LEVEL; level++) {
		for (int refine = 0; refine < 2; refine++) {
			struct bc_render_region lr = {.tiles = tiles,
			                              .level = level,
			                              .refine = refine != 0};
			copy_frame(&f, &sen);
			f.key = ref.key;
			REQUIRE(bc_renderer_render_region(r, &cam, &f, &lr, &st,
			                                  &ei) == 0);
			CHECK(!st.whole);
			CHECK_EQ_INT(
			    check_region_pixels(&f, &ref, &sen, &lr, name), 0);
		}
	}

	/* Another camera: the frame holds another view, drawn whole. */
	cam2 = cam;
	cam2.eye[0] += 0.01f * bc_tree_lin(t)->size;
	REQUIRE(bc_renderer_render(r, &cam2, &ref2, &st, &ei) == 0);
	copy_frame(&f, &ref);
	REQUIRE(bc_renderer_render_region(r, &cam2, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK_EQ_INT(diff_frames(&f, &ref2, NULL, name), 0);
	/* ... and then regions of that view are regions again. */
	REQUIRE(bc_renderer_render_region(r, &cam2, &f, &rg, &st, &ei) == 0);
	CHECK(!st.whole);

	/* An empty dirty set (nothing edited) keeps the key... */
	bc_tree_take_dirty(t, &dirty);
	REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) == 0);
	REQUIRE(bc_renderer_render_region(r, &cam2, &f, &rg, &st, &ei) == 0);
	CHECK(!st.whole);
	/* ... a structural change (dirty NULL) changes it. */
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	copy_frame(&f, &sen);
	f.key = ref2.key;
	REQUIRE(bc_renderer_render_region(r, &cam2, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK(f.key != ref2.key);
	/* Compared with a render after the sync: svo rebuilds its octree
	 * there, for this camera's hit band, and its depths may move in the
	 * last bit against a frame drawn through the octree built for the
	 * first camera. */
	REQUIRE(bc_renderer_render(r, &cam2, &ref2, &st, &ei) == 0);
	CHECK_EQ_INT(f.key, ref2.key);
	CHECK_EQ_INT(diff_frames(&f, &ref2, NULL, name), 0);

	/* A refine call on a foreign frame is drawn whole at its level. */
	copy_frame(&f, &sen);
	f.key = 0;
	rg = (struct bc_render_region){.level = 1, .refine = true};
	REQUIRE(bc_renderer_render_region(r, &cam2, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	rg.refine = false;
	CHECK_EQ_INT(check_region_pixels(&f, &ref2, &sen, &rg, name), 0);

	bc_renderer_destroy(r);
	bc_frame_finish(&ref);
	bc_frame_finish(&ref2);
	bc_frame_finish(&f);
	bc_frame_finish(&sen);
	bc_tree_destroy(t);
}

static void test_regions_leave_other_pixels_alone(void)
{
	int ran = 0;
	for (size_t i = 0; i < sizeof(cpu_backends) / sizeof(cpu_backends[0]);
	     i++) {
		if (bc_backend_available(cpu_backends[i])) {
			region_backend(cpu_backends[i]);
			ran++;
		}
	}
	if (!ran) {
		BC_SKIP("no CPU backend built in");
	}
}

/* ---- Progressive refinement --------------------------------------------- */

static void test_level_partition(void)
{
	/* Every pixel is traced by exactly one of level 3, then 2, 1, 0
	 * refining. */
	for (uint32_t y = 0; y < 70; y++) {
		for (uint32_t x = 0; x < 70; x++) {
			int n = bc_render_level_has(x, y, 3, false);
			for (uint32_t level = 0; level < 3; level++) {
				n += bc_render_level_has(x, y, level, true);
			}
			if (n != 1) {
				fprintf(stderr, "  pixel (%u, %u): %d\n", x, y,
				        n);
			}
			CHECK_EQ_INT(n, 1);
			/* Without refine, level n holds the coarser ones. */
			for (uint32_t level = 1; level <= 3; level++) {
				if (bc_render_level_has(x, y, level, false)) {
					CHECK(bc_render_level_has(
					    x, y, level - 1, false));
				}
			}
			/* Refining level 3 (the coarsest) refines nothing. */
			CHECK_EQ_INT(bc_render_level_has(x, y, 3, true),
			             bc_render_level_has(x, y, 3, false));
		}
	}
}

static void refine_one(enum bc_backend b, const struct scene *s, uint32_t w,
                       uint32_t h)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = NULL;
	struct bc_frame whole = {0}, f = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint64_t rays = 0;
	char what[96];
	REQUIRE(t);
	REQUIRE(build_scene(s, t) == 0);
	frame_scene(bc_tree_lin(t), &cam);
	REQUIRE(bc_frame_init(&whole, w, h) == 0);
	REQUIRE(bc_frame_init(&f, w, h) == 0);
	fill_sentinel(&f);
	REQUIRE(bc_renderer_create(&r, b, NULL, &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	for (int level = (int)BC_RENDER_MAX_LEVEL; level >= 0; level--) {
		struct bc_render_region rg = {
		    .level = (uint32_t)level,
		    .refine = level != (int)BC_RENDER_MAX_LEVEL};
		REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) ==
		        0);
		CHECK(!st.whole);
		CHECK(!st.incomplete);
		rays += st.rays;
	}
	REQUIRE(bc_renderer_render(r, &cam, &whole, &st, &ei) == 0);
	CHECK_EQ_INT(st.rays, (uint64_t)w * h);
	snprintf(what, sizeof(what), "%s %s %ux%u refined", bc_backend_name(b),
	         s->label, w, h);
	CHECK_EQ_INT(rays, (uint64_t)w * h);
	CHECK_EQ_INT(diff_frames(&f, &whole, NULL, what), 0);
	CHECK_EQ_INT(f.key, whole.key);
	bc_renderer_destroy(r);
	bc_frame_finish(&whole);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
}

static void test_refinement_assembles_the_whole_frame(void)
{
	static const uint32_t sizes[][2] = {{61, 47}, {96, 64}, {9, 17}};
	int ran = 0;
	for (size_t i = 0; i < sizeof(cpu_backends) / sizeof(cpu_backends[0]);
	     i++) {
		enum bc_backend b = cpu_backends[i];
		if (!bc_backend_available(b)) {
			continue;
		}
		ran++;
		for (size_t k = 0; k < sizeof(sizes) / sizeof(sizes[0]); k++) {
			refine_one(b, &scenes[SCENE_FIG18_SPHERES_SMOOTH],
			           sizes[k][0], sizes[k][1]);
			refine_one(b, &scenes[SCENE_RANDTREE_16], sizes[k][0],
			           sizes[k][1]);
		}
		refine_one(b, &scenes[SCENE_GEARS], 61, 47);
	}
	if (!ran) {
		BC_SKIP("no CPU backend built in");
	}
}

/* ---- Frame keys --------------------------------------------------------- */

/* The power of two the CPU backends round the scene's diagonal up to
 * (render.h: frame keys hold the backend's frame constants). */
static float pow2_above(float size)
{
	return exp2f(ceilf(log2f(size)));
}

static void key_backend(enum bc_backend b)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = NULL;
	struct bc_frame f = {0}, g = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_dirty dirty;
	struct bc_prim_data p;
	const struct bc_lin *l;
	uint32_t w = 61, h = 47, id;
	size_t nt = ntiles(w, h);
	uint8_t tiles[64];
	float size0, x0;
	/* Every tile, without refine: the key alone decides whether the
	 * call counts as a region made whole. */
	struct bc_render_region rg = {.tiles = tiles};
	const char *name = bc_backend_name(b);
	REQUIRE(t);
	REQUIRE(nt <= sizeof(tiles));
	memset(tiles, 1, nt);
	REQUIRE(build_scene(&scenes[SCENE_FIG18_SPHERES_SHARP], t) == 0);
	l = bc_tree_lin(t);
	size0 = l->size;
	frame_scene(l, &cam);
	REQUIRE(bc_frame_init(&f, w, h) == 0);
	REQUIRE(bc_frame_init(&g, w, h) == 0);
	REQUIRE(bc_renderer_create(&r, b, NULL, &ei) == 0);
	REQUIRE(bc_renderer_sync(r, t, NULL, &ei) == 0);
	REQUIRE(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);

	/* Move the primitive that sets the scene's upper x bound by 1 % of
	 * the scene's size, whichever way keeps the diagonal's power of
	 * two: the bounds move, the key stays. */
	id = 0;
	for (uint32_t k = 0; k < l->nprims; k++) {
		float lo[3], hi[3];
		struct bc_abv a = bc_lin_abv(l, k);
		bc_abv_aabb(&a, lo, hi);
		if (hi[0] == l->hi[0]) {
			id = l->node_id[l->prim_slot[k]];
		}
	}
	REQUIRE(id != 0);
	REQUIRE(bc_tree_get(t, id, &p, NULL));
	x0 = p.translate[0];
	p.translate[0] = x0 + 0.01f * size0;
	REQUIRE(bc_tree_set_prim(t, id, &p, NULL) == 0);
	if (pow2_above(l->size) != pow2_above(size0)) {
		p.translate[0] = x0 - 0.01f * size0;
		REQUIRE(bc_tree_set_prim(t, id, &p, NULL) == 0);
	}
	CHECK(l->size != size0);
	CHECK(pow2_above(l->size) == pow2_above(size0));
	bc_tree_take_dirty(t, &dirty);
	REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) == 0);
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(!st.whole);
	REQUIRE(bc_renderer_render(r, &cam, &g, &st, &ei) == 0);
	CHECK_EQ_INT(diff_frames(&f, &g, NULL, name), 0);
	CHECK_EQ_INT(f.key, g.key);

	/* Move it far out: the scene is more than twice its size. */
	p.translate[0] = x0 + 3.0f * size0;
	REQUIRE(bc_tree_set_prim(t, id, &p, NULL) == 0);
	CHECK(l->size > 2.0f * size0);
	bc_tree_take_dirty(t, &dirty);
	REQUIRE(bc_renderer_sync(r, t, &dirty, &ei) == 0);
	REQUIRE(bc_renderer_render_region(r, &cam, &f, &rg, &st, &ei) == 0);
	CHECK(st.whole);
	CHECK_EQ_INT(st.rays, (uint64_t)w * h);
	REQUIRE(bc_renderer_render(r, &cam, &g, &st, &ei) == 0);
	CHECK_EQ_INT(diff_frames(&f, &g, NULL, name), 0);
	CHECK_EQ_INT(f.key, g.key);

	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	bc_frame_finish(&g);
	bc_tree_destroy(t);
}

static void test_frame_key_follows_the_scene_scale(void)
{
	/* naive and tiled derive their steps from the scene's scale; svo
	 * has no key of its own (every edit rebuilds its octree and it
	 * marks every tile damaged). */
	if (!bc_backend_available(BC_BACKEND_TILED)) {
		BC_SKIP("no CPU backend built in");
	}
	key_backend(BC_BACKEND_TILED);
	key_backend(BC_BACKEND_NAIVE);
}

/* ---- Groups: an edit of many neighbouring primitives ------------------- */

/* A renderer following group moves (group_move) of a scene, and a second
 * one that renders each new state whole. */
struct group_run {
	struct bc_tree *t;
	struct bc_renderer *r, *ref;
	struct bc_camera cam;
	struct bc_frame f, g;
	uint32_t w, h;
	size_t nt;
	uint8_t *tiles;
	struct bc_render_stats st; /* r's last frame */
};

/* Two-thread renderers of t through cam at w x h, r's first frame
 * drawn. */
static void group_start(struct group_run *gr, struct bc_tree *t,
                        const struct bc_camera *cam, uint32_t w, uint32_t h)
{
	struct bc_render_opts ro = {.threads = 2};
	struct bc_dirty dirty;
	struct bc_errinfo ei = {0};
	memset(gr, 0, sizeof(*gr));
	gr->t = t;
	gr->cam = *cam;
	gr->w = w;
	gr->h = h;
	gr->nt = ntiles(w, h);
	gr->tiles = calloc(gr->nt, 1);
	REQUIRE(gr->tiles);
	bc_tree_take_dirty(t, &dirty);
	REQUIRE(bc_frame_init(&gr->f, w, h) == 0 &&
	        bc_frame_init(&gr->g, w, h) == 0);
	REQUIRE(bc_renderer_create(&gr->r, BC_BACKEND_TILED, &ro, &ei) == 0 &&
	        bc_renderer_create(&gr->ref, BC_BACKEND_TILED, &ro, &ei) == 0);
	REQUIRE(bc_renderer_sync(gr->r, t, NULL, &ei) == 0);
	REQUIRE(
	    bc_renderer_render_region(gr->r, &gr->cam, &gr->f,
	                              &(struct bc_render_region){.tiles = NULL},
	                              &gr->st, &ei) == 0);
}

/* Moves primitives [first, first + n) by d along x, draws r's marked
 * tiles and holds them to ref's whole render of the new state (what
 * names the move in a failure). Returns false when the move or the draw
 * failed (checked). */
static bool group_step(struct group_run *gr, uint32_t first, uint32_t n,
                       float d, const char *what)
{
	struct bc_dirty dirty;
	struct bc_render_stats st;
	struct bc_errinfo ei = {0};
	memset(gr->tiles, 0, gr->nt);
	if (group_move(gr->t, gr->r, &gr->cam, gr->w, gr->h, first, n, d,
	               gr->tiles, &ei)) {
		fprintf(stderr, "  move: %s\n", ei.msg);
		CHECK(0 && "group move");
		return false;
	}
	bc_tree_take_dirty(gr->t, &dirty);
	if (bc_renderer_sync(gr->r, gr->t, &dirty, &ei) ||
	    !draw_marked(gr->r, &gr->cam, &gr->f, gr->tiles, &gr->st) ||
	    bc_renderer_sync(gr->ref, gr->t, NULL, &ei) ||
	    bc_renderer_render(gr->ref, &gr->cam, &gr->g, &st, &ei)) {
		CHECK(0 && "sync or draw");
		return false;
	}
	CHECK(diff_frames(&gr->f, &gr->g, gr->tiles, what) == 0);
	return true;
}

static void group_end(struct group_run *gr)
{
	bc_renderer_destroy(gr->r);
	bc_renderer_destroy(gr->ref);
	bc_frame_finish(&gr->f);
	bc_frame_finish(&gr->g);
	bc_tree_destroy(gr->t);
	free(gr->tiles);
}

/* Groups of 65 to 256 neighbouring spheres of 4096 (more than
 * BC_CPU_PATCH_PRIMS, within 1 / BC_CPU_PATCH_SHARE of the scene: the
 * tiles' candidates are patched, not built again) and some of 1024 (built
 * again) move; the marked tiles drawn into the last frame must equal a
 * whole render of the new state, bit for bit. */
static void test_tiled_group_edits_are_exact(void)
{
	struct bc_gen_opts o = {
	    .count = 4096, .kind = SPHERES, .blend = SMOOTH};
	struct bc_tree *t = bc_tree_create();
	struct group_run gr;
	struct bc_camera cam;
	uint32_t drawn = 0;
	REQUIRE(t && bc_gen("fig18", &o, t, NULL, NULL) == 0);
	frame_scene(bc_tree_lin(t), &cam);
	group_start(&gr, t, &cam, 160, 120);
	for (int e = 0; e < 12; e++) {
		uint32_t n = e % 4 == 3 ? 1024u : 65u + dmg_below(192);
		uint32_t first = dmg_below(4096 - n + 1);
		char what[80];
		snprintf(what, sizeof(what), "%u spheres from %u moved", n,
		         first);
		if (!group_step(&gr, first, n,
		                dmg_float(-0.02f, 0.02f) * bc_tree_lin(t)->size,
		                what)) {
			break;
		}
		drawn += !gr.st.whole;
	}
	/* A move that changes the scene's bounds redraws all of it. */
	CHECK(drawn > 6);
	group_end(&gr);
}

#define SEED_LIST_ROOM 0x77u

/* Big spheres, overlapping: nearly every tile that a sphere's bounding
 * sphere can be seen in (its candidates, row_visit) is covered by it, so
 * that the lists take more room than a build keeps for them (about
 * three quarters of their candidates' room: frags_size). Primitive k is
 * child k of the root (group_move). */
static void sphere_stack(struct bc_tree *t, uint32_t n)
{
	struct bc_op_data u = {.kind = BC_OP_UNION};
	REQUIRE(bc_tree_begin(t) == 0 && bc_tree_push_op(t, 0, &u, NULL) == 0);
	for (uint32_t k = 0; k < n; k++) {
		struct bc_prim_data p;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		p.params[0] = dmg_float(5.0f, 7.0f);
		p.translate[0] = dmg_float(-3.0f, 3.0f);
		p.translate[1] = dmg_float(-2.0f, 2.0f);
		p.translate[2] = dmg_float(-2.0f, 2.0f);
		REQUIRE(bc_tree_put_prim(t, 0, &p, NULL) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0 && bc_tree_end(t, NULL) == 0);
}

/* Lists that outgrow the room kept for them: the first frame of
 * sphere_stack's view grows the room, and moves of groups of spheres far
 * across the frame, whose tiles' lists then outgrow their rooms and
 * leave them behind, compact it (edits go on until it has twice, 400 at
 * most). Every frame drawn from the kept lists equals a fresh
 * renderer's. */
static void test_tiled_lists_outgrow_their_room(void)
{
	struct bc_tree *t = bc_tree_create();
	struct group_run gr;
	struct bc_camera cam;
	uint32_t n = 96, grown = 0, compacted = 0;
	dmg_state = SEED_LIST_ROOM; /* whichever tests ran before */
	REQUIRE(t);
	sphere_stack(t, n);
	bc_camera_default(&cam);
	memcpy(cam.eye, (float[3]){0.0f, 0.0f, 24.0f}, sizeof(cam.eye));
	memset(cam.target, 0, sizeof(cam.target));
	cam.fov_y_deg = 40.0f;
	group_start(&gr, t, &cam, 320, 240);
	grown += gr.st.lists_grown;
	compacted += gr.st.lists_compacted;
	for (int e = 0; e < 400 && (e < 40 || compacted < 2); e++) {
		uint32_t m = 8u + dmg_below(9);
		uint32_t first = dmg_below(n - m + 1);
		float d = (e % 2 ? -1.0f : 1.0f) * dmg_float(3.0f, 6.0f);
		char what[80];
		snprintf(what, sizeof(what), "%u spheres from %u moved by %g",
		         m, first, (double)d);
		if (!group_step(&gr, first, m, d, what)) {
			break;
		}
		grown += gr.st.lists_grown;
		compacted += gr.st.lists_compacted;
	}
	fprintf(stderr, "  lists' room grown %u times, compacted %u times\n",
	        grown, compacted);
	CHECK(grown > 0);
	CHECK(compacted > 0);
	group_end(&gr);
}

/* An allocation that fails anywhere in sphere_stack's first frame (the
 * sweep fails each of its allocations in turn, the growth of the lists'
 * room among them) fails the call with BC_ENOMEM, and the next call of
 * the same renderer draws the frame a renderer without failures
 * draws. */
static void test_tiled_list_room_survives_allocation_failures(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_render_opts ro = {.threads = 2};
	struct bc_frame f = {0}, g = {0};
	struct bc_render_stats st;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	unsigned long n;
	int rc = -1;
	dmg_state = SEED_LIST_ROOM;
	REQUIRE(t);
	sphere_stack(t, 96);
	bc_camera_default(&cam);
	memcpy(cam.eye, (float[3]){0.0f, 0.0f, 24.0f}, sizeof(cam.eye));
	memset(cam.target, 0, sizeof(cam.target));
	cam.fov_y_deg = 40.0f;
	REQUIRE(bc_frame_init(&f, 320, 240) == 0 &&
	        bc_frame_init(&g, 320, 240) == 0);
	REQUIRE(bc_render_once(BC_BACKEND_TILED, &ro, t, &cam, &g, &st, &ei) ==
	        0);
	REQUIRE(st.lists_grown > 0);
	for (n = 1; n < 400 && rc != 0; n++) {
		struct bc_renderer *r = NULL;
		REQUIRE(bc_renderer_create(&r, BC_BACKEND_TILED, &ro, &ei) ==
		            0 &&
		        bc_renderer_sync(r, t, NULL, &ei) == 0);
		bc_alloc_fail_after(n);
		rc = bc_renderer_render(r, &cam, &f, &st, &ei);
		bc_alloc_fail_after(0);
		CHECK(rc == 0 || rc == BC_ENOMEM);
		CHECK(bc_renderer_render(r, &cam, &f, &st, &ei) == 0);
		CHECK(memcmp(f.rgba, g.rgba, (size_t)320 * 240 * 4) == 0 &&
		      memcmp(f.ids, g.ids, (size_t)320 * 240 * 4) == 0);
		bc_renderer_destroy(r);
	}
	CHECK_EQ_INT(rc, 0);
	CHECK(n > 10);
	bc_frame_finish(&f);
	bc_frame_finish(&g);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"level_partition", test_level_partition},
    {"regions_leave_other_pixels_alone", test_regions_leave_other_pixels_alone},
    {"refinement_assembles_the_whole_frame",
     test_refinement_assembles_the_whole_frame},
    {"frame_key_follows_the_scene_scale",
     test_frame_key_follows_the_scene_scale},
    {"tiled_damage_is_exact", test_tiled_damage_is_exact},
    {"tiled_follows_structural_edits", test_tiled_follows_structural_edits},
    {"tiled_group_edits_are_exact", test_tiled_group_edits_are_exact},
    {"tiled_lists_outgrow_their_room", test_tiled_lists_outgrow_their_room},
    {"tiled_list_room_survives_allocation_failures",
     test_tiled_list_room_survives_allocation_failures},
    {"naive_damage_and_subsets_are_exact",
     test_naive_damage_and_subsets_are_exact},
    {"svo_damage_and_subsets_are_exact", test_svo_damage_and_subsets_are_exact},
};

BC_TEST_MAIN(tests)
