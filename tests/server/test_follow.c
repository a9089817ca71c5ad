/*
 * Presenting and following in blobcastd, over raw protocol connections:
 * followers' cameras track the presenter's and their frames are rendered
 * at their own view sizes (a follower's snapshot equals that of a member
 * that set the presenter's camera itself); a follower that moves its own
 * camera leaves the follow; a presenter that leaves or disconnects ends
 * the presentation for everyone; a second presenter replaces the first;
 * viewers may follow; bad values and states are refused with their codes;
 * connections that never sent a presentation message are never sent one.
 * The session camera (SESSION_CAMERA) is ordered like an edit, survives
 * kill -9 and is what joiners start from.
 */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[48];

static const struct bc_msg_camera cam1 = {
    {0.0f, 1.0f, 6.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 40.0f};
static const struct bc_msg_camera cam2 = {
    {4.0f, 2.5f, 3.0f}, {0.0f, 0.2f, 0.0f}, {0.0f, 1.0f, 0.0f}, 55.0f};
static const struct bc_msg_camera cam3 = {
    {-3.0f, 1.5f, 4.5f}, {0.1f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 35.0f};

static bool same_camera(const struct bc_msg_camera *a,
                        const struct bc_msg_camera *b)
{
	return memcmp(a, b, sizeof(*a)) == 0;
}

/* Connects, says hello as name (announcing features when announce, else
 * as an earlier client) and joins (creating) session s. */
static void member_as(struct conn *c, const struct daemon *d, const char *name,
                      const char *s, enum bc_proto_role role, bool create,
                      bool announce, uint32_t features)
{
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello_as(c, name, BC_PROTO_ENCODINGS_ALL, announce,
	                      features) == 0);
	REQUIRE(conn_join(c, s, role, create) == 0);
	REQUIRE(conn_expect(c, BC_MSG_SCENE_STATE, 5000) == 1);
}

static void member(struct conn *c, const struct daemon *d, const char *name,
                   const char *s, enum bc_proto_role role, bool create)
{
	member_as(c, d, name, s, role, create, true, BC_PROTO_FEATURES_READ);
}

static uint32_t send_toggle(struct conn *c, enum bc_msg_type t, uint8_t on)
{
	struct bc_msg m = {.type = t};
	m.toggle.on = on;
	return conn_send(c, &m);
}

static uint32_t send_camera(struct conn *c, const struct bc_msg_camera *k,
                            bool interacting)
{
	struct bc_msg m = {.type = BC_MSG_CAMERA};
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	m.camera = *k;
	return conn_send(c, &m);
}

/* Receives until OK or ERROR answering seq; returns 0 for OK, the
 * ERROR's code (negative), or 1 on a timeout. PRESENTER messages on the
 * way are kept in *pm (when not NULL). */
static int await_answer(struct conn *c, uint32_t seq,
                        struct bc_msg_presenter *pm)
{
	int64_t end = t_now_ms() + 5000;
	while (t_now_ms() < end) {
		if (conn_recv(c, 100) != 1) {
			continue;
		}
		if (c->m.type == BC_MSG_PRESENTER && pm) {
			*pm = c->m.presenter;
		}
		if (c->m.type == BC_MSG_OK && c->m.seq == seq) {
			return 0;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			return -(int)c->m.error.code;
		}
	}
	return 1;
}

/* The next PRESENTER within ms into *pm; false when none came. */
static bool next_presenter(struct conn *c, int ms, struct bc_msg_presenter *pm)
{
	if (conn_expect(c, BC_MSG_PRESENTER, ms) != 1) {
		return false;
	}
	*pm = c->m.presenter;
	return true;
}

/* Whether a message of type arrives within ms. */
static bool arrives(struct conn *c, enum bc_msg_type type, int ms)
{
	return conn_expect(c, type, ms) == 1;
}

/* A raw snapshot's pixels (bc_malloc'ed, *n bytes), NULL on failure. */
static uint8_t *snapshot(struct conn *c, size_t *n, uint16_t *w, uint16_t *h)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	uint32_t seq;
	uint8_t *px;
	m.snapshot.encoding = BC_PROTO_ENC_RAW;
	seq = conn_send(c, &m);
	for (;;) {
		if (conn_expect(c, BC_MSG_FRAME, 20000) != 1) {
			return NULL;
		}
		if (c->m.seq == seq && (c->m.flags & BC_PROTO_FLAG_SNAPSHOT)) {
			break;
		}
	}
	*n = c->m.frame.rects[0].data.len;
	*w = c->m.frame.width;
	*h = c->m.frame.height;
	if (!(px = bc_malloc(*n))) {
		return NULL;
	}
	memcpy(px, c->m.frame.rects[0].data.ptr, *n);
	return px;
}

/* Waits for a FRAME (any) and returns whether its view size is w x h. */
static bool frame_at(struct conn *c, uint16_t w, uint16_t h)
{
	if (conn_expect(c, BC_MSG_FRAME, 20000) != 1) {
		return false;
	}
	return c->m.frame.width == w && c->m.frame.height == h;
}

static void drain(struct conn *c)
{
	while (conn_recv(c, 200) == 1) {
	}
}

static void followers_track_the_presenter(void)
{
	struct daemon d;
	struct conn a, b, e, ref;
	struct bc_msg_presenter pm = {0};
	uint32_t ida, seq;
	uint8_t *pb, *pr;
	size_t nb = 0, nr = 0;
	uint16_t w, h, w2, h2;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/track", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&a, &d, "alice", "f", BC_PROTO_ROLE_EDITOR, true);
	member(&b, &d, "bob", "f", BC_PROTO_ROLE_VIEWER, false);
	member(&e, &d, "erin", "f", BC_PROTO_ROLE_EDITOR, false);

	/* alice presents from cam1 at 80x60. */
	conn_view(&a, 80, 60, BC_PROTO_ENC_RAW);
	send_camera(&a, &cam1, false);
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	CHECK_EQ_INT(await_answer(&a, seq, &pm), 0);
	ida = pm.presenter;
	CHECK(ida != 0);
	CHECK_EQ_INT(pm.following, 0);

	/* bob, a viewer, follows at 64x48; erin at 32x24. Each first
	 * learns who presents with FOLLOW 0. */
	conn_view(&b, 64, 48, BC_PROTO_ENC_RAW);
	seq = send_toggle(&b, BC_MSG_FOLLOW, 0);
	memset(&pm, 0, sizeof(pm));
	CHECK_EQ_INT(await_answer(&b, seq, &pm), 0);
	CHECK_EQ_INT(pm.presenter, ida);
	CHECK_EQ_INT(pm.following, 0);
	seq = send_toggle(&b, BC_MSG_FOLLOW, 1);
	REQUIRE(arrives(&b, BC_MSG_FOLLOW_CAMERA, 5000));
	CHECK_EQ_INT(b.m.follow_camera.presenter, ida);
	CHECK(same_camera(&b.m.follow_camera.camera, &cam1));
	CHECK_EQ_INT(await_answer(&b, seq, &pm), 0);
	CHECK_EQ_INT(pm.following, 1);
	conn_view(&e, 32, 24, BC_PROTO_ENC_JPEG);
	seq = send_toggle(&e, BC_MSG_FOLLOW, 1);
	REQUIRE(arrives(&e, BC_MSG_FOLLOW_CAMERA, 5000));
	CHECK_EQ_INT(await_answer(&e, seq, NULL), 0);
	drain(&b);
	drain(&e);

	/* alice drags to cam2: both followers get the camera, flagged
	 * INTERACTING, and frames at their own sizes. */
	send_camera(&a, &cam2, true);
	REQUIRE(arrives(&b, BC_MSG_FOLLOW_CAMERA, 5000));
	CHECK(same_camera(&b.m.follow_camera.camera, &cam2));
	CHECK_EQ_INT(b.m.flags, BC_PROTO_FLAG_INTERACTING);
	CHECK(frame_at(&b, 64, 48));
	REQUIRE(arrives(&e, BC_MSG_FOLLOW_CAMERA, 5000));
	CHECK(same_camera(&e.m.follow_camera.camera, &cam2));
	CHECK(frame_at(&e, 32, 24));
	send_camera(&a, &cam2, false);
	REQUIRE(arrives(&b, BC_MSG_FOLLOW_CAMERA, 5000));
	CHECK_EQ_INT(b.m.flags, 0);

	/* bob's picture is the one a member that set cam2 itself gets. */
	member(&ref, &d, "ref", "f", BC_PROTO_ROLE_VIEWER, false);
	conn_view(&ref, 64, 48, BC_PROTO_ENC_RAW);
	send_camera(&ref, &cam2, false);
	pb = snapshot(&b, &nb, &w, &h);
	pr = snapshot(&ref, &nr, &w2, &h2);
	REQUIRE(pb && pr);
	CHECK_EQ_INT(w, 64);
	CHECK_EQ_INT(h, 48);
	CHECK_EQ_INT(nb, nr);
	CHECK(nb == nr && memcmp(pb, pr, nb) == 0);
	bc_free(pb);
	bc_free(pr);
	conn_close(&ref);

	/* bob moves his own camera: he leaves the follow and is told;
	 * alice's next move reaches erin only. */
	drain(&b);
	drain(&e);
	send_camera(&b, &cam1, false);
	REQUIRE(next_presenter(&b, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, ida);
	CHECK_EQ_INT(pm.following, 0);
	send_camera(&a, &cam3, false);
	REQUIRE(arrives(&e, BC_MSG_FOLLOW_CAMERA, 5000));
	CHECK(same_camera(&e.m.follow_camera.camera, &cam3));
	CHECK(!arrives(&b, BC_MSG_FOLLOW_CAMERA, 600));

	/* alice leaves: the presentation ends for everyone. */
	{
		struct bc_msg m = {.type = BC_MSG_SESSION_LEAVE};
		conn_send(&a, &m);
	}
	REQUIRE(next_presenter(&e, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, 0);
	CHECK_EQ_INT(pm.following, 0);
	REQUIRE(next_presenter(&b, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, 0);
	/* ... and nobody can follow now. */
	seq = send_toggle(&e, BC_MSG_FOLLOW, 1);
	CHECK_EQ_INT(await_answer(&e, seq, NULL), BC_ESTATE);
	conn_close(&a);
	conn_close(&b);
	conn_close(&e);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* A follower whose view equals the presenter's shares its render, but
 * each FRAME carries its receiver's own last CAMERA in camera_seq (the
 * follow adds none, PROTOCOL.md 5); the presenter's carry its CAMERA's.
 * When another member deletes the session, the follower hears PRESENTER
 * 0 before its ERROR ENOSESSION, though it comes before the presenter in
 * the session. */
static void shared_frames_carry_each_ones_camera_seq(void)
{
	struct daemon d;
	struct conn a, b, p;
	struct bc_msg_presenter pm = {0};
	struct bc_msg del = {.type = BC_MSG_SESSION_DELETE};
	uint32_t seq, own_b, drag = 0, drag0 = 0;
	int frames_b = 0, frames_p = 0;
	bool told = false;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/camseq", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&a, &d, "alice", "c", BC_PROTO_ROLE_EDITOR, true);
	member(&b, &d, "bob", "c", BC_PROTO_ROLE_VIEWER, false);
	member(&p, &d, "carol", "c", BC_PROTO_ROLE_EDITOR, false);
	conn_view(&p, 64, 48, BC_PROTO_ENC_RAW);
	conn_view(&b, 64, 48, BC_PROTO_ENC_RAW);
	/* bob's own CAMERA, then carol's seqs run far ahead of bob's. */
	own_b = send_camera(&b, &cam3, false);
	for (int i = 0; i < 40; i++) {
		struct bc_msg ping = {.type = BC_MSG_PING};
		conn_send(&p, &ping);
	}
	seq = send_toggle(&p, BC_MSG_PRESENT, 1);
	CHECK_EQ_INT(await_answer(&p, seq, &pm), 0);
	seq = send_toggle(&b, BC_MSG_FOLLOW, 1);
	CHECK_EQ_INT(await_answer(&b, seq, NULL), 0);
	drain(&p);
	drain(&b);
	/* carol drags: both views are equal and show the same cameras. */
	for (int i = 0; i < 4; i++) {
		drag = send_camera(&p, (i % 2) ? &cam1 : &cam2, i < 3);
		drag0 = i == 0 ? drag : drag0;
	}
	CHECK(drag0 > own_b);
	for (int64_t end = t_now_ms() + 3000; t_now_ms() < end;) {
		if (conn_recv(&b, 100) == 1 && b.m.type == BC_MSG_FRAME) {
			frames_b++;
			CHECK_EQ_INT(b.m.frame.camera_seq, own_b);
		}
		if (conn_recv(&p, 100) == 1 && p.m.type == BC_MSG_FRAME) {
			/* One of carol's CAMERAs, or 0: a frame of her view
			 * from before them, which a loaded machine may send
			 * after the drain above. */
			uint32_t cs = p.m.frame.camera_seq;
			frames_p += cs != 0;
			CHECK(cs == 0 || (cs >= drag0 && cs <= drag));
		}
	}
	CHECK(frames_b > 0);
	CHECK(frames_p > 0);
	/* alice deletes the session: bob's follow ends, and he is told. */
	del.session_delete.name.ptr = "c";
	del.session_delete.name.len = 1;
	REQUIRE(conn_send(&a, &del));
	while (conn_recv(&b, 5000) == 1) {
		if (b.m.type == BC_MSG_PRESENTER) {
			told = b.m.presenter.presenter == 0 &&
			       b.m.presenter.following == 0;
		}
		if (b.m.type == BC_MSG_ERROR) {
			CHECK_EQ_INT(b.m.error.code, -BC_ENOSESSION);
			break;
		}
	}
	CHECK(told);
	conn_close(&a);
	conn_close(&b);
	conn_close(&p);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void presenters_race_and_disconnect(void)
{
	struct daemon d;
	struct conn a, b, f;
	struct bc_msg_presenter pm = {0};
	uint32_t ida, idb, seq;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/race", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&a, &d, "alice", "r", BC_PROTO_ROLE_EDITOR, true);
	member(&b, &d, "bob", "r", BC_PROTO_ROLE_VIEWER, false);
	member(&f, &d, "fay", "r", BC_PROTO_ROLE_VIEWER, false);
	send_camera(&a, &cam1, false);
	send_camera(&b, &cam2, false);
	conn_view(&f, 48, 32, BC_PROTO_ENC_JPEG);

	/* alice presents, then bob: the later one presents (a new presenter
	 * replaces the old), and everyone hears the same final presenter.
	 * alice's answer comes first: sent on two connections at once, the
	 * two requests reach the server in either order. */
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	CHECK_EQ_INT(await_answer(&a, seq, &pm), 0);
	seq = send_toggle(&b, BC_MSG_PRESENT, 1);
	CHECK_EQ_INT(await_answer(&b, seq, &pm), 0);
	seq = send_toggle(&f, BC_MSG_FOLLOW, 1);
	REQUIRE(arrives(&f, BC_MSG_FOLLOW_CAMERA, 5000));
	idb = f.m.follow_camera.presenter;
	CHECK(same_camera(&f.m.follow_camera.camera, &cam2));
	CHECK_EQ_INT(await_answer(&f, seq, &pm), 0);
	CHECK_EQ_INT(pm.presenter, idb);
	CHECK_EQ_INT(pm.following, 1);
	drain(&a);
	drain(&f);

	/* alice takes over again: fay follows her now, from cam1. */
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	REQUIRE(arrives(&f, BC_MSG_FOLLOW_CAMERA, 5000));
	ida = f.m.follow_camera.presenter;
	CHECK(ida != idb);
	CHECK(same_camera(&f.m.follow_camera.camera, &cam1));
	REQUIRE(next_presenter(&f, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, ida);
	CHECK_EQ_INT(pm.following, 1);
	REQUIRE(next_presenter(&b, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, ida);
	/* bob stopping, no longer presenting, changes nothing. */
	drain(&f);
	seq = send_toggle(&b, BC_MSG_PRESENT, 0);
	CHECK_EQ_INT(await_answer(&b, seq, &pm), 0);
	CHECK_EQ_INT(pm.presenter, ida);
	CHECK(!arrives(&f, BC_MSG_PRESENTER, 400));
	/* The presenter cannot follow. */
	seq = send_toggle(&a, BC_MSG_FOLLOW, 1);
	CHECK_EQ_INT(await_answer(&a, seq, NULL), BC_ESTATE);

	/* alice's connection drops: the presentation ends. */
	conn_close(&a);
	REQUIRE(next_presenter(&f, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, 0);
	CHECK_EQ_INT(pm.following, 0);
	REQUIRE(next_presenter(&b, 5000, &pm));
	CHECK_EQ_INT(pm.presenter, 0);
	conn_close(&b);
	conn_close(&f);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void refusals_and_old_clients(void)
{
	struct daemon d;
	struct conn a, old, np, v, x;
	struct bc_msg m = {.type = BC_MSG_SESSION_CAMERA};
	uint32_t seq;
	/* PRESENT with on = 2: a decoding error (ERANGE), fatal. */
	static const uint8_t bad_present[] = {
	    0x42, 0x43, 0x53, 0x54, 1, 28, 0, 0, 1, 0, 0, 0, 9, 0, 0, 0, 2};
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/refuse", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	/* Outside a session: ESTATE, not fatal. */
	REQUIRE(conn_open(&x, &d) == 0);
	REQUIRE(conn_hello(&x, "x") == 0);
	seq = send_toggle(&x, BC_MSG_FOLLOW, 0);
	CHECK_EQ_INT(await_answer(&x, seq, NULL), BC_ESTATE);
	REQUIRE(conn_join(&x, "q", BC_PROTO_ROLE_EDITOR, true) == 0);
	seq = send_toggle(&x, BC_MSG_FOLLOW, 1);
	CHECK_EQ_INT(await_answer(&x, seq, NULL), BC_ESTATE);
	REQUIRE(send_raw(&x, bad_present, sizeof(bad_present)) == 0);
	REQUIRE(conn_expect(&x, BC_MSG_ERROR, 5000) == 1);
	CHECK_EQ_INT(x.m.error.code, -BC_ERANGE);
	CHECK(x.m.flags & BC_PROTO_FLAG_FATAL);
	conn_close(&x);

	/* An earlier client (a HELLO without features) that never sent a
	 * presentation message hears nothing of it, and gets a session
	 * camera change as SCENE_STATE. */
	member_as(&old, &d, "old", "q", BC_PROTO_ROLE_VIEWER, false, false, 0);
	/* A client that announced features without PRESENT hears nothing
	 * of types 30, 31 and 33 either, even after sending FOLLOW (for an
	 * earlier client, sending one would announce them). */
	member_as(&np, &d, "np", "q", BC_PROTO_ROLE_VIEWER, false, true,
	          BC_PROTO_FEATURES_READ & ~BC_PROTO_FEATURE_PRESENT);
	seq = send_toggle(&np, BC_MSG_FOLLOW, 0);
	CHECK_EQ_INT(await_answer(&np, seq, NULL), 0);
	member(&a, &d, "alice", "q", BC_PROTO_ROLE_EDITOR, false);
	member(&v, &d, "vic", "q", BC_PROTO_ROLE_VIEWER, false);
	seq = send_toggle(&a, BC_MSG_PRESENT, 1);
	CHECK_EQ_INT(await_answer(&a, seq, NULL), 0);
	/* Viewers may not set the session camera. */
	m.session_camera = cam3;
	seq = conn_send(&v, &m);
	CHECK_EQ_INT(await_answer(&v, seq, NULL), BC_EPERM);
	/* An invalid camera: ERANGE, not fatal. */
	m.session_camera = cam3;
	memcpy(m.session_camera.target, m.session_camera.eye,
	       sizeof(m.session_camera.eye));
	seq = conn_send(&a, &m);
	CHECK_EQ_INT(await_answer(&a, seq, NULL), BC_ERANGE);
	m.session_camera = cam3;
	conn_send(&a, &m);
	REQUIRE(conn_expect(&old, BC_MSG_SCENE_STATE, 5000) == 1);
	{
		struct bc_tree *t = bc_tree_create();
		struct bc_camera got;
		bool has = false;
		REQUIRE(t);
		CHECK(bc_scene_decode(old.m.scene_state.scene.ptr,
		                      old.m.scene_state.scene.len, t, &got,
		                      &has, NULL) == 0);
		CHECK(has && memcmp(got.eye, cam3.eye, sizeof(got.eye)) == 0);
		bc_tree_destroy(t);
	}
	/* Nothing of type 30 or above reached the old member. */
	while (conn_recv(&old, 300) == 1) {
		CHECK(old.m.type < BC_MSG_PRESENTER);
	}
	while (conn_recv(&np, 300) == 1) {
		CHECK(np.m.type < BC_MSG_PRESENTER);
	}
	conn_close(&np);
	conn_close(&old);
	conn_close(&a);
	conn_close(&v);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* The SCENE_STATE camera a new joiner of session s gets. */
static bool joiner_camera(const struct daemon *d, const char *s,
                          struct bc_camera *cam, uint64_t *order)
{
	struct conn j;
	struct bc_tree *t = bc_tree_create();
	bool has = false, ok;
	member(&j, d, "joiner", s, BC_PROTO_ROLE_VIEWER, false);
	*order = j.m.scene_state.order;
	ok = t &&
	     bc_scene_decode(j.m.scene_state.scene.ptr,
	                     j.m.scene_state.scene.len, t, cam, &has,
	                     NULL) == 0 &&
	     has;
	bc_tree_destroy(t);
	conn_close(&j);
	return ok;
}

static void session_camera_survives_kill(void)
{
	struct daemon d;
	struct conn a;
	struct bc_msg m = {.type = BC_MSG_SESSION_CAMERA};
	struct bc_camera got;
	uint64_t order0, order1, order;
	uint32_t seq;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/kill", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&a, &d, "alice", "k", BC_PROTO_ROLE_EDITOR, true);
	order0 = a.m.scene_state.order;
	/* A refused edit takes no order number; the camera takes the
	 * next one. */
	seq = conn_move(&a, 0xfffffffu, 0, 0, 0, false);
	CHECK_EQ_INT(await_answer(&a, seq, NULL), BC_ENONODE);
	m.session_camera = cam3;
	seq = conn_send(&a, &m);
	REQUIRE(conn_expect(&a, BC_MSG_SESSION_CAMERA_SET, 5000) == 1);
	order1 = a.m.session_camera_set.order;
	CHECK_EQ_INT(order1, order0 + 1);
	CHECK_EQ_INT(a.m.session_camera_set.author_seq, seq);
	CHECK(same_camera(&a.m.session_camera_set.camera, &cam3));
	/* Joiners start from it and SCENE_STATE carries it. */
	REQUIRE(joiner_camera(&d, "k", &got, &order));
	CHECK(memcmp(got.eye, cam3.eye, sizeof(got.eye)) == 0);
	CHECK_EQ_INT(got.fov_y_deg, 35);
	CHECK_EQ_INT(order, order1);
	conn_close(&a);
	/* kill -9: the journal has it. */
	CHECK(WIFEXITED(daemon_stop(&d, SIGKILL)) == 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(joiner_camera(&d, "k", &got, &order));
	CHECK(memcmp(got.eye, cam3.eye, sizeof(got.eye)) == 0);
	CHECK(memcmp(got.target, cam3.target, sizeof(got.target)) == 0);
	CHECK_EQ_INT(order, order1);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"shared_frames_carry_each_ones_camera_seq",
     shared_frames_carry_each_ones_camera_seq},
    {"followers_track_the_presenter", followers_track_the_presenter},
    {"presenters_race_and_disconnect", presenters_race_and_disconnect},
    {"refusals_and_old_clients", refusals_and_old_clients},
    {"session_camera_survives_kill", session_camera_survives_kill},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("follow", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
