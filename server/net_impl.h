/*
 * The libuv callbacks net.c (connections: reading, HELLO, output queues,
 * timeouts) lends listen.c (accepting connections) when it sets up a new
 * connection or the listeners.
 */
#ifndef BLOBCAST_SERVER_NET_IMPL_H
#define BLOBCAST_SERVER_NET_IMPL_H

#include "server.h"

/* Close callback of a connection's handles: frees it after the last. */
void bc__net_handle_closed(uv_handle_t *h);

/* Read callbacks of a connection's stream. */
void bc__net_on_alloc(uv_handle_t *h, size_t suggested, uv_buf_t *buf);
void bc__net_on_read(uv_stream_t *s, ssize_t n, const uv_buf_t *buf);

/* Writes what a TLS connection's state has to send (handshake records,
 * alerts); closes the connection when that fails. */
void bc__net_tls_flush(struct bc_conn *c);

/* Whether tokens are configured and the TCP listener is plain and
 * reachable from other hosts (listen.c). */
bool bc_net_tokens_in_clear(struct bc_srv *srv);

/* A connection said no HELLO in time: ERROR ETIMEOUT, then closed. */
void bc__net_hello_timeout(uv_timer_t *t);

/* Once a second: message and idle timeouts, clients that stopped reading. */
void bc__net_check_stalls(uv_timer_t *t);

#endif
