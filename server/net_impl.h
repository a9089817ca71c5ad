/*
 * The transport's private types, shared by net.c (connections: reading,
 * framing, parking, writing, timeouts), listen.c (the listeners, accepting)
 * and admit.c (who gets a slot when connections run short).
 */
#ifndef BLOBCAST_SERVER_NET_IMPL_H
#define BLOBCAST_SERVER_NET_IMPL_H

#include "dispatch.h"
#include "srv_limits.h"
#include "transport.h"

/* A client's acknowledgements (feature ACKS, PROTOCOL.md 7.27; acks.c):
 * the FRAMEs of its view written and not yet acknowledged, oldest first,
 * and what their round trips say of the path. */
struct bc_acks {
	bool on;        /* granted: frames wait for acknowledgements */
	uint32_t acked; /* the newest FRAME acknowledged */
	uint32_t n;
	struct bc_ack_frame {
		uint32_t no;
		size_t len;
		uint64_t written_us;
	} out[BC_PROTO_ACK_WINDOW];
	/* From write to acknowledgement, microseconds: smoothed (1/8) and
	 * least; bytes per second acknowledged while frames waited. */
	uint32_t srtt_us, min_us;
	uint64_t bps;
};

/* A view FRAME of len bytes, number no, has been written at now_us
 * (microseconds, uv_hrtime's clock). */
void bc__acks_written(struct bc_acks *a, uint32_t no, size_t len,
                      uint64_t now_us);
/* Whether the window is full: the next frame waits. */
bool bc__acks_full(const struct bc_acks *a);
/* Whether the acknowledgements come late against the least round trip
 * seen: frames queue somewhere on the path (a slow link, not a far one). */
bool bc__acks_congested(const struct bc_acks *a);
/* FRAME_ACK for frame no, the last FRAME written being last. Returns 0,
 * or BC_ERANGE with a sentence in ei (a frame never sent, or not above
 * the previous acknowledgement): nothing changes then. */
int bc__acks_take(struct bc_acks *a, uint32_t no, uint32_t last,
                  uint64_t now_us, struct bc_errinfo *ei);
/* STATS's link figures as the acknowledgements measure them, over those of
 * TCP (PROTOCOL.md 7.18). */
void bc__acks_info(const struct bc_acks *a, struct bc_proto_link *out);

struct bc_conn {
	struct bc_net *net;
	uint32_t slot, gen;
	union {
		uv_tcp_t tcp;
		uv_pipe_t pipe;
		uv_stream_t stream;
		uv_handle_t handle;
	} h;
	/* Before HELLO its deadline; after, the pacing tick (net.c, pace). */
	uv_timer_t hello_timer;
	struct bc_tls *tls;   /* TLS state (tls.h) on a TLS listener, or NULL */
	bool is_tcp, trusted; /* trusted: loopback TCP or Unix socket */
	bool authed;          /* HELLO accepted */
	bool closing;
	bool draining; /* shut down after the queued bytes are written */
	/* To be closed at the loop's next turn (net.c, close_soon): set
	 * with draining, so that it takes no more output and reads no more
	 * meanwhile. */
	bool doomed;
	struct bc_conn *doomed_next;
	uv_shutdown_t shutdown;
	const char *drain_why;
	uint32_t handles_open;
	struct bc_proto_reader reader;
	char name[BC_PROTO_MAX_NAME + 1]; /* for the log */
	/* Admission (admit.c): the peer's address as 16 bytes (IPv4 in its
	 * v4-mapped form), whether known, and when it came (loop clock). */
	uint8_t addr[16];
	bool has_addr;
	uint64_t accepted_ms;
	/* A message that waits for its session (BC_DISPATCH_PARK): the
	 * reader is not touched, so it stays valid, until it is resumed. */
	bool parked, resume_again;
	struct bc_msg parked_msg;
	struct bc_conn *resume_next;
	bool resume_queued;
	/* Output: messages go out in order, a piece at a time (net.c,
	 * pump); frames one at a time. queued counts both, frame_bytes the
	 * frame being written. */
	struct write_req *out_head, *out_tail;
	bool writing;      /* a piece is with libuv */
	bool shutdown_due; /* draining: shut down once the queue is empty */
	size_t queued, frame_bytes;
	/* Of queued, the shared whole messages (a big scene's SCENE_STATE,
	 * whole or in parts): beside the frame, the cap's other exemption. */
	size_t shared_bytes;
	bool frame_writing;
	uint64_t frame_started_ms; /* or when the kernel last took a piece */
	struct bc_shared *frame_next;
	uint32_t frame_next_camera_seq;
	/* SNAPSHOT answers waiting for the frame being written: never
	 * spoiled, written in order before frame_next (at most
	 * BC_SRV_MAX_CLIENT_REQUESTS, the sessions layer's cap). */
	struct bc_answer *answers_head, *answers_tail;
	uint32_t frame_no; /* FRAMEs written to this client */
	/* Timeouts (loop clock, ms): when the first byte of a message still
	 * incomplete arrived (0: none pending), and when the last bytes did. */
	uint64_t msg_started_ms, last_read_ms;
	struct bc_conn_counters counters;
	uint64_t frames_spoiled;
	/* A frame waits for the link (pace): the frame written last. */
	bool pacing;
	size_t paced_len, paced_backlog;
	struct bc_acks acks; /* FRAME_ACK (acks.c) */
};

struct bc_net {
	uv_loop_t *loop;
	const struct bc_srv_config *cfg;
	struct bc_dispatch *d;
	struct bc_link link;
	uv_tcp_t tcp_listener;
	uv_pipe_t unix_listener;
	bool has_tcp, has_unix;
	struct bc_tls_ctx *tls; /* certificate and key, or NULL: plain TCP */
	uv_timer_t stall_timer; /* timeouts, clients that stopped reading */
	uv_idle_t resumer;      /* parked connections to resume */
	struct bc_conn *resume_head, *resume_tail;
	uv_idle_t doomer; /* connections to close (close_soon) */
	struct bc_conn *doomed;
	struct bc_conn *clients[BC_SRV_MAX_CONNECTIONS];
	uint32_t gens[BC_SRV_MAX_CONNECTIONS];
	uint32_t nclients;
	bool stopping;
	uint64_t refused_log_ms; /* refusals are logged once a second */
	uint32_t refused_quiet;
};

/* ---- net.c ---- */

struct bc_conn *bc__conn_get(struct bc_net *n, struct bc_conn_ref ref);
void bc__conn_close(struct bc_conn *c, const char *why);
void bc__conn_close_after_flush(struct bc_conn *c, const char *why);
/* Starts a connection accepted into slot: its reader, HELLO timer and
 * reads. */
void bc__conn_start(struct bc_conn *c, uint32_t slot);
/* Close callback of a connection's handles: frees it after the last. */
void bc__net_handle_closed(uv_handle_t *h);
/* Writes what a TLS connection's state has to send. */
void bc__net_tls_flush(struct bc_conn *c);
/* Once a second: message and idle timeouts, clients that stopped reading. */
void bc__net_check_stalls(uv_timer_t *t);

/* ---- admit.c ---- */

/* Makes room for connection c (its address read, not in the table yet):
 * closes older unauthenticated connections of its address or prefix past
 * their caps, and when every slot is taken the oldest unauthenticated one
 * anywhere, else the longest-idle one that said HELLO and joined nothing.
 * Returns the free slot, or BC_SRV_MAX_CONNECTIONS with *why when c must
 * be refused. */
uint32_t bc__admit(struct bc_net *n, struct bc_conn *c, const char **why);
/* Reads the peer address of a TCP connection into c. */
void bc__admit_address(struct bc_conn *c);

#endif
