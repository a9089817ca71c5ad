/*
 * Members (loop thread): a client's member state from HELLO to close,
 * joining and leaving sessions, and what members are told of their
 * session: SESSION_INFO (who is in it) and SCENE_STATE (its scene; for a
 * big scene encoded on a task while the joiner waits, and kept for the
 * next joiners until the scene changes).
 */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

void bc_member_init(struct bc_member *m, struct bc_sessions *ss,
                    struct bc_peer *peer)
{
	memset(m, 0, sizeof(*m));
	m->ss = ss;
	m->peer = peer;
	if (peer->ref.slot < BC_SRV_MAX_CONNECTIONS) {
		ss->by_slot[peer->ref.slot] = m;
	}
}

void bc_member_finish(struct bc_member *m)
{
	if (!m->ss) {
		return;
	}
	bc__unpark(m);
	bc__leave(m);
	bc__parts_drop(m);
	bc_vstream_unref(m->vstream);
	m->vstream = NULL;
	if (m->peer->ref.slot < BC_SRV_MAX_CONNECTIONS &&
	    m->ss->by_slot[m->peer->ref.slot] == m) {
		m->ss->by_slot[m->peer->ref.slot] = NULL;
	}
	m->ss = NULL;
}

static void kick_due(uv_timer_t *t)
{
	bc__schedule(t->data);
}

void bc_member_writable(struct bc_member *m)
{
	m->frame_out = false;
	/* Not at once: the other members' frame writes usually finish in the
	 * same loop turn, and scheduling after them keeps equal views in one
	 * shared render. */
	if (m->session && m->dirty) {
		uv_timer_start(&m->session->kick, kick_due, 0, 0);
	}
}

void bc_member_answered(struct bc_member *m)
{
	m->answers_unsent -= m->answers_unsent > 0 ? 1u : 0u;
}

/* ---- sending --------------------------------------------------------------- */

/* m cannot be sent what its session now holds: a scene or edit with
 * kinds its client did not announce (PROTOCOL.md 4). Told why, closed. */
static void cannot_serve(struct bc_member *m, uint32_t needs)
{
	const struct bc_link *l = m->ss->link;
	uint32_t missing = needs & ~m->peer->features;
	bc_link_error(l, m->peer->ref, 0, BC_ENOTSUP, true,
	              "%s (features 0x%x, announced 0x%x): use a newer "
	              "client",
	              missing == BC_PROTO_FEATURE_PARTS
	                  ? "the session's scene is larger than one message "
	                    "and this client did not announce scenes in parts"
	                  : "the session's scene uses node kinds that this "
	                    "client did not announce",
	              needs, m->peer->features);
	l->close(l->ud, m->peer->ref, "its client cannot decode the scene",
	         true);
}

/* ed's operations for a member not granted NAMES (PROTOCOL.md 7.12):
 * without NAME operations, subtrees without their names tables (copies
 * in *bytes, which the caller frees). Returns the operations kept (in
 * ops, BC_PROTO_MAX_EDIT_OPS), or -1 when out of memory. */
static int without_names(const struct bc_msg_edit_applied *ed,
                         struct bc_proto_edit_op *ops, uint8_t **bytes)
{
	size_t total = 0, at = 0;
	int n = 0;
	*bytes = NULL;
	for (uint16_t i = 0; i < ed->nops; i++) {
		total += ed->ops[i].subtree.len;
	}
	if (total && !(*bytes = bc_malloc(total))) {
		return -1;
	}
	for (uint16_t i = 0; i < ed->nops; i++) {
		struct bc_proto_edit_op op = ed->ops[i];
		if (op.kind == BC_PROTO_EDIT_NAME) {
			continue;
		}
		if (op.subtree.len &&
		    (op.subtree.ptr[0] & BC_PROTO_SCENE_FLAG_NAMES)) {
			uint8_t *copy = *bytes + at;
			memcpy(copy, op.subtree.ptr, op.subtree.len);
			op.subtree.len = (uint32_t)bc_proto_scene_strip_names(
			    copy, op.subtree.len);
			op.subtree.ptr = copy;
			at += op.subtree.len;
		}
		ops[n++] = op;
	}
	return n;
}

/* The session's SCENE_STATE at its order, kept for joiners too. */
static struct bc_shared *state_now(struct bc_session *s)
{
	if (!s->state_msg || s->state_order != s->order) {
		bc_shared_unref(s->state_msg);
		s->state_msg =
		    bc__state_msg(s->tree, &s->camera, s->order, 0, 0);
		s->state_order = s->order;
	}
	s->state_used_ms = bc__now_ms(s->ss);
	return s->state_msg;
}

bool bc__session_state_idle(struct bc_session *s, uint64_t now)
{
	uint32_t nodes = s->tree ? bc_tree_node_count(s->tree) : 0;
	if (!s->state_msg || now - s->state_used_ms < s->ss->render_idle_ms) {
		return false;
	}
	bc_log(BC_LOG_DEBUG,
	       "session %s: its scene encoded for joiners dropped, none for "
	       "%llu s",
	       s->name, (unsigned long long)((now - s->state_used_ms) / 1000u));
	bc__session_changed(s);
	if (nodes >= BC_SRV_HEAVY_NODES) {
		/* Unless a member's queue still holds it, tens of MB go:
		 * back to the system, not kept in the heap. */
		bc_heap_give_back();
	}
	return true;
}

void bc__send(struct bc_member *m, const struct bc_msg *msg)
{
	const struct bc_link *l = m->ss->link;
	uint32_t missing = 0;
	struct bc_msg older;
	struct bc_proto_edit_op *kept = NULL;
	uint8_t *bytes = NULL;
	/* Only a client without every feature needs the message looked
	 * at (which scans an edit's subtrees), not each member of a
	 * broadcast. */
	if (msg->type == BC_MSG_EDIT_APPLIED &&
	    (m->peer->features & BC_PROTO_FEATURES_SENT) !=
	        BC_PROTO_FEATURES_SENT) {
		missing = bc_proto_msg_features(msg) & ~m->peer->features;
	}
	if (missing & ~(BC_PROTO_FEATURE_UNDO | BC_PROTO_FEATURE_NAMES)) {
		cannot_serve(m, missing);
		return;
	}
	older = *msg;
	if (missing & BC_PROTO_FEATURE_UNDO) {
		/* A client without UNDO gets the undo's operations as an
		 * edit like any other: the same scene, without the flag and
		 * the fields it would not know. */
		older.flags &=
		    (uint16_t) ~(BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO);
		older.edit_applied.target_order = 0;
		older.edit_applied.target_author.len = 0;
	}
	if (missing & BC_PROTO_FEATURE_NAMES) {
		int n = -1;
		if ((kept = bc_calloc(msg->edit_applied.nops, sizeof(*kept)))) {
			n = without_names(&msg->edit_applied, kept, &bytes);
		}
		if (n == 0 && m->session) {
			/* Nothing left: the whole scene at this order. */
			struct bc_shared *st = state_now(m->session);
			if (st) {
				bc__send_state_msg(m->session, m, st);
			}
			bc_free(kept);
			return;
		}
		if (n < 0) {
			bc_log(BC_LOG_ERROR,
			       "member %u: out of memory for "
			       "an edit without names",
			       m->member_id);
			bc_free(kept);
			return;
		}
		older.edit_applied.nops = (uint16_t)n;
		older.edit_applied.ops = kept;
	}
	l->send(l->ud, m->peer->ref, missing ? &older : msg);
	bc_free(bytes);
	bc_free(kept);
}

void bc__send_error(struct bc_member *m, uint32_t seq, int code,
                    const char *fmt, ...)
{
	char text[BC_PROTO_MAX_ERROR_TEXT];
	va_list args;
	va_start(args, fmt);
	vsnprintf(text, sizeof(text), fmt, args);
	va_end(args);
	bc_link_error(m->ss->link, m->peer->ref, seq, code, false, "%s", text);
}

uint32_t bc__members(const struct bc_session *s, struct bc_member **out)
{
	memcpy(out, s->members, s->nmembers * sizeof(*out));
	return s->nmembers;
}

void bc__send_info(struct bc_session *s)
{
	struct bc_proto_member list[BC_PROTO_MAX_MEMBERS];
	struct bc_member *members[BC_PROTO_MAX_MEMBERS];
	uint32_t n = bc__members(s, members);
	for (uint32_t i = 0; i < n; i++) {
		list[i].id = members[i]->member_id;
		list[i].role = members[i]->peer->role;
		list[i].name.ptr = members[i]->peer->name;
		list[i].name.len = (uint32_t)strlen(members[i]->peer->name);
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_msg info = {.type = BC_MSG_SESSION_INFO};
		info.session_info.session_id = s->id;
		info.session_info.member_id = members[i]->member_id;
		info.session_info.role = members[i]->peer->role;
		info.session_info.name.ptr = s->name;
		info.session_info.name.len = (uint32_t)strlen(s->name);
		info.session_info.nmembers = (uint16_t)n;
		info.session_info.members = list;
		bc__send(members[i], &info);
	}
}

/* msg, a whole SCENE_STATE's head and st's scene: the head written and
 * who may be sent it. A scene whose SCENE_STATE passes one message's
 * payload limit is kept the same way, to be sent only in parts (PROTOCOL.md
 * 7.10.1): its head's length is never sent as it is. */
static struct bc_shared *state_head(struct bc_shared *msg,
                                    const struct bc_msg *st)
{
	uint32_t len = st->scene_state.scene.len;
	bc_proto_scene_state_head(msg->data, 0, st->scene_state.order,
	                          st->scene_state.author,
	                          st->scene_state.author_seq, len);
	/* Who may be sent it (PROTOCOL.md 4). */
	msg->needs = bc_proto_msg_features(st);
	if (BC_PROTO_SCENE_STATE_FIXED + (uint64_t)len > BC_PROTO_MAX_PAYLOAD) {
		msg->needs |= BC_PROTO_FEATURE_PARTS;
	}
	return msg;
}

/* st, encoded once for every receiver, in a copy of its scene. */
static struct bc_shared *shared_state(const struct bc_msg *st)
{
	const struct bc_proto_bytes *scene = &st->scene_state.scene;
	struct bc_shared *msg =
	    bc_shared_new(BC_PROTO_SCENE_PART_HEAD + (size_t)scene->len);
	if (!msg) {
		return NULL;
	}
	memcpy(msg->data + BC_PROTO_SCENE_PART_HEAD, scene->ptr, scene->len);
	return state_head(msg, st);
}

struct bc_shared *bc__state_msg(const struct bc_tree *t,
                                const struct bc_camera *cam, uint64_t order,
                                uint32_t author, uint32_t author_seq)
{
	/* The scene is encoded after room for its message's bc_shared and
	 * head, and becomes the message without a copy: a million spheres'
	 * 40 MB copied took a fifth of a joiner's SCENE_STATE. */
	const size_t head = BC_SHARED_HEAD + BC_PROTO_SCENE_PART_HEAD;
	struct bc_msg st = {.type = BC_MSG_SCENE_STATE};
	struct bc_shared *msg;
	uint8_t *bytes = NULL;
	size_t len = 0;
	if (bc_scene_encode_after(t, cam, head, &bytes, &len)) {
		return NULL;
	}
	st.scene_state.order = order;
	st.scene_state.author = author;
	st.scene_state.author_seq = author_seq;
	st.scene_state.scene.ptr = bytes + head;
	st.scene_state.scene.len = (uint32_t)(len - head);
	msg = state_head(bc_shared_adopt(bytes, len), &st);
	if (msg->needs & BC_PROTO_FEATURE_NAMES) {
		/* The tree's bytes are the same without the names table,
		 * which ends the scene (PROTOCOL.md 8): a copy, its names
		 * flag cleared and its table cut off. */
		struct bc_shared *older = shared_state(&st);
		if (older) {
			uint8_t *scene = older->data + BC_PROTO_SCENE_PART_HEAD;
			st.scene_state.scene.ptr = scene;
			st.scene_state.scene.len =
			    (uint32_t)bc_proto_scene_strip_names(
			        scene, st.scene_state.scene.len);
			older->len = BC_PROTO_SCENE_PART_HEAD +
			             (size_t)st.scene_state.scene.len;
			state_head(older, &st);
		}
		if (!(msg->older = older)) {
			bc_shared_unref(msg);
			msg = NULL;
		}
	}
	return msg;
}

int bc__state_limit(struct bc_session *s, bool old, const char *what,
                    struct bc_errinfo *ei)
{
	uint64_t now = bc__now_ms(s->ss);
	if (!old) {
		return 0;
	}
	if (s->camera_state_ms &&
	    now - s->camera_state_ms < BC_SRV_CAMERA_STATE_MS) {
		return bc_errinfo_set(
		    ei, BC_EBUSY,
		    "%s at most once in %u ms while members of an older "
		    "protocol are in the session; try again in %u ms",
		    what, BC_SRV_CAMERA_STATE_MS,
		    (unsigned)(BC_SRV_CAMERA_STATE_MS -
		               (now - s->camera_state_ms)));
	}
	s->camera_state_ms = now;
	return 0;
}

void bc__send_state_msg(struct bc_session *s, struct bc_member *to,
                        struct bc_shared *msg)
{
	const struct bc_link *l = s->ss->link;
	struct bc_member *members[BC_PROTO_MAX_MEMBERS];
	uint32_t n;
	if (to) {
		members[0] = to;
		n = 1;
	} else {
		n = bc__members(s, members);
	}
	for (uint32_t i = 0; i < n; i++) {
		uint32_t missing = msg->needs & ~members[i]->peer->features;
		struct bc_shared *send = msg;
		const struct bc_peer *peer = members[i]->peer;
		if ((missing & BC_PROTO_FEATURE_NAMES) && msg->older) {
			/* Not granted NAMES: the scene without its names. */
			send = msg->older;
			missing = send->needs & ~peer->features;
		}
		if (missing) {
			cannot_serve(members[i], send->needs);
		} else if ((peer->features & BC_PROTO_FEATURE_PARTS) &&
		           send->len - BC_PROTO_HEADER_SIZE >
		               peer->max_frame_bytes) {
			/* Granted PARTS: no message over its limit. */
			l->send_parts(l->ud, peer->ref, send,
			              peer->max_frame_bytes);
		} else {
			l->send_shared(l->ud, peer->ref, send);
		}
	}
}

void bc__send_state(struct bc_session *s, struct bc_member *to, uint32_t author,
                    uint32_t author_seq)
{
	struct bc_shared *msg =
	    bc__state_msg(s->tree, &s->camera, s->order, author, author_seq);
	if (!msg) {
		bc_log(BC_LOG_ERROR, "session %s: cannot encode the scene",
		       s->name);
		return;
	}
	bc__send_state_msg(s, to, msg);
	bc_shared_unref(msg);
}

/* ---- joining and leaving -------------------------------------------------- */

void bc__leave(struct bc_member *m)
{
	struct bc_session *s = m->session;
	if (!s) {
		return;
	}
	bc__present_leave(m);
	bc__frames_forget(m);
	bc__parts_drop(m); /* an unfinished scene was for this session */
	for (uint32_t i = 0; i < s->nmembers; i++) {
		if (s->members[i] == m) {
			s->members[i] = s->members[--s->nmembers];
			break;
		}
	}
	m->session = NULL;
	m->peer->stage = BC_PROTO_STAGE_READY;
	m->peer->role = BC_PROTO_ROLE_INVALID;
	if (s->nmembers == 0) {
		s->empty_since_ms = bc__now_ms(s->ss);
	}
	bc__send_info(s);
}

void bc__mark_all(struct bc_session *s)
{
	for (uint32_t i = 0; i < s->nmembers; i++) {
		s->members[i]->shown.view = 0; /* the next frame is whole */
		bc__owe_frame(s->members[i]);
	}
}

/* Encoding a big scene's SCENE_STATE for joiners, off the loop. */
struct state_task {
	struct bc_task t;
	struct bc_shared *msg;
	uint64_t order;
};

static void state_run(struct bc_task *t)
{
	struct state_task *st = (struct state_task *)t;
	/* The session is busy: its tree and camera do not change. */
	st->msg = bc__state_msg(t->s->tree, &t->s->camera, st->order, 0, 0);
}

static void state_done(struct bc_task *t)
{
	struct state_task *st = (struct state_task *)t;
	struct bc_session *s = t->s;
	if (!s->removed && st->msg) {
		bc__session_changed(s);
		s->state_msg = st->msg;
		s->state_order = st->order;
		s->state_used_ms = bc__now_ms(s->ss);
		st->msg = NULL;
	} else if (!st->msg) {
		bc_log(BC_LOG_ERROR, "session %s: cannot encode the scene",
		       s->name);
	}
	bc_shared_unref(st->msg);
	bc_free(st);
}

/* Whether the joiner must wait for s: it is busy, loading, or its scene
 * is big and not encoded at this order yet (a task is started). */
static bool must_wait(struct bc_session *s)
{
	struct state_task *st;
	if (s->busy || !s->tree) {
		return true;
	}
	if (bc_tree_node_count(s->tree) < BC_SRV_HEAVY_NODES ||
	    (s->state_msg && s->state_order == s->order)) {
		return false;
	}
	if (!(st = bc_calloc(1, sizeof(*st)))) {
		return false; /* encoded on the loop, then */
	}
	st->order = s->order;
	st->t.run = state_run;
	st->t.done = state_done;
	st->t.holds_order = true;
	bc__task_start(s, &st->t);
	return true;
}

int bc__join(struct bc_member *m, struct bc_session *s, enum bc_proto_role role,
             uint32_t seq)
{
	if (must_wait(s)) {
		return bc__park(s, m, seq);
	}
	if (s->nmembers >= BC_PROTO_MAX_MEMBERS) {
		bc__send_error(m, seq, BC_ELIMIT,
		               "session %s is full (%u members)", s->name,
		               BC_PROTO_MAX_MEMBERS);
		return 0;
	}
	if (s->lost) {
		bc__send_error(m, seq, BC_EBUSY,
		               "session %s is to load again from what it saved "
		               "once its members have left (the server ran out "
		               "of memory); try again in a minute",
		               s->name);
		return 0;
	}
	if (m->session) {
		bc__leave(m);
	}
	s->members[s->nmembers++] = m;
	m->session = s;
	m->member_id = s->next_member_id++;
	m->peer->role = role;
	m->peer->stage = BC_PROTO_STAGE_SESSION;
	/* A camera the client chose (even before joining) stays its own. */
	if (!m->has_camera) {
		m->camera = s->camera;
		m->camera_seq = 0;
	}
	m->shown.view = 0;
	bc__send_info(s);
	if (s->state_msg && s->state_order == s->order) {
		s->state_used_ms = bc__now_ms(s->ss);
		bc__send_state_msg(s, m, s->state_msg);
	} else {
		bc__send_state(s, m, 0, 0);
	}
	bc__present_joined(m);
	bc__owe_frame(m);
	bc__schedule(s);
	return 0;
}
