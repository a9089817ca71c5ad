/*
 * The render scheduler and the loop, as clients see them:
 *  - a quiet session keeps its fair share beside a heavy one: its edits'
 *    frames come within a few of its own render times, measured against
 *    a run of the same edits alone (a calibration, so load on the machine
 *    moves both), where one render thread served sessions a job each;
 *  - a scene whose rays crawl (twist at a rate of 10^6) gives a whole,
 *    INCOMPLETE picture at once, delays nobody else, and SIGTERM still
 *    stops the daemon at once;
 *  - a stream of parameter edits reaches the frames as its newest value,
 *    in far fewer frames than edits;
 *  - a client's requests are answered in the order it sent them (a PING
 *    after an EDIT comes back after its EDIT_APPLIED), and a burst of
 *    them does not hold another client's PING behind it;
 *  - STATS's load section (PROTOCOL.md 7.18): the workers, the view
 *    cache and its cap, the loop's longest turn and request, the reset;
 *  - the view cache stays under its cap whatever the view sizes.
 */
#include <math.h>
#include <stdlib.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"
#include "srv_limits.h"

static char base_dir[48];

/* daemon.h's helpers this file does not need. */
static void unused(void)
{
	(void)conn_hello_enc;
	(void)conn_view;
}

static int cmp_i64(const void *a, const void *b)
{
	int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
	return (x > y) - (x < y);
}

static int64_t percentile(int64_t *v, int n, int p)
{
	qsort(v, (size_t)n, sizeof(*v), cmp_i64);
	return n ? v[(n - 1) * p / 100] : 0;
}

/* A member of session name (created when create) with a w x h view in
 * encoding enc (downscale 8: coarse first pictures allowed). */
static void member(struct conn *c, const struct daemon *d, const char *name,
                   bool create, uint16_t w, uint16_t h,
                   enum bc_proto_encoding enc)
{
	struct bc_msg m = {.type = BC_MSG_VIEW};
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello(c, name) == 0);
	REQUIRE(conn_join(c, name, BC_PROTO_ROLE_EDITOR, create) == 0);
	m.view.width = w;
	m.view.height = h;
	m.view.encoding = enc;
	m.view.quality_interactive = 60;
	m.view.quality_still = 90;
	m.view.downscale = 8;
	REQUIRE(conn_send(c, &m));
}

/* Loads a generated scene into c's session. */
static void load_gen(struct conn *c, const char *gen, uint32_t count,
                     enum bc_gen_blend blend)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_gen_opts o = {.count = count, .blend = blend};
	REQUIRE(t && bc_gen(gen, &o, t, &cam, NULL) == 0);
	conn_load_tree(c, t, &cam);
}

/* A scene of nspheres in a row, ids 2.., under a union with id 1. */
static void row_json(char *buf, size_t n, int nspheres)
{
	size_t at = (size_t)snprintf(buf, n,
	                             "{\"blobcast\": 1, \"root\": {\"type\": "
	                             "\"union\", \"id\": 1, \"children\": [");
	for (int i = 0; i < nspheres; i++) {
		at += (size_t)snprintf(
		    buf + at, n - at,
		    "%s{\"type\": \"sphere\", \"id\": %d, "
		    "\"radius\": 0.3, \"translate\": [%g, 0, "
		    "0]}",
		    i ? ", " : "", 2 + i, (double)(i - nspheres / 2));
	}
	snprintf(buf + at, n - at, "]}}");
}

/* A member of a new session name holding a row of spheres (id 2 the
 * first): what the edits below move. */
static void row_member(struct conn *c, const struct daemon *d, const char *name,
                       uint16_t w, uint16_t h)
{
	char json[2048];
	member(c, d, name, true, w, h, BC_PROTO_ENC_RAW);
	row_json(json, sizeof(json), 5);
	conn_load_json(c, json);
}

/* Waits for a FRAME whose order reaches order; its arrival time, or -1. */
static int64_t frame_reaching(struct conn *c, uint64_t order, int timeout_ms)
{
	int64_t end = t_now_ms() + timeout_ms;
	while (t_now_ms() < end) {
		if (conn_expect(c, BC_MSG_FRAME, (int)(end - t_now_ms())) !=
		    1) {
			return -1;
		}
		if (c->m.frame.order >= order) {
			return t_now_ms();
		}
	}
	return -1;
}

/* How long an edit's answer and its frame may take before edit_frames
 * gives up: far above any fair share, since a wait that ends early fails
 * a test whatever the times say (a loaded 2-core machine drawing three
 * llvmpipe sessions once took over 30 s for one edit's frame). */
#define EDIT_WAIT_MS 120000

/* Moves node 2 of c's session n times, each time waiting for the frame
 * that shows it: the edit -> frame times into ms. Returns how many came. */

static int edit_frames(struct conn *c, int n, int64_t *ms)
{
	int got = 0;
	for (int i = 0; i < n; i++) {
		int64_t t0 = t_now_ms(), t1;
		uint32_t seq = conn_move(c, 2, (i % 2) ? 0.05f : -0.05f, 0.5f,
		                         0.0f, false);
		uint64_t order = 0;
		while (seq && conn_recv(c, EDIT_WAIT_MS) == 1) {
			if (c->m.type == BC_MSG_EDIT_APPLIED &&
			    c->m.edit_applied.author_seq == seq) {
				order = c->m.edit_applied.order;
				break;
			}
		}
		if (!order ||
		    (t1 = frame_reaching(c, order, EDIT_WAIT_MS)) < 0) {
			break;
		}
		ms[got++] = t1 - t0;
	}
	return got;
}

/* Drains what c has received without waiting. */
static void drain(struct conn *c)
{
	while (conn_recv(c, 0) == 1) {
	}
}

static void a_quiet_session_keeps_its_share_beside_a_heavy_one(void)
{
	static const char *const opts[] = {"--render-threads", "2", NULL};
	enum { N = 16 };
	struct daemon d;
	struct conn quiet, heavy, snap;
	struct bc_msg cam = {.type = BC_MSG_CAMERA};
	int64_t alone[N], loaded[N], end;
	int n_alone, n_loaded, sent = 0;
	int64_t p_alone, p_loaded;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/share", base_dir);
	REQUIRE(daemon_start_with(&d, dir, opts) == 0);
	row_member(&quiet, &d, "quiet", 160, 120);
	REQUIRE(conn_expect(&quiet, BC_MSG_FRAME, 30000) == 1);
	n_alone = edit_frames(&quiet, N, alone);
	REQUIRE(n_alone == N);
	p_alone = percentile(alone, n_alone, 50);
	/* The heavy session: thousands of smooth spheres at a large view,
	 * its camera never still, snapshots queued behind it. */
	member(&heavy, &d, "heavy", true, 1024, 1024, BC_PROTO_ENC_JPEG);
	load_gen(&heavy, "fig18", 4096, BC_GEN_BLEND_SMOOTH);
	member(&snap, &d, "heavy", false, 1024, 1024, BC_PROTO_ENC_PNG);
	for (int i = 0; i < (int)BC_SRV_MAX_CLIENT_REQUESTS; i++) {
		struct bc_msg s = {.type = BC_MSG_SNAPSHOT};
		s.snapshot.encoding = BC_PROTO_ENC_PNG;
		REQUIRE(conn_send(&snap, &s));
	}
	cam.flags = BC_PROTO_FLAG_INTERACTING;
	cam.camera.fov_y_deg = 45.0f;
	cam.camera.up[1] = 1.0f;
	end = t_now_ms() + 300;
	while (t_now_ms() < end) {
		/* The orbit goes on while the quiet session edits: a thread
		 * of its own would be simplest, but interleaving keeps the
		 * test single-threaded; each quiet edit waits its frame. */
		float a = (float)sent++ * 0.2f;
		cam.camera.eye[0] = 30.0f * sinf(a);
		cam.camera.eye[2] = 30.0f * cosf(a);
		REQUIRE(conn_send(&heavy, &cam));
		drain(&heavy);
		t_sleep_ms(20);
	}
	n_loaded = 0;
	for (int i = 0; i < N; i++) {
		float a = (float)sent++ * 0.2f;
		cam.camera.eye[0] = 30.0f * sinf(a);
		cam.camera.eye[2] = 30.0f * cosf(a);
		REQUIRE(conn_send(&heavy, &cam));
		drain(&heavy);
		drain(&snap);
		n_loaded += edit_frames(&quiet, 1, &loaded[n_loaded]);
	}
	REQUIRE(n_loaded == N);
	p_loaded = percentile(loaded, n_loaded, 50);
	printf("  quiet session edit -> frame p50: alone %lld ms, beside the "
	       "heavy one %lld ms (p90 %lld)\n",
	       (long long)p_alone, (long long)p_loaded,
	       (long long)percentile(loaded, n_loaded, 90));
	/* Its fair share: its own render, a slice of another session's, a
	 * turn of the loop. One render thread in arrival order made it wait
	 * for whole frames and snapshots of the heavy session (50-170x). */
	CHECK(p_loaded <= 4 * p_alone + 150);
	conn_close(&quiet);
	conn_close(&heavy);
	conn_close(&snap);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void a_crawling_scene_is_slow_for_itself_only(void)
{
	static const char *const opts[] = {"--render-threads", "2",
	                                   "--frame-budget", "500", NULL};
	static const char twist[] =
	    "{\"blobcast\": 1, \"root\": {\"type\": \"twist\", \"id\": 1, "
	    "\"rate\": 1000000, \"children\": [{\"type\": \"box\", \"id\": 2, "
	    "\"half_extents\": [1, 1, 1]}]}}";
	struct daemon d;
	struct conn crawl, quiet;
	int64_t t0, took, ms[4];
	int status;
	bool incomplete = false;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/crawl", base_dir);
	REQUIRE(daemon_start_with(&d, dir, opts) == 0);
	member(&crawl, &d, "crawl", true, 320, 240, BC_PROTO_ENC_RAW);
	REQUIRE(conn_expect(&crawl, BC_MSG_FRAME, 30000) == 1);
	t0 = t_now_ms();
	conn_load_json(&crawl, twist);
	/* A whole picture at once (one render thread was held for over an
	 * hour by such a scene), saying it is not finished. */
	while (t_now_ms() - t0 < 60000 && !incomplete &&
	       conn_expect(&crawl, BC_MSG_FRAME, 60000) == 1) {
		incomplete = (crawl.m.flags & BC_PROTO_FLAG_INCOMPLETE) != 0;
	}
	took = t_now_ms() - t0;
	printf("  twist rate 1e6: an INCOMPLETE picture after %lld ms\n",
	       (long long)took);
	CHECK(incomplete);
	/* A snapshot goes to level 0 but retries its rays only within the
	 * frame budget, then says INCOMPLETE (it retried every tile up to the
	 * largest bound: minutes at this size). */
	{
		struct bc_msg snap = {.type = BC_MSG_SNAPSHOT};
		uint32_t seq;
		snap.snapshot.encoding = BC_PROTO_ENC_RAW;
		t0 = t_now_ms();
		REQUIRE((seq = conn_send(&crawl, &snap)));
		do {
			REQUIRE(conn_expect(&crawl, BC_MSG_FRAME, 60000) == 1);
		} while (crawl.m.seq != seq);
		took = t_now_ms() - t0;
		printf("  its snapshot: INCOMPLETE after %lld ms\n",
		       (long long)took);
		CHECK(crawl.m.flags & BC_PROTO_FLAG_SNAPSHOT);
		CHECK(crawl.m.flags & BC_PROTO_FLAG_INCOMPLETE);
		CHECK(took < 30000);
	}
	/* Another session is served meanwhile. */
	row_member(&quiet, &d, "quiet", 160, 120);
	REQUIRE(conn_expect(&quiet, BC_MSG_FRAME, 30000) == 1);
	CHECK(edit_frames(&quiet, 4, ms) == 4);
	/* And SIGTERM stops it at once, whatever the workers do. */
	t0 = t_now_ms();
	status = daemon_stop(&d, SIGTERM);
	took = t_now_ms() - t0;
	printf("  SIGTERM while rendering it: stopped in %lld ms\n",
	       (long long)took);
	CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
	CHECK(took < 4000);
	conn_close(&crawl);
	conn_close(&quiet);
}

static void a_stream_of_edits_shows_its_newest_value(void)
{
	enum { EDITS = 300 };
	struct daemon d;
	struct conn ed, view;
	uint32_t frames = 0, last_seq = 0;
	uint64_t last_order = 0, shown = 0;
	int64_t end;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/stream", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	row_member(&ed, &d, "s", 64, 64);
	member(&view, &d, "s", false, 320, 240, BC_PROTO_ENC_RAW);
	REQUIRE(conn_expect(&view, BC_MSG_FRAME, 30000) == 1);
	for (int i = 0; i < EDITS; i++) {
		REQUIRE((last_seq = conn_move(&ed, 3, (float)i * 0.001f, 0.0f,
		                              0.0f, true)));
	}
	/* Every edit is acknowledged; the viewer's frames catch up with the
	 * last one. */
	end = t_now_ms() + 120000;
	while (!last_order && t_now_ms() < end && conn_recv(&ed, 10000) == 1) {
		if (ed.m.type == BC_MSG_EDIT_APPLIED &&
		    ed.m.edit_applied.author_seq == last_seq) {
			last_order = ed.m.edit_applied.order;
		}
	}
	REQUIRE(last_order > 0);
	while (shown < last_order && t_now_ms() < end &&
	       conn_expect(&view, BC_MSG_FRAME, 10000) == 1) {
		frames++;
		shown = view.m.frame.order;
	}
	printf("  %d edits: the viewer's frames reached order %llu in %u "
	       "frames\n",
	       EDITS, (unsigned long long)shown, frames);
	CHECK(shown >= last_order);
	CHECK(frames < EDITS / 2);
	conn_close(&ed);
	conn_close(&view);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void answers_keep_the_order_of_requests(void)
{
	struct daemon d;
	struct conn c;
	struct bc_msg ping = {.type = BC_MSG_PING};
	uint32_t edit_seq, ping_seq;
	bool applied = false, ponged = false, in_order = true;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/order", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	row_member(&c, &d, "o", 64, 64);
	for (int round = 0; round < 20; round++) {
		applied = ponged = false;
		REQUIRE((edit_seq = conn_move(&c, 2, 0.01f * (float)round, 0.5f,
		                              0.0f, false)));
		ping.ping.stamp = (uint64_t)round;
		REQUIRE((ping_seq = conn_send(&c, &ping)));
		while (!ponged && conn_recv(&c, 10000) == 1) {
			if (c.m.type == BC_MSG_EDIT_APPLIED &&
			    c.m.edit_applied.author_seq == edit_seq) {
				applied = true;
			}
			if (c.m.type == BC_MSG_PONG && c.m.seq == ping_seq) {
				ponged = true;
				in_order = in_order && applied;
			}
		}
		CHECK(ponged);
	}
	CHECK(in_order);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* A client that sends a burst of 100 000 SESSION_LISTs at once and then a
 * PING gets its PONG after all of them, and another client's PING is
 * answered after a share of a loop turn, not after the burst: its round
 * trip stays under a third of the burst's time (a ratio, so load on the
 * machine moves both; measured 1/20 with the share, and 2/3 when the
 * daemon handled all it read of the burst at once). One round trip is one
 * sample, which a stall of this process on a loaded machine can stretch
 * (40 ms against a 182 ms burst, seen once; a sixth failed three tries in
 * a row once, the suite running three tests on two cores): up to five
 * fresh daemons try, and one must show it; a daemon without the share
 * fails all five. *fair: whether this try showed it. */
static void burst_once(int attempt, bool *fair)
{
	enum { BURST = 100000 };
	struct daemon d;
	struct conn a, b;
	struct bc_proto_buf buf;
	struct bc_msg ping = {.type = BC_MSG_PING},
	              list = {.type = BC_MSG_SESSION_LIST};
	size_t sent = 0;
	uint32_t last = 0, b_seq = 0, answers = 0;
	int64_t t0, b_sent = 0, b_rtt = -1, burst_ms = -1;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/burst%d", base_dir, attempt);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(conn_open(&a, &d) == 0 && conn_hello(&a, "burst") == 0);
	REQUIRE(conn_open(&b, &d) == 0 && conn_hello(&b, "calm") == 0);
	bc_proto_buf_init(&buf, 0);
	for (uint32_t i = 0; i < BURST; i++) {
		list.seq = ++a.seq;
		REQUIRE(bc_proto_encode(&buf, &list, NULL) == 0);
	}
	ping.seq = last = ++a.seq;
	REQUIRE(bc_proto_encode(&buf, &ping, NULL) == 0);
	REQUIRE(fcntl(a.fd, F_SETFL, fcntl(a.fd, F_GETFL) | O_NONBLOCK) == 0);
	t0 = t_now_ms();
	while (burst_ms < 0 && t_now_ms() - t0 < 120000) {
		struct pollfd p[2] = {{.fd = a.fd, .events = POLLIN},
		                      {.fd = b.fd, .events = POLLIN}};
		if (sent < buf.len) {
			ssize_t k = send(a.fd, buf.data + sent, buf.len - sent,
			                 MSG_NOSIGNAL);
			sent += k > 0 ? (size_t)k : 0;
		}
		/* The calm client asks once the burst is under way. */
		if (!b_seq && sent >= buf.len / 4u) {
			REQUIRE((b_seq = conn_send(&b, &ping)));
			b_sent = t_now_ms();
		}
		p[0].events |= sent < buf.len ? POLLOUT : 0;
		poll(p, 2, 1);
		while (b_seq && b_rtt < 0 && conn_recv(&b, 0) == 1) {
			if (b.m.type == BC_MSG_PONG && b.m.seq == b_seq) {
				b_rtt = t_now_ms() - b_sent;
			}
		}
		/* A few of the burst's answers at a time: the calm client's
		 * PONG is looked for often. */
		for (int k = 0; k < 64 && burst_ms < 0 && conn_recv(&a, 0) == 1;
		     k++) {
			CHECK(a.m.type != BC_MSG_ERROR);
			answers += a.m.type == BC_MSG_SESSIONS;
			if (a.m.type == BC_MSG_PONG && a.m.seq == last) {
				burst_ms = t_now_ms() - t0;
			}
		}
	}
	printf("  %d SESSION_LISTs and a PING in %lld ms; the other "
	       "client's PING %lld ms\n",
	       BURST, (long long)burst_ms, (long long)b_rtt);
	CHECK(burst_ms > 0);
	CHECK_EQ_INT(answers, BURST); /* every one, before the PONG */
	CHECK(b_rtt >= 0);
	*fair = b_rtt >= 0 && b_rtt * 3 < burst_ms;
	bc_proto_buf_finish(&buf);
	conn_close(&a);
	conn_close(&b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void a_burst_of_requests_leaves_others_their_turn(void)
{
	bool fair = false;
	for (int i = 0; i < 5 && !fair; i++) {
		burst_once(i, &fair);
	}
	CHECK(fair);
}

/* The tree of the SCENE_STATE in c->m, or NULL. */
static struct bc_tree *state_tree(const struct conn *c)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	bool has_cam;
	if (!t || c->m.type != BC_MSG_SCENE_STATE ||
	    bc_scene_decode(c->m.scene_state.scene.ptr,
	                    c->m.scene_state.scene.len, t, &cam, &has_cam,
	                    NULL) != 0) {
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

/* The scene a new member of name gets, or NULL. */
static struct bc_tree *joined_tree(const struct daemon *d, const char *name)
{
	struct conn j;
	struct bc_tree *t = NULL;
	if (conn_open(&j, d) == 0 && conn_hello(&j, "joiner") == 0 &&
	    conn_join(&j, name, BC_PROTO_ROLE_VIEWER, false) == 0 &&
	    conn_expect(&j, BC_MSG_SCENE_STATE, 60000) == 1) {
		t = state_tree(&j);
	}
	conn_close(&j);
	return t;
}

/* A long batch of SETs on a big scene applies off the loop, the session
 * busy meanwhile: a PING sent after it comes back after its EDIT_APPLIED,
 * the batch is applied whole, and one UNDO takes it back whole. */
static void a_long_batch_of_sets_on_a_big_scene_applies_whole(void)
{
	enum { NOPS = 300 };
	struct daemon d;
	struct conn c;
	struct bc_tree *t;
	const struct bc_lin *lin;
	struct bc_proto_field fields[NOPS];
	struct bc_proto_edit_op ops[NOPS];
	uint32_t ids[NOPS], seq, ping_seq, undo_seq;
	struct bc_msg m = {.type = BC_MSG_EDIT}, ping = {.type = BC_MSG_PING},
	              undo = {.type = BC_MSG_UNDO};
	struct bc_prim_data p, before;
	struct bc_op_data op;
	bool applied = false;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/sets", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	member(&c, &d, "big", true, 64, 64, BC_PROTO_ENC_RAW);
	load_gen(&c, "fig18", BC_SRV_HEAVY_NODES, BC_GEN_BLEND_SMOOTH);
	REQUIRE((t = state_tree(&c)));
	lin = bc_tree_lin(t);
	REQUIRE(bc_tree_node_count(t) >= BC_SRV_HEAVY_NODES);
	REQUIRE(lin->nprims >= NOPS && NOPS >= BC_SRV_HEAVY_SETS);
	for (uint32_t i = 0; i < NOPS; i++) {
		ids[i] = lin->node_id[lin->prim_slot[i]];
		fields[i] = (struct bc_proto_field){
		    .field = BC_PROTO_FIELD_TRANSLATE,
		    .count = 3,
		    .v = {0.001f * (float)i, 7.0f, -3.0f}};
		ops[i] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_SET,
		                                   .node = ids[i],
		                                   .nfields = 1,
		                                   .fields = &fields[i]};
	}
	REQUIRE(bc_tree_get(t, ids[NOPS - 1], &before, &op));
	bc_tree_destroy(t);
	m.edit.nops = NOPS;
	m.edit.ops = ops;
	REQUIRE((seq = conn_send(&c, &m)));
	REQUIRE((ping_seq = conn_send(&c, &ping)));
	while (conn_recv(&c, 60000) == 1 &&
	       !(c.m.type == BC_MSG_PONG && c.m.seq == ping_seq)) {
		CHECK(c.m.type != BC_MSG_ERROR);
		applied = applied || (c.m.type == BC_MSG_EDIT_APPLIED &&
		                      c.m.edit_applied.author_seq == seq &&
		                      c.m.edit_applied.nops == NOPS);
	}
	CHECK(applied); /* before the PONG */
	REQUIRE((t = joined_tree(&d, "big")));
	for (uint32_t i = 0; i < NOPS; i++) {
		REQUIRE(bc_tree_get(t, ids[i], &p, &op));
		CHECK(p.translate[1] == 7.0f && p.translate[2] == -3.0f);
	}
	bc_tree_destroy(t);
	REQUIRE((undo_seq = conn_send(&c, &undo)));
	REQUIRE(conn_expect(&c, BC_MSG_EDIT_APPLIED, 60000) == 1);
	REQUIRE((t = joined_tree(&d, "big")));
	REQUIRE(bc_tree_get(t, ids[NOPS - 1], &p, &op));
	CHECK(memcmp(p.translate, before.translate, sizeof(p.translate)) == 0);
	bc_tree_destroy(t);
	(void)undo_seq;
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* GET_STATS with parts; STATS into c->m. */
static void get_stats(struct conn *c, uint8_t parts)
{
	struct bc_msg m = {.type = BC_MSG_GET_STATS};
	uint32_t seq;
	m.get_stats.parts = parts;
	REQUIRE((seq = conn_send(c, &m)));
	do {
		REQUIRE(conn_expect(c, BC_MSG_STATS, 10000) == 1);
	} while (c->m.seq != seq);
}

static void stats_tell_the_load(void)
{
	static const char *const opts[] = {"--render-threads", "3", NULL};
	struct daemon d;
	struct conn c;
	int64_t ms[3];
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/stats", base_dir);
	REQUIRE(daemon_start_with(&d, dir, opts) == 0);
	row_member(&c, &d, "st", 256, 192);
	REQUIRE(conn_expect(&c, BC_MSG_FRAME, 30000) == 1);
	CHECK(edit_frames(&c, 3, ms) == 3);
	/* Without parts: the first version's STATS, no load section. */
	get_stats(&c, 0);
	CHECK(!c.m.stats.has_load);
	CHECK(c.m.stats.frames >= 4);
	get_stats(&c, BC_PROTO_STATS_LOAD);
	CHECK(c.m.stats.has_load);
	CHECK_EQ_INT(c.m.stats.load.render_workers, 3);
	CHECK(c.m.stats.load.view_cap == BC_SRV_VIEW_BYTES);
	/* The view (its 256x192 colour plane, 4 bytes a pixel) is kept,
	 * and the renderer's state for it. */
	CHECK(c.m.stats.load.view_bytes > 256u * 192u * 4u);
	CHECK(c.m.stats.load.view_bytes <= c.m.stats.load.view_cap);
	CHECK(c.m.stats.load.session_render_us > 0);
	CHECK(c.m.stats.load.loop_turn_max_ms >= 0.0f &&
	      c.m.stats.load.loop_turn_max_ms < 60000.0f);
	CHECK(c.m.stats.load.loop_request_max_ms <=
	      c.m.stats.load.loop_turn_max_ms + 1.0f);
	/* RESET answers the maxima so far, then starts them anew: the
	 * next answer's are those of the few turns between. */
	get_stats(&c, BC_PROTO_STATS_LOAD | BC_PROTO_STATS_RESET);
	get_stats(&c, BC_PROTO_STATS_LOAD);
	CHECK(c.m.stats.load.loop_request_max_ms < 1000.0f);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void the_view_cache_stays_under_its_cap(void)
{
	static const char *const opts[] = {"--view-cache", "32", NULL};
	struct daemon d;
	struct conn c;
	struct bc_msg cam = {.type = BC_MSG_CAMERA};
	uint64_t worst = 0, cap = 0;
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/cache", base_dir);
	REQUIRE(daemon_start_with(&d, dir, opts) == 0);
	/* Each view is 9 MiB of planes and about as much renderer state:
	 * a few fit under 32 MiB, the others push the oldest out. */
	member(&c, &d, "v", true, 1024, 768, BC_PROTO_ENC_JPEG);
	REQUIRE(conn_expect(&c, BC_MSG_FRAME, 60000) == 1);
	cam.camera.fov_y_deg = 45.0f;
	cam.camera.up[1] = 1.0f;
	for (int i = 0; i < 8; i++) {
		cam.camera.eye[0] = 6.0f * sinf((float)i);
		cam.camera.eye[2] = 6.0f * cosf((float)i);
		REQUIRE(conn_send(&c, &cam));
		REQUIRE(conn_expect(&c, BC_MSG_FRAME, 60000) == 1);
		get_stats(&c, BC_PROTO_STATS_LOAD);
		cap = c.m.stats.load.view_cap;
		worst = c.m.stats.load.view_bytes > worst
		            ? c.m.stats.load.view_bytes
		            : worst;
	}
	printf("  8 views of 1024x768: the cache held at most %llu of %llu "
	       "bytes\n",
	       (unsigned long long)worst, (unsigned long long)cap);
	CHECK(cap == 32u << 20);
	CHECK(worst > 0 && worst <= cap);
	conn_close(&c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* The gl backend is one more kind of worker, scheduled alike: through EGL
 * (Mesa llvmpipe where there is no GPU) two sessions are served side by
 * side, each edit shows in its own frame, and a crawling scene's picture
 * comes INCOMPLETE without holding them. */
static void gl_workers_are_scheduled_alike(void)
{
	static const char *const opts[] = {
	    "--backend", "gl", "--render-threads", "2", "--frame-budget",
	    "500",       NULL};
	static const char twist[] =
	    "{\"blobcast\": 1, \"root\": {\"type\": \"twist\", \"id\": 1, "
	    "\"rate\": 1000000, \"children\": [{\"type\": \"box\", \"id\": 2, "
	    "\"half_extents\": [1, 1, 1]}]}}";
	struct daemon d;
	struct conn a, b, crawl;
	int64_t ms[3];
	bool incomplete = false;
	/* Static: a test that stops at a REQUIRE leaves daemon_log_path
	 * pointing here for the next one. */
	static char log[128];
	char dir[96];
	snprintf(dir, sizeof(dir), "%s/gl", base_dir);
	snprintf(log, sizeof(log), "%s/gl.log", base_dir);
	/* The daemon fills what it frees: two workers drawing with
	 * llvmpipe contexts at once read memory Mesa had freed (and
	 * crashed), which render/gl/context.c now prevents by giving
	 * software contexts turns. */
	daemon_fill_freed = true;
	daemon_log_path = log;
	REQUIRE(daemon_start_with(&d, dir, opts) == 0);
	daemon_log_path = NULL;
	daemon_fill_freed = false;
	row_member(&a, &d, "gl-a", 64, 48);
	row_member(&b, &d, "gl-b", 64, 48);
	member(&crawl, &d, "gl-crawl", true, 64, 48, BC_PROTO_ENC_RAW);
	conn_load_json(&crawl, twist);
	REQUIRE(conn_expect(&a, BC_MSG_FRAME, 60000) == 1);
	REQUIRE(conn_expect(&b, BC_MSG_FRAME, 60000) == 1);
	CHECK_EQ_INT(edit_frames(&a, 3, ms), 3);
	CHECK_EQ_INT(edit_frames(&b, 3, ms), 3);
	while (!incomplete && conn_expect(&crawl, BC_MSG_FRAME, 60000) == 1) {
		incomplete = (crawl.m.flags & BC_PROTO_FLAG_INCOMPLETE) != 0;
	}
	CHECK(incomplete);
	conn_close(&a);
	conn_close(&b);
	conn_close(&crawl);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	/* The pictures came from the gl backend, not a fallback. */
	CHECK(bc_test_file_has(log, "backend gl"));
	CHECK(bc_test_file_has(log, "gl: "));
}

/* Counts the lines of file that hold needle. */
static int lines_with(const char *file, const char *needle)
{
	char line[1024];
	int n = 0;
	FILE *f = fopen(file, "r");
	if (!f) {
		return -1;
	}
	while (fgets(line, sizeof(line), f)) {
		n += strstr(line, needle) != NULL;
	}
	fclose(f);
	return n;
}

/* Every gl region call pays the A-buffer of every primitive, the scan of
 * every tile and the planes' readback: the scheduler hands it a pass at a
 * time. Sized by its tracing, as a tiled slice is, a slice of a big scene
 * came down to one tile, and a frame to one call per tile (a 1024x768
 * view of 65 536 spheres: 50 minutes on llvmpipe, and no still at all
 * from a million spheres on a GPU). Here: 2048 spheres, 96x72 (108 tiles):
 * the first still comes in a few calls, not hundreds. */
static void a_gl_frame_is_drawn_in_few_calls(void)
{
	static const char *const opts[] = {
	    "--backend", "gl", "--render-threads", "1", "--log", "debug", NULL};
	struct daemon d;
	struct conn a;
	bool still = false;
	/* Static: a test that stops at a REQUIRE leaves daemon_log_path
	 * pointing here for the next one. */
	static char log[128];
	char dir[96];
	int calls;
	snprintf(dir, sizeof(dir), "%s/glcalls", base_dir);
	snprintf(log, sizeof(log), "%s/glcalls.log", base_dir);
	daemon_log_path = log;
	REQUIRE(daemon_start_with(&d, dir, opts) == 0);
	daemon_log_path = NULL;
	member(&a, &d, "glcalls", true, 96, 72, BC_PROTO_ENC_RAW);
	load_gen(&a, "fig18", 2048, BC_GEN_BLEND_SMOOTH);
	while (!still && conn_expect(&a, BC_MSG_FRAME, 120000) == 1) {
		still = (a.m.flags & BC_PROTO_FLAG_STILL) != 0;
	}
	CHECK(still);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	/* One debug line per region call (job.c's render_slice); the
	 * default scene's first frames count too. A pass per level (4),
	 * refinements and retries: a dozen at most, where per-tile slices
	 * made hundreds. */
	calls = lines_with(log, " tiles, ");
	CHECK(calls > 0);
	CHECK(calls <= 24);
	if (calls > 24) {
		fprintf(stderr, "  %d region calls\n", calls);
	}
}

/* The configuration file takes every setting the command line does, by
 * the option's name with '_' for '-' and in its range (docs/operations.md,
 * "Configuration file"), and the command line wins: render_threads and
 * view_cache from the file show in STATS's load section; --view-cache on
 * the command line replaces the file's. */
static void the_configuration_file_gives_the_options(void)
{
	const char *opts[] = {"--config", NULL, NULL, NULL, NULL};
	char dir[96], cfg[128];
	struct daemon d;
	struct conn c;
	FILE *f;
	snprintf(dir, sizeof(dir), "%s/config", base_dir);
	snprintf(cfg, sizeof(cfg), "%s/config.json", base_dir);
	REQUIRE((f = fopen(cfg, "w")) != NULL);
	fprintf(f, "{\"render_threads\": 3, \"view_cache\": 64, "
	           "\"no_pace\": true, \"simd\": \"off\"}\n");
	fclose(f);
	opts[1] = cfg;
	for (int cli = 0; cli < 2; cli++) {
		opts[2] = cli ? "--view-cache" : NULL;
		opts[3] = cli ? "32" : NULL;
		REQUIRE(daemon_start_with(&d, dir, opts) == 0);
		REQUIRE(conn_open(&c, &d) == 0 && conn_hello(&c, "cfg") == 0);
		get_stats(&c, BC_PROTO_STATS_LOAD);
		CHECK(c.m.stats.has_load);
		CHECK_EQ_INT(c.m.stats.load.render_workers, 3);
		CHECK(c.m.stats.load.view_cap == (cli ? 32u : 64u) << 20);
		conn_close(&c);
		CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	}
}

static const struct bc_test tests[] = {
    {"a_quiet_session_keeps_its_share_beside_a_heavy_one",
     a_quiet_session_keeps_its_share_beside_a_heavy_one},
    {"a_crawling_scene_is_slow_for_itself_only",
     a_crawling_scene_is_slow_for_itself_only},
    {"a_stream_of_edits_shows_its_newest_value",
     a_stream_of_edits_shows_its_newest_value},
    {"answers_keep_the_order_of_requests", answers_keep_the_order_of_requests},
    {"a_burst_of_requests_leaves_others_their_turn",
     a_burst_of_requests_leaves_others_their_turn},
    {"a_long_batch_of_sets_on_a_big_scene_applies_whole",
     a_long_batch_of_sets_on_a_big_scene_applies_whole},
    {"stats_tell_the_load", stats_tell_the_load},
    {"the_configuration_file_gives_the_options",
     the_configuration_file_gives_the_options},
    {"the_view_cache_stays_under_its_cap", the_view_cache_stays_under_its_cap},
    {"gl_workers_are_scheduled_alike", gl_workers_are_scheduled_alike},
    {"a_gl_frame_is_drawn_in_few_calls", a_gl_frame_is_drawn_in_few_calls},
};

int main(int argc, char **argv)
{
	(void)unused;
	return daemon_tests_run("sched", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
