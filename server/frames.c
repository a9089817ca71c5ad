/*
 * Frames (loop thread): which member is owed a frame, and when. Frames are
 * rendered on change only. Each member has a camera and a view; while
 * changes marked INTERACTING keep arriving a member's frames are
 * interactive (coarse levels, damage rectangles, interactive quality);
 * BC_SRV_STILL_DELAY_MS after the last one it gets the still. Members whose
 * frames would be equal share one render and one encode (the render thread
 * decides levels and rectangles: rthread.c). Also the requests that shape
 * frames: CAMERA, VIEW, PICK and SNAPSHOT.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "server.h"

static void kick_due(uv_timer_t *t)
{
	bc_session_schedule(t->data);
}

/* ---- frames -------------------------------------------------------------- */

/* Two members can share a render when everything that shapes the frame is
 * equal. */
static bool same_frame(const struct bc_conn *a, const struct bc_conn *b,
                       bool still_a, bool still_b)
{
	return still_a == still_b &&
	       memcmp(&a->camera, &b->camera, sizeof(a->camera)) == 0 &&
	       a->view.width == b->view.width &&
	       a->view.height == b->view.height &&
	       a->view.encoding == b->view.encoding &&
	       a->view.quality_interactive == b->view.quality_interactive &&
	       a->view.quality_still == b->view.quality_still &&
	       a->view.downscale == b->view.downscale &&
	       a->encodings == b->encodings &&
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

/* The VIEW's encoding governs every frame, coarse levels and damage
 * rectangles included (PROTOCOL.md 7.14): a client that asks PNG gets no
 * JPEG it may not want; one that wants cheap interactive frames asks JPEG. */
static int frame_encoding(const struct bc_conn *c, bool still)
{
	(void)still;
	return (int)c->view.encoding;
}

static void still_due(uv_timer_t *timer)
{
	struct bc_session *s = timer->data;
	uint64_t now = bc_now_ms(s->srv);
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_conn *m = bc_conn_get(s->srv, s->members[i]);
		if (m && m->has_view && !m->still_sent &&
		    now >= m->interacting_until) {
			m->dirty = true;
		}
	}
	bc_session_schedule(s);
}

void bc_session_schedule(struct bc_session *s)
{
	struct bc_srv *srv = s->srv;
	uint64_t now = bc_now_ms(srv), next_still = 0;
	struct bc_conn *group[BC_PROTO_MAX_MEMBERS];
	bool done[BC_PROTO_MAX_MEMBERS] = {0};
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_conn *c = bc_conn_get(srv, s->members[i]);
		struct bc_rjob *job;
		uint32_t ng = 0;
		bool still;
		/* One frame in flight per client: while one is being
		 * written, changes only accumulate (the next frame shows the
		 * newest state); a client that stopped reading costs no
		 * renders. */
		if (!c || done[i] || !c->has_view || !c->dirty ||
		    c->render_pending || c->frame_writing) {
			continue;
		}
		still = now >= c->interacting_until;
		if (!still &&
		    (next_still == 0 || c->interacting_until > next_still)) {
			next_still = c->interacting_until;
		}
		group[ng++] = c;
		for (uint32_t j = i + 1; j < s->nmembers; j++) {
			struct bc_conn *o = bc_conn_get(srv, s->members[j]);
			if (o && !done[j] && o->has_view && o->dirty &&
			    !o->render_pending && !o->frame_writing &&
			    same_frame(c, o, still,
			               now >= o->interacting_until)) {
				group[ng++] = o;
				done[j] = true;
			}
		}
		if (!(job = bc_calloc(1, sizeof(*job))) ||
		    !(job->targets = bc_calloc(ng, sizeof(*job->targets)))) {
			/* The group stays dirty: owed its frame, retried. */
			bc_free(job);
			bc_log(BC_LOG_ERROR,
			       "session %u: out of memory for a frame job; "
			       "retrying in %u ms",
			       s->id, BC_SRV_OOM_RETRY_MS);
			uv_timer_start(&s->kick, kick_due, BC_SRV_OOM_RETRY_MS,
			               0);
			break;
		}
		job->session_id = s->id;
		job->camera = c->camera;
		job->width = c->view.width;
		job->height = c->view.height;
		job->encoding = frame_encoding(c, true);
		job->encoding_interactive = frame_encoding(c, false);
		job->quality_still = c->view.quality_still;
		job->quality_interactive = c->view.quality_interactive;
		job->max_level = max_level(c->view.downscale);
		job->final = still;
		job->shown = c->shown;
		job->camera_seq = c->camera_seq;
		job->order = s->order;
		job->frame_no = ++srv->frame_no;
		for (uint32_t g = 0; g < ng; g++) {
			struct bc_conn *m = group[g];
			job->targets[g] = bc_conn_ref_of(m);
			m->dirty = false;
			m->render_pending = true;
		}
		job->ntargets = ng;
		bc_rthread_job(srv, job);
	}
	if (next_still > now) {
		uv_timer_start(&s->still_timer, still_due, next_still - now, 0);
	}
}

void bc_session_client_ready(struct bc_conn *c)
{
	/* Not at once: the other members' frame writes usually finish in the
	 * same loop turn, and scheduling after them keeps equal views in one
	 * shared render. */
	if (c->session && c->dirty) {
		uv_timer_start(&c->session->kick, kick_due, 0, 0);
	}
}

void bc_session_frame_failed(struct bc_srv *srv, const struct bc_rjob *job)
{
	struct bc_session *s = bc_session_by_id(srv, job->session_id);
	for (uint32_t i = 0; i < job->ntargets; i++) {
		struct bc_conn *c = bc_conn_get(srv, job->targets[i]);
		if (!c) {
			continue;
		}
		if (job->pick || job->snapshot_seq) {
			bc_conn_send_error(
			    c, job->pick ? job->pick_seq : job->snapshot_seq,
			    BC_ENOMEM, false, "the server is out of memory");
			continue;
		}
		c->render_pending = false;
		c->dirty = true;
	}
	if (s && !job->pick && !job->snapshot_seq) {
		bc_log(BC_LOG_ERROR,
		       "session %u: frame %u failed; retrying in %u ms", s->id,
		       job->frame_no, BC_SRV_OOM_RETRY_MS);
		uv_timer_start(&s->kick, kick_due, BC_SRV_OOM_RETRY_MS, 0);
	}
}

void bc_session_frame_done(struct bc_srv *srv, uint32_t session_id,
                           const struct bc_conn_ref *targets, uint32_t n)
{
	struct bc_session *s = bc_session_by_id(srv, session_id);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_conn *c = bc_conn_get(srv, targets[i]);
		if (c) {
			c->render_pending = false;
		}
	}
	if (s) {
		bc_session_schedule(s);
	}
}

void bc_handle_camera(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	bc_edit_camera_from_msg(&m->camera, &cam);
	if (bc_camera_validate(&cam, &ei)) {
		bc_conn_send_error(c, m->seq, ei.code, false, "%s", ei.msg);
		return;
	}
	c->camera = cam;
	c->has_camera = true;
	c->camera_seq = m->seq;
	c->dirty = true;
	c->interacting_until = (m->flags & BC_PROTO_FLAG_INTERACTING)
	                           ? bc_now_ms(c->srv) + BC_SRV_STILL_DELAY_MS
	                           : 0;
	/* A follower leaves the follow; a presenter's followers track. */
	bc_present_camera_moved(c, m->flags);
	/* Before joining, the camera waits for the session. */
	if (c->session) {
		bc_session_schedule(c->session);
	}
}

void bc_handle_view(struct bc_conn *c, const struct bc_msg *m)
{
	const struct bc_msg_view *v = &m->view;
	if (v->width > BC_SRV_MAX_DIM || v->height > BC_SRV_MAX_DIM) {
		bc_conn_send_error(c, m->seq, BC_ERANGE, false,
		                   "view %ux%u is over this server's %ux%u",
		                   v->width, v->height, BC_SRV_MAX_DIM,
		                   BC_SRV_MAX_DIM);
		return;
	}
	if (!(c->encodings & (1u << (v->encoding - 1)))) {
		bc_conn_send_error(c, m->seq, BC_EINVAL, false,
		                   "the view asks for an encoding the "
		                   "client's HELLO did not list");
		return;
	}
	c->view = *v;
	c->has_view = true;
	c->dirty = true;
	c->shown.view = 0;
	if (c->session) {
		bc_session_schedule(c->session);
	}
}

/* A render job for c alone at its full view size, answering request seq
 * (a PICK or a SNAPSHOT), or NULL: c already has BC_SRV_MAX_CLIENT_REQUESTS
 * of them queued (answered EBUSY), or out of memory (ENOMEM). */
static struct bc_rjob *single_job(struct bc_conn *c, uint32_t seq)
{
	struct bc_rjob *job;
	if (c->requests >= BC_SRV_MAX_CLIENT_REQUESTS) {
		bc_conn_send_error(c, seq, BC_EBUSY, false,
		                   "%u picks and snapshots are already being "
		                   "rendered for this client; wait for their "
		                   "answers",
		                   c->requests);
		return NULL;
	}
	job = bc_calloc(1, sizeof(*job));
	if (!job || !(job->targets = bc_calloc(1, sizeof(*job->targets)))) {
		bc_free(job);
		bc_log(BC_LOG_ERROR, "out of memory for a render request");
		bc_conn_send_error(c, seq, BC_ENOMEM, false,
		                   "the server is out of memory");
		return NULL;
	}
	c->requests++;
	job->session_id = c->session->id;
	job->camera = c->camera;
	job->width = c->view.width;
	job->height = c->view.height;
	job->targets[0] = bc_conn_ref_of(c);
	job->ntargets = 1;
	return job;
}

void bc_handle_pick(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_rjob *job;
	if (!c->session || !c->has_view || m->pick.x >= c->view.width ||
	    m->pick.y >= c->view.height) {
		bc_conn_send_error(c, m->seq, BC_ERANGE, false,
		                   "pick outside the view (send VIEW first)");
		return;
	}
	if (!(job = single_job(c, m->seq))) {
		return;
	}
	job->pick = true;
	job->pick_x = m->pick.x;
	job->pick_y = m->pick.y;
	job->pick_seq = m->seq;
	bc_rthread_job(c->srv, job);
}

void bc_handle_snapshot(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_rjob *job;
	if (!c->session || !c->has_view) {
		bc_conn_send_error(c, m->seq, BC_ESTATE, false,
		                   "join a session and send VIEW before "
		                   "SNAPSHOT");
		return;
	}
	if (!(job = single_job(c, m->seq))) {
		return;
	}
	job->encoding = (int)m->snapshot.encoding;
	job->quality_still = 100;
	job->final = true;
	job->camera_seq = c->camera_seq;
	job->order = c->session->order;
	job->frame_no = ++c->srv->frame_no;
	job->snapshot_seq = m->seq;
	job->snapshot_planes = m->snapshot.planes;
	bc_rthread_job(c->srv, job);
}
