/*
 * The GPU run's measurements of the gl backend itself: `table2` (Zanni 2024
 * Table 2 with the A-buffer / tracing split of its Fig. 20) and `edit` (a
 * parameter edit on the GPU: bytes, sync, the damaged region against a
 * whole frame, and the region-assembled frame against a whole render).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "gpu.h"

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
	bool away; /* the camera turned round: every tile empty */
};

static int table2_scene(struct bc_renderer *r, const struct gpu_opts *op,
                        struct gpu_out *o, const struct t2_scene *s, bool first)
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
	uint32_t bands = 0;
	const char *why = NULL;
	bool incomplete = false;
	t0 = gpu_now_ms();
	if (!t || !wall || !abuf || !trace ||
	    bc_frame_init(&f, op->size, op->size)) {
		why = "out of memory";
	} else if (bc_gen(s->gen, &s->o, t, &cam, &ei)) {
		why = ei.msg;
	} else {
		if (s->away) {
			for (int i = 0; i < 3; i++) {
				cam.target[i] =
				    2.0f * cam.eye[i] - cam.target[i];
			}
		}
		gen_ms = gpu_now_ms() - t0;
		t0 = gpu_now_ms();
		if (bc_renderer_sync(r, t, NULL, &ei)) {
			why = ei.msg;
		}
		sync_ms = gpu_now_ms() - t0;
	}
	/* Warm-up: buffer growth, caches, clocks. */
	for (; !why && warm < op->warmup; warm++) {
		struct bc_render_stats st;
		if (bc_renderer_render(r, &cam, &f, &st, &ei)) {
			why = ei.msg;
		}
	}
	for (double s0 = gpu_now_ms(); !why && frames < op->reps; frames++) {
		struct bc_render_stats st;
		double w0 = gpu_now_ms();
		/* Slow scenes (fig16 L6 on a small GPU) keep the step within
		 * its time: at least 5 frames, then at most ~20 s. */
		if (frames >= 5 && w0 - s0 > 20000.0) {
			gpu_fail(o, "%s: %d of %d frames (over 20 s)", s->label,
			         frames, op->reps);
			break;
		}
		if (bc_renderer_render(r, &cam, &f, &st, &ei)) {
			why = ei.msg;
			break;
		}
		wall[frames] = gpu_now_ms() - w0;
		abuf[frames] = st.ms_abuffer;
		trace[frames] = st.ms_trace;
		incomplete |= st.incomplete;
		bands = st.bands > bands ? st.bands : bands;
	}
	if (frames > 0) {
		best = wall[0];
		for (int i = 1; i < frames; i++) {
			best = fmin(best, wall[i]);
		}
		mw = gpu_median(wall, frames);
		ma = gpu_median(abuf, frames);
		mt = gpu_median(trace, frames);
		bc_render_gl_info(r, &info);
	}
	if (why) {
		gpu_fail(o, "%s: %s", s->label, why);
	}
	pm = paper_ms(s->gen, s->o.kind, s->n, smooth);
	printf("table2 %-28s %8u prims: median %8.2f ms (abuf %7.2f, trace "
	       "%7.2f) of %d frames, %u A-buffer band%s; paper ",
	       s->label, t ? bc_tree_prim_count(t) : 0, mw, ma, mt, frames,
	       bands, bands == 1 ? "" : "s");
	if (isnan(pm)) {
		printf("-\n");
	} else {
		printf("%.1f ms\n", pm);
	}
	fprintf(o->json, "%s{\"scene\":", first ? "" : ",");
	gpu_jstr(o->json, s->label);
	fputs(",\"gen\":", o->json);
	gpu_jstr(o->json, s->gen);
	fprintf(o->json, ",\"n\":%u,\"blend\":\"%s\",\"prims\":%u,", s->n,
	        smooth ? "smooth" : "sharp", t ? bc_tree_prim_count(t) : 0);
	fprintf(o->json, "\"frames\":%d,\"warmup\":%d,\"median_ms\":", frames,
	        warm);
	gpu_jnum(o->json, mw);
	fputs(",\"min_ms\":", o->json);
	gpu_jnum(o->json, best);
	fputs(",\"abuffer_ms\":", o->json);
	gpu_jnum(o->json, ma);
	fputs(",\"trace_ms\":", o->json);
	gpu_jnum(o->json, mt);
	fputs(",\"gen_ms\":", o->json);
	gpu_jnum(o->json, gen_ms);
	fputs(",\"sync_ms\":", o->json);
	gpu_jnum(o->json, sync_ms);
	fputs(",\"paper_ms\":", o->json);
	gpu_jnum(o->json, pm);
	fprintf(o->json,
	        ",\"fragments\":%u,\"dispatches\":%u,\"over_m\":%u,"
	        "\"bands\":%u,\"incomplete\":%s",
	        info.fragments, info.dispatches, info.over_m, bands,
	        incomplete ? "true" : "false");
	if (why) {
		fputs(",\"error\":", o->json);
		gpu_jstr(o->json, why);
	}
	fputc('}', o->json);
	if (frames > 0) {
		double share = ma + mt > 0 ? 100.0 * ma / (ma + mt) : NAN;
		fprintf(o->md,
		        "| %s | %u | %.2f | %.2f | %.2f | %.0f %% | %u | %.2f "
		        "| ",
		        s->label, bc_tree_prim_count(t), mw, ma, mt, share,
		        bands, sync_ms);
		if (isnan(pm)) {
			fputs("– | – |\n", o->md);
		} else {
			fprintf(o->md, "%.1f | %.2f× |\n", pm, mw / pm);
		}
	} else {
		fprintf(o->md, "| %s | %u | failed: %s | | | | | | | |\n",
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

int gpu_cmd_table2(const struct gpu_opts *op)
{
	static const enum bc_gen_kind kinds[] = {BC_GEN_KIND_BOXES,
	                                         BC_GEN_KIND_SPHERES};
	static const char *const kind_names[] = {"boxes", "spheres"};
	static const enum bc_gen_blend blends[] = {BC_GEN_BLEND_SHARP,
	                                           BC_GEN_BLEND_SMOOTH};
	struct t2_scene *list;
	size_t n = 0, cap;
	struct gpu_out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	double start = gpu_now_ms();
	int skipped = 0;
	cap = 2 * (2 * op->ncounts + op->nlens + op->nlevels) + 3;
	list = bc_calloc(cap, sizeof(*list));
	if (!list || gpu_out_open(&o, op)) {
		bc_free(list);
		return 1;
	}
	/* The floor: what a frame costs with nothing in any tile (16
	 * spheres behind the camera), and with one sphere. Against the
	 * rows below they separate what every tile pays from what its
	 * list costs. */
	for (int f = 0; f < 2; f++) {
		struct t2_scene *s = &list[n++];
		snprintf(s->label, sizeof(s->label), "%s",
		         f ? "floor: one sphere" : "floor: empty view");
		s->gen = "fig18";
		s->o.kind = BC_GEN_KIND_SPHERES;
		s->o.blend = BC_GEN_BLEND_SHARP;
		s->o.count = f ? 1 : 16;
		s->away = f == 0;
	}
	for (int b = op->smooth_spheres ? 1 : 0; b < 2; b++) {
		const char *bn = b ? "smooth" : "sharp";
		for (int k = op->smooth_spheres ? 1 : 0; k < 2; k++) {
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
	r = gpu_open_gl(op, &o, &info);
	fprintf(o.json, "{\"size\":%u,\"reps\":%d,\"warmup\":%d,\"rows\":[",
	        op->size, op->reps, op->warmup);
	fprintf(o.md,
	        "%ux%u, median of %d frames after %d warm-up frames; "
	        "A-buffer and tracing from GPU timer queries (medians); "
	        "sync: tree upload after generation; paper: Zanni 2024 "
	        "Table 2 (RTX 4080, 1024x1024); bands: the A-buffer's bands "
	        "of tile rows (a view over its limit).\n\n"
	        "| scene | prims | ms | A-buffer | tracing | A-buffer share | "
	        "bands | sync ms | paper ms | ours / paper |\n"
	        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
	        op->size, op->size, op->reps, op->warmup);
	for (size_t i = 0; r && i < n; i++) {
		if (op->budget_s > 0 &&
		    gpu_now_ms() - start > op->budget_s * 1e3) {
			gpu_fail(&o, "%s: not run, the step's %.0f s are spent",
			         list[i].label, op->budget_s);
			skipped++;
			continue;
		}
		(void)table2_scene(r, op, &o, &list[i], i == 0);
	}
	fprintf(o.json, "],\"scenes\":%zu,\"skipped\":%d", n, skipped);
	gpu_json_errors(o.json);
	fputs("}\n", o.json);
	bc_renderer_destroy(r);
	bc_free(list);
	return gpu_out_close(&o);
}

/* ---- edit --------------------------------------------------------------- */

static int edit_scene(struct bc_renderer *r, const struct gpu_opts *op,
                      struct gpu_out *o, uint32_t count, bool first)
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
		double t0 = gpu_now_ms();
		bc_tree_take_dirty(t, &dirty);
		if (bc_renderer_sync(r, t, NULL, &ei)) {
			why = ei.msg;
		}
		full_sync = gpu_now_ms() - t0;
		bc_render_gl_info(r, &info);
		full_bytes = info.upload_bytes;
		/* The frame the edits' regions are drawn over. */
		if (!why && bc_renderer_render(r, &cam, &acc, NULL, &ei)) {
			why = ei.msg;
		}
	}
	for (int i = 0; !why && i < n; i++) {
		const struct bc_lin *l = bc_tree_lin(t);
		uint32_t k =
		    (uint32_t)(((uint64_t)i * 2654435761u) % l->nprims);
		uint32_t id = l->node_id[l->prim_slot[k]];
		struct bc_abv before = bc_lin_abv(l, k), after;
		struct bc_prim_data p;
		struct bc_render_region reg = {.tiles = tiles};
		double t0;
		uint32_t marked = 0;
		bc_tree_get(t, id, &p, NULL);
		p.translate[0] += 0.01f * (i % 2 ? -1.0f : 1.0f);
		t0 = gpu_now_ms();
		if (bc_tree_set_prim(t, id, &p, &ei)) {
			why = ei.msg;
			break;
		}
		bc_tree_take_dirty(t, &dirty);
		if (bc_renderer_sync(r, t, &dirty, &ei)) {
			why = ei.msg;
			break;
		}
		sync_ms[i] = gpu_now_ms() - t0;
		bc_render_gl_info(r, &info);
		bytes += (double)info.upload_bytes;
		memset(tiles, 0, (size_t)tw * th);
		bc_renderer_damage(r, &cam, op->size, op->size, &before, tiles);
		after = bc_lin_abv(bc_tree_lin(t), k);
		bc_renderer_damage(r, &cam, op->size, op->size, &after, tiles);
		for (size_t j = 0; j < (size_t)tw * th; j++) {
			marked += tiles[j] ? 1u : 0u;
		}
		ntiles[i] = marked;
		t0 = gpu_now_ms();
		if (bc_renderer_render_region(r, &cam, &acc, &reg, NULL, &ei)) {
			why = ei.msg;
			break;
		}
		region_ms[i] = gpu_now_ms() - t0;
		t0 = gpu_now_ms();
		if (bc_renderer_render(r, &cam, &whole, NULL, &ei)) {
			why = ei.msg;
			break;
		}
		whole_ms[i] = gpu_now_ms() - t0;
		done++;
	}
	if (!why && done > 0) {
		size_t px = (size_t)op->size * op->size;
		exact = memcmp(acc.rgba, whole.rgba, 4 * px) == 0 &&
		        memcmp(acc.depth, whole.depth, 4 * px) == 0 &&
		        memcmp(acc.ids, whole.ids, 4 * px) == 0;
		if (!exact) {
			gpu_fail(o,
			         "fig18 %u: the frame assembled from damaged "
			         "regions differs from a whole render",
			         count);
		}
		bytes /= done;
	}
	if (why) {
		gpu_fail(o, "edit fig18 %u: %s", count, why);
	}
	{
		double ms = gpu_median(sync_ms, done),
		       rm = gpu_median(region_ms, done);
		double wm = gpu_median(whole_ms, done),
		       tm = gpu_median(ntiles, done);
		printf("edit fig18 spheres smooth %7u: %d edits, %.0f bytes, "
		       "sync %.3f ms, region %.2f ms (%.0f tiles), whole %.2f "
		       "ms; full upload %llu bytes, %.2f ms; exact %s\n",
		       count, done, bytes, ms, rm, tm, wm,
		       (unsigned long long)full_bytes, full_sync,
		       exact ? "yes" : "no");
		fprintf(o->json, "%s{\"prims\":%u,\"edits\":%d,",
		        first ? "" : ",", count, done);
		fputs("\"upload_bytes\":", o->json);
		gpu_jnum(o->json, bytes);
		fputs(",\"sync_ms\":", o->json);
		gpu_jnum(o->json, ms);
		fputs(",\"region_ms\":", o->json);
		gpu_jnum(o->json, rm);
		fputs(",\"region_tiles\":", o->json);
		gpu_jnum(o->json, tm);
		fputs(",\"whole_ms\":", o->json);
		gpu_jnum(o->json, wm);
		fprintf(o->json,
		        ",\"full_upload_bytes\":%llu,\"full_sync_ms\":",
		        (unsigned long long)full_bytes);
		gpu_jnum(o->json, full_sync);
		fprintf(o->json, ",\"exact\":%s", exact ? "true" : "false");
		if (why) {
			fputs(",\"error\":", o->json);
			gpu_jstr(o->json, why);
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

int gpu_cmd_edit(const struct gpu_opts *op)
{
	struct gpu_out o;
	struct bc_gl_info info = {0};
	struct bc_renderer *r;
	if (gpu_out_open(&o, op)) {
		return 1;
	}
	r = gpu_open_gl(op, &o, &info);
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
	gpu_json_errors(o.json);
	fputs("}\n", o.json);
	bc_renderer_destroy(r);
	return gpu_out_close(&o);
}
