/*
 * Shading shared by the CPU backends (naive, tiled, svo), so that equal hits
 * give equal pixels whichever backend traced them: one directional light
 * from the camera's upper left, ambient, a Blinn specular, sRGB output; a
 * dark vertical gradient behind; a viridis ramp for the debug views. The gl
 * backend's shaders follow the same formulas (shaders/).
 */
#ifndef BLOBCAST_SHADE_H
#define BLOBCAST_SHADE_H

#include <stdint.h>

#include "blobcast/blobtree.h"

struct bc_shade {
	float light[3]; /* unit vector toward the light */
	float ambient;
};

/* Sets the light for a view (camera-relative, so every view is lit alike)
 * and builds the sRGB table bc_shade_hit reads (once per process). */
void bc_shade_init(struct bc_shade *s, const struct bc_view_rays *vr);

/* Writes the RGBA of a surface point seen along unit direction d with field
 * gradient grad (any length; zero or non-finite: the surface faces the
 * viewer; seen from inside: the side facing the viewer is lit) and linear
 * albedo. s must have been set by bc_shade_init. The colour is
 * blobcast/shade_lanes.h's, which shades several pixels at once. */
void bc_shade_hit(const struct bc_shade *s, const float grad[3],
                  const float d[3], const float albedo[3], uint8_t px[4]);

/* Writes the RGBA of linear colour lit (bc_shade_hit's bytes for the
 * colour blobcast/shade_lanes.h computed). bc_shade_init must have been
 * called once in the process (it builds the sRGB table). */
void bc_shade_put_lit(const float lit[3], uint8_t px[4]);

/* Writes the background of row y of an image height rows tall. */
void bc_shade_miss(uint32_t y, uint32_t height, uint8_t px[4]);

/* The sRGB byte of linear intensity c (0 at or below 0 and for NaN, 255
 * at or above 1): the sRGB transfer function, rounded to the nearest byte.
 * Thread-safe; the first call builds a table. */
uint8_t bc_shade_srgb8(float c);

/* Writes the debug ramp's colour for x in [0, 1] (clamped). */
void bc_shade_ramp(float x, uint8_t px[4]);

#endif
