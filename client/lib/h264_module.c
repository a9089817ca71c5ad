/*
 * bc_client_h264.so: the video module's software H.264 decoder behind the
 * table of h264_module.h, for libblobcast to open when a program first
 * gets an H.264 frame. Only the entry point is exported.
 */
#include "h264_module.h"

#include "blobcast/video.h"

static int dec_open(void **dec, struct bc_errinfo *ei)
{
	struct bc_video_decoder_opts o = {.pixfmt = BC_VIDEO_PIX_RGBA};
	struct bc_video_decoder *d = NULL;
	int rc = bc_video_decoder_open(&o, &d, ei);
	*dec = d;
	return rc;
}

static void dec_destroy(void *dec)
{
	bc_video_decoder_destroy(dec);
}

static int dec_decode(void *dec, const uint8_t *data, size_t len,
                      uint32_t width, uint32_t height, const uint8_t **pixels,
                      size_t *stride, struct bc_errinfo *ei)
{
	return bc_video_decode(dec, data, len, width, height, pixels, stride,
	                       ei);
}

static const struct bc_h264_ops ops = {BC_H264_MODULE_ABI, dec_open,
                                       dec_destroy, dec_decode};

__attribute__((visibility("default"))) const struct bc_h264_ops *
bc_client_h264_module(void)
{
	return &ops;
}
