/*
 * Undo and redo in blobcastd: two editors change a session (a move, a
 * drag, an insertion, a new colour), undo and redo each other's changes in
 * turn, and at every step each editor's mirror -- built only by replaying
 * EDIT_APPLIED with the edit module -- equals a late joiner's SCENE_STATE,
 * and the scene equals what it was before (after) the changes undone
 * (redone). Undos name the edit and author they take back; a new edit
 * by the author of what was undone leaves nothing to redo; a restart replays
 * the undos from the journal. The editors do not announce HISTORY, so their
 * UNDO is the session's. The undo and redo of each kind of structural edit
 * carry the subtrees of the change, not the scene, to the members and to the
 * journal.
 */
#include <dirent.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

struct editor {
	struct conn c;
	uint32_t member; /* its member id in the session */
	struct bc_tree *mirror;
	/* The last EDIT_APPLIED answering it: the bytes of its subtrees, and
	 * whether one of its operations replaced the root. */
	size_t subtree_bytes;
	bool replaced_root;
};

/* Replays every EDIT_APPLIED in what e has received, until (ms) one
 * answering seq arrives; returns that message's flags, -1 on an ERROR
 * for seq (its code in e->c.m) or a timeout. */
static int await_applied(struct editor *e, uint32_t seq, int ms)
{
	int64_t end = t_now_ms() + ms;
	while (t_now_ms() < end) {
		struct bc_errinfo ei = {0};
		uint32_t root;
		if (conn_recv(&e->c, 100) != 1) {
			continue;
		}
		if (e->c.m.type == BC_MSG_ERROR && e->c.m.seq == seq) {
			return -1;
		}
		if (e->c.m.type != BC_MSG_EDIT_APPLIED) {
			continue;
		}
		root = bc_tree_root(e->mirror);
		if (bc_edit_replay(&e->mirror, &e->c.m.edit_applied, &ei)) {
			CHECK(0 && "an EDIT_APPLIED does not replay");
			return -1;
		}
		if (e->c.m.edit_applied.author == e->member &&
		    e->c.m.edit_applied.author_seq == seq) {
			const struct bc_msg_edit_applied *a =
			    &e->c.m.edit_applied;
			e->subtree_bytes = 0;
			e->replaced_root = false;
			for (uint32_t i = 0; i < a->nops; i++) {
				e->subtree_bytes += a->ops[i].subtree.len;
				e->replaced_root =
				    e->replaced_root ||
				    (a->ops[i].kind == BC_PROTO_EDIT_REPLACE &&
				     a->ops[i].node == root);
			}
			return e->c.m.flags;
		}
	}
	return -1;
}

static void join(struct editor *e, const struct daemon *d, const char *name,
                 bool create)
{
	REQUIRE(conn_open(&e->c, d) == 0);
	/* Without HISTORY: UNDO takes the session's newest change, whoever
	 * made it (PROTOCOL.md 7.20); test_undo_mine covers the rest. */
	REQUIRE(conn_hello_as(&e->c, name, BC_PROTO_ENCODINGS_ALL, true,
	                      BC_PROTO_FEATURES_READ &
	                          ~BC_PROTO_FEATURE_HISTORY) == 0);
	REQUIRE(conn_join(&e->c, "u", BC_PROTO_ROLE_EDITOR, create) == 0);
	e->member = e->c.m.session_info.member_id;
	REQUIRE(conn_expect(&e->c, BC_MSG_SCENE_STATE, 5000) == 1);
	REQUIRE((e->mirror = scene_of(&e->c)));
}

static bool same_tree(const struct bc_tree *a, const struct bc_tree *b)
{
	uint8_t *x = NULL, *y = NULL;
	size_t nx = 0, ny = 0;
	bool same = bc_tree_encode(a, &x, &nx) == 0 &&
	            bc_tree_encode(b, &y, &ny) == 0 && nx == ny &&
	            memcmp(x, y, nx) == 0;
	bc_free(x);
	bc_free(y);
	return same;
}

/* Takes the EDIT_APPLIED messages e is sent into its mirror until the
 * mirror equals want, or 30 s pass (a broadcast to a member is not an
 * answer to anything it asked, so no PING can say it has arrived). The
 * caller then checks the mirror: a missing edit fails there, and an extra
 * one fails the next state check. */
static void catch_up(struct editor *e, const struct bc_tree *want)
{
	struct bc_errinfo ei = {0};
	int64_t end = t_now_ms() + 30000;
	while (!same_tree(e->mirror, want) && t_now_ms() < end) {
		if (conn_recv(&e->c, 100) == 1 &&
		    e->c.m.type == BC_MSG_EDIT_APPLIED) {
			CHECK(bc_edit_replay(&e->mirror, &e->c.m.edit_applied,
			                     &ei) == 0);
		}
	}
}

/* The session's scene as a joiner gets it, or NULL. */
static struct bc_tree *joiner_scene(const struct daemon *d)
{
	struct conn j;
	struct bc_tree *t = NULL;
	if (conn_open(&j, d) != 0) {
		return NULL;
	}
	if (conn_hello(&j, "joiner") == 0 &&
	    conn_join(&j, "u", BC_PROTO_ROLE_VIEWER, false) == 0 &&
	    conn_expect(&j, BC_MSG_SCENE_STATE, 5000) == 1) {
		t = scene_of(&j);
	}
	conn_close(&j);
	return t;
}

/* Both mirrors equal the joiner's scene, and want when it is given. */
static void check_state(const struct daemon *d, struct editor *a,
                        struct editor *b, const struct bc_tree *want)
{
	struct bc_tree *j = joiner_scene(d);
	REQUIRE(j);
	catch_up(a, j);
	catch_up(b, j);
	CHECK(same_tree(a->mirror, j));
	CHECK(same_tree(b->mirror, j));
	if (want) {
		CHECK(same_tree(want, j));
	}
	bc_tree_destroy(j);
}

static struct bc_tree *copy_of(const struct bc_tree *t)
{
	struct bc_tree *c = bc_tree_create();
	if (c && bc_tree_copy(c, t, NULL) != 0) {
		bc_tree_destroy(c);
		c = NULL;
	}
	return c;
}

static uint32_t send_set(struct editor *e, uint32_t id, uint8_t field,
                         const float *v, uint8_t n, bool interacting)
{
	struct bc_proto_field f = {.field = field, .count = n};
	struct bc_proto_edit_op op = {
	    .kind = BC_PROTO_EDIT_SET, .node = id, .nfields = 1, .fields = &f};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	memcpy(f.v, v, n * sizeof(float));
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	m.edit.nops = 1;
	m.edit.ops = &op;
	return conn_send(&e->c, &m);
}

static uint32_t send_insert(struct editor *e, uint32_t parent, uint32_t id)
{
	static const float t[3] = {0.3f, 0.2f, 0.1f}, q[4] = {0, 0, 0, 1};
	float r = 0.25f;
	struct bc_proto_buf b;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT,
	                              .node = parent};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	uint32_t seq;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 1);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id, t, q, NULL, 1, &r);
	op.subtree.ptr = b.data;
	op.subtree.len = (uint32_t)b.len;
	m.edit.nops = 1;
	m.edit.ops = &op;
	seq = conn_send(&e->c, &m);
	bc_proto_buf_finish(&b);
	return seq;
}

static uint32_t send_undo(struct editor *e, bool redo)
{
	struct bc_msg m = {.type = redo ? BC_MSG_REDO : BC_MSG_UNDO};
	return conn_send(&e->c, &m);
}

/* Sends UNDO (REDO) from e; checks the answer names target_order and
 * author. */
static void undo(struct editor *e, bool redo, uint64_t target_order,
                 const char *author)
{
	uint32_t seq = send_undo(e, redo);
	const struct bc_msg_edit_applied *a = &e->c.m.edit_applied;
	int flags = await_applied(e, seq, 10000);
	REQUIRE(flags >= 0);
	CHECK_EQ_INT(flags, redo ? BC_PROTO_FLAG_REDO : BC_PROTO_FLAG_UNDO);
	CHECK_EQ_INT(a->target_order, target_order);
	CHECK(a->target_author.len == strlen(author) &&
	      memcmp(a->target_author.ptr, author, a->target_author.len) == 0);
}

static uint64_t last_order(const struct editor *e)
{
	return e->c.m.edit_applied.order;
}

/* kill -9 and a restart on dir: a joiner's scene equals mirror; then the
 * daemon stops. */
static void restart_gives(struct daemon *d, const char *dir,
                          const struct bc_tree *mirror)
{
	CHECK(WIFEXITED(daemon_stop(d, SIGKILL)) == 0);
	REQUIRE(daemon_start(d, dir) == 0);
	{
		struct bc_tree *j = joiner_scene(d);
		CHECK(j && same_tree(mirror, j));
		bc_tree_destroy(j);
	}
	CHECK(WIFEXITED(daemon_stop(d, SIGTERM)));
}

static void two_editors_undo_and_redo_each_other(void)
{
	struct daemon d;
	struct editor alice = {0}, bob = {0};
	struct bc_tree *before, *after;
	struct bc_prim_data p;
	struct bc_op_data op;
	char dir[64];
	const struct bc_lin *l;
	uint32_t prim0, prim1, root, seq;
	uint64_t o_move, o_drag, o_insert, o_colour;
	float v[3];
	snprintf(dir, sizeof(dir), "%s/two", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	join(&alice, &d, "alice", true);
	join(&bob, &d, "bob", false);
	l = bc_tree_lin(alice.mirror);
	REQUIRE(l && l->nprims >= 2);
	prim0 = l->node_id[l->prim_slot[0]];
	prim1 = l->node_id[l->prim_slot[1]];
	root = bc_tree_root(alice.mirror);
	REQUIRE((before = copy_of(alice.mirror)));

	/* Nothing to undo yet. */
	seq = send_undo(&alice, false);
	CHECK(await_applied(&alice, seq, 5000) == -1);
	CHECK_EQ_INT(alice.c.m.error.code, -BC_ESTATE);

	/* alice moves one primitive; bob drags another (four edits, the
	 * last one the release); alice inserts a sphere. */
	v[0] = 0.4f, v[1] = 0.0f, v[2] = -0.2f;
	REQUIRE(await_applied(&alice,
	                      send_set(&alice, prim0, BC_PROTO_FIELD_TRANSLATE,
	                               v, 3, false),
	                      10000) >= 0);
	o_move = last_order(&alice);
	for (int i = 1; i <= 4; i++) {
		v[0] = 0.1f * (float)i, v[1] = 0.05f * (float)i, v[2] = 0.0f;
		REQUIRE(await_applied(&bob,
		                      send_set(&bob, prim1,
		                               BC_PROTO_FIELD_TRANSLATE, v, 3,
		                               i < 4),
		                      10000) >= 0);
	}
	o_drag = last_order(&bob);
	REQUIRE(await_applied(&alice, send_insert(&alice, root, 9001), 10000) >=
	        0);
	o_insert = last_order(&alice);
	REQUIRE((after = copy_of(alice.mirror)));
	check_state(&d, &alice, &bob, after);

	/* bob undoes alice's insertion, alice undoes bob's whole drag, bob
	 * undoes alice's move: the scene is as it started. */
	undo(&bob, false, o_insert, "alice");
	check_state(&d, &alice, &bob, NULL);
	undo(&alice, false, o_drag, "bob");
	check_state(&d, &alice, &bob, NULL);
	undo(&bob, false, o_move, "alice");
	check_state(&d, &alice, &bob, before);
	seq = send_undo(&bob, false);
	CHECK(await_applied(&bob, seq, 5000) == -1);
	CHECK_EQ_INT(bob.c.m.error.code, -BC_ESTATE);

	/* Three redos bring every change back, in order. */
	undo(&alice, true, o_move, "alice");
	undo(&bob, true, o_drag, "bob");
	undo(&alice, true, o_insert, "alice");
	check_state(&d, &alice, &bob, after);

	/* A colour on a primitive that had none (the inserted sphere) is
	 * taken away again. */
	REQUIRE(bc_tree_get(alice.mirror, 9001, &p, &op));
	REQUIRE(!p.has_color);
	v[0] = 1.0f, v[1] = 0.0f, v[2] = 0.0f;
	REQUIRE(await_applied(
	            &alice,
	            send_set(&alice, 9001, BC_PROTO_FIELD_COLOR, v, 3, false),
	            10000) >= 0);
	o_colour = last_order(&alice);
	undo(&bob, false, o_colour, "alice");
	check_state(&d, &alice, &bob, after);
	REQUIRE(bc_tree_get(alice.mirror, 9001, &p, &op));
	CHECK(!p.has_color);

	/* A new edit by the author of the change undone leaves nothing to
	 * redo (PROTOCOL.md 7.20: it drops its author's undone steps). */
	v[0] = -0.3f, v[1] = 0.1f, v[2] = 0.0f;
	REQUIRE(await_applied(&alice,
	                      send_set(&alice, prim1, BC_PROTO_FIELD_TRANSLATE,
	                               v, 3, false),
	                      10000) >= 0);
	seq = send_undo(&alice, true);
	CHECK(await_applied(&alice, seq, 5000) == -1);
	CHECK_EQ_INT(alice.c.m.error.code, -BC_ESTATE);
	check_state(&d, &alice, &bob, NULL);

	/* After a restart the journal, undos included, gives the same
	 * scene. */
	conn_close(&alice.c);
	conn_close(&bob.c);
	restart_gives(&d, dir, alice.mirror);
	bc_tree_destroy(alice.mirror);
	bc_tree_destroy(bob.mirror);
	bc_tree_destroy(before);
	bc_tree_destroy(after);
}

/* ---- structural steps, kept and sent in proportion to the change ---- */

static const float T0[3] = {0, 0, 0}, R0[4] = {0, 0, 0, 1};

/* union 1 { spheres 100 .. 100 + n - 1, union 5 { sphere 6, sphere 7 },
 * offset 8 { sphere 9 } }, loaded into alice's session; both mirrors
 * start from its SCENE_STATE. */
static void load_spheres(struct editor *alice, struct editor *bob, uint32_t n)
{
	struct bc_proto_buf b;
	struct bc_tree *t = bc_tree_create();
	float r = 0.05f, amount = 0.02f;
	REQUIRE(t);
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, n + 6);
	bc_proto_scene_op(&b, BC_OP_UNION, 1, 0, 0, n + 2);
	for (uint32_t i = 0; i < n; i++) {
		float at[3] = {(float)(i % 100) * 0.02f - 1.0f,
		               (float)(i / 100) * 0.02f - 1.0f, 0.0f};
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 100 + i, at, R0, NULL,
		                    1, &r);
	}
	bc_proto_scene_op(&b, BC_OP_UNION, 5, 0, 0, 2);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 6, T0, R0, NULL, 1, &r);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 7, T0, R0, NULL, 1, &r);
	bc_proto_scene_unary(&b, BC_OP_OFFSET, 8, 1, &amount);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 9, T0, R0, NULL, 1, &r);
	REQUIRE(bc_scene_decode(b.data, b.len, t, NULL, NULL, NULL) == 0);
	bc_proto_buf_finish(&b);
	conn_load_tree(&alice->c, t, NULL);
	bc_tree_destroy(alice->mirror);
	REQUIRE((alice->mirror = scene_of(&alice->c)));
	REQUIRE(conn_expect(&bob->c, BC_MSG_SCENE_STATE, 60000) == 1);
	bc_tree_destroy(bob->mirror);
	REQUIRE((bob->mirror = scene_of(&bob->c)));
}

static uint32_t send_ops(struct editor *e, const struct bc_proto_edit_op *ops,
                         uint16_t n)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	m.edit.nops = n;
	m.edit.ops = ops;
	return conn_send(&e->c, &m);
}

/* A one-sphere subtree of id. */
static struct bc_proto_buf sphere_bytes(uint32_t id)
{
	struct bc_proto_buf b;
	float r = 0.1f;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 1);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id, T0, R0, NULL, 1, &r);
	return b;
}

/* alice applies ops; bob undoes them, alice redoes them, bob undoes them
 * again. Each time the session's scene (a joiner's) and both mirrors are
 * the scene before (an undo) or after (the redo), node for node, and the
 * EDIT_APPLIED of each undo and redo carries at most max_bytes of
 * subtrees and replaces no root. */
static void undo_redo_one(const struct daemon *d, struct editor *alice,
                          struct editor *bob,
                          const struct bc_proto_edit_op *ops, uint16_t n,
                          size_t max_bytes)
{
	struct bc_tree *before = copy_of(alice->mirror), *after = NULL;
	uint64_t o;
	REQUIRE(before);
	if (await_applied(alice, send_ops(alice, ops, n), 30000) < 0) {
		fprintf(stderr, "  edit refused: %.*s\n",
		        (int)alice->c.m.error.text.len,
		        alice->c.m.error.text.ptr);
		CHECK(0 && "the edit applies");
		bc_tree_destroy(before);
		return;
	}
	o = last_order(alice);
	REQUIRE((after = copy_of(alice->mirror)));
	CHECK(!same_tree(before, after));
	check_state(d, alice, bob, after);
	undo(bob, false, o, "alice");
	CHECK(bob->subtree_bytes <= max_bytes);
	CHECK(!bob->replaced_root);
	check_state(d, alice, bob, before);
	undo(alice, true, o, "alice");
	CHECK(alice->subtree_bytes <= max_bytes);
	CHECK(!alice->replaced_root);
	check_state(d, alice, bob, after);
	/* Undone again (the inverse of the redo): the next case starts from
	 * the same scene. */
	undo(bob, false, o, "alice");
	CHECK(bob->subtree_bytes <= max_bytes);
	check_state(d, alice, bob, before);
	bc_tree_destroy(before);
	bc_tree_destroy(after);
}

/* Every structural edit kind on a 2000-sphere scene (78 KB encoded):
 * INSERT, REMOVE (of one of many children; of the child of a unary node,
 * which takes the node too; of one of two children, which takes their
 * operator), REPLACE, and a move to another group (REMOVE and INSERT of
 * the same id). Undo and redo restore the exact scene on the server and
 * on mirrors replaying the broadcast EDIT_APPLIED, each carrying the
 * subtrees of the change -- a sphere, an operator of two -- not the
 * scene; a restart restores the same scene. */
static void structural_undo_redo_exact_and_small(void)
{
	struct daemon d;
	struct editor alice = {0}, bob = {0};
	struct bc_proto_buf s1 = sphere_bytes(3), s2 = sphere_bytes(5);
	struct bc_proto_buf s3 = sphere_bytes(103);
	struct bc_proto_edit_op op[2];
	char dir[64];
	/* A sphere node is 39 bytes, an operator 17; scene header 5. */
	const size_t one = 5 + 39, group = 5 + 17 + 2 * 39;
	snprintf(dir, sizeof(dir), "%s/kinds", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	join(&alice, &d, "alice", true);
	join(&bob, &d, "bob", false);
	load_spheres(&alice, &bob, 2000);

	op[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
	                              .node = 1,
	                              .position = 7,
	                              .subtree = {s1.data, (uint32_t)s1.len}};
	undo_redo_one(&d, &alice, &bob, op, 1, one);
	op[0] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                  .node = 150};
	undo_redo_one(&d, &alice, &bob, op, 1, one);
	op[0].node = 9; /* offset 8 goes with it */
	undo_redo_one(&d, &alice, &bob, op, 1, one + 10);
	op[0].node = 6; /* union 5 goes, sphere 7 in its place */
	undo_redo_one(&d, &alice, &bob, op, 1, group);
	op[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REPLACE,
	                              .node = 5,
	                              .subtree = {s2.data, (uint32_t)s2.len}};
	undo_redo_one(&d, &alice, &bob, op, 1, group + one);
	op[0] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                  .node = 103};
	op[1] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
	                              .node = 5,
	                              .position = 1,
	                              .subtree = {s3.data, (uint32_t)s3.len}};
	undo_redo_one(&d, &alice, &bob, op, 2, 2 * one);

	/* The journal, undos and redos included, restores that scene. */
	conn_close(&alice.c);
	conn_close(&bob.c);
	restart_gives(&d, dir, alice.mirror);
	bc_proto_buf_finish(&s1);
	bc_proto_buf_finish(&s2);
	bc_proto_buf_finish(&s3);
	bc_tree_destroy(alice.mirror);
	bc_tree_destroy(bob.mirror);
}

/* The UNDO of an INSERT of one sphere into a 10 000-sphere scene (390 KB
 * encoded) is journaled as a REMOVE: its record takes well under 4 KiB,
 * and so does the REDO's (an INSERT of the sphere). A restart on the same
 * data directory replays them to the same scene. */
static void undo_of_an_insert_journals_a_small_record(void)
{
	struct daemon d;
	struct editor alice = {0}, bob = {0};
	struct bc_proto_buf s1 = sphere_bytes(3);
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT,
	                              .node = 1,
	                              .position = 5000,
	                              .subtree = {s1.data, (uint32_t)s1.len}};
	struct bc_tree *before;
	long long j0, j1, j2;
	char dir[64];
	uint64_t o;
	snprintf(dir, sizeof(dir), "%s/journal", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	join(&alice, &d, "alice", true);
	join(&bob, &d, "bob", false);
	load_spheres(&alice, &bob, 10000);
	REQUIRE((before = copy_of(alice.mirror)));
	REQUIRE(await_applied(&alice, send_ops(&alice, &op, 1), 30000) >= 0);
	o = last_order(&alice);
	REQUIRE((j0 = session_journal_bytes(dir, "u")) > 0);
	undo(&bob, false, o, "alice");
	j1 = session_journal_bytes(dir, "u");
	undo(&bob, true, o, "alice");
	j2 = session_journal_bytes(dir, "u");
	CHECK(j1 - j0 > 0 && j1 - j0 < 4096);
	CHECK(j2 - j1 > 0 && j2 - j1 < 4096);
	undo(&alice, false, o, "alice");
	check_state(&d, &alice, &bob, before);

	conn_close(&alice.c);
	conn_close(&bob.c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGKILL)) == 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	{
		struct bc_tree *j = joiner_scene(&d);
		CHECK(j && same_tree(before, j));
		bc_tree_destroy(j);
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_proto_buf_finish(&s1);
	bc_tree_destroy(before);
	bc_tree_destroy(alice.mirror);
	bc_tree_destroy(bob.mirror);
}

static const struct bc_test tests[] = {
    {"two_editors_undo_and_redo_each_other",
     two_editors_undo_and_redo_each_other},
    {"structural_undo_redo_exact_and_small",
     structural_undo_redo_exact_and_small},
    {"undo_of_an_insert_journals_a_small_record",
     undo_of_an_insert_journals_a_small_record},
};

int main(int argc, char **argv)
{
	(void)conn_view;
	(void)conn_move;
	return daemon_tests_run("undo", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
