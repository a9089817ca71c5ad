/*
 * Files the viewer saves from its mirror of the session, named
 * blobcast-SESSION-ORDER.EXT in the snapshot directory after the edit
 * order they hold; saving asks the daemon nothing.
 *
 * Ctrl+S and Ctrl+Shift+S: the session's scene as a scene file -- JSON or
 * binary, the files `blobcast scene` and the page's downloads write
 * (docs/scene-format.md). The mirror is the session's scene as of that
 * order (bc_client_scene), with the session's camera.
 *
 * Ctrl+M and Ctrl+Shift+M: its solid as a closed mesh, glTF binary or
 * OBJ, the mesh `blobcast mesh --session` writes (docs/mesh.md) with its
 * defaults. Meshing a big scene takes seconds (fig18's 1024 spheres: 2.6
 * s), so it runs on a thread of its own: the window copies its mirror
 * (bare, the model alone) and goes on; the thread lays the copy out,
 * meshes it and writes the file, and the status line follows it.
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

/* The path of a file of the session at its edit order with extension
 * ext, in path (n bytes). False, saying why on the status line (what:
 * what was not saved), when there is no scene yet or the path is too
 * long. */
static bool save_path(struct bc_viewer_app *a, const char *what,
                      const char *ext, char *path, size_t n)
{
	const struct bc_client_info *info = bc_client_info(a->c);
	char session[BC_PROTO_MAX_NAME + 1];
	if (!bc_client_scene(a->c, NULL) || !info->session[0]) {
		bc_viewer_status(a, "%s not saved: no scene yet", what);
		return false;
	}
	file_part(info->session, session, sizeof(session));
	if (snprintf(path, n, "%s/blobcast-%s-%llu.%s", a->o.snapshot_dir,
	             session, (unsigned long long)info->order, ext) >= (int)n) {
		bc_viewer_status(a, "%s not saved: --snapshot-dir is too long",
		                 what);
		return false;
	}
	return true;
}

static const char *base_name(const char *path)
{
	const char *slash = strrchr(path, '/');
	return slash ? slash + 1 : path;
}

void bc_viewer_save_scene(struct bc_viewer_app *a, bool binary)
{
	const struct bc_client_info *info = bc_client_info(a->c);
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	const struct bc_tree *t = bc_client_scene(a->c, &cam);
	char path[4096];
	const char *what = binary ? "binary scene" : "scene";
	int rc;
	if (!save_path(a, what, binary ? "bin" : "json", path, sizeof(path))) {
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
	bc_viewer_status(a, "saved %s (%u nodes, edit order %llu)",
	                 base_name(path), bc_tree_node_count(t),
	                 (unsigned long long)info->order);
	if (a->o.verbose) {
		printf("scene %s order=%llu\n", path,
		       (unsigned long long)info->order);
		fflush(stdout);
	}
}

/* ---- the mesher ------------------------------------------------------------ */

static void mesh_progress(void *ctx, double done)
{
	struct bc_viewer_mesher *m = ctx;
	double d = done < 0.0 ? 0.0 : done > 1.0 ? 1.0 : done;
	atomic_store(&m->permille, (unsigned)(d * 1000.0));
}

/* The mesher's work: lays its copy out, meshes it and writes the file. */
static void mesh_main(void *arg)
{
	struct bc_viewer_mesher *m = arg;
	struct bc_tree *laid = bc_tree_create();
	struct bc_mesh mesh;
	struct bc_mesh_opts o = {.progress = mesh_progress, .ctx = m};
	memset(&mesh, 0, sizeof(mesh));
	if (!laid) {
		m->rc = BC_ENOMEM;
		snprintf(m->ei.msg, sizeof(m->ei.msg), "out of memory");
	} else if (!(m->rc = bc_tree_copy(laid, m->tree, &m->ei)) &&
	           !(m->rc = bc_mesh_build(&mesh, laid, &o, &m->ei)) &&
	           !(m->rc =
	                 bc_mesh_write(&mesh, m->path, m->format, &m->ei))) {
		m->nverts = mesh.nverts;
		m->ntris = mesh.ntris;
	}
	bc_mesh_finish(&mesh);
	bc_tree_destroy(laid);
	bc_tree_destroy(m->tree);
	m->tree = NULL;
}

void bc_viewer_save_mesh(struct bc_viewer_app *a, bool obj)
{
	struct bc_viewer_mesher *m = &a->mesher;
	struct bc_errinfo ei = {0};
	const char *what = obj ? "OBJ mesh" : "glTF mesh";
	if (m->w.busy) {
		bc_viewer_status(a,
		                 "%s not started: %s is still being made "
		                 "(%u %%)",
		                 what, base_name(m->path),
		                 atomic_load(&m->permille) / 10u);
		return;
	}
	if (!save_path(a, what, obj ? "obj" : "glb", m->path,
	               sizeof(m->path))) {
		return;
	}
	/* The model alone, copied here (the mirror changes under the loop);
	 * the thread lays it out. */
	if (!(m->tree = bc_tree_create()) ||
	    bc_tree_set_layout(m->tree, false) ||
	    bc_tree_copy(m->tree, bc_client_scene(a->c, NULL), &ei)) {
		bc_viewer_status(a, "%s not saved: %s", what,
		                 ei.msg[0] ? ei.msg : "out of memory");
		bc_tree_destroy(m->tree);
		m->tree = NULL;
		return;
	}
	m->format = obj ? BC_MESH_FORMAT_OBJ : BC_MESH_FORMAT_GLB;
	m->rc = 0;
	memset(&m->ei, 0, sizeof(m->ei));
	m->nverts = m->ntris = 0;
	atomic_store(&m->permille, 0u);
	if (bc_viewer_worker_start(&m->w, mesh_main, m)) {
		bc_viewer_status(a, "%s not saved: no thread for it", what);
		bc_tree_destroy(m->tree);
		m->tree = NULL;
		return;
	}
	bc_viewer_status(a, "meshing %s ...", base_name(m->path));
}

/* Says what became of the mesher's file, its thread joined: on the status
 * line, and on stderr too when loud (the window is closing). */
static void mesh_said(struct bc_viewer_app *a, bool loud)
{
	struct bc_viewer_mesher *m = &a->mesher;
	double now = bc_viewer_now_ms();
	if (m->rc) {
		bc_viewer_status(a, "mesh not saved: %s", m->ei.msg);
	} else {
		bc_viewer_status(a, "saved %s (%u triangles, %.1f s)",
		                 base_name(m->path), m->ntris,
		                 (now - m->w.started) / 1e3);
		if (a->o.verbose) {
			printf("mesh %s vertices=%u triangles=%u\n", m->path,
			       m->nverts, m->ntris);
			fflush(stdout);
		}
	}
	if (loud) {
		fprintf(stderr, "blobcast-view: %s\n", a->status);
	}
}

double bc_viewer_mesh_poll(struct bc_viewer_app *a, double now)
{
	struct bc_viewer_mesher *m = &a->mesher;
	if (bc_viewer_worker_reap(&m->w)) {
		mesh_said(a, false);
	}
	if (!m->w.busy) {
		return -1.0;
	}
	if (bc_viewer_worker_say_due(&m->w, now)) {
		bc_viewer_status(a, "meshing %s: %u %%", base_name(m->path),
		                 atomic_load(&m->permille) / 10u);
	}
	return bc_viewer_worker_next(&m->w, now);
}

void bc_viewer_mesh_wait(struct bc_viewer_app *a)
{
	struct bc_viewer_mesher *m = &a->mesher;
	bool waits;
	if (!m->w.busy) {
		return;
	}
	waits = !atomic_load(&m->w.done);
	if (waits) {
		fprintf(stderr, "blobcast-view: finishing %s (%u %%) ...\n",
		        m->path, atomic_load(&m->permille) / 10u);
	}
	bc_viewer_worker_join(&m->w);
	mesh_said(a, waits);
}
