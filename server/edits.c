/*
 * Changes to a session's scene (loop thread). An EDIT is applied by the
 * edit module as one atomic batch (bc_edit_batch_apply), journaled and
 * synced to disk, and only then broadcast as EDIT_APPLIED to every member
 * -- the author's copy is its acknowledgement; a batch that cannot be
 * journaled is undone. A parameter edit touches only the edited nodes
 * (blobtree keeps the layout); structural edits replace the tree by an
 * edited copy. The render thread's replica follows either way; which tiles
 * an edit damages is decided there (rthread.c), not here.
 */
#include <inttypes.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "server.h"

/* Bytes of the scene encoding (PROTOCOL.md section 8) of one node. */
#define OP_BYTES 17u
#define PRIM_BYTES 35u /* without its colour and parameters */
#define COLOR_BYTES 12u
/* The most a node takes: a primitive with colour and 8 parameters. */
#define NODE_MAX_BYTES (PRIM_BYTES + COLOR_BYTES + 4u * 8u)
/* SCENE_STATE's fields before the scene, the scene's flags, camera and
 * node count. */
#define STATE_FIXED_BYTES (16u + 1u + 40u + 4u)

/* Whether t's SCENE_STATE (the session's camera always included) would pass
 * BC_SRV_MAX_SCENE_BYTES: such a scene could be sent to no member. Counted
 * by a walk over the nodes when the node count alone does not settle it.
 * Returns 0, BC_ELIMIT (with the sizes in ei) or BC_ENOMEM. */
static int check_scene_bytes(const struct bc_tree *t, struct bc_errinfo *ei)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	uint64_t bytes = STATE_FIXED_BYTES;
	uint32_t nodes = bc_tree_node_count(t);
	int rc;
	if (bytes + (uint64_t)nodes * NODE_MAX_BYTES <=
	    BC_SRV_MAX_SCENE_BYTES) {
		return 0;
	}
	if ((rc = bc_scene_walk_init(&w, t))) {
		return bc_errinfo_set(ei, rc, "cannot measure the scene");
	}
	while (bc_scene_walk_next(&w, &n)) {
		if (n.is_op) {
			bytes += OP_BYTES;
		} else {
			bytes += PRIM_BYTES +
			         (n.prim.has_color ? COLOR_BYTES : 0) +
			         4u * bc_scene_prim_nfloats(n.prim.kind);
		}
	}
	bc_scene_walk_finish(&w);
	if (bytes > BC_SRV_MAX_SCENE_BYTES) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "the scene (%u nodes) would take %" PRIu64
		    " bytes to send, over the %u a client's queue holds",
		    nodes, bytes, BC_SRV_MAX_SCENE_BYTES);
	}
	return 0;
}

/* A SCENE_LOAD on its way. prepare() makes everything the load needs --
 * the decoded and checked tree, the render thread's copy, the members'
 * SCENE_STATE bytes and the snapshot on disk -- on the loop, or on a
 * worker thread for a large one (BC_SRV_ASYNC_LOAD_BYTES; the session is
 * `loading` meanwhile, its store used by that thread alone); commit()
 * then applies it on the loop. */
struct load {
	uv_work_t work;
	struct bc_session *s;
	struct bc_conn_ref author;
	uint32_t author_id, seq;
	uint8_t *owned; /* the payload's copy, for a worker */
	struct bc_proto_bytes scene;
	uint64_t order;
	struct bc_tree *t, *copy;
	struct bc_camera cam;
	bool has_cam;
	uint8_t *state;
	size_t state_len;
	int rc;
	struct bc_errinfo ei;
};

static void prepare(struct load *l)
{
	struct bc_errinfo *ei = &l->ei;
	if (!(l->t = bc_tree_create()) || !(l->copy = bc_tree_create())) {
		l->rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		return;
	}
	if ((l->rc = bc_scene_decode(l->scene.ptr, l->scene.len, l->t, &l->cam,
	                             &l->has_cam, ei))) {
		return;
	}
	if (bc_tree_node_count(l->t) > BC_SRV_MAX_NODES) {
		l->rc = bc_errinfo_set(ei, BC_ELIMIT, "more than %u nodes",
		                       BC_SRV_MAX_NODES);
		return;
	}
	if ((l->rc = check_scene_bytes(l->t, ei)) ||
	    (l->rc = bc_tree_copy(l->copy, l->t, ei))) {
		return;
	}
	if ((l->rc =
	         bc_scene_encode(l->t, &l->cam, &l->state, &l->state_len))) {
		bc_errinfo_set(ei, l->rc, "cannot encode the scene");
		return;
	}
	/* On disk before anyone hears of it: the load is acknowledged only
	 * once it is safe. */
	l->rc = bc_store_snapshot(l->s->store, l->t, &l->cam, l->order, ei);
}

static void load_free(struct load *l)
{
	bc_tree_destroy(l->t);
	bc_tree_destroy(l->copy);
	bc_free(l->state);
	bc_free(l->owned);
	bc_free(l);
}

static void commit(struct load *l)
{
	struct bc_session *s = l->s;
	struct bc_srv *srv = s->srv;
	struct bc_conn *author = bc_conn_get(srv, l->author);
	if (l->rc) {
		/* Only a failed write locks the session: a scene the store
		 * refuses up front (too big or too deep to restore) left
		 * nothing on disk. */
		if (l->rc == BC_EIO) {
			s->store_failed = true;
		}
		if (author) {
			bc_conn_send_error(author, l->seq, l->rc, false,
			                   "scene not loaded: %s", l->ei.msg);
		}
		return;
	}
	bc_tree_destroy(s->tree);
	s->tree = l->t;
	l->t = NULL;
	s->camera = l->cam;
	s->order = l->order;
	s->last_edit_ms = bc_unix_ms();
	bc_rthread_scene(srv, s->id, l->copy);
	l->copy = NULL;
	bc_session_send_state_bytes(s, NULL, l->author_id, l->seq, l->state,
	                            l->state_len);
	if (l->has_cam) {
		for (uint32_t i = 0; i < s->nmembers; i++) {
			struct bc_conn *o = bc_conn_get(srv, s->members[i]);
			if (o) {
				o->camera = l->cam;
			}
		}
	}
	/* A new scene: nothing before it can be undone. */
	bc_undo_clear(s);
	bc_session_mark_all(s);
	bc_session_schedule(s);
}

static void prepare_work(uv_work_t *w)
{
	prepare(w->data);
}

static void prepared(uv_work_t *w, int status)
{
	struct load *l = w->data;
	struct bc_session *s = l->s;
	s->loading = false;
	if (status != 0 && l->rc == 0) {
		l->rc =
		    bc_errinfo_set(&l->ei, BC_EIO, "the load was cancelled");
	}
	if (!s->removed) {
		commit(l);
	}
	load_free(l);
	bc_session_unref(s);
}

/* A session whose scene is being replaced by a large load takes no change
 * until it is: refused with EBUSY (the client retries after the load's
 * SCENE_STATE). */
static bool busy(struct bc_conn *c, const struct bc_msg *m)
{
	if (!c->session->loading) {
		return false;
	}
	bc_conn_send_error(c, m->seq, BC_EBUSY, false,
	                   "the session's scene is being replaced by a "
	                   "SCENE_LOAD; retry after its SCENE_STATE");
	return true;
}

void bc_handle_scene_load(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct load *l;
	if (busy(c, m)) {
		return;
	}
	if (s->store_failed) {
		bc_conn_send_error(c, m->seq, BC_EIO, false,
		                   "scene not loaded: the session cannot be "
		                   "saved: changes are refused");
		return;
	}
	if (!(l = bc_calloc(1, sizeof(*l)))) {
		bc_conn_send_error(c, m->seq, BC_ENOMEM, false,
		                   "scene not loaded: out of memory");
		return;
	}
	l->s = s;
	l->author = bc_conn_ref_of(c);
	l->author_id = c->member_id;
	l->seq = m->seq;
	l->scene = m->scene_load.scene;
	l->cam = s->camera;
	l->order = s->order + 1;
	l->work.data = l;
	if (m->scene_load.scene.len >= BC_SRV_ASYNC_LOAD_BYTES) {
		/* The payload lives in the reader's buffer only until the
		 * next message. */
		if (!(l->owned = bc_malloc(l->scene.len))) {
			bc_free(l);
			bc_conn_send_error(c, m->seq, BC_ENOMEM, false,
			                   "scene not loaded: out of memory");
			return;
		}
		memcpy(l->owned, l->scene.ptr, l->scene.len);
		l->scene.ptr = l->owned;
		if (uv_queue_work(c->srv->loop, &l->work, prepare_work,
		                  prepared) == 0) {
			s->loading = true;
			s->handles_open++;
			return;
		}
	}
	prepare(l);
	commit(l);
	load_free(l);
}

int bc_session_apply(struct bc_conn *c, const struct bc_proto_edit_op *ops,
                     uint16_t nops, uint32_t seq, const struct bc_change *how,
                     struct bc_edit_batch *b, struct bc_errinfo *ei)
{
	struct bc_session *s = c->session;
	struct bc_srv *srv = c->srv;
	struct bc_proto_buf rec;
	struct bc_msg applied = {.type = BC_MSG_EDIT_APPLIED};
	struct bc_msg as_edit = {.type = BC_MSG_EDIT};
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	bool interacting = (how->flags & BC_PROTO_FLAG_INTERACTING) != 0;
	uint32_t nrefs;
	uint64_t t0 = bc_clock_ns();
	int rc;
	memset(b, 0, sizeof(*b));
	if (s->store_failed) {
		return bc_errinfo_set(ei, BC_EIO,
		                      "the session cannot be saved: edits are "
		                      "refused");
	}
	if ((rc = bc_edit_batch_apply(b, &s->tree, ops, nops, ei))) {
		return rc;
	}
	/* A structural edit can grow the scene past what a member's queue
	 * holds: undone like an edit that could not be journaled. */
	if (b->structural && (rc = check_scene_bytes(s->tree, ei))) {
		bc_edit_batch_undo(b, &s->tree);
		return rc;
	}
	/* The journal record is the EDIT payload: sync it before anyone
	 * hears of the edit. */
	bc_proto_buf_init(&rec, 0);
	as_edit.edit.nops = nops;
	as_edit.edit.ops = ops;
	if ((rc = bc_proto_encode(&rec, &as_edit, ei)) ||
	    (rc = bc_store_append(s->store, s->order + 1,
	                          rec.data + BC_PROTO_HEADER_SIZE,
	                          rec.len - BC_PROTO_HEADER_SIZE, ei))) {
		if (rc == BC_EIO) {
			s->store_failed = true;
		}
		/* Not on disk, so not applied: the structural copy goes, or
		 * the parameters are put back. */
		bc_edit_batch_undo(b, &s->tree);
		bc_proto_buf_finish(&rec);
		return rc;
	}
	bc_proto_buf_finish(&rec);
	s->order++;
	s->last_edit_ms = bc_unix_ms();
	{
		double ms = (double)(bc_clock_ns() - t0) / 1e6;
		s->edit_ms_avg = s->edit_ms_avg == 0.0
		                     ? ms
		                     : 0.9 * s->edit_ms_avg + 0.1 * ms;
	}
	/* The render thread's replica follows. */
	if (b->structural) {
		struct bc_tree *copy = bc_tree_create();
		if (copy && bc_tree_copy(copy, s->tree, NULL) == 0) {
			bc_rthread_scene(srv, s->id, copy);
		} else {
			bc_tree_destroy(copy);
		}
	} else {
		for (uint32_t i = 0; i < nops; i++) {
			struct bc_prim_data p;
			struct bc_op_data op;
			uint32_t id = ops[i].node;
			bc_tree_get(s->tree, id, &p, &op);
			if (op.kind != BC_OP_INVALID) {
				bc_rthread_set_op(srv, s->id, id, &op);
			} else {
				bc_rthread_set_prim(srv, s->id, id, &p);
			}
		}
	}
	applied.flags = how->flags;
	applied.edit_applied.order = s->order;
	applied.edit_applied.author = c->member_id;
	applied.edit_applied.author_seq = seq;
	applied.edit_applied.nops = nops;
	applied.edit_applied.ops = ops;
	applied.edit_applied.target_order = how->target_order;
	if (how->target_author) {
		applied.edit_applied.target_author.ptr = how->target_author;
		applied.edit_applied.target_author.len =
		    (uint32_t)strlen(how->target_author);
	}
	nrefs = bc_session_members(s, refs);
	for (uint32_t i = 0; i < nrefs; i++) {
		struct bc_conn *o = bc_conn_get(srv, refs[i]);
		if (!o) {
			continue;
		}
		bc_conn_send(o, &applied);
		o->dirty = true;
		o->interacting_until =
		    interacting ? bc_now_ms(srv) + BC_SRV_STILL_DELAY_MS : 0;
		if (b->structural) {
			o->shown.view = 0;
		}
	}
	/* Logs its own failures and backs off after one (a full disk). */
	bc_store_snapshot_due(s->store, BC_SRV_SNAPSHOT_EVERY, s->tree,
	                      &s->camera, s->order, ei);
	bc_session_schedule(s);
	return 0;
}

void bc_handle_edit(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_errinfo ei = {0};
	struct bc_edit_batch batch;
	struct bc_change how = {.flags = m->flags & BC_PROTO_FLAG_INTERACTING};
	int rc;
	if (busy(c, m)) {
		return;
	}
	rc = bc_session_apply(c, m->edit.ops, m->edit.nops, m->seq, &how,
	                      &batch, &ei);
	if (rc) {
		bc_conn_send_error(c, m->seq, rc, false, "edit refused: %s",
		                   ei.msg);
		return;
	}
	/* The history takes what undoes the batch. */
	bc_undo_record(c, &batch, (how.flags & BC_PROTO_FLAG_INTERACTING) != 0);
	bc_edit_batch_finish(&batch);
}

void bc_handle_undo(struct bc_conn *c, const struct bc_msg *m)
{
	if (busy(c, m)) {
		return;
	}
	bc_undo_step(c, m->type == BC_MSG_REDO, m->seq);
}
