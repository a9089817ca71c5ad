/*
 * The requirements of protocol/PROTOCOL.md on a server that no other test
 * checks, each against a real blobcastd over raw protocol connections,
 * written from the spec's words alone as an outside client would: every
 * test names the section it pins. docs/protocol-tests.md lists every
 * requirement of the spec with the test that checks it; a requirement
 * added to the spec gets a test here (or elsewhere) and a row there.
 *
 * Scenes are built with the scene writers of the codec and read back with
 * a small walker of section 8 written here, so that no server code decides
 * what the bytes mean.
 */
#include <arpa/inet.h>
#include <netinet/in.h>

#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

/* Hang guard for every wait on an answer: generous, never a timing
 * expectation. */
#define WAIT_MS 20000

/* Kinds of section 8 (the operator and unary kinds without their 0x80). */
#define K_SPHERE 1u
#define K_UNION 1u
#define K_SMOOTH_UNION 4u
#define K_OFFSET 7u

/* daemon.h's helpers this file does not use. */
static void unused(void)
{
	(void)daemon_start;
	(void)conn_move;
}

static int start(struct daemon *d, const char *what, const char *const *extra)
{
	char dir[80];
	snprintf(dir, sizeof(dir), "%s/%s", base_dir, what);
	return daemon_start_with(d, dir, extra);
}

/* ---- raw messages ------------------------------------------------------ */

static void put16(uint8_t *p, uint32_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
}

static void put32(uint8_t *p, uint32_t v)
{
	put16(p, v);
	put16(p + 2, v >> 16);
}

static uint32_t get32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	       (uint32_t)p[3] << 24;
}

static float getf(const uint8_t *p)
{
	uint32_t u = get32(p);
	float f;
	memcpy(&f, &u, sizeof(f));
	return f;
}

/* Writes a header (section 2) announcing len payload bytes into out (16
 * bytes), then the n bytes of payload (n may differ from len). Returns
 * the bytes written. */
static size_t raw_msg(uint8_t *out, uint8_t version, uint8_t type,
                      uint16_t flags, uint32_t len, uint32_t seq,
                      const void *payload, size_t n)
{
	memcpy(out, "BCST", 4);
	out[4] = version;
	out[5] = type;
	put16(out + 6, flags);
	put32(out + 8, len);
	put32(out + 12, seq);
	if (n) {
		memcpy(out + 16, payload, n);
	}
	return 16 + n;
}

/* ---- waiting for answers ----------------------------------------------- */

/* The connection is still served: a PING comes back as its PONG. */
static bool alive(struct conn *c)
{
	struct bc_msg ping = {.type = BC_MSG_PING};
	uint32_t seq;
	ping.ping.stamp = 77;
	seq = conn_send(c, &ping);
	while (seq && conn_expect(c, BC_MSG_PONG, WAIT_MS) == 1) {
		if (c->m.seq == seq) {
			return true;
		}
	}
	return false;
}

/* The server closes c: the stream ends within the hang guard (messages on
 * the way are skipped). */
static bool closed(struct conn *c)
{
	int64_t end = t_now_ms() + WAIT_MS;
	while (t_now_ms() < end) {
		int rc = conn_recv(c, 500);
		if (rc < 0) {
			return true;
		}
	}
	return false;
}

/* Receives until the message answering seq (its seq, any type but the
 * seq-0 ones); returns its type, BC_MSG_INVALID on a timeout or a close.
 * An ERROR is left in c->m. */
static enum bc_msg_type answer(struct conn *c, uint32_t seq)
{
	int64_t end = t_now_ms() + WAIT_MS;
	while (t_now_ms() < end) {
		if (conn_recv(c, 200) < 0) {
			return BC_MSG_INVALID;
		}
		if (c->m.type != BC_MSG_INVALID && c->m.seq == seq) {
			return c->m.type;
		}
	}
	return BC_MSG_INVALID;
}

/* The code (positive) of the non-fatal ERROR that answers seq; 0 when the
 * answer is not an ERROR, -1 when the ERROR is FATAL. */
static int refused(struct conn *c, uint32_t seq)
{
	if (answer(c, seq) != BC_MSG_ERROR) {
		return 0;
	}
	return (c->m.flags & BC_PROTO_FLAG_FATAL) ? -1 : (int)c->m.error.code;
}

static uint32_t send_empty(struct conn *c, enum bc_msg_type type)
{
	struct bc_msg m = {.type = type};
	return conn_send(c, &m);
}

static uint32_t send_toggle(struct conn *c, enum bc_msg_type type, uint8_t on)
{
	struct bc_msg m = {.type = type};
	m.toggle.on = on;
	return conn_send(c, &m);
}

static uint32_t send_session(struct conn *c, enum bc_msg_type type,
                             const char *name, enum bc_proto_role role)
{
	struct bc_msg m = {.type = type};
	if (type == BC_MSG_SESSION_DELETE) {
		m.session_delete.name.ptr = name;
		m.session_delete.name.len = (uint32_t)strlen(name);
	} else {
		m.session.role = role;
		m.session.name.ptr = name;
		m.session.name.len = (uint32_t)strlen(name);
	}
	return conn_send(c, &m);
}

static const struct bc_msg_camera cam_a = {
    {0.0f, 1.0f, 6.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 40.0f};
static const struct bc_msg_camera cam_b = {
    {4.0f, 2.5f, 3.0f}, {0.0f, 0.2f, 0.0f}, {0.0f, 1.0f, 0.0f}, 55.0f};

static uint32_t send_camera(struct conn *c, enum bc_msg_type type,
                            const struct bc_msg_camera *k, uint16_t flags)
{
	struct bc_msg m = {.type = type, .flags = flags};
	if (type == BC_MSG_SESSION_CAMERA) {
		m.session_camera = *k;
	} else {
		m.camera = *k;
	}
	return conn_send(c, &m);
}

/* Connects, says HELLO as name and joins (or creates) session s as role;
 * returns 0 with the SCENE_STATE that follows SESSION_INFO in c->m. */
static int member(struct conn *c, const struct daemon *d, const char *name,
                  const char *s, enum bc_proto_role role, bool create)
{
	if (conn_open(c, d) || conn_hello(c, name) ||
	    conn_join(c, s, role, create)) {
		return -1;
	}
	return conn_expect(c, BC_MSG_SCENE_STATE, WAIT_MS) == 1 ? 0 : -1;
}

/* ---- scenes (section 8) ------------------------------------------------- */

struct node {
	uint8_t tag;
	uint32_t id;
	float translate_x;  /* primitives */
	float blend, range; /* operators */
};

/* Walks the scene encoding bytes (n): up to max nodes into out. Returns
 * the node count, -1 when the bytes are not a scene of section 8. */
static int walk_scene(const uint8_t *p, size_t n, struct node *out, int max)
{
	size_t pos = 1;
	uint32_t count;
	if (n < 1) {
		return -1;
	}
	if (p[0] & 1) {
		pos += 40;
	}
	if (pos + 4 > n) {
		return -1;
	}
	count = get32(p + pos);
	pos += 4;
	for (uint32_t i = 0; i < count; i++) {
		struct node nd = {0};
		if (pos + 5 > n) {
			return -1;
		}
		nd.tag = p[pos];
		nd.id = get32(p + pos + 1);
		pos += 5;
		if (nd.tag >= 1 && nd.tag <= 32) {
			if (pos + 29 > n) {
				return -1;
			}
			nd.translate_x = getf(p + pos);
			pos += 28;
			pos += p[pos] ? 13u : 1u;
			if (pos + 1 > n) {
				return -1;
			}
			pos += 1u + 4u * p[pos];
		} else if (nd.tag >= 0x81 && nd.tag <= 0x86) {
			if (pos + 12 > n) {
				return -1;
			}
			nd.blend = getf(p + pos);
			nd.range = getf(p + pos + 4);
			pos += 12;
		} else if (nd.tag >= 0x87 && nd.tag <= 0x8e) {
			if (pos + 1 > n) {
				return -1;
			}
			pos += 1u + 4u * p[pos];
		} else {
			return -1;
		}
		if (pos > n) {
			return -1;
		}
		if ((int)i < max) {
			out[i] = nd;
		}
	}
	return pos == n ? (int)count : -1;
}

static int walk_state(const struct conn *c, struct node *out, int max)
{
	return walk_scene(c->m.scene_state.scene.ptr,
	                  c->m.scene_state.scene.len, out, max);
}

static const struct node *find(const struct node *nodes, int n, uint32_t id)
{
	for (int i = 0; i < n; i++) {
		if (nodes[i].id == id) {
			return &nodes[i];
		}
	}
	return NULL;
}

static void sphere(struct bc_proto_buf *b, uint32_t id, float x)
{
	const float t[3] = {x, 0.0f, 0.0f}, r[4] = {0, 0, 0, 1};
	const float radius = 0.5f;
	bc_proto_scene_prim(b, K_SPHERE, id, t, r, NULL, 1, &radius);
}

/* The test scene, ids from base (0: every id 0, for the server to give):
 * union base+0 of sphere +1, smooth_union +2 (blend 0.2, range 0) of
 * spheres +3 and +4, and offset +5 of sphere +6. */
static void test_scene(struct bc_proto_buf *b, uint32_t base)
{
	uint32_t k = base ? 1 : 0;
	bc_proto_buf_init(b, 0);
	bc_proto_scene_begin(b, NULL, 7);
	bc_proto_scene_op(b, K_UNION, base, 0.0f, 0.0f, 3);
	sphere(b, base + 1 * k, -1.0f);
	bc_proto_scene_op(b, K_SMOOTH_UNION, base + 2 * k, 0.2f, 0.0f, 2);
	sphere(b, base + 3 * k, 0.0f);
	sphere(b, base + 4 * k, 0.4f);
	{
		const float amount = 0.05f;
		bc_proto_scene_unary(b, K_OFFSET, base + 5 * k, 1, &amount);
	}
	sphere(b, base + 6 * k, 1.0f);
}

static uint32_t send_load(struct conn *c, const uint8_t *bytes, size_t n)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	m.scene_load.scene.ptr = bytes;
	m.scene_load.scene.len = (uint32_t)n;
	return conn_send(c, &m);
}

/* Loads the test scene with ids 1..7 and waits for its SCENE_STATE. */
static int load_test_scene(struct conn *c)
{
	struct bc_proto_buf b;
	uint32_t seq;
	test_scene(&b, 1);
	seq = send_load(c, b.data, b.len);
	bc_proto_buf_finish(&b);
	while (seq && conn_expect(c, BC_MSG_SCENE_STATE, WAIT_MS) == 1) {
		if (c->m.scene_state.author_seq == seq) {
			return 0;
		}
	}
	return -1;
}

static uint32_t send_ops(struct conn *c, const struct bc_proto_edit_op *ops,
                         uint16_t n)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	m.edit.nops = n;
	m.edit.ops = ops;
	return conn_send(c, &m);
}

static uint32_t send_set(struct conn *c, uint32_t node, uint8_t field,
                         uint8_t count, float v)
{
	struct bc_proto_field f = {field, count, {v, v, v, v}};
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET,
	                              .node = node,
	                              .nfields = 1,
	                              .fields = &f};
	return send_ops(c, &op, 1);
}

/* Waits for the EDIT_APPLIED whose author_seq is seq (c->m); false on an
 * ERROR for seq or a timeout. */
static bool applied(struct conn *c, uint32_t seq)
{
	int64_t end = t_now_ms() + WAIT_MS;
	while (t_now_ms() < end) {
		if (conn_recv(c, 200) < 0) {
			return false;
		}
		if (c->m.type == BC_MSG_EDIT_APPLIED &&
		    c->m.edit_applied.author_seq == seq) {
			return true;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			return false;
		}
	}
	return false;
}

/* ---- 3: decoding errors ------------------------------------------------- */

struct bad {
	const char *name;
	int stage;    /* 0 before HELLO, 1 after it, 2 an editor in a session */
	uint8_t type; /* header type */
	uint8_t version;
	uint16_t flags;
	int64_t length; /* the header's length; -1: the payload's */
	const char *payload;
	size_t n; /* payload bytes sent */
	int code; /* the ERROR expected (positive) */
};

/* A SET of node 1 giving translate twice (section 9: EPARSE). */
#define SET_TWICE                                                              \
	"\x01\x00\x01\x01\x00\x00\x00\x02"                                     \
	"\x01\x03\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"             \
	"\x01\x03\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
/* A CAMERA whose eye.x is 2e6 (|v| above 10^6: ERANGE) or NaN. */
#define CAM_TAIL                                                               \
	"\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"     \
	"\x00\x00\x80\x3f\x00\x00\x00\x00\x00\x00\x20\x42"
#define CAM_FAR "\x00\x24\xf4\x49\x00\x00\x00\x00\x00\x00\x80\x3f" CAM_TAIL
#define CAM_NAN "\x00\x00\xc0\x7f\x00\x00\x00\x00\x00\x00\x80\x3f" CAM_TAIL

static const struct bad bads[] = {
    /* 3.1, header, each as soon as its byte arrives. */
    {"magic", 0, 4, 1, 0, 8, "\0\0\0\0\0\0\0\0", 8, -BC_EPROTO_MAGIC},
    {"version 2", 0, 4, 2, 0, 8, "\0\0\0\0\0\0\0\0", 8, -BC_EPROTO_VERSION},
    {"type 0", 1, 0, 1, 0, 0, NULL, 0, -BC_EPROTO_TYPE},
    {"type 39", 1, 39, 1, 0, 0, NULL, 0, -BC_EPROTO_TYPE},
    {"type 255", 0, 255, 1, 0, 0, NULL, 0, -BC_EPROTO_TYPE},
    /* 3.1 step 3, 5: a type clients never send. */
    {"WELCOME from a client", 1, 2, 1, 0, 0, NULL, 0, -BC_EPROTO_TYPE},
    {"OK from a client", 1, 6, 1, 0, 0, NULL, 0, -BC_EPROTO_TYPE},
    /* 3.1 step 4, 5: before HELLO only HELLO and PING. */
    {"SESSION_LIST before HELLO", 0, 26, 1, 0, 0, NULL, 0, -BC_ESTATE},
    {"flag on PING", 1, 4, 1, 1, 8, "\0\0\0\0\0\0\0\0", 8, -BC_EPROTO_FLAGS},
    /* 3.1 step 6: decided from the header alone (no payload is sent). */
    {"PING of 9 bytes", 1, 4, 1, 0, 9, NULL, 0, -BC_EPROTO_LENGTH},
    {"HELLO over 4 KiB", 0, 1, 1, 0, 5000, NULL, 0, -BC_EPROTO_LENGTH},
    {"SCENE_LOAD over 64 MiB", 2, 11, 1, 0, 67108865, NULL, 0,
     -BC_EPROTO_LENGTH},
    /* 3.2: payload rules, in a valid header. */
    {"PING of 7 bytes", 1, 4, 1, 0, -1, "\0\0\0\0\0\0\0", 7,
     -BC_EPROTO_TRUNCATED},
    {"trailing byte", 1, 23, 1, 0, -1, "\x01\x00\x61\x00", 4,
     -BC_EPROTO_TRAILING},
    {"role 3", 1, 8, 1, 0, -1, "\x03\x01\x00\x61", 4, -BC_EENUM},
    {"name with NUL", 1, 8, 1, 0, -1, "\x01\x01\x00\x00", 4, -BC_ESTRING},
    {"name not UTF-8", 1, 8, 1, 0, -1, "\x01\x01\x00\xff", 4, -BC_ESTRING},
    {"empty name", 1, 8, 1, 0, -1, "\x01\x00\x00", 3, -BC_EPROTO_LENGTH},
    {"op_count 0", 2, 13, 1, 0, -1, "\x00\x00", 2, -BC_EPROTO_COUNT},
    {"op kind 6", 2, 13, 1, 0, -1, "\x01\x00\x06\x01\x00\x00\x00", 7,
     -BC_EENUM},
    {"SET of node 0", 2, 13, 1, 0, -1,
     "\x01\x00\x01\x00\x00\x00\x00\x01\x01\x03\x00\x00\x00\x00\x00\x00"
     "\x00\x00\x00\x00\x00\x00",
     22, -BC_ERANGE},
    {"SET field twice", 2, 13, 1, 0, -1, SET_TWICE, 36, -BC_EPARSE},
    {"CAMERA eye 2e6", 2, 15, 1, 0, -1, CAM_FAR, 40, -BC_ERANGE},
    {"CAMERA eye NaN", 2, 15, 1, 0, -1, CAM_NAN, 40, -BC_ENONFINITE},
    {"HELLO version_min 0", 0, 1, 1, 0, -1,
     "\x00\x00\x01\x00\x07\x00\x00\x00\x00\x00\x00\x00\x00", 13, -BC_ERANGE},
    {"HELLO encodings bit 4", 0, 1, 1, 0, -1,
     "\x01\x00\x01\x00\x10\x00\x00\x00\x00\x00\x00\x00\x00", 13,
     -BC_EPROTO_FLAGS},
    {"VIEW width 0", 1, 16, 1, 0, -1, "\x00\x00\x10\x00\x01\x3c\x5a\x01", 8,
     -BC_ERANGE},
    {"VIEW encoding 5", 1, 16, 1, 0, -1, "\x10\x00\x10\x00\x05\x3c\x5a\x01", 8,
     -BC_EENUM},
    {"VIEW still_encoding 0", 1, 16, 1, 0, -1,
     "\x10\x00\x10\x00\x04\x3c\x5a\x01\x00", 9, -BC_EENUM},
    {"FRAME_ACK frame 0", 1, 36, 1, 0, -1, "\x00\x00\x00\x00", 4, -BC_ERANGE},
    {"SNAPSHOT JPEG", 2, 20, 1, 0, -1, "\x01", 1, -BC_EENUM},
    {"SNAPSHOT planes 0", 2, 20, 1, 0, -1, "\x02\x00", 2, -BC_ERANGE},
    {"SNAPSHOT planes bit 2", 2, 20, 1, 0, -1, "\x02\x04", 2, -BC_EPROTO_FLAGS},
    {"GET_STATS RESET alone", 1, 21, 1, 0, -1, "\x02", 1, -BC_ERANGE},
    {"GET_STATS parts 0", 1, 21, 1, 0, -1, "\x00", 1, -BC_ERANGE},
    {"FOLLOW on 2", 2, 29, 1, 0, -1, "\x02", 1, -BC_ERANGE},
};

/* Sections 3, 3.1, 3.2, 5, 6: each malformed message is answered with
 * ERROR carrying its code, seq 0 and FATAL, and the server closes. */
static void decoding_errors_are_fatal_with_seq_0(void)
{
	struct daemon d;
	REQUIRE(start(&d, "decode", NULL) == 0);
	for (size_t i = 0; i < sizeof(bads) / sizeof(bads[0]); i++) {
		const struct bad *b = &bads[i];
		struct conn c;
		uint8_t buf[128];
		uint32_t len =
		    b->length < 0 ? (uint32_t)b->n : (uint32_t)b->length;
		size_t n;
		bool got = false;
		REQUIRE(conn_open(&c, &d) == 0);
		if (b->stage >= 1) {
			REQUIRE(conn_hello(&c, "bad") == 0);
		}
		if (b->stage >= 2) {
			REQUIRE(conn_join(&c, "default", BC_PROTO_ROLE_EDITOR,
			                  false) == 0);
		}
		n = raw_msg(buf, b->version, b->type, b->flags, len, ++c.seq,
		            b->payload, b->n);
		if (strcmp(b->name, "magic") == 0) {
			buf[0] = 'X';
		}
		REQUIRE(send_raw(&c, buf, n) == 0);
		while (conn_recv(&c, WAIT_MS) == 1) {
			if (c.m.type == BC_MSG_ERROR) {
				got = true;
				break;
			}
		}
		if (!got || c.m.error.code != (uint16_t)b->code ||
		    c.m.seq != 0 || !(c.m.flags & BC_PROTO_FLAG_FATAL)) {
			fprintf(stderr, "  %s: %s, code %d seq %u flags %u\n",
			        b->name, got ? "wrong ERROR" : "no ERROR",
			        got ? (int)c.m.error.code : 0,
			        got ? c.m.seq : 0, got ? c.m.flags : 0);
			bc_test_failures++;
		}
		CHECK(closed(&c));
		conn_close(&c);
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 3.1: a stream that ends between two messages, or before any, ends
 * cleanly: the server closes without an ERROR. */
static void a_stream_ending_between_messages_ends_cleanly(void)
{
	struct daemon d;
	REQUIRE(start(&d, "clean", NULL) == 0);
	for (int hello = 0; hello < 2; hello++) {
		struct conn c;
		bool error = false;
		int rc;
		REQUIRE(conn_open(&c, &d) == 0);
		if (hello) {
			REQUIRE(conn_hello(&c, "clean") == 0);
			REQUIRE(send_empty(&c, BC_MSG_SESSION_LIST));
		}
		shutdown(c.fd, SHUT_WR);
		while ((rc = conn_recv(&c, WAIT_MS)) == 1) {
			error = error || c.m.type == BC_MSG_ERROR;
		}
		CHECK_EQ_INT(rc, -1); /* closed, not timed out */
		CHECK(!error);
		conn_close(&c);
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- 4, 5, 7.1: HELLO ------------------------------------------------- */

/* 4: the highest common version is picked, no common one is a fatal
 * EPROTO_VERSION; 5, 7.4: PING before HELLO is answered, stamp and seq
 * echoed; 2: WELCOME carries HELLO's seq. */
static void hello_negotiates_the_version(void)
{
	struct daemon d;
	struct conn c;
	struct bc_msg m = {.type = BC_MSG_HELLO};
	uint32_t seq;
	REQUIRE(start(&d, "version", NULL) == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	m = (struct bc_msg){.type = BC_MSG_PING};
	m.ping.stamp = 0x1122334455667788ull;
	seq = conn_send(&c, &m);
	REQUIRE(answer(&c, seq) == BC_MSG_PONG);
	CHECK(c.m.ping.stamp == 0x1122334455667788ull);
	m = (struct bc_msg){.type = BC_MSG_HELLO};
	m.hello.version_min = 1;
	m.hello.version_max = 9;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	seq = conn_send(&c, &m);
	REQUIRE(answer(&c, seq) == BC_MSG_WELCOME);
	CHECK_EQ_INT(c.m.welcome.version, 1);
	CHECK(alive(&c));
	conn_close(&c);

	REQUIRE(conn_open(&c, &d) == 0);
	m.hello.version_min = 2;
	m.hello.version_max = 3;
	seq = conn_send(&c, &m);
	REQUIRE(conn_expect(&c, BC_MSG_ERROR, WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.error.code, -BC_EPROTO_VERSION);
	CHECK(c.m.flags & BC_PROTO_FLAG_FATAL);
	CHECK_EQ_INT(c.m.seq, seq);
	CHECK(closed(&c));
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 5: a connection that sends nothing is closed with a fatal ETIMEOUT. */
static void a_silent_connection_times_out(void)
{
	struct daemon d;
	struct conn c;
	REQUIRE(start(&d, "silent", NULL) == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_expect(&c, BC_MSG_ERROR, 3 * WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.error.code, -BC_ETIMEOUT);
	CHECK(c.m.flags & BC_PROTO_FLAG_FATAL);
	CHECK(closed(&c));
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* A TCP connection to 127.0.0.1:port with a client reader, or fd -1. */
static void tcp_open(struct conn *c, int port)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	memset(c, 0, sizeof(*c));
	c->fd = socket(AF_INET, SOCK_STREAM, 0);
	inet_pton(AF_INET, "127.0.0.1", &sa.sin_addr);
	sa.sin_port = htons((uint16_t)port);
	if (c->fd < 0 || connect(c->fd, (struct sockaddr *)&sa, sizeof(sa))) {
		if (c->fd >= 0) {
			close(c->fd);
		}
		c->fd = -1;
		return;
	}
	bc_proto_reader_init(&c->r, &(struct bc_proto_reader_opts){
	                                .side = BC_PROTO_SIDE_CLIENT});
}

static uint32_t hello_token(struct conn *c, const char *token)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	m.hello.version_min = m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.token.ptr = token;
	m.hello.token.len = (uint32_t)strlen(token);
	return conn_send(c, &m);
}

/* 5, 7.1: a bad token is a fatal EAUTH answering the HELLO; 7.6: a token
 * that grants the viewer role only cannot join as editor (EPERM). */
static void tokens_refuse_hello_and_the_editor_role(void)
{
	struct daemon d;
	struct conn c;
	/* Static: a test that stops at a REQUIRE leaves daemon_log_path
	 * pointing here for the next one. */
	static char log[96];
	char cfg[96];
	const char *extra[] = {"--listen", "127.0.0.1:0", "--config", cfg,
	                       NULL};
	FILE *f;
	int port = 0;
	uint32_t seq;
	snprintf(cfg, sizeof(cfg), "%s/tokens.json", base_dir);
	snprintf(log, sizeof(log), "%s/tokens.log", base_dir);
	REQUIRE((f = fopen(cfg, "w")));
	fputs("{\"tokens\": [{\"token\": \"ed\", \"role\": \"editor\"}, "
	      "{\"token\": \"vw\", \"role\": \"viewer\"}]}\n",
	      f);
	fclose(f);
	daemon_log_path = log;
	REQUIRE(start(&d, "tokens", extra) == 0);
	daemon_log_path = NULL;
	port = daemon_log_port(log);
	REQUIRE(port > 0);

	tcp_open(&c, port);
	REQUIRE(c.fd >= 0);
	seq = hello_token(&c, "nope");
	REQUIRE(conn_expect(&c, BC_MSG_ERROR, WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.error.code, -BC_EAUTH);
	CHECK_EQ_INT(c.m.seq, seq); /* 2: the refused message's seq */
	CHECK(c.m.flags & BC_PROTO_FLAG_FATAL);
	CHECK(closed(&c));
	conn_close(&c);

	tcp_open(&c, port);
	REQUIRE(c.fd >= 0);
	seq = hello_token(&c, "vw");
	REQUIRE(answer(&c, seq) == BC_MSG_WELCOME);
	seq = send_session(&c, BC_MSG_SESSION_JOIN, "default",
	                   BC_PROTO_ROLE_EDITOR);
	CHECK_EQ_INT(refused(&c, seq), -BC_EPERM);
	CHECK(alive(&c));
	CHECK(conn_join(&c, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- 5: stages and roles ------------------------------------------------ */

/* 5: a second HELLO, CREATE/JOIN in a session, and the session requests
 * outside one are ESTATE, not fatal. */
static void requests_out_of_stage_are_estate_not_fatal(void)
{
	static const enum bc_msg_type outside[] = {
	    BC_MSG_SESSION_LEAVE, BC_MSG_PICK,    BC_MSG_SNAPSHOT,
	    BC_MSG_SCENE_LOAD,    BC_MSG_EDIT,    BC_MSG_UNDO,
	    BC_MSG_REDO,          BC_MSG_PRESENT, BC_MSG_SESSION_CAMERA,
	};
	struct daemon d;
	struct conn c;
	struct bc_msg m;
	struct bc_proto_buf scene;
	uint32_t seq;
	REQUIRE(start(&d, "stage", NULL) == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_hello(&c, "stage") == 0);
	/* A VIEW first, so that PICK and SNAPSHOT meet the stage rule. */
	REQUIRE(conn_view(&c, 32, 32, BC_PROTO_ENC_RAW));
	m = (struct bc_msg){.type = BC_MSG_HELLO};
	m.hello.version_min = m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	seq = conn_send(&c, &m);
	CHECK_EQ_INT(refused(&c, seq), -BC_ESTATE);
	test_scene(&scene, 1);
	for (size_t i = 0; i < sizeof(outside) / sizeof(outside[0]); i++) {
		m = (struct bc_msg){.type = outside[i]};
		switch (outside[i]) {
		case BC_MSG_PICK:
			m.pick.x = m.pick.y = 1;
			break;
		case BC_MSG_SNAPSHOT:
			m.snapshot.encoding = BC_PROTO_ENC_PNG;
			break;
		case BC_MSG_SCENE_LOAD:
			m.scene_load.scene.ptr = scene.data;
			m.scene_load.scene.len = (uint32_t)scene.len;
			break;
		case BC_MSG_EDIT: {
			static const struct bc_proto_edit_op op = {
			    .kind = BC_PROTO_EDIT_REMOVE, .node = 2};
			m.edit.nops = 1;
			m.edit.ops = &op;
			break;
		}
		case BC_MSG_PRESENT:
			m.toggle.on = 1;
			break;
		case BC_MSG_SESSION_CAMERA:
			m.session_camera = cam_a;
			break;
		default:
			break;
		}
		seq = conn_send(&c, &m);
		if (refused(&c, seq) != -BC_ESTATE) {
			fprintf(stderr, "  %s outside a session: not ESTATE\n",
			        bc_proto_type_name(outside[i]));
			bc_test_failures++;
		}
	}
	bc_proto_buf_finish(&scene);
	CHECK(alive(&c));
	REQUIRE(conn_join(&c, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	seq = send_session(&c, BC_MSG_SESSION_JOIN, "default",
	                   BC_PROTO_ROLE_EDITOR);
	CHECK_EQ_INT(refused(&c, seq), -BC_ESTATE);
	seq = send_session(&c, BC_MSG_SESSION_CREATE, "another",
	                   BC_PROTO_ROLE_EDITOR);
	CHECK_EQ_INT(refused(&c, seq), -BC_ESTATE);
	CHECK(alive(&c));
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 5, 7.9, 7.20, 7.25: a viewer's SCENE_LOAD, EDIT, UNDO, REDO and
 * SESSION_CAMERA are EPERM, not fatal. */
static void a_viewer_may_not_change_the_scene(void)
{
	struct daemon d;
	struct conn v;
	struct bc_proto_buf scene;
	uint32_t seqs[5];
	REQUIRE(start(&d, "viewer", NULL) == 0);
	REQUIRE(member(&v, &d, "v", "default", BC_PROTO_ROLE_VIEWER, false) ==
	        0);
	test_scene(&scene, 1);
	seqs[0] = send_load(&v, scene.data, scene.len);
	bc_proto_buf_finish(&scene);
	seqs[1] = send_set(&v, 1, BC_PROTO_FIELD_TRANSLATE, 3, 0.5f);
	seqs[2] = send_empty(&v, BC_MSG_UNDO);
	seqs[3] = send_empty(&v, BC_MSG_REDO);
	seqs[4] = send_camera(&v, BC_MSG_SESSION_CAMERA, &cam_a, 0);
	for (int i = 0; i < 5; i++) {
		CHECK_EQ_INT(refused(&v, seqs[i]), -BC_EPERM);
	}
	CHECK(alive(&v));
	conn_close(&v);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- 7.6, 7.7, 7.8: sessions ------------------------------------------- */

static bool lists_member(const struct bc_msg_session_info *si, uint32_t id)
{
	int seen = 0;
	for (uint16_t i = 0; i < si->nmembers; i++) {
		seen += si->members[i].id == id;
	}
	return seen == 1;
}

/* 7.6: CREATE is answered by SESSION_INFO then SCENE_STATE (5: the
 * built-in scene, order 0, author 0); names that are not file names are
 * EINVAL, not fatal. 7.8: SESSION_INFO (seq 0) reaches every member when
 * someone joins or leaves, with the receiver's own id and every member
 * once. 7.7: LEAVE is answered by OK. */
static void sessions_answer_and_announce_members(void)
{
	static const char *const bad_names[] = {".hidden", "a/b", "a b",
	                                        "\xc3\xa9t\xc3\xa9"};
	struct daemon d;
	struct conn a, b;
	struct node nodes[64];
	uint32_t seq, ida, idb;
	REQUIRE(start(&d, "sessions", NULL) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "alice") == 0);
	for (size_t i = 0; i < sizeof(bad_names) / sizeof(bad_names[0]); i++) {
		seq = send_session(&a, BC_MSG_SESSION_CREATE, bad_names[i],
		                   BC_PROTO_ROLE_EDITOR);
		CHECK_EQ_INT(refused(&a, seq), -BC_EINVAL);
	}
	seq = send_session(&a, BC_MSG_SESSION_CREATE, "s-1_x.y",
	                   BC_PROTO_ROLE_EDITOR);
	REQUIRE(conn_recv(&a, WAIT_MS) == 1);
	REQUIRE(a.m.type == BC_MSG_SESSION_INFO);
	CHECK_EQ_INT(a.m.seq, 0);
	CHECK_EQ_INT(a.m.session_info.role, BC_PROTO_ROLE_EDITOR);
	CHECK(a.m.session_info.name.len == 7 &&
	      memcmp(a.m.session_info.name.ptr, "s-1_x.y", 7) == 0);
	ida = a.m.session_info.member_id;
	CHECK_EQ_INT(a.m.session_info.nmembers, 1);
	CHECK(lists_member(&a.m.session_info, ida));
	REQUIRE(conn_recv(&a, WAIT_MS) == 1);
	REQUIRE(a.m.type == BC_MSG_SCENE_STATE);
	CHECK_EQ_INT(a.m.seq, 0);
	CHECK(a.m.scene_state.order == 0);
	CHECK_EQ_INT(a.m.scene_state.author, 0);
	CHECK_EQ_INT(a.m.scene_state.author_seq, 0);
	CHECK(walk_state(&a, nodes, 64) >= 1);

	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "bob") == 0);
	REQUIRE(conn_join(&b, "s-1_x.y", BC_PROTO_ROLE_VIEWER, false) == 0);
	idb = b.m.session_info.member_id;
	CHECK(idb != ida);
	CHECK_EQ_INT(b.m.session_info.role, BC_PROTO_ROLE_VIEWER);
	CHECK_EQ_INT(b.m.session_info.nmembers, 2);
	CHECK(lists_member(&b.m.session_info, ida));
	CHECK(lists_member(&b.m.session_info, idb));
	REQUIRE(conn_recv(&b, WAIT_MS) == 1);
	CHECK(b.m.type == BC_MSG_SCENE_STATE);
	REQUIRE(conn_expect(&a, BC_MSG_SESSION_INFO, WAIT_MS) == 1);
	CHECK_EQ_INT(a.m.seq, 0);
	CHECK_EQ_INT(a.m.session_info.member_id, ida);
	CHECK_EQ_INT(a.m.session_info.nmembers, 2);
	CHECK(lists_member(&a.m.session_info, idb));

	seq = send_empty(&b, BC_MSG_SESSION_LEAVE);
	CHECK(answer(&b, seq) == BC_MSG_OK);
	REQUIRE(conn_expect(&a, BC_MSG_SESSION_INFO, WAIT_MS) == 1);
	CHECK_EQ_INT(a.m.session_info.nmembers, 1);
	CHECK(lists_member(&a.m.session_info, ida));
	/* Back in READY: it may join again. */
	CHECK(conn_join(&b, "s-1_x.y", BC_PROTO_ROLE_VIEWER, false) == 0);
	conn_close(&a);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 7.6, 11: a JOIN of a session that has WELCOME's max_members is ELIMIT,
 * and so is a CREATE when the server holds all the sessions it can (each
 * with a member, so none can make room). */
static void full_sessions_and_a_full_server_are_elimit(void)
{
	enum { MAXC = 240 };
	static struct conn c[MAXC];
	struct daemon d;
	struct bc_msg m = {.type = BC_MSG_HELLO};
	int n = 0, code = 0;
	uint32_t seq;
	uint16_t max_members;
	REQUIRE(start(&d, "full", NULL) == 0);
	REQUIRE(conn_open(&c[0], &d) == 0);
	m.hello.version_min = m.hello.version_max = 1;
	REQUIRE(conn_send(&c[0], &m));
	REQUIRE(conn_expect(&c[0], BC_MSG_WELCOME, WAIT_MS) == 1);
	max_members = c[0].m.welcome.max_members;
	REQUIRE(max_members >= 1 && max_members < MAXC / 2);
	REQUIRE(conn_join(&c[0], "full", BC_PROTO_ROLE_EDITOR, true) == 0);
	for (n = 1; n < max_members; n++) {
		REQUIRE(conn_open(&c[n], &d) == 0);
		REQUIRE(conn_hello_enc(&c[n], "m", 0) == 0);
		REQUIRE(conn_join(&c[n], "full", BC_PROTO_ROLE_VIEWER, false) ==
		        0);
	}
	REQUIRE(conn_open(&c[n], &d) == 0);
	REQUIRE(conn_hello_enc(&c[n], "one-too-many", 0) == 0);
	seq = send_session(&c[n], BC_MSG_SESSION_JOIN, "full",
	                   BC_PROTO_ROLE_VIEWER);
	CHECK_EQ_INT(refused(&c[n], seq), -BC_ELIMIT);
	CHECK(alive(&c[n]));
	/* Sessions of their own until the server is full. */
	for (; n < MAXC; n++) {
		char name[16];
		if (n > max_members) {
			REQUIRE(conn_open(&c[n], &d) == 0);
			REQUIRE(conn_hello_enc(&c[n], "m", 0) == 0);
		}
		snprintf(name, sizeof(name), "own%d", n);
		seq = send_session(&c[n], BC_MSG_SESSION_CREATE, name,
		                   BC_PROTO_ROLE_EDITOR);
		/* SESSION_INFO (seq 0) or an ERROR answering seq. */
		while (conn_recv(&c[n], WAIT_MS) == 1 &&
		       c[n].m.type != BC_MSG_SESSION_INFO &&
		       !(c[n].m.type == BC_MSG_ERROR && c[n].m.seq == seq)) {
		}
		if (c[n].m.type == BC_MSG_ERROR) {
			code = c[n].m.error.code;
			CHECK(!(c[n].m.flags & BC_PROTO_FLAG_FATAL));
			CHECK(alive(&c[n]));
			n++;
			break;
		}
		if (c[n].m.type != BC_MSG_SESSION_INFO) {
			CHECK(0 && "no answer to SESSION_CREATE");
			n++;
			break;
		}
	}
	printf("  %d connections, the last CREATE answered %s\n", n,
	       code ? bc_err_name(-code) : "without an ERROR");
	CHECK_EQ_INT(code, -BC_ELIMIT);
	for (int i = 0; i < n && i < MAXC; i++) {
		conn_close(&c[i]);
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 7.7: after SESSION_LEAVE's OK no FRAME or PICK_RESULT of the session
 * follows (its unanswered PICKs and SNAPSHOTs are dropped). 7.19: a member
 * that deletes its own session hears ERROR ENOSESSION (seq 0, not fatal)
 * first, then OK; it keeps its view in READY, so its next session's
 * frames come without a new VIEW. */
static void leaving_and_deleting_drop_what_was_asked(void)
{
	struct daemon d;
	struct conn a;
	uint32_t seq;
	bool late = false, enosession = false;
	REQUIRE(start(&d, "leave", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "l1", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_view_scaled(&a, 200, 150, BC_PROTO_ENC_RAW, 1));
	REQUIRE(conn_expect(&a, BC_MSG_FRAME, WAIT_MS) == 1);
	for (int i = 0; i < 3; i++) {
		struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
		m.snapshot.encoding = BC_PROTO_ENC_RAW;
		m.snapshot.planes = 3;
		REQUIRE(conn_send(&a, &m));
		m = (struct bc_msg){.type = BC_MSG_PICK};
		m.pick.x = 100;
		m.pick.y = 75;
		REQUIRE(conn_send(&a, &m));
	}
	seq = send_empty(&a, BC_MSG_SESSION_LEAVE);
	REQUIRE(answer(&a, seq) == BC_MSG_OK);
	while (conn_recv(&a, 1500) == 1) {
		late = late || a.m.type == BC_MSG_FRAME ||
		       a.m.type == BC_MSG_PICK_RESULT;
	}
	CHECK(!late);

	REQUIRE(conn_view_scaled(&a, 200, 150, BC_PROTO_ENC_RAW, 1));
	REQUIRE(conn_join(&a, "l2", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_FRAME, WAIT_MS) == 1);
	seq = send_session(&a, BC_MSG_SESSION_DELETE, "l2", 0);
	while (conn_recv(&a, WAIT_MS) == 1) {
		if (a.m.type == BC_MSG_ERROR) {
			CHECK_EQ_INT(a.m.error.code, -BC_ENOSESSION);
			CHECK_EQ_INT(a.m.seq, 0);
			CHECK(!(a.m.flags & BC_PROTO_FLAG_FATAL));
			enosession = true;
		}
		if (a.m.type == BC_MSG_OK) {
			CHECK_EQ_INT(a.m.seq, seq);
			break;
		}
	}
	CHECK(enosession);
	CHECK(a.m.type == BC_MSG_OK);
	/* Back in READY with its view: a new session sends frames of it. */
	REQUIRE(conn_join(&a, "l3", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_FRAME, WAIT_MS) == 1);
	CHECK(a.m.frame.width == 200 && a.m.frame.height == 150);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 7.21: a session kept on disk that the server has not loaded since it
 * started is listed with flags 0 (and prims, order, last_edit_ms 0). More
 * sessions are made than a server keeps in memory, so that after a
 * restart some stay on disk until joined. */
static void a_session_not_loaded_since_start_is_listed_with_flags_0(void)
{
	enum { SESSIONS = 130 };
	struct daemon d;
	struct conn a;
	uint32_t seq, on_disk = 0;
	REQUIRE(start(&d, "disk", NULL) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	for (int i = 0; i < SESSIONS; i++) {
		char name[16];
		snprintf(name, sizeof(name), "kept%03d", i);
		REQUIRE(conn_join(&a, name, BC_PROTO_ROLE_EDITOR, true) == 0);
		seq = send_empty(&a, BC_MSG_SESSION_LEAVE);
		REQUIRE(answer(&a, seq) == BC_MSG_OK);
	}
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	REQUIRE(start(&d, "disk", NULL) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	seq = send_empty(&a, BC_MSG_SESSION_LIST);
	REQUIRE(answer(&a, seq) == BC_MSG_SESSIONS);
	CHECK(a.m.sessions.nsessions >= SESSIONS);
	for (uint16_t i = 0; i < a.m.sessions.nsessions; i++) {
		const struct bc_proto_session_entry *e =
		    &a.m.sessions.sessions[i];
		if (e->flags & BC_PROTO_SESSION_LOADED) {
			continue;
		}
		on_disk++;
		CHECK_EQ_INT(e->flags, 0);
		CHECK_EQ_INT(e->members, 0);
		CHECK_EQ_INT(e->prims, 0);
		CHECK(e->order == 0 && e->last_edit_ms == 0);
	}
	printf("  %u of %u sessions listed as on disk only\n", on_disk,
	       a.m.sessions.nsessions);
	CHECK(on_disk > 0);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- 7.9 .. 7.12, 8, 9: scenes and edits -------------------------------- */

/* 7.9, 7.10: a SCENE_LOAD reaches every member, the author included, as
 * SCENE_STATE (seq 0) with the next order, the author's member id and
 * seq; nodes given id 0 get ids (7.10: every id non-zero); 9: range 0 is
 * stored as 1.25 blend; a bad scene is a non-fatal ERROR with the
 * decoder's code; 7.20: a SCENE_LOAD empties the undo history. */
static void scene_load_reaches_every_member_with_the_next_order(void)
{
	struct daemon d;
	struct conn a, b;
	struct bc_proto_buf s;
	struct node nodes[16];
	uint64_t order;
	uint32_t seq, ida;
	int n;
	REQUIRE(start(&d, "load", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "ld", BC_PROTO_ROLE_EDITOR, true) == 0);
	ida = 0;
	REQUIRE(member(&b, &d, "b", "ld", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SESSION_INFO, WAIT_MS) == 1);
	ida = a.m.session_info.member_id;
	order = b.m.scene_state.order;
	/* An edit to undo, then a load. */
	REQUIRE(walk_state(&b, nodes, 16) >= 1);
	{
		const struct node *p = NULL;
		int all = walk_state(&b, nodes, 16);
		for (int i = 0; i < all && i < 16 && !p; i++) {
			p = nodes[i].tag >= 1 && nodes[i].tag <= 32 ? &nodes[i]
			                                            : NULL;
		}
		REQUIRE(p);
		seq = send_set(&a, p->id, BC_PROTO_FIELD_TRANSLATE, 3, 0.1f);
		REQUIRE(applied(&a, seq));
		order = a.m.edit_applied.order;
	}
	test_scene(&s, 0);
	seq = send_load(&a, s.data, s.len);
	bc_proto_buf_finish(&s);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, WAIT_MS) == 1);
	CHECK_EQ_INT(a.m.seq, 0);
	CHECK(a.m.scene_state.order == order + 1);
	CHECK_EQ_INT(a.m.scene_state.author, ida);
	CHECK_EQ_INT(a.m.scene_state.author_seq, seq);
	REQUIRE(conn_expect(&b, BC_MSG_SCENE_STATE, WAIT_MS) == 1);
	CHECK(b.m.scene_state.order == order + 1);
	CHECK_EQ_INT(b.m.scene_state.author, ida);
	CHECK_EQ_INT(b.m.scene_state.author_seq, seq);
	n = walk_state(&b, nodes, 16);
	REQUIRE(n == 7);
	for (int i = 0; i < n; i++) {
		CHECK(nodes[i].id != 0);
		for (int j = 0; j < i; j++) {
			CHECK(nodes[i].id != nodes[j].id);
		}
	}
	CHECK_EQ_INT(nodes[2].tag, 0x80 | K_SMOOTH_UNION);
	CHECK_NEAR(nodes[2].range, 1.25 * 0.2, 1e-6);
	/* Nothing to undo after a load. */
	seq = send_empty(&a, BC_MSG_UNDO);
	CHECK_EQ_INT(refused(&a, seq), -BC_ESTATE);
	/* A bad scene: its decoder's code, not fatal. */
	{
		uint8_t dup[256];
		test_scene(&s, 1);
		REQUIRE(s.len + 1 <= sizeof(dup));
		memcpy(dup, s.data, s.len);
		dup[s.len] = 0;
		seq = send_load(&a, dup, s.len + 1);
		CHECK_EQ_INT(refused(&a, seq), -BC_EPROTO_TRAILING);
		bc_proto_buf_finish(&s);
		bc_proto_buf_init(&s, 0);
		bc_proto_scene_begin(&s, NULL, 3);
		bc_proto_scene_op(&s, K_UNION, 1, 0.0f, 0.0f, 2);
		sphere(&s, 2, 0.0f);
		sphere(&s, 2, 1.0f);
		seq = send_load(&a, s.data, s.len);
		CHECK_EQ_INT(refused(&a, seq), -BC_EDUPID);
		bc_proto_buf_finish(&s);
	}
	CHECK(alive(&a));
	conn_close(&a);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 7.11: a batch with a failing operation applies none of it and takes no
 * order number; 7.12: EDIT_APPLIED (seq 0) repeats the operations as sent,
 * to the bit (negative zero kept, section 1). */
static void an_edit_applies_whole_or_not_at_all(void)
{
	struct daemon d;
	struct conn a, j;
	struct node nodes[16];
	uint64_t order;
	uint32_t seq;
	const struct node *p;
	int n;
	REQUIRE(start(&d, "batch", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "b", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(load_test_scene(&a) == 0);
	order = a.m.scene_state.order;
	{
		struct bc_proto_field f = {
		    BC_PROTO_FIELD_TRANSLATE, 3, {0.75f, 0, 0, 0}};
		struct bc_proto_edit_op ops[2] = {
		    {.kind = BC_PROTO_EDIT_SET,
		     .node = 2,
		     .nfields = 1,
		     .fields = &f},
		    {.kind = BC_PROTO_EDIT_SET,
		     .node = 999,
		     .nfields = 1,
		     .fields = &f},
		};
		seq = send_ops(&a, ops, 2);
		CHECK_EQ_INT(refused(&a, seq), -BC_ENONODE);
	}
	REQUIRE(member(&j, &d, "j", "b", BC_PROTO_ROLE_VIEWER, false) == 0);
	CHECK(j.m.scene_state.order == order);
	n = walk_state(&j, nodes, 16);
	REQUIRE(n == 7);
	REQUIRE((p = find(nodes, n, 2)) != NULL);
	CHECK_EQ_INT(p->translate_x, -1);
	conn_close(&j);
	{
		struct bc_proto_field f[2] = {
		    {BC_PROTO_FIELD_TRANSLATE, 3, {-0.0f, 0.5f, 1e-7f, 0}},
		    {BC_PROTO_FIELD_PARAM0, 1, {0.25f, 0, 0, 0}},
		};
		struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET,
		                              .node = 4,
		                              .nfields = 2,
		                              .fields = f};
		const struct bc_proto_edit_op *got;
		seq = send_ops(&a, &op, 1);
		REQUIRE(applied(&a, seq));
		CHECK_EQ_INT(a.m.seq, 0);
		CHECK(a.m.edit_applied.order == order + 1);
		REQUIRE(a.m.edit_applied.nops == 1);
		got = &a.m.edit_applied.ops[0];
		CHECK(got->kind == BC_PROTO_EDIT_SET && got->node == 4);
		REQUIRE(got->nfields == 2);
		for (int i = 0; i < 2; i++) {
			CHECK_EQ_INT(got->fields[i].field, f[i].field);
			CHECK_EQ_INT(got->fields[i].count, f[i].count);
			CHECK(memcmp(got->fields[i].v, f[i].v,
			             4u * f[i].count) == 0);
		}
	}
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static uint32_t send_subtree(struct conn *c, enum bc_proto_edit_kind kind,
                             uint32_t node, uint32_t id)
{
	struct bc_proto_buf s;
	struct bc_proto_edit_op op = {.kind = kind, .node = node};
	uint32_t seq;
	bc_proto_buf_init(&s, 0);
	bc_proto_scene_begin(&s, NULL, 1);
	sphere(&s, id, 2.0f);
	op.subtree.ptr = s.data;
	op.subtree.len = (uint32_t)s.len;
	seq = send_ops(c, &op, 1);
	bc_proto_buf_finish(&s);
	return seq;
}

/* 8, 9: subtree ids must be new (EDUPID), except a REPLACE's root may
 * reuse the replaced node's; INSERT under a unary node is EINVAL; a SET
 * of blend on a sharp operator is EINVAL; a field that does not apply to
 * the node is ERANGE or EINVAL; each not fatal. */
static void edits_meaning_is_checked_not_fatally(void)
{
	struct daemon d;
	struct conn a;
	uint32_t seq;
	int code;
	REQUIRE(start(&d, "meaning", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "m", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(load_test_scene(&a) == 0);
	seq = send_subtree(&a, BC_PROTO_EDIT_INSERT, 1, 2);
	CHECK_EQ_INT(refused(&a, seq), -BC_EDUPID);
	seq = send_subtree(&a, BC_PROTO_EDIT_REPLACE, 4, 2);
	CHECK_EQ_INT(refused(&a, seq), -BC_EDUPID);
	seq = send_subtree(&a, BC_PROTO_EDIT_INSERT, 6, 50);
	CHECK_EQ_INT(refused(&a, seq), -BC_EINVAL);
	seq = send_set(&a, 1, BC_PROTO_FIELD_BLEND, 1, 0.1f);
	CHECK_EQ_INT(refused(&a, seq), -BC_EINVAL);
	seq = send_set(&a, 2, BC_PROTO_FIELD_BLEND, 1, 0.1f);
	code = refused(&a, seq);
	CHECK(code == -BC_ERANGE || code == -BC_EINVAL);
	seq = send_set(&a, 1, BC_PROTO_FIELD_TRANSLATE, 3, 0.1f);
	code = refused(&a, seq);
	CHECK(code == -BC_ERANGE || code == -BC_EINVAL);
	/* A sphere's radius must be > 0. */
	seq = send_set(&a, 2, BC_PROTO_FIELD_PARAM0, 1, -1.0f);
	CHECK_EQ_INT(refused(&a, seq), -BC_ERANGE);
	seq = send_subtree(&a, BC_PROTO_EDIT_REPLACE, 4, 4);
	CHECK(applied(&a, seq));
	seq = send_subtree(&a, BC_PROTO_EDIT_INSERT, 1, 51);
	CHECK(applied(&a, seq));
	CHECK(alive(&a));
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 7.20, 7.25: UNDO takes back the newest edit, not a SESSION_CAMERA made
 * after it. */
static void undo_does_not_take_a_camera_back(void)
{
	struct daemon d;
	struct conn a;
	uint64_t order;
	uint32_t seq;
	REQUIRE(start(&d, "undo", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "u", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(send_toggle(&a, BC_MSG_FOLLOW, 0)); /* knows type 33 */
	REQUIRE(load_test_scene(&a) == 0);
	seq = send_set(&a, 2, BC_PROTO_FIELD_TRANSLATE, 3, 0.3f);
	REQUIRE(applied(&a, seq));
	order = a.m.edit_applied.order;
	seq = send_camera(&a, BC_MSG_SESSION_CAMERA, &cam_b, 0);
	REQUIRE(conn_expect(&a, BC_MSG_SESSION_CAMERA_SET, WAIT_MS) == 1);
	CHECK_EQ_INT(a.m.seq, 0);
	CHECK_EQ_INT(a.m.session_camera_set.author_seq, seq);
	CHECK(a.m.session_camera_set.order == order + 1);
	seq = send_empty(&a, BC_MSG_UNDO);
	REQUIRE(applied(&a, seq));
	CHECK(a.m.flags & BC_PROTO_FLAG_UNDO);
	CHECK(a.m.edit_applied.target_order == order);
	CHECK(a.m.edit_applied.order == order + 2);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- 7.13 .. 7.18: camera, view, frames, pick -------------------------- */

/* 7.13: eye = target, or up along the view, is a non-fatal ERANGE. 7.14:
 * a VIEW encoding the HELLO did not list is EINVAL, a size over WELCOME's
 * max_dim is ERANGE, not fatal; before any VIEW no FRAME comes, a PICK is
 * ERANGE and a SNAPSHOT ESTATE. 7.16: a PICK outside the view is ERANGE;
 * inside, PICK_RESULT answers with the PICK's seq. */
static void camera_view_and_pick_refusals(void)
{
	struct daemon d;
	struct conn a;
	struct bc_msg m = {.type = BC_MSG_HELLO};
	struct bc_msg_camera k = cam_a;
	uint16_t max_dim;
	uint32_t seq;
	bool frame = false;
	REQUIRE(start(&d, "view", NULL) == 0);
	REQUIRE(conn_open(&a, &d) == 0);
	m.hello.version_min = m.hello.version_max = 1;
	m.hello.encodings = 1u << (BC_PROTO_ENC_JPEG - 1);
	REQUIRE(conn_send(&a, &m));
	REQUIRE(conn_expect(&a, BC_MSG_WELCOME, WAIT_MS) == 1);
	max_dim = a.m.welcome.max_dim;
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	memcpy(k.target, k.eye, sizeof(k.eye));
	seq = send_camera(&a, BC_MSG_CAMERA, &k, 0);
	CHECK_EQ_INT(refused(&a, seq), -BC_ERANGE);
	k = cam_a;
	memcpy(k.up, k.eye, sizeof(k.up)); /* along eye - target */
	seq = send_camera(&a, BC_MSG_CAMERA, &k, 0);
	CHECK_EQ_INT(refused(&a, seq), -BC_ERANGE);
	m = (struct bc_msg){.type = BC_MSG_PICK};
	m.pick.x = m.pick.y = 0;
	seq = conn_send(&a, &m);
	CHECK_EQ_INT(refused(&a, seq), -BC_ERANGE);
	m = (struct bc_msg){.type = BC_MSG_SNAPSHOT};
	m.snapshot.encoding = BC_PROTO_ENC_PNG;
	seq = conn_send(&a, &m);
	CHECK_EQ_INT(refused(&a, seq), -BC_ESTATE);
	seq = conn_view(&a, 32, 32, BC_PROTO_ENC_PNG);
	CHECK_EQ_INT(refused(&a, seq), -BC_EINVAL);
	while (conn_recv(&a, 1000) == 1) {
		frame = frame || a.m.type == BC_MSG_FRAME;
	}
	CHECK(!frame);
	if (max_dim < BC_PROTO_MAX_DIM) {
		seq = conn_view(&a, (uint16_t)(max_dim + 1), 16,
		                BC_PROTO_ENC_JPEG);
		CHECK_EQ_INT(refused(&a, seq), -BC_ERANGE);
	}
	REQUIRE(conn_view(&a, 40, 30, BC_PROTO_ENC_JPEG));
	m = (struct bc_msg){.type = BC_MSG_PICK};
	m.pick.x = 40;
	m.pick.y = 0;
	seq = conn_send(&a, &m);
	CHECK_EQ_INT(refused(&a, seq), -BC_ERANGE);
	m.pick.x = 20;
	m.pick.y = 15;
	seq = conn_send(&a, &m);
	CHECK(answer(&a, seq) == BC_MSG_PICK_RESULT);
	CHECK(a.m.pick_result.x == 20 && a.m.pick_result.y == 15);
	CHECK(alive(&a));
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Collects a drag's frames up to the first STILL; returns the highest
 * level seen, -1 when no still came. */
static int levels_up_to_the_still(struct conn *c)
{
	int top = 0;
	for (int i = 0; i < 6; i++) {
		struct bc_msg_camera k = cam_a;
		k.eye[0] = 0.2f * (float)i;
		if (!send_camera(c, BC_MSG_CAMERA, &k,
		                 i < 5 ? BC_PROTO_FLAG_INTERACTING : 0)) {
			return -1;
		}
	}
	for (;;) {
		int level;
		if (conn_expect(c, BC_MSG_FRAME, WAIT_MS) != 1) {
			return -1;
		}
		CHECK_EQ_INT(c->m.seq, 0);
		level = (int)bc_proto_flags_level(c->m.flags);
		top = level > top ? level : top;
		if (c->m.flags & BC_PROTO_FLAG_STILL) {
			CHECK_EQ_INT(level, 0);
			return top;
		}
	}
}

/* 7.14, 7.15: no FRAME's level passes the VIEW's downscale (2^n <=
 * downscale). */
static void frames_stay_within_the_views_downscale(void)
{
	struct daemon d;
	struct conn a;
	REQUIRE(start(&d, "downscale", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "default", BC_PROTO_ROLE_VIEWER, false) ==
	        0);
	REQUIRE(conn_view_scaled(&a, 160, 120, BC_PROTO_ENC_RAW, 1));
	CHECK_EQ_INT(levels_up_to_the_still(&a), 0);
	REQUIRE(conn_view_scaled(&a, 160, 120, BC_PROTO_ENC_RAW, 3));
	{
		int top = levels_up_to_the_still(&a);
		CHECK(top >= 0 && top <= 1);
	}
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- 2, 7.3 .. 7.5, 7.18, 7.21 .. 7.24: seq and answers ---------------- */

/* 2: answers carry their request's seq (PONG, STATS, SESSIONS, OK, the
 * snapshot's FRAME, ERROR), the rest seq 0 (PRESENTER, FOLLOW_CAMERA,
 * other FRAMEs); 7.4: PINGs are answered in order, stamp echoed; 7.18:
 * STATS without LOAD is the 64-byte one; 7.3: an ERROR from a client
 * with a code the server does not know is accepted; 5: the server never
 * sends PING. */
static void answers_carry_their_requests_seq(void)
{
	struct daemon d;
	struct conn a, f;
	struct bc_msg m;
	uint32_t seqs[3], seq;
	bool pinged = false;
	REQUIRE(start(&d, "seq", NULL) == 0);
	REQUIRE(member(&a, &d, "a", "q", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(member(&f, &d, "f", "q", BC_PROTO_ROLE_VIEWER, false) == 0);
	for (int i = 0; i < 3; i++) {
		m = (struct bc_msg){.type = BC_MSG_PING};
		m.ping.stamp = 1000u + (uint64_t)i;
		seqs[i] = conn_send(&a, &m);
	}
	for (int i = 0; i < 3; i++) {
		REQUIRE(conn_expect(&a, BC_MSG_PONG, WAIT_MS) == 1);
		CHECK_EQ_INT(a.m.seq, seqs[i]);
		CHECK(a.m.ping.stamp == 1000u + (uint64_t)i);
	}
	seq = send_empty(&a, BC_MSG_GET_STATS);
	REQUIRE(answer(&a, seq) == BC_MSG_STATS);
	CHECK(!a.m.stats.has_load);
	seq = send_empty(&a, BC_MSG_SESSION_LIST);
	CHECK(answer(&a, seq) == BC_MSG_SESSIONS);
	/* An ERROR of a code nobody knows, from the client. */
	{
		uint8_t buf[32];
		size_t n = raw_msg(buf, 1, BC_MSG_ERROR, 0, 4, ++a.seq,
		                   "\xe7\x03\x00\x00", 4);
		REQUIRE(send_raw(&a, buf, n) == 0);
	}
	CHECK(alive(&a));
	/* The presenter's camera reaches the follower with seq 0. */
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	REQUIRE(answer(&a, seq) == BC_MSG_OK);
	seq = send_toggle(&f, BC_MSG_FOLLOW, 1);
	while (conn_recv(&f, WAIT_MS) == 1 && f.m.type != BC_MSG_OK) {
		if (f.m.type == BC_MSG_PRESENTER ||
		    f.m.type == BC_MSG_FOLLOW_CAMERA) {
			CHECK_EQ_INT(f.m.seq, 0);
		}
	}
	CHECK(f.m.type == BC_MSG_OK && f.m.seq == seq);
	REQUIRE(conn_view(&f, 48, 32, BC_PROTO_ENC_PNG));
	send_camera(&a, BC_MSG_CAMERA, &cam_b, 0);
	REQUIRE(conn_expect(&f, BC_MSG_FOLLOW_CAMERA, WAIT_MS) == 1);
	CHECK_EQ_INT(f.m.seq, 0);
	m = (struct bc_msg){.type = BC_MSG_SNAPSHOT};
	m.snapshot.encoding = BC_PROTO_ENC_PNG;
	seq = conn_send(&f, &m);
	for (;;) {
		REQUIRE(conn_expect(&f, BC_MSG_FRAME, WAIT_MS) == 1);
		if (f.m.flags & BC_PROTO_FLAG_SNAPSHOT) {
			CHECK_EQ_INT(f.m.seq, seq);
			CHECK(f.m.flags & BC_PROTO_FLAG_STILL);
			break;
		}
		CHECK_EQ_INT(f.m.seq, 0);
	}
	while (conn_recv(&a, 300) == 1) {
		pinged = pinged || a.m.type == BC_MSG_PING;
	}
	while (conn_recv(&f, 300) == 1) {
		pinged = pinged || f.m.type == BC_MSG_PING;
	}
	CHECK(!pinged);
	conn_close(&a);
	conn_close(&f);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* 5, 7.22: PRESENT outside a session is ESTATE; FOLLOW 1 with nobody
 * presenting is ESTATE and the sender hears PRESENTER 0; 4: a connection
 * that sent FOLLOW (even refused) knows PRESENTER and hears it on
 * joining while someone presents; 5: VIEW does not end a follow; PRESENT
 * 1 from a follower ends its follow; PRESENT 0 from the presenter ends the
 * presentation for every member that knows it, the one leaving excepted
 * when the presenter leaves. */
static void presenting_rules(void)
{
	struct daemon d;
	struct conn a, b, c;
	struct bc_msg_presenter pm = {0};
	uint32_t seq, ida, idb;
	bool told = false;
	REQUIRE(start(&d, "present", NULL) == 0);
	REQUIRE(conn_open(&c, &d) == 0 && conn_hello(&c, "c") == 0);
	seq = send_toggle(&c, BC_MSG_PRESENT, 1);
	CHECK_EQ_INT(refused(&c, seq), -BC_ESTATE);
	seq = send_toggle(&c, BC_MSG_FOLLOW, 0);
	CHECK_EQ_INT(refused(&c, seq), -BC_ESTATE);

	REQUIRE(member(&a, &d, "a", "p", BC_PROTO_ROLE_EDITOR, true) == 0);
	ida = 0;
	seq = send_toggle(&a, BC_MSG_FOLLOW, 1);
	{
		int code = 0;
		while ((!code || !told) && conn_recv(&a, WAIT_MS) == 1) {
			if (a.m.type == BC_MSG_PRESENTER) {
				told = a.m.presenter.presenter == 0 &&
				       a.m.presenter.following == 0;
			}
			if (a.m.type == BC_MSG_ERROR && a.m.seq == seq) {
				code = a.m.error.code;
			}
		}
		CHECK_EQ_INT(code, -BC_ESTATE);
		CHECK(told);
	}
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	while (conn_recv(&a, WAIT_MS) == 1 &&
	       !(a.m.type == BC_MSG_OK && a.m.seq == seq)) {
		if (a.m.type == BC_MSG_PRESENTER) {
			ida = a.m.presenter.presenter;
		}
	}
	REQUIRE(ida != 0);
	/* c, refused before it joined, is told who presents on joining. */
	REQUIRE(conn_join(&c, "p", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&c, BC_MSG_PRESENTER, WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.presenter.presenter, ida);
	CHECK_EQ_INT(c.m.presenter.following, 0);
	/* b follows; a VIEW keeps the follow. */
	REQUIRE(member(&b, &d, "b", "p", BC_PROTO_ROLE_VIEWER, false) == 0);
	seq = send_toggle(&b, BC_MSG_FOLLOW, 1);
	CHECK(answer(&b, seq) == BC_MSG_OK);
	REQUIRE(conn_view(&b, 32, 24, BC_PROTO_ENC_PNG));
	send_camera(&a, BC_MSG_CAMERA, &cam_b, 0);
	told = false;
	while (!told && conn_expect(&b, BC_MSG_FOLLOW_CAMERA, WAIT_MS) == 1) {
		told = memcmp(&b.m.follow_camera.camera, &cam_b,
		              sizeof(cam_b)) == 0;
	}
	CHECK(told);
	/* b presents: it no longer follows, and presents itself. */
	seq = send_toggle(&b, BC_MSG_PRESENT, 1);
	idb = 0;
	while (conn_recv(&b, WAIT_MS) == 1 &&
	       !(b.m.type == BC_MSG_OK && b.m.seq == seq)) {
		if (b.m.type == BC_MSG_PRESENTER) {
			pm = b.m.presenter;
		}
	}
	CHECK(b.m.type == BC_MSG_OK);
	idb = pm.presenter;
	CHECK(idb != 0 && idb != ida);
	CHECK_EQ_INT(pm.following, 0);
	/* a follows b; b stops presenting: a and c hear presenter 0. */
	seq = send_toggle(&a, BC_MSG_FOLLOW, 1);
	CHECK(answer(&a, seq) == BC_MSG_OK);
	while (conn_recv(&c, 300) == 1) {
	}
	seq = send_toggle(&b, BC_MSG_PRESENT, 0);
	CHECK(answer(&b, seq) == BC_MSG_OK);
	REQUIRE(conn_expect(&a, BC_MSG_PRESENTER, WAIT_MS) == 1);
	CHECK_EQ_INT(a.m.presenter.presenter, 0);
	CHECK_EQ_INT(a.m.presenter.following, 0);
	REQUIRE(conn_expect(&c, BC_MSG_PRESENTER, WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.presenter.presenter, 0);
	/* a presents and leaves: c is told, a is not. */
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	CHECK(answer(&a, seq) == BC_MSG_OK);
	REQUIRE(conn_expect(&c, BC_MSG_PRESENTER, WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.presenter.presenter, ida);
	seq = send_empty(&a, BC_MSG_SESSION_LEAVE);
	told = false;
	while (conn_recv(&a, WAIT_MS) == 1 &&
	       !(a.m.type == BC_MSG_OK && a.m.seq == seq)) {
		told = told || a.m.type == BC_MSG_PRESENTER;
	}
	CHECK(a.m.type == BC_MSG_OK);
	CHECK(!told);
	REQUIRE(conn_expect(&c, BC_MSG_PRESENTER, WAIT_MS) == 1);
	CHECK_EQ_INT(c.m.presenter.presenter, 0);
	conn_close(&a);
	conn_close(&b);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* GET_STATS's LINK part: over TCP the link section carries the round trip
 * and delivery rate the server's TCP measures (loopback: well under a
 * second, non-zero once a frame went out), over a Unix socket zeros; the
 * payload grows by exactly the 32 bytes of the section. */
static void stats_link_section_measures_the_path(void)
{
	char listen_on[32];
	const char *extra[] = {"--listen", listen_on, NULL};
	struct sockaddr_in sa = {.sin_family = AF_INET};
	struct daemon d;
	struct conn t, u;
	struct bc_msg m = {.type = BC_MSG_GET_STATS};
	uint32_t seq;
	int port = daemon_free_port();
	REQUIRE(port > 0);
	snprintf(listen_on, sizeof(listen_on), "127.0.0.1:%d", port);
	REQUIRE(start(&d, "link", extra) == 0);
	memset(&t, 0, sizeof(t));
	t.fd = socket(AF_INET, SOCK_STREAM, 0);
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	sa.sin_port = htons((uint16_t)port);
	REQUIRE(t.fd >= 0 &&
	        connect(t.fd, (struct sockaddr *)&sa, sizeof(sa)) == 0);
	bc_proto_reader_init(
	    &t.r, &(struct bc_proto_reader_opts){.side = BC_PROTO_SIDE_CLIENT});
	REQUIRE(conn_hello(&t, "tcp") == 0);
	REQUIRE(conn_join(&t, "link", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&t, BC_MSG_SCENE_STATE, WAIT_MS) == 1);
	conn_view(&t, 64, 48, BC_PROTO_ENC_RAW);
	REQUIRE(conn_expect(&t, BC_MSG_FRAME, WAIT_MS) == 1);
	m.get_stats.parts = BC_PROTO_STATS_LINK;
	seq = conn_send(&t, &m);
	REQUIRE(answer(&t, seq) == BC_MSG_STATS);
	CHECK(t.m.stats.has_link && !t.m.stats.has_load && !t.m.stats.has_tls);
	CHECK(t.m.stats.link.rtt_us > 0 && t.m.stats.link.rtt_us < 1000000);
	CHECK(t.m.stats.link.min_rtt_us > 0 &&
	      t.m.stats.link.min_rtt_us <= t.m.stats.link.rtt_us + 1000);
	CHECK(t.m.stats.link.delivery_bps > 0);
	/* Every part at once: the sections in their order. */
	m.get_stats.parts = BC_PROTO_STATS_PARTS_ALL;
	seq = conn_send(&t, &m);
	REQUIRE(answer(&t, seq) == BC_MSG_STATS);
	CHECK(t.m.stats.has_load && t.m.stats.has_tls && t.m.stats.has_link);
	CHECK(t.m.stats.link.rtt_us > 0);
	/* A Unix socket has no round trip to tell. */
	REQUIRE(member(&u, &d, "unix", "link", BC_PROTO_ROLE_EDITOR, false) ==
	        0);
	m.get_stats.parts = BC_PROTO_STATS_LINK;
	seq = conn_send(&u, &m);
	REQUIRE(answer(&u, seq) == BC_MSG_STATS);
	CHECK(u.m.stats.has_link && u.m.stats.link.rtt_us == 0 &&
	      u.m.stats.link.delivery_bps == 0 &&
	      u.m.stats.link.frames_paced == 0);
	conn_close(&u);
	conn_close(&t);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* ---- scenes in parts (7.10.1) ------------------------------------------- */

/* HELLO with max_frame_bytes and features (all encodings). */
static int hello_limit(struct conn *c, const char *name, uint32_t max_frame,
                       uint32_t features)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	m.hello.version_min = 1;
	m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.max_frame_bytes = max_frame;
	m.hello.client_name.ptr = name;
	m.hello.client_name.len = (uint32_t)strlen(name);
	m.hello.has_features = true;
	m.hello.features = features;
	if (!conn_send(c, &m) || conn_expect(c, BC_MSG_WELCOME, WAIT_MS) != 1 ||
	    c->m.welcome.features != (features & BC_PROTO_FEATURES_ALL)) {
		return -1;
	}
	return 0;
}

/* A union of n spheres (ids 1..n+1), bytes in b. */
static void many_spheres(struct bc_proto_buf *b, uint32_t n)
{
	bc_proto_buf_init(b, 0);
	bc_proto_scene_begin(b, NULL, n + 1);
	bc_proto_scene_op(b, K_UNION, 1, 0.0f, 0.0f, n);
	for (uint32_t i = 0; i < n; i++) {
		sphere(b, 2 + i, 0.01f * (float)i);
	}
}

/* A SCENE_LOAD part of piece bytes; returns its seq. */
static uint32_t send_part(struct conn *c, uint16_t flags, const uint8_t *piece,
                          size_t n)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD, .flags = flags};
	m.scene_load.scene.ptr = piece;
	m.scene_load.scene.len = (uint32_t)n;
	return conn_send(c, &m);
}

/* The part just sent was taken: a PING after it comes back with no ERROR
 * before it. */
static bool taken(struct conn *c)
{
	uint32_t seq = send_empty(c, BC_MSG_PING);
	int64_t end = t_now_ms() + WAIT_MS;
	while (seq && t_now_ms() < end) {
		if (conn_recv(c, 200) < 0 || c->m.type == BC_MSG_ERROR) {
			return false;
		}
		if (c->m.type == BC_MSG_PONG && c->m.seq == seq) {
			return true;
		}
	}
	return false;
}

/* Receives a SCENE_STATE, whole or in parts, checking 7.10.1 on the way:
 * parts one after another, each within limit bytes of payload, the same
 * fields in each. Its scene in *scene (freed by the caller), its first
 * part in c->m's fields; returns the parts (1: whole), or -1. */
static int recv_state(struct conn *c, uint32_t limit, uint8_t **scene,
                      size_t *len, uint64_t *order, uint32_t *author_seq)
{
	int parts = 0;
	*scene = NULL;
	*len = 0;
	for (;;) {
		uint16_t want;
		uint8_t *grown;
		if (parts == 0) {
			if (conn_expect(c, BC_MSG_SCENE_STATE, WAIT_MS) != 1) {
				return -1;
			}
		} else if (conn_recv(c, WAIT_MS) != 1 ||
		           c->m.type != BC_MSG_SCENE_STATE) {
			return -1; /* nothing else between the parts */
		}
		want = parts == 0 ? 0 : BC_PROTO_FLAG_CONT;
		if ((c->m.flags & BC_PROTO_FLAG_CONT) != want ||
		    BC_PROTO_SCENE_STATE_FIXED + c->m.scene_state.scene.len >
		        limit ||
		    (parts > 0 &&
		     (c->m.scene_state.order != *order ||
		      c->m.scene_state.author_seq != *author_seq))) {
			return -1;
		}
		*order = c->m.scene_state.order;
		*author_seq = c->m.scene_state.author_seq;
		if (!(grown =
		          realloc(*scene, *len + c->m.scene_state.scene.len))) {
			return -1;
		}
		*scene = grown;
		memcpy(*scene + *len, c->m.scene_state.scene.ptr,
		       c->m.scene_state.scene.len);
		*len += c->m.scene_state.scene.len;
		parts++;
		if (!(c->m.flags & BC_PROTO_FLAG_MORE)) {
			return parts;
		}
	}
}

/* 7.10.1 and 4.1 PARTS: a SCENE_LOAD in parts, with other requests
 * between them, is one load answered after its last part; SCENE_STATE
 * comes in parts within a PARTS client's max_frame_bytes, whole to a
 * client without PARTS; the refusals (ESTATE, ELIMIT, EBUSY) are not
 * fatal and drop the scene. */
static void scenes_travel_in_parts(void)
{
	const char *const small[] = {"--max-scene", "4", NULL};
	const uint32_t all = BC_PROTO_FEATURES_READ;
	const uint32_t limit = BC_PROTO_MIN_FRAME_BYTES;
	struct daemon d;
	struct conn a, b, v, j;
	struct bc_proto_buf s;
	struct node nodes[4];
	uint8_t *got = NULL;
	size_t len = 0, third;
	uint64_t order = 0;
	uint32_t seq, pseq, aseq = 0;
	REQUIRE(start(&d, "parts", small) == 0);
	/* a: editor, PARTS, 64 KiB; b: viewer without PARTS, 64 KiB;
	 * v: viewer, PARTS, the server's limit. */
	REQUIRE(conn_open(&a, &d) == 0);
	REQUIRE(hello_limit(&a, "a", limit, all) == 0);
	REQUIRE(conn_join(&a, "pt", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, WAIT_MS) == 1);
	REQUIRE(conn_open(&b, &d) == 0);
	REQUIRE(hello_limit(&b, "b", limit, all & ~BC_PROTO_FEATURE_PARTS) ==
	        0);
	REQUIRE(conn_join(&b, "pt", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&b, BC_MSG_SCENE_STATE, WAIT_MS) == 1);
	REQUIRE(member(&v, &d, "v", "pt", BC_PROTO_ROLE_VIEWER, false) == 0);
	/* 90000 spheres: parts of over 1 MiB, which the daemon keeps in the
	 * buffers they arrived in (BC_SRV_DETACH_BYTES), and a SCENE_STATE
	 * of many 64 KiB parts. */
	many_spheres(&s, 90000);
	REQUIRE(s.len > 3u * (1u << 20) && s.len < (4u << 20) - 4096u);
	third = s.len / 3 + 1; /* pieces end inside nodes */
	/* Parts with a PING between: the PONG comes first, then one answer
	 * to the last part. */
	CHECK(send_part(&a, BC_PROTO_FLAG_MORE, s.data, third));
	pseq = send_empty(&a, BC_MSG_PING);
	CHECK(answer(&a, pseq) == BC_MSG_PONG);
	CHECK(send_part(&a, BC_PROTO_FLAGS_PARTS, s.data + third, third));
	seq = send_part(&a, BC_PROTO_FLAG_CONT, s.data + 2 * third,
	                s.len - 2 * third);
	/* a: in parts, each within 64 KiB. */
	CHECK(recv_state(&a, limit, &got, &len, &order, &aseq) >= 4);
	CHECK_EQ_INT(aseq, seq);
	CHECK_EQ_INT(walk_scene(got, len, nodes, 4), 90001);
	free(got);
	/* b (no PARTS): whole, past its max_frame_bytes, as before. */
	CHECK_EQ_INT(
	    recv_state(&b, BC_PROTO_MAX_PAYLOAD, &got, &len, &order, &aseq), 1);
	CHECK(len > limit);
	CHECK_EQ_INT(walk_scene(got, len, nodes, 4), 90001);
	free(got);
	/* v (PARTS, 64 MiB): whole. */
	CHECK_EQ_INT(
	    recv_state(&v, BC_PROTO_MAX_PAYLOAD, &got, &len, &order, &aseq), 1);
	free(got);
	/* A joiner granted PARTS with 64 KiB gets the kept state in parts. */
	REQUIRE(conn_open(&j, &d) == 0);
	REQUIRE(hello_limit(&j, "j", limit, all) == 0);
	REQUIRE(conn_join(&j, "pt", BC_PROTO_ROLE_VIEWER, false) == 0);
	CHECK(recv_state(&j, limit, &got, &len, &order, &aseq) >= 4);
	CHECK_EQ_INT(walk_scene(got, len, nodes, 4), 90001);
	free(got);
	conn_close(&j);
	/* A CONT with no scene begun: ESTATE, not fatal. */
	seq = send_part(&a, BC_PROTO_FLAG_CONT, s.data, 10);
	CHECK_EQ_INT(refused(&a, seq), -BC_ESTATE);
	/* A first part drops the unfinished scene: the load is the second
	 * one's (the test scene of 7 nodes). */
	CHECK(send_part(&a, BC_PROTO_FLAG_MORE, s.data, third));
	{
		struct bc_proto_buf t;
		test_scene(&t, 0);
		CHECK(send_part(&a, BC_PROTO_FLAG_MORE, t.data, 5));
		seq = send_part(&a, BC_PROTO_FLAG_CONT, t.data + 5, t.len - 5);
		bc_proto_buf_finish(&t);
	}
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, WAIT_MS) == 1);
	CHECK_EQ_INT(a.m.flags, 0);
	CHECK_EQ_INT(a.m.scene_state.author_seq, seq);
	CHECK_EQ_INT(walk_state(&a, nodes, 4), 7);
	/* Past --max-scene (4 MiB): ELIMIT at the part that passes it; the
	 * rest of that scene is ESTATE. */
	{
		size_t big = 2500u * 1024u;
		uint8_t *junk = calloc(1, 4u << 20);
		REQUIRE(junk);
		CHECK(send_part(&a, BC_PROTO_FLAG_MORE, junk, big));
		seq = send_part(&a, BC_PROTO_FLAGS_PARTS, junk, big);
		CHECK_EQ_INT(refused(&a, seq), -BC_ELIMIT);
		seq = send_part(&a, BC_PROTO_FLAG_CONT, junk, 10);
		CHECK_EQ_INT(refused(&a, seq), -BC_ESTATE);
		/* The unfinished scenes of every client: at most 8 MiB. v is
		 * a viewer (EPERM); two more editors hold 3.6 MB each. */
		seq = send_part(&v, BC_PROTO_FLAG_MORE, junk, 10);
		CHECK_EQ_INT(refused(&v, seq), -BC_EPERM);
		{
			struct conn e1, e2;
			REQUIRE(member(&e1, &d, "e1", "pt",
			               BC_PROTO_ROLE_EDITOR, false) == 0);
			REQUIRE(member(&e2, &d, "e2", "pt",
			               BC_PROTO_ROLE_EDITOR, false) == 0);
			CHECK(
			    send_part(&e1, BC_PROTO_FLAG_MORE, junk, 3600000));
			CHECK(taken(&e1));
			CHECK(
			    send_part(&e2, BC_PROTO_FLAG_MORE, junk, 3600000));
			CHECK(taken(&e2));
			seq = send_part(&a, BC_PROTO_FLAG_MORE, junk, 1600000);
			CHECK_EQ_INT(refused(&a, seq), -BC_EBUSY);
			/* After 10 s without a part, the others' unfinished
			 * scenes make room (a wait of at least that long, not
			 * a timing expectation); their next part is ESTATE. */
			t_sleep_ms(10500);
			CHECK(send_part(&a, BC_PROTO_FLAG_MORE, junk, 1600000));
			CHECK(taken(&a));
			seq = send_part(&e2, BC_PROTO_FLAG_CONT, junk, 10);
			CHECK_EQ_INT(refused(&e2, seq), -BC_ESTATE);
			/* 1.6 + 3.6 MB held; 3.6 more passes 8 MiB ... */
			CHECK(
			    send_part(&e1, BC_PROTO_FLAG_MORE, junk, 3600000));
			CHECK(taken(&e1));
			seq = send_part(&e2, BC_PROTO_FLAG_MORE, junk, 3600000);
			CHECK_EQ_INT(refused(&e2, seq), -BC_EBUSY);
			/* ... until leaving the session drops e1's. */
			seq = send_empty(&e1, BC_MSG_SESSION_LEAVE);
			CHECK(answer(&e1, seq) == BC_MSG_OK);
			CHECK(
			    send_part(&e2, BC_PROTO_FLAG_MORE, junk, 3600000));
			CHECK(taken(&e2));
			conn_close(&e1);
			conn_close(&e2);
		}
		free(junk);
	}
	bc_proto_buf_finish(&s);
	CHECK(alive(&a));
	conn_close(&a);
	conn_close(&b);
	conn_close(&v);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"scenes_travel_in_parts", scenes_travel_in_parts},
    {"stats_link_section_measures_the_path",
     stats_link_section_measures_the_path},
    {"decoding_errors_are_fatal_with_seq_0",
     decoding_errors_are_fatal_with_seq_0},
    {"a_stream_ending_between_messages_ends_cleanly",
     a_stream_ending_between_messages_ends_cleanly},
    {"hello_negotiates_the_version", hello_negotiates_the_version},
    {"a_silent_connection_times_out", a_silent_connection_times_out},
    {"tokens_refuse_hello_and_the_editor_role",
     tokens_refuse_hello_and_the_editor_role},
    {"requests_out_of_stage_are_estate_not_fatal",
     requests_out_of_stage_are_estate_not_fatal},
    {"a_viewer_may_not_change_the_scene", a_viewer_may_not_change_the_scene},
    {"sessions_answer_and_announce_members",
     sessions_answer_and_announce_members},
    {"full_sessions_and_a_full_server_are_elimit",
     full_sessions_and_a_full_server_are_elimit},
    {"leaving_and_deleting_drop_what_was_asked",
     leaving_and_deleting_drop_what_was_asked},
    {"a_session_not_loaded_since_start_is_listed_with_flags_0",
     a_session_not_loaded_since_start_is_listed_with_flags_0},
    {"scene_load_reaches_every_member_with_the_next_order",
     scene_load_reaches_every_member_with_the_next_order},
    {"an_edit_applies_whole_or_not_at_all",
     an_edit_applies_whole_or_not_at_all},
    {"edits_meaning_is_checked_not_fatally",
     edits_meaning_is_checked_not_fatally},
    {"undo_does_not_take_a_camera_back", undo_does_not_take_a_camera_back},
    {"camera_view_and_pick_refusals", camera_view_and_pick_refusals},
    {"frames_stay_within_the_views_downscale",
     frames_stay_within_the_views_downscale},
    {"answers_carry_their_requests_seq", answers_carry_their_requests_seq},
    {"presenting_rules", presenting_rules},
};

int main(int argc, char **argv)
{
	(void)unused;
	return daemon_tests_run("must", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
