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
 * With --damage, each kill (after the SIGKILL, before the restart) also
 * damages the data directory of one busy session, the two taking turns
 * and each going through four cases in rotation (a case that cannot apply
 * gives way to the next), to test the recovery rules of
 * docs/operations.md, "Data directory":
 *
 *  1. its newest snap-N.bin is cut to half its size, when the previous
 *     generation's snapshot is there: the older snapshot and the journals
 *     give back every edit;
 *  2. bytes are flipped inside a record in the middle of a journal-M.bin
 *     that a newer snapshot covers (M < N): it is not even read;
 *  3. the session directory is made read-only (a read-only bind mount,
 *     else chattr +i) for a restart of 3 s while clients try it: the
 *     session is not served, or its edits are refused, never an older
 *     state; then it is writable again, SIGKILL, restart;
 *  4. bytes are flipped inside a record in the middle of the newest
 *     journal: an acknowledged edit is lost for real (no copy exists).
 *     The session must be refused for 3 s (ERROR EIO naming `blobcastd
 *     --check`); then the daemon is killed, `blobcastd --check DIR` must
 *     exit 1 naming it NOT WHOLE, `--check DIR --repair` must exit 0, and
 *     after the restart the session's order must be at least the highest
 *     it ever acknowledged.
 *
 * After each cycle a joiner checks both busy sessions: every edit
 * acknowledged before the kill is there (but the one whose record case 4
 * flipped, counted apart as lost to unrepairable damage) and the order is
 * not behind. Each EDIT_APPLIED is kept with the daemon generation that
 * sent it: an order at or below one an earlier generation acknowledged in
 * the same session is an order number reused. Per case the soak prints
 * the times applied, acknowledged edits lost, orders reused and JOINs
 * refused; the exit status is also 1 when a case other than 4 lost an
 * acknowledged edit, case 4 lost more than its flipped record, an order
 * number was reused, an older state was served, or a check of case 4
 * failed. Clients refused a session back off (up to 2 s) and retry.
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
#include <dirent.h>
#include <math.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdatomic.h>

/* scene.h first: daemon.h then offers scene_of(). */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/bytes.h"
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
/* Daemon starts whose damage case is remembered (a run of hours with a
 * kill every second stays below it; later ones count as undamaged). */
#define MAX_GENS 8192
/* What a JOIN refusal's text is copied into. */
#define WHY_LEN 512

struct opts {
	double duration_s, kill_every_s;
	int editors, viewers, flooders, stalled, flood_addrs, flood_per_s;
	int edit_hz, alone_edits;
	bool damage;
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

/* The damage cases of --damage (see the comment at the top). */
enum damage {
	DAMAGE_NONE = 0,
	DAMAGE_SNAP_TORN,
	DAMAGE_OLD_JOURNAL,
	DAMAGE_READ_ONLY,
	DAMAGE_LIVE_JOURNAL,
	DAMAGE_COUNT
};

/* Which damage each daemon start follows, and in which busy session
 * (-1: none), so that what a client of that generation sees is counted
 * under its case. Written before the start is published (dmn_lock). */
static uint8_t gen_damage[MAX_GENS];
static int8_t gen_session[MAX_GENS];
static enum damage pending_damage;
static int pending_session = -1;

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
	if (dmn_gen < MAX_GENS) {
		gen_damage[dmn_gen] = (uint8_t)pending_damage;
		gen_session[dmn_gen] = (int8_t)pending_session;
	}
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

#define BUSY_SESSIONS 2
#define BUSY_PRIMS 256u

static const char *const busy_name[BUSY_SESSIONS] = {"busy0", "busy1"};

static atomic_long connects, connects_refused;
static atomic_long edits_sent, edits_acked, edits_refused;
static atomic_long frames_seen, snapshots_asked, snapshots_got;
static atomic_long stalled_dropped, stalled_rounds;
static atomic_long flood_opened, flood_closed_at_once, flood_connect_failed;

/* Per damage case (DAMAGE_NONE: what no damage explains). */
struct damage_stats {
	long applied, skipped;   /* main thread only */
	long lost, lost_flipped; /* found by the checks (main thread) */
	long reused;             /* found at the end */
	long older_state;        /* a JOIN answered with an older order */
	long unserved;           /* a session not served after its cycle */
	long check_failed;       /* case 4: --check, --repair or the order */
	atomic_long joins_refused, joins_refused_named, edits_refused;
};

static struct damage_stats dstats[DAMAGE_COUNT];

static const char *const damage_label[DAMAGE_COUNT] = {
    "no damage", "1 newest snapshot torn", "2 covered journal flipped",
    "3 directory read-only", "4 live journal flipped"};

/* The busy session named name, or -1. */
static int busy_index(const char *name)
{
	for (int s = 0; s < BUSY_SESSIONS; s++) {
		if (!strcmp(name, busy_name[s])) {
			return s;
		}
	}
	return -1;
}

/* The case that generation g's daemon started after in busy session s. */
static enum damage damage_of(int g, int s)
{
	if (g <= 0 || g >= MAX_GENS || s < 0 || gen_session[g] != s) {
		return DAMAGE_NONE;
	}
	return (enum damage)gen_damage[g];
}

/* SESSION_JOIN of session in role: 0 when SESSION_INFO came, the ERROR's
 * code (> 0, its text copied to why) when refused, -1 when the link
 * failed or nothing came within 5 s. */
static int join(struct conn *c, const char *session, enum bc_proto_role role,
                char why[WHY_LEN])
{
	struct bc_msg m = {.type = BC_MSG_SESSION_JOIN};
	int64_t end = t_now_ms() + 5000;
	uint32_t seq;
	why[0] = 0;
	m.session.role = role;
	m.session.name.ptr = session;
	m.session.name.len = (uint32_t)strlen(session);
	if (!(seq = conn_send(c, &m))) {
		return -1;
	}
	while (t_now_ms() < end) {
		int rc = conn_recv(c, (int)(end - t_now_ms()));
		if (rc < 0) {
			return -1;
		}
		if (rc == 1 && c->m.type == BC_MSG_SESSION_INFO) {
			return 0;
		}
		if (rc == 1 && c->m.type == BC_MSG_ERROR &&
		    (c->m.seq == seq || c->m.seq == 0)) {
			size_t n = c->m.error.text.len < WHY_LEN - 1
			               ? c->m.error.text.len
			               : WHY_LEN - 1;
			memcpy(why, c->m.error.text.ptr, n);
			why[n] = 0;
			return c->m.error.code ? c->m.error.code : -1;
		}
	}
	return -1;
}

/* What a failed connect_to means for the caller's next try. */
enum {
	CONNECT_DOWN = -1,    /* the daemon was (re)starting: retry soon */
	CONNECT_REFUSED = -2, /* refused while it was up: back off */
};

/* Connects c (HELLO, then joins session in role). Returns the daemon's
 * generation (>= 0) when it was the same daemon throughout, else
 * CONNECT_DOWN or CONNECT_REFUSED; counts a refusal only when the daemon
 * was up throughout, a JOIN refused with EIO under the damage case of the
 * session in that generation. */
static int connect_to(struct conn *c, const char *name, const char *session,
                      enum bc_proto_role role)
{
	int g = up_gen();
	int rc;
	char why[WHY_LEN];
	if (g < 0) {
		return CONNECT_DOWN;
	}
	atomic_fetch_add(&connects, 1);
	/* conn_open closes its socket itself when it fails. */
	rc = conn_open(c, &dmn);
	if (rc == 0 && conn_hello(c, name)) {
		conn_close(c);
		rc = -1;
	} else if (rc == 0 && (rc = join(c, session, role, why)) != 0) {
		conn_close(c);
	}
	if (rc != 0 && up_gen() != g) {
		atomic_fetch_sub(&connects, 1);
		return CONNECT_DOWN;
	}
	if (rc == -BC_EIO) {
		struct damage_stats *d =
		    &dstats[damage_of(g, busy_index(session))];
		atomic_fetch_add(&d->joins_refused, 1);
		if (strstr(why, "blobcastd --check")) {
			atomic_fetch_add(&d->joins_refused_named, 1);
		}
		return CONNECT_REFUSED;
	}
	if (rc != 0) {
		atomic_fetch_add(&connects_refused, 1);
		return CONNECT_REFUSED;
	}
	if (up_gen() != g) {
		/* Killed and started again meanwhile: which daemon answered
		 * is not known; try again. */
		conn_close(c);
		atomic_fetch_sub(&connects, 1);
		return CONNECT_DOWN;
	}
	return g;
}

/* Waits before the next connect: 50 ms after the daemon was down, else
 * *backoff ms, doubled each time up to 2 s (a session refused while its
 * files are damaged is asked again calmly, not in a busy loop). A
 * successful connect resets *backoff to 50. */
static void retry_wait(int why, long *backoff)
{
	if (why == CONNECT_DOWN) {
		t_sleep_ms(50);
		return;
	}
	t_sleep_ms(*backoff);
	*backoff = *backoff >= 1000 ? 2000 : *backoff * 2;
}

/* ---- sessions and their scenes ---------------------------------------- */
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

#define MARKER_BIT 0x80000000u

/* One acknowledged edit. */
struct ack {
	uint64_t order; /* its EDIT_APPLIED's */
	uint32_t k;     /* the colour's k, or a marker's id | MARKER_BIT */
	int gen;        /* the daemon start that acknowledged it */
	bool flipped;   /* its journal record was flipped (case 4) */
	bool missed;    /* already counted as lost by a check */
};

struct editor {
	int index, session;
	uint32_t prim;   /* the primitive it recolours */
	uint32_t next_k; /* increasing over the whole run */
	int gen;         /* of the daemon it is connected to */
	/* In flight: seq -> k (k | MARKER_BIT for a marker). */
	uint32_t pend_seq[EDITOR_WINDOW], pend_k[EDITOR_WINDOW];
	uint32_t npend;
	/* Acknowledged, in order; the checks read them under lock. */
	pthread_mutex_t lock;
	struct ack *acks;
	size_t nacks, cap;
	uint64_t max_order; /* largest order acknowledged */
};

static int push_ack(struct editor *e, const struct ack *a)
{
	if (e->nacks == e->cap) {
		size_t c = e->cap ? e->cap * 2 : 1024;
		struct ack *p = bc_realloc(e->acks, c * sizeof(*p));
		if (!p) {
			return -1;
		}
		e->acks = p;
		e->cap = c;
	}
	e->acks[e->nacks++] = *a;
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
		k = id | MARKER_BIT;
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
			atomic_fetch_add(&dstats[damage_of(e->gen, e->session)]
			                      .edits_refused,
			                 1);
			return;
		}
		atomic_fetch_add(&edits_acked, 1);
		pthread_mutex_lock(&e->lock);
		if (order > e->max_order) {
			e->max_order = order;
		}
		push_ack(e,
		         &(struct ack){.order = order, .k = k, .gen = e->gen});
		pthread_mutex_unlock(&e->lock);
		return;
	}
}

static void *editor_main(void *arg)
{
	struct editor *e = arg;
	char name[16];
	long backoff = 50;
	snprintf(name, sizeof(name), "editor%d", e->index);
	while (!atomic_load(&stopping)) {
		struct conn c;
		struct bc_tree *t;
		uint32_t me, root;
		int64_t next = t_now_ms();
		int g = connect_to(&c, name, busy_name[e->session],
		                   BC_PROTO_ROLE_EDITOR);
		if (g < 0) {
			retry_wait(g, &backoff);
			continue;
		}
		backoff = 50;
		e->gen = g;
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
	int step = 0, g;
	long backoff = 50;
	snprintf(name, sizeof(name), "viewer%d", w->index);
	while (!atomic_load(&stopping)) {
		struct conn c;
		int64_t next_orbit;
		if ((g = connect_to(&c, name,
		                    busy_name[w->index % BUSY_SESSIONS],
		                    BC_PROTO_ROLE_VIEWER)) < 0) {
			retry_wait(g, &backoff);
			continue;
		}
		backoff = 50;
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
	long backoff = 50;
	while (!atomic_load(&stopping)) {
		struct conn c;
		int64_t end;
		int g = connect_to(&c, "flooder",
		                   busy_name[w->index % BUSY_SESSIONS],
		                   BC_PROTO_ROLE_VIEWER);
		if (g < 0) {
			retry_wait(g, &backoff);
			continue;
		}
		backoff = 50;
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
	long backoff = 50;
	snprintf(name, sizeof(name), "stalled%d", w->index);
	while (!atomic_load(&stopping)) {
		struct conn c;
		int64_t end;
		int g = connect_to(&c, name, sessions[w->index % 3],
		                   BC_PROTO_ROLE_VIEWER);
		if (g < 0) {
			retry_wait(g, &backoff);
			continue;
		}
		backoff = 50;
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
	if (connect_to(c, "calm", "calm", BC_PROTO_ROLE_EDITOR) < 0) {
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

/* ---- what a restarted daemon holds ---------------------------------------- */

static struct editor editors[MAX_THREADS];

/* The largest order acknowledged in busy session s before generation
 * gnow. */
static uint64_t acked_top(int s, int gnow)
{
	uint64_t top = 0;
	for (int e = 0; e < opt.editors; e++) {
		struct editor *ed = &editors[e];
		if (ed->session != s) {
			continue;
		}
		pthread_mutex_lock(&ed->lock);
		for (size_t i = 0; i < ed->nacks; i++) {
			if (ed->acks[i].gen < gnow && ed->acks[i].order > top) {
				top = ed->acks[i].order;
			}
		}
		pthread_mutex_unlock(&ed->lock);
	}
	return top;
}

/* Editor ed's acknowledged edits before generation gnow that tree t does
 * not hold (colour behind, marker absent), but those counted before and
 * those whose record was flipped on purpose; each is counted once.
 * *checked adds the edits looked at. */
static long editor_missing(struct editor *ed, struct bc_tree *t, int gnow,
                           long *checked)
{
	struct bc_prim_data p = {0};
	bool colored = t && bc_tree_get(t, ed->prim, &p, NULL) && p.has_color;
	uint32_t kf = colored ? color_k(p.color) : 0, last = 0;
	long gone = 0;
	pthread_mutex_lock(&ed->lock);
	for (size_t i = 0; i < ed->nacks; i++) {
		struct ack *a = &ed->acks[i];
		bool lost;
		if (a->gen >= gnow || a->flipped) {
			continue;
		}
		(*checked)++;
		if (a->missed) {
			continue;
		}
		if (a->k & MARKER_BIT) {
			lost = !t ||
			       !bc_tree_get(t, a->k & ~MARKER_BIT, NULL, NULL);
		} else {
			lost = !colored || a->k > kf;
			last = a->k;
		}
		if (lost) {
			a->missed = true;
			gone++;
		}
	}
	pthread_mutex_unlock(&ed->lock);
	if (gone) {
		printf("editor %d (%s): %ld acknowledged edits missing (colour "
		       "k %u, last acknowledged %u)\n",
		       ed->index, busy_name[ed->session], gone, kf, last);
	}
	return gone;
}

/* Checks busy session s as a fresh joiner finds it against what its
 * editors had acknowledged before generation gnow: the order is not
 * below the largest acknowledged (else older_state), and every such edit
 * is there (editor_missing); new losses are counted under d. A session
 * that cannot be joined counts under unserved, and at the end (final)
 * all its edits count as lost. Returns the edits newly found lost. */
static long check_session(int s, enum damage d, int gnow, bool final,
                          long *checked)
{
	struct conn c;
	struct bc_tree *t = NULL;
	char why[WHY_LEN] = "";
	uint64_t order = 0, top = acked_top(s, gnow);
	long lost = 0;
	int rc = -1;
	if (conn_open(&c, &dmn) == 0) {
		rc = conn_hello(&c, "verify")
		         ? -1
		         : join(&c, busy_name[s], BC_PROTO_ROLE_VIEWER, why);
		if (rc == 0 &&
		    conn_expect(&c, BC_MSG_SCENE_STATE, 30000) == 1) {
			order = c.m.scene_state.order;
			t = scene_of(&c);
		}
		conn_close(&c);
	}
	if (!t) {
		printf(
		    "session %s: cannot be joined after the restart (%s)%s\n",
		    busy_name[s], why[0] ? why : "no answer",
		    final ? ": all its acknowledged edits count as lost" : "");
		dstats[d].unserved++;
		if (!final) {
			return 0;
		}
	} else if (order < top) {
		printf("session %s: served at order %llu, below the %llu it "
		       "acknowledged\n",
		       busy_name[s], (unsigned long long)order,
		       (unsigned long long)top);
		dstats[d].older_state++;
	}
	for (int e = 0; e < opt.editors; e++) {
		if (editors[e].session == s) {
			lost += editor_missing(&editors[e], t, gnow, checked);
		}
	}
	dstats[d].lost += lost;
	bc_tree_destroy(t);
	return lost;
}

/* Acknowledged edits absent from the sessions' scenes after the last
 * restart (those found lost earlier are not counted again). */
static long verify(long *checked)
{
	long lost = 0;
	int g = up_gen();
	*checked = 0;
	for (int s = 0; s < BUSY_SESSIONS; s++) {
		lost += check_session(s, DAMAGE_NONE, g, true, checked);
	}
	return lost;
}

/* Order numbers reused: per busy session, an acknowledged order at or
 * below one that an earlier daemon generation acknowledged, counted
 * under the case that generation started after. */
static long count_reused(void)
{
	static uint64_t below[MAX_GENS];
	long total = 0;
	for (int s = 0; s < BUSY_SESSIONS; s++) {
		uint64_t run = 0;
		memset(below, 0, sizeof(below));
		for (int e = 0; e < opt.editors; e++) {
			struct editor *ed = &editors[e];
			for (size_t i = 0; ed->session == s && i < ed->nacks;
			     i++) {
				int g = ed->acks[i].gen < MAX_GENS
				            ? ed->acks[i].gen
				            : MAX_GENS - 1;
				if (ed->acks[i].order > below[g]) {
					below[g] = ed->acks[i].order;
				}
			}
		}
		/* below[g]: the largest order of generations before g. */
		for (int g = 0; g < MAX_GENS; g++) {
			uint64_t top = below[g];
			below[g] = run;
			run = top > run ? top : run;
		}
		for (int e = 0; e < opt.editors; e++) {
			struct editor *ed = &editors[e];
			for (size_t i = 0; ed->session == s && i < ed->nacks;
			     i++) {
				const struct ack *a = &ed->acks[i];
				int g =
				    a->gen < MAX_GENS ? a->gen : MAX_GENS - 1;
				if (a->order > below[g]) {
					continue;
				}
				if (total++ < 10) {
					printf("session %s: order %llu "
					       "acknowledged again by start "
					       "%d (an earlier start had "
					       "reached %llu)\n",
					       busy_name[s],
					       (unsigned long long)a->order, g,
					       (unsigned long long)below[g]);
				}
				dstats[damage_of(g, s)].reused++;
			}
		}
	}
	return total;
}

/* ---- damaged files (--damage) ------------------------------------------- */

/* Case 2 never flips a journal twice (a second flip of the same bytes
 * would mend it), and case 1 never tears a snapshot whose older
 * generation needs a journal case 2 flipped: that would be damage the
 * rules do not promise to survive. */
#define MAX_FLIPPED 256
#define MAX_FILES 64
#define JOURNAL_MAGIC 0x314a4342u /* 'BCJ1', server/journal.c */
#define RECORD_HEADER 20u         /* magic, length, order, CRC32 */

static int next_case[BUSY_SESSIONS] = {DAMAGE_SNAP_TORN, DAMAGE_SNAP_TORN};
static uint64_t flipped_journal[BUSY_SESSIONS][MAX_FLIPPED];
static size_t nflipped_journal[BUSY_SESSIONS];
static bool ro_by_chattr;      /* else a read-only bind mount */
static long check_exits[2][3]; /* [repair][exit status 0, 1, other] */

static void session_dir(int s, char *buf, size_t n)
{
	snprintf(buf, n, "%s/sessions/%s", data_dir, busy_name[s]);
}

static int cmp_desc_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return x < y ? 1 : x > y ? -1 : 0;
}

/* The N of each PREFIX-N.SUFFIX in dir (exactly), newest first; returns
 * how many (at most max). */
static size_t list_numbered(const char *dir, const char *prefix,
                            const char *suffix, uint64_t *out, size_t max)
{
	DIR *d = opendir(dir);
	struct dirent *de;
	size_t n = 0, lp = strlen(prefix);
	if (!d) {
		return 0;
	}
	while ((de = readdir(d)) && n < max) {
		const char *p = de->d_name;
		char *end;
		if (strncmp(p, prefix, lp) != 0 || p[lp] < '0' || p[lp] > '9') {
			continue;
		}
		out[n] = strtoull(p + lp, &end, 10);
		n += !strcmp(end, suffix);
	}
	closedir(d);
	qsort(out, n, sizeof(*out), cmp_desc_u64);
	return n;
}

static bool was_flipped(int s, uint64_t journal)
{
	for (size_t i = 0; i < nflipped_journal[s]; i++) {
		if (flipped_journal[s][i] == journal) {
			return true;
		}
	}
	return false;
}

struct record {
	long off;
	uint32_t len;
	uint64_t order;
};

/* The whole records of journal file at the front of it, by their headers
 * (magic and length; the CRC32 is the daemon's to check): their count,
 * and record number want in *r. -1 when the file cannot be read. */
static long journal_records(const char *file, long want, struct record *r)
{
	FILE *f = fopen(file, "rb");
	uint8_t hdr[RECORD_HEADER];
	long n = 0, off = 0, size;
	if (!f || fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0) {
		if (f) {
			fclose(f);
		}
		return -1;
	}
	while (off + (long)RECORD_HEADER <= size &&
	       fseek(f, off, SEEK_SET) == 0 &&
	       fread(hdr, 1, sizeof(hdr), f) == sizeof(hdr) &&
	       bc_get_le32(hdr) == JOURNAL_MAGIC &&
	       (long)bc_get_le32(hdr + 4) <= size - off - (long)RECORD_HEADER) {
		if (n == want) {
			r->off = off;
			r->len = bc_get_le32(hdr + 4);
			r->order = bc_get_le64(hdr + 8);
		}
		off += (long)RECORD_HEADER + (long)bc_get_le32(hdr + 4);
		n++;
	}
	fclose(f);
	return n;
}

/* Flips (xor 0xff) up to 4 payload bytes in the middle of record r of
 * file: its CRC32 no longer matches. 0, or -1. */
static int flip_record(const char *file, const struct record *r)
{
	uint8_t b[4];
	size_t n = r->len < 4 ? r->len : 4;
	long at = r->off + (long)RECORD_HEADER + (long)(r->len - n) / 2;
	FILE *f = fopen(file, "r+b");
	int rc = -1;
	if (f && n > 0 && fseek(f, at, SEEK_SET) == 0 &&
	    fread(b, 1, n, f) == n) {
		for (size_t i = 0; i < n && i < sizeof(b); i++) {
			b[i] ^= 0xffu;
		}
		if (fseek(f, at, SEEK_SET) == 0 && fwrite(b, 1, n, f) == n &&
		    fflush(f) == 0 && fsync(fileno(f)) == 0) {
			rc = 0;
		}
	}
	if (f && fclose(f) != 0) {
		rc = -1;
	}
	return rc;
}

/* Case 1: the newest snapshot cut to half, when the previous generation
 * (an older snapshot and its journal, not flipped) is there. 0 applied,
 * 1 not applicable, -1 failed. */
static int tear_newest_snapshot(int s, const char *dir, char *what, size_t n)
{
	uint64_t snaps[MAX_FILES];
	char file[256];
	struct stat st;
	size_t ns = list_numbered(dir, "snap-", ".bin", snaps, MAX_FILES);
	if (ns < 2 || was_flipped(s, snaps[1])) {
		return 1;
	}
	snprintf(file, sizeof(file), "%s/journal-%llu.bin", dir,
	         (unsigned long long)snaps[1]);
	if (stat(file, &st) != 0) {
		printf("  note: %s has snap-%llu.bin but not its journal\n",
		       busy_name[s], (unsigned long long)snaps[1]);
		return 1;
	}
	snprintf(file, sizeof(file), "%s/snap-%llu.bin", dir,
	         (unsigned long long)snaps[0]);
	if (stat(file, &st) != 0 || truncate(file, st.st_size / 2) != 0) {
		return -1;
	}
	snprintf(what, n,
	         "snap-%llu.bin cut from %lld to %lld bytes "
	         "(snap-%llu.bin is there)",
	         (unsigned long long)snaps[0], (long long)st.st_size,
	         (long long)(st.st_size / 2), (unsigned long long)snaps[1]);
	return 0;
}

/* Flips the middle record of journal-J.bin of s, which must hold at
 * least min records; *r is that record. 0, 1 (too few), -1. */
static int flip_middle(const char *dir, uint64_t j, long min, struct record *r,
                       char *what, size_t n)
{
	char file[256];
	long nrec;
	snprintf(file, sizeof(file), "%s/journal-%llu.bin", dir,
	         (unsigned long long)j);
	nrec = journal_records(file, -1, r);
	if (nrec < min) {
		return nrec < 0 ? -1 : 1;
	}
	if (journal_records(file, (nrec - 1) / 2, r) != nrec ||
	    flip_record(file, r) != 0) {
		return -1;
	}
	snprintf(what, n,
	         "journal-%llu.bin: record %ld of %ld (edit %llu, bytes "
	         "%ld..%ld) flipped",
	         (unsigned long long)j, (nrec - 1) / 2 + 1, nrec,
	         (unsigned long long)r->order, r->off,
	         r->off + (long)RECORD_HEADER + (long)r->len);
	return 0;
}

/* Case 2: a record flipped in the newest journal older than the newest
 * snapshot (which covers it). */
static int flip_covered_journal(int s, const char *dir, char *what, size_t n)
{
	uint64_t snaps[MAX_FILES], journals[MAX_FILES];
	struct record r;
	size_t ns = list_numbered(dir, "snap-", ".bin", snaps, MAX_FILES);
	size_t nj = list_numbered(dir, "journal-", ".bin", journals, MAX_FILES);
	int rc;
	for (size_t i = 0; ns > 0 && i < nj; i++) {
		if (journals[i] >= snaps[0]) {
			continue;
		}
		if (was_flipped(s, journals[i]) ||
		    nflipped_journal[s] == MAX_FLIPPED) {
			return 1;
		}
		if ((rc = flip_middle(dir, journals[i], 1, &r, what, n)) == 0) {
			flipped_journal[s][nflipped_journal[s]++] = journals[i];
		}
		return rc;
	}
	return 1;
}

/* Case 4: a record flipped in the middle of the newest journal, with a
 * whole record after it (else it would read as a torn tail); *order is
 * the edit it held. */
static int flip_live_journal(const char *dir, uint64_t *order, char *what,
                             size_t n)
{
	uint64_t snaps[MAX_FILES], journals[MAX_FILES];
	struct record r;
	size_t ns = list_numbered(dir, "snap-", ".bin", snaps, MAX_FILES);
	size_t nj = list_numbered(dir, "journal-", ".bin", journals, MAX_FILES);
	int rc;
	if (nj == 0 || (ns > 0 && journals[0] < snaps[0])) {
		return 1;
	}
	if ((rc = flip_middle(dir, journals[0], 2, &r, what, n)) == 0) {
		*order = r.order;
	}
	return rc;
}

/* Case 3: dir read-only, by a read-only bind mount (then even its
 * existing files refuse writes), else chattr +i (on this ext4 as root;
 * chmod does not stop root). 0, or -1. */
static int make_read_only(const char *dir, char *what, size_t n)
{
	char cmd[1024];
	snprintf(cmd, sizeof(cmd),
	         "mount --bind '%s' '%s' 2>/dev/null && "
	         "mount -o remount,ro,bind '%s' '%s' 2>/dev/null",
	         dir, dir, dir, dir);
	ro_by_chattr = false;
	if (system(cmd) == 0) {
		snprintf(what, n,
		         "read-only bind mount of the session "
		         "directory");
		return 0;
	}
	snprintf(cmd, sizeof(cmd), "umount '%s' 2>/dev/null", dir);
	if (system(cmd) != 0) {
		/* Not mounted: nothing to undo. */
	}
	snprintf(cmd, sizeof(cmd), "chattr +i '%s' 2>/dev/null", dir);
	if (system(cmd) != 0) {
		return -1;
	}
	ro_by_chattr = true;
	snprintf(what, n, "chattr +i on the session directory");
	return 0;
}

static int make_writable(const char *dir)
{
	char cmd[512];
	snprintf(cmd, sizeof(cmd),
	         ro_by_chattr ? "chattr -i '%s'" : "umount '%s'", dir);
	return system(cmd) == 0 ? 0 : -1;
}

/* Applies the next case of busy session s that can apply (its rotation
 * goes on from the one after it); *what says what was done. Case 4 sets
 * *order to the edit of the flipped record. Returns the case, or
 * DAMAGE_NONE when none applied. */
static enum damage damage_session(int s, char *what, size_t n, uint64_t *order)
{
	char dir[192];
	session_dir(s, dir, sizeof(dir));
	for (int i = 0; i < DAMAGE_COUNT - 1; i++) {
		enum damage d = (enum damage)(1 + (next_case[s] - 1 + i) %
		                                      (DAMAGE_COUNT - 1));
		int rc = d == DAMAGE_SNAP_TORN
		             ? tear_newest_snapshot(s, dir, what, n)
		         : d == DAMAGE_OLD_JOURNAL
		             ? flip_covered_journal(s, dir, what, n)
		         : d == DAMAGE_READ_ONLY
		             ? make_read_only(dir, what, n)
		             : flip_live_journal(dir, order, what, n);
		if (rc == 0) {
			next_case[s] = (int)d % (DAMAGE_COUNT - 1) + 1;
			dstats[d].applied++;
			return d;
		}
		if (rc < 0) {
			printf("  case %s could not be applied to %s: %s\n",
			       damage_label[d], busy_name[s], strerror(errno));
		}
		dstats[d].skipped++;
	}
	return DAMAGE_NONE;
}

/* Marks the acknowledged edit of order in busy session s as flipped on
 * purpose (case 4): lost by nature, counted apart. */
static void mark_flipped(int s, uint64_t order)
{
	for (int e = 0; e < opt.editors; e++) {
		struct editor *ed = &editors[e];
		if (ed->session != s) {
			continue;
		}
		pthread_mutex_lock(&ed->lock);
		for (size_t i = ed->nacks; i-- > 0;) {
			if (ed->acks[i].order == order &&
			    !ed->acks[i].flipped) {
				ed->acks[i].flipped = true;
				dstats[DAMAGE_LIVE_JOURNAL].lost_flipped++;
				printf("  edit %llu was acknowledged to editor "
				       "%d (%s k %u): lost by nature\n",
				       (unsigned long long)order, e,
				       ed->acks[i].k & MARKER_BIT ? "marker"
				                                  : "colour",
				       ed->acks[i].k & ~MARKER_BIT);
				i = 0;
			}
		}
		pthread_mutex_unlock(&ed->lock);
	}
}

/* A viewer's JOIN of busy session s now: 0 served (its order in *order),
 * > 0 the ERROR's code (text in why), -1 no answer. */
static int probe(int s, uint64_t *order, char why[WHY_LEN])
{
	struct conn c;
	int rc = -1;
	*order = 0;
	why[0] = 0;
	if (conn_open(&c, &dmn) != 0) {
		return -1;
	}
	if (!conn_hello(&c, "probe")) {
		rc = join(&c, busy_name[s], BC_PROTO_ROLE_VIEWER, why);
	}
	if (rc == 0) {
		rc = conn_expect(&c, BC_MSG_SCENE_STATE, 30000) == 1 ? 0 : -1;
		*order = c.m.scene_state.order;
	}
	conn_close(&c);
	return rc;
}

/* Runs `blobcastd --check DATA [--repair]` (the daemon stopped), prints
 * its lines and says whether one names busy session s NOT WHOLE. Returns
 * its exit status (-1 when it did not run). */
static int run_check(int s, bool repair, bool *named)
{
	char cmd[512], line[1024], want[64];
	FILE *p;
	int status;
	snprintf(cmd, sizeof(cmd), "'%s' --check '%s'%s", daemon_path, data_dir,
	         repair ? " --repair" : "");
	snprintf(want, sizeof(want), "%s: NOT WHOLE", busy_name[s]);
	*named = false;
	if (!(p = popen(cmd, "r"))) {
		return -1;
	}
	while (fgets(line, sizeof(line), p)) {
		printf("  %s: %s", repair ? "--check --repair" : "--check",
		       line);
		*named = *named || !strncmp(line, want, strlen(want));
	}
	status = pclose(p);
	status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
	check_exits[repair][status == 0 ? 0 : status == 1 ? 1 : 2]++;
	return status;
}

/* Case 3's and 4's time with the damage in place: the restarted daemon
 * runs 3 s while the clients try the session; a probe JOIN sees what
 * they see. Case 4 must be refused with EIO naming `blobcastd --check`;
 * case 3 refused, or served at an order not below the acknowledged. */
static void damaged_window(int s, enum damage d)
{
	uint64_t order, top = acked_top(s, up_gen());
	char why[WHY_LEN];
	int rc = probe(s, &order, why);
	if (rc == -BC_EIO) {
		printf("  JOIN %s: refused, EIO: %s\n", busy_name[s], why);
		if (d == DAMAGE_LIVE_JOURNAL &&
		    !strstr(why, "blobcastd --check")) {
			printf(
			    "  the refusal does not name blobcastd --check\n");
			dstats[d].check_failed++;
		}
	} else if (rc == 0) {
		printf("  JOIN %s: served at order %llu (largest acknowledged "
		       "%llu)\n",
		       busy_name[s], (unsigned long long)order,
		       (unsigned long long)top);
		if (order < top) {
			dstats[d].older_state++;
		}
		if (d == DAMAGE_LIVE_JOURNAL) {
			dstats[d].check_failed++;
		}
	} else {
		printf("  JOIN %s: %s %d (%s)\n", busy_name[s],
		       rc > 0 ? "refused with code" : "no answer", rc, why);
		if (d == DAMAGE_LIVE_JOURNAL) {
			dstats[d].check_failed++;
		}
	}
	sleep_sampling(3000);
}

/* After SIGKILL number nth with --damage: damages one busy session (they
 * take turns), restarts the daemon, and for cases 3 and 4 keeps it up 3 s
 * with the damage, kills it again (*kills counts it), undoes what case 3
 * did or runs --check and --check --repair for case 4, and restarts it;
 * then checks both busy sessions. 0, or -1 when the daemon did not
 * start. */
static int damage_cycle(int nth, int *kills, int64_t t0)
{
	int s = nth % BUSY_SESSIONS, rc, g;
	char what[512] = "", dir[192];
	uint64_t order = 0;
	enum damage d = damage_session(s, what, sizeof(what), &order);
	session_dir(s, dir, sizeof(dir));
	printf("t=%llds kill %d: %s: %s%s%s\n",
	       (long long)((t_now_ms() - t0) / 1000), *kills, busy_name[s],
	       d ? damage_label[d] : "no case applies", d ? ": " : "", what);
	if (d == DAMAGE_LIVE_JOURNAL) {
		mark_flipped(s, order);
	}
	pending_damage = d;
	pending_session = s;
	rc = start_daemon();
	if (rc == 0 && (d == DAMAGE_READ_ONLY || d == DAMAGE_LIVE_JOURNAL)) {
		damaged_window(s, d);
		kill_daemon();
		(*kills)++;
	}
	if (d == DAMAGE_READ_ONLY && make_writable(dir) != 0) {
		printf("  cannot make %s writable again\n", dir);
		rc = -1;
	}
	if (rc == 0 && d == DAMAGE_LIVE_JOURNAL) {
		bool named, unused;
		int st = run_check(s, false, &named);
		int sr = run_check(s, true, &unused);
		if (st != 1 || !named || sr != 0) {
			printf(
			    "  --check exited %d (%s), --repair %d: expected "
			    "1 naming it, then 0\n",
			    st, named ? "naming it" : "not naming it", sr);
			dstats[d].check_failed++;
		}
	}
	if (rc == 0 && (d == DAMAGE_READ_ONLY || d == DAMAGE_LIVE_JOURNAL)) {
		rc = start_daemon();
	}
	pending_damage = DAMAGE_NONE;
	pending_session = -1;
	if (rc != 0) {
		return -1;
	}
	g = up_gen();
	for (int i = 0; i < BUSY_SESSIONS; i++) {
		long checked = 0;
		if (i == s && d == DAMAGE_LIVE_JOURNAL) {
			uint64_t o;
			char why[WHY_LEN];
			int pr = probe(s, &o, why);
			printf("  after --repair: %s %s order %llu, largest "
			       "acknowledged %llu\n",
			       busy_name[s],
			       pr == 0 ? "served at" : "NOT served,",
			       (unsigned long long)o,
			       (unsigned long long)acked_top(s, g));
		}
		check_session(i, damage_of(g, i), g, false, &checked);
	}
	return 0;
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
	    "                    load (default %d)\n"
	    "  --damage          at each kill, damage one busy session's\n"
	    "                    files, rotating through: 1 newest snapshot\n"
	    "                    torn (when an older one is there), 2 a\n"
	    "                    record flipped in a journal a newer\n"
	    "                    snapshot covers, 3 the session directory\n"
	    "                    read-only for a 3 s restart, 4 a record\n"
	    "                    flipped in the live journal (that edit is\n"
	    "                    lost: the session must be refused, named\n"
	    "                    by blobcastd --check and repaired by\n"
	    "                    --repair without reusing an order);\n"
	    "                    exit status 1 also when cases 1-3 lose an\n"
	    "                    acknowledged edit or an order is reused\n"
	    "                    (needs root: mount, chattr)\n",
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
		if (!strcmp(a, "--damage")) {
			opt.damage = true;
			continue;
		}
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
	int nworkers = 0, kills = 0, crashes = 0, cycles = 0;
	long lost, checked, reused, flipped, bad = 0;
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
	if (!(tcp_port = daemon_free_port())) {
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
	if (opt.damage) {
		printf("damage: at each kill, one busy session's files, cases "
		       "1-4 in rotation\n");
	}
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
		pthread_mutex_init(&editors[e].lock, NULL);
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
			bool killed = dmn.pid > 0;
			int rc;
			if (killed) {
				kill_daemon();
				kills++;
			}
			rc = opt.damage && killed
			         ? damage_cycle(cycles++, &kills, t0)
			         : start_daemon();
			if (rc != 0) {
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
	verify(&checked);
	reused = count_reused();
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
	lost = 0;
	for (int d = 0; d < DAMAGE_COUNT; d++) {
		lost += dstats[d].lost;
		bad += dstats[d].older_state + dstats[d].unserved +
		       dstats[d].check_failed;
	}
	flipped = dstats[DAMAGE_LIVE_JOURNAL].lost_flipped;
	if (opt.damage) {
		printf("damage cycles: %d (kills incl. those of cases 3 and 4 "
		       "and the last: %d)\n",
		       cycles, kills);
		printf("  %-26s %7s %7s %5s %7s %6s %6s %6s %6s %5s %5s %5s\n",
		       "case", "applied", "skipped", "lost", "flipped",
		       "reused", "joinEIO", "naming", "editEIO", "older",
		       "unsrv", "chk!");
		for (int d = 0; d < DAMAGE_COUNT; d++) {
			const struct damage_stats *x = &dstats[d];
			printf("  %-26s %7ld %7ld %5ld %7ld %6ld %6ld %6ld "
			       "%6ld %5ld %5ld %5ld\n",
			       damage_label[d], x->applied, x->skipped, x->lost,
			       x->lost_flipped, x->reused,
			       atomic_load(&x->joins_refused),
			       atomic_load(&x->joins_refused_named),
			       atomic_load(&x->edits_refused), x->older_state,
			       x->unserved, x->check_failed);
		}
		printf("blobcastd --check exits: %ld x 0, %ld x 1, %ld other; "
		       "--check --repair: %ld x 0, %ld x 1, %ld other\n",
		       check_exits[0][0], check_exits[0][1], check_exits[0][2],
		       check_exits[1][0], check_exits[1][1], check_exits[1][2]);
		printf("case 3 made the directory read-only by %s\n",
		       ro_by_chattr ? "chattr +i" : "a read-only bind mount");
	}
	printf("acknowledged edits checked: %ld\n", checked);
	printf("acknowledged edits lost: %ld\n", lost);
	if (opt.damage) {
		printf("acknowledged edits lost to unrepairable damage, named "
		       "by --check: %ld\n",
		       flipped);
	}
	printf("order numbers reused: %ld\n", reused);
	bad += lost + reused;

	daemon_stop(&dmn, SIGTERM);
	for (int e = 0; e < opt.editors; e++) {
		bc_free(editors[e].acks);
		pthread_mutex_destroy(&editors[e].lock);
	}
	bc_free(alone.v);
	bc_free(alone_after.v);
	bc_free(calm_load.v);
	bc_free(calm_back.v);
	if (bad == 0) {
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock %s.log", data_dir,
		         data_dir, data_dir);
		if (system(cmd) != 0) {
			return 1;
		}
	} else {
		printf("data directory and log kept: %s, %s.log\n", data_dir,
		       data_dir);
	}
	return bad == 0 ? 0 : 1;
}
