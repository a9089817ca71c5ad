/*
 * blobcast-view's side of the conversation: every message from the server
 * (frames into textures, PICK answers into the drag, EDIT_APPLIED into the
 * edit queue and latency meter, SCENE_STATE into the camera) and every
 * message to it (VIEW, CAMERA at a bounded rate, EDITs through the queue,
 * PICK, SNAPSHOT). Nothing here waits for the network: receiving uses
 * bc_client_recv() with a zero timeout, sending writes one small message.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "app.h"
#include "blobcast/edit.h"
#include "blobcast/image.h"
#include "blobcast/log.h"

/* ---- sending ------------------------------------------------------------- */

/* The largest side the daemon (WELCOME max_dim) and our textures take. */
static uint32_t view_max(const struct bc_viewer_app *a)
{
	const struct bc_client_info *info = bc_client_info(a->c);
	uint32_t max = info->max_dim ? info->max_dim : BC_PROTO_MAX_DIM;
	if (a->gl.max_tex > 0 && (uint32_t)a->gl.max_tex < max) {
		max = (uint32_t)a->gl.max_tex;
	}
	return max;
}

bool bc_viewer_view_changed(struct bc_viewer_app *a)
{
	int fw = 0, fh = 0;
	uint32_t w, h;
	glfwGetFramebufferSize(a->win, &fw, &fh);
	if (fw <= 0 || fh <= 0) {
		return false;
	}
	bc_viewer_view_size((uint32_t)fw, (uint32_t)fh, view_max(a), &w, &h);
	return w != a->view_w || h != a->view_h;
}

int bc_viewer_send_view(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	int fw = 0, fh = 0, ww = 0, wh = 0, rc;
	uint32_t w, h, max = view_max(a);
	bool capped;
	/* Pixels, not screen coordinates: on a HiDPI screen the framebuffer
	 * is larger than the window, and the picture is rendered for it. */
	glfwGetFramebufferSize(a->win, &fw, &fh);
	/* A minimized window has no size; keep the last view. */
	if (fw <= 0 || fh <= 0) {
		return 0;
	}
	capped = bc_viewer_view_size((uint32_t)fw, (uint32_t)fh, max, &w, &h);
	if (capped && !a->view_capped_said) {
		fprintf(stderr,
		        "blobcast-view: the window is %dx%d pixels; the daemon "
		        "renders at most %u a side: the view is %ux%u, scaled "
		        "up\n",
		        fw, fh, max, w, h);
		a->view_capped_said = true;
	}
	rc = bc_client_view(
	    a->c,
	    &(struct bc_msg_view){
	        .width = (uint16_t)w,
	        .height = (uint16_t)h,
	        .encoding = a->o.encoding,
	        /* Interactive frames trade quality for speed. */
	        .quality_interactive =
	            (uint8_t)(a->o.quality < 70 ? a->o.quality : 70),
	        .quality_still = a->o.quality,
	        .downscale = a->o.downscale,
	        .still_encoding =
	            a->o.exact_still ? BC_PROTO_ENC_PNG : BC_PROTO_ENC_INVALID,
	    },
	    &a->view_seq, &ei);
	if (rc) {
		bc_viewer_status(a, "VIEW not sent: %s", ei.msg);
		return rc;
	}
	a->view_w = w;
	a->view_h = h;
	a->view_sent_at = bc_viewer_now_ms();
	if (a->o.verbose) {
		float sx = 1.0f, sy = 1.0f;
		glfwGetWindowSize(a->win, &ww, &wh);
		glfwGetWindowContentScale(a->win, &sx, &sy);
		printf("view %ux%u framebuffer %dx%d window %dx%d scale "
		       "%.2gx%.2g%s\n",
		       w, h, fw, fh, ww, wh, (double)sx, (double)sy,
		       capped ? " capped" : "");
		fflush(stdout);
	}
	return 0;
}

void bc_viewer_camera_changed(struct bc_viewer_app *a, bool interacting)
{
	a->cam_dirty = true;
	a->cam_interacting = interacting;
	a->redraw = true;
}

static void send_camera(struct bc_viewer_app *a, double now)
{
	struct bc_errinfo ei = {0};
	uint32_t seq = 0;
	/* Our own camera ends a follow (the server says so with PRESENTER):
	 * F must be pressed again to follow. */
	if (a->roster.following) {
		a->follow_wanted = false;
	}
	bc_viewer_cam_clamp(&a->cam);
	if (bc_client_camera(a->c, &a->cam, a->cam_interacting, &seq, &ei)) {
		bc_viewer_status(a, "CAMERA not sent: %s", ei.msg);
	} else {
		/* Pending since the oldest camera no frame reflects. */
		if (!a->cam_seq) {
			a->cam_seq_at = now;
		}
		a->cam_seq = seq;
	}
	a->cam_dirty = false;
	a->cam_sent_at = now;
}

static void flush_edits(struct bc_viewer_app *a)
{
	while (bc_viewer_edits_ready(&a->edits)) {
		const struct bc_viewer_edit *e = &a->edits.pending;
		struct bc_errinfo ei = {0};
		uint32_t seq = 0;
		if (bc_client_edit_set(a->c, e->node, e->fields, e->nfields,
		                       e->interacting, &seq, &ei)) {
			bc_viewer_status(a, "edit not sent: %s", ei.msg);
			a->edits.has_pending = false;
			return;
		}
		bc_viewer_edits_sent(&a->edits, seq, bc_viewer_now_ms());
	}
}

void bc_viewer_edit(struct bc_viewer_app *a, const struct bc_viewer_edit *e)
{
	bc_viewer_edits_queue(&a->edits, e);
	flush_edits(a);
}

/* FOLLOW or PRESENT with on, not waiting: the answer is a PRESENTER (and
 * an OK), or ERROR ESTATE when nobody presents. */
static int send_toggle(struct bc_viewer_app *a, enum bc_msg_type type, bool on)
{
	struct bc_msg m = {.type = type};
	m.toggle.on = on ? 1 : 0;
	return bc_client_send(a->c, &m, NULL);
}

static const char *member_name(const struct bc_viewer_roster *r, uint32_t id,
                               char *buf, size_t n)
{
	for (size_t i = 0; i < r->n; i++) {
		if (r->m[i].id == id && r->m[i].name[0]) {
			snprintf(buf, n, "%s", r->m[i].name);
			return buf;
		}
	}
	snprintf(buf, n, "member %u", id);
	return buf;
}

void bc_viewer_follow_toggle(struct bc_viewer_app *a)
{
	const struct bc_viewer_roster *r = &a->roster;
	if (a->offline) {
		return;
	}
	if (r->following || a->follow_wanted) {
		a->follow_wanted = false;
		if (r->following && send_toggle(a, BC_MSG_FOLLOW, false)) {
			bc_viewer_status(a, "FOLLOW not sent");
		}
		bc_viewer_status(a, "not following");
		return;
	}
	if (r->presenter && r->presenter == r->self) {
		bc_viewer_status(a, "you present; Shift-F stops presenting");
		return;
	}
	a->follow_wanted = true;
	if (!r->presenter) {
		bc_viewer_status(a, "nobody presents; following whoever "
		                    "starts (F again: not)");
		return;
	}
	/* The presenter's camera takes over: ours is not sent. */
	a->cam_dirty = false;
	if (send_toggle(a, BC_MSG_FOLLOW, true)) {
		bc_viewer_status(a, "FOLLOW not sent");
	}
}

void bc_viewer_present_toggle(struct bc_viewer_app *a)
{
	const struct bc_viewer_roster *r = &a->roster;
	bool on = !(r->presenter && r->presenter == r->self);
	if (a->offline) {
		return;
	}
	if (on) {
		a->follow_wanted = false;
		/* Followers start from the camera we show. */
		if (a->cam_dirty) {
			send_camera(a, bc_viewer_now_ms());
		}
	}
	if (send_toggle(a, BC_MSG_PRESENT, on)) {
		bc_viewer_status(a, "PRESENT not sent");
	}
}

uint32_t bc_viewer_pick(struct bc_viewer_app *a, double x, double y)
{
	struct bc_msg m = {.type = BC_MSG_PICK};
	uint32_t seq = 0;
	float vx, vy;
	if (!a->view_w) {
		return 0;
	}
	bc_viewer_to_view(a, x, y, &vx, &vy);
	m.pick.x = (uint16_t)fminf(fmaxf(vx, 0.0f), (float)(a->view_w - 1));
	m.pick.y = (uint16_t)fminf(fmaxf(vy, 0.0f), (float)(a->view_h - 1));
	if (bc_client_send(a->c, &m, &seq)) {
		return 0;
	}
	return seq;
}

void bc_viewer_undo(struct bc_viewer_app *a, bool redo, bool any)
{
	struct bc_msg m = {.type = redo ? BC_MSG_REDO : BC_MSG_UNDO};
	uint32_t seq = 0;
	if (!bc_viewer_may_edit(a, redo ? "redo" : "undo")) {
		return;
	}
	if (any) {
		if (!(bc_client_info(a->c)->features &
		      BC_PROTO_FEATURE_HISTORY)) {
			/* A scope byte would be refused (ENOTSUP). */
			bc_viewer_status(a,
			                 "this daemon has no per-person undo: "
			                 "Ctrl+Z already takes the session's "
			                 "newest change");
			return;
		}
		m.undo.scope = BC_PROTO_UNDO_SESSION;
	}
	if (bc_client_send(a->c, &m, &seq)) {
		bc_viewer_status(a, "%s not sent", redo ? "REDO" : "UNDO");
		return;
	}
	a->undo_seq = seq;
	a->undo_redo = redo;
}

void bc_viewer_set_session_camera(struct bc_viewer_app *a)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_CAMERA};
	uint32_t seq = 0;
	if (!bc_viewer_may_edit(a, "setting the session's camera")) {
		return;
	}
	bc_edit_camera_to_msg(&a->cam, &m.session_camera);
	if (bc_client_send(a->c, &m, &seq)) {
		bc_viewer_status(a, "SESSION_CAMERA not sent");
		return;
	}
	a->session_cam_seq = seq;
}

void bc_viewer_picture_drop(struct bc_viewer_app *a, const char *why)
{
	if (!a->big) {
		return;
	}
	bc_client_big_free(a->big);
	a->big = NULL;
	bc_client_image_finish(&a->big_img);
	bc_viewer_status(a, "picture abandoned: %s", why);
}

/* S with --snapshot-size: the picture in tiles, taken from the messages
 * as they arrive (bc_viewer_pump) while the window keeps drawing. */
static void request_picture(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	uint32_t done, total;
	if (a->big) {
		bc_viewer_status(a, "a picture is on its way");
		return;
	}
	bc_client_image_init(&a->big_img);
	if (bc_client_big_start(
	        a->c,
	        &(struct bc_client_big_opts){.width = a->o.snap_width,
	                                     .height = a->o.snap_height},
	        &a->big_img, &a->big, &ei)) {
		bc_client_image_finish(&a->big_img);
		bc_viewer_status(a, "picture not asked for: %s (%s)", ei.msg,
		                 bc_err_name(ei.code));
		return;
	}
	bc_client_big_progress(a->big, &done, &total);
	bc_viewer_status(a, "picture %ux%u: asking for %u tile%s",
	                 a->o.snap_width, a->o.snap_height, total,
	                 total == 1 ? "" : "s");
}

void bc_viewer_request_snapshot(struct bc_viewer_app *a)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	if (a->o.snap_width) {
		request_picture(a);
		return;
	}
	if (a->snapshot_seq) {
		bc_viewer_status(a, "a snapshot is on its way");
		return;
	}
	m.snapshot.encoding = BC_PROTO_ENC_PNG;
	if (bc_client_send(a->c, &m, &a->snapshot_seq)) {
		a->snapshot_seq = 0;
		bc_viewer_status(a, "SNAPSHOT not sent");
		return;
	}
	bc_viewer_status(a, "snapshot requested");
}

double bc_viewer_send_due(struct bc_viewer_app *a, double now)
{
	double next = -1.0;
#define DUE(t)                                                                 \
	do {                                                                   \
		double in_ = (t)-now;                                          \
		if (next < 0.0 || in_ < next) {                                \
			next = in_ > 0.0 ? in_ : 0.0;                          \
		}                                                              \
	} while (0)
	if (a->view_due > 0.0) {
		if (now >= a->view_due) {
			a->view_due = 0.0;
			/* A VIEW of the same size would only make the daemon
			 * render the picture again. */
			if (bc_viewer_view_changed(a)) {
				bc_viewer_send_view(a);
			}
		} else {
			DUE(a->view_due);
		}
	}
	if (a->cam_final_at > 0.0) {
		if (now >= a->cam_final_at) {
			a->cam_final_at = 0.0;
			bc_viewer_camera_changed(a, false);
		} else {
			DUE(a->cam_final_at);
		}
	}
	if (a->cam_dirty) {
		if (!a->cam_interacting ||
		    now - a->cam_sent_at >= BC_VIEWER_CAMERA_EVERY_MS) {
			send_camera(a, now);
		} else {
			DUE(a->cam_sent_at + BC_VIEWER_CAMERA_EVERY_MS);
		}
	}
	if (a->wheel.what != BC_VIEWER_WHEEL_NONE) {
		if (now >= a->wheel.end_at) {
			struct bc_viewer_edit e = a->wheel.edit;
			e.interacting = false;
			a->wheel.what = BC_VIEWER_WHEEL_NONE;
			bc_viewer_edit(a, &e);
		} else {
			DUE(a->wheel.end_at);
		}
	}
	flush_edits(a);
#undef DUE
	return next;
}

double bc_viewer_pending_since(const struct bc_viewer_app *a)
{
	double t = 0.0;
#define OLDEST(x)                                                              \
	do {                                                                   \
		double x_ = (x);                                               \
		if (x_ > 0.0 && (t == 0.0 || x_ < t)) {                        \
			t = x_;                                                \
		}                                                              \
	} while (0)
	OLDEST(a->view_sent_at);
	if (a->cam_seq) {
		OLDEST(a->cam_seq_at);
	}
	if (a->edits.nsent) {
		OLDEST(a->edits.sent[0].at);
	}
	if (a->edits.nshown) {
		OLDEST(a->edits.shown[0].at);
	}
#undef OLDEST
	return t;
}

/* ---- receiving ----------------------------------------------------------- */

/* A name for a snapshot file that does not exist yet. */
static void snapshot_name(struct bc_viewer_app *a, char *out, size_t n)
{
	for (unsigned k = 1; k < 100000; k++) {
		snprintf(out, n, "%s/blobcast-snapshot-%03u.png",
		         a->o.snapshot_dir, k);
		if (access(out, F_OK) != 0) {
			return;
		}
	}
}

/* Writes a snapshot or a picture to the next free name. */
static void save_picture(struct bc_viewer_app *a,
                         const struct bc_client_image *img)
{
	struct bc_errinfo ei = {0};
	char path[4096];
	snapshot_name(a, path, sizeof(path));
	/* Writing a PNG takes tens of milliseconds (a second for 8192^2):
	 * one stutter on a key press is acceptable for a file the user
	 * asked for. */
	if (bc_image_write_rgba8(path, img->width, img->height, img->rgba,
	                         &ei)) {
		bc_viewer_status(a, "snapshot not saved: %s", ei.msg);
		return;
	}
	bc_viewer_status(a, "saved %s (%ux%u, lossless)",
	                 strrchr(path, '/') ? strrchr(path, '/') + 1 : path,
	                 img->width, img->height);
	if (a->o.verbose) {
		printf("snapshot %s %ux%u\n", path, img->width, img->height);
		fflush(stdout);
	}
}

static void got_snapshot(struct bc_viewer_app *a, const struct bc_msg *m)
{
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	bc_client_image_init(&img);
	a->snapshot_seq = 0;
	if (bc_client_image_apply(&img, m, &ei)) {
		bc_viewer_status(a, "snapshot does not decode: %s", ei.msg);
	} else {
		save_picture(a, &img);
	}
	bc_client_image_finish(&img);
}

/* Offers m to the picture in tiles; true when it was one of its. */
static bool picture_take(struct bc_viewer_app *a, const struct bc_msg *m)
{
	struct bc_errinfo ei = {0};
	uint32_t done, total;
	int rc = bc_client_big_take(a->big, m, &ei);
	if (rc == BC_CLIENT_BIG_NOT_OURS) {
		return false;
	}
	if (rc < 0) {
		bc_viewer_picture_drop(a, ei.msg);
		return true;
	}
	if (rc == BC_CLIENT_BIG_MORE) {
		bc_client_big_progress(a->big, &done, &total);
		bc_viewer_status(a, "picture %ux%u: tile %u of %u",
		                 a->big_img.width, a->big_img.height, done,
		                 total);
		return true;
	}
	bc_client_big_free(a->big);
	a->big = NULL;
	save_picture(a, &a->big_img);
	bc_client_image_finish(&a->big_img);
	return true;
}

uint8_t bc_viewer_encodings(const struct bc_viewer_opts *o)
{
	/* H.264 is announced only when asked for: a server of a text before
	 * it refuses the HELLO. still_encoding came with it. */
	return o->encoding == BC_PROTO_ENC_H264 || o->exact_still
	           ? BC_PROTO_ENCODINGS_ALL
	           : BC_PROTO_ENCODINGS_IMAGES;
}

void bc_viewer_frame_drawn(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	if (a->offline ||
	    !(bc_client_info(a->c)->features & BC_PROTO_FEATURE_ACKS) ||
	    a->frame_got <= a->frame_acked) {
		return;
	}
	if (bc_client_frame_ack(a->c, a->frame_got, &ei)) {
		bc_viewer_status(a, "FRAME_ACK not sent: %s", ei.msg);
		return;
	}
	a->frame_acked = a->frame_got;
}

/* A frame that failed to decode. A broken H.264 chain mends with the
 * KEY frame that a VIEW sent again brings; until it comes, the frames
 * that build on the lost ones fail as expected. */
static void frame_failed(struct bc_viewer_app *a, const struct bc_msg *m,
                         const struct bc_errinfo *ei)
{
	if (m->frame.encoding != BC_PROTO_ENC_H264) {
		bc_viewer_status(a, "frame %u: %s", m->frame.frame_no, ei->msg);
		return;
	}
	if (!a->awaiting_key) {
		bc_viewer_status(a, "frame %u: %s", m->frame.frame_no, ei->msg);
		a->awaiting_key = true;
		bc_viewer_send_view(a);
	}
}

static void got_frame(struct bc_viewer_app *a, const struct bc_msg *m)
{
	const struct bc_msg_frame *fr = &m->frame;
	struct bc_viewer_update up;
	struct bc_errinfo ei = {0};
	const uint8_t *pixels;
	uint32_t w, h;
	/* Every frame is acknowledged once the window has been drawn after
	 * it, snapshots and frames that failed included. */
	if (fr->frame_no > a->frame_got) {
		a->frame_got = fr->frame_no;
	}
	a->redraw = true;
	if (m->flags & BC_PROTO_FLAG_SNAPSHOT) {
		if (m->seq == a->snapshot_seq) {
			got_snapshot(a, m);
		}
		return;
	}
	if (m->flags & BC_PROTO_FLAG_KEY) {
		a->awaiting_key = false;
	}
	if (bc_viewer_frames_apply(&a->frames, m, &up, &ei)) {
		frame_failed(a, m, &ei);
		return;
	}
	if (up.tex == BC_VIEWER_TEX_FULL) {
		pixels = a->frames.comp;
		w = a->frames.width;
		h = a->frames.height;
	} else {
		pixels = a->frames.small.rgba;
		w = a->frames.small.width;
		h = a->frames.small.height;
	}
	if (bc_viewer_gl_upload(&a->gl, up.tex, pixels, w, h, &up, &ei)) {
		bc_viewer_status(a, "frame %u: %s", fr->frame_no, ei.msg);
	}
	if (up.want_refresh) {
		/* Repeating the VIEW makes the server send a whole still. */
		bc_viewer_send_view(a);
	}
	a->nframes++;
	bc_viewer_shot_frame(&a->shot, m->flags, bc_viewer_now_ms());
	if (!a->frames.refining) {
		a->npictures++;
		a->shot_ready = true;
		a->shot_unfinished = false;
	}
	bc_viewer_meter_frame(&a->meter, bc_client_info(a->c)->last_msg_bytes,
	                      bc_viewer_now_ms());
	a->last.frame_no = fr->frame_no;
	a->last.width = fr->width;
	a->last.height = fr->height;
	a->last.image_width = fr->image_width;
	a->last.image_height = fr->image_height;
	a->last.nrects = fr->nrects;
	a->last.order = fr->order;
	a->last.flags = m->flags;
	a->last.encoding = fr->encoding;
	if (!a->settle || fr->order > a->settle_order) {
		a->settle_order = fr->order;
	}
	a->settle = true;
	a->redraw = true;
	a->turn_pending = false;
	a->view_sent_at = 0.0;
	if (a->cam_seq && fr->camera_seq >= a->cam_seq) {
		a->cam_seq = 0;
	}
	if (a->o.verbose) {
		printf(
		    "frame %llu no=%u order=%llu %s %s image=%ux%u level=%u "
		    "rects=%u bytes=%u%s%s%s\n",
		    (unsigned long long)a->nframes, fr->frame_no,
		    (unsigned long long)fr->order,
		    (m->flags & BC_PROTO_FLAG_STILL) ? "still" : "interactive",
		    bc_proto_encoding_name(fr->encoding), fr->image_width,
		    fr->image_height, (unsigned)a->frames.level, fr->nrects,
		    bc_client_info(a->c)->last_msg_bytes,
		    a->frames.refining ? " refining" : "",
		    (m->flags & BC_PROTO_FLAG_INCOMPLETE) ? " incomplete" : "",
		    up.want_refresh ? " refresh" : "");
		fflush(stdout);
	}
}

/* The selection and the regroup mark name nodes that another member (or
 * an undo) may have removed: forget those. */
static void forget_gone(struct bc_viewer_app *a, const struct bc_tree *t)
{
	uint32_t *ids[3] = {&a->selected, &a->sel_leaf, &a->mark};
	for (int i = 0; i < 3; i++) {
		if (*ids[i] && (!t || !bc_tree_get(t, *ids[i], NULL, NULL))) {
			*ids[i] = 0;
		}
	}
}

void bc_viewer_scene_loaded(struct bc_viewer_app *a, bool has_camera,
                            uint32_t author, uint64_t order)
{
	struct bc_camera cam;
	const struct bc_tree *t = bc_client_scene(a->c, &cam);
	/* A scene that carries a camera resets every member's camera on the
	 * server: follow it. */
	if (t && has_camera) {
		a->cam = cam;
		a->scene_cam = cam;
	}
	forget_gone(a, t);
	if (author) {
		bc_viewer_roster_edit(&a->roster, author, order);
	}
	a->redraw = true;
}

static void got_scene(struct bc_viewer_app *a, const struct bc_msg *m)
{
	struct bc_proto_scene_info si;
	bool has_camera =
	    bc_proto_scene_scan(m->scene_state.scene.ptr,
	                        m->scene_state.scene.len, &si, NULL) == 0 &&
	    si.has_camera;
	bc_viewer_scene_loaded(a, has_camera, m->scene_state.author,
	                       m->scene_state.order);
}

static void got_applied(struct bc_viewer_app *a, const struct bc_msg *m)
{
	const struct bc_msg_edit_applied *e = &m->edit_applied;
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	if (e->author == bc_client_info(a->c)->member_id) {
		if (bc_viewer_edits_applied(&a->edits, e->author_seq,
		                            e->order)) {
			flush_edits(a);
		}
		bc_viewer_model_applied(a, e->author_seq);
	}
	forget_gone(a, t);
	bc_viewer_roster_edit(&a->roster, e->author, e->order);
	if (m->flags & (BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO)) {
		char text[200];
		if (e->author == bc_client_info(a->c)->member_id &&
		    e->author_seq == a->undo_seq) {
			a->undo_seq = 0;
		}
		bc_viewer_status(
		    a, "%s",
		    bc_viewer_undo_text(&a->roster, m, text, sizeof(text)));
		if (a->o.verbose) {
			printf("%s order=%llu of=%llu by=%u\n",
			       (m->flags & BC_PROTO_FLAG_REDO) ? "redo"
			                                       : "undo",
			       (unsigned long long)e->order,
			       (unsigned long long)e->target_order, e->author);
		}
	}
	if (a->o.verbose) {
		printf("applied order=%llu author=%u seq=%u ops=%u\n",
		       (unsigned long long)e->order, e->author, e->author_seq,
		       e->nops);
		fflush(stdout);
	}
	a->redraw = true;
}

static void got_presenter(struct bc_viewer_app *a, const struct bc_msg *m)
{
	struct bc_viewer_roster *r = &a->roster;
	uint32_t was = r->presenter;
	bool followed = r->following;
	char name[BC_PROTO_MAX_NAME + 16];
	r->presenter = m->presenter.presenter;
	r->following = m->presenter.following != 0;
	a->redraw = true;
	if (a->o.verbose) {
		printf("presenter %u following=%d\n", r->presenter,
		       r->following ? 1 : 0);
		fflush(stdout);
	}
	if (r->presenter && r->presenter != r->self && !r->following &&
	    a->follow_wanted) {
		/* F is on: follow whoever presents now. */
		a->cam_dirty = false;
		if (send_toggle(a, BC_MSG_FOLLOW, true)) {
			bc_viewer_status(a, "FOLLOW not sent");
		}
		return;
	}
	if (r->following && !followed) {
		bc_viewer_status(
		    a, "following %s",
		    member_name(r, r->presenter, name, sizeof(name)));
	} else if (!r->presenter && was) {
		bc_viewer_status(a, "%s stopped presenting",
		                 was == r->self
		                     ? "you"
		                     : member_name(r, was, name, sizeof(name)));
	} else if (r->presenter != was && r->presenter == r->self) {
		bc_viewer_status(a, "you present: followers see your camera");
	} else if (r->presenter != was) {
		bc_viewer_status(
		    a, "%s presents: F follows",
		    member_name(r, r->presenter, name, sizeof(name)));
	} else if (followed && !r->following) {
		bc_viewer_status(a, "not following");
	}
}

/* The presenter's camera, which the server now renders us from: ours
 * becomes it, so that a drag starts from what is shown. */
static void got_follow_camera(struct bc_viewer_app *a, const struct bc_msg *m)
{
	bc_edit_camera_from_msg(&m->follow_camera.camera, &a->cam);
	a->cam_dirty = false;
	a->redraw = true;
}

static void got_error(struct bc_viewer_app *a, const struct bc_msg *m)
{
	if (m->seq && m->seq == a->sessions.delete_seq) {
		a->sessions.delete_seq = 0;
		a->sessions.doomed[0] = '\0';
	}
	if (m->seq && m->seq == a->sessions.asked) {
		/* The panel stops waiting; the status says why. */
		a->sessions.asked = 0;
		a->redraw = true;
	}
	if (m->seq && m->seq == a->session_cam_seq) {
		a->session_cam_seq = 0;
	}
	if (m->seq && m->seq == a->history.asked) {
		a->history.asked = 0;
		a->redraw = true;
	}
	if (m->seq && m->seq == a->undo_seq) {
		a->undo_seq = 0;
		if (-(int)m->error.code == BC_ESTATE) {
			/* The daemon's words say why: nothing of yours left,
			 * or built on by someone (named). */
			bc_viewer_status(a, "%.*s", (int)m->error.text.len,
			                 m->error.text.ptr);
			return;
		}
	}
	bc_viewer_status(a, "server: %.*s (%s)", (int)m->error.text.len,
	                 m->error.text.ptr, bc_err_name(-(int)m->error.code));
	if (m->seq == 0) {
		return;
	}
	if (bc_viewer_edits_refused(&a->edits, m->seq)) {
		flush_edits(a);
	}
	bc_viewer_model_refused(a, m->seq);
	if (m->seq == a->snapshot_seq) {
		a->snapshot_seq = 0;
	}
	if (a->drag.mode == BC_VIEWER_DRAG_PENDING &&
	    m->seq == a->drag.pick_seq) {
		bc_viewer_pick_answer(a, m->seq, 0, NULL);
	}
	if (a->turn_pending) {
		/* A refused camera makes no frame; do not wait for one. */
		a->turn_pending = false;
	}
	/* Nor is a refused camera or view pending. */
	if (m->seq == a->cam_seq) {
		a->cam_seq = 0;
	}
	if (m->seq == a->view_seq) {
		a->view_sent_at = 0.0;
	}
}

void bc_viewer_sessions_ask(struct bc_viewer_app *a)
{
	struct bc_msg list = {.type = BC_MSG_SESSION_LIST};
	struct bc_msg stats = {.type = BC_MSG_GET_STATS};
	uint32_t seq = 0;
	if (a->offline) {
		bc_viewer_status(a, "no connection to ask for the sessions");
		return;
	}
	a->sessions.listed = false;
	a->redraw = true;
	if (bc_client_send(a->c, &list, &seq)) {
		return; /* the pump reports the lost connection */
	}
	a->sessions.asked = seq;
	/* A daemon that did not grant MEMORY would close the connection for
	 * the part (PROTOCOL.md 7.18). */
	if (bc_client_info(a->c)->features & BC_PROTO_FEATURE_MEMORY) {
		stats.get_stats.parts = BC_PROTO_STATS_MEMORY;
		bc_client_send(a->c, &stats, NULL);
	}
}

/* SESSIONS: the panel's rows; with --verbose a line for each. */
static void got_sessions(struct bc_viewer_app *a, const struct bc_msg *m)
{
	struct bc_viewer_sessions *s = &a->sessions;
	if (m->seq != s->asked) {
		return; /* an answer to an earlier ask */
	}
	s->asked = 0;
	bc_viewer_sessions_take(s, &m->sessions, a->o.session);
	a->redraw = true;
	if (a->o.verbose) {
		printf("sessions %u\n", s->listed_n);
		for (uint32_t i = 0; i < s->n; i++) {
			const struct bc_viewer_session_row *r = &s->row[i];
			printf("session %s members=%u prims=%u order=%llu "
			       "loaded=%d\n",
			       r->name, r->members, r->prims,
			       (unsigned long long)r->order, r->loaded);
		}
		fflush(stdout);
	}
}

/* Asks again at most this often while the session's order moves (ms), as
 * the page's History panel does. */
#define HISTORY_EVERY_MS 1000.0

void bc_viewer_history_ask(struct bc_viewer_app *a)
{
	struct bc_msg m = {.type = BC_MSG_HISTORY_GET};
	uint32_t seq = 0;
	a->redraw = true;
	if (a->offline) {
		bc_viewer_status(a, "no connection to ask for the history");
		return;
	}
	if (!(bc_client_info(a->c)->features & BC_PROTO_FEATURE_HISTORY)) {
		bc_viewer_status(a, "this daemon keeps no history (it has no "
		                    "per-person undo)");
		return;
	}
	if (bc_client_send(a->c, &m, &seq)) {
		return; /* the pump reports the lost connection */
	}
	a->history.asked = seq;
	a->history.asked_at = bc_viewer_now_ms();
}

double bc_viewer_history_poll(struct bc_viewer_app *a, double now)
{
	struct bc_viewer_history *h = &a->history;
	double due;
	if (!h->open || h->asked || !h->listed || a->offline ||
	    bc_client_info(a->c)->order == h->order) {
		return -1.0;
	}
	due = h->asked_at + HISTORY_EVERY_MS - now;
	if (due > 0.0) {
		return due;
	}
	bc_viewer_history_ask(a);
	return -1.0;
}

/* HISTORY: the panel's rows; with --verbose a line for the list and one
 * for each change. */
static void got_history(struct bc_viewer_app *a, const struct bc_msg *m)
{
	struct bc_viewer_history *h = &a->history;
	if (m->seq != h->asked) {
		return; /* an answer to an earlier ask */
	}
	h->asked = 0;
	bc_viewer_history_take(h, &m->history);
	a->redraw = true;
	if (a->o.verbose) {
		printf("history %u order=%llu\n", h->n,
		       (unsigned long long)h->order);
		for (uint32_t i = 0; i < h->n; i++) {
			const struct bc_viewer_change_row *r = &h->row[i];
			printf("change %llu %s author=%s yours=%d next=%d "
			       "built_on=%llu what=%s\n",
			       (unsigned long long)r->order,
			       r->undone ? "undone" : "applied", r->author,
			       r->yours, r->next,
			       (unsigned long long)r->built_on, r->what);
		}
		fflush(stdout);
	}
}

/* SESSION_CAMERA_SET: R goes to the session's new camera; the status
 * line says who set it. */
static void got_session_camera(struct bc_viewer_app *a,
                               const struct bc_msg_session_camera_set *cs)
{
	char name[BC_PROTO_MAX_NAME + 16];
	bool mine = cs->author == bc_client_info(a->c)->member_id &&
	            cs->author_seq == a->session_cam_seq && a->session_cam_seq;
	bc_edit_camera_from_msg(&cs->camera, &a->scene_cam);
	bc_viewer_roster_edit(&a->roster, cs->author, cs->order);
	if (mine) {
		a->session_cam_seq = 0;
		bc_viewer_status(a,
		                 "the session's camera is now this view "
		                 "(edit order %llu): joiners start here, R "
		                 "comes back here",
		                 (unsigned long long)cs->order);
	} else {
		bc_viewer_status(
		    a, "%s set the session's camera (R goes there)",
		    member_name(&a->roster, cs->author, name, sizeof(name)));
	}
	if (a->o.verbose) {
		printf("session_camera order=%llu by=%u\n",
		       (unsigned long long)cs->order, cs->author);
		fflush(stdout);
	}
	a->redraw = true;
}

int bc_viewer_pump(struct bc_viewer_app *a)
{
	for (int i = 0; i < BC_VIEWER_MSGS_PER_TURN; i++) {
		struct bc_msg m;
		struct bc_errinfo ei = {0};
		int rc = bc_client_recv(a->c, &m, 0);
		if (rc == 0) {
			return 0;
		}
		if (rc < 0) {
			bc_client_error(a->c, &ei);
			bc_viewer_status(a, "connection lost: %s", ei.msg);
			return rc;
		}
		/* The roster borrowed from the client lasts until it receives:
		 * take it again after each message (it changes with
		 * SESSION_INFO and with the session's deletion). */
		bc_viewer_roster_update(&a->roster, a->c);
		if (a->big && picture_take(a, &m)) {
			a->redraw = true;
			continue;
		}
		switch (m.type) {
		case BC_MSG_FRAME:
			got_frame(a, &m);
			break;
		case BC_MSG_PICK_RESULT:
			bc_viewer_pick_answer(a, m.seq, m.pick_result.node,
			                      m.pick_result.position);
			break;
		case BC_MSG_EDIT_APPLIED:
			got_applied(a, &m);
			break;
		case BC_MSG_SCENE_STATE:
			got_scene(a, &m);
			break;
		case BC_MSG_SESSION_INFO:
			a->stats_at = 0.0;
			a->redraw = true;
			if (a->o.verbose) {
				char line[400];
				printf("members %s\n",
				       bc_viewer_roster_text(&a->roster, line,
				                             sizeof(line)));
				fflush(stdout);
			}
			break;
		case BC_MSG_ERROR:
			got_error(a, &m);
			break;
		case BC_MSG_SESSIONS:
			got_sessions(a, &m);
			break;
		case BC_MSG_HISTORY:
			got_history(a, &m);
			break;
		case BC_MSG_OK:
			if (m.seq && m.seq == a->sessions.delete_seq) {
				/* The SESSION_DELETE went through: the list
				 * is asked for again. */
				bc_viewer_status(a, "deleted session %s",
				                 a->sessions.doomed);
				a->sessions.delete_seq = 0;
				a->sessions.doomed[0] = '\0';
				bc_viewer_sessions_ask(a);
			}
			break;
		case BC_MSG_STATS:
			bc_viewer_sessions_stats(&a->sessions, &m.stats);
			a->redraw = a->redraw || a->sessions.open;
			break;
		case BC_MSG_PRESENTER:
			got_presenter(a, &m);
			break;
		case BC_MSG_FOLLOW_CAMERA:
			got_follow_camera(a, &m);
			break;
		case BC_MSG_SESSION_CAMERA_SET:
			got_session_camera(a, &m.session_camera_set);
			break;
		default:
			break;
		}
	}
	return 1;
}
