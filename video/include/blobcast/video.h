/*
 * H.264 video frames: an encoder that turns rendered pictures into one
 * access unit each and a decoder that turns access units back into
 * pictures, both through FFmpeg's libavcodec (docs/video.md).
 *
 * The stream is built for an interactive view, where every frame is shown
 * as soon as it arrives:
 *  - No B-frames and no reordering: each picture given to the encoder comes
 *    back at once as one access unit (one in, one out), the SPS says so
 *    (max_num_reorder_frames 0 in its VUI), and the decoder gives each
 *    access unit's picture back at once.
 *  - Access units are Annex B byte streams (00 00 01 start codes). An IDR
 *    carries its SPS and PPS in band, so any IDR is a place to start
 *    decoding. IDRs come only when asked for: the first frame, a frame
 *    encoded with BC_VIDEO_FORCE_IDR, every still, and the first moving
 *    frame after a still (there are no periodic IDRs and no scene-cut
 *    IDRs: the transport is reliable and a lost decoder asks for one).
 *  - A still (BC_VIDEO_STILL) is an IDR coded at a fixed low quantizer
 *    (BC_VIDEO_STILL_QP unless opts say otherwise): the picture a person
 *    looks at after motion stops is sharp, whatever the bitrate of the
 *    moving frames was.
 *  - H.264's 4:2:0 pictures have even sizes. An odd width or height is
 *    padded by one column or row (copies of the last one) before the
 *    conversion to YCbCr, so the coded picture is the even size; the
 *    decoder is told the real size and hands back only that part. (The
 *    SPS cropping window cannot say "one pixel" in 4:2:0: its unit is
 *    two. Padding the RGB picture, not the converted planes, keeps the
 *    chroma samples where decoders expect them.)
 *  - Colours: the RGB pictures are converted to BT.601 limited-range YCbCr
 *    with sRGB primaries and transfer, and the VUI says so.
 *
 * Neither object is thread-safe; one thread uses one object at a time.
 */
#ifndef BLOBCAST_VIDEO_H
#define BLOBCAST_VIDEO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/error.h"

/* Largest width or height of a video frame: 4096, the widest picture
 * h264_nvenc encodes in H.264 and the largest that browsers' and GPUs'
 * decoders commonly accept. */
#define BC_VIDEO_MAX_DIM 4096u
/* Largest frame in 16x16 macroblocks: 36864, the MaxFS of H.264 levels 5.1
 * and 5.2 (4096 x 2304, for instance), the highest levels that hardware
 * decoders and WebCodecs reliably support. */
#define BC_VIDEO_MAX_MBS 36864u
/* Longest access unit the decoder accepts: more than a frame of the
 * largest size can take even in PCM macroblocks (384 bytes of samples per
 * 16x16 macroblock plus its headers), so only garbage is ever refused. */
#define BC_VIDEO_MAX_AU_BYTES ((size_t)BC_VIDEO_MAX_MBS * 512u + 65536u)
/* Quantizer of a still when opts.still_qp is 0. Measured on rendered
 * frames (PSNR over RGB against the render; tests/video, docs/video.md):
 * a 4:4:4 still reaches 45 dB or more (48-49 dB at 1920x1080), a 4:2:0
 * still comes within 0.6 dB of what the conversion to 4:2:0 alone
 * leaves (about 45 dB at 1920x1080, less on smaller pictures, whatever
 * the quantizer). */
#define BC_VIDEO_STILL_QP 12
/* Frames per second when opts.fps is 0. */
#define BC_VIDEO_DEFAULT_FPS 30u
/* Bits per pixel per frame of the default bitrate (opts.bitrate 0): about
 * 4.4 Mbit/s for 1920 x 1080 at 30 frames per second. */
#define BC_VIDEO_DEFAULT_BPP 0.07
/* libx264's preset when opts.x264_preset is NULL: at 1920x1080 on one
 * core it encodes a frame in about a tenth of the time the CPU renderer
 * takes to draw it, and at JPEG q80's PSNR in about a fifth of its bytes
 * ("veryfast" takes a quarter less time for 12-13% more bytes, "medium"
 * 1.8 times the time for 10% fewer: docs/benchmarks.md). */
#define BC_VIDEO_DEFAULT_X264_PRESET "faster"
/* The bitrate's bounds, bits per second: below 32 kbit/s no frame size is
 * usable, above 400 Mbit/s is past what any level allows. */
#define BC_VIDEO_MIN_BITRATE 32000u
#define BC_VIDEO_MAX_BITRATE 400000000u
/* The least default bitrate: BC_VIDEO_DEFAULT_BPP gives a 160 x 120 view
 * 40 kbit/s, a few hundred bytes a frame, too few for its edges; 600
 * kbit/s is a small share of any link a view is watched over. */
#define BC_VIDEO_MIN_DEFAULT_BITRATE 600000u

/* The bitrate an encoder of width x height pictures at fps frames per
 * second (0: BC_VIDEO_DEFAULT_FPS) runs at when opts.bitrate is 0:
 * BC_VIDEO_DEFAULT_BPP bits per pixel per frame of the coded (even)
 * size, at least BC_VIDEO_MIN_DEFAULT_BITRATE, within the bounds. */
uint32_t bc_video_default_bitrate(uint32_t width, uint32_t height,
                                  uint32_t fps);

/* The layout of the RGB pictures given and taken (8 bits per channel,
 * rows top first). */
enum bc_video_pixfmt {
	BC_VIDEO_PIX_DEFAULT = 0, /* RGBA, what the renderers produce */
	BC_VIDEO_PIX_RGBA,        /* 4 bytes per pixel, alpha ignored / 255 */
	BC_VIDEO_PIX_RGB,         /* 3 bytes per pixel */
	BC_VIDEO_PIX_COUNT
};

/* Which libavcodec encoder runs. */
enum bc_video_backend {
	BC_VIDEO_BACKEND_AUTO = 0, /* h264_nvenc if it opens, else libx264 */
	BC_VIDEO_BACKEND_X264,     /* libx264 on the CPU */
	BC_VIDEO_BACKEND_NVENC,    /* h264_nvenc only: fails without one */
	BC_VIDEO_BACKEND_COUNT
};

/* Encoder options; zero means default for every field. */
struct bc_video_opts {
	uint32_t fps;     /* frames per second, 1..240; 0: 30 */
	uint32_t bitrate; /* bits per second of moving frames; 0: default */
	int still_qp;     /* quantizer of stills, 1..51; 0: BC_VIDEO_STILL_QP */
	enum bc_video_backend backend;
	enum bc_video_pixfmt pixfmt; /* of the pictures given */
	/* libx264's preset ("ultrafast" .. "placebo"); NULL:
	 * BC_VIDEO_DEFAULT_X264_PRESET. */
	const char *x264_preset;
	uint32_t threads; /* encoder threads, 0: libavcodec's choice */
	/* Stills in 4:4:4 (the High 4:4:4 Predictive profile) instead of
	 * 4:2:0: no colour resolution lost at edges, which is what keeps a
	 * 4:2:0 still of a rendered frame under 45 dB (docs/video.md), but
	 * not every decoder takes that profile. */
	bool still_444;
};

/* bc_video_encode's flags. */
enum bc_video_flag {
	BC_VIDEO_FORCE_IDR = 1u << 0, /* make this frame an IDR */
	BC_VIDEO_STILL = 1u << 1,     /* an IDR at the still quantizer */
};

/* One access unit. data is owned by the encoder and stays valid until the
 * next bc_video_encode, bc_video_encoder_set_bitrate or
 * bc_video_encoder_destroy on it. */
struct bc_video_au {
	const uint8_t *data; /* Annex B */
	size_t len;
	bool idr;   /* an IDR, with its SPS and PPS in band */
	bool still; /* coded at the still quantizer */
};

struct bc_video_encoder;

/* Opens an encoder for width x height pictures (1..BC_VIDEO_MAX_DIM each,
 * at most BC_VIDEO_MAX_MBS macroblocks once padded to even sizes). Logs
 * one line (BC_LOG_INFO) naming the encoder that runs and why. Returns 0
 * and sets *out (the caller destroys it), or BC_EINVAL (bad option),
 * BC_ELIMIT (size), BC_ENOTSUP (no H.264 encoder, or nvenc asked for and
 * not available), BC_ECODEC (the encoder refused to open) or BC_ENOMEM,
 * with a sentence in ei; *out is NULL then. */
int bc_video_encoder_open(uint32_t width, uint32_t height,
                          const struct bc_video_opts *opts,
                          struct bc_video_encoder **out, struct bc_errinfo *ei);

/* Whether this libavcodec has an H.264 encoder that backend would try
 * (AUTO and X264: libx264; NVENC: h264_nvenc). Opening one may still fail
 * (no NVIDIA device, say): this only says whether it is worth trying. */
bool bc_video_encoder_available(enum bc_video_backend backend);

/* Frees enc and everything it holds; NULL is a no-op. */
void bc_video_encoder_destroy(struct bc_video_encoder *enc);

/* The libavcodec encoder that runs ("libx264" or "h264_nvenc"). */
const char *bc_video_encoder_name(const struct bc_video_encoder *enc);

/* Encodes the width x height picture at pixels (rows stride bytes apart,
 * in opts.pixfmt) into one access unit in *out (reset on entry). flags
 * are enum bc_video_flag bits. Returns 0, or BC_EINVAL (bad stride or
 * flags), BC_ECODEC or BC_ENOMEM with a sentence in ei; after an encoder
 * error the next frame is an IDR. */
int bc_video_encode(struct bc_video_encoder *enc, const uint8_t *pixels,
                    size_t stride, unsigned flags, struct bc_video_au *out,
                    struct bc_errinfo *ei);

/* Changes the bitrate of the moving frames from the next frame on (for a
 * rate that follows the connection). libx264 and h264_nvenc take the new
 * rate on the running encoder, so this costs nothing and needs no IDR.
 * Returns 0 or BC_ERANGE (outside BC_VIDEO_MIN_BITRATE..MAX). */
int bc_video_encoder_set_bitrate(struct bc_video_encoder *enc, uint32_t bitrate,
                                 struct bc_errinfo *ei);

/* Decoder options; zero means default. */
struct bc_video_decoder_opts {
	enum bc_video_pixfmt pixfmt; /* of the pictures returned */
};

struct bc_video_decoder;

/* Opens libavcodec's software H.264 decoder, on one thread (with slice
 * threads it would conceal damaged slices without a word; a 1920x1080
 * picture takes a few milliseconds on one core). Returns 0 and sets *out (the
 * caller destroys it), or BC_ENOTSUP (no H.264 decoder), BC_ECODEC or
 * BC_ENOMEM with a sentence in ei. */
int bc_video_decoder_open(const struct bc_video_decoder_opts *opts,
                          struct bc_video_decoder **out, struct bc_errinfo *ei);

/* Frees dec; NULL is a no-op. */
void bc_video_decoder_destroy(struct bc_video_decoder *dec);

/* Decodes the access unit of len bytes at data (untrusted: any bytes are
 * refused cleanly) into a width x height picture, which the stream must
 * code at that size or at that size padded to even numbers (the padding
 * is cropped). *pixels (reset on entry) then points at width x height
 * pixels in opts.pixfmt, rows *stride bytes apart (more than width's for
 * an odd width: the row goes on with the padding), owned by the decoder
 * and valid until its next call. The first access unit, and the first
 * after any error, must be an IDR: until one comes, others are refused
 * with BC_ESTATE. Returns 0, BC_EINVAL (size 0), BC_ELIMIT (size over the
 * limits),
 * BC_EPROTO_LENGTH (len 0 or over BC_VIDEO_MAX_AU_BYTES), BC_ESTATE,
 * BC_ECODEC (bytes that are not a whole picture of that size), or
 * BC_ENOMEM, with a sentence in ei. */
int bc_video_decode(struct bc_video_decoder *dec, const uint8_t *data,
                    size_t len, uint32_t width, uint32_t height,
                    const uint8_t **pixels, size_t *stride,
                    struct bc_errinfo *ei);

#endif
