/*
 * The client side of the WAN bench (bench/wan/run.sh): joins a session,
 * orbits the camera at a fixed rate for a while without waiting for
 * frames, as a person dragging does, and measures what reaches it: frames
 * per second delivered, camera-to-decoded-frame latency (from each CAMERA
 * sent to the first frame that shows it or a later camera, once the
 * client has decoded it), bytes per frame, the time to decode, how long
 * the still takes once the motion stops, and the PSNR of decoded frames
 * (a few moving ones, and the still) against PNG (lossless) snapshots of the
 * same cameras, asked for after the orbit. JPEG frames decode through
 * libblobcast, H.264 ones through libavcodec. One JSON line.
 *
 * usage: bench_wan_client ADDR SESSION WxH SECONDS RATE_HZ [QUALITY
 *                         [DOWNSCALE [jpeg|h264|h264-png]]]
 * (h264-png: H.264 moving frames and a PNG still)
 * (the token, when the daemon wants one, in BLOBCAST_TOKEN; a JSON scene
 * to load into the session first, in BC_WAN_SCENE)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/clock.h"
#include "blobcast/scene.h"
#include "blobcast/video.h"

#define MAX_SENT 65536u
/* Moving frames kept to compare with snapshots of their cameras. */
#define SAMPLES 6u
#define SAMPLE_EVERY 20u

/* A decoded picture and the camera it shows. */
struct sample {
	uint8_t *rgba; /* w * h * 4 */
	struct bc_camera cam;
	uint8_t level;
};

/* PSNR over RGB of two w x h RGBA pictures. */
static double psnr(const uint8_t *a, const uint8_t *b, uint32_t w, uint32_t h)
{
	double se = 0.0;
	for (size_t i = 0; i < (size_t)w * h; i++) {
		for (int k = 0; k < 3; k++) {
			double d = (double)a[i * 4 + k] - (double)b[i * 4 + k];
			se += d * d;
		}
	}
	return se == 0.0 ? 99.0
	                 : 10.0 * log10(255.0 * 255.0 * 3.0 * (double)w *
	                                (double)h / se);
}

/* What a frame decodes to, the client's way for its encoding. */
struct decoder {
	struct bc_client_image img;
	struct bc_video_decoder *video;
	uint32_t w, h;
	const uint8_t *px; /* the last picture, w * h RGBA, rows w * 4 */
	uint8_t *copy;     /* an H.264 picture with its rows packed */
	double ms;         /* decoding time, all frames */
};

/* Decodes FRAME m; a coarse level's picture is scaled up (each block
 * takes its pixel) so that every picture is w x h. Returns 0 or an
 * error. */
static int decode(struct decoder *d, const struct bc_msg *m,
                  struct bc_errinfo *ei)
{
	double t0 = bc_clock_ms();
	int rc;
	if (m->frame.encoding == BC_PROTO_ENC_H264) {
		const uint8_t *px;
		size_t stride;
		rc = bc_video_decode(d->video, m->frame.rects[0].data.ptr,
		                     m->frame.rects[0].data.len, d->w, d->h,
		                     &px, &stride, ei);
		for (uint32_t y = 0; rc == 0 && y < d->h; y++) {
			memcpy(d->copy + (size_t)y * d->w * 4u,
			       px + (size_t)y * stride, (size_t)d->w * 4u);
		}
	} else {
		uint32_t l = bc_proto_flags_level(m->flags);
		rc = bc_client_image_apply(&d->img, m, ei);
		for (uint32_t y = 0; rc == 0 && y < d->h; y++) {
			for (uint32_t x = 0; x < d->w; x++) {
				memcpy(d->copy + ((size_t)y * d->w + x) * 4u,
				       d->img.rgba +
				           ((size_t)(y >> l) * d->img.width +
				            (x >> l)) *
				               4u,
				       4);
			}
		}
	}
	d->px = d->copy;
	d->ms += bc_clock_ms() - t0;
	return rc;
}

static int cmp_double(const void *x, const void *y)
{
	double a = *(const double *)x, b = *(const double *)y;
	return (a > b) - (a < b);
}

static double pct(const double *v, uint32_t n, double p)
{
	double rank = ceil(p / 100.0 * (double)n);
	uint32_t k = rank < 1.0 ? 0u : (uint32_t)rank - 1u;
	return n ? v[k < n ? k : n - 1] : 0.0;
}

static void die(const char *what, const struct bc_errinfo *ei)
{
	fprintf(stderr, "bench_wan_client: %s: %s\n", what, ei ? ei->msg : "");
	exit(1);
}

/* The orbit's camera at angle a around the session camera's target, at
 * its distance and height. */
static void orbit(const struct bc_camera *home, double a, struct bc_camera *c)
{
	float dx = home->eye[0] - home->target[0];
	float dz = home->eye[2] - home->target[2];
	double r = sqrt((double)(dx * dx + dz * dz));
	double a0 = atan2((double)dz, (double)dx);
	*c = *home;
	c->eye[0] = home->target[0] + (float)(r * cos(a0 + a));
	c->eye[2] = home->target[2] + (float)(r * sin(a0 + a));
}

int main(int argc, char **argv)
{
	struct bc_client_opts o = {0};
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_camera home, cam;
	struct bc_msg m;
	uint32_t w, h, seq, quality = 80, downscale = 1;
	double seconds, rate, *sent, *lat, t0, next, end, still_ms = -1.0;
	uint32_t nlat = 0, ncam = 0, frames = 0, coarse = 0, last_seq = 0;
	uint32_t nsamples = 0, keys = 0;
	uint64_t bytes = 0;
	struct bc_proto_link link = {0};
	struct bc_msg_stats st = {0};
	struct bc_camera *cams;
	struct sample samples[SAMPLES];
	struct decoder dec = {0};
	enum bc_proto_encoding enc = BC_PROTO_ENC_JPEG, still_enc = 0;
	double psnr_moving = 0.0, psnr_still = 0.0;
	const char *scene = getenv("BC_WAN_SCENE");
	if (argc < 6 || sscanf(argv[3], "%ux%u", &w, &h) != 2) {
		fprintf(stderr, "usage: bench_wan_client ADDR SESSION WxH "
		                "SECONDS RATE_HZ [QUALITY [DOWNSCALE "
		                "[jpeg|h264|h264-png]]]\n");
		return 2;
	}
	if (argc > 8 && strncmp(argv[8], "h264", 4) == 0) {
		enc = BC_PROTO_ENC_H264;
		still_enc =
		    strcmp(argv[8], "h264-png") == 0 ? BC_PROTO_ENC_PNG : 0;
		o.encodings = BC_PROTO_ENCODINGS_ALL;
	}
	seconds = atof(argv[4]);
	rate = atof(argv[5]);
	if (argc > 6) {
		quality = (uint32_t)atoi(argv[6]);
	}
	if (argc > 7) {
		downscale = (uint32_t)atoi(argv[7]);
	}
	sent = bc_calloc(MAX_SENT, sizeof(*sent));
	lat = bc_calloc(MAX_SENT, sizeof(*lat));
	cams = bc_calloc(MAX_SENT, sizeof(*cams));
	dec.w = w;
	dec.h = h;
	dec.copy = bc_malloc((size_t)w * h * 4u);
	if (!sent || !lat || !cams || !dec.copy || rate <= 0.0 ||
	    seconds <= 0.0) {
		die("arguments", NULL);
	}
	bc_client_image_init(&dec.img);
	if (enc == BC_PROTO_ENC_H264 &&
	    bc_video_decoder_open(NULL, &dec.video, &ei)) {
		die("decoder", &ei);
	}
	o.addr = argv[1];
	o.name = "wan-bench";
	o.token = getenv("BLOBCAST_TOKEN");
	if (bc_client_connect(&c, &o, &ei)) {
		die("connect", &ei);
	}
	if (bc_client_join(c, argv[2], BC_PROTO_ROLE_EDITOR, BC_CLIENT_JOIN_ANY,
	                   &ei)) {
		die("join", &ei);
	}
	if (scene && *scene &&
	    bc_client_load_scene_file(c, scene, NULL, NULL, &ei)) {
		die("load", &ei);
	}
	if (!bc_client_scene(c, &home)) {
		die("no scene", NULL);
	}
	if (bc_client_view(
	        c,
	        &(struct bc_msg_view){.width = (uint16_t)w,
	                              .height = (uint16_t)h,
	                              .encoding = enc,
	                              .still_encoding = still_enc,
	                              .quality_interactive = (uint8_t)quality,
	                              .quality_still = 90,
	                              .downscale = (uint8_t)downscale},
	        &seq, &ei) ||
	    bc_client_wait(c, BC_MSG_FRAME, 0, &m, 30000, &ei) ||
	    decode(&dec, &m, &ei)) {
		die("first frame", &ei);
	}
	t0 = bc_clock_ms();
	next = t0;
	end = t0 + seconds * 1000.0;
	while (bc_clock_ms() < end) {
		double now = bc_clock_ms();
		int rc;
		if (now >= next) {
			orbit(&home, (double)ncam * 0.02, &cam);
			if (bc_client_camera(c, &cam, true, &seq, &ei)) {
				die("camera", &ei);
			}
			if (seq < MAX_SENT) {
				sent[seq] = bc_clock_ms();
				cams[seq] = cam;
			}
			last_seq = seq;
			ncam++;
			next += 1000.0 / rate;
			continue;
		}
		rc = bc_client_recv(c, &m, (int)(next - now) + 1);
		if (rc < 0) {
			bc_client_error(c, &ei);
			die("receive", &ei);
		}
		if (rc == 1 && m.type == BC_MSG_FRAME) {
			uint32_t cs = m.frame.camera_seq;
			frames++;
			bytes += bc_client_info(c)->last_msg_bytes;
			if (bc_proto_flags_level(m.flags) > 0) {
				coarse++;
			}
			keys += (m.flags & BC_PROTO_FLAG_KEY) ? 1u : 0u;
			if (decode(&dec, &m, &ei)) {
				die("decode", &ei);
			}
			if (frames % SAMPLE_EVERY == 0 && nsamples < SAMPLES &&
			    cs && cs < MAX_SENT && sent[cs] > 0.0 &&
			    (samples[nsamples].rgba =
			         bc_malloc((size_t)w * h * 4u))) {
				memcpy(samples[nsamples].rgba, dec.px,
				       (size_t)w * h * 4u);
				samples[nsamples].cam = cams[cs];
				samples[nsamples].level =
				    (uint8_t)bc_proto_flags_level(m.flags);
				nsamples++;
			}
			if (cs && cs < MAX_SENT && sent[cs] > 0.0 &&
			    nlat < MAX_SENT) {
				lat[nlat++] = bc_clock_ms() - sent[cs];
			}
		} else if (rc == 1 && m.type == BC_MSG_ERROR) {
			fprintf(stderr, "bench_wan_client: server: %.*s\n",
			        (int)m.error.text.len, m.error.text.ptr);
		}
	}
	/* The motion stops: time to the exact still of the last camera. */
	{
		double ts = bc_clock_ms();
		orbit(&home, (double)ncam * 0.02, &cam);
		if (bc_client_camera(c, &cam, false, &seq, &ei)) {
			die("camera", &ei);
		}
		while (bc_clock_ms() - ts < 60000.0) {
			int rc = bc_client_recv(c, &m, 1000);
			if (rc < 0) {
				die("receive", NULL);
			}
			if (rc == 1 && m.type == BC_MSG_FRAME &&
			    decode(&dec, &m, &ei)) {
				die("decode", &ei);
			}
			if (rc == 1 && m.type == BC_MSG_FRAME &&
			    m.frame.camera_seq >= seq &&
			    (m.flags & BC_PROTO_FLAG_STILL)) {
				still_ms = bc_clock_ms() - ts;
				break;
			}
		}
	}
	/* The pictures against PNG (lossless) snapshots of their cameras: the
	 * still first (the camera is where the orbit stopped), then the moving
	 * frames kept. */
	{
		struct bc_client_image raw;
		bc_client_image_init(&raw);
		if (still_ms >= 0.0 &&
		    bc_client_snapshot(c, BC_PROTO_ENC_PNG, &raw, &ei) == 0) {
			psnr_still = psnr(raw.rgba, dec.px, w, h);
		}
		for (uint32_t k = 0; k < nsamples; k++) {
			if (bc_client_camera(c, &samples[k].cam, false, &seq,
			                     &ei) ||
			    bc_client_snapshot(c, BC_PROTO_ENC_PNG, &raw,
			                       &ei)) {
				die("snapshot", &ei);
			}
			psnr_moving += psnr(raw.rgba, samples[k].rgba, w, h);
			bc_free(samples[k].rgba);
		}
		psnr_moving = nsamples ? psnr_moving / nsamples : 0.0;
		bc_client_image_finish(&raw);
	}
	/* What the server's TCP measured of the path, and what it held. */
	{
		if (bc_client_stats_parts(c, BC_PROTO_STATS_LINK, &st, &ei) ==
		    0) {
			link = st.link;
		}
	}
	qsort(lat, nlat, sizeof(*lat), cmp_double);
	printf("{\"size\": \"%ux%u\", \"seconds\": %.1f, \"cameras\": %u, "
	       "\"frames\": %u, \"coarse_frames\": %u, "
	       "\"delivered_fps\": %.2f, \"bytes_per_frame\": %.0f, "
	       "\"latency_p50_ms\": %.1f, \"latency_p99_ms\": %.1f, "
	       "\"latency_max_ms\": %.1f, \"still_ms\": %.1f, "
	       "\"last_camera_seq\": %u, \"server_rtt_ms\": %.1f, "
	       "\"server_delivery_mbit\": %.2f, \"frames_paced\": %u, "
	       "\"frames_spoiled\": %llu, \"encoding\": \"%s\", "
	       "\"key_frames\": %u, \"decode_ms\": %.2f, "
	       "\"psnr_moving_db\": %.1f, \"moving_samples\": %u, "
	       "\"psnr_still_db\": %.1f, \"render_ms\": %.1f, "
	       "\"encode_ms\": %.1f}\n",
	       w, h, seconds, ncam, frames, coarse, (double)frames / seconds,
	       frames ? (double)bytes / (double)frames : 0.0,
	       pct(lat, nlat, 50.0), pct(lat, nlat, 99.0),
	       nlat ? lat[nlat - 1] : 0.0, still_ms, last_seq,
	       (double)link.rtt_us / 1e3, (double)link.delivery_bps * 8.0 / 1e6,
	       link.frames_paced, (unsigned long long)link.frames_spoiled,
	       argc > 8 ? argv[8] : "jpeg", keys,
	       frames ? dec.ms / frames : 0.0, psnr_moving, nsamples,
	       psnr_still, (double)st.render_ms_avg, (double)st.encode_ms_avg);
	bc_client_image_finish(&dec.img);
	bc_video_decoder_destroy(dec.video);
	bc_free(dec.copy);
	bc_free(cams);
	bc_client_destroy(c);
	bc_free(sent);
	bc_free(lat);
	return 0;
}
