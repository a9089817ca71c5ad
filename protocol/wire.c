/*
 * The shared byte helpers that are not small enough to inline: strict UTF-8
 * validation and the growth rule of struct bc_proto_buf (doubling, never
 * past the ceiling fixed at init).
 */
#include "wire.h"

#include "blobcast/alloc.h"

size_t bc__utf8_check(const uint8_t *p, size_t n)
{
	size_t i = 0;
	while (i < n) {
		uint8_t c = p[i];
		if (c >= 0x01 && c <= 0x7f) {
			i++;
			continue;
		}
		/* Lead byte: the sequence length and the range of the
		 * second byte, which is what excludes overlong forms,
		 * surrogates (U+D800..DFFF) and code points over U+10FFFF
		 * (RFC 3629, section 4). */
		size_t len;
		uint8_t lo = 0x80, hi = 0xbf;
		if (c >= 0xc2 && c <= 0xdf) {
			len = 2;
		} else if (c == 0xe0) {
			len = 3;
			lo = 0xa0;
		} else if (c == 0xed) {
			len = 3;
			hi = 0x9f;
		} else if (c >= 0xe1 && c <= 0xef) {
			len = 3;
		} else if (c == 0xf0) {
			len = 4;
			lo = 0x90;
		} else if (c >= 0xf1 && c <= 0xf3) {
			len = 4;
		} else if (c == 0xf4) {
			len = 4;
			hi = 0x8f;
		} else {
			return i; /* NUL, a stray continuation, C0, C1, F5+ */
		}
		if (n - i < len) {
			return i;
		}
		if (p[i + 1] < lo || p[i + 1] > hi) {
			return i;
		}
		for (size_t k = 2; k < len; k++) {
			if (p[i + k] < 0x80 || p[i + k] > 0xbf) {
				return i;
			}
		}
		i += len;
	}
	return n;
}

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
