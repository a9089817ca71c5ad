/*
 * Ctrl+S and Ctrl+Shift+S: the session's scene, as this window's mirror
 * holds it, saved as a scene file in the snapshot directory -- JSON or
 * binary, the files `blobcast scene` and the page's downloads write
 * (docs/scene-format.md), named blobcast-SESSION-ORDER.json or .bin after
 * the edit order they hold. The mirror is the session's scene as of that
 * order (bc_client_scene), with the session's camera; saving it asks the
 * daemon nothing.
 */
#include <stdio.h>
#include <string.h>

#include "app.h"
#include "blobcast/scene.h"

/* The session's name as a file name's part: the daemon allows letters,
 * digits, '-', '_' and '.' (PROTOCOL.md 7.6); anything else a server
 * might send becomes '_'. */
static void file_part(const char *name, char *out, size_t n)
{
	size_t k = 0;
	for (; name[k] && k + 1 < n; k++) {
		char c = name[k];
		bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
		          (c >= '0' && c <= '9') || c == '-' || c == '_' ||
		          (c == '.' && k > 0);
		out[k] = ok ? c : '_';
	}
	out[k] = '\0';
}

void bc_viewer_save_scene(struct bc_viewer_app *a, bool binary)
{
	const struct bc_client_info *info = bc_client_info(a->c);
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	const struct bc_tree *t = bc_client_scene(a->c, &cam);
	char session[BC_PROTO_MAX_NAME + 1], path[4096];
	const char *what = binary ? "binary scene" : "scene";
	const char *base;
	int rc;
	if (!t || !info->session[0]) {
		bc_viewer_status(a, "%s not saved: no scene yet", what);
		return;
	}
	file_part(info->session, session, sizeof(session));
	if (snprintf(path, sizeof(path), "%s/blobcast-%s-%llu.%s",
	             a->o.snapshot_dir, session,
	             (unsigned long long)info->order,
	             binary ? "bin" : "json") >= (int)sizeof(path)) {
		bc_viewer_status(a, "%s not saved: --snapshot-dir is too long",
		                 what);
		return;
	}
	/* A million primitives: 0.8 s as JSON, 0.02 s binary (docs/
	 * benchmarks.md, "Binary snapshots"); the window waits, as for a
	 * snapshot's PNG. */
	rc = binary ? bc_scene_save_binary(path, t, &cam, &ei)
	            : bc_scene_save_json(path, t, &cam, &ei);
	if (rc) {
		bc_viewer_status(a, "%s not saved: %s", what, ei.msg);
		return;
	}
	base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
	bc_viewer_status(a, "saved %s (%u nodes, edit order %llu)", base,
	                 bc_tree_node_count(t),
	                 (unsigned long long)info->order);
	if (a->o.verbose) {
		printf("scene %s order=%llu\n", path,
		       (unsigned long long)info->order);
		fflush(stdout);
	}
}
