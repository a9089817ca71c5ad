/*
 * What a job does, one slice at a time, on the worker holding its flow
 * (work.c). A frame job:
 *  1. start: syncs the renderer with the copy, takes the view (views.c)
 *     and plans a pass;
 *  2. render: the pass's tiles, a few milliseconds of them per slice (the
 *     cost model's milliseconds per ray say how many), each ray bounded
 *     in evaluations; passes in this order:
 *       - FIRST: tiles holding nothing, whole at a coarse level (the
 *         finest whose cost fits BC_SRV_COARSE_MS), or level 0 for a
 *         snapshot;
 *       - DAMAGE: tiles a parameter edit damaged, again at their level
 *         (over BC_SRV_DAMAGE_PCT of the view: FIRST again instead);
 *       - RETRY: tiles with rays that ran out of evaluations, again with
 *         four times the bound, up to BC_SRV_RAY_EVALS_MAX;
 *       - REFINE: the coarsest tiles one level finer, tracing only the
 *         pixels the level adds;
 *     a frame takes FIRST or DAMAGE, or else one RETRY or REFINE step; a
 *     snapshot goes on to level 0, retrying within the frame budget;
 *  3. encode: the tiles changed since the picture the clients hold, or
 *     the whole picture at the view's level (a large PNG a band of rows
 *     per slice);
 *  4. finish: the FRAME, shared by the job's targets.
 * A ray that runs out leaves its pixel as it was: before a pass the tiles
 * get the coarser level's values (or the background), so a picture is
 * always whole; the frame says INCOMPLETE and later frames retry. A
 * refinement that passes the frame budget sends what it has (INCOMPLETE)
 * and goes on in the next job.
 * A PICK is one ray, in one slice.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/clock.h"
#include "blobcast/log.h"
#include "blobcast/shade.h"
#include "work_impl.h"

/* ---- pick ---------------------------------------------------------------- */

/* One ray of the job's camera through pixel (x, y), sphere traced on the
 * full tree (a pick is one ray: no tiles to share), within
 * BC_SRV_PICK_EVALS primitive evaluations. */
static void pick(const struct flow *f, struct bc_job *job)
{
	const struct bc_lin *l = f->tree ? bc_tree_lin(f->tree) : NULL;
	const struct bc_job_req *q = &job->req;
	struct bc_work_done *d = &job->done;
	struct bc_view_rays vr;
	float dir[3], t0 = 0.0f, t1 = INFINITY, eps;
	uint64_t budget;
	if (!l || l->nprims == 0) {
		return;
	}
	bc_view_rays_init(&vr, &q->camera, q->width, q->height);
	bc_view_rays_dir(&vr, (float)q->pick_x + 0.5f, (float)q->pick_y + 0.5f,
	                 dir);
	for (int i = 0; i < 3; i++) {
		float inv = 1.0f / dir[i];
		float a = (l->lo[i] - vr.eye[i]) * inv;
		float b = (l->hi[i] - vr.eye[i]) * inv;
		if (dir[i] == 0.0f) {
			if (vr.eye[i] < l->lo[i] || vr.eye[i] > l->hi[i]) {
				return;
			}
			continue;
		}
		t0 = fmaxf(t0, fminf(a, b));
		t1 = fminf(t1, fmaxf(a, b));
	}
	eps = 1e-4f * l->size;
	budget = BC_SRV_PICK_EVALS / l->nprims + 1u;
	for (uint64_t step = 0; step < budget && t0 <= t1; step++) {
		float p[3] = {vr.eye[0] + t0 * dir[0], vr.eye[1] + t0 * dir[1],
		              vr.eye[2] + t0 * dir[2]};
		uint32_t k;
		float v = bc_eval_full_id(l, p, &k);
		if (v < eps) {
			d->hit = k != BC_NONE;
			d->node = d->hit ? l->node_id[l->prim_slot[k]] : 0;
			if (d->hit) {
				memcpy(d->position, p, sizeof(p));
				d->depth = t0;
			}
			return;
		}
		/* The compact operators compress the field: 1.45 bounds its
		 * Lipschitz constant (Zanni 2024, §7). */
		t0 += fmaxf(v / 1.45f, eps);
	}
}

/* ---- ending -------------------------------------------------------------- */

void bc__job_end(struct bc_work *w, struct bc_job *job,
                 enum bc_work_outcome outcome)
{
	job->done.outcome = outcome;
	if (job->v) {
		bc__view_release(w, job->v);
		job->v = NULL;
	}
	bc_encode_job_free(job->enc);
	job->enc = NULL;
}

void bc__job_free(struct bc_job *job)
{
	if (!job) {
		return;
	}
	bc_shared_unref(job->done.frame);
	bc_encode_job_free(job->enc);
	for (uint32_t i = 0; i < job->req.ntargets; i++) {
		bc_shared_unref(job->done.vframes[i]);
		bc_vstream_unref(job->req.video[i]);
	}
	bc_free(job);
}

bool bc__job_yieldable(const struct bc_job *job)
{
	if (job->req.kind != BC_JOB_FRAME) {
		return false;
	}
	return job->stage == JS_START ||
	       (job->stage == JS_RENDER &&
	        (job->pass == PASS_RETRY || job->pass == PASS_REFINE));
}

/* ---- planning ------------------------------------------------------------ */

/* The level a new picture starts at: the finest whose estimated cost fits
 * BC_SRV_COARSE_MS, never coarser than the clients accept. */
static int start_level(const struct flow *f, const struct bc_job_req *q)
{
	int max = (int)q->max_level;
	if (f->ms_per_ray <= 0.0) {
		return max; /* no estimate yet: the cheapest picture */
	}
	/* A link slower than the renderer (frames.c) asks for coarser. */
	for (int l = (int)q->min_level < max ? (int)q->min_level : max; l < max;
	     l++) {
		double rays = (double)((q->width + (1u << l) - 1) >> l) *
		              (double)((q->height + (1u << l) - 1) >> l);
		if (f->ms_abuffer + rays * f->ms_per_ray <= BC_SRV_COARSE_MS) {
			return l;
		}
	}
	return max;
}

/* Whether tile t takes part in the job's pass. */
static bool selected(const struct bc_job *job, uint32_t t)
{
	const struct view *v = job->v;
	switch (job->pass) {
	case PASS_FIRST:
		return v->tlevel[t] < 0;
	case PASS_DAMAGE:
		return v->damage[t] && v->tlevel[t] == job->pass_level;
	case PASS_RETRY:
		return v->shorts[t] && v->tlevel[t] == job->pass_level;
	case PASS_REFINE:
		return v->tlevel[t] == job->pass_level + 1;
	default:
		return false;
	}
}

/* The finest level among tiles matching what (damage or short bytes) that
 * hold something, or -1 when none does. */
static int8_t level_of_marked(const struct view *v, const uint8_t *what)
{
	int8_t level = -1;
	for (uint32_t t = 0; t < v->ntiles; t++) {
		if (what[t] && v->tlevel[t] >= 0 && v->tlevel[t] > level) {
			level = v->tlevel[t];
		}
	}
	return level;
}

/* A large damage starts the picture anew at a coarse level: past
 * BC_SRV_DAMAGE_PCT of the view a damage render costs about a whole
 * frame. Never for a snapshot, which wants every pixel at level 0. */
static void forget_large_damage(struct bc_work *w, struct bc_job *job)
{
	struct view *v = job->v;
	uint32_t n = 0;
	if (!v->damaged || w->opts.no_damage ||
	    job->req.kind == BC_JOB_SNAPSHOT) {
		return;
	}
	for (uint32_t t = 0; t < v->ntiles; t++) {
		n += v->damage[t] && v->tlevel[t] >= 0;
	}
	if ((uint64_t)n * 100u > (uint64_t)v->ntiles * BC_SRV_DAMAGE_PCT) {
		bc__view_reset(v);
	}
}

/* Whether the job has run past the frame budget since it started. */
static bool over_budget(const struct bc_work *w, const struct bc_job *job)
{
	return bc_clock_ms() - job->started_ms > (double)w->budget_ms;
}

/* Milliseconds a slice of the job's pass aims at: BC_SRV_SLICE_MS, and
 * no more than the frame budget for a step that the budget may cut. */
static double slice_target(const struct bc_work *w, const struct bc_job *job)
{
	bool cut = job->req.kind == BC_JOB_FRAME &&
	           (job->pass == PASS_RETRY || job->pass == PASS_REFINE);
	return cut && (double)w->budget_ms < BC_SRV_SLICE_MS
	           ? (double)w->budget_ms
	           : BC_SRV_SLICE_MS;
}

/* Tiles per slice for ms a slice, from the session's cost model. */
static uint32_t tiles_for(const struct flow *f, const struct bc_job *job,
                          double ms)
{
	double rays, k;
	if (bc_renderer_wants_large_regions(f->r)) {
		/* Every call pays the whole frame's lists and readback (gl):
		 * sized by its tracing, a slice of a big scene came down to
		 * one tile, and a 1024x768 frame of 65 536 spheres took 50
		 * minutes on llvmpipe. A pass in one call pays them once. */
		return BC_SRV_SLICE_TILES_MAX;
	}
	if (f->ms_per_ray <= 0.0) {
		return BC_SRV_SLICE_TILES_FIRST;
	}
	rays = (double)(64u >> (2u * (uint32_t)job->pass_level));
	rays *= job->pass == PASS_REFINE ? 0.75 : 1.0;
	k = ms / (rays * f->ms_per_ray);
	return k < 1.0                              ? 1u
	       : k > (double)BC_SRV_SLICE_TILES_MAX ? BC_SRV_SLICE_TILES_MAX
	                                            : (uint32_t)k;
}

/* Chooses the next pass (job->pass, PASS_NONE when the picture is as far
 * as this job takes it) and its slice size. first: the job's first plan;
 * retry: rays that ran out may be traced again with a larger bound. */
static void plan_pass(const struct flow *f, struct bc_job *job, bool first,
                      bool retry);

static void plan(struct bc_work *w, const struct flow *f, struct bc_job *job,
                 bool first)
{
	/* A snapshot goes down to level 0 whatever it costs, but retries
	 * only within the frame budget: past it, it is sent INCOMPLETE
	 * (a twist at rate 1e6 retried every tile at the largest bound for
	 * a minute). A frame's refinement is cut in after_pass. */
	bool retry = job->req.kind != BC_JOB_SNAPSHOT || !over_budget(w, job);
	plan_pass(f, job, first, retry);
	job->slice_tiles = tiles_for(f, job, slice_target(w, job));
}

static void plan_pass(const struct flow *f, struct bc_job *job, bool first,
                      bool retry)
{
	struct view *v = job->v;
	bool snapshot = job->req.kind == BC_JOB_SNAPSHOT;
	int level = bc__view_level(v);
	int8_t l;
	job->cursor = 0;
	job->bound = f->ray_bound;
	job->pass = PASS_NONE;
	if (level < 0) {
		job->pass = PASS_FIRST;
		job->pass_level =
		    (int8_t)(snapshot ? 0 : start_level(f, &job->req));
		return;
	}
	if (v->damaged && (l = level_of_marked(v, v->damage)) >= 0) {
		job->pass = PASS_DAMAGE;
		job->pass_level = l;
		return;
	}
	v->damaged = false;
	if (!first && !snapshot) {
		return; /* one step per frame */
	}
	if (retry && v->bound < BC_SRV_RAY_EVALS_MAX &&
	    (l = level_of_marked(v, v->shorts)) >= 0) {
		job->pass = PASS_RETRY;
		job->pass_level = l;
		job->bound = 4u * v->bound < BC_SRV_RAY_EVALS_MAX
		                 ? 4u * v->bound
		                 : BC_SRV_RAY_EVALS_MAX;
		return;
	}
	if (level > 0) {
		job->pass = PASS_REFINE;
		job->pass_level = (int8_t)(level - 1);
	}
}

/* ---- rendering ----------------------------------------------------------- */

/* Before a pass traces a tile, the pixels it traces take the value a ray
 * that runs out should leave: the coarser level's (refinement), the
 * background (a tile that held nothing), or what they held (a damage or
 * retry pass redraws over its own picture). */
static void prefill(const struct bc_job *job, uint32_t t)
{
	const struct view *v = job->v;
	const struct bc_frame *fr = &v->frame;
	uint32_t x0 = (t % v->tw) * BC_RENDER_TILE;
	uint32_t y0 = (t / v->tw) * BC_RENDER_TILE;
	uint32_t level = (uint32_t)job->pass_level;
	bool refine = job->pass == PASS_REFINE;
	uint32_t m2 = (2u << level) - 1u;
	if (job->pass != PASS_REFINE && job->pass != PASS_FIRST) {
		return;
	}
	for (uint32_t y = y0; y < y0 + BC_RENDER_TILE && y < v->height; y++) {
		for (uint32_t x = x0; x < x0 + BC_RENDER_TILE && x < v->width;
		     x++) {
			size_t i = (size_t)y * v->width + x, from;
			if (!bc_render_level_has(x, y, level, refine)) {
				continue;
			}
			if (!refine) {
				bc_shade_miss(y, v->height, fr->rgba + 4u * i);
				if (fr->depth) {
					fr->depth[i] = INFINITY;
					fr->ids[i] = 0;
				}
				continue;
			}
			from = (size_t)(y & ~m2) * v->width + (x & ~m2);
			memcpy(fr->rgba + 4u * i, fr->rgba + 4u * from, 4);
			if (fr->depth) {
				fr->depth[i] = fr->depth[from];
				fr->ids[i] = fr->ids[from];
			}
		}
	}
}

/* Room for the view's tiles in the worker's masks, which are all zero
 * between slices. */
static bool masks_for(struct worker *wk, uint32_t ntiles)
{
	if (wk->mask_cap >= ntiles) {
		return true;
	}
	bc_free(wk->mask);
	bc_free(wk->shorts);
	wk->mask_cap = 0;
	wk->mask = bc_calloc(ntiles, 1);
	wk->shorts = bc_calloc(ntiles, 1);
	if (!wk->mask || !wk->shorts) {
		return false;
	}
	wk->mask_cap = ntiles;
	return true;
}

/* A slice's tiles: up to job->slice_tiles of the pass from the cursor,
 * marked in wk->mask and prefilled, in [first, first + count); end is the
 * tile after the last looked at. */
struct slice {
	uint32_t n, first, count, end;
};

static void gather(struct bc_job *job, struct worker *wk, struct slice *sl)
{
	struct view *v = job->v;
	uint32_t t = job->cursor;
	sl->n = sl->count = 0;
	sl->first = t;
	for (; t < v->ntiles && sl->n < job->slice_tiles; t++) {
		if (selected(job, t)) {
			if (sl->n++ == 0) {
				sl->first = t;
			}
			wk->mask[t] = 1;
			prefill(job, t);
			sl->count = t - sl->first + 1;
		}
	}
	sl->end = t;
}

/* What a render call did to the view's tiles: those drawn now hold the
 * pass's level, undamaged, short or not as the renderer says (a refinement
 * traced only the level's new pixels: rays that ran out before still
 * did); the view remembers the bound they ran out under, which retries
 * raise. The worker's masks are left all zero. */
static void account(struct bc_job *job, struct worker *wk,
                    const struct slice *sl, bool whole)
{
	struct view *v = job->v;
	bool refine = job->pass == PASS_REFINE && !whole, shorts = false;
	uint32_t t0 = whole ? 0 : sl->first;
	uint32_t t1 = whole ? v->ntiles : sl->first + sl->count;
	v->version++;
	for (uint32_t t = t0; t < t1; t++) {
		if (!whole && !wk->mask[t]) {
			continue;
		}
		v->tlevel[t] = job->pass_level;
		v->damage[t] = 0;
		v->shorts[t] =
		    (uint8_t)(wk->shorts[t] | (refine ? v->shorts[t] : 0u));
		v->changed[t] = v->version;
		shorts = shorts || wk->shorts[t];
	}
	memset(wk->mask + t0, 0, t1 - t0);
	memset(wk->shorts + t0, 0, t1 - t0);
	if (shorts) {
		v->bound = job->bound;
	}
}

/* Keeps the cost model: milliseconds per traced ray, of the A-buffer of a
 * new view, and the slice size that fits the slice's target. */
static void learn(const struct bc_work *w, struct flow *f, struct bc_job *job,
                  uint32_t ntiles, const struct bc_render_stats *st,
                  bool new_view)
{
	double per_tile;
	if (st->rays > 0) {
		double per_ray = st->ms_trace / (double)st->rays;
		f->ms_per_ray = f->ms_per_ray > 0.0
		                    ? 0.7 * f->ms_per_ray + 0.3 * per_ray
		                    : per_ray;
	}
	if (new_view) {
		f->ms_abuffer = f->ms_abuffer > 0.0
		                    ? 0.7 * f->ms_abuffer + 0.3 * st->ms_abuffer
		                    : st->ms_abuffer;
	}
	/* Most rays ran out: this scene crawls, and a picture of coarser
	 * values now beats a picture never finished. The retries raise the
	 * bound for the tiles that need it. */
	if (job->pass != PASS_RETRY && st->short_rays * 4u > st->rays) {
		f->ray_bound = f->ray_bound / 8u > BC_SRV_RAY_EVALS_MIN
		                   ? f->ray_bound / 8u
		                   : BC_SRV_RAY_EVALS_MIN;
		job->bound = f->ray_bound;
	} else if (st->short_rays == 0 && f->ray_bound < BC_SRV_RAY_EVALS) {
		f->ray_bound *= 2u;
	}
	/* The next slice scales to the target from what this one took (its
	 * lists included), growing at most twofold: tiles differ a lot (a
	 * background tile costs almost nothing, a crowded one a lot), and a
	 * slice that comes out long holds a worker others may be waiting
	 * for. */
	per_tile = ntiles ? st->ms_total / (double)ntiles : 0.0;
	if (per_tile > 0.0 && !bc_renderer_wants_large_regions(f->r)) {
		double k = slice_target(w, job) / per_tile;
		double most = 2.0 * (double)ntiles + 1.0;
		k = k > most ? most : k;
		job->slice_tiles = k < 1.0 ? 1u
		                   : k > (double)BC_SRV_SLICE_TILES_MAX
		                       ? BC_SRV_SLICE_TILES_MAX
		                       : (uint32_t)k;
	}
}

/* A snapshot's retries stop at the frame budget, also inside a pass: the
 * tiles not retried keep the values they have and their marks. */
static bool snapshot_out_of_budget(const struct bc_work *w,
                                   const struct bc_job *job)
{
	return job->req.kind == BC_JOB_SNAPSHOT && job->pass == PASS_RETRY &&
	       over_budget(w, job);
}

/* Renders the pass's next slice of tiles. Returns 0, or an error in ei;
 * job->pass becomes PASS_NONE when the pass is over. */
static int render_slice(struct bc_work *w, struct worker *wk, struct flow *f,
                        struct bc_job *job, struct bc_errinfo *ei)
{
	struct view *v = job->v;
	struct bc_render_stats st;
	struct bc_render_region rg = {0};
	struct slice sl;
	bool new_view = v->frame.key == 0;
	int rc;
	if (!masks_for(wk, v->ntiles)) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	gather(job, wk, &sl);
	if (sl.n > 0) {
		rg.tiles = wk->mask;
		rg.level = (uint32_t)job->pass_level;
		rg.refine = job->pass == PASS_REFINE;
		rg.max_evals = job->bound;
		rg.short_tiles = wk->shorts;
		rg.tile_first = sl.first;
		rg.tile_count = sl.count;
		rg.adopt_key = true;
		rg.threads = wk->team;
		f->render_calls++;
		rc = bc_renderer_render_region(f->r, &v->camera, &v->frame, &rg,
		                               &st, ei);
		if (rc) {
			memset(wk->mask + sl.first, 0, sl.count);
			memset(wk->shorts, 0, v->ntiles);
			return rc;
		}
		bc_log(BC_LOG_DEBUG,
		       "session %u view %u: pass %d level %d%s, %u tiles, "
		       "%llu rays, %.2f ms (lists %.2f ms), %llu evaluations, "
		       "%llu short",
		       f->sid, v->id, (int)job->pass, job->pass_level,
		       rg.refine ? " refined" : "", sl.n,
		       (unsigned long long)st.rays, st.ms_total, st.ms_abuffer,
		       (unsigned long long)st.field_evals,
		       (unsigned long long)st.short_rays);
		account(job, wk, &sl, st.whole);
		learn(w, f, job, sl.n, &st, new_view);
		job->render_ms += st.ms_total;
		bc__flow_kept(w, f);
		bc__views_settle(w);
		if (st.whole) {
			sl.end = v->ntiles;
		}
	}
	job->cursor = sl.end;
	if (sl.end >= v->ntiles || snapshot_out_of_budget(w, job)) {
		job->pass = PASS_NONE;
	}
	return 0;
}

/* ---- encoding and the frame ---------------------------------------------- */

/* A view's depth (f32, +inf on a miss) or id (u32, 0 on a miss) plane as
 * the wire carries it: 4 bytes a pixel, little-endian whatever the host's
 * order (PROTOCOL.md 7.17). NULL when out of memory. */
static uint8_t *plane_bytes(const struct view *v, bool depth)
{
	size_t n = (size_t)v->width * v->height;
	uint8_t *out = bc_malloc(n * 4u);
	if (!out) {
		return NULL;
	}
	for (size_t i = 0; i < n; i++) {
		uint32_t u;
		if (depth) {
			memcpy(&u, &v->frame.depth[i], sizeof(u));
		} else {
			u = v->frame.ids[i];
		}
		bc_put_le32(out + 4u * i, u);
	}
	return out;
}

static bool lossless_frame(const struct bc_job *job, int level)
{
	return job->req.kind == BC_JOB_SNAPSHOT ||
	       (job->req.final && level == 0);
}

/* The encoding of the job's frame at level: the still's, or the moving
 * frames'. */
static int frame_encoding(const struct bc_job *job, int level)
{
	return lossless_frame(job, level) ? job->req.encoding
	                                  : job->req.encoding_interactive;
}

/* Whether the job sends only the tiles changed since what its targets
 * hold: they hold this view at level 0, and the frame keeps its kind (a
 * still over a lossless base, or an interactive frame). */
static bool patches(const struct bc_job *job, int level)
{
	const struct bc_shown *s = &job->req.shown;
	/* An H.264 frame is always the whole view (PROTOCOL.md 7.15). */
	return job->req.kind != BC_JOB_SNAPSHOT && level == 0 &&
	       frame_encoding(job, level) != BC_PROTO_ENC_H264 &&
	       s->view == job->v->id && s->level == 0 &&
	       (!lossless_frame(job, level) || s->lossless);
}

/* Sets up the encoding of the frame's rectangles. */
static int encode_begin(struct worker *wk, struct bc_job *job,
                        struct bc_errinfo *ei)
{
	const struct view *v = job->v;
	int level = bc__view_level(v);
	bool lossless = lossless_frame(job, level);
	struct bc_proto_rect whole, *rects = &whole;
	uint32_t n = 1, iw, ih;
	const uint8_t *pix;
	int rc;
	if (level < 0) {
		/* A pass that fills every tile always ends before encoding. */
		return bc_errinfo_set(ei, BC_ESTATE, "the view has no picture");
	}
	if (!(pix = bc__picture(wk, v, level, &iw, &ih))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "no memory for a picture");
	}
	whole =
	    (struct bc_proto_rect){0, 0, (uint16_t)iw, (uint16_t)ih, {NULL, 0}};
	if (patches(job, level)) {
		bool none;
		uint32_t k =
		    bc__changed_rects(wk, v, job->req.shown.version, &none);
		if (k > 0) {
			rects = wk->rects;
			n = k;
		} else if (none) {
			/* Nothing visible changed: the smallest frame still
			 * tells the order reached. */
			whole.w = (uint16_t)(iw < 16 ? iw : 16);
			whole.h = (uint16_t)(ih < 16 ? ih : 16);
		}
	}
	rc = bc_encode_job_new(&job->enc, pix, iw, ih, level > 0, rects, n,
	                       frame_encoding(job, level),
	                       lossless ? job->req.quality_still
	                                : job->req.quality_interactive);
	if (rc) {
		return bc_errinfo_set(ei, rc, "cannot encode the frame");
	}
	return 0;
}

/* The snapshot's planes after its colour, as PROTOCOL.md 7.17 orders
 * them: depth first, then ids. Returns the count or an error. */
static int snapshot_planes(const struct bc_job *job, struct bc_proto_rect *out,
                           uint8_t **bufs, uint16_t *flags)
{
	static const struct {
		uint8_t plane;
		uint16_t flag;
	} kinds[2] = {{BC_PROTO_PLANE_DEPTH, BC_PROTO_FLAG_DEPTH},
	              {BC_PROTO_PLANE_IDS, BC_PROTO_FLAG_IDS}};
	const struct view *v = job->v;
	int n = 0;
	for (int k = 0; k < 2; k++) {
		if (!(job->req.snapshot_planes & kinds[k].plane)) {
			continue;
		}
		if (!(bufs[n] = plane_bytes(v, k == 0))) {
			return BC_ENOMEM;
		}
		out[n] = (struct bc_proto_rect){
		    0,
		    0,
		    (uint16_t)v->width,
		    (uint16_t)v->height,
		    {bufs[n], (uint32_t)v->width * v->height * 4u}};
		*flags |= kinds[k].flag;
		n++;
	}
	return n;
}

/* The FRAME's flags besides the level and planes. */
static uint16_t frame_flags(const struct bc_job *job, int level)
{
	uint16_t flags = bc_proto_flags_with_level(0, (unsigned)level);
	if (job->req.kind == BC_JOB_SNAPSHOT) {
		flags |= BC_PROTO_FLAG_SNAPSHOT | BC_PROTO_FLAG_STILL;
	} else if (lossless_frame(job, level)) {
		flags |= BC_PROTO_FLAG_STILL;
	}
	if (job->incomplete) {
		flags |= BC_PROTO_FLAG_INCOMPLETE;
	}
	return flags;
}

/* Encodes the FRAME message into a shared buffer, *out. */
static int frame_bytes(struct bc_job *job, const struct bc_msg *m,
                       struct bc_shared **out, struct bc_errinfo *ei)
{
	struct bc_proto_buf b;
	int rc;
	/* Up to the protocol's limit: each target's own max_frame_bytes is
	 * checked when it is delivered (ELIMIT, PROTOCOL.md 7.15). */
	bc_proto_buf_init(&b,
	                  (size_t)BC_PROTO_MAX_PAYLOAD + BC_PROTO_HEADER_SIZE);
	rc = bc_proto_encode(&b, m, ei);
	if (rc == BC_ELIMIT || rc == BC_EPROTO_LENGTH) {
		job->done.outcome = BC_WORK_TOO_BIG;
		rc = 0;
	} else if (rc == 0 && !(*out = bc_shared_new(b.len))) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "no memory for a frame");
	} else if (rc == 0) {
		memcpy((*out)->data, b.data, b.len);
	}
	bc_proto_buf_finish(&b);
	return rc;
}

/* The FRAME's fields but its rectangles, at the view's level. */
static void frame_msg(const struct flow *f, const struct bc_job *job, int level,
                      struct bc_msg *m)
{
	const struct view *v = job->v;
	uint32_t iw =
	    level ? (v->width + (1u << level) - 1) >> level : v->width;
	uint32_t ih =
	    level ? (v->height + (1u << level) - 1) >> level : v->height;
	if (frame_encoding(job, level) == BC_PROTO_ENC_H264) {
		/* The view's size at every level (PROTOCOL.md 7.15). */
		iw = v->width;
		ih = v->height;
	}
	*m = (struct bc_msg){.type = BC_MSG_FRAME, .seq = job->req.seq};
	m->flags = frame_flags(job, level);
	m->frame.frame_no = job->req.frame_no;
	m->frame.order = f->order;
	if (f->order >= job->req.scene_order && job->req.order > f->order) {
		m->frame.order = job->req.order;
	}
	m->frame.camera_seq = job->req.camera_seq;
	m->frame.encoding = (enum bc_proto_encoding)frame_encoding(job, level);
	m->frame.width = (uint16_t)job->req.width;
	m->frame.height = (uint16_t)job->req.height;
	m->frame.image_width = (uint16_t)iw;
	m->frame.image_height = (uint16_t)ih;
}

/* What the targets hold after the job's frame m. */
static void frame_done(struct bc_job *job, int level, const struct bc_msg *m)
{
	const struct view *v = job->v;
	job->done.order = m->frame.order;
	job->done.incomplete = job->incomplete;
	job->done.shown = (struct bc_shown){
	    .view = v->id,
	    .version = v->version,
	    .level = (int8_t)level,
	    .lossless = lossless_frame(job, level) &&
	                (patches(job, level) ? job->req.shown.lossless : true),
	    .refining = (level > 0 || job->incomplete) && !job->stuck,
	    .still = (m->flags & BC_PROTO_FLAG_STILL) != 0,
	};
}

/* Builds the FRAME from the encoded rectangles (and a snapshot's planes)
 * and what the targets hold after it. */
static int finish(const struct flow *f, struct bc_job *job,
                  struct bc_errinfo *ei)
{
	int level = bc__view_level(job->v);
	struct bc_msg m;
	struct bc_proto_rect all[3], *rects;
	uint8_t *planes[2] = {NULL, NULL};
	uint32_t n;
	int rc = 0, np = 0;
	rects = bc_encode_job_rects(job->enc, &n);
	frame_msg(f, job, level, &m);
	if (job->req.kind == BC_JOB_SNAPSHOT) {
		all[0] = rects[0];
		if ((np = snapshot_planes(job, all + 1, planes, &m.flags)) <
		    0) {
			rc = bc_errinfo_set(ei, np, "no memory for the planes");
			goto out;
		}
		rects = all;
		n = 1u + (uint32_t)np;
	}
	m.frame.nrects = (uint16_t)n;
	m.frame.rects = rects;
	if ((rc = frame_bytes(job, &m, &job->done.frame, ei)) == 0) {
		frame_done(job, level, &m);
	}
out:
	bc_free(planes[0]);
	bc_free(planes[1]);
	return rc;
}

/* H.264 (PROTOCOL.md 7.15): the picture encoded into the next target's
 * own stream, its FRAME built (one target a step, so that a large group
 * gives the worker back between them). A target whose encoder fails gets
 * no frame (done.vfailed). Returns true when the job is over. */
static bool video_step(const struct flow *f, struct bc_job *job,
                       struct bc_errinfo *ei, int *rc)
{
	const struct view *v = job->v;
	int level = bc__view_level(v);
	bool still = lossless_frame(job, level);
	while (job->vnext < job->req.ntargets) {
		uint32_t i = job->vnext++;
		struct bc_vstream_au au;
		struct bc_proto_rect r = {
		    0, 0, (uint16_t)v->width, (uint16_t)v->height, {NULL, 0}};
		struct bc_msg m;
		double t0 = bc_clock_ms();
		*rc = bc_vstream_encode(job->req.video[i], v->frame.rgba,
		                        v->width, v->height, level, still, &au,
		                        ei);
		job->encode_ms += bc_clock_ms() - t0;
		if (*rc == BC_ENOMEM) {
			return true;
		}
		if (*rc) {
			job->done.vfailed |= (uint64_t)1 << i;
			snprintf(job->done.why, sizeof(job->done.why), "%s",
			         ei->msg);
			continue;
		}
		frame_msg(f, job, level, &m);
		m.flags |= au.key ? BC_PROTO_FLAG_KEY : 0u;
		r.data = (struct bc_proto_bytes){au.data, (uint32_t)au.len};
		m.frame.nrects = 1;
		m.frame.rects = &r;
		*rc = frame_bytes(job, &m, &job->done.vframes[i], ei);
		bc_free(au.data);
		if (*rc) {
			return true;
		}
		frame_done(job, level, &m);
		return job->vnext == job->req.ntargets;
	}
	/* Past the last target. When every target's encoder failed there is
	 * nothing to send: the job fails (frames.c moves them to images). */
	*rc = BC_ECODEC;
	for (uint32_t i = 0; i < job->req.ntargets; i++) {
		*rc = job->done.vframes[i] ? 0 : *rc;
	}
	if (*rc) {
		bc_errinfo_set(ei, *rc, "%s", job->done.why);
	}
	return true;
}

/* ---- the slice ----------------------------------------------------------- */

/* Syncs f's renderer with its copy (creating it) and takes the job's view.
 * Returns 0 or an error. */
static int start(struct bc_work *w, struct flow *f, struct bc_job *job,
                 struct bc_errinfo *ei)
{
	struct bc_dirty dirty;
	int rc;
	if (!f->tree || f->broken || !bc_tree_lin(f->tree)) {
		return bc_errinfo_set(ei, BC_ESTATE, "no scene to render");
	}
	if (!f->r &&
	    (rc = bc_renderer_create(&f->r, w->opts.backend, &w->ropts, ei))) {
		return rc;
	}
	bc_tree_take_dirty(f->tree, &dirty);
	if (f->fresh || dirty.edits) {
		rc = bc_renderer_sync(f->r, f->tree, f->fresh ? NULL : &dirty,
		                      ei);
		f->fresh = false;
		if (rc) {
			return rc;
		}
	}
	/* The renderer keeps state for one view: for another size it would
	 * be rebuilt anyway, so it goes first and the cap has room for it.
	 * Another camera at the same size keeps its buffers, which the new
	 * view's lists fill again (the renderer sees the camera change):
	 * freed and asked for again, their pages were faulted in anew at
	 * every step of an orbit, a sixth of a million spheres' frame. */
	if (f->r && (f->rw != job->req.width || f->rh != job->req.height ||
	             memcmp(&f->rwin, &job->req.win, sizeof(f->rwin)))) {
		bc_renderer_release(f->r);
		bc__flow_kept(w, f);
	}
	f->rwin = job->req.win;
	f->rw = job->req.width;
	f->rh = job->req.height;
	job->v = bc__view_acquire(w, f->sid, &job->req.win, &job->req.camera,
	                          job->req.width, job->req.height);
	if (!job->v ||
	    (job->req.snapshot_planes && bc__view_planes(w, job->v))) {
		return bc_errinfo_set(
		    ei, BC_ENOMEM,
		    "no room for a %ux%u view%s under the view "
		    "cache's cap (--view-cache)",
		    job->req.width, job->req.height,
		    job->req.snapshot_planes ? " with planes" : "");
	}
	forget_large_damage(w, job);
	plan(w, f, job, true);
	job->stage = job->pass == PASS_NONE ? JS_ENCODE : JS_RENDER;
	return 0;
}

/* After a pass: another (a snapshot down to level 0, damage at another
 * level), or the encoding. A refinement past the frame budget sends what
 * it has. */
static void after_pass(struct bc_work *w, const struct flow *f,
                       struct bc_job *job)
{
	if (job->pass == PASS_NONE) {
		plan(w, f, job, false);
	}
	if (job->req.kind == BC_JOB_FRAME &&
	    (job->pass == PASS_REFINE || job->pass == PASS_RETRY) &&
	    over_budget(w, job)) {
		job->incomplete = true;
		job->pass = PASS_NONE;
	}
	if (job->pass == PASS_NONE) {
		const struct view *v = job->v;
		bool shorts = level_of_marked(v, v->shorts) >= 0;
		job->incomplete = job->incomplete || shorts;
		job->stuck = shorts && v->bound >= BC_SRV_RAY_EVALS_MAX;
		job->stage = JS_ENCODE;
	}
}

/* One step of the job. Returns true when it is over. */
static bool step(struct bc_work *w, struct worker *wk, struct flow *f,
                 struct bc_job *job, struct bc_errinfo *ei, int *rc)
{
	switch (job->stage) {
	case JS_START:
		if (job->req.kind == BC_JOB_PICK) {
			pick(f, job);
			return true;
		}
		*rc = start(w, f, job, ei);
		return *rc != 0;
	case JS_RENDER:
		if (!(*rc = render_slice(w, wk, f, job, ei))) {
			after_pass(w, f, job);
		}
		return *rc != 0;
	case JS_ENCODE:
		if (job->req.video[0] &&
		    frame_encoding(job, bc__view_level(job->v)) ==
		        BC_PROTO_ENC_H264) {
			return video_step(f, job, ei, rc);
		}
		if (!job->enc && (*rc = encode_begin(wk, job, ei))) {
			return true;
		}
		*rc = bc_encode_job_run(job->enc, wk->enc, BC_SRV_SLICE_MS);
		if (*rc < 0) {
			bc_errinfo_set(ei, *rc, "encoding failed");
			return true;
		}
		job->stage = *rc == 1 ? JS_FINISH : JS_ENCODE;
		*rc = 0;
		return false;
	case JS_FINISH:
		job->encode_ms += bc_encode_job_ms(job->enc);
		*rc = finish(f, job, ei);
		return true;
	default:
		return true;
	}
}

bool bc__job_slice(struct bc_work *w, struct worker *wk, struct flow *f,
                   struct bc_job *job)
{
	struct bc_errinfo ei = {0};
	double t0 = bc_clock_ms();
	int rc = 0;
	bool over = false;
	uint64_t rendered = f->render_calls;
	if (job->stage == JS_START) {
		job->started_ms = t0;
	}
	/* Steps while the slice has time: a small job ends in one. */
	while (!over && bc_clock_ms() - t0 < BC_SRV_SLICE_MS) {
		over = step(w, wk, f, job, &ei, &rc);
	}
	if (f->render_calls == rendered) {
		wk->team = 1; /* encoding: one thread */
	}
	if (!over) {
		return false;
	}
	job->done.render_ms = job->render_ms;
	job->done.encode_ms = job->encode_ms;
	bc_log(BC_LOG_DEBUG,
	       "session %u job %u (kind %d): waited %.1f ms, took %.1f ms, "
	       "render %.1f ms, encode %.1f ms",
	       f->sid, job->req.frame_no, (int)job->req.kind,
	       job->started_ms - job->submitted_ms,
	       bc_clock_ms() - job->started_ms, job->render_ms, job->encode_ms);
	if (rc) {
		bc_log(BC_LOG_ERROR, "session %u: frame %u failed: %s", f->sid,
		       job->req.frame_no, ei.msg);
		job->done.code = rc;
		snprintf(job->done.why, sizeof(job->done.why), "%s", ei.msg);
		bc__job_end(w, job,
		            rc == BC_ENOMEM ? BC_WORK_OOM : BC_WORK_FAILED);
	} else {
		enum bc_work_outcome o = job->done.outcome;
		bc__job_end(w, job, o == BC_WORK_TOO_BIG ? o : BC_WORK_DONE);
	}
	return true;
}
