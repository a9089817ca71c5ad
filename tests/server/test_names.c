/*
 * Node names in blobcastd (PROTOCOL.md 4.1 NAMES, 8, 9, 7.12): a NAME
 * reaches members granted NAMES as itself and, for a member without it,
 * the change made only of NAMEs comes as the whole SCENE_STATE at its
 * order (without the names table) while a mixed change comes without its
 * NAME operations and with its subtrees' names left out; such changes are
 * taken once a second while such members are in the session (EBUSY), and
 * draw nothing (no frame follows them);
 * joiners get the table as their features allow; a rename undoes and
 * redoes as one step, shows in HISTORY, and survives SIGTERM and kill -9;
 * a NAME of no node and a names table naming no node are refused; HISTORY
 * escapes control characters of names.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];
static uint32_t member_of_fd[1024];

static const char *const scene_json =
    "{\"blobcast\": 1, \"root\": {\"type\": \"union\", \"id\": 1, "
    "\"name\": \"base\", \"children\": [\n"
    "  {\"type\": \"sphere\", \"id\": 2, \"radius\": 0.5},\n"
    "  {\"type\": \"sphere\", \"id\": 3, \"radius\": 0.5, "
    "\"translate\": [1, 0, 0]}]}}\n";

/* A HELLO announcing features as name, then CREATE or JOIN of session as
 * an editor; the SCENE_STATE read. */
static void enter(struct conn *c, const struct daemon *d, const char *name,
                  uint32_t features, const char *session, bool create)
{
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello_as(c, name, BC_PROTO_ENCODINGS_ALL, true,
	                      features) == 0);
	REQUIRE(conn_join(c, session, BC_PROTO_ROLE_EDITOR, create) == 0);
	REQUIRE(c->fd >= 0 && c->fd < 1024);
	member_of_fd[c->fd] = c->m.session_info.member_id;
	REQUIRE(conn_expect(c, BC_MSG_SCENE_STATE, 5000) == 1);
}

/* The answer to seq: its EDIT_APPLIED's order (c->m holds it), or 0 after
 * an ERROR for seq (c->m holds that). */
static uint64_t answer(struct conn *c, uint32_t seq)
{
	uint64_t o = conn_edit_answer(c, member_of_fd[c->fd], seq);
	CHECK(o > 0 || c->m.type == BC_MSG_ERROR);
	return o;
}

static uint32_t send_ops(struct conn *c, const struct bc_proto_edit_op *ops,
                         uint16_t n)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	m.edit.nops = n;
	m.edit.ops = ops;
	return conn_send(c, &m);
}

static struct bc_proto_edit_op name_op(uint32_t node, const char *name)
{
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_NAME, .node = node};
	op.name.ptr = name;
	op.name.len = (uint32_t)strlen(name);
	return op;
}

/* Renames node from c; returns the edit's order (0: refused). */
static uint64_t rename_node(struct conn *c, uint32_t node, const char *name)
{
	struct bc_proto_edit_op op = name_op(node, name);
	return answer(c, send_ops(c, &op, 1));
}

/* The type of the next message of c that is neither a frame nor
 * SESSION_INFO (in c->m); BC_MSG_INVALID when none comes. */
static enum bc_msg_type next_change(struct conn *c)
{
	for (;;) {
		if (conn_recv(c, 10000) != 1) {
			return BC_MSG_INVALID;
		}
		if (c->m.type != BC_MSG_FRAME &&
		    c->m.type != BC_MSG_SESSION_INFO) {
			return c->m.type;
		}
	}
}

/* 1 when a FRAME reaches c within ms, else 0. */
static int next_frame_within(struct conn *c, int ms)
{
	int64_t end = t_now_ms() + ms;
	while (t_now_ms() < end) {
		if (conn_recv(c, 100) == 1 && c->m.type == BC_MSG_FRAME) {
			return 1;
		}
	}
	return 0;
}

/* Whether node's name in c's SCENE_STATE (in c->m) is name (NULL: none);
 * the state's features must say NAMES exactly when it has names. */
static bool state_names(const struct conn *c, uint32_t node, const char *name)
{
	struct bc_proto_scene_info info;
	struct bc_tree *t = scene_of(c);
	const char *got;
	bool ok;
	if (!t ||
	    bc_proto_scene_scan(c->m.scene_state.scene.ptr,
	                        c->m.scene_state.scene.len, &info, NULL) != 0) {
		bc_tree_destroy(t);
		return false;
	}
	got = bc_tree_name(t, node);
	ok = (name ? got && strcmp(got, name) == 0 : got == NULL) &&
	     ((info.features & BC_PROTO_FEATURE_NAMES) != 0) ==
	         (bc_tree_name_count(t) > 0);
	bc_tree_destroy(t);
	return ok;
}

static const char *const moon =
    "{\"blobcast\": 1, \"root\": {\"type\": \"sphere\", \"id\": 9, "
    "\"name\": \"moon\", \"radius\": 0.2}}";

static void names_reach_members_as_their_features_allow(void)
{
	const uint32_t without =
	    BC_PROTO_FEATURES_READ & ~BC_PROTO_FEATURE_NAMES;
	struct daemon d;
	struct conn a, old, late;
	struct bc_proto_edit_op ops[2];
	struct bc_proto_field f = {.field = 1, .count = 3, .v = {0, 2, 0}};
	struct bc_tree *sub;
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint64_t o;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/features", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&a, &d, "ann", BC_PROTO_FEATURES_READ, "n", true);
	conn_load_json(&a, scene_json);
	CHECK(state_names(&a, 1, "base"));
	/* A joiner without NAMES: the same tree, no names table. */
	enter(&old, &d, "olga", without, "n", false);
	CHECK(state_names(&old, 1, NULL));
	sub = scene_of(&old);
	CHECK(sub && bc_tree_node_count(sub) == 3);
	bc_tree_destroy(sub);

	/* A change made only of NAMEs: the older member gets the scene. */
	REQUIRE((o = rename_node(&a, 2, "left")) > 0);
	CHECK(next_change(&old) == BC_MSG_SCENE_STATE);
	CHECK(old.m.scene_state.order == o);
	CHECK(state_names(&old, 2, NULL));
	/* ... once a second while such members are in the session. */
	CHECK(rename_node(&a, 3, "right") == 0);
	CHECK_EQ_INT(a.m.error.code, -BC_EBUSY);
	CHECK(!(a.m.flags & BC_PROTO_FLAG_FATAL));

	/* A mixed change: the older member gets it without the NAME. */
	ops[0] = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_SET, .node = 3, .nfields = 1, .fields = &f};
	ops[1] = name_op(3, "right");
	REQUIRE((o = answer(&a, send_ops(&a, ops, 2))) > 0);
	CHECK(a.m.edit_applied.nops == 2);
	CHECK(next_change(&old) == BC_MSG_EDIT_APPLIED);
	CHECK(old.m.edit_applied.order == o);
	CHECK(old.m.edit_applied.nops == 1 &&
	      old.m.edit_applied.ops[0].kind == BC_PROTO_EDIT_SET);

	/* An INSERT whose subtree has names: the older member's has none. */
	sub = bc_tree_create();
	REQUIRE(sub &&
	        bc_scene_parse_json(moon, strlen(moon), sub, NULL, NULL) == 0);
	REQUIRE(bc_scene_encode(sub, NULL, &bytes, &len) == 0);
	bc_tree_destroy(sub);
	ops[0] = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT, .node = 1, .position = 2};
	ops[0].subtree.ptr = bytes;
	ops[0].subtree.len = (uint32_t)len;
	REQUIRE((o = answer(&a, send_ops(&a, ops, 1))) > 0);
	CHECK(a.m.edit_applied.ops[0].subtree.ptr[0] & BC_SCENE_FLAG_NAMES);
	CHECK(next_change(&old) == BC_MSG_EDIT_APPLIED);
	CHECK(old.m.edit_applied.order == o);
	CHECK(old.m.edit_applied.ops[0].subtree.len < len &&
	      old.m.edit_applied.ops[0].subtree.ptr[0] == 0);
	CHECK(bc_proto_scene_scan(old.m.edit_applied.ops[0].subtree.ptr,
	                          old.m.edit_applied.ops[0].subtree.len, NULL,
	                          NULL) == 0);
	bc_free(bytes);

	/* Joiners: the table as their features allow. */
	enter(&late, &d, "lee", BC_PROTO_FEATURES_READ, "n", false);
	CHECK(state_names(&late, 9, "moon"));
	CHECK(state_names(&late, 3, "right"));
	conn_close(&late);
	enter(&late, &d, "lou", without, "n", false);
	CHECK(state_names(&late, 9, NULL));
	conn_close(&late);

	/* Without older members, NAME changes are not held back; and they
	 * draw nothing: no frame follows them. */
	conn_close(&old);
	t_sleep_ms(200);
	conn_view(&a, 32, 24, BC_PROTO_ENC_RAW);
	REQUIRE(conn_expect(&a, BC_MSG_FRAME, 10000) == 1);
	while (conn_recv(&a, 1000) == 1) {
		/* the view's refinements, if any */
	}
	CHECK(rename_node(&a, 2, "l") > 0);
	CHECK(rename_node(&a, 2, "ll") > 0);
	CHECK(next_frame_within(&a, 1000) == 0);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static uint32_t send_undo(struct conn *c, bool redo)
{
	struct bc_msg m = {.type = redo ? BC_MSG_REDO : BC_MSG_UNDO};
	m.undo.scope = BC_PROTO_UNDO_MINE;
	return conn_send(c, &m);
}

/* c's session's scene, asked for by joining again as name. */
static void rejoin(struct conn *c, const struct daemon *d, const char *name)
{
	enter(c, d, name, BC_PROTO_FEATURES_READ, "r", false);
}

/* Whether c's HISTORY has an entry whose text is what. */
static bool history_has(struct conn *c, const char *what)
{
	struct bc_msg m = {.type = BC_MSG_HISTORY_GET};
	uint32_t seq = conn_send(c, &m);
	do {
		if (conn_recv(c, 10000) != 1) {
			return false;
		}
	} while (c->m.seq != seq || c->m.type != BC_MSG_HISTORY);
	for (uint32_t i = 0; i < c->m.history.nentries; i++) {
		const struct bc_proto_str *w = &c->m.history.entries[i].what;
		if (w->len == strlen(what) &&
		    memcmp(w->ptr, what, w->len) == 0) {
			return true;
		}
	}
	return false;
}

static void a_rename_undoes_and_survives_restarts(void)
{
	struct daemon d;
	struct conn c;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/restart", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&c, &d, "rae", BC_PROTO_FEATURES_READ, "r", true);
	conn_load_json(&c, scene_json);
	REQUIRE(rename_node(&c, 2, "left") > 0);
	CHECK(history_has(&c, "NAME node 2 \"left\""));
	/* UNDO gives the earlier name back: none. */
	REQUIRE(answer(&c, send_undo(&c, false)) > 0);
	CHECK(c.m.flags & BC_PROTO_FLAG_UNDO);
	CHECK(c.m.edit_applied.nops == 1 &&
	      c.m.edit_applied.ops[0].kind == BC_PROTO_EDIT_NAME &&
	      c.m.edit_applied.ops[0].name.len == 0);
	REQUIRE(answer(&c, send_undo(&c, true)) > 0);
	CHECK(c.m.edit_applied.ops[0].name.len == 4);
	conn_close(&c);

	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	REQUIRE(daemon_start(&d, dir) == 0);
	rejoin(&c, &d, "rae");
	CHECK(state_names(&c, 2, "left"));
	CHECK(state_names(&c, 1, "base"));
	REQUIRE(rename_node(&c, 2, "port") > 0);
	conn_close(&c);

	/* kill -9 after the rename was acknowledged. */
	CHECK(WIFEXITED(daemon_stop(&d, SIGKILL)) == 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	rejoin(&c, &d, "rae");
	CHECK(state_names(&c, 2, "port"));
	/* The history came back too: undo gives "left" again. */
	REQUIRE(answer(&c, send_undo(&c, false)) > 0);
	CHECK(c.m.edit_applied.ops[0].name.len == 4 &&
	      memcmp(c.m.edit_applied.ops[0].name.ptr, "left", 4) == 0);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void names_of_no_node_are_refused(void)
{
	struct daemon d;
	struct conn c;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	static const float zero[3] = {0, 0, 0}, ident[4] = {0, 0, 0, 1};
	static const float radius = 1.0f;
	struct bc_proto_buf b;
	char dir[64];
	uint32_t seq;
	snprintf(dir, sizeof(dir), "%s/refused", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&c, &d, "ray", BC_PROTO_FEATURES_READ, "x", true);
	CHECK(rename_node(&c, 4000000, "ghost") == 0);
	CHECK_EQ_INT(c.m.error.code, -BC_ENONODE);
	CHECK(!(c.m.flags & BC_PROTO_FLAG_FATAL));
	/* One sphere (id 1) and a names table naming id 2. */
	bc_proto_buf_init(&b, 0);
	REQUIRE(bc_proto_scene_begin(&b, NULL, 1) == 0 &&
	        bc_proto_scene_prim(&b, 1, 1, zero, ident, NULL, 1, &radius) ==
	            0 &&
	        bc_proto_scene_names(&b, 0, 1) == 0 &&
	        bc_proto_scene_name(&b, 2, "x", 1) == 0);
	m.scene_load.scene.ptr = b.data;
	m.scene_load.scene.len = (uint32_t)b.len;
	seq = conn_send(&c, &m);
	bc_proto_buf_finish(&b);
	do {
		REQUIRE(conn_recv(&c, 10000) == 1);
	} while (c.m.type != BC_MSG_ERROR || c.m.seq != seq);
	CHECK_EQ_INT(c.m.error.code, -BC_ENONODE);
	CHECK(!(c.m.flags & BC_PROTO_FLAG_FATAL));
	/* The connection goes on. */
	conn_load_json(&c, scene_json);
	CHECK(rename_node(&c, 2, "fine") > 0);
	/* HISTORY shows a control character escaped, never raw. */
	CHECK(rename_node(&c, 3, "t\tb\x1b[2J") > 0);
	CHECK(history_has(&c, "NAME node 3 \"t\\x09b\\x1b[2J\""));
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"names_reach_members_as_their_features_allow",
     names_reach_members_as_their_features_allow},
    {"a_rename_undoes_and_survives_restarts",
     a_rename_undoes_and_survives_restarts},
    {"names_of_no_node_are_refused", names_of_no_node_are_refused},
};

int main(int argc, char **argv)
{
	(void)conn_view;
	return daemon_tests_run("names", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
