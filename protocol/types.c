/*
 * The table of message types: names, which side sends each, the header
 * flags each defines and the largest payload each can validly have (derived
 * from proto_limits.h, so a header announcing more is refused before a
 * single payload byte is buffered). Also the client state machine of
 * PROTOCOL.md as a function the server calls for every message.
 */
#include "wire.h"

#include <string.h>

/* A string field at its longest: u16 length and the bytes. */
#define STR_MAX(n) (2u + (n))

#define HELLO_MAX                                                              \
	(2u + 2u + 1u + 4u + STR_MAX(BC_PROTO_MAX_NAME) +                      \
	 STR_MAX(BC_PROTO_MAX_TOKEN) + 4u)
#define WELCOME_MAX                                                            \
	(2u + 4u + 4u + 4u + 4u + 2u + 2u + 2u + STR_MAX(BC_PROTO_MAX_NAME) +  \
	 4u)
#define ERROR_MAX (2u + STR_MAX(BC_PROTO_MAX_ERROR_TEXT))
#define SESSION_MAX (1u + STR_MAX(BC_PROTO_MAX_NAME))
#define SESSION_INFO_MAX                                                       \
	(4u + 4u + 1u + STR_MAX(BC_PROTO_MAX_NAME) + 2u +                      \
	 BC_PROTO_MAX_MEMBERS * (4u + 1u + STR_MAX(BC_PROTO_MAX_NAME)))
/* A SESSIONS entry: name, members, prims, order, last edit, flags. */
#define SESSION_ENTRY_MAX (STR_MAX(BC_PROTO_MAX_NAME) + 2u + 4u + 8u + 8u + 1u)
#define SESSIONS_MAX (2u + BC_PROTO_MAX_SESSIONS_LISTED * SESSION_ENTRY_MAX)
#define BULK BC_PROTO_MAX_PAYLOAD
/* STATS: the client's figures, then the optional load, TLS, link and
 * memory sections. */
#define STATS_MAX (64u + 44u + 9u + 32u + 28u)
/* A HISTORY entry: order, time, built_on, state, flags, author, what. */
#define HISTORY_ENTRY_MAX                                                      \
	(8u + 8u + 8u + 1u + 1u + STR_MAX(BC_PROTO_MAX_NAME) +                 \
	 STR_MAX(BC_PROTO_MAX_HISTORY_TEXT))
#define HISTORY_MAX (8u + 2u + BC_PROTO_MAX_HISTORY * HISTORY_ENTRY_MAX)
/* A camera: eye, target, up (3 f32 each) and fov_y_deg. */
#define CAMERA_SIZE 40u

static const struct bc__type_info types[BC_MSG_COUNT] = {
    [BC_MSG_HELLO] = {"HELLO", BC__FROM_CLIENT, 0, HELLO_MAX},
    [BC_MSG_WELCOME] = {"WELCOME", BC__FROM_SERVER, 0, WELCOME_MAX},
    [BC_MSG_ERROR] = {"ERROR", BC__FROM_BOTH, BC_PROTO_FLAG_FATAL, ERROR_MAX},
    [BC_MSG_PING] = {"PING", BC__FROM_BOTH, 0, 8},
    [BC_MSG_PONG] = {"PONG", BC__FROM_BOTH, 0, 8},
    [BC_MSG_OK] = {"OK", BC__FROM_SERVER, 0, 0},
    [BC_MSG_SESSION_CREATE] = {"SESSION_CREATE", BC__FROM_CLIENT, 0,
                               SESSION_MAX},
    [BC_MSG_SESSION_JOIN] = {"SESSION_JOIN", BC__FROM_CLIENT, 0, SESSION_MAX},
    [BC_MSG_SESSION_LEAVE] = {"SESSION_LEAVE", BC__FROM_CLIENT, 0, 0},
    [BC_MSG_SESSION_INFO] = {"SESSION_INFO", BC__FROM_SERVER, 0,
                             SESSION_INFO_MAX},
    [BC_MSG_SCENE_LOAD] = {"SCENE_LOAD", BC__FROM_CLIENT, BC_PROTO_FLAGS_PARTS,
                           BULK},
    [BC_MSG_SCENE_STATE] = {"SCENE_STATE", BC__FROM_SERVER,
                            BC_PROTO_FLAGS_PARTS, BULK},
    [BC_MSG_EDIT] = {"EDIT", BC__FROM_CLIENT, BC_PROTO_FLAG_INTERACTING, BULK},
    [BC_MSG_EDIT_APPLIED] = {"EDIT_APPLIED", BC__FROM_SERVER,
                             BC_PROTO_FLAG_INTERACTING | BC_PROTO_FLAG_UNDO |
                                 BC_PROTO_FLAG_REDO,
                             BULK},
    [BC_MSG_CAMERA] = {"CAMERA", BC__FROM_CLIENT, BC_PROTO_FLAG_INTERACTING,
                       CAMERA_SIZE},
    [BC_MSG_VIEW] = {"VIEW", BC__FROM_CLIENT, 0, 9},
    [BC_MSG_FRAME] = {"FRAME", BC__FROM_SERVER,
                      BC_PROTO_FLAG_STILL | BC_PROTO_FLAG_SNAPSHOT |
                          BC_PROTO_FLAG_INCOMPLETE | BC_PROTO_FLAG_LEVEL_MASK |
                          BC_PROTO_FLAG_DEPTH | BC_PROTO_FLAG_IDS |
                          BC_PROTO_FLAG_KEY,
                      BULK},
    [BC_MSG_PICK] = {"PICK", BC__FROM_CLIENT, 0, 4},
    [BC_MSG_PICK_RESULT] = {"PICK_RESULT", BC__FROM_SERVER, 0, 24},
    [BC_MSG_SNAPSHOT] = {"SNAPSHOT", BC__FROM_CLIENT, 0, 14},
    [BC_MSG_GET_STATS] = {"GET_STATS", BC__FROM_CLIENT, 0, 1},
    [BC_MSG_STATS] = {"STATS", BC__FROM_SERVER, 0, STATS_MAX},
    [BC_MSG_SESSION_DELETE] = {"SESSION_DELETE", BC__FROM_CLIENT, 0,
                               STR_MAX(BC_PROTO_MAX_NAME)},
    [BC_MSG_UNDO] = {"UNDO", BC__FROM_CLIENT, 0, 1},
    [BC_MSG_REDO] = {"REDO", BC__FROM_CLIENT, 0, 1},
    [BC_MSG_SESSION_LIST] = {"SESSION_LIST", BC__FROM_CLIENT, 0, 0},
    [BC_MSG_SESSIONS] = {"SESSIONS", BC__FROM_SERVER, 0, SESSIONS_MAX},
    [BC_MSG_PRESENT] = {"PRESENT", BC__FROM_CLIENT, 0, 1},
    [BC_MSG_FOLLOW] = {"FOLLOW", BC__FROM_CLIENT, 0, 1},
    [BC_MSG_PRESENTER] = {"PRESENTER", BC__FROM_SERVER, 0, 5},
    [BC_MSG_FOLLOW_CAMERA] = {"FOLLOW_CAMERA", BC__FROM_SERVER,
                              BC_PROTO_FLAG_INTERACTING, 4u + CAMERA_SIZE},
    [BC_MSG_SESSION_CAMERA] = {"SESSION_CAMERA", BC__FROM_CLIENT, 0,
                               CAMERA_SIZE},
    [BC_MSG_SESSION_CAMERA_SET] = {"SESSION_CAMERA_SET", BC__FROM_SERVER, 0,
                                   8u + 4u + 4u + CAMERA_SIZE},
    [BC_MSG_HISTORY_GET] = {"HISTORY_GET", BC__FROM_CLIENT, 0, 0},
    [BC_MSG_HISTORY] = {"HISTORY", BC__FROM_SERVER, 0, HISTORY_MAX},
    [BC_MSG_FRAME_ACK] = {"FRAME_ACK", BC__FROM_CLIENT, 0, 4},
    [BC_MSG_MESH] = {"MESH", BC__FROM_CLIENT, 0, 4},
    [BC_MSG_MESH_DATA] = {"MESH_DATA", BC__FROM_SERVER, 0, BULK},
};

const struct bc__type_info *bc__type_info(unsigned type)
{
	if (type == 0 || type >= BC_MSG_COUNT) {
		return NULL;
	}
	return &types[type];
}

int bc__check_flags(const struct bc__type_info *t, uint16_t flags,
                    struct bc_errinfo *ei)
{
	if (flags & ~t->flags) {
		return bc_errinfo_set(ei, BC_EPROTO_FLAGS,
		                      "%s with undefined flags 0x%04x", t->name,
		                      (unsigned)(flags & ~t->flags));
	}
	/* A refinement frame is never the final picture: STILL and SNAPSHOT
	 * name full-size images only. Only FRAME defines the level bits, so
	 * the test needs no look at the type. */
	unsigned level = bc_proto_flags_level(flags);
	if (level > 0 &&
	    (flags & (BC_PROTO_FLAG_STILL | BC_PROTO_FLAG_SNAPSHOT))) {
		return bc_errinfo_set(
		    ei, BC_EPROTO_FLAGS, "%s at level %u with %s", t->name,
		    level,
		    (flags & BC_PROTO_FLAG_SNAPSHOT) ? "SNAPSHOT" : "STILL");
	}
	/* The depth and id planes answer a SNAPSHOT only. Only FRAME
	 * defines them. */
	if ((flags & (BC_PROTO_FLAG_DEPTH | BC_PROTO_FLAG_IDS)) &&
	    !(flags & BC_PROTO_FLAG_SNAPSHOT)) {
		return bc_errinfo_set(
		    ei, BC_EPROTO_FLAGS, "%s with %s but not SNAPSHOT", t->name,
		    (flags & BC_PROTO_FLAG_DEPTH) ? "DEPTH" : "IDS");
	}
	return 0;
}

const char *bc_proto_type_name(enum bc_msg_type type)
{
	const struct bc__type_info *t = bc__type_info((unsigned)type);
	return t ? t->name : NULL;
}

const char *bc_proto_encoding_name(enum bc_proto_encoding e)
{
	switch (e) {
	case BC_PROTO_ENC_JPEG:
		return "jpeg";
	case BC_PROTO_ENC_PNG:
		return "png";
	case BC_PROTO_ENC_RAW:
		return "raw";
	case BC_PROTO_ENC_H264:
		return "h264";
	default:
		return "?";
	}
}

enum bc_msg_type bc_proto_type_from_name(const char *name)
{
	for (unsigned i = 1; name && i < BC_MSG_COUNT; i++) {
		if (strcmp(types[i].name, name) == 0) {
			return (enum bc_msg_type)i;
		}
	}
	return BC_MSG_INVALID;
}

int bc_proto_client_may_send(enum bc_proto_stage stage, enum bc_proto_role role,
                             enum bc_msg_type type)
{
	const struct bc__type_info *t = bc__type_info((unsigned)type);
	if (!t || !(t->from & BC__FROM_CLIENT)) {
		return BC_EPROTO_TYPE;
	}
	switch (type) {
	case BC_MSG_HELLO:
		return stage == BC_PROTO_STAGE_HELLO ? 0 : BC_ESTATE;
	case BC_MSG_PING:
		return 0;
	case BC_MSG_PONG:
	case BC_MSG_ERROR:
	case BC_MSG_CAMERA:
	case BC_MSG_VIEW:
	case BC_MSG_GET_STATS:
	case BC_MSG_FRAME_ACK:
	case BC_MSG_SESSION_DELETE:
	case BC_MSG_SESSION_LIST:
		return stage == BC_PROTO_STAGE_HELLO ? BC_ESTATE : 0;
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		return stage == BC_PROTO_STAGE_READY ? 0 : BC_ESTATE;
	case BC_MSG_SESSION_LEAVE:
	case BC_MSG_PICK:
	case BC_MSG_SNAPSHOT:
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
	case BC_MSG_HISTORY_GET:
	case BC_MSG_MESH:
		return stage == BC_PROTO_STAGE_SESSION ? 0 : BC_ESTATE;
	case BC_MSG_SCENE_LOAD:
	case BC_MSG_EDIT:
	case BC_MSG_UNDO:
	case BC_MSG_REDO:
	case BC_MSG_SESSION_CAMERA:
		if (stage != BC_PROTO_STAGE_SESSION) {
			return BC_ESTATE;
		}
		return role == BC_PROTO_ROLE_EDITOR ? 0 : BC_EPERM;
	default:
		return BC_EPROTO_TYPE;
	}
}

/* ---- Features (PROTOCOL.md 4) --------------------------------------------- */

static uint32_t ops_features(const struct bc_msg_edit_applied *ea)
{
	uint32_t f = 0;
	for (uint16_t i = 0; i < ea->nops; i++) {
		const struct bc_proto_edit_op *op = &ea->ops[i];
		struct bc_proto_scene_info info;
		if (op->kind == BC_PROTO_EDIT_NAME) {
			f |= BC_PROTO_FEATURE_NAMES;
		}
		if (op->subtree.len &&
		    bc_proto_scene_scan(op->subtree.ptr, op->subtree.len, &info,
		                        NULL) == 0) {
			f |= info.features;
		}
		for (uint8_t k = 0; k < op->nfields; k++) {
			if (op->fields[k].field == BC_PROTO_FIELD_OP_KIND &&
			    op->fields[k].count >= 1 &&
			    op->fields[k].v[0] >=
			        (float)BC_PROTO_OP_KIND_FIRST_UNARY) {
				f |= BC_PROTO_FEATURE_KINDS;
			}
		}
	}
	return f;
}

uint32_t bc_proto_msg_features(const struct bc_msg *m)
{
	struct bc_proto_scene_info info;
	switch (m->type) {
	case BC_MSG_FRAME:
		return bc_proto_flags_level(m->flags) ? BC_PROTO_FEATURE_LEVELS
		                                      : 0u;
	case BC_MSG_EDIT_APPLIED:
		return ((m->flags & (BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO))
		            ? BC_PROTO_FEATURE_UNDO
		            : 0u) |
		       ops_features(&m->edit_applied);
	case BC_MSG_SCENE_STATE:
		/* A part is not a scene alone: what its scene needs is the
		 * sender's to know (the server scans the whole scene). */
		if (m->flags & BC_PROTO_FLAGS_PARTS) {
			return BC_PROTO_FEATURE_PARTS;
		}
		return bc_proto_scene_scan(m->scene_state.scene.ptr,
		                           m->scene_state.scene.len, &info,
		                           NULL) == 0
		           ? info.features
		           : 0u;
	case BC_MSG_PRESENTER:
	case BC_MSG_FOLLOW_CAMERA:
	case BC_MSG_SESSION_CAMERA_SET:
		return BC_PROTO_FEATURE_PRESENT;
	default:
		return 0;
	}
}
