/*
 * Renderers behind one small interface. A backend receives the tree (and what
 * changed since it last saw it), a camera and a frame to fill: RGBA8, depth
 * (ray parameter t along unit directions: world distance; +inf on a miss)
 * and the stable id of the primitive hit (0 on a miss). Every backend gives
 * these the same meaning so they can be compared pixel by pixel.
 */
#ifndef BLOBCAST_RENDER_H
#define BLOBCAST_RENDER_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"

/* Largest width or height of a frame: keeps w*h*16 bytes far below 2^32 and
 * matches the largest texture GL drivers guarantee. */
#define BC_RENDER_MAX_DIM 8192u

/* Row 0 is the top row. Any of the three planes may be NULL when the caller
 * does not want it (rgba is always allocated by bc_frame_init). */
struct bc_frame {
	uint32_t width, height;
	uint8_t *rgba;   /* width * height * 4 */
	float *depth;    /* width * height */
	uint32_t *ids;   /* width * height */
};

/* Allocates all three planes. Returns 0, BC_ERANGE (size 0 or over
 * BC_RENDER_MAX_DIM) or BC_ENOMEM. bc_frame_finish accepts a zeroed frame. */
int bc_frame_init(struct bc_frame *f, uint32_t width, uint32_t height);
void bc_frame_finish(struct bc_frame *f);

enum bc_debug_mode {
	BC_DEBUG_NONE = 0,
	BC_DEBUG_EVALS,    /* colour = field evaluations per ray */
	BC_DEBUG_OVERLAPS, /* colour = primitives listed in the pixel's tile */
	BC_DEBUG_COUNT
};

enum bc_backend {
	BC_BACKEND_INVALID = 0,
	BC_BACKEND_NAIVE, /* CPU sphere tracing of the full tree: the baseline */
	BC_BACKEND_TILED, /* CPU synchronized tile tracing (paper §6) */
	BC_BACKEND_GL,    /* OpenGL compute through EGL or OSMesa */
	BC_BACKEND_SVO,   /* CPU adaptive octree + interval ray casting */
	BC_BACKEND_COUNT
};

enum bc_range_arith {
	BC_RANGE_DEFAULT = 0, /* the backend's choice (RevAA) */
	BC_RANGE_IA,
	BC_RANGE_AA,
	BC_RANGE_REVAA,
	BC_RANGE_COUNT
};

/* Zero means default for every field. */
struct bc_render_opts {
	enum bc_debug_mode debug;
	uint32_t threads;        /* CPU threads, 0 = one per core */
	const char *gl_platform; /* "auto" | "device" | "surfaceless" | "osmesa" */
	enum bc_range_arith svo_range;
	uint32_t svo_threshold;  /* node-count threshold tau, 0 = default */
	uint32_t svo_max_depth;  /* 0 = default */
	/* Milliseconds a frame may take, 0 = no limit. Past it the tiled
	 * tracer starts no new tile: the rest is background and the stats
	 * say incomplete (one pathological scene cannot stall a server). */
	uint32_t budget_ms;
};

/* Timings of one frame, milliseconds, and work counters. */
struct bc_render_stats {
	double ms_total;
	double ms_abuffer; /* building per-tile lists (tiled, gl) */
	double ms_trace;
	double ms_upload;  /* gl: data sent to the GPU for this frame */
	uint64_t field_evals;
	uint32_t max_overlap; /* most primitives listed in one tile */
	bool incomplete;      /* cut short by a time budget */
};

struct bc_renderer;

/* A backend's entry points. sync() tells it the tree and what changed since
 * its previous sync (dirty == NULL: everything); render() draws the tree it
 * last synced. */
struct bc_backend_ops {
	const char *name;
	int (*create)(struct bc_renderer **out, const struct bc_render_opts *opts,
		      struct bc_errinfo *ei);
	void (*destroy)(struct bc_renderer *r);
	int (*sync)(struct bc_renderer *r, const struct bc_tree *t,
		    const struct bc_dirty *dirty, struct bc_errinfo *ei);
	int (*render)(struct bc_renderer *r, const struct bc_camera *cam,
		      struct bc_frame *out, struct bc_render_stats *stats,
		      struct bc_errinfo *ei);
};

/* Returns the ops of backend b, or NULL when it is not built in. */
const struct bc_backend_ops *bc_backend_get(enum bc_backend b);
/* "naive", "tiled", "gl", "svo" <-> enum; BC_BACKEND_INVALID if unknown. */
enum bc_backend bc_backend_from_name(const char *name);
const char *bc_backend_name(enum bc_backend b);

/* Convenience: create, sync, render once, destroy. */
int bc_render_once(enum bc_backend b, const struct bc_render_opts *opts,
		   const struct bc_tree *t, const struct bc_camera *cam,
		   struct bc_frame *out, struct bc_render_stats *stats,
		   struct bc_errinfo *ei);

#endif
