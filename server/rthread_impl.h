/*
 * The render thread's private types, shared by rthread.c (the thread, its
 * replicas, command and result queues), render_job.c (what a job renders:
 * picks, frames and their encoding) and views.c (the kept views: damage,
 * progressive refinement, the cost model, pictures).
 */
#ifndef BLOBCAST_SERVER_RTHREAD_IMPL_H
#define BLOBCAST_SERVER_RTHREAD_IMPL_H

#include "server.h"

enum rcmd_kind {
	RCMD_INVALID = 0,
	RCMD_SCENE,
	RCMD_SET_PRIM,
	RCMD_SET_OP,
	RCMD_DROP,
	RCMD_JOB,
	RCMD_COUNT
};

struct rcmd {
	enum rcmd_kind kind;
	uint32_t session_id;
	struct bc_tree *tree;
	uint32_t id;
	struct bc_prim_data p;
	struct bc_op_data op;
	struct bc_rjob *job;
	struct rresult *res; /* RCMD_JOB: allocated with the command */
	struct rcmd *next;
};

struct rresult {
	struct bc_rjob *job;
	struct bc_shared *frame;
	bool yielded; /* no frame: a refinement gave way to newer work */
	bool hit;
	float position[3], depth;
	uint32_t node;
	double render_ms, encode_ms;
	bool incomplete;
	bool too_big; /* no frame: it is over the protocol's payload limit */
	bool oom;     /* no frame: out of memory, the targets stay owed */
	struct bc_shown shown; /* what the targets hold after this frame */
	struct rresult *next;
};

struct replica {
	uint32_t session_id;
	struct bc_tree *tree;
	struct bc_renderer *r;
	bool fresh; /* the renderer has not seen this tree yet */
	/* Cost model of this scene's frames, for the coarse level: running
	 * averages of milliseconds per traced ray and per A-buffer. */
	double ms_per_ray, ms_abuffer;
};

/* One view's planes (see the file comment). */
struct view {
	uint32_t id; /* unique over the thread's life, 0: slot free */
	uint32_t session_id;
	struct bc_camera camera;
	uint32_t width, height, ntiles;
	struct bc_frame frame;
	int level;         /* finest level complete in frame, -1: none */
	bool stuck;        /* a refinement hit the time budget: wait */
	uint32_t version;  /* bumped whenever frame changes */
	uint32_t *changed; /* per tile: version of its last change */
	uint8_t *damage;   /* per tile: an edit may have changed it */
	bool damaged;
	uint64_t used; /* for eviction, least recently used first */
};

struct bc_rthread {
	struct bc_srv *srv;
	uv_thread_t thread;
	uv_mutex_t lock;
	uv_cond_t cond;
	struct rcmd *head, *tail;
	uint32_t last_session; /* served last: the turns go on from it */
	struct rresult *rhead, *rtail;
	bool quit;
	enum bc_backend backend;
	struct bc_render_opts opts;
	struct bc_encoder *enc;
	struct replica replicas[BC_SRV_MAX_SESSIONS];
	struct view views[BC_SRV_MAX_VIEWS];
	uint32_t next_view_id;
	uint64_t clock;
	bool damage_off; /* every edit re-renders the whole view */
	uint8_t *small;  /* a coarse level's picture, RGBA */
	size_t small_cap;
	struct bc_proto_rect *rects;
	uint8_t *seen, *band;
	size_t seen_cap, band_cap;
	uint32_t budget_ms; /* of one refinement step */
};

/* A parameter edit of node id is about to be applied to rp's tree:
 * remembers the ABVs it can change; after it, marks in every view of the
 * session the tiles those ABVs reach before and after. */
struct edit_abvs {
	uint32_t k0, n;
	struct bc_abv *old;
};

/* ---- rthread.c ---- */

/* The replica of session id, or NULL; with create, a free slot is taken
 * for it when it has none. */
struct replica *bc__replica_of(struct bc_rthread *rt, uint32_t id, bool create);

/* Hands res back to the loop thread (the result queue and its async). */
void bc__push_result(struct bc_rthread *rt, struct rresult *res);

/* ---- render_job.c ---- */

/* Runs job (a pick or a frame) and pushes res, filled, as its result. */
void bc__run_job(struct bc_rthread *rt, struct bc_rjob *job,
                 struct rresult *res);

/* ---- views.c ---- */

void bc__view_free(struct view *v);

void bc__views_drop(struct bc_rthread *rt, uint32_t session_id);

struct view *bc__view_of(struct bc_rthread *rt, const struct bc_rjob *job);

void bc__edit_begin(const struct replica *rp, uint32_t id, struct edit_abvs *e);

void bc__edit_end(struct bc_rthread *rt, const struct replica *rp,
                  struct edit_abvs *e);

int bc__update_view(struct bc_rthread *rt, struct replica *rp, struct view *v,
                    const struct bc_rjob *job, bool *incomplete, bool *yielded,
                    struct bc_errinfo *ei);

uint32_t bc__changed_rects(struct bc_rthread *rt, const struct view *v,
                           uint32_t since, bool *none);

const uint8_t *bc__picture(struct bc_rthread *rt, const struct view *v,
                           uint32_t *w, uint32_t *h);

#endif
