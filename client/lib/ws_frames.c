/* The receiving half of WebSocket framing (ws_frames.h). */
#include <string.h>

#include "ws_frames.h"

enum {
	OP_CONT = 0,
	OP_TEXT = 1,
	OP_BIN = 2,
	OP_CLOSE = 8,
	OP_PING = 9,
	OP_PONG = 10
};

/* Header bytes once hdr[1] is known: 2, plus 2 or 8 of extended length. */
static size_t header_size(const uint8_t *hdr)
{
	uint8_t l = hdr[1] & 0x7fu;
	return l == 126 ? 4 : l == 127 ? 10 : 2;
}

static int refuse(struct bc_ws_rx *r, const char *why)
{
	r->err = why;
	return -1;
}

/* A whole header in r->hdr: checks it and starts the payload. */
static int start_frame(struct bc_ws_rx *r)
{
	uint8_t b0 = r->hdr[0], b1 = r->hdr[1];
	r->op = b0 & 0x0fu;
	if (b0 & 0x70u) {
		return refuse(r, "reserved bits set");
	}
	if (b1 & 0x80u) {
		return refuse(r, "a masked frame from the server");
	}
	if ((b1 & 0x7fu) < 126) {
		r->left = b1 & 0x7fu;
	} else if ((b1 & 0x7fu) == 126) {
		r->left = (uint64_t)r->hdr[2] << 8 | r->hdr[3];
	} else {
		r->left = 0;
		for (int i = 0; i < 8; i++) {
			r->left = r->left << 8 | r->hdr[2 + i];
		}
		if (r->left >> 63) {
			return refuse(r, "a length over 2^63");
		}
	}
	if (r->op == OP_TEXT) {
		return refuse(r, "a text frame (the binary subprotocol was "
		                 "asked for)");
	}
	if ((r->op > OP_BIN && r->op < OP_CLOSE) || r->op > OP_PONG) {
		return refuse(r, "an unknown opcode");
	}
	if (r->op >= OP_CLOSE && (r->left > sizeof(r->ctl) || !(b0 & 0x80u))) {
		return refuse(r, "a control frame over 125 bytes or "
		                 "fragmented");
	}
	r->hhave = 0;
	r->ctl_len = 0;
	r->in_payload = true;
	return 0;
}

int bc_ws_rx_feed(struct bc_ws_rx *r, const uint8_t *in, size_t n, size_t *used,
                  uint8_t *out, size_t cap, size_t *produced,
                  enum bc_ws_event *event)
{
	size_t i = 0, o = 0;
	*event = BC_WS_NONE;
	*used = 0;
	*produced = 0;
	if (r->err) {
		return -1;
	}
	while (i < n && !r->closed) {
		if (!r->in_payload) {
			r->hdr[r->hhave++] = in[i++];
			if (r->hhave < 2 || r->hhave < header_size(r->hdr)) {
				continue;
			}
			if (start_frame(r)) {
				*used = i;
				*produced = o;
				return -1;
			}
		}
		{
			size_t avail = n - i;
			size_t take = avail < r->left ? avail : (size_t)r->left;
			if (r->op < OP_CLOSE) {
				if (take > cap - o) {
					take = cap - o;
				}
				memcpy(out + o, in + i, take);
				o += take;
			} else {
				memcpy(r->ctl + r->ctl_len, in + i, take);
				r->ctl_len += take;
			}
			i += take;
			r->left -= take;
			if (r->left > 0) {
				if (o == cap && r->op < OP_CLOSE) {
					break; /* out is full */
				}
				continue;
			}
			r->in_payload = false;
			if (r->op >= OP_CLOSE) {
				*event = r->op == OP_PING   ? BC_WS_PING
				         : r->op == OP_PONG ? BC_WS_PONG
				                            : BC_WS_CLOSE;
				r->closed = r->op == OP_CLOSE;
				break;
			}
		}
	}
	*used = i;
	*produced = o;
	return 0;
}
