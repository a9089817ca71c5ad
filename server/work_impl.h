/*
 * The work layer's private types, shared by work.c (the scheduler, its
 * workers and queues), flow.c (a session's render copy and the changes
 * queued for it), views.c (the view cache: planes kept per view, tile by
 * tile) and job.c (what one slice of a job does).
 *
 * Locking: w->lock guards the flows' queues (changes and jobs), their
 * scheduling state and the result list; w->views.lock guards the view
 * cache's table. A flow's render copy, renderer and current job belong to
 * the worker that holds the flow (flow->held), one at a time, so slices
 * of one session never run at once and need no lock of their own.
 */
#ifndef BLOBCAST_SERVER_WORK_IMPL_H
#define BLOBCAST_SERVER_WORK_IMPL_H

#include <stdatomic.h>

#include "encode.h"
#include "work.h"

/* Scheduling classes inside a session, served in this order. */
enum job_class {
	JC_INTERACTIVE = 0, /* frames during an interaction, picks */
	JC_STILL,           /* refinement toward the still, first pictures */
	JC_SNAPSHOT,
	JC_COUNT
};

/* A change queued for a render copy. */
enum upd_kind { UPD_INVALID = 0, UPD_SCENE, UPD_STATES, UPD_OPS, UPD_COUNT };

struct upd {
	enum upd_kind kind;
	struct upd *next;
	uint64_t order;       /* the session's order once it is applied */
	struct bc_tree *tree; /* UPD_SCENE */
	/* UPD_STATES: the newest state of each node, and an open-addressing
	 * table of id -> index + 1 (0: empty) over them. */
	struct bc_edit_saved *st;
	uint32_t n, cap;
	uint32_t *index;
	uint32_t index_cap;     /* a power of two, at least twice cap */
	struct bc_ops_copy ops; /* UPD_OPS */
	bool early;             /* UPD_OPS: queued before the session's apply */
	/* An early batch's verdict when it came before a worker took the
	 * change (bc_work_settle): 1 stands, -1 undone, 0 not yet. */
	int8_t verdict;
	size_t bytes; /* what this change holds, for the flow's cap */
};

/* A view kept by the cache: the full-size planes of one camera and size
 * of a session, and per 8x8 tile what they hold. */
struct view {
	uint32_t id; /* unique over the work layer's life; 0: slot free */
	uint32_t sid;
	struct bc_camera camera;
	uint32_t width, height, tw, th, ntiles;
	struct bc_frame frame;
	int8_t *tlevel;    /* finest level the tile holds whole; -1 nothing */
	uint8_t *damage;   /* an edit may have changed the tile */
	uint8_t *shorts;   /* rays of the tile ran out of evaluations */
	uint32_t *changed; /* version of the tile's last change */
	uint32_t version;  /* bumped whenever the planes change */
	uint32_t bound;    /* evaluations a retry of short tiles may take */
	bool damaged;      /* some damage byte is set */
	bool dead;         /* dropped while pinned: freed at the last unpin */
	uint32_t pins;     /* running jobs (and damage marking) using it */
	uint64_t used;     /* for eviction, least recently used first */
	size_t bytes;
};

struct views {
	uv_mutex_t lock;
	struct view v[BC_SRV_MAX_VIEWS];
	size_t bytes; /* of the views' planes */
	size_t cap;
	uint32_t next_id;
	uint64_t clock;
};

/* What became of an early batch on the copy (struct flow's eb_state). */
enum early_state { EB_NONE = 0, EB_APPLIED, EB_FAILED, EB_SKIPPED };

/* A session's render side. */
struct flow {
	uint32_t sid; /* 0: slot free */
	/* Under w->lock. */
	struct upd *uhead, *utail;
	size_t ubytes;
	struct bc_job *qhead[JC_COUNT], *qtail[JC_COUNT];
	struct bc_job *cur; /* started, not finished */
	bool held;          /* a worker runs a slice of it now */
	/* A structural batch queued ahead of the session's own apply
	 * (bc_work_ops_early) waits for its verdict: the flow's jobs wait
	 * meanwhile, so no frame shows a batch that may yet be undone. */
	bool early;
	/* The verdict on the early batch a worker already took (it is
	 * held, eb_state), for the holder: 1 stands, -1 undone. */
	int8_t settle;
	bool dropped;    /* the session is gone: freed by a worker */
	double vruntime; /* render ms, the scheduler's clock */
	uint64_t render_us;
	double long_ms;  /* the last slice, when it ran long */
	double first_ms; /* the first slices of its jobs, running average */
	/* Only the holder touches these. */
	struct bc_tree *tree;
	struct bc_renderer *r;
	bool fresh;  /* the renderer has not seen this tree yet */
	bool broken; /* a change could not be applied: no frames */
	uint64_t order;
	/* The early batch as the copy took it, until its verdict: applied
	 * (eb holds what undoes it), failed, or not tried (no copy); and
	 * the copy's order before it. */
	enum early_state eb_state;
	struct bc_edit_batch eb;
	uint64_t eb_order;
	/* Cost model of this scene's frames, for the coarse level and the
	 * slice size: running averages of milliseconds per traced ray and
	 * per A-buffer of a new view. */
	double ms_per_ray, ms_abuffer;
	/* Evaluations a ray may spend in this scene's passes: lowered while
	 * most rays run out (a crawling scene's first picture comes at once,
	 * retries go on from there), raised back while none do. */
	uint32_t ray_bound;
	uint64_t render_calls; /* renderer calls of its slices */
	size_t kept_bytes;     /* renderer state, counted in the cache */
	/* The view size and window the renderer keeps state for
	 * (bc_renderer_release when another comes). */
	uint32_t rw, rh;
	struct bc_job_window rwin;
};

/* Per worker scratch: reused across slices, never shared. */
struct worker {
	struct bc_work *w;
	uv_thread_t thread;
	uint32_t index;
	bool started;
	bool in_slice; /* for bc_work_stop's bounded wait */
	/* Render threads this worker's slice may use: 1, or every worker's
	 * when the others wait for work (work.c); a slice that does not
	 * render sets it back to 1 (job.c). */
	uint32_t team;
	const struct flow *prev; /* the flow of its last slice */
	struct bc_encoder *enc;
	uint8_t *mask, *shorts; /* per tile of the view being rendered */
	size_t mask_cap;
	uint8_t *small; /* a coarse level's picture */
	size_t small_cap;
	uint8_t *seen; /* tiles merged into rectangles */
	size_t seen_cap;
	struct bc_proto_rect *rects;
};

/* One job and its progress. */
enum job_stage {
	JS_START = 0, /* sync the renderer, take the view, plan */
	JS_RENDER,    /* tiles, a slice at a time */
	JS_ENCODE,    /* rectangles (a PNG a band of rows at a time) */
	JS_FINISH,
	JS_COUNT
};

/* What a render pass does to the tiles it selects. */
enum pass_kind {
	PASS_NONE = 0,
	PASS_FIRST,  /* tiles holding nothing, at a coarse level */
	PASS_DAMAGE, /* damaged tiles, again at their level */
	PASS_RETRY,  /* tiles with rays that ran out, with a larger bound */
	PASS_REFINE, /* the coarsest tiles, one level finer */
	PASS_COUNT
};

struct bc_job {
	struct bc_job_req req;
	enum job_class cls;
	struct flow *flow;
	struct bc_job *prev, *next; /* in its flow's queue, or results */
	/* Under w->lock. */
	bool running, retracted, cancelled;
	/* The worker's. */
	enum job_stage stage;
	enum pass_kind pass;
	int8_t pass_level;    /* DAMAGE and REFINE: the level worked on */
	uint32_t cursor;      /* next tile of the pass to look at */
	uint32_t slice_tiles; /* tiles per slice, from the cost model */
	uint32_t bound;       /* evaluations per ray of this pass */
	struct view *v;
	double submitted_ms, started_ms, render_ms, encode_ms;
	bool incomplete;
	bool stuck;     /* rays still run out at BC_SRV_RAY_EVALS_MAX */
	uint32_t vnext; /* H.264: the next target to encode for */
	struct bc_encode_job *enc; /* JS_ENCODE's rectangles */
	struct bc_work_done done;
};

struct bc_work {
	uv_loop_t *loop;
	struct bc_work_opts opts;
	uv_mutex_t lock;
	uv_cond_t cond;
	bool quit;
	struct flow flows[BC_SRV_MAX_FLOWS];
	double min_vruntime;
	uint32_t queued, running; /* jobs */
	uint32_t long_slices;     /* workers inside a long slice now */
	uint32_t waiting;         /* workers waiting for work */
	double short_seen_ms; /* when short work last waited (bc_clock_ms) */
	struct bc_job *rhead, *rtail; /* finished, for the loop */
	uv_async_t results;
	struct views views;
	struct worker *workers;
	uint32_t nworkers;
	struct bc_render_opts ropts;
	uint32_t budget_ms;
	/* Bytes the flows' renderers keep (each holder adds its change). */
	atomic_size_t kept_bytes;
};

/* ---- work.c ---- */

/* Queues change u for session sid (a scene creates its flow). Returns 0,
 * or BC_ELIMIT when the flow's queued changes would pass
 * BC_SRV_FLOW_CHANGE_BYTES, an early batch still waits for its verdict
 * (u early too), or no flow can be had (u freed). */
int bc__work_queue(struct bc_work *w, uint32_t sid, struct upd *u);
/* A flow about to get work after none starts at most the wake credit
 * behind the others (work.c). Called with the lock held. */
void bc__work_wake(struct bc_work *w, struct flow *f);
/* What the renderers keep, for the view cache's cap. Takes no lock. */
size_t bc__work_kept_bytes(struct bc_work *w);
/* Has the renderers of sessions no worker holds give back their state
 * (bc_renderer_release), for a view that does not fit. */
void bc__work_trim(struct bc_work *w);
/* The holder of f records what its renderer keeps now. */
void bc__flow_kept(struct bc_work *w, struct flow *f);

/* ---- flow.c ---- */

/* Applies the verdict on the early batch f holds (settle, 0: none), then
 * the changes queued for f (taken from its queue by the caller),
 * coalesced, marking the tiles they damage in the session's views. */
void bc__flow_apply(struct bc_work *w, struct flow *f, struct upd *list,
                    int settle);
void bc__upd_free(struct upd *u);
/* Frees the flow's copy, renderer and views (the holder, or stop). */
void bc__flow_clear(struct bc_work *w, struct flow *f);

/* ---- views.c ---- */

int bc__views_init(struct views *vs, size_t cap);
void bc__views_finish(struct views *vs);
/* The view of (sid, cam, width x height, the window win of a bigger
 * picture or none), kept or new, pinned; NULL when
 * out of memory or when the cache cannot make room under its cap (every
 * other view pinned). extra: bytes the renderer will keep beside it. */
struct view *bc__view_acquire(struct bc_work *w, uint32_t sid,
                              const struct bc_job_window *win,
                              const struct bc_camera *cam, uint32_t width,
                              uint32_t height);
void bc__view_release(struct bc_work *w, struct view *v);
/* Forgets every view of a session (its structure changed, or it ends). */
void bc__views_drop(struct bc_work *w, uint32_t sid);
/* Pins every live view of sid into out (BC_SRV_MAX_VIEWS); returns the
 * count. The caller releases each. */
uint32_t bc__views_of(struct bc_work *w, uint32_t sid, struct view **out);
/* Sets every tile of v to hold nothing. */
void bc__view_reset(struct view *v);
/* A renderer's state grows past what was counted for its view (tile lists
 * of a crowded scene): back under the cap, idle renderers' state and then
 * least recently used views go. Called by a worker after a render. */
void bc__views_settle(struct bc_work *w);
/* Gives pinned view v its depth and id planes (views keep colour only
 * until a snapshot asks for them; all tiles are then drawn again).
 * Returns 0, or BC_ENOMEM when they do not fit under the cap. */
int bc__view_planes(struct bc_work *w, struct view *v);
/* The level of v's picture: the coarsest of its tiles' (-1: a tile holds
 * nothing). */
int bc__view_level(const struct view *v);
/* Merges the tiles changed after version `since` into rectangles in
 * wk->rects. Returns the count; 0 when there are more than
 * BC_PROTO_MAX_RECTS or none changed (*none set). */
uint32_t bc__changed_rects(struct worker *wk, const struct view *v,
                           uint32_t since, bool *none);
/* The picture of v at level l: every 2^l-th pixel of each row and column
 * (level 0: the planes themselves). NULL when out of memory. */
const uint8_t *bc__picture(struct worker *wk, const struct view *v, int l,
                           uint32_t *w, uint32_t *h);
/* Renderer state and view planes the cache holds now, and its cap. */
size_t bc__views_bytes(struct bc_work *w);

/* ---- job.c ---- */

/* Runs one slice of f's current job. Returns true when the job is over
 * (job->done filled). */
bool bc__job_slice(struct bc_work *w, struct worker *wk, struct flow *f,
                   struct bc_job *job);
/* Ends job without running it further: done.outcome as given. */
void bc__job_end(struct bc_work *w, struct bc_job *job,
                 enum bc_work_outcome outcome);
/* Whether the job's current work may give way (a refinement step, a
 * retry, the still): the scheduler then ends it when retracted or when
 * changes wait for its session. */
bool bc__job_yieldable(const struct bc_job *job);
void bc__job_free(struct bc_job *job);

#endif
