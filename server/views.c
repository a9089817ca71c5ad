/*
 * The render thread's views (see rthread.c's comment): for each view it
 * renders, the planes at full size, the finest level they hold and a
 * version per tile; the damage a parameter edit does to them; the coarse
 * level a new view starts at (the cost model) and its refinement, level by
 * level within the frame budget; the rectangles changed since a version;
 * and the picture at the view's level.
 */
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/log.h"
#include "rthread_impl.h"

void bc__view_free(struct view *v)
{
	bc_frame_finish(&v->frame);
	bc_free(v->changed);
	bc_free(v->damage);
	memset(v, 0, sizeof(*v));
}

/* Forgets every view of a session (its structure changed, or it ends). */
void bc__views_drop(struct bc_rthread *rt, uint32_t session_id)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		if (rt->views[i].id && rt->views[i].session_id == session_id) {
			bc__view_free(&rt->views[i]);
		}
	}
}

/* The view of a job, kept or new (the least recently used one, or one
 * over the memory cap, makes room). NULL when out of memory. */
struct view *bc__view_of(struct bc_rthread *rt, const struct bc_rjob *job)
{
	struct view *v = NULL, *oldest = NULL;
	size_t bytes = 0, need = (size_t)job->width * job->height * 12u;
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *w = &rt->views[i];
		if (!w->id) {
			v = v ? v : w;
			continue;
		}
		if (w->session_id == job->session_id &&
		    w->width == job->width && w->height == job->height &&
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
		bc__view_free(oldest);
		v = v ? v : oldest;
	}
	if (!v) {
		return NULL;
	}
	v->ntiles =
	    bc_render_tiles_x(job->width) * bc_render_tiles_y(job->height);
	if (bc_frame_init(&v->frame, job->width, job->height) ||
	    !(v->changed = bc_calloc(v->ntiles, sizeof(*v->changed))) ||
	    !(v->damage = bc_calloc(v->ntiles, 1))) {
		bc__view_free(v);
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

void bc__edit_begin(const struct replica *rp, uint32_t id, struct edit_abvs *e)
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

void bc__edit_end(struct bc_rthread *rt, const struct replica *rp,
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
		if (rp->ms_abuffer + rays * rp->ms_per_ray <=
		    BC_SRV_COARSE_MS) {
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
		rp->ms_abuffer = rp->ms_abuffer > 0.0 ? 0.7 * rp->ms_abuffer +
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
	double start = bc_clock_ms();
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
		    bc_clock_ms() - start > (double)rt->budget_ms) {
			return 0;
		}
		memset(rt->band, 0, v->ntiles);
		memset(rt->band + (size_t)y0 * cols, 1,
		       (size_t)(y1 - y0) * cols);
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
int bc__update_view(struct bc_rthread *rt, struct replica *rp, struct view *v,
                    const struct bc_rjob *job, bool *incomplete, bool *yielded,
                    struct bc_errinfo *ei)
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
	    (uint64_t)ndamaged * 100u >
	        (uint64_t)v->ntiles * BC_SRV_DAMAGE_PCT &&
	    !job->snapshot_seq) {
		v->level = -1; /* large: a fresh progressive picture */
	}
	if (v->level < 0) {
		struct bc_render_region all = {NULL, 0, false};
		all.level =
		    job->snapshot_seq ? 0u : (uint32_t)start_level(rp, job);
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
	} else if (v->level > 0 && (!v->stuck || job->snapshot_seq)) {
		/* One level finer; a snapshot waits for all, even of a
		 * picture the budget stopped. */
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
		if (v->level == 0) {
			v->stuck = false;
		}
	}
	v->damaged = false;
	memset(v->damage, 0, v->ntiles);
	return 0;
}

/* Merges the tiles changed after version `since` into rectangles (runs
 * along each tile row, then runs of equal spans down the rows). Returns
 * the count; 0 when there are more than BC_PROTO_MAX_RECTS (the whole
 * picture is then cheaper) or none changed (*none set). */
uint32_t bc__changed_rects(struct bc_rthread *rt, const struct view *v,
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
	(v->changed[(size_t)(y)*cols + (x)] > since &&                         \
	 !rt->seen[(size_t)(y)*cols + (x)])
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
			    (uint16_t)(tx * T),
			    (uint16_t)(ty * T),
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
const uint8_t *bc__picture(struct bc_rthread *rt, const struct view *v,
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
