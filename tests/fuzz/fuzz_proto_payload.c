/*
 * libFuzzer harness for the per-type payload decoders, called directly
 * (bc_proto_decode_payload) so that every input reaches a decoder instead of
 * the header checks: byte 0 picks the type (modulo BC_MSG_COUNT + 1, so 0
 * and the first unknown type test the refusal), byte 1 the header flags,
 * the rest is the payload. Oracle: an
 * accepted payload encodes back to the same bytes under a correct header,
 * and a refused one has a reason.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void die(const char *why)
{
	fprintf(stderr, "fuzz_proto_payload: %s\n", why);
	abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 2) {
		return 0;
	}
	enum bc_msg_type type =
	    (enum bc_msg_type)(data[0] % ((unsigned)BC_MSG_COUNT + 1u));
	uint16_t flags = (uint16_t)(data[1] & 0x7u);
	const uint8_t *payload = data + 2;
	size_t n = size - 2;
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bc_errinfo ei = {0};
	bc_proto_reader_init(&r, NULL);
	int rc = bc_proto_decode_payload(&r, type, flags, 0x01020304u, payload,
	                                 n, &m, &ei);
	if (rc < 0) {
		if (ei.code != rc || ei.msg[0] == '\0') {
			die("refusal without a reason");
		}
	} else {
		struct bc_proto_buf b;
		bc_proto_buf_init(&b, 0);
		if (bc_proto_encode(&b, &m, NULL) != 0) {
			die("an accepted payload does not re-encode");
		}
		if (b.len != BC_PROTO_HEADER_SIZE + n ||
		    memcmp(b.data + BC_PROTO_HEADER_SIZE, payload, n) != 0) {
			die("re-encoding differs from the payload");
		}
		if (b.data[5] != (uint8_t)type || b.data[6] != flags ||
		    b.data[12] != 0x04) {
			die("header fields do not survive");
		}
		bc_proto_buf_finish(&b);
	}
	bc_proto_reader_finish(&r);
	return 0;
}
