/*
 * The dispatcher behind blobcast/render.h: which backends this build holds,
 * their names, frames, and the create-sync-render-destroy shorthand. The
 * backends are compiled in when CMake found their libraries (it defines
 * BLOBCAST_HAVE_CPU, _GL, _SVO); a backend not built in is simply absent.
 */
#include "blobcast/render.h"

#include <string.h>

#include "blobcast/alloc.h"

#if defined(BLOBCAST_HAVE_CPU)
#include "blobcast/render_cpu.h"
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

const struct bc_backend_ops *bc_backend_get(enum bc_backend b)
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

int bc_frame_init(struct bc_frame *f, uint32_t width, uint32_t height)
{
	size_t n;
	memset(f, 0, sizeof(*f));
	if (width == 0 || height == 0 || width > BC_RENDER_MAX_DIM ||
	    height > BC_RENDER_MAX_DIM) {
		return BC_ERANGE;
	}
	n = (size_t)width * height;
	f->rgba = bc_malloc(4 * n);
	f->depth = bc_malloc(n * sizeof(*f->depth));
	f->ids = bc_malloc(n * sizeof(*f->ids));
	if (!f->rgba || !f->depth || !f->ids) {
		bc_frame_finish(f);
		return BC_ENOMEM;
	}
	f->width = width;
	f->height = height;
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

int bc_render_once(enum bc_backend b, const struct bc_render_opts *opts,
		   const struct bc_tree *t, const struct bc_camera *cam,
		   struct bc_frame *out, struct bc_render_stats *stats,
		   struct bc_errinfo *ei)
{
	const struct bc_backend_ops *ops = bc_backend_get(b);
	struct bc_render_opts defaults = {0};
	struct bc_renderer *r = NULL;
	int rc;
	if (stats) {
		memset(stats, 0, sizeof(*stats));
	}
	if (!ops) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
				      "render: backend '%s' is not built in",
				      bc_backend_name(b));
	}
	if ((rc = ops->create(&r, opts ? opts : &defaults, ei))) {
		return rc;
	}
	if ((rc = ops->sync(r, t, NULL, ei)) == 0) {
		rc = ops->render(r, cam, out, stats, ei);
	}
	ops->destroy(r);
	return rc;
}
