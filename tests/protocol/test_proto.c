/*
 * Unit tests of the protocol codec: table-driven malformed input (each row
 * a byte string and the error PROTOCOL.md documents for it), round trips of
 * every message type, the reader's stream rules (stages, sides, limits,
 * sticky errors, arbitrary splits of the input), the encoder's refusals,
 * and an allocation-failure loop. Run under ASan and UBSan by the test
 * command, so "never a crash" is checked, not assumed.
 */
#include <stdint.h>

#include "blobcast/alloc.h"
#include "blobcast/proto.h"
#include "blobcast/render.h"
#include "test.h"

/* The kinds and limits the protocol repeats from blobtree are asserted in
 * edit/fields.c, which every build compiles; render is not the edit
 * module's business, so its limit is held here. */
_Static_assert(BC_PROTO_MAX_DIM == BC_RENDER_MAX_DIM,
               "frame size limit differs from render's");

/* ---- Byte building ----------------------------------------------------------
 */

struct bytes {
	uint8_t b[8192];
	size_t n;
};

static void p8(struct bytes *s, unsigned v)
{
	s->b[s->n++] = (uint8_t)v;
}

static void p16(struct bytes *s, unsigned v)
{
	p8(s, v & 0xff);
	p8(s, (v >> 8) & 0xff);
}

static void p32(struct bytes *s, uint32_t v)
{
	p16(s, v & 0xffff);
	p16(s, v >> 16);
}

static void pf(struct bytes *s, float f)
{
	uint32_t u;
	memcpy(&u, &f, 4);
	p32(s, u);
}

static void praw(struct bytes *s, const void *p, size_t n)
{
	memcpy(s->b + s->n, p, n);
	s->n += n;
}

static void hdr(struct bytes *s, unsigned type, uint32_t len)
{
	praw(s, "BCST", 4);
	p8(s, BC_PROTO_VERSION);
	p8(s, type);
	p16(s, 0);
	p32(s, len);
	p32(s, 1);
}

/* Feeds all bytes, drains, ends the stream; returns the final code. */
static int decode_all(const struct bc_proto_reader_opts *o, const uint8_t *b,
                      size_t n, int *nmsgs)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	int rc = bc_proto_reader_init(&r, o);
	int count = 0;
	if (rc == 0) {
		rc = bc_proto_reader_feed(&r, b, n);
	}
	while (rc >= 0 && (rc = bc_proto_reader_next(&r, &m)) == 1) {
		count++;
	}
	if (rc == 0) {
		rc = bc_proto_reader_eof(&r);
	}
	bc_proto_reader_finish(&r);
	if (nmsgs) {
		*nmsgs = count;
	}
	return rc;
}

/* ---- Malformed input, one row per case
 * ---------------------------------------- */

enum build_case {
	C_EMPTY_STREAM,
	C_TRUNC_HEADER,
	C_TRUNC_BODY,
	C_LEN0_CAMERA,
	C_LEN0_EMPTY_TYPE,
	C_LIMIT_PLUS1,
	C_LEN_2_31,
	C_LEN_2_32M1,
	C_LIMIT_EXACT_WAITS,
	C_UNKNOWN_TYPE,
	C_WRONG_VERSION,
	C_WRONG_MAGIC,
	C_RESERVED_FLAGS,
	C_COUNT_OVER_BYTES,
	C_COUNT_OVER_LIMIT,
	C_STRING_OVER_BYTES,
	C_STRING_BAD_UTF8,
	C_NAN_CAMERA,
	C_INF_CAMERA,
	C_NEGINF_FIELD,
	C_NAN_STATS,
	C_SHORT_PICK,
	C_TRAILING,
	C_BAD_ENUM,
	C_PRE_HELLO_EDIT,
	C_WRONG_SIDE,
};

static void build_case(enum build_case c, struct bytes *s)
{
	memset(s, 0, sizeof(*s));
	switch (c) {
	case C_EMPTY_STREAM:
		break;
	case C_TRUNC_HEADER:
		hdr(s, BC_MSG_PING, 8);
		s->n = 11;
		break;
	case C_TRUNC_BODY:
		hdr(s, BC_MSG_PING, 8);
		p32(s, 1); /* 4 of the 8 stamp bytes, then the stream ends */
		break;
	case C_LEN0_CAMERA:
		hdr(s, BC_MSG_CAMERA, 0);
		break;
	case C_LEN0_EMPTY_TYPE: /* length 0 is right for OK: a message */
		hdr(s, BC_MSG_OK, 0);
		break;
	case C_LIMIT_PLUS1:
		hdr(s, BC_MSG_EDIT, BC_PROTO_MAX_PAYLOAD + 1);
		break;
	case C_LEN_2_31:
		hdr(s, BC_MSG_FRAME, 0x80000000u);
		break;
	case C_LEN_2_32M1:
		hdr(s, BC_MSG_SCENE_LOAD, 0xffffffffu);
		break;
	case C_LIMIT_EXACT_WAITS:
		hdr(s, BC_MSG_SCENE_LOAD, BC_PROTO_MAX_PAYLOAD);
		break;
	case C_UNKNOWN_TYPE:
		hdr(s, 200, 0);
		break;
	case C_WRONG_VERSION:
		hdr(s, BC_MSG_PING, 8);
		s->b[4] = 2;
		p32(s, 0);
		p32(s, 0);
		break;
	case C_WRONG_MAGIC:
		praw(s, "PNG", 3);
		break;
	case C_RESERVED_FLAGS:
		hdr(s, BC_MSG_PING, 8);
		s->b[7] = 0x80;
		p32(s, 0);
		p32(s, 0);
		break;
	case C_COUNT_OVER_BYTES: /* 100 ops declared, 2 bytes follow */
		hdr(s, BC_MSG_EDIT, 4);
		p16(s, 100);
		p16(s, 0);
		break;
	case C_COUNT_OVER_LIMIT: /* 65535 rects */
		hdr(s, BC_MSG_FRAME, 4 + 8 + 4 + 1 + 8 + 2);
		p32(s, 1);
		p32(s, 0);
		p32(s, 0);
		p32(s, 0);
		p8(s, BC_PROTO_ENC_JPEG);
		p16(s, 8);
		p16(s, 8);
		p16(s, 8);
		p16(s, 8);
		p16(s, 0xffff);
		break;
	case C_STRING_OVER_BYTES: /* name claims 60 bytes, 3 follow */
		hdr(s, BC_MSG_SESSION_JOIN, 1 + 2 + 3);
		p8(s, BC_PROTO_ROLE_VIEWER);
		p16(s, 60);
		praw(s, "abc", 3);
		break;
	case C_STRING_BAD_UTF8:
		hdr(s, BC_MSG_SESSION_JOIN, 1 + 2 + 2);
		p8(s, BC_PROTO_ROLE_VIEWER);
		p16(s, 2);
		praw(s, "\xc3\x28", 2);
		break;
	case C_NAN_CAMERA:
	case C_INF_CAMERA:
		hdr(s, BC_MSG_CAMERA, 40);
		for (int i = 0; i < 9; i++) {
			pf(s, i == 4 ? (c == C_NAN_CAMERA ? NAN : INFINITY)
			             : 1.0f);
		}
		pf(s, 45.0f);
		break;
	case C_NEGINF_FIELD: /* EDIT set: blend = -inf */
		hdr(s, BC_MSG_EDIT, 2 + 1 + 4 + 1 + 2 + 4);
		p16(s, 1);
		p8(s, BC_PROTO_EDIT_SET);
		p32(s, 1);
		p8(s, 1);
		p8(s, BC_PROTO_FIELD_BLEND);
		p8(s, 1);
		pf(s, -INFINITY);
		break;
	case C_NAN_STATS:
		hdr(s, BC_MSG_STATS, 64);
		for (int i = 0; i < 10; i++) {
			p32(s, 0);
		}
		for (int i = 0; i < 6; i++) {
			pf(s, i == 5 ? NAN : 1.0f);
		}
		break;
	case C_TRAILING: /* a JOIN with one byte after its name */
		hdr(s, BC_MSG_SESSION_JOIN, 1 + 2 + 1 + 1);
		p8(s, BC_PROTO_ROLE_VIEWER);
		p16(s, 1);
		praw(s, "ab", 2);
		break;
	case C_SHORT_PICK:
		hdr(s, BC_MSG_PICK, 4);
		p16(s, 1);
		p8(s, 2); /* a 3-byte PICK: y is short */
		s->b[8] = 3;
		break;
	case C_BAD_ENUM:
		hdr(s, BC_MSG_SNAPSHOT, 1);
		p8(s, 7);
		break;
	case C_PRE_HELLO_EDIT:
		hdr(s, BC_MSG_EDIT, 7);
		p16(s, 1);
		p8(s, BC_PROTO_EDIT_REMOVE);
		p32(s, 5);
		break;
	case C_WRONG_SIDE:
		hdr(s, BC_MSG_WELCOME, 0);
		break;
	}
}

static void test_malformed_table(void)
{
	static const struct bc_proto_reader_opts pre_hello = {
	    .side = BC_PROTO_SIDE_SERVER, .await_hello = true};
	static const struct bc_proto_reader_opts server = {
	    .side = BC_PROTO_SIDE_SERVER};
	static const struct {
		const char *name;
		enum build_case c;
		const struct bc_proto_reader_opts *opts;
		int want;
		int msgs;
	} rows[] = {
	    {"empty stream ends cleanly", C_EMPTY_STREAM, NULL, 0, 0},
	    {"truncated header", C_TRUNC_HEADER, NULL, BC_EPROTO_TRUNCATED, 0},
	    {"truncated body", C_TRUNC_BODY, NULL, BC_EPROTO_TRUNCATED, 0},
	    {"length 0 for CAMERA", C_LEN0_CAMERA, NULL, BC_EPROTO_TRUNCATED,
	     0},
	    {"length 0 for OK", C_LEN0_EMPTY_TYPE, NULL, 0, 1},
	    {"length limit+1", C_LIMIT_PLUS1, NULL, BC_EPROTO_LENGTH, 0},
	    {"length 2^31", C_LEN_2_31, NULL, BC_EPROTO_LENGTH, 0},
	    {"length 2^32-1", C_LEN_2_32M1, NULL, BC_EPROTO_LENGTH, 0},
	    {"length = limit waits, then truncated", C_LIMIT_EXACT_WAITS, NULL,
	     BC_EPROTO_TRUNCATED, 0},
	    {"unknown type", C_UNKNOWN_TYPE, NULL, BC_EPROTO_TYPE, 0},
	    {"wrong version", C_WRONG_VERSION, NULL, BC_EPROTO_VERSION, 0},
	    {"wrong magic", C_WRONG_MAGIC, NULL, BC_EPROTO_MAGIC, 0},
	    {"reserved flags", C_RESERVED_FLAGS, NULL, BC_EPROTO_FLAGS, 0},
	    {"count larger than the bytes left", C_COUNT_OVER_BYTES, NULL,
	     BC_EPROTO_COUNT, 0},
	    {"count over its limit", C_COUNT_OVER_LIMIT, NULL, BC_EPROTO_COUNT,
	     0},
	    {"string longer than the bytes left", C_STRING_OVER_BYTES, NULL,
	     BC_EPROTO_TRUNCATED, 0},
	    {"string not UTF-8", C_STRING_BAD_UTF8, NULL, BC_ESTRING, 0},
	    {"NaN camera", C_NAN_CAMERA, NULL, BC_ENONFINITE, 0},
	    {"infinite camera", C_INF_CAMERA, NULL, BC_ENONFINITE, 0},
	    {"-inf edit value", C_NEGINF_FIELD, NULL, BC_ENONFINITE, 0},
	    {"NaN statistic", C_NAN_STATS, NULL, BC_ENONFINITE, 0},
	    {"short PICK", C_SHORT_PICK, NULL, BC_EPROTO_TRUNCATED, 0},
	    {"trailing byte", C_TRAILING, NULL, BC_EPROTO_TRAILING, 0},
	    {"bad enum", C_BAD_ENUM, NULL, BC_EENUM, 0},
	    {"EDIT before HELLO", C_PRE_HELLO_EDIT, &pre_hello, BC_ESTATE, 0},
	    {"EDIT after HELLO", C_PRE_HELLO_EDIT, &server, 0, 1},
	    {"WELCOME sent to a server", C_WRONG_SIDE, &server, BC_EPROTO_TYPE,
	     0},
	};
	for (size_t i = 0; i < sizeof(rows) / sizeof(rows[0]); i++) {
		struct bytes s;
		int n = 0;
		build_case(rows[i].c, &s);
		int rc = decode_all(rows[i].opts, s.b, s.n, &n);
		if (rc != rows[i].want || n != rows[i].msgs) {
			fprintf(stderr, "  %s: got %s/%d, want %s/%d\n",
			        rows[i].name, bc_err_name(rc), n,
			        bc_err_name(rows[i].want), rows[i].msgs);
			bc_test_failures++;
		}
	}
}

/* ---- One valid sample of every type
 * --------------------------------------------- */

#define S(lit) ((struct bc_proto_str){lit, sizeof(lit) - 1})

static const uint8_t scene_bytes[] = {0, 1, 0, 0, 0, 1, 9, 9, 9};
static const uint8_t image_bytes[16] = {0xff, 0xd8, 1, 2, 3, 4, 0xff, 0xd9};
static const struct bc_proto_member members[] = {
    {5, BC_PROTO_ROLE_EDITOR, S("alice")},
    {6, BC_PROTO_ROLE_VIEWER, S("bob \xe2\x9c\x93")},
};
static const struct bc_proto_field fields[] = {
    {BC_PROTO_FIELD_TRANSLATE, 3, {1.0f, -2.0f, 3.5f, 0}},
    {BC_PROTO_FIELD_PARAM0 + 2, 1, {0.25f, 0, 0, 0}},
    {BC_PROTO_FIELD_OP_KIND, 1, {4.0f, 0, 0, 0}},
};
static const struct bc_proto_edit_op ops[] = {
    {.kind = BC_PROTO_EDIT_SET, .node = 3, .nfields = 3, .fields = fields},
    {.kind = BC_PROTO_EDIT_INSERT,
     .node = 1,
     .position = 0,
     .subtree = {scene_bytes, sizeof(scene_bytes)}},
    {.kind = BC_PROTO_EDIT_REMOVE, .node = 9},
    {.kind = BC_PROTO_EDIT_REPLACE, .node = 4, .subtree = {scene_bytes, 3}},
};
static const struct bc_proto_rect rects[] = {
    {0, 0, 8, 8, {image_bytes, sizeof(image_bytes)}},
    {8, 8, 2, 2, {image_bytes, 5}},
};

static void sample(enum bc_msg_type t, struct bc_msg *m)
{
	memset(m, 0, sizeof(*m));
	m->type = t;
	m->seq = 1000u + (uint32_t)t;
	switch (t) {
	case BC_MSG_HELLO:
		m->hello = (struct bc_msg_hello){
		    1, 2, 5, 1u << 20, S("cli"), S("tok"), true, 0x8000000fu};
		break;
	case BC_MSG_WELCOME:
		m->welcome = (struct bc_msg_welcome){
		    1, 77, 1u << 24, 1u << 20, 1000, 4096,
		    8, 64, S("srv"), true,     0x0fu};
		break;
	case BC_MSG_ERROR:
		m->flags = BC_PROTO_FLAG_FATAL;
		m->error = (struct bc_msg_error){23, S("viewers cannot edit")};
		break;
	case BC_MSG_PING:
	case BC_MSG_PONG:
		m->ping.stamp = UINT64_C(0x0102030405060708);
		break;
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		m->session =
		    (struct bc_msg_session){BC_PROTO_ROLE_EDITOR, S("review")};
		break;
	case BC_MSG_SESSION_INFO:
		m->session_info = (struct bc_msg_session_info){
		    3, 6, BC_PROTO_ROLE_VIEWER, S("review"), 2, members};
		break;
	case BC_MSG_SCENE_LOAD:
		m->scene_load.scene =
		    (struct bc_proto_bytes){scene_bytes, sizeof(scene_bytes)};
		break;
	case BC_MSG_SCENE_STATE:
		m->scene_state = (struct bc_msg_scene_state){
		    UINT64_C(1) << 40,
		    5,
		    12,
		    {scene_bytes, sizeof(scene_bytes)}};
		break;
	case BC_MSG_EDIT:
		m->flags = BC_PROTO_FLAG_INTERACTING;
		m->edit = (struct bc_msg_edit){4, ops};
		break;
	case BC_MSG_EDIT_APPLIED:
		m->flags = BC_PROTO_FLAG_UNDO;
		m->edit_applied = (struct bc_msg_edit_applied){
		    9, 5, 12, 4, ops, 7, S("carol")};
		break;
	case BC_MSG_CAMERA:
	case BC_MSG_SESSION_CAMERA:
		m->camera = (struct bc_msg_camera){
		    {1, 2, 3}, {0, 0, 0}, {0, 1, 0}, 50.0f};
		break;
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
		m->toggle.on = 1;
		break;
	case BC_MSG_PRESENTER:
		m->presenter = (struct bc_msg_presenter){7, 1};
		break;
	case BC_MSG_FOLLOW_CAMERA:
		m->follow_camera = (struct bc_msg_follow_camera){
		    7, {{1, 2, 3}, {0, 0, 0}, {0, 1, 0}, 50.0f}};
		break;
	case BC_MSG_SESSION_CAMERA_SET:
		m->session_camera_set = (struct bc_msg_session_camera_set){
		    12, 3, 42, {{1, 2, 3}, {0, 0, 0}, {0, 1, 0}, 50.0f}};
		break;
	case BC_MSG_VIEW:
		m->view =
		    (struct bc_msg_view){640, 480, BC_PROTO_ENC_JPEG,   50,
		                         90,  2,   BC_PROTO_ENC_INVALID};
		break;
	case BC_MSG_FRAME:
		m->frame = (struct bc_msg_frame){
		    7, 9, 30, BC_PROTO_ENC_JPEG, 20, 20, 10, 10, 2, rects};
		break;
	case BC_MSG_PICK:
		m->pick = (struct bc_msg_pick){10, 20};
		break;
	case BC_MSG_FRAME_ACK:
		m->frame_ack.frame_no = 41;
		break;
	case BC_MSG_MESH:
		m->mesh = (struct bc_msg_mesh){BC_PROTO_MESH_GLB,
		                               BC_PROTO_MESH_RAW, 256};
		break;
	case BC_MSG_MESH_DATA:
		m->mesh_data = (struct bc_msg_mesh_data){
		    BC_PROTO_MESH_OBJ,
		    0,
		    128,
		    9,
		    3,
		    1,
		    {image_bytes, sizeof(image_bytes)}};
		break;
	case BC_MSG_PICK_RESULT:
		m->pick_result = (struct bc_msg_pick_result){
		    10, 20, 4, {1.5f, -0.5f, 2.0f}, 4.25f};
		break;
	case BC_MSG_SNAPSHOT:
		m->snapshot.encoding = BC_PROTO_ENC_PNG;
		break;
	case BC_MSG_STATS:
		m->stats = (struct bc_msg_stats){
		    1,
		    2,
		    3,
		    4,
		    5,
		    6,
		    7.0f,
		    8.0f,
		    9.0f,
		    10.0f,
		    11.0f,
		    12.0f,
		    true,
		    {1.5f, 2.5f, 2u, 3u, 4u, 5u, 6u, 7u},
		    true,
		    1764748800000u,
		    1,
		    true,
		    {50000u, 48000u, 1250000u, 65536u, 3u, 9u},
		    true,
		    {100001u, 149796u, 60001u, 3u}};
		break;
	case BC_MSG_SESSION_DELETE:
		m->session_delete.name = S("old-review");
		break;
	case BC_MSG_UNDO:
	case BC_MSG_REDO:
	case BC_MSG_SESSION_LIST:
		break;
	case BC_MSG_SESSIONS: {
		static const struct bc_proto_session_entry list[2] = {
		    {{"review", 6}, 3, 1024, 77, 1764547200000u, 3},
		    {{"old", 3}, 0, 0, 0, 0, 0}};
		m->sessions = (struct bc_msg_sessions){2, list};
		break;
	}
	default:
		break;
	}
}

/* Encodes every sample into one stream, decodes it in chunks of every size
 * from 1 to 97 bytes, and checks that each decoded message re-encodes to
 * its original bytes. */
static void test_round_trip_every_type(void)
{
	struct bc_proto_buf all, one;
	size_t start[BC_MSG_COUNT + 1];
	struct bc_errinfo ei = {0};
	bc_proto_buf_init(&all, 0);
	bc_proto_buf_init(&one, 0);
	for (int t = 1; t < BC_MSG_COUNT; t++) {
		struct bc_msg m;
		sample((enum bc_msg_type)t, &m);
		start[t] = all.len;
		int rc = bc_proto_encode(&all, &m, &ei);
		if (rc) {
			fprintf(stderr, "  %s: %s\n",
			        bc_proto_type_name((enum bc_msg_type)t),
			        ei.msg);
		}
		REQUIRE(rc == 0);
	}
	start[BC_MSG_COUNT] = all.len;
	for (size_t chunk = 1; chunk <= 97; chunk += (chunk < 20 ? 1 : 11)) {
		struct bc_proto_reader r;
		struct bc_msg m;
		int t = 1;
		bc_proto_reader_init(&r, NULL);
		for (size_t off = 0; off < all.len; off += chunk) {
			size_t k =
			    all.len - off < chunk ? all.len - off : chunk;
			REQUIRE(bc_proto_reader_feed(&r, all.data + off, k) ==
			        0);
			int rc;
			while ((rc = bc_proto_reader_next(&r, &m)) == 1) {
				CHECK_EQ_INT(m.type, t);
				CHECK_EQ_INT(m.seq, 1000 + t);
				bc_proto_buf_reset(&one);
				CHECK(bc_proto_encode(&one, &m, NULL) == 0);
				size_t len = start[t + 1] - start[t];
				CHECK(one.len == len &&
				      memcmp(one.data, all.data + start[t],
				             len) == 0);
				t++;
			}
			CHECK(rc == 0);
		}
		CHECK_EQ_INT(t, BC_MSG_COUNT);
		CHECK(bc_proto_reader_eof(&r) == 0);
		bc_proto_reader_finish(&r);
	}
	bc_proto_buf_finish(&all);
	bc_proto_buf_finish(&one);
}

/* Decoded strings and byte ranges point into the reader's buffer. */
static void test_zero_copy(void)
{
	struct bc_proto_buf b;
	struct bc_msg m;
	struct bc_proto_reader r;
	bc_proto_buf_init(&b, 0);
	sample(BC_MSG_FRAME, &m);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	bc_proto_reader_init(&r, NULL);
	REQUIRE(bc_proto_reader_feed(&r, b.data, b.len) == 0);
	REQUIRE(bc_proto_reader_next(&r, &m) == 1);
	CHECK(m.frame.rects[0].data.ptr >= r.buf &&
	      m.frame.rects[0].data.ptr < r.buf + r.cap);
	CHECK(memcmp(m.frame.rects[1].data.ptr, image_bytes, 5) == 0);
	bc_proto_reader_finish(&r);
	bc_proto_buf_finish(&b);
}

/* detach() hands over the buffer a SCENE_LOAD lies in: its scene stays
 * valid after the reader goes on, and the bytes after it (the start of a
 * PING) are the reader's still. */
static void test_detach(void)
{
	static const struct bc_proto_reader_opts server = {
	    .side = BC_PROTO_SIDE_SERVER};
	struct bc_proto_buf b;
	struct bc_msg m, ping = {.type = BC_MSG_PING, .seq = 7};
	struct bc_proto_reader r;
	size_t load_len;
	uint8_t *kept;
	bc_proto_buf_init(&b, 0);
	sample(BC_MSG_SCENE_LOAD, &m);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	load_len = b.len;
	REQUIRE(bc_proto_encode(&b, &ping, NULL) == 0);
	bc_proto_reader_init(&r, &server);
	REQUIRE(bc_proto_reader_feed(&r, b.data, load_len + 5) == 0);
	REQUIRE(bc_proto_reader_next(&r, &m) == 1);
	REQUIRE(m.type == BC_MSG_SCENE_LOAD);
	kept = bc_proto_reader_detach(&r);
	REQUIRE(kept != NULL);
	CHECK(m.scene_load.scene.ptr > kept &&
	      m.scene_load.scene.ptr < kept + load_len);
	CHECK_EQ_INT(bc_proto_reader_pending(&r), 5);
	REQUIRE(bc_proto_reader_feed(&r, b.data + load_len + 5,
	                             b.len - load_len - 5) == 0);
	CHECK_EQ_INT(bc_proto_reader_next(&r, &ping), 1);
	CHECK(ping.type == BC_MSG_PING && ping.seq == 7);
	CHECK_EQ_INT(m.scene_load.scene.len, sizeof(scene_bytes));
	CHECK(memcmp(m.scene_load.scene.ptr, scene_bytes,
	             sizeof(scene_bytes)) == 0);
	bc_free(kept);
	bc_proto_reader_finish(&r);
	bc_proto_buf_finish(&b);
}

/* ---- Reader rules
 * --------------------------------------------------------------- */

static void test_error_is_sticky(void)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bytes ok, bad;
	build_case(C_LEN0_EMPTY_TYPE, &ok);
	build_case(C_WRONG_MAGIC, &bad);
	bc_proto_reader_init(&r, NULL);
	CHECK(bc_proto_reader_feed(&r, bad.b, bad.n) == 0);
	CHECK(bc_proto_reader_next(&r, &m) == BC_EPROTO_MAGIC);
	CHECK(strstr(r.errstr, "magic") != NULL);
	CHECK(bc_proto_reader_feed(&r, ok.b, ok.n) == BC_EPROTO_MAGIC);
	CHECK(bc_proto_reader_next(&r, &m) == BC_EPROTO_MAGIC);
	CHECK(m.type == BC_MSG_INVALID);
	CHECK(bc_proto_reader_eof(&r) == BC_EPROTO_MAGIC);
	bc_proto_reader_finish(&r);
	bc_proto_reader_finish(NULL);
}

/* A header announcing 64 MiB makes the reader hold the bytes that came,
 * not what was announced. */
static void test_announced_length_allocates_nothing(void)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bytes s;
	build_case(C_LIMIT_EXACT_WAITS, &s);
	bc_proto_reader_init(&r, NULL);
	CHECK(bc_proto_reader_feed(&r, s.b, s.n) == 0);
	CHECK(bc_proto_reader_next(&r, &m) == 0);
	CHECK(r.cap <= 4096);
	CHECK(bc_proto_reader_pending(&r) == BC_PROTO_HEADER_SIZE);
	bc_proto_reader_finish(&r);
}

static void test_pre_hello_stage(void)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	sample(BC_MSG_HELLO, &m);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	sample(BC_MSG_SESSION_JOIN, &m);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	bc_proto_reader_init(
	    &r, &(struct bc_proto_reader_opts){.side = BC_PROTO_SIDE_SERVER,
	                                       .await_hello = true});
	REQUIRE(bc_proto_reader_feed(&r, b.data, b.len) == 0);
	CHECK(bc_proto_reader_next(&r, &m) == 1);
	CHECK(m.type == BC_MSG_HELLO);
	/* The server accepts the HELLO before reading on. */
	bc_proto_reader_hello_done(&r);
	CHECK(bc_proto_reader_next(&r, &m) == 1);
	CHECK(m.type == BC_MSG_SESSION_JOIN);
	bc_proto_reader_finish(&r);

	/* Without hello_done the pipelined JOIN is refused. */
	bc_proto_reader_init(
	    &r, &(struct bc_proto_reader_opts){.side = BC_PROTO_SIDE_SERVER,
	                                       .await_hello = true});
	REQUIRE(bc_proto_reader_feed(&r, b.data, b.len) == 0);
	CHECK(bc_proto_reader_next(&r, &m) == 1);
	CHECK(bc_proto_reader_next(&r, &m) == BC_ESTATE);
	bc_proto_reader_finish(&r);
	bc_proto_buf_finish(&b);
}

static void test_payload_limit_and_feed_ceiling(void)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bytes s;
	memset(&s, 0, sizeof(s));
	hdr(&s, BC_MSG_FRAME, 70000);
	bc_proto_reader_init(
	    &r, &(struct bc_proto_reader_opts){.side = BC_PROTO_SIDE_CLIENT,
	                                       .max_payload = 65536});
	CHECK(bc_proto_reader_feed(&r, s.b, s.n) == 0);
	CHECK(bc_proto_reader_next(&r, &m) == BC_EPROTO_LENGTH);
	bc_proto_reader_finish(&r);

	/* Raising the limit lets the same header through. */
	bc_proto_reader_init(
	    &r, &(struct bc_proto_reader_opts){.max_payload = 65536});
	bc_proto_reader_set_max_payload(&r, 1u << 20);
	CHECK(bc_proto_reader_feed(&r, s.b, s.n) == 0);
	CHECK(bc_proto_reader_next(&r, &m) == 0);
	bc_proto_reader_finish(&r);

	/* A caller that never drains hits the ceiling: one message of the
	 * limit plus BC_PROTO_READ_SLACK. */
	static uint8_t zeros[64 * 1024];
	bc_proto_reader_init(
	    &r, &(struct bc_proto_reader_opts){.max_payload = 4096});
	int rc = 0;
	size_t fed = 0;
	while (rc == 0 && fed < 4 * BC_PROTO_READ_SLACK) {
		rc = bc_proto_reader_feed(&r, zeros, sizeof(zeros));
		fed += sizeof(zeros);
	}
	CHECK(rc == BC_ELIMIT);
	CHECK(fed <= BC_PROTO_HEADER_SIZE + 4096 + BC_PROTO_READ_SLACK +
	                 sizeof(zeros));
	CHECK(bc_proto_reader_feed(&r, zeros, 1) == BC_ELIMIT);
	bc_proto_reader_finish(&r);
}

/* Many small messages fed at once come out one by one, in order. */
static void test_many_messages_one_feed(void)
{
	struct bc_proto_buf b;
	struct bc_proto_reader r;
	struct bc_msg m;
	bc_proto_buf_init(&b, 0);
	for (uint32_t i = 0; i < 5000; i++) {
		struct bc_msg p = {.type = BC_MSG_PING, .seq = i + 1};
		p.ping.stamp = i * UINT64_C(7);
		REQUIRE(bc_proto_encode(&b, &p, NULL) == 0);
	}
	bc_proto_reader_init(&r, NULL);
	REQUIRE(bc_proto_reader_feed(&r, b.data, b.len) == 0);
	uint32_t n = 0;
	while (bc_proto_reader_next(&r, &m) == 1) {
		CHECK(m.seq == n + 1 && m.ping.stamp == n * UINT64_C(7));
		n++;
	}
	CHECK_EQ_INT(n, 5000);
	CHECK(bc_proto_reader_pending(&r) == 0);
	bc_proto_reader_finish(&r);
	bc_proto_buf_finish(&b);
}

/* ---- Encoder refusals
 * ------------------------------------------------------------ */

static void test_encoder_refuses_what_decoder_refuses(void)
{
	struct bc_proto_buf b;
	struct bc_msg m;
	struct bc_errinfo ei;
	bc_proto_buf_init(&b, 0);
	sample(BC_MSG_PING, &m);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	size_t len = b.len;

	sample(BC_MSG_CAMERA, &m);
	m.camera.fov_y_deg = NAN;
	CHECK(bc_proto_encode(&b, &m, &ei) == BC_ENONFINITE);
	CHECK(ei.code == BC_ENONFINITE && strstr(ei.msg, "fov") != NULL);
	m.camera.fov_y_deg = 180.0f;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_ERANGE);

	sample(BC_MSG_SESSION_JOIN, &m);
	m.session.name = S("a\0b");
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_ESTRING);
	m.session.name = S("");
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_LENGTH);
	m.session.name.len = 70000; /* would wrap the u16 length */
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_LENGTH);
	sample(BC_MSG_SESSION_JOIN, &m);
	m.session.role = (enum bc_proto_role)300; /* would wrap the u8 */
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EENUM);

	sample(BC_MSG_EDIT, &m);
	m.edit.nops = BC_PROTO_MAX_EDIT_OPS + 1;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_COUNT);
	m.edit.nops = 0;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_COUNT);
	m.flags = 0x0100;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_FLAGS);

	sample(BC_MSG_FRAME, &m);
	m.frame.image_width = 21; /* wider than the frame */
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_ERANGE);
	sample(BC_MSG_FRAME, &m);
	m.frame.encoding = BC_PROTO_ENC_RAW; /* rect lengths now wrong */
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_LENGTH);

	m.type = (enum bc_msg_type)99;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_TYPE);
	m.type = BC_MSG_INVALID;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_TYPE);

	/* Nothing refused was appended. */
	CHECK(b.len == len);
	bc_proto_buf_finish(&b);
}

/* ---- Refinement levels
 * ------------------------------------------------------------ */

static void test_level_flag_helpers(void)
{
	CHECK_EQ_INT(BC_PROTO_FLAG_LEVEL_MASK,
	             BC_PROTO_MAX_LEVEL << BC_PROTO_FLAG_LEVEL_SHIFT);
	CHECK_EQ_INT(bc_proto_flags_level(0), 0);
	CHECK_EQ_INT(bc_proto_flags_level(0x0008), 1);
	CHECK_EQ_INT(bc_proto_flags_level(0x0010 | BC_PROTO_FLAG_INCOMPLETE),
	             2);
	CHECK_EQ_INT(bc_proto_flags_level(0xffff), 3);
	CHECK_EQ_INT(bc_proto_flags_with_level(BC_PROTO_FLAG_INCOMPLETE, 2),
	             0x0014);
	CHECK_EQ_INT(bc_proto_flags_with_level(0x001f, 0), 0x0007);
	CHECK_EQ_INT(bc_proto_flags_with_level(0x0008, 3), 0x0018);
	CHECK_EQ_INT(bc_proto_level_dim(1280, 1), 640);
	CHECK_EQ_INT(bc_proto_level_dim(1281, 1), 641);
	CHECK_EQ_INT(bc_proto_level_dim(7, 2), 2);
	CHECK_EQ_INT(bc_proto_level_dim(1, 3), 1);
	CHECK_EQ_INT(bc_proto_level_dim(8192, 3), 1024);
	CHECK_EQ_INT(bc_proto_level_dim(8191, 3), 1024);
	CHECK_EQ_INT(bc_proto_level_dim(9, 0), 9);
}

/* A raw level frame of a view w x h with an image iw x ih in one rectangle
 * of rw x rh pixels at the origin; pixels points at enough bytes. */
static struct bc_msg level_frame(unsigned level, uint16_t w, uint16_t h,
                                 uint16_t iw, uint16_t ih,
                                 struct bc_proto_rect *rect,
                                 const uint8_t *pixels)
{
	*rect = (struct bc_proto_rect){
	    0, 0, iw, ih, {pixels, (uint32_t)iw * ih * 4u}};
	struct bc_msg m = {.type = BC_MSG_FRAME,
	                   .flags = bc_proto_flags_with_level(0, level)};
	m.frame = (struct bc_msg_frame){1,  2, 3,   BC_PROTO_ENC_RAW, w, h, iw,
	                                ih, 1, rect};
	return m;
}

/* Every view size up to 19 x 19 at every level: the one image size
 * ceil(view / 2^n) round-trips with its level, one pixel more or less
 * either way is ERANGE, on the encoder and on the reader alike. */
static void test_frame_level_sizes(void)
{
	static uint8_t pixels[19 * 19 * 4];
	struct bc_proto_buf b;
	struct bc_proto_reader r;
	struct bc_proto_rect rect;
	struct bc_msg m, out;
	bc_proto_buf_init(&b, 0);
	int bad = 0;
	for (unsigned level = 1; level <= BC_PROTO_MAX_LEVEL; level++) {
		for (uint16_t w = 1; w < 20; w++) {
			for (uint16_t h = 1; h < 20; h++) {
				uint16_t iw = bc_proto_level_dim(w, level);
				uint16_t ih = bc_proto_level_dim(h, level);
				bc_proto_buf_reset(&b);
				m = level_frame(level, w, h, iw, ih, &rect,
				                pixels);
				m.flags |= BC_PROTO_FLAG_INCOMPLETE;
				if (bc_proto_encode(&b, &m, NULL) != 0) {
					bad++;
					continue;
				}
				bc_proto_reader_init(
				    &r, &(struct bc_proto_reader_opts){
				            .side = BC_PROTO_SIDE_CLIENT});
				bc_proto_reader_feed(&r, b.data, b.len);
				if (bc_proto_reader_next(&r, &out) != 1 ||
				    bc_proto_flags_level(out.flags) != level ||
				    !(out.flags & BC_PROTO_FLAG_INCOMPLETE) ||
				    out.frame.image_width != iw ||
				    out.frame.image_height != ih) {
					bad++;
				}
				bc_proto_reader_finish(&r);
				/* One column or row more or fewer. */
				uint16_t dw[4] = {(uint16_t)(iw + 1),
				                  (uint16_t)(iw - 1), iw, iw};
				uint16_t dh[4] = {ih, ih, (uint16_t)(ih + 1),
				                  (uint16_t)(ih - 1)};
				for (int k = 0; k < 4; k++) {
					if (dw[k] == 0 || dh[k] == 0) {
						continue;
					}
					m = level_frame(level, w, h, dw[k],
					                dh[k], &rect, pixels);
					if (bc_proto_encode(&b, &m, NULL) !=
					    BC_ERANGE) {
						bad++;
					}
				}
			}
		}
	}
	CHECK_EQ_INT(bad, 0);
	bc_proto_buf_finish(&b);
}

static void test_frame_level_refusals(void)
{
	static uint8_t pixels[10 * 10 * 4];
	struct bc_proto_buf b;
	struct bc_proto_rect rect;
	struct bc_errinfo ei;
	bc_proto_buf_init(&b, 0);

	/* A level frame is never STILL or SNAPSHOT. */
	struct bc_msg m = level_frame(1, 20, 20, 10, 10, &rect, pixels);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	size_t len = b.len;
	m.flags |= BC_PROTO_FLAG_STILL;
	CHECK(bc_proto_encode(&b, &m, &ei) == BC_EPROTO_FLAGS);
	CHECK(strstr(ei.msg, "STILL") != NULL);
	m = level_frame(2, 20, 20, 5, 5, &rect, pixels);
	m.flags |= BC_PROTO_FLAG_SNAPSHOT;
	CHECK(bc_proto_encode(&b, &m, &ei) == BC_EPROTO_FLAGS);
	CHECK(strstr(ei.msg, "SNAPSHOT") != NULL);
	/* Level 0 keeps STILL, SNAPSHOT and a full-size image. */
	m = level_frame(0, 10, 10, 10, 10, &rect, pixels);
	m.flags |= BC_PROTO_FLAG_STILL | BC_PROTO_FLAG_SNAPSHOT;
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	len = b.len;

	/* One rectangle, the whole image. */
	struct bc_proto_rect two[2] = {
	    {0, 0, 10, 5, {pixels, 10 * 5 * 4}},
	    {0, 5, 10, 5, {pixels, 10 * 5 * 4}},
	};
	m = level_frame(1, 20, 20, 10, 10, &rect, pixels);
	m.frame.nrects = 2;
	m.frame.rects = two;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_COUNT);
	m.flags = 0; /* the same two damage rectangles at level 0 */
	m.frame.image_width = m.frame.image_height = 10;
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	len = b.len;
	m = level_frame(1, 20, 20, 10, 10, &rect, pixels);
	rect.w = 9;
	rect.data.len = 9 * 10 * 4;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_ERANGE);

	/* The level bits belong to FRAME only. */
	struct bc_msg cam;
	sample(BC_MSG_CAMERA, &cam);
	cam.flags = bc_proto_flags_with_level(0, 1);
	CHECK(bc_proto_encode(&b, &cam, NULL) == BC_EPROTO_FLAGS);
	sample(BC_MSG_EDIT, &cam);
	cam.flags |= BC_PROTO_FLAG_LEVEL_MASK;
	CHECK(bc_proto_encode(&b, &cam, NULL) == BC_EPROTO_FLAGS);
	CHECK(b.len == len);

	/* The reader refuses level with STILL from the header alone, and
	 * decode_payload makes the same check. */
	struct bytes s = {0};
	praw(&s, "BCST", 4);
	p8(&s, BC_PROTO_VERSION);
	p8(&s, BC_MSG_FRAME);
	p16(&s, 0x0008 | BC_PROTO_FLAG_STILL);
	struct bc_proto_reader r;
	struct bc_msg out;
	bc_proto_reader_init(&r, NULL);
	bc_proto_reader_feed(&r, s.b, s.n);
	CHECK(bc_proto_reader_next(&r, &out) == BC_EPROTO_FLAGS);
	bc_proto_reader_finish(&r);
	bc_proto_reader_init(&r, NULL);
	m = level_frame(1, 20, 20, 10, 10, &rect, pixels);
	bc_proto_buf_reset(&b);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	const uint8_t *payload = b.data + BC_PROTO_HEADER_SIZE;
	size_t n = b.len - BC_PROTO_HEADER_SIZE;
	CHECK(bc_proto_decode_payload(&r, BC_MSG_FRAME, 0x0008, 0, payload, n,
	                              &out, NULL) == 0);
	CHECK(bc_proto_flags_level(out.flags) == 1);
	CHECK(bc_proto_decode_payload(&r, BC_MSG_FRAME,
	                              0x0008 | BC_PROTO_FLAG_STILL, 0, payload,
	                              n, &out, NULL) == BC_EPROTO_FLAGS);
	CHECK(bc_proto_decode_payload(&r, BC_MSG_PICK_RESULT, 0x0008, 0,
	                              payload, n, &out,
	                              NULL) == BC_EPROTO_FLAGS);
	bc_proto_reader_finish(&r);
	bc_proto_buf_finish(&b);
}

static void test_buffer_ceiling(void)
{
	struct bc_proto_buf b;
	struct bc_msg m;
	bc_proto_buf_init(&b, 3 * (BC_PROTO_HEADER_SIZE + 8));
	sample(BC_MSG_PING, &m);
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_ELIMIT);
	CHECK(b.len == 3 * (BC_PROTO_HEADER_SIZE + 8));
	bc_proto_buf_consume(&b, BC_PROTO_HEADER_SIZE + 8);
	CHECK(b.len == 2 * (BC_PROTO_HEADER_SIZE + 8));
	CHECK(memcmp(b.data, "BCST", 4) == 0);
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	bc_proto_buf_finish(&b);
	bc_proto_buf_finish(NULL);
}

/* A payload over its type's maximum is EPROTO_LENGTH, not a big alloc. */
static void test_encoder_type_maximum(void)
{
	static char text[BC_PROTO_MAX_ERROR_TEXT + 1];
	struct bc_proto_buf b;
	struct bc_msg m = {.type = BC_MSG_ERROR};
	memset(text, 'e', sizeof(text));
	bc_proto_buf_init(&b, 0);
	m.error.code = 1;
	m.error.text = (struct bc_proto_str){text, BC_PROTO_MAX_ERROR_TEXT};
	CHECK(bc_proto_encode(&b, &m, NULL) == 0);
	m.error.text.len++;
	CHECK(bc_proto_encode(&b, &m, NULL) == BC_EPROTO_LENGTH);
	bc_proto_buf_finish(&b);
}

/* ---- Allocation failures
 * ------------------------------------------------------- */

/* Every allocation of encode and decode fails in turn; each run ends in
 * success or BC_ENOMEM and leaks nothing (ASan checks the leaks). */
static void test_allocation_failures(void)
{
	static const enum bc_msg_type types[] = {
	    BC_MSG_SESSION_INFO, BC_MSG_EDIT, BC_MSG_FRAME, BC_MSG_HELLO};
	for (size_t i = 0; i < sizeof(types) / sizeof(types[0]); i++) {
		int done = 0;
		for (unsigned long n = 1; n < 64 && !done; n++) {
			struct bc_proto_buf b;
			struct bc_proto_reader r;
			struct bc_msg m;
			bc_proto_buf_init(&b, 0);
			bc_proto_reader_init(&r, NULL);
			sample(types[i], &m);
			bc_alloc_fail_after(n);
			int rc = bc_proto_encode(&b, &m, NULL);
			if (rc == 0) {
				rc = bc_proto_reader_feed(&r, b.data, b.len);
			}
			if (rc == 0) {
				rc = bc_proto_reader_next(&r, &m);
			}
			bc_alloc_fail_after(0);
			CHECK(rc == 1 || rc == BC_ENOMEM);
			if (rc == BC_ENOMEM) {
				CHECK(r.err == BC_ENOMEM || r.err == 0);
			}
			done = rc == 1;
			bc_proto_reader_finish(&r);
			bc_proto_buf_finish(&b);
		}
		CHECK(done);
	}
}

/* ---- UTF-8
 * -------------------------------------------------------------------------- */

/* Reference: decode one sequence by the Unicode definition and say whether
 * it is a valid, shortest, non-surrogate, non-NUL code point. */
static int ref_valid(const uint8_t *p, size_t n)
{
	size_t i = 0;
	while (i < n) {
		uint32_t cp;
		size_t len;
		if (p[i] < 0x80) {
			cp = p[i];
			len = 1;
		} else if ((p[i] & 0xe0) == 0xc0) {
			cp = p[i] & 0x1fu;
			len = 2;
		} else if ((p[i] & 0xf0) == 0xe0) {
			cp = p[i] & 0x0fu;
			len = 3;
		} else if ((p[i] & 0xf8) == 0xf0) {
			cp = p[i] & 0x07u;
			len = 4;
		} else {
			return 0;
		}
		if (i + len > n) {
			return 0;
		}
		for (size_t k = 1; k < len; k++) {
			if ((p[i + k] & 0xc0) != 0x80) {
				return 0;
			}
			cp = cp << 6 | (p[i + k] & 0x3fu);
		}
		static const uint32_t min[5] = {0, 0, 0x80, 0x800, 0x10000};
		if (cp == 0 || cp < min[len] || cp > 0x10ffff ||
		    (cp >= 0xd800 && cp <= 0xdfff)) {
			return 0;
		}
		i += len;
	}
	return 1;
}

static int codec_valid(const uint8_t *p, size_t n)
{
	struct bytes s;
	struct bc_proto_reader r;
	struct bc_msg m;
	memset(&s, 0, sizeof(s));
	hdr(&s, BC_MSG_SESSION_JOIN, (uint32_t)(3 + n));
	p8(&s, BC_PROTO_ROLE_VIEWER);
	p16(&s, (unsigned)n);
	praw(&s, p, n);
	bc_proto_reader_init(&r, NULL);
	bc_proto_reader_feed(&r, s.b, s.n);
	int rc = bc_proto_reader_next(&r, &m);
	bc_proto_reader_finish(&r);
	if (rc != 1 && rc != BC_ESTRING) {
		fprintf(stderr, "  unexpected %s\n", bc_err_name(rc));
		bc_test_failures++;
	}
	return rc == 1;
}

/* Every 1- and 2-byte string, every 3-byte string with a lead byte of
 * 0xe0..0xef, and 4-byte strings around each boundary agree with the
 * reference. */
static void test_utf8_against_reference(void)
{
	uint8_t p[4];
	long mismatches = 0;
	for (unsigned a = 0; a < 256; a++) {
		p[0] = (uint8_t)a;
		mismatches += codec_valid(p, 1) != ref_valid(p, 1);
		for (unsigned b = 0; b < 256; b++) {
			p[1] = (uint8_t)b;
			mismatches += codec_valid(p, 2) != ref_valid(p, 2);
		}
	}
	for (unsigned a = 0xe0; a <= 0xef; a++) {
		for (unsigned b = 0x70; b < 0xd0; b++) {
			for (unsigned c = 0x70; c < 0xd0; c += 7) {
				p[0] = (uint8_t)a;
				p[1] = (uint8_t)b;
				p[2] = (uint8_t)c;
				mismatches +=
				    codec_valid(p, 3) != ref_valid(p, 3);
			}
		}
	}
	static const uint8_t lead[] = {0xef, 0xf0, 0xf1, 0xf3,
	                               0xf4, 0xf5, 0xf8};
	for (size_t i = 0; i < sizeof(lead); i++) {
		for (unsigned b = 0x70; b < 0xd0; b++) {
			p[0] = lead[i];
			p[1] = (uint8_t)b;
			p[2] = 0x80;
			p[3] = 0xbf;
			mismatches += codec_valid(p, 4) != ref_valid(p, 4);
		}
	}
	CHECK_EQ_INT(mismatches, 0);
}

/* ---- Names and rules
 * --------------------------------------------------------------- */

static void test_type_names(void)
{
	for (int t = 1; t < BC_MSG_COUNT; t++) {
		const char *name = bc_proto_type_name((enum bc_msg_type)t);
		REQUIRE(name);
		CHECK_EQ_INT(bc_proto_type_from_name(name), t);
	}
	CHECK(bc_proto_type_name(BC_MSG_INVALID) == NULL);
	CHECK(bc_proto_type_name(BC_MSG_COUNT) == NULL);
	CHECK(bc_proto_type_from_name("NOPE") == BC_MSG_INVALID);
	CHECK(bc_proto_type_from_name(NULL) == BC_MSG_INVALID);
}

static void test_client_state_machine(void)
{
	enum bc_proto_stage H = BC_PROTO_STAGE_HELLO, R = BC_PROTO_STAGE_READY,
	                    S = BC_PROTO_STAGE_SESSION;
	enum bc_proto_role E = BC_PROTO_ROLE_EDITOR, V = BC_PROTO_ROLE_VIEWER,
	                   N = BC_PROTO_ROLE_INVALID;
	CHECK(bc_proto_client_may_send(H, N, BC_MSG_HELLO) == 0);
	CHECK(bc_proto_client_may_send(H, N, BC_MSG_PING) == 0);
	CHECK(bc_proto_client_may_send(H, N, BC_MSG_SESSION_JOIN) == BC_ESTATE);
	CHECK(bc_proto_client_may_send(H, N, BC_MSG_CAMERA) == BC_ESTATE);
	CHECK(bc_proto_client_may_send(R, N, BC_MSG_HELLO) == BC_ESTATE);
	CHECK(bc_proto_client_may_send(R, N, BC_MSG_SESSION_CREATE) == 0);
	CHECK(bc_proto_client_may_send(R, N, BC_MSG_VIEW) == 0);
	CHECK(bc_proto_client_may_send(R, N, BC_MSG_EDIT) == BC_ESTATE);
	CHECK(bc_proto_client_may_send(R, N, BC_MSG_PICK) == BC_ESTATE);
	CHECK(bc_proto_client_may_send(S, V, BC_MSG_EDIT) == BC_EPERM);
	CHECK(bc_proto_client_may_send(S, V, BC_MSG_SCENE_LOAD) == BC_EPERM);
	CHECK(bc_proto_client_may_send(S, E, BC_MSG_EDIT) == 0);
	CHECK(bc_proto_client_may_send(S, E, BC_MSG_SCENE_LOAD) == 0);
	CHECK(bc_proto_client_may_send(S, V, BC_MSG_SNAPSHOT) == 0);
	CHECK(bc_proto_client_may_send(S, V, BC_MSG_SESSION_JOIN) == BC_ESTATE);
	CHECK(bc_proto_client_may_send(S, E, BC_MSG_FRAME) == BC_EPROTO_TYPE);
	CHECK(bc_proto_client_may_send(S, E, BC_MSG_WELCOME) == BC_EPROTO_TYPE);
	CHECK(bc_proto_client_may_send(S, E, (enum bc_msg_type)77) ==
	      BC_EPROTO_TYPE);
}

/* Scenes in parts (PROTOCOL.md 7.10.1): the assembler gives back the
 * scene whole from its pieces, and refuses parts out of their order. */
static struct bc_msg state_part(uint16_t flags, const uint8_t *piece,
                                uint32_t n, uint64_t order)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_STATE, .flags = flags};
	m.scene_state.order = order;
	m.scene_state.author = 3;
	m.scene_state.author_seq = 9;
	m.scene_state.scene.ptr = piece;
	m.scene_state.scene.len = n;
	return m;
}

static int parts_run(struct bc_proto_parts *p, const struct bc_msg *ms, int n,
                     struct bc_msg *out)
{
	int rc = 0;
	for (int i = 0; i < n && rc >= 0; i++) {
		rc = bc_proto_parts_add(p, &ms[i], out, NULL);
	}
	return rc;
}

static void test_scene_parts(void)
{
	uint8_t scene[100], head[BC_PROTO_SCENE_PART_HEAD];
	uint8_t wire[BC_PROTO_SCENE_PART_HEAD + 33];
	struct bc_proto_parts p;
	struct bc_msg out, ping = {.type = BC_MSG_PING};
	struct bc_proto_reader r;
	for (int i = 0; i < 100; i++) {
		scene[i] = (uint8_t)(i * 7);
	}
	/* Client side: MORE, MORE|CONT, CONT make one SCENE_STATE. */
	{
		struct bc_msg ms[3] = {
		    state_part(BC_PROTO_FLAG_MORE, scene, 10, 5),
		    state_part(BC_PROTO_FLAGS_PARTS, scene + 10, 1, 5),
		    state_part(BC_PROTO_FLAG_CONT, scene + 11, 89, 5)};
		bc_proto_parts_init(&p, 0, false);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &ms[0], &out, NULL), 0);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &ms[1], &out, NULL), 0);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &ms[2], &out, NULL), 1);
		CHECK_EQ_INT(out.flags, 0);
		CHECK(out.scene_state.order == 5);
		CHECK_EQ_INT(out.scene_state.author_seq, 9);
		CHECK_EQ_INT(out.scene_state.scene.len, 100);
		CHECK(memcmp(out.scene_state.scene.ptr, scene, 100) == 0);
		/* Other messages, and whole scenes, pass as they are. */
		CHECK_EQ_INT(bc_proto_parts_add(&p, &ping, &out, NULL), 1);
		CHECK_EQ_INT(out.type, BC_MSG_PING);
		/* Out of order: the server's fault. */
		{
			struct bc_msg bad[][2] = {
			    {state_part(BC_PROTO_FLAG_CONT, scene, 4, 5), ping},
			    {ms[0], ping},
			    {ms[0], ms[0]},
			    {ms[0],
			     state_part(BC_PROTO_FLAG_CONT, scene, 4, 6)},
			    {ms[0], state_part(0, scene, 4, 5)}};
			for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]);
			     i++) {
				struct bc_proto_parts q;
				bc_proto_parts_init(&q, 0, false);
				CHECK_EQ_INT(parts_run(&q, bad[i], 2, &out),
				             BC_EPROTO_FLAGS);
				CHECK(!q.open);
				bc_proto_parts_finish(&q);
			}
		}
		bc_proto_parts_finish(&p);
	}
	/* Past max: EPROTO_LENGTH, the scene dropped. */
	{
		struct bc_msg ms[2] = {
		    state_part(BC_PROTO_FLAG_MORE, scene, 60, 1),
		    state_part(BC_PROTO_FLAG_CONT, scene, 40, 1)};
		bc_proto_parts_init(&p, 99, false);
		CHECK_EQ_INT(parts_run(&p, ms, 2, &out), BC_EPROTO_LENGTH);
		CHECK(!p.open && p.len == 0);
		bc_proto_parts_finish(&p);
	}
	/* Server side (between): other messages may come between, a first
	 * part drops an unfinished scene, a CONT with none is ESTATE. */
	{
		struct bc_msg a = {.type = BC_MSG_SCENE_LOAD,
		                   .flags = BC_PROTO_FLAG_MORE};
		struct bc_msg z = a;
		a.scene_load.scene.ptr = scene;
		a.scene_load.scene.len = 30;
		z.flags = BC_PROTO_FLAG_CONT;
		z.scene_load.scene.ptr = scene + 30;
		z.scene_load.scene.len = 70;
		bc_proto_parts_init(&p, 0, true);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &z, &out, NULL), BC_ESTATE);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &a, &out, NULL), 0);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &a, &out, NULL), 0);
		CHECK_EQ_INT(p.len,
		             30); /* the second first part started over */
		CHECK_EQ_INT(bc_proto_parts_add(&p, &ping, &out, NULL), 1);
		CHECK_EQ_INT(bc_proto_parts_add(&p, &z, &out, NULL), 1);
		CHECK_EQ_INT(out.type, BC_MSG_SCENE_LOAD);
		CHECK_EQ_INT(out.flags, 0);
		CHECK_EQ_INT(out.scene_load.scene.len, 100);
		CHECK(memcmp(out.scene_load.scene.ptr, scene, 100) == 0);
		bc_proto_parts_finish(&p);
	}
	/* A part's head, as the daemon writes it, then its piece: a
	 * SCENE_STATE that decodes. */
	bc_proto_scene_state_head(head, BC_PROTO_FLAGS_PARTS, 77, 4, 12, 33);
	memcpy(wire, head, sizeof(head));
	memcpy(wire + sizeof(head), scene, 33);
	bc_proto_reader_init(&r, NULL);
	CHECK_EQ_INT(bc_proto_reader_feed(&r, wire, sizeof(wire)), 0);
	CHECK_EQ_INT(bc_proto_reader_next(&r, &out), 1);
	CHECK_EQ_INT(out.type, BC_MSG_SCENE_STATE);
	CHECK_EQ_INT(out.seq, 0);
	CHECK_EQ_INT(out.flags, BC_PROTO_FLAGS_PARTS);
	CHECK(out.scene_state.order == 77);
	CHECK_EQ_INT(out.scene_state.author, 4);
	CHECK_EQ_INT(out.scene_state.author_seq, 12);
	CHECK_EQ_INT(out.scene_state.scene.len, 33);
	CHECK(memcmp(out.scene_state.scene.ptr, scene, 33) == 0);
	bc_proto_reader_finish(&r);
}

/* A MESH_DATA's head, as the daemon writes it before a file it made
 * there, then the file: the bytes the encoder makes of the same message. */
static void test_mesh_data_head(void)
{
	static const uint8_t file[] = "# blobcast mesh: 0 vertices, 0 "
	                              "triangles\n";
	struct bc_msg m = {.type = BC_MSG_MESH_DATA, .seq = 91};
	struct bc_proto_buf b;
	uint8_t wire[BC_PROTO_MESH_DATA_HEAD + sizeof(file)];
	m.mesh_data = (struct bc_msg_mesh_data){
	    BC_PROTO_MESH_GLB,   BC_PROTO_MESH_RAW, 4096, UINT64_MAX - 1, 7, 9,
	    {file, sizeof(file)}};
	bc_proto_mesh_data_head(wire, m.seq, &m.mesh_data);
	memcpy(wire + BC_PROTO_MESH_DATA_HEAD, file, sizeof(file));
	bc_proto_buf_init(&b, 0);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	CHECK_EQ_INT(b.len, sizeof(wire));
	CHECK(b.len == sizeof(wire) && memcmp(b.data, wire, b.len) == 0);
	bc_proto_buf_finish(&b);
}

static const struct bc_test tests[] = {
    {"malformed_table", test_malformed_table},
    {"mesh_data_head", test_mesh_data_head},
    {"scene_parts", test_scene_parts},
    {"round_trip_every_type", test_round_trip_every_type},
    {"zero_copy", test_zero_copy},
    {"detach", test_detach},
    {"error_is_sticky", test_error_is_sticky},
    {"announced_length_allocates_nothing",
     test_announced_length_allocates_nothing},
    {"pre_hello_stage", test_pre_hello_stage},
    {"payload_limit_and_feed_ceiling", test_payload_limit_and_feed_ceiling},
    {"many_messages_one_feed", test_many_messages_one_feed},
    {"encoder_refuses_what_decoder_refuses",
     test_encoder_refuses_what_decoder_refuses},
    {"level_flag_helpers", test_level_flag_helpers},
    {"frame_level_sizes", test_frame_level_sizes},
    {"frame_level_refusals", test_frame_level_refusals},
    {"buffer_ceiling", test_buffer_ceiling},
    {"encoder_type_maximum", test_encoder_type_maximum},
    {"allocation_failures", test_allocation_failures},
    {"utf8_against_reference", test_utf8_against_reference},
    {"type_names", test_type_names},
    {"client_state_machine", test_client_state_machine},
};

BC_TEST_MAIN(tests)
