/*
 * blobcastd does what PROTOCOL.md says, in the places a client written from
 * the spec alone found it did not: each test names the spec's rule. And a
 * mirror check: three editors send thousands of random edits, valid and
 * invalid, each replays every EDIT_APPLIED into its mirror with the edit
 * module, and every mirror must equal a late joiner's SCENE_STATE byte for
 * byte.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];
static const char *const no_simd[] = {"--simd", "off", NULL};

/* daemon.h's helpers this file does not need. */
static void unused(void)
{
	(void)conn_move;
	(void)daemon_start;
}

static int start(struct daemon *d, const char *what)
{
	char dir[80];
	snprintf(dir, sizeof(dir), "%s/%s", base_dir, what);
	return daemon_start_with(d, dir, no_simd);
}

/* An editor joined to "default", its SCENE_STATE in c->m. */
static int editor(struct conn *c, const struct daemon *d, const char *name,
                  uint8_t encodings)
{
	if (conn_open(c, d) || conn_hello_enc(c, name, encodings) ||
	    conn_join(c, "default", BC_PROTO_ROLE_EDITOR, false)) {
		return -1;
	}
	return conn_expect(c, BC_MSG_SCENE_STATE, 5000) == 1 ? 0 : -1;
}

/* The connection is still served (a fatal error would have closed it). */
static bool alive(struct conn *c)
{
	struct bc_msg ping = {.type = BC_MSG_PING};
	ping.ping.stamp = 7;
	return conn_send(c, &ping) && conn_expect(c, BC_MSG_PONG, 5000) == 1;
}

static int expect_error(struct conn *c, uint32_t seq)
{
	if (conn_expect(c, BC_MSG_ERROR, 5000) != 1 || c->m.seq != seq) {
		return -1;
	}
	return (int)c->m.error.code;
}

/* Spec 9: REMOVE of the root is refused (the bytes of the report). */
static void remove_root_is_refused(void)
{
	struct daemon d;
	struct conn a;
	static const uint8_t bytes[] = {0x42, 0x43, 0x53, 0x54, 0x01, 0x0d,
	                                0x00, 0x00, 0x07, 0x00, 0x00, 0x00,
	                                0x03, 0x00, 0x00, 0x00, 0x01, 0x00,
	                                0x03, 0x01, 0x00, 0x00, 0x00};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(start(&d, "root") == 0);
	REQUIRE(editor(&a, &d, "a", BC_PROTO_ENCODINGS_ALL) == 0);
	REQUIRE(bc_scene_decode(a.m.scene_state.scene.ptr,
	                        a.m.scene_state.scene.len, t, NULL, NULL,
	                        NULL) == 0);
	if (bc_tree_root(t) == 1) {
		REQUIRE(send_raw(&a, bytes, sizeof(bytes)) == 0);
		REQUIRE(conn_expect(&a, BC_MSG_ERROR, 5000) == 1);
		CHECK_EQ_INT(a.m.error.code, -BC_EINVAL);
		CHECK(!(a.m.flags & BC_PROTO_FLAG_FATAL));
	}
	{
		struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REMOVE,
		                              .node = bc_tree_root(t)};
		struct bc_msg m = {.type = BC_MSG_EDIT};
		uint32_t seq;
		m.edit.nops = 1;
		m.edit.ops = &op;
		seq = conn_send(&a, &m);
		CHECK_EQ_INT(expect_error(&a, seq), -BC_EINVAL);
	}
	CHECK(alive(&a));
	bc_tree_destroy(t);
	conn_close(&a);
	daemon_stop(&d, SIGTERM);
}

/* Spec 9: an operator kind 4.5 or 7 is refused, not fatally; 7.12: a
 * subtree with id 0 is EINVAL even when id 1 is free. */
static void meaning_is_refused_not_fatally(void)
{
	struct daemon d;
	struct conn a;
	struct bc_tree *t = bc_tree_create();
	const float kinds[] = {4.5f, 7.0f};
	uint32_t op_id = 0;
	REQUIRE(start(&d, "meaning") == 0);
	REQUIRE(editor(&a, &d, "a", BC_PROTO_ENCODINGS_ALL) == 0);
	REQUIRE(bc_scene_decode(a.m.scene_state.scene.ptr,
	                        a.m.scene_state.scene.len, t, NULL, NULL,
	                        NULL) == 0);
	op_id = bc_tree_root(t);
	for (int i = 0; i < 2; i++) {
		struct bc_proto_field f = {
		    BC_PROTO_FIELD_OP_KIND, 1, {kinds[i], 0, 0, 0}};
		struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET,
		                              .node = op_id,
		                              .nfields = 1,
		                              .fields = &f};
		struct bc_msg m = {.type = BC_MSG_EDIT};
		uint32_t seq;
		m.edit.nops = 1;
		m.edit.ops = &op;
		seq = conn_send(&a, &m);
		CHECK_EQ_INT(expect_error(&a, seq), -BC_EENUM);
		CHECK(!(a.m.flags & BC_PROTO_FLAG_FATAL));
		CHECK(alive(&a));
	}
	{
		struct bc_proto_buf sub;
		const float t0[3] = {0, 0, 0}, r0[4] = {0, 0, 0, 1}, rad = 0.2f;
		struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT,
		                              .node = op_id};
		struct bc_msg m = {.type = BC_MSG_EDIT};
		uint32_t seq;
		bc_proto_buf_init(&sub, 0);
		bc_proto_scene_begin(&sub, NULL, 1);
		bc_proto_scene_prim(&sub, BC_PRIM_SPHERE, 0, t0, r0, NULL, 1,
		                    &rad);
		op.subtree.ptr = sub.data;
		op.subtree.len = (uint32_t)sub.len;
		m.edit.nops = 1;
		m.edit.ops = &op;
		seq = conn_send(&a, &m);
		CHECK_EQ_INT(expect_error(&a, seq), -BC_EINVAL);
		bc_proto_buf_finish(&sub);
	}
	bc_tree_destroy(t);
	conn_close(&a);
	daemon_stop(&d, SIGTERM);
}

/* Spec 7.14/7.15: the VIEW's encoding governs every frame (coarse levels
 * during a camera drag included); frame_no counts this client's frames;
 * HELLO encodings 0 gets no frames and its VIEW is refused. */
static void frames_follow_the_view_and_count_per_client(void)
{
	struct daemon d;
	struct conn a, b, none;
	uint32_t seq, last_no = 0;
	int frames = 0;
	REQUIRE(start(&d, "frames") == 0);
	REQUIRE(editor(&a, &d, "a", BC_PROTO_ENCODINGS_ALL) == 0);
	REQUIRE(conn_view(&a, 64, 48, BC_PROTO_ENC_PNG));
	for (int i = 0; i < 4; i++) {
		struct bc_msg cam = {.type = BC_MSG_CAMERA,
		                     .flags = BC_PROTO_FLAG_INTERACTING};
		float eye[3] = {3.0f + 0.1f * (float)i, 2, 3};
		memcpy(cam.camera.eye, eye, sizeof(eye));
		cam.camera.up[1] = 1;
		cam.camera.fov_y_deg = 40;
		REQUIRE(conn_send(&a, &cam));
	}
	do {
		REQUIRE(conn_expect(&a, BC_MSG_FRAME, 20000) == 1);
		CHECK_EQ_INT(a.m.frame.encoding, BC_PROTO_ENC_PNG);
		CHECK(a.m.frame.frame_no == last_no + 1);
		last_no = a.m.frame.frame_no;
		frames++;
	} while (!(a.m.flags & BC_PROTO_FLAG_STILL));
	/* A second client's frames count from 1. */
	REQUIRE(editor(&b, &d, "b", BC_PROTO_ENCODINGS_ALL) == 0);
	REQUIRE(conn_view(&b, 64, 48, BC_PROTO_ENC_PNG));
	REQUIRE(conn_expect(&b, BC_MSG_FRAME, 20000) == 1);
	CHECK_EQ_INT((int)b.m.frame.frame_no, 1);
	/* Encodings 0: no frames. */
	REQUIRE(editor(&none, &d, "none", 0) == 0);
	seq = conn_view(&none, 64, 48, BC_PROTO_ENC_PNG);
	CHECK_EQ_INT(expect_error(&none, seq), -BC_EINVAL);
	CHECK(conn_expect(&none, BC_MSG_FRAME, 1500) == 0);
	printf("  %d frames, PNG at every level\n", frames);
	conn_close(&a);
	conn_close(&b);
	conn_close(&none);
	daemon_stop(&d, SIGTERM);
}

/* Spec 3.1: a stream that ends inside a header or a payload is answered
 * with a fatal EPROTO_TRUNCATED. */
static void a_stream_cut_inside_a_message_is_truncated(void)
{
	struct daemon d;
	REQUIRE(start(&d, "trunc") == 0);
	for (int cut = 0; cut < 2; cut++) {
		struct conn c;
		static const uint8_t part[] = {
		    0x42, 0x43, 0x53, 0x54, 0x01, 0x04, 0x00, 0x00, 0x01,
		    0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x01, 0x02};
		REQUIRE(conn_open(&c, &d) == 0);
		/* PING: cut in the header (8 bytes) or in the payload. */
		REQUIRE(send_raw(&c, part, cut ? sizeof(part) : 8) == 0);
		shutdown(c.fd, SHUT_WR);
		REQUIRE(conn_expect(&c, BC_MSG_ERROR, 5000) == 1);
		CHECK_EQ_INT(c.m.error.code, -BC_EPROTO_TRUNCATED);
		CHECK(c.m.flags & BC_PROTO_FLAG_FATAL);
		conn_close(&c);
	}
	daemon_stop(&d, SIGTERM);
}

/* Spec 7.15: a frame over the client's max_frame_bytes is not sent, and the
 * client hears a non-fatal ERROR ELIMIT (seq 0; a SNAPSHOT's: its seq). */
static void a_frame_over_the_limit_is_elimit(void)
{
	struct daemon d;
	struct conn a;
	struct bc_msg m = {.type = BC_MSG_HELLO};
	uint32_t seq;
	REQUIRE(start(&d, "limit") == 0);
	REQUIRE(conn_open(&a, &d) == 0);
	m.hello.version_min = 1;
	m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.max_frame_bytes = BC_PROTO_MIN_FRAME_BYTES;
	m.hello.client_name.ptr = "small";
	m.hello.client_name.len = 5;
	REQUIRE(conn_send(&a, &m));
	REQUIRE(conn_expect(&a, BC_MSG_WELCOME, 5000) == 1);
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	/* Raw 256 x 256 at level 0 only: 262144 bytes of pixels. */
	m = (struct bc_msg){.type = BC_MSG_VIEW};
	m.view.width = 256;
	m.view.height = 256;
	m.view.encoding = BC_PROTO_ENC_RAW;
	m.view.quality_interactive = 60;
	m.view.quality_still = 90;
	m.view.downscale = 1;
	REQUIRE(conn_send(&a, &m));
	CHECK_EQ_INT(expect_error(&a, 0), -BC_ELIMIT);
	CHECK(!(a.m.flags & BC_PROTO_FLAG_FATAL));
	CHECK(alive(&a));
	m = (struct bc_msg){.type = BC_MSG_SNAPSHOT};
	m.snapshot.encoding = BC_PROTO_ENC_RAW;
	seq = conn_send(&a, &m);
	CHECK_EQ_INT(expect_error(&a, seq), -BC_ELIMIT);
	CHECK(!(a.m.flags & BC_PROTO_FLAG_FATAL));
	CHECK(alive(&a));
	conn_close(&a);
	daemon_stop(&d, SIGTERM);
}

/* ---- the mirror check ----------------------------------------------------
 */

#define EDITORS 3
#define EDITS 10000
#define WINDOW 8 /* edits an editor has in flight */

struct member {
	struct conn c;
	struct bc_tree *mirror;
	uint64_t order;
	uint32_t id; /* member id */
	uint32_t inflight;
	uint32_t refused;
};

static uint32_t rnd(uint64_t *s)
{
	*s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
	return (uint32_t)(*s >> 33);
}

/* Any live id of the mirror (or a missing one now and then). */
static uint32_t pick_id(const struct bc_tree *t, uint64_t *s)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t n = bc_tree_node_count(t);
	if (rnd(s) % 20 == 0 || n == 0) {
		return 900000 + rnd(s) % 10;
	}
	return l->node_id[rnd(s) % n];
}

/* A leaf (a primitive) of the mirror, or any node when none is found. */
static uint32_t pick_leaf(const struct bc_tree *t, uint64_t *s)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t n = bc_tree_node_count(t);
	for (int tries = 0; tries < 16; tries++) {
		uint32_t id = l->node_id[rnd(s) % n];
		if (bc_tree_child_count(t, id) == 0) {
			return id;
		}
	}
	return pick_id(t, s);
}

/* A subtree to insert: a sphere, or a union of two or three spheres (one id
 * 0 in it now and then: EINVAL). */
static void random_subtree(struct bc_proto_buf *sub, uint32_t *next_id,
                           uint64_t *s, float rad)
{
	const float t0[3] = {0, 0, 0}, r0[4] = {0, 0, 0, 1};
	uint32_t kids = rnd(s) % 2 ? 0 : 2 + rnd(s) % 2;
	uint32_t zero = rnd(s) % 25 == 0 ? rnd(s) % (kids + 1) : 99;
	bc_proto_scene_begin(sub, NULL, 1 + kids);
	if (kids) {
		bc_proto_scene_op(sub, BC_OP_UNION,
		                  zero == 0 ? 0 : (*next_id)++, 0, 0, kids);
	}
	for (uint32_t i = 0; i < (kids ? kids : 1); i++) {
		float t[3] = {t0[0] + 0.3f * (float)i, t0[1], t0[2]};
		uint32_t id = zero == i + (kids ? 1u : 0u) ? 0 : (*next_id)++;
		bc_proto_scene_prim(sub, BC_PRIM_SPHERE, id, t, r0, NULL, 1,
		                    &rad);
	}
}

static uint32_t pick_op(const struct bc_tree *t, uint64_t *s)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t n = bc_tree_node_count(t);
	for (int tries = 0; tries < 16; tries++) {
		uint32_t id = l->node_id[rnd(s) % n];
		if (bc_tree_child_count(t, id) > 0) {
			return id;
		}
	}
	return bc_tree_root(t);
}

/* One random edit (valid or not) from m, built against its mirror. */
static void random_edit(struct member *m, uint32_t *next_id, uint64_t *s)
{
	struct bc_proto_field f[3];
	struct bc_proto_edit_op op = {0};
	struct bc_proto_buf sub;
	struct bc_msg msg = {.type = BC_MSG_EDIT};
	float rad = 0.05f + (float)(rnd(s) % 100) / 400.0f;
	uint32_t k = rnd(s) % 100;
	bc_proto_buf_init(&sub, 0);
	memset(f, 0, sizeof(f));
	if (k < 45) {
		op.kind = BC_PROTO_EDIT_SET;
		op.node = pick_id(m->mirror, s);
		op.fields = f;
		op.nfields = 1;
		switch (rnd(s) % 7) {
		case 0: /* translate: good on primitives */
		case 1:
			f[0] = (struct bc_proto_field){
			    BC_PROTO_FIELD_TRANSLATE,
			    3,
			    {(float)(rnd(s) % 200) / 100.0f - 1.0f, 0.1f, 0,
			     0}};
			break;
		case 2: /* parameter 0 (radius of a sphere, ...) */
			f[0] = (struct bc_proto_field){
			    BC_PROTO_FIELD_PARAM0, 1, {rad, 0, 0, 0}};
			break;
		case 3: /* blend: smooth operators only */
			f[0] = (struct bc_proto_field){
			    BC_PROTO_FIELD_BLEND, 1, {rad, 0, 0, 0}};
			break;
		case 4: /* to a sharp kind, with or without blend 0 range 0 */
			f[0] = (struct bc_proto_field){
			    BC_PROTO_FIELD_OP_KIND,
			    1,
			    {(float)(1 + rnd(s) % 3), 0, 0, 0}};
			if (rnd(s) % 2) {
				f[1] = (struct bc_proto_field){
				    BC_PROTO_FIELD_BLEND, 1, {0}};
				f[2] = (struct bc_proto_field){
				    BC_PROTO_FIELD_RANGE, 1, {0}};
				op.nfields = 3;
			}
			break;
		case 5: /* to a smooth kind with a blend */
			f[0] = (struct bc_proto_field){
			    BC_PROTO_FIELD_OP_KIND,
			    1,
			    {(float)(4 + rnd(s) % 3), 0, 0, 0}};
			f[1] = (struct bc_proto_field){
			    BC_PROTO_FIELD_BLEND, 1, {rad, 0, 0, 0}};
			op.nfields = 2;
			break;
		default: /* no kind at all */
			f[0] = (struct bc_proto_field){
			    BC_PROTO_FIELD_OP_KIND,
			    1,
			    {rnd(s) % 2 ? 4.5f : 7.0f, 0, 0, 0}};
			break;
		}
	} else if (k < 85) {
		/* INSERT (or, 1 in 10, REPLACE) a subtree (id 0 now and then;
		 * ids of other editors may collide: EDUPID). A REPLACE hits a
		 * leaf, and the root 1 time in 40, so that the tree grows to
		 * a hundred nodes or so and is cut back now and then. */
		op.kind =
		    rnd(s) % 10 ? BC_PROTO_EDIT_INSERT : BC_PROTO_EDIT_REPLACE;
		if (op.kind == BC_PROTO_EDIT_INSERT) {
			op.node = pick_op(m->mirror, s);
		} else {
			op.node = rnd(s) % 40 == 0 ? bc_tree_root(m->mirror)
			                           : pick_leaf(m->mirror, s);
		}
		op.position = rnd(s) % 3;
		random_subtree(&sub, next_id, s, rad);
		op.subtree.ptr = sub.data;
		op.subtree.len = (uint32_t)sub.len;
	} else {
		/* REMOVE: a leaf mostly, any node 1 time in 4, the root
		 * (refused) 1 time in 15. */
		uint32_t r = rnd(s) % 120;
		op.kind = BC_PROTO_EDIT_REMOVE;
		op.node = r < 8    ? bc_tree_root(m->mirror)
		          : r < 38 ? pick_id(m->mirror, s)
		                   : pick_leaf(m->mirror, s);
	}
	msg.edit.nops = 1;
	msg.edit.ops = &op;
	if (conn_send(&m->c, &msg)) {
		m->inflight++;
	}
	bc_proto_buf_finish(&sub);
}

/* Takes what m has received: replays EDIT_APPLIED, counts answers. */
static int drain(struct member *m, int timeout_ms)
{
	int rc;
	while ((rc = conn_recv(&m->c, timeout_ms)) == 1) {
		struct bc_errinfo ei = {0};
		timeout_ms = 0;
		if (m->c.m.type == BC_MSG_EDIT_APPLIED) {
			const struct bc_msg_edit_applied *ea =
			    &m->c.m.edit_applied;
			if (ea->order != m->order + 1 ||
			    bc_edit_replay(&m->mirror, ea, &ei)) {
				fprintf(stderr, "  mirror: order %llu: %s\n",
				        (unsigned long long)ea->order, ei.msg);
				return -1;
			}
			m->order = ea->order;
			if (ea->author == m->id) {
				m->inflight--;
			}
		} else if (m->c.m.type == BC_MSG_ERROR) {
			if (m->c.m.flags & BC_PROTO_FLAG_FATAL) {
				return -1;
			}
			m->refused++;
			m->inflight--;
		}
	}
	return rc < 0 ? -1 : 0;
}

static void mirrors_equal_a_joiners_state(void)
{
	struct daemon d;
	struct member m[EDITORS];
	struct conn late;
	struct bc_tree *joined = bc_tree_create();
	struct bc_camera cam;
	uint64_t seed = 12345;
	uint32_t next_id = 1000, sent = 0;
	uint32_t applied = 0, refused = 0, nmin = UINT32_MAX, nmax = 0;
	uint64_t nsum = 0;
	int64_t t0 = t_now_ms();
	REQUIRE(start(&d, "mirror") == 0);
	for (int i = 0; i < EDITORS; i++) {
		char name[16];
		snprintf(name, sizeof(name), "e%d", i);
		memset(&m[i], 0, sizeof(m[i]));
		REQUIRE(conn_open(&m[i].c, &d) == 0);
		REQUIRE(conn_hello(&m[i].c, name) == 0);
		REQUIRE(conn_join(&m[i].c, "default", BC_PROTO_ROLE_EDITOR,
		                  false) == 0);
		m[i].id = m[i].c.m.session_info.member_id;
		REQUIRE(conn_expect(&m[i].c, BC_MSG_SCENE_STATE, 5000) == 1);
		REQUIRE((m[i].mirror = bc_tree_create()) != NULL);
		REQUIRE(bc_scene_decode(m[i].c.m.scene_state.scene.ptr,
		                        m[i].c.m.scene_state.scene.len,
		                        m[i].mirror, NULL, NULL, NULL) == 0);
		m[i].order = m[i].c.m.scene_state.order;
	}
	for (int i = 0; i < EDITORS; i++) {
		REQUIRE(drain(&m[i], 0) == 0);
	}
	while (sent < EDITS) {
		for (int i = 0; i < EDITORS && sent < EDITS; i++) {
			if (m[i].inflight < WINDOW) {
				uint32_t n = bc_tree_node_count(m[i].mirror);
				nmin = n < nmin ? n : nmin;
				nmax = n > nmax ? n : nmax;
				nsum += n;
				random_edit(&m[i], &next_id, &seed);
				sent++;
			}
		}
		for (int i = 0; i < EDITORS; i++) {
			REQUIRE(drain(&m[i], 0) == 0);
		}
		for (int i = 0; i < EDITORS; i++) {
			if (m[i].inflight >= WINDOW) {
				REQUIRE(drain(&m[i], 5) == 0);
			}
		}
		if (sent % (EDITORS * WINDOW) == 0) {
			/* Let the daemon catch up every few rounds. */
			for (int i = 0; i < EDITORS; i++) {
				REQUIRE(drain(&m[i], 50) == 0);
			}
		}
	}
	/* Everything answered: a PING round trip orders after every edit. */
	for (int i = 0; i < EDITORS; i++) {
		struct bc_msg ping = {.type = BC_MSG_PING};
		uint32_t seq = conn_send(&m[i].c, &ping);
		for (;;) {
			REQUIRE(conn_recv(&m[i].c, 20000) == 1);
			if (m[i].c.m.type == BC_MSG_PONG &&
			    m[i].c.m.seq == seq) {
				break;
			}
			if (m[i].c.m.type == BC_MSG_EDIT_APPLIED) {
				struct bc_errinfo ei = {0};
				REQUIRE(m[i].c.m.edit_applied.order ==
				        m[i].order + 1);
				REQUIRE(bc_edit_replay(&m[i].mirror,
				                       &m[i].c.m.edit_applied,
				                       &ei) == 0);
				m[i].order = m[i].c.m.edit_applied.order;
			} else if (m[i].c.m.type == BC_MSG_ERROR) {
				m[i].refused++;
			}
		}
	}
	/* The last editor's PONG came after every edit was ordered; the
	 * others may still have EDIT_APPLIED of later edits queued. */
	for (int i = 0; i < EDITORS; i++) {
		REQUIRE(drain(&m[i], 300) == 0);
	}
	REQUIRE(conn_open(&late, &d) == 0 && conn_hello(&late, "late") == 0);
	REQUIRE(conn_join(&late, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&late, BC_MSG_SCENE_STATE, 5000) == 1);
	REQUIRE(bc_scene_decode(late.m.scene_state.scene.ptr,
	                        late.m.scene_state.scene.len, joined, &cam,
	                        NULL, NULL) == 0);
	for (int i = 0; i < EDITORS; i++) {
		uint8_t *bytes = NULL;
		size_t len = 0;
		CHECK(m[i].order == late.m.scene_state.order);
		REQUIRE(bc_scene_encode(m[i].mirror, &cam, &bytes, &len) == 0);
		CHECK(len == late.m.scene_state.scene.len &&
		      memcmp(bytes, late.m.scene_state.scene.ptr, len) == 0);
		bc_free(bytes);
		refused += m[i].refused;
		bc_tree_destroy(m[i].mirror);
		conn_close(&m[i].c);
	}
	applied = (uint32_t)late.m.scene_state.order;
	printf("  %u edits from %d editors: %u applied (order), %u refused, "
	       "%u nodes at the end (%u..%u, %.0f on average when an edit "
	       "was made), %lld ms\n",
	       sent, EDITORS, applied, refused, bc_tree_node_count(joined),
	       nmin, nmax, (double)nsum / (double)sent,
	       (long long)(t_now_ms() - t0));
	CHECK(applied > 1000 && refused > 1000);
	/* Most edits work on a real tree, not a lone node. */
	CHECK((double)nsum / (double)sent >= 20.0);
	bc_tree_destroy(joined);
	conn_close(&late);
	daemon_stop(&d, SIGTERM);
}

static const struct bc_test tests[] = {
    {"remove_root_is_refused", remove_root_is_refused},
    {"meaning_is_refused_not_fatally", meaning_is_refused_not_fatally},
    {"frames_follow_the_view_and_count_per_client",
     frames_follow_the_view_and_count_per_client},
    {"a_stream_cut_inside_a_message_is_truncated",
     a_stream_cut_inside_a_message_is_truncated},
    {"a_frame_over_the_limit_is_elimit", a_frame_over_the_limit_is_elimit},
    {"mirrors_equal_a_joiners_state", mirrors_equal_a_joiners_state},
};

int main(int argc, char **argv)
{
	(void)unused;
	return daemon_tests_run("spec", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
