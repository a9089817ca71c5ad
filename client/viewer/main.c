/*
 * blobcast-view: a desktop window on a blobcast session. It joins a session
 * through libblobcast, shows the frames the daemon renders for its own
 * camera and window size, lets the user orbit, pan and zoom, pick, move and
 * resize primitives (input.c), and overlays frames per second, edit ->
 * frame latency and kB per frame.
 *
 * This file owns the options, start-up and shutdown, the loop and drawing.
 * The loop never waits on the network: a watcher thread polls the socket
 * and wakes glfwWaitEventsTimeout() with glfwPostEmptyEvent() when bytes
 * arrive; the main thread then drains them with zero-timeout receives. The
 * watcher touches nothing but the socket's readiness, so libblobcast stays
 * single-threaded as it requires.
 *
 * A lost connection (the daemon restarted, the network dropped) keeps the
 * last picture on screen and is tried again after the library's doubling
 * delay (bc_client_backoff); the new connection joins the session again
 * (bc_client_rejoin), sends our view and camera, and replaces the old one.
 * Errors a retry would meet again (bc_client_retry_useless: a refused
 * token or role, a missing session) stop the retries and stay on the
 * overlay.
 */
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "app.h"
#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/clock.h"
#include "blobcast/image.h"
#include "blobcast/log.h"

#define EXIT_FAIL 1

double bc_viewer_now_ms(void)
{
	return bc_clock_ms();
}

void bc_viewer_status(struct bc_viewer_app *a, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(a->status, sizeof(a->status), fmt, ap);
	va_end(ap);
	a->status_at = bc_viewer_now_ms();
	a->redraw = true;
	if (a->o.verbose) {
		printf("status %s\n", a->status);
		fflush(stdout);
	}
}

const char *bc_viewer_view_only_text(const struct bc_viewer_app *a)
{
	if (bc_client_info(a->c)->role != BC_PROTO_ROLE_VIEWER) {
		return "";
	}
	return a->view_only_token ? "view-only (the token grants viewing only)"
	                          : "view-only (--role viewer)";
}

bool bc_viewer_may_edit(struct bc_viewer_app *a, const char *what)
{
	if (bc_client_info(a->c)->role == BC_PROTO_ROLE_EDITOR) {
		return true;
	}
	bc_viewer_status(a, "%s: %s is off", bc_viewer_view_only_text(a), what);
	return false;
}

/* ---- options ------------------------------------------------------------- */

static const struct bc_opt_name role_names[] = {
    {"auto", BC_PROTO_ROLE_INVALID},
    {"editor", BC_PROTO_ROLE_EDITOR},
    {"viewer", BC_PROTO_ROLE_VIEWER},
    {NULL, 0}};
static const struct bc_opt_name encoding_names[] = {{"jpeg", BC_PROTO_ENC_JPEG},
                                                    {"png", BC_PROTO_ENC_PNG},
                                                    {"h264", BC_PROTO_ENC_H264},
                                                    {NULL, 0}};

/* What the table parses into before it is moved into the options. */
struct cli {
	int role, encoding;
	uint32_t size[2], snap[2], quality, downscale;
	bool no_overlay;
};

/* Returns 0 to go on, or the exit status (0 after --help, 2 on a bad
 * argument) with *done set. */
static int parse_args(int argc, char **argv, struct bc_viewer_opts *o,
                      bool *done)
{
	struct cli c = {
	    .role = BC_PROTO_ROLE_INVALID,
	    .encoding = BC_PROTO_ENC_JPEG,
	    .size = {960, 600},
	    .quality = 85,
	    .downscale = 2,
	};
	const struct bc_opt opts[] = {
	    {.name = "server",
	     .kind = BC_OPT_STRING,
	     .dst = &o->server,
	     .arg = "ADDR",
	     .help = "HOST:PORT, [IPV6]:PORT or unix:PATH (default\n"
	             "$BLOBCAST_SERVER, else 127.0.0.1:7878);\n"
	             "tls://HOST:PORT for TLS; wss://HOST/PATH\n"
	             "through a WebSocket proxy (docs/deploy.md)"},
	    {.name = "ca",
	     .kind = BC_OPT_STRING,
	     .dst = &o->ca,
	     .arg = "FILE",
	     .help = "TLS: trust the CA certificates in FILE"},
	    {.name = "insecure",
	     .kind = BC_OPT_FLAG,
	     .dst = &o->insecure,
	     .help = "TLS: do not check the server's certificate"},
	    {.name = "session",
	     .kind = BC_OPT_STRING,
	     .dst = &o->session,
	     .arg = "NAME",
	     .help = "session to join (default \"default\"; an editor\n"
	             "creates it when it does not exist)"},
	    {.name = "role",
	     .kind = BC_OPT_ENUM,
	     .dst = &c.role,
	     .arg = "ROLE",
	     .help = "{choices} (default {default}: an editor\n"
	             "when the token allows it, else view-only)",
	     .names = role_names},
	    {.name = "name",
	     .kind = BC_OPT_STRING,
	     .dst = &o->name,
	     .arg = "NAME",
	     .help = "the name other members see (default\n{default})"},
	    {.name = "token",
	     .kind = BC_OPT_STRING,
	     .dst = &o->token,
	     .arg = "TOKEN",
	     .help = "authentication token (default $BLOBCAST_TOKEN)"},
	    {.name = "size",
	     .kind = BC_OPT_SIZE,
	     .dst = c.size,
	     .lo = 1,
	     .hi = BC_PROTO_MAX_DIM,
	     .arg = "WxH",
	     .help = "window size, each {range} (default 960x600)"},
	    {.name = "encoding",
	     .kind = BC_OPT_ENUM,
	     .dst = &c.encoding,
	     .arg = "ENC",
	     .help = "frames as {choices} (default {default}); h264:\n"
	             "a video stream, decoded here (the server must\n"
	             "have an H.264 encoder)",
	     .names = encoding_names},
	    {.name = "exact-still",
	     .kind = BC_OPT_FLAG,
	     .dst = &o->exact_still,
	     .help = "with jpeg or h264: the still, once the picture\n"
	             "stops, as a lossless PNG (needs a server that\n"
	             "knows H.264)"},
	    {.name = "quality",
	     .kind = BC_OPT_U32,
	     .dst = &c.quality,
	     .lo = 1,
	     .hi = BC_PROTO_MAX_QUALITY,
	     .arg = "Q",
	     .help = "JPEG quality of still frames, {range}\n"
	             "(default {default}; interactive frames use at\n"
	             "most 70)"},
	    {.name = "downscale",
	     .kind = BC_OPT_U32,
	     .dst = &c.downscale,
	     .lo = 1,
	     .hi = BC_PROTO_MAX_DOWNSCALE,
	     .arg = "N",
	     .help = "coarsest block accepted, {range} (default\n"
	             "{default}): refinement frames at 1/2^n size,\n"
	             "2^n <= N"},
	    {.name = "gles",
	     .kind = BC_OPT_FLAG,
	     .dst = &o->gles,
	     .help = "use an OpenGL ES 2.0 context"},
	    {.name = "no-overlay",
	     .kind = BC_OPT_FLAG,
	     .dst = &c.no_overlay,
	     .help = "start with the overlay hidden (O toggles)"},
	    {.name = "snapshot-dir",
	     .kind = BC_OPT_STRING,
	     .dst = &o->snapshot_dir,
	     .arg = "DIR",
	     .help = "where S saves lossless snapshots,\n"
	             "Ctrl-S scene files and Ctrl-M meshes\n"
	             "(default {default})"},
	    {.name = "snapshot-size",
	     .kind = BC_OPT_SIZE,
	     .dst = c.snap,
	     .lo = 1,
	     .hi = BC_PROTO_MAX_DIM,
	     .arg = "WxH",
	     .help = "S saves a picture of WxH, each {range},\n"
	             "asked for in tiles (default: the window's\n"
	             "size, in one piece)"},
	    {.name = "screenshot",
	     .kind = BC_OPT_STRING,
	     .dst = &o->screenshot,
	     .arg = "FILE",
	     .help = "save the window to FILE once --frames\n"
	             "pictures were shown, then exit: 0 when the\n"
	             "last was finished, 5 when the daemon stopped\n"
	             "refining it or --screenshot-wait ran out"},
	    {.name = "screenshot-wait",
	     .kind = BC_OPT_U32,
	     .dst = &o->shot_wait_s,
	     .lo = 1,
	     .hi = 86400,
	     .arg = "SEC",
	     .help = "with --screenshot: wait at most SEC seconds\n"
	             "for each finished picture, {range}\n"
	             "(default {default})"},
	    {.name = "frames",
	     .kind = BC_OPT_U32,
	     .dst = &o->frames,
	     .lo = 1,
	     .hi = 1000000,
	     .arg = "N",
	     .help = "finished pictures before the screenshot,\n"
	             "{range} (the last frame of each refinement;\n"
	             "default {default})"},
	    {.name = "turn",
	     .kind = BC_OPT_F32,
	     .dst = &o->turn_deg,
	     .lo = -90,
	     .hi = 90,
	     .arg = "DEG",
	     .help = "with --frames > 1: turn the camera by DEG\n"
	             "({range}) after each picture (the daemon\n"
	             "renders on change only; default {default})"},
	    {.name = "dump-frame",
	     .kind = BC_OPT_STRING,
	     .dst = &o->dump_frame,
	     .arg = "FILE",
	     .help = "with --screenshot: also save the picture\n"
	             "received"},
	    {.name = "verbose",
	     .kind = BC_OPT_FLAG,
	     .dst = &o->verbose,
	     .help = "print frames, picks and edits on stdout"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args p = {
	    .prog = "blobcast-view",
	    .usage = "blobcast-view [options]",
	    .about = "Shows a blobcast session in a window and edits it "
	             "with the mouse.",
	    .footer =
	        "Mouse: drag orbits, or moves the shape under the pointer; "
	        "right drag\nor Shift-drag pans; the wheel zooms, Shift+wheel "
	        "sizes the selected\nshape, Ctrl+wheel changes its operator's "
	        "blend, Alt+wheel the\nvalue of the nearest unary node above "
	        "it (offset amount, onion\nthickness, elongate half_extents, "
	        "twist or bend rate, repeat\nspacing, scale factor; mirrors "
	        "are passed over).\n\n"
	        "Keys: H lists them on the overlay. Home zooms to fit the "
	        "whole\nscene (Shift+Home the selection), R goes back to the "
	        "session's\ncamera, Shift-R makes this view the session's "
	        "camera (editors;\njoiners start from it); S snapshot, P "
	        "screenshot, O overlay, Q or\nEscape quit;\nCtrl-S saves the "
	        "scene as JSON, Ctrl-Shift-S as "
	        "a binary scene\nfile (in --snapshot-dir, named after the "
	        "session and edit order);\nCtrl-M its solid as a glTF mesh, "
	        "Ctrl-Shift-M as OBJ (the mesh\n`blobcast mesh --session` "
	        "writes, made while the window goes on);\nCtrl-O loads a scene "
	        "file into the session (type its path; it replaces the\n"
	        "scene for everyone, as `blobcast load`; read while the window "
	        "goes on);\nCtrl-Z undoes "
	        "your own newest change, Ctrl-Shift-Z or Ctrl-Y redoes\n"
	        "it; with Alt too, the session's newest whoever made it "
	        "(its owner\nor the presenter only); F "
	        "follow the presenter\n(this window shows what the "
	        "presenter's camera sees, at its own size;\nmoving the camera "
	        "or F again stops), Shift-F present (members who\nfollow see "
	        "this window's camera; Shift-F again stops); L lists\nthe "
	        "daemon's sessions (Up/Down, Enter joins the one chosen, N "
	        "names\na new one to create, Delete twice deletes another, "
	        "F5 asks again,\nL or Escape closes); I shows the history of "
	        "the session's changes\n(who, what, when, undone; \"<- your "
	        "undo\" on the one Ctrl-Z takes;\nUp/Down, PgUp/PgDn scroll, "
	        "F5 asks again, I or Escape closes).\n\n"
	        "Modelling, one edit each (every member sees it at once, and "
	        "it "
	        "undoes\nas one step): Up and Down select the parent of the "
	        "selection "
	        "and back;\nA opens the add palette (Up/Down, PgUp/PgDn, a "
	        "letter "
	        "jumps,\nEnter chooses, Escape closes): a shape or an operator "
	        "is added\nunder the selection's operator at the centre of the "
	        "view, a unary\nkind wraps the selection (W opens the palette "
	        "there); Delete or X\ndeletes the selection, D duplicates it; "
	        "M marks the selected\noperator and G moves the selection "
	        "under it, Alt+Up and Alt+Down move it\none place among its "
	        "siblings; K gives the selected\noperator its next kind "
	        "(union, intersection, difference), Shift-K\nturns it sharp "
	        "or smooth; F2 names the selection (type the name,\nEnter "
	        "sends it, an empty one takes the name away, Escape\n"
	        "cancels).\n\n"
	        "A token that grants viewing only opens the window view-only "
	        "(the\noverlay says so; edit keys are off) unless --role "
	        "editor asks\nfor more. A lost connection is retried (after "
	        "0.25 s, doubling up\nto 4 s) and the session joined again; a "
	        "refused token or role or a\nmissing session stop the retries. "
	        "With --screenshot a lost\nconnection exits 1 instead.",
	    .opts = opts};
	*o = (struct bc_viewer_opts){
	    .session = "default",
	    .name = "blobcast-view",
	    .overlay = true,
	    .frames = 1,
	    .shot_wait_s = BC_VIEWER_SHOT_WAIT_S,
	    .turn_deg = 15.0f,
	    .snapshot_dir = ".",
	    /* As the blobcast CLI: the environment names the daemon. */
	    .server = getenv("BLOBCAST_SERVER"),
	    .token = getenv("BLOBCAST_TOKEN"),
	};
	*done = true;
	if (bc_args_parse(&p, argc, argv)) {
		return p.status;
	}
	if (p.npos) {
		return bc_args_error(&p, "unexpected argument '%s'", p.pos[0]);
	}
	o->role = (enum bc_proto_role)c.role;
	o->encoding = (enum bc_proto_encoding)c.encoding;
	if (o->exact_still && o->encoding == BC_PROTO_ENC_PNG) {
		return bc_args_error(&p, "--exact-still applies to --encoding "
		                         "jpeg or h264: PNG frames are exact "
		                         "already");
	}
	o->width = c.size[0];
	o->height = c.size[1];
	o->snap_width = c.snap[0];
	o->snap_height = c.snap[1];
	o->quality = (uint8_t)c.quality;
	o->downscale = (uint8_t)c.downscale;
	o->overlay = !c.no_overlay;
	if (o->dump_frame && !o->screenshot) {
		return bc_args_error(&p, "--dump-frame needs --screenshot");
	}
	if (o->screenshot &&
	    !bc_image_ext_supports(o->screenshot, BC_IMAGE_U8)) {
		return bc_args_error(&p, "cannot write images named %s",
		                     o->screenshot);
	}
	*done = false;
	return 0;
}

/* ---- the socket watcher -------------------------------------------------- */

static void *watch_main(void *arg)
{
	struct bc_viewer_app *a = arg;
	bool armed = true;
	for (;;) {
		struct pollfd p[2] = {
		    {.fd = a->wake[0], .events = POLLIN},
		    {.fd = bc_client_fd(a->c), .events = armed ? POLLIN : 0},
		};
		char b;
		if (poll(p, 2, -1) < 0) {
			if (errno == EINTR) {
				continue;
			}
			return NULL;
		}
		if (p[0].revents) {
			if (read(a->wake[0], &b, 1) != 1 || b == 'q') {
				return NULL;
			}
			armed = true;
			continue;
		}
		if (armed && p[1].revents) {
			/* One wake-up per drain: the loop re-arms us once
			 * it has read what is there. */
			armed = false;
			atomic_store(&a->fired, 1);
			glfwPostEmptyEvent();
		}
	}
}

static int watch_start(struct bc_viewer_app *a)
{
	if (pipe(a->wake) != 0) {
		return BC_EIO;
	}
	atomic_store(&a->fired, 0);
	if (pthread_create(&a->watcher, NULL, watch_main, a) != 0) {
		close(a->wake[0]);
		close(a->wake[1]);
		return BC_EIO;
	}
	a->watching = true;
	return 0;
}

static void watch_rearm(struct bc_viewer_app *a)
{
	if (a->watching && atomic_exchange(&a->fired, 0)) {
		ssize_t n = write(a->wake[1], "a", 1);
		(void)n;
	}
}

static void watch_stop(struct bc_viewer_app *a)
{
	ssize_t n;
	if (!a->watching) {
		return;
	}
	n = write(a->wake[1], "q", 1);
	(void)n;
	pthread_join(a->watcher, NULL);
	close(a->wake[0]);
	close(a->wake[1]);
	a->watching = false;
}

/* ---- drawing ------------------------------------------------------------- */

static const char *role_name(enum bc_proto_role r)
{
	return r == BC_PROTO_ROLE_VIEWER ? "view-only" : "editor";
}

static void fmt_latency(const struct bc_viewer_meter *m, char *out, size_t n)
{
	double avg = bc_viewer_meter_latency_avg(m);
	if (avg < 0.0) {
		snprintf(out, n, "-");
	} else {
		snprintf(out, n, "%.0f ms (avg %.0f)", m->last_latency, avg);
	}
}

/* What the selection is, for the overlay's third line. */
static void fmt_selection(struct bc_viewer_app *a, char *out, size_t n)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	struct bc_prim_data p;
	struct bc_op_data op;
	const struct bc_prim_info *info;
	struct bc_unary u;
	char name[BC_TREE_NAME_MAX + 4];
	uint32_t parent;
	int k, len;
	if (!a->selected || !t || !bc_tree_get(t, a->selected, &p, NULL)) {
		snprintf(out, n, "click a shape to select it");
		return;
	}
	if (!(info = bc_prim_info(p.kind))) {
		/* An operator or unary node, selected with Up. */
		bc_viewer_node_text(t, a->selected, out, n);
		return;
	}
	len = snprintf(out, n, "#%u %s%s", a->selected, info->name,
	               bc_viewer_name_text(t, a->selected, name, sizeof(name)));
	if ((k = bc_viewer_size_param(p.kind)) >= 0 && len >= 0 &&
	    (size_t)len < n) {
		len += snprintf(out + len, n - (size_t)len, " %s %.3g",
		                info->params[k].name,
		                (double)p.params[info->params[k].offset]);
	}
	parent = bc_tree_parent(t, a->selected);
	/* A unary parent is named below, as what Alt+wheel edits (or not
	 * at all: a mirror has no value to change). */
	if (parent && bc_tree_get(t, parent, NULL, &op) &&
	    !bc_op_is_unary(op.kind) && len >= 0 && (size_t)len < n) {
		if (bc_op_is_smooth(op.kind)) {
			len += snprintf(out + len, n - (size_t)len,
			                " in %s blend %.3g",
			                bc_op_name(op.kind), (double)op.blend);
		} else {
			len += snprintf(out + len, n - (size_t)len, " in %s",
			                bc_op_name(op.kind));
		}
	}
	if (bc_viewer_unary_target(t, a->selected, &u) && len >= 0 &&
	    (size_t)len < n) {
		char words[64];
		snprintf(out + len, n - (size_t)len, " under %s",
		         bc_viewer_unary_text(&u, words, sizeof(words)));
	}
}

/* Where a panel of text sits in the window. */
enum panel_corner {
	PANEL_TOP_LEFT = 0,
	PANEL_BOTTOM_LEFT,
	PANEL_BOTTOM_RIGHT,
	PANEL_CORNER_COUNT
};

/* Draws text in colour rgba on a dark panel in a corner of the fw x fh
 * window, text pixels scale window pixels wide. */
static void draw_panel(struct bc_viewer_app *a, const char *text,
                       enum panel_corner corner, uint32_t fw, uint32_t fh,
                       float scale, const float rgba[4])
{
	const float pad = 6.0f;
	const float panel_rgba[4] = {0.0f, 0.0f, 0.0f, 0.6f};
	float w, h, x = 0.0f, y = 0.0f;
	size_t nf;
	int lines = 1;
	for (const char *p = text; *p; p++) {
		lines += *p == '\n';
	}
	w = bc_viewer_text_width(text, scale) + 2.0f * pad;
	h = (float)lines * BC_VIEWER_LINE_ADVANCE * scale + 2.0f * pad -
	    2.0f * scale;
	if (corner != PANEL_TOP_LEFT) {
		y = (float)fh - h;
	}
	if (corner == PANEL_BOTTOM_RIGHT) {
		x = (float)fw - w;
	}
	{
		const float q[12] = {x, y, x + w, y,     x + w, y + h,
		                     x, y, x + w, y + h, x,     y + h};
		bc_viewer_gl_draw(&a->gl, GL_TRIANGLES, q, 6, panel_rgba);
	}
	nf = bc_viewer_text_tris(text, x + pad, y + pad, scale, a->text,
	                         BC_VIEWER_TEXT_FLOATS);
	if (nf > BC_VIEWER_TEXT_FLOATS) {
		nf = BC_VIEWER_TEXT_FLOATS;
	}
	bc_viewer_gl_draw(&a->gl, GL_TRIANGLES, a->text, nf / 2u, rgba);
}

/* The bottom-right tag: whether the picture on screen is final, and
 * whether a render we asked for has not come yet. Amber, apart from the
 * numbers, so that a coarse or budget-cut picture never passes for the
 * real one. */
static void draw_tag(struct bc_viewer_app *a, uint32_t fw, uint32_t fh,
                     float scale, const char *refining, double now)
{
	const float tag_rgba[4] = {0.95f, 0.72f, 0.29f, 1.0f};
	double since = a->offline ? 0.0 : bc_viewer_pending_since(a);
	char tag[96];
	tag[0] = '\0';
	if (refining[0]) {
		snprintf(tag, sizeof(tag), "%s", refining);
	}
	if (since > 0.0) {
		size_t len = strlen(tag);
		snprintf(tag + len, sizeof(tag) - len,
		         "%srender pending %.1f s", len ? "\n" : "",
		         (now - since) / 1e3);
	}
	if (tag[0]) {
		/* Bottom right: the overlay's text runs along the top. */
		draw_panel(a, tag, PANEL_BOTTOM_RIGHT, fw, fh, scale, tag_rgba);
	}
}

/* Text pixels per font pixel: 2 in a wide window, and on a HiDPI screen
 * (whose framebuffer has more pixels than the window has screen
 * coordinates) at least the content scale. */
static float overlay_scale(struct bc_viewer_app *a, uint32_t fw)
{
	float scale = fw >= 900 ? 2.0f : 1.0f, sx = 1.0f, sy = 1.0f;
	glfwGetWindowContentScale(a->win, &sx, &sy);
	if (floorf(sy + 0.5f) > scale) {
		scale = floorf(sy + 0.5f);
	}
	return scale;
}

/* The panel along the bottom (the add palette, or the keys), shown with
 * or without the rest of the overlay. */
static void draw_lower(struct bc_viewer_app *a, uint32_t fw, uint32_t fh)
{
	const float menu_rgba[4] = {0.75f, 0.9f, 1.0f, 1.0f};
	char lower[BC_VIEWER_PANEL_TEXT];
	if (bc_viewer_lower_panel(a, lower, sizeof(lower))) {
		draw_panel(a, lower, PANEL_BOTTOM_LEFT, fw, fh,
		           overlay_scale(a, fw), menu_rgba);
	}
}

static void draw_overlay(struct bc_viewer_app *a, uint32_t fw, uint32_t fh,
                         double now)
{
	char text[1100], lat[64], sel[280], refining[48], who[160];
	const float text_rgba[4] = {0.95f, 0.95f, 0.9f, 1.0f};
	float scale = overlay_scale(a, fw);
	fmt_latency(&a->meter, lat, sizeof(lat));
	fmt_selection(a, sel, sizeof(sel));
	bc_viewer_refining_text(a->last.flags, refining, sizeof(refining));
	snprintf(
	    text, sizeof(text),
	    "%.0f fps  edit>frame %s  %.1f kB/frame  H: keys\n"
	    "frame %u %s %s %ux%u %u rect%s order %llu%s%s\n%s\n%s",
	    bc_viewer_meter_fps(&a->meter, now), lat,
	    bc_viewer_meter_kb(&a->meter), a->last.frame_no,
	    (a->last.flags & BC_PROTO_FLAG_STILL) ? "still" : "interactive",
	    a->last.encoding == BC_PROTO_ENC_PNG   ? "png"
	    : a->last.encoding == BC_PROTO_ENC_RAW ? "raw"
	                                           : "jpeg",
	    a->last.image_width, a->last.image_height, a->last.nrects,
	    a->last.nrects == 1 ? "" : "s", (unsigned long long)a->last.order,
	    refining[0] ? "  " : "", refining, sel,
	    bc_viewer_roster_text(&a->roster, who, sizeof(who)));
	if (a->mark) {
		char words[96];
		size_t len = strlen(text);
		snprintf(text + len, sizeof(text) - len,
		         "\nregroup parent %s (G moves the selection under it)",
		         bc_viewer_node_text(bc_client_scene(a->c, NULL),
		                             a->mark, words, sizeof(words)));
	}
	if (bc_viewer_view_only_text(a)[0]) {
		size_t len = strlen(text);
		snprintf(text + len, sizeof(text) - len,
		         "\n%s: edit keys are off",
		         bc_viewer_view_only_text(a));
	}
	if (a->status[0] &&
	    (a->offline || now - a->status_at < BC_VIEWER_STATUS_MS)) {
		size_t len = strlen(text);
		snprintf(text + len, sizeof(text) - len, "\n%s", a->status);
	}
	draw_panel(a, text, PANEL_TOP_LEFT, fw, fh, scale, text_rgba);
	draw_lower(a, fw, fh);
	draw_tag(a, fw, fh, scale, refining, now);
}

/* Outlines node id in colour rgba, projected with our camera (the one the
 * picture was rendered for, or about to be): a primitive's bounding box,
 * turned with it, or the world box around the ABVs of a subtree. */
static void outline(struct bc_viewer_app *a, uint32_t id, uint32_t fw,
                    uint32_t fh, const float rgba[4])
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	const float dark[4] = {0.0f, 0.0f, 0.0f, 0.7f};
	struct bc_prim_data p;
	float corners[8][3], px[8][2], lines[48], shadow[48], lo[3], hi[3];
	if (!id || !t || !a->view_w || !bc_tree_get(t, id, &p, NULL)) {
		return;
	}
	if (p.kind != BC_PRIM_INVALID) {
		bc_viewer_box_corners(&p, corners);
	} else if (bc_viewer_node_box(t, id, lo, hi)) {
		for (int k = 0; k < 8; k++) {
			for (int i = 0; i < 3; i++) {
				corners[k][i] = ((k >> i) & 1) ? hi[i] : lo[i];
			}
		}
	} else {
		return;
	}
	for (int i = 0; i < 8; i++) {
		float v[3];
		if (!bc_viewer_project(&a->cam, a->view_w, a->view_h,
		                       corners[i], v)) {
			return;
		}
		px[i][0] = v[0] * (float)fw / (float)a->view_w;
		px[i][1] = v[1] * (float)fh / (float)a->view_h;
	}
	for (int e = 0; e < 12; e++) {
		for (int j = 0; j < 2; j++) {
			int c = bc_viewer_box_edges[e][j];
			lines[e * 4 + j * 2] = px[c][0];
			lines[e * 4 + j * 2 + 1] = px[c][1];
			shadow[e * 4 + j * 2] = px[c][0] + 1.0f;
			shadow[e * 4 + j * 2 + 1] = px[c][1] + 1.0f;
		}
	}
	bc_viewer_gl_draw(&a->gl, GL_LINES, shadow, 24, dark);
	bc_viewer_gl_draw(&a->gl, GL_LINES, lines, 24, rgba);
}

/* The selection in amber, the regroup parent (M) in blue. */
static void draw_highlight(struct bc_viewer_app *a, uint32_t fw, uint32_t fh)
{
	const float amber[4] = {0.95f, 0.72f, 0.29f, 1.0f};
	const float blue[4] = {0.35f, 0.7f, 1.0f, 1.0f};
	if (a->mark != a->selected) {
		outline(a, a->mark, fw, fh, blue);
	}
	outline(a, a->selected, fw, fh, amber);
}

/* Writes the back buffer (before the swap) to path. */
static int save_window(struct bc_viewer_app *a, const char *path, uint32_t fw,
                       uint32_t fh)
{
	struct bc_errinfo ei = {0};
	uint8_t *px = bc_malloc((size_t)fw * fh * 4u);
	int rc;
	if (!px) {
		bc_viewer_status(a, "screenshot: out of memory");
		return BC_ENOMEM;
	}
	if (!(rc = bc_viewer_gl_read(&a->gl, fw, fh, px, &ei))) {
		rc = bc_image_write_rgba8(path, fw, fh, px, &ei);
	}
	bc_free(px);
	if (rc) {
		bc_viewer_status(a, "screenshot not saved: %s", ei.msg);
		fprintf(stderr, "blobcast-view: %s: %s\n", path, ei.msg);
		return rc;
	}
	bc_viewer_status(a, "saved %s (%ux%u)", path, fw, fh);
	if (a->o.verbose) {
		printf("screenshot %s %ux%u\n", path, fw, fh);
		fflush(stdout);
	}
	return 0;
}

/* The picture as received (the composite, or the last downscaled image),
 * for tests comparing it with the window. */
static int dump_frame(struct bc_viewer_app *a, const char *path)
{
	struct bc_errinfo ei = {0};
	const struct bc_viewer_frames *f = &a->frames;
	int rc;
	if (f->showing_small) {
		rc = bc_image_write_rgba8(path, f->small.width, f->small.height,
		                          f->small.rgba, &ei);
	} else if (f->comp) {
		rc = bc_image_write_rgba8(path, f->width, f->height, f->comp,
		                          &ei);
	} else {
		rc = bc_errinfo_set(&ei, BC_ESTATE, "no frame yet");
	}
	if (rc) {
		fprintf(stderr, "blobcast-view: %s: %s\n", path, ei.msg);
	}
	return rc;
}

static void draw(struct bc_viewer_app *a, double now)
{
	int fwi = 0, fhi = 0;
	uint32_t fw, fh;
	bool shot_done = a->o.screenshot && a->npictures >= a->o.frames;
	glfwGetFramebufferSize(a->win, &fwi, &fhi);
	if (fwi <= 0 || fhi <= 0) {
		return;
	}
	fw = (uint32_t)fwi;
	fh = (uint32_t)fhi;
	bc_viewer_gl_begin(&a->gl, fw, fh);
	if (a->frames.showing_small) {
		/* A level image spans the view with its top-left part. */
		bc_viewer_gl_image(&a->gl, BC_VIEWER_TEX_SMALL, 0.0f, 0.0f,
		                   (float)fw, (float)fh, a->frames.small_u,
		                   a->frames.small_v);
	} else if (a->frames.have_full) {
		bc_viewer_gl_image(&a->gl, BC_VIEWER_TEX_FULL, 0.0f, 0.0f,
		                   (float)fw, (float)fh, 1.0f, 1.0f);
	}
	draw_highlight(a, fw, fh);
	if (a->o.overlay) {
		draw_overlay(a, fw, fh, now);
	} else {
		draw_lower(a, fw, fh);
	}
	if (shot_done) {
		a->exit_code =
		    save_window(a, a->o.screenshot, fw, fh) ||
		            (a->o.dump_frame && dump_frame(a, a->o.dump_frame))
		        ? EXIT_FAIL
		    : a->shot_unfinished ? BC_VIEWER_EXIT_UNFINISHED
		                         : 0;
		a->quit = true;
	} else if (a->screenshot_now) {
		char path[64];
		a->screenshot_now = false;
		snprintf(path, sizeof(path), "blobcast-view-%03u.png",
		         ++a->shots);
		save_window(a, path, fw, fh);
	}
	glfwSwapBuffers(a->win);
	a->redraw = false;
	bc_viewer_frame_drawn(a);
	if (a->settle) {
		uint32_t n = bc_viewer_edits_frame(
		    &a->edits, a->settle_order, bc_viewer_now_ms(), &a->meter);
		if (n && a->o.verbose) {
			/* The frame settles n edits, oldest first: the first
			 * waited longest, the newest least. */
			const struct bc_viewer_meter *m = &a->meter;
			uint32_t k = n < m->nlatency ? n : m->nlatency;
			uint32_t first =
			    (m->next_latency + BC_VIEWER_METER_LATENCIES - k) %
			    BC_VIEWER_METER_LATENCIES;
			printf("latency edits=%u last_ms=%.1f oldest_ms=%.1f\n",
			       n, m->last_latency, m->latency[first]);
			fflush(stdout);
		}
		a->settle = false;
	}
}

static void update_title(struct bc_viewer_app *a, double now)
{
	const struct bc_client_info *info = bc_client_info(a->c);
	char title[300], lat[64];
	fmt_latency(&a->meter, lat, sizeof(lat));
	snprintf(title, sizeof(title),
	         "blobcast-view: %s (%s, %u member%s) - %.0f fps, edit>frame "
	         "%s, %.1f kB/frame",
	         info->session, role_name(info->role), info->nmembers,
	         info->nmembers == 1 ? "" : "s",
	         bc_viewer_meter_fps(&a->meter, now), lat,
	         bc_viewer_meter_kb(&a->meter));
	glfwSetWindowTitle(a->win, title);
	a->stats_at = now;
}

/* --screenshot: a picture that will not be finished counts as it is once
 * the daemon stopped refining it or the wait for it ran out (shot.c); the
 * screenshot then says so on stderr and in its exit status. Returns the
 * ms until the answer may change (negative: nothing to wait for). */
static double shot_poll(struct bc_viewer_app *a, double now)
{
	enum bc_viewer_shot_state st;
	double due, wait_ms = (double)a->o.shot_wait_s * 1e3;
	char what[200];
	if (!a->o.screenshot || a->shot_ready || a->npictures >= a->o.frames) {
		return -1.0;
	}
	st = bc_viewer_shot_check(&a->shot, now, bc_viewer_pending_since(a),
	                          wait_ms, &due);
	if (st == BC_VIEWER_SHOT_WAITING || st == BC_VIEWER_SHOT_FINISHED) {
		return due;
	}
	bc_viewer_shot_text(&a->shot, st, wait_ms, what, sizeof(what));
	if (a->npictures + 1u < a->o.frames) {
		fprintf(stderr,
		        "blobcast-view: picture %llu of %u not finished: %s; "
		        "going on with the next\n",
		        (unsigned long long)a->npictures + 1u, a->o.frames,
		        what);
	} else {
		fprintf(stderr,
		        "blobcast-view: picture %llu of %u not finished: %s; "
		        "%s shows it as it is (exit status %d)\n",
		        (unsigned long long)a->npictures + 1u, a->o.frames,
		        what, a->o.screenshot, BC_VIEWER_EXIT_UNFINISHED);
	}
	if (a->o.verbose) {
		printf("unfinished %s\n", what);
		fflush(stdout);
	}
	a->npictures++;
	a->shot_ready = true;
	a->shot_unfinished = true;
	a->redraw = true;
	return -1.0;
}

/* --frames N: the daemon renders on change only; turning the camera after
 * each picture gives it one. Turning while it refines would cut the
 * refinement short, so the turn waits for a finished picture, or for one
 * shot_poll took as it is. */
static void maybe_turn(struct bc_viewer_app *a, double now)
{
	if (!a->o.screenshot || !a->shot_ready || a->npictures >= a->o.frames ||
	    a->turn_pending) {
		return;
	}
	bc_viewer_orbit(&a->cam,
	                a->o.turn_deg * 3.14159265f / 180.0f /
	                    BC_VIEWER_ORBIT_PER_PX,
	                0.0f);
	bc_viewer_camera_changed(a, false);
	a->turn_pending = true;
	a->shot_ready = false;
	bc_viewer_shot_start(&a->shot, now);
}

/* After joining (bc_client_join or bc_client_rejoin, which fill the
 * library's roster and scene mirror): takes the roster into *roster and
 * asks with FOLLOW 0 who presents (PRESENTER, handled by bc_viewer_pump,
 * which follows again when F is on). Returns 0 or the sticky error. */
static int joined(struct bc_client *c, struct bc_viewer_roster *roster,
                  struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_FOLLOW};
	int rc;
	memset(roster, 0, sizeof(*roster));
	bc_viewer_roster_update(roster, c);
	if ((rc = bc_client_send(c, &m, NULL))) {
		bc_client_error(c, ei);
	}
	return rc;
}

/* Connects and joins session s with the options' address, token and
 * role: an editor creates it when missing, a viewer needs it to exist.
 * Without --role, a token that grants viewing only (EPERM for the editor
 * role) joins as a viewer: *view_only_token then says so. Returns 0 or
 * the error with its reason in ei; *c is set either way (NULL when
 * connecting failed). */
static int open_session(const struct bc_viewer_app *a, const char *s,
                        struct bc_client **c, struct bc_viewer_roster *roster,
                        bool *view_only_token, struct bc_errinfo *ei)
{
	int rc = bc_client_connect(c,
	                           &(struct bc_client_opts){
	                               .addr = a->o.server,
	                               .name = a->o.name,
	                               .token = a->o.token,
	                               .ca_file = a->o.ca,
	                               .insecure = a->o.insecure,
	                               .encodings = bc_viewer_encodings(&a->o),
	                               /* Frames are acknowledged once drawn
	                                * (bc_viewer_frame_drawn). */
	                               .acks = true,
	                               /* The daemon draws: the mirror needs
	                                * no layout (node boxes come from the
	                                * model, bc_tree_node_box). */
	                               .bare_scene = true,
	                           },
	                           ei);
	*view_only_token = false;
	if (rc) {
		return rc;
	}
	if (a->o.role == BC_PROTO_ROLE_VIEWER) {
		rc = bc_client_join(*c, s, BC_PROTO_ROLE_VIEWER,
		                    BC_CLIENT_JOIN_EXISTING, ei);
		return rc ? rc : joined(*c, roster, ei);
	}
	rc =
	    bc_client_join(*c, s, BC_PROTO_ROLE_EDITOR, BC_CLIENT_JOIN_ANY, ei);
	if (rc == BC_EPERM && a->o.role == BC_PROTO_ROLE_INVALID) {
		/* The refusal is not fatal: the same connection may look.
		 * A viewer cannot create the session, so it must exist. */
		rc = bc_client_join(*c, s, BC_PROTO_ROLE_VIEWER,
		                    BC_CLIENT_JOIN_EXISTING, ei);
		*view_only_token = rc == 0;
	} else if (rc == BC_EPERM) {
		size_t len = strlen(ei->msg);
		snprintf(ei->msg + len, sizeof(ei->msg) - len,
		         "; without --role editor the window opens view-only");
	}
	return rc ? rc : joined(*c, roster, ei);
}

/* The connection failed with code: keep the picture, stop watching the
 * socket and schedule the first attempt to reconnect. */
static void lost(struct bc_viewer_app *a, int code, double now)
{
	char why[sizeof(a->status)];
	snprintf(why, sizeof(why), "%s", a->status);
	watch_stop(a);
	/* The daemon drops our member now; the scene mirror and roster stay
	 * for the overlay, the options for bc_client_rejoin(). */
	bc_client_disconnect(a->c);
	a->offline = true;
	bc_client_backoff_reset(&a->retry, now);
	a->gave_up = bc_client_retry_useless(code);
	if (a->o.verbose) {
		printf("lost %s\n", bc_err_name(code));
		fflush(stdout);
	}
	if (!a->gave_up) {
		bc_viewer_status(a, "%s - reconnecting", why);
	}
}

/* The joined connection c (its roster taken) replaces the window's
 * (which is destroyed): everything tied to the old one's sequence numbers
 * starts afresh, the scene's camera is the new mirror's, and the VIEW
 * goes out. Returns 0, or -1 when the new connection failed at once
 * (then lost()). */
static int adopt(struct bc_viewer_app *a, struct bc_client *c,
                 const struct bc_viewer_roster *roster, double now)
{
	struct bc_errinfo ei = {0};
	struct bc_camera scene_cam;
	bc_client_destroy(a->c);
	a->c = c;
	a->roster = *roster;
	bc_viewer_edits_init(&a->edits);
	a->model_seq = 0;
	a->model_select = 0;
	a->drag.mode = BC_VIEWER_DRAG_NONE;
	a->wheel.what = BC_VIEWER_WHEEL_NONE;
	a->snapshot_seq = 0;
	a->undo_seq = 0;
	a->session_cam_seq = 0;
	a->turn_pending = false;
	a->cam_seq = 0;
	a->view_sent_at = 0.0;
	a->frame_got = a->frame_acked = 0;
	a->awaiting_key = false;
	a->sessions.asked = 0;
	a->sessions.delete_seq = 0; /* its OK would come on the old one */
	a->sessions.doomed[0] = '\0';
	/* Another session's history, or the same one's after a reconnect:
	 * asked again on the new connection when the panel is open. */
	a->history.asked = 0;
	a->history.listed = false;
	if (bc_client_scene(a->c, &scene_cam)) {
		a->scene_cam = scene_cam;
	}
	a->offline = false;
	a->gave_up = false;
	/* The daemon starts a member on the scene's camera: ours goes along
	 * with the view. */
	if (bc_viewer_send_view(a) || watch_start(a)) {
		bc_client_error(a->c, &ei);
		lost(a, ei.code ? ei.code : BC_EIO, now);
		return -1;
	}
	if (a->history.open) {
		bc_viewer_history_ask(a);
	}
	return 0;
}

void bc_viewer_switch_session(struct bc_viewer_app *a, const char *name)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_viewer_roster roster;
	bool view_only = false;
	char title[BC_PROTO_MAX_NAME + 32];
	int rc;
	if (!a->offline && strcmp(name, a->o.session) == 0) {
		bc_viewer_status(a, "this window is in session %s already",
		                 name);
		return;
	}
	bc_viewer_status(a, "joining session %s...", name);
	if ((rc = open_session(a, name, &c, &roster, &view_only, &ei))) {
		bc_client_destroy(c);
		bc_viewer_status(a, "cannot join session %s: %s (%s)", name,
		                 ei.msg, bc_err_name(rc));
		if (a->o.verbose) {
			printf("switch %s failed %s\n", name, bc_err_name(rc));
			fflush(stdout);
		}
		return;
	}
	/* Joined: the old connection goes (the daemon drops that member),
	 * and with it what belonged to its session. */
	watch_stop(a);
	bc_viewer_picture_drop(a, "another session was joined");
	snprintf(a->session_name, sizeof(a->session_name), "%s", name);
	a->o.session = a->session_name;
	a->view_only_token = view_only;
	a->selected = a->sel_leaf = a->mark = 0;
	a->palette.open = false;
	a->rename.open = false;
	a->sessions.open = false;
	bc_client_backoff_reset(&a->retry, bc_viewer_now_ms());
	if (adopt(a, c, &roster, bc_viewer_now_ms())) {
		return;
	}
	a->cam = a->scene_cam;
	bc_viewer_camera_changed(a, false);
	snprintf(title, sizeof(title), "blobcast-view: %s", name);
	glfwSetWindowTitle(a->win, title);
	a->stats_at = 0.0;
	a->redraw = true;
	bc_viewer_status(a, "joined session %s as %s", name,
	                 role_name(bc_client_info(a->c)->role));
	if (a->o.verbose) {
		printf("joined %s role=%s%s\n", name,
		       role_name(bc_client_info(a->c)->role),
		       view_only ? " token=viewer" : "");
		fflush(stdout);
	}
}

/* One attempt to reconnect (bc_client_rejoin: the dead connection's
 * address, options and session). On success the new connection replaces
 * the dead one (whose scene mirror the overlay read meanwhile) and
 * everything tied to the old one's sequence numbers starts afresh. */
static void reconnect(struct bc_viewer_app *a, double now)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_viewer_roster roster;
	int rc = bc_client_rejoin(a->c, BC_VIEWER_RETRY_TIMEOUT_MS, &c, &ei);
	if (!rc) {
		rc = joined(c, &roster, &ei);
	}
	if (rc) {
		int delay;
		bc_client_destroy(c);
		if (bc_client_retry_useless(rc)) {
			a->gave_up = true;
			bc_viewer_status(a, "reconnecting refused: %s (%s)",
			                 ei.msg, bc_err_name(rc));
			return;
		}
		delay = bc_client_backoff_next(&a->retry, bc_viewer_now_ms());
		bc_viewer_status(
		    a,
		    "connection lost; attempt %u failed (%s), next "
		    "in %.1f s",
		    a->retry.attempts, bc_err_name(rc), delay / 1e3);
		return;
	}
	bc_viewer_picture_drop(a, "the connection was lost");
	if (adopt(a, c, &roster, now)) {
		return;
	}
	bc_viewer_camera_changed(a, false);
	bc_viewer_status(a, "rejoined session %s after %u failed attempt%s",
	                 a->o.session, a->retry.attempts,
	                 a->retry.attempts == 1 ? "" : "s");
	if (a->o.verbose) {
		printf("rejoined %s attempts=%u\n", a->o.session,
		       a->retry.attempts);
		fflush(stdout);
	}
}

/* The nearer of two waits in ms, where a negative one is none. */
static double sooner(double due, double other)
{
	return other >= 0.0 && (due < 0.0 || other < due) ? other : due;
}

static void run(struct bc_viewer_app *a)
{
	while (!a->quit && !glfwWindowShouldClose(a->win)) {
		double now, due, wait;
		int more = 0;
		if (!a->offline) {
			more = bc_viewer_pump(a);
			if (more < 0) {
				fprintf(stderr, "blobcast-view: %s\n",
				        a->status);
				if (a->o.screenshot) {
					a->offline = true;
					a->exit_code = EXIT_FAIL;
					break;
				}
				lost(a, more, bc_viewer_now_ms());
				more = 0;
			}
		}
		now = bc_viewer_now_ms();
		if (a->offline && !a->gave_up &&
		    bc_client_backoff_due(&a->retry, now)) {
			reconnect(a, now);
			now = bc_viewer_now_ms();
			a->redraw = true;
		}
		if (!a->offline) {
			double shot_due = shot_poll(a, now);
			bc_viewer_drag_step(a, false);
			maybe_turn(a, now);
			due = bc_viewer_send_due(a, now);
			due = sooner(due, shot_due);
		} else if (!a->gave_up) {
			due = a->retry.next_at > now ? a->retry.next_at - now
			                             : 0.0;
		} else {
			due = -1.0;
		}
		/* The mesher's, the reader's and the history panel's
		 * turns. */
		due = sooner(due, bc_viewer_mesh_poll(a, now));
		due = sooner(due, bc_viewer_load_poll(a, now));
		due = sooner(due, bc_viewer_history_poll(a, now));
		if (now - a->stats_at >= BC_VIEWER_STATS_EVERY_MS) {
			update_title(a, now);
			a->redraw = a->redraw || a->o.overlay;
		}
		if (a->redraw) {
			draw(a, now);
		}
		if (a->quit) {
			break;
		}
		if (!a->offline) {
			watch_rearm(a);
		}
		if (more) {
			glfwPollEvents();
			continue;
		}
		wait = BC_VIEWER_STATS_EVERY_MS -
		       (bc_viewer_now_ms() - a->stats_at);
		if (due >= 0.0 && due < wait) {
			wait = due;
		}
		if (a->status[0] && !a->offline) {
			double left = a->status_at + BC_VIEWER_STATUS_MS -
			              bc_viewer_now_ms();
			if (left > 0.0 && left < wait) {
				wait = left;
			}
		}
		glfwWaitEventsTimeout(wait > 1.0 ? wait / 1e3 : 0.001);
	}
}

static void on_glfw_error(int code, const char *text)
{
	bc_log(BC_LOG_WARN, "GLFW error 0x%x: %s", (unsigned)code, text);
}

static GLFWwindow *open_window(const struct bc_viewer_opts *o, char *title)
{
	GLFWwindow *w;
	glfwDefaultWindowHints();
	glfwWindowHint(GLFW_DOUBLEBUFFER, GLFW_TRUE);
	if (o->gles) {
		glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_ES_API);
		glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 2);
		glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
	} else {
		/* 2.1 and no profile: what old drivers offer; newer ones
		 * give a compatibility context. */
		glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
		glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 2);
		glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 1);
	}
	w = glfwCreateWindow((int)o->width, (int)o->height, title, NULL, NULL);
	if (!w && o->gles) {
		/* Some X servers' GLX cannot make ES contexts; EGL can. */
		glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_EGL_CONTEXT_API);
		w = glfwCreateWindow((int)o->width, (int)o->height, title, NULL,
		                     NULL);
	}
	return w;
}

int main(int argc, char **argv)
{
	static struct bc_viewer_app app;
	struct bc_viewer_app *a = &app;
	struct bc_errinfo ei = {0};
	const struct bc_tree *scene;
	char title[128];
	bool glfw_up = false, stop;
	int rc;
	if ((rc = parse_args(argc, argv, &a->o, &stop)) || stop) {
		return rc;
	}
	bc_log_init(a->o.verbose ? BC_LOG_INFO : BC_LOG_WARN);
	bc_viewer_frames_init(&a->frames);
	bc_viewer_meter_init(&a->meter);
	bc_viewer_edits_init(&a->edits);
	bc_client_backoff_init(&a->retry, 0, 0);
	a->exit_code = EXIT_FAIL;
	if (!(a->text = bc_malloc(BC_VIEWER_TEXT_FLOATS * sizeof(float)))) {
		fprintf(stderr, "blobcast-view: out of memory\n");
		goto cleanup;
	}

	if ((rc = open_session(a, a->o.session, &a->c, &a->roster,
	                       &a->view_only_token, &ei))) {
		fprintf(stderr, "blobcast-view: %s: %s\n",
		        a->o.server ? a->o.server : "127.0.0.1:7878", ei.msg);
		goto cleanup;
	}
	if (a->o.verbose) {
		printf("joined %s role=%s%s\n", a->o.session,
		       role_name(bc_client_info(a->c)->role),
		       a->view_only_token ? " token=viewer" : "");
		fflush(stdout);
	}
	if ((scene = bc_client_scene(a->c, &a->cam)) == NULL) {
		bc_camera_default(&a->cam);
	}
	a->scene_cam = a->cam;

	glfwSetErrorCallback(on_glfw_error);
	if (!glfwInit()) {
		fprintf(stderr, "blobcast-view: no window system (is DISPLAY "
		                "set? headless: xvfb-run blobcast-view ...)\n");
		goto cleanup;
	}
	glfw_up = true;
	snprintf(title, sizeof(title), "blobcast-view: %s", a->o.session);
	if (!(a->win = open_window(&a->o, title))) {
		fprintf(stderr, "blobcast-view: no %s context for a window\n",
		        a->o.gles ? "OpenGL ES 2.0" : "OpenGL 2.1");
		goto cleanup;
	}
	glfwMakeContextCurrent(a->win);
	glfwSwapInterval(1);
	if (bc_viewer_gl_init(&a->gl, a->o.gles, &ei)) {
		fprintf(stderr, "blobcast-view: %s\n", ei.msg);
		goto cleanup;
	}
	a->gl_ready = true;
	bc_log(BC_LOG_INFO, "GL: %s, %s", a->gl.version, a->gl.renderer);
	if (a->o.verbose) {
		printf("gl %s | %s\n", a->gl.version, a->gl.renderer);
		fflush(stdout);
	}
	bc_viewer_input_install(a);
	if (bc_viewer_send_view(a) || watch_start(a)) {
		fprintf(stderr, "blobcast-view: cannot start: %s\n", a->status);
		goto cleanup;
	}
	a->exit_code = 0;
	a->redraw = true;
	bc_viewer_shot_start(&a->shot, bc_viewer_now_ms());
	run(a);
cleanup:
	bc_viewer_mesh_wait(a);
	bc_viewer_load_wait(a);
	watch_stop(a);
	if (a->gl_ready) {
		bc_viewer_gl_finish(&a->gl);
	}
	if (a->win) {
		glfwDestroyWindow(a->win);
	}
	if (glfw_up) {
		glfwTerminate();
	}
	bc_viewer_frames_finish(&a->frames);
	bc_client_big_free(a->big);
	bc_client_image_finish(&a->big_img);
	bc_client_destroy(a->c);
	bc_free(a->text);
	return a->exit_code;
}
