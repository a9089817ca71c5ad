/*
 * The scheduler: render workers, the flows they serve, and the queue of
 * finished jobs the loop thread takes through a uv_async.
 *
 * Who runs next. A flow (one per session) is runnable when it has a job or
 * a change for its render copy and no worker holds it. A free worker takes
 * the runnable flow with the smallest key, vruntime + the penalty of the
 * class of its next job: vruntime counts the render milliseconds the flow
 * has used (every session weighs the same), so a session that rendered
 * little goes first and a busy one cannot take more than its share while
 * others wait -- Linux CFS's rule, on render time. A flow that wakes from
 * idle starts at most BC_SRV_WAKE_CREDIT_MS behind the least clock of the
 * others: a quiet session goes first at once, but sleeping does not bank
 * time. The class penalties put stills behind interactive frames and
 * snapshots behind stills across sessions too, without starving them.
 *
 * Slices. The worker runs one slice of the flow's current job (job.c: a
 * few milliseconds of tiles, or of encoding; a whole pass for a renderer
 * whose every call pays a whole frame's setup, gl) and puts the flow
 * back; any job gives way between slices. While the other workers wait for work
 * and no other flow has any, a slice's renderer call uses their cores too
 * (team_of): one session alone gets the whole machine, slice by slice,
 * and is charged for every core it used. A slice that ran long (a new view of a
 * big scene builds its A-buffer in one renderer call) marks its flow, and while
 * one worker is inside such a slice the others do not start another one as long
 * as shorter work waits: one heavy session never holds every worker.
 *
 * Inside a flow, between jobs, the queued changes are applied to the copy
 * (flow.c); jobs run interactive class first, then stills, then snapshots,
 * each to its end, so a frame shows one state of the scene. A job that
 * may give way (job.c's bc__job_yieldable) is ended at a slice boundary
 * when retracted or when changes wait for its session. A structural
 * batch may reach the copy before the session has applied and journaled
 * it (bc_work_ops_early: the two splices then run at once); until its
 * verdict (bc_work_settle) the flow takes no job, and an undone one is
 * undone on the copy before the next.
 *
 * Stopping: the workers leave at their next slice boundary; bc_work_stop
 * waits a bounded time, since a renderer call does not return early.
 */
#include <pthread.h>
#include <sched.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/log.h"
#include "blobcast/render_common.h"
#include "work_impl.h"

static const double class_penalty_ms[JC_COUNT] = {
    [JC_INTERACTIVE] = 0.0,
    [JC_STILL] = BC_SRV_STILL_PENALTY_MS,
    [JC_SNAPSHOT] = BC_SRV_SNAPSHOT_PENALTY_MS,
};

/* ---- flows --------------------------------------------------------------- */

/* The flow of session sid, or NULL; with create, a free slot is taken.
 * Called with the lock held. */
static struct flow *flow_of(struct bc_work *w, uint32_t sid, bool create)
{
	struct flow *free_slot = NULL;
	for (uint32_t i = 0; i < BC_SRV_MAX_FLOWS; i++) {
		struct flow *f = &w->flows[i];
		if (f->sid == sid && !f->dropped) {
			return f;
		}
		if (!free_slot && f->sid == 0) {
			free_slot = f;
		}
	}
	if (!create || !free_slot) {
		return NULL;
	}
	memset(free_slot, 0, sizeof(*free_slot));
	free_slot->sid = sid;
	free_slot->ray_bound = BC_SRV_RAY_EVALS;
	free_slot->vruntime = w->min_vruntime;
	return free_slot;
}

static bool has_jobs(const struct flow *f)
{
	for (int c = 0; c < JC_COUNT; c++) {
		if (f->qhead[c]) {
			return true;
		}
	}
	return false;
}

static bool has_work(const struct flow *f)
{
	return f->sid && (f->dropped || f->cur || f->uhead || f->settle ||
	                  (!f->early && has_jobs(f)));
}

/* The class of the next slice f would run. */
static enum job_class next_class(const struct flow *f)
{
	if (f->cur) {
		return f->cur->cls;
	}
	for (int c = 0; c < JC_COUNT; c++) {
		if (f->qhead[c]) {
			return (enum job_class)c;
		}
	}
	return JC_INTERACTIVE; /* changes only: cheap, and others wait */
}

void bc__work_wake(struct bc_work *w, struct flow *f)
{
	double floor = w->min_vruntime - BC_SRV_WAKE_CREDIT_MS;
	if (!has_work(f) && f->vruntime < floor) {
		f->vruntime = floor;
	}
}

/* Whether f's next slice will likely run long: its last one did, or it
 * starts a job and the first slices of its jobs run long (a new view's
 * A-buffer of a big scene). */
static bool runs_long(const struct flow *f)
{
	return f->long_ms > 0.0 ||
	       (!f->cur && f->first_ms >= BC_SRV_LONG_SLICE_MS);
}

/* The runnable flow to serve next, or NULL. Called with the lock held. A
 * worker is kept for short work while the others run long slices, when
 * short work waits or came within BC_SRV_SHORT_RECENT_MS: a quiet
 * session's next frame must not wait behind two heavy ones. */
static struct flow *pick(struct bc_work *w, const struct flow *prev, double now)
{
	struct flow *best = NULL, *best_short = NULL;
	double key = 0.0, key_short = 0.0, least = -1.0;
	for (uint32_t i = 0; i < BC_SRV_MAX_FLOWS; i++) {
		struct flow *f = &w->flows[i];
		double k;
		if (!has_work(f) || f->held) {
			continue;
		}
		if (f->dropped) {
			return f; /* freeing it is quick */
		}
		if (least < 0.0 || f->vruntime < least) {
			least = f->vruntime;
		}
		k = f->vruntime + class_penalty_ms[next_class(f)];
		if (f == prev && f->cur) {
			/* Its job goes on unless another is well behind. */
			k -= BC_SRV_GRANULARITY_MS;
		}
		if (!best || k < key) {
			best = f;
			key = k;
		}
		if (!runs_long(f) && (!best_short || k < key_short)) {
			best_short = f;
			key_short = k;
		}
	}
	if (least > w->min_vruntime) {
		w->min_vruntime = least;
	}
	if (best_short) {
		w->short_seen_ms = now;
	}
	if (best && runs_long(best) && w->nworkers > 1 &&
	    w->long_slices + 1 >= w->nworkers &&
	    (best_short || now - w->short_seen_ms < BC_SRV_SHORT_RECENT_MS)) {
		return best_short;
	}
	return best;
}

/* Takes the next job of f (interactive first). Called with the lock held. */
static struct bc_job *pop_job(struct bc_work *w, struct flow *f)
{
	for (int c = 0; c < JC_COUNT; c++) {
		struct bc_job *j = f->qhead[c];
		if (!j) {
			continue;
		}
		f->qhead[c] = j->next;
		if (!j->next) {
			f->qtail[c] = NULL;
		} else {
			j->next->prev = NULL;
		}
		j->prev = j->next = NULL;
		j->running = true;
		w->queued--;
		w->running++;
		return j;
	}
	return NULL;
}

/* Hands a finished job to the loop. Called with the lock held. */
static void push_result(struct bc_work *w, struct bc_job *j)
{
	j->next = NULL;
	if (w->rtail) {
		w->rtail->next = j;
	} else {
		w->rhead = j;
	}
	w->rtail = j;
	uv_async_send(&w->results);
}

/* ---- workers ------------------------------------------------------------- */

/* What one turn of a worker does with the flow it holds: changes between
 * jobs, or a slice of the current job. Runs without the lock. Returns
 * true when the job is over. */
static bool run_turn(struct bc_work *w, struct worker *wk, struct flow *f,
                     struct upd *changes, int settle, struct bc_job *job,
                     enum bc_work_outcome stop)
{
	if (changes || settle) {
		bc__flow_apply(w, f, changes, settle);
	}
	if (!job) {
		return false;
	}
	if (stop != BC_WORK_DONE) {
		bc__job_end(w, job, stop);
		return true;
	}
	return bc__job_slice(w, wk, f, job);
}

/* Takes f's changes (and the verdict on an early batch) when it is
 * between jobs, and its job to run: none while an early batch waits for
 * its verdict. Called with the lock held; *stop (not BC_WORK_DONE) tells
 * to end the job now: cancelled, or giving way where it may. */
static struct bc_job *take_turn(struct bc_work *w, struct flow *f,
                                struct upd **changes, int *settle,
                                enum bc_work_outcome *stop)
{
	*changes = NULL;
	*settle = 0;
	*stop = BC_WORK_DONE;
	if (f->cur) {
		if (f->cur->cancelled) {
			*stop = BC_WORK_DROPPED;
		} else if ((f->cur->retracted || f->uhead) &&
		           bc__job_yieldable(f->cur)) {
			*stop = BC_WORK_NOTHING;
		}
		return f->cur;
	}
	*changes = f->uhead;
	f->uhead = f->utail = NULL;
	f->ubytes = 0;
	*settle = f->settle;
	f->settle = 0;
	f->cur = f->early ? NULL : pop_job(w, f);
	return f->cur;
}

/* Frees a dropped flow: its jobs go back as DROPPED. Called with the lock
 * held and the flow held. */
static void drop_flow(struct bc_work *w, struct flow *f)
{
	struct bc_job *j;
	if (f->cur) {
		bc__job_end(w, f->cur, BC_WORK_DROPPED);
		w->running--;
		push_result(w, f->cur);
		f->cur = NULL;
	}
	while ((j = pop_job(w, f))) {
		bc__job_end(w, j, BC_WORK_DROPPED);
		w->running--;
		push_result(w, j);
	}
	while (f->uhead) {
		struct upd *u = f->uhead;
		f->uhead = u->next;
		bc__upd_free(u);
	}
	uv_mutex_unlock(&w->lock);
	bc__flow_clear(w, f);
	uv_mutex_lock(&w->lock);
	memset(f, 0, sizeof(*f));
}

/* The render threads the next slice may use: while every other worker
 * waits and no other flow has work, the cores they would use are free,
 * and one session's frames come as fast as the machine allows (a worker
 * woken meanwhile shares a core for the rest of the slice, a few
 * milliseconds). Called with the lock held, the slice's flow held. */
static uint32_t team_of(const struct bc_work *w)
{
	if (w->waiting + 1u < w->nworkers) {
		return 1u;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_FLOWS; i++) {
		const struct flow *f = &w->flows[i];
		if (has_work(f) && !f->held) {
			return 1u;
		}
	}
	return w->nworkers;
}

/* Workers render as SCHED_BATCH: the same share of the CPU as any thread
 * (niced ones lost their cores to clients on the same host), but a thread
 * that wakes (the loop, with a PING to answer) runs at once instead of
 * after their time slice: with plain SCHED_OTHER workers the loop waited
 * up to 30 ms for a core. Threads a worker starts (the renderers' pool)
 * inherit it. */
static void batch_policy(uint32_t index)
{
#ifdef SCHED_BATCH
	struct sched_param p = {.sched_priority = 0};
	if (pthread_setschedparam(pthread_self(), SCHED_BATCH, &p) != 0) {
		bc_log(BC_LOG_DEBUG, "render worker %u keeps its policy",
		       index);
	}
#else
	(void)index;
#endif
}

static void worker_main(void *arg)
{
	struct worker *wk = arg;
	struct bc_work *w = wk->w;
	batch_policy(wk->index);
	uv_mutex_lock(&w->lock);
	while (!w->quit) {
		struct flow *f = pick(w, wk->prev, bc_clock_ms());
		struct upd *changes;
		struct bc_job *job;
		enum bc_work_outcome stop;
		int settle;
		bool over, was_long, first;
		double t0, ms;
		if (!f) {
			w->waiting++;
			uv_cond_wait(&w->cond, &w->lock);
			w->waiting--;
			continue;
		}
		f->held = true;
		if (f->dropped) {
			drop_flow(w, f);
			wk->prev = NULL;
			continue;
		}
		first = !f->cur;
		job = take_turn(w, f, &changes, &settle, &stop);
		was_long = runs_long(f);
		w->long_slices += was_long ? 1u : 0u;
		wk->team = team_of(w);
		wk->in_slice = true;
		uv_mutex_unlock(&w->lock);
		t0 = bc_clock_ms();
		over = run_turn(w, wk, f, changes, settle, job, stop);
		ms = bc_clock_ms() - t0;
		uv_mutex_lock(&w->lock);
		wk->in_slice = false;
		w->long_slices -= was_long ? 1u : 0u;
		/* A slice is charged for every core it used. */
		f->vruntime += ms * (double)wk->team;
		f->render_us += (uint64_t)(ms * (double)wk->team * 1000.0);
		f->long_ms = ms >= BC_SRV_LONG_SLICE_MS ? ms : 0.0;
		if (first && job) {
			f->first_ms = 0.7 * f->first_ms + 0.3 * ms;
		}
		f->held = false;
		wk->prev = f;
		if (over) {
			f->cur = NULL;
			w->running--;
			push_result(w, job);
		}
		/* Another worker may take what this one leaves. */
		uv_cond_signal(&w->cond);
	}
	uv_mutex_unlock(&w->lock);
}

/* ---- results, on the loop thread ----------------------------------------- */

static void deliver(uv_async_t *async)
{
	struct bc_work *w = async->data;
	struct bc_job *j;
	uv_mutex_lock(&w->lock);
	j = w->rhead;
	w->rhead = w->rtail = NULL;
	uv_mutex_unlock(&w->lock);
	while (j) {
		struct bc_job *next = j->next;
		j->done.job = j;
		j->done.req = &j->req;
		w->opts.done(w->opts.ud, &j->done);
		bc__job_free(j);
		j = next;
	}
}

/* ---- the loop's calls ---------------------------------------------------- */

int bc__work_queue(struct bc_work *w, uint32_t sid, struct upd *u)
{
	bool scene = u->kind == UPD_SCENE && u->tree;
	struct flow *f;
	uv_mutex_lock(&w->lock);
	if (!(f = flow_of(w, sid, scene))) {
		/* Without a flow there is no copy to follow or drop (its
		 * session's scene never came); only a scene makes one. */
		uv_mutex_unlock(&w->lock);
		bc__upd_free(u);
		return scene ? BC_ELIMIT : 0;
	}
	if (u->kind != UPD_SCENE &&
	    (f->ubytes + u->bytes > BC_SRV_FLOW_CHANGE_BYTES ||
	     (u->early && f->early))) {
		uv_mutex_unlock(&w->lock);
		bc__upd_free(u);
		return BC_ELIMIT;
	}
	bc__work_wake(w, f);
	if (u->kind == UPD_SCENE) {
		/* A new scene makes what was queued before it moot. */
		while (f->uhead) {
			struct upd *old = f->uhead;
			f->uhead = old->next;
			bc__upd_free(old);
		}
		f->utail = NULL;
		f->ubytes = 0;
	}
	if (f->utail) {
		f->utail->next = u;
	} else {
		f->uhead = u;
	}
	f->utail = u;
	f->ubytes += u->bytes;
	f->early = f->early || u->early;
	uv_cond_signal(&w->cond);
	uv_mutex_unlock(&w->lock);
	return 0;
}

void bc_work_scene(struct bc_work *w, uint32_t sid, struct bc_tree *t,
                   uint64_t order)
{
	struct upd *u = bc_calloc(1, sizeof(*u));
	if (!u) {
		bc_log(BC_LOG_ERROR,
		       "session %u: no memory for its render copy", sid);
		bc_tree_destroy(t);
		return;
	}
	u->kind = UPD_SCENE;
	u->tree = t;
	u->order = order;
	u->bytes = t ? (size_t)bc_tree_node_count(t) * BC_SRV_NODE_BYTES : 0;
	if (bc__work_queue(w, sid, u)) {
		bc_log(BC_LOG_ERROR, "session %u: no render slot", sid);
	}
}

void bc_work_settle(struct bc_work *w, uint32_t sid, bool stands)
{
	struct flow *f;
	struct upd *u;
	uv_mutex_lock(&w->lock);
	if ((f = flow_of(w, sid, false)) && f->early) {
		f->early = false;
		/* Still queued: the verdict goes with the batch (an undone
		 * one is then never applied). Else a worker took it, and
		 * holds it until its next turn between jobs. */
		for (u = f->uhead; u && !(u->early && !u->verdict);
		     u = u->next) {
		}
		if (u) {
			u->verdict = stands ? 1 : -1;
		} else {
			f->settle = stands ? 1 : -1;
		}
		uv_cond_signal(&w->cond);
	}
	uv_mutex_unlock(&w->lock);
}

void bc_work_drop(struct bc_work *w, uint32_t sid)
{
	struct flow *f;
	uv_mutex_lock(&w->lock);
	if ((f = flow_of(w, sid, false))) {
		f->dropped = true;
		uv_cond_signal(&w->cond);
	}
	uv_mutex_unlock(&w->lock);
}

static enum job_class class_of(const struct bc_job_req *req)
{
	switch (req->kind) {
	case BC_JOB_SNAPSHOT:
		return JC_SNAPSHOT;
	case BC_JOB_FRAME:
		return req->final ? JC_STILL : JC_INTERACTIVE;
	default:
		return JC_INTERACTIVE;
	}
}

struct bc_job *bc_work_submit(struct bc_work *w, const struct bc_job_req *req)
{
	struct bc_job *j = bc_calloc(1, sizeof(*j));
	struct flow *f;
	if (!j) {
		return NULL;
	}
	j->req = *req;
	for (uint32_t i = 0; i < req->ntargets; i++) {
		if (req->video[i]) {
			bc_vstream_ref(req->video[i]);
		}
	}
	j->cls = class_of(req);
	j->submitted_ms = bc_clock_ms();
	uv_mutex_lock(&w->lock);
	if (!(f = flow_of(w, req->session_id, true))) {
		uv_mutex_unlock(&w->lock);
		bc_free(j);
		return NULL;
	}
	bc__work_wake(w, f);
	j->flow = f;
	j->prev = f->qtail[j->cls];
	if (f->qtail[j->cls]) {
		f->qtail[j->cls]->next = j;
	} else {
		f->qhead[j->cls] = j;
	}
	f->qtail[j->cls] = j;
	w->queued++;
	uv_cond_signal(&w->cond);
	uv_mutex_unlock(&w->lock);
	return j;
}

/* Marks a running job (returns false), or takes a queued one out of its
 * flow and frees it (true). */
static bool take_back(struct bc_work *w, struct bc_job *j, bool cancel)
{
	struct flow *f = j->flow;
	uv_mutex_lock(&w->lock);
	if (j->running) {
		j->retracted = true;
		j->cancelled = j->cancelled || cancel;
		uv_mutex_unlock(&w->lock);
		return false;
	}
	if (j->prev) {
		j->prev->next = j->next;
	} else {
		f->qhead[j->cls] = j->next;
	}
	if (j->next) {
		j->next->prev = j->prev;
	} else {
		f->qtail[j->cls] = j->prev;
	}
	w->queued--;
	uv_mutex_unlock(&w->lock);
	bc__job_free(j);
	return true;
}

bool bc_work_retract(struct bc_work *w, struct bc_job *j)
{
	return take_back(w, j, false);
}

bool bc_work_cancel(struct bc_work *w, struct bc_job *j)
{
	return take_back(w, j, true);
}

bool bc_work_queued(struct bc_work *w, const struct bc_job *j)
{
	bool queued;
	uv_mutex_lock(&w->lock);
	queued = !j->running;
	uv_mutex_unlock(&w->lock);
	return queued;
}

void bc_work_stats(struct bc_work *w, struct bc_work_stats *out)
{
	memset(out, 0, sizeof(*out));
	uv_mutex_lock(&w->lock);
	out->workers = w->nworkers;
	out->queued = w->queued;
	out->running = w->running;
	uv_mutex_unlock(&w->lock);
	out->view_bytes = bc__views_bytes(w);
	out->view_cap = w->views.cap;
}

uint64_t bc_work_session_us(struct bc_work *w, uint32_t sid)
{
	struct flow *f;
	uint64_t us = 0;
	uv_mutex_lock(&w->lock);
	if ((f = flow_of(w, sid, false))) {
		us = f->render_us;
	}
	uv_mutex_unlock(&w->lock);
	return us;
}

/* ---- renderer memory ----------------------------------------------------- */

size_t bc__work_kept_bytes(struct bc_work *w)
{
	return atomic_load(&w->kept_bytes);
}

void bc__flow_kept(struct bc_work *w, struct flow *f)
{
	size_t now = f->r ? bc_renderer_kept_bytes(f->r) : 0;
	if (now >= f->kept_bytes) {
		atomic_fetch_add(&w->kept_bytes, now - f->kept_bytes);
	} else {
		atomic_fetch_sub(&w->kept_bytes, f->kept_bytes - now);
	}
	f->kept_bytes = now;
}

void bc__work_trim(struct bc_work *w)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_FLOWS; i++) {
		struct flow *f = &w->flows[i];
		uv_mutex_lock(&w->lock);
		if (!f->sid || f->held || f->dropped || !f->r ||
		    f->kept_bytes == 0) {
			uv_mutex_unlock(&w->lock);
			continue;
		}
		/* Held, so no worker picks it while its renderer shrinks. */
		f->held = true;
		uv_mutex_unlock(&w->lock);
		bc_renderer_release(f->r);
		bc__flow_kept(w, f);
		uv_mutex_lock(&w->lock);
		f->held = false;
		uv_cond_signal(&w->cond);
		uv_mutex_unlock(&w->lock);
	}
}

/* ---- start and stop ------------------------------------------------------ */

static int start_workers(struct bc_work *w, struct bc_errinfo *ei)
{
	for (uint32_t i = 0; i < w->nworkers; i++) {
		struct worker *wk = &w->workers[i];
		wk->w = w;
		wk->index = i;
		if (!(wk->enc = bc_encoder_create()) ||
		    !(wk->rects =
		          bc_calloc(BC_PROTO_MAX_RECTS, sizeof(*wk->rects)))) {
			return bc_errinfo_set(
			    ei, BC_ENOMEM, "no memory for render worker %u", i);
		}
		if (uv_thread_create(&wk->thread, worker_main, wk) != 0) {
			return bc_errinfo_set(
			    ei, BC_EIO, "cannot start render worker %u", i);
		}
		wk->started = true;
	}
	return 0;
}

int bc_work_start(struct bc_work **out, const struct bc_work_opts *opts,
                  struct bc_errinfo *ei)
{
	struct bc_work *w;
	int rc;
	*out = NULL;
	if (!bc_backend_available(opts->backend)) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "backend %s is not built in",
		                      bc_backend_name(opts->backend));
	}
	if (!(w = bc_calloc(1, sizeof(*w)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	w->loop = opts->loop;
	w->opts = *opts;
	w->nworkers = opts->workers ? opts->workers : bc_pool_default_threads();
	if (w->nworkers > BC_SRV_MAX_WORKERS) {
		w->nworkers = BC_SRV_MAX_WORKERS;
	}
	w->budget_ms =
	    opts->budget_ms ? opts->budget_ms : BC_SRV_FRAME_BUDGET_MS;
	/* A renderer has a thread per worker; each slice says how many it
	 * may use (team_of). */
	w->ropts.threads = w->nworkers;
	w->ropts.gl_platform = opts->gl_platform;
	w->ropts.simd = opts->simd;
	if (uv_mutex_init(&w->lock) || uv_cond_init(&w->cond)) {
		bc_free(w);
		return bc_errinfo_set(ei, BC_EIO, "cannot make a lock");
	}
	if ((rc = bc__views_init(&w->views, opts->view_cap
	                                        ? opts->view_cap
	                                        : BC_SRV_VIEW_BYTES))) {
		uv_mutex_destroy(&w->lock);
		uv_cond_destroy(&w->cond);
		bc_free(w);
		return bc_errinfo_set(ei, rc, "cannot make the view cache");
	}
	uv_async_init(w->loop, &w->results, deliver);
	w->results.data = w;
	*out = w;
	if (!(w->workers = bc_calloc(w->nworkers, sizeof(*w->workers)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	if ((rc = start_workers(w, ei))) {
		return rc;
	}
	bc_log(BC_LOG_INFO, "%u render worker%s, backend %s", w->nworkers,
	       w->nworkers == 1 ? "" : "s", bc_backend_name(opts->backend));
	return 0;
}

/* Whether every started worker has left its loop, waiting up to wait_ms. */
static bool workers_left(struct bc_work *w, uint32_t wait_ms)
{
	double end = bc_clock_ms() + wait_ms;
	for (;;) {
		bool busy = false;
		uv_mutex_lock(&w->lock);
		for (uint32_t i = 0; i < w->nworkers; i++) {
			busy = busy || w->workers[i].in_slice;
		}
		uv_mutex_unlock(&w->lock);
		if (!busy) {
			return true;
		}
		if (bc_clock_ms() >= end) {
			return false;
		}
		uv_sleep(5);
	}
}

/* The results handle is part of w: w goes once the loop has closed it. */
static void results_closed(uv_handle_t *h)
{
	bc_free(h->data);
}

/* Frees everything once no worker runs, w itself when the loop has closed
 * its results handle. Called with the lock held; it is released and
 * destroyed. */
static void free_all(struct bc_work *w)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_FLOWS; i++) {
		struct flow *f = &w->flows[i];
		if (f->sid) {
			f->dropped = true;
			f->held = true;
			drop_flow(w, f);
		}
	}
	while (w->rhead) {
		struct bc_job *j = w->rhead;
		w->rhead = j->next;
		bc__job_free(j);
	}
	for (uint32_t i = 0; i < w->nworkers; i++) {
		struct worker *wk = &w->workers[i];
		bc_encoder_destroy(wk->enc);
		bc_free(wk->rects);
		bc_free(wk->mask);
		bc_free(wk->shorts);
		bc_free(wk->small);
		bc_free(wk->seen);
	}
	uv_mutex_unlock(&w->lock);
	bc__views_finish(&w->views);
	uv_mutex_destroy(&w->lock);
	uv_cond_destroy(&w->cond);
	bc_free(w->workers);
	uv_close((uv_handle_t *)&w->results, results_closed);
}

bool bc_work_stop(struct bc_work *w, uint32_t wait_ms)
{
	if (!w) {
		return true;
	}
	uv_mutex_lock(&w->lock);
	w->quit = true;
	uv_cond_broadcast(&w->cond);
	uv_mutex_unlock(&w->lock);
	if (!w->workers || !workers_left(w, wait_ms)) {
		/* The caller ends the process: a worker may still post to
		 * the results handle, so it stays open. */
		bc_log(BC_LOG_WARN, "a render worker is still inside a "
		                    "slice; not waiting for it");
		return false;
	}
	for (uint32_t i = 0; i < w->nworkers; i++) {
		if (w->workers[i].started) {
			uv_thread_join(&w->workers[i].thread);
		}
	}
	uv_mutex_lock(&w->lock);
	free_all(w);
	return true;
}
