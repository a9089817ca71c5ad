/*
 * Sessions (loop thread): the table of loaded sessions and their life --
 * loaded from the store (on libuv's thread pool for a JOIN, so a big
 * session's replay never holds the loop), unloaded when idle, saved,
 * deleted, freed -- with the two mechanisms that keep the loop free:
 *  - tasks: work on the thread pool for one session; one that holds the
 *    session's order (a load, a big structural edit, a snapshot, a scene
 *    encode) makes the session busy while it runs;
 *  - parking: a request that must come after that work (an edit, a join,
 *    a delete) waits with its connection, which reads nothing more until
 *    the session is free; then the transport dispatches it again.
 * Also SESSION_CREATE, SESSION_JOIN, SESSION_LEAVE, SESSION_DELETE and
 * SESSION_LIST (from the index of sessions on disk, index.c).
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

uint64_t bc__now_ms(const struct bc_sessions *ss)
{
	return uv_now(ss->loop);
}

uint64_t bc__unix_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

struct bc_session *bc__session_by_id(struct bc_sessions *ss, uint32_t id)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (ss->sessions[i] && ss->sessions[i]->id == id) {
			return ss->sessions[i];
		}
	}
	return NULL;
}

struct bc_session *bc__session_by_name(struct bc_sessions *ss, const char *name,
                                       size_t len)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = ss->sessions[i];
		if (s && strlen(s->name) == len &&
		    memcmp(s->name, name, len) == 0) {
			return s;
		}
	}
	return NULL;
}

struct bc_member *bc__member_of(struct bc_sessions *ss, struct bc_conn_ref ref)
{
	struct bc_member *m;
	if (ref.slot >= BC_SRV_MAX_CONNECTIONS) {
		return NULL;
	}
	m = ss->by_slot[ref.slot];
	return m && bc_conn_ref_eq(m->peer->ref, ref) ? m : NULL;
}

/* ---- tasks and parking --------------------------------------------------- */

/* A tree being freed, off the loop. */
struct tree_free {
	uv_work_t req;
	struct bc_tree *t;
};

static void tree_free_run(uv_work_t *req)
{
	struct tree_free *f = req->data;
	bc_tree_destroy(f->t);
	/* Only big trees come here: what they held goes back to the
	 * system, not to this thread's arena. */
	bc_heap_give_back();
}

static void tree_free_done(uv_work_t *req, int status)
{
	(void)status;
	bc_free(req->data);
}

void bc__tree_free_later(uv_loop_t *loop, struct bc_tree *t)
{
	struct tree_free *f;
	if (!t) {
		return;
	}
	if (bc_tree_node_count(t) < BC_SRV_HEAVY_NODES ||
	    !(f = bc_calloc(1, sizeof(*f)))) {
		bc_tree_destroy(t);
		return;
	}
	f->t = t;
	f->req.data = f;
	if (uv_queue_work(loop, &f->req, tree_free_run, tree_free_done)) {
		bc_tree_destroy(t);
		bc_free(f);
	}
}

static void free_session(struct bc_session *s)
{
	bc__undo_clear(s);
	bc_store_session_close(s->store);
	/* The layer may be gone (its sessions go as their handles close):
	 * the loop is the timer's. */
	bc__tree_free_later(s->kick.loop, s->tree);
	bc_shared_unref(s->state_msg);
	bc_free(s);
}

void bc__session_unref(struct bc_session *s)
{
	if (--s->handles_open == 0) {
		free_session(s);
	}
}

/* The first member parked behind s, taken out of the queue (NULL when
 * none is). */
static struct bc_member *pop_parked(struct bc_session *s)
{
	struct bc_member *m = s->park_head;
	if (m) {
		s->park_head = m->park_next;
		if (!s->park_head) {
			s->park_tail = NULL;
		}
		m->parked = NULL;
		m->park_next = NULL;
	}
	return m;
}

/* Resumes the members parked behind s, in order, while it is free: each
 * one's request comes again in a later loop turn (and parks again if s is
 * busy by then). */
static void resume_parked(struct bc_session *s)
{
	struct bc_member *m;
	while (!s->busy && (m = pop_parked(s))) {
		s->ss->link->resume(s->ss->link->ud, m->peer->ref,
		                    m->park_again);
	}
}

static int wait_for(struct bc_session *s, struct bc_member *m, uint32_t seq,
                    bool again)
{
	bc__unpark(m); /* a held request that goes on to more work */
	m->parked = s;
	m->park_seq = seq;
	m->park_again = again;
	m->park_next = NULL;
	if (s->park_tail) {
		s->park_tail->park_next = m;
	} else {
		s->park_head = m;
	}
	s->park_tail = m;
	return again ? BC_PARK : BC_HOLD;
}

int bc__park(struct bc_session *s, struct bc_member *m, uint32_t seq)
{
	return wait_for(s, m, seq, true);
}

int bc__hold(struct bc_session *s, struct bc_member *m, uint32_t seq)
{
	return wait_for(s, m, seq, false);
}

void bc__unpark(struct bc_member *m)
{
	struct bc_session *s = m->parked;
	struct bc_member **p;
	if (!s) {
		return;
	}
	for (p = &s->park_head; *p; p = &(*p)->park_next) {
		if (*p == m) {
			*p = m->park_next;
			break;
		}
	}
	s->park_tail = NULL;
	for (struct bc_member *q = s->park_head; q; q = q->park_next) {
		s->park_tail = q;
	}
	m->parked = NULL;
	m->park_next = NULL;
}

static void task_run(uv_work_t *req)
{
	struct bc_task *t = req->data;
	t->run(t);
}

static void task_after(uv_work_t *req, int status)
{
	struct bc_task *t = req->data;
	struct bc_session *s = t->s;
	(void)status;
	if (t->holds_order) {
		s->busy--;
	}
	t->done(t); /* frees t */
	if (!s->removed) {
		resume_parked(s);
		/* Frames whose render copy waited for the task. */
		if (!s->busy) {
			bc__schedule(s);
		}
		/* A load's snapshot comes after its SCENE_STATE, once the
		 * members held behind the load were let go (the journal
		 * record is what made the load safe). */
		if (!s->busy && s->tree && s->store &&
		    bc_store_snapshot_is_due(s->store, BC_SRV_SNAPSHOT_EVERY)) {
			bc__session_snapshot_due(s);
		}
	}
	bc__session_unref(s);
}

void bc__task_start(struct bc_session *s, struct bc_task *t)
{
	t->s = s;
	t->req.data = t;
	s->handles_open++;
	if (t->holds_order) {
		s->busy++;
	}
	if (uv_queue_work(s->ss->loop, &t->req, task_run, task_after) != 0) {
		/* Cannot happen with a valid request; the work still has to
		 * be done. */
		t->run(t);
		task_after(&t->req, 0);
	}
}

/* ---- loading ------------------------------------------------------------- */

/* The first bytes of a journaled SCENE_LOAD: an op_count (65535) that no
 * EDIT has, as the camera records' two zero bytes. */
#define LOAD_RECORD_MAGIC 0xffu
#define LOAD_RECORD_MAGIC_LEN 2u

int bc__journal_load(struct bc_store_session *st, uint64_t order,
                     const uint8_t *scene, size_t len, struct bc_errinfo *ei)
{
	static const uint8_t magic[LOAD_RECORD_MAGIC_LEN] = {LOAD_RECORD_MAGIC,
	                                                     LOAD_RECORD_MAGIC};
	return bc_store_append_scene(st, order, magic, sizeof(magic), scene,
	                             len, ei);
}

struct bc_tree *bc__session_tree(void)
{
	struct bc_tree *t = bc_tree_create();
	if (t) {
		bc_tree_set_layout(t, false);
	}
	return t;
}

struct bc_tree *bc__copy_tree(void)
{
	struct bc_tree *t = bc_tree_create();
	if (t) {
		bc_tree_set_names(t, false);
	}
	return t;
}

/* The second decode of a large load, on a thread of its own. */
struct twin {
	const uint8_t *scene;
	size_t len;
	struct bc_tree *t;
	int rc;
	struct bc_errinfo ei;
};

static void twin_run(void *arg)
{
	struct twin *tw = arg;
	tw->rc =
	    bc_scene_decode(tw->scene, tw->len, tw->t, NULL, NULL, &tw->ei);
}

/* A copy of a million-node tree (bc_tree_copy builds and lays it out
 * anew) took as long as its decode, one after the other; decoding the
 * bytes twice, at once, takes one decode's time on two cores and gives
 * the same tree, fresh ids included. Without a copy (NULL), once. */
int bc__load_decode(const uint8_t *scene, size_t len, struct bc_tree *tree,
                    struct bc_tree *copy, struct bc_camera *cam, bool *has_cam,
                    struct bc_errinfo *ei)
{
	struct twin tw = {scene, len, copy, 0, {0}};
	uv_thread_t th;
	bool apart;
	if (!copy) {
		return bc_scene_decode(scene, len, tree, cam, has_cam, ei);
	}
	apart = len >= BC_SRV_DETACH_BYTES &&
	        uv_thread_create(&th, twin_run, &tw) == 0;
	int rc = bc_scene_decode(scene, len, tree, cam, has_cam, ei);
	if (apart) {
		uv_thread_join(&th);
	} else if (rc == 0) {
		twin_run(&tw);
	}
	if (rc == 0 && tw.rc) {
		/* The same bytes decoded once: only memory can fail. */
		rc = bc_errinfo_set(ei, tw.rc, "%s", tw.ei.msg);
	}
	return rc;
}

/* A journaled SCENE_LOAD: 1 when rec is one and it replaced the tree
 * (and the camera, when it carries one), 0 when rec is no load record,
 * else an error code. */
static int replay_load(struct replay_ctx *ctx, const uint8_t *rec, size_t len)
{
	struct bc_tree *t;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	bool has_cam = false;
	int rc;
	if (len < LOAD_RECORD_MAGIC_LEN || rec[0] != LOAD_RECORD_MAGIC ||
	    rec[1] != LOAD_RECORD_MAGIC) {
		return 0;
	}
	if (!(t = bc__session_tree())) {
		return BC_ENOMEM;
	}
	if ((rc = bc_scene_decode(rec + LOAD_RECORD_MAGIC_LEN,
	                          len - LOAD_RECORD_MAGIC_LEN, t, &cam,
	                          &has_cam, &ei))) {
		bc_log(BC_LOG_ERROR, "journal replay: a scene load: %s",
		       ei.msg);
		bc_tree_destroy(t);
		return rc;
	}
	bc_tree_destroy(*ctx->tree);
	*ctx->tree = t;
	if (has_cam) {
		*ctx->camera = cam;
	}
	return 1;
}

/* Applies an EDIT payload's operations to *ctx->tree in place, each in
 * turn: no copy of the tree per record (a journal of structural edits on
 * a big scene replays in time proportional to the edits). A batch of
 * SETs goes through a batch, whose saved states the history keeps (in b,
 * which the caller finishes). */
static int replay_ops(struct replay_ctx *ctx, const struct bc_msg *m,
                      struct bc_edit_batch *b, struct bc_errinfo *ei)
{
	int rc = 0;
	for (uint16_t i = 0; i < m->edit.nops; i++) {
		b->structural =
		    b->structural || m->edit.ops[i].kind != BC_PROTO_EDIT_SET;
	}
	if (!b->structural) {
		return bc_edit_batch_apply(b, ctx->tree, m->edit.ops,
		                           m->edit.nops, ei);
	}
	for (uint16_t i = 0; !rc && i < m->edit.nops; i++) {
		rc = bc_edit_apply_op(*ctx->tree, &m->edit.ops[i], ei);
	}
	return rc;
}

/* The history follows a replayed record (undo.c): a failure to keep it
 * loses the history, never the scene. */
static void replay_note(struct replay_ctx *ctx, uint64_t order,
                        const struct bc_undo_record *h, const struct bc_msg *m,
                        const struct bc_edit_batch *b)
{
	struct bc_proto_reader r;
	struct bc_msg inv = {0};
	struct bc_errinfo ei = {0};
	struct bc_undo_change c = {
	    .kind = h->kind,
	    .interacting = h->interacting,
	    .order = order,
	    .target = h->target,
	    .time_ms = h->time_ms,
	    .name = h->name,
	    .member = h->member,
	    .ops = m->edit.ops,
	    .nops = m->edit.nops,
	    .tree = *ctx->tree,
	};
	int rc = 0;
	if (!ctx->undo) {
		return;
	}
	bc_proto_reader_init(&r, NULL);
	if (b->structural &&
	    (!h->inv || bc_proto_decode_payload(&r, BC_MSG_EDIT, 0, 0, h->inv,
	                                        h->inv_len, &inv, &ei))) {
		rc = BC_EINVAL;
	}
	if (!rc) {
		rc = bc__undo_note(ctx->undo, &c, b, inv.edit.ops,
		                   b->structural ? inv.edit.nops : 0);
	}
	bc_proto_reader_finish(&r);
	if (rc) {
		bc_log(BC_LOG_WARN,
		       "journal replay: edit %llu: the undo history cannot "
		       "follow (%s); it restarts after it",
		       (unsigned long long)order, bc_strerror(rc));
		bc__undo_free(ctx->undo);
		ctx->undo = bc__undo_new();
	}
}

int bc__replay_record(void *ud, uint64_t order, const uint8_t *rec, size_t len)
{
	struct replay_ctx *ctx = ud;
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bc_errinfo ei = {0};
	struct bc_undo_record h;
	struct bc_edit_batch b = {0};
	int rc;
	if (order == 0) {
		/* The history carried by the snapshot the journal follows
		 * (store.h): lost, never the scene, when it does not read. */
		if (ctx->undo && (rc = bc__undo_uncarry(ctx->undo, rec, len))) {
			bc_log(BC_LOG_WARN,
			       "journal replay: the undo history kept with the "
			       "snapshot does not read (%s); it restarts here",
			       bc_strerror(rc));
		}
		return 0;
	}
	/* A SESSION_CAMERA record (present.c), a SCENE_LOAD, an edit with
	 * its history (undo.c) or a plain EDIT (an earlier journal). */
	if ((rc = bc__present_camera_record(rec, len, ctx->camera)) != 0) {
		return rc < 0 ? rc : 0;
	}
	if ((rc = replay_load(ctx, rec, len)) != 0) {
		if (rc > 0 && ctx->undo) {
			/* A new scene: nothing before it can be undone. */
			bc__undo_free(ctx->undo);
			ctx->undo = bc__undo_new();
		}
		return rc < 0 ? rc : 0;
	}
	if ((rc = bc__undo_record_parse(rec, len, &h)) < 0) {
		bc_log(BC_LOG_ERROR,
		       "journal replay: a damaged edit record "
		       "(%s)",
		       bc_strerror(rc));
		return rc;
	}
	bc_proto_reader_init(&r, NULL);
	rc = rc ? bc_proto_decode_payload(&r, BC_MSG_EDIT, 0, 0, h.fwd,
	                                  h.fwd_len, &m, &ei)
	        : bc_proto_decode_payload(&r, BC_MSG_EDIT, 0, 0, rec, len, &m,
	                                  &ei);
	/* These records applied when they were acknowledged; one that
	 * fails now is a loss, which leaves the session not whole
	 * (store.h), whatever state it left. */
	if (!rc) {
		rc = replay_ops(ctx, &m, &b, &ei);
	}
	if (rc) {
		bc_log(BC_LOG_ERROR, "journal replay: %s", ei.msg);
	} else if (h.fwd) {
		replay_note(ctx, order, &h, &m, &b);
	}
	bc_edit_batch_finish(&b);
	bc_proto_reader_finish(&r);
	return rc;
}

/* Loading a session: its snapshot and journal read (or a new session made
 * with the default scene). */
struct load_task {
	struct bc_task t;
	struct bc_store *store;
	struct bc_store_session *st;
	struct bc_tree *tree;
	struct bc_camera cam;
	uint64_t order;
	bool created;
	struct bc_undo *undo; /* the history the journal gave back */
	char owner[BC_STORE_OWNER_MAX + 1];
	uint64_t taken; /* room for the tree (bc__room_take) */
	bool roomed;
	int rc;
	struct bc_errinfo ei;
};

static void load_run(struct bc_task *t)
{
	struct load_task *l = (struct load_task *)t;
	struct bc_session *s = t->s;
	struct replay_ctx ctx = {&l->tree, &l->cam, bc__undo_new()};
	bc_camera_default(&l->cam);
	if (!(l->tree = bc__session_tree())) {
		l->rc = bc_errinfo_set(&l->ei, BC_ENOMEM, "out of memory");
		return;
	}
	l->rc = bc_store_session_open(l->store, s->name, &l->st, l->tree,
	                              &l->cam, &l->order, &l->created,
	                              bc__replay_record, &ctx, &l->ei);
	l->undo = ctx.undo;
	if (!l->rc && l->created) {
		const char *json = bc_scene_default_json();
		if (!(l->rc = bc_scene_parse_json(json, strlen(json), l->tree,
		                                  &l->cam, &l->ei))) {
			l->rc = bc_store_snapshot(l->st, l->tree, &l->cam, 0,
			                          &l->ei);
		}
		/* Its creator owns it (PROTOCOL.md 7.20); the session is
		 * busy, so its owner field stays as the CREATE set it. */
		if (!l->rc && s->owner[0]) {
			l->rc = bc_store_owner_write(l->st, s->owner, &l->ei);
		}
	} else if (!l->rc) {
		bc_store_owner_read(l->st, l->owner);
	}
}

static void load_free(struct load_task *l)
{
	bc__room_give(l->t.s->ss, &l->taken);
	bc__undo_free(l->undo);
	bc_store_session_close(l->st);
	bc__tree_free_later(l->t.s->kick.loop, l->tree);
	bc_free(l);
}

/* A failed load: members waiting to join hear why; the session goes. */
static void load_failed(struct bc_session *s, const struct load_task *l)
{
	struct bc_sessions *ss = s->ss;
	bc_log(l->rc == BC_ELIMIT ? BC_LOG_WARN : BC_LOG_ERROR,
	       "cannot load session %s: %s", s->name, l->ei.msg);
	struct bc_member *m;
	while ((m = pop_parked(s))) {
		if (m->park_again) {
			bc__send_error(m, m->park_seq, l->rc,
			               "cannot load session %s: %s", s->name,
			               l->ei.msg);
		}
		ss->link->resume(ss->link->ud, m->peer->ref, false);
	}
	bc__session_unload(s, "its load failed");
}

/* Room for the scene read (a new session's default scene is always let
 * in: it has a few dozen nodes). Sets l->rc when there is none. */
static void load_room(struct bc_session *s, struct load_task *l)
{
	if (!l->roomed && !l->rc && !l->created) {
		l->rc = bc__room_take(s, bc_tree_node_count(l->tree), &l->taken,
		                      &l->ei);
	}
	l->roomed = true;
}

/* A load refused room that session w's work holds (bc__room_busy): the
 * requests parked behind the load (the JOINs that asked for it) wait
 * behind w's work instead of hearing ELIMIT, and come again when it ends,
 * loading s afresh then; s is unloaded meanwhile. False where waiting
 * would not make the room. */
static bool load_waits(struct bc_session *s, const struct load_task *l)
{
	struct bc_member *m;
	struct bc_session *w;
	if (l->rc != BC_ELIMIT || !l->tree ||
	    !(w = bc__room_busy(s, bc_tree_node_count(l->tree)))) {
		return false;
	}
	bc_log(BC_LOG_INFO,
	       "session %s: its load waits for the room session %s holds "
	       "until its work ends",
	       s->name, w->name);
	while ((m = pop_parked(s))) {
		if (m->park_again) {
			(void)wait_for(w, m, m->park_seq, true);
		} else {
			s->ss->link->resume(s->ss->link->ud, m->peer->ref,
			                    false);
		}
	}
	bc__session_unload(s, "its room is held by another's work");
	return true;
}

static void load_done(struct bc_task *t)
{
	struct load_task *l = (struct load_task *)t;
	struct bc_session *s = t->s;
	if (s->removed) {
		load_free(l);
		return;
	}
	load_room(s, l);
	if (l->rc && load_waits(s, l)) {
		load_free(l);
		return;
	}
	if (l->rc) {
		load_failed(s, l);
		load_free(l);
		return;
	}
	s->tree = l->tree;
	bc__room_settle(s, &l->taken);
	s->store = l->st;
	s->camera = l->cam;
	s->order = s->scene_order = l->order;
	s->last_edit_ms = bc_store_session_mtime_ms(s->store);
	if (!l->created) {
		memcpy(s->owner, l->owner, sizeof(s->owner));
	}
	bc__undo_restored(l->undo);
	s->undo = l->undo;
	l->undo = NULL;
	/* No render copy yet: the first member who wants a picture has it
	 * made (bc__session_copy). */
	l->tree = NULL;
	l->st = NULL;
	bc__index_note(s->ss->index, s);
	bc_log(BC_LOG_INFO, "session %s: %u primitives, edit order %llu%s",
	       s->name, bc_tree_prim_count(s->tree),
	       (unsigned long long)s->order, l->created ? " (new)" : "");
	load_free(l);
}

/* ---- the table ------------------------------------------------------------ */

static void timer_closed(uv_handle_t *h)
{
	bc__session_unref(h->data);
}

/* The sweep timer is part of the table: the table goes once the loop has
 * closed it. */
static void sweep_closed(uv_handle_t *h)
{
	bc_free(h->data);
}

/* Takes s out of the table: its copy goes, and it is freed once its
 * timers and tasks are done. */
static void session_remove(struct bc_session *s)
{
	struct bc_sessions *ss = s->ss;
	struct bc_index_entry *e = bc__index_get(ss->index, s->name);
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (ss->sessions[i] == s) {
			ss->sessions[i] = NULL;
			ss->nsessions--;
		}
	}
	if (e && e->loaded == s) {
		e->loaded = NULL;
	}
	s->removed = true;
	ss->nodes_held -= s->nodes;
	s->nodes = 0;
	bc_work_drop(ss->work, s->id);
	uv_close((uv_handle_t *)&s->still_timer, timer_closed);
	uv_close((uv_handle_t *)&s->kick, timer_closed);
}

/* Whether s may be unloaded: no members, nobody waiting for it, nothing
 * running for it, and every applied edit in its journal (a session whose
 * storage failed stays, holding what it could not write). */
static bool unloadable(const struct bc_session *s)
{
	return s->nmembers == 0 && !s->busy && !s->park_head &&
	       !s->store_failed;
}

bool bc__session_unload(struct bc_session *s, const char *why)
{
	if (!unloadable(s)) {
		return false;
	}
	bc_log(BC_LOG_INFO,
	       "session %s unloaded (%s); it loads again when joined", s->name,
	       why);
	if (s->tree) {
		bc__index_note(s->ss->index, s);
	}
	session_remove(s);
	return true;
}

/* The session without members for longest that may be unloaded, other
 * than keep; with holding, only one that holds nodes. NULL for none. */
static struct bc_session *idlest(struct bc_sessions *ss,
                                 const struct bc_session *keep, bool holding)
{
	struct bc_session *oldest = NULL;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = ss->sessions[i];
		if (s && s != keep && unloadable(s) && (!holding || s->nodes) &&
		    (!oldest || s->empty_since_ms < oldest->empty_since_ms)) {
			oldest = s;
		}
	}
	return oldest;
}

/* A free slot in the table, unloading the session that has been without
 * members longest when there is none; BC_SRV_MAX_SESSIONS when every
 * session is in use. */
static uint32_t free_slot(struct bc_sessions *ss)
{
	struct bc_session *oldest;
	uint32_t slot = 0;
	while (slot < BC_SRV_MAX_SESSIONS && ss->sessions[slot]) {
		slot++;
	}
	if (slot < BC_SRV_MAX_SESSIONS) {
		return slot;
	}
	oldest = idlest(ss, NULL, false);
	if (!oldest || !bc__session_unload(oldest, "its place is needed")) {
		return BC_SRV_MAX_SESSIONS;
	}
	slot = 0;
	while (ss->sessions[slot]) {
		slot++;
	}
	return slot;
}

/* Nodes held by sessions that bc__room_take may unload for keep. */
static uint64_t unloadable_nodes(struct bc_sessions *ss,
                                 const struct bc_session *keep)
{
	uint64_t n = 0;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		const struct bc_session *s = ss->sessions[i];
		n += s && s != keep && unloadable(s) ? s->nodes : 0u;
	}
	return n;
}

int bc__room_take(struct bc_session *s, uint64_t after, uint64_t *taken,
                  struct bc_errinfo *ei)
{
	struct bc_sessions *ss = s->ss;
	uint64_t more = after > s->nodes ? after - s->nodes : 0, in_use;
	*taken = 0;
	if (!more) {
		return 0; /* what takes nodes away is never refused for room */
	}
	if (after > ss->nodes_cap) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "a scene of %" PRIu64 " nodes is more than this server "
		    "holds in all its sessions (%" PRIu64
		    " nodes, --scene-memory): a smaller scene, or a server "
		    "given more memory, takes it",
		    after, ss->nodes_cap);
	}
	/* Nothing is unloaded for a change that would not fit even so. */
	if (ss->starting && ss->nodes_held + more > ss->nodes_cap) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "the sessions restored before it hold %" PRIu64
		    " of the %" PRIu64
		    " scene nodes this server allows (--scene-memory)",
		    ss->nodes_held, ss->nodes_cap);
	}
	in_use = ss->nodes_held - unloadable_nodes(ss, s);
	if (in_use + more > ss->nodes_cap) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "sessions in use (with members or work under way) hold "
		    "%" PRIu64 " of the %" PRIu64 " scene nodes this server "
		    "allows (--scene-memory) and %" PRIu64 " more do not "
		    "fit: members must leave sessions or make their scenes "
		    "smaller first",
		    in_use, ss->nodes_cap, more);
	}
	while (ss->nodes_held + more > ss->nodes_cap) {
		struct bc_session *o = idlest(ss, s, true);
		if (!o || !bc__session_unload(o, "its memory is needed")) {
			return bc_errinfo_set(ei, BC_ELIMIT, "no room");
		}
	}
	ss->nodes_held += more;
	*taken = more;
	return 0;
}

/* The sessions other than s whose room comes free when their work ends
 * (without members, busy, holding nodes: a session being read from disk
 * holds none yet, and one whose storage failed never unloads): their
 * nodes in *soon, and the one holding most, or NULL for none. */
static struct bc_session *finishing(const struct bc_session *s, uint64_t *soon)
{
	struct bc_session *most = NULL;
	*soon = 0;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *o = s->ss->sessions[i];
		if (o && o != s && o->nmembers == 0 && o->busy && o->nodes &&
		    !o->store_failed) {
			*soon += o->nodes;
			most = !most || o->nodes > most->nodes ? o : most;
		}
	}
	return most;
}

bool bc__room_finishing(const struct bc_session *s)
{
	uint64_t soon;
	return finishing(s, &soon) != NULL;
}

struct bc_session *bc__room_busy(struct bc_session *s, uint64_t after)
{
	struct bc_sessions *ss = s->ss;
	struct bc_session *most;
	uint64_t more = after > s->nodes ? after - s->nodes : 0, in_use, soon;
	if (!more || after > ss->nodes_cap || ss->starting) {
		return NULL;
	}
	in_use = ss->nodes_held - unloadable_nodes(ss, s);
	if (in_use + more <= ss->nodes_cap) {
		return NULL;
	}
	most = finishing(s, &soon);
	return in_use - soon + more <= ss->nodes_cap ? most : NULL;
}

void bc__room_give(struct bc_sessions *ss, uint64_t *taken)
{
	ss->nodes_held -= *taken;
	*taken = 0;
}

void bc__room_settle(struct bc_session *s, uint64_t *taken)
{
	uint64_t n = s->tree ? bc_tree_node_count(s->tree) : 0;
	bc__room_give(s->ss, taken);
	s->ss->nodes_held = s->ss->nodes_held - s->nodes + n;
	s->nodes = n;
}

static void sweep_idle(uv_timer_t *t)
{
	struct bc_sessions *ss = t->data;
	uint64_t now = bc__now_ms(ss);
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = ss->sessions[i];
		if (!s) {
			continue; /* sessions leave the table as they go */
		}
		bc__session_copy_idle(s, now);
		bc__session_state_idle(s, now);
		if (!unloadable(s)) {
			continue;
		}
		if (s->lost) {
			bc__session_unload(s, "to load again what it saved");
		} else if (now - s->empty_since_ms >= BC_SRV_SESSION_IDLE_MS) {
			bc__session_unload(s, "no members for 15 minutes");
		}
	}
}

/* A session object for name in a free slot of the table, its load not
 * started. NULL with ei set when the table is full or out of memory. */
static struct bc_session *session_new(struct bc_sessions *ss, const char *name,
                                      struct bc_errinfo *ei)
{
	struct bc_session *s;
	struct bc_index_entry *e;
	uint32_t slot = free_slot(ss);
	if (slot == BC_SRV_MAX_SESSIONS) {
		bc_errinfo_set(ei, BC_ELIMIT, "at most %u sessions in use",
		               BC_SRV_MAX_SESSIONS);
		return NULL;
	}
	if (!(s = bc_calloc(1, sizeof(*s))) ||
	    !(e = bc__index_add(ss->index, name))) {
		bc_free(s);
		bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		return NULL;
	}
	s->ss = ss;
	snprintf(s->name, sizeof(s->name), "%s", name);
	bc_camera_default(&s->camera);
	s->id = ++ss->next_session_id;
	s->next_member_id = 1;
	s->empty_since_ms = bc__now_ms(ss);
	uv_timer_init(ss->loop, &s->still_timer);
	s->still_timer.data = s;
	uv_timer_init(ss->loop, &s->kick);
	s->kick.data = s;
	s->handles_open = 2;
	ss->sessions[slot] = s;
	ss->nsessions++;
	e->loaded = s;
	return s;
}

static struct load_task *load_task_new(struct bc_sessions *ss)
{
	struct load_task *l = bc_calloc(1, sizeof(*l));
	if (l) {
		l->store = ss->store;
		l->t.run = load_run;
		l->t.done = load_done;
		l->t.holds_order = true;
	}
	return l;
}

/* Opens session name now, on the loop (start-up, and new sessions, whose
 * default scene is small). */
static int session_open_now(struct bc_sessions *ss, const char *name,
                            struct bc_session **out, struct bc_errinfo *ei)
{
	struct bc_session *s = session_new(ss, name, ei);
	struct load_task *l;
	int rc;
	*out = NULL;
	if (!s) {
		return ei->code;
	}
	if (!(l = load_task_new(ss))) {
		session_remove(s);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	l->t.s = s;
	load_run(&l->t);
	load_room(s, l);
	if ((rc = l->rc)) {
		bc_errinfo_set(ei, rc, "%s", l->ei.msg);
		load_free(l);
		session_remove(s);
		return rc;
	}
	load_done(&l->t);
	*out = s;
	return 0;
}

/* Starts loading session name on a task; joiners park meanwhile. */
static int session_open_later(struct bc_sessions *ss, const char *name,
                              struct bc_session **out, struct bc_errinfo *ei)
{
	struct bc_session *s = session_new(ss, name, ei);
	struct load_task *l;
	*out = NULL;
	if (!s) {
		return ei->code;
	}
	if (!(l = load_task_new(ss))) {
		session_remove(s);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	bc__task_start(s, &l->t);
	*out = s;
	return 0;
}

/* ---- the layer ------------------------------------------------------------ */

int bc_sessions_new(struct bc_sessions **out,
                    const struct bc_sessions_opts *opts, struct bc_errinfo *ei)
{
	struct bc_sessions *ss = bc_calloc(1, sizeof(*ss));
	struct bc_session *s;
	uint32_t n, sweep_ms;
	int rc;
	*out = NULL;
	if (!ss) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	ss->loop = opts->loop;
	ss->link = opts->link;
	ss->work = opts->work;
	ss->store = opts->store;
	ss->no_damage = opts->no_damage;
	ss->video = opts->video;
	ss->max_scene_bytes =
	    opts->max_scene_bytes &&
	            opts->max_scene_bytes < BC_SRV_MAX_SCENE_BYTES_LIMIT
	        ? opts->max_scene_bytes
	    : opts->max_scene_bytes ? BC_SRV_MAX_SCENE_BYTES_LIMIT
	                            : BC_SRV_MAX_SCENE_BYTES;
	if ((rc = bc__index_new(&ss->index, ss->store))) {
		bc_free(ss);
		return bc_errinfo_set(ei, rc, "cannot list the sessions");
	}
	ss->render_idle_ms =
	    opts->render_idle_ms ? opts->render_idle_ms : BC_SRV_RENDER_IDLE_MS;
	ss->nodes_cap = opts->scene_nodes ? opts->scene_nodes : UINT64_MAX;
	sweep_ms = ss->render_idle_ms / 4u < BC_SRV_SESSION_SWEEP_MS
	               ? ss->render_idle_ms / 4u
	               : BC_SRV_SESSION_SWEEP_MS;
	sweep_ms = sweep_ms < 50u ? 50u : sweep_ms;
	*out = ss;
	uv_timer_init(ss->loop, &ss->sweep);
	ss->sweep.data = ss;
	uv_timer_start(&ss->sweep, sweep_idle, sweep_ms, sweep_ms);
	/* "default" first, always there unless its scene alone passes
	 * --scene-memory (it then loads when joined, refused); then the
	 * other sessions on disk up to the table's size and the scene
	 * memory, the rest when joined. */
	ss->starting = true;
	if ((rc = session_open_now(ss, "default", &s, ei)) == BC_ELIMIT) {
		bc_log(BC_LOG_WARN, "session default stays on disk: %s",
		       ei->msg);
	} else if (rc) {
		return rc;
	}
	n = bc__index_count(ss->index);
	for (uint32_t i = 0; i < n && ss->nsessions < BC_SRV_MAX_SESSIONS;
	     i++) {
		struct bc_errinfo e = {0};
		const char *name = bc__index_at(ss->index, i)->name;
		if (strcmp(name, "default") == 0) {
			continue;
		}
		if ((rc = session_open_now(ss, name, &s, &e)) == BC_ELIMIT) {
			bc_log(BC_LOG_INFO,
			       "session %s stays on disk until joined: %s",
			       name, e.msg);
		} else if (rc) {
			bc_log(BC_LOG_ERROR, "cannot restore session %s: %s",
			       name, e.msg);
		}
	}
	ss->starting = false;
	return 0;
}

/* The session's history in the form a snapshot keeps (undo.c); without
 * memory for it the snapshot goes on and the history before it is lost
 * on a restart, logged. */
static void carry(struct bc_session *s, uint8_t **hist, size_t *hlen)
{
	if (bc__undo_carry(s->undo, s->tree, hist, hlen)) {
		bc_log(BC_LOG_WARN,
		       "session %s: no memory to keep the undo history with "
		       "its snapshot",
		       s->name);
	}
}

void bc_sessions_save_all(struct bc_sessions *ss, uint32_t budget_ms)
{
	double end = bc_clock_ms() + budget_ms;
	ss->stopping = true;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = ss->sessions[i];
		struct bc_errinfo ei = {0};
		if (!s || !s->tree || s->store_failed || s->lost || s->busy ||
		    bc_store_journal_records(s->store) == 0) {
			continue;
		}
		/* A big scene's snapshot alone could pass the time the stop
		 * has; its journal restores it just the same. */
		if (bc_clock_ms() >= end ||
		    bc_tree_node_count(s->tree) >= BC_SRV_HEAVY_NODES) {
			bc_log(BC_LOG_INFO,
			       "session %s: left to its journal (no time to "
			       "save it whole)",
			       s->name);
			continue;
		}
		uint8_t *hist = NULL;
		size_t hlen = 0;
		carry(s, &hist, &hlen);
		if (bc_store_snapshot_with(s->store, s->tree, &s->camera,
		                           s->order, hist, hlen, &ei)) {
			bc_log(BC_LOG_ERROR, "session %s: %s", s->name, ei.msg);
		}
		bc_free(hist);
	}
}

void bc_sessions_free(struct bc_sessions *ss)
{
	if (!ss) {
		return;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (ss->sessions[i]) {
			ss->sessions[i]->park_head = NULL;
			ss->sessions[i]->nmembers = 0;
			session_remove(ss->sessions[i]);
		}
	}
	bc__meshes_free(ss);
	bc__index_free(ss->index);
	ss->index = NULL;
	/* The sessions themselves go as their handles close, the table with
	 * its sweep timer. */
	uv_close((uv_handle_t *)&ss->sweep, sweep_closed);
}

void bc_sessions_stats(const struct bc_sessions *ss,
                       struct bc_sessions_stats *out)
{
	out->sessions = ss->nsessions;
	out->render_ms_last = ss->render_ms_last;
	out->render_ms_avg = ss->render_ms_avg;
	out->encode_ms_last = ss->encode_ms_last;
	out->encode_ms_avg = ss->encode_ms_avg;
	out->nodes_held = ss->nodes_held;
	out->nodes_cap = ss->nodes_cap;
}

/* ---- requests ------------------------------------------------------------ */

/* The name of a session request, checked and NUL-terminated into name.
 * Returns false after answering. */
static bool name_of(struct bc_member *m, uint32_t seq,
                    const struct bc_proto_str *n, int code, char *name)
{
	if (!bc_store_name_ok(n->ptr, n->len)) {
		bc__send_error(m, seq, code,
		               "session names use letters, digits, '-', '_' "
		               "and '.', not starting with '.'");
		return false;
	}
	memcpy(name, n->ptr, n->len);
	name[n->len] = '\0';
	return true;
}

int bc_handle_session(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_sessions *ss = m->ss;
	const struct bc_msg_session *req = &msg->session;
	bool create = msg->type == BC_MSG_SESSION_CREATE;
	struct bc_session *s;
	struct bc_errinfo ei = {0};
	char name[BC_PROTO_MAX_NAME + 1];
	int rc;
	if ((req->role == BC_PROTO_ROLE_EDITOR || create) &&
	    m->peer->max_role != BC_PROTO_ROLE_EDITOR) {
		bc__send_error(m, msg->seq, BC_EPERM,
		               "your token grants the viewer role only%s",
		               create ? ", which cannot create sessions" : "");
		return 0;
	}
	if (!name_of(m, msg->seq, &req->name, BC_EINVAL, name)) {
		return 0;
	}
	s = bc__session_by_name(ss, name, req->name.len);
	if (create && s && bc_conn_ref_eq(s->creator, m->peer->ref)) {
		/* Its own CREATE, come again once the session loaded. */
		create = false;
	} else if (create && (s || bc_store_session_exists(ss->store, name))) {
		bc__send_error(m, msg->seq, BC_EEXIST, "session %s exists",
		               name);
		return 0;
	}
	if (!s && !create && !bc__index_get(ss->index, name)) {
		bc__send_error(m, msg->seq, BC_ENOSESSION,
		               "no session named %s", name);
		return 0;
	}
	/* A new session, or one not loaded: the member waits for it. */
	if (!s) {
		if (session_open_later(ss, name, &s, &ei)) {
			bc__send_error(m, msg->seq, ei.code, "%s", ei.msg);
			return 0;
		}
		s->creator = create ? m->peer->ref : (struct bc_conn_ref){0, 0};
		if (create) {
			memcpy(s->owner, m->peer->name, sizeof(s->owner));
		}
	}
	rc = bc__join(m, s, req->role, msg->seq);
	if (rc == 0 && bc_conn_ref_eq(s->creator, m->peer->ref)) {
		s->creator = (struct bc_conn_ref){0, 0};
	}
	return rc;
}

int bc_handle_leave(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_msg ok = {.type = BC_MSG_OK, .seq = msg->seq};
	bc__leave(m);
	bc__send(m, &ok);
	return 0;
}

/* Sends every member of s back to READY, telling why. */
static void evict_members(struct bc_session *s, const struct bc_member *by,
                          const char *name)
{
	struct bc_member *list[BC_PROTO_MAX_MEMBERS];
	uint32_t n = bc__members(s, list);
	bc__present_session_gone(s);
	for (uint32_t i = 0; i < n; i++) {
		bc__send_error(list[i], 0, BC_ENOSESSION,
		               "session %s was deleted by %s", name,
		               by->peer->name[0] ? by->peer->name : "a client");
		bc__leave(list[i]);
	}
}

int bc_handle_session_delete(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_sessions *ss = m->ss;
	struct bc_session *s;
	struct bc_errinfo ei = {0};
	char name[BC_PROTO_MAX_NAME + 1];
	if (m->peer->max_role != BC_PROTO_ROLE_EDITOR) {
		bc__send_error(m, msg->seq, BC_EPERM,
		               "your token grants the viewer role only, which "
		               "cannot delete sessions");
		return 0;
	}
	if (!name_of(m, msg->seq, &msg->session_delete.name, BC_ENOSESSION,
	             name)) {
		return 0;
	}
	s = bc__session_by_name(ss, name, strlen(name));
	if (!s && !bc__index_get(ss->index, name)) {
		bc__send_error(m, msg->seq, BC_ENOSESSION,
		               "no session named %s", name);
		return 0;
	}
	if (s && (s->busy || s->park_head)) {
		return bc__park(s, m, msg->seq);
	}
	if (s) {
		evict_members(s, m, name);
		session_remove(s);
	}
	if (bc_store_session_delete(ss->store, name, &ei)) {
		bc_log(BC_LOG_ERROR, "session %s: %s", name, ei.msg);
		bc__send_error(m, msg->seq, ei.code, "%s", ei.msg);
		return 0;
	}
	bc__index_remove(ss->index, name);
	bc_log(BC_LOG_INFO, "session %s deleted by connection %u (%s)", name,
	       m->peer->ref.gen, m->peer->name);
	bc_link_ok(ss->link, m->peer->ref, msg->seq);
	return 0;
}

/* SESSIONS's entry for index entry e. */
static void list_entry(const struct bc_index_entry *e,
                       struct bc_proto_session_entry *out)
{
	const struct bc_session *s = e->loaded;
	memset(out, 0, sizeof(*out));
	out->name.ptr = e->name;
	out->name.len = (uint32_t)strlen(e->name);
	if (s && s->tree) {
		out->members = (uint16_t)s->nmembers;
		out->prims = bc_tree_prim_count(s->tree);
		out->order = s->order;
		out->last_edit_ms = s->last_edit_ms;
		out->flags = BC_PROTO_SESSION_LOADED | BC_PROTO_SESSION_KNOWN;
	} else if (e->known) {
		out->prims = e->prims;
		out->order = e->order;
		out->last_edit_ms = e->last_edit_ms;
		out->flags = BC_PROTO_SESSION_KNOWN;
	}
}

int bc_handle_session_list(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_sessions *ss = m->ss;
	struct bc_msg out = {.type = BC_MSG_SESSIONS, .seq = msg->seq};
	uint32_t n = bc__index_count(ss->index);
	struct bc_proto_session_entry *e;
	/* The index is kept in name order: the first entries are the
	 * answer, without a look at the disk. */
	if (n > BC_PROTO_MAX_SESSIONS_LISTED) {
		n = BC_PROTO_MAX_SESSIONS_LISTED;
	}
	if (!(e = bc_calloc(n ? n : 1, sizeof(*e)))) {
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "the server is out of memory");
		return 0;
	}
	for (uint32_t i = 0; i < n; i++) {
		list_entry(bc__index_at(ss->index, i), &e[i]);
	}
	out.sessions.nsessions = (uint16_t)n;
	out.sessions.sessions = e;
	bc__send(m, &out);
	bc_free(e);
	return 0;
}

/* ---- snapshots on a task ------------------------------------------------- */

struct snap_task {
	struct bc_task t;
	int rc;
	struct bc_errinfo ei;
};

/* How much lower a snapshot's thread runs than the daemon's others. */
#define SNAPSHOT_NICE 10

static void snap_write(void *arg)
{
	struct snap_task *st = arg;
	struct bc_session *s = st->t.s;
	uint8_t *hist = NULL;
	size_t hlen = 0;
	carry(s, &hist, &hlen);
	st->rc = bc_store_snapshot_due_with(s->store, BC_SRV_SNAPSHOT_EVERY,
	                                    s->tree, &s->camera, s->order, hist,
	                                    hlen, &st->ei);
	bc_free(hist);
}

static void snap_write_niced(void *arg)
{
	/* Linux: the calling thread's nice value only. Advice: a snapshot
	 * that cannot lower itself is written all the same. */
	(void)setpriority(PRIO_PROCESS, 0,
	                  getpriority(PRIO_PROCESS, 0) + SNAPSHOT_NICE);
	snap_write(arg);
}

/* The snapshot is written by a thread of its own at a lower priority (a
 * million primitives' JSON was seconds of CPU, and held back the first
 * frame of the scene just loaded on two cores; the binary form is a
 * fraction of that, and still an encoding and a write of 40 MB), which
 * this task waits for. */
static void snap_run(struct bc_task *t)
{
	struct snap_task *st = (struct snap_task *)t;
	uv_thread_t th;
	/* The session is busy: nothing changes its tree, history or
	 * store. */
	if (!bc_store_snapshot_is_due(t->s->store, BC_SRV_SNAPSHOT_EVERY)) {
		return;
	}
	if (uv_thread_create(&th, snap_write_niced, st) == 0) {
		uv_thread_join(&th);
	} else {
		snap_write(st);
	}
}

static void snap_done(struct bc_task *t)
{
	bc_free(t);
}

void bc__session_snapshot_due(struct bc_session *s)
{
	struct snap_task *st;
	if (s->lost ||
	    !bc_store_snapshot_is_due(s->store, BC_SRV_SNAPSHOT_EVERY) ||
	    s->ss->stopping || !(st = bc_calloc(1, sizeof(*st)))) {
		return;
	}
	st->t.run = snap_run;
	st->t.done = snap_done;
	st->t.holds_order = true;
	bc__task_start(s, &st->t);
}

void bc__session_changed(struct bc_session *s)
{
	bc_shared_unref(s->state_msg);
	s->state_msg = NULL;
}

/* ---- member figures ------------------------------------------------------- */

uint64_t bc_member_order(const struct bc_member *m)
{
	return m->session ? m->session->order : 0;
}

double bc_member_edit_ms(const struct bc_member *m)
{
	return m->session ? m->session->edit_ms_avg : 0.0;
}

uint32_t bc_member_session_id(const struct bc_member *m)
{
	return m->session ? m->session->id : 0;
}

uint64_t bc_member_session_nodes(const struct bc_member *m)
{
	return m->session ? m->session->nodes : 0;
}
