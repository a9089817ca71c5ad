/*
 * Runs the language-neutral test vectors of protocol/vectors/ (written by
 * an independent Python encoder, gen_vectors.py) through the C codec:
 *  - valid entries decode to exactly the listed fields, and both the
 *    decoded message and one built from the listed fields encode back to
 *    the very same bytes;
 *  - invalid entries fail with exactly the listed error code, whether the
 *    bytes arrive at once or one at a time;
 *  - scene.json entries go through the scene scanner.
 * Every message type must have its file, so a new type cannot ship without
 * vectors.
 */
#include <dirent.h>
#include <jansson.h>
#include <stdint.h>

#include "blobcast/alloc.h"
#include "blobcast/proto.h"
#include "test.h"

#ifndef BC_VECTORS_DIR
#define BC_VECTORS_DIR "protocol/vectors"
#endif

/* ---- Small helpers --------------------------------------------------------
 */

/* Allocations made while building one message from JSON, freed together. */
static void *keep[4096];
static size_t nkeep;

static void *hold(size_t n)
{
	void *p = calloc(1, n ? n : 1);
	if (nkeep < sizeof(keep) / sizeof(keep[0])) {
		keep[nkeep++] = p;
	}
	return p;
}

static void release(void)
{
	for (size_t i = 0; i < nkeep; i++) {
		free(keep[i]);
	}
	nkeep = 0;
}

static int hexval(int c)
{
	if (c >= '0' && c <= '9') {
		return c - '0';
	}
	if (c >= 'a' && c <= 'f') {
		return c - 'a' + 10;
	}
	return -1;
}

/* Decodes hex into a held buffer; returns its length or -1. */
static long unhex(const char *hex, uint8_t **out)
{
	size_t n = strlen(hex);
	if (n % 2) {
		return -1;
	}
	uint8_t *b = hold(n / 2);
	for (size_t i = 0; i < n / 2; i++) {
		int hi = hexval(hex[2 * i]), lo = hexval(hex[2 * i + 1]);
		if (hi < 0 || lo < 0) {
			return -1;
		}
		b[i] = (uint8_t)(hi << 4 | lo);
	}
	*out = b;
	return (long)(n / 2);
}

static uint64_t jint(const json_t *o, const char *key)
{
	json_t *v = json_object_get(o, key);
	if (json_is_string(v)) { /* u64 travel as decimal strings */
		return strtoull(json_string_value(v), NULL, 10);
	}
	return (uint64_t)json_integer_value(v);
}

static float jflt(const json_t *v)
{
	return (float)json_number_value(v);
}

static void jvec(const json_t *o, const char *key, float *out, size_t n)
{
	json_t *a = json_object_get(o, key);
	for (size_t i = 0; i < n; i++) {
		out[i] = jflt(json_array_get(a, i));
	}
}

static struct bc_proto_str jstr(const json_t *o, const char *key)
{
	json_t *v = json_object_get(o, key);
	return (struct bc_proto_str){json_string_value(v),
	                             (uint32_t)json_string_length(v)};
}

static struct bc_proto_bytes jbytes(const json_t *o, const char *key)
{
	uint8_t *b = NULL;
	long n = unhex(json_string_value(json_object_get(o, key)), &b);
	return (struct bc_proto_bytes){b, n < 0 ? 0u : (uint32_t)n};
}

/* ---- Fields (JSON) -> struct bc_msg
 * ------------------------------------------ */

static const struct bc_proto_edit_op *jops(const json_t *f, uint16_t *n)
{
	json_t *a = json_object_get(f, "ops");
	*n = (uint16_t)json_array_size(a);
	struct bc_proto_edit_op *ops = hold(*n * sizeof(*ops));
	for (size_t i = 0; i < *n; i++) {
		json_t *o = json_array_get(a, i);
		struct bc_proto_edit_op *op = &ops[i];
		op->kind = (enum bc_proto_edit_kind)jint(o, "kind");
		op->node = (uint32_t)jint(
		    o, op->kind == BC_PROTO_EDIT_INSERT ? "parent" : "node");
		op->position = (uint32_t)jint(o, "position");
		if (json_object_get(o, "subtree")) {
			op->subtree = jbytes(o, "subtree");
		}
		if (json_object_get(o, "name")) {
			op->name = jstr(o, "name");
		}
		json_t *fa = json_object_get(o, "fields");
		op->nfields = (uint8_t)json_array_size(fa);
		struct bc_proto_field *fs = hold(op->nfields * sizeof(*fs));
		for (size_t k = 0; k < op->nfields; k++) {
			json_t *fo = json_array_get(fa, k);
			json_t *va = json_object_get(fo, "values");
			fs[k].field = (uint8_t)jint(fo, "field");
			fs[k].count = (uint8_t)json_array_size(va);
			for (size_t j = 0; j < fs[k].count && j < 4; j++) {
				fs[k].v[j] = jflt(json_array_get(va, j));
			}
		}
		op->fields = fs;
	}
	return ops;
}

/* A camera's fields (CAMERA, SESSION_CAMERA and the camera of
 * FOLLOW_CAMERA and SESSION_CAMERA_SET). */
static void jcam(const json_t *f, struct bc_msg_camera *c)
{
	jvec(f, "eye", c->eye, 3);
	jvec(f, "target", c->target, 3);
	jvec(f, "up", c->up, 3);
	c->fov_y_deg = jflt(json_object_get(f, "fov_y_deg"));
}

static void build(enum bc_msg_type type, const json_t *f, struct bc_msg *m)
{
	memset(m, 0, sizeof(*m));
	m->type = type;
	m->seq = (uint32_t)jint(f, "seq");
	m->flags = (uint16_t)jint(f, "flags");
	switch (type) {
	case BC_MSG_HELLO:
		m->hello.version_min = (uint16_t)jint(f, "version_min");
		m->hello.version_max = (uint16_t)jint(f, "version_max");
		m->hello.encodings = (uint8_t)jint(f, "encodings");
		m->hello.max_frame_bytes = (uint32_t)jint(f, "max_frame_bytes");
		m->hello.client_name = jstr(f, "client_name");
		m->hello.token = jstr(f, "token");
		m->hello.has_features = json_object_get(f, "features") != NULL;
		m->hello.features = (uint32_t)jint(f, "features");
		break;
	case BC_MSG_WELCOME:
		m->welcome.version = (uint16_t)jint(f, "version");
		m->welcome.connection_id = (uint32_t)jint(f, "connection_id");
		m->welcome.max_payload = (uint32_t)jint(f, "max_payload");
		m->welcome.max_frame_bytes =
		    (uint32_t)jint(f, "max_frame_bytes");
		m->welcome.max_nodes = (uint32_t)jint(f, "max_nodes");
		m->welcome.max_dim = (uint16_t)jint(f, "max_dim");
		m->welcome.max_members = (uint16_t)jint(f, "max_members");
		m->welcome.max_edit_ops = (uint16_t)jint(f, "max_edit_ops");
		m->welcome.server_id = jstr(f, "server_id");
		m->welcome.has_features =
		    json_object_get(f, "features") != NULL;
		m->welcome.features = (uint32_t)jint(f, "features");
		break;
	case BC_MSG_ERROR:
		m->error.code = (uint16_t)jint(f, "code");
		m->error.text = jstr(f, "text");
		break;
	case BC_MSG_PING:
	case BC_MSG_PONG:
		m->ping.stamp = jint(f, "stamp");
		break;
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		m->session.role = (enum bc_proto_role)jint(f, "role");
		m->session.name = jstr(f, "name");
		break;
	case BC_MSG_SESSION_DELETE:
		m->session_delete.name = jstr(f, "name");
		break;
	case BC_MSG_SESSIONS: {
		static struct bc_proto_session_entry
		    list[BC_PROTO_MAX_SESSIONS_LISTED];
		json_t *arr = json_object_get(f, "sessions");
		size_t i;
		json_t *e;
		json_array_foreach(arr, i, e)
		{
			if (i >= BC_PROTO_MAX_SESSIONS_LISTED) {
				break;
			}
			list[i].name = jstr(e, "name");
			list[i].members = (uint16_t)jint(e, "members");
			list[i].prims = (uint32_t)jint(e, "prims");
			list[i].order = jint(e, "order");
			list[i].last_edit_ms = jint(e, "last_edit_ms");
			list[i].flags = (uint8_t)jint(e, "flags");
		}
		m->sessions.nsessions = (uint16_t)json_array_size(arr);
		m->sessions.sessions = list;
		break;
	}
	case BC_MSG_SESSION_INFO: {
		struct bc_msg_session_info *s = &m->session_info;
		s->session_id = (uint32_t)jint(f, "session_id");
		s->member_id = (uint32_t)jint(f, "member_id");
		s->role = (enum bc_proto_role)jint(f, "role");
		s->name = jstr(f, "name");
		json_t *a = json_object_get(f, "members");
		s->nmembers = (uint16_t)json_array_size(a);
		struct bc_proto_member *mb = hold(s->nmembers * sizeof(*mb));
		for (size_t i = 0; i < s->nmembers; i++) {
			json_t *o = json_array_get(a, i);
			mb[i].id = (uint32_t)jint(o, "id");
			mb[i].role = (enum bc_proto_role)jint(o, "role");
			mb[i].name = jstr(o, "name");
		}
		s->members = mb;
		break;
	}
	case BC_MSG_SCENE_LOAD:
		m->scene_load.scene = jbytes(f, "scene");
		break;
	case BC_MSG_SCENE_STATE:
		m->scene_state.order = jint(f, "order");
		m->scene_state.author = (uint32_t)jint(f, "author");
		m->scene_state.author_seq = (uint32_t)jint(f, "author_seq");
		m->scene_state.scene = jbytes(f, "scene");
		break;
	case BC_MSG_EDIT:
		m->edit.ops = jops(f, &m->edit.nops);
		break;
	case BC_MSG_EDIT_APPLIED:
		m->edit_applied.order = jint(f, "order");
		m->edit_applied.author = (uint32_t)jint(f, "author");
		m->edit_applied.author_seq = (uint32_t)jint(f, "author_seq");
		m->edit_applied.ops = jops(f, &m->edit_applied.nops);
		if (json_object_get(f, "target_order")) {
			m->edit_applied.target_order = jint(f, "target_order");
			m->edit_applied.target_author =
			    jstr(f, "target_author");
		}
		break;
	case BC_MSG_CAMERA:
		jcam(f, &m->camera);
		break;
	case BC_MSG_SESSION_CAMERA:
		jcam(f, &m->session_camera);
		break;
	case BC_MSG_FOLLOW_CAMERA:
		m->follow_camera.presenter = (uint32_t)jint(f, "presenter");
		jcam(f, &m->follow_camera.camera);
		break;
	case BC_MSG_SESSION_CAMERA_SET:
		m->session_camera_set.order = jint(f, "order");
		m->session_camera_set.author = (uint32_t)jint(f, "author");
		m->session_camera_set.author_seq =
		    (uint32_t)jint(f, "author_seq");
		jcam(f, &m->session_camera_set.camera);
		break;
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
		m->toggle.on = (uint8_t)jint(f, "on");
		break;
	case BC_MSG_PRESENTER:
		m->presenter.presenter = (uint32_t)jint(f, "presenter");
		m->presenter.following = (uint8_t)jint(f, "following");
		break;
	case BC_MSG_VIEW:
		m->view.width = (uint16_t)jint(f, "width");
		m->view.height = (uint16_t)jint(f, "height");
		m->view.encoding = (enum bc_proto_encoding)jint(f, "encoding");
		m->view.quality_interactive =
		    (uint8_t)jint(f, "quality_interactive");
		m->view.quality_still = (uint8_t)jint(f, "quality_still");
		m->view.downscale = (uint8_t)jint(f, "downscale");
		m->view.still_encoding =
		    (enum bc_proto_encoding)jint(f, "still_encoding");
		break;
	case BC_MSG_FRAME_ACK:
		m->frame_ack.frame_no = (uint32_t)jint(f, "frame_no");
		break;
	case BC_MSG_MESH:
		m->mesh.format = (enum bc_proto_mesh_format)jint(f, "format");
		m->mesh.options = (uint8_t)jint(f, "options");
		m->mesh.resolution = (uint16_t)jint(f, "resolution");
		break;
	case BC_MSG_MESH_DATA:
		m->mesh_data.format =
		    (enum bc_proto_mesh_format)jint(f, "format");
		m->mesh_data.options = (uint8_t)jint(f, "options");
		m->mesh_data.resolution = (uint16_t)jint(f, "resolution");
		m->mesh_data.order = jint(f, "order");
		m->mesh_data.vertices = (uint32_t)jint(f, "vertices");
		m->mesh_data.triangles = (uint32_t)jint(f, "triangles");
		m->mesh_data.file = jbytes(f, "file");
		break;
	case BC_MSG_FRAME: {
		struct bc_msg_frame *fr = &m->frame;
		fr->frame_no = (uint32_t)jint(f, "frame_no");
		fr->order = jint(f, "order");
		fr->camera_seq = (uint32_t)jint(f, "camera_seq");
		fr->encoding = (enum bc_proto_encoding)jint(f, "encoding");
		fr->width = (uint16_t)jint(f, "width");
		fr->height = (uint16_t)jint(f, "height");
		fr->image_width = (uint16_t)jint(f, "image_width");
		fr->image_height = (uint16_t)jint(f, "image_height");
		json_t *a = json_object_get(f, "rects");
		fr->nrects = (uint16_t)json_array_size(a);
		struct bc_proto_rect *r = hold(fr->nrects * sizeof(*r));
		for (size_t i = 0; i < fr->nrects; i++) {
			json_t *o = json_array_get(a, i);
			r[i].x = (uint16_t)jint(o, "x");
			r[i].y = (uint16_t)jint(o, "y");
			r[i].w = (uint16_t)jint(o, "w");
			r[i].h = (uint16_t)jint(o, "h");
			r[i].data = jbytes(o, "data");
		}
		fr->rects = r;
		break;
	}
	case BC_MSG_PICK:
		m->pick.x = (uint16_t)jint(f, "x");
		m->pick.y = (uint16_t)jint(f, "y");
		break;
	case BC_MSG_PICK_RESULT:
		m->pick_result.x = (uint16_t)jint(f, "x");
		m->pick_result.y = (uint16_t)jint(f, "y");
		m->pick_result.node = (uint32_t)jint(f, "node");
		jvec(f, "position", m->pick_result.position, 3);
		m->pick_result.depth = jflt(json_object_get(f, "depth"));
		break;
	case BC_MSG_SNAPSHOT:
		m->snapshot.encoding =
		    (enum bc_proto_encoding)jint(f, "encoding");
		m->snapshot.planes = (uint8_t)jint(f, "planes");
		if ((m->snapshot.has_tile =
		         json_object_get(f, "full_width") != NULL)) {
			m->snapshot.full_width =
			    (uint16_t)jint(f, "full_width");
			m->snapshot.full_height =
			    (uint16_t)jint(f, "full_height");
			m->snapshot.tile_x = (uint16_t)jint(f, "tile_x");
			m->snapshot.tile_y = (uint16_t)jint(f, "tile_y");
			m->snapshot.tile_width =
			    (uint16_t)jint(f, "tile_width");
			m->snapshot.tile_height =
			    (uint16_t)jint(f, "tile_height");
		}
		break;
	case BC_MSG_STATS: {
		struct bc_msg_stats *s = &m->stats;
		s->uptime_ms = jint(f, "uptime_ms");
		s->frames = jint(f, "frames");
		s->bytes = jint(f, "bytes");
		s->order = jint(f, "order");
		s->sessions = (uint32_t)jint(f, "sessions");
		s->clients = (uint32_t)jint(f, "clients");
		s->render_ms_last = jflt(json_object_get(f, "render_ms_last"));
		s->render_ms_avg = jflt(json_object_get(f, "render_ms_avg"));
		s->encode_ms_last = jflt(json_object_get(f, "encode_ms_last"));
		s->encode_ms_avg = jflt(json_object_get(f, "encode_ms_avg"));
		s->edit_ms_avg = jflt(json_object_get(f, "edit_ms_avg"));
		s->fps = jflt(json_object_get(f, "fps"));
		s->has_load = json_is_true(json_object_get(f, "has_load"));
		if (s->has_load) {
			struct bc_proto_load *l = &s->load;
			l->loop_turn_max_ms =
			    jflt(json_object_get(f, "loop_turn_max_ms"));
			l->loop_request_max_ms =
			    jflt(json_object_get(f, "loop_request_max_ms"));
			l->render_workers = (uint32_t)jint(f, "render_workers");
			l->jobs_queued = (uint32_t)jint(f, "jobs_queued");
			l->jobs_running = (uint32_t)jint(f, "jobs_running");
			l->view_bytes = jint(f, "view_bytes");
			l->view_cap = jint(f, "view_cap");
			l->session_render_us = jint(f, "session_render_us");
		}
		s->has_tls = json_is_true(json_object_get(f, "has_tls"));
		if (s->has_tls) {
			s->tls_not_after_ms = jint(f, "tls_not_after_ms");
			s->tls_expiring = (uint8_t)jint(f, "tls_expiring");
		}
		s->has_link = json_is_true(json_object_get(f, "has_link"));
		if (s->has_link) {
			struct bc_proto_link *k = &s->link;
			k->rtt_us = (uint32_t)jint(f, "rtt_us");
			k->min_rtt_us = (uint32_t)jint(f, "min_rtt_us");
			k->delivery_bps = jint(f, "delivery_bps");
			k->unacked_bytes = (uint32_t)jint(f, "unacked_bytes");
			k->frames_paced = (uint32_t)jint(f, "frames_paced");
			k->frames_spoiled = jint(f, "frames_spoiled");
		}
		s->has_memory = json_is_true(json_object_get(f, "has_memory"));
		if (s->has_memory) {
			struct bc_proto_memory *mm = &s->memory;
			mm->scene_nodes = jint(f, "scene_nodes");
			mm->scene_nodes_cap = jint(f, "scene_nodes_cap");
			mm->session_nodes = jint(f, "session_nodes");
			mm->sessions_loaded =
			    (uint32_t)jint(f, "sessions_loaded");
		}
		break;
	}
	case BC_MSG_GET_STATS:
		m->get_stats.parts = (uint8_t)jint(f, "parts");
		break;
	case BC_MSG_UNDO:
	case BC_MSG_REDO:
		m->undo.scope = (uint8_t)jint(f, "scope");
		break;
	case BC_MSG_HISTORY: {
		static struct bc_proto_history_entry list[BC_PROTO_MAX_HISTORY];
		json_t *arr = json_object_get(f, "entries");
		size_t i;
		json_t *e;
		json_array_foreach(arr, i, e)
		{
			if (i >= BC_PROTO_MAX_HISTORY) {
				break;
			}
			list[i].order = jint(e, "order");
			list[i].time_ms = jint(e, "time_ms");
			list[i].built_on = jint(e, "built_on");
			list[i].state = (uint8_t)jint(e, "state");
			list[i].flags = (uint8_t)jint(e, "flags");
			list[i].author = jstr(e, "author");
			list[i].what = jstr(e, "what");
		}
		m->history.order = jint(f, "order");
		m->history.nentries = (uint16_t)json_array_size(arr);
		m->history.entries = list;
		break;
	}
	default:
		break;
	}
}

/* ---- Deep comparison of two messages
 * ------------------------------------------ */

static int str_eq(struct bc_proto_str a, struct bc_proto_str b)
{
	return a.len == b.len &&
	       (a.len == 0 || memcmp(a.ptr, b.ptr, a.len) == 0);
}

static int bytes_eq(struct bc_proto_bytes a, struct bc_proto_bytes b)
{
	return a.len == b.len &&
	       (a.len == 0 || memcmp(a.ptr, b.ptr, a.len) == 0);
}

/* Floats compare by bits: -0.0 must stay -0.0 through the codec. */
static int f_eq(const float *a, const float *b, size_t n)
{
	return memcmp(a, b, n * sizeof(float)) == 0;
}

static int ops_eq(const struct bc_proto_edit_op *a,
                  const struct bc_proto_edit_op *b, unsigned n)
{
	for (unsigned i = 0; i < n; i++) {
		if (a[i].kind != b[i].kind || a[i].node != b[i].node ||
		    a[i].nfields != b[i].nfields ||
		    !bytes_eq(a[i].subtree, b[i].subtree)) {
			return 0;
		}
		if (a[i].kind == BC_PROTO_EDIT_INSERT &&
		    a[i].position != b[i].position) {
			return 0;
		}
		for (unsigned k = 0; k < a[i].nfields; k++) {
			const struct bc_proto_field *x = &a[i].fields[k];
			const struct bc_proto_field *y = &b[i].fields[k];
			if (x->field != y->field || x->count != y->count ||
			    !f_eq(x->v, y->v, x->count)) {
				return 0;
			}
		}
	}
	return 1;
}

static int cam_eq(const struct bc_msg_camera *a, const struct bc_msg_camera *b)
{
	return f_eq(a->eye, b->eye, 3) && f_eq(a->target, b->target, 3) &&
	       f_eq(a->up, b->up, 3) && f_eq(&a->fov_y_deg, &b->fov_y_deg, 1);
}

static int msg_eq(const struct bc_msg *a, const struct bc_msg *b)
{
	if (a->type != b->type || a->seq != b->seq || a->flags != b->flags) {
		return 0;
	}
	switch (a->type) {
	case BC_MSG_HELLO:
		return a->hello.version_min == b->hello.version_min &&
		       a->hello.version_max == b->hello.version_max &&
		       a->hello.encodings == b->hello.encodings &&
		       a->hello.max_frame_bytes == b->hello.max_frame_bytes &&
		       str_eq(a->hello.client_name, b->hello.client_name) &&
		       str_eq(a->hello.token, b->hello.token) &&
		       a->hello.has_features == b->hello.has_features &&
		       a->hello.features == b->hello.features;
	case BC_MSG_WELCOME:
		return a->welcome.version == b->welcome.version &&
		       a->welcome.connection_id == b->welcome.connection_id &&
		       a->welcome.max_payload == b->welcome.max_payload &&
		       a->welcome.max_frame_bytes ==
		           b->welcome.max_frame_bytes &&
		       a->welcome.max_nodes == b->welcome.max_nodes &&
		       a->welcome.max_dim == b->welcome.max_dim &&
		       a->welcome.max_members == b->welcome.max_members &&
		       a->welcome.max_edit_ops == b->welcome.max_edit_ops &&
		       str_eq(a->welcome.server_id, b->welcome.server_id) &&
		       a->welcome.has_features == b->welcome.has_features &&
		       a->welcome.features == b->welcome.features;
	case BC_MSG_ERROR:
		return a->error.code == b->error.code &&
		       str_eq(a->error.text, b->error.text);
	case BC_MSG_PING:
	case BC_MSG_PONG:
		return a->ping.stamp == b->ping.stamp;
	case BC_MSG_SESSION_CREATE:
	case BC_MSG_SESSION_JOIN:
		return a->session.role == b->session.role &&
		       str_eq(a->session.name, b->session.name);
	case BC_MSG_SESSION_INFO: {
		const struct bc_msg_session_info *x = &a->session_info;
		const struct bc_msg_session_info *y = &b->session_info;
		if (x->session_id != y->session_id ||
		    x->member_id != y->member_id || x->role != y->role ||
		    !str_eq(x->name, y->name) || x->nmembers != y->nmembers) {
			return 0;
		}
		for (unsigned i = 0; i < x->nmembers; i++) {
			if (x->members[i].id != y->members[i].id ||
			    x->members[i].role != y->members[i].role ||
			    !str_eq(x->members[i].name, y->members[i].name)) {
				return 0;
			}
		}
		return 1;
	}
	case BC_MSG_SCENE_LOAD:
		return bytes_eq(a->scene_load.scene, b->scene_load.scene);
	case BC_MSG_SCENE_STATE:
		return a->scene_state.order == b->scene_state.order &&
		       a->scene_state.author == b->scene_state.author &&
		       a->scene_state.author_seq == b->scene_state.author_seq &&
		       bytes_eq(a->scene_state.scene, b->scene_state.scene);
	case BC_MSG_EDIT:
		return a->edit.nops == b->edit.nops &&
		       ops_eq(a->edit.ops, b->edit.ops, a->edit.nops);
	case BC_MSG_EDIT_APPLIED:
		return a->edit_applied.order == b->edit_applied.order &&
		       a->edit_applied.author == b->edit_applied.author &&
		       a->edit_applied.author_seq ==
		           b->edit_applied.author_seq &&
		       a->edit_applied.nops == b->edit_applied.nops &&
		       ops_eq(a->edit_applied.ops, b->edit_applied.ops,
		              a->edit_applied.nops) &&
		       a->edit_applied.target_order ==
		           b->edit_applied.target_order &&
		       str_eq(a->edit_applied.target_author,
		              b->edit_applied.target_author);
	case BC_MSG_CAMERA:
		return cam_eq(&a->camera, &b->camera);
	case BC_MSG_SESSION_CAMERA:
		return cam_eq(&a->session_camera, &b->session_camera);
	case BC_MSG_FOLLOW_CAMERA:
		return a->follow_camera.presenter ==
		           b->follow_camera.presenter &&
		       cam_eq(&a->follow_camera.camera,
		              &b->follow_camera.camera);
	case BC_MSG_SESSION_CAMERA_SET:
		return a->session_camera_set.order ==
		           b->session_camera_set.order &&
		       a->session_camera_set.author ==
		           b->session_camera_set.author &&
		       a->session_camera_set.author_seq ==
		           b->session_camera_set.author_seq &&
		       cam_eq(&a->session_camera_set.camera,
		              &b->session_camera_set.camera);
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
		return a->toggle.on == b->toggle.on;
	case BC_MSG_PRESENTER:
		return a->presenter.presenter == b->presenter.presenter &&
		       a->presenter.following == b->presenter.following;
	case BC_MSG_VIEW:
		return memcmp(&a->view, &b->view, sizeof(a->view)) == 0;
	case BC_MSG_FRAME: {
		const struct bc_msg_frame *x = &a->frame, *y = &b->frame;
		if (x->frame_no != y->frame_no || x->order != y->order ||
		    x->camera_seq != y->camera_seq ||
		    x->encoding != y->encoding || x->width != y->width ||
		    x->height != y->height ||
		    x->image_width != y->image_width ||
		    x->image_height != y->image_height ||
		    x->nrects != y->nrects) {
			return 0;
		}
		for (unsigned i = 0; i < x->nrects; i++) {
			const struct bc_proto_rect *p = &x->rects[i];
			const struct bc_proto_rect *q = &y->rects[i];
			if (p->x != q->x || p->y != q->y || p->w != q->w ||
			    p->h != q->h || !bytes_eq(p->data, q->data)) {
				return 0;
			}
		}
		return 1;
	}
	case BC_MSG_FRAME_ACK:
		return a->frame_ack.frame_no == b->frame_ack.frame_no;
	case BC_MSG_MESH:
		return memcmp(&a->mesh, &b->mesh, sizeof(a->mesh)) == 0;
	case BC_MSG_MESH_DATA: {
		const struct bc_msg_mesh_data *x = &a->mesh_data;
		const struct bc_msg_mesh_data *y = &b->mesh_data;
		return x->format == y->format && x->options == y->options &&
		       x->resolution == y->resolution && x->order == y->order &&
		       x->vertices == y->vertices &&
		       x->triangles == y->triangles &&
		       bytes_eq(x->file, y->file);
	}
	case BC_MSG_PICK:
		return a->pick.x == b->pick.x && a->pick.y == b->pick.y;
	case BC_MSG_PICK_RESULT:
		return a->pick_result.x == b->pick_result.x &&
		       a->pick_result.y == b->pick_result.y &&
		       a->pick_result.node == b->pick_result.node &&
		       f_eq(a->pick_result.position, b->pick_result.position,
		            3) &&
		       f_eq(&a->pick_result.depth, &b->pick_result.depth, 1);
	case BC_MSG_SNAPSHOT:
		return a->snapshot.encoding == b->snapshot.encoding &&
		       a->snapshot.planes == b->snapshot.planes &&
		       a->snapshot.has_tile == b->snapshot.has_tile &&
		       (!a->snapshot.has_tile ||
		        (a->snapshot.full_width == b->snapshot.full_width &&
		         a->snapshot.full_height == b->snapshot.full_height &&
		         a->snapshot.tile_x == b->snapshot.tile_x &&
		         a->snapshot.tile_y == b->snapshot.tile_y &&
		         a->snapshot.tile_width == b->snapshot.tile_width &&
		         a->snapshot.tile_height == b->snapshot.tile_height));
	case BC_MSG_STATS:
		return memcmp(&a->stats, &b->stats, sizeof(a->stats)) == 0;
	case BC_MSG_GET_STATS:
		return a->get_stats.parts == b->get_stats.parts;
	case BC_MSG_UNDO:
	case BC_MSG_REDO:
		return a->undo.scope == b->undo.scope;
	case BC_MSG_HISTORY:
		if (a->history.order != b->history.order ||
		    a->history.nentries != b->history.nentries) {
			return 0;
		}
		for (unsigned i = 0; i < a->history.nentries; i++) {
			const struct bc_proto_history_entry *x =
			    &a->history.entries[i];
			const struct bc_proto_history_entry *y =
			    &b->history.entries[i];
			if (x->order != y->order || x->time_ms != y->time_ms ||
			    x->built_on != y->built_on ||
			    x->state != y->state || x->flags != y->flags ||
			    !str_eq(x->author, y->author) ||
			    !str_eq(x->what, y->what)) {
				return 0;
			}
		}
		return 1;
	case BC_MSG_SESSION_DELETE:
		return str_eq(a->session_delete.name, b->session_delete.name);
	case BC_MSG_SESSIONS:
		if (a->sessions.nsessions != b->sessions.nsessions) {
			return 0;
		}
		for (unsigned i = 0; i < a->sessions.nsessions; i++) {
			const struct bc_proto_session_entry *x =
			    &a->sessions.sessions[i];
			const struct bc_proto_session_entry *y =
			    &b->sessions.sessions[i];
			if (!str_eq(x->name, y->name) ||
			    x->members != y->members || x->prims != y->prims ||
			    x->order != y->order ||
			    x->last_edit_ms != y->last_edit_ms ||
			    x->flags != y->flags) {
				return 0;
			}
		}
		return 1;
	default: /* no payload */
		return 1;
	}
}

/* ---- Running entries
 * ----------------------------------------------------------- */

static void reader_opts(const json_t *e, struct bc_proto_reader_opts *o)
{
	memset(o, 0, sizeof(*o));
	json_t *r = json_object_get(e, "reader");
	if (!r) {
		return;
	}
	const char *side = json_string_value(json_object_get(r, "side"));
	if (side && strcmp(side, "server") == 0) {
		o->side = BC_PROTO_SIDE_SERVER;
	} else if (side && strcmp(side, "client") == 0) {
		o->side = BC_PROTO_SIDE_CLIENT;
	}
	o->max_payload = (uint32_t)jint(r, "max_payload");
	o->await_hello = json_is_true(json_object_get(r, "await_hello"));
}

/* Feeds bytes (all at once, or one at a time), drains, then ends the
 * stream. Returns the final code (0 = clean end) and counts messages. */
static int run_stream(const struct bc_proto_reader_opts *o, const uint8_t *b,
                      size_t n, int bytewise, int *nmsgs)
{
	struct bc_proto_reader r;
	struct bc_msg m;
	int rc = bc_proto_reader_init(&r, o);
	*nmsgs = 0;
	for (size_t off = 0; rc >= 0 && off < n;) {
		size_t k = bytewise ? 1 : n - off;
		rc = bc_proto_reader_feed(&r, b + off, k);
		off += k;
		while (rc >= 0 && (rc = bc_proto_reader_next(&r, &m)) == 1) {
			(*nmsgs)++;
		}
	}
	if (rc >= 0) {
		rc = bc_proto_reader_eof(&r);
	}
	if (rc < 0) {
		CHECK(r.err == rc);
		CHECK(r.errstr[0] != '\0');
	}
	bc_proto_reader_finish(&r);
	return rc;
}

static int total_valid, total_invalid;

static void run_valid(enum bc_msg_type type, const json_t *e)
{
	const char *name = json_string_value(json_object_get(e, "name"));
	uint8_t *bytes = NULL;
	long n = unhex(json_string_value(json_object_get(e, "hex")), &bytes);
	REQUIRE(n >= (long)BC_PROTO_HEADER_SIZE);
	struct bc_msg want;
	build(type, json_object_get(e, "fields"), &want);

	/* Decode in one reader that stays alive while we compare. */
	struct bc_proto_reader r;
	struct bc_msg got;
	REQUIRE(bc_proto_reader_init(&r, NULL) == 0);
	CHECK(bc_proto_reader_feed(&r, bytes, (size_t)n) == 0);
	int rc = bc_proto_reader_next(&r, &got);
	if (rc != 1) {
		fprintf(stderr, "  %s/%s: next = %d (%s)\n",
		        bc_proto_type_name(type), name, rc, r.errstr);
	}
	CHECK(rc == 1);
	if (rc == 1) {
		CHECK(got.type == type);
		if (!msg_eq(&got, &want)) {
			fprintf(stderr, "  %s/%s: decoded fields differ\n",
			        bc_proto_type_name(type), name);
			bc_test_failures++;
		}
		/* Decoded message -> same bytes. */
		struct bc_proto_buf b;
		struct bc_errinfo ei = {0};
		bc_proto_buf_init(&b, 0);
		CHECK(bc_proto_encode(&b, &got, &ei) == 0);
		CHECK(b.len == (size_t)n && memcmp(b.data, bytes, b.len) == 0);
		bc_proto_buf_finish(&b);
	}
	CHECK(bc_proto_reader_next(&r, &got) == 0);
	CHECK(bc_proto_reader_eof(&r) == 0);
	bc_proto_reader_finish(&r);

	/* Fields -> same bytes. */
	struct bc_proto_buf b;
	struct bc_errinfo ei = {0};
	bc_proto_buf_init(&b, 0);
	rc = bc_proto_encode(&b, &want, &ei);
	if (rc != 0 || b.len != (size_t)n ||
	    memcmp(b.data, bytes, (size_t)n) != 0) {
		fprintf(stderr,
		        "  %s/%s: encoding the fields gives %d (%s), "
		        "%zu bytes for %ld\n",
		        bc_proto_type_name(type), name, rc, ei.msg, b.len, n);
		bc_test_failures++;
	}
	bc_proto_buf_finish(&b);

	/* One byte at a time, and through the payload decoder alone. */
	int count = 0;
	CHECK(run_stream(&(struct bc_proto_reader_opts){0}, bytes, (size_t)n, 1,
	                 &count) == 0);
	CHECK(count == 1);
	struct bc_proto_reader pr;
	bc_proto_reader_init(&pr, NULL);
	CHECK(bc_proto_decode_payload(
	          &pr, type, want.flags, want.seq, bytes + BC_PROTO_HEADER_SIZE,
	          (size_t)n - BC_PROTO_HEADER_SIZE, &got, NULL) == 0);
	CHECK(msg_eq(&got, &want));
	bc_proto_reader_finish(&pr);
	total_valid++;
}

static void run_invalid(const json_t *e)
{
	const char *name = json_string_value(json_object_get(e, "name"));
	const char *want = json_string_value(json_object_get(e, "error"));
	int want_msgs = (int)jint(e, "messages");
	uint8_t *bytes = NULL;
	long n = unhex(json_string_value(json_object_get(e, "hex")), &bytes);
	REQUIRE(n >= 0);
	struct bc_proto_reader_opts o;
	reader_opts(e, &o);
	for (int bytewise = 0; bytewise < 2; bytewise++) {
		int count = 0;
		int rc = run_stream(&o, bytes, (size_t)n, bytewise, &count);
		const char *got = rc == 0 ? NULL : bc_err_name(rc);
		int ok =
		    (want == NULL) ? rc == 0 : (got && strcmp(got, want) == 0);
		if (!ok || count != want_msgs) {
			fprintf(stderr,
			        "  %s: got %s after %d messages, want %s after "
			        "%d (%s)\n",
			        name, got ? got : "success", count,
			        want ? want : "success", want_msgs,
			        bytewise ? "bytewise" : "at once");
			bc_test_failures++;
		}
	}
	total_invalid++;
}

static json_t *load(const char *file)
{
	char path[512];
	json_error_t jerr;
	snprintf(path, sizeof(path), "%s/%s", BC_VECTORS_DIR, file);
	json_t *doc = json_load_file(path, 0, &jerr);
	if (!doc) {
		fprintf(stderr, "  %s: %s (line %d)\n", path, jerr.text,
		        jerr.line);
	}
	return doc;
}

/* "SESSION_INFO" -> "session_info.json". */
static void file_of(enum bc_msg_type t, char *out, size_t n)
{
	const char *name = bc_proto_type_name(t);
	size_t i = 0;
	for (; name[i] && i + 6 < n; i++) {
		char c = name[i];
		out[i] = (char)(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
	}
	snprintf(out + i, n - i, ".json");
}

static void test_every_type_has_vectors(void)
{
	for (int t = 1; t < BC_MSG_COUNT; t++) {
		char file[64];
		file_of((enum bc_msg_type)t, file, sizeof(file));
		json_t *doc = load(file);
		REQUIRE(doc);
		CHECK(jint(doc, "type_id") == (uint64_t)t);
		json_t *valid = json_object_get(doc, "valid");
		json_t *invalid = json_object_get(doc, "invalid");
		CHECK(json_array_size(valid) >= 1);
		CHECK(json_array_size(invalid) >= 5);
		size_t i;
		json_t *e;
		json_array_foreach(valid, i, e)
		{
			run_valid((enum bc_msg_type)t, e);
			release();
		}
		json_array_foreach(invalid, i, e)
		{
			run_invalid(e);
			release();
		}
		json_decref(doc);
	}
	printf("  %d valid and %d invalid message vectors\n", total_valid,
	       total_invalid);
}

static void test_framing_vectors(void)
{
	json_t *doc = load("framing.json");
	REQUIRE(doc);
	size_t i;
	json_t *e;
	json_array_foreach(json_object_get(doc, "invalid"), i, e)
	{
		run_invalid(e);
		release();
	}
	CHECK(json_array_size(json_object_get(doc, "invalid")) >= 20);
	json_decref(doc);
}

static void test_scene_vectors(void)
{
	json_t *doc = load("scene.json");
	REQUIRE(doc);
	size_t i;
	json_t *e;
	json_array_foreach(json_object_get(doc, "valid"), i, e)
	{
		uint8_t *b = NULL;
		long n =
		    unhex(json_string_value(json_object_get(e, "hex")), &b);
		json_t *f = json_object_get(e, "fields");
		struct bc_proto_scene_info info;
		struct bc_errinfo ei = {0};
		int rc = bc_proto_scene_scan(b, (size_t)n, &info, &ei);
		if (rc != 0) {
			fprintf(stderr, "  %s: %s\n",
			        json_string_value(json_object_get(e, "name")),
			        ei.msg);
		}
		CHECK(rc == 0);
		CHECK(info.has_camera ==
		      json_is_true(json_object_get(f, "has_camera")));
		CHECK(info.nodes == jint(f, "nodes"));
		CHECK(info.prims == jint(f, "prims"));
		CHECK(info.ops == jint(f, "ops"));
		CHECK(info.depth == jint(f, "depth"));
		CHECK(info.names == (json_object_get(f, "names")
		                         ? (uint32_t)jint(f, "names")
		                         : 0u));
		CHECK(((info.features & BC_PROTO_FEATURE_NAMES) != 0) ==
		      (info.names > 0));
		release();
	}
	json_array_foreach(json_object_get(doc, "invalid"), i, e)
	{
		uint8_t *b = NULL;
		long n =
		    unhex(json_string_value(json_object_get(e, "hex")), &b);
		const char *want =
		    json_string_value(json_object_get(e, "error"));
		struct bc_errinfo ei = {0};
		int rc = bc_proto_scene_scan(b, (size_t)n, NULL, &ei);
		if (rc == 0 || strcmp(bc_err_name(rc), want) != 0) {
			fprintf(stderr, "  %s: got %s (%s), want %s\n",
			        json_string_value(json_object_get(e, "name")),
			        rc ? bc_err_name(rc) : "success", ei.msg, want);
			bc_test_failures++;
		}
		release();
	}
	json_decref(doc);
}

/* No stray files: every JSON file here is one the tests above read. */
static void test_no_unknown_vector_files(void)
{
	DIR *d = opendir(BC_VECTORS_DIR);
	REQUIRE(d);
	struct dirent *de;
	int files = 0;
	while ((de = readdir(d))) {
		size_t n = strlen(de->d_name);
		if (n < 5 || strcmp(de->d_name + n - 5, ".json") != 0) {
			continue;
		}
		files++;
		char stem[64] = {0};
		int known = strcmp(de->d_name, "framing.json") == 0 ||
		            strcmp(de->d_name, "scene.json") == 0;
		for (int t = 1; !known && t < BC_MSG_COUNT; t++) {
			file_of((enum bc_msg_type)t, stem, sizeof(stem));
			known = strcmp(stem, de->d_name) == 0;
		}
		if (!known) {
			fprintf(stderr, "  unknown vector file %s\n",
			        de->d_name);
			bc_test_failures++;
		}
	}
	closedir(d);
	CHECK(files == BC_MSG_COUNT - 1 + 2);
}

static const struct bc_test tests[] = {
    {"every_type_has_vectors", test_every_type_has_vectors},
    {"framing_vectors", test_framing_vectors},
    {"scene_vectors", test_scene_vectors},
    {"no_unknown_vector_files", test_no_unknown_vector_files},
};

BC_TEST_MAIN(tests)
