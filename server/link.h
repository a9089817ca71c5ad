/*
 * What every layer of blobcastd shares, and the one way a lower layer
 * speaks upward. The layers, each calling only the ones below it
 * (docs/architecture.md, checked by tests/server/check_layers.py):
 *
 *   transport (net.c, listen.c, admit.c, tls.c, addr.c)
 *     -> dispatch (dispatch.c)
 *       -> sessions (session.c, members.c, frames.c, edits.c, undo.c,
 *                    present.c, index.c, store.c, journal.c, snapshot.c)
 *         -> work (work.c, flow.c, job.c, views.c, encode.c)
 *           -> renderers (render/)
 *
 * Messages to clients go up: the sessions and dispatch layers hold a
 * struct bc_link, a table of callbacks the transport fills in, and send
 * through it. Shared here besides: connection handles, reference-counted
 * frames and the client's identity as the layers below transport see it.
 */
#ifndef BLOBCAST_SERVER_LINK_H
#define BLOBCAST_SERVER_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/proto.h"

/* A connection handle that survives the connection: stale ones (another
 * generation) find nothing. */
struct bc_conn_ref {
	uint32_t slot, gen;
};

static inline bool bc_conn_ref_eq(struct bc_conn_ref a, struct bc_conn_ref b)
{
	return a.slot == b.slot && a.gen == b.gen;
}

/* A reference-counted byte buffer: one encoded FRAME shared by every client
 * of a view group. The counts change on the loop thread only. */
struct bc_shared {
	uint32_t refs;
	uint32_t needs; /* features a receiver must have (bc_proto) */
	/* The same message for a receiver not granted NAMES (its names left
	 * out, PROTOCOL.md 4.1), owned by this one; NULL when needs has no
	 * BC_PROTO_FEATURE_NAMES. */
	struct bc_shared *older;
	size_t len;
	uint8_t data[];
};
/* Returns a buffer of len bytes with one reference, or NULL. */
struct bc_shared *bc_shared_new(size_t len);
/* Bytes of a bc_shared before its data. */
#define BC_SHARED_HEAD offsetof(struct bc_shared, data)
/* Makes buf (from bc_malloc or bc_realloc, total bytes, total > BC_SHARED_HEAD)
 * a buffer of its last total - BC_SHARED_HEAD bytes with one reference, without
 * a copy: for a message made after room for its bc_shared (a big scene's
 * SCENE_STATE). */
struct bc_shared *bc_shared_adopt(uint8_t *buf, size_t total);
void bc_shared_unref(struct bc_shared *s);

/* A client as the layers below transport know it, owned by dispatch: who
 * it is and what it said in HELLO. */
struct bc_peer {
	struct bc_conn_ref ref;
	char name[BC_PROTO_MAX_NAME + 1];
	enum bc_proto_role max_role; /* what its token grants */
	enum bc_proto_role role;     /* in its session */
	enum bc_proto_stage stage;
	uint8_t encodings;
	uint32_t max_frame_bytes;
	/* The features its HELLO announced that this server has
	 * (BC_PROTO_FEATURE_*, PROTOCOL.md 4); 0 for an earlier client's
	 * HELLO without the field (announced false). */
	uint32_t features;
	bool announced;
	/* It is sent PRESENTER, FOLLOW_CAMERA and SESSION_CAMERA_SET: it
	 * announced PRESENT, or (a HELLO without features) it has sent a
	 * type of 28 or more (PRESENT, FOLLOW, SESSION_CAMERA). */
	bool knows_present;
};

/* What the transport lends the layers below it: each call concerns one
 * connection, by handle; a stale handle is ignored. */
struct bc_link {
	void *ud;
	/* Encodes and queues m; a failure closes the connection. */
	void (*send)(void *ud, struct bc_conn_ref to, const struct bc_msg *m);
	/* Queues a FRAME (the transport takes its own reference; an unsent
	 * older frame is spoiled), with camera_seq for this client in place
	 * of the shared one. */
	void (*send_frame)(void *ud, struct bc_conn_ref to,
	                   struct bc_shared *frame, uint32_t camera_seq);
	/* Queues a whole encoded message (the transport takes its own
	 * reference): one encoding for many clients, made off the loop (a
	 * big scene's SCENE_STATE), and no copy of it on the loop. */
	void (*send_shared)(void *ud, struct bc_conn_ref to,
	                    struct bc_shared *msg);
	/* Queues a shared SCENE_STATE (bc_proto_scene_state_head, then the
	 * scene) as parts whose payloads are at most part_max bytes
	 * (PROTOCOL.md 7.10.1), one after another with nothing between them;
	 * each part is a slice of msg behind a head of its own. */
	void (*send_parts)(void *ud, struct bc_conn_ref to,
	                   struct bc_shared *msg, uint32_t part_max);
	/* Drops the FRAMEs and SNAPSHOT answers waiting for the connection
	 * (not the one being written): it left its session, and nothing of
	 * that session follows the OK or ERROR that says so. */
	void (*forget_frames)(void *ud, struct bc_conn_ref to);
	/* The connection was granted ACKS: its view's frames wait for its
	 * FRAME_ACKs from now on (PROTOCOL.md 7.27). */
	void (*acks_on)(void *ud, struct bc_conn_ref to);
	/* FRAME_ACK no from the connection. Returns 0, or BC_ERANGE with the
	 * reason in ei (a frame never sent, or out of order). */
	int (*frame_ack)(void *ud, struct bc_conn_ref from, uint32_t no,
	                 struct bc_errinfo *ei);
	/* The buffer the message being handled lies in, now the caller's
	 * (bc_free): a big payload kept without a copy on the loop. NULL
	 * when out of memory; the message is unchanged either way. */
	void *(*detach)(void *ud, struct bc_conn_ref from);
	/* Closes the connection, after its queued bytes when flush is set
	 * (an ERROR just sent then still goes out). */
	void (*close)(void *ud, struct bc_conn_ref to, const char *why,
	              bool flush);
	/* A message of this connection waited (BC_PARK, sessions.h): in a
	 * later turn of the loop, dispatch it again (again) or drop it (it
	 * was answered meanwhile), then read on. */
	void (*resume)(void *ud, struct bc_conn_ref to, bool again);
	/* What the transport knows of the path to this connection (STATS's
	 * link section): TCP's round trip and delivery rate, the bytes not
	 * yet acknowledged, the frames paced and spoiled. Zeros when it is
	 * not TCP or gone. */
	void (*link_info)(void *ud, struct bc_conn_ref to,
	                  struct bc_proto_link *out);
};

/* ERROR to one connection: a code (BC_E*) and a sentence, logged; fatal
 * ones carry the FATAL flag (the caller closes). */
void bc_link_error(const struct bc_link *l, struct bc_conn_ref to, uint32_t seq,
                   int code, bool fatal, const char *fmt, ...)
    __attribute__((format(printf, 6, 7)));

/* A deep copy of edit operations (their fields and subtrees), made
 * because a decoded message lives only until its reader's next call. */
struct bc_ops_copy {
	struct bc_proto_edit_op *ops;
	uint32_t n;
	uint8_t *blob; /* the fields and subtrees */
	size_t bytes;  /* everything the copy holds */
};
/* Returns 0 or BC_ENOMEM (out zeroed). */
int bc_ops_copy(struct bc_ops_copy *out, const struct bc_proto_edit_op *ops,
                uint32_t n);
void bc_ops_copy_finish(struct bc_ops_copy *c);

/* OK answering seq. */
void bc_link_ok(const struct bc_link *l, struct bc_conn_ref to, uint32_t seq);

/* Returns the allocator's free memory to the system. glibc keeps what a
 * thread freed in that thread's arena, resident, until asked: after a big
 * scene's trees, renderer or queued frames go, the daemon's RSS would
 * otherwise stay at their peak. It walks every arena (up to ~20 ms on a
 * heap of a GiB), so it follows big frees only: a heavy tree's, on the
 * task or worker that freed it, and a client's with megabytes queued. */
void bc_heap_give_back(void);
/* One malloc arena for every thread of the daemon (glibc; called first
 * in main). glibc gives each thread that allocates while another holds
 * the lock an arena of its own, and a thread arena's free memory at its
 * top goes back to the system only past a trim threshold that glibc
 * raises to twice the largest block freed (up to 64 MiB), which
 * bc_heap_give_back cannot lower: a big tree made on a task and freed
 * later (a render copy that nobody looked at, a replaced scene) kept
 * tens of megabytes resident, more at each cycle. With one arena it all
 * goes back. The render threads allocate per frame and per job, not per
 * ray (small blocks come from each thread's own cache): the orbit and
 * drag figures did not move (docs/benchmarks.md, "One malloc arena"). */
void bc_heap_policy(void);

#endif
