/*
 * Changes to a session's scene (loop thread). An EDIT is applied by the
 * edit module as one atomic batch (bc_edit_batch_apply), journaled and
 * synced to disk, and only then broadcast as EDIT_APPLIED to every member
 * -- the author's copy is its acknowledgement; a batch that cannot be
 * journaled is undone. A parameter edit touches only the edited nodes
 * (blobtree keeps the layout); a structural edit builds an edited copy,
 * on a task for a big scene (BC_SRV_HEAVY_NODES), the session busy and
 * its later changes parked meanwhile. The work layer's copy follows with
 * the nodes' new states or the batch's operations; which tiles an edit
 * damages is decided there (flow.c), not here. Also SCENE_LOAD (a large
 * one prepared on a task) and UNDO/REDO's entry point.
 */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

/* Bytes of the scene encoding (PROTOCOL.md section 8) of one node. */
#define OP_BYTES 17u
#define PRIM_BYTES 35u /* without its colour and parameters */
#define COLOR_BYTES 12u
/* SCENE_STATE's fields before the scene, the scene's flags, camera and
 * node count. */
#define STATE_FIXED_BYTES (16u + BC_SCENE_HEAD_MAX_BYTES)

/* Whether t's SCENE_STATE (the session's camera always included) would pass
 * cap bytes (the daemon's --max-scene): such a scene could be sent to no
 * member. Counted from the tree's counts in O(1) (a walk over a million
 * nodes took longer than the edit it checked). Returns 0 or BC_ELIMIT
 * (with the sizes in ei). */
static int check_scene_bytes(const struct bc_tree *t, size_t cap,
                             struct bc_errinfo *ei)
{
	uint32_t nodes = bc_tree_node_count(t), prims = bc_tree_prim_count(t);
	uint32_t colored = 0;
	uint64_t floats = 0, bytes;
	bc_tree_counts(t, &colored, &floats);
	bytes = STATE_FIXED_BYTES + (uint64_t)(nodes - prims) * OP_BYTES +
	        (uint64_t)prims * PRIM_BYTES + (uint64_t)colored * COLOR_BYTES +
	        4u * floats;
	if (bytes > cap) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "the scene (%u nodes) would take %" PRIu64
		    " bytes to send, over this server's %zu (--max-scene)",
		    nodes, bytes, cap);
	}
	return 0;
}

/* The nodes of node id's subtree in t (the root's: all of them). */
static uint64_t subtree_nodes(const struct bc_tree *t, uint32_t id)
{
	struct bc_scene_walk w = {0};
	struct bc_scene_node n;
	uint64_t k = 0;
	if (id == bc_tree_root(t)) {
		return bc_tree_node_count(t);
	}
	if (bc_scene_walk_init_at(&w, t, id)) {
		return 0;
	}
	while (bc_scene_walk_next(&w, &n)) {
		k++;
	}
	bc_scene_walk_finish(&w);
	return k;
}

static int cmp_id(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return x < y ? -1 : x > y;
}

/* At least how many of t's nodes ops take away, never more than they do:
 * each REMOVE's or REPLACE's target that is in t and not inside another
 * target (whose subtree holds it) counts its subtree in t. A subtree an
 * earlier operation moved out of a target (a REMOVE and an INSERT of the
 * same ids, as `blobcast move` sends) comes back in that INSERT's count;
 * a target the batch made itself is not in t; an operator a REMOVE leaves
 * with one child goes too, uncounted. */
static uint64_t nodes_taken(const struct bc_tree *t,
                            const struct bc_proto_edit_op *op, uint32_t nops)
{
	uint32_t ids[BC_PROTO_MAX_EDIT_OPS], k = 0, kept = 0;
	uint64_t n = 0;
	for (uint32_t i = 0; i < nops && i < BC_PROTO_MAX_EDIT_OPS; i++) {
		if ((op[i].kind == BC_PROTO_EDIT_REMOVE ||
		     op[i].kind == BC_PROTO_EDIT_REPLACE) &&
		    bc_tree_get(t, op[i].node, NULL, NULL)) {
			ids[k++] = op[i].node;
		}
	}
	qsort(ids, k, sizeof(ids[0]), cmp_id);
	for (uint32_t i = 0; i < k; i++) {
		if (kept == 0 || ids[i] != ids[kept - 1]) {
			ids[kept++] = ids[i];
		}
	}
	for (uint32_t i = 0; i < kept; i++) {
		bool inner = false;
		for (uint32_t p = bc_tree_parent(t, ids[i]); p && !inner;
		     p = bc_tree_parent(t, p)) {
			inner = bsearch(&p, ids, kept, sizeof(ids[0]), cmp_id);
		}
		n += inner ? 0 : subtree_nodes(t, ids[i]);
	}
	return n;
}

/* At most how many nodes a session's scene has after ops: those it has,
 * with every subtree they insert and less those they take away
 * (nodes_taken; a REPLACE of the root by a union holding it, as `blobcast
 * wrap` sends, adds two nodes, not the scene's count). Room is taken for
 * that before the batch applies (bc__room_take) and settled at the count
 * after. */
static uint64_t nodes_after(const struct bc_tree *t,
                            const struct bc_proto_edit_op *op, uint32_t nops)
{
	uint64_t n = bc_tree_node_count(t), added = 0, taken;
	for (uint32_t i = 0; i < nops; i++) {
		const struct bc_proto_bytes *b = &op[i].subtree;
		if (op[i].kind == BC_PROTO_EDIT_INSERT ||
		    op[i].kind == BC_PROTO_EDIT_REPLACE) {
			added += bc_scene_head_count(b->ptr, b->len, b->len);
		}
	}
	/* Only a batch that adds nodes takes room: one that adds none
	 * is not worth a walk of what it removes. */
	taken = added ? nodes_taken(t, op, nops) : 0;
	return n + added - (taken < n ? taken : n);
}

/* m's change needs the room that session w's work keeps back
 * (bc__room_busy): the request waits behind that work and comes again
 * when it ends. */
static int wait_for_room(struct bc_member *m, struct bc_session *w,
                         uint32_t seq, const char *what)
{
	bc_log(BC_LOG_INFO,
	       "session %s: %s waits for the room session %s holds until "
	       "its work ends",
	       m->session->name, what, w->name);
	return bc__park(w, m, seq);
}

int bc__change_waits(struct bc_member *m, const struct bc_proto_edit_op *ops,
                     uint32_t nops, uint32_t seq, const char *what)
{
	struct bc_session *s = m->session, *w;
	/* Most of the time nothing is finishing: the change's count (a
	 * walk of what it removes) is left to bc__apply. */
	if (!s->tree || s->lost || !bc__room_finishing(s) ||
	    !(w = bc__room_busy(s, nodes_after(s->tree, ops, nops)))) {
		return 0;
	}
	return wait_for_room(m, w, seq, what);
}

bool bc__refuse_change(struct bc_member *m, uint32_t seq, int *park)
{
	struct bc_session *s = m->session;
	*park = 0;
	if (s->busy || s->park_head) {
		/* Behind the work running for the session, and behind those
		 * already waiting for it: changes keep their order. */
		*park = bc__park(s, m, seq);
		return true;
	}
	if (s->store_failed) {
		bc__send_error(m, seq, BC_EIO,
		               "the session cannot be saved: changes are "
		               "refused");
		return true;
	}
	return false;
}

/* The session's tree is not what its journal holds (struct bc_session's
 * lost). */
static void lose(struct bc_session *s)
{
	if (!s->lost) {
		s->lost = true;
		bc_log(
		    BC_LOG_ERROR,
		    "session %s: out of memory taking back a refused change; "
		    "its scene no longer matches its journal: changes and "
		    "joins are refused until its members have left (it "
		    "then loads again from what it saved) or a scene is "
		    "loaded",
		    s->name);
	}
}

/* ---- one batch ------------------------------------------------------------- */

/* A batch on its way. It is applied to a tree (the session's, in place,
 * for parameters; an edited copy for structure: on the loop, or on the
 * task for a big scene), checked, encoded as its journal record, then
 * appended and synced on the task -- a disk's sync takes milliseconds
 * under load, which the loop must not wait for -- and only then committed
 * on the loop. The session is busy throughout: its next changes park. */
struct batch {
	struct bc_task t;
	struct bc_session *s;
	struct bc_ops_copy ops; /* the message is gone by the task's end */
	const struct bc_proto_edit_op *op;
	uint32_t nops;
	bool heavy; /* applied on the task */
	/* Its operations went to the render copy before the session's own
	 * apply (bc_work_ops_early), which then waits for the verdict. */
	bool early;
	bool settled;
	/* Only NAME operations: nothing that is drawn changes (the render
	 * copy, the views and the scene's order stay). */
	bool names_only;
	bool applied;
	/* Refused, and the session's tree not put back (out of memory). */
	bool lost;
	struct bc_author author;
	struct bc_change how;
	bc_applied_fn done;
	void *ud;
	struct bc_tree *tree; /* the scene after the batch */
	uint64_t taken;       /* room for the nodes it inserts */
	struct bc_edit_batch b;
	struct bc_proto_buf rec; /* the journal record (an EDIT message) */
	uint64_t t0_ns;
	int rc;
	struct bc_errinfo ei;
};

/* Applies, checks and encodes the batch's journal record: its
 * operations, who made it and, for a structural batch, what undoes it
 * (the history is journaled with the edits, undo.c). */
static int batch_apply(struct batch *x)
{
	struct bc_session *s = x->s;
	struct bc_undo_change c =
	    bc__undo_change_of(s, &x->author, &x->how, x->op, x->nops);
	x->tree = s->tree;
	if ((x->rc = bc_edit_batch_apply_undoable(&x->b, &x->tree, x->op,
	                                          x->nops, &x->ei))) {
		x->lost = x->b.lost;
		return x->rc;
	}
	x->applied = true;
	/* A structural edit can grow the scene past what a member's queue
	 * holds, or nest it deeper than its snapshots hold (every later
	 * snapshot would fail, the journal never compacted), and a record
	 * must encode: undone like an edit that could not be journaled. */
	if ((x->b.structural &&
	     ((x->rc = check_scene_bytes(x->tree, s->ss->max_scene_bytes,
	                                 &x->ei)) ||
	      (x->rc = bc_store_scene_depth_ok(x->tree, &x->ei)))) ||
	    (x->rc = bc__undo_record_encode(&x->rec, &c, x->b.inv.ops,
	                                    x->b.inv.nops, &x->ei))) {
		x->lost = bc_edit_batch_undo(&x->b, &x->tree) != 0;
		x->applied = false;
	}
	return x->rc;
}

/* On the task: the record appended and synced before anyone hears of the
 * edit; a batch that cannot be journaled is undone (the session, busy,
 * has not changed meanwhile). */
static void batch_run(struct bc_task *t)
{
	struct batch *x = (struct batch *)t;
	struct bc_session *s = x->s;
	if (x->heavy && batch_apply(x)) {
		return;
	}
	if ((x->rc = bc_store_append(s->store, s->order + 1, x->rec.data,
	                             x->rec.len, &x->ei))) {
		x->lost = bc_edit_batch_undo(&x->b, &x->tree) != 0;
		x->applied = false;
	}
}

/* The render copy follows: the nodes' new states, or the operations, or,
 * for a batch it took early, the word that it stands. A copy that cannot
 * follow (out of memory, its queue over its cap) is made again whole when
 * the next frame wants it (bc__session_copy: on a task for a big scene,
 * not on the loop). Without a copy there is nothing to follow. */
static void follow(struct bc_session *s, struct batch *x)
{
	struct bc_work *w = s->ss->work;
	struct bc_edit_saved *st = NULL;
	uint32_t n = 0;
	int rc;
	if (x->names_only) {
		return; /* names are not drawn: the copy needs none */
	}
	if (x->early) {
		bc_work_settle(w, s->id, true);
		x->settled = true;
		return;
	}
	if (!s->copied) {
		return; /* made from the tree when a picture is wanted */
	}
	if (x->b.structural) {
		rc = bc_work_ops(w, s->id, s->order, x->op, x->nops);
	} else if ((st = bc_calloc(x->nops ? x->nops : 1, sizeof(*st)))) {
		for (uint32_t i = 0; i < x->nops; i++) {
			st[n].id = x->op[i].node;
			if (bc_tree_get(s->tree, st[n].id, &st[n].p,
			                &st[n].op)) {
				bc_tree_get_unary(s->tree, st[n].id, &st[n].un);
				n++;
			}
		}
		rc = bc_work_states(w, s->id, s->order, st, n);
		bc_free(st);
	} else {
		rc = BC_ENOMEM;
	}
	if (rc) {
		s->copied = false;
		bc_log(BC_LOG_WARN,
		       "session %s: its render copy could not follow an edit; "
		       "it is made again",
		       s->name);
	}
}

/* EDIT_APPLIED to every member; each owes a frame, unless only names
 * changed, which nothing draws. */
static void broadcast(struct bc_session *s, const struct batch *x)
{
	struct bc_msg a = {.type = BC_MSG_EDIT_APPLIED, .flags = x->how.flags};
	struct bc_member *list[BC_PROTO_MAX_MEMBERS];
	bool interacting = (x->how.flags & BC_PROTO_FLAG_INTERACTING) != 0;
	uint64_t until =
	    interacting ? bc__now_ms(s->ss) + BC_SRV_STILL_DELAY_MS : 0;
	uint32_t n = bc__members(s, list);
	a.edit_applied.order = s->order;
	a.edit_applied.author = x->author.member_id;
	a.edit_applied.author_seq = x->author.seq;
	a.edit_applied.nops = (uint16_t)x->nops;
	a.edit_applied.ops = x->op;
	a.edit_applied.target_order = x->how.target_order;
	if (x->how.target_author[0]) {
		a.edit_applied.target_author.ptr = x->how.target_author;
		a.edit_applied.target_author.len =
		    (uint32_t)strlen(x->how.target_author);
	}
	for (uint32_t i = 0; i < n; i++) {
		if (!x->names_only) {
			/* A structural batch keeps what the member was shown:
			 * where the render copy cannot follow it splice by
			 * splice (flow.c), its views go, and a view of
			 * another id is sent whole. */
			list[i]->interacting_until = until;
			bc__owe_frame(list[i]);
		}
		/* Last: a member whose client cannot be sent the edit leaves
		 * here (bc__send closes it, PROTOCOL.md 4). */
		bc__send(list[i], &a);
	}
}

/* The batch is on disk: it becomes the session's, everyone hears of it. */
static void batch_commit(struct batch *x)
{
	struct bc_session *s = x->s;
	double ms = (double)(bc_clock_ns() - x->t0_ns) / 1e6;
	s->tree = x->tree;
	bc__room_settle(s, &x->taken);
	s->order++;
	if (!x->names_only) {
		s->scene_order = s->order;
	}
	s->last_edit_ms = bc__unix_ms();
	s->edit_ms_avg =
	    s->edit_ms_avg == 0.0 ? ms : 0.9 * s->edit_ms_avg + 0.1 * ms;
	bc_log(BC_LOG_DEBUG, "session %s: edit %llu journaled in %.1f ms",
	       s->name, (unsigned long long)s->order, ms);
	bc__session_changed(s);
	follow(s, x);
	broadcast(s, x);
	x->done(s, &x->author, &x->how, &x->b, x->op, x->nops, x->ud);
	bc__session_snapshot_due(s);
	bc__schedule(s);
}

static void batch_free(struct batch *x)
{
	bc__room_give(x->s->ss, &x->taken);
	if (x->early && !x->settled) {
		/* Refused, undone, or its session gone: the copy undoes it. */
		bc_work_settle(x->s->ss->work, x->s->id, false);
	}
	bc_edit_batch_finish(&x->b);
	bc_ops_copy_finish(&x->ops);
	bc_proto_buf_finish(&x->rec);
	bc_free(x);
}

/* After the task: committed, or its author hears why not. */
static void batch_done(struct bc_task *t)
{
	struct batch *x = (struct batch *)t;
	struct bc_session *s = x->s;
	struct bc_member *m = bc__member_of(s->ss, x->author.ref);
	if (s->removed) {
		/* Deleted meanwhile: an edited copy goes, the session's own
		 * tree is freed with it. */
		if (x->applied && x->b.structural) {
			bc_tree_destroy(x->tree);
			x->b.old = NULL;
		}
	} else if (x->rc) {
		s->store_failed = s->store_failed || x->rc == BC_EIO;
		if (x->lost) {
			lose(s);
		}
		if (m) {
			bc__send_error(m, x->author.seq, x->rc,
			               "edit refused: %s", x->ei.msg);
		}
	} else {
		batch_commit(x);
	}
	batch_free(x);
}

int bc__apply(struct bc_member *m, const struct bc_proto_edit_op *ops,
              uint16_t nops, uint32_t seq, const struct bc_change *how,
              bc_applied_fn done, void *ud, struct bc_errinfo *ei)
{
	struct bc_session *s = m->session;
	struct batch *x;
	uint64_t after;
	bool structural = false, names_only = nops > 0, old = false;
	if (s->lost) {
		return bc_errinfo_set(
		    ei, BC_ENOMEM,
		    "the server ran out of memory and this session's scene no "
		    "longer matches what it saved: changes wait until its "
		    "members have left (it then loads again) or a scene is "
		    "loaded");
	}
	for (uint32_t i = 0; i < nops; i++) {
		names_only = names_only && ops[i].kind == BC_PROTO_EDIT_NAME;
	}
	for (uint32_t i = 0; names_only && i < s->nmembers; i++) {
		old = old ||
		      !(s->members[i]->peer->features & BC_PROTO_FEATURE_NAMES);
	}
	/* Members without NAMES get such a change as the whole scene. */
	if (names_only && bc__state_limit(s, old, "names change", ei)) {
		return ei->code;
	}
	x = bc_calloc(1, sizeof(*x));
	if (!x || bc_ops_copy(&x->ops, ops, nops)) {
		bc_free(x);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	x->s = s;
	for (uint32_t i = 0; i < nops; i++) {
		structural = structural || ops[i].kind != BC_PROTO_EDIT_SET;
	}
	after = structural ? nodes_after(s->tree, ops, nops)
	                   : bc_tree_node_count(s->tree);
	if (structural && bc__room_take(s, after, &x->taken, ei)) {
		batch_free(x);
		return ei->code;
	}
	/* A big scene's structural edit, or a long batch of SETs on it,
	 * applies on the task: the session is busy meanwhile, so nothing on
	 * the loop reads the tree the task changes. A scene that the edit
	 * makes big counts too: an INSERT of 60 000 spheres into a scene of
	 * three nodes took the loop 200 ms (ASan build). */
	x->heavy = (bc_tree_node_count(s->tree) >= BC_SRV_HEAVY_NODES ||
	            after >= BC_SRV_HEAVY_NODES) &&
	           (structural || nops >= BC_SRV_HEAVY_SETS);
	x->names_only = names_only;
	x->op = x->ops.ops;
	x->nops = nops;
	x->author = (struct bc_author){m->peer->ref, m->member_id, seq, {0}};
	memcpy(x->author.name, m->peer->name, sizeof(x->author.name));
	x->how = *how;
	x->how.time_ms = bc__unix_ms();
	x->done = done;
	x->ud = ud;
	x->t0_ns = bc_clock_ns();
	/* A structural batch goes to the render copy first, so that its
	 * splice there runs while the session's own tree takes it and the
	 * record is journaled, not after (a splice in the middle of a big
	 * operator costs milliseconds per 100 000 operands). */
	x->early = structural && !names_only && s->copied &&
	           bc_work_ops_early(s->ss->work, s->id, s->order + 1, x->op,
	                             nops) == 0;
	if (!x->heavy && batch_apply(x)) {
		int rc = bc_errinfo_set(ei, x->rc, "%s", x->ei.msg);
		if (x->lost) {
			lose(s);
		}
		batch_free(x);
		return rc;
	}
	x->t.run = batch_run;
	x->t.done = batch_done;
	x->t.holds_order = true;
	bc__task_start(s, &x->t);
	return 1;
}

/* ---- EDIT ------------------------------------------------------------------ */

int bc_handle_edit(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_errinfo ei = {0};
	struct bc_change how = {.flags =
	                            msg->flags & BC_PROTO_FLAG_INTERACTING};
	int rc, park;
	if (bc__refuse_change(m, msg->seq, &park)) {
		return park;
	}
	if ((park = bc__change_waits(m, msg->edit.ops, msg->edit.nops, msg->seq,
	                             "an edit"))) {
		return park;
	}
	rc = bc__apply(m, msg->edit.ops, msg->edit.nops, msg->seq, &how,
	               bc__undo_applied, NULL, &ei);
	if (rc < 0) {
		bc__send_error(m, msg->seq, rc, "edit refused: %s", ei.msg);
		return 0;
	}
	return bc__hold(m->session, m, msg->seq);
}

int bc_handle_history(struct bc_member *m, const struct bc_msg *msg)
{
	/* Read only: it answers at once, even while the session is busy
	 * (the history changes on the loop only). */
	return bc__undo_history(m, msg->seq);
}

int bc_handle_undo(struct bc_member *m, const struct bc_msg *msg)
{
	int park;
	if (bc__refuse_change(m, msg->seq, &park)) {
		return park;
	}
	return bc__undo_step(m, msg->type == BC_MSG_REDO, msg->undo.scope,
	                     msg->seq);
}

/* ---- SCENE_LOAD ------------------------------------------------------------ */

/* A SCENE_LOAD on its way: the decoded and checked tree, the work
 * layer's copy, the members' SCENE_STATE bytes and the snapshot on disk
 * are made by prepare() on a task, the session busy; commit() then
 * applies it on the loop. */
struct load {
	struct bc_task t;
	struct bc_author author;
	uint8_t *owned; /* the payload's buffer or copy, for a task */
	struct bc_proto_bytes scene;
	struct bc_load_parts parts; /* or its parts, joined by the task */
	uint64_t order;
	/* copy: the render copy, decoded beside the tree when the flow
	 * holds one or a member has a view (copy_wanted); else made when
	 * someone first wants a picture (bc__session_copy). */
	struct bc_tree *tree, *copy;
	bool copy_wanted;
	uint32_t nodes; /* the count its head gives */
	uint64_t taken; /* room for them (bc__room_take) */
	struct bc_camera cam;
	bool has_cam;
	struct bc_shared *state; /* the members' SCENE_STATE */
	int rc;
	struct bc_errinfo ei;
};

static void parts_free(struct bc_load_parts *p)
{
	for (uint32_t i = 0; i < p->n; i++) {
		bc_free(p->v[i].owned);
	}
	bc_free(p->v);
	memset(p, 0, sizeof(*p));
}

/* The scene of a load in parts, in one buffer (on the task: a scene of
 * hundreds of megabytes is not copied on the loop). */
static int join_parts(struct load *l)
{
	size_t at = 0;
	if (!(l->owned = bc_malloc(l->parts.len))) {
		return bc_errinfo_set(&l->ei, BC_ENOMEM,
		                      "out of memory for a scene of %zu bytes",
		                      l->parts.len);
	}
	bc_populate(l->owned, l->parts.len);
	for (uint32_t i = 0; i < l->parts.n; i++) {
		memcpy(l->owned + at, l->parts.v[i].ptr, l->parts.v[i].len);
		at += l->parts.v[i].len;
	}
	l->scene.ptr = l->owned;
	l->scene.len = (uint32_t)at;
	parts_free(&l->parts);
	return 0;
}

static void prepare(struct bc_task *t)
{
	struct load *l = (struct load *)t;
	struct bc_errinfo *ei = &l->ei;
	if (l->parts.n && (l->rc = join_parts(l))) {
		return;
	}
	if (!(l->tree = bc__session_tree()) ||
	    (l->copy_wanted && !(l->copy = bc__copy_tree()))) {
		l->rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		return;
	}
	if ((l->rc = bc__load_decode(l->scene.ptr, l->scene.len, l->tree,
	                             l->copy, &l->cam, &l->has_cam, ei))) {
		return;
	}
	if (bc_tree_node_count(l->tree) != l->nodes) {
		/* Cannot happen: the decoder holds the scene to its count. */
		l->rc = bc_errinfo_set(ei, BC_ELIMIT,
		                       "more nodes than its head counts");
		return;
	}
	if (bc_tree_node_count(l->tree) > BC_SRV_MAX_NODES) {
		l->rc = bc_errinfo_set(ei, BC_ELIMIT, "more than %u nodes",
		                       BC_SRV_MAX_NODES);
		return;
	}
	if ((l->rc =
	         check_scene_bytes(l->tree, l->t.s->ss->max_scene_bytes, ei))) {
		return;
	}
	if (!(l->state = bc__state_msg(l->tree, &l->cam, l->order,
	                               l->author.member_id, l->author.seq))) {
		l->rc =
		    bc_errinfo_set(ei, BC_ENOMEM, "cannot encode the scene");
		return;
	}
	/* On disk before anyone hears of it: journaled, which makes it safe
	 * (a restore replays the record). The snapshot that starts the next
	 * journal follows on its own task once the load is answered
	 * (bc_store_append_scene). A scene no snapshot could hold is refused
	 * before either. */
	l->rc = bc_store_scene_depth_ok(l->tree, ei);
	if (!l->rc) {
		l->rc = bc__journal_load(t->s->store, l->order, l->scene.ptr,
		                         l->scene.len, ei);
	}
	/* The bytes are in the trees and the journal now: freed here, off
	 * the loop, before the old scene's trees (whose task gives the heap
	 * back to the system, bc__tree_free_later). */
	bc_free(l->owned);
	l->owned = NULL;
	l->scene = (struct bc_proto_bytes){0};
}

static void load_free(struct load *l)
{
	bc__room_give(l->t.s->ss, &l->taken);
	/* A refused load of a big scene leaves two trees to free. */
	bc__tree_free_later(l->t.s->kick.loop, l->tree);
	bc__tree_free_later(l->t.s->kick.loop, l->copy);
	bc_shared_unref(l->state);
	bc_free(l->owned);
	parts_free(&l->parts);
	bc_free(l);
}

static void commit(struct bc_task *t)
{
	struct load *l = (struct load *)t;
	struct bc_session *s = t->s;
	struct bc_member *author = bc__member_of(s->ss, l->author.ref);
	if (s->removed) {
		load_free(l);
		return;
	}
	if (l->rc) {
		/* Only a failed write locks the session: a scene the store
		 * refuses up front (too big or too deep to restore) left
		 * nothing on disk. */
		s->store_failed = s->store_failed || l->rc == BC_EIO;
		if (author) {
			bc__send_error(author, l->author.seq, l->rc,
			               "scene not loaded: %s", l->ei.msg);
		}
		load_free(l);
		return;
	}
	bc__tree_free_later(s->ss->loop, s->tree);
	s->tree = l->tree;
	bc__room_settle(s, &l->taken);
	s->lost = false; /* the scene whole again, as saved */
	s->camera = l->cam;
	s->order = s->scene_order = l->order;
	s->last_edit_ms = bc__unix_ms();
	bc__session_changed(s);
	/* Without a copy (nobody looks) the old scene's goes too. */
	bc_work_scene(s->ss->work, s->id, l->copy, s->order);
	s->copied = l->copy != NULL;
	/* A new copy stays for render_idle_ms from now. */
	s->looked_ms = bc__now_ms(s->ss);
	l->tree = l->copy = NULL;
	bc__send_state_msg(s, NULL, l->state);
	for (uint32_t i = 0; i < s->nmembers && l->has_cam; i++) {
		s->members[i]->camera = l->cam;
	}
	/* A new scene: nothing before it can be undone. */
	bc__undo_clear(s);
	bc__mark_all(s);
	bc__schedule(s);
	load_free(l);
}

/* The node count in the head of a scene sent in parts
 * (bc_scene_head_count): in p's first pieces, then in last (NULL: none),
 * a piece not taken into p yet. */
static uint32_t parts_count(const struct bc_load_parts *p,
                            const struct bc_proto_bytes *last)
{
	uint8_t head[BC_SCENE_HEAD_MAX_BYTES];
	size_t n = 0, total = p->len + (last ? last->len : 0);
	for (uint32_t i = 0; i <= p->n && n < sizeof(head); i++) {
		const uint8_t *ptr = i < p->n ? p->v[i].ptr : NULL;
		size_t len = i < p->n ? p->v[i].len : 0;
		if (i == p->n && last) {
			ptr = last->ptr;
			len = last->len;
		}
		len = len < sizeof(head) - n ? len : sizeof(head) - n;
		if (len) {
			memcpy(head + n, ptr, len);
			n += len;
		}
	}
	return bc_scene_head_count(head, n, total);
}

/* The node count in the head of the scene being loaded
 * (bc_scene_head_count): whole in msg, or in m->parts's first pieces. */
static uint32_t load_count(const struct bc_member *m, const struct bc_msg *msg,
                           bool in_parts)
{
	const struct bc_proto_bytes *b = &msg->scene_load.scene;
	return in_parts ? parts_count(&m->parts, NULL)
	                : bc_scene_head_count(b->ptr, b->len, b->len);
}

/* Starts the load of msg's scene: a whole SCENE_LOAD, or the last part
 * of one sent in parts, whose pieces (m->parts) this takes. Room for its
 * nodes is taken first (a session without members may be unloaded for
 * it). */
static int start_load(struct bc_member *m, const struct bc_msg *msg,
                      bool in_parts)
{
	struct bc_session *s = m->session;
	struct bc_errinfo ei = {0};
	struct load *l;
	if (!(l = bc_calloc(1, sizeof(*l)))) {
		bc__parts_drop(m);
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "scene not loaded: out of memory");
		return 0;
	}
	l->t.s = s;
	l->nodes = load_count(m, msg, in_parts);
	if (bc__room_take(s, l->nodes, &l->taken, &ei)) {
		bc_free(l);
		bc__parts_drop(m);
		bc__send_error(m, msg->seq, ei.code, "scene not loaded: %s",
		               ei.msg);
		return 0;
	}
	l->author =
	    (struct bc_author){m->peer->ref, m->member_id, msg->seq, {0}};
	l->scene = msg->scene_load.scene;
	l->cam = s->camera;
	l->order = s->order + 1;
	l->copy_wanted = s->copied;
	for (uint32_t i = 0; i < s->nmembers; i++) {
		l->copy_wanted = l->copy_wanted || s->members[i]->has_view;
	}
	l->t.run = prepare;
	l->t.done = commit;
	l->t.holds_order = true;
	if (in_parts) {
		/* Joined on the task. */
		l->parts = m->parts;
		l->scene.len = 0;
		m->ss->parts_bytes -= m->parts.len;
		memset(&m->parts, 0, sizeof(m->parts));
		bc__task_start(s, &l->t);
		return bc__hold(s, m, msg->seq);
	}
	/* A whole payload lives in the reader's buffer only until the next
	 * message: a big one takes that buffer (a 35 MB copy took the loop
	 * 22 ms; the scene stays where it is in it), a small one is
	 * copied. */
	if (l->scene.len >= BC_SRV_DETACH_BYTES) {
		l->owned = m->ss->link->detach(m->ss->link->ud, m->peer->ref);
	}
	if (!l->owned &&
	    (l->owned = bc_malloc(l->scene.len ? l->scene.len : 1))) {
		if (l->scene.len) {
			memcpy(l->owned, l->scene.ptr, l->scene.len);
		}
		l->scene.ptr = l->owned;
	}
	if (!l->owned) {
		bc__room_give(s->ss, &l->taken);
		bc_free(l);
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "scene not loaded: out of memory");
		return 0;
	}
	bc__task_start(s, &l->t);
	return bc__hold(s, m, msg->seq);
}

/* ---- SCENE_LOAD in parts (PROTOCOL.md 7.10.1) ------------------------------ */

void bc__parts_drop(struct bc_member *m)
{
	m->ss->parts_bytes -= m->parts.len;
	parts_free(&m->parts);
}

/* Keeps msg's piece in m->parts: a big one in the reader's buffer,
 * handed over; a small one copied, joined to the copy before it. Returns
 * 0 or BC_ENOMEM (the scene then dropped). */
static int keep_piece(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_load_parts *p = &m->parts;
	const struct bc_proto_bytes *b = &msg->scene_load.scene;
	struct bc_load_piece *last = p->n ? &p->v[p->n - 1] : NULL;
	uint8_t *owned = NULL;
	if (b->len < BC_SRV_DETACH_BYTES && last && last->ptr == last->owned) {
		if (last->len + b->len > last->room) {
			/* Doubling: many tiny parts cost linear time. */
			size_t room = 2 * (last->len + b->len);
			uint8_t *grown = bc_realloc(last->owned, room);
			if (!grown) {
				return BC_ENOMEM;
			}
			last->owned = grown;
			last->ptr = grown;
			last->room = room;
		}
		memcpy(last->owned + last->len, b->ptr, b->len);
		last->len += b->len;
		p->len += b->len;
		return 0;
	}
	if (p->n == p->cap) {
		uint32_t cap = p->cap ? 2 * p->cap : 8;
		struct bc_load_piece *v =
		    bc_reallocarray(p->v, cap, sizeof(*v));
		if (!v) {
			return BC_ENOMEM;
		}
		p->v = v;
		p->cap = cap;
	}
	if (b->len >= BC_SRV_DETACH_BYTES) {
		owned = m->ss->link->detach(m->ss->link->ud, m->peer->ref);
	}
	p->v[p->n] = (struct bc_load_piece){owned, b->ptr, b->len, b->len};
	if (!owned) {
		if (!(owned = bc_malloc(b->len))) {
			return BC_ENOMEM;
		}
		memcpy(owned, b->ptr, b->len);
		p->v[p->n].owned = owned;
		p->v[p->n].ptr = owned;
	}
	p->n++;
	p->len += b->len;
	return 0;
}

/* Drops the unfinished scenes of other members that have had no part for
 * BC_SRV_PART_STALE_MS, to make room for m's. */
static void drop_stale_parts(struct bc_member *m)
{
	uint64_t now = bc__now_ms(m->ss);
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		struct bc_member *o = m->ss->by_slot[i];
		if (o && o != m && o->parts.open &&
		    now - o->parts_ms >= BC_SRV_PART_STALE_MS) {
			bc_log(BC_LOG_INFO,
			       "member %u: an unfinished scene of %zu bytes "
			       "dropped, no part for %u ms",
			       o->member_id, o->parts.len,
			       (unsigned)(now - o->parts_ms));
			bc__parts_drop(o);
		}
	}
}

/* Takes a part of a SCENE_LOAD: true when it was the last, the whole
 * scene then in m->parts; false when more must come or the part was
 * refused (answered, its scene dropped). */
static bool take_part(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_sessions *ss = m->ss;
	bool cont = (msg->flags & BC_PROTO_FLAG_CONT) != 0;
	size_t piece = msg->scene_load.scene.len;
	size_t pending_cap = BC_SRV_PARTS_PENDING_SCENES * ss->max_scene_bytes;
	if (!cont) {
		bc__parts_drop(m); /* a first part drops an unfinished scene */
		m->parts.open = true;
	} else if (!m->parts.open) {
		bc__send_error(
		    m, msg->seq, BC_ESTATE,
		    "scene not loaded: a SCENE_LOAD part (CONT) with "
		    "no scene begun: its first part was refused, "
		    "dropped or never sent");
		return false;
	}
	if (m->parts.len + piece > ss->max_scene_bytes) {
		size_t had = m->parts.len;
		bc__parts_drop(m);
		bc__send_error(m, msg->seq, BC_ELIMIT,
		               "scene not loaded: its parts pass this server's "
		               "%zu bytes (--max-scene) at %zu bytes",
		               ss->max_scene_bytes, had + piece);
		return false;
	}
	if (ss->parts_bytes + piece > pending_cap) {
		drop_stale_parts(m);
		if (ss->parts_bytes + piece > pending_cap) {
			bc__parts_drop(m);
			bc__send_error(
			    m, msg->seq, BC_EBUSY,
			    "scene not loaded: this server holds %zu "
			    "bytes of scenes in parts, at most %zu; "
			    "send it again later",
			    ss->parts_bytes, pending_cap);
			return false;
		}
	}
	m->parts_ms = bc__now_ms(ss);
	if (keep_piece(m, msg)) {
		bc__parts_drop(m);
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "scene not loaded: out of memory");
		return false;
	}
	ss->parts_bytes += piece;
	if (msg->flags & BC_PROTO_FLAG_MORE) {
		return false;
	}
	m->parts.open = false;
	return true;
}

int bc_handle_scene_load(struct bc_member *m, const struct bc_msg *msg)
{
	const struct bc_proto_bytes *b = &msg->scene_load.scene;
	struct bc_session *w = NULL;
	int park;
	if (bc__refuse_change(m, msg->seq, &park)) {
		if (!park) {
			bc__parts_drop(m); /* refused: its scene is dropped */
		}
		return park;
	}
	/* Waiting for room comes before the scene (or its last part) is
	 * taken: the request comes again whole. */
	if (!(msg->flags & BC_PROTO_FLAGS_PARTS)) {
		w = bc__room_busy(m->session,
		                  bc_scene_head_count(b->ptr, b->len, b->len));
	} else if (!(msg->flags & BC_PROTO_FLAG_MORE) && m->parts.open) {
		w = bc__room_busy(m->session, parts_count(&m->parts, b));
	}
	if (w) {
		return wait_for_room(m, w, msg->seq, "a scene load");
	}
	if (msg->flags & BC_PROTO_FLAGS_PARTS) {
		return take_part(m, msg) ? start_load(m, msg, true) : 0;
	}
	bc__parts_drop(m); /* a whole scene replaces an unfinished one */
	return start_load(m, msg, false);
}
