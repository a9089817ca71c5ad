/*
 * The front of blobcast/render.h: which backends this build holds, their
 * names, frames, and the functions every caller goes through. They check a
 * frame, a camera and a region once, keep the base part of every renderer
 * (tree, options, structure generation), decide when a region must become
 * the whole frame (the frame's key), and hand the rest to the backend. The
 * backends are compiled in when CMake found their libraries (it defines
 * BLOBCAST_HAVE_CPU, _GL, _SVO); a backend not built in is simply absent.
 */
#include "blobcast/render.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/render_backend.h"

#if defined(BLOBCAST_HAVE_CPU)
extern const struct bc_backend_ops bc_backend_naive_ops;
extern const struct bc_backend_ops bc_backend_tiled_ops;
#endif
#if defined(BLOBCAST_HAVE_GL)
extern const struct bc_backend_ops bc_backend_gl_ops;
#endif
#if defined(BLOBCAST_HAVE_SVO)
extern const struct bc_backend_ops bc_backend_svo_ops;
#endif

static const char *const names[BC_BACKEND_COUNT] = {
    [BC_BACKEND_NAIVE] = "naive",
    [BC_BACKEND_TILED] = "tiled",
    [BC_BACKEND_GL] = "gl",
    [BC_BACKEND_SVO] = "svo",
};

static const struct bc_backend_ops *backend_ops(enum bc_backend b)
{
	switch (b) {
#if defined(BLOBCAST_HAVE_CPU)
	case BC_BACKEND_NAIVE:
		return &bc_backend_naive_ops;
	case BC_BACKEND_TILED:
		return &bc_backend_tiled_ops;
#endif
#if defined(BLOBCAST_HAVE_GL)
	case BC_BACKEND_GL:
		return &bc_backend_gl_ops;
#endif
#if defined(BLOBCAST_HAVE_SVO)
	case BC_BACKEND_SVO:
		return &bc_backend_svo_ops;
#endif
	default:
		return NULL;
	}
}

enum bc_backend bc_backend_from_name(const char *name)
{
	if (!name) {
		return BC_BACKEND_INVALID;
	}
	for (int b = BC_BACKEND_INVALID + 1; b < BC_BACKEND_COUNT; b++) {
		if (strcmp(name, names[b]) == 0) {
			return (enum bc_backend)b;
		}
	}
	return BC_BACKEND_INVALID;
}

const char *bc_backend_name(enum bc_backend b)
{
	/* Never NULL, so callers may print it unchecked. */
	if ((int)b <= BC_BACKEND_INVALID || b >= BC_BACKEND_COUNT) {
		return "invalid";
	}
	return names[b];
}

bool bc_backend_available(enum bc_backend b)
{
	return backend_ops(b) != NULL;
}

int bc_frame_init(struct bc_frame *f, uint32_t width, uint32_t height)
{
	size_t n;
	memset(f, 0, sizeof(*f));
	if (width == 0 || height == 0 || width > BC_RENDER_MAX_DIM ||
	    height > BC_RENDER_MAX_DIM) {
		return BC_ERANGE;
	}
	n = (size_t)width * height;
	/* On whole cache lines: the CPU backends' threads draw runs of 8
	 * tiles (whole lines of a row whose width is a multiple of 16) side
	 * by side. */
	f->rgba = bc_malloc_lines(4 * n);
	f->depth = bc_malloc_lines(n * sizeof(*f->depth));
	f->ids = bc_malloc_lines(n * sizeof(*f->ids));
	if (!f->rgba || !f->depth || !f->ids) {
		bc_frame_finish(f);
		return BC_ENOMEM;
	}
	f->width = width;
	f->height = height;
	return 0;
}

int bc_frame_window(struct bc_frame *f, uint32_t x, uint32_t y,
                    uint32_t full_width, uint32_t full_height)
{
	if (full_width == 0) {
		f->win_x = f->win_y = f->full_width = f->full_height = 0;
		f->key = 0;
		return 0;
	}
	if (full_width > BC_RENDER_MAX_DIM || full_height > BC_RENDER_MAX_DIM ||
	    x >= full_width || y >= full_height || f->width > full_width - x ||
	    f->height > full_height - y) {
		return BC_ERANGE;
	}
	f->win_x = x;
	f->win_y = y;
	f->full_width = full_width;
	f->full_height = full_height;
	f->key = 0;
	return 0;
}

void bc_frame_finish(struct bc_frame *f)
{
	if (!f) {
		return;
	}
	bc_free(f->rgba);
	bc_free(f->depth);
	bc_free(f->ids);
	memset(f, 0, sizeof(*f));
}

/* ---- The front ---------------------------------------------------------- */

int bc_renderer_create(struct bc_renderer **out, enum bc_backend b,
                       const struct bc_render_opts *opts, struct bc_errinfo *ei)
{
	const struct bc_backend_ops *ops = backend_ops(b);
	struct bc_render_opts o = {0};
	int rc;
	*out = NULL;
	if (!ops) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "render: backend '%s' is not built in",
		                      bc_backend_name(b));
	}
	if (opts) {
		o = *opts;
	}
	if ((unsigned)o.debug >= BC_DEBUG_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM,
		                      "render: debug mode %d out of range",
		                      (int)o.debug);
	}
	if ((unsigned)o.simd >= BC_SIMD_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM,
		                      "render: simd mode %d out of range",
		                      (int)o.simd);
	}
	if ((rc = ops->create(out, &o, ei))) {
		*out = NULL;
		return rc;
	}
	(*out)->ops = ops;
	(*out)->backend = b;
	(*out)->opts = o;
	/* Strings belong to the caller; backends copy what they need. */
	(*out)->opts.gl_platform = NULL;
	(*out)->tree = NULL;
	(*out)->generation = 1;
	return 0;
}

void bc_renderer_destroy(struct bc_renderer *r)
{
	if (r) {
		r->ops->destroy(r);
	}
}

enum bc_backend bc_renderer_backend(const struct bc_renderer *r)
{
	return r ? r->backend : BC_BACKEND_INVALID;
}

bool bc_renderer_follows(const struct bc_renderer *r,
                         const struct bc_dirty *dirty)
{
	return r && r->tree && dirty && dirty->spliced &&
	       r->ops->follows_splices;
}

bool bc_renderer_wants_large_regions(const struct bc_renderer *r)
{
	return r && r->ops->whole_regions;
}

int bc_renderer_sync(struct bc_renderer *r, const struct bc_tree *t,
                     const struct bc_dirty *dirty, struct bc_errinfo *ei)
{
	if (!r || !t) {
		return bc_errinfo_set(ei, BC_EINVAL, "render: no tree to sync");
	}
	if (!bc_renderer_follows(r, dirty) &&
	    (!dirty || dirty->structure || t != r->tree)) {
		r->generation++;
	}
	r->tree = t;
	return r->ops->sync ? r->ops->sync(r, t, dirty, ei) : 0;
}

/* FNV-1a over the bytes of what shapes every pixel of a frame. */
static uint64_t hash_bytes(uint64_t h, const void *p, size_t n)
{
	const uint8_t *b = p;
	for (size_t i = 0; i < n; i++) {
		h = (h ^ b[i]) * 0x100000001b3ull;
	}
	return h;
}

static uint64_t frame_key(struct bc_renderer *r, const struct bc_camera *cam,
                          const struct bc_frame *f)
{
	uint64_t k = 0xcbf29ce484222325ull, backend = 0;
	uint32_t w = f->width, h = f->height;
	uint32_t dims[3] = {w, h, (uint32_t)r->opts.debug};
	if (r->ops->key) {
		backend = r->ops->key(r, cam, w, h);
	}
	k = hash_bytes(k, cam, sizeof(*cam));
	k = hash_bytes(k, dims, sizeof(dims));
	if (f->full_width) {
		/* Another window of the view is other pixels. A whole frame
		 * hashes as before windows existed. */
		uint32_t win[4] = {f->win_x, f->win_y, f->full_width,
		                   f->full_height};
		k = hash_bytes(k, win, sizeof(win));
	}
	k = hash_bytes(k, &r->generation, sizeof(r->generation));
	k = hash_bytes(k, &backend, sizeof(backend));
	return k ? k : 1; /* 0 means "nothing rendered" */
}

int bc_renderer_render_region(struct bc_renderer *r,
                              const struct bc_camera *cam, struct bc_frame *out,
                              const struct bc_render_region *region,
                              struct bc_render_stats *stats,
                              struct bc_errinfo *ei)
{
	struct bc_render_stats local;
	struct bc_render_region whole = {0};
	uint64_t key;
	int rc;
	if (!stats) {
		stats = &local;
	}
	memset(stats, 0, sizeof(*stats));
	if (!r || !cam || !out || !out->rgba || out->width == 0 ||
	    out->height == 0 || out->width > BC_RENDER_MAX_DIM ||
	    out->height > BC_RENDER_MAX_DIM) {
		return bc_errinfo_set(ei, BC_EINVAL, "render: bad frame");
	}
	if (out->full_width &&
	    (out->full_width > BC_RENDER_MAX_DIM ||
	     out->full_height > BC_RENDER_MAX_DIM ||
	     out->win_x >= out->full_width || out->win_y >= out->full_height ||
	     out->width > out->full_width - out->win_x ||
	     out->height > out->full_height - out->win_y)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "render: window %ux%u at (%u, %u) not "
		                      "inside a %ux%u view",
		                      out->width, out->height, out->win_x,
		                      out->win_y, out->full_width,
		                      out->full_height);
	}
	if (region && region->level > BC_RENDER_MAX_LEVEL) {
		return bc_errinfo_set(ei, BC_ERANGE, "render: level %u over %u",
		                      region->level, BC_RENDER_MAX_LEVEL);
	}
	if (!r->tree) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "render: no tree synced yet");
	}
	if ((rc = bc_camera_validate(cam, ei))) {
		return rc;
	}
	key = frame_key(r, cam, out);
	if (!region) {
		region = &whole;
	} else if (region->tile_count &&
	           ((uint64_t)region->tile_first + region->tile_count >
	            (uint64_t)bc_render_tiles_x(out->width) *
	                bc_render_tiles_y(out->height))) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "render: tiles %u..%u past the frame's",
		                      region->tile_first,
		                      region->tile_first + region->tile_count);
	} else if (out->key != key && (region->tiles || region->refine) &&
	           !region->adopt_key) {
		/* The frame holds another rendering: redraw all of it at
		 * this level, within the caller's bound (its scheduler
		 * counts on the bound whatever the call draws). */
		whole.level = region->level;
		whole.max_evals = region->max_evals;
		whole.short_tiles = region->short_tiles;
		whole.threads = region->threads;
		region = &whole;
		stats->whole = true;
	}
	out->key = 0; /* unknown until the backend succeeds */
	if ((rc = r->ops->render(r, cam, out, region, stats, ei))) {
		return rc;
	}
	if (!stats->incomplete) {
		out->key = key;
	}
	return 0;
}

int bc_renderer_render(struct bc_renderer *r, const struct bc_camera *cam,
                       struct bc_frame *out, struct bc_render_stats *stats,
                       struct bc_errinfo *ei)
{
	return bc_renderer_render_region(r, cam, out, NULL, stats, ei);
}

void bc_renderer_release(struct bc_renderer *r)
{
	if (r && r->ops->release) {
		r->ops->release(r);
	}
}

void bc_renderer_set_progress(struct bc_renderer *r, bc_render_progress_fn fn,
                              void *user)
{
	if (r) {
		r->progress = fn;
		r->progress_user = user;
	}
}

size_t bc_renderer_kept_bytes(const struct bc_renderer *r)
{
	if (!r || !r->ops->kept_bytes) {
		return 0;
	}
	return r->ops->kept_bytes(r);
}

void bc_renderer_damage(struct bc_renderer *r, const struct bc_camera *cam,
                        uint32_t width, uint32_t height,
                        const struct bc_abv *abv, uint8_t *tiles)
{
	size_t n = (size_t)bc_render_tiles_x(width) * bc_render_tiles_y(height);
	if (!r || !tiles || width == 0 || height == 0) {
		return;
	}
	if (!r->ops->damage || !cam || !abv ||
	    bc_camera_validate(cam, NULL) != 0) {
		memset(tiles, 1, n);
		return;
	}
	r->ops->damage(r, cam, width, height, abv, tiles);
}

int bc_render_once(enum bc_backend b, const struct bc_render_opts *opts,
                   const struct bc_tree *t, const struct bc_camera *cam,
                   struct bc_frame *out, struct bc_render_stats *stats,
                   struct bc_errinfo *ei)
{
	struct bc_renderer *r = NULL;
	int rc;
	if (stats) {
		memset(stats, 0, sizeof(*stats));
	}
	if ((rc = bc_renderer_create(&r, b, opts, ei))) {
		return rc;
	}
	if ((rc = bc_renderer_sync(r, t, NULL, ei)) == 0) {
		rc = bc_renderer_render(r, cam, out, stats, ei);
	}
	bc_renderer_destroy(r);
	return rc;
}
