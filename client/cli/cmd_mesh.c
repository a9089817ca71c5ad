/*
 * `blobcast mesh`: loads a scene (a file, '-' for stdin, 'default'),
 * meshes its surface with surface nets on a grid visited through an octree
 * of the primitives' ABVs (blobtree/mesh.c), and writes the mesh in the
 * format the output's extension names. Progress goes to stderr.
 */
#include "cmd_mesh.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/clock.h"
#include "blobcast/num.h"
#include "blobcast/mesh.h"
#include "cli.h"
#include "cmd_render.h"

struct mesh_args {
	const char *scene, *out;
	uint32_t resolution;
	float lo[3], hi[3];
	bool bounds, quiet;
};

/* Returns 0 to go on, or the exit status (0 after --help, 2 on a bad
 * argument) with *done set. */
static int parse(int argc, char **argv, struct mesh_args *a, bool *done)
{
	const char *bounds = NULL;
	const struct bc_opt opts[] = {
	    {.name = "out",
	     .kind = BC_OPT_STRING,
	     .dst = &a->out,
	     .arg = "FILE",
	     .help = ".obj (text), .ply (binary) or .stl\n"
	             "(binary), by extension (required)",
	     .flags = BC_OPT_REQUIRED},
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
	             "cut by it is closed by its faces"},
	    {.name = "quiet",
	     .kind = BC_OPT_FLAG,
	     .dst = &a->quiet,
	     .help = "no progress and no summary line"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args p = {
	    .prog = "blobcast mesh",
	    .usage = "blobcast mesh SCENE --out FILE [options]",
	    .about = "Writes a closed triangle mesh of SCENE's surface. "
	             "SCENE is a\nJSON scene file, '-' to read one from "
	             "stdin, or 'default'.\nThe surface is sampled on a "
	             "uniform grid (surface nets: one\nvertex per grid "
	             "cell the surface crosses, placed on the\nsurface "
	             "within its cell); only cells near the surface are\n"
	             "evaluated. Triangles are wound counter-clockwise "
	             "seen from\noutside; vertices carry their primitive's "
	             "colour (OBJ, PLY).",
	    .opts = opts};
	float b[6];
	memset(a, 0, sizeof(*a));
	a->resolution = BC_MESH_DEFAULT_RESOLUTION;
	*done = true;
	if (bc_cli_args_parse(&p, argc, argv)) {
		return p.status;
	}
	if (p.npos == 0) {
		return bc_args_error(&p, "SCENE is required");
	}
	if (p.npos > 1) {
		return bc_args_error(&p, "a second scene '%s'", p.pos[1]);
	}
	a->scene = p.pos[0];
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
	if (bc_mesh_format_of(a->out) == BC_MESH_FORMAT_INVALID) {
		return bc_args_error(&p,
		                     "%s: the extension must be .obj, .ply "
		                     "or .stl",
		                     a->out);
	}
	*done = false;
	return 0;
}

struct prog {
	double last;
	bool on;
};

static void on_progress(void *ctx, double done)
{
	struct prog *p = ctx;
	double t = bc_clock_ms();
	if (p->on && t - p->last > 500.0) {
		fprintf(stderr, "\rmeshing: %3.0f%%", 100.0 * done);
		p->last = t;
	}
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
	status = 1;
	memset(&m, 0, sizeof(m));
	t = bc_tree_create();
	if (!t) {
		fprintf(stderr, "blobcast mesh: out of memory\n");
		return 1;
	}
	if (bc_cli_load_scene(a.scene, t, &cam, &ei)) {
		bc_cli_explain(stderr, "blobcast mesh", ei.msg);
		goto done;
	}
	o.resolution = a.resolution;
	if (a.bounds) {
		memcpy(o.lo, a.lo, sizeof(o.lo));
		memcpy(o.hi, a.hi, sizeof(o.hi));
	}
	pg.on = !a.quiet;
	pg.last = bc_clock_ms();
	o.progress = on_progress;
	o.ctx = &pg;
	t0 = bc_clock_ms();
	if (bc_mesh_build(&m, t, &o, &ei)) {
		fprintf(stderr, "%sblobcast mesh: %s\n", pg.on ? "\n" : "",
		        ei.msg);
		goto done;
	}
	if (bc_mesh_write(&m, a.out, bc_mesh_format_of(a.out), &ei)) {
		fprintf(stderr, "%sblobcast mesh: %s\n", pg.on ? "\n" : "",
		        ei.msg);
		goto done;
	}
	if (!a.quiet) {
		fprintf(stderr,
		        "\rmeshing: done. %s: %u vertices, %u triangles, cell "
		        "%.4g, %.1f ms, %llu field evaluations\n",
		        a.out, m.nverts, m.ntris, (double)m.cell,
		        bc_clock_ms() - t0, (unsigned long long)m.evals);
	}
	status = 0;
done:
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
	return status;
}
