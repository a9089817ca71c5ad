/*
 * What the encoder and the decoder share: the size rules, the pixel
 * layouts, the colour conversion's settings and libavcodec's messages
 * routed into our logger.
 */
#ifndef BLOBCAST_VIDEO_PRIV_H
#define BLOBCAST_VIDEO_PRIV_H

#include <stddef.h>
#include <stdint.h>

#include <libavutil/pixfmt.h>

#include "blobcast/video.h"

/* libswscale's flags for both directions: exact rounding and full chroma
 * interpolation cost little at these sizes and keep the round trip of a
 * flat colour within one step of 255. */
#define BC__VIDEO_SWS_FLAGS                                                    \
	(SWS_BILINEAR | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT |                \
	 SWS_FULL_CHR_H_INP)

/* The even size a width or height is coded at. */
static inline uint32_t bc__video_even(uint32_t n)
{
	return n + (n & 1u);
}

/* Checks width x height against the limits of blobcast/video.h. Returns 0
 * or BC_ELIMIT / BC_EINVAL with a sentence in ei naming what. */
int bc__video_check_size(uint32_t width, uint32_t height, const char *what,
                         struct bc_errinfo *ei);

/* libswscale's name for a layout and its bytes per pixel; the default
 * layout is RGBA. Returns AV_PIX_FMT_NONE for values out of the enum. */
enum AVPixelFormat bc__video_av_pixfmt(enum bc_video_pixfmt f,
                                       size_t *bytes_per_pixel);

/* Routes libavcodec's messages into bc_log at BC_LOG_DEBUG (once per
 * process): a failure is reported by our own sentence, and the encoders'
 * chatter on every open would fill the daemon's log otherwise. */
void bc__video_route_av_log(void);

/* Sets ei from a libav error code: "what: libav's sentence". Returns
 * code. */
int bc__video_av_error(struct bc_errinfo *ei, int code, const char *what,
                       int averr);

/* Sets the colour conversion of sws between RGB (full range) and BT.601
 * limited-range YCbCr; to_yuv says which way. */
struct SwsContext;
void bc__video_sws_colours(struct SwsContext *sws, int to_yuv);

#endif
