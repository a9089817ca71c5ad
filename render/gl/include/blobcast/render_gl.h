/*
 * The OpenGL backend (backend name "gl"): Zanni 2024's synchronized tracing
 * as OpenGL 4.3+ compute work, on a context from the EGL device platform (a
 * real GPU), EGL surfaceless (Mesa llvmpipe on CPU-only hosts) or OSMesa.
 * It is created and driven through blobcast/render.h's front like every
 * backend (BC_BACKEND_GL); this header adds what only it can say: which
 * platform and driver it got, what the driver granted, and the limits the last
 * frame ran into.
 */
#ifndef BLOBCAST_RENDER_GL_H
#define BLOBCAST_RENDER_GL_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/error.h"
#include "blobcast/render.h"

extern const struct bc_backend_ops bc_backend_gl_ops;

enum bc_gl_platform {
	BC_GL_PLATFORM_AUTO = 0,    /* device, then surfaceless, then osmesa */
	BC_GL_PLATFORM_DEVICE,      /* EGL_EXT_platform_device */
	BC_GL_PLATFORM_SURFACELESS, /* EGL_MESA_platform_surfaceless */
	BC_GL_PLATFORM_OSMESA,
	BC_GL_PLATFORM_COUNT
};

/* "auto", "device", "surfaceless", "osmesa" <-> enum. NULL or "" is auto;
 * an unknown name gives BC_GL_PLATFORM_COUNT. */
enum bc_gl_platform bc_gl_platform_from_name(const char *name);
const char *bc_gl_platform_name(enum bc_gl_platform p);

struct bc_gl_info {
	enum bc_gl_platform platform; /* the one that worked */
	bool software_device;  /* device platform: a software (Mesa) device */
	int major, minor;      /* context version */
	char renderer[128];    /* GL_RENDERER */
	char version[128];     /* GL_VERSION */
	bool robust_access;    /* GL_CONTEXT_FLAG_ROBUST_ACCESS_BIT granted */
	bool lose_on_reset;    /* reset strategy GL_LOSE_CONTEXT_ON_RESET */
	bool debug_output;     /* GL_KHR_debug messages reach the log */
	uint32_t shared_bytes; /* GL_MAX_COMPUTE_SHARED_MEMORY_SIZE */
	/* The last frame. */
	uint32_t fragments;      /* A-buffer fragments */
	uint32_t ranges;         /* depth ranges traced, all tiles */
	uint32_t over_m;         /* ranges whose active set spilled past
	                            M_overlap into global scratch */
	uint32_t over_cache;     /* ranges whose records did not all fit the
	                            shared node cache */
	uint32_t ranges_general; /* ranges whose view needed the general
	                            evaluation (deep stack, records or view
	                            in global memory) */
	uint32_t retries;        /* times the frame was redrawn after growing
	                            the A-buffer or the suspension slots */
	uint32_t suspensions;    /* tiles that suspended (loop budget) */
	uint32_t dispatches;     /* tracing dispatches the frame took */
	uint32_t loop_budget;    /* loop iterations per shader invocation the
	                            driver allows (llvmpipe), 0: no limit */
	/* Since creation, and the last sync. */
	uint32_t program_builds; /* shader programs built (once, at create) */
	uint32_t full_uploads;   /* syncs that uploaded the whole tree */
	uint32_t lists_built;    /* A-buffers built for every tile and kept */
	uint32_t lists_reused;   /* region calls that traced kept lists */
	bool upload_full;        /* the last sync uploaded everything */
	uint64_t upload_bytes;   /* bytes the last sync sent */
};

/* Fills *out for r, a renderer of backend BC_BACKEND_GL. Returns 0, or
 * BC_EINVAL (with *out zeroed) for NULL or another backend's renderer. */
int bc_render_gl_info(const struct bc_renderer *r, struct bc_gl_info *out);

/* Sets the A-buffer's fragment capacity for the next frame (at least 1,
 * at most the backend's limit). Frames that need more grow it and draw
 * again by themselves, so this only serves tests of that path and callers
 * that know their scenes' needs in advance. Returns 0, or BC_EINVAL for
 * fragments == 0, NULL or another backend's renderer. */
int bc_render_gl_set_capacity(struct bc_renderer *r, uint32_t fragments);

/* Smallest loop budget bc_render_gl_set_loop_budget accepts: the tracing
 * pass keeps 2048 iterations for loops it does not count, and needs room
 * for a range's fetch and view on small scenes besides. */
#define BC_GL_MIN_LOOP_BUDGET 3072u

/* Sets the loop iterations one tracing invocation may spend per dispatch
 * before its tile suspends (0: the driver's own, llvmpipe's limit or
 * none; never above the driver's limit). A small budget makes rays pause
 * and tiles suspend often, on any driver: it serves tests that pausing
 * never changes a pixel. Returns 0, or BC_EINVAL for a budget below
 * BC_GL_MIN_LOOP_BUDGET, NULL or another backend's renderer. */
int bc_render_gl_set_loop_budget(struct bc_renderer *r, uint32_t iterations);

#endif
