/*
 * Scenes in parts (PROTOCOL.md 7.10.1): a scene whose SCENE_LOAD or
 * SCENE_STATE would pass a receiver's limit travels as several messages of
 * the same type, the first with header flag MORE, the middle ones with MORE
 * and CONT, the last with CONT. Here: the receiving side's assembly (a
 * client's for SCENE_STATE; a server's for SCENE_LOAD, as the test
 * servers use it -- blobcastd keeps big parts where they were read,
 * server/edits.c) and the head of a SCENE_STATE part, which the daemon
 * writes in front of a slice of one shared scene encoding.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/proto.h"

void bc_proto_parts_init(struct bc_proto_parts *p, size_t max, bool between)
{
	memset(p, 0, sizeof(*p));
	p->max = max && max < BC_PROTO_MAX_SCENE_BYTES
	             ? max
	             : (size_t)BC_PROTO_MAX_SCENE_BYTES;
	p->between = between;
}

void bc_proto_parts_drop(struct bc_proto_parts *p)
{
	bc_free(p->data);
	p->data = NULL;
	p->len = p->cap = 0;
	p->open = false;
}

void bc_proto_parts_finish(struct bc_proto_parts *p)
{
	bc_proto_parts_drop(p);
}

/* The scene field of a SCENE_LOAD or SCENE_STATE. */
static const struct bc_proto_bytes *scene_of(const struct bc_msg *m)
{
	return m->type == BC_MSG_SCENE_LOAD ? &m->scene_load.scene
	                                    : &m->scene_state.scene;
}

/* Whether m continues the SCENE_STATE p holds: the same order, author and
 * author_seq in every part. */
static bool same_state(const struct bc_proto_parts *p, const struct bc_msg *m)
{
	return m->type != BC_MSG_SCENE_STATE ||
	       (m->scene_state.order == p->order &&
	        m->scene_state.author == p->author &&
	        m->scene_state.author_seq == p->author_seq);
}

static int append(struct bc_proto_parts *p, const struct bc_proto_bytes *b,
                  struct bc_errinfo *ei)
{
	if (b->len > p->max - p->len) {
		size_t len = p->len;
		bc_proto_parts_drop(p);
		return bc_errinfo_set(ei, BC_EPROTO_LENGTH,
		                      "a scene in parts of more than %zu bytes "
		                      "(%zu so far, a part of %u more)",
		                      p->max, len, b->len);
	}
	if (p->len + b->len > p->cap) {
		size_t cap = p->cap ? p->cap : 65536u;
		uint8_t *grown;
		while (cap < p->len + b->len) {
			cap = cap > p->max / 2 ? p->max : cap * 2;
		}
		if (!(grown = bc_realloc(p->data, cap))) {
			bc_proto_parts_drop(p);
			return bc_errinfo_set(ei, BC_ENOMEM,
			                      "out of memory for a scene of "
			                      "%zu bytes",
			                      cap);
		}
		p->data = grown;
		p->cap = cap;
	}
	memcpy(p->data + p->len, b->ptr, b->len);
	p->len += b->len;
	return 0;
}

int bc_proto_parts_add(struct bc_proto_parts *p, const struct bc_msg *m,
                       struct bc_msg *out, struct bc_errinfo *ei)
{
	bool part =
	    (m->type == BC_MSG_SCENE_LOAD || m->type == BC_MSG_SCENE_STATE) &&
	    (m->flags & BC_PROTO_FLAGS_PARTS);
	int rc;
	if (!part) {
		if (p->open && !p->between) {
			bc_proto_parts_drop(p);
			return bc_errinfo_set(
			    ei, BC_EPROTO_FLAGS,
			    "a %s came between the parts of a scene",
			    bc_proto_type_name(m->type));
		}
		if (p->open && (m->type == BC_MSG_SCENE_LOAD ||
		                m->type == BC_MSG_SCENE_STATE)) {
			bc_proto_parts_drop(p); /* a whole scene replaces it */
		}
		*out = *m;
		return 1;
	}
	if (m->flags & BC_PROTO_FLAG_CONT) {
		if (!p->open || p->type != m->type || !same_state(p, m)) {
			bool was = p->open;
			bc_proto_parts_drop(p);
			/* A client may lose its first part to a refusal (not
			 * fatal); a server breaks the rule of 7.10.1. */
			return bc_errinfo_set(
			    ei, p->between ? BC_ESTATE : BC_EPROTO_FLAGS,
			    was ? "a %s part (CONT) that does not continue the "
			          "scene begun"
			        : "a %s part (CONT) with no scene begun: its "
			          "first part was refused, dropped or never "
			          "sent",
			    bc_proto_type_name(m->type));
		}
	} else {
		/* A first part: an unfinished scene is dropped. */
		if (p->open && !p->between) {
			bc_proto_parts_drop(p);
			return bc_errinfo_set(ei, BC_EPROTO_FLAGS,
			                      "a %s part began a scene before "
			                      "the last one ended",
			                      bc_proto_type_name(m->type));
		}
		p->len = 0;
		p->open = true;
		p->type = m->type;
		if (m->type == BC_MSG_SCENE_STATE) {
			p->order = m->scene_state.order;
			p->author = m->scene_state.author;
			p->author_seq = m->scene_state.author_seq;
		}
	}
	if ((rc = append(p, scene_of(m), ei))) {
		return rc;
	}
	if (m->flags & BC_PROTO_FLAG_MORE) {
		return 0;
	}
	p->open = false;
	*out = *m;
	out->flags = (uint16_t)(m->flags & ~BC_PROTO_FLAGS_PARTS);
	if (m->type == BC_MSG_SCENE_LOAD) {
		out->scene_load.scene.ptr = p->data;
		out->scene_load.scene.len = (uint32_t)p->len;
	} else {
		out->scene_state.scene.ptr = p->data;
		out->scene_state.scene.len = (uint32_t)p->len;
	}
	return 1;
}

void bc_proto_scene_state_head(uint8_t *out, uint16_t flags, uint64_t order,
                               uint32_t author, uint32_t author_seq,
                               uint32_t piece)
{
	out[0] = BC_PROTO_MAGIC0;
	out[1] = BC_PROTO_MAGIC1;
	out[2] = BC_PROTO_MAGIC2;
	out[3] = BC_PROTO_MAGIC3;
	out[4] = BC_PROTO_VERSION;
	out[5] = (uint8_t)BC_MSG_SCENE_STATE;
	bc_put_le16(out + 6, flags);
	bc_put_le32(out + 8, BC_PROTO_SCENE_STATE_FIXED + piece);
	bc_put_le32(out + 12, 0); /* seq: SCENE_STATE always carries 0 */
	bc_put_le64(out + 16, order);
	bc_put_le32(out + 24, author);
	bc_put_le32(out + 28, author_seq);
	bc_put_le32(out + 32, piece);
}

void bc_proto_mesh_data_head(uint8_t *out, uint32_t seq,
                             const struct bc_msg_mesh_data *md)
{
	out[0] = BC_PROTO_MAGIC0;
	out[1] = BC_PROTO_MAGIC1;
	out[2] = BC_PROTO_MAGIC2;
	out[3] = BC_PROTO_MAGIC3;
	out[4] = BC_PROTO_VERSION;
	out[5] = (uint8_t)BC_MSG_MESH_DATA;
	bc_put_le16(out + 6, 0);
	bc_put_le32(out + 8, BC_PROTO_MESH_DATA_FIXED + md->file.len);
	bc_put_le32(out + 12, seq);
	out[16] = (uint8_t)md->format;
	out[17] = md->options;
	bc_put_le16(out + 18, md->resolution);
	bc_put_le64(out + 20, md->order);
	bc_put_le32(out + 28, md->vertices);
	bc_put_le32(out + 32, md->triangles);
	bc_put_le32(out + 36, md->file.len);
}
