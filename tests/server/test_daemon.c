/*
 * blobcastd end to end over its Unix socket: sessions and members, ordered
 * edits seen by everyone, late joiners, roles, frames and damage, bad input
 * that must not disturb other clients, and crash safety (kill -9 in a
 * stream of edits loses no acknowledged edit, leaves no temporary files).
 */
#include <dirent.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

static void make_dir_name(char *out, size_t n, const char *what)
{
	size_t lb = strlen(base_dir), lw = strlen(what);
	if (lb + 1 + lw + 1 > n) {
		out[0] = '\0';
		return;
	}
	memcpy(out, base_dir, lb);
	out[lb] = '/';
	memcpy(out + lb + 1, what, lw + 1);
}

/* The scene from the last SCENE_STATE received on c. */
static uint32_t first_prim_id(const struct bc_tree *t)
{
	const struct bc_lin *l = bc_tree_lin(t);
	return l->node_id[l->prim_slot[0]];
}

/* The primitive with the smallest ABV: moving it damages little. */
static uint32_t smallest_prim_id(const struct bc_tree *t)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t best = 0;
	float best_vol = INFINITY;
	for (uint32_t k = 0; k < l->nprims; k++) {
		float lo[3], hi[3], vol;
		struct bc_abv a = bc_lin_abv(l, k);
		bc_abv_aabb(&a, lo, hi);
		vol = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
		if (vol < best_vol) {
			best_vol = vol;
			best = k;
		}
	}
	return l->node_id[l->prim_slot[best]];
}

static void members_see_the_same_edits_in_order(void)
{
	struct daemon d;
	struct conn a, b, late, viewer;
	struct bc_tree *t;
	char dir[64];
	uint32_t id, seq;
	uint64_t orders_a[4], orders_b[4];
	float last_x = -1.0f;
	make_dir_name(dir, sizeof(dir), "order");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_open(&b, &d) == 0);
	REQUIRE(conn_hello(&a, "alice") == 0 && conn_hello(&b, "bob") == 0);
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	REQUIRE((t = scene_of(&a)) != NULL);
	id = first_prim_id(t);
	bc_tree_destroy(t);
	REQUIRE(conn_join(&b, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&b, BC_MSG_SCENE_STATE, 5000) == 1);
	/* Interleaved edits from both editors. */
	for (int i = 0; i < 4; i++) {
		struct conn *who = (i % 2) ? &b : &a;
		REQUIRE(conn_move(who, id, 0.1f * (float)i, 0, 0, false));
	}
	for (int i = 0; i < 4; i++) {
		REQUIRE(conn_expect(&a, BC_MSG_EDIT_APPLIED, 5000) == 1);
		orders_a[i] = a.m.edit_applied.order;
		/* The connections race: the server's order decides. */
		last_x = a.m.edit_applied.ops[0].fields[0].v[0];
		REQUIRE(conn_expect(&b, BC_MSG_EDIT_APPLIED, 5000) == 1);
		orders_b[i] = b.m.edit_applied.order;
		CHECK(orders_a[i] == orders_b[i]);
		CHECK(i == 0 || orders_a[i] == orders_a[i - 1] + 1);
	}
	/* A late joiner gets the state as of the last order. */
	REQUIRE(conn_open(&late, &d) == 0 && conn_hello(&late, "late") == 0);
	REQUIRE(conn_join(&late, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&late, BC_MSG_SCENE_STATE, 5000) == 1);
	CHECK(late.m.scene_state.order == orders_a[3]);
	REQUIRE((t = scene_of(&late)) != NULL);
	{
		struct bc_prim_data p;
		CHECK(bc_tree_get(t, id, &p, NULL));
		CHECK(p.translate[0] == last_x);
	}
	bc_tree_destroy(t);
	/* A viewer cannot edit. */
	viewer = late;
	seq = conn_move(&viewer, id, 1, 1, 1, false);
	REQUIRE(conn_expect(&viewer, BC_MSG_ERROR, 5000) == 1);
	CHECK(viewer.m.seq == seq);
	CHECK(viewer.m.error.code == (uint16_t)-BC_EPERM);
	/* Unknown ids are refused; the connection stays usable. */
	seq = conn_move(&a, 999999, 0, 0, 0, false);
	REQUIRE(conn_expect(&a, BC_MSG_ERROR, 5000) == 1);
	CHECK(a.m.seq == seq && a.m.error.code == (uint16_t)-BC_ENONODE);
	{
		struct bc_msg ping = {.type = BC_MSG_PING};
		ping.ping.stamp = 42;
		conn_send(&a, &ping);
		REQUIRE(conn_expect(&a, BC_MSG_PONG, 5000) == 1);
		CHECK(a.m.ping.stamp == 42);
	}
	conn_close(&a);
	conn_close(&b);
	conn_close(&late);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void frames_follow_views_and_edits_send_damage_only(void)
{
	struct daemon d;
	struct conn a;
	struct bc_tree *t;
	char dir[64];
	uint32_t id;
	uint64_t order;
	make_dir_name(dir, sizeof(dir), "frames");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	/* VIEW and CAMERA may come before joining: they wait for it. */
	REQUIRE(conn_view(&a, 96, 64, BC_PROTO_ENC_RAW));
	{
		struct bc_msg cam = {.type = BC_MSG_CAMERA};
		cam.camera.eye[2] = 9.0f;
		cam.camera.up[1] = 1.0f;
		cam.camera.fov_y_deg = 40.0f;
		REQUIRE(conn_send(&a, &cam));
	}
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	REQUIRE((t = scene_of(&a)) != NULL);
	id = smallest_prim_id(t);
	bc_tree_destroy(t);
	/* Coarse pictures first (each whole at its level), then the
	 * still. */
	do {
		REQUIRE(conn_expect(&a, BC_MSG_FRAME, 20000) == 1);
		CHECK(a.m.frame.width == 96 && a.m.frame.height == 64);
		CHECK(a.m.frame.nrects == 1);
	} while (!(a.m.flags & BC_PROTO_FLAG_STILL));
	CHECK(a.m.frame.rects[0].data.len == 96u * 64u * 4u);
	CHECK(bc_proto_flags_level(a.m.flags) == 0);
	CHECK(a.m.frame.image_width == 96 && a.m.frame.image_height == 64);
	/* A small move: the still after it carries damaged blocks only. */
	REQUIRE(conn_move(&a, id, 0.01f, 0, 0, false));
	REQUIRE(conn_expect(&a, BC_MSG_EDIT_APPLIED, 5000) == 1);
	order = a.m.edit_applied.order;
	REQUIRE(conn_expect(&a, BC_MSG_FRAME, 20000) == 1);
	CHECK(a.m.frame.order == order);
	{
		uint64_t area = 0;
		for (uint32_t i = 0; i < a.m.frame.nrects; i++) {
			area += (uint64_t)a.m.frame.rects[i].w *
			        a.m.frame.rects[i].h;
			CHECK(a.m.frame.rects[i].data.len ==
			      4u * a.m.frame.rects[i].w * a.m.frame.rects[i].h);
		}
		CHECK(area < 96u * 64u);
	}
	/* PICK in the middle of the view answers with a node or a miss. */
	{
		struct bc_msg pk = {.type = BC_MSG_PICK};
		uint32_t seq;
		pk.pick.x = 48;
		pk.pick.y = 32;
		seq = conn_send(&a, &pk);
		REQUIRE(conn_expect(&a, BC_MSG_PICK_RESULT, 20000) == 1);
		CHECK(a.m.seq == seq);
	}
	/* A SNAPSHOT answers with a lossless full frame. */
	{
		struct bc_msg sn = {.type = BC_MSG_SNAPSHOT};
		sn.snapshot.encoding = BC_PROTO_ENC_PNG;
		conn_send(&a, &sn);
		for (;;) {
			REQUIRE(conn_expect(&a, BC_MSG_FRAME, 20000) == 1);
			if (a.m.flags & BC_PROTO_FLAG_SNAPSHOT) {
				break;
			}
		}
		CHECK(a.m.frame.encoding == BC_PROTO_ENC_PNG);
		CHECK(a.m.frame.nrects == 1);
		CHECK(memcmp(a.m.frame.rects[0].data.ptr, "\x89PNG", 4) == 0);
	}
	conn_close(&a);
	daemon_stop(&d, SIGTERM);
}

static void bad_input_never_disturbs_other_clients(void)
{
	struct daemon d;
	struct conn good, bad;
	char dir[64];
	uint8_t junk[4096];
	make_dir_name(dir, sizeof(dir), "bad");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&good, &d) == 0 && conn_hello(&good, "good") == 0);
	/* Random bytes. */
	srand(7);
	for (size_t i = 0; i < sizeof(junk); i++) {
		junk[i] = (uint8_t)rand();
	}
	REQUIRE(conn_open(&bad, &d) == 0);
	send_raw(&bad, junk, sizeof(junk));
	CHECK(conn_expect(&bad, BC_MSG_ERROR, 5000) != 0);
	conn_close(&bad);
	/* A header claiming 2^32-1 bytes of payload. */
	{
		uint8_t hdr[16] = {'B', 'C', 'S',  'T',  1,    BC_MSG_HELLO,
		                   0,   0,   0xff, 0xff, 0xff, 0xff,
		                   1,   0,   0,    0};
		REQUIRE(conn_open(&bad, &d) == 0);
		send_raw(&bad, hdr, sizeof(hdr));
		REQUIRE(conn_expect(&bad, BC_MSG_ERROR, 5000) == 1);
		CHECK(bad.m.error.code == (uint16_t)-BC_EPROTO_LENGTH);
		conn_close(&bad);
	}
	/* A huge view and a NaN camera after a proper HELLO. */
	{
		struct bc_msg cam = {.type = BC_MSG_CAMERA};
		REQUIRE(conn_open(&bad, &d) == 0 && conn_hello(&bad, "b") == 0);
		REQUIRE(conn_join(&bad, "default", BC_PROTO_ROLE_EDITOR,
		                  false) == 0);
		REQUIRE(conn_view(&bad, 8000, 8000, BC_PROTO_ENC_JPEG));
		REQUIRE(conn_expect(&bad, BC_MSG_ERROR, 5000) == 1);
		CHECK(bad.m.error.code == (uint16_t)-BC_ERANGE);
		cam.camera.eye[2] = 5.0f;
		cam.camera.up[1] = 1.0f;
		cam.camera.fov_y_deg = 45.0f;
		conn_send(&bad, &cam);
		/* An encoder refuses NaN, so patch the bytes by hand: eye.x
		 * is the payload's first float. */
		{
			struct bc_proto_buf b;
			bc_proto_buf_init(&b, 0);
			cam.seq = ++bad.seq;
			REQUIRE(bc_proto_encode(&b, &cam, NULL) == 0);
			memcpy(b.data + BC_PROTO_HEADER_SIZE,
			       "\x00\x00\xc0\x7f", 4);
			send_raw(&bad, b.data, b.len);
			bc_proto_buf_finish(&b);
		}
		REQUIRE(conn_expect(&bad, BC_MSG_ERROR, 5000) == 1);
		CHECK(bad.m.error.code == (uint16_t)-BC_ENONFINITE);
		conn_close(&bad);
	}
	/* A HELLO that never finishes: the daemon gives up on it. */
	{
		int64_t t0 = t_now_ms();
		REQUIRE(conn_open(&bad, &d) == 0);
		send_raw(&bad, "BCST\x01", 5);
		CHECK(conn_expect(&bad, BC_MSG_ERROR, 8000) != 0);
		CHECK(t_now_ms() - t0 < 8000);
		conn_close(&bad);
	}
	/* The good client never noticed. */
	{
		struct bc_msg ping = {.type = BC_MSG_PING};
		ping.ping.stamp = 7;
		conn_send(&good, &ping);
		REQUIRE(conn_expect(&good, BC_MSG_PONG, 5000) == 1);
	}
	conn_close(&good);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static bool has_temp_files(const char *dir)
{
	char path[512];
	DIR *dd;
	struct dirent *e;
	bool found = false;
	snprintf(path, sizeof(path), "%s/sessions/default", dir);
	if (!(dd = opendir(path))) {
		return true;
	}
	while ((e = readdir(dd))) {
		found = found || strstr(e->d_name, ".tmp") != NULL;
	}
	closedir(dd);
	return found;
}

static void kill_9_loses_no_acknowledged_edit(void)
{
	struct daemon d;
	struct conn a;
	struct bc_tree *t;
	char dir[64];
	uint32_t id;
	float last_acked = -1.0f;
	uint64_t last_order = 0, restored = 0;
	int acked = 0;
	make_dir_name(dir, sizeof(dir), "crash");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	REQUIRE((t = scene_of(&a)) != NULL);
	id = first_prim_id(t);
	bc_tree_destroy(t);
	/* Stream edits without waiting for them, read acknowledgements as
	 * they come, and kill the daemon once some are in while many more
	 * are still in flight. */
	for (int i = 1; i <= 400; i++) {
		conn_move(&a, id, 0.001f * (float)i, 0, 0, false);
	}
	while (acked < 40 && conn_recv(&a, 10000) == 1) {
		if (a.m.type == BC_MSG_EDIT_APPLIED) {
			last_order = a.m.edit_applied.order;
			last_acked = a.m.edit_applied.ops[0].fields[0].v[0];
			acked++;
		}
	}
	daemon_stop(&d, SIGKILL);
	conn_close(&a);
	CHECK(acked > 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_join(&a, "default", BC_PROTO_ROLE_EDITOR, false) == 0);
	REQUIRE(conn_expect(&a, BC_MSG_SCENE_STATE, 5000) == 1);
	restored = a.m.scene_state.order;
	CHECK(restored >= last_order);
	REQUIRE((t = scene_of(&a)) != NULL);
	{
		struct bc_prim_data p;
		CHECK(bc_tree_get(t, id, &p, NULL));
		/* Edits past the last one we saw may have been applied too
		 * (acknowledged in flight); none before it may be missing. */
		CHECK(p.translate[0] >= last_acked - 1e-6f);
	}
	bc_tree_destroy(t);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	CHECK(!has_temp_files(dir));
	printf("  %d edits acknowledged before the kill (last order %llu); "
	       "order %llu restored\n",
	       acked, (unsigned long long)last_order,
	       (unsigned long long)restored);
}

static void a_client_that_stops_reading_is_dropped(void)
{
	struct daemon d;
	struct conn lazy, busy;
	char dir[64];
	int64_t t0;
	int rc = 1;
	make_dir_name(dir, sizeof(dir), "stall");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&lazy, &d) == 0 && conn_hello(&lazy, "lazy") == 0);
	REQUIRE(conn_join(&lazy, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	/* A raw 1024^2 frame (4 MiB) cannot fit the socket buffer: its write
	 * stays pending while the client does not read. */
	{
		struct bc_msg v = {.type = BC_MSG_VIEW};
		v.view.width = 1024;
		v.view.height = 1024;
		v.view.encoding = BC_PROTO_ENC_RAW;
		v.view.quality_interactive = 50;
		v.view.quality_still = 90;
		v.view.downscale = 1;
		REQUIRE(conn_send(&lazy, &v));
	}
	REQUIRE(conn_open(&busy, &d) == 0 && conn_hello(&busy, "busy") == 0);
	t0 = t_now_ms();
	/* The other client keeps being served meanwhile. The stall limit
	 * (10 s) counts from the frame's first write, which waits for its
	 * render: the sanitized daemon's 1024^2 frame took long enough on
	 * a loaded machine that 25 s from here was once too few. */
	while (t_now_ms() - t0 < 60000) {
		struct bc_msg ping = {.type = BC_MSG_PING};
		struct pollfd pfd = {.fd = lazy.fd, .events = POLLIN};
		ping.ping.stamp = 1;
		conn_send(&busy, &ping);
		REQUIRE(conn_expect(&busy, BC_MSG_PONG, 5000) == 1);
		/* Look at the lazy socket without reading it (reading would
		 * unblock the daemon's write): a Unix socket whose peer has
		 * closed polls as hung up. */
		if (poll(&pfd, 1, 0) == 1 && (pfd.revents & POLLHUP)) {
			rc = 0;
			break;
		}
		t_sleep_ms(500);
	}
	CHECK(rc == 0);
	/* Dropped after the stall limit, not before. */
	CHECK(t_now_ms() - t0 >= 9000);
	printf("  dropped after %lld ms\n", (long long)(t_now_ms() - t0));
	conn_close(&lazy);
	conn_close(&busy);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Lays the rectangles of a level-0 raw FRAME on img (w x h RGBA) and
 * returns the pixels they cover. */
static uint64_t compose(uint8_t *img, uint32_t w, const struct bc_msg *m)
{
	uint64_t area = 0;
	for (uint32_t i = 0; i < m->frame.nrects; i++) {
		const struct bc_proto_rect *r = &m->frame.rects[i];
		CHECK(r->data.len == 4u * r->w * r->h && r->x + r->w <= w);
		for (uint32_t y = 0;
		     y < r->h && r->data.len == 4u * r->w * r->h; y++) {
			memcpy(img + 4 * ((size_t)(r->y + y) * w + r->x),
			       r->data.ptr + 4 * (size_t)y * r->w, 4u * r->w);
		}
		area += (uint64_t)r->w * r->h;
	}
	return area;
}

/* Sends one structural operation and lays every frame after its
 * EDIT_APPLIED on img until the still: each at the still's level (the
 * picture is not started over) and smaller than the view. */
static void structural_step(struct conn *c, struct bc_proto_edit_op op,
                            uint8_t *img, uint32_t w, uint32_t h)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	uint64_t order;
	m.edit.nops = 1;
	m.edit.ops = &op;
	REQUIRE(conn_send(c, &m));
	REQUIRE(conn_expect(c, BC_MSG_EDIT_APPLIED, 20000) == 1);
	order = c->m.edit_applied.order;
	do {
		REQUIRE(conn_expect(c, BC_MSG_FRAME, 20000) == 1);
		CHECK(c->m.frame.order >= order);
		CHECK(bc_proto_flags_level(c->m.flags) == 0);
		CHECK(compose(img, w, &c->m) < (uint64_t)w * h / 2);
	} while (!(c->m.flags & BC_PROTO_FLAG_STILL));
}

/* INSERT and REMOVE keep the picture too (the renderer follows the
 * spliced layout): a small sphere added at the end of the root union and
 * taken away again redraws only blocks it reaches, at the still's level,
 * and the picture after both equals the one before, bit for bit. */
static void structural_edits_send_damage_only(void)
{
	static const char scene[] =
	    "{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 9], "
	    "\"target\": [0, 0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 40}, "
	    "\"root\": {\"type\": \"smooth_union\", \"id\": 1, "
	    "\"blend\": 0.2, \"range\": 0.3, \"children\": ["
	    "{\"type\": \"sphere\", \"id\": 2, \"radius\": 0.8, "
	    "\"translate\": [-1.2, 0, 0]}, "
	    "{\"type\": \"sphere\", \"id\": 3, \"radius\": 0.6, "
	    "\"translate\": [1.2, 0, 0]}, "
	    "{\"type\": \"sphere\", \"id\": 4, \"radius\": 0.5, "
	    "\"translate\": [0, -1.2, 0]}]}}";
	enum { W = 96, H = 64 };
	static uint8_t before[W * H * 4], img[W * H * 4];
	static const float at[3] = {0.0f, 0.4f, 0.0f}, rot[4] = {0, 0, 0, 1};
	const float radius = 0.15f;
	struct bc_proto_buf sub;
	struct daemon d;
	struct conn a;
	char dir[64];
	make_dir_name(dir, sizeof(dir), "splice");
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "a") == 0);
	REQUIRE(conn_join(&a, "splice", BC_PROTO_ROLE_EDITOR, true) == 0);
	conn_load_json(&a, scene);
	REQUIRE(conn_view(&a, W, H, BC_PROTO_ENC_RAW));
	do {
		REQUIRE(conn_expect(&a, BC_MSG_FRAME, 20000) == 1);
	} while (!(a.m.flags & BC_PROTO_FLAG_STILL));
	REQUIRE(bc_proto_flags_level(a.m.flags) == 0);
	CHECK(compose(before, W, &a.m) == (uint64_t)W * H);
	memcpy(img, before, sizeof(img));
	bc_proto_buf_init(&sub, 0);
	REQUIRE(bc_proto_scene_begin(&sub, NULL, 1) == 0 &&
	        bc_proto_scene_prim(&sub, BC_PRIM_SPHERE, 50, at, rot, NULL, 1,
	                            &radius) == 0);
	structural_step(
	    &a,
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
	                              .node = 1,
	                              .position = 3,
	                              .subtree = {sub.data, (uint32_t)sub.len}},
	    img, W, H);
	bc_proto_buf_finish(&sub);
	CHECK(memcmp(img, before, sizeof(img)) != 0); /* the sphere shows */
	structural_step(
	    &a,
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 50},
	    img, W, H);
	CHECK(memcmp(img, before, sizeof(img)) == 0);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* n spheres of radius 0.02 (ids 2..n+1) under union 1, all at x >= 8,
 * outside the view of a camera at (0, 0, 6) looking at the origin: the
 * middle of the picture is empty. bc_free's the text. */
static char *far_spheres(uint32_t n)
{
	size_t cap = 256u + (size_t)n * 96u, len;
	char *s = bc_malloc(cap);
	if (!s) {
		return NULL;
	}
	len = (size_t)snprintf(
	    s, cap,
	    "{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 6], \"target\": "
	    "[0, 0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 45}, \"root\": "
	    "{\"type\": \"union\", \"id\": 1, \"children\": [");
	for (uint32_t k = 0; k < n; k++) {
		len += (size_t)snprintf(
		    s + len, cap - len,
		    "%s{\"type\": \"sphere\", \"id\": %u, \"radius\": 0.02, "
		    "\"translate\": [%u, %u, 0]}",
		    k ? ", " : "", k + 2u, 8u + k % 200u, k / 200u);
	}
	snprintf(s + len, cap - len, "]}}");
	return s;
}

/* The first PICK_RESULT answering seq: its node (0 also when none
 * came). */
static uint32_t picked(struct conn *c, uint32_t seq)
{
	while (conn_expect(c, BC_MSG_PICK_RESULT, 60000) == 1) {
		if (c->m.seq == seq) {
			return c->m.pick_result.node;
		}
	}
	return 0;
}

/* Member c (id) of a session of far_spheres that has no render copy:
 * sphere 2 moves into the empty middle of the view and grows, and sphere
 * 3 is removed, with nobody looking; then c views (96x64) and PICKs the
 * middle at once. The copy made for that picture must hold the edits:
 * the PICK hits sphere 2 and the first still shows the last order. */
static void edits_without_a_copy_are_drawn(struct conn *c, uint32_t id)
{
	struct bc_proto_field r = {
	    .field = BC_PROTO_FIELD_PARAM0, .count = 1, .v = {0.8f}};
	struct bc_proto_edit_op grow = {.kind = BC_PROTO_EDIT_SET,
	                                .node = 2,
	                                .nfields = 1,
	                                .fields = &r},
	                        cut = {.kind = BC_PROTO_EDIT_REMOVE, .node = 3};
	struct bc_msg m = {.type = BC_MSG_EDIT}, pk = {.type = BC_MSG_PICK};
	uint64_t order;
	uint32_t seq = conn_move(c, 2, 0, 0, 0, false);
	CHECK(conn_edit_answer(c, id, seq) != 0);
	m.edit.nops = 1;
	m.edit.ops = &grow;
	seq = conn_send(c, &m);
	CHECK(conn_edit_answer(c, id, seq) != 0);
	m.edit.ops = &cut;
	seq = conn_send(c, &m);
	CHECK((order = conn_edit_answer(c, id, seq)) != 0);
	REQUIRE(conn_view(c, 96, 64, BC_PROTO_ENC_PNG));
	pk.pick.x = 48;
	pk.pick.y = 32;
	seq = conn_send(c, &pk);
	CHECK(picked(c, seq) == 2);
	do {
		REQUIRE(conn_expect(c, BC_MSG_FRAME, 60000) == 1);
	} while (!(c->m.flags & BC_PROTO_FLAG_STILL));
	CHECK(c->m.frame.order == order);
}

/* Session name of daemon d (started on dir) gets scene json (freed here)
 * from a member who creates it and leaves; with restart the daemon is
 * then stopped and started again on dir. c joins it as an editor (its
 * member id in *id) and takes its SCENE_STATE. */
static void saved_then_joined(struct daemon *d, const char *dir,
                              const char *name, char *json, bool restart,
                              struct conn *c, uint32_t *id)
{
	REQUIRE(json != NULL);
	REQUIRE(conn_open(c, d) == 0 && conn_hello(c, "a") == 0);
	REQUIRE(conn_join(c, name, BC_PROTO_ROLE_EDITOR, true) == 0);
	conn_load_json(c, json);
	bc_free(json);
	conn_close(c);
	if (restart) {
		REQUIRE(WIFEXITED(daemon_stop(d, SIGTERM)));
		REQUIRE(daemon_start(d, dir) == 0);
	}
	REQUIRE(conn_open(c, d) == 0 && conn_hello(c, "b") == 0);
	REQUIRE(conn_join(c, name, BC_PROTO_ROLE_EDITOR, false) == 0);
	*id = c->m.session_info.member_id;
	REQUIRE(conn_expect(c, BC_MSG_SCENE_STATE, 60000) == 1);
}

/* A session restored from disk, or loaded by a member without a view into
 * a session nobody views (edits.c decodes it once), has no render copy
 * until a member wants a picture (frames.c, bc__session_copy): edits made
 * before that are not sent anywhere, and the copy made then must hold
 * them. A small scene's copy is made on the loop, a big one's (20 000
 * nodes or more) on a task with the session busy, the PICK sent at once
 * behind the VIEW parked until it is there. Restored small, restored
 * big, loaded big. */
static void a_session_is_drawn_with_edits_made_before_a_view(void)
{
	static const char *const names[] = {"lazy-small", "lazy-big",
	                                    "lazy-loaded"};
	for (int v = 0; v < 3; v++) {
		const char *name = names[v];
		struct daemon d;
		struct conn c;
		/* Static: a test that stops at a REQUIRE leaves
		 * daemon_log_path pointing here for the next one. */
		static char log[80];
		char dir[64];
		uint32_t id;
		make_dir_name(dir, sizeof(dir), name);
		snprintf(log, sizeof(log), "%s.log", dir);
		daemon_log_path = log;
		REQUIRE(daemon_start(&d, dir) == 0);
		daemon_log_path = NULL;
		saved_then_joined(&d, dir, name, far_spheres(v ? 20000u : 3u),
		                  v < 2, &c, &id);
		edits_without_a_copy_are_drawn(&c, id);
		/* The load made none: the view had it made, on a task (of the
		 * tree as then: 20 000 nodes, one sphere removed). */
		CHECK(v < 2 ||
		      daemon_log_count(log, "render copy of 20000 nodes "
		                            "made") == 1);
		conn_close(&c);
		CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	}
}

/* --render-idle: once nobody has looked at a session for that long (its
 * viewer left; an editor stays, without a view) its render copy goes
 * (frames.c, bc__session_copy_idle), and the next picture makes it again
 * with the edits made meanwhile, none of which reached a copy. The drop
 * must be logged after the viewer left (the copy of the load may go
 * before the view: nobody looked at it either). */
static void a_render_copy_nobody_looks_at_goes_and_comes_back(void)
{
	static const char *const opts[] = {"--render-idle", "1", NULL};
	static const char said[] = "render copy dropped";
	for (int big = 0; big < 2; big++) {
		const char *name = big ? "idle-big" : "idle-small";
		struct daemon d;
		struct conn c, v;
		static char log[80]; /* outlives a REQUIRE (above) */
		char dir[64], *json = far_spheres(big ? 20000u : 3u);
		uint32_t id;
		unsigned before;
		int64_t end;
		REQUIRE(json != NULL);
		make_dir_name(dir, sizeof(dir), name);
		snprintf(log, sizeof(log), "%s.log", dir);
		daemon_log_path = log;
		REQUIRE(daemon_start_with(&d, dir, opts) == 0);
		daemon_log_path = NULL;
		REQUIRE(conn_open(&c, &d) == 0 && conn_hello(&c, "a") == 0);
		REQUIRE(conn_join(&c, name, BC_PROTO_ROLE_EDITOR, true) == 0);
		id = c.m.session_info.member_id;
		conn_load_json(&c, json);
		bc_free(json);
		REQUIRE(conn_open(&v, &d) == 0 && conn_hello(&v, "v") == 0);
		REQUIRE(conn_join(&v, name, BC_PROTO_ROLE_VIEWER, false) == 0);
		REQUIRE(conn_view(&v, 96, 64, BC_PROTO_ENC_PNG));
		do {
			REQUIRE(conn_expect(&v, BC_MSG_FRAME, 60000) == 1);
		} while (!(v.m.flags & BC_PROTO_FLAG_STILL));
		before = daemon_log_count(log, said);
		conn_close(&v);
		end = t_now_ms() + 30000;
		while (daemon_log_count(log, said) == before &&
		       t_now_ms() < end) {
			t_sleep_ms(50);
		}
		CHECK(daemon_log_count(log, said) == before + 1);
		edits_without_a_copy_are_drawn(&c, id);
		conn_close(&c);
		CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	}
}

/* A VIEW and a PICK that come while a SCENE_LOAD is on its task (the
 * session busy) must see the loaded scene: the render copy they want
 * waits for the load (bc__session_copy). It used to be made at once, of
 * the old tree, on a task beside the load's, and to reach the work layer
 * after the load's own, so that the old scene was drawn and picked under
 * the new order. 100 000 far spheres restored (no copy yet); member a
 * loads one sphere in the middle of the view, and member b, joined
 * without a view, sends VIEW and PICK right behind it. */
static void a_view_during_a_load_sees_the_loaded_scene(void)
{
	static const char one[] =
	    "{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 6], \"target\": "
	    "[0, 0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 45}, \"root\": "
	    "{\"type\": \"sphere\", \"id\": 7, \"radius\": 1}}";
	struct bc_msg ld = {.type = BC_MSG_SCENE_LOAD},
	              pk = {.type = BC_MSG_PICK};
	struct bc_camera cam;
	struct bc_tree *t = bc_tree_create();
	struct daemon d;
	struct conn a, b;
	char dir[64];
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint32_t seq, id;
	REQUIRE(t);
	REQUIRE(bc_scene_parse_json(one, sizeof(one) - 1, t, &cam, NULL) == 0);
	REQUIRE(bc_scene_encode(t, &cam, &bytes, &len) == 0);
	bc_tree_destroy(t);
	make_dir_name(dir, sizeof(dir), "during");
	REQUIRE(daemon_start(&d, dir) == 0);
	saved_then_joined(&d, dir, "during", far_spheres(100000), true, &a,
	                  &id);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "viewer") == 0);
	REQUIRE(conn_join(&b, "during", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&b, BC_MSG_SCENE_STATE, 60000) == 1);
	ld.scene_load.scene.ptr = bytes;
	ld.scene_load.scene.len = (uint32_t)len;
	REQUIRE(conn_send(&a, &ld));
	REQUIRE(conn_view(&b, 96, 64, BC_PROTO_ENC_PNG));
	pk.pick.x = 48;
	pk.pick.y = 32;
	seq = conn_send(&b, &pk);
	CHECK(picked(&b, seq) == 7);
	bc_free(bytes);
	conn_close(&a);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"members_see_the_same_edits_in_order",
     members_see_the_same_edits_in_order},
    {"frames_follow_views_and_edits_send_damage_only",
     frames_follow_views_and_edits_send_damage_only},
    {"structural_edits_send_damage_only", structural_edits_send_damage_only},
    {"bad_input_never_disturbs_other_clients",
     bad_input_never_disturbs_other_clients},
    {"kill_9_loses_no_acknowledged_edit", kill_9_loses_no_acknowledged_edit},
    {"a_client_that_stops_reading_is_dropped",
     a_client_that_stops_reading_is_dropped},
    {"a_session_is_drawn_with_edits_made_before_a_view",
     a_session_is_drawn_with_edits_made_before_a_view},
    {"a_render_copy_nobody_looks_at_goes_and_comes_back",
     a_render_copy_nobody_looks_at_goes_and_comes_back},
    {"a_view_during_a_load_sees_the_loaded_scene",
     a_view_during_a_load_sees_the_loaded_scene},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("daemon", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
