/*
 * Frame encoding for the stream: TurboJPEG for interactive and still JPEG
 * frames, libpng for lossless stills, and raw RGBA. Each call encodes one
 * rectangle of an RGBA8 image (rows top to bottom) into a growable buffer.
 */
#ifndef BLOBCAST_SERVER_ENCODE_H
#define BLOBCAST_SERVER_ENCODE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/proto.h"

struct bc_encoder;

/* Returns NULL on allocation failure. */
struct bc_encoder *bc_encoder_create(void);
void bc_encoder_destroy(struct bc_encoder *enc);

/* An encoded image: bytes owned by the caller (bc_free). */
struct bc_encoded {
	uint8_t *data;
	size_t len;
};

/* Encodes the rectangle (x, y, w, h) of rgba (width x height, stride
 * width * 4). encoding is 1 jpeg, 2 png, 3 raw (the protocol's numbers);
 * quality 1..100 applies to JPEG. Returns 0, BC_ECODEC or BC_ENOMEM. */
int bc_encode_rect(struct bc_encoder *enc, const uint8_t *rgba, uint32_t width,
                   uint32_t x, uint32_t y, uint32_t w, uint32_t h, int encoding,
                   int quality, struct bc_encoded *out);

/* ---- A frame's rectangles, encoded a slice at a time -------------------- */

/* The rectangles of one picture, in order, with their encoding state: a
 * render worker encodes for a few milliseconds and gives way, and the next
 * slice (maybe on another worker) goes on. Large PNG rectangles advance a
 * band of rows at a time; others are encoded whole. */
struct bc_encode_job;

/* Prepares the encoding of rects[0..n) of rgba (iw x ih, rows top to
 * bottom). With copy the picture is copied (a coarse level's picture lives
 * in a worker's scratch); without it the caller keeps rgba unchanged until
 * bc_encode_job_free. Returns 0, BC_EINVAL (a rectangle outside the
 * picture) or BC_ENOMEM. */
int bc_encode_job_new(struct bc_encode_job **out, const uint8_t *rgba,
                      uint32_t iw, uint32_t ih, bool copy,
                      const struct bc_proto_rect *rects, uint32_t n,
                      int encoding, int quality);
/* Encodes for about ms milliseconds (at least one band). Returns 1 when
 * every rectangle is done, 0 when more remains, or BC_ECODEC/BC_ENOMEM. */
int bc_encode_job_run(struct bc_encode_job *e, struct bc_encoder *enc,
                      double ms);
/* The rectangles with their encoded data, valid until the job is freed. */
struct bc_proto_rect *bc_encode_job_rects(struct bc_encode_job *e, uint32_t *n);
/* Encoding time so far, milliseconds. */
double bc_encode_job_ms(const struct bc_encode_job *e);
void bc_encode_job_free(struct bc_encode_job *e);

#endif
