/*
 * A live fuzzer of blobcastd: it starts the daemon on a data directory and
 * attacks it over its TCP socket from several concurrent connections. Each
 * connection is a loop: HELLO (usually valid, sometimes mutated or
 * replaced), CREATE or JOIN of one of a few sessions, then a random mix of
 *
 *  (a) valid messages of every type a client may send (PROTOCOL.md 5):
 *      EDITs with operations of every kind on ids that exist and ids that
 *      do not, SET fields of every number, CAMERA, VIEW, PICK, SNAPSHOT at
 *      small sizes, SCENE_LOAD of small random scenes, UNDO, REDO,
 *      PRESENT, FOLLOW, SESSION_CAMERA, SESSION_LIST, GET_STATS, PING,
 *      PONG, ERROR, LEAVE, SESSION_DELETE of throwaway sessions, and the
 *      ones the stage forbids (a second HELLO, JOIN inside a session);
 *  (b) the same messages mutated: bit flips, truncation, extension,
 *      length fields that lie, wrong types, flags, smashed counts,
 *      integers and floats, spliced bytes;
 *  (c) random bytes, bare or behind a well-formed header;
 *  (d) the messages and scenes of protocol/vectors/ replayed, as they
 *      are or mutated;
 *
 * reading everything the daemon sends (non-blocking, through the client
 * decoder, so a daemon message that does not decode is caught too) and
 * reconnecting when the daemon closes. A PING every few messages, with at
 * most two unanswered, keeps either side's socket from backing up and
 * shows when the daemon stops answering. A separate quiet client PINGs
 * the daemon every 10 s throughout.
 *
 * At the end the daemon must be alive and serve a fresh client; every
 * session's SCENE_STATE (order and scene bytes) is recorded, the daemon is
 * stopped with SIGTERM and restarted on the same data directory, and every
 * session must come back identical; then a short second round of fuzzing,
 * a record, SIGKILL, a restart and the same comparison (what was
 * acknowledged must survive kill -9). Every log of the daemon is searched
 * for sanitizer reports.
 *
 * Each connection draws from its own PRNG, seeded from --seed and its
 * index, so a run's choices repeat with the same seed; what the daemon
 * answers, and when, feeds back into them (ids learnt from SCENE_STATE,
 * closed links), so the interleaving of a run is not reproduced exactly.
 * Usage: fuzz_live PATH/TO/blobcastd [options]; --help lists them.
 */
#include <arpa/inet.h>
#include <dirent.h>
#include <math.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <stdatomic.h>

/* scene.h first: daemon.h then offers scene_of(). */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "../tests/server/daemon.h"

#ifndef BC_FUZZ_VECTORS_DIR
#define BC_FUZZ_VECTORS_DIR "protocol/vectors"
#endif

#define MAX_CONNS 64
/* Node ids a connection remembers (from SCENE_STATE and its own edits). */
#define MAX_KNOWN 512
/* Daemon starts in one run: the first, three planned restarts, and
 * restarts after deaths. */
#define MAX_STARTS 32
/* The shared sessions fz0 .. fz3, and throwaway ones per connection. */
#define NSESSIONS 4
#define TMP_PER_CONN 2
/* Flow-control PINGs a connection may have unanswered. */
#define WINDOW_PINGS 2
/* A PING unanswered this long on a connection that sent only valid
 * messages since the one before is a stall (reported). Answers come in
 * order, so it waits for up to eight small snapshots on a busy daemon. */
#define STALL_MS 30000
/* After a message that may have desynchronised the stream, the
 * connection waits this long for its PING, then gives up. */
#define RISKY_MS 2000
/* The quiet client's PING, a stage with no renders ahead of it. */
#define MONITOR_MS 30000
#define MAX_OPS 64
#define NELEM(a) ((uint32_t)(sizeof(a) / sizeof((a)[0])))

/* ---- options ------------------------------------------------------------- */

struct opts {
	double duration_s;
	int conns;
	uint64_t seed;
	bool seed_given;
	const char *data;
	const char *vectors;
	bool early_reset;
};

static struct opts opt = {
    .duration_s = 60, .conns = 8, .vectors = BC_FUZZ_VECTORS_DIR};

/* ---- PRNG (splitmix64) ---------------------------------------------------- */

static uint64_t next_u64(uint64_t *s)
{
	uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

/* Uniform in [0, n). */
static uint32_t rnd(uint64_t *s, uint32_t n)
{
	return n ? (uint32_t)(next_u64(s) % n) : 0;
}

static float rndf(uint64_t *s, float lo, float hi)
{
	return lo + (hi - lo) * (float)(next_u64(s) >> 40) / 16777216.0f;
}

/* True with probability per_mille / 1000. */
static bool pm(uint64_t *s, uint32_t per_mille)
{
	return rnd(s, 1000) < per_mille;
}

static void put_le(uint8_t *p, uint64_t v, int n)
{
	for (int i = 0; i < n; i++) {
		p[i] = (uint8_t)(v >> (8 * i));
	}
}

static uint32_t get_le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	       (uint32_t)p[3] << 24;
}

/* ---- counters -------------------------------------------------------------- */

enum cls {
	CLS_VALID,
	CLS_MUTATED,
	CLS_RANDOM,
	CLS_VECTOR,
	CLS_VECTOR_MUT,
	CLS_COUNT
};
static const char *const cls_name[CLS_COUNT] = {"valid", "mutated", "random",
                                                "vector", "vector mutated"};

static atomic_long n_sent[CLS_COUNT], n_bytes, n_connects, n_connect_failed;
/* Valid and mutated messages by the type they were built as. */
static atomic_long n_type_valid[BC_MSG_COUNT], n_type_mutated[BC_MSG_COUNT];
static atomic_long n_answers[BC_MSG_COUNT], n_errors[BC_ERR_COUNT + 1];
static atomic_long n_fatal, n_closed, n_closed_silent, n_bad_answers;
static atomic_long n_stalls, n_given_up, n_encode_refused, n_filler;
static atomic_long n_early_resets;
static atomic_long n_monitor_pings, n_monitor_fail, monitor_max_ms;
static atomic_bool stopping;

/* ---- protocol vectors ------------------------------------------------------ */

struct vec {
	uint8_t *bytes;
	size_t len;
};

/* Messages (or streams) of every file but scene.json, those of a client
 * type apart; scene encodings of scene.json. */
static struct vec *vecs, *scenes;
static size_t nvecs, nscenes;
static size_t *client_vecs, nclient_vecs;

static int hexval(char c)
{
	if (c >= '0' && c <= '9') {
		return c - '0';
	}
	if (c >= 'a' && c <= 'f') {
		return c - 'a' + 10;
	}
	if (c >= 'A' && c <= 'F') {
		return c - 'A' + 10;
	}
	return -1;
}

static int vec_push(struct vec **v, size_t *n, const char *hex, size_t digits)
{
	struct vec *p = bc_realloc(*v, (*n + 1) * sizeof(**v));
	uint8_t *b = bc_malloc(digits / 2);
	if (!p || !b) {
		if (p) {
			*v = p;
		}
		bc_free(b);
		return -1;
	}
	*v = p;
	for (size_t i = 0; i < digits / 2; i++) {
		b[i] =
		    (uint8_t)(hexval(hex[2 * i]) << 4 | hexval(hex[2 * i + 1]));
	}
	p[*n] = (struct vec){.bytes = b, .len = digits / 2};
	(*n)++;
	return 0;
}

/* Every "hex" string of one vector file. */
static int load_vector_file(const char *path, bool scene)
{
	FILE *f = fopen(path, "rb");
	char *text = NULL;
	long size;
	int rc = -1;
	if (!f) {
		return -1;
	}
	if (fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 ||
	    fseek(f, 0, SEEK_SET) != 0 ||
	    !(text = bc_malloc((size_t)size + 1)) ||
	    fread(text, 1, (size_t)size, f) != (size_t)size) {
		goto out;
	}
	text[size] = 0;
	for (const char *p = text; (p = strstr(p, "\"hex\""));) {
		const char *q;
		p += 5;
		while (*p == ' ' || *p == ':' || *p == '\n') {
			p++;
		}
		if (*p != '"') {
			continue;
		}
		for (q = ++p; hexval(*q) >= 0; q++) {
		}
		if (*q == '"' && q > p && (q - p) % 2 == 0 &&
		    vec_push(scene ? &scenes : &vecs, scene ? &nscenes : &nvecs,
		             p, (size_t)(q - p)) != 0) {
			goto out;
		}
		p = q;
	}
	rc = 0;
out:
	bc_free(text);
	fclose(f);
	return rc;
}

static int cmp_str(const void *a, const void *b)
{
	return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Loads dir/ *.json in name order (so a seed picks the same vectors on any
 * file system). Returns the number of files read, -1 on an error. */
static int load_vectors(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	char *names[128];
	int n = 0, rc = 0;
	if (!d) {
		return -1;
	}
	while ((e = readdir(d)) && n < 128) {
		size_t len = strlen(e->d_name);
		if (len > 5 && !strcmp(e->d_name + len - 5, ".json") &&
		    (names[n] = bc_malloc(len + 1))) {
			memcpy(names[n++], e->d_name, len + 1);
		}
	}
	closedir(d);
	qsort(names, (size_t)n, sizeof(char *), cmp_str);
	for (int i = 0; i < n; i++) {
		char path[4096];
		snprintf(path, sizeof(path), "%s/%s", dir, names[i]);
		if (rc == 0 &&
		    load_vector_file(path, !strcmp(names[i], "scene.json"))) {
			rc = -1;
		}
		bc_free(names[i]);
	}
	client_vecs = bc_calloc(nvecs ? nvecs : 1, sizeof(size_t));
	for (size_t i = 0; client_vecs && i < nvecs; i++) {
		if (vecs[i].len > 5 &&
		    bc_proto_client_may_send(
		        BC_PROTO_STAGE_SESSION, BC_PROTO_ROLE_EDITOR,
		        (enum bc_msg_type)vecs[i].bytes[5]) != BC_EPROTO_TYPE) {
			client_vecs[nclient_vecs++] = i;
		}
	}
	return rc ? -1 : n;
}

/* ---- the daemon under test --------------------------------------------------- */

static struct daemon dmn;
static char data_dir[85];
static char listen_arg[32];
static int tcp_port;
static char log_paths[MAX_STARTS][112];
static int nstarts, deaths;

static int start_daemon(void)
{
	const char *extra[] = {"--listen", listen_arg, "--log", "warn", NULL};
	if (nstarts >= MAX_STARTS) {
		return -1;
	}
	snprintf(log_paths[nstarts], sizeof(log_paths[0]), "%s.log.%d",
	         data_dir, nstarts);
	daemon_log_path = log_paths[nstarts++];
	if (daemon_start_with(&dmn, data_dir, extra) != 0) {
		if (dmn.pid > 0) {
			daemon_stop(&dmn, SIGKILL);
		}
		return -1;
	}
	return 0;
}

static int tcp_connect(void)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	int fd = socket(AF_INET, SOCK_STREAM, 0), one = 1;
	if (fd < 0) {
		return -1;
	}
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	sa.sin_port = htons((uint16_t)tcp_port);
	if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) != 0) {
		close(fd);
		return -1;
	}
	setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	return fd;
}

/* daemon.h's struct conn over TCP; its helpers then work unchanged. */
static int conn_open_tcp(struct conn *c)
{
	memset(c, 0, sizeof(*c));
	if ((c->fd = tcp_connect()) < 0) {
		return -1;
	}
	bc_proto_reader_init(&c->r, &(struct bc_proto_reader_opts){
	                                .side = BC_PROTO_SIDE_CLIENT});
	return 0;
}

/* Sanitizer reports in a log of the daemon (the first few printed). */
static long log_reports(const char *path)
{
	FILE *f = fopen(path, "r");
	char line[2048];
	long n = 0;
	if (!f) {
		return 0;
	}
	while (fgets(line, sizeof(line), f)) {
		if (strstr(line, "ERROR: AddressSanitizer") ||
		    strstr(line, "ERROR: LeakSanitizer") ||
		    strstr(line, "runtime error:")) {
			if (++n <= 5) {
				printf("  %s: %s", path, line);
			}
		}
	}
	fclose(f);
	return n;
}

/* ---- one fuzzing connection -------------------------------------------------- */

enum { K_PRIM = 1, K_OP, K_UNARY };

struct known {
	uint32_t id;
	uint8_t what;
};

struct fz {
	int index;
	uint64_t rng;
	pthread_t th;
	int fd;
	struct bc_proto_reader r;
	struct bc_proto_parts parts; /* a SCENE_STATE in parts (7.10.1) */
	struct bc_msg m;
	uint32_t seq;
	bool in_session, closed, fatal;
	/* The daemon has sent something or closed: it accepted the link. */
	bool heard;
	/* Something that may desynchronise the stream was sent when the
	 * last seq was risky_seq: a PING after it must come back before the
	 * connection counts as clean again. */
	bool risky;
	uint32_t risky_seq;
	uint32_t ping_seq[WINDOW_PINGS];
	int64_t ping_at[WINDOW_PINGS];
	int pings_out;
	/* The last valid CREATE or JOIN: the stage is taken as SESSION
	 * from when it is sent until its ERROR, if one comes. */
	uint32_t enter_seq;
	uint16_t view_w, view_h;
	uint8_t encodings;
	/* Per mille of this connection's messages that are not valid. */
	uint32_t risk;
	struct known ids[MAX_KNOWN];
	uint32_t nids;
	uint32_t next_id;
	unsigned tmp_next;
	struct bc_proto_buf b, sub;
	uint8_t *mb;
	size_t mcap;
	uint8_t in[65536];
};

static const uint8_t client_types[] = {1,  3,  4,  5,  7,  8,  9,
                                       11, 13, 15, 16, 18, 20, 21,
                                       23, 24, 25, 26, 28, 29, 32};

static void fz_pump(struct fz *f);

static void add_known(struct fz *f, uint32_t id, uint8_t what)
{
	if (id == 0) {
		return;
	}
	if (f->nids < MAX_KNOWN) {
		f->ids[f->nids++] = (struct known){id, what};
	} else {
		f->ids[rnd(&f->rng, MAX_KNOWN)] = (struct known){id, what};
	}
}

/* An id of the session's scene as last seen (preferring kind what, when
 * not 0), now and then one that is most likely not in it. */
static uint32_t pick_id(struct fz *f, uint8_t what)
{
	if (f->nids == 0 || pm(&f->rng, 50)) {
		return 1 + rnd(&f->rng, 0xfffffffeu);
	}
	for (int tries = 0; what && tries < 8; tries++) {
		const struct known *k = &f->ids[rnd(&f->rng, f->nids)];
		if (k->what == what) {
			return k->id;
		}
	}
	return f->ids[rnd(&f->rng, f->nids)].id;
}

/* A fresh id: the connection's index in the top byte keeps connections
 * apart. */
static uint32_t fresh_id(struct fz *f)
{
	f->next_id = (f->next_id + 1) & 0xffffffu;
	if (f->next_id == 0) {
		f->next_id = 1;
	}
	return ((uint32_t)(f->index + 1) << 24) | f->next_id;
}

/* Adds the nodes of scene bytes to what f knows (forgetting the rest
 * first when replace). Returns 0 or the decoder's code. */
static int learn_scene(struct fz *f, const struct bc_proto_bytes *s,
                       bool replace)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_scene_walk w = {0};
	struct bc_scene_node nd;
	int rc;
	if (!t) {
		return BC_ENOMEM;
	}
	rc = bc_scene_decode(s->ptr, s->len, t, NULL, NULL, NULL);
	if (rc == 0 && (rc = bc_scene_walk_init(&w, t)) == 0) {
		if (replace) {
			f->nids = 0;
		}
		while (bc_scene_walk_next(&w, &nd)) {
			add_known(f, nd.id,
			          !nd.is_op                    ? K_PRIM
			          : bc_op_is_unary(nd.op.kind) ? K_UNARY
			                                       : K_OP);
		}
	}
	bc_scene_walk_finish(&w);
	bc_tree_destroy(t);
	return rc;
}

static void forget(struct fz *f, uint32_t id)
{
	for (uint32_t i = 0; i < f->nids; i++) {
		if (f->ids[i].id == id) {
			f->ids[i] = f->ids[--f->nids];
			return;
		}
	}
}

/* What an EDIT_APPLIED (anyone's) changed in the ids f knows: removed
 * and replaced nodes go, the nodes of new subtrees come. */
static void learn_edit(struct fz *f)
{
	const struct bc_msg_edit_applied *e = &f->m.edit_applied;
	for (uint16_t i = 0; i < e->nops; i++) {
		const struct bc_proto_edit_op *op = &e->ops[i];
		if (op->kind == BC_PROTO_EDIT_REMOVE ||
		    op->kind == BC_PROTO_EDIT_REPLACE) {
			forget(f, op->node);
		}
		if (op->subtree.len) {
			learn_scene(f, &op->subtree, false);
		}
	}
}

static void fz_handle(struct fz *f)
{
	const struct bc_msg *m = &f->m;
	atomic_fetch_add(&n_answers[m->type], 1);
	switch (m->type) {
	case BC_MSG_ERROR:
		atomic_fetch_add(
		    &n_errors[m->error.code < BC_ERR_COUNT ? m->error.code
		                                           : BC_ERR_COUNT],
		    1);
		if (m->flags & BC_PROTO_FLAG_FATAL) {
			atomic_fetch_add(&n_fatal, 1);
			f->fatal = true;
		}
		if ((m->error.code == -BC_ENOSESSION && m->seq == 0) ||
		    (f->enter_seq && m->seq == f->enter_seq)) {
			f->in_session = false;
		}
		break;
	case BC_MSG_SESSION_INFO:
		f->in_session = true;
		break;
	case BC_MSG_SCENE_STATE: {
		/* A scene the daemon sends that blobtree refuses is a
		 * daemon bug, counted with undecodable messages. */
		int rc = learn_scene(f, &m->scene_state.scene, true);
		if (rc != 0 && rc != BC_ENOMEM &&
		    atomic_fetch_add(&n_bad_answers, 1) < 10) {
			printf("conn %d: SCENE_STATE order %llu of %u bytes "
			       "does not decode: %s\n",
			       f->index,
			       (unsigned long long)m->scene_state.order,
			       m->scene_state.scene.len, bc_err_name(rc));
		}
		break;
	}
	case BC_MSG_EDIT_APPLIED:
		learn_edit(f);
		break;
	case BC_MSG_PONG:
		if (f->pings_out > 0 && m->seq == f->ping_seq[0] &&
		    (m->ping.stamp >> 32) == (uint64_t)f->index + 1) {
			if (f->risky && m->seq > f->risky_seq) {
				f->risky = false;
			}
			for (int i = 1; i < f->pings_out; i++) {
				f->ping_seq[i - 1] = f->ping_seq[i];
				f->ping_at[i - 1] = f->ping_at[i];
			}
			f->pings_out--;
		}
		break;
	default:
		break;
	}
}

/* A message from the daemon that the client decoder refuses. */
static void fz_bad(struct fz *f)
{
	if (atomic_fetch_add(&n_bad_answers, 1) < 10) {
		printf("conn %d: the daemon sent bytes the client decoder "
		       "refuses: %s (%s)\n",
		       f->index, bc_err_name(f->r.err), f->r.errstr);
	}
	f->closed = true;
}

/* Reads whatever has arrived, without waiting. */
static void fz_pump(struct fz *f)
{
	while (!f->closed) {
		ssize_t n = recv(f->fd, f->in, sizeof(f->in), MSG_DONTWAIT);
		struct bc_msg part;
		struct bc_errinfo ei = {0};
		int rc;
		if (n >= 0) {
			f->heard = true;
		}
		if (n > 0) {
			if (bc_proto_reader_feed(&f->r, f->in, (size_t)n) !=
			    0) {
				fz_bad(f);
				return;
			}
			while ((rc = bc_proto_reader_next(&f->r, &part)) == 1) {
				/* Parts out of their order are a daemon bug. */
				int pr = bc_proto_parts_add(&f->parts, &part,
				                            &f->m, &ei);
				if (pr < 0) {
					if (atomic_fetch_add(&n_bad_answers,
					                     1) < 10) {
						printf("conn %d: %s\n",
						       f->index, ei.msg);
					}
					f->closed = true;
					return;
				}
				if (pr == 1) {
					fz_handle(f);
				}
			}
			if (rc < 0) {
				fz_bad(f);
				return;
			}
			continue;
		}
		if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
			return;
		}
		if (n < 0 && errno == EINTR) {
			continue;
		}
		atomic_fetch_add(&n_closed, 1);
		if (!f->fatal) {
			atomic_fetch_add(&n_closed_silent, 1);
		}
		f->closed = true;
	}
}

/* Writes n bytes, reading what arrives meanwhile; -1 when the link broke
 * or the daemon did not take them within STALL_MS. */
static int fz_write(struct fz *f, const uint8_t *p, size_t n)
{
	int64_t end = t_now_ms() + STALL_MS;
	while (n > 0 && !f->closed) {
		ssize_t k = send(f->fd, p, n, MSG_NOSIGNAL | MSG_DONTWAIT);
		if (k > 0) {
			p += k;
			n -= (size_t)k;
			atomic_fetch_add(&n_bytes, (long)k);
			continue;
		}
		if (k < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
			struct pollfd pfd = {.fd = f->fd,
			                     .events = POLLIN | POLLOUT};
			if (t_now_ms() > end || atomic_load(&stopping)) {
				atomic_fetch_add(
				    f->risky ? &n_given_up : &n_stalls, 1);
				f->closed = true;
				return -1;
			}
			poll(&pfd, 1, 20);
			fz_pump(f);
			continue;
		}
		if (k < 0 && errno == EINTR) {
			continue;
		}
		f->closed = true;
	}
	return f->closed ? -1 : 0;
}

static void fz_mark_risky(struct fz *f)
{
	f->risky = true;
	f->risky_seq = f->seq;
}

/* Room for n bytes in the mutation buffer (plus what mutations add). */
static uint8_t *fz_room(struct fz *f, size_t n)
{
	if (f->mcap < n + 4096) {
		uint8_t *p = bc_realloc(f->mb, n + 4096);
		if (!p) {
			return NULL;
		}
		f->mb = p;
		f->mcap = n + 4096;
	}
	return f->mb;
}

static const uint32_t interesting[] = {
    0,          1,          2,         3,         4,         0x7f,
    0x80,       0xff,       0x100,     0x3ff,     0x400,     0x401,
    0x1000,     0x1001,     0x7fff,    0x8000,    0xffff,    0x10000,
    0x3fffff,   0x400000,   0x1000000, 0x4000000, 0x4000001, 0x7fffffff,
    0x80000000, 0xfffffffe, 0xffffffff};

/* NaN, infinities, the largest float, a denormal, -0, just over 10^6,
 * 10^9, -10^6, a hair above 1, 180. */
static const uint32_t odd_floats[] = {
    0x7fc00000, 0x7f800000, 0xff800000, 0x7f7fffff, 0x00000001, 0x80000000,
    0x49742401, 0x4e6e6b28, 0xc9742400, 0x3f800001, 0x43340000};

/* Mutates f->mb[0..*n) (a message, header included, or any bytes) in
 * place, one to three times. */
static void mutate(struct fz *f, size_t *n)
{
	uint64_t *s = &f->rng;
	int times = 1 + (int)rnd(s, pm(s, 700) ? 1 : 3);
	for (int t = 0; t < times && *n != 0; t++) {
		uint8_t *b = f->mb;
		size_t plen = *n > 16 ? *n - 16 : 0;
		uint32_t what = *n >= 16 ? rnd(s, 13) : 0;
		switch (what) {
		case 1: /* truncated, the header saying so */
			if (plen) {
				plen = rnd(s, (uint32_t)plen);
				*n = 16 + plen;
				put_le(b + 8, plen, 4);
			}
			break;
		case 2: /* truncated, the header lying */
			if (*n > 1) {
				*n = 1 + rnd(s, (uint32_t)*n - 1);
			}
			break;
		case 3:   /* extended, the header saying so */
		case 4: { /* extended raw: the bytes start the next message */
			size_t add = 1 + rnd(s, 64);
			for (size_t i = 0; i < add; i++) {
				b[*n + i] = (uint8_t)next_u64(s);
			}
			if (what == 4 && pm(s, 500)) {
				memcpy(b + *n, "BCST\x01", add < 5 ? add : 5);
			}
			*n += add;
			if (what == 3) {
				put_le(b + 8, plen + add, 4);
			}
			break;
		}
		case 5: /* a length field that lies */
			put_le(b + 8,
			       pm(s, 500)
			           ? interesting[rnd(s, NELEM(interesting))]
			           : plen + rnd(s, 9) - 4,
			       4);
			break;
		case 6: /* the wrong type */
			b[5] = pm(s, 600)
			           ? client_types[rnd(s, NELEM(client_types))]
			           : (uint8_t)rnd(s, 256);
			break;
		case 7: /* an integer smashed: counts, lengths, enums, ids */
			if (plen) {
				int w = 1 << rnd(s, 3);
				size_t off =
				    pm(s, 300) ? 0 : rnd(s, (uint32_t)plen);
				uint32_t v =
				    interesting[rnd(s, NELEM(interesting))];
				if (off + (size_t)w > plen) {
					off = plen >= (size_t)w
					          ? plen - (size_t)w
					          : 0;
					w = plen >= (size_t)w ? w : 1;
				}
				put_le(b + 16 + off, v, w);
			}
			break;
		case 8: /* a float smashed */
			if (plen >= 4) {
				size_t off = rnd(s, (uint32_t)plen - 3);
				put_le(b + 16 + off,
				       odd_floats[rnd(s, NELEM(odd_floats))],
				       4);
			}
			break;
		case 9: /* header flags */
			put_le(b + 6,
			       pm(s, 500) ? 1u << rnd(s, 16) : rnd(s, 65536),
			       2);
			break;
		case 10: /* magic or version */
			b[rnd(s, 5)] ^= (uint8_t)(1u << rnd(s, 8));
			break;
		case 11:   /* bytes inserted in the payload */
		case 12: { /* bytes cut out of the payload */
			size_t at = 16 + rnd(s, (uint32_t)plen + 1);
			size_t k = 1 + rnd(s, 32);
			if (what == 11) {
				memmove(b + at + k, b + at, *n - at);
				for (size_t i = 0; i < k; i++) {
					b[at + i] = (uint8_t)next_u64(s);
				}
				*n += k;
				plen += k;
			} else {
				k = k < *n - at ? k : *n - at;
				memmove(b + at, b + at + k, *n - at - k);
				*n -= k;
				plen -= k;
			}
			if (pm(s, 500)) {
				put_le(b + 8, plen, 4);
			}
			break;
		}
		default: { /* bit flips, mostly in the payload */
			int k = 1 + (int)rnd(s, 8);
			for (int i = 0; i < k; i++) {
				size_t at = *n > 16 && pm(s, 700)
				                ? 16 + rnd(s, (uint32_t)*n - 16)
				                : rnd(s, (uint32_t)*n);
				b[at] ^= (uint8_t)(1u << rnd(s, 8));
			}
			break;
		}
		}
	}
}

/* Sends f->mb[0..n); when its header claims payload bytes that are not
 * there, now and then sends them (random) so the daemon decodes the
 * message rather than waiting for it. */
static void fz_send_mutated(struct fz *f, size_t n, enum cls c)
{
	uint32_t claimed, missing = 0;
	atomic_fetch_add(&n_sent[c], 1);
	fz_mark_risky(f);
	if (n >= 16 && !memcmp(f->mb, "BCST", 4)) {
		claimed = get_le32(f->mb + 8);
		if (claimed > n - 16) {
			missing = claimed - (uint32_t)(n - 16);
		}
	}
	if (fz_write(f, f->mb, n) == 0 && missing > 0 && missing <= 65536 &&
	    pm(&f->rng, 500) && fz_room(f, missing)) {
		for (uint32_t i = 0; i < missing; i++) {
			f->mb[i] = (uint8_t)next_u64(&f->rng);
		}
		atomic_fetch_add(&n_filler, 1);
		fz_write(f, f->mb, missing);
	}
}

/* Encodes m with the next seq and sends it, mutated when asked, counted
 * as c (by type too when c is CLS_VALID or CLS_MUTATED). Returns whether
 * it was sent. */
static bool fz_emit_as(struct fz *f, struct bc_msg *m, bool mutated, enum cls c)
{
	size_t n;
	if (++f->seq == 0) {
		f->seq = 1;
	}
	m->seq = f->seq;
	bc_proto_buf_reset(&f->b);
	if (bc_proto_encode(&f->b, m, NULL) != 0) {
		atomic_fetch_add(&n_encode_refused, 1);
		return false;
	}
	if (!mutated) {
		atomic_fetch_add(&n_sent[c], 1);
		if (c == CLS_VALID) {
			atomic_fetch_add(&n_type_valid[m->type], 1);
		} else {
			fz_mark_risky(f);
		}
		return fz_write(f, f->b.data, f->b.len) == 0;
	}
	n = f->b.len;
	if (!fz_room(f, n)) {
		return false;
	}
	memcpy(f->mb, f->b.data, n);
	mutate(f, &n);
	if (c == CLS_MUTATED) {
		atomic_fetch_add(&n_type_mutated[m->type], 1);
	}
	fz_send_mutated(f, n, c);
	return !f->closed;
}

static bool fz_emit(struct fz *f, struct bc_msg *m, bool mutated)
{
	return fz_emit_as(f, m, mutated, mutated ? CLS_MUTATED : CLS_VALID);
}

/* ---- random scenes ----------------------------------------------------------- */

static void rand_quat(struct fz *f, float q[4])
{
	float len = 0;
	for (int i = 0; i < 4; i++) {
		q[i] = rndf(&f->rng, -1, 1);
		len += q[i] * q[i];
	}
	if (len < 1e-3f) {
		q[0] = q[1] = q[2] = 0;
		q[3] = len = 1;
	}
	len = sqrtf(len);
	for (int i = 0; i < 4; i++) {
		q[i] /= len;
	}
}

/* eye[3] target[3] up[3] fov: an orbit around the origin; now and then a
 * degenerate one (eye = target, up along the view) the daemon refuses. */
static void rand_camera(struct fz *f, float c[10])
{
	float a = rndf(&f->rng, 0, 6.2831f), e = rndf(&f->rng, -1.2f, 1.2f);
	float r = rndf(&f->rng, 3, 12);
	c[0] = r * cosf(e) * sinf(a);
	c[1] = r * sinf(e);
	c[2] = r * cosf(e) * cosf(a);
	for (int i = 3; i < 6; i++) {
		c[i] = rndf(&f->rng, -0.5f, 0.5f);
	}
	c[6] = 0;
	c[7] = 1;
	c[8] = 0;
	c[9] = rndf(&f->rng, 20, 90);
	if (pm(&f->rng, 30)) {
		memcpy(c + 3, c, 3 * sizeof(float));
	} else if (pm(&f->rng, 20)) {
		for (int i = 0; i < 3; i++) {
			c[6 + i] = c[3 + i] - c[i];
		}
	}
}

static void gen_prim(struct fz *f, struct bc_proto_buf *b, uint32_t id)
{
	static const uint8_t safe[] = {BC_PRIM_SPHERE,    BC_PRIM_BOX,
	                               BC_PRIM_CAPSULE,   BC_PRIM_CYLINDER,
	                               BC_PRIM_TORUS,     BC_PRIM_ELLIPSOID,
	                               BC_PRIM_OCTAHEDRON};
	uint64_t *s = &f->rng;
	float tr[3], q[4], col[3], p[8] = {0};
	uint8_t kind = pm(s, 800) ? safe[rnd(s, NELEM(safe))]
	                          : (uint8_t)(1 + rnd(s, BC_PRIM_COUNT - 1));
	uint8_t np = (uint8_t)bc_scene_prim_nfloats((enum bc_prim)kind);
	for (int i = 0; i < 3; i++) {
		tr[i] = rndf(s, -2, 2);
		col[i] = rndf(s, 0, 1);
	}
	rand_quat(f, q);
	for (int i = 0; i < np && i < 8; i++) {
		p[i] = rndf(s, 0.1f, 0.6f);
	}
	switch (kind) {
	case BC_PRIM_BOX:
		p[3] = rndf(s, 0, 0.05f);
		break;
	case BC_PRIM_CAPSULE:
		for (int i = 0; i < 6; i++) {
			p[i] = rndf(s, -1, 1);
		}
		break;
	case BC_PRIM_TORUS:
		p[0] = rndf(s, 0.5f, 1);
		p[1] = rndf(s, 0.1f, 0.3f);
		break;
	default:
		break;
	}
	bc_proto_scene_prim(b, kind, id, tr, q, pm(s, 500) ? col : NULL, np, p);
}

/* One node and its subtree in pre-order, about *left nodes (never fewer
 * than one); returns the nodes written. */
static uint32_t gen_node(struct fz *f, struct bc_proto_buf *b, int *left,
                         int depth, uint32_t zero_pm, uint32_t id)
{
	uint64_t *s = &f->rng;
	uint32_t r = rnd(s, 100), n = 1;
	if (id == 0 && !pm(s, zero_pm)) {
		id = fresh_id(f);
	}
	(*left)--;
	if (*left >= 2 && depth < 6 && r < 30) {
		uint32_t k = 2 + (*left >= 3 && pm(s, 300));
		uint8_t kind = (uint8_t)(1 + rnd(s, 6));
		float blend = 0, range = 0;
		if (kind >= BC_OP_SMOOTH_UNION) {
			blend = rndf(s, 0.05f, 0.4f);
			range = pm(s, 500) ? 0 : blend * rndf(s, 0.2f, 2);
		}
		bc_proto_scene_op(b, kind, id, blend, range, k);
		for (uint32_t i = 0; i < k; i++) {
			n += gen_node(f, b, left, depth + 1, zero_pm, 0);
		}
	} else if (*left >= 1 && depth < 6 && r < 42) {
		uint8_t kind =
		    (uint8_t)(BC_OP_FIRST_UNARY +
		              rnd(s, BC_OP_COUNT - BC_OP_FIRST_UNARY));
		const struct bc_unary_info *info =
		    bc_unary_info((enum bc_op)kind);
		uint8_t np = (uint8_t)(info ? info->nparams : 1);
		float u[BC_PROTO_MAX_UNARY_PARAMS] = {0};
		for (int i = 0; i < np && i < (int)BC_PROTO_MAX_UNARY_PARAMS;
		     i++) {
			u[i] = rndf(s, 0.05f, 0.5f);
		}
		if (kind == BC_OP_MIRROR) {
			u[0] = (float)(1 + rnd(s, 7));
		} else if (kind == BC_OP_REPEAT) {
			for (int i = 0; i < 3; i++) {
				u[i] = rndf(s, 1, 3);
				u[3 + i] = (float)rnd(s, 3);
			}
		} else if (kind == BC_OP_SCALE) {
			u[0] = rndf(s, 0.5f, 2);
		}
		bc_proto_scene_unary(b, kind, id, np, u);
		n += gen_node(f, b, left, depth + 1, zero_pm, 0);
	} else {
		gen_prim(f, b, id);
	}
	return n;
}

/* Appends a scene of about nodes nodes to f->sub (with a camera when
 * asked; root_id for the root when not 0; each other id 0 with
 * probability zero_pm / 1000). Returns where it starts. */
static size_t gen_scene(struct fz *f, bool camera, int nodes, uint32_t zero_pm,
                        uint32_t root_id)
{
	size_t at = f->sub.len;
	float cam[10];
	uint32_t n;
	rand_camera(f, cam);
	if (bc_proto_scene_begin(&f->sub, camera ? cam : NULL, 0) != 0) {
		return at;
	}
	n = gen_node(f, &f->sub, &nodes, 0, zero_pm, root_id);
	put_le(f->sub.data + at + 1 + (camera ? 40 : 0), n, 4);
	return at;
}

/* ---- valid messages ------------------------------------------------------------ */

static void act_hello(struct fz *f, bool mutated)
{
	struct bc_msg m = {.type = BC_MSG_HELLO};
	char name[32], token[65];
	uint64_t *s = &f->rng;
	m.hello.version_min = 1;
	m.hello.version_max = pm(s, 900) ? 1 : (uint16_t)(1 + rnd(s, 5));
	f->encodings = pm(s, 950) ? (uint8_t)(1 + rnd(s, 7)) : 0;
	m.hello.encodings = f->encodings;
	m.hello.max_frame_bytes = pm(s, 800) ? 0 : 65536u + rnd(s, 1u << 22);
	snprintf(name, sizeof(name), pm(s, 900) ? "fz%d" : "fz%d-\xc3\xa9",
	         f->index);
	m.hello.client_name.ptr = name;
	m.hello.client_name.len = (uint32_t)strlen(name);
	if (pm(s, 50)) {
		uint32_t len = rnd(s, 65);
		for (uint32_t i = 0; i < len; i++) {
			token[i] = (char)('a' + rnd(s, 26));
		}
		m.hello.token.ptr = token;
		m.hello.token.len = len;
	}
	/* Features (PROTOCOL.md 4.1): mostly every one, so that sessions
	 * with every node kind keep their members; sometimes a random mask
	 * or none (an earlier client, closed with ENOTSUP when its session
	 * gains a kind it did not announce). */
	if (pm(s, 900)) {
		m.hello.has_features = true;
		m.hello.features =
		    pm(s, 900) ? BC_PROTO_FEATURES_ALL : (uint32_t)next_u64(s);
	}
	fz_emit(f, &m, mutated);
}

static void act_enter(struct fz *f, bool mutated)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_JOIN};
	char name[40];
	uint64_t *s = &f->rng;
	uint32_t r = rnd(s, 100);
	m.session.role =
	    pm(s, 850) ? BC_PROTO_ROLE_EDITOR : BC_PROTO_ROLE_VIEWER;
	if (r < 10) {
		snprintf(name, sizeof(name), "tmp-%d-%u", f->index,
		         f->tmp_next++ % TMP_PER_CONN);
		m.type = BC_MSG_SESSION_CREATE;
		m.session.role = BC_PROTO_ROLE_EDITOR;
	} else if (r < 14) {
		snprintf(name, sizeof(name), "nope-%u", rnd(s, 1000));
	} else {
		uint32_t k = rnd(s, NSESSIONS + 1);
		/* The session the daemon opens itself, or one of ours. */
		if (k == NSESSIONS) {
			snprintf(name, sizeof(name), "default");
		} else {
			snprintf(name, sizeof(name), "fz%u", k);
		}
		if (pm(s, 150)) {
			m.type = BC_MSG_SESSION_CREATE;
		}
	}
	m.session.name.ptr = name;
	m.session.name.len = (uint32_t)strlen(name);
	if (fz_emit(f, &m, mutated) && !mutated && !f->in_session) {
		f->in_session = true;
		f->enter_seq = m.seq;
	}
}

static void act_delete(struct fz *f, bool mutated)
{
	struct bc_msg m = {.type = BC_MSG_SESSION_DELETE};
	char name[40];
	if (pm(&f->rng, 700)) {
		snprintf(name, sizeof(name), "tmp-%d-%u", f->index,
		         (f->tmp_next + TMP_PER_CONN - 1) % TMP_PER_CONN);
	} else {
		snprintf(name, sizeof(name), "nope-%u", rnd(&f->rng, 1000));
	}
	m.session_delete.name.ptr = name;
	m.session_delete.name.len = (uint32_t)strlen(name);
	fz_emit(f, &m, mutated);
}

/* SET fields: up to max distinct field numbers with values of the right
 * count (the decoder's rule); whether they apply to the node is the
 * daemon's to say. */
static uint8_t gen_fields(struct fz *f, struct bc_proto_field *fl, int max)
{
	static const uint8_t nums[] = {1,  2,  3,  16, 17, 18, 19,
	                               20, 21, 22, 23, 32, 33, 34};
	uint64_t *s = &f->rng;
	uint32_t used = 0;
	int n = 1 + (int)rnd(s, pm(s, 900) ? 2 : (uint32_t)max);
	for (int k = 0; k < n; k++) {
		struct bc_proto_field *x = &fl[k];
		uint32_t i;
		do {
			i = rnd(s, NELEM(nums));
		} while (used & (1u << i));
		used |= 1u << i;
		memset(x, 0, sizeof(*x));
		x->field = nums[i];
		switch (x->field) {
		case BC_PROTO_FIELD_TRANSLATE:
			x->count = 3;
			for (int j = 0; j < 3; j++) {
				x->v[j] = rndf(s, -3, 3);
			}
			break;
		case BC_PROTO_FIELD_ROTATE:
			x->count = 4;
			rand_quat(f, x->v);
			if (pm(s, 50)) {
				x->v[0] += 0.5f;
			}
			break;
		case BC_PROTO_FIELD_COLOR:
			x->count = 3;
			for (int j = 0; j < 3; j++) {
				x->v[j] = pm(s, 30) ? 1.5f : rndf(s, 0, 1);
			}
			break;
		case BC_PROTO_FIELD_BLEND:
			x->count = 1;
			x->v[0] = pm(s, 100) ? 0 : rndf(s, 0.05f, 0.5f);
			break;
		case BC_PROTO_FIELD_RANGE:
			x->count = 1;
			x->v[0] = pm(s, 300) ? 0 : rndf(s, 0.1f, 1);
			break;
		case BC_PROTO_FIELD_OP_KIND:
			x->count = 1;
			x->v[0] = pm(s, 30) ? 2.5f : (float)(1 + rnd(s, 15));
			break;
		default: /* a parameter: 1 or 3 values mostly */
			x->count = (uint8_t)(pm(s, 500)   ? 1
			                     : pm(s, 700) ? 3
			                                  : 1 + rnd(s, 4));
			for (int j = 0; j < x->count; j++) {
				x->v[j] = rndf(s, 0.05f, 1.2f);
			}
			break;
		}
	}
	return (uint8_t)n;
}

static void act_edit(struct fz *f, bool mutated)
{
	struct bc_proto_edit_op ops[MAX_OPS];
	struct bc_proto_field fields[MAX_OPS][6];
	size_t at[MAX_OPS];
	struct bc_msg m = {.type = BC_MSG_EDIT};
	uint64_t *s = &f->rng;
	uint32_t nops = pm(s, 700)   ? 1
	                : pm(s, 700) ? 2 + rnd(s, 2)
	                : pm(s, 900) ? 1 + rnd(s, 16)
	                             : 1 + rnd(s, MAX_OPS);
	bc_proto_buf_reset(&f->sub);
	memset(ops, 0, sizeof(ops));
	for (uint32_t i = 0; i < nops; i++) {
		struct bc_proto_edit_op *op = &ops[i];
		uint32_t r = rnd(s, 100);
		if (r < 60) {
			op->kind = BC_PROTO_EDIT_SET;
			op->node = pick_id(f, 0);
			op->fields = fields[i];
			op->nfields = gen_fields(f, fields[i], 6);
		} else if (r < 82) {
			op->kind = BC_PROTO_EDIT_INSERT;
			op->node = pick_id(f, K_OP);
			op->position = rnd(s, 4);
			at[i] = gen_scene(f, false, 1 + (int)rnd(s, 6), 20, 0);
		} else if (r < 90) {
			op->kind = BC_PROTO_EDIT_REMOVE;
			op->node = pick_id(f, 0);
		} else {
			op->kind = BC_PROTO_EDIT_REPLACE;
			op->node = pick_id(f, 0);
			at[i] = gen_scene(f, false, 1 + (int)rnd(s, 6), 20,
			                  pm(s, 200) ? op->node : 0);
		}
		at[i] = op->kind == BC_PROTO_EDIT_INSERT ||
		                op->kind == BC_PROTO_EDIT_REPLACE
		            ? at[i]
		            : f->sub.len;
	}
	/* The subtrees' bytes moved while f->sub grew: point at them now. */
	for (uint32_t i = 0; i < nops; i++) {
		if (ops[i].kind == BC_PROTO_EDIT_INSERT ||
		    ops[i].kind == BC_PROTO_EDIT_REPLACE) {
			size_t end = f->sub.len;
			for (uint32_t j = i + 1; j < nops; j++) {
				if (ops[j].kind == BC_PROTO_EDIT_INSERT ||
				    ops[j].kind == BC_PROTO_EDIT_REPLACE) {
					end = at[j];
					break;
				}
			}
			ops[i].subtree.ptr = f->sub.data + at[i];
			ops[i].subtree.len = (uint32_t)(end - at[i]);
		}
	}
	m.flags = pm(s, 200) ? BC_PROTO_FLAG_INTERACTING : 0;
	m.edit.nops = (uint16_t)nops;
	m.edit.ops = ops;
	fz_emit(f, &m, mutated);
}

static void act_load(struct fz *f, bool mutated)
{
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	bc_proto_buf_reset(&f->sub);
	gen_scene(f, pm(&f->rng, 500), 1 + (int)rnd(&f->rng, 24), 100, 0);
	m.scene_load.scene.ptr = f->sub.data;
	m.scene_load.scene.len = (uint32_t)f->sub.len;
	if (f->sub.len >= 2 && pm(&f->rng, 300)) {
		/* In parts (PROTOCOL.md 7.10.1), cut anywhere; now and then
		 * a part left out, so that a CONT comes with no scene begun
		 * or the scene stays unfinished. */
		size_t at = 0;
		while (at < f->sub.len) {
			size_t n =
			    1 + rnd(&f->rng, (uint32_t)(f->sub.len - at));
			m.flags =
			    (uint16_t)((at ? BC_PROTO_FLAG_CONT : 0u) |
			               (at + n < f->sub.len ? BC_PROTO_FLAG_MORE
			                                    : 0u));
			m.scene_load.scene.ptr = f->sub.data + at;
			m.scene_load.scene.len = (uint32_t)n;
			if (pm(&f->rng, 950)) {
				fz_emit(f, &m, mutated);
			}
			at += n;
		}
		return;
	}
	fz_emit(f, &m, mutated);
}

static void act_camera(struct fz *f, bool mutated, enum bc_msg_type type)
{
	struct bc_msg m = {.type = type};
	float c[10];
	struct bc_msg_camera *cam =
	    type == BC_MSG_CAMERA ? &m.camera : &m.session_camera;
	rand_camera(f, c);
	memcpy(cam->eye, c, sizeof(cam->eye));
	memcpy(cam->target, c + 3, sizeof(cam->target));
	memcpy(cam->up, c + 6, sizeof(cam->up));
	cam->fov_y_deg = c[9];
	if (type == BC_MSG_CAMERA && pm(&f->rng, 300)) {
		m.flags = BC_PROTO_FLAG_INTERACTING;
	}
	fz_emit(f, &m, mutated);
}

static void act_view(struct fz *f, bool mutated)
{
	struct bc_msg m = {.type = BC_MSG_VIEW};
	uint64_t *s = &f->rng;
	uint8_t enc = (uint8_t)(1 + rnd(s, 3));
	for (int i = 0; i < 8 && f->encodings && pm(s, 900) &&
	                !(f->encodings & (1u << (enc - 1)));
	     i++) {
		enc = (uint8_t)(1 + rnd(s, 3));
	}
	m.view.width =
	    (uint16_t)(pm(s, 950) ? 8 + rnd(s, 89) : 8 + rnd(s, 249));
	m.view.height =
	    (uint16_t)(pm(s, 950) ? 8 + rnd(s, 89) : 8 + rnd(s, 249));
	m.view.encoding = (enum bc_proto_encoding)enc;
	m.view.quality_interactive = (uint8_t)(1 + rnd(s, 100));
	m.view.quality_still = (uint8_t)(1 + rnd(s, 100));
	m.view.downscale = (uint8_t)(1 + rnd(s, 8));
	if (fz_emit(f, &m, mutated) && !mutated) {
		f->view_w = m.view.width;
		f->view_h = m.view.height;
	}
}

static void act_small(struct fz *f, bool mutated, enum bc_msg_type type)
{
	struct bc_msg m = {.type = type};
	char text[32];
	uint64_t *s = &f->rng;
	switch (type) {
	case BC_MSG_SNAPSHOT:
		m.snapshot.encoding =
		    pm(s, 500) ? BC_PROTO_ENC_PNG : BC_PROTO_ENC_RAW;
		m.snapshot.planes = (uint8_t)rnd(s, 4);
		break;
	case BC_MSG_PICK:
		m.pick.x = (uint16_t)rnd(s, f->view_w ? f->view_w + 2u : 64u);
		m.pick.y = (uint16_t)rnd(s, f->view_h ? f->view_h + 2u : 64u);
		break;
	case BC_MSG_GET_STATS: {
		static const uint8_t parts[] = {0, BC_PROTO_STATS_LOAD,
		                                BC_PROTO_STATS_PARTS_ALL};
		m.get_stats.parts = parts[rnd(s, 3)];
		break;
	}
	case BC_MSG_PRESENT:
	case BC_MSG_FOLLOW:
		m.toggle.on = (uint8_t)rnd(s, 2);
		break;
	case BC_MSG_PING:
	case BC_MSG_PONG:
		m.ping.stamp = next_u64(s);
		break;
	case BC_MSG_ERROR:
		m.error.code = (uint16_t)(1 + rnd(s, BC_ERR_COUNT + 2));
		snprintf(text, sizeof(text), "client error %u", rnd(s, 100));
		m.error.text.ptr = text;
		m.error.text.len = (uint32_t)strlen(text);
		m.flags = pm(s, 100) ? BC_PROTO_FLAG_FATAL : 0;
		break;
	case BC_MSG_SESSION_LEAVE:
		if (!mutated) {
			f->in_session = false;
		}
		break;
	default: /* UNDO, REDO, SESSION_LIST: empty */
		break;
	}
	fz_emit(f, &m, mutated);
}

/* One message of every kind a client may send, in the stage the
 * connection believes it is in, mutated when asked. */
static void fz_message(struct fz *f, bool mutated)
{
	uint32_t r = rnd(&f->rng, 100);
	if (!f->in_session && rnd(&f->rng, 100) < 60) {
		act_enter(f, mutated);
	} else if (r < 30) {
		act_edit(f, mutated);
	} else if (r < 38) {
		act_camera(f, mutated, BC_MSG_CAMERA);
	} else if (r < 42) {
		act_view(f, mutated);
	} else if (r < 45) {
		act_small(f, mutated, BC_MSG_SNAPSHOT);
	} else if (r < 48) {
		act_small(f, mutated, BC_MSG_PICK);
	} else if (r < 53) {
		act_small(f, mutated, BC_MSG_UNDO);
	} else if (r < 57) {
		act_small(f, mutated, BC_MSG_REDO);
	} else if (r < 60) {
		act_load(f, mutated);
	} else if (r < 63) {
		act_camera(f, mutated, BC_MSG_SESSION_CAMERA);
	} else if (r < 66) {
		act_small(f, mutated, BC_MSG_PRESENT);
	} else if (r < 70) {
		act_small(f, mutated, BC_MSG_FOLLOW);
	} else if (r < 74) {
		act_small(f, mutated, BC_MSG_GET_STATS);
	} else if (r < 78) {
		act_small(f, mutated, BC_MSG_SESSION_LIST);
	} else if (r < 81) {
		act_small(f, mutated, BC_MSG_PING);
	} else if (r < 83) {
		act_small(f, mutated, BC_MSG_SESSION_LEAVE);
	} else if (r < 85) {
		act_delete(f, mutated);
	} else if (r < 87) {
		act_enter(f, mutated);
	} else if (r < 88) {
		act_hello(f, mutated);
	} else if (r < 89) {
		act_small(f, mutated, BC_MSG_PONG);
	} else if (r < 90) {
		act_small(f, mutated, BC_MSG_ERROR);
	} else {
		act_edit(f, mutated);
	}
}

/* ---- random bytes and vectors ------------------------------------------------- */

static void fz_random(struct fz *f)
{
	uint64_t *s = &f->rng;
	size_t n;
	if (pm(s, 500)) {
		n = 1 + rnd(s, 512);
		if (!fz_room(f, n)) {
			return;
		}
		for (size_t i = 0; i < n; i++) {
			f->mb[i] = (uint8_t)next_u64(s);
		}
	} else {
		uint32_t plen = pm(s, 900) ? rnd(s, 300) : rnd(s, 8192);
		n = 16 + plen;
		if (!fz_room(f, n)) {
			return;
		}
		memcpy(f->mb, "BCST\x01", 5);
		f->mb[5] = pm(s, 800)
		               ? client_types[rnd(s, NELEM(client_types))]
		               : (uint8_t)rnd(s, 64);
		put_le(f->mb + 6, pm(s, 800) ? 0 : 1, 2);
		put_le(f->mb + 8, plen, 4);
		put_le(f->mb + 12, ++f->seq, 4);
		for (size_t i = 16; i < n; i++) {
			f->mb[i] = (uint8_t)next_u64(s);
		}
	}
	fz_send_mutated(f, n, CLS_RANDOM);
}

/* A scene of scene.json framed as a SCENE_LOAD, an INSERT or a REPLACE. */
static void fz_vector_scene(struct fz *f, bool mutated)
{
	const struct vec *v = &scenes[rnd(&f->rng, (uint32_t)nscenes)];
	struct bc_proto_edit_op op = {.node = pick_id(f, 0)};
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	uint32_t r = rnd(&f->rng, 100);
	if (r < 50) {
		m.scene_load.scene.ptr = v->bytes;
		m.scene_load.scene.len = (uint32_t)v->len;
	} else {
		op.kind = r < 75 ? BC_PROTO_EDIT_INSERT : BC_PROTO_EDIT_REPLACE;
		if (op.kind == BC_PROTO_EDIT_INSERT) {
			op.node = pick_id(f, K_OP);
		}
		op.subtree.ptr = v->bytes;
		op.subtree.len = (uint32_t)v->len;
		m.type = BC_MSG_EDIT;
		m.edit.nops = 1;
		m.edit.ops = &op;
	}
	fz_emit_as(f, &m, mutated, mutated ? CLS_VECTOR_MUT : CLS_VECTOR);
}

static void fz_vector(struct fz *f)
{
	uint64_t *s = &f->rng;
	bool mutated = pm(s, 400);
	const struct vec *v;
	size_t n;
	if (nvecs == 0) {
		fz_random(f);
		return;
	}
	if (nscenes && pm(s, 300)) {
		fz_vector_scene(f, mutated);
		return;
	}
	v = nclient_vecs && pm(s, 700)
	        ? &vecs[client_vecs[rnd(s, (uint32_t)nclient_vecs)]]
	        : &vecs[rnd(s, (uint32_t)nvecs)];
	n = v->len;
	if (!fz_room(f, n)) {
		return;
	}
	memcpy(f->mb, v->bytes, n);
	if (mutated) {
		mutate(f, &n);
	}
	fz_send_mutated(f, n, mutated ? CLS_VECTOR_MUT : CLS_VECTOR);
}

/* ---- a connection's life ------------------------------------------------------- */

static int fz_open(struct fz *f)
{
	atomic_fetch_add(&n_connects, 1);
	f->fd = tcp_connect();
	if (f->fd < 0) {
		atomic_fetch_add(&n_connect_failed, 1);
		return -1;
	}
	fcntl(f->fd, F_SETFL, fcntl(f->fd, F_GETFL) | O_NONBLOCK);
	bc_proto_reader_init(&f->r, &(struct bc_proto_reader_opts){
	                                .side = BC_PROTO_SIDE_CLIENT});
	bc_proto_parts_init(&f->parts, 0, false);
	f->seq = 0;
	f->in_session = f->closed = f->fatal = f->risky = false;
	f->heard = false;
	f->pings_out = 0;
	f->enter_seq = 0;
	f->view_w = f->view_h = 0;
	f->nids = 0;
	return 0;
}

/* Closes the link; abortive: with a reset (SO_LINGER 0), only once the
 * daemon is known to have accepted it unless --early-reset. */
static void fz_close(struct fz *f, bool abortive)
{
	if (abortive && (f->heard || opt.early_reset)) {
		struct linger lg = {.l_onoff = 1, .l_linger = 0};
		setsockopt(f->fd, SOL_SOCKET, SO_LINGER, &lg, sizeof(lg));
	}
	close(f->fd);
	f->fd = -1;
	bc_proto_reader_finish(&f->r);
	bc_proto_parts_finish(&f->parts);
}

/* Reads until the daemon closes, at most ms. */
static void fz_drain(struct fz *f, int ms)
{
	int64_t end = t_now_ms() + ms;
	while (!f->closed && t_now_ms() < end) {
		struct pollfd pfd = {.fd = f->fd, .events = POLLIN};
		poll(&pfd, 1, 20);
		fz_pump(f);
	}
}

/* Waits until fewer than WINDOW_PINGS flow PINGs are unanswered; -1 when
 * the link closed or the daemon stopped answering. */
static int fz_wait_window(struct fz *f)
{
	for (;;) {
		struct pollfd pfd = {.fd = f->fd, .events = POLLIN};
		int64_t waited;
		fz_pump(f);
		if (f->closed) {
			return -1;
		}
		if (f->pings_out < WINDOW_PINGS) {
			return 0;
		}
		waited = t_now_ms() - f->ping_at[0];
		if (f->risky ? waited > RISKY_MS : waited > STALL_MS) {
			if (f->risky) {
				atomic_fetch_add(&n_given_up, 1);
			} else if (atomic_fetch_add(&n_stalls, 1) < 10) {
				printf("conn %d: a PING after valid messages "
				       "only was not answered in %d s\n",
				       f->index, STALL_MS / 1000);
			}
			return -1;
		}
		if (atomic_load(&stopping)) {
			return -1;
		}
		poll(&pfd, 1, 20);
	}
}

static void fz_flow_ping(struct fz *f)
{
	struct bc_msg m = {.type = BC_MSG_PING};
	m.ping.stamp = ((uint64_t)f->index + 1) << 32;
	if (fz_emit(f, &m, false) && f->pings_out < WINDOW_PINGS) {
		f->ping_seq[f->pings_out] = m.seq;
		f->ping_at[f->pings_out++] = t_now_ms();
	}
}

/* The first message: a valid HELLO mostly. */
static void fz_first(struct fz *f)
{
	uint32_t r = rnd(&f->rng, 1000);
	if (r < 900) {
		act_hello(f, false);
	} else if (r < 950) {
		act_hello(f, true);
	} else if (r < 970) {
		fz_vector(f);
	} else if (r < 985) {
		fz_random(f);
	} else if (r < 995) {
		/* Something else first: refused before HELLO (ESTATE). */
		fz_message(f, false);
		fz_mark_risky(f);
	}
}

/* How a connection ends: closed, reset, LEAVE, half-closed inside a
 * message or between two, or hung up on a burst of requests. */
static void fz_end(struct fz *f)
{
	uint32_t r = rnd(&f->rng, 100);
	bool abortive = pm(&f->rng, 500);
	if (f->closed || atomic_load(&stopping) || r < 35) {
		fz_close(f, abortive);
		return;
	}
	if (r < 55) {
		act_small(f, false, BC_MSG_SESSION_LEAVE);
		fz_drain(f, 300);
	} else if (r < 70) {
		struct bc_msg m = {.type = BC_MSG_CAMERA};
		m.camera.up[1] = 1;
		m.camera.eye[2] = 5;
		m.camera.fov_y_deg = 45;
		m.seq = ++f->seq;
		bc_proto_buf_reset(&f->b);
		if (bc_proto_encode(&f->b, &m, NULL) == 0) {
			fz_write(f, f->b.data,
			         1 + rnd(&f->rng, (uint32_t)f->b.len - 1));
		}
		shutdown(f->fd, SHUT_WR);
		fz_drain(f, 2000);
	} else if (r < 80) {
		shutdown(f->fd, SHUT_WR);
		fz_drain(f, 2000);
	} else {
		for (int i = 0; i < 6 && !f->closed; i++) {
			act_small(f, false,
			          i % 2 ? BC_MSG_SNAPSHOT : BC_MSG_GET_STATS);
		}
		act_edit(f, false);
	}
	fz_close(f, abortive);
}

static void fz_connection(struct fz *f)
{
	static const uint32_t risks[] = {5, 20, 60, 200, 600};
	static const uint32_t lives[] = {8, 40, 200, 1000, 4000};
	uint64_t *s = &f->rng;
	uint32_t life = lives[rnd(s, 5)], every = 4 + rnd(s, 29), since = 0;
	f->risk = risks[rnd(s, 5)];
	fz_first(f);
	if (!f->closed) {
		act_enter(f, false);
	}
	for (uint32_t i = 0; i < life && !atomic_load(&stopping); i++) {
		uint32_t r;
		if (fz_wait_window(f)) {
			break;
		}
		r = rnd(s, 1000);
		if (r >= f->risk) {
			fz_message(f, false);
		} else if ((r = rnd(s, 100)) < 55) {
			fz_message(f, true);
		} else if (r < 70) {
			fz_random(f);
		} else {
			fz_vector(f);
		}
		if (f->closed) {
			break;
		}
		if (++since >= every) {
			fz_flow_ping(f);
			since = 0;
		}
	}
	fz_end(f);
}

static void *fz_main(void *arg)
{
	struct fz *f = arg;
	while (!atomic_load(&stopping)) {
		if (fz_open(f) != 0) {
			t_sleep_ms(50);
			continue;
		}
		if (opt.early_reset && pm(&f->rng, 50)) {
			/* Reset at once, most likely before the daemon
			 * accepted the connection. */
			atomic_fetch_add(&n_early_resets, 1);
			fz_close(f, true);
			continue;
		}
		fz_connection(f);
	}
	return NULL;
}

/* ---- the quiet client ------------------------------------------------------------ */

static struct conn monitor;
static bool monitor_up;

/* PINGs the daemon from a client in no session; false when no PONG came
 * within MONITOR_MS. */
static bool monitor_ping(void)
{
	struct bc_msg m = {.type = BC_MSG_PING};
	int64_t t0 = t_now_ms(), ms;
	uint32_t seq;
	if (!monitor_up) {
		if (conn_open_tcp(&monitor) != 0) {
			return false;
		}
		if (conn_hello(&monitor, "fuzz-monitor") != 0) {
			conn_close(&monitor);
			return false;
		}
		monitor_up = true;
	}
	atomic_fetch_add(&n_monitor_pings, 1);
	seq = conn_send(&monitor, &m);
	while (seq) {
		int left = (int)(t0 + MONITOR_MS - t_now_ms());
		if (left <= 0 ||
		    conn_expect(&monitor, BC_MSG_PONG, left) != 1) {
			break;
		}
		if (monitor.m.seq != seq) {
			continue;
		}
		ms = t_now_ms() - t0;
		if (ms > atomic_load(&monitor_max_ms)) {
			atomic_store(&monitor_max_ms, ms);
		}
		return true;
	}
	conn_close(&monitor);
	monitor_up = false;
	return false;
}

/* ---- a round of fuzzing ------------------------------------------------------------ */

static struct fz *fzs;

static long total_sent(void)
{
	long n = 0;
	for (int c = 0; c < CLS_COUNT; c++) {
		n += atomic_load(&n_sent[c]);
	}
	return n;
}

static long total_errors(void)
{
	long n = 0;
	for (int c = 0; c <= BC_ERR_COUNT; c++) {
		n += atomic_load(&n_errors[c]);
	}
	return n;
}

static void progress(double t, long sent_before, double dt)
{
	long sent = total_sent();
	printf(
	    "t=%.0fs sent=%ld (%.0f/s) valid=%ld mutated=%ld random=%ld "
	    "vector=%ld+%ld bytes=%.1fMiB conns=%ld answers: frames=%ld "
	    "errors=%ld fatal=%ld | bad=%ld stalls=%ld deaths=%d "
	    "monitor_max=%ldms\n",
	    t, sent, dt > 0 ? (double)(sent - sent_before) / dt : 0.0,
	    atomic_load(&n_sent[CLS_VALID]), atomic_load(&n_sent[CLS_MUTATED]),
	    atomic_load(&n_sent[CLS_RANDOM]), atomic_load(&n_sent[CLS_VECTOR]),
	    atomic_load(&n_sent[CLS_VECTOR_MUT]),
	    (double)atomic_load(&n_bytes) / 1048576.0, atomic_load(&n_connects),
	    atomic_load(&n_answers[BC_MSG_FRAME]), total_errors(),
	    atomic_load(&n_fatal), atomic_load(&n_bad_answers),
	    atomic_load(&n_stalls), deaths, atomic_load(&monitor_max_ms));
}

/* A death of the daemon during the round: counted, its log searched, and
 * the daemon started again so the round goes on. */
static void check_death(double t)
{
	int status;
	pid_t pid = dmn.pid;
	if (pid <= 0 || waitpid(pid, &status, WNOHANG) != pid) {
		return;
	}
	deaths++;
	daemon_track(pid, false);
	dmn.pid = 0;
	printf("t=%.0fs: THE DAEMON DIED (%s %d); log %s\n", t,
	       WIFSIGNALED(status) ? "signal" : "exit status",
	       WIFSIGNALED(status) ? WTERMSIG(status) : WEXITSTATUS(status),
	       log_paths[nstarts - 1]);
	log_reports(log_paths[nstarts - 1]);
	if (monitor_up) {
		conn_close(&monitor);
		monitor_up = false;
	}
	if (start_daemon() != 0) {
		printf("the daemon did not start again\n");
	}
}

static void run_round(double seconds)
{
	int64_t t0 = t_now_ms(), next = t0 + 10000, last = t0;
	long sent_last = total_sent();
	atomic_store(&stopping, false);
	/* The quiet client connects before the load. */
	if (!monitor_ping()) {
		atomic_fetch_add(&n_monitor_fail, 1);
	}
	for (int i = 0; i < opt.conns; i++) {
		pthread_create(&fzs[i].th, NULL, fz_main, &fzs[i]);
	}
	while (t_now_ms() - t0 < (int64_t)(seconds * 1000)) {
		t_sleep_ms(200);
		check_death((double)(t_now_ms() - t0) / 1000.0);
		if (t_now_ms() >= next) {
			if (!monitor_ping()) {
				atomic_fetch_add(&n_monitor_fail, 1);
				printf("the quiet client's PING was not "
				       "answered within %d s\n",
				       MONITOR_MS / 1000);
			}
			progress((double)(t_now_ms() - t0) / 1000.0, sent_last,
			         (double)(t_now_ms() - last) / 1000.0);
			sent_last = total_sent();
			last = t_now_ms();
			next += 10000;
		}
	}
	atomic_store(&stopping, true);
	for (int i = 0; i < opt.conns; i++) {
		pthread_join(fzs[i].th, NULL);
	}
	check_death((double)(t_now_ms() - t0) / 1000.0);
	progress((double)(t_now_ms() - t0) / 1000.0, sent_last,
	         (double)(t_now_ms() - last) / 1000.0);
}

/* ---- what the sessions hold ---------------------------------------------------------- */

struct state {
	char name[BC_PROTO_MAX_NAME + 1];
	uint64_t order;
	uint8_t *scene;
	uint32_t len;
	bool ok;
};

static void states_free(struct state *s, size_t n)
{
	for (size_t i = 0; s && i < n; i++) {
		bc_free(s[i].scene);
	}
	bc_free(s);
}

/* A fresh client: HELLO answered by WELCOME. */
static int fresh_client(struct conn *c)
{
	if (conn_open_tcp(c) != 0) {
		return -1;
	}
	if (conn_hello(c, "fuzz-check") != 0) {
		conn_close(c);
		return -1;
	}
	return 0;
}

/* JOINs (or CREATEs) name: 0 on SESSION_INFO, -1 on the ERROR for that
 * request (printed unless quiet) or nothing within 60 s. */
static int enter(struct conn *c, const char *name, enum bc_msg_type type,
                 bool quiet)
{
	struct bc_msg m = {.type = type};
	uint32_t seq;
	m.session.role = BC_PROTO_ROLE_VIEWER;
	m.session.name.ptr = name;
	m.session.name.len = (uint32_t)strlen(name);
	if (!(seq = conn_send(c, &m))) {
		return -1;
	}
	while (conn_recv(c, 60000) == 1) {
		if (c->m.type == BC_MSG_SESSION_INFO) {
			return 0;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			if (!quiet) {
				printf("%s %s refused: %s\n",
				       bc_proto_type_name(type), name,
				       bc_err_name(-(int)c->m.error.code));
			}
			return -1;
		}
	}
	return -1;
}

/* The daemon's sessions and their orders (UINT64_MAX where not known). */
static int list_sessions(struct state **out, size_t *n)
{
	struct conn c;
	struct bc_msg m = {.type = BC_MSG_SESSION_LIST};
	uint32_t seq;
	int rc = -1;
	*out = NULL;
	*n = 0;
	if (fresh_client(&c) != 0) {
		return -1;
	}
	seq = conn_send(&c, &m);
	while (seq && conn_expect(&c, BC_MSG_SESSIONS, 30000) == 1) {
		const struct bc_msg_sessions *ss = &c.m.sessions;
		if (c.m.seq != seq) {
			continue;
		}
		*out =
		    bc_calloc(ss->nsessions ? ss->nsessions : 1, sizeof(**out));
		if (!*out) {
			break;
		}
		for (uint16_t i = 0; i < ss->nsessions; i++) {
			const struct bc_proto_session_entry *e =
			    &ss->sessions[i];
			struct state *st = &(*out)[i];
			memcpy(st->name, e->name.ptr, e->name.len);
			st->order = (e->flags & BC_PROTO_SESSION_KNOWN)
			                ? e->order
			                : UINT64_MAX;
		}
		*n = ss->nsessions;
		rc = 0;
		break;
	}
	conn_close(&c);
	return rc;
}

/* Every session's SCENE_STATE as a fresh joiner gets it; repeated until
 * the list's orders agree with what was recorded (nothing changed
 * meanwhile). */
static int record_all(struct state **out, size_t *n)
{
	for (int attempt = 0; attempt < 5; attempt++) {
		struct state *s, *again;
		size_t ns, nagain;
		bool stable;
		if (list_sessions(&s, &ns) != 0) {
			return -1;
		}
		for (size_t i = 0; i < ns; i++) {
			struct conn c;
			if (fresh_client(&c) != 0) {
				continue;
			}
			if (enter(&c, s[i].name, BC_MSG_SESSION_JOIN, false) ==
			        0 &&
			    conn_expect(&c, BC_MSG_SCENE_STATE, 60000) == 1) {
				const struct bc_proto_bytes *b =
				    &c.m.scene_state.scene;
				s[i].order = c.m.scene_state.order;
				s[i].scene = bc_malloc(b->len ? b->len : 1);
				if (s[i].scene) {
					memcpy(s[i].scene, b->ptr, b->len);
					s[i].len = b->len;
					s[i].ok = true;
				}
			}
			conn_close(&c);
		}
		if (list_sessions(&again, &nagain) != 0) {
			states_free(s, ns);
			return -1;
		}
		stable = nagain == ns;
		for (size_t i = 0; stable && i < ns; i++) {
			stable = !strcmp(s[i].name, again[i].name) &&
			         (again[i].order == UINT64_MAX ||
			          again[i].order == s[i].order);
		}
		states_free(again, nagain);
		if (stable) {
			*out = s;
			*n = ns;
			return 0;
		}
		states_free(s, ns);
		t_sleep_ms(500);
	}
	return -1;
}

/* Sessions of before missing from after, or different; printed. */
static int compare(const char *what, const struct state *a, size_t na,
                   const struct state *b, size_t nb)
{
	int bad = 0;
	for (size_t i = 0; i < na; i++) {
		const struct state *x = &a[i], *y = NULL;
		for (size_t j = 0; j < nb && !y; j++) {
			y = !strcmp(b[j].name, x->name) ? &b[j] : NULL;
		}
		if (!x->ok) {
			printf("  %s: session %s could not be joined before "
			       "the restart\n",
			       what, x->name);
			bad++;
		} else if (!y || !y->ok) {
			printf("  %s: session %s (order %llu) is %s after the "
			       "restart\n",
			       what, x->name, (unsigned long long)x->order,
			       y ? "not joinable" : "gone");
			bad++;
		} else if (x->order != y->order || x->len != y->len ||
		           memcmp(x->scene, y->scene, x->len)) {
			size_t k = 0;
			while (k < x->len && k < y->len &&
			       x->scene[k] == y->scene[k]) {
				k++;
			}
			printf("  %s: session %s differs: order %llu -> %llu, "
			       "%u -> %u scene bytes, first difference at "
			       "byte %zu\n",
			       what, x->name, (unsigned long long)x->order,
			       (unsigned long long)y->order, x->len, y->len, k);
			bad++;
		}
	}
	if (nb > na) {
		printf("  %s: %zu sessions after the restart, %zu before\n",
		       what, nb, na);
		bad++;
	}
	return bad;
}

/* The daemon alive, and a fresh client served: WELCOME, then JOIN. */
static bool alive_and_serving(void)
{
	struct conn c;
	bool ok;
	if (dmn.pid <= 0 || waitpid(dmn.pid, NULL, WNOHANG) != 0) {
		printf("the daemon is not running\n");
		return false;
	}
	if (fresh_client(&c) != 0) {
		printf("a fresh client got no WELCOME\n");
		return false;
	}
	ok = enter(&c, "fz0", BC_MSG_SESSION_JOIN, false) == 0;
	if (!ok) {
		printf("a fresh client could not JOIN fz0\n");
	}
	conn_close(&c);
	return ok;
}

/* Records every session, stops the daemon with sig, starts it again on
 * the same data directory and compares. Returns the sessions that differ
 * (or 1000 when a step failed); *recorded gets how many were compared. */
static int restart_compare(int sig, const char *what, size_t *recorded,
                           int *stop_status)
{
	struct state *a, *b;
	size_t na, nb;
	int bad;
	*recorded = 0;
	if (record_all(&a, &na) != 0) {
		printf("%s: the sessions could not be recorded\n", what);
		return 1000;
	}
	*stop_status = daemon_stop(&dmn, sig);
	if (start_daemon() != 0) {
		printf("%s: the daemon did not start again\n", what);
		states_free(a, na);
		return 1000;
	}
	if (record_all(&b, &nb) != 0) {
		printf("%s: the sessions could not be recorded after the "
		       "restart\n",
		       what);
		states_free(a, na);
		return 1000;
	}
	bad = compare(what, a, na, b, nb);
	*recorded = na;
	printf("%s: %zu sessions recorded, %d differ after the restart\n", what,
	       na, bad);
	for (size_t i = 0; i < na; i++) {
		printf("  %-20s order %llu, %u scene bytes\n", a[i].name,
		       (unsigned long long)a[i].order, a[i].len);
	}
	states_free(a, na);
	states_free(b, nb);
	return bad;
}

/* ---- main ----------------------------------------------------------------------------- */

static void usage(FILE *f)
{
	fprintf(
	    f,
	    "usage: fuzz_live PATH/TO/blobcastd [options]\n"
	    "Starts blobcastd (on 127.0.0.1, a free TCP port) and attacks it\n"
	    "over TCP from concurrent connections: valid messages of every\n"
	    "client type, the same mutated, random bytes, and the messages\n"
	    "and scenes of the protocol's test vectors, as they are and\n"
	    "mutated; it reads every answer and reconnects when closed. A\n"
	    "summary every 10 s and at the end. Then: the daemon must be\n"
	    "alive and serve a fresh client; every session's SCENE_STATE is\n"
	    "recorded, the daemon stopped with SIGTERM and restarted, and the\n"
	    "sessions compared; a short second round, and the same with\n"
	    "SIGKILL. Exit status 0 when the daemon never died, its logs\n"
	    "(DIR.log.N) hold no sanitizer report, it never sent what the\n"
	    "client decoder refuses, a quiet client's PING was always\n"
	    "answered, SIGTERM stopped it cleanly and every session compared\n"
	    "equal; 1 otherwise, 2 on a usage or setup error.\n"
	    "  --duration S   seconds of the first round (default %.0f); the\n"
	    "                 second round lasts S / 10, from 2 to 30 s\n"
	    "  --conns N      concurrent connections, 1..%d (default %d)\n"
	    "  --seed X       seed of the choices (default: from the clock;\n"
	    "                 printed)\n"
	    "  --data DIR     the daemon's data directory (default: a fresh\n"
	    "                 /tmp/bc-fuzz-PID, removed after a clean run);\n"
	    "                 its socket is DIR.sock, its logs DIR.log.N\n"
	    "  --vectors DIR  the protocol's test vectors (default\n"
	    "                 %s)\n"
	    "  --early-reset  also reset connections (SO_LINGER 0) before\n"
	    "                 the daemon has answered them, when it may not\n"
	    "                 have accepted them yet (5%% of connections);\n"
	    "                 without it a connection is reset only after\n"
	    "                 the daemon sent it something\n",
	    opt.duration_s, MAX_CONNS, opt.conns, BC_FUZZ_VECTORS_DIR);
}

static int parse_args(int argc, char **argv)
{
	for (int i = 2; i < argc; i++) {
		const char *a = argv[i], *v;
		char *end;
		if (!strcmp(a, "--early-reset")) {
			opt.early_reset = true;
			continue;
		}
		if (i + 1 >= argc) {
			return -1;
		}
		v = argv[++i];
		if (!strcmp(a, "--duration")) {
			opt.duration_s = strtod(v, &end);
			if (*end || !(opt.duration_s >= 1)) {
				return -1;
			}
		} else if (!strcmp(a, "--conns")) {
			long n = strtol(v, &end, 10);
			if (*end || n < 1 || n > MAX_CONNS) {
				return -1;
			}
			opt.conns = (int)n;
		} else if (!strcmp(a, "--seed")) {
			opt.seed = strtoull(v, &end, 0);
			if (*end) {
				return -1;
			}
			opt.seed_given = true;
		} else if (!strcmp(a, "--data")) {
			opt.data = v;
		} else if (!strcmp(a, "--vectors")) {
			opt.vectors = v;
		} else {
			return -1;
		}
	}
	return 0;
}

static void print_summary(void)
{
	printf("messages sent: %ld (", total_sent());
	for (int c = 0; c < CLS_COUNT; c++) {
		printf("%s%s %ld", c ? ", " : "", cls_name[c],
		       atomic_load(&n_sent[c]));
	}
	printf("), %.1f MiB, %ld connections (%ld connects failed), %ld "
	       "messages the encoder refused to build\n",
	       (double)atomic_load(&n_bytes) / 1048576.0,
	       atomic_load(&n_connects), atomic_load(&n_connect_failed),
	       atomic_load(&n_encode_refused));
	printf("valid / mutated by type:");
	for (int t = 1; t < BC_MSG_COUNT; t++) {
		long v = atomic_load(&n_type_valid[t]);
		long m = atomic_load(&n_type_mutated[t]);
		if (v || m) {
			printf(" %s %ld/%ld", bc_proto_type_name(t), v, m);
		}
	}
	printf("\nanswers by type:");
	for (int t = 1; t < BC_MSG_COUNT; t++) {
		if (atomic_load(&n_answers[t])) {
			printf(" %s %ld", bc_proto_type_name(t),
			       atomic_load(&n_answers[t]));
		}
	}
	printf("\nerrors by code:");
	for (int c = 0; c <= BC_ERR_COUNT; c++) {
		if (atomic_load(&n_errors[c])) {
			printf(" %s %ld",
			       c < BC_ERR_COUNT ? bc_err_name(-c) : "other",
			       atomic_load(&n_errors[c]));
		}
	}
	printf("\nfatal errors %ld; links closed by the daemon %ld (%ld "
	       "without a fatal ERROR first); payload fillers sent %ld; "
	       "early resets %ld\n",
	       atomic_load(&n_fatal), atomic_load(&n_closed),
	       atomic_load(&n_closed_silent), atomic_load(&n_filler),
	       atomic_load(&n_early_resets));
	printf("connections given up after a risky message %ld; stalls "
	       "(clean PING unanswered %d s) %ld\n",
	       atomic_load(&n_given_up), STALL_MS / 1000,
	       atomic_load(&n_stalls));
	printf("quiet client: %ld PINGs, slowest PONG %ld ms, %ld "
	       "unanswered\n",
	       atomic_load(&n_monitor_pings), atomic_load(&monitor_max_ms),
	       atomic_load(&n_monitor_fail));
	printf("daemon messages the client decoder refused: %ld\n",
	       atomic_load(&n_bad_answers));
}

int main(int argc, char **argv)
{
	int64_t t0;
	double round2;
	size_t nterm = 0, nkill = 0;
	int bad_term, bad_kill, term_status = -1, kill_status = -1,
	                        last_status = -1;
	long reports = 0;
	bool alive1, alive2, pass;
	char cmd[512];
	(void)daemon_start;
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
	setvbuf(stdout, NULL, _IOLBF, 0);
	if (!opt.seed_given) {
		opt.seed = (uint64_t)time(NULL) * 1000003u ^ (uint64_t)getpid();
	}
	if (opt.data) {
		if (strlen(opt.data) >= sizeof(data_dir)) {
			fprintf(stderr, "--data: at most %zu characters\n",
			        sizeof(data_dir) - 1);
			return 2;
		}
		snprintf(data_dir, sizeof(data_dir), "%s", opt.data);
	} else {
		snprintf(data_dir, sizeof(data_dir), "/tmp/bc-fuzz-%d",
		         (int)getpid());
	}
	if (mkdir(data_dir, 0700) != 0 && errno != EEXIST) {
		fprintf(stderr, "cannot create %s\n", data_dir);
		return 2;
	}
	if (load_vectors(opt.vectors) < 0) {
		printf("warning: no test vectors read from %s\n", opt.vectors);
	}
	if (!(tcp_port = daemon_free_port())) {
		fprintf(stderr, "no free TCP port\n");
		return 2;
	}
	snprintf(listen_arg, sizeof(listen_arg), "127.0.0.1:%d", tcp_port);
	round2 = opt.duration_s / 10 < 2    ? 2
	         : opt.duration_s / 10 > 30 ? 30
	                                    : opt.duration_s / 10;
	printf("fuzz_live: %s, data %s, port %d, seed %llu (0x%llx)\n", argv[1],
	       data_dir, tcp_port, (unsigned long long)opt.seed,
	       (unsigned long long)opt.seed);
	printf("%d connections, %.0f s + %.0f s; %zu message vectors (%zu "
	       "of client types), %zu scene vectors from %s\n",
	       opt.conns, opt.duration_s, round2, nvecs, nclient_vecs, nscenes,
	       opt.vectors);
	if (start_daemon() != 0) {
		fprintf(stderr, "cannot start %s (log %s)\n", argv[1],
		        log_paths[0]);
		return 2;
	}
	for (int s = 0; s < NSESSIONS; s++) {
		struct conn c;
		char name[8];
		snprintf(name, sizeof(name), "fz%d", s);
		if (fresh_client(&c) != 0) {
			fprintf(stderr, "the daemon does not serve clients\n");
			daemon_stop(&dmn, SIGKILL);
			return 2;
		}
		/* EEXIST on a data directory used before is fine. */
		enter(&c, name, BC_MSG_SESSION_CREATE, true);
		conn_close(&c);
	}
	fzs = bc_calloc((size_t)opt.conns, sizeof(*fzs));
	if (!fzs) {
		return 2;
	}
	for (int i = 0; i < opt.conns; i++) {
		uint64_t s =
		    opt.seed ^ (0x51ed270b27a9c3f1ull * (uint64_t)(i + 1));
		fzs[i].index = i;
		fzs[i].rng = next_u64(&s);
		fzs[i].fd = -1;
		bc_proto_buf_init(&fzs[i].b, 0);
		bc_proto_buf_init(&fzs[i].sub, 0);
	}

	t0 = t_now_ms();
	printf("== round 1: %.0f s\n", opt.duration_s);
	run_round(opt.duration_s);
	if (monitor_up) {
		conn_close(&monitor);
		monitor_up = false;
	}
	alive1 = alive_and_serving();
	printf("after round 1: the daemon is %s\n",
	       alive1 ? "alive and serves a fresh client (WELCOME, JOIN)"
	              : "NOT SERVING");
	printf("== SIGTERM and restart\n");
	bad_term = restart_compare(SIGTERM, "SIGTERM", &nterm, &term_status);

	printf("== round 2: %.0f s\n", round2);
	run_round(round2);
	if (monitor_up) {
		conn_close(&monitor);
		monitor_up = false;
	}
	alive2 = alive_and_serving();
	printf("after round 2: the daemon is %s\n",
	       alive2 ? "alive and serves a fresh client" : "NOT SERVING");
	printf("== SIGKILL and restart\n");
	bad_kill = restart_compare(SIGKILL, "SIGKILL", &nkill, &kill_status);
	(void)kill_status;
	last_status = dmn.pid > 0 ? daemon_stop(&dmn, SIGTERM) : -1;

	printf("\n== fuzz_live summary (seed %llu, %d connections, %.0f s "
	       "in all)\n",
	       (unsigned long long)opt.seed, opt.conns,
	       (double)(t_now_ms() - t0) / 1000.0);
	print_summary();
	for (int i = 0; i < nstarts; i++) {
		reports += log_reports(log_paths[i]);
	}
	printf("daemon starts %d, deaths %d, sanitizer reports %ld\n", nstarts,
	       deaths, reports);
	printf("SIGTERM stops: after round 1 %s, at the end %s\n",
	       WIFEXITED(term_status) && WEXITSTATUS(term_status) == 0
	           ? "exit 0"
	           : "NOT CLEAN",
	       last_status >= 0 && WIFEXITED(last_status) &&
	               WEXITSTATUS(last_status) == 0
	           ? "exit 0"
	           : "NOT CLEAN");
	printf("SIGTERM restart: %zu sessions, %d differ; SIGKILL restart: "
	       "%zu sessions, %d differ\n",
	       nterm, bad_term, nkill, bad_kill);
	pass = deaths == 0 && reports == 0 && alive1 && alive2 &&
	       bad_term == 0 && bad_kill == 0 &&
	       atomic_load(&n_bad_answers) == 0 &&
	       atomic_load(&n_monitor_fail) == 0 && WIFEXITED(term_status) &&
	       WEXITSTATUS(term_status) == 0 && last_status >= 0 &&
	       WIFEXITED(last_status) && WEXITSTATUS(last_status) == 0;
	printf("result: %s\n", pass ? "PASS" : "FAIL");

	for (int i = 0; i < opt.conns; i++) {
		bc_proto_buf_finish(&fzs[i].b);
		bc_proto_buf_finish(&fzs[i].sub);
		bc_free(fzs[i].mb);
	}
	bc_free(fzs);
	for (size_t i = 0; i < nvecs; i++) {
		bc_free(vecs[i].bytes);
	}
	for (size_t i = 0; i < nscenes; i++) {
		bc_free(scenes[i].bytes);
	}
	bc_free(vecs);
	bc_free(scenes);
	bc_free(client_vecs);
	if (pass && !opt.data) {
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock %s.log.*",
		         data_dir, data_dir, data_dir);
		if (system(cmd) != 0) {
			printf("could not remove %s\n", data_dir);
		}
	} else {
		printf("data directory and logs kept: %s, %s.log.0 .. %d\n",
		       data_dir, data_dir, nstarts - 1);
	}
	return pass ? 0 : 1;
}
