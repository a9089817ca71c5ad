/*
 * Accepting connections (loop thread): the TCP and Unix listeners opened
 * from --listen and --unix, and the checks a new connection passes before
 * it gets a slot -- the connection limit, loopback or a configured token
 * for TCP peers, and the cap on connections from one address that have
 * not said HELLO; refusals are logged at most once a second. An accepted
 * connection is handed to net.c's reader and HELLO timer.
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

/* The peer address of a TCP connection as 16 bytes (IPv4 in its v4-mapped
 * IPv6 form, so both spellings of one host compare equal); false when it
 * cannot be read. */
static bool peer_addr16(uv_tcp_t *tcp, uint8_t out[16])
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	if (uv_tcp_getpeername(tcp, (struct sockaddr *)&sa, &len) != 0) {
		return false;
	}
	if (sa.ss_family == AF_INET) {
		const struct sockaddr_in *in = (const struct sockaddr_in *)&sa;
		memset(out, 0, 10);
		out[10] = out[11] = 0xff;
		memcpy(out + 12, &in->sin_addr.s_addr, 4);
		return true;
	}
	if (sa.ss_family == AF_INET6) {
		const struct sockaddr_in6 *in6 =
		    (const struct sockaddr_in6 *)&sa;
		memcpy(out, in6->sin6_addr.s6_addr, 16);
		return true;
	}
	return false;
}

/* Whether c's peer already holds BC_SRV_MAX_PREHELLO_PER_ADDR connections
 * that have not completed HELLO (c, not yet in the table, not counted). */
static bool prehello_cap_reached(struct bc_srv *srv, struct bc_conn *c)
{
	uint8_t mine[16], theirs[16];
	uint32_t n = 0;
	if (c->is_tcp && !peer_addr16(&c->h.tcp, mine)) {
		return false;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		struct bc_conn *o = srv->clients[i];
		if (!o || o->closing || o->draining ||
		    o->stage != BC_PROTO_STAGE_HELLO ||
		    o->is_tcp != c->is_tcp) {
			continue;
		}
		if (c->is_tcp && (!peer_addr16(&o->h.tcp, theirs) ||
		                  memcmp(mine, theirs, 16) != 0)) {
			continue;
		}
		if (++n >= BC_SRV_MAX_PREHELLO_PER_ADDR) {
			return true;
		}
	}
	return false;
}

/* A warning for refused connections at most once a second: a flood must
 * not flood the log too. */
static void warn_refused(struct bc_srv *srv, const char *why)
{
	static uint64_t last_ms;
	static uint32_t suppressed;
	uint64_t now = bc_now_ms(srv);
	if (last_ms && now - last_ms < 1000) {
		suppressed++;
		return;
	}
	if (suppressed) {
		bc_log(BC_LOG_WARN,
		       "refusing a connection: %s (and %u more refused in "
		       "the last second)",
		       why, suppressed);
	} else {
		bc_log(BC_LOG_WARN, "refusing a connection: %s", why);
	}
	last_ms = now;
	suppressed = 0;
}

static void on_connection(uv_stream_t *server, int status)
{
	struct bc_srv *srv = server->data;
	bool tcp = server == (uv_stream_t *)&srv->tcp_listener;
	struct bc_conn *c;
	uint32_t slot = 0;
	if (status < 0) {
		bc_log(BC_LOG_WARN, "accept: %s", uv_strerror(status));
		return;
	}
	c = bc_calloc(1, sizeof(*c));
	if (!c) {
		return;
	}
	c->srv = srv;
	if (tcp) {
		uv_tcp_init(srv->loop, &c->h.tcp);
	} else {
		uv_pipe_init(srv->loop, &c->h.pipe, 0);
	}
	c->h.handle.data = c;
	uv_timer_init(srv->loop, &c->hello_timer);
	c->hello_timer.data = c;
	c->is_tcp = tcp;
	if (uv_accept(server, &c->h.stream) != 0) {
		c->handles_open = 2;
		c->closing = true;
		uv_close(&c->h.handle, bc__net_handle_closed);
		uv_close((uv_handle_t *)&c->hello_timer, bc__net_handle_closed);
		return;
	}
	c->trusted = !tcp || is_loopback(&c->h.tcp);
	while (slot < BC_SRV_MAX_CONNECTIONS && srv->clients[slot]) {
		slot++;
	}
	if (srv->stopping || slot == BC_SRV_MAX_CONNECTIONS ||
	    (tcp && !c->trusted && srv->cfg.ntokens == 0) ||
	    prehello_cap_reached(srv, c)) {
		warn_refused(srv,
		             srv->stopping ? "shutting down"
		             : slot == BC_SRV_MAX_CONNECTIONS
		                 ? "too many connections"
		             : (tcp && !c->trusted && srv->cfg.ntokens == 0)
		                 ? "not loopback and no token configured"
		                 : "too many connections from one address "
		                   "without HELLO");
		c->handles_open = 2;
		c->closing = true;
		uv_close(&c->h.handle, bc__net_handle_closed);
		uv_close((uv_handle_t *)&c->hello_timer, bc__net_handle_closed);
		return;
	}
	c->slot = slot;
	c->gen = ++srv->gens[slot] * BC_SRV_MAX_CONNECTIONS + slot;
	srv->clients[slot] = c;
	srv->nclients++;
	snprintf(c->name, sizeof(c->name), "?");
	bc_proto_reader_init(&c->reader, &(struct bc_proto_reader_opts){
	                                     .side = BC_PROTO_SIDE_SERVER,
	                                     .await_hello = true,
	                                 });
	if (tcp) {
		uv_tcp_nodelay(&c->h.tcp, 1);
	}
	if (tcp && srv->tls && !(c->tls = bc_tls_new(srv->tls))) {
		bc_conn_close(c, "out of memory for TLS");
		return;
	}
	uv_timer_start(&c->hello_timer, bc__net_hello_timeout,
	               BC_SRV_HELLO_TIMEOUT_MS, 0);
	uv_read_start(&c->h.stream, bc__net_on_alloc, bc__net_on_read);
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

bool bc_net_tokens_in_clear(struct bc_srv *srv)
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	if (!srv->has_tcp || srv->tls || srv->cfg.ntokens == 0) {
		return false;
	}
	if (uv_tcp_getsockname(&srv->tcp_listener, (struct sockaddr *)&sa,
	                       &len) != 0) {
		return true;
	}
	return !bc_addr_is_loopback((const struct sockaddr *)&sa);
}

/* Tokens would cross the network readable by anyone on the path: refused
 * unless the operator said --allow-plaintext (a network of its own, a
 * proxy in front on the same host), and then warned about. */
static int check_plaintext(struct bc_srv *srv, struct bc_errinfo *ei)
{
	if (!bc_net_tokens_in_clear(srv)) {
		return 0;
	}
	if (!srv->cfg.allow_plaintext) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "--listen %s is reachable from other "
		                      "hosts and tokens are configured: give "
		                      "--tls-cert and --tls-key so that tokens "
		                      "are not sent in clear, or "
		                      "--allow-plaintext (docs/operations.md, "
		                      "TLS)",
		                      srv->cfg.listen);
	}
	bc_log(BC_LOG_WARN,
	       "listening on %s without TLS (--allow-plaintext): tokens and "
	       "scenes cross the network in clear",
	       srv->cfg.listen);
	return 0;
}

int bc_net_listen(struct bc_srv *srv, struct bc_errinfo *ei)
{
	int rc;
	if (srv->cfg.listen && srv->cfg.tls_cert && !srv->tls &&
	    (rc = bc_tls_ctx_new(&srv->tls, srv->cfg.tls_cert,
	                         srv->cfg.tls_key ? srv->cfg.tls_key
	                                          : srv->cfg.tls_cert,
	                         ei))) {
		return rc;
	}
	uv_timer_init(srv->loop, &srv->stall_timer);
	srv->stall_timer.data = srv;
	uv_timer_start(&srv->stall_timer, bc__net_check_stalls, 1000, 1000);
	if (srv->cfg.listen) {
		char host[256];
		int port;
		struct sockaddr_storage sa;
		if (parse_listen(srv->cfg.listen, host, sizeof(host), &port)) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "--listen %s: expected HOST:PORT",
			                      srv->cfg.listen);
		}
		if (uv_ip4_addr(host, port, (struct sockaddr_in *)&sa) != 0 &&
		    uv_ip6_addr(host, port, (struct sockaddr_in6 *)&sa) != 0) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "--listen %s: not an IP address",
			                      srv->cfg.listen);
		}
		uv_tcp_init(srv->loop, &srv->tcp_listener);
		srv->tcp_listener.data = srv;
		srv->has_tcp = true;
		if ((rc = uv_tcp_bind(&srv->tcp_listener,
		                      (const struct sockaddr *)&sa, 0)) ||
		    (rc = uv_listen((uv_stream_t *)&srv->tcp_listener, 64,
		                    on_connection))) {
			return bc_errinfo_set(ei, BC_EIO, "listen on %s: %s",
			                      srv->cfg.listen, uv_strerror(rc));
		}
		if ((rc = check_plaintext(srv, ei))) {
			return rc;
		}
		bc_log(BC_LOG_INFO, "listening on %s%s", srv->cfg.listen,
		       srv->tls ? " (TLS)" : "");
	}
	if (srv->cfg.unix_path) {
		uv_pipe_init(srv->loop, &srv->unix_listener, 0);
		srv->unix_listener.data = srv;
		srv->has_unix = true;
		/* A socket file left by a daemon that died is replaced. */
		unlink(srv->cfg.unix_path);
		if ((rc = uv_pipe_bind(&srv->unix_listener,
		                       srv->cfg.unix_path)) ||
		    (rc = uv_listen((uv_stream_t *)&srv->unix_listener, 64,
		                    on_connection))) {
			return bc_errinfo_set(ei, BC_EIO, "listen on %s: %s",
			                      srv->cfg.unix_path,
			                      uv_strerror(rc));
		}
		bc_log(BC_LOG_INFO, "listening on unix:%s", srv->cfg.unix_path);
	}
	return 0;
}
