/*
 * Ctrl+O: a scene file loaded into the window's session, as `blobcast
 * load` does it (the same reading, JSON or binary, and the same
 * SCENE_LOAD, in parts when it is big). The path is typed into an entry
 * in the lower panel (relative to the directory blobcast-view started
 * in); the load replaces the session's scene for every member and the
 * session's undo history starts again from it, which the entry says
 * before Enter. Enter starts reading the file on a thread of its own (a
 * million spheres as JSON: about 5 s), the status line counting the
 * seconds while the window goes on; nothing is sent before the whole
 * file has read, so a wrong path or a bad file leaves the entry open
 * with the reason. The loop then sends it and waits for the daemon's
 * SCENE_STATE (the window pauses for that part, as for a snapshot's PNG:
 * under a second for a million spheres).
 */
#include <stdio.h>
#include <string.h>

#include "app.h"
#include "blobcast/alloc.h"
#include "blobcast/bytes.h"

void bc_viewer_load_open(struct bc_viewer_app *a)
{
	if (!bc_viewer_may_edit(a, "loading a scene")) {
		return;
	}
	a->load.open = true;
	a->load.len = 0;
	a->load.path[0] = '\0';
	a->redraw = true;
}

void bc_viewer_load_char(struct bc_viewer_app *a, uint32_t cp)
{
	char u[4];
	size_t n;
	if (cp < 0x20u || cp == 0x7fu || !(n = bc_utf8_encode(cp, u))) {
		return;
	}
	if (a->load.len + n >= sizeof(a->load.path)) {
		bc_viewer_status(a, "the path is too long");
		return;
	}
	memcpy(a->load.path + a->load.len, u, n);
	a->load.len += n;
	a->load.path[a->load.len] = '\0';
	a->redraw = true;
}

void bc_viewer_load_back(struct bc_viewer_app *a)
{
	/* A whole UTF-8 character: continuation bytes first. */
	while (a->load.len > 0 &&
	       ((unsigned char)a->load.path[a->load.len - 1] & 0xc0u) ==
	           0x80u) {
		a->load.len--;
	}
	if (a->load.len > 0) {
		a->load.len--;
	}
	a->load.path[a->load.len] = '\0';
	a->redraw = true;
}

/* The reader's work: reads and checks the file, and encodes its scene. */
static void read_main(void *arg)
{
	struct bc_viewer_reader *r = arg;
	struct bc_proto_scene_info si;
	r->rc = bc_client_read_scene_file(r->path, &r->bytes, &r->len,
	                                  &r->nodes, &r->ei);
	r->has_camera = !r->rc &&
	                bc_proto_scene_scan(r->bytes, r->len, &si, NULL) == 0 &&
	                si.has_camera;
}

void bc_viewer_load_send(struct bc_viewer_app *a)
{
	struct bc_viewer_reader *r = &a->load.reader;
	if (r->w.busy || r->ready) {
		bc_viewer_status(a, "%s is still being read", r->path);
		return;
	}
	if (!a->load.len) {
		bc_viewer_status(a, "type the scene file's path first");
		return;
	}
	if (a->offline) {
		bc_viewer_status(a, "not loaded: not connected");
		return;
	}
	memcpy(r->path, a->load.path, a->load.len + 1);
	r->bytes = NULL;
	r->len = 0;
	r->nodes = 0;
	r->rc = 0;
	memset(&r->ei, 0, sizeof(r->ei));
	r->cancelled = false;
	if (bc_viewer_worker_start(&r->w, read_main, r)) {
		bc_viewer_status(a, "not loaded: no thread to read it on");
		return;
	}
	a->redraw = true;
	bc_viewer_status(a, "reading %s ...", r->path);
}

void bc_viewer_load_cancel(struct bc_viewer_app *a)
{
	struct bc_viewer_reader *r = &a->load.reader;
	a->load.open = false;
	a->redraw = true;
	if (r->w.busy || r->ready) {
		r->cancelled = true;
		bc_viewer_status(a, "loading cancelled: %s is not sent",
		                 r->path);
		return;
	}
	bc_viewer_status(a, "loading cancelled");
}

/* The scene read, sent: SCENE_LOAD, and the wait for its SCENE_STATE. */
static void send_read(struct bc_viewer_app *a)
{
	struct bc_viewer_reader *r = &a->load.reader;
	struct bc_errinfo ei = {0};
	uint64_t order = 0;
	int rc;
	if (a->offline) {
		bc_viewer_status(a, "not loaded: not connected");
		return;
	}
	rc = bc_client_load_scene(a->c, r->bytes, r->len, &order, &ei);
	if (rc) {
		bc_viewer_status(a, "not loaded: %s (%s)", ei.msg,
		                 bc_err_name(rc));
		return;
	}
	a->load.open = false;
	bc_viewer_scene_loaded(a, r->has_camera,
	                       bc_client_info(a->c)->member_id, order);
	bc_viewer_status(a,
	                 "loaded %s: %u nodes, edit order %llu (the undo "
	                 "history starts here)",
	                 r->path, r->nodes, (unsigned long long)order);
	if (a->o.verbose) {
		printf("load %s nodes=%u order=%llu\n", r->path, r->nodes,
		       (unsigned long long)order);
		fflush(stdout);
	}
}

static void read_drop(struct bc_viewer_reader *r)
{
	bc_free(r->bytes);
	r->bytes = NULL;
	r->len = 0;
	r->ready = false;
}

double bc_viewer_load_poll(struct bc_viewer_app *a, double now)
{
	struct bc_viewer_reader *r = &a->load.reader;
	if (r->ready) {
		/* Read in an earlier turn, which drew the line below. */
		if (!r->cancelled) {
			send_read(a);
		}
		read_drop(r);
		return -1.0;
	}
	if (!bc_viewer_worker_reap(&r->w)) {
		if (!r->w.busy) {
			return -1.0;
		}
		if (bc_viewer_worker_say_due(&r->w, now)) {
			bc_viewer_status(a, "reading %s: %.1f s", r->path,
			                 (now - r->w.started) / 1e3);
		}
		return bc_viewer_worker_next(&r->w, now);
	}
	if (r->cancelled) {
		read_drop(r);
		return -1.0;
	}
	if (r->rc) {
		bc_viewer_status(a, "not loaded: %s", r->ei.msg);
		read_drop(r);
		return -1.0;
	}
	/* Said and drawn before the wait for the daemon. */
	r->ready = true;
	a->redraw = true;
	bc_viewer_status(a, "loading %s (%u nodes): waiting for the daemon",
	                 r->path, r->nodes);
	return 0.0;
}

void bc_viewer_load_wait(struct bc_viewer_app *a)
{
	struct bc_viewer_reader *r = &a->load.reader;
	if (r->w.busy && !atomic_load(&r->w.done)) {
		fprintf(stderr,
		        "blobcast-view: waiting for %s to be read (it is not "
		        "loaded) ...\n",
		        r->path);
	}
	bc_viewer_worker_join(&r->w);
	read_drop(r);
}

void bc_viewer_load_text(const struct bc_viewer_app *a, char *out, size_t n)
{
	const struct bc_viewer_reader *r = &a->load.reader;
	char shown[sizeof(a->load.path)];
	bc_viewer_drawable(a->load.path, shown, sizeof(shown));
	if (r->w.busy || r->ready) {
		char file[sizeof(r->path)];
		bc_viewer_drawable(r->path, file, sizeof(file));
		snprintf(out, n,
		         "Load a scene file (JSON or binary) into session %s: "
		         "%s_\nReading %s: nothing is sent before the whole "
		         "file has read.\nEsc cancels the load.",
		         a->o.session, shown, file);
		return;
	}
	snprintf(out, n,
	         "Load a scene file (JSON or binary) into session %s: %s_\n"
	         "It replaces the scene for every member, and the undo "
	         "history starts again.\nEnter loads, Esc cancels; the path "
	         "is relative to where blobcast-view started.",
	         a->o.session, shown);
}
