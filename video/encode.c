/*
 * The H.264 encoder (blobcast/video.h): RGB pictures converted to 4:2:0
 * YCbCr by libswscale, encoded by h264_nvenc or libx264 into one Annex B
 * access unit per picture.
 *
 * Two libavcodec contexts: `moving` codes the interactive stream at the
 * asked bitrate (IP only, no lookahead, a small VBV buffer), `still` codes
 * stills as IDRs at a constant quantizer. A rate-controlled encoder cannot
 * code one frame at a fixed quantizer (neither libx264's nor nvenc's
 * libavcodec wrapper takes a quantizer per frame, and the VBV buffer would
 * squeeze a sharp frame anyway), so a still comes from its own context,
 * opened the first time one is asked for. A still replaces the decoder's
 * references, so the moving frame after it is an IDR again.
 */
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include <libavcodec/avcodec.h>
#include <libavutil/error.h>
#include <libavutil/frame.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "video_priv.h"

/* Most frames per second an encoder is opened for. */
#define MAX_FPS 240u
/* The VBV buffer of moving frames holds this fraction of a second at the
 * bitrate: a frame may be several times the average (an IDR, a sudden
 * change) but never so large that it stalls the stream for long. */
#define VBV_SECONDS_DIV 4
/* libx264 settings: no scene-cut or periodic IDRs (IDRs only when
 * asked), SPS and PPS before every IDR. The stills' context numbers its
 * SPS and PPS 1, the moving frames' 0: each context alternates its IDRs'
 * idr_pic_id between 0 and 1 on its own, so a still right after a moving
 * IDR (or the moving IDR right after a still) may repeat the id, and the
 * different PPS id is then what marks the second IDR as a new picture
 * (H.264 7.4.1.2.4) for a decoder that reads the stream as bytes. */
#define X264_PARAMS "scenecut=0:keyint=infinite:repeat-headers=1"
#define X264_PARAMS_STILL X264_PARAMS ":sps-id=1"

struct bc_video_encoder {
	uint32_t width, height;   /* of the pictures given */
	uint32_t cwidth, cheight; /* coded: even */
	uint32_t fps, bitrate;
	int still_qp;
	size_t bpp; /* bytes per pixel of the pictures given */
	enum AVPixelFormat src_fmt;
	char preset[32];
	uint32_t threads;
	const AVCodec *codec;
	bool nvenc;
	AVCodecContext *moving, *still;
	bool still_444; /* stills in 4:4:4 */
	/* The moving frames' picture (4:2:0) and the stills' (4:2:0: the
	 * same; 4:4:4: their own, made the first time). */
	struct picture {
		AVFrame *frame;
		struct SwsContext *sws;
	} p420, p444;
	AVPacket *pkt;
	uint8_t *pad; /* odd sizes: the picture padded to the coded size */
	int64_t pts;
	bool need_idr; /* the next moving frame must be an IDR */
};

static int set_opt(AVCodecContext *c, const char *key, const char *val,
                   struct bc_errinfo *ei)
{
	int rc = av_opt_set(c->priv_data, key, val, 0);
	if (rc < 0) {
		char what[96];
		snprintf(what, sizeof(what), "video encoder option %s=%s", key,
		         val);
		return bc__video_av_error(ei, BC_EINVAL, what, rc);
	}
	return 0;
}

/* Applies the moving stream's rate to c: average and peak rate, and the
 * VBV buffer. libx264 and nvenc read these again before each frame. */
static void apply_rate(AVCodecContext *c, uint32_t bitrate)
{
	c->bit_rate = bitrate;
	c->rc_max_rate = bitrate;
	c->rc_buffer_size = (int)(bitrate / VBV_SECONDS_DIV);
}

/* The settings of one backend for one of the two contexts. */
static int configure(struct bc_video_encoder *enc, AVCodecContext *c,
                     bool still, struct bc_errinfo *ei)
{
	char qp[16];
	int rc;
	snprintf(qp, sizeof(qp), "%d", enc->still_qp);
	if (enc->nvenc) {
		/* p1: the fastest preset; ull: ultra-low-latency tuning;
		 * zerolatency and delay 0: a packet for every frame at
		 * once; forced-idr: an I picture asked for is an IDR. */
		if ((rc = set_opt(c, "preset", "p1", ei)) ||
		    (rc = set_opt(c, "tune", "ull", ei)) ||
		    (rc = set_opt(c, "zerolatency", "1", ei)) ||
		    (rc = set_opt(c, "delay", "0", ei)) ||
		    (rc = set_opt(c, "forced-idr", "1", ei)) ||
		    (rc = set_opt(c, "rc", still ? "constqp" : "cbr", ei))) {
			return rc;
		}
		if (still && (rc = set_opt(c, "qp", qp, ei))) {
			return rc;
		}
		return 0;
	}
	if ((rc = set_opt(c, "preset", enc->preset, ei)) ||
	    (rc = set_opt(c, "tune", "zerolatency", ei)) ||
	    (rc = set_opt(c, "forced-idr", "1", ei)) ||
	    (rc = set_opt(c, "x264-params",
	                  still ? X264_PARAMS_STILL : X264_PARAMS, ei))) {
		return rc;
	}
	if (still && (rc = set_opt(c, "qp", qp, ei))) {
		return rc;
	}
	return 0;
}

/* Opens one context of enc's codec: the moving stream's or the stills'. */
static int open_ctx(struct bc_video_encoder *enc, bool still,
                    AVCodecContext **out, struct bc_errinfo *ei)
{
	AVCodecContext *c = avcodec_alloc_context3(enc->codec);
	int rc;
	*out = NULL;
	if (!c) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "video encoder: out of memory");
	}
	c->width = (int)enc->cwidth;
	c->height = (int)enc->cheight;
	c->pix_fmt =
	    still && enc->still_444 ? AV_PIX_FMT_YUV444P : AV_PIX_FMT_YUV420P;
	c->time_base = (AVRational){1, (int)enc->fps};
	c->framerate = (AVRational){(int)enc->fps, 1};
	c->max_b_frames = 0;
	c->gop_size = INT_MAX; /* IDRs only when asked */
	c->thread_count = (int)enc->threads;
	/* I pictures at the P quantizer: a still is at still_qp exactly. */
	c->i_quant_factor = 1.0f;
	c->i_quant_offset = 0.0f;
	c->color_range = AVCOL_RANGE_MPEG;
	c->colorspace = AVCOL_SPC_SMPTE170M;
	c->color_primaries = AVCOL_PRI_BT709;
	c->color_trc = AVCOL_TRC_IEC61966_2_1;
	/* No AV_CODEC_FLAG_GLOBAL_HEADER: SPS and PPS stay in band. */
	c->flags &= ~AV_CODEC_FLAG_GLOBAL_HEADER;
	if (!still) {
		apply_rate(c, enc->bitrate);
	}
	if ((rc = configure(enc, c, still, ei))) {
		avcodec_free_context(&c);
		return rc;
	}
	rc = avcodec_open2(c, enc->codec, NULL);
	if (rc < 0) {
		char why[AV_ERROR_MAX_STRING_SIZE] = "";
		avcodec_free_context(&c);
		av_strerror(rc, why, sizeof(why));
		if (enc->nvenc) {
			return bc_errinfo_set(
			    ei, BC_ENOTSUP,
			    "video encoder h264_nvenc did not open (%s): it "
			    "needs an NVIDIA GPU and its driver",
			    why);
		}
		/* EINVAL: an option's value (a preset's name, say). */
		return bc_errinfo_set(
		    ei, rc == AVERROR(EINVAL) ? BC_EINVAL : BC_ECODEC,
		    "video encoder %s (%ux%u) did not open: %s%s",
		    enc->codec->name, enc->cwidth, enc->cheight, why,
		    rc == AVERROR(EINVAL) ? " (check the preset's name)" : "");
	}
	*out = c;
	return 0;
}

static int check_opts(const struct bc_video_opts *o, struct bc_errinfo *ei)
{
	if (o->fps > MAX_FPS) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video encoder: %u frames per second is "
		                      "over %u",
		                      o->fps, MAX_FPS);
	}
	if (o->bitrate && (o->bitrate < BC_VIDEO_MIN_BITRATE ||
	                   o->bitrate > BC_VIDEO_MAX_BITRATE)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video encoder: bitrate %u bit/s is "
		                      "outside %u..%u",
		                      o->bitrate, BC_VIDEO_MIN_BITRATE,
		                      BC_VIDEO_MAX_BITRATE);
	}
	if (o->still_qp < 0 || o->still_qp > 51) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video encoder: still quantizer %d is "
		                      "outside 1..51",
		                      o->still_qp);
	}
	if ((unsigned)o->backend >= BC_VIDEO_BACKEND_COUNT ||
	    (unsigned)o->pixfmt >= BC_VIDEO_PIX_COUNT) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video encoder: unknown backend or pixel "
		                      "format");
	}
	if (o->x264_preset && strlen(o->x264_preset) >= 32) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video encoder: preset name too long");
	}
	return 0;
}

/* Opens the moving context with the codec named name; on failure leaves
 * enc->moving NULL and returns the error. */
static int try_codec(struct bc_video_encoder *enc, const char *name,
                     struct bc_errinfo *ei)
{
	enc->codec = avcodec_find_encoder_by_name(name);
	if (!enc->codec) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "video encoder: this libavcodec has no "
		                      "%s encoder",
		                      name);
	}
	enc->nvenc = strcmp(name, "h264_nvenc") == 0;
	return open_ctx(enc, false, &enc->moving, ei);
}

/* Makes pic a coded-size frame of fmt and the conversion into it. */
static int picture_init(struct bc_video_encoder *enc, struct picture *pic,
                        enum AVPixelFormat fmt, struct bc_errinfo *ei)
{
	AVFrame *f = pic->frame = av_frame_alloc();
	if (!f) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "video encoder: out of memory");
	}
	f->format = fmt;
	f->width = (int)enc->cwidth;
	f->height = (int)enc->cheight;
	f->color_range = AVCOL_RANGE_MPEG;
	f->colorspace = AVCOL_SPC_SMPTE170M;
	if (av_frame_get_buffer(f, 0) < 0) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "video encoder: out of memory");
	}
	pic->sws = sws_getContext(
	    (int)enc->cwidth, (int)enc->cheight, enc->src_fmt, (int)enc->cwidth,
	    (int)enc->cheight, fmt, BC__VIDEO_SWS_FLAGS, NULL, NULL, NULL);
	if (!pic->sws) {
		return bc_errinfo_set(
		    ei, BC_ECODEC,
		    "video encoder: libswscale cannot convert "
		    "%ux%u to YCbCr",
		    enc->cwidth, enc->cheight);
	}
	bc__video_sws_colours(pic->sws, 1);
	return 0;
}

static void picture_finish(struct picture *pic)
{
	av_frame_free(&pic->frame);
	sws_freeContext(pic->sws);
	pic->sws = NULL;
}

int bc_video_encoder_open(uint32_t width, uint32_t height,
                          const struct bc_video_opts *opts,
                          struct bc_video_encoder **out, struct bc_errinfo *ei)
{
	static const struct bc_video_opts defaults = {0};
	const struct bc_video_opts *o = opts ? opts : &defaults;
	struct bc_video_encoder *enc = NULL;
	struct bc_errinfo nv = {0};
	int rc;
	*out = NULL;
	if ((rc = bc__video_check_size(width, height, "video encoder", ei)) ||
	    (rc = check_opts(o, ei))) {
		return rc;
	}
	bc__video_route_av_log();
	enc = bc_calloc(1, sizeof(*enc));
	if (!enc) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "video encoder: out of memory");
	}
	enc->width = width;
	enc->height = height;
	enc->cwidth = bc__video_even(width);
	enc->cheight = bc__video_even(height);
	enc->fps = o->fps ? o->fps : BC_VIDEO_DEFAULT_FPS;
	enc->bitrate = o->bitrate
	                   ? o->bitrate
	                   : bc_video_default_bitrate(width, height, enc->fps);
	enc->still_qp = o->still_qp ? o->still_qp : BC_VIDEO_STILL_QP;
	enc->src_fmt = bc__video_av_pixfmt(o->pixfmt, &enc->bpp);
	snprintf(enc->preset, sizeof(enc->preset), "%s",
	         o->x264_preset ? o->x264_preset
	                        : BC_VIDEO_DEFAULT_X264_PRESET);
	enc->threads = o->threads;
	enc->still_444 = o->still_444;
	enc->need_idr = true;

	rc = BC_ENOTSUP;
	if (o->backend != BC_VIDEO_BACKEND_X264) {
		rc = try_codec(enc, "h264_nvenc", &nv);
		if (rc && o->backend == BC_VIDEO_BACKEND_NVENC) {
			bc_errinfo_set(ei, rc,
			               "%s; the x264 or auto backend runs "
			               "without one",
			               nv.msg);
			goto fail;
		}
	}
	if (rc) {
		rc = try_codec(enc, "libx264", ei);
		if (rc) {
			goto fail;
		}
	}
	if (enc->nvenc) {
		bc_log(BC_LOG_INFO,
		       "video: h264_nvenc encodes %ux%u at %u bit/s, %u fps",
		       width, height, enc->bitrate, enc->fps);
	} else {
		bc_log(BC_LOG_INFO,
		       "video: libx264 (%s) encodes %ux%u at %u bit/s, %u "
		       "fps%s%s%s",
		       enc->preset, width, height, enc->bitrate, enc->fps,
		       nv.code ? " (" : "", nv.msg, nv.code ? ")" : "");
	}

	enc->pkt = av_packet_alloc();
	if (!enc->pkt) {
		rc = bc_errinfo_set(ei, BC_ENOMEM,
		                    "video encoder: out of memory");
		goto fail;
	}
	if ((rc = picture_init(enc, &enc->p420, AV_PIX_FMT_YUV420P, ei))) {
		goto fail;
	}
	if ((enc->cwidth != width || enc->cheight != height) &&
	    !(enc->pad =
	          bc_malloc((size_t)enc->cwidth * enc->cheight * enc->bpp))) {
		rc = bc_errinfo_set(ei, BC_ENOMEM,
		                    "video encoder: out of memory");
		goto fail;
	}
	*out = enc;
	return 0;
fail:
	bc_video_encoder_destroy(enc);
	return rc;
}

uint32_t bc_video_default_bitrate(uint32_t width, uint32_t height, uint32_t fps)
{
	double b = BC_VIDEO_DEFAULT_BPP * (double)bc__video_even(width) *
	           (double)bc__video_even(height) *
	           (double)(fps ? fps : BC_VIDEO_DEFAULT_FPS);
	b = b < BC_VIDEO_MIN_DEFAULT_BITRATE ? BC_VIDEO_MIN_DEFAULT_BITRATE : b;
	b = b > BC_VIDEO_MAX_BITRATE ? BC_VIDEO_MAX_BITRATE : b;
	return (uint32_t)b;
}

bool bc_video_encoder_available(enum bc_video_backend backend)
{
	if (backend == BC_VIDEO_BACKEND_NVENC) {
		return avcodec_find_encoder_by_name("h264_nvenc") != NULL;
	}
	return avcodec_find_encoder_by_name("libx264") != NULL ||
	       (backend == BC_VIDEO_BACKEND_AUTO &&
	        avcodec_find_encoder_by_name("h264_nvenc") != NULL);
}

void bc_video_encoder_destroy(struct bc_video_encoder *enc)
{
	if (!enc) {
		return;
	}
	avcodec_free_context(&enc->moving);
	avcodec_free_context(&enc->still);
	picture_finish(&enc->p420);
	picture_finish(&enc->p444);
	av_packet_free(&enc->pkt);
	bc_free(enc->pad);
	bc_free(enc);
}

const char *bc_video_encoder_name(const struct bc_video_encoder *enc)
{
	return enc->codec->name;
}

int bc_video_encoder_set_bitrate(struct bc_video_encoder *enc, uint32_t bitrate,
                                 struct bc_errinfo *ei)
{
	if (bitrate < BC_VIDEO_MIN_BITRATE || bitrate > BC_VIDEO_MAX_BITRATE) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "video encoder: bitrate %u bit/s is "
		                      "outside %u..%u",
		                      bitrate, BC_VIDEO_MIN_BITRATE,
		                      BC_VIDEO_MAX_BITRATE);
	}
	enc->bitrate = bitrate;
	apply_rate(enc->moving, bitrate);
	return 0;
}

/* Returns the picture at pixels, or, for odd sizes, a copy of it padded
 * to the coded size with copies of its last column and row: converted
 * whole, its chroma samples sit where a decoder expects them (converting
 * an odd width straight to ceil(width / 2) chroma columns would stretch
 * them a little across the picture). */
static const uint8_t *padded(struct bc_video_encoder *enc,
                             const uint8_t *pixels, size_t *stride)
{
	size_t row = (size_t)enc->width * enc->bpp;
	size_t prow = (size_t)enc->cwidth * enc->bpp;
	if (enc->cwidth == enc->width && enc->cheight == enc->height) {
		return pixels;
	}
	for (uint32_t y = 0; y < enc->cheight; y++) {
		uint32_t sy = y < enc->height ? y : enc->height - 1;
		uint8_t *dst = enc->pad + (size_t)y * prow;
		memcpy(dst, pixels + (size_t)sy * *stride, row);
		if (prow > row) {
			memcpy(dst + row, dst + row - enc->bpp, enc->bpp);
		}
	}
	*stride = prow;
	return enc->pad;
}

/* Converts the picture into pic's frame. */
static int convert(struct bc_video_encoder *enc, struct picture *pic,
                   const uint8_t *pixels, size_t stride, struct bc_errinfo *ei)
{
	const uint8_t *src[1];
	int src_stride[1];
	AVFrame *f = pic->frame;
	int rc = av_frame_make_writable(f);
	if (rc < 0) {
		return bc__video_av_error(ei, BC_ENOMEM, "video encoder", rc);
	}
	src[0] = padded(enc, pixels, &stride);
	src_stride[0] = (int)stride;
	sws_scale(pic->sws, src, src_stride, 0, (int)enc->cheight, f->data,
	          f->linesize);
	return 0;
}

int bc_video_encode(struct bc_video_encoder *enc, const uint8_t *pixels,
                    size_t stride, unsigned flags, struct bc_video_au *out,
                    struct bc_errinfo *ei)
{
	bool still = (flags & BC_VIDEO_STILL) != 0;
	bool idr = still || (flags & BC_VIDEO_FORCE_IDR) || enc->need_idr;
	struct picture *pic;
	AVCodecContext *c;
	int rc;
	memset(out, 0, sizeof(*out));
	if (!pixels ||
	    flags & ~(unsigned)(BC_VIDEO_FORCE_IDR | BC_VIDEO_STILL) ||
	    stride < enc->width * enc->bpp || stride > INT_MAX) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video encoder: no pixels, unknown flags "
		                      "or a row stride of %zu bytes for %u "
		                      "pixels of %zu bytes",
		                      stride, enc->width, enc->bpp);
	}
	if (still && !enc->still &&
	    (rc = open_ctx(enc, true, &enc->still, ei))) {
		return rc;
	}
	pic = still && enc->still_444 ? &enc->p444 : &enc->p420;
	if (!pic->frame &&
	    (rc = picture_init(enc, pic, AV_PIX_FMT_YUV444P, ei))) {
		picture_finish(pic);
		return rc;
	}
	if ((rc = convert(enc, pic, pixels, stride, ei))) {
		return rc;
	}
	c = still ? enc->still : enc->moving;
	pic->frame->pict_type = idr ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;
	pic->frame->pts = enc->pts++;
	av_packet_unref(enc->pkt);
	/* Whatever fails below, the decoder's picture may now differ from
	 * the encoder's: start again from an IDR. */
	enc->need_idr = true;
	rc = avcodec_send_frame(c, pic->frame);
	if (rc < 0) {
		return bc__video_av_error(ei, BC_ECODEC, "video encoder", rc);
	}
	rc = avcodec_receive_packet(c, enc->pkt);
	if (rc == AVERROR(EAGAIN)) {
		return bc_errinfo_set(
		    ei, BC_ECODEC,
		    "video encoder: %s held the frame back "
		    "(it must give one access unit per frame)",
		    enc->codec->name);
	}
	if (rc < 0) {
		return bc__video_av_error(ei, BC_ECODEC, "video encoder", rc);
	}
	/* After a still the references are gone: the next moving frame is an
	 * IDR. */
	enc->need_idr = still;
	out->data = enc->pkt->data;
	out->len = (size_t)enc->pkt->size;
	out->idr = (enc->pkt->flags & AV_PKT_FLAG_KEY) != 0;
	out->still = still;
	return 0;
}
