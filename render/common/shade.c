/*
 * Shading shared by every CPU backend (naive, tiled, svo) and repeated in
 * the GLSL: a directional light from the camera's upper left with ambient
 * and a little specular, the background gradient, and the debug colour
 * ramp. Colours are computed in linear RGB and stored as sRGB bytes.
 */
#include "blobcast/shade.h"

#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <string.h>

#include "blobcast/vec.h"

/* blobcast/shade_lanes.h's vocabulary, one float a lane. */
typedef float vf;
typedef bool vm;
static inline vf vset1(float a)
{
	return a;
}
static inline vf vadd(vf a, vf b)
{
	return a + b;
}
static inline vf vsub(vf a, vf b)
{
	return a - b;
}
static inline vf vmul(vf a, vf b)
{
	return a * b;
}
static inline vf vdiv(vf a, vf b)
{
	return a / b;
}
static inline vf vsqrt(vf a)
{
	return sqrtf(a);
}
static inline vf vabs(vf a)
{
	return fabsf(a);
}
static inline vf vneg(vf a)
{
	return -a;
}
static inline vf vmax(vf a, vf b)
{
	return a > b ? a : b;
}
static inline vm vgt(vf a, vf b)
{
	return a > b;
}
static inline vm vle(vf a, vf b)
{
	return a <= b;
}
static inline vm mand(vm a, vm b)
{
	return a && b;
}
static inline vf vsel(vm m, vf a, vf b)
{
	return m ? a : b;
}

#include "blobcast/shade_lanes.h"

/* The sRGB byte of linear c: the transfer function, rounded. This is the
 * definition; bc_shade_srgb8 gives the same bytes by table. */
static uint8_t srgb8_formula(float c)
{
	float s;
	if (!(c > 0.0f)) {
		return 0;
	}
	if (c >= 1.0f) {
		return 255;
	}
	s = c <= 0.0031308f ? 12.92f * c
	                    : 1.055f * powf(c, 1.0f / 2.4f) - 0.055f;
	return (uint8_t)(s * 255.0f + 0.5f);
}

/*
 * Three bytes a lit pixel, each a powf: 3 % of an svo frame's instructions.
 * The formula is monotone, so its bytes are fixed by 255 edges, edge[k]
 * the least float whose byte is k or more, found once by bisection on the
 * floats' bit patterns. A float's top bits (exponent and 7 bits of
 * mantissa) pick a bucket a little narrower than a byte's step everywhere
 * above edge[1], and guess[] holds the byte at the bucket's start: one
 * comparison with the next edge finishes the lookup.
 */
#define SRGB_SHIFT 16u
static float srgb_edge[257]; /* edge[0] = 0, edge[256] = +inf */
static uint32_t srgb_base;   /* bucket of edge[1] */
static uint8_t srgb_guess[(0x3f800000u >> SRGB_SHIFT) + 1u];
static pthread_once_t srgb_once = PTHREAD_ONCE_INIT;

static float float_of(uint32_t bits)
{
	float f;
	memcpy(&f, &bits, sizeof(f));
	return f;
}

static uint32_t bits_of(float f)
{
	uint32_t b;
	memcpy(&b, &f, sizeof(b));
	return b;
}

static void srgb_init(void)
{
	srgb_edge[0] = 0.0f;
	srgb_edge[256] = INFINITY;
	for (uint32_t k = 1; k < 256; k++) {
		/* Positive floats order as their bit patterns. */
		uint32_t lo = 0, hi = bits_of(1.0f);
		while (lo < hi) {
			uint32_t mid = lo + (hi - lo) / 2u;
			if (srgb8_formula(float_of(mid)) >= k) {
				hi = mid;
			} else {
				lo = mid + 1u;
			}
		}
		srgb_edge[k] = float_of(lo);
	}
	srgb_base = bits_of(srgb_edge[1]) >> SRGB_SHIFT;
	for (uint32_t i = srgb_base; i <= (0x3f800000u >> SRGB_SHIFT); i++) {
		srgb_guess[i] = srgb8_formula(float_of(i << SRGB_SHIFT));
	}
}

/* bc_shade_srgb8 once the table is built. A bucket holds at most one
 * edge (it is narrower than a byte's step), so one comparison, added
 * rather than branched on, finishes the lookup. */
static inline uint8_t srgb8_table(float c)
{
	uint32_t i, k;
	if (!(c >= srgb_edge[1])) {
		return 0; /* NaN too */
	}
	if (c >= 1.0f) {
		return 255;
	}
	i = bits_of(c) >> SRGB_SHIFT;
	k = i >= srgb_base ? srgb_guess[i] : 0u;
	k += c >= srgb_edge[k + 1u];
	return (uint8_t)k;
}

uint8_t bc_shade_srgb8(float c)
{
	(void)pthread_once(&srgb_once, srgb_init);
	return srgb8_table(c);
}

void bc_shade_init(struct bc_shade *s, const struct bc_view_rays *vr)
{
	/* Light from the camera's upper left, slightly from the front. */
	for (int i = 0; i < 3; i++) {
		s->light[i] = -0.5f * vr->right[i] + 0.6f * vr->up[i] -
		              0.6f * vr->forward[i];
	}
	bc_v3_normalize_div(s->light);
	s->ambient = 0.18f;
	/* bc_shade_hit's sRGB table. */
	(void)pthread_once(&srgb_once, srgb_init);
}

/* A perceptual ramp (viridis, sampled at five points and interpolated) for
 * x in [0, 1]. */
void bc_shade_ramp(float x, uint8_t rgb[4])
{
	static const float stops[5][3] = {
	    {0.267f, 0.005f, 0.329f}, {0.229f, 0.322f, 0.545f},
	    {0.128f, 0.567f, 0.551f}, {0.369f, 0.789f, 0.383f},
	    {0.993f, 0.906f, 0.144f},
	};
	float s;
	int i;
	x = x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x);
	s = x * 4.0f;
	i = s >= 4.0f ? 3 : (int)s;
	s -= (float)i;
	for (int c = 0; c < 3; c++) {
		float v = stops[i][c] + (stops[i + 1][c] - stops[i][c]) * s;
		rgb[c] = (uint8_t)(v * 255.0f + 0.5f);
	}
	rgb[3] = 255;
}

void bc_shade_miss(uint32_t y, uint32_t height, uint8_t px[4])
{
	/* Dark vertical gradient, lighter at the top. */
	float v = height > 1 ? (float)y / (float)(height - 1) : 0.0f;
	px[0] = (uint8_t)(30.0f - 22.0f * v);
	px[1] = (uint8_t)(33.0f - 24.0f * v);
	px[2] = (uint8_t)(42.0f - 30.0f * v);
	px[3] = 255;
}

void bc_shade_put_lit(const float lit[3], uint8_t px[4])
{
	for (int c = 0; c < 3; c++) {
		px[c] = srgb8_table(lit[c]);
	}
	px[3] = 255;
}

void bc_shade_hit(const struct bc_shade *s, const float grad[3],
                  const float d[3], const float albedo[3], uint8_t px[4])
{
	float lit[3];
	bc__shade_lit(s, grad, d, albedo, lit);
	bc_shade_put_lit(lit, px);
}
