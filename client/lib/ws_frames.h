/*
 * The receiving half of WebSocket framing (RFC 6455 section 5), client
 * side, as a pure function over bytes: no sockets, no allocation, so that
 * it can be fuzzed alone (tests/fuzz/fuzz_ws_frames.c). Every length is
 * bounded: data payloads are streamed out as they arrive (never buffered
 * whole), control payloads are at most 125 bytes.
 */
#ifndef BLOBCAST_CLIENT_WS_FRAMES_H
#define BLOBCAST_CLIENT_WS_FRAMES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

enum bc_ws_event {
	BC_WS_NONE = 0,
	BC_WS_PING,  /* a ping completed: answer with its payload (ctl) */
	BC_WS_PONG,  /* a pong completed: nothing to do */
	BC_WS_CLOSE, /* a close frame completed: the stream has ended */
};

struct bc_ws_rx {
	uint8_t hdr[10]; /* the frame header being read (servers never mask) */
	size_t hhave;
	bool in_payload;
	uint8_t op;
	uint64_t left;    /* payload bytes of this frame still to come */
	uint8_t ctl[125]; /* a control frame's payload */
	size_t ctl_len;
	bool closed;     /* a close frame was read: nothing more is parsed */
	const char *err; /* why the stream was refused, or NULL */
};

/*
 * Parses in[0..n): the payload bytes of data frames (binary, and their
 * continuations) go to out (at most cap). Stops after a control frame
 * completes (*event says which; r->ctl holds its payload), when out is
 * full, or at the end of in. *used and *produced count what was consumed
 * and written. Returns 0, or -1 when the bytes break the framing rules
 * (a text or unknown opcode, a masked frame, reserved bits, a control
 * frame over 125 bytes or fragmented, a length over 2^63); r->err says
 * why and every later call fails the same way.
 */
int bc_ws_rx_feed(struct bc_ws_rx *r, const uint8_t *in, size_t n, size_t *used,
                  uint8_t *out, size_t cap, size_t *produced,
                  enum bc_ws_event *event);

#endif
