/*
 * Connections (loop thread): the per-connection protocol reader and state
 * machine up to the session layer, timeouts, and output queues (listen.c
 * accepts them). Messages are written as they come; FRAMEs are written one
 * at a time per client and a newer frame replaces one not yet started
 * (frame spoiling), so a slow client gets fewer frames, never a growing
 * backlog.
 * A client whose queue still passes BC_SRV_MAX_CLIENT_QUEUE is dropped.
 * Clients are freed from their close callback, never inside a callback that
 * still uses them.
 */
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/log.h"
#include "net_impl.h"
#include "tls.h"

/* Reads land in a buffer of this size before being fed to the reader. */
#define READ_CHUNK (64u * 1024u)

/* A FRAME's header and frame_no, the part written per client. */
#define FRAME_PREFIX (BC_PROTO_HEADER_SIZE + 4u)

struct write_req {
	uv_write_t req;
	struct bc_conn_ref who;
	struct bc_srv *srv;
	struct bc_shared *shared; /* a frame, or NULL */
	uint8_t *owned;           /* a message's bytes, or NULL */
	uint8_t *cipher;          /* what goes out on a TLS connection */
	size_t len;
};

struct bc_shared *bc_shared_new(size_t len)
{
	struct bc_shared *s = bc_malloc(sizeof(*s) + len);
	if (s) {
		s->refs = 1;
		s->len = len;
	}
	return s;
}

void bc_shared_unref(struct bc_shared *s)
{
	if (s && --s->refs == 0) {
		bc_free(s);
	}
}

/* The loop's cached time, not base's bc_clock: libuv arms every timer
 * (the still timer, the stall check, the sweeps) against uv_now, which it
 * caches as the loop turns, from CLOCK_MONOTONIC_COARSE where that is fine
 * enough. Deadlines compared in a timer's callback must come from the
 * same reading, or a timer can fire while a second clock still says
 * "not yet". */
uint64_t bc_now_ms(struct bc_srv *srv)
{
	return uv_now(srv->loop);
}

struct bc_conn *bc_conn_get(struct bc_srv *srv, struct bc_conn_ref ref)
{
	struct bc_conn *c;
	if (ref.slot >= BC_SRV_MAX_CONNECTIONS) {
		return NULL;
	}
	c = srv->clients[ref.slot];
	return (c && c->gen == ref.gen && !c->closing) ? c : NULL;
}

struct bc_conn_ref bc_conn_ref_of(const struct bc_conn *c)
{
	return (struct bc_conn_ref){c->slot, c->gen};
}

void bc__net_handle_closed(uv_handle_t *h)
{
	struct bc_conn *c = h->data;
	if (--c->handles_open > 0) {
		return;
	}
	bool trim = c->queued >= BC_SRV_TRIM_AFTER_BYTES;
	bc_proto_reader_finish(&c->reader);
	bc_shared_unref(c->frame_next);
	bc_tls_free(c->tls);
	bc_free(c);
	/* The pending writes were cancelled (their buffers freed) before this
	 * last close callback; glibc keeps freed memory in its arenas unless
	 * asked to give it back. */
#if defined(__GLIBC__)
	if (trim) {
		malloc_trim(0);
	}
#else
	(void)trim;
#endif
}

void bc_conn_close(struct bc_conn *c, const char *why)
{
	struct bc_srv *srv = c->srv;
	if (c->closing) {
		return;
	}
	bc_log(BC_LOG_INFO, "connection %u (%s) closed: %s", c->gen, c->name,
	       why);
	if (c->session) {
		bc_session_leave(c);
	}
	c->closing = true;
	srv->clients[c->slot] = NULL;
	srv->nclients--;
	c->handles_open = 2;
	uv_close(&c->h.handle, bc__net_handle_closed);
	uv_close((uv_handle_t *)&c->hello_timer, bc__net_handle_closed);
}

static void shutdown_done(uv_shutdown_t *req, int status)
{
	struct bc_conn *c = req->data;
	(void)status;
	bc_conn_close(c, c->drain_why);
}

void bc_conn_close_after_flush(struct bc_conn *c, const char *why)
{
	if (c->closing || c->draining) {
		return;
	}
	if (c->session) {
		bc_session_leave(c);
	}
	c->draining = true;
	c->drain_why = why;
	uv_read_stop(&c->h.stream);
	if (c->tls) {
		/* close_notify goes out after the queued records. */
		bc_tls_close_notify(c->tls);
		bc__net_tls_flush(c);
		if (c->closing) {
			return;
		}
	}
	c->shutdown.data = c;
	if (uv_shutdown(&c->shutdown, &c->h.stream, shutdown_done) != 0) {
		bc_conn_close(c, why);
	}
}

static void write_done(uv_write_t *req, int status)
{
	struct write_req *w = (struct write_req *)req;
	struct bc_conn *c = bc_conn_get(w->srv, w->who);
	if (c) {
		c->queued -= w->len;
		if (status < 0) {
			bc_conn_close(c, uv_strerror(status));
		} else if (w->shared) {
			c->frame_writing = false;
			c->frames_sent++;
			c->bytes_sent += w->len;
			if (c->frame_next) {
				struct bc_shared *next = c->frame_next;
				c->frame_next = NULL;
				bc_conn_send_frame(c, next);
				bc_shared_unref(next);
			} else {
				bc_session_client_ready(c);
			}
		} else {
			c->bytes_sent += w->len;
		}
	}
	bc_shared_unref(w->shared);
	bc_free(w->owned);
	bc_free(w->cipher);
	bc_free(w);
}

/* Writes the ciphertext c's TLS state holds (handshake records, alerts,
 * close_notify). Those bytes count for no message. */
void bc__net_tls_flush(struct bc_conn *c)
{
	struct write_req *w;
	uint8_t *bytes;
	size_t n;
	uv_buf_t buf;
	if (bc_tls_take_output(c->tls, &bytes, &n)) {
		bc_conn_close(c, "out of memory");
		return;
	}
	if (n == 0) {
		return;
	}
	if (!(w = bc_calloc(1, sizeof(*w)))) {
		bc_free(bytes);
		bc_conn_close(c, "out of memory");
		return;
	}
	w->srv = c->srv;
	w->who = bc_conn_ref_of(c);
	w->cipher = bytes;
	buf = uv_buf_init((char *)bytes, (unsigned int)n);
	if (uv_write(&w->req, &c->h.stream, &buf, 1, write_done) < 0) {
		bc_free(bytes);
		bc_free(w);
		bc_conn_close(c, "write failed");
	}
}

/* On a TLS connection the plaintext buffers are encrypted into one
 * ciphertext buffer that is written instead (w keeps the plaintext
 * references for write_done's bookkeeping). Returns 0 or a BC_E* code. */
static int tls_seal(struct bc_conn *c, struct write_req *w, uv_buf_t *buf,
                    unsigned int *nbufs)
{
	size_t n;
	int rc;
	for (unsigned int i = 0; i < *nbufs; i++) {
		if ((rc = bc_tls_write(c->tls, buf[i].base, buf[i].len))) {
			return rc;
		}
	}
	if ((rc = bc_tls_take_output(c->tls, &w->cipher, &n))) {
		return rc;
	}
	buf[0] = uv_buf_init((char *)w->cipher, (unsigned int)n);
	*nbufs = 1;
	return 0;
}

/* Queues bytes (taking owned or a reference to shared). */
static void queue_bytes(struct bc_conn *c, uint8_t *owned,
                        struct bc_shared *shared, const uint8_t *data,
                        size_t len)
{
	struct write_req *w;
	uv_buf_t buf[2];
	unsigned int nbufs;
	int rc;
	if (c->tls && !bc_tls_ready(c->tls)) {
		/* Nothing can be said before the handshake (an ERROR for a
		 * HELLO timeout): the connection is closed without it. */
		bc_free(owned);
		return;
	}
	if (c->queued + len > BC_SRV_MAX_CLIENT_QUEUE) {
		bc_free(owned);
		bc_log(BC_LOG_WARN,
		       "dropping client %u (%s): %zu bytes queued, it stopped "
		       "reading",
		       c->gen, c->name, c->queued);
		bc_conn_close(c, "output queue over its limit");
		return;
	}
	w = bc_calloc(1, sizeof(*w));
	if (!w) {
		bc_free(owned);
		bc_conn_close(c, "out of memory");
		return;
	}
	w->srv = c->srv;
	w->who = bc_conn_ref_of(c);
	w->owned = owned;
	w->len = len;
	nbufs = 1;
	buf[0] = uv_buf_init((char *)data, (unsigned int)len);
	if (shared) {
		/* A FRAME shared by a view group: frame_no counts this
		 * client's frames (PROTOCOL.md 7.15), so the header and
		 * frame_no go out from a private copy, the rest shared. */
		if (!(w->owned = bc_malloc(FRAME_PREFIX))) {
			bc_free(w);
			bc_log(BC_LOG_ERROR,
			       "client %u: out of memory for a "
			       "frame",
			       c->gen);
			bc_conn_close(c, "out of memory");
			return;
		}
		memcpy(w->owned, data, FRAME_PREFIX);
		bc_put_le32(w->owned + BC_PROTO_HEADER_SIZE, ++c->frame_no);
		buf[0] = uv_buf_init((char *)w->owned, FRAME_PREFIX);
		buf[1] = uv_buf_init((char *)data + FRAME_PREFIX,
		                     (unsigned int)(len - FRAME_PREFIX));
		nbufs = 2;
		shared->refs++;
		w->shared = shared;
	}
	if (c->tls && tls_seal(c, w, buf, &nbufs)) {
		bc_shared_unref(w->shared);
		bc_free(w->owned);
		bc_free(w->cipher);
		bc_free(w);
		bc_conn_close(c, "TLS encryption failed");
		return;
	}
	c->queued += len;
	rc = uv_write(&w->req, &c->h.stream, buf, nbufs, write_done);
	if (rc < 0) {
		c->queued -= len;
		bc_shared_unref(w->shared);
		bc_free(w->owned);
		bc_free(w->cipher);
		bc_free(w);
		bc_conn_close(c, uv_strerror(rc));
	}
}

void bc_conn_send(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_proto_buf b;
	struct bc_errinfo ei = {0};
	int rc;
	if (c->closing || c->draining) {
		return;
	}
	bc_proto_buf_init(&b, 0);
	rc = bc_proto_encode(&b, m, &ei);
	if (rc) {
		bc_log(BC_LOG_ERROR, "cannot encode %s for client %u: %s",
		       bc_proto_type_name(m->type), c->gen, ei.msg);
		bc_proto_buf_finish(&b);
		return;
	}
	queue_bytes(c, b.data, NULL, b.data, b.len);
}

void bc_conn_send_error(struct bc_conn *c, uint32_t seq, int code, bool fatal,
                        const char *fmt, ...)
{
	char text[BC_PROTO_MAX_ERROR_TEXT];
	struct bc_msg m = {.type = BC_MSG_ERROR, .seq = seq};
	va_list args;
	int n;
	va_start(args, fmt);
	n = vsnprintf(text, sizeof(text), fmt, args);
	va_end(args);
	if (n < 0) {
		n = 0;
	}
	m.flags = fatal ? BC_PROTO_FLAG_FATAL : 0;
	m.error.code = (uint16_t)(code < 0 ? -code : code);
	m.error.text.ptr = text;
	m.error.text.len =
	    (uint32_t)((size_t)n < sizeof(text) ? (size_t)n : sizeof(text) - 1);
	bc_log(BC_LOG_INFO, "client %u: error %s: %s", c->gen,
	       bc_err_name(code), text);
	bc_conn_send(c, &m);
}

void bc_conn_send_frame(struct bc_conn *c, struct bc_shared *frame)
{
	if (c->closing || c->draining) {
		return;
	}
	if (c->frame_writing &&
	    bc_now_ms(c->srv) - c->frame_started_ms > BC_SRV_STALL_MS) {
		bc_log(BC_LOG_WARN,
		       "dropping client %u (%s): a frame has waited %u ms, it "
		       "stopped reading",
		       c->gen, c->name, BC_SRV_STALL_MS);
		bc_conn_close(c, "stopped reading");
		return;
	}
	if (c->frame_writing) {
		/* Spoil the unsent frame: the newer one supersedes it. */
		if (c->frame_next) {
			c->frames_spoiled++;
			bc_shared_unref(c->frame_next);
		}
		frame->refs++;
		c->frame_next = frame;
		return;
	}
	c->frame_writing = true;
	c->frame_started_ms = bc_now_ms(c->srv);
	if (!c->first_frame_ms) {
		c->first_frame_ms = bc_now_ms(c->srv);
	}
	queue_bytes(c, NULL, frame, frame->data, frame->len);
}

/* ---- HELLO -------------------------------------------------------------- */

static enum bc_proto_role token_role(struct bc_srv *srv, struct bc_conn *c,
                                     struct bc_proto_str tok)
{
	for (uint32_t i = 0; i < srv->cfg.ntokens; i++) {
		const char *t = srv->cfg.tokens[i].token;
		if (strlen(t) == tok.len && memcmp(t, tok.ptr, tok.len) == 0) {
			return srv->cfg.tokens[i].role;
		}
	}
	/* No token: only trusted peers, and only when no token is configured
	 * or they come over the Unix socket (filesystem permissions). */
	if (tok.len == 0 && c->trusted &&
	    (srv->cfg.ntokens == 0 || !c->is_tcp)) {
		return BC_PROTO_ROLE_EDITOR;
	}
	return BC_PROTO_ROLE_INVALID;
}

static void handle_hello(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	const struct bc_msg_hello *h = &m->hello;
	struct bc_msg w = {.type = BC_MSG_WELCOME, .seq = m->seq};
	if (h->version_min > BC_PROTO_VERSION ||
	    h->version_max < BC_PROTO_VERSION) {
		bc_conn_send_error(c, m->seq, BC_EPROTO_VERSION, true,
		                   "this server speaks version %u only",
		                   BC_PROTO_VERSION);
		bc_conn_close_after_flush(c, "version mismatch");
		return;
	}
	c->max_role = token_role(srv, c, h->token);
	if (c->max_role == BC_PROTO_ROLE_INVALID) {
		bc_conn_send_error(c, m->seq, BC_EAUTH, true,
		                   "a valid token is required");
		bc_conn_close_after_flush(c, "authentication failed");
		return;
	}
	memcpy(c->name, h->client_name.ptr, h->client_name.len);
	c->name[h->client_name.len] = '\0';
	/* 0: the client wants no frames; its VIEWs are refused (EINVAL). */
	c->encodings = h->encodings;
	c->max_frame_bytes =
	    h->max_frame_bytes ? h->max_frame_bytes : BC_PROTO_MAX_PAYLOAD;
	c->stage = BC_PROTO_STAGE_READY;
	uv_timer_stop(&c->hello_timer);
	bc_proto_reader_hello_done(&c->reader);
	w.welcome.version = BC_PROTO_VERSION;
	w.welcome.connection_id = c->gen;
	w.welcome.max_payload = BC_PROTO_MAX_PAYLOAD;
	w.welcome.max_frame_bytes = c->max_frame_bytes;
	w.welcome.max_nodes = BC_SRV_MAX_NODES;
	w.welcome.max_dim = BC_SRV_MAX_DIM;
	w.welcome.max_members = BC_PROTO_MAX_MEMBERS;
	w.welcome.max_edit_ops = BC_PROTO_MAX_EDIT_OPS;
	w.welcome.server_id.ptr = srv->cfg.server_id;
	w.welcome.server_id.len = (uint32_t)strlen(srv->cfg.server_id);
	bc_conn_send(c, &w);
}

static void dispatch(struct bc_conn *c, const struct bc_msg *m)
{
	int rc = bc_proto_client_may_send(c->stage, c->role, m->type);
	if (m->type == BC_MSG_PING) {
		struct bc_msg pong = {.type = BC_MSG_PONG, .seq = m->seq};
		pong.ping.stamp = m->ping.stamp;
		bc_conn_send(c, &pong);
		return;
	}
	if (m->type == BC_MSG_PONG || m->type == BC_MSG_ERROR) {
		return;
	}
	/* A client that sends a type of the presentation messages knows
	 * those the server sends (PROTOCOL.md 4), refused or not. */
	if (m->type >= BC_MSG_PRESENT) {
		c->knows_present = true;
	}
	if (rc) {
		bc_conn_send_error(c, m->seq, rc, false, "%s is not allowed %s",
		                   bc_proto_type_name(m->type),
		                   rc == BC_EPERM ? "for a viewer"
		                                  : "at this point");
		return;
	}
	if (m->type == BC_MSG_HELLO) {
		handle_hello(c, m);
		return;
	}
	bc_session_handle(c, m);
}

void bc__net_on_alloc(uv_handle_t *h, size_t suggested, uv_buf_t *buf)
{
	static char chunk[READ_CHUNK];
	(void)h;
	(void)suggested;
	/* One loop thread: a static chunk is fed to the reader (which copies)
	 * before the next read can happen. */
	*buf = uv_buf_init(chunk, sizeof(chunk));
}

/* Plaintext bytes from the peer: fed to the protocol reader, and every
 * whole message dispatched. */
static void on_bytes(struct bc_conn *c, const char *bytes, size_t n)
{
	struct bc_msg m;
	int rc;
	c->last_read_ms = bc_now_ms(c->srv);
	rc = bc_proto_reader_feed(&c->reader, bytes, n);
	while (rc == 0 && !c->closing && !c->draining) {
		rc = bc_proto_reader_next(&c->reader, &m);
		if (rc == 1) {
			c->msg_started_ms = 0;
			dispatch(c, &m);
			rc = 0;
		} else {
			break;
		}
	}
	/* Bytes left over start a message that must complete within the
	 * message timeout (check_timeouts), counted from its first byte. */
	if (bc_proto_reader_pending(&c->reader) == 0) {
		c->msg_started_ms = 0;
	} else if (c->msg_started_ms == 0) {
		c->msg_started_ms = c->last_read_ms;
	}
	if (rc < 0 && !c->closing && !c->draining) {
		/* The stream cannot be resynchronized: say why, then close. */
		bc_conn_send_error(c, 0, rc, true, "%s", c->reader.errstr);
		bc_conn_close_after_flush(c, "protocol error");
	}
}

/* Ciphertext from the peer of a TLS connection: the handshake advanced,
 * records decrypted and their bytes handled, whatever TLS has to say
 * written. A peer that speaks the plain protocol to this port hears why
 * it is refused, in the plain protocol. */
static void on_tls_bytes(struct bc_conn *c, const char *bytes, size_t n)
{
	static char plain[READ_CHUNK];
	char why[256];
	long got = 0;
	if (!bc_tls_started(c->tls) &&
	    (uint8_t)bytes[0] != 0x16 /* TLS handshake record */) {
		bc_tls_free(c->tls);
		c->tls = NULL;
		bc_log(BC_LOG_INFO,
		       "connection %u: plain protocol on the TLS port, refused",
		       c->gen);
		bc_conn_send_error(c, 0, BC_ENOTSUP, true,
		                   "this port speaks TLS: connect with "
		                   "tls://HOST:PORT");
		bc_conn_close_after_flush(c, "not TLS");
		return;
	}
	if (bc_tls_feed(c->tls, bytes, n)) {
		bc_conn_close(c, "out of memory");
		return;
	}
	while (!c->closing && !c->draining) {
		bool was_ready = bc_tls_ready(c->tls);
		got =
		    bc_tls_read(c->tls, plain, sizeof(plain), why, sizeof(why));
		if (!was_ready && bc_tls_ready(c->tls)) {
			char desc[128];
			bc_log(BC_LOG_INFO, "connection %u: TLS (%s)", c->gen,
			       bc_tls_describe(c->tls, desc, sizeof(desc)));
		}
		if (got <= 0) {
			break;
		}
		on_bytes(c, plain, (size_t)got);
	}
	if (c->closing) {
		return;
	}
	bc__net_tls_flush(c);
	if (got < 0 && !c->closing && !c->draining) {
		if (got == BC_ECLOSED) {
			bc_conn_close(c, "peer closed");
		} else {
			bc_log(BC_LOG_INFO, "connection %u: TLS: %s", c->gen,
			       why);
			bc_conn_close(c, bc_tls_ready(c->tls)
			                     ? "TLS error"
			                     : "TLS handshake failed");
		}
	}
}

void bc__net_on_read(uv_stream_t *s, ssize_t n, const uv_buf_t *buf)
{
	struct bc_conn *c = s->data;
	if (c->closing || c->draining) {
		return;
	}
	if (n < 0) {
		int eof = bc_proto_reader_eof(&c->reader);
		if (eof < 0 && n == UV_EOF) {
			/* The stream ended inside a message (PROTOCOL.md 3.1):
			 * a peer that only shut down its sending side still
			 * hears why. */
			bc_conn_send_error(c, 0, eof, true, "%s",
			                   c->reader.errstr);
			bc_conn_close_after_flush(c, "stream ended inside a "
			                             "message");
			return;
		}
		if (eof < 0) {
			bc_log(BC_LOG_INFO, "client %u: %s", c->gen,
			       c->reader.errstr);
		}
		bc_conn_close(c, n == UV_EOF ? "peer closed"
		                             : uv_strerror((int)n));
		return;
	}
	if (n == 0) {
		return;
	}
	if (c->tls) {
		on_tls_bytes(c, buf->base, (size_t)n);
	} else {
		on_bytes(c, buf->base, (size_t)n);
	}
}

void bc__net_hello_timeout(uv_timer_t *t)
{
	struct bc_conn *c = t->data;
	bc_conn_send_error(c, 0, BC_ETIMEOUT, true, "no HELLO within %u ms",
	                   BC_SRV_HELLO_TIMEOUT_MS);
	bc_conn_close_after_flush(c, "HELLO timeout");
}

/* After HELLO: a message must complete within the message timeout of its
 * first byte, and a client in no session may not stay silent past the idle
 * timeout. (Before HELLO the HELLO timeout covers both.) */
static void check_timeouts(struct bc_srv *srv, struct bc_conn *c, uint64_t now)
{
	uint64_t msg_ms = srv->cfg.message_timeout_ms
	                      ? srv->cfg.message_timeout_ms
	                      : BC_SRV_MESSAGE_TIMEOUT_MS;
	uint64_t idle_ms = srv->cfg.idle_timeout_ms ? srv->cfg.idle_timeout_ms
	                                            : BC_SRV_IDLE_TIMEOUT_MS;
	if (c->closing || c->draining || c->stage == BC_PROTO_STAGE_HELLO) {
		return;
	}
	if (c->msg_started_ms && now - c->msg_started_ms > msg_ms) {
		bc_conn_send_error(c, 0, BC_ETIMEOUT, true,
		                   "a message did not complete within %" PRIu64
		                   " ms of its first byte",
		                   msg_ms);
		bc_conn_close_after_flush(c, "message timeout");
	} else if (!c->session && now - c->last_read_ms > idle_ms) {
		bc_conn_send_error(c, 0, BC_ETIMEOUT, true,
		                   "idle for %" PRIu64 " ms in no session",
		                   idle_ms);
		bc_conn_close_after_flush(c, "idle timeout");
	}
}

void bc__net_check_stalls(uv_timer_t *t)
{
	struct bc_srv *srv = t->data;
	uint64_t now = bc_now_ms(srv);
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		struct bc_conn *c = srv->clients[i];
		if (c) {
			check_timeouts(srv, c, now);
		}
		if (c && !c->closing && c->frame_writing &&
		    now - c->frame_started_ms > BC_SRV_STALL_MS) {
			bc_log(BC_LOG_WARN,
			       "dropping client %u (%s): a frame has waited "
			       "%llu ms, it stopped reading",
			       c->gen, c->name,
			       (unsigned long long)(now - c->frame_started_ms));
			bc_conn_close(c, "stopped reading");
		}
	}
}

void bc_net_close_all(struct bc_srv *srv)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		if (srv->clients[i]) {
			bc_conn_close(srv->clients[i], "server stopping");
		}
	}
	if (uv_is_active((uv_handle_t *)&srv->stall_timer) ||
	    srv->stall_timer.data == srv) {
		uv_close((uv_handle_t *)&srv->stall_timer, NULL);
		srv->stall_timer.data = NULL;
	}
	if (srv->has_tcp) {
		uv_close((uv_handle_t *)&srv->tcp_listener, NULL);
	}
	if (srv->has_unix) {
		uv_close((uv_handle_t *)&srv->unix_listener, NULL);
		unlink(srv->cfg.unix_path);
	}
}
