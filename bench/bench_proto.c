/*
 * Protocol codec throughput, measured side by side in one run:
 *  - FRAME with one 1 MB rectangle (the interactive stream's big messages),
 *    and with 64 rectangles of 16 KB (damaged tiles);
 *  - SCENE_LOAD framing a synthesized 10^6-node scene (about 39 MB), and
 *    the structural scan of those scene bytes;
 *  - small messages (CAMERA, a one-field EDIT), in messages per second.
 * Encode appends to a bc_proto_buf (copying the payload and checking the
 * result with the decoder, as the daemon does); decode is feed() plus
 * next() on a reader (copying into the reader's buffer, as from a socket),
 * and the payload decoder alone (zero copy). Each figure is the best of
 * five timed runs of at least 0.2 s. Usage: bench_proto [--quick]
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/clock.h"
#include "blobcast/proto.h"

static double now_s(void)
{
	return (double)bc_clock_ns() * 1e-9;
}

static double min_time = 0.2;
static int runs = 5;

/* Keeps the optimizer from dropping work whose result is unused. */
static volatile uint64_t sink;

struct job {
	const char *name;
	size_t bytes; /* bytes per iteration (whole messages) */
	int msgs;     /* messages per iteration */
	void (*fn)(void *ctx);
	void *ctx;
};

/* Returns the best seconds per iteration. */
static double measure(const struct job *j)
{
	double best = 1e30;
	for (int r = 0; r < runs; r++) {
		long n = 0;
		double t0 = now_s(), t;
		do {
			j->fn(j->ctx);
			n++;
			t = now_s() - t0;
		} while (t < min_time);
		if (t / (double)n < best) {
			best = t / (double)n;
		}
	}
	return best;
}

/* bytes == 0: the work does not depend on the bytes (zero copy), so a
 * throughput in MB/s would mean nothing; only the message rate is shown. */
static void report(const struct job *j)
{
	double s = measure(j);
	if (j->bytes) {
		printf("%-58s %9.1f MB/s %12.0f msg/s %10.4f ms\n", j->name,
		       (double)j->bytes / s / 1e6, (double)j->msgs / s,
		       s * 1e3);
	} else {
		printf("%-58s %9s      %12.0f msg/s %10.4f ms\n", j->name, "-",
		       (double)j->msgs / s, s * 1e3);
	}
}

/* ---- Contexts --------------------------------------------------------------
 */

struct codec_ctx {
	struct bc_msg msg;       /* to encode */
	struct bc_proto_buf out; /* encode target */
	const uint8_t *wire;     /* one encoded message */
	size_t wire_len;
	struct bc_proto_reader rd;
	int count; /* messages per iteration */
};

static void do_encode(void *p)
{
	struct codec_ctx *c = p;
	bc_proto_buf_reset(&c->out);
	for (int i = 0; i < c->count; i++) {
		if (bc_proto_encode(&c->out, &c->msg, NULL) != 0) {
			abort();
		}
	}
	sink += c->out.len;
}

static void do_decode_reader(void *p)
{
	struct codec_ctx *c = p;
	struct bc_msg m;
	for (int i = 0; i < c->count; i++) {
		if (bc_proto_reader_feed(&c->rd, c->wire, c->wire_len) != 0 ||
		    bc_proto_reader_next(&c->rd, &m) != 1) {
			abort();
		}
		sink += m.seq;
	}
}

static void do_decode_payload(void *p)
{
	struct codec_ctx *c = p;
	struct bc_msg m;
	for (int i = 0; i < c->count; i++) {
		if (bc_proto_decode_payload(
		        &c->rd, c->msg.type, c->msg.flags, c->msg.seq,
		        c->wire + BC_PROTO_HEADER_SIZE,
		        c->wire_len - BC_PROTO_HEADER_SIZE, &m, NULL) != 0) {
			abort();
		}
		sink += m.seq;
	}
}

struct scan_ctx {
	const uint8_t *bytes;
	size_t len;
};

static void do_scan(void *p)
{
	struct scan_ctx *c = p;
	struct bc_proto_scene_info info;
	if (bc_proto_scene_scan(c->bytes, c->len, &info, NULL) != 0) {
		abort();
	}
	sink += info.nodes;
}

/* Encodes c->msg once into wire storage and sets up the reader. */
static void prepare(struct codec_ctx *c, struct bc_proto_buf *wire)
{
	bc_proto_buf_init(&c->out, 0);
	bc_proto_buf_init(wire, 0);
	if (bc_proto_encode(wire, &c->msg, NULL) != 0) {
		fprintf(stderr, "bench: sample does not encode\n");
		exit(1);
	}
	c->wire = wire->data;
	c->wire_len = wire->len;
	bc_proto_reader_init(&c->rd, NULL);
}

static void run_codec(const char *what, struct codec_ctx *c)
{
	char name[96];
	size_t bytes = c->wire_len * (size_t)c->count;
	snprintf(name, sizeof(name), "%s encode", what);
	report(&(struct job){name, bytes, c->count, do_encode, c});
	snprintf(name, sizeof(name), "%s decode (reader)", what);
	report(&(struct job){name, bytes, c->count, do_decode_reader, c});
	/* Bulk payloads are not touched by their decoder (byte ranges point
	 * into the input), small ones are read field by field. */
	bool bulk =
	    c->msg.type == BC_MSG_FRAME || c->msg.type == BC_MSG_SCENE_LOAD;
	snprintf(name, sizeof(name), "%s decode (payload%s)", what,
	         bulk ? ", zero copy" : "");
	report(&(struct job){name, bulk ? 0 : bytes, c->count,
	                     do_decode_payload, c});
}

static void finish(struct codec_ctx *c, struct bc_proto_buf *wire)
{
	bc_proto_reader_finish(&c->rd);
	bc_proto_buf_finish(&c->out);
	bc_proto_buf_finish(wire);
}

/* ---- Scene synthesis ------------------------------------------------------
 */

static uint64_t rng = 88172645463325252u;
static uint32_t rnd(uint32_t n)
{
	rng ^= rng << 13;
	rng ^= rng >> 7;
	rng ^= rng << 17;
	return (uint32_t)(rng % n);
}

/* A balanced tree of n nodes (n != 2): binary smooth unions over spheres,
 * boxes and capsules, half of them coloured. Returns 0 or an error. */
static int write_tree(struct bc_proto_buf *b, uint32_t n, uint32_t *next_id)
{
	static const float t[3] = {0.5f, 1.0f, -2.0f}, q[4] = {0, 0, 0, 1};
	static const float col[3] = {0.8f, 0.4f, 0.2f};
	static const float p[7] = {1.0f, 0.5f, 0.5f, 0.1f, 0.0f, 1.0f, 0.2f};
	static const uint8_t kinds[3] = {1, 2, 3}, np[3] = {1, 4, 7};
	if (n == 1) {
		uint32_t k = rnd(3);
		return bc_proto_scene_prim(b, kinds[k], (*next_id)++, t, q,
		                           rnd(2) ? col : NULL, np[k], p);
	}
	uint32_t a = (n - 1) / 2, c = n - 1 - a;
	uint32_t k = 2;
	if (a == 2 || c == 2) { /* 1 + 2 or 2 + 2: three or four leaves */
		k = n - 1;
	}
	int rc = bc_proto_scene_op(b, 4, (*next_id)++, 0.1f, 0.2f, k);
	if (k != 2) {
		for (uint32_t i = 0; rc == 0 && i < k; i++) {
			rc = write_tree(b, 1, next_id);
		}
		return rc;
	}
	if (rc == 0) {
		rc = write_tree(b, a, next_id);
	}
	return rc ? rc : write_tree(b, c, next_id);
}

int main(int argc, char **argv)
{
	if (argc > 1 && strcmp(argv[1], "--quick") == 0) {
		min_time = 0.05;
		runs = 2;
	}
	printf("%-58s %14s %18s %13s\n", "case", "throughput", "messages",
	       "per iteration");

	/* FRAME, one 1 MB rectangle. */
	static struct bc_proto_rect rects[64];
	size_t big = 1u << 20;
	uint8_t *jpeg = malloc(big);
	for (size_t i = 0; i < big; i++) {
		jpeg[i] = (uint8_t)rnd(256);
	}
	struct codec_ctx c = {.count = 1};
	struct bc_proto_buf wire;
	rects[0] =
	    (struct bc_proto_rect){0, 0, 1920, 1080, {jpeg, (uint32_t)big}};
	c.msg = (struct bc_msg){.type = BC_MSG_FRAME};
	c.msg.frame = (struct bc_msg_frame){
	    1, 2, 3, BC_PROTO_ENC_JPEG, 1920, 1080, 1920, 1080, 1, rects};
	prepare(&c, &wire);
	run_codec("FRAME 1 rect x 1 MB", &c);
	finish(&c, &wire);

	/* FRAME, 64 damaged tiles of 16 KB. */
	for (int i = 0; i < 64; i++) {
		rects[i] =
		    (struct bc_proto_rect){(uint16_t)(64 * (i % 16)),
		                           (uint16_t)(64 * (i / 16)),
		                           64,
		                           64,
		                           {jpeg + 16384 * (size_t)i, 16384}};
	}
	c = (struct codec_ctx){.count = 1};
	c.msg = (struct bc_msg){.type = BC_MSG_FRAME};
	c.msg.frame = (struct bc_msg_frame){
	    1, 2, 3, BC_PROTO_ENC_JPEG, 1920, 1080, 1920, 1080, 64, rects};
	prepare(&c, &wire);
	run_codec("FRAME 64 rects x 16 KB", &c);
	finish(&c, &wire);

	/* SCENE_LOAD of 10^6 nodes. */
	struct bc_proto_buf scene;
	uint32_t id = 1;
	bc_proto_buf_init(&scene, 0);
	if (bc_proto_scene_begin(&scene, NULL, 1000000) != 0 ||
	    write_tree(&scene, 1000000, &id) != 0) {
		fprintf(stderr, "bench: scene synthesis failed\n");
		return 1;
	}
	struct bc_proto_scene_info info;
	if (bc_proto_scene_scan(scene.data, scene.len, &info, NULL) != 0) {
		fprintf(stderr, "bench: synthesized scene does not scan\n");
		return 1;
	}
	printf("(scene: %u nodes, %u primitives, %u operators, depth %u, "
	       "%zu bytes)\n",
	       info.nodes, info.prims, info.ops, info.depth, scene.len);
	c = (struct codec_ctx){.count = 1};
	c.msg = (struct bc_msg){.type = BC_MSG_SCENE_LOAD};
	c.msg.scene_load.scene =
	    (struct bc_proto_bytes){scene.data, (uint32_t)scene.len};
	prepare(&c, &wire);
	char what[64];
	snprintf(what, sizeof(what), "SCENE_LOAD 1e6 nodes (%.1f MB)",
	         (double)scene.len / 1e6);
	run_codec(what, &c);
	finish(&c, &wire);
	struct scan_ctx sc = {scene.data, scene.len};
	report(
	    &(struct job){"scene scan 1e6 nodes", scene.len, 1, do_scan, &sc});
	bc_proto_buf_finish(&scene);

	/* Small messages, 1000 per iteration. */
	c = (struct codec_ctx){.count = 1000};
	c.msg = (struct bc_msg){.type = BC_MSG_CAMERA, .seq = 9};
	c.msg.camera =
	    (struct bc_msg_camera){{1, 2, 6}, {0, 0, 0}, {0, 1, 0}, 45.0f};
	prepare(&c, &wire);
	run_codec("CAMERA x 1000", &c);
	finish(&c, &wire);

	static const struct bc_proto_field f = {1, 3, {0.5f, 0.0f, -2.0f, 0}};
	static const struct bc_proto_edit_op op = {
	    .kind = BC_PROTO_EDIT_SET, .node = 7, .nfields = 1, .fields = &f};
	c = (struct codec_ctx){.count = 1000};
	c.msg = (struct bc_msg){.type = BC_MSG_EDIT, .seq = 9};
	c.msg.edit = (struct bc_msg_edit){1, &op};
	prepare(&c, &wire);
	run_codec("EDIT set translate x 1000", &c);
	finish(&c, &wire);

	free(jpeg);
	return sink == 42 ? 2 : 0;
}
