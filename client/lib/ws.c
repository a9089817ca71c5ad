/*
 * WebSocket (RFC 6455) under the protocol, client side: the path a browser
 * takes (through a proxy to websockify, which unwraps the binary messages
 * into a TCP stream to blobcastd), so that native clients can be routed by
 * the same proxy rule (docs/deploy.md). The opening handshake checks the
 * server's Sec-WebSocket-Accept; every frame we send is one masked binary
 * message; frames received are parsed with every length bounded: data
 * frames are streamed out (the protocol's reader frames messages itself),
 * pings are answered, a close frame ends the stream.
 */
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include <openssl/evp.h>
#include <openssl/rand.h>
#include <openssl/sha.h>

#include "blobcast/alloc.h"
#include "client_impl.h"
#include "ws_frames.h"

/* The handshake's answer must fit in this many bytes. */
#define WS_MAX_RESPONSE 8192u
/* Bytes taken from the stream at a time. */
#define WS_RAW 65536u

enum { OP_BIN = 2, OP_PONG = 10 };

struct bc__ws {
	uint8_t raw[WS_RAW];
	size_t rpos, rlen; /* unparsed bytes: raw[rpos, rlen) */
	struct bc_ws_rx rx;
};

static const char ws_guid[] = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11";

/* The Sec-WebSocket-Accept value for key (RFC 6455 4.2.2). */
static void accept_of(const char *key, char out[64])
{
	char both[128];
	uint8_t sha[SHA_DIGEST_LENGTH];
	int n = snprintf(both, sizeof(both), "%s%s", key, ws_guid);
	SHA1((const uint8_t *)both, (size_t)n, sha);
	EVP_EncodeBlock((uint8_t *)out, sha, SHA_DIGEST_LENGTH);
}

/* The value of header name in the response head (NUL-terminated, lines
 * ending in CRLF), copied into out; false when absent. */
static bool header(const char *head, const char *name, char *out, size_t cap)
{
	size_t nlen = strlen(name);
	const char *line = strstr(head, "\r\n");
	while (line && line[2] != '\0' && !(line[2] == '\r')) {
		const char *l = line + 2;
		const char *end = strstr(l, "\r\n");
		if (!end) {
			return false;
		}
		if ((size_t)(end - l) > nlen && l[nlen] == ':' &&
		    strncasecmp(l, name, nlen) == 0) {
			const char *v = l + nlen + 1;
			size_t n;
			while (*v == ' ' || *v == '\t') {
				v++;
			}
			n = (size_t)(end - v);
			while (n > 0 && (v[n - 1] == ' ' || v[n - 1] == '\t')) {
				n--;
			}
			if (n >= cap) {
				n = cap - 1;
			}
			memcpy(out, v, n);
			out[n] = '\0';
			return true;
		}
		line = end;
	}
	return false;
}

int bc__client_ws_start(struct bc_client *c, const struct bc_client_addr *a,
                        double deadline)
{
	uint8_t nonce[16];
	char key[32], want[64], got[128], req[BC_CLIENT_MAX_WS_PATH + 640];
	char head[WS_MAX_RESPONSE + 1];
	size_t have = 0;
	const char *end = NULL;
	bool bracket = strchr(a->host, ':') != NULL; /* an IPv6 address */
	bool default_port = a->port == (a->tls ? 443 : 80);
	int n, rc;
	if (!(c->ws = bc_calloc(1, sizeof(*c->ws)))) {
		return bc__client_fail(c, BC_ENOMEM, "out of memory");
	}
	if (RAND_bytes(nonce, sizeof(nonce)) != 1) {
		return bc__client_fail(c, BC_EIO,
		                       "no random bytes for the "
		                       "WebSocket key");
	}
	EVP_EncodeBlock((uint8_t *)key, nonce, sizeof(nonce));
	accept_of(key, want);
	n = snprintf(req, sizeof(req),
	             "GET %s HTTP/1.1\r\n"
	             "Host: %s%s%s%s%.0u\r\n"
	             "Upgrade: websocket\r\n"
	             "Connection: Upgrade\r\n"
	             "Sec-WebSocket-Key: %s\r\n"
	             "Sec-WebSocket-Version: 13\r\n"
	             "Sec-WebSocket-Protocol: binary\r\n"
	             "User-Agent: libblobcast\r\n"
	             "\r\n",
	             a->resource, bracket ? "[" : "", a->host,
	             bracket ? "]" : "", default_port ? "" : ":",
	             default_port ? 0u : (unsigned)a->port, key);
	if (n < 0 || (size_t)n >= sizeof(req)) {
		return bc__client_fail(c, BC_EINVAL,
		                       "WebSocket request too "
		                       "long");
	}
	if ((rc = bc__client_stream_write(c, req, (size_t)n, deadline,
	                                  "WebSocket handshake"))) {
		return rc;
	}
	/* The answer's head, up to its blank line; bytes after it are the
	 * first frames. */
	while (!end) {
		long k;
		if (have == WS_MAX_RESPONSE) {
			return bc__client_fail(c, BC_EPARSE,
			                       "WebSocket handshake: an answer "
			                       "over %u bytes",
			                       WS_MAX_RESPONSE);
		}
		k = bc__client_stream_read(c, head + have,
		                           WS_MAX_RESPONSE - have, deadline);
		if (k == 0) {
			return bc__client_fail(
			    c, BC_ETIMEOUT,
			    "WebSocket handshake with %s: no "
			    "answer within %d ms",
			    a->host, c->timeout_ms);
		}
		if (k == BC__CLIENT_EOF) {
			return bc__client_fail(
			    c, BC_ECLOSED,
			    "WebSocket handshake with %s: the "
			    "server closed the connection",
			    a->host);
		}
		if (k < 0) {
			return (int)k;
		}
		have += (size_t)k;
		head[have] = '\0';
		if (memchr(head, '\0', have)) {
			return bc__client_fail(c, BC_EPARSE,
			                       "WebSocket handshake: a NUL in "
			                       "the answer");
		}
		end = strstr(head, "\r\n\r\n");
	}
	{
		size_t used = (size_t)(end + 4 - head);
		const char *eol = strstr(head, "\r\n");
		int status = 0;
		if (sscanf(head, "HTTP/1.1 %d", &status) != 1 ||
		    status != 101) {
			return bc__client_fail(
			    c,
			    status == 401 || status == 403 ? BC_EAUTH : BC_EIO,
			    "WebSocket handshake with %s%s: the server "
			    "answered \"%.*s\"",
			    a->host, a->resource, (int)(eol ? eol - head : 0),
			    head);
		}
		head[used - 2] = '\0'; /* keep the last header's CRLF */
		if (!header(head, "Sec-WebSocket-Accept", got, sizeof(got)) ||
		    strcmp(got, want) != 0) {
			return bc__client_fail(c, BC_EPARSE,
			                       "WebSocket handshake: a wrong "
			                       "Sec-WebSocket-Accept");
		}
		memcpy(c->ws->raw, head + used, have - used);
		c->ws->rlen = have - used;
	}
	return 0;
}

/* A frame of op with payload (masked, as a client must). */
static int send_frame(struct bc_client *c, uint8_t op, const void *data,
                      size_t len, double deadline, const char *what)
{
	uint8_t hdr[14], mask[4];
	size_t h = 2;
	uint8_t *frame;
	int rc;
	hdr[0] = (uint8_t)(0x80u | op);
	if (len < 126) {
		hdr[1] = (uint8_t)(0x80u | len);
	} else if (len <= 0xffff) {
		hdr[1] = 0x80u | 126u;
		hdr[2] = (uint8_t)(len >> 8);
		hdr[3] = (uint8_t)len;
		h = 4;
	} else {
		hdr[1] = 0x80u | 127u;
		for (int i = 0; i < 8; i++) {
			hdr[2 + i] = (uint8_t)((uint64_t)len >> (56 - 8 * i));
		}
		h = 10;
	}
	if (RAND_bytes(mask, 4) != 1) {
		return bc__client_fail(c, BC_EIO,
		                       "no random bytes for a "
		                       "WebSocket mask");
	}
	memcpy(hdr + h, mask, 4);
	h += 4;
	if (!(frame = bc_malloc(h + len))) {
		return bc__client_fail(c, BC_ENOMEM, "out of memory");
	}
	memcpy(frame, hdr, h);
	for (size_t i = 0; i < len; i++) {
		frame[h + i] = ((const uint8_t *)data)[i] ^ mask[i & 3];
	}
	rc = bc__client_stream_write(c, frame, h + len, deadline, what);
	bc_free(frame);
	return rc;
}

int bc__client_io_write(struct bc_client *c, const void *data, size_t len,
                        double deadline, const char *what)
{
	if (!c->ws) {
		return bc__client_stream_write(c, data, len, deadline, what);
	}
	return send_frame(c, OP_BIN, data, len, deadline, what);
}

/* Parses what raw holds: payload bytes of data frames into buf (up to
 * cap), pings answered. Returns the bytes given, or BC__CLIENT_EOF after a
 * close frame, or the sticky error. */
static long parse(struct bc_client *c, uint8_t *buf, size_t cap,
                  double deadline)
{
	struct bc__ws *w = c->ws;
	size_t out = 0;
	while (w->rpos < w->rlen && out < cap && !w->rx.closed) {
		size_t used, produced;
		enum bc_ws_event ev;
		int rc =
		    bc_ws_rx_feed(&w->rx, w->raw + w->rpos, w->rlen - w->rpos,
		                  &used, buf + out, cap - out, &produced, &ev);
		w->rpos += used;
		out += produced;
		if (rc) {
			return bc__client_fail(c, BC_EPARSE, "WebSocket: %s",
			                       w->rx.err);
		}
		if (ev == BC_WS_PING &&
		    (rc = send_frame(c, OP_PONG, w->rx.ctl, w->rx.ctl_len,
		                     deadline, "WebSocket pong"))) {
			return rc;
		}
		if (used == 0 && produced == 0 && ev == BC_WS_NONE) {
			break;
		}
	}
	if (out == 0 && w->rx.closed) {
		return BC__CLIENT_EOF;
	}
	return (long)out;
}

long bc__client_io_read(struct bc_client *c, void *buf, size_t cap,
                        double deadline)
{
	struct bc__ws *w = c->ws;
	if (!w) {
		return bc__client_stream_read(c, buf, cap, deadline);
	}
	for (;;) {
		long n = parse(c, buf, cap, deadline);
		if (n != 0) {
			return n;
		}
		w->rpos = w->rlen = 0;
		n = bc__client_stream_read(c, w->raw, sizeof(w->raw), deadline);
		if (n <= 0) {
			return n;
		}
		w->rlen = (size_t)n;
	}
}

void bc__client_ws_free(struct bc_client *c)
{
	bc_free(c->ws);
	c->ws = NULL;
}
