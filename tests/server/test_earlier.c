/*
 * Clients of an earlier text of version 1 (PROTOCOL.md 4.1): the daemon
 * serves them, and sends them nothing that text did not define.
 *
 *  - the byte transcripts of protocol/vectors/earlier/ (a first-text
 *    editor and viewer) are replayed; every message the daemon sends back
 *    is checked against the first text: types 1..22, its flags (no LEVEL,
 *    no UNDO/REDO), a WELCOME without features, a 64-byte STATS, scenes
 *    of its kinds only;
 *  - one UNDO in a session with an earlier client: it gets the undo's
 *    operations as a plain EDIT_APPLIED, stays connected, and its mirror
 *    equals the scene; a current client gets the UNDO flag;
 *  - coarse levels go only to clients that announced LEVELS;
 *  - a scene the earlier client cannot decode (a unary node, a primitive
 *    kind above 16) ends its connection with ERROR ENOTSUP, never with
 *    bytes it would refuse.
 */
#include <jansson.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "test.h"
#include "daemon.h"

static char base_dir[96];

/* Whether m is something the first text of version 1 defines, as a
 * server's message: why not in *why. */
static bool first_text_ok(const struct bc_msg *m, const char **why)
{
	uint16_t allowed = 0;
	*why = NULL;
	switch (m->type) {
	case BC_MSG_WELCOME:
		if (m->welcome.has_features) {
			*why = "WELCOME with a features field";
		}
		break;
	case BC_MSG_ERROR:
		allowed = BC_PROTO_FLAG_FATAL;
		break;
	case BC_MSG_EDIT_APPLIED:
		allowed = BC_PROTO_FLAG_INTERACTING;
		break;
	case BC_MSG_FRAME:
		allowed = BC_PROTO_FLAG_STILL | BC_PROTO_FLAG_SNAPSHOT |
		          BC_PROTO_FLAG_INCOMPLETE;
		break;
	case BC_MSG_STATS:
		if (m->stats.has_load || m->stats.has_tls) {
			*why = "STATS longer than 64 bytes";
		}
		break;
	case BC_MSG_PING:
	case BC_MSG_PONG:
	case BC_MSG_OK:
	case BC_MSG_SESSION_INFO:
	case BC_MSG_SCENE_STATE:
	case BC_MSG_PICK_RESULT:
		break;
	default:
		*why = "a type the first text does not define";
		return false;
	}
	if (!*why && (m->flags & ~allowed)) {
		*why = "a flag the first text does not define";
	}
	if (!*why && bc_proto_msg_features(m) != 0) {
		*why = "a feature (level, undo, kind) it did not announce";
	}
	return *why == NULL;
}

/* Receives one message into c->m and checks it against the first text. */
static int recv_first_text(struct conn *c, int timeout_ms)
{
	const char *why;
	int rc = conn_recv(c, timeout_ms);
	if (rc == 1 && !first_text_ok(&c->m, &why)) {
		fprintf(stderr,
		        "  to an earlier client: %s (type %d flags 0x%x)\n",
		        why, (int)c->m.type, (unsigned)c->m.flags);
		bc_test_failures++;
	}
	return rc;
}

static uint32_t jget(const json_t *o, const char *k, uint32_t dflt)
{
	json_t *v = json_object_get(o, k);
	return v ? (uint32_t)json_integer_value(v) : dflt;
}

/* Whether c->m is what step e waits for. */
static bool matches(const struct conn *c, const json_t *e)
{
	const struct bc_msg *m = &c->m;
	const char *type = json_string_value(json_object_get(e, "expect"));
	const char *code = json_string_value(json_object_get(e, "code"));
	if (strcmp(bc_proto_type_name(m->type), type) != 0) {
		return false;
	}
	if (json_object_get(e, "seq") && m->seq != jget(e, "seq", 0)) {
		return false;
	}
	if (code && strcmp(bc_err_name(-(int)m->error.code), code) != 0) {
		return false;
	}
	if (m->type == BC_MSG_SCENE_STATE && json_object_get(e, "author_seq") &&
	    m->scene_state.author_seq != jget(e, "author_seq", 0)) {
		return false;
	}
	if (m->type == BC_MSG_EDIT_APPLIED &&
	    m->edit_applied.author_seq != jget(e, "author_seq", 0)) {
		return false;
	}
	if (m->type == BC_MSG_FRAME) {
		if (json_object_get(e, "camera_seq") &&
		    m->frame.camera_seq != jget(e, "camera_seq", 0)) {
			return false;
		}
		if (json_is_true(json_object_get(e, "still")) &&
		    !(m->flags & BC_PROTO_FLAG_STILL)) {
			return false;
		}
		if (json_is_true(json_object_get(e, "snapshot")) &&
		    !(m->flags & BC_PROTO_FLAG_SNAPSHOT)) {
			return false;
		}
	}
	return true;
}

/* One transcript: its bytes sent as they are, each awaited answer read
 * (every message on the way checked). */
static void replay(const struct daemon *d, const json_t *tr)
{
	const json_t *steps = json_object_get(tr, "steps");
	const char *name = json_string_value(json_object_get(tr, "name"));
	struct conn c;
	size_t i;
	json_t *e;
	REQUIRE(conn_open(&c, d) == 0);
	json_array_foreach(steps, i, e)
	{
		const char *hex = json_string_value(json_object_get(e, "send"));
		if (hex) {
			size_t n = strlen(hex) / 2;
			uint8_t *b = bc_malloc(n);
			REQUIRE(b);
			for (size_t k = 0; k < n; k++) {
				unsigned v;
				REQUIRE(sscanf(hex + 2 * k, "%2x", &v) == 1);
				b[k] = (uint8_t)v;
			}
			REQUIRE(send_raw(&c, b, n) == 0);
			bc_free(b);
			continue;
		}
		for (;;) {
			int rc = recv_first_text(&c, 30000);
			if (rc != 1) {
				fprintf(stderr,
				        "  transcript %s, step %zu: no %s "
				        "(%s)\n",
				        name, i,
				        json_string_value(
				            json_object_get(e, "expect")),
				        rc == 0 ? "timeout" : "closed");
				bc_test_failures++;
				conn_close(&c);
				return;
			}
			if (matches(&c, e)) {
				break;
			}
		}
	}
	conn_close(&c);
}

static void earlier_transcripts_are_served(void)
{
	struct daemon d;
	char dir[128];
	json_error_t err;
	json_t *doc =
	    json_load_file(BC_VECTORS_DIR "/earlier/first_text.json", 0, &err);
	size_t i;
	json_t *tr;
	REQUIRE(doc);
	snprintf(dir, sizeof(dir), "%s/transcripts", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	CHECK(json_array_size(json_object_get(doc, "transcripts")) >= 2);
	json_array_foreach(json_object_get(doc, "transcripts"), i, tr)
	{
		replay(&d, tr);
	}
	json_decref(doc);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* A scene of the first text's kinds: a union of two spheres, ids 1..3. */
#define SMALL_SCENE                                                            \
	"{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 5], \"target\": [0, "  \
	"0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 40}, \"root\": {\"type\": "  \
	"\"union\", \"id\": 1, \"children\": [{\"type\": \"sphere\", \"id\": " \
	"2, \"radius\": 0.5, \"translate\": [-0.6, 0, 0]}, {\"type\": "        \
	"\"sphere\", \"id\": 3, \"radius\": 0.4, \"translate\": [0.6, 0, "     \
	"0]}]}}"

/* INSERT of subtree bytes under node 1 (appended). */
static uint32_t insert_under_root(struct conn *c, const uint8_t *sub,
                                  size_t len)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	struct bc_proto_edit_op op = {
	    .kind = BC_PROTO_EDIT_INSERT, .node = 1, .position = 2};
	op.subtree.ptr = sub;
	op.subtree.len = (uint32_t)len;
	m.edit.nops = 1;
	m.edit.ops = &op;
	return conn_send(c, &m);
}

/* Scene bytes of one primitive (JSON text of its node). */
static void prim_bytes(const char *node_json, uint8_t **bytes, size_t *len)
{
	char json[512];
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	snprintf(json, sizeof(json), "{\"blobcast\": 1, \"root\": %s}",
	         node_json);
	REQUIRE(t &&
	        bc_scene_parse_json(json, strlen(json), t, &cam, NULL) == 0);
	REQUIRE(bc_scene_encode(t, NULL, bytes, len) == 0);
	bc_tree_destroy(t);
}

/* Waits for the EDIT_APPLIED of order > after on c (earlier client:
 * every message checked), applying it to *mirror. */
static void mirror_next_edit(struct conn *c, struct bc_tree **mirror,
                             bool earlier)
{
	for (;;) {
		int rc =
		    earlier ? recv_first_text(c, 30000) : conn_recv(c, 30000);
		REQUIRE(rc == 1);
		if (c->m.type == BC_MSG_EDIT_APPLIED) {
			CHECK(bc_edit_replay(mirror, &c->m.edit_applied,
			                     NULL) == 0);
			return;
		}
	}
}

/* Whether the scene a fresh joiner of session s gets equals mirror. */
static void joiner_sees(const struct daemon *d, const char *s,
                        const struct bc_tree *mirror, bool *same)
{
	struct conn j;
	struct bc_tree *t;
	uint8_t *a = NULL, *b = NULL;
	size_t na = 0, nb = 0;
	*same = false;
	REQUIRE(conn_open(&j, d) == 0);
	REQUIRE(conn_hello(&j, "joiner") == 0);
	REQUIRE(conn_join(&j, s, BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&j, BC_MSG_SCENE_STATE, 30000) == 1);
	REQUIRE((t = scene_of(&j)));
	REQUIRE(bc_scene_encode(t, NULL, &a, &na) == 0);
	REQUIRE(bc_scene_encode(mirror, NULL, &b, &nb) == 0);
	*same = na == nb && memcmp(a, b, na) == 0;
	bc_free(a);
	bc_free(b);
	bc_tree_destroy(t);
	conn_close(&j);
}

static void one_undo_with_an_earlier_client(void)
{
	struct daemon d;
	struct conn ed, old;
	struct bc_tree *mirror;
	struct bc_msg m = {.type = BC_MSG_UNDO};
	struct bc_msg ping = {.type = BC_MSG_PING};
	uint8_t *sub = NULL;
	size_t len = 0;
	uint32_t seq;
	bool same;
	char dir[128];
	snprintf(dir, sizeof(dir), "%s/undo", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&ed, &d) == 0);
	REQUIRE(conn_hello(&ed, "editor") == 0);
	REQUIRE(conn_join(&ed, "u", BC_PROTO_ROLE_EDITOR, true) == 0);
	conn_load_json(&ed, SMALL_SCENE);
	/* The earlier client joins and mirrors the scene. */
	REQUIRE(conn_open(&old, &d) == 0);
	REQUIRE(conn_hello_as(&old, "first-text", BC_PROTO_ENCODINGS_ALL, false,
	                      0) == 0);
	REQUIRE(conn_join(&old, "u", BC_PROTO_ROLE_VIEWER, false) == 0);
	do {
		REQUIRE(recv_first_text(&old, 30000) == 1);
	} while (old.m.type != BC_MSG_SCENE_STATE);
	REQUIRE((mirror = scene_of(&old)));
	/* An edit, then one UNDO of it by the current client. */
	prim_bytes("{\"type\": \"sphere\", \"id\": 7, \"radius\": 0.3}", &sub,
	           &len);
	REQUIRE(insert_under_root(&ed, sub, len));
	bc_free(sub);
	mirror_next_edit(&old, &mirror, true);
	CHECK_EQ_INT((int)bc_tree_node_count(mirror), 4);
	seq = conn_send(&ed, &m);
	/* The editor (UNDO announced) hears it as an undo ... */
	do {
		REQUIRE(conn_expect(&ed, BC_MSG_EDIT_APPLIED, 30000) == 1);
	} while (ed.m.edit_applied.author_seq != seq);
	CHECK(ed.m.flags & BC_PROTO_FLAG_UNDO);
	CHECK(ed.m.edit_applied.target_order > 0);
	/* ... the earlier client as a plain edit that it applies. */
	mirror_next_edit(&old, &mirror, true);
	CHECK(!(old.m.flags & BC_PROTO_FLAG_UNDO));
	CHECK_EQ_INT((int)old.m.edit_applied.author_seq, (int)seq);
	CHECK_EQ_INT((int)bc_tree_node_count(mirror), 3);
	joiner_sees(&d, "u", mirror, &same);
	CHECK(same);
	/* Still connected and answered. */
	ping.ping.stamp = 42;
	seq = conn_send(&old, &ping);
	for (;;) {
		REQUIRE(recv_first_text(&old, 30000) == 1);
		if (old.m.type == BC_MSG_PONG) {
			CHECK_EQ_INT((int)old.m.seq, (int)seq);
			break;
		}
	}
	bc_tree_destroy(mirror);
	conn_close(&old);
	conn_close(&ed);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Frames while dragging with downscale 8: the levels each client gets. */
static void levels_seen(struct conn *c, struct conn *driver, bool earlier,
                        uint32_t *seen)
{
	struct bc_msg cam = {.type = BC_MSG_CAMERA,
	                     .flags = BC_PROTO_FLAG_INTERACTING};
	*seen = 0;
	REQUIRE(conn_view_scaled(c, 256, 192, BC_PROTO_ENC_RAW, 8));
	for (int i = 0; i < 6; i++) {
		float eye[3] = {0.2f * (float)i, 0.0f, 5.0f};
		int64_t end = t_now_ms() + 20000;
		uint32_t seq;
		memcpy(cam.camera.eye, eye, sizeof(eye));
		cam.camera.up[1] = 1.0f;
		cam.camera.fov_y_deg = 40.0f;
		seq = conn_send(driver, &cam);
		(void)seq;
		/* The first frame after the camera change. */
		while (t_now_ms() < end) {
			int rc = earlier ? recv_first_text(c, 20000)
			                 : conn_recv(c, 20000);
			REQUIRE(rc == 1);
			if (c->m.type == BC_MSG_FRAME) {
				*seen |= 1u << bc_proto_flags_level(c->m.flags);
				break;
			}
		}
	}
}

static void levels_only_for_clients_that_announced_them(void)
{
	struct daemon d;
	struct conn now, old;
	uint32_t now_levels, old_levels;
	char dir[128];
	snprintf(dir, sizeof(dir), "%s/levels", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&now, &d) == 0);
	REQUIRE(conn_hello(&now, "now") == 0);
	REQUIRE(conn_join(&now, "lv", BC_PROTO_ROLE_EDITOR, true) == 0);
	conn_load_json(&now, SMALL_SCENE);
	levels_seen(&now, &now, false, &now_levels);
	REQUIRE(conn_open(&old, &d) == 0);
	REQUIRE(conn_hello_as(&old, "first-text", BC_PROTO_ENCODINGS_ALL, false,
	                      0) == 0);
	REQUIRE(conn_join(&old, "lv2", BC_PROTO_ROLE_EDITOR, true) == 0);
	levels_seen(&old, &old, true, &old_levels);
	/* The current client is sent coarse levels while it drags (so the
	 * check below can fail); the earlier one only level 0. */
	CHECK(now_levels & ~1u);
	CHECK_EQ_INT((int)old_levels, 1);
	conn_close(&old);
	conn_close(&now);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* An earlier client in session s; expects ERROR ENOTSUP (FATAL) and the
 * end of its connection once a node it cannot decode appears. */
static void earlier_refused_with_enotsup(struct conn *old)
{
	bool refused = false;
	for (;;) {
		int rc = recv_first_text(old, 30000);
		if (rc != 1) {
			CHECK(rc == -1); /* closed, not a timeout */
			break;
		}
		if (old->m.type == BC_MSG_ERROR) {
			CHECK_EQ_INT(old->m.error.code, -BC_ENOTSUP);
			CHECK(old->m.flags & BC_PROTO_FLAG_FATAL);
			refused = true;
		}
	}
	CHECK(refused);
}

static void kinds_it_cannot_decode_end_its_connection(void)
{
	struct daemon d;
	struct conn ed, old, late;
	uint8_t *sub = NULL;
	size_t len = 0;
	char dir[128];
	snprintf(dir, sizeof(dir), "%s/kinds", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&ed, &d) == 0);
	REQUIRE(conn_hello(&ed, "editor") == 0);
	REQUIRE(conn_join(&ed, "k", BC_PROTO_ROLE_EDITOR, true) == 0);
	conn_load_json(&ed, SMALL_SCENE);
	REQUIRE(conn_open(&old, &d) == 0);
	REQUIRE(conn_hello_as(&old, "first-text", BC_PROTO_ENCODINGS_ALL, false,
	                      0) == 0);
	REQUIRE(conn_join(&old, "k", BC_PROTO_ROLE_VIEWER, false) == 0);
	do {
		REQUIRE(recv_first_text(&old, 30000) == 1);
	} while (old.m.type != BC_MSG_SCENE_STATE);
	/* A twist around a sphere: a unary node of the later text. */
	prim_bytes("{\"type\": \"twist\", \"id\": 8, \"rate\": 1, "
	           "\"children\": [{\"type\": \"sphere\", \"id\": 9, "
	           "\"radius\": 0.2}]}",
	           &sub, &len);
	REQUIRE(insert_under_root(&ed, sub, len));
	bc_free(sub);
	REQUIRE(conn_expect(&ed, BC_MSG_EDIT_APPLIED, 30000) == 1);
	earlier_refused_with_enotsup(&old);
	conn_close(&old);
	/* Joining the session now: refused the same way. */
	REQUIRE(conn_open(&late, &d) == 0);
	REQUIRE(conn_hello_as(&late, "first-text", BC_PROTO_ENCODINGS_ALL,
	                      false, 0) == 0);
	REQUIRE(conn_join(&late, "k", BC_PROTO_ROLE_VIEWER, false) == 0);
	earlier_refused_with_enotsup(&late);
	conn_close(&late);
	/* The current client was never disturbed. */
	{
		struct bc_msg ping = {.type = BC_MSG_PING};
		uint32_t seq = conn_send(&ed, &ping);
		do {
			REQUIRE(conn_expect(&ed, BC_MSG_PONG, 30000) == 1);
		} while (ed.m.seq != seq);
	}
	conn_close(&ed);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

int main(int argc, char **argv)
{
	static const struct bc_test tests[] = {
	    {"earlier_transcripts_are_served", earlier_transcripts_are_served},
	    {"one_undo_with_an_earlier_client",
	     one_undo_with_an_earlier_client},
	    {"levels_only_for_clients_that_announced_them",
	     levels_only_for_clients_that_announced_them},
	    {"kinds_it_cannot_decode_end_its_connection",
	     kinds_it_cannot_decode_end_its_connection},
	};
	return daemon_tests_run("earlier", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
