/*
 * The numbers the overlay shows: frames per second (frames shown in the
 * last second, counted from a ring of arrival times, so a stalled stream
 * reads 0 at once rather than a stale average), kB per frame (wire bytes of
 * the last frames) and edit -> frame latency (last and average of the last
 * ones). Plain rings: no allocation, nothing to free.
 */
#include <string.h>

#include "viewer.h"

void bc_viewer_meter_init(struct bc_viewer_meter *m)
{
	memset(m, 0, sizeof(*m));
	m->last_latency = -1.0;
}

void bc_viewer_meter_frame(struct bc_viewer_meter *m, uint32_t bytes,
                           double now_ms)
{
	m->frame_at[m->next_at] = now_ms;
	m->next_at = (m->next_at + 1) % BC_VIEWER_METER_TIMES;
	if (m->nframes_at < BC_VIEWER_METER_TIMES) {
		m->nframes_at++;
	}
	m->bytes[m->next_bytes] = bytes;
	m->next_bytes = (m->next_bytes + 1) % BC_VIEWER_METER_BYTES;
	if (m->nbytes < BC_VIEWER_METER_BYTES) {
		m->nbytes++;
	}
	m->frames++;
}

void bc_viewer_meter_latency(struct bc_viewer_meter *m, double ms)
{
	m->latency[m->next_latency] = ms;
	m->next_latency = (m->next_latency + 1) % BC_VIEWER_METER_LATENCIES;
	if (m->nlatency < BC_VIEWER_METER_LATENCIES) {
		m->nlatency++;
	}
	m->last_latency = ms;
}

double bc_viewer_meter_fps(const struct bc_viewer_meter *m, double now_ms)
{
	uint32_t n = 0;
	for (uint32_t i = 0; i < m->nframes_at; i++) {
		double at = m->frame_at[i];
		if (at > now_ms - 1000.0 && at <= now_ms) {
			n++;
		}
	}
	return (double)n;
}

double bc_viewer_meter_kb(const struct bc_viewer_meter *m)
{
	double sum = 0.0;
	if (m->nbytes == 0) {
		return 0.0;
	}
	for (uint32_t i = 0; i < m->nbytes; i++) {
		sum += (double)m->bytes[i];
	}
	return sum / (double)m->nbytes / 1000.0;
}

double bc_viewer_meter_latency_avg(const struct bc_viewer_meter *m)
{
	double sum = 0.0;
	if (m->nlatency == 0) {
		return -1.0;
	}
	for (uint32_t i = 0; i < m->nlatency; i++) {
		sum += m->latency[i];
	}
	return sum / (double)m->nlatency;
}
