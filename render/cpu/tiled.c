/*
 * The tiled CPU backend: Zanni 2024 §6 on CPU threads.
 *
 * A-buffer. The screen is cut into 8x8 tiles. Each primitive's world ABV is
 * projected (through its world AABB, conservatively) to a rectangle of
 * tiles; for each such tile whose bounding cone of pixel rays meets the
 * ABV's bounding sphere, the tile's pixel rays are clipped against the ABV
 * itself and the hits aggregate into one fragment: min entry, max exit (no
 * fragment when no ray hits). Fragments are bucketed per tile. Depths are
 * ray parameters t along unit directions rather than the paper's NDC: a
 * primitive's interval on every ray of the tile lies inside its fragment's
 * [entry, exit], which is all the range walk below needs.
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
#include "blobcast/log.h"

struct bc__tiled_bufs {
	float *dirs; /* 3 per pixel */
	size_t dirs_cap;
	/* The view dirs and cones were made for: kept while it stays. */
	struct bc_camera rays_cam;
	uint32_t rays_w, rays_h;
	struct cone *cones;
	size_t cones_cap;
	struct rect *rects;     /* per primitive */
	uint64_t *cand_off;     /* per primitive + 1: candidate tiles */
	size_t prims_cap;
	float *cand;            /* 2 per candidate: entry, exit */
	size_t cand_cap;
	uint32_t *tile_off;     /* per tile + 1 */
	uint32_t *tile_cur;
	size_t tiles_cap;
	struct bc__frag *frags;
	size_t frags_cap;
	struct bc__tile_worker workers[BC_CPU_MAX_THREADS];
};

/* Tiles [x0, x1) x [y0, y1) a primitive may cover. */
struct rect {
	uint32_t x0, y0, x1, y1;
};

/* Apex at the eye: every pixel ray of a block is within the half-angle
 * (given by its cosine and sine) of axis. */
struct cone {
	float axis[3];
	float cos_h, sin_h;
};

/* Cones per tile: the whole tile, then its four 4x4 quarters. */
#define CONES_PER_TILE 5u
#define QUARTER (BC_CPU_TILE / 2u)

void bc__tiled_free(struct bc__tiled_bufs *b)
{
	if (!b) {
		return;
	}
	bc_free(b->dirs);
	bc_free(b->cones);
	bc_free(b->rects);
	bc_free(b->cand_off);
	bc_free(b->cand);
	bc_free(b->tile_off);
	bc_free(b->tile_cur);
	bc_free(b->frags);
	for (uint32_t i = 0; i < BC_CPU_MAX_THREADS; i++) {
		bc_view_finish(&b->workers[i].view);
		bc_free(b->workers[i].act);
		bc_free(b->workers[i].act_t1);
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

/* Grows two arrays that share one capacity. */
static int grow_pair(void **p, void **q, size_t *cap, size_t n, size_t psize,
		     size_t qsize)
{
	void *fp, *fq;
	if (n <= *cap) {
		return 0;
	}
	fp = bc_calloc(n, psize);
	fq = bc_calloc(n, qsize);
	if (!fp || !fq) {
		bc_free(fp);
		bc_free(fq);
		return BC_ENOMEM;
	}
	bc_free(*p);
	bc_free(*q);
	*p = fp;
	*q = fq;
	*cap = n;
	return 0;
}

/* ---- One frame ---------------------------------------------------------- */

struct tiled_frame {
	const struct bc__frame_ctx *fc;
	struct bc__tiled_bufs *b;
	uint32_t tw, th, ntiles;
	uint32_t nprims;
	const struct bc_render_region *region;
	uint64_t ncand;
	atomic_uint next;   /* work counter of the running phase */
	atomic_uint tiles_done;
	struct bc__progress progress;
	double deadline;   /* bc_render_now_ms() past which no tile starts; 0: none */
	atomic_uint skipped; /* tiles left as background past the deadline */
	atomic_uint tiles_asked, rays; /* tiles and pixels the region asks */
};

static inline float dot3(const float a[3], const float b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static float angle_between(const float a[3], const float b[3])
{
	float c = dot3(a, b);
	return acosf(c > 1.0f ? 1.0f : (c < -1.0f ? -1.0f : c));
}

/* The cone of the pixel rays through pixel centres [x0, x1] x [y0, y1]
 * (inclusive, in pixel coordinates). */
static void make_cone(const struct bc_view_rays *vr, float x0, float y0,
		      float x1, float y1, struct cone *c)
{
	float cx[4] = {x0, x1, x0, x1}, cy[4] = {y0, y0, y1, y1};
	float half = 0.0f;
	bc_view_rays_dir(vr, 0.5f * (x0 + x1), 0.5f * (y0 + y1), c->axis);
	for (int k = 0; k < 4; k++) {
		float corner[3];
		bc_view_rays_dir(vr, cx[k], cy[k], corner);
		half = bc__maxf(half, angle_between(corner, c->axis));
	}
	/* Margin for rounding in the angle computations. */
	half += 1.0e-4f;
	c->cos_h = cosf(half);
	c->sin_h = sinf(half);
}

/* Phase 1, per pixel row: ray directions; per tile row: tile cones. */
static void phase_rays(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	const struct bc__frame_ctx *fc = tf->fc;
	uint32_t w = fc->out->width, h = fc->out->height;
	(void)thread;
	for (;;) {
		uint32_t y = atomic_fetch_add(&tf->next, 1u);
		float *row;
		if (y >= h) {
			break;
		}
		row = tf->b->dirs + 3 * (size_t)y * w;
		for (uint32_t x = 0; x < w; x++) {
			bc_view_rays_dir(&fc->vr, (float)x + 0.5f,
					 (float)y + 0.5f, row + 3 * x);
		}
		if (y % BC_CPU_TILE != 0) {
			continue;
		}
		for (uint32_t tx = 0; tx < tf->tw; tx++) {
			struct cone *c =
				&tf->b->cones[CONES_PER_TILE *
					      ((y / BC_CPU_TILE) * tf->tw + tx)];
			uint32_t x0 = tx * BC_CPU_TILE;
			uint32_t x1 = x0 + BC_CPU_TILE < w ? x0 + BC_CPU_TILE : w;
			uint32_t y1 = y + BC_CPU_TILE < h ? y + BC_CPU_TILE : h;
			make_cone(&fc->vr, (float)x0 + 0.5f, (float)y + 0.5f,
				  (float)x1 - 0.5f, (float)y1 - 0.5f, &c[0]);
			for (uint32_t q = 0; q < 4; q++) {
				uint32_t qx0 = x0 + (q & 1u) * QUARTER;
				uint32_t qy0 = y + (q >> 1) * QUARTER;
				uint32_t qx1 = qx0 + QUARTER < x1 ? qx0 + QUARTER
								  : x1;
				uint32_t qy1 = qy0 + QUARTER < y1 ? qy0 + QUARTER
								  : y1;
				if (qx0 >= qx1 || qy0 >= qy1) {
					continue; /* off the image's edge */
				}
				make_cone(&fc->vr, (float)qx0 + 0.5f,
					  (float)qy0 + 0.5f, (float)qx1 - 0.5f,
					  (float)qy1 - 0.5f, &c[1 + q]);
			}
		}
	}
}

/* The tiles the box [lo, hi] can cover, conservatively. */
static struct rect project_box(const struct tiled_frame *tf, const float lo[3],
			       const float hi[3])
{
	const struct bc__frame_ctx *fc = tf->fc;
	const struct bc_view_rays *vr = &fc->vr;
	float w = (float)fc->out->width, h = (float)fc->out->height;
	float px0 = INFINITY, px1 = -INFINITY, py0 = INFINITY, py1 = -INFINITY;
	struct rect all = {0, 0, tf->tw, tf->th}, none = {0, 0, 0, 0}, r;
	int behind = 0;
	for (int c = 0; c < 8; c++) {
		float p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1],
			      (c & 4) ? hi[2] : lo[2]};
		float v[3] = {p[0] - vr->eye[0], p[1] - vr->eye[1],
			      p[2] - vr->eye[2]};
		float z = dot3(v, vr->forward), sx, sy;
		if (!(z > 1.0e-6f * (fabsf(v[0]) + fabsf(v[1]) + fabsf(v[2])))) {
			behind++;
			continue;
		}
		sx = dot3(v, vr->right) / (z * vr->tan_half_y * vr->aspect);
		sy = dot3(v, vr->up) / (z * vr->tan_half_y);
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
	 * margin absorbs rounding. */
	px0 = bc__maxf(px0 - 1.5f, 0.0f);
	py0 = bc__maxf(py0 - 1.5f, 0.0f);
	px1 = bc__minf(px1 + 0.5f, w - 1.0f);
	py1 = bc__minf(py1 + 0.5f, h - 1.0f);
	if (!(px0 <= px1 && py0 <= py1)) {
		return none;
	}
	r.x0 = (uint32_t)px0 / BC_CPU_TILE;
	r.y0 = (uint32_t)py0 / BC_CPU_TILE;
	r.x1 = (uint32_t)px1 / BC_CPU_TILE + 1;
	r.y1 = (uint32_t)py1 / BC_CPU_TILE + 1;
	return r;
}

/* The world ABV of primitive k widened by the hit epsilon (times the
 * Lipschitz bound, since the tracer compares field / 1.45): a ray counts
 * as a hit where the field is below that, which can be just outside the
 * ABV itself when the ROI offset is 0 (sharp operators). Without the
 * margin such near hits, which naive tracing finds, would fall between
 * depth ranges. Widening only adds primitives to views, which is always
 * safe. The epsilon grows with distance: the farthest point of the
 * primitive's bounding sphere sets it. */
static void widened_abv(const struct bc__frame_ctx *fc,
			const struct bc_abv *abv, struct bc_abv *out,
			float lo[3], float hi[3])
{
	const float *eye = fc->vr.eye;
	float far = 0.0f, r2 = 0.0f, m;
	*out = *abv;
	bc_abv_aabb(out, lo, hi);
	for (int i = 0; i < 3; i++) {
		float c = 0.5f * (lo[i] + hi[i]) - eye[i];
		float e = 0.5f * (hi[i] - lo[i]);
		far += c * c;
		r2 += e * e;
	}
	far = sqrtf(far) + sqrtf(r2);
	m = BC_CPU_LIPSCHITZ *
	    bc__maxf(BC_CPU_HIT_FOOTPRINT * fc->pix_angle * far, fc->min_step);
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
	for (int i = 0; i < 3; i++) {
		lo[i] -= m;
		hi[i] += m;
	}
}

/* Phase 2, per primitive: its tile rectangle. */
static void phase_rects(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	(void)thread;
	for (;;) {
		uint32_t k0 = atomic_fetch_add(&tf->next, 256u);
		if (k0 >= tf->nprims) {
			break;
		}
		for (uint32_t k = k0; k < tf->nprims && k < k0 + 256u; k++) {
			struct bc_abv abv;
			float lo[3], hi[3];
			widened_abv(tf->fc, &tf->fc->lin->abv[k], &abv, lo, hi);
			tf->b->rects[k] = project_box(tf, lo, hi);
		}
	}
}

/* Does the sphere (centre relative to the eye v, radius r) meet the
 * cone? With dist = |v| > r the sphere spans the angle asin(r / dist)
 * around v, so they meet when the angle between v and the axis is at most
 * half + asin(r / dist), i.e. (both angles below pi) when
 * dot(v, axis) >= cos_h sqrt(dist^2 - r^2) - sin_h r. */
static inline bool cone_meets_sphere(const struct cone *c, const float v[3],
				     float dist2, float r)
{
	if (dist2 <= r * r) {
		return true;
	}
	return dot3(v, c->axis) >=
	       c->cos_h * sqrtf(dist2 - r * r) - c->sin_h * r;
}

/* A sphere around the (world) shape: tighter than the AABB's for spheres
 * and capsules, which makes the cone tests sharper. */
static void bounding_sphere(const struct bc_abv *abv, const float lo[3],
			    const float hi[3], float c[3], float *r)
{
	float e2 = 0.0f;
	switch (abv->shape) {
	case BC_ABV_SPHERE:
		memcpy(c, abv->center, sizeof(abv->center));
		*r = abv->radius;
		return;
	case BC_ABV_CAPSULE:
		for (int i = 0; i < 3; i++) {
			float e = 0.5f * (abv->end[i] - abv->center[i]);
			c[i] = abv->center[i] + e;
			e2 += e * e;
		}
		*r = sqrtf(e2) + abv->radius;
		return;
	case BC_ABV_BOX:
		memcpy(c, abv->center, sizeof(abv->center));
		*r = sqrtf(dot3(abv->half, abv->half));
		return;
	default:
		for (int i = 0; i < 3; i++) {
			float e = 0.5f * (hi[i] - lo[i]);
			c[i] = lo[i] + e;
			e2 += e * e;
		}
		*r = sqrtf(e2);
		return;
	}
}

/* Ray (from the eye, unit d) against a sphere ABV (centre v relative to the
 * eye, radius r): the one shape whose test is inlined here, because sphere
 * ABVs are the most common and a call to bc_abv_ray per pixel ray (double
 * precision, outward rounding) was most of the A-buffer's time at 4096
 * primitives. Computing the squared distance of the centre from the ray
 * directly avoids the cancellation of b^2 - c; the interval is padded
 * outwards. Rays that graze the sphere within rounding may be lost, which
 * is safe because the ABV was widened by the hit epsilon (widened_abv):
 * every ray that meets the unwidened ABV crosses this sphere well inside. */
static inline bool ray_sphere(const float v[3], float r, const float d[3],
			      float *t0, float *t1)
{
	float b = dot3(v, d);
	float p[3] = {v[0] - b * d[0], v[1] - b * d[1], v[2] - b * d[2]};
	float disc = r * r - dot3(p, p), s, pad;
	if (!(disc >= 0.0f)) {
		return false;
	}
	s = sqrtf(disc);
	pad = 1.0e-5f * (fabsf(b) + r);
	*t0 = b - s - pad;
	*t1 = b + s + pad;
	return true;
}

/* The fragment of one ABV in tile (tx, ty): min entry and max exit over
 * the tile's pixel rays that hit it, or (inf, -inf). The tile's cone, then
 * each quarter's, are tested against the ABV's bounding sphere (v: centre
 * relative to the eye) before any ray is. */
static void fragment(const struct tiled_frame *tf, const struct bc_abv *abv,
		     const float v[3], float dist2, float radius, uint32_t tx,
		     uint32_t ty, float out[2])
{
	const struct bc__frame_ctx *fc = tf->fc;
	const struct cone *cones =
		&tf->b->cones[CONES_PER_TILE * (ty * tf->tw + tx)];
	uint32_t w = fc->out->width, h = fc->out->height;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	uint32_t x1 = x0 + BC_CPU_TILE < w ? x0 + BC_CPU_TILE : w;
	uint32_t y1 = y0 + BC_CPU_TILE < h ? y0 + BC_CPU_TILE : h;
	float t0 = INFINITY, t1 = -INFINITY;
	out[0] = t0;
	out[1] = t1;
	if (!cone_meets_sphere(&cones[0], v, dist2, radius)) {
		return;
	}
	for (uint32_t q = 0; q < 4; q++) {
		uint32_t qx0 = x0 + (q & 1u) * QUARTER;
		uint32_t qy0 = y0 + (q >> 1) * QUARTER;
		uint32_t qx1 = qx0 + QUARTER < x1 ? qx0 + QUARTER : x1;
		uint32_t qy1 = qy0 + QUARTER < y1 ? qy0 + QUARTER : y1;
		if (qx0 >= qx1 || qy0 >= qy1 ||
		    !cone_meets_sphere(&cones[1 + q], v, dist2, radius)) {
			continue;
		}
		for (uint32_t y = qy0; y < qy1; y++) {
			const float *d = tf->b->dirs + 3 * ((size_t)y * w + qx0);
			for (uint32_t x = qx0; x < qx1; x++, d += 3) {
				float a, e;
				bool hit = abv->shape == BC_ABV_SPHERE
						   ? ray_sphere(v, abv->radius, d,
								&a, &e)
						   : bc_abv_ray(abv, fc->vr.eye, d,
								&a, &e);
				if (hit && e > 0.0f) {
					a = a > 0.0f ? a : 0.0f;
					t0 = a < t0 ? a : t0;
					t1 = e > t1 ? e : t1;
				}
			}
		}
	}
	out[0] = t0;
	out[1] = t1;
}

/* Phase 3, per chunk of candidates: the fragment of primitive k in each
 * candidate tile. */
#define CAND_CHUNK 64u

static void phase_intervals(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	const struct bc__frame_ctx *fc = tf->fc;
	struct bc__tiled_bufs *b = tf->b;
	uint32_t nchunks = (uint32_t)((tf->ncand + CAND_CHUNK - 1) / CAND_CHUNK);
	(void)thread;
	for (;;) {
		uint32_t chunk = atomic_fetch_add(&tf->next, 1u);
		uint64_t c0, c1;
		uint32_t lo = 0, hi;
		if (chunk >= nchunks) {
			break;
		}
		c0 = (uint64_t)chunk * CAND_CHUNK;
		c1 = c0 + CAND_CHUNK < tf->ncand ? c0 + CAND_CHUNK : tf->ncand;
		/* The primitive owning candidate c0: last k with
		 * cand_off[k] <= c0. */
		hi = tf->nprims;
		while (hi - lo > 1) {
			uint32_t mid = lo + (hi - lo) / 2;
			if (b->cand_off[mid] <= c0) {
				lo = mid;
			} else {
				hi = mid;
			}
		}
		for (uint32_t k = lo; k < tf->nprims && b->cand_off[k] < c1;
		     k++) {
			const struct rect *r = &b->rects[k];
			struct bc_abv abv;
			uint32_t rw = r->x1 - r->x0;
			uint64_t from = b->cand_off[k] > c0 ? b->cand_off[k] : c0;
			uint64_t to = b->cand_off[k + 1] < c1 ? b->cand_off[k + 1]
							      : c1;
			float lo3[3], hi3[3], v[3], dist2, radius;
			widened_abv(fc, &fc->lin->abv[k], &abv, lo3, hi3);
			bounding_sphere(&abv, lo3, hi3, v, &radius);
			for (int i = 0; i < 3; i++) {
				v[i] -= fc->vr.eye[i];
			}
			dist2 = dot3(v, v);
			for (uint64_t c = from; c < to; c++) {
				uint32_t j = (uint32_t)(c - b->cand_off[k]);
				uint32_t tx = r->x0 + j % rw, ty = r->y0 + j / rw;
				if (tf->region->tiles &&
				    !tf->region->tiles[ty * tf->tw + tx]) {
					/* Not drawn: no list needed. */
					b->cand[2 * c] = INFINITY;
					b->cand[2 * c + 1] = -INFINITY;
					continue;
				}
				fragment(tf, &abv, v, dist2, radius, tx, ty,
					 &b->cand[2 * c]);
			}
		}
	}
}

/* Past the frame budget: the tile's asked pixels become background. */
static void skip_tile(struct tiled_frame *tf, uint32_t tx, uint32_t ty,
		      uint64_t mask)
{
	const struct bc__frame_ctx *fc = tf->fc;
	uint32_t w = fc->out->width, h = fc->out->height;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	for (uint32_t y = y0; y < y0 + BC_CPU_TILE && y < h; y++) {
		for (uint32_t x = x0; x < x0 + BC_CPU_TILE && x < w; x++) {
			if ((mask >> ((y - y0) * BC_CPU_TILE + (x - x0))) & 1u) {
				bc__put_miss(fc, x, y, 0, 0);
			}
		}
	}
	atomic_fetch_add(&tf->skipped, 1u);
}

/* Phase 4, per tile of the region: walk the depth ranges and trace. */
static void phase_trace(void *arg, uint32_t thread)
{
	struct tiled_frame *tf = arg;
	struct bc__tile_worker *wk = &tf->b->workers[thread];
	const struct bc__frame_ctx *fc = tf->fc;
	uint32_t w = fc->out->width, h = fc->out->height;
	for (;;) {
		uint32_t tile = atomic_fetch_add(&tf->next, 1u);
		uint32_t tx = tile % tf->tw, ty = tile / tf->tw;
		struct bc__tile_job job;
		uint64_t mask;
		if (tile >= tf->ntiles) {
			break;
		}
		mask = bc__region_mask(tf->region, tx, ty, w, h);
		if (!mask) {
			continue;
		}
		atomic_fetch_add(&tf->tiles_asked, 1u);
		atomic_fetch_add(&tf->rays, bc__popcount64(mask));
		if (tf->deadline > 0.0 && bc_render_now_ms() > tf->deadline) {
			skip_tile(tf, tx, ty, mask);
			continue;
		}
		job = (struct bc__tile_job){
			.fc = fc,
			.dirs = tf->b->dirs,
			.list = tf->b->frags + tf->b->tile_off[tile],
			.n = tf->b->tile_off[tile + 1] - tf->b->tile_off[tile],
			.x0 = tx * BC_CPU_TILE,
			.y0 = ty * BC_CPU_TILE,
			.x1 = (tx + 1) * BC_CPU_TILE < w ? (tx + 1) * BC_CPU_TILE
							 : w,
			.y1 = (ty + 1) * BC_CPU_TILE < h ? (ty + 1) * BC_CPU_TILE
							 : h,
			.mask = mask,
		};
		bc__trace_tile(wk, &job);
		atomic_fetch_add(&tf->tiles_done, 1u);
		if (thread == 0) {
			bc__progress_tick(&tf->progress,
					  atomic_load(&tf->tiles_done));
		}
	}
}

/* Buckets the candidates that hold a fragment by tile. Returns the longest
 * tile list. */
static uint32_t bucket(struct tiled_frame *tf)
{
	struct bc__tiled_bufs *b = tf->b;
	uint32_t longest = 0;
	memset(b->tile_cur, 0, tf->ntiles * sizeof(*b->tile_cur));
	for (int pass = 0; pass < 2; pass++) {
		for (uint32_t k = 0; k < tf->nprims; k++) {
			const struct rect *r = &b->rects[k];
			uint32_t rw = r->x1 - r->x0;
			for (uint64_t c = b->cand_off[k]; c < b->cand_off[k + 1];
			     c++) {
				uint32_t j = (uint32_t)(c - b->cand_off[k]);
				uint32_t tile = (r->y0 + j / rw) * tf->tw +
						r->x0 + j % rw;
				if (!(b->cand[2 * c + 1] >= b->cand[2 * c])) {
					continue; /* no ray of the tile hit */
				}
				if (pass == 0) {
					b->tile_cur[tile]++;
				} else {
					b->frags[b->tile_cur[tile]++] =
						(struct bc__frag){b->cand[2 * c],
							      b->cand[2 * c + 1], k};
				}
			}
		}
		if (pass == 0) {
			uint32_t sum = 0;
			for (uint32_t t = 0; t < tf->ntiles; t++) {
				uint32_t cnt = b->tile_cur[t];
				b->tile_off[t] = sum;
				b->tile_cur[t] = sum;
				sum += cnt;
				longest = cnt > longest ? cnt : longest;
			}
			b->tile_off[tf->ntiles] = sum;
		}
	}
	return longest;
}

static int tiled_create(struct bc_renderer **out,
			const struct bc_render_opts *opts, struct bc_errinfo *ei)
{
	return bc__cpu_create(out, BC__CPU_TILED, opts, ei);
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
		if (longest > 0 && wk->view.cap < 2 * longest) {
			/* A view of the first `longest` primitives reserves
			 * what any active set of that size needs. */
			uint32_t m = longest < lin->nprims ? longest
							   : lin->nprims;
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
	double t_start = bc_render_now_ms(), t_ab;
	uint32_t longest = 0, overflows = 0;
	size_t npix;
	int rc;
	if (!r->tiled && !(r->tiled = bc_calloc(1, sizeof(*r->tiled)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "render: out of memory");
	}
	b = r->tiled;
	lin = bc_tree_lin(base->tree);
	bc__frame_setup(&fc, lin, cam, out, base->opts.debug);
	tf.fc = &fc;
	tf.region = region;
	tf.b = b;
	tf.tw = (out->width + BC_CPU_TILE - 1) / BC_CPU_TILE;
	tf.th = (out->height + BC_CPU_TILE - 1) / BC_CPU_TILE;
	tf.ntiles = tf.tw * tf.th;
	tf.nprims = lin ? lin->nprims : 0;
	npix = (size_t)out->width * out->height;
	if (grow((void **)&b->dirs, &b->dirs_cap, 3 * npix, sizeof(float)) ||
	    grow((void **)&b->cones, &b->cones_cap,
		 (size_t)CONES_PER_TILE * tf.ntiles, sizeof(*b->cones)) ||
	    grow_pair((void **)&b->tile_off, (void **)&b->tile_cur,
		      &b->tiles_cap, (size_t)tf.ntiles + 1, sizeof(uint32_t),
		      sizeof(uint32_t))) {
		goto nomem;
	}
	atomic_init(&tf.next, 0u);
	atomic_init(&tf.tiles_done, 0u);
	atomic_init(&tf.skipped, 0u);
	atomic_init(&tf.tiles_asked, 0u);
	atomic_init(&tf.rays, 0u);
	tf.deadline = base->opts.budget_ms ? t_start + base->opts.budget_ms
					 : 0.0;
	/* Directions and cones depend on the view only: a region drawn into
	 * the same view (damage, refinement) reuses them. */
	if (b->rays_w != out->width || b->rays_h != out->height ||
	    memcmp(&b->rays_cam, cam, sizeof(*cam)) != 0) {
		bc_pool_run(r->threads, phase_rays, &tf);
		b->rays_cam = *cam;
		b->rays_w = out->width;
		b->rays_h = out->height;
	}
	if (tf.nprims > 0) {
		if (grow_pair((void **)&b->rects, (void **)&b->cand_off,
			      &b->prims_cap, (size_t)tf.nprims + 1,
			      sizeof(*b->rects), sizeof(uint64_t))) {
			goto nomem;
		}
		atomic_store(&tf.next, 0u);
		bc_pool_run(r->threads, phase_rects, &tf);
		b->cand_off[0] = 0;
		for (uint32_t k = 0; k < tf.nprims; k++) {
			const struct rect *rc_ = &b->rects[k];
			b->cand_off[k + 1] =
				b->cand_off[k] + (uint64_t)(rc_->x1 - rc_->x0) *
							 (rc_->y1 - rc_->y0);
		}
		tf.ncand = b->cand_off[tf.nprims];
		if (tf.ncand > BC_CPU_MAX_FRAGMENTS) {
			return bc_errinfo_set(
				ei, BC_ELIMIT,
				"render: %llu primitive-tile pairs exceed the "
				"A-buffer limit of %u (fewer or smaller "
				"primitives, or a smaller frame)",
				(unsigned long long)tf.ncand,
				BC_CPU_MAX_FRAGMENTS);
		}
		if (grow((void **)&b->cand, &b->cand_cap,
			 2 * (size_t)(tf.ncand ? tf.ncand : 1), sizeof(float))) {
			goto nomem;
		}
		atomic_store(&tf.next, 0u);
		bc_pool_run(r->threads, phase_intervals, &tf);
		if (grow((void **)&b->frags, &b->frags_cap,
			 (size_t)(tf.ncand ? tf.ncand : 1), sizeof(*b->frags))) {
			goto nomem;
		}
		longest = bucket(&tf);
	} else {
		memset(b->tile_off, 0, ((size_t)tf.ntiles + 1) * sizeof(uint32_t));
	}
	if ((rc = prepare_workers(r, lin, longest))) {
		goto nomem;
	}
	t_ab = bc_render_now_ms();
	bc__progress_init(&tf.progress, r, tf.ntiles);
	atomic_store(&tf.next, 0u);
	bc_pool_run(r->threads, phase_trace, &tf);
	for (uint32_t i = 0; i < r->threads; i++) {
		overflows += b->workers[i].overflows;
	}
	if (overflows) {
		bc_log(BC_LOG_DEBUG,
		       "render: %u depth ranges went over M_overlap=%u", overflows,
		       BC_CPU_M_OVERLAP);
	}
	{
		double now = bc_render_now_ms();
		stats->ms_abuffer = t_ab - t_start;
		stats->ms_trace = now - t_ab;
		stats->ms_total = now - t_start;
		stats->max_overlap = longest;
		stats->incomplete = atomic_load(&tf.skipped) > 0;
		stats->tiles = atomic_load(&tf.tiles_asked);
		stats->rays = atomic_load(&tf.rays);
		for (uint32_t i = 0; i < r->threads; i++) {
			stats->field_evals += b->workers[i].evals;
		}
	}
	return 0;
nomem:
	return bc_errinfo_set(ei, BC_ENOMEM, "render: out of memory for a "
			      "%ux%u frame", out->width, out->height);
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

const struct bc_backend_ops bc_backend_tiled_ops = {
	.name = "tiled",
	.create = tiled_create,
	.destroy = bc__cpu_destroy,
	.render = tiled_render,
	.key = bc__cpu_key,
	.damage = tiled_damage,
};
