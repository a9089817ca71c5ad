/*
 * Presentation (loop thread): one member of a session may present, others
 * follow: their cameras track the presenter's, each rendered at its own
 * VIEW. PRESENT and FOLLOW change who presents and who follows; PRESENTER
 * tells members (the connections that know these types, PROTOCOL.md 4);
 * FOLLOW_CAMERA gives each follower the camera it now renders from. Also
 * SESSION_CAMERA: an editor sets the session's stored camera (what joiners
 * start from and SCENE_STATE carries), journaled like an edit and answered
 * by SESSION_CAMERA_SET to every member; members' own cameras stay.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "sessions_impl.h"

static struct bc_member *presenter_of(struct bc_session *s)
{
	struct bc_member *p = s->presenter;
	if (!s->presenter_id || !p) {
		return NULL;
	}
	return p->session == s && p->member_id == s->presenter_id ? p : NULL;
}

/* PRESENTER to one member that knows the type. */
static void tell(struct bc_session *s, struct bc_member *m)
{
	struct bc_msg pm = {.type = BC_MSG_PRESENTER};
	if (!m->peer->knows_present) {
		return;
	}
	pm.presenter.presenter = s->presenter_id;
	pm.presenter.following = m->follows && s->presenter_id ? 1 : 0;
	bc__send(m, &pm);
}

/* PRESENTER to every member but except (one leaving, or NULL). */
static void tell_all(struct bc_session *s, const struct bc_member *except)
{
	struct bc_member *list[BC_PROTO_MAX_MEMBERS];
	uint32_t n = bc__members(s, list);
	for (uint32_t i = 0; i < n; i++) {
		if (list[i] != except) {
			tell(s, list[i]);
		}
	}
}

/* Follower f takes presenter p's camera (and its interaction state), is
 * told so and is owed a frame at its own view. */
static void track(struct bc_member *f, const struct bc_member *p,
                  uint16_t flags)
{
	struct bc_msg fc = {.type = BC_MSG_FOLLOW_CAMERA};
	f->camera = p->camera;
	f->has_camera = true;
	f->interacting_until = p->interacting_until;
	bc__owe_frame(f);
	fc.flags = flags & BC_PROTO_FLAG_INTERACTING;
	fc.follow_camera.presenter = p->member_id;
	bc_edit_camera_to_msg(&p->camera, &fc.follow_camera.camera);
	if (f->peer->knows_present) {
		bc__send(f, &fc);
	}
}

/* Nobody presents any more: every follow ends. */
static void end_presentation(struct bc_session *s,
                             const struct bc_member *except)
{
	s->presenter_id = 0;
	s->presenter = NULL;
	for (uint32_t i = 0; i < s->nmembers; i++) {
		s->members[i]->follows = false;
	}
	tell_all(s, except);
}

static void send_ok(struct bc_member *c, uint32_t seq)
{
	struct bc_msg ok = {.type = BC_MSG_OK, .seq = seq};
	bc__send(c, &ok);
}

int bc_handle_present(struct bc_member *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_member *p = presenter_of(s);
	if (m->toggle.on) {
		struct bc_member *list[BC_PROTO_MAX_MEMBERS];
		uint32_t n;
		s->presenter_id = c->member_id;
		s->presenter = c;
		c->follows = false; /* nobody follows themselves */
		if (p != c) {
			bc_log(BC_LOG_INFO,
			       "session %s: member %u (%s) presents%s", s->name,
			       c->member_id, c->peer->name,
			       p ? " in place of another member" : "");
		}
		/* Followers of a replaced presenter follow the new one. */
		n = bc__members(s, list);
		for (uint32_t i = 0; i < n; i++) {
			if (list[i]->follows) {
				track(list[i], c, 0);
			}
		}
		tell_all(s, NULL);
		bc__schedule(s);
	} else if (p == c) {
		bc_log(BC_LOG_INFO, "session %s: member %u stops presenting",
		       s->name, c->member_id);
		end_presentation(s, NULL);
	} else {
		/* Not presenting (any more): nothing changes, and the
		 * sender learns who does. */
		tell(s, c);
	}
	send_ok(c, m->seq);
	return 0;
}

int bc_handle_follow(struct bc_member *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_member *p = presenter_of(s);
	if (m->toggle.on) {
		if (!p) {
			bc__send_error(c, m->seq, BC_ESTATE,
			               "nobody presents in session %s",
			               s->name);
			tell(s, c);
			return 0;
		}
		if (p == c) {
			bc__send_error(c, m->seq, BC_ESTATE,
			               "you are presenting; a presenter does "
			               "not follow");
			return 0;
		}
		c->follows = true;
		track(c, p, 0);
		bc__schedule(s);
	} else {
		c->follows = false;
	}
	tell(s, c);
	send_ok(c, m->seq);
	return 0;
}

void bc__present_camera_moved(struct bc_member *c, uint16_t flags)
{
	struct bc_session *s = c->session;
	struct bc_member *list[BC_PROTO_MAX_MEMBERS];
	uint32_t n;
	if (!s) {
		return;
	}
	if (c->follows) {
		/* Moving one's own camera leaves the follow. */
		c->follows = false;
		tell(s, c);
		return;
	}
	if (presenter_of(s) != c) {
		return;
	}
	n = bc__members(s, list);
	for (uint32_t i = 0; i < n; i++) {
		if (list[i] != c && list[i]->follows) {
			track(list[i], c, flags);
		}
	}
}

void bc__present_leave(struct bc_member *c)
{
	struct bc_session *s = c->session;
	c->follows = false;
	if (s && s->presenter_id && s->presenter_id == c->member_id) {
		bc_log(BC_LOG_INFO,
		       "session %s: presenter %u left; the presentation ends",
		       s->name, c->member_id);
		/* The leaver is not told: it is leaving the session. */
		end_presentation(s, c);
	}
}

void bc__present_session_gone(struct bc_session *s)
{
	if (s->presenter_id) {
		end_presentation(s, NULL);
	}
}

void bc__present_joined(struct bc_member *c)
{
	struct bc_session *s = c->session;
	c->follows = false;
	if (s && s->presenter_id) {
		tell(s, c);
	}
}

/* ---- the session camera -------------------------------------------------- */

#define CAMERA_RECORD_MAGIC_LEN 2u

int bc__present_camera_record(const uint8_t *rec, size_t len,
                              struct bc_camera *cam)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bc_errinfo ei = {0};
	int rc;
	if (len < CAMERA_RECORD_MAGIC_LEN || rec[0] != 0 || rec[1] != 0) {
		return 0;
	}
	bc_proto_reader_init(&r, NULL);
	rc = bc_proto_decode_payload(&r, BC_MSG_SESSION_CAMERA, 0, 0,
	                             rec + CAMERA_RECORD_MAGIC_LEN,
	                             len - CAMERA_RECORD_MAGIC_LEN, &m, &ei);
	bc_proto_reader_finish(&r);
	if (!rc) {
		struct bc_camera c;
		bc_edit_camera_from_msg(&m.session_camera, &c);
		if (!(rc = bc_camera_validate(&c, &ei))) {
			*cam = c;
			return 1;
		}
	}
	bc_log(BC_LOG_ERROR, "journal replay: a session camera record: %s",
	       ei.msg);
	return rc;
}

/* Members that do not know SESSION_CAMERA_SET are sent the whole
 * SCENE_STATE at the new order instead, so their mirrors see no gap
 * (PROTOCOL.md 7.25). Returns true when the camera must wait. */
static bool state_rate_limited(struct bc_member *c, uint32_t seq)
{
	struct bc_session *s = c->session;
	struct bc_errinfo ei = {0};
	bool old = false;
	for (uint32_t i = 0; i < s->nmembers; i++) {
		old = old || !s->members[i]->peer->knows_present;
	}
	if (bc__state_limit(s, old, "the session camera changes", &ei)) {
		bc__send_error(c, seq, ei.code, "%s", ei.msg);
		return true;
	}
	return false;
}

/* A SESSION_CAMERA on its way: its journal record (two zero bytes, then
 * the SESSION_CAMERA payload) appended and synced on a task, the session
 * busy; then the camera is the session's and every member hears of it. */
struct camera_task {
	struct bc_task t;
	struct bc_author author;
	struct bc_msg_camera wire;
	struct bc_camera cam;
	uint8_t rec[CAMERA_RECORD_MAGIC_LEN + 64];
	size_t len;
	int rc;
	struct bc_errinfo ei;
};

static void camera_run(struct bc_task *t)
{
	struct camera_task *c = (struct camera_task *)t;
	c->rc = bc_store_append(t->s->store, t->s->order + 1, c->rec, c->len,
	                        &c->ei);
}

static void camera_commit(struct bc_session *s, const struct camera_task *c)
{
	struct bc_msg set = {.type = BC_MSG_SESSION_CAMERA_SET};
	struct bc_member *list[BC_PROTO_MAX_MEMBERS];
	struct bc_shared *state = NULL;
	uint32_t n;
	s->order++;
	s->last_edit_ms = bc__unix_ms();
	s->camera = c->cam;
	bc__session_changed(s);
	bc_log(BC_LOG_INFO, "session %s: camera set by member %u (order %llu)",
	       s->name, c->author.member_id, (unsigned long long)s->order);
	set.session_camera_set.order = s->order;
	set.session_camera_set.author = c->author.member_id;
	set.session_camera_set.author_seq = c->author.seq;
	set.session_camera_set.camera = c->wire;
	n = bc__members(s, list);
	for (uint32_t i = 0; i < n; i++) {
		if (list[i]->peer->knows_present) {
			bc__send(list[i], &set);
		} else if (state || (state = bc__state_msg(s->tree, &s->camera,
		                                           s->order, 0, 0))) {
			/* One encoding for every older member. */
			bc__send_state_msg(s, list[i], state);
		}
	}
	bc_shared_unref(state);
	bc__session_snapshot_due(s);
}

static void camera_done(struct bc_task *t)
{
	struct camera_task *c = (struct camera_task *)t;
	struct bc_session *s = t->s;
	struct bc_member *m = bc__member_of(s->ss, c->author.ref);
	if (s->removed) {
		/* Deleted meanwhile: nobody to tell. */
	} else if (c->rc) {
		s->store_failed = s->store_failed || c->rc == BC_EIO;
		if (m) {
			bc__send_error(m, c->author.seq, c->rc,
			               "camera not set: %s", c->ei.msg);
		}
	} else {
		camera_commit(s, c);
	}
	bc_free(c);
}

/* Prepares c's journal record from the request. */
static int camera_record(struct camera_task *c, const struct bc_msg *m,
                         struct bc_errinfo *ei)
{
	struct bc_proto_buf rec;
	struct bc_msg as_rec = {.type = BC_MSG_SESSION_CAMERA};
	int rc;
	bc_proto_buf_init(&rec, 0);
	as_rec.session_camera = m->session_camera;
	if ((rc = bc_proto_encode(&rec, &as_rec, ei)) == 0) {
		c->len =
		    CAMERA_RECORD_MAGIC_LEN + rec.len - BC_PROTO_HEADER_SIZE;
		memcpy(c->rec + CAMERA_RECORD_MAGIC_LEN,
		       rec.data + BC_PROTO_HEADER_SIZE,
		       rec.len - BC_PROTO_HEADER_SIZE);
	}
	bc_proto_buf_finish(&rec);
	return rc;
}

int bc_handle_session_camera(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_session *s = m->session;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct camera_task *c;
	int rc, park;
	bc_edit_camera_from_msg(&msg->session_camera, &cam);
	if (bc_camera_validate(&cam, &ei)) {
		bc__send_error(m, msg->seq, ei.code, "%s", ei.msg);
		return 0;
	}
	if (bc__refuse_change(m, msg->seq, &park)) {
		return park;
	}
	if (state_rate_limited(m, msg->seq)) {
		return 0;
	}
	if (!(c = bc_calloc(1, sizeof(*c)))) {
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "camera not set: out of memory");
		return 0;
	}
	if ((rc = camera_record(c, msg, &ei))) {
		bc_free(c);
		bc__send_error(m, msg->seq, rc, "camera not set: %s", ei.msg);
		return 0;
	}
	c->author =
	    (struct bc_author){m->peer->ref, m->member_id, msg->seq, {0}};
	c->wire = msg->session_camera;
	c->cam = cam;
	c->t.run = camera_run;
	c->t.done = camera_done;
	c->t.holds_order = true;
	bc__task_start(s, &c->t);
	return bc__hold(s, m, msg->seq);
}
