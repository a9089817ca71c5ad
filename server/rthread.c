/*
 * The render thread. It owns the renderer (and so the GL context, when the
 * backend is gl) and a replica of every session's scene: the loop thread
 * sends it the same parameter edits it applied (so the replica re-processes
 * nothing either) or a copy after a structural edit. Commands run in the
 * order they were sent, so a frame reflects exactly the edits sent before
 * it. Finished frames are encoded here and handed back through a queue and
 * a uv_async.
 *
 * Views. For every view it renders (session, camera, size) the thread keeps
 * the last frame's colour, depth and id planes at full size, the finest
 * refinement level they hold, and a version per 8x8 tile (when it last
 * changed). A parameter edit marks the tiles the renderer says it can reach
 * (bc_renderer_damage over the edited primitives' ABVs before and after)
 * and the next frame re-renders only those; a camera move or a large
 * damage starts a new view at a coarse level (one ray per 2^n x 2^n block,
 * chosen to fit BC_SRV_COARSE_MS) and each following job refines it one
 * level, tracing only pixels it does not have, until level 0. A client is
 * sent the tiles that changed since the version it holds, or the whole
 * picture at the view's level.
 */
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "encode.h"
#include "server.h"

enum rcmd_kind {
	RCMD_INVALID = 0,
	RCMD_SCENE,
	RCMD_SET_PRIM,
	RCMD_SET_OP,
	RCMD_DROP,
	RCMD_JOB,
	RCMD_COUNT
};

struct rcmd {
	enum rcmd_kind kind;
	uint32_t session_id;
	struct bc_tree *tree;
	uint32_t id;
	struct bc_prim_data p;
	struct bc_op_data op;
	struct bc_rjob *job;
	struct rresult *res; /* RCMD_JOB: allocated with the command */
	struct rcmd *next;
};

struct rresult {
	struct bc_rjob *job;
	struct bc_shared *frame;
	bool yielded; /* no frame: a refinement gave way to newer work */
	bool hit;
	float position[3], depth;
	uint32_t node;
	double render_ms, encode_ms;
	bool incomplete;
	bool too_big; /* no frame: it is over the protocol's payload limit */
	bool oom;     /* no frame: out of memory, the targets stay owed */
	struct bc_shown shown; /* what the targets hold after this frame */
	struct rresult *next;
};

struct replica {
	uint32_t session_id;
	struct bc_tree *tree;
	struct bc_renderer *r;
	bool fresh; /* the renderer has not seen this tree yet */
	/* Cost model of this scene's frames, for the coarse level: running
	 * averages of milliseconds per traced ray and per A-buffer. */
	double ms_per_ray, ms_abuffer;
};

/* One view's planes (see the file comment). */
struct view {
	uint32_t id; /* unique over the thread's life, 0: slot free */
	uint32_t session_id;
	struct bc_camera camera;
	uint32_t width, height, ntiles;
	struct bc_frame frame;
	int level;        /* finest level complete in frame, -1: none */
	bool stuck;       /* a refinement hit the time budget: wait */
	uint32_t version; /* bumped whenever frame changes */
	uint32_t *changed; /* per tile: version of its last change */
	uint8_t *damage;   /* per tile: an edit may have changed it */
	bool damaged;
	uint64_t used; /* for eviction, least recently used first */
};

struct bc_rthread {
	struct bc_srv *srv;
	uv_thread_t thread;
	uv_mutex_t lock;
	uv_cond_t cond;
	struct rcmd *head, *tail;
	struct rresult *rhead, *rtail;
	bool quit;
	enum bc_backend backend;
	struct bc_render_opts opts;
	struct bc_encoder *enc;
	struct replica replicas[BC_SRV_MAX_SESSIONS];
	struct view views[BC_SRV_MAX_VIEWS];
	uint32_t next_view_id;
	uint64_t clock;
	bool damage_off; /* every edit re-renders the whole view */
	uint8_t *small;  /* a coarse level's picture, RGBA */
	size_t small_cap;
	struct bc_proto_rect *rects;
	uint8_t *seen, *band;
	size_t seen_cap, band_cap;
	uint32_t budget_ms; /* of one refinement step */
};

static struct replica *replica_of(struct bc_rthread *rt, uint32_t id,
				  bool create)
{
	struct replica *free_slot = NULL;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (rt->replicas[i].session_id == id) {
			return &rt->replicas[i];
		}
		if (!free_slot && rt->replicas[i].session_id == 0) {
			free_slot = &rt->replicas[i];
		}
	}
	if (create && free_slot) {
		free_slot->session_id = id;
		return free_slot;
	}
	return NULL;
}

static void view_free(struct view *v)
{
	bc_frame_finish(&v->frame);
	bc_free(v->changed);
	bc_free(v->damage);
	memset(v, 0, sizeof(*v));
}

/* Forgets every view of a session (its structure changed, or it ends). */
static void views_drop(struct bc_rthread *rt, uint32_t session_id)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		if (rt->views[i].id && rt->views[i].session_id == session_id) {
			view_free(&rt->views[i]);
		}
	}
}

static void replica_drop(struct bc_rthread *rt, struct replica *rp)
{
	views_drop(rt, rp->session_id);
	bc_renderer_destroy(rp->r);
	bc_tree_destroy(rp->tree);
	memset(rp, 0, sizeof(*rp));
}

/* The view of a job, kept or new (the least recently used one, or one
 * over the memory cap, makes room). NULL when out of memory. */
static struct view *view_of(struct bc_rthread *rt, const struct bc_rjob *job)
{
	struct view *v = NULL, *oldest = NULL;
	size_t bytes = 0, need = (size_t)job->width * job->height * 12u;
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *w = &rt->views[i];
		if (!w->id) {
			v = v ? v : w;
			continue;
		}
		if (w->session_id == job->session_id && w->width == job->width &&
		    w->height == job->height &&
		    memcmp(&w->camera, &job->camera, sizeof(w->camera)) == 0) {
			w->used = ++rt->clock;
			return w;
		}
		bytes += (size_t)w->width * w->height * 12u;
		if (!oldest || w->used < oldest->used) {
			oldest = w;
		}
	}
	if (oldest && (!v || bytes + need > BC_SRV_VIEW_BYTES)) {
		view_free(oldest);
		v = v ? v : oldest;
	}
	if (!v) {
		return NULL;
	}
	v->ntiles = bc_render_tiles_x(job->width) *
		    bc_render_tiles_y(job->height);
	if (bc_frame_init(&v->frame, job->width, job->height) ||
	    !(v->changed = bc_calloc(v->ntiles, sizeof(*v->changed))) ||
	    !(v->damage = bc_calloc(v->ntiles, 1))) {
		view_free(v);
		return NULL;
	}
	if (++rt->next_view_id == 0) {
		rt->next_view_id = 1;
	}
	v->id = rt->next_view_id;
	v->session_id = job->session_id;
	v->camera = job->camera;
	v->width = job->width;
	v->height = job->height;
	v->level = -1;
	v->used = ++rt->clock;
	return v;
}

/* A parameter edit of node id is about to be applied to rp's tree:
 * remembers the ABVs it can change; after it, marks in every view of the
 * session the tiles those ABVs reach before and after. */
struct edit_abvs {
	uint32_t k0, n;
	struct bc_abv *old;
};

static void edit_begin(const struct replica *rp, uint32_t id,
		       struct edit_abvs *e)
{
	const struct bc_lin *l = bc_tree_lin(rp->tree);
	uint32_t s = bc_tree_slot(rp->tree, id);
	memset(e, 0, sizeof(*e));
	if (!l || s == BC_NONE) {
		return;
	}
	/* A node's subtree holds the primitives k0 .. k0 + n - 1 (an
	 * operator's edit changes their ROIs, so their ABVs). */
	e->k0 = l->prim_of[l->first[s]];
	e->n = (s - l->first[s]) / 2 + 1;
	if (e->n <= BC_SRV_DAMAGE_PRIMS) {
		e->old = bc_calloc(e->n, sizeof(*e->old));
		if (e->old) {
			memcpy(e->old, l->abv + e->k0, e->n * sizeof(*e->old));
		}
	}
}

static void edit_end(struct bc_rthread *rt, const struct replica *rp,
		     struct edit_abvs *e)
{
	const struct bc_lin *l = bc_tree_lin(rp->tree);
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *v = &rt->views[i];
		if (!v->id || v->session_id != rp->session_id || v->level < 0) {
			continue;
		}
		v->damaged = true;
		if (!e->old || !rp->r || !l || rt->damage_off) {
			/* Too many to project, or no renderer yet. */
			memset(v->damage, 1, v->ntiles);
			continue;
		}
		for (uint32_t k = 0; k < e->n; k++) {
			bc_renderer_damage(rp->r, &v->camera, v->width,
					   v->height, &e->old[k], v->damage);
			bc_renderer_damage(rp->r, &v->camera, v->width,
					   v->height, &l->abv[e->k0 + k],
					   v->damage);
		}
	}
	bc_free(e->old);
	e->old = NULL;
}

static void push_result(struct bc_rthread *rt, struct rresult *res)
{
	uv_mutex_lock(&rt->lock);
	if (rt->rtail) {
		rt->rtail->next = res;
	} else {
		rt->rhead = res;
	}
	rt->rtail = res;
	uv_mutex_unlock(&rt->lock);
	uv_async_send(&rt->srv->results);
}

/* One ray of the job's camera through pixel (x, y), sphere traced on the
 * full tree (a pick is one ray: no tiles to share). */
static void pick(struct replica *rp, struct bc_rjob *job, struct rresult *res)
{
	const struct bc_lin *l = rp->tree ? bc_tree_lin(rp->tree) : NULL;
	struct bc_view_rays vr;
	float d[3], t0 = 0.0f, t1 = INFINITY, eps;
	if (!l) {
		return;
	}
	bc_view_rays_init(&vr, &job->camera, job->width, job->height);
	bc_view_rays_dir(&vr, (float)job->pick_x + 0.5f,
			 (float)job->pick_y + 0.5f, d);
	for (int i = 0; i < 3; i++) {
		float inv = 1.0f / d[i];
		float a = (l->lo[i] - vr.eye[i]) * inv;
		float b = (l->hi[i] - vr.eye[i]) * inv;
		if (d[i] == 0.0f) {
			if (vr.eye[i] < l->lo[i] || vr.eye[i] > l->hi[i]) {
				return;
			}
			continue;
		}
		t0 = fmaxf(t0, fminf(a, b));
		t1 = fminf(t1, fmaxf(a, b));
	}
	eps = 1e-4f * l->size;
	for (int step = 0; step < 100000 && t0 <= t1; step++) {
		float p[3] = {vr.eye[0] + t0 * d[0], vr.eye[1] + t0 * d[1],
			      vr.eye[2] + t0 * d[2]};
		uint32_t k;
		float f = bc_eval_full_id(l, p, &k);
		if (f < eps) {
			res->hit = k != BC_NONE;
			res->node = res->hit ? l->node_id[l->prim_slot[k]] : 0;
			memcpy(res->position, p, sizeof(p));
			res->depth = t0;
			return;
		}
		/* The compact operators compress the field: 1.45 bounds its
		 * Lipschitz constant (Zanni 2024, §7). */
		t0 += fmaxf(f / 1.45f, eps);
	}
}

static double now_ms(void)
{
	return (double)uv_hrtime() / 1e6;
}

/* The level a new view starts at: the finest whose estimated cost fits
 * BC_SRV_COARSE_MS, never coarser than the client accepts. */
static int start_level(const struct replica *rp, const struct bc_rjob *job)
{
	int max = (int)job->max_level;
	if (rp->ms_per_ray <= 0.0) {
		return max; /* no estimate yet: the cheapest picture */
	}
	for (int l = 0; l < max; l++) {
		double rays = (double)((job->width + (1u << l) - 1) >> l) *
			      (double)((job->height + (1u << l) - 1) >> l);
		if (rp->ms_abuffer + rays * rp->ms_per_ray <= BC_SRV_COARSE_MS) {
			return l;
		}
	}
	return max;
}

/* Renders region into v and keeps the cost model and tile versions. */
static int render_into(struct bc_rthread *rt, struct replica *rp,
		       struct view *v, const struct bc_render_region *rg,
		       bool *incomplete, struct bc_errinfo *ei)
{
	struct bc_render_stats st;
	int rc = bc_renderer_render_region(rp->r, &v->camera, &v->frame, rg,
					   &st, ei);
	(void)rt;
	if (rc) {
		return rc;
	}
	bc_log(BC_LOG_DEBUG,
	       "view %u: level %u%s, %u tiles, %llu rays, %.1f ms (lists "
	       "%.1f ms), %llu field evaluations",
	       v->id, rg->level, rg->refine ? " refined" : "", st.tiles,
	       (unsigned long long)st.rays, st.ms_total, st.ms_abuffer,
	       (unsigned long long)st.field_evals);
	if (st.rays > 0) {
		double per_ray = st.ms_trace / (double)st.rays;
		rp->ms_per_ray = rp->ms_per_ray > 0.0
					 ? 0.7 * rp->ms_per_ray + 0.3 * per_ray
					 : per_ray;
	}
	if (!rg->tiles && !rg->refine) {
		/* The lists of a whole new view: what a coarse start costs
		 * before its first ray. */
		rp->ms_abuffer = rp->ms_abuffer > 0.0
					 ? 0.7 * rp->ms_abuffer +
						   0.3 * st.ms_abuffer
					 : st.ms_abuffer;
	}
	v->version++;
	for (uint32_t t = 0; t < v->ntiles; t++) {
		if (st.whole || !rg->tiles || rg->tiles[t]) {
			v->changed[t] = v->version;
		}
	}
	*incomplete = *incomplete || st.incomplete;
	return 0;
}

/* Whether an edit of session sid waits in the queue: a refinement then
 * yields to it (its tiles would be traced again). Other jobs are not
 * waited for: two members refining different views would yield to each
 * other forever. */
static bool newer_work(struct bc_rthread *rt, uint32_t sid)
{
	bool found = false;
	uv_mutex_lock(&rt->lock);
	for (const struct rcmd *c = rt->head; c && !found; c = c->next) {
		found = c->session_id == sid && c->kind != RCMD_JOB;
	}
	uv_mutex_unlock(&rt->lock);
	return found;
}

/* Traces the pixels of the level below v's, in bands of tile rows, and
 * stops between bands when the frame budget is spent (never for a
 * snapshot), or, with *yielded set, before any band while newer work for
 * the session waits (the refinement is then owed, not failed). *done
 * tells whether the level is complete. The renderer itself has no budget
 * here: a picture is always whole at some level. */
static int refine(struct bc_rthread *rt, struct replica *rp, struct view *v,
		  bool unbounded, bool *done, bool *yielded,
		  struct bc_errinfo *ei)
{
	uint32_t cols = bc_render_tiles_x(v->width);
	uint32_t rows = bc_render_tiles_y(v->height);
	uint32_t band = (rows + BC_SRV_REFINE_BANDS - 1) / BC_SRV_REFINE_BANDS;
	double start = now_ms();
	bool ignored = false;
	int rc;
	*done = false;
	if (rt->band_cap < v->ntiles) {
		bc_free(rt->band);
		rt->band_cap = 0;
		if (!(rt->band = bc_malloc(v->ntiles))) {
			return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		}
		rt->band_cap = v->ntiles;
	}
	for (uint32_t y0 = 0; y0 < rows; y0 += band) {
		struct bc_render_region rg = {rt->band, (uint32_t)v->level - 1u,
					      true};
		uint32_t y1 = y0 + band < rows ? y0 + band : rows;
		if (!unbounded && newer_work(rt, v->session_id)) {
			*yielded = true;
			return 0;
		}
		if (y0 > 0 && !unbounded &&
		    now_ms() - start > (double)rt->budget_ms) {
			return 0;
		}
		memset(rt->band, 0, v->ntiles);
		memset(rt->band + (size_t)y0 * cols, 1, (size_t)(y1 - y0) * cols);
		if ((rc = render_into(rt, rp, v, &rg, &ignored, ei))) {
			return rc;
		}
	}
	*done = true;
	return 0;
}

/* Brings v up to date for job: whole at a coarse level when it holds
 * nothing or the damage is large, the damaged tiles at its level, or one
 * level finer (all the way to 0 for a snapshot or when asked). */
static int update_view(struct bc_rthread *rt, struct replica *rp,
		       struct view *v, const struct bc_rjob *job,
		       bool *incomplete, bool *yielded, struct bc_errinfo *ei)
{
	uint32_t ndamaged = 0;
	int rc;
	if (v->damaged) {
		for (uint32_t t = 0; t < v->ntiles; t++) {
			ndamaged += v->damage[t] ? 1u : 0u;
		}
	}
	/* With damage off (to compare) every edit redraws the whole view at
	 * its level, as a renderer without damage would. */
	if (v->level >= 0 && v->damaged && !rt->damage_off &&
	    (uint64_t)ndamaged * 100u > (uint64_t)v->ntiles * BC_SRV_DAMAGE_PCT &&
	    !job->snapshot_seq) {
		v->level = -1; /* large: a fresh progressive picture */
	}
	if (v->level < 0) {
		struct bc_render_region all = {NULL, 0, false};
		all.level = job->snapshot_seq ? 0u : (uint32_t)start_level(rp, job);
		if ((rc = render_into(rt, rp, v, &all, incomplete, ei))) {
			return rc;
		}
		v->level = (int)all.level;
		v->stuck = false;
	} else if (v->damaged && ndamaged > 0) {
		struct bc_render_region dmg = {v->damage, (uint32_t)v->level,
					       false};
		if ((rc = render_into(rt, rp, v, &dmg, incomplete, ei))) {
			return rc;
		}
		v->stuck = false;
	} else if (v->level > 0 && !v->stuck) {
		/* One level finer; a snapshot waits for all. */
		do {
			bool done = false;
			if ((rc = refine(rt, rp, v, job->snapshot_seq != 0,
					 &done, yielded, ei))) {
				return rc;
			}
			if (*yielded) {
				break;
			}
			if (!done) {
				/* The budget ran out: the picture stays
				 * complete at its level until something
				 * changes. */
				v->stuck = true;
				*incomplete = true;
				break;
			}
			v->level--;
		} while (v->level > 0 && job->snapshot_seq);
	}
	v->damaged = false;
	memset(v->damage, 0, v->ntiles);
	return 0;
}

/* Merges the tiles changed after version `since` into rectangles (runs
 * along each tile row, then runs of equal spans down the rows). Returns
 * the count; 0 when there are more than BC_PROTO_MAX_RECTS (the whole
 * picture is then cheaper) or none changed (*none set). */
static uint32_t changed_rects(struct bc_rthread *rt, const struct view *v,
			      uint32_t since, bool *none)
{
	uint32_t n = 0, T = BC_RENDER_TILE;
	uint32_t cols = bc_render_tiles_x(v->width);
	uint32_t rows = bc_render_tiles_y(v->height);
	*none = true;
	if (rt->seen_cap < v->ntiles) {
		bc_free(rt->seen);
		rt->seen_cap = 0;
		if (!(rt->seen = bc_malloc(v->ntiles))) {
			return 0;
		}
		rt->seen_cap = v->ntiles;
	}
	memset(rt->seen, 0, v->ntiles);
	for (uint32_t ty = 0; ty < rows; ty++) {
		for (uint32_t tx = 0; tx < cols; tx++) {
			uint32_t w = 0, h = 1;
			bool same = true;
#define CHANGED(x, y)                                                          \
	(v->changed[(size_t)(y) * cols + (x)] > since &&                       \
	 !rt->seen[(size_t)(y) * cols + (x)])
			if (!CHANGED(tx, ty)) {
				continue;
			}
			*none = false;
			while (tx + w < cols && CHANGED(tx + w, ty)) {
				w++;
			}
			while (same && ty + h < rows) {
				for (uint32_t i = 0; i < w; i++) {
					if (!CHANGED(tx + i, ty + h)) {
						same = false;
						break;
					}
				}
				h += same ? 1 : 0;
			}
#undef CHANGED
			for (uint32_t j = 0; j < h; j++) {
				memset(rt->seen + (size_t)(ty + j) * cols + tx,
				       1, w);
			}
			if (n == BC_PROTO_MAX_RECTS) {
				return 0;
			}
			rt->rects[n] = (struct bc_proto_rect){
				(uint16_t)(tx * T), (uint16_t)(ty * T),
				(uint16_t)((tx + w) * T > v->width
						   ? v->width - tx * T
						   : w * T),
				(uint16_t)((ty + h) * T > v->height
						   ? v->height - ty * T
						   : h * T),
				{NULL, 0}};
			n++;
		}
	}
	return n;
}

/* The picture of v at its level: every 2^level-th pixel of each row and
 * column (level 0: the planes themselves). Returns NULL when out of
 * memory. */
static const uint8_t *picture(struct bc_rthread *rt, const struct view *v,
			      uint32_t *w, uint32_t *h)
{
	uint32_t l = (uint32_t)v->level;
	size_t need;
	*w = (v->width + (1u << l) - 1) >> l;
	*h = (v->height + (1u << l) - 1) >> l;
	if (l == 0) {
		return v->frame.rgba;
	}
	need = (size_t)*w * *h * 4u;
	if (rt->small_cap < need) {
		bc_free(rt->small);
		rt->small_cap = 0;
		if (!(rt->small = bc_malloc(need))) {
			return NULL;
		}
		rt->small_cap = need;
	}
	for (uint32_t y = 0; y < *h; y++) {
		for (uint32_t x = 0; x < *w; x++) {
			memcpy(rt->small + ((size_t)y * *w + x) * 4u,
			       v->frame.rgba + (((size_t)y << l) * v->width +
						((size_t)x << l)) *
						       4u,
			       4);
		}
	}
	return rt->small;
}

static void run_job(struct bc_rthread *rt, struct bc_rjob *job,
                    struct rresult *res)
{
	struct replica *rp = replica_of(rt, job->session_id, false);
	struct bc_errinfo ei = {0};
	struct bc_proto_rect whole, *rects = &whole;
	struct bc_encoded *enc = NULL;
	struct bc_msg m = {.type = BC_MSG_FRAME};
	struct bc_proto_buf b;
	struct view *v;
	const uint8_t *pix;
	uint32_t nrects = 1, iw, ih;
	bool incomplete = false, yielded = false, lossless, patch;
	int encoding, quality, rc;
	double t0, t1;
	res->job = job;
	if (!rp || !rp->tree || !bc_tree_lin(rp->tree)) {
		push_result(rt, res);
		return;
	}
	if (job->pick) {
		pick(rp, job, res);
		push_result(rt, res);
		return;
	}
	if (!rp->r &&
	    bc_renderer_create(&rp->r, rt->backend, &rt->opts, &ei)) {
		bc_log(BC_LOG_ERROR, "renderer: %s", ei.msg);
		push_result(rt, res);
		return;
	}
	t0 = now_ms();
	if (rp->fresh) {
		struct bc_dirty ignored;
		bc_tree_take_dirty(rp->tree, &ignored);
		rp->fresh = false;
		if (bc_renderer_sync(rp->r, rp->tree, NULL, &ei)) {
			goto fail;
		}
	} else {
		struct bc_dirty dirty;
		bc_tree_take_dirty(rp->tree, &dirty);
		if (dirty.edits &&
		    bc_renderer_sync(rp->r, rp->tree, &dirty, &ei)) {
			goto fail;
		}
	}
	if (!(v = view_of(rt, job))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for a %ux%u view",
			       job->width, job->height);
		goto fail;
	}
	if (update_view(rt, rp, v, job, &incomplete, &yielded, &ei)) {
		v->level = -1;
		goto fail;
	}
	if (yielded) {
		/* Nothing new to show: the refinement waits behind newer
		 * work, and the targets stay owed a frame. */
		res->yielded = true;
		push_result(rt, res);
		return;
	}
	t1 = now_ms();
	res->render_ms = t1 - t0;
	/* What to send: the tiles changed since the picture the targets
	 * hold, when they hold this view at level 0 and the frame keeps its
	 * kind (a still over a lossless base, or an interactive frame);
	 * else the whole picture at the view's level. */
	lossless = job->snapshot_seq || (job->final && v->level == 0);
	encoding = lossless ? job->encoding : job->encoding_interactive;
	quality = lossless ? job->quality_still : job->quality_interactive;
	patch = !job->snapshot_seq && v->level == 0 &&
		job->shown.view == v->id && job->shown.level == 0 &&
		(!lossless || job->shown.lossless);
	if (!(pix = picture(rt, v, &iw, &ih))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for a picture");
		goto fail;
	}
	whole = (struct bc_proto_rect){0, 0, (uint16_t)iw, (uint16_t)ih,
				       {NULL, 0}};
	if (patch) {
		bool none;
		uint32_t n = changed_rects(rt, v, job->shown.version, &none);
		if (n > 0) {
			rects = rt->rects;
			nrects = n;
		} else if (none) {
			/* Nothing visible changed: the smallest frame still
			 * tells the order reached. */
			whole.w = (uint16_t)(iw < 16 ? iw : 16);
			whole.h = (uint16_t)(ih < 16 ? ih : 16);
		}
	}
	if (!(enc = bc_calloc(nrects, sizeof(*enc)))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for %u rectangles",
		               nrects);
		goto fail;
	}
	for (uint32_t i = 0; i < nrects; i++) {
		if (bc_encode_rect(rt->enc, pix, iw, rects[i].x, rects[i].y,
				   rects[i].w, rects[i].h, encoding, quality,
				   &enc[i])) {
			bc_errinfo_set(&ei, BC_ECODEC, "encoding failed");
			goto fail;
		}
		rects[i].data.ptr = enc[i].data;
		rects[i].data.len = (uint32_t)enc[i].len;
	}
	m.flags = bc_proto_flags_with_level(0, (unsigned)v->level);
	if (job->snapshot_seq) {
		m.flags |= BC_PROTO_FLAG_SNAPSHOT | BC_PROTO_FLAG_STILL;
	} else if (lossless) {
		m.flags |= BC_PROTO_FLAG_STILL;
	}
	if (incomplete || v->stuck) {
		m.flags |= BC_PROTO_FLAG_INCOMPLETE;
		res->incomplete = true;
		bc_log(BC_LOG_WARN,
		       "session %u: frame %u refined only to level %d within "
		       "the %u ms budget",
		       job->session_id, job->frame_no, v->level,
		       rt->budget_ms);
	}
	m.seq = job->snapshot_seq;
	m.frame.frame_no = job->frame_no;
	m.frame.order = job->order;
	m.frame.camera_seq = job->camera_seq;
	m.frame.encoding = (enum bc_proto_encoding)encoding;
	m.frame.width = (uint16_t)job->width;
	m.frame.height = (uint16_t)job->height;
	m.frame.image_width = (uint16_t)iw;
	m.frame.image_height = (uint16_t)ih;
	m.frame.nrects = (uint16_t)nrects;
	m.frame.rects = rects;
	/* Encoded up to the protocol's limit: each target's own
	 * max_frame_bytes is checked when it is delivered (a frame over it is
	 * answered ERROR ELIMIT, PROTOCOL.md 7.15). */
	bc_proto_buf_init(&b,
	                  (size_t)BC_PROTO_MAX_PAYLOAD + BC_PROTO_HEADER_SIZE);
	rc = bc_proto_encode(&b, &m, &ei);
	res->too_big = rc == BC_ELIMIT || rc == BC_EPROTO_LENGTH;
	if (rc == 0 && !(res->frame = bc_shared_new(b.len))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for a frame");
		res->oom = true;
	}
	if (res->frame) {
		memcpy(res->frame->data, b.data, b.len);
		res->shown = (struct bc_shown){
			.view = v->id,
			.version = v->version,
			.level = (int8_t)v->level,
			.lossless = lossless && (patch ? job->shown.lossless
						       : true),
			.refining = v->level > 0 && !v->stuck,
			.still = (m.flags & BC_PROTO_FLAG_STILL) != 0,
		};
	} else {
		bc_log(BC_LOG_WARN, "frame %u not sent: %s", job->frame_no,
		       ei.msg);
	}
	bc_proto_buf_finish(&b);
	res->encode_ms = now_ms() - t1;
	for (uint32_t i = 0; i < nrects; i++) {
		bc_free(enc[i].data);
		rects[i].data.ptr = NULL;
	}
	bc_free(enc);
	push_result(rt, res);
	return;
fail:
	bc_log(BC_LOG_ERROR, "session %u: frame failed: %s", job->session_id,
	       ei.msg);
	res->oom = ei.code == BC_ENOMEM;
	if (enc) {
		for (uint32_t i = 0; i < nrects; i++) {
			bc_free(enc[i].data);
			rects[i].data.ptr = NULL;
		}
		bc_free(enc);
	}
	push_result(rt, res);
}

static void run(struct bc_rthread *rt, struct rcmd *cmd)
{
	struct replica *rp;
	switch (cmd->kind) {
	case RCMD_SCENE:
		rp = replica_of(rt, cmd->session_id, true);
		if (!rp) {
			bc_tree_destroy(cmd->tree);
			break;
		}
		bc_tree_destroy(rp->tree);
		rp->tree = cmd->tree;
		rp->fresh = true;
		views_drop(rt, cmd->session_id);
		break;
	case RCMD_SET_PRIM:
	case RCMD_SET_OP:
		rp = replica_of(rt, cmd->session_id, false);
		if (rp && rp->tree) {
			struct edit_abvs e;
			edit_begin(rp, cmd->id, &e);
			if (cmd->kind == RCMD_SET_PRIM) {
				bc_tree_set_prim(rp->tree, cmd->id, &cmd->p,
						 NULL);
			} else {
				bc_tree_set_op(rp->tree, cmd->id, &cmd->op,
					       NULL);
			}
			edit_end(rt, rp, &e);
		}
		break;
	case RCMD_DROP:
		rp = replica_of(rt, cmd->session_id, false);
		if (rp) {
			replica_drop(rt, rp);
		}
		break;
	case RCMD_JOB:
		run_job(rt, cmd->job, cmd->res);
		break;
	default:
		break;
	}
}

static void thread_main(void *arg)
{
	struct bc_rthread *rt = arg;
	for (;;) {
		struct rcmd *cmd;
		uv_mutex_lock(&rt->lock);
		while (!rt->head && !rt->quit) {
			uv_cond_wait(&rt->cond, &rt->lock);
		}
		if (rt->quit) {
			uv_mutex_unlock(&rt->lock);
			break;
		}
		cmd = rt->head;
		rt->head = cmd->next;
		if (!rt->head) {
			rt->tail = NULL;
		}
		uv_mutex_unlock(&rt->lock);
		run(rt, cmd);
		bc_free(cmd);
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		replica_drop(rt, &rt->replicas[i]);
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		view_free(&rt->views[i]);
	}
}

static void push_cmd(struct bc_srv *srv, struct rcmd *cmd)
{
	struct bc_rthread *rt = srv->rt;
	uv_mutex_lock(&rt->lock);
	if (rt->tail) {
		rt->tail->next = cmd;
	} else {
		rt->head = cmd;
	}
	rt->tail = cmd;
	uv_cond_signal(&rt->cond);
	uv_mutex_unlock(&rt->lock);
}

static struct rcmd *new_cmd(enum rcmd_kind kind, uint32_t session_id)
{
	struct rcmd *cmd = bc_calloc(1, sizeof(*cmd));
	if (cmd) {
		cmd->kind = kind;
		cmd->session_id = session_id;
	} else {
		bc_log(BC_LOG_ERROR, "out of memory queueing render work");
	}
	return cmd;
}

void bc_rthread_scene(struct bc_srv *srv, uint32_t session_id,
		      struct bc_tree *copy)
{
	struct rcmd *cmd = new_cmd(RCMD_SCENE, session_id);
	if (!cmd) {
		bc_tree_destroy(copy);
		return;
	}
	cmd->tree = copy;
	push_cmd(srv, cmd);
}

void bc_rthread_set_prim(struct bc_srv *srv, uint32_t session_id, uint32_t id,
			 const struct bc_prim_data *p)
{
	struct rcmd *cmd = new_cmd(RCMD_SET_PRIM, session_id);
	if (cmd) {
		cmd->id = id;
		cmd->p = *p;
		push_cmd(srv, cmd);
	}
}

void bc_rthread_set_op(struct bc_srv *srv, uint32_t session_id, uint32_t id,
		       const struct bc_op_data *op)
{
	struct rcmd *cmd = new_cmd(RCMD_SET_OP, session_id);
	if (cmd) {
		cmd->id = id;
		cmd->op = *op;
		push_cmd(srv, cmd);
	}
}

void bc_rthread_drop(struct bc_srv *srv, uint32_t session_id)
{
	struct rcmd *cmd = new_cmd(RCMD_DROP, session_id);
	if (cmd) {
		push_cmd(srv, cmd);
	}
}

static void free_job(struct bc_rjob *job)
{
	bc_free(job->targets);
	bc_free(job);
}

void bc_rthread_job(struct bc_srv *srv, struct bc_rjob *job)
{
	struct rcmd *cmd = new_cmd(RCMD_JOB, job->session_id);
	struct rresult *res = bc_calloc(1, sizeof(*res));
	if (!cmd || !res) {
		bc_log(BC_LOG_ERROR, "out of memory queueing a render job");
		bc_free(cmd);
		bc_free(res);
		bc_session_frame_failed(srv, job);
		free_job(job);
		return;
	}
	cmd->job = job;
	cmd->res = res;
	push_cmd(srv, cmd);
}

/* The frame does not fit what c accepts (its HELLO max_frame_bytes) or
 * the protocol's payload limit. */
static bool over_limit(const struct bc_conn *c, const struct rresult *res)
{
	return res->too_big ||
	       (res->frame && res->frame->len - BC_PROTO_HEADER_SIZE >
	                          (size_t)c->max_frame_bytes);
}

/* A frame too large for c is not sent: c hears ERROR ELIMIT, non-fatal,
 * with the SNAPSHOT's seq or 0 (PROTOCOL.md 7.15), and keeps the picture it
 * has. */
static void frame_over_limit(struct bc_conn *c, const struct bc_rjob *job,
                             const struct rresult *res)
{
	size_t len = res->frame ? res->frame->len - BC_PROTO_HEADER_SIZE : 0;
	bc_log(BC_LOG_WARN,
	       "client %u: frame %u not sent: %zu bytes, over its limit of "
	       "%u",
	       c->gen, job->frame_no, len, c->max_frame_bytes);
	bc_conn_send_error(c, job->snapshot_seq, BC_ELIMIT, false,
	                   "the %s (%ux%u) does not fit the frame size limit "
	                   "(%u bytes)",
	                   job->snapshot_seq ? "snapshot" : "frame", job->width,
	                   job->height, c->max_frame_bytes);
}

void bc_rthread_deliver(uv_async_t *async)
{
	struct bc_srv *srv = async->data;
	struct bc_rthread *rt = srv->rt;
	struct rresult *res;
	uv_mutex_lock(&rt->lock);
	res = rt->rhead;
	rt->rhead = rt->rtail = NULL;
	uv_mutex_unlock(&rt->lock);
	while (res) {
		struct rresult *next = res->next;
		struct bc_rjob *job = res->job;
		if (job->pick) {
			struct bc_conn *c = bc_conn_get(srv, job->targets[0]);
			struct bc_msg m = {.type = BC_MSG_PICK_RESULT,
					   .seq = job->pick_seq};
			m.pick_result.x = job->pick_x;
			m.pick_result.y = job->pick_y;
			m.pick_result.node = res->hit ? res->node : 0;
			if (res->hit) {
				memcpy(m.pick_result.position, res->position,
				       sizeof(res->position));
				m.pick_result.depth = res->depth;
			}
			if (c) {
				bc_conn_send(c, &m);
			}
		} else {
			if (res->render_ms > 0.0) {
				srv->render_ms_last = res->render_ms;
				srv->encode_ms_last = res->encode_ms;
				srv->render_ms_avg =
					srv->render_ms_avg == 0.0
						? res->render_ms
						: 0.9 * srv->render_ms_avg +
							  0.1 * res->render_ms;
				srv->encode_ms_avg =
					srv->encode_ms_avg == 0.0
						? res->encode_ms
						: 0.9 * srv->encode_ms_avg +
							  0.1 * res->encode_ms;
			}
			for (uint32_t i = 0; i < job->ntargets && res->yielded;
			     i++) {
				struct bc_conn *c =
					bc_conn_get(srv, job->targets[i]);
				if (c) {
					c->dirty = true;
				}
			}
			for (uint32_t i = 0;
			     i < job->ntargets && (res->frame || res->too_big);
			     i++) {
				struct bc_conn *c =
					bc_conn_get(srv, job->targets[i]);
				if (c && over_limit(c, res)) {
					frame_over_limit(c, job, res);
				} else if (c && !job->snapshot_seq) {
					bc_conn_send_frame(c, res->frame);
					c->shown = res->shown;
					c->still_sent = res->shown.still;
					/* A finer level is owed while nothing
					 * else changes; during an interaction
					 * it waits for its end (the still
					 * timer), so the next camera or edit
					 * never queues behind a refinement. */
					c->dirty = c->dirty ||
						   (res->shown.refining &&
						    bc_now_ms(srv) >=
							    c->interacting_until);
				} else if (c) {
					bc_conn_send_frame(c, res->frame);
				}
			}
			if (res->oom) {
				bc_session_frame_failed(srv, job);
			} else if (!job->snapshot_seq) {
				bc_session_frame_done(srv, job->session_id,
						      job->targets, job->ntargets);
			} else if (!res->frame && !res->too_big) {
				struct bc_conn *c =
					bc_conn_get(srv, job->targets[0]);
				if (c) {
					bc_conn_send_error(
					    c, job->snapshot_seq, BC_EIO, false,
					    "the snapshot could not be "
					    "rendered or encoded");
				}
			}
		}
		bc_shared_unref(res->frame);
		free_job(job);
		bc_free(res);
		res = next;
	}
}

int bc_rthread_start(struct bc_srv *srv, struct bc_errinfo *ei)
{
	struct bc_rthread *rt = bc_calloc(1, sizeof(*rt));
	if (!rt) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	rt->srv = srv;
	rt->backend = srv->cfg.backend;
	if (!bc_backend_available(rt->backend)) {
		bc_free(rt);
		return bc_errinfo_set(ei, BC_ENOTSUP,
				      "backend %s is not built in",
				      bc_backend_name(srv->cfg.backend));
	}
	rt->opts.gl_platform = srv->cfg.gl_platform;
	/* The renderer never cuts a frame: refinement keeps the budget
	 * (refine()), so every picture sent is whole at its level. */
	rt->opts.budget_ms = 0;
	rt->budget_ms = srv->cfg.frame_budget_ms ? srv->cfg.frame_budget_ms
						 : BC_SRV_FRAME_BUDGET_MS;
	rt->opts.simd = srv->cfg.simd;
	rt->damage_off = srv->cfg.no_damage;
	if (!(rt->enc = bc_encoder_create()) ||
	    !(rt->rects = bc_calloc(BC_PROTO_MAX_RECTS, sizeof(*rt->rects)))) {
		bc_encoder_destroy(rt->enc);
		bc_free(rt);
		return bc_errinfo_set(ei, BC_ENOMEM, "cannot create encoder");
	}
	uv_mutex_init(&rt->lock);
	uv_cond_init(&rt->cond);
	srv->rt = rt;
	uv_async_init(srv->loop, &srv->results, bc_rthread_deliver);
	srv->results.data = srv;
	if (uv_thread_create(&rt->thread, thread_main, rt) != 0) {
		return bc_errinfo_set(ei, BC_EIO, "cannot start render thread");
	}
	return 0;
}

void bc_rthread_stop(struct bc_srv *srv)
{
	struct bc_rthread *rt = srv->rt;
	struct rcmd *cmd;
	struct rresult *res;
	if (!rt) {
		return;
	}
	uv_mutex_lock(&rt->lock);
	rt->quit = true;
	uv_cond_signal(&rt->cond);
	uv_mutex_unlock(&rt->lock);
	uv_thread_join(&rt->thread);
	for (cmd = rt->head; cmd;) {
		struct rcmd *next = cmd->next;
		bc_tree_destroy(cmd->tree);
		bc_free(cmd->res);
		if (cmd->job) {
			free_job(cmd->job);
		}
		bc_free(cmd);
		cmd = next;
	}
	for (res = rt->rhead; res;) {
		struct rresult *next = res->next;
		bc_shared_unref(res->frame);
		free_job(res->job);
		bc_free(res);
		res = next;
	}
	bc_free(rt->small);
	bc_free(rt->rects);
	bc_free(rt->seen);
	bc_free(rt->band);
	bc_encoder_destroy(rt->enc);
	uv_mutex_destroy(&rt->lock);
	uv_cond_destroy(&rt->cond);
	uv_close((uv_handle_t *)&srv->results, NULL);
	bc_free(rt);
	srv->rt = NULL;
}
