/*
 * The bounded growable buffer (blobcast/buf.h). Growth doubles, clamped to
 * the ceiling plus one byte for the terminator bc_buf_take writes, so a
 * buffer never holds more than max + 1 bytes whatever its input asks for.
 */
#include "blobcast/buf.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/error.h"

void bc_buf_init(struct bc_buf *b, size_t max)
{
	/* Room for the terminator must not overflow. */
	*b = (struct bc_buf){.max = max < SIZE_MAX / 2 ? max : SIZE_MAX / 2};
}

void bc_buf_finish(struct bc_buf *b)
{
	if (!b) {
		return;
	}
	bc_free(b->data);
	b->data = NULL;
	b->len = 0;
	b->cap = 0;
}

/* Frees the contents and records err; returns it. */
static int fail(struct bc_buf *b, int err)
{
	bc_buf_finish(b);
	b->err = err;
	return err;
}

int bc_buf_reserve(struct bc_buf *b, size_t n)
{
	size_t want, cap;
	uint8_t *grown;
	if (b->err) {
		return b->err;
	}
	if (n > b->max - b->len) {
		return fail(b, BC_ELIMIT);
	}
	want = b->len + n + 1;
	if (want <= b->cap) {
		return 0;
	}
	cap = b->cap ? b->cap : (b->max < 64 ? b->max + 1 : 64);
	while (cap < want) {
		cap = cap > (b->max + 1) / 2 ? b->max + 1 : cap * 2;
	}
	if (!(grown = bc_realloc(b->data, cap))) {
		return fail(b, BC_ENOMEM);
	}
	b->data = grown;
	b->cap = cap;
	return 0;
}

int bc_buf_append(struct bc_buf *b, const void *p, size_t n)
{
	int rc = bc_buf_reserve(b, n);
	if (rc) {
		return rc;
	}
	if (n) {
		memcpy(b->data + b->len, p, n);
		b->len += n;
	}
	return 0;
}

int bc_buf_printf(struct bc_buf *b, const char *fmt, ...)
{
	va_list ap;
	int n, rc;
	if (b->err) {
		return b->err;
	}
	va_start(ap, fmt);
	n = vsnprintf(NULL, 0, fmt, ap);
	va_end(ap);
	if (n < 0) {
		return fail(b, BC_EINVAL);
	}
	if ((rc = bc_buf_reserve(b, (size_t)n))) {
		return rc;
	}
	/* reserve left room for n bytes and a NUL. */
	va_start(ap, fmt);
	vsnprintf((char *)b->data + b->len, (size_t)n + 1, fmt, ap);
	va_end(ap);
	b->len += (size_t)n;
	return 0;
}

size_t bc_str_appendf(char *buf, size_t cap, size_t len, const char *fmt, ...)
{
	va_list ap;
	int n;
	if (len + 1 >= cap) {
		return len;
	}
	va_start(ap, fmt);
	n = vsnprintf(buf + len, cap - len, fmt, ap);
	va_end(ap);
	if (n < 0) {
		return len;
	}
	return (size_t)n < cap - len ? len + (size_t)n : cap - 1;
}

int bc_buf_take(struct bc_buf *b, uint8_t **out, size_t *len)
{
	*out = NULL;
	*len = 0;
	if (b->err) {
		return b->err;
	}
	if (!b->data && bc_buf_reserve(b, 0)) {
		return b->err;
	}
	b->data[b->len] = 0;
	*out = b->data;
	*len = b->len;
	b->data = NULL;
	b->len = 0;
	b->cap = 0;
	return 0;
}
