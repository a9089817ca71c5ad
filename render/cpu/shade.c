/*
 * Pixel output shared by the naive and tiled backends: one frame's
 * constants (camera rays, minimal step, light), the normal from the field
 * gradient, and the debug colour ramps; the shading itself is
 * render/common's (blobcast/shade.h).
 */
#include "cpu.h"
#include "blobcast/shade.h"

#include <math.h>
#include <string.h>

void bc__frame_setup(struct bc__frame_ctx *fc, const struct bc_lin *lin,
                     const struct bc_camera *cam, struct bc_frame *out,
                     enum bc_debug_mode debug)
{
	float size;
	memset(fc, 0, sizeof(*fc));
	fc->lin = lin;
	fc->out = out;
	fc->debug = debug;
	/* A window's rays are those of its pixels in the whole view, and
	 * the footprint below is the whole view's pixel's. */
	bc_frame_view_rays(&fc->vr, cam, out);
	/* A power of two: edits that move the scene's bounds a little keep
	 * every step length, so damage renders stay exact. */
	size = bc_render_scale(lin);
	fc->min_step = BC_CPU_MIN_STEP_REL * size;
	fc->refine_tol = BC_CPU_REFINE_REL * size;
	fc->pix_angle = 2.0f * fc->vr.tan_half_y / (float)fc->vr.height;
	bc_shade_init(&fc->shade, &fc->vr);
}

static void debug_colour(const struct bc__frame_ctx *fc, uint32_t evals,
                         uint32_t overlaps, uint8_t *px)
{
	if (fc->debug == BC_DEBUG_EVALS) {
		bc_shade_ramp((float)evals / (float)BC_CPU_DEBUG_EVALS_MAX, px);
	} else {
		bc_shade_ramp(
		    (float)overlaps / (float)BC_CPU_DEBUG_OVERLAPS_MAX, px);
	}
}

/* Writes the pixels x0 + i of row y whose bit i is set in bits as misses
 * after `evals` evaluations: one colour for all of them. */
static void put_miss_row(const struct bc__frame_ctx *fc, uint32_t x0,
                         uint32_t y, uint64_t bits, uint32_t evals,
                         uint32_t overlaps)
{
	struct bc_frame *out = fc->out;
	size_t row = (size_t)y * out->width + x0;
	uint8_t c[4];
	if (fc->debug != BC_DEBUG_NONE) {
		debug_colour(fc, evals, overlaps, c);
	} else {
		bc_shade_miss(bc_frame_view_row(out, y),
		              bc_frame_view_height(out), c);
	}
	/* Run by run of set bits (a tile row is mostly one): plain loops
	 * over consecutive pixels, which the compiler makes stores of
	 * several at once, where a store a bit cost a vector frame of gears
	 * 8 % of its time. */
	uint8_t *rgba = out->rgba + 4 * row;
	float *depth = out->depth ? out->depth + row : NULL;
	uint32_t *ids = out->ids ? out->ids + row : NULL;
	while (bits) {
		uint32_t a = (uint32_t)__builtin_ctzll(bits), b;
		uint64_t rest = ~bits >> a;
		b = a + (rest ? (uint32_t)__builtin_ctzll(rest) : 64u - a);
		for (uint32_t x = a; x < b; x++) {
			memcpy(rgba + 4 * x, c, sizeof(c));
		}
		if (depth) {
			for (uint32_t x = a; x < b; x++) {
				depth[x] = INFINITY;
			}
		}
		if (ids) {
			memset(ids + a, 0, (b - a) * sizeof(ids[0]));
		}
		bits = b < 64u ? bits & ~((2ull << (b - 1u)) - 1u) : 0u;
	}
}

void bc__put_miss(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                  uint32_t evals, uint32_t overlaps)
{
	put_miss_row(fc, x, y, 1u, evals, overlaps);
}

void bc__put_miss_row(const struct bc__frame_ctx *fc, uint32_t x0, uint32_t y,
                      uint64_t bits)
{
	put_miss_row(fc, x0, y, bits, 0, 0);
}

void bc__put_miss_tile(const struct bc__frame_ctx *fc, uint32_t x0, uint32_t y0,
                       uint32_t x1, uint32_t y1, uint64_t mask)
{
	uint64_t row = (1ull << (x1 - x0)) - 1u;
	for (uint32_t y = y0; y < y1; y++) {
		uint64_t bits = (mask >> ((y - y0) * BC_CPU_TILE)) & row;
		if (bits) {
			put_miss_row(fc, x0, y, bits, 0, 0);
		}
	}
}

const float bc__tet[4][3] = {{1, -1, -1}, {-1, -1, 1}, {-1, 1, -1}, {1, 1, 1}};

void bc__put_hit(const struct bc__frame_ctx *fc, struct bc__field *f,
                 uint32_t x, uint32_t y, const float d[3], float t,
                 uint32_t overlaps)
{
	const float *eye = fc->vr.eye;
	float p[3] = {eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]};
	float n[3] = {0.0f, 0.0f, 0.0f}, h;
	uint32_t prim = BC_NONE;
	(void)bc__field_eval_id(f, p, &prim);
	/* Differences over the hit epsilon: the scale at which the surface
	 * was resolved. */
	h = bc__maxf(BC_CPU_HIT_FOOTPRINT * fc->pix_angle * t, fc->min_step);
	/* Tetrahedral differences: four samples give the gradient. */
	for (int k = 0; k < 4; k++) {
		float q[3] = {p[0] + h * bc__tet[k][0],
		              p[1] + h * bc__tet[k][1],
		              p[2] + h * bc__tet[k][2]};
		float v = bc__field_eval(f, q);
		for (int c = 0; c < 3; c++) {
			n[c] += bc__tet[k][c] * v;
		}
	}
	bc__put_shaded(fc, x, y, d, t, n, prim, f->evals, overlaps);
}

const float *bc__albedo(const struct bc_lin *lin, uint32_t prim)
{
	static const float grey[3] = {0.7f, 0.7f, 0.7f};
	return prim < lin->nprims ? lin->color[prim] : grey;
}

/* The depth and id planes of pixel i for a hit at t on primitive prim. */
static void put_depth_id(const struct bc__frame_ctx *fc, size_t i, float t,
                         uint32_t prim)
{
	const struct bc_lin *lin = fc->lin;
	struct bc_frame *out = fc->out;
	if (out->depth) {
		out->depth[i] = t;
	}
	if (out->ids) {
		out->ids[i] =
		    prim < lin->nprims ? lin->node_id[lin->prim_slot[prim]] : 0;
	}
}

void bc__put_shaded(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                    const float d[3], float t, const float n[3], uint32_t prim,
                    uint32_t evals, uint32_t overlaps)
{
	struct bc_frame *out = fc->out;
	size_t i = (size_t)y * out->width + x;
	uint8_t *px = out->rgba + 4 * i;
	if (fc->debug != BC_DEBUG_NONE) {
		debug_colour(fc, evals, overlaps, px);
	} else {
		bc_shade_hit(&fc->shade, n, d, bc__albedo(fc->lin, prim), px);
	}
	put_depth_id(fc, i, t, prim);
}

void bc__put_lit(const struct bc__frame_ctx *fc, uint32_t x, uint32_t y,
                 float t, const float lit[3], uint32_t prim)
{
	struct bc_frame *out = fc->out;
	size_t i = (size_t)y * out->width + x;
	bc_shade_put_lit(lit, out->rgba + 4 * i);
	put_depth_id(fc, i, t, prim);
}
