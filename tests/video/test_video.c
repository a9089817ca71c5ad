/*
 * The H.264 encoder and decoder (blobcast/video.h). Pictures are synthetic
 * (moving gradients, a disc and a bar) or rendered by the CPU tiled
 * renderer (an orbit around a small Fig. 18 scene); each is encoded,
 * decoded and compared with its source by PSNR over RGB. The access
 * units' NAL unit types are read here from their Annex B start codes, not
 * taken from the encoder's word: the first frame, forced frames, stills and
 * the frame after a still are IDRs with SPS and PPS in band, other frames
 * are not. Every frame gives one access unit at once; a plain libavcodec
 * decoder in strict mode (which holds pictures back unless the SPS says
 * there is no reordering) gives each picture back at once too. Odd sizes
 * come back at their size. The decoder refuses garbage, truncated and
 * damaged access units, frames before an IDR and wrong sizes with errors,
 * and recovers at the next IDR; the encoder refuses impossible sizes and
 * options with a sentence; a bitrate lowered on a running encoder makes
 * smaller frames.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <libavcodec/avcodec.h>

#include "blobcast/alloc.h"
#include "blobcast/gen.h"
#include "blobcast/log.h"
#include "blobcast/render.h"
#include "blobcast/video.h"
#include "test.h"

/* PSNR floors (dB, RGB against the source): moving frames at a reasonable
 * bitrate, and stills. */
#define MOVING_DB 38.0
#define STILL_DB 45.0

/* ---- Pictures ------------------------------------------------------------ */

/* Frame t of a moving synthetic picture, RGBA, made like a rendered one:
 * a smooth gradient that drifts, a shaded disc that travels right and a
 * bar that travels down, each with a two-pixel soft edge. */
static void synth(uint8_t *rgba, uint32_t w, uint32_t h, int t)
{
	double cx = w * 0.25 + 2.0 * t, cy = h * 0.5, r = h * 0.2;
	double by = h * 0.1 + 1.5 * t;
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			uint8_t *p = rgba + ((size_t)y * w + x) * 4u;
			double c[3] = {
			    110.0 + 60.0 * sin((x + 2.0 * t) / 23.0),
			    120.0 + 50.0 * cos((y + 1.0 * t) / 19.0),
			    130.0 + 40.0 * sin((x + y + 3.0 * t) / 31.0)};
			double d = hypot(x + 0.5 - cx, y + 0.5 - cy);
			double a = fmin(fmax((r - d) / 2.0 + 0.5, 0.0), 1.0);
			double b = fmin(
			    fmax(1.0 - fabs(y + 0.5 - by) / 3.0, 0.0), 1.0);
			double shade = 0.6 + 0.4 * fmax(0.0, 1.0 - d / r);
			const double disc[3] = {200, 110, 80},
			             bar[3] = {80, 100, 170};
			for (int k = 0; k < 3; k++) {
				double v = c[k] * (1 - a) + disc[k] * shade * a;
				v = v * (1 - b) + bar[k] * b;
				p[k] = (uint8_t)lrint(v);
			}
			p[3] = 255;
		}
	}
}

/* PSNR over the RGB channels of two w x h pictures (a: RGBA, b: bpp bytes
 * per pixel, rows b_stride apart); 99 for identical pictures. */
static double psnr(const uint8_t *a, const uint8_t *b, size_t b_stride,
                   size_t bpp, uint32_t w, uint32_t h)
{
	double se = 0.0, mse;
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			const uint8_t *pa = a + ((size_t)y * w + x) * 4u;
			const uint8_t *pb = b + (size_t)y * b_stride + x * bpp;
			for (int k = 0; k < 3; k++) {
				double d = (double)pa[k] - (double)pb[k];
				se += d * d;
			}
		}
	}
	mse = se / (3.0 * w * h);
	return mse == 0.0 ? 99.0 : 10.0 * log10(255.0 * 255.0 / mse);
}

/* ---- Annex B ------------------------------------------------------------- */

/* NAL unit types of an Annex B access unit, in order (at most cap). */
static size_t nal_types(const uint8_t *p, size_t len, int *types, size_t cap)
{
	size_t n = 0;
	for (size_t i = 0; i + 3 < len && n < cap; i++) {
		if (p[i] == 0 && p[i + 1] == 0 && p[i + 2] == 1) {
			types[n++] = p[i + 3] & 0x1f;
			i += 2;
		}
	}
	return n;
}

static bool has_type(const int *types, size_t n, int type)
{
	for (size_t i = 0; i < n; i++) {
		if (types[i] == type) {
			return true;
		}
	}
	return false;
}

/* An IDR with SPS (7) and PPS (8) before its first IDR slice (5), and no
 * non-IDR slice (1). */
static bool is_idr_au(const uint8_t *p, size_t len)
{
	int t[64];
	size_t n = nal_types(p, len, t, 64);
	size_t first5 = n, sps = n, pps = n;
	for (size_t i = n; i-- > 0;) {
		first5 = t[i] == 5 ? i : first5;
		sps = t[i] == 7 ? i : sps;
		pps = t[i] == 8 ? i : pps;
	}
	return first5 < n && sps < first5 && pps < first5 && !has_type(t, n, 1);
}

/* Non-IDR slices only, no parameter sets. */
static bool is_p_au(const uint8_t *p, size_t len)
{
	int t[64];
	size_t n = nal_types(p, len, t, 64);
	return has_type(t, n, 1) && !has_type(t, n, 5) && !has_type(t, n, 7) &&
	       !has_type(t, n, 8);
}

/* The pic_parameter_set_id of the first slice of an access unit, -1 if
 * none: the third Exp-Golomb number of its header (after first_mb_in_slice
 * and slice_type), emulation prevention bytes skipped. */
static int slice_pps_id(const uint8_t *p, size_t len)
{
	size_t i = 0, bit = 0, start = 0, zeros = 0;
	int value = -1;
	for (; i + 3 < len; i++) {
		int t = p[i + 3] & 0x1f;
		if (p[i] == 0 && p[i + 1] == 0 && p[i + 2] == 1 &&
		    (t == 1 || t == 5)) {
			start = i + 4;
			break;
		}
	}
	if (!start) {
		return -1;
	}
	/* Unescape up to 16 bytes of the header into a bit string. */
	uint8_t hdr[16];
	size_t n = 0;
	for (i = start; i < len && n < sizeof(hdr); i++) {
		if (zeros >= 2 && p[i] == 3) {
			zeros = 0;
			continue;
		}
		zeros = p[i] == 0 ? zeros + 1 : 0;
		hdr[n++] = p[i];
	}
	for (int k = 0; k < 3; k++) {
		int lead = 0;
		uint32_t v = 0;
		while (bit < n * 8 && !(hdr[bit / 8] >> (7 - bit % 8) & 1)) {
			lead++;
			bit++;
		}
		bit++;
		for (int j = 0; j < lead && bit < n * 8; j++, bit++) {
			v = v << 1 | (hdr[bit / 8] >> (7 - bit % 8) & 1u);
		}
		value = (int)((1u << lead) - 1u + v);
	}
	return bit <= n * 8 ? value : -1;
}

/* ---- Helpers ------------------------------------------------------------- */

struct pair {
	struct bc_video_encoder *enc;
	struct bc_video_decoder *dec;
	uint32_t w, h;
};

/* Opens an encoder (o, NULL for defaults; one thread, so that slices and
 * so the figures do not depend on the machine's cores) and a decoder. */
static bool pair_open(struct pair *p, uint32_t w, uint32_t h,
                      const struct bc_video_opts *opts)
{
	struct bc_errinfo ei = {0};
	struct bc_video_opts o1 = opts ? *opts : (struct bc_video_opts){0};
	const struct bc_video_opts *o = &o1;
	o1.threads = 1;
	memset(p, 0, sizeof(*p));
	p->w = w;
	p->h = h;
	if (bc_video_encoder_open(w, h, o, &p->enc, &ei) ||
	    bc_video_decoder_open(NULL, &p->dec, &ei)) {
		fprintf(stderr, "  open: %s\n", ei.msg);
		return false;
	}
	return true;
}

static void pair_close(struct pair *p)
{
	bc_video_encoder_destroy(p->enc);
	bc_video_decoder_destroy(p->dec);
}

/* pair_open and a w x h RGBA picture to fill; NULL (everything freed) on
 * an error. */
static uint8_t *pair_open_picture(struct pair *p, uint32_t w, uint32_t h,
                                  const struct bc_video_opts *o)
{
	uint8_t *rgba = malloc((size_t)w * h * 4u);
	if (!rgba || !pair_open(p, w, h, o)) {
		pair_close(p);
		free(rgba);
		return NULL;
	}
	return rgba;
}

/* Encodes rgba with flags and decodes it; returns the PSNR against rgba,
 * or -1 on an error. *au gets the access unit (valid until the next
 * encode); decoded, unless NULL, a copy of the decoded picture (RGBA). */
static double round_trip(struct pair *p, const uint8_t *rgba, unsigned flags,
                         struct bc_video_au *au, uint8_t *decoded)
{
	struct bc_errinfo ei = {0};
	const uint8_t *px;
	size_t stride;
	if (bc_video_encode(p->enc, rgba, (size_t)p->w * 4u, flags, au, &ei)) {
		fprintf(stderr, "  encode: %s\n", ei.msg);
		return -1.0;
	}
	if (bc_video_decode(p->dec, au->data, au->len, p->w, p->h, &px, &stride,
	                    &ei)) {
		fprintf(stderr, "  decode: %s\n", ei.msg);
		return -1.0;
	}
	for (uint32_t y = 0; decoded && y < p->h; y++) {
		memcpy(decoded + (size_t)y * p->w * 4u, px + y * stride,
		       (size_t)p->w * 4u);
	}
	return psnr(rgba, px, stride, 4, p->w, p->h);
}

/* rgba as the conversion to 4:2:0 and back alone leaves it: a still at
 * quantizer 1 (all but lossless), decoded into out (RGBA). PSNR against
 * this picture is what coding lost, apart from the chroma resolution
 * that 4:2:0 drops at sharp colour edges. */
static bool conversion_only(uint32_t w, uint32_t h, const uint8_t *rgba,
                            uint8_t *out)
{
	struct bc_video_au au;
	struct pair p;
	bool ok = pair_open(&p, w, h, &(struct bc_video_opts){.still_qp = 1}) &&
	          round_trip(&p, rgba, BC_VIDEO_STILL, &au, out) > 0.0;
	pair_close(&p);
	return ok;
}

/* Checks a 4:2:0 still and a 4:4:4 still of rgba: the first loses at
 * least STILL_DB to coding (against conversion_only) and no more than
 * 1 dB against the source than the conversion alone does; the second,
 * when floor_444, is STILL_DB or more against the source (pictures made
 * of edges alone, a few pixels wide, are not held to it). Prints the
 * figures. */
static void check_stills(const char *label, uint32_t w, uint32_t h,
                         const uint8_t *rgba, bool floor_444)
{
	size_t n = (size_t)w * h * 4u;
	uint8_t *ref = malloc(n), *dec = malloc(n);
	struct bc_video_au au;
	struct pair p, q;
	double conv, coded, src, full;
	bool ok;
	if (!ref || !dec) {
		CHECK(0);
		free(ref);
		free(dec);
		return;
	}
	ok = conversion_only(w, h, rgba, ref) && pair_open(&p, w, h, NULL) &&
	     pair_open(&q, w, h, &(struct bc_video_opts){.still_444 = true});
	CHECK(ok);
	if (ok) {
		src = round_trip(&p, rgba, BC_VIDEO_STILL, &au, dec);
		coded = psnr(ref, dec, (size_t)w * 4u, 4, w, h);
		conv = psnr(rgba, ref, (size_t)w * 4u, 4, w, h);
		CHECK(is_idr_au(au.data, au.len));
		full = round_trip(&q, rgba, BC_VIDEO_STILL, &au, NULL);
		CHECK(is_idr_au(au.data, au.len));
		printf("  %s: 4:2:0 conversion %.1f dB; 4:2:0 still %.1f dB "
		       "(coding alone %.1f dB); 4:4:4 still %.1f dB\n",
		       label, conv, src, coded, full);
		CHECK(coded >= STILL_DB);
		CHECK(src >= conv - 1.0);
		CHECK(full >= STILL_DB || !floor_444);
		/* The moving frame after a 4:4:4 still is a 4:2:0 IDR. */
		CHECK(round_trip(&q, rgba, 0, &au, NULL) > 0.0);
		CHECK(is_idr_au(au.data, au.len));
	}
	pair_close(&p);
	pair_close(&q);
	free(ref);
	free(dec);
}

/* ---- Tests --------------------------------------------------------------- */

/* IDRs exactly where they belong; one access unit per frame at once. */
static void test_idr_rules(void)
{
	const uint32_t w = 160, h = 96;
	uint8_t *rgba;
	struct pair p;
	/* Frame: flags asked, whether an IDR must come. */
	static const struct {
		unsigned flags;
		bool idr;
	} seq[] = {
	    {0, true},
	    {0, false},
	    {0, false},
	    {BC_VIDEO_FORCE_IDR, true},
	    {0, false},
	    {0, false},
	    {BC_VIDEO_STILL, true},
	    {0, true}, /* the first moving frame after a still */
	    {0, false},
	    {BC_VIDEO_STILL, true},
	    {BC_VIDEO_STILL, true},
	    {BC_VIDEO_FORCE_IDR, true},
	    {0, false},
	    {BC_VIDEO_FORCE_IDR, true},
	    {BC_VIDEO_STILL, true}, /* right after a moving IDR */
	    {0, true},
	};
	rgba = pair_open_picture(&p, w, h,
	                         &(struct bc_video_opts){.bitrate = 800000});
	REQUIRE(rgba);
	for (size_t i = 0; i < sizeof(seq) / sizeof(seq[0]); i++) {
		struct bc_video_au au;
		double db;
		synth(rgba, w, h, (int)i);
		db = round_trip(&p, rgba, seq[i].flags, &au, NULL);
		CHECK(db > 0.0);
		CHECK(au.len > 0);
		if (seq[i].idr) {
			CHECK(is_idr_au(au.data, au.len));
		} else {
			CHECK(is_p_au(au.data, au.len));
		}
		CHECK_EQ_INT(au.idr, seq[i].idr);
		CHECK_EQ_INT(au.still, (seq[i].flags & BC_VIDEO_STILL) != 0);
		/* Stills' slices name PPS 1, moving frames' PPS 0: an IDR
		 * right after an IDR of the other context is a new picture
		 * even when both have the same idr_pic_id. */
		CHECK_EQ_INT(slice_pps_id(au.data, au.len), au.still ? 1 : 0);
	}
	pair_close(&p);
	free(rgba);
}

/* Moving frames at a reasonable bitrate stay at or above MOVING_DB, and
 * stills after them keep what check_stills asks. */
static void test_psnr(void)
{
	const uint32_t w = 192, h = 112;
	uint8_t *rgba;
	struct bc_video_au au;
	struct pair p;
	double worst = 99.0;
	rgba = pair_open_picture(&p, w, h,
	                         &(struct bc_video_opts){.bitrate = 1500000});
	REQUIRE(rgba);
	for (int i = 0; i < 12; i++) {
		double db;
		synth(rgba, w, h, i);
		db = round_trip(&p, rgba, 0, &au, NULL);
		worst = db < worst ? db : worst;
	}
	printf("  %ux%u: worst moving frame %.1f dB\n", w, h, worst);
	CHECK(worst >= MOVING_DB);
	check_stills("192x112", w, h, rgba, true);
	pair_close(&p);
	free(rgba);
}

/* rgba (w x h) with its last column and row repeated to even sizes. */
static uint8_t *pad_even(const uint8_t *rgba, uint32_t w, uint32_t h)
{
	uint32_t pw = w + (w & 1u), ph = h + (h & 1u);
	uint8_t *out = malloc((size_t)pw * ph * 4u);
	for (uint32_t y = 0; out && y < ph; y++) {
		for (uint32_t x = 0; x < pw; x++) {
			uint32_t sx = x < w ? x : w - 1, sy = y < h ? y : h - 1;
			memcpy(out + ((size_t)y * pw + x) * 4u,
			       rgba + ((size_t)sy * w + sx) * 4u, 4);
		}
	}
	return out;
}

/* Odd sizes: the access units are those of the picture padded by hand
 * (the last column and row repeated) to even sizes, byte for byte, and
 * they decode at the odd size, the padding cropped; moving frames lose
 * no more than MOVING_DB to coding, stills as check_stills says. */
static void test_odd_sizes(void)
{
	static const uint32_t sizes[][2] = {{33, 17}, {1, 1}, {35, 2}};
	const struct bc_video_opts o = {.bitrate = 300000};
	for (size_t s = 0; s < sizeof(sizes) / sizeof(sizes[0]); s++) {
		uint32_t w = sizes[s][0], h = sizes[s][1];
		uint32_t pw = w + (w & 1u), ph = h + (h & 1u);
		size_t n = (size_t)w * h * 4u;
		uint8_t *rgba = malloc(n), *ref = malloc(n), *dec = malloc(n);
		struct bc_video_encoder *even = NULL;
		struct bc_errinfo ei = {0};
		struct pair p;
		char label[32];
		REQUIRE(rgba && ref && dec);
		CHECK(pair_open(&p, w, h, &o));
		CHECK(bc_video_encoder_open(pw, ph, &o, &even, &ei) == 0);
		for (int i = 0; p.dec && even && i < 4; i++) {
			struct bc_video_au au, eau;
			unsigned flags = i == 3 ? BC_VIDEO_STILL : 0;
			uint8_t *padded;
			double coded;
			synth(rgba, w, h, i);
			padded = pad_even(rgba, w, h);
			REQUIRE(padded);
			CHECK(round_trip(&p, rgba, flags, &au, dec) > 0.0);
			CHECK(bc_video_encode(even, padded, pw * 4u, flags,
			                      &eau, &ei) == 0);
			CHECK(au.len == eau.len &&
			      memcmp(au.data, eau.data, au.len) == 0);
			free(padded);
			CHECK(conversion_only(w, h, rgba, ref));
			coded = psnr(ref, dec, (size_t)w * 4u, 4, w, h);
			printf("  %ux%u frame %d: coding alone %.1f dB\n", w, h,
			       i, coded);
			CHECK(coded >= (flags ? STILL_DB : MOVING_DB));
		}
		snprintf(label, sizeof(label), "%ux%u", w, h);
		check_stills(label, w, h, rgba, false);
		bc_video_encoder_destroy(even);
		pair_close(&p);
		free(rgba);
		free(ref);
		free(dec);
	}
}

/* A plain libavcodec decoder in strict mode holds pictures back unless
 * the SPS says the stream has no reordering (max_num_reorder_frames 0 in
 * its VUI): it must still give every picture back at once. */
static void test_no_reordering(void)
{
	const uint32_t w = 96, h = 64;
	uint8_t *rgba = malloc((size_t)w * h * 4u);
	const AVCodec *codec = avcodec_find_decoder(AV_CODEC_ID_H264);
	AVCodecContext *ctx = codec ? avcodec_alloc_context3(codec) : NULL;
	AVPacket *pkt = av_packet_alloc();
	AVFrame *frame = av_frame_alloc();
	struct bc_video_encoder *enc = NULL;
	struct bc_errinfo ei = {0};
	REQUIRE(rgba && ctx && pkt && frame);
	ctx->strict_std_compliance = FF_COMPLIANCE_STRICT;
	ctx->thread_count = 1;
	CHECK(avcodec_open2(ctx, codec, NULL) == 0);
	CHECK(bc_video_encoder_open(w, h, NULL, &enc, &ei) == 0);
	for (int i = 0; enc && i < 8; i++) {
		struct bc_video_au au;
		synth(rgba, w, h, i);
		CHECK(bc_video_encode(enc, rgba, w * 4u,
		                      i == 5 ? BC_VIDEO_STILL : 0, &au,
		                      &ei) == 0);
		REQUIRE(av_new_packet(pkt, (int)au.len) == 0);
		memcpy(pkt->data, au.data, au.len);
		CHECK(avcodec_send_packet(ctx, pkt) == 0);
		av_packet_unref(pkt);
		/* This access unit's picture, now. */
		CHECK(avcodec_receive_frame(ctx, frame) == 0);
		CHECK_EQ_INT(frame->width, (int)w);
		CHECK_EQ_INT(frame->height, (int)h);
		av_frame_unref(frame);
	}
	bc_video_encoder_destroy(enc);
	av_frame_free(&frame);
	av_packet_free(&pkt);
	avcodec_free_context(&ctx);
	free(rgba);
}

/* A small PRNG for garbage bytes (xorshift64). */
static uint64_t rng_next(uint64_t *s)
{
	*s ^= *s << 13;
	*s ^= *s >> 7;
	*s ^= *s << 17;
	return *s;
}

/* Offset of the first IDR slice's NAL unit header in an access unit, 0
 * if none. */
static size_t slice_offset(const uint8_t *p, size_t len)
{
	for (size_t i = 0; i + 3 < len; i++) {
		if (p[i] == 0 && p[i + 1] == 0 && p[i + 2] == 1 &&
		    (p[i + 3] & 0x1f) == 5) {
			return i + 3;
		}
	}
	return 0;
}

/* Expects decoding bytes to fail with an error and a sentence. */
static void expect_refused(struct bc_video_decoder *dec, const uint8_t *b,
                           size_t len, uint32_t w, uint32_t h)
{
	struct bc_errinfo ei = {0};
	const uint8_t *px = (const uint8_t *)"x";
	size_t stride = 1;
	int rc = bc_video_decode(dec, b, len, w, h, &px, &stride, &ei);
	CHECK(rc < 0);
	CHECK(ei.code == rc && ei.msg[0] != '\0');
	CHECK(px == NULL && stride == 0);
}

/* Encodes synthetic frame t (w x h, through rgba) and returns a malloc'd
 * copy of its access unit, NULL on an error. */
static uint8_t *encode_copy(struct bc_video_encoder *enc, uint8_t *rgba,
                            uint32_t w, uint32_t h, int t, size_t *len)
{
	struct bc_errinfo ei = {0};
	struct bc_video_au au;
	uint8_t *copy;
	synth(rgba, w, h, t);
	if (bc_video_encode(enc, rgba, w * 4u, 0, &au, &ei) ||
	    !(copy = malloc(au.len))) {
		return NULL;
	}
	memcpy(copy, au.data, au.len);
	*len = au.len;
	return copy;
}

/* Garbage, truncated and damaged access units, frames before an IDR and
 * wrong sizes are refused; the decoder starts again at the next IDR. */
static void test_decoder_refuses(void)
{
	const uint32_t w = 96, h = 64;
	uint8_t *rgba = malloc((size_t)w * h * 4u);
	uint8_t *idr = NULL, *pframe = NULL, *buf = malloc(4096);
	size_t idr_len = 0, p_len = 0;
	struct bc_video_encoder *enc = NULL;
	struct bc_video_decoder *dec = NULL, *fresh = NULL;
	struct bc_errinfo ei = {0};
	const uint8_t *px, *fpx = NULL;
	size_t stride, slice;
	uint64_t seed = 0x9e3779b97f4a7c15ull;
	REQUIRE(rgba && buf);
	REQUIRE(bc_video_encoder_open(w, h, NULL, &enc, &ei) == 0);
	REQUIRE(bc_video_decoder_open(NULL, &dec, &ei) == 0);
	idr = encode_copy(enc, rgba, w, h, 0, &idr_len);
	pframe = encode_copy(enc, rgba, w, h, 1, &p_len);
	REQUIRE(idr && pframe);

	/* Lengths out of bounds, checked before the bytes are read. */
	CHECK_EQ_INT(bc_video_decode(dec, idr, 0, w, h, &px, &stride, &ei),
	             BC_EPROTO_LENGTH);
	CHECK_EQ_INT(bc_video_decode(dec, idr, BC_VIDEO_MAX_AU_BYTES + 1, w, h,
	                             &px, &stride, &ei),
	             BC_EPROTO_LENGTH);
	CHECK_EQ_INT(
	    bc_video_decode(dec, idr, idr_len, 0, h, &px, &stride, &ei),
	    BC_EINVAL);
	CHECK_EQ_INT(
	    bc_video_decode(dec, idr, idr_len, 5000, h, &px, &stride, &ei),
	    BC_ELIMIT);
	/* A P frame before any IDR. */
	CHECK_EQ_INT(
	    bc_video_decode(dec, pframe, p_len, w, h, &px, &stride, &ei),
	    BC_ESTATE);
	/* Random bytes, with and without an IDR NAL header in front. */
	for (int round = 0; round < 20; round++) {
		size_t n = 1 + rng_next(&seed) % 4000;
		for (size_t i = 0; i < n; i++) {
			buf[i] = (uint8_t)rng_next(&seed);
		}
		if (round % 2 && n > 8) {
			memcpy(buf, "\0\0\0\1\x65", 5);
		}
		expect_refused(dec, buf, n, w, h);
	}
	/* Truncated IDRs: the parameter sets whole, the slice cut at eighths
	 * of its length; then the slice damaged in its middle. */
	slice = slice_offset(idr, idr_len);
	REQUIRE(slice > 0 && slice + 64 < idr_len && idr_len <= 4096);
	for (size_t k = 1; k < 8; k++) {
		expect_refused(dec, idr, slice + (idr_len - slice) * k / 8, w,
		               h);
	}
	memcpy(buf, idr, idr_len);
	for (size_t i = (slice + idr_len) / 2; i < (slice + idr_len) / 2 + 16;
	     i++) {
		buf[i] ^= 0x5a;
	}
	expect_refused(dec, buf, idr_len, w, h);
	/* A whole IDR of the wrong size for the view. */
	expect_refused(dec, idr, idr_len, 64, 64);
	/* After the errors, P frames wait for an IDR; the IDR decodes. */
	CHECK_EQ_INT(
	    bc_video_decode(dec, pframe, p_len, w, h, &px, &stride, &ei),
	    BC_ESTATE);
	CHECK_EQ_INT(
	    bc_video_decode(dec, idr, idr_len, w, h, &px, &stride, &ei), 0);
	CHECK(px != NULL && stride == w * 4u);
	CHECK_EQ_INT(
	    bc_video_decode(dec, pframe, p_len, w, h, &px, &stride, &ei), 0);
	/* As a fresh decoder decodes the same two access units. */
	REQUIRE(bc_video_decoder_open(NULL, &fresh, &ei) == 0);
	CHECK_EQ_INT(
	    bc_video_decode(fresh, idr, idr_len, w, h, &fpx, &stride, &ei), 0);
	CHECK_EQ_INT(
	    bc_video_decode(fresh, pframe, p_len, w, h, &fpx, &stride, &ei), 0);
	if (px && fpx) {
		CHECK_MEMEQ(px, fpx, (size_t)w * h * 4u);
	}
	bc_video_decoder_destroy(fresh);
	bc_video_encoder_destroy(enc);
	bc_video_decoder_destroy(dec);
	free(idr);
	free(pframe);
	free(buf);
	free(rgba);
}

/* Impossible requests fail with a code and a sentence, leaving *out NULL. */
static void test_encoder_refuses(void)
{
	static const struct {
		uint32_t w, h;
		struct bc_video_opts o;
		int rc;
	} cases[] = {
	    {0, 0, {0}, BC_EINVAL},
	    {64, 0, {0}, BC_EINVAL},
	    {5000, 64, {0}, BC_ELIMIT},
	    {4096, 4096, {0}, BC_ELIMIT},
	    {64, 64, {.fps = 1000}, BC_EINVAL},
	    {64, 64, {.bitrate = 1000}, BC_EINVAL},
	    {64, 64, {.still_qp = 60}, BC_EINVAL},
	    {64, 64, {.backend = BC_VIDEO_BACKEND_COUNT}, BC_EINVAL},
	    {64, 64, {.pixfmt = BC_VIDEO_PIX_COUNT}, BC_EINVAL},
	    {64, 64, {.x264_preset = "warp9"}, BC_EINVAL},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bc_video_encoder *enc = (void *)&cases[i];
		struct bc_errinfo ei = {0};
		int rc = bc_video_encoder_open(cases[i].w, cases[i].h,
		                               &cases[i].o, &enc, &ei);
		if (rc != cases[i].rc) {
			fprintf(stderr, "  case %zu: %d (%s)\n", i, rc, ei.msg);
		}
		CHECK_EQ_INT(rc, cases[i].rc);
		CHECK(enc == NULL);
		CHECK(ei.msg[0] != '\0');
		bc_video_encoder_destroy(enc);
	}
	/* nvenc alone: without an NVIDIA GPU, a clear refusal; with one, an
	 * encoder that says it is nvenc. */
	{
		struct bc_video_encoder *enc = NULL;
		struct bc_errinfo ei = {0};
		int rc = bc_video_encoder_open(
		    64, 64,
		    &(struct bc_video_opts){.backend = BC_VIDEO_BACKEND_NVENC},
		    &enc, &ei);
		if (rc) {
			CHECK(enc == NULL && ei.msg[0] != '\0');
			CHECK(strstr(ei.msg, "nvenc") != NULL);
		} else {
			CHECK_STREQ(bc_video_encoder_name(enc), "h264_nvenc");
		}
		bc_video_encoder_destroy(enc);
	}
}

/* Stride and flag checks, and bitrate bounds on a running encoder. */
static void test_encode_args(void)
{
	const uint32_t w = 32, h = 16;
	uint8_t rgba[32 * 16 * 4] = {0};
	struct bc_video_encoder *enc = NULL;
	struct bc_errinfo ei = {0};
	struct bc_video_au au;
	REQUIRE(bc_video_encoder_open(w, h, NULL, &enc, &ei) == 0);
	CHECK_EQ_INT(bc_video_encode(enc, rgba, w * 4u - 1, 0, &au, &ei),
	             BC_EINVAL);
	CHECK_EQ_INT(bc_video_encode(enc, rgba, w * 4u, 1u << 7, &au, &ei),
	             BC_EINVAL);
	CHECK_EQ_INT(bc_video_encode(enc, NULL, w * 4u, 0, &au, &ei),
	             BC_EINVAL);
	CHECK(au.data == NULL && au.len == 0);
	CHECK_EQ_INT(bc_video_encoder_set_bitrate(enc, 10, &ei), BC_ERANGE);
	CHECK_EQ_INT(
	    bc_video_encoder_set_bitrate(enc, BC_VIDEO_MAX_BITRATE + 1u, &ei),
	    BC_ERANGE);
	CHECK_EQ_INT(bc_video_encode(enc, rgba, w * 4u, 0, &au, &ei), 0);
	CHECK(is_idr_au(au.data, au.len));
	CHECK_STREQ(bc_video_encoder_name(enc), "libx264");
	bc_video_encoder_destroy(enc);
}

/* A lower bitrate set on the running encoder makes smaller frames, with
 * no IDR. */
static void test_set_bitrate(void)
{
	const uint32_t w = 192, h = 112;
	uint8_t *rgba = malloc((size_t)w * h * 4u);
	struct bc_video_encoder *enc = NULL;
	struct bc_errinfo ei = {0};
	size_t before = 0, after = 0;
	REQUIRE(rgba);
	REQUIRE(bc_video_encoder_open(
	            w, h, &(struct bc_video_opts){.bitrate = 3000000}, &enc,
	            &ei) == 0);
	for (int i = 0; i < 40; i++) {
		struct bc_video_au au;
		if (i == 20) {
			CHECK(bc_video_encoder_set_bitrate(enc, 100000, &ei) ==
			      0);
		}
		synth(rgba, w, h, 3 * i);
		CHECK(bc_video_encode(enc, rgba, w * 4u, 0, &au, &ei) == 0);
		if (i >= 10 && i < 20) {
			before += au.len;
		} else if (i >= 30) {
			after += au.len;
		}
		if (i > 0) {
			CHECK(is_p_au(au.data, au.len));
		}
	}
	printf("  bytes of 10 frames at 3 Mbit/s %zu, at 100 kbit/s %zu\n",
	       before, after);
	CHECK(after * 4 < before);
	bc_video_encoder_destroy(enc);
	free(rgba);
}

/* Rendered frames: an orbit around a small Fig. 18 scene by the CPU
 * tiled renderer, RGB pictures on both sides. */
static void test_rendered(void)
{
	const uint32_t w = 128, h = 96;
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam0, cam;
	struct bc_frame f = {0};
	struct bc_errinfo ei = {0};
	struct bc_video_encoder *enc = NULL;
	struct bc_video_decoder *dec = NULL;
	const struct bc_video_opts eo = {.bitrate = 1000000,
	                                 .pixfmt = BC_VIDEO_PIX_RGB};
	uint8_t *rgb = malloc((size_t)w * h * 3u);
	double worst = 99.0, still = 0.0;
	REQUIRE(t && rgb);
	REQUIRE(bc_gen("fig18",
	               &(struct bc_gen_opts){.count = 16,
	                                     .kind = BC_GEN_KIND_SPHERES,
	                                     .blend = BC_GEN_BLEND_SMOOTH},
	               t, &cam0, &ei) == 0);
	REQUIRE(bc_frame_init(&f, w, h) == 0);
	REQUIRE(bc_video_encoder_open(w, h, &eo, &enc, &ei) == 0);
	REQUIRE(bc_video_decoder_open(
	            &(struct bc_video_decoder_opts){.pixfmt = BC_VIDEO_PIX_RGB},
	            &dec, &ei) == 0);
	for (int i = 0; i < 6; i++) {
		float a = 0.06f * (float)i;
		float dx = cam0.eye[0] - cam0.target[0];
		float dz = cam0.eye[2] - cam0.target[2];
		struct bc_render_stats st;
		struct bc_video_au au;
		const uint8_t *px;
		size_t stride;
		double db;
		bool last = i == 5;
		cam = cam0;
		cam.eye[0] = cam0.target[0] + dx * cosf(a) - dz * sinf(a);
		cam.eye[2] = cam0.target[2] + dx * sinf(a) + dz * cosf(a);
		REQUIRE(bc_render_once(BC_BACKEND_TILED,
		                       &(struct bc_render_opts){.threads = 1},
		                       t, &cam, &f, &st, &ei) == 0);
		for (size_t k = 0; k < (size_t)w * h; k++) {
			memcpy(rgb + k * 3u, f.rgba + k * 4u, 3);
		}
		REQUIRE(bc_video_encode(enc, rgb, w * 3u,
		                        last ? BC_VIDEO_STILL : 0, &au,
		                        &ei) == 0);
		REQUIRE(bc_video_decode(dec, au.data, au.len, w, h, &px,
		                        &stride, &ei) == 0);
		CHECK_EQ_INT(stride, w * 3u);
		db = psnr(f.rgba, px, stride, 3, w, h);
		if (last) {
			still = db;
		} else {
			worst = db < worst ? db : worst;
		}
	}
	printf("  rendered %ux%u: worst moving %.1f dB, still %.1f dB\n", w, h,
	       worst, still);
	CHECK(worst >= MOVING_DB);
	check_stills("rendered", w, h, f.rgba, true);
	bc_video_encoder_destroy(enc);
	bc_video_decoder_destroy(dec);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
	free(rgb);
}

/* The one line that says which encoder runs. */
static char log_seen[512];

static void log_capture(enum bc_log_level level, const char *file, int line,
                        const char *fmt, va_list args) BC__PRINTF(4, 0);
static void log_capture(enum bc_log_level level, const char *file, int line,
                        const char *fmt, va_list args)
{
	char msg[512];
	(void)file;
	(void)line;
	vsnprintf(msg, sizeof(msg), fmt, args);
	if (level == BC_LOG_INFO && strstr(msg, "video: ")) {
		snprintf(log_seen, sizeof(log_seen), "%s", msg);
	}
}

static void test_logs_encoder(void)
{
	struct bc_video_encoder *enc = NULL;
	struct bc_errinfo ei = {0};
	enum bc_log_level was = bc_log_level();
	log_seen[0] = '\0';
	bc_log_init(BC_LOG_INFO);
	bc_log_set_callback(log_capture);
	CHECK(bc_video_encoder_open(48, 32, NULL, &enc, &ei) == 0);
	bc_log_set_callback(NULL);
	bc_log_init(was);
	CHECK(strstr(log_seen, bc_video_encoder_name(enc)) != NULL);
	CHECK(strstr(log_seen, "48x32") != NULL);
	bc_video_encoder_destroy(enc);
}

/* Every failed allocation of ours fails the call cleanly (and leaks
 * nothing, which ASan checks at exit). */
static void test_alloc_failures(void)
{
	uint8_t rgba[32 * 16 * 4] = {0};
	for (unsigned long n = 1; n < 8; n++) {
		struct bc_video_encoder *enc = NULL;
		struct bc_video_decoder *dec = NULL;
		struct bc_errinfo ei = {0};
		struct bc_video_au au = {0};
		const uint8_t *px;
		size_t stride;
		int rc;
		bc_alloc_fail_after(n);
		rc = bc_video_encoder_open(32, 16, NULL, &enc, &ei);
		if (!rc) {
			rc = bc_video_encode(enc, rgba, 128, 0, &au, &ei);
		}
		if (!rc) {
			rc = bc_video_decoder_open(NULL, &dec, &ei);
		}
		if (!rc) {
			rc = bc_video_decode(dec, au.data, au.len, 32, 16, &px,
			                     &stride, &ei);
		}
		bc_alloc_fail_after(0);
		CHECK(rc == 0 || rc == BC_ENOMEM);
		bc_video_encoder_destroy(enc);
		bc_video_decoder_destroy(dec);
	}
}

static const struct bc_test tests[] = {
    {"idr_rules", test_idr_rules},
    {"psnr", test_psnr},
    {"odd_sizes", test_odd_sizes},
    {"no_reordering", test_no_reordering},
    {"decoder_refuses", test_decoder_refuses},
    {"encoder_refuses", test_encoder_refuses},
    {"encode_args", test_encode_args},
    {"set_bitrate", test_set_bitrate},
    {"rendered", test_rendered},
    {"logs_encoder", test_logs_encoder},
    {"alloc_failures", test_alloc_failures},
};

BC_TEST_MAIN(tests)
