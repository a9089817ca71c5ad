/*
 * libFuzzer harness for the scene-encoding scanner, differential: a short
 * recursive reference written straight from PROTOCOL.md's grammar must
 * accept exactly what bc_proto_scene_scan accepts, with the same counts.
 * (The reference recurses at most BC_PROTO_SCENE_MAX_DEPTH levels; the
 * scanner does not recurse at all.)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/bytes.h"
#include "blobcast/proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

struct ref {
	const uint8_t *p;
	size_t n, pos;
	uint32_t left, prims, ops, depth, names;
};

static int rd(struct ref *r, size_t k, uint32_t *v)
{
	if (r->n - r->pos < k) {
		return -1;
	}
	uint32_t x = 0;
	for (size_t i = 0; i < k; i++) {
		x |= (uint32_t)r->p[r->pos + i] << (8 * i);
	}
	r->pos += k;
	*v = x;
	return 0;
}

static int floats(struct ref *r, uint32_t k, float *first)
{
	for (uint32_t i = 0; i < k; i++) {
		uint32_t u;
		if (rd(r, 4, &u) || (u & 0x7f800000u) == 0x7f800000u) {
			return -1;
		}
		if (i == 0 && first) {
			memcpy(first, &u, 4);
		}
	}
	return 0;
}

/* One node and its subtree; depth = nodes on its path, itself included. */
static int node(struct ref *r, uint32_t depth)
{
	uint32_t tag, id, v;
	float blend = 0, range = 0;
	if (r->left == 0 || depth > BC_PROTO_SCENE_MAX_DEPTH ||
	    rd(r, 1, &tag) || rd(r, 4, &id)) {
		return -1;
	}
	r->left--;
	if ((tag & 0x80u) && (tag & 0x7fu) >= BC_PROTO_OP_KIND_FIRST_UNARY &&
	    (tag & 0x7fu) <= BC_PROTO_OP_KIND_MAX) {
		/* A unary node: nfloats, floats, exactly one child. */
		if (rd(r, 1, &v) || v > BC_PROTO_MAX_UNARY_PARAMS ||
		    floats(r, v, NULL)) {
			return -1;
		}
		r->ops++;
		return node(r, depth + 1);
	}
	if (tag & 0x80u) {
		uint32_t kind = tag & 0x7fu;
		if (kind < 1 || kind > 6 || floats(r, 1, &blend) ||
		    floats(r, 1, &range) || rd(r, 4, &v) || v < 2 ||
		    (kind <= 3 && (blend != 0.0f || range != 0.0f))) {
			return -1;
		}
		r->ops++;
		for (uint32_t i = 0; i < v; i++) {
			if (node(r, depth + 1)) {
				return -1;
			}
		}
		return 0;
	}
	if (tag < 1 || tag > 32 || floats(r, 7, NULL) || rd(r, 1, &v) ||
	    v > 1 || floats(r, 3 * v, NULL) || rd(r, 1, &v) ||
	    v > BC_PROTO_MAX_PRIM_PARAMS || floats(r, v, NULL)) {
		return -1;
	}
	r->prims++;
	if (depth > r->depth) {
		r->depth = depth;
	}
	return 0;
}

/* The names table after a tree of `nodes` nodes: count 1..nodes, then
 * (id, length, bytes) with ids increasing from 1, lengths 1..64 and the
 * bytes strict UTF-8 without NUL (base's check, itself tested against a
 * reference in test_proto). */
static int names(struct ref *r, uint32_t nodes)
{
	uint32_t count, prev = 0;
	if (rd(r, 4, &count) || count < 1 || count > nodes) {
		return -1;
	}
	for (uint32_t i = 0; i < count; i++) {
		uint32_t id, len;
		if (rd(r, 4, &id) || rd(r, 2, &len) || id <= prev || len < 1 ||
		    len > BC_PROTO_MAX_NAME || r->n - r->pos < len ||
		    bc_utf8_check(r->p + r->pos, len) < len) {
			return -1;
		}
		prev = id;
		r->pos += len;
	}
	r->names = count;
	return 0;
}

static int reference(const uint8_t *p, size_t n, struct ref *r)
{
	uint32_t flags, count;
	memset(r, 0, sizeof(*r));
	r->p = p;
	r->n = n;
	if (rd(r, 1, &flags) || flags > 3 ||
	    floats(r, 10 * (flags & 1u), NULL) || rd(r, 4, &count) ||
	    count < 1 || count > BC_PROTO_SCENE_MAX_NODES) {
		return -1;
	}
	r->left = count;
	if (node(r, 1) || r->left != 0 || ((flags & 2u) && names(r, count)) ||
	    r->pos != n) {
		return -1;
	}
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct bc_proto_scene_info info;
	struct bc_errinfo ei = {0};
	struct ref r;
	int rc = bc_proto_scene_scan(data, size, &info, &ei);
	int want = reference(data, size, &r);
	if ((rc == 0) != (want == 0)) {
		fprintf(stderr, "scanner %d (%s), reference %d\n", rc, ei.msg,
		        want);
		abort();
	}
	if (rc == 0 &&
	    (info.prims != r.prims || info.ops != r.ops ||
	     info.depth != r.depth || info.nodes != r.prims + r.ops ||
	     info.names != r.names)) {
		fprintf(stderr, "counts differ\n");
		abort();
	}
	if (rc < 0 && (ei.code != rc || ei.msg[0] == '\0')) {
		fprintf(stderr, "refusal without a reason\n");
		abort();
	}
	return 0;
}
