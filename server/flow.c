/*
 * A session's render copy (the flow's tree) and the changes queued for it.
 *
 * The loop thread applies every change to the session's own tree first;
 * the copy follows here, between jobs, on the worker holding the flow:
 *  - a parameter edit arrives as the states its nodes have after it
 *    (bc_edit_saved), merged on arrival into the newest queued set, so a
 *    stream of 1024-op batches at 20 Hz costs the renderer the newest
 *    value of each node once, however many batches came while a frame
 *    was being rendered;
 *  - a structural edit arrives as its operations, replayed with the edit
 *    module's own code (bc_edit_batch_apply), so the copy's tree is the
 *    session's, node for node, and the loop never copies a tree for it;
 *    when its layout was spliced and the renderer follows splices, the
 *    views keep their pictures and redraw the tiles the tree's dirty
 *    record says the change can reach, as for a parameter edit; else
 *    the pictures start over;
 *  - a structural batch may also arrive before the session applies it
 *    (bc_work_ops_early), so that the copy's splice runs beside the
 *    session's instead of after it; it is kept undoable until its
 *    verdict, and undone if the session refused or undid it;
 *  - a loaded scene arrives whole, and so does the session's tree when a
 *    member first wants a picture of a session that has no copy yet (a
 *    restored one, or one whose copy could not follow an edit:
 *    frames.c, bc__session_copy).
 * Applying a parameter change marks, in each of the session's views, the
 * tiles the renderer says the edited primitives' ABVs reach before and
 * after it (an operator's edit: every primitive of its subtree); the next
 * frame re-renders those tiles only.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "work_impl.h"

void bc__upd_free(struct upd *u)
{
	if (!u) {
		return;
	}
	bc_tree_destroy(u->tree);
	bc_free(u->st);
	bc_free(u->index);
	bc_ops_copy_finish(&u->ops);
	bc_free(u);
}

/* ---- parameter states, merged by node id ---------------------------------- */

static uint32_t hash_id(uint32_t id)
{
	id ^= id >> 16;
	id *= 0x7feb352du;
	id ^= id >> 15;
	return id;
}

/* Grows u's states to hold `need` and its index to twice that. Returns
 * false when out of memory (u unchanged). */
static bool states_reserve(struct upd *u, uint32_t need)
{
	uint32_t cap = u->cap ? u->cap : 16u, icap;
	struct bc_edit_saved *st;
	uint32_t *index;
	if (need <= u->cap) {
		return true;
	}
	while (cap < need) {
		cap *= 2u;
	}
	icap = 2u * cap;
	if (!(st = bc_realloc(u->st, (size_t)cap * sizeof(*st)))) {
		return false;
	}
	u->st = st;
	if (!(index = bc_calloc(icap, sizeof(*index)))) {
		return false;
	}
	bc_free(u->index);
	u->index = index;
	u->index_cap = icap;
	u->cap = cap;
	/* Rehash what is there. */
	for (uint32_t k = 0; k < u->n; k++) {
		uint32_t h = hash_id(u->st[k].id) & (icap - 1u);
		while (index[h]) {
			h = (h + 1u) & (icap - 1u);
		}
		index[h] = k + 1u;
	}
	return true;
}

/* Puts state s into u, replacing an earlier state of the same node. */
static bool states_put(struct upd *u, const struct bc_edit_saved *s)
{
	uint32_t h;
	if (!states_reserve(u, u->n + 1u)) {
		return false;
	}
	h = hash_id(s->id) & (u->index_cap - 1u);
	while (u->index[h]) {
		struct bc_edit_saved *old = &u->st[u->index[h] - 1u];
		if (old->id == s->id) {
			*old = *s;
			return true;
		}
		h = (h + 1u) & (u->index_cap - 1u);
	}
	u->st[u->n] = *s;
	u->index[h] = ++u->n;
	u->bytes += sizeof(*s) + 2u * sizeof(uint32_t);
	return true;
}

int bc_work_states(struct bc_work *w, uint32_t sid, uint64_t order,
                   const struct bc_edit_saved *states, uint32_t n)
{
	struct flow *f = NULL;
	struct upd *u, *fresh = NULL;
	bool ok = true;
	uv_mutex_lock(&w->lock);
	for (uint32_t i = 0; i < BC_SRV_MAX_FLOWS && !f; i++) {
		if (w->flows[i].sid == sid && !w->flows[i].dropped) {
			f = &w->flows[i];
		}
	}
	if (!f) {
		/* No copy (the session's scene never reached the work layer):
		 * nothing to follow. */
		uv_mutex_unlock(&w->lock);
		return 0;
	}
	u = f->utail;
	if (!u || u->kind != UPD_STATES) {
		if (!(u = fresh = bc_calloc(1, sizeof(*u)))) {
			uv_mutex_unlock(&w->lock);
			return BC_ENOMEM;
		}
		u->kind = UPD_STATES;
	}
	f->ubytes -= fresh ? 0 : u->bytes;
	for (uint32_t i = 0; i < n && ok; i++) {
		ok = states_put(u, &states[i]);
	}
	u->order = order;
	if (!ok || f->ubytes + u->bytes > BC_SRV_FLOW_CHANGE_BYTES) {
		/* The copy cannot follow: the caller sends the scene, which
		 * replaces whatever is queued. */
		f->ubytes += fresh ? 0 : u->bytes;
		uv_mutex_unlock(&w->lock);
		bc__upd_free(fresh);
		return ok ? BC_ELIMIT : BC_ENOMEM;
	}
	f->ubytes += u->bytes;
	if (fresh) {
		bc__work_wake(w, f);
		if (f->utail) {
			f->utail->next = fresh;
		} else {
			f->uhead = fresh;
		}
		f->utail = fresh;
	}
	uv_cond_signal(&w->cond);
	uv_mutex_unlock(&w->lock);
	return 0;
}

/* ---- structural batches -------------------------------------------------- */

static int queue_ops(struct bc_work *w, uint32_t sid, uint64_t order,
                     const struct bc_proto_edit_op *ops, uint32_t n, bool early)
{
	struct upd *u = bc_calloc(1, sizeof(*u));
	if (!u || bc_ops_copy(&u->ops, ops, n)) {
		bc__upd_free(u);
		return BC_ENOMEM;
	}
	u->kind = UPD_OPS;
	u->early = early;
	u->order = order;
	u->bytes = sizeof(*u) + u->ops.bytes;
	return bc__work_queue(w, sid, u);
}

int bc_work_ops(struct bc_work *w, uint32_t sid, uint64_t order,
                const struct bc_proto_edit_op *ops, uint32_t n)
{
	return queue_ops(w, sid, order, ops, n, false);
}

int bc_work_ops_early(struct bc_work *w, uint32_t sid, uint64_t order,
                      const struct bc_proto_edit_op *ops, uint32_t n)
{
	return queue_ops(w, sid, order, ops, n, true);
}

/* ---- applying, on the worker holding the flow ---------------------------- */

/* The primitives a node's edit can change the ABVs of: those of its
 * subtree, k0 .. k0 + n - 1 (an operator's edit changes their ROIs). */
struct damage {
	uint32_t k0, n;
	struct bc_abv *old; /* their ABVs before; NULL: too many, or none */
};

static void damage_begin(const struct flow *f, uint32_t id, struct damage *d)
{
	const struct bc_lin *l = bc_tree_lin(f->tree);
	uint32_t s = bc_tree_slot(f->tree, id);
	memset(d, 0, sizeof(*d));
	if (!l || s == BC_NONE) {
		return;
	}
	d->k0 = bc_lin_first_prim(l, s);
	d->n = (s - bc_lin_first(l, s)) / 2 + 1;
	if (d->n <= BC_SRV_DAMAGE_PRIMS &&
	    (d->old = bc_calloc(d->n, sizeof(*d->old)))) {
		for (uint32_t k = 0; k < d->n; k++) {
			d->old[k] = bc_lin_abv(l, d->k0 + k);
		}
	}
}

/* Marks in each view the tiles the ABVs a[0..na) and l's of primitives
 * k0 .. k0 + nb - 1 can reach (all of them when `all`). */
static void mark_views(struct bc_work *w, const struct flow *f,
                       struct view **views, uint32_t nviews,
                       const struct bc_abv *a, uint32_t na,
                       const struct bc_lin *l, uint32_t k0, uint32_t nb,
                       bool all)
{
	for (uint32_t i = 0; i < nviews; i++) {
		struct view *v = views[i];
		v->damaged = true;
		if (all || !f->r || w->opts.no_damage || v->frame.full_width) {
			/* Too many to project, no renderer yet, or a
			 * snapshot tile's window (projected as a whole view
			 * it would miss): all of it. */
			memset(v->damage, 1, v->ntiles);
			continue;
		}
		for (uint32_t k = 0; k < na; k++) {
			bc_renderer_damage(f->r, &v->camera, v->width,
			                   v->height, &a[k], v->damage);
		}
		for (uint32_t k = 0; k < nb; k++) {
			struct bc_abv b = bc_lin_abv(l, k0 + k);
			bc_renderer_damage(f->r, &v->camera, v->width,
			                   v->height, &b, v->damage);
		}
	}
}

static void damage_end(struct bc_work *w, const struct flow *f,
                       struct view **views, uint32_t nviews, struct damage *d)
{
	const struct bc_lin *l = bc_tree_lin(f->tree);
	mark_views(w, f, views, nviews, d->old, d->n, l, d->k0, d->n,
	           !d->old || !l);
	bc_free(d->old);
	d->old = NULL;
}

/* A structural batch the renderer follows splice by splice (struct
 * bc_dirty's spliced, bc_renderer_follows): the renderer syncs here (the
 * batch may have handed the scene out in another tree object, and the
 * damage is projected with the scene's new scale), and the views keep
 * their pictures and redraw only the tiles the ABVs that went and the
 * dirty primitives' new ABVs reach. */
static bool damage_spliced(struct bc_work *w, struct flow *f)
{
	const struct bc_lin *l = bc_tree_lin(f->tree);
	struct view *views[BC_SRV_MAX_VIEWS];
	struct bc_dirty d;
	uint32_t nviews, n;
	if (f->fresh || !l ||
	    !bc_renderer_follows(f->r, bc_tree_dirty(f->tree))) {
		return false;
	}
	bc_tree_take_dirty(f->tree, &d);
	if (bc_renderer_sync(f->r, f->tree, &d, NULL)) {
		return false;
	}
	n = d.prim_hi - d.prim_lo;
	nviews = bc__views_of(w, f->sid, views);
	mark_views(w, f, views, nviews, d.gone, d.ngone, l, d.prim_lo, n,
	           n > BC_SRV_DAMAGE_PRIMS);
	for (uint32_t i = 0; i < nviews; i++) {
		bc__view_release(w, views[i]);
	}
	return true;
}

static void apply_states(struct bc_work *w, struct flow *f, const struct upd *u)
{
	struct view *views[BC_SRV_MAX_VIEWS];
	uint32_t nviews = bc__views_of(w, f->sid, views);
	for (uint32_t i = 0; i < u->n; i++) {
		struct damage d;
		damage_begin(f, u->st[i].id, &d);
		bc_edit_saved_restore(f->tree, &u->st[i]);
		damage_end(w, f, views, nviews, &d);
	}
	for (uint32_t i = 0; i < nviews; i++) {
		bc__view_release(w, views[i]);
	}
}

/* After a structural change of the copy: the views follow it tile by
 * tile where the renderer follows its splices, else start over. */
static void structure_changed(struct bc_work *w, struct flow *f)
{
	if (!f->broken && damage_spliced(w, f)) {
		return;
	}
	f->fresh = true;
	f->ms_per_ray = f->ms_abuffer = 0.0;
	f->ray_bound = BC_SRV_RAY_EVALS;
	bc__views_drop(w, f->sid);
}

/* An early batch (bc_work_ops_early) whose verdict has not come:
 * applied, and kept undoable until it does. A failure is not yet an
 * error: the session's own apply of the same operations on the same tree
 * fails alike, unless memory ran out here (the verdict tells). */
static void apply_early(struct bc_work *w, struct flow *f, const struct upd *u)
{
	struct bc_errinfo ei = {0};
	if (f->eb_state != EB_NONE) {
		/* Cannot happen: a session has one early batch at a time,
		 * and a batch's verdict is applied before the next batch. */
		bc_log(BC_LOG_ERROR,
		       "session %u: an early batch came before the verdict on "
		       "the one before",
		       f->sid);
		bc_edit_batch_finish(&f->eb);
	}
	f->eb_order = f->order;
	if (!f->tree || f->broken) {
		f->eb_state = EB_SKIPPED;
		return;
	}
	if (bc_edit_batch_apply(&f->eb, &f->tree, u->ops.ops, u->ops.n, &ei)) {
		bc_log(BC_LOG_DEBUG, "session %u: early batch refused: %s",
		       f->sid, ei.msg);
		f->eb_state = EB_FAILED;
		if (f->eb.lost) {
			/* Refused, and not put back: the copy is no longer
			 * the session's scene. */
			bc_log(BC_LOG_ERROR,
			       "session %u: the render copy lost its scene: "
			       "%s",
			       f->sid, ei.msg);
			f->broken = true;
		}
		return;
	}
	f->eb_state = EB_APPLIED;
	structure_changed(w, f);
}

/* The verdict on the early batch: kept, or undone on the copy. */
static void settle_early(struct bc_work *w, struct flow *f, bool stands)
{
	enum early_state was = f->eb_state;
	f->eb_state = EB_NONE;
	if (was == EB_NONE) {
		return; /* a scene replaced it before it came */
	}
	if (stands) {
		bc_edit_batch_finish(&f->eb);
		if (was == EB_FAILED) {
			bc_log(BC_LOG_ERROR,
			       "session %u: the render copy cannot follow a "
			       "structural edit",
			       f->sid);
			f->broken = true;
		}
		return;
	}
	f->order = f->eb_order;
	if (was == EB_APPLIED) {
		if (bc_edit_batch_undo(&f->eb, &f->tree)) {
			bc_log(BC_LOG_ERROR,
			       "session %u: the render copy cannot take back "
			       "a refused edit (out of memory)",
			       f->sid);
			f->broken = true;
		}
		structure_changed(w, f);
	}
}

/* Frees f's copy of the scene. A big one's renderer buffers, sized for
 * it, go too (the next scene builds everything again anyway), and the
 * memory both held returns to the system: the worker that freed it would
 * keep it resident in its arena. */
static void drop_copy(struct bc_work *w, struct flow *f)
{
	bool big = f->tree && bc_tree_node_count(f->tree) >= BC_SRV_HEAVY_NODES;
	if (big && f->r) {
		bc_renderer_release(f->r);
		bc__flow_kept(w, f);
	}
	bc_tree_destroy(f->tree);
	f->tree = NULL;
	if (big) {
		bc_heap_give_back();
	}
}

static void apply_one(struct bc_work *w, struct flow *f, struct upd *u)
{
	struct bc_errinfo ei = {0};
	struct bc_edit_batch b;
	switch (u->kind) {
	case UPD_SCENE:
		if (!u->tree) {
			/* Nobody looks: the copy and everything drawn from
			 * it go, the renderer too (the next scene lays its
			 * lists out again anyway). */
			bc__flow_clear(w, f);
			f->fresh = true;
			f->broken = false;
			break;
		}
		/* A scene replaces an early batch's copy too. */
		bc_edit_batch_finish(&f->eb);
		f->eb_state = EB_NONE;
		drop_copy(w, f);
		f->tree = u->tree;
		u->tree = NULL;
		f->fresh = true;
		f->broken = false;
		/* Another scene: its cost is unknown, so its first pictures
		 * start at the coarsest level again. */
		f->ms_per_ray = f->ms_abuffer = 0.0;
		f->ray_bound = BC_SRV_RAY_EVALS;
		bc__views_drop(w, f->sid);
		break;
	case UPD_STATES:
		if (f->tree && !f->broken) {
			apply_states(w, f, u);
		}
		break;
	case UPD_OPS:
		if (u->early && u->verdict < 0) {
			return; /* undone before it was taken: never applied */
		}
		if (u->early && !u->verdict) {
			apply_early(w, f, u);
			break;
		}
		if (!f->tree || f->broken) {
			break;
		}
		if (bc_edit_batch_apply(&b, &f->tree, u->ops.ops, u->ops.n,
		                        &ei)) {
			/* The session applied these very operations to the
			 * same tree: only memory can fail here. Frames stop
			 * until a scene comes. */
			bc_log(BC_LOG_ERROR,
			       "session %u: the render copy cannot follow a "
			       "structural edit: %s",
			       f->sid, ei.msg);
			f->broken = true;
		}
		bc_edit_batch_finish(&b);
		structure_changed(w, f);
		break;
	default:
		break;
	}
	f->order = u->order;
}

void bc__flow_apply(struct bc_work *w, struct flow *f, struct upd *list,
                    int settle)
{
	/* The verdict is on a batch taken in an earlier turn (one still
	 * queued carries its own), and every change in the list came after
	 * it. */
	if (settle) {
		settle_early(w, f, settle > 0);
	}
	while (list) {
		struct upd *next = list->next;
		apply_one(w, f, list);
		bc__upd_free(list);
		list = next;
	}
}

void bc__flow_clear(struct bc_work *w, struct flow *f)
{
	bc_edit_batch_finish(&f->eb);
	f->eb_state = EB_NONE;
	bc__views_drop(w, f->sid);
	bc_renderer_destroy(f->r);
	atomic_fetch_sub(&w->kept_bytes, f->kept_bytes);
	f->kept_bytes = 0;
	f->r = NULL;
	drop_copy(w, f);
}
