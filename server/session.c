/*
 * Sessions (loop thread): their lifecycle (open, restore from the store,
 * save, unload when idle, delete, free), their members (join, leave,
 * SESSION_INFO, SCENE_STATE) and
 * the table that routes a client's requests to their handlers: edits.c
 * (EDIT, SCENE_LOAD), frames.c (CAMERA, VIEW, PICK, SNAPSHOT and frame
 * scheduling) and the session and STATS handlers here.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "server.h"

struct bc_session *bc_session_by_id(struct bc_srv *srv, uint32_t id)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (srv->sessions[i] && srv->sessions[i]->id == id) {
			return srv->sessions[i];
		}
	}
	return NULL;
}

static struct bc_session *session_by_name(struct bc_srv *srv, const char *name,
                                          size_t len)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		if (s && strlen(s->name) == len &&
		    memcmp(s->name, name, len) == 0) {
			return s;
		}
	}
	return NULL;
}

uint64_t bc_unix_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

/* ---- what is known of unloaded sessions ---------------------------------- */

static struct bc_session_summary *summary_of(struct bc_srv *srv,
                                             const char *name)
{
	for (uint32_t i = 0; i < srv->nunloaded; i++) {
		if (strcmp(srv->unloaded[i].name, name) == 0) {
			return &srv->unloaded[i];
		}
	}
	return NULL;
}

static void summary_forget(struct bc_srv *srv, const char *name)
{
	struct bc_session_summary *s = summary_of(srv, name);
	if (s) {
		*s = srv->unloaded[--srv->nunloaded];
	}
}

/* Remembers what SESSIONS says of s once it is unloaded (best effort: out
 * of memory, it is listed without details). */
static void summary_keep(struct bc_session *s)
{
	struct bc_srv *srv = s->srv;
	struct bc_session_summary *sum = summary_of(srv, s->name);
	if (!sum) {
		if (srv->nunloaded == srv->unloaded_cap) {
			uint32_t cap =
			    srv->unloaded_cap ? 2u * srv->unloaded_cap : 16u;
			struct bc_session_summary *more =
			    bc_realloc(srv->unloaded, cap * sizeof(*more));
			if (!more) {
				return;
			}
			srv->unloaded = more;
			srv->unloaded_cap = cap;
		}
		sum = &srv->unloaded[srv->nunloaded++];
	}
	snprintf(sum->name, sizeof(sum->name), "%s", s->name);
	sum->prims = bc_tree_prim_count(s->tree);
	sum->order = s->order;
	sum->last_edit_ms = s->last_edit_ms;
}

/* ---- sessions ------------------------------------------------------------ */

struct replay_ctx {
	struct bc_srv *srv;
	struct bc_tree **tree;
	struct bc_camera *camera;
};

static int replay_record(void *ud, uint64_t order, const uint8_t *rec,
                         size_t len)
{
	struct replay_ctx *ctx = ud;
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bc_errinfo ei = {0};
	struct bc_edit_batch b;
	int rc;
	(void)order;
	/* A SESSION_CAMERA record (present.c) or an EDIT. */
	if ((rc = bc_present_camera_record(rec, len, ctx->camera)) != 0) {
		return rc < 0 ? rc : 0;
	}
	bc_proto_reader_init(&r, NULL);
	rc = bc_proto_decode_payload(&r, BC_MSG_EDIT, 0, 0, rec, len, &m, &ei);
	if (!rc) {
		rc = bc_edit_batch_apply(&b, ctx->tree, m.edit.ops, m.edit.nops,
		                         &ei);
		bc_edit_batch_finish(&b);
	}
	if (rc) {
		bc_log(BC_LOG_ERROR, "journal replay: %s", ei.msg);
	}
	bc_proto_reader_finish(&r);
	return rc;
}

static void free_session(struct bc_session *s)
{
	bc_undo_clear(s);
	bc_store_session_close(s->store);
	bc_tree_destroy(s->tree);
	bc_free(s);
}

void bc_session_unref(struct bc_session *s)
{
	if (--s->handles_open == 0) {
		free_session(s);
	}
}

static void still_closed(uv_handle_t *h)
{
	bc_session_unref(h->data);
}

/* Takes s out of the server (it has no members left): its replica goes,
 * and it is freed once its timers have closed. */
static void session_remove(struct bc_session *s)
{
	struct bc_srv *srv = s->srv;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (srv->sessions[i] == s) {
			srv->sessions[i] = NULL;
			srv->nsessions--;
		}
	}
	s->removed = true;
	bc_rthread_drop(srv, s->id);
	uv_close((uv_handle_t *)&s->still_timer, still_closed);
	uv_close((uv_handle_t *)&s->kick, still_closed);
}

/* Whether s may be unloaded: it has no members, and every applied edit
 * is in its journal (a session whose storage failed stays, holding what it
 * could not write; one being loaded waits for its load). */
static bool unloadable(const struct bc_session *s)
{
	return s->nmembers == 0 && !s->store_failed && !s->loading;
}

/* Unloads s when unloadable(): a JOIN restores it as it was. */
static bool session_unload(struct bc_session *s, const char *why)
{
	if (!unloadable(s)) {
		return false;
	}
	bc_log(BC_LOG_INFO,
	       "session %s unloaded (%s); it loads again when joined", s->name,
	       why);
	summary_keep(s);
	session_remove(s);
	return true;
}

/* A free slot in the session table, unloading the session that has been
 * without members longest when there is none; BC_SRV_MAX_SESSIONS when
 * every session has members. */
static uint32_t free_slot(struct bc_srv *srv)
{
	struct bc_session *oldest = NULL;
	uint32_t slot = 0;
	while (slot < BC_SRV_MAX_SESSIONS && srv->sessions[slot]) {
		slot++;
	}
	if (slot < BC_SRV_MAX_SESSIONS) {
		return slot;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		if (unloadable(s) &&
		    (!oldest || s->empty_since_ms < oldest->empty_since_ms)) {
			oldest = s;
			slot = i;
		}
	}
	if (!oldest || !session_unload(oldest, "its place is needed")) {
		return BC_SRV_MAX_SESSIONS;
	}
	return slot;
}

static void sweep_idle(uv_timer_t *t)
{
	struct bc_srv *srv = t->data;
	uint64_t now = bc_now_ms(srv);
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		if (s && unloadable(s) &&
		    now - s->empty_since_ms >= BC_SRV_SESSION_IDLE_MS) {
			session_unload(s, "no members for 15 minutes");
		}
	}
}

/* Opens (or creates, with the default scene) session name. */
static int session_open(struct bc_srv *srv, const char *name,
                        struct bc_session **out, struct bc_errinfo *ei)
{
	struct bc_session *s;
	struct replay_ctx ctx;
	bool created;
	uint32_t slot = 0;
	struct bc_tree *copy;
	int rc;
	*out = NULL;
	if ((slot = free_slot(srv)) == BC_SRV_MAX_SESSIONS) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "at most %u sessions with members",
		                      BC_SRV_MAX_SESSIONS);
	}
	if (!(s = bc_calloc(1, sizeof(*s))) || !(s->tree = bc_tree_create())) {
		bc_free(s);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	s->srv = srv;
	snprintf(s->name, sizeof(s->name), "%s", name);
	bc_camera_default(&s->camera);
	ctx.srv = srv;
	ctx.tree = &s->tree;
	ctx.camera = &s->camera;
	rc = bc_store_session_open(srv->store, name, &s->store, s->tree,
	                           &s->camera, &s->order, &created,
	                           replay_record, &ctx, ei);
	if (rc) {
		free_session(s);
		return rc;
	}
	if (created) {
		const char *json = bc_scene_default_json();
		if ((rc = bc_scene_parse_json(json, strlen(json), s->tree,
		                              &s->camera, ei)) ||
		    (rc = bc_store_snapshot(s->store, s->tree, &s->camera, 0,
		                            ei))) {
			free_session(s);
			return rc;
		}
	}
	if (!(copy = bc_tree_create()) || bc_tree_copy(copy, s->tree, NULL)) {
		bc_tree_destroy(copy);
		free_session(s);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	s->id = ++srv->next_session_id;
	s->next_member_id = 1;
	s->last_edit_ms = bc_store_session_mtime_ms(s->store);
	summary_forget(srv, name);
	s->empty_since_ms = bc_now_ms(srv);
	uv_timer_init(srv->loop, &s->still_timer);
	s->still_timer.data = s;
	uv_timer_init(srv->loop, &s->kick);
	s->kick.data = s;
	s->handles_open = 2;
	srv->sessions[slot] = s;
	srv->nsessions++;
	bc_rthread_scene(srv, s->id, copy);
	bc_log(BC_LOG_INFO, "session %s: %u primitives, edit order %llu%s",
	       name, bc_tree_prim_count(s->tree), (unsigned long long)s->order,
	       created ? " (new)" : "");
	*out = s;
	return 0;
}

static void restore_one(void *ud, const char *name)
{
	struct bc_srv *srv = ud;
	struct bc_session *s;
	struct bc_errinfo ei = {0};
	if (session_open(srv, name, &s, &ei)) {
		bc_log(BC_LOG_ERROR, "cannot restore session %s: %s", name,
		       ei.msg);
	}
}

int bc_sessions_restore(struct bc_srv *srv, struct bc_errinfo *ei)
{
	struct bc_session *s;
	uv_timer_init(srv->loop, &srv->session_sweep);
	srv->session_sweep.data = srv;
	uv_timer_start(&srv->session_sweep, sweep_idle, BC_SRV_SESSION_SWEEP_MS,
	               BC_SRV_SESSION_SWEEP_MS);
	bc_store_list(srv->store, restore_one, srv);
	if (!session_by_name(srv, "default", 7)) {
		return session_open(srv, "default", &s, ei);
	}
	return 0;
}

void bc_sessions_save_all(struct bc_srv *srv)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		struct bc_errinfo ei = {0};
		/* A load in flight writes its own snapshot. */
		if (!s || s->store_failed || s->loading ||
		    bc_store_journal_records(s->store) == 0) {
			continue;
		}
		if (bc_store_snapshot(s->store, s->tree, &s->camera, s->order,
		                      &ei)) {
			bc_log(BC_LOG_ERROR, "session %s: %s", s->name, ei.msg);
		}
	}
}

void bc_sessions_free(struct bc_srv *srv)
{
	if (srv->session_sweep.data) {
		uv_close((uv_handle_t *)&srv->session_sweep, NULL);
		srv->session_sweep.data = NULL;
	}
	bc_free(srv->unloaded);
	srv->unloaded = NULL;
	srv->nunloaded = srv->unloaded_cap = 0;
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (srv->sessions[i]) {
			srv->sessions[i]->removed = true;
			uv_close((uv_handle_t *)&srv->sessions[i]->still_timer,
			         still_closed);
			uv_close((uv_handle_t *)&srv->sessions[i]->kick,
			         still_closed);
			srv->sessions[i] = NULL;
		}
	}
}

/* ---- members ------------------------------------------------------------- */

uint32_t bc_session_members(const struct bc_session *s, struct bc_conn_ref *out)
{
	memcpy(out, s->members, s->nmembers * sizeof(*out));
	return s->nmembers;
}

void bc_session_send_info(struct bc_session *s)
{
	struct bc_proto_member members[BC_PROTO_MAX_MEMBERS];
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	uint32_t n = 0, nrefs;
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_conn *m = bc_conn_get(s->srv, s->members[i]);
		if (m) {
			members[n].id = m->member_id;
			members[n].role = m->role;
			members[n].name.ptr = m->name;
			members[n].name.len = (uint32_t)strlen(m->name);
			n++;
		}
	}
	nrefs = bc_session_members(s, refs);
	for (uint32_t i = 0; i < nrefs; i++) {
		struct bc_conn *m = bc_conn_get(s->srv, refs[i]);
		struct bc_msg info = {.type = BC_MSG_SESSION_INFO};
		if (!m || n == 0) {
			continue;
		}
		info.session_info.session_id = s->id;
		info.session_info.member_id = m->member_id;
		info.session_info.role = m->role;
		info.session_info.name.ptr = s->name;
		info.session_info.name.len = (uint32_t)strlen(s->name);
		info.session_info.nmembers = (uint16_t)n;
		info.session_info.members = members;
		bc_conn_send(m, &info);
	}
}

void bc_session_send_state(struct bc_session *s, struct bc_conn *to,
                           uint32_t author, uint32_t author_seq)
{
	uint8_t *bytes = NULL;
	size_t len = 0;
	if (bc_scene_encode(s->tree, &s->camera, &bytes, &len)) {
		bc_log(BC_LOG_ERROR, "session %s: cannot encode the scene",
		       s->name);
		return;
	}
	bc_session_send_state_bytes(s, to, author, author_seq, bytes, len);
	bc_free(bytes);
}

void bc_session_send_state_bytes(struct bc_session *s, struct bc_conn *to,
                                 uint32_t author, uint32_t author_seq,
                                 const uint8_t *bytes, size_t len)
{
	struct bc_msg st = {.type = BC_MSG_SCENE_STATE};
	st.scene_state.order = s->order;
	st.scene_state.author = author;
	st.scene_state.author_seq = author_seq;
	st.scene_state.scene.ptr = bytes;
	st.scene_state.scene.len = (uint32_t)len;
	if (to) {
		bc_conn_send(to, &st);
	} else {
		struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
		uint32_t n = bc_session_members(s, refs);
		for (uint32_t i = 0; i < n; i++) {
			struct bc_conn *m = bc_conn_get(s->srv, refs[i]);
			if (m) {
				bc_conn_send(m, &st);
			}
		}
	}
}

void bc_session_leave(struct bc_conn *c)
{
	struct bc_session *s = c->session;
	struct bc_conn_ref me = bc_conn_ref_of(c);
	if (!s) {
		return;
	}
	bc_present_leave(c);
	for (uint32_t i = 0; i < s->nmembers; i++) {
		if (s->members[i].slot == me.slot &&
		    s->members[i].gen == me.gen) {
			s->members[i] = s->members[--s->nmembers];
			break;
		}
	}
	c->session = NULL;
	c->stage = BC_PROTO_STAGE_READY;
	c->role = BC_PROTO_ROLE_INVALID;
	c->render_pending = false;
	/* When c is closing, its queued renders serve nobody once it is
	 * gone (a client still connected keeps its PICK and SNAPSHOT
	 * answers). */
	bc_rthread_sweep_soon(s->srv);
	if (s->nmembers == 0) {
		s->empty_since_ms = bc_now_ms(s->srv);
	}
	bc_session_send_info(s);
}

void bc_session_mark_all(struct bc_session *s)
{
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_conn *m = bc_conn_get(s->srv, s->members[i]);
		if (m) {
			m->shown.view = 0; /* the next frame is whole */
			m->dirty = true;
		}
	}
}

static void join(struct bc_conn *c, struct bc_session *s,
                 enum bc_proto_role role, uint32_t seq)
{
	(void)seq;
	if (s->nmembers >= BC_PROTO_MAX_MEMBERS) {
		bc_conn_send_error(c, seq, BC_ELIMIT, false,
		                   "session %s is full (%u members)", s->name,
		                   BC_PROTO_MAX_MEMBERS);
		return;
	}
	if (c->session) {
		bc_session_leave(c);
	}
	s->members[s->nmembers++] = bc_conn_ref_of(c);
	c->session = s;
	c->member_id = s->next_member_id++;
	c->role = role;
	c->stage = BC_PROTO_STAGE_SESSION;
	/* A camera the client chose (even before joining) stays its own. */
	if (!c->has_camera) {
		c->camera = s->camera;
		c->camera_seq = 0;
	}
	c->shown.view = 0;
	c->dirty = true;
	bc_session_send_info(s);
	bc_session_send_state(s, c, 0, 0);
	bc_present_joined(c);
	bc_session_schedule(s);
}

void bc_handle_session(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	const struct bc_msg_session *req = &m->session;
	struct bc_session *s =
	    session_by_name(srv, req->name.ptr, req->name.len);
	struct bc_errinfo ei = {0};
	char name[BC_PROTO_MAX_NAME + 1];
	if ((req->role == BC_PROTO_ROLE_EDITOR ||
	     m->type == BC_MSG_SESSION_CREATE) &&
	    c->max_role != BC_PROTO_ROLE_EDITOR) {
		bc_conn_send_error(c, m->seq, BC_EPERM, false,
		                   "your token grants the viewer role only%s",
		                   m->type == BC_MSG_SESSION_CREATE
		                       ? ", which cannot create sessions"
		                       : "");
		return;
	}
	if (!bc_store_name_ok(req->name.ptr, req->name.len)) {
		bc_conn_send_error(c, m->seq, BC_EINVAL, false,
		                   "session names use letters, digits, '-', "
		                   "'_' and '.', not starting with '.'");
		return;
	}
	memcpy(name, req->name.ptr, req->name.len);
	name[req->name.len] = '\0';
	if (m->type == BC_MSG_SESSION_CREATE &&
	    (s || bc_store_session_exists(srv->store, name))) {
		bc_conn_send_error(c, m->seq, BC_EEXIST, false,
		                   "session %s exists", name);
		return;
	}
	if (!s && m->type == BC_MSG_SESSION_JOIN &&
	    !bc_store_session_exists(srv->store, name)) {
		bc_conn_send_error(c, m->seq, BC_ENOSESSION, false,
		                   "no session named %s", name);
		return;
	}
	/* A new session, or one unloaded while it had no members. */
	if (!s && session_open(srv, name, &s, &ei)) {
		bc_conn_send_error(c, m->seq, ei.code, false, "%s", ei.msg);
		return;
	}
	join(c, s, req->role, m->seq);
}

void bc_handle_session_delete(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	const struct bc_proto_str *n = &m->session_delete.name;
	struct bc_session *s = session_by_name(srv, n->ptr, n->len);
	struct bc_msg ok = {.type = BC_MSG_OK, .seq = m->seq};
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	struct bc_errinfo ei = {0};
	char name[BC_PROTO_MAX_NAME + 1];
	uint32_t nrefs;
	if (c->max_role != BC_PROTO_ROLE_EDITOR) {
		bc_conn_send_error(c, m->seq, BC_EPERM, false,
		                   "your token grants the viewer role only, "
		                   "which cannot delete sessions");
		return;
	}
	if (!bc_store_name_ok(n->ptr, n->len)) {
		bc_conn_send_error(c, m->seq, BC_ENOSESSION, false,
		                   "no session has that name");
		return;
	}
	memcpy(name, n->ptr, n->len);
	name[n->len] = '\0';
	if (!s && !bc_store_session_exists(srv->store, name)) {
		bc_conn_send_error(c, m->seq, BC_ENOSESSION, false,
		                   "no session named %s", name);
		return;
	}
	if (s && s->loading) {
		bc_conn_send_error(c, m->seq, BC_EBUSY, false,
		                   "session %s is loading a scene; retry after "
		                   "its SCENE_STATE",
		                   name);
		return;
	}
	if (s) {
		/* The presentation goes with the session, untold. */
		s->presenter_id = 0;
		/* Members first hear why they are back in READY. */
		nrefs = bc_session_members(s, refs);
		for (uint32_t i = 0; i < nrefs; i++) {
			struct bc_conn *mc = bc_conn_get(srv, refs[i]);
			if (!mc) {
				continue;
			}
			bc_conn_send_error(mc, 0, BC_ENOSESSION, false,
			                   "session %s was deleted by %s", name,
			                   c->name[0] ? c->name : "a client");
			bc_session_leave(mc);
		}
		s->nmembers = 0; /* members already closing are gone too */
		session_remove(s);
	}
	if (bc_store_session_delete(srv->store, name, &ei)) {
		bc_log(BC_LOG_ERROR, "session %s: %s", name, ei.msg);
		bc_conn_send_error(c, m->seq, ei.code, false, "%s", ei.msg);
		return;
	}
	summary_forget(srv, name);
	bc_log(BC_LOG_INFO, "session %s deleted by connection %u (%s)", name,
	       c->gen, c->name);
	bc_conn_send(c, &ok);
}

void bc_handle_stats(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	struct bc_msg st = {.type = BC_MSG_STATS, .seq = m->seq};
	uint64_t now = bc_now_ms(srv);
	double secs =
	    c->first_frame_ms ? (double)(now - c->first_frame_ms) / 1e3 : 0.0;
	st.stats.uptime_ms = now - srv->started_ms;
	st.stats.frames = c->frames_sent;
	st.stats.bytes = c->bytes_sent;
	st.stats.order = c->session ? c->session->order : 0;
	st.stats.sessions = srv->nsessions;
	st.stats.clients = srv->nclients;
	st.stats.render_ms_last = (float)srv->render_ms_last;
	st.stats.render_ms_avg = (float)srv->render_ms_avg;
	st.stats.encode_ms_last = (float)srv->encode_ms_last;
	st.stats.encode_ms_avg = (float)srv->encode_ms_avg;
	st.stats.edit_ms_avg =
	    c->session ? (float)c->session->edit_ms_avg : 0.0f;
	st.stats.fps =
	    secs > 0.0 ? (float)((double)c->frames_sent / secs) : 0.0f;
	if (m->get_stats.parts & BC_PROTO_STATS_LOAD) {
		st.stats.has_load = true;
		st.stats.load.render_workers = 1;
		st.stats.load.view_cap = BC_SRV_VIEW_BYTES;
	}
	bc_conn_send(c, &st);
}

/* SESSION_LIST: the sessions loaded, then those on disk, by name. */
struct listing {
	struct bc_srv *srv;
	struct bc_proto_session_entry *e;
	char (*names)[BC_PROTO_MAX_NAME + 1];
	uint32_t n, cap;
	bool oom;
};

static struct bc_proto_session_entry *listing_add(struct listing *l,
                                                  const char *name)
{
	struct bc_proto_session_entry *e;
	if (l->n == l->cap) {
		uint32_t cap = l->cap ? 2u * l->cap : 64u;
		struct bc_proto_session_entry *more =
		    bc_realloc(l->e, cap * sizeof(*more));
		char(*names)[BC_PROTO_MAX_NAME + 1];
		if (!more) {
			l->oom = true;
			return NULL;
		}
		l->e = more;
		names = bc_realloc(l->names, cap * sizeof(*names));
		if (!names) {
			l->oom = true;
			return NULL;
		}
		l->names = names;
		l->cap = cap;
	}
	e = &l->e[l->n];
	memset(e, 0, sizeof(*e));
	snprintf(l->names[l->n], sizeof(l->names[l->n]), "%s", name);
	l->n++;
	return e;
}

static void list_stored(void *ud, const char *name)
{
	struct listing *l = ud;
	struct bc_session_summary *sum;
	struct bc_proto_session_entry *e;
	if (session_by_name(l->srv, name, strlen(name)) ||
	    !(e = listing_add(l, name))) {
		return;
	}
	if ((sum = summary_of(l->srv, name))) {
		e->prims = sum->prims;
		e->order = sum->order;
		e->last_edit_ms = sum->last_edit_ms;
		e->flags = BC_PROTO_SESSION_KNOWN;
	}
}

static int by_name(const void *a, const void *b)
{
	return strcmp(((const struct bc_proto_session_entry *)a)->name.ptr,
	              ((const struct bc_proto_session_entry *)b)->name.ptr);
}

void bc_handle_session_list(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	struct listing l = {.srv = srv};
	struct bc_msg out = {.type = BC_MSG_SESSIONS, .seq = m->seq};
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		struct bc_proto_session_entry *e;
		if (!s || !(e = listing_add(&l, s->name))) {
			continue;
		}
		e->members = (uint16_t)s->nmembers;
		e->prims = bc_tree_prim_count(s->tree);
		e->order = s->order;
		e->last_edit_ms = s->last_edit_ms;
		e->flags = BC_PROTO_SESSION_LOADED | BC_PROTO_SESSION_KNOWN;
	}
	bc_store_list(srv->store, list_stored, &l);
	if (l.oom) {
		bc_conn_send_error(c, m->seq, BC_ENOMEM, false,
		                   "the server is out of memory");
		goto out;
	}
	/* The names move with the entries only once the arrays stop
	 * growing. */
	for (uint32_t i = 0; i < l.n; i++) {
		l.e[i].name.ptr = l.names[i];
		l.e[i].name.len = (uint32_t)strlen(l.names[i]);
	}
	qsort(l.e, l.n, sizeof(*l.e), by_name);
	out.sessions.nsessions = (uint16_t)(l.n < BC_PROTO_MAX_SESSIONS_LISTED
	                                        ? l.n
	                                        : BC_PROTO_MAX_SESSIONS_LISTED);
	out.sessions.sessions = l.e;
	bc_conn_send(c, &out);
out:
	bc_free(l.e);
	bc_free(l.names);
}

static void handle_leave(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_msg ok = {.type = BC_MSG_OK, .seq = m->seq};
	bc_session_leave(c);
	bc_conn_send(c, &ok);
}

typedef void (*handler_fn)(struct bc_conn *c, const struct bc_msg *m);

/* What the server does with each request a client may send after HELLO
 * (net.c has already checked the stage and the role: PROTOCOL.md 5). */
static const handler_fn handlers[BC_MSG_COUNT] = {
    [BC_MSG_SESSION_CREATE] = bc_handle_session,
    [BC_MSG_SESSION_JOIN] = bc_handle_session,
    [BC_MSG_SESSION_LEAVE] = handle_leave,
    [BC_MSG_SCENE_LOAD] = bc_handle_scene_load,
    [BC_MSG_EDIT] = bc_handle_edit,
    [BC_MSG_CAMERA] = bc_handle_camera,
    [BC_MSG_VIEW] = bc_handle_view,
    [BC_MSG_PICK] = bc_handle_pick,
    [BC_MSG_SNAPSHOT] = bc_handle_snapshot,
    [BC_MSG_GET_STATS] = bc_handle_stats,
    [BC_MSG_SESSION_DELETE] = bc_handle_session_delete,
    [BC_MSG_UNDO] = bc_handle_undo,
    [BC_MSG_REDO] = bc_handle_undo,
    [BC_MSG_SESSION_LIST] = bc_handle_session_list,
    [BC_MSG_PRESENT] = bc_handle_present,
    [BC_MSG_FOLLOW] = bc_handle_follow,
    [BC_MSG_SESSION_CAMERA] = bc_handle_session_camera,
};

void bc_session_handle(struct bc_conn *c, const struct bc_msg *m)
{
	handler_fn h =
	    (unsigned)m->type < BC_MSG_COUNT ? handlers[m->type] : NULL;
	if (!h) {
		bc_conn_send_error(c, m->seq, BC_EPROTO_TYPE, false,
		                   "%s is not a request",
		                   bc_proto_type_name(m->type));
		return;
	}
	h(c, m);
}
