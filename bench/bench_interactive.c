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
 *  - structural (when asked): one sphere INSERTed at the end of the root
 *    union, then REMOVEd, again and again, then the same in the middle of
 *    its operands and at its start: edit -> EDIT_APPLIED and edit -> the
 *    FRAME that reflects it, p50 / p99 of each kind.
 *
 * Usage: bench_interactive PATH/TO/blobcastd [edits] [cameras] [spheres]
 *                          [structural]
 * (spheres: fig18's count, default 1024; a large scene loads for a while
 * before the drag starts, and above 4096 the no-damage run is left out;
 * structural: how many INSERT and REMOVE pairs, default 0)
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
static int structural;
static uint32_t root_id = 1, root_children; /* fig18: the root union is id 1 */
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

/* Sends op alone and waits for its EDIT_APPLIED and then the FRAME whose
 * order reflects it: the two latencies in ms, or -1 on an error. */
static int timed_edit(struct conn *c, const struct bc_proto_edit_op *op,
                      int64_t *applied_ms, int64_t *frame_ms)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	int64_t t0 = t_now_ms();
	uint64_t order = 0;
	uint32_t seq;
	m.edit.nops = 1;
	m.edit.ops = op;
	seq = conn_send(c, &m);
	for (;;) {
		int rc = conn_recv(c, 60000);
		if (rc != 1) {
			fprintf(stderr, "no answer to the edit (%s)\n",
			        rc == 0 ? "timed out" : "connection lost");
			return -1;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			fprintf(stderr, "edit refused: %.*s\n",
			        (int)c->m.error.text.len, c->m.error.text.ptr);
			return -1;
		}
		if (c->m.type == BC_MSG_EDIT_APPLIED && !order) {
			order = c->m.edit_applied.order;
			*applied_ms = t_now_ms() - t0;
		} else if (c->m.type == BC_MSG_FRAME && order &&
		           c->m.frame.order >= order) {
			*frame_ms = t_now_ms() - t0;
			return 0;
		}
	}
}

static void print_pcts(const char *what, int64_t *v, int n)
{
	qsort(v, (size_t)n, sizeof(int64_t), latency_cmp_i64);
	printf(" %s_p50_ms=%lld %s_p99_ms=%lld", what, (long long)v[n / 2],
	       what, (long long)v[(n * 99) / 100]);
}

/* The CPU time (clock ticks) process pid has used, -1 when unknown. */
static long long cpu_ticks(pid_t pid)
{
	char path[64], buf[1024], *p;
	long long ut = 0, st = 0;
	FILE *f;
	size_t n;
	snprintf(path, sizeof(path), "/proc/%d/stat", (int)pid);
	if (!(f = fopen(path, "r"))) {
		return -1;
	}
	n = fread(buf, 1, sizeof(buf) - 1, f);
	fclose(f);
	buf[n] = 0;
	/* Fields 14 and 15, after the command's closing parenthesis. */
	if (!(p = strrchr(buf, ')')) ||
	    sscanf(p + 2,
	           "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lld %lld", &ut,
	           &st) != 2) {
		return -1;
	}
	return ut + st;
}

/* Waits (at most two minutes) until the daemon's CPU time stops growing
 * for a second: a large scene's load leaves its snapshot being written
 * in the background for a while, which would be timed with the edits. */
static void wait_idle(pid_t pid)
{
	long long last = cpu_ticks(pid);
	for (int i = 0; i < 120 && last >= 0; i++) {
		long long now;
		t_sleep_ms(1000);
		now = cpu_ticks(pid);
		if (now < 0 || now - last <= 2) {
			return;
		}
		last = now;
	}
}

/* INSERT one sphere as operand `position` of the root union, then REMOVE
 * it, pairs times, each edit waiting for the frame that shows it. */
static void structure(struct conn *c, int pairs, uint32_t position,
                      const char *where)
{
	int64_t *v = bc_calloc((size_t)pairs * 4, sizeof(int64_t));
	int n = 0;
	for (int i = 0; v && i < pairs; i++) {
		static const float rot[4] = {0, 0, 0, 1};
		const float pos[3] = {0.05f * (float)(i % 7), 0.0f, 0.0f};
		const float radius = 0.1f;
		uint32_t id = 0x7F000000u + (uint32_t)i + position;
		struct bc_proto_buf b;
		struct bc_proto_edit_op ins = {.kind = BC_PROTO_EDIT_INSERT,
		                               .node = root_id,
		                               .position = position};
		struct bc_proto_edit_op rem = {.kind = BC_PROTO_EDIT_REMOVE,
		                               .node = id};
		int rc;
		bc_proto_buf_init(&b, 0);
		if (bc_proto_scene_begin(&b, NULL, 1) ||
		    bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id, pos, rot, NULL,
		                        1, &radius)) {
			bc_proto_buf_finish(&b);
			break;
		}
		ins.subtree.ptr = b.data;
		ins.subtree.len = (uint32_t)b.len;
		rc = timed_edit(c, &ins, &v[n], &v[pairs + n]);
		bc_proto_buf_finish(&b);
		if (rc ||
		    timed_edit(c, &rem, &v[2 * pairs + n], &v[3 * pairs + n])) {
			break;
		}
		n++;
	}
	if (n > 0) {
		printf("structural spheres=%u at=%s pairs=%d", spheres, where,
		       n);
		print_pcts("insert_applied", v, n);
		print_pcts("insert_frame", v + pairs, n);
		print_pcts("remove_applied", v + 2 * pairs, n);
		print_pcts("remove_frame", v + 3 * pairs, n);
		printf("\n");
	}
	bc_free(v);
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
	if (structural > 0 && strcmp(label, "damage") == 0) {
		settle(&c);
		wait_idle(d.pid);
		fprintf(stderr, "structural: timing %d pairs\n", structural);
		structure(&c, structural, root_children, "end");
		structure(&c, structural, root_children / 2, "middle");
		structure(&c, structural, 0, "start");
	}
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
		                "[edits] [cameras] [spheres] [structural]\n");
		return 2;
	}
	if (argc > 4) {
		spheres = (uint32_t)atoi(argv[4]);
	}
	if (argc > 5) {
		structural = atoi(argv[5]);
	}
	root_children = spheres;
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
