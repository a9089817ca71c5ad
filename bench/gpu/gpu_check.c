/*
 * The correctness steps of the GPU run: `refs` (at packing time: the
 * scenes and their references from the CPU tiled renderer), `info` (the gl
 * context), `check` (gl against the references, as tests/gl compares gl
 * with the tiled renderer) and `verify` (results.json says every step ran
 * and every scene is correct).
 */
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>
#include <zlib.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "gpu.h"

#define REF_MAGIC 0x31464552u /* "REF1" little-endian */

/* ---- Correctness scenes and references -------------------------------- */

struct ref_scene {
	const char *name;
	const char *gen; /* NULL: the built-in default scene */
	struct bc_gen_opts o;
};

static const struct ref_scene ref_scenes[] = {
    {"default", NULL, {0}},
    {"fig18-boxes-64-sharp",
     "fig18",
     {.count = 64, .kind = BC_GEN_KIND_BOXES, .blend = BC_GEN_BLEND_SHARP}},
    {"fig18-boxes-256-smooth",
     "fig18",
     {.count = 256, .kind = BC_GEN_KIND_BOXES, .blend = BC_GEN_BLEND_SMOOTH}},
    {"fig18-spheres-256-smooth",
     "fig18",
     {.count = 256, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SMOOTH}},
    {"fig18-spheres-1024-sharp",
     "fig18",
     {.count = 1024, .kind = BC_GEN_KIND_SPHERES, .blend = BC_GEN_BLEND_SHARP}},
    {"fig18-lenses-96-smooth",
     "fig18",
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
	    hdr[0] == REF_MAGIC && hdr[1] > 0 && hdr[2] > 0 && hdr[1] <= 4096 &&
	    hdr[2] <= 4096 && bc_frame_init(f, hdr[1], hdr[2]) == 0) {
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

int gpu_cmd_refs(const struct gpu_opts *op)
{
	struct gpu_out o;
	size_t n = sizeof(ref_scenes) / sizeof(ref_scenes[0]);
	struct bc_frame f = {0};
	if (!op->dir) {
		fprintf(stderr, "bench_gpu refs: --dir DIR is required\n");
		return 2;
	}
	if (gpu_out_open(&o, op) || bc_frame_init(&f, op->size, op->size)) {
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
			gpu_fail(&o, "%s: out of memory", s->name);
			continue;
		}
		bc_camera_default(&cam);
		if (s->gen) {
			rc = bc_gen(s->gen, &s->o, t, &cam, &ei);
		} else {
			const char *txt = bc_scene_default_json();
			rc =
			    bc_scene_parse_json(txt, strlen(txt), t, &cam, &ei);
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
			gpu_fail(&o, "%s: %s", s->name, ei.msg);
			bc_tree_destroy(t);
			continue;
		}
		for (size_t p = 0; p < (size_t)f.width * f.height; p++) {
			hits += isfinite(f.depth[p]) ? 1u : 0u;
		}
		/* A reference with (almost) nothing in view proves nothing. */
		if (hits * 100 < f.width * f.height) {
			gpu_fail(&o, "%s: only %u of %u pixels hit", s->name,
			         hits, f.width * f.height);
		}
		snprintf(path, sizeof(path), "%s/%s.ref", op->dir, s->name);
		if (ref_write(path, &f, bc_tree_lin(t)->size, hits)) {
			gpu_fail(&o, "%s: cannot write %s", s->name, path);
		}
		printf("ref %-26s %7u prims, %ux%u, %u hits, tiled %.1f ms\n",
		       s->name, bc_tree_prim_count(t), f.width, f.height, hits,
		       st.ms_total);
		fprintf(o.json, "%s{\"name\":", i ? "," : "");
		gpu_jstr(o.json, s->name);
		fprintf(o.json, ",\"prims\":%u,\"hits\":%u}",
		        bc_tree_prim_count(t), hits);
		bc_tree_destroy(t);
	}
	fputc(']', o.json);
	gpu_json_errors(o.json);
	fputs("}\n", o.json);
	bc_frame_finish(&f);
	return gpu_out_close(&o);
}

/* ---- info --------------------------------------------------------------- */

int gpu_cmd_info(const struct gpu_opts *op)
{
	struct gpu_out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	if (gpu_out_open(&o, op)) {
		return 1;
	}
	{
		/* The context is reported whatever it is; then judged. */
		struct gpu_opts any = *op;
		any.expect_hardware = false;
		r = gpu_open_gl(&any, &o, &info);
	}
	if (r && op->expect_hardware && gpu_is_software(&info)) {
		gpu_fail(&o,
		         "a GPU was expected, the context is %s on the %s "
		         "platform%s",
		         info.renderer, bc_gl_platform_name(info.platform),
		         info.software_device ? " (software device)" : "");
	}
	fprintf(o.json, "{\"ok\":%s", r ? "true" : "false");
	if (r) {
		fputs(",\"platform\":", o.json);
		gpu_jstr(o.json, bc_gl_platform_name(info.platform));
		fprintf(o.json, ",\"software\":%s,\"renderer\":",
		        gpu_is_software(&info) ? "true" : "false");
		gpu_jstr(o.json, info.renderer);
		fputs(",\"version\":", o.json);
		gpu_jstr(o.json, info.version);
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
	gpu_json_errors(o.json);
	fputs("}\n", o.json);
	bc_renderer_destroy(r);
	return gpu_out_close(&o);
}

static int cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;
	return (x > y) - (x < y);
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
				dz[out->both] =
				    fabsf(a->depth[i] - b->depth[i]);
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

int gpu_cmd_check(const struct gpu_opts *op)
{
	struct gpu_out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	size_t n = 0;
	char **names;
	int correct = 0, ran = 0;
	if (!op->dir) {
		fprintf(stderr, "bench_gpu check: --dir DIR is required\n");
		return 2;
	}
	if (gpu_out_open(&o, op)) {
		return 1;
	}
	names = list_scenes(op->dir, &n);
	if (n == 0) {
		gpu_fail(&o, "no NAME.json scenes in %s", op->dir);
	}
	r = gpu_open_gl(op, &o, &info);
	fputs("{\"scenes\":[", o.json);
	fprintf(o.md, "| scene | prims | size | hits | silhouette px | median "
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
				double t0 = gpu_now_ms();
				if (bc_renderer_render(r, &cam, &g, &st, &ei)) {
					why = ei.msg;
				}
				ms = gpu_now_ms() - t0;
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
				gpu_fail(
				    &o,
				    "%s: differs from the tiled reference "
				    "(silhouette %u px, median dz %.3g, ids "
				    "%u/%u%s)",
				    names[i], a.mask_diff, (double)a.median_dz,
				    a.id_diff, a.both,
				    st.incomplete ? ", incomplete" : "");
			}
		} else {
			gpu_fail(&o, "%s: %s", names[i], why);
		}
		ran++;
		correct += ok;
		printf("check %-26s %s: silhouette %u px, median dz %.3g "
		       "(limit %.3g), ids %u/%u, %.1f ms\n",
		       names[i], ok ? "correct" : "WRONG", a.mask_diff,
		       (double)a.median_dz, 1e-3 * (double)size, a.id_diff,
		       a.both, ms);
		fprintf(o.json, "%s{\"name\":", i ? "," : "");
		gpu_jstr(o.json, names[i]);
		fprintf(o.json,
		        ",\"prims\":%u,\"width\":%u,\"height\":%u,"
		        "\"ref_hits\":%u,\"silhouette_px\":%u,\"both\":%u,"
		        "\"ids_differ\":%u,\"median_dz\":",
		        t ? bc_tree_prim_count(t) : 0, ref.width, ref.height,
		        hits, a.mask_diff, a.both, a.id_diff);
		gpu_jnum(o.json, (double)a.median_dz);
		fputs(",\"dz_limit\":", o.json);
		gpu_jnum(o.json, 1e-3 * (double)size);
		fputs(",\"ms\":", o.json);
		gpu_jnum(o.json, ms);
		fprintf(o.json, ",\"correct\":%s", ok ? "true" : "false");
		if (why) {
			fputs(",\"error\":", o.json);
			gpu_jstr(o.json, why);
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
		gpu_fail(&o, "%d scenes checked, at least %d asked for", ran,
		         op->min_scenes);
	}
	fprintf(o.json, "],\"checked\":%d,\"correct\":%d", ran, correct);
	gpu_json_errors(o.json);
	fputs("}\n", o.json);
	fprintf(o.md, "\n%d of %d scenes correct.\n", correct, ran);
	bc_renderer_destroy(r);
	return gpu_out_close(&o);
}

/* ---- verify ------------------------------------------------------------- */

int gpu_cmd_verify(const struct gpu_opts *op)
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
			fprintf(
			    stderr, "verify: step %s did not succeed: %s\n",
			    key,
			    json_string_value(json_object_get(step, "error"))
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
				fprintf(stderr,
				        "verify: scene %s not correct\n",
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
