/*
 * The dispatch layer, as the transport and main see it: one table from
 * message type to handler, with the state and role checks of PROTOCOL.md 5
 * made once for every request, HELLO and its tokens, PING, STATS, and the
 * event loop's own timing (the longest busy turn and request, which STATS
 * reports).
 */
#ifndef BLOBCAST_SERVER_DISPATCH_H
#define BLOBCAST_SERVER_DISPATCH_H

#include <stdbool.h>
#include <stdint.h>
#include <uv.h>

#include "link.h"
#include "sessions.h"
#include "work.h"

struct bc_dispatch;
struct bc_srv_config;

/* What bc_dispatch_message tells the transport. */
enum bc_dispatch_result {
	BC_DISPATCH_OK = 0,
	BC_DISPATCH_PARK,  /* the message waits: read nothing more until the
	                    * link's resume */
	BC_DISPATCH_HELLO, /* HELLO was accepted: the client is authenticated */
	BC_DISPATCH_RESULT_COUNT
};

/* What the transport counts of a connection, read by STATS. */
struct bc_conn_counters {
	uint64_t frames_sent, bytes_sent;
	uint64_t first_frame_ms; /* loop clock; 0: no frame yet */
	uint64_t frames_paced;   /* times a frame waited for the link */
};

struct bc_dispatch_opts {
	uv_loop_t *loop;
	const struct bc_link *link;
	struct bc_sessions *sessions;
	struct bc_work *work;
	/* The tokens are read at each HELLO: main swaps them on SIGHUP. */
	const struct bc_srv_config *cfg;
};

int bc_dispatch_new(struct bc_dispatch **out,
                    const struct bc_dispatch_opts *opts, struct bc_errinfo *ei);
/* Closes its loop handles; frees once they are closed (run the loop). */
void bc_dispatch_free(struct bc_dispatch *d);

/* A connection came (trusted: loopback TCP or the Unix socket). counters
 * stay valid until bc_dispatch_closed. Returns 0 or BC_ENOMEM. */
int bc_dispatch_open(struct bc_dispatch *d, struct bc_conn_ref ref,
                     bool trusted, bool is_tcp,
                     const struct bc_conn_counters *counters);
/* One whole message from ref. */
enum bc_dispatch_result bc_dispatch_message(struct bc_dispatch *d,
                                            struct bc_conn_ref ref,
                                            const struct bc_msg *m);
/* ref's last frame has left its queue. */
void bc_dispatch_writable(struct bc_dispatch *d, struct bc_conn_ref ref);
/* A SNAPSHOT's answer to ref was written. */
void bc_dispatch_answered(struct bc_dispatch *d, struct bc_conn_ref ref);
/* The TLS certificate in use ends its validity at this Unix time in ms
 * (0: no TLS), for STATS's TLS section; set at start and each reload. */
void bc_dispatch_set_tls_expiry(struct bc_dispatch *d, uint64_t not_after_ms);
/* ref is closing: nothing more is sent to it. */
void bc_dispatch_closed(struct bc_dispatch *d, struct bc_conn_ref ref);
/* Whether ref has completed HELLO and is in no session: what admission
 * may close first when connections run short. */
bool bc_dispatch_idle(const struct bc_dispatch *d, struct bc_conn_ref ref);

#endif
