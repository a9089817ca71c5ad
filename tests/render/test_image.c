/*
 * Image files through bc_image: each plane a frame produces survives a round
 * trip through the formats the CLI offers for it (RGBA8 png and tif, float
 * exr/tif/pfm, uint32 tif/exr), formats that would lose samples are refused
 * by name, and the reader bounds what a file header may ask for.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/image.h"
#include "test.h"

static char dir[64];

static const char *tmp_path(const char *name)
{
	static char path[128];
	if (!dir[0]) {
		strcpy(dir, "/tmp/bc-test-image-XXXXXX");
		if (!mkdtemp(dir)) {
			return NULL;
		}
	}
	snprintf(path, sizeof(path), "%s/%s", dir, name);
	return path;
}

/* Odd sizes catch row/column mix-ups and stride errors. */
enum { W = 13, H = 7 };

static void test_rgba8_round_trip_png_and_tif(void)
{
	static const char *names[] = {"rgba.png", "rgba.tif"};
	uint8_t px[W * H * 4];
	for (int i = 0; i < W * H * 4; i++) {
		px[i] = (uint8_t)((i * 37 + 11) & 0xff);
	}
	for (size_t n = 0; n < 2; n++) {
		struct bc_errinfo ei = {0};
		struct bc_image back;
		const char *path = tmp_path(names[n]);
		REQUIRE(path);
		CHECK_EQ_INT(bc_image_write_rgba8(path, W, H, px, &ei), 0);
		REQUIRE(bc_image_read(path, BC_IMAGE_U8, &back, &ei) == 0);
		CHECK_EQ_INT(back.width, W);
		CHECK_EQ_INT(back.height, H);
		CHECK_EQ_INT(back.channels, 4);
		if (back.channels == 4) {
			CHECK_MEMEQ(back.pixels, px, sizeof(px));
		}
		bc_image_finish(&back);
		unlink(path);
	}
}

static void test_float_round_trip_exr_tif_pfm(void)
{
	static const char *names[] = {"depth.exr", "depth.tif", "depth.pfm"};
	float v[W * H];
	for (int i = 0; i < W * H; i++) {
		v[i] = (float)i * 0.37f - 3.0f;
	}
	v[5] = INFINITY; /* a miss: depth planes carry +inf */
	for (size_t n = 0; n < 3; n++) {
		struct bc_errinfo ei = {0};
		struct bc_image back;
		const char *path = tmp_path(names[n]);
		int bad = 0;
		REQUIRE(path);
		if (bc_image_write_float(path, W, H, v, &ei) != 0) {
			fprintf(stderr, "  %s\n", ei.msg);
			bc_test_failures++;
		}
		REQUIRE(bc_image_read(path, BC_IMAGE_F32, &back, &ei) == 0);
		CHECK_EQ_INT(back.width, W);
		CHECK_EQ_INT(back.height, H);
		CHECK_EQ_INT(back.channels, 1);
		for (int i = 0; i < W * H && back.channels == 1; i++) {
			/* Bit-exact: depth files must not be quantized. */
			bad += memcmp(&((float *)back.pixels)[i], &v[i],
			              sizeof(float)) != 0;
		}
		if (bad) {
			fprintf(stderr, "  %s: %d samples differ\n", names[n],
			        bad);
		}
		CHECK_EQ_INT(bad, 0);
		bc_image_finish(&back);
		unlink(path);
	}
}

static void test_u32_round_trip_tif_exr(void)
{
	static const char *names[] = {"ids.tif", "ids.exr"};
	uint32_t v[W * H];
	for (int i = 0; i < W * H; i++) {
		/* Values above 2^24 would not survive a float channel. */
		v[i] = (uint32_t)i * 2654435761u;
	}
	v[0] = 0;
	v[1] = UINT32_MAX;
	for (size_t n = 0; n < 2; n++) {
		struct bc_errinfo ei = {0};
		struct bc_image back;
		const char *path = tmp_path(names[n]);
		REQUIRE(path);
		CHECK_EQ_INT(bc_image_write_u32(path, W, H, v, &ei), 0);
		REQUIRE(bc_image_read(path, BC_IMAGE_U32, &back, &ei) == 0);
		CHECK_EQ_INT(back.width, W);
		CHECK_EQ_INT(back.height, H);
		CHECK_EQ_INT(back.channels, 1);
		if (back.channels == 1) {
			CHECK_MEMEQ(back.pixels, v, sizeof(v));
		}
		bc_image_finish(&back);
		unlink(path);
	}
}

static void test_lossy_formats_are_refused_by_type(void)
{
	float f[4] = {1, 2, 3, 4};
	uint32_t u[4] = {1, 2, 3, 4};
	struct bc_errinfo ei = {0};
	const char *png = tmp_path("x.png");
	REQUIRE(png);
	CHECK(bc_image_ext_supports("a/b.EXR", BC_IMAGE_F32));
	CHECK(bc_image_ext_supports("b.tiff", BC_IMAGE_U32));
	CHECK(!bc_image_ext_supports("b.png", BC_IMAGE_F32));
	CHECK(!bc_image_ext_supports("b.pfm", BC_IMAGE_U32));
	CHECK(!bc_image_ext_supports("dir.exr/noext", BC_IMAGE_F32));
	CHECK(bc_image_ext_supports("b.png", BC_IMAGE_U8));
	CHECK(!bc_image_ext_supports("b.nosuchformat", BC_IMAGE_U8));
	CHECK_EQ_INT(bc_image_write_float(png, 2, 2, f, &ei), BC_EINVAL);
	CHECK(strstr(ei.msg, ".png") != NULL);
	CHECK_EQ_INT(bc_image_write_u32(png, 2, 2, u, &ei), BC_EINVAL);
	CHECK(access(png, F_OK) != 0);
}

static void test_unknown_extension_and_missing_file(void)
{
	uint8_t px[16] = {0};
	struct bc_errinfo ei = {0};
	struct bc_image back = {1, 1, 1, BC_IMAGE_U8, px};
	const char *path = tmp_path("x.nosuchformat");
	REQUIRE(path);
	CHECK_EQ_INT(bc_image_write_rgba8(path, 2, 2, px, &ei), BC_ENOTSUP);
	CHECK(strstr(ei.msg, "nosuchformat") != NULL);
	CHECK_EQ_INT(
	    bc_image_read(tmp_path("missing.png"), BC_IMAGE_U8, &back, &ei),
	    BC_EIO);
	/* The out-parameter is reset even on failure. */
	CHECK(back.pixels == NULL && back.width == 0);
	CHECK_EQ_INT(bc_image_write_rgba8(path, 0, 2, px, &ei), BC_EINVAL);
	bc_image_finish(NULL);
}

static void test_jpeg_keeps_colour_drops_alpha(void)
{
	uint8_t px[W * H * 4];
	struct bc_errinfo ei = {0};
	struct bc_image back;
	const char *path = tmp_path("rgba.jpg");
	REQUIRE(path);
	for (int i = 0; i < W * H; i++) {
		px[4 * i + 0] = 200;
		px[4 * i + 1] = 100;
		px[4 * i + 2] = 50;
		px[4 * i + 3] = 7; /* alpha: not stored by jpeg */
	}
	CHECK_EQ_INT(bc_image_write_rgba8(path, W, H, px, &ei), 0);
	REQUIRE(bc_image_read(path, BC_IMAGE_U8, &back, &ei) == 0);
	CHECK_EQ_INT(back.channels, 3);
	if (back.channels == 3) {
		const uint8_t *b = back.pixels;
		CHECK(abs((int)b[0] - 200) < 8 && abs((int)b[1] - 100) < 8 &&
		      abs((int)b[2] - 50) < 8);
	}
	bc_image_finish(&back);
	unlink(path);
}

/* Reads up to cap bytes of path into buf; returns how many (0 when it
 * cannot be read). */
static size_t slurp(const char *path, char *buf, size_t cap)
{
	FILE *f = fopen(path, "rb");
	size_t n;
	if (!f) {
		return 0;
	}
	n = fread(buf, 1, cap, f);
	fclose(f);
	return n;
}

static bool has_text(const char *buf, size_t n, const char *text)
{
	size_t k = strlen(text);
	for (size_t i = 0; i + k <= n; i++) {
		if (!memcmp(buf + i, text, k)) {
			return true;
		}
	}
	return false;
}

/* TIFF and OpenEXR files state when they were written; with
 * SOURCE_DATE_EPOCH set they state that time instead, so that writing the
 * same image twice gives the same bytes; a value that is not a count of
 * seconds is refused, naming the variable, and nothing is written. */
static void test_source_date_epoch_makes_files_reproducible(void)
{
	static const char *names[] = {"date.tif", "date.exr"};
	static char a[1 << 16], b[1 << 16];
	float v[W * H];
	for (int i = 0; i < W * H; i++) {
		v[i] = (float)i;
	}
	REQUIRE(setenv("SOURCE_DATE_EPOCH", "1700000000", 1) == 0);
	for (size_t n = 0; n < 2; n++) {
		struct bc_errinfo ei = {0};
		const char *path = tmp_path(names[n]);
		size_t na, nb;
		REQUIRE(path);
		CHECK_EQ_INT(bc_image_write_float(path, W, H, v, &ei), 0);
		na = slurp(path, a, sizeof(a));
		/* A second apart at least: a stamp of the time of writing
		 * would differ. */
		sleep(1);
		CHECK_EQ_INT(bc_image_write_float(path, W, H, v, &ei), 0);
		nb = slurp(path, b, sizeof(b));
		CHECK(na > 0 && na < sizeof(a));
		CHECK_EQ_INT(na, nb);
		CHECK(na == nb && !memcmp(a, b, na));
		/* 1 700 000 000 s after the epoch, in UTC. */
		CHECK(has_text(a, na, "2023:11:14 22:13:20"));
		unlink(path);
	}
	for (size_t n = 0; n < 2; n++) {
		static const char *bad[] = {"-1", "12x", "", " 5",
		                            "99999999999999999999"};
		const char *path = tmp_path(names[n]);
		REQUIRE(path);
		for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
			struct bc_errinfo ei = {0};
			REQUIRE(setenv("SOURCE_DATE_EPOCH", bad[k], 1) == 0);
			CHECK_EQ_INT(bc_image_write_float(path, W, H, v, &ei),
			             BC_EINVAL);
			CHECK(strstr(ei.msg, "SOURCE_DATE_EPOCH") != NULL);
			CHECK(access(path, F_OK) != 0);
		}
	}
	REQUIRE(unsetenv("SOURCE_DATE_EPOCH") == 0);
}

static void test_reader_refuses_oversized_header(void)
{
	/* A PFM header is text: claim 70000 x 70000 floats with no data. The
	 * reader must refuse before allocating ~18 GiB. */
	struct bc_errinfo ei = {0};
	struct bc_image back;
	const char *path = tmp_path("huge.pfm");
	FILE *f;
	REQUIRE(path);
	f = fopen(path, "wb");
	REQUIRE(f);
	fputs("Pf\n70000 70000\n-1.0\n", f);
	fclose(f);
	CHECK_EQ_INT(bc_image_read(path, BC_IMAGE_F32, &back, &ei), BC_ELIMIT);
	CHECK(back.pixels == NULL);
	unlink(path);
	rmdir(dir);
}

static const struct bc_test tests[] = {
    {"rgba8_round_trip_png_and_tif", test_rgba8_round_trip_png_and_tif},
    {"float_round_trip_exr_tif_pfm", test_float_round_trip_exr_tif_pfm},
    {"u32_round_trip_tif_exr", test_u32_round_trip_tif_exr},
    {"lossy_formats_are_refused_by_type",
     test_lossy_formats_are_refused_by_type},
    {"unknown_extension_and_missing_file",
     test_unknown_extension_and_missing_file},
    {"jpeg_keeps_colour_drops_alpha", test_jpeg_keeps_colour_drops_alpha},
    {"source_date_epoch_makes_files_reproducible",
     test_source_date_epoch_makes_files_reproducible},
    {"reader_refuses_oversized_header", test_reader_refuses_oversized_header},
};

BC_TEST_MAIN(tests)
