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
#include "blobcast/clock.h"
#include "blobcast/error.h"
#include "blobcast/log.h"

/* A PNG rectangle of more pixels than this is encoded a band of rows at a
 * time (a 2048^2 snapshot takes about 100 ms whole). */
#define PNG_STREAM_PIXELS (256u * 256u)
/* Rows between looks at the clock while streaming a PNG. */
#define PNG_ROWS_PER_LOOK 16u

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

/* zlib level of every PNG: most of the size win of zlib's default at a
 * third of its time (lossless stills are already ~30x a JPEG frame's
 * cost). */
#define PNG_LEVEL 3

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
	png_set_compression_level(png, PNG_LEVEL);
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

/* ---- A frame's rectangles, a slice at a time ----------------------------- */

/* A PNG being written a band of rows at a time. */
struct png_stream {
	png_structp png;
	png_infop info;
	struct png_sink sink;
	uint32_t row; /* the next row to write */
};

static void png_stream_free(struct png_stream *p)
{
	if (!p) {
		return;
	}
	png_destroy_write_struct(&p->png, &p->info);
	bc_free(p->sink.data);
	bc_free(p);
}

/* Starts a w x h PNG: its header goes into the sink. */
static int png_stream_new(struct png_stream **out, uint32_t w, uint32_t h)
{
	struct png_stream *p = bc_calloc(1, sizeof(*p));
	*out = NULL;
	if (!p) {
		return BC_ENOMEM;
	}
	p->png =
	    png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
	if (!p->png || !(p->info = png_create_info_struct(p->png))) {
		png_stream_free(p);
		return BC_ENOMEM;
	}
	if (setjmp(png_jmpbuf(p->png))) {
		int rc = p->sink.failed ? BC_ENOMEM : BC_ECODEC;
		png_stream_free(p);
		return rc;
	}
	png_set_write_fn(p->png, &p->sink, png_write, png_flush);
	png_set_IHDR(p->png, p->info, w, h, 8, PNG_COLOR_TYPE_RGB_ALPHA,
	             PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
	             PNG_FILTER_TYPE_DEFAULT);
	png_set_compression_level(p->png, PNG_LEVEL);
	png_write_info(p->png, p->info);
	*out = p;
	return 0;
}

/* Writes rows of rectangle r of rgba (stride width) until `until_ms` on
 * the clock; finishes the PNG after its last row. Returns 1 when done, 0
 * when rows remain, or an error. */
static int png_stream_rows(struct png_stream *p, const uint8_t *rgba,
                           uint32_t width, const struct bc_proto_rect *r,
                           double until_ms)
{
	if (setjmp(png_jmpbuf(p->png))) {
		return p->sink.failed ? BC_ENOMEM : BC_ECODEC;
	}
	while (p->row < r->h) {
		for (uint32_t k = 0; k < PNG_ROWS_PER_LOOK && p->row < r->h;
		     k++, p->row++) {
			png_write_row(
			    p->png,
			    (png_const_bytep)(rgba +
			                      ((size_t)(r->y + p->row) * width +
			                       r->x) *
			                          4u));
		}
		if (bc_clock_ms() >= until_ms) {
			break;
		}
	}
	if (p->row < r->h) {
		return 0;
	}
	png_write_end(p->png, NULL);
	return 1;
}

struct bc_encode_job {
	uint8_t *copy;
	const uint8_t *rgba;
	uint32_t iw, ih;
	struct bc_proto_rect *rects;
	uint32_t n, next;
	int encoding, quality;
	struct png_stream *png; /* the rectangle in progress */
	double ms;
};

int bc_encode_job_new(struct bc_encode_job **out, const uint8_t *rgba,
                      uint32_t iw, uint32_t ih, bool copy,
                      const struct bc_proto_rect *rects, uint32_t n,
                      int encoding, int quality)
{
	struct bc_encode_job *e;
	*out = NULL;
	for (uint32_t i = 0; i < n; i++) {
		if (rects[i].w == 0 || rects[i].h == 0 ||
		    (uint32_t)rects[i].x + rects[i].w > iw ||
		    (uint32_t)rects[i].y + rects[i].h > ih) {
			return BC_EINVAL;
		}
	}
	if (!(e = bc_calloc(1, sizeof(*e))) ||
	    !(e->rects = bc_calloc(n ? n : 1, sizeof(*e->rects)))) {
		bc_free(e);
		return BC_ENOMEM;
	}
	memcpy(e->rects, rects, (size_t)n * sizeof(*rects));
	for (uint32_t i = 0; i < n; i++) {
		e->rects[i].data.ptr = NULL;
		e->rects[i].data.len = 0;
	}
	if (copy) {
		size_t bytes = (size_t)iw * ih * 4u;
		if (!(e->copy = bc_malloc(bytes))) {
			bc_encode_job_free(e);
			return BC_ENOMEM;
		}
		memcpy(e->copy, rgba, bytes);
		rgba = e->copy;
	}
	e->rgba = rgba;
	e->iw = iw;
	e->ih = ih;
	e->n = n;
	e->encoding = encoding;
	e->quality = quality;
	*out = e;
	return 0;
}

/* Streams the current rectangle's PNG. Returns 1 when it is done. */
static int run_png(struct bc_encode_job *e, struct bc_proto_rect *r,
                   double until_ms)
{
	int rc;
	if (!e->png && (rc = png_stream_new(&e->png, r->w, r->h))) {
		return rc;
	}
	if ((rc = png_stream_rows(e->png, e->rgba, e->iw, r, until_ms)) != 1) {
		return rc;
	}
	r->data.ptr = e->png->sink.data;
	r->data.len = (uint32_t)e->png->sink.len;
	e->png->sink.data = NULL;
	png_stream_free(e->png);
	e->png = NULL;
	return 1;
}

int bc_encode_job_run(struct bc_encode_job *e, struct bc_encoder *enc,
                      double ms)
{
	double t0 = bc_clock_ms(), until = t0 + ms;
	int rc = 0;
	while (e->next < e->n) {
		struct bc_proto_rect *r = &e->rects[e->next];
		if (e->encoding == 2 &&
		    (uint32_t)r->w * r->h > PNG_STREAM_PIXELS) {
			rc = run_png(e, r, until);
		} else {
			struct bc_encoded out;
			rc = bc_encode_rect(enc, e->rgba, e->iw, r->x, r->y,
			                    r->w, r->h, e->encoding, e->quality,
			                    &out);
			if (rc == 0) {
				r->data.ptr = out.data;
				r->data.len = (uint32_t)out.len;
				rc = 1;
			}
		}
		if (rc < 0) {
			break;
		}
		e->next += rc == 1 ? 1u : 0u;
		if (rc == 0 || bc_clock_ms() >= until) {
			break;
		}
	}
	e->ms += bc_clock_ms() - t0;
	return rc < 0 ? rc : e->next == e->n ? 1 : 0;
}

struct bc_proto_rect *bc_encode_job_rects(struct bc_encode_job *e, uint32_t *n)
{
	*n = e->n;
	return e->rects;
}

double bc_encode_job_ms(const struct bc_encode_job *e)
{
	return e->ms;
}

void bc_encode_job_free(struct bc_encode_job *e)
{
	if (!e) {
		return;
	}
	for (uint32_t i = 0; i < e->n; i++) {
		bc_free((void *)e->rects[i].data.ptr);
	}
	png_stream_free(e->png);
	bc_free(e->rects);
	bc_free(e->copy);
	bc_free(e);
}
