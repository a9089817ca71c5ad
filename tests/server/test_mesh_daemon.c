/*
 * MESH in blobcastd (PROTOCOL.md 7.28): the file a MESH_DATA carries is,
 * byte for byte, what blobtree's mesher and writers make of the session's
 * scene (what `blobcast mesh` writes), in each format, at the default and
 * a given resolution, raw or not, and of the scene as the MESH found it
 * (after an edit: the edit's order and a different file); a PING after a
 * MESH is answered before it; a second MESH of the same client, and a
 * third in the daemon, are refused with EBUSY; a client that did not
 * announce MESH gets ENOTSUP, a resolution over the daemon's bound and a
 * file over the client's max_frame_bytes ELIMIT, all not fatal; the
 * daemon stops promptly while it meshes.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/mesh.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

/* HELLO announcing features, with the client's max_frame_bytes (0: the
 * server's), then a viewer's JOIN of "default"; the SCENE_STATE read. */
static void enter_as(struct conn *c, const struct daemon *d, const char *name,
                     uint32_t features, uint32_t max_frame_bytes)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	REQUIRE(conn_open(c, d) == 0);
	m.hello.version_min = 1;
	m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.max_frame_bytes = max_frame_bytes;
	m.hello.client_name.ptr = name;
	m.hello.client_name.len = (uint32_t)strlen(name);
	m.hello.has_features = true;
	m.hello.features = features;
	REQUIRE(conn_send(c, &m));
	REQUIRE(conn_expect(c, BC_MSG_WELCOME, 5000) == 1);
	REQUIRE(c->m.welcome.features == (features & BC_PROTO_FEATURES_ALL));
	REQUIRE(conn_join(c, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(c, BC_MSG_SCENE_STATE, 5000) == 1);
}

static void enter(struct conn *c, const struct daemon *d, const char *name)
{
	enter_as(c, d, name, BC_PROTO_FEATURES_READ, 0);
}

static uint32_t send_mesh(struct conn *c, enum bc_proto_mesh_format format,
                          uint8_t options, uint16_t resolution)
{
	struct bc_msg m = {.type = BC_MSG_MESH};
	m.mesh.format = format;
	m.mesh.options = options;
	m.mesh.resolution = resolution;
	return conn_send(c, &m);
}

/* Receives until the answer to seq (MESH_DATA or ERROR, in c->m); other
 * messages are skipped. 1, or 0 after 120 s without it. */
static int answer_of(struct conn *c, uint32_t seq)
{
	int64_t end = t_now_ms() + 120000;
	while (t_now_ms() < end) {
		if (conn_recv(c, 200) == 1 &&
		    (c->m.type == BC_MSG_MESH_DATA ||
		     c->m.type == BC_MSG_ERROR) &&
		    c->m.seq == seq) {
			return 1;
		}
	}
	return 0;
}

/* The refusal of seq must be ERROR code, not fatal. */
static void expect_refusal(struct conn *c, uint32_t seq, int code)
{
	REQUIRE(answer_of(c, seq) == 1);
	CHECK_EQ_INT(c->m.type, BC_MSG_ERROR);
	CHECK_EQ_INT(c->m.error.code, -code);
	CHECK(!(c->m.flags & BC_PROTO_FLAG_FATAL));
}

/* What blobtree makes of tree t (a copy is laid out) in format. */
static void local_file(const struct bc_tree *t, enum bc_mesh_format format,
                       uint32_t resolution, bool raw, uint8_t **bytes,
                       size_t *len, uint32_t *ntris)
{
	struct bc_tree *laid = bc_tree_create();
	struct bc_mesh_opts o = {.resolution = resolution, .raw = raw};
	struct bc_mesh mesh;
	memset(&mesh, 0, sizeof(mesh));
	REQUIRE(laid && bc_tree_copy(laid, t, NULL) == 0);
	REQUIRE(bc_mesh_build(&mesh, laid, &o, NULL) == 0);
	REQUIRE(bc_mesh_write_mem(&mesh, format, 0, bytes, len, NULL) == 0);
	*ntris = mesh.ntris;
	bc_mesh_finish(&mesh);
	bc_tree_destroy(laid);
}

/* The id of t's first primitive, in pre-order (0: none). */
static uint32_t first_prim(const struct bc_tree *t)
{
	struct bc_scene_walk w = {0};
	struct bc_scene_node nd;
	uint32_t id = 0;
	if (bc_scene_walk_init(&w, t) != 0) {
		return 0;
	}
	while (!id && bc_scene_walk_next(&w, &nd)) {
		id = nd.is_op ? 0 : nd.id;
	}
	bc_scene_walk_finish(&w);
	return id;
}

/* MESH's answer for seq against blobtree's file of t. */
static void expect_same(struct conn *c, uint32_t seq, const struct bc_tree *t,
                        enum bc_mesh_format format, uint32_t resolution,
                        bool raw, uint64_t order)
{
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint32_t ntris = 0;
	local_file(t, format, resolution, raw, &bytes, &len, &ntris);
	REQUIRE(answer_of(c, seq) == 1);
	REQUIRE(c->m.type == BC_MSG_MESH_DATA);
	CHECK_EQ_INT(c->m.mesh_data.format, (int)format);
	CHECK_EQ_INT(c->m.mesh_data.options, raw ? BC_PROTO_MESH_RAW : 0);
	CHECK_EQ_INT(c->m.mesh_data.resolution, resolution);
	CHECK(c->m.mesh_data.order == order);
	CHECK_EQ_INT(c->m.mesh_data.triangles, ntris);
	CHECK_EQ_INT(c->m.mesh_data.file.len, len);
	CHECK(c->m.mesh_data.file.len == len &&
	      memcmp(c->m.mesh_data.file.ptr, bytes, len) == 0);
	bc_free(bytes);
}

static void test_files_are_blobtrees(void)
{
	char dir[96];
	struct daemon d;
	struct conn a;
	struct bc_tree *before, *after;
	uint64_t order;
	uint32_t seq;
	snprintf(dir, sizeof(dir), "%s/files", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&a, &d, "alice");
	before = scene_of(&a);
	REQUIRE(before);
	/* The default resolution (0) is 128, in every format. */
	seq = send_mesh(&a, BC_PROTO_MESH_GLB, 0, 0);
	expect_same(&a, seq, before, BC_MESH_FORMAT_GLB, 128, false, 0);
	seq = send_mesh(&a, BC_PROTO_MESH_OBJ, BC_PROTO_MESH_RAW, 40);
	expect_same(&a, seq, before, BC_MESH_FORMAT_OBJ, 40, true, 0);
	seq = send_mesh(&a, BC_PROTO_MESH_PLY, 0, 48);
	expect_same(&a, seq, before, BC_MESH_FORMAT_PLY, 48, false, 0);
	seq = send_mesh(&a, BC_PROTO_MESH_STL, 0, 5);
	expect_same(&a, seq, before, BC_MESH_FORMAT_STL, 5, false, 0);
	/* An edit, then a MESH: the mesh is of the edited scene. */
	REQUIRE(first_prim(before));
	seq = conn_move(&a, first_prim(before), 0.75f, 0.5f, 0.25f, false);
	REQUIRE(seq);
	do {
		REQUIRE(conn_expect(&a, BC_MSG_EDIT_APPLIED, 10000) == 1);
	} while (a.m.edit_applied.author_seq != seq);
	order = a.m.edit_applied.order;
	conn_close(&a);
	enter(&a, &d, "alice");
	after = scene_of(&a);
	REQUIRE(after);
	CHECK(a.m.scene_state.order == order);
	seq = send_mesh(&a, BC_PROTO_MESH_OBJ, 0, 64);
	expect_same(&a, seq, after, BC_MESH_FORMAT_OBJ, 64, false, order);
	{
		uint8_t *b0 = NULL;
		size_t n0 = 0;
		uint32_t t0 = 0;
		local_file(before, BC_MESH_FORMAT_OBJ, 64, false, &b0, &n0,
		           &t0);
		CHECK(n0 != a.m.mesh_data.file.len ||
		      memcmp(b0, a.m.mesh_data.file.ptr, n0) != 0);
		bc_free(b0);
	}
	bc_tree_destroy(before);
	bc_tree_destroy(after);
	conn_close(&a);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

static void test_later_requests_and_ebusy(void)
{
	char dir[96];
	struct daemon d;
	struct conn a, b, c;
	struct bc_msg ping = {.type = BC_MSG_PING};
	uint32_t first, second, pinged, other, third;
	bool pong_first = false;
	snprintf(dir, sizeof(dir), "%s/busy", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&a, &d, "alice");
	enter(&b, &d, "bob");
	enter(&c, &d, "carol");
	/* Sent together: alice's two MESHes and PING, bob's MESH, carol's
	 * MESH. A mesh at 256 takes the daemon well over the time these
	 * take to arrive. */
	first = send_mesh(&a, BC_PROTO_MESH_GLB, 0, 256);
	second = send_mesh(&a, BC_PROTO_MESH_GLB, 0, 32);
	ping.ping.stamp = 77;
	pinged = conn_send(&a, &ping);
	other = send_mesh(&b, BC_PROTO_MESH_STL, 0, 256);
	/* carol's after bob's MESH is in: both slots taken. */
	REQUIRE(conn_send(&b, &ping));
	REQUIRE(conn_expect(&b, BC_MSG_PONG, 10000) == 1);
	third = send_mesh(&c, BC_PROTO_MESH_OBJ, 0, 16);
	REQUIRE(first && second && pinged && other && third);
	expect_refusal(&c, third, BC_EBUSY);
	/* alice: the second MESH refused, the PONG before the first's
	 * MESH_DATA. */
	for (int64_t end = t_now_ms() + 120000; t_now_ms() < end;) {
		if (conn_recv(&a, 200) != 1) {
			continue;
		}
		if (a.m.type == BC_MSG_ERROR && a.m.seq == second) {
			CHECK_EQ_INT(a.m.error.code, -BC_EBUSY);
		} else if (a.m.type == BC_MSG_PONG) {
			pong_first = true;
		} else if (a.m.type == BC_MSG_MESH_DATA) {
			CHECK_EQ_INT(a.m.seq, first);
			break;
		}
	}
	CHECK(pong_first);
	CHECK_EQ_INT(a.m.type, BC_MSG_MESH_DATA);
	REQUIRE(answer_of(&b, other) == 1);
	CHECK_EQ_INT(b.m.type, BC_MSG_MESH_DATA);
	/* With the slots free again, carol's next one is made. */
	third = send_mesh(&c, BC_PROTO_MESH_OBJ, 0, 16);
	REQUIRE(answer_of(&c, third) == 1);
	CHECK_EQ_INT(c.m.type, BC_MSG_MESH_DATA);
	conn_close(&a);
	conn_close(&b);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

static void test_refusals(void)
{
	char dir[96];
	struct daemon d;
	struct conn a, old, small;
	struct bc_msg ping = {.type = BC_MSG_PING};
	uint32_t seq;
	snprintf(dir, sizeof(dir), "%s/refusals", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	/* Not announced: ENOTSUP, and the connection goes on. */
	enter_as(&old, &d, "old",
	         BC_PROTO_FEATURES_READ & ~BC_PROTO_FEATURE_MESH, 0);
	seq = send_mesh(&old, BC_PROTO_MESH_GLB, 0, 0);
	expect_refusal(&old, seq, BC_ENOTSUP);
	REQUIRE(conn_send(&old, &ping));
	CHECK(conn_expect(&old, BC_MSG_PONG, 5000) == 1);
	/* Over the daemon's bound (256): ELIMIT. */
	enter(&a, &d, "alice");
	seq = send_mesh(&a, BC_PROTO_MESH_GLB, 0, 257);
	expect_refusal(&a, seq, BC_ELIMIT);
	CHECK(strstr(a.m.error.text.ptr, "256") != NULL);
	/* A file over the client's max_frame_bytes (64 KiB): ELIMIT. */
	enter_as(&small, &d, "small", BC_PROTO_FEATURES_READ,
	         BC_PROTO_MIN_FRAME_BYTES);
	seq = send_mesh(&small, BC_PROTO_MESH_OBJ, 0, 128);
	expect_refusal(&small, seq, BC_ELIMIT);
	CHECK(strstr(small.m.error.text.ptr, "max_frame_bytes") != NULL);
	/* ... and a small one fits. At 8 cells the default scene's thin
	 * shapes leave no surface: an empty STL file, but no glTF one. */
	seq = send_mesh(&small, BC_PROTO_MESH_STL, 0, 8);
	REQUIRE(answer_of(&small, seq) == 1);
	REQUIRE(small.m.type == BC_MSG_MESH_DATA);
	CHECK_EQ_INT(small.m.mesh_data.triangles, 0);
	CHECK_EQ_INT(small.m.mesh_data.file.len, 84);
	seq = send_mesh(&small, BC_PROTO_MESH_GLB, 0, 8);
	expect_refusal(&small, seq, BC_EINVAL);
	conn_close(&old);
	conn_close(&a);
	conn_close(&small);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* SIGTERM while a fine mesh is under way: the daemon stops it and exits
 * cleanly. */
static void test_stop_while_meshing(void)
{
	char dir[96];
	struct daemon d;
	struct conn a;
	struct bc_msg ping = {.type = BC_MSG_PING};
	snprintf(dir, sizeof(dir), "%s/stop", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	enter(&a, &d, "alice");
	REQUIRE(send_mesh(&a, BC_PROTO_MESH_GLB, 0, 256));
	REQUIRE(conn_send(&a, &ping));
	REQUIRE(conn_expect(&a, BC_MSG_PONG, 10000) == 1);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
	conn_close(&a);
}

static const struct bc_test tests[] = {
    {"files_are_blobtrees", test_files_are_blobtrees},
    {"later_requests_and_ebusy", test_later_requests_and_ebusy},
    {"refusals", test_refusals},
    {"stop_while_meshing", test_stop_while_meshing},
};

int main(int argc, char **argv)
{
	(void)conn_view;
	return daemon_tests_run("mesh-daemon", base_dir, sizeof(base_dir),
	                        tests, sizeof(tests) / sizeof(tests[0]), argc,
	                        argv);
}
