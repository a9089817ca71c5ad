/*
 * Private state of blobcastd, shared by its parts:
 *  - net.c: the libuv loop thread: connections (struct bc_conn, the
 *    daemon's own; libblobcast's struct bc_client is the client side), the
 *    protocol state machine, output queues with frame spoiling;
 *  - listen.c: the listeners, accepting connections;
 *  - session.c: session lifecycle, members, the message -> handler table;
 *  - edits.c: EDIT and SCENE_LOAD (the edit module applies, the journal
 *    keeps, EDIT_APPLIED broadcasts);
 *  - frames.c: frame scheduling and CAMERA, VIEW, PICK, SNAPSHOT;
 *  - rthread.c: the render thread: a replica of each session's scene, the
 *    renderer, encoding (render_job.c, views.c); results come back to the
 *    loop through a uv_async;
 *  - main.c: options, configuration, start-up, shutdown.
 * Everything except rthread.c runs on the loop thread.
 */
#ifndef BLOBCAST_SERVER_SERVER_H
#define BLOBCAST_SERVER_SERVER_H

#include <stdbool.h>
#include <stdint.h>
#include <uv.h>

#include "blobcast/blobtree.h"
#include "blobcast/proto.h"
#include "blobcast/render.h"
#include "srv_limits.h"
#include "store.h"

struct bc_srv;
struct bc_session;
struct bc_rthread;

/* A reference-counted byte buffer: one encoded FRAME shared by every client
 * of a view group. */
struct bc_shared {
	uint32_t refs;
	size_t len;
	uint8_t data[];
};
struct bc_shared *bc_shared_new(size_t len);
void bc_shared_unref(struct bc_shared *s);

/* A connection handle that survives the connection: stale ones (another
 * generation) are refused. */
struct bc_conn_ref {
	uint32_t slot, gen;
};

struct bc_token {
	char *token;
	enum bc_proto_role role; /* the highest role it grants */
};

struct bc_srv_config {
	char *listen; /* HOST:PORT, NULL = none */
	char *unix_path;
	char *data_dir;
	enum bc_backend backend;
	char *gl_platform;
	char *server_id;
	struct bc_token *tokens;
	uint32_t ntokens;
	enum bc_simd simd;
	bool no_damage; /* edits re-render whole views (for comparison) */
	uint32_t frame_budget_ms;    /* 0: BC_SRV_FRAME_BUDGET_MS */
	uint32_t message_timeout_ms; /* 0: BC_SRV_MESSAGE_TIMEOUT_MS */
	uint32_t idle_timeout_ms;    /* 0: BC_SRV_IDLE_TIMEOUT_MS */
	char *tls_cert, *tls_key;    /* PEM files: TLS on the TCP listener */
	bool allow_plaintext; /* tokens may cross a non-loopback plain TCP */
};

/* What a client holds of a view after a frame (set by the render thread,
 * kept by the loop): the view's id (0: nothing), its version, the level of
 * the picture, whether every pixel came losslessly, whether finer levels
 * will follow, and whether the frame was the still. */
struct bc_shown {
	uint32_t view;
	uint32_t version;
	int8_t level;
	bool lossless;
	bool refining;
	bool still;
};

struct bc_conn {
	struct bc_srv *srv;
	uint32_t slot, gen;
	union {
		uv_tcp_t tcp;
		uv_pipe_t pipe;
		uv_stream_t stream;
		uv_handle_t handle;
	} h;
	uv_timer_t hello_timer;
	struct bc_tls *tls;   /* TLS state (tls.h) on a TLS listener, or NULL */
	bool is_tcp, trusted; /* trusted: loopback TCP or Unix socket */
	bool closing;
	bool draining; /* shut down after the queued bytes are written */
	uv_shutdown_t shutdown;
	const char *drain_why;
	uint32_t handles_open;
	struct bc_proto_reader reader;
	enum bc_proto_stage stage;
	enum bc_proto_role max_role; /* from the token */
	enum bc_proto_role role;
	char name[BC_PROTO_MAX_NAME + 1];
	uint8_t encodings;
	uint32_t max_frame_bytes;

	struct bc_session *session;
	uint32_t member_id;
	/* Presentation (present.c): the client has sent a type of 28 or more
	 * (PRESENT, FOLLOW, SESSION_CAMERA), so it is sent PRESENTER,
	 * FOLLOW_CAMERA and SESSION_CAMERA_SET; it follows the presenter. */
	bool knows_present;
	bool follows;

	/* View and frames. */
	bool has_view;
	bool has_camera; /* the client sent its own CAMERA */
	struct bc_msg_view view;
	struct bc_camera camera;
	uint32_t camera_seq;
	uint64_t interacting_until; /* ms, loop clock */
	bool dirty;            /* owed a frame: a change, or a finer level */
	bool render_pending;   /* a job for this client is queued */
	uint32_t requests;     /* PICKs and SNAPSHOTs queued, unanswered */
	bool still_sent;       /* the last frame sent was the still of now */
	struct bc_shown shown; /* what its last frame left it holding */

	/* Output: messages go out at once; frames one at a time. */
	size_t queued;
	bool frame_writing;
	uint64_t frame_started_ms;
	struct bc_shared *frame_next;
	uint32_t frame_no; /* FRAMEs written to this client */
	/* Timeouts (loop clock, ms): when the first byte of a message still
	 * incomplete arrived (0: none pending), and when the last bytes did. */
	uint64_t msg_started_ms, last_read_ms;
	uint64_t frames_sent, bytes_sent, frames_spoiled;
	uint64_t first_frame_ms;
};

struct bc_session {
	struct bc_srv *srv;
	uint32_t id;
	char name[BC_PROTO_MAX_NAME + 1];
	struct bc_tree *tree;
	struct bc_camera
	    camera; /* the scene's camera: new members start here */
	uint64_t order;
	struct bc_store_session *store;
	bool store_failed; /* a write failed: edits are refused */
	struct bc_conn_ref members[BC_PROTO_MAX_MEMBERS];
	uint32_t nmembers;
	uint32_t next_member_id;
	uv_timer_t still_timer;
	uv_timer_t kick; /* schedules frames once a loop turn's writes end */
	uint64_t empty_since_ms; /* loop clock; when the last member left */
	bool loading;          /* a SCENE_LOAD runs on a worker: changes wait */
	uint64_t last_edit_ms; /* Unix ms of its last change (0: unknown) */
	struct bc_undo *undo;  /* undo/redo history (undo.c), or NULL */
	/* The member presenting (present.c): its id, 0 when nobody does. */
	uint32_t presenter_id;
	struct bc_conn_ref presenter;
	bool removed; /* out of the server, freed once its handles close */
	uint32_t handles_open; /* timers and a load's work request */
	double edit_ms_avg;
};

/* A session not in memory, as SESSIONS lists it. */
struct bc_session_summary {
	char name[BC_PROTO_MAX_NAME + 1];
	uint32_t prims;
	uint64_t order, last_edit_ms;
};

struct bc_srv {
	uv_loop_t *loop;
	struct bc_srv_config cfg;
	struct bc_store *store;
	uv_tcp_t tcp_listener;
	uv_pipe_t unix_listener;
	bool has_tcp, has_unix;
	struct bc_tls_ctx *tls; /* certificate and key, or NULL: plain TCP */
	uv_signal_t sigterm, sigint;
	uv_timer_t stall_timer; /* drops clients that stopped reading */
	uv_async_t results;
	uv_timer_t job_sweep; /* drops queued jobs of clients that left */
	struct bc_rthread *rt;

	struct bc_conn *clients[BC_SRV_MAX_CONNECTIONS];
	uint32_t gens[BC_SRV_MAX_CONNECTIONS];
	uint32_t nclients;
	uint32_t next_conn_id;

	struct bc_session *sessions[BC_SRV_MAX_SESSIONS];
	uint32_t nsessions;
	uv_timer_t session_sweep; /* unloads sessions idle without members */
	/* What SESSIONS says of sessions unloaded since the start. */
	struct bc_session_summary *unloaded;
	uint32_t nunloaded, unloaded_cap;
	uint32_t next_session_id;

	uint64_t started_ms;
	uint32_t frame_no;
	bool stopping;
	/* Render statistics, from the render thread's results. */
	double render_ms_last, render_ms_avg, encode_ms_last, encode_ms_avg;
};

/* ---- listen.c ----------------------------------------------------------- */
int bc_net_listen(struct bc_srv *srv, struct bc_errinfo *ei);

/* ---- net.c -------------------------------------------------------------- */
struct bc_conn *bc_conn_get(struct bc_srv *srv, struct bc_conn_ref ref);
struct bc_conn_ref bc_conn_ref_of(const struct bc_conn *c);
/* Encodes and queues m; on failure the client is closed. */
void bc_conn_send(struct bc_conn *c, const struct bc_msg *m);
void bc_conn_send_error(struct bc_conn *c, uint32_t seq, int code, bool fatal,
                        const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));
/* Queues a FRAME (spoiling an unsent older one). */
void bc_conn_send_frame(struct bc_conn *c, struct bc_shared *frame);
void bc_conn_close(struct bc_conn *c, const char *why);
/* Stops reading, lets queued bytes (an ERROR) go out, then closes. */
void bc_conn_close_after_flush(struct bc_conn *c, const char *why);
uint64_t bc_now_ms(struct bc_srv *srv);
void bc_net_close_all(struct bc_srv *srv);

/* ---- session.c ---------------------------------------------------------- */
int bc_sessions_restore(struct bc_srv *srv, struct bc_errinfo *ei);
void bc_sessions_save_all(struct bc_srv *srv);
void bc_sessions_free(struct bc_srv *srv);
/* Dispatches a message from a client in stage READY or SESSION. */
void bc_session_handle(struct bc_conn *c, const struct bc_msg *m);
void bc_session_leave(struct bc_conn *c);
/* Copies the session's member handles into out (BC_PROTO_MAX_MEMBERS
 * entries) and returns their count. Loops that send iterate the copy: a
 * send can drop a member (its queue overflowed), which reorders
 * s->members under the loop and would skip the member moved into its
 * place. */
uint32_t bc_session_members(const struct bc_session *s,
                            struct bc_conn_ref *out);
/* c's frame backlog cleared: render for it again if it is owed a frame. */
void bc_session_client_ready(struct bc_conn *c);
/* A render job could not run for lack of memory: its PICK or SNAPSHOT is
 * answered ERROR ENOMEM; clients owed a frame stay owed, and the session
 * retries after BC_SRV_OOM_RETRY_MS. */
struct bc_rjob;
void bc_session_frame_failed(struct bc_srv *srv, const struct bc_rjob *job);
/* A render job for these clients finished: schedule what is still owed. */
void bc_session_frame_done(struct bc_srv *srv, uint32_t session_id,
                           const struct bc_conn_ref *targets, uint32_t n);
struct bc_session *bc_session_by_id(struct bc_srv *srv, uint32_t id);
void bc_session_send_info(struct bc_session *s);
/* SCENE_STATE to one member (to) or, with to NULL, to every member. */
void bc_session_send_state(struct bc_session *s, struct bc_conn *to,
                           uint32_t author, uint32_t author_seq);
/* The same with the scene already encoded (bc_scene_encode of s->tree). */
void bc_session_send_state_bytes(struct bc_session *s, struct bc_conn *to,
                                 uint32_t author, uint32_t author_seq,
                                 const uint8_t *bytes, size_t len);
/* Frees s once nothing refers to it (its timers and a load in flight). */
void bc_session_unref(struct bc_session *s);
/* Every member's next frame is whole. */
void bc_session_mark_all(struct bc_session *s);
void bc_handle_session(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_stats(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_session_delete(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_session_list(struct bc_conn *c, const struct bc_msg *m);
/* Unix time now, milliseconds. */
uint64_t bc_unix_ms(void);

/* ---- edits.c ------------------------------------------------------------ */
void bc_handle_scene_load(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_edit(struct bc_conn *c, const struct bc_msg *m);
/* UNDO and REDO. */
void bc_handle_undo(struct bc_conn *c, const struct bc_msg *m);

/* How an applied change presents itself in its EDIT_APPLIED. */
struct bc_change {
	uint16_t flags;        /* BC_PROTO_FLAG_INTERACTING, _UNDO or _REDO */
	uint64_t target_order; /* UNDO, REDO: the edit undone or redone */
	const char *target_author; /* and its author's name */
};
struct bc_edit_batch;
/* Applies ops from member c (its request seq) to c's session as one batch:
 * checked, journaled and synced, then broadcast as EDIT_APPLIED and passed
 * to the render thread. Returns 0 with b holding what undoes the batch
 * (the caller finishes it), or an error in ei with nothing changed. */
int bc_session_apply(struct bc_conn *c, const struct bc_proto_edit_op *ops,
                     uint16_t nops, uint32_t seq, const struct bc_change *how,
                     struct bc_edit_batch *b, struct bc_errinfo *ei);

/* ---- undo.c ------------------------------------------------------------- */
/* Records what undoes batch b, just applied by c (takes b's old tree);
 * clears the redo steps. Edits of one drag (interacting, up to the first
 * edit without it) make one step. */
void bc_undo_record(struct bc_conn *c, struct bc_edit_batch *b,
                    bool interacting);
/* UNDO (or REDO) from c, request seq: applies the newest step back as an
 * edit, or answers ERROR ESTATE when there is none. */
void bc_undo_step(struct bc_conn *c, bool redo, uint32_t seq);
/* Forgets s's history (a new scene, or s going away). */
void bc_undo_clear(struct bc_session *s);

/* ---- present.c ---------------------------------------------------------- */
void bc_handle_present(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_follow(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_session_camera(struct bc_conn *c, const struct bc_msg *m);
/* c's own CAMERA was applied (flags: the CAMERA's): a follower stops
 * following; the presenter's followers take its camera. */
void bc_present_camera_moved(struct bc_conn *c, uint16_t flags);
/* c leaves its session: a presenter's presentation ends for everyone. */
void bc_present_leave(struct bc_conn *c);
/* c joined its session: tells it who presents (when it knows the types). */
void bc_present_joined(struct bc_conn *c);
/* A journal record that sets the session camera: two zero bytes (an
 * op_count no EDIT has) and the SESSION_CAMERA payload. Returns 1 and
 * fills *cam when rec is one (0 when it is an EDIT, an error code when it
 * is a damaged camera record). */
int bc_present_camera_record(const uint8_t *rec, size_t len,
                             struct bc_camera *cam);

/* ---- frames.c ----------------------------------------------------------- */
/* Starts a render for every member owed a frame (grouping equal ones). */
void bc_session_schedule(struct bc_session *s);
void bc_handle_camera(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_view(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_pick(struct bc_conn *c, const struct bc_msg *m);
void bc_handle_snapshot(struct bc_conn *c, const struct bc_msg *m);

/* ---- rthread.c ---------------------------------------------------------- */

/* One frame to render for a group of clients sharing a view and holding
 * the same picture of it. The render thread decides the level and the
 * rectangles (see rthread.c). */
struct bc_rjob {
	uint32_t session_id;
	struct bc_camera camera;
	uint32_t width, height; /* VIEW size */
	int encoding;           /* of stills and snapshots */
	int encoding_interactive;
	int quality_still, quality_interactive;
	uint32_t max_level; /* coarsest level the clients accept */
	bool final;         /* the interaction is over: refine to the still */
	struct bc_shown shown; /* what the targets hold */
	uint32_t camera_seq;
	uint64_t order;
	uint32_t frame_no;
	uint32_t snapshot_seq;   /* != 0: answer to a SNAPSHOT */
	uint8_t snapshot_planes; /* its BC_PROTO_PLANE_* bits */
	struct bc_conn_ref *targets;
	uint32_t ntargets;
	/* PICK: answer one ray instead of a frame. */
	bool pick;
	uint16_t pick_x, pick_y;
	uint32_t pick_seq;
};

int bc_rthread_start(struct bc_srv *srv, struct bc_errinfo *ei);
void bc_rthread_stop(struct bc_srv *srv);
/* Each takes ownership of its argument. */
void bc_rthread_scene(struct bc_srv *srv, uint32_t session_id,
                      struct bc_tree *copy);
void bc_rthread_set_prim(struct bc_srv *srv, uint32_t session_id, uint32_t id,
                         const struct bc_prim_data *p);
void bc_rthread_set_op(struct bc_srv *srv, uint32_t session_id, uint32_t id,
                       const struct bc_op_data *op);
void bc_rthread_drop(struct bc_srv *srv, uint32_t session_id);
void bc_rthread_job(struct bc_srv *srv, struct bc_rjob *job);
/* Soon (next loop turn, once a closing connection is gone): removes from
 * the render queue every job none of whose clients is still connected. */
void bc_rthread_sweep_soon(struct bc_srv *srv);
/* Called on the loop thread by the results async. */
void bc_rthread_deliver(uv_async_t *async);

#endif
