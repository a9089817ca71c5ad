/*
 * Mesh export (blobtree/mesh.c): the mesh of a sphere is a
 * closed 2-manifold of genus 0 (every edge used by exactly two triangles,
 * in opposite directions; V - E + F = 2) whose enclosed volume is the
 * ball's to 2 %; on the catalogue (every primitive kind) and on generated
 * scenes every vertex lies within a grid cell of the zero set, every
 * directed edge is used once and has its reverse (a closed, consistently
 * oriented 2-manifold), the enclosed volume
 * matches a count of the grid points inside to 2 %, and most of the grid
 * is never evaluated; the OBJ, PLY and STL files
 * written parse back to the same mesh; bad arguments are refused.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/mesh.h"
#include "blobcast/scene.h"
#include "test.h"

static struct bc_tree *one_sphere(float r)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = r;
	p.translate[0] = 0.1f;
	if (!t || bc_tree_begin(t) || bc_tree_put_prim(t, 1, &p, NULL) ||
	    bc_tree_end(t, NULL)) {
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return (x > y) - (x < y);
}

struct topo {
	uint64_t edges;  /* undirected */
	uint64_t open;   /* directed edges without their reverse */
	uint64_t shared; /* directed edges used more than once */
	double volume;
};

/* Edge uses: every directed edge (a, b) must appear once and (b, a) once. */
static void topology(const struct bc_mesh *m, struct topo *o)
{
	uint64_t n = 3ull * m->ntris, *dir = malloc(n * sizeof(*dir));
	double vol = 0.0;
	memset(o, 0, sizeof(*o));
	REQUIRE(dir);
	for (uint32_t i = 0; i < m->ntris; i++) {
		const float *a = m->pos[m->tri[i][0]],
		            *b = m->pos[m->tri[i][1]],
		            *c = m->pos[m->tri[i][2]];
		for (int e = 0; e < 3; e++) {
			uint64_t u = m->tri[i][e], v = m->tri[i][(e + 1) % 3];
			dir[3 * i + e] = u << 32 | v;
		}
		/* Divergence theorem: sum of signed tetrahedra. */
		vol += ((double)a[0] *
		            ((double)b[1] * c[2] - (double)b[2] * c[1]) -
		        (double)a[1] *
		            ((double)b[0] * c[2] - (double)b[2] * c[0]) +
		        (double)a[2] *
		            ((double)b[0] * c[1] - (double)b[1] * c[0])) /
		       6.0;
	}
	qsort(dir, n, sizeof(*dir), cmp_u64);
	for (uint64_t i = 0; i < n; i++) {
		uint64_t rev = (dir[i] << 32) | (dir[i] >> 32), *hit;
		bool dup = i + 1 < n && dir[i + 1] == dir[i];
		hit = bsearch(&rev, dir, n, sizeof(*dir), cmp_u64);
		o->open += !hit;
		o->shared += dup;
		if ((dir[i] >> 32) < (dir[i] & 0xffffffffu)) {
			o->edges++;
		}
	}
	o->volume = vol;
	free(dir);
}

static void sphere_is_a_closed_genus_0_manifold(void)
{
	struct bc_tree *t = one_sphere(1.0f);
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	struct topo tp;
	const struct bc_lin *l;
	float worst = 0.0f;
	REQUIRE(t);
	l = bc_tree_lin(t);
	REQUIRE(bc_mesh_build(&m, t, &(struct bc_mesh_opts){.resolution = 48},
	                      &ei) == 0);
	CHECK(m.nverts > 0 && m.ntris > 0);
	for (uint32_t i = 0; i < m.nverts; i++) {
		worst = fmaxf(worst, fabsf(bc_eval_full(l, m.pos[i])));
	}
	topology(&m, &tp);
	printf("  sphere: %u vertices, %u triangles, %llu edges, worst |f| "
	       "%.2g (cell %.3g), volume %.4f (ball %.4f)\n",
	       m.nverts, m.ntris, (unsigned long long)tp.edges, (double)worst,
	       (double)m.cell, tp.volume, 4.0 / 3.0 * 3.14159265358979);
	CHECK(worst <= 0.1f * m.cell);
	CHECK_EQ_INT(tp.open, 0);
	CHECK_EQ_INT(tp.shared, 0);
	CHECK((int64_t)m.nverts - (int64_t)tp.edges + (int64_t)m.ntris == 2);
	CHECK(fabs(tp.volume / (4.0 / 3.0 * 3.14159265358979) - 1.0) < 0.02);
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
}

/* Volume by counting grid points inside, over the mesh's box. */
static double voxel_volume(const struct bc_lin *l, double h)
{
	double v = 0.0;
	for (double z = l->lo[2] + 0.5 * h; z < l->hi[2]; z += h) {
		for (double y = l->lo[1] + 0.5 * h; y < l->hi[1]; y += h) {
			for (double x = l->lo[0] + 0.5 * h; x < l->hi[0];
			     x += h) {
				float p[3] = {(float)x, (float)y, (float)z};
				v += bc_eval_full(l, p) < 0.0f;
			}
		}
	}
	return v * h * h * h;
}

static void scenes_mesh_closed_near_the_surface(void)
{
	static const struct {
		const char *gen;
		struct bc_gen_opts o;
		uint32_t res;
		double vox, visited;
	} scenes[] = {
	    {"catalogue", {.seed = 1}, 160, 0.06, 0.25},
	    {"gears", {.teeth = 12}, 128, 0.02, 0.25},
	    {"fig18",
	     {.count = 24, .kind = BC_GEN_KIND_SPHERES},
	     80,
	     0.03,
	     0.9},
	};
	for (size_t s = 0; s < sizeof(scenes) / sizeof(scenes[0]); s++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_mesh m;
		struct bc_errinfo ei = {0};
		struct topo tp;
		const struct bc_lin *l;
		uint32_t far = 0;
		double vv;
		REQUIRE(t);
		REQUIRE(bc_gen(scenes[s].gen, &scenes[s].o, t, NULL, &ei) == 0);
		l = bc_tree_lin(t);
		REQUIRE(bc_mesh_build(
		            &m, t,
		            &(struct bc_mesh_opts){.resolution = scenes[s].res},
		            &ei) == 0);
		for (uint32_t i = 0; i < m.nverts; i++) {
			/* A vertex stays in its cell, which the surface
			 * crosses: within a cell diagonal of the zero set,
			 * and the field is at most 1.45 times that. */
			far += fabsf(bc_eval_full(l, m.pos[i])) >
			       1.45f * 1.7321f * m.cell;
		}
		topology(&m, &tp);
		vv = voxel_volume(l, scenes[s].vox);
		printf("  %-9s res %u: %u vertices, %u triangles, %llu of "
		       "%llu edges non-manifold, %u vertices beyond a cell, "
		       "volume %.4f, voxel count %.4f, %llu of %.0f cells "
		       "evaluated\n",
		       scenes[s].gen, scenes[s].res, m.nverts, m.ntris,
		       (unsigned long long)tp.shared,
		       (unsigned long long)tp.edges, far, tp.volume, vv,
		       (unsigned long long)m.cells_visited,
		       (double)scenes[s].res * scenes[s].res * scenes[s].res);
		CHECK(m.ntris > 1000);
		CHECK_EQ_INT(far, 0);
		/* A closed 2-manifold, consistently oriented: every directed
		 * edge once, with its reverse. */
		CHECK_EQ_INT(tp.open, 0);
		CHECK_EQ_INT(tp.shared, 0);
		CHECK(fabs(tp.volume / vv - 1.0) < 0.02);
		/* Only the cells near the surface were evaluated. */
		CHECK((double)m.cells_visited <
		      scenes[s].visited * scenes[s].res * scenes[s].res *
		          scenes[s].res);
		bc_mesh_finish(&m);
		bc_tree_destroy(t);
	}
}

/* ---- the files ----------------------------------------------------------- */

static float rd_f32(const uint8_t *p)
{
	uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 |
	             (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
	float f;
	memcpy(&f, &u, 4);
	return f;
}

static uint32_t rd_u32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	       (uint32_t)p[3] << 24;
}

static uint8_t *slurp(const char *path, size_t *n)
{
	FILE *f = fopen(path, "rb");
	uint8_t *b;
	long len;
	if (!f) {
		return NULL;
	}
	fseek(f, 0, SEEK_END);
	len = ftell(f);
	fseek(f, 0, SEEK_SET);
	b = malloc((size_t)len + 1);
	if (b && fread(b, 1, (size_t)len, f) != (size_t)len) {
		free(b);
		b = NULL;
	}
	fclose(f);
	if (b) {
		b[len] = 0;
		*n = (size_t)len;
	}
	return b;
}

static void files_parse_back(void)
{
	struct bc_tree *t = one_sphere(0.7f);
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	char dir[] = "/tmp/bc_mesh_XXXXXX", path[64];
	size_t n = 0;
	uint8_t *b;
	REQUIRE(t && mkdtemp(dir));
	REQUIRE(bc_mesh_build(&m, t, &(struct bc_mesh_opts){.resolution = 20},
	                      &ei) == 0);
	CHECK_EQ_INT(bc_mesh_format_of("a.OBJ"), BC_MESH_FORMAT_OBJ);
	CHECK_EQ_INT(bc_mesh_format_of("a.ply"), BC_MESH_FORMAT_PLY);
	CHECK_EQ_INT(bc_mesh_format_of("a.stl"), BC_MESH_FORMAT_STL);
	CHECK_EQ_INT(bc_mesh_format_of("a.glb"), BC_MESH_FORMAT_GLB);
	CHECK_EQ_INT(bc_mesh_format_of("a.gltf"), BC_MESH_FORMAT_INVALID);
	CHECK_EQ_INT(bc_mesh_format_of("obj"), BC_MESH_FORMAT_INVALID);

	/* OBJ: v lines then f lines, 1-based indices. */
	snprintf(path, sizeof(path), "%s/m.obj", dir);
	REQUIRE(bc_mesh_write(&m, path, BC_MESH_FORMAT_OBJ, &ei) == 0);
	REQUIRE((b = slurp(path, &n)));
	{
		uint32_t nv = 0, nf = 0, badf = 0, badv = 0;
		char *save = NULL;
		for (char *line = strtok_r((char *)b, "\n", &save); line;
		     line = strtok_r(NULL, "\n", &save)) {
			float x, y, z, r, g, bl;
			unsigned i, j, k;
			if (line[0] == 'v') {
				badv += sscanf(line, "v %f %f %f %f %f %f", &x,
				               &y, &z, &r, &g, &bl) != 6 ||
				        fabsf(x - m.pos[nv][0]) > 1e-6f;
				nv++;
			} else if (line[0] == 'f') {
				badf += sscanf(line, "f %u %u %u", &i, &j,
				               &k) != 3 ||
				        i != m.tri[nf][0] + 1 ||
				        k != m.tri[nf][2] + 1;
				nf++;
			}
		}
		CHECK_EQ_INT(nv, m.nverts);
		CHECK_EQ_INT(nf, m.ntris);
		CHECK_EQ_INT(badv, 0);
		CHECK_EQ_INT(badf, 0);
	}
	free(b);
	unlink(path);

	/* PLY: the header's counts, then the binary records. */
	snprintf(path, sizeof(path), "%s/m.ply", dir);
	REQUIRE(bc_mesh_write(&m, path, BC_MESH_FORMAT_PLY, &ei) == 0);
	REQUIRE((b = slurp(path, &n)));
	{
		unsigned nv = 0, nf = 0;
		const char *end = strstr((const char *)b, "end_header\n");
		REQUIRE(end);
		CHECK(strncmp((const char *)b,
		              "ply\nformat binary_little_endian 1.0\n",
		              36) == 0);
		CHECK(sscanf(strstr((const char *)b, "element vertex"),
		             "element vertex %u", &nv) == 1);
		CHECK(sscanf(strstr((const char *)b, "element face"),
		             "element face %u", &nf) == 1);
		CHECK_EQ_INT(nv, m.nverts);
		CHECK_EQ_INT(nf, m.ntris);
		{
			const uint8_t *p = (const uint8_t *)end + 11;
			size_t body = n - (size_t)(p - b);
			CHECK_EQ_INT(body, (size_t)nv * 15 + (size_t)nf * 13);
			CHECK(rd_f32(p + 15 * (nv - 1) + 4) ==
			      m.pos[nv - 1][1]);
			p += 15 * (size_t)nv;
			CHECK(p[13 * (nf - 1)] == 3);
			CHECK(rd_u32(p + 13 * (nf - 1) + 5) ==
			      m.tri[nf - 1][1]);
		}
	}
	free(b);
	unlink(path);

	/* STL: 80-byte header, count, 50 bytes a facet, normals outward. */
	snprintf(path, sizeof(path), "%s/m.stl", dir);
	REQUIRE(bc_mesh_write(&m, path, BC_MESH_FORMAT_STL, &ei) == 0);
	REQUIRE((b = slurp(path, &n)));
	CHECK_EQ_INT(n, 84 + 50 * (size_t)m.ntris);
	CHECK_EQ_INT(rd_u32(b + 80), m.ntris);
	{
		uint32_t inward = 0;
		for (uint32_t i = 0; i < m.ntris; i++) {
			const uint8_t *f = b + 84 + 50 * (size_t)i;
			float d = 0.0f;
			for (int a = 0; a < 3; a++) {
				/* The sphere's centre is (0.1, 0, 0). */
				float c =
				    rd_f32(f + 12 + 4 * a) - (a ? 0.0f : 0.1f);
				d += rd_f32(f + 4 * a) * c;
			}
			inward += d <= 0.0f;
		}
		CHECK_EQ_INT(inward, 0);
	}
	free(b);
	unlink(path);
	CHECK(bc_mesh_write(&m, "/nonexistent-dir/x.stl", BC_MESH_FORMAT_STL,
	                    &ei) == BC_EIO);
	CHECK(strstr(ei.msg, "nonexistent") != NULL);
	rmdir(dir);
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
}

static void bad_arguments_are_refused(void)
{
	struct bc_tree *t = one_sphere(1.0f), *e = bc_tree_create();
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	REQUIRE(t && e);
	CHECK(bc_mesh_build(&m, e, NULL, &ei) == BC_EINVAL);
	CHECK(bc_mesh_build(&m, t,
	                    &(struct bc_mesh_opts){
	                        .resolution = BC_MESH_MAX_RESOLUTION + 1},
	                    &ei) == BC_ERANGE);
	CHECK(bc_mesh_build(
	          &m, t,
	          &(struct bc_mesh_opts){.lo = {0, 0, 0}, .hi = {1, 0, 1}},
	          &ei) == BC_EINVAL);
	/* A box cutting the sphere: the mesh is closed by its face. */
	REQUIRE(bc_mesh_build(&m, t,
	                      &(struct bc_mesh_opts){.resolution = 40,
	                                             .lo = {-1, -1, -1},
	                                             .hi = {1.2f, 1, 0.3f}},
	                      &ei) == 0);
	{
		struct topo tp;
		topology(&m, &tp);
		CHECK(m.ntris > 0);
		CHECK_EQ_INT(tp.open, 0);
		CHECK_EQ_INT(tp.shared, 0);
	}
	bc_mesh_finish(&m);
	bc_mesh_finish(NULL);
	bc_tree_destroy(t);
	bc_tree_destroy(e);
}

/* bc_mesh_write_mem: the bytes bc_mesh_write puts in the file, in every
 * format, after head bytes left for the caller; and a mesh of tens of
 * thousands of triangles, so that the memory stream grows many times. */
static void memory_files_are_the_files(void)
{
	struct bc_tree *t = one_sphere(0.7f);
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	char dir[] = "/tmp/bc_mesh_XXXXXX", path[64];
	REQUIRE(t && mkdtemp(dir));
	REQUIRE(bc_mesh_build(&m, t, &(struct bc_mesh_opts){.resolution = 120},
	                      &ei) == 0);
	CHECK(m.ntris > 20000);
	for (int f = BC_MESH_FORMAT_OBJ; f < BC_MESH_FORMAT_COUNT; f++) {
		uint8_t *mem = NULL, *file;
		size_t len = 0, n = 0;
		snprintf(path, sizeof(path), "%s/m", dir);
		REQUIRE(bc_mesh_write(&m, path, (enum bc_mesh_format)f, &ei) ==
		        0);
		REQUIRE((file = slurp(path, &n)));
		REQUIRE(bc_mesh_write_mem(&m, (enum bc_mesh_format)f, 7, &mem,
		                          &len, &ei) == 0);
		CHECK_EQ_INT(len, n + 7);
		CHECK(len == n + 7 && memcmp(mem + 7, file, n) == 0);
		free(file);
		bc_free(mem);
		unlink(path);
	}
	CHECK(bc_mesh_write_mem(&m, BC_MESH_FORMAT_INVALID, 0,
	                        &(uint8_t *){NULL}, &(size_t){0},
	                        &ei) == BC_EINVAL);
	rmdir(dir);
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
}

/* A scene's own box needs 5 cells along its longest side (two of
 * margin each way); a given box does not. */
static void a_scene_box_needs_five_cells(void)
{
	struct bc_tree *t = one_sphere(1.0f);
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	CHECK(bc_mesh_build(&m, t, &(struct bc_mesh_opts){.resolution = 4},
	                    &ei) == BC_ERANGE);
	CHECK(strstr(ei.msg, "5 or more") != NULL);
	REQUIRE(bc_mesh_build(&m, t, &(struct bc_mesh_opts){.resolution = 5},
	                      &ei) == 0);
	/* One cell of scene (its 2-wide box) inside the margins. */
	CHECK(m.cell >= 2.0f && m.cell < 2.5f);
	bc_mesh_finish(&m);
	REQUIRE(bc_mesh_build(&m, t,
	                      &(struct bc_mesh_opts){.resolution = 2,
	                                             .lo = {-2, -2, -2},
	                                             .hi = {2, 2, 2}},
	                      &ei) == 0);
	CHECK(m.cell == 2.0f);
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
}

/* What stop_at sees: the last progress, and the fraction it stops at. */
struct stopper {
	double last, at;
};

static void note_progress(void *ctx, double done)
{
	((struct stopper *)ctx)->last = done;
}

static bool stop_at(void *ctx)
{
	const struct stopper *s = ctx;
	return s->last >= s->at;
}

/* opts->stop: asked in the grid's regions and between the collapse's
 * passes; true ends the build with BC_ECLOSED and an empty mesh. */
static void a_stop_ends_the_build(void)
{
	struct bc_tree *t = one_sphere(0.7f);
	struct bc_mesh m;
	struct bc_errinfo ei = {0};
	/* In the grid (its share of the progress is 0.6), at once. */
	struct stopper grid = {0.0, 0.0};
	/* After the grid: in the collapse, after its first pass. */
	struct stopper collapse = {0.0, 0.61};
	struct bc_mesh_opts o = {
	    .resolution = 64, .progress = note_progress, .stop = stop_at};
	REQUIRE(t);
	o.ctx = &grid;
	CHECK(bc_mesh_build(&m, t, &o, &ei) == BC_ECLOSED);
	CHECK_EQ_INT(m.ntris, 0);
	CHECK(grid.last < 0.6);
	o.ctx = &collapse;
	CHECK(bc_mesh_build(&m, t, &o, &ei) == BC_ECLOSED);
	CHECK_EQ_INT(m.ntris, 0);
	CHECK(collapse.last > 0.6 && collapse.last < 1.0);
	/* Never stopped: the whole mesh. */
	collapse = (struct stopper){0.0, 2.0};
	REQUIRE(bc_mesh_build(&m, t, &o, &ei) == 0);
	CHECK(m.ntris > 0);
	CHECK(collapse.last == 1.0);
	bc_mesh_finish(&m);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"memory_files_are_the_files", memory_files_are_the_files},
    {"a_scene_box_needs_five_cells", a_scene_box_needs_five_cells},
    {"a_stop_ends_the_build", a_stop_ends_the_build},
    {"sphere_is_a_closed_genus_0_manifold",
     sphere_is_a_closed_genus_0_manifold},
    {"scenes_mesh_closed_near_the_surface",
     scenes_mesh_closed_near_the_surface},
    {"files_parse_back", files_parse_back},
    {"bad_arguments_are_refused", bad_arguments_are_refused},
};

BC_TEST_MAIN(tests)
