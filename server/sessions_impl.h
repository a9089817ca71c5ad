/*
 * The sessions layer's private types, shared by its files:
 *  - session.c: the table of loaded sessions, loading (on a task),
 *    unloading when idle, restore at start, saving, deleting, tasks and
 *    parking (a busy session's requests wait);
 *  - members.c: members joining and leaving, SESSION_INFO, SCENE_STATE;
 *  - index.c: every session on disk, with what SESSION_LIST says of it;
 *  - frames.c: which member is owed a frame and when, the jobs that make
 *    them, CAMERA, VIEW, PICK and SNAPSHOT, and the work layer's results;
 *  - edits.c: EDIT and SCENE_LOAD: applied, journaled, broadcast;
 *  - undo.c: each session's undo and redo history;
 *  - present.c: presenting, following, the session camera.
 */
#ifndef BLOBCAST_SERVER_SESSIONS_IMPL_H
#define BLOBCAST_SERVER_SESSIONS_IMPL_H

#include "blobcast/edit.h"
#include "sessions.h"
#include "srv_limits.h"
#include "store.h"

struct bc_index;

struct bc_session {
	struct bc_sessions *ss;
	uint32_t id;
	char name[BC_PROTO_MAX_NAME + 1];
	struct bc_tree *tree; /* NULL while it loads */
	struct bc_camera
	    camera; /* the scene's camera: new members start here */
	uint64_t order;
	uint64_t scene_order; /* of the last change to the scene's nodes */
	struct bc_store_session *store;
	bool store_failed; /* a write failed: edits are refused */
	/* Out of memory taking back a refused change left the tree unlike
	 * what the journal holds (bc_edit_batch's lost): edits and joins are
	 * refused, no snapshot is written, and once the last member has
	 * left the session is unloaded, to load again from what it saved. A
	 * scene loaded over it ends that. */
	bool lost;
	/* The work layer holds a render copy of the tree (frames.c,
	 * bc__session_copy): made when a member first wants a picture, not
	 * at the load, so a session nobody looks at keeps its tree alone.
	 * copying: a task makes it (the session busy); copy_rc: why the
	 * last one failed, told once. */
	bool copied, copying;
	int copy_rc;
	/* Loop clock: when a member last had a view or wanted a picture.
	 * The copy goes once nobody has for ss->render_idle_ms
	 * (bc__session_copy_idle). */
	uint64_t looked_ms;
	struct bc_member *members[BC_PROTO_MAX_MEMBERS];
	uint32_t nmembers;
	uint32_t next_member_id;
	uv_timer_t still_timer;
	uv_timer_t kick; /* schedules frames once a loop turn's writes end */
	uint64_t empty_since_ms; /* loop clock; when the last member left */
	uint64_t last_edit_ms;   /* Unix ms of its last change (0: unknown) */
	struct bc_undo *undo;    /* undo/redo history (undo.c), or NULL */
	/* The client name of the member whose SESSION_CREATE made it (kept
	 * in its directory); "" when the server made it or the creator had
	 * no name. It may undo anyone's change (PROTOCOL.md 7.20). */
	char owner[BC_PROTO_MAX_NAME + 1];
	/* The member presenting (present.c): its id, 0 when nobody does. */
	uint32_t presenter_id;
	struct bc_member *presenter;
	bool removed; /* out of the table, freed once its handles close */
	uint32_t handles_open; /* timers and tasks in flight */
	double edit_ms_avg;
	/* Work on the thread pool that the order of its changes must wait
	 * for (a load, a big structural edit, a snapshot, an encode), and
	 * the members whose requests wait meanwhile, in order. */
	uint32_t busy;
	struct bc_member *park_head, *park_tail;
	/* Made by a SESSION_CREATE that waits for its load: that request,
	 * dispatched again, joins instead of finding the name taken. */
	struct bc_conn_ref creator;
	/* SCENE_STATE of a big scene, encoded on a task for joiners, while
	 * the order stays state_order and it was last sent (loop clock,
	 * state_used_ms) less than ss->render_idle_ms ago
	 * (bc__session_state_idle): about 51 bytes a primitive. */
	struct bc_shared *state_msg;
	uint64_t state_order;
	uint64_t state_used_ms;
	/* When a SESSION_CAMERA or a change made only of NAMEs last sent
	 * members of an older protocol the whole scene (loop clock;
	 * bc__state_limit). */
	uint64_t camera_state_ms;
	/* The nodes of its tree that ss->nodes_held counts (bc__room_*). */
	uint64_t nodes;
};

struct bc_sessions {
	uv_loop_t *loop;
	const struct bc_link *link;
	struct bc_work *work;
	struct bc_store *store;
	bool no_damage;
	size_t max_scene_bytes;  /* SCENE_STATE payload (--max-scene) */
	uint32_t render_idle_ms; /* render copies unused this long go */
	size_t parts_bytes;      /* of every member's unfinished SCENE_LOAD */
	/* Scene nodes all loaded sessions may hold together (--scene-memory),
	 * and those they hold with what changes under way have taken. */
	uint64_t nodes_cap, nodes_held;
	bool starting; /* restoring at start-up: nothing is unloaded */
	struct bc_video_opts video;
	struct bc_session *sessions[BC_SRV_MAX_SESSIONS];
	uint32_t nsessions;
	uint32_t next_session_id;
	struct bc_member *by_slot[BC_SRV_MAX_CONNECTIONS];
	uv_timer_t sweep; /* unloads sessions idle without members */
	struct bc_index *index;
	uint32_t frame_no;
	double render_ms_last, render_ms_avg, encode_ms_last, encode_ms_avg;
	bool stopping;
	struct bc_meshes *meshes; /* MESH (meshes.c), made when first asked */
};

/* Work for a session on libuv's thread pool: run off the loop, done on it
 * (where the session may have been removed meanwhile: s->removed). */
struct bc_task {
	uv_work_t req;
	struct bc_session *s;
	bool holds_order; /* the session is busy while it runs */
	void (*run)(struct bc_task *t);
	void (*done)(struct bc_task *t);
};

/* ---- session.c ---- */

/* Room for scenes (--scene-memory; docs/operations.md). A change that
 * leaves s with at most `after` nodes takes room for what it adds before
 * it starts: sessions without members are unloaded for it, the longest
 * without first, while the loaded sessions' nodes would pass the cap.
 * Sets *taken (settled once the change is s's, or given back). Returns 0
 * or BC_ELIMIT (ei says why and what to do). Loop only. */
int bc__room_take(struct bc_session *s, uint64_t after, uint64_t *taken,
                  struct bc_errinfo *ei);
/* The session whose work under way keeps back the room a change of s to
 * `after` nodes needs: a session without members, busy (a snapshot, an
 * edit its last member left running), that can be unloaded once that work
 * ends, and whose nodes with those of the sessions idle already make the
 * room. The request parks behind it (bc__park) and takes the room when it
 * comes again, instead of a refusal a second too early. NULL where the room
 * is there now, or would not be even so (bc__room_take then says why). */
struct bc_session *bc__room_busy(struct bc_session *s, uint64_t after);
/* Whether any session's room comes free when its work ends (the cheap
 * test before counting a change's nodes for bc__room_busy). */
bool bc__room_finishing(const struct bc_session *s);
/* Whether m's change ops (an EDIT's, or an UNDO's or REDO's, request seq)
 * must wait for the room a session's work holds (bc__room_busy): then
 * it is parked behind that work (the log says so, naming the change
 * `what`) and this returns BC_PARK; else 0. */
int bc__change_waits(struct bc_member *m, const struct bc_proto_edit_op *ops,
                     uint32_t nops, uint32_t seq, const char *what);
void bc__room_give(struct bc_sessions *ss, uint64_t *taken);
/* s->tree is its scene now: the count follows it, taken given back. */
void bc__room_settle(struct bc_session *s, uint64_t *taken);

uint64_t bc__now_ms(const struct bc_sessions *ss);
uint64_t bc__unix_ms(void);
struct bc_session *bc__session_by_name(struct bc_sessions *ss, const char *name,
                                       size_t len);
struct bc_session *bc__session_by_id(struct bc_sessions *ss, uint32_t id);
/* The member of connection ref, or NULL. */
struct bc_member *bc__member_of(struct bc_sessions *ss, struct bc_conn_ref ref);
/* Frees t (NULL: nothing), on libuv's thread pool when it is big: a scene
 * of 600 000 nodes takes 20 ms to free, which the loop must not wait for
 * (Redis frees big values in the background alike). */
void bc__tree_free_later(uv_loop_t *loop, struct bc_tree *t);
/* Starts t (the caller filled run and done); holds_order makes s busy. */
void bc__task_start(struct bc_session *s, struct bc_task *t);
/* m's request seq waits for s: returns BC_PARK. */
int bc__park(struct bc_session *s, struct bc_member *m, uint32_t seq);
/* m's request seq was taken by work of s: m reads nothing more until that
 * work is done. Returns BC_HOLD. */
int bc__hold(struct bc_session *s, struct bc_member *m, uint32_t seq);
/* m leaves whatever queue it waits in (its connection closes). */
void bc__unpark(struct bc_member *m);
/* Frees s once nothing refers to it (its timers and tasks). */
void bc__session_unref(struct bc_session *s);
/* Its snapshot on a task, when the journal says one is due. */
void bc__session_snapshot_due(struct bc_session *s);
/* The session's scene changed: SCENE_STATEs encoded before go. */
void bc__session_changed(struct bc_session *s);
/* Unloads s when it has no members and nothing waits; true if it did. */
bool bc__session_unload(struct bc_session *s, const char *why);

/* ---- meshes.c ---- */

/* Stops the meshing thread (a mesh under way stops) and drops the meshes
 * not answered yet. */
void bc__meshes_free(struct bc_sessions *ss);

/* ---- members.c ---- */

/* Copies s's members into out (BC_PROTO_MAX_MEMBERS) and returns their
 * count: loops that send iterate the copy, since a send can drop a member
 * (its queue overflowed), which reorders s->members under the loop. */
uint32_t bc__members(const struct bc_session *s, struct bc_member **out);
void bc__send(struct bc_member *m, const struct bc_msg *msg);
void bc__send_error(struct bc_member *m, uint32_t seq, int code,
                    const char *fmt, ...) __attribute__((format(printf, 4, 5)));
void bc__send_info(struct bc_session *s);
/* A SCENE_STATE of tree t and camera cam at order, encoded whole (any
 * thread), or NULL when out of memory. */
struct bc_shared *bc__state_msg(const struct bc_tree *t,
                                const struct bc_camera *cam, uint64_t order,
                                uint32_t author, uint32_t author_seq);
/* msg, a SCENE_STATE, to one member (to) or, with to NULL, to every
 * member: one encoding, queued by reference. */
void bc__send_state_msg(struct bc_session *s, struct bc_member *to,
                        struct bc_shared *msg);
/* A change that members of an older protocol (old: s has some) receive as
 * the whole SCENE_STATE is taken once per BC_SRV_CAMERA_STATE_MS
 * (PROTOCOL.md 7.12, 7.25): returns 0 (and notes the time), or BC_EBUSY
 * in ei saying "<what> at most once in ...". */
int bc__state_limit(struct bc_session *s, bool old, const char *what,
                    struct bc_errinfo *ei);
/* s's SCENE_STATE, encoded here, to one member or every one. */
void bc__send_state(struct bc_session *s, struct bc_member *to, uint32_t author,
                    uint32_t author_seq);
void bc__leave(struct bc_member *m);
/* Drops m's unfinished SCENE_LOAD in parts, if any (edits.c). */
void bc__parts_drop(struct bc_member *m);
/* Drops the SCENE_STATE s keeps for joiners once none has been sent it
 * for ss->render_idle_ms. Returns true when it did. */
bool bc__session_state_idle(struct bc_session *s, uint64_t now);
/* m joins s (its role asked, its request seq). Returns 0 or BC_PARK. */
int bc__join(struct bc_member *m, struct bc_session *s, enum bc_proto_role role,
             uint32_t seq);
/* Every member's next frame is whole. */
void bc__mark_all(struct bc_session *s);

/* ---- index.c ---- */

/* What SESSION_LIST says of a session on disk. */
struct bc_index_entry {
	char name[BC_PROTO_MAX_NAME + 1];
	struct bc_session *loaded; /* NULL when on disk only */
	bool known;                /* the figures below are known */
	uint32_t prims;
	uint64_t order, last_edit_ms;
};
int bc__index_new(struct bc_index **out, struct bc_store *store);
void bc__index_free(struct bc_index *ix);
/* The entry of name, or NULL. */
struct bc_index_entry *bc__index_get(struct bc_index *ix, const char *name);
/* Adds name (sorted), or returns its entry. NULL when out of memory. */
struct bc_index_entry *bc__index_add(struct bc_index *ix, const char *name);
void bc__index_remove(struct bc_index *ix, const char *name);
uint32_t bc__index_count(const struct bc_index *ix);
/* Entry i in name order. */
struct bc_index_entry *bc__index_at(struct bc_index *ix, uint32_t i);
/* Keeps what is known of s as it unloads or changes. */
void bc__index_note(struct bc_index *ix, const struct bc_session *s);

/* ---- frames.c ---- */

/* Starts a job for every member owed a frame (grouping equal ones). */
void bc__schedule(struct bc_session *s);
/* Makes sure the work layer holds s's render copy: 0 when it does (made
 * now, on the loop, for a scene under BC_SRV_HEAVY_NODES), BC_PARK while
 * a task makes it (the session busy until then) or while another task
 * holds the session (the copy is made after it), or the error of the
 * last copy that failed (BC_ENOMEM), said once. */
int bc__session_copy(struct bc_session *s);
/* Drops s's render copy when nobody has looked at s for render_idle_ms
 * (no member has a view, a frame job, a PICK or a SNAPSHOT queued) and
 * s is not busy. Returns true when it did. */
bool bc__session_copy_idle(struct bc_session *s, uint64_t now);
/* m's state changed in a way its queued frame does not show: the job is
 * retracted (latest wins) and m is owed a new one. */
void bc__owe_frame(struct bc_member *m);
/* Forgets m's jobs (it leaves its session or closes). */
void bc__frames_forget(struct bc_member *m);

/* ---- edits.c ---- */

/* How an applied change presents itself in its EDIT_APPLIED, and what
 * its journal record says of it. */
struct bc_change {
	uint16_t flags;        /* BC_PROTO_FLAG_INTERACTING, _UNDO or _REDO */
	uint8_t kind;          /* BC_UNDO_*; 0: an edit */
	uint64_t time_ms;      /* when it applied, Unix ms (set by bc__apply) */
	uint64_t target_order; /* UNDO, REDO: the edit undone or redone */
	char target_author[BC_PROTO_MAX_NAME + 1]; /* and its author */
};
/* Who made a change (kept across a task: the member may be gone). */
struct bc_author {
	struct bc_conn_ref ref;
	uint32_t member_id, seq;
	char name[BC_PROTO_MAX_NAME + 1];
};
/* Called once a batch (operations ops) is applied, journaled and
 * broadcast, with b holding what undoes it (the callee may take its old
 * tree; the caller finishes b). */
typedef void (*bc_applied_fn)(struct bc_session *s, const struct bc_author *a,
                              const struct bc_change *how,
                              struct bc_edit_batch *b,
                              const struct bc_proto_edit_op *ops, uint32_t nops,
                              void *ud);
/* Applies ops from member m (request seq) to m's session as one batch:
 * checked, journaled and synced, then broadcast as EDIT_APPLIED, passed
 * to the work layer, and handed to done. The sync (and for a big scene,
 * BC_SRV_HEAVY_NODES, a structural batch itself) runs on a task, the
 * session busy meanwhile. Returns 1 (done follows, or the author hears
 * the error), or an error in ei with nothing changed. */
int bc__apply(struct bc_member *m, const struct bc_proto_edit_op *ops,
              uint16_t nops, uint32_t seq, const struct bc_change *how,
              bc_applied_fn done, void *ud, struct bc_errinfo *ei);
/* Whether m's session refuses changes (answered to m with seq), or the
 * request must wait for it (*park set). */
bool bc__refuse_change(struct bc_member *m, uint32_t seq, int *park);

/* ---- undo.c ---- */

struct bc_undo;
/* Who owns a change: a client name, or for a member without one its
 * member id while it is connected (0: nobody). */
struct bc_undo_who {
	const char *name;
	uint32_t member;
};
/* What a change did to the history: an edit, or an undo or redo of the
 * step of edit target. */
enum { BC_UNDO_EDIT = 1, BC_UNDO_UNDO = 2, BC_UNDO_REDO = 3 };
struct bc_undo_change {
	uint8_t kind;
	bool interacting; /* an edit of a drag (INTERACTING) */
	uint64_t order;   /* the change's own order number */
	uint64_t target;  /* UNDO, REDO: the step's order */
	uint64_t time_ms;
	const char *name; /* who made it */
	uint32_t member;
	const struct bc_proto_edit_op *ops; /* the change's operations */
	uint32_t nops;
	/* The scene after it (names parameters in the history), or NULL. */
	const struct bc_tree *tree;
};
/* A history record read back from the journal (bc__undo_record_parse):
 * the change and its EDIT payloads, pointing into the record. */
struct bc_undo_record {
	uint8_t kind;
	bool interacting;
	uint64_t time_ms, target;
	uint32_t member;
	uint16_t name_len;
	char name[BC_PROTO_MAX_NAME + 1];
	const uint8_t *fwd, *inv; /* inv NULL: a parameter change */
	uint32_t fwd_len, inv_len;
};

struct bc_undo *bc__undo_new(void);
void bc__undo_free(struct bc_undo *u);
/* The history change c makes: b (the batch applied) holds the saved
 * states of a parameter change; inv[0..ninv) undoes a structural one.
 * Returns 0 or BC_ENOMEM (the history is then not whole: drop it). */
int bc__undo_note(struct bc_undo *u, const struct bc_undo_change *c,
                  const struct bc_edit_batch *b,
                  const struct bc_proto_edit_op *inv, uint32_t ninv);
/* A restored history: member ids of the run before mean nothing now. */
void bc__undo_restored(struct bc_undo *u);
/* Whether a change by (author, member) is who's. */
bool bc__undo_owns(const char *author, uint32_t member,
                   const struct bc_undo_who *who);
/* The history's view of a change a made (its operations ops), now
 * applied at s->order. */
struct bc_undo_change bc__undo_change_of(const struct bc_session *s,
                                         const struct bc_author *a,
                                         const struct bc_change *how,
                                         const struct bc_proto_edit_op *ops,
                                         uint32_t nops);
/* A bc_applied_fn: the history takes what undoes an applied EDIT, UNDO or
 * REDO (how->kind). */
void bc__undo_applied(struct bc_session *s, const struct bc_author *a,
                      const struct bc_change *how, struct bc_edit_batch *b,
                      const struct bc_proto_edit_op *ops, uint32_t nops,
                      void *ud);
/* The live form of bc__undo_note for s (takes b's old tree to free off
 * the loop); a failure drops the history, logged. */
void bc__undo_record(struct bc_session *s, const struct bc_undo_change *c,
                     struct bc_edit_batch *b);
/* UNDO (or REDO) of scope (BC_PROTO_UNDO_*) from m, request seq.
 * Returns 0 or BC_HOLD. */
int bc__undo_step(struct bc_member *m, bool redo, uint8_t scope, uint32_t seq);
/* HISTORY_GET from m: answers HISTORY. Returns 0. */
int bc__undo_history(struct bc_member *m, uint32_t seq);
/* Forgets s's history (a new scene, or s going away). */
void bc__undo_clear(struct bc_session *s);
/* The journal record of change c (its operations, and inv that undoes
 * a structural one) into out. Returns 0 or an error in ei. */
int bc__undo_record_encode(struct bc_proto_buf *out,
                           const struct bc_undo_change *c,
                           const struct bc_proto_edit_op *inv, uint32_t ninv,
                           struct bc_errinfo *ei);
/* The history in the form a snapshot carries (history-N.bin): *out
 * (bc_free) and *len, NULL and 0 for an empty one; t is the scene now.
 * Returns 0 or BC_ENOMEM. */
int bc__undo_carry(const struct bc_undo *u, const struct bc_tree *t,
                   uint8_t **out, size_t *len);
/* u becomes the history p[0..len) carries; bytes that do not hold one
 * leave it empty and return an error. */
int bc__undo_uncarry(struct bc_undo *u, const uint8_t *p, size_t len);
/* 1 and *r when rec is a history record, 0 when it is not one, or an
 * error code for a damaged one. */
int bc__undo_record_parse(const uint8_t *rec, size_t len,
                          struct bc_undo_record *r);

/* ---- present.c ---- */

/* m's own CAMERA was applied (flags: the CAMERA's): a follower stops
 * following; the presenter's followers take its camera. */
void bc__present_camera_moved(struct bc_member *m, uint16_t flags);
/* m leaves its session: a presenter's presentation ends for everyone. */
void bc__present_leave(struct bc_member *m);
/* m joined its session: tells it who presents (when it knows the types). */
void bc__present_joined(struct bc_member *m);
/* The session is going away (deleted): a presentation ends, and every
 * member that knows PRESENTER hears it (PRESENTER 0) before it is sent
 * out of the session. */
void bc__present_session_gone(struct bc_session *s);
/* A journal record that sets the session camera: two zero bytes (an
 * op_count no EDIT has) and the SESSION_CAMERA payload. Returns 1 and
 * fills *cam when rec is one (0 when it is an EDIT, an error code when it
 * is a damaged camera record). */
int bc__present_camera_record(const uint8_t *rec, size_t len,
                              struct bc_camera *cam);
/* Restoring a session: a journal record applied to *tree and *camera
 * (bc_store_replay_fn, ud a struct replay_ctx): an EDIT, a session camera
 * or a SCENE_LOAD. */
struct replay_ctx {
	struct bc_tree **tree;
	struct bc_camera *camera;
	struct bc_undo *undo; /* the history rebuilt, or NULL */
};
int bc__replay_record(void *ud, uint64_t order, const uint8_t *rec, size_t len);
/* Journals a SCENE_LOAD (its scene bytes, camera included) as edit order:
 * two 0xff bytes (an op_count no EDIT has) and the scene encoding. */
int bc__journal_load(struct bc_store_session *st, uint64_t order,
                     const uint8_t *scene, size_t len, struct bc_errinfo *ei);
/* A new, empty session tree: bare (bc_tree_set_layout), since nothing
 * renders from it: the work layer's copy is laid out. The session keeps
 * the model only, and its structural edits splice no layout. */
struct bc_tree *bc__session_tree(void);
/* A new, empty tree for the work layer's render copy: laid out, and
 * without names (bc_tree_set_names), which no renderer reads. */
struct bc_tree *bc__copy_tree(void);
/* Decodes a SCENE_LOAD's scene into tree (camera and has_cam as
 * bc_scene_decode) and into copy, the work layer's, on two threads when it
 * is large; copy may be NULL (no render copy wanted yet). */
int bc__load_decode(const uint8_t *scene, size_t len, struct bc_tree *tree,
                    struct bc_tree *copy, struct bc_camera *cam, bool *has_cam,
                    struct bc_errinfo *ei);

#endif
