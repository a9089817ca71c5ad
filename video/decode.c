/*
 * The H.264 decoder (blobcast/video.h): libavcodec's software decoder,
 * one access unit in and one picture out, converted to RGB by libswscale.
 * The bytes come from the network: their length is bounded before they
 * are copied, the decoder refuses pictures larger than the limits before
 * it allocates them, and every failure is an error code, never an abort.
 */
#include <string.h>

#include <libavcodec/avcodec.h>
#include <libavutil/frame.h>
#include <libswscale/swscale.h>

#include "blobcast/alloc.h"
#include "video_priv.h"

/* NAL unit type of an IDR picture's slices. */
#define NAL_IDR 5

struct bc_video_decoder {
	AVCodecContext *ctx;
	AVPacket *pkt;
	AVFrame *frame;
	struct SwsContext *sws;
	enum AVPixelFormat dst_fmt;
	size_t bpp;
	uint8_t *pixels; /* the whole coded picture, RGB */
	size_t cap, stride;
	bool need_idr; /* refuse access units until an IDR */
};

int bc_video_decoder_open(const struct bc_video_decoder_opts *opts,
                          struct bc_video_decoder **out, struct bc_errinfo *ei)
{
	static const struct bc_video_decoder_opts defaults = {0};
	const struct bc_video_decoder_opts *o = opts ? opts : &defaults;
	const AVCodec *codec;
	struct bc_video_decoder *dec;
	int rc;
	*out = NULL;
	if ((unsigned)o->pixfmt >= BC_VIDEO_PIX_COUNT) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "video decoder: unknown pixel format");
	}
	bc__video_route_av_log();
	codec = avcodec_find_decoder(AV_CODEC_ID_H264);
	if (!codec) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "video decoder: this libavcodec has no "
		                      "H.264 decoder");
	}
	dec = bc_calloc(1, sizeof(*dec));
	if (!dec) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "video decoder: out of memory");
	}
	dec->dst_fmt = bc__video_av_pixfmt(o->pixfmt, &dec->bpp);
	dec->need_idr = true;
	dec->ctx = avcodec_alloc_context3(codec);
	dec->pkt = av_packet_alloc();
	dec->frame = av_frame_alloc();
	if (!dec->ctx || !dec->pkt || !dec->frame) {
		rc = bc_errinfo_set(ei, BC_ENOMEM,
		                    "video decoder: out of memory");
		goto fail;
	}
	/* Each access unit's picture at once (the stream has no
	 * reordering), and an error for a damaged picture instead of a
	 * concealed one. One thread: frame threads delay the output by a
	 * frame per thread, and with slice threads libavcodec drops the
	 * errors of single slices (a cut access unit would then come out
	 * concealed, with no error). */
	dec->ctx->flags |= AV_CODEC_FLAG_LOW_DELAY;
	dec->ctx->thread_count = 1;
	dec->ctx->err_recognition =
	    AV_EF_EXPLODE | AV_EF_BITSTREAM | AV_EF_BUFFER | AV_EF_CRCCHECK;
	/* Nothing larger than the largest frame is ever allocated, whatever
	 * an SPS claims. */
	dec->ctx->max_pixels = (int64_t)BC_VIDEO_MAX_MBS * 256;
	rc = avcodec_open2(dec->ctx, codec, NULL);
	if (rc < 0) {
		rc = bc__video_av_error(ei, BC_ECODEC, "video decoder", rc);
		goto fail;
	}
	*out = dec;
	return 0;
fail:
	bc_video_decoder_destroy(dec);
	return rc;
}

void bc_video_decoder_destroy(struct bc_video_decoder *dec)
{
	if (!dec) {
		return;
	}
	avcodec_free_context(&dec->ctx);
	av_packet_free(&dec->pkt);
	av_frame_free(&dec->frame);
	sws_freeContext(dec->sws);
	bc_free(dec->pixels);
	bc_free(dec);
}

/* Whether the Annex B bytes hold a NAL unit of type IDR: a start code
 * (00 00 01) followed by a header byte whose low five bits are 5. */
static bool has_idr(const uint8_t *p, size_t len)
{
	for (size_t i = 0; i + 3 < len; i++) {
		if (p[i] == 0 && p[i + 1] == 0 && p[i + 2] == 1) {
			if ((p[i + 3] & 0x1f) == NAL_IDR) {
				return true;
			}
			i += 2;
		}
	}
	return false;
}

/* Sends the access unit and takes its picture into dec->frame. */
static int decode_picture(struct bc_video_decoder *dec, const uint8_t *data,
                          size_t len, struct bc_errinfo *ei)
{
	int rc;
	av_packet_unref(dec->pkt);
	av_frame_unref(dec->frame);
	/* A copy: libavcodec reads a padding of zeros past the end. */
	if (av_new_packet(dec->pkt, (int)len) < 0) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "video decoder: out of memory");
	}
	memcpy(dec->pkt->data, data, len);
	rc = avcodec_send_packet(dec->ctx, dec->pkt);
	if (rc < 0) {
		return bc__video_av_error(
		    ei, BC_ECODEC, "video decoder: a damaged access unit", rc);
	}
	rc = avcodec_receive_frame(dec->ctx, dec->frame);
	if (rc == AVERROR(EAGAIN)) {
		return bc_errinfo_set(ei, BC_ECODEC,
		                      "video decoder: the access unit of %zu "
		                      "bytes held no picture",
		                      len);
	}
	if (rc < 0) {
		return bc__video_av_error(
		    ei, BC_ECODEC, "video decoder: a damaged access unit", rc);
	}
	if ((dec->frame->flags & AV_FRAME_FLAG_CORRUPT) ||
	    dec->frame->decode_error_flags) {
		return bc_errinfo_set(ei, BC_ECODEC,
		                      "video decoder: the picture was damaged "
		                      "(missing or broken slices)");
	}
	return 0;
}

/* Converts dec->frame to RGB whole (the padding of odd sizes too, so that
 * chroma is upsampled from where it was sampled); the caller is given its
 * top-left width x height pixels. */
static int to_rgb(struct bc_video_decoder *dec, struct bc_errinfo *ei)
{
	AVFrame *f = dec->frame;
	size_t stride = (size_t)f->width * dec->bpp;
	size_t need = stride * (size_t)f->height;
	uint8_t *dst[1];
	int dst_stride[1] = {(int)stride};
	if (f->format != AV_PIX_FMT_YUV420P &&
	    f->format != AV_PIX_FMT_YUVJ420P &&
	    f->format != AV_PIX_FMT_YUV444P &&
	    f->format != AV_PIX_FMT_YUVJ444P) {
		return bc_errinfo_set(ei, BC_ECODEC,
		                      "video decoder: the stream is not 8-bit "
		                      "4:2:0 or 4:4:4 (pixel format %d)",
		                      f->format);
	}
	if (need > dec->cap) {
		bc_free(dec->pixels);
		dec->cap = 0;
		dec->pixels = bc_malloc(need);
		if (!dec->pixels) {
			return bc_errinfo_set(ei, BC_ENOMEM,
			                      "video decoder: out of memory");
		}
		dec->cap = need;
	}
	dec->sws = sws_getCachedContext(dec->sws, f->width, f->height,
	                                (enum AVPixelFormat)f->format, f->width,
	                                f->height, dec->dst_fmt,
	                                BC__VIDEO_SWS_FLAGS, NULL, NULL, NULL);
	if (!dec->sws) {
		return bc_errinfo_set(
		    ei, BC_ENOMEM,
		    "video decoder: libswscale cannot convert "
		    "%dx%d to RGB",
		    f->width, f->height);
	}
	bc__video_sws_colours(dec->sws, 0);
	dst[0] = dec->pixels;
	sws_scale(dec->sws, (const uint8_t *const *)f->data, f->linesize, 0,
	          f->height, dst, dst_stride);
	dec->stride = stride;
	return 0;
}

int bc_video_decode(struct bc_video_decoder *dec, const uint8_t *data,
                    size_t len, uint32_t width, uint32_t height,
                    const uint8_t **pixels, size_t *stride,
                    struct bc_errinfo *ei)
{
	int rc;
	*pixels = NULL;
	*stride = 0;
	if ((rc = bc__video_check_size(width, height, "video decoder", ei))) {
		return rc;
	}
	if (!data || len == 0 || len > BC_VIDEO_MAX_AU_BYTES) {
		return bc_errinfo_set(ei, BC_EPROTO_LENGTH,
		                      "video decoder: an access unit of %zu "
		                      "bytes (1..%zu)",
		                      len, (size_t)BC_VIDEO_MAX_AU_BYTES);
	}
	if (dec->need_idr && !has_idr(data, len)) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "video decoder: waiting for an IDR "
		                      "picture (a key frame) to start from");
	}
	dec->need_idr = true;
	if ((rc = decode_picture(dec, data, len, ei))) {
		avcodec_flush_buffers(dec->ctx);
		return rc;
	}
	if ((uint32_t)dec->frame->width != width &&
	    (uint32_t)dec->frame->width != bc__video_even(width)) {
		rc = BC_ECODEC;
	}
	if ((uint32_t)dec->frame->height != height &&
	    (uint32_t)dec->frame->height != bc__video_even(height)) {
		rc = BC_ECODEC;
	}
	if (rc) {
		avcodec_flush_buffers(dec->ctx);
		return bc_errinfo_set(ei, rc,
		                      "video decoder: the stream's picture is "
		                      "%dx%d, the view %ux%u",
		                      dec->frame->width, dec->frame->height,
		                      width, height);
	}
	if ((rc = to_rgb(dec, ei))) {
		return rc;
	}
	dec->need_idr = false;
	*pixels = dec->pixels;
	*stride = dec->stride;
	return 0;
}
