/*
 * Admission (loop thread): who gets one of the BC_SRV_MAX_CONNECTIONS
 * slots. A connection that has not completed HELLO costs a slot, a reader
 * and, on the TLS port, a handshake; an attacker can open many from many
 * addresses and never finish them. So, like nginx's per-address limits:
 *  - at most BC_SRV_MAX_PREHELLO_PER_ADDR unauthenticated connections per
 *    peer address and BC_SRV_MAX_PREHELLO_PER_PREFIX per prefix (/24 for
 *    IPv4, /56 for IPv6); a new one past a cap closes the oldest
 *    unauthenticated one of that address or prefix instead of being
 *    refused, so a legitimate client sharing the prefix with an attacker
 *    still gets in and has until BC_SRV_MAX_PREHELLO_PER_PREFIX newer
 *    connections came to say HELLO;
 *  - when every slot is taken, the oldest unauthenticated connection
 *    anywhere makes room, and failing that the client that said HELLO,
 *    joined no session and has been silent longest (at least
 *    BC_SRV_EVICT_IDLE_MS);
 *  - only when every slot holds a client in a session (or one that spoke
 *    recently) is the new connection refused.
 * Unix-socket peers count as one address of their own.
 */
#include <string.h>

#include "blobcast/log.h"
#include "net_impl.h"

void bc__admit_address(struct bc_conn *c)
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	memset(c->addr, 0, sizeof(c->addr));
	c->has_addr = false;
	if (!c->is_tcp ||
	    uv_tcp_getpeername(&c->h.tcp, (struct sockaddr *)&sa, &len) != 0) {
		return;
	}
	if (sa.ss_family == AF_INET) {
		const struct sockaddr_in *in = (const struct sockaddr_in *)&sa;
		c->addr[10] = c->addr[11] = 0xff;
		memcpy(c->addr + 12, &in->sin_addr.s_addr, 4);
		c->has_addr = true;
	} else if (sa.ss_family == AF_INET6) {
		const struct sockaddr_in6 *in6 =
		    (const struct sockaddr_in6 *)&sa;
		memcpy(c->addr, in6->sin6_addr.s6_addr, 16);
		c->has_addr = true;
	}
}

/* Bytes of the address that make its prefix: /24 of an IPv4 address in
 * its v4-mapped form, /56 of an IPv6 one. */
static size_t prefix_bytes(const uint8_t addr[16])
{
	static const uint8_t mapped[12] = {0, 0, 0, 0, 0,    0,
	                                   0, 0, 0, 0, 0xff, 0xff};
	return memcmp(addr, mapped, sizeof(mapped)) == 0 ? 15u : 7u;
}

/* Whether o shares the first k bytes of c's address (k 16: the address;
 * Unix-socket peers share theirs). */
static bool same(const struct bc_conn *c, const struct bc_conn *o, size_t k)
{
	if (c->is_tcp != o->is_tcp || c->has_addr != o->has_addr) {
		return false;
	}
	return !c->has_addr || memcmp(c->addr, o->addr, k) == 0;
}

static bool unauthenticated(const struct bc_conn *o)
{
	return o && !o->closing && !o->draining && !o->authed;
}

/* Closes, when `cap` or more unauthenticated connections share the first
 * k address bytes with c, the oldest of them. */
static void cap_group(struct bc_net *n, const struct bc_conn *c, size_t k,
                      uint32_t cap, const char *what)
{
	struct bc_conn *oldest = NULL;
	uint32_t count = 0;
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		struct bc_conn *o = n->clients[i];
		if (!unauthenticated(o) || !same(c, o, k)) {
			continue;
		}
		count++;
		if (!oldest || o->accepted_ms < oldest->accepted_ms) {
			oldest = o;
		}
	}
	if (count >= cap && oldest) {
		bc_log(BC_LOG_INFO,
		       "connection %u: closed for a newer one (%u without "
		       "HELLO from one %s)",
		       oldest->gen, count, what);
		bc__conn_close(oldest, "made room for a newer connection");
	}
}

/* The slot of the connection to close when all are taken, or
 * BC_SRV_MAX_CONNECTIONS: the oldest unauthenticated, else the longest
 * idle in no session. */
static uint32_t victim(struct bc_net *n)
{
	uint32_t pick = BC_SRV_MAX_CONNECTIONS, idle = BC_SRV_MAX_CONNECTIONS;
	uint64_t now = uv_now(n->loop);
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		struct bc_conn *o = n->clients[i];
		if (unauthenticated(o) &&
		    (pick == BC_SRV_MAX_CONNECTIONS ||
		     o->accepted_ms < n->clients[pick]->accepted_ms)) {
			pick = i;
		}
		if (o && !o->closing && o->authed &&
		    now - o->last_read_ms >= BC_SRV_EVICT_IDLE_MS &&
		    bc_dispatch_idle(n->d,
		                     (struct bc_conn_ref){o->slot, o->gen}) &&
		    (idle == BC_SRV_MAX_CONNECTIONS ||
		     o->last_read_ms < n->clients[idle]->last_read_ms)) {
			idle = i;
		}
	}
	return pick != BC_SRV_MAX_CONNECTIONS ? pick : idle;
}

uint32_t bc__admit(struct bc_net *n, struct bc_conn *c, const char **why)
{
	uint32_t slot = 0, v;
	cap_group(n, c, 16, BC_SRV_MAX_PREHELLO_PER_ADDR, "address");
	if (c->has_addr) {
		cap_group(n, c, prefix_bytes(c->addr),
		          BC_SRV_MAX_PREHELLO_PER_PREFIX, "prefix");
	}
	while (slot < BC_SRV_MAX_CONNECTIONS && n->clients[slot]) {
		slot++;
	}
	if (slot < BC_SRV_MAX_CONNECTIONS) {
		return slot;
	}
	if ((v = victim(n)) == BC_SRV_MAX_CONNECTIONS) {
		*why = "too many connections";
		return BC_SRV_MAX_CONNECTIONS;
	}
	bc_log(BC_LOG_INFO, "connection %u: closed to make room for a new one",
	       n->clients[v]->gen);
	bc__conn_close(n->clients[v], n->clients[v]->authed
	                                  ? "idle, its slot was needed"
	                                  : "no HELLO, its slot was needed");
	return v;
}
