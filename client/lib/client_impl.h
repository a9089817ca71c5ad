/*
 * Private parts of libblobcast shared by its files: the connection struct
 * and the roster (client.c), the scene mirror's edit replay (edit.c) and the
 * clock.
 */
#ifndef BLOBCAST_CLIENT_IMPL_H
#define BLOBCAST_CLIENT_IMPL_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/client.h"

struct ssl_st;
struct ssl_ctx_st;

struct bc_client {
	int fd;
	/* TLS (transport.c) over fd, or NULL: the socket as it is. */
	struct ssl_st *ssl;
	struct ssl_ctx_st *ssl_ctx;
	/* WebSocket framing over the stream (ws:// and wss://), or NULL. */
	struct bc__ws *ws;
	int err;           /* 0 or the sticky BC_E* code */
	char errstr[256];  /* its reason */
	int timeout_ms;    /* < 0: none */
	uint8_t encodings; /* what our HELLO announced */
	uint32_t next_seq;
	struct bc_proto_reader reader;
	/* A SCENE_STATE arriving in parts (PROTOCOL.md 7.10.1). */
	struct bc_proto_parts parts;
	struct bc_proto_buf out;
	uint8_t *chunk; /* BC_CLIENT_READ_CHUNK bytes */
	struct bc_client_info info;
	/* The scene mirror, valid when has_scene. */
	struct bc_tree *scene;
	struct bc_camera camera;
	bool has_scene;
	uint64_t scene_order;
	/* The roster (bc_client_members), from the last SESSION_INFO. */
	struct bc_client_member members[BC_PROTO_MAX_MEMBERS];
	size_t nmembers;
	/* The seq of the SESSION_LEAVE awaiting its OK (0: none). */
	uint32_t leave_seq;
	/* What bc_client_rejoin() repeats (rejoin.c): the options connected
	 * with, their strings the client's own copies, and the session
	 * bc_client_join() entered last (join_name "" before any). */
	struct bc_client_opts opts;
	char join_name[BC_PROTO_MAX_NAME + 1];
	enum bc_proto_role join_role;
	enum bc_client_join_mode join_mode;
	/* The id after the last one model.c handed out (0: none), so that
	 * actions sent before the mirror shows the last one take others. */
	uint32_t model_next_id;
};

/* Milliseconds left until deadline (a bc_clock_ms() value), rounded
 * up, for poll(); -1 when there is no deadline (deadline < 0). */
int bc__client_ms_left(double deadline);

/* Records a sticky error on c (the first one wins) and returns it. */
int bc__client_fail(struct bc_client *c, int code, const char *fmt,
                    ...) BC__ERRINFO_PRINTF;

/* ---- rejoin.c: what a reconnect repeats --------------------------------- */

/* Copies o, its strings included, into c->opts. Returns 0 or BC_ENOMEM
 * (what was copied is freed by bc__client_forget()). */
int bc__client_remember(struct bc_client *c, const struct bc_client_opts *o);
/* Frees the copies; accepts a client that remembered nothing. */
void bc__client_forget(struct bc_client *c);
/* Records the session that bc_client_join() entered (name checked). */
void bc__client_joined(struct bc_client *c, const char *name,
                       enum bc_proto_role role, enum bc_client_join_mode mode);

/* ---- transport.c: the byte stream ---------------------------------------- */

/* What bc__client_stream_read() returns at the end of the stream. */
#define BC__CLIENT_EOF (-1000)

/* TLS over c->fd: the handshake, the certificate verified against ca_file
 * (NULL: the system's store) and host unless insecure. Returns 0 or the
 * sticky error it recorded. */
int bc__client_tls_start(struct bc_client *c, const char *host,
                         const char *ca_file, bool insecure, double deadline);
/* Frees the TLS state (after a close_notify, best effort). */
void bc__client_transport_free(struct bc_client *c);
/* Up to cap bytes from the stream: > 0 bytes, 0 at the deadline,
 * BC__CLIENT_EOF, or the sticky error it recorded. */
long bc__client_stream_read(struct bc_client *c, void *buf, size_t cap,
                            double deadline);
/* All len bytes to the stream by deadline (what: the message, for the
 * error). Returns 0 or the sticky error it recorded. */
int bc__client_stream_write(struct bc_client *c, const void *data, size_t len,
                            double deadline, const char *what);

/* The WebSocket opening handshake on the stream (GET a->resource with
 * Upgrade: websocket, subprotocol "binary"); 0 or the sticky error. */
int bc__client_ws_start(struct bc_client *c, const struct bc_client_addr *a,
                        double deadline);
/* The protocol's bytes: as bc__client_stream_read() and _write(), inside
 * WebSocket binary messages when c->ws (answering pings, a close frame
 * read as the end of the stream). */
long bc__client_io_read(struct bc_client *c, void *buf, size_t cap,
                        double deadline);
int bc__client_io_write(struct bc_client *c, const void *data, size_t len,
                        double deadline, const char *what);
/* Frees the WebSocket state. */
void bc__client_ws_free(struct bc_client *c);

/* Replays the operations of an EDIT_APPLIED on a scene mirror, atomically
 * (bc_edit_replay). Returns 0 or the failing operation's error with the
 * reason in ei; *t is then unchanged (the caller drops it). */
int bc__client_replay(struct bc_tree **t, const struct bc_msg_edit_applied *ea,
                      struct bc_errinfo *ei);

#endif
