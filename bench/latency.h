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
#include "blobcast/gen.h"
#include "blobcast/scene.h"

struct latency {
	int n;                 /* frames received */
	int64_t p50, p99, max; /* milliseconds */
	double bytes, rects;   /* per frame */
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
	int64_t *lat =
	    bc_calloc((size_t)(edits > 0 ? edits : 1), sizeof(int64_t));
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

/* Loads fig18 (count smooth spheres) into c's session with SCENE_LOAD and
 * waits for its SCENE_STATE. *prim_id: a sphere in the middle of the grid,
 * *prim its data; *cam (may be NULL) the scene's camera. */
static inline int latency_load_fig18(struct conn *c, uint32_t count,
                                     uint32_t *prim_id,
                                     struct bc_prim_data *prim,
                                     struct bc_camera *cam)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera scene_cam;
	struct bc_gen_opts o = {.count = count,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SMOOTH};
	uint8_t *bytes = NULL;
	size_t len = 0;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	const struct bc_lin *l;
	if (!t || bc_gen("fig18", &o, t, &scene_cam, NULL) ||
	    bc_scene_encode(t, &scene_cam, &bytes, &len)) {
		bc_tree_destroy(t);
		return -1;
	}
	l = bc_tree_lin(t);
	*prim_id = l->node_id[l->prim_slot[l->nprims / 2]];
	bc_tree_get(t, *prim_id, prim, NULL);
	if (cam) {
		*cam = scene_cam;
	}
	m.scene_load.scene.ptr = bytes;
	m.scene_load.scene.len = (uint32_t)len;
	conn_send(c, &m);
	bc_free(bytes);
	bc_tree_destroy(t);
	return conn_expect(c, BC_MSG_SCENE_STATE, 300000) == 1 ? 0 : -1;
}

/* VmRSS and VmHWM of process pid in KiB (-1 when unknown). */
static inline void latency_rss_of(pid_t pid, long *rss, long *hwm)
{
	char path[64], line[256];
	FILE *f;
	*rss = *hwm = -1;
	snprintf(path, sizeof(path), "/proc/%d/status", (int)pid);
	if (!(f = fopen(path, "r"))) {
		return;
	}
	while (fgets(line, sizeof(line), f)) {
		if (strncmp(line, "VmRSS:", 6) == 0) {
			*rss = atol(line + 6);
		} else if (strncmp(line, "VmHWM:", 6) == 0) {
			*hwm = atol(line + 6);
		}
	}
	fclose(f);
}

#endif
