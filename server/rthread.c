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
 * picture at the view's level. The views are kept in views.c and what a
 * job renders (a pick, a frame and its encoding) in render_job.c; this file
 * holds the thread, its replicas, its command and result queues.
 *
 * Fairness. Commands of one session run in the order they were sent, but
 * sessions are independent (each has its own replica), so the thread takes
 * them in turns: the oldest command of the next session, round robin on
 * session ids. A session with a backlog of large frames then delays
 * another session's next frame by one job, not by its whole backlog. Jobs
 * of clients that have all disconnected are removed from the queue
 * (bc_rthread_sweep_soon), and each client has at most
 * BC_SRV_MAX_CLIENT_REQUESTS PICKs and SNAPSHOTs queued (frames.c).
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "encode.h"
#include "rthread_impl.h"

struct replica *bc__replica_of(struct bc_rthread *rt, uint32_t id, bool create)
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

static void replica_drop(struct bc_rthread *rt, struct replica *rp)
{
	bc__views_drop(rt, rp->session_id);
	bc_renderer_destroy(rp->r);
	bc_tree_destroy(rp->tree);
	memset(rp, 0, sizeof(*rp));
}

void bc__push_result(struct bc_rthread *rt, struct rresult *res)
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

static void run(struct bc_rthread *rt, struct rcmd *cmd)
{
	struct replica *rp;
	switch (cmd->kind) {
	case RCMD_SCENE:
		rp = bc__replica_of(rt, cmd->session_id, true);
		if (!rp) {
			bc_tree_destroy(cmd->tree);
			break;
		}
		bc_tree_destroy(rp->tree);
		rp->tree = cmd->tree;
		rp->fresh = true;
		bc__views_drop(rt, cmd->session_id);
		break;
	case RCMD_SET_PRIM:
	case RCMD_SET_OP:
		rp = bc__replica_of(rt, cmd->session_id, false);
		if (rp && rp->tree) {
			struct edit_abvs e;
			bc__edit_begin(rp, cmd->id, &e);
			if (cmd->kind == RCMD_SET_PRIM) {
				bc_tree_set_prim(rp->tree, cmd->id, &cmd->p,
				                 NULL);
			} else {
				bc_tree_set_op(rp->tree, cmd->id, &cmd->op,
				               NULL);
			}
			bc__edit_end(rt, rp, &e);
		}
		break;
	case RCMD_DROP:
		rp = bc__replica_of(rt, cmd->session_id, false);
		if (rp) {
			replica_drop(rt, rp);
		}
		break;
	case RCMD_JOB:
		bc__run_job(rt, cmd->job, cmd->res);
		break;
	default:
		break;
	}
}

/* Unlinks cmd, whose predecessor in the queue is prev (NULL: the head).
 * Called with the lock held. */
static void unlink_cmd(struct bc_rthread *rt, struct rcmd *prev,
                       struct rcmd *cmd)
{
	if (prev) {
		prev->next = cmd->next;
	} else {
		rt->head = cmd->next;
	}
	if (rt->tail == cmd) {
		rt->tail = prev;
	}
	cmd->next = NULL;
}

/* The command to run next (see Fairness in the file comment): the oldest
 * of the session whose id follows the last served one, cyclically. Called
 * with the lock held and the queue not empty. */
static struct rcmd *take_cmd(struct bc_rthread *rt)
{
	struct rcmd *next = NULL, *next_prev = NULL;
	struct rcmd *low = NULL, *low_prev = NULL, *prev = NULL;
	for (struct rcmd *c = rt->head; c; prev = c, c = c->next) {
		uint32_t id = c->session_id;
		/* Strict comparisons keep each session's oldest command. */
		if (id > rt->last_session && (!next || id < next->session_id)) {
			next = c;
			next_prev = prev;
		}
		if (!low || id < low->session_id) {
			low = c;
			low_prev = prev;
		}
	}
	if (!next) {
		next = low;
		next_prev = low_prev;
	}
	unlink_cmd(rt, next_prev, next);
	rt->last_session = next->session_id;
	return next;
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
		cmd = take_cmd(rt);
		uv_mutex_unlock(&rt->lock);
		run(rt, cmd);
		bc_free(cmd);
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		replica_drop(rt, &rt->replicas[i]);
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_VIEWS; i++) {
		bc__view_free(&rt->views[i]);
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

static bool has_client(struct bc_srv *srv, const struct bc_rjob *job)
{
	for (uint32_t i = 0; i < job->ntargets; i++) {
		if (bc_conn_get(srv, job->targets[i])) {
			return true;
		}
	}
	return false;
}

static void sweep(uv_timer_t *t)
{
	struct bc_srv *srv = t->data;
	struct bc_rthread *rt = srv->rt;
	struct rcmd *gone = NULL, *prev = NULL, *cmd;
	uint32_t n = 0;
	uv_mutex_lock(&rt->lock);
	for (cmd = rt->head; cmd;) {
		struct rcmd *next = cmd->next;
		if (cmd->kind == RCMD_JOB && !has_client(srv, cmd->job)) {
			unlink_cmd(rt, prev, cmd);
			cmd->next = gone;
			gone = cmd;
			n++;
		} else {
			prev = cmd;
		}
		cmd = next;
	}
	uv_mutex_unlock(&rt->lock);
	while (gone) {
		cmd = gone->next;
		free_job(gone->job);
		bc_free(gone->res);
		bc_free(gone);
		gone = cmd;
	}
	if (n > 0) {
		bc_log(BC_LOG_INFO,
		       "dropped %u queued render job%s of clients that left", n,
		       n == 1 ? "" : "s");
	}
}

void bc_rthread_sweep_soon(struct bc_srv *srv)
{
	if (srv->rt) {
		uv_timer_start(&srv->job_sweep, sweep, 0, 0);
	}
}

void bc_rthread_job(struct bc_srv *srv, struct bc_rjob *job)
{
	struct rcmd *cmd = new_cmd(RCMD_JOB, job->session_id);
	struct rresult *res = bc_calloc(1, sizeof(*res));
	if (!cmd || !res) {
		struct bc_conn *c = bc_conn_get(srv, job->targets[0]);
		bc_log(BC_LOG_ERROR, "out of memory queueing a render job");
		bc_free(cmd);
		bc_free(res);
		if (c && (job->pick || job->snapshot_seq) && c->requests > 0) {
			c->requests--;
		}
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
		if (job->pick || job->snapshot_seq) {
			struct bc_conn *c = bc_conn_get(srv, job->targets[0]);
			if (c && c->requests > 0) {
				c->requests--;
			}
		}
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
				                      job->targets,
				                      job->ntargets);
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
	uv_timer_init(srv->loop, &srv->job_sweep);
	srv->job_sweep.data = srv;
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
	uv_close((uv_handle_t *)&srv->job_sweep, NULL);
	bc_free(rt);
	srv->rt = NULL;
}
