/*
 * What the files of the gl backend share: the context (EGL device or
 * surfaceless display, or OSMesa) with its loaded GL entry points and what
 * the driver granted; the constants, buffer bindings and layouts that
 * shaders/common.glsl mirrors.
 *
 * GL entry points come from glad, generated at build time in its
 * multi-context form: each context holds its own table (struct
 * GladGLContext), loaded through eglGetProcAddress or OSMesaGetProcAddress.
 * Calling libOpenGL's exports directly would bind whichever implementation
 * the loader picked, which is wrong under OSMesa.
 */
#ifndef BLOBCAST_RENDER_GL_PRIV_H
#define BLOBCAST_RENDER_GL_PRIV_H

#include <stdbool.h>
#include <stdint.h>

#include <glad/gl.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/render.h"
#include "blobcast/render_gl.h"
#include "gl_platform.h"

/* ---- Constants (mirrored in shaders/common.glsl) ------------------------ */

#define BC_GL_TILE 8u
/* Tracing constants, the CPU renderers' (render/cpu/cpu.h): same values so
 * that both backends draw the same surfaces. */
#define BC_GL_MIN_STEP_REL 1.0e-4f
#define BC_GL_REFINE_REL 1.0e-5f
#define BC_GL_AMBIENT 0.18f
/* Fragments of one frame's A-buffer: each costs 56 bytes of GPU memory
 * (linked, sorted, scratch), so 2^24 is 896 MiB at most, reached only by
 * frames that need it (capacity grows from BC_GL_MIN_FRAGMENTS). The
 * driver's storage block size lowers it (llvmpipe's 128 MiB: about
 * 5.6 * 10^6). A 4096-primitive scene at 512^2 makes about 10^5, a million
 * fig18 spheres at 1024^2 4.5 * 10^6. Calls beyond are drawn in bands of
 * tile rows (backend.c, draw_bands); only a tile row beyond fails, with
 * BC_ELIMIT. */
#define BC_GL_MAX_FRAGMENTS (1u << 24)
/* The first frame's fragment capacity; frames that need more grow it. */
#define BC_GL_MIN_FRAGMENTS (1u << 16)
/* Statistics buffer: slots as in common.glsl. */
#define BC_GL_STAT_FRAGMENTS 0u
#define BC_GL_STAT_MAX_OVERLAP 1u
#define BC_GL_STAT_OVER_M 2u
#define BC_GL_STAT_OVER_CACHE 3u
#define BC_GL_STAT_RANGES 4u
#define BC_GL_STAT_SUSPENDED 5u
#define BC_GL_STAT_SLOTS 6u
#define BC_GL_STAT_NO_SLOT 7u
#define BC_GL_STAT_OVER_BUDGET 8u
#define BC_GL_STAT_DISPATCHES 9u
#define BC_GL_STAT_GENERAL 10u
#define BC_GL_STAT_OVER_VIEW 11u
#define BC_GL_STAT_EVALS 16u
#define BC_GL_STAT_EVAL_BUCKETS 256u
#define BC_GL_STAT_WORDS (BC_GL_STAT_EVALS + BC_GL_STAT_EVAL_BUCKETS)
/* Workgroup size of the scan pass (abuffer_scan.comp). */
#define BC_GL_SCAN_THREADS 256u
/* llvmpipe ends every loop of a shader invocation once 65535 loop
 * iterations have run in it, all loops together (gallivm's loop limiter).
 * The tracing pass is told this budget and suspends tiles before it runs
 * out; other drivers have no such limit and get none. */
#define BC_GL_LLVMPIPE_LOOP_LIMIT 65535u
/* Longest tile list the sort pass can order within that limit: lists up to
 * 1024 are sorted in shared memory, longer ones by a heap sort in one
 * invocation (about 2 n log2 n loop iterations). */
#define BC_GL_LLVMPIPE_SORT_MAX 2048u
/* Tracing dispatches of one frame at most: each moves every suspended
 * tile on by at least one step of every ray, so this is only reached by a
 * frame that cannot finish. */
#define BC_GL_MAX_DISPATCHES 4096u
/* Suspension slots of the first frame; a frame that needs more grows them
 * and is drawn again. */
#define BC_GL_MIN_SLOTS 256u

/* Storage buffer binding points. */
enum bc__gl_buf {
	BC__GL_BUF_NODES = 0,
	BC__GL_BUF_PARAMS,
	BC__GL_BUF_TOPO,
	BC__GL_BUF_PRIMS,
	BC__GL_BUF_ABVS,
	BC__GL_BUF_LINKS,
	BC__GL_BUF_TILES,
	BC__GL_BUF_SORTED,
	BC__GL_BUF_SCRATCH,
	BC__GL_BUF_STATS,
	BC__GL_BUF_REGION, /* a region's tile list and tile bits */
	BC__GL_BUF_SHORT,  /* per tile, the rays that ran out of the bound */
	BC__GL_BUF_COUNT
};

/* Floats per primitive in the Prims and Abvs buffers. */
#define BC_GL_PRIM_FLOATS 8u
#define BC_GL_ABV_FLOATS 28u

/* The Frame uniform block (std140: every member a vec4). */
struct bc__gl_frame_ubo {
	float eye[4];       /* w: tan(fov_y / 2) */
	float forward[4];   /* w: aspect */
	float right[4];     /* w: minimal step */
	float up[4];        /* w: pixel footprint per unit of t */
	float light[4];     /* w: ambient */
	float misc[4];      /* bisection tolerance, scene size, lip, 1/lip */
	uint32_t size[4];   /* width, height, tiles across, tiles down */
	uint32_t counts[4]; /* primitives, fragment capacity, debug mode */
	uint32_t pool[4];   /* slot base (scratch words), slots, budget */
	uint32_t region[4]; /* level, refine, tiles listed, list used */
	/* The region's max_evals (0: none); with a tile list, the listed
	 * tiles' bounding box, x0 | y0 << 16 and x1 | y1 << 16 (half-open,
	 * in tiles); 0. */
	uint32_t bound[4];
	/* The frame as a window of the whole view: x0, y0, full width,
	 * full height; (0, 0, width, height) for the whole view. */
	uint32_t window[4];
};

/* Words per tile in the Short buffer: a bit per pixel whose ray ran out of
 * the region's evaluation bound (bit (y % 8) * 8 + x % 8). */
#define BC_GL_SHORT_WORDS 2u

/* Suspension slots (trace.comp): 8 words for the tile's walk and 9 per
 * ray (flags, the pending hit, a paused ray's sphere tracing state and
 * next sample). */
#define BC_GL_SLOT_WORDS (8u + 9u * 64u)

/* ---- Context ------------------------------------------------------------ */

struct bc__gl_ctx {
	struct bc__gl_plat plat;
	GladGLContext gl;
	struct bc_gl_info info;
	/* A software renderer (llvmpipe, softpipe, OSMesa): its contexts
	 * are used one at a time in the process (context.c, "Software
	 * contexts"); locked: this one holds that turn. */
	bool serialize, locked;
};

/* Creates a context on platform (AUTO tries a hardware device, then
 * surfaceless, then OSMesa) and loads its entry points; it is left current.
 * Returns 0, BC_EGL with the failed call and the error's name in ei,
 * BC_ENOTSUP when the platform is not built in, or BC_ENOMEM. */
int bc__gl_ctx_open(struct bc__gl_ctx *c, enum bc_gl_platform platform,
                    struct bc_errinfo *ei);
/* Destroys the context (which need not be current). Accepts a zeroed one. */
void bc__gl_ctx_close(struct bc__gl_ctx *c);
/* Makes c current on the calling thread / releases it. */
int bc__gl_ctx_bind(struct bc__gl_ctx *c, struct bc_errinfo *ei);
void bc__gl_ctx_unbind(struct bc__gl_ctx *c);

/* Name of a GL error code ("GL_INVALID_OPERATION"); never NULL. */
const char *bc__gl_error_name(GLenum e);
/* Checks glGetError (draining it) after `stage`. Returns 0 or BC_EGL with
 * every pending error named in ei. */
int bc__gl_check(struct bc__gl_ctx *c, const char *stage,
                 struct bc_errinfo *ei);

/* ---- Programs ----------------------------------------------------------- */

enum bc__gl_prog {
	BC__GL_PROG_ABUFFER = 0, /* vert + geom + frag */
	BC__GL_PROG_SCAN,
	BC__GL_PROG_SORT,
	BC__GL_PROG_TRACE,
	BC__GL_PROG_TRACE_UNARY, /* trace.comp with BC_UNARY: built on demand */
	BC__GL_PROG_COUNT
};

/* Compiles and links the embedded stages into progs[]. Info logs are
 * always logged; a failure names the stage and carries the log's start in
 * ei. Returns 0 or BC_EGL. */
int bc__gl_programs_build(struct bc__gl_ctx *c, GLuint progs[BC__GL_PROG_COUNT],
                          struct bc_errinfo *ei);
/* Builds the tracer for trees with unary nodes (trace.comp compiled with
 * BC_UNARY defined) into *prog. Returns 0 or BC_EGL with the log in ei. */
int bc__gl_program_trace_unary(struct bc__gl_ctx *c, GLuint *prog,
                               struct bc_errinfo *ei);
void bc__gl_programs_free(struct bc__gl_ctx *c,
                          GLuint progs[BC__GL_PROG_COUNT]);

#endif
