/*
 * H.264 encoding beside rendering: an orbit around Fig. 18's 1024 smooth
 * spheres rendered by the CPU tiled renderer at 1920x1080 and 1280x720,
 * then encoded by libx264 (blobcast/video.h) at a few bitrates and by
 * TurboJPEG at quality 80 (the interactive stream's codec, called as
 * server/encode.c calls it), each decoded again and compared with the
 * rendered frame by PSNR over RGB.
 *
 * Per size it prints the render time per frame, and per codec the encode
 * time per frame (process CPU time, the conversion from RGB included;
 * wall time beside it), the decode time (CPU, the conversion to RGB
 * included), the mean bytes per frame (H.264: the IDR that
 * starts the stream apart), mean and lowest PSNR, and the bytes of JPEG
 * q80 over those of H.264. A still (an IDR at the still quantizer) of the
 * last frame, in 4:2:0 and in 4:4:4, and the PSNR of the RGB -> YCbCr
 * 4:2:0 -> RGB conversion alone (the most any 4:2:0 codec can reach) are
 * printed too.
 *
 * Usage: bench_video [--frames F] [--threads T] [--enc-threads E]
 *                    [--still-qp Q] [--preset P] [--step D]
 *                    [--backend x264|nvenc|auto] [--quick]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <turbojpeg.h>

#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "blobcast/video.h"

#define MAX_FRAMES 120u
#define JPEG_QUALITY 80

static double clock_ms(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* Squared error over RGB of two w x h pictures of bpp bytes per pixel. */
static double sq_err(const uint8_t *a, const uint8_t *b, size_t bpp, uint32_t w,
                     uint32_t h)
{
	double se = 0.0;
	for (size_t i = 0; i < (size_t)w * h; i++) {
		for (int k = 0; k < 3; k++) {
			double d = (double)a[i * 4u + (size_t)k] -
			           (double)b[i * bpp + (size_t)k];
			se += d * d;
		}
	}
	return se;
}

static double psnr(double se, uint32_t w, uint32_t h)
{
	double mse = se / (3.0 * w * h);
	return mse == 0.0 ? 99.0 : 10.0 * log10(255.0 * 255.0 / mse);
}

struct run {
	double cpu_ms, wall_ms; /* encoding, per frame */
	double dec_ms;          /* decoding, CPU, per frame */
	double bytes;           /* mean, without the first frame for H.264 */
	size_t first_bytes;     /* H.264: the IDR */
	double db_mean, db_min;
};

static void die(const char *what, const char *msg)
{
	fprintf(stderr, "bench_video: %s: %s\n", what, msg);
	exit(1);
}

/* Encodes the frames with H.264 (flags 0; BC_VIDEO_STILL alone: one still
 * of the last frame) and decodes each. */
static struct run run_h264(uint8_t **frames, uint32_t n, uint32_t w, uint32_t h,
                           const struct bc_video_opts *o, bool still)
{
	struct run r = {.db_min = 1e9};
	struct bc_video_encoder *enc = NULL;
	struct bc_video_decoder *dec = NULL;
	struct bc_errinfo ei = {0};
	double cpu = 0.0, wall = 0.0, dcpu = 0.0;
	size_t bytes = 0;
	uint32_t first = still ? n - 1 : 0;
	if (bc_video_encoder_open(w, h, o, &enc, &ei) ||
	    bc_video_decoder_open(NULL, &dec, &ei)) {
		die("open", ei.msg);
	}
	for (uint32_t i = first; i < n; i++) {
		struct bc_video_au au;
		const uint8_t *px;
		size_t stride;
		double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		double w0 = clock_ms(CLOCK_MONOTONIC), db;
		if (bc_video_encode(enc, frames[i], (size_t)w * 4u,
		                    still ? BC_VIDEO_STILL : 0, &au, &ei)) {
			die("encode", ei.msg);
		}
		cpu += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
		wall += clock_ms(CLOCK_MONOTONIC) - w0;
		if (i == first) {
			r.first_bytes = au.len;
		} else {
			bytes += au.len;
		}
		c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		if (bc_video_decode(dec, au.data, au.len, w, h, &px, &stride,
		                    &ei)) {
			die("decode", ei.msg);
		}
		dcpu += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
		db = psnr(sq_err(frames[i], px, 4, w, h), w, h);
		r.db_mean += db;
		r.db_min = db < r.db_min ? db : r.db_min;
	}
	n -= first;
	r.cpu_ms = cpu / n;
	r.wall_ms = wall / n;
	r.dec_ms = dcpu / n;
	r.bytes = n > 1 ? (double)bytes / (n - 1) : (double)r.first_bytes;
	r.db_mean /= n;
	bc_video_encoder_destroy(enc);
	bc_video_decoder_destroy(dec);
	return r;
}

/* TurboJPEG quality 80, 4:2:0, fast DCT: server/encode.c's settings for
 * the moving stream. */
static struct run run_jpeg(uint8_t **frames, uint32_t n, uint32_t w, uint32_t h)
{
	struct run r = {.db_min = 1e9};
	tjhandle tc = tjInitCompress(), td = tjInitDecompress();
	uint8_t *back = malloc((size_t)w * h * 4u);
	double cpu = 0.0, wall = 0.0, bytes = 0.0, dcpu = 0.0;
	if (!tc || !td || !back) {
		die("jpeg", "cannot start TurboJPEG");
	}
	for (uint32_t i = 0; i < n; i++) {
		unsigned char *jpeg = NULL;
		unsigned long size = 0;
		double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		double w0 = clock_ms(CLOCK_MONOTONIC), db;
		if (tjCompress2(tc, frames[i], (int)w, (int)(w * 4u), (int)h,
		                TJPF_RGBA, &jpeg, &size, TJSAMP_420,
		                JPEG_QUALITY, TJFLAG_FASTDCT) != 0) {
			die("jpeg", tjGetErrorStr2(tc));
		}
		cpu += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
		wall += clock_ms(CLOCK_MONOTONIC) - w0;
		bytes += (double)size;
		c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
		if (tjDecompress2(td, jpeg, size, back, (int)w, (int)(w * 4u),
		                  (int)h, TJPF_RGBA, 0) != 0) {
			die("jpeg", tjGetErrorStr2(td));
		}
		dcpu += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
		tjFree(jpeg);
		db = psnr(sq_err(frames[i], back, 4, w, h), w, h);
		r.db_mean += db;
		r.db_min = db < r.db_min ? db : r.db_min;
	}
	r.cpu_ms = cpu / n;
	r.wall_ms = wall / n;
	r.dec_ms = dcpu / n;
	r.bytes = bytes / n;
	r.db_mean /= n;
	tjDestroy(tc);
	tjDestroy(td);
	free(back);
	return r;
}

/* PSNR of the 4:2:0 conversion alone: a still at quantizer 1 is as close
 * to the converted picture as H.264 gets (near lossless), so what it
 * loses is the conversion's. */
static double floor_420(uint8_t **frames, uint32_t n, uint32_t w, uint32_t h,
                        const struct bc_video_opts *base)
{
	struct bc_video_opts o = *base;
	o.still_qp = 1;
	return run_h264(frames, n, w, h, &o, true).db_mean;
}

static void print_row(const char *label, const struct run *r, double jpeg_bytes)
{
	char first[24] = "";
	if (r->first_bytes) {
		snprintf(first, sizeof(first), "%zu", r->first_bytes);
	}
	printf("  %-22s %8.1f %8.1f %7.1f | %10.0f %9s | %6.2f %6.2f | "
	       "%6.1fx\n",
	       label, r->cpu_ms, r->wall_ms, r->dec_ms, r->bytes, first,
	       r->db_mean, r->db_min, jpeg_bytes / r->bytes);
}

int main(int argc, char **argv)
{
	static const uint32_t sizes[][2] = {{1920, 1080}, {1280, 720}};
	static const uint32_t bitrates[] = {1000000, 2000000, 4000000, 6000000,
	                                    8000000};
	uint32_t nframes = 10, threads = 1, enc_threads = 1;
	uint32_t still_qp = BC_VIDEO_STILL_QP;
	float step = 2.0f;
	const char *preset = BC_VIDEO_DEFAULT_X264_PRESET;
	bool quick = false;
	int backend = BC_VIDEO_BACKEND_X264;
	static const struct bc_opt_name backends[] = {
	    {"x264", BC_VIDEO_BACKEND_X264},
	    {"nvenc", BC_VIDEO_BACKEND_NVENC},
	    {"auto", BC_VIDEO_BACKEND_AUTO},
	    {NULL, 0},
	};
	const struct bc_opt opts_table[] = {
	    {.name = "frames",
	     .kind = BC_OPT_U32,
	     .dst = &nframes,
	     .lo = 2,
	     .hi = MAX_FRAMES,
	     .arg = "F",
	     .help = "frames of the orbit, {range} (default {default})"},
	    {.name = "threads",
	     .kind = BC_OPT_U32,
	     .dst = &threads,
	     .hi = 1024,
	     .arg = "T",
	     .help = "render threads, 0 = one per core (default {default})"},
	    {.name = "enc-threads",
	     .kind = BC_OPT_U32,
	     .dst = &enc_threads,
	     .hi = 64,
	     .arg = "E",
	     .help = "libx264 threads, 0 = its choice (default {default})"},
	    {.name = "step",
	     .kind = BC_OPT_F32,
	     .dst = &step,
	     .lo = 0,
	     .hi = 90,
	     .arg = "D",
	     .help = "degrees the camera turns per frame (default "
	             "{default})"},
	    {.name = "still-qp",
	     .kind = BC_OPT_U32,
	     .dst = &still_qp,
	     .lo = 1,
	     .hi = 51,
	     .arg = "Q",
	     .help = "quantizer of the stills (default {default})"},
	    {.name = "preset",
	     .kind = BC_OPT_STRING,
	     .dst = &preset,
	     .arg = "P",
	     .help =
	         "libx264 preset (default " BC_VIDEO_DEFAULT_X264_PRESET ")"},
	    {.name = "backend",
	     .kind = BC_OPT_ENUM,
	     .dst = &backend,
	     .names = backends,
	     .arg = "B",
	     .help = "H.264 encoder: {choices} (default x264; nvenc on an "
	             "NVIDIA GPU)"},
	    {.name = "quick",
	     .kind = BC_OPT_FLAG,
	     .dst = &quick,
	     .help = "1280x720 only"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args args = {.prog = "bench_video",
	                       .usage = "bench_video [options]",
	                       .opts = opts_table};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam0;
	struct bc_errinfo ei = {0};
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (args.npos) {
		return bc_args_error(&args, "unexpected argument '%s'",
		                     args.pos[0]);
	}
	if (!t || bc_gen("fig18",
	                 &(struct bc_gen_opts){.count = 1024,
	                                       .kind = BC_GEN_KIND_SPHERES,
	                                       .blend = BC_GEN_BLEND_SMOOTH},
	                 t, &cam0, &ei)) {
		die("fig18", ei.msg);
	}
	printf("fig18 smooth spheres 1024, an orbit of %u frames, %.1f "
	       "degrees a frame; render: tiled, %u thread(s); H.264: %s "
	       "(libx264: preset %s, %u thread(s), zerolatency); times per "
	       "frame, ms (CPU of the process, then wall)\n",
	       nframes, (double)step, threads,
	       backend == BC_VIDEO_BACKEND_X264    ? "x264"
	       : backend == BC_VIDEO_BACKEND_NVENC ? "nvenc"
	                                           : "auto",
	       preset, enc_threads);
	for (size_t s = quick ? 1 : 0; s < 2; s++) {
		uint32_t w = sizes[s][0], h = sizes[s][1];
		uint8_t *frames[MAX_FRAMES];
		struct bc_frame f = {0};
		double rcpu = 0.0, rwall = 0.0;
		struct bc_video_opts vo = {.x264_preset = preset,
		                           .threads = enc_threads,
		                           .still_qp = (int)still_qp,
		                           .backend =
		                               (enum bc_video_backend)backend};
		struct run jpeg, still, still444;
		if (bc_frame_init(&f, w, h)) {
			die("frame", "out of memory");
		}
		for (uint32_t i = 0; i < nframes; i++) {
			float a = (float)i * step * 3.14159265f / 180.0f;
			float dx = cam0.eye[0] - cam0.target[0];
			float dz = cam0.eye[2] - cam0.target[2];
			struct bc_camera cam = cam0;
			struct bc_render_stats st;
			double c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
			double w0 = clock_ms(CLOCK_MONOTONIC);
			cam.eye[0] =
			    cam0.target[0] + dx * cosf(a) - dz * sinf(a);
			cam.eye[2] =
			    cam0.target[2] + dx * sinf(a) + dz * cosf(a);
			if (bc_render_once(
			        BC_BACKEND_TILED,
			        &(struct bc_render_opts){.threads = threads}, t,
			        &cam, &f, &st, &ei)) {
				die("render", ei.msg);
			}
			rcpu += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
			rwall += clock_ms(CLOCK_MONOTONIC) - w0;
			frames[i] = malloc((size_t)w * h * 4u);
			if (!frames[i]) {
				die("frame", "out of memory");
			}
			memcpy(frames[i], f.rgba, (size_t)w * h * 4u);
		}
		printf("\n%ux%u: render %.1f ms CPU (%.1f wall) per frame\n", w,
		       h, rcpu / nframes, rwall / nframes);
		printf("  %-22s %8s %8s %7s | %10s %9s | %6s %6s | %7s\n",
		       "codec", "enc-cpu", "enc-wall", "dec-cpu", "bytes/fr",
		       "IDR", "dB", "min", "jpeg/x");
		jpeg = run_jpeg(frames, nframes, w, h);
		print_row("JPEG q80 4:2:0", &jpeg, jpeg.bytes);
		for (size_t b = 0; b < sizeof(bitrates) / sizeof(bitrates[0]);
		     b++) {
			char label[40];
			struct run r;
			vo.bitrate = bitrates[b];
			r = run_h264(frames, nframes, w, h, &vo, false);
			snprintf(label, sizeof(label), "H.264 %u Mbit/s",
			         bitrates[b] / 1000000u);
			print_row(label, &r, jpeg.bytes);
		}
		vo.bitrate = 0;
		still = run_h264(frames, nframes, w, h, &vo, true);
		vo.still_444 = true;
		still444 = run_h264(frames, nframes, w, h, &vo, true);
		vo.still_444 = false;
		printf("  still (IDR, QP %d): 4:2:0 %.1f ms CPU, %zu bytes, "
		       "%.2f dB; 4:4:4 %.1f ms CPU, %zu bytes, %.2f dB; the "
		       "4:2:0 conversion alone: %.2f dB\n",
		       (int)still_qp, still.cpu_ms, still.first_bytes,
		       still.db_mean, still444.cpu_ms, still444.first_bytes,
		       still444.db_mean, floor_420(frames, nframes, w, h, &vo));
		fflush(stdout);
		for (uint32_t i = 0; i < nframes; i++) {
			free(frames[i]);
		}
		bc_frame_finish(&f);
	}
	bc_tree_destroy(t);
	return 0;
}
