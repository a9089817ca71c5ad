/*
 * The gl backend (struct bc_backend_ops "gl"): the renderer object (the
 * front's struct bc_renderer first), the blobtree's GPU buffers and their
 * updates, one frame's passes, the frame key and damage.
 *
 * Buffers. The linearized tree goes up as storage buffers: node words with
 * parameter offsets and the parameter records exactly as bc_lin holds them,
 * the traversal indices (first, fast, jump, kills) per slot, and per
 * primitive its slot, stable id, colour and world ABV. sync() with a
 * parameter edit's dirty ranges sends only those bytes (glBufferSubData of
 * the changed records, node words, traversal entries and ABVs); nothing is
 * recompiled. A structural edit, a different tree or changed counts upload
 * everything.
 *
 * A frame. (1) A-buffer: ABV imposters are rasterized at one pixel per 8x8
 * tile (abuffer.vert/geom/frag), each fragment clipping the tile's rays
 * against the ABV and pushing (entry, exit, primitive) on the tile's linked
 * list; a scan gives each tile its offset and a sort pass lays each list out
 * contiguously, ordered by entry. (2) Tracing: one workgroup per tile walks
 * its list in shared depth ranges with a pruned view of the active
 * primitives (trace.comp), and shades the hits. (3) Readback: the colour,
 * depth and id images and the statistics are copied by the GPU into one
 * pixel buffer object; the host waits on a single fence and maps it once.
 * A frame whose fragments overflow the A-buffer is counted exactly (the
 * count keeps running past the capacity), so the buffer is grown to fit and
 * the frame drawn again, at most once more; lists built for a new view or
 * a band are counted before tracing, so such a frame is not traced first.
 * A call whose lists pass the A-buffer's limit is drawn in bands of tile
 * rows, each a region of its own (draw_bands).
 *
 * Regions. A call draws the tiles of a mask and, in them, the pixels of a
 * refinement level. A mask becomes a list of tile indices (Region buffer):
 * the sort and trace passes run one workgroup per listed tile, and the
 * rasterizer drops fragments of unlisted tiles. Pixels outside the level
 * take no part in tracing, only in their workgroup's barriers. A pixel's
 * value depends only on its tile's list (ordered by a total order), the
 * tree and the frame constants, and its own ray (a ray paused by the loop
 * budget resumes with the step it was about to take), so a frame assembled
 * from regions equals a whole render bit for bit (docs/gl.md). Only the
 * drawn pixels are copied into the caller's frame. Under an evaluation
 * bound a ray that runs out stops (trace.comp) and sets its bit in the
 * Short buffer, read back with the statistics: its pixel is not copied
 * and its tile is marked in the region's short_tiles.
 *
 * Memory. The images, the readback buffer, the tile table and the
 * A-buffer's storage are sized for the last view and kept; release frees
 * them and the next frame allocates them again.
 *
 * Each entry point makes the context current and releases it before
 * returning, so a renderer may be driven from any one thread at a time.
 */
#include "gl_priv.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/log.h"
#include "blobcast/render_backend.h"
#include "blobcast/render_common.h"
#include "blobcast/vec.h"

/* The shaders copy these enum values and layouts (shaders/common.glsl,
 * prim.glsl); a change here must be made there too. */
_Static_assert(BC_OP_SMOOTH_DIFFERENCE == 6, "shaders/common.glsl op kinds");
_Static_assert(BC_PRIM_REVOLVE_STAR == 32 && BC_PRIM_COUNT == 33,
               "shaders/prim.glsl primitive kinds");
_Static_assert(BC_ABV_CAPSULE == 3, "shaders/common.glsl ABV shapes");
_Static_assert(BC_DEBUG_OVERLAPS == 2, "shaders/common.glsl debug modes");
_Static_assert(BC_PRIM_RECORD_VEC4 == 5 && BC_SPHERE_RECORD_VEC4 == 1 &&
                   BC_OP_RECORD_VEC4 == 1,
               "shaders/common.glsl record sizes");
_Static_assert(BC_PRIM_PACKED == 8, "shaders/prim.glsl packed parameters");
_Static_assert(BC_EVAL_STACK == 130, "shaders/common.glsl BC_EVAL_STACK");
_Static_assert(sizeof(struct bc__gl_frame_ubo) == 192, "std140 Frame block");
_Static_assert(BC_RENDER_TILE == BC_GL_TILE, "tiles of the front");
_Static_assert(BC_RENDER_MAX_LEVEL == 3, "shaders/common.glsl BC_MAX_LEVEL");
/* Primitive indices share a 32-bit view instruction word with 11 bits of
 * kind and flags (trace.comp). */
_Static_assert(BC_TREE_MAX_NODES / 2 < (1u << 21), "primitive index bits");

/* How long a frame may keep the GPU before the wait gives up: far beyond
 * any frame llvmpipe renders at the largest size, short enough that a hung
 * driver does not hold the render thread forever. */
#define BC_GL_FENCE_TIMEOUT_S 300.0
/* Bytes per fragment in the linked list, the sorted lists and scratch. */
#define LINK_BYTES 16u
#define SORTED_BYTES 16u
#define SCRATCH_BYTES 24u

enum { Q_START = 0, Q_ABUFFER, Q_TRACE, Q_COUNT };

struct gl_renderer {
	struct bc_renderer base; /* first: the front's part */
	struct bc__gl_ctx ctx;
	/* Sticky: a lost context refuses all further work. */
	int err;
	char errstr[200];
	GLuint progs[BC__GL_PROG_COUNT];
	GLuint vao, fbo, ubo, pbo;
	GLuint bufs[BC__GL_BUF_COUNT];
	size_t buf_size[BC__GL_BUF_COUNT];
	GLuint tex[3]; /* rgba (r32ui), depth (r32f), ids (r32ui) */
	uint32_t tex_w, tex_h;
	size_t pbo_size;
	GLuint queries[Q_COUNT];
	/* The tree last uploaded and the counts its buffers were sized for. */
	const struct bc_tree *tree;
	bool synced;
	uint32_t count, nprims, nparam;
	uint32_t frag_cap;
	uint32_t want_cap; /* capacity asked for, 0: none */
	uint32_t slots;    /* suspension slots after the fragment scratch */
	uint32_t budget;   /* loop budget per invocation, 0: none */
	uint32_t driver_budget; /* the driver's own limit, 0: none */
	/* The region's tile list and bits, built on the host per frame. */
	uint32_t *region;
	size_t region_cap;
	double upload_ms; /* since the last frame */
	uint32_t builds;
	uint64_t upload_bytes;
	bool upload_full;
	uint32_t full_uploads;
	/* The A-buffer kept between region calls of one view: built for
	 * every tile with the frame constants lists_u (up to its region
	 * fields), its tile table saved in lists_tiles (the tracer writes
	 * the tiles' state words), its fragment count and longest list.
	 * Any sync, a new size or new fragment buffers drop it. */
	bool lists_kept;
	struct bc__gl_frame_ubo lists_u;
	GLuint lists_tiles;
	size_t lists_tiles_size;
	uint32_t lists_frags, lists_max;
	uint32_t lists_builds, lists_reused;
	/* The last view whose lists passed the A-buffer's limit, drawn in
	 * bands (draw_bands): its frame constants without capacity or
	 * region, and the most fragments a call of it needed (0: none). A
	 * whole frame of it goes to bands without first drawing every
	 * tile's lists to count them. A sync that uploads the whole tree
	 * forgets it. */
	struct bc__gl_frame_ubo band_u;
	uint32_t band_need;
};

/* The gl renderer behind the front's base (NULL stays NULL). */
static struct gl_renderer *gl_of(struct bc_renderer *base)
{
	return (struct gl_renderer *)base;
}

/* ---- Buffers ------------------------------------------------------------ */

/* (Re)allocates storage buffer b with room for size bytes (never zero:
 * binding an empty buffer is undefined). Contents are not kept. */
static void buf_alloc(struct gl_renderer *r, int b, size_t size,
                      const void *data)
{
	GladGLContext *gl = &r->ctx.gl;
	size_t room = size < 64 ? 64 : size;
	gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, r->bufs[b]);
	gl->BufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)room,
	               room == size ? data : NULL, GL_DYNAMIC_DRAW);
	if (data && room != size && size > 0) {
		gl->BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)size,
		                  data);
	}
	r->buf_size[b] = room;
	r->upload_bytes += data ? size : 0;
}

static void buf_update(struct gl_renderer *r, int b, size_t off, size_t size,
                       const void *data)
{
	GladGLContext *gl = &r->ctx.gl;
	if (size == 0) {
		return;
	}
	gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, r->bufs[b]);
	gl->BufferSubData(GL_SHADER_STORAGE_BUFFER, (GLintptr)off,
	                  (GLsizeiptr)size, data);
	r->upload_bytes += size;
}

static void fill_topo(const struct bc_lin *l, uint32_t lo, uint32_t hi,
                      uint32_t *out)
{
	for (uint32_t s = lo; s < hi; s++, out += 4) {
		out[0] = bc_lin_first(l, s);
		out[1] = l->fast[s];
		out[2] = l->jump[s];
		out[3] = bc_lin_kills(l, s);
	}
}

static void fill_prims(const struct bc_lin *l, uint32_t lo, uint32_t hi,
                       float *out)
{
	for (uint32_t k = lo; k < hi; k++, out += BC_GL_PRIM_FLOATS) {
		uint32_t u[2] = {l->prim_slot[k], l->node_id[l->prim_slot[k]]};
		memcpy(out, u, sizeof(u));
		out[2] = 0.0f;
		out[3] = 0.0f;
		out[4] = l->color[k][0];
		out[5] = l->color[k][1];
		out[6] = l->color[k][2];
		out[7] = 1.0f;
	}
}

static void fill_abvs(const struct bc_lin *l, uint32_t lo, uint32_t hi,
                      float *out)
{
	for (uint32_t k = lo; k < hi; k++, out += BC_GL_ABV_FLOATS) {
		const struct bc_abv abv = bc_lin_abv(l, k), *a = &abv;
		float blo[3], bhi[3];
		memset(out, 0, BC_GL_ABV_FLOATS * sizeof(float));
		bc_abv_aabb(a, blo, bhi);
		for (int i = 0; i < 3; i++) {
			out[i] = blo[i];
			out[4 + i] = bhi[i];
			out[8 + i] = a->center[i];
			out[12 + i] =
			    a->shape == BC_ABV_BOX ? a->half[i] : a->end[i];
			out[16 + i] = a->axis[0][i];
			out[20 + i] = a->axis[1][i];
			out[24 + i] = a->axis[2][i];
		}
		/* The shape as a float: see common.glsl. */
		out[3] = (float)a->shape;
		out[7] = a->radius;
	}
}

/* The unary tables shaders/unary.glsl reads after the slots' entries: per
 * slot (innermost wrapper, innermost domain node, value-changing wrappers
 * above, 0), then per unary node (kind, record, next wrapper out, next
 * domain node out). */
static void fill_unary(const struct bc_lin *l, uint32_t *out)
{
	for (uint32_t s = 0; s < l->count; s++, out += 4) {
		out[0] = l->wrap[s];
		out[1] = l->dom[s];
		out[2] = l->ucount[s];
		out[3] = 0;
	}
	for (uint32_t u = 0; u < l->nunary; u++, out += 4) {
		out[0] = l->unary_kind[u];
		out[1] = l->unary_param[u];
		out[2] = l->unary_outer[u];
		out[3] = l->unary_dom[u];
	}
}

/* Uploads slots [lo, hi) of the traversal indices (whole: all of them and,
 * when the tree has unary nodes, their tables; those change only with the
 * structure). */
static int put_topo(struct gl_renderer *r, const struct bc_lin *l, uint32_t lo,
                    uint32_t hi, bool whole)
{
	size_t n = hi - lo;
	size_t extra = whole && l->nunary ? (size_t)l->count + l->nunary : 0;
	uint32_t *tmp =
	    bc_malloc((n + extra ? n + extra : 1) * 4 * sizeof(uint32_t));
	if (!tmp) {
		return BC_ENOMEM;
	}
	fill_topo(l, lo, hi, tmp);
	if (extra) {
		fill_unary(l, tmp + 4 * n);
		n += extra;
	}
	if (whole) {
		buf_alloc(r, BC__GL_BUF_TOPO, n * 16, tmp);
	} else {
		buf_update(r, BC__GL_BUF_TOPO, (size_t)lo * 16, n * 16, tmp);
	}
	bc_free(tmp);
	return 0;
}

/* Uploads primitives [lo, hi) (slot, id, colour, ABV). */
static int put_prims(struct gl_renderer *r, const struct bc_lin *l, uint32_t lo,
                     uint32_t hi, bool whole)
{
	size_t n = hi - lo;
	size_t pb = BC_GL_PRIM_FLOATS * sizeof(float);
	size_t ab = BC_GL_ABV_FLOATS * sizeof(float);
	float *tmp = bc_malloc((n ? n : 1) * (pb + ab));
	if (!tmp) {
		return BC_ENOMEM;
	}
	fill_prims(l, lo, hi, tmp);
	fill_abvs(l, lo, hi, tmp + n * BC_GL_PRIM_FLOATS);
	if (whole) {
		buf_alloc(r, BC__GL_BUF_PRIMS, n * pb, tmp);
		buf_alloc(r, BC__GL_BUF_ABVS, n * ab,
		          tmp + n * BC_GL_PRIM_FLOATS);
	} else {
		buf_update(r, BC__GL_BUF_PRIMS, (size_t)lo * pb, n * pb, tmp);
		buf_update(r, BC__GL_BUF_ABVS, (size_t)lo * ab, n * ab,
		           tmp + n * BC_GL_PRIM_FLOATS);
	}
	bc_free(tmp);
	return 0;
}

static int upload_all(struct gl_renderer *r, const struct bc_lin *l)
{
	int rc;
	buf_alloc(r, BC__GL_BUF_NODES, (size_t)l->count * 8, l->node);
	buf_alloc(r, BC__GL_BUF_PARAMS, (size_t)l->nparam * 16, l->param);
	if ((rc = put_topo(r, l, 0, l->count, true)) ||
	    (rc = put_prims(r, l, 0, l->nprims, true))) {
		return rc;
	}
	r->count = l->count;
	r->nprims = l->nprims;
	r->nparam = l->nparam;
	r->upload_full = true;
	r->full_uploads++;
	return 0;
}

/* Clamps [*lo, *hi) to [0, n); false when empty. */
static bool clamp_range(uint32_t *lo, uint32_t *hi, uint32_t n)
{
	if (*hi > n) {
		*hi = n;
	}
	return *lo < *hi;
}

static int upload_dirty(struct gl_renderer *r, const struct bc_lin *l,
                        const struct bc_dirty *d)
{
	uint32_t plo = d->param_lo, phi = d->param_hi;
	uint32_t slo = d->slot_lo, shi = d->slot_hi;
	uint32_t klo = d->prim_lo, khi = d->prim_hi;
	int rc;
	if (clamp_range(&plo, &phi, l->nparam)) {
		buf_update(r, BC__GL_BUF_PARAMS, (size_t)plo * 16,
		           (size_t)(phi - plo) * 16, l->param + 4u * plo);
	}
	if (clamp_range(&slo, &shi, l->count)) {
		/* An operator edit changes node words (the kind) and, with
		 * the kind's class, the kill counts of its whole subtree;
		 * its primitives' ABVs moved with the new ROIs. The slot
		 * range is that subtree, whose leaves are consecutive
		 * primitives: the first leaf is slot_lo, and a subtree of
		 * m slots has (m + 1) / 2 leaves. */
		uint32_t k0 = bc_lin_first_prim(l, shi - 1);
		uint32_t k1 = k0 + (shi - bc_lin_first(l, shi - 1) + 1) / 2;
		if (slo < bc_lin_first(l, shi - 1)) {
			/* Several edited subtrees merged into one range:
			 * refresh every primitive rather than work out
			 * which. */
			k0 = 0;
			k1 = l->nprims;
		}
		buf_update(r, BC__GL_BUF_NODES, (size_t)slo * 8,
		           (size_t)(shi - slo) * 8, l->node + 2u * slo);
		if ((rc = put_topo(r, l, slo, shi, false))) {
			return rc;
		}
		if (k0 < l->nprims) {
			if (klo < khi && klo < l->nprims) {
				klo = klo < k0 ? klo : k0;
				khi = khi > k1 ? khi : k1;
			} else {
				klo = k0;
				khi = k1;
			}
		}
	}
	if (clamp_range(&klo, &khi, l->nprims) &&
	    (rc = put_prims(r, l, klo, khi, false))) {
		return rc;
	}
	r->upload_full = false;
	return 0;
}

/* ---- Create and destroy ------------------------------------------------- */

static void release_gl(struct gl_renderer *r)
{
	GladGLContext *gl = &r->ctx.gl;
	if (!gl->DeleteBuffers) {
		return; /* entry points never loaded */
	}
	bc__gl_programs_free(&r->ctx, r->progs);
	gl->DeleteBuffers(BC__GL_BUF_COUNT, r->bufs);
	gl->DeleteBuffers(1, &r->ubo);
	gl->DeleteBuffers(1, &r->pbo);
	gl->DeleteBuffers(1, &r->lists_tiles);
	gl->DeleteTextures(3, r->tex);
	gl->DeleteQueries(Q_COUNT, r->queries);
	gl->DeleteFramebuffers(1, &r->fbo);
	gl->DeleteVertexArrays(1, &r->vao);
}

static void gl_destroy(struct bc_renderer *base)
{
	struct gl_renderer *r = gl_of(base);
	struct bc_errinfo ei = {0};
	if (!r) {
		return;
	}
	if (r->ctx.plat.platform != BC_GL_PLATFORM_AUTO) {
		/* Objects die with the context anyway; deleting them first
		 * matters when the driver shares the display. */
		if (bc__gl_ctx_bind(&r->ctx, &ei) == 0) {
			release_gl(r);
			bc__gl_ctx_unbind(&r->ctx);
		}
		bc__gl_ctx_close(&r->ctx);
	}
	bc_free(r->region);
	bc_free(r);
}

/* opts comes from the front, checked and never NULL; its gl_platform
 * string is the caller's and is not kept (the front clears it), so the
 * platform is decided here, once. */
static int gl_create(struct bc_renderer **out,
                     const struct bc_render_opts *opts, struct bc_errinfo *ei)
{
	struct gl_renderer *r;
	enum bc_gl_platform platform;
	GladGLContext *gl;
	int rc;
	*out = NULL;
	platform = bc_gl_platform_from_name(opts->gl_platform);
	if (platform == BC_GL_PLATFORM_COUNT) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "gl: unknown platform '%s' (auto, "
		                      "device, surfaceless or osmesa)",
		                      opts->gl_platform);
	}
	if (!(r = bc_calloc(1, sizeof(*r)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "gl: out of memory");
	}
	if ((rc = bc__gl_ctx_open(&r->ctx, platform, ei))) {
		goto fail;
	}
	gl = &r->ctx.gl;
	if ((rc = bc__gl_programs_build(&r->ctx, r->progs, ei))) {
		goto fail;
	}
	r->builds++;
	if (strstr(r->ctx.info.renderer, "llvmpipe")) {
		r->budget = BC_GL_LLVMPIPE_LOOP_LIMIT;
	}
	r->driver_budget = r->budget;
	r->ctx.info.loop_budget = r->budget;
	gl->GenVertexArrays(1, &r->vao);
	gl->GenFramebuffers(1, &r->fbo);
	gl->GenBuffers(BC__GL_BUF_COUNT, r->bufs);
	gl->GenBuffers(1, &r->ubo);
	gl->GenBuffers(1, &r->pbo);
	gl->GenBuffers(1, &r->lists_tiles);
	gl->GenQueries(Q_COUNT, r->queries);
	gl->BindBuffer(GL_UNIFORM_BUFFER, r->ubo);
	gl->BufferData(GL_UNIFORM_BUFFER, sizeof(struct bc__gl_frame_ubo), NULL,
	               GL_DYNAMIC_DRAW);
	for (int b = 0; b < BC__GL_BUF_COUNT; b++) {
		buf_alloc(r, b, 64, NULL);
	}
	buf_alloc(r, BC__GL_BUF_STATS, BC_GL_STAT_WORDS * 4, NULL);
	if ((rc = bc__gl_check(&r->ctx, "creating objects", ei))) {
		goto fail;
	}
	bc__gl_ctx_unbind(&r->ctx);
	*out = &r->base;
	return 0;
fail:
	gl_destroy(&r->base);
	return rc;
}

/* ---- Sync -----------------------------------------------------------------
 */

/* Makes the context current, refusing work after a loss. */
static int enter(struct gl_renderer *r, struct bc_errinfo *ei)
{
	GladGLContext *gl = &r->ctx.gl;
	int rc;
	if (r->err) {
		return bc_errinfo_set(ei, r->err, "%s", r->errstr);
	}
	if ((rc = bc__gl_ctx_bind(&r->ctx, ei))) {
		return rc;
	}
	if (gl->GetGraphicsResetStatus) {
		GLenum s = gl->GetGraphicsResetStatus();
		if (s != GL_NO_ERROR) {
			const char *why = s == GL_GUILTY_CONTEXT_RESET
			                      ? "GL_GUILTY_CONTEXT_RESET"
			                  : s == GL_INNOCENT_CONTEXT_RESET
			                      ? "GL_INNOCENT_CONTEXT_RESET"
			                      : "GL_UNKNOWN_CONTEXT_RESET";
			r->err = BC_EGL;
			snprintf(r->errstr, sizeof(r->errstr),
			         "gl: context lost (%s): create a new renderer",
			         why);
			bc_log(BC_LOG_ERROR, "%s", r->errstr);
			bc__gl_ctx_unbind(&r->ctx);
			return bc_errinfo_set(ei, r->err, "%s", r->errstr);
		}
	}
	return 0;
}

static int gl_sync(struct bc_renderer *base, const struct bc_tree *t,
                   const struct bc_dirty *dirty, struct bc_errinfo *ei)
{
	struct gl_renderer *r = gl_of(base);
	const struct bc_lin *l;
	double t0;
	int rc = 0;
	if ((rc = enter(r, ei))) {
		return rc;
	}
	t0 = bc_clock_ms();
	r->upload_bytes = 0;
	r->lists_kept = false; /* the lists were of the tree before */
	l = bc_tree_lin(t);
	if (l && l->nunary && !r->progs[BC__GL_PROG_TRACE_UNARY]) {
		/* Built on the first tree with unary nodes. */
		if ((rc = bc__gl_program_trace_unary(
		         &r->ctx, &r->progs[BC__GL_PROG_TRACE_UNARY], ei))) {
			bc__gl_ctx_unbind(&r->ctx);
			r->synced = false;
			return rc;
		}
		r->builds++;
	}
	if (!l) {
		/* An empty tree: nothing to upload, every ray misses. */
		r->count = r->nprims = r->nparam = 0;
		r->upload_full = true;
	} else if (!dirty || dirty->structure || !r->synced || t != r->tree ||
	           l->count != r->count || l->nprims != r->nprims ||
	           l->nparam != r->nparam) {
		r->band_need = 0;
		rc = upload_all(r, l);
	} else if (dirty->edits) {
		rc = upload_dirty(r, l, dirty);
	}
	if (rc == 0) {
		rc = bc__gl_check(&r->ctx, "uploading the tree", ei);
	} else {
		bc_errinfo_set(ei, rc, "gl: out of memory uploading the tree");
	}
	r->synced = rc == 0;
	r->tree = t;
	r->upload_ms += bc_clock_ms() - t0;
	bc__gl_ctx_unbind(&r->ctx);
	return rc;
}

/* ---- One frame ------------------------------------------------------------
 */

/* The frame's uniforms: render/cpu/shade.c's frame setup (the region's
 * part is filled by the caller). Rays, aspect and pixel footprint are the
 * whole view's when the frame is a window of it. */
static void frame_setup(struct bc__gl_frame_ubo *u, const struct bc_lin *l,
                        const struct bc_camera *cam, const struct bc_frame *out,
                        enum bc_debug_mode debug, uint32_t nprims, uint32_t cap,
                        uint32_t slots, uint32_t budget)
{
	struct bc_view_rays vr;
	uint32_t w = out->width, h = out->height;
	/* The scene's scale, not its size: an edit that moves the bounds a
	 * little keeps every constant, so a damaged region is drawn with the
	 * constants of the frame around it. */
	float size = bc_render_scale(l), light[3];
	memset(u, 0, sizeof(*u));
	bc_frame_view_rays(&vr, cam, out);
	u->window[0] = vr.x0;
	u->window[1] = vr.y0;
	u->window[2] = vr.width;
	u->window[3] = vr.height;
	for (int i = 0; i < 3; i++) {
		u->eye[i] = vr.eye[i];
		u->forward[i] = vr.forward[i];
		u->right[i] = vr.right[i];
		u->up[i] = vr.up[i];
		light[i] = -0.5f * vr.right[i] + 0.6f * vr.up[i] -
		           0.6f * vr.forward[i];
	}
	bc_v3_normalize_div(light);
	memcpy(u->light, light, sizeof(light));
	u->eye[3] = vr.tan_half_y;
	u->forward[3] = vr.aspect;
	u->right[3] = BC_GL_MIN_STEP_REL * size;
	u->up[3] = 2.0f * vr.tan_half_y / (float)vr.height;
	u->light[3] = BC_GL_AMBIENT;
	u->misc[0] = BC_GL_REFINE_REL * size;
	u->misc[1] = size;
	u->size[0] = w;
	u->size[1] = h;
	u->size[2] = (w + BC_GL_TILE - 1) / BC_GL_TILE;
	u->size[3] = (h + BC_GL_TILE - 1) / BC_GL_TILE;
	u->counts[0] = nprims;
	/* Where the unary tables start in Topo, 0 without unary nodes. */
	u->counts[3] = l && l->nunary ? l->count : 0;
	u->misc[2] = l ? l->lip : 1.0f;
	u->misc[3] = 1.0f / u->misc[2];
	u->counts[1] = cap;
	u->counts[2] = (uint32_t)debug;
	/* Slots follow the fragment scratch: 6 words per fragment. */
	u->pool[0] = 6u * cap;
	u->pool[1] = slots;
	u->pool[2] = budget;
}

/* Images, the tile table, the framebuffer and the readback buffer for a
 * w x h frame. */
static int frame_buffers(struct gl_renderer *r, uint32_t w, uint32_t h)
{
	GladGLContext *gl = &r->ctx.gl;
	static const GLenum fmt[3] = {GL_R32UI, GL_R32F, GL_R32UI};
	uint32_t tw = (w + BC_GL_TILE - 1) / BC_GL_TILE;
	uint32_t th = (h + BC_GL_TILE - 1) / BC_GL_TILE;
	size_t npix = (size_t)w * h;
	if (r->tex_w == w && r->tex_h == h) {
		return 0;
	}
	gl->DeleteTextures(3, r->tex);
	gl->GenTextures(3, r->tex);
	for (int i = 0; i < 3; i++) {
		gl->BindTexture(GL_TEXTURE_2D, r->tex[i]);
		gl->TexStorage2D(GL_TEXTURE_2D, 1, fmt[i], (GLsizei)w,
		                 (GLsizei)h);
	}
	gl->BindTexture(GL_TEXTURE_2D, 0);
	buf_alloc(r, BC__GL_BUF_TILES, (size_t)tw * th * 16, NULL);
	buf_alloc(r, BC__GL_BUF_SHORT, (size_t)tw * th * BC_GL_SHORT_WORDS * 4,
	          NULL);
	gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo);
	gl->FramebufferParameteri(GL_FRAMEBUFFER, GL_FRAMEBUFFER_DEFAULT_WIDTH,
	                          (GLint)tw);
	gl->FramebufferParameteri(GL_FRAMEBUFFER, GL_FRAMEBUFFER_DEFAULT_HEIGHT,
	                          (GLint)th);
	gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
	/* The planes, the statistics, then the Short words of a bounded
	 * frame. */
	r->pbo_size = 12 * npix + BC_GL_STAT_WORDS * 4 +
	              (size_t)tw * th * BC_GL_SHORT_WORDS * 4;
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, r->pbo);
	gl->BufferData(GL_PIXEL_PACK_BUFFER, (GLsizeiptr)r->pbo_size, NULL,
	               GL_STREAM_READ);
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
	r->tex_w = w;
	r->tex_h = h;
	return 0;
}

/* Fragment storage for cap fragments, and scratch with `slots`
 * suspension slots after it. */
static void frag_buffers(struct gl_renderer *r, uint32_t cap, uint32_t slots)
{
	buf_alloc(r, BC__GL_BUF_LINKS, (size_t)cap * LINK_BYTES, NULL);
	buf_alloc(r, BC__GL_BUF_SORTED, (size_t)cap * SORTED_BYTES, NULL);
	r->lists_kept = false;
	buf_alloc(r, BC__GL_BUF_SCRATCH,
	          (size_t)cap * SCRATCH_BYTES +
	              (size_t)slots * BC_GL_SLOT_WORDS * 4u,
	          NULL);
	r->frag_cap = cap;
	r->slots = slots;
}

/* Largest fragment capacity: the limit (opts.abuffer_limit may lower
 * it), and the driver's storage block size for the largest per-fragment
 * buffer. */
static uint32_t frag_limit(struct gl_renderer *r)
{
	GLint64 block = 0;
	uint64_t most = BC_GL_MAX_FRAGMENTS;
	if (r->base.opts.abuffer_limit && r->base.opts.abuffer_limit < most) {
		most = r->base.opts.abuffer_limit;
	}
	r->ctx.gl.GetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &block);
	if (block > 0) {
		/* The scratch block also holds the suspension slots. */
		uint64_t room = (uint64_t)block -
		                (uint64_t)r->slots * BC_GL_SLOT_WORDS * 4u;
		if ((uint64_t)block >
		        (uint64_t)r->slots * BC_GL_SLOT_WORDS * 4u &&
		    room / SCRATCH_BYTES < most) {
			most = room / SCRATCH_BYTES;
		}
	}
	return (uint32_t)most;
}

/* ---- Regions ----------------------------------------------------------- */

/* How one call's region is drawn: which tiles (all of them in row-major
 * order, or a list uploaded in the Region buffer) and the workgroups of a
 * per-tile dispatch. */
struct plan {
	uint32_t level;
	bool refine;
	bool list;       /* tiles from the Region buffer */
	uint32_t nlist;  /* tiles listed */
	uint32_t gx, gy; /* workgroups of a per-tile dispatch */
	uint32_t box[4]; /* listed tiles' bounds: x0, y0, x1, y1 (half-open) */
	uint32_t tiles;  /* tiles with a pixel to draw */
	uint64_t rays;   /* pixels to draw */
};

/* Whether p asks for most of a frame of ntiles tiles (every tile, or a
 * list of a quarter of them or more): such a call's lists are built for
 * every tile, not for its own tiles alone. */
static bool plan_wide(const struct plan *p, uint64_t ntiles)
{
	return !p->list || (uint64_t)p->nlist * 4 >= ntiles;
}

/* Pixels of a tile spanning [x0, x0 + n) (x0 a multiple of the tile) whose
 * coordinate is a multiple of 2^level. */
static uint32_t level_count(uint32_t n, uint32_t level)
{
	return (n + (1u << level) - 1u) >> level;
}

/* Pixels of tile (tx, ty) the region's level asks for: those at level,
 * less those of level + 1 when refining (both sets are products of
 * per-axis sets, see bc_render_level_has). */
static uint32_t tile_rays(uint32_t tx, uint32_t ty, uint32_t w, uint32_t h,
                          uint32_t level, bool refine)
{
	uint32_t tw =
	    w - tx * BC_GL_TILE < BC_GL_TILE ? w - tx * BC_GL_TILE : BC_GL_TILE;
	uint32_t th =
	    h - ty * BC_GL_TILE < BC_GL_TILE ? h - ty * BC_GL_TILE : BC_GL_TILE;
	uint32_t n = level_count(tw, level) * level_count(th, level);
	if (refine && level < BC_RENDER_MAX_LEVEL) {
		n -= level_count(tw, level + 1) * level_count(th, level + 1);
	}
	return n;
}

/* Plans region for a w x h frame; a list goes into r->region (tile
 * indices, then one bit per tile). Returns 0 or BC_ENOMEM. */
static int plan_region(struct gl_renderer *r,
                       const struct bc_render_region *region, uint32_t w,
                       uint32_t h, struct plan *p)
{
	uint32_t tw = bc_render_tiles_x(w), th = bc_render_tiles_y(h);
	size_t ntiles = (size_t)tw * th, words = (ntiles + 31) / 32;
	memset(p, 0, sizeof(*p));
	p->level = region->level;
	p->refine = region->refine;
	p->list = region->tiles != NULL;
	if (p->list && r->region_cap < ntiles + words) {
		uint32_t *grown = bc_malloc((ntiles + words) * sizeof(*grown));
		if (!grown) {
			return BC_ENOMEM;
		}
		bc_free(r->region);
		r->region = grown;
		r->region_cap = ntiles + words;
	}
	for (uint32_t ty = 0; ty < th; ty++) {
		for (uint32_t tx = 0; tx < tw; tx++) {
			uint32_t i = ty * tw + tx;
			uint32_t n =
			    tile_rays(tx, ty, w, h, p->level, p->refine);
			if (p->list && (!region->tiles[i] || n == 0)) {
				continue;
			}
			if (n > 0) {
				p->tiles++;
				p->rays += n;
			}
			if (p->list) {
				r->region[p->nlist++] = i;
			}
		}
	}
	p->gx = tw;
	p->gy = th;
	if (p->list) {
		uint32_t *bits = r->region + p->nlist;
		memset(bits, 0, words * sizeof(*bits));
		p->box[0] = tw;
		p->box[1] = th;
		for (uint32_t j = 0; j < p->nlist; j++) {
			uint32_t i = r->region[j], x = i % tw, y = i / tw;
			bits[i / 32] |= 1u << (i % 32);
			p->box[0] = x < p->box[0] ? x : p->box[0];
			p->box[1] = y < p->box[1] ? y : p->box[1];
			p->box[2] = x + 1 > p->box[2] ? x + 1 : p->box[2];
			p->box[3] = y + 1 > p->box[3] ? y + 1 : p->box[3];
		}
		p->gy = (p->nlist + tw - 1) / tw;
	}
	return 0;
}

/* Sends a planned list to the Region buffer (not counted as tree
 * upload). */
static void upload_region(struct gl_renderer *r, const struct plan *p,
                          uint32_t w, uint32_t h)
{
	GladGLContext *gl = &r->ctx.gl;
	size_t ntiles = (size_t)bc_render_tiles_x(w) * bc_render_tiles_y(h);
	size_t bytes = (p->nlist + (ntiles + 31) / 32) * sizeof(uint32_t);
	if (!p->list) {
		return;
	}
	gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, r->bufs[BC__GL_BUF_REGION]);
	if (r->buf_size[BC__GL_BUF_REGION] < bytes) {
		gl->BufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)bytes,
		               r->region, GL_DYNAMIC_DRAW);
		r->buf_size[BC__GL_BUF_REGION] = bytes;
	} else {
		gl->BufferSubData(GL_SHADER_STORAGE_BUFFER, 0,
		                  (GLsizeiptr)bytes, r->region);
	}
}

/* The tile's bits in the mapped Short words: pixels whose rays ran out. */
static uint64_t short_bits(const char *shorts, uint32_t tile)
{
	uint32_t wd[BC_GL_SHORT_WORDS];
	memcpy(wd, shorts + (size_t)tile * sizeof(wd), sizeof(wd));
	return (uint64_t)wd[0] | (uint64_t)wd[1] << 32;
}

/* Copies the pixels p drew from the mapped planes (rgba, depth, ids, each
 * w * h words) into out; the others keep their values, and so do those
 * whose rays ran out of the bound when shorts (the mapped Short words of a
 * bounded frame) is given. */
static void copy_region(struct gl_renderer *r, const struct plan *p,
                        const char *map, const char *shorts,
                        struct bc_frame *out)
{
	uint32_t w = out->width, h = out->height, tw = bc_render_tiles_x(w);
	size_t npix = (size_t)w * h;
	uint32_t n = p->list ? p->nlist : tw * bc_render_tiles_y(h);
	uint32_t step = 1u << p->level;
	if (!p->list && p->level == 0 && !shorts) {
		memcpy(out->rgba, map, 4 * npix);
		if (out->depth) {
			memcpy(out->depth, map + 4 * npix, 4 * npix);
		}
		if (out->ids) {
			memcpy(out->ids, map + 8 * npix, 4 * npix);
		}
		return;
	}
	for (uint32_t j = 0; j < n; j++) {
		uint32_t i = p->list ? r->region[j] : j;
		uint32_t x0 = (i % tw) * BC_GL_TILE, y0 = (i / tw) * BC_GL_TILE;
		uint64_t cut = shorts ? short_bits(shorts, i) : 0;
		for (uint32_t y = y0; y < y0 + BC_GL_TILE && y < h; y += step) {
			for (uint32_t x = x0; x < x0 + BC_GL_TILE && x < w;
			     x += step) {
				size_t k = (size_t)y * w + x;
				uint32_t bit = (y - y0) * BC_GL_TILE + (x - x0);
				if (!bc_render_level_has(x, y, p->level,
				                         p->refine) ||
				    (cut >> bit) & 1u) {
					continue;
				}
				memcpy(out->rgba + 4 * k, map + 4 * k, 4);
				if (out->depth) {
					memcpy(out->depth + k,
					       map + 4 * (npix + k), 4);
				}
				if (out->ids) {
					memcpy(out->ids + k,
					       map + 4 * (2 * npix + k), 4);
				}
			}
		}
	}
}

/* Marks in short_tiles (may be NULL) the tiles p drew where a ray ran out
 * of the bound, from the mapped Short words. Returns those rays. */
static uint64_t mark_short(const struct gl_renderer *r, const struct plan *p,
                           const char *shorts, uint32_t ntiles,
                           uint8_t *short_tiles)
{
	uint32_t n = p->list ? p->nlist : ntiles;
	uint64_t rays = 0;
	for (uint32_t j = 0; j < n; j++) {
		uint32_t i = p->list ? r->region[j] : j;
		uint64_t cut = short_bits(shorts, i);
		if (!cut) {
			continue;
		}
		for (; cut; cut &= cut - 1u) {
			rays++;
		}
		if (short_tiles) {
			short_tiles[i] = 1;
		}
	}
	return rays;
}

/* How draw gets the frame's A-buffer. */
enum lists_use {
	LISTS_REGION, /* built for the region's tiles only */
	LISTS_ALL,    /* built for every tile, then kept */
	LISTS_KEPT,   /* those kept from an earlier call of the view */
};

/* Whether u and the kept lists' frame constants describe the same view
 * (everything before the region fields, and the window). */
static bool same_view(const struct bc__gl_frame_ubo *u,
                      const struct bc__gl_frame_ubo *k)
{
	return memcmp(u, k, offsetof(struct bc__gl_frame_ubo, region)) == 0 &&
	       memcmp(u->window, k->window, sizeof(u->window)) == 0;
}

/* Issues the A-buffer passes of one frame (none for kept lists). */
static void draw(struct gl_renderer *r, const struct bc__gl_frame_ubo *u,
                 const struct plan *p, uint32_t nprims, enum lists_use use)
{
	GladGLContext *gl = &r->ctx.gl;
	static const uint32_t tile_init[4] = {0xffffffffu, 0u, 0u, 0u};
	static const uint32_t zero = 0;
	uint32_t tw = u->size[2], th = u->size[3];
	size_t table = (size_t)tw * th * 16;
	struct bc__gl_frame_ubo all = *u;
	/* The lists of every tile are built with the region fields of a
	 * whole frame, then traced with the call's. */
	if (use == LISTS_ALL) {
		all.region[2] = all.region[3] = 0;
	}
	gl->BindBuffer(GL_UNIFORM_BUFFER, r->ubo);
	gl->BufferSubData(GL_UNIFORM_BUFFER, 0, sizeof(all), &all);
	gl->BindBufferBase(GL_UNIFORM_BUFFER, 0, r->ubo);
	for (int b = 0; b < BC__GL_BUF_COUNT; b++) {
		gl->BindBufferBase(GL_SHADER_STORAGE_BUFFER, (GLuint)b,
		                   r->bufs[b]);
	}
	if (use == LISTS_KEPT) {
		gl->BindBuffer(GL_COPY_READ_BUFFER, r->lists_tiles);
		gl->BindBuffer(GL_COPY_WRITE_BUFFER, r->bufs[BC__GL_BUF_TILES]);
		gl->CopyBufferSubData(GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER,
		                      0, 0, (GLsizeiptr)table);
	} else {
		gl->BindBuffer(GL_SHADER_STORAGE_BUFFER,
		               r->bufs[BC__GL_BUF_TILES]);
		gl->ClearBufferSubData(GL_SHADER_STORAGE_BUFFER, GL_RGBA32UI, 0,
		                       (GLsizeiptr)table, GL_RGBA_INTEGER,
		                       GL_UNSIGNED_INT, tile_init);
	}
	gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, r->bufs[BC__GL_BUF_STATS]);
	gl->ClearBufferData(GL_SHADER_STORAGE_BUFFER, GL_R32UI, GL_RED_INTEGER,
	                    GL_UNSIGNED_INT, &zero);
	if (u->bound[0]) {
		/* Only the tracer of a bounded frame sets Short bits. */
		gl->BindBuffer(GL_SHADER_STORAGE_BUFFER,
		               r->bufs[BC__GL_BUF_SHORT]);
		gl->ClearBufferSubData(
		    GL_SHADER_STORAGE_BUFFER, GL_R32UI, 0,
		    (GLsizeiptr)((size_t)tw * th * BC_GL_SHORT_WORDS * 4),
		    GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
	}
	gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
	gl->QueryCounter(r->queries[Q_START], GL_TIMESTAMP);

	/* A-buffer: imposters at one pixel per tile, no attachments. */
	if (nprims > 0 && use != LISTS_KEPT) {
		gl->UseProgram(r->progs[BC__GL_PROG_ABUFFER]);
		gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo);
		gl->Viewport(0, 0, (GLsizei)tw, (GLsizei)th);
		gl->Disable(GL_DEPTH_TEST);
		gl->Disable(GL_CULL_FACE);
		gl->BindVertexArray(r->vao);
		gl->DrawArrays(GL_POINTS, 0, (GLsizei)nprims);
		gl->BindVertexArray(0);
		gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
		gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
	}
	if (use != LISTS_KEPT) {
		gl->UseProgram(r->progs[BC__GL_PROG_SCAN]);
		gl->DispatchCompute(1, 1, 1);
		gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
		gl->UseProgram(r->progs[BC__GL_PROG_SORT]);
		gl->DispatchCompute(use == LISTS_ALL ? tw : p->gx,
		                    use == LISTS_ALL ? th : p->gy, 1);
		gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
	}
	if (use == LISTS_ALL) {
		/* Kept before the tracer writes the tiles' state words. */
		if (r->lists_tiles_size < table) {
			gl->BindBuffer(GL_COPY_WRITE_BUFFER, r->lists_tiles);
			gl->BufferData(GL_COPY_WRITE_BUFFER, (GLsizeiptr)table,
			               NULL, GL_DYNAMIC_COPY);
			r->lists_tiles_size = table;
		}
		gl->BindBuffer(GL_COPY_READ_BUFFER, r->bufs[BC__GL_BUF_TILES]);
		gl->BindBuffer(GL_COPY_WRITE_BUFFER, r->lists_tiles);
		gl->CopyBufferSubData(GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER,
		                      0, 0, (GLsizeiptr)table);
		gl->BindBuffer(GL_UNIFORM_BUFFER, r->ubo);
		gl->BufferSubData(GL_UNIFORM_BUFFER, 0, sizeof(*u), u);
		gl->MemoryBarrier(GL_UNIFORM_BARRIER_BIT |
		                  GL_BUFFER_UPDATE_BARRIER_BIT);
	}
	gl->QueryCounter(r->queries[Q_ABUFFER], GL_TIMESTAMP);
}

/* Issues the first tracing dispatch of a drawn frame (tracing and
 * shading). */
static void trace(struct gl_renderer *r, const struct bc__gl_frame_ubo *u,
                  const struct plan *p)
{
	GladGLContext *gl = &r->ctx.gl;
	gl->UseProgram(r->progs[u->counts[3] ? BC__GL_PROG_TRACE_UNARY
	                                     : BC__GL_PROG_TRACE]);
	gl->BindImageTexture(0, r->tex[0], 0, GL_FALSE, 0, GL_WRITE_ONLY,
	                     GL_R32UI);
	gl->BindImageTexture(1, r->tex[1], 0, GL_FALSE, 0, GL_WRITE_ONLY,
	                     GL_R32F);
	gl->BindImageTexture(2, r->tex[2], 0, GL_FALSE, 0, GL_WRITE_ONLY,
	                     GL_R32UI);
	gl->DispatchCompute(p->gx, p->gy, 1);
}

/* Word slot of the statistics buffer as the passes issued so far leave
 * it (the host waits for them). The buffer stays bound to
 * GL_SHADER_STORAGE_BUFFER. */
static uint32_t stat_word(struct gl_renderer *r, uint32_t slot)
{
	GladGLContext *gl = &r->ctx.gl;
	uint32_t v = 0;
	gl->MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
	gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, r->bufs[BC__GL_BUF_STATS]);
	gl->GetBufferSubData(GL_SHADER_STORAGE_BUFFER, 4 * slot, 4, &v);
	return v;
}

/* Dispatches the tracing pass again while tiles are suspended (only with
 * a loop budget). Past the frame's time budget (counted from t_start) the
 * last dispatch tells suspended tiles to finish with what they found, and
 * *incomplete is set. Returns 0, BC_ELIMIT or BC_EGL. */
static int finish_tracing(struct gl_renderer *r, struct bc__gl_frame_ubo *u,
                          const struct plan *p, double t_start,
                          uint32_t *dispatches, bool *incomplete,
                          struct bc_errinfo *ei)
{
	GladGLContext *gl = &r->ctx.gl;
	static const uint32_t zero = 0;
	uint32_t budget_ms = r->base.opts.budget_ms;
	*dispatches = 1;
	*incomplete = false;
	while (r->budget && !*incomplete) {
		uint32_t suspended = stat_word(r, BC_GL_STAT_SUSPENDED);
		if (!suspended) {
			break;
		}
		if (*dispatches >= BC_GL_MAX_DISPATCHES) {
			return bc_errinfo_set(ei, BC_ELIMIT,
			                      "gl: %u tiles still unfinished "
			                      "after %u dispatches",
			                      suspended, *dispatches);
		}
		gl->ClearBufferSubData(GL_SHADER_STORAGE_BUFFER, GL_R32UI,
		                       4 * BC_GL_STAT_SUSPENDED, 4,
		                       GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
		if (budget_ms && bc_clock_ms() - t_start > (double)budget_ms) {
			/* Out of time: one last dispatch finishes every
			 * suspended tile with what it has. */
			u->pool[3] = 1;
			gl->BindBuffer(GL_UNIFORM_BUFFER, r->ubo);
			gl->BufferSubData(GL_UNIFORM_BUFFER, 0, sizeof(*u), u);
			*incomplete = true;
		}
		gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT |
		                  GL_UNIFORM_BARRIER_BIT);
		gl->DispatchCompute(p->gx, p->gy, 1);
		(*dispatches)++;
	}
	return bc__gl_check(&r->ctx, "tracing", ei);
}

/* Issues the copies of the planes and statistics into the readback
 * buffer, and of the Short words of a bounded frame (short_bytes of them;
 * 0: none). */
static void read_back(struct gl_renderer *r, const struct plan *p, uint32_t w,
                      uint32_t h, size_t short_bytes)
{
	GladGLContext *gl = &r->ctx.gl;
	size_t npix = (size_t)w * h;
	static const GLenum fmt[3] = {GL_RED_INTEGER, GL_RED, GL_RED_INTEGER};
	static const GLenum type[3] = {GL_UNSIGNED_INT, GL_FLOAT,
	                               GL_UNSIGNED_INT};
	gl->MemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT |
	                  GL_PIXEL_BUFFER_BARRIER_BIT |
	                  GL_BUFFER_UPDATE_BARRIER_BIT);
	gl->QueryCounter(r->queries[Q_TRACE], GL_TIMESTAMP);

	/* Readback: the planes and the statistics into one buffer, plane k
	 * at 4 * k * npix. A region's list reads only the rows of its
	 * tiles' bounding box (4.5's glGetTextureSubImage), at the offsets a
	 * whole plane would put them: an edit's damage on a 1080p view then
	 * moves a few rows, not 25 MB. */
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, r->pbo);
	gl->PixelStorei(GL_PACK_ALIGNMENT, 4);
	for (int k = 0; k < 3; k++) {
		size_t base = 4 * (size_t)k * npix;
		if (p->list && gl->GetTextureSubImage) {
			uint32_t y0 = p->box[1] * BC_GL_TILE;
			uint32_t y1 = p->box[3] * BC_GL_TILE < h
			                  ? p->box[3] * BC_GL_TILE
			                  : h;
			size_t bytes = 4 * (size_t)w * (y1 - y0);
			gl->GetTextureSubImage(
			    r->tex[k], 0, 0, (GLint)y0, 0, (GLsizei)w,
			    (GLsizei)(y1 - y0), 1, fmt[k], type[k],
			    (GLsizei)bytes,
			    (void *)(uintptr_t)(base + 4 * (size_t)w * y0));
		} else {
			gl->BindTexture(GL_TEXTURE_2D, r->tex[k]);
			gl->GetTexImage(GL_TEXTURE_2D, 0, fmt[k], type[k],
			                (void *)(uintptr_t)base);
		}
	}
	gl->BindTexture(GL_TEXTURE_2D, 0);
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
	gl->BindBuffer(GL_COPY_READ_BUFFER, r->bufs[BC__GL_BUF_STATS]);
	gl->BindBuffer(GL_COPY_WRITE_BUFFER, r->pbo);
	gl->CopyBufferSubData(GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, 0,
	                      (GLintptr)(12 * npix), BC_GL_STAT_WORDS * 4);
	if (short_bytes) {
		gl->BindBuffer(GL_COPY_READ_BUFFER, r->bufs[BC__GL_BUF_SHORT]);
		gl->CopyBufferSubData(
		    GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, 0,
		    (GLintptr)(12 * npix + BC_GL_STAT_WORDS * 4),
		    (GLsizeiptr)short_bytes);
	}
	gl->BindBuffer(GL_COPY_READ_BUFFER, 0);
	gl->BindBuffer(GL_COPY_WRITE_BUFFER, 0);
}

/* Waits for everything issued so far. */
static int wait_fence(struct gl_renderer *r, struct bc_errinfo *ei)
{
	GladGLContext *gl = &r->ctx.gl;
	GLsync fence = gl->FenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
	double start = bc_clock_ms();
	int rc = 0;
	if (!fence) {
		return bc__gl_check(&r->ctx, "glFenceSync", ei)
		           ? BC_EGL
		           : bc_errinfo_set(ei, BC_EGL,
		                            "gl: glFenceSync failed");
	}
	for (;;) {
		/* One second at a time, so a lost context is noticed. */
		GLenum s = gl->ClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT,
		                              1000000000ull);
		if (s == GL_ALREADY_SIGNALED || s == GL_CONDITION_SATISFIED) {
			break;
		}
		if (s == GL_WAIT_FAILED) {
			rc = bc__gl_check(&r->ctx, "glClientWaitSync", ei);
			if (!rc) {
				rc = bc_errinfo_set(ei, BC_EGL,
				                    "gl: glClientWaitSync "
				                    "failed");
			}
			break;
		}
		if (gl->GetGraphicsResetStatus &&
		    gl->GetGraphicsResetStatus() != GL_NO_ERROR) {
			rc = bc_errinfo_set(ei, BC_EGL,
			                    "gl: context lost during a frame");
			break;
		}
		if (bc_clock_ms() - start > BC_GL_FENCE_TIMEOUT_S * 1e3) {
			rc = bc_errinfo_set(ei, BC_ETIMEOUT,
			                    "gl: frame not done after %.0f s",
			                    BC_GL_FENCE_TIMEOUT_S);
			break;
		}
	}
	gl->DeleteSync(fence);
	return rc;
}

static double query_ms(struct gl_renderer *r, int a, int b)
{
	GLuint64 ta = 0, tb = 0;
	r->ctx.gl.GetQueryObjectui64v(r->queries[a], GL_QUERY_RESULT, &ta);
	r->ctx.gl.GetQueryObjectui64v(r->queries[b], GL_QUERY_RESULT, &tb);
	return tb > ta ? (double)(tb - ta) * 1e-6 : 0.0;
}

/* Traces the lists draw() built or took for plan, reads the frame back
 * and, when everything fit (*fits: the fragments in the capacity and the
 * limit, every suspended tile a slot), copies the plan's pixels into
 * out. stat gets
 * the frame's statistics words. Returns 0 or an error. */
static int trace_plan(struct gl_renderer *r, struct bc__gl_frame_ubo *u,
                      const struct plan *plan,
                      const struct bc_render_region *region, enum lists_use use,
                      uint32_t limit, double t_start, struct bc_frame *out,
                      struct bc_render_stats *stats, uint32_t *stat, bool *fits,
                      struct bc_errinfo *ei)
{
	GladGLContext *gl = &r->ctx.gl;
	uint32_t w = out->width, h = out->height, dispatches = 0;
	uint32_t ntiles = bc_render_tiles_x(w) * bc_render_tiles_y(h);
	size_t npix = (size_t)w * h;
	/* A bounded frame reads back which rays ran out. */
	size_t short_bytes =
	    region->max_evals ? (size_t)ntiles * BC_GL_SHORT_WORDS * 4 : 0;
	bool incomplete = false;
	void *map;
	int rc;
	*fits = false;
	trace(r, u, plan);
	if ((rc = finish_tracing(r, u, plan, t_start, &dispatches, &incomplete,
	                         ei))) {
		return rc;
	}
	read_back(r, plan, w, h, short_bytes);
	if ((rc = wait_fence(r, ei))) {
		return rc;
	}
	r->ctx.info.dispatches += dispatches;
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, r->pbo);
	map = gl->MapBufferRange(
	    GL_PIXEL_PACK_BUFFER, 0,
	    (GLsizeiptr)(12 * npix + BC_GL_STAT_WORDS * 4 + short_bytes),
	    GL_MAP_READ_BIT);
	if (!map) {
		gl->BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
		rc = bc__gl_check(&r->ctx, "glMapBufferRange", ei);
		return rc ? rc
		          : bc_errinfo_set(ei, BC_EGL,
		                           "gl: glMapBufferRange failed");
	}
	memcpy(stat, (const char *)map + 12 * npix,
	       BC_GL_STAT_WORDS * sizeof(*stat));
	if (use == LISTS_KEPT) {
		stat[BC_GL_STAT_FRAGMENTS] = r->lists_frags;
		stat[BC_GL_STAT_MAX_OVERLAP] = r->lists_max;
	}
	*fits = stat[BC_GL_STAT_FRAGMENTS] <= r->frag_cap &&
	        stat[BC_GL_STAT_FRAGMENTS] <= limit &&
	        stat[BC_GL_STAT_NO_SLOT] == 0;
	if (*fits) {
		const char *shorts =
		    short_bytes
		        ? (const char *)map + 12 * npix + BC_GL_STAT_WORDS * 4
		        : NULL;
		copy_region(r, plan, map, shorts, out);
		if (shorts) {
			stats->short_rays += mark_short(r, plan, shorts, ntiles,
			                                region->short_tiles);
		}
		stats->incomplete = stats->incomplete || incomplete;
	}
	gl->UnmapBuffer(GL_PIXEL_PACK_BUFFER);
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
	return 0;
}

/* Draws plan's tiles of region into out: the A-buffer built for every tile
 * and kept, taken from an earlier call of the view, or built for the
 * plan's tiles alone (a region of a few tiles; always for a band, whose
 * buffers the next band reuses). Adds to stats and to the context's
 * counters of the frame. When the plan's lists pass the A-buffer's limit
 * nothing is copied into out, *need is set to the fragments they need
 * (0 otherwise) and 0 is returned. Returns 0 or an error. */
static int draw_plan(struct gl_renderer *r, const struct bc_camera *cam,
                     const struct bc_render_region *region,
                     const struct plan *plan, bool band, double t_start,
                     struct bc_frame *out, struct bc_render_stats *stats,
                     uint32_t *need, struct bc_errinfo *ei)
{
	const struct bc_lin *l = bc_tree_lin(r->tree);
	struct bc__gl_frame_ubo u;
	uint32_t w = out->width, h = out->height;
	uint32_t ntiles = bc_render_tiles_x(w) * bc_render_tiles_y(h);
	uint32_t nprims = l ? r->nprims : 0, stat[BC_GL_STAT_WORDS], limit;
	uint32_t retries = 0;
	enum lists_use use;
	int rc;
	*need = 0;
	upload_region(r, plan, w, h);
	for (;;) {
		uint32_t tiles;
		bool fits;
		frame_setup(&u, l, cam, out, r->base.opts.debug, nprims,
		            r->frag_cap, r->slots, r->budget);
		u.region[0] = plan->level;
		u.region[1] = plan->refine ? 1u : 0u;
		u.region[2] = plan->nlist;
		u.region[3] = plan->list ? 1u : 0u;
		u.bound[0] = region->max_evals;
		u.bound[1] = plan->box[0] | plan->box[1] << 16;
		u.bound[2] = plan->box[2] | plan->box[3] << 16;
		tiles = u.size[2] * u.size[3];
		/* The view's lists, kept from an earlier call, or built: for
		 * every tile (and kept) unless the region is a few tiles of
		 * it, such as an edit's damage, or a band. */
		if (!band && r->lists_kept && same_view(&u, &r->lists_u)) {
			use = LISTS_KEPT;
			r->lists_reused++;
		} else if (!band && plan_wide(plan, ntiles)) {
			use = LISTS_ALL;
			r->lists_builds++;
		} else {
			use = LISTS_REGION;
		}
		r->lists_kept = false;
		draw(r, &u, plan, nprims, use);
		if ((rc = bc__gl_check(&r->ctx, "drawing a frame", ei))) {
			return rc;
		}
		limit = frag_limit(r);
		fits = true;
		if (band || use == LISTS_ALL) {
			/* Lists of a new view or a band may pass the
			 * capacity or the limit: their count, read before
			 * tracing, spares tracing a frame that would be
			 * thrown away (on llvmpipe a million spheres' first
			 * 1080p frame took 82 s with it, 61 s without). A frame
			 * whose lists fit pays one round trip between host
			 * and GPU before its tracing starts. */
			memset(stat, 0, sizeof(stat));
			stat[BC_GL_STAT_FRAGMENTS] =
			    stat_word(r, BC_GL_STAT_FRAGMENTS);
			if ((rc = bc__gl_check(&r->ctx, "counting fragments",
			                       ei))) {
				return rc;
			}
			fits = stat[BC_GL_STAT_FRAGMENTS] <= r->frag_cap &&
			       stat[BC_GL_STAT_FRAGMENTS] <= limit;
		}
		if (fits) {
			if ((rc = trace_plan(r, &u, plan, region, use, limit,
			                     t_start, out, stats, stat, &fits,
			                     ei))) {
				return rc;
			}
		}
		if (fits) {
			if (use == LISTS_ALL) {
				/* pool[3] is set when out of time, which
				 * is no part of the view. */
				r->lists_kept = true;
				r->lists_u = u;
				r->lists_u.pool[3] = 0;
				r->lists_frags = stat[BC_GL_STAT_FRAGMENTS];
				r->lists_max = stat[BC_GL_STAT_MAX_OVERLAP];
			} else if (use == LISTS_KEPT) {
				r->lists_kept = true;
			}
			break;
		}
		/* Too many fragments or suspended tiles: both counts are
		 * exact, so a draw with room for them (and some to spare)
		 * fits. Two retries cover growing both. Past the limit the
		 * caller draws in bands, and a band past the capacity is
		 * drawn in fewer rows rather than in larger buffers. */
		if (stat[BC_GL_STAT_FRAGMENTS] > limit ||
		    (band && stat[BC_GL_STAT_FRAGMENTS] > r->frag_cap)) {
			*need = stat[BC_GL_STAT_FRAGMENTS];
			r->ctx.info.retries += retries;
			return 0;
		}
		if (retries >= 2) {
			return bc_errinfo_set(
			    ei, BC_ELIMIT,
			    "gl: %u A-buffer fragments and %u "
			    "suspended tiles still do not fit "
			    "after growing the buffers twice",
			    stat[BC_GL_STAT_FRAGMENTS], stat[BC_GL_STAT_SLOTS]);
		}
		{
			uint64_t want =
			    (uint64_t)stat[BC_GL_STAT_FRAGMENTS] * 3 / 2;
			uint64_t slots =
			    (uint64_t)stat[BC_GL_STAT_SLOTS] * 3 / 2;
			uint32_t cap = r->frag_cap;
			if (stat[BC_GL_STAT_FRAGMENTS] > r->frag_cap) {
				cap = want < limit ? (uint32_t)want : limit;
			}
			if (slots < r->slots) {
				slots = r->slots;
			}
			frag_buffers(r, cap,
			             slots < tiles ? (uint32_t)slots : tiles);
		}
		retries++;
	}
	r->ctx.info.retries += retries;
	if (r->budget &&
	    stat[BC_GL_STAT_MAX_OVERLAP] > BC_GL_LLVMPIPE_SORT_MAX) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "gl: a tile lists %u primitives, more than "
		    "llvmpipe's loop limit lets one shader "
		    "sort (%u)",
		    stat[BC_GL_STAT_MAX_OVERLAP], BC_GL_LLVMPIPE_SORT_MAX);
	}
	if (stat[BC_GL_STAT_OVER_VIEW]) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "gl: %u depth ranges need more view "
		                      "instructions (unary nodes) than a tile "
		                      "holds",
		                      stat[BC_GL_STAT_OVER_VIEW]);
	}
	if (stat[BC_GL_STAT_OVER_BUDGET]) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "gl: %u depth ranges need more loop iterations than "
		    "llvmpipe allows one shader invocation (too many "
		    "primitives meet at one depth in one tile)",
		    stat[BC_GL_STAT_OVER_BUDGET]);
	}
	r->ctx.info.fragments += stat[BC_GL_STAT_FRAGMENTS];
	r->ctx.info.suspensions += stat[BC_GL_STAT_SLOTS];
	r->ctx.info.ranges += stat[BC_GL_STAT_RANGES];
	r->ctx.info.over_m += stat[BC_GL_STAT_OVER_M];
	r->ctx.info.over_cache += stat[BC_GL_STAT_OVER_CACHE];
	r->ctx.info.ranges_general += stat[BC_GL_STAT_GENERAL];
	if (stat[BC_GL_STAT_OVER_M]) {
		bc_log(BC_LOG_DEBUG, "gl: %u depth ranges went over M_overlap",
		       stat[BC_GL_STAT_OVER_M]);
	}
	stats->ms_abuffer += query_ms(r, Q_START, Q_ABUFFER);
	stats->ms_trace += query_ms(r, Q_ABUFFER, Q_TRACE);
	stats->ms_upload += r->upload_ms;
	if (stat[BC_GL_STAT_MAX_OVERLAP] > stats->max_overlap) {
		stats->max_overlap = stat[BC_GL_STAT_MAX_OVERLAP];
	}
	stats->tiles += plan->tiles;
	stats->rays += plan->rays;
	for (uint32_t i = 0; i < BC_GL_STAT_EVAL_BUCKETS; i++) {
		stats->field_evals += stat[BC_GL_STAT_EVALS + i];
	}
	r->upload_ms = 0.0;
	return bc__gl_check(&r->ctx, "reading a frame back", ei);
}

/* The least room bands are drawn in, when the buffers the view has are
 * smaller (a band of a few rows per pass over every imposter would be
 * slow): 2^20 fragments (56 MiB), or an eighth of a lower limit. */
#define BAND_MIN_ROOM (1u << 20)

/* Draws whole's tiles (the call's plan) in bands of whole tile rows, each
 * drawn as a region of its own within the A-buffer's limit: a view whose
 * lists together pass the limit (need: the fragments they need) is drawn
 * a band at a time. A tile's list does not depend on the other tiles', so
 * the pixels are those of one pass. Bands are drawn in the buffers the
 * view has (at least BAND_MIN_ROOM or an eighth of the limit, at most the
 * limit), not grown to the limit: at 2^24 fragments they would be 896 MiB, and
 * the daemon counts what a renderer keeps against its cap on views (on llvmpipe
 * it is host memory). Bands are sized from need's average over the rows to fill
 * three quarters of that room, so that most fit it at once; a band that
 * passes the limit is drawn again in fewer rows (in proportion), a band
 * that fits lets the next one grow back (doubling), and a single tile row
 * that passes the limit is refused. Reports progress by tile rows
 * (bc_renderer_set_progress). */
static int draw_bands(struct gl_renderer *r, const struct bc_camera *cam,
                      const struct bc_render_region *region,
                      const struct plan *whole, uint32_t need, double t_start,
                      struct bc_frame *out, struct bc_render_stats *stats,
                      struct bc_errinfo *ei)
{
	uint32_t w = out->width, h = out->height, tw = bc_render_tiles_x(w);
	uint32_t th = bc_render_tiles_y(h), limit = frag_limit(r);
	uint32_t y0 = whole->list ? whole->box[1] : 0, y = y0;
	uint32_t y1 = whole->list ? whole->box[3] : th;
	uint32_t least = BAND_MIN_ROOM < limit / 8 ? BAND_MIN_ROOM : limit / 8;
	uint32_t room = r->frag_cap > least ? r->frag_cap : least;
	uint64_t aim, base, per;
	struct bc_render_region band = *region;
	struct bc_render_progress prog;
	uint8_t *mask = bc_malloc((size_t)tw * th);
	int rc = 0;
	if (!mask) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "gl: out of memory for a band's tiles");
	}
	room = room < limit ? room : limit;
	room = room > 0 ? room : 1;
	if (r->frag_cap < room) {
		frag_buffers(r, room, r->slots);
	}
	aim = (uint64_t)room / 4 * 3 > 0 ? (uint64_t)room / 4 * 3 : 1;
	base = (uint64_t)(y1 - y) * aim / (need > 0 ? need : 1);
	base = base > 0 ? base : 1;
	per = base;
	band.tiles = mask;
	stats->bands = 0;
	/* Progress by tile rows (a banded frame of a million spheres on
	 * llvmpipe takes minutes). */
	bc_render_progress_init(&prog, &r->base, y1 - y0);
	prog.start = t_start;
	while (y < y1 && rc == 0) {
		uint32_t n = per < y1 - y ? (uint32_t)per : y1 - y, got = 0;
		struct plan p;
		memset(mask, 0, (size_t)tw * th);
		for (uint32_t i = y * tw; i < (y + n) * tw; i++) {
			mask[i] = !region->tiles || region->tiles[i];
		}
		if (plan_region(r, &band, w, h, &p)) {
			rc = bc_errinfo_set(ei, BC_ENOMEM,
			                    "gl: out of memory for a region");
			break;
		}
		if (p.tiles > 0 &&
		    (rc = draw_plan(r, cam, &band, &p, true, t_start, out,
		                    stats, &got, ei)) == 0 &&
		    got > 0) {
			if (n == 1 && got > limit) {
				rc = bc_errinfo_set(
				    ei, BC_ELIMIT,
				    "gl: tile row %u alone needs %u A-buffer "
				    "fragments, over the limit of %u (fewer "
				    "or smaller primitives, or a narrower "
				    "frame)",
				    y, got, limit);
				break;
			}
			if (n == 1) {
				/* One row past the room: the room grows
				 * to hold it, with some to spare. */
				uint64_t more = (uint64_t)got + got / 2;
				room = more < limit ? (uint32_t)more : limit;
				frag_buffers(r, room, r->slots);
				aim = (uint64_t)room / 4 * 3;
				continue;
			}
			per = (uint64_t)n * aim / got;
			per = per < 1 ? 1 : per >= n ? n - 1u : per;
			continue;
		}
		stats->bands += p.tiles > 0;
		y += n;
		bc_render_progress_tick(&prog, y - y0);
		per = 2 * (uint64_t)n < base ? 2 * (uint64_t)n : base;
	}
	bc_free(mask);
	return rc;
}

/* Whether the view of cam and out is the one r last had to draw in bands
 * (r->band_u: its frame constants with no capacity and no region). */
static bool banded_view(struct gl_renderer *r, const struct bc_camera *cam,
                        const struct bc_frame *out,
                        struct bc__gl_frame_ubo *view)
{
	const struct bc_lin *l = bc_tree_lin(r->tree);
	frame_setup(view, l, cam, out, r->base.opts.debug, l ? r->nprims : 0, 0,
	            0, r->budget);
	return r->band_need > 0 && same_view(view, &r->band_u);
}

/* Draws region's pixels of the synced tree (see the file comment). The
 * front checked the frame, the camera and the level, and zeroed stats. */
static int gl_render(struct bc_renderer *base, const struct bc_camera *cam,
                     struct bc_frame *out,
                     const struct bc_render_region *region,
                     struct bc_render_stats *stats, struct bc_errinfo *ei)
{
	struct gl_renderer *r = gl_of(base);
	struct bc__gl_frame_ubo view;
	struct plan plan;
	const struct bc_lin *l;
	double t_start = bc_clock_ms();
	uint32_t w, h, nprims, need = 0;
	bool banded;
	int rc = 0;
	if (!r->tree || !r->synced) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "render: no tree synced yet");
	}
	w = out->width;
	h = out->height;
	if (plan_region(r, region, w, h, &plan)) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "gl: out of memory for a region");
	}
	if (plan.tiles == 0) {
		return 0; /* no pixel asked: nothing to draw */
	}
	if ((rc = enter(r, ei))) {
		return rc;
	}
	l = bc_tree_lin(r->tree);
	nprims = l ? r->nprims : 0;
	frame_buffers(r, w, h);
	if (r->want_cap) {
		uint32_t limit = frag_limit(r);
		frag_buffers(r, r->want_cap < limit ? r->want_cap : limit,
		             r->slots);
		r->want_cap = 0;
	} else if (r->frag_cap == 0) {
		uint64_t want = 4 * (uint64_t)((w + 7) / 8) * ((h + 7) / 8) +
		                4 * (uint64_t)nprims;
		uint32_t limit = frag_limit(r);
		want = want > BC_GL_MIN_FRAGMENTS ? want : BC_GL_MIN_FRAGMENTS;
		frag_buffers(r, want < limit ? (uint32_t)want : limit,
		             r->slots);
	}
	if (r->budget && r->slots == 0) {
		uint32_t tiles = ((w + 7) / 8) * ((h + 7) / 8);
		frag_buffers(r, r->frag_cap,
		             tiles < BC_GL_MIN_SLOTS ? tiles : BC_GL_MIN_SLOTS);
	}
	r->ctx.info.fragments = r->ctx.info.suspensions = 0;
	r->ctx.info.ranges = r->ctx.info.over_m = r->ctx.info.over_cache = 0;
	r->ctx.info.ranges_general = r->ctx.info.dispatches = 0;
	r->ctx.info.retries = 0;
	/* A view known to pass the limit: a whole frame goes to bands at
	 * once, a region tries its own tiles' lists first. */
	banded = banded_view(r, cam, out, &view);
	if (banded && plan_wide(&plan, (uint64_t)bc_render_tiles_x(w) *
	                                   bc_render_tiles_y(h))) {
		need = r->band_need;
	} else {
		rc = draw_plan(r, cam, region, &plan, banded, t_start, out,
		               stats, &need, ei);
	}
	if (rc == 0 && need > 0) {
		if (!banded || need > r->band_need) {
			r->band_u = view;
			r->band_need = need;
		}
		rc = draw_bands(r, cam, region, &plan, need, t_start, out,
		                stats, ei);
	} else if (rc == 0) {
		stats->bands = 1;
	}
	bc__gl_ctx_unbind(&r->ctx);
	stats->ms_total = bc_clock_ms() - t_start;
	return rc;
}

/* The tiles abuffer.geom can give a primitive of world ABV abv: its AABB
 * widened by the hit margin (common.glsl's bc_abv_margin), projected, and
 * rounded out to tiles, with the shader's pixel of margin and one more
 * for the difference between this float arithmetic and the driver's. A
 * corner near or behind the eye plane marks every tile, as the shader
 * lists every tile for an AABB straddling it; only an AABB wholly behind
 * the eye, by a margin, marks nothing. Conservative: a tile the shader
 * may list is always marked. */
static void gl_damage(struct bc_renderer *base, const struct bc_camera *cam,
                      uint32_t width, uint32_t height, const struct bc_abv *abv,
                      uint8_t *tiles)
{
	uint32_t tw = bc_render_tiles_x(width), th = bc_render_tiles_y(height);
	struct bc_view_rays vr;
	float scale =
	    bc_render_scale(base->tree ? bc_tree_lin(base->tree) : NULL);
	float lo[3], hi[3], c[3], e[3], far, m, footprint;
	double px0 = INFINITY, px1 = -INFINITY, py0 = INFINITY, py1 = -INFINITY;
	double w = width, h = height;
	uint32_t front = 0, behind = 0, x0, x1, y0, y1;
	bc_view_rays_init(&vr, cam, width, height);
	bc_abv_aabb(abv, lo, hi);
	for (int i = 0; i < 3; i++) {
		c[i] = 0.5f * (lo[i] + hi[i]) - vr.eye[i];
		e[i] = 0.5f * (hi[i] - lo[i]);
	}
	far = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) +
	      sqrtf(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
	footprint = 2.0f * vr.tan_half_y / (float)height;
	m = 0.5f * footprint * far;
	if (m < BC_GL_MIN_STEP_REL * scale) {
		m = BC_GL_MIN_STEP_REL * scale;
	}
	/* 1.45 as the shader's BC_LIPSCHITZ times the tree's bound (its
	 * u_misc.z), and a little more for rounding. */
	m *= 1.45f * 1.001f;
	if (base->tree && bc_tree_lin(base->tree)) {
		m *= bc_tree_lin(base->tree)->lip;
	}
	for (uint32_t k = 0; k < 8; k++) {
		double v[3], z, sx, sy, s = 0.0;
		for (int i = 0; i < 3; i++) {
			double p = (k >> i) & 1u ? (double)hi[i] + m
			                         : (double)lo[i] - m;
			v[i] = p - vr.eye[i];
			s += fabs(v[i]);
		}
		z = v[0] * vr.forward[0] + v[1] * vr.forward[1] +
		    v[2] * vr.forward[2];
		if (z < 0.0) {
			behind++;
		}
		if (!(z > 1.0e-5 * s)) {
			continue;
		}
		front++;
		sx = (v[0] * vr.right[0] + v[1] * vr.right[1] +
		      v[2] * vr.right[2]) /
		     (z * vr.tan_half_y * vr.aspect);
		sy = (v[0] * vr.up[0] + v[1] * vr.up[1] + v[2] * vr.up[2]) /
		     (z * vr.tan_half_y);
		px0 = fmin(px0, (sx + 1.0) * 0.5 * w);
		px1 = fmax(px1, (sx + 1.0) * 0.5 * w);
		py0 = fmin(py0, (1.0 - sy) * 0.5 * h);
		py1 = fmax(py1, (1.0 - sy) * 0.5 * h);
	}
	if (behind == 8) {
		return;
	}
	if (front < 8 || !isfinite(px0) || !isfinite(px1) || !isfinite(py0) ||
	    !isfinite(py1)) {
		memset(tiles, 1, (size_t)tw * th);
		return;
	}
	px0 = fmax(px0 - 2.5, 0.0);
	py0 = fmax(py0 - 2.5, 0.0);
	px1 = fmin(px1 + 1.5, w - 1.0);
	py1 = fmin(py1 + 1.5, h - 1.0);
	if (!(px0 <= px1 && py0 <= py1)) {
		return;
	}
	x0 = (uint32_t)px0 / BC_GL_TILE;
	y0 = (uint32_t)py0 / BC_GL_TILE;
	x1 = (uint32_t)px1 / BC_GL_TILE + 1;
	y1 = (uint32_t)py1 / BC_GL_TILE + 1;
	for (uint32_t ty = y0; ty < y1 && ty < th; ty++) {
		memset(tiles + (size_t)ty * tw + x0, 1,
		       (x1 < tw ? x1 : tw) - x0);
	}
}

/* Frees the storage of everything sized for the last view: the images
 * and the readback buffer, the tile table and Short words, the A-buffer's
 * fragments and the tracer's scratch, the region's tile list. The next
 * render allocates them again as the first did (fragment room for what the
 * last frame had, so it need not draw twice), and since no pixel depends
 * on where these live or how large they are, it draws the same pixels. */
static void gl_release(struct bc_renderer *base)
{
	static const int per_view[] = {BC__GL_BUF_LINKS,  BC__GL_BUF_TILES,
	                               BC__GL_BUF_SORTED, BC__GL_BUF_SCRATCH,
	                               BC__GL_BUF_REGION, BC__GL_BUF_SHORT};
	struct gl_renderer *r = gl_of(base);
	GladGLContext *gl = &r->ctx.gl;
	bc_free(r->region);
	r->region = NULL;
	r->region_cap = 0;
	if (enter(r, NULL)) {
		return; /* a lost context: nothing on it to free */
	}
	gl->DeleteTextures(3, r->tex);
	memset(r->tex, 0, sizeof(r->tex));
	r->tex_w = r->tex_h = 0;
	gl->BindBuffer(GL_COPY_WRITE_BUFFER, r->lists_tiles);
	gl->BufferData(GL_COPY_WRITE_BUFFER, 0, NULL, GL_DYNAMIC_COPY);
	gl->BindBuffer(GL_COPY_WRITE_BUFFER, 0);
	r->lists_tiles_size = 0;
	r->lists_kept = false;
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, r->pbo);
	gl->BufferData(GL_PIXEL_PACK_BUFFER, 0, NULL, GL_STREAM_READ);
	gl->BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
	r->pbo_size = 0;
	for (size_t i = 0; i < sizeof(per_view) / sizeof(per_view[0]); i++) {
		buf_alloc(r, per_view[i], 0, NULL);
	}
	if (!r->want_cap && r->frag_cap) {
		r->want_cap = r->frag_cap;
	}
	r->frag_cap = 0;
	(void)bc__gl_check(&r->ctx, "releasing a view", NULL);
	bc__gl_ctx_unbind(&r->ctx);
}

/* What gl_release frees: the per-view buffers above their floor of 64
 * bytes, the images (12 bytes a pixel), the readback buffer and the host
 * tile list. */
static size_t gl_kept_bytes(const struct bc_renderer *base)
{
	static const int per_view[] = {BC__GL_BUF_LINKS,  BC__GL_BUF_TILES,
	                               BC__GL_BUF_SORTED, BC__GL_BUF_SCRATCH,
	                               BC__GL_BUF_REGION, BC__GL_BUF_SHORT};
	const struct gl_renderer *r = (const struct gl_renderer *)base;
	size_t n = 12 * (size_t)r->tex_w * r->tex_h + r->pbo_size +
	           r->lists_tiles_size + r->region_cap * sizeof(*r->region);
	for (size_t i = 0; i < sizeof(per_view) / sizeof(per_view[0]); i++) {
		if (r->buf_size[per_view[i]] > 64) {
			n += r->buf_size[per_view[i]];
		}
	}
	return n;
}

int bc_render_gl_info(const struct bc_renderer *base, struct bc_gl_info *out)
{
	const struct gl_renderer *r = (const struct gl_renderer *)base;
	memset(out, 0, sizeof(*out));
	if (!base || base->ops != &bc_backend_gl_ops) {
		return BC_EINVAL;
	}
	*out = r->ctx.info;
	out->program_builds = r->builds;
	out->upload_bytes = r->upload_bytes;
	out->upload_full = r->upload_full;
	out->full_uploads = r->full_uploads;
	out->lists_built = r->lists_builds;
	out->lists_reused = r->lists_reused;
	return 0;
}

int bc_render_gl_set_capacity(struct bc_renderer *base, uint32_t fragments)
{
	if (!base || base->ops != &bc_backend_gl_ops || fragments == 0) {
		return BC_EINVAL;
	}
	gl_of(base)->want_cap = fragments;
	return 0;
}

int bc_render_gl_set_loop_budget(struct bc_renderer *base, uint32_t iterations)
{
	struct gl_renderer *r = gl_of(base);
	if (!base || base->ops != &bc_backend_gl_ops ||
	    (iterations != 0 && iterations < BC_GL_MIN_LOOP_BUDGET)) {
		return BC_EINVAL;
	}
	if (iterations == 0 ||
	    (r->driver_budget && iterations > r->driver_budget)) {
		iterations = r->driver_budget;
	}
	r->budget = iterations;
	r->ctx.info.loop_budget = iterations;
	return 0;
}

const struct bc_backend_ops bc_backend_gl_ops = {
    .name = "gl",
    .create = gl_create,
    .destroy = gl_destroy,
    .sync = gl_sync,
    .render = gl_render,
    /* The scene scale the minimal step, the bisection tolerance and the
     * A-buffer's margins derive from, and the Lipschitz bound. */
    .key = bc_render_scale_key,
    .damage = gl_damage,
    .whole_regions = true,
    .release = gl_release,
    .kept_bytes = gl_kept_bytes,
};
