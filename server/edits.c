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

void bc_handle_scene_load(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_tree *t = bc_tree_create(), *copy = bc_tree_create();
	struct bc_camera cam = s->camera;
	struct bc_errinfo ei = {0};
	bool has_cam = false;
	int rc;
	if (!t || !copy) {
		rc = bc_errinfo_set(&ei, BC_ENOMEM, "out of memory");
		goto fail;
	}
	if (s->store_failed) {
		rc = bc_errinfo_set(&ei, BC_EIO,
		                    "the session cannot be saved: changes are "
		                    "refused");
		goto fail;
	}
	if ((rc = bc_scene_decode(m->scene_load.scene.ptr,
	                          m->scene_load.scene.len, t, &cam, &has_cam,
	                          &ei))) {
		goto fail;
	}
	if (bc_tree_node_count(t) > BC_SRV_MAX_NODES) {
		rc = bc_errinfo_set(&ei, BC_ELIMIT, "more than %u nodes",
		                    BC_SRV_MAX_NODES);
		goto fail;
	}
	if ((rc = check_scene_bytes(t, &ei))) {
		goto fail;
	}
	if ((rc = bc_tree_copy(copy, t, &ei))) {
		goto fail;
	}
	/* On disk first: the load is acknowledged only once it is safe. */
	if ((rc = bc_store_snapshot(s->store, t, &cam, s->order + 1, &ei))) {
		/* Only a failed write locks the session: a scene the store
		 * refuses up front (too big or too deep to restore) left
		 * nothing on disk. */
		if (rc == BC_EIO) {
			s->store_failed = true;
		}
		goto fail;
	}
	bc_tree_destroy(s->tree);
	s->tree = t;
	s->camera = cam;
	s->order++;
	bc_rthread_scene(c->srv, s->id, copy);
	bc_session_send_state(s, NULL, c->member_id, m->seq);
	if (has_cam) {
		for (uint32_t i = 0; i < s->nmembers; i++) {
			struct bc_conn *o = bc_conn_get(c->srv, s->members[i]);
			if (o) {
				o->camera = cam;
			}
		}
	}
	bc_session_mark_all(s);
	bc_session_schedule(s);
	return;
fail:
	bc_tree_destroy(t);
	bc_tree_destroy(copy);
	bc_conn_send_error(c, m->seq, rc, false, "scene not loaded: %s",
	                   ei.msg);
}

void bc_handle_edit(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_srv *srv = c->srv;
	struct bc_errinfo ei = {0};
	struct bc_edit_batch batch = {0};
	struct bc_proto_buf rec;
	struct bc_msg applied = {.type = BC_MSG_EDIT_APPLIED};
	struct bc_msg as_edit = {.type = BC_MSG_EDIT};
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	uint32_t nrefs;
	bool structural;
	uint64_t t0 = uv_hrtime();
	int rc;
	bc_proto_buf_init(&rec, 0);
	if (s->store_failed) {
		rc = bc_errinfo_set(&ei, BC_EIO,
		                    "the session cannot be saved: edits are "
		                    "refused");
		goto fail;
	}
	if ((rc = bc_edit_batch_apply(&batch, &s->tree, m->edit.ops,
	                              m->edit.nops, &ei))) {
		goto fail;
	}
	structural = batch.structural;
	/* A structural edit can grow the scene past what a member's queue
	 * holds: undone like an edit that could not be journaled. */
	if (structural && (rc = check_scene_bytes(s->tree, &ei))) {
		bc_edit_batch_undo(&batch, &s->tree);
		goto fail;
	}
	/* The journal record is the EDIT payload: sync it before anyone
	 * hears of the edit. */
	as_edit.edit = m->edit;
	if ((rc = bc_proto_encode(&rec, &as_edit, &ei)) ||
	    (rc = bc_store_append(s->store, s->order + 1,
	                          rec.data + BC_PROTO_HEADER_SIZE,
	                          rec.len - BC_PROTO_HEADER_SIZE, &ei))) {
		if (rc == BC_EIO) {
			s->store_failed = true;
		}
		/* Not on disk, so not applied: the structural copy goes, or
		 * the parameters are put back. */
		bc_edit_batch_undo(&batch, &s->tree);
		goto fail;
	}
	s->order++;
	{
		double ms = (double)(uv_hrtime() - t0) / 1e6;
		s->edit_ms_avg = s->edit_ms_avg == 0.0
		                     ? ms
		                     : 0.9 * s->edit_ms_avg + 0.1 * ms;
	}
	/* The render thread's replica follows. */
	if (structural) {
		struct bc_tree *copy = bc_tree_create();
		if (copy && bc_tree_copy(copy, s->tree, NULL) == 0) {
			bc_rthread_scene(srv, s->id, copy);
		} else {
			bc_tree_destroy(copy);
		}
	} else {
		for (uint32_t i = 0; i < m->edit.nops; i++) {
			struct bc_prim_data p;
			struct bc_op_data op;
			uint32_t id = m->edit.ops[i].node;
			bc_tree_get(s->tree, id, &p, &op);
			if (op.kind != BC_OP_INVALID) {
				bc_rthread_set_op(srv, s->id, id, &op);
			} else {
				bc_rthread_set_prim(srv, s->id, id, &p);
			}
		}
	}
	applied.flags = m->flags & BC_PROTO_FLAG_INTERACTING;
	applied.edit_applied.order = s->order;
	applied.edit_applied.author = c->member_id;
	applied.edit_applied.author_seq = m->seq;
	applied.edit_applied.nops = m->edit.nops;
	applied.edit_applied.ops = m->edit.ops;
	nrefs = bc_session_members(s, refs);
	for (uint32_t i = 0; i < nrefs; i++) {
		struct bc_conn *o = bc_conn_get(srv, refs[i]);
		if (!o) {
			continue;
		}
		bc_conn_send(o, &applied);
		o->dirty = true;
		if (m->flags & BC_PROTO_FLAG_INTERACTING) {
			o->interacting_until =
			    bc_now_ms(srv) + BC_SRV_STILL_DELAY_MS;
		} else {
			o->interacting_until = 0;
		}
		if (structural) {
			o->shown.view = 0;
		}
	}
	/* Logs its own failures and backs off after one (a full disk). */
	bc_store_snapshot_due(s->store, BC_SRV_SNAPSHOT_EVERY, s->tree,
	                      &s->camera, s->order, &ei);
	bc_edit_batch_finish(&batch);
	bc_proto_buf_finish(&rec);
	bc_session_schedule(s);
	return;
fail:
	bc_edit_batch_finish(&batch);
	bc_proto_buf_finish(&rec);
	bc_conn_send_error(c, m->seq, rc, false, "edit refused: %s", ei.msg);
}
