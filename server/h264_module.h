/*
 * blobcastd's H.264 encoder in a module of its own (bc_server_h264.so,
 * built from h264_module.c with the video module and FFmpeg's libraries),
 * which vstream.c opens with dlopen() once, at the daemon's start. FFmpeg's
 * libavcodec brings some ninety shared libraries (x264, x265, vpx, dav1d,
 * VA-API...); linked into blobcastd they would be needed wherever the
 * daemon runs, the GPU run's kit included (bench/gpu/pack.sh carries what a
 * bare host lacks, under 64 MiB). Without the module the daemon refuses
 * encoding 4 (ENOTSUP) and serves everything else.
 */
#ifndef BLOBCAST_SERVER_H264_MODULE_H
#define BLOBCAST_SERVER_H264_MODULE_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/video.h"

/* The module's one exported symbol, and the version of its table: a module
 * of another build is refused. */
#define BC_SRV_H264_ENTRY "bc_server_h264_module"
#define BC_SRV_H264_ABI 1u
/* Its file name, and the environment variable that names another path. */
#define BC_SRV_H264_FILE "bc_server_h264.so"
#define BC_SRV_H264_ENV "BLOBCASTD_H264_MODULE"

/* The encoder functions of blobcast/video.h. */
struct bc_srv_h264_ops {
	uint32_t abi;
	bool (*available)(enum bc_video_backend backend);
	int (*open)(uint32_t width, uint32_t height,
	            const struct bc_video_opts *opts,
	            struct bc_video_encoder **out, struct bc_errinfo *ei);
	void (*destroy)(struct bc_video_encoder *enc);
	const char *(*name)(const struct bc_video_encoder *enc);
	int (*encode)(struct bc_video_encoder *enc, const uint8_t *pixels,
	              size_t stride, unsigned flags, struct bc_video_au *out,
	              struct bc_errinfo *ei);
	int (*set_bitrate)(struct bc_video_encoder *enc, uint32_t bitrate,
	                   struct bc_errinfo *ei);
	uint32_t (*default_bitrate)(uint32_t width, uint32_t height,
	                            uint32_t fps);
};

typedef const struct bc_srv_h264_ops *(*bc_srv_h264_fn)(void);

/* The entry point (h264_module.c). */
const struct bc_srv_h264_ops *bc_server_h264_module(void);

#endif
