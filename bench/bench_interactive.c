/*
 * What a person waits for, through blobcastd's Unix socket with the raw
 * protocol, at 1024x768 JPEG on fig18 1024 smooth spheres (CPU backend):
 *  - drag: one sphere moved by INTERACTING edits, each waiting for the
 *    FRAME that reflects it: edit -> frame p50 / p99, bytes and rectangles
 *    per frame; the same daemon binary with --no-damage (edits re-render
 *    the whole view) beside it, for the ratio;
 *  - orbit: INTERACTING cameras around the scene, each sent when the frame
 *    of the previous one arrived: camera -> first (coarse) frame p50 / p99,
 *    the levels seen, and frames per second while orbiting.
 *
 * Usage: bench_interactive PATH/TO/blobcastd [edits] [cameras] [spheres]
 * (spheres: fig18's count, default 1024; a large scene loads for a while
 * before the drag starts, and above 4096 the no-damage run is left out)
 */
#include <math.h>
#include <stdint.h>

#include "../tests/server/daemon.h"
#include "blobcast/alloc.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "latency.h"

#define W 1024u
#define H 768u

static struct bc_camera scene_cam;
static uint32_t spheres = 1024;
static struct bc_prim_data original;

static void send_view(struct conn *c)
{
	struct bc_msg v = {.type = BC_MSG_VIEW};
	v.view.width = W;
	v.view.height = H;
	v.view.encoding = BC_PROTO_ENC_JPEG;
	v.view.quality_interactive = 70;
	v.view.quality_still = 90;
	v.view.downscale = 8;
	conn_send(c, &v);
}

static void send_camera(struct conn *c, const struct bc_camera *cam,
                        bool interacting)
{
	struct bc_msg m = {.type = BC_MSG_CAMERA};
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	memcpy(m.camera.eye, cam->eye, sizeof(cam->eye));
	memcpy(m.camera.target, cam->target, sizeof(cam->target));
	memcpy(m.camera.up, cam->up, sizeof(cam->up));
	m.camera.fov_y_deg = cam->fov_y_deg;
	conn_send(c, &m);
}

/* Reads frames until the still of the current state. */
static int settle(struct conn *c)
{
	while (conn_recv(c, 60000) == 1) {
		if (c->m.type == BC_MSG_FRAME &&
		    (c->m.flags & BC_PROTO_FLAG_STILL)) {
			return 0;
		}
	}
	return -1;
}

static void drag(struct conn *c, uint32_t id, int edits, const char *label)
{
	float dx[25];
	struct latency l;
	for (int i = 0; i < 25; i++) {
		dx[i] = 0.004f * (float)i;
	}
	latency_edits(c, id, &original, dx, 25, edits, true, &l);
	if (l.n) {
		printf(
		    "drag %-10s edits=%d p50_ms=%lld p99_ms=%lld "
		    "max_ms=%lld bytes_per_frame=%.0f rects_per_frame=%.1f\n",
		    label, l.n, (long long)l.p50, (long long)l.p99,
		    (long long)l.max, l.bytes, l.rects);
	}
}

static void orbit(struct conn *c, int cameras)
{
	int64_t *lat = bc_calloc((size_t)cameras, sizeof(int64_t));
	int64_t t_start = t_now_ms();
	int levels[4] = {0};
	int got = 0;
	float dx = scene_cam.eye[0] - scene_cam.target[0];
	float dz = scene_cam.eye[2] - scene_cam.target[2];
	float r = sqrtf(dx * dx + dz * dz), a0 = atan2f(dz, dx);
	for (int i = 0; i < cameras; i++) {
		struct bc_camera cam = scene_cam;
		float a = a0 + 0.02f * (float)(i + 1);
		int64_t t0 = t_now_ms();
		cam.eye[0] = scene_cam.target[0] + r * cosf(a);
		cam.eye[2] = scene_cam.target[2] + r * sinf(a);
		send_camera(c, &cam, true);
		/* The first frame that reflects this camera. */
		while (conn_recv(c, 30000) == 1) {
			if (c->m.type == BC_MSG_FRAME) {
				levels[bc_proto_flags_level(c->m.flags)]++;
				if (c->m.frame.camera_seq == c->seq) {
					lat[got++] = t_now_ms() - t0;
					break;
				}
			}
		}
	}
	qsort(lat, (size_t)got, sizeof(int64_t), latency_cmp_i64);
	if (got) {
		double secs = (double)(t_now_ms() - t_start) / 1000.0;
		printf("orbit cameras=%d first_frame_p50_ms=%lld p99_ms=%lld "
		       "frames_per_second=%.1f levels_seen=%d/%d/%d/%d "
		       "(0/1/2/3)\n",
		       got, (long long)lat[got / 2],
		       (long long)lat[(got * 99) / 100], (double)got / secs,
		       levels[0], levels[1], levels[2], levels[3]);
	}
	bc_free(lat);
}

static int run(const char *label, const char *const *opts, int edits,
               int cameras)
{
	struct daemon d;
	struct conn c;
	uint32_t id;
	char dir[64];
	snprintf(dir, sizeof(dir), "/tmp/bc-bench-i-%d-%s", (int)getpid(),
	         label);
	if (daemon_start_with(&d, dir, opts) != 0) {
		fprintf(stderr, "cannot start %s\n", daemon_path);
		return 1;
	}
	if (conn_open(&c, &d) || conn_hello(&c, "bench") ||
	    conn_join(&c, "bench", BC_PROTO_ROLE_EDITOR, true) ||
	    latency_load_fig18(&c, spheres, &id, &original, &scene_cam)) {
		fprintf(stderr, "scene load failed\n");
		daemon_stop(&d, SIGTERM);
		return 1;
	}
	send_view(&c);
	if (settle(&c)) {
		fprintf(stderr, "no still frame\n");
	}
	drag(&c, id, 3, "warm-up");
	drag(&c, id, edits, label);
	if (cameras > 0) {
		settle(&c);
		orbit(&c, cameras);
	}
	conn_close(&c);
	daemon_stop(&d, SIGTERM);
	{
		char cmd[160];
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock", dir, dir);
		if (system(cmd) != 0) {
			return 1;
		}
	}
	return 0;
}

int main(int argc, char **argv)
{
	static const char *const no_damage[] = {"--no-damage", NULL};
	int edits = argc > 2 ? atoi(argv[2]) : 100;
	int cameras = argc > 3 ? atoi(argv[3]) : 60;
	if (argc < 2) {
		fprintf(stderr, "usage: bench_interactive PATH/TO/blobcastd "
		                "[edits] [cameras] [spheres]\n");
		return 2;
	}
	if (argc > 4) {
		spheres = (uint32_t)atoi(argv[4]);
	}
	daemon_path = argv[1];
	signal(SIGPIPE, SIG_IGN);
	(void)conn_view;
	(void)daemon_start;
	/* A large scene's whole frames take seconds each: the no-damage
	 * run is the small scene's comparison only. */
	if (run("damage", NULL, edits, cameras) ||
	    (spheres <= 4096 && run("no-damage", no_damage, edits, 0))) {
		return 1;
	}
	return 0;
}
