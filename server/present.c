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

#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "server.h"

static struct bc_conn *presenter_of(struct bc_session *s)
{
	struct bc_conn *p;
	if (!s->presenter_id) {
		return NULL;
	}
	p = bc_conn_get(s->srv, s->presenter);
	return p && p->session == s && p->member_id == s->presenter_id ? p
	                                                               : NULL;
}

/* PRESENTER to one member that knows the type. */
static void tell(struct bc_session *s, struct bc_conn *m)
{
	struct bc_msg pm = {.type = BC_MSG_PRESENTER};
	if (!m->knows_present) {
		return;
	}
	pm.presenter.presenter = s->presenter_id;
	pm.presenter.following = m->follows && s->presenter_id ? 1 : 0;
	bc_conn_send(m, &pm);
}

/* PRESENTER to every member but except (one leaving, or NULL). */
static void tell_all(struct bc_session *s, const struct bc_conn *except)
{
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	uint32_t n = bc_session_members(s, refs);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_conn *m = bc_conn_get(s->srv, refs[i]);
		if (m && m != except) {
			tell(s, m);
		}
	}
}

/* Follower f takes presenter p's camera (and its interaction state), is
 * told so and is owed a frame at its own view. */
static void track(struct bc_conn *f, const struct bc_conn *p, uint16_t flags)
{
	struct bc_msg fc = {.type = BC_MSG_FOLLOW_CAMERA};
	f->camera = p->camera;
	f->has_camera = true;
	f->interacting_until = p->interacting_until;
	f->dirty = true;
	fc.flags = flags & BC_PROTO_FLAG_INTERACTING;
	fc.follow_camera.presenter = p->member_id;
	bc_edit_camera_to_msg(&p->camera, &fc.follow_camera.camera);
	if (f->knows_present) {
		bc_conn_send(f, &fc);
	}
}

/* Nobody presents any more: every follow ends. */
static void end_presentation(struct bc_session *s, const struct bc_conn *except)
{
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	uint32_t n = bc_session_members(s, refs);
	s->presenter_id = 0;
	s->presenter = (struct bc_conn_ref){0, 0};
	for (uint32_t i = 0; i < n; i++) {
		struct bc_conn *m = bc_conn_get(s->srv, refs[i]);
		if (m) {
			m->follows = false;
		}
	}
	tell_all(s, except);
}

static void send_ok(struct bc_conn *c, uint32_t seq)
{
	struct bc_msg ok = {.type = BC_MSG_OK, .seq = seq};
	bc_conn_send(c, &ok);
}

void bc_handle_present(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_conn *p = presenter_of(s);
	if (m->toggle.on) {
		struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
		uint32_t n;
		s->presenter_id = c->member_id;
		s->presenter = bc_conn_ref_of(c);
		c->follows = false; /* nobody follows themselves */
		if (p != c) {
			bc_log(BC_LOG_INFO,
			       "session %s: member %u (%s) presents%s", s->name,
			       c->member_id, c->name,
			       p ? " in place of another member" : "");
		}
		/* Followers of a replaced presenter follow the new one. */
		n = bc_session_members(s, refs);
		for (uint32_t i = 0; i < n; i++) {
			struct bc_conn *f = bc_conn_get(s->srv, refs[i]);
			if (f && f->follows) {
				track(f, c, 0);
			}
		}
		tell_all(s, NULL);
		bc_session_schedule(s);
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
}

void bc_handle_follow(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_conn *p = presenter_of(s);
	if (m->toggle.on) {
		if (!p) {
			bc_conn_send_error(c, m->seq, BC_ESTATE, false,
			                   "nobody presents in session %s",
			                   s->name);
			tell(s, c);
			return;
		}
		if (p == c) {
			bc_conn_send_error(c, m->seq, BC_ESTATE, false,
			                   "you are presenting; a presenter "
			                   "does not follow");
			return;
		}
		c->follows = true;
		track(c, p, 0);
		bc_session_schedule(s);
	} else {
		c->follows = false;
	}
	tell(s, c);
	send_ok(c, m->seq);
}

void bc_present_camera_moved(struct bc_conn *c, uint16_t flags)
{
	struct bc_session *s = c->session;
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
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
	n = bc_session_members(s, refs);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_conn *f = bc_conn_get(s->srv, refs[i]);
		if (f && f != c && f->follows) {
			track(f, c, flags);
		}
	}
}

void bc_present_leave(struct bc_conn *c)
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

void bc_present_joined(struct bc_conn *c)
{
	struct bc_session *s = c->session;
	c->follows = false;
	if (s && s->presenter_id) {
		tell(s, c);
	}
}

/* ---- the session camera -------------------------------------------------- */

#define CAMERA_RECORD_MAGIC_LEN 2u

int bc_present_camera_record(const uint8_t *rec, size_t len,
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

void bc_handle_session_camera(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_srv *srv = c->srv;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_proto_buf rec;
	struct bc_msg as_rec = {.type = BC_MSG_SESSION_CAMERA};
	struct bc_msg set = {.type = BC_MSG_SESSION_CAMERA_SET};
	struct bc_conn_ref refs[BC_PROTO_MAX_MEMBERS];
	uint32_t n;
	int rc;
	bc_edit_camera_from_msg(&m->session_camera, &cam);
	if (bc_camera_validate(&cam, &ei)) {
		bc_conn_send_error(c, m->seq, ei.code, false, "%s", ei.msg);
		return;
	}
	if (s->loading) {
		bc_conn_send_error(c, m->seq, BC_EBUSY, false,
		                   "the session's scene is being replaced by a "
		                   "SCENE_LOAD; retry after its SCENE_STATE");
		return;
	}
	if (s->store_failed) {
		bc_conn_send_error(c, m->seq, BC_EIO, false,
		                   "camera not set: the session cannot be "
		                   "saved: changes are refused");
		return;
	}
	/* The record: two zero bytes, then the SESSION_CAMERA payload. */
	bc_proto_buf_init(&rec, 0);
	as_rec.session_camera = m->session_camera;
	if ((rc = bc_proto_encode(&rec, &as_rec, &ei)) == 0) {
		uint8_t bytes[CAMERA_RECORD_MAGIC_LEN + 64] = {0};
		size_t len = rec.len - BC_PROTO_HEADER_SIZE;
		memcpy(bytes + CAMERA_RECORD_MAGIC_LEN,
		       rec.data + BC_PROTO_HEADER_SIZE, len);
		rc = bc_store_append(s->store, s->order + 1, bytes,
		                     CAMERA_RECORD_MAGIC_LEN + len, &ei);
	}
	bc_proto_buf_finish(&rec);
	if (rc) {
		if (rc == BC_EIO) {
			s->store_failed = true;
		}
		bc_conn_send_error(c, m->seq, rc, false, "camera not set: %s",
		                   ei.msg);
		return;
	}
	s->order++;
	s->last_edit_ms = bc_unix_ms();
	s->camera = cam;
	bc_log(BC_LOG_INFO, "session %s: camera set by member %u (order %llu)",
	       s->name, c->member_id, (unsigned long long)s->order);
	set.session_camera_set.order = s->order;
	set.session_camera_set.author = c->member_id;
	set.session_camera_set.author_seq = m->seq;
	set.session_camera_set.camera = m->session_camera;
	/* Members that do not know SESSION_CAMERA_SET get the scene again
	 * (SCENE_STATE at the new order), so their mirrors see no gap. */
	n = bc_session_members(s, refs);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_conn *o = bc_conn_get(srv, refs[i]);
		if (o && o->knows_present) {
			bc_conn_send(o, &set);
		} else if (o) {
			bc_session_send_state(s, o, 0, 0);
		}
	}
	bc_store_snapshot_due(s->store, BC_SRV_SNAPSHOT_EVERY, s->tree,
	                      &s->camera, s->order, &ei);
}
