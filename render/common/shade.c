/*
 * Shading shared by every CPU backend (naive, tiled, svo) and repeated in
 * the GLSL: a directional light from the camera's upper left with ambient
 * and a little specular, the background gradient, and the debug colour
 * ramp. Colours are computed in linear RGB and stored as sRGB bytes.
 */
#include "blobcast/shade.h"

#include <math.h>
#include <string.h>

#include "blobcast/vec.h"
static inline float maxf(float a, float b)
{
	return a > b ? a : b;
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
}

static uint8_t to_srgb8(float c)
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

void bc_shade_hit(const struct bc_shade *s, const float grad[3],
                  const float d[3], const float albedo[3], uint8_t px[4])
{
	float n[3] = {grad[0], grad[1], grad[2]};
	float hv[3] = {s->light[0] - d[0], s->light[1] - d[1],
	               s->light[2] - d[2]};
	float diff, spec;
	if (!(isfinite(n[0]) && isfinite(n[1]) && isfinite(n[2])) ||
	    bc_v3_dot(n, n) == 0.0f) {
		/* No usable gradient (a sample fell outside every active
		 * primitive): face the viewer. */
		n[0] = -d[0];
		n[1] = -d[1];
		n[2] = -d[2];
	}
	bc_v3_normalize_div(n);
	if (bc_v3_dot(n, d) > 0.0f) {
		/* Seen from inside (the eye is in the solid): light the side
		 * that faces us. */
		n[0] = -n[0];
		n[1] = -n[1];
		n[2] = -n[2];
	}
	diff = maxf(bc_v3_dot(n, s->light), 0.0f);
	bc_v3_normalize_div(hv);
	spec = diff > 0.0f ? powf(maxf(bc_v3_dot(n, hv), 0.0f), 48.0f) : 0.0f;
	for (int c = 0; c < 3; c++) {
		float lit =
		    albedo[c] * (s->ambient + (1.0f - s->ambient) * diff) +
		    0.25f * spec;
		px[c] = to_srgb8(lit);
	}
	px[3] = 255;
}
