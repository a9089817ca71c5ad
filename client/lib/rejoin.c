/*
 * Reconnecting: what a client remembers of how it connected and which
 * session it entered, the call that opens a new connection into the same
 * session (bc_client_rejoin), letting go of a lost connection's socket
 * while keeping what the rejoin needs (bc_client_disconnect), the back-off
 * between attempts and the errors after which attempting again is
 * pointless. The CLI's `watch` and
 * blobcast-view both keep going across a daemon restart with these, so
 * that the policy is written once.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "client_impl.h"

bool bc_client_retry_useless(int code)
{
	switch (code) {
	/* The token is refused (or the TLS certificate is not trusted): the
	 * same credentials are refused again. */
	case BC_EAUTH:
	/* The token does not grant the role asked for. */
	case BC_EPERM:
	/* The daemon speaks another protocol version: it stays that one
	 * until someone upgrades it. */
	case BC_EPROTO_VERSION:
	/* The session is gone (deleted, or not kept by the restarted
	 * daemon); a viewer cannot create it, and an editor joining with
	 * BC_CLIENT_JOIN_ANY never meets this. */
	case BC_ENOSESSION:
	/* The options themselves are wrong (an address that does not
	 * parse, a session name too long). */
	case BC_EINVAL:
		return true;
	default:
		/* Everything else may pass: the daemon is down or restarting
		 * (BC_EIO, BC_ECLOSED, BC_ETIMEOUT), busy, out of memory, or
		 * a session or the daemon's session table is full (BC_ELIMIT)
		 * until someone leaves. */
		return false;
	}
}

void bc_client_backoff_init(struct bc_client_backoff *b, int first_ms,
                            int longest_ms)
{
	memset(b, 0, sizeof(*b));
	b->first_ms = first_ms > 0 ? first_ms : BC_CLIENT_BACKOFF_FIRST_MS;
	b->longest_ms =
	    longest_ms > 0 ? longest_ms : BC_CLIENT_BACKOFF_LONGEST_MS;
	if (b->longest_ms < b->first_ms) {
		b->longest_ms = b->first_ms;
	}
	b->delay_ms = b->first_ms;
}

void bc_client_backoff_reset(struct bc_client_backoff *b, double now_ms)
{
	b->attempts = 0;
	b->delay_ms = b->first_ms;
	b->next_at = now_ms + b->delay_ms;
}

int bc_client_backoff_next(struct bc_client_backoff *b, double now_ms)
{
	b->attempts++;
	/* Halving the ceiling instead of doubling the delay cannot
	 * overflow whatever the caller chose. */
	b->delay_ms =
	    b->delay_ms > b->longest_ms / 2 ? b->longest_ms : b->delay_ms * 2;
	b->next_at = now_ms + b->delay_ms;
	return b->delay_ms;
}

bool bc_client_backoff_due(const struct bc_client_backoff *b, double now_ms)
{
	return now_ms >= b->next_at;
}

/* A copy of s (NULL stays NULL) into *to; false when out of memory. */
static bool keep(const char **to, const char *s)
{
	return !s || (*to = bc_strdup(s)) != NULL;
}

int bc__client_remember(struct bc_client *c, const struct bc_client_opts *o)
{
	c->opts = *o;
	/* None of the caller's pointers stays: bc__client_forget() frees
	 * whatever is set, after a copy that failed half-way too. */
	c->opts.addr = c->opts.name = c->opts.token = c->opts.ca_file = NULL;
	if (!keep(&c->opts.addr, o->addr) || !keep(&c->opts.name, o->name) ||
	    !keep(&c->opts.token, o->token) ||
	    !keep(&c->opts.ca_file, o->ca_file)) {
		return BC_ENOMEM;
	}
	return 0;
}

void bc__client_forget(struct bc_client *c)
{
	/* The casts drop the const the public struct gives its fields; these
	 * strings are the client's own copies. */
	bc_free((void *)(uintptr_t)c->opts.addr);
	bc_free((void *)(uintptr_t)c->opts.name);
	bc_free((void *)(uintptr_t)c->opts.token);
	bc_free((void *)(uintptr_t)c->opts.ca_file);
	memset(&c->opts, 0, sizeof(c->opts));
}

void bc__client_joined(struct bc_client *c, const char *name,
                       enum bc_proto_role role, enum bc_client_join_mode mode)
{
	/* The caller checked the name's length. */
	snprintf(c->join_name, sizeof(c->join_name), "%s", name);
	c->join_role = role;
	c->join_mode = mode;
}

void bc_client_disconnect(struct bc_client *c)
{
	if (!c || c->fd < 0) {
		return;
	}
	/* Every call checks the sticky error before it touches the socket,
	 * so none reaches the closed one. */
	bc__client_fail(c, BC_ECLOSED, "connection closed by this client");
	bc__client_transport_free(c);
	bc__client_ws_free(c);
	close(c->fd);
	c->fd = -1;
}

int bc_client_rejoin(const struct bc_client *old, int timeout_ms,
                     struct bc_client **out, struct bc_errinfo *ei)
{
	struct bc_client_opts o = old->opts;
	enum bc_client_join_mode mode = old->join_mode;
	int rc;
	*out = NULL;
	if (timeout_ms) {
		o.timeout_ms = timeout_ms;
	}
	if ((rc = bc_client_connect(out, &o, ei)) || !old->join_name[0]) {
		return rc;
	}
	/* The session this client created may well exist now: create it
	 * only if it is gone. */
	if (mode == BC_CLIENT_JOIN_CREATE) {
		mode = BC_CLIENT_JOIN_ANY;
	}
	return bc_client_join(*out, old->join_name, old->join_role, mode, ei);
}
