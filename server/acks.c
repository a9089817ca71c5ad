/*
 * FRAME_ACK (transport, loop thread; PROTOCOL.md 7.27): a client granted
 * ACKS acknowledges the FRAMEs it has shown, and its view's frames wait
 * while BC_PROTO_ACK_WINDOW of them are unacknowledged (net.c, pace). A
 * proxy in front of the client (websockify for the page) takes the
 * server's bytes as fast as loopback allows, so the socket's backlog
 * cannot say that frames queue further on; the client's acknowledgements
 * can, and their round trips say how far and how slow the path is.
 */
#include <string.h>

#include "net_impl.h"

void bc__acks_written(struct bc_acks *a, uint32_t no, size_t len,
                      uint64_t now_ms)
{
	if (a->n == BC_PROTO_ACK_WINDOW) {
		/* Only a frame written past a full window (a SNAPSHOT's
		 * answer is not counted; this is defensive): forget the
		 * oldest. */
		memmove(&a->out[0], &a->out[1],
		        (a->n - 1u) * sizeof(a->out[0]));
		a->n--;
	}
	a->out[a->n++] = (struct bc_ack_frame){no, len, now_ms};
}

bool bc__acks_full(const struct bc_acks *a)
{
	return a->on && a->n >= BC_PROTO_ACK_WINDOW;
}

bool bc__acks_congested(const struct bc_acks *a)
{
	return a->min_us > 0 && a->srtt_us > a->min_us + a->min_us / 2u +
	                                         BC_SRV_ACK_QUEUE_SLACK_US;
}

/* One round trip of rtt_us for bytes acknowledged over span_ms. */
static void sample(struct bc_acks *a, uint64_t rtt_us, size_t bytes,
                   uint64_t span_ms, bool waited)
{
	uint32_t r = rtt_us > UINT32_MAX ? UINT32_MAX : (uint32_t)rtt_us;
	a->srtt_us = a->srtt_us ? a->srtt_us - a->srtt_us / 8u + r / 8u : r;
	a->min_us = a->min_us && a->min_us < r ? a->min_us : (r ? r : 1u);
	if (waited && span_ms > 0) {
		uint64_t bps = (uint64_t)bytes * 1000u / span_ms;
		a->bps = a->bps ? a->bps - a->bps / 4u + bps / 4u : bps;
	}
}

int bc__acks_take(struct bc_acks *a, uint32_t no, uint32_t last,
                  uint64_t now_ms, struct bc_errinfo *ei)
{
	uint32_t k = 0;
	size_t bytes = 0;
	uint64_t first_ms = 0;
	if (no > last) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "FRAME_ACK for frame %u, which was never "
		                      "sent (the last FRAME sent is %u)",
		                      no, last);
	}
	if (no <= a->acked) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "FRAME_ACK for frame %u out of order: "
		                      "frame %u was acknowledged already",
		                      no, a->acked);
	}
	a->acked = no;
	while (k < a->n && a->out[k].no <= no) {
		bytes += a->out[k].len;
		first_ms = k == 0 ? a->out[k].written_ms : first_ms;
		k++;
	}
	if (k > 0) {
		const struct bc_ack_frame *newest = &a->out[k - 1u];
		/* The rate counts only when the window was full: frames
		 * then waited for the path, not for the renderer. */
		sample(a, (now_ms - newest->written_ms) * 1000u, bytes,
		       now_ms - first_ms, a->n == BC_PROTO_ACK_WINDOW);
		memmove(&a->out[0], &a->out[k], (a->n - k) * sizeof(a->out[0]));
		a->n -= k;
	}
	return 0;
}

void bc__acks_info(const struct bc_acks *a, struct bc_proto_link *out)
{
	if (!a->on || a->srtt_us == 0) {
		return;
	}
	out->rtt_us = a->srtt_us;
	out->min_rtt_us = a->min_us;
	if (a->bps && (out->delivery_bps == 0 || a->bps < out->delivery_bps)) {
		out->delivery_bps = a->bps;
	}
}
