/*
 * Byte-level helpers shared inside protocol/ (reads go through base's
 * bounded cursor, blobcast/bytes.h): a writer that either
 * measures or writes (so an encoder runs once to size a message and once to
 * fill it), strict UTF-8 and float checks, and the per-type table. Nothing
 * here casts a struct onto a buffer: every integer is assembled byte by
 * byte, little-endian, whatever the host's byte order.
 */
#ifndef BLOBCAST_PROTOCOL_WIRE_H
#define BLOBCAST_PROTOCOL_WIRE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/bytes.h"
#include "blobcast/proto.h"

/* ---- Reading ------------------------------------------------------------ */

/* The payload decoder (decode.c) and the scene scanner (scene.c) read
 * through base's struct bc_rd (blobcast/bytes.h). */

/* An IEEE 754 binary32 is its bit pattern as a u32; memcpy is the one
 * portable way to reinterpret it. */
static inline float bc__bits_f32(uint32_t u)
{
	float f;
	memcpy(&f, &u, sizeof(f));
	return f;
}

static inline uint32_t bc__f32_bits(float f)
{
	uint32_t u;
	memcpy(&u, &f, sizeof(u));
	return u;
}

/* Finite means the exponent is not all ones. Tested on the bits so that it
 * still holds in code built with relaxed math. */
static inline bool bc__bits_finite(uint32_t u)
{
	return (u & 0x7f800000u) != 0x7f800000u;
}

/* ---- Writing ------------------------------------------------------------ */

/* With p == NULL the writer only counts (n grows, nothing is stored);
 * otherwise it stores into p[0..cap), which the measuring pass sized. err
 * keeps the first problem an encoder found in its input. */
struct bc__w {
	uint8_t *p;
	size_t n, cap;
	int err;
	struct bc_errinfo *ei;
};

static inline void bc__put_raw(struct bc__w *w, const void *src, size_t k)
{
	if (w->p && k && w->n + k <= w->cap) {
		memcpy(w->p + w->n, src, k);
	}
	w->n += k;
}

static inline void bc__put_u8(struct bc__w *w, uint8_t v)
{
	bc__put_raw(w, &v, 1);
}

static inline void bc__put_u16(struct bc__w *w, uint16_t v)
{
	uint8_t b[2];
	bc_put_le16(b, v);
	bc__put_raw(w, b, 2);
}

static inline void bc__put_u32(struct bc__w *w, uint32_t v)
{
	uint8_t b[4];
	bc_put_le32(b, v);
	bc__put_raw(w, b, 4);
}

static inline void bc__put_u64(struct bc__w *w, uint64_t v)
{
	bc__put_u32(w, (uint32_t)v);
	bc__put_u32(w, (uint32_t)(v >> 32));
}

static inline void bc__put_f32(struct bc__w *w, float f)
{
	bc__put_u32(w, bc__f32_bits(f));
}

/* Reserves room for k more bytes in b (growing by doubling up to b->max).
 * Returns 0, BC_ELIMIT or BC_ENOMEM. */
int bc__buf_reserve(struct bc_proto_buf *b, size_t k);

/* ---- Types ----------------------------------------------------------------
 */

/* Who sends a type. */
#define BC__FROM_CLIENT 1u
#define BC__FROM_SERVER 2u
#define BC__FROM_BOTH 3u

struct bc__type_info {
	const char *name;
	uint8_t from;         /* BC__FROM_* */
	uint16_t flags;       /* flag bits defined for the type */
	uint32_t max_payload; /* largest valid payload of the type */
};

/* Returns the row of type, or NULL when it is not a message type. */
const struct bc__type_info *bc__type_info(unsigned type);

/* The header flag rule (PROTOCOL.md 3.1 step 5) for t's row: bits the type
 * does not define, on FRAME a level above 0 with STILL or SNAPSHOT, and
 * DEPTH or IDS without SNAPSHOT.
 * Returns 0 or BC_EPROTO_FLAGS with the reason in ei. */
int bc__check_flags(const struct bc__type_info *t, uint16_t flags,
                    struct bc_errinfo *ei);

/* Decodes a payload into *out (header fields already set by the caller).
 * store NULL: check only, arrays are not kept. Returns 0 or a code with the
 * reason in ei. */
int bc__decode_payload(struct bc_proto_store *store, struct bc_msg *out,
                       const uint8_t *payload, size_t len,
                       struct bc_errinfo *ei);

void bc__store_free(struct bc_proto_store *s);

#endif
