/*
 * The encoder's and the decoder's shared rules (video_priv.h): frame size
 * limits, pixel layouts, colour conversion settings and libav's log.
 */
#include "video_priv.h"

#include <pthread.h>
#include <stdarg.h>
#include <string.h>

#include <libavutil/error.h>
#include <libavutil/log.h>
#include <libswscale/swscale.h>

#include "blobcast/log.h"

int bc__video_check_size(uint32_t width, uint32_t height, const char *what,
                         struct bc_errinfo *ei)
{
	uint64_t mbs;
	if (width == 0 || height == 0) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "%s: a video frame of %ux%u has no "
		                      "pixels; give a width and a height of at "
		                      "least 1",
		                      what, width, height);
	}
	if (width > BC_VIDEO_MAX_DIM || height > BC_VIDEO_MAX_DIM) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "%s: a video frame of %ux%u is over the "
		    "largest side of %u pixels; use a smaller "
		    "view or a still image",
		    what, width, height, BC_VIDEO_MAX_DIM);
	}
	mbs = (uint64_t)((width + 15u) / 16u) * ((height + 15u) / 16u);
	if (mbs > BC_VIDEO_MAX_MBS) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "%s: a video frame of %ux%u has %llu "
		                      "macroblocks, over H.264 level 5.1's %u "
		                      "(4096x2304); use a smaller view or a "
		                      "still image",
		                      what, width, height,
		                      (unsigned long long)mbs,
		                      BC_VIDEO_MAX_MBS);
	}
	return 0;
}

enum AVPixelFormat bc__video_av_pixfmt(enum bc_video_pixfmt f,
                                       size_t *bytes_per_pixel)
{
	switch (f) {
	case BC_VIDEO_PIX_DEFAULT:
	case BC_VIDEO_PIX_RGBA:
		*bytes_per_pixel = 4;
		return AV_PIX_FMT_RGBA;
	case BC_VIDEO_PIX_RGB:
		*bytes_per_pixel = 3;
		return AV_PIX_FMT_RGB24;
	case BC_VIDEO_PIX_COUNT:
		break;
	}
	*bytes_per_pixel = 0;
	return AV_PIX_FMT_NONE;
}

static void av_log_to_bc(void *avcl, int level, const char *fmt, va_list vl)
{
	char line[512];
	int prefix = 1;
	size_t n;
	if (level > AV_LOG_INFO || bc_log_level() < BC_LOG_DEBUG) {
		return;
	}
	av_log_format_line(avcl, level, fmt, vl, line, (int)sizeof(line),
	                   &prefix);
	n = strlen(line);
	while (n > 0 && line[n - 1] == '\n') {
		line[--n] = '\0';
	}
	bc_log(BC_LOG_DEBUG, "libav: %s", line);
}

static pthread_once_t route_once = PTHREAD_ONCE_INIT;

static void av_log_install(void)
{
	av_log_set_callback(av_log_to_bc);
}

void bc__video_route_av_log(void)
{
	pthread_once(&route_once, av_log_install);
}

int bc__video_av_error(struct bc_errinfo *ei, int code, const char *what,
                       int averr)
{
	char why[AV_ERROR_MAX_STRING_SIZE] = "";
	av_strerror(averr, why, sizeof(why));
	return bc_errinfo_set(ei, code, "%s: %s", what, why);
}

void bc__video_sws_colours(struct SwsContext *sws, int to_yuv)
{
	const int *bt601 = sws_getCoefficients(SWS_CS_ITU601);
	/* src range, dst range: RGB is full range (1), YCbCr limited (0). */
	sws_setColorspaceDetails(sws, bt601, to_yuv ? 1 : 0, bt601,
	                         to_yuv ? 0 : 1, 0, 1 << 16, 1 << 16);
}
