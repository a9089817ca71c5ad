/*
 * Frames (loop thread): which member is owed a frame, and when. Frames are
 * rendered on change only. Each member has a camera and a view; while
 * changes marked INTERACTING keep arriving a member's frames are
 * interactive (coarse levels, damage rectangles, interactive quality);
 * BC_SRV_STILL_DELAY_MS after the last one it gets the still. Members whose
 * frames would be equal share one job and one encode (the work layer
 * decides levels and rectangles: job.c). A member has at most one frame
 * job; a change it does not show retracts the job while it waits for a
 * worker, and makes a running one give way where it can (latest wins).
 * Also the requests that shape frames (CAMERA, VIEW, PICK, SNAPSHOT) and
 * what the work layer gives back.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "sessions_impl.h"

static void kick_due(uv_timer_t *t)
{
	bc__schedule(t->data);
}

/* Two members can share a render when everything that shapes the frame is
 * equal. */
static bool same_frame(const struct bc_member *a, const struct bc_member *b,
                       bool still_a, bool still_b)
{
	/* H.264 members share the render, each with its own stream's next
	 * access unit of it; they do not share with image members. */
	return still_a == still_b && !a->vstream == !b->vstream &&
	       memcmp(&a->camera, &b->camera, sizeof(a->camera)) == 0 &&
	       a->view.width == b->view.width &&
	       a->view.height == b->view.height &&
	       a->view.encoding == b->view.encoding &&
	       a->view.quality_interactive == b->view.quality_interactive &&
	       a->view.quality_still == b->view.quality_still &&
	       a->view.downscale == b->view.downscale &&
	       a->view.still_encoding == b->view.still_encoding &&
	       a->peer->encodings == b->peer->encodings &&
	       (a->peer->features & BC_PROTO_FEATURE_LEVELS) ==
	           (b->peer->features & BC_PROTO_FEATURE_LEVELS) &&
	       memcmp(&a->shown, &b->shown, sizeof(a->shown)) == 0;
}

/* The coarsest refinement level a VIEW's downscale d accepts: the largest
 * n with 2^n <= d. */
static uint32_t max_level(uint32_t d)
{
	uint32_t n = 0;
	while (n < BC_PROTO_MAX_LEVEL && (2u << n) <= d) {
		n++;
	}
	return n;
}

static void still_due(uv_timer_t *timer)
{
	struct bc_session *s = timer->data;
	uint64_t now = bc__now_ms(s->ss);
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_member *m = s->members[i];
		if (m->has_view && !m->still_sent &&
		    now >= m->interacting_until) {
			bc__owe_frame(m);
		}
	}
	bc__schedule(s);
}

/* Whether m can start a frame job now. One frame in flight per client:
 * while one is being written, changes only accumulate (the next frame
 * shows the newest state); a client that stopped reading costs no
 * renders. */
static bool ready(const struct bc_member *m)
{
	return m->has_view && m->dirty && !m->job && !m->frame_out;
}

/* The job request of member m's frame. */
/* The finest level m's interactive frames may start at, for its link:
 * when frames waited for the link since last asked (the transport paces
 * them, PROTOCOL.md 7.18's frames_paced), one level coarser, a quarter of
 * the bytes; after BC_SRV_LINK_CALM_FRAMES frames that did not wait, one
 * finer again. Up to max, the coarsest the VIEW accepts. A still still
 * refines to level 0: only the interaction is coarser. */
static uint32_t link_level(struct bc_session *s, struct bc_member *m,
                           uint32_t max)
{
	const struct bc_link *l = s->ss->link;
	struct bc_proto_link li;
	l->link_info(l->ud, m->peer->ref, &li);
	if (li.rtt_us < BC_SRV_LINK_MIN_RTT_US) {
		/* Loopback or a Unix socket: a slow reader, not a slow
		 * link; its frames stay as fine as rendering allows. */
		m->paced_seen = li.frames_paced;
		m->link_level = 0;
		return 0;
	}
	if (li.frames_paced != m->paced_seen) {
		m->paced_seen = li.frames_paced;
		m->link_calm = 0;
		m->link_level += m->link_level < max ? 1u : 0u;
		bc_log(BC_LOG_DEBUG,
		       "member %u: its link holds frames back: interactive "
		       "frames from level %u",
		       m->member_id, m->link_level);
	} else if (++m->link_calm >= BC_SRV_LINK_CALM_FRAMES) {
		m->link_calm = 0;
		m->link_level -= m->link_level > 0 ? 1u : 0u;
	}
	return m->link_level < max ? m->link_level : max;
}

/* The bitrate of m's H.264 stream, from its link: when frames waited for
 * the link since the last frame, three quarters of the rate the link
 * delivers (or three quarters of the bitrate, when that is not known);
 * after BC_SRV_LINK_CALM_FRAMES frames that did not wait, a quarter more,
 * back to the default. The coarse levels (link_level) take over below
 * what a rate can save. */
static void video_rate(struct bc_session *s, struct bc_member *m)
{
	const struct bc_link *l = s->ss->link;
	struct bc_proto_link li;
	uint32_t def =
	    bc_vstream_default_bitrate(m->view.width, m->view.height);
	l->link_info(l->ud, m->peer->ref, &li);
	if (li.rtt_us < BC_SRV_LINK_MIN_RTT_US) {
		m->video_paced_seen = li.frames_paced;
		return; /* a slow reader on loopback, not a slow link */
	}
	if (li.frames_paced != m->video_paced_seen) {
		uint32_t cur = m->video_bps ? m->video_bps : def;
		uint64_t link = li.delivery_bps * 8u * 3u / 4u;
		m->video_paced_seen = li.frames_paced;
		m->video_calm = 0;
		m->video_bps =
		    link && link < cur ? (uint32_t)link : cur / 4u * 3u;
		bc_log(BC_LOG_DEBUG,
		       "member %u: its link holds frames back: H.264 at %u "
		       "bit/s",
		       m->member_id, m->video_bps);
	} else if (m->video_bps && ++m->video_calm >= BC_SRV_LINK_CALM_FRAMES) {
		m->video_calm = 0;
		m->video_bps += m->video_bps / 4u;
		m->video_bps = m->video_bps >= def ? 0u : m->video_bps;
	}
	bc_vstream_set_bitrate(m->vstream, m->video_bps);
}

static void frame_req(struct bc_session *s, struct bc_member *m, bool still,
                      struct bc_job_req *q)
{
	memset(q, 0, sizeof(*q));
	q->kind = BC_JOB_FRAME;
	q->session_id = s->id;
	q->camera = m->camera;
	q->width = m->view.width;
	q->height = m->view.height;
	/* The VIEW's encoding governs every frame, coarse levels and damage
	 * rectangles included (PROTOCOL.md 7.14). */
	q->encoding = (int)(m->view.still_encoding ? m->view.still_encoding
	                                           : m->view.encoding);
	q->encoding_interactive = (int)m->view.encoding;
	q->quality_still = m->view.quality_still;
	q->quality_interactive = m->view.quality_interactive;
	/* Coarse levels only for a client that announced them (PROTOCOL.md
	 * 4); an earlier one gets level 0 frames, whole or damaged. */
	q->max_level = (m->peer->features & BC_PROTO_FEATURE_LEVELS)
	                   ? max_level(m->view.downscale)
	                   : 0;
	q->min_level = still ? 0 : link_level(s, m, q->max_level);
	q->final = still;
	q->shown = m->shown;
	q->camera_seq = m->camera_seq;
	q->order = s->order;
	q->scene_order = s->scene_order;
	q->frame_no = ++s->ss->frame_no;
}

/* ---- the render copy, made when first wanted ------------------------------ */

struct copy_task {
	struct bc_task t;
	struct bc_tree *copy;
	double ms; /* what the copy took */
	int rc;
};

/* On the task: the session is busy, so its tree does not change. */
static void copy_run(struct bc_task *t)
{
	struct copy_task *c = (struct copy_task *)t;
	double t0 = bc_clock_ms();
	c->rc = bc_tree_copy(c->copy, t->s->tree, NULL);
	c->ms = bc_clock_ms() - t0;
}

static void copy_done(struct bc_task *t)
{
	struct copy_task *c = (struct copy_task *)t;
	struct bc_session *s = t->s;
	s->copying = false;
	if (!s->removed && !c->rc) {
		/* The session was busy that long: say why. */
		bc_log(BC_LOG_INFO,
		       "session %s: render copy of %u nodes made for its first "
		       "picture in %.0f ms",
		       s->name, bc_tree_node_count(c->copy), c->ms);
		bc_work_scene(s->ss->work, s->id, c->copy, s->order);
		c->copy = NULL;
		s->copied = true;
	} else if (!s->removed) {
		/* Told to the first request parked behind the task; the
		 * frames owed try again later. */
		s->copy_rc = c->rc;
		bc_log(BC_LOG_ERROR,
		       "session %s: no memory for its render copy", s->name);
		uv_timer_start(&s->kick, kick_due, BC_SRV_OOM_RETRY_MS, 0);
	}
	bc__tree_free_later(s->ss->loop, c->copy);
	bc_free(c);
	if (!s->removed && s->copied) {
		bc__schedule(s);
	}
}

int bc__session_copy(struct bc_session *s)
{
	struct copy_task *c;
	struct bc_tree *t;
	int rc;
	s->looked_ms = bc__now_ms(s->ss);
	if (s->copied) {
		return 0;
	}
	if (s->copying) {
		return BC_PARK;
	}
	if (s->busy) {
		/* A task may be changing the tree (a big structural edit)
		 * or about to replace it (a load): the copy waits for it,
		 * as a parked request does, and the task's end schedules
		 * the frames owed. */
		return BC_PARK;
	}
	if ((rc = s->copy_rc)) {
		s->copy_rc = 0;
		return rc;
	}
	if (!s->tree) {
		return BC_ESTATE;
	}
	if (bc_tree_node_count(s->tree) < BC_SRV_HEAVY_NODES) {
		if (!(t = bc__copy_tree()) || bc_tree_copy(t, s->tree, NULL)) {
			bc_tree_destroy(t);
			bc_log(BC_LOG_ERROR,
			       "session %s: no memory for its render copy",
			       s->name);
			return BC_ENOMEM;
		}
		bc_work_scene(s->ss->work, s->id, t, s->order);
		s->copied = true;
		return 0;
	}
	if (!(c = bc_calloc(1, sizeof(*c))) || !(c->copy = bc__copy_tree())) {
		bc_free(c);
		return BC_ENOMEM;
	}
	c->t.run = copy_run;
	c->t.done = copy_done;
	c->t.holds_order = true;
	s->copying = true;
	bc__task_start(s, &c->t);
	return BC_PARK;
}

/* Whether m looks at its session: it has a view, a frame job, or PICKs
 * or SNAPSHOTs queued. */
static bool looks(const struct bc_member *m)
{
	return m->has_view || m->job || m->requests;
}

bool bc__session_copy_idle(struct bc_session *s, uint64_t now)
{
	if (!s->copied || s->busy) {
		return false;
	}
	for (uint32_t i = 0; i < s->nmembers; i++) {
		if (looks(s->members[i])) {
			s->looked_ms = now;
			return false;
		}
	}
	if (now - s->looked_ms < s->ss->render_idle_ms) {
		return false;
	}
	bc_log(BC_LOG_INFO,
	       "session %s: render copy dropped, no picture wanted for %llu "
	       "s; the next one makes it again",
	       s->name, (unsigned long long)((now - s->looked_ms) / 1000u));
	bc_work_scene(s->ss->work, s->id, NULL, s->order);
	s->copied = false;
	return true;
}

/* Whether a frame can be asked for: the render copy is there, or is made
 * now; else the frames stay owed (a task's end schedules them, a failed
 * copy is tried again later). */
static bool copy_ready(struct bc_session *s)
{
	int rc = bc__session_copy(s);
	if (rc && rc != BC_PARK) {
		uv_timer_start(&s->kick, kick_due, BC_SRV_OOM_RETRY_MS, 0);
	}
	return rc == 0;
}

/* ---- scheduling ------------------------------------------------------------ */

void bc__schedule(struct bc_session *s)
{
	struct bc_sessions *ss = s->ss;
	uint64_t now = bc__now_ms(ss), next_still = 0;
	bool done[BC_PROTO_MAX_MEMBERS] = {0};
	struct bc_job_req q;
	bool owed = false;
	for (uint32_t i = 0; i < s->nmembers && !owed; i++) {
		owed = ready(s->members[i]);
	}
	if (!owed || !copy_ready(s)) {
		return;
	}
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_member *m = s->members[i],
		                 *group[BC_PROTO_MAX_MEMBERS];
		uint32_t ng = 0;
		struct bc_job *job;
		bool still;
		if (done[i] || !ready(m)) {
			continue;
		}
		still = now >= m->interacting_until;
		if (!still &&
		    (next_still == 0 || m->interacting_until > next_still)) {
			next_still = m->interacting_until;
		}
		frame_req(s, m, still, &q);
		group[ng++] = m;
		for (uint32_t j = i + 1; j < s->nmembers; j++) {
			struct bc_member *o = s->members[j];
			if (!done[j] && ready(o) &&
			    same_frame(m, o, still,
			               now >= o->interacting_until)) {
				group[ng++] = o;
				done[j] = true;
			}
		}
		for (uint32_t g = 0; g < ng; g++) {
			q.targets[g] = group[g]->peer->ref;
			q.target_camera_seq[g] = group[g]->camera_seq;
			q.video[g] = group[g]->vstream;
			if (q.video[g]) {
				video_rate(s, group[g]);
			}
		}
		q.ntargets = ng;
		if (!(job = bc_work_submit(ss->work, &q))) {
			/* The group stays owed its frame, retried. */
			bc_log(BC_LOG_ERROR,
			       "session %u: out of memory for a frame job; "
			       "retrying in %u ms",
			       s->id, BC_SRV_OOM_RETRY_MS);
			uv_timer_start(&s->kick, kick_due, BC_SRV_OOM_RETRY_MS,
			               0);
			break;
		}
		for (uint32_t g = 0; g < ng; g++) {
			group[g]->job = job;
			group[g]->dirty = false;
		}
	}
	if (next_still > now) {
		uv_timer_start(&s->still_timer, still_due, next_still - now, 0);
	}
}

/* The members of s that wait for job, made owed again (the job is gone
 * without a frame). */
static void reowe_group(struct bc_session *s, const struct bc_job *job)
{
	for (uint32_t i = 0; i < s->nmembers; i++) {
		if (s->members[i]->job == job) {
			s->members[i]->job = NULL;
			s->members[i]->dirty = true;
		}
	}
}

void bc__owe_frame(struct bc_member *m)
{
	struct bc_job *job = m->job;
	m->dirty = true;
	if (!job || !m->session) {
		return;
	}
	/* Latest wins: a job still waiting for a worker goes (its members
	 * get a new one at the next schedule); a running one gives way at
	 * its next slice if what it does can wait. */
	if (bc_work_retract(m->ss->work, job)) {
		reowe_group(m->session, job);
	}
}

/* Drops m's PICKs and SNAPSHOTs: they answer nobody once m leaves. */
static uint32_t forget_requests(struct bc_member *m)
{
	uint32_t dropped = 0;
	for (uint32_t i = 0; i < BC_SRV_MAX_CLIENT_REQUESTS; i++) {
		if (m->req_jobs[i]) {
			dropped += bc_work_cancel(m->ss->work, m->req_jobs[i]);
			m->req_jobs[i] = NULL;
		}
	}
	m->requests = 0;
	return dropped;
}

void bc__frames_forget(struct bc_member *m)
{
	struct bc_session *s = m->session;
	struct bc_job *job = m->job;
	uint32_t dropped;
	bool shared = false;
	/* The wait before its session's copy goes starts now. */
	if (s && looks(m)) {
		s->looked_ms = bc__now_ms(m->ss);
	}
	dropped = forget_requests(m);
	m->ss->link->forget_frames(m->ss->link->ud, m->peer->ref);
	m->answers_unsent = 0;
	m->job = NULL;
	m->dirty = false;
	m->frame_out = false;
	for (uint32_t i = 0; job && s && i < s->nmembers; i++) {
		shared =
		    shared || (s->members[i] != m && s->members[i]->job == job);
	}
	/* A job nobody else waits for serves nobody once m is gone. */
	if (job && s && !shared) {
		dropped += bc_work_cancel(m->ss->work, job);
	}
	if (dropped > 0) {
		bc_log(BC_LOG_INFO,
		       "dropped %u queued render job%s of clients that left",
		       dropped, dropped == 1 ? "" : "s");
	}
}

/* ---- what the work layer gives back ---------------------------------------- */

/* The member a job's target ref still is, in the job's session, or NULL. */
static struct bc_member *target(struct bc_sessions *ss,
                                const struct bc_job_req *q, uint32_t i)
{
	struct bc_member *m = bc__member_of(ss, q->targets[i]);
	return m && m->session && m->session->id == q->session_id ? m : NULL;
}

/* A frame too large for m is not sent: m hears ERROR ELIMIT, non-fatal,
 * with the SNAPSHOT's seq or 0 (PROTOCOL.md 7.15), and keeps the picture
 * it has. */
/* Target i's frame: its own H.264 access unit, or the one frame of all
 * (images, and an H.264 view's still in another encoding). */
static struct bc_shared *frame_of(const struct bc_work_done *d, uint32_t i)
{
	return d->vframes[i] ? d->vframes[i] : d->frame;
}

static bool over_limit(struct bc_member *m, const struct bc_work_done *d,
                       uint32_t i)
{
	const struct bc_job_req *q = d->req;
	const struct bc_shared *fr = frame_of(d, i);
	size_t len = fr ? fr->len - BC_PROTO_HEADER_SIZE : 0;
	if (d->outcome != BC_WORK_TOO_BIG &&
	    len <= (size_t)m->peer->max_frame_bytes) {
		return false;
	}
	bc_log(BC_LOG_WARN,
	       "client %u: frame %u not sent: over its limit of %u",
	       m->peer->ref.gen, q->frame_no, m->peer->max_frame_bytes);
	bc__send_error(m, q->kind == BC_JOB_SNAPSHOT ? q->seq : 0, BC_ELIMIT,
	               "the %s (%ux%u) does not fit the frame size limit (%u "
	               "bytes)",
	               q->kind == BC_JOB_SNAPSHOT ? "snapshot" : "frame",
	               q->width, q->height, m->peer->max_frame_bytes);
	return true;
}

/* The job's frame to its target i, m. */
static void send_frame(struct bc_member *m, const struct bc_work_done *d,
                       uint32_t i)
{
	struct bc_shared *fr = frame_of(d, i);
	if (d->vframes[i]) {
		bc_vstream_delivered(d->req->video[i]);
	}
	m->ss->link->send_frame(m->ss->link->ud, m->peer->ref, fr,
	                        d->req->target_camera_seq[i]);
	m->frames++;
}

static void pick_done(struct bc_member *m, const struct bc_work_done *d)
{
	struct bc_msg r = {.type = BC_MSG_PICK_RESULT, .seq = d->req->seq};
	r.pick_result.x = d->req->pick_x;
	r.pick_result.y = d->req->pick_y;
	r.pick_result.node = d->hit ? d->node : 0;
	if (d->hit) {
		memcpy(r.pick_result.position, d->position,
		       sizeof(d->position));
		r.pick_result.depth = d->depth;
	}
	bc__send(m, &r);
}

static void snapshot_done(struct bc_member *m, const struct bc_work_done *d)
{
	uint32_t seq = d->req->seq;
	switch (d->outcome) {
	case BC_WORK_DONE:
	case BC_WORK_TOO_BIG:
		if (!over_limit(m, d, 0)) {
			send_frame(m, d, 0);
			m->answers_unsent++;
		}
		break;
	case BC_WORK_OOM:
		bc__send_error(m, seq, BC_ENOMEM,
		               "the server is out of memory for this snapshot");
		break;
	case BC_WORK_DROPPED:
		break;
	default:
		bc__send_error(m, seq, BC_EIO,
		               "the snapshot could not be rendered or encoded");
		break;
	}
}

/* Takes job out of m's requests; false when it was not one of them (m
 * left and came back meanwhile). */
static bool forget_request(struct bc_member *m, const struct bc_job *job)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_CLIENT_REQUESTS; i++) {
		if (m->req_jobs[i] == job) {
			m->req_jobs[i] = NULL;
			m->requests--;
			return true;
		}
	}
	return false;
}

/* m's H.264 encoder failed (why): its view goes on in the VIEW's still
 * encoding or the first image encoding its HELLO listed, as if its VIEW
 * had asked for it, and the client hears ECODEC naming it (PROTOCOL.md
 * 7.15); without one it gets no frames until its next VIEW. */
static void video_fallback(struct bc_member *m, const char *why)
{
	static const enum bc_proto_encoding order[] = {
	    BC_PROTO_ENC_JPEG, BC_PROTO_ENC_PNG, BC_PROTO_ENC_RAW};
	enum bc_proto_encoding e = m->view.still_encoding;
	for (size_t k = 0; !e && k < sizeof(order) / sizeof(order[0]); k++) {
		if (m->peer->encodings & (1u << (order[k] - 1))) {
			e = order[k];
		}
	}
	bc_vstream_unref(m->vstream);
	m->vstream = NULL;
	m->shown.view = 0;
	if (!e) {
		m->has_view = false;
		bc__send_error(m, 0, BC_ECODEC,
		               "the H.264 encoder failed (%s) and the client "
		               "listed no other encoding: no frames until it "
		               "sends VIEW again",
		               why);
		return;
	}
	m->view.encoding = e;
	m->view.still_encoding = BC_PROTO_ENC_INVALID;
	m->dirty = true;
	bc__send_error(m, 0, BC_ECODEC,
	               "the H.264 encoder failed (%s): frames come as %s "
	               "until the next VIEW",
	               why, bc_proto_encoding_name(e));
}

/* A frame for the job's target i, m. */
static void frame_to(struct bc_member *m, const struct bc_work_done *d,
                     uint32_t i)
{
	if (m->job == d->job) {
		m->job = NULL;
	}
	if ((d->vfailed >> i) & 1u) {
		/* Its stream's encoder failed; the others' frames went. */
		if (m->vstream && m->vstream == d->req->video[i]) {
			video_fallback(m, d->why);
		}
		return;
	}
	switch (d->outcome) {
	case BC_WORK_DONE:
	case BC_WORK_TOO_BIG:
		if (over_limit(m, d, i)) {
			break;
		}
		send_frame(m, d, i);
		if (!m->ss || !m->session) {
			/* The transport dropped the client while queueing it
			 * (a frame it left unread too long): it is gone. */
			break;
		}
		m->frame_out = true;
		m->shown = d->shown;
		m->still_sent = d->shown.still;
		/* A finer level is owed while nothing else changes; during
		 * an interaction it waits for its end (the still timer), so
		 * the next camera or edit never queues behind a refinement.
		 * A frame of an older order than the session's is owed anew
		 * too (an edit came while it rendered). */
		m->dirty = m->dirty ||
		           (d->shown.refining &&
		            bc__now_ms(m->ss) >= m->interacting_until) ||
		           d->order < m->session->order;
		break;
	case BC_WORK_NOTHING:
	case BC_WORK_OOM:
		m->dirty = true;
		break;
	case BC_WORK_FAILED:
		/* Drawing it again would fail the same way: the client hears
		 * why, and the view waits for its next change (PROTOCOL.md
		 * 7.15, "Frames that cannot be drawn"). */
		bc__send_error(m, 0,
		               d->code == BC_ELIMIT || d->code == BC_EGL ||
		                       d->code == BC_EDEPTH
		                   ? d->code
		                   : BC_EIO,
		               "this view's frame could not be drawn (%s); "
		               "the next VIEW, CAMERA or edit tries again",
		               d->why[0] ? d->why : "no reason given");
		break;
	default:
		break;
	}
}

static void note_times(struct bc_sessions *ss, const struct bc_work_done *d)
{
	if (d->render_ms <= 0.0) {
		return;
	}
	ss->render_ms_last = d->render_ms;
	ss->encode_ms_last = d->encode_ms;
	ss->render_ms_avg = ss->render_ms_avg == 0.0
	                        ? d->render_ms
	                        : 0.9 * ss->render_ms_avg + 0.1 * d->render_ms;
	ss->encode_ms_avg = ss->encode_ms_avg == 0.0
	                        ? d->encode_ms
	                        : 0.9 * ss->encode_ms_avg + 0.1 * d->encode_ms;
}

void bc_sessions_job_done(void *ud, const struct bc_work_done *d)
{
	struct bc_sessions *ss = ud;
	const struct bc_job_req *q = d->req;
	struct bc_session *s = bc__session_by_id(ss, q->session_id);
	struct bc_member *m;
	note_times(ss, d);
	if (q->kind != BC_JOB_FRAME) {
		if ((m = target(ss, q, 0)) && forget_request(m, d->job)) {
			if (q->kind == BC_JOB_PICK) {
				pick_done(m, d);
			} else {
				snapshot_done(m, d);
			}
		}
		return;
	}
	for (uint32_t i = 0; i < q->ntargets; i++) {
		if ((m = target(ss, q, i))) {
			frame_to(m, d, i);
		}
	}
	if (s && !s->removed) {
		if (d->outcome == BC_WORK_OOM) {
			bc_log(BC_LOG_ERROR,
			       "session %u: frame %u failed; retrying in %u ms",
			       s->id, q->frame_no, BC_SRV_OOM_RETRY_MS);
			uv_timer_start(&s->kick, kick_due, BC_SRV_OOM_RETRY_MS,
			               0);
		} else {
			bc__schedule(s);
		}
	}
}

/* ---- requests -------------------------------------------------------------- */

int bc_handle_camera(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	bc_edit_camera_from_msg(&msg->camera, &cam);
	if (bc_camera_validate(&cam, &ei)) {
		bc__send_error(m, msg->seq, ei.code, "%s", ei.msg);
		return 0;
	}
	m->camera = cam;
	m->has_camera = true;
	m->camera_seq = msg->seq;
	m->interacting_until = (msg->flags & BC_PROTO_FLAG_INTERACTING)
	                           ? bc__now_ms(m->ss) + BC_SRV_STILL_DELAY_MS
	                           : 0;
	bc__owe_frame(m);
	/* A follower leaves the follow; a presenter's followers track. */
	bc__present_camera_moved(m, msg->flags);
	/* Before joining, the camera waits for the session. */
	if (m->session) {
		bc__schedule(m->session);
	}
	return 0;
}

/* A VIEW or a snapshot tile (what) of w x h over WELCOME's max_dim is
 * refused with ERANGE: true when it was. */
static bool over_max_dim(struct bc_member *m, uint32_t seq, const char *what,
                         uint32_t w, uint32_t h)
{
	if (w <= BC_SRV_MAX_DIM && h <= BC_SRV_MAX_DIM) {
		return false;
	}
	bc__send_error(m, seq, BC_ERANGE,
	               "%s %ux%u is over this server's %ux%u", what, w, h,
	               BC_SRV_MAX_DIM, BC_SRV_MAX_DIM);
	return true;
}

/* Whether this server can encode m's H.264 VIEW msg: an encoder exists
 * (ENOTSUP), and the size is one H.264 decoders take (ERANGE). */
static bool video_view_ok(struct bc_member *m, const struct bc_msg *msg)
{
	const struct bc_msg_view *v = &msg->view;
	uint32_t mbs = ((v->width + 15u) / 16u) * ((v->height + 15u) / 16u);
	if (!bc_vstream_can_encode(m->ss->video.backend)) {
		bc__send_error(m, msg->seq, BC_ENOTSUP,
		               "this server has no H.264 encoder; ask for "
		               "JPEG, PNG or raw");
		return false;
	}
	if (v->width > BC_PROTO_MAX_VIDEO_DIM ||
	    v->height > BC_PROTO_MAX_VIDEO_DIM ||
	    mbs > BC_PROTO_MAX_VIDEO_MBS) {
		bc__send_error(m, msg->seq, BC_ERANGE,
		               "an H.264 view of %ux%u is over %u pixels a "
		               "side or %u macroblocks (4096x2304); ask for a "
		               "smaller view or an image encoding",
		               v->width, v->height, BC_PROTO_MAX_VIDEO_DIM,
		               BC_PROTO_MAX_VIDEO_MBS);
		return false;
	}
	return true;
}

struct module_task {
	struct bc_task t;
	struct bc_errinfo ei;
	int rc;
};

static void module_run(struct bc_task *t)
{
	struct module_task *mt = (struct module_task *)t;
	mt->rc = bc_vstream_load(&mt->ei);
}

/* The log says once why encoding 4 is refused (a module found at the
 * start that did not open). */
static void module_done(struct bc_task *t)
{
	static bool told;
	struct module_task *mt = (struct module_task *)t;
	if (mt->rc && !told) {
		told = true;
		bc_log(BC_LOG_WARN, "%s; views of encoding 4 are refused",
		       mt->ei.msg);
	}
	bc_free(mt);
}

/* The first VIEW of encoding 4 in the daemon's life: the H.264 module
 * opens on a task (FFmpeg's libraries: tens of milliseconds, up to a
 * second sanitized) while the VIEW waits parked behind it, and the rest of
 * m's session with it; other sessions go on. Returns BC_PARK, or 0 when
 * the module was opened here: a VIEW before the client joined (no session
 * to park behind; the load its HELLO began is waited for), or no memory
 * for the task. */
static int open_video_module(struct bc_member *m, uint32_t seq)
{
	struct module_task *mt = m->session ? bc_calloc(1, sizeof(*mt)) : NULL;
	if (!mt) {
		(void)bc_vstream_load(NULL);
		return 0;
	}
	mt->t.run = module_run;
	mt->t.done = module_done;
	mt->t.holds_order = true;
	bc__task_start(m->session, &mt->t);
	return bc__park(m->session, m, seq);
}

int bc_handle_view(struct bc_member *m, const struct bc_msg *msg)
{
	const struct bc_msg_view *v = &msg->view;
	if (over_max_dim(m, msg->seq, "view", v->width, v->height)) {
		return 0;
	}
	if (!(m->peer->encodings & (1u << (v->encoding - 1))) ||
	    (v->still_encoding &&
	     !(m->peer->encodings & (1u << (v->still_encoding - 1))))) {
		bc__send_error(m, msg->seq, BC_EINVAL,
		               "the view asks for an encoding the client's "
		               "HELLO did not list");
		return 0;
	}
	if (v->encoding == BC_PROTO_ENC_H264) {
		if (!bc_vstream_loaded() &&
		    open_video_module(m, msg->seq) == BC_PARK) {
			return BC_PARK;
		}
		if (!video_view_ok(m, msg)) {
			return 0;
		}
	}
	/* Every VIEW of encoding 4 starts a stream: its first frame is an
	 * IDR (PROTOCOL.md 7.15). */
	bc_vstream_unref(m->vstream);
	m->vstream = NULL;
	m->video_bps = 0;
	if (v->encoding == BC_PROTO_ENC_H264 &&
	    !(m->vstream = bc_vstream_new(&m->ss->video))) {
		m->has_view = false;
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "the server is out of memory");
		return 0;
	}
	m->view = *v;
	m->has_view = true;
	m->shown.view = 0;
	bc__owe_frame(m);
	if (m->session) {
		bc__schedule(m->session);
	}
	return 0;
}

/* A job request for m alone at its full view size, answering request
 * seq (a PICK or a SNAPSHOT), or false: m already has
 * BC_SRV_MAX_CLIENT_REQUESTS of them queued (answered EBUSY). */
static bool single_req(struct bc_member *m, uint32_t seq, enum bc_job_kind kind,
                       struct bc_job_req *q)
{
	if (m->requests + m->answers_unsent >= BC_SRV_MAX_CLIENT_REQUESTS) {
		bc__send_error(m, seq, BC_EBUSY,
		               "%u picks and snapshots are already being "
		               "rendered for this client; wait for their "
		               "answers",
		               m->requests + m->answers_unsent);
		return false;
	}
	memset(q, 0, sizeof(*q));
	q->kind = kind;
	q->session_id = m->session->id;
	q->camera = m->camera;
	q->width = m->view.width;
	q->height = m->view.height;
	q->seq = seq;
	q->targets[0] = m->peer->ref;
	q->target_camera_seq[0] = m->camera_seq;
	q->ntargets = 1;
	return true;
}

/* PICK and SNAPSHOT need the render copy: 0 when it is there, BC_PARK
 * while it is made (the request comes again after), -1 when it cannot be
 * (answered). */
static int single_copy(struct bc_member *m, uint32_t seq)
{
	int rc = bc__session_copy(m->session);
	if (rc == BC_PARK) {
		return bc__park(m->session, m, seq);
	}
	if (rc) {
		bc__send_error(m, seq, rc,
		               "no memory for the session's render copy; try "
		               "again later");
		return -1;
	}
	return 0;
}

static void submit_single(struct bc_member *m, const struct bc_job_req *q)
{
	struct bc_job *job = bc_work_submit(m->ss->work, q);
	if (!job) {
		bc_log(BC_LOG_ERROR, "out of memory for a render request");
		bc__send_error(m, q->seq, BC_ENOMEM,
		               "the server is out of memory");
		return;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_CLIENT_REQUESTS; i++) {
		if (!m->req_jobs[i]) {
			m->req_jobs[i] = job;
			break;
		}
	}
	m->requests++;
}

int bc_handle_pick(struct bc_member *m, const struct bc_msg *msg)
{
	struct bc_job_req q;
	int rc;
	if (!m->session || !m->has_view || msg->pick.x >= m->view.width ||
	    msg->pick.y >= m->view.height) {
		bc__send_error(m, msg->seq, BC_ERANGE,
		               "pick outside the view (send VIEW first)");
		return 0;
	}
	if ((rc = single_copy(m, msg->seq))) {
		return rc == BC_PARK ? rc : 0;
	}
	if (single_req(m, msg->seq, BC_JOB_PICK, &q)) {
		q.pick_x = msg->pick.x;
		q.pick_y = msg->pick.y;
		submit_single(m, &q);
	}
	return 0;
}

int bc_handle_snapshot(struct bc_member *m, const struct bc_msg *msg)
{
	const struct bc_msg_snapshot *sn = &msg->snapshot;
	struct bc_job_req q;
	int rc;
	if (!m->session || !m->has_view) {
		bc__send_error(m, msg->seq, BC_ESTATE,
		               "join a session and send VIEW before SNAPSHOT");
		return 0;
	}
	if (sn->has_tile && !(m->peer->features & BC_PROTO_FEATURE_TILES)) {
		bc__send_error(m, msg->seq, BC_ENOTSUP,
		               "the tile form of SNAPSHOT needs the feature "
		               "TILES announced in HELLO");
		return 0;
	}
	if (sn->has_tile && over_max_dim(m, msg->seq, "tile", sn->tile_width,
	                                 sn->tile_height)) {
		return 0;
	}
	if ((rc = single_copy(m, msg->seq))) {
		return rc == BC_PARK ? rc : 0;
	}
	if (single_req(m, msg->seq, BC_JOB_SNAPSHOT, &q)) {
		if (sn->has_tile) {
			q.width = sn->tile_width;
			q.height = sn->tile_height;
			q.win = (struct bc_job_window){sn->tile_x, sn->tile_y,
			                               sn->full_width,
			                               sn->full_height};
		}
		q.encoding = (int)msg->snapshot.encoding;
		q.quality_still = 100;
		q.final = true;
		q.camera_seq = m->camera_seq;
		q.order = m->session->order;
		q.scene_order = m->session->scene_order;
		q.frame_no = ++m->ss->frame_no;
		q.snapshot_planes = msg->snapshot.planes;
		submit_single(m, &q);
	}
	return 0;
}
