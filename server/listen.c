/*
 * Accepting connections (loop thread): the TCP and Unix listeners opened
 * from --listen and --unix, and the checks a new connection passes before
 * it gets a slot -- loopback or a configured token for TCP peers, and
 * admission (admit.c: caps per address and per prefix on connections that
 * have not said HELLO, room made by closing the oldest of those); refusals
 * are logged at most once a second. An accepted connection is handed to
 * net.c's reader and HELLO timer. Also what main needs of the listeners:
 * where they are, the plaintext rule, reloading the certificate.
 */
#include <arpa/inet.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "addr.h"
#include "net_impl.h"
#include "tls.h"

static bool is_loopback(uv_tcp_t *tcp)
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	if (uv_tcp_getpeername(tcp, (struct sockaddr *)&sa, &len) != 0) {
		return false;
	}
	/* 127/8, ::1 and v4-mapped ::ffff:127/104 (a [::] listener sees
	 * IPv4 loopback clients in that form). */
	return bc_addr_is_loopback((const struct sockaddr *)&sa);
}

/* A warning for refused connections at most once a second: a flood must
 * not flood the log too. */
static void warn_refused(struct bc_net *n, const char *why)
{
	uint64_t now = uv_now(n->loop);
	if (n->refused_log_ms && now - n->refused_log_ms < 1000) {
		n->refused_quiet++;
		return;
	}
	if (n->refused_quiet) {
		bc_log(BC_LOG_WARN,
		       "refusing a connection: %s (and %u more refused in "
		       "the last second)",
		       why, n->refused_quiet);
	} else {
		bc_log(BC_LOG_WARN, "refusing a connection: %s", why);
	}
	n->refused_log_ms = now;
	n->refused_quiet = 0;
}

/* Closes a connection that never got a slot. */
static void discard(struct bc_conn *c)
{
	c->handles_open = 2;
	c->closing = true;
	uv_close(&c->h.handle, bc__net_handle_closed);
	uv_close((uv_handle_t *)&c->hello_timer, bc__net_handle_closed);
}

static void on_connection(uv_stream_t *server, int status)
{
	struct bc_net *n = server->data;
	bool tcp = server == (uv_stream_t *)&n->tcp_listener;
	const char *why = NULL;
	struct bc_conn *c;
	uint32_t slot;
	if (status < 0) {
		bc_log(BC_LOG_WARN, "accept: %s", uv_strerror(status));
		return;
	}
	if (!(c = bc_calloc(1, sizeof(*c)))) {
		return;
	}
	c->net = n;
	if (tcp) {
		uv_tcp_init(n->loop, &c->h.tcp);
	} else {
		uv_pipe_init(n->loop, &c->h.pipe, 0);
	}
	c->h.handle.data = c;
	uv_timer_init(n->loop, &c->hello_timer);
	/* Before anything can discard it: both handles' close callbacks
	 * find the connection through data. */
	c->hello_timer.data = c;
	c->is_tcp = tcp;
	c->accepted_ms = uv_now(n->loop);
	if (uv_accept(server, &c->h.stream) != 0) {
		discard(c);
		return;
	}
	c->trusted = !tcp || is_loopback(&c->h.tcp);
	bc__admit_address(c);
	if (n->stopping) {
		why = "shutting down";
	} else if (tcp && !c->trusted && n->cfg->ntokens == 0) {
		why = "not loopback and no token configured";
	}
	if (why || (slot = bc__admit(n, c, &why)) == BC_SRV_MAX_CONNECTIONS) {
		warn_refused(n, why);
		discard(c);
		return;
	}
	if (tcp) {
		uv_tcp_nodelay(&c->h.tcp, 1);
	}
	if (tcp && n->tls && !(c->tls = bc_tls_new(n->tls))) {
		discard(c);
		return;
	}
	bc__conn_start(c, slot);
	bc_log(BC_LOG_INFO, "connection %u from %s%s", c->gen,
	       tcp ? (c->trusted ? "loopback" : "network") : "unix socket",
	       c->tls ? " (TLS)" : "");
}

static int parse_listen(const char *spec, char *host, size_t hostlen, int *port)
{
	const char *colon = strrchr(spec, ':');
	char *end;
	long p;
	size_t n;
	if (!colon) {
		return BC_EINVAL;
	}
	n = (size_t)(colon - spec);
	if (n >= 2 && spec[0] == '[' && spec[n - 1] == ']') {
		/* [::]:7878, the usual spelling of an IPv6 host with a port */
		spec++;
		n -= 2;
	}
	if (n == 0 || n >= hostlen) {
		return BC_EINVAL;
	}
	memcpy(host, spec, n);
	host[n] = '\0';
	p = strtol(colon + 1, &end, 10);
	if (*end || p < 0 || p > 65535) {
		return BC_EINVAL;
	}
	*port = (int)p;
	return 0;
}

bool bc_net_tokens_in_clear(struct bc_net *n)
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	if (!n->has_tcp || n->tls || n->cfg->ntokens == 0) {
		return false;
	}
	if (uv_tcp_getsockname(&n->tcp_listener, (struct sockaddr *)&sa,
	                       &len) != 0) {
		return true;
	}
	return !bc_addr_is_loopback((const struct sockaddr *)&sa);
}

/* Tokens would cross the network readable by anyone on the path: refused
 * unless the operator said --allow-plaintext (a network of its own, a
 * proxy in front on the same host), and then warned about. */
static int check_plaintext(struct bc_net *n, struct bc_errinfo *ei)
{
	if (!bc_net_tokens_in_clear(n)) {
		return 0;
	}
	if (!n->cfg->allow_plaintext) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "--listen %s is reachable from other "
		                      "hosts and tokens are configured: give "
		                      "--tls-cert and --tls-key so that tokens "
		                      "are not sent in clear, or "
		                      "--allow-plaintext (docs/operations.md, "
		                      "TLS)",
		                      n->cfg->listen);
	}
	bc_log(BC_LOG_WARN,
	       "listening on %s without TLS (--allow-plaintext): tokens and "
	       "scenes cross the network in clear",
	       n->cfg->listen);
	return 0;
}

int bc_net_listen(struct bc_net *n, struct bc_errinfo *ei)
{
	int rc;
	if (n->cfg->listen && n->cfg->tls_cert && !n->tls &&
	    (rc = bc_tls_ctx_new(&n->tls, n->cfg->tls_cert,
	                         n->cfg->tls_key ? n->cfg->tls_key
	                                         : n->cfg->tls_cert,
	                         n->cfg->tls_allow_expired, ei))) {
		return rc;
	}
	if (n->tls) {
		bc_dispatch_set_tls_expiry(n->d,
		                           bc_tls_ctx_not_after_ms(n->tls));
	}
	uv_timer_start(&n->stall_timer, bc__net_check_stalls, 1000, 1000);
	if (n->cfg->listen) {
		char host[256];
		int port;
		struct sockaddr_storage sa;
		if (parse_listen(n->cfg->listen, host, sizeof(host), &port)) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "--listen %s: expected HOST:PORT",
			                      n->cfg->listen);
		}
		if (uv_ip4_addr(host, port, (struct sockaddr_in *)&sa) != 0 &&
		    uv_ip6_addr(host, port, (struct sockaddr_in6 *)&sa) != 0) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "--listen %s: not an IP address",
			                      n->cfg->listen);
		}
		uv_tcp_init(n->loop, &n->tcp_listener);
		n->tcp_listener.data = n;
		n->has_tcp = true;
		if ((rc = uv_tcp_bind(&n->tcp_listener,
		                      (const struct sockaddr *)&sa, 0)) ||
		    (rc = uv_listen((uv_stream_t *)&n->tcp_listener, 64,
		                    on_connection))) {
			return bc_errinfo_set(ei, BC_EIO, "listen on %s: %s",
			                      n->cfg->listen, uv_strerror(rc));
		}
		if ((rc = check_plaintext(n, ei))) {
			return rc;
		}
		bc_log(BC_LOG_INFO, "listening on %s%s", n->cfg->listen,
		       n->tls ? " (TLS)" : "");
	}
	if (n->cfg->unix_path) {
		uv_pipe_init(n->loop, &n->unix_listener, 0);
		n->unix_listener.data = n;
		n->has_unix = true;
		/* A socket file left by a daemon that died is replaced. */
		unlink(n->cfg->unix_path);
		if ((rc = uv_pipe_bind(&n->unix_listener, n->cfg->unix_path)) ||
		    (rc = uv_listen((uv_stream_t *)&n->unix_listener, 64,
		                    on_connection))) {
			return bc_errinfo_set(ei, BC_EIO, "listen on %s: %s",
			                      n->cfg->unix_path,
			                      uv_strerror(rc));
		}
		bc_log(BC_LOG_INFO, "listening on unix:%s", n->cfg->unix_path);
	}
	return 0;
}

/* Without tokens only loopback and Unix-socket clients get in: say so when
 * the TCP listener is reachable from other hosts, where an operator would
 * otherwise see connections refused with no hint at start. */
void bc_net_warn_exposed(struct bc_net *n)
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	if (!n->has_tcp || n->cfg->ntokens > 0 ||
	    uv_tcp_getsockname(&n->tcp_listener, (struct sockaddr *)&sa,
	                       &len) != 0 ||
	    bc_addr_is_loopback((const struct sockaddr *)&sa)) {
		return;
	}
	bc_log(BC_LOG_WARN,
	       "listening on %s with no tokens configured: only loopback "
	       "and Unix-socket clients will be accepted (docs/operations.md, "
	       "Access)",
	       n->cfg->listen);
}

void bc_net_announce(struct bc_net *n)
{
	if (n->has_tcp) {
		struct sockaddr_storage sa;
		int len = sizeof(sa);
		char host[64] = "?";
		int port = 0;
		uv_tcp_getsockname(&n->tcp_listener, (struct sockaddr *)&sa,
		                   &len);
		if (sa.ss_family == AF_INET) {
			struct sockaddr_in *in = (struct sockaddr_in *)&sa;
			uv_ip4_name(in, host, sizeof(host));
			port = ntohs(in->sin_port);
		} else if (sa.ss_family == AF_INET6) {
			struct sockaddr_in6 *in6 = (struct sockaddr_in6 *)&sa;
			uv_ip6_name(in6, host, sizeof(host));
			port = ntohs(in6->sin6_port);
		}
		fprintf(stderr, "blobcastd: listening on %s:%d\n", host, port);
	}
	if (n->has_unix) {
		fprintf(stderr, "blobcastd: listening on unix:%s\n",
		        n->cfg->unix_path);
	}
	bc_net_warn_exposed(n);
}

int bc_net_reload_tls(struct bc_net *n, struct bc_errinfo *ei)
{
	struct bc_tls_ctx *fresh = NULL;
	int rc;
	if (!n->tls) {
		return 0;
	}
	if ((rc = bc_tls_ctx_new(&fresh, n->cfg->tls_cert,
	                         n->cfg->tls_key ? n->cfg->tls_key
	                                         : n->cfg->tls_cert,
	                         n->cfg->tls_allow_expired, ei))) {
		return rc;
	}
	bc_tls_ctx_free(n->tls);
	n->tls = fresh;
	bc_dispatch_set_tls_expiry(n->d, bc_tls_ctx_not_after_ms(n->tls));
	return 0;
}
