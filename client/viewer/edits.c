/*
 * The edit queue of direct manipulation. A drag produces far more mouse
 * events than a server renders frames, so edits marked INTERACTING go one
 * at a time: the next leaves when EDIT_APPLIED acknowledges the last, and
 * carries the newest values (an edit not yet sent is simply replaced). A
 * slow server is never flooded and never lags behind the mouse. The final
 * edit of a gesture (no INTERACTING) leaves at once.
 *
 * It also measures edit -> frame latency: the time from sending an EDIT to
 * showing the first frame whose order number is at least the order the
 * server gave that edit (PROTOCOL.md section 5).
 */
#include <string.h>

#include "viewer.h"

void bc_viewer_edits_init(struct bc_viewer_edits *q)
{
	memset(q, 0, sizeof(*q));
}

void bc_viewer_edits_queue(struct bc_viewer_edits *q,
                           const struct bc_viewer_edit *e)
{
	q->pending = *e;
	q->has_pending = true;
}

bool bc_viewer_edits_ready(const struct bc_viewer_edits *q)
{
	return q->has_pending && (!q->pending.interacting || q->inflight == 0);
}

void bc_viewer_edits_sent(struct bc_viewer_edits *q, uint32_t seq,
                          double now_ms)
{
	bc_viewer_edits_track(q, seq, now_ms);
	if (q->has_pending && q->pending.interacting) {
		q->inflight = seq;
	}
	q->has_pending = false;
}

void bc_viewer_edits_track(struct bc_viewer_edits *q, uint32_t seq,
                           double now_ms)
{
	if (q->nsent == BC_VIEWER_EDITS_SENT) {
		/* An answer that never came: forget the oldest. */
		memmove(&q->sent[0], &q->sent[1],
		        (BC_VIEWER_EDITS_SENT - 1) * sizeof(q->sent[0]));
		q->nsent--;
	}
	q->sent[q->nsent].seq = seq;
	q->sent[q->nsent].at = now_ms;
	q->nsent++;
}

/* Removes seq from the sent list; returns its send time or a negative
 * value when it is not there. */
static double take_sent(struct bc_viewer_edits *q, uint32_t seq)
{
	for (uint32_t i = 0; i < q->nsent; i++) {
		if (q->sent[i].seq == seq) {
			double at = q->sent[i].at;
			memmove(&q->sent[i], &q->sent[i + 1],
			        (q->nsent - i - 1) * sizeof(q->sent[0]));
			q->nsent--;
			return at;
		}
	}
	return -1.0;
}

bool bc_viewer_edits_applied(struct bc_viewer_edits *q, uint32_t seq,
                             uint64_t order)
{
	double at = take_sent(q, seq);
	bool was_inflight = seq != 0 && seq == q->inflight;
	if (at >= 0.0) {
		if (q->nshown == BC_VIEWER_EDITS_SENT) {
			memmove(&q->shown[0], &q->shown[1],
			        (BC_VIEWER_EDITS_SENT - 1) *
			            sizeof(q->shown[0]));
			q->nshown--;
		}
		q->shown[q->nshown].order = order;
		q->shown[q->nshown].at = at;
		q->nshown++;
	}
	if (was_inflight) {
		q->inflight = 0;
	}
	return was_inflight;
}

bool bc_viewer_edits_refused(struct bc_viewer_edits *q, uint32_t seq)
{
	bool ours = take_sent(q, seq) >= 0.0;
	if (seq != 0 && seq == q->inflight) {
		q->inflight = 0;
	}
	return ours;
}

uint32_t bc_viewer_edits_frame(struct bc_viewer_edits *q, uint64_t order,
                               double now_ms, struct bc_viewer_meter *m)
{
	uint32_t n = 0, keep = 0;
	/* Orders grow in the order EDIT_APPLIED arrives, but keep the test
	 * per entry: it costs nothing and assumes nothing. */
	for (uint32_t i = 0; i < q->nshown; i++) {
		if (q->shown[i].order <= order) {
			if (m) {
				bc_viewer_meter_latency(m, now_ms -
				                               q->shown[i].at);
			}
			n++;
		} else {
			q->shown[keep++] = q->shown[i];
		}
	}
	q->nshown = keep;
	return n;
}
