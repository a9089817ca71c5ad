/*
 * Encoders: struct bc_msg to bytes. Each type has one writer that runs
 * twice, first measuring (so the payload's size is known and checked before
 * the buffer grows) and then writing. The writer itself only refuses what
 * would not survive the trip onto the wire (a string longer than its length
 * field, a count over its limit, an enum that does not fit its byte); the
 * finished payload is then run through the decoder, so a message is
 * appended only if the decoder accepts it, and with the decoder's error
 * otherwise. That keeps one definition of "valid" for both directions.
 */
#include "wire.h"

#include <stdarg.h>
#include <stdio.h>

static void wfail(struct bc__w *w, int code, const char *fmt,
                  ...) BC__ERRINFO_PRINTF;

static void wfail(struct bc__w *w, int code, const char *fmt, ...)
{
	char reason[192];
	va_list ap;
	if (w->err) {
		return;
	}
	w->err = code;
	va_start(ap, fmt);
	vsnprintf(reason, sizeof(reason), fmt, ap);
	va_end(ap);
	bc_errinfo_set(w->ei, code, "encode: %s", reason);
}

static void w_str(struct bc__w *w, const char *what, struct bc_proto_str s,
                  uint32_t max)
{
	if (s.len > max) {
		wfail(w, BC_EPROTO_LENGTH, "%s length %u over %u", what, s.len,
		      max);
		return;
	}
	if (s.len && !s.ptr) {
		wfail(w, BC_EINVAL, "%s has a length but no bytes", what);
		return;
	}
	bc__put_u16(w, (uint16_t)s.len);
	bc__put_raw(w, s.ptr, s.len);
}

static void w_blob(struct bc__w *w, const char *what, struct bc_proto_bytes b)
{
	if (b.len && !b.ptr) {
		wfail(w, BC_EINVAL, "%s has a length but no bytes", what);
		return;
	}
	bc__put_u32(w, b.len);
	bc__put_raw(w, b.ptr, b.len);
}

/* Enums are held as ints but travel as one byte. */
static void w_enum(struct bc__w *w, const char *what, int v, int count)
{
	if (v < 0 || v >= count) {
		wfail(w, BC_EENUM, "%s = %d is out of range", what, v);
		return;
	}
	bc__put_u8(w, (uint8_t)v);
}

/* An array of n elements must exist and n must fit its limit. */
static bool w_count(struct bc__w *w, const char *what, unsigned n, unsigned max,
                    const void *arr)
{
	if (n > max) {
		wfail(w, BC_EPROTO_COUNT, "%s %u over %u", what, n, max);
		return false;
	}
	if (n && !arr) {
		wfail(w, BC_EINVAL, "%s %u with no array", what, n);
		return false;
	}
	return true;
}

static void w_f32v(struct bc__w *w, const float *v, int n)
{
	for (int i = 0; i < n; i++) {
		bc__put_f32(w, v[i]);
	}
}

static void w_ops(struct bc__w *w, uint16_t nops,
                  const struct bc_proto_edit_op *ops)
{
	if (!w_count(w, "op_count", nops, BC_PROTO_MAX_EDIT_OPS, ops)) {
		return;
	}
	bc__put_u16(w, nops);
	for (unsigned i = 0; i < nops && !w->err; i++) {
		const struct bc_proto_edit_op *op = &ops[i];
		w_enum(w, "op.kind", (int)op->kind, BC_PROTO_EDIT_COUNT);
		switch (op->kind) {
		case BC_PROTO_EDIT_SET:
			bc__put_u32(w, op->node);
			if (!w_count(w, "op.field_count", op->nfields,
			             BC_PROTO_MAX_SET_FIELDS, op->fields)) {
				return;
			}
			bc__put_u8(w, op->nfields);
			for (unsigned k = 0; k < op->nfields; k++) {
				const struct bc_proto_field *f = &op->fields[k];
				if (f->count > BC_PROTO_MAX_FIELD_VALUES) {
					wfail(w, BC_EPROTO_COUNT,
					      "field %u has %u values",
					      (unsigned)f->field,
					      (unsigned)f->count);
					return;
				}
				bc__put_u8(w, f->field);
				bc__put_u8(w, f->count);
				w_f32v(w, f->v, f->count);
			}
			break;
		case BC_PROTO_EDIT_INSERT:
			bc__put_u32(w, op->node);
			bc__put_u32(w, op->position);
			w_blob(w, "op.subtree", op->subtree);
			break;
		case BC_PROTO_EDIT_REMOVE:
			bc__put_u32(w, op->node);
			break;
		case BC_PROTO_EDIT_REPLACE:
			bc__put_u32(w, op->node);
			w_blob(w, "op.subtree", op->subtree);
			break;
		case BC_PROTO_EDIT_NAME:
			bc__put_u32(w, op->node);
			w_str(w, "op.name", op->name, BC_PROTO_MAX_NAME);
			break;
		default:
			/* INVALID: w_enum lets 0 through; the decoder
			 * refuses it with EENUM. */
			break;
		}
	}
}

static void w_frame(struct bc__w *w, const struct bc_msg_frame *f)
{
	bc__put_u32(w, f->frame_no);
	bc__put_u64(w, f->order);
	bc__put_u32(w, f->camera_seq);
	w_enum(w, "encoding", (int)f->encoding, BC_PROTO_ENC_COUNT);
	bc__put_u16(w, f->width);
	bc__put_u16(w, f->height);
	bc__put_u16(w, f->image_width);
	bc__put_u16(w, f->image_height);
	if (!w_count(w, "rect_count", f->nrects, BC_PROTO_MAX_RECTS,
	             f->rects)) {
		return;
	}
	bc__put_u16(w, f->nrects);
	for (unsigned i = 0; i < f->nrects; i++) {
		const struct bc_proto_rect *r = &f->rects[i];
		bc__put_u16(w, r->x);
		bc__put_u16(w, r->y);
		bc__put_u16(w, r->w);
		bc__put_u16(w, r->h);
		w_blob(w, "rect.data", r->data);
	}
}

static void w_camera(struct bc__w *w, const struct bc_msg_camera *c)
{
	w_f32v(w, c->eye, 3);
	w_f32v(w, c->target, 3);
	w_f32v(w, c->up, 3);
	bc__put_f32(w, c->fov_y_deg);
}

static void w_body(struct bc__w *w, const struct bc_msg *m)
{
	switch (m->type) {
	case BC_MSG_HELLO: {
		const struct bc_msg_hello *h = &m->hello;
		bc__put_u16(w, h->version_min);
		bc__put_u16(w, h->version_max);
		bc__put_u8(w, h->encodings);
		bc__put_u32(w, h->max_frame_bytes);
		w_str(w, "client_name", h->client_name, BC_PROTO_MAX_NAME);
		w_str(w, "token", h->token, BC_PROTO_MAX_TOKEN);
		if (h->has_features) {
			bc__put_u32(w, h->features);
		}
		break;
	}
	case BC_MSG_WELCOME: {
		const struct bc_msg_welcome *wl = &m->welcome;
		bc__put_u16(w, wl->version);
		bc__put_u32(w, wl->connection_id);
		bc__put_u32(w, wl->max_payload);
		bc__put_u32(w, wl->max_frame_bytes);
		bc__put_u32(w, wl->max_nodes);
		bc__put_u16(w, wl->max_dim);
		bc__put_u16(w, wl->max_members);
		bc__put_u16(w, wl->max_edit_ops);
		w_str(w, "server_id", wl->server_id, BC_PROTO_MAX_NAME);
		if (wl->has_features) {
			bc__put_u32(w, wl->features);
		}
		break;
	}
	case BC_MSG_ERROR:
		bc__put_u16(w, m->error.code);
		w_str(w, "text", m->error.text, BC_PROTO_MAX_ERROR_TEXT);
		break;
	case BC_MSG_PING:
	case BC_MSG_PONG:
		bc__put_u64(w, m->ping.stamp);
		break;
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		w_enum(w, "role", (int)m->session.role, BC_PROTO_ROLE_COUNT);
		w_str(w, "name", m->session.name, BC_PROTO_MAX_NAME);
		break;
	case BC_MSG_SESSION_INFO: {
		const struct bc_msg_session_info *s = &m->session_info;
		bc__put_u32(w, s->session_id);
		bc__put_u32(w, s->member_id);
		w_enum(w, "role", (int)s->role, BC_PROTO_ROLE_COUNT);
		w_str(w, "name", s->name, BC_PROTO_MAX_NAME);
		if (!w_count(w, "member_count", s->nmembers,
		             BC_PROTO_MAX_MEMBERS, s->members)) {
			break;
		}
		bc__put_u16(w, s->nmembers);
		for (unsigned i = 0; i < s->nmembers; i++) {
			bc__put_u32(w, s->members[i].id);
			w_enum(w, "member.role", (int)s->members[i].role,
			       BC_PROTO_ROLE_COUNT);
			w_str(w, "member.name", s->members[i].name,
			      BC_PROTO_MAX_NAME);
		}
		break;
	}
	case BC_MSG_SCENE_LOAD:
		w_blob(w, "scene", m->scene_load.scene);
		break;
	case BC_MSG_SCENE_STATE:
		bc__put_u64(w, m->scene_state.order);
		bc__put_u32(w, m->scene_state.author);
		bc__put_u32(w, m->scene_state.author_seq);
		w_blob(w, "scene", m->scene_state.scene);
		break;
	case BC_MSG_EDIT:
		w_ops(w, m->edit.nops, m->edit.ops);
		break;
	case BC_MSG_EDIT_APPLIED:
		bc__put_u64(w, m->edit_applied.order);
		bc__put_u32(w, m->edit_applied.author);
		bc__put_u32(w, m->edit_applied.author_seq);
		w_ops(w, m->edit_applied.nops, m->edit_applied.ops);
		if (m->flags & (BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO)) {
			bc__put_u64(w, m->edit_applied.target_order);
			w_str(w, "target_author", m->edit_applied.target_author,
			      BC_PROTO_MAX_NAME);
		}
		break;
	case BC_MSG_CAMERA:
		w_camera(w, &m->camera);
		break;
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
		bc__put_u8(w, m->toggle.on);
		break;
	case BC_MSG_PRESENTER:
		bc__put_u32(w, m->presenter.presenter);
		bc__put_u8(w, m->presenter.following);
		break;
	case BC_MSG_FOLLOW_CAMERA:
		bc__put_u32(w, m->follow_camera.presenter);
		w_camera(w, &m->follow_camera.camera);
		break;
	case BC_MSG_SESSION_CAMERA:
		w_camera(w, &m->session_camera);
		break;
	case BC_MSG_SESSION_CAMERA_SET:
		bc__put_u64(w, m->session_camera_set.order);
		bc__put_u32(w, m->session_camera_set.author);
		bc__put_u32(w, m->session_camera_set.author_seq);
		w_camera(w, &m->session_camera_set.camera);
		break;
	case BC_MSG_VIEW:
		bc__put_u16(w, m->view.width);
		bc__put_u16(w, m->view.height);
		w_enum(w, "encoding", (int)m->view.encoding,
		       BC_PROTO_ENC_COUNT);
		bc__put_u8(w, m->view.quality_interactive);
		bc__put_u8(w, m->view.quality_still);
		bc__put_u8(w, m->view.downscale);
		if (m->view.still_encoding != BC_PROTO_ENC_INVALID) {
			w_enum(w, "still_encoding", (int)m->view.still_encoding,
			       BC_PROTO_ENC_H264);
		}
		break;
	case BC_MSG_FRAME:
		w_frame(w, &m->frame);
		break;
	case BC_MSG_FRAME_ACK:
		bc__put_u32(w, m->frame_ack.frame_no);
		break;
	case BC_MSG_MESH:
		w_enum(w, "format", (int)m->mesh.format,
		       BC_PROTO_MESH_FORMAT_COUNT);
		bc__put_u8(w, m->mesh.options);
		bc__put_u16(w, m->mesh.resolution);
		break;
	case BC_MSG_MESH_DATA:
		w_enum(w, "format", (int)m->mesh_data.format,
		       BC_PROTO_MESH_FORMAT_COUNT);
		bc__put_u8(w, m->mesh_data.options);
		bc__put_u16(w, m->mesh_data.resolution);
		bc__put_u64(w, m->mesh_data.order);
		bc__put_u32(w, m->mesh_data.vertices);
		bc__put_u32(w, m->mesh_data.triangles);
		w_blob(w, "file", m->mesh_data.file);
		break;
	case BC_MSG_PICK:
		bc__put_u16(w, m->pick.x);
		bc__put_u16(w, m->pick.y);
		break;
	case BC_MSG_PICK_RESULT:
		bc__put_u16(w, m->pick_result.x);
		bc__put_u16(w, m->pick_result.y);
		bc__put_u32(w, m->pick_result.node);
		w_f32v(w, m->pick_result.position, 3);
		bc__put_f32(w, m->pick_result.depth);
		break;
	case BC_MSG_SNAPSHOT:
		w_enum(w, "encoding", (int)m->snapshot.encoding,
		       BC_PROTO_ENC_COUNT);
		/* Left out when 0: the one-byte SNAPSHOT of colour only;
		 * the tile form always has it. */
		if (m->snapshot.planes != 0 || m->snapshot.has_tile) {
			bc__put_u8(w, m->snapshot.planes);
		}
		if (m->snapshot.has_tile) {
			bc__put_u16(w, m->snapshot.full_width);
			bc__put_u16(w, m->snapshot.full_height);
			bc__put_u16(w, m->snapshot.tile_x);
			bc__put_u16(w, m->snapshot.tile_y);
			bc__put_u16(w, m->snapshot.tile_width);
			bc__put_u16(w, m->snapshot.tile_height);
		}
		break;
	case BC_MSG_STATS: {
		const struct bc_msg_stats *s = &m->stats;
		bc__put_u64(w, s->uptime_ms);
		bc__put_u64(w, s->frames);
		bc__put_u64(w, s->bytes);
		bc__put_u64(w, s->order);
		bc__put_u32(w, s->sessions);
		bc__put_u32(w, s->clients);
		bc__put_f32(w, s->render_ms_last);
		bc__put_f32(w, s->render_ms_avg);
		bc__put_f32(w, s->encode_ms_last);
		bc__put_f32(w, s->encode_ms_avg);
		bc__put_f32(w, s->edit_ms_avg);
		bc__put_f32(w, s->fps);
		if (s->has_load) {
			const struct bc_proto_load *l = &s->load;
			bc__put_f32(w, l->loop_turn_max_ms);
			bc__put_f32(w, l->loop_request_max_ms);
			bc__put_u32(w, l->render_workers);
			bc__put_u32(w, l->jobs_queued);
			bc__put_u32(w, l->jobs_running);
			bc__put_u64(w, l->view_bytes);
			bc__put_u64(w, l->view_cap);
			bc__put_u64(w, l->session_render_us);
		}
		if (s->has_tls) {
			bc__put_u64(w, s->tls_not_after_ms);
			bc__put_u8(w, s->tls_expiring);
		}
		if (s->has_link) {
			const struct bc_proto_link *l = &s->link;
			bc__put_u32(w, l->rtt_us);
			bc__put_u32(w, l->min_rtt_us);
			bc__put_u64(w, l->delivery_bps);
			bc__put_u32(w, l->unacked_bytes);
			bc__put_u32(w, l->frames_paced);
			bc__put_u64(w, l->frames_spoiled);
		}
		if (s->has_memory) {
			const struct bc_proto_memory *mm = &s->memory;
			bc__put_u64(w, mm->scene_nodes);
			bc__put_u64(w, mm->scene_nodes_cap);
			bc__put_u64(w, mm->session_nodes);
			bc__put_u32(w, mm->sessions_loaded);
		}
		break;
	}
	case BC_MSG_GET_STATS:
		/* Left out when 0: the first version's empty GET_STATS. */
		if (m->get_stats.parts != 0) {
			bc__put_u8(w, m->get_stats.parts);
		}
		break;
	case BC_MSG_SESSION_DELETE:
		w_str(w, "name", m->session_delete.name, BC_PROTO_MAX_NAME);
		break;
	case BC_MSG_SESSIONS: {
		const struct bc_msg_sessions *l = &m->sessions;
		if (!w_count(w, "session_count", l->nsessions,
		             BC_PROTO_MAX_SESSIONS_LISTED, l->sessions)) {
			break;
		}
		bc__put_u16(w, l->nsessions);
		for (unsigned i = 0; i < l->nsessions; i++) {
			const struct bc_proto_session_entry *s =
			    &l->sessions[i];
			w_str(w, "session.name", s->name, BC_PROTO_MAX_NAME);
			bc__put_u16(w, s->members);
			bc__put_u32(w, s->prims);
			bc__put_u64(w, s->order);
			bc__put_u64(w, s->last_edit_ms);
			bc__put_u8(w, s->flags);
		}
		break;
	}
	case BC_MSG_UNDO:
	case BC_MSG_REDO:
		/* Left out when 0: the first text's empty UNDO and REDO. */
		if (m->undo.scope != BC_PROTO_UNDO_DEFAULT) {
			w_enum(w, "scope", (int)m->undo.scope,
			       BC_PROTO_UNDO_SCOPE_COUNT);
		}
		break;
	case BC_MSG_HISTORY: {
		const struct bc_msg_history *h = &m->history;
		bc__put_u64(w, h->order);
		if (!w_count(w, "entry_count", h->nentries,
		             BC_PROTO_MAX_HISTORY, h->entries)) {
			break;
		}
		bc__put_u16(w, h->nentries);
		for (unsigned i = 0; i < h->nentries; i++) {
			const struct bc_proto_history_entry *e = &h->entries[i];
			if (e->order == 0) {
				wfail(w, BC_ERANGE, "entry.order is 0");
			}
			bc__put_u64(w, e->order);
			bc__put_u64(w, e->time_ms);
			bc__put_u64(w, e->built_on);
			w_enum(w, "entry.state", e->state ? (int)e->state : -1,
			       BC_PROTO_HISTORY_STATE_COUNT);
			if (e->flags & ~BC_PROTO_HISTORY_FLAGS_ALL) {
				wfail(w, BC_EPROTO_FLAGS,
				      "entry flags 0x%02x has undefined bits",
				      (unsigned)e->flags);
			}
			bc__put_u8(w, e->flags);
			w_str(w, "entry.author", e->author, BC_PROTO_MAX_NAME);
			w_str(w, "entry.what", e->what,
			      BC_PROTO_MAX_HISTORY_TEXT);
		}
		break;
	}
	default: /* OK, SESSION_LEAVE, SESSION_LIST, HISTORY_GET:
	          * no payload */
		break;
	}
}

int bc_proto_encode(struct bc_proto_buf *b, const struct bc_msg *m,
                    struct bc_errinfo *ei)
{
	const struct bc__type_info *t = bc__type_info((unsigned)m->type);
	if (!t) {
		return bc_errinfo_set(ei, BC_EPROTO_TYPE,
		                      "encode: type %d is unknown",
		                      (int)m->type);
	}
	int rc = bc__check_flags(t, m->flags, ei);
	if (rc < 0) {
		return rc;
	}
	struct bc__w measure = {.ei = ei};
	w_body(&measure, m);
	if (measure.err) {
		return measure.err;
	}
	size_t n = measure.n;
	if (n > t->max_payload) {
		return bc_errinfo_set(ei, BC_EPROTO_LENGTH,
		                      "encode: %s payload of %zu bytes is over "
		                      "its maximum %u",
		                      t->name, n, t->max_payload);
	}
	rc = bc__buf_reserve(b, BC_PROTO_HEADER_SIZE + n);
	if (rc < 0) {
		return bc_errinfo_set(ei, rc,
		                      "encode: %s of %zu bytes does not fit "
		                      "the buffer (%zu of %zu used)",
		                      t->name, n, b->len, b->max);
	}
	/* Written past b->len and committed only once checked, so a refused
	 * message leaves b as it was. */
	struct bc__w w = {.p = b->data + b->len,
	                  .cap = BC_PROTO_HEADER_SIZE + n};
	bc__put_u8(&w, BC_PROTO_MAGIC0);
	bc__put_u8(&w, BC_PROTO_MAGIC1);
	bc__put_u8(&w, BC_PROTO_MAGIC2);
	bc__put_u8(&w, BC_PROTO_MAGIC3);
	bc__put_u8(&w, BC_PROTO_VERSION);
	bc__put_u8(&w, (uint8_t)m->type);
	bc__put_u16(&w, m->flags);
	bc__put_u32(&w, (uint32_t)n);
	bc__put_u32(&w, m->seq);
	w_body(&w, m);
	struct bc_msg check = {
	    .type = m->type, .flags = m->flags, .seq = m->seq};
	rc = bc__decode_payload(NULL, &check,
	                        b->data + b->len + BC_PROTO_HEADER_SIZE, n, ei);
	if (rc < 0) {
		return rc;
	}
	b->len += BC_PROTO_HEADER_SIZE + n;
	return 0;
}
