/*
 * The scene encoding at the protocol level: the writers and the structural
 * scanner agree on random trees (their counts, and the ids it visits); nesting
 * is refused exactly past BC_PROTO_SCENE_MAX_DEPTH; and a SCENE_LOAD of a
 * 10^6-node scene encodes, travels through the reader in socket-sized pieces,
 * and decodes to the same bytes, which scan to the same counts.
 */
#include <stdint.h>

#include "blobcast/alloc.h"
#include "blobcast/proto.h"
#include "test.h"

static const float T0[3] = {0.5f, -1.0f, 2.0f};
static const float R0[4] = {0.0f, 0.0f, 0.0f, 1.0f};
static const float C0[3] = {1.0f, 0.5f, 0.25f};

/* A deterministic generator (xorshift64*), so failures reproduce. */
static uint64_t rng = 0x9e3779b97f4a7c15u;
static uint32_t rnd(uint32_t n)
{
	rng ^= rng >> 12;
	rng ^= rng << 25;
	rng ^= rng >> 27;
	return (uint32_t)((rng * UINT64_C(2685821657736338717)) >> 33) % n;
}

struct counts {
	uint32_t nodes, prims, ops, depth;
};

/* Writes a subtree of exactly n nodes (n != 2) whose root is node number d
 * on its path from the scene's root, in pre-order. Returns 0 or the
 * writer's error. */
static int write_tree(struct bc_proto_buf *b, uint32_t n, uint32_t d,
                      struct counts *c, int random_shape)
{
	if (d > c->depth) {
		c->depth = d;
	}
	if (n == 1) {
		float params[8];
		uint8_t np = (uint8_t)(1 + rnd(8));
		for (int i = 0; i < np; i++) {
			params[i] = 0.1f * (float)(1 + rnd(50));
		}
		c->prims++;
		return bc_proto_scene_prim(b, (uint8_t)(1 + rnd(16)),
		                           c->nodes++ + 1, T0, R0,
		                           rnd(2) ? C0 : NULL, np, params);
	}
	/* Split n - 1 nodes among k >= 2 children, none of size 2 (an
	 * operator needs at least two children of its own): start from k
	 * parts, then turn each part of 2 into two parts of 1. */
	uint32_t sizes[8];
	uint32_t k = random_shape ? 2 + rnd(3) : 2;
	if (k > n - 1) {
		k = n - 1;
	}
	uint32_t extra = n - 1 - k;
	for (uint32_t i = 0; i < k; i++) {
		uint32_t add = i + 1 == k     ? extra
		               : random_shape ? rnd(extra + 1)
		                              : extra / (k - i);
		sizes[i] = 1 + add;
		extra -= add;
	}
	for (uint32_t i = 0, kk = k; i < kk; i++) {
		if (sizes[i] == 2) {
			sizes[i] = 1;
			sizes[k++] = 1;
		}
	}
	c->ops++;
	/* Sharp operators (kinds 1..3) carry blend = range = 0. */
	uint8_t kind = (uint8_t)(1 + rnd(6));
	float blend = kind > 3 ? 0.25f : 0.0f;
	int rc =
	    bc_proto_scene_op(b, kind, c->nodes++ + 1, blend, 2 * blend, k);
	for (uint32_t i = 0; rc == 0 && i < k; i++) {
		rc = write_tree(b, sizes[i], d + 1, c, random_shape);
	}
	return rc;
}

/* bc_proto_scene_scan_ids's visitor: checks the ids come 1, 2, ... (the
 * writer numbers nodes in the encoding's order), stopping at stop_at. */
struct id_walk {
	uint32_t next, stop_at;
	bool in_order;
};

static bool visit_id(void *ud, uint32_t id)
{
	struct id_walk *w = ud;
	w->in_order = w->in_order && id == w->next + 1;
	w->next++;
	return w->next != w->stop_at;
}

static void test_random_trees_scan_to_their_counts(void)
{
	for (int iter = 0; iter < 300; iter++) {
		struct bc_proto_buf b;
		struct counts c = {0};
		/* At most 250 nodes keeps any shape within the depth
		 * limit: each level below the root takes an operator and a
		 * sibling, so the deepest path has at most 125 nodes. */
		uint32_t n = 1 + rnd(250);
		if (n == 2) {
			n = 3;
		}
		bc_proto_buf_init(&b, 0);
		REQUIRE(bc_proto_scene_begin(
		            &b,
		            rnd(2) ? NULL
		                   : (const float[10]){0, 0, 5, 0, 0, 0, 0, 1,
		                                       0, 40},
		            n) == 0);
		REQUIRE(write_tree(&b, n, 1, &c, 1) == 0);
		REQUIRE(c.nodes == n);
		struct bc_proto_scene_info info;
		struct bc_errinfo ei = {0};
		int rc = bc_proto_scene_scan(b.data, b.len, &info, &ei);
		if (rc) {
			fprintf(stderr, "  n=%u: %s\n", n, ei.msg);
		}
		CHECK(rc == 0);
		CHECK(info.nodes == n && info.prims == c.prims &&
		      info.ops == c.ops && info.depth == c.depth);
		/* The ids, each once in the encoding's order; a visit that
		 * says stop ends the scan there. */
		{
			struct id_walk w = {0, 0, true};
			CHECK(bc_proto_scene_scan_ids(b.data, b.len, visit_id,
			                              &w, NULL) == 0);
			CHECK(w.in_order && w.next == n);
			w = (struct id_walk){0, 1 + rnd(n), true};
			CHECK(bc_proto_scene_scan_ids(b.data, b.len, visit_id,
			                              &w, NULL) == BC_ENOMEM);
			CHECK(w.in_order && w.next == w.stop_at);
		}
		/* Every proper prefix is refused, none crashes. */
		for (size_t cut = 0; cut < b.len; cut += 1 + b.len / 50) {
			CHECK(bc_proto_scene_scan(b.data, cut, NULL, NULL) < 0);
		}
		bc_proto_buf_finish(&b);
	}
}

/* A comb of `depth` nested unions, each with a sphere as second child: its
 * deepest path has depth + 1 nodes. */
static int write_comb(struct bc_proto_buf *b, uint32_t depth)
{
	static const float r[1] = {1.0f};
	int rc = bc_proto_scene_begin(b, NULL, 2 * depth + 1);
	for (uint32_t i = 0; rc == 0 && i < depth; i++) {
		rc = bc_proto_scene_op(b, 1, 0, 0.0f, 0.0f, 2);
	}
	for (uint32_t i = 0; rc == 0 && i <= depth; i++) {
		rc = bc_proto_scene_prim(b, 1, 0, T0, R0, NULL, 1, r);
	}
	return rc;
}

static void test_depth_limit(void)
{
	struct bc_proto_buf b;
	struct bc_proto_scene_info info;
	bc_proto_buf_init(&b, 0);
	/* 100 000 levels are accepted and cost no C stack. */
	REQUIRE(write_comb(&b, 100000) == 0);
	CHECK(bc_proto_scene_scan(b.data, b.len, &info, NULL) == 0);
	CHECK(info.depth == 100001);
	bc_proto_buf_reset(&b);
	REQUIRE(write_comb(&b, BC_PROTO_SCENE_MAX_DEPTH - 1) == 0);
	CHECK(bc_proto_scene_scan(b.data, b.len, &info, NULL) == 0);
	CHECK(info.depth == BC_PROTO_SCENE_MAX_DEPTH);
	bc_proto_buf_reset(&b);
	REQUIRE(write_comb(&b, BC_PROTO_SCENE_MAX_DEPTH) == 0);
	CHECK(bc_proto_scene_scan(b.data, b.len, &info, NULL) == BC_EDEPTH);
	bc_proto_buf_finish(&b);
}

static void test_writers_respect_the_ceiling(void)
{
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 22);
	CHECK(bc_proto_scene_begin(&b, NULL, 1) == 0);
	CHECK(b.len == 5);
	/* A 35-byte primitive does not fit; the buffer stays as it was. */
	CHECK(bc_proto_scene_prim(&b, 1, 1, T0, R0, NULL, 0, NULL) ==
	      BC_ELIMIT);
	CHECK(b.len == 5);
	CHECK(bc_proto_scene_op(&b, 1, 1, 0, 0, 2) == 0);
	CHECK(b.len == 22);
	CHECK(bc_proto_scene_op(&b, 1, 1, 0, 0, 2) == BC_ELIMIT);
	CHECK(b.len == 22);
	bc_proto_buf_finish(&b);
}

/* The 10^6-node scene: a balanced tree of binary and ternary operators
 * over primitives of every kind, about half with colours. */
static void test_million_node_scene_load(void)
{
	const uint32_t n = 1000000;
	struct bc_proto_buf scene, wire;
	struct counts c = {0};
	bc_proto_buf_init(&scene, 0);
	bc_proto_buf_init(&wire, 0);
	REQUIRE(bc_proto_scene_begin(&scene, NULL, n) == 0);
	REQUIRE(write_tree(&scene, n, 1, &c, 0) == 0);
	REQUIRE(c.nodes == n);
	printf("  %u nodes (%u primitives, %u operators, depth %u): %zu "
	       "bytes\n",
	       n, c.prims, c.ops, c.depth, scene.len);
	CHECK(scene.len <= BC_PROTO_MAX_PAYLOAD - 4);

	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD, .seq = 4};
	m.scene_load.scene =
	    (struct bc_proto_bytes){scene.data, (uint32_t)scene.len};
	struct bc_errinfo ei = {0};
	int rc = bc_proto_encode(&wire, &m, &ei);
	if (rc) {
		fprintf(stderr, "  encode: %s\n", ei.msg);
	}
	REQUIRE(rc == 0);

	/* Through a server-side reader in 64 KiB reads, as from a socket. */
	struct bc_proto_reader r;
	struct bc_msg got;
	bc_proto_reader_init(
	    &r, &(struct bc_proto_reader_opts){.side = BC_PROTO_SIDE_SERVER});
	int msgs = 0;
	for (size_t off = 0; off < wire.len; off += 65536) {
		size_t k = wire.len - off < 65536 ? wire.len - off : 65536;
		REQUIRE(bc_proto_reader_feed(&r, wire.data + off, k) == 0);
		while ((rc = bc_proto_reader_next(&r, &got)) == 1) {
			msgs++;
			CHECK(got.type == BC_MSG_SCENE_LOAD && got.seq == 4);
			CHECK(got.scene_load.scene.len == scene.len);
			CHECK_MEMEQ(got.scene_load.scene.ptr, scene.data,
			            scene.len);
			struct bc_proto_scene_info info;
			CHECK(bc_proto_scene_scan(got.scene_load.scene.ptr,
			                          got.scene_load.scene.len,
			                          &info, NULL) == 0);
			CHECK(info.nodes == n && info.prims == c.prims &&
			      info.ops == c.ops && info.depth == c.depth);
		}
		CHECK(rc == 0);
	}
	CHECK(msgs == 1);
	CHECK(bc_proto_reader_eof(&r) == 0);
	/* The reader grew with the bytes, to no more than twice them. */
	CHECK(r.cap <= 2 * wire.len);
	bc_proto_reader_finish(&r);
	bc_proto_buf_finish(&wire);
	bc_proto_buf_finish(&scene);
}

static const struct bc_test tests[] = {
    {"random_trees_scan_to_their_counts",
     test_random_trees_scan_to_their_counts},
    {"depth_limit", test_depth_limit},
    {"writers_respect_the_ceiling", test_writers_respect_the_ceiling},
    {"million_node_scene_load", test_million_node_scene_load},
};

BC_TEST_MAIN(tests)
