/*
 * Frame encoding (see encode.h). One encoder per thread: the TurboJPEG
 * handle is reused across frames.
 */
#include "encode.h"

#include <png.h>
#include <setjmp.h>
#include <stdbool.h>
#include <string.h>
#include <turbojpeg.h>

#include "blobcast/alloc.h"
#include "blobcast/error.h"
#include "blobcast/log.h"

struct bc_encoder {
	tjhandle tj;
};

struct bc_encoder *bc_encoder_create(void)
{
	struct bc_encoder *enc = bc_calloc(1, sizeof(*enc));
	if (!enc) {
		return NULL;
	}
	enc->tj = tjInitCompress();
	if (!enc->tj) {
		bc_free(enc);
		return NULL;
	}
	return enc;
}

void bc_encoder_destroy(struct bc_encoder *enc)
{
	if (!enc) {
		return;
	}
	tjDestroy(enc->tj);
	bc_free(enc);
}

static int encode_jpeg(struct bc_encoder *enc, const uint8_t *rgba,
                       uint32_t width, uint32_t x, uint32_t y, uint32_t w,
                       uint32_t h, int quality, struct bc_encoded *out)
{
	unsigned char *jpeg = NULL;
	unsigned long size = 0;
	const uint8_t *origin = rgba + ((size_t)y * width + x) * 4u;
	/* 4:2:0 for the moving stream; full chroma for high-quality stills,
	 * where colour fringes on thin features would show. */
	int samp = quality >= 90 ? TJSAMP_444 : TJSAMP_420;
	if (tjCompress2(enc->tj, origin, (int)w, (int)(width * 4u), (int)h,
	                TJPF_RGBA, &jpeg, &size, samp, quality,
	                TJFLAG_FASTDCT) != 0) {
		bc_log(BC_LOG_ERROR, "jpeg: %s", tjGetErrorStr2(enc->tj));
		tjFree(jpeg);
		return BC_ECODEC;
	}
	out->data = bc_malloc(size);
	if (!out->data) {
		tjFree(jpeg);
		return BC_ENOMEM;
	}
	memcpy(out->data, jpeg, size);
	out->len = size;
	tjFree(jpeg);
	return 0;
}

struct png_sink {
	uint8_t *data;
	size_t len, cap;
	bool failed;
};

static void png_write(png_structp png, png_bytep bytes, png_size_t n)
{
	struct png_sink *s = png_get_io_ptr(png);
	if (s->failed) {
		return;
	}
	if (s->len + n > s->cap) {
		size_t cap = s->cap ? s->cap : 65536;
		uint8_t *grown;
		while (cap < s->len + n) {
			cap *= 2;
		}
		grown = bc_realloc(s->data, cap);
		if (!grown) {
			s->failed = true;
			png_error(png, "out of memory");
		}
		s->data = grown;
		s->cap = cap;
	}
	memcpy(s->data + s->len, bytes, n);
	s->len += n;
}

static void png_flush(png_structp png)
{
	(void)png;
}

static int encode_png(const uint8_t *rgba, uint32_t width, uint32_t x,
                      uint32_t y, uint32_t w, uint32_t h,
                      struct bc_encoded *out)
{
	struct png_sink sink = {0};
	png_structp png;
	png_infop info = NULL;
	png_bytep *volatile rows = NULL;
	int rc = BC_ECODEC;
	png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
	if (!png || !(info = png_create_info_struct(png))) {
		png_destroy_write_struct(&png, NULL);
		return BC_ENOMEM;
	}
	rows = bc_calloc(h, sizeof(png_bytep));
	if (!rows) {
		png_destroy_write_struct(&png, &info);
		return BC_ENOMEM;
	}
	if (setjmp(png_jmpbuf(png))) {
		rc = sink.failed ? BC_ENOMEM : BC_ECODEC;
		goto out;
	}
	for (uint32_t r = 0; r < h; r++) {
		rows[r] =
		    (png_bytep)(rgba + ((size_t)(y + r) * width + x) * 4u);
	}
	png_set_write_fn(png, &sink, png_write, png_flush);
	png_set_IHDR(png, info, w, h, 8, PNG_COLOR_TYPE_RGB_ALPHA,
	             PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
	             PNG_FILTER_TYPE_DEFAULT);
	/* Level 3: most of the size win of zlib's default at a third of its
	 * time (lossless stills are already ~30x a JPEG frame's cost). */
	png_set_compression_level(png, 3);
	png_set_rows(png, info, rows);
	png_write_png(png, info, PNG_TRANSFORM_IDENTITY, NULL);
	out->data = sink.data;
	out->len = sink.len;
	sink.data = NULL;
	rc = 0;
out:
	png_destroy_write_struct(&png, &info);
	bc_free(rows);
	bc_free(sink.data);
	return rc;
}

static int encode_raw(const uint8_t *rgba, uint32_t width, uint32_t x,
                      uint32_t y, uint32_t w, uint32_t h,
                      struct bc_encoded *out)
{
	size_t row = (size_t)w * 4u;
	out->data = bc_malloc(row * h);
	if (!out->data) {
		return BC_ENOMEM;
	}
	for (uint32_t r = 0; r < h; r++) {
		memcpy(out->data + row * r,
		       rgba + ((size_t)(y + r) * width + x) * 4u, row);
	}
	out->len = row * h;
	return 0;
}

int bc_encode_rect(struct bc_encoder *enc, const uint8_t *rgba, uint32_t width,
                   uint32_t x, uint32_t y, uint32_t w, uint32_t h, int encoding,
                   int quality, struct bc_encoded *out)
{
	out->data = NULL;
	out->len = 0;
	if (w == 0 || h == 0) {
		return BC_EINVAL;
	}
	switch (encoding) {
	case 1:
		return encode_jpeg(enc, rgba, width, x, y, w, h, quality, out);
	case 2:
		return encode_png(rgba, width, x, y, w, h, out);
	case 3:
		return encode_raw(rgba, width, x, y, w, h, out);
	default:
		return BC_EINVAL;
	}
}
