/*
 * TLS on the daemon's TCP connections: OpenSSL driven through memory BIOs,
 * so that libuv keeps owning the sockets. The loop thread feeds the bytes
 * it reads (ciphertext) in, takes plaintext out, writes plaintext in and
 * takes the ciphertext to send out. One context (certificate and key) per
 * daemon; one state per connection.
 */
#ifndef BLOBCAST_SERVER_TLS_H
#define BLOBCAST_SERVER_TLS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/error.h"

struct bc_tls_ctx;
struct bc_tls;

/* Loads a PEM certificate chain and its private key (TLS 1.2 and newer).
 * A certificate that has expired or is not valid yet is refused (clients
 * would refuse it) unless allow_expired, which logs a warning instead;
 * one that expires within BC_SRV_TLS_WARN_DAYS is logged as a warning.
 * Returns 0 or BC_EIO/BC_EINVAL with the file and the reason. */
int bc_tls_ctx_new(struct bc_tls_ctx **out, const char *cert_file,
                   const char *key_file, bool allow_expired,
                   struct bc_errinfo *ei);
void bc_tls_ctx_free(struct bc_tls_ctx *ctx);
/* When ctx's certificate stops being valid, Unix milliseconds (0 when it
 * cannot be read). */
uint64_t bc_tls_ctx_not_after_ms(const struct bc_tls_ctx *ctx);

/* A server-side connection state; NULL when out of memory. It holds its
 * own reference to ctx, so ctx may be freed (replaced) before it. */
struct bc_tls *bc_tls_new(struct bc_tls_ctx *ctx);
void bc_tls_free(struct bc_tls *t);

/* Whether the handshake has completed (application data may flow). */
bool bc_tls_ready(const struct bc_tls *t);

/* Whether any bytes from the peer have been fed yet. */
bool bc_tls_started(const struct bc_tls *t);

/* Hands ciphertext read from the peer to the TLS state. Returns 0 or
 * BC_ENOMEM. */
int bc_tls_feed(struct bc_tls *t, const void *data, size_t len);

/*
 * Advances the handshake and decrypts: up to cap bytes of plaintext into
 * buf. Returns the number of bytes (> 0), 0 when more ciphertext is needed,
 * or a negative BC_E* code (BC_EIO: a failed handshake or a bad record;
 * BC_ECLOSED: the peer sent close_notify) with the reason in why.
 */
long bc_tls_read(struct bc_tls *t, void *buf, size_t cap, char *why,
                 size_t whylen);

/* Encrypts len bytes of plaintext (only once ready). Returns 0 or a
 * negative BC_E* code. */
int bc_tls_write(struct bc_tls *t, const void *data, size_t len);

/* Queues a close_notify alert (after the handshake; else nothing). */
void bc_tls_close_notify(struct bc_tls *t);

/* Ciphertext waiting to be sent: moves it into a new bc_malloc'd buffer
 * (*out, *len); *out is NULL and *len 0 when there is none. Returns 0 or
 * BC_ENOMEM. */
int bc_tls_take_output(struct bc_tls *t, uint8_t **out, size_t *len);

/* The negotiated protocol version and cipher, for the log. */
const char *bc_tls_describe(const struct bc_tls *t, char *buf, size_t len);

#endif
