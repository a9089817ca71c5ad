/*
 * Frame assembly: rectangles in raw RGBA, JPEG and PNG land at their place
 * in the client framebuffer, coverage tells when the picture is whole, a
 * frame of a new size starts a new picture, and bad rectangles (outside the
 * image, wrong byte counts, corrupt or mis-sized images) are refused
 * without touching pixels they do not own. Test images are encoded here
 * with TurboJPEG and libpng directly, independently of the server's code.
 */
#include <png.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "test.h"

/* A recognisable pattern: every pixel differs from its neighbours. */
static void pattern(uint8_t *rgba, uint32_t w, uint32_t h, uint32_t seed)
{
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			uint8_t *p = rgba + ((size_t)y * w + x) * 4u;
			p[0] = (uint8_t)(x * 16u + seed);
			p[1] = (uint8_t)(y * 16u + seed * 3u);
			p[2] = (uint8_t)((x ^ y) * 8u + seed * 7u);
			p[3] = 255;
		}
	}
}

/* A smooth pattern, which JPEG reproduces closely. */
static void gradient(uint8_t *rgba, uint32_t w, uint32_t h)
{
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			uint8_t *p = rgba + ((size_t)y * w + x) * 4u;
			p[0] = (uint8_t)(x * 255u / (w - 1));
			p[1] = (uint8_t)(y * 255u / (h - 1));
			p[2] = 128;
			p[3] = 255;
		}
	}
}

static struct bc_msg frame_msg(uint16_t w, uint16_t h,
                               enum bc_proto_encoding enc,
                               const struct bc_proto_rect *rects, uint16_t n)
{
	struct bc_msg m = {.type = BC_MSG_FRAME};
	m.flags = BC_PROTO_FLAG_STILL;
	m.frame.frame_no = 9;
	m.frame.order = 4;
	m.frame.camera_seq = 2;
	m.frame.encoding = enc;
	m.frame.width = w;
	m.frame.height = h;
	m.frame.image_width = w;
	m.frame.image_height = h;
	m.frame.nrects = n;
	m.frame.rects = rects;
	return m;
}

/* The pixel (x, y) of img equals pixel (sx, sy) of src (src_w wide). */
static int same_px(const struct bc_client_image *img, uint32_t x, uint32_t y,
                   const uint8_t *src, uint32_t src_w, uint32_t sx, uint32_t sy)
{
	return memcmp(img->rgba + ((size_t)y * img->width + x) * 4u,
	              src + ((size_t)sy * src_w + sx) * 4u, 4) == 0;
}

/* ---- encoders for test data -----------------------------------------------
 */

struct membuf {
	uint8_t *data;
	size_t len, cap;
};

static void png_mem_write(png_structp png, png_bytep b, png_size_t n)
{
	struct membuf *m = png_get_io_ptr(png);
	if (m->len + n > m->cap) {
		m->cap = (m->len + n) * 2u;
		m->data = realloc(m->data, m->cap);
	}
	memcpy(m->data + m->len, b, n);
	m->len += n;
}

static void png_mem_flush(png_structp png)
{
	(void)png;
}

/* Encodes w x h pixels of channels (1 gray, 3 RGB, 4 RGBA) taken from the
 * first channels of rgba. Returns malloc'd bytes. */
static uint8_t *make_png(const uint8_t *rgba, uint32_t w, uint32_t h,
                         int channels, size_t *len)
{
	struct membuf m = {0};
	png_structp png =
	    png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
	png_infop info = png_create_info_struct(png);
	uint8_t *row = malloc((size_t)w * 4u);
	int type = channels == 1   ? PNG_COLOR_TYPE_GRAY
	           : channels == 3 ? PNG_COLOR_TYPE_RGB
	                           : PNG_COLOR_TYPE_RGB_ALPHA;
	if (setjmp(png_jmpbuf(png))) {
		abort();
	}
	png_set_write_fn(png, &m, png_mem_write, png_mem_flush);
	png_set_IHDR(png, info, w, h, 8, type, PNG_INTERLACE_NONE,
	             PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
	png_write_info(png, info);
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			const uint8_t *p = rgba + ((size_t)y * w + x) * 4u;
			memcpy(row + (size_t)x * (size_t)channels, p,
			       (size_t)channels);
		}
		png_write_row(png, row);
	}
	png_write_end(png, NULL);
	png_destroy_write_struct(&png, &info);
	free(row);
	*len = m.len;
	return m.data;
}

static uint8_t *make_jpeg(const uint8_t *rgba, uint32_t w, uint32_t h,
                          size_t *len)
{
	tjhandle tj = tjInitCompress();
	unsigned char *jpeg = NULL;
	unsigned long size = 0;
	uint8_t *copy;
	if (tjCompress2(tj, rgba, (int)w, 0, (int)h, TJPF_RGBA, &jpeg, &size,
	                TJSAMP_444, 100, 0) != 0) {
		abort();
	}
	copy = malloc(size);
	memcpy(copy, jpeg, size);
	tjFree(jpeg);
	tjDestroy(tj);
	*len = size;
	return copy;
}

/* ---- tests ------------------------------------------------------------------
 */

static void test_raw_full_frame_fills_image(void)
{
	uint8_t src[6 * 4 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r = {0, 0, 6, 4, {src, sizeof(src)}};
	struct bc_msg m = frame_msg(6, 4, BC_PROTO_ENC_RAW, &r, 1);
	pattern(src, 6, 4, 1);
	bc_client_image_init(&img);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.width, 6);
	CHECK_EQ_INT(img.height, 4);
	CHECK(img.complete);
	CHECK_MEMEQ(img.rgba, src, sizeof(src));
	CHECK_EQ_INT(img.frame_no, 9);
	CHECK_EQ_INT(img.order, 4);
	CHECK_EQ_INT(img.camera_seq, 2);
	CHECK_EQ_INT(img.flags, BC_PROTO_FLAG_STILL);
	CHECK_EQ_INT(img.nrects, 1);
	bc_client_image_finish(&img);
	CHECK(img.rgba == NULL);
}

static void test_partial_rects_replace_only_their_pixels(void)
{
	uint8_t base[8 * 8 * 4], patch[3 * 2 * 4], patch2[1 * 1 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect full = {0, 0, 8, 8, {base, sizeof(base)}};
	struct bc_proto_rect two[2] = {
	    {5, 6, 3, 2, {patch, sizeof(patch)}},
	    {0, 0, 1, 1, {patch2, sizeof(patch2)}},
	};
	struct bc_msg m = frame_msg(8, 8, BC_PROTO_ENC_RAW, &full, 1);
	pattern(base, 8, 8, 0);
	pattern(patch, 3, 2, 99);
	pattern(patch2, 1, 1, 50);
	bc_client_image_init(&img);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	m = frame_msg(8, 8, BC_PROTO_ENC_RAW, two, 2);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK(img.complete);
	for (uint32_t y = 0; y < 8; y++) {
		for (uint32_t x = 0; x < 8; x++) {
			if (x >= 5 && y >= 6) {
				CHECK(same_px(&img, x, y, patch, 3, x - 5,
				              y - 6));
			} else if (x == 0 && y == 0) {
				CHECK(same_px(&img, x, y, patch2, 1, 0, 0));
			} else {
				CHECK(same_px(&img, x, y, base, 8, x, y));
			}
		}
	}
	bc_client_image_finish(&img);
}

static void test_coverage_completes_from_pieces(void)
{
	uint8_t top[10 * 3 * 4], bottom[10 * 4 * 4], again[10 * 3 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r_top = {0, 0, 10, 3, {top, sizeof(top)}};
	struct bc_proto_rect r_again = {0, 0, 10, 3, {again, sizeof(again)}};
	struct bc_proto_rect r_bot = {0, 3, 10, 4, {bottom, sizeof(bottom)}};
	struct bc_msg m;
	pattern(top, 10, 3, 5);
	pattern(again, 10, 3, 6);
	pattern(bottom, 10, 4, 7);
	bc_client_image_init(&img);
	m = frame_msg(10, 7, BC_PROTO_ENC_RAW, &r_top, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK(!img.complete);
	/* The same pixels twice do not count twice. */
	m = frame_msg(10, 7, BC_PROTO_ENC_RAW, &r_again, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK(!img.complete);
	m = frame_msg(10, 7, BC_PROTO_ENC_RAW, &r_bot, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK(img.complete);
	CHECK(same_px(&img, 9, 2, again, 10, 9, 2));
	CHECK(same_px(&img, 4, 6, bottom, 10, 4, 3));
	bc_client_image_finish(&img);
}

static void test_new_size_starts_new_picture(void)
{
	uint8_t big[8 * 8 * 4], small[4 * 4 * 4], part[2 * 2 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r_big = {0, 0, 8, 8, {big, sizeof(big)}};
	struct bc_proto_rect r_small = {0, 0, 4, 4, {small, sizeof(small)}};
	struct bc_proto_rect r_part = {2, 2, 2, 2, {part, sizeof(part)}};
	struct bc_msg m;
	pattern(big, 8, 8, 1);
	pattern(small, 4, 4, 2);
	pattern(part, 2, 2, 3);
	bc_client_image_init(&img);
	m = frame_msg(8, 8, BC_PROTO_ENC_RAW, &r_big, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	/* A downscaled interactive frame of a 8x8 view. */
	m = frame_msg(8, 8, BC_PROTO_ENC_RAW, &r_small, 1);
	m.frame.image_width = 4;
	m.frame.image_height = 4;
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.width, 4);
	CHECK_EQ_INT(img.view_width, 8);
	CHECK(img.complete);
	CHECK_MEMEQ(img.rgba, small, sizeof(small));
	/* Back to full size with only part of it: the rest is unknown. */
	m = frame_msg(8, 8, BC_PROTO_ENC_RAW, &r_part, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.width, 8);
	CHECK(!img.complete);
	CHECK(same_px(&img, 3, 3, part, 2, 1, 1));
	CHECK(img.rgba[0] == 0 && img.rgba[3] == 0);
	bc_client_image_finish(&img);
}

/* Refinement: a level-2 picture of a 7x5 view is 2x2 pixels, one per 4x4
 * block; the image reports its level and that it is still refining until
 * a level-0 frame without INCOMPLETE arrives. */
static void test_levels_are_reported(void)
{
	uint8_t coarse[2 * 2 * 4], fine[7 * 5 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r_coarse = {0, 0, 2, 2, {coarse, sizeof(coarse)}};
	struct bc_proto_rect r_fine = {0, 0, 7, 5, {fine, sizeof(fine)}};
	struct bc_msg m;
	pattern(coarse, 2, 2, 5);
	pattern(fine, 7, 5, 6);
	bc_client_image_init(&img);
	m = frame_msg(7, 5, BC_PROTO_ENC_RAW, &r_coarse, 1);
	m.flags = bc_proto_flags_with_level(0, 2);
	m.frame.image_width = bc_proto_level_dim(7, 2);
	m.frame.image_height = bc_proto_level_dim(5, 2);
	REQUIRE(m.frame.image_width == 2 && m.frame.image_height == 2);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.level, 2);
	CHECK(img.refining);
	CHECK(img.complete);
	CHECK_EQ_INT(img.width, 2);
	CHECK_EQ_INT(img.view_width, 7);
	CHECK_MEMEQ(img.rgba, coarse, sizeof(coarse));
	/* Level 1, cut by the budget: still refining. */
	m.flags = bc_proto_flags_with_level(BC_PROTO_FLAG_INCOMPLETE, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.level, 1);
	CHECK(img.refining);
	/* Level 0 but INCOMPLETE: the budget stopped refinement. */
	m = frame_msg(7, 5, BC_PROTO_ENC_RAW, &r_fine, 1);
	m.flags = BC_PROTO_FLAG_INCOMPLETE;
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.level, 0);
	CHECK(img.refining);
	/* The still ends it. */
	m.flags = BC_PROTO_FLAG_STILL;
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK_EQ_INT(img.level, 0);
	CHECK(!img.refining);
	CHECK_MEMEQ(img.rgba, fine, sizeof(fine));
	bc_client_image_finish(&img);
	CHECK_EQ_INT(img.level, 0);
	CHECK(!img.refining);
}

static void test_jpeg_rect_decodes_in_place(void)
{
	uint8_t base[32 * 24 * 4], grad[16 * 8 * 4];
	size_t len;
	uint8_t *jpeg;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r_base = {0, 0, 32, 24, {base, sizeof(base)}};
	struct bc_proto_rect r;
	struct bc_msg m;
	int worst = 0;
	pattern(base, 32, 24, 4);
	gradient(grad, 16, 8);
	jpeg = make_jpeg(grad, 16, 8, &len);
	bc_client_image_init(&img);
	m = frame_msg(32, 24, BC_PROTO_ENC_RAW, &r_base, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	r = (struct bc_proto_rect){16, 8, 16, 8, {jpeg, (uint32_t)len}};
	m = frame_msg(32, 24, BC_PROTO_ENC_JPEG, &r, 1);
	if (bc_client_image_apply(&img, &m, &ei) != 0) {
		fprintf(stderr, "  %s\n", ei.msg);
		CHECK(0);
	}
	CHECK_EQ_INT(img.encoding, BC_PROTO_ENC_JPEG);
	for (uint32_t y = 0; y < 24; y++) {
		for (uint32_t x = 0; x < 32; x++) {
			const uint8_t *p = img.rgba + ((size_t)y * 32 + x) * 4;
			if (x >= 16 && y >= 8 && y < 16) {
				const uint8_t *q =
				    grad + ((size_t)(y - 8) * 16 + x - 16) * 4;
				for (int c = 0; c < 3; c++) {
					int d = abs((int)p[c] - (int)q[c]);
					worst = d > worst ? d : worst;
				}
				CHECK_EQ_INT(p[3], 255);
			} else {
				CHECK(same_px(&img, x, y, base, 32, x, y));
			}
		}
	}
	/* Quality 100, 4:4:4: only rounding in the colour transform. */
	CHECK(worst <= 3);
	bc_client_image_finish(&img);
	free(jpeg);
}

static void test_png_rects_decode_exactly(void)
{
	uint8_t src[12 * 10 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	int channels[] = {4, 3, 1};
	pattern(src, 12, 10, 8);
	bc_client_image_init(&img);
	for (size_t i = 0; i < 3; i++) {
		size_t len;
		uint8_t *png = make_png(src, 12, 10, channels[i], &len);
		struct bc_proto_rect r = {0, 0, 12, 10, {png, (uint32_t)len}};
		struct bc_msg m = frame_msg(12, 10, BC_PROTO_ENC_PNG, &r, 1);
		if (bc_client_image_apply(&img, &m, &ei) != 0) {
			fprintf(stderr, "  channels %d: %s\n", channels[i],
			        ei.msg);
			CHECK(0);
		}
		for (size_t p = 0; p < 12 * 10; p++) {
			const uint8_t *a = img.rgba + p * 4, *b = src + p * 4;
			if (channels[i] == 1) {
				/* Gray expands to r = g = b. */
				CHECK(a[0] == b[0] && a[1] == b[0] &&
				      a[2] == b[0]);
			} else {
				CHECK_MEMEQ(a, b, 3);
			}
			CHECK_EQ_INT(a[3], 255);
		}
		free(png);
	}
	bc_client_image_finish(&img);
}

static void test_rect_outside_image_is_refused_untouched(void)
{
	uint8_t base[4 * 4 * 4], patch[2 * 2 * 4];
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r_base = {0, 0, 4, 4, {base, sizeof(base)}};
	struct bc_proto_rect bad[] = {
	    {3, 0, 2, 2, {patch, sizeof(patch)}},
	    {0, 3, 2, 2, {patch, sizeof(patch)}},
	    {0, 0, 0, 2, {patch, 0}},
	    {65535, 65535, 2, 2, {patch, sizeof(patch)}},
	};
	struct bc_msg m;
	pattern(base, 4, 4, 1);
	pattern(patch, 2, 2, 2);
	bc_client_image_init(&img);
	m = frame_msg(4, 4, BC_PROTO_ENC_RAW, &r_base, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		/* A good first rectangle must not be written either. */
		struct bc_proto_rect two[2] = {
		    {0, 0, 2, 2, {patch, sizeof(patch)}}, bad[i]};
		m = frame_msg(4, 4, BC_PROTO_ENC_RAW, two, 2);
		CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ERANGE);
		CHECK_MEMEQ(img.rgba, base, sizeof(base));
		CHECK(img.complete);
	}
	bc_client_image_finish(&img);
}

static void test_bad_bytes_are_codec_errors(void)
{
	uint8_t base[16 * 16 * 4], grad[16 * 16 * 4];
	size_t jlen, plen;
	uint8_t *jpeg, *png;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_proto_rect r_base = {0, 0, 16, 16, {base, sizeof(base)}};
	struct bc_proto_rect r;
	struct bc_msg m;
	pattern(base, 16, 16, 3);
	gradient(grad, 16, 16);
	jpeg = make_jpeg(grad, 16, 16, &jlen);
	png = make_png(grad, 16, 16, 4, &plen);
	bc_client_image_init(&img);
	m = frame_msg(16, 16, BC_PROTO_ENC_RAW, &r_base, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);

	/* Raw with one byte missing. */
	r = (struct bc_proto_rect){0, 0, 16, 16, {base, sizeof(base) - 1}};
	m = frame_msg(16, 16, BC_PROTO_ENC_RAW, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	CHECK(!img.complete);

	/* A 16x16 JPEG in an 8x8 rectangle, then a truncated one. */
	r = (struct bc_proto_rect){0, 0, 8, 8, {jpeg, (uint32_t)jlen}};
	m = frame_msg(16, 16, BC_PROTO_ENC_JPEG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	r = (struct bc_proto_rect){0, 0, 16, 16, {jpeg, (uint32_t)jlen / 2}};
	m = frame_msg(16, 16, BC_PROTO_ENC_JPEG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	r = (struct bc_proto_rect){0, 0, 16, 16, {jpeg, 0}};
	m = frame_msg(16, 16, BC_PROTO_ENC_JPEG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);

	/* PNG: too big for its rectangle, truncated, corrupt, not a PNG. */
	r = (struct bc_proto_rect){0, 0, 8, 16, {png, (uint32_t)plen}};
	m = frame_msg(16, 16, BC_PROTO_ENC_PNG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	r = (struct bc_proto_rect){0, 0, 16, 16, {png, (uint32_t)plen - 20}};
	m = frame_msg(16, 16, BC_PROTO_ENC_PNG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	png[plen / 2] ^= 0xff;
	r = (struct bc_proto_rect){0, 0, 16, 16, {png, (uint32_t)plen}};
	m = frame_msg(16, 16, BC_PROTO_ENC_PNG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	r = (struct bc_proto_rect){0, 0, 16, 16, {jpeg, (uint32_t)jlen}};
	m = frame_msg(16, 16, BC_PROTO_ENC_PNG, &r, 1);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	CHECK(!img.complete);

	/* A good full frame makes the picture whole again. */
	m = frame_msg(16, 16, BC_PROTO_ENC_RAW, &r_base, 1);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK(img.complete);

	m = (struct bc_msg){.type = BC_MSG_PING};
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_EINVAL);
	bc_client_image_finish(&img);
	free(jpeg);
	free(png);
}

/* Every allocation of a PNG frame fails in turn: each failure is reported
 * (ENOMEM, or ECODEC when libpng turns it into its own error) and frees
 * what it took (ASan's leak check runs at exit). */
static void test_allocation_failures_are_reported(void)
{
	uint8_t src[20 * 12 * 4];
	size_t len;
	uint8_t *png;
	unsigned long n;
	pattern(src, 20, 12, 9);
	png = make_png(src, 20, 12, 3, &len);
	for (n = 1; n < 1000; n++) {
		struct bc_client_image img;
		struct bc_errinfo ei = {0};
		struct bc_proto_rect r[2] = {
		    {0, 0, 20, 12, {png, (uint32_t)len}},
		    {0, 0, 20, 12, {png, (uint32_t)len}},
		};
		struct bc_msg m = frame_msg(20, 12, BC_PROTO_ENC_PNG, r, 2);
		int rc;
		bc_client_image_init(&img);
		bc_alloc_fail_after(n);
		rc = bc_client_image_apply(&img, &m, &ei);
		bc_alloc_fail_after(0);
		bc_client_image_finish(&img);
		if (rc == 0) {
			break;
		}
		CHECK(rc == BC_ENOMEM || rc == BC_ECODEC);
	}
	CHECK(n > 2 && n < 1000);
	free(png);
}

static const struct bc_test tests[] = {
    {"raw_full_frame_fills_image", test_raw_full_frame_fills_image},
    {"partial_rects_replace_only_their_pixels",
     test_partial_rects_replace_only_their_pixels},
    {"coverage_completes_from_pieces", test_coverage_completes_from_pieces},
    {"new_size_starts_new_picture", test_new_size_starts_new_picture},
    {"levels_are_reported", test_levels_are_reported},
    {"jpeg_rect_decodes_in_place", test_jpeg_rect_decodes_in_place},
    {"png_rects_decode_exactly", test_png_rects_decode_exactly},
    {"rect_outside_image_is_refused_untouched",
     test_rect_outside_image_is_refused_untouched},
    {"bad_bytes_are_codec_errors", test_bad_bytes_are_codec_errors},
    {"allocation_failures_are_reported", test_allocation_failures_are_reported},
};

BC_TEST_MAIN(tests)
