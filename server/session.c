/*
 * Sessions (loop thread): a scene, its members and its edit order. Edits are
 * validated, applied atomically (a batch applies whole or not at all),
 * journaled and synced to disk, then broadcast as EDIT_APPLIED to every
 * member -- the author's copy is its acknowledgement. A parameter edit
 * touches only the edited nodes (blobtree keeps the layout); structural edits
 * are applied to a copy that replaces the scene when the whole batch is good.
 *
 * Frames are rendered on change only. Each member has a camera and a view;
 * while changes marked INTERACTING keep arriving, members get JPEG frames at
 * the interactive quality and downscale; BC_SRV_STILL_DELAY_MS after the last
 * one, a still at full size and still quality. A still after a parameter
 * edit carries only the damaged blocks: those covered by the edited
 * primitives' ABVs before and after. Members whose views are equal share one
 * render and one encode.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "server.h"

struct bc_session *bc_session_by_id(struct bc_srv *srv, uint32_t id)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (srv->sessions[i] && srv->sessions[i]->id == id) {
			return srv->sessions[i];
		}
	}
	return NULL;
}

static struct bc_session *session_by_name(struct bc_srv *srv, const char *name,
					  size_t len)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		if (s && strlen(s->name) == len && memcmp(s->name, name, len) == 0) {
			return s;
		}
	}
	return NULL;
}

/* ---- applying edits ------------------------------------------------------ */

/* Writes the fields of a SET operation into p or op (whichever the node
 * is). Returns 0 or an error with the reason. */
static int apply_fields(const struct bc_proto_edit_op *e, bool is_op,
			struct bc_prim_data *p, struct bc_op_data *op,
			struct bc_errinfo *ei)
{
	const struct bc_prim_info *info = is_op ? NULL : bc_prim_info(p->kind);
	for (uint32_t i = 0; i < e->nfields; i++) {
		const struct bc_proto_field *f = &e->fields[i];
		uint32_t want = 0;
		float *dst = NULL;
		if (!is_op && f->field == BC_PROTO_FIELD_TRANSLATE) {
			dst = p->translate;
			want = 3;
		} else if (!is_op && f->field == BC_PROTO_FIELD_ROTATE) {
			dst = p->rotate;
			want = 4;
		} else if (!is_op && f->field == BC_PROTO_FIELD_COLOR) {
			dst = p->color;
			want = 3;
			p->has_color = true;
		} else if (!is_op && f->field >= BC_PROTO_FIELD_PARAM0 &&
			   info &&
			   f->field < BC_PROTO_FIELD_PARAM0 + info->nparams) {
			const struct bc_param_desc *d =
				&info->params[f->field - BC_PROTO_FIELD_PARAM0];
			dst = p->params + d->offset;
			want = d->count;
		} else if (is_op && f->field == BC_PROTO_FIELD_BLEND) {
			dst = &op->blend;
			want = 1;
		} else if (is_op && f->field == BC_PROTO_FIELD_RANGE) {
			dst = &op->range;
			want = 1;
		} else if (is_op && f->field == BC_PROTO_FIELD_OP_KIND) {
			float k = f->v[0];
			if (f->count != 1 || !(k >= 1.0f) ||
			    !(k <= (float)(BC_OP_COUNT - 1)) || k != floorf(k)) {
				return bc_errinfo_set(ei, BC_EENUM,
						      "node %u: operator kind "
						      "must be an integer 1..%d",
						      e->node, BC_OP_COUNT - 1);
			}
			op->kind = (enum bc_op)(int)k;
			continue;
		} else {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "node %u: field %u does not "
					      "apply to a%s",
					      e->node, f->field,
					      is_op ? "n operator"
						    : " primitive of this kind");
		}
		if (f->count != want) {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "node %u: field %u takes %u "
					      "values, got %u",
					      e->node, f->field, want, f->count);
		}
		memcpy(dst, f->v, want * sizeof(float));
	}
	return 0;
}

static int apply_set(struct bc_tree *t, const struct bc_proto_edit_op *e,
		     struct bc_errinfo *ei)
{
	struct bc_prim_data p;
	struct bc_op_data op;
	int rc;
	if (!bc_tree_get(t, e->node, &p, &op)) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u",
				      e->node);
	}
	if ((rc = apply_fields(e, op.kind != BC_OP_INVALID, &p, &op, ei))) {
		return rc;
	}
	if (op.kind != BC_OP_INVALID) {
		return bc_tree_set_op(t, e->node, &op, ei);
	}
	return bc_tree_set_prim(t, e->node, &p, ei);
}

static int apply_structural(struct bc_tree *t, const struct bc_proto_edit_op *e,
			    struct bc_errinfo *ei)
{
	struct bc_tree *sub;
	int rc;
	if (e->kind == BC_PROTO_EDIT_REMOVE) {
		if (bc_tree_node_count(t) <= 1) {
			return bc_errinfo_set(ei, BC_EINVAL,
					      "cannot remove the last node");
		}
		return bc_tree_remove(t, e->node, ei);
	}
	if (!(sub = bc_tree_create())) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	rc = bc_scene_decode(e->subtree.ptr, e->subtree.len, sub, NULL, NULL,
			     ei);
	if (!rc && bc_tree_has_auto_ids(sub)) {
		/* EDIT_APPLIED repeats the subtree as sent: every member must
		 * be able to name its nodes alike. */
		rc = bc_errinfo_set(ei, BC_EINVAL,
				    "every node of an inserted or replacing "
				    "subtree needs an explicit id");
	}
	if (!rc) {
		rc = e->kind == BC_PROTO_EDIT_INSERT
			     ? bc_tree_insert(t, e->node, e->position, sub, ei)
			     : bc_tree_replace(t, e->node, sub, ei);
	}
	bc_tree_destroy(sub);
	return rc;
}

/* Saved parameters of a node, to roll a parameter batch back. */
struct undo {
	uint32_t id;
	struct bc_prim_data p;
	struct bc_op_data op;
};

/*
 * Applies a batch to the session's tree, whole or not at all. Parameter
 * batches are applied in place with an undo list; batches with structural
 * operations are applied to a copy; *structural tells whether the layout
 * changed.
 */
/* Restores the parameters saved in undo, newest first: each restore puts
 * back a state that was valid, so it cannot fail. */
static void roll_back(struct bc_tree *t, const struct undo *undo, uint32_t n)
{
	while (n-- > 0) {
		if (undo[n].op.kind != BC_OP_INVALID) {
			bc_tree_set_op(t, undo[n].id, &undo[n].op, NULL);
		} else {
			bc_tree_set_prim(t, undo[n].id, &undo[n].p, NULL);
		}
	}
}

static int apply_batch(struct bc_tree **tp, const struct bc_msg_edit *ed,
		       bool *structural,
		       struct bc_tree **replaced, struct undo **undo_out,
		       uint32_t *nundo_out, struct bc_errinfo *ei)
{
	struct bc_tree *t = *tp, *work = t;
	struct undo *undo = NULL;
	uint32_t nundo = 0;
	int rc = 0;
	*structural = false;
	*replaced = NULL;
	*undo_out = NULL;
	*nundo_out = 0;
	for (uint32_t i = 0; i < ed->nops; i++) {
		if (ed->ops[i].kind != BC_PROTO_EDIT_SET) {
			*structural = true;
		}
	}
	if (*structural) {
		if (!(work = bc_tree_create()) ||
		    (rc = bc_tree_copy(work, t, ei))) {
			bc_tree_destroy(work);
			return rc ? rc : bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		}
	} else if (!(undo = bc_calloc(ed->nops, sizeof(*undo)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	for (uint32_t i = 0; i < ed->nops && !rc; i++) {
		const struct bc_proto_edit_op *e = &ed->ops[i];
		if (e->kind == BC_PROTO_EDIT_SET) {
			if (!*structural) {
				undo[nundo].id = e->node;
				bc_tree_get(work, e->node, &undo[nundo].p,
					    &undo[nundo].op);
			}
			rc = apply_set(work, e, ei);
			if (!rc && !*structural) {
				nundo++;
			}
		} else {
			rc = apply_structural(work, e, ei);
		}
		if (rc) {
			/* Prefix the reason with the operation's index. */
			char why[sizeof(ei->msg)];
			memcpy(why, ei->msg, sizeof(why));
			bc_errinfo_set(ei, rc, "operation %u: %.200s", i, why);
		}
	}
	if (*structural) {
		if (rc) {
			bc_tree_destroy(work);
		} else {
			*replaced = t;
			*tp = work;
		}
	} else if (rc) {
		roll_back(t, undo, nundo);
	} else {
		*undo_out = undo;
		*nundo_out = nundo;
		undo = NULL;
	}
	bc_free(undo);
	return rc;
}

/* ---- sessions ------------------------------------------------------------ */

struct replay_ctx {
	struct bc_srv *srv;
	struct bc_tree **tree;
};

static int replay_record(void *ud, uint64_t order, const uint8_t *rec,
			 size_t len)
{
	struct replay_ctx *ctx = ud;
	struct bc_proto_reader r;
	struct bc_msg m;
	struct bc_errinfo ei = {0};
	struct bc_tree *old = NULL;
	struct undo *undo = NULL;
	uint32_t nundo = 0;
	bool structural;
	int rc;
	(void)order;
	bc_proto_reader_init(&r, NULL);
	rc = bc_proto_decode_payload(&r, BC_MSG_EDIT, 0, 0, rec, len, &m, &ei);
	if (!rc) {
		rc = apply_batch(ctx->tree, &m.edit, &structural, &old, &undo,
				 &nundo, &ei);
		bc_free(undo);
		bc_tree_destroy(old);
	}
	if (rc) {
		bc_log(BC_LOG_ERROR, "journal replay: %s", ei.msg);
	}
	bc_proto_reader_finish(&r);
	return rc;
}

static void free_session(struct bc_session *s)
{
	bc_store_session_close(s->store);
	bc_tree_destroy(s->tree);
	bc_free(s);
}

static void still_closed(uv_handle_t *h)
{
	struct bc_session *s = h->data;
	if (--s->handles_open == 0) {
		free_session(s);
	}
}

static void schedule(struct bc_session *s);

static void kick_due(uv_timer_t *t)
{
	schedule(t->data);
}

static void still_due(uv_timer_t *timer);

/* Opens (or creates, with the default scene) session name. */
static int session_open(struct bc_srv *srv, const char *name,
			struct bc_session **out, struct bc_errinfo *ei)
{
	struct bc_session *s;
	struct replay_ctx ctx;
	bool created;
	uint32_t slot = 0;
	struct bc_tree *copy;
	int rc;
	*out = NULL;
	while (slot < BC_SRV_MAX_SESSIONS && srv->sessions[slot]) {
		slot++;
	}
	if (slot == BC_SRV_MAX_SESSIONS) {
		return bc_errinfo_set(ei, BC_ELIMIT, "at most %u sessions",
				      BC_SRV_MAX_SESSIONS);
	}
	if (!(s = bc_calloc(1, sizeof(*s))) || !(s->tree = bc_tree_create())) {
		bc_free(s);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	s->srv = srv;
	snprintf(s->name, sizeof(s->name), "%s", name);
	bc_camera_default(&s->camera);
	ctx.srv = srv;
	ctx.tree = &s->tree;
	rc = bc_store_session_open(srv->store, name, &s->store, s->tree,
				   &s->camera, &s->order, &created,
				   replay_record, &ctx, ei);
	if (rc) {
		free_session(s);
		return rc;
	}
	if (created) {
		const char *json = bc_scene_default_json();
		if ((rc = bc_scene_parse_json(json, strlen(json), s->tree,
					      &s->camera, ei)) ||
		    (rc = bc_store_snapshot(s->store, s->tree, &s->camera, 0,
					    ei))) {
			free_session(s);
			return rc;
		}
	}
	if (!(copy = bc_tree_create()) || bc_tree_copy(copy, s->tree, NULL)) {
		bc_tree_destroy(copy);
		free_session(s);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	s->id = ++srv->next_session_id;
	s->next_member_id = 1;
	uv_timer_init(srv->loop, &s->still_timer);
	s->still_timer.data = s;
	uv_timer_init(srv->loop, &s->kick);
	s->kick.data = s;
	s->handles_open = 2;
	srv->sessions[slot] = s;
	srv->nsessions++;
	bc_rthread_scene(srv, s->id, copy);
	bc_log(BC_LOG_INFO, "session %s: %u primitives, edit order %llu%s",
	       name, bc_tree_prim_count(s->tree), (unsigned long long)s->order,
	       created ? " (new)" : "");
	*out = s;
	return 0;
}

static void restore_one(void *ud, const char *name)
{
	struct bc_srv *srv = ud;
	struct bc_session *s;
	struct bc_errinfo ei = {0};
	if (session_open(srv, name, &s, &ei)) {
		bc_log(BC_LOG_ERROR, "cannot restore session %s: %s", name,
		       ei.msg);
	}
}

int bc_sessions_restore(struct bc_srv *srv, struct bc_errinfo *ei)
{
	struct bc_session *s;
	bc_store_list(srv->store, restore_one, srv);
	if (!session_by_name(srv, "default", 7)) {
		return session_open(srv, "default", &s, ei);
	}
	return 0;
}

void bc_sessions_save_all(struct bc_srv *srv)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		struct bc_session *s = srv->sessions[i];
		struct bc_errinfo ei = {0};
		if (!s || s->store_failed ||
		    bc_store_journal_records(s->store) == 0) {
			continue;
		}
		if (bc_store_snapshot(s->store, s->tree, &s->camera, s->order,
				      &ei)) {
			bc_log(BC_LOG_ERROR, "session %s: %s", s->name, ei.msg);
		}
	}
}

void bc_sessions_free(struct bc_srv *srv)
{
	for (uint32_t i = 0; i < BC_SRV_MAX_SESSIONS; i++) {
		if (srv->sessions[i]) {
			uv_close((uv_handle_t *)&srv->sessions[i]->still_timer,
				 still_closed);
			uv_close((uv_handle_t *)&srv->sessions[i]->kick,
				 still_closed);
			srv->sessions[i] = NULL;
		}
	}
}

/* ---- members ------------------------------------------------------------- */

static void send_info(struct bc_session *s)
{
	struct bc_proto_member members[BC_PROTO_MAX_MEMBERS];
	uint32_t n = 0;
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_client *m = bc_client_get(s->srv, s->members[i]);
		if (m) {
			members[n].id = m->member_id;
			members[n].role = m->role;
			members[n].name.ptr = m->name;
			members[n].name.len = (uint32_t)strlen(m->name);
			n++;
		}
	}
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_client *m = bc_client_get(s->srv, s->members[i]);
		struct bc_msg info = {.type = BC_MSG_SESSION_INFO};
		if (!m || n == 0) {
			continue;
		}
		info.session_info.session_id = s->id;
		info.session_info.member_id = m->member_id;
		info.session_info.role = m->role;
		info.session_info.name.ptr = s->name;
		info.session_info.name.len = (uint32_t)strlen(s->name);
		info.session_info.nmembers = (uint16_t)n;
		info.session_info.members = members;
		bc_client_send(m, &info);
	}
}

static void send_state(struct bc_session *s, struct bc_client *to,
		       uint32_t author, uint32_t author_seq)
{
	struct bc_msg st = {.type = BC_MSG_SCENE_STATE};
	uint8_t *bytes = NULL;
	size_t len = 0;
	if (bc_scene_encode(s->tree, &s->camera, &bytes, &len)) {
		bc_log(BC_LOG_ERROR, "session %s: cannot encode the scene",
		       s->name);
		return;
	}
	st.scene_state.order = s->order;
	st.scene_state.author = author;
	st.scene_state.author_seq = author_seq;
	st.scene_state.scene.ptr = bytes;
	st.scene_state.scene.len = (uint32_t)len;
	if (to) {
		bc_client_send(to, &st);
	} else {
		for (uint32_t i = 0; i < s->nmembers; i++) {
			struct bc_client *m = bc_client_get(s->srv, s->members[i]);
			if (m) {
				bc_client_send(m, &st);
			}
		}
	}
	bc_free(bytes);
}

void bc_session_leave(struct bc_client *c)
{
	struct bc_session *s = c->session;
	struct bc_client_ref me = bc_client_ref_of(c);
	if (!s) {
		return;
	}
	for (uint32_t i = 0; i < s->nmembers; i++) {
		if (s->members[i].slot == me.slot && s->members[i].gen == me.gen) {
			s->members[i] = s->members[--s->nmembers];
			break;
		}
	}
	c->session = NULL;
	c->stage = BC_PROTO_STAGE_READY;
	c->role = BC_PROTO_ROLE_INVALID;
	c->render_pending = false;
	send_info(s);
}

static void mark_all(struct bc_session *s)
{
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_client *m = bc_client_get(s->srv, s->members[i]);
		if (m) {
			m->shown.view = 0; /* the next frame is whole */
			m->dirty = true;
		}
	}
}

static void schedule(struct bc_session *s);

static void join(struct bc_client *c, struct bc_session *s,
		 enum bc_proto_role role, uint32_t seq)
{
	(void)seq;
	if (s->nmembers >= BC_PROTO_MAX_MEMBERS) {
		bc_client_send_error(c, seq, BC_ELIMIT,
				     false, "session %s is full (%u members)",
				     s->name, BC_PROTO_MAX_MEMBERS);
		return;
	}
	if (c->session) {
		bc_session_leave(c);
	}
	s->members[s->nmembers++] = bc_client_ref_of(c);
	c->session = s;
	c->member_id = s->next_member_id++;
	c->role = role;
	c->stage = BC_PROTO_STAGE_SESSION;
	/* A camera the client chose (even before joining) stays its own. */
	if (!c->has_camera) {
		c->camera = s->camera;
		c->camera_seq = 0;
	}
	c->shown.view = 0;
	c->dirty = true;
	send_info(s);
	send_state(s, c, 0, 0);
	schedule(s);
}

static void handle_session(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	const struct bc_msg_session *req = &m->session;
	struct bc_session *s = session_by_name(srv, req->name.ptr, req->name.len);
	struct bc_errinfo ei = {0};
	char name[BC_PROTO_MAX_NAME + 1];
	if (req->role == BC_PROTO_ROLE_EDITOR &&
	    c->max_role != BC_PROTO_ROLE_EDITOR) {
		bc_client_send_error(c, m->seq, BC_EPERM, false,
				     "your token grants the viewer role only");
		return;
	}
	if (!bc_store_name_ok(req->name.ptr, req->name.len)) {
		bc_client_send_error(c, m->seq, BC_EINVAL, false,
				     "session names use letters, digits, '-', "
				     "'_' and '.', not starting with '.'");
		return;
	}
	memcpy(name, req->name.ptr, req->name.len);
	name[req->name.len] = '\0';
	if (m->type == BC_MSG_SESSION_CREATE) {
		if (s) {
			bc_client_send_error(c, m->seq, BC_EEXIST, false,
					     "session %s exists", name);
			return;
		}
		if (session_open(srv, name, &s, &ei)) {
			bc_client_send_error(c, m->seq, ei.code, false, "%s",
					     ei.msg);
			return;
		}
	} else if (!s) {
		bc_client_send_error(c, m->seq, BC_ENOSESSION, false,
				     "no session named %s", name);
		return;
	}
	join(c, s, req->role, m->seq);
}

/* ---- frames -------------------------------------------------------------- */

/* Two members can share a render when everything that shapes the frame is
 * equal. */
static bool same_frame(const struct bc_client *a, const struct bc_client *b,
		       bool still_a, bool still_b)
{
	return still_a == still_b &&
	       memcmp(&a->camera, &b->camera, sizeof(a->camera)) == 0 &&
	       a->view.width == b->view.width &&
	       a->view.height == b->view.height &&
	       a->view.encoding == b->view.encoding &&
	       a->view.quality_interactive == b->view.quality_interactive &&
	       a->view.quality_still == b->view.quality_still &&
	       a->view.downscale == b->view.downscale &&
	       a->encodings == b->encodings &&
	       memcmp(&a->shown, &b->shown, sizeof(a->shown)) == 0;
}

/* The coarsest refinement level a VIEW's downscale d accepts: the largest
 * n with 2^n <= d. */
static uint32_t max_level(uint32_t d)
{
	uint32_t n = 0;
	while (n < BC_PROTO_MAX_LEVEL && (2u << n) <= d) {
		n++;
	}
	return n;
}

static int frame_encoding(const struct bc_client *c, bool still)
{
	bool jpeg_ok = (c->encodings & (1u << (BC_PROTO_ENC_JPEG - 1))) != 0;
	if (!still && jpeg_ok) {
		return BC_PROTO_ENC_JPEG;
	}
	return (int)c->view.encoding;
}

static void still_due(uv_timer_t *timer)
{
	struct bc_session *s = timer->data;
	uint64_t now = bc_now_ms(s->srv);
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_client *m = bc_client_get(s->srv, s->members[i]);
		if (m && m->has_view && !m->still_sent &&
		    now >= m->interacting_until) {
			m->dirty = true;
		}
	}
	schedule(s);
}

static void schedule(struct bc_session *s)
{
	struct bc_srv *srv = s->srv;
	uint64_t now = bc_now_ms(srv), next_still = 0;
	struct bc_client *group[BC_PROTO_MAX_MEMBERS];
	bool done[BC_PROTO_MAX_MEMBERS] = {0};
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_client *c = bc_client_get(srv, s->members[i]);
		struct bc_rjob *job;
		uint32_t ng = 0, max_bytes;
		bool still;
		/* One frame in flight per client: while one is being
		 * written, changes only accumulate (the next frame shows the
		 * newest state); a client that stopped reading costs no
		 * renders. */
		if (!c || done[i] || !c->has_view || !c->dirty ||
		    c->render_pending || c->frame_writing) {
			continue;
		}
		still = now >= c->interacting_until;
		if (!still && (next_still == 0 || c->interacting_until > next_still)) {
			next_still = c->interacting_until;
		}
		group[ng++] = c;
		max_bytes = c->max_frame_bytes;
		for (uint32_t j = i + 1; j < s->nmembers; j++) {
			struct bc_client *o = bc_client_get(srv, s->members[j]);
			if (o && !done[j] && o->has_view && o->dirty &&
			    !o->render_pending && !o->frame_writing &&
			    same_frame(c, o, still, now >= o->interacting_until)) {
				group[ng++] = o;
				done[j] = true;
				if (o->max_frame_bytes < max_bytes) {
					max_bytes = o->max_frame_bytes;
				}
			}
		}
		if (!(job = bc_calloc(1, sizeof(*job))) ||
		    !(job->targets = bc_calloc(ng, sizeof(*job->targets)))) {
			bc_free(job);
			return;
		}
		job->session_id = s->id;
		job->camera = c->camera;
		job->width = c->view.width;
		job->height = c->view.height;
		job->encoding = frame_encoding(c, true);
		job->encoding_interactive = frame_encoding(c, false);
		job->quality_still = c->view.quality_still;
		job->quality_interactive = c->view.quality_interactive;
		job->max_level = max_level(c->view.downscale);
		job->final = still;
		job->shown = c->shown;
		job->camera_seq = c->camera_seq;
		job->order = s->order;
		job->frame_no = ++srv->frame_no;
		job->max_bytes = max_bytes;
		for (uint32_t g = 0; g < ng; g++) {
			struct bc_client *m = group[g];
			job->targets[g] = bc_client_ref_of(m);
			m->dirty = false;
			m->render_pending = true;
		}
		job->ntargets = ng;
		bc_rthread_job(srv, job);
	}
	if (next_still > now) {
		uv_timer_start(&s->still_timer, still_due, next_still - now, 0);
	}
}

void bc_session_client_ready(struct bc_client *c)
{
	/* Not at once: the other members' frame writes usually finish in the
	 * same loop turn, and scheduling after them keeps equal views in one
	 * shared render. */
	if (c->session && c->dirty) {
		uv_timer_start(&c->session->kick, kick_due, 0, 0);
	}
}

void bc_session_frame_done(struct bc_srv *srv, uint32_t session_id,
			   const struct bc_client_ref *targets, uint32_t n)
{
	struct bc_session *s = bc_session_by_id(srv, session_id);
	for (uint32_t i = 0; i < n; i++) {
		struct bc_client *c = bc_client_get(srv, targets[i]);
		if (c) {
			c->render_pending = false;
		}
	}
	if (s) {
		schedule(s);
	}
}

/* ---- messages ------------------------------------------------------------ */

static void handle_scene_load(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_tree *t = bc_tree_create(), *copy = bc_tree_create();
	struct bc_camera cam = s->camera;
	struct bc_errinfo ei = {0};
	bool has_cam = false;
	int rc;
	if (!t || !copy) {
		rc = bc_errinfo_set(&ei, BC_ENOMEM, "out of memory");
		goto fail;
	}
	if (s->store_failed) {
		rc = bc_errinfo_set(&ei, BC_EIO,
				    "the session cannot be saved: changes are "
				    "refused");
		goto fail;
	}
	if ((rc = bc_scene_decode(m->scene_load.scene.ptr,
				  m->scene_load.scene.len, t, &cam, &has_cam,
				  &ei))) {
		goto fail;
	}
	if (bc_tree_node_count(t) > BC_SRV_MAX_NODES) {
		rc = bc_errinfo_set(&ei, BC_ELIMIT, "more than %u nodes",
				    BC_SRV_MAX_NODES);
		goto fail;
	}
	if ((rc = bc_tree_copy(copy, t, &ei))) {
		goto fail;
	}
	/* On disk first: the load is acknowledged only once it is safe. */
	if ((rc = bc_store_snapshot(s->store, t, &cam, s->order + 1, &ei))) {
		s->store_failed = true;
		goto fail;
	}
	bc_tree_destroy(s->tree);
	s->tree = t;
	s->camera = cam;
	s->order++;
	bc_rthread_scene(c->srv, s->id, copy);
	send_state(s, NULL, c->member_id, m->seq);
	if (has_cam) {
		for (uint32_t i = 0; i < s->nmembers; i++) {
			struct bc_client *o = bc_client_get(c->srv, s->members[i]);
			if (o) {
				o->camera = cam;
			}
		}
	}
	mark_all(s);
	schedule(s);
	return;
fail:
	bc_tree_destroy(t);
	bc_tree_destroy(copy);
	bc_client_send_error(c, m->seq, rc, false, "scene not loaded: %s",
			     ei.msg);
}

static void handle_edit(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_session *s = c->session;
	struct bc_srv *srv = c->srv;
	struct bc_errinfo ei = {0};
	struct bc_tree *old = NULL;
	struct bc_proto_buf rec;
	struct bc_msg applied = {.type = BC_MSG_EDIT_APPLIED};
	struct bc_msg as_edit = {.type = BC_MSG_EDIT};
	struct undo *undo = NULL;
	uint32_t nundo = 0;
	bool structural = false;
	uint64_t t0 = uv_hrtime();
	int rc;
	bc_proto_buf_init(&rec, 0);
	if (s->store_failed) {
		rc = bc_errinfo_set(&ei, BC_EIO,
				    "the session cannot be saved: edits are "
				    "refused");
		goto fail;
	}
	if ((rc = apply_batch(&s->tree, &m->edit, &structural, &old, &undo,
			      &nundo, &ei))) {
		goto fail;
	}
	/* The journal record is the EDIT payload: sync it before anyone
	 * hears of the edit. */
	as_edit.edit = m->edit;
	if ((rc = bc_proto_encode(&rec, &as_edit, &ei)) ||
	    (rc = bc_store_append(s->store, s->order + 1,
				  rec.data + BC_PROTO_HEADER_SIZE,
				  rec.len - BC_PROTO_HEADER_SIZE, &ei))) {
		if (rc == BC_EIO) {
			s->store_failed = true;
		}
		/* Not on disk, so not applied: the structural copy goes, or
		 * the parameters are put back. */
		if (structural) {
			bc_tree_destroy(s->tree);
			s->tree = old;
			old = NULL;
		} else {
			roll_back(s->tree, undo, nundo);
		}
		goto fail;
	}
	s->order++;
	{
		double ms = (double)(uv_hrtime() - t0) / 1e6;
		s->edit_ms_avg = s->edit_ms_avg == 0.0 ? ms
						       : 0.9 * s->edit_ms_avg + 0.1 * ms;
	}
	/* The render thread's replica follows. */
	if (structural) {
		struct bc_tree *copy = bc_tree_create();
		if (copy && bc_tree_copy(copy, s->tree, NULL) == 0) {
			bc_rthread_scene(srv, s->id, copy);
		} else {
			bc_tree_destroy(copy);
		}
	} else {
		for (uint32_t i = 0; i < m->edit.nops; i++) {
			struct bc_prim_data p;
			struct bc_op_data op;
			uint32_t id = m->edit.ops[i].node;
			bc_tree_get(s->tree, id, &p, &op);
			if (op.kind != BC_OP_INVALID) {
				bc_rthread_set_op(srv, s->id, id, &op);
			} else {
				bc_rthread_set_prim(srv, s->id, id, &p);
			}
		}
	}
	applied.flags = m->flags & BC_PROTO_FLAG_INTERACTING;
	applied.edit_applied.order = s->order;
	applied.edit_applied.author = c->member_id;
	applied.edit_applied.author_seq = m->seq;
	applied.edit_applied.nops = m->edit.nops;
	applied.edit_applied.ops = m->edit.ops;
	for (uint32_t i = 0; i < s->nmembers; i++) {
		struct bc_client *o = bc_client_get(srv, s->members[i]);
		if (!o) {
			continue;
		}
		bc_client_send(o, &applied);
		o->dirty = true;
		if (m->flags & BC_PROTO_FLAG_INTERACTING) {
			o->interacting_until = bc_now_ms(srv) + BC_SRV_STILL_DELAY_MS;
		} else {
			o->interacting_until = 0;
		}
		if (structural) {
			o->shown.view = 0;
		}
	}
	if (bc_store_journal_records(s->store) >= BC_SRV_SNAPSHOT_EVERY &&
	    bc_store_snapshot(s->store, s->tree, &s->camera, s->order, &ei)) {
		bc_log(BC_LOG_ERROR, "session %s: %s", s->name, ei.msg);
	}
	bc_tree_destroy(old);
	bc_free(undo);
	bc_proto_buf_finish(&rec);
	schedule(s);
	return;
fail:
	bc_tree_destroy(old);
	bc_free(undo);
	bc_proto_buf_finish(&rec);
	bc_client_send_error(c, m->seq, rc, false, "edit refused: %s", ei.msg);
}

static void handle_camera(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	memcpy(cam.eye, m->camera.eye, sizeof(cam.eye));
	memcpy(cam.target, m->camera.target, sizeof(cam.target));
	memcpy(cam.up, m->camera.up, sizeof(cam.up));
	cam.fov_y_deg = m->camera.fov_y_deg;
	if (bc_camera_validate(&cam, &ei)) {
		bc_client_send_error(c, m->seq, ei.code, false, "%s", ei.msg);
		return;
	}
	c->camera = cam;
	c->has_camera = true;
	c->camera_seq = m->seq;
	c->dirty = true;
	c->interacting_until = (m->flags & BC_PROTO_FLAG_INTERACTING)
				       ? bc_now_ms(c->srv) + BC_SRV_STILL_DELAY_MS
				       : 0;
	/* Before joining, the camera waits for the session. */
	if (c->session) {
		schedule(c->session);
	}
}

static void handle_view(struct bc_client *c, const struct bc_msg *m)
{
	const struct bc_msg_view *v = &m->view;
	if (v->width > BC_SRV_MAX_DIM || v->height > BC_SRV_MAX_DIM) {
		bc_client_send_error(c, m->seq, BC_ERANGE, false,
				     "view %ux%u is over this server's %ux%u",
				     v->width, v->height, BC_SRV_MAX_DIM,
				     BC_SRV_MAX_DIM);
		return;
	}
	if (!(c->encodings & (1u << (v->encoding - 1)))) {
		bc_client_send_error(c, m->seq, BC_EINVAL, false,
				     "the view asks for an encoding the "
				     "client's HELLO did not list");
		return;
	}
	c->view = *v;
	c->has_view = true;
	c->dirty = true;
	c->shown.view = 0;
	if (c->session) {
		schedule(c->session);
	}
}

/* A render job for c alone at its full view size, or NULL (out of
 * memory). */
static struct bc_rjob *single_job(struct bc_client *c)
{
	struct bc_rjob *job = bc_calloc(1, sizeof(*job));
	if (!job || !(job->targets = bc_calloc(1, sizeof(*job->targets)))) {
		bc_free(job);
		return NULL;
	}
	job->session_id = c->session->id;
	job->camera = c->camera;
	job->width = c->view.width;
	job->height = c->view.height;
	job->targets[0] = bc_client_ref_of(c);
	job->ntargets = 1;
	return job;
}

static void handle_pick(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_rjob *job;
	if (!c->session || !c->has_view || m->pick.x >= c->view.width ||
	    m->pick.y >= c->view.height) {
		bc_client_send_error(c, m->seq, BC_ERANGE, false,
				     "pick outside the view (send VIEW first)");
		return;
	}
	if (!(job = single_job(c))) {
		return;
	}
	job->pick = true;
	job->pick_x = m->pick.x;
	job->pick_y = m->pick.y;
	job->pick_seq = m->seq;
	bc_rthread_job(c->srv, job);
}

static void handle_snapshot(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_rjob *job;
	if (!c->session || !c->has_view) {
		bc_client_send_error(c, m->seq, BC_ESTATE, false,
				     "join a session and send VIEW before "
				     "SNAPSHOT");
		return;
	}
	if (!(job = single_job(c))) {
		return;
	}
	job->encoding = (int)m->snapshot.encoding;
	job->quality_still = 100;
	job->final = true;
	job->camera_seq = c->camera_seq;
	job->order = c->session->order;
	job->frame_no = ++c->srv->frame_no;
	job->max_bytes = c->max_frame_bytes;
	job->snapshot_seq = m->seq;
	bc_rthread_job(c->srv, job);
}

static void handle_stats(struct bc_client *c, const struct bc_msg *m)
{
	struct bc_srv *srv = c->srv;
	struct bc_msg st = {.type = BC_MSG_STATS, .seq = m->seq};
	uint64_t now = bc_now_ms(srv);
	double secs = c->first_frame_ms ? (double)(now - c->first_frame_ms) / 1e3
					: 0.0;
	st.stats.uptime_ms = now - srv->started_ms;
	st.stats.frames = c->frames_sent;
	st.stats.bytes = c->bytes_sent;
	st.stats.order = c->session ? c->session->order : 0;
	st.stats.sessions = srv->nsessions;
	st.stats.clients = srv->nclients;
	st.stats.render_ms_last = (float)srv->render_ms_last;
	st.stats.render_ms_avg = (float)srv->render_ms_avg;
	st.stats.encode_ms_last = (float)srv->encode_ms_last;
	st.stats.encode_ms_avg = (float)srv->encode_ms_avg;
	st.stats.edit_ms_avg = c->session ? (float)c->session->edit_ms_avg : 0.0f;
	st.stats.fps = secs > 0.0 ? (float)((double)c->frames_sent / secs) : 0.0f;
	bc_client_send(c, &st);
}

void bc_session_handle(struct bc_client *c, const struct bc_msg *m)
{
	switch (m->type) {
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		handle_session(c, m);
		break;
	case BC_MSG_SESSION_LEAVE: {
		struct bc_msg ok = {.type = BC_MSG_OK, .seq = m->seq};
		bc_session_leave(c);
		bc_client_send(c, &ok);
		break;
	}
	case BC_MSG_SCENE_LOAD:
		handle_scene_load(c, m);
		break;
	case BC_MSG_EDIT:
		handle_edit(c, m);
		break;
	case BC_MSG_CAMERA:
		handle_camera(c, m);
		break;
	case BC_MSG_VIEW:
		handle_view(c, m);
		break;
	case BC_MSG_PICK:
		handle_pick(c, m);
		break;
	case BC_MSG_SNAPSHOT:
		handle_snapshot(c, m);
		break;
	case BC_MSG_GET_STATS:
		handle_stats(c, m);
		break;
	default:
		bc_client_send_error(c, m->seq, BC_EPROTO_TYPE, false,
				     "%s is not a request",
				     bc_proto_type_name(m->type));
		break;
	}
}
