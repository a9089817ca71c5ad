/*
 * The H.264 decoder of libblobcast's images, in a module of its own
 * (bc_client_h264.so, built from h264_module.c with the video module and
 * FFmpeg's libraries) that image.c opens with dlopen() at the first H.264
 * frame. FFmpeg's libavcodec brings some ninety shared libraries (x264,
 * x265, vpx, dav1d, VA-API...); linked into libblobcast they would load at
 * the start of every program that uses it, tripling the start-up of the
 * `blobcast` CLI's commands, which never see a video frame unless asked
 * (docs/benchmarks.md, "CLI start-up").
 */
#ifndef BLOBCAST_CLIENT_H264_MODULE_H
#define BLOBCAST_CLIENT_H264_MODULE_H

#include <stddef.h>
#include <stdint.h>

#include "blobcast/error.h"

/* The module's one exported symbol, and the version of its table: a module
 * of another build is refused. */
#define BC_H264_MODULE_ENTRY "bc_client_h264_module"
#define BC_H264_MODULE_ABI 1u
/* Its file name, and the environment variable that names another path. */
#define BC_H264_MODULE_FILE "bc_client_h264.so"
#define BC_H264_MODULE_ENV "BLOBCAST_H264_MODULE"

/* bc_video_decoder_open (RGBA pictures), _destroy and bc_video_decode
 * (video.h), behind an opaque decoder. */
struct bc_h264_ops {
	uint32_t abi;
	int (*open)(void **dec, struct bc_errinfo *ei);
	void (*destroy)(void *dec);
	int (*decode)(void *dec, const uint8_t *data, size_t len,
	              uint32_t width, uint32_t height, const uint8_t **pixels,
	              size_t *stride, struct bc_errinfo *ei);
};

typedef const struct bc_h264_ops *(*bc_h264_module_fn)(void);

/* The entry point (h264_module.c). */
const struct bc_h264_ops *bc_client_h264_module(void);

/* The module's table, loaded on the first call (image.c): 0 and *ops, or
 * BC_ENOTSUP with the places looked at and what to do in ei. */
int bc__client_h264(const struct bc_h264_ops **ops, struct bc_errinfo *ei);

#endif
