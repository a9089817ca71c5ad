/*
 * How long --screenshot waits, and the size of the view a framebuffer asks
 * for.
 *
 * A screenshot wants the finished picture: level 0 without INCOMPLETE
 * (normally the still). The daemon may never send it. Its time budget can
 * leave a picture INCOMPLETE for good once it has spent what it allows on
 * those pixels; PROTOCOL.md 7.15 says only that INCOMPLETE frames keep
 * coming while it still refines, and that the last one keeps the flag
 * until something changes. So a picture that is not finished is taken as
 * settled when no frame has come for a quiet time while nothing we sent
 * waits for an answer; the quiet time is a floor or a few times the
 * longest gap between this picture's frames, whichever is longer, since
 * the daemon's frame budget (unknown to the client) sets that gap. A wait
 * per picture bounds everything else (a crawling scene that keeps
 * refining for minutes, a daemon that sends nothing).
 */
#include <stdio.h>
#include <string.h>

#include "viewer.h"

void bc_viewer_shot_start(struct bc_viewer_shot *s, double now)
{
	memset(s, 0, sizeof(*s));
	s->start = now;
}

void bc_viewer_shot_frame(struct bc_viewer_shot *s, uint16_t flags, double now)
{
	double from = s->nframes ? s->last_at : s->start;
	if (now - from > s->max_gap) {
		s->max_gap = now - from;
	}
	s->last_at = now;
	s->flags = flags;
	s->nframes++;
}

bool bc_viewer_shot_finished(const struct bc_viewer_shot *s)
{
	return s->nframes > 0 && bc_proto_flags_level(s->flags) == 0 &&
	       !(s->flags & BC_PROTO_FLAG_INCOMPLETE);
}

double bc_viewer_shot_quiet_ms(const struct bc_viewer_shot *s)
{
	double q = BC_VIEWER_SHOT_QUIET_GAPS * s->max_gap;
	return q > BC_VIEWER_SHOT_QUIET_MS ? q : BC_VIEWER_SHOT_QUIET_MS;
}

enum bc_viewer_shot_state bc_viewer_shot_check(const struct bc_viewer_shot *s,
                                               double now, double pending_since,
                                               double wait_ms, double *due_ms)
{
	double end = s->start + wait_ms, next = end;
	*due_ms = -1.0;
	if (bc_viewer_shot_finished(s)) {
		return BC_VIEWER_SHOT_FINISHED;
	}
	if (s->nframes > 0 && pending_since <= 0.0) {
		/* Nothing of ours is on its way: a silent daemon has
		 * nothing better to send. */
		double quiet_end = s->last_at + bc_viewer_shot_quiet_ms(s);
		if (now >= quiet_end) {
			return BC_VIEWER_SHOT_SETTLED;
		}
		if (quiet_end < next) {
			next = quiet_end;
		}
	}
	if (now >= end) {
		return BC_VIEWER_SHOT_TIMEOUT;
	}
	*due_ms = next - now;
	return BC_VIEWER_SHOT_WAITING;
}

const char *bc_viewer_shot_text(const struct bc_viewer_shot *s,
                                enum bc_viewer_shot_state st, double wait_ms,
                                char *out, size_t n)
{
	unsigned level = bc_proto_flags_level(s->flags);
	bool incomplete = (s->flags & BC_PROTO_FLAG_INCOMPLETE) != 0;
	if (n == 0) {
		return out;
	}
	if (s->nframes == 0) {
		snprintf(out, n, "no frame within %.0f s", wait_ms / 1e3);
	} else if (st == BC_VIEWER_SHOT_FINISHED) {
		snprintf(out, n, "level 0, finished");
	} else if (st == BC_VIEWER_SHOT_SETTLED) {
		snprintf(out, n,
		         "level %u%s: no better frame for %.1f s (the daemon "
		         "stopped refining it)",
		         level, incomplete ? ", INCOMPLETE" : "",
		         bc_viewer_shot_quiet_ms(s) / 1e3);
	} else {
		snprintf(out, n, "level %u%s: still refining after %.0f s",
		         level, incomplete ? ", INCOMPLETE" : "",
		         wait_ms / 1e3);
	}
	return out;
}

bool bc_viewer_view_size(uint32_t fb_w, uint32_t fb_h, uint32_t max,
                         uint32_t *w, uint32_t *h)
{
	uint32_t big = fb_w > fb_h ? fb_w : fb_h;
	*w = fb_w;
	*h = fb_h;
	if (max == 0 || big <= max) {
		return false;
	}
	/* The longer side becomes max, the other keeps the aspect ratio
	 * (rounded, at least 1), so the picture is not stretched. */
	if (fb_w >= fb_h) {
		*w = max;
		*h = (uint32_t)(((uint64_t)fb_h * max + fb_w / 2u) / fb_w);
	} else {
		*h = max;
		*w = (uint32_t)(((uint64_t)fb_w * max + fb_h / 2u) / fb_h);
	}
	if (*w == 0) {
		*w = 1;
	}
	if (*h == 0) {
		*h = 1;
	}
	return true;
}
