/*
 * The A-buffer's inner loops (abuffer.h): the scalar reference forms, and
 * the choice between them and the vector kernels, made with the packet
 * tracer's (so opts.simd means the same for both).
 */
#include "abuffer.h"

#include "packet.h"

/* Where ray l of quarter q lies in its tile. */
static inline uint32_t ray_dx(uint32_t q, uint32_t l)
{
	return (q & 1u) * 4u + (l & 3u);
}

static inline uint32_t ray_dy(uint32_t q, uint32_t l)
{
	return (q >> 1) * 4u + (l >> 2);
}

static void dirs_scalar(const struct bc_view_rays *vr, uint32_t x0, uint32_t y0,
                        struct bc__ab_rays *out)
{
	for (uint32_t q = 0; q < 4; q++) {
		for (uint32_t l = 0; l < BC__AB_QUARTER_RAYS; l++) {
			float d[3];
			bc_view_rays_dir(vr, (float)(x0 + ray_dx(q, l)) + 0.5f,
			                 (float)(y0 + ray_dy(q, l)) + 0.5f, d);
			out->d[q][0][l] = d[0];
			out->d[q][1][l] = d[1];
			out->d[q][2][l] = d[2];
		}
	}
}

/* The scalar clipping of the rays in `lanes`, folded into t: against the
 * sphere (v relative to the eye, r) when abv is NULL, else against abv
 * from the eye at v. */
static void clip_scalar(const struct bc__ab_rays *rays, uint64_t lanes,
                        const struct bc_abv *abv, const float v[3], float r,
                        float t[2])
{
	float t0 = t[0], t1 = t[1];
	for (uint32_t i = 0; i < 4 * BC__AB_QUARTER_RAYS; i++) {
		uint32_t q = i / BC__AB_QUARTER_RAYS,
		         l = i % BC__AB_QUARTER_RAYS;
		float d[3], a, e;
		bool hit;
		if (!((lanes >> i) & 1u)) {
			continue;
		}
		d[0] = rays->d[q][0][l];
		d[1] = rays->d[q][1][l];
		d[2] = rays->d[q][2][l];
		hit = abv ? bc_abv_ray(abv, v, d, &a, &e)
		          : bc__ab_ray_sphere(v, r, d, &a, &e);
		if (hit && e > 0.0f) {
			a = a > 0.0f ? a : 0.0f;
			t0 = a < t0 ? a : t0;
			t1 = e > t1 ? e : t1;
		}
	}
	t[0] = t0;
	t[1] = t1;
}

static void sphere_scalar(const struct bc__ab_rays *rays, uint64_t lanes,
                          const float v[3], float r, float t[2])
{
	clip_scalar(rays, lanes, NULL, v, r, t);
}

void bc__ab_abv_scalar(const struct bc__ab_rays *rays, uint64_t lanes,
                       const struct bc_abv *abv, const float eye[3], float t[2])
{
	clip_scalar(rays, lanes, abv, eye, 0.0f, t);
}

struct bc__ab_kernel bc__ab_kernel_for(enum bc_simd simd)
{
	struct bc__ab_kernel k = {dirs_scalar, sphere_scalar,
	                          bc__ab_abv_scalar};
#if defined(BLOBCAST_SIMD_X86)
	switch (bc__pk_kernel_for(simd).lanes) {
	case 16:
		k.dirs = bc__ab_dirs_avx512;
		k.sphere = bc__ab_sphere_avx512;
		k.abv = bc__ab_abv_avx512;
		break;
	case 8:
		k.dirs = bc__ab_dirs_avx2;
		k.sphere = bc__ab_sphere_avx2;
		break;
	default:
		break;
	}
#else
	(void)simd;
#endif
	return k;
}
