/*
 * Ctrl+O: a scene file loaded into the window's session, as `blobcast
 * load` does it (the same reading, JSON or binary, and the same
 * SCENE_LOAD, in parts when it is big). The path is typed into an entry
 * in the lower panel (relative to the directory blobcast-view started
 * in); the load replaces the session's scene for every member and the
 * session's undo history starts again from it, which the entry says
 * before Enter. Reading the file happens before anything is sent, so a
 * wrong path or a bad file leaves the entry open with the reason; the
 * load itself waits for the daemon's SCENE_STATE (the window pauses for
 * a big scene, as for a snapshot's PNG).
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

void bc_viewer_load_send(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	struct bc_proto_scene_info si;
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint32_t nodes = 0;
	uint64_t order = 0;
	bool has_camera;
	int rc;
	if (!a->load.len) {
		bc_viewer_status(a, "type the scene file's path first");
		return;
	}
	if (a->offline) {
		bc_viewer_status(a, "not loaded: not connected");
		return;
	}
	if (bc_client_read_scene_file(a->load.path, &bytes, &len, &nodes,
	                              &ei)) {
		bc_viewer_status(a, "not loaded: %s", ei.msg);
		return;
	}
	has_camera =
	    bc_proto_scene_scan(bytes, len, &si, NULL) == 0 && si.has_camera;
	rc = bc_client_load_scene(a->c, bytes, len, &order, &ei);
	bc_free(bytes);
	if (rc) {
		bc_viewer_status(a, "not loaded: %s (%s)", ei.msg,
		                 bc_err_name(rc));
		return;
	}
	a->load.open = false;
	bc_viewer_scene_loaded(a, has_camera, bc_client_info(a->c)->member_id,
	                       order);
	bc_viewer_status(a,
	                 "loaded %s: %u nodes, edit order %llu (the undo "
	                 "history starts here)",
	                 a->load.path, nodes, (unsigned long long)order);
	if (a->o.verbose) {
		printf("load %s nodes=%u order=%llu\n", a->load.path, nodes,
		       (unsigned long long)order);
		fflush(stdout);
	}
}

void bc_viewer_load_text(const struct bc_viewer_app *a, char *out, size_t n)
{
	char shown[sizeof(a->load.path)];
	bc_viewer_drawable(a->load.path, shown, sizeof(shown));
	snprintf(out, n,
	         "Load a scene file (JSON or binary) into session %s: %s_\n"
	         "It replaces the scene for every member, and the undo "
	         "history starts again.\nEnter loads, Esc cancels; the path "
	         "is relative to where blobcast-view started.",
	         a->o.session, shown);
}
