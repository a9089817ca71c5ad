/*
 * The connection: address parsing, connecting (TCP or Unix, non-blocking
 * with a deadline), the HELLO/WELCOME handshake, whole-message writes, the
 * receive loop over the protocol's push reader, the bookkeeping that
 * SESSION_INFO, SCENE_STATE and EDIT_APPLIED drive (session details, the
 * roster of members and the scene mirror), and the request/response helpers
 * built on bc_client_wait().
 */
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "client_impl.h"

/* ---- small things ------------------------------------------------------ */

static double deadline_after(int timeout_ms)
{
	return timeout_ms < 0 ? -1.0 : bc_clock_ms() + (double)timeout_ms;
}

/* Records a sticky error on c and returns it. */
static int fail(struct bc_client *c, int code, const char *fmt,
                ...) BC__ERRINFO_PRINTF;

static int fail(struct bc_client *c, int code, const char *fmt, ...)
{
	va_list ap;
	if (c->err) {
		return c->err;
	}
	c->err = code;
	va_start(ap, fmt);
	vsnprintf(c->errstr, sizeof(c->errstr), fmt, ap);
	va_end(ap);
	return code;
}

int bc__client_fail(struct bc_client *c, int code, const char *fmt, ...)
{
	va_list ap;
	if (c->err) {
		return c->err;
	}
	c->err = code;
	va_start(ap, fmt);
	vsnprintf(c->errstr, sizeof(c->errstr), fmt, ap);
	va_end(ap);
	return code;
}

static int send_or_say(struct bc_client *c, struct bc_msg *m, uint32_t *seq,
                       struct bc_errinfo *ei);

/* Copies the sticky error into ei and returns it. */
static int sticky(const struct bc_client *c, struct bc_errinfo *ei)
{
	return bc_errinfo_set(ei, c->err, "%s", c->errstr);
}

static void copy_str(char *dst, size_t cap, struct bc_proto_str s)
{
	size_t n = s.len < cap - 1 ? s.len : cap - 1;
	if (n) {
		memcpy(dst, s.ptr, n);
	}
	dst[n] = '\0';
}

/* ---- addresses ----------------------------------------------------------- */

/* Parses a decimal port 1..65535 from s[0..n). */
static bool parse_port(const char *s, size_t n, uint16_t *port)
{
	unsigned long v = 0;
	if (n == 0 || n > 5) {
		return false;
	}
	for (size_t i = 0; i < n; i++) {
		if (s[i] < '0' || s[i] > '9') {
			return false;
		}
		v = v * 10u + (unsigned long)(s[i] - '0');
	}
	if (v == 0 || v > 65535u) {
		return false;
	}
	*port = (uint16_t)v;
	return true;
}

/* A host is printable ASCII without blanks, slashes or brackets; the
 * resolver decides the rest. */
static bool host_ok(const char *s, size_t n)
{
	if (n == 0 || n > BC_CLIENT_MAX_HOST) {
		return false;
	}
	for (size_t i = 0; i < n; i++) {
		unsigned char ch = (unsigned char)s[i];
		if (ch <= ' ' || ch >= 0x7f || ch == '/' || ch == '[' ||
		    ch == ']') {
			return false;
		}
	}
	return true;
}

/* ws://HOST[:PORT][/PATH] and wss://...: the host part as a TCP address,
 * the path (default "/") printable ASCII without blanks. */
static int parse_ws(const char *s, struct bc_client_addr *out,
                    struct bc_errinfo *ei)
{
	bool tls = s[2] == 's';
	const char *hp = s + (tls ? 6 : 5);
	const char *slash = strchr(hp, '/');
	size_t hlen = slash ? (size_t)(slash - hp) : strlen(hp);
	const char *path = slash ? slash : "/";
	char host[BC_CLIENT_MAX_HOST + 16];
	const char *colon;
	bool has_port;
	int rc;
	if (hlen == 0 || hlen >= sizeof(host)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "\"%.64s\": expected ws[s]://HOST[:PORT]"
		                      "/PATH",
		                      s);
	}
	memcpy(host, hp, hlen);
	host[hlen] = '\0';
	colon = strrchr(host, ':');
	has_port = colon && (host[0] != '[' || colon > strchr(host, ']'));
	if ((rc = bc_client_addr_parse(host, out, ei))) {
		return rc;
	}
	if (out->kind != BC_CLIENT_ADDR_TCP) {
		memset(out, 0, sizeof(*out));
		return bc_errinfo_set(ei, BC_EINVAL, "\"%.64s\": bad host", s);
	}
	if (strlen(path) > BC_CLIENT_MAX_WS_PATH) {
		memset(out, 0, sizeof(*out));
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "\"%.64s\": path over %u bytes", s,
		                      BC_CLIENT_MAX_WS_PATH);
	}
	for (const char *p = path; *p; p++) {
		if ((unsigned char)*p <= ' ' || (unsigned char)*p >= 0x7f) {
			memset(out, 0, sizeof(*out));
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "\"%.64s\": the path must be "
			                      "printable ASCII without blanks "
			                      "(percent-encode the rest)",
			                      s);
		}
	}
	if (!has_port) {
		out->port = tls ? 443 : 80;
	}
	out->ws = true;
	out->tls = tls;
	memcpy(out->resource, path, strlen(path) + 1);
	return 0;
}

int bc_client_addr_parse(const char *s, struct bc_client_addr *out,
                         struct bc_errinfo *ei)
{
	const char *host, *port = NULL, *colon;
	size_t hlen, plen = 0, len;
	memset(out, 0, sizeof(*out));
	if (!s || !*s) {
		s = BC_CLIENT_DEFAULT_HOST;
	}
	if (strncmp(s, "ws://", 5) == 0 || strncmp(s, "wss://", 6) == 0) {
		return parse_ws(s, out, ei);
	}
	if (strncmp(s, "tls://", 6) == 0) {
		int rc = bc_client_addr_parse(s + 6, out, ei);
		if (rc == 0 && out->kind != BC_CLIENT_ADDR_TCP) {
			memset(out, 0, sizeof(*out));
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "\"%.64s\": TLS is for TCP "
			                      "addresses, not Unix sockets",
			                      s);
		}
		out->tls = rc == 0;
		return rc;
	}
	len = strlen(s);
	if (strncmp(s, "unix:", 5) == 0) {
		size_t n = len - 5;
		if (n == 0) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "\"unix:\" needs a socket path");
		}
		if (n > BC_CLIENT_MAX_UNIX_PATH) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "socket path of %zu bytes is over "
			    "%u",
			    n, BC_CLIENT_MAX_UNIX_PATH);
		}
		out->kind = BC_CLIENT_ADDR_UNIX;
		memcpy(out->path, s + 5, n + 1);
		return 0;
	}
	{
		/* A URL of another scheme, such as the page's http:// address:
		 * say so rather than misread it as HOST:PORT. */
		size_t n = strspn(s, "abcdefghijklmnopqrstuvwxyz+.-");
		if (n > 0 && strncmp(s + n, "://", 3) == 0) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "\"%.64s\": %.*s:// is not a blobcastd address "
			    "(HOST:PORT, tls://, ws://, wss:// or unix:PATH; "
			    "a web page's address is not the daemon's)",
			    s, (int)n, s);
		}
	}
	if (s[0] == '[') {
		const char *close = strchr(s, ']');
		if (!close) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "\"%.64s\": '[' without ']'", s);
		}
		host = s + 1;
		hlen = (size_t)(close - host);
		if (close[1] == ':') {
			port = close + 2;
			plen = strlen(port);
		} else if (close[1] != '\0') {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "\"%.64s\": expected ':PORT' after "
			    "']'",
			    s);
		}
	} else {
		colon = strchr(s, ':');
		if (colon && strchr(colon + 1, ':')) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "\"%.64s\": write an IPv6 address "
			    "as [ADDRESS]:PORT",
			    s);
		}
		host = s;
		hlen = colon ? (size_t)(colon - s) : len;
		if (colon) {
			port = colon + 1;
			plen = strlen(port);
		}
		if (hlen == 0) {
			host = BC_CLIENT_DEFAULT_HOST;
			hlen = strlen(host);
		}
	}
	if (!host_ok(host, hlen)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "\"%.64s\": bad host name (1..%u "
		                      "printable characters)",
		                      s, BC_CLIENT_MAX_HOST);
	}
	out->port = (uint16_t)BC_CLIENT_DEFAULT_PORT;
	if (port && !parse_port(port, plen, &out->port)) {
		memset(out, 0, sizeof(*out));
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "\"%.64s\": port must be a number "
		                      "1..65535",
		                      s);
	}
	out->kind = BC_CLIENT_ADDR_TCP;
	memcpy(out->host, host, hlen);
	out->host[hlen] = '\0';
	return 0;
}

/* ---- connecting -------------------------------------------------------------- */

/* With the default timeout, how long a TCP connect waits for the server to
 * accept. Three seconds cover one lost SYN (sent again after one second)
 * on any link, so a host that is down or a firewall that drops the
 * connection is reported then rather than after the whole timeout. */
#define CONNECT_DEFAULT_MS 3000
/* How long the answer to HELLO may be silent before the client asks, on a
 * second connection, what listens there. blobcastd answers HELLO at once
 * (its event loop never waits on work), so silence past half a second is a
 * slow link or another program; the probe ends the wait early only when it
 * proves the latter (python's http.server and websockify wait silently for
 * a request line that HELLO never ends). */
#define HELLO_QUIET_MS 500
/* How long that probe waits for its answer. */
#define PROBE_MS 1000
/* Bytes of an answer looked at to tell what sent it: an HTTP status line,
 * a TLS alert, the first line of a banner. */
#define PROBE_BYTES 256

static int set_nonblock(int fd)
{
	int fl = fcntl(fd, F_GETFL);
	if (fl < 0 || fcntl(fd, F_SETFL, fl | O_NONBLOCK) < 0 ||
	    fcntl(fd, F_SETFD, FD_CLOEXEC) < 0) {
		return -1;
	}
	return 0;
}

/* The earlier of deadline (-1: none) and ms from now. */
static double deadline_min(double deadline, int ms)
{
	double d = bc_clock_ms() + (double)ms;
	return deadline < 0.0 || d < deadline ? d : deadline;
}

/* Connects a non-blocking socket, waiting until deadline. Returns 0 or an
 * errno value (ETIMEDOUT for the deadline). */
static int connect_wait(int fd, const struct sockaddr *sa, socklen_t len,
                        double deadline)
{
	struct pollfd p = {.fd = fd, .events = POLLOUT};
	int soerr = 0, n;
	socklen_t sl = sizeof(soerr);
	if (connect(fd, sa, len) == 0) {
		return 0;
	}
	if (errno != EINPROGRESS && errno != EINTR) {
		return errno;
	}
	do {
		n = poll(&p, 1, bc__client_ms_left(deadline));
	} while (n < 0 && errno == EINTR);
	if (n == 0) {
		return ETIMEDOUT;
	}
	if (n < 0) {
		return errno;
	}
	if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &soerr, &sl) < 0) {
		return errno;
	}
	return soerr;
}

static int open_unix(const struct bc_client_addr *a, double deadline,
                     int *fd_out, struct bc_errinfo *ei)
{
	struct sockaddr_un sun;
	const char *why;
	int fd, e;
	memset(&sun, 0, sizeof(sun));
	sun.sun_family = AF_UNIX;
	memcpy(sun.sun_path, a->path, strlen(a->path) + 1);
	fd = socket(AF_UNIX, SOCK_STREAM, 0);
	if (fd < 0 || set_nonblock(fd) < 0) {
		e = errno;
		if (fd >= 0) {
			close(fd);
		}
		return bc_errinfo_set(ei, BC_EIO, "socket: %s", strerror(e));
	}
	e = connect_wait(fd, (const struct sockaddr *)&sun, sizeof(sun),
	                 deadline);
	if (!e) {
		*fd_out = fd;
		return 0;
	}
	close(fd);
	switch (e) {
	case ENOENT:
		why = "no such socket (is blobcastd running with --unix at "
		      "that path?)";
		break;
	case ECONNREFUSED:
		why = "nothing listens on it (a socket left behind by a "
		      "daemon that stopped?)";
		break;
	case EACCES:
		why = "permission denied (the socket's directory or mode "
		      "keeps this user out)";
		break;
	default:
		why = strerror(e);
		break;
	}
	return bc_errinfo_set(ei, e == ETIMEDOUT ? BC_ETIMEOUT : BC_EIO,
	                      "cannot connect to unix:%s: %s", a->path, why);
}

/* The reason a TCP connect failed with errno e, and what to do. */
static void tcp_reason(const struct bc_client_addr *a, int e, int waited_ms,
                       char *buf, size_t cap)
{
	switch (e) {
	case ECONNREFUSED:
		snprintf(buf, cap,
		         "connection refused: nothing listens on port %u (is "
		         "blobcastd running? it listens on %u unless told "
		         "otherwise)",
		         (unsigned)a->port, BC_CLIENT_DEFAULT_PORT);
		break;
	case ETIMEDOUT:
		snprintf(buf, cap,
		         "no answer within %d ms (the host is down or a "
		         "firewall drops the connection; on a slow link, "
		         "allow more time)",
		         waited_ms);
		break;
	case EHOSTUNREACH:
	case ENETUNREACH:
		snprintf(buf, cap, "%s (check the host and the network)",
		         strerror(e));
		break;
	default:
		snprintf(buf, cap, "%s", e ? strerror(e) : "no address");
		break;
	}
}

static int open_tcp(const struct bc_client_addr *a, double deadline,
                    int *fd_out, struct bc_errinfo *ei)
{
	struct addrinfo hints, *res = NULL, *ai;
	char port[8], why[200];
	double start = bc_clock_ms();
	int rc, e = 0, fd = -1, one = 1;
	memset(&hints, 0, sizeof(hints));
	hints.ai_family = AF_UNSPEC;
	hints.ai_socktype = SOCK_STREAM;
	hints.ai_flags = AI_NUMERICSERV;
	snprintf(port, sizeof(port), "%u", (unsigned)a->port);
	rc = getaddrinfo(a->host, port, &hints, &res);
	if (rc != 0) {
		return bc_errinfo_set(ei, BC_EIO,
		                      "cannot resolve %s: %s (check the host "
		                      "name)",
		                      a->host, gai_strerror(rc));
	}
	for (ai = res; ai; ai = ai->ai_next) {
		fd = socket(ai->ai_family, ai->ai_socktype, ai->ai_protocol);
		if (fd < 0) {
			e = errno;
			continue;
		}
		if (set_nonblock(fd) < 0) {
			e = errno;
		} else {
			e = connect_wait(fd, ai->ai_addr, ai->ai_addrlen,
			                 deadline);
		}
		if (e == 0) {
			break;
		}
		close(fd);
		fd = -1;
		if (e == ETIMEDOUT) {
			break;
		}
	}
	freeaddrinfo(res);
	if (fd < 0) {
		tcp_reason(a, e, (int)(bc_clock_ms() - start + 0.5), why,
		           sizeof(why));
		return bc_errinfo_set(ei, e == ETIMEDOUT ? BC_ETIMEOUT : BC_EIO,
		                      "cannot connect to %s:%u: %s", a->host,
		                      (unsigned)a->port, why);
	}
	/* Requests are small and latency-bound: do not let Nagle hold an EDIT
	 * back waiting for the ACK of the previous one. */
	if (setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one)) < 0) {
		bc_log(BC_LOG_WARN, "TCP_NODELAY: %s", strerror(errno));
	}
	*fd_out = fd;
	return 0;
}

/* ---- what listens there, when it is not a blobcastd ----------------------- */

/*
 * blobcastd starts every answer with the magic "BCST", whatever it was
 * sent. When the answer to HELLO starts otherwise, is cut, or does not come,
 * the client looks at what did come and, where that says too little, asks
 * the port once more on a second connection: with the HTTP request that
 * opens a WebSocket (a web server answers it with a status line, websockify
 * with 101, blobcastd with an ERROR, a TLS server with an alert or by
 * closing), or with a TLS handshake. Only the error message depends on it.
 */
enum peer {
	PEER_NONE = 0,  /* no connection, or nothing came before the deadline */
	PEER_CLOSED,    /* closed (or reset) without a byte */
	PEER_BLOBCAST,  /* "BCST": a blobcastd */
	PEER_HTTP,      /* an HTTP status line other than 101 */
	PEER_WEBSOCKET, /* 101 Switching Protocols: a WebSocket endpoint */
	PEER_TLS,       /* a TLS alert record */
	PEER_OTHER,     /* anything else */
	PEER_COUNT
};

struct peer_answer {
	enum peer kind;
	/* HTTP: the status line; OTHER: the first line, printable only. */
	char line[64];
	/* BLOBCAST: the code of its ERROR, when the answer was one. */
	int error_code;
};

/* What the first n bytes of an answer say about who sent them. */
static void classify(const uint8_t *b, size_t n, struct peer_answer *p)
{
	static const char magic[4] = {BC_PROTO_MAGIC0, BC_PROTO_MAGIC1,
	                              BC_PROTO_MAGIC2, BC_PROTO_MAGIC3};
	size_t k = 0;
	memset(p, 0, sizeof(*p));
	if (n == 0) {
		p->kind = PEER_NONE;
		return;
	}
	if (memcmp(b, magic, n < 4 ? n : 4) == 0) {
		p->kind = PEER_BLOBCAST;
		return;
	}
	if (n >= 2 && b[0] == 0x15 && b[1] == 0x03) {
		p->kind = PEER_TLS;
		return;
	}
	/* The first line, control bytes left out. */
	for (size_t i = 0;
	     i < n && b[i] != '\r' && b[i] != '\n' && k + 1 < sizeof(p->line);
	     i++) {
		if (b[i] >= 0x20 && b[i] < 0x7f) {
			p->line[k++] = (char)b[i];
		}
	}
	p->line[k] = '\0';
	if (n >= 5 && memcmp(b, "HTTP/", 5) == 0) {
		const char *sp = strchr(p->line, ' ');
		p->kind = sp && strncmp(sp + 1, "101", 3) == 0 ? PEER_WEBSOCKET
		                                               : PEER_HTTP;
		return;
	}
	p->kind = PEER_OTHER;
}

/* Sends all of req on the non-blocking fd by deadline; 0 or -1. */
static int send_all(int fd, const void *req, size_t len, double deadline)
{
	size_t done = 0;
	while (done < len) {
		struct pollfd p = {.fd = fd, .events = POLLOUT};
		ssize_t n = send(fd, (const char *)req + done, len - done,
		                 MSG_NOSIGNAL);
		if (n > 0) {
			done += (size_t)n;
			continue;
		}
		if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK &&
		    errno != EINTR) {
			return -1;
		}
		if (poll(&p, 1, bc__client_ms_left(deadline)) == 0) {
			return -1;
		}
	}
	return 0;
}

/* Opens a second connection to a and asks it what it is, by deadline,
 * with the request that opens a WebSocket. Returns the socket, or -1. */
static int probe_start(const struct bc_client_addr *a, double deadline)
{
	char req[BC_CLIENT_MAX_HOST + 256];
	int fd = -1, len;
	if (open_tcp(a, deadline, &fd, NULL)) {
		return -1;
	}
	len = snprintf(req, sizeof(req),
	               "GET / HTTP/1.1\r\nHost: %s:%u\r\nUpgrade: websocket\r\n"
	               "Connection: Upgrade\r\n"
	               "Sec-WebSocket-Key: YmxvYmNhc3QtcHJvYmUtMQ==\r\n"
	               "Sec-WebSocket-Version: 13\r\n"
	               "Sec-WebSocket-Protocol: binary\r\n\r\n",
	               a->host, (unsigned)a->port);
	if (len < 0 || (size_t)len >= sizeof(req) ||
	    send_all(fd, req, (size_t)len, deadline)) {
		close(fd);
		return -1;
	}
	return fd;
}

/* Reads the answer to probe_start()'s request on fd until deadline: enough
 * for a status line, or one whole ERROR of blobcastd's. p->kind stays
 * PEER_NONE when nothing came. */
static void probe_read(int fd, double deadline, struct peer_answer *p)
{
	uint8_t buf[PROBE_BYTES];
	struct bc_proto_reader r;
	struct bc_msg m;
	size_t have = 0;
	memset(p, 0, sizeof(*p));
	while (fd >= 0 && have < sizeof(buf)) {
		struct pollfd pf = {.fd = fd, .events = POLLIN};
		ssize_t n;
		int k = poll(&pf, 1, bc__client_ms_left(deadline));
		if (k < 0 && errno == EINTR) {
			continue;
		}
		if (k <= 0) {
			break;
		}
		n = recv(fd, buf + have, sizeof(buf) - have, 0);
		if (n < 0 && (errno == EINTR || errno == EAGAIN)) {
			continue;
		}
		if (n <= 0) {
			if (have == 0) {
				p->kind = PEER_CLOSED;
			}
			break;
		}
		have += (size_t)n;
		if (!memchr(buf, '\n', have) && have < BC_PROTO_HEADER_SIZE) {
			continue;
		}
		/* A status line, or a header's worth of BCST: read on only
		 * for a whole ERROR message. */
		classify(buf, have, p);
		if (p->kind != PEER_BLOBCAST) {
			return;
		}
		bc_proto_reader_init(&r, &(struct bc_proto_reader_opts){
		                             .side = BC_PROTO_SIDE_CLIENT});
		if (bc_proto_reader_feed(&r, buf, have) == 0 &&
		    bc_proto_reader_next(&r, &m) == 1) {
			if (m.type == BC_MSG_ERROR) {
				p->error_code = -(int)m.error.code;
			}
			bc_proto_reader_finish(&r);
			return;
		}
		bc_proto_reader_finish(&r);
	}
	if (have) {
		classify(buf, have, p);
	}
}

/* probe_start() and probe_read() on one connection. */
static void probe_http(const struct bc_client_addr *a, double deadline,
                       struct peer_answer *p)
{
	int fd = probe_start(a, deadline);
	probe_read(fd, deadline, p);
	if (fd >= 0) {
		close(fd);
	}
}

/* Whether a TLS handshake (certificate not checked) succeeds at a by
 * deadline: the question is only whether the port speaks TLS. */
static bool probe_tls(const struct bc_client_addr *a, double deadline)
{
	struct bc_client t;
	bool ok;
	memset(&t, 0, sizeof(t));
	t.fd = -1;
	t.timeout_ms = PROBE_MS;
	if (open_tcp(a, deadline, &t.fd, NULL)) {
		return false;
	}
	ok = bc__client_tls_start(&t, a->host, NULL, true, deadline) == 0;
	bc__client_transport_free(&t);
	close(t.fd);
	return ok;
}

/* Says in ei what answered at a instead of blobcastd (p: its answer to
 * HELLO, or to the probe) and returns the code: BC_EPROTO_MAGIC when
 * something else answered, BC_ECLOSED when it only closed. */
static int not_blobcastd(const struct bc_client_addr *a,
                         const struct peer_answer *p, struct bc_errinfo *ei)
{
	const char *h = a->host;
	unsigned port = a->port;
	switch (p->kind) {
	case PEER_WEBSOCKET:
		return bc_errinfo_set(
		    ei, BC_EPROTO_MAGIC,
		    "%s:%u is a WebSocket endpoint (websockify "
		    "or a proxy), not blobcastd itself: "
		    "connect through it as ws://%s:%u/",
		    h, port, h, port);
	case PEER_HTTP:
		return bc_errinfo_set(
		    ei, BC_EPROTO_MAGIC,
		    "%s:%u answers HTTP (\"%s\"): that is a web server, not "
		    "blobcastd; use the daemon's own port (%u unless set "
		    "otherwise), or ws://HOST:PORT/ of its websockify",
		    h, port, p->line, BC_CLIENT_DEFAULT_PORT);
	case PEER_TLS:
		return bc_errinfo_set(ei, BC_EPROTO_MAGIC,
		                      "%s:%u speaks TLS: connect with "
		                      "tls://%s:%u",
		                      h, port, h, port);
	case PEER_OTHER:
		return bc_errinfo_set(ei, BC_EPROTO_MAGIC,
		                      "%s:%u answers \"%s\", not the blobcast "
		                      "protocol: another program listens "
		                      "there, not blobcastd",
		                      h, port, p->line);
	default:
		return bc_errinfo_set(ei, BC_ECLOSED,
		                      "%s:%u closed the connection without "
		                      "answering HELLO: not a blobcastd, or a "
		                      "proxy whose daemon is down",
		                      h, port);
	}
}

/* What first_answer() returns when it closed the connection to hear the
 * probe, and the probe then found a blobcastd: connect again. */
#define HELLO_AGAIN 1

/* Waits for fd to be readable until deadline: 1, 0 at the deadline, or
 * -1 with errno. */
static int readable(int fd, double deadline)
{
	struct pollfd pf = {.fd = fd, .events = POLLIN};
	int k;
	do {
		k = poll(&pf, 1, bc__client_ms_left(deadline));
	} while (k < 0 && errno == EINTR);
	return k;
}

/* The answer to HELLO was silent until deadline. */
static int silent(const struct bc_client *c, const struct bc_client_addr *a,
                  bool probed, struct bc_errinfo *ei)
{
	return bc_errinfo_set(ei, BC_ETIMEOUT,
	                      "no WELCOME from %s:%u within %d ms: it "
	                      "accepted the connection but stays silent%s "
	                      "(not a blobcastd? on a slow link, allow more "
	                      "time)",
	                      a->host, (unsigned)a->port, c->timeout_ms,
	                      probed ? ", to an HTTP request too" : "");
}

/*
 * Waits, on a plain TCP connection that has sent HELLO, for the first bytes
 * of the answer and checks that they are blobcastd's. Returns 0 when they
 * are (the reader takes them), HELLO_AGAIN, or an error with what listens
 * there: BC_EPROTO_MAGIC (another program answered), BC_ECLOSED (closed
 * without a word), BC_ETIMEOUT (silent until deadline).
 */
static int first_answer(struct bc_client *c, const struct bc_client_addr *a,
                        double deadline, struct bc_errinfo *ei)
{
	struct peer_answer p, probe = {0};
	uint8_t buf[PROBE_BYTES];
	double quiet = deadline_min(deadline, HELLO_QUIET_MS);
	int k = readable(c->fd, quiet), pfd;
	ssize_t n;
	if (k == 0 && quiet == deadline) {
		return silent(c, a, false, ei);
	}
	if (k == 0) {
		/* Silent so far: ask what listens there. */
		pfd = probe_start(a, deadline_min(deadline, PROBE_MS));
		probe_read(pfd, deadline_min(deadline, PROBE_MS), &probe);
		if (probe.kind == PEER_NONE && pfd >= 0) {
			/* The probe is silent too: a server that serves
			 * one connection at a time (python's HTTPServer) is
			 * still busy with HELLO. Let it go and hear the
			 * probe; a blobcastd that answers it after all is
			 * connected to again. */
			close(c->fd);
			c->fd = -1;
			probe_read(pfd, deadline, &probe);
			close(pfd);
			if (probe.kind == PEER_BLOBCAST) {
				return HELLO_AGAIN;
			}
			if (probe.kind == PEER_NONE) {
				return silent(c, a, true, ei);
			}
			return not_blobcastd(a, &probe, ei);
		}
		if (pfd >= 0) {
			close(pfd);
		}
		if (probe.kind == PEER_HTTP || probe.kind == PEER_WEBSOCKET ||
		    probe.kind == PEER_TLS || probe.kind == PEER_OTHER) {
			return not_blobcastd(a, &probe, ei);
		}
		/* A blobcastd (a slow one), or no telling: wait on. */
		if ((k = readable(c->fd, deadline)) == 0) {
			return silent(c, a, true, ei);
		}
	}
	if (k < 0) {
		return bc_errinfo_set(ei, BC_EIO, "poll: %s", strerror(errno));
	}
	do {
		n = recv(c->fd, buf, sizeof(buf), MSG_PEEK);
	} while (n < 0 && errno == EINTR);
	if (n < 0 && errno != ECONNRESET) {
		/* The reader meets the same error and says so. */
		return 0;
	}
	classify(buf, n > 0 ? (size_t)n : 0, &p);
	if (p.kind == PEER_BLOBCAST) {
		return 0;
	}
	if (p.kind == PEER_NONE) {
		/* Closed without a word: TLS servers do that to plain
		 * bytes. */
		p.kind = probe_tls(a, deadline_min(deadline, PROBE_MS))
		             ? PEER_TLS
		             : PEER_CLOSED;
	} else if (p.kind == PEER_HTTP) {
		/* A web server, or a WebSocket endpoint that refuses what is
		 * not an upgrade: ask with one. */
		probe_http(a, deadline_min(deadline, PROBE_MS), &probe);
		if (probe.kind == PEER_WEBSOCKET) {
			p = probe;
		}
	}
	return not_blobcastd(a, &p, ei);
}

/* A TLS handshake with a failed (the sticky error of c): when the port
 * answers plain HTTP or the plain blobcast protocol, says so in ei, after
 * the TLS reason; returns the sticky code. */
static int tls_failed(struct bc_client *c, const struct bc_client_addr *a,
                      struct bc_errinfo *ei)
{
	struct peer_answer p;
	if (c->err != BC_EIO && c->err != BC_ETIMEOUT) {
		return sticky(c, ei);
	}
	/* The handshake may have used up the deadline: the probe has its
	 * own. */
	probe_http(a, bc_clock_ms() + PROBE_MS, &p);
	/* blobcastd's TLS port answers plain bytes with ENOTSUP; its plain
	 * port with any other ERROR. */
	if (p.kind == PEER_BLOBCAST && p.error_code != BC_ENOTSUP) {
		return bc_errinfo_set(ei, c->err,
		                      "TLS handshake with %s:%u failed: it "
		                      "speaks the blobcast protocol without "
		                      "TLS: connect with %s:%u (no tls://)",
		                      a->host, (unsigned)a->port, a->host,
		                      (unsigned)a->port);
	}
	if (p.kind == PEER_HTTP || p.kind == PEER_WEBSOCKET) {
		return bc_errinfo_set(ei, c->err,
		                      "TLS handshake with %s:%u failed; in "
		                      "plain it answers HTTP (\"%s\"): a web "
		                      "server, not blobcastd",
		                      a->host, (unsigned)a->port, p.line);
	}
	return sticky(c, ei);
}

/* Sends HELLO and waits until deadline for WELCOME; on a plain TCP
 * connection (a: its address, else NULL) checks first that blobcastd is
 * the one answering. */
static int hello(struct bc_client *c, const struct bc_client_opts *o,
                 const struct bc_client_addr *a, double deadline,
                 struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	const char *name = o->name ? o->name : "libblobcast";
	const char *token = o->token ? o->token : "";
	int rc, left;
	if (strlen(name) > BC_PROTO_MAX_NAME) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "client name over %u bytes",
		                      BC_PROTO_MAX_NAME);
	}
	if (strlen(token) > BC_PROTO_MAX_TOKEN) {
		return bc_errinfo_set(ei, BC_EINVAL, "token over %u bytes",
		                      BC_PROTO_MAX_TOKEN);
	}
	m.hello.version_min = BC_PROTO_VERSION;
	m.hello.version_max = BC_PROTO_VERSION;
	m.hello.encodings = c->encodings;
	m.hello.max_frame_bytes = o->max_frame_bytes;
	m.hello.client_name.ptr = name;
	m.hello.client_name.len = (uint32_t)strlen(name);
	m.hello.token.ptr = token;
	m.hello.token.len = (uint32_t)strlen(token);
	/* Everything of the protocol this library decodes; ACKS binds the
	 * program to acknowledge its frames, so only when it says it will. */
	m.hello.has_features = true;
	m.hello.features =
	    BC_PROTO_FEATURES_READ | (o->acks ? BC_PROTO_FEATURE_ACKS : 0u);
	if ((rc = send_or_say(c, &m, NULL, ei))) {
		return rc;
	}
	if (a && (rc = first_answer(c, a, deadline, ei))) {
		return rc;
	}
	left = bc__client_ms_left(deadline);
	if ((rc = bc_client_wait(c, BC_MSG_WELCOME, 0, &m, left == 0 ? 1 : left,
	                         ei))) {
		return rc;
	}
	c->info.version = m.welcome.version;
	c->info.connection_id = m.welcome.connection_id;
	c->info.max_payload = m.welcome.max_payload;
	c->info.max_frame_bytes = m.welcome.max_frame_bytes;
	c->info.max_nodes = m.welcome.max_nodes;
	c->info.max_dim = m.welcome.max_dim;
	c->info.max_members = m.welcome.max_members;
	c->info.max_edit_ops = m.welcome.max_edit_ops;
	copy_str(c->info.server_id, sizeof(c->info.server_id),
	         m.welcome.server_id);
	c->info.features = m.welcome.features;
	return 0;
}

int bc_client_connect(struct bc_client **out, const struct bc_client_opts *opts,
                      struct bc_errinfo *ei)
{
	static const struct bc_client_opts none = {0};
	const struct bc_client_opts *o = opts ? opts : &none;
	struct bc_client_addr addr;
	struct bc_client *c = NULL;
	struct bc_proto_reader_opts ro = {.side = BC_PROTO_SIDE_CLIENT};
	double deadline;
	int rc;
	*out = NULL;
	if ((rc = bc_client_addr_parse(o->addr, &addr, ei))) {
		return rc;
	}
	if (o->encodings & ~BC_PROTO_ENCODINGS_ALL) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "encodings 0x%02x has unknown bits",
		                      (unsigned)o->encodings);
	}
	if (!(c = bc_calloc(1, sizeof(*c))) ||
	    !(c->chunk = bc_malloc(BC_CLIENT_READ_CHUNK))) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		goto fail;
	}
	c->fd = -1;
	c->next_seq = 1;
	if (bc__client_remember(c, o)) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		goto fail;
	}
	c->timeout_ms =
	    o->timeout_ms == 0 ? BC_CLIENT_DEFAULT_TIMEOUT_MS : o->timeout_ms;
	c->encodings = o->encodings ? o->encodings : BC_PROTO_ENCODINGS_IMAGES;
	/* SCENE_STATE may be as large as any message, so the reader keeps the
	 * protocol's limit; the server holds FRAMEs to max_frame_bytes. */
	bc_proto_reader_init(&c->reader, &ro);
	bc_proto_parts_init(&c->parts, 0, false);
	bc_proto_buf_init(&c->out, 0);
	deadline = deadline_after(c->timeout_ms);
	/* The default timeout waits less for the TCP connect than for an
	 * answer (CONNECT_DEFAULT_MS); a timeout given is the caller's. */
	rc = addr.kind == BC_CLIENT_ADDR_UNIX
	         ? open_unix(&addr, deadline, &c->fd, ei)
	         : open_tcp(&addr,
	                    o->timeout_ms == 0
	                        ? deadline_min(deadline, CONNECT_DEFAULT_MS)
	                        : deadline,
	                    &c->fd, ei);
	/* The token goes out in HELLO: only after the handshake succeeded. */
	if (!rc && addr.tls &&
	    bc__client_tls_start(c, addr.host, o->ca_file, o->insecure,
	                         deadline)) {
		rc = tls_failed(c, &addr, ei);
	}
	if (!rc && addr.ws && bc__client_ws_start(c, &addr, deadline)) {
		rc = sticky(c, ei);
	}
	if (!rc) {
		rc = hello(c, o,
		           addr.kind == BC_CLIENT_ADDR_TCP && !addr.tls &&
		                   !addr.ws
		               ? &addr
		               : NULL,
		           deadline, ei);
	}
	if (rc == HELLO_AGAIN) {
		/* A slow blobcastd: once more on a new connection, waiting
		 * for it without asking. */
		c->next_seq = 1;
		memset(&c->info, 0, sizeof(c->info));
		rc = open_tcp(&addr, deadline, &c->fd, ei);
		if (!rc) {
			rc = hello(c, o, NULL, deadline, ei);
		}
	}
	if (rc) {
		goto fail;
	}
	*out = c;
	return 0;
fail:
	bc_client_destroy(c);
	return rc;
}

void bc_client_destroy(struct bc_client *c)
{
	if (!c) {
		return;
	}
	bc__client_transport_free(c);
	bc__client_ws_free(c);
	if (c->fd >= 0) {
		close(c->fd);
	}
	bc_proto_reader_finish(&c->reader);
	bc_proto_parts_finish(&c->parts);
	bc_proto_buf_finish(&c->out);
	bc_tree_destroy(c->scene);
	bc_free(c->chunk);
	bc__client_forget(c);
	bc_free(c);
}

int bc_client_fd(const struct bc_client *c)
{
	return c->fd;
}

const struct bc_client_info *bc_client_info(const struct bc_client *c)
{
	return &c->info;
}

int bc_client_error(const struct bc_client *c, struct bc_errinfo *ei)
{
	if (!c->err) {
		if (ei) {
			ei->code = 0;
			ei->msg[0] = '\0';
		}
		return 0;
	}
	return sticky(c, ei);
}

/* ---- sending ------------------------------------------------------------------ */

/* bc_client_send(), with the reason of any failure in ei. */
static int send_msg(struct bc_client *c, struct bc_msg *m, uint32_t *seq_out,
                    struct bc_errinfo *ei)
{
	struct bc_errinfo why = {0};
	double deadline;
	int rc;
	if (seq_out) {
		*seq_out = 0;
	}
	if (c->err) {
		return sticky(c, ei);
	}
	m->seq = c->next_seq;
	bc_proto_buf_reset(&c->out);
	if ((rc = bc_proto_encode(&c->out, m, &why))) {
		return bc_errinfo_set(ei, rc, "%s not sent: %s",
		                      bc_proto_type_name(m->type), why.msg);
	}
	/* Seq 0 means "no request" in answers: skip it when wrapping. */
	c->next_seq = c->next_seq == UINT32_MAX ? 1 : c->next_seq + 1;
	deadline = deadline_after(c->timeout_ms);
	if ((rc = bc__client_io_write(c, c->out.data, c->out.len, deadline,
	                              bc_proto_type_name(m->type)))) {
		return rc;
	}
	c->info.msgs_out++;
	c->info.bytes_out += c->out.len;
	if (m->type == BC_MSG_SESSION_LEAVE) {
		/* Its OK says we are out: the roster is emptied then. */
		c->leave_seq = m->seq;
	}
	if (seq_out) {
		*seq_out = m->seq;
	}
	return 0;
}

int bc_client_send(struct bc_client *c, struct bc_msg *m, uint32_t *seq_out)
{
	return send_msg(c, m, seq_out, NULL);
}

/* ---- receiving ---------------------------------------------------------------- */

static void drop_scene(struct bc_client *c, const char *why)
{
	if (c->has_scene) {
		bc_log(BC_LOG_WARN, "scene mirror dropped: %s", why);
	}
	c->has_scene = false;
}

/* Back in READY (left, or the session was deleted): no session details,
 * no roster. */
static void left_session(struct bc_client *c)
{
	c->info.session_id = 0;
	c->info.nmembers = 0;
	c->nmembers = 0;
}

/* Replaces the roster with si's member list. */
static void roster_update(struct bc_client *c,
                          const struct bc_msg_session_info *si)
{
	size_t n = si->nmembers < BC_PROTO_MAX_MEMBERS ? si->nmembers
	                                               : BC_PROTO_MAX_MEMBERS;
	for (size_t i = 0; i < n; i++) {
		struct bc_client_member *e = &c->members[i];
		e->id = si->members[i].id;
		e->role = si->members[i].role;
		copy_str(e->name, sizeof(e->name), si->members[i].name);
	}
	c->nmembers = n;
}

/* Keeps the session details, the roster and the scene mirror current. Failures
 * here concern the mirror only, never the stream: they are logged and the
 * mirror is dropped until the next SCENE_STATE. */
static void track(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_errinfo ei = {0};
	switch (m->type) {
	case BC_MSG_SESSION_INFO:
		/* A new membership: PRESENTER follows if someone presents. */
		if (m->session_info.member_id != c->info.member_id ||
		    m->session_info.session_id != c->info.session_id) {
			c->info.presenter = 0;
			c->info.following = false;
		}
		c->info.session_id = m->session_info.session_id;
		c->info.member_id = m->session_info.member_id;
		c->info.role = m->session_info.role;
		c->info.nmembers = m->session_info.nmembers;
		copy_str(c->info.session, sizeof(c->info.session),
		         m->session_info.name);
		roster_update(c, &m->session_info);
		break;
	case BC_MSG_OK:
		/* SESSION_LEAVE and SESSION_DELETE are answered with OK; only
		 * the first takes us out of the session. */
		if (c->leave_seq && m->seq == c->leave_seq) {
			c->leave_seq = 0;
			left_session(c);
		}
		break;
	case BC_MSG_SCENE_STATE: {
		struct bc_tree *t = c->scene;
		bool has_cam = false;
		if (!t && (t = bc_tree_create())) {
			bc_tree_set_layout(t, !c->opts.bare_scene);
		}
		c->info.order = m->scene_state.order;
		c->scene = t;
		if (!t) {
			drop_scene(c, "out of memory");
			break;
		}
		if (bc_scene_decode(m->scene_state.scene.ptr,
		                    m->scene_state.scene.len, t, &c->camera,
		                    &has_cam, &ei)) {
			drop_scene(c, ei.msg);
			bc_log(BC_LOG_WARN, "SCENE_STATE does not decode: %s",
			       ei.msg);
			break;
		}
		if (!has_cam) {
			bc_camera_default(&c->camera);
		}
		c->has_scene = true;
		c->scene_order = m->scene_state.order;
		break;
	}
	case BC_MSG_EDIT_APPLIED:
		if (m->edit_applied.order > c->info.order) {
			c->info.order = m->edit_applied.order;
		}
		if (!c->has_scene) {
			break;
		}
		if (m->edit_applied.order != c->scene_order + 1) {
			drop_scene(c, "an edit order was skipped");
			break;
		}
		if (bc__client_replay(&c->scene, &m->edit_applied, &ei)) {
			drop_scene(c, ei.msg);
			break;
		}
		c->scene_order = m->edit_applied.order;
		break;
	case BC_MSG_PRESENTER:
		c->info.presenter = m->presenter.presenter;
		c->info.following = m->presenter.following != 0;
		break;
	case BC_MSG_SESSION_CAMERA_SET: {
		const struct bc_msg_session_camera_set *cs =
		    &m->session_camera_set;
		if (cs->order > c->info.order) {
			c->info.order = cs->order;
		}
		if (!c->has_scene) {
			break;
		}
		if (cs->order != c->scene_order + 1) {
			drop_scene(c, "an edit order was skipped");
			break;
		}
		bc_edit_camera_from_msg(&cs->camera, &c->camera);
		c->scene_order = cs->order;
		break;
	}
	case BC_MSG_ERROR:
		if (m->flags & BC_PROTO_FLAG_FATAL) {
			int code =
			    m->error.code ? -(int)m->error.code : BC_ECLOSED;
			fail(c, code, "server: %.*s", (int)m->error.text.len,
			     m->error.text.ptr);
		} else if (m->seq == 0 &&
		           -(int)m->error.code == BC_ENOSESSION) {
			/* Our session was deleted: back in READY. */
			left_session(c);
			drop_scene(c, "the session was deleted");
		}
		break;
	default:
		break;
	}
}

int bc_client_recv(struct bc_client *c, struct bc_msg *out, int timeout_ms)
{
	double deadline = deadline_after(timeout_ms);
	struct bc_msg part;
	int rc;
	memset(out, 0, sizeof(*out));
	/* A FATAL ERROR is handed out once; what follows is its code. */
	if (c->err) {
		return c->err;
	}
	for (;;) {
		size_t before = bc_proto_reader_pending(&c->reader);
		long n;
		rc = bc_proto_reader_next(&c->reader, &part);
		if (rc == 1) {
			size_t size =
			    before - bc_proto_reader_pending(&c->reader);
			struct bc_errinfo ei = {0};
			c->info.msgs_in++;
			c->info.bytes_in += size;
			c->info.last_msg_bytes = (uint32_t)size;
			/* A scene in parts is handed out whole, once its last
			 * part has come. */
			rc = bc_proto_parts_add(&c->parts, &part, out, &ei);
			if (rc < 0) {
				return fail(c, rc,
				            "bad scene from the server: %s",
				            ei.msg);
			}
			if (rc == 0) {
				continue;
			}
			track(c, out);
			return 1;
		}
		if (rc < 0) {
			return fail(c, rc, "bad bytes from the server: %s",
			            c->reader.errstr);
		}
		n = bc__client_io_read(c, c->chunk, BC_CLIENT_READ_CHUNK,
		                       deadline);
		if (n == 0) {
			return 0;
		}
		if (n < 0 && n != BC__CLIENT_EOF) {
			return (int)n;
		}
		if (n == BC__CLIENT_EOF) {
			if (bc_proto_reader_eof(&c->reader) < 0) {
				return fail(c, c->reader.err,
				            "the server closed the connection "
				            "mid-message: %s",
				            c->reader.errstr);
			}
			return fail(c, BC_ECLOSED,
			            "the server closed the connection");
		}
		if ((rc = bc_proto_reader_feed(&c->reader, c->chunk,
		                               (size_t)n))) {
			return fail(c, rc, "reader: %s", c->reader.errstr);
		}
	}
}

/* ---- waiting for answers ------------------------------------------------------ */

static bool matches(const struct bc_client *c, const struct bc_msg *m,
                    enum bc_msg_type type, uint32_t seq)
{
	if (m->type != type) {
		return false;
	}
	switch (type) {
	case BC_MSG_EDIT_APPLIED:
		return m->edit_applied.author == c->info.member_id &&
		       (seq == 0 || m->edit_applied.author_seq == seq);
	case BC_MSG_SCENE_STATE:
		return seq == 0 ||
		       (m->scene_state.author == c->info.member_id &&
		        m->scene_state.author_seq == seq);
	case BC_MSG_SESSION_CAMERA_SET:
		return m->session_camera_set.author == c->info.member_id &&
		       (seq == 0 || m->session_camera_set.author_seq == seq);
	case BC_MSG_PRESENTER:
	case BC_MSG_FOLLOW_CAMERA:
		return true; /* always seq 0 */
	default:
		return seq == 0 || m->seq == seq;
	}
}

int bc_client_wait(struct bc_client *c, enum bc_msg_type type, uint32_t seq,
                   struct bc_msg *out, int timeout_ms, struct bc_errinfo *ei)
{
	double deadline =
	    deadline_after(timeout_ms == 0 ? c->timeout_ms : timeout_ms);
	for (;;) {
		int rc = bc_client_recv(c, out, bc__client_ms_left(deadline));
		if (rc < 0) {
			return sticky(c, ei);
		}
		if (rc == 0) {
			return bc_errinfo_set(ei, BC_ETIMEOUT,
			                      "no %s from the server in time",
			                      bc_proto_type_name(type));
		}
		if (out->type == BC_MSG_ERROR) {
			int code =
			    out->error.code ? -(int)out->error.code : BC_EINVAL;
			return bc_errinfo_set(ei, code, "%.*s",
			                      (int)out->error.text.len,
			                      out->error.text.ptr);
		}
		if (matches(c, out, type, seq)) {
			return 0;
		}
	}
}

/* ---- sessions ------------------------------------------------------------------ */

/* Sends m; a failure, sticky or not, comes back with its reason in ei. */
static int send_or_say(struct bc_client *c, struct bc_msg *m, uint32_t *seq,
                       struct bc_errinfo *ei)
{
	int rc = send_msg(c, m, seq, ei);
	if (rc && c->err) {
		return sticky(c, ei);
	}
	return rc;
}

static int join_once(struct bc_client *c, enum bc_msg_type type,
                     const char *name, enum bc_proto_role role,
                     struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = type};
	uint32_t seq;
	int rc;
	m.session.role = role;
	m.session.name.ptr = name;
	m.session.name.len = (uint32_t)strlen(name);
	if ((rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_SESSION_INFO, 0, &m, 0, ei))) {
		return rc;
	}
	/* The joiner's copy of the scene follows SESSION_INFO at once. */
	return bc_client_wait(c, BC_MSG_SCENE_STATE, 0, &m, 0, ei);
}

int bc_client_join(struct bc_client *c, const char *name,
                   enum bc_proto_role role, enum bc_client_join_mode mode,
                   struct bc_errinfo *ei)
{
	int rc;
	if (!name || !*name || strlen(name) > BC_PROTO_MAX_NAME) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "session names have 1..%u bytes",
		                      BC_PROTO_MAX_NAME);
	}
	if ((unsigned)mode >= BC_CLIENT_JOIN_MODE_COUNT ||
	    (unsigned)role >= BC_PROTO_ROLE_COUNT) {
		return bc_errinfo_set(ei, BC_EINVAL, "bad join mode or role");
	}
	if (role == BC_PROTO_ROLE_INVALID) {
		role = BC_PROTO_ROLE_EDITOR;
	}
	if (mode == BC_CLIENT_JOIN_CREATE) {
		rc = join_once(c, BC_MSG_SESSION_CREATE, name, role, ei);
	} else {
		rc = join_once(c, BC_MSG_SESSION_JOIN, name, role, ei);
	}
	if (rc == BC_ENOSESSION && mode == BC_CLIENT_JOIN_ANY) {
		rc = join_once(c, BC_MSG_SESSION_CREATE, name, role, ei);
		/* Someone else created it between our two requests. */
		if (rc == BC_EEXIST) {
			rc = join_once(c, BC_MSG_SESSION_JOIN, name, role, ei);
		}
	}
	if (!rc) {
		/* What bc_client_rejoin() repeats. */
		bc__client_joined(c, name, role, mode);
	}
	return rc;
}

int bc_client_members(const struct bc_client *c,
                      const struct bc_client_member **list, size_t *n)
{
	*list = c->nmembers ? c->members : NULL;
	*n = c->nmembers;
	return 0;
}

const struct bc_client_member *bc_client_member_find(const struct bc_client *c,
                                                     uint32_t id)
{
	for (size_t i = 0; id && i < c->nmembers; i++) {
		if (c->members[i].id == id) {
			return &c->members[i];
		}
	}
	return NULL;
}

const struct bc_tree *bc_client_scene(const struct bc_client *c,
                                      struct bc_camera *cam)
{
	if (!c->has_scene) {
		return NULL;
	}
	if (cam) {
		*cam = c->camera;
	}
	return c->scene;
}

int bc_client_load_scene(struct bc_client *c, const uint8_t *bytes, size_t len,
                         uint64_t *order, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	uint32_t seq;
	int rc;
	if (order) {
		*order = 0;
	}
	/* One message when it fits the server's limit; else in parts, which
	 * a server that granted PARTS accepts (PROTOCOL.md 7.10.1). */
	size_t piece = c->info.max_payload > 4u ? c->info.max_payload - 4u
	                                        : BC_PROTO_MAX_PAYLOAD - 4u;
	bool parts = (c->info.features & BC_PROTO_FEATURE_PARTS) != 0;
	if (len == 0 || len > BC_PROTO_MAX_SCENE_BYTES ||
	    (len > piece && !parts)) {
		return bc_errinfo_set(
		    ei, BC_ELIMIT,
		    "a scene of %zu bytes does not fit one message (1..%zu)%s",
		    len, len > piece ? piece : (size_t)BC_PROTO_MAX_SCENE_BYTES,
		    parts ? ""
		          : " and the server did not grant scenes in parts "
		            "(PARTS): a server of an earlier protocol text");
	}
	for (size_t at = 0; at < len; at += piece) {
		size_t n = len - at < piece ? len - at : piece;
		m.type = BC_MSG_SCENE_LOAD;
		m.flags = (uint16_t)((at > 0 ? BC_PROTO_FLAG_CONT : 0u) |
		                     (at + n < len ? BC_PROTO_FLAG_MORE : 0u));
		m.scene_load.scene.ptr = bytes + at;
		m.scene_load.scene.len = (uint32_t)n;
		if ((rc = send_or_say(c, &m, &seq, ei))) {
			return rc;
		}
	}
	if ((rc = bc_client_wait(c, BC_MSG_SCENE_STATE, seq, &m, 0, ei))) {
		return rc;
	}
	if (order) {
		*order = m.scene_state.order;
	}
	return 0;
}

int bc_client_read_scene_file(const char *path, uint8_t **bytes, size_t *len,
                              uint32_t *nodes, struct bc_errinfo *ei)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	int rc;
	*bytes = NULL;
	*len = 0;
	if (nodes) {
		*nodes = 0;
	}
	if (!t) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	/* The tree is only encoded: no layout (a million spheres' would
	 * take seconds and hundreds of MB). */
	bc_tree_set_layout(t, false);
	if (!(rc = bc_scene_load_file(path, t, &cam, ei)) &&
	    (rc = bc_scene_encode(t, &cam, bytes, len))) {
		rc = bc_errinfo_set(ei, rc, "%s: cannot encode the scene: %s",
		                    path, bc_strerror(rc));
	}
	if (!rc && nodes) {
		*nodes = bc_tree_node_count(t);
	}
	bc_tree_destroy(t);
	return rc;
}

int bc_client_load_scene_file(struct bc_client *c, const char *path,
                              uint64_t *order, uint32_t *nodes,
                              struct bc_errinfo *ei)
{
	uint8_t *bytes;
	size_t len;
	int rc;
	if (order) {
		*order = 0;
	}
	/* The file's tree is gone before the scene is sent and its
	 * SCENE_STATE taken in. */
	if (!(rc = bc_client_read_scene_file(path, &bytes, &len, nodes, ei)) &&
	    (rc = bc_client_load_scene(c, bytes, len, order, ei)) && nodes) {
		*nodes = 0;
	}
	bc_free(bytes);
	return rc;
}

/* Whether a VIEW's encodings are ones our HELLO announced (the server
 * refuses others) and its still_encoding one a server that took our HELLO
 * reads (a server of a text before H.264 refuses VIEW's ninth byte, and it
 * would have refused a HELLO announcing H.264). */
static int view_encodings_announced(const struct bc_client *c,
                                    const struct bc_msg_view *v,
                                    struct bc_errinfo *ei)
{
	const enum bc_proto_encoding enc[2] = {v->encoding, v->still_encoding};
	for (int i = 0; i < 2; i++) {
		if (i == 1 && enc[i] == BC_PROTO_ENC_INVALID) {
			break;
		}
		if (enc[i] <= BC_PROTO_ENC_INVALID ||
		    enc[i] >= BC_PROTO_ENC_COUNT ||
		    !(c->encodings & (1u << (enc[i] - 1)))) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "VIEW %s %s was not announced in HELLO (encodings "
			    "0x%02x); connect with it in bc_client_opts "
			    "encodings",
			    i ? "still_encoding" : "encoding",
			    bc_proto_encoding_name(enc[i]),
			    (unsigned)c->encodings);
		}
	}
	if (v->still_encoding != BC_PROTO_ENC_INVALID &&
	    !(c->encodings & (1u << (BC_PROTO_ENC_H264 - 1)))) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "VIEW still_encoding needs H.264 "
		                      "announced in HELLO (encodings bit 3): "
		                      "a server that does not read it refuses "
		                      "the VIEW");
	}
	return 0;
}

int bc_client_view(struct bc_client *c, const struct bc_msg_view *view,
                   uint32_t *seq_out, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_VIEW};
	int rc;
	if (seq_out) {
		*seq_out = 0;
	}
	m.view = *view;
	if (m.view.encoding == BC_PROTO_ENC_INVALID) {
		bool jpeg = c->encodings & (1u << (BC_PROTO_ENC_JPEG - 1));
		m.view.encoding = jpeg ? BC_PROTO_ENC_JPEG : BC_PROTO_ENC_PNG;
	}
	if ((rc = view_encodings_announced(c, &m.view, ei))) {
		return rc;
	}
	if (m.view.quality_interactive == 0) {
		m.view.quality_interactive = 75;
	}
	if (m.view.quality_still == 0) {
		m.view.quality_still = 90;
	}
	if (m.view.downscale == 0) {
		m.view.downscale = 1;
	}
	return send_or_say(c, &m, seq_out, ei);
}

int bc_client_frame_ack(struct bc_client *c, uint32_t frame_no,
                        struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_FRAME_ACK};
	if (!(c->info.features & BC_PROTO_FEATURE_ACKS)) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "the server did not grant ACKS: it paces "
		                      "frames by itself and takes no "
		                      "FRAME_ACK (connect with bc_client_opts "
		                      "acks to ask for it)");
	}
	if (frame_no == 0) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "FRAME_ACK of frame 0: frames are "
		                      "numbered from 1");
	}
	m.frame_ack.frame_no = frame_no;
	return send_or_say(c, &m, NULL, ei);
}

int bc_client_camera(struct bc_client *c, const struct bc_camera *cam,
                     bool interacting, uint32_t *seq_out, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_CAMERA};
	if (seq_out) {
		*seq_out = 0;
	}
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	bc_edit_camera_to_msg(cam, &m.camera);
	return send_or_say(c, &m, seq_out, ei);
}

int bc_client_stats(struct bc_client *c, struct bc_msg_stats *out,
                    struct bc_errinfo *ei)
{
	return bc_client_stats_parts(c, 0, out, ei);
}

int bc_client_stats_parts(struct bc_client *c, uint8_t parts,
                          struct bc_msg_stats *out, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_GET_STATS};
	uint32_t seq;
	m.get_stats.parts = parts;
	int rc;
	memset(out, 0, sizeof(*out));
	if ((parts & BC_PROTO_STATS_MEMORY) &&
	    !(c->info.features & BC_PROTO_FEATURE_MEMORY)) {
		/* A server that does not know the part closes the
		 * connection for it (EPROTO_FLAGS). */
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "the server does not tell its scene "
		                      "memory (it did not grant MEMORY: an "
		                      "earlier blobcastd)");
	}
	if ((rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_STATS, seq, &m, 0, ei))) {
		return rc;
	}
	*out = m.stats;
	return 0;
}

/* ---- edits ---------------------------------------------------------------------- */

int bc_client_edit_set(struct bc_client *c, uint32_t node,
                       const struct bc_proto_field *fields, uint8_t nfields,
                       bool interacting, uint32_t *seq_out,
                       struct bc_errinfo *ei)
{
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	if (seq_out) {
		*seq_out = 0;
	}
	op.node = node;
	op.nfields = nfields;
	op.fields = fields;
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	m.edit.nops = 1;
	m.edit.ops = &op;
	return send_or_say(c, &m, seq_out, ei);
}

int bc_client_edit_kv(struct bc_client *c, uint32_t node, const char *const *kv,
                      size_t n, bool interacting, uint32_t *seq_out,
                      struct bc_errinfo *ei)
{
	struct bc_proto_field fields[BC_PROTO_MAX_SET_FIELDS];
	uint8_t nfields;
	int rc;
	if (seq_out) {
		*seq_out = 0;
	}
	if (c->err) {
		return sticky(c, ei);
	}
	if (!c->has_scene) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "no scene yet: join a session first");
	}
	if ((rc = bc_client_edit_parse(c->scene, node, kv, n, fields, &nfields,
	                               ei))) {
		return rc;
	}
	return bc_client_edit_set(c, node, fields, nfields, interacting,
	                          seq_out, ei);
}

int bc_client_wait_applied(struct bc_client *c, uint32_t seq, uint64_t *order,
                           struct bc_errinfo *ei)
{
	struct bc_msg m;
	int rc;
	if (order) {
		*order = 0;
	}
	if ((rc = bc_client_wait(c, BC_MSG_EDIT_APPLIED, seq, &m, 0, ei))) {
		return rc;
	}
	if (order) {
		*order = m.edit_applied.order;
	}
	return 0;
}

/* ---- snapshots --------------------------------------------------------------------- */

int bc_client_snapshot(struct bc_client *c, enum bc_proto_encoding encoding,
                       struct bc_client_image *out, struct bc_errinfo *ei)
{
	return bc_client_snapshot_planes(c, encoding, 0, out, ei);
}

int bc_client_snapshot_planes(struct bc_client *c,
                              enum bc_proto_encoding encoding, unsigned planes,
                              struct bc_client_image *out,
                              struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	uint32_t seq;
	int rc;
	if (encoding == BC_PROTO_ENC_INVALID) {
		encoding = BC_PROTO_ENC_PNG;
	}
	if (encoding != BC_PROTO_ENC_PNG && encoding != BC_PROTO_ENC_RAW) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "snapshots are PNG or raw");
	}
	if (planes & ~BC_PROTO_PLANES_ALL) {
		return bc_errinfo_set(ei, BC_EINVAL, "planes 0x%x", planes);
	}
	m.snapshot.encoding = encoding;
	m.snapshot.planes = (uint8_t)planes;
	if ((rc = send_or_say(c, &m, &seq, ei))) {
		return rc;
	}
	for (;;) {
		if ((rc = bc_client_wait(c, BC_MSG_FRAME, seq, &m, 0, ei))) {
			return rc;
		}
		if (m.flags & BC_PROTO_FLAG_SNAPSHOT) {
			break;
		}
	}
	/* A snapshot is a picture of its own: never patched over whatever
	 * the image held. */
	bc_client_image_finish(out);
	bc_client_image_init(out);
	if ((rc = bc_client_image_apply(out, &m, ei))) {
		return rc;
	}
	if (((planes & BC_PROTO_PLANE_DEPTH) && !out->depth) ||
	    ((planes & BC_PROTO_PLANE_IDS) && !out->ids)) {
		return bc_errinfo_set(ei, BC_EIO,
		                      "the snapshot lacks a plane asked for");
	}
	return 0;
}

int bc_client_delete_session(struct bc_client *c, const char *name,
                             struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_DELETE};
	uint32_t seq;
	int rc;
	if (!name || !*name || strlen(name) > BC_PROTO_MAX_NAME) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "session names have 1..%u bytes",
		                      BC_PROTO_MAX_NAME);
	}
	m.session_delete.name.ptr = name;
	m.session_delete.name.len = (uint32_t)strlen(name);
	if ((rc = send_or_say(c, &m, &seq, ei))) {
		return rc;
	}
	/* A member deleting its own session hears ENOSESSION (seq 0)
	 * first, like every member. */
	while ((rc = bc_client_wait(c, BC_MSG_OK, seq, &m, 0, ei)) &&
	       m.type == BC_MSG_ERROR && m.seq == 0 && rc == BC_ENOSESSION) {
	}
	return rc;
}

/* BC_ENOTSUP unless the server granted per-person undo and HISTORY. */
static int need_history(const struct bc_client *c, struct bc_errinfo *ei)
{
	if (c->info.features & BC_PROTO_FEATURE_HISTORY) {
		return 0;
	}
	return bc_errinfo_set(ei, BC_ENOTSUP,
	                      "the server has no per-person undo or history "
	                      "(it is older than this client): only the "
	                      "session's undo is there");
}

/* UNDO or REDO of scope (BC_PROTO_UNDO_*; 0: no scope byte). */
static int undo_with(struct bc_client *c, bool redo, uint8_t scope,
                     struct bc_client_undone *out, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = redo ? BC_MSG_REDO : BC_MSG_UNDO};
	const struct bc_msg_edit_applied *a = &m.edit_applied;
	uint32_t seq;
	int rc;
	if (out) {
		memset(out, 0, sizeof(*out));
	}
	if (scope && (rc = need_history(c, ei))) {
		return rc;
	}
	m.undo.scope = scope;
	if ((rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_EDIT_APPLIED, seq, &m, 0, ei))) {
		return rc;
	}
	if (out) {
		out->order = a->order;
		out->target_order = a->target_order;
		copy_str(out->target_author, sizeof(out->target_author),
		         a->target_author);
	}
	return 0;
}

int bc_client_undo(struct bc_client *c, bool redo, struct bc_client_undone *out,
                   struct bc_errinfo *ei)
{
	return undo_with(c, redo, BC_PROTO_UNDO_DEFAULT, out, ei);
}

int bc_client_undo_mine(struct bc_client *c, bool redo,
                        struct bc_client_undone *out, struct bc_errinfo *ei)
{
	return undo_with(c, redo, BC_PROTO_UNDO_MINE, out, ei);
}

int bc_client_undo_session(struct bc_client *c, bool redo,
                           struct bc_client_undone *out, struct bc_errinfo *ei)
{
	return undo_with(c, redo, BC_PROTO_UNDO_SESSION, out, ei);
}

int bc_client_history(struct bc_client *c, struct bc_client_change **out,
                      size_t *n, uint64_t *order, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_HISTORY_GET};
	struct bc_client_change *list = NULL;
	uint32_t seq;
	int rc;
	*out = NULL;
	*n = 0;
	if (order) {
		*order = 0;
	}
	if ((rc = need_history(c, ei)) || (rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_HISTORY, seq, &m, 0, ei))) {
		return rc;
	}
	if (m.history.nentries &&
	    !(list = bc_calloc(m.history.nentries, sizeof(*list)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (uint32_t i = 0; i < m.history.nentries; i++) {
		const struct bc_proto_history_entry *e = &m.history.entries[i];
		list[i].order = e->order;
		list[i].time_ms = e->time_ms;
		list[i].built_on = e->built_on;
		list[i].undone = e->state == BC_PROTO_HISTORY_UNDONE;
		list[i].yours = (e->flags & BC_PROTO_HISTORY_YOURS) != 0;
		list[i].next = (e->flags & BC_PROTO_HISTORY_NEXT) != 0;
		copy_str(list[i].author, sizeof(list[i].author), e->author);
		copy_str(list[i].what, sizeof(list[i].what), e->what);
	}
	*out = list;
	*n = m.history.nentries;
	if (order) {
		*order = m.history.order;
	}
	return 0;
}

int bc_client_mesh(struct bc_client *c, int format, uint8_t options,
                   uint16_t resolution, int timeout_ms,
                   struct bc_client_mesh *out, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_MESH};
	uint32_t seq;
	int rc;
	memset(out, 0, sizeof(*out));
	if (!(c->info.features & BC_PROTO_FEATURE_MESH)) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "the server does not make meshes (it is "
		                      "older than this client): mesh here "
		                      "instead");
	}
	m.mesh.format = (enum bc_proto_mesh_format)format;
	m.mesh.options = options;
	m.mesh.resolution = resolution;
	if ((rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_MESH_DATA, seq, &m, timeout_ms,
	                         ei))) {
		return rc;
	}
	if (!(out->file = bc_malloc(m.mesh_data.file.len))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	memcpy(out->file, m.mesh_data.file.ptr, m.mesh_data.file.len);
	out->len = m.mesh_data.file.len;
	out->vertices = m.mesh_data.vertices;
	out->triangles = m.mesh_data.triangles;
	out->resolution = m.mesh_data.resolution;
	out->order = m.mesh_data.order;
	return 0;
}

int bc_client_sessions(struct bc_client *c, struct bc_client_session **out,
                       size_t *n, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_LIST};
	struct bc_client_session *list = NULL;
	uint32_t seq;
	int rc;
	*out = NULL;
	*n = 0;
	if ((rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_SESSIONS, seq, &m, 0, ei))) {
		return rc;
	}
	if (m.sessions.nsessions &&
	    !(list = bc_calloc(m.sessions.nsessions, sizeof(*list)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (uint32_t i = 0; i < m.sessions.nsessions; i++) {
		const struct bc_proto_session_entry *e =
		    &m.sessions.sessions[i];
		copy_str(list[i].name, sizeof(list[i].name), e->name);
		list[i].members = e->members;
		list[i].prims = e->prims;
		list[i].order = e->order;
		list[i].last_edit_ms = e->last_edit_ms;
		list[i].loaded = (e->flags & BC_PROTO_SESSION_LOADED) != 0;
		list[i].known = (e->flags & BC_PROTO_SESSION_KNOWN) != 0;
	}
	*out = list;
	*n = m.sessions.nsessions;
	return 0;
}

int bc_client_present(struct bc_client *c, bool on, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_PRESENT};
	uint32_t seq;
	int rc;
	m.toggle.on = on ? 1 : 0;
	if ((rc = send_or_say(c, &m, &seq, ei))) {
		return rc;
	}
	return bc_client_wait(c, BC_MSG_OK, seq, &m, 0, ei);
}

int bc_client_follow(struct bc_client *c, bool on, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_FOLLOW};
	uint32_t seq;
	int rc;
	m.toggle.on = on ? 1 : 0;
	if ((rc = send_or_say(c, &m, &seq, ei))) {
		return rc;
	}
	return bc_client_wait(c, BC_MSG_OK, seq, &m, 0, ei);
}

int bc_client_session_camera(struct bc_client *c, const struct bc_camera *cam,
                             uint64_t *order, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_CAMERA};
	uint32_t seq;
	int rc;
	if (order) {
		*order = 0;
	}
	bc_edit_camera_to_msg(cam, &m.session_camera);
	if ((rc = send_or_say(c, &m, &seq, ei)) ||
	    (rc = bc_client_wait(c, BC_MSG_SESSION_CAMERA_SET, seq, &m, 0,
	                         ei))) {
		return rc;
	}
	if (order) {
		*order = m.session_camera_set.order;
	}
	return 0;
}
