/*
 * libblobcast: the C client of blobcastd. It owns one connection to the
 * daemon (TCP or a Unix socket), the HELLO/WELCOME handshake, sequence
 * numbers, a blocking-with-timeout receive loop on top of the protocol's push
 * reader, a mirror of the session's scene (kept current from SCENE_STATE and
 * EDIT_APPLIED, so that `radius=0.4` can be mapped to the right field of the
 * right kind of node), and the client-side framebuffer that FRAME rectangles
 * (JPEG, PNG or raw) are decoded into.
 *
 * Two levels of use:
 *  - a poll loop (a viewer): bc_client_fd(), bc_client_send() and
 *    bc_client_recv(timeout 0), feeding every FRAME to
 *    bc_client_image_apply();
 *  - request/response helpers (tools, the CLI): bc_client_join(),
 *    bc_client_load_scene_file(), bc_client_edit_kv(), bc_client_snapshot()
 *    and bc_client_stats() send one request and wait for its answer,
 *    consuming whatever else arrives meanwhile (frames included).
 *
 * Every function returns 0 or a negative BC_E* code. The connection keeps a
 * sticky error: once the stream failed (closed, timed out mid-write, bytes
 * the reader refused, a FATAL ERROR from the server) every later call
 * returns that error, and bc_client_error() gives its reason. Failures of a
 * single request (an ERROR answer, an edit string that does not parse, a
 * wait that timed out between messages) are not sticky. Nothing here is
 * thread-safe: one thread uses a client at a time.
 */
#ifndef BLOBCAST_CLIENT_H
#define BLOBCAST_CLIENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/export.h"
#include "blobcast/proto.h"

/* ---- Defaults and limits --------------------------------------------------
 */

/* Where blobcastd listens when started without options. */
#define BC_CLIENT_DEFAULT_HOST "127.0.0.1"
#define BC_CLIENT_DEFAULT_PORT 7878u

/* How long connecting and each helper's wait may take unless the options say
 * otherwise: a local daemon answers in milliseconds, a remote one over a
 * slow link well within ten seconds; a hung daemon should not hang a
 * script forever. */
#define BC_CLIENT_DEFAULT_TIMEOUT_MS 10000

/* Longest host name (DNS allows 253 characters plus a trailing dot). */
#define BC_CLIENT_MAX_HOST 255u
/* Longest Unix socket path: Linux's sun_path holds 108 bytes with the NUL. */
#define BC_CLIENT_MAX_UNIX_PATH 107u
/* Longest path (with its query) of a ws:// or wss:// address. */
#define BC_CLIENT_MAX_WS_PATH 1023u

/* Bytes taken from the socket per read: big enough that a 1 MB frame costs
 * a handful of system calls, small enough to live in every client. */
#define BC_CLIENT_READ_CHUNK (64u * 1024u)

/* Largest key=value list one edit takes: one per field number. */
#define BC_CLIENT_MAX_EDIT_ARGS BC_PROTO_MAX_SET_FIELDS

/* ---- Addresses --------------------------------------------------------------
 */

enum bc_client_addr_kind {
	BC_CLIENT_ADDR_INVALID = 0,
	BC_CLIENT_ADDR_TCP,
	BC_CLIENT_ADDR_UNIX,
	BC_CLIENT_ADDR_KIND_COUNT
};

struct bc_client_addr {
	enum bc_client_addr_kind kind;
	uint16_t port;                            /* TCP */
	char host[BC_CLIENT_MAX_HOST + 1];        /* TCP, without brackets */
	char path[BC_CLIENT_MAX_UNIX_PATH + 1];   /* UNIX */
	bool tls;                                 /* TCP: tls:// or wss:// */
	bool ws;                                  /* TCP: ws:// or wss:// */
	char resource[BC_CLIENT_MAX_WS_PATH + 1]; /* ws: "/PATH?QUERY" */
};

/*
 * Parses a server address into *out (reset on entry):
 *   NULL or ""        127.0.0.1:7878
 *   HOST:PORT         a name or IPv4 address and a port 1..65535
 *   HOST              the default port
 *   :PORT             the default host
 *   [IPV6]:PORT, [IPV6]
 *   unix:PATH         a Unix socket (PATH up to BC_CLIENT_MAX_UNIX_PATH bytes)
 *   tls://ADDRESS     any TCP form above, over TLS (out->tls)
 *   ws://ADDRESS/PATH the protocol inside WebSocket binary messages, as
 *                     the browser page speaks it (a proxy in front of
 *                     websockify: docs/deploy.md); the port defaults to 80
 *   wss://ADDRESS/PATH the same over TLS; the port defaults to 443
 * Returns 0 or BC_EINVAL with the reason in ei (which may be NULL).
 */
BC_API int bc_client_addr_parse(const char *s, struct bc_client_addr *out,
                                struct bc_errinfo *ei);

/* ---- The connection ---------------------------------------------------------
 */

/* Zero means default for every field. */
struct bc_client_opts {
	const char *addr;  /* as bc_client_addr_parse() takes it */
	const char *name;  /* HELLO client_name; NULL: "libblobcast" */
	const char *token; /* HELLO token; NULL: none */
	/* HELLO encodings, bits (1 << (encoding - 1)); 0: JPEG, PNG and raw
	 * (BC_PROTO_ENCODINGS_IMAGES). BC_PROTO_ENCODINGS_ALL adds H.264
	 * (encoding 4), which bc_client_image_apply() decodes; a server of a
	 * text before H.264 refuses that HELLO (BC_EPROTO_FLAGS): connect
	 * again without it. */
	uint8_t encodings;
	uint32_t max_frame_bytes; /* 0: the server's limit */
	/* Milliseconds for connecting, for completing one send, and for each
	 * helper's wait; 0: BC_CLIENT_DEFAULT_TIMEOUT_MS, of which the TCP
	 * connect itself takes at most 3 s (a host that is down is reported
	 * then); negative: none. */
	int timeout_ms;
	/* TLS (a tls:// address): the server's certificate must chain to a
	 * certificate in ca_file (PEM; NULL: the system's trust store) and
	 * name the host of the address. insecure skips both checks (the
	 * traffic is still encrypted, but to whoever answers). */
	const char *ca_file;
	bool insecure;
	/* Announce the feature ACKS (PROTOCOL.md 7.27): when the server
	 * grants it (bc_client_info()->features), the program promises to
	 * acknowledge every FRAME with bc_client_frame_ack() once it has shown
	 * it, and the server keeps at most BC_PROTO_ACK_WINDOW frames
	 * unacknowledged: a program that does not acknowledge stops getting
	 * frames. false: every other feature (BC_PROTO_FEATURES_READ). */
	bool acks;
	/* Keep the scene mirror bare (bc_tree_set_layout false): the model
	 * alone, without the renderers' layout, so that bc_tree_lin() and
	 * bc_tree_slot() of bc_client_scene() answer NULL and BC_NONE.
	 * Everything else the mirror answers is the same (bc_tree_node_box
	 * too); a big session's SCENE_STATE then costs about half the time
	 * and memory to take in (a million spheres: docs/benchmarks.md). For
	 * programs that draw nothing of the scene themselves (the CLI, the
	 * viewer); false: laid out. */
	bool bare_scene;
};

struct bc_client;

/* What the server said in WELCOME and SESSION_INFO, and traffic counts.
 * Strings are NUL-terminated copies. */
struct bc_client_info {
	uint16_t version;
	uint32_t connection_id;
	uint32_t max_payload;     /* largest message the server accepts */
	uint32_t max_frame_bytes; /* largest FRAME it will send us */
	uint32_t max_nodes;
	uint16_t max_dim, max_members, max_edit_ops;
	char server_id[BC_PROTO_MAX_NAME + 1];
	/* Features the server granted of those announced (every one this
	 * library knows but ACKS, BC_PROTO_FEATURES_READ, and ACKS too with
	 * opts.acks; PROTOCOL.md 4). A server that predates them grants none
	 * and sends no field. */
	uint32_t features;
	/* The session, once joined (zero before and after leaving). */
	uint32_t session_id, member_id;
	enum bc_proto_role role;
	uint16_t nmembers;
	char session[BC_PROTO_MAX_NAME + 1];
	/* The latest edit order heard of (SCENE_STATE, EDIT_APPLIED). */
	uint64_t order;
	/* Traffic: whole messages, header included. */
	uint64_t msgs_in, msgs_out, bytes_in, bytes_out;
	/* Size on the wire of the message bc_client_recv() returned last. */
	uint32_t last_msg_bytes;
	/* Presentation (PRESENTER, once this client has called
	 * bc_client_present or bc_client_follow): the member id of the
	 * session's presenter (0: nobody) and whether this client follows. */
	uint32_t presenter;
	bool following;
};

/*
 * Connects to opts->addr (TCP with TCP_NODELAY, or a Unix socket), completes
 * the TLS handshake for tls:// and wss:// (BC_EAUTH: the certificate is not
 * trusted; BC_EIO: no TLS there) and the WebSocket one for ws:// and wss://,
 * sends HELLO and waits for WELCOME. On success *out (reset on entry) is a
 * client to free with bc_client_destroy(). Returns 0, BC_EINVAL (bad options),
 * BC_EIO (no connection: refused, unreachable, not resolved), BC_ETIMEOUT,
 * BC_ENOMEM, a protocol error, or the code of the server's ERROR (BC_EAUTH,
 * BC_EPROTO_VERSION...) with its text; the reason is in ei (which may be
 * NULL). On a plain TCP address, a peer that answers HELLO with anything
 * but blobcastd's magic (an HTTP server, a WebSocket proxy, a TLS server)
 * gives BC_EPROTO_MAGIC, and one that closes without a word BC_ECLOSED,
 * with a sentence naming what listens there and the address to use; when
 * HELLO gets no answer for half a second, a second connection asks the
 * port what it is, so that such a peer is reported in about a second, while
 * a slow blobcastd is still waited for.
 */
BC_API int bc_client_connect(struct bc_client **out,
                             const struct bc_client_opts *opts,
                             struct bc_errinfo *ei);
/* Closes the connection and frees everything; accepts NULL. */
BC_API void bc_client_destroy(struct bc_client *c);

/* The socket, for poll(): readable means bc_client_recv() has bytes to work
 * on. The client owns it; do not read, write or close it. Over TLS, poll
 * only after bc_client_recv(timeout 0) returned 0: it drains what TLS has
 * buffered. */
BC_API int bc_client_fd(const struct bc_client *c);
/* WELCOME, session and traffic details (owned by c, updated by every call). */
BC_API const struct bc_client_info *bc_client_info(const struct bc_client *c);
/* Returns the sticky error (0 if none) and copies its reason into ei. */
BC_API int bc_client_error(const struct bc_client *c, struct bc_errinfo *ei);

/*
 * Gives m the next sequence number (written to *seq_out, which may be NULL,
 * and to m->seq), encodes it and writes it whole, waiting for the socket
 * with poll() for at most the client's timeout. Returns 0; the encoder's
 * error for an invalid message (nothing was sent, not sticky); or a sticky
 * BC_ECLOSED, BC_EIO or BC_ETIMEOUT (the stream is unusable).
 */
BC_API int bc_client_send(struct bc_client *c, struct bc_msg *m,
                          uint32_t *seq_out);

/*
 * Waits at most timeout_ms (0: only what is already buffered or readable
 * now; negative: forever) for the next message. Returns 1 with *out (reset
 * on entry) valid until the next call on c, 0 on timeout, or a sticky
 * negative code: BC_ECLOSED when the server closed the stream, a protocol
 * error, BC_EIO. A FATAL ERROR message is returned like any other, and its
 * code becomes the sticky error of the calls that follow. SESSION_INFO,
 * SCENE_STATE and EDIT_APPLIED also update bc_client_info(), the roster
 * (bc_client_members) and the scene mirror before they are returned.
 */
BC_API int bc_client_recv(struct bc_client *c, struct bc_msg *out,
                          int timeout_ms);

/*
 * Receives until the answer to request seq arrives, consuming other
 * messages: type FRAME matches a FRAME whose seq is seq (a SNAPSHOT's
 * answer), or any FRAME when seq is 0; EDIT_APPLIED and SCENE_STATE match
 * when this client is the author and seq is the request's; every other type
 * matches its own seq (0: any). Returns 0 with *out as bc_client_recv()
 * gives it; the negated code of an ERROR that arrives meanwhile (whatever
 * request it answers), with its text in ei; BC_ETIMEOUT (not sticky) after
 * timeout_ms (0: the client's timeout, negative: none); or the sticky error.
 */
BC_API int bc_client_wait(struct bc_client *c, enum bc_msg_type type,
                          uint32_t seq, struct bc_msg *out, int timeout_ms,
                          struct bc_errinfo *ei);

/* ---- Sessions and scenes
 * ------------------------------------------------------ */

enum bc_client_join_mode {
	BC_CLIENT_JOIN_EXISTING = 0, /* SESSION_JOIN; no such session: error */
	BC_CLIENT_JOIN_CREATE,       /* SESSION_CREATE; it exists: error */
	BC_CLIENT_JOIN_ANY,          /* join, creating the session if missing */
	BC_CLIENT_JOIN_MODE_COUNT
};

/*
 * Enters session name with role (EDITOR or VIEWER; 0 means EDITOR) and waits
 * for SESSION_INFO and the SCENE_STATE that follows it, which fills the
 * scene mirror. bc_client_info() then holds the member id and role. Returns
 * 0 or an error (the server's ENOSESSION, EEXIST, EPERM...) with the reason.
 */
BC_API int bc_client_join(struct bc_client *c, const char *name,
                          enum bc_proto_role role,
                          enum bc_client_join_mode mode, struct bc_errinfo *ei);

/* Deletes session name on the server (SESSION_DELETE): its members, this
 * client too when it is one, are sent back to READY with ERROR ENOSESSION.
 * Needs a token granting the editor role (BC_EPERM otherwise);
 * BC_ENOSESSION when there is no such session. */
BC_API int bc_client_delete_session(struct bc_client *c, const char *name,
                                    struct bc_errinfo *ei);

/* One member of the session, as SESSION_INFO lists it (PROTOCOL.md 7.8). */
struct bc_client_member {
	uint32_t id;
	enum bc_proto_role role;
	char name[BC_PROTO_MAX_NAME + 1]; /* its HELLO client_name; may be "" */
};

/*
 * The roster: the members of the session this client is in, this client
 * included, in the order of the last SESSION_INFO received (the server
 * sends one to every member whenever someone joins or leaves).
 * *list and *n are reset on entry; *list then points to *n entries owned by
 * c, valid until the next call on c that receives (bc_client_recv(),
 * bc_client_wait() and the helpers that wait) or bc_client_destroy(). The
 * roster is empty (*list NULL, *n 0) before joining, after leaving (the OK
 * of SESSION_LEAVE) and after the session was deleted; a new connection
 * starts empty. Returns 0.
 */
BC_API int bc_client_members(const struct bc_client *c,
                             const struct bc_client_member **list, size_t *n);
/* The roster's entry for member id, owned by c and valid as long as
 * bc_client_members()'s list; NULL when id is not (or no longer) a member. */
BC_API const struct bc_client_member *
bc_client_member_find(const struct bc_client *c, uint32_t id);

/* What an UNDO or REDO did (bc_client_undo). */
struct bc_client_undone {
	uint64_t order;        /* the order number of the undo's own edit */
	uint64_t target_order; /* the edit undone or redone */
	char target_author[BC_PROTO_MAX_NAME + 1]; /* that edit's author */
};

/* Undoes (redo false) or redoes a change and waits until it is applied;
 * *out (may be NULL) says what it was. Needs the editor role. Against a
 * server that granted per-person undo (BC_PROTO_FEATURE_HISTORY) it is
 * bc_client_undo_mine; against an older one, the session's newest change,
 * whoever made it. BC_ESTATE when there is nothing to undo (redo). */
BC_API int bc_client_undo(struct bc_client *c, bool redo,
                          struct bc_client_undone *out, struct bc_errinfo *ei);
/* Undoes (redoes) this client's own newest change -- its client name's,
 * whichever connection made it (PROTOCOL.md 7.20) -- skipping changes
 * another member has since built on. BC_ESTATE when none is left (the
 * text names a change built on it and its author), BC_ENOTSUP when the
 * server has no per-person undo. */
BC_API int bc_client_undo_mine(struct bc_client *c, bool redo,
                               struct bc_client_undone *out,
                               struct bc_errinfo *ei);
/* Undoes (redoes) the session's newest change, whoever made it: only for
 * the session's owner (the client name that created it) or its presenter,
 * others get BC_EPERM; BC_ENOTSUP as above. */
BC_API int bc_client_undo_session(struct bc_client *c, bool redo,
                                  struct bc_client_undone *out,
                                  struct bc_errinfo *ei);

/* One change of the session's undo history (bc_client_history). */
struct bc_client_change {
	uint64_t order;    /* the edit that made it: what undo names */
	uint64_t time_ms;  /* when, Unix ms; 0: unknown */
	uint64_t built_on; /* newest later change built on it; 0: none */
	bool undone;       /* taken back (can be redone), else applied */
	bool yours;        /* this client's own (its client name's) */
	bool next;         /* the one this client's own undo/redo takes */
	char author[BC_PROTO_MAX_NAME + 1];
	char what[BC_PROTO_MAX_HISTORY_TEXT + 1]; /* "SET node 12 translate" */
};

/* A mesh the server made of the session's solid (MESH, PROTOCOL.md 7.28):
 * the file `blobcast mesh` writes of the same scene. */
struct bc_client_mesh {
	uint8_t *file; /* bc_malloc'ed, the caller bc_free's */
	size_t len;
	uint32_t vertices, triangles;
	uint16_t resolution; /* the one used */
	uint64_t order;      /* the session's order the mesh is of */
};

/* Asks the server to mesh the session's solid in format (an enum
 * bc_proto_mesh_format) with options (BC_PROTO_MESH_*) at resolution (0:
 * the default, 128) and waits for the file, up to timeout_ms (0: the
 * client's timeout; negative: none; meshing takes seconds). Any role, in a
 * session. BC_ENOTSUP when the server does not mesh (older than this
 * client); the server's ELIMIT, EBUSY, EINVAL, ENOMEM negated, with its
 * words in ei. */
BC_API int bc_client_mesh(struct bc_client *c, int format, uint8_t options,
                          uint16_t resolution, int timeout_ms,
                          struct bc_client_mesh *out, struct bc_errinfo *ei);

/* The session's undo history, newest first, at most BC_PROTO_MAX_HISTORY
 * (HISTORY_GET): *out receives a bc_malloc'ed array of *n entries (NULL
 * when none) the caller bc_free's; *order (may be NULL) the session's
 * order number. Any role, in a session; BC_ENOTSUP when the server has no
 * per-person undo. */
BC_API int bc_client_history(struct bc_client *c, struct bc_client_change **out,
                             size_t *n, uint64_t *order, struct bc_errinfo *ei);

/* One session of the server (bc_client_sessions). */
struct bc_client_session {
	char name[BC_PROTO_MAX_NAME + 1];
	uint32_t members;      /* connected members */
	uint32_t prims;        /* primitives (known only) */
	uint64_t order;        /* last edit order number (known only) */
	uint64_t last_edit_ms; /* Unix ms of its last change; 0: unknown */
	bool loaded;           /* in the server's memory */
	bool known;            /* prims, order and last_edit_ms are given */
};

/* Lists the server's sessions by name (SESSION_LIST), up to 1024: *out
 * receives a bc_malloc'ed array of *n entries (NULL when none) the caller
 * bc_free's. Allowed in or out of a session. */
BC_API int bc_client_sessions(struct bc_client *c,
                              struct bc_client_session **out, size_t *n,
                              struct bc_errinfo *ei);

/* The scene mirror: the session's scene as of bc_client_info()->order, or
 * NULL before the first SCENE_STATE (or if an edit could not be replayed on
 * it, which is logged). Owned by c; valid until the next call on c. cam
 * (may be NULL) receives the scene's camera. */
BC_API const struct bc_tree *bc_client_scene(const struct bc_client *c,
                                             struct bc_camera *cam);

/* Sends SCENE_LOAD with scene bytes (the binary encoding) and waits for the
 * SCENE_STATE that acknowledges it; *order (may be NULL, reset on entry)
 * receives the new edit order. A scene over the server's max_payload goes
 * in parts when the server granted BC_PROTO_FEATURE_PARTS (else BC_ELIMIT,
 * nothing sent). A SCENE_STATE that comes in parts reaches the caller of
 * bc_client_recv() whole, as one message. */
BC_API int bc_client_load_scene(struct bc_client *c, const uint8_t *bytes,
                                size_t len, uint64_t *order,
                                struct bc_errinfo *ei);
/* Reads a scene file, JSON or binary (bc_scene_load_file), and encodes it
 * with its camera: *bytes (bc_malloc'ed, the caller bc_free's) and *len are
 * what bc_client_load_scene() sends, *nodes (may be NULL) its node count.
 * Needs no connection, so a program can refuse a bad file before it
 * connects. Returns 0, or the reading's or encoding's error with the
 * reason (*bytes NULL). */
BC_API int bc_client_read_scene_file(const char *path, uint8_t **bytes,
                                     size_t *len, uint32_t *nodes,
                                     struct bc_errinfo *ei);
/* Reads a scene file as bc_client_read_scene_file() does and loads it as
 * bc_client_load_scene() does. *nodes (may be NULL) receives its node
 * count (0 unless loaded). */
BC_API int bc_client_load_scene_file(struct bc_client *c, const char *path,
                                     uint64_t *order, uint32_t *nodes,
                                     struct bc_errinfo *ei);

/* Sends VIEW. Zero fields take defaults: encoding JPEG when this client
 * decodes it (else PNG), interactive quality 75, still quality 90,
 * downscale 1, still_encoding none (the still in encoding). width and
 * height are required. An encoding or still_encoding that the HELLO did
 * not announce, or a still_encoding without H.264 announced (a server
 * of an earlier text refuses its 9-byte form), is refused before sending
 * (BC_EINVAL). After an H.264 frame that does not decode, sending the
 * same VIEW again brings a key frame (PROTOCOL.md 7.15). */
BC_API int bc_client_view(struct bc_client *c, const struct bc_msg_view *view,
                          uint32_t *seq_out, struct bc_errinfo *ei);

/* Acknowledges every FRAME up to frame_no (its frame_no field) as shown
 * (FRAME_ACK, PROTOCOL.md 7.27). Only when the server granted ACKS
 * (opts.acks; else BC_ENOTSUP, nothing sent); the server answers a
 * frame_no not above the previous acknowledgement, or above its last
 * frame, with a non-fatal ERROR ERANGE. */
BC_API int bc_client_frame_ack(struct bc_client *c, uint32_t frame_no,
                               struct bc_errinfo *ei);

/* Sends CAMERA (this connection's camera; the server answers with a frame
 * when a VIEW is set, or with ERROR for an invalid camera). */
BC_API int bc_client_camera(struct bc_client *c, const struct bc_camera *cam,
                            bool interacting, uint32_t *seq_out,
                            struct bc_errinfo *ei);

/* Presents (on) or stops presenting in the session: PRESENT, then waits
 * for its OK (the PRESENTER that precedes it updates bc_client_info()).
 * A new presenter replaces the old; the members following follow it.
 * Stopping when not presenting changes nothing. Any role may present. */
BC_API int bc_client_present(struct bc_client *c, bool on,
                             struct bc_errinfo *ei);

/* Follows the presenter (on: this client's camera tracks the presenter's,
 * rendered at this client's VIEW, each change arriving as FOLLOW_CAMERA)
 * or stops. Waits for the OK. BC_ESTATE when nobody presents or this
 * client presents. Sending CAMERA ends a follow (PRESENTER says so).
 * bc_client_follow(c, false, ...) also just asks to hear PRESENTER. */
BC_API int bc_client_follow(struct bc_client *c, bool on,
                            struct bc_errinfo *ei);

/* Sets the session's stored camera (SESSION_CAMERA: what joiners start
 * from, what SCENE_STATE and the mirror carry; no member's own camera
 * moves) and waits for its SESSION_CAMERA_SET; *order (may be NULL, reset
 * on entry) receives the change's order number. Needs the editor role. */
BC_API int bc_client_session_camera(struct bc_client *c,
                                    const struct bc_camera *cam,
                                    uint64_t *order, struct bc_errinfo *ei);

/* Sends GET_STATS and waits for STATS, copied into *out (reset on entry). */
BC_API int bc_client_stats(struct bc_client *c, struct bc_msg_stats *out,
                           struct bc_errinfo *ei);
/* The same asking for parts (BC_PROTO_STATS_LOAD, optionally with
 * BC_PROTO_STATS_RESET; BC_PROTO_STATS_TLS, BC_PROTO_STATS_LINK;
 * BC_PROTO_STATS_MEMORY only of a server that granted
 * BC_PROTO_FEATURE_MEMORY): out->has_load, has_tls, has_link and
 * has_memory tell which sections came. */
BC_API int bc_client_stats_parts(struct bc_client *c, uint8_t parts,
                                 struct bc_msg_stats *out,
                                 struct bc_errinfo *ei);

/* ---- Edits
 * ----------------------------------------------------------------------- */

/*
 * Turns key=value strings into the fields of one SET operation on node, a
 * node of scene: for primitives translate=x,y,z rotate=x,y,z,w color=r,g,b
 * and the kind's parameter names (bc_prim_info: radius=0.4,
 * half_extents=0.5,0.5,0.5, ...; field BC_PROTO_FIELD_PARAM0 + k for the
 * k-th); for operators blend=B range=R kind=NAME (smooth_union, ...).
 * Values are comma-separated finite floats, exactly as many as the field
 * takes, each within BC_PROTO_MAX_ABS. fields must hold
 * BC_PROTO_MAX_SET_FIELDS; *nfields is reset on entry. Returns 0,
 * BC_ENONODE (node not in scene), BC_EINVAL (unknown or repeated key, wrong
 * number of values, no arguments), BC_EPARSE (not a number), BC_ENONFINITE,
 * BC_ERANGE or BC_ELIMIT (too many arguments), with the reason in ei.
 */
BC_API int bc_client_edit_parse(const struct bc_tree *scene, uint32_t node,
                                const char *const *kv, size_t n,
                                struct bc_proto_field *fields, uint8_t *nfields,
                                struct bc_errinfo *ei);

/* Sends EDIT with one SET operation on node. */
BC_API int bc_client_edit_set(struct bc_client *c, uint32_t node,
                              const struct bc_proto_field *fields,
                              uint8_t nfields, bool interacting,
                              uint32_t *seq_out, struct bc_errinfo *ei);

/* bc_client_edit_parse() against the scene mirror, then
 * bc_client_edit_set(). BC_ESTATE when there is no mirror (not joined). */
BC_API int bc_client_edit_kv(struct bc_client *c, uint32_t node,
                             const char *const *kv, size_t n, bool interacting,
                             uint32_t *seq_out, struct bc_errinfo *ei);

/* Waits for the EDIT_APPLIED of this client's EDIT seq; *order (may be NULL,
 * reset on entry) receives the order number the server gave it. */
BC_API int bc_client_wait_applied(struct bc_client *c, uint32_t seq,
                                  uint64_t *order, struct bc_errinfo *ei);

/* ---- Frames
 * ------------------------------------------------------------------------ */

/*
 * The client-side framebuffer that FRAMEs are assembled in. A frame carries
 * rectangles of an image of image_width x image_height pixels (the VIEW size,
 * or smaller: a refinement level n > 0 frame is one pixel per 2^n x 2^n
 * block of the view, ceil(view / 2^n) pixels, and a level-0 frame may be
 * downscaled); each one replaces those pixels. A frame of another image size
 * starts a new, empty image. Fields are read-only for users.
 *
 * Showing it: at level n > 0 pixel (i, j) is the view's pixel
 * (2^n i, 2^n j), the top-left of its block, so scale by 2^n from the top
 * left (the last column and row may reach past the view); at level 0 scale
 * width x height to view_width x view_height. While refining is true the
 * server sends finer frames without being asked.
 */
struct bc_client_image {
	uint32_t width, height;           /* pixels held */
	uint32_t view_width, view_height; /* the VIEW size they stand for */
	uint8_t *rgba; /* width * height * 4 bytes, row 0 on top, alpha 255 */
	bool complete; /* every pixel has come from a frame */
	/* The last frame applied. */
	uint32_t frame_no, camera_seq, seq;
	uint64_t order;
	uint16_t flags; /* STILL, SNAPSHOT, INCOMPLETE and the level bits */
	/* The refinement level, bc_proto_flags_level(flags): 0 full
	 * resolution, n in 1..BC_PROTO_MAX_LEVEL one pixel per 2^n block. */
	uint8_t level;
	/* The picture is still being refined: level > 0 or INCOMPLETE (the
	 * server's time budget stopped refinement; more frames follow). */
	bool refining;
	enum bc_proto_encoding encoding;
	uint32_t nrects;
	/* The depth and id planes of the last frame applied, when it carried
	 * them (the answer to bc_client_snapshot_planes()), else NULL: width *
	 * height values each, row 0 on top, freed by the next frame applied
	 * and by finish. depth: distance along the ray, +inf on a miss; ids:
	 * node id of the primitive seen, 0 on a miss. */
	float *depth;
	uint32_t *ids;
	/* Private. */
	uint8_t *seen; /* one bit per pixel while !complete, or NULL */
	uint64_t nseen;
	void *tj;
	void *video; /* the H.264 decoder since the last KEY frame, or NULL */
};

/* init/finish on caller memory; finish accepts a zeroed image. */
BC_API void bc_client_image_init(struct bc_client_image *img);
BC_API void bc_client_image_finish(struct bc_client_image *img);

/*
 * Decodes the rectangles of FRAME m into img. Every rectangle must lie in
 * the image and decode to exactly its size. Returns 0, BC_EINVAL (not a
 * FRAME), BC_ERANGE (a rectangle outside the image), BC_ECODEC (bytes that
 * do not decode, or decode to another size; the pixels already written stay
 * and img->complete becomes false) or BC_ENOMEM, with the reason in ei.
 *
 * H.264 frames (encoding 4, PROTOCOL.md 7.15) are a chain: img keeps a
 * software decoder (libavcodec), started by a KEY frame, and every frame
 * of the view must be applied, in order. A frame without KEY when there is
 * no chain (none started yet, or the last one failed) is refused with
 * BC_ESTATE, and a frame that does not decode with BC_ECODEC, which ends
 * the chain; either way img stays as it was, and the caller sends its VIEW
 * again (bc_client_view) to get a KEY frame. Frames of other encodings
 * (a PNG or raw still, VIEW still_encoding) leave the chain as it is.
 */
BC_API int bc_client_image_apply(struct bc_client_image *img,
                                 const struct bc_msg *m, struct bc_errinfo *ei);

/* Sends SNAPSHOT (encoding PNG or RAW; 0 means PNG) and waits for its FRAME,
 * decoded into *out (which must be initialized; its previous contents are
 * replaced). A VIEW must have been sent: it gives the size. Returns 0 or a
 * BC_E* code with the reason in ei. */
BC_API int bc_client_snapshot(struct bc_client *c,
                              enum bc_proto_encoding encoding,
                              struct bc_client_image *out,
                              struct bc_errinfo *ei);

/* bc_client_snapshot() that also asks for the planes given by planes
 * (BC_PROTO_PLANE_DEPTH, BC_PROTO_PLANE_IDS; 0 is colour only): on success
 * out->depth and out->ids hold those asked (owned by out, freed by
 * bc_client_image_finish), at the colour's size. Returns 0, BC_EINVAL
 * (other plane bits, or an encoding other than PNG and raw), BC_EIO (the
 * answer lacks a plane asked) or another BC_E* code, with ei. */
BC_API int bc_client_snapshot_planes(struct bc_client *c,
                                     enum bc_proto_encoding encoding,
                                     unsigned planes,
                                     struct bc_client_image *out,
                                     struct bc_errinfo *ei);

/* ---- Big snapshots
 * ------------------------------------------------------------------------ */

/* The tile edge bc_client_snapshot_big() asks for unless told: 1024^2
 * PNG tiles stay far under any max_frame_bytes a client sensibly sets,
 * and each is a short job for the server, so other sessions are not held
 * up behind one big picture. */
#define BC_CLIENT_BIG_TILE 1024u

/* Progress of bc_client_snapshot_big(): tiles arrived of total (a tile
 * asked for again counts again). */
typedef void (*bc_client_progress_fn)(void *ud, uint32_t done, uint32_t total);

/* Zero means default for every field but the size. */
struct bc_client_big_opts {
	uint32_t width, height;          /* the picture, 1..BC_PROTO_MAX_DIM */
	enum bc_proto_encoding encoding; /* PNG (0 or 2) or raw */
	unsigned planes;                 /* BC_PROTO_PLANE_* bits */
	/* Tile edge in pixels, rounded down to a multiple of 8 and capped at
	 * the server's max_dim; 0: BC_CLIENT_BIG_TILE. */
	uint32_t tile;
	uint32_t in_flight; /* tiles asked for at once, 1..4; 0: 2 */
	int timeout_ms;     /* for each tile; 0: the client's timeout */
	bc_client_progress_fn progress;
	void *ud;
};

/*
 * A lossless picture of width x height (up to 8192 x 8192, beyond the
 * server's VIEW limit) from this client's camera, asked for in tiles with
 * SNAPSHOT's tile form and assembled into *out (initialized; replaced):
 * out->rgba, and out->depth / out->ids when planes asked for them, at the
 * full size; out->order is the edit order every tile shows (a tile that
 * an edit overtook is asked for again), out->flags has INCOMPLETE when a
 * tile was cut by the server's time budget. A VIEW must have been sent
 * (any size: it plays no part). Needs the feature TILES (WELCOME).
 * Returns 0, BC_ENOTSUP (the server did not grant TILES), BC_ERANGE (a
 * size outside 1..8192), BC_EINVAL (encoding or planes), BC_ENOMEM,
 * BC_EBUSY (the scene or camera kept changing between tiles), or the
 * server's or the connection's error, with the reason in ei.
 */
BC_API int bc_client_snapshot_big(struct bc_client *c,
                                  const struct bc_client_big_opts *opts,
                                  struct bc_client_image *out,
                                  struct bc_errinfo *ei);

/*
 * The same picture without blocking, for a program with its own loop (the
 * viewer): bc_client_big_start() asks for the first tiles; each message
 * the program receives (bc_client_recv) goes to bc_client_big_take()
 * first, which answers BC_CLIENT_BIG_NOT_OURS (the program handles it as
 * usual), BC_CLIENT_BIG_MORE (a tile taken, more to come), BC_CLIENT_BIG_
 * DONE (*out is the whole picture) or a negative BC_E* code with ei (the
 * picture failed: free it). out must stay valid until then.
 * bc_client_big_free() ends it at any time (answers still on their way
 * are then not ours: a FRAME with SNAPSHOT the program did not ask for).
 */
enum {
	BC_CLIENT_BIG_NOT_OURS = 1,
	BC_CLIENT_BIG_MORE = 2,
	BC_CLIENT_BIG_DONE = 3,
};
struct bc_client_big;
BC_API int bc_client_big_start(struct bc_client *c,
                               const struct bc_client_big_opts *opts,
                               struct bc_client_image *out,
                               struct bc_client_big **big,
                               struct bc_errinfo *ei);
BC_API int bc_client_big_take(struct bc_client_big *b, const struct bc_msg *m,
                              struct bc_errinfo *ei);
/* Tiles arrived and in all, for a progress display. */
BC_API void bc_client_big_progress(const struct bc_client_big *b,
                                   uint32_t *done, uint32_t *total);
BC_API void bc_client_big_free(struct bc_client_big *b);
/* ---- Reconnecting
 * ------------------------------------------------------------------ */

/*
 * A program that outlives its connection (a viewer, `blobcast watch`) keeps
 * going across a daemon restart or a network drop like this:
 *
 *   bc_client_backoff_init(&b, 0, 0);
 *   ... bc_client_recv() fails, or a FATAL ERROR arrives, with code:
 *   if (bc_client_retry_useless(code)) stop;
 *   bc_client_disconnect(c); bc_client_backoff_reset(&b, now);
 *   ... once bc_client_backoff_due(&b, now):
 *   if ((rc = bc_client_rejoin(c, 0, &fresh, &ei)) == 0) {
 *           bc_client_destroy(c); c = fresh;  (send VIEW, CAMERA again)
 *   } else {
 *           bc_client_destroy(fresh);
 *           if (bc_client_retry_useless(rc)) stop;
 *           bc_client_backoff_next(&b, now);
 *   }
 *
 * The new connection is a new member of the session: a new member id, an
 * empty edit history of its own, no VIEW and the session's camera; what
 * the old connection had set up beyond the join is the caller's to send
 * again.
 */

/* The delays between attempts unless bc_client_backoff_init() is given
 * others: a restarting blobcastd is back well within a second, and a
 * longer outage is tried every few seconds, which costs the daemon
 * nothing noticeable. */
#define BC_CLIENT_BACKOFF_FIRST_MS 250
#define BC_CLIENT_BACKOFF_LONGEST_MS 4000

/*
 * Whether an error (a negative BC_E* code from connecting, joining, or a
 * connection that failed) would be met again by connecting again with the
 * same options: BC_EAUTH (the token or the certificate is refused),
 * BC_EPERM (the token does not grant the role), BC_EPROTO_VERSION (the
 * daemon speaks another version), BC_ENOSESSION (the session is gone; a
 * viewer cannot create it) and BC_EINVAL (options that are wrong in
 * themselves). Everything else may pass with time: the daemon down or
 * restarting (BC_EIO, BC_ECLOSED, BC_ETIMEOUT), busy, or a full session
 * (BC_ELIMIT) that empties as members leave.
 */
BC_API bool bc_client_retry_useless(int code);

/*
 * When to attempt again: the first attempt comes first_ms after the loss,
 * and each failed attempt doubles the delay up to longest_ms. Times are
 * milliseconds on any monotonic clock of the caller's (the same one for
 * every call). Fields are read-only for users; the struct lives in the
 * caller's memory and owns nothing.
 */
struct bc_client_backoff {
	int first_ms, longest_ms; /* as set by bc_client_backoff_init() */
	int delay_ms;             /* the delay last scheduled */
	unsigned attempts;        /* failed attempts since the last reset */
	double next_at;           /* when the next attempt is due */
};

/* Sets the delays (first_ms <= 0: BC_CLIENT_BACKOFF_FIRST_MS; longest_ms
 * <= 0: BC_CLIENT_BACKOFF_LONGEST_MS; a longest below the first is raised
 * to it), no attempts, and an attempt due at once (next_at 0). */
BC_API void bc_client_backoff_init(struct bc_client_backoff *b, int first_ms,
                                   int longest_ms);
/* The connection was lost at now_ms: no failed attempts yet, the delay
 * back to first_ms, the first attempt due at now_ms + first_ms. */
BC_API void bc_client_backoff_reset(struct bc_client_backoff *b, double now_ms);
/* An attempt failed at now_ms: counts it in attempts, doubles the delay
 * (at most longest_ms) and makes the next attempt due that much after
 * now_ms. Returns the new delay in milliseconds. */
BC_API int bc_client_backoff_next(struct bc_client_backoff *b, double now_ms);
/* Whether the next attempt is due at now_ms. */
BC_API bool bc_client_backoff_due(const struct bc_client_backoff *b,
                                  double now_ms);

/*
 * Closes c's socket now (TLS and WebSocket state with it), so that the
 * daemon sees this member leave at once rather than whenever it notices a
 * dead or confused connection, while c keeps its info, roster, scene
 * mirror and what bc_client_rejoin() needs. c's sticky error stays, or
 * becomes BC_ECLOSED when there was none; bc_client_fd() returns -1.
 * Accepts NULL and a client already disconnected; bc_client_destroy()
 * still frees c.
 */
BC_API void bc_client_disconnect(struct bc_client *c);

/*
 * Opens a new connection with the options old was connected with (their
 * strings are kept by old; timeout_ms, when not 0, replaces their
 * timeout_ms: a window that does not redraw while it waits wants a short
 * one) and, when old entered a session with bc_client_join(), joins that
 * session again with the same role. The join mode is the same, except
 * that BC_CLIENT_JOIN_CREATE becomes BC_CLIENT_JOIN_ANY: the session old
 * created may exist now. old is only read; it may be a connection that
 * failed. *out (reset on entry) receives the new client, which the caller
 * frees with bc_client_destroy() and, usually, puts in old's place; its
 * roster and scene mirror are those of the join.
 * Returns 0, or the error of bc_client_connect() (*out then NULL) or of
 * bc_client_join() (*out then the connection that could not join, for the
 * caller to inspect and destroy), with the reason in ei.
 */
BC_API int bc_client_rejoin(const struct bc_client *old, int timeout_ms,
                            struct bc_client **out, struct bc_errinfo *ei);

#endif
