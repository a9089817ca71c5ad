/*
 * The blobcast wire protocol codec: message structs to bytes and back, with
 * no I/O. protocol/PROTOCOL.md is the specification; this header is its C
 * form. The daemon and every C client link this same code.
 *
 * Reading is a push parser (hiredis reader style): feed it bytes as they
 * arrive, then call next() until it says it needs more. Every length and
 * count is checked against proto_limits.h and against the bytes actually
 * present before anything is allocated; an error is sticky.
 *
 * Writing appends whole messages to a struct bc_proto_buf, a growable buffer
 * whose ceiling is fixed at init. The encoder refuses any message that the
 * decoder would refuse, so the two are exact inverses: decoding what was
 * encoded gives back the same fields, and encoding what was decoded gives
 * back the same bytes.
 */
#ifndef BLOBCAST_PROTO_H
#define BLOBCAST_PROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/error.h"
#include "blobcast/export.h"
#include "blobcast/proto_fields.h"
#include "blobcast/proto_limits.h"

/* ---- Framing ------------------------------------------------------------ */

/* Every message starts with this 16-byte header (all integers little-endian):
 *   0  u8[4] magic "BCST"      4  u8 version      5  u8 type
 *   6  u16 flags               8  u32 payload length
 *  12  u32 seq
 */
#define BC_PROTO_HEADER_SIZE 16u
#define BC_PROTO_MAGIC0 0x42u /* 'B' */
#define BC_PROTO_MAGIC1 0x43u /* 'C' */
#define BC_PROTO_MAGIC2 0x53u /* 'S' */
#define BC_PROTO_MAGIC3 0x54u /* 'T' */
/* The protocol version this code speaks (the only one so far). */
#define BC_PROTO_VERSION 1u

/* Message types; the numbers are the wire values and are never reused. */
enum bc_msg_type {
	BC_MSG_INVALID = 0,
	BC_MSG_HELLO = 1,               /* client -> server */
	BC_MSG_WELCOME = 2,             /* server -> client */
	BC_MSG_ERROR = 3,               /* both */
	BC_MSG_PING = 4,                /* both */
	BC_MSG_PONG = 5,                /* both */
	BC_MSG_OK = 6,                  /* server -> client */
	BC_MSG_SESSION_CREATE = 7,      /* client -> server */
	BC_MSG_SESSION_JOIN = 8,        /* client -> server */
	BC_MSG_SESSION_LEAVE = 9,       /* client -> server */
	BC_MSG_SESSION_INFO = 10,       /* server -> client */
	BC_MSG_SCENE_LOAD = 11,         /* client -> server */
	BC_MSG_SCENE_STATE = 12,        /* server -> client */
	BC_MSG_EDIT = 13,               /* client -> server */
	BC_MSG_EDIT_APPLIED = 14,       /* server -> client */
	BC_MSG_CAMERA = 15,             /* client -> server */
	BC_MSG_VIEW = 16,               /* client -> server */
	BC_MSG_FRAME = 17,              /* server -> client */
	BC_MSG_PICK = 18,               /* client -> server */
	BC_MSG_PICK_RESULT = 19,        /* server -> client */
	BC_MSG_SNAPSHOT = 20,           /* client -> server */
	BC_MSG_GET_STATS = 21,          /* client -> server */
	BC_MSG_STATS = 22,              /* server -> client */
	BC_MSG_SESSION_DELETE = 23,     /* client -> server */
	BC_MSG_UNDO = 24,               /* client -> server */
	BC_MSG_REDO = 25,               /* client -> server */
	BC_MSG_SESSION_LIST = 26,       /* client -> server */
	BC_MSG_SESSIONS = 27,           /* server -> client */
	BC_MSG_PRESENT = 28,            /* client -> server */
	BC_MSG_FOLLOW = 29,             /* client -> server */
	BC_MSG_PRESENTER = 30,          /* server -> client */
	BC_MSG_FOLLOW_CAMERA = 31,      /* server -> client */
	BC_MSG_SESSION_CAMERA = 32,     /* client -> server */
	BC_MSG_SESSION_CAMERA_SET = 33, /* server -> client */
	BC_MSG_HISTORY_GET = 34,        /* client -> server */
	BC_MSG_HISTORY = 35,            /* server -> client */
	BC_MSG_FRAME_ACK = 36,          /* client -> server (feature ACKS) */
	BC_MSG_MESH = 37,               /* client -> server (feature MESH) */
	BC_MSG_MESH_DATA = 38,          /* server -> client */
	BC_MSG_COUNT
};

/* Header flag bits. Each is defined for some types only; a bit that is not
 * defined for the message's type must be 0 (BC_EPROTO_FLAGS). */
/* ERROR: the sender closes the connection after this message. */
#define BC_PROTO_FLAG_FATAL 0x0001u
/* CAMERA, EDIT: part of a continuous interaction (a drag); the server renders
 * at interactive quality until a message without it arrives. FOLLOW_CAMERA
 * copies it from the presenter's CAMERA. */
#define BC_PROTO_FLAG_INTERACTING 0x0001u
/* EDIT_APPLIED: the operations undo (UNDO) or redo (REDO) an earlier edit
 * of the session; the payload then ends with that edit's order and its
 * author's name. Never both. */
#define BC_PROTO_FLAG_UNDO 0x0002u
#define BC_PROTO_FLAG_REDO 0x0004u
/* FRAME: rendered at full size and still quality. */
#define BC_PROTO_FLAG_STILL 0x0001u
/* FRAME: the lossless answer to a SNAPSHOT (seq = that request's seq). */
#define BC_PROTO_FLAG_SNAPSHOT 0x0002u
/* FRAME: the server's time budget stopped refinement. The picture is
 * complete at its level (no background band); the server refines it when it
 * can. */
#define BC_PROTO_FLAG_INCOMPLETE 0x0004u
/* FRAME: the refinement level n (0..BC_PROTO_MAX_LEVEL) in bits 3..4. A
 * level n > 0 frame is one whole picture with one ray per 2^n x 2^n block
 * of the view: image_width = ceil(width / 2^n), image_height likewise, one
 * rectangle covering it, image pixel (i, j) being the view's pixel
 * (2^n i, 2^n j); never with STILL or SNAPSHOT. Frames at lower levels
 * follow unless the view, camera or scene changes. Level 0 is the frame
 * as it always was (whole image or damaged rectangles). */
#define BC_PROTO_FLAG_LEVEL_SHIFT 3
#define BC_PROTO_FLAG_LEVEL_MASK 0x0018u
/* The coarsest level: 2^3 = 8 = BC_PROTO_MAX_DOWNSCALE, the coarsest block
 * a client may accept (VIEW downscale). */
#define BC_PROTO_MAX_LEVEL 3u
/* FRAME, only with SNAPSHOT (else BC_EPROTO_FLAGS, a header rule): the
 * answer carries the depth plane, a rectangle after the colour one covering
 * the image, w * h little-endian f32 (distance along the ray, +inf on a
 * miss). Asked by SNAPSHOT's BC_PROTO_PLANE_DEPTH. */
#define BC_PROTO_FLAG_DEPTH 0x0020u
/* FRAME, only with SNAPSHOT: the answer carries the id plane, a rectangle
 * after the colour one (and the depth one, when there is one), w * h
 * little-endian u32 (node id of the primitive seen, 0 on a miss). Asked by
 * SNAPSHOT's BC_PROTO_PLANE_IDS. */
#define BC_PROTO_FLAG_IDS 0x0040u
/* FRAME of encoding 4 (H.264) only (else BC_EPROTO_FLAGS, at the encoding
 * field): the access unit is an IDR with its SPS and PPS in band, where a
 * decoder may start (PROTOCOL.md 7.15, "Encoding 4"). */
#define BC_PROTO_FLAG_KEY 0x0080u
/* SCENE_LOAD and SCENE_STATE (PROTOCOL.md 7.10.1): the message is one part
 * of a scene sent in parts. MORE: another part of the same scene follows;
 * CONT: this part continues the scene of the part before it. Neither: the
 * message holds the whole scene, as in the first text. */
#define BC_PROTO_FLAG_MORE 0x0001u
#define BC_PROTO_FLAG_CONT 0x0002u
#define BC_PROTO_FLAGS_PARTS (BC_PROTO_FLAG_MORE | BC_PROTO_FLAG_CONT)

/* SNAPSHOT's optional planes byte: the planes the answer carries besides
 * colour. Other bits: BC_EPROTO_FLAGS. Colour only leaves the byte out (a
 * present 0 is BC_ERANGE), so each SNAPSHOT has one encoding. */
#define BC_PROTO_PLANE_DEPTH 0x01u
#define BC_PROTO_PLANE_IDS 0x02u
#define BC_PROTO_PLANES_ALL 0x03u

/* GET_STATS parts (PROTOCOL.md 7.18): what STATS carries besides the
 * client's own figures. LOAD asks for the daemon's load section; RESET
 * (with LOAD only) then starts its maxima anew. */
#define BC_PROTO_STATS_LOAD 0x01u
#define BC_PROTO_STATS_RESET 0x02u
/* TLS asks for the TLS section: the certificate's end of validity. */
#define BC_PROTO_STATS_TLS 0x04u
/* LINK asks for the link section: what the server's TCP measures of the
 * path to this client, and how many frames waited for it. */
#define BC_PROTO_STATS_LINK 0x08u
/* MEMORY asks for the memory section: the scene nodes all sessions hold
 * and their cap (asked only of a server that granted
 * BC_PROTO_FEATURE_MEMORY). */
#define BC_PROTO_STATS_MEMORY 0x10u
#define BC_PROTO_STATS_PARTS_ALL 0x1fu

/* Features (PROTOCOL.md 4): what version 1 gained after its first text
 * (2026-11-22), each sent by a server only to a client that announced it
 * in HELLO and saw it granted in WELCOME. */
#define BC_PROTO_FEATURE_LEVELS 0x01u  /* FRAME's LEVEL (coarse levels) */
#define BC_PROTO_FEATURE_UNDO 0x02u    /* EDIT_APPLIED's UNDO and REDO */
#define BC_PROTO_FEATURE_PRESENT 0x04u /* types 30, 31 and 33 */
#define BC_PROTO_FEATURE_KINDS 0x08u   /* prim kinds 17..32, unary nodes */
/* Not something the server sends but a request form it accepts: granted,
 * the client may send SNAPSHOT's tile form (PROTOCOL.md 7.17). */
#define BC_PROTO_FEATURE_TILES 0x10u
/* A request form too: granted, the client may send UNDO and REDO with a
 * scope byte (its own changes, or the session's) and HISTORY_GET
 * (PROTOCOL.md 7.20, 7.26). */
#define BC_PROTO_FEATURE_HISTORY 0x20u
/* Node names: scenes' names table (scene flag bit 1) and NAME operations
 * (PROTOCOL.md 4.1, 8, 9). */
#define BC_PROTO_FEATURE_NAMES 0x40u
/* A request form: granted, the client sends FRAME_ACK and the server keeps
 * at most BC_PROTO_ACK_WINDOW of its view's FRAMEs unacknowledged
 * (PROTOCOL.md 7.27). */
#define BC_PROTO_FEATURE_ACKS 0x80u
/* Scenes in parts (PROTOCOL.md 7.10.1): a SCENE_STATE that would pass the
 * client's limit comes as several messages (header flags MORE and CONT);
 * granted, the server also accepts SCENE_LOAD in parts. */
#define BC_PROTO_FEATURE_PARTS 0x100u
/* A request form: granted, the client may ask GET_STATS for the memory
 * section (BC_PROTO_STATS_MEMORY, PROTOCOL.md 7.18). */
#define BC_PROTO_FEATURE_MEMORY 0x200u
/* A request form: granted, the client may send MESH, which the server
 * answers with MESH_DATA (PROTOCOL.md 7.28). */
#define BC_PROTO_FEATURE_MESH 0x400u
#define BC_PROTO_FEATURES_ALL 0x7ffu
/* What a client that only reads may announce: every feature but ACKS,
 * which also binds the client to send FRAME_ACK for each FRAME. */
#define BC_PROTO_FEATURES_READ (BC_PROTO_FEATURES_ALL & ~BC_PROTO_FEATURE_ACKS)
/* FRAMEs of the view a client granted ACKS may have unacknowledged. */
#define BC_PROTO_ACK_WINDOW 2u
/* The features that decide what a server may send. */
#define BC_PROTO_FEATURES_SENT                                                 \
	(BC_PROTO_FEATURE_LEVELS | BC_PROTO_FEATURE_UNDO |                     \
	 BC_PROTO_FEATURE_PRESENT | BC_PROTO_FEATURE_KINDS |                   \
	 BC_PROTO_FEATURE_NAMES)
/* The scene kinds of the first text: primitives 1..16, binary operators
 * only. A scene beyond them needs BC_PROTO_FEATURE_KINDS. */
#define BC_PROTO_PRIM_KIND_MAX_FIRST 16u

/* The number of plane rectangles (0..2) a FRAME with these flags carries
 * after its colour rectangle. */
static inline unsigned bc_proto_flags_nplanes(uint16_t flags)
{
	return ((flags & BC_PROTO_FLAG_DEPTH) ? 1u : 0u) +
	       ((flags & BC_PROTO_FLAG_IDS) ? 1u : 0u);
}

/* The level of a FRAME's flags, 0..BC_PROTO_MAX_LEVEL. */
static inline unsigned bc_proto_flags_level(uint16_t flags)
{
	return (flags & BC_PROTO_FLAG_LEVEL_MASK) >> BC_PROTO_FLAG_LEVEL_SHIFT;
}

/* flags with its level field replaced by level (taken modulo 4; levels
 * above BC_PROTO_MAX_LEVEL do not exist). */
static inline uint16_t bc_proto_flags_with_level(uint16_t flags, unsigned level)
{
	return (uint16_t)((flags & ~BC_PROTO_FLAG_LEVEL_MASK) |
	                  ((level << BC_PROTO_FLAG_LEVEL_SHIFT) &
	                   BC_PROTO_FLAG_LEVEL_MASK));
}

/* The image size of a level's frame for a view size: ceil(dim / 2^level),
 * the number of 2^level blocks that cover dim pixels. */
static inline uint16_t bc_proto_level_dim(uint16_t dim, unsigned level)
{
	return (uint16_t)(((unsigned)dim + (1u << level) - 1u) >> level);
}

/* Which peer's messages a reader accepts. */
enum bc_proto_side {
	BC_PROTO_SIDE_ANY = 0, /* every type (tools, tests) */
	BC_PROTO_SIDE_SERVER,  /* a server reading what clients send */
	BC_PROTO_SIDE_CLIENT,  /* a client reading what servers send */
	BC_PROTO_SIDE_COUNT
};

enum bc_proto_role {
	BC_PROTO_ROLE_INVALID = 0,
	BC_PROTO_ROLE_EDITOR = 1,
	BC_PROTO_ROLE_VIEWER = 2,
	BC_PROTO_ROLE_COUNT
};

enum bc_proto_encoding {
	BC_PROTO_ENC_INVALID = 0,
	BC_PROTO_ENC_JPEG = 1,
	BC_PROTO_ENC_PNG = 2,
	BC_PROTO_ENC_RAW = 3, /* RGBA8, rows top to bottom, no padding */
	/* One H.264 access unit (Annex B) of the whole view, a chain of
	 * frames since the last KEY (PROTOCOL.md 7.15, "Encoding 4"). */
	BC_PROTO_ENC_H264 = 4,
	BC_PROTO_ENC_COUNT
};

/* HELLO.encodings bits: bit (encoding - 1) set = the client decodes it. */
#define BC_PROTO_ENCODINGS_ALL 0x0fu
/* The image encodings (JPEG, PNG, raw): what every server takes in HELLO
 * (a server of a text before H.264 refuses bit 3, PROTOCOL.md 7.1). */
#define BC_PROTO_ENCODINGS_IMAGES 0x07u

enum bc_proto_edit_kind {
	BC_PROTO_EDIT_INVALID = 0,
	BC_PROTO_EDIT_SET = 1,     /* set fields of node */
	BC_PROTO_EDIT_INSERT = 2,  /* insert subtree under node at position */
	BC_PROTO_EDIT_REMOVE = 3,  /* remove node and its subtree */
	BC_PROTO_EDIT_REPLACE = 4, /* replace node by subtree */
	BC_PROTO_EDIT_NAME = 5,    /* name node (empty: no name) */
	BC_PROTO_EDIT_COUNT
};

/* Field numbers of a set operation, the node kinds OP_KIND and the scene
 * encoding number, and what each field takes: blobcast/proto_fields.h. */

/* ---- Message fields ------------------------------------------------------ */

/* A string: UTF-8 without NUL, NOT NUL-terminated (print with "%.*s"). */
struct bc_proto_str {
	const char *ptr;
	uint32_t len;
};

/* An opaque byte range (scene bytes, encoded image bytes). */
struct bc_proto_bytes {
	const uint8_t *ptr;
	uint32_t len;
};

struct bc_msg_hello {
	uint16_t version_min, version_max; /* versions the client speaks */
	uint8_t encodings;                 /* bit (encoding - 1): decodes it */
	uint32_t max_frame_bytes; /* largest FRAME payload; 0 = server's */
	struct bc_proto_str client_name; /* 0..BC_PROTO_MAX_NAME bytes */
	struct bc_proto_str token;       /* 0..BC_PROTO_MAX_TOKEN bytes */
	/* The features field (BC_PROTO_FEATURE_*; unknown bits allowed, a
	 * server ignores them): sent when has_features; a HELLO without it
	 * is an earlier client's. */
	bool has_features;
	uint32_t features;
};

struct bc_msg_welcome {
	uint16_t version;              /* the version both will speak */
	uint32_t connection_id;        /* != 0 */
	uint32_t max_payload;          /* server's payload limit after HELLO */
	uint32_t max_frame_bytes;      /* FRAME payloads this client will get */
	uint32_t max_nodes;            /* nodes a session's scene may have */
	uint16_t max_dim;              /* largest VIEW width or height */
	uint16_t max_members;          /* clients per session */
	uint16_t max_edit_ops;         /* operations per EDIT */
	struct bc_proto_str server_id; /* 0..BC_PROTO_MAX_NAME bytes */
	/* The features granted, present (has_features) only when the HELLO
	 * had its features field: those announced that the server uses. */
	bool has_features;
	uint32_t features;
};

struct bc_msg_error {
	uint16_t code;            /* magnitude of a BC_E* code, >= 1 */
	struct bc_proto_str text; /* 0..BC_PROTO_MAX_ERROR_TEXT bytes */
};

/* PING and PONG: PONG echoes the PING's stamp (the sender's clock, opaque
 * to the receiver), so the pinger computes the round-trip time. */
struct bc_msg_ping {
	uint64_t stamp;
};

/* SESSION_CREATE and SESSION_JOIN. */
struct bc_msg_session {
	enum bc_proto_role role;
	struct bc_proto_str name; /* 1..BC_PROTO_MAX_NAME bytes */
};

struct bc_msg_session_delete {
	struct bc_proto_str name; /* 1..BC_PROTO_MAX_NAME bytes */
};

/* One session of a SESSIONS answer. */
struct bc_proto_session_entry {
	struct bc_proto_str name; /* 1..BC_PROTO_MAX_NAME bytes */
	uint16_t members;         /* connected members */
	uint32_t prims;           /* primitives of its scene */
	uint64_t order;           /* its last edit order number */
	uint64_t last_edit_ms;    /* when it changed, Unix ms; 0: unknown */
	uint8_t flags;            /* BC_PROTO_SESSION_* */
};
/* SESSIONS entry flags: the session is loaded in the server's memory; its
 * prims, order and last_edit_ms are known (else 0: a session on disk the
 * server has not loaded since it started). Other bits: EPROTO_FLAGS. */
#define BC_PROTO_SESSION_LOADED 0x01u
#define BC_PROTO_SESSION_KNOWN 0x02u
#define BC_PROTO_SESSION_FLAGS_ALL 0x03u

struct bc_msg_sessions {
	uint16_t nsessions; /* 0..BC_PROTO_MAX_SESSIONS_LISTED */
	const struct bc_proto_session_entry *sessions;
};

/* UNDO and REDO's optional scope byte (PROTOCOL.md 7.20). 0: the byte is
 * left out (a client not granted HISTORY: the session's newest change; one
 * granted it: its own). */
enum bc_proto_undo_scope {
	BC_PROTO_UNDO_DEFAULT = 0,
	BC_PROTO_UNDO_MINE = 1,    /* the sender's own newest change */
	BC_PROTO_UNDO_SESSION = 2, /* the session's, the owner or presenter */
	BC_PROTO_UNDO_SCOPE_COUNT
};

struct bc_msg_undo {
	uint8_t scope; /* enum bc_proto_undo_scope */
};

/* One change of a HISTORY answer (PROTOCOL.md 7.26). */
enum bc_proto_history_state {
	BC_PROTO_HISTORY_INVALID = 0,
	BC_PROTO_HISTORY_APPLIED = 1, /* in the scene: it can be undone */
	BC_PROTO_HISTORY_UNDONE = 2,  /* taken back: it can be redone */
	BC_PROTO_HISTORY_STATE_COUNT
};
/* HISTORY entry flags: the change is the receiver's own (its UNDO or REDO
 * of scope MINE may take it); it is the one the receiver's own UNDO
 * (applied) or REDO (undone) takes now. Other bits: EPROTO_FLAGS. */
#define BC_PROTO_HISTORY_YOURS 0x01u
#define BC_PROTO_HISTORY_NEXT 0x02u
#define BC_PROTO_HISTORY_FLAGS_ALL 0x03u

struct bc_proto_history_entry {
	uint64_t order;    /* the edit that made the change, >= 1 */
	uint64_t time_ms;  /* when, Unix ms; 0: unknown */
	uint64_t built_on; /* the newest later change built on it, or 0 */
	uint8_t state;     /* enum bc_proto_history_state */
	uint8_t flags;     /* BC_PROTO_HISTORY_* */
	struct bc_proto_str author; /* its author's client name */
	struct bc_proto_str what;   /* a short description */
};

struct bc_msg_history {
	uint64_t order;    /* the session's order number now */
	uint16_t nentries; /* 0..BC_PROTO_MAX_HISTORY, newest first */
	const struct bc_proto_history_entry *entries;
};

struct bc_proto_member {
	uint32_t id; /* != 0, unique in the session */
	enum bc_proto_role role;
	struct bc_proto_str name; /* the member's HELLO client_name */
};

struct bc_msg_session_info {
	uint32_t session_id;      /* != 0 */
	uint32_t member_id;       /* the receiver's own id, != 0 */
	enum bc_proto_role role;  /* the receiver's role */
	struct bc_proto_str name; /* session name */
	uint16_t nmembers;        /* 1..BC_PROTO_MAX_MEMBERS */
	const struct bc_proto_member *members;
};

struct bc_msg_scene_load {
	struct bc_proto_bytes scene; /* scene encoding, >= 1 byte */
};

struct bc_msg_scene_state {
	uint64_t order;      /* edit order number the state reflects */
	uint32_t author;     /* member whose SCENE_LOAD this is, or 0 */
	uint32_t author_seq; /* that member's SCENE_LOAD seq, or 0 */
	struct bc_proto_bytes scene;
};

struct bc_proto_field {
	uint8_t field; /* BC_PROTO_FIELD_* */
	uint8_t count; /* number of values */
	float v[BC_PROTO_MAX_FIELD_VALUES];
};

struct bc_proto_edit_op {
	enum bc_proto_edit_kind kind;
	uint32_t node;     /* SET, REMOVE, REPLACE: the node; INSERT: parent */
	uint32_t position; /* INSERT: child index (== child count: append) */
	struct bc_proto_bytes subtree; /* INSERT, REPLACE: scene encoding */
	uint8_t nfields;               /* SET: 1..BC_PROTO_MAX_SET_FIELDS */
	const struct bc_proto_field *fields;
	struct bc_proto_str name; /* NAME: 0..BC_PROTO_MAX_NAME bytes */
};

struct bc_msg_edit {
	uint16_t nops; /* 1..BC_PROTO_MAX_EDIT_OPS */
	const struct bc_proto_edit_op *ops;
};

struct bc_msg_edit_applied {
	uint64_t order;      /* server's order number, >= 1 */
	uint32_t author;     /* member id, != 0 */
	uint32_t author_seq; /* the EDIT's seq */
	uint16_t nops;
	const struct bc_proto_edit_op *ops;
	/* With BC_PROTO_FLAG_UNDO or _REDO only: the edit undone or redone
	 * (its order number, >= 1) and its author's client name. */
	uint64_t target_order;
	struct bc_proto_str target_author;
};

struct bc_msg_camera {
	float eye[3], target[3], up[3];
	float fov_y_deg; /* (0, 180) */
};

struct bc_msg_view {
	uint16_t width, height; /* 1..BC_PROTO_MAX_DIM */
	enum bc_proto_encoding encoding;
	uint8_t quality_interactive, quality_still; /* 1..100 */
	/* 1..BC_PROTO_MAX_DOWNSCALE: the coarsest block the client accepts;
	 * frames have 2^level <= downscale. */
	uint8_t downscale;
	/* The still's encoding (1..3), or 0: the still is in encoding. An
	 * optional ninth byte, left out when 0 (a present 0 is
	 * BC_EENUM). */
	enum bc_proto_encoding still_encoding;
};

struct bc_proto_rect {
	uint16_t x, y, w, h; /* in image pixels, row 0 on top */
	struct bc_proto_bytes data;
};

struct bc_msg_frame {
	uint32_t frame_no;
	uint64_t order;      /* last edit order number the frame reflects */
	uint32_t camera_seq; /* seq of the last CAMERA it reflects, or 0 */
	enum bc_proto_encoding encoding;
	uint16_t width, height; /* full (VIEW) size */
	/* Encoded size: at level n > 0 (bc_proto_flags_level(flags)) exactly
	 * ceil(width / 2^n) x ceil(height / 2^n); at level 0 at most the full
	 * size. */
	uint16_t image_width, image_height;
	uint16_t nrects; /* 1..BC_PROTO_MAX_RECTS */
	const struct bc_proto_rect *rects;
};

struct bc_msg_pick {
	uint16_t x, y; /* pixel in VIEW coordinates */
};

/* FRAME_ACK: every FRAME numbered up to frame_no (>= 1) is handled. */
struct bc_msg_frame_ack {
	uint32_t frame_no;
};

/* MESH's file formats (PROTOCOL.md 7.28), numbered as blobtree's
 * enum bc_mesh_format. */
enum bc_proto_mesh_format {
	BC_PROTO_MESH_INVALID = 0,
	BC_PROTO_MESH_OBJ = 1,
	BC_PROTO_MESH_PLY = 2,
	BC_PROTO_MESH_STL = 3,
	BC_PROTO_MESH_GLB = 4,
	BC_PROTO_MESH_FORMAT_COUNT
};
/* MESH options: RAW keeps every triangle (no edge collapse). */
#define BC_PROTO_MESH_RAW 0x01u
#define BC_PROTO_MESH_OPTIONS_ALL 0x01u

/* MESH: the session's solid as a mesh file. resolution 0 asks for
 * BC_PROTO_MESH_DEFAULT_RESOLUTION. */
struct bc_msg_mesh {
	enum bc_proto_mesh_format format;
	uint8_t options;     /* BC_PROTO_MESH_* */
	uint16_t resolution; /* 0, or 2..BC_PROTO_MAX_MESH_RESOLUTION */
};

/* MESH_DATA: the answer, the file whole. */
struct bc_msg_mesh_data {
	enum bc_proto_mesh_format format;
	uint8_t options;
	uint16_t resolution; /* the one used */
	uint64_t order;      /* the session's order the mesh is of */
	uint32_t vertices, triangles;
	struct bc_proto_bytes file;
};

struct bc_msg_pick_result {
	uint16_t x, y;
	uint32_t node;     /* primitive hit, 0 on a miss */
	float position[3]; /* world hit point; 0 on a miss */
	float depth;       /* distance from the eye, >= 0; 0 on a miss */
};

struct bc_msg_snapshot {
	enum bc_proto_encoding encoding; /* PNG or RAW */
	/* BC_PROTO_PLANE_* bits; 0: colour only. Encoded as an optional
	 * second byte, left out when 0, so a colour-only SNAPSHOT is the
	 * same one byte it always was (a present 0 does not decode), except
	 * in the tile form, which always carries it. */
	uint8_t planes;
	/* The tile form (feature TILES): the answer is the window of
	 * tile_width x tile_height pixels at (tile_x, tile_y) of a
	 * full_width x full_height picture from the client's camera, not
	 * the VIEW. full 1..BC_PROTO_MAX_DIM, the tile inside it. */
	bool has_tile;
	uint16_t full_width, full_height;
	uint16_t tile_x, tile_y, tile_width, tile_height;
};

/* GET_STATS: BC_PROTO_STATS_* bits; 0: the client's figures only. Encoded
 * as an optional byte, left out when 0, so the first version's empty
 * GET_STATS is the same message (a present 0 does not decode). */
struct bc_msg_get_stats {
	uint8_t parts;
};

/* STATS's load section, sent only to a GET_STATS that asked
 * BC_PROTO_STATS_LOAD: how busy the daemon is. Maxima run from the start
 * or from the last RESET. */
struct bc_proto_load {
	float loop_turn_max_ms;    /* longest busy turn of the event loop */
	float loop_request_max_ms; /* longest single request on the loop */
	uint32_t render_workers;
	uint32_t jobs_queued;  /* render jobs waiting for a worker */
	uint32_t jobs_running; /* render jobs started, not finished */
	uint64_t view_bytes;   /* the view cache's planes and renderer state */
	uint64_t view_cap;     /* its cap */
	/* Render time spent for the client's session (0: in none), us. */
	uint64_t session_render_us;
};

/* STATS's link section (PROTOCOL.md 7.18). */
struct bc_proto_link {
	uint32_t rtt_us;         /* smoothed round-trip time (0: unknown) */
	uint32_t min_rtt_us;     /* the least seen on this connection */
	uint64_t delivery_bps;   /* recent delivery rate, bytes per second */
	uint32_t unacked_bytes;  /* written, not yet acknowledged or sent */
	uint32_t frames_paced;   /* times a frame waited for the link */
	uint64_t frames_spoiled; /* frames a newer one replaced unsent */
};

/* STATS's memory section (PROTOCOL.md 7.18): scene nodes. */
struct bc_proto_memory {
	uint64_t scene_nodes;     /* held by all loaded sessions' scenes */
	uint64_t scene_nodes_cap; /* the most they may hold together */
	uint64_t session_nodes;   /* the client's session's (0: none) */
	uint32_t sessions_loaded;
};

struct bc_msg_stats {
	uint64_t uptime_ms;
	uint64_t frames; /* FRAMEs sent to this client */
	uint64_t bytes;  /* bytes sent to this client */
	uint64_t order;  /* latest edit order of the client's session */
	uint32_t sessions, clients; /* on the whole server */
	float render_ms_last, render_ms_avg;
	float encode_ms_last, encode_ms_avg;
	float edit_ms_avg; /* applying one EDIT */
	float fps;         /* frames per second sent to this client */
	bool has_load;     /* the load section follows (asked by LOAD) */
	struct bc_proto_load load;
	bool has_tls; /* the TLS section follows (asked by TLS) */
	/* The end of the server certificate's validity, Unix ms (0: the
	 * server listens without TLS), and whether fewer than 14 days are
	 * left. */
	uint64_t tls_not_after_ms;
	uint8_t tls_expiring;
	bool has_link; /* the link section follows (asked by LINK) */
	struct bc_proto_link link;
	bool has_memory; /* the memory section follows (asked by MEMORY) */
	struct bc_proto_memory memory;
};

/* PRESENT and FOLLOW: on 1 starts presenting (following), 0 stops; other
 * values: BC_ERANGE. */
struct bc_msg_toggle {
	uint8_t on;
};

/* PRESENTER: who presents in the receiver's session (0: nobody) and
 * whether the receiver follows (1 only with a presenter, else BC_ERANGE). */
struct bc_msg_presenter {
	uint32_t presenter;
	uint8_t following;
};

/* FOLLOW_CAMERA: the presenter's camera, which the receiver (a follower)
 * now renders from. */
struct bc_msg_follow_camera {
	uint32_t presenter; /* != 0 */
	struct bc_msg_camera camera;
};

/* SESSION_CAMERA_SET: the session's stored camera changed (the answer to
 * a SESSION_CAMERA, sent to every member). */
struct bc_msg_session_camera_set {
	uint64_t order;      /* the change's order number, >= 1 */
	uint32_t author;     /* member id, != 0 */
	uint32_t author_seq; /* that SESSION_CAMERA's seq */
	struct bc_msg_camera camera;
};

/* One message. Variable parts (strings, byte ranges, arrays) of a decoded
 * message point into the reader: strings and byte ranges into its input
 * buffer (zero copy), arrays (members, ops, fields, rects) into storage the
 * reader owns. Both stay valid until the next call of any function on that
 * reader. For encoding, the caller points them at its own memory. Types
 * without payload (OK, SESSION_LEAVE, SESSION_LIST, HISTORY_GET) use no
 * union member. */
struct bc_msg {
	enum bc_msg_type type;
	uint16_t flags;
	uint32_t seq;
	union {
		struct bc_msg_hello hello;
		struct bc_msg_welcome welcome;
		struct bc_msg_error error;
		struct bc_msg_ping ping;       /* PING and PONG */
		struct bc_msg_session session; /* CREATE and JOIN */
		struct bc_msg_session_info session_info;
		struct bc_msg_scene_load scene_load;
		struct bc_msg_scene_state scene_state;
		struct bc_msg_edit edit;
		struct bc_msg_edit_applied edit_applied;
		struct bc_msg_camera camera;
		struct bc_msg_view view;
		struct bc_msg_frame frame;
		struct bc_msg_pick pick;
		struct bc_msg_pick_result pick_result;
		struct bc_msg_snapshot snapshot;
		struct bc_msg_get_stats get_stats;
		struct bc_msg_stats stats;
		struct bc_msg_session_delete session_delete;
		struct bc_msg_sessions sessions;
		struct bc_msg_toggle toggle; /* PRESENT and FOLLOW */
		struct bc_msg_presenter presenter;
		struct bc_msg_follow_camera follow_camera;
		struct bc_msg_camera session_camera; /* SESSION_CAMERA */
		struct bc_msg_session_camera_set session_camera_set;
		struct bc_msg_undo undo; /* UNDO and REDO */
		struct bc_msg_history history;
		struct bc_msg_frame_ack frame_ack;
		struct bc_msg_mesh mesh;
		struct bc_msg_mesh_data mesh_data;
	};
};

/* ---- Reading ------------------------------------------------------------- */

/* Zero means default for every field. */
struct bc_proto_reader_opts {
	enum bc_proto_side side; /* types from the other side: EPROTO_TYPE */
	/* Payload limit; 0 or anything above BC_PROTO_MAX_PAYLOAD means
	 * BC_PROTO_MAX_PAYLOAD. A client sets its HELLO max_frame_bytes. */
	uint32_t max_payload;
	/* Start in the pre-HELLO stage: only HELLO and PING are accepted
	 * (others: BC_ESTATE) and payloads are limited to
	 * BC_PROTO_HELLO_MAX_PAYLOAD, until bc_proto_reader_hello_done(). */
	bool await_hello;
};

/* Array storage of decoded messages (private to the codec). */
struct bc_proto_store {
	struct bc_proto_member *members;
	struct bc_proto_edit_op *ops;
	struct bc_proto_field *fields;
	struct bc_proto_rect *rects;
	size_t members_cap, ops_cap, fields_cap, rects_cap;
	struct bc_proto_session_entry *sessions;
	size_t sessions_cap;
	struct bc_proto_history_entry *history;
	size_t history_cap;
};

struct bc_proto_reader {
	int err;          /* 0 or the sticky BC_E* error */
	char errstr[256]; /* the reason, when err != 0 */
	/* Everything below is private. */
	struct bc_proto_reader_opts opts;
	bool pre_hello;
	uint8_t *buf;
	size_t len, pos, cap; /* bytes buffered, parsed, allocated */
	struct bc_proto_store store;
	uint64_t nmsgs; /* messages returned so far (for error reasons) */
};

/* Sets up r with opts (which may be NULL). Allocates nothing; returns 0, or
 * BC_EINVAL for an out-of-range side. */
BC_API int bc_proto_reader_init(struct bc_proto_reader *r,
                                const struct bc_proto_reader_opts *opts);
/* Frees everything r holds; accepts NULL and a zeroed reader. */
BC_API void bc_proto_reader_finish(struct bc_proto_reader *r);

/* Appends n bytes (copied) to r. Returns 0, the sticky error if there is
 * one, BC_ENOMEM, or BC_ELIMIT when more than one whole message plus
 * BC_PROTO_READ_SLACK bytes would be waiting unparsed (drain with
 * bc_proto_reader_next() before feeding more). ENOMEM and ELIMIT are
 * sticky. */
BC_API int bc_proto_reader_feed(struct bc_proto_reader *r, const void *bytes,
                                size_t n);

/* Parses the next message into *out (reset on entry). Returns 1 (a
 * message), 0 (more bytes needed) or a negative BC_E* code, which is also
 * stored in r->err with a reason in r->errstr; after an error every call
 * returns it again. Header errors are reported as soon as the offending
 * header byte has arrived. See struct bc_msg for how long *out is valid. */
BC_API int bc_proto_reader_next(struct bc_proto_reader *r, struct bc_msg *out);

/* The stream has ended. Returns 0 if it ended between messages, otherwise
 * (a partial message is buffered) sets the sticky BC_EPROTO_TRUNCATED. */
BC_API int bc_proto_reader_eof(struct bc_proto_reader *r);

/* Ends the pre-HELLO stage (call once the peer's HELLO was accepted). */
BC_API void bc_proto_reader_hello_done(struct bc_proto_reader *r);

/* Changes the payload limit for messages whose header has not been parsed
 * yet (same rules as opts.max_payload). */
BC_API void bc_proto_reader_set_max_payload(struct bc_proto_reader *r,
                                            uint32_t max_payload);

/* Bytes buffered and not yet returned as messages. */
BC_API size_t bc_proto_reader_pending(const struct bc_proto_reader *r);

/* Hands the caller the buffer that the message last returned by next()
 * lies in, to free with bc_free: its byte ranges (a SCENE_LOAD's scene)
 * stay valid as long as the caller keeps the buffer, so a big payload is
 * kept without a copy. r goes on in a buffer of its own holding the bytes
 * after that message. Call it before the next feed() or next(). Returns
 * NULL when out of memory (or nothing is buffered), r unchanged. */
BC_API void *bc_proto_reader_detach(struct bc_proto_reader *r);

/* Decodes one payload of the given type, outside any stream: no header,
 * no side or stage rules, only the type's own payload checks (including its
 * maximum size). Arrays go to r's storage and byte ranges point into
 * payload; r's stream and sticky error are untouched. Returns 0 or a
 * negative BC_E* code with the reason in ei (which may be NULL). */
BC_API int bc_proto_decode_payload(struct bc_proto_reader *r,
                                   enum bc_msg_type type, uint16_t flags,
                                   uint32_t seq, const uint8_t *payload,
                                   size_t len, struct bc_msg *out,
                                   struct bc_errinfo *ei);

/* ---- Writing ------------------------------------------------------------- */

/* A growable output buffer with a ceiling fixed at init. */
struct bc_proto_buf {
	uint8_t *data;
	size_t len, cap, max;
};

/* max is the ceiling in bytes; 0 means one largest message
 * (BC_PROTO_HEADER_SIZE + BC_PROTO_MAX_PAYLOAD). Allocates nothing. */
BC_API void bc_proto_buf_init(struct bc_proto_buf *b, size_t max);
/* Frees the buffer; accepts NULL and a zeroed buffer. */
BC_API void bc_proto_buf_finish(struct bc_proto_buf *b);
/* Forgets the contents, keeps the memory. */
BC_API void bc_proto_buf_reset(struct bc_proto_buf *b);
/* Drops the first n bytes (those sent), keeping the rest in order. */
BC_API void bc_proto_buf_consume(struct bc_proto_buf *b, size_t n);

/* Appends m, header included, to b. Returns 0 or a negative code, and then
 * b is exactly as before: BC_EPROTO_TYPE (type out of range),
 * BC_EPROTO_FLAGS, BC_EPROTO_LENGTH (payload over its type's maximum),
 * BC_ELIMIT (b's ceiling), BC_ENOMEM, or the code the decoder would give
 * for an invalid field (ESTRING, ENONFINITE, ERANGE, EENUM, EPROTO_COUNT,
 * ...), with the reason in ei (which may be NULL). */
BC_API int bc_proto_encode(struct bc_proto_buf *b, const struct bc_msg *m,
                           struct bc_errinfo *ei);

/* ---- Scenes in parts (PROTOCOL.md 7.10.1) -------------------------------- */

/* Assembles a scene sent in parts (header flags MORE and CONT) from
 * SCENE_LOAD or SCENE_STATE messages, one scene at a time. */
struct bc_proto_parts {
	uint8_t *data; /* the pieces so far */
	size_t len, cap, max;
	bool open;    /* a part with MORE came last: the scene is unfinished */
	bool between; /* other messages may come between the parts */
	enum bc_msg_type type;
	uint64_t order; /* a SCENE_STATE's fields, the same in every part */
	uint32_t author, author_seq;
};

/* max: the most bytes a scene may have (0 or over it:
 * BC_PROTO_MAX_SCENE_BYTES). between: a server's SCENE_LOAD, whose parts
 * other requests may come between; a client reading SCENE_STATE passes
 * false (a server sends the parts of one scene one after another).
 * Allocates nothing. */
BC_API void bc_proto_parts_init(struct bc_proto_parts *p, size_t max,
                                bool between);
/* Forgets an unfinished scene and frees the buffer. */
BC_API void bc_proto_parts_drop(struct bc_proto_parts *p);
BC_API void bc_proto_parts_finish(struct bc_proto_parts *p);
/* Takes a decoded message m. Returns 1 when *out is whole: m itself when it
 * is not a part, or the scene's last part with every piece in its scene
 * field (pointing into p, valid until the next call) and MORE and CONT
 * cleared; 0 when m was a part and more must come; or a negative code, the
 * unfinished scene dropped: BC_ESTATE (between: a CONT part with no scene
 * begun), BC_EPROTO_FLAGS (not between: a CONT part that continues
 * nothing or a SCENE_STATE part whose order, author or author_seq differs
 * from the first part's, a first part or another message inside a scene),
 * BC_EPROTO_LENGTH (the scene would pass max), BC_ENOMEM. A whole
 * SCENE_LOAD or SCENE_STATE when between drops an unfinished scene. */
BC_API int bc_proto_parts_add(struct bc_proto_parts *p, const struct bc_msg *m,
                              struct bc_msg *out, struct bc_errinfo *ei);

/* SCENE_STATE's fields before its scene bytes: order, author, author_seq
 * and the byte range's length. */
#define BC_PROTO_SCENE_STATE_FIXED 20u
/* A SCENE_STATE part's bytes before its piece of the scene. */
#define BC_PROTO_SCENE_PART_HEAD                                               \
	(BC_PROTO_HEADER_SIZE + BC_PROTO_SCENE_STATE_FIXED)
/* Writes BC_PROTO_SCENE_PART_HEAD bytes to out: the header (seq 0, the
 * flags given, a payload of the fixed fields and piece bytes) and the
 * fields before the piece, which the caller sends after them. */
BC_API void bc_proto_scene_state_head(uint8_t *out, uint16_t flags,
                                      uint64_t order, uint32_t author,
                                      uint32_t author_seq, uint32_t piece);

/* MESH_DATA's fixed fields: format, options, resolution, order, vertices,
 * triangles and the file's length. */
#define BC_PROTO_MESH_DATA_FIXED 24u
/* A MESH_DATA's bytes before its file. */
#define BC_PROTO_MESH_DATA_HEAD                                                \
	(BC_PROTO_HEADER_SIZE + BC_PROTO_MESH_DATA_FIXED)
/* Writes BC_PROTO_MESH_DATA_HEAD bytes to out: the header (seq, no flags,
 * a payload of the fixed fields and md->file.len bytes) and the fields
 * before the file, which the caller sends after them (md->file.ptr is not
 * read). */
BC_API void bc_proto_mesh_data_head(uint8_t *out, uint32_t seq,
                                    const struct bc_msg_mesh_data *md);

/* ---- The scene encoding (owned by blobtree; see PROTOCOL.md) --------------
 */

struct bc_proto_scene_info {
	bool has_camera;
	uint32_t nodes, prims, ops;
	uint32_t depth;    /* most nodes on a path from the root (root = 1) */
	uint32_t zero_ids; /* nodes with id 0 (the decoder names them) */
	/* What a receiver must have announced to be sent these bytes:
	 * BC_PROTO_FEATURE_KINDS when a node is of a kind added after the
	 * first text, BC_PROTO_FEATURE_NAMES with a names table (PROTOCOL.md
	 * 4). */
	uint32_t features;
	uint32_t names;  /* entries of the names table (0: none) */
	size_t names_at; /* where the names table starts: the tree's end */
};

/* The scene flags byte (PROTOCOL.md 8). */
#define BC_PROTO_SCENE_FLAG_CAMERA 0x01u
#define BC_PROTO_SCENE_FLAG_NAMES 0x02u
/* Smallest names table entry: id, length and one byte. */
#define BC_PROTO_SCENE_NAME_MIN 7u

/* Checks scene bytes as PROTOCOL.md describes them, with the checks and the
 * check order of blobtree's decoder for everything the bytes alone decide
 * (flags, tags, counts, nesting, finite floats, sharp operators without
 * blend, exact length), without building anything: iterative, no
 * allocation, linear time. What needs the primitive tables or the whole
 * tree (each kind's exact float count, parameter ranges, camera geometry,
 * unique ids) is left to blobtree. Returns 0 with *info filled (it may be
 * NULL), or a negative code with the reason in ei. */
BC_API int bc_proto_scene_scan(const uint8_t *bytes, size_t len,
                               struct bc_proto_scene_info *info,
                               struct bc_errinfo *ei);

/* bc_proto_scene_scan that also calls visit(ud, id) with each node's id,
 * in the order of the encoding (an id of 0 too), as the scan reads it:
 * the ids of a subtree without building it. A visit that returns false
 * stops the scan (BC_ENOMEM); ids of bytes that fail later were visited
 * up to the failure. */
BC_API int bc_proto_scene_scan_ids(const uint8_t *bytes, size_t len,
                                   bool (*visit)(void *ud, uint32_t id),
                                   void *ud, struct bc_errinfo *ei);

/* Writers for the scene encoding, for clients and tests that build scene
 * bytes without blobtree: begin, then every node in pre-order. camera is
 * NULL or the 10 floats eye[3] target[3] up[3] fov_y_deg. color is NULL or
 * 3 floats. Each returns 0, BC_ELIMIT or BC_ENOMEM (and then b is as
 * before); the scanner, not the writers, checks the result. */
BC_API int bc_proto_scene_begin(struct bc_proto_buf *b, const float *camera,
                                uint32_t node_count);
BC_API int bc_proto_scene_prim(struct bc_proto_buf *b, uint8_t kind,
                               uint32_t id, const float translate[3],
                               const float rotate[4], const float *color,
                               uint8_t nparams, const float *params);
BC_API int bc_proto_scene_op(struct bc_proto_buf *b, uint8_t kind, uint32_t id,
                             float blend, float range, uint32_t child_count);
/* A unary or domain node (kind 7..14) and its nparams floats (at most
 * BC_PROTO_MAX_UNARY_PARAMS); its one child is the next node written. */
BC_API int bc_proto_scene_unary(struct bc_proto_buf *b, uint8_t kind,
                                uint32_t id, uint8_t nparams,
                                const float *params);
/* After the last node: the names table's count, which also sets the names
 * bit in the flags byte of the scene that starts at b->data[scene_at];
 * then count bc_proto_scene_name() calls, ids increasing, each name 1..64
 * bytes of UTF-8 (the scanner checks). */
BC_API int bc_proto_scene_names(struct bc_proto_buf *b, size_t scene_at,
                                uint32_t count);
BC_API int bc_proto_scene_name(struct bc_proto_buf *b, uint32_t id,
                               const char *name, size_t len);
/* For a receiver not granted NAMES (PROTOCOL.md 4.1): clears the names bit
 * of scene bytes[0..len) in place and returns the length without the names
 * table (len when the scene has none or does not scan). */
BC_API size_t bc_proto_scene_strip_names(uint8_t *bytes, size_t len);

/* ---- Names and rules ------------------------------------------------------
 */

/* "HELLO", "FRAME", ...; NULL when type is out of range. Static. */
BC_API const char *bc_proto_type_name(enum bc_msg_type type);
/* Type named name (as above), or BC_MSG_INVALID. */
BC_API enum bc_msg_type bc_proto_type_from_name(const char *name);
/* "jpeg", "png", "raw"; "?" for any other value. Static. */
BC_API const char *bc_proto_encoding_name(enum bc_proto_encoding e);

/* Where a client connection stands (PROTOCOL.md, "State machine"). */
enum bc_proto_stage {
	BC_PROTO_STAGE_HELLO = 0, /* default: connected, no HELLO yet */
	BC_PROTO_STAGE_READY,     /* WELCOME sent, in no session */
	BC_PROTO_STAGE_SESSION,   /* member of a session, with a role */
	BC_PROTO_STAGE_COUNT
};

/* The features (BC_PROTO_FEATURE_*) a receiver must have announced to be
 * sent m (PROTOCOL.md 4): LEVELS for a FRAME above level 0, UNDO for an
 * EDIT_APPLIED with UNDO or REDO, PRESENT for types 30, 31 and 33, KINDS
 * for a scene or an edit's subtree with a kind added after the first text
 * (scanned: linear in the scene's bytes) or a SET of a unary OP_KIND. */
BC_API uint32_t bc_proto_msg_features(const struct bc_msg *m);

/* Whether a client in stage (and, in a session, role) may send type.
 * Returns 0, BC_EPROTO_TYPE (not a client message), BC_ESTATE (not in this
 * stage) or BC_EPERM (not for this role). The server answers accordingly. */
BC_API int bc_proto_client_may_send(enum bc_proto_stage stage,
                                    enum bc_proto_role role,
                                    enum bc_msg_type type);

#endif
