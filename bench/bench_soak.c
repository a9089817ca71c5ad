/*
 * A soak of blobcastd under mixed clients with kill -9 every few seconds,
 * measured from outside over its sockets (the daemon is a black box):
 *
 *  - editors in two sessions send parameter edits (each recolours its own
 *    primitive with an increasing number k) and, every 20th edit, insert a
 *    marker sphere with an id of its own; what each EDIT_APPLIED
 *    acknowledged is recorded;
 *  - viewers watch those sessions and orbit now and then; a SNAPSHOT
 *    flooder asks bursts of PNG snapshots and hangs up without reading
 *    them; stalled readers join, ask big raw frames and never read; a
 *    connection flood opens TCP connections from several loopback
 *    addresses that never send HELLO;
 *  - a well-behaved client in a session of its own measures edit -> frame
 *    latency (bench/latency.h) alone first, under the load, and alone
 *    again at the end;
 *  - every --kill-every seconds the daemon is killed with SIGKILL and
 *    restarted on the same data directory and addresses; clients
 *    reconnect;
 *  - at the end (after one more kill) a joiner checks every session:
 *    each editor's primitive holds at least its last acknowledged k, and
 *    every acknowledged marker is in the tree. "acknowledged edits lost"
 *    counts the acknowledged edits the restored scenes do not hold; the
 *    exit status is 1 when it is not 0.
 *
 * The daemon's RSS (VmRSS) is sampled every second, per phase.
 *
 * The defaults compress 30 minutes of a busy review ten times: four
 * editors each editing 3 times a second on average (a 30 Hz drag a tenth
 * of the time) send about 21 600 edits in 30 minutes, sent here in 180 s;
 * a kill every 15 s is a crash every 2.5 minutes at the real pace.
 * Usage: bench_soak PATH/TO/blobcastd [options]; --help lists them.
 */
#include <arpa/inet.h>
#include <math.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdatomic.h>

/* scene.h first: daemon.h then offers scene_of(). */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "../tests/server/daemon.h"
#include "latency.h"

/* Ids of marker spheres: editor e's k-th marker is MARKER_ID + e << 20 +
 * k / MARKER_EVERY, far above the generated scenes' ids. */
#define MARKER_ID 0x40000000u
#define MARKER_EVERY 20u
#define MAX_THREADS 64
#define EDITOR_WINDOW 8u
#define MAX_PHASES 64

struct opts {
	double duration_s, kill_every_s;
	int editors, viewers, flooders, stalled, flood_addrs, flood_per_s;
	int edit_hz, alone_edits;
};

static struct opts opt = {.duration_s = 180,
                          .kill_every_s = 15,
                          .editors = 4,
                          .viewers = 4,
                          .flooders = 1,
                          .stalled = 3,
                          .flood_addrs = 8,
                          .flood_per_s = 64,
                          .edit_hz = 30,
                          .alone_edits = 60};

/* ---- the daemon under test ------------------------------------------ */

static struct daemon dmn;
static char data_dir[64];
static char listen_arg[32];
static int tcp_port;
static pthread_mutex_t dmn_lock = PTHREAD_MUTEX_INITIALIZER;
static int dmn_gen; /* restarts so far; changes while it is down */
static bool dmn_up;
static atomic_bool stopping;

/* Whether the daemon was up through [gen_before, now]: a failure then is
 * the daemon's refusal, not its restart. */
static int up_gen(void)
{
	int g;
	pthread_mutex_lock(&dmn_lock);
	g = dmn_up ? dmn_gen : -1;
	pthread_mutex_unlock(&dmn_lock);
	return g;
}

static int start_daemon(void)
{
	const char *extra[] = {"--listen", listen_arg, NULL};
	int rc = daemon_start_with(&dmn, data_dir, extra);
	pthread_mutex_lock(&dmn_lock);
	dmn_gen++;
	dmn_up = rc == 0;
	pthread_mutex_unlock(&dmn_lock);
	return rc;
}

static void kill_daemon(void)
{
	pthread_mutex_lock(&dmn_lock);
	dmn_up = false;
	pthread_mutex_unlock(&dmn_lock);
	daemon_stop(&dmn, SIGKILL);
}

/* A free TCP port on 127.0.0.1 (kept for every restart). */
static int pick_port(void)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	socklen_t len = sizeof(sa);
	int fd = socket(AF_INET, SOCK_STREAM, 0), port = 0;
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (fd >= 0 && bind(fd, (struct sockaddr *)&sa, sizeof(sa)) == 0 &&
	    getsockname(fd, (struct sockaddr *)&sa, &len) == 0) {
		port = ntohs(sa.sin_port);
	}
	if (fd >= 0) {
		close(fd);
	}
	return port;
}

static long rss_kib(pid_t pid)
{
	char path[64], line[256];
	long kib = -1;
	FILE *f;
	snprintf(path, sizeof(path), "/proc/%d/status", (int)pid);
	if (!(f = fopen(path, "r"))) {
		return -1;
	}
	while (fgets(line, sizeof(line), f)) {
		if (strncmp(line, "VmRSS:", 6) == 0) {
			kib = atol(line + 6);
			break;
		}
	}
	fclose(f);
	return kib;
}

/* ---- counters ---------------------------------------------------------- */

static atomic_long connects, connects_refused;
static atomic_long edits_sent, edits_acked, edits_refused;
static atomic_long frames_seen, snapshots_asked, snapshots_got;
static atomic_long stalled_dropped, stalled_rounds;
static atomic_long flood_opened, flood_closed_at_once, flood_connect_failed;

/* Connects c (HELLO, then joins session in role); counts a refusal only
 * when the daemon was up throughout. */
static int connect_to(struct conn *c, const char *name, const char *session,
                      enum bc_proto_role role)
{
	int g = up_gen();
	int rc;
	if (g < 0) {
		return -1;
	}
	atomic_fetch_add(&connects, 1);
	/* conn_open closes its socket itself when it fails. */
	rc = conn_open(c, &dmn);
	if (rc == 0 &&
	    (conn_hello(c, name) || conn_join(c, session, role, false))) {
		conn_close(c);
		rc = -1;
	}
	if (rc != 0) {
		if (up_gen() == g) {
			atomic_fetch_add(&connects_refused, 1);
		} else {
			atomic_fetch_sub(&connects, 1);
		}
		return -1;
	}
	return 0;
}

/* ---- sessions and their scenes ---------------------------------------- */

#define BUSY_SESSIONS 2
#define BUSY_PRIMS 256u

static const char *const busy_name[BUSY_SESSIONS] = {"busy0", "busy1"};
static uint32_t busy_prims[BUSY_SESSIONS][BUSY_PRIMS];
static uint32_t calm_id;
static struct bc_prim_data calm_prim;

/* Creates session name with fig18 of count spheres through c. */
static int create_session(const char *name, uint32_t count, uint32_t *id,
                          struct bc_prim_data *prim)
{
	struct conn c;
	int rc;
	if (conn_open(&c, &dmn)) {
		return -1;
	}
	if (conn_hello(&c, "setup") ||
	    conn_join(&c, name, BC_PROTO_ROLE_EDITOR, true)) {
		conn_close(&c);
		return -1;
	}
	rc = latency_load_fig18(&c, count, id, prim, NULL);
	conn_close(&c);
	return rc;
}

/* The primitives of a busy session (its SCENE_STATE, through a joiner). */
static int read_prims(int s)
{
	struct conn c;
	struct bc_tree *t;
	const struct bc_lin *l;
	int rc = -1;
	if (conn_open(&c, &dmn)) {
		return -1;
	}
	if (conn_hello(&c, "setup") ||
	    conn_join(&c, busy_name[s], BC_PROTO_ROLE_VIEWER, false) ||
	    conn_expect(&c, BC_MSG_SCENE_STATE, 10000) != 1 ||
	    !(t = scene_of(&c))) {
		conn_close(&c);
		return -1;
	}
	l = bc_tree_lin(t);
	if (l->nprims >= BUSY_PRIMS) {
		for (uint32_t i = 0; i < BUSY_PRIMS; i++) {
			busy_prims[s][i] = l->node_id[l->prim_slot[i]];
		}
		rc = 0;
	}
	bc_tree_destroy(t);
	conn_close(&c);
	return rc;
}

/* ---- editors ----------------------------------------------------------- */

struct editor {
	int index, session;
	uint32_t prim;   /* the primitive it recolours */
	uint32_t next_k; /* increasing over the whole run */
	/* In flight: seq -> k (k | 1 << 31 for a marker). */
	uint32_t pend_seq[EDITOR_WINDOW], pend_k[EDITOR_WINDOW];
	uint32_t npend;
	/* Acknowledged: colours (k) and markers (ids), in order. */
	uint32_t *acked_k, nacked_k, cap_k;
	uint32_t *acked_m, nacked_m, cap_m;
	uint64_t max_order; /* largest order acknowledged */
};

static int push_u32(uint32_t **a, uint32_t *n, uint32_t *cap, uint32_t v)
{
	if (*n == *cap) {
		uint32_t c = *cap ? *cap * 2 : 1024;
		uint32_t *p = bc_realloc(*a, (size_t)c * sizeof(uint32_t));
		if (!p) {
			return -1;
		}
		*a = p;
		*cap = c;
	}
	(*a)[(*n)++] = v;
	return 0;
}

/* The colour that carries k exactly (12 bits per channel). */
static void k_color(uint32_t k, float out[3])
{
	out[0] = (float)(k & 0xfffu) / 4096.0f;
	out[1] = (float)((k >> 12) & 0xfffu) / 4096.0f;
	out[2] = 0.5f;
}

static uint32_t color_k(const float c[3])
{
	return (uint32_t)(c[0] * 4096.0f + 0.5f) +
	       ((uint32_t)(c[1] * 4096.0f + 0.5f) << 12);
}

static uint32_t editor_send(struct editor *e, struct conn *c, uint32_t root)
{
	uint32_t k = e->next_k++;
	bool marker = k % MARKER_EVERY == MARKER_EVERY - 1;
	struct bc_proto_field f = {.field = BC_PROTO_FIELD_COLOR, .count = 3};
	struct bc_proto_edit_op op = {0};
	struct bc_proto_buf sub;
	struct bc_msg m = {.type = BC_MSG_EDIT};
	uint32_t seq;
	bc_proto_buf_init(&sub, 0);
	if (marker) {
		static const float t0[3] = {0, 0, 0}, r0[4] = {0, 0, 0, 1};
		float rad = 0.001f;
		uint32_t id =
		    MARKER_ID + ((uint32_t)e->index << 20) + k / MARKER_EVERY;
		bc_proto_scene_begin(&sub, NULL, 1);
		bc_proto_scene_prim(&sub, BC_PRIM_SPHERE, id, t0, r0, NULL, 1,
		                    &rad);
		op.kind = BC_PROTO_EDIT_INSERT;
		op.node = root;
		op.position = 0;
		op.subtree.ptr = sub.data;
		op.subtree.len = (uint32_t)sub.len;
		k = id | 0x80000000u;
	} else {
		k_color(k, f.v);
		op.kind = BC_PROTO_EDIT_SET;
		op.node = e->prim;
		op.nfields = 1;
		op.fields = &f;
	}
	m.edit.nops = 1;
	m.edit.ops = &op;
	seq = conn_send(c, &m);
	bc_proto_buf_finish(&sub);
	if (seq) {
		e->pend_seq[e->npend] = seq;
		e->pend_k[e->npend++] = k;
		atomic_fetch_add(&edits_sent, 1);
	}
	return seq;
}

/* An answer to one of e's edits: acknowledged (EDIT_APPLIED) or refused. */
static void editor_answer(struct editor *e, uint32_t seq, bool acked,
                          uint64_t order)
{
	for (uint32_t i = 0; i < e->npend; i++) {
		uint32_t k;
		if (e->pend_seq[i] != seq) {
			continue;
		}
		k = e->pend_k[i];
		e->pend_seq[i] = e->pend_seq[e->npend - 1];
		e->pend_k[i] = e->pend_k[e->npend - 1];
		e->npend--;
		if (!acked) {
			atomic_fetch_add(&edits_refused, 1);
			return;
		}
		atomic_fetch_add(&edits_acked, 1);
		if (order > e->max_order) {
			e->max_order = order;
		}
		if (k & 0x80000000u) {
			push_u32(&e->acked_m, &e->nacked_m, &e->cap_m,
			         k & 0x7fffffffu);
		} else {
			push_u32(&e->acked_k, &e->nacked_k, &e->cap_k, k);
		}
		return;
	}
}

static void *editor_main(void *arg)
{
	struct editor *e = arg;
	char name[16];
	snprintf(name, sizeof(name), "editor%d", e->index);
	while (!atomic_load(&stopping)) {
		struct conn c;
		struct bc_tree *t;
		uint32_t me, root;
		int64_t next = t_now_ms();
		if (connect_to(&c, name, busy_name[e->session],
		               BC_PROTO_ROLE_EDITOR) != 0) {
			t_sleep_ms(50);
			continue;
		}
		me = c.m.session_info.member_id;
		if (conn_expect(&c, BC_MSG_SCENE_STATE, 10000) != 1 ||
		    !(t = scene_of(&c))) {
			conn_close(&c);
			continue;
		}
		root = bc_tree_root(t);
		bc_tree_destroy(t);
		e->npend = 0;
		while (!atomic_load(&stopping)) {
			int rc;
			if (e->npend < EDITOR_WINDOW && t_now_ms() >= next) {
				if (!editor_send(e, &c, root)) {
					break;
				}
				next += 1000 / opt.edit_hz;
			}
			rc = conn_recv(&c, 5);
			if (rc < 0) {
				break;
			}
			if (rc == 1 && c.m.type == BC_MSG_EDIT_APPLIED &&
			    c.m.edit_applied.author == me) {
				editor_answer(e, c.m.edit_applied.author_seq,
				              true, c.m.edit_applied.order);
			} else if (rc == 1 && c.m.type == BC_MSG_ERROR) {
				editor_answer(e, c.m.seq, false, 0);
				if (c.m.flags & BC_PROTO_FLAG_FATAL) {
					break;
				}
			}
		}
		/* Edits in flight when the link broke: not acknowledged. */
		e->npend = 0;
		conn_close(&c);
	}
	return NULL;
}

/* ---- viewers, the snapshot flooder, stalled readers, the flood --------- */

static void send_view(struct conn *c, uint16_t size, int enc, int ds)
{
	struct bc_msg m = {.type = BC_MSG_VIEW};
	m.view.width = size;
	m.view.height = size;
	m.view.encoding = (enum bc_proto_encoding)enc;
	m.view.quality_interactive = 60;
	m.view.quality_still = 90;
	m.view.downscale = (uint8_t)ds;
	conn_send(c, &m);
}

static void send_orbit(struct conn *c, int step)
{
	struct bc_msg m = {.type = BC_MSG_CAMERA};
	float a = 0.3f * (float)step;
	m.camera.eye[0] = 12.0f * sinf(a);
	m.camera.eye[1] = 4.0f;
	m.camera.eye[2] = 12.0f * cosf(a);
	m.camera.up[1] = 1.0f;
	m.camera.fov_y_deg = 45.0f;
	conn_send(c, &m);
}

struct worker {
	int index;
	pthread_t th;
};

static void *viewer_main(void *arg)
{
	struct worker *w = arg;
	char name[16];
	int step = 0;
	snprintf(name, sizeof(name), "viewer%d", w->index);
	while (!atomic_load(&stopping)) {
		struct conn c;
		int64_t next_orbit;
		if (connect_to(&c, name, busy_name[w->index % BUSY_SESSIONS],
		               BC_PROTO_ROLE_VIEWER) != 0) {
			t_sleep_ms(50);
			continue;
		}
		send_view(&c, 384, BC_PROTO_ENC_JPEG, 4);
		next_orbit = t_now_ms() + 2000;
		while (!atomic_load(&stopping)) {
			int rc = conn_recv(&c, 50);
			if (rc < 0) {
				break;
			}
			if (rc == 1 && c.m.type == BC_MSG_FRAME) {
				atomic_fetch_add(&frames_seen, 1);
			}
			if (t_now_ms() >= next_orbit) {
				send_orbit(&c, step++);
				next_orbit += 2000;
			}
		}
		conn_close(&c);
	}
	return NULL;
}

/* Bursts of 20 PNG snapshots; it reads for a second, then hangs up with
 * the rest unread (their render jobs are the daemon's to drop). */
static void *flooder_main(void *arg)
{
	struct worker *w = arg;
	while (!atomic_load(&stopping)) {
		struct conn c;
		int64_t end;
		if (connect_to(&c, "flooder",
		               busy_name[w->index % BUSY_SESSIONS],
		               BC_PROTO_ROLE_VIEWER) != 0) {
			t_sleep_ms(50);
			continue;
		}
		send_view(&c, 512, BC_PROTO_ENC_PNG, 1);
		for (int i = 0; i < 20; i++) {
			struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
			m.snapshot.encoding = BC_PROTO_ENC_PNG;
			if (conn_send(&c, &m)) {
				atomic_fetch_add(&snapshots_asked, 1);
			}
		}
		end = t_now_ms() + 1000;
		while (!atomic_load(&stopping) && t_now_ms() < end) {
			int rc = conn_recv(&c, 50);
			if (rc < 0) {
				break;
			}
			if (rc == 1 && c.m.type == BC_MSG_FRAME &&
			    (c.m.flags & BC_PROTO_FLAG_SNAPSHOT)) {
				atomic_fetch_add(&snapshots_got, 1);
			}
		}
		conn_close(&c);
		t_sleep_ms(500);
	}
	return NULL;
}

/* Joins, asks a 2048^2 raw view and snapshots, never reads; waits to be
 * dropped (at most 15 s), then starts over. */
static void *stalled_main(void *arg)
{
	struct worker *w = arg;
	static const char *const sessions[] = {"busy0", "busy1", "calm"};
	char name[16];
	snprintf(name, sizeof(name), "stalled%d", w->index);
	while (!atomic_load(&stopping)) {
		struct conn c;
		int64_t end;
		int g = up_gen();
		if (connect_to(&c, name, sessions[w->index % 3],
		               BC_PROTO_ROLE_VIEWER) != 0) {
			t_sleep_ms(50);
			continue;
		}
		atomic_fetch_add(&stalled_rounds, 1);
		send_view(&c, 2048, BC_PROTO_ENC_RAW, 1);
		for (int i = 0; i < 4; i++) {
			struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
			m.snapshot.encoding = BC_PROTO_ENC_RAW;
			conn_send(&c, &m);
		}
		end = t_now_ms() + 15000;
		while (!atomic_load(&stopping) && t_now_ms() < end) {
			struct pollfd pfd = {.fd = c.fd, .events = 0};
			if (poll(&pfd, 1, 100) == 1 &&
			    (pfd.revents & (POLLHUP | POLLERR))) {
				if (up_gen() == g) {
					atomic_fetch_add(&stalled_dropped, 1);
				}
				break;
			}
		}
		conn_close(&c);
	}
	return NULL;
}

/* A TCP connection from 127.0.0.from_host to the daemon's port,
 * non-blocking connect completed within 1 s; -1 on failure. */
static int flood_connect(int from_host)
{
	struct sockaddr_in src = {.sin_family = AF_INET};
	struct sockaddr_in dst = {.sin_family = AF_INET};
	int fd = socket(AF_INET, SOCK_STREAM, 0);
	if (fd < 0) {
		return -1;
	}
	src.sin_addr.s_addr = htonl(0x7f000000u | (uint32_t)from_host);
	dst.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	dst.sin_port = htons((uint16_t)tcp_port);
	if (bind(fd, (struct sockaddr *)&src, sizeof(src)) != 0 ||
	    connect(fd, (struct sockaddr *)&dst, sizeof(dst)) != 0) {
		close(fd);
		return -1;
	}
	return fd;
}

/* Every second, flood_per_s silent connections spread over flood_addrs
 * source addresses (127.0.0.2 ..); those still open after 6 s (past the
 * HELLO timeout) are closed by us. */
static void *flood_main(void *arg)
{
	enum { HOLD = 6 };
	int *fds = bc_calloc((size_t)opt.flood_per_s * (HOLD + 1), sizeof(int));
	int round = 0;
	(void)arg;
	if (!fds) {
		return NULL;
	}
	while (!atomic_load(&stopping)) {
		int *mine = fds + (round % (HOLD + 1)) * opt.flood_per_s;
		int g = up_gen();
		for (int i = 0; i < opt.flood_per_s; i++) {
			if (mine[i] > 0) {
				close(mine[i]);
			}
			mine[i] =
			    g < 0 ? -1 : flood_connect(2 + i % opt.flood_addrs);
			if (g >= 0) {
				atomic_fetch_add(mine[i] >= 0
				                     ? &flood_opened
				                     : &flood_connect_failed,
				                 1);
			}
		}
		t_sleep_ms(300);
		/* Closed at once: the daemon refused it (per-address cap). */
		for (int i = 0; i < opt.flood_per_s && g >= 0; i++) {
			struct pollfd pfd = {.fd = mine[i], .events = POLLIN};
			if (mine[i] >= 0 && poll(&pfd, 1, 0) == 1 &&
			    up_gen() == g) {
				atomic_fetch_add(&flood_closed_at_once, 1);
				close(mine[i]);
				mine[i] = -1;
			}
		}
		t_sleep_ms(700);
		round++;
	}
	for (int i = 0; i < opt.flood_per_s * (HOLD + 1); i++) {
		if (fds[i] > 0) {
			close(fds[i]);
		}
	}
	bc_free(fds);
	return NULL;
}

/* ---- the well-behaved client -------------------------------------------- */

struct samples {
	int64_t *v;
	size_t n, cap;
	long lost; /* edits with no frame within latency_edits' 30 s */
};

static void sample_add(struct samples *s, int64_t v)
{
	if (s->n == s->cap) {
		size_t c = s->cap ? s->cap * 2 : 256;
		int64_t *p = bc_realloc(s->v, c * sizeof(int64_t));
		if (!p) {
			return;
		}
		s->v = p;
		s->cap = c;
	}
	s->v[s->n++] = v;
}

static int64_t pct(struct samples *s, int p)
{
	if (s->n == 0) {
		return -1;
	}
	qsort(s->v, s->n, sizeof(int64_t), latency_cmp_i64);
	return s->v[(s->n * (size_t)p) / 100 < s->n ? (s->n * (size_t)p) / 100
	                                            : s->n - 1];
}

/* Joins calm, a 512^2 JPEG view like bench_daemon, up to the still. */
static int calm_connect(struct conn *c)
{
	if (connect_to(c, "calm", "calm", BC_PROTO_ROLE_EDITOR) != 0) {
		return -1;
	}
	conn_view(c, 512, 512, BC_PROTO_ENC_JPEG);
	do {
		if (conn_expect(c, BC_MSG_FRAME, 30000) != 1) {
			conn_close(c);
			return -1;
		}
	} while (!(c->m.flags & BC_PROTO_FLAG_STILL));
	return 0;
}

/* Edits of the calm primitive, each timed to its frame, until max
 * samples (0: until stopping). */
/* Under load: from the calm client's link breaking (a kill) to its
 * next still picture (restart, restore, reconnect, render). */
static struct samples calm_back;

static void calm_run(struct samples *s, size_t max)
{
	static const float dx[2] = {-0.02f, 0.02f};
	int k = 0;
	int64_t give_up = t_now_ms() + 120000, lost_at = 0;
	while (max ? s->n < max && t_now_ms() < give_up
	           : !atomic_load(&stopping)) {
		struct conn c;
		if (calm_connect(&c) != 0) {
			t_sleep_ms(50);
			continue;
		}
		if (lost_at && !max) {
			sample_add(&calm_back, t_now_ms() - lost_at);
		}
		lost_at = 0;
		while (max ? s->n < max : !atomic_load(&stopping)) {
			struct latency l;
			struct bc_msg ping = {.type = BC_MSG_PING};
			latency_edits(&c, calm_id, &calm_prim, &dx[k++ % 2], 1,
			              1, false, &l);
			if (l.n == 1) {
				sample_add(s, l.p50);
				continue;
			}
			/* No frame: the daemon went away, or it starved us. */
			if (conn_send(&c, &ping) &&
			    conn_expect(&c, BC_MSG_PONG, 5000) == 1) {
				s->lost++;
				continue;
			}
			lost_at = t_now_ms();
			break;
		}
		conn_close(&c);
	}
}

struct calm_job {
	struct samples *s;
	size_t max;
	atomic_bool done;
};

static void *calm_main(void *arg)
{
	struct calm_job *j = arg;
	calm_run(j->s, j->max);
	atomic_store(&j->done, true);
	return NULL;
}

/* ---- RSS per phase ------------------------------------------------------- */

struct phase {
	char name[32];
	long n, min, max, last;
};

static struct phase phases[MAX_PHASES];
static int nphases;

static void phase_begin(const char *name)
{
	if (nphases < MAX_PHASES) {
		struct phase *p = &phases[nphases++];
		snprintf(p->name, sizeof(p->name), "%s", name);
		p->min = -1;
	}
}

static void phase_sample(void)
{
	struct phase *p;
	long kib = dmn.pid > 0 ? rss_kib(dmn.pid) : -1;
	if (kib < 0 || nphases == 0) {
		return;
	}
	p = &phases[nphases - 1];
	p->n++;
	p->min = p->min < 0 || kib < p->min ? kib : p->min;
	p->max = kib > p->max ? kib : p->max;
	p->last = kib;
}

/* Sleeps ms; RSS is sampled once a second. */
static void sleep_sampling(int64_t ms)
{
	static int64_t last;
	int64_t end = t_now_ms() + ms;
	while (t_now_ms() < end) {
		int64_t left = end - t_now_ms();
		t_sleep_ms(left < 100 ? (long)left : 100);
		if (t_now_ms() - last >= 1000) {
			last = t_now_ms();
			phase_sample();
		}
	}
}

/* ---- the end: what the restarted daemon holds --------------------------- */

static struct editor editors[MAX_THREADS];

/* Acknowledged edits absent from the sessions' scenes. */
static long verify(long *checked)
{
	long lost = 0;
	*checked = 0;
	for (int s = 0; s < BUSY_SESSIONS; s++) {
		struct conn c;
		struct bc_tree *t;
		uint64_t order;
		if (conn_open(&c, &dmn)) {
			c.fd = -1;
		}
		if (c.fd < 0 || conn_hello(&c, "verify") ||
		    conn_join(&c, busy_name[s], BC_PROTO_ROLE_VIEWER, false) ||
		    conn_expect(&c, BC_MSG_SCENE_STATE, 30000) != 1 ||
		    !(t = scene_of(&c))) {
			printf("session %s: cannot be joined after the "
			       "restart: all its acknowledged edits count "
			       "as lost\n",
			       busy_name[s]);
			for (int e = 0; e < opt.editors; e++) {
				if (editors[e].session == s) {
					lost += editors[e].nacked_k +
					        editors[e].nacked_m;
					*checked += editors[e].nacked_k +
					            editors[e].nacked_m;
				}
			}
			conn_close(&c);
			continue;
		}
		order = c.m.scene_state.order;
		for (int e = 0; e < opt.editors; e++) {
			struct editor *ed = &editors[e];
			struct bc_prim_data p = {0};
			bool colored;
			uint32_t kf = 0;
			long gone = 0;
			if (ed->session != s) {
				continue;
			}
			colored =
			    bc_tree_get(t, ed->prim, &p, NULL) && p.has_color;
			if (colored) {
				kf = color_k(p.color);
			}
			for (uint32_t i = 0; i < ed->nacked_k; i++) {
				gone += !colored || ed->acked_k[i] > kf;
			}
			for (uint32_t i = 0; i < ed->nacked_m; i++) {
				gone +=
				    !bc_tree_get(t, ed->acked_m[i], NULL, NULL);
			}
			if (gone || order < ed->max_order) {
				printf(
				    "editor %d (%s): %ld acknowledged edits "
				    "missing (colour k %u, last acknowledged "
				    "%u); session order %llu, largest "
				    "acknowledged %llu\n",
				    e, busy_name[s], gone, kf,
				    ed->nacked_k ? ed->acked_k[ed->nacked_k - 1]
				                 : 0,
				    (unsigned long long)order,
				    (unsigned long long)ed->max_order);
			}
			lost += gone;
			*checked += ed->nacked_k + ed->nacked_m;
		}
		bc_tree_destroy(t);
		conn_close(&c);
	}
	return lost;
}

/* ---- main ---------------------------------------------------------------- */

static void usage(FILE *f)
{
	fprintf(
	    f,
	    "usage: bench_soak PATH/TO/blobcastd [options]\n"
	    "Mixed clients against a blobcastd it starts (temporary data\n"
	    "directory, Unix socket and TCP port), killed with SIGKILL and\n"
	    "restarted every --kill-every seconds; at the end every\n"
	    "acknowledged edit must be in the restored sessions (exit\n"
	    "status 1 if one is missing, 2 on a usage or setup error).\n"
	    "The defaults are 30 minutes of a busy review (about 21 600\n"
	    "edits, a crash every 2.5 minutes) compressed ten times.\n"
	    "  --duration S      seconds under load (default %.0f)\n"
	    "  --kill-every S    seconds between kills (default %.0f)\n"
	    "  --editors N       editing clients (default %d)\n"
	    "  --viewers N       watching clients (default %d)\n"
	    "  --flooders N      snapshot flooders (default %d)\n"
	    "  --stalled N       clients that never read (default %d)\n"
	    "  --edit-hz N       edits per second per editor (default %d)\n"
	    "  --flood-addrs N   source addresses of the connection flood\n"
	    "                    (127.0.0.2 ..; default %d, 0: no flood)\n"
	    "  --flood-per-s N   silent connections per second (default "
	    "%d)\n"
	    "  --alone-edits N   edits timed alone before and after the\n"
	    "                    load (default %d)\n",
	    opt.duration_s, opt.kill_every_s, opt.editors, opt.viewers,
	    opt.flooders, opt.stalled, opt.edit_hz, opt.flood_addrs,
	    opt.flood_per_s, opt.alone_edits);
}

static int parse_args(int argc, char **argv)
{
	for (int i = 2; i < argc; i++) {
		const char *a = argv[i];
		double v;
		char *end;
		if (i + 1 >= argc) {
			return -1;
		}
		v = strtod(argv[++i], &end);
		if (*end || v < 0) {
			return -1;
		}
		if (!strcmp(a, "--duration")) {
			opt.duration_s = v;
		} else if (!strcmp(a, "--kill-every")) {
			opt.kill_every_s = v;
		} else if (!strcmp(a, "--editors") && v >= 1 && v <= 16) {
			opt.editors = (int)v;
		} else if (!strcmp(a, "--viewers") && v <= 16) {
			opt.viewers = (int)v;
		} else if (!strcmp(a, "--flooders") && v <= 8) {
			opt.flooders = (int)v;
		} else if (!strcmp(a, "--stalled") && v <= 16) {
			opt.stalled = (int)v;
		} else if (!strcmp(a, "--edit-hz") && v >= 1 && v <= 1000) {
			opt.edit_hz = (int)v;
		} else if (!strcmp(a, "--flood-addrs") && v <= 200) {
			opt.flood_addrs = (int)v;
		} else if (!strcmp(a, "--flood-per-s") && v >= 1 && v <= 1000) {
			opt.flood_per_s = (int)v;
		} else if (!strcmp(a, "--alone-edits") && v >= 1) {
			opt.alone_edits = (int)v;
		} else {
			return -1;
		}
	}
	return opt.kill_every_s >= 1 ? 0 : -1;
}

/* The calm client alone for opt.alone_edits edits, RSS sampled. */
static void alone_phase(struct samples *s)
{
	struct calm_job j = {.s = s, .max = (size_t)opt.alone_edits};
	pthread_t th;
	atomic_init(&j.done, false);
	pthread_create(&th, NULL, calm_main, &j);
	while (!atomic_load(&j.done)) {
		sleep_sampling(100);
	}
	pthread_join(th, NULL);
	phase_sample();
}

static void print_latency(const char *what, struct samples *s)
{
	printf("%-22s edits=%zu p50_ms=%lld p99_ms=%lld max_ms=%lld "
	       "no_frame_in_30s=%ld\n",
	       what, s->n, (long long)pct(s, 50), (long long)pct(s, 99),
	       (long long)pct(s, 100), s->lost);
}

int main(int argc, char **argv)
{
	struct worker workers[MAX_THREADS];
	pthread_t calm_th, flood_th;
	struct samples alone = {0}, alone_after = {0}, calm_load = {0};
	struct calm_job job = {.s = &calm_load};
	atomic_init(&job.done, false);
	int nworkers = 0, kills = 0, crashes = 0;
	long lost, checked;
	int64_t t0, next_kill, next_print;
	char cmd[256];
	(void)daemon_start; /* daemon.h's; restarts need the TCP port too */
	if (argc >= 2 && !strcmp(argv[1], "--help")) {
		usage(stdout);
		return 0;
	}
	if (argc < 2 || parse_args(argc, argv) != 0) {
		usage(stderr);
		return 2;
	}
	daemon_path = argv[1];
	signal(SIGPIPE, SIG_IGN);
	/* The daemon's log goes to DIR.log, ours to stdout. */
	snprintf(data_dir, sizeof(data_dir), "/tmp/bc-soak-%d", (int)getpid());
	snprintf(cmd, sizeof(cmd), "%s.log", data_dir);
	if (!freopen(cmd, "w", stderr)) {
		return 2;
	}
	setenv("BLOBCAST_TEST_VERBOSE", "1", 1);
	setvbuf(stdout, NULL, _IOLBF, 0);
	if (!(tcp_port = pick_port())) {
		printf("no free TCP port\n");
		return 2;
	}
	snprintf(listen_arg, sizeof(listen_arg), "127.0.0.1:%d", tcp_port);
	printf("bench_soak: %s, data %s, log %s.log, port %d\n", argv[1],
	       data_dir, data_dir, tcp_port);
	printf("load: %.0f s, kill -9 every %.0f s, %d editors at %d Hz, "
	       "%d viewers, %d snapshot flooders, %d stalled readers, "
	       "flood of %d connections/s from %d addresses\n",
	       opt.duration_s, opt.kill_every_s, opt.editors, opt.edit_hz,
	       opt.viewers, opt.flooders, opt.stalled,
	       opt.flood_addrs ? opt.flood_per_s : 0, opt.flood_addrs);
	if (start_daemon() != 0) {
		printf("cannot start %s\n", argv[1]);
		return 2;
	}
	if (create_session("calm", 1024, &calm_id, &calm_prim) != 0) {
		printf("cannot create the calm session\n");
		return 2;
	}
	for (int s = 0; s < BUSY_SESSIONS; s++) {
		uint32_t id;
		struct bc_prim_data p;
		if (create_session(busy_name[s], BUSY_PRIMS, &id, &p) != 0 ||
		    read_prims(s) != 0) {
			printf("cannot create session %s\n", busy_name[s]);
			return 2;
		}
	}
	/* Alone: the calm client and nothing else. */
	phase_begin("alone");
	phase_sample();
	alone_phase(&alone);
	print_latency("edit->frame alone", &alone);

	/* Under load, killed every kill_every seconds. */
	atomic_store(&stopping, false);
	for (int e = 0; e < opt.editors; e++) {
		editors[e].index = e;
		editors[e].session = e % BUSY_SESSIONS;
		editors[e].prim =
		    busy_prims[e % BUSY_SESSIONS]
		              [(37u * (uint32_t)e + 11u) % BUSY_PRIMS];
		pthread_create(&workers[nworkers].th, NULL, editor_main,
		               &editors[e]);
		nworkers++;
	}
	for (int i = 0; i < opt.viewers; i++, nworkers++) {
		workers[nworkers].index = i;
		pthread_create(&workers[nworkers].th, NULL, viewer_main,
		               &workers[nworkers]);
	}
	for (int i = 0; i < opt.flooders; i++, nworkers++) {
		workers[nworkers].index = i;
		pthread_create(&workers[nworkers].th, NULL, flooder_main,
		               &workers[nworkers]);
	}
	for (int i = 0; i < opt.stalled; i++, nworkers++) {
		workers[nworkers].index = i;
		pthread_create(&workers[nworkers].th, NULL, stalled_main,
		               &workers[nworkers]);
	}
	if (opt.flood_addrs > 0) {
		pthread_create(&flood_th, NULL, flood_main, NULL);
	}
	pthread_create(&calm_th, NULL, calm_main, &job);
	t0 = t_now_ms();
	next_kill = t0 + (int64_t)(opt.kill_every_s * 1000);
	next_print = t0 + 10000;
	phase_begin("load, start");
	while (t_now_ms() - t0 < (int64_t)(opt.duration_s * 1000)) {
		int status;
		sleep_sampling(200);
		if (dmn.pid > 0 &&
		    waitpid(dmn.pid, &status, WNOHANG) == dmn.pid) {
			printf("t=%llds: the daemon died on its own (%s %d); "
			       "restarting\n",
			       (long long)((t_now_ms() - t0) / 1000),
			       WIFSIGNALED(status) ? "signal" : "exit",
			       WIFSIGNALED(status) ? WTERMSIG(status)
			                           : WEXITSTATUS(status));
			crashes++;
			dmn.pid = 0;
			pthread_mutex_lock(&dmn_lock);
			dmn_up = false;
			pthread_mutex_unlock(&dmn_lock);
			next_kill = 0;
		}
		if (t_now_ms() >= next_kill) {
			char name[32];
			if (dmn.pid > 0) {
				kill_daemon();
				kills++;
			}
			if (start_daemon() != 0) {
				printf("the daemon did not restart after kill "
				       "%d: see %s.log\n",
				       kills, data_dir);
				atomic_store(&stopping, true);
				break;
			}
			snprintf(name, sizeof(name), "load, after kill %d",
			         kills);
			phase_begin(name);
			phase_sample();
			next_kill =
			    t_now_ms() + (int64_t)(opt.kill_every_s * 1000);
		}
		if (t_now_ms() >= next_print) {
			printf("t=%llds kills=%d edits sent=%ld acked=%ld "
			       "calm samples=%zu rss=%ld MiB\n",
			       (long long)((t_now_ms() - t0) / 1000), kills,
			       atomic_load(&edits_sent),
			       atomic_load(&edits_acked), calm_load.n,
			       phases[nphases - 1].last / 1024);
			next_print += 10000;
		}
	}
	phase_sample();
	atomic_store(&stopping, true);
	for (int i = 0; i < nworkers; i++) {
		pthread_join(workers[i].th, NULL);
	}
	if (opt.flood_addrs > 0) {
		pthread_join(flood_th, NULL);
	}
	pthread_join(calm_th, NULL);

	/* One more kill, then what the restarted daemon holds. */
	kill_daemon();
	kills++;
	if (start_daemon() != 0) {
		printf("the daemon did not restart after the last kill\n");
		return 1;
	}
	phase_begin("restarted, verify");
	phase_sample();
	lost = verify(&checked);
	phase_sample();
	atomic_store(&stopping, false);
	alone_phase(&alone_after);

	printf("\n== results (%.0f s under load) ==\n", opt.duration_s);
	print_latency("edit->frame alone", &alone);
	print_latency("edit->frame under load", &calm_load);
	print_latency("edit->frame alone again", &alone_after);
	printf("calm client back to a still after a kill: n=%zu p50_ms=%lld "
	       "max_ms=%lld\n",
	       calm_back.n, (long long)pct(&calm_back, 50),
	       (long long)pct(&calm_back, 100));
	if (pct(&alone, 99) > 0 && pct(&calm_load, 99) >= 0) {
		printf("p99 under load / alone = %.1f, p50 = %.1f\n",
		       (double)pct(&calm_load, 99) / (double)pct(&alone, 99),
		       (double)pct(&calm_load, 50) /
		           (double)(pct(&alone, 50) > 0 ? pct(&alone, 50) : 1));
	}
	printf("kills done: %d (daemon deaths not ours: %d)\n", kills, crashes);
	printf("edits sent: %ld, acknowledged: %ld, refused: %ld\n",
	       atomic_load(&edits_sent), atomic_load(&edits_acked),
	       atomic_load(&edits_refused));
	printf("viewer frames: %ld; snapshots asked %ld, received %ld\n",
	       atomic_load(&frames_seen), atomic_load(&snapshots_asked),
	       atomic_load(&snapshots_got));
	printf("stalled readers: %ld joins, %ld dropped by the daemon\n",
	       atomic_load(&stalled_rounds), atomic_load(&stalled_dropped));
	printf("connects refused: %ld of %ld client connects (while the "
	       "daemon was up)\n",
	       atomic_load(&connects_refused), atomic_load(&connects));
	printf("connection flood: %ld opened, %ld closed at once by the "
	       "daemon, %ld connect() failures\n",
	       atomic_load(&flood_opened), atomic_load(&flood_closed_at_once),
	       atomic_load(&flood_connect_failed));
	printf("daemon RSS (MiB)\n  %-22s %7s %7s %7s %7s\n", "phase",
	       "samples", "min", "max", "last");
	for (int i = 0; i < nphases; i++) {
		printf("  %-22s %7ld %7.0f %7.0f %7.0f\n", phases[i].name,
		       phases[i].n, (double)phases[i].min / 1024.0,
		       (double)phases[i].max / 1024.0,
		       (double)phases[i].last / 1024.0);
	}
	printf("acknowledged edits checked: %ld\n", checked);
	printf("acknowledged edits lost: %ld\n", lost);

	daemon_stop(&dmn, SIGTERM);
	for (int e = 0; e < opt.editors; e++) {
		bc_free(editors[e].acked_k);
		bc_free(editors[e].acked_m);
	}
	bc_free(alone.v);
	bc_free(alone_after.v);
	bc_free(calm_load.v);
	bc_free(calm_back.v);
	if (lost == 0) {
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock %s.log", data_dir,
		         data_dir, data_dir);
		if (system(cmd) != 0) {
			return 1;
		}
	} else {
		printf("data directory and log kept: %s, %s.log\n", data_dir,
		       data_dir);
	}
	return lost == 0 ? 0 : 1;
}
