/*
 * TLS on blobcastd's TCP listener, end to end: certificates made here with
 * the openssl command; a real daemon; libblobcast as the client. A full
 * request over TLS (join, edit, snapshot) with a token, the certificate
 * checks (wrong CA, no CA given, a name that does not match after a
 * SIGHUP reloaded the certificate, --insecure), a plain client on the TLS
 * port and a TLS client on a plain port both refused cleanly with the
 * daemon still serving, a stalled handshake held to the HELLO timeout,
 * the token never leaving before the handshake
 * (a recorder and a man in the middle with an untrusted certificate), and
 * the start-up refusal of tokens on a plain listener reachable from other
 * hosts.
 */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/ssl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <time.h>

#include "blobcast/client.h"
#include "blobcast/log.h"
/* Not every helper of daemon.h is used here. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include "daemon.h"
#pragma GCC diagnostic pop
#include "test.h"

#define TOKEN "tls-test-token-7d41c9e2"

static char base_dir[64];

static void path_of(char *out, size_t cap, const char *name)
{
	snprintf(out, cap, "%s/%s", base_dir, name);
}

static int sh(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int sh(const char *fmt, ...)
{
	char cmd[2048];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(cmd, sizeof(cmd), fmt, ap);
	va_end(ap);
	return system(cmd);
}

/* A CA, a server certificate it signed for localhost and 127.0.0.1 (with
 * its key in the same file, the daemon's default), a second unrelated CA,
 * and a certificate from the first CA for another name. */
static bool make_certs(void)
{
	const char *d = base_dir;
	const char *ec = "-newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes";
	return sh("cd %s && "
	          "openssl req -x509 %s -keyout ca.key -out ca.pem -days 2 "
	          "-subj /CN=blobcast-test-ca 2>/dev/null && "
	          "openssl req -x509 %s -keyout other-ca.key -out other-ca.pem "
	          "-days 2 -subj /CN=another-ca 2>/dev/null && "
	          "printf 'subjectAltName=DNS:localhost,IP:127.0.0.1\\n' "
	          "> good.ext && "
	          "printf 'subjectAltName=DNS:elsewhere.example\\n' > bad.ext "
	          "&& "
	          "for n in good bad; do "
	          "openssl req %s -keyout $n.key -out $n.csr "
	          "-subj /CN=blobcastd 2>/dev/null && "
	          "openssl x509 -req -in $n.csr -CA ca.pem -CAkey ca.key "
	          "-CAcreateserial -days 2 -extfile $n.ext -out $n.crt "
	          "2>/dev/null && cat $n.crt $n.key > $n.pem || exit 1; done "
	          "&& "
	          "cp good.pem server.pem",
	          d, ec, ec, ec) == 0;
}

static struct daemon tls_d, plain_d;
static int tls_port, plain_port;
static char tls_log[128], plain_log[128];

/* Connects with a limit for each answer that a loaded machine does not
 * reach: the sanitized daemon drew the 700x700 frames below in more than
 * the 3 s it once was, with a test suite running beside this one. The
 * refusals tested come at once; the timeouts tested set their own. */
static int connect_to(struct bc_client **c, const char *addr, const char *ca,
                      bool insecure, const char *token, struct bc_errinfo *ei)
{
	return bc_client_connect(c,
	                         &(struct bc_client_opts){
	                             .addr = addr,
	                             .name = "test-tls",
	                             .token = token,
	                             .timeout_ms = 30000,
	                             .ca_file = ca,
	                             .insecure = insecure,
	                         },
	                         ei);
}

/* A primitive of the mirrored scene (a leaf under the root). */
static uint32_t some_prim(struct bc_client *c)
{
	const struct bc_tree *t = bc_client_scene(c, NULL);
	uint32_t id = t ? bc_tree_root(t) : 0;
	while (t && id && bc_tree_child_count(t, id) > 0) {
		id = bc_tree_child(t, id, 0);
	}
	return id;
}

static void join_edit_snapshot_over_tls(void)
{
	char addr[64], ca[128];
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	uint32_t seq = 0, node;
	uint64_t order = 0;
	const char *kv[] = {"translate=0.125,0,0"};
	struct bc_msg_view v = {.width = 64, .height = 48};
	path_of(ca, sizeof(ca), "ca.pem");
	snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", tls_port);
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, TOKEN, &ei), 0);
	if (!c) {
		fprintf(stderr, "  %s\n", ei.msg);
		return;
	}
	CHECK_EQ_INT(bc_client_join(c, "default", BC_PROTO_ROLE_EDITOR,
	                            BC_CLIENT_JOIN_ANY, &ei),
	             0);
	node = some_prim(c);
	CHECK(node != 0);
	CHECK_EQ_INT(bc_client_edit_kv(c, node, kv, 1, false, &seq, &ei), 0);
	CHECK_EQ_INT(bc_client_wait_applied(c, seq, &order, &ei), 0);
	CHECK(order >= 1);
	CHECK_EQ_INT(bc_client_view(c, &v, NULL, &ei), 0);
	bc_client_image_init(&img);
	CHECK_EQ_INT(bc_client_snapshot(c, BC_PROTO_ENC_PNG, &img, &ei), 0);
	CHECK_EQ_INT(img.width, 64);
	CHECK_EQ_INT(img.height, 48);
	if (ei.msg[0]) {
		fprintf(stderr, "  %s\n", ei.msg);
	}
	bc_client_image_finish(&img);
	/* STATS's TLS section: the certificate (-days 2) ends in about two
	 * days, so it is expiring (under 14). */
	{
		struct bc_msg_stats st;
		uint64_t now_ms = (uint64_t)time(NULL) * 1000u;
		CHECK_EQ_INT(
		    bc_client_stats_parts(c, BC_PROTO_STATS_TLS, &st, &ei), 0);
		CHECK(st.has_tls && !st.has_load);
		CHECK(st.tls_not_after_ms > now_ms + 86400000u &&
		      st.tls_not_after_ms < now_ms + 3u * 86400000u);
		CHECK_EQ_INT(st.tls_expiring, 1);
	}
	bc_client_destroy(c);
	CHECK(bc_test_file_has(tls_log, "TLS (TLSv1.3"));

	/* By name: the certificate names localhost too. */
	c = NULL;
	snprintf(addr, sizeof(addr), "tls://localhost:%d", tls_port);
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, TOKEN, &ei), 0);
	bc_client_destroy(c);
}

/* Messages several times the daemon's write piece (BC_SRV_WRITE_PIECE:
 * raw frames of 1.9 MiB, a snapshot with its planes of 5.8 MiB) go out a
 * piece per loop turn; the small ones queued meanwhile (EDIT_APPLIED, the
 * answers) must come after them whole, never inside. The client's reader
 * refuses a stream that is cut anywhere. */
static void big_messages_arrive_whole(const char *addr, const char *ca,
                                      const char *token)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_image img, shot;
	struct bc_msg m;
	uint32_t seq = 0, node, frames = 0;
	uint64_t order = 0;
	struct bc_msg_view v = {.width = 700,
	                        .height = 700,
	                        .encoding = BC_PROTO_ENC_RAW,
	                        .downscale = 1};
	char kv[64];
	const char *kvs[] = {kv};
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, token, &ei), 0);
	if (!c) {
		fprintf(stderr, "  %s: %s\n", addr, ei.msg);
		return;
	}
	CHECK_EQ_INT(bc_client_join(c, "big", BC_PROTO_ROLE_EDITOR,
	                            BC_CLIENT_JOIN_ANY, &ei),
	             0);
	CHECK_EQ_INT(bc_client_view(c, &v, NULL, &ei), 0);
	node = some_prim(c);
	for (int i = 0; i < 6; i++) {
		snprintf(kv, sizeof(kv), "translate=%g,0,0", 0.02 * i);
		CHECK_EQ_INT(
		    bc_client_edit_kv(c, node, kvs, 1, false, &seq, &ei), 0);
	}
	CHECK_EQ_INT(bc_client_wait_applied(c, seq, &order, &ei), 0);
	bc_client_image_init(&img);
	while (frames < 50 &&
	       bc_client_wait(c, BC_MSG_FRAME, 0, &m, 0, &ei) == 0) {
		frames++;
		CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), 0);
		if (m.frame.order >= order &&
		    bc_proto_flags_level(m.flags) == 0 &&
		    !(m.flags & BC_PROTO_FLAG_INCOMPLETE)) {
			break;
		}
	}
	CHECK(frames < 50);
	CHECK_EQ_INT(img.width, 700);
	CHECK_EQ_INT(img.height, 700);
	bc_client_image_init(&shot);
	CHECK_EQ_INT(bc_client_snapshot_planes(
	                 c, BC_PROTO_ENC_RAW,
	                 BC_PROTO_PLANE_DEPTH | BC_PROTO_PLANE_IDS, &shot, &ei),
	             0);
	CHECK_EQ_INT(shot.width, 700);
	CHECK(shot.depth != NULL && shot.ids != NULL);
	/* The connection still speaks: an answer after all of it. */
	CHECK_EQ_INT(bc_client_edit_kv(c, node, kvs, 1, false, &seq, &ei), 0);
	CHECK_EQ_INT(bc_client_wait_applied(c, seq, &order, &ei), 0);
	if (ei.msg[0]) {
		fprintf(stderr, "  %s: %s\n", addr, ei.msg);
	}
	bc_client_image_finish(&shot);
	bc_client_image_finish(&img);
	bc_client_destroy(c);
}

static void big_messages_arrive_whole_over_tls_and_tcp(void)
{
	char addr[64], ca[128];
	path_of(ca, sizeof(ca), "ca.pem");
	snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", tls_port);
	big_messages_arrive_whole(addr, ca, TOKEN);
	snprintf(addr, sizeof(addr), "127.0.0.1:%d", plain_port);
	big_messages_arrive_whole(addr, NULL, NULL);
}

static void untrusted_certificates_are_refused(void)
{
	char addr[64], ca[128], other[128];
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	path_of(ca, sizeof(ca), "ca.pem");
	path_of(other, sizeof(other), "other-ca.pem");
	snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", tls_port);

	/* Another CA. */
	CHECK_EQ_INT(connect_to(&c, addr, other, false, TOKEN, &ei), BC_EAUTH);
	CHECK(c == NULL);
	CHECK(strstr(ei.msg, "not trusted") != NULL);
	fprintf(stderr, "  wrong CA: %s\n", ei.msg);

	/* No CA given: the system's store does not know ours. */
	CHECK_EQ_INT(connect_to(&c, addr, NULL, false, TOKEN, &ei), BC_EAUTH);
	CHECK(strstr(ei.msg, "--ca") != NULL);

	/* Insecure by name: encrypted, unchecked, works. */
	CHECK_EQ_INT(connect_to(&c, addr, NULL, true, TOKEN, &ei), 0);
	bc_client_destroy(c);
	c = NULL;

	/* A CA file that does not exist is the caller's mistake. */
	CHECK_EQ_INT(
	    connect_to(&c, addr, "/nonexistent/ca.pem", false, TOKEN, &ei),
	    BC_EINVAL);

	/* SIGHUP reloads the certificate: one from the right CA for
	 * another name is refused for its name, and the good one again
	 * after the next SIGHUP. */
	CHECK_EQ_INT(sh("cp %s/bad.pem %s/server.pem", base_dir, base_dir), 0);
	kill(tls_d.pid, SIGHUP);
	t_sleep_ms(300);
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, TOKEN, &ei), BC_EAUTH);
	CHECK(strstr(ei.msg, "mismatch") != NULL);
	fprintf(stderr, "  wrong name: %s\n", ei.msg);
	CHECK_EQ_INT(sh("cp %s/good.pem %s/server.pem", base_dir, base_dir), 0);
	kill(tls_d.pid, SIGHUP);
	t_sleep_ms(300);
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, TOKEN, &ei), 0);
	bc_client_destroy(c);
	CHECK(bc_test_file_has(tls_log, "reloaded the TLS certificate"));
}

static int tcp_connect(int port)
{
	struct sockaddr_in sa = {.sin_family = AF_INET,
	                         .sin_port = htons((uint16_t)port)};
	int fd = socket(AF_INET, SOCK_STREAM, 0);
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) != 0) {
		close(fd);
		return -1;
	}
	return fd;
}

static void wrong_protocol_on_either_port_is_refused_cleanly(void)
{
	char addr[64], ca[128];
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct conn raw;
	path_of(ca, sizeof(ca), "ca.pem");

	/* A plain client on the TLS port hears why, in plain, and is
	 * closed. */
	memset(&raw, 0, sizeof(raw));
	raw.fd = tcp_connect(tls_port);
	CHECK(raw.fd >= 0);
	bc_proto_reader_init(&raw.r, &(struct bc_proto_reader_opts){
	                                 .side = BC_PROTO_SIDE_CLIENT});
	{
		struct bc_msg m = {.type = BC_MSG_HELLO};
		m.hello.version_min = m.hello.version_max = 1;
		m.hello.encodings = BC_PROTO_ENCODINGS_ALL;
		m.hello.client_name.ptr = "plain";
		m.hello.client_name.len = 5;
		CHECK(conn_send(&raw, &m) != 0);
	}
	CHECK_EQ_INT(conn_recv(&raw, 3000), 1);
	CHECK_EQ_INT(raw.m.type, BC_MSG_ERROR);
	CHECK(raw.m.flags & BC_PROTO_FLAG_FATAL);
	CHECK_EQ_INT(raw.m.error.code, -BC_ENOTSUP);
	CHECK_EQ_INT(conn_recv(&raw, 3000), -1); /* then closed */
	conn_close(&raw);

	/* libblobcast without tls:// on the TLS port: the same, as its
	 * error. */
	snprintf(addr, sizeof(addr), "127.0.0.1:%d", tls_port);
	CHECK(connect_to(&c, addr, NULL, false, TOKEN, &ei) != 0);
	CHECK(strstr(ei.msg, "tls://") != NULL);
	fprintf(stderr, "  plain on TLS: %s\n", ei.msg);

	/* Garbage that starts like a TLS record: handshake failure, closed. */
	raw.fd = tcp_connect(tls_port);
	CHECK(raw.fd >= 0);
	CHECK_EQ_INT(send_raw(&raw, "\x16\x03\x01\x00\x05hello", 10), 0);
	{
		char b[64];
		struct pollfd p = {.fd = raw.fd, .events = POLLIN};
		CHECK_EQ_INT(poll(&p, 1, 3000), 1);
		/* An alert or nothing, then the end. */
		ssize_t n;
		while ((n = recv(raw.fd, b, sizeof(b), 0)) > 0) {
		}
		CHECK_EQ_INT(n, 0);
	}
	close(raw.fd);

	/* A TLS client on a plain port fails with a TLS error. */
	snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", plain_port);
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, NULL, &ei), BC_EIO);
	CHECK(strstr(ei.msg, "TLS handshake") != NULL);
	fprintf(stderr, "  TLS on plain: %s\n", ei.msg);

	/* Both daemons still serve. */
	snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", tls_port);
	CHECK_EQ_INT(connect_to(&c, addr, ca, false, TOKEN, &ei), 0);
	bc_client_destroy(c);
	c = NULL;
	snprintf(addr, sizeof(addr), "127.0.0.1:%d", plain_port);
	CHECK_EQ_INT(connect_to(&c, addr, NULL, false, NULL, &ei), 0);
	bc_client_destroy(c);
	CHECK(kill(tls_d.pid, 0) == 0 && kill(plain_d.pid, 0) == 0);
}

/* A handshake that never completes is held to the HELLO timeout (5 s):
 * the time before HELLO includes the handshake. */
static void a_stalled_handshake_meets_the_hello_timeout(void)
{
	struct conn raw;
	int64_t t0;
	char b[64];
	ssize_t n;
	memset(&raw, 0, sizeof(raw));
	raw.fd = tcp_connect(tls_port);
	REQUIRE(raw.fd >= 0);
	t0 = t_now_ms();
	/* The start of a ClientHello record, and then nothing. */
	CHECK_EQ_INT(send_raw(&raw, "\x16\x03\x01\x02\x00\x01", 6), 0);
	{
		struct pollfd p = {.fd = raw.fd, .events = POLLIN};
		CHECK_EQ_INT(poll(&p, 1, 9000), 1);
	}
	while ((n = recv(raw.fd, b, sizeof(b), 0)) > 0) {
	}
	CHECK_EQ_INT(n, 0);
	CHECK(t_now_ms() - t0 >= 4500);
	CHECK(t_now_ms() - t0 < 9000);
	close(raw.fd);
	CHECK(kill(tls_d.pid, 0) == 0);
}

/* ---- peers that are not blobcastd ---------------------------------------- */

/* A listener on an ephemeral loopback port; *port receives it. */
static int listen_any(int *port)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	socklen_t len = sizeof(sa);
	int fd = socket(AF_INET, SOCK_STREAM, 0);
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (bind(fd, (struct sockaddr *)&sa, sizeof(sa)) != 0 ||
	    listen(fd, 4) != 0 ||
	    getsockname(fd, (struct sockaddr *)&sa, &len) != 0) {
		close(fd);
		return -1;
	}
	*port = ntohs(sa.sin_port);
	return fd;
}

static bool has_bytes(const uint8_t *hay, size_t n, const char *needle)
{
	size_t k = strlen(needle);
	for (size_t i = 0; i + k <= n; i++) {
		if (memcmp(hay + i, needle, k) == 0) {
			return true;
		}
	}
	return false;
}

/* In a child: accepts one connection and writes to out everything that
 * arrives until the peer closes or is silent for 20 s -- the raw bytes, or
 * (with a certificate) what a TLS server presenting it decrypts, until the
 * token is among them: then it closes, so that a client waiting for an
 * answer need not wait for its own timeout. No clock decides what is
 * recorded (a short one did under load: the handshake of a sanitized
 * client on a busy machine took longer). */
static pid_t record_one(int lfd, const char *cert, const char *out)
{
	pid_t pid = fork();
	if (pid != 0) {
		return pid;
	}
	{
		int fd = accept(lfd, NULL, NULL);
		FILE *f = fopen(out, "wb");
		static uint8_t all[1 << 16];
		size_t got = 0;
		struct timeval tv = {20, 0};
		if (fd < 0 || !f) {
			_exit(1);
		}
		setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
		if (cert) {
			SSL_CTX *ctx = SSL_CTX_new(TLS_server_method());
			SSL *ssl;
			SSL_CTX_use_certificate_chain_file(ctx, cert);
			SSL_CTX_use_PrivateKey_file(ctx, cert,
			                            SSL_FILETYPE_PEM);
			ssl = SSL_new(ctx);
			SSL_set_fd(ssl, fd);
			if (SSL_accept(ssl) == 1) {
				int n;
				while (got < sizeof(all) &&
				       (n = SSL_read(
				            ssl, all + got,
				            (int)(sizeof(all) - got))) > 0) {
					got += (size_t)n;
					if (has_bytes(all, got, TOKEN)) {
						break;
					}
				}
			}
		} else {
			ssize_t n;
			while (got < sizeof(all) &&
			       (n = recv(fd, all + got, sizeof(all) - got, 0)) >
			           0) {
				got += (size_t)n;
				if (has_bytes(all, got, TOKEN)) {
					break;
				}
			}
		}
		fwrite(all, 1, got, f);
		fclose(f);
		_exit(0);
	}
}

static size_t slurp(const char *path, uint8_t *buf, size_t cap)
{
	FILE *f = fopen(path, "rb");
	size_t n = f ? fread(buf, 1, cap, f) : 0;
	if (f) {
		fclose(f);
	}
	return n;
}

static void token_never_sent_before_the_handshake(void)
{
	char addr[64], ca[128], rec[128], bad[128];
	static uint8_t got[1 << 16];
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	int port, lfd, status;
	pid_t pid;
	size_t n;
	path_of(ca, sizeof(ca), "ca.pem");
	path_of(rec, sizeof(rec), "recorded.bin");
	path_of(bad, sizeof(bad), "other-ca.pem");

	/* A recorder that never answers: only a ClientHello, no token. */
	lfd = listen_any(&port);
	CHECK(lfd >= 0);
	pid = record_one(lfd, NULL, rec);
	snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", port);
	CHECK(bc_client_connect(&c,
	                        &(struct bc_client_opts){
	                            .addr = addr,
	                            .token = TOKEN,
	                            .timeout_ms = 800,
	                            .insecure = true,
	                        },
	                        &ei) == BC_ETIMEOUT);
	waitpid(pid, &status, 0);
	close(lfd);
	n = slurp(rec, got, sizeof(got));
	CHECK(n > 5 && got[0] == 0x16); /* a TLS handshake record */
	CHECK(!has_bytes(got, n, TOKEN));

	/* A man in the middle with a certificate of its own (made by
	 * another CA): the client refuses it before HELLO, so it decrypts
	 * nothing. */
	{
		char mitm[128];
		path_of(mitm, sizeof(mitm), "mitm.pem");
		CHECK_EQ_INT(
		    sh("cd %s && openssl req -x509 -newkey ec -pkeyopt "
		       "ec_paramgen_curve:P-256 -nodes -keyout m.key "
		       "-out m.crt -days 2 -subj /CN=localhost "
		       "-addext subjectAltName=IP:127.0.0.1 "
		       "2>/dev/null && cat m.crt m.key > mitm.pem",
		       base_dir),
		    0);
		lfd = listen_any(&port);
		pid = record_one(lfd, mitm, rec);
		snprintf(addr, sizeof(addr), "tls://127.0.0.1:%d", port);
		CHECK_EQ_INT(connect_to(&c, addr, ca, false, TOKEN, &ei),
		             BC_EAUTH);
		waitpid(pid, &status, 0);
		n = slurp(rec, got, sizeof(got));
		CHECK_EQ_INT(n, 0);
		CHECK(!has_bytes(got, n, TOKEN));

		/* The control: told --insecure, the client trusts the man
		 * in the middle, and he reads the token. So the recorder
		 * does see a token when one is sent. */
		pid = record_one(lfd, mitm, rec);
		(void)bc_client_connect(&c,
		                        &(struct bc_client_opts){
		                            .addr = addr,
		                            .token = TOKEN,
		                            .timeout_ms = 30000,
		                            .insecure = true,
		                        },
		                        &ei);
		waitpid(pid, &status, 0);
		close(lfd);
		n = slurp(rec, got, sizeof(got));
		CHECK(has_bytes(got, n, TOKEN));
	}
	(void)bad;
}

/* ---- start-up rules ------------------------------------------------------ */

/* Runs blobcastd with args until it exits or 1.5 s pass (then SIGTERM);
 * its stderr goes to log. Returns the exit status, or -1 when it was
 * still running. */
static int run_daemon(const char *log, const char *const *args)
{
	const char *argv[16] = {"blobcastd"};
	int status = 0, i = 1;
	pid_t pid;
	for (; args[i - 1] && i < 15; i++) {
		argv[i] = args[i - 1];
	}
	argv[i] = NULL;
	pid = fork();
	if (pid == 0) {
		int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
		dup2(fd, 2);
		execv(daemon_path, (char *const *)argv);
		_exit(127);
	}
	for (int k = 0; k < 60; k++) {
		if (waitpid(pid, &status, WNOHANG) == pid) {
			return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
		}
		t_sleep_ms(25);
	}
	kill(pid, SIGTERM);
	waitpid(pid, &status, 0);
	return -1;
}

#define DAY_S (24L * 3600L)

/* A self-signed certificate for localhost, valid from now + from_s to now
 * + until_s (seconds; negative: in the past), with its key, in file name
 * under base_dir (the openssl command cannot date one in the past). */
static bool make_dated_cert(const char *name, long from_s, long until_s)
{
	char path[160];
	EVP_PKEY *key = EVP_EC_gen("P-256");
	X509 *x = X509_new();
	X509_NAME *nm = x ? X509_get_subject_name(x) : NULL;
	FILE *f;
	bool ok = false;
	if (key && nm && X509_set_version(x, 2) &&
	    ASN1_INTEGER_set(X509_get_serialNumber(x), 1) &&
	    X509_gmtime_adj(X509_getm_notBefore(x), from_s) &&
	    X509_gmtime_adj(X509_getm_notAfter(x), until_s) &&
	    X509_set_pubkey(x, key) &&
	    X509_NAME_add_entry_by_txt(nm, "CN", MBSTRING_ASC,
	                               (const unsigned char *)"localhost", -1,
	                               -1, 0) &&
	    X509_set_issuer_name(x, nm) &&
	    X509_sign(x, key, EVP_sha256()) > 0) {
		path_of(path, sizeof(path), name);
		if ((f = fopen(path, "w"))) {
			ok = PEM_write_X509(f, x) &&
			     PEM_write_PrivateKey(f, key, NULL, NULL, 0, NULL,
			                          NULL);
			fclose(f);
		}
	}
	X509_free(x);
	EVP_PKEY_free(key);
	return ok;
}

/* The daemon with certificate name: its exit status (run_daemon). */
static int start_with_cert(const char *name, bool allow, const char *log)
{
	char data[128], cert[128];
	const char *args[] = {"--listen",
	                      "127.0.0.1:0",
	                      "--data",
	                      data,
	                      "--tls-cert",
	                      cert,
	                      allow ? "--tls-allow-expired" : NULL,
	                      NULL};
	path_of(data, sizeof(data), "data-dates");
	path_of(cert, sizeof(cert), name);
	return run_daemon(log, args);
}

/* A certificate out of its dates is refused at start with the date that
 * passed, unless --tls-allow-expired, which warns; one that expires within
 * 14 days starts with a warning that says when. (-1: still running after
 * run_daemon's wait, so it started.) */
static void out_of_date_certificates_are_refused(void)
{
	char log[128];
	path_of(log, sizeof(log), "dates.log");
	REQUIRE(make_dated_cert("expired.pem", -10 * DAY_S, -DAY_S));
	REQUIRE(make_dated_cert("future.pem", DAY_S, 10 * DAY_S));
	REQUIRE(make_dated_cert("soon.pem", -DAY_S, 5 * DAY_S));
	REQUIRE(make_dated_cert("fine.pem", -DAY_S, 60 * DAY_S));
	CHECK_EQ_INT(start_with_cert("expired.pem", false, log), 1);
	CHECK(bc_test_file_has(log, "the certificate expired on"));
	CHECK(bc_test_file_has(log, "--tls-allow-expired"));
	CHECK_EQ_INT(start_with_cert("future.pem", false, log), 1);
	CHECK(bc_test_file_has(log, "is not valid before"));
	CHECK_EQ_INT(start_with_cert("expired.pem", true, log), -1);
	CHECK(bc_test_file_has(log, "will refuse to connect"));
	CHECK_EQ_INT(start_with_cert("soon.pem", false, log), -1);
	CHECK(bc_test_file_has(log, "the certificate expires in 4 days"));
	CHECK_EQ_INT(start_with_cert("fine.pem", false, log), -1);
	CHECK(!bc_test_file_has(log, "the certificate"));
}

static void tokens_in_clear_need_allow_plaintext(void)
{
	char log[128], cfg[128], data[128];
	FILE *f;
	path_of(log, sizeof(log), "startup.log");
	path_of(cfg, sizeof(cfg), "tokens-only.json");
	path_of(data, sizeof(data), "data-startup");
	f = fopen(cfg, "w");
	CHECK(f != NULL);
	if (!f) {
		return;
	}
	fprintf(f, "{\"tokens\": [{\"token\": \"%s\", \"role\": \"editor\"}]}",
	        TOKEN);
	fclose(f);
	{
		const char *args[] = {"--listen", "0.0.0.0:0", "--data", data,
		                      "--config", cfg,         NULL};
		CHECK_EQ_INT(run_daemon(log, args), 1);
		CHECK(bc_test_file_has(log, "--allow-plaintext"));
	}
	{
		const char *args[] = {
		    "--listen", "0.0.0.0:0",         "--data", data, "--config",
		    cfg,        "--allow-plaintext", NULL};
		CHECK_EQ_INT(run_daemon(log, args), -1);
		CHECK(bc_test_file_has(log, "without TLS (--allow-plaintext)"));
	}
	{
		/* Loopback needs no TLS: nobody else is on that path. */
		const char *args[] = {"--listen", "127.0.0.1:0", "--data", data,
		                      "--config", cfg,           NULL};
		CHECK_EQ_INT(run_daemon(log, args), -1);
	}
	{
		char cert[128];
		path_of(cert, sizeof(cert), "ca.pem"); /* no key in it */
		const char *args[] = {"--listen", "127.0.0.1:0", "--data",
		                      data,       "--tls-cert",  cert,
		                      NULL};
		CHECK_EQ_INT(run_daemon(log, args), 1);
		CHECK(bc_test_file_has(log, "private key"));
	}
}

static const struct bc_test tests[] = {
    {"join_edit_snapshot_over_tls", join_edit_snapshot_over_tls},
    {"big_messages_arrive_whole_over_tls_and_tcp",
     big_messages_arrive_whole_over_tls_and_tcp},
    {"untrusted_certificates_are_refused", untrusted_certificates_are_refused},
    {"wrong_protocol_on_either_port_is_refused_cleanly",
     wrong_protocol_on_either_port_is_refused_cleanly},
    {"a_stalled_handshake_meets_the_hello_timeout",
     a_stalled_handshake_meets_the_hello_timeout},
    {"token_never_sent_before_the_handshake",
     token_never_sent_before_the_handshake},
    {"tokens_in_clear_need_allow_plaintext",
     tokens_in_clear_need_allow_plaintext},
    {"out_of_date_certificates_are_refused",
     out_of_date_certificates_are_refused},
};

int main(int argc, char **argv)
{
	char dir[128], cfg[128], cert[128];
	const char *extra[5] = {NULL};
	FILE *f;
	int rc;
	signal(SIGPIPE, SIG_IGN);
	bc_log_init(BC_LOG_ERROR);
	snprintf(base_dir, sizeof(base_dir), "/tmp/bc-tls-test-%d",
	         (int)getpid());
	mkdir(base_dir, 0700);
	if (system("openssl version >/dev/null 2>&1") != 0) {
		fprintf(stderr, "the openssl command is missing "
		                "(deploy/install-deps.sh)\n");
		return 1;
	}
	if (!make_certs()) {
		fprintf(stderr, "could not make test certificates\n");
		return 1;
	}
	/* The TLS daemon: loopback, a token, certificate from the config. */
	path_of(cfg, sizeof(cfg), "tls.json");
	path_of(cert, sizeof(cert), "server.pem");
	f = fopen(cfg, "w");
	if (!f) {
		return 1;
	}
	fprintf(f,
	        "{\"tls_cert\": \"%s\", \"tls_key\": \"%s\", \"tokens\": "
	        "[{\"token\": \"%s\", \"role\": \"editor\"}]}",
	        cert, cert, TOKEN);
	fclose(f);
	path_of(tls_log, sizeof(tls_log), "tls-daemon.log");
	path_of(dir, sizeof(dir), "d-tls");
	daemon_log_path = tls_log;
	extra[0] = "--listen";
	extra[1] = "127.0.0.1:0";
	extra[2] = "--config";
	extra[3] = cfg;
	if (daemon_start_with(&tls_d, dir, extra) ||
	    (tls_port = daemon_log_port(tls_log)) <= 0) {
		fprintf(stderr, "the TLS daemon did not start (%s)\n", tls_log);
		if (tls_d.pid > 0) {
			daemon_stop(&tls_d, SIGKILL);
		}
		return 1;
	}
	path_of(plain_log, sizeof(plain_log), "plain-daemon.log");
	path_of(dir, sizeof(dir), "d-plain");
	daemon_log_path = plain_log;
	extra[2] = NULL;
	if (daemon_start_with(&plain_d, dir, extra) ||
	    (plain_port = daemon_log_port(plain_log)) <= 0) {
		fprintf(stderr, "the plain daemon did not start (%s)\n",
		        plain_log);
		daemon_stop(&tls_d, SIGTERM);
		if (plain_d.pid > 0) {
			daemon_stop(&plain_d, SIGKILL);
		}
		return 1;
	}
	rc = bc_test_run(tests, sizeof(tests) / sizeof(tests[0]), argc, argv);
	CHECK_EQ_INT(daemon_stop(&tls_d, SIGTERM), 0);
	CHECK_EQ_INT(daemon_stop(&plain_d, SIGTERM), 0);
	if (bc_test_failures) {
		rc = 1;
	}
	if (rc == 0) {
		sh("rm -rf %s", base_dir);
	} else {
		fprintf(stderr, "kept %s\n", base_dir);
	}
	return rc;
}
