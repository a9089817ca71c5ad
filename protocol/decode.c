/*
 * Payload decoders, one per message type. This file owns the order in which
 * fields are checked, which PROTOCOL.md states as a rule: fields are read in
 * wire order and each is checked as soon as it is read, so the first field
 * that fails decides the error code. Every count is checked against its
 * limit and against the bytes left (count x smallest element) before any
 * element is read or any storage is reserved, so a short payload can never
 * make the decoder allocate much.
 *
 * Strings and byte ranges point into the payload; arrays go to the caller's
 * struct bc_proto_store, or nowhere when it is NULL (the encoder uses that
 * to check a message it has just written).
 */
#include "wire.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "blobcast/alloc.h"

struct dec {
	struct bc_rd c; /* err is set only by the read that fails */
	struct bc_proto_store *store; /* NULL: check only */
	struct bc_errinfo *ei;
	struct bc_msg *m;
};

#define TRY(expr)                                                              \
	do {                                                                   \
		int rc_ = (expr);                                              \
		if (rc_ < 0) {                                                 \
			return rc_;                                            \
		}                                                              \
	} while (0)

/* Smallest encodings of repeated elements, for the count-versus-bytes-left
 * checks (PROTOCOL.md gives the same numbers). */
#define MEMBER_MIN 7u         /* u32 id, u8 role, empty name */
#define SESSION_ENTRY_MIN 26u /* a 1-byte name and the fixed fields */
/* A HISTORY entry: its fixed fields and two empty strings. */
#define HISTORY_ENTRY_MIN 30u
#define OP_MIN 5u    /* REMOVE: u8 kind, u32 node */
#define FIELD_MIN 6u /* u8 field, u8 count, one f32 */
#define RECT_MIN 13u /* 4 x u16, u32 length, one byte */

/* Records code with "TYPE: reason (payload byte N)" in d->ei. */
static int fail(struct dec *d, int code, const char *fmt,
                ...) BC__ERRINFO_PRINTF;

static int fail(struct dec *d, int code, const char *fmt, ...)
{
	char reason[192];
	va_list ap;
	if (!d->ei) {
		return code;
	}
	va_start(ap, fmt);
	vsnprintf(reason, sizeof(reason), fmt, ap);
	va_end(ap);
	const char *name = bc_proto_type_name(d->m->type);
	return bc_errinfo_set(d->ei, code, "%s: %s (payload byte %zu)",
	                      name ? name : "?", reason, d->c.pos);
}

/* A read came short: what is left is measured from pos, which the cursor
 * leaves where the failed read began (bc_rd_left reads 0 once it failed). */
static int truncated(struct dec *d, const char *what, size_t need)
{
	return fail(d, BC_EPROTO_TRUNCATED, "%s needs %zu bytes, %zu left",
	            what, need, d->c.len - d->c.pos);
}

/* The fixed-size fields: bytes.h's cursor checks the bytes left and
 * assembles the value; a short read gets the decoder's own sentence. */
static int rd_u8(struct dec *d, const char *what, uint8_t *v)
{
	*v = bc_rd_u8(&d->c);
	return d->c.err ? truncated(d, what, 1) : 0;
}

static int rd_u16(struct dec *d, const char *what, uint16_t *v)
{
	*v = bc_rd_u16(&d->c);
	return d->c.err ? truncated(d, what, 2) : 0;
}

static int rd_u32(struct dec *d, const char *what, uint32_t *v)
{
	*v = bc_rd_u32(&d->c);
	return d->c.err ? truncated(d, what, 4) : 0;
}

static int rd_u64(struct dec *d, const char *what, uint64_t *v)
{
	*v = bc_rd_u64(&d->c);
	return d->c.err ? truncated(d, what, 8) : 0;
}

/* A u32 id that must not be 0. */
static int rd_id(struct dec *d, const char *what, uint32_t *v)
{
	TRY(rd_u32(d, what, v));
	if (*v == 0) {
		return fail(d, BC_ERANGE, "%s is 0", what);
	}
	return 0;
}

/* Every f32 of a payload must be finite. */
static int rd_f32(struct dec *d, const char *what, float *v)
{
	uint32_t u;
	TRY(rd_u32(d, what, &u));
	if (!bc__bits_finite(u)) {
		return fail(d, BC_ENONFINITE, "%s is not finite (bits %08x)",
		            what, u);
	}
	*v = bc__bits_f32(u);
	return 0;
}

/* A finite f32 with |v| <= BC_PROTO_MAX_ABS. */
static int rd_f32_abs(struct dec *d, const char *what, float *v)
{
	TRY(rd_f32(d, what, v));
	if (fabsf(*v) > BC_PROTO_MAX_ABS) {
		return fail(d, BC_ERANGE, "|%s| = %g is over %g", what,
		            (double)fabsf(*v), (double)BC_PROTO_MAX_ABS);
	}
	return 0;
}

/* A finite f32 >= 0. */
static int rd_f32_nonneg(struct dec *d, const char *what, float *v)
{
	TRY(rd_f32(d, what, v));
	if (*v < 0.0f) {
		return fail(d, BC_ERANGE, "%s = %g is negative", what,
		            (double)*v);
	}
	return 0;
}

static int rd_u16_range(struct dec *d, const char *what, unsigned lo,
                        unsigned hi, uint16_t *v)
{
	TRY(rd_u16(d, what, v));
	if (*v < lo || *v > hi) {
		return fail(d, BC_ERANGE, "%s = %u is outside %u..%u", what,
		            (unsigned)*v, lo, hi);
	}
	return 0;
}

static int rd_u8_range(struct dec *d, const char *what, unsigned lo,
                       unsigned hi, uint8_t *v)
{
	TRY(rd_u8(d, what, v));
	if (*v < lo || *v > hi) {
		return fail(d, BC_ERANGE, "%s = %u is outside %u..%u", what,
		            (unsigned)*v, lo, hi);
	}
	return 0;
}

static int rd_role(struct dec *d, const char *what, enum bc_proto_role *role)
{
	uint8_t v;
	TRY(rd_u8(d, what, &v));
	if (v == 0 || v >= BC_PROTO_ROLE_COUNT) {
		return fail(d, BC_EENUM, "%s = %u is not a role", what,
		            (unsigned)v);
	}
	*role = (enum bc_proto_role)v;
	return 0;
}

static int rd_encoding(struct dec *d, const char *what,
                       enum bc_proto_encoding *enc)
{
	uint8_t v;
	TRY(rd_u8(d, what, &v));
	if (v == 0 || v >= BC_PROTO_ENC_COUNT) {
		return fail(d, BC_EENUM, "%s = %u is not an encoding", what,
		            (unsigned)v);
	}
	*enc = (enum bc_proto_encoding)v;
	return 0;
}

/* u16 byte length (min..max), then that many bytes of strict UTF-8. */
static int rd_str(struct dec *d, const char *what, unsigned min, unsigned max,
                  struct bc_proto_str *s)
{
	uint16_t n;
	TRY(rd_u16(d, what, &n));
	if (n < min || n > max) {
		return fail(d, BC_EPROTO_LENGTH,
		            "%s length %u is outside %u..%u", what, (unsigned)n,
		            min, max);
	}
	if (n > bc_rd_left(&d->c)) {
		return truncated(d, what, n);
	}
	const uint8_t *p = d->c.p + d->c.pos;
	size_t bad = bc_utf8_check(p, n);
	if (bad < n) {
		d->c.pos += bad;
		return fail(d, BC_ESTRING,
		            "%s: byte %zu (0x%02x) breaks UTF-8 or is NUL",
		            what, bad, (unsigned)p[bad]);
	}
	s->ptr = (const char *)p;
	s->len = n;
	d->c.pos += n;
	return 0;
}

/* u32 byte length (>= 1), then that many opaque bytes. */
static int rd_blob(struct dec *d, const char *what, struct bc_proto_bytes *b)
{
	uint32_t n;
	TRY(rd_u32(d, what, &n));
	if (n == 0) {
		return fail(d, BC_EPROTO_LENGTH, "%s is empty", what);
	}
	if (n > bc_rd_left(&d->c)) {
		return truncated(d, what, n);
	}
	b->ptr = d->c.p + d->c.pos;
	b->len = n;
	d->c.pos += n;
	return 0;
}

/* A count n in min..max whose n elements of at least elem bytes each must
 * fit in what is left. */
static int check_count(struct dec *d, const char *what, unsigned n,
                       unsigned min, unsigned max, size_t elem)
{
	if (n < min || n > max) {
		return fail(d, BC_EPROTO_COUNT, "%s %u is outside %u..%u", what,
		            n, min, max);
	}
	if ((size_t)n * elem > bc_rd_left(&d->c)) {
		return fail(d, BC_EPROTO_COUNT,
		            "%s %u needs at least %zu bytes, %zu left", what, n,
		            (size_t)n * elem, bc_rd_left(&d->c));
	}
	return 0;
}

/* Grows one array of the store to hold need elements. The counts that
 * reach here are bounded by proto_limits.h, so this never grows far. */
static int reserve(struct dec *d, void **arr, size_t *cap, size_t need,
                   size_t size)
{
	if (need <= *cap) {
		return 0;
	}
	size_t n = *cap ? *cap : 16;
	while (n < need) {
		n *= 2;
	}
	void *p = bc_reallocarray(*arr, n, size);
	if (!p) {
		return fail(d, BC_ENOMEM, "no memory for %zu elements", n);
	}
	*arr = p;
	*cap = n;
	return 0;
}

/* ---- Types ----------------------------------------------------------------
 */

static int dec_hello(struct dec *d, struct bc_msg_hello *h)
{
	TRY(rd_u16(d, "version_min", &h->version_min));
	if (h->version_min == 0) {
		return fail(d, BC_ERANGE, "version_min is 0");
	}
	TRY(rd_u16(d, "version_max", &h->version_max));
	if (h->version_max < h->version_min) {
		return fail(d, BC_ERANGE, "version_max %u < version_min %u",
		            (unsigned)h->version_max, (unsigned)h->version_min);
	}
	TRY(rd_u8(d, "encodings", &h->encodings));
	if (h->encodings & ~BC_PROTO_ENCODINGS_ALL) {
		return fail(d, BC_EPROTO_FLAGS,
		            "encodings 0x%02x has reserved bits",
		            (unsigned)h->encodings);
	}
	TRY(rd_u32(d, "max_frame_bytes", &h->max_frame_bytes));
	if (h->max_frame_bytes != 0 &&
	    h->max_frame_bytes < BC_PROTO_MIN_FRAME_BYTES) {
		return fail(d, BC_ERANGE, "max_frame_bytes %u is under %u",
		            h->max_frame_bytes, BC_PROTO_MIN_FRAME_BYTES);
	}
	TRY(rd_str(d, "client_name", 0, BC_PROTO_MAX_NAME, &h->client_name));
	TRY(rd_str(d, "token", 0, BC_PROTO_MAX_TOKEN, &h->token));
	/* The features field: absent in an earlier client's HELLO. Bits this
	 * text does not name are a later client's features, not an error. */
	if (bc_rd_left(&d->c) != 0) {
		h->has_features = true;
		TRY(rd_u32(d, "features", &h->features));
	}
	return 0;
}

static int rd_u32_range(struct dec *d, const char *what, uint32_t lo,
                        uint32_t hi, uint32_t *v)
{
	TRY(rd_u32(d, what, v));
	if (*v < lo || *v > hi) {
		return fail(d, BC_ERANGE, "%s = %u is outside %u..%u", what, *v,
		            lo, hi);
	}
	return 0;
}

static int dec_welcome(struct dec *d, struct bc_msg_welcome *w)
{
	TRY(rd_u16_range(d, "version", 1, UINT16_MAX, &w->version));
	TRY(rd_id(d, "connection_id", &w->connection_id));
	TRY(rd_u32_range(d, "max_payload", BC_PROTO_HELLO_MAX_PAYLOAD,
	                 BC_PROTO_MAX_PAYLOAD, &w->max_payload));
	TRY(rd_u32_range(d, "max_frame_bytes", BC_PROTO_MIN_FRAME_BYTES,
	                 BC_PROTO_MAX_PAYLOAD, &w->max_frame_bytes));
	TRY(rd_u32_range(d, "max_nodes", 1, BC_PROTO_SCENE_MAX_NODES,
	                 &w->max_nodes));
	TRY(rd_u16_range(d, "max_dim", 1, BC_PROTO_MAX_DIM, &w->max_dim));
	TRY(rd_u16_range(d, "max_members", 1, BC_PROTO_MAX_MEMBERS,
	                 &w->max_members));
	TRY(rd_u16_range(d, "max_edit_ops", 1, BC_PROTO_MAX_EDIT_OPS,
	                 &w->max_edit_ops));
	TRY(rd_str(d, "server_id", 0, BC_PROTO_MAX_NAME, &w->server_id));
	/* Granted features: only an answer to a HELLO that announced some,
	 * and never a feature this text does not know. */
	if (bc_rd_left(&d->c) != 0) {
		w->has_features = true;
		TRY(rd_u32(d, "features", &w->features));
		if (w->features & ~BC_PROTO_FEATURES_ALL) {
			return fail(d, BC_EPROTO_FLAGS,
			            "features 0x%08x has undefined bits",
			            w->features);
		}
	}
	return 0;
}

static int dec_error(struct dec *d, struct bc_msg_error *e)
{
	TRY(rd_u16_range(d, "code", 1, UINT16_MAX, &e->code));
	TRY(rd_str(d, "text", 0, BC_PROTO_MAX_ERROR_TEXT, &e->text));
	return 0;
}

static int dec_session(struct dec *d, struct bc_msg_session *s)
{
	TRY(rd_role(d, "role", &s->role));
	TRY(rd_str(d, "name", 1, BC_PROTO_MAX_NAME, &s->name));
	return 0;
}

static int dec_session_info(struct dec *d, struct bc_msg_session_info *s)
{
	TRY(rd_id(d, "session_id", &s->session_id));
	TRY(rd_id(d, "member_id", &s->member_id));
	TRY(rd_role(d, "role", &s->role));
	TRY(rd_str(d, "name", 1, BC_PROTO_MAX_NAME, &s->name));
	TRY(rd_u16(d, "member_count", &s->nmembers));
	TRY(check_count(d, "member_count", s->nmembers, 1, BC_PROTO_MAX_MEMBERS,
	                MEMBER_MIN));
	struct bc_proto_member *out = NULL;
	if (d->store) {
		TRY(reserve(d, (void **)&d->store->members,
		            &d->store->members_cap, s->nmembers, sizeof(*out)));
		out = d->store->members;
	}
	for (unsigned i = 0; i < s->nmembers; i++) {
		struct bc_proto_member mb = {0};
		TRY(rd_id(d, "member.id", &mb.id));
		TRY(rd_role(d, "member.role", &mb.role));
		TRY(rd_str(d, "member.name", 0, BC_PROTO_MAX_NAME, &mb.name));
		if (out) {
			out[i] = mb;
		}
	}
	s->members = out;
	return 0;
}

static int dec_sessions(struct dec *d, struct bc_msg_sessions *l)
{
	struct bc_proto_session_entry *out = NULL;
	TRY(rd_u16(d, "session_count", &l->nsessions));
	TRY(check_count(d, "session_count", l->nsessions, 0,
	                BC_PROTO_MAX_SESSIONS_LISTED, SESSION_ENTRY_MIN));
	if (d->store && l->nsessions) {
		TRY(reserve(d, (void **)&d->store->sessions,
		            &d->store->sessions_cap, l->nsessions,
		            sizeof(*out)));
		out = d->store->sessions;
	}
	for (unsigned i = 0; i < l->nsessions; i++) {
		struct bc_proto_session_entry e = {0};
		TRY(rd_str(d, "session.name", 1, BC_PROTO_MAX_NAME, &e.name));
		TRY(rd_u16(d, "session.members", &e.members));
		TRY(rd_u32(d, "session.prims", &e.prims));
		TRY(rd_u64(d, "session.order", &e.order));
		TRY(rd_u64(d, "session.last_edit_ms", &e.last_edit_ms));
		TRY(rd_u8(d, "session.flags", &e.flags));
		if (e.flags & ~BC_PROTO_SESSION_FLAGS_ALL) {
			return fail(d, BC_EPROTO_FLAGS,
			            "session flags 0x%02x has undefined bits",
			            (unsigned)e.flags);
		}
		if (out) {
			out[i] = e;
		}
	}
	l->sessions = out;
	return 0;
}

static int dec_field(struct dec *d, uint64_t *seen, struct bc_proto_field *f)
{
	TRY(rd_u8(d, "field", &f->field));
	/* Field numbers and the value counts each takes: the table of
	 * proto_fields.h. */
	const struct bc_proto_field_info *info = bc_proto_field_info(f->field);
	if (!info) {
		return fail(d, BC_EENUM, "field %u is not a field number",
		            (unsigned)f->field);
	}
	/* Field numbers are below 64, so one bit each. */
	if (*seen & (UINT64_C(1) << f->field)) {
		return fail(d, BC_EPARSE, "field %u given twice",
		            (unsigned)f->field);
	}
	*seen |= UINT64_C(1) << f->field;
	TRY(rd_u8(d, "field.count", &f->count));
	if (f->count < info->min_values || f->count > info->max_values) {
		if (info->min_values == info->max_values) {
			return fail(d, BC_EPROTO_COUNT,
			            "field %u has %u values, expected %u",
			            (unsigned)f->field, (unsigned)f->count,
			            (unsigned)info->max_values);
		}
		return fail(d, BC_EPROTO_COUNT,
		            "field %u has %u values, expected %u..%u",
		            (unsigned)f->field, (unsigned)f->count,
		            (unsigned)info->min_values,
		            (unsigned)info->max_values);
	}
	if ((size_t)f->count * 4u > bc_rd_left(&d->c)) {
		return fail(d, BC_EPROTO_COUNT,
		            "field %u: %u values need %u bytes, %zu left",
		            (unsigned)f->field, (unsigned)f->count,
		            4u * f->count, bc_rd_left(&d->c));
	}
	for (unsigned k = 0; k < f->count; k++) {
		TRY(rd_f32_abs(d, "field value", &f->v[k]));
	}
	/* An operator kind's value (an integer 1..6) is meaning, checked by
	 * the server when it applies the SET (PROTOCOL.md 9): refused there
	 * with a non-fatal EENUM, not here with a fatal one. */
	return 0;
}

static int dec_ops(struct dec *d, uint16_t *nops,
                   const struct bc_proto_edit_op **ops_out)
{
	TRY(rd_u16(d, "op_count", nops));
	TRY(check_count(d, "op_count", *nops, 1, BC_PROTO_MAX_EDIT_OPS,
	                OP_MIN));
	struct bc_proto_edit_op *ops = NULL;
	struct bc_proto_store *st = d->store;
	if (st) {
		TRY(reserve(d, (void **)&st->ops, &st->ops_cap, *nops,
		            sizeof(*ops)));
		ops = st->ops;
	}
	size_t nfields = 0;
	for (unsigned i = 0; i < *nops; i++) {
		struct bc_proto_edit_op op = {0};
		uint8_t kind;
		TRY(rd_u8(d, "op.kind", &kind));
		if (kind == 0 || kind >= BC_PROTO_EDIT_COUNT) {
			return fail(d, BC_EENUM, "op %u: kind %u is unknown", i,
			            (unsigned)kind);
		}
		op.kind = (enum bc_proto_edit_kind)kind;
		switch (op.kind) {
		case BC_PROTO_EDIT_SET: {
			TRY(rd_id(d, "op.node", &op.node));
			TRY(rd_u8(d, "op.field_count", &op.nfields));
			TRY(check_count(d, "op.field_count", op.nfields, 1,
			                BC_PROTO_MAX_SET_FIELDS, FIELD_MIN));
			if (st) {
				TRY(reserve(
				    d, (void **)&st->fields, &st->fields_cap,
				    nfields + op.nfields, sizeof(*st->fields)));
			}
			uint64_t seen = 0;
			for (unsigned k = 0; k < op.nfields; k++) {
				struct bc_proto_field f = {0};
				TRY(dec_field(d, &seen, &f));
				if (st) {
					st->fields[nfields + k] = f;
				}
			}
			nfields += op.nfields;
			break;
		}
		case BC_PROTO_EDIT_INSERT:
			TRY(rd_id(d, "op.parent", &op.node));
			TRY(rd_u32(d, "op.position", &op.position));
			TRY(rd_blob(d, "op.subtree", &op.subtree));
			break;
		case BC_PROTO_EDIT_REMOVE:
			TRY(rd_id(d, "op.node", &op.node));
			break;
		case BC_PROTO_EDIT_REPLACE:
			TRY(rd_id(d, "op.node", &op.node));
			TRY(rd_blob(d, "op.subtree", &op.subtree));
			break;
		case BC_PROTO_EDIT_NAME:
			TRY(rd_id(d, "op.node", &op.node));
			TRY(rd_str(d, "op.name", 0, BC_PROTO_MAX_NAME,
			           &op.name));
			break;
		default:
			break;
		}
		if (ops) {
			ops[i] = op;
		}
	}
	/* The fields array may have moved while it grew: point the set
	 * operations at their fields only now. */
	if (ops) {
		size_t k = 0;
		for (unsigned i = 0; i < *nops; i++) {
			if (ops[i].kind == BC_PROTO_EDIT_SET) {
				ops[i].fields = st->fields + k;
				k += ops[i].nfields;
			}
		}
	}
	*ops_out = ops;
	return 0;
}

/* The origin of an applied change, as EDIT_APPLIED and SESSION_CAMERA_SET
 * carry it: its order (from 1), its author's id and the author's seq. */
static int dec_origin(struct dec *d, uint64_t *order, uint32_t *author,
                      uint32_t *author_seq)
{
	TRY(rd_u64(d, "order", order));
	if (*order == 0) {
		return fail(d, BC_ERANGE, "order is 0");
	}
	TRY(rd_id(d, "author", author));
	return rd_u32(d, "author_seq", author_seq);
}

static int dec_camera(struct dec *d, struct bc_msg_camera *c)
{
	static const char *const names[3][3] = {
	    {"eye.x", "eye.y", "eye.z"},
	    {"target.x", "target.y", "target.z"},
	    {"up.x", "up.y", "up.z"},
	};
	float *vec[3] = {c->eye, c->target, c->up};
	for (int i = 0; i < 3; i++) {
		for (int k = 0; k < 3; k++) {
			TRY(rd_f32_abs(d, names[i][k], &vec[i][k]));
		}
	}
	TRY(rd_f32(d, "fov_y_deg", &c->fov_y_deg));
	if (!(c->fov_y_deg > 0.0f && c->fov_y_deg < 180.0f)) {
		return fail(d, BC_ERANGE, "fov_y_deg %g is outside (0, 180)",
		            (double)c->fov_y_deg);
	}
	return 0;
}

static int dec_view(struct dec *d, struct bc_msg_view *v)
{
	TRY(rd_u16_range(d, "width", 1, BC_PROTO_MAX_DIM, &v->width));
	TRY(rd_u16_range(d, "height", 1, BC_PROTO_MAX_DIM, &v->height));
	TRY(rd_encoding(d, "encoding", &v->encoding));
	TRY(rd_u8_range(d, "quality_interactive", 1, BC_PROTO_MAX_QUALITY,
	                &v->quality_interactive));
	TRY(rd_u8_range(d, "quality_still", 1, BC_PROTO_MAX_QUALITY,
	                &v->quality_still));
	TRY(rd_u8_range(d, "downscale", 1, BC_PROTO_MAX_DOWNSCALE,
	                &v->downscale));
	/* still_encoding is optional: left out, the still is in encoding. */
	v->still_encoding = BC_PROTO_ENC_INVALID;
	if (bc_rd_left(&d->c) == 0) {
		return 0;
	}
	TRY(rd_encoding(d, "still_encoding", &v->still_encoding));
	if (v->still_encoding == BC_PROTO_ENC_H264) {
		return fail(d, BC_EENUM,
		            "still_encoding 4: an H.264 still is asked by "
		            "leaving the byte out");
	}
	return 0;
}

/* VIEW's downscale names the coarsest block a client accepts; the coarsest
 * level's block must be exactly the largest downscale. */
_Static_assert((1u << BC_PROTO_MAX_LEVEL) == BC_PROTO_MAX_DOWNSCALE,
               "the coarsest level is the largest downscale");

static int dec_frame(struct dec *d, struct bc_msg_frame *f)
{
	bool snap = (d->m->flags & BC_PROTO_FLAG_SNAPSHOT) != 0;
	bool full = snap || (d->m->flags & BC_PROTO_FLAG_STILL);
	/* The header rule (bc__check_flags) keeps STILL and SNAPSHOT off
	 * levels above 0, so full and level > 0 never meet. */
	unsigned level = bc_proto_flags_level(d->m->flags);
	/* A snapshot and a refinement frame are one rectangle that is the
	 * whole image. */
	bool whole = snap || level > 0;
	/* A snapshot's colour rectangle is followed by one per plane asked
	 * (the header rule keeps DEPTH and IDS on snapshots). */
	unsigned nwhole = 1u + bc_proto_flags_nplanes(d->m->flags);
	TRY(rd_u32(d, "frame_no", &f->frame_no));
	TRY(rd_u64(d, "order", &f->order));
	TRY(rd_u32(d, "camera_seq", &f->camera_seq));
	TRY(rd_encoding(d, "encoding", &f->encoding));
	if (snap && (f->encoding == BC_PROTO_ENC_JPEG ||
	             f->encoding == BC_PROTO_ENC_H264)) {
		return fail(d, BC_EENUM, "a snapshot cannot be %s",
		            bc_proto_encoding_name(f->encoding));
	}
	/* H.264: one access unit of the whole view at every level. */
	bool video = f->encoding == BC_PROTO_ENC_H264;
	if ((d->m->flags & BC_PROTO_FLAG_KEY) && !video) {
		return fail(d, BC_EPROTO_FLAGS,
		            "KEY on a FRAME of encoding %u (only H.264 has "
		            "key frames)",
		            (unsigned)f->encoding);
	}
	whole = whole || video;
	TRY(rd_u16_range(d, "width", 1, BC_PROTO_MAX_DIM, &f->width));
	TRY(rd_u16_range(d, "height", 1, BC_PROTO_MAX_DIM, &f->height));
	/* Level n: one ray per 2^n block, so exactly the blocks that cover
	 * the view; level 0: at most the view (the view itself when full). */
	uint16_t iw = video ? f->width : bc_proto_level_dim(f->width, level);
	uint16_t ih = video ? f->height : bc_proto_level_dim(f->height, level);
	bool fixed = full || level > 0 || video;
	TRY(rd_u16_range(d, "image_width", fixed ? iw : 1, iw,
	                 &f->image_width));
	TRY(rd_u16_range(d, "image_height", fixed ? ih : 1, ih,
	                 &f->image_height));
	TRY(rd_u16(d, "rect_count", &f->nrects));
	TRY(check_count(d, "rect_count", f->nrects, snap ? nwhole : 1u,
	                whole ? nwhole : BC_PROTO_MAX_RECTS, RECT_MIN));
	struct bc_proto_rect *out = NULL;
	if (d->store) {
		TRY(reserve(d, (void **)&d->store->rects, &d->store->rects_cap,
		            f->nrects, sizeof(*out)));
		out = d->store->rects;
	}
	for (unsigned i = 0; i < f->nrects; i++) {
		struct bc_proto_rect r = {0};
		TRY(rd_u16(d, "rect.x", &r.x));
		TRY(rd_u16(d, "rect.y", &r.y));
		TRY(rd_u16(d, "rect.w", &r.w));
		/* A snapshot's or a refinement's one rectangle is the
		 * whole image. */
		unsigned wmin = whole ? f->image_width : 1u;
		if (r.w < wmin || (unsigned)r.x + r.w > f->image_width) {
			return fail(d, BC_ERANGE,
			            "rect %u: x %u + w %u is outside 1..%u", i,
			            (unsigned)r.x, (unsigned)r.w,
			            (unsigned)f->image_width);
		}
		TRY(rd_u16(d, "rect.h", &r.h));
		unsigned hmin = whole ? f->image_height : 1u;
		if (r.h < hmin || (unsigned)r.y + r.h > f->image_height) {
			return fail(d, BC_ERANGE,
			            "rect %u: y %u + h %u is outside 1..%u", i,
			            (unsigned)r.y, (unsigned)r.h,
			            (unsigned)f->image_height);
		}
		uint32_t n;
		TRY(rd_u32(d, "rect.length", &n));
		uint64_t raw = (uint64_t)r.w * r.h * 4u;
		/* A plane (every rectangle after a snapshot's first) is 4
		 * bytes a pixel whatever the colour's encoding. */
		bool plane = snap && i > 0;
		bool exact = f->encoding == BC_PROTO_ENC_RAW || plane;
		if (n == 0 || (exact && n != raw)) {
			return fail(d, BC_EPROTO_LENGTH,
			            "rect %u: length %u (%s needs %llu)", i, n,
			            plane ? "a plane" : "raw",
			            (unsigned long long)raw);
		}
		if (n > bc_rd_left(&d->c)) {
			return truncated(d, "rect.data", n);
		}
		r.data.ptr = d->c.p + d->c.pos;
		r.data.len = n;
		d->c.pos += n;
		if (out) {
			out[i] = r;
		}
	}
	f->rects = out;
	return 0;
}

/* SNAPSHOT's tile form: the picture's size, then the tile inside it. */
static int dec_snapshot_tile(struct dec *d, struct bc_msg_snapshot *s)
{
	TRY(rd_u16_range(d, "full_width", 1, BC_PROTO_MAX_DIM, &s->full_width));
	TRY(rd_u16_range(d, "full_height", 1, BC_PROTO_MAX_DIM,
	                 &s->full_height));
	TRY(rd_u16_range(d, "tile_x", 0, s->full_width - 1u, &s->tile_x));
	TRY(rd_u16_range(d, "tile_y", 0, s->full_height - 1u, &s->tile_y));
	TRY(rd_u16_range(d, "tile_width", 1, s->full_width - s->tile_x,
	                 &s->tile_width));
	return rd_u16_range(d, "tile_height", 1, s->full_height - s->tile_y,
	                    &s->tile_height);
}

static int dec_pick_result(struct dec *d, struct bc_msg_pick_result *p)
{
	static const char *const names[3] = {"position.x", "position.y",
	                                     "position.z"};
	TRY(rd_u16(d, "x", &p->x));
	TRY(rd_u16(d, "y", &p->y));
	TRY(rd_u32(d, "node", &p->node));
	for (int k = 0; k < 3; k++) {
		TRY(rd_f32(d, names[k], &p->position[k]));
		if (p->node == 0 && p->position[k] != 0.0f) {
			return fail(d, BC_ERANGE, "a miss has %s != 0",
			            names[k]);
		}
	}
	TRY(rd_f32_nonneg(d, "depth", &p->depth));
	if (p->node == 0 && p->depth != 0.0f) {
		return fail(d, BC_ERANGE, "a miss has depth != 0");
	}
	return 0;
}

/* STATS's optional load and TLS sections (PROTOCOL.md 7.18). */
#define STATS_LOAD_BYTES 44u
#define STATS_TLS_BYTES 9u
#define STATS_LINK_BYTES 32u
#define STATS_MEMORY_BYTES 28u

static int dec_stats_load(struct dec *d, struct bc_proto_load *l)
{
	TRY(rd_f32_nonneg(d, "loop_turn_max_ms", &l->loop_turn_max_ms));
	TRY(rd_f32_nonneg(d, "loop_request_max_ms", &l->loop_request_max_ms));
	TRY(rd_u32(d, "render_workers", &l->render_workers));
	TRY(rd_u32(d, "jobs_queued", &l->jobs_queued));
	TRY(rd_u32(d, "jobs_running", &l->jobs_running));
	TRY(rd_u64(d, "view_bytes", &l->view_bytes));
	TRY(rd_u64(d, "view_cap", &l->view_cap));
	TRY(rd_u64(d, "session_render_us", &l->session_render_us));
	return 0;
}

static int dec_stats(struct dec *d, struct bc_msg_stats *s)
{
	size_t left;
	TRY(rd_u64(d, "uptime_ms", &s->uptime_ms));
	TRY(rd_u64(d, "frames", &s->frames));
	TRY(rd_u64(d, "bytes", &s->bytes));
	TRY(rd_u64(d, "order", &s->order));
	TRY(rd_u32(d, "sessions", &s->sessions));
	TRY(rd_u32(d, "clients", &s->clients));
	TRY(rd_f32_nonneg(d, "render_ms_last", &s->render_ms_last));
	TRY(rd_f32_nonneg(d, "render_ms_avg", &s->render_ms_avg));
	TRY(rd_f32_nonneg(d, "encode_ms_last", &s->encode_ms_last));
	TRY(rd_f32_nonneg(d, "encode_ms_avg", &s->encode_ms_avg));
	TRY(rd_f32_nonneg(d, "edit_ms_avg", &s->edit_ms_avg));
	TRY(rd_f32_nonneg(d, "fps", &s->fps));
	/* The sections follow only when the client asked for them, in the
	 * order load, TLS, link, memory: the payload's length tells which
	 * (every sum of 44, 9, 32 and 28 differs); anything else is bytes
	 * after the last field. */
	left = bc_rd_left(&d->c);
	bool load = false, tls = false, link = false, memory = false;
	for (unsigned k = 0; k < 16; k++) {
		if (left == ((k & 1u) ? STATS_LOAD_BYTES : 0u) +
		                ((k & 2u) ? STATS_TLS_BYTES : 0u) +
		                ((k & 4u) ? STATS_LINK_BYTES : 0u) +
		                ((k & 8u) ? STATS_MEMORY_BYTES : 0u)) {
			load = (k & 1u) != 0;
			tls = (k & 2u) != 0;
			link = (k & 4u) != 0;
			memory = (k & 8u) != 0;
			break;
		}
		if (k == 15) {
			return fail(d, BC_EPROTO_TRAILING,
			            "%zu bytes after the last field, not a "
			            "load, TLS, link or memory section",
			            left);
		}
	}
	if (load) {
		s->has_load = true;
		TRY(dec_stats_load(d, &s->load));
	}
	if (tls) {
		s->has_tls = true;
		TRY(rd_u64(d, "tls_not_after_ms", &s->tls_not_after_ms));
		TRY(rd_u8(d, "tls_expiring", &s->tls_expiring));
		if (s->tls_expiring > 1) {
			return fail(d, BC_ERANGE,
			            "tls_expiring %u is not 0 or 1",
			            (unsigned)s->tls_expiring);
		}
	}
	if (link) {
		struct bc_proto_link *l = &s->link;
		s->has_link = true;
		TRY(rd_u32(d, "rtt_us", &l->rtt_us));
		TRY(rd_u32(d, "min_rtt_us", &l->min_rtt_us));
		TRY(rd_u64(d, "delivery_bps", &l->delivery_bps));
		TRY(rd_u32(d, "unacked_bytes", &l->unacked_bytes));
		TRY(rd_u32(d, "frames_paced", &l->frames_paced));
		TRY(rd_u64(d, "frames_spoiled", &l->frames_spoiled));
	}
	if (memory) {
		struct bc_proto_memory *mm = &s->memory;
		s->has_memory = true;
		TRY(rd_u64(d, "scene_nodes", &mm->scene_nodes));
		TRY(rd_u64(d, "scene_nodes_cap", &mm->scene_nodes_cap));
		TRY(rd_u64(d, "session_nodes", &mm->session_nodes));
		TRY(rd_u32(d, "sessions_loaded", &mm->sessions_loaded));
	}
	return 0;
}

/* GET_STATS: empty, or one byte of parts (PROTOCOL.md 7.18). */
static int dec_get_stats(struct dec *d, struct bc_msg_get_stats *g)
{
	if (bc_rd_left(&d->c) == 0) {
		return 0;
	}
	TRY(rd_u8(d, "parts", &g->parts));
	if (g->parts & ~BC_PROTO_STATS_PARTS_ALL) {
		return fail(d, BC_EPROTO_FLAGS,
		            "parts 0x%02x has undefined bits",
		            (unsigned)g->parts);
	}
	if (g->parts == 0) {
		return fail(d, BC_ERANGE, "parts 0 (leave it out)");
	}
	if ((g->parts & BC_PROTO_STATS_RESET) &&
	    !(g->parts & BC_PROTO_STATS_LOAD)) {
		return fail(d, BC_ERANGE, "parts RESET without LOAD");
	}
	return 0;
}

static int dec_history(struct dec *d, struct bc_msg_history *h)
{
	struct bc_proto_history_entry *out = NULL;
	TRY(rd_u64(d, "order", &h->order));
	TRY(rd_u16(d, "entry_count", &h->nentries));
	TRY(check_count(d, "entry_count", h->nentries, 0, BC_PROTO_MAX_HISTORY,
	                HISTORY_ENTRY_MIN));
	if (d->store && h->nentries) {
		TRY(reserve(d, (void **)&d->store->history,
		            &d->store->history_cap, h->nentries, sizeof(*out)));
		out = d->store->history;
	}
	for (unsigned i = 0; i < h->nentries; i++) {
		struct bc_proto_history_entry e = {0};
		TRY(rd_u64(d, "entry.order", &e.order));
		if (e.order == 0) {
			return fail(d, BC_ERANGE, "entry.order is 0");
		}
		TRY(rd_u64(d, "entry.time_ms", &e.time_ms));
		TRY(rd_u64(d, "entry.built_on", &e.built_on));
		TRY(rd_u8(d, "entry.state", &e.state));
		if (e.state == 0 || e.state >= BC_PROTO_HISTORY_STATE_COUNT) {
			return fail(d, BC_EENUM, "entry.state %u is unknown",
			            (unsigned)e.state);
		}
		TRY(rd_u8(d, "entry.flags", &e.flags));
		if (e.flags & ~BC_PROTO_HISTORY_FLAGS_ALL) {
			return fail(d, BC_EPROTO_FLAGS,
			            "entry flags 0x%02x has undefined bits",
			            (unsigned)e.flags);
		}
		TRY(rd_str(d, "entry.author", 0, BC_PROTO_MAX_NAME, &e.author));
		TRY(rd_str(d, "entry.what", 0, BC_PROTO_MAX_HISTORY_TEXT,
		           &e.what));
		if (out) {
			out[i] = e;
		}
	}
	h->entries = out;
	return 0;
}

/* UNDO and REDO: empty, or one byte of scope (PROTOCOL.md 7.20). */
static int dec_undo(struct dec *d, struct bc_msg_undo *u)
{
	u->scope = BC_PROTO_UNDO_DEFAULT;
	if (bc_rd_left(&d->c) == 0) {
		return 0;
	}
	TRY(rd_u8(d, "scope", &u->scope));
	if (u->scope == 0 || u->scope >= BC_PROTO_UNDO_SCOPE_COUNT) {
		return fail(d, BC_EENUM, "scope %u is unknown",
		            (unsigned)u->scope);
	}
	return 0;
}

/* MESH's and MESH_DATA's first fields: format, options and resolution
 * (lo: the one value under the least also allowed, a MESH's 0, which asks
 * for the default; BC_PROTO_MIN_MESH_RESOLUTION for MESH_DATA). */
static int dec_mesh_head(struct dec *d, enum bc_proto_mesh_format *format,
                         uint8_t *options, uint16_t *resolution, unsigned lo)
{
	uint8_t v;
	TRY(rd_u8(d, "format", &v));
	if (v == 0 || v >= BC_PROTO_MESH_FORMAT_COUNT) {
		return fail(d, BC_EENUM, "format = %u is not a mesh format",
		            (unsigned)v);
	}
	*format = (enum bc_proto_mesh_format)v;
	TRY(rd_u8(d, "options", options));
	if (*options & ~BC_PROTO_MESH_OPTIONS_ALL) {
		return fail(d, BC_EPROTO_FLAGS,
		            "options 0x%02x has undefined bits",
		            (unsigned)*options);
	}
	TRY(rd_u16(d, "resolution", resolution));
	if ((*resolution < BC_PROTO_MIN_MESH_RESOLUTION && *resolution != lo) ||
	    *resolution > BC_PROTO_MAX_MESH_RESOLUTION) {
		return fail(d, BC_ERANGE, "resolution = %u is outside %u..%u%s",
		            (unsigned)*resolution, BC_PROTO_MIN_MESH_RESOLUTION,
		            BC_PROTO_MAX_MESH_RESOLUTION,
		            lo == 0 ? " (0: the default)" : "");
	}
	return 0;
}

static int dec_mesh_data(struct dec *d, struct bc_msg_mesh_data *md)
{
	TRY(dec_mesh_head(d, &md->format, &md->options, &md->resolution,
	                  BC_PROTO_MIN_MESH_RESOLUTION));
	TRY(rd_u64(d, "order", &md->order));
	TRY(rd_u32(d, "vertices", &md->vertices));
	TRY(rd_u32(d, "triangles", &md->triangles));
	return rd_blob(d, "file", &md->file);
}

static int dec_body(struct dec *d, struct bc_msg *m)
{
	switch (m->type) {
	case BC_MSG_HELLO:
		return dec_hello(d, &m->hello);
	case BC_MSG_WELCOME:
		return dec_welcome(d, &m->welcome);
	case BC_MSG_ERROR:
		return dec_error(d, &m->error);
	case BC_MSG_PING:
	case BC_MSG_PONG:
		return rd_u64(d, "stamp", &m->ping.stamp);
	case BC_MSG_GET_STATS:
		return dec_get_stats(d, &m->get_stats);
	case BC_MSG_OK:
	case BC_MSG_SESSION_LEAVE:
	case BC_MSG_SESSION_LIST:
	case BC_MSG_HISTORY_GET:
		return 0;
	case BC_MSG_UNDO:
	case BC_MSG_REDO:
		return dec_undo(d, &m->undo);
	case BC_MSG_HISTORY:
		return dec_history(d, &m->history);
	case BC_MSG_SESSIONS:
		return dec_sessions(d, &m->sessions);
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		return dec_session(d, &m->session);
	case BC_MSG_SESSION_INFO:
		return dec_session_info(d, &m->session_info);
	case BC_MSG_SCENE_LOAD:
		return rd_blob(d, "scene", &m->scene_load.scene);
	case BC_MSG_SCENE_STATE:
		TRY(rd_u64(d, "order", &m->scene_state.order));
		TRY(rd_u32(d, "author", &m->scene_state.author));
		TRY(rd_u32(d, "author_seq", &m->scene_state.author_seq));
		return rd_blob(d, "scene", &m->scene_state.scene);
	case BC_MSG_EDIT:
		return dec_ops(d, &m->edit.nops, &m->edit.ops);
	case BC_MSG_EDIT_APPLIED: {
		struct bc_msg_edit_applied *a = &m->edit_applied;
		TRY(dec_origin(d, &a->order, &a->author, &a->author_seq));
		TRY(dec_ops(d, &a->nops, &a->ops));
		a->target_order = 0;
		a->target_author = (struct bc_proto_str){NULL, 0};
		if (!(d->m->flags &
		      (BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO))) {
			return 0;
		}
		if ((d->m->flags & BC_PROTO_FLAG_UNDO) &&
		    (d->m->flags & BC_PROTO_FLAG_REDO)) {
			return fail(d, BC_EPROTO_FLAGS,
			            "EDIT_APPLIED with both UNDO and REDO");
		}
		TRY(rd_u64(d, "target_order", &a->target_order));
		if (a->target_order == 0) {
			return fail(d, BC_ERANGE, "target_order is 0");
		}
		return rd_str(d, "target_author", 0, BC_PROTO_MAX_NAME,
		              &a->target_author);
	}
	case BC_MSG_CAMERA:
		return dec_camera(d, &m->camera);
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
		return rd_u8_range(d, "on", 0, 1, &m->toggle.on);
	case BC_MSG_PRESENTER:
		TRY(rd_u32(d, "presenter", &m->presenter.presenter));
		TRY(rd_u8_range(d, "following", 0, 1, &m->presenter.following));
		if (m->presenter.following && m->presenter.presenter == 0) {
			return fail(d, BC_ERANGE,
			            "following 1 while nobody presents");
		}
		return 0;
	case BC_MSG_FOLLOW_CAMERA:
		TRY(rd_id(d, "presenter", &m->follow_camera.presenter));
		return dec_camera(d, &m->follow_camera.camera);
	case BC_MSG_SESSION_CAMERA:
		return dec_camera(d, &m->session_camera);
	case BC_MSG_SESSION_CAMERA_SET: {
		struct bc_msg_session_camera_set *c = &m->session_camera_set;
		TRY(dec_origin(d, &c->order, &c->author, &c->author_seq));
		return dec_camera(d, &c->camera);
	}
	case BC_MSG_VIEW:
		return dec_view(d, &m->view);
	case BC_MSG_FRAME:
		return dec_frame(d, &m->frame);
	case BC_MSG_FRAME_ACK:
		return rd_u32_range(d, "frame_no", 1, UINT32_MAX,
		                    &m->frame_ack.frame_no);
	case BC_MSG_MESH:
		return dec_mesh_head(d, &m->mesh.format, &m->mesh.options,
		                     &m->mesh.resolution, 0);
	case BC_MSG_MESH_DATA:
		return dec_mesh_data(d, &m->mesh_data);
	case BC_MSG_PICK:
		TRY(rd_u16(d, "x", &m->pick.x));
		return rd_u16(d, "y", &m->pick.y);
	case BC_MSG_PICK_RESULT:
		return dec_pick_result(d, &m->pick_result);
	case BC_MSG_SNAPSHOT: {
		TRY(rd_encoding(d, "encoding", &m->snapshot.encoding));
		if (m->snapshot.encoding == BC_PROTO_ENC_JPEG) {
			return fail(d, BC_EENUM, "a snapshot cannot be JPEG");
		}
		/* planes is optional: a colour-only SNAPSHOT may stop here. */
		m->snapshot.planes = 0;
		if (bc_rd_left(&d->c) == 0) {
			return 0;
		}
		TRY(rd_u8(d, "planes", &m->snapshot.planes));
		if (m->snapshot.planes & ~BC_PROTO_PLANES_ALL) {
			return fail(d, BC_EPROTO_FLAGS,
			            "planes 0x%02x has undefined bits",
			            (unsigned)m->snapshot.planes);
		}
		m->snapshot.has_tile = bc_rd_left(&d->c) > 0;
		if (!m->snapshot.has_tile) {
			/* Colour only leaves the byte out: one encoding per
			 * SNAPSHOT. */
			if (m->snapshot.planes == 0) {
				return fail(d, BC_ERANGE,
				            "planes 0 (leave it out)");
			}
			return 0;
		}
		return dec_snapshot_tile(d, &m->snapshot);
	}
	case BC_MSG_STATS:
		return dec_stats(d, &m->stats);
	case BC_MSG_SESSION_DELETE:
		return rd_str(d, "name", 1, BC_PROTO_MAX_NAME,
		              &m->session_delete.name);
	default:
		return fail(d, BC_EPROTO_TYPE, "type %d is unknown",
		            (int)m->type);
	}
}

int bc__decode_payload(struct bc_proto_store *store, struct bc_msg *out,
                       const uint8_t *payload, size_t len,
                       struct bc_errinfo *ei)
{
	struct dec d = {
	    .c = bc_rd_init(payload, len),
	    .store = store,
	    .ei = ei,
	    .m = out,
	};
	TRY(dec_body(&d, out));
	if (bc_rd_left(&d.c)) {
		return fail(&d, BC_EPROTO_TRAILING,
		            "%zu bytes after the last field", bc_rd_left(&d.c));
	}
	return 0;
}

void bc__store_free(struct bc_proto_store *s)
{
	bc_free(s->members);
	bc_free(s->ops);
	bc_free(s->fields);
	bc_free(s->rects);
	bc_free(s->sessions);
	bc_free(s->history);
	memset(s, 0, sizeof(*s));
}
