/*
 * The render thread. It owns the renderer (and so the GL context, when the
 * backend is gl) and a replica of every session's scene: the loop thread
 * sends it the same parameter edits it applied (so the replica re-processes
 * nothing either) or a copy after a structural edit. Commands run in the
 * order they were sent, so a frame reflects exactly the edits sent before
 * it. Finished frames are encoded here and handed back through a queue and
 * a uv_async.
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
	struct rcmd *next;
};

struct rresult {
	struct bc_rjob *job;
	struct bc_shared *frame;
	bool hit;
	float position[3], depth;
	uint32_t node;
	double render_ms, encode_ms;
	bool incomplete;
	struct rresult *next;
};

struct replica {
	uint32_t session_id;
	struct bc_tree *tree;
	struct bc_renderer *r;
	bool fresh; /* the renderer has not seen this tree yet */
};

struct bc_rthread {
	struct bc_srv *srv;
	uv_thread_t thread;
	uv_mutex_t lock;
	uv_cond_t cond;
	struct rcmd *head, *tail;
	struct rresult *rhead, *rtail;
	bool quit;
	const struct bc_backend_ops *ops;
	struct bc_render_opts opts;
	struct bc_encoder *enc;
	struct replica replicas[BC_SRV_MAX_SESSIONS];
	struct bc_frame frame;
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

static void replica_drop(struct bc_rthread *rt, struct replica *rp)
{
	if (rp->r) {
		rt->ops->destroy(rp->r);
	}
	bc_tree_destroy(rp->tree);
	memset(rp, 0, sizeof(*rp));
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

static void run_job(struct bc_rthread *rt, struct bc_rjob *job)
{
	struct replica *rp = replica_of(rt, job->session_id, false);
	struct rresult *res = bc_calloc(1, sizeof(*res));
	struct bc_render_stats stats = {0};
	struct bc_errinfo ei = {0};
	struct bc_proto_rect whole, *rects;
	struct bc_encoded *enc = NULL;
	struct bc_msg m = {.type = BC_MSG_FRAME};
	struct bc_proto_buf b;
	uint32_t nrects;
	double t0, t1;
	if (!res) {
		return;
	}
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
	if (!rp->r && rt->ops->create(&rp->r, &rt->opts, &ei)) {
		bc_log(BC_LOG_ERROR, "renderer: %s", ei.msg);
		push_result(rt, res);
		return;
	}
	t0 = now_ms();
	if (rp->fresh) {
		struct bc_dirty ignored;
		bc_tree_take_dirty(rp->tree, &ignored);
		rp->fresh = false;
		if (rt->ops->sync(rp->r, rp->tree, NULL, &ei)) {
			goto fail;
		}
	} else {
		struct bc_dirty dirty;
		bc_tree_take_dirty(rp->tree, &dirty);
		if (dirty.edits && rt->ops->sync(rp->r, rp->tree, &dirty, &ei)) {
			goto fail;
		}
	}
	if (rt->frame.width != job->image_width ||
	    rt->frame.height != job->image_height) {
		bc_frame_finish(&rt->frame);
		if (bc_frame_init(&rt->frame, job->image_width,
				  job->image_height)) {
			bc_errinfo_set(&ei, BC_ENOMEM, "frame allocation");
			goto fail;
		}
	}
	if (rt->ops->render(rp->r, &job->camera, &rt->frame, &stats, &ei)) {
		goto fail;
	}
	t1 = now_ms();
	res->render_ms = t1 - t0;
	whole = (struct bc_proto_rect){0, 0, (uint16_t)job->image_width,
				       (uint16_t)job->image_height, {NULL, 0}};
	rects = job->nrects ? job->rects : &whole;
	nrects = job->nrects ? job->nrects : 1;
	if (!(enc = bc_calloc(nrects, sizeof(*enc)))) {
		goto fail;
	}
	for (uint32_t i = 0; i < nrects; i++) {
		if (bc_encode_rect(rt->enc, rt->frame.rgba, job->image_width,
				   rects[i].x, rects[i].y, rects[i].w,
				   rects[i].h, job->encoding, job->quality,
				   &enc[i])) {
			bc_errinfo_set(&ei, BC_ECODEC, "encoding failed");
			goto fail;
		}
		rects[i].data.ptr = enc[i].data;
		rects[i].data.len = (uint32_t)enc[i].len;
	}
	m.flags = job->flags;
	if (stats.incomplete) {
		m.flags |= BC_PROTO_FLAG_INCOMPLETE;
		res->incomplete = true;
		bc_log(BC_LOG_WARN,
		       "session %u: frame %u cut at the %u ms budget",
		       job->session_id, job->frame_no, BC_SRV_FRAME_BUDGET_MS);
	}
	m.seq = job->snapshot_seq;
	m.frame.frame_no = job->frame_no;
	m.frame.order = job->order;
	m.frame.camera_seq = job->camera_seq;
	m.frame.encoding = (enum bc_proto_encoding)job->encoding;
	m.frame.width = (uint16_t)job->width;
	m.frame.height = (uint16_t)job->height;
	m.frame.image_width = (uint16_t)job->image_width;
	m.frame.image_height = (uint16_t)job->image_height;
	m.frame.nrects = (uint16_t)nrects;
	m.frame.rects = rects;
	bc_proto_buf_init(&b, (size_t)job->max_bytes + BC_PROTO_HEADER_SIZE);
	if (bc_proto_encode(&b, &m, &ei) == 0 &&
	    (res->frame = bc_shared_new(b.len))) {
		memcpy(res->frame->data, b.data, b.len);
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
	if (enc) {
		for (uint32_t i = 0; i < (job->nrects ? job->nrects : 1); i++) {
			bc_free(enc[i].data);
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
		break;
	case RCMD_SET_PRIM:
		rp = replica_of(rt, cmd->session_id, false);
		if (rp && rp->tree) {
			bc_tree_set_prim(rp->tree, cmd->id, &cmd->p, NULL);
		}
		break;
	case RCMD_SET_OP:
		rp = replica_of(rt, cmd->session_id, false);
		if (rp && rp->tree) {
			bc_tree_set_op(rp->tree, cmd->id, &cmd->op, NULL);
		}
		break;
	case RCMD_DROP:
		rp = replica_of(rt, cmd->session_id, false);
		if (rp) {
			replica_drop(rt, rp);
		}
		break;
	case RCMD_JOB:
		run_job(rt, cmd->job);
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
	bc_free(job->rects);
	bc_free(job->targets);
	bc_free(job);
}

void bc_rthread_job(struct bc_srv *srv, struct bc_rjob *job)
{
	struct rcmd *cmd = new_cmd(RCMD_JOB, job->session_id);
	if (!cmd) {
		bc_session_frame_done(srv, job->session_id, job->targets,
				      job->ntargets);
		free_job(job);
		return;
	}
	cmd->job = job;
	push_cmd(srv, cmd);
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
			struct bc_client *c = bc_client_get(srv, job->targets[0]);
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
				bc_client_send(c, &m);
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
			for (uint32_t i = 0; i < job->ntargets && res->frame;
			     i++) {
				struct bc_client *c =
					bc_client_get(srv, job->targets[i]);
				if (c) {
					bc_client_send_frame(c, res->frame);
					/* Nothing to patch with damage: the
					 * next frame is whole. */
					c->has_base = c->has_base &&
						      !res->incomplete;
				}
			}
			if (!job->snapshot_seq) {
				bc_session_frame_done(srv, job->session_id,
						      job->targets, job->ntargets);
			} else if (!res->frame) {
				struct bc_client *c =
					bc_client_get(srv, job->targets[0]);
				if (c) {
					bc_client_send_error(
						c, job->snapshot_seq, BC_ELIMIT,
						false,
						"the snapshot does not fit the "
						"frame size limit");
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
	rt->ops = bc_backend_get(srv->cfg.backend);
	if (!rt->ops) {
		bc_free(rt);
		return bc_errinfo_set(ei, BC_ENOTSUP,
				      "backend %s is not built in",
				      bc_backend_name(srv->cfg.backend));
	}
	rt->opts.gl_platform = srv->cfg.gl_platform;
	rt->opts.budget_ms = BC_SRV_FRAME_BUDGET_MS;
	if (!(rt->enc = bc_encoder_create())) {
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
	bc_frame_finish(&rt->frame);
	bc_encoder_destroy(rt->enc);
	uv_mutex_destroy(&rt->lock);
	uv_cond_destroy(&rt->cond);
	uv_close((uv_handle_t *)&srv->results, NULL);
	bc_free(rt);
	srv->rt = NULL;
}
