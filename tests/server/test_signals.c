/*
 * blobcastd as an operator meets it: SIGHUP re-reads the tokens of the
 * --config file (and a bad file keeps the old ones), the warning when a TCP
 * listener is reachable from other hosts with no tokens, and log lines a
 * client's name cannot forge. The daemon's stderr goes to a file here so
 * the tests can read its log and the TCP port it was given.
 */
#include <netinet/in.h>
#include <arpa/inet.h>

#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

static void make_dir_name(char *out, size_t n, const char *what)
{
	snprintf(out, n, "%s/%s", base_dir, what);
}

/* The daemon's log file: DIR.log. */
static void log_path(char *out, size_t n, const struct daemon *d)
{
	snprintf(out, n, "%s.log", d->dir);
}

/* Reads the whole log of d into buf (NUL-terminated); returns its length. */
static size_t read_log(const struct daemon *d, char *buf, size_t n)
{
	char path[128];
	FILE *f;
	size_t len = 0;
	log_path(path, sizeof(path), d);
	f = fopen(path, "r");
	if (f) {
		len = fread(buf, 1, n - 1, f);
		fclose(f);
	}
	buf[len] = '\0';
	return len;
}

/* Waits until the log of d holds needle; returns 1, or 0 after timeout. */
static int wait_log(const struct daemon *d, const char *needle, int timeout_ms)
{
	static char buf[1 << 16];
	int64_t end = t_now_ms() + timeout_ms;
	do {
		read_log(d, buf, sizeof(buf));
		if (strstr(buf, needle)) {
			return 1;
		}
		t_sleep_ms(20);
	} while (t_now_ms() < end);
	fprintf(stderr, "  log never said \"%s\"; it holds:\n%s\n", needle,
	        buf);
	return 0;
}

/* Starts blobcastd on dir with its Unix socket, --log info, stderr in
 * DIR.log and up to four extra options, and waits until its signal
 * handlers are in place (the "backend" line comes after them). */
static int start(struct daemon *d, const char *dir, const char *const *extra)
{
	const char *more[5] = {NULL};
	char path[128];
	for (int i = 0; extra && i < 4 && extra[i]; i++) {
		more[i] = extra[i];
	}
	memset(d, 0, sizeof(*d));
	snprintf(d->dir, sizeof(d->dir), "%s", dir);
	snprintf(d->sock, sizeof(d->sock), "%s.sock", dir);
	log_path(path, sizeof(path), d);
	d->pid = fork();
	if (d->pid < 0) {
		return -1;
	}
	if (d->pid == 0) {
		int fd =
		    open(path, O_WRONLY | O_CREAT | O_TRUNC | O_APPEND, 0600);
		if (fd >= 0) {
			dup2(fd, 2);
		}
		daemon_child_env();
		execl(daemon_path, "blobcastd", "--listen", "none", "--unix",
		      d->sock, "--data", d->dir, "--log", "info", more[0],
		      more[1], more[2], more[3], (char *)NULL);
		_exit(127);
	}
	return wait_log(d, "blobcastd: backend ", 10000) ? 0 : -1;
}

/* The port of the daemon's TCP listener on 127.0.0.1, 0 if none. */
static int tcp_port(const struct daemon *d)
{
	char path[128];
	log_path(path, sizeof(path), d);
	return daemon_log_port(path);
}

static int tcp_open(struct conn *c, int port)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	memset(c, 0, sizeof(*c));
	sa.sin_port = htons((uint16_t)port);
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	c->fd = socket(AF_INET, SOCK_STREAM, 0);
	if (c->fd < 0 || connect(c->fd, (struct sockaddr *)&sa, sizeof(sa))) {
		if (c->fd >= 0) {
			close(c->fd);
		}
		c->fd = -1;
		return -1;
	}
	bc_proto_reader_init(&c->r, &(struct bc_proto_reader_opts){
	                                .side = BC_PROTO_SIDE_CLIENT});
	return 0;
}

/* HELLO with token: 0 on WELCOME, the (negative) error code of an ERROR
 * answer, 1 when nothing came. */
static int hello_with(struct conn *c, const char *name, const char *token)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	m.hello.version_min = 1;
	m.hello.version_max = 1;
	m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
	m.hello.client_name.ptr = name;
	m.hello.client_name.len = (uint32_t)strlen(name);
	m.hello.token.ptr = token;
	m.hello.token.len = (uint32_t)strlen(token);
	if (!conn_send(c, &m)) {
		return 1;
	}
	for (;;) {
		if (conn_recv(c, 5000) != 1) {
			return 1;
		}
		if (c->m.type == BC_MSG_WELCOME) {
			return 0;
		}
		if (c->m.type == BC_MSG_ERROR) {
			return -(int)c->m.error.code;
		}
	}
}

/* A fresh TCP connection's answer to HELLO with token (see hello_with). */
static int try_token(int port, const char *token)
{
	struct conn c;
	int rc;
	if (tcp_open(&c, port)) {
		return 1;
	}
	rc = hello_with(&c, "probe", token);
	conn_close(&c);
	return rc;
}

static int write_file(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");
	int ok;
	if (!f) {
		return -1;
	}
	ok = fputs(text, f) >= 0;
	return (fclose(f) == 0 && ok) ? 0 : -1;
}

static int ping(struct conn *c)
{
	struct bc_msg m = {.type = BC_MSG_PING};
	m.ping.stamp = 7;
	if (!conn_send(c, &m)) {
		return -1;
	}
	return conn_expect(c, BC_MSG_PONG, 5000) == 1 && c->m.ping.stamp == 7
	           ? 0
	           : -1;
}

/* SIGHUP swaps the tokens: the new one is accepted, the old one refused,
 * and a client that said HELLO with the old one keeps its role. */
static void sighup_replaces_the_tokens(void)
{
	struct daemon d;
	struct conn old, fresh;
	char dir[80], cfg[96];
	int port;
	make_dir_name(dir, sizeof(dir), "reload");
	snprintf(cfg, sizeof(cfg), "%s.json", dir);
	REQUIRE(write_file(cfg, "{\"tokens\": [{\"token\": \"first-token\", "
	                        "\"role\": \"editor\"}]}") == 0);
	REQUIRE(start(&d, dir,
	              (const char *[]){"--config", cfg, "--listen",
	                               "127.0.0.1:0", NULL}) == 0);
	port = tcp_port(&d);
	REQUIRE(port > 0);
	REQUIRE(tcp_open(&old, port) == 0);
	REQUIRE(hello_with(&old, "old", "first-token") == 0);
	CHECK_EQ_INT(try_token(port, "second-token"), BC_EAUTH);

	REQUIRE(write_file(cfg, "{\"tokens\": [{\"token\": \"second-token\", "
	                        "\"role\": \"viewer\"}]}") == 0);
	REQUIRE(kill(d.pid, SIGHUP) == 0);
	CHECK(wait_log(&d, "reloaded 1 tokens from", 5000));
	CHECK(wait_log(&d, "other settings take effect on restart", 100));
	CHECK_EQ_INT(try_token(port, "first-token"), BC_EAUTH);
	REQUIRE(tcp_open(&fresh, port) == 0);
	CHECK_EQ_INT(hello_with(&fresh, "fresh", "second-token"), 0);
	/* The new token grants viewer only. */
	CHECK(conn_join(&fresh, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	/* The first client still has the editor role its token gave. */
	CHECK(ping(&old) == 0);
	CHECK(conn_join(&old, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	conn_close(&old);
	conn_close(&fresh);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* A file that does not load keeps the tokens in use; one without tokens
 * leaves loopback clients only, like a start without tokens. */
static void a_bad_file_on_sighup_keeps_the_tokens(void)
{
	struct daemon d;
	char dir[80], cfg[96];
	int port;
	make_dir_name(dir, sizeof(dir), "badreload");
	snprintf(cfg, sizeof(cfg), "%s.json", dir);
	REQUIRE(write_file(cfg, "{\"tokens\": [{\"token\": \"kept-token\", "
	                        "\"role\": \"editor\"}]}") == 0);
	REQUIRE(start(&d, dir,
	              (const char *[]){"--config", cfg, "--listen",
	                               "127.0.0.1:0", NULL}) == 0);
	port = tcp_port(&d);
	REQUIRE(port > 0);
	REQUIRE(write_file(cfg, "{\"tokens\": [{\"token\": \"x\"") == 0);
	REQUIRE(kill(d.pid, SIGHUP) == 0);
	CHECK(wait_log(&d, "keeping the 1 tokens in use", 5000));
	CHECK_EQ_INT(try_token(port, "kept-token"), 0);
	CHECK_EQ_INT(try_token(port, ""), BC_EAUTH);

	REQUIRE(write_file(cfg, "{}") == 0);
	REQUIRE(kill(d.pid, SIGHUP) == 0);
	CHECK(wait_log(&d, "reloaded 0 tokens from", 5000));
	CHECK_EQ_INT(try_token(port, "kept-token"), BC_EAUTH);
	CHECK_EQ_INT(try_token(port, ""), 0);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

/* Without --config there is nothing to reload: SIGHUP is logged and the
 * daemon goes on. */
static void sighup_without_a_config_file_is_harmless(void)
{
	struct daemon d;
	struct conn c;
	char dir[80];
	make_dir_name(dir, sizeof(dir), "noconfig");
	REQUIRE(start(&d, dir, NULL) == 0);
	REQUIRE(kill(d.pid, SIGHUP) == 0);
	CHECK(wait_log(&d, "no --config file, nothing to reload", 5000));
	REQUIRE(kill(d.pid, SIGHUP) == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	CHECK(conn_hello(&c, "after-hup") == 0);
	CHECK(ping(&c) == 0);
	conn_close(&c);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

static int warned(const char *what, const char *const *extra)
{
	static char buf[1 << 16];
	struct daemon d;
	char dir[80];
	make_dir_name(dir, sizeof(dir), what);
	if (start(&d, dir, extra) != 0) {
		daemon_stop(&d, SIGKILL);
		return -1;
	}
	read_log(&d, buf, sizeof(buf));
	daemon_stop(&d, SIGTERM);
	return strstr(buf, "with no tokens configured: only loopback") != NULL;
}

/* A listener other hosts can reach, with no tokens, refuses them all:
 * the daemon says so when it starts. */
static void listening_beyond_loopback_without_tokens_warns(void)
{
	char cfg[96];
	CHECK_EQ_INT(
	    warned("any4", (const char *[]){"--listen", "0.0.0.0:0", NULL}), 1);
	CHECK_EQ_INT(
	    warned("lo4", (const char *[]){"--listen", "127.0.0.1:0", NULL}),
	    0);
	make_dir_name(cfg, sizeof(cfg), "tokens.json");
	/* (Tokens on a plain listener beyond loopback need allow_plaintext:
	 * test_tls.) */
	REQUIRE(write_file(cfg,
	                   "{\"allow_plaintext\": true, \"tokens\": "
	                   "[{\"token\": \"t\", \"role\": \"viewer\"}]}") == 0);
	CHECK_EQ_INT(warned("anytok", (const char *[]){"--listen", "0.0.0.0:0",
	                                               "--config", cfg, NULL}),
	             0);
}

/* A client name with a newline ends up escaped in the daemon's log, not
 * as a line of its own. */
static void a_client_name_cannot_forge_log_lines(void)
{
	static char buf[1 << 16];
	struct daemon d;
	struct conn c;
	char dir[80];
	make_dir_name(dir, sizeof(dir), "forge");
	REQUIRE(start(&d, dir, NULL) == 0);
	REQUIRE(conn_open(&c, &d) == 0);
	CHECK(conn_hello(&c, "eve\n[error] [store.c:1] forged") == 0);
	conn_close(&c);
	CHECK(wait_log(&d, "(eve\\n[error] [store.c:1] forged) closed", 5000));
	read_log(&d, buf, sizeof(buf));
	CHECK(strstr(buf, "\n[error] [store.c:1] forged") == NULL);
	CHECK_EQ_INT(daemon_stop(&d, SIGTERM), 0);
}

static const struct bc_test tests[] = {
    {"sighup_replaces_the_tokens", sighup_replaces_the_tokens},
    {"a_bad_file_on_sighup_keeps_the_tokens",
     a_bad_file_on_sighup_keeps_the_tokens},
    {"sighup_without_a_config_file_is_harmless",
     sighup_without_a_config_file_is_harmless},
    {"listening_beyond_loopback_without_tokens_warns",
     listening_beyond_loopback_without_tokens_warns},
    {"a_client_name_cannot_forge_log_lines",
     a_client_name_cannot_forge_log_lines},
};

int main(int argc, char **argv)
{
	/* The daemons these tests stop fill what they free: a handle freed
	 * before the loop has closed it (the work layer's and the sessions
	 * table's once were) then fails libuv's close. */
	daemon_fill_freed = true;
	/* daemon.h's helpers this file has no use for. */
	(void)daemon_start;
	(void)conn_view;
	(void)conn_move;
	return daemon_tests_run("signals", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
