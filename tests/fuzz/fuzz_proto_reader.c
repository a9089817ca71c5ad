/*
 * libFuzzer harness for the stream reader. The first two input bytes pick
 * the reader's options (side, pre-HELLO stage, payload limit) and how the
 * rest is cut into feed() calls; the rest is the stream. Oracles besides
 * the sanitizers: every message the reader returns re-encodes to exactly
 * the bytes it came from (the encoding is canonical), errors are sticky
 * and come with a reason. Every message also goes through the assembler
 * of scenes in parts (PROTOCOL.md 7.10.1), as a client or a server uses
 * it: a scene it hands back whole is exactly its parts' pieces, and a
 * refusal leaves no scene open.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void die(const char *why)
{
	fprintf(stderr, "fuzz_proto_reader: %s\n", why);
	abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 2) {
		return 0;
	}
	uint8_t o = data[0];
	uint32_t cut = data[1];
	struct bc_proto_reader_opts opts = {
	    .side = (enum bc_proto_side)(o % BC_PROTO_SIDE_COUNT),
	    .await_hello = (o >> 2) & 1u,
	    .max_payload = ((o >> 3) & 1u) ? 4096u : 0u,
	};
	data += 2;
	size -= 2;
	struct bc_proto_reader r;
	struct bc_proto_parts parts;
	struct bc_proto_buf b;
	struct bc_msg m, whole;
	size_t pieces = 0; /* bytes of the open scene's parts so far */
	if (bc_proto_reader_init(&r, &opts) != 0) {
		die("init refused valid options");
	}
	bc_proto_buf_init(&b, 0);
	bc_proto_parts_init(&parts, ((o >> 4) & 1u) ? 300u : 0u,
	                    opts.side == BC_PROTO_SIDE_SERVER);
	size_t off = 0, msg = 0;
	int rc = 0;
	while (rc >= 0 && off < size) {
		/* Chunks of 1..64 bytes from a small LCG, or all at once. */
		size_t k = size - off;
		if (cut) {
			cut = cut * 1103515245u + 12345u;
			size_t c = 1 + (cut >> 16) % 64;
			k = c < k ? c : k;
		}
		rc = bc_proto_reader_feed(&r, data + off, k);
		off += k;
		while (rc >= 0 && (rc = bc_proto_reader_next(&r, &m)) == 1) {
			const uint8_t *h = data + msg;
			size_t len =
			    BC_PROTO_HEADER_SIZE +
			    ((size_t)h[8] | (size_t)h[9] << 8 |
			     (size_t)h[10] << 16 | (size_t)h[11] << 24);
			bc_proto_buf_reset(&b);
			if (bc_proto_encode(&b, &m, NULL) != 0) {
				die("a decoded message does not re-encode");
			}
			if (b.len != len || memcmp(b.data, h, len) != 0) {
				die("re-encoding differs from the input");
			}
			if (m.type == BC_MSG_HELLO && opts.await_hello) {
				bc_proto_reader_hello_done(&r);
			}
			msg += len;
			{
				bool part = (m.type == BC_MSG_SCENE_LOAD ||
				             m.type == BC_MSG_SCENE_STATE) &&
				            (m.flags & BC_PROTO_FLAGS_PARTS);
				uint32_t piece = m.type == BC_MSG_SCENE_LOAD
				                     ? m.scene_load.scene.len
				                     : m.scene_state.scene.len;
				size_t before = parts.open ? pieces : 0;
				struct bc_errinfo ei = {0};
				int pr =
				    bc_proto_parts_add(&parts, &m, &whole, &ei);
				if (pr < 0 && (parts.open || !ei.msg[0])) {
					die("a refused part left its scene "
					    "open");
				}
				if (pr == 0) {
					pieces = (m.flags & BC_PROTO_FLAG_CONT)
					             ? before + piece
					             : piece;
				}
				if (pr == 1 && part &&
				    (whole.flags & BC_PROTO_FLAGS_PARTS ||
				     (whole.type == BC_MSG_SCENE_LOAD
				          ? whole.scene_load.scene.len
				          : whole.scene_state.scene.len) !=
				         before + piece)) {
					die("a scene in parts is not its "
					    "pieces");
				}
			}
		}
	}
	if (rc >= 0) {
		rc = bc_proto_reader_eof(&r);
	}
	if (rc < 0) {
		if (r.err != rc || r.errstr[0] == '\0') {
			die("error without a sticky code and reason");
		}
		if (bc_proto_reader_next(&r, &m) != rc ||
		    bc_proto_reader_feed(&r, data, size) != rc) {
			die("error is not sticky");
		}
	}
	bc_proto_buf_finish(&b);
	bc_proto_parts_finish(&parts);
	bc_proto_reader_finish(&r);
	return 0;
}
