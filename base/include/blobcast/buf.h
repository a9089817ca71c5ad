/*
 * A growable byte buffer with a ceiling fixed at init, for output whose
 * size depends on untrusted input (a scene encoded back to bytes, JSON
 * written from a tree). Going over the ceiling, or running out of memory,
 * frees the contents and sets a sticky error: every later call fails with
 * the same code, so a writer can append a whole document and check once at
 * the end (curl's dynbuf, STYLE 10).
 */
#ifndef BLOBCAST_BUF_H
#define BLOBCAST_BUF_H

#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#define BC__BUF_PRINTF __attribute__((format(printf, 2, 3)))
#define BC__STR_PRINTF __attribute__((format(printf, 4, 5)))
#else
#define BC__BUF_PRINTF
#define BC__STR_PRINTF
#endif

/* data[0..len) is the contents; cap the bytes allocated; max the ceiling
 * (len never exceeds it); err 0 or the first failure (BC_ELIMIT over max,
 * BC_ENOMEM). */
struct bc_buf {
	uint8_t *data;
	size_t len, cap, max;
	int err;
};

/* Empties b with ceiling max bytes (0 is refused by every append with
 * BC_ELIMIT). Allocates nothing. */
void bc_buf_init(struct bc_buf *b, size_t max);
/* Frees the contents; accepts NULL and a zeroed buffer. b can be reused
 * after bc_buf_init. */
void bc_buf_finish(struct bc_buf *b);
/* Makes room for n more bytes. Returns 0 or the (sticky) error. */
int bc_buf_reserve(struct bc_buf *b, size_t n);
/* Appends n bytes of p. Returns 0 or the (sticky) error. */
int bc_buf_append(struct bc_buf *b, const void *p, size_t n);
/* Appends printf output, without its NUL. Returns 0 or the error. */
int bc_buf_printf(struct bc_buf *b, const char *fmt, ...) BC__BUF_PRINTF;
/* Hands the contents to the caller (to bc_free) and empties b: *out and
 * *len get the bytes, NUL-terminated one past len (the terminator is not
 * counted and needs no room under max). On a sticky error returns it, sets
 * *out to NULL and *len to 0. */
int bc_buf_take(struct bc_buf *b, uint8_t **out, size_t *len);

/* For text of a fixed size (an error's reason, a panel's lines): writes
 * printf output at buf + len, never past cap bytes, cut there and always
 * NUL-terminated. Returns the new length: cap - 1 when cut, len when
 * nothing fits or the format fails. */
size_t bc_str_appendf(char *buf, size_t cap, size_t len, const char *fmt,
                      ...) BC__STR_PRINTF;

#endif
