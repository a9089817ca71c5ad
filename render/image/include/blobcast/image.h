/*
 * Image files for the tools and tests: a thin C interface over OpenImageIO
 * (which has no C API of its own). The format comes from the file name's
 * extension. Writers take one plane in memory -- RGBA8 colour, a single
 * float channel (depth) or a single uint32 channel (node ids) -- and refuse
 * formats that cannot store those samples exactly; the reader gives back any
 * image converted to the sample type asked for, within fixed limits because
 * files are untrusted.
 */
#ifndef BLOBCAST_IMAGE_H
#define BLOBCAST_IMAGE_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/error.h"

/* Largest width or height read back: larger than any frame we write
 * (BC_RENDER_MAX_DIM) yet small enough that a forged header cannot make the
 * reader ask for absurd memory. */
#define BC_IMAGE_MAX_DIM 65536u
/* Largest number of samples (width * height * channels) read back: 2^28
 * samples is 1 GiB of floats, an 8192^2 RGBA frame. */
#define BC_IMAGE_MAX_SAMPLES (1u << 28)
/* Channels read back: RGBA plus a few extra (EXR files may hold more). */
#define BC_IMAGE_MAX_CHANNELS 16u

enum bc_image_type {
	BC_IMAGE_INVALID = 0,
	BC_IMAGE_U8,  /* uint8_t samples */
	BC_IMAGE_F32, /* float samples */
	BC_IMAGE_U32, /* uint32_t samples */
	BC_IMAGE_TYPE_COUNT
};

/* An image in memory: width * height pixels of `channels` interleaved
 * samples of `type`, row 0 at the top, no padding. */
struct bc_image {
	uint32_t width, height, channels;
	enum bc_image_type type;
	void *pixels;
};

/* Returns true when the extension of path names a format that stores samples
 * of type exactly: U8 -- anything OpenImageIO writes (png, tif, exr, jpg,
 * ...; jpg is lossy and drops alpha); F32 -- .exr, .tif/.tiff, .pfm; U32 --
 * .tif/.tiff, .exr. Used to refuse a bad output name before any work. */
bool bc_image_ext_supports(const char *path, enum bc_image_type type);

/* Writes img to path. Formats without an alpha channel get the first three
 * of four U8 channels. Returns 0, BC_EINVAL (bad image, or a format that
 * cannot hold the sample type: see bc_image_ext_supports), BC_ENOTSUP
 * (unknown extension) or BC_EIO (the file could not be written); the reason,
 * including OpenImageIO's message, is in ei. */
int bc_image_write(const char *path, const struct bc_image *img,
                   struct bc_errinfo *ei);

/* Shorthands for the three planes of a rendered frame. */
int bc_image_write_rgba8(const char *path, uint32_t width, uint32_t height,
                         const uint8_t *rgba, struct bc_errinfo *ei);
int bc_image_write_float(const char *path, uint32_t width, uint32_t height,
                         const float *values, struct bc_errinfo *ei);
int bc_image_write_u32(const char *path, uint32_t width, uint32_t height,
                       const uint32_t *values, struct bc_errinfo *ei);

/* Reads the first subimage of path with all its channels, converted to
 * type, into *out (reset on entry; pixels allocated with bc_malloc, freed by
 * bc_image_finish). Returns 0, BC_EIO (missing or unreadable file),
 * BC_ELIMIT (over BC_IMAGE_MAX_DIM / _SAMPLES / _CHANNELS), BC_EINVAL (bad
 * type) or BC_ENOMEM. */
int bc_image_read(const char *path, enum bc_image_type type,
                  struct bc_image *out, struct bc_errinfo *ei);

/* Frees the pixels of an image filled by bc_image_read; accepts NULL and a
 * zeroed image. */
void bc_image_finish(struct bc_image *img);

#endif
