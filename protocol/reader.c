/*
 * The push parser: bytes in with feed(), messages out with next(). It owns
 * the stream rules of PROTOCOL.md -- the header checks, in their order and
 * as early as the bytes allow; the side and pre-HELLO rules; the payload
 * limits -- and the input buffer, which grows with the bytes that actually
 * arrive (never with what a header announces) and never past one whole
 * message plus BC_PROTO_READ_SLACK. Errors are sticky: a stream that went
 * wrong once cannot be trusted to be in step again.
 */
#include "wire.h"

#include <stdarg.h>
#include <stdio.h>

#include "blobcast/alloc.h"

static int set_err(struct bc_proto_reader *r, int code, const char *fmt,
                   ...) BC__ERRINFO_PRINTF;

static int set_err(struct bc_proto_reader *r, int code, const char *fmt, ...)
{
	va_list ap;
	r->err = code;
	va_start(ap, fmt);
	vsnprintf(r->errstr, sizeof(r->errstr), fmt, ap);
	va_end(ap);
	return code;
}

static uint32_t clamp_payload(uint32_t max)
{
	return (max == 0 || max > BC_PROTO_MAX_PAYLOAD) ? BC_PROTO_MAX_PAYLOAD
	                                                : max;
}

/* The payload limit now in force. */
static uint32_t limit(const struct bc_proto_reader *r)
{
	uint32_t max = r->opts.max_payload;
	if (r->pre_hello && max > BC_PROTO_HELLO_MAX_PAYLOAD) {
		max = BC_PROTO_HELLO_MAX_PAYLOAD;
	}
	return max;
}

int bc_proto_reader_init(struct bc_proto_reader *r,
                         const struct bc_proto_reader_opts *opts)
{
	memset(r, 0, sizeof(*r));
	if (opts) {
		if ((unsigned)opts->side >= BC_PROTO_SIDE_COUNT) {
			return BC_EINVAL;
		}
		r->opts = *opts;
	}
	r->opts.max_payload = clamp_payload(r->opts.max_payload);
	r->pre_hello = r->opts.await_hello;
	return 0;
}

void bc_proto_reader_finish(struct bc_proto_reader *r)
{
	if (!r) {
		return;
	}
	bc_free(r->buf);
	bc__store_free(&r->store);
	memset(r, 0, sizeof(*r));
}

void bc_proto_reader_hello_done(struct bc_proto_reader *r)
{
	r->pre_hello = false;
}

void bc_proto_reader_set_max_payload(struct bc_proto_reader *r,
                                     uint32_t max_payload)
{
	r->opts.max_payload = clamp_payload(max_payload);
}

size_t bc_proto_reader_pending(const struct bc_proto_reader *r)
{
	return r->len - r->pos;
}

void *bc_proto_reader_detach(struct bc_proto_reader *r)
{
	uint8_t *old = r->buf, *tail = NULL;
	size_t left = r->len - r->pos;
	if (!old || (left > 0 && !(tail = bc_malloc(left)))) {
		return NULL;
	}
	if (left > 0) {
		memcpy(tail, r->buf + r->pos, left);
	}
	r->buf = tail;
	r->cap = r->len = left;
	r->pos = 0;
	return old;
}

int bc_proto_reader_feed(struct bc_proto_reader *r, const void *bytes, size_t n)
{
	if (r->err) {
		return r->err;
	}
	if (n == 0) {
		return 0;
	}
	/* Drop what was parsed. Only the unparsed tail moves, and a caller
	 * that drains after every read keeps that tail under one message. */
	if (r->pos > 0) {
		memmove(r->buf, r->buf + r->pos, r->len - r->pos);
		r->len -= r->pos;
		r->pos = 0;
	}
	size_t ceiling =
	    (size_t)BC_PROTO_HEADER_SIZE + limit(r) + BC_PROTO_READ_SLACK;
	if (n > ceiling - r->len) {
		return set_err(r, BC_ELIMIT,
		               "%zu unparsed bytes plus %zu more exceed the "
		               "reader's %zu (drain with next() between reads)",
		               r->len, n, ceiling);
	}
	if (r->len + n > r->cap) {
		size_t cap = r->cap ? r->cap : 4096;
		while (cap < r->len + n) {
			cap = cap > ceiling / 2 ? ceiling : cap * 2;
		}
		uint8_t *p = bc_realloc(r->buf, cap);
		if (!p) {
			return set_err(r, BC_ENOMEM,
			               "no memory for a %zu-byte buffer", cap);
		}
		r->buf = p;
		r->cap = cap;
	}
	memcpy(r->buf + r->len, bytes, n);
	r->len += n;
	return 0;
}

/* Checks the first avail (< 16 possible) bytes of a header, field by field
 * in header order, so a stream that is not ours fails on its first byte.
 * Returns 0 or a code with the reason in r. */
static int check_header(struct bc_proto_reader *r, const uint8_t *h,
                        size_t avail)
{
	static const uint8_t magic[4] = {BC_PROTO_MAGIC0, BC_PROTO_MAGIC1,
	                                 BC_PROTO_MAGIC2, BC_PROTO_MAGIC3};
	for (size_t i = 0; i < 4 && i < avail; i++) {
		if (h[i] != magic[i]) {
			return set_err(
			    r, BC_EPROTO_MAGIC,
			    "header byte %zu is 0x%02x, not the magic "
			    "\"BCST\" (message %llu)",
			    i, (unsigned)h[i],
			    (unsigned long long)r->nmsgs + 1);
		}
	}
	if (avail < 5) {
		return 0;
	}
	if (h[4] != BC_PROTO_VERSION) {
		return set_err(r, BC_EPROTO_VERSION, "version %u is not %u",
		               (unsigned)h[4], BC_PROTO_VERSION);
	}
	if (avail < 6) {
		return 0;
	}
	const struct bc__type_info *t = bc__type_info(h[5]);
	if (!t) {
		return set_err(r, BC_EPROTO_TYPE, "message type %u is unknown",
		               (unsigned)h[5]);
	}
	unsigned want = r->opts.side == BC_PROTO_SIDE_SERVER   ? BC__FROM_CLIENT
	                : r->opts.side == BC_PROTO_SIDE_CLIENT ? BC__FROM_SERVER
	                                                       : BC__FROM_BOTH;
	if (!(t->from & want)) {
		return set_err(r, BC_EPROTO_TYPE, "%s (%u) is never sent %s",
		               t->name, (unsigned)h[5],
		               want == BC__FROM_CLIENT ? "by clients"
		                                       : "by servers");
	}
	if (r->pre_hello && h[5] != BC_MSG_HELLO && h[5] != BC_MSG_PING) {
		return set_err(r, BC_ESTATE,
		               "%s before HELLO (only HELLO and PING are "
		               "allowed)",
		               t->name);
	}
	if (avail < 8) {
		return 0;
	}
	uint16_t flags = bc_get_le16(h + 6);
	struct bc_errinfo ei = {0};
	int rc = bc__check_flags(t, flags, &ei);
	if (rc < 0) {
		return set_err(r, rc, "%s", ei.msg);
	}
	if (avail < 12) {
		return 0;
	}
	uint32_t len = bc_get_le32(h + 8);
	if (len > t->max_payload) {
		return set_err(r, BC_EPROTO_LENGTH,
		               "%s payload length %u is over its maximum %u",
		               t->name, len, t->max_payload);
	}
	if (len > limit(r)) {
		return set_err(r, BC_EPROTO_LENGTH,
		               "%s payload length %u is over the limit %u%s",
		               t->name, len, limit(r),
		               r->pre_hello ? " before HELLO" : "");
	}
	return 0;
}

int bc_proto_reader_next(struct bc_proto_reader *r, struct bc_msg *out)
{
	memset(out, 0, sizeof(*out));
	if (r->err) {
		return r->err;
	}
	size_t avail = r->len - r->pos;
	if (avail == 0) {
		return 0;
	}
	const uint8_t *h = r->buf + r->pos;
	size_t hbytes =
	    avail < BC_PROTO_HEADER_SIZE ? avail : BC_PROTO_HEADER_SIZE;
	int rc = check_header(r, h, hbytes);
	if (rc < 0 || hbytes < BC_PROTO_HEADER_SIZE) {
		return rc;
	}
	uint32_t len = bc_get_le32(h + 8);
	if (avail - BC_PROTO_HEADER_SIZE < len) {
		return 0;
	}
	out->type = (enum bc_msg_type)h[5];
	out->flags = bc_get_le16(h + 6);
	out->seq = bc_get_le32(h + 12);
	struct bc_errinfo ei = {0};
	rc = bc__decode_payload(&r->store, out, h + BC_PROTO_HEADER_SIZE, len,
	                        &ei);
	if (rc < 0) {
		memset(out, 0, sizeof(*out));
		return set_err(r, rc, "%s", ei.msg);
	}
	r->pos += BC_PROTO_HEADER_SIZE + len;
	r->nmsgs++;
	/* Whole buffer parsed: start over at 0 so feed() has nothing to
	 * move. */
	if (r->pos == r->len) {
		r->pos = r->len = 0;
	}
	return 1;
}

int bc_proto_reader_eof(struct bc_proto_reader *r)
{
	if (r->err) {
		return r->err;
	}
	size_t left = r->len - r->pos;
	if (left == 0) {
		return 0;
	}
	return set_err(r, BC_EPROTO_TRUNCATED,
	               "stream ended %zu bytes into message %llu", left,
	               (unsigned long long)r->nmsgs + 1);
}

int bc_proto_decode_payload(struct bc_proto_reader *r, enum bc_msg_type type,
                            uint16_t flags, uint32_t seq,
                            const uint8_t *payload, size_t len,
                            struct bc_msg *out, struct bc_errinfo *ei)
{
	memset(out, 0, sizeof(*out));
	const struct bc__type_info *t = bc__type_info((unsigned)type);
	if (!t) {
		return bc_errinfo_set(ei, BC_EPROTO_TYPE,
		                      "message type %d is unknown", (int)type);
	}
	int rc = bc__check_flags(t, flags, ei);
	if (rc < 0) {
		return rc;
	}
	if (len > t->max_payload) {
		return bc_errinfo_set(ei, BC_EPROTO_LENGTH,
		                      "%s payload length %zu is over its "
		                      "maximum %u",
		                      t->name, len, t->max_payload);
	}
	out->type = type;
	out->flags = flags;
	out->seq = seq;
	rc = bc__decode_payload(&r->store, out, payload, len, ei);
	if (rc < 0) {
		memset(out, 0, sizeof(*out));
	}
	return rc;
}
