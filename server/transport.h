/*
 * The transport layer, as main sees it: listeners (TCP with optional TLS,
 * a Unix socket), admission (who gets a connection slot), framing through
 * the protocol's push reader, and output queues with frame spoiling. It
 * hands whole messages to dispatch and implements the link (link.h) the
 * layers below send through.
 */
#ifndef BLOBCAST_SERVER_TRANSPORT_H
#define BLOBCAST_SERVER_TRANSPORT_H

#include <stdbool.h>
#include <uv.h>

#include "blobcast/error.h"
#include "config.h"
#include "link.h"

struct bc_net;
struct bc_dispatch;
struct bc_tls_ctx;

/* The transport on loop with configuration cfg (kept by the caller; its
 * tokens may be swapped while it runs). Returns 0 or BC_ENOMEM. */
int bc_net_new(struct bc_net **out, uv_loop_t *loop,
               const struct bc_srv_config *cfg);
/* The link the layers below send through (valid until bc_net_free). */
const struct bc_link *bc_net_link(struct bc_net *n);
/* Where whole messages go; set before bc_net_listen. */
void bc_net_set_dispatch(struct bc_net *n, struct bc_dispatch *d);
/* Opens the listeners of the configuration (TLS from its certificate).
 * Returns 0 or an error with the reason. */
int bc_net_listen(struct bc_net *n, struct bc_errinfo *ei);
/* Prints where it listens (stderr) and warns when a TCP listener reachable
 * from other hosts has no tokens. */
void bc_net_announce(struct bc_net *n);
/* Warns when a TCP listener reachable from other hosts has no tokens (only
 * loopback and Unix-socket clients then get in). */
void bc_net_warn_exposed(struct bc_net *n);
/* Whether tokens are configured and the TCP listener is plain and
 * reachable from other hosts. */
bool bc_net_tokens_in_clear(struct bc_net *n);
/* Replaces the TLS certificate and key for new connections (SIGHUP);
 * established ones keep theirs. Returns 0 or an error; none in use: 0. */
int bc_net_reload_tls(struct bc_net *n, struct bc_errinfo *ei);
/* Stops accepting, closes every connection and the listeners. */
void bc_net_close_all(struct bc_net *n);
/* Frees it once the loop has run its close callbacks. Accepts NULL. */
void bc_net_free(struct bc_net *n);

#endif
