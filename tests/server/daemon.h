/*
 * Test helpers for driving a real blobcastd: start it on a temporary data
 * directory and Unix socket, connect raw protocol clients (the bc_proto
 * codec over a socket, no client library), send and await messages.
 */
#ifndef BLOBCAST_TESTS_DAEMON_H
#define BLOBCAST_TESTS_DAEMON_H

#include <arpa/inet.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/proto.h"

#ifndef BLOBCASTD_PATH
#define BLOBCASTD_PATH "blobcastd"
#endif
/* The daemon executable (benchmarks point it at a Release build). */
static const char *daemon_path = BLOBCASTD_PATH;
/* When set, the next daemons started write their log (stderr) to this
 * file, truncated at each start, for tests that check what was logged. */
static const char *daemon_log_path;
/* When set, the next daemons started run with ASan filling what they free
 * (max_free_fill_size, added to ASAN_OPTIONS): memory read after it was
 * freed then holds garbage instead of bytes that still look right, also
 * where the reader is not instrumented (libuv, Mesa). */
static bool daemon_fill_freed;

/* In a daemon's child before exec: what the settings above ask of its
 * environment. */
static inline void daemon_child_env(void)
{
	const char *asan = getenv("ASAN_OPTIONS");
	char fill[1024];
	if (!daemon_fill_freed) {
		return;
	}
	snprintf(fill, sizeof(fill),
	         "%s%smax_free_fill_size=65536:free_fill_byte=190",
	         asan ? asan : "", asan && *asan ? ":" : "");
	setenv("ASAN_OPTIONS", fill, 1);
}

struct daemon {
	pid_t pid;
	char dir[80];
	char sock[90]; /* fits sockaddr_un.sun_path (108) */
};

static inline void t_sleep_ms(long ms)
{
	struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
	nanosleep(&ts, NULL);
}

static inline int64_t t_now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* The port of the TCP listener on 127.0.0.1 that a daemon whose stderr
 * goes to log announced ("blobcastd: listening on 127.0.0.1:PORT"), or 0
 * when the line has not come within 30 s. The daemon announces once it
 * listens on every address, so one that already answers on its Unix
 * socket may not have written the line yet (a loaded machine showed it). */
static inline int daemon_log_port(const char *log)
{
	static const char needle[] = "blobcastd: listening on 127.0.0.1:";
	int64_t end = t_now_ms() + 30000;
	do {
		char buf[8192];
		FILE *f = fopen(log, "r");
		size_t n = f ? fread(buf, 1, sizeof(buf) - 1, f) : 0;
		const char *p;
		if (f) {
			fclose(f);
		}
		buf[n] = '\0';
		if ((p = strstr(buf, needle))) {
			return atoi(p + strlen(needle));
		}
		t_sleep_ms(25);
	} while (t_now_ms() < end);
	return 0;
}

/* The daemons started and not yet stopped: a test that ends early (a
 * failed REQUIRE) leaves its daemon to daemon_tests_run, which kills it,
 * rather than running on after the test program. */
static pid_t daemon_running[32];

static inline void daemon_track(pid_t pid, bool on)
{
	for (size_t i = 0; i < sizeof(daemon_running) / sizeof(pid_t); i++) {
		if (daemon_running[i] == (on ? 0 : pid)) {
			daemon_running[i] = on ? pid : 0;
			return;
		}
	}
}

/* Starts blobcastd on dir (created by the caller or here), with up to
 * eight extra options (NULL-terminated; extra may be NULL; more: -1). */
static inline int daemon_start_with(struct daemon *d, const char *dir,
                                    const char *const *extra)
{
	const char *more[9] = {NULL};
	int nmore = 0;
	for (; extra && nmore < 8 && extra[nmore]; nmore++) {
		more[nmore] = extra[nmore];
	}
	if (extra && extra[nmore]) {
		return -1;
	}
	if (strlen(dir) + 6 > sizeof(d->sock)) {
		return -1;
	}
	memcpy(d->dir, dir, strlen(dir) + 1);
	memcpy(d->sock, dir, strlen(dir));
	memcpy(d->sock + strlen(dir), ".sock", 6);
	d->pid = fork();
	if (d->pid < 0) {
		return -1;
	}
	if (d->pid == 0) {
		int devnull = open("/dev/null", O_WRONLY);
		daemon_child_env();
		if (daemon_log_path) {
			int log = open(daemon_log_path,
			               O_WRONLY | O_CREAT | O_TRUNC, 0600);
			if (log >= 0) {
				dup2(log, 2);
			}
		} else if (devnull >= 0 && !getenv("BLOBCAST_TEST_VERBOSE")) {
			dup2(devnull, 2);
		}
		execl(daemon_path, "blobcastd", "--listen", "none", "--unix",
		      d->sock, "--data", d->dir, "--log", "info", more[0],
		      more[1], more[2], more[3], more[4], more[5], more[6],
		      more[7], (char *)NULL);
		_exit(127);
	}
	daemon_track(d->pid, true);
	/* Wait for the socket to accept. */
	for (int i = 0; i < 400; i++) {
		struct sockaddr_un sa = {.sun_family = AF_UNIX};
		int fd = socket(AF_UNIX, SOCK_STREAM, 0);
		memcpy(sa.sun_path, d->sock, strlen(d->sock) + 1);
		if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) == 0) {
			close(fd);
			return 0;
		}
		close(fd);
		t_sleep_ms(25);
	}
	return -1;
}

/* How many times a log file (daemon_log_path) holds text, in its first
 * 64 KiB. */
static inline unsigned daemon_log_count(const char *file, const char *text)
{
	static char buf[1 << 16];
	FILE *f = fopen(file, "r");
	unsigned count = 0;
	size_t n;
	if (!f) {
		return 0;
	}
	n = fread(buf, 1, sizeof(buf) - 1, f);
	fclose(f);
	buf[n] = '\0';
	for (const char *p = buf; (p = strstr(p, text)); p += strlen(text)) {
		count++;
	}
	return count;
}

static inline int daemon_start(struct daemon *d, const char *dir)
{
	return daemon_start_with(d, dir, NULL);
}

static inline int daemon_stop(struct daemon *d, int sig)
{
	int status = 0;
	if (d->pid <= 0) {
		return -1;
	}
	kill(d->pid, sig);
	waitpid(d->pid, &status, 0);
	daemon_track(d->pid, false);
	d->pid = 0;
	return status;
}

struct conn {
	int fd;
	struct bc_proto_reader r;
	uint32_t seq;
	struct bc_msg m; /* the last message received */
};

static inline int conn_open(struct conn *c, const struct daemon *d)
{
	struct sockaddr_un sa = {.sun_family = AF_UNIX};
	memset(c, 0, sizeof(*c));
	c->fd = socket(AF_UNIX, SOCK_STREAM, 0);
	memcpy(sa.sun_path, d->sock, strlen(d->sock) + 1);
	if (connect(c->fd, (struct sockaddr *)&sa, sizeof(sa)) != 0) {
		close(c->fd);
		return -1;
	}
	bc_proto_reader_init(&c->r, &(struct bc_proto_reader_opts){
	                                .side = BC_PROTO_SIDE_CLIENT});
	return 0;
}

static inline void conn_close(struct conn *c)
{
	if (c->fd > 0) {
		close(c->fd);
	}
	bc_proto_reader_finish(&c->r);
	c->fd = -1;
}

static inline int send_raw(struct conn *c, const void *bytes, size_t n)
{
	const uint8_t *p = bytes;
	while (n > 0) {
		ssize_t k = send(c->fd, p, n, MSG_NOSIGNAL);
		if (k <= 0) {
			return -1;
		}
		p += k;
		n -= (size_t)k;
	}
	return 0;
}

/* Sends m with the next seq; returns that seq, 0 on failure. */
static inline uint32_t conn_send(struct conn *c, struct bc_msg *m)
{
	struct bc_proto_buf b;
	int rc;
	m->seq = ++c->seq;
	bc_proto_buf_init(&b, 0);
	rc = bc_proto_encode(&b, m, NULL);
	if (!rc) {
		rc = send_raw(c, b.data, b.len);
	}
	bc_proto_buf_finish(&b);
	return rc ? 0 : m->seq;
}

/* Receives the next message into c->m: 1, 0 on timeout, -1 closed/error. */
static inline int conn_recv(struct conn *c, int timeout_ms)
{
	int64_t end = t_now_ms() + timeout_ms;
	for (;;) {
		uint8_t buf[65536];
		struct pollfd pfd = {.fd = c->fd, .events = POLLIN};
		int rc = bc_proto_reader_next(&c->r, &c->m);
		int64_t left;
		ssize_t n;
		if (rc != 0) {
			return rc > 0 ? 1 : -1;
		}
		/* A zero timeout still takes what is already there. */
		left = end - t_now_ms();
		if (poll(&pfd, 1, left > 0 ? (int)left : 0) <= 0) {
			return 0;
		}
		n = recv(c->fd, buf, sizeof(buf), 0);
		if (n <= 0) {
			return -1;
		}
		if (bc_proto_reader_feed(&c->r, buf, (size_t)n)) {
			return -1;
		}
	}
}

/* Receives until a message of type arrives (others are skipped). */
static inline int conn_expect(struct conn *c, enum bc_msg_type type,
                              int timeout_ms)
{
	int64_t end = t_now_ms() + timeout_ms;
	for (;;) {
		int64_t left = end - t_now_ms();
		int rc;
		if (left <= 0) {
			return 0;
		}
		rc = conn_recv(c, (int)left);
		if (rc <= 0) {
			return rc;
		}
		if (c->m.type == type) {
			return 1;
		}
	}
}

/* HELLO listing the encodings in mask (bit e - 1: encoding e) and, when
 * announce, the features (PROTOCOL.md 4); without, an earlier client's
 * HELLO. The WELCOME must carry the features field exactly when it was
 * announced. */
static inline int conn_hello_as(struct conn *c, const char *name, uint8_t mask,
                                bool announce, uint32_t features)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	m.hello.version_min = 1;
	m.hello.version_max = 1;
	m.hello.encodings = mask;
	m.hello.client_name.ptr = name;
	m.hello.client_name.len = (uint32_t)strlen(name);
	m.hello.has_features = announce;
	m.hello.features = features;
	if (!conn_send(c, &m)) {
		return -1;
	}
	if (conn_expect(c, BC_MSG_WELCOME, 5000) != 1 ||
	    c->m.welcome.has_features != announce ||
	    c->m.welcome.features != (features & BC_PROTO_FEATURES_ALL)) {
		return -1;
	}
	return 0;
}

/* HELLO of a client of this text: every feature announced. */
static inline int conn_hello_enc(struct conn *c, const char *name, uint8_t mask)
{
	return conn_hello_as(c, name, mask, true, BC_PROTO_FEATURES_READ);
}

static inline int conn_hello(struct conn *c, const char *name)
{
	return conn_hello_enc(c, name, BC_PROTO_ENCODINGS_ALL);
}

static inline int conn_join(struct conn *c, const char *session,
                            enum bc_proto_role role, bool create)
{
	struct bc_msg m = {.type = create ? BC_MSG_SESSION_CREATE
	                                  : BC_MSG_SESSION_JOIN};
	m.session.role = role;
	m.session.name.ptr = session;
	m.session.name.len = (uint32_t)strlen(session);
	if (!conn_send(c, &m)) {
		return -1;
	}
	return conn_expect(c, BC_MSG_SESSION_INFO, 5000) == 1 ? 0 : -1;
}

/* VIEW of w x h in enc, qualities 60 and 90, coarsest block downscale. */
static inline uint32_t conn_view_scaled(struct conn *c, uint16_t w, uint16_t h,
                                        enum bc_proto_encoding enc,
                                        uint8_t downscale)
{
	struct bc_msg m = {.type = BC_MSG_VIEW};
	m.view.width = w;
	m.view.height = h;
	m.view.encoding = enc;
	m.view.quality_interactive = 60;
	m.view.quality_still = 90;
	m.view.downscale = downscale;
	return conn_send(c, &m);
}

static inline uint32_t conn_view(struct conn *c, uint16_t w, uint16_t h,
                                 enum bc_proto_encoding enc)
{
	return conn_view_scaled(c, w, h, enc, 2);
}

/* A SET edit of one translate field on node id. */
static inline uint32_t conn_move(struct conn *c, uint32_t id, float x, float y,
                                 float z, bool interacting)
{
	struct bc_proto_field f = {
	    .field = BC_PROTO_FIELD_TRANSLATE, .count = 3, .v = {x, y, z}};
	struct bc_proto_edit_op op = {
	    .kind = BC_PROTO_EDIT_SET, .node = id, .nfields = 1, .fields = &f};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	m.edit.nops = 1;
	m.edit.ops = &op;
	return conn_send(c, &m);
}

/* The answer to an edit, UNDO or REDO of seq from member (c's member
 * id): its EDIT_APPLIED's order (c->m holds it), or 0 after an ERROR for
 * seq (c->m holds that) or 20 s without either. */
static inline uint64_t conn_edit_answer(struct conn *c, uint32_t member,
                                        uint32_t seq)
{
	int64_t end = t_now_ms() + 20000;
	while (t_now_ms() < end) {
		if (conn_recv(c, 200) != 1) {
			continue;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			return 0;
		}
		if (c->m.type == BC_MSG_EDIT_APPLIED &&
		    c->m.edit_applied.author == member &&
		    c->m.edit_applied.author_seq == seq) {
			return c->m.edit_applied.order;
		}
	}
	c->m.type = BC_MSG_INVALID;
	return 0;
}

/* A free TCP port on 127.0.0.1 (bound, then let go), 0 when none. */
static inline int daemon_free_port(void)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	socklen_t len = sizeof(sa);
	int fd = socket(AF_INET, SOCK_STREAM, 0), port = 0;
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (fd >= 0 && bind(fd, (struct sockaddr *)&sa, sizeof(sa)) == 0 &&
	    getsockname(fd, (struct sockaddr *)&sa, &len) == 0) {
		port = ntohs(sa.sin_port);
	}
	if (fd >= 0) {
		close(fd);
	}
	return port;
}

/* Bytes of session name's journals in data directory dir
 * (DIR/sessions/NAME/journal-*.bin), -1 when it cannot be read. */
static inline long long session_journal_bytes(const char *dir, const char *name)
{
	char path[512];
	long long total = 0;
	DIR *dp;
	struct dirent *de;
	snprintf(path, sizeof(path), "%s/sessions/%s", dir, name);
	if (!(dp = opendir(path))) {
		return -1;
	}
	while ((de = readdir(dp))) {
		struct stat st;
		char file[1024];
		if (strncmp(de->d_name, "journal-", 8) != 0) {
			continue;
		}
		snprintf(file, sizeof(file), "%s/%s", path, de->d_name);
		if (stat(file, &st) == 0) {
			total += (long long)st.st_size;
		}
	}
	closedir(dp);
	return total;
}

#if defined(BLOBCAST_TESTS_TEST_H)
/* Runs tests with SIGPIPE ignored (a daemon may close first) in a fresh
 * directory /tmp/bc-NAME-test-PID, written into dir (n bytes): removed
 * when every test passed, kept for inspection when one failed. */
static inline int daemon_tests_run(const char *name, char *dir, size_t n,
                                   const struct bc_test *tests, size_t ntests,
                                   int argc, char **argv)
{
	char cmd[128];
	int rc;
	signal(SIGPIPE, SIG_IGN);
	snprintf(dir, n, "/tmp/bc-%s-test-%d", name, (int)getpid());
	mkdir(dir, 0700);
	rc = bc_test_run(tests, ntests, argc, argv);
	for (size_t i = 0; i < sizeof(daemon_running) / sizeof(pid_t); i++) {
		if (daemon_running[i] > 0) {
			fprintf(stderr,
			        "a test left blobcastd %d running: "
			        "killed\n",
			        (int)daemon_running[i]);
			kill(daemon_running[i], SIGKILL);
			waitpid(daemon_running[i], NULL, 0);
			rc = 1;
		}
	}
	if (rc == 0) {
		snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
		if (system(cmd) != 0) {
			fprintf(stderr, "could not remove %s\n", dir);
		}
	}
	return rc;
}
#endif

#if defined(BLOBCAST_SCENE_H)
/* The scene of the SCENE_STATE in c->m, decoded; NULL when it does not
 * decode. The caller destroys it. (Only where blobcast/scene.h is
 * included before this header.) */
static inline struct bc_tree *scene_of(const struct conn *c)
{
	struct bc_tree *t = bc_tree_create();
	if (!t ||
	    bc_scene_decode(c->m.scene_state.scene.ptr,
	                    c->m.scene_state.scene.len, t, NULL, NULL, NULL)) {
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

#if defined(BLOBCAST_TESTS_TEST_H)
/* Loads tree t (taking it) with camera cam into c's session and waits
 * for the SCENE_STATE that answers it. */
static inline void conn_load_tree(struct conn *c, struct bc_tree *t,
                                  const struct bc_camera *cam)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint32_t seq;
	int rc = bc_scene_encode(t, cam, &bytes, &len);
	bc_tree_destroy(t);
	REQUIRE(rc == 0);
	m.scene_load.scene.ptr = bytes;
	m.scene_load.scene.len = (uint32_t)len;
	seq = conn_send(c, &m);
	bc_free(bytes);
	REQUIRE(seq);
	do {
		REQUIRE(conn_expect(c, BC_MSG_SCENE_STATE, 60000) == 1);
	} while (c->m.scene_state.author_seq != seq);
}

/* Loads scene JSON into c's session (conn_load_tree). */
static inline void conn_load_json(struct conn *c, const char *json)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	int parsed = t ? bc_scene_parse_json(json, strlen(json), t, &cam, NULL)
	               : BC_ENOMEM;
	if (parsed) {
		bc_tree_destroy(t);
	}
	REQUIRE(parsed == 0);
	conn_load_tree(c, t, &cam);
}
#endif
#endif

#endif
