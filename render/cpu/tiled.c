/*
 * The tiled CPU backend: Zanni 2024 §6 on CPU threads.
 *
 * A-buffer. The screen is cut into 8x8 tiles. Each primitive's world ABV is
 * projected (through its world AABB, conservatively) to a rectangle of
 * tiles; for each such tile whose bounding cone of pixel rays meets the
 * ABV's bounding sphere, the tile's pixel rays are clipped against the ABV
 * itself and the hits aggregate into one fragment: min entry, max exit (no
 * fragment when no ray hits). Depths are ray parameters t along unit
 * directions rather than the paper's NDC: a primitive's interval on every
 * ray of the tile lies inside its fragment's [entry, exit], which is all
 * the range walk below needs.
 *
 * Lists kept. A tile's list depends only on the view (camera, frame size,
 * the frame constants of bc_render_scale_key) and the ABVs of the primitives
 * whose rectangles hold the tile, not on the pixels asked of it. So the lists
 * and the ray directions are kept between renders of one view and each render
 * computes them only for the tiles of its region that lack them: the
 * refinement levels and bands of a view compute every list once. A new
 * view, or a change of the tree's structure, drops them all; a parameter
 * edit (the sync hook's dirty primitives) drops the lists of the tiles in
 * its primitives' rectangles before and after the edit, which are the only
 * lists that can hold them; one whose candidates are built again (more
 * primitives than a patch takes, BC_CPU_PATCH_PRIMS, or more than the room
 * kept for patches) drops every list. A list is computed from the tile
 * alone, so it is the same whichever render computes it. For the same reason a
 * release (bc_renderer_release) may drop everything kept: the renders
 * after it compute the lists again, the same lists.
 *
 * Tracing. Each tile (one work item, on any thread) sorts its list by entry
 * and walks depth ranges as §6.2 does (eq. 21-22): drop active primitives
 * whose exit is <= the previous range end; start the next range there, or
 * at the next entry if nothing is active; fetch while the next entry is <=
 * the largest active exit, fewer than M_overlap (128) are active and fewer
 * than 8 were fetched this turn; the range ends at min(next entry, largest
 * active exit). The active set is kept sorted by primitive index, a pruned
 * view is built for it (bc_view_build, one struct bc_view per thread) and
 * every ray of the tile without a hit yet is sphere traced inside the range.
 * The sort orders by (entry, primitive), a total order, so a kept list,
 * already sorted by an earlier render, sorts to the same order again.
 *
 * Overflow. When M_overlap primitives are active and the next one enters at
 * the range start itself, no smaller range exists that excludes it. The
 * paper's shared-memory limit does not bind a CPU, so the walk degrades:
 * it fetches past the limit everything entering there (making a bigger
 * view), and the tile is still rendered exactly.
 */
#include "tiled.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/log.h"
#include "blobcast/vec.h"

#include "abuffer.h"

/* Tiles [x0, x1) x [y0, y1) a primitive may cover: 16 bits hold any
 * frame's tile columns and rows (8 bytes a primitive, not 16). */
struct rect {
	uint16_t x0, y0, x1, y1;
};
_Static_assert(BC_RENDER_MAX_DIM / BC_CPU_TILE + 1u <= UINT16_MAX,
               "a tile column or row must fit struct rect");

/* Apex at the eye: every pixel ray of a block is within the half-angle
 * (given by its cosine and sine) of axis. */
struct cone {
	float axis[3];
	float cos_h, sin_h;
};

/* What the A-buffer keeps of a primitive in one view, 16 bytes: its tile
 * rectangle, the widening of its ABV (widened_abv), and the one term of
 * its bounding sphere seen from the eye (struct seen) that takes a square
 * root (ROOT_INSIDE when the eye is inside the sphere). The sphere's
 * centre and radius are made again from the layout's ABV (whose shape the
 * widening keeps) and the margin when a tile's list tests the primitive
 * (prim_seen), the same floats prim_setup made from them: a million
 * primitives kept 36 bytes each here when they were kept too, and making
 * the root again as well cost a cold frame's lists 4-7 % more time
 * (docs/benchmarks.md, "A view's primitive in 20 bytes" and "... in 16
 * bytes"). */
struct ab_prim {
	struct rect rect;
	float margin;
	float root;
};
_Static_assert(sizeof(struct ab_prim) <= 16, "a view's primitive grew");
/* ab_prim's root where the eye is inside the bounding sphere (a root is
 * never negative). */
#define ROOT_INSIDE (-1.0f)

/* A primitive's widened ABV's bounding sphere seen from the eye: centre v
 * relative to the eye, radius; when the eye is outside (inside false),
 * root = sqrt(|v|^2 - radius^2), the cone tests' term. */
struct seen {
	float v[3], radius, root;
	bool inside;
};

/* A tile's state bits within the kept view: cones computed (tiles with
 * candidates only), list computed; a tile with its list needs nothing
 * more. */
#define TILE_CONES 2u
#define TILE_LIST 4u
#define TILE_DONE TILE_LIST

struct bc__tiled_bufs {
	/* The view everything below was made for (bc_render_scale_key's scale
	 * through min_step). view_ok false: nothing is kept. */
	bool view_ok;
	struct bc_camera cam;
	uint32_t w, h, nprims;
	uint32_t win[4]; /* the frame's window: x, y, full width, height */
	uint64_t generation;
	const struct bc_lin *lin;
	float min_step, pix_angle;
	/* The view's lists passed the A-buffer's limit: its primitives'
	 * rectangles are kept, its lists built a band of tile rows at a time
	 * (draw_bands), only the last band's kept for the next call. */
	bool banded;
	/* A banded view's primitives by tile row: those whose rectangle
	 * holds row y, increasing, at row_prims[row_off[y] .. row_off[y +
	 * 1]) (th + 1 offsets), so that a band's lists are built from its
	 * rows' primitives, not from a pass over all of them (a region of a
	 * few tiles in a million-sphere view). rows_ok false: not made for
	 * the primitives' rectangles as they are. */
	bool rows_ok;
	/* The band whose candidates (and lists, TILE_LIST) are built:
	 * rows [band_y0, band_y1), while band_ok. */
	bool band_ok;
	uint32_t band_y0, band_y1;
	uint32_t *row_off, *row_prims;
	size_t row_off_cap, row_prims_cap;
	/* Primitives whose ABVs changed since the lists were made (sync). */
	uint32_t dirty_lo, dirty_hi;

	struct ab_prim *prims;
	size_t prims_cap;
	/* Per tile: state, list length, candidates (primitives whose
	 * rectangle holds it and, but in a band's, whose bounding sphere
	 * meets its whole-tile cone, increasing: visit_rows) at
	 * cand[cand_off[t] ..
	 * cand_end[t]) with room up to cand_lim[t], and the list at
	 * frags[frag_off[t] ..] in room of frag_room[t] fragments. A full
	 * build lays the tiles out in order, each with some room to spare
	 * (slack); a patch (patch_cand) rewrites a tile's candidates in
	 * place, or, when they outgrow its room, after cand_used. off_alt
	 * and cur are scratch. */
	uint8_t *state;
	uint32_t *list_n, *cand_off, *cand_end, *cand_lim, *off_alt, *cur;
	uint32_t *frag_off, *frag_room;
	struct bc__zq *zq;  /* the depth scale of the tile's list */
	struct cone *cones; /* CONES_PER_TILE per tile */
	size_t tiles_cap;
	uint32_t *cand, *scratch;
	size_t cand_cap, cand_used, scratch_cap;
	/* The tiles' lists, each where place_list put it: a list that
	 * fits its tile's room is written there, a longer one gets room of
	 * its own after frags_used. A cone test drops about half of a
	 * tile's candidates, so lists kept at their candidates' offsets (as
	 * they were) left most of an array as big as the candidates and
	 * their slack, 8 bytes an entry, unused: 83 MB for 27 MB of lists
	 * at a million spheres, 1024x768. Room of a tile is its own (frag_room
	 * 0: none) until frags_reset; what lists that outgrew their room left
	 * behind is given back when make_frag_room compacts. */
	struct bc__frag *frags;
	size_t frags_cap, frags_used;
	/* A shared pass's counts, then cursors: share i's at share_cur[i *
	 * ntiles + t] (phase_visit). */
	uint32_t *share_cur;
	size_t share_cap;
	struct bc__tile_worker workers[BC_CPU_MAX_THREADS];
};

/* Cones per tile: the whole tile, then its four 4x4 quarters. */
#define CONES_PER_TILE 5u
#define QUARTER (BC_CPU_TILE / 2u)

static void free_tiles(struct bc__tiled_bufs *b)
{
	bc_free(b->state);
	bc_free(b->list_n);
	bc_free(b->cand_off);
	bc_free(b->cand_end);
	bc_free(b->cand_lim);
	bc_free(b->off_alt);
	bc_free(b->cur);
	bc_free(b->zq);
	bc_free(b->cones);
	bc_free(b->frag_off);
	bc_free(b->frag_room);
	b->state = NULL;
	b->list_n = b->cand_off = b->cand_end = b->cand_lim = NULL;
	b->off_alt = b->cur = b->frag_off = b->frag_room = NULL;
	b->zq = NULL;
	b->cones = NULL;
	b->tiles_cap = 0;
}

void bc__tiled_free(struct bc__tiled_bufs *b)
{
	if (!b) {
		return;
	}
	bc_free(b->prims);
	free_tiles(b);
	bc_free(b->row_off);
	bc_free(b->row_prims);
	bc_free(b->cand);
	bc_free(b->scratch);
	bc_free(b->frags);
	bc_free(b->share_cur);
	for (uint32_t i = 0; i < BC_CPU_MAX_THREADS; i++) {
		bc_view_finish(&b->workers[i].view);
		bc_view_finish(&b->workers[i].tile_view);
		bc_free(b->workers[i].tile_act);
		bc_free(b->workers[i].act);
		bc_free(b->workers[i].act_t1);
		bc_free(b->workers[i].tz);
		bc_free(b->workers[i].lst);
		bc_free(b->workers[i].sort);
	}
	bc_free(b);
}

/* Grows *p to at least n elements of size bytes (contents not kept). */
static int grow(void **p, size_t *cap, size_t n, size_t size)
{
	void *fresh;
	if (n <= *cap) {
		return 0;
	}
	fresh = bc_calloc(n, size);
	if (!fresh) {
		return BC_ENOMEM;
	}
	bc_free(*p);
	*p = fresh;
	*cap = n;
	return 0;
}

/* Room for n elements as grow gives it, the room given back first when
 * it is more than twice that (a bigger view's before). */
static int fit(void **p, size_t *cap, size_t n, size_t size)
{
	if (*cap > 2u * n) {
		bc_free(*p);
		*p = NULL;
		*cap = 0;
	}
	return grow(p, cap, n, size);
}

/* Room for n tiles in every per-tile array (contents not kept), the
 * room of more than twice as many (a bigger frame's) given back. */
static int grow_tiles(struct bc__tiled_bufs *b, size_t n)
{
	if (n <= b->tiles_cap && b->tiles_cap <= 2u * n) {
		return 0;
	}
	free_tiles(b);
	b->state = bc_calloc(n, sizeof(*b->state));
	b->list_n = bc_calloc(n, sizeof(*b->list_n));
	b->cand_off = bc_calloc(n + 1, sizeof(*b->cand_off));
	b->cand_end = bc_calloc(n, sizeof(*b->cand_end));
	b->cand_lim = bc_calloc(n, sizeof(*b->cand_lim));
	b->off_alt = bc_calloc(n + 1, sizeof(*b->off_alt));
	b->cur = bc_calloc(n, sizeof(*b->cur));
	b->zq = bc_calloc(n, sizeof(*b->zq));
	b->cones = bc_calloc(n * CONES_PER_TILE, sizeof(*b->cones));
	b->frag_off = bc_calloc(n, sizeof(*b->frag_off));
	b->frag_room = bc_calloc(n, sizeof(*b->frag_room));
	if (!b->state || !b->list_n || !b->cand_off || !b->cand_end ||
	    !b->cand_lim || !b->off_alt || !b->cur || !b->zq || !b->cones ||
	    !b->frag_off || !b->frag_room) {
		free_tiles(b);
		return BC_ENOMEM;
	}
	b->tiles_cap = n;
	b->frags_used = 0; /* no tile holds room now */
	return 0;
}

/* Drops every tile's list and its room: the kept lists start again at
 * the front of b->frags. */
static void frags_reset(struct bc__tiled_bufs *b)
{
	for (size_t t = 0; t < b->tiles_cap; t++) {
		b->state[t] &= (uint8_t)~TILE_LIST;
	}
	if (b->tiles_cap) {
		memset(b->frag_room, 0, b->tiles_cap * sizeof(*b->frag_room));
	}
	b->frags_used = 0;
}

/* ---- One frame ---------------------------------------------------------- */

/* The tiles [lo, hi) of a tile phase still to hand out from one thread's
 * share, lo in the low half of the word: the owner's takes from the front
 * and the other threads' from the back are each one compare-and-swap. */
struct tile_span {
	_Alignas(64) _Atomic uint64_t lohi;
};

struct tiled_frame {
	const struct bc__frame_ctx *fc;
	struct bc__tiled_bufs *b;
	struct bc__ab_kernel kern;
	uint32_t tw, th, ntiles;
	uint32_t t0, t1; /* the region's tiles are in [t0, t1) */
	uint32_t nprims;
	/* Fragments the A-buffer's lists may hold at once (opts). */
	uint32_t limit;
	const struct bc_render_region *region;
	uint32_t threads; /* the call's share of the renderer's threads */
	/* Work counter of the primitives' phase, and tiles traced: each on a
	 * cache line of its own, away from the fields every thread reads. */
	_Alignas(64) atomic_uint next;
	/* The primitive-tile pairs of the rectangles phase_prims made, and
	 * the candidates a build of every row kept of them (build_cand). */
	_Atomic uint64_t pairs;
	uint64_t cands;
	struct tile_span spans[BC_POOL_MAX_THREADS]; /* see next_tile */
	uint32_t nspans; /* the shares the pool runs: spans in use */
	_Alignas(64) atomic_uint tiles_done;
	struct bc_render_progress progress;
	/* bc_clock_ms() past which no tile starts; 0: none. */
	double deadline;
	atomic_uint skipped; /* tiles left as background past the deadline */
	/* The lists phase's end of b->frags_used, and the room the lists
	 * that did not fit b->frags asked for (place_list). */
	_Alignas(64) _Atomic size_t frag_next;
	_Atomic size_t frag_short;
	/* The shares count_cand counted every row in (phase_visit); 0: one
	 * pass. */
	uint32_t visit_shares;
};

/* The cone of the pixel rays through pixel centres [x0, x1] x [y0, y1]
 * (inclusive, in pixel coordinates), whose corner rays (the pixel rays
 * there) are corner[4]. The half-angle is the largest angle between the
 * axis and a corner: acosf of the smallest cosine, since acosf never
 * increases (glibc's, checked over every float of [-1, 1]), which takes
 * one acosf instead of four for the same value. */
static void make_cone(const struct bc_view_rays *vr, float x0, float y0,
                      float x1, float y1, const float *const corner[4],
                      struct cone *c)
{
	float least = 1.0f, half;
	bc_view_rays_dir(vr, 0.5f * (x0 + x1), 0.5f * (y0 + y1), c->axis);
	for (int k = 0; k < 4; k++) {
		least = bc__minf(least, bc_v3_dot(corner[k], c->axis));
	}
	half = acosf(least < -1.0f ? -1.0f : least);
	/* Margin for rounding in the angle computations. */
	half += 1.0e-4f;
	c->cos_h = cosf(half);
	c->sin_h = sinf(half);
}

/* The tiles the box [lo, hi] can cover, conservatively. */
static struct rect project_box(const struct tiled_frame *tf, const float lo[3],
                               const float hi[3])
{
	const struct bc__frame_ctx *fc = tf->fc;
	const struct bc_view_rays *vr = &fc->vr;
	/* Points project into the whole view (its size is the frame's when
	 * the frame is the view), and the pixel rectangle is clipped to
	 * the frame's window there: a window's tile lists are those of the
	 * view's tiles it holds, bit for bit, when its origin is a
	 * multiple of the tile. */
	float w = (float)vr->width, h = (float)vr->height;
	uint32_t ox = vr->x0, oy = vr->y0;
	float px0 = INFINITY, px1 = -INFINITY, py0 = INFINITY, py1 = -INFINITY;
	struct rect all = {0, 0, (uint16_t)tf->tw, (uint16_t)tf->th};
	struct rect none = {0, 0, 0, 0}, r;
	int behind = 0;
	for (int c = 0; c < 8; c++) {
		float p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1],
		              (c & 4) ? hi[2] : lo[2]};
		float v[3] = {p[0] - vr->eye[0], p[1] - vr->eye[1],
		              p[2] - vr->eye[2]};
		float z = bc_v3_dot(v, vr->forward), sx, sy;
		if (!(z >
		      1.0e-6f * (fabsf(v[0]) + fabsf(v[1]) + fabsf(v[2])))) {
			behind++;
			continue;
		}
		sx =
		    bc_v3_dot(v, vr->right) / (z * vr->tan_half_y * vr->aspect);
		sy = bc_v3_dot(v, vr->up) / (z * vr->tan_half_y);
		px0 = bc__minf(px0, (sx + 1.0f) * 0.5f * w);
		px1 = bc__maxf(px1, (sx + 1.0f) * 0.5f * w);
		py0 = bc__minf(py0, (1.0f - sy) * 0.5f * h);
		py1 = bc__maxf(py1, (1.0f - sy) * 0.5f * h);
	}
	if (behind == 8) {
		return none; /* wholly behind the eye: no ray reaches it */
	}
	if (behind) {
		return all; /* straddles the eye plane: anywhere on screen */
	}
	/* Pixel i is covered when its centre i + 0.5 is inside; one pixel of
	 * margin absorbs rounding. The window's edges are whole numbers
	 * (exact as floats), and (uint32_t) rounds down, so subtracting
	 * the origin after it is exact. */
	px0 = bc__maxf(px0 - 1.5f, (float)ox);
	py0 = bc__maxf(py0 - 1.5f, (float)oy);
	px1 = bc__minf(px1 + 0.5f, (float)(ox + fc->out->width) - 1.0f);
	py1 = bc__minf(py1 + 0.5f, (float)(oy + fc->out->height) - 1.0f);
	if (!(px0 <= px1 && py0 <= py1)) {
		return none;
	}
	r.x0 = (uint16_t)(((uint32_t)px0 - ox) / BC_CPU_TILE);
	r.y0 = (uint16_t)(((uint32_t)py0 - oy) / BC_CPU_TILE);
	r.x1 = (uint16_t)(((uint32_t)px1 - ox) / BC_CPU_TILE + 1);
	r.y1 = (uint16_t)(((uint32_t)py1 - oy) / BC_CPU_TILE + 1);
	return r;
}

/* abv grown by m: a box's half extents, a sphere's or capsule's radius. */
static void widen_by(const struct bc_abv *abv, float m, struct bc_abv *out)
{
	*out = *abv;
	switch (out->shape) {
	case BC_ABV_BOX:
		for (int i = 0; i < 3; i++) {
			out->half[i] += m;
		}
		break;
	default:
		out->radius += m;
		break;
	}
}

/* The world ABV of primitive k widened by the hit epsilon (times the
 * Lipschitz bound, since the tracer compares field / 1.45): a ray counts
 * as a hit where the field is below that, which can be just outside the
 * ABV itself when the ROI offset is 0 (sharp operators). Without the
 * margin such near hits, which naive tracing finds, would fall between
 * depth ranges. Widening only adds primitives to views, which is always
 * safe. The epsilon grows with distance: the farthest point of the
 * primitive's bounding sphere sets it. Returns the margin; lo, hi: the
 * widened ABV's bounding box. */
static float widened_abv(const struct bc__frame_ctx *fc,
                         const struct bc_abv *abv, struct bc_abv *out,
                         float lo[3], float hi[3])
{
	const float *eye = fc->vr.eye;
	float far = 0.0f, r2 = 0.0f, m;
	bc_abv_aabb(abv, lo, hi);
	for (int i = 0; i < 3; i++) {
		float c = 0.5f * (lo[i] + hi[i]) - eye[i];
		float e = 0.5f * (hi[i] - lo[i]);
		far += c * c;
		r2 += e * e;
	}
	far = sqrtf(far) + sqrtf(r2);
	m = BC_CPU_LIPSCHITZ * fc->lin->lip *
	    bc__maxf(BC_CPU_HIT_FOOTPRINT * fc->pix_angle * far, fc->min_step);
	widen_by(abv, m, out);
	for (int i = 0; i < 3; i++) {
		lo[i] -= m;
		hi[i] += m;
	}
	return m;
}

/* Does the sphere (centre relative to the eye v, radius r) meet the
 * cone? With dist = |v| > r the sphere spans the angle asin(r / dist)
 * around v, so they meet when the angle between v and the axis is at most
 * half + asin(r / dist), i.e. (both angles below pi) when
 * dot(v, axis) >= cos_h sqrt(dist^2 - r^2) - sin_h r. */
static inline bool cone_meets_sphere(const struct cone *c, const struct seen *p)
{
	if (p->inside) {
		return true;
	}
	return bc_v3_dot(p->v, c->axis) >=
	       c->cos_h * p->root - c->sin_h * p->radius;
}

/* A sphere around the (world) shape abv widened by m (widen_by, whose
 * AABB is abv's grown by m): tighter than the AABB's for spheres and
 * capsules, which makes the cone tests sharper. The widened shape's own
 * floats, without a copy of the ABV: a tile's list makes it for every
 * candidate. */
static void bounding_sphere(const struct bc_abv *abv, float m, float c[3],
                            float *r)
{
	float e2 = 0.0f, lo[3], hi[3];
	switch (abv->shape) {
	case BC_ABV_SPHERE:
		memcpy(c, abv->center, sizeof(abv->center));
		*r = abv->radius + m;
		return;
	case BC_ABV_CAPSULE:
		for (int i = 0; i < 3; i++) {
			float e = 0.5f * (abv->end[i] - abv->center[i]);
			c[i] = abv->center[i] + e;
			e2 += e * e;
		}
		*r = sqrtf(e2) + (abv->radius + m);
		return;
	case BC_ABV_BOX:
		memcpy(c, abv->center, sizeof(abv->center));
		for (int i = 0; i < 3; i++) {
			float h = abv->half[i] + m;
			e2 += h * h;
		}
		*r = sqrtf(e2);
		return;
	default:
		bc_abv_aabb(abv, lo, hi);
		for (int i = 0; i < 3; i++) {
			float e;
			lo[i] -= m;
			hi[i] += m;
			e = 0.5f * (hi[i] - lo[i]);
			c[i] = lo[i] + e;
			e2 += e * e;
		}
		*r = sqrtf(e2);
		return;
	}
}

/* Primitive k's A-buffer terms in this view. */
static void prim_setup(const struct tiled_frame *tf, uint32_t k,
                       struct ab_prim *p)
{
	const struct bc__frame_ctx *fc = tf->fc;
	struct bc_abv abv = bc_lin_abv(fc->lin, k), wide;
	float lo[3], hi[3], c[3], r, v[3], dist2;
	p->margin = widened_abv(fc, &abv, &wide, lo, hi);
	p->rect = project_box(tf, lo, hi);
	bounding_sphere(&abv, p->margin, c, &r);
	bc_v3_sub(c, fc->vr.eye, v);
	dist2 = bc_v3_dot(v, v);
	p->root = dist2 <= r * r ? ROOT_INSIDE : sqrtf(dist2 - r * r);
}

/* Primitive k's bounding sphere seen from the eye, p its terms. */
static inline void prim_seen(const struct bc__frame_ctx *fc, uint32_t k,
                             const struct ab_prim *p, struct seen *s)
{
	const struct bc_lin *lin = fc->lin;
	float c[3];
	if (lin->sabv) {
		/* Spheres alone: the sphere around a sphere is itself. */
		memcpy(c, lin->sabv[k], sizeof(c));
		s->radius = lin->sabv[k][3] + p->margin;
	} else {
		bounding_sphere(&lin->abv[k], p->margin, c, &s->radius);
	}
	bc_v3_sub(c, fc->vr.eye, s->v);
	s->inside = p->root == ROOT_INSIDE;
	s->root = s->inside ? 0.0f : p->root;
}

/* Keeps only the state bits `keep` of the tiles of rectangle r. */
static void rect_state_and(struct tiled_frame *tf, const struct rect *r,
                           uint8_t keep)
{
	for (uint32_t ty = r->y0; ty < r->y1; ty++) {
		for (uint32_t tx = r->x0; tx < r->x1; tx++) {
			tf->b->state[(size_t)ty * tf->tw + tx] &= keep;
		}
	}
}

/* The room a tile of n candidates gets beyond them: a drag moves a
 * primitive by a tile or so, into tiles it did not cover. */
static uint32_t slack(uint32_t n)
{
	return n / 4u + 4u;
}

/* The room a tile's list of n fragments takes: less spare than a
 * candidates' (slack), since a list is at most its candidates. */
static uint32_t frag_slack(uint32_t n)
{
	return n / 8u + 4u;
}

/* Starts the kept lists again (frags_reset), with room for those of
 * candidates that take `cands` entries, slack included: three quarters
 * of that when they met the tiles' cones already (coned, visit_rows), of
 * which most make a fragment (a million spheres at 1024x768: 3.36
 * million of 4.12, and the lists with their spare 0.73 of the
 * candidates' room, slack included), else half (a band's: the cone test
 * keeps about half). Lists that need more are given it as they are made
 * (make_frag_room). Room of more than twice that (a wider view's
 * before) is given back. Returns 0 or BC_ENOMEM. */
static int frags_size(struct bc__tiled_bufs *b, uint64_t cands, bool coned)
{
	size_t want = (size_t)(coned ? cands - cands / 4u : cands / 2u) + 1024u;
	frags_reset(b);
	if (b->frags_cap >= want && b->frags_cap <= 2u * want) {
		return 0;
	}
	bc_free(b->frags);
	b->frags = NULL;
	b->frags_cap = 0;
	return grow((void **)&b->frags, &b->frags_cap, want, sizeof(*b->frags));
}

/* build_cand's answer when the lists would pass the A-buffer's limit. */
#define OVER_LIMIT 2

/* How a new view whose primitives' rectangles make more pairs of tile
 * and rectangle than the A-buffer's limit is judged (surely_over): the
 * cone tests of about SAMPLE_PRIMS primitives spread over all of them,
 * and of at most SAMPLE_PAIRS pairs. */
#define SAMPLE_PRIMS 4096u
#define SAMPLE_PAIRS (1u << 21)

/* Sorts the primitives into b's tile rows (row_off, row_prims) by
 * counting. Returns 0 or BC_ENOMEM. */
static int build_rows(struct tiled_frame *tf)
{
	struct bc__tiled_bufs *b = tf->b;
	uint64_t sum = 0;
	if (grow((void **)&b->row_off, &b->row_off_cap, tf->th + 1u,
	         sizeof(*b->row_off))) {
		return BC_ENOMEM;
	}
	memset(b->row_off, 0, (tf->th + 1u) * sizeof(*b->row_off));
	for (uint32_t k = 0; k < tf->nprims; k++) {
		const struct rect *r = &b->prims[k].rect;
		for (uint32_t y = r->y0; r->x0 < r->x1 && y < r->y1; y++) {
			b->row_off[y + 1]++;
		}
	}
	for (uint32_t y = 0; y < tf->th; y++) {
		sum += b->row_off[y + 1];
		b->row_off[y + 1] = (uint32_t)sum;
	}
	if (sum > UINT32_MAX ||
	    grow((void **)&b->row_prims, &b->row_prims_cap,
	         sum ? (size_t)sum : 1u, sizeof(*b->row_prims))) {
		return BC_ENOMEM;
	}
	for (uint32_t k = 0; k < tf->nprims; k++) {
		const struct rect *r = &b->prims[k].rect;
		for (uint32_t y = r->y0; r->x0 < r->x1 && y < r->y1; y++) {
			b->row_prims[b->row_off[y]++] = k;
		}
	}
	for (uint32_t y = tf->th; y > 0; y--) {
		b->row_off[y] = b->row_off[y - 1];
	}
	b->row_off[0] = 0;
	b->rows_ok = true;
	return 0;
}

/* A banded view's rows [y0, y1) are sorted out from the row index when
 * they are fewer than 1 / ROWS_SHARE of the view's (a daemon's slice of a
 * few tiles), else from a pass over every primitive: that one reads the
 * primitives in order, the index's entries of one row lie all over them
 * (at 4K of a million spheres the index made a whole frame's lists 25 %
 * slower). */
#define ROWS_SHARE 4u

static bool few_rows(const struct tiled_frame *tf, uint32_t y0, uint32_t y1)
{
	return (uint64_t)(y1 - y0) * ROWS_SHARE < tf->th;
}

static bool by_rows(const struct tiled_frame *tf, uint32_t y0, uint32_t y1)
{
	return tf->b->banded && tf->b->rows_ok && few_rows(tf, y0, y1);
}

/* Primitive k's tiles in one row (row: that row's cursors in b->cur,
 * cones: that row's tiles' cones, r its rectangle, sp its bounding
 * sphere seen from the eye, or NULL) whose whole-tile cone meets that
 * sphere (every one without sp): counted, or, with cand, k written at
 * each tile's cursor. A tile's list tests that cone first (tile_list),
 * so the candidates it drops would never make a fragment: at a million
 * spheres, 1024x768, 44 % of the pairs of tile and rectangle, and as
 * many entries of b->cand. */
static inline void row_visit(uint32_t *row, const struct cone *cones,
                             const struct rect *r, const struct seen *sp,
                             uint32_t k, uint32_t *cand)
{
	for (uint32_t tx = r->x0; tx < r->x1; tx++) {
		if (sp && !cone_meets_sphere(&cones[CONES_PER_TILE * tx], sp)) {
			continue;
		}
		if (cand) {
			cand[row[tx]++] = k;
		} else {
			row[tx]++;
		}
	}
}

/* Primitive k's pairs in rows [ya, yb) through row_visit, cur the
 * cursors of every tile; with cone, only those whose tile's cone meets
 * its bounding sphere. */
static inline void prim_visit(const struct tiled_frame *tf, uint32_t *cur,
                              uint32_t k, uint32_t ya, uint32_t yb,
                              uint32_t *cand, bool cone)
{
	const struct ab_prim *p = &tf->b->prims[k];
	struct seen sp;
	if (ya >= yb || p->rect.x0 >= p->rect.x1) {
		return;
	}
	if (cone) {
		prim_seen(tf->fc, k, p, &sp);
	}
	for (uint32_t ty = ya; ty < yb; ty++) {
		size_t row = (size_t)ty * tf->tw;
		row_visit(cur + row, tf->b->cones + CONES_PER_TILE * row,
		          &p->rect, cone ? &sp : NULL, k, cand);
	}
}

/* Whether the candidates' count and fill test the tiles' cones: those
 * of a view kept whole are, a banded view's are not. A banded view
 * builds its bands' candidates again at each call (a drag's rows among
 * them), where the cone tests cost such a drag at 3840x2160 half as much
 * again, and the tiles' lists test the cone as well (tile_list). The
 * count and the fill of one build must agree. */
static bool coned(const struct tiled_frame *tf)
{
	return !tf->b->banded;
}

/* Every primitive-tile pair of rows [y0, y1) through row_visit, in
 * increasing primitive order per tile, cone-tested when coned: from the
 * rows' primitives (by_rows), else from a pass over every primitive's
 * rectangle. */
static void visit_rows(struct tiled_frame *tf, uint32_t y0, uint32_t y1,
                       uint32_t *cand)
{
	struct bc__tiled_bufs *b = tf->b;
	bool cone = coned(tf);
	if (by_rows(tf, y0, y1)) {
		for (uint32_t y = y0; y < y1; y++) {
			for (uint32_t i = b->row_off[y]; i < b->row_off[y + 1];
			     i++) {
				prim_visit(tf, b->cur, b->row_prims[i], y,
				           y + 1, cand, cone);
			}
		}
		return;
	}
	for (uint32_t k = 0; k < tf->nprims; k++) {
		const struct rect *r = &b->prims[k].rect;
		uint32_t ya = r->y0 > y0 ? r->y0 : y0;
		uint32_t yb = r->y1 < y1 ? r->y1 : y1;
		prim_visit(tf, b->cur, k, ya, yb, cand, cone);
	}
}

/* The shares bc_pool_run(threads, ...) runs, numbered 0 .. n - 1. */
static inline uint32_t pool_shares(uint32_t threads)
{
	return threads < 1                     ? 1u
	       : threads > BC_POOL_MAX_THREADS ? BC_POOL_MAX_THREADS
	                                       : threads;
}

/* From this many primitives on, the pass over every primitive's
 * rectangle of a build of every row (count_cand, then build_cand's fill)
 * runs in shares of the primitives, one per thread: share i counts the
 * pairs of its primitives per tile in counts of its own, and writes its
 * candidates after the earlier shares' in each tile, so that each tile's
 * candidates stay increasing: a counting sort in parallel, which reads
 * each rectangle once in all, as the one pass did. That pass was the one
 * part of a new view's A-buffer left on one thread: 5 % of the samples
 * of an orbit of a million spheres on 2 threads, and a larger part of a
 * frame with more. From 16384 primitives at first; at 1024 and 4096 (a
 * 512^2 view of fig18) a shared pass takes the A-buffer's wall time on 2
 * threads from 1.9 to 1.7-1.8 and from 3.5 to 3.2 ms (of 3.1 and 5.9 on
 * one): once the tracing got faster, the cold frame's one-thread part
 * held its 2-thread speedup near 1.9. Below that the pool's extra run
 * costs about what the pass saves. */
#define VISIT_SHARED_PRIMS 1024u

struct visit_run {
	struct tiled_frame *tf;
	uint32_t n;     /* shares */
	uint32_t *cand; /* NULL: count */
};

/* Share i of a shared pass: its primitives' pairs counted in its counts
 * (b->share_cur's i-th row of tiles), or written at its cursors there. */
static void phase_visit(void *arg, uint32_t share)
{
	const struct visit_run *v = arg;
	struct tiled_frame *tf = v->tf;
	struct bc__tiled_bufs *b = tf->b;
	uint32_t *cur = b->share_cur + (size_t)share * tf->ntiles;
	uint32_t k0 = (uint32_t)((uint64_t)tf->nprims * share / v->n);
	uint32_t k1 = (uint32_t)((uint64_t)tf->nprims * (share + 1) / v->n);
	if (!v->cand) {
		memset(cur, 0, tf->ntiles * sizeof(*cur));
	}
	for (uint32_t k = k0; k < k1; k++) {
		const struct rect *r = &b->prims[k].rect;
		prim_visit(tf, cur, k, r->y0, r->y1, v->cand, coned(tf));
	}
}

/* Counts in b->cur the candidates of each tile of rows [y0, y1) (the
 * other rows' entries are left as they are): in shares of the primitives
 * (VISIT_SHARED_PRIMS; tf->visit_shares set) when the rows are all of
 * them and room for the shares' counts can be had, else in one pass. */
static void count_cand(struct tiled_frame *tf, uint32_t y0, uint32_t y1)
{
	struct bc__tiled_bufs *b = tf->b;
	uint32_t n = pool_shares(tf->threads);
	tf->visit_shares = 0;
	if (n > 1 && tf->nprims >= VISIT_SHARED_PRIMS && y0 == 0 &&
	    y1 == tf->th && !by_rows(tf, y0, y1) &&
	    fit((void **)&b->share_cur, &b->share_cap, (size_t)n * tf->ntiles,
	        sizeof(*b->share_cur)) == 0) {
		struct visit_run v = {.tf = tf, .n = n, .cand = NULL};
		bc_pool_run(n, phase_visit, &v);
		for (uint32_t t = 0; t < tf->ntiles; t++) {
			uint32_t sum = 0;
			for (uint32_t i = 0; i < n; i++) {
				sum += b->share_cur[(size_t)i * tf->ntiles + t];
			}
			b->cur[t] = sum;
		}
		tf->visit_shares = n;
		return;
	}
	memset(b->cur + (size_t)y0 * tf->tw, 0,
	       (size_t)(y1 - y0) * tf->tw * sizeof(*b->cur));
	visit_rows(tf, y0, y1, NULL);
}

/* build_cand's fill of every row after a shared count: each share's
 * cursors in each tile after the earlier shares' candidates (from the
 * tile's offset, off[t]), and b->cur at the tile's end, where one pass
 * leaves it. */
static void fill_shared(struct tiled_frame *tf, const uint32_t *off)
{
	struct bc__tiled_bufs *b = tf->b;
	struct visit_run v = {.tf = tf, .n = tf->visit_shares, .cand = b->cand};
	for (uint32_t t = 0; t < tf->ntiles; t++) {
		uint32_t c = off[t];
		for (uint32_t i = 0; i < v.n; i++) {
			uint32_t *cur =
			    &b->share_cur[(size_t)i * tf->ntiles + t];
			uint32_t count = *cur;
			*cur = c;
			c += count;
		}
		b->cur[t] = c;
	}
	bc_pool_run(v.n, phase_visit, &v);
}

/* The room the candidates counted in b->cur take in tile row y, slack
 * included: what that row adds to a build of the rows around it. */
static uint64_t row_room(const struct tiled_frame *tf, uint32_t y)
{
	const uint32_t *row = tf->b->cur + (size_t)y * tf->tw;
	uint64_t sum = 0;
	for (uint32_t tx = 0; tx < tf->tw; tx++) {
		sum += row[tx] + slack(row[tx]);
	}
	return sum;
}

/* Builds the candidates of every tile of rows [y0, y1) from their counts
 * in b->cur (count_cand; counting sort, primitives increasing) and drops
 * every tile's list (frags_size; a band's build leaves the other rows'
 * candidates stale, their lists with them): a tile drawn again
 * computes its list from its candidates, the same list. (The lists kept
 * through an edit of many primitives once moved to their tiles' new
 * places, through a second array as big as the lists, 124 MB at a
 * million spheres, that stayed: after an edit only the tiles it damaged
 * are drawn again, and their lists are dropped anyway.) A build of every
 * row lays out every tile; a band's (b->banded) only the band's (its
 * rows' primitives from the row index when by_rows says so), and the
 * other tiles' candidates and lists are left as they are, stale: only
 * the band is drawn from them. Returns 0, OVER_LIMIT when the rows'
 * lists would pass tf->limit fragments (nothing is built then), or
 * BC_ENOMEM. */
static int build_cand(struct tiled_frame *tf, uint32_t y0, uint32_t y1)
{
	struct bc__tiled_bufs *b = tf->b;
	uint32_t *off = b->off_alt;
	uint32_t t0 = y0 * tf->tw, t1 = y1 * tf->tw;
	uint64_t sum = 0, kept = 0;
	size_t room;
	for (uint32_t t = t0; t < t1; t++) {
		off[t] = (uint32_t)sum;
		kept += b->cur[t];
		sum += b->cur[t] + slack(b->cur[t]);
		b->cur[t] = off[t];
		if (sum > tf->limit) {
			return OVER_LIMIT;
		}
	}
	off[t1] = (uint32_t)sum;
	if (y0 == 0 && y1 == tf->th && coned(tf)) {
		tf->cands = kept;
	}
	/* Room after the tiles for those a patch makes outgrow their own;
	 * when it runs out, the next patch builds everything again. */
	room = (size_t)sum + (size_t)sum / 8u + 1024u;
	/* A build of every row gives back the room of a view of many more
	 * pairs before (a camera zoomed in on a big scene: fit), as
	 * frags_size gives the lists'; a band's keeps it. */
	if ((y0 == 0 && y1 == tf->th ? fit : grow)(
	        (void **)&b->cand, &b->cand_cap, room, sizeof(*b->cand))) {
		return BC_ENOMEM;
	}
	if (tf->visit_shares && y0 == 0 && y1 == tf->th) {
		fill_shared(tf, off);
	} else {
		visit_rows(tf, y0, y1, b->cand);
	}
	if (frags_size(b, sum, coned(tf))) {
		return BC_ENOMEM;
	}
	b->off_alt = b->cand_off;
	b->cand_off = off;
	for (uint32_t t = t0; t < t1; t++) {
		b->cand_end[t] = b->cur[t]; /* the fill's cursor: the count */
		b->cand_lim[t] = off[t + 1];
	}
	b->cand_used = sum;
	return 0;
}

/* Grows *p to at least n elements of size bytes, keeping its contents. */
static int grow_keep(void **p, size_t *cap, size_t n, size_t size)
{
	void *fresh;
	if (n <= *cap) {
		return 0;
	}
	n += n / 4u;
	if (!(fresh = bc_realloc(*p, n * size))) {
		return BC_ENOMEM;
	}
	*p = fresh;
	*cap = n;
	return 0;
}

static bool rect_has(const struct rect *r, uint32_t tx, uint32_t ty)
{
	return tx >= r->x0 && tx < r->x1 && ty >= r->y0 && ty < r->y1;
}

/* Marks the tiles of rectangle r in b->cur. */
static void rect_mark(struct tiled_frame *tf, const struct rect *r)
{
	for (uint32_t ty = r->y0; ty < r->y1; ty++) {
		for (uint32_t tx = r->x0; tx < r->x1; tx++) {
			tf->b->cur[(size_t)ty * tf->tw + tx] = 1;
		}
	}
}

/* An increasing list (old[0 .. n)) after primitives lo..hi-1 moved: the
 * old entries outside that range, with those of the range that `in` says
 * now belong (at `where`) in their place, so that it stays increasing;
 * written at out when out is not NULL. Returns the count. */
static uint32_t merge_moved(const struct tiled_frame *tf, const uint32_t *old,
                            uint32_t n_old, uint32_t lo, uint32_t hi,
                            bool (*in)(const struct tiled_frame *, uint32_t,
                                       uint32_t),
                            uint32_t where, uint32_t *out)
{
	uint32_t n = 0, i = 0;
	for (; i < n_old && old[i] < lo; i++, n++) {
		if (out) {
			out[n] = old[i];
		}
	}
	for (uint32_t k = lo; k < hi; k++) {
		if (in(tf, k, where)) {
			if (out) {
				out[n] = k;
			}
			n++;
		}
	}
	for (; i < n_old; i++) {
		if (old[i] >= hi) {
			if (out) {
				out[n] = old[i];
			}
			n++;
		}
	}
	return n;
}

/* Whether primitive k is a candidate of tile t: its rectangle holds it
 * and its bounding sphere meets the tile's whole cone (as a build of
 * every row keeps them). */
static bool in_tile(const struct tiled_frame *tf, uint32_t k, uint32_t t)
{
	const struct ab_prim *p = &tf->b->prims[k];
	struct seen sp;
	if (!rect_has(&p->rect, t % tf->tw, t / tf->tw)) {
		return false;
	}
	prim_seen(tf->fc, k, p, &sp);
	return cone_meets_sphere(&tf->b->cones[CONES_PER_TILE * t], &sp);
}

/* Whether primitive k is in tile row y of the row index (build_rows). */
static bool in_row(const struct tiled_frame *tf, uint32_t k, uint32_t y)
{
	const struct rect *r = &tf->b->prims[k].rect;
	return r->x0 < r->x1 && y >= r->y0 && y < r->y1;
}

/* Candidates of marked tile t after primitives lo..hi-1 moved. */
static uint32_t patched_list(const struct tiled_frame *tf, uint32_t t,
                             uint32_t lo, uint32_t hi, uint32_t *out)
{
	const struct bc__tiled_bufs *b = tf->b;
	return merge_moved(tf, b->cand + b->cand_off[t],
	                   b->cand_end[t] - b->cand_off[t], lo, hi, in_tile, t,
	                   out);
}

/* Row y's primitives after primitives lo..hi-1 moved. */
static uint32_t patched_row(const struct tiled_frame *tf, uint32_t y,
                            uint32_t lo, uint32_t hi, uint32_t *out)
{
	const struct bc__tiled_bufs *b = tf->b;
	return merge_moved(tf, b->row_prims + b->row_off[y],
	                   b->row_off[y + 1] - b->row_off[y], lo, hi, in_row, y,
	                   out);
}

/* Marks the rows of rectangle r in b->cur (a banded view's rows to
 * patch). */
static void rows_mark(struct tiled_frame *tf, const struct rect *r)
{
	for (uint32_t ty = r->y0; r->x0 < r->x1 && ty < r->y1; ty++) {
		tf->b->cur[ty] = 1;
	}
}

/* After a parameter edit moved primitives lo..hi-1 of a banded view, the
 * rows marked in b->cur (those their old and new rectangles hold) are
 * sorted again in place, and the other rows' primitives moved to their
 * new offsets, where build_rows made the whole index again: a pass over
 * every primitive that was most of a drag's time at 4096x4096 of a
 * million spheres. The marked rows are written in b->scratch first, then
 * the other rows moved, those that move towards the start in increasing
 * order and the others in decreasing order (neither overwrites a row not
 * yet moved), and the marked rows copied in. Returns 0 or BC_ENOMEM
 * (the index is as it was then). */
static int patch_rows(struct tiled_frame *tf, uint32_t lo, uint32_t hi)
{
	struct bc__tiled_bufs *b = tf->b;
	uint32_t *off = b->off_alt; /* the new offsets, th + 1 */
	uint64_t sum = 0, marked = 0;
	size_t at = 0;
	for (uint32_t y = 0; y < tf->th; y++) {
		uint32_t n = b->cur[y] ? patched_row(tf, y, lo, hi, NULL)
		                       : b->row_off[y + 1] - b->row_off[y];
		off[y] = (uint32_t)sum;
		sum += n;
		marked += b->cur[y] ? n : 0u;
	}
	off[tf->th] = (uint32_t)sum;
	if (sum > UINT32_MAX ||
	    grow_keep((void **)&b->row_prims, &b->row_prims_cap,
	              sum ? (size_t)sum : 1u, sizeof(*b->row_prims)) ||
	    grow_keep((void **)&b->scratch, &b->scratch_cap, marked + 1u,
	              sizeof(*b->scratch))) {
		return BC_ENOMEM;
	}
	for (uint32_t y = 0; y < tf->th; y++) {
		if (b->cur[y]) {
			at += patched_row(tf, y, lo, hi, b->scratch + at);
		}
	}
	for (uint32_t y = 0; y < tf->th; y++) {
		if (!b->cur[y] && off[y] < b->row_off[y]) {
			memmove(b->row_prims + off[y],
			        b->row_prims + b->row_off[y],
			        (size_t)(off[y + 1] - off[y]) *
			            sizeof(*b->row_prims));
		}
	}
	for (uint32_t y = tf->th; y-- > 0;) {
		if (!b->cur[y] && off[y] > b->row_off[y]) {
			memmove(b->row_prims + off[y],
			        b->row_prims + b->row_off[y],
			        (size_t)(off[y + 1] - off[y]) *
			            sizeof(*b->row_prims));
		}
	}
	at = 0;
	for (uint32_t y = 0; y < tf->th; y++) {
		if (b->cur[y]) {
			size_t n = off[y + 1] - off[y];
			memcpy(b->row_prims + off[y], b->scratch + at,
			       n * sizeof(*b->row_prims));
			at += n;
		}
	}
	memcpy(b->row_off, off, (tf->th + 1u) * sizeof(*off));
	return 0;
}

/* After a parameter edit moved primitives lo..hi-1, the candidates of the
 * tiles marked in b->cur (those their old and new rectangles cover) are
 * written anew: in their tile's room when they fit, else after cand_used
 * with room of their own. Every other tile keeps its list and its
 * fragments where they are, so a drag costs what the edited primitive
 * covers, not a pass over every primitive of the scene. Returns 0, 1 when
 * a full build should run instead (the room after the tiles is used up),
 * or BC_ENOMEM. */
static int patch_cand(struct tiled_frame *tf, uint32_t lo, uint32_t hi)
{
	struct bc__tiled_bufs *b = tf->b;
	size_t need = 0, longest = 0;
	for (uint32_t t = 0; t < tf->ntiles; t++) {
		if (b->cur[t]) {
			uint32_t n = patched_list(tf, t, lo, hi, NULL);
			b->off_alt[t] = n;
			longest = n > longest ? n : longest;
			if (n > b->cand_lim[t] - b->cand_off[t]) {
				need += n + slack(n);
			}
		}
	}
	if (b->cand_used + need > b->cand_cap) {
		return 1;
	}
	if (grow_keep((void **)&b->scratch, &b->scratch_cap, longest + 1u,
	              sizeof(*b->scratch))) {
		return BC_ENOMEM;
	}
	for (uint32_t t = 0; t < tf->ntiles; t++) {
		uint32_t n = b->off_alt[t];
		if (!b->cur[t]) {
			continue;
		}
		patched_list(tf, t, lo, hi, b->scratch);
		if (n > b->cand_lim[t] - b->cand_off[t]) {
			b->cand_off[t] = (uint32_t)b->cand_used;
			b->cand_lim[t] = b->cand_off[t] + n + slack(n);
			b->cand_used = b->cand_lim[t];
		}
		memcpy(b->cand + b->cand_off[t], b->scratch,
		       n * sizeof(*b->cand));
		b->cand_end[t] = b->cand_off[t] + n;
	}
	return 0;
}

/* Whether patching the candidates of the tiles marked in b->cur after
 * primitives lo..hi-1 moved costs less than building every tile's: a
 * patch passes over the range once for each marked tile (patched_list), a
 * build over every candidate of every tile. A drag of one primitive, or
 * of a selection of up to BC_CPU_PATCH_PRIMS, always patches. */
static bool patch_pays(const struct tiled_frame *tf, uint32_t lo, uint32_t hi)
{
	uint64_t marked = 0;
	if (hi - lo <= BC_CPU_PATCH_PRIMS) {
		return true;
	}
	for (uint32_t t = 0; t < tf->ntiles; t++) {
		marked += tf->b->cur[t] != 0;
	}
	return marked * (hi - lo) <= tf->b->cand_used;
}

/* The ray of pixel (dx, dy) of the tile, copied into d. */
static const float *tile_ray(const struct bc__ab_rays *rays, uint32_t dx,
                             uint32_t dy, float d[3])
{
	uint32_t q = (dx >= QUARTER) + 2u * (dy >= QUARTER);
	uint32_t l = (dy % QUARTER) * QUARTER + dx % QUARTER;
	for (int i = 0; i < 3; i++) {
		d[i] = rays->d[q][i][l];
	}
	return d;
}

/* The tile's ray directions for the tracer (struct bc__tile_job's dirs:
 * 3 per pixel of the tile, in rows of BC_CPU_TILE), from its rays by
 * quarter. They are made again for each tile traced, the same bits as
 * its lists' rays (one kernel, one view), where the view kept them for
 * every pixel: 12 bytes a pixel (25 MB at 1920x1080, 100 at 3840x2160)
 * for each view a daemon keeps, against 0.03 microseconds a tile with
 * AVX-512 (0.8 on the scalar path). */
static void tile_dirs(const struct bc__ab_rays *rays,
                      float d[3 * BC_CPU_TILE * BC_CPU_TILE])
{
	for (uint32_t q = 0; q < 4; q++) {
		for (uint32_t l = 0; l < BC__AB_QUARTER_RAYS; l++) {
			uint32_t dx = (q & 1u) * QUARTER + (l & 3u);
			uint32_t dy = (q >> 1) * QUARTER + (l >> 2);
			float *o = d + 3 * (dy * BC_CPU_TILE + dx);
			o[0] = rays->d[q][0][l];
			o[1] = rays->d[q][1][l];
			o[2] = rays->d[q][2][l];
		}
	}
}

/* The cone of the pixel block [bx0, bx1) x [by0, by1) of the tile whose
 * top-left pixel is (x0, y0). Its corner rays are pixel rays: taken from
 * rays, they are what bc_view_rays_dir gives for those pixel centres
 * (abuffer.h). */
static void block_cone(const struct bc_view_rays *vr,
                       const struct bc__ab_rays *rays, uint32_t x0, uint32_t y0,
                       uint32_t bx0, uint32_t by0, uint32_t bx1, uint32_t by1,
                       struct cone *c)
{
	float d[4][3];
	const float *corner[4] = {
	    tile_ray(rays, bx0 - x0, by0 - y0, d[0]),
	    tile_ray(rays, bx1 - 1 - x0, by0 - y0, d[1]),
	    tile_ray(rays, bx0 - x0, by1 - 1 - y0, d[2]),
	    tile_ray(rays, bx1 - 1 - x0, by1 - 1 - y0, d[3])};
	make_cone(vr, (float)bx0 + 0.5f, (float)by0 + 0.5f, (float)bx1 - 0.5f,
	          (float)by1 - 0.5f, corner, c);
}

/* The whole tile's cone. Its corner rays come from bc_view_rays_dir,
 * the same bits as the kernel's rays for those pixels (abuffer.h), as
 * block_cone would take them: 4 rays, not the tile's 64, for every tile
 * of a new view (phase_prims). */
static void tile_cone(const struct tiled_frame *tf, uint32_t tx, uint32_t ty)
{
	const struct bc__frame_ctx *fc = tf->fc;
	struct cone *c = &tf->b->cones[CONES_PER_TILE * (ty * tf->tw + tx)];
	uint32_t w = fc->out->width, h = fc->out->height;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	float x1 = (float)(x0 + BC_CPU_TILE < w ? x0 + BC_CPU_TILE : w) - 0.5f;
	float y1 = (float)(y0 + BC_CPU_TILE < h ? y0 + BC_CPU_TILE : h) - 0.5f;
	float fx0 = (float)x0 + 0.5f, fy0 = (float)y0 + 0.5f, d[4][3];
	const float *corner[4] = {d[0], d[1], d[2], d[3]};
	bc_view_rays_dir(&fc->vr, fx0, fy0, d[0]);
	bc_view_rays_dir(&fc->vr, x1, fy0, d[1]);
	bc_view_rays_dir(&fc->vr, fx0, y1, d[2]);
	bc_view_rays_dir(&fc->vr, x1, y1, d[3]);
	make_cone(&fc->vr, fx0, fy0, x1, y1, corner, c);
}

/* The tile's quarters' cones. */
static void tile_cones(const struct tiled_frame *tf, uint32_t tx, uint32_t ty,
                       const struct bc__ab_rays *rays)
{
	const struct bc__frame_ctx *fc = tf->fc;
	struct cone *c = &tf->b->cones[CONES_PER_TILE * (ty * tf->tw + tx)];
	uint32_t w = fc->out->width, h = fc->out->height;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	uint32_t x1 = x0 + BC_CPU_TILE < w ? x0 + BC_CPU_TILE : w;
	uint32_t y1 = y0 + BC_CPU_TILE < h ? y0 + BC_CPU_TILE : h;
	for (uint32_t q = 0; q < 4; q++) {
		uint32_t qx0 = x0 + (q & 1u) * QUARTER;
		uint32_t qy0 = y0 + (q >> 1) * QUARTER;
		uint32_t qx1 = qx0 + QUARTER < x1 ? qx0 + QUARTER : x1;
		uint32_t qy1 = qy0 + QUARTER < y1 ? qy0 + QUARTER : y1;
		if (qx0 >= qx1 || qy0 >= qy1) {
			continue; /* off the image's edge */
		}
		block_cone(&fc->vr, rays, x0, y0, qx0, qy0, qx1, qy1,
		           &c[1 + q]);
	}
}

/* The tile's rays inside the frame, per quarter: bit l of quarter[q] for
 * ray l (abuffer.h), shifted to bit q * 16 + l. */
static void tile_quarters(const struct tiled_frame *tf, uint32_t tx,
                          uint32_t ty, uint64_t quarter[4])
{
	uint32_t w = tf->fc->out->width, h = tf->fc->out->height;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	for (uint32_t q = 0; q < 4; q++) {
		quarter[q] = 0;
		for (uint32_t l = 0; l < BC__AB_QUARTER_RAYS; l++) {
			uint32_t x = x0 + (q & 1u) * QUARTER + (l & 3u);
			uint32_t y = y0 + (q >> 1) * QUARTER + (l >> 2);
			if (x < w && y < h) {
				quarter[q] |= 1ull
				              << (q * BC__AB_QUARTER_RAYS + l);
			}
		}
	}
}

/* How many candidates ahead tile_list asks for a primitive's bytes. */
#define LIST_PREFETCH 8u

/* The tile's list, written at out: for each candidate whose bounding
 * sphere meets the tile's cone (every candidate of a view kept whole
 * does, a band's may not: visit_rows), the rays of the quarters whose
 * cones it meets are clipped against the ABV; the hits make one
 * fragment, min entry and max exit, kept as floats in tz (room for the
 * tile's candidates, as out) until the last one sets the tile's depth
 * scale. */
static uint32_t tile_list(const struct tiled_frame *tf, uint32_t tile,
                          const struct bc__ab_rays *rays,
                          const uint64_t quarter[4], float *tz,
                          struct bc__frag *out)
{
	const struct bc__tiled_bufs *b = tf->b;
	const struct cone *cones = &b->cones[CONES_PER_TILE * tile];
	const float *eye = tf->fc->vr.eye;
	const struct bc_lin *lin = tf->fc->lin;
	uint32_t n = 0;
	float lo = INFINITY, hi = -INFINITY, inv;
	struct bc__zq z;
	for (uint32_t i = b->cand_off[tile]; i < b->cand_end[tile]; i++) {
		uint32_t k = b->cand[i];
		uint64_t lanes = 0;
		float t[2] = {INFINITY, -INFINITY};
		struct seen sp;
		if (i + LIST_PREFETCH < b->cand_end[tile]) {
			/* A tile's candidates lie anywhere in the primitive
			 * arrays: ask for a later one's bytes (its margin and
			 * its ABV's centre and radius) now, so that the misses
			 * overlap. */
			uint32_t later = b->cand[i + LIST_PREFETCH];
			__builtin_prefetch(&b->prims[later]);
			__builtin_prefetch(
			    lin->sabv ? (const void *)lin->sabv[later]
			              : (const void *)&lin->abv[later]);
		}
		prim_seen(tf->fc, k, &b->prims[k], &sp);
		if (!cone_meets_sphere(&cones[0], &sp)) {
			continue; /* a band's candidate (visit_rows) */
		}
		for (uint32_t q = 0; q < 4; q++) {
			if (quarter[q] &&
			    cone_meets_sphere(&cones[1 + q], &sp)) {
				lanes |= quarter[q];
			}
		}
		if (!lanes) {
			continue;
		}
		if (lin->sabv || lin->abv[k].shape == BC_ABV_SPHERE) {
			/* The sphere around a sphere is itself. */
			tf->kern.sphere(rays, lanes, sp.v, sp.radius, t);
		} else {
			struct bc_abv wide;
			widen_by(&lin->abv[k], b->prims[k].margin, &wide);
			tf->kern.abv(rays, lanes, &wide, eye, t);
		}
		if (t[1] >= t[0]) {
			tz[2 * n] = t[0];
			tz[2 * n + 1] = t[1];
			lo = bc__minf(lo, t[0]);
			hi = bc__maxf(hi, t[1]);
			out[n++].prim = k;
		}
	}
	if (n == 0) {
		return 0;
	}
	z = bc__zq_for(lo, hi);
	inv = 1.0f / z.step;
	for (uint32_t i = 0; i < n; i++) {
		out[i].q0 = bc__zq_down(z, inv, tz[2 * i]);
		out[i].q1 = bc__zq_up(z, inv, tz[2 * i + 1]);
	}
	b->zq[tile] = z;
	return n;
}

/* Tiles are handed out in runs of TILE_RUN neighbours in a row: a thread
 * then writes whole cache lines of the frame's planes and of the per-tile
 * arrays (an 8-pixel tile row is 32 bytes of colour, depth and ids), where
 * single tiles taken in turn by two threads had them share every line
 * between neighbours. Runs of 8 tiles are a 64-pixel strip; the last
 * tiles of a share go one at a time, which evens out the threads' ends. */
#define TILE_RUN 8u

static inline uint64_t span_word(uint32_t lo, uint32_t hi)
{
	return (uint64_t)lo | (uint64_t)hi << 32;
}

/* Gives each of the phase's shares an equal slice of the region's tiles,
 * in order: share i the i-th. */
static void spans_init(struct tiled_frame *tf)
{
	uint64_t count = tf->t1 - tf->t0;
	tf->nspans = pool_shares(tf->threads);
	for (uint32_t i = 0; i < tf->nspans; i++) {
		uint32_t lo = tf->t0 + (uint32_t)(count * i / tf->nspans);
		uint32_t hi = tf->t0 + (uint32_t)(count * (i + 1) / tf->nspans);
		atomic_init(&tf->spans[i].lohi, span_word(lo, hi));
	}
}

/* A run from span sp: its front for the owner, its back for another
 * thread. False when it is empty. */
static bool span_take(struct tile_span *sp, bool front, uint32_t *tile,
                      uint32_t *end)
{
	uint64_t w = atomic_load_explicit(&sp->lohi, memory_order_relaxed);
	for (;;) {
		uint32_t lo = (uint32_t)w, hi = (uint32_t)(w >> 32), run;
		if (lo >= hi) {
			return false;
		}
		run = hi - lo > 2u * TILE_RUN ? TILE_RUN : 1u;
		if (atomic_compare_exchange_weak_explicit(
		        &sp->lohi, &w,
		        front ? span_word(lo + run, hi)
		              : span_word(lo, hi - run),
		        memory_order_relaxed, memory_order_relaxed)) {
			*tile = front ? lo : hi - run;
			*end = *tile + run;
			return true;
		}
	}
}

/* The next tile of the running phase for `thread`: *tile + 1 within its
 * run while it lasts (*end), else the first of a new run from its own
 * share, else from the back of another's. A thread thus draws the same
 * tiles frame after frame, except where the shares' ends meet: the frame's
 * cache lines stay in one core's cache (taking runs from one counter in
 * turn, two threads swapped a third of them every frame, and writing a
 * background row cost three times what it does on one thread). False when
 * the region's tiles are all taken. */
static inline bool next_tile(struct tiled_frame *tf, uint32_t thread,
                             uint32_t *tile, uint32_t *end)
{
	uint32_t n = tf->nspans;
	if (*tile + 1 < *end) {
		++*tile;
		return true;
	}
	if (span_take(&tf->spans[thread], true, tile, end)) {
		return true;
	}
	for (uint32_t k = 1; k < n; k++) {
		if (span_take(&tf->spans[(thread + k) % n], false, tile, end)) {
			return true;
		}
	}
	return false;
}

/* Keeps the tile's list of n fragments (lst): in the tile's room when it
 * fits, else in room of its own taken from the end of the kept lists;
 * when that is past b->frags, the room it would take is added to
 * tf->frag_short and the list is not kept (false): it is made again once
 * draw_tiles has made room (make_frag_room). */
static bool place_list(struct tiled_frame *tf, uint32_t tile,
                       const struct bc__frag *lst, uint32_t n)
{
	struct bc__tiled_bufs *b = tf->b;
	if (n > b->frag_room[tile]) {
		size_t room = (size_t)n + frag_slack(n);
		size_t at =
		    atomic_load_explicit(&tf->frag_next, memory_order_relaxed);
		do {
			if (room > b->frags_cap - at) {
				atomic_fetch_add_explicit(&tf->frag_short, room,
				                          memory_order_relaxed);
				return false;
			}
		} while (!atomic_compare_exchange_weak_explicit(
		    &tf->frag_next, &at, at + room, memory_order_relaxed,
		    memory_order_relaxed));
		b->frag_off[tile] = (uint32_t)at;
		b->frag_room[tile] = (uint32_t)room;
	}
	memcpy(b->frags + b->frag_off[tile], lst, (size_t)n * sizeof(*lst));
	b->list_n[tile] = n;
	return true;
}

/* Phase 1 of a new view: prim_setup per primitive (in runs of 256), then
 * every tile's whole cone (tile_cone, in runs of 64), which the
 * candidates' build tests (visit_rows). */
static void phase_prims(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	uint32_t runs = (tf->nprims + 255u) / 256u;
	uint64_t pairs = 0;
	(void)thread;
	for (;;) {
		uint32_t u = atomic_fetch_add(&tf->next, 1u), t0;
		if (u < runs) {
			for (uint32_t k = u * 256u;
			     k < tf->nprims && k < (u + 1u) * 256u; k++) {
				const struct rect *r = &tf->b->prims[k].rect;
				prim_setup(tf, k, &tf->b->prims[k]);
				pairs +=
				    (uint64_t)(r->x1 - r->x0) * (r->y1 - r->y0);
			}
			continue;
		}
		if ((t0 = (u - runs) * 64u) >= tf->ntiles) {
			break;
		}
		for (uint32_t t = t0; t < tf->ntiles && t < t0 + 64u; t++) {
			tile_cone(tf, t % tf->tw, t / tf->tw);
		}
	}
	atomic_fetch_add(&tf->pairs, pairs);
}

/* Phase 2, per tile of the region not yet complete: its rays and quarter cones
 * (once per view), its list. */
static void phase_lists(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	struct bc__tiled_bufs *b = tf->b;
	struct bc__tile_worker *wk = &b->workers[thread];
	uint32_t tile = 0, end = 0;
	for (;;) {
		uint32_t tx, ty;
		struct bc__ab_rays rays;
		uint64_t quarter[4];
		if (!next_tile(tf, thread, &tile, &end)) {
			break;
		}
		tx = tile % tf->tw;
		ty = tile / tf->tw;
		if ((b->state[tile] & TILE_DONE) == TILE_DONE ||
		    (tf->region->tiles && !tf->region->tiles[tile])) {
			continue;
		}
		b->list_n[tile] = 0;
		if (b->cand_end[tile] > b->cand_off[tile]) {
			uint32_t n;
			tf->kern.dirs(&tf->fc->vr, tx * BC_CPU_TILE,
			              ty * BC_CPU_TILE, &rays);
			/* Tiles without candidates, often most of a frame's
			 * background, need no quarter cones. */
			if (!(b->state[tile] & TILE_CONES)) {
				tile_cones(tf, tx, ty, &rays);
				b->state[tile] |= TILE_CONES;
			}
			tile_quarters(tf, tx, ty, quarter);
			n = tile_list(tf, tile, &rays, quarter, wk->tz,
			              wk->lst);
			if (!place_list(tf, tile, wk->lst, n)) {
				continue;
			}
		}
		b->state[tile] |= TILE_LIST;
	}
}

/* After a lists phase in which lists asking for `short_by` fragments of
 * room did not fit b->frags: room for them, by compacting the kept lists
 * into a new array when the room no tile holds (lists that outgrew their
 * room left it behind) would give them that, or is a quarter of the used
 * part, else by growing the array; counted in stats. Either way a
 * quarter more than the lists need is left free, so the kept lists take
 * at most about 1.25 times their room plus what drawing since left
 * behind, and that less than what a compaction would give back.
 * Returns 0 or BC_ENOMEM (nothing changed then). */
static int make_frag_room(struct bc__tiled_bufs *b, size_t short_by,
                          struct bc_render_stats *stats)
{
	size_t held = 0, live = 0, at = 0, left;
	struct bc__frag *fresh;
	for (size_t t = 0; t < b->tiles_cap; t++) {
		held += b->frag_room[t];
		live += (b->state[t] & TILE_LIST) ? b->frag_room[t] : 0u;
	}
	left = b->frags_used - held;
	if (left < short_by && 4u * left < b->frags_used) {
		stats->lists_grown++;
		return grow_keep((void **)&b->frags, &b->frags_cap,
		                 b->frags_used + short_by, sizeof(*b->frags));
	}
	fresh = bc_malloc((live + short_by + (live + short_by) / 4u + 1024u) *
	                  sizeof(*fresh));
	if (!fresh) {
		return BC_ENOMEM;
	}
	for (size_t t = 0; t < b->tiles_cap; t++) {
		if (!(b->state[t] & TILE_LIST)) {
			b->frag_room[t] = 0;
			continue;
		}
		memcpy(fresh + at, b->frags + b->frag_off[t],
		       (size_t)b->list_n[t] * sizeof(*fresh));
		b->frag_off[t] = (uint32_t)at;
		at += b->frag_room[t];
	}
	stats->lists_compacted++;
	bc_free(b->frags);
	b->frags = fresh;
	b->frags_cap = live + short_by + (live + short_by) / 4u + 1024u;
	b->frags_used = at;
	return 0;
}

/* Past the frame budget: the tile's asked pixels become background. */
static void skip_tile(struct tiled_frame *tf, uint32_t tx, uint32_t ty,
                      uint64_t mask)
{
	const struct bc__frame_ctx *fc = tf->fc;
	uint32_t w = fc->out->width, h = fc->out->height;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	bc__put_miss_tile(fc, x0, y0,
	                  x0 + BC_CPU_TILE < w ? x0 + BC_CPU_TILE : w,
	                  y0 + BC_CPU_TILE < h ? y0 + BC_CPU_TILE : h, mask);
	atomic_fetch_add(&tf->skipped, 1u);
}

/* Phase 3, per tile of the region: walk the depth ranges and trace. */
static void phase_trace(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	struct bc__tile_worker *wk = &tf->b->workers[thread];
	const struct bc__frame_ctx *fc = tf->fc;
	uint32_t w = fc->out->width, h = fc->out->height;
	uint32_t tile = 0, end = 0, done = 0;
	struct bc__ab_rays rays;
	float dirs[3 * BC_CPU_TILE * BC_CPU_TILE];
	for (;;) {
		uint32_t tx, ty;
		struct bc__tile_job job;
		uint64_t mask, cut;
		if (done > 0 && tile + 1 >= end) {
			/* The run's tiles are counted once it is drawn: a
			 * shared counter added to per tile, each thread in
			 * turn, cost more than a background tile's drawing. */
			atomic_fetch_add(&tf->tiles_done, done);
			done = 0;
			if (thread == 0) {
				bc_render_progress_tick(
				    &tf->progress,
				    atomic_load(&tf->tiles_done));
			}
		}
		if (!next_tile(tf, thread, &tile, &end)) {
			break;
		}
		tx = tile % tf->tw;
		ty = tile / tf->tw;
		mask = bc__region_mask(tf->region, tx, ty, w, h);
		if (!mask) {
			continue;
		}
		wk->tiles_asked++;
		wk->rays += bc__popcount64(mask);
		if (tf->deadline > 0.0 && bc_clock_ms() > tf->deadline) {
			skip_tile(tf, tx, ty, mask);
			continue;
		}
		if (tf->b->list_n[tile] > 0) {
			/* A tile without a list misses everywhere
			 * (bc__trace_tile) and needs no rays: most of a
			 * small scene's frame. */
			tf->kern.dirs(&fc->vr, tx * BC_CPU_TILE,
			              ty * BC_CPU_TILE, &rays);
			tile_dirs(&rays, dirs);
		}
		job = (struct bc__tile_job){
		    .fc = fc,
		    .dirs = dirs,
		    .list = tf->b->frags + tf->b->frag_off[tile],
		    .n = tf->b->list_n[tile],
		    .zq = tf->b->zq[tile],
		    .x0 = tx * BC_CPU_TILE,
		    .y0 = ty * BC_CPU_TILE,
		    .x1 =
		        (tx + 1) * BC_CPU_TILE < w ? (tx + 1) * BC_CPU_TILE : w,
		    .y1 =
		        (ty + 1) * BC_CPU_TILE < h ? (ty + 1) * BC_CPU_TILE : h,
		    .mask = mask,
		};
		cut = bc__trace_tile(wk, &job);
		if (cut) {
			/* One thread draws a tile: its byte is this
			 * thread's to write. */
			wk->short_rays += bc__popcount64(cut);
			if (fc->short_tiles) {
				fc->short_tiles[tile] = 1;
			}
		}
		done++;
	}
}

static int tiled_create(struct bc_renderer **out,
                        const struct bc_render_opts *opts,
                        struct bc_errinfo *ei)
{
	return bc__cpu_create(out, BC__CPU_TILED, opts, ei);
}

/* Gives every worker room for the depths and the list of `longest`
 * fragments, here on the calling thread (tile_list's tz and out). */
static int prepare_listers(struct bc__cpu *r, uint32_t longest)
{
	struct bc__tiled_bufs *b = r->tiled;
	for (uint32_t i = 0; i < r->threads; i++) {
		struct bc__tile_worker *wk = &b->workers[i];
		if (wk->tz_cap < longest) {
			float *tz =
			    bc_malloc(2 * (size_t)longest * sizeof(*tz));
			struct bc__frag *lst =
			    bc_malloc((size_t)longest * sizeof(*lst));
			if (!tz || !lst) {
				bc_free(tz);
				bc_free(lst);
				return BC_ENOMEM;
			}
			bc_free(wk->tz);
			bc_free(wk->lst);
			wk->tz = tz;
			wk->lst = lst;
			wk->tz_cap = longest;
		}
	}
	return 0;
}

/* Gives every worker room for `longest` active primitives and a view of
 * them, here on the calling thread, so the workers never allocate. */
static int prepare_workers(struct bc__cpu *r, const struct bc_lin *lin,
                           uint32_t longest)
{
	struct bc__tiled_bufs *b = r->tiled;
	uint32_t need = longest > 0 ? longest : 1;
	for (uint32_t i = 0; i < r->threads; i++) {
		struct bc__tile_worker *wk = &b->workers[i];
		wk->evals = 0;
		wk->short_rays = 0;
		wk->tiles_asked = 0;
		wk->rays = 0;
		wk->overflows = 0;
		wk->simd = r->base.opts.simd;
		if (wk->cap < need) {
			uint32_t *act = bc_calloc(need, sizeof(*act));
			float *t1 = bc_calloc(need, sizeof(*t1));
			if (!act || !t1) {
				bc_free(act);
				bc_free(t1);
				return BC_ENOMEM;
			}
			bc_free(wk->act);
			bc_free(wk->act_t1);
			wk->act = act;
			wk->act_t1 = t1;
			wk->cap = need;
		}
		if (wk->sort_cap < longest) {
			struct bc__frag *sort =
			    bc_malloc((size_t)longest * sizeof(*sort));
			if (!sort) {
				return BC_ENOMEM;
			}
			bc_free(wk->sort);
			wk->sort = sort;
			wk->sort_cap = longest;
		}
		if (longest > 0 && wk->view.cap < 2 * longest) {
			/* A view of the first `longest` primitives reserves
			 * what any active set of that size needs. */
			uint32_t m =
			    longest < lin->nprims ? longest : lin->nprims;
			int rc;
			for (uint32_t k = 0; k < m; k++) {
				wk->act[k] = k;
			}
			if ((rc = bc_view_build(&wk->view, lin, wk->act, m))) {
				return rc;
			}
		}
	}
	return 0;
}

/* Whether b's kept lists were made for this frame's view. */
static bool same_view(const struct bc__tiled_bufs *b, const struct bc__cpu *r,
                      const struct bc__frame_ctx *fc,
                      const struct bc_camera *cam)
{
	const struct bc_frame *f = fc->out;
	uint32_t win[4] = {f->win_x, f->win_y, f->full_width, f->full_height};
	return b->view_ok && b->w == f->width && b->h == f->height &&
	       memcmp(b->win, win, sizeof(win)) == 0 &&
	       b->generation == r->base.generation && b->lin == fc->lin &&
	       b->nprims == (fc->lin ? fc->lin->nprims : 0) &&
	       memcmp(&b->cam, cam, sizeof(*cam)) == 0 &&
	       memcmp(&b->min_step, &fc->min_step, sizeof(float)) == 0 &&
	       memcmp(&b->pix_angle, &fc->pix_angle, sizeof(float)) == 0;
}

/* Whether a new view's candidates (after phase_prims) would surely pass
 * the A-buffer's limit, so that it is banded without a count. A tile's
 * room is its candidates, a quarter more and 4 (slack), and its
 * candidates are the pairs of tile and rectangle that pass the tile's
 * cone test (visit_rows): a view whose pairs pass the limit may still
 * fit. The share of the pairs that pass is taken from every step-th
 * primitive's (SAMPLE_PRIMS of them, SAMPLE_PAIRS pairs at most: 1.6
 * and 6.4 ms at 3840x2160 and 4096x4096 of a million spheres on a busy
 * machine): about half at a million spheres (56 % at
 * 1024x768, 50 % at 3840x2160, whose 23.6 million pairs banded it before
 * and whose 11.8 million candidates fit), less where the eye is among
 * the primitives. A view estimated within an eighth over the limit is
 * counted, and banded after the count if it does not fit: a count costs
 * a cone test a pair (at 4096x4096, 62 million pairs, 7 % of the
 * frame). */
static bool surely_over(const struct tiled_frame *tf)
{
	const struct bc__tiled_bufs *b = tf->b;
	uint64_t pairs = atomic_load(&tf->pairs),
	         fixed = 4u * (uint64_t)tf->ntiles;
	uint64_t seen = 0, kept = 0, est;
	uint32_t step = tf->nprims / SAMPLE_PRIMS + 1u;
	if (pairs + fixed <= tf->limit) {
		return false;
	}
	for (uint32_t k = 0; k < tf->nprims && seen < SAMPLE_PAIRS; k += step) {
		const struct ab_prim *p = &b->prims[k];
		struct seen sp;
		if (p->rect.x0 >= p->rect.x1 || p->rect.y0 >= p->rect.y1) {
			continue;
		}
		prim_seen(tf->fc, k, p, &sp);
		for (uint32_t ty = p->rect.y0; ty < p->rect.y1; ty++) {
			const struct cone *c =
			    b->cones + CONES_PER_TILE * ((size_t)ty * tf->tw);
			for (uint32_t tx = p->rect.x0; tx < p->rect.x1; tx++) {
				kept += cone_meets_sphere(
				    &c[CONES_PER_TILE * tx], &sp);
			}
		}
		seen += (uint64_t)(p->rect.x1 - p->rect.x0) *
		        (p->rect.y1 - p->rect.y0);
	}
	est = seen ? (uint64_t)((double)pairs * (double)kept / (double)seen)
	           : pairs;
	return est + est / 4u + fixed > tf->limit + tf->limit / 8u;
}

/* Makes b's lists this frame's view's: all dropped for a new view, those
 * the dirty primitives can reach after parameter edits. Returns 0,
 * OVER_LIMIT when the view's lists cannot all be kept at once (its
 * primitives' rectangles are kept, and the frame is drawn in bands:
 * draw_bands), or an error, after which nothing is kept. */
static int keep_view(struct bc__cpu *r, struct tiled_frame *tf,
                     const struct bc_camera *cam)
{
	struct bc__tiled_bufs *b = tf->b;
	const struct bc__frame_ctx *fc = tf->fc;
	int rc;
	if (same_view(b, r, fc, cam)) {
		uint32_t hi =
		    b->dirty_hi < tf->nprims ? b->dirty_hi : tf->nprims;
		uint32_t lo = b->dirty_lo;
		bool patch =
		    !b->banded && (hi - lo <= BC_CPU_PATCH_PRIMS ||
		                   hi - lo <= tf->nprims / BC_CPU_PATCH_SHARE);
		/* A banded view's row index, patched for a few primitives. */
		bool rows =
		    b->banded && b->rows_ok && hi - lo <= BC_CPU_PATCH_PRIMS;
		if (lo >= hi) {
			return b->banded ? OVER_LIMIT : 0;
		}
		if (patch || rows) {
			memset(b->cur, 0, tf->ntiles * sizeof(*b->cur));
		}
		for (uint32_t k = lo; k < hi; k++) {
			struct ab_prim *p = &b->prims[k];
			for (int after = 0; after < 2; after++) {
				rect_state_and(tf, &p->rect,
				               (uint8_t)~TILE_LIST);
				if (patch) {
					rect_mark(tf, &p->rect);
				} else if (rows) {
					rows_mark(tf, &p->rect);
				}
				if (!after) {
					prim_setup(tf, k, p);
				}
			}
		}
		b->dirty_lo = b->dirty_hi = 0;
		if (b->banded) {
			/* It stays banded until the view changes: trying
			 * every row's lists again would cost a pass over
			 * every pair at each edit of a drag. */
			b->band_ok = false;
			b->rows_ok = rows && patch_rows(tf, lo, hi) == 0;
			return OVER_LIMIT;
		}
		b->view_ok = false;
		rc = patch && patch_pays(tf, lo, hi) ? patch_cand(tf, lo, hi)
		                                     : 1;
		if (rc == 1) {
			count_cand(tf, 0, tf->th);
			rc = build_cand(tf, 0, tf->th);
		}
		if (rc && rc != OVER_LIMIT) {
			return rc;
		}
		b->banded = rc == OVER_LIMIT;
		b->view_ok = true;
		return rc;
	}
	b->view_ok = false;
	b->banded = b->rows_ok = b->band_ok = false;
	b->dirty_lo = b->dirty_hi = 0;
	if (grow_tiles(b, tf->ntiles) ||
	    fit((void **)&b->prims, &b->prims_cap, tf->nprims ? tf->nprims : 1,
	        sizeof(*b->prims))) {
		return BC_ENOMEM;
	}
	memset(b->state, 0, tf->ntiles * sizeof(*b->state));
	atomic_store(&tf->next, 0u);
	atomic_store(&tf->pairs, 0u);
	if (tf->nprims > 0) {
		bc_pool_run(tf->threads, phase_prims, tf);
	}
	if (surely_over(tf)) {
		rc = OVER_LIMIT;
	} else {
		count_cand(tf, 0, tf->th);
		rc = build_cand(tf, 0, tf->th);
	}
	if (rc && rc != OVER_LIMIT) {
		return rc;
	}
	b->banded = rc == OVER_LIMIT;
	b->cam = *cam;
	b->w = fc->out->width;
	b->h = fc->out->height;
	b->win[0] = fc->out->win_x;
	b->win[1] = fc->out->win_y;
	b->win[2] = fc->out->full_width;
	b->win[3] = fc->out->full_height;
	b->generation = r->base.generation;
	b->lin = fc->lin;
	b->nprims = tf->nprims;
	b->min_step = fc->min_step;
	b->pix_angle = fc->pix_angle;
	b->view_ok = true;
	return rc;
}

/* Phase 2 over the region: every tile's list made and kept, the room
 * for those that did not fit made and the phase run again for them
 * (their lists are the same again: it runs once more at most). Returns
 * 0 or BC_ENOMEM. */
static int list_tiles(struct tiled_frame *tf, struct bc_render_stats *stats)
{
	struct bc__tiled_bufs *b = tf->b;
	size_t short_by = 0;
	do {
		int rc;
		if (short_by && (rc = make_frag_room(b, short_by, stats))) {
			return rc;
		}
		atomic_store(&tf->frag_next, b->frags_used);
		atomic_store(&tf->frag_short, 0u);
		spans_init(tf);
		bc_pool_run(tf->threads, phase_lists, tf);
		b->frags_used = atomic_load(&tf->frag_next);
		short_by = atomic_load(&tf->frag_short);
	} while (short_by);
	return 0;
}

/* Lists and traces the region's tiles in [tf->t0, tf->t1), whose
 * candidates are built, adding the work to stats. Returns 0 or
 * BC_ENOMEM. */
static int draw_tiles(struct bc__cpu *r, struct tiled_frame *tf,
                      struct bc_render_stats *stats)
{
	struct bc__tiled_bufs *b = tf->b;
	const struct bc_render_region *region = tf->region;
	double t_start = bc_clock_ms(), t_ab;
	uint32_t longest = 0, widest = 0, overflows = 0, todo = 0;
	int rc;
	for (uint32_t t = tf->t0; t < tf->t1; t++) {
		if ((!region->tiles || region->tiles[t]) &&
		    (b->state[t] & TILE_DONE) != TILE_DONE) {
			uint32_t c = b->cand_end[t] - b->cand_off[t];
			todo++;
			widest = c > widest ? c : widest;
		}
	}
	if (todo > 0) {
		if ((rc = prepare_listers(r, widest))) {
			return rc;
		}
		if ((rc = list_tiles(tf, stats))) {
			return rc;
		}
	}
	for (uint32_t t = tf->t0; t < tf->t1; t++) {
		if ((!region->tiles || region->tiles[t]) &&
		    b->list_n[t] > longest) {
			longest = b->list_n[t];
		}
	}
	if ((rc = prepare_workers(r, tf->fc->lin, longest))) {
		return rc;
	}
	t_ab = bc_clock_ms();
	spans_init(tf);
	bc_pool_run(tf->threads, phase_trace, tf);
	for (uint32_t i = 0; i < r->threads; i++) {
		overflows += b->workers[i].overflows;
	}
	if (overflows) {
		bc_log(BC_LOG_DEBUG,
		       "render: %u depth ranges went over M_overlap=%u",
		       overflows, BC_CPU_M_OVERLAP);
	}
	stats->ms_abuffer += t_ab - t_start;
	stats->ms_trace += bc_clock_ms() - t_ab;
	stats->max_overlap =
	    longest > stats->max_overlap ? longest : stats->max_overlap;
	for (uint32_t i = 0; i < r->threads; i++) {
		stats->tiles += b->workers[i].tiles_asked;
		stats->rays += b->workers[i].rays;
		stats->field_evals += b->workers[i].evals;
		stats->short_rays += b->workers[i].short_rays;
	}
	return 0;
}

/* Whether tile row y holds a tile of the region's. */
static bool row_asked(const struct tiled_frame *tf, uint32_t y)
{
	uint32_t a = y * tf->tw, z = a + tf->tw;
	a = a > tf->t0 ? a : tf->t0;
	z = z < tf->t1 ? z : tf->t1;
	if (!tf->region->tiles) {
		return a < z;
	}
	for (uint32_t t = a; t < z; t++) {
		if (tf->region->tiles[t]) {
			return true;
		}
	}
	return false;
}

/* Rows a band made for a region of fewer rows takes at least, while the
 * limit allows: the daemon draws a view in slices of tiles in row order
 * (a few dozen tiles of a 480-tile row at 3840 pixels), and the slices
 * after the one that made it find their rows' candidates and lists
 * built (b->band_*). Made for one slice's rows only, the lists of each
 * row were sorted out again for every slice of it. */
#define BAND_MIN_ROWS 8u

/* Draws the region of a view whose lists would pass the A-buffer's
 * limit all at once: in bands of whole tile rows, each band's lists
 * within the limit, built, drawn and dropped in turn (the pixels are
 * those of one pass: a tile's list is the same whichever band builds
 * it), except the last band's, kept for the next call. Rows the region
 * does not touch are not built. A row whose lists alone pass the limit
 * cannot be drawn: BC_ELIMIT. */
static int draw_bands(struct bc__cpu *r, struct tiled_frame *tf,
                      struct bc_render_stats *stats, struct bc_errinfo *ei)
{
	struct bc__tiled_bufs *b = tf->b;
	uint32_t t0 = tf->t0, t1 = tf->t1, nb = 0;
	uint32_t y = t0 / tf->tw, y_end = (t1 + tf->tw - 1) / tf->tw;
	uint32_t y_more = y + BAND_MIN_ROWS;
	uint32_t *band;
	double t_lists = bc_clock_ms();
	int rc = 0;
	if (b->band_ok && y >= b->band_y0 && y_end <= b->band_y1) {
		/* An earlier call built these rows: their lists are kept
		 * too. */
		stats->bands = 1;
		return draw_tiles(r, tf, stats);
	}
	y_more = y_more < y_end ? y_end : y_more < tf->th ? y_more : tf->th;
	if (!b->rows_ok && few_rows(tf, y, y_more) && (rc = build_rows(tf))) {
		return rc;
	}
	if (!(band = bc_malloc(2 * (size_t)tf->th * sizeof(*band)))) {
		return BC_ENOMEM;
	}
	/* The bands, from one count of the region's rows (and of those the
	 * last band may take): each as many rows as fit. A band's build
	 * rewrites the counts of its own rows only, so the count serves
	 * every band's build. */
	count_cand(tf, y, y_more);
	while (y < y_end) {
		uint32_t y1 = y;
		uint64_t sum = 0;
		if (!row_asked(tf, y)) {
			y++;
			continue;
		}
		while (y1 < y_end && row_asked(tf, y1) &&
		       sum + row_room(tf, y1) <= tf->limit) {
			sum += row_room(tf, y1++);
		}
		if (y1 == y) {
			rc = bc_errinfo_set(
			    ei, BC_ELIMIT,
			    "render: tile row %u alone needs %llu A-buffer "
			    "entries (its primitive-tile pairs and room to "
			    "grow), over the limit of %u (fewer or smaller "
			    "primitives, or a narrower frame)",
			    y, (unsigned long long)row_room(tf, y), tf->limit);
			goto out;
		}
		while (y1 == y_end && y1 < y_more &&
		       sum + row_room(tf, y1) <= tf->limit) {
			sum += row_room(tf, y1++);
			y_end = y1; /* the last band, for the next calls */
		}
		band[2 * nb] = y;
		band[2 * nb + 1] = y1;
		nb++;
		y = y1;
	}
	for (uint32_t i = 0; i < nb && rc == 0; i++) {
		uint32_t a = band[2 * i] * tf->tw, z = band[2 * i + 1] * tf->tw;
		tf->t0 = a > t0 ? a : t0;
		tf->t1 = z < t1 ? z : t1;
		b->band_ok = false;
		rc = build_cand(tf, band[2 * i], band[2 * i + 1]);
		if (rc == OVER_LIMIT) {
			/* The count above fitted these rows: unreachable. */
			rc = bc_errinfo_set(ei, BC_ELIMIT,
			                    "render: an A-buffer band over "
			                    "its count");
		} else if (rc == 0) {
			b->band_ok = true;
			b->band_y0 = band[2 * i];
			b->band_y1 = band[2 * i + 1];
			stats->ms_abuffer += bc_clock_ms() - t_lists;
			rc = tf->t0 < tf->t1 ? draw_tiles(r, tf, stats) : 0;
			t_lists = bc_clock_ms();
		}
	}
	tf->t0 = t0;
	tf->t1 = t1;
	stats->bands = nb;
out:
	bc_free(band);
	return rc;
}

static int tiled_render(struct bc_renderer *base, const struct bc_camera *cam,
                        struct bc_frame *out,
                        const struct bc_render_region *region,
                        struct bc_render_stats *stats, struct bc_errinfo *ei)
{
	struct bc__cpu *r = bc__cpu_of(base);
	struct bc__frame_ctx fc;
	struct tiled_frame tf = {0};
	struct bc__tiled_bufs *b;
	const struct bc_lin *lin;
	double t_start = bc_clock_ms();
	uint32_t limit = base->opts.abuffer_limit;
	int rc;
	if (!r->tiled && !(r->tiled = bc_calloc(1, sizeof(*r->tiled)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "render: out of memory");
	}
	b = r->tiled;
	lin = bc_tree_lin(base->tree);
	bc__frame_setup(&fc, lin, cam, out, base->opts.debug);
	fc.max_evals = region->max_evals;
	fc.short_tiles = region->short_tiles;
	tf.fc = &fc;
	tf.region = region;
	tf.threads = bc_render_region_threads(region, r->threads);
	tf.b = b;
	tf.kern = bc__ab_kernel_for(base->opts.simd);
	tf.tw = (out->width + BC_CPU_TILE - 1) / BC_CPU_TILE;
	tf.th = (out->height + BC_CPU_TILE - 1) / BC_CPU_TILE;
	tf.ntiles = tf.tw * tf.th;
	tf.t0 = region->tile_count ? region->tile_first : 0;
	tf.t1 = region->tile_count ? region->tile_first + region->tile_count
	                           : tf.ntiles;
	tf.nprims = lin ? lin->nprims : 0;
	tf.limit = limit > 0 && limit < BC_CPU_MAX_FRAGMENTS
	               ? limit
	               : BC_CPU_MAX_FRAGMENTS;
	atomic_init(&tf.next, 0u);
	atomic_init(&tf.tiles_done, 0u);
	atomic_init(&tf.skipped, 0u);
	tf.deadline =
	    base->opts.budget_ms ? t_start + base->opts.budget_ms : 0.0;
	rc = keep_view(r, &tf, cam);
	if (rc && rc != OVER_LIMIT) {
		goto fail;
	}
	bc_render_progress_init(&tf.progress, &r->base, tf.ntiles);
	stats->ms_abuffer = bc_clock_ms() - t_start;
	stats->ab_pairs = atomic_load(&tf.pairs);
	stats->ab_candidates = tf.cands;
	stats->bands = 1;
	rc = rc == OVER_LIMIT ? draw_bands(r, &tf, stats, ei)
	                      : draw_tiles(r, &tf, stats);
	if (rc) {
		goto fail;
	}
	stats->ms_total = bc_clock_ms() - t_start;
	stats->incomplete = atomic_load(&tf.skipped) > 0;
	return 0;
fail:
	if (rc != BC_ENOMEM) {
		return rc;
	}
	return bc_errinfo_set(ei, BC_ENOMEM,
	                      "render: out of memory for a "
	                      "%ux%u frame",
	                      out->width, out->height);
}

/* Tile t's candidates without primitives [lo, hi), those past hi moved
 * by shift; its list is dropped when it lost one, else renumbered. */
static void follow_tile(struct bc__tiled_bufs *b, uint32_t t, uint32_t lo,
                        uint32_t hi, uint32_t shift)
{
	uint32_t o = b->cand_off[t], w = o, end = b->cand_end[t];
	uint32_t *c = b->cand, gone = 0;
	/* Most tiles lose no candidate (an insertion loses none, a removal
	 * only the tiles of what went): a look for one, then the renumbering
	 * in place, both loops without branches that the compiler turns
	 * into vector code, the pass over every candidate a splice before
	 * the end costs (follow_splice). */
	for (uint32_t i = o; i < end; i++) {
		gone |= (uint32_t)(c[i] - lo < hi - lo);
	}
	if (!gone) {
		for (uint32_t i = o; i < end; i++) {
			c[i] += c[i] >= hi ? shift : 0u;
		}
		w = end;
	}
	for (uint32_t i = o; gone && i < end; i++) {
		uint32_t k = c[i];
		if (k >= lo && k < hi) {
			continue;
		}
		c[w++] = k >= hi ? k + shift : k;
	}
	if (w != b->cand_end[t]) {
		b->state[t] &= (uint8_t)~TILE_LIST;
		b->cand_end[t] = w;
	} else if ((b->state[t] & TILE_LIST) && shift) {
		struct bc__frag *f = b->frags + b->frag_off[t];
		for (uint32_t i = 0; i < b->list_n[t]; i++) {
			f[i].prim += f[i].prim >= hi ? shift : 0u;
		}
	}
}

/* The kept view follows one splice of the primitives' indices: the
 * primitives that went leave the candidate lists (and the lists of their
 * tiles are dropped), those past them are renumbered there and in the
 * kept lists, and the new ones get empty rectangles (their tiles come
 * with the dirty range, keep_view). A splice at the end of the
 * primitives (an operand added to or taken from the end of the root's
 * operator, the usual edit of a big scene) touches only the tiles of
 * those that went; one before it takes a pass over every candidate, at
 * memory speed. It runs on the caller's thread: a sync has no share of
 * the cores from the daemon's scheduler (bc_render_region.threads is a
 * render call's), so taking the pool here would run on cores it gave
 * another session's work. */
static int follow_splice(struct bc__tiled_bufs *b,
                         const struct bc_dirty_splice *sp)
{
	uint32_t tw = (b->w + BC_CPU_TILE - 1) / BC_CPU_TILE;
	uint32_t ntiles = tw * ((b->h + BC_CPU_TILE - 1) / BC_CPU_TILE);
	uint32_t lo = sp->at, hi = sp->at + sp->del, n = b->nprims;
	uint32_t shift = sp->ins - sp->del; /* modulo 2^32 */
	if (hi > n ||
	    grow_keep((void **)&b->prims, &b->prims_cap,
	              (size_t)n - sp->del + sp->ins + 1u, sizeof(*b->prims))) {
		return BC_ENOMEM;
	}
	if (b->banded) {
		/* Only a band's lists are kept: dropped, and the rows
		 * sorted again. */
		b->rows_ok = b->band_ok = false;
	} else if (hi == n) {
		for (uint32_t k = lo; k < hi; k++) {
			const struct rect *r = &b->prims[k].rect;
			for (uint32_t ty = r->y0; ty < r->y1; ty++) {
				for (uint32_t tx = r->x0; tx < r->x1; tx++) {
					follow_tile(b, ty * tw + tx, lo, hi,
					            shift);
				}
			}
		}
	} else {
		for (uint32_t t = 0; t < ntiles; t++) {
			follow_tile(b, t, lo, hi, shift);
		}
	}
	memmove(b->prims + lo + sp->ins, b->prims + hi,
	        (size_t)(n - hi) * sizeof(*b->prims));
	for (uint32_t k = lo; k < lo + sp->ins; k++) {
		memset(&b->prims[k].rect, 0, sizeof(b->prims[k].rect));
	}
	b->nprims = n - sp->del + sp->ins;
	bc_dirty_splice_range(sp, &b->dirty_lo, &b->dirty_hi);
	return 0;
}

/* Records the primitives whose ABVs changed, for the next render to drop
 * the lists they can reach (keep_view). A structural change drops all,
 * but one made of splices, which the kept view follows. */
static int tiled_sync(struct bc_renderer *base, const struct bc_tree *t,
                      const struct bc_dirty *dirty, struct bc_errinfo *ei)
{
	struct bc__tiled_bufs *b = bc__cpu_of(base)->tiled;
	(void)ei;
	if (!b) {
		return 0;
	}
	if (dirty && dirty->structure && dirty->spliced && b->view_ok) {
		for (uint32_t i = 0; i < dirty->nsplices && b->view_ok; i++) {
			if (follow_splice(b, &dirty->splice[i])) {
				b->view_ok = false;
			}
		}
		/* The scene may be another object now (bc_tree_swap). */
		b->lin = bc_tree_lin(t);
	} else if (!dirty || dirty->structure) {
		b->view_ok = false;
		return 0;
	}
	if (dirty->prim_lo >= dirty->prim_hi) {
		return 0;
	}
	if (b->dirty_lo >= b->dirty_hi) {
		b->dirty_lo = dirty->prim_lo;
		b->dirty_hi = dirty->prim_hi;
	} else {
		b->dirty_lo =
		    b->dirty_lo < dirty->prim_lo ? b->dirty_lo : dirty->prim_lo;
		b->dirty_hi =
		    b->dirty_hi > dirty->prim_hi ? b->dirty_hi : dirty->prim_hi;
	}
	return 0;
}

/* The tiles whose lists can hold a primitive of world ABV abv: the same
 * widening and projection the A-buffer applies (phase_rects), so a tile
 * left unmarked never lists it, and its pixels cannot change with it. */
static void tiled_damage(struct bc_renderer *base, const struct bc_camera *cam,
                         uint32_t width, uint32_t height,
                         const struct bc_abv *abv, uint8_t *tiles)
{
	struct bc_frame dims = {.width = width, .height = height};
	struct bc__frame_ctx fc;
	struct tiled_frame tf = {0};
	struct bc_abv wide;
	struct rect rc;
	float lo[3], hi[3];
	bc__frame_setup(&fc, base->tree ? bc_tree_lin(base->tree) : NULL, cam,
	                &dims, base->opts.debug);
	tf.fc = &fc;
	tf.tw = bc_render_tiles_x(width);
	tf.th = bc_render_tiles_y(height);
	widened_abv(&fc, abv, &wide, lo, hi);
	rc = project_box(&tf, lo, hi);
	for (uint32_t ty = rc.y0; ty < rc.y1; ty++) {
		memset(tiles + (size_t)ty * tf.tw + rc.x0, 1, rc.x1 - rc.x0);
	}
}

/* Frees every buffer kept for the last view: the next render finds no
 * buffers, as the first one did, and computes the lists it needs again
 * from their tiles alone, so it draws the same pixels. */
static void tiled_release(struct bc_renderer *base)
{
	struct bc__cpu *r = bc__cpu_of(base);
	bc__tiled_free(r->tiled);
	r->tiled = NULL;
}

/* What tiled_release frees, from the buffers' capacities. */
static size_t tiled_kept_bytes(const struct bc_renderer *base)
{
	const struct bc__tiled_bufs *b =
	    ((const struct bc__cpu *)(const void *)base)->tiled;
	size_t n;
	if (!b) {
		return 0;
	}
	n = sizeof(*b) + b->prims_cap * sizeof(*b->prims) +
	    b->cand_cap * sizeof(*b->cand) + b->frags_cap * sizeof(*b->frags) +
	    b->row_off_cap * sizeof(*b->row_off) +
	    b->row_prims_cap * sizeof(*b->row_prims) +
	    b->share_cap * sizeof(*b->share_cur) +
	    b->scratch_cap * sizeof(*b->scratch);
	if (b->tiles_cap) {
		n += b->tiles_cap *
		         (sizeof(*b->state) + sizeof(*b->list_n) +
		          sizeof(*b->cur) + sizeof(*b->zq) +
		          sizeof(*b->frag_off) + sizeof(*b->frag_room) +
		          CONES_PER_TILE * sizeof(*b->cones)) +
		     2 * (b->tiles_cap + 1) * sizeof(*b->cand_off) +
		     b->tiles_cap *
		         (sizeof(*b->cand_end) + sizeof(*b->cand_lim));
	}
	for (uint32_t i = 0; i < BC_CPU_MAX_THREADS; i++) {
		const struct bc__tile_worker *wk = &b->workers[i];
		n +=
		    (size_t)wk->cap * (sizeof(*wk->act) + sizeof(*wk->act_t1)) +
		    (size_t)wk->tile_cap * sizeof(*wk->tile_act) +
		    (size_t)wk->tz_cap *
		        (2 * sizeof(*wk->tz) + sizeof(*wk->lst)) +
		    (size_t)wk->sort_cap * sizeof(*wk->sort) +
		    ((size_t)wk->view.cap + wk->tile_view.cap) *
		        sizeof(*wk->view.instr);
	}
	return n;
}

const struct bc_backend_ops bc_backend_tiled_ops = {
    .name = "tiled",
    .create = tiled_create,
    .destroy = bc__cpu_destroy,
    .sync = tiled_sync,
    .render = tiled_render,
    .key = bc_render_scale_key,
    .damage = tiled_damage,
    .follows_splices = true,
    .release = tiled_release,
    .kept_bytes = tiled_kept_bytes,
};
