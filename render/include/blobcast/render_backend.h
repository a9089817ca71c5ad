/*
 * What a backend implements behind blobcast/render.h: the renderer base
 * struct that every backend embeds as its first member, and its entry
 * points. Only the render modules include this; everyone else goes through
 * the front functions (render/render.c), which validate a frame, a camera
 * and a region once, so backends need not.
 */
#ifndef BLOBCAST_RENDER_BACKEND_H
#define BLOBCAST_RENDER_BACKEND_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/render.h"

struct bc_backend_ops;

/* The part of every renderer the front owns. Backends embed it first:
 * `struct bc__cpu { struct bc_renderer base; ... }`. */
struct bc_renderer {
	const struct bc_backend_ops *ops;
	enum bc_backend backend;
	struct bc_render_opts opts; /* gl_platform is not kept (NULL) */
	const struct bc_tree *tree; /* last synced, NULL before */
	/* Counts syncs that changed the tree's structure (but those the
	 * backend follows splice by splice): part of every frame's key, so
	 * no region is drawn over a frame of another structure. */
	uint64_t generation;
	/* bc_renderer_set_progress's callback, NULL: none. */
	bc_render_progress_fn progress;
	void *progress_user;
};

struct bc_backend_ops {
	const char *name;
	/* Allocates the backend's renderer; the front fills the base after. */
	int (*create)(struct bc_renderer **out,
	              const struct bc_render_opts *opts, struct bc_errinfo *ei);
	void (*destroy)(struct bc_renderer *r);
	/* Optional (NULL: nothing to do beyond the base's tree). Called
	 * after the front stored t in r->tree. */
	int (*sync)(struct bc_renderer *r, const struct bc_tree *t,
	            const struct bc_dirty *dirty, struct bc_errinfo *ei);
	/* Draws region's pixels (region is never NULL; the front checked
	 * the frame, the camera, the level, and that a tree is synced).
	 * stats is never NULL and zeroed. Every backend honours the
	 * region's max_evals: it leaves the pixels of rays that run out as
	 * they are, counts them in stats->short_rays and marks their tiles
	 * in short_tiles. */
	int (*render)(struct bc_renderer *r, const struct bc_camera *cam,
	              struct bc_frame *out,
	              const struct bc_render_region *region,
	              struct bc_render_stats *stats, struct bc_errinfo *ei);
	/* Optional: a hash of the backend's own constants that shape every
	 * pixel of the next frame (e.g. a step length derived from the
	 * scene's size). NULL: none. */
	uint64_t (*key)(struct bc_renderer *r, const struct bc_camera *cam,
	                uint32_t width, uint32_t height);
	/* Optional: the tiles an ABV can reach (see bc_renderer_damage).
	 * NULL: pixels depend on every primitive, the front marks all. */
	void (*damage)(struct bc_renderer *r, const struct bc_camera *cam,
	               uint32_t width, uint32_t height,
	               const struct bc_abv *abv, uint8_t *tiles);
	/* Whether sync follows a spliced structure change (struct
	 * bc_dirty's spliced) with what it keeps, so that such a change
	 * keeps the frame key and damages only what bc_dirty says it can
	 * reach. false: every structure change is a new generation. */
	bool follows_splices;
	/* Whether a region call pays a whole frame's setup whatever its
	 * size (gl: the A-buffer pass over every primitive, the scan over
	 * every tile, the planes' readback), so that a caller splitting a
	 * frame should hand it large regions. false: a call costs about
	 * what its tiles cost (tiled keeps its lists between calls). */
	bool whole_regions;
	/* Optional: frees what the backend keeps for its last view (see
	 * bc_renderer_release). NULL: it keeps nothing. */
	void (*release)(struct bc_renderer *r);
	/* Optional: the bytes release would free. NULL: 0. */
	size_t (*kept_bytes)(const struct bc_renderer *r);
};

/* The rays of frame f through cam: those of f's window of the whole view
 * when f is a window (bc_frame_window), else those of f itself. Every
 * backend prepares its rays here, so a window's pixels get exactly the
 * rays the whole view's render gives them. */
static inline void bc_frame_view_rays(struct bc_view_rays *vr,
                                      const struct bc_camera *cam,
                                      const struct bc_frame *f)
{
	if (f->full_width) {
		bc_view_rays_init_window(vr, cam, f->full_width, f->full_height,
		                         f->win_x, f->win_y);
	} else {
		bc_view_rays_init(vr, cam, f->width, f->height);
	}
}

/* Row y of frame f as a row of the whole view, and the whole view's
 * height: the background gradient runs over the whole view. */
static inline uint32_t bc_frame_view_row(const struct bc_frame *f, uint32_t y)
{
	return f->full_width ? f->win_y + y : y;
}

static inline uint32_t bc_frame_view_height(const struct bc_frame *f)
{
	return f->full_width ? f->full_height : f->height;
}

#endif
