/*
 * The `svo` backend: struct bc_backend_ops over the adaptive octree. sync()
 * compiles the tree into an RPN (a copy: later edits do not reach it until
 * the next sync); render() builds the octree when it has none or when the
 * frame needs a thicker hit band than it was built with (the band depends
 * on the camera and the resolution), then casts one ray per pixel centre
 * on worker threads, 8x8 tiles at a time.
 *
 * Pixels mean what they mean for the CPU backends (render.h): the same hit
 * criterion (svo.h), the same normals (tetrahedral differences over the
 * hit thickness), light, colours, background and debug ramps, so frames of
 * `svo` and `tiled` compare pixel by pixel. The octree's build time is
 * reported as ms_abuffer, the slot for a frame's acceleration structure,
 * and counts against the frame's time budget: past it no tile is started.
 * A region's evaluation bound goes to the caster (cast.c), which stops a
 * ray at it; a ray that ran out, or whose normal would go past it, is left
 * as the frame held it. release frees the octree and keeps its band, so
 * the next render builds the same one.
 */
#include "svo_impl.h"

#include <math.h>
#include <stdatomic.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/render_backend.h"
#include "blobcast/render_common.h"
#include "blobcast/shade.h"

/* Worker threads at most, whatever opts.threads asks. */
#define SVO_MAX_THREADS BC_POOL_MAX_THREADS
/* Tile edge in pixels: rays of a tile share leaves, so handing out tiles
 * rather than rows keeps a thread's octree walk in cache. */
#define SVO_TILE 8u
/* A ray packet's block of pixels (BC_SVO_PACKET of them). */
#define PACKET_W 4u
#define PACKET_H 2u
/* The octree is built with this much more band than the frame needs, so a
 * camera that moves a little does not force a rebuild every frame. */
#define SVO_BAND_SLACK 1.5f
/* Debug ramps saturate here (the CPU backends' values). */
#define SVO_DEBUG_EVALS_MAX 256.0f
#define SVO_DEBUG_TERMS_MAX 64.0f

struct svo_renderer {
	struct bc_renderer base; /* the front's part, first */
	uint32_t threads;
	bool synced, empty;
	struct bc_svo_rpn rpn;
	struct bc_svo *svo;
	float band; /* band the octree was built with */
};

static struct svo_renderer *svo_of(struct bc_renderer *base)
{
	return (struct svo_renderer *)base; /* base is the first member */
}

static int svo_create(struct bc_renderer **out,
                      const struct bc_render_opts *opts, struct bc_errinfo *ei)
{
	struct svo_renderer *r;
	*out = NULL;
	if ((int)opts->svo_range < BC_RANGE_DEFAULT ||
	    opts->svo_range >= BC_RANGE_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM, "svo: unknown range %d",
		                      (int)opts->svo_range);
	}
	if (opts->svo_max_depth > BC_SVO_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "svo: max depth %u exceeds %u",
		                      opts->svo_max_depth, BC_SVO_MAX_DEPTH);
	}
	if ((int)opts->debug < BC_DEBUG_NONE || opts->debug >= BC_DEBUG_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM,
		                      "svo: unknown debug mode %d",
		                      (int)opts->debug);
	}
	r = bc_calloc(1, sizeof(*r));
	if (!r) {
		return bc_errinfo_set(ei, BC_ENOMEM, "svo: out of memory");
	}
	r->threads = opts->threads ? opts->threads : bc_pool_default_threads();
	if (r->threads > SVO_MAX_THREADS) {
		r->threads = SVO_MAX_THREADS;
	}
	*out = &r->base;
	return 0;
}

static void svo_destroy(struct bc_renderer *base)
{
	struct svo_renderer *r = svo_of(base);
	if (!r) {
		return;
	}
	bc_svo_destroy(r->svo);
	bc_svo_rpn_finish(&r->rpn);
	bc_free(r);
}

static bool unchanged(const struct bc_dirty *d)
{
	return d && !d->structure && d->slot_lo == d->slot_hi &&
	       d->param_lo == d->param_hi && d->prim_lo == d->prim_hi &&
	       d->edits == 0;
}

static int svo_sync(struct bc_renderer *base, const struct bc_tree *t,
                    const struct bc_dirty *dirty, struct bc_errinfo *ei)
{
	struct svo_renderer *r = svo_of(base);
	const struct bc_lin *l;
	int rc;
	if (r->synced && unchanged(dirty)) {
		return 0;
	}
	/* Any change moves the field somewhere: the octree is rebuilt, for
	 * the band of the next frame. */
	bc_svo_destroy(r->svo);
	r->svo = NULL;
	r->band = 0.0f;
	bc_svo_rpn_finish(&r->rpn);
	r->synced = false;
	l = t ? bc_tree_lin(t) : NULL;
	r->empty = l == NULL;
	if (l && (rc = bc_svo_rpn_init(&r->rpn, l))) {
		return bc_errinfo_set(ei, rc, "svo: compiling the tree: %s",
		                      bc_strerror(rc));
	}
	r->synced = true;
	return 0;
}

/* ---- Pixels ---------------------------------------------------------------
 */

struct frame {
	struct svo_renderer *r;
	struct bc_frame *out;
	const struct bc_render_region *region;
	struct bc_view_rays vr;
	struct bc_svo_cast_params cp;
	struct bc_shade shade;
	uint32_t tiles_x, ntiles;
	double start, budget_ms; /* budget 0: none */
	atomic_bool late;        /* the budget ran out: tiles left blank */
	atomic_uint next;
	atomic_uint_fast64_t evals, rays, short_rays;
	atomic_uint tiles;
	atomic_int err;
};

static void debug_px(const struct frame *fr, uint32_t evals, uint32_t terms,
                     uint8_t px[4])
{
	if (fr->r->base.opts.debug == BC_DEBUG_EVALS) {
		bc_shade_ramp((float)evals / SVO_DEBUG_EVALS_MAX, px);
	} else {
		bc_shade_ramp((float)terms / SVO_DEBUG_TERMS_MAX, px);
	}
}

static void put_miss(const struct frame *fr, uint32_t x, uint32_t y,
                     uint32_t evals)
{
	struct bc_frame *out = fr->out;
	size_t i = (size_t)y * out->width + x;
	uint8_t *px = out->rgba + 4 * i;
	if (fr->r->base.opts.debug != BC_DEBUG_NONE) {
		debug_px(fr, evals, 0, px);
	} else {
		bc_shade_miss(bc_frame_view_row(out, y),
		              bc_frame_view_height(out), px);
	}
	if (out->depth) {
		out->depth[i] = INFINITY;
	}
	if (out->ids) {
		out->ids[i] = 0;
	}
}

/* The tetrahedral normal's directions. */
static const float tet[4][3] = {
    {1, -1, -1}, {-1, -1, 1}, {-1, 1, -1}, {1, 1, 1}};

/* The four points whose field gives a hit's normal: differences over the
 * hit thickness, the scale the surface was resolved at (as the CPU
 * backends take them). */
static void tet_points(const struct frame *fr, const float d[3],
                       const struct bc_svo_hit *hit, float q[4][3])
{
	const float *eye = fr->vr.eye;
	float t = hit->t;
	float p[3] = {eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]};
	float h =
	    fmaxf(BC_SVO_HIT_FOOTPRINT * fr->cp.pix_angle * t, fr->cp.min_step);
	for (int k = 0; k < 4; k++) {
		for (int c = 0; c < 3; c++) {
			q[k][c] = p[c] + h * tet[k][c];
		}
	}
}

/* Writes a hit; v holds the field at its tet_points. */
static void put_hit(const struct frame *fr, uint32_t x, uint32_t y,
                    const float d[3], const struct bc_svo_hit *hit,
                    const float v[4])
{
	const struct bc_svo_rpn *rpn = &fr->r->rpn;
	struct bc_frame *out = fr->out;
	size_t i = (size_t)y * out->width + x;
	uint8_t *px = out->rgba + 4 * i;
	float t = hit->t;
	float n[3] = {0.0f, 0.0f, 0.0f};
	for (int k = 0; k < 4; k++) {
		for (int c = 0; c < 3; c++) {
			n[c] += tet[k][c] * v[k];
		}
	}
	if (fr->r->base.opts.debug != BC_DEBUG_NONE) {
		debug_px(fr, hit->evals + hit->range_evals + 4u,
		         hit->leaf_terms, px);
	} else {
		static const float grey[3] = {0.7f, 0.7f, 0.7f};
		bc_shade_hit(
		    &fr->shade, n, d,
		    hit->prim < rpn->nprims ? rpn->color[hit->prim] : grey, px);
	}
	if (out->depth) {
		out->depth[i] = t;
	}
	if (out->ids) {
		out->ids[i] =
		    hit->prim < rpn->nprims ? rpn->prim_id[hit->prim] : 0;
	}
}

/* The normals' samples v[l] of the hits `hit`: two hits whose variant is
 * the same share one evaluation of it over eight points. */
static void normals(const struct frame *fr, const float (*d)[3],
                    const struct bc_svo_hit *hits, uint32_t hit, float (*v)[4])
{
	const struct bc_svo_rpn *rpn = &fr->r->rpn;
	while (hit) {
		uint32_t a = bc__svo_lowest(hit), b = BC_NONE;
		float q[8][3], out[8];
		hit &= hit - 1u;
		for (uint32_t rest = hit; rest; rest &= rest - 1u) {
			uint32_t l = bc__svo_lowest(rest);
			if (hits[l].mask.pairs == hits[a].mask.pairs &&
			    hits[l].mask.nwords == hits[a].mask.nwords) {
				b = l;
				break;
			}
		}
		tet_points(fr, d[a], &hits[a], q);
		if (b == BC_NONE) {
			bc_svo_cmask_eval_n(rpn, hits[a].mask,
			                    (const float(*)[3])q, 4, v[a]);
			continue;
		}
		hit &= ~(1u << b);
		tet_points(fr, d[b], &hits[b], q + 4);
		bc_svo_cmask_eval_n(rpn, hits[a].mask, (const float(*)[3])q, 8,
		                    out);
		memcpy(v[a], out, sizeof(v[a]));
		memcpy(v[b], out + 4, sizeof(v[b]));
	}
}

/* Samples of a hit's normal (tet_points). */
#define NORMAL_EVALS 4u

/* Whether a hit's normal fits within the frame's bound after what its
 * cast spent. */
static bool can_shade(const struct frame *fr, const struct bc_svo_hit *h)
{
	uint32_t used = h->evals + h->range_evals, most = fr->cp.max_evals;
	return most == 0 || (used <= most && most - used >= NORMAL_EVALS);
}

/* Casts n pixels (px[l], py[l]) as one packet and writes them, but for
 * those whose rays ran out of the frame's bound (their normal's samples
 * included): those are left as they are and counted in the return value.
 * A packet of one or two rays gains nothing from sharing, so those are
 * cast alone (the same result either way: bc_svo_cast_packet). */
static uint32_t cast_packet(const struct frame *fr, struct bc_svo_caster *c,
                            const uint32_t *px, const uint32_t *py, uint32_t n,
                            uint64_t *evals)
{
	float d[BC_SVO_PACKET][3], v[BC_SVO_PACKET][4];
	uint32_t hit = 0, cut = 0;
	struct bc_svo_hit hits[BC_SVO_PACKET];
	for (uint32_t l = 0; l < n; l++) {
		bc_view_rays_dir(&fr->vr, (float)px[l] + 0.5f,
		                 (float)py[l] + 0.5f, d[l]);
	}
	if (!c) {
		memset(hits, 0, sizeof(hits));
	} else if (n > 2) {
		hit = bc_svo_cast_packet(c, fr->vr.eye, (const float(*)[3])d, n,
		                         0.0f, INFINITY, &fr->cp, hits);
	} else {
		for (uint32_t l = 0; l < n; l++) {
			hit |= bc_svo_cast(c, fr->vr.eye, d[l], 0.0f, INFINITY,
			                   &fr->cp, &hits[l])
			           ? 1u << l
			           : 0u;
		}
	}
	for (uint32_t l = 0; l < n; l++) {
		if (hits[l].ran_out ||
		    ((hit >> l) & 1u && !can_shade(fr, &hits[l]))) {
			cut |= 1u << l;
		}
	}
	hit &= ~cut;
	normals(fr, d, hits, hit, v);
	for (uint32_t l = 0; l < n; l++) {
		if ((hit >> l) & 1u) {
			put_hit(fr, px[l], py[l], d[l], &hits[l], v[l]);
		} else if (!((cut >> l) & 1u)) {
			put_miss(fr, px[l], py[l],
			         hits[l].evals + hits[l].range_evals);
		}
		*evals += hits[l].evals + hits[l].range_evals;
	}
	return bc__svo_popcount(cut);
}

/* Casts the pixels of the tile at (x0, y0) that this pass renders, in
 * packets of BC_SVO_PACKET taken block by block (PACKET_W x PACKET_H
 * pixels: neighbouring rays cross the same nodes and leaves); a coarse
 * level's few pixels per block fill a packet from several blocks. Returns
 * how many pixels; *cut gets those whose rays ran out of the bound. */
static uint32_t cast_tile(const struct frame *fr, struct bc_svo_caster *c,
                          uint32_t x0, uint32_t y0, uint64_t *evals,
                          uint32_t *cut)
{
	const struct bc_render_region *rg = fr->region;
	const struct bc_frame *out = fr->out;
	uint32_t px[BC_SVO_PACKET], py[BC_SVO_PACKET], n = 0, total = 0;
	if (c) {
		bc_svo_caster_forget(c);
	}
	for (uint32_t by = y0; by < y0 + SVO_TILE && by < out->height;
	     by += PACKET_H) {
		for (uint32_t bx = x0; bx < x0 + SVO_TILE && bx < out->width;
		     bx += PACKET_W) {
			for (uint32_t y = by;
			     y < by + PACKET_H && y < out->height; y++) {
				for (uint32_t x = bx;
				     x < bx + PACKET_W && x < out->width; x++) {
					if (!bc_render_level_has(
					        x, y, rg->level, rg->refine)) {
						continue;
					}
					px[n] = x;
					py[n++] = y;
					if (n == BC_SVO_PACKET) {
						*cut += cast_packet(
						    fr, c, px, py, n, evals);
						total += n;
						n = 0;
					}
				}
			}
		}
	}
	if (n) {
		*cut += cast_packet(fr, c, px, py, n, evals);
		total += n;
	}
	return total;
}

static void worker(void *arg, uint32_t thread)
{
	struct frame *fr = arg;
	const struct bc_render_region *rg = fr->region;
	struct bc_svo_caster *c = NULL;
	struct bc_frame *out = fr->out;
	uint64_t evals = 0, rays = 0, cut_rays = 0;
	int rc = fr->r->svo ? bc_svo_caster_create(&c, fr->r->svo) : 0;
	if (rc) {
		/* The other threads take this one's share. */
		atomic_store(&fr->err, rc);
		return;
	}
	(void)thread;
	for (;;) {
		uint32_t tile = atomic_fetch_add(&fr->next, 1u);
		uint32_t x0, y0;
		if (tile >= fr->ntiles) {
			break;
		}
		if (rg->tiles && !rg->tiles[tile]) {
			continue;
		}
		atomic_fetch_add(&fr->tiles, 1u);
		x0 = (tile % fr->tiles_x) * SVO_TILE;
		y0 = (tile / fr->tiles_x) * SVO_TILE;
		if (fr->budget_ms > 0.0 &&
		    (atomic_load(&fr->late) ||
		     bc_clock_ms() - fr->start > fr->budget_ms)) {
			/* Past the frame's budget no tile is started: the rest
			 * is background, and the frame says so. */
			atomic_store(&fr->late, true);
			for (uint32_t y = y0;
			     y < y0 + SVO_TILE && y < out->height; y++) {
				for (uint32_t x = x0;
				     x < x0 + SVO_TILE && x < out->width; x++) {
					if (bc_render_level_has(x, y, rg->level,
					                        rg->refine)) {
						put_miss(fr, x, y, 0);
					}
				}
			}
			continue;
		}
		{
			uint32_t cut = 0;
			rays += cast_tile(fr, c, x0, y0, &evals, &cut);
			cut_rays += cut;
			if (cut && rg->short_tiles) {
				/* This thread alone draws the tile. */
				rg->short_tiles[tile] = 1;
			}
		}
	}
	atomic_fetch_add(&fr->evals, evals);
	atomic_fetch_add(&fr->rays, rays);
	atomic_fetch_add(&fr->short_rays, cut_rays);
	bc_svo_caster_destroy(c);
}

/* Hit thickness the frame needs: the band at the farthest corner of the
 * tree's box from the eye. */
static float frame_band(const struct bc_svo_rpn *rpn, const float eye[3],
                        const struct bc_svo_cast_params *cp)
{
	float far = 0.0f;
	for (uint32_t k = 0; k < 8; k++) {
		float s2 = 0.0f;
		for (int i = 0; i < 3; i++) {
			float c = (k >> i) & 1u ? rpn->hi[i] : rpn->lo[i];
			s2 += (c - eye[i]) * (c - eye[i]);
		}
		far = fmaxf(far, sqrtf(s2));
	}
	return bc_svo_hit_band(cp, far);
}

static int svo_render(struct bc_renderer *base, const struct bc_camera *cam,
                      struct bc_frame *out,
                      const struct bc_render_region *region,
                      struct bc_render_stats *stats, struct bc_errinfo *ei)
{
	struct svo_renderer *r = svo_of(base);
	struct frame fr;
	double t0 = bc_clock_ms(), t1;
	float size;
	int rc;
	if (!r->synced) {
		return bc_errinfo_set(ei, BC_ESTATE, "svo: render before sync");
	}
	memset(&fr, 0, sizeof(fr));
	fr.r = r;
	fr.out = out;
	fr.region = region;
	fr.start = t0;
	fr.budget_ms = (double)base->opts.budget_ms;
	/* A window's rays and pixel footprint are the whole view's. */
	bc_frame_view_rays(&fr.vr, cam, out);
	size = !r->empty && r->rpn.size > 0.0f && isfinite(r->rpn.size)
	           ? r->rpn.size
	           : 1.0f;
	fr.cp.pix_angle = 2.0f * fr.vr.tan_half_y / (float)fr.vr.height;
	fr.cp.min_step = BC_SVO_MIN_STEP_REL * size;
	fr.cp.refine_tol = BC_SVO_REFINE_REL * size;
	fr.cp.max_evals = region->max_evals;
	bc_shade_init(&fr.shade, &fr.vr);
	if (!r->empty) {
		float need = frame_band(&r->rpn, fr.vr.eye, &fr.cp);
		if (!r->svo || need > r->band) {
			/* After a release the octree is built again with
			 * the band it had: the same octree, the same
			 * pixels. */
			struct bc_svo_opts so = {
			    .arith = base->opts.svo_range,
			    .threshold = base->opts.svo_threshold,
			    .max_depth = base->opts.svo_max_depth,
			    .band = need > r->band ? need * SVO_BAND_SLACK
			                           : r->band,
			};
			bc_svo_destroy(r->svo);
			r->svo = NULL;
			if ((rc = bc_svo_build(&r->svo, &r->rpn, &so, ei))) {
				return rc;
			}
			r->band = so.band;
		}
	}
	t1 = bc_clock_ms();
	fr.tiles_x = (out->width + SVO_TILE - 1) / SVO_TILE;
	fr.ntiles = fr.tiles_x * ((out->height + SVO_TILE - 1) / SVO_TILE);
	atomic_init(&fr.next, 0u);
	atomic_init(&fr.evals, 0u);
	atomic_init(&fr.err, 0);
	atomic_init(&fr.late, false);
	atomic_init(&fr.rays, 0u);
	atomic_init(&fr.short_rays, 0u);
	atomic_init(&fr.tiles, 0u);
	bc_pool_run(bc_render_region_threads(region, r->threads), worker, &fr);
	if (atomic_load(&fr.next) < fr.ntiles) {
		/* Every thread failed to get its scratch memory. */
		rc = atomic_load(&fr.err);
		return bc_errinfo_set(ei, rc ? rc : BC_ENOMEM,
		                      "svo: no memory for the casters");
	}
	{
		double t2 = bc_clock_ms();
		stats->ms_total = t2 - t0;
		stats->ms_abuffer = t1 - t0;
		stats->ms_trace = t2 - t1;
		stats->field_evals = atomic_load(&fr.evals);
		stats->rays = atomic_load(&fr.rays);
		stats->short_rays = atomic_load(&fr.short_rays);
		stats->tiles = atomic_load(&fr.tiles);
		stats->incomplete = atomic_load(&fr.late);
	}
	return 0;
}

/* Frees the octree, by far the largest thing kept (the RPN belongs to the
 * synced tree and stays). The band it was built with stays too, so that
 * the next render builds the same octree. */
static void svo_release(struct bc_renderer *base)
{
	struct svo_renderer *r = svo_of(base);
	bc_svo_destroy(r->svo);
	r->svo = NULL;
}

/* The octree's bytes, from its arrays' capacities. */
static size_t svo_kept_bytes(const struct bc_renderer *base)
{
	const struct bc_svo *s =
	    ((const struct svo_renderer *)(const void *)base)->svo;
	if (!s) {
		return 0;
	}
	return sizeof(*s) + (size_t)s->capnodes * sizeof(*s->nodes) +
	       (size_t)s->capleaves * sizeof(*s->leaves) +
	       s->pool.cap * sizeof(*s->pool.v) +
	       (size_t)s->rpn->nwords * sizeof(*s->full);
}

const struct bc_backend_ops bc_backend_svo_ops = {
    .name = "svo",
    .create = svo_create,
    .destroy = svo_destroy,
    .sync = svo_sync,
    .render = svo_render,
    .release = svo_release,
    .kept_bytes = svo_kept_bytes,
    /* No key and no damage hook: any edit rebuilds the octree, whose
     * cells (and so every pixel) depend on all primitives. */
};
