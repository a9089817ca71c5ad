/*
 * Little-endian byte access for every module that reads or writes bytes
 * that cross a process boundary (the wire protocol, binary scenes, the
 * journal, image files). Integers are assembled byte by byte and floats go
 * through memcpy, so nothing casts a struct onto a buffer and the host's
 * byte order and alignment never matter.
 *
 * struct bc_rd is a bounded read cursor over untrusted bytes: every read
 * checks that its size is left before it touches memory, and the first
 * failure is sticky (later reads return zeros and leave pos alone), so a
 * parser can read a whole record and test rd.err once at the end.
 * Header-only: the functions are small enough to inline everywhere.
 */
#ifndef BLOBCAST_BYTES_H
#define BLOBCAST_BYTES_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/error.h"

static inline uint16_t bc_get_le16(const uint8_t *p)
{
	return (uint16_t)((unsigned)p[0] | (unsigned)p[1] << 8);
}

static inline uint32_t bc_get_le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	       (uint32_t)p[3] << 24;
}

static inline uint64_t bc_get_le64(const uint8_t *p)
{
	return (uint64_t)bc_get_le32(p) | (uint64_t)bc_get_le32(p + 4) << 32;
}

/* The IEEE-754 binary32 whose bit pattern is the little-endian word at p. */
static inline float bc_get_f32(const uint8_t *p)
{
	uint32_t u = bc_get_le32(p);
	float f;
	memcpy(&f, &u, sizeof(f));
	return f;
}

static inline void bc_put_le16(uint8_t *p, uint16_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
}

static inline void bc_put_le32(uint8_t *p, uint32_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
	p[2] = (uint8_t)(v >> 16);
	p[3] = (uint8_t)(v >> 24);
}

static inline void bc_put_le64(uint8_t *p, uint64_t v)
{
	bc_put_le32(p, (uint32_t)v);
	bc_put_le32(p + 4, (uint32_t)(v >> 32));
}

static inline void bc_put_f32(uint8_t *p, float f)
{
	uint32_t u;
	memcpy(&u, &f, sizeof(u));
	bc_put_le32(p, u);
}

/* A read cursor: p[0..len) are the bytes, pos the next one to read, err 0
 * or the first failure (BC_EPROTO_TRUNCATED). Initialise with
 * bc_rd_init or a literal { p, len, 0, 0 }. */
struct bc_rd {
	const uint8_t *p;
	size_t len, pos;
	int err;
};

static inline struct bc_rd bc_rd_init(const void *p, size_t len)
{
	struct bc_rd r = {(const uint8_t *)p, len, 0, 0};
	return r;
}

/* Bytes left to read (0 once the cursor has failed). */
static inline size_t bc_rd_left(const struct bc_rd *r)
{
	return r->err ? 0 : r->len - r->pos;
}

/* Returns a pointer to the next n bytes and moves past them, or NULL (and
 * err set, pos unchanged) when fewer than n are left or err was already
 * set. The test is written as n > len - pos so that it cannot overflow. */
static inline const uint8_t *bc_rd_take(struct bc_rd *r, size_t n)
{
	const uint8_t *at;
	if (r->err || n > r->len - r->pos) {
		r->err = r->err ? r->err : BC_EPROTO_TRUNCATED;
		return NULL;
	}
	at = r->p + r->pos;
	r->pos += n;
	return at;
}

static inline uint8_t bc_rd_u8(struct bc_rd *r)
{
	const uint8_t *b = bc_rd_take(r, 1);
	return b ? b[0] : 0;
}

static inline uint16_t bc_rd_u16(struct bc_rd *r)
{
	const uint8_t *b = bc_rd_take(r, 2);
	return b ? bc_get_le16(b) : 0;
}

static inline uint32_t bc_rd_u32(struct bc_rd *r)
{
	const uint8_t *b = bc_rd_take(r, 4);
	return b ? bc_get_le32(b) : 0;
}

static inline uint64_t bc_rd_u64(struct bc_rd *r)
{
	const uint8_t *b = bc_rd_take(r, 8);
	return b ? bc_get_le64(b) : 0;
}

static inline float bc_rd_f32(struct bc_rd *r)
{
	const uint8_t *b = bc_rd_take(r, 4);
	return b ? bc_get_f32(b) : 0.0f;
}

/* Copies the next n bytes into out (zeros on failure). Returns r->err. */
static inline int bc_rd_bytes(struct bc_rd *r, void *out, size_t n)
{
	const uint8_t *b = bc_rd_take(r, n);
	if (b) {
		memcpy(out, b, n);
	} else if (n) {
		memset(out, 0, n);
	}
	return r->err;
}

/* Returns the offset of the first byte of p[0..n) that breaks strict UTF-8
 * (overlong forms, surrogates, code points above U+10FFFF, truncated
 * sequences) or is NUL; n when the whole string is valid. */
size_t bc_utf8_check(const uint8_t *p, size_t n);
/* Writes code point cp as UTF-8 into out; returns its length (1..4), or
 * 0 for what is no character (a surrogate, above U+10FFFF), out then
 * untouched. */
size_t bc_utf8_encode(uint32_t cp, char out[4]);

#endif
