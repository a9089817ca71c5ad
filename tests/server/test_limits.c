/*
 * blobcastd's limits against clients that misbehave: a message trickled a
 * byte a second times out, a client idle in no session is dropped (session
 * members are not), a flood of connections that never say HELLO leaves
 * room for others, a scene too big to send to a member is refused before
 * anything is applied or saved, and memory held for dropped clients goes
 * back to the system.
 */
#include <arpa/inet.h>
#include <netinet/in.h>

#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"
#include "srv_limits.h"

/* c opens a connection to d as client name and joins session "s" in role
 * (creating it: create). 0 or -1. */
static int enter(struct conn *c, const struct daemon *d, const char *name,
                 enum bc_proto_role role, bool create)
{
	if (conn_open(c, d) != 0) {
		return -1;
	}
	if (conn_hello(c, name) != 0) {
		return -1;
	}
	return conn_join(c, "s", role, create);
}

static char base_dir[48];

static void make_dir_name(char *out, size_t n, const char *what)
{
	snprintf(out, n, "%s/%s", base_dir, what);
}

static int ping(struct conn *c)
{
	struct bc_msg m = {.type = BC_MSG_PING};
	m.ping.stamp = 7;
	if (!conn_send(c, &m)) {
		return -1;
	}
	return conn_expect(c, BC_MSG_PONG, 5000) == 1 ? 0 : -1;
}

/* Waits up to ms for an ERROR on c; returns its code, or 0. */
static int expect_error(struct conn *c, int ms)
{
	if (conn_expect(c, BC_MSG_ERROR, ms) != 1) {
		return 0;
	}
	return c->m.error.code;
}

static void a_trickled_message_times_out(void)
{
	struct daemon d;
	struct conn slow, member;
	struct bc_proto_buf b;
	struct bc_msg m = {.type = BC_MSG_PING};
	char dir[64];
	int64_t t0;
	int code = 0;
	make_dir_name(dir, sizeof(dir), "trickle");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(enter(&member, &d, "member", BC_PROTO_ROLE_VIEWER, true) == 0);
	REQUIRE(conn_open(&slow, &d) == 0);
	REQUIRE(conn_hello(&slow, "slow") == 0);
	/* A PING (24 bytes) at a byte a second would take 24 s. */
	m.seq = 1;
	m.ping.stamp = 1;
	bc_proto_buf_init(&b, 0);
	REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	t0 = t_now_ms();
	for (size_t i = 0; i < b.len && code == 0; i++) {
		if (send_raw(&slow, b.data + i, 1) != 0) {
			break;
		}
		code = expect_error(&slow, 1000);
	}
	bc_proto_buf_finish(&b);
	CHECK_EQ_INT(code, -BC_ETIMEOUT);
	CHECK(slow.m.flags & BC_PROTO_FLAG_FATAL);
	CHECK(t_now_ms() - t0 >= (int64_t)BC_SRV_MESSAGE_TIMEOUT_MS - 1000);
	printf("  timed out after %lld ms\n", (long long)(t_now_ms() - t0));
	/* The connection is then closed. */
	CHECK(conn_recv(&slow, 3000) == -1);
	/* A member of a session that said nothing meanwhile is still served. */
	CHECK(ping(&member) == 0);
	conn_close(&slow);
	conn_close(&member);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void an_idle_client_in_no_session_is_dropped(void)
{
	struct daemon d;
	struct conn idle, member;
	char dir[64], cfg[80];
	const char *extra[] = {"--config", cfg, NULL};
	FILE *f;
	int64_t t0;
	make_dir_name(dir, sizeof(dir), "idle");
	make_dir_name(cfg, sizeof(cfg), "idle.json");
	f = fopen(cfg, "w");
	REQUIRE(f);
	fprintf(f, "{\"idle_timeout_ms\": 2000}\n");
	fclose(f);
	REQUIRE(daemon_start_with(&d, dir, extra) == 0);
	REQUIRE(enter(&member, &d, "member", BC_PROTO_ROLE_VIEWER, true) == 0);
	REQUIRE(conn_open(&idle, &d) == 0);
	REQUIRE(conn_hello(&idle, "idle") == 0);
	t0 = t_now_ms();
	CHECK_EQ_INT(expect_error(&idle, 6000), -BC_ETIMEOUT);
	CHECK(t_now_ms() - t0 >= 1500);
	CHECK(conn_recv(&idle, 3000) == -1);
	/* The member was as silent for as long, and stays. */
	CHECK(ping(&member) == 0);
	conn_close(&idle);
	conn_close(&member);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Starts the daemon listening on 127.0.0.1 at a free port too, and returns
 * that port (0 on failure): its stderr goes to a file for the address. */
static int daemon_start_tcp_config(struct daemon *d, const char *dir,
                                   const char *config)
{
	const char *extra[] = {"--listen", "127.0.0.1:0",
	                       config ? "--config" : NULL, config, NULL};
	char log[80];
	int saved = dup(2), fd;
	const char *verbose = getenv("BLOBCAST_TEST_VERBOSE");
	snprintf(log, sizeof(log), "%s.stderr", dir);
	fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
	if (fd < 0 || saved < 0) {
		return 0;
	}
	fflush(stderr);
	dup2(fd, 2);
	close(fd);
	if (!verbose) {
		setenv("BLOBCAST_TEST_VERBOSE", "1", 1);
	}
	fd = daemon_start_with(d, dir, extra);
	if (!verbose) {
		unsetenv("BLOBCAST_TEST_VERBOSE");
	}
	dup2(saved, 2);
	close(saved);
	return fd == 0 ? daemon_log_port(log) : 0;
}

static int daemon_start_tcp(struct daemon *d, const char *dir)
{
	return daemon_start_tcp_config(d, dir, NULL);
}

/* A TCP connection from source address from (127.x.y.z) to port. */
static int tcp_connect(const char *from, int port)
{
	struct sockaddr_in src = {.sin_family = AF_INET};
	struct sockaddr_in dst = {.sin_family = AF_INET};
	int fd = socket(AF_INET, SOCK_STREAM, 0);
	inet_pton(AF_INET, from, &src.sin_addr);
	inet_pton(AF_INET, "127.0.0.1", &dst.sin_addr);
	dst.sin_port = htons((uint16_t)port);
	if (fd < 0 || bind(fd, (struct sockaddr *)&src, sizeof(src)) != 0 ||
	    connect(fd, (struct sockaddr *)&dst, sizeof(dst)) != 0) {
		if (fd >= 0) {
			close(fd);
		}
		return -1;
	}
	return fd;
}

static void a_connection_flood_leaves_room_for_others(void)
{
	enum { FLOOD = 300 };
	static int fds[FLOOD];
	struct daemon d;
	struct conn good;
	char dir[64];
	int port, opened = 0, still_open = 0;
	int64_t t0;
	make_dir_name(dir, sizeof(dir), "flood");
	port = daemon_start_tcp(&d, dir);
	REQUIRE(port > 0);
	/* More silent connections than the daemon has slots, from one
	 * address. */
	for (int i = 0; i < FLOOD; i++) {
		fds[i] = tcp_connect("127.0.0.1", port);
		opened += fds[i] >= 0;
	}
	CHECK(opened > 0);
	t_sleep_ms(500);
	/* Those over the per-address cap were closed at once. */
	for (int i = 0; i < FLOOD; i++) {
		struct pollfd pfd = {.fd = fds[i], .events = POLLIN};
		if (fds[i] >= 0 &&
		    !(poll(&pfd, 1, 0) == 1 &&
		      (pfd.revents & (POLLIN | POLLHUP | POLLERR)))) {
			still_open++;
		}
	}
	printf("  %d of %d silent connections held\n", still_open, opened);
	CHECK(still_open <= 16);
	/* A client from another address gets in and through HELLO at once. */
	memset(&good, 0, sizeof(good));
	t0 = t_now_ms();
	good.fd = tcp_connect("127.0.0.2", port);
	REQUIRE(good.fd >= 0);
	bc_proto_reader_init(&good.r, &(struct bc_proto_reader_opts){
	                                  .side = BC_PROTO_SIDE_CLIENT});
	CHECK(conn_hello(&good, "good") == 0);
	CHECK(t_now_ms() - t0 < 2000);
	conn_close(&good);
	/* So does one over the Unix socket. */
	REQUIRE(conn_open(&good, &d) == 0);
	CHECK(conn_hello(&good, "local") == 0);
	conn_close(&good);
	for (int i = 0; i < FLOOD; i++) {
		if (fds[i] >= 0) {
			close(fds[i]);
		}
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void a_flood_from_many_addresses_leaves_room_for_a_neighbour(void)
{
	enum { ADDRS = 40, PER_ADDR = 16 };
	static int fds[ADDRS * PER_ADDR];
	struct daemon d;
	struct conn good;
	char dir[64], from[32];
	int port, opened = 0;
	int64_t t0;
	make_dir_name(dir, sizeof(dir), "prefix");
	port = daemon_start_tcp(&d, dir);
	REQUIRE(port > 0);
	/* Silent connections from 40 addresses of one /24, more than the
	 * daemon's 256 slots: before admission kept caps per prefix and made
	 * room from the oldest, 57 of 60 legitimate connects were refused. */
	for (int a = 0; a < ADDRS; a++) {
		snprintf(from, sizeof(from), "127.0.0.%d", 10 + a);
		for (int i = 0; i < PER_ADDR; i++) {
			int fd = tcp_connect(from, port);
			fds[a * PER_ADDR + i] = fd;
			opened += fd >= 0;
		}
	}
	CHECK(opened > 0);
	t_sleep_ms(200);
	/* A client of the same prefix, and one of another, get in and
	 * through HELLO at once, a few times over. */
	for (int k = 0; k < 6; k++) {
		memset(&good, 0, sizeof(good));
		t0 = t_now_ms();
		good.fd =
		    tcp_connect(k % 2 ? "127.0.0.200" : "127.0.1.7", port);
		REQUIRE(good.fd >= 0);
		bc_proto_reader_init(&good.r,
		                     &(struct bc_proto_reader_opts){
		                         .side = BC_PROTO_SIDE_CLIENT});
		CHECK(conn_hello(&good, "good") == 0);
		CHECK(t_now_ms() - t0 < 2000);
		conn_close(&good);
	}
	for (int i = 0; i < ADDRS * PER_ADDR; i++) {
		if (fds[i] >= 0) {
			close(fds[i]);
		}
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* A flat union of n spheres, as a scene encoding; ids from first, or all 0
 * (the server assigns them) when first is 0. */
static struct bc_proto_buf big_scene(uint32_t n, bool camera, uint32_t first)
{
	static const float cam[10] = {0, 0, 5, 0, 0, 0, 0, 1, 0, 45};
	static const float t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1};
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, camera ? cam : NULL, n + 1);
	bc_proto_scene_op(&b, BC_OP_UNION, first, 0, 0, n);
	for (uint32_t i = 0; i < n; i++) {
		float r = 0.5f + (float)(i % 100) * 0.001f;
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE,
		                    first ? first + 1 + i : 0, t, q, NULL, 1,
		                    &r);
	}
	return b;
}

static void a_scene_too_big_to_send_is_refused(void)
{
	struct daemon d;
	struct conn a, joiner;
	struct bc_proto_buf b;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REPLACE};
	struct bc_tree *t;
	char dir[64];
	uint64_t order;
	/* A daemon holding scenes to 2 MiB (--max-scene; 64 by default, the
	 * protocol's limit); 39 bytes a sphere: just over it. */
	static const char *const cap[] = {"--max-scene", "2", NULL};
	uint32_t n = (2u << 20) / 39u + 1000u;
	make_dir_name(dir, sizeof(dir), "bigscene");
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(enter(&a, &d, "author", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	order = a.m.scene_state.order;
	t = scene_of(&a);
	REQUIRE(t);
	op.node = bc_tree_lin(t)->node_id[0];
	bc_tree_destroy(t);

	b = big_scene(n, true, 0);
	REQUIRE(b.len > (2u << 20) && b.len < BC_PROTO_MAX_PAYLOAD);
	m.scene_load.scene.ptr = b.data;
	m.scene_load.scene.len = (uint32_t)b.len;
	REQUIRE(conn_send(&a, &m));
	CHECK_EQ_INT(expect_error(&a, 60000), -BC_ELIMIT);
	printf("  %.*s\n", (int)a.m.error.text.len, a.m.error.text.ptr);
	bc_proto_buf_finish(&b);

	/* A structural edit that would grow the scene as far. */
	b = big_scene(n, false, 1u << 24);
	op.subtree.ptr = b.data;
	op.subtree.len = (uint32_t)b.len;
	memset(&m, 0, sizeof(m));
	m.type = BC_MSG_EDIT;
	m.edit.nops = 1;
	m.edit.ops = &op;
	REQUIRE(conn_send(&a, &m));
	CHECK_EQ_INT(expect_error(&a, 60000), -BC_ELIMIT);
	bc_proto_buf_finish(&b);

	/* The author is still served; a joiner gets the unchanged scene, also
	 * after a restart. */
	CHECK(ping(&a) == 0);
	for (int round = 0; round < 2; round++) {
		REQUIRE(enter(&joiner, &d, "joiner", BC_PROTO_ROLE_VIEWER,
		              false) == 0);
		REQUIRE(conn_expect(&joiner, BC_MSG_SCENE_STATE, 5000) == 1);
		CHECK_EQ_INT(joiner.m.scene_state.order, order);
		CHECK(ping(&joiner) == 0);
		conn_close(&joiner);
		if (round == 0) {
			conn_close(&a);
			CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
			REQUIRE(daemon_start_with(&d, dir, cap) == 0);
		}
	}
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* A scene of n spheres of radius 0.05 scattered over [-1, 1]^3 under one
 * union, with a camera: cheap to trace at any size. */
static struct bc_proto_buf scattered(uint32_t n)
{
	static const float cam[10] = {0, 0, 5, 0, 0, 0, 0, 1, 0, 45};
	const float q[4] = {0, 0, 0, 1}, r = 0.05f;
	uint32_t x = 12345u;
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, cam, n + 1);
	bc_proto_scene_op(&b, BC_OP_UNION, 0, 0, 0, n);
	for (uint32_t i = 0; i < n; i++) {
		float t[3];
		for (int k = 0; k < 3; k++) {
			x = x * 1664525u + 1013904223u;
			t[k] = (float)(x >> 8) / (float)(1u << 23) - 1.0f;
		}
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 0, t, q, NULL, 1, &r);
	}
	return b;
}

/* What load_answer and answer_of give for a change applied: no ERROR's
 * code (EINVAL's is 1, which once passed for an answer applied). */
#define APPLIED 1000

/* c's SCENE_LOAD of b: APPLIED when its SCENE_STATE came, else the
 * ERROR's code (0: neither). */
static int load_answer(struct conn *c, const struct bc_proto_buf *b)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	uint32_t seq;
	m.scene_load.scene.ptr = b->data;
	m.scene_load.scene.len = (uint32_t)b->len;
	seq = conn_send(c, &m);
	while (conn_recv(c, 60000) == 1) {
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			return c->m.error.code;
		}
		if (c->m.type == BC_MSG_SCENE_STATE &&
		    c->m.scene_state.author_seq == seq) {
			return APPLIED;
		}
	}
	return 0;
}

/* Sends the SCENE_LOAD of b from c and waits for its SCENE_STATE. */
static void load_and_wait(struct conn *c, const struct bc_proto_buf *b)
{
	REQUIRE(load_answer(c, b) == APPLIED);
}

/* A daemon holding 1 MiB for a client (--client-queue) and a scene of
 * 2 MiB: its SCENE_STATE, one buffer shared by every member, passes the
 * cap alone and still reaches its author and every joiner, two at once
 * too; a joiner that leaves in the middle of it harms nobody; and the cap
 * still holds for a member that stopped reading: a second SCENE_STATE
 * behind the first drops it. */
static void a_scene_past_the_client_queue_reaches_its_members(void)
{
	static const char *const cap[] = {"--client-queue", "1", NULL};
	const uint32_t n = (2u << 20) / 39u;
	struct conn a, j[2], quitter, stuck;
	struct bc_proto_buf b;
	struct daemon d;
	struct bc_tree *t;
	char dir[64];
	uint64_t order;
	int rc;
	make_dir_name(dir, sizeof(dir), "queuecap");
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(enter(&a, &d, "author", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	b = scattered(n);
	REQUIRE(b.len > (2u << 20) - 4096u);
	load_and_wait(&a, &b);
	order = a.m.scene_state.order;
	REQUIRE((t = scene_of(&a)));
	CHECK(bc_tree_prim_count(t) == n);
	bc_tree_destroy(t);

	for (int round = 0; round < 2; round++) {
		/* One that leaves once the scene has begun to come. */
		uint8_t some[4096];
		REQUIRE(enter(&quitter, &d, "quitter", BC_PROTO_ROLE_VIEWER,
		              false) == 0);
		CHECK(recv(quitter.fd, some, sizeof(some), 0) > 0);
		conn_close(&quitter);
		/* Two joining at once. */
		for (int k = 0; k < 2; k++) {
			REQUIRE(conn_open(&j[k], &d) == 0);
			REQUIRE(conn_hello(&j[k], "joiner") == 0);
			REQUIRE(conn_join(&j[k], "s", BC_PROTO_ROLE_VIEWER,
			                  false) == 0);
		}
		for (int k = 0; k < 2; k++) {
			REQUIRE(conn_expect(&j[k], BC_MSG_SCENE_STATE, 60000) ==
			        1);
			CHECK(j[k].m.scene_state.order == order);
			CHECK(j[k].m.scene_state.scene.len + 64u > b.len);
			CHECK(ping(&j[k]) == 0);
			conn_close(&j[k]);
		}
	}

	/* A member that reads nothing: the scene loaded again comes behind
	 * the first, still in its queue, and passes the cap. */
	REQUIRE(enter(&stuck, &d, "stuck", BC_PROTO_ROLE_VIEWER, false) == 0);
	t_sleep_ms(200); /* its scene is queued */
	load_and_wait(&a, &b);
	CHECK(a.m.scene_state.order > order);
	CHECK(ping(&a) == 0);
	{
		int states = 0;
		while ((rc = conn_recv(&stuck, 30000)) == 1) {
			states += stuck.m.type == BC_MSG_SCENE_STATE;
		}
		CHECK_EQ_INT(rc, -1); /* closed, not a timeout */
		CHECK(states <= 1);
	}
	conn_close(&stuck);
	bc_proto_buf_finish(&b);
	CHECK(ping(&a) == 0);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* k spheres of radius 0.4 at (x, 0, 0), under a union when k > 1: a
 * subtree to INSERT, with ids from id up. */
static struct bc_proto_buf spheres_at(uint32_t k, float x, uint32_t id)
{
	const float t[3] = {x, 0, 0}, q[4] = {0, 0, 0, 1}, r = 0.4f;
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, k > 1 ? k + 1 : 1);
	if (k > 1) {
		bc_proto_scene_op(&b, BC_OP_UNION, id++, 0, 0, k);
	}
	for (uint32_t i = 0; i < k; i++) {
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id++, t, q, NULL, 1,
		                    &r);
	}
	return b;
}

/* Sends one EDIT of op; returns its seq. */
static uint32_t send_edit(struct conn *c, const struct bc_proto_edit_op *op)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	m.edit.nops = 1;
	m.edit.ops = op;
	return conn_send(c, &m);
}

/* The answer to c's EDIT or SCENE_LOAD seq: the ERROR's code, or APPLIED
 * for its EDIT_APPLIED or SCENE_STATE. */
static int answer_of(struct conn *c, uint32_t seq)
{
	for (;;) {
		if (conn_recv(c, 60000) != 1) {
			return 0;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			return c->m.error.code;
		}
		if ((c->m.type == BC_MSG_EDIT_APPLIED &&
		     c->m.edit_applied.author_seq == seq) ||
		    (c->m.type == BC_MSG_SCENE_STATE &&
		     c->m.scene_state.author_seq == seq)) {
			return APPLIED;
		}
	}
}

static int edit_answer(struct conn *c, const struct bc_proto_edit_op *op)
{
	return answer_of(c, send_edit(c, op));
}

/* The raw pixels of a SNAPSHOT of c's view into px (n bytes); false when
 * none came or its size differs. */
static bool snapshot_raw(struct conn *c, uint8_t *px, size_t n)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	uint32_t seq;
	m.snapshot.encoding = BC_PROTO_ENC_RAW;
	seq = conn_send(c, &m);
	for (;;) {
		if (conn_recv(c, 60000) != 1) {
			return false;
		}
		if (c->m.type == BC_MSG_FRAME && c->m.seq == seq &&
		    (c->m.flags & BC_PROTO_FLAG_SNAPSHOT)) {
			break;
		}
	}
	if (c->m.frame.nrects != 1 || c->m.frame.rects[0].data.len != n) {
		return false;
	}
	memcpy(px, c->m.frame.rects[0].data.ptr, n);
	return true;
}

/* A structural edit reaches the render copy before the session has applied
 * and journaled it (the two run at once); one the session then refuses
 * is undone on the copy too: the pictures after it are those before it,
 * bit for bit, and the session's next edits are drawn. Then the same
 * edits while another member's snapshot holds the copy, so that their
 * verdicts come while they still wait for it (the refused one is never
 * applied there). The scene has over BC_SRV_HEAVY_NODES nodes (its
 * structural edits apply on a task) and fits --max-scene 1 with a little
 * room. */
static void a_refused_structural_edit_is_not_drawn(void)
{
	enum { SIZE = 48 };
	static const char *const cap[] = {"--max-scene", "1", NULL};
	static uint8_t before[SIZE * SIZE * 4], after[SIZE * SIZE * 4],
	    with[SIZE * SIZE * 4];
	const uint32_t n = ((1u << 20) - 4096u) / 39u;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT};
	struct bc_proto_edit_op rm = {.kind = BC_PROTO_EDIT_REMOVE};
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	struct bc_msg snap = {.type = BC_MSG_SNAPSHOT};
	const struct bc_lin *l;
	struct bc_proto_buf b, sub, big;
	struct bc_tree *t;
	struct daemon d;
	struct conn a, b2;
	uint32_t seq, seq2;
	char dir[64];
	REQUIRE(n + 1 >= BC_SRV_HEAVY_NODES);
	make_dir_name(dir, sizeof(dir), "refused");
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(enter(&a, &d, "author", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	b = scattered(n);
	m.scene_load.scene.ptr = b.data;
	m.scene_load.scene.len = (uint32_t)b.len;
	REQUIRE(conn_send(&a, &m));
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 60000) == 1);
	bc_proto_buf_finish(&b);
	REQUIRE((t = scene_of(&a)));
	REQUIRE(bc_tree_prim_count(t) == n);
	l = bc_tree_lin(t);
	op.node = l->node_id[l->count - 1]; /* the root union */
	op.position = n;
	bc_tree_destroy(t);
	REQUIRE(conn_view(&a, SIZE, SIZE, BC_PROTO_ENC_RAW));
	REQUIRE(snapshot_raw(&a, before, sizeof(before)));

	/* 200 spheres beside the cloud: 7 800 bytes more than the cap. */
	big = spheres_at(200, 1.3f, 1u << 24);
	op.subtree.ptr = big.data;
	op.subtree.len = (uint32_t)big.len;
	CHECK_EQ_INT(edit_answer(&a, &op), -BC_ELIMIT);
	REQUIRE(snapshot_raw(&a, after, sizeof(after)));
	CHECK(memcmp(before, after, sizeof(before)) == 0);

	/* One that fails on the copy as on the session's tree (no such
	 * parent): nothing changes, and the copy still follows. */
	sub = spheres_at(1, 1.3f, 1u << 24);
	op.subtree.ptr = sub.data;
	op.subtree.len = (uint32_t)sub.len;
	op.node += 1000000u;
	op.position = 0;
	CHECK_EQ_INT(edit_answer(&a, &op), -BC_ENONODE);
	REQUIRE(snapshot_raw(&a, after, sizeof(after)));
	CHECK(memcmp(before, after, sizeof(before)) == 0);

	/* One sphere fits, stands and is drawn; its removal is drawn. */
	op.node -= 1000000u;
	op.position = n;
	CHECK_EQ_INT(edit_answer(&a, &op), APPLIED);
	REQUIRE(snapshot_raw(&a, with, sizeof(with)));
	CHECK(memcmp(before, with, sizeof(before)) != 0);
	rm.node = 1u << 24;
	CHECK_EQ_INT(edit_answer(&a, &rm), APPLIED);
	REQUIRE(snapshot_raw(&a, after, sizeof(after)));
	CHECK(memcmp(before, after, sizeof(before)) == 0);

	/* The same two edits while another member's big snapshot holds the
	 * render copy: their verdicts come before the copy takes them (the
	 * refused one is never applied there), or after, depending on the
	 * timing; either way the picture is the one with the sphere. */
	REQUIRE(enter(&b2, &d, "viewer", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_view(&b2, 1024, 768, BC_PROTO_ENC_PNG));
	snap.snapshot.encoding = BC_PROTO_ENC_RAW;
	REQUIRE(conn_send(&b2, &snap));
	t_sleep_ms(50); /* its job starts: the edits' copies wait */
	op.subtree.ptr = big.data;
	op.subtree.len = (uint32_t)big.len;
	seq = send_edit(&a, &op);
	op.subtree.ptr = sub.data;
	op.subtree.len = (uint32_t)sub.len;
	seq2 = send_edit(&a, &op);
	CHECK_EQ_INT(answer_of(&a, seq), -BC_ELIMIT);
	CHECK_EQ_INT(answer_of(&a, seq2), APPLIED);
	REQUIRE(snapshot_raw(&a, after, sizeof(after)));
	CHECK(memcmp(with, after, sizeof(with)) == 0);
	bc_proto_buf_finish(&sub);
	bc_proto_buf_finish(&big);
	conn_close(&b2);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Sends n SNAPSHOTs in one write (so the daemon reads them in one turn). */
static void send_snapshots(struct conn *c, uint32_t n)
{
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
		m.seq = ++c->seq;
		m.snapshot.encoding = BC_PROTO_ENC_PNG;
		REQUIRE(bc_proto_encode(&b, &m, NULL) == 0);
	}
	REQUIRE(send_raw(c, b.data, b.len) == 0);
	bc_proto_buf_finish(&b);
}

/* A member of session name (created when create) with a size x size
 * view. */
static void member(struct conn *c, const struct daemon *d, const char *name,
                   bool create, uint16_t size)
{
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello(c, name) == 0);
	REQUIRE(conn_join(c, name, BC_PROTO_ROLE_EDITOR, create) == 0);
	REQUIRE(conn_view(c, size, size, BC_PROTO_ENC_PNG));
}

/* Takes what c has received so far (without waiting): counts snapshot
 * answers and EBUSY errors. */
static void drain(struct conn *c, int wait_ms, uint32_t *snaps, uint32_t *busy)
{
	while (conn_recv(c, wait_ms) == 1) {
		if (c->m.type == BC_MSG_FRAME &&
		    (c->m.flags & BC_PROTO_FLAG_SNAPSHOT)) {
			(*snaps)++;
		} else if (c->m.type == BC_MSG_ERROR &&
		           c->m.error.code == -BC_EBUSY) {
			(*busy)++;
		} else if (c->m.type == BC_MSG_ERROR) {
			/* Not what these tests expect: say which. */
			printf("  unexpected ERROR %s (seq %u): %.*s\n",
			       bc_err_name(-(int)c->m.error.code), c->m.seq,
			       (int)c->m.error.text.len, c->m.error.text.ptr);
		}
	}
}

static void a_snapshot_larger_than_the_queue_arrives(void)
{
	struct daemon d;
	struct conn c;
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	char dir[64];
	uint32_t seq;
	bool got = false;
	make_dir_name(dir, sizeof(dir), "bigsnap");
	REQUIRE(daemon_start(&d, dir) == 0);
	/* 2048^2 raw with depth and ids: 48 MiB, over the 32 MiB queue
	 * but within the protocol's 64 MiB. */
	member(&c, &d, "s", true, 2048);
	m.snapshot.encoding = BC_PROTO_ENC_RAW;
	m.snapshot.planes = BC_PROTO_PLANE_DEPTH | BC_PROTO_PLANE_IDS;
	REQUIRE((seq = conn_send(&c, &m)));
	while (!got && conn_recv(&c, 120000) == 1) {
		CHECK(c.m.type != BC_MSG_ERROR);
		got = c.m.type == BC_MSG_FRAME && c.m.seq == seq;
	}
	CHECK(got);
	if (got) {
		CHECK_EQ_INT(c.m.frame.nrects, 3);
		CHECK(c.m.frame.rects[0].data.len == 2048u * 2048u * 4u);
	}
	/* Still connected. */
	CHECK(ping(&c) == 0);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void a_client_queues_a_bounded_number_of_requests(void)
{
	struct daemon d;
	struct conn c;
	char dir[64];
	uint32_t snaps = 0, busy = 0, sent = BC_SRV_MAX_CLIENT_REQUESTS + 12u;
	int64_t end;
	make_dir_name(dir, sizeof(dir), "requests");
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&c, &d, "s", true, 512);
	send_snapshots(&c, sent);
	end = t_now_ms() + 120000;
	while (snaps + busy < sent && t_now_ms() < end) {
		drain(&c, 1000, &snaps, &busy);
	}
	/* All arrive in one read: the first BC_SRV_MAX_CLIENT_REQUESTS are
	 * queued, the rest refused at once. */
	CHECK_EQ_INT(snaps, BC_SRV_MAX_CLIENT_REQUESTS);
	CHECK_EQ_INT(busy, sent - BC_SRV_MAX_CLIENT_REQUESTS);
	/* Once answered, the client may ask again. */
	send_snapshots(&c, 1);
	snaps = busy = 0;
	end = t_now_ms() + 60000;
	while (snaps + busy < 1 && t_now_ms() < end) {
		drain(&c, 1000, &snaps, &busy);
	}
	CHECK_EQ_INT(snaps, 1);
	CHECK_EQ_INT(busy, 0);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void the_jobs_of_a_client_that_left_are_dropped(void)
{
	struct daemon d;
	struct conn a, b;
	/* Static: a test that stops at a REQUIRE leaves daemon_log_path
	 * pointing here for the next one. */
	static char log[80];
	char dir[64];
	uint32_t snaps = 0, busy = 0;
	int64_t end;
	make_dir_name(dir, sizeof(dir), "gone");
	snprintf(log, sizeof(log), "%s.log", dir);
	daemon_log_path = log;
	REQUIRE(daemon_start(&d, dir) == 0);
	daemon_log_path = NULL;
	member(&a, &d, "s", true, 2048);
	send_snapshots(&a, BC_SRV_MAX_CLIENT_REQUESTS);
	t_sleep_ms(50);
	conn_close(&a);
	/* The first snapshot is rendering; the others are dropped, and a
	 * member of the same session (whose commands run in order) is
	 * answered after that one render, not after all of them. */
	member(&b, &d, "s", false, 64);
	send_snapshots(&b, 1);
	end = t_now_ms() + 120000;
	while (snaps < 1 && t_now_ms() < end) {
		drain(&b, 1000, &snaps, &busy);
	}
	CHECK_EQ_INT(snaps, 1);
	CHECK(daemon_log_count(log, "queued render jobs of clients that left") >
	      0);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void sessions_take_turns_on_the_render_thread(void)
{
	struct daemon d;
	struct conn big, small;
	char dir[64];
	uint32_t big_snaps = 0, small_snaps = 0, busy = 0;
	int64_t end;
	make_dir_name(dir, sizeof(dir), "turns");
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&big, &d, "big", true, 2048);
	member(&small, &d, "small", true, 64);
	/* Both views' first frames are out of the way. */
	REQUIRE(conn_expect(&big, BC_MSG_FRAME, 60000) == 1);
	REQUIRE(conn_expect(&small, BC_MSG_FRAME, 60000) == 1);
	send_snapshots(&big, BC_SRV_MAX_CLIENT_REQUESTS);
	t_sleep_ms(20);
	send_snapshots(&small, 1);
	end = t_now_ms() + 120000;
	while (small_snaps < 1 && t_now_ms() < end) {
		drain(&small, 100, &small_snaps, &busy);
	}
	REQUIRE(small_snaps == 1);
	drain(&big, 0, &big_snaps, &busy);
	/* In one queue the small session would wait for all eight large
	 * snapshots; in turns, for the one running (and at most the one
	 * after it when it came in between two). */
	CHECK(big_snaps <= 2);
	printf("  large snapshots answered before the small one: %u of %u\n",
	       big_snaps, BC_SRV_MAX_CLIENT_REQUESTS);
	end = t_now_ms() + 120000;
	while (big_snaps < BC_SRV_MAX_CLIENT_REQUESTS && t_now_ms() < end) {
		drain(&big, 1000, &big_snaps, &busy);
	}
	CHECK_EQ_INT(big_snaps, BC_SRV_MAX_CLIENT_REQUESTS);
	CHECK_EQ_INT(busy, 0);
	conn_close(&big);
	conn_close(&small);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* HELLO over TCP to port with a token. */
static void tcp_hello(struct conn *c, int port, const char *token)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	memset(c, 0, sizeof(*c));
	c->fd = tcp_connect("127.0.0.1", port);
	REQUIRE(c->fd >= 0);
	bc_proto_reader_init(&c->r, &(struct bc_proto_reader_opts){
	                                .side = BC_PROTO_SIDE_CLIENT});
	m.hello.version_min = m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.client_name.ptr = token;
	m.hello.client_name.len = (uint32_t)strlen(token);
	m.hello.token.ptr = token;
	m.hello.token.len = (uint32_t)strlen(token);
	REQUIRE(conn_send(c, &m));
	REQUIRE(conn_expect(c, BC_MSG_WELCOME, 5000) == 1);
}

/* Sends a session request of type t and returns the answer: 0 for
 * SESSION_INFO or OK, else the ERROR's code (-1: none). */
static int session_request(struct conn *c, enum bc_msg_type t, const char *name,
                           enum bc_proto_role role)
{
	struct bc_msg m = {.type = t};
	uint32_t seq;
	if (t == BC_MSG_SESSION_DELETE) {
		m.session_delete.name.ptr = name;
		m.session_delete.name.len = (uint32_t)strlen(name);
	} else {
		m.session.role = role;
		m.session.name.ptr = name;
		m.session.name.len = (uint32_t)strlen(name);
	}
	seq = conn_send(c, &m);
	while (conn_recv(c, 10000) == 1) {
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			return c->m.error.code;
		}
		if (c->m.type == BC_MSG_SESSION_INFO ||
		    (c->m.type == BC_MSG_OK && c->m.seq == seq)) {
			return 0;
		}
	}
	return -1;
}

static void leave(struct conn *c)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_LEAVE};
	uint32_t seq = conn_send(c, &m);
	while (conn_recv(c, 10000) == 1) {
		if (c->m.type == BC_MSG_OK && c->m.seq == seq) {
			return;
		}
	}
	CHECK(0 && "no OK for SESSION_LEAVE");
}

static void a_viewer_token_cannot_create_or_delete_sessions(void)
{
	struct daemon d;
	struct conn viewer, editor;
	char dir[64], cfg[80];
	FILE *f;
	int port;
	make_dir_name(dir, sizeof(dir), "tokens");
	snprintf(cfg, sizeof(cfg), "%s.json", dir);
	REQUIRE((f = fopen(cfg, "w")));
	fputs("{\"tokens\": [{\"token\": \"ed\", \"role\": \"editor\"}, "
	      "{\"token\": \"vw\", \"role\": \"viewer\"}]}",
	      f);
	fclose(f);
	port = daemon_start_tcp_config(&d, dir, cfg);
	REQUIRE(port > 0);
	tcp_hello(&viewer, port, "vw");
	CHECK_EQ_INT(session_request(&viewer, BC_MSG_SESSION_CREATE, "mine",
	                             BC_PROTO_ROLE_VIEWER),
	             -BC_EPERM);
	CHECK_EQ_INT(
	    session_request(&viewer, BC_MSG_SESSION_DELETE, "default", 0),
	    -BC_EPERM);
	CHECK_EQ_INT(session_request(&viewer, BC_MSG_SESSION_JOIN, "mine",
	                             BC_PROTO_ROLE_VIEWER),
	             -BC_ENOSESSION);
	CHECK_EQ_INT(session_request(&viewer, BC_MSG_SESSION_JOIN, "default",
	                             BC_PROTO_ROLE_VIEWER),
	             0);
	tcp_hello(&editor, port, "ed");
	CHECK_EQ_INT(session_request(&editor, BC_MSG_SESSION_CREATE, "mine",
	                             BC_PROTO_ROLE_VIEWER),
	             0);
	conn_close(&viewer);
	conn_close(&editor);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void idle_sessions_make_room_and_load_again(void)
{
	struct daemon d;
	struct conn a;
	struct bc_tree *t;
	char dir[64], name[16];
	uint64_t order;
	make_dir_name(dir, sizeof(dir), "unload");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0);
	REQUIRE(conn_hello(&a, "a") == 0);
	REQUIRE(conn_join(&a, "s1", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	REQUIRE((t = scene_of(&a)));
	REQUIRE(conn_move(&a,
	                  bc_tree_lin(t)->node_id[bc_tree_lin(t)->prim_slot[0]],
	                  0.25f, 0, 0, false));
	bc_tree_destroy(t);
	REQUIRE(conn_expect(&a, BC_MSG_EDIT_APPLIED, 10000) == 1);
	order = a.m.edit_applied.order;
	leave(&a);
	/* default and s1, then sessions enough to fill the table twice
	 * over: each creation past the limit unloads the session without
	 * members for longest (default, then s1). */
	for (uint32_t i = 2; i <= 2 * BC_SRV_MAX_SESSIONS; i++) {
		snprintf(name, sizeof(name), "s%u", i);
		REQUIRE(session_request(&a, BC_MSG_SESSION_CREATE, name,
		                        BC_PROTO_ROLE_EDITOR) == 0);
		leave(&a);
	}
	/* SESSION_LIST names all of them, by name: 64 loaded, the others on
	 * disk with what was known when they unloaded. */
	{
		struct bc_msg m = {.type = BC_MSG_SESSION_LIST};
		const struct bc_msg_sessions *l = &a.m.sessions;
		uint32_t loaded = 0, known = 0;
		bool s1_seen = false;
		REQUIRE(conn_send(&a, &m));
		REQUIRE(conn_expect(&a, BC_MSG_SESSIONS, 5000) == 1);
		CHECK_EQ_INT(l->nsessions, 2 * BC_SRV_MAX_SESSIONS + 1);
		for (uint32_t i = 0; i < l->nsessions; i++) {
			const struct bc_proto_session_entry *e =
			    &l->sessions[i];
			loaded += (e->flags & BC_PROTO_SESSION_LOADED) != 0;
			known += (e->flags & BC_PROTO_SESSION_KNOWN) != 0;
			if (i > 0) {
				const struct bc_proto_session_entry *p = e - 1;
				size_t n = p->name.len < e->name.len
				               ? p->name.len
				               : e->name.len;
				int cmp = memcmp(p->name.ptr, e->name.ptr, n);
				CHECK(cmp < 0 ||
				      (cmp == 0 && p->name.len < e->name.len));
			}
			if (e->name.len == 2 &&
			    memcmp(e->name.ptr, "s1", 2) == 0) {
				s1_seen = true;
				CHECK(!(e->flags & BC_PROTO_SESSION_LOADED));
				CHECK(e->flags & BC_PROTO_SESSION_KNOWN);
				CHECK_EQ_INT(e->order, order);
				CHECK(e->prims > 0 && e->last_edit_ms > 0);
			}
		}
		CHECK_EQ_INT(loaded, BC_SRV_MAX_SESSIONS);
		CHECK_EQ_INT(known, 2 * BC_SRV_MAX_SESSIONS + 1);
		CHECK(s1_seen);
	}
	/* s1 loads again as it was left. */
	REQUIRE(conn_join(&a, "s1", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	CHECK_EQ_INT(a.m.scene_state.order, order);
	leave(&a);
	CHECK_EQ_INT(session_request(&a, BC_MSG_SESSION_CREATE, "s1",
	                             BC_PROTO_ROLE_EDITOR),
	             -BC_EEXIST);
	CHECK_EQ_INT(session_request(&a, BC_MSG_SESSION_JOIN, "default",
	                             BC_PROTO_ROLE_VIEWER),
	             0);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void a_deleted_session_is_gone_for_good(void)
{
	struct daemon d;
	struct conn a, b, c;
	char dir[64], path[128];
	struct stat sb;
	make_dir_name(dir, sizeof(dir), "delete");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "alice") == 0);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "bob") == 0);
	REQUIRE(conn_open(&c, &d) == 0 && conn_hello(&c, "carol") == 0);
	REQUIRE(conn_join(&a, "doomed", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_join(&b, "doomed", BC_PROTO_ROLE_VIEWER, false) == 0);
	CHECK_EQ_INT(session_request(&c, BC_MSG_SESSION_DELETE, "doomed", 0),
	             0);
	/* Both members hear it (seq 0) and are back in READY. */
	REQUIRE(conn_expect(&b, BC_MSG_ERROR, 5000) == 1);
	CHECK_EQ_INT(b.m.error.code, -BC_ENOSESSION);
	CHECK_EQ_INT(b.m.seq, 0);
	printf("  %.*s\n", (int)b.m.error.text.len, b.m.error.text.ptr);
	REQUIRE(conn_expect(&a, BC_MSG_ERROR, 5000) == 1);
	CHECK_EQ_INT(a.m.seq, 0);
	CHECK_EQ_INT(session_request(&b, BC_MSG_SESSION_JOIN, "doomed",
	                             BC_PROTO_ROLE_VIEWER),
	             -BC_ENOSESSION);
	CHECK_EQ_INT(session_request(&c, BC_MSG_SESSION_DELETE, "doomed", 0),
	             -BC_ENOSESSION);
	/* The files are kept aside, out of the sessions the daemon loads. */
	snprintf(path, sizeof(path), "%s/sessions/doomed", dir);
	CHECK(stat(path, &sb) != 0);
	snprintf(path, sizeof(path), "%s/sessions/.deleted", dir);
	CHECK(stat(path, &sb) == 0 && S_ISDIR(sb.st_mode));
	/* The name starts anew, also after a restart. */
	CHECK_EQ_INT(session_request(&a, BC_MSG_SESSION_CREATE, "doomed",
	                             BC_PROTO_ROLE_EDITOR),
	             0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	CHECK_EQ_INT(a.m.scene_state.order, 0);
	conn_close(&a);
	conn_close(&b);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "alice") == 0);
	REQUIRE(conn_join(&a, "doomed", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	CHECK_EQ_INT(a.m.scene_state.order, 0);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void a_large_load_does_not_hold_other_sessions(void)
{
	struct daemon d;
	struct conn a, b;
	struct bc_proto_buf buf;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	char dir[64];
	int64_t t0, worst = 0, took;
	uint32_t seq, pings = 0;
	bool loaded = false;
	make_dir_name(dir, sizeof(dir), "bigload");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "loader") == 0);
	REQUIRE(conn_join(&a, "big", BC_PROTO_ROLE_EDITOR, true) == 0);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "other") == 0);
	REQUIRE(conn_join(&b, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	buf = big_scene(400000, true, 0);
	m.scene_load.scene.ptr = buf.data;
	m.scene_load.scene.len = (uint32_t)buf.len;
	t0 = t_now_ms();
	REQUIRE((seq = conn_send(&a, &m)));
	bc_proto_buf_finish(&buf);
	/* The other session's client is answered at once all along. */
	while (!loaded && t_now_ms() - t0 < 300000) {
		int64_t p0 = t_now_ms();
		REQUIRE(ping(&b) == 0);
		if (t_now_ms() - p0 > worst) {
			worst = t_now_ms() - p0;
		}
		pings++;
		while (conn_recv(&a, 0) == 1) {
			if (a.m.type == BC_MSG_SCENE_STATE &&
			    a.m.scene_state.author_seq == seq) {
				/* Encoded off the loop and sent as is: the
				 * whole scene. */
				struct bc_tree *t = scene_of(&a);
				CHECK(t && bc_tree_node_count(t) > 400000u);
				bc_tree_destroy(t);
				loaded = true;
			}
			CHECK(a.m.type != BC_MSG_ERROR);
		}
		t_sleep_ms(10);
	}
	took = t_now_ms() - t0;
	printf("  400000-node load: %lld ms; %u pings meanwhile, slowest "
	       "%lld ms\n",
	       (long long)took, pings, (long long)worst);
	CHECK(loaded);
	CHECK(worst < 1000);
	conn_close(&a);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Root union (id) of two unions of g1 and g2 spheres: 3 + g1 + g2 nodes,
 * ids id.. in order (the first group's union is id + 1). */
static struct bc_proto_buf two_groups(uint32_t g1, uint32_t g2, uint32_t id)
{
	const float t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, r = 0.4f;
	const uint32_t g[2] = {g1, g2};
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 3 + g1 + g2);
	bc_proto_scene_op(&b, BC_OP_UNION, id++, 0, 0, 2);
	for (int k = 0; k < 2; k++) {
		bc_proto_scene_op(&b, BC_OP_UNION, id++, 0, 0, g[k]);
		for (uint32_t i = 0; i < g[k]; i++) {
			bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id++, t, q,
			                    NULL, 1, &r);
		}
	}
	return b;
}

/* Whether the ERROR c received last holds text. */
static bool error_says(const struct conn *c, const char *text)
{
	char buf[BC_PROTO_MAX_ERROR_TEXT + 1];
	memcpy(buf, c->m.error.text.ptr, c->m.error.text.len);
	buf[c->m.error.text.len] = '\0';
	return strstr(buf, text) != NULL;
}

/* Nodes of the scene c received last (SCENE_STATE). */
static uint32_t nodes_of(const struct conn *c)
{
	struct bc_tree *t = scene_of(c);
	uint32_t n = t ? bc_tree_node_count(t) : 0;
	bc_tree_destroy(t);
	return n;
}

static int undo_answer(struct conn *c)
{
	struct bc_msg m = {.type = BC_MSG_UNDO};
	return answer_of(c, conn_send(c, &m));
}

/* --scene-memory 1: 1 MiB at 700 bytes a node, 1497 nodes in all loaded
 * sessions. A load, an INSERT and an UNDO that would pass it are refused
 * (ELIMIT) while the sessions holding the nodes are in use, and nothing
 * is unloaded for them; once those sessions have no members they are
 * unloaded to make room, and a JOIN that loads a session is refused when
 * no room can be made. A restart restores sessions up to the cap; the
 * rest load when joined. */
static void the_scene_memory_cap_holds_across_sessions(void)
{
	static const char *const cap[] = {"--scene-memory", "1", NULL};
	struct bc_proto_edit_op ins = {.kind = BC_PROTO_EDIT_INSERT};
	struct bc_proto_edit_op rm = {.kind = BC_PROTO_EDIT_REMOVE};
	struct bc_proto_edit_op name = {.kind = BC_PROTO_EDIT_NAME};
	struct bc_proto_buf ga, gb, sub, one;
	struct daemon d;
	struct conn a, b;
	/* Static: a test that stops at a REQUIRE leaves daemon_log_path
	 * pointing here for the next one. */
	static char log[80];
	char dir[64];
	make_dir_name(dir, sizeof(dir), "room");
	snprintf(log, sizeof(log), "%s.log", dir);
	daemon_log_path = log;
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "b") == 0);
	/* a: 703 nodes; b: 801 do not fit beside them. */
	REQUIRE(conn_join(&a, "a", BC_PROTO_ROLE_EDITOR, true) == 0);
	ga = two_groups(400, 300, 10000);
	CHECK_EQ_INT(load_answer(&a, &ga), APPLIED);
	REQUIRE(conn_join(&b, "b", BC_PROTO_ROLE_EDITOR, true) == 0);
	one = spheres_at(10, 1, 5000);
	CHECK_EQ_INT(load_answer(&b, &one), APPLIED);
	bc_proto_buf_finish(&one);
	gb = two_groups(400, 398, 20000);
	CHECK_EQ_INT(load_answer(&b, &gb), -BC_ELIMIT);
	CHECK(error_says(&b, "--scene-memory"));
	CHECK_EQ_INT(daemon_log_count(log, "unloaded (its memory"), 0);
	/* An INSERT of 791 nodes neither; one of a sphere does. */
	sub = spheres_at(790, 0, 0);
	one = spheres_at(1, 1, 30000);
	ins.node = 5000;
	ins.subtree.ptr = sub.data;
	ins.subtree.len = (uint32_t)sub.len;
	CHECK_EQ_INT(edit_answer(&b, &ins), -BC_ELIMIT);
	ins.subtree.ptr = one.data;
	ins.subtree.len = (uint32_t)one.len;
	CHECK_EQ_INT(edit_answer(&b, &ins), APPLIED);
	/* Once a is left, it goes for b's load (default before it). A
	 * session saving its snapshot is in use, and the snapshot after a's
	 * load runs on a task, which an fsync on a busy disk can stretch to
	 * seconds: an edit of a waits for it, so a is idle once answered. */
	name.node = 10000;
	name.name.ptr = "a";
	name.name.len = 1;
	CHECK_EQ_INT(edit_answer(&a, &name), APPLIED);
	leave(&a);
	CHECK_EQ_INT(load_answer(&b, &gb), APPLIED);
	CHECK_EQ_INT(daemon_log_count(log, "session a unloaded (its memory"),
	             1);
	/* a cannot load beside b's 801 nodes ... */
	CHECK_EQ_INT(
	    session_request(&a, BC_MSG_SESSION_JOIN, "a", BC_PROTO_ROLE_EDITOR),
	    -BC_ELIMIT);
	/* ... until b takes away its first group (401 nodes) */
	rm.node = 20001;
	CHECK_EQ_INT(edit_answer(&b, &rm), APPLIED);
	REQUIRE(conn_join(&a, "a", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 10000) == 1);
	CHECK_EQ_INT(nodes_of(&a), 703);
	/* and b's UNDO, which would put them back, waits for a to go. */
	CHECK_EQ_INT(undo_answer(&b), -BC_ELIMIT);
	leave(&a);
	CHECK_EQ_INT(undo_answer(&b), APPLIED);
	CHECK_EQ_INT(daemon_log_count(log, "session a unloaded (its memory"),
	             2);
	conn_close(&a);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	/* A restart restores a (703 nodes), not b (801) beside it; b loads
	 * when joined, a unloaded for it. */
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	daemon_log_path = NULL;
	CHECK_EQ_INT(daemon_log_count(log, "stays on disk until joined"), 1);
	CHECK_EQ_INT(daemon_log_count(log, "session b stays on disk"), 1);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "b") == 0);
	REQUIRE(conn_join(&b, "b", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&b, BC_MSG_SCENE_STATE, 10000) == 1);
	CHECK_EQ_INT(nodes_of(&b), 801);
	CHECK_EQ_INT(daemon_log_count(log, "session a unloaded (its memory"),
	             1);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_proto_buf_finish(&ga);
	bc_proto_buf_finish(&gb);
	bc_proto_buf_finish(&sub);
	bc_proto_buf_finish(&one);
}

/* Whether SESSION_LIST (sent by c) lists session name loaded, without
 * members, with prims primitives. */
static bool listed_memberless(struct conn *c, const char *name, uint32_t prims)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_LIST};
	const struct bc_msg_sessions *l = &c->m.sessions;
	if (!conn_send(c, &m) || conn_expect(c, BC_MSG_SESSIONS, 5000) != 1) {
		return false;
	}
	for (uint32_t i = 0; i < l->nsessions; i++) {
		const struct bc_proto_session_entry *e = &l->sessions[i];
		if (e->name.len == strlen(name) &&
		    memcmp(e->name.ptr, name, e->name.len) == 0) {
			return (e->flags & BC_PROTO_SESSION_LOADED) &&
			       e->members == 0 && e->prims == prims;
		}
	}
	return false;
}

/* A message sent but for its last byte (send_last sends it): however big,
 * the daemon then has it whole at once. */
struct held_msg {
	struct bc_proto_buf b;
	uint32_t seq;
};

static void send_but_last(struct conn *c, struct bc_msg *m, struct held_msg *h)
{
	h->seq = m->seq = ++c->seq;
	bc_proto_buf_init(&h->b, 0);
	REQUIRE(bc_proto_encode(&h->b, m, NULL) == 0);
	REQUIRE(send_raw(c, h->b.data, h->b.len - 1) == 0);
}

static void send_last(struct conn *c, struct held_msg *h)
{
	REQUIRE(send_raw(c, h->b.data + h->b.len - 1, 1) == 0);
	bc_proto_buf_finish(&h->b);
}

/* c loads b into its session and leaves it at once (both sent before any
 * answer is read) while w holds a message but for its last byte; once
 * o (a third client) sees the session loaded without members, w's last
 * byte goes. The snapshot of the load runs on a task then, which keeps
 * the session busy (not unloadable) for a while: w's message comes in
 * that while unless the snapshot is quicker than SESSION_LIST's round
 * trip. c's answers are read. */
static void load_leave_send(struct conn *c, const char *name,
                            const struct bc_proto_buf *b, uint32_t prims,
                            struct conn *o, struct conn *w, struct held_msg *h)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	struct bc_msg l = {.type = BC_MSG_SESSION_LEAVE};
	int64_t end = t_now_ms() + 30000;
	uint32_t seq;
	m.scene_load.scene.ptr = b->data;
	m.scene_load.scene.len = (uint32_t)b->len;
	REQUIRE(conn_send(c, &m));
	REQUIRE((seq = conn_send(c, &l)));
	while (!listed_memberless(o, name, prims) && t_now_ms() < end) {
	}
	CHECK(t_now_ms() < end);
	send_last(w, h);
	while (conn_recv(c, 30000) == 1) {
		if (c->m.type == BC_MSG_OK && c->m.seq == seq) {
			return;
		}
	}
	CHECK(0 && "no OK for SESSION_LEAVE");
}

/* --scene-memory 100: 149 796 nodes. Session a is loaded with 100 001
 * nodes and left at once; b's load of 60 001 then needs a's room. Where
 * it comes while a's snapshot runs, it waits for that work to end and
 * takes the room then (a unloaded), where it was refused with ELIMIT.
 * Then the same for an INSERT: session c takes a's place, and b's INSERT
 * of 60 000 spheres needs c's room; for an UNDO that puts them back after
 * b removed them, with session e's room; and for a JOIN that loads b's
 * session from disk, with f's. The daemon's log says when a request
 * waited (the test prints how many did: the snapshot may be quicker than
 * a round trip); the answer is the same either way. */
static void a_change_waits_for_the_room_a_snapshot_holds(void)
{
	static const char *const cap[] = {"--scene-memory", "100", NULL};
	struct bc_proto_edit_op ins = {.kind = BC_PROTO_EDIT_INSERT};
	struct bc_proto_edit_op rm = {.kind = BC_PROTO_EDIT_REMOVE};
	struct bc_proto_buf big, mid, two, huge, thousand;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	struct held_msg h;
	struct daemon d;
	struct conn a, b, o;
	static char log[80];
	char dir[64];
	make_dir_name(dir, sizeof(dir), "wait-room");
	snprintf(log, sizeof(log), "%s.log", dir);
	daemon_log_path = log;
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "b") == 0);
	REQUIRE(conn_open(&o, &d) == 0 && conn_hello(&o, "o") == 0);
	REQUIRE(conn_join(&b, "b", BC_PROTO_ROLE_EDITOR, true) == 0);
	big = spheres_at(100000, 0, 10000);
	mid = spheres_at(60000, 1, 200000);
	two = spheres_at(2, 2, 300000);
	huge = spheres_at(149000, 0, 400000);
	thousand = spheres_at(999, 3, 600000);
	REQUIRE(conn_join(&a, "a", BC_PROTO_ROLE_EDITOR, true) == 0);
	m.scene_load.scene.ptr = mid.data;
	m.scene_load.scene.len = (uint32_t)mid.len;
	send_but_last(&b, &m, &h);
	load_leave_send(&a, "a", &big, 100000, &o, &b, &h);
	CHECK_EQ_INT(answer_of(&b, h.seq), APPLIED);
	CHECK_EQ_INT(daemon_log_count(log, "session a unloaded (its memory"),
	             1);
	/* b back to two spheres; c takes a's place, and b's INSERT of
	 * 60 000 needs c's room. */
	CHECK_EQ_INT(load_answer(&b, &two), APPLIED);
	REQUIRE(conn_join(&a, "c", BC_PROTO_ROLE_EDITOR, true) == 0);
	memset(&m, 0, sizeof(m));
	m.type = BC_MSG_EDIT;
	m.edit.nops = 1;
	m.edit.ops = &ins;
	ins.node = 300000;
	ins.subtree.ptr = mid.data;
	ins.subtree.len = (uint32_t)mid.len;
	send_but_last(&b, &m, &h);
	load_leave_send(&a, "c", &big, 100000, &o, &b, &h);
	CHECK_EQ_INT(answer_of(&b, h.seq), APPLIED);
	CHECK_EQ_INT(daemon_log_count(log, "session c unloaded (its memory"),
	             1);
	/* And an UNDO that puts 60 001 nodes back: b removes the group it
	 * inserted, session e takes the room, b's UNDO needs e's. */
	rm.node = 200000;
	CHECK_EQ_INT(edit_answer(&b, &rm), APPLIED);
	REQUIRE(conn_join(&a, "e", BC_PROTO_ROLE_EDITOR, true) == 0);
	memset(&m, 0, sizeof(m));
	m.type = BC_MSG_UNDO;
	send_but_last(&b, &m, &h);
	load_leave_send(&a, "e", &big, 100000, &o, &b, &h);
	CHECK_EQ_INT(answer_of(&b, h.seq), APPLIED);
	CHECK_EQ_INT(daemon_log_count(log, "session e unloaded (its memory"),
	             1);
	/* And a JOIN that loads a session from disk: b (1 000 nodes now)
	 * left and unloaded for session f's 149 001, b's JOIN of it needs
	 * f's room. */
	CHECK_EQ_INT(load_answer(&b, &thousand), APPLIED);
	leave(&b);
	memset(&m, 0, sizeof(m));
	m.type = BC_MSG_SESSION_JOIN;
	m.session.role = BC_PROTO_ROLE_EDITOR;
	m.session.name.ptr = "b";
	m.session.name.len = 1;
	send_but_last(&b, &m, &h);
	REQUIRE(conn_join(&a, "f", BC_PROTO_ROLE_EDITOR, true) == 0);
	load_leave_send(&a, "f", &huge, 149000, &o, &b, &h);
	CHECK(conn_expect(&b, BC_MSG_SESSION_INFO, 30000) == 1);
	REQUIRE(conn_expect(&b, BC_MSG_SCENE_STATE, 30000) == 1);
	CHECK_EQ_INT(nodes_of(&b), 1000);
	CHECK_EQ_INT(daemon_log_count(log, "session f unloaded (its memory"),
	             1);
	printf("# requests that waited for a snapshot's room: %d of 4\n",
	       daemon_log_count(log, "until its work ends"));
	conn_close(&a);
	conn_close(&b);
	conn_close(&o);
	daemon_log_path = NULL;
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_proto_buf_finish(&big);
	bc_proto_buf_finish(&mid);
	bc_proto_buf_finish(&two);
	bc_proto_buf_finish(&huge);
	bc_proto_buf_finish(&thousand);
}

/* GET_STATS's MEMORY part (c's answer in c->m). */
static bool memory_stats(struct conn *c, uint8_t parts)
{
	struct bc_msg m = {.type = BC_MSG_GET_STATS};
	uint32_t seq;
	m.get_stats.parts = parts;
	seq = conn_send(c, &m);
	while (conn_recv(c, 10000) == 1) {
		if (c->m.type == BC_MSG_STATS && c->m.seq == seq) {
			return c->m.stats.has_memory;
		}
	}
	return false;
}

/* STATS's memory section (PROTOCOL.md 7.18) at --scene-memory 1 (1 497
 * nodes): the cap, the nodes all loaded sessions hold and the asker's
 * session's; a load moves both by its nodes, and an unload gives them
 * back. The WELCOME granted MEMORY (conn_hello checks every feature it
 * announced was granted); the section comes after the others. */
static void stats_tell_the_scene_memory(void)
{
	static const char *const cap[] = {"--scene-memory", "1", NULL};
	const struct bc_proto_memory *ma, *mo;
	struct bc_proto_buf g = two_groups(400, 300, 10000);
	struct bc_proto_buf gn = two_groups(400, 398, 20000);
	struct daemon d;
	struct conn a, o;
	uint64_t before;
	char dir[64];
	make_dir_name(dir, sizeof(dir), "memory-stats");
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_open(&o, &d) == 0 && conn_hello(&o, "o") == 0);
	ma = &a.m.stats.memory;
	mo = &o.m.stats.memory;
	/* Outside a session: only session default is loaded. */
	REQUIRE(memory_stats(&o, BC_PROTO_STATS_MEMORY));
	CHECK(!o.m.stats.has_load && !o.m.stats.has_link);
	CHECK_EQ_INT(mo->scene_nodes_cap, 1497);
	CHECK(mo->scene_nodes > 0 && mo->scene_nodes < 100);
	CHECK_EQ_INT(mo->session_nodes, 0);
	CHECK_EQ_INT(mo->sessions_loaded, 1);
	before = mo->scene_nodes;
	REQUIRE(conn_join(&a, "m", BC_PROTO_ROLE_EDITOR, true) == 0);
	CHECK_EQ_INT(load_answer(&a, &g), APPLIED);
	REQUIRE(memory_stats(&a, BC_PROTO_STATS_MEMORY));
	CHECK_EQ_INT(ma->session_nodes, 703);
	CHECK_EQ_INT(ma->scene_nodes, before + 703);
	CHECK_EQ_INT(ma->sessions_loaded, 2);
	/* Every part: the memory section last, the same figures. */
	REQUIRE(memory_stats(&a, BC_PROTO_STATS_PARTS_ALL));
	CHECK(a.m.stats.has_load && a.m.stats.has_tls && a.m.stats.has_link);
	CHECK_EQ_INT(ma->scene_nodes, before + 703);
	CHECK_EQ_INT(ma->scene_nodes_cap, 1497);
	/* Left, default and m are unloaded for n's 801 nodes: theirs go. */
	leave(&a);
	REQUIRE(conn_join(&a, "n", BC_PROTO_ROLE_EDITOR, true) == 0);
	CHECK_EQ_INT(load_answer(&a, &gn), APPLIED);
	REQUIRE(memory_stats(&o, BC_PROTO_STATS_MEMORY));
	CHECK_EQ_INT(mo->scene_nodes, 801);
	CHECK_EQ_INT(mo->session_nodes, 0);
	CHECK_EQ_INT(mo->sessions_loaded, 1);
	conn_close(&a);
	conn_close(&o);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_proto_buf_finish(&g);
	bc_proto_buf_finish(&gn);
}

/* Spheres g (ids id + 1 ..) under a union of id, as scene bytes. */
static void put_group(struct bc_proto_buf *b, uint32_t g, uint32_t id)
{
	const float t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, r = 0.4f;
	bc_proto_scene_op(b, BC_OP_UNION, id++, 0, 0, g);
	for (uint32_t i = 0; i < g; i++) {
		bc_proto_scene_prim(b, BC_PRIM_SPHERE, id++, t, q, NULL, 1, &r);
	}
}

/* two_groups(g1, g2, id) wrapped in a union wid with a sphere wid + 1:
 * the subtree of a REPLACE of its root, as `blobcast wrap` sends. */
static struct bc_proto_buf wrapped(uint32_t g1, uint32_t g2, uint32_t id,
                                   uint32_t wid)
{
	const float t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, r = 0.4f;
	struct bc_proto_buf b;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 5 + g1 + g2);
	bc_proto_scene_op(&b, BC_OP_UNION, wid, 0, 0, 2);
	bc_proto_scene_op(&b, BC_OP_UNION, id, 0, 0, 2);
	put_group(&b, g1, id + 1);
	put_group(&b, g2, id + 2 + g1);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, wid + 1, t, q, NULL, 1, &r);
	return b;
}

/* The room a change takes counts what it takes away: at --scene-memory 1
 * (1 497 nodes), a scene of 1 000 wrapped whole (a REPLACE of its root
 * by a union holding it: 1 002 nodes after) and a group of 901 moved (a
 * REMOVE and an INSERT of the same ids) apply; they were refused as
 * scenes of 2 002 and 1 903 nodes. A REPLACE that does make the scene
 * pass the cap is refused still. */
static void a_wrap_or_move_takes_no_room_for_what_it_removes(void)
{
	static const char *const cap[] = {"--scene-memory", "1", NULL};
	struct bc_proto_buf g = two_groups(900, 97, 20000);
	struct bc_proto_buf w = wrapped(900, 97, 20000, 30000);
	struct bc_proto_buf moved, big;
	struct bc_proto_edit_op ops[2] = {{.kind = BC_PROTO_EDIT_REMOVE},
	                                  {.kind = BC_PROTO_EDIT_INSERT}};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	struct daemon d;
	struct conn a;
	char dir[64];
	make_dir_name(dir, sizeof(dir), "room-taken");
	REQUIRE(daemon_start_with(&d, dir, cap) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_join(&a, "w", BC_PROTO_ROLE_EDITOR, true) == 0);
	CHECK_EQ_INT(load_answer(&a, &g), APPLIED);
	ops[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REPLACE,
	                              .node = 20000,
	                              .subtree = {w.data, (uint32_t)w.len}};
	CHECK_EQ_INT(edit_answer(&a, &ops[0]), APPLIED);
	/* Group 20001 (901 nodes) into group 20902, first. */
	bc_proto_buf_init(&moved, 0);
	bc_proto_scene_begin(&moved, NULL, 901);
	put_group(&moved, 900, 20001);
	ops[0] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                   .node = 20001};
	ops[1] = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT,
	    .node = 20902,
	    .position = 0,
	    .subtree = {moved.data, (uint32_t)moved.len}};
	m.edit.nops = 2;
	m.edit.ops = ops;
	CHECK_EQ_INT(answer_of(&a, conn_send(&a, &m)), APPLIED);
	REQUIRE(memory_stats(&a, BC_PROTO_STATS_MEMORY));
	/* 1 002, less union 20000 that the REMOVE left with one child. */
	CHECK_EQ_INT(a.m.stats.memory.session_nodes, 1001);
	/* The whole scene for a group of 1 600 spheres: 1 601 nodes. */
	bc_proto_buf_init(&big, 0);
	bc_proto_scene_begin(&big, NULL, 1601);
	put_group(&big, 1600, 40000);
	ops[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REPLACE,
	                              .node = 30000,
	                              .subtree = {big.data, (uint32_t)big.len}};
	CHECK_EQ_INT(edit_answer(&a, &ops[0]), -BC_ELIMIT);
	CHECK(error_says(&a, "a scene of 1601 nodes"));
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_proto_buf_finish(&g);
	bc_proto_buf_finish(&w);
	bc_proto_buf_finish(&moved);
	bc_proto_buf_finish(&big);
}

/* A daemon restarted with less --scene-memory than session "default"'s
 * scene alone starts all the same, says so, and refuses a JOIN of it
 * with ELIMIT, not an EIO or a daemon that does not start. */
static void a_default_scene_past_the_budget_waits_on_disk(void)
{
	static const char *const roomy[] = {"--scene-memory", "2", NULL};
	static const char *const tight[] = {"--scene-memory", "1", NULL};
	struct bc_proto_buf big = spheres_at(2000, 0, 0);
	struct daemon d;
	struct conn a;
	/* Static: a test that stops at a REQUIRE leaves daemon_log_path
	 * pointing here for the next one. */
	static char log[80];
	char dir[64];
	make_dir_name(dir, sizeof(dir), "bigdefault");
	snprintf(log, sizeof(log), "%s.log", dir);
	REQUIRE(daemon_start_with(&d, dir, roomy) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	CHECK_EQ_INT(load_answer(&a, &big), APPLIED);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	daemon_log_path = log;
	REQUIRE(daemon_start_with(&d, dir, tight) == 0);
	daemon_log_path = NULL;
	CHECK_EQ_INT(daemon_log_count(log, "session default stays on disk"), 1);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	CHECK_EQ_INT(session_request(&a, BC_MSG_SESSION_JOIN, "default",
	                             BC_PROTO_ROLE_VIEWER),
	             -BC_ELIMIT);
	CHECK(error_says(&a, "more than this server holds in all"));
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_proto_buf_finish(&big);
}

static const struct bc_test tests[] = {
    {"a_trickled_message_times_out", a_trickled_message_times_out},
    {"an_idle_client_in_no_session_is_dropped",
     an_idle_client_in_no_session_is_dropped},
    {"a_connection_flood_leaves_room_for_others",
     a_connection_flood_leaves_room_for_others},
    {"a_flood_from_many_addresses_leaves_room_for_a_neighbour",
     a_flood_from_many_addresses_leaves_room_for_a_neighbour},
    {"a_snapshot_larger_than_the_queue_arrives",
     a_snapshot_larger_than_the_queue_arrives},
    {"a_scene_too_big_to_send_is_refused", a_scene_too_big_to_send_is_refused},
    {"a_scene_past_the_client_queue_reaches_its_members",
     a_scene_past_the_client_queue_reaches_its_members},
    {"a_refused_structural_edit_is_not_drawn",
     a_refused_structural_edit_is_not_drawn},
    {"a_client_queues_a_bounded_number_of_requests",
     a_client_queues_a_bounded_number_of_requests},
    {"the_jobs_of_a_client_that_left_are_dropped",
     the_jobs_of_a_client_that_left_are_dropped},
    {"sessions_take_turns_on_the_render_thread",
     sessions_take_turns_on_the_render_thread},
    {"a_viewer_token_cannot_create_or_delete_sessions",
     a_viewer_token_cannot_create_or_delete_sessions},
    {"idle_sessions_make_room_and_load_again",
     idle_sessions_make_room_and_load_again},
    {"a_deleted_session_is_gone_for_good", a_deleted_session_is_gone_for_good},
    {"a_large_load_does_not_hold_other_sessions",
     a_large_load_does_not_hold_other_sessions},
    {"the_scene_memory_cap_holds_across_sessions",
     the_scene_memory_cap_holds_across_sessions},
    {"a_change_waits_for_the_room_a_snapshot_holds",
     a_change_waits_for_the_room_a_snapshot_holds},
    {"stats_tell_the_scene_memory", stats_tell_the_scene_memory},
    {"a_wrap_or_move_takes_no_room_for_what_it_removes",
     a_wrap_or_move_takes_no_room_for_what_it_removes},
    {"a_default_scene_past_the_budget_waits_on_disk",
     a_default_scene_past_the_budget_waits_on_disk},
};

int main(int argc, char **argv)
{
	(void)conn_view;
	(void)conn_move;
	return daemon_tests_run("limits", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
