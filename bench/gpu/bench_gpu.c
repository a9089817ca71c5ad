/*
 * The GPU run's driver: every measurement and check that bench/gpu/run.sh
 * makes on a GPU host (or on llvmpipe here, with small sizes), one
 * subcommand per step. Each step writes a JSON object (--json FILE) and a
 * Markdown section (--md FILE) that run.sh assembles into results.json and
 * results.md, prints what it does to stdout and what it could not do to
 * stderr, and exits non-zero when anything failed — after doing the rest.
 *
 *   refs    (packing, here) generates the correctness scenes, saves them as
 *           JSON and renders each with the CPU tiled renderer: depth and
 *           ids into NAME.ref (gzip; the hit mask is depth < inf).
 *   info    creates a gl renderer on the asked platform and reports what
 *           it got (GL_RENDERER, version, platform, limits).
 *   check   renders every NAME.json of a folder with gl and compares with
 *           NAME.ref as tests/gl compares with the tiled renderer.
 *   table2  Zanni 2024 Table 2: fig18 boxes/spheres (and the intersected
 *           spheres, "lenses"), sharp and smooth, and fig16 L1..L6, per
 *           frame median ms after warm-up with the A-buffer / tracing
 *           split of the paper's Fig. 20 (GPU timer queries).
 *   edit    a parameter edit on the GPU: bytes uploaded, sync ms, the
 *           damaged region re-rendered (ms, tiles) against a whole frame,
 *           and the region-assembled frame compared with a whole render.
 *   daemon  edit -> frame through blobcastd --backend gl, JPEG, p50/p99,
 *           at each asked view size (bench/latency.h's measurement).
 *   verify  reads results.json: every step ran and succeeded, every scene
 *           correct, at least N scenes.
 *
 * Usage: bench_gpu COMMAND [options]; bench_gpu --help lists them.
 */
#include <dirent.h>
#include <stdarg.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <jansson.h>
#include <zlib.h>

#include "../../tests/server/daemon.h"
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/log.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "blobcast/render_gl.h"
#include "blobcast/scene.h"
#include "latency.h"

#define REF_MAGIC 0x31464552u /* "REF1" little-endian */
#define MAX_LIST 32

/* ---- Options and output ---------------------------------------------- */

struct opts {
	const char *platform; /* gl platform name, NULL: auto */
	const char *json, *md;
	const char *dir;        /* refs: output; check: scenes and refs */
	const char *blobcastd;  /* daemon */
	uint32_t size;          /* frame edge */
	int reps, warmup, edits;
	double budget_s;        /* table2: start no scene after this */
	uint32_t counts[MAX_LIST], ncounts;      /* fig18 counts */
	uint32_t lens_counts[MAX_LIST], nlens;   /* fig18 lenses counts */
	uint32_t levels[MAX_LIST], nlevels;      /* fig16 levels */
	uint32_t sizes[MAX_LIST][2], nsizes;     /* daemon view sizes */
	int min_scenes;
	bool expect_hardware;
	const char *file; /* verify */
};

struct out {
	FILE *json, *md;
	char json_tmp[4200];
	const char *json_path;
	int failures;
};

static double now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static void jstr(FILE *f, const char *s)
{
	fputc('"', f);
	for (; s && *s; s++) {
		unsigned char c = (unsigned char)*s;
		if (c == '"' || c == '\\') {
			fprintf(f, "\\%c", c);
		} else if (c < 0x20 || c >= 0x7f) {
			fprintf(f, "\\u%04x", c);
		} else {
			fputc(c, f);
		}
	}
	fputc('"', f);
}

/* A number, or null when it is not finite (JSON has no inf or NaN). */
static void jnum(FILE *f, double v)
{
	if (isfinite(v)) {
		fprintf(f, "%.4f", v);
	} else {
		fputs("null", f);
	}
}

/* Opens the step's outputs: JSON into a temporary file renamed into place
 * at the end (a crash leaves none rather than half an object), Markdown
 * appended as it goes. */
static int out_open(struct out *o, const struct opts *op)
{
	memset(o, 0, sizeof(*o));
	o->json_path = op->json;
	if (op->json) {
		snprintf(o->json_tmp, sizeof(o->json_tmp), "%s.tmp", op->json);
		o->json = fopen(o->json_tmp, "w");
	} else {
		o->json = fopen("/dev/null", "w");
	}
	o->md = fopen(op->md ? op->md : "/dev/null", "w");
	if (!o->json || !o->md) {
		fprintf(stderr, "bench_gpu: cannot write %s / %s\n",
			op->json ? op->json : "-", op->md ? op->md : "-");
		return -1;
	}
	return 0;
}

static int out_close(struct out *o)
{
	int rc = o->failures ? 1 : 0;
	if (o->json) {
		if (fclose(o->json) != 0) {
			rc = 1;
		} else if (o->json_path &&
			   rename(o->json_tmp, o->json_path) != 0) {
			fprintf(stderr, "bench_gpu: cannot write %s\n",
				o->json_path);
			rc = 1;
		}
	}
	if (o->md && fclose(o->md) != 0) {
		rc = 1;
	}
	return rc;
}

/* Reports a failure: stderr now, the step's "errors" at the end. */
#define MAX_ERRORS 64
static char errors[MAX_ERRORS][300];
static int nerrors;

static void fail(struct out *o, const char *fmt, ...) BC__PRINTF(2, 3);
static void fail(struct out *o, const char *fmt, ...)
{
	va_list ap;
	char msg[300];
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	fprintf(stderr, "bench_gpu: %s\n", msg);
	if (nerrors < MAX_ERRORS) {
		memcpy(errors[nerrors++], msg, sizeof(msg));
	}
	o->failures++;
}

static void json_errors(FILE *f)
{
	fputs(",\"errors\":[", f);
	for (int i = 0; i < nerrors; i++) {
		if (i) {
			fputc(',', f);
		}
		jstr(f, errors[i]);
	}
	fputc(']', f);
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

static int cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;
	return (x > y) - (x < y);
}

static double median(double *v, int n)
{
	if (n <= 0) {
		return NAN;
	}
	qsort(v, (size_t)n, sizeof(*v), cmp_double);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static bool is_software(const struct bc_gl_info *info)
{
	return info->software_device || strstr(info->renderer, "llvmpipe") ||
	       strstr(info->renderer, "softpipe") ||
	       info->platform == BC_GL_PLATFORM_SURFACELESS ||
	       info->platform == BC_GL_PLATFORM_OSMESA;
}

/* A gl renderer on op's platform, its info in *info; NULL (reported) when
 * none can be created, or when op asks for hardware and it is software. */
static struct bc_renderer *open_gl(const struct opts *op, struct out *o,
				   struct bc_gl_info *info)
{
	struct bc_render_opts ro = {.gl_platform = op->platform};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, BC_BACKEND_GL, &ro, &ei)) {
		fail(o, "gl renderer (platform %s): %s",
		     op->platform ? op->platform : "auto", ei.msg);
		return NULL;
	}
	bc_render_gl_info(r, info);
	printf("gl: %s platform%s, GL_RENDERER %s, GL_VERSION %s\n",
	       bc_gl_platform_name(info->platform),
	       info->software_device ? " (software device)" : "",
	       info->renderer, info->version);
	/* On a GPU host a software context would spend the run's minutes
	 * measuring the wrong thing: refuse it. */
	if (op->expect_hardware && is_software(info)) {
		fail(o,
		     "a GPU was expected, the context is %s on the %s "
		     "platform%s",
		     info->renderer, bc_gl_platform_name(info->platform),
		     info->software_device ? " (software device)" : "");
		bc_renderer_destroy(r);
		return NULL;
	}
	return r;
}

/* ---- Correctness scenes and references -------------------------------- */

struct ref_scene {
	const char *name;
	const char *gen; /* NULL: the built-in default scene */
	struct bc_gen_opts o;
};

static const struct ref_scene ref_scenes[] = {
    {"default", NULL, {0}},
    {"fig18-boxes-64-sharp", "fig18",
     {.count = 64, .kind = BC_GEN_KIND_BOXES, .blend = BC_GEN_BLEND_SHARP}},
    {"fig18-boxes-256-smooth", "fig18",
     {.count = 256, .kind = BC_GEN_KIND_BOXES, .blend = BC_GEN_BLEND_SMOOTH}},
    {"fig18-spheres-256-smooth", "fig18",
     {.count = 256,
      .kind = BC_GEN_KIND_SPHERES,
      .blend = BC_GEN_BLEND_SMOOTH}},
    {"fig18-spheres-1024-sharp", "fig18",
     {.count = 1024,
      .kind = BC_GEN_KIND_SPHERES,
      .blend = BC_GEN_BLEND_SHARP}},
    {"fig18-lenses-96-smooth", "fig18",
     {.count = 96, .kind = BC_GEN_KIND_LENSES, .blend = BC_GEN_BLEND_SMOOTH}},
    {"fig16-L2-smooth", "fig16", {.level = 2, .blend = BC_GEN_BLEND_SMOOTH}},
    {"fig16-L3-sharp", "fig16", {.level = 3, .blend = BC_GEN_BLEND_SHARP}},
    {"comb-64-smooth", "comb", {.count = 64, .blend = BC_GEN_BLEND_SMOOTH}},
    /* Every primitive kind under every operator kind (most seeds
     * intersect away to nothing: these two do not). */
    {"random-50-seed0", "random", {.count = 50, .seed = 0}},
    {"random-50-seed4", "random", {.count = 50, .seed = 4}},
    {"gears-24", "gears", {.teeth = 24}},
    {"many-gears-16", "many-gears", {.count = 16}},
    {"many-spheres-500", "many-spheres", {.count = 500, .seed = 3}},
};

/* A reference: header (magic, width, height, scene size as float bits,
 * hits) then depth (float) and ids (uint32), row 0 on top, gzip'd. */
static int ref_write(const char *path, const struct bc_frame *f, float size,
		     uint32_t hits)
{
	gzFile g = gzopen(path, "wb6");
	uint32_t hdr[5] = {REF_MAGIC, f->width, f->height, 0, hits};
	size_t n = (size_t)f->width * f->height;
	int ok;
	if (!g) {
		return -1;
	}
	memcpy(&hdr[3], &size, sizeof(size));
	ok = gzwrite(g, hdr, sizeof(hdr)) == (int)sizeof(hdr) &&
	     gzwrite(g, f->depth, (unsigned)(n * 4)) == (int)(n * 4) &&
	     gzwrite(g, f->ids, (unsigned)(n * 4)) == (int)(n * 4);
	return gzclose(g) == Z_OK && ok ? 0 : -1;
}

/* Reads path into *f (initialized here at the stored size). */
static int ref_read(const char *path, struct bc_frame *f, float *size,
		    uint32_t *hits)
{
	gzFile g = gzopen(path, "rb");
	uint32_t hdr[5];
	size_t n;
	int ok = 0;
	memset(f, 0, sizeof(*f));
	if (!g) {
		return -1;
	}
	if (gzread(g, hdr, sizeof(hdr)) == (int)sizeof(hdr) &&
	    hdr[0] == REF_MAGIC && hdr[1] > 0 && hdr[2] > 0 &&
	    hdr[1] <= 4096 && hdr[2] <= 4096 &&
	    bc_frame_init(f, hdr[1], hdr[2]) == 0) {
		n = (size_t)hdr[1] * hdr[2];
		memcpy(size, &hdr[3], sizeof(*size));
		*hits = hdr[4];
		ok = gzread(g, f->depth, (unsigned)(n * 4)) == (int)(n * 4) &&
		     gzread(g, f->ids, (unsigned)(n * 4)) == (int)(n * 4);
	}
	gzclose(g);
	if (!ok) {
		bc_frame_finish(f);
		return -1;
	}
	return 0;
}

static int cmd_refs(const struct opts *op)
{
	struct out o;
	size_t n = sizeof(ref_scenes) / sizeof(ref_scenes[0]);
	struct bc_frame f = {0};
	if (!op->dir) {
		fprintf(stderr, "bench_gpu refs: --dir DIR is required\n");
		return 2;
	}
	if (out_open(&o, op) || bc_frame_init(&f, op->size, op->size)) {
		return 1;
	}
	fputs("{\"scenes\":[", o.json);
	for (size_t i = 0; i < n; i++) {
		const struct ref_scene *s = &ref_scenes[i];
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct bc_render_stats st;
		char path[4096];
		uint32_t hits = 0;
		int rc;
		if (!t) {
			fail(&o, "%s: out of memory", s->name);
			continue;
		}
		bc_camera_default(&cam);
		if (s->gen) {
			rc = bc_gen(s->gen, &s->o, t, &cam, &ei);
		} else {
			const char *txt = bc_scene_default_json();
			rc = bc_scene_parse_json(txt, strlen(txt), t, &cam, &ei);
		}
		snprintf(path, sizeof(path), "%s/%s.json", op->dir, s->name);
		if (rc == 0) {
			rc = bc_scene_save_json(path, t, &cam, &ei);
		}
		if (rc == 0) {
			rc = bc_render_once(BC_BACKEND_TILED, NULL, t, &cam, &f,
					    &st, &ei);
		}
		if (rc) {
			fail(&o, "%s: %s", s->name, ei.msg);
			bc_tree_destroy(t);
			continue;
		}
		for (size_t p = 0; p < (size_t)f.width * f.height; p++) {
			hits += isfinite(f.depth[p]) ? 1u : 0u;
		}
		/* A reference with (almost) nothing in view proves nothing. */
		if (hits * 100 < f.width * f.height) {
			fail(&o, "%s: only %u of %u pixels hit", s->name, hits,
			     f.width * f.height);
		}
		snprintf(path, sizeof(path), "%s/%s.ref", op->dir, s->name);
		if (ref_write(path, &f, bc_tree_lin(t)->size, hits)) {
			fail(&o, "%s: cannot write %s", s->name, path);
		}
		printf("ref %-26s %7u prims, %ux%u, %u hits, tiled %.1f ms\n",
		       s->name, bc_tree_prim_count(t), f.width, f.height, hits,
		       st.ms_total);
		fprintf(o.json, "%s{\"name\":", i ? "," : "");
		jstr(o.json, s->name);
		fprintf(o.json, ",\"prims\":%u,\"hits\":%u}",
			bc_tree_prim_count(t), hits);
		bc_tree_destroy(t);
	}
	fputc(']', o.json);
	json_errors(o.json);
	fputs("}\n", o.json);
	bc_frame_finish(&f);
	return out_close(&o);
}

/* ---- info --------------------------------------------------------------- */

static int cmd_info(const struct opts *op)
{
	struct out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	if (out_open(&o, op)) {
		return 1;
	}
	{
		/* The context is reported whatever it is; then judged. */
		struct opts any = *op;
		any.expect_hardware = false;
		r = open_gl(&any, &o, &info);
	}
	if (r && op->expect_hardware && is_software(&info)) {
		fail(&o,
		     "a GPU was expected, the context is %s on the %s "
		     "platform%s",
		     info.renderer, bc_gl_platform_name(info.platform),
		     info.software_device ? " (software device)" : "");
	}
	fprintf(o.json, "{\"ok\":%s", r ? "true" : "false");
	if (r) {
		fputs(",\"platform\":", o.json);
		jstr(o.json, bc_gl_platform_name(info.platform));
		fprintf(o.json, ",\"software\":%s,\"renderer\":",
			is_software(&info) ? "true" : "false");
		jstr(o.json, info.renderer);
		fputs(",\"version\":", o.json);
		jstr(o.json, info.version);
		fprintf(o.json,
			",\"context\":\"%d.%d\",\"robust_access\":%s,"
			"\"lose_on_reset\":%s,\"shared_bytes\":%u,"
			"\"loop_budget\":%u,\"program_builds\":%u",
			info.major, info.minor,
			info.robust_access ? "true" : "false",
			info.lose_on_reset ? "true" : "false",
			info.shared_bytes, info.loop_budget,
			info.program_builds);
		fprintf(o.md,
			"GL_RENDERER: `%s`; GL_VERSION: `%s`; %s platform%s; "
			"robust access %s; %u bytes of shared memory per "
			"workgroup.\n",
			info.renderer, info.version,
			bc_gl_platform_name(info.platform),
			info.software_device ? " (software device)" : "",
			info.robust_access ? "granted" : "not granted",
			info.shared_bytes);
		printf("GL_RENDERER: %s\n", info.renderer);
	}
	json_errors(o.json);
	fputs("}\n", o.json);
	bc_renderer_destroy(r);
	return out_close(&o);
}

/* ---- check -------------------------------------------------------------- */

struct agreement {
	uint32_t mask_diff, both, id_diff;
	float median_dz;
};

static void compare(const struct bc_frame *a, const struct bc_frame *b,
		    struct agreement *out)
{
	size_t n = (size_t)a->width * a->height;
	float *dz = bc_calloc(n ? n : 1, sizeof(*dz));
	memset(out, 0, sizeof(*out));
	for (size_t i = 0; i < n; i++) {
		bool ha = isfinite(a->depth[i]), hb = isfinite(b->depth[i]);
		if (ha != hb) {
			out->mask_diff++;
		} else if (ha) {
			if (dz) {
				dz[out->both] = fabsf(a->depth[i] - b->depth[i]);
			}
			out->both++;
			out->id_diff += a->ids[i] != b->ids[i];
		}
	}
	out->median_dz = INFINITY;
	if (dz && out->both) {
		qsort(dz, out->both, sizeof(*dz), cmp_float);
		out->median_dz = dz[out->both / 2];
	}
	bc_free(dz);
}

static int cmp_str(const void *a, const void *b)
{
	return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The NAME.json files of dir, sorted; *n of them. Caller frees. */
static char **list_scenes(const char *dir, size_t *n)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	char **v = NULL;
	size_t cap = 0;
	*n = 0;
	if (!d) {
		return NULL;
	}
	while ((e = readdir(d)) != NULL) {
		size_t len = strlen(e->d_name);
		if (len > 5 && strcmp(e->d_name + len - 5, ".json") == 0) {
			if (*n == cap) {
				char **nv;
				cap = cap ? 2 * cap : 16;
				nv = bc_realloc(v, cap * sizeof(*v));
				if (!nv) {
					break;
				}
				v = nv;
			}
			v[*n] = bc_calloc(len - 4, 1);
			if (v[*n]) {
				memcpy(v[*n], e->d_name, len - 5);
				(*n)++;
			}
		}
	}
	closedir(d);
	if (*n) {
		qsort(v, *n, sizeof(*v), cmp_str);
	}
	return v;
}

static int cmd_check(const struct opts *op)
{
	struct out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	size_t n = 0;
	char **names;
	int correct = 0, ran = 0;
	if (!op->dir) {
		fprintf(stderr, "bench_gpu check: --dir DIR is required\n");
		return 2;
	}
	if (out_open(&o, op)) {
		return 1;
	}
	names = list_scenes(op->dir, &n);
	if (n == 0) {
		fail(&o, "no NAME.json scenes in %s", op->dir);
	}
	r = open_gl(op, &o, &info);
	fputs("{\"scenes\":[", o.json);
	fprintf(o.md,
		"| scene | prims | size | hits | silhouette px | median "
		"\\|dz\\| (limit) | ids differ | gl ms | correct |\n"
		"|---|---:|---|---:|---:|---:|---:|---:|---|\n");
	for (size_t i = 0; i < n; i++) {
		char path[4096];
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct bc_frame ref = {0}, g = {0};
		struct bc_render_stats st = {0};
		struct agreement a = {0};
		float size = 0;
		uint32_t hits = 0;
		bool ok = false;
		const char *why = NULL;
		double ms = NAN;
		bc_camera_default(&cam);
		snprintf(path, sizeof(path), "%s/%s.json", op->dir, names[i]);
		if (!t || bc_scene_load_json(path, t, &cam, &ei)) {
			why = ei.msg[0] ? ei.msg : "out of memory";
		} else {
			snprintf(path, sizeof(path), "%s/%s.ref", op->dir,
				 names[i]);
			if (ref_read(path, &ref, &size, &hits)) {
				why = "missing or corrupt reference";
			} else if (!r) {
				why = "no gl renderer";
			} else if (bc_frame_init(&g, ref.width, ref.height) ||
				   bc_renderer_sync(r, t, NULL, &ei)) {
				why = ei.msg[0] ? ei.msg : "out of memory";
			} else {
				double t0 = now_ms();
				if (bc_renderer_render(r, &cam, &g, &st, &ei)) {
					why = ei.msg;
				}
				ms = now_ms() - t0;
			}
		}
		if (!why) {
			compare(&g, &ref, &a);
			/* tests/gl's criteria: silhouettes on < 0.5 % of
			 * pixels, median depth difference < 1e-3 of the
			 * scene's size, ids on >= 95 % of common hits, and
			 * the reference's hits seen. */
			ok = a.mask_diff * 200 < ref.width * ref.height &&
			     a.median_dz < 1e-3f * size &&
			     a.id_diff * 20 <= a.both && a.both > 0 &&
			     hits > 0 && !st.incomplete;
			if (!ok) {
				fail(&o,
				     "%s: differs from the tiled reference "
				     "(silhouette %u px, median dz %.3g, ids "
				     "%u/%u%s)",
				     names[i], a.mask_diff,
				     (double)a.median_dz, a.id_diff, a.both,
				     st.incomplete ? ", incomplete" : "");
			}
		} else {
			fail(&o, "%s: %s", names[i], why);
		}
		ran++;
		correct += ok;
		printf("check %-26s %s: silhouette %u px, median dz %.3g "
		       "(limit %.3g), ids %u/%u, %.1f ms\n",
		       names[i], ok ? "correct" : "WRONG", a.mask_diff,
		       (double)a.median_dz, 1e-3 * (double)size, a.id_diff,
		       a.both, ms);
		fprintf(o.json, "%s{\"name\":", i ? "," : "");
		jstr(o.json, names[i]);
		fprintf(o.json,
			",\"prims\":%u,\"width\":%u,\"height\":%u,"
			"\"ref_hits\":%u,\"silhouette_px\":%u,\"both\":%u,"
			"\"ids_differ\":%u,\"median_dz\":",
			t ? bc_tree_prim_count(t) : 0, ref.width, ref.height,
			hits, a.mask_diff, a.both, a.id_diff);
		jnum(o.json, (double)a.median_dz);
		fputs(",\"dz_limit\":", o.json);
		jnum(o.json, 1e-3 * (double)size);
		fputs(",\"ms\":", o.json);
		jnum(o.json, ms);
		fprintf(o.json, ",\"correct\":%s", ok ? "true" : "false");
		if (why) {
			fputs(",\"error\":", o.json);
			jstr(o.json, why);
		}
		fputc('}', o.json);
		fprintf(o.md,
			"| %s | %u | %ux%u | %u | %u | %.3g (%.3g) | %u/%u | "
			"%.1f | %s |\n",
			names[i], t ? bc_tree_prim_count(t) : 0, ref.width,
			ref.height, hits, a.mask_diff, (double)a.median_dz,
			1e-3 * (double)size, a.id_diff, a.both, ms,
			ok ? "yes" : "**no**");
		bc_frame_finish(&ref);
		bc_frame_finish(&g);
		bc_tree_destroy(t);
		bc_free(names[i]);
	}
	bc_free(names);
	if (ran < op->min_scenes) {
		fail(&o, "%d scenes checked, at least %d asked for", ran,
		     op->min_scenes);
	}
	fprintf(o.json, "],\"checked\":%d,\"correct\":%d", ran, correct);
	json_errors(o.json);
	fputs("}\n", o.json);
	fprintf(o.md, "\n%d of %d scenes correct.\n", correct, ran);
	bc_renderer_destroy(r);
	return out_close(&o);
}

/* ---- table2 ------------------------------------------------------------- */

/* The paper's RTX 4080 times at 1024x1024 (Zanni 2024, Table 2; ms): min
 * (sharp union) and the compact smooth union G_U; NAN where it has none.
 * n: fig18 primitives (a lens is two intersected spheres: the paper's
 * first value, the CSG form), fig16 level. */
struct paper_row {
	const char *gen;
	enum bc_gen_kind kind; /* fig18 */
	uint32_t n;            /* fig18 count, fig16 level */
	double sharp, smooth;
};

static const struct paper_row paper[] = {
    {"fig18", BC_GEN_KIND_BOXES, 16, 0.8, 6.0},
    {"fig18", BC_GEN_KIND_BOXES, 64, 1.2, 4.4},
    {"fig18", BC_GEN_KIND_BOXES, 256, 1.7, 6.9},
    {"fig18", BC_GEN_KIND_BOXES, 1024, 2.0, 12.4},
    {"fig18", BC_GEN_KIND_BOXES, 4096, 3.0, 23.0},
    {"fig18", BC_GEN_KIND_LENSES, 24, 4.6, 5.0},
    {"fig18", BC_GEN_KIND_LENSES, 96, 6.8, 11.6},
    {"fig18", BC_GEN_KIND_LENSES, 384, 10.4, 24.4},
    {"fig18", BC_GEN_KIND_LENSES, 1536, 15.4, 36.5},
    {"fig18", BC_GEN_KIND_LENSES, 6144, 34.0, 77.4},
    {"fig16", BC_GEN_KIND_DEFAULT, 1, 0.6, 1.7},
    {"fig16", BC_GEN_KIND_DEFAULT, 2, 0.9, 3.5},
    {"fig16", BC_GEN_KIND_DEFAULT, 3, 1.4, 5.6},
    {"fig16", BC_GEN_KIND_DEFAULT, 4, 2.4, 12.2},
    {"fig16", BC_GEN_KIND_DEFAULT, 5, 6.8, 61.1},
    {"fig16", BC_GEN_KIND_DEFAULT, 6, 85.3, 468.5},
};

static double paper_ms(const char *gen, enum bc_gen_kind kind, uint32_t n,
		       bool smooth)
{
	for (size_t i = 0; i < sizeof(paper) / sizeof(paper[0]); i++) {
		if (strcmp(paper[i].gen, gen) == 0 && paper[i].n == n &&
		    (strcmp(gen, "fig16") == 0 || paper[i].kind == kind)) {
			return smooth ? paper[i].smooth : paper[i].sharp;
		}
	}
	return NAN;
}

struct t2_scene {
	char label[64];
	const char *gen;
	struct bc_gen_opts o;
	uint32_t n;
};

static int table2_scene(struct bc_renderer *r, const struct opts *op,
			struct out *o, const struct t2_scene *s, bool first)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_frame f = {0};
	struct bc_gl_info info = {0};
	double *wall = bc_calloc((size_t)op->reps, sizeof(double));
	double *abuf = bc_calloc((size_t)op->reps, sizeof(double));
	double *trace = bc_calloc((size_t)op->reps, sizeof(double));
	double t0, gen_ms = NAN, sync_ms = NAN, mw = NAN, ma = NAN, mt = NAN;
	double best = NAN, pm;
	bool smooth = s->o.blend == BC_GEN_BLEND_SMOOTH;
	int frames = 0, warm = 0;
	const char *why = NULL;
	bool incomplete = false;
	t0 = now_ms();
	if (!t || !wall || !abuf || !trace ||
	    bc_frame_init(&f, op->size, op->size)) {
		why = "out of memory";
	} else if (bc_gen(s->gen, &s->o, t, &cam, &ei)) {
		why = ei.msg;
	} else {
		gen_ms = now_ms() - t0;
		t0 = now_ms();
		if (bc_renderer_sync(r, t, NULL, &ei)) {
			why = ei.msg;
		}
		sync_ms = now_ms() - t0;
	}
	/* Warm-up: buffer growth, caches, clocks. */
	for (; !why && warm < op->warmup; warm++) {
		struct bc_render_stats st;
		if (bc_renderer_render(r, &cam, &f, &st, &ei)) {
			why = ei.msg;
		}
	}
	for (double s0 = now_ms(); !why && frames < op->reps; frames++) {
		struct bc_render_stats st;
		double w0 = now_ms();
		/* Slow scenes (fig16 L6 on a small GPU) keep the step within
		 * its time: at least 5 frames, then at most ~20 s. */
		if (frames >= 5 && w0 - s0 > 20000.0) {
			fail(o, "%s: %d of %d frames (over 20 s)", s->label,
			     frames, op->reps);
			break;
		}
		if (bc_renderer_render(r, &cam, &f, &st, &ei)) {
			why = ei.msg;
			break;
		}
		wall[frames] = now_ms() - w0;
		abuf[frames] = st.ms_abuffer;
		trace[frames] = st.ms_trace;
		incomplete |= st.incomplete;
	}
	if (frames > 0) {
		best = wall[0];
		for (int i = 1; i < frames; i++) {
			best = fmin(best, wall[i]);
		}
		mw = median(wall, frames);
		ma = median(abuf, frames);
		mt = median(trace, frames);
		bc_render_gl_info(r, &info);
	}
	if (why) {
		fail(o, "%s: %s", s->label, why);
	}
	pm = paper_ms(s->gen, s->o.kind, s->n, smooth);
	printf("table2 %-28s %8u prims: median %8.2f ms (abuf %7.2f, trace "
	       "%7.2f) of %d frames; paper ",
	       s->label, t ? bc_tree_prim_count(t) : 0, mw, ma, mt, frames);
	if (isnan(pm)) {
		printf("-\n");
	} else {
		printf("%.1f ms\n", pm);
	}
	fprintf(o->json, "%s{\"scene\":", first ? "" : ",");
	jstr(o->json, s->label);
	fputs(",\"gen\":", o->json);
	jstr(o->json, s->gen);
	fprintf(o->json, ",\"n\":%u,\"blend\":\"%s\",\"prims\":%u,", s->n,
		smooth ? "smooth" : "sharp", t ? bc_tree_prim_count(t) : 0);
	fprintf(o->json, "\"frames\":%d,\"warmup\":%d,\"median_ms\":", frames,
		warm);
	jnum(o->json, mw);
	fputs(",\"min_ms\":", o->json);
	jnum(o->json, best);
	fputs(",\"abuffer_ms\":", o->json);
	jnum(o->json, ma);
	fputs(",\"trace_ms\":", o->json);
	jnum(o->json, mt);
	fputs(",\"gen_ms\":", o->json);
	jnum(o->json, gen_ms);
	fputs(",\"sync_ms\":", o->json);
	jnum(o->json, sync_ms);
	fputs(",\"paper_ms\":", o->json);
	jnum(o->json, pm);
	fprintf(o->json,
		",\"fragments\":%u,\"dispatches\":%u,\"over_m\":%u,"
		"\"incomplete\":%s",
		info.fragments, info.dispatches, info.over_m,
		incomplete ? "true" : "false");
	if (why) {
		fputs(",\"error\":", o->json);
		jstr(o->json, why);
	}
	fputc('}', o->json);
	if (frames > 0) {
		double share = ma + mt > 0 ? 100.0 * ma / (ma + mt) : NAN;
		fprintf(o->md,
			"| %s | %u | %.2f | %.2f | %.2f | %.0f %% | %.2f | ",
			s->label, bc_tree_prim_count(t), mw, ma, mt, share,
			sync_ms);
		if (isnan(pm)) {
			fputs("– | – |\n", o->md);
		} else {
			fprintf(o->md, "%.1f | %.2f× |\n", pm, mw / pm);
		}
	} else {
		fprintf(o->md, "| %s | %u | failed: %s | | | | | | |\n",
			s->label, t ? bc_tree_prim_count(t) : 0,
			why ? why : "no frame");
	}
	bc_free(wall);
	bc_free(abuf);
	bc_free(trace);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
	return why ? -1 : 0;
}

static int cmd_table2(const struct opts *op)
{
	static const enum bc_gen_kind kinds[] = {BC_GEN_KIND_BOXES,
						 BC_GEN_KIND_SPHERES};
	static const char *const kind_names[] = {"boxes", "spheres"};
	static const enum bc_gen_blend blends[] = {BC_GEN_BLEND_SHARP,
						   BC_GEN_BLEND_SMOOTH};
	struct t2_scene *list;
	size_t n = 0, cap;
	struct out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	double start = now_ms();
	int skipped = 0;
	cap = 2 * (2 * op->ncounts + op->nlens + op->nlevels) + 1;
	list = bc_calloc(cap, sizeof(*list));
	if (!list || out_open(&o, op)) {
		bc_free(list);
		return 1;
	}
	for (int b = 0; b < 2; b++) {
		const char *bn = b ? "smooth" : "sharp";
		for (int k = 0; k < 2; k++) {
			for (uint32_t c = 0; c < op->ncounts; c++) {
				struct t2_scene *s = &list[n++];
				snprintf(s->label, sizeof(s->label),
					 "fig18 %s %s %u", kind_names[k], bn,
					 op->counts[c]);
				s->gen = "fig18";
				s->o.kind = kinds[k];
				s->o.blend = blends[b];
				s->o.count = op->counts[c];
				s->n = op->counts[c];
			}
		}
		for (uint32_t c = 0; c < op->nlens; c++) {
			struct t2_scene *s = &list[n++];
			snprintf(s->label, sizeof(s->label),
				 "fig18 lenses %s %u", bn, op->lens_counts[c]);
			s->gen = "fig18";
			s->o.kind = BC_GEN_KIND_LENSES;
			s->o.blend = blends[b];
			s->o.count = op->lens_counts[c];
			/* The paper counts the spheres. */
			s->n = 2 * op->lens_counts[c];
		}
		for (uint32_t c = 0; c < op->nlevels; c++) {
			struct t2_scene *s = &list[n++];
			snprintf(s->label, sizeof(s->label), "fig16 L%u %s",
				 op->levels[c], bn);
			s->gen = "fig16";
			s->o.level = op->levels[c];
			s->o.blend = blends[b];
			s->n = op->levels[c];
		}
	}
	r = open_gl(op, &o, &info);
	fprintf(o.json, "{\"size\":%u,\"reps\":%d,\"warmup\":%d,\"rows\":[",
		op->size, op->reps, op->warmup);
	fprintf(o.md,
		"%ux%u, median of %d frames after %d warm-up frames; "
		"A-buffer and tracing from GPU timer queries (medians); "
		"sync: tree upload after generation; paper: Zanni 2024 "
		"Table 2 (RTX 4080, 1024x1024).\n\n"
		"| scene | prims | ms | A-buffer | tracing | A-buffer share | "
		"sync ms | paper ms | ours / paper |\n"
		"|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
		op->size, op->size, op->reps, op->warmup);
	for (size_t i = 0; r && i < n; i++) {
		if (op->budget_s > 0 && now_ms() - start > op->budget_s * 1e3) {
			fail(&o, "%s: not run, the step's %.0f s are spent",
			     list[i].label, op->budget_s);
			skipped++;
			continue;
		}
		(void)table2_scene(r, op, &o, &list[i], i == 0);
	}
	fprintf(o.json, "],\"scenes\":%zu,\"skipped\":%d", n, skipped);
	json_errors(o.json);
	fputs("}\n", o.json);
	bc_renderer_destroy(r);
	bc_free(list);
	return out_close(&o);
}

/* ---- edit --------------------------------------------------------------- */

static int edit_scene(struct bc_renderer *r, const struct opts *op,
		      struct out *o, uint32_t count, bool first)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_gen_opts go = {.count = count,
				 .kind = BC_GEN_KIND_SPHERES,
				 .blend = BC_GEN_BLEND_SMOOTH};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_frame acc = {0}, whole = {0};
	struct bc_gl_info info = {0};
	struct bc_dirty dirty;
	uint32_t tw = bc_render_tiles_x(op->size),
		 th = bc_render_tiles_y(op->size);
	uint8_t *tiles = bc_calloc((size_t)tw * th, 1);
	int n = op->edits > 0 ? op->edits : 1, done = 0;
	double *sync_ms = bc_calloc((size_t)n, sizeof(double));
	double *region_ms = bc_calloc((size_t)n, sizeof(double));
	double *whole_ms = bc_calloc((size_t)n, sizeof(double));
	double *ntiles = bc_calloc((size_t)n, sizeof(double));
	double full_sync = NAN, bytes = 0;
	uint64_t full_bytes = 0;
	bool exact = false;
	const char *why = NULL;
	if (!t || !tiles || !sync_ms || !region_ms || !whole_ms || !ntiles ||
	    bc_frame_init(&acc, op->size, op->size) ||
	    bc_frame_init(&whole, op->size, op->size)) {
		why = "out of memory";
	} else if (bc_gen("fig18", &go, t, &cam, &ei)) {
		why = ei.msg;
	} else {
		double t0 = now_ms();
		bc_tree_take_dirty(t, &dirty);
		if (bc_renderer_sync(r, t, NULL, &ei)) {
			why = ei.msg;
		}
		full_sync = now_ms() - t0;
		bc_render_gl_info(r, &info);
		full_bytes = info.upload_bytes;
		/* The frame the edits' regions are drawn over. */
		if (!why && bc_renderer_render(r, &cam, &acc, NULL, &ei)) {
			why = ei.msg;
		}
	}
	for (int i = 0; !why && i < n; i++) {
		const struct bc_lin *l = bc_tree_lin(t);
		uint32_t k = (uint32_t)(((uint64_t)i * 2654435761u) % l->nprims);
		uint32_t id = l->node_id[l->prim_slot[k]];
		struct bc_abv before = l->abv[k];
		struct bc_prim_data p;
		struct bc_render_region reg = {tiles, 0, false};
		double t0;
		uint32_t marked = 0;
		bc_tree_get(t, id, &p, NULL);
		p.translate[0] += 0.01f * (i % 2 ? -1.0f : 1.0f);
		t0 = now_ms();
		if (bc_tree_set_prim(t, id, &p, &ei)) {
			why = ei.msg;
			break;
		}
		bc_tree_take_dirty(t, &dirty);
		if (bc_renderer_sync(r, t, &dirty, &ei)) {
			why = ei.msg;
			break;
		}
		sync_ms[i] = now_ms() - t0;
		bc_render_gl_info(r, &info);
		bytes += (double)info.upload_bytes;
		memset(tiles, 0, (size_t)tw * th);
		bc_renderer_damage(r, &cam, op->size, op->size, &before, tiles);
		bc_renderer_damage(r, &cam, op->size, op->size,
				   &bc_tree_lin(t)->abv[k], tiles);
		for (size_t j = 0; j < (size_t)tw * th; j++) {
			marked += tiles[j] ? 1u : 0u;
		}
		ntiles[i] = marked;
		t0 = now_ms();
		if (bc_renderer_render_region(r, &cam, &acc, &reg, NULL, &ei)) {
			why = ei.msg;
			break;
		}
		region_ms[i] = now_ms() - t0;
		t0 = now_ms();
		if (bc_renderer_render(r, &cam, &whole, NULL, &ei)) {
			why = ei.msg;
			break;
		}
		whole_ms[i] = now_ms() - t0;
		done++;
	}
	if (!why && done > 0) {
		size_t px = (size_t)op->size * op->size;
		exact = memcmp(acc.rgba, whole.rgba, 4 * px) == 0 &&
			memcmp(acc.depth, whole.depth, 4 * px) == 0 &&
			memcmp(acc.ids, whole.ids, 4 * px) == 0;
		if (!exact) {
			fail(o,
			     "fig18 %u: the frame assembled from damaged "
			     "regions differs from a whole render",
			     count);
		}
		bytes /= done;
	}
	if (why) {
		fail(o, "edit fig18 %u: %s", count, why);
	}
	{
		double ms = median(sync_ms, done), rm = median(region_ms, done);
		double wm = median(whole_ms, done), tm = median(ntiles, done);
		printf("edit fig18 spheres smooth %7u: %d edits, %.0f bytes, "
		       "sync %.3f ms, region %.2f ms (%.0f tiles), whole %.2f "
		       "ms; full upload %llu bytes, %.2f ms; exact %s\n",
		       count, done, bytes, ms, rm, tm, wm,
		       (unsigned long long)full_bytes, full_sync,
		       exact ? "yes" : "no");
		fprintf(o->json, "%s{\"prims\":%u,\"edits\":%d,", first ? "" : ",",
			count, done);
		fputs("\"upload_bytes\":", o->json);
		jnum(o->json, bytes);
		fputs(",\"sync_ms\":", o->json);
		jnum(o->json, ms);
		fputs(",\"region_ms\":", o->json);
		jnum(o->json, rm);
		fputs(",\"region_tiles\":", o->json);
		jnum(o->json, tm);
		fputs(",\"whole_ms\":", o->json);
		jnum(o->json, wm);
		fprintf(o->json, ",\"full_upload_bytes\":%llu,\"full_sync_ms\":",
			(unsigned long long)full_bytes);
		jnum(o->json, full_sync);
		fprintf(o->json, ",\"exact\":%s", exact ? "true" : "false");
		if (why) {
			fputs(",\"error\":", o->json);
			jstr(o->json, why);
		}
		fputc('}', o->json);
		fprintf(o->md,
			"| %u | %d | %.0f | %.3f | %.2f (%.0f of %u tiles) | "
			"%.2f | %llu / %.2f | %s |\n",
			count, done, bytes, ms, rm, tm, tw * th, wm,
			(unsigned long long)full_bytes, full_sync,
			exact ? "yes" : "**no**");
	}
	bc_free(tiles);
	bc_free(sync_ms);
	bc_free(region_ms);
	bc_free(whole_ms);
	bc_free(ntiles);
	bc_frame_finish(&acc);
	bc_frame_finish(&whole);
	bc_tree_destroy(t);
	return why ? -1 : 0;
}

static int cmd_edit(const struct opts *op)
{
	struct out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	if (out_open(&o, op)) {
		return 1;
	}
	r = open_gl(op, &o, &info);
	fprintf(o.json, "{\"size\":%u,\"rows\":[", op->size);
	fprintf(o.md,
		"fig18 smooth spheres, %ux%u; one sphere moved per edit "
		"(medians): bytes sent to the GPU and sync ms; the damaged "
		"tiles re-rendered against a whole frame; the frame "
		"assembled from regions compared with a whole render.\n\n"
		"| prims | edits | bytes / edit | sync ms | region ms | whole "
		"ms | full upload bytes / ms | exact |\n"
		"|---:|---:|---:|---:|---:|---:|---:|---|\n",
		op->size, op->size);
	for (uint32_t c = 0; r && c < op->ncounts; c++) {
		(void)edit_scene(r, op, &o, op->counts[c], c == 0);
	}
	fputc(']', o.json);
	json_errors(o.json);
	fputs("}\n", o.json);
	bc_renderer_destroy(r);
	return out_close(&o);
}

/* ---- daemon ------------------------------------------------------------- */

static struct bc_prim_data original;

static void send_view(struct conn *c, uint32_t w, uint32_t h)
{
	struct bc_msg v = {.type = BC_MSG_VIEW};
	v.view.width = (uint16_t)w;
	v.view.height = (uint16_t)h;
	v.view.encoding = BC_PROTO_ENC_JPEG;
	v.view.quality_interactive = 70;
	v.view.quality_still = 90;
	v.view.downscale = 8;
	conn_send(c, &v);
}

/* Reads frames until the still of the current state. */
static int settle(struct conn *c, int timeout_ms)
{
	int64_t end = t_now_ms() + timeout_ms;
	while (t_now_ms() < end && conn_recv(c, 1000) >= 0) {
		if (c->m.type == BC_MSG_FRAME &&
		    (c->m.flags & BC_PROTO_FLAG_STILL)) {
			return 0;
		}
		if (c->m.type == BC_MSG_ERROR) {
			return -1;
		}
	}
	return -1;
}

/* Reads what the daemon still sends (refinements, the still frame) until
 * it has been quiet for quiet_ms, at most max_ms. */
static void drain(struct conn *c, int quiet_ms, int max_ms)
{
	int64_t end = t_now_ms() + max_ms;
	while (t_now_ms() < end && conn_recv(c, quiet_ms) == 1) {
	}
}

static void daemon_row(struct out *o, const char *mode, uint32_t w,
		       uint32_t h, const struct latency *l, int asked,
		       bool first)
{
	printf("daemon %ux%u %-5s: %d of %d edits, p50 %lld ms, p99 %lld ms, "
	       "max %lld ms, %.0f bytes per frame\n",
	       w, h, mode, l->n, asked, (long long)l->p50, (long long)l->p99,
	       (long long)l->max, l->bytes);
	fprintf(o->json,
		"%s{\"size\":\"%ux%u\",\"mode\":\"%s\",\"encoding\":\"jpeg\","
		"\"edits\":%d,\"frames\":%d,\"p50_ms\":%lld,\"p99_ms\":%lld,"
		"\"max_ms\":%lld,\"bytes_per_frame\":%.0f}",
		first ? "" : ",", w, h, mode, asked, l->n, (long long)l->p50,
		(long long)l->p99, (long long)l->max, l->bytes);
	fprintf(o->md, "| %ux%u | %s | %d / %d | %lld | %lld | %lld | %.0f |\n",
		w, h, mode, l->n, asked, (long long)l->p50, (long long)l->p99,
		(long long)l->max, l->bytes);
	if (l->n < asked) {
		fail(o, "%ux%u %s: %d of %d edits got their frame", w, h, mode,
		     l->n, asked);
	}
}

static int cmd_daemon(const struct opts *op)
{
	struct out o;
	struct daemon d = {0};
	struct conn c = {.fd = -1};
	uint32_t id = 0, count = op->ncounts ? op->counts[0] : 1024;
	char dir[64];
	const char *extra[5] = {"--backend", "gl", NULL, NULL, NULL};
	bool first = true, up = false;
	if (!op->blobcastd) {
		fprintf(stderr, "bench_gpu daemon: --blobcastd PATH is "
				"required\n");
		return 2;
	}
	if (out_open(&o, op)) {
		return 1;
	}
	if (op->platform) {
		extra[2] = "--gl-platform";
		extra[3] = op->platform;
	}
	daemon_path = op->blobcastd;
	signal(SIGPIPE, SIG_IGN);
	/* The daemon's log goes to our stderr (the step's log). */
	setenv("BLOBCAST_TEST_VERBOSE", "1", 1);
	snprintf(dir, sizeof(dir), "/tmp/bc-gpu-%d", (int)getpid());
	fprintf(o.json, "{\"scene\":\"fig18 smooth spheres %u\",\"rows\":[",
		count);
	fprintf(o.md,
		"blobcastd --backend gl, fig18 smooth spheres %u, JPEG; each "
		"edit moves one sphere and waits for the first FRAME that "
		"reflects it (bench/latency.h). still: plain edits; drag: "
		"INTERACTING edits. ms.\n\n"
		"| view | mode | frames / edits | p50 | p99 | max | bytes / "
		"frame |\n|---|---|---:|---:|---:|---:|---:|\n",
		count);
	if (daemon_start_with(&d, dir, extra) != 0) {
		fail(&o, "cannot start %s", op->blobcastd);
	} else if (conn_open(&c, &d) || conn_hello(&c, "bench_gpu") ||
		   conn_join(&c, "gpu", BC_PROTO_ROLE_EDITOR, true)) {
		fail(&o, "cannot join a session of %s", op->blobcastd);
	} else if (latency_load_fig18(&c, count, &id, &original, NULL)) {
		fail(&o, "loading fig18 %u into the daemon failed", count);
	} else {
		up = true;
	}
	for (uint32_t s = 0; up && s < op->nsizes; s++) {
		uint32_t w = op->sizes[s][0], h = op->sizes[s][1];
		static const float dx[2] = {-0.02f, 0.02f};
		float drag[25];
		struct latency l;
		for (int i = 0; i < 25; i++) {
			drag[i] = 0.004f * (float)i;
		}
		send_view(&c, w, h);
		if (settle(&c, 30000)) {
			fail(&o, "%ux%u: no still frame from the daemon in 30 s "
				 "(its log says why)", w, h);
			break;
		}
		/* Warm-up edits, not counted. */
		latency_edits(&c, id, &original, dx, 2, 3, false, &l);
		latency_edits(&c, id, &original, dx, 2, op->edits, false, &l);
		daemon_row(&o, "still", w, h, &l, op->edits, first);
		first = false;
		drain(&c, 500, 60000);
		latency_edits(&c, id, &original, drag, 25, op->edits, true, &l);
		daemon_row(&o, "drag", w, h, &l, op->edits, false);
		drain(&c, 500, 60000);
	}
	fputc(']', o.json);
	json_errors(o.json);
	fputs("}\n", o.json);
	conn_close(&c);
	if (d.pid > 0) {
		int status = daemon_stop(&d, SIGTERM);
		if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
			fail(&o, "blobcastd did not exit cleanly (status %d)",
			     status);
		}
	}
	{
		char cmd[160];
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock", dir, dir);
		if (system(cmd) != 0) {
			fail(&o, "cannot remove %s", dir);
		}
	}
	/* Helpers of daemon.h this driver does without. */
	(void)t_sleep_ms;
	(void)daemon_start;
	(void)conn_view;
	return out_close(&o);
}

/* ---- verify ------------------------------------------------------------- */

static int cmd_verify(const struct opts *op)
{
	json_error_t je;
	json_t *root, *steps, *check, *scenes;
	const char *key;
	json_t *step;
	int bad = 0, nscenes = 0;
	if (!op->file) {
		fprintf(stderr, "bench_gpu verify: FILE is required\n");
		return 2;
	}
	root = json_load_file(op->file, 0, &je);
	if (!root) {
		fprintf(stderr, "verify: %s: %s (line %d)\n", op->file, je.text,
			je.line);
		return 1;
	}
	steps = json_object_get(root, "steps");
	if (!json_is_object(steps) || json_object_size(steps) == 0) {
		fprintf(stderr, "verify: no steps\n");
		bad++;
	}
	json_object_foreach(steps, key, step)
	{
		if (!json_is_true(json_object_get(step, "ok")) ||
		    !json_is_true(json_object_get(step, "ran"))) {
			fprintf(stderr, "verify: step %s did not succeed: %s\n",
				key,
				json_string_value(
				    json_object_get(step, "error"))
				    ? json_string_value(
					  json_object_get(step, "error"))
				    : "(no error given)");
			bad++;
		}
	}
	check = json_object_get(json_object_get(steps, "check"), "data");
	scenes = json_object_get(check, "scenes");
	if (!json_is_array(scenes)) {
		fprintf(stderr, "verify: no check.data.scenes\n");
		bad++;
	} else {
		size_t i;
		json_t *s;
		json_array_foreach(scenes, i, s)
		{
			nscenes++;
			if (!json_is_true(json_object_get(s, "correct"))) {
				fprintf(stderr, "verify: scene %s not correct\n",
					json_string_value(
					    json_object_get(s, "name")));
				bad++;
			}
		}
	}
	if (nscenes < op->min_scenes) {
		fprintf(stderr, "verify: %d scenes, at least %d expected\n",
			nscenes, op->min_scenes);
		bad++;
	}
	if (!json_is_true(json_object_get(root, "ok"))) {
		fprintf(stderr, "verify: results.json says ok = false\n");
		bad++;
	}
	printf("verify: %d steps, %d scenes, %s\n",
	       (int)json_object_size(steps), nscenes,
	       bad ? "FAILED" : "all ran, all correct");
	json_decref(root);
	return bad ? 1 : 0;
}

/* ---- Arguments ---------------------------------------------------------- */

static const char usage[] =
    "usage: bench_gpu COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  refs    --dir DIR [--size N]   write the correctness scenes and "
    "their\n"
    "          tiled CPU references (NAME.json, NAME.ref) into DIR\n"
    "  info    the gl context: GL_RENDERER, platform\n"
    "  check   --dir DIR [--min-scenes N]  gl against the references\n"
    "  table2  [--size N] [--reps R] [--warmup W] [--counts LIST]\n"
    "          [--lens-counts LIST] [--levels LIST] [--budget-s S]\n"
    "          Zanni 2024 Table 2 (fig18, fig16) with the A-buffer / "
    "tracing split\n"
    "  edit    [--size N] [--counts LIST] [--edits E]  parameter edits "
    "on the GPU\n"
    "  daemon  --blobcastd PATH [--counts N] [--sizes WxH,...] [--edits "
    "E]\n"
    "          edit -> frame through blobcastd --backend gl (JPEG)\n"
    "  verify  FILE [--min-scenes N]  results.json: every step ran and "
    "succeeded,\n"
    "          every scene correct\n"
    "\n"
    "common options:\n"
    "  --platform P   gl platform: auto | device | surfaceless | osmesa\n"
    "  --expect-hardware  fail at once (info: after reporting it) when the\n"
    "                 gl context is software (llvmpipe, surfaceless, "
    "OSMesa)\n"
    "  --json FILE    the step's results as one JSON object\n"
    "  --md FILE      the step's results as Markdown\n"
    "LIST: comma-separated numbers (table2 --counts 16,64,256,1024,4096;\n"
    "--levels 1,2,3,4,5,6; an empty LIST leaves that family out).\n"
    "Exit status: 0 when everything asked for ran and passed, 1 when "
    "something\nfailed (what ran is still reported), 2 for bad usage.\n";

static int parse_list(const char *s, uint32_t *v, uint32_t *n)
{
	*n = 0;
	while (s && *s) {
		char *end;
		unsigned long x = strtoul(s, &end, 10);
		if (end == s || x == 0 || x > (1ul << 24) || *n >= MAX_LIST) {
			return -1;
		}
		v[(*n)++] = (uint32_t)x;
		s = *end == ',' ? end + 1 : end;
		if (*end && *end != ',') {
			return -1;
		}
	}
	return 0;
}

static int parse_sizes(const char *s, struct opts *op)
{
	op->nsizes = 0;
	while (s && *s) {
		unsigned w, h;
		int used = 0;
		if (op->nsizes >= MAX_LIST ||
		    sscanf(s, "%ux%u%n", &w, &h, &used) != 2 || w == 0 ||
		    h == 0 || w > 8192 || h > 8192) {
			return -1;
		}
		op->sizes[op->nsizes][0] = w;
		op->sizes[op->nsizes][1] = h;
		op->nsizes++;
		s += used;
		if (*s == ',') {
			s++;
		} else if (*s) {
			return -1;
		}
	}
	return 0;
}

int main(int argc, char **argv)
{
	struct opts op = {.size = 512,
			  .reps = 20,
			  .warmup = 3,
			  .edits = 50,
			  .min_scenes = 1};
	const char *cmd;
	if (argc < 2 || strcmp(argv[1], "--help") == 0 ||
	    strcmp(argv[1], "-h") == 0) {
		fputs(usage, argc < 2 ? stderr : stdout);
		return argc < 2 ? 2 : 0;
	}
	cmd = argv[1];
	parse_list("16,64,256,1024,4096", op.counts, &op.ncounts);
	/* Lenses of two spheres: the paper's 24..6144 primitives. */
	parse_list("12,48,192,768,3072", op.lens_counts, &op.nlens);
	parse_list("1,2,3,4,5,6", op.levels, &op.nlevels);
	parse_sizes("1920x1080,1024x768", &op);
	for (int i = 2; i < argc; i++) {
		const char *a = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : NULL;
		bool bad = false;
		if (strcmp(a, "--expect-hardware") == 0) {
			op.expect_hardware = true;
			continue;
		}
		if (a[0] != '-' && strcmp(cmd, "verify") == 0 && !op.file) {
			op.file = a;
			continue;
		}
		if (!v) {
			fprintf(stderr, "bench_gpu: %s needs a value\n%s", a,
				usage);
			return 2;
		}
		i++;
		if (strcmp(a, "--platform") == 0) {
			op.platform = v;
		} else if (strcmp(a, "--json") == 0) {
			op.json = v;
		} else if (strcmp(a, "--md") == 0) {
			op.md = v;
		} else if (strcmp(a, "--dir") == 0) {
			op.dir = v;
		} else if (strcmp(a, "--blobcastd") == 0) {
			op.blobcastd = v;
		} else if (strcmp(a, "--size") == 0) {
			op.size = (uint32_t)atoi(v);
			bad = op.size == 0 || op.size > 4096;
		} else if (strcmp(a, "--reps") == 0) {
			op.reps = atoi(v);
			bad = op.reps < 1 || op.reps > 10000;
		} else if (strcmp(a, "--warmup") == 0) {
			op.warmup = atoi(v);
			bad = op.warmup < 0 || op.warmup > 1000;
		} else if (strcmp(a, "--edits") == 0) {
			op.edits = atoi(v);
			bad = op.edits < 1 || op.edits > 100000;
		} else if (strcmp(a, "--min-scenes") == 0) {
			op.min_scenes = atoi(v);
		} else if (strcmp(a, "--budget-s") == 0) {
			op.budget_s = atof(v);
		} else if (strcmp(a, "--counts") == 0) {
			bad = parse_list(v, op.counts, &op.ncounts) != 0;
		} else if (strcmp(a, "--lens-counts") == 0) {
			bad = parse_list(v, op.lens_counts, &op.nlens) != 0;
		} else if (strcmp(a, "--levels") == 0) {
			bad = parse_list(v, op.levels, &op.nlevels) != 0;
			for (uint32_t k = 0; k < op.nlevels; k++) {
				bad |= op.levels[k] > BC_GEN_MAX_LEVEL;
			}
		} else if (strcmp(a, "--sizes") == 0) {
			bad = parse_sizes(v, &op) != 0;
		} else {
			fprintf(stderr, "bench_gpu: unknown option %s\n%s", a,
				usage);
			return 2;
		}
		if (bad) {
			fprintf(stderr, "bench_gpu: bad value for %s: %s\n", a,
				v);
			return 2;
		}
	}
	/* Output is read through pipes and files: line by line. */
	setvbuf(stdout, NULL, _IOLBF, 0);
	if (strcmp(cmd, "refs") == 0) {
		return cmd_refs(&op);
	} else if (strcmp(cmd, "info") == 0) {
		return cmd_info(&op);
	} else if (strcmp(cmd, "check") == 0) {
		return cmd_check(&op);
	} else if (strcmp(cmd, "table2") == 0) {
		return cmd_table2(&op);
	} else if (strcmp(cmd, "edit") == 0) {
		return cmd_edit(&op);
	} else if (strcmp(cmd, "daemon") == 0) {
		return cmd_daemon(&op);
	} else if (strcmp(cmd, "verify") == 0) {
		return cmd_verify(&op);
	}
	fprintf(stderr, "bench_gpu: unknown command %s\n%s", cmd, usage);
	return 2;
}
