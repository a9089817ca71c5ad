/*
 * The view cache. For every view the workers render (session, camera,
 * size) it keeps the full-size colour, depth and id planes and, per 8x8
 * tile, the finest refinement level the tile holds whole, whether an edit
 * damaged it, whether rays of it ran out of evaluations, and the version
 * of its last change. A job pins the view it works on; views nobody pins
 * are dropped least recently used first whenever a new one would pass the
 * cache's cap, which counts the planes and the renderers' own state (a
 * renderer keeps per-view buffers too: the tiled backend's ray directions
 * alone are 12 bytes a pixel), so the cap holds whatever the view sizes.
 * Also the two things a frame takes from a view: the rectangles changed
 * since a version, and the picture at a level.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "work_impl.h"

/* Bytes a view of this size holds: its colour plane and per-tile state
 * (depth and ids come only with a snapshot that asks for them), and the
 * state its session's renderer will keep for it. */
static size_t view_bytes(uint32_t width, uint32_t height)
{
	size_t ntiles =
	    (size_t)bc_render_tiles_x(width) * bc_render_tiles_y(height);
	return (size_t)width * height * 4u + ntiles * 7u;
}

static size_t renderer_bytes(uint32_t width, uint32_t height)
{
	return (size_t)width * height * BC_SRV_RENDERER_BYTES_PX;
}

int bc__views_init(struct views *vs, size_t cap)
{
	memset(vs, 0, sizeof(*vs));
	vs->cap = cap;
	return uv_mutex_init(&vs->lock) ? BC_EIO : 0;
}

static void view_free(struct views *vs, struct view *v)
{
	vs->bytes -= v->bytes;
	bc_frame_finish(&v->frame);
	bc_free(v->tlevel);
	bc_free(v->damage);
	bc_free(v->shorts);
	bc_free(v->changed);
	memset(v, 0, sizeof(*v));
}

void bc__views_finish(struct views *vs)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		if (vs->v[i].id) {
			view_free(vs, &vs->v[i]);
		}
	}
	uv_mutex_destroy(&vs->lock);
}

/* The least recently used view nobody pins, or NULL. Lock held. */
static struct view *lru(struct views *vs)
{
	struct view *oldest = NULL;
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *v = &vs->v[i];
		if (v->id && !v->pins && (!oldest || v->used < oldest->used)) {
			oldest = v;
		}
	}
	return oldest;
}

/* Whether the frame is the window win (or the whole view, without one). */
static bool same_window(const struct bc_frame *f,
                        const struct bc_job_window *win)
{
	return f->full_width == win->full_width &&
	       (!win->full_width || (f->full_height == win->full_height &&
	                             f->win_x == win->x && f->win_y == win->y));
}

/* A kept view of (sid, win, cam, width, height), pinned, or NULL. Lock
 * held. */
static struct view *find(struct views *vs, uint32_t sid,
                         const struct bc_job_window *win,
                         const struct bc_camera *cam, uint32_t width,
                         uint32_t height)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *v = &vs->v[i];
		if (v->id && !v->dead && v->sid == sid && v->width == width &&
		    v->height == height && same_window(&v->frame, win) &&
		    memcmp(&v->camera, cam, sizeof(*cam)) == 0) {
			v->pins++;
			v->used = ++vs->clock;
			return v;
		}
	}
	return NULL;
}

/* Drops unpinned views, oldest first, until `need` more bytes fit under
 * the cap beside the renderers' `kept`. Returns a free slot, or NULL when
 * the room cannot be made. Lock held. */
static struct view *make_room(struct views *vs, size_t need, size_t kept)
{
	struct view *slot = NULL, *old;
	while (vs->bytes + kept + need > vs->cap && (old = lru(vs))) {
		view_free(vs, old);
	}
	if (vs->bytes + kept + need > vs->cap) {
		return NULL;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS && !slot; i++) {
		slot = vs->v[i].id ? NULL : &vs->v[i];
	}
	if (!slot && (old = lru(vs))) {
		view_free(vs, old);
		slot = old;
	}
	return slot;
}

static int view_init(struct view *v, const struct bc_job_window *win,
                     uint32_t width, uint32_t height)
{
	v->tw = bc_render_tiles_x(width);
	v->th = bc_render_tiles_y(height);
	v->ntiles = v->tw * v->th;
	memset(&v->frame, 0, sizeof(v->frame));
	v->frame.width = width;
	v->frame.height = height;
	if (!(v->frame.rgba = bc_malloc((size_t)width * height * 4u)) ||
	    !(v->tlevel = bc_malloc(v->ntiles)) ||
	    !(v->damage = bc_calloc(v->ntiles, 1)) ||
	    !(v->shorts = bc_calloc(v->ntiles, 1)) ||
	    !(v->changed = bc_calloc(v->ntiles, sizeof(*v->changed)))) {
		return BC_ENOMEM;
	}
	if (win->full_width &&
	    bc_frame_window(&v->frame, win->x, win->y, win->full_width,
	                    win->full_height)) {
		return BC_ERANGE;
	}
	v->width = width;
	v->height = height;
	bc__view_reset(v);
	return 0;
}

struct view *bc__view_acquire(struct bc_work *w, uint32_t sid,
                              const struct bc_job_window *win,
                              const struct bc_camera *cam, uint32_t width,
                              uint32_t height)
{
	struct views *vs = &w->views;
	size_t need = view_bytes(width, height);
	struct view *v;
	uv_mutex_lock(&vs->lock);
	if ((v = find(vs, sid, win, cam, width, height))) {
		uv_mutex_unlock(&vs->lock);
		return v;
	}
	v = make_room(vs, need + renderer_bytes(width, height),
	              bc__work_kept_bytes(w));
	uv_mutex_unlock(&vs->lock);
	if (!v) {
		/* Renderers of idle sessions give their state back first. */
		bc__work_trim(w);
		uv_mutex_lock(&vs->lock);
		v = make_room(vs, need + renderer_bytes(width, height),
		              bc__work_kept_bytes(w));
		uv_mutex_unlock(&vs->lock);
	}
	if (!v) {
		bc_log(BC_LOG_WARN,
		       "view cache: no room for a %ux%u view under its %zu "
		       "MiB cap",
		       width, height, vs->cap >> 20);
		return NULL;
	}
	uv_mutex_lock(&vs->lock);
	if (v->id) {
		/* Another worker took the slot meanwhile. */
		v = make_room(vs, need + renderer_bytes(width, height),
		              bc__work_kept_bytes(w));
	}
	if (!v || view_init(v, win, width, height)) {
		if (v) {
			view_free(vs, v);
		}
		uv_mutex_unlock(&vs->lock);
		return NULL;
	}
	if (++vs->next_id == 0) {
		vs->next_id = 1;
	}
	v->id = vs->next_id;
	v->sid = sid;
	v->camera = *cam;
	v->pins = 1;
	v->used = ++vs->clock;
	v->bytes = need;
	vs->bytes += need;
	uv_mutex_unlock(&vs->lock);
	return v;
}

void bc__view_release(struct bc_work *w, struct view *v)
{
	struct views *vs = &w->views;
	uv_mutex_lock(&vs->lock);
	/* A snapshot tile's window is never asked for again as it is (the
	 * next tile is another window): kept, it would only push other
	 * sessions' views out of the cache. */
	if (--v->pins == 0 && (v->dead || v->frame.full_width)) {
		view_free(vs, v);
	}
	uv_mutex_unlock(&vs->lock);
}

void bc__views_drop(struct bc_work *w, uint32_t sid)
{
	struct views *vs = &w->views;
	uv_mutex_lock(&vs->lock);
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *v = &vs->v[i];
		if (!v->id || v->sid != sid) {
			continue;
		}
		if (v->pins) {
			v->dead = true;
		} else {
			view_free(vs, v);
		}
	}
	uv_mutex_unlock(&vs->lock);
}

uint32_t bc__views_of(struct bc_work *w, uint32_t sid, struct view **out)
{
	struct views *vs = &w->views;
	uint32_t n = 0;
	uv_mutex_lock(&vs->lock);
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		struct view *v = &vs->v[i];
		if (v->id && !v->dead && v->sid == sid) {
			v->pins++;
			out[n++] = v;
		}
	}
	uv_mutex_unlock(&vs->lock);
	return n;
}

size_t bc__views_bytes(struct bc_work *w)
{
	size_t bytes;
	uv_mutex_lock(&w->views.lock);
	bytes = w->views.bytes;
	uv_mutex_unlock(&w->views.lock);
	return bytes + bc__work_kept_bytes(w);
}

/* Drops least recently used views that no job holds while the cache and
 * the renderers' state pass the cap. Called with the lock held. */
static void shed(struct views *vs, size_t kept)
{
	struct view *old;
	while (vs->bytes + kept > vs->cap && (old = lru(vs))) {
		view_free(vs, old);
	}
}

void bc__views_settle(struct bc_work *w)
{
	struct views *vs = &w->views;
	if (bc__views_bytes(w) <= vs->cap) {
		return;
	}
	/* Renderers of idle sessions give their state back first, then
	 * views go. */
	bc__work_trim(w);
	uv_mutex_lock(&vs->lock);
	shed(vs, bc__work_kept_bytes(w));
	uv_mutex_unlock(&vs->lock);
}

int bc__view_planes(struct bc_work *w, struct view *v)
{
	struct views *vs = &w->views;
	size_t n = (size_t)v->width * v->height, need = 8u * n;
	int rc = 0;
	if (v->frame.depth) {
		return 0;
	}
	uv_mutex_lock(&vs->lock);
	/* This view is pinned, so make_room never drops it. */
	if (vs->bytes + bc__work_kept_bytes(w) + need > vs->cap &&
	    !make_room(vs, need, bc__work_kept_bytes(w))) {
		rc = BC_ENOMEM;
	} else if (!(v->frame.depth = bc_malloc(n * sizeof(float))) ||
	           !(v->frame.ids = bc_malloc(n * sizeof(uint32_t)))) {
		bc_free(v->frame.depth);
		v->frame.depth = NULL;
		rc = BC_ENOMEM;
	} else {
		v->bytes += need;
		vs->bytes += need;
		v->frame.key = 0;
		bc__view_reset(v);
	}
	uv_mutex_unlock(&vs->lock);
	return rc;
}

void bc__view_reset(struct view *v)
{
	memset(v->tlevel, 0xff, v->ntiles); /* -1: nothing */
	memset(v->damage, 0, v->ntiles);
	memset(v->shorts, 0, v->ntiles);
	v->damaged = false;
	v->bound = 0;
}

int bc__view_level(const struct view *v)
{
	int level = 0;
	for (uint32_t t = 0; t < v->ntiles; t++) {
		if (v->tlevel[t] < 0) {
			return -1;
		}
		level = v->tlevel[t] > level ? v->tlevel[t] : level;
	}
	return level;
}

/* Room for n bytes in *buf. */
static bool reserve(uint8_t **buf, size_t *cap, size_t n)
{
	if (*cap >= n) {
		return true;
	}
	bc_free(*buf);
	*cap = 0;
	if (!(*buf = bc_malloc(n))) {
		return false;
	}
	*cap = n;
	return true;
}

/* Whether tile (x, y) changed after `since` and is not merged yet. */
static bool changed_after(const struct worker *wk, const struct view *v,
                          uint32_t x, uint32_t y, uint32_t since)
{
	size_t t = (size_t)y * v->tw + x;
	return v->changed[t] > since && !wk->seen[t];
}

/* The run of changed tiles from (tx, ty): its width along the row, then
 * how many rows below repeat it exactly. */
static void run_at(const struct worker *wk, const struct view *v, uint32_t tx,
                   uint32_t ty, uint32_t since, uint32_t *w, uint32_t *h)
{
	bool same = true;
	*w = 0;
	*h = 1;
	while (tx + *w < v->tw && changed_after(wk, v, tx + *w, ty, since)) {
		(*w)++;
	}
	while (same && ty + *h < v->th) {
		for (uint32_t i = 0; i < *w && same; i++) {
			same = changed_after(wk, v, tx + i, ty + *h, since);
		}
		*h += same ? 1u : 0u;
	}
}

uint32_t bc__changed_rects(struct worker *wk, const struct view *v,
                           uint32_t since, bool *none)
{
	uint32_t n = 0, T = BC_RENDER_TILE;
	*none = true;
	if (!reserve(&wk->seen, &wk->seen_cap, v->ntiles)) {
		return 0;
	}
	memset(wk->seen, 0, v->ntiles);
	for (uint32_t ty = 0; ty < v->th; ty++) {
		for (uint32_t tx = 0; tx < v->tw; tx++) {
			uint32_t w, h;
			if (!changed_after(wk, v, tx, ty, since)) {
				continue;
			}
			*none = false;
			run_at(wk, v, tx, ty, since, &w, &h);
			for (uint32_t j = 0; j < h; j++) {
				memset(wk->seen + (size_t)(ty + j) * v->tw + tx,
				       1, w);
			}
			if (n == BC_PROTO_MAX_RECTS) {
				return 0;
			}
			wk->rects[n++] = (struct bc_proto_rect){
			    (uint16_t)(tx * T),
			    (uint16_t)(ty * T),
			    (uint16_t)((tx + w) * T > v->width
			                   ? v->width - tx * T
			                   : w * T),
			    (uint16_t)((ty + h) * T > v->height
			                   ? v->height - ty * T
			                   : h * T),
			    {NULL, 0}};
		}
	}
	return n;
}

const uint8_t *bc__picture(struct worker *wk, const struct view *v, int l,
                           uint32_t *w, uint32_t *h)
{
	*w = (v->width + (1u << l) - 1) >> l;
	*h = (v->height + (1u << l) - 1) >> l;
	if (l == 0) {
		return v->frame.rgba;
	}
	if (!reserve(&wk->small, &wk->small_cap, (size_t)*w * *h * 4u)) {
		return NULL;
	}
	for (uint32_t y = 0; y < *h; y++) {
		for (uint32_t x = 0; x < *w; x++) {
			memcpy(wk->small + ((size_t)y * *w + x) * 4u,
			       v->frame.rgba + (((size_t)y << l) * v->width +
			                        ((size_t)x << l)) *
			                           4u,
			       4);
		}
	}
	return wk->small;
}
