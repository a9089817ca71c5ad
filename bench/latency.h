/*
 * What the daemon benchmarks share: edits of one primitive, each timed
 * until the FRAME that reflects it arrives, summarized as percentiles.
 * Include after ../tests/server/daemon.h and blobcast/blobtree.h.
 */
#ifndef BLOBCAST_BENCH_LATENCY_H
#define BLOBCAST_BENCH_LATENCY_H

#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>

#include "blobcast/alloc.h"

struct latency {
	int n;                  /* frames received */
	int64_t p50, p99, max;  /* milliseconds */
	double bytes, rects;    /* per frame */
};

static inline int latency_cmp_i64(const void *a, const void *b)
{
	int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
	return (x > y) - (x < y);
}

static inline double latency_frame_bytes(const struct bc_msg *m)
{
	double n = 0;
	for (uint32_t i = 0; i < m->frame.nrects; i++) {
		n += m->frame.rects[i].data.len;
	}
	return n;
}

/* Moves primitive id to from->translate + (dx[i % ndx], 0, 0) edits times
 * (INTERACTING when asked), waiting each time for the FRAME whose order
 * reflects the edit. */
static inline void latency_edits(struct conn *c, uint32_t id,
				 const struct bc_prim_data *from,
				 const float *dx, int ndx, int edits,
				 bool interacting, struct latency *out)
{
	int64_t *lat = bc_calloc((size_t)(edits > 0 ? edits : 1),
				 sizeof(int64_t));
	memset(out, 0, sizeof(*out));
	for (int i = 0; lat && i < edits; i++) {
		int64_t t0 = t_now_ms();
		uint64_t order = 0;
		conn_move(c, id, from->translate[0] + dx[i % ndx],
			  from->translate[1], from->translate[2], interacting);
		while (conn_recv(c, 30000) == 1) {
			if (c->m.type == BC_MSG_EDIT_APPLIED) {
				order = c->m.edit_applied.order;
			} else if (c->m.type == BC_MSG_FRAME && order &&
				   c->m.frame.order >= order) {
				lat[out->n++] = t_now_ms() - t0;
				out->bytes += latency_frame_bytes(&c->m);
				out->rects += c->m.frame.nrects;
				break;
			}
		}
	}
	if (out->n > 0) {
		qsort(lat, (size_t)out->n, sizeof(int64_t), latency_cmp_i64);
		out->p50 = lat[out->n / 2];
		out->p99 = lat[(out->n * 99) / 100];
		out->max = lat[out->n - 1];
		out->bytes /= out->n;
		out->rects /= out->n;
	}
	bc_free(lat);
}

#endif
