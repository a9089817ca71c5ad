/*
 * The sessions layer, as dispatch and main see it: sessions (a scene, its
 * members, undo history, journal and presentation), and the member side
 * of each client (its view, camera and frames), with the handlers of the
 * requests that concern them. Every handler runs on the loop thread and
 * returns quickly: work that takes long (a structural edit of a big scene,
 * loading a session, encoding or saving a big scene) runs on libuv's
 * thread pool while the session is busy, and a request that must keep its
 * place behind that work is parked (BC_PARK): its connection stops
 * reading until the session can take it (link.h's resume).
 */
#ifndef BLOBCAST_SERVER_SESSIONS_H
#define BLOBCAST_SERVER_SESSIONS_H

#include <stdbool.h>
#include <stdio.h>
#include <stdint.h>
#include <uv.h>

#include "blobcast/blobtree.h"
#include "blobcast/proto.h"
#include "link.h"
#include "srv_limits.h"
#include "work.h"

struct bc_sessions;
struct bc_session;
struct bc_store;

/* A handler's answer besides 0: the request waits (its connection reads
 * nothing more until resumed, then the same message comes again). */
#define BC_PARK 1
/* Or: the request was taken and its answer comes when its session's work
 * is done; the connection reads nothing more until then, so its later
 * requests (a PING, say) are answered after it, in order. */
#define BC_HOLD 2

/* A SCENE_LOAD arriving in parts (PROTOCOL.md 7.10.1, edits.c): its
 * pieces as they came, a big one in the reader's buffer it arrived in
 * (handed over, not copied on the loop), small ones gathered in copies.
 * The load's task joins them. */
struct bc_load_piece {
	uint8_t *owned; /* the buffer holding it, freed with it */
	/* Its bytes, in owned: at its start for a copy (which later small
	 * pieces may join), after the message's head in a reader's buffer. */
	const uint8_t *ptr;
	size_t len;
	size_t room; /* a copy's capacity, for the small pieces that join it */
};
struct bc_load_parts {
	bool open; /* a part with MORE came last */
	struct bc_load_piece *v;
	uint32_t n, cap;
	size_t len; /* the scene's bytes so far */
};

/* A client as the sessions layer keeps it (embedded in dispatch's client
 * state; bc_member_init and bc_member_finish bracket its life). */
struct bc_member {
	struct bc_sessions *ss;
	struct bc_peer *peer;
	struct bc_session *session;
	uint32_t member_id;
	bool follows; /* its camera tracks the presenter's (present.c) */
	/* View and frames (frames.c). */
	bool has_view;
	bool has_camera; /* the client sent its own CAMERA */
	struct bc_msg_view view;
	struct bc_camera camera;
	uint32_t camera_seq;
	uint64_t interacting_until; /* ms, loop clock */
	bool dirty;              /* owed a frame: a change, or a finer level */
	struct bc_job *job;      /* its frame job in the work layer, or NULL */
	uint32_t requests;       /* PICKs and SNAPSHOTs queued, unanswered */
	uint32_t answers_unsent; /* SNAPSHOT answers the transport holds */
	struct bc_job *req_jobs[BC_SRV_MAX_CLIENT_REQUESTS]; /* their jobs */
	bool still_sent; /* the last frame sent was the still of now */
	bool frame_out;  /* a frame is being written to it */
	/* Its link (frames.c, link_level): the transport's count of frames
	 * that waited for it when last looked at, the level interactive
	 * frames start at no finer than, and frames since it last grew. */
	uint32_t paced_seen;
	uint32_t link_level, link_calm;
	/* Its H.264 stream (encoding 4; NULL otherwise) and the stream's
	 * bitrate as its link allows (frames.c, video_rate; 0: the
	 * default), with the same counters as the level's. */
	struct bc_vstream *vstream;
	uint32_t video_bps, video_paced_seen, video_calm;
	struct bc_shown shown; /* what its last frame left it holding */
	uint64_t frames;       /* FRAMEs handed to the transport */
	/* Parked behind a busy session (session.c): which, the request's
	 * seq (to answer it when the session's load fails) and the next
	 * member waiting. */
	struct bc_session *parked;
	uint32_t park_seq;
	bool park_again; /* dispatch the request again (not held) */
	struct bc_member *park_next;
	/* A SCENE_LOAD in parts not finished yet (edits.c), and when its
	 * last part came (loop clock, ms). */
	struct bc_load_parts parts;
	uint64_t parts_ms;
};

struct bc_sessions_opts {
	uv_loop_t *loop;
	const struct bc_link *link;
	struct bc_work *work;
	struct bc_store *store;
	bool no_damage;
	size_t max_scene_bytes;  /* 0: BC_SRV_MAX_SCENE_BYTES */
	uint32_t render_idle_ms; /* 0: BC_SRV_RENDER_IDLE_MS */
	/* Scene nodes all loaded sessions may hold together (--scene-memory
	 * over BC_SRV_NODE_COST); 0: no cap. */
	uint64_t scene_nodes;
	/* How H.264 views are encoded: backend and preset (the preset
	 * string must outlive the layer). */
	struct bc_video_opts video;
};

/* Makes the layer and restores every stored session (and "default").
 * Returns 0 or an error. */
int bc_sessions_new(struct bc_sessions **out,
                    const struct bc_sessions_opts *opts, struct bc_errinfo *ei);
/* Snapshots sessions whose journals hold edits, within budget_ms (what
 * is left stays in the journals, which restore it just the same). */
void bc_sessions_save_all(struct bc_sessions *ss, uint32_t budget_ms);
/* Frees everything once the loop has closed its handles (call, then run
 * the loop until it returns). Accepts NULL. */
void bc_sessions_free(struct bc_sessions *ss);

/* blobcastd --check DIR [--repair]: restores every session of data
 * directory dir as a start would, changing nothing, and prints to out one
 * line per session: whole (its last edit), or not whole (why, and how far
 * its files can be read). With repair, a session that is not whole is
 * set aside (its files kept under sessions/.damaged/) and goes on from
 * the best state its files give, at the highest order number they named
 * (the default scene when no snapshot loads). Returns 0 when every
 * session is whole or repaired, 1 when one is not whole, 2 when the
 * directory cannot be read (a running daemon holds it). */
int bc_sessions_check(const char *dir, bool repair, FILE *out);

/* The work layer's callback: a job is done (bc_work_opts.done). */
void bc_sessions_job_done(void *ud, const struct bc_work_done *d);

/* ---- members ------------------------------------------------------------- */

void bc_member_init(struct bc_member *m, struct bc_sessions *ss,
                    struct bc_peer *peer);
/* Leaves its session and forgets its jobs (the connection is closing). */
void bc_member_finish(struct bc_member *m);
/* Its last frame left the transport's queue: it may get the next. */
void bc_member_writable(struct bc_member *m);
/* A SNAPSHOT's answer left the transport's queue (or was dropped with the
 * connection): one more request may be made. */
void bc_member_answered(struct bc_member *m);

/* ---- figures for STATS ---------------------------------------------------- */

struct bc_sessions_stats {
	uint32_t sessions; /* loaded */
	double render_ms_last, render_ms_avg, encode_ms_last, encode_ms_avg;
	/* Scene nodes the loaded sessions hold (with the room changes under
	 * way have taken) and --scene-memory's cap on them. */
	uint64_t nodes_held, nodes_cap;
};
void bc_sessions_stats(const struct bc_sessions *ss,
                       struct bc_sessions_stats *out);
/* The member's session's order, edit time and id (zeros without one). */
uint64_t bc_member_order(const struct bc_member *m);
double bc_member_edit_ms(const struct bc_member *m);
uint32_t bc_member_session_id(const struct bc_member *m);
/* The nodes of the member's session's scene (0 without one, or while it
 * is read from disk). */
uint64_t bc_member_session_nodes(const struct bc_member *m);

/* ---- request handlers (dispatch.c's table) --------------------------------
 * Each returns 0 or BC_PARK; refusals are answered ERROR inside. */

int bc_handle_session(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_leave(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_session_delete(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_session_list(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_scene_load(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_edit(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_undo(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_history(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_camera(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_view(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_pick(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_snapshot(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_present(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_follow(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_session_camera(struct bc_member *m, const struct bc_msg *msg);
int bc_handle_mesh(struct bc_member *m, const struct bc_msg *msg);

#endif
