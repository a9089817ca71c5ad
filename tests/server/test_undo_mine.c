/*
 * Per-person undo in blobcastd (PROTOCOL.md 7.20, 7.26): two editors each
 * undo only their own change; with three editors a change someone built
 * on is skipped and then refused, naming the change built on it; the
 * session-wide undo is refused to a plain editor and allowed to the
 * session's owner and to its presenter; the history (HISTORY) and who
 * may undo what survive a SIGTERM and a kill -9 restart, keyed by client
 * name; a client that did not announce HISTORY keeps the session-wide
 * undo; bad UNDO payloads get the right ERROR.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];
/* Each connection's member id, by socket: answers are told apart from
 * other members' edits by their author. */
static uint32_t member_of_fd[1024];

static void note_member(const struct conn *c)
{
	REQUIRE(c->fd >= 0 && c->fd < 1024 && c->m.type == BC_MSG_SESSION_INFO);
	member_of_fd[c->fd] = c->m.session_info.member_id;
}

/* A HELLO of this text (every feature, HISTORY among them) as name, then
 * SESSION_CREATE or JOIN of session as an editor; the SCENE_STATE read. */
static void enter(struct conn *c, const struct daemon *d, const char *name,
                  const char *session, bool create)
{
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello(c, name) == 0);
	REQUIRE(conn_join(c, session, BC_PROTO_ROLE_EDITOR, create) == 0);
	note_member(c);
	REQUIRE(conn_expect(c, BC_MSG_SCENE_STATE, 5000) == 1);
}

/* The ids of the first n primitives of c's SCENE_STATE, in pre-order. */
static void prims_of(const struct conn *c, uint32_t *ids, uint32_t n)
{
	struct bc_tree *t = scene_of(c);
	struct bc_scene_walk w = {0};
	struct bc_scene_node nd;
	uint32_t k = 0;
	REQUIRE(t && bc_scene_walk_init(&w, t) == 0);
	while (k < n && bc_scene_walk_next(&w, &nd)) {
		if (!nd.is_op) {
			ids[k++] = nd.id;
		}
	}
	bc_scene_walk_finish(&w);
	bc_tree_destroy(t);
	REQUIRE(k == n);
}

/* Waits for the answer to seq: its EDIT_APPLIED's order (c->m holds it),
 * or 0 after an ERROR for seq (c->m holds that) or a timeout. */
static uint64_t answer(struct conn *c, uint32_t seq)
{
	uint64_t o = conn_edit_answer(c, member_of_fd[c->fd], seq);
	CHECK(o > 0 || c->m.type == BC_MSG_ERROR);
	return o;
}

/* A SET of node's translate; returns the edit's order. */
static uint64_t move(struct conn *c, uint32_t node, float x)
{
	uint64_t o = answer(c, conn_move(c, node, x, 0.25f, 0.0f, false));
	CHECK(o > 0);
	return o;
}

static uint32_t send_undo(struct conn *c, bool redo, uint8_t scope)
{
	struct bc_msg m = {.type = redo ? BC_MSG_REDO : BC_MSG_UNDO};
	m.undo.scope = scope;
	return conn_send(c, &m);
}

/* UNDO (REDO) of scope from c must take back edit target of author. */
static void undo_takes(struct conn *c, bool redo, uint8_t scope,
                       uint64_t target, const char *author)
{
	uint64_t o = answer(c, send_undo(c, redo, scope));
	const struct bc_msg_edit_applied *a = &c->m.edit_applied;
	REQUIRE(o > 0);
	CHECK(c->m.flags & (redo ? BC_PROTO_FLAG_REDO : BC_PROTO_FLAG_UNDO));
	CHECK(a->target_order == target);
	CHECK(a->target_author.len == strlen(author) &&
	      memcmp(a->target_author.ptr, author, a->target_author.len) == 0);
}

/* UNDO (REDO) of scope from c must be refused with code; the ERROR's
 * text must hold has (when not NULL). */
static void undo_refused(struct conn *c, bool redo, uint8_t scope, int code,
                         const char *has)
{
	char text[BC_PROTO_MAX_ERROR_TEXT + 1];
	REQUIRE(answer(c, send_undo(c, redo, scope)) == 0);
	REQUIRE(c->m.type == BC_MSG_ERROR);
	CHECK_EQ_INT(c->m.error.code, -code);
	memcpy(text, c->m.error.text.ptr, c->m.error.text.len);
	text[c->m.error.text.len] = '\0';
	if (has && !strstr(text, has)) {
		fprintf(stderr, "  error text \"%s\" lacks \"%s\"\n", text,
		        has);
		CHECK(0 && "the error names what it should");
	}
}

/* One HISTORY entry as compared across restarts. */
struct entry {
	uint64_t order, time_ms, built_on;
	uint8_t state, flags;
	char author[BC_PROTO_MAX_NAME + 1];
	char what[BC_PROTO_MAX_HISTORY_TEXT + 1];
};

/* HISTORY_GET from c: the entries (at most cap) into e, their count
 * into *count. */
static void history_into(struct conn *c, struct entry *e, uint32_t cap,
                         uint32_t *count)
{
	struct bc_msg m = {.type = BC_MSG_HISTORY_GET};
	uint32_t seq = conn_send(c, &m), n;
	*count = 0;
	for (;;) {
		REQUIRE(conn_recv(c, 10000) == 1);
		if (c->m.seq == seq && (c->m.type == BC_MSG_HISTORY ||
		                        c->m.type == BC_MSG_ERROR)) {
			break;
		}
	}
	REQUIRE(c->m.type == BC_MSG_HISTORY);
	n = c->m.history.nentries;
	REQUIRE(n <= cap);
	for (uint32_t i = 0; i < n; i++) {
		const struct bc_proto_history_entry *x =
		    &c->m.history.entries[i];
		memset(&e[i], 0, sizeof(e[i]));
		e[i].order = x->order;
		e[i].time_ms = x->time_ms;
		e[i].built_on = x->built_on;
		e[i].state = x->state;
		e[i].flags = x->flags;
		memcpy(e[i].author, x->author.ptr, x->author.len);
		memcpy(e[i].what, x->what.ptr, x->what.len);
	}
	*count = n;
}

static uint32_t history(struct conn *c, struct entry *e, uint32_t cap)
{
	uint32_t n = 0;
	history_into(c, e, cap, &n);
	return n;
}

/* The entry of edit order in e[0..n), or NULL. */
static const struct entry *entry_of(const struct entry *e, uint32_t n,
                                    uint64_t order)
{
	for (uint32_t i = 0; i < n; i++) {
		if (e[i].order == order) {
			return &e[i];
		}
	}
	return NULL;
}

static void two_editors_each_undo_their_own(void)
{
	struct daemon d;
	struct conn alice, bob;
	uint32_t p[2];
	uint64_t oa, ob;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/two", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&alice, &d, "alice", "two", true);
	prims_of(&alice, p, 2);
	enter(&bob, &d, "bob", "two", false);
	oa = move(&alice, p[0], 0.5f);
	ob = move(&bob, p[1], -0.5f);
	/* alice's UNDO (no scope byte: her own) takes her change, not
	 * bob's newer one; bob's (scope MINE) takes his. */
	undo_takes(&alice, false, BC_PROTO_UNDO_DEFAULT, oa, "alice");
	undo_takes(&bob, false, BC_PROTO_UNDO_MINE, ob, "bob");
	undo_refused(&alice, false, BC_PROTO_UNDO_MINE, BC_ESTATE,
	             "nothing to undo");
	/* Each redoes their own. */
	undo_takes(&bob, true, BC_PROTO_UNDO_MINE, ob, "bob");
	undo_takes(&alice, true, BC_PROTO_UNDO_MINE, oa, "alice");
	conn_close(&alice);
	conn_close(&bob);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void three_editors_built_on_is_skipped_then_refused(void)
{
	struct daemon d;
	struct conn alice, bob, carol;
	struct entry e[16];
	const struct entry *x;
	uint32_t p[3], n;
	uint64_t o1, o2, o3, o4;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/three", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&alice, &d, "alice", "three", true);
	prims_of(&alice, p, 3);
	enter(&bob, &d, "bob", "three", false);
	enter(&carol, &d, "carol", "three", false);
	o1 = move(&alice, p[0], 0.1f); /* alice: A */
	o2 = move(&alice, p[1], 0.2f); /* alice: B */
	o3 = move(&bob, p[1], 0.3f);   /* bob builds on alice's B */
	o4 = move(&carol, p[2], 0.4f); /* carol: elsewhere */
	/* alice's newest change (B) is built on: skipped, A goes. */
	undo_takes(&alice, false, BC_PROTO_UNDO_MINE, o1, "alice");
	/* Only B is left, built on by bob's edit: refused, naming it. */
	undo_refused(&alice, false, BC_PROTO_UNDO_MINE, BC_ESTATE, "bob");
	/* What carol sees: bob's on top of alice's B, carol's own, alice's
	 * A undone; nobody's but carol's is hers. */
	n = history(&carol, e, 16);
	CHECK_EQ_INT(n, 4);
	REQUIRE((x = entry_of(e, n, o2)));
	CHECK(x->state == BC_PROTO_HISTORY_APPLIED && x->built_on == o3 &&
	      strcmp(x->author, "alice") == 0 && !x->flags);
	CHECK(strncmp(x->what, "SET node ", 9) == 0 &&
	      strstr(x->what, "translate"));
	REQUIRE((x = entry_of(e, n, o1)));
	CHECK(x->state == BC_PROTO_HISTORY_UNDONE && x->built_on == 0);
	REQUIRE((x = entry_of(e, n, o4)));
	CHECK(x->flags == (BC_PROTO_HISTORY_YOURS | BC_PROTO_HISTORY_NEXT));
	CHECK(x->time_ms > 1700000000000ull);
	REQUIRE((x = entry_of(e, n, o3)));
	CHECK(x->built_on == 0 && strcmp(x->author, "bob") == 0);
	/* bob undoes his; then alice's B is free again. */
	undo_takes(&bob, false, BC_PROTO_UNDO_MINE, o3, "bob");
	undo_takes(&alice, false, BC_PROTO_UNDO_MINE, o2, "alice");
	/* bob redoes his (an undo builds on nothing: it is no applied
	 * change); now alice's undone B is built on by it, so her REDO
	 * skips it and brings back A, and the next one is refused. */
	undo_takes(&bob, true, BC_PROTO_UNDO_MINE, o3, "bob");
	undo_takes(&alice, true, BC_PROTO_UNDO_MINE, o1, "alice");
	undo_refused(&alice, true, BC_PROTO_UNDO_MINE, BC_ESTATE, "bob");
	conn_close(&alice);
	conn_close(&bob);
	conn_close(&carol);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* An INSERT of a group: its inner nodes are the change's too. alice
 * inserts a union of two spheres (ids 9001..9003) under the root; bob's
 * edit of a sphere inside it builds on her insert, so her UNDO of it is
 * refused naming bob until he takes his back. */
static void an_edit_inside_an_inserted_group_builds_on_it(void)
{
	static const float t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, r = 0.2f;
	struct bc_proto_edit_op ins = {.kind = BC_PROTO_EDIT_INSERT};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	struct bc_proto_buf g;
	struct bc_scene_walk w = {0};
	struct bc_scene_node root;
	struct bc_tree *tree;
	struct daemon d;
	struct conn alice, bob;
	uint64_t o1, o2;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/inserted", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&alice, &d, "alice", "inserted", true);
	REQUIRE((tree = scene_of(&alice)) &&
	        bc_scene_walk_init(&w, tree) == 0 &&
	        bc_scene_walk_next(&w, &root) && root.is_op);
	bc_scene_walk_finish(&w);
	bc_tree_destroy(tree);
	enter(&bob, &d, "bob", "inserted", false);
	bc_proto_buf_init(&g, 0);
	REQUIRE(bc_proto_scene_begin(&g, NULL, 3) == 0 &&
	        bc_proto_scene_op(&g, BC_OP_UNION, 9001, 0, 0, 2) == 0 &&
	        bc_proto_scene_prim(&g, BC_PRIM_SPHERE, 9002, t, q, NULL, 1,
	                            &r) == 0 &&
	        bc_proto_scene_prim(&g, BC_PRIM_SPHERE, 9003, t, q, NULL, 1,
	                            &r) == 0);
	ins.node = root.id;
	ins.subtree.ptr = g.data;
	ins.subtree.len = (uint32_t)g.len;
	m.edit.nops = 1;
	m.edit.ops = &ins;
	o1 = answer(&alice, conn_send(&alice, &m));
	REQUIRE(o1 > 0);
	o2 = move(&bob, 9003, 0.5f); /* inside alice's group */
	undo_refused(&alice, false, BC_PROTO_UNDO_MINE, BC_ESTATE, "bob");
	undo_takes(&bob, false, BC_PROTO_UNDO_MINE, o2, "bob");
	undo_takes(&alice, false, BC_PROTO_UNDO_MINE, o1, "alice");
	bc_proto_buf_finish(&g);
	conn_close(&alice);
	conn_close(&bob);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void session_undo_is_the_owners_or_presenters(void)
{
	struct daemon d;
	struct conn alice, bob;
	struct bc_msg pr = {.type = BC_MSG_PRESENT};
	uint32_t p[2];
	uint64_t oa, ob, ob2;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/owner", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&alice, &d, "alice", "own", true); /* alice owns "own" */
	prims_of(&alice, p, 2);
	enter(&bob, &d, "bob", "own", false);
	oa = move(&alice, p[0], 0.5f);
	ob = move(&bob, p[1], 0.5f);
	/* bob is a plain editor: EPERM for the session's undo. */
	undo_refused(&bob, false, BC_PROTO_UNDO_SESSION, BC_EPERM, "owner");
	undo_refused(&bob, true, BC_PROTO_UNDO_SESSION, BC_EPERM, NULL);
	/* alice, the owner, takes the session's newest: bob's. */
	undo_takes(&alice, false, BC_PROTO_UNDO_SESSION, ob, "bob");
	/* bob presents: now he may, and takes alice's. */
	pr.toggle.on = 1;
	REQUIRE(conn_send(&bob, &pr));
	REQUIRE(conn_expect(&bob, BC_MSG_OK, 5000) == 1);
	undo_takes(&bob, false, BC_PROTO_UNDO_SESSION, oa, "alice");
	undo_takes(&bob, true, BC_PROTO_UNDO_SESSION, oa, "alice");
	ob2 = move(&bob, p[1], 0.7f);
	CHECK(ob2 > ob);
	conn_close(&alice);
	conn_close(&bob);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* The entries of a and b agree (the NEXT and YOURS flags are the
 * asker's, so one asker for both). */
static void same_history(const struct entry *a, uint32_t na,
                         const struct entry *b, uint32_t nb)
{
	CHECK_EQ_INT(na, nb);
	for (uint32_t i = 0; i < na && i < nb; i++) {
		CHECK(a[i].order == b[i].order && a[i].state == b[i].state &&
		      a[i].built_on == b[i].built_on &&
		      a[i].time_ms == b[i].time_ms &&
		      a[i].flags == b[i].flags &&
		      strcmp(a[i].author, b[i].author) == 0 &&
		      strcmp(a[i].what, b[i].what) == 0);
	}
}

/* A new connection as name, in session "keep". */
static void back_as(struct conn *c, const struct daemon *d, const char *name)
{
	enter(c, d, name, "keep", false);
}

static void history_survives_sigterm_and_kill9(void)
{
	struct daemon d;
	struct conn alice, bob, look;
	struct entry e0[16], e1[16], e2[16];
	uint32_t p[3], n0, n1, n2;
	uint64_t o1, o2, o3, o4;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/keep", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&alice, &d, "alice", "keep", true);
	prims_of(&alice, p, 3);
	enter(&bob, &d, "bob", "keep", false);
	o1 = move(&alice, p[0], 0.1f);
	o2 = move(&bob, p[1], 0.2f);
	o3 = move(&alice, p[2], 0.3f);
	undo_takes(&alice, false, BC_PROTO_UNDO_MINE, o3, "alice");
	back_as(&look, &d, "alice");
	n0 = history(&look, e0, 16);
	CHECK_EQ_INT(n0, 3);
	conn_close(&look);
	conn_close(&alice);
	conn_close(&bob);

	/* SIGTERM: the session is saved whole (its history beside its
	 * snapshot); alice, back with a new member id, sees the same
	 * history and still owns her steps. */
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	REQUIRE(daemon_start(&d, dir) == 0);
	back_as(&look, &d, "alice");
	n1 = history(&look, e1, 16);
	same_history(e0, n0, e1, n1);
	undo_takes(&look, true, BC_PROTO_UNDO_MINE, o3, "alice");
	undo_takes(&look, false, BC_PROTO_UNDO_MINE, o3, "alice");
	back_as(&bob, &d, "bob");
	o4 = move(&bob, p[0], 0.9f); /* bob builds on alice's o1 */
	n1 = history(&look, e1, 16);
	conn_close(&look);
	conn_close(&bob);

	/* kill -9: the journal gives the history back, edit by edit. */
	CHECK(WIFEXITED(daemon_stop(&d, SIGKILL)) == 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	back_as(&look, &d, "alice");
	n2 = history(&look, e2, 16);
	same_history(e1, n1, e2, n2);
	CHECK(entry_of(e2, n2, o1) && entry_of(e2, n2, o1)->built_on == o4);
	/* alice's o1 is built on: her redo of o3 is what is left. */
	undo_refused(&look, false, BC_PROTO_UNDO_MINE, BC_ESTATE, "bob");
	undo_takes(&look, true, BC_PROTO_UNDO_MINE, o3, "alice");
	back_as(&bob, &d, "bob");
	undo_takes(&bob, false, BC_PROTO_UNDO_MINE, o4, "bob");
	undo_takes(&bob, false, BC_PROTO_UNDO_MINE, o2, "bob");
	conn_close(&look);
	conn_close(&bob);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void earlier_client_keeps_the_session_undo(void)
{
	struct daemon d;
	struct conn alice, old;
	struct bc_msg m = {.type = BC_MSG_HISTORY_GET};
	uint32_t p[2], seq;
	uint64_t oa;
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/old", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&alice, &d, "alice", "old", true);
	prims_of(&alice, p, 2);
	/* A client of the first text: no features field at all. */
	REQUIRE(conn_open(&old, &d) == 0);
	REQUIRE(conn_hello_as(&old, "old", BC_PROTO_ENCODINGS_ALL, false, 0) ==
	        0);
	REQUIRE(conn_join(&old, "old", BC_PROTO_ROLE_EDITOR, false) == 0);
	note_member(&old);
	oa = move(&alice, p[0], 0.5f);
	/* Its UNDO is the session's, as it always was: alice's change,
	 * answered without the UNDO flag it did not announce. */
	REQUIRE(answer(&old, send_undo(&old, false, 0)) > 0);
	CHECK(old.m.flags == 0 && old.m.edit_applied.target_order == 0);
	/* A scope byte or HISTORY_GET from it: ENOTSUP, not fatal. */
	REQUIRE(answer(&old, send_undo(&old, false, BC_PROTO_UNDO_MINE)) == 0);
	CHECK_EQ_INT(old.m.error.code, -BC_ENOTSUP);
	CHECK(!(old.m.flags & BC_PROTO_FLAG_FATAL));
	seq = conn_send(&old, &m);
	REQUIRE(conn_expect(&old, BC_MSG_ERROR, 5000) == 1);
	CHECK(old.m.seq == seq);
	CHECK_EQ_INT(old.m.error.code, -BC_ENOTSUP);
	/* Still served. */
	CHECK(answer(&old, send_undo(&old, true, 0)) > 0);
	(void)oa;
	conn_close(&alice);
	conn_close(&old);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* An UNDO with payload bytes: header, then the payload. */
static void send_undo_bytes(struct conn *c, const uint8_t *pl, uint32_t n)
{
	uint8_t b[32] = {'B', 'C', 'S', 'T', 1, BC_MSG_UNDO, 0, 0};
	b[8] = (uint8_t)n;
	b[12] = (uint8_t)++c->seq;
	memcpy(b + 16, pl, n);
	REQUIRE(send_raw(c, b, 16u + n) == 0);
}

/* c must get a FATAL ERROR code and then be closed. */
static void refused_fatal(struct conn *c, int code)
{
	REQUIRE(conn_expect(c, BC_MSG_ERROR, 5000) == 1);
	CHECK_EQ_INT(c->m.error.code, -code);
	CHECK(c->m.flags & BC_PROTO_FLAG_FATAL);
	CHECK(conn_recv(c, 5000) == -1);
}

static void bad_undo_payloads_are_refused(void)
{
	static const uint8_t zero = 0, three = 3, two[2] = {1, 1};
	struct daemon d;
	struct conn c;
	struct bc_msg m = {.type = BC_MSG_HISTORY_GET};
	char dir[64];
	snprintf(dir, sizeof(dir), "%s/bad", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	/* Unknown scopes (0 is never valid, 3 is not defined). */
	enter(&c, &d, "x", "bad", true);
	send_undo_bytes(&c, &three, 1);
	refused_fatal(&c, BC_EENUM);
	conn_close(&c);
	enter(&c, &d, "x", "bad", false);
	send_undo_bytes(&c, &zero, 1);
	refused_fatal(&c, BC_EENUM);
	conn_close(&c);
	/* Two bytes: over UNDO's largest payload. */
	enter(&c, &d, "x", "bad", false);
	send_undo_bytes(&c, two, 2);
	refused_fatal(&c, BC_EPROTO_LENGTH);
	conn_close(&c);
	/* HISTORY_GET outside a session: ESTATE, not fatal. */
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_hello(&c, "x") == 0);
	REQUIRE(conn_send(&c, &m));
	REQUIRE(conn_expect(&c, BC_MSG_ERROR, 5000) == 1);
	CHECK_EQ_INT(c.m.error.code, -BC_ESTATE);
	CHECK(!(c.m.flags & BC_PROTO_FLAG_FATAL));
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"two_editors_each_undo_their_own", two_editors_each_undo_their_own},
    {"three_editors_built_on_is_skipped_then_refused",
     three_editors_built_on_is_skipped_then_refused},
    {"an_edit_inside_an_inserted_group_builds_on_it",
     an_edit_inside_an_inserted_group_builds_on_it},
    {"session_undo_is_the_owners_or_presenters",
     session_undo_is_the_owners_or_presenters},
    {"history_survives_sigterm_and_kill9", history_survives_sigterm_and_kill9},
    {"earlier_client_keeps_the_session_undo",
     earlier_client_keeps_the_session_undo},
    {"bad_undo_payloads_are_refused", bad_undo_payloads_are_refused},
};

int main(int argc, char **argv)
{
	(void)conn_view;
	return daemon_tests_run("undo-mine", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
