/*
 * The shared byte helper that is not small enough to inline: the growth
 * rule of struct bc_proto_buf (doubling, never past the ceiling fixed at
 * init). Strict UTF-8 validation is base's bc_utf8_check().
 */
#include "wire.h"

#include "blobcast/alloc.h"

int bc__buf_reserve(struct bc_proto_buf *b, size_t k)
{
	if (k > b->max - b->len) {
		return BC_ELIMIT;
	}
	size_t need = b->len + k;
	if (need <= b->cap) {
		return 0;
	}
	size_t cap = b->cap ? b->cap : 256;
	while (cap < need) {
		cap = cap > b->max / 2 ? b->max : cap * 2;
	}
	uint8_t *p = bc_realloc(b->data, cap);
	if (!p) {
		return BC_ENOMEM;
	}
	b->data = p;
	b->cap = cap;
	return 0;
}

void bc_proto_buf_init(struct bc_proto_buf *b, size_t max)
{
	memset(b, 0, sizeof(*b));
	b->max =
	    max ? max : (size_t)BC_PROTO_HEADER_SIZE + BC_PROTO_MAX_PAYLOAD;
}

void bc_proto_buf_finish(struct bc_proto_buf *b)
{
	if (!b) {
		return;
	}
	bc_free(b->data);
	memset(b, 0, sizeof(*b));
}

void bc_proto_buf_reset(struct bc_proto_buf *b)
{
	b->len = 0;
}

void bc_proto_buf_consume(struct bc_proto_buf *b, size_t n)
{
	if (n >= b->len) {
		b->len = 0;
		return;
	}
	memmove(b->data, b->data + n, b->len - n);
	b->len -= n;
}
