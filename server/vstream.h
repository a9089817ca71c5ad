/*
 * A client's H.264 stream (encoding 4, PROTOCOL.md 7.15): the encoder
 * state of one member's view, which lives with the view and not with a
 * render worker. The sessions layer makes one for each VIEW of encoding 4
 * and hands it to that member's frame jobs; the worker running a job
 * encodes the job's picture with it (work layer, job.c).
 *
 * Threads: a member has at most one frame job at a time, so one worker at
 * a time encodes; the loop thread only sets the flags and the bitrate
 * (atomics) and counts references. Every access unit the worker makes
 * must reach the client, or the next one must be an IDR: the loop thread
 * says so with bc_vstream_delivered for each frame it sends, and a worker
 * that finds an access unit it made unconfirmed starts again from an IDR
 * (a frame over the client's limit, a job dropped after encoding).
 */
#ifndef BLOBCAST_SERVER_VSTREAM_H
#define BLOBCAST_SERVER_VSTREAM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/error.h"
#include "blobcast/video.h"

struct bc_vstream;

/* Looks for the encoder module (h264_module.h) without opening it:
 * blobcastd calls it at its start, so that its log says before anyone
 * asks when encoding 4 will be refused. Returns 0 when a module file is
 * there (opening it may still fail: bc_vstream_load says why), or
 * BC_ENOTSUP with where it looked and what to do in ei (NULL allowed). */
int bc_vstream_find(struct bc_errinfo *ei);
/* Opens the encoder module once per process: FFmpeg's libraries, tens of
 * milliseconds, and some 15 MB resident that a daemon nobody asks for
 * video from never pays. The first VIEW of encoding 4 has it opened on a
 * task (frames.c) and waits parked, so that the loop never waits for it.
 * Returns 0, or BC_ENOTSUP with where it looked and what to do in ei
 * (NULL allowed): encoding 4 is then refused. Thread-safe. */
int bc_vstream_load(struct bc_errinfo *ei);
/* Whether bc_vstream_load has been done, whatever it found: then it and
 * bc_vstream_can_encode answer at once. */
bool bc_vstream_loaded(void);
/* Starts bc_vstream_load on a thread of its own, once (a HELLO that lists
 * H.264: the load goes on while the client joins, and its VIEW seldom
 * waits). Returns at once. */
void bc_vstream_preload(void);
/* Waits for the preload thread, if one was started (the daemon's end: no
 * thread left inside dlopen while the process exits). */
void bc_vstream_settle(void);
/* Whether an H.264 view can be served: the module is there and has an
 * encoder that backend tries. */
bool bc_vstream_can_encode(enum bc_video_backend backend);
/* The module's default bitrate of a width x height view (0 without it). */
uint32_t bc_vstream_default_bitrate(uint32_t width, uint32_t height);

/* A stream with one reference, encoding with opts (copied; the preset
 * string too); the encoder opens at the first frame, on a worker. NULL
 * when out of memory. */
struct bc_vstream *bc_vstream_new(const struct bc_video_opts *opts);
void bc_vstream_ref(struct bc_vstream *vs);
/* Drops a reference; the last frees the encoder. NULL is a no-op. */
void bc_vstream_unref(struct bc_vstream *vs);

/* Loop thread: the access unit of the last frame encoded was sent. */
void bc_vstream_delivered(struct bc_vstream *vs);
/* Loop thread: the next frame is an IDR whatever came before. */
void bc_vstream_restart(struct bc_vstream *vs);
/* Loop thread: the bitrate of moving frames from the next frame on, bits
 * per second (clamped to what the encoder takes); 0: the default for the
 * view's size. */
void bc_vstream_set_bitrate(struct bc_vstream *vs, uint32_t bps);

/* One encoded frame. data is bc_malloc'ed, the caller's. */
struct bc_vstream_au {
	uint8_t *data;
	size_t len;
	bool key; /* an IDR with its SPS and PPS: FRAME flag KEY */
};

/* Worker: encodes the picture of a width x height view whose RGBA pixels
 * (rows width * 4 bytes apart) hold level `level`: at a level n > 0 only
 * the top-left pixel of each 2^n block is rendered, and the picture is
 * scaled up (each block takes its pixel) before encoding. A still is an
 * IDR at the still quantizer. Opens the encoder, or reopens it for a new
 * size. Returns 0, or BC_ENOTSUP / BC_ECODEC / BC_ELIMIT / BC_ENOMEM with
 * the reason in ei; after an error the stream starts again at an IDR. */
int bc_vstream_encode(struct bc_vstream *vs, const uint8_t *rgba,
                      uint32_t width, uint32_t height, int level, bool still,
                      struct bc_vstream_au *out, struct bc_errinfo *ei);

#endif
