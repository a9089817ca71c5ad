/*
 * libblobcast against a scripted fake server: a thread in this test that
 * accepts one connection (loopback TCP or a Unix socket) and speaks the
 * protocol through bc_proto, checking what the client sends and answering
 * as blobcastd would -- or as a broken or hostile peer would. Covers the
 * handshake, sessions, the scene mirror (parameter and structural edits,
 * a skipped order), edit acknowledgements among other members' edits,
 * the roster of members through joins, leaves and deletion,
 * presenting, following and the session camera (which moves the mirror's
 * camera and order), frames and snapshots, messages larger than one read, and
 * every way a connection can fail (refused, wrong protocol, silence, ERROR, a
 * close between or inside messages).
 */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "test.h"

/* ---- the fake server ------------------------------------------------------ */

struct fake;
typedef void (*script_fn)(struct fake *f, int fd);

struct fake {
	int lfd;
	char addr[160];
	char dir[64]; /* temp dir of a Unix socket, or "" */
	pthread_t thread;
	pid_t child; /* the server runs in a child process instead, or 0 */
	script_fn script;
	int failures; /* checks that failed in the server thread */
	struct bc_proto_reader r;
};

/* CHECK for the server thread: counted apart, added up at the end. */
#define SCHECK(f, cond)                                                        \
	do {                                                                   \
		if (!(cond)) {                                                 \
			fprintf(stderr, "  %s:%d: server CHECK failed: %s\n",  \
			        __FILE__, __LINE__, #cond);                    \
			(f)->failures++;                                       \
		}                                                              \
	} while (0)

static void write_all(int fd, const void *p, size_t n)
{
	const uint8_t *b = p;
	while (n > 0) {
		ssize_t k = send(fd, b, n, MSG_NOSIGNAL);
		if (k <= 0) {
			return;
		}
		b += k;
		n -= (size_t)k;
	}
}

static void srv_send(struct fake *f, int fd, const struct bc_msg *m)
{
	struct bc_proto_buf b;
	struct bc_errinfo ei = {0};
	bc_proto_buf_init(&b, 0);
	if (bc_proto_encode(&b, m, &ei) != 0) {
		fprintf(stderr, "  fake server cannot encode %s: %s\n",
		        bc_proto_type_name(m->type), ei.msg);
		f->failures++;
	}
	write_all(fd, b.data, b.len);
	bc_proto_buf_finish(&b);
}

/* Next message from the client; 0 when it closed or sent garbage. */
static int srv_next(struct fake *f, int fd, struct bc_msg *m)
{
	for (;;) {
		uint8_t buf[4096];
		ssize_t n;
		int rc = bc_proto_reader_next(&f->r, m);
		if (rc != 0) {
			return rc > 0;
		}
		n = read(fd, buf, sizeof(buf));
		if (n <= 0 || bc_proto_reader_feed(&f->r, buf, (size_t)n)) {
			return 0;
		}
	}
}

/* Waits for one message of type, failing the test on anything else. */
static int srv_expect(struct fake *f, int fd, enum bc_msg_type type,
                      struct bc_msg *m)
{
	if (!srv_next(f, fd, m)) {
		fprintf(stderr, "  fake server: no %s\n",
		        bc_proto_type_name(type));
		f->failures++;
		return 0;
	}
	if (m->type != type) {
		fprintf(stderr, "  fake server: %s instead of %s\n",
		        bc_proto_type_name(m->type), bc_proto_type_name(type));
		f->failures++;
		return 0;
	}
	return 1;
}

static void srv_error(struct fake *f, int fd, uint32_t seq, int code,
                      bool fatal, const char *text)
{
	struct bc_msg e = {.type = BC_MSG_ERROR, .seq = seq};
	e.flags = fatal ? BC_PROTO_FLAG_FATAL : 0;
	e.error.code = (uint16_t)-code;
	e.error.text.ptr = text;
	e.error.text.len = (uint32_t)strlen(text);
	srv_send(f, fd, &e);
}

/* HELLO (in *m) -> WELCOME with max_payload and, when the HELLO
 * announced some, the features granted. */
static int srv_hello_with(struct fake *f, int fd, uint32_t max_payload,
                          uint32_t features, struct bc_msg *m)
{
	struct bc_msg w = {.type = BC_MSG_WELCOME};
	if (!srv_expect(f, fd, BC_MSG_HELLO, m)) {
		return 0;
	}
	SCHECK(f, m->hello.version_min <= BC_PROTO_VERSION &&
	              m->hello.version_max >= BC_PROTO_VERSION);
	bc_proto_reader_hello_done(&f->r);
	w.seq = m->seq;
	w.welcome.version = BC_PROTO_VERSION;
	w.welcome.connection_id = 7;
	w.welcome.max_payload = max_payload;
	w.welcome.max_frame_bytes = 1u << 20;
	w.welcome.max_nodes = 100000;
	w.welcome.max_dim = 4096;
	w.welcome.max_members = 64;
	w.welcome.max_edit_ops = 1024;
	w.welcome.server_id.ptr = "fake";
	w.welcome.server_id.len = 4;
	w.welcome.has_features = features && m->hello.has_features;
	w.welcome.features = w.welcome.has_features ? features : 0;
	srv_send(f, fd, &w);
	return 1;
}

/* HELLO -> WELCOME, the start of most scripts. */
static int srv_hello(struct fake *f, int fd)
{
	struct bc_msg m;
	return srv_hello_with(f, fd, BC_PROTO_MAX_PAYLOAD, 0, &m);
}

static void *fake_main(void *arg)
{
	struct fake *f = arg;
	struct bc_proto_reader_opts ro = {.side = BC_PROTO_SIDE_SERVER,
	                                  .await_hello = true};
	int fd = accept(f->lfd, NULL, NULL);
	if (fd < 0) {
		f->failures++;
		return NULL;
	}
	bc_proto_reader_init(&f->r, &ro);
	f->script(f, fd);
	bc_proto_reader_finish(&f->r);
	close(fd);
	return NULL;
}

static int fake_start(struct fake *f, script_fn script, bool unix_socket)
{
	memset(f, 0, sizeof(*f));
	f->script = script;
	if (unix_socket) {
		struct sockaddr_un sun = {.sun_family = AF_UNIX};
		snprintf(f->dir, sizeof(f->dir), "/tmp/bc-client-test-XXXXXX");
		if (!mkdtemp(f->dir)) {
			return -1;
		}
		snprintf(sun.sun_path, sizeof(sun.sun_path), "%s/s.sock",
		         f->dir);
		snprintf(f->addr, sizeof(f->addr), "unix:%s", sun.sun_path);
		f->lfd = socket(AF_UNIX, SOCK_STREAM, 0);
		if (f->lfd < 0 ||
		    bind(f->lfd, (struct sockaddr *)&sun, sizeof(sun)) < 0) {
			return -1;
		}
	} else {
		struct sockaddr_in in = {.sin_family = AF_INET};
		socklen_t len = sizeof(in);
		in.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
		f->lfd = socket(AF_INET, SOCK_STREAM, 0);
		if (f->lfd < 0 ||
		    bind(f->lfd, (struct sockaddr *)&in, sizeof(in)) < 0 ||
		    getsockname(f->lfd, (struct sockaddr *)&in, &len) < 0) {
			return -1;
		}
		snprintf(f->addr, sizeof(f->addr), "127.0.0.1:%u",
		         (unsigned)ntohs(in.sin_port));
	}
	if (listen(f->lfd, 1) < 0 ||
	    pthread_create(&f->thread, NULL, fake_main, f) != 0) {
		return -1;
	}
	return 0;
}

/* The same server in a child process: the allocation-failure hook counts
 * this process's allocations only, so the client's can be failed one by
 * one while the server's never are. */
static int fake_fork(struct fake *f, script_fn script)
{
	struct sockaddr_in in = {.sin_family = AF_INET};
	socklen_t len = sizeof(in);
	memset(f, 0, sizeof(*f));
	f->script = script;
	in.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	f->lfd = socket(AF_INET, SOCK_STREAM, 0);
	if (f->lfd < 0 ||
	    bind(f->lfd, (struct sockaddr *)&in, sizeof(in)) < 0 ||
	    getsockname(f->lfd, (struct sockaddr *)&in, &len) < 0 ||
	    listen(f->lfd, 1) < 0) {
		return -1;
	}
	snprintf(f->addr, sizeof(f->addr), "127.0.0.1:%u",
	         (unsigned)ntohs(in.sin_port));
	fflush(NULL);
	f->child = fork();
	if (f->child < 0) {
		return -1;
	}
	if (f->child == 0) {
		fake_main(f);
		close(f->lfd);
		exit(f->failures ? 1 : 0);
	}
	return 0;
}

/* Joins the server thread and counts its failures into the test's. */
static void fake_stop(struct fake *f)
{
	if (f->child > 0) {
		struct sockaddr_in in;
		socklen_t len = sizeof(in);
		int st = 0, wake = socket(AF_INET, SOCK_STREAM, 0);
		/* A client that failed before connecting leaves the server in
		 * accept(): a connection that closes at once lets it finish.
		 * (If it has served already, this one just waits in the
		 * backlog until the listener closes.) */
		if (wake >= 0 &&
		    getsockname(f->lfd, (struct sockaddr *)&in, &len) == 0) {
			(void)connect(wake, (struct sockaddr *)&in, len);
		}
		if (wake >= 0) {
			close(wake);
		}
		close(f->lfd);
		waitpid(f->child, &st, 0);
		if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) {
			fprintf(stderr, "  fake server process failed (%d)\n",
			        st);
			bc_test_failures++;
		}
		return;
	}
	pthread_join(f->thread, NULL);
	close(f->lfd);
	if (f->dir[0]) {
		char path[128];
		snprintf(path, sizeof(path), "%s/s.sock", f->dir);
		unlink(path);
		rmdir(f->dir);
	}
	bc_test_failures += f->failures;
}

/* ---- scenes ------------------------------------------------------------------ */

static const char scene_json[] =
    "{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 5], \"target\": "
    "[0, 0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 40}, \"root\": "
    "{\"type\": \"union\", \"id\": 1, \"children\": ["
    "{\"type\": \"sphere\", \"id\": 2, \"radius\": 0.5},"
    "{\"type\": \"box\", \"id\": 3, \"half_extents\": [0.3, 0.3, 0.3]},"
    "{\"type\": \"sphere\", \"id\": 4, \"radius\": 0.2}]}}";

/* Encodes a JSON scene, or a union of n spheres when json is NULL. */
static uint8_t *scene_bytes(const char *json, uint32_t n, size_t *len)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	uint8_t *out = NULL;
	*len = 0;
	if (json) {
		if (bc_scene_parse_json(json, strlen(json), t, &cam, &ei)) {
			fprintf(stderr, "  scene: %s\n", ei.msg);
			abort();
		}
	} else {
		struct bc_op_data op = {.kind = BC_OP_UNION};
		bc_camera_default(&cam);
		bc_tree_begin(t);
		bc_tree_push_op(t, 1, &op, &ei);
		for (uint32_t i = 0; i < n; i++) {
			struct bc_prim_data p;
			bc_prim_data_init(&p, BC_PRIM_SPHERE);
			p.params[0] = 0.1f;
			p.translate[0] = (float)i * 0.01f;
			if (bc_tree_put_prim(t, 100 + i, &p, &ei)) {
				abort();
			}
		}
		bc_tree_pop_op(t, &ei);
		if (bc_tree_end(t, &ei)) {
			fprintf(stderr, "  scene: %s\n", ei.msg);
			abort();
		}
	}
	if (bc_scene_encode(t, &cam, &out, len)) {
		abort();
	}
	bc_tree_destroy(t);
	return out;
}

static void srv_session(struct fake *f, int fd, uint32_t seq, uint64_t order)
{
	struct bc_proto_member me = {.id = 3, .role = BC_PROTO_ROLE_EDITOR};
	struct bc_msg info = {.type = BC_MSG_SESSION_INFO, .seq = seq};
	struct bc_msg st = {.type = BC_MSG_SCENE_STATE};
	size_t len;
	uint8_t *bytes = scene_bytes(scene_json, 0, &len);
	me.name.ptr = "loopback-test";
	me.name.len = 13;
	info.session_info.session_id = 11;
	info.session_info.member_id = 3;
	info.session_info.role = BC_PROTO_ROLE_EDITOR;
	info.session_info.name.ptr = "s1";
	info.session_info.name.len = 2;
	info.session_info.nmembers = 1;
	info.session_info.members = &me;
	srv_send(f, fd, &info);
	st.scene_state.order = order;
	st.scene_state.scene.ptr = bytes;
	st.scene_state.scene.len = (uint32_t)len;
	srv_send(f, fd, &st);
	bc_free(bytes);
}

/* A recognisable raw image. */
static uint8_t *pixels(uint32_t w, uint32_t h, uint8_t seed)
{
	uint8_t *p = malloc((size_t)w * h * 4u);
	for (size_t i = 0; i < (size_t)w * h; i++) {
		p[4 * i] = (uint8_t)(i + seed);
		p[4 * i + 1] = (uint8_t)(i >> 8);
		p[4 * i + 2] = seed;
		p[4 * i + 3] = 255;
	}
	return p;
}

static void srv_frame(struct fake *f, int fd, uint32_t seq, uint16_t flags,
                      uint16_t w, uint16_t h, uint8_t seed, uint64_t order)
{
	struct bc_msg m = {.type = BC_MSG_FRAME, .seq = seq, .flags = flags};
	uint8_t *p = pixels(w, h, seed);
	struct bc_proto_rect r = {0, 0, w, h, {p, (uint32_t)w * h * 4u}};
	m.frame.frame_no = seed;
	m.frame.order = order;
	m.frame.encoding = BC_PROTO_ENC_RAW;
	m.frame.width = m.frame.image_width = w;
	m.frame.height = m.frame.image_height = h;
	m.frame.nrects = 1;
	m.frame.rects = &r;
	srv_send(f, fd, &m);
	free(p);
}

static struct bc_client *connect_to(struct fake *f, int timeout_ms)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	if (bc_client_connect(
	        &c,
	        &(struct bc_client_opts){.addr = f->addr,
	                                 .name = "loopback-test",
	                                 .timeout_ms = timeout_ms},
	        &ei) != 0) {
		fprintf(stderr, "  connect: %s\n", ei.msg);
	}
	return c;
}

/* ---- handshake and session ------------------------------------------------- */

static void script_session(struct fake *f, int fd)
{
	struct bc_msg m;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	SCHECK(f, m.session.name.len == 2 &&
	              memcmp(m.session.name.ptr, "s1", 2) == 0);
	SCHECK(f, m.session.role == BC_PROTO_ROLE_EDITOR);
	srv_error(f, fd, m.seq, BC_ENOSESSION, false, "no session named s1");
	if (!srv_expect(f, fd, BC_MSG_SESSION_CREATE, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	if (!srv_expect(f, fd, BC_MSG_GET_STATS, &m)) {
		return;
	}
	{
		struct bc_msg st = {.type = BC_MSG_STATS, .seq = m.seq};
		st.stats.frames = 12;
		st.stats.order = 5;
		st.stats.fps = 30.0f;
		srv_send(f, fd, &st);
	}
	/* Then the client leaves: the server sees the stream end. */
	SCHECK(f, !srv_next(f, fd, &m));
}

static void test_handshake_join_or_create_and_stats(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_msg_stats st;
	struct bc_prim_data p;
	struct bc_camera cam;
	const struct bc_client_info *info;
	const struct bc_tree *t;
	REQUIRE(fake_start(&f, script_session, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		info = bc_client_info(c);
		CHECK_EQ_INT(info->connection_id, 7);
		CHECK_EQ_INT(info->max_frame_bytes, 1u << 20);
		CHECK_STREQ(info->server_id, "fake");
		CHECK(bc_client_fd(c) >= 0);
		CHECK(bc_client_scene(c, NULL) == NULL);
		CHECK_EQ_INT(
		    bc_client_join(c, "s1", 0, BC_CLIENT_JOIN_ANY, &ei), 0);
		CHECK_EQ_INT(info->member_id, 3);
		CHECK_EQ_INT(info->session_id, 11);
		CHECK_EQ_INT(info->role, BC_PROTO_ROLE_EDITOR);
		CHECK_STREQ(info->session, "s1");
		CHECK_EQ_INT(info->order, 5);
		t = bc_client_scene(c, &cam);
		REQUIRE(t != NULL);
		CHECK_EQ_INT(bc_tree_node_count(t), 4);
		CHECK(bc_tree_get(t, 2, &p, NULL) && p.kind == BC_PRIM_SPHERE);
		CHECK(cam.eye[2] == 5.0f && cam.fov_y_deg == 40.0f);
		CHECK_EQ_INT(bc_client_stats(c, &st, &ei), 0);
		CHECK_EQ_INT(st.frames, 12);
		CHECK(st.fps == 30.0f);
		CHECK(info->msgs_out == 4 && info->msgs_in == 5);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

static void script_join_refused(struct fake *f, int fd)
{
	struct bc_msg m;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_error(f, fd, m.seq, BC_ENOSESSION, false, "no session named zz");
	if (!srv_expect(f, fd, BC_MSG_SESSION_CREATE, &m)) {
		return;
	}
	srv_error(f, fd, m.seq, BC_EPERM, false,
	          "your token grants the viewer role only");
	SCHECK(f, !srv_next(f, fd, &m));
}

static void test_session_errors_carry_server_text(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	REQUIRE(fake_start(&f, script_join_refused, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		CHECK_EQ_INT(
		    bc_client_join(c, "zz", 0, BC_CLIENT_JOIN_EXISTING, &ei),
		    BC_ENOSESSION);
		CHECK(strstr(ei.msg, "no session named zz") != NULL);
		/* Not sticky: the connection goes on. */
		CHECK_EQ_INT(bc_client_error(c, NULL), 0);
		CHECK_EQ_INT(bc_client_join(c, "zz", BC_PROTO_ROLE_EDITOR,
		                            BC_CLIENT_JOIN_CREATE, &ei),
		             BC_EPERM);
		CHECK(strstr(ei.msg, "viewer role only") != NULL);
		CHECK_EQ_INT(bc_client_join(c, "", 0, BC_CLIENT_JOIN_ANY, &ei),
		             BC_EINVAL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

/* ---- edits and the mirror ----------------------------------------------------- */

static void script_edit(struct fake *f, int fd)
{
	struct bc_msg m;
	struct bc_proto_field other_f = {.field = BC_PROTO_FIELD_TRANSLATE,
	                                 .count = 3,
	                                 .v = {2.0f, 0.0f, 0.0f}};
	struct bc_proto_edit_op other = {.kind = BC_PROTO_EDIT_SET,
	                                 .node = 3,
	                                 .nfields = 1,
	                                 .fields = &other_f};
	struct bc_msg ea = {.type = BC_MSG_EDIT_APPLIED};
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	if (!srv_expect(f, fd, BC_MSG_EDIT, &m)) {
		return;
	}
	SCHECK(f, m.flags == BC_PROTO_FLAG_INTERACTING);
	SCHECK(f, m.edit.nops == 1 && m.edit.ops[0].kind == BC_PROTO_EDIT_SET);
	SCHECK(f, m.edit.ops[0].node == 2 && m.edit.ops[0].nfields == 1);
	SCHECK(f, m.edit.ops[0].fields[0].field == BC_PROTO_FIELD_PARAM0);
	SCHECK(f, m.edit.ops[0].fields[0].v[0] == 0.4f);
	/* Another member's edit is applied first and broadcast to all. */
	ea.seq = 41;
	ea.edit_applied.order = 6;
	ea.edit_applied.author = 8;
	ea.edit_applied.author_seq = 41;
	ea.edit_applied.nops = 1;
	ea.edit_applied.ops = &other;
	srv_send(f, fd, &ea);
	srv_frame(f, fd, 0, 0, 4, 4, 1, 6);
	ea.seq = m.seq;
	ea.edit_applied.order = 7;
	ea.edit_applied.author = 3;
	ea.edit_applied.author_seq = m.seq;
	ea.edit_applied.nops = m.edit.nops;
	ea.edit_applied.ops = m.edit.ops;
	srv_send(f, fd, &ea);
	/* A bad edit is answered with ERROR. */
	if (!srv_expect(f, fd, BC_MSG_EDIT, &m)) {
		return;
	}
	srv_error(f, fd, m.seq, BC_ERANGE, false,
	          "edit refused: operation 0: radius must be > 0");
	SCHECK(f, !srv_next(f, fd, &m));
}

static void test_edit_is_acknowledged_among_other_edits(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	const char *kv[] = {"radius=0.4"}, *bad[] = {"radius=-1"};
	const char *typo[] = {"radios=1"};
	struct bc_prim_data p;
	uint32_t seq;
	uint64_t order;
	REQUIRE(fake_start(&f, script_edit, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		CHECK_EQ_INT(bc_client_edit_kv(c, 2, kv, 1, false, &seq, &ei),
		             BC_ESTATE);
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		/* A typo never reaches the server. */
		CHECK_EQ_INT(bc_client_edit_kv(c, 2, typo, 1, true, &seq, &ei),
		             BC_EINVAL);
		CHECK_EQ_INT(seq, 0);
		REQUIRE(bc_client_edit_kv(c, 2, kv, 1, true, &seq, &ei) == 0);
		CHECK(seq != 0);
		CHECK_EQ_INT(bc_client_wait_applied(c, seq, &order, &ei), 0);
		CHECK_EQ_INT(order, 7);
		CHECK_EQ_INT(bc_client_info(c)->order, 7);
		/* The mirror holds both edits, in order. */
		REQUIRE(bc_client_scene(c, NULL) != NULL);
		CHECK(bc_tree_get(bc_client_scene(c, NULL), 2, &p, NULL));
		CHECK(p.params[0] == 0.4f);
		CHECK(bc_tree_get(bc_client_scene(c, NULL), 3, &p, NULL));
		CHECK(p.translate[0] == 2.0f);
		REQUIRE(bc_client_edit_kv(c, 2, bad, 1, false, &seq, &ei) == 0);
		CHECK_EQ_INT(bc_client_wait_applied(c, seq, &order, &ei),
		             BC_ERANGE);
		CHECK(strstr(ei.msg, "radius must be > 0") != NULL);
		CHECK_EQ_INT(order, 0);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

static void script_structural(struct fake *f, int fd)
{
	struct bc_msg m, ea = {.type = BC_MSG_EDIT_APPLIED};
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REMOVE, .node = 4};
	struct bc_proto_buf sub;
	float one = 1.0f;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	ea.edit_applied.author = 8;
	ea.edit_applied.author_seq = 1;
	ea.edit_applied.nops = 1;
	ea.edit_applied.ops = &op;
	ea.edit_applied.order = 6;
	srv_send(f, fd, &ea);
	/* Insert a sphere (id 40, radius 1) as the first child of node 1. */
	bc_proto_buf_init(&sub, 0);
	bc_proto_scene_begin(&sub, NULL, 1);
	bc_proto_scene_prim(&sub, BC_PRIM_SPHERE, 40, (float[3]){0, 1, 0},
	                    (float[4]){0, 0, 0, 1}, NULL, 1, &one);
	op = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT, .node = 1, .position = 0};
	op.subtree.ptr = sub.data;
	op.subtree.len = (uint32_t)sub.len;
	ea.edit_applied.order = 7;
	srv_send(f, fd, &ea);
	bc_proto_buf_finish(&sub);
	/* Order 8 is never sent: the mirror cannot follow order 9. */
	op = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 3};
	ea.edit_applied.order = 9;
	srv_send(f, fd, &ea);
	/* A fresh SCENE_STATE brings it back; then a subtree whose node has
	 * id 0 (the server picks the id, the edit does not say which) drops
	 * it again. */
	srv_session(f, fd, 0, 10);
	bc_proto_buf_init(&sub, 0);
	bc_proto_scene_begin(&sub, NULL, 1);
	bc_proto_scene_prim(&sub, BC_PRIM_SPHERE, 0, (float[3]){0, 1, 0},
	                    (float[4]){0, 0, 0, 1}, NULL, 1, &one);
	op = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT, .node = 1, .position = 1};
	op.subtree.ptr = sub.data;
	op.subtree.len = (uint32_t)sub.len;
	ea.edit_applied.order = 11;
	srv_send(f, fd, &ea);
	bc_proto_buf_finish(&sub);
	SCHECK(f, !srv_next(f, fd, &m));
}

/* The mirror follows the same edits laid out (by default) or bare
 * (bc_client_opts.bare_scene), which differ only in the layout. */
static void mirror_follows_structural_edits(bool bare)
{
	struct fake f;
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	struct bc_prim_data p;
	const struct bc_tree *t;
	REQUIRE(fake_start(&f, script_structural, false) == 0);
	if (bc_client_connect(&c,
	                      &(struct bc_client_opts){.addr = f.addr,
	                                               .name = "loopback-test",
	                                               .timeout_ms = 5000,
	                                               .bare_scene = bare},
	                      &ei) != 0) {
		fprintf(stderr, "  connect: %s\n", ei.msg);
	}
	CHECK(c != NULL);
	if (c) {
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		t = bc_client_scene(c, NULL);
		REQUIRE(t != NULL);
		CHECK_EQ_INT(bc_tree_lays_out(t), !bare);
		CHECK_EQ_INT(bc_tree_lin(t) != NULL, !bare);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.type, BC_MSG_EDIT_APPLIED);
		t = bc_client_scene(c, NULL);
		REQUIRE(t != NULL);
		CHECK_EQ_INT(bc_tree_lin(t) != NULL, !bare);
		CHECK(!bc_tree_get(t, 4, NULL, NULL));
		CHECK_EQ_INT(bc_tree_node_count(t), 3);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		t = bc_client_scene(c, NULL);
		REQUIRE(t != NULL);
		CHECK(bc_tree_get(t, 40, &p, NULL));
		CHECK(p.params[0] == 1.0f && p.translate[1] == 1.0f);
		CHECK_EQ_INT(bc_tree_child(t, 1, 0), 40);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.edit_applied.order, 9);
		CHECK(bc_client_scene(c, NULL) == NULL);
		CHECK_EQ_INT(bc_client_info(c)->order, 9);
		/* SESSION_INFO, then SCENE_STATE: the mirror is back. */
		REQUIRE(bc_client_wait(c, BC_MSG_SCENE_STATE, 0, &m, 0, &ei) ==
		        0);
		REQUIRE(bc_client_scene(c, NULL) != NULL);
		CHECK_EQ_INT(bc_tree_node_count(bc_client_scene(c, NULL)), 4);
		CHECK_EQ_INT(bc_tree_lin(bc_client_scene(c, NULL)) != NULL,
		             !bare);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.edit_applied.order, 11);
		CHECK(bc_client_scene(c, NULL) == NULL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

static void test_mirror_follows_structural_edits(void)
{
	mirror_follows_structural_edits(false);
}

static void test_bare_mirror_follows_structural_edits(void)
{
	mirror_follows_structural_edits(true);
}

/* ---- presenting and the session camera ------------------------------------ */

static const struct bc_msg_camera loop_cam = {
    {2.0f, 1.0f, 5.0f}, {0.0f, 0.5f, 0.0f}, {0.0f, 1.0f, 0.0f}, 33.0f};

static void script_present(struct fake *f, int fd)
{
	struct bc_msg m, out;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REMOVE, .node = 4};
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	/* FOLLOW 1: the camera, then who presents, then OK. */
	if (!srv_expect(f, fd, BC_MSG_FOLLOW, &m)) {
		return;
	}
	SCHECK(f, m.toggle.on == 1);
	out = (struct bc_msg){.type = BC_MSG_FOLLOW_CAMERA};
	out.follow_camera.presenter = 9;
	out.follow_camera.camera = loop_cam;
	srv_send(f, fd, &out);
	out = (struct bc_msg){.type = BC_MSG_PRESENTER};
	out.presenter.presenter = 9;
	out.presenter.following = 1;
	srv_send(f, fd, &out);
	srv_send(f, fd, &(struct bc_msg){.type = BC_MSG_OK, .seq = m.seq});
	/* PRESENT 1: this client presents, so it follows nobody. */
	if (!srv_expect(f, fd, BC_MSG_PRESENT, &m)) {
		return;
	}
	SCHECK(f, m.toggle.on == 1);
	out = (struct bc_msg){.type = BC_MSG_PRESENTER};
	out.presenter.presenter = 3;
	srv_send(f, fd, &out);
	srv_send(f, fd, &(struct bc_msg){.type = BC_MSG_OK, .seq = m.seq});
	/* SESSION_CAMERA: order 6; then another member's edit, order 7. */
	if (!srv_expect(f, fd, BC_MSG_SESSION_CAMERA, &m)) {
		return;
	}
	out = (struct bc_msg){.type = BC_MSG_SESSION_CAMERA_SET};
	out.session_camera_set.order = 6;
	out.session_camera_set.author = 3;
	out.session_camera_set.author_seq = m.seq;
	out.session_camera_set.camera = m.session_camera;
	srv_send(f, fd, &out);
	out = (struct bc_msg){.type = BC_MSG_EDIT_APPLIED};
	out.edit_applied.order = 7;
	out.edit_applied.author = 8;
	out.edit_applied.author_seq = 1;
	out.edit_applied.nops = 1;
	out.edit_applied.ops = &op;
	srv_send(f, fd, &out);
	SCHECK(f, !srv_next(f, fd, &m));
}

/* bc_client_follow and _present keep bc_client_info()'s presenter and
 * following; bc_client_session_camera waits for its SESSION_CAMERA_SET,
 * which moves the mirror's camera and order, so the next edit still
 * replays. */
static void test_presenting_and_session_camera(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_camera cam = {
	    {2.0f, 1.0f, 5.0f}, {0.0f, 0.5f, 0.0f}, {0.0f, 1.0f, 0.0f}, 33.0f};
	struct bc_camera got;
	struct bc_msg m;
	uint64_t order = 0;
	REQUIRE(fake_start(&f, script_present, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		CHECK_EQ_INT(bc_client_info(c)->presenter, 0);
		CHECK_EQ_INT(bc_client_follow(c, true, &ei), 0);
		CHECK_EQ_INT(bc_client_info(c)->presenter, 9);
		CHECK(bc_client_info(c)->following);
		CHECK_EQ_INT(bc_client_present(c, true, &ei), 0);
		CHECK_EQ_INT(bc_client_info(c)->presenter, 3);
		CHECK(!bc_client_info(c)->following);
		CHECK_EQ_INT(bc_client_session_camera(c, &cam, &order, &ei), 0);
		CHECK_EQ_INT(order, 6);
		REQUIRE(bc_client_scene(c, &got) != NULL);
		CHECK(memcmp(&got, &cam, sizeof(got)) == 0);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.edit_applied.order, 7);
		REQUIRE(bc_client_scene(c, NULL) != NULL);
		CHECK(!bc_tree_get(bc_client_scene(c, NULL), 4, NULL, NULL));
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

/* ---- the roster --------------------------------------------------------------- */

/* SESSION_INFO with seq 0 for member 3 of session s1, listing ids[0..n)
 * ("loopback-test" for 3, "bob" for 5, unnamed otherwise). */
static void srv_members(struct fake *f, int fd, const uint32_t *ids, uint16_t n)
{
	struct bc_proto_member mem[4];
	struct bc_msg info = {.type = BC_MSG_SESSION_INFO};
	for (uint16_t i = 0; i < n; i++) {
		mem[i] = (struct bc_proto_member){.id = ids[i]};
		mem[i].role =
		    ids[i] == 5 ? BC_PROTO_ROLE_VIEWER : BC_PROTO_ROLE_EDITOR;
		if (ids[i] == 3) {
			mem[i].name =
			    (struct bc_proto_str){"loopback-test", 13};
		} else if (ids[i] == 5) {
			mem[i].name = (struct bc_proto_str){"bob", 3};
		}
	}
	info.session_info.session_id = 11;
	info.session_info.member_id = 3;
	info.session_info.role = BC_PROTO_ROLE_EDITOR;
	info.session_info.name = (struct bc_proto_str){"s1", 2};
	info.session_info.nmembers = n;
	info.session_info.members = mem;
	srv_send(f, fd, &info);
}

static void script_roster(struct fake *f, int fd)
{
	const uint32_t both[] = {3, 5}, three[] = {3, 5, 8}, me[] = {3};
	struct bc_msg m;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	srv_members(f, fd, both, 2);  /* bob joins */
	srv_members(f, fd, three, 3); /* member 8, unnamed, joins */
	srv_members(f, fd, me, 1);    /* both leave */
	if (!srv_expect(f, fd, BC_MSG_SESSION_LEAVE, &m)) {
		return;
	}
	srv_send(f, fd, &(struct bc_msg){.type = BC_MSG_OK, .seq = m.seq});
	if (!srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	srv_members(f, fd, both, 2); /* bob is back */
	srv_error(f, fd, 0, BC_ENOSESSION, false, "session s1 was deleted");
	SCHECK(f, !srv_next(f, fd, &m));
}

/* The roster follows every SESSION_INFO: joins add members with their
 * names and roles, leaves drop them (bc_client_member_find too); leaving
 * (the OK of SESSION_LEAVE) and the session's deletion empty it. */
static void test_roster_follows_joins_and_leaves(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	const struct bc_client_member *list = NULL, *bob;
	struct bc_msg m;
	size_t n = 99;
	REQUIRE(fake_start(&f, script_roster, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		CHECK_EQ_INT(bc_client_members(c, &list, &n), 0);
		CHECK(list == NULL && n == 0);
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		bc_client_members(c, &list, &n);
		REQUIRE(n == 1 && list);
		CHECK_EQ_INT(list[0].id, 3);
		CHECK_STREQ(list[0].name, "loopback-test");
		CHECK(bc_client_member_find(c, 5) == NULL);

		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.type, BC_MSG_SESSION_INFO);
		bc_client_members(c, &list, &n);
		REQUIRE(n == 2);
		CHECK(list[0].id == 3 && list[1].id == 5);
		REQUIRE((bob = bc_client_member_find(c, 5)) != NULL);
		CHECK_STREQ(bob->name, "bob");
		CHECK_EQ_INT(bob->role, BC_PROTO_ROLE_VIEWER);
		CHECK_EQ_INT(bc_client_info(c)->nmembers, 2);

		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		bc_client_members(c, &list, &n);
		REQUIRE(n == 3);
		CHECK_EQ_INT(list[2].id, 8);
		CHECK_STREQ(list[2].name, "");

		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		bc_client_members(c, &list, &n);
		CHECK(n == 1 && list[0].id == 3);
		CHECK(bc_client_member_find(c, 5) == NULL);
		CHECK(bc_client_member_find(c, 8) == NULL);
		CHECK(bc_client_member_find(c, 0) == NULL);

		m = (struct bc_msg){.type = BC_MSG_SESSION_LEAVE};
		REQUIRE(bc_client_send(c, &m, NULL) == 0);
		REQUIRE(bc_client_wait(c, BC_MSG_OK, m.seq, &m, 0, &ei) == 0);
		bc_client_members(c, &list, &n);
		CHECK(list == NULL && n == 0);
		CHECK_EQ_INT(bc_client_info(c)->session_id, 0);

		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		bc_client_members(c, &list, &n);
		CHECK_EQ_INT(n, 2);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.type, BC_MSG_ERROR);
		bc_client_members(c, &list, &n);
		CHECK(list == NULL && n == 0);
		CHECK(bc_client_member_find(c, 3) == NULL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

/* ---- frames and snapshots ---------------------------------------------------------- */

static void script_frames(struct fake *f, int fd)
{
	struct bc_msg m;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	if (!srv_expect(f, fd, BC_MSG_VIEW, &m)) {
		return;
	}
	SCHECK(f, m.view.width == 8 && m.view.height == 4);
	SCHECK(f, m.view.encoding == BC_PROTO_ENC_RAW);
	SCHECK(f, m.view.quality_interactive == 75 &&
	              m.view.quality_still == 90 && m.view.downscale == 1);
	srv_frame(f, fd, 0, BC_PROTO_FLAG_STILL, 8, 4, 10, 5);
	if (!srv_expect(f, fd, BC_MSG_CAMERA, &m)) {
		return;
	}
	SCHECK(f, m.camera.eye[0] == 1.0f && m.camera.fov_y_deg == 30.0f);
	SCHECK(f, m.flags == 0);
	if (!srv_expect(f, fd, BC_MSG_SNAPSHOT, &m)) {
		return;
	}
	SCHECK(f, m.snapshot.encoding == BC_PROTO_ENC_RAW);
	/* A stream frame comes first; the snapshot is the one with its seq. */
	srv_frame(f, fd, 0, BC_PROTO_FLAG_STILL, 8, 4, 20, 5);
	srv_frame(f, fd, m.seq, BC_PROTO_FLAG_STILL | BC_PROTO_FLAG_SNAPSHOT, 8,
	          4, 30, 5);
	SCHECK(f, !srv_next(f, fd, &m));
}

static void test_frames_and_snapshot(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_client_image img, snap;
	struct bc_camera cam = {{1, 0, 5}, {0, 0, 0}, {0, 1, 0}, 30.0f};
	struct bc_msg m;
	uint8_t *want;
	uint32_t seq;
	bc_client_image_init(&img);
	bc_client_image_init(&snap);
	REQUIRE(fake_start(&f, script_frames, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		REQUIRE(bc_client_view(
		            c,
		            &(struct bc_msg_view){.width = 8,
		                                  .height = 4,
		                                  .encoding = BC_PROTO_ENC_RAW},
		            &seq, &ei) == 0);
		REQUIRE(bc_client_wait(c, BC_MSG_FRAME, 0, &m, 0, &ei) == 0);
		CHECK(bc_client_info(c)->last_msg_bytes >
		      BC_PROTO_HEADER_SIZE + 8 * 4 * 4);
		REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
		want = pixels(8, 4, 10);
		CHECK(img.complete);
		CHECK_MEMEQ(img.rgba, want, 8 * 4 * 4);
		free(want);
		REQUIRE(bc_client_camera(c, &cam, false, &seq, &ei) == 0);
		REQUIRE(bc_client_snapshot(c, BC_PROTO_ENC_RAW, &snap, &ei) ==
		        0);
		want = pixels(8, 4, 30);
		CHECK(snap.complete);
		CHECK_MEMEQ(snap.rgba, want, 8 * 4 * 4);
		CHECK(snap.flags & BC_PROTO_FLAG_SNAPSHOT);
		free(want);
		CHECK_EQ_INT(
		    bc_client_snapshot(c, BC_PROTO_ENC_JPEG, &snap, &ei),
		    BC_EINVAL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
	bc_client_image_finish(&img);
	bc_client_image_finish(&snap);
}

/* ---- large messages -------------------------------------------------------------------- */

static void script_large(struct fake *f, int fd)
{
	struct bc_msg m, st = {.type = BC_MSG_SCENE_STATE};
	size_t len;
	uint8_t *bytes;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	bytes = scene_bytes(NULL, 8000, &len);
	SCHECK(f, len > 3 * BC_CLIENT_READ_CHUNK);
	st.scene_state.order = 6;
	st.scene_state.scene.ptr = bytes;
	st.scene_state.scene.len = (uint32_t)len;
	srv_send(f, fd, &st);
	bc_free(bytes);
	srv_frame(f, fd, 0, 0, 320, 240, 3, 6);
	/* Returning closes the connection. */
}

static void test_messages_larger_than_a_read(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	struct bc_msg m;
	uint8_t *want;
	bc_client_image_init(&img);
	REQUIRE(fake_start(&f, script_large, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.type, BC_MSG_SCENE_STATE);
		REQUIRE(bc_client_scene(c, NULL) != NULL);
		CHECK_EQ_INT(bc_tree_node_count(bc_client_scene(c, NULL)),
		             8001);
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
		want = pixels(320, 240, 3);
		CHECK_MEMEQ(img.rgba, want, 320 * 240 * 4);
		free(want);
		/* Then the server closes between messages. */
		CHECK_EQ_INT(bc_client_recv(c, &m, 5000), BC_ECLOSED);
		CHECK_EQ_INT(bc_client_recv(c, &m, 0), BC_ECLOSED);
		CHECK_EQ_INT(bc_client_error(c, &ei), BC_ECLOSED);
		CHECK(strstr(ei.msg, "closed") != NULL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
	bc_client_image_finish(&img);
}

/* ---- scenes in parts (PROTOCOL.md 7.10.1) ---------------------------------- */

/* The largest payload the fake server takes: the smallest a WELCOME may
 * say, so that a modest scene needs parts. */
#define PARTS_MAX_PAYLOAD 4096u

static void srv_state_part(struct fake *f, int fd, uint16_t flags,
                           uint32_t author_seq, const uint8_t *piece, size_t n)
{
	struct bc_msg st = {.type = BC_MSG_SCENE_STATE, .flags = flags};
	st.scene_state.order = 6;
	st.scene_state.author = 3;
	st.scene_state.author_seq = author_seq;
	st.scene_state.scene.ptr = piece;
	st.scene_state.scene.len = (uint32_t)n;
	srv_send(f, fd, &st);
}

static void script_parts(struct fake *f, int fd)
{
	struct bc_msg m;
	struct bc_proto_parts p;
	int nparts = 0, rc = 0;
	if (!srv_hello_with(f, fd, PARTS_MAX_PAYLOAD, BC_PROTO_FEATURE_PARTS,
	                    &m)) {
		return;
	}
	SCHECK(f, m.hello.has_features &&
	              (m.hello.features & BC_PROTO_FEATURE_PARTS));
	if (!srv_expect(f, fd, BC_MSG_SESSION_JOIN, &m)) {
		return;
	}
	srv_session(f, fd, m.seq, 5);
	/* The load: parts within the payload limit, one scene. */
	bc_proto_parts_init(&p, 0, true);
	while (rc == 0 && srv_expect(f, fd, BC_MSG_SCENE_LOAD, &m)) {
		SCHECK(f, 4u + m.scene_load.scene.len <= PARTS_MAX_PAYLOAD);
		SCHECK(f, (m.flags & BC_PROTO_FLAG_CONT) == (nparts ? 2 : 0));
		nparts++;
		rc = bc_proto_parts_add(&p, &m, &m, NULL);
	}
	SCHECK(f, rc == 1 && nparts >= 3);
	if (rc == 1) {
		/* Answered in parts of 5000 bytes, with the last part's seq. */
		const uint8_t *b = m.scene_load.scene.ptr;
		size_t len = m.scene_load.scene.len;
		for (size_t at = 0; at < len; at += 5000) {
			size_t n = len - at < 5000 ? len - at : 5000;
			srv_state_part(
			    f, fd,
			    (uint16_t)((at ? BC_PROTO_FLAG_CONT : 0u) |
			               (at + n < len ? BC_PROTO_FLAG_MORE
			                             : 0u)),
			    m.seq, b + at, n);
		}
		/* Then a broken one: a PING inside a scene's parts. */
		srv_state_part(f, fd, BC_PROTO_FLAG_MORE, 0, b, 10);
		m.type = BC_MSG_PING;
		m.seq = 1;
		m.flags = 0;
		m.ping.stamp = 1;
		srv_send(f, fd, &m);
	}
	bc_proto_parts_finish(&p);
	/* The client closes on the broken stream. */
	SCHECK(f, !srv_next(f, fd, &m) || m.type == BC_MSG_ERROR);
}

static void test_scenes_in_parts(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	uint64_t order = 0;
	size_t len;
	uint8_t *bytes = scene_bytes(NULL, 2000, &len);
	REQUIRE(len > 3 * PARTS_MAX_PAYLOAD);
	REQUIRE(fake_start(&f, script_parts, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		CHECK(bc_client_info(c)->features & BC_PROTO_FEATURE_PARTS);
		CHECK_EQ_INT(bc_client_info(c)->max_payload, PARTS_MAX_PAYLOAD);
		REQUIRE(bc_client_join(c, "s1", 0, 0, &ei) == 0);
		/* Sent in parts, answered in parts, mirrored whole. */
		CHECK_EQ_INT(bc_client_load_scene(c, bytes, len, &order, &ei),
		             0);
		CHECK(order == 6);
		REQUIRE(bc_client_scene(c, NULL) != NULL);
		CHECK_EQ_INT(bc_tree_node_count(bc_client_scene(c, NULL)),
		             2001);
		/* Parts cut by another message: the server's fault. */
		CHECK_EQ_INT(bc_client_recv(c, &m, 5000), BC_EPROTO_FLAGS);
		CHECK_EQ_INT(bc_client_error(c, &ei), BC_EPROTO_FLAGS);
		CHECK(strstr(ei.msg, "between the parts") != NULL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
	bc_free(bytes);
}

/* ---- failures ------------------------------------------------------------------------------ */

static void script_auth(struct fake *f, int fd)
{
	struct bc_msg m;
	if (!srv_expect(f, fd, BC_MSG_HELLO, &m)) {
		return;
	}
	SCHECK(f, m.hello.token.len == 6 &&
	              memcmp(m.hello.token.ptr, "wrong!", 6) == 0);
	srv_error(f, fd, m.seq, BC_EAUTH, true, "a valid token is required");
}

static void test_auth_error_is_reported(void)
{
	struct fake f;
	struct bc_client *c = (struct bc_client *)&f; /* must be reset */
	struct bc_errinfo ei = {0};
	REQUIRE(fake_start(&f, script_auth, false) == 0);
	CHECK_EQ_INT(
	    bc_client_connect(
	        &c, &(struct bc_client_opts){.addr = f.addr, .token = "wrong!"},
	        &ei),
	    BC_EAUTH);
	CHECK(c == NULL);
	CHECK(strstr(ei.msg, "a valid token is required") != NULL);
	fake_stop(&f);
}

static void script_http(struct fake *f, int fd)
{
	static const char reply[] = "HTTP/1.1 400 Bad Request\r\n\r\n";
	struct bc_msg m;
	(void)srv_next(f, fd, &m);
	write_all(fd, reply, sizeof(reply) - 1);
}

static void test_not_a_blobcast_server(void)
{
	struct fake f;
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	REQUIRE(fake_start(&f, script_http, false) == 0);
	CHECK_EQ_INT(bc_client_connect(
	                 &c, &(struct bc_client_opts){.addr = f.addr}, &ei),
	             BC_EPROTO_MAGIC);
	CHECK(c == NULL);
	fake_stop(&f);
}

static void script_silent(struct fake *f, int fd)
{
	struct bc_msg m;
	(void)srv_expect(f, fd, BC_MSG_HELLO, &m);
	/* Say nothing until the client gives up and closes. */
	SCHECK(f, !srv_next(f, fd, &m));
}

static void test_silent_server_times_out(void)
{
	struct fake f;
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	REQUIRE(fake_start(&f, script_silent, false) == 0);
	CHECK_EQ_INT(
	    bc_client_connect(
	        &c, &(struct bc_client_opts){.addr = f.addr, .timeout_ms = 150},
	        &ei),
	    BC_ETIMEOUT);
	CHECK(strstr(ei.msg, "WELCOME") != NULL);
	fake_stop(&f);
}

static void script_truncated(struct fake *f, int fd)
{
	struct bc_msg m;
	uint8_t half[10];
	struct bc_proto_buf b;
	if (!srv_hello(f, fd)) {
		return;
	}
	m = (struct bc_msg){.type = BC_MSG_PONG};
	m.ping.stamp = 99;
	bc_proto_buf_init(&b, 0);
	bc_proto_encode(&b, &m, NULL);
	memcpy(half, b.data, sizeof(half));
	bc_proto_buf_finish(&b);
	write_all(fd, half, sizeof(half));
}

static void test_close_inside_a_message_is_sticky(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_msg m = {.type = BC_MSG_PING};
	REQUIRE(fake_start(&f, script_truncated, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		CHECK_EQ_INT(bc_client_recv(c, &m, 5000), BC_EPROTO_TRUNCATED);
		CHECK_EQ_INT(bc_client_recv(c, &m, 5000), BC_EPROTO_TRUNCATED);
		m = (struct bc_msg){.type = BC_MSG_PING};
		CHECK_EQ_INT(bc_client_send(c, &m, NULL), BC_EPROTO_TRUNCATED);
		CHECK_EQ_INT(bc_client_error(c, &ei), BC_EPROTO_TRUNCATED);
		CHECK(strstr(ei.msg, "mid-message") != NULL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

static void script_fatal(struct fake *f, int fd)
{
	if (!srv_hello(f, fd)) {
		return;
	}
	srv_error(f, fd, 0, BC_EPROTO_LENGTH, true, "payload too long");
}

static void test_fatal_error_becomes_sticky(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	REQUIRE(fake_start(&f, script_fatal, false) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		REQUIRE(bc_client_recv(c, &m, 5000) == 1);
		CHECK_EQ_INT(m.type, BC_MSG_ERROR);
		CHECK(m.flags & BC_PROTO_FLAG_FATAL);
		CHECK_EQ_INT(bc_client_recv(c, &m, 5000), BC_EPROTO_LENGTH);
		CHECK_EQ_INT(bc_client_error(c, &ei), BC_EPROTO_LENGTH);
		CHECK(strstr(ei.msg, "payload too long") != NULL);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

static void script_unix(struct fake *f, int fd)
{
	struct bc_msg m;
	if (!srv_hello(f, fd) || !srv_expect(f, fd, BC_MSG_PING, &m)) {
		return;
	}
	m.type = BC_MSG_PONG;
	srv_send(f, fd, &m);
	SCHECK(f, !srv_next(f, fd, &m));
}

static void test_unix_socket_ping(void)
{
	struct fake f;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_msg m = {.type = BC_MSG_PING};
	uint32_t seq;
	REQUIRE(fake_start(&f, script_unix, true) == 0);
	c = connect_to(&f, 5000);
	if (c) {
		m.ping.stamp = 0x1122334455667788ull;
		REQUIRE(bc_client_send(c, &m, &seq) == 0);
		CHECK_EQ_INT(m.seq, seq);
		REQUIRE(bc_client_wait(c, BC_MSG_PONG, seq, &m, 0, &ei) == 0);
		CHECK(m.ping.stamp == 0x1122334455667788ull);
		/* Nothing more: a zero timeout returns at once. */
		CHECK_EQ_INT(bc_client_recv(c, &m, 0), 0);
		CHECK_EQ_INT(bc_client_wait(c, BC_MSG_PONG, 0, &m, 50, &ei),
		             BC_ETIMEOUT);
		CHECK_EQ_INT(bc_client_error(c, NULL), 0);
	}
	bc_client_destroy(c);
	fake_stop(&f);
}

static void test_refused_and_bad_options(void)
{
	struct sockaddr_in in = {.sin_family = AF_INET};
	socklen_t len = sizeof(in);
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	char addr[64];
	int fd = socket(AF_INET, SOCK_STREAM, 0);
	in.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	/* A port that was just free: nobody listens on it. */
	REQUIRE(fd >= 0 && bind(fd, (struct sockaddr *)&in, sizeof(in)) == 0);
	REQUIRE(getsockname(fd, (struct sockaddr *)&in, &len) == 0);
	close(fd);
	snprintf(addr, sizeof(addr), "127.0.0.1:%u",
	         (unsigned)ntohs(in.sin_port));
	CHECK_EQ_INT(
	    bc_client_connect(&c, &(struct bc_client_opts){.addr = addr}, &ei),
	    BC_EIO);
	CHECK(strstr(ei.msg, "cannot connect") != NULL);
	CHECK_EQ_INT(
	    bc_client_connect(
	        &c, &(struct bc_client_opts){.addr = "unix:/nonexistent/x"},
	        &ei),
	    BC_EIO);
	CHECK_EQ_INT(
	    bc_client_connect(&c, &(struct bc_client_opts){.addr = "h:0"}, &ei),
	    BC_EINVAL);
	CHECK_EQ_INT(
	    bc_client_connect(
	        &c, &(struct bc_client_opts){.addr = addr, .encodings = 0x80},
	        &ei),
	    BC_EINVAL);
	CHECK(c == NULL);
	bc_client_destroy(NULL);
}

/* ---- allocation failures ------------------------------------------------- */

/* Serves whatever a client asks, for as long as it stays; a client that
 * vanishes at any point is normal here. */
static void script_serve(struct fake *f, int fd)
{
	struct bc_msg m;
	if (!srv_next(f, fd, &m) || m.type != BC_MSG_HELLO) {
		return;
	}
	bc_proto_reader_hello_done(&f->r);
	{
		struct bc_msg w = {.type = BC_MSG_WELCOME, .seq = m.seq};
		w.welcome.version = BC_PROTO_VERSION;
		w.welcome.connection_id = 7;
		w.welcome.max_payload = BC_PROTO_MAX_PAYLOAD;
		w.welcome.max_frame_bytes = 1u << 20;
		w.welcome.max_nodes = 1000;
		w.welcome.max_dim = 4096;
		w.welcome.max_members = 64;
		w.welcome.max_edit_ops = 1024;
		srv_send(f, fd, &w);
	}
	while (srv_next(f, fd, &m)) {
		if (m.type == BC_MSG_SESSION_JOIN) {
			srv_session(f, fd, m.seq, 5);
		} else if (m.type == BC_MSG_EDIT) {
			struct bc_msg ea = {.type = BC_MSG_EDIT_APPLIED};
			ea.edit_applied.order = 6;
			ea.edit_applied.author = 3;
			ea.edit_applied.author_seq = m.seq;
			ea.edit_applied.nops = m.edit.nops;
			ea.edit_applied.ops = m.edit.ops;
			srv_send(f, fd, &ea);
		} else if (m.type == BC_MSG_VIEW) {
			srv_frame(f, fd, 0, BC_PROTO_FLAG_STILL, 16, 8, 1, 6);
		} else if (m.type == BC_MSG_GET_STATS) {
			struct bc_msg st = {.type = BC_MSG_STATS, .seq = m.seq};
			srv_send(f, fd, &st);
		}
	}
}

static unsigned long quiet_count;

static void quiet(enum bc_log_level level, const char *file, int line,
                  const char *fmt, va_list args)
{
	(void)level;
	(void)file;
	(void)line;
	(void)fmt;
	(void)args;
	quiet_count++;
}

/* Connect, join, edit, frame, stats, with the client's Nth allocation
 * failing, for every N until all succeed: each failure is reported as an
 * error, never a crash, and frees what it took (ASan checks at exit). */
static void test_allocation_failures_are_reported(void)
{
	const char *kv[] = {"radius=0.3", "color=0,1,0"};
	unsigned long n;
	/* A mirror that cannot be built is logged; that is expected here. */
	bc_log_set_callback(quiet);
	for (n = 1; n < 2000; n++) {
		struct fake f;
		struct bc_client *c = NULL;
		struct bc_client_image img;
		struct bc_errinfo ei = {0};
		struct bc_msg_stats st;
		struct bc_msg m;
		uint32_t seq;
		int rc;
		REQUIRE(fake_fork(&f, script_serve) == 0);
		bc_client_image_init(&img);
		bc_alloc_fail_after(n);
		rc = bc_client_connect(&c,
		                       &(struct bc_client_opts){
		                           .addr = f.addr, .timeout_ms = 5000},
		                       &ei);
		if (!rc) {
			rc = bc_client_join(c, "s1", 0, 0, &ei);
		}
		if (!rc) {
			rc = bc_client_edit_kv(c, 2, kv, 2, false, &seq, &ei);
		}
		if (!rc) {
			rc = bc_client_wait_applied(c, seq, NULL, &ei);
		}
		if (!rc) {
			rc = bc_client_view(
			    c, &(struct bc_msg_view){.width = 16, .height = 8},
			    NULL, &ei);
		}
		if (!rc) {
			rc = bc_client_wait(c, BC_MSG_FRAME, 0, &m, 0, &ei);
		}
		if (!rc) {
			rc = bc_client_image_apply(&img, &m, &ei);
		}
		if (!rc) {
			rc = bc_client_stats(c, &st, &ei);
		}
		bc_alloc_fail_after(0);
		bc_client_destroy(c);
		bc_client_image_finish(&img);
		fake_stop(&f);
		if (rc == 0) {
			break;
		}
		/* Out of memory, or (when the mirror could not be built) no
		 * scene to edit against. */
		if (rc != BC_ENOMEM && rc != BC_ESTATE) {
			fprintf(stderr, "  allocation %lu: %s (%s)\n", n,
			        bc_err_name(rc), ei.msg);
			CHECK(0);
		}
	}
	bc_log_set_callback(NULL);
	CHECK(n > 5 && n < 2000);
	CHECK(quiet_count > 0);
	printf("  %lu allocation points failed in turn\n", n - 1);
}

static const struct bc_test tests[] = {
    {"scenes_in_parts", test_scenes_in_parts},
    {"handshake_join_or_create_and_stats",
     test_handshake_join_or_create_and_stats},
    {"session_errors_carry_server_text", test_session_errors_carry_server_text},
    {"edit_is_acknowledged_among_other_edits",
     test_edit_is_acknowledged_among_other_edits},
    {"mirror_follows_structural_edits", test_mirror_follows_structural_edits},
    {"bare_mirror_follows_structural_edits",
     test_bare_mirror_follows_structural_edits},
    {"frames_and_snapshot", test_frames_and_snapshot},
    {"messages_larger_than_a_read", test_messages_larger_than_a_read},
    {"auth_error_is_reported", test_auth_error_is_reported},
    {"not_a_blobcast_server", test_not_a_blobcast_server},
    {"silent_server_times_out", test_silent_server_times_out},
    {"close_inside_a_message_is_sticky", test_close_inside_a_message_is_sticky},
    {"fatal_error_becomes_sticky", test_fatal_error_becomes_sticky},
    {"unix_socket_ping", test_unix_socket_ping},
    {"refused_and_bad_options", test_refused_and_bad_options},
    {"allocation_failures_are_reported", test_allocation_failures_are_reported},
    {"presenting_and_session_camera", test_presenting_and_session_camera},
    {"roster_follows_joins_and_leaves", test_roster_follows_joins_and_leaves},
};

BC_TEST_MAIN(tests)
