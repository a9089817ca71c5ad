/*
 * `blobcast mesh`: loads a scene (a file, '-' for stdin, 'default'),
 * meshes its surface with surface nets on a grid visited through an octree
 * of the primitives' ABVs (blobtree/mesh.c), and writes the mesh in the
 * format the output's extension names. Progress goes to stderr.
 */
#include "cmd_mesh.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/blobtree.h"
#include "blobcast/mesh.h"
#include "cmd_render.h"

struct mesh_args {
	const char *scene, *out;
	uint32_t resolution;
	float lo[3], hi[3];
	bool bounds, quiet;
};

static void usage(FILE *f)
{
	fprintf(f,
	        "usage: blobcast mesh SCENE --out FILE [options]\n"
	        "\n"
	        "Writes a closed triangle mesh of SCENE's surface. SCENE is a\n"
	        "JSON scene file, '-' to read one from stdin, or 'default'.\n"
	        "The surface is sampled on a uniform grid (surface nets: one\n"
	        "vertex per grid cell the surface crosses, placed on the\n"
	        "surface within its cell); only cells near the surface are\n"
	        "evaluated. Triangles are wound counter-clockwise seen from\n"
	        "outside; vertices carry their primitive's colour (OBJ, PLY).\n"
	        "\n"
	        "  --out FILE          .obj (text), .ply (binary) or .stl\n"
	        "                      (binary), by extension (required)\n"
	        "  --resolution N      grid cells along the box's longest side,\n"
	        "                      2..%u (default %u)\n"
	        "  --bounds X0,Y0,Z0,X1,Y1,Z1\n"
	        "                      the box to mesh (default: the scene's\n"
	        "                      box and two cells of margin); a solid\n"
	        "                      cut by it is closed by its faces\n"
	        "  --quiet             no progress and no summary line\n"
	        "  -h, --help          this help\n",
	        BC_MESH_MAX_RESOLUTION, BC_MESH_DEFAULT_RESOLUTION);
}

static int parse(int argc, char **argv, struct mesh_args *a)
{
	memset(a, 0, sizeof(*a));
	for (int i = 1; i < argc; i++) {
		const char *s = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : NULL;
		if (strcmp(s, "-h") == 0 || strcmp(s, "--help") == 0) {
			usage(stdout);
			return -1;
		}
		if (strcmp(s, "--quiet") == 0) {
			a->quiet = true;
		} else if (strcmp(s, "--out") == 0 && v) {
			a->out = v;
			i++;
		} else if (strcmp(s, "--resolution") == 0 && v) {
			char *end;
			unsigned long n;
			errno = 0;
			n = strtoul(v, &end, 10);
			if (errno || *end || end == v || n < 2 ||
			    n > BC_MESH_MAX_RESOLUTION) {
				fprintf(stderr,
				        "blobcast mesh: --resolution '%s' is "
				        "not a whole number in 2..%u\n",
				        v, BC_MESH_MAX_RESOLUTION);
				return 2;
			}
			a->resolution = (uint32_t)n;
			i++;
		} else if (strcmp(s, "--bounds") == 0 && v) {
			float b[6];
			char tail;
			if (sscanf(v, "%f,%f,%f,%f,%f,%f%c", &b[0], &b[1], &b[2],
			           &b[3], &b[4], &b[5], &tail) != 6 ||
			    !(b[3] > b[0] && b[4] > b[1] && b[5] > b[2])) {
				fprintf(stderr,
				        "blobcast mesh: --bounds '%s' is not "
				        "X0,Y0,Z0,X1,Y1,Z1 with each 1 above "
				        "its 0\n",
				        v);
				return 2;
			}
			memcpy(a->lo, b, sizeof(a->lo));
			memcpy(a->hi, b + 3, sizeof(a->hi));
			a->bounds = true;
			i++;
		} else if (s[0] == '-' && s[1] != '\0') {
			fprintf(stderr,
			        "blobcast mesh: unknown option or missing value "
			        "'%s' (see 'blobcast mesh --help')\n",
			        s);
			return 2;
		} else if (!a->scene) {
			a->scene = s;
		} else {
			fprintf(stderr, "blobcast mesh: a second scene '%s'\n",
			        s);
			return 2;
		}
	}
	if (!a->scene || !a->out) {
		fprintf(stderr, "blobcast mesh: %s is required (see 'blobcast "
		                "mesh --help')\n",
		        a->scene ? "--out" : "SCENE");
		return 2;
	}
	if (bc_mesh_format_of(a->out) == BC_MESH_FORMAT_INVALID) {
		fprintf(stderr,
		        "blobcast mesh: %s: the extension must be .obj, .ply "
		        "or .stl\n",
		        a->out);
		return 2;
	}
	return 0;
}

static double now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

struct prog {
	double last;
	bool on;
};

static void on_progress(void *ctx, double done)
{
	struct prog *p = ctx;
	double t = now_ms();
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
	int rc = parse(argc, argv, &a), status = 1;
	if (rc) {
		return rc < 0 ? 0 : rc;
	}
	memset(&m, 0, sizeof(m));
	t = bc_tree_create();
	if (!t) {
		fprintf(stderr, "blobcast mesh: out of memory\n");
		return 1;
	}
	if (bc_cli_load_scene(a.scene, t, &cam, &ei)) {
		fprintf(stderr, "blobcast mesh: %s\n", ei.msg);
		goto done;
	}
	o.resolution = a.resolution;
	if (a.bounds) {
		memcpy(o.lo, a.lo, sizeof(o.lo));
		memcpy(o.hi, a.hi, sizeof(o.hi));
	}
	pg.on = !a.quiet;
	pg.last = now_ms();
	o.progress = on_progress;
	o.ctx = &pg;
	t0 = now_ms();
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
		        now_ms() - t0, (unsigned long long)m.evals);
	}
	status = 0;
done:
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
	return status;
}
