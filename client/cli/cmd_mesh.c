/*
 * `blobcast mesh`: takes a scene (a file, '-' for stdin, 'default', or a
 * live session's scene through libblobcast, joined as a viewer), meshes
 * its surface with marching tetrahedra on a grid visited through an octree
 * of the primitives' ABVs (blobtree/mesh.c), and writes the mesh as OBJ,
 * PLY, STL or binary glTF. Progress goes to stderr.
 */
#include "cmd_mesh.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/clock.h"
#include "blobcast/mesh.h"
#include "blobcast/num.h"
#include "cli.h"
#include "cmd_client.h"
#include "cmd_render.h"

struct mesh_args {
	const char *scene, *out;
	enum bc_mesh_format format;
	uint32_t resolution;
	float lo[3], hi[3];
	bool bounds, quiet, raw;
	bool on_daemon; /* the daemon meshes (MESH) */
	bool timeout_given;
	/* A live session instead of SCENE: the client commands' options. */
	struct bc_cli_call call;
};

static const struct bc_opt_name format_names[] = {
    {"obj", BC_MESH_FORMAT_OBJ},
    {"ply", BC_MESH_FORMAT_PLY},
    {"stl", BC_MESH_FORMAT_STL},
    {"glb", BC_MESH_FORMAT_GLB},
    {NULL, 0},
};

/* Returns 0 to go on, or the exit status (0 after --help, 2 on a bad
 * argument) with *done set. */
static int parse(int argc, char **argv, struct mesh_args *a, bool *done)
{
	const char *bounds = NULL;
	int format = BC_MESH_FORMAT_INVALID;
	uint32_t timeout_ms = 10000;
	struct bc_cli_call *c = &a->call;
	const struct bc_opt opts[] = {
	    {.name = "out",
	     .kind = BC_OPT_STRING,
	     .dst = &a->out,
	     .arg = "FILE",
	     .help = "the mesh file (required); its extension names\n"
	             "the format unless --format does: .obj (text),\n"
	             ".ply (binary), .stl (binary) or .glb (binary\n"
	             "glTF 2.0 with normals and vertex colours)",
	     .flags = BC_OPT_REQUIRED},
	    {.name = "format",
	     .kind = BC_OPT_ENUM,
	     .dst = &format,
	     .arg = "F",
	     .names = format_names,
	     .help = "{choices}: the format, whatever\nFILE's extension"},
	    {.name = "resolution",
	     .kind = BC_OPT_U32,
	     .dst = &a->resolution,
	     .lo = 2,
	     .hi = BC_MESH_MAX_RESOLUTION,
	     .arg = "N",
	     .help = "grid cells along the box's longest side,\n"
	             "{range} (default {default})"},
	    {.name = "bounds",
	     .kind = BC_OPT_STRING,
	     .dst = &bounds,
	     .arg = "X0,Y0,Z0,X1,Y1,Z1",
	     .help = "the box to mesh (default: the scene's\n"
	             "box and two cells of margin); a solid\n"
	             "cut by it is closed along its faces"},
	    {.name = "raw",
	     .kind = BC_OPT_FLAG,
	     .dst = &a->raw,
	     .help = "keep every triangle of the tetrahedra (no\n"
	             "collapse of edges under half a cell): faster,\n"
	             "about twice the triangles"},
	    {.name = "quiet",
	     .kind = BC_OPT_FLAG,
	     .dst = &a->quiet,
	     .help = "no progress and no summary line"},
	    {.name = "session",
	     .kind = BC_OPT_STRING,
	     .dst = &c->session,
	     .arg = "NAME",
	     .help = "mesh the scene of live session NAME instead\n"
	             "of SCENE (joined as a viewer, then left)"},
	    {.name = "on-daemon",
	     .kind = BC_OPT_FLAG,
	     .dst = &a->on_daemon,
	     .help = "with --session: the daemon makes the mesh\n"
	             "(the same file) and sends it, for a machine\n"
	             "too small to mesh; up to the daemon's finest\n"
	             "grid (blobcastd: 256), no --bounds; the wait\n"
	             "has no limit unless --timeout is given"},
	    {.name = "server",
	     .kind = BC_OPT_STRING,
	     .dst = &c->server,
	     .arg = "ADDR",
	     .help = "with --session: the blobcastd, as for the\n"
	             "server commands (default $BLOBCAST_SERVER,\n"
	             "else 127.0.0.1:7878)"},
	    {.name = "token",
	     .kind = BC_OPT_STRING,
	     .dst = &c->token,
	     .arg = "TOKEN",
	     .flags = BC_OPT_EMPTY,
	     .help = "with --session: authentication token\n"
	             "(default $BLOBCAST_TOKEN)"},
	    {.name = "name",
	     .kind = BC_OPT_STRING,
	     .dst = &c->name,
	     .arg = "NAME",
	     .flags = BC_OPT_EMPTY,
	     .help = "with --session: the name other members see"},
	    {.name = "timeout",
	     .kind = BC_OPT_U32,
	     .dst = &timeout_ms,
	     .lo = 0,
	     .hi = 86400000,
	     .arg = "MS",
	     .help = "with --session: limit for connecting and each\n"
	             "answer ({range}; default 10000; 0 waits\n"
	             "forever)"},
	    {.name = "ca",
	     .kind = BC_OPT_STRING,
	     .dst = &c->ca,
	     .arg = "FILE",
	     .help = "with --session over TLS: trust the CA\n"
	             "certificates in FILE (PEM)"},
	    {.name = "insecure",
	     .kind = BC_OPT_FLAG,
	     .dst = &c->insecure,
	     .help = "with --session over TLS: do not check the\n"
	             "server's certificate"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args p = {
	    .prog = "blobcast mesh",
	    .usage = "blobcast mesh (SCENE | --session NAME) --out FILE "
	             "[options]",
	    .about =
	        "Writes the surface of SCENE (a scene file, JSON or binary, "
	        "'-'\nto read one from stdin, or 'default') or of a "
	        "live\nsession's scene as a triangle mesh that is a closed "
	        "2-manifold:\nevery edge is used by exactly two triangles, in "
	        "opposite\ndirections (no holes, no edge shared by more than "
	        "two), and no\ntriangle is degenerate.\nTriangles wind "
	        "counter-clockwise seen from "
	        "outside. Vertices\ncarry their primitive's colour (OBJ, PLY, "
	        "glb). The surface is\nsampled on a uniform grid (marching "
	        "tetrahedra: the zero set of\nthe field's linear "
	        "interpolation); only cells near the surface\nare evaluated. "
	        "Edges under half a cell are then collapsed where\nthat keeps "
	        "the topology (--raw: not). Detail smaller than a grid\ncell "
	        "is lost, and a sharp edge is bevelled within a cell\n"
	        "(docs/mesh.md).\n\n"
	        "Progress: on a terminal, a 'meshing: N%' line on stderr "
	        "updated\nin place after the first second; otherwise one such "
	        "line every\n10 s. Then one summary line; --quiet prints "
	        "neither.",
	    .opts = opts};
	float b[6];
	memset(a, 0, sizeof(*a));
	a->resolution = BC_MESH_DEFAULT_RESOLUTION;
	*done = true;
	if (bc_cli_args_parse(&p, argc, argv)) {
		return p.status;
	}
	if (p.npos > 1) {
		return bc_args_error(&p, "a second scene '%s'", p.pos[1]);
	}
	if (c->session) {
		struct bc_client_addr addr;
		struct bc_errinfo ei = {0};
		if (p.npos) {
			return bc_args_error(&p, "give SCENE or --session, not "
			                         "both");
		}
		if (strlen(c->session) > BC_PROTO_MAX_NAME ||
		    (c->name && strlen(c->name) > BC_PROTO_MAX_NAME)) {
			return bc_args_error(&p,
			                     "--session and --name are at most "
			                     "%u bytes",
			                     BC_PROTO_MAX_NAME);
		}
		if (c->server && bc_client_addr_parse(c->server, &addr, &ei)) {
			return bc_args_error(&p, "--server: %s", ei.msg);
		}
		c->cmd = "mesh";
		c->timeout_ms = (int)timeout_ms;
		a->timeout_given = bc_args_given(&p, "timeout");
		if (a->on_daemon && bounds) {
			return bc_args_error(&p,
			                     "--bounds: the daemon meshes "
			                     "the scene's own box; leave out "
			                     "--on-daemon to mesh another");
		}
	} else {
		const char *only[] = {"server",   "token", "name",
		                      "timeout",  "ca",    "insecure",
		                      "on-daemon"};
		if (p.npos == 0) {
			return bc_args_error(&p, "SCENE (or --session NAME) is "
			                         "required");
		}
		for (size_t i = 0; i < sizeof(only) / sizeof(only[0]); i++) {
			if (bc_args_given(&p, only[i])) {
				return bc_args_error(
				    &p,
				    "--%s applies with --session "
				    "only",
				    only[i]);
			}
		}
		a->scene = p.pos[0];
	}
	if (bounds) {
		if (bc_num_f32s(bounds, b, 6) ||
		    !(b[3] > b[0] && b[4] > b[1] && b[5] > b[2])) {
			return bc_args_error(&p,
			                     "--bounds '%s' is not "
			                     "X0,Y0,Z0,X1,Y1,Z1 with each 1 "
			                     "above its 0",
			                     bounds);
		}
		memcpy(a->lo, b, sizeof(a->lo));
		memcpy(a->hi, b + 3, sizeof(a->hi));
		a->bounds = true;
	}
	a->format = format != BC_MESH_FORMAT_INVALID
	                ? (enum bc_mesh_format)format
	                : bc_mesh_format_of(a->out);
	if (a->format == BC_MESH_FORMAT_INVALID) {
		return bc_args_error(&p,
		                     "%s: the extension must be .obj, .ply, "
		                     ".stl or .glb, or give --format",
		                     a->out);
	}
	*done = false;
	return 0;
}

/* Progress on stderr: on a terminal one line rewritten in place, from the
 * first second on; elsewhere (a log, a pipe) a whole line every 10 s, so
 * that a log shows a long run moving without filling up. */
struct prog {
	double start, last;
	bool on, tty, shown;
};

static void on_progress(void *ctx, double done)
{
	struct prog *p = ctx;
	double t = bc_clock_ms();
	if (!p->on) {
		return;
	}
	if (p->tty && t - p->start > 1000.0 && t - p->last > 250.0) {
		fprintf(stderr, "\rmeshing: %3.0f%%", 100.0 * done);
		p->last = t;
		p->shown = true;
	} else if (!p->tty && t - p->last > 10000.0) {
		fprintf(stderr, "meshing: %3.0f%% after %.0f s\n", 100.0 * done,
		        (t - p->start) / 1000.0);
		p->last = t;
	}
}

/* The scene of the live session a->call names, copied into t (the
 * connection is closed before meshing, which may take long). 0, or the
 * exit status after saying why. */
static int session_scene(struct mesh_args *a, struct bc_tree *t)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	const struct bc_tree *s;
	int status = bc_cli_open_session(&a->call, BC_PROTO_ROLE_VIEWER,
	                                 BC_CLIENT_JOIN_EXISTING, &c);
	if (status == 0) {
		if (!(s = bc_client_scene(c, NULL))) {
			fprintf(stderr,
			        "blobcast mesh: the session's scene did "
			        "not decode (see the log above)\n");
			status = BC_CLI_EXIT_FAIL;
		} else if (bc_tree_copy(t, s, &ei)) {
			fprintf(stderr, "blobcast mesh: %s\n", ei.msg);
			status = BC_CLI_EXIT_FAIL;
		}
	}
	bc_client_destroy(c);
	return status;
}

/* --on-daemon: the session's mesh as the daemon makes it, written to
 * a->out. Returns the exit status after saying what happened. */
static int daemon_mesh(struct mesh_args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_mesh m = {0};
	double t0 = bc_clock_ms();
	int status = bc_cli_open_session(&a->call, BC_PROTO_ROLE_VIEWER,
	                                 BC_CLIENT_JOIN_EXISTING, &c);
	if (status) {
		goto out;
	}
	if (!a->quiet) {
		fprintf(stderr, "meshing on the daemon ...\n");
	}
	if (bc_client_mesh(c, (int)a->format, a->raw ? BC_PROTO_MESH_RAW : 0u,
	                   (uint16_t)a->resolution,
	                   a->timeout_given ? a->call.timeout_ms : -1, &m,
	                   &ei)) {
		status = bc_cli_failed(&a->call, c, NULL, &ei);
		goto out;
	}
	if (bc_mesh_write_file(a->out, m.file, m.len, &ei)) {
		fprintf(stderr, "blobcast mesh: %s\n", ei.msg);
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (!a->quiet) {
		fprintf(stderr,
		        "meshing: done on the daemon. %s: %u vertices, %u "
		        "triangles, resolution %u, edit order %llu, %.1f ms\n",
		        a->out, m.vertices, m.triangles, (unsigned)m.resolution,
		        (unsigned long long)m.order, bc_clock_ms() - t0);
	}
out:
	bc_free(m.file);
	bc_client_destroy(c);
	return status;
}

int bc_cli_mesh(int argc, char **argv)
{
	struct mesh_args a;
	struct bc_tree *t = NULL;
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_mesh m;
	struct prog pg = {0};
	struct bc_mesh_opts o = {0};
	double t0;
	bool stop;
	int status = parse(argc, argv, &a, &stop);
	if (stop) {
		return status;
	}
	if (a.on_daemon) {
		return daemon_mesh(&a);
	}
	status = 1;
	memset(&m, 0, sizeof(m));
	t = bc_tree_create();
	if (!t) {
		fprintf(stderr, "blobcast mesh: out of memory\n");
		return 1;
	}
	if (a.call.session) {
		if ((status = session_scene(&a, t))) {
			goto done;
		}
		status = 1;
	} else if (bc_cli_load_scene(a.scene, t, &cam, &ei)) {
		bc_cli_explain(stderr, "blobcast mesh", ei.msg);
		goto done;
	}
	o.resolution = a.resolution;
	o.raw = a.raw;
	if (a.bounds) {
		memcpy(o.lo, a.lo, sizeof(o.lo));
		memcpy(o.hi, a.hi, sizeof(o.hi));
	}
	pg.on = !a.quiet;
	pg.tty = isatty(STDERR_FILENO) == 1;
	pg.start = pg.last = bc_clock_ms();
	o.progress = on_progress;
	o.ctx = &pg;
	t0 = bc_clock_ms();
	if (bc_mesh_build(&m, t, &o, &ei)) {
		fprintf(stderr, "%sblobcast mesh: %s\n", pg.shown ? "\n" : "",
		        ei.msg);
		goto done;
	}
	if (bc_mesh_write(&m, a.out, a.format, &ei)) {
		fprintf(stderr, "%sblobcast mesh: %s\n", pg.shown ? "\n" : "",
		        ei.msg);
		goto done;
	}
	if (!a.quiet) {
		fprintf(stderr,
		        "%smeshing: done. %s: %u vertices, %u triangles, cell "
		        "%.4g, %.1f ms, %llu field evaluations\n",
		        pg.shown ? "\r" : "", a.out, m.nverts, m.ntris,
		        (double)m.cell, bc_clock_ms() - t0,
		        (unsigned long long)m.evals);
	}
	status = 0;
done:
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
	return status;
}
