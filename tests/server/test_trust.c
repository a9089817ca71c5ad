/*
 * What the daemon must not lose or get wrong, over raw protocol
 * connections (each a regression of a loss path or a wrong answer):
 *  - a REMOVE whose chain of unary nodes reaches the root would empty the
 *    scene: it is refused with EINVAL, and the session keeps its scene for
 *    every joiner, also after a restart (PROTOCOL.md 9);
 *  - a SET of a unary node's parameter or kind changes the picture at
 *    once: the render copy follows it, so a snapshot after the edit equals
 *    the snapshot of the scene the session then reports (SCENE_STATE),
 *    loaded fresh into another session;
 *  - a HELLO whose max_frame_bytes is above what the protocol can carry is
 *    welcomed, with the protocol's limit (PROTOCOL.md 7.2);
 *  - one name created and deleted many times a second: every DELETE is
 *    answered OK and every CREATE starts anew (PROTOCOL.md 7.19);
 *  - eight SNAPSHOTs pipelined with edits, twice: each answered (an answer
 *    waiting behind another frame was spoiled by the next one, so about
 *    half of the runs lost some);
 *  - a member whose session is deleted with SNAPSHOTs outstanding gets no
 *    FRAME of it after its ERROR ENOSESSION (PROTOCOL.md 7.19);
 *  - 400 sessions on disk and a limit of 128 descriptors: the daemon
 *    starts, lists them and serves one;
 *  - a structural EDIT past the depth a snapshot holds (1023) is refused
 *    with EDEPTH; up to it, the scene survives a restart;
 *  - one EDIT of an INSERT whose subtree is no multiple of 4 bytes long
 *    and a SET applies (the daemon's copy of the operations once put the
 *    SET's fields at a misaligned address: the sanitizer daemon died);
 *  - TCP connections reset before they are accepted are let go without
 *    harm (refusing one dereferenced a handle not yet set up).
 */
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

#define W 64
#define H 48

/* root (id 1: its type and parameter as JSON members) of an onion (id 2,
 * thickness 0.05) of a sphere (id 3, radius 0.6), seen from the front. */
static void chain_json(char *buf, size_t n, const char *root)
{
	snprintf(buf, n,
	         "{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 4], "
	         "\"target\": [0, 0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": "
	         "40}, \"root\": {%s, \"id\": 1, \"children\": [{\"type\": "
	         "\"onion\", \"id\": 2, \"thickness\": 0.05, \"children\": "
	         "[{\"type\": \"sphere\", \"id\": 3, \"radius\": 0.6}]}]}}",
	         root);
}

#define OFFSET_01 "\"type\": \"offset\", \"amount\": 0.1"

/* Connects as name and joins (creating) session s. */
static void member(struct conn *c, const struct daemon *d, const char *name,
                   const char *s, bool create)
{
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello(c, name) == 0);
	REQUIRE(conn_join(c, s, BC_PROTO_ROLE_EDITOR, create) == 0);
}

/* Sends one operation; *type becomes the answer's: EDIT_APPLIED, or
 * ERROR with its code in *code (0 when neither came in 20 s). */
static void edit1(struct conn *c, struct bc_proto_edit_op op,
                  enum bc_msg_type *type, int *code)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	uint32_t seq;
	*type = 0;
	m.edit.nops = 1;
	m.edit.ops = &op;
	REQUIRE((seq = conn_send(c, &m)));
	while (conn_recv(c, 20000) == 1) {
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			*type = BC_MSG_ERROR;
			*code = c->m.error.code;
			return;
		}
		if (c->m.type == BC_MSG_EDIT_APPLIED &&
		    c->m.edit_applied.author_seq == seq) {
			*type = BC_MSG_EDIT_APPLIED;
			return;
		}
	}
}

/* A joiner of session s gets its SCENE_STATE, of nodes nodes. */
static void joiner_gets_the_scene(const struct daemon *d, const char *s,
                                  uint32_t nodes)
{
	struct conn c;
	struct bc_tree *t;
	member(&c, d, "joiner", s, false);
	REQUIRE(conn_expect(&c, BC_MSG_SCENE_STATE, 20000) == 1);
	REQUIRE((t = scene_of(&c)));
	CHECK_EQ_INT((int)bc_tree_node_count(t), (int)nodes);
	bc_tree_destroy(t);
	conn_close(&c);
}

static void remove_up_a_unary_chain_keeps_the_session(void)
{
	char dir[96], json[512];
	struct daemon d;
	struct conn a;
	int code = 0;
	snprintf(dir, sizeof(dir), "%s/chain", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&a, &d, "editor", "chain", true);
	chain_json(json, sizeof(json), OFFSET_01);
	conn_load_json(&a, json);
	/* The sphere, then each unary node: every one would take the
	 * chain up to the root with it. */
	for (uint32_t id = 3; id >= 1; id--) {
		struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REMOVE,
		                              .node = id};
		enum bc_msg_type type;
		edit1(&a, op, &type, &code);
		CHECK_EQ_INT(type, BC_MSG_ERROR);
		CHECK_EQ_INT(code, -BC_EINVAL);
	}
	joiner_gets_the_scene(&d, "chain", 3);
	conn_close(&a);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	joiner_gets_the_scene(&d, "chain", 3);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* A raw colour snapshot of c's view into px (W x H x 4 bytes); false when
 * it did not come. */
static bool snapshot(struct conn *c, uint8_t *px)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	uint32_t seq;
	m.snapshot.encoding = BC_PROTO_ENC_RAW;
	if (!(seq = conn_send(c, &m))) {
		return false;
	}
	do {
		if (conn_expect(c, BC_MSG_FRAME, 30000) != 1) {
			return false;
		}
	} while (c->m.seq != seq);
	if (c->m.frame.nrects != 1 ||
	    c->m.frame.rects[0].data.len != (uint32_t)(W * H * 4)) {
		return false;
	}
	memcpy(px, c->m.frame.rects[0].data.ptr, (size_t)W * H * 4);
	return true;
}

/* Session s with the chain scene under root in a W x H view. */
static void viewer_of(struct conn *c, const struct daemon *d, const char *s,
                      const char *root)
{
	char json[512];
	member(c, d, s, s, true);
	chain_json(json, sizeof(json), root);
	conn_load_json(c, json);
	REQUIRE(conn_view_scaled(c, W, H, BC_PROTO_ENC_RAW, 1));
}

/* Session s loaded fresh with the scene session of says it has now (a
 * joiner's SCENE_STATE), under the chain scene's camera, in a W x H
 * view. */
static void copy_of(struct conn *c, const struct daemon *d, const char *s,
                    const char *of)
{
	char json[512];
	struct conn j;
	struct bc_tree *t = NULL, *unused = bc_tree_create();
	struct bc_camera cam;
	chain_json(json, sizeof(json), OFFSET_01);
	REQUIRE(unused && bc_scene_parse_json(json, strlen(json), unused, &cam,
	                                      NULL) == 0);
	bc_tree_destroy(unused);
	member(&j, d, "joiner", of, false);
	REQUIRE(conn_expect(&j, BC_MSG_SCENE_STATE, 20000) == 1);
	REQUIRE((t = scene_of(&j)));
	conn_close(&j);
	member(c, d, s, s, true);
	conn_load_tree(c, t, &cam);
	REQUIRE(conn_view_scaled(c, W, H, BC_PROTO_ENC_RAW, 1));
}

static void unary_sets_change_the_picture(void)
{
	char dir[96];
	struct daemon d;
	struct conn live, fresh, kind;
	struct bc_proto_field amount = {BC_PROTO_FIELD_PARAM0, 1, {0.3f}};
	struct bc_proto_field to_elongate = {
	    BC_PROTO_FIELD_OP_KIND, 1, {(float)BC_OP_ELONGATE}};
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET,
	                              .node = 1,
	                              .nfields = 1,
	                              .fields = &amount};
	static uint8_t before[W * H * 4], after[W * H * 4], want[W * H * 4];
	enum bc_msg_type type;
	int code = 0;
	snprintf(dir, sizeof(dir), "%s/unary", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	viewer_of(&live, &d, "live", OFFSET_01);
	REQUIRE(snapshot(&live, before));
	edit1(&live, op, &type, &code);
	CHECK_EQ_INT(type, BC_MSG_EDIT_APPLIED);
	REQUIRE(snapshot(&live, after));
	copy_of(&fresh, &d, "fresh", "live");
	REQUIRE(snapshot(&fresh, want));
	CHECK(memcmp(before, after, sizeof(after)) != 0);
	CHECK(memcmp(after, want, sizeof(after)) == 0);
	/* The kind: offset becomes elongate, with the new kind's default
	 * parameters (PROTOCOL.md 9). */
	op.fields = &to_elongate;
	edit1(&live, op, &type, &code);
	CHECK_EQ_INT(type, BC_MSG_EDIT_APPLIED);
	REQUIRE(snapshot(&live, after));
	copy_of(&kind, &d, "kind", "live");
	REQUIRE(snapshot(&kind, want));
	CHECK(memcmp(before, after, sizeof(after)) != 0);
	CHECK(memcmp(after, want, sizeof(after)) == 0);
	conn_close(&kind);
	conn_close(&live);
	conn_close(&fresh);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

static void a_huge_max_frame_bytes_is_welcomed_with_the_limit(void)
{
	char dir[96];
	struct daemon d;
	struct conn c;
	struct bc_msg m = {.type = BC_MSG_HELLO};
	snprintf(dir, sizeof(dir), "%s/hello", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	m.hello.version_min = 1;
	m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.max_frame_bytes = 0xffffffffu;
	REQUIRE(conn_send(&c, &m));
	CHECK_EQ_INT(conn_expect(&c, BC_MSG_WELCOME, 5000), 1);
	CHECK_EQ_INT((long long)c.m.welcome.max_frame_bytes,
	             (long long)BC_PROTO_MAX_PAYLOAD);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* Creates and deletes session "again" through c: true when the DELETE
 * was answered OK. */
static bool create_and_delete(struct conn *c)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_DELETE};
	uint32_t seq;
	if (conn_join(c, "again", BC_PROTO_ROLE_EDITOR, true) != 0) {
		return false;
	}
	m.session_delete.name.ptr = "again";
	m.session_delete.name.len = 5;
	if (!(seq = conn_send(c, &m))) {
		return false;
	}
	while (conn_recv(c, 20000) == 1) {
		if (c->m.seq == seq) { /* ENOSESSION seq 0 first: we were in */
			return c->m.type == BC_MSG_OK;
		}
	}
	return false;
}

/* One name deleted many times a second: its files go aside under a name
 * of their own each time (NAME.deleted-STAMP, then -1, -2...). Only 100
 * such names a second were tried, so the 101st SESSION_DELETE of a
 * second answered EIO, left the directory, and the next CREATE got
 * EEXIST. The 100 names of this second and the next two are taken first,
 * so the test does not depend on the machine's speed. */
static void a_name_deleted_many_times_a_second(void)
{
	char dir[96], path[256], stamp[32];
	struct daemon d;
	struct conn c;
	int ok = 0;
	snprintf(dir, sizeof(dir), "%s/delete", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	snprintf(path, sizeof(path), "%s/sessions/.deleted", dir);
	REQUIRE(mkdir(path, 0755) == 0 || errno == EEXIST);
	for (time_t t = time(NULL); t < time(NULL) + 3; t++) {
		struct tm tm;
		gmtime_r(&t, &tm);
		strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%SZ", &tm);
		for (int k = 0; k < 100; k++) {
			snprintf(path, sizeof(path),
			         k ? "%s/sessions/.deleted/again.deleted-%s-%d"
			           : "%s/sessions/.deleted/again.deleted-%s",
			         dir, stamp, k);
			REQUIRE(mkdir(path, 0755) == 0);
		}
	}
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_hello(&c, "deleter") == 0);
	for (int i = 0; i < 20; i++) {
		ok += create_and_delete(&c);
	}
	CHECK_EQ_INT(ok, 20);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* SNAPSHOTs pipelined with edits between them, the most a client may
 * have outstanding (BC_SRV_MAX_CLIENT_REQUESTS, 8), each answered by its
 * own FRAME; then eight more: the queue is free again. */
static void pipelined_snapshots_are_all_answered(void)
{
	char dir[96], json[512];
	struct daemon d;
	struct conn c;
	int answered = 0, errors = 0;
	snprintf(dir, sizeof(dir), "%s/snaps", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&c, &d, "snapper", "snaps", true);
	chain_json(json, sizeof(json), OFFSET_01);
	conn_load_json(&c, json);
	REQUIRE(conn_view_scaled(&c, W, H, BC_PROTO_ENC_RAW, 8));
	for (int round = 0; round < 2; round++) {
		uint32_t first = 0, last = 0;
		for (int i = 0; i < 8; i++) {
			struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
			struct bc_proto_field f = {BC_PROTO_FIELD_PARAM0,
			                           1,
			                           {0.1f + 0.01f * (float)i}};
			struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET,
			                              .node = 1,
			                              .nfields = 1,
			                              .fields = &f};
			struct bc_msg e = {.type = BC_MSG_EDIT};
			e.edit.nops = 1;
			e.edit.ops = &op;
			REQUIRE(conn_send(&c, &e));
			m.snapshot.encoding = BC_PROTO_ENC_RAW;
			REQUIRE((last = conn_send(&c, &m)));
			first = first ? first : last;
		}
		for (int got = 0; got < 8;) {
			if (conn_recv(&c, 30000) != 1) {
				fprintf(stderr,
				        "  round %d: %d of 8 answered\n", round,
				        got);
				break;
			}
			if (c.m.type == BC_MSG_FRAME && c.m.seq >= first &&
			    c.m.seq <= last &&
			    (c.m.flags & BC_PROTO_FLAG_SNAPSHOT)) {
				answered++;
				got++;
			} else if (c.m.type == BC_MSG_ERROR && c.m.seq) {
				errors++;
				got++;
				fprintf(stderr, "  seq %u: error %d\n", c.m.seq,
				        (int)c.m.error.code);
			}
		}
	}
	CHECK_EQ_INT(answered, 16);
	CHECK_EQ_INT(errors, 0);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* A member with SNAPSHOTs outstanding whose session is deleted hears
 * ERROR ENOSESSION, and nothing of the session after it (up to five
 * snapshot FRAMEs used to follow: answers queued behind its frame). */
static void nothing_of_a_deleted_session_follows_enosession(void)
{
	char dir[96], json[512];
	struct daemon d;
	struct conn c, del;
	struct bc_msg m = {.type = BC_MSG_SESSION_DELETE};
	int after = 0;
	bool gone = false;
	snprintf(dir, sizeof(dir), "%s/gone", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&c, &d, "snapper", "gone", true);
	chain_json(json, sizeof(json), OFFSET_01);
	conn_load_json(&c, json);
	REQUIRE(conn_view_scaled(&c, 512, 384, BC_PROTO_ENC_RAW, 1));
	for (int i = 0; i < 8; i++) {
		struct bc_msg s = {.type = BC_MSG_SNAPSHOT};
		s.snapshot.encoding = BC_PROTO_ENC_RAW;
		REQUIRE(conn_send(&c, &s));
	}
	/* Some answers are made and queued behind the first frame. */
	t_sleep_ms(300);
	REQUIRE(conn_open(&del, &d) == 0);
	REQUIRE(conn_hello(&del, "deleter") == 0);
	m.session_delete.name.ptr = "gone";
	m.session_delete.name.len = 4;
	REQUIRE(conn_send(&del, &m));
	while (conn_recv(&c, 1500) == 1) {
		if (c.m.type == BC_MSG_ERROR && c.m.seq == 0 &&
		    c.m.error.code == -BC_ENOSESSION) {
			gone = true;
		} else if (gone && (c.m.type == BC_MSG_FRAME ||
		                    c.m.type == BC_MSG_PICK_RESULT)) {
			after++;
		}
	}
	CHECK(gone);
	CHECK_EQ_INT(after, 0);
	conn_close(&c);
	conn_close(&del);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* More sessions on disk than the daemon may open files: it starts, lists
 * them all and serves any (sessions are opened when joined and closed
 * when they unload, PROTOCOL.md 7.21; about 4 100 sessions once passed
 * the unit's LimitNOFILE and the daemon exited at start with "too many
 * open files"). */
static void more_sessions_than_file_descriptors(void)
{
	enum { N = 400 };
	char dir[96], path[256], json[512];
	struct daemon d;
	struct conn c;
	struct rlimit old, low;
	struct bc_msg list = {.type = BC_MSG_SESSION_LIST};
	FILE *f;
	int started;
	snprintf(dir, sizeof(dir), "%s/many", base_dir);
	chain_json(json, sizeof(json), OFFSET_01);
	snprintf(path, sizeof(path), "%s", dir);
	REQUIRE(mkdir(path, 0755) == 0);
	snprintf(path, sizeof(path), "%s/sessions", dir);
	REQUIRE(mkdir(path, 0755) == 0);
	for (int i = 0; i < N; i++) {
		snprintf(path, sizeof(path), "%s/sessions/s%d", dir, i);
		REQUIRE(mkdir(path, 0755) == 0);
		snprintf(path, sizeof(path), "%s/sessions/s%d/snap-0.json", dir,
		         i);
		REQUIRE((f = fopen(path, "w")));
		fputs(json, f);
		fclose(f);
	}
	/* The daemon inherits a limit of 128 descriptors. */
	REQUIRE(getrlimit(RLIMIT_NOFILE, &old) == 0);
	low = old;
	low.rlim_cur = 128;
	REQUIRE(setrlimit(RLIMIT_NOFILE, &low) == 0);
	started = daemon_start(&d, dir);
	setrlimit(RLIMIT_NOFILE, &old);
	REQUIRE(started == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_hello(&c, "lister") == 0);
	REQUIRE(conn_send(&c, &list));
	REQUIRE(conn_expect(&c, BC_MSG_SESSIONS, 20000) == 1);
	/* Every one of them, and the daemon's own default. */
	CHECK(c.m.sessions.nsessions >= N);
	/* The last one (in no particular order on disk) is served. */
	REQUIRE(conn_join(&c, "s399", BC_PROTO_ROLE_EDITOR, false) == 0);
	CHECK_EQ_INT(conn_expect(&c, BC_MSG_SCENE_STATE, 20000), 1);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* Encodes a left chain: depth smooth unions (ids 1000..), each with the
 * next and a sphere (ids 5000..), the last with two spheres. */
static void chain_bytes(struct bc_proto_buf *b, uint32_t depth)
{
	static const float t0[3] = {0, 0, 0}, r0[4] = {0, 0, 0, 1};
	float r = 0.1f;
	bc_proto_buf_init(b, 0);
	bc_proto_scene_begin(b, NULL, 2u * depth + 1u);
	for (uint32_t i = 0; i < depth; i++) {
		bc_proto_scene_op(b, BC_OP_SMOOTH_UNION, 1000u + i, 0.05f, 0.0f,
		                  2);
	}
	for (uint32_t i = 0; i <= depth; i++) {
		bc_proto_scene_prim(b, BC_PRIM_SPHERE, 5000u + i, t0, r0, NULL,
		                    1, &r);
	}
}

/* Sends INSERT of b's subtree under parent; the answer's type and code. */
static void insert(struct conn *c, uint32_t parent,
                   const struct bc_proto_buf *b, enum bc_msg_type *type,
                   int *code)
{
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT,
	                              .node = parent,
	                              .subtree = {b->data, (uint32_t)b->len}};
	edit1(c, op, type, code);
}

/* A structural edit that would nest the scene deeper than its snapshot
 * can hold (1023 levels) is refused with EDEPTH; up to it, it applies
 * and the session's snapshot at SIGTERM restores it. (It was applied, and
 * every later snapshot failed: the journal was never compacted.) */
static void an_edit_past_the_snapshot_depth_is_refused(void)
{
	char dir[96];
	struct daemon d;
	struct conn c;
	struct bc_proto_buf deep, one;
	enum bc_msg_type type;
	int code = 0;
	struct bc_tree *t;
	snprintf(dir, sizeof(dir), "%s/depth", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&c, &d, "deep", "deep", true);
	conn_load_json(&c,
	               "{\"blobcast\": 1, \"root\": {\"type\": \"union\", "
	               "\"id\": 1, \"children\": [{\"type\": \"sphere\", "
	               "\"id\": 2, \"radius\": 0.3}, {\"type\": \"sphere\", "
	               "\"id\": 3, \"radius\": 0.3}]}}");
	/* Under the root (level 1): 1022 more levels, 1023 in all. */
	chain_bytes(&deep, 1021);
	insert(&c, 1, &deep, &type, &code);
	CHECK_EQ_INT(type, BC_MSG_EDIT_APPLIED);
	/* One level more under the deepest union: refused. */
	{
		static const float t0[3] = {0, 0, 0}, r0[4] = {0, 0, 0, 1};
		float r = 0.1f;
		bc_proto_buf_init(&one, 0);
		bc_proto_scene_begin(&one, NULL, 3);
		bc_proto_scene_op(&one, BC_OP_UNION, 9000, 0.0f, 0.0f, 2);
		bc_proto_scene_prim(&one, BC_PRIM_SPHERE, 9001, t0, r0, NULL, 1,
		                    &r);
		bc_proto_scene_prim(&one, BC_PRIM_SPHERE, 9002, t0, r0, NULL, 1,
		                    &r);
	}
	insert(&c, 1000u + 1020u, &one, &type, &code);
	CHECK_EQ_INT(type, BC_MSG_ERROR);
	CHECK_EQ_INT(code, -BC_EDEPTH);
	bc_proto_buf_finish(&deep);
	bc_proto_buf_finish(&one);
	conn_close(&c);
	/* SIGTERM writes its snapshot; the restart reads it back whole. */
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&c, &d, "deep", "deep", false);
	REQUIRE(conn_expect(&c, BC_MSG_SCENE_STATE, 20000) == 1);
	REQUIRE((t = scene_of(&c)));
	CHECK_EQ_INT((int)bc_tree_nesting(t), 1023);
	bc_tree_destroy(t);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

static void a_short_subtree_then_a_set_applies(void)
{
	char dir[96];
	struct daemon d;
	struct conn a;
	struct bc_msg m = {.type = BC_MSG_EDIT};
	struct bc_proto_edit_op ops[2] = {{.kind = BC_PROTO_EDIT_INSERT},
	                                  {.kind = BC_PROTO_EDIT_SET}};
	struct bc_proto_field f = {.field = BC_PROTO_FIELD_TRANSLATE,
	                           .count = 3,
	                           .v = {1.0f, 2.0f, 3.0f}};
	struct bc_proto_buf b;
	uint32_t seq;
	snprintf(dir, sizeof(dir), "%s/align", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&a, &d, "editor", "align", true);
	/* offset(sphere): 54 bytes of subtree. */
	bc_proto_buf_init(&b, 0);
	REQUIRE(bc_proto_scene_begin(&b, NULL, 2) == 0);
	REQUIRE(bc_proto_scene_unary(&b, 7, 0x1000, 1, (const float[]){0.1f}) ==
	        0);
	REQUIRE(bc_proto_scene_prim(&b, 1, 0x1001, (const float[]){0, 0, 0},
	                            (const float[]){0, 0, 0, 1}, NULL, 1,
	                            (const float[]){0.5f}) == 0);
	CHECK(b.len % 4 != 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 20000) == 1);
	{
		struct bc_tree *t = scene_of(&a);
		REQUIRE(t);
		ops[0].node = bc_tree_root(t);
		bc_tree_destroy(t);
	}
	ops[0].position = 0;
	ops[0].subtree.ptr = b.data;
	ops[0].subtree.len = (uint32_t)b.len;
	ops[1].node = 0x1001;
	ops[1].nfields = 1;
	ops[1].fields = &f;
	m.edit.nops = 2;
	m.edit.ops = ops;
	REQUIRE((seq = conn_send(&a, &m)));
	bc_proto_buf_finish(&b);
	do {
		REQUIRE(conn_expect(&a, BC_MSG_EDIT_APPLIED, 20000) == 1);
	} while (a.m.edit_applied.author_seq != seq);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void reset_connections_are_let_go(void)
{
	char dir[96], listen_on[32];
	struct daemon d;
	struct conn c;
	int port = daemon_free_port();
	const char *extra[] = {"--listen", listen_on, NULL};
	struct sockaddr_in sa = {.sin_family = AF_INET};
	REQUIRE(port > 0);
	snprintf(listen_on, sizeof(listen_on), "127.0.0.1:%d", port);
	snprintf(dir, sizeof(dir), "%s/reset", base_dir);
	REQUIRE(daemon_start_with(&d, dir, extra) == 0);
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	sa.sin_port = htons((uint16_t)port);
	/* Connect and reset at once (SO_LINGER 0): the peer is gone before
	 * the daemon accepts, so it is refused (no peer address). */
	for (int i = 0; i < 400; i++) {
		struct linger lg = {1, 0};
		int fd = socket(AF_INET, SOCK_STREAM, 0);
		REQUIRE(fd >= 0);
		setsockopt(fd, SOL_SOCKET, SO_LINGER, &lg, sizeof(lg));
		if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) != 0) {
			close(fd);
			break;
		}
		close(fd);
	}
	/* Still there and serving. */
	REQUIRE(conn_open(&c, &d) == 0);
	CHECK(conn_hello(&c, "after") == 0);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"a_short_subtree_then_a_set_applies", a_short_subtree_then_a_set_applies},
    {"reset_connections_are_let_go", reset_connections_are_let_go},
    {"an_edit_past_the_snapshot_depth_is_refused",
     an_edit_past_the_snapshot_depth_is_refused},
    {"more_sessions_than_file_descriptors",
     more_sessions_than_file_descriptors},
    {"nothing_of_a_deleted_session_follows_enosession",
     nothing_of_a_deleted_session_follows_enosession},
    {"pipelined_snapshots_are_all_answered",
     pipelined_snapshots_are_all_answered},
    {"remove_up_a_unary_chain_keeps_the_session",
     remove_up_a_unary_chain_keeps_the_session},
    {"unary_sets_change_the_picture", unary_sets_change_the_picture},
    {"a_huge_max_frame_bytes_is_welcomed_with_the_limit",
     a_huge_max_frame_bytes_is_welcomed_with_the_limit},
    {"a_name_deleted_many_times_a_second", a_name_deleted_many_times_a_second},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("trust", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
