/*
 * Members dropped while an EDIT_APPLIED is being broadcast. A member whose
 * output queue passes BC_SRV_MAX_CLIENT_QUEUE is dropped inside the send
 * that overflows it, and leaving a session moves the last member into the
 * leaver's slot: a broadcast that walked the live member list skipped the
 * member moved there, so an author could miss the acknowledgement of an
 * applied, saved edit and every mirror built from EDIT_APPLIED diverged.
 *
 * Each round opens a session and fills it in a layout of member slots:
 * stalled members (they read up to their first frame, ask one raw
 * snapshot with depth and ids and never read again, so the snapshot fills
 * their queue to a little below the limit and a few EDIT_APPLIED later
 * they overflow; all at once, or in two waves), editors sending large
 * parameter batches, readers, and closers that go away at the moment of
 * the drops (a close, a close in the middle of a message, a
 * SESSION_LEAVE). The layouts put live members behind stalled ones,
 * between them and before them. Every editor must receive the acknowledgement
 * of every edit it sent, in order, every live member must see every order
 * number, and a joiner's SCENE_STATE must equal the mirror each live member
 * built from its EDIT_APPLIED messages, byte for byte.
 *
 * BLOBCASTD in the environment names another daemon to test (a bisect).
 */
#include <sys/ioctl.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"
#include "srv_limits.h"

/* Primitives of the scene, and so SET operations per edit (the protocol's
 * BC_PROTO_MAX_EDIT_OPS): an EDIT_APPLIED of about 58 KiB. */
#define NPRIMS 1024u
/* Rows taken off the stalled members' view per stagger wave: 8 rows of
 * 12-byte pixels are 152 KiB, more than two EDIT_APPLIED, so each wave
 * overflows on a later broadcast. */
#define WAVE_ROWS 8u
/* Edits an editor has sent and not yet seen acknowledged. */
#define WINDOW 3u
/* Edits per round at most (the drops come after about 35). */
#define MAX_EDITS 400u
#define MAX_SLOTS 24

static char base_dir[48];
/* The stalled members' big message: a raw SNAPSHOT with its depth and id
 * planes, 12 bytes a pixel, of a big x big view fills a queue to 2 MiB
 * below BC_SRV_MAX_CLIENT_QUEUE (1619^2: 30.0 MiB of 32), room for about
 * 35 EDIT_APPLIED of applied_bytes; the first_drop-th overflows it. */
static uint16_t big;
static uint32_t applied_bytes, first_drop;

/* daemon.h's helpers this file does not need. */
static void unused(void)
{
	(void)conn_move;
	(void)conn_view;
}

struct member {
	struct conn c;
	char kind;   /* S stalled, E editor, R reader, C closer */
	uint32_t id; /* member id */
	struct bc_tree *mirror;
	uint64_t order;           /* last order number replayed */
	uint32_t seqs[MAX_EDITS]; /* seq of each EDIT sent */
	uint32_t sent, acked, errors, gaps;
	bool gone;  /* closed by the test (closers) */
	bool still; /* a stalled member's first frame came */
};

/* The round's scene: its primitives' ids and data (editors move them a
 * little and recolour them). */
static uint32_t prim_id[NPRIMS];
static struct bc_prim_data prim[NPRIMS];
static struct bc_camera scene_cam;

static uint32_t rnd(uint64_t *s)
{
	*s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
	return (uint32_t)(*s >> 33);
}

/* The fig18 grid of NPRIMS smooth spheres, encoded for SCENE_LOAD. */
static int make_scene(uint8_t **bytes, size_t *len)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_gen_opts o = {.count = NPRIMS,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SMOOTH};
	const struct bc_lin *l;
	int rc = -1;
	if (!t || bc_gen("fig18", &o, t, &scene_cam, NULL)) {
		goto out;
	}
	l = bc_tree_lin(t);
	if (l->nprims != NPRIMS) {
		goto out;
	}
	for (uint32_t i = 0; i < NPRIMS; i++) {
		prim_id[i] = l->node_id[l->prim_slot[i]];
		bc_tree_get(t, prim_id[i], &prim[i], NULL);
	}
	rc = bc_scene_encode(t, &scene_cam, bytes, len) ? -1 : 0;
out:
	bc_tree_destroy(t);
	return rc;
}

/* Edit k of editor e: a SET of every primitive (translate, rotate, colour
 * and radius), valid, different from the edits before it. The operations
 * live until the next call. */
static const struct bc_proto_edit_op *edit_ops(uint32_t e, uint32_t k)
{
	static struct bc_proto_edit_op ops[NPRIMS];
	static struct bc_proto_field f[NPRIMS][4];
	float dx = 0.002f * (float)((k * 7u + e) % 11u);
	for (uint32_t i = 0; i < NPRIMS; i++) {
		const struct bc_prim_data *p = &prim[i];
		f[i][0] = (struct bc_proto_field){BC_PROTO_FIELD_TRANSLATE,
		                                  3,
		                                  {p->translate[0] + dx,
		                                   p->translate[1],
		                                   p->translate[2], 0}};
		f[i][1] = (struct bc_proto_field){
		    BC_PROTO_FIELD_ROTATE, 4, {0, 0, 0, 1}};
		f[i][2] =
		    (struct bc_proto_field){BC_PROTO_FIELD_COLOR,
		                            3,
		                            {(float)((k + i) % 97u) / 96.0f,
		                             (float)(e % 9u) / 8.0f, 0.5f, 0}};
		f[i][3] = (struct bc_proto_field){
		    BC_PROTO_FIELD_PARAM0, 1, {p->params[0], 0, 0, 0}};
		ops[i] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_SET,
		                                   .node = prim_id[i],
		                                   .nfields = 4,
		                                   .fields = f[i]};
	}
	return ops;
}

static uint32_t send_edit(struct member *m, uint32_t e, uint32_t k)
{
	struct bc_msg msg = {.type = BC_MSG_EDIT};
	msg.edit.nops = NPRIMS;
	msg.edit.ops = edit_ops(e, k);
	return conn_send(&m->c, &msg);
}

/* The sizes the rounds rely on, from the daemon's queue limit and the
 * edits' encoding. */
static int measure(void)
{
	struct bc_msg ea = {.type = BC_MSG_EDIT_APPLIED};
	struct bc_proto_buf b;
	double room = (double)BC_SRV_MAX_CLIENT_QUEUE - (double)(2u << 20);
	uint64_t snap;
	int rc;
	big = (uint16_t)sqrt(room / 12.0);
	ea.edit_applied.order = 1;
	ea.edit_applied.author = 1;
	ea.edit_applied.author_seq = 1;
	ea.edit_applied.nops = NPRIMS;
	ea.edit_applied.ops = edit_ops(0, 0);
	bc_proto_buf_init(&b, 0);
	rc = bc_proto_encode(&b, &ea, NULL);
	applied_bytes = (uint32_t)b.len;
	bc_proto_buf_finish(&b);
	/* The snapshot's FRAME: its planes and about 100 bytes of fields. */
	snap = 12u * (uint64_t)big * big + 100u;
	if (rc || applied_bytes == 0 || big > BC_SRV_MAX_DIM ||
	    snap >= BC_SRV_MAX_CLIENT_QUEUE) {
		return -1;
	}
	first_drop =
	    (uint32_t)((BC_SRV_MAX_CLIENT_QUEUE - snap) / applied_bytes) + 1u;
	return first_drop + 60u < MAX_EDITS ? 0 : -1;
}

/* Handles one message a live member received: replays EDIT_APPLIED into
 * its mirror (order numbers must follow each other), checks and counts the
 * acknowledgements of its own edits. */
static void take(struct member *m)
{
	const struct bc_msg *msg = &m->c.m;
	if (msg->type == BC_MSG_EDIT_APPLIED) {
		const struct bc_msg_edit_applied *ea = &msg->edit_applied;
		struct bc_errinfo ei = {0};
		if (ea->order != m->order + 1) {
			if (m->gaps++ == 0) {
				fprintf(stderr,
				        "  member %u (%c): order %llu after "
				        "%llu\n",
				        m->id, m->kind,
				        (unsigned long long)ea->order,
				        (unsigned long long)m->order);
			}
		}
		if (bc_edit_replay(&m->mirror, ea, &ei)) {
			fprintf(stderr, "  member %u: replay: %s\n", m->id,
			        ei.msg);
			m->gaps++;
		}
		m->order = ea->order;
		if (ea->author == m->id) {
			if (m->acked < m->sent &&
			    ea->author_seq == m->seqs[m->acked]) {
				m->acked++;
			} else {
				fprintf(stderr,
				        "  member %u: acknowledgement of seq "
				        "%u, expected %u\n",
				        m->id, ea->author_seq,
				        m->acked < m->sent ? m->seqs[m->acked]
				                           : 0);
				m->errors++;
			}
		}
	} else if (msg->type == BC_MSG_ERROR) {
		fprintf(stderr, "  member %u: ERROR %u for seq %u\n", m->id,
		        msg->error.code, msg->seq);
		m->errors++;
	}
}

/* Takes everything m has received within timeout_ms (then what is there);
 * -1 when the connection is gone. */
static int drain(struct member *m, int timeout_ms)
{
	int rc;
	while ((rc = conn_recv(&m->c, timeout_ms)) == 1) {
		timeout_ms = 0;
		take(m);
	}
	return rc < 0 ? -1 : 0;
}

/* A PING answered: everything the daemon queued for m before it is
 * taken. */
static int sync_member(struct member *m)
{
	struct bc_msg ping = {.type = BC_MSG_PING};
	uint32_t seq;
	ping.ping.stamp = 1;
	if (!(seq = conn_send(&m->c, &ping))) {
		return -1;
	}
	for (;;) {
		if (conn_recv(&m->c, 20000) != 1) {
			return -1;
		}
		if (m->c.m.type == BC_MSG_PONG && m->c.m.seq == seq) {
			return 0;
		}
		take(m);
	}
}

/* Bytes waiting in the socket of a member that does not read. */
static int unread(const struct member *m)
{
	int n = 0;
	return ioctl(m->c.fd, FIONREAD, &n) == 0 ? n : -1;
}

/* The daemon closed a member that does not read. */
static bool hung_up(const struct member *m)
{
	struct pollfd pfd = {.fd = m->c.fd, .events = 0};
	return poll(&pfd, 1, 0) == 1 && (pfd.revents & (POLLHUP | POLLERR));
}

/* Joins m to session (creating it when create), its SESSION_INFO and, for
 * a live member, its SCENE_STATE decoded into its mirror. */
static int join(struct member *m, const struct daemon *d, const char *session,
                char kind, int n, bool create)
{
	char name[16];
	snprintf(name, sizeof(name), "%c%d", kind, n);
	memset(m, 0, sizeof(*m));
	m->kind = kind;
	if (conn_open(&m->c, d) || conn_hello(&m->c, name) ||
	    conn_join(&m->c, session,
	              kind == 'E' ? BC_PROTO_ROLE_EDITOR : BC_PROTO_ROLE_VIEWER,
	              create)) {
		return -1;
	}
	m->id = m->c.m.session_info.member_id;
	if (kind == 'S' || create) {
		return 0; /* a stalled member reads nothing more */
	}
	if (conn_expect(&m->c, BC_MSG_SCENE_STATE, 10000) != 1 ||
	    !(m->mirror = bc_tree_create()) ||
	    bc_scene_decode(m->c.m.scene_state.scene.ptr,
	                    m->c.m.scene_state.scene.len, m->mirror, NULL, NULL,
	                    NULL)) {
		return -1;
	}
	m->order = m->c.m.scene_state.order;
	return 0;
}

/* A stalled member's setup: a view of big x h looking away from the scene
 * (nothing in view, a cheap render; members of one wave share it) and a
 * raw SNAPSHOT of it with depth and ids. The member reads up to its first
 * frame, the still, and never again. */
static int stall(struct member *m, uint16_t h)
{
	struct bc_msg cam = {.type = BC_MSG_CAMERA};
	struct bc_msg v = {.type = BC_MSG_VIEW};
	struct bc_msg snap = {.type = BC_MSG_SNAPSHOT};
	for (int a = 0; a < 3; a++) {
		cam.camera.eye[a] = scene_cam.eye[a];
		cam.camera.target[a] =
		    2.0f * scene_cam.eye[a] - scene_cam.target[a];
		cam.camera.up[a] = scene_cam.up[a];
	}
	cam.camera.fov_y_deg = scene_cam.fov_y_deg;
	v.view.width = big;
	v.view.height = h;
	v.view.encoding = BC_PROTO_ENC_JPEG;
	v.view.quality_interactive = 50;
	v.view.quality_still = 90;
	v.view.downscale = 1;
	snap.snapshot.encoding = BC_PROTO_ENC_RAW;
	snap.snapshot.planes = BC_PROTO_PLANE_DEPTH | BC_PROTO_PLANE_IDS;
	return conn_send(&m->c, &cam) && conn_send(&m->c, &v) &&
	               conn_send(&m->c, &snap)
	           ? 0
	           : -1;
}

/* Whether the stalled member m's snapshot is being written (1), not yet
 * (0), or its connection failed (-1). It reads up to the still; what comes
 * after it beyond a few member lists is the snapshot. */
static int stalled_ready(struct member *m)
{
	int rc = 0;
	while (!m->still && (rc = conn_recv(&m->c, 0)) == 1) {
		m->still = m->c.m.type == BC_MSG_FRAME &&
		           (m->c.m.flags & BC_PROTO_FLAG_STILL) &&
		           !(m->c.m.flags & BC_PROTO_FLAG_SNAPSHOT);
		if (m->c.m.type == BC_MSG_ERROR) {
			return -1;
		}
	}
	if (rc < 0) {
		return -1;
	}
	return m->still &&
	       bc_proto_reader_pending(&m->c.r) + (size_t)unread(m) >=
	           (16u << 10);
}

/* How the closers go: a close, a close inside a message, a LEAVE. */
static void close_now(struct member *m, int how)
{
	if (how == 1) {
		static const uint8_t half_ping[] = {'B', 'C', 'S', 'T', 1, 4,
		                                    0,   0,   8,   0,   0, 0};
		send_raw(&m->c, half_ping, sizeof(half_ping));
	} else if (how == 2) {
		struct bc_msg leave = {.type = BC_MSG_SESSION_LEAVE};
		conn_send(&m->c, &leave);
	}
	conn_close(&m->c);
	m->gone = true;
}

/*
 * One round: slot 0 is the editor that creates the session and loads the
 * scene; slots 1.. follow layout. With waves > 1 the stalled members'
 * snapshots come in that many sizes, so that they overflow on different
 * broadcasts.
 */
static void round_of(const struct daemon *d, int round, const char *layout,
                     uint32_t waves)
{
	static struct member ms[MAX_SLOTS];
	char session[16];
	uint8_t *scene = NULL;
	size_t scene_len = 0, n = strlen(layout) + 1;
	struct bc_msg load = {.type = BC_MSG_SCENE_LOAD};
	uint32_t stalled = 0, dropped = 0, edits = 0, editors = 0, after = 0;
	uint32_t closer_k = 0, k = 0, drop_edit[MAX_SLOTS] = {0};
	struct conn late;
	struct bc_tree *joined = NULL;
	struct bc_camera cam;
	int64_t t0 = t_now_ms(), t_frames, t_dropped = 0;
	bool closed = false;
	REQUIRE(n <= MAX_SLOTS);
	snprintf(session, sizeof(session), "round%d", round);
	REQUIRE(make_scene(&scene, &scene_len) == 0);
	REQUIRE(join(&ms[0], d, session, 'E', 0, true) == 0);
	load.scene_load.scene.ptr = scene;
	load.scene_load.scene.len = (uint32_t)scene_len;
	REQUIRE(conn_send(&ms[0].c, &load) != 0);
	bc_free(scene);
	/* The built-in scene's SCENE_STATE comes first, then the load's. */
	do {
		REQUIRE(conn_expect(&ms[0].c, BC_MSG_SCENE_STATE, 20000) == 1);
	} while (ms[0].c.m.scene_state.author_seq != load.seq);
	REQUIRE((ms[0].mirror = bc_tree_create()) != NULL);
	REQUIRE(bc_scene_decode(ms[0].c.m.scene_state.scene.ptr,
	                        ms[0].c.m.scene_state.scene.len, ms[0].mirror,
	                        NULL, NULL, NULL) == 0);
	ms[0].order = ms[0].c.m.scene_state.order;
	for (size_t i = 1; i < n; i++) {
		REQUIRE(join(&ms[i], d, session, layout[i - 1], (int)i,
		             false) == 0);
	}
	/* The stalled members' snapshots: each fills its queue to a little
	 * below the limit (the wave's view height sets how little). */
	for (size_t i = 1; i < n; i++) {
		if (ms[i].kind == 'S') {
			uint32_t wave = stalled++ % waves;
			REQUIRE(stall(&ms[i],
			              (uint16_t)(big - WAVE_ROWS * wave)) == 0);
		}
	}
	for (size_t i = 1; i < n; i++) {
		int64_t end = t_now_ms() + 20000;
		int rc;
		while (ms[i].kind == 'S' && (rc = stalled_ready(&ms[i])) != 1) {
			REQUIRE(rc == 0 && t_now_ms() < end);
			for (size_t j = 0; j < n; j++) {
				if (ms[j].kind == 'E' || ms[j].kind == 'R') {
					REQUIRE(drain(&ms[j], 0) == 0);
				}
			}
			t_sleep_ms(5);
		}
	}
	t_frames = t_now_ms();
	/* The editors' edits, WINDOW in flight each, until every stalled
	 * member is dropped, then a few more. The closers go the moment the
	 * first drops are due. */
	for (size_t i = 0; i < n; i++) {
		editors += ms[i].kind == 'E';
	}
	while (edits < first_drop + 60u && after < 2 * editors) {
		for (size_t i = 0; i < n; i++) {
			struct member *m = &ms[i];
			if (m->kind == 'E' && m->sent - m->acked < WINDOW &&
			    m->sent < MAX_EDITS) {
				uint32_t seq = send_edit(m, (uint32_t)i, k++);
				REQUIRE(seq != 0);
				m->seqs[m->sent++] = seq;
				edits++;
				after += dropped == stalled;
			}
		}
		if (!closed && edits + 1 >= first_drop) {
			for (size_t i = 0; i < n; i++) {
				if (ms[i].kind == 'C') {
					close_now(&ms[i],
					          (int)(closer_k++ % 3));
				}
			}
			closed = true;
		}
		for (size_t i = 0; i < n; i++) {
			struct member *m = &ms[i];
			if (m->kind == 'S' && !drop_edit[i] && hung_up(m)) {
				drop_edit[i] = edits;
				dropped++;
				t_dropped = t_now_ms();
			} else if ((m->kind == 'E' || m->kind == 'R') &&
			           drain(m, m->kind == 'E' &&
			                            m->sent - m->acked >= WINDOW
			                        ? 5
			                        : 0) != 0) {
				fprintf(stderr, "  %s: member %u (%c) closed\n",
				        session, m->id, m->kind);
				bc_test_failures++;
				goto out;
			}
		}
	}
	/* Every edit answered: each editor's PING after its edits, then
	 * everyone's after all of them. */
	for (size_t i = 0; i < n; i++) {
		if (ms[i].kind == 'E') {
			CHECK(sync_member(&ms[i]) == 0);
		}
	}
	for (size_t i = 0; i < n; i++) {
		if (ms[i].kind == 'E' || ms[i].kind == 'R') {
			CHECK(sync_member(&ms[i]) == 0);
		}
	}
	for (size_t i = 1; i < n; i++) {
		if (ms[i].kind == 'S' && !drop_edit[i] && hung_up(&ms[i])) {
			drop_edit[i] = edits;
			dropped++;
			t_dropped = t_now_ms();
		}
	}
	printf("  %s (E%s, %u wave%s): %u edits, %u of %u stalled members "
	       "dropped, seen after edits",
	       session, layout, waves, waves > 1 ? "s" : "", edits, dropped,
	       stalled);
	for (size_t i = 1; i < n; i++) {
		if (ms[i].kind == 'S') {
			printf(" %u", drop_edit[i]);
		}
	}
	printf(" (the last %lld ms after the snapshots), %lld ms\n",
	       (long long)(t_dropped - t_frames), (long long)(t_now_ms() - t0));
	/* The round exercised what it is for: the queues overflowed while
	 * edits were broadcast, not at the stall timeout. */
	CHECK(dropped == stalled);
	CHECK(t_dropped - t_frames < (int64_t)BC_SRV_STALL_MS);
	for (size_t i = 0; i < n; i++) {
		struct member *m = &ms[i];
		if (m->kind == 'E') {
			if (m->acked != m->sent) {
				fprintf(stderr,
				        "  %s: editor %u: %u of %u edits "
				        "acknowledged\n",
				        session, m->id, m->acked, m->sent);
			}
			CHECK(m->sent > 0 && m->acked == m->sent);
		}
		if (m->kind == 'E' || m->kind == 'R') {
			CHECK(m->errors == 0);
			CHECK(m->gaps == 0);
		}
	}
	/* A joiner's scene is every live member's mirror. */
	REQUIRE(conn_open(&late, d) == 0 && conn_hello(&late, "late") == 0);
	REQUIRE(conn_join(&late, session, BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&late, BC_MSG_SCENE_STATE, 10000) == 1);
	REQUIRE((joined = bc_tree_create()) != NULL);
	REQUIRE(bc_scene_decode(late.m.scene_state.scene.ptr,
	                        late.m.scene_state.scene.len, joined, &cam,
	                        NULL, NULL) == 0);
	CHECK(late.m.scene_state.order == 1 + edits);
	for (size_t i = 0; i < n; i++) {
		struct member *m = &ms[i];
		uint8_t *bytes = NULL;
		size_t len = 0;
		if (m->kind != 'E' && m->kind != 'R') {
			continue;
		}
		CHECK(m->order == late.m.scene_state.order);
		CHECK(bc_scene_encode(m->mirror, &cam, &bytes, &len) == 0);
		CHECK(bytes && len == late.m.scene_state.scene.len &&
		      memcmp(bytes, late.m.scene_state.scene.ptr, len) == 0);
		bc_free(bytes);
	}
	bc_tree_destroy(joined);
	conn_close(&late);
out:
	for (size_t i = 0; i < n; i++) {
		if (!ms[i].gone) {
			conn_close(&ms[i].c);
		}
		bc_tree_destroy(ms[i].mirror);
		ms[i].mirror = NULL;
	}
}

/* Layouts of slots 1.. (slot 0 is the creating editor). */
static void every_author_is_acknowledged_while_members_drop(void)
{
	struct daemon d;
	char dir[80], layout[MAX_SLOTS];
	uint64_t seed = 20261201;
	snprintf(dir, sizeof(dir), "%s/members", base_dir);
	{
		uint8_t *bytes = NULL;
		size_t len = 0;
		REQUIRE(make_scene(&bytes, &len) == 0);
		bc_free(bytes);
		REQUIRE(measure() == 0);
	}
	printf("  snapshots of %ux%u, EDIT_APPLIED of %u bytes: the %uth "
	       "after a snapshot overflows its queue\n",
	       big, big, applied_bytes, first_drop);
	REQUIRE(daemon_start(&d, dir) == 0);
	/* Stalled in front, live members behind them: each drop moves a
	 * live member into the dropped slot. All drop on one broadcast. */
	round_of(&d, 1, "SSSSCECRER", 1);
	/* Interleaved, in two waves. */
	round_of(&d, 2, "SESRCSESRC", 2);
	/* Shuffled slots, two waves. */
	memcpy(layout, "SSSSEERRCC", 11);
	for (int i = 9; i > 0; i--) {
		int j = (int)(rnd(&seed) % (uint32_t)(i + 1));
		char t = layout[i];
		layout[i] = layout[j];
		layout[j] = t;
	}
	round_of(&d, 3, layout, 2);
	CHECK(daemon_stop(&d, SIGTERM) == 0);
}

static const struct bc_test tests[] = {
    {"every_author_is_acknowledged_while_members_drop",
     every_author_is_acknowledged_while_members_drop},
};

int main(int argc, char **argv)
{
	(void)unused;
	if (getenv("BLOBCASTD")) {
		daemon_path = getenv("BLOBCASTD");
	}
	return daemon_tests_run("members", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
