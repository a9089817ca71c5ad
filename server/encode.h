/*
 * Frame encoding for the stream: TurboJPEG for interactive and still JPEG
 * frames, libpng for lossless stills, and raw RGBA. Each call encodes one
 * rectangle of an RGBA8 image (rows top to bottom) into a growable buffer.
 */
#ifndef BLOBCAST_SERVER_ENCODE_H
#define BLOBCAST_SERVER_ENCODE_H

#include <stddef.h>
#include <stdint.h>

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

#endif
