/*
 * Progress reports of long render calls (blobcast/render_common.h), paced
 * alike for every backend.
 */
#include "blobcast/render_common.h"

#include "blobcast/clock.h"
#include "blobcast/render_backend.h"

void bc_render_progress_init(struct bc_render_progress *p,
                             const struct bc_renderer *r, uint32_t total)
{
	p->fn = r ? r->progress : NULL;
	p->user = r ? r->progress_user : NULL;
	p->total = total;
	p->start = bc_clock_ms();
	p->last = p->start;
}

void bc_render_progress_tick(struct bc_render_progress *p, uint32_t done)
{
	double now;
	if (!p->fn) {
		return;
	}
	now = bc_clock_ms();
	/* Short calls stay quiet; long ones report four times a second. */
	if (now - p->start < 1000.0 || now - p->last < 250.0) {
		return;
	}
	p->last = now;
	p->fn(p->user, done > p->total ? p->total : done, p->total);
}
