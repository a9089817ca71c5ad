/*
 * The work layer: the render copies of the sessions' scenes and the render
 * jobs on them, run by a pool of render workers under one scheduler
 * (work.c). Called from the loop thread by the sessions layer; what a job
 * gives back arrives on the loop thread through the callback of the
 * options.
 *
 * Scheduling, in short (work.c has the whole of it): each session has a
 * flow, its render copy and its queue of jobs; a worker takes the
 * runnable flow that has had the least render time (a virtual clock per
 * session, as Linux's CFS keeps per task), runs one slice of its current
 * job (a few milliseconds of tiles, then encoding) and puts it back, so
 * any job yields between slices and a session gets its fair share however
 * much work it queues. Inside a session, interactive frames go before
 * stills and stills before snapshots; parameter edits reach the copy
 * coalesced to the newest state of each node, between jobs.
 */
#ifndef BLOBCAST_SERVER_WORK_H
#define BLOBCAST_SERVER_WORK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <uv.h>

#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/proto.h"
#include "blobcast/render.h"
#include "link.h"
#include "srv_limits.h"
#include "vstream.h"

struct bc_work;
struct bc_job;

/* What a client holds of a view after a frame (set by the worker, kept by
 * the sessions layer): the view's id (0: nothing), its version, the level
 * of the picture, whether every pixel came losslessly, whether finer
 * levels will follow, and whether the frame was the still. */
struct bc_shown {
	uint32_t view;
	uint32_t version;
	int8_t level;
	bool lossless;
	bool refining;
	bool still;
};

enum bc_job_kind {
	BC_JOB_INVALID = 0,
	BC_JOB_FRAME,    /* the next frame of a group of members */
	BC_JOB_PICK,     /* one ray: PICK_RESULT */
	BC_JOB_SNAPSHOT, /* a level-0 FRAME answering SNAPSHOT */
	BC_JOB_KIND_COUNT
};

/* One job: a frame for a group of clients sharing a view and holding the
 * same picture of it, or a PICK, or a SNAPSHOT for one client. The worker
 * decides the level and the rectangles (job.c). */
/* A snapshot tile (PROTOCOL.md 7.17): the job's width x height pixels are
 * the window at (x, y) of a full_width x full_height picture. full_width
 * 0: the job's size is the whole picture. */
struct bc_job_window {
	uint32_t x, y, full_width, full_height;
};

struct bc_job_req {
	enum bc_job_kind kind;
	uint32_t session_id;
	struct bc_camera camera;
	uint32_t width, height; /* VIEW size (a tile's, with win) */
	struct bc_job_window win;
	int encoding; /* of stills and snapshots */
	int encoding_interactive;
	int quality_still, quality_interactive;
	uint32_t max_level; /* coarsest level the clients accept */
	/* Finest level an interactive picture starts at (its link is slower
	 * than the renderer: frames.c); at most max_level. */
	uint32_t min_level;
	bool final; /* the interaction is over: refine to the still */
	struct bc_shown shown; /* what the targets hold */
	uint32_t camera_seq;
	/* The session's order, and that of its last change to the scene (a
	 * SESSION_CAMERA takes an order but changes no node): once the copy
	 * holds scene_order, a frame may say order. */
	uint64_t order, scene_order;
	uint32_t frame_no;
	uint32_t seq;            /* PICK's or SNAPSHOT's */
	uint8_t snapshot_planes; /* BC_PROTO_PLANE_* bits */
	uint16_t pick_x, pick_y;
	struct bc_conn_ref targets[BC_PROTO_MAX_MEMBERS];
	/* Each target's own last CAMERA when the job was made: a FRAME
	 * shared by a view group carries, for each, its own (a follower's
	 * is not its presenter's, PROTOCOL.md 5). */
	uint32_t target_camera_seq[BC_PROTO_MAX_MEMBERS];
	uint32_t ntargets;
	/* Each target's H.264 stream when the job's frames are encoding 4
	 * (every target's then, or none's): one render, and each target's
	 * own access unit of it. The job holds a reference to each. */
	struct bc_vstream *video[BC_PROTO_MAX_MEMBERS];
};

enum bc_work_outcome {
	BC_WORK_DONE = 0, /* a frame, or a pick's answer */
	BC_WORK_NOTHING,  /* nothing new to show (a refinement gave way) */
	BC_WORK_TOO_BIG,  /* the frame passes the protocol's payload limit */
	BC_WORK_OOM,      /* out of memory (or over the view cache's cap) */
	BC_WORK_FAILED,   /* the renderer or the encoder failed */
	BC_WORK_DROPPED,  /* retracted, or its session went away */
	BC_WORK_OUTCOME_COUNT
};

/* A finished job, as the options' callback sees it on the loop thread.
 * frame is borrowed: a receiver that keeps it takes a reference. */
struct bc_work_done {
	const struct bc_job *job; /* the handle bc_work_submit returned */
	const struct bc_job_req *req;
	enum bc_work_outcome outcome;
	struct bc_shared *frame;
	struct bc_shown shown; /* what the targets hold after frame */
	bool incomplete;       /* frame says INCOMPLETE */
	bool hit;              /* PICK */
	float position[3], depth;
	uint32_t node;
	double render_ms, encode_ms; /* 0 when nothing was rendered */
	uint64_t order;              /* of the scene the frame shows */
	/* With req.video: target i's FRAME, its stream's access unit (NULL
	 * when it has none: bit i of vfailed says its encoder failed, and
	 * why says how; frame is NULL). Borrowed as frame is. */
	struct bc_shared *vframes[BC_PROTO_MAX_MEMBERS];
	uint64_t vfailed;
	char why[256]; /* as struct bc_errinfo's msg */
	int code;      /* BC_WORK_FAILED: the renderer's or encoder's code */
};

/* Zero means default for every field but the loop and the callback. */
struct bc_work_opts {
	uv_loop_t *loop;
	enum bc_backend backend;
	const char *gl_platform;
	enum bc_simd simd;
	uint32_t workers;   /* render workers; 0: one per core */
	uint32_t budget_ms; /* a refinement step's time; 0: default */
	bool no_damage;     /* edits redraw whole views (to compare) */
	size_t view_cap;    /* bytes of views and renderer state */
	void (*done)(void *ud, const struct bc_work_done *d);
	void *ud;
};

/* Starts the workers. Returns 0, or BC_ENOTSUP (the backend is not built
 * in), BC_ENOMEM, BC_EIO (a thread would not start) with the reason. */
int bc_work_start(struct bc_work **out, const struct bc_work_opts *opts,
                  struct bc_errinfo *ei);

/* Tells the workers to stop at their next slice boundary and waits up to
 * wait_ms for them. Returns true when they stopped: everything is freed,
 * the last of it once the loop has closed the work's handle (run the loop
 * until it returns). False when one is still inside a slice (a renderer
 * call that does not return): nothing is freed and the handle stays open,
 * and the process should exit without waiting (what every session holds is
 * already on disk). Accepts NULL (true). */
bool bc_work_stop(struct bc_work *w, uint32_t wait_ms);

/* ---- The render copy of session sid --------------------------------------
 * Changes reach the copy in the order they were made, between jobs; order
 * is the session's order once a change is applied, what the frames
 * rendered after it report. */

/* Replaces the copy by tree t (taken), dropping every change still queued
 * and every view of the session: a loaded scene, a restored session. With
 * t NULL the copy goes with the renderer's state for it and the views,
 * and no other takes its place (nobody looks at the session: the caller
 * has no job of it queued, and sends a scene before the next); the flow
 * stays, with its share of render time. */
void bc_work_scene(struct bc_work *w, uint32_t sid, struct bc_tree *t,
                   uint64_t order);
/* The states nodes have after a parameter edit (bc_edit_saved of each,
 * copied): a later state of a node replaces an earlier one still queued,
 * so a stream of edits reaches the renderer as the newest value of each
 * node. Returns 0 or BC_ENOMEM (then the copy is out of date: the caller
 * sends bc_work_scene). */
int bc_work_states(struct bc_work *w, uint32_t sid, uint64_t order,
                   const struct bc_edit_saved *states, uint32_t n);
/* A structural batch (copied, subtrees included), replayed on the copy
 * with the edit module's own code. Returns 0 or BC_ENOMEM (as above). */
int bc_work_ops(struct bc_work *w, uint32_t sid, uint64_t order,
                const struct bc_proto_edit_op *ops, uint32_t n);
/* A structural batch queued before the session applies it, so that the
 * copy's splice runs beside the session's: the copy applies it at once,
 * keeping what undoes it, and the session's jobs wait for the verdict,
 * bc_work_settle (one early batch at a time). Returns 0 (also when the
 * session has no copy), or BC_ENOMEM or BC_ELIMIT (the queue is full):
 * nothing was queued, and the batch follows with bc_work_ops once it
 * stands. */
int bc_work_ops_early(struct bc_work *w, uint32_t sid, uint64_t order,
                      const struct bc_proto_edit_op *ops, uint32_t n);
/* The verdict on session sid's early batch: it stands (applied,
 * journaled), or it was refused or undone, and so is undone on the copy.
 * Every early batch gets one. */
void bc_work_settle(struct bc_work *w, uint32_t sid, bool stands);
/* The session is gone: its copy, views and jobs go at the next slice. */
void bc_work_drop(struct bc_work *w, uint32_t sid);

/* ---- Jobs ---------------------------------------------------------------- */

/* Queues a job (O(1)). Returns its handle, valid until the done callback
 * has delivered it or bc_work_retract said it is gone; NULL when out of
 * memory. */
struct bc_job *bc_work_submit(struct bc_work *w, const struct bc_job_req *req);

/* Newer work supersedes job (latest wins). Returns true when the job had
 * not started: it is gone, no callback follows. Otherwise it stops at its
 * next slice boundary when what it does can wait (a refinement step, a
 * retry of rays that ran out, the still), delivered as BC_WORK_NOTHING,
 * or finishes (a first picture, a damage render, a snapshot): its
 * callback follows either way. */
bool bc_work_retract(struct bc_work *w, struct bc_job *job);

/* Nobody wants job any more (its clients left): it goes at its next
 * slice boundary whatever it does. Returns true when it had not started
 * (it is gone, no callback follows); otherwise its callback follows, as
 * BC_WORK_DROPPED. */
bool bc_work_cancel(struct bc_work *w, struct bc_job *job);

/* Whether a job is still waiting for a worker. */
bool bc_work_queued(struct bc_work *w, const struct bc_job *job);

struct bc_work_stats {
	uint32_t workers;
	uint32_t queued, running; /* jobs */
	uint64_t view_bytes, view_cap;
};
void bc_work_stats(struct bc_work *w, struct bc_work_stats *out);
/* Render time spent for session sid since it was loaded, microseconds. */
uint64_t bc_work_session_us(struct bc_work *w, uint32_t sid);

#endif
