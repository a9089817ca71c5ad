/*
 * Comparing two renderings of one scene, as the tests judge backends and
 * vector paths against each other: the fraction of pixels hit by one only,
 * the median depth difference and the fraction of equal ids where both
 * hit.
 */
#ifndef BLOBCAST_TESTS_RENDER_COMPARE_H
#define BLOBCAST_TESTS_RENDER_COMPARE_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/render.h"

struct cmp {
	double mask_frac; /* pixels hit by one renderer only */
	double depth_med; /* median |depth delta| where both hit */
	double id_frac;   /* pixels hit by both with equal ids */
	uint32_t both;
};

/* Pixel i of a and pixel j of b agree bit for bit: rgba, depth (as
 * bytes, so NaN and infinity patterns count) and id. */
static inline bool pixel_equal_at(const struct bc_frame *a, size_t i,
                                  const struct bc_frame *b, size_t j)
{
	return memcmp(a->rgba + 4 * i, b->rgba + 4 * j, 4) == 0 &&
	       memcmp(&a->depth[i], &b->depth[j], sizeof(float)) == 0 &&
	       a->ids[i] == b->ids[j];
}

/* Pixel i of a and b agree bit for bit. */
static inline bool pixel_equal(const struct bc_frame *a,
                               const struct bc_frame *b, size_t i)
{
	return pixel_equal_at(a, i, b, i);
}

static inline int cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;
	return (x > y) - (x < y);
}

static inline struct cmp compare(const struct bc_frame *a,
                                 const struct bc_frame *b)
{
	size_t n = (size_t)a->width * a->height, diff = 0, both = 0, same = 0;
	float *d = bc_calloc(n, sizeof(float));
	struct cmp c = {1.0, INFINITY, 0.0, 0};
	if (!d) {
		return c;
	}
	for (size_t i = 0; i < n; i++) {
		bool ha = isfinite(a->depth[i]), hb = isfinite(b->depth[i]);
		if (ha != hb) {
			diff++;
		} else if (ha) {
			d[both++] = fabsf(a->depth[i] - b->depth[i]);
			same += a->ids[i] == b->ids[i];
		}
	}
	qsort(d, both, sizeof(float), cmp_float);
	c.mask_frac = (double)diff / (double)n;
	c.depth_med = both ? (double)d[both / 2] : 0.0;
	c.id_frac = both ? (double)same / (double)both : 1.0;
	c.both = (uint32_t)both;
	bc_free(d);
	return c;
}

#endif
