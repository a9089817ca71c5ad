/*
 * The inner loops of the tiled backend's A-buffer (tiled.c), with vector
 * forms chosen at run time as the packet tracer's are: the 64 pixel ray
 * directions of a tile, and the clipping of a tile's rays against one
 * sphere ABV, folded into the primitive's fragment (min entry, max exit).
 * The scalar forms are the reference; the AVX2 and AVX-512 ones
 * (abuffer_avx2.c, abuffer_avx512.c, compiled with -ffp-contract=off) do
 * the same float operations in the same order lane by lane, so every
 * choice of opts.simd gives the same directions and the same lists, bit
 * for bit.
 */
#ifndef BLOBCAST_RENDER_CPU_ABUFFER_H
#define BLOBCAST_RENDER_CPU_ABUFFER_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "cpu.h"

/* Rays per quarter tile (4 x 4): one AVX-512 vector, two AVX2 ones. */
#define BC__AB_QUARTER_RAYS 16u

/* The unit directions of a tile's 64 pixel rays, structure of arrays by
 * quarter: ray l of quarter q goes through pixel (x0 + (q & 1) * 4 +
 * (l & 3), y0 + (q >> 1) * 4 + (l >> 2)), as bc_view_rays_dir gives it
 * (pixels beyond the frame's edge included: callers mask them). */
struct bc__ab_rays {
	_Alignas(64) float d[4][3][BC__AB_QUARTER_RAYS];
};

/* Fills out with the rays of the tile whose top-left pixel is (x0, y0). */
typedef void (*bc__ab_dirs_fn)(const struct bc_view_rays *vr, uint32_t x0,
                               uint32_t y0, struct bc__ab_rays *out);

/* Clips the rays whose bit (q * 16 + l) is set in `rays` against the
 * sphere of centre v (relative to the eye) and radius r, as tiled.c's
 * ray_sphere does one ray at a time, and folds every hit whose exit is
 * ahead of the eye into t: t[0] = min(t[0], max(entry, 0)), t[1] =
 * max(t[1], exit). */
typedef void (*bc__ab_sphere_fn)(const struct bc__ab_rays *rays, uint64_t lanes,
                                 const float v[3], float r, float t[2]);

/* Clips the rays whose bit is set in `rays` against a box or capsule ABV
 * with bc_abv_ray (from the eye), and folds every hit whose exit is ahead
 * of the eye into t as AB_SPHERE does. The AVX-512 form does bc_abv_ray's
 * double-precision operations in the same order, 8 rays at a time, and
 * rounds the ends to float as it does (nextafterf outwards), so the
 * fragments are the same bit for bit. */
typedef void (*bc__ab_abv_fn)(const struct bc__ab_rays *rays, uint64_t lanes,
                              const struct bc_abv *abv, const float eye[3],
                              float t[2]);

/* The scalar form of bc__ab_abv_fn (the vector one's reference, and its
 * fallback for shapes other than boxes and capsules). */
void bc__ab_abv_scalar(const struct bc__ab_rays *rays, uint64_t lanes,
                       const struct bc_abv *abv, const float eye[3],
                       float t[2]);

struct bc__ab_kernel {
	bc__ab_dirs_fn dirs;
	bc__ab_sphere_fn sphere;
	bc__ab_abv_fn abv;
};

/* The kernels for a simd choice on this CPU, as bc__pk_kernel_for picks
 * the packet tracer's (AUTO: the widest; OFF or a width the CPU lacks:
 * scalar). */
struct bc__ab_kernel bc__ab_kernel_for(enum bc_simd simd);

/* Ray (from the eye, unit d) against a sphere (centre v relative to the
 * eye, radius r): computing the squared distance of the centre from the
 * ray directly avoids the cancellation of b^2 - c; the interval is padded
 * outwards. Rays that graze the sphere within rounding may be lost, which
 * the A-buffer makes safe by widening every ABV by the hit epsilon first
 * (tiled.c's widened_abv). The vector kernels repeat these operations. */
static inline bool bc__ab_ray_sphere(const float v[3], float r,
                                     const float d[3], float *t0, float *t1)
{
	float b = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
	float p[3] = {v[0] - b * d[0], v[1] - b * d[1], v[2] - b * d[2]};
	float disc = r * r - (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), s, pad;
	if (!(disc >= 0.0f)) {
		return false;
	}
	s = sqrtf(disc);
	pad = 1.0e-5f * (fabsf(b) + r);
	*t0 = b - s - pad;
	*t1 = b + s + pad;
	return true;
}

#if defined(BLOBCAST_SIMD_X86)
void bc__ab_dirs_avx2(const struct bc_view_rays *vr, uint32_t x0, uint32_t y0,
                      struct bc__ab_rays *out);
void bc__ab_sphere_avx2(const struct bc__ab_rays *rays, uint64_t lanes,
                        const float v[3], float r, float t[2]);
void bc__ab_dirs_avx512(const struct bc_view_rays *vr, uint32_t x0, uint32_t y0,
                        struct bc__ab_rays *out);
void bc__ab_sphere_avx512(const struct bc__ab_rays *rays, uint64_t lanes,
                          const float v[3], float r, float t[2]);
void bc__ab_abv_avx512(const struct bc__ab_rays *rays, uint64_t lanes,
                       const struct bc_abv *abv, const float eye[3],
                       float t[2]);
#endif

#endif
