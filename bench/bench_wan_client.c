/*
 * The client side of the WAN bench (bench/wan/run.sh): joins a session,
 * orbits the camera at a fixed rate for a while without waiting for
 * frames, as a person dragging does, and measures what reaches it: frames
 * per second delivered, camera-to-frame latency (from each CAMERA sent to
 * the first frame that shows it or a later camera), bytes per frame, and
 * how long the exact still takes once the motion stops. One JSON line.
 *
 * usage: bench_wan_client ADDR SESSION WxH SECONDS RATE_HZ [QUALITY
 *                         [DOWNSCALE]]
 * (the token, when the daemon wants one, in BLOBCAST_TOKEN)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/clock.h"
#include "blobcast/scene.h"

#define MAX_SENT 65536u

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
	uint64_t bytes = 0;
	struct bc_proto_link link = {0};
	if (argc < 6 || sscanf(argv[3], "%ux%u", &w, &h) != 2) {
		fprintf(stderr, "usage: bench_wan_client ADDR SESSION WxH "
		                "SECONDS RATE_HZ [QUALITY [DOWNSCALE]]\n");
		return 2;
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
	if (!sent || !lat || rate <= 0.0 || seconds <= 0.0) {
		die("arguments", NULL);
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
	if (!bc_client_scene(c, &home)) {
		die("no scene", NULL);
	}
	if (bc_client_view(
	        c,
	        &(struct bc_msg_view){.width = (uint16_t)w,
	                              .height = (uint16_t)h,
	                              .encoding = BC_PROTO_ENC_JPEG,
	                              .quality_interactive = (uint8_t)quality,
	                              .quality_still = 90,
	                              .downscale = (uint8_t)downscale},
	        &seq, &ei) ||
	    bc_client_wait(c, BC_MSG_FRAME, 0, &m, 30000, &ei)) {
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
			    m.frame.camera_seq >= seq &&
			    (m.flags & BC_PROTO_FLAG_STILL)) {
				still_ms = bc_clock_ms() - ts;
				break;
			}
		}
	}
	/* What the server's TCP measured of the path, and what it held. */
	{
		struct bc_msg_stats st;
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
	       "\"frames_spoiled\": %llu}\n",
	       w, h, seconds, ncam, frames, coarse, (double)frames / seconds,
	       frames ? (double)bytes / (double)frames : 0.0,
	       pct(lat, nlat, 50.0), pct(lat, nlat, 99.0),
	       nlat ? lat[nlat - 1] : 0.0, still_ms, last_seq,
	       (double)link.rtt_us / 1e3, (double)link.delivery_bps * 8.0 / 1e6,
	       link.frames_paced, (unsigned long long)link.frames_spoiled);
	bc_client_destroy(c);
	bc_free(sent);
	bc_free(lat);
	return 0;
}
