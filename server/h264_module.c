/*
 * bc_server_h264.so: the video module's H.264 encoder behind the table of
 * h264_module.h, for blobcastd to open at its start. Only the entry point
 * is exported.
 */
#include "h264_module.h"

static const struct bc_srv_h264_ops ops = {
    BC_SRV_H264_ABI,
    bc_video_encoder_available,
    bc_video_encoder_open,
    bc_video_encoder_destroy,
    bc_video_encoder_name,
    bc_video_encode,
    bc_video_encoder_set_bitrate,
    bc_video_default_bitrate,
};

__attribute__((visibility("default"))) const struct bc_srv_h264_ops *
bc_server_h264_module(void)
{
	return &ops;
}
