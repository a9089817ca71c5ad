/*
 * Image checks for test_viewer.sh, reading files through bc_image:
 *   info FILE            prints "WIDTH HEIGHT COLOURS STDDEV": distinct RGB
 *                        colours and the standard deviation of all RGB
 *                        samples (a blank or flat image has few and ~0)
 *   same A B TOL         exit 0 when both have one size and every RGB
 *                        sample differs by at most TOL; else prints where
 *                        they differ and exits 1
 *   count FILE R G B TOL prints how many pixels are within TOL of (R, G, B)
 *                        in every channel
 *   lit FILE LEVEL       prints how many pixels have a channel above LEVEL:
 *                        the lit shapes against the renderer's dark
 *                        background (every channel below 43)
 *   border FILE LEVEL    the same for the outermost rows and columns only:
 *                        0 when the shapes lie wholly inside the image
 * Exit 2 on bad usage or an unreadable file.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/image.h"

static int load(const char *path, struct bc_image *img)
{
	struct bc_errinfo ei = {0};
	if (bc_image_read(path, BC_IMAGE_U8, img, &ei)) {
		fprintf(stderr, "viewer_imgcheck: %s: %s\n", path, ei.msg);
		return -1;
	}
	if (img->channels < 3) {
		fprintf(stderr, "viewer_imgcheck: %s: %u channels\n", path,
		        img->channels);
		bc_image_finish(img);
		return -1;
	}
	return 0;
}

static int cmp_u32(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return x < y ? -1 : x > y;
}

static int info(const char *path)
{
	struct bc_image img;
	size_t n, colours = 0;
	uint32_t *rgb;
	double sum = 0.0, sq = 0.0, mean;
	if (load(path, &img)) {
		return 2;
	}
	n = (size_t)img.width * img.height;
	if (!(rgb = bc_calloc(n, sizeof(*rgb)))) {
		bc_image_finish(&img);
		return 2;
	}
	for (size_t i = 0; i < n; i++) {
		const uint8_t *p =
		    (const uint8_t *)img.pixels + i * img.channels;
		rgb[i] = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
		for (int c = 0; c < 3; c++) {
			sum += p[c];
			sq += (double)p[c] * p[c];
		}
	}
	qsort(rgb, n, sizeof(*rgb), cmp_u32);
	for (size_t i = 0; i < n; i++) {
		colours += i == 0 || rgb[i] != rgb[i - 1];
	}
	mean = sum / (3.0 * (double)n);
	printf("%u %u %zu %.2f\n", img.width, img.height, colours,
	       sqrt(fmax(sq / (3.0 * (double)n) - mean * mean, 0.0)));
	bc_free(rgb);
	bc_image_finish(&img);
	return 0;
}

static int same(const char *pa, const char *pb, int tol)
{
	struct bc_image a, b;
	size_t bad = 0, first = 0;
	int worst = 0, rc;
	if (load(pa, &a)) {
		return 2;
	}
	if (load(pb, &b)) {
		bc_image_finish(&a);
		return 2;
	}
	if (a.width != b.width || a.height != b.height) {
		printf("sizes differ: %ux%u vs %ux%u\n", a.width, a.height,
		       b.width, b.height);
		rc = 1;
		goto out;
	}
	for (size_t i = 0; i < (size_t)a.width * a.height; i++) {
		const uint8_t *p = (const uint8_t *)a.pixels + i * a.channels;
		const uint8_t *q = (const uint8_t *)b.pixels + i * b.channels;
		int d = 0;
		for (int c = 0; c < 3; c++) {
			int e = abs((int)p[c] - (int)q[c]);
			d = e > d ? e : d;
		}
		if (d > tol) {
			if (bad++ == 0) {
				first = i;
			}
		}
		worst = d > worst ? d : worst;
	}
	if (bad) {
		printf("%zu pixels differ by more than %d (largest %d), the "
		       "first at (%zu, %zu)\n",
		       bad, tol, worst, first % a.width, first / a.width);
	}
	rc = bad ? 1 : 0;
out:
	bc_image_finish(&a);
	bc_image_finish(&b);
	return rc;
}

/* What count() counts. */
enum count_mode {
	COUNT_NEAR = 0, /* pixels within v[3] of (v[0], v[1], v[2]) */
	COUNT_LIT,      /* pixels with a channel above v[0] */
	COUNT_BORDER,   /* such pixels in the outermost rows and columns */
	COUNT_MODE_COUNT
};

/* Prints how many pixels of the image at path are as mode says. */
static int count(const char *path, enum count_mode mode, const int v[4])
{
	struct bc_image img;
	size_t n = 0;
	if (load(path, &img)) {
		return 2;
	}
	for (size_t i = 0; i < (size_t)img.width * img.height; i++) {
		const uint8_t *p =
		    (const uint8_t *)img.pixels + i * img.channels;
		size_t x = i % img.width, y = i / img.width;
		bool edge = x == 0 || y == 0 || x + 1 == img.width ||
		            y + 1 == img.height;
		if (mode == COUNT_NEAR) {
			n += abs(p[0] - v[0]) <= v[3] &&
			     abs(p[1] - v[1]) <= v[3] &&
			     abs(p[2] - v[2]) <= v[3];
		} else if (mode == COUNT_LIT || edge) {
			n += p[0] > v[0] || p[1] > v[0] || p[2] > v[0];
		}
	}
	printf("%zu\n", n);
	bc_image_finish(&img);
	return 0;
}

int main(int argc, char **argv)
{
	if (argc == 3 && strcmp(argv[1], "info") == 0) {
		return info(argv[2]);
	}
	if (argc == 5 && strcmp(argv[1], "same") == 0) {
		return same(argv[2], argv[3], atoi(argv[4]));
	}
	if (argc == 7 && strcmp(argv[1], "count") == 0) {
		const int v[4] = {atoi(argv[3]), atoi(argv[4]), atoi(argv[5]),
		                  atoi(argv[6])};
		return count(argv[2], COUNT_NEAR, v);
	}
	if (argc == 4 &&
	    (strcmp(argv[1], "lit") == 0 || strcmp(argv[1], "border") == 0)) {
		const int v[4] = {atoi(argv[3]), 0, 0, 0};
		return count(argv[2],
		             argv[1][0] == 'l' ? COUNT_LIT : COUNT_BORDER, v);
	}
	fprintf(stderr, "usage: viewer_imgcheck info FILE | same A B TOL | "
	                "count FILE R G B TOL | lit FILE LEVEL | border FILE "
	                "LEVEL\n");
	return 2;
}
