/*
 * bench_fair: several clients against one blobcastd, to judge how the
 * daemon shares itself between sessions. It is written from
 * protocol/PROTOCOL.md alone: every client is a raw protocol connection
 * (tests/server/daemon.h) driven by a thread of its own, never the client
 * library, so that the same program measures today's daemon ("before")
 * and the scheduler's ("after") without knowing either's insides.
 *
 * Scenarios (--help says what each one plays and which bounds it checks):
 *  fairness  a small probe session's edit -> frame and PING round trips,
 *            alone, beside three heavy sessions, and in the 2 s after
 *            they leave; the daemon's loop maxima over the heavy phase;
 *  twist     the probe beside a session whose scene is slow to trace;
 *  mesh      the probe beside a client that keeps the daemon meshing;
 *  capacity  1 to 16 sessions, each dragging a sphere;
 *  scaling   one orbiting client, --render-threads 1 against 2;
 *  loop      one structural edit of the largest scene the daemon takes;
 *  memory    28 views of one client, then the daemon's RSS.
 *
 * Every wait has a timeout, every scenario an alarm that kills its daemon
 * when it runs far over its time, and every daemon is killed with SIGKILL
 * at the end of its scenario. Latencies are in milliseconds; percentiles
 * are nearest rank over all samples of a phase. An answer still missing
 * when a client stops (a frame the daemon never sent) counts as a sample
 * of the time waited so far, marked "censored": it is a lower bound.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

/* scene.h before daemon.h: daemon.h then offers scene_of(). */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "../tests/server/daemon.h"
#include "latency.h"

#if defined(__GNUC__)
#define FAIR_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define FAIR_PRINTF(a, b)
#endif

/* ---- What the clients do (the figures) --------------------------- */

/* The probe: fig18 of 64 smooth spheres in a 640x480 JPEG view, one
 * sphere moved 20 times a second, a PING every 50 ms. */
#define PROBE_SPHERES 64u
#define PROBE_W 640
#define PROBE_H 480
#define EDIT_PERIOD_US 50000
#define PING_PERIOD_US 50000
/* PINGs in flight a client remembers, to count those never answered:
 * 200 s of a loop that answers nothing at 20 a second, 40 s at 100. */
#define PING_RING 4096u
/* A client told to stop waits this long for the answers in flight before
 * counting them as censored: a frame 2 s late is measured, not guessed. */
#define DRAIN_US 2000000

/* Heavy session A: 100 000 spheres, a 1600x1200 view, EDITs of 1024 SET
 * operations 20 times a second, at most 4 of them unacknowledged. */
#define A_SPHERES 100000u
#define A_W 1600
#define A_H 1200
#define A_OPS 1024u
#define A_PERIOD_US 50000
#define A_WINDOW 4u
/* Each moved sphere lands within this distance of its place on each axis:
 * a third to a half of a sphere's radius at 100 000 spheres. */
#define A_JITTER 0.01f

/* Heavy session B: 4096 spheres, 8 PNG snapshots with depth and ids of a
 * 2048x2048 view always outstanding. */
#define B_SPHERES 4096u
#define B_DIM 2048
#define B_SNAPSHOTS 8u

/* Heavy session C: 20 000 spheres, a new VIEW (two sizes around 1280x960
 * in turn) and a new orbit CAMERA every 30 ms. */
#define C_SPHERES 20000u
#define C_PERIOD_US 30000
#define C_ORBIT_STEP 0.05

/* After the heavy clients leave: 2 s in buckets of 0.5 s. */
#define RECOVERY_US 2000000
#define RECOVERY_BUCKETS 4

/* twist: twist(sphere) at the largest rate a scene may hold (|values| <=
 * 10^6), in an 800x600 view whose first frame is due within 5 s. */
#define TWIST_RATE 1.0e6f
#define TWIST_RATE_NAME "1e6"
#define TWIST_W 800
#define TWIST_H 600
#define TWIST_BOUND_MS 5000.0

/* capacity: sessions of fig18 1024 smooth, each one member dragging a
 * sphere in a 1024x768 JPEG view; every session's p99 within 50 ms. */
#define CAP_SPHERES 1024u
#define CAP_W 1024
#define CAP_H 768
#define CAP_P99_MS 50.0
static const int cap_sessions[] = {1, 2, 4, 8, 16};

/* scaling: an orbit of fig18 1024 smooth at 1024x768 JPEG. */
#define SCALE_SPHERES 1024u
#define SCALE_W 1024
#define SCALE_H 768
#define SCALE_STEP 0.1
/* A camera whose frame has not come in this long is given up on. */
#define SCALE_GIVE_UP_MS 5000

/* loop: a structural edit of 700 000 spheres (or the most the daemon
 * takes), watched by a second client that PINGs every 10 ms. */
#define LOOP_SPHERES 700000u
#define LOOP_W 640
#define LOOP_H 480
#define LOOP_PING_PERIOD_US 10000
#define LOOP_LOAD_TRIES 4
/* The inserted sphere's id: the generators number nodes 1, 2, ... and a
 * scene has at most 2^22 - 1 nodes, so no generated scene uses it. */
#define INSERT_ID 0x7f000001u

/* memory: 16 views of 64x64, then 12 of 4096x4096; RSS within the view
 * cache's cap plus 150 MiB. */
#define MEM_SMALL_VIEWS 16
#define MEM_SMALL_DIM 64
#define MEM_BIG_VIEWS 12
#define MEM_BIG_DIM 4096
#define MEM_SLACK_MIB 150.0

/* ---- Timeouts ------------------------------------------------------------ */

/* A scene of up to a few thousand spheres loads in well under a second;
 * 100 000 take seconds, 700 000 may take a minute on a loaded machine. */
#define SMALL_LOAD_MS 60000
#define BIG_LOAD_MS 300000
/* The first still of a view: seconds for the probe, minutes at most for
 * 700 000 spheres on two shared cores. */
#define STILL_MS 120000
#define BIG_STILL_MS 300000
#define STATS_MS 10000
/* A blocked send fails after this long instead of hanging: a daemon that
 * reads nothing for a minute is a finding, not a reason to wait. */
#define SEND_TIMEOUT_S 60
/* Time for the daemon to listen after it was started. */
#define START_MS 30000
/* Each scenario's alarm: its own time plus this margin for loads and
 * stills. Past it the daemon is killed and every client fails at once. */
#define ALARM_MARGIN_S 900

#define ERRLEN 256
#define MAX_DAEMON_ARGS 32
#define MAX_SCENARIOS 16

/* ---- Options and output -------------------------------------------------- */

static struct {
	const char *args[MAX_DAEMON_ARGS];
	int nargs;
	const char *scenarios[MAX_SCENARIOS];
	int nscenarios;
	double seconds;
	const char *out;
} opt = {.seconds = 10.0};

static FILE *out_copy;
static int64_t bench_t0;

static int64_t now_us(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static int64_t seconds_us(double s)
{
	return (int64_t)(s * 1e6);
}

/* The report: stdout, and the --out file when there is one. */
static void FAIR_PRINTF(1, 2) report(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	if (out_copy) {
		va_list again;
		va_copy(again, ap);
		vfprintf(out_copy, fmt, again);
		va_end(again);
	}
	vprintf(fmt, ap);
	va_end(ap);
}

/* Progress goes to stderr, stamped with the time since the start, so that
 * a long load is seen to be a load and not a hang. */
static void FAIR_PRINTF(1, 2) progress(const char *fmt, ...)
{
	va_list ap;
	fprintf(stderr, "[%7.1f s] ", (double)(now_us() - bench_t0) / 1e6);
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fputc('\n', stderr);
}

/* Something that could not be measured: a line of the report, and the
 * exit status 1. */
static int errors;

static void FAIR_PRINTF(1, 2) error_line(const char *fmt, ...)
{
	char line[2 * ERRLEN];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(line, sizeof(line), fmt, ap);
	va_end(ap);
	report("- error: %s\n", line);
	errors++;
}

static void FAIR_PRINTF(2, 3) seterr(char *err, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(err, ERRLEN, fmt, ap);
	va_end(ap);
}

/* Sleeps until t (now_us() time); signals do not cut it short. */
static void sleep_until(int64_t t)
{
	for (int64_t left; (left = t - now_us()) > 0;) {
		t_sleep_ms(left > 100000 ? 100 : (long)((left + 999) / 1000));
	}
}

/* Milliseconds from now to t, between 0 and cap, rounded up so that a
 * poll does not wake just before t and spin. */
static int ms_until(int64_t t, int cap)
{
	int64_t d = t - now_us();
	if (d <= 0) {
		return 0;
	}
	d = (d + 999) / 1000;
	return d > cap ? cap : (int)d;
}

/* ---- Samples and percentiles --------------------------------------------- */

struct sample {
	int64_t t_us;   /* when the request was sent */
	int64_t lat_us; /* until its answer, or until given up (censored) */
	bool censored;
};

struct series {
	struct sample *v;
	size_t n, cap;
};

static void series_add(struct series *s, int64_t t, int64_t lat, bool censored)
{
	if (s->n == s->cap) {
		size_t c = s->cap ? 2 * s->cap : 1024;
		struct sample *p = bc_realloc(s->v, c * sizeof(*p));
		if (!p) {
			return;
		}
		s->v = p;
		s->cap = c;
	}
	s->v[s->n++] = (struct sample){t, lat, censored};
}

static void series_finish(struct series *s)
{
	bc_free(s->v);
	memset(s, 0, sizeof(*s));
}

/* Milliseconds; n == 0: no sample. */
struct summary {
	size_t n, censored;
	double p50, p99, max;
};

/* The nearest-rank p-th percentile of n sorted values. */
static int64_t rank(const int64_t *v, size_t n, unsigned p)
{
	size_t k = (n * p + 99) / 100;
	return v[k > 0 ? k - 1 : 0];
}

/* Summarizes the samples sent in [from, to). */
static void summarize(const struct series *s, int64_t from, int64_t to,
                      struct summary *out)
{
	int64_t *v = bc_calloc(s->n ? s->n : 1, sizeof(int64_t));
	size_t n = 0, cens = 0;
	memset(out, 0, sizeof(*out));
	if (!v) {
		return;
	}
	for (size_t i = 0; i < s->n; i++) {
		if (s->v[i].t_us >= from && s->v[i].t_us < to) {
			v[n++] = s->v[i].lat_us;
			cens += s->v[i].censored;
		}
	}
	if (n > 0) {
		qsort(v, n, sizeof(int64_t), latency_cmp_i64);
		out->n = n;
		out->censored = cens;
		out->p50 = (double)rank(v, n, 50) / 1e3;
		out->p99 = (double)rank(v, n, 99) / 1e3;
		out->max = (double)v[n - 1] / 1e3;
	}
	bc_free(v);
}

/* "p50 / p99 / max" or "-" when there is no sample. */
static const char *fmt3(char *buf, size_t n, const struct summary *s)
{
	if (s->n == 0) {
		snprintf(buf, n, "-");
	} else {
		snprintf(buf, n, "%.1f / %.1f / %.1f", s->p50, s->p99, s->max);
	}
	return buf;
}

/* One greppable line per measurement: RESULT scenario=S phase=P what=W,
 * then key=value pairs. */
static void result_summary(const char *scenario, const char *phase,
                           const char *what, const struct summary *s)
{
	report("RESULT scenario=%s phase=%s what=%s n=%zu censored=%zu",
	       scenario, phase, what, s->n, s->censored);
	if (s->n > 0) {
		report(" p50_ms=%.1f p99_ms=%.1f max_ms=%.1f", s->p50, s->p99,
		       s->max);
	}
	report("\n");
}

/* A bound: PASS when value <= limit. how says where limit comes from
 * (NULL: limit is a constant). */
static bool bound(const char *scenario, const char *what, bool have,
                  double value, double limit, const char *how)
{
	bool ok = have && value <= limit;
	if (!have) {
		report("FAIL %s: %s: not measured (no sample)\n", scenario,
		       what);
	} else if (how) {
		report("%s %s: %s %.1f ms <= %s = %.1f ms\n",
		       ok ? "PASS" : "FAIL", scenario, what, value, how, limit);
	} else {
		report("%s %s: %s %.1f ms <= %.1f ms\n", ok ? "PASS" : "FAIL",
		       scenario, what, value, limit);
	}
	return ok;
}

/* ---- The daemon ---------------------------------------------------------- */

/* The daemon being measured, for the signal handlers: SIGALRM (a scenario
 * far over its time) and SIGINT or SIGTERM (we are stopped) kill it. */
static volatile sig_atomic_t live_pid;
static volatile sig_atomic_t alarm_fired;
static int daemon_serial;

static void on_alarm(int sig)
{
	(void)sig;
	alarm_fired = 1;
	if (live_pid > 0) {
		kill((pid_t)live_pid, SIGKILL);
	}
}

static void on_stop(int sig)
{
	if (live_pid > 0) {
		kill((pid_t)live_pid, SIGKILL);
	}
	_exit(128 + sig);
}

static void log_path(const struct daemon *d, char *buf, size_t n)
{
	snprintf(buf, n, "%s.log", d->dir);
}

/* The last two non-empty lines of the daemon's log, joined (its reason,
 * when it exits at start, and what it added), into buf. */
static void log_tail(const struct daemon *d, char *buf, size_t n)
{
	char path[128], line[512], last[2][512] = {"", ""};
	FILE *f;
	buf[0] = '\0';
	log_path(d, path, sizeof(path));
	if (!(f = fopen(path, "r"))) {
		return;
	}
	while (fgets(line, sizeof(line), f)) {
		size_t len = strcspn(line, "\n");
		line[len] = '\0';
		if (len > 0) {
			memcpy(last[0], last[1], sizeof(last[0]));
			memcpy(last[1], line, len + 1);
		}
	}
	fclose(f);
	snprintf(buf, n, "%.200s%s%.200s", last[0], last[0][0] ? " " : "",
	         last[1]);
}

/* Lines of the daemon's log that contain needle (-1: no log); the first
 * of them, from needle on, into first. */
static long log_first(const struct daemon *d, const char *needle, char *first,
                      size_t n)
{
	char path[128], line[1024];
	long count = 0;
	FILE *f;
	first[0] = '\0';
	log_path(d, path, sizeof(path));
	if (!(f = fopen(path, "r"))) {
		return -1;
	}
	while (fgets(line, sizeof(line), f)) {
		char *at = strstr(line, needle);
		if (at && count++ == 0) {
			at[strcspn(at, "\n")] = '\0';
			snprintf(first, n, "%s", at);
		}
	}
	fclose(f);
	return count;
}

/* Removes the daemon's directory and socket, and its log unless keep (or
 * BENCH_FAIR_KEEP_LOGS is set in the environment, to read them after). */
static void rm_daemon_files(const struct daemon *d, bool keep)
{
	char cmd[512], lp[128];
	log_path(d, lp, sizeof(lp));
	keep = keep || getenv("BENCH_FAIR_KEEP_LOGS") != NULL;
	snprintf(cmd, sizeof(cmd), "rm -rf %s %s%s%s", d->dir, d->sock,
	         keep ? "" : " ", keep ? "" : lp);
	if (system(cmd) != 0) {
		progress("could not remove %s", d->dir);
	}
}

/*
 * Starts the daemon on a fresh directory /tmp/bc-fair-PID-N with its log
 * in DIR.log: the options daemon.h gives, then every --daemon-arg, then
 * extra (NULL-terminated, may be NULL). daemon.h's daemon_start_with takes
 * four extra options and waits 10 s for a daemon that has already exited;
 * this one takes any number and notices at once. Returns 0 once the socket
 * accepts; -1 with the reason in why, and *exited set when the daemon
 * exited by itself (an option it refuses). After a failure nothing of it
 * is left but the log of a daemon that never listened (why names it).
 */
static int fair_start(struct daemon *d, const char *const *extra, char *why,
                      bool *exited)
{
	const char *argv[16 + MAX_DAEMON_ARGS];
	char lp[128];
	int argc = 0, status;
	int64_t end;
	memset(d, 0, sizeof(*d));
	*exited = false;
	snprintf(d->dir, sizeof(d->dir), "/tmp/bc-fair-%d-%d", (int)getpid(),
	         ++daemon_serial);
	snprintf(d->sock, sizeof(d->sock), "%s.sock", d->dir);
	log_path(d, lp, sizeof(lp));
	if (mkdir(d->dir, 0700) != 0) {
		seterr(why, "cannot create %s: %s", d->dir, strerror(errno));
		return -1;
	}
	argv[argc++] = "blobcastd";
	argv[argc++] = "--listen";
	argv[argc++] = "none";
	argv[argc++] = "--unix";
	argv[argc++] = d->sock;
	argv[argc++] = "--data";
	argv[argc++] = d->dir;
	argv[argc++] = "--log";
	argv[argc++] = "info";
	for (int i = 0; i < opt.nargs; i++) {
		argv[argc++] = opt.args[i];
	}
	for (int i = 0; extra && extra[i] && argc < 15 + MAX_DAEMON_ARGS; i++) {
		argv[argc++] = extra[i];
	}
	argv[argc] = NULL;
	d->pid = fork();
	if (d->pid < 0) {
		seterr(why, "fork: %s", strerror(errno));
		return -1;
	}
	if (d->pid == 0) {
		int log = open(lp, O_WRONLY | O_CREAT | O_TRUNC, 0600);
		int devnull = open("/dev/null", O_WRONLY);
		if (devnull >= 0) {
			dup2(devnull, 1);
		}
		if (log >= 0) {
			dup2(log, 2);
		}
		/* execv's argv is char *const[]: the strings are not
		 * written. */
		execv(daemon_path, (char *const *)argv);
		fprintf(stderr, "cannot run %s: %s\n", daemon_path,
		        strerror(errno));
		_exit(127);
	}
	live_pid = d->pid;
	end = now_us() + (int64_t)START_MS * 1000;
	while (now_us() < end) {
		struct conn c;
		if (waitpid(d->pid, &status, WNOHANG) == d->pid) {
			char tail[512];
			log_tail(d, tail, sizeof(tail));
			seterr(why,
			       "the daemon exited at start (%s %d): \"%s\"",
			       WIFSIGNALED(status) ? "signal" : "status",
			       WIFSIGNALED(status) ? WTERMSIG(status)
			                           : WEXITSTATUS(status),
			       tail);
			live_pid = 0;
			d->pid = 0;
			*exited = true;
			/* The reason is in why: nothing to keep. */
			rm_daemon_files(d, false);
			return -1;
		}
		if (conn_open(&c, d) == 0) {
			conn_close(&c);
			return 0;
		}
		t_sleep_ms(20);
	}
	seterr(why, "the daemon did not listen on %s within %d s (its log: %s)",
	       d->sock, START_MS / 1000, lp);
	live_pid = 0;
	daemon_stop(d, SIGKILL);
	rm_daemon_files(d, true);
	return -1;
}

/*
 * Kills the daemon (SIGKILL: nothing of it is measured after its
 * scenario, and a render thread stuck in a slow scene would not stop for
 * SIGTERM) and removes its directory and socket; its log too, unless keep.
 * Reports a daemon that had died by itself before. Accepts a daemon that
 * never started.
 */
static void fair_stop(struct daemon *d, const char *scenario, bool keep)
{
	char lp[128];
	int status = 0;
	log_path(d, lp, sizeof(lp));
	live_pid = 0;
	if (d->pid > 0) {
		if (waitpid(d->pid, &status, WNOHANG) == d->pid) {
			char tail[512];
			log_tail(d, tail, sizeof(tail));
			error_line("%s: the daemon had died by itself "
			           "(%s %d) before the end; its log ends: "
			           "\"%s\" (log kept: %s)",
			           scenario,
			           WIFSIGNALED(status) ? "signal" : "status",
			           WIFSIGNALED(status) ? WTERMSIG(status)
			                               : WEXITSTATUS(status),
			           tail, lp);
			keep = true;
			d->pid = 0;
		} else {
			daemon_stop(d, SIGKILL);
		}
	}
	if (d->dir[0]) {
		rm_daemon_files(d, keep);
	}
}

/* A scenario's alarm: the daemon is killed when it is still running
 * seconds from now. */
static void arm_alarm(double seconds)
{
	alarm_fired = 0;
	alarm((unsigned)(seconds + ALARM_MARGIN_S));
}

static void disarm_alarm(const char *scenario)
{
	alarm(0);
	if (alarm_fired) {
		error_line("%s ran past its time limit; its daemon was "
		           "killed",
		           scenario);
	}
}

/* ---- Connections and messages -------------------------------------------- */

/* Connects and says HELLO (every encoding, the server's frame limit).
 * Sends time out after SEND_TIMEOUT_S. Returns 0, or -1 with the reason
 * in err (c is then closed). */
static int client_open(struct conn *c, const struct daemon *d, const char *name,
                       char *err)
{
	struct timeval tv = {.tv_sec = SEND_TIMEOUT_S};
	if (conn_open(c, d) != 0) {
		seterr(err, "%s: cannot connect to %s: %s", name, d->sock,
		       strerror(errno));
		c->fd = -1;
		return -1;
	}
	setsockopt(c->fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof(tv));
	if (conn_hello(c, name) != 0) {
		seterr(err, "%s: no WELCOME within 5 s", name);
		conn_close(c);
		return -1;
	}
	return 0;
}

/* Connects, then creates (or joins) session as its editor. *member: the
 * member id SESSION_INFO gave. */
static int client_session(struct conn *c, const struct daemon *d,
                          const char *name, const char *session, bool create,
                          uint32_t *member, char *err)
{
	if (client_open(c, d, name, err) != 0) {
		return -1;
	}
	if (conn_join(c, session, BC_PROTO_ROLE_EDITOR, create) != 0) {
		seterr(err, "%s: no SESSION_INFO for %s of session %s in 5 s",
		       name, create ? "SESSION_CREATE" : "SESSION_JOIN",
		       session);
		conn_close(c);
		return -1;
	}
	*member = c->m.session_info.member_id;
	return 0;
}

/* The text of the ERROR in c->m: "ENAME: sentence". */
static void error_text(const struct conn *c, char *buf, size_t n)
{
	snprintf(buf, n, "%s: %.*s", bc_err_name(-(int)c->m.error.code),
	         (int)c->m.error.text.len, c->m.error.text.ptr);
}

/* Why conn_recv said -1: the daemon closed, or the reader refused. */
static void closed_text(const struct conn *c, char *buf, size_t n)
{
	if (c->r.err) {
		snprintf(buf, n, "protocol error %s: %.200s",
		         bc_err_name(c->r.err), c->r.errstr);
	} else {
		snprintf(buf, n, "the daemon closed the connection");
	}
}

/* A CAMERA on base's orbit about its target (y up), angle radians on. */
static uint32_t send_orbit(struct conn *c, const struct bc_camera *base,
                           double angle, bool interacting)
{
	struct bc_msg m = {.type = BC_MSG_CAMERA};
	double dx = base->eye[0] - base->target[0];
	double dz = base->eye[2] - base->target[2];
	double r = sqrt(dx * dx + dz * dz), a0 = atan2(dx, dz);
	if (r < 1e-3) {
		r = 1.0;
	}
	m.flags = interacting ? BC_PROTO_FLAG_INTERACTING : 0;
	m.camera.eye[0] = (float)(base->target[0] + r * sin(a0 + angle));
	m.camera.eye[1] = base->eye[1];
	m.camera.eye[2] = (float)(base->target[2] + r * cos(a0 + angle));
	memcpy(m.camera.target, base->target, sizeof(m.camera.target));
	m.camera.up[1] = 1.0f;
	m.camera.fov_y_deg = base->fov_y_deg;
	return conn_send(c, &m);
}

static uint32_t send_ping(struct conn *c, int64_t stamp)
{
	struct bc_msg m = {.type = BC_MSG_PING};
	m.ping.stamp = (uint64_t)stamp;
	return conn_send(c, &m);
}

/* GET_STATS with parts; the answer into *out. Returns 0, or -1 with the
 * reason in err. */
static int get_stats(struct conn *c, uint8_t parts, struct bc_msg_stats *out,
                     char *err)
{
	struct bc_msg m = {.type = BC_MSG_GET_STATS};
	int64_t end = now_us() + (int64_t)STATS_MS * 1000;
	uint32_t seq;
	m.get_stats.parts = parts;
	memset(out, 0, sizeof(*out));
	if (!(seq = conn_send(c, &m))) {
		seterr(err, "GET_STATS could not be sent");
		return -1;
	}
	while (now_us() < end) {
		int rc = conn_recv(c, ms_until(end, 1000));
		if (rc < 0) {
			char why[ERRLEN];
			closed_text(c, why, sizeof(why));
			seterr(err, "GET_STATS: %s", why);
			return -1;
		}
		if (rc == 1 && c->m.type == BC_MSG_STATS && c->m.seq == seq) {
			*out = c->m.stats;
			return 0;
		}
		if (rc == 1 && c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			char why[ERRLEN];
			error_text(c, why, sizeof(why));
			seterr(err, "GET_STATS refused: %s", why);
			return -1;
		}
	}
	seterr(err, "no STATS within %d s", STATS_MS / 1000);
	return -1;
}

/* ---- Scenes -------------------------------------------------------------- */

struct scene {
	struct bc_tree *t;
	struct bc_camera cam;
	uint32_t count; /* spheres */
	const char *what;
	char what_buf[48];
	double load_s; /* SCENE_LOAD to its SCENE_STATE */
	bool refused;  /* the daemon answered the load with ERROR */
};

static void scene_finish(struct scene *s)
{
	bc_tree_destroy(s->t);
	s->t = NULL;
}

/* fig18 of count spheres. Returns 0 or -1 with the reason in err. */
static int scene_fig18(struct scene *s, uint32_t count, enum bc_gen_blend blend,
                       char *err)
{
	struct bc_gen_opts o = {
	    .count = count, .kind = BC_GEN_KIND_SPHERES, .blend = blend};
	struct bc_errinfo ei = {0};
	memset(s, 0, sizeof(*s));
	s->count = count;
	snprintf(s->what_buf, sizeof(s->what_buf), "fig18 %u %s", count,
	         blend == BC_GEN_BLEND_SHARP ? "sharp" : "smooth");
	s->what = s->what_buf;
	if (!(s->t = bc_tree_create()) ||
	    bc_gen("fig18", &o, s->t, &s->cam, &ei)) {
		seterr(err, "cannot generate %s: %s", s->what, ei.msg);
		scene_finish(s);
		return -1;
	}
	return 0;
}

/* twist(sphere) at TWIST_RATE, seen by the default camera. */
static int scene_twist(struct scene *s, char *err)
{
	struct bc_errinfo ei = {0};
	struct bc_unary u;
	struct bc_prim_data sphere;
	memset(s, 0, sizeof(*s));
	s->count = 1;
	snprintf(s->what_buf, sizeof(s->what_buf), "twist(sphere), rate %s",
	         TWIST_RATE_NAME);
	s->what = s->what_buf;
	bc_camera_default(&s->cam);
	bc_unary_init(&u, BC_OP_TWIST);
	u.u[0] = TWIST_RATE;
	bc_prim_data_init(&sphere, BC_PRIM_SPHERE);
	if (!(s->t = bc_tree_create()) || bc_tree_begin(s->t) ||
	    bc_tree_push_unary(s->t, 1, &u, &ei) ||
	    bc_tree_put_prim(s->t, 2, &sphere, &ei) ||
	    bc_tree_pop_op(s->t, &ei) || bc_tree_end(s->t, &ei)) {
		seterr(err, "cannot build %s: %s", s->what, ei.msg);
		scene_finish(s);
		return -1;
	}
	return 0;
}

/* The id and position of the middle sphere (as latency.h picks it). */
static void scene_middle(const struct scene *s, uint32_t *id, float pos[3])
{
	const struct bc_lin *l = bc_tree_lin(s->t);
	struct bc_prim_data p;
	*id = l->node_id[l->prim_slot[l->nprims / 2]];
	bc_tree_get(s->t, *id, &p, NULL);
	memcpy(pos, p.translate, sizeof(p.translate));
}

/*
 * SCENE_LOAD of s, waiting up to timeout_ms for the SCENE_STATE that
 * answers it (the one whose author_seq is the load's: a join's own
 * SCENE_STATE comes first and is not it). Sets s->load_s. Returns 0, or
 * a negative BC_E* code with the reason in err: the daemon's refusal
 * (then s->refused is set), BC_ETIMEOUT (no answer in time), BC_ECLOSED
 * (the connection ended) or BC_ENOMEM.
 */
static int scene_load(struct conn *c, struct scene *s, int timeout_ms,
                      char *err)
{
	uint8_t *bytes = NULL;
	size_t len = 0;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	int64_t t0, end;
	uint32_t seq;
	if (bc_scene_encode(s->t, &s->cam, &bytes, &len)) {
		seterr(err, "cannot encode %s", s->what);
		return BC_ENOMEM;
	}
	m.scene_load.scene.ptr = bytes;
	m.scene_load.scene.len = (uint32_t)len;
	t0 = now_us();
	seq = conn_send(c, &m);
	bc_free(bytes);
	if (!seq) {
		seterr(err,
		       "SCENE_LOAD of %s (%zu bytes) could not be sent: %s",
		       s->what, len, strerror(errno));
		return BC_ECLOSED;
	}
	end = t0 + (int64_t)timeout_ms * 1000;
	while (now_us() < end) {
		int rc = conn_recv(c, ms_until(end, 1000));
		if (rc < 0) {
			char why[ERRLEN];
			closed_text(c, why, sizeof(why));
			seterr(err, "loading %s: %s", s->what, why);
			return BC_ECLOSED;
		}
		if (rc == 1 && c->m.type == BC_MSG_SCENE_STATE &&
		    c->m.scene_state.author_seq == seq) {
			s->load_s = (double)(now_us() - t0) / 1e6;
			return 0;
		}
		if (rc == 1 && c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			char why[ERRLEN];
			error_text(c, why, sizeof(why));
			seterr(err, "the daemon refused %s: %s", s->what, why);
			s->refused = true;
			return -(int)c->m.error.code;
		}
	}
	seterr(err, "no SCENE_STATE for %s within %d s", s->what,
	       timeout_ms / 1000);
	return BC_ETIMEOUT;
}

/* Waits for a FRAME with flag STILL; 0, or -1 with the reason in err. */
static int wait_still(struct conn *c, int timeout_ms, const char *who,
                      char *err)
{
	int64_t end = now_us() + (int64_t)timeout_ms * 1000;
	while (now_us() < end) {
		int rc = conn_recv(c, ms_until(end, 1000));
		if (rc < 0) {
			char why[ERRLEN];
			closed_text(c, why, sizeof(why));
			seterr(err, "%s, waiting for its first still: %s", who,
			       why);
			return -1;
		}
		if (rc == 1 && c->m.type == BC_MSG_FRAME &&
		    (c->m.flags & BC_PROTO_FLAG_STILL)) {
			return 0;
		}
		if (rc == 1 && c->m.type == BC_MSG_ERROR) {
			char why[ERRLEN];
			error_text(c, why, sizeof(why));
			seterr(err, "%s, waiting for its first still: %s", who,
			       why);
			return -1;
		}
	}
	seterr(err, "%s: no still frame within %d s", who, timeout_ms / 1000);
	return -1;
}

/* ---- The probe: an editor timing each edit to its frame ------------------ */

struct probe {
	/* Set before its thread starts. */
	char name[24];
	bool interacting; /* its edits are a drag */
	uint32_t prim;    /* the sphere it moves */
	float base[3];    /* that sphere's place */
	struct conn c;
	uint32_t member;
	struct scene sc;
	/* Written by its thread, read once it has ended. */
	struct series edits, pings;
	long frames, refused;
	char err[ERRLEN];
	atomic_bool stop;
	pthread_t th;
	bool running;
};

/* Connects p, creates session with fig18 count smooth, opens a w x h
 * JPEG view and waits for its first still. Returns 0 or -1 (p->err). */
static int probe_setup(struct probe *p, const struct daemon *d,
                       const char *name, const char *session, uint32_t count,
                       uint16_t w, uint16_t h, bool interacting)
{
	memset(p, 0, sizeof(*p));
	p->c.fd = -1;
	snprintf(p->name, sizeof(p->name), "%s", name);
	p->interacting = interacting;
	atomic_init(&p->stop, false);
	if (client_session(&p->c, d, name, session, true, &p->member, p->err) ||
	    scene_fig18(&p->sc, count, BC_GEN_BLEND_SMOOTH, p->err)) {
		return -1;
	}
	scene_middle(&p->sc, &p->prim, p->base);
	if (scene_load(&p->c, &p->sc, SMALL_LOAD_MS, p->err) != 0) {
		return -1;
	}
	conn_view(&p->c, w, h, BC_PROTO_ENC_JPEG);
	return wait_still(&p->c, STILL_MS, name, p->err);
}

/* What a probe has in flight. PINGs are answered in order, so a ring of
 * their send times tells which are still unanswered. */
struct probe_state {
	int64_t *ring;
	size_t head, tail;
	int64_t t_edit, frame_t;
	uint64_t order, frame_order;
	uint32_t eseq;
	bool pending;
};

/* One message for probe p, received at now. Returns false when its
 * connection is done for (p->err says why). */
static bool probe_take(struct probe *p, struct probe_state *st, int64_t now)
{
	struct conn *c = &p->c;
	if (c->m.type == BC_MSG_EDIT_APPLIED) {
		if (st->pending && c->m.edit_applied.author == p->member &&
		    c->m.edit_applied.author_seq == st->eseq) {
			st->order = c->m.edit_applied.order;
			/* A frame that came first still counts. */
			if (st->frame_order >= st->order) {
				series_add(&p->edits, st->t_edit,
				           st->frame_t - st->t_edit, false);
				st->pending = false;
			}
		}
	} else if (c->m.type == BC_MSG_FRAME) {
		p->frames++;
		if (c->m.frame.order > st->frame_order) {
			st->frame_order = c->m.frame.order;
			st->frame_t = now;
		}
		if (st->pending && st->order && c->m.frame.order >= st->order) {
			series_add(&p->edits, st->t_edit, now - st->t_edit,
			           false);
			st->pending = false;
		}
	} else if (c->m.type == BC_MSG_PONG) {
		int64_t stamp = (int64_t)c->m.ping.stamp;
		if (st->head != st->tail) {
			st->head++;
		}
		series_add(&p->pings, stamp, now - stamp, false);
	} else if (c->m.type == BC_MSG_ERROR) {
		char why[ERRLEN];
		error_text(c, why, sizeof(why));
		if (st->pending && c->m.seq == st->eseq) {
			p->refused++;
			st->pending = false;
		}
		if (c->m.flags & BC_PROTO_FLAG_FATAL) {
			seterr(p->err, "%s: fatal ERROR %s", p->name, why);
			return false;
		}
	}
	return true;
}

/* The probe's loop: an edit at most every EDIT_PERIOD_US and never before
 * the previous one's frame; a PING every PING_PERIOD_US whatever happens,
 * so that a stalled loop shows as PINGs waiting. Told to stop, it sends
 * nothing more and waits up to DRAIN_US for what is in flight; what is
 * still unanswered then counts as waited so far (censored). */
static void *probe_main(void *arg)
{
	struct probe *p = arg;
	struct conn *c = &p->c;
	struct probe_state st = {0};
	int64_t next_edit = now_us(), next_ping = next_edit, drain_end = 0;
	int64_t now;
	uint32_t k = 0;
	if (!(st.ring = bc_calloc(PING_RING, sizeof(int64_t)))) {
		seterr(p->err, "%s: out of memory", p->name);
		return NULL;
	}
	for (;;) {
		int64_t wake;
		int rc;
		now = now_us();
		if (!drain_end && atomic_load(&p->stop)) {
			drain_end = now + DRAIN_US;
		}
		if (drain_end &&
		    (now >= drain_end || (!st.pending && st.head == st.tail))) {
			break;
		}
		if (!drain_end && !st.pending && now >= next_edit) {
			float dx = (k++ & 1u) ? 0.02f : -0.02f;
			st.eseq =
			    conn_move(c, p->prim, p->base[0] + dx, p->base[1],
			              p->base[2], p->interacting);
			if (!st.eseq) {
				seterr(p->err, "%s: an EDIT could not be sent",
				       p->name);
				break;
			}
			st.pending = true;
			st.order = 0;
			st.t_edit = now;
			next_edit = now + EDIT_PERIOD_US;
		}
		if (!drain_end && now >= next_ping) {
			if (st.tail - st.head < PING_RING) {
				if (!send_ping(c, now)) {
					seterr(p->err,
					       "%s: a PING could not be sent",
					       p->name);
					break;
				}
				st.ring[st.tail++ % PING_RING] = now;
			}
			next_ping += PING_PERIOD_US;
			if (next_ping <= now) {
				next_ping = now + PING_PERIOD_US;
			}
		}
		wake = drain_end ? drain_end : next_ping;
		if (!drain_end && !st.pending && next_edit < wake) {
			wake = next_edit;
		}
		rc = conn_recv(c, ms_until(wake, 50));
		if (rc < 0) {
			char why[ERRLEN];
			closed_text(c, why, sizeof(why));
			seterr(p->err, "%s: %s", p->name, why);
			break;
		}
		if (rc == 1 && !probe_take(p, &st, now_us())) {
			break;
		}
	}
	now = now_us();
	if (st.pending) {
		series_add(&p->edits, st.t_edit, now - st.t_edit, true);
	}
	while (st.head != st.tail) {
		int64_t t = st.ring[st.head++ % PING_RING];
		series_add(&p->pings, t, now - t, true);
	}
	bc_free(st.ring);
	return NULL;
}

static void probe_start(struct probe *p)
{
	p->running = pthread_create(&p->th, NULL, probe_main, p) == 0;
	if (!p->running) {
		seterr(p->err, "%s: cannot start its thread", p->name);
	}
}

/* Tells p to stop; probe_stop then waits for it (so that several probes
 * drain at once). */
static void probe_signal(struct probe *p)
{
	atomic_store(&p->stop, true);
}

static void probe_stop(struct probe *p)
{
	atomic_store(&p->stop, true);
	if (p->running) {
		pthread_join(p->th, NULL);
		p->running = false;
	}
}

static void probe_finish(struct probe *p)
{
	probe_stop(p);
	conn_close(&p->c);
	scene_finish(&p->sc);
	series_finish(&p->edits);
	series_finish(&p->pings);
}

/* ---- The heavy clients of fairness (b) ----------------------------------- */

struct heavy {
	char tag; /* 'A', 'B' or 'C' */
	char session[16], name[16];
	const struct daemon *d;
	struct scene sc;
	/* A: every sphere's id and place; the EDIT being built. */
	uint32_t nprims, *ids;
	float (*pos)[3];
	struct bc_proto_edit_op *ops;
	struct bc_proto_field *fields;
	uint64_t rng;
	struct conn c;
	uint32_t member;
	bool connected;
	/* In flight: A's EDITs, B's SNAPSHOTs. */
	uint32_t inflight[B_SNAPSHOTS], ninflight;
	/* Written by its thread, read once it has ended. */
	long frames, sent, answered, refused, errors, drops;
	char last_error[ERRLEN];
	char err[ERRLEN];
	atomic_bool stop;
	pthread_t th;
	bool running;
};

static uint64_t rng_next(uint64_t *s)
{
	/* xorshift64*: deterministic, and the same on every machine. */
	*s ^= *s >> 12;
	*s ^= *s << 25;
	*s ^= *s >> 27;
	return *s * 2685821657736338717ull;
}

static double rng_unit(uint64_t *s)
{
	return (double)(rng_next(s) >> 11) / 9007199254740992.0;
}

/* Creates h's session and loads its scene (A tries smooth, then sharp). */
static int heavy_setup(struct heavy *h, const struct daemon *d, char tag)
{
	uint32_t count = tag == 'A'   ? A_SPHERES
	                 : tag == 'B' ? B_SPHERES
	                              : C_SPHERES;
	int rc;
	memset(h, 0, sizeof(*h));
	h->c.fd = -1;
	h->tag = tag;
	h->d = d;
	h->rng = 0x9e3779b97f4a7c15ull + (uint64_t)tag;
	atomic_init(&h->stop, false);
	snprintf(h->session, sizeof(h->session), "heavy-%c", tag);
	snprintf(h->name, sizeof(h->name), "heavy%c", tag);
	if (client_session(&h->c, d, h->name, h->session, true, &h->member,
	                   h->err)) {
		return -1;
	}
	for (int sharp = 0; sharp < (tag == 'A' ? 2 : 1); sharp++) {
		char why[ERRLEN];
		if (scene_fig18(&h->sc, count,
		                sharp ? BC_GEN_BLEND_SHARP
		                      : BC_GEN_BLEND_SMOOTH,
		                h->err)) {
			return -1;
		}
		progress("heavy %c: loading %s", tag, h->sc.what);
		rc = scene_load(&h->c, &h->sc, BIG_LOAD_MS, why);
		if (rc == 0) {
			/* A sharp load after a refused smooth one is no
			 * error: the table names the scene loaded. */
			h->err[0] = '\0';
			break;
		}
		seterr(h->err, "heavy %c: %s", tag, why);
		if (!h->sc.refused) {
			scene_finish(&h->sc);
			return -1;
		}
		scene_finish(&h->sc);
	}
	if (!h->sc.t) {
		return -1;
	}
	h->connected = true;
	if (tag == 'A') {
		const struct bc_lin *l = bc_tree_lin(h->sc.t);
		h->nprims = l->nprims;
		h->ids = bc_calloc(h->nprims, sizeof(*h->ids));
		h->pos = bc_calloc(h->nprims, sizeof(*h->pos));
		h->ops = bc_calloc(A_OPS, sizeof(*h->ops));
		h->fields = bc_calloc(A_OPS, sizeof(*h->fields));
		if (!h->ids || !h->pos || !h->ops || !h->fields ||
		    h->nprims < A_OPS) {
			seterr(h->err, "heavy A: out of memory");
			return -1;
		}
		for (uint32_t i = 0; i < h->nprims; i++) {
			struct bc_prim_data p;
			h->ids[i] = l->node_id[l->prim_slot[i]];
			bc_tree_get(h->sc.t, h->ids[i], &p, NULL);
			memcpy(h->pos[i], p.translate, sizeof(h->pos[i]));
		}
	}
	return 0;
}

/* A's EDIT: A_OPS translates of distinct random spheres (one in each of
 * A_OPS equal runs of the sphere list, from a random start), each within
 * A_JITTER of its place, as a drag (INTERACTING). */
static uint32_t heavy_a_edit(struct heavy *h)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	uint32_t stride = h->nprims / A_OPS;
	uint32_t start = (uint32_t)(rng_next(&h->rng) % h->nprims);
	for (uint32_t i = 0; i < A_OPS; i++) {
		uint32_t k = (start + i * stride +
		              (uint32_t)(rng_next(&h->rng) % stride)) %
		             h->nprims;
		struct bc_proto_field *f = &h->fields[i];
		f->field = BC_PROTO_FIELD_TRANSLATE;
		f->count = 3;
		for (int j = 0; j < 3; j++) {
			f->v[j] =
			    h->pos[k][j] +
			    A_JITTER * (float)(2.0 * rng_unit(&h->rng) - 1.0);
		}
		h->ops[i] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_SET,
		                                      .node = h->ids[k],
		                                      .nfields = 1,
		                                      .fields = f};
	}
	m.flags = BC_PROTO_FLAG_INTERACTING;
	m.edit.nops = (uint16_t)A_OPS;
	m.edit.ops = h->ops;
	return conn_send(&h->c, &m);
}

static uint32_t heavy_b_snapshot(struct heavy *h)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	m.snapshot.encoding = BC_PROTO_ENC_PNG;
	m.snapshot.planes = BC_PROTO_PLANE_DEPTH | BC_PROTO_PLANE_IDS;
	return conn_send(&h->c, &m);
}

static bool inflight_take(struct heavy *h, uint32_t seq)
{
	for (uint32_t i = 0; i < h->ninflight; i++) {
		if (h->inflight[i] == seq) {
			h->inflight[i] = h->inflight[--h->ninflight];
			return true;
		}
	}
	return false;
}

static bool heavy_b_refill(struct heavy *h)
{
	while (h->ninflight < B_SNAPSHOTS) {
		uint32_t seq = heavy_b_snapshot(h);
		if (!seq) {
			return false;
		}
		h->inflight[h->ninflight++] = seq;
		h->sent++;
	}
	return true;
}

/* What each heavy client asks as it (re)starts: its view, B's snapshots. */
static bool heavy_begin(struct heavy *h)
{
	h->ninflight = 0;
	if (h->tag == 'A') {
		return conn_view(&h->c, A_W, A_H, BC_PROTO_ENC_JPEG) != 0;
	}
	if (h->tag == 'B') {
		return conn_view(&h->c, B_DIM, B_DIM, BC_PROTO_ENC_JPEG) &&
		       heavy_b_refill(h);
	}
	return true;
}

/* One message for h. Returns false when the connection is done for. */
static bool heavy_handle(struct heavy *h)
{
	struct conn *c = &h->c;
	if (c->m.type == BC_MSG_FRAME) {
		if ((c->m.flags & BC_PROTO_FLAG_SNAPSHOT) &&
		    inflight_take(h, c->m.seq)) {
			h->answered++;
			return heavy_b_refill(h);
		}
		h->frames++;
	} else if (c->m.type == BC_MSG_EDIT_APPLIED) {
		if (c->m.edit_applied.author == h->member &&
		    inflight_take(h, c->m.edit_applied.author_seq)) {
			h->answered++;
		}
	} else if (c->m.type == BC_MSG_ERROR) {
		h->errors++;
		error_text(c, h->last_error, sizeof(h->last_error));
		if (inflight_take(h, c->m.seq)) {
			h->refused++;
			if (h->tag == 'B' && !heavy_b_refill(h)) {
				return false;
			}
		}
		return !(c->m.flags & BC_PROTO_FLAG_FATAL);
	}
	return true;
}

/* Runs h until told to stop. A connection the daemon closes (it drops a
 * client whose output passes its queue cap) is counted and made again, so
 * that the load stays on for the whole phase. */
static void *heavy_main(void *arg)
{
	struct heavy *h = arg;
	int64_t next = now_us();
	unsigned step = 0;
	while (!atomic_load(&h->stop)) {
		bool ok;
		if (!h->connected) {
			char why[ERRLEN];
			conn_close(&h->c);
			t_sleep_ms(200);
			if (atomic_load(&h->stop) ||
			    client_session(&h->c, h->d, h->name, h->session,
			                   false, &h->member, why)) {
				continue;
			}
			h->connected = true;
		}
		ok = heavy_begin(h);
		while (ok && !atomic_load(&h->stop)) {
			int64_t now = now_us();
			int rc;
			if (h->tag == 'A' && now >= next &&
			    h->ninflight < A_WINDOW) {
				uint32_t seq = heavy_a_edit(h);
				if (!(ok = seq != 0)) {
					break;
				}
				h->inflight[h->ninflight++] = seq;
				h->sent++;
				next = next + A_PERIOD_US > now
				           ? next + A_PERIOD_US
				           : now + A_PERIOD_US;
			} else if (h->tag == 'C' && now >= next) {
				uint16_t w = (step & 1u) ? 1312 : 1280;
				uint16_t hh = (step & 1u) ? 984 : 960;
				ok = conn_view_scaled(&h->c, w, hh,
				                      BC_PROTO_ENC_JPEG, 2) &&
				     send_orbit(&h->c, &h->sc.cam,
				                C_ORBIT_STEP * step, true);
				step++;
				h->sent++;
				next = next + C_PERIOD_US > now
				           ? next + C_PERIOD_US
				           : now + C_PERIOD_US;
				if (!ok) {
					break;
				}
			}
			/* A client with nothing to send before an answer
			 * comes (A with its window full, B always) waits for
			 * one: a zero timeout would spin and take a core from
			 * the daemon it measures. */
			rc = conn_recv(
			    &h->c, (h->tag == 'A' && h->ninflight < A_WINDOW) ||
			                   h->tag == 'C'
			               ? ms_until(next, 30)
			               : 30);
			if (rc < 0) {
				closed_text(&h->c, h->last_error,
				            sizeof(h->last_error));
				ok = false;
			} else if (rc == 1) {
				ok = heavy_handle(h);
			}
		}
		if (!atomic_load(&h->stop)) {
			h->drops++;
			h->connected = false;
		}
	}
	conn_close(&h->c);
	return NULL;
}

static void heavy_finish(struct heavy *h)
{
	atomic_store(&h->stop, true);
	if (h->running) {
		pthread_join(h->th, NULL);
		h->running = false;
	}
	conn_close(&h->c);
	scene_finish(&h->sc);
	bc_free(h->ids);
	bc_free(h->pos);
	bc_free(h->ops);
	bc_free(h->fields);
	h->ids = NULL;
	h->pos = NULL;
	h->ops = NULL;
	h->fields = NULL;
}

/* ---- Reporting the probe ------------------------------------------------- */

struct phase {
	const char *name, *label;
	int64_t from, to;
	struct summary edits, pings;
};

static void phase_measure(struct phase *ph, const struct probe *p)
{
	summarize(&p->edits, ph->from, ph->to, &ph->edits);
	summarize(&p->pings, ph->from, ph->to, &ph->pings);
}

static void phase_table_head(void)
{
	report("| phase | edits (censored) | edit -> frame p50 / p99 / max "
	       "ms | PINGs (censored) | PING p50 / p99 / max ms |\n"
	       "|---|---:|---:|---:|---:|\n");
}

static void phase_row(const struct phase *ph)
{
	char e[64], g[64];
	report("| %s | %zu (%zu) | %s | %zu (%zu) | %s |\n", ph->label,
	       ph->edits.n, ph->edits.censored, fmt3(e, sizeof(e), &ph->edits),
	       ph->pings.n, ph->pings.censored, fmt3(g, sizeof(g), &ph->pings));
}

static void phase_results(const char *scenario, const struct phase *ph)
{
	result_summary(scenario, ph->name, "edit_frame", &ph->edits);
	result_summary(scenario, ph->name, "ping", &ph->pings);
}

/* The bounds of fairness (b), also twist's: the probe's edit -> frame
 * against its time alone, and its PING round trips. */
static void probe_bounds(const char *scenario, const struct phase *alone,
                         const struct phase *loaded)
{
	char how[96];
	bool have = alone->edits.n > 0 && loaded->edits.n > 0;
	snprintf(how, sizeof(how), "1.5 * alone p50 %.1f ms + 2 ms",
	         alone->edits.p50);
	bound(scenario, "probe edit -> frame p50 under load", have,
	      loaded->edits.p50, 1.5 * alone->edits.p50 + 2.0, how);
	snprintf(how, sizeof(how), "3 * alone p99 %.1f ms + 10 ms",
	         alone->edits.p99);
	bound(scenario, "probe edit -> frame p99 under load", have,
	      loaded->edits.p99, 3.0 * alone->edits.p99 + 10.0, how);
	bound(scenario, "probe PING p99 under load", loaded->pings.n > 0,
	      loaded->pings.p99, 20.0, NULL);
}

/* One GET_STATS (LOAD) answer: label in the table, name in RESULT. */
struct load_row {
	const char *label, *name;
	bool have;
	struct bc_msg_stats st;
};

/* The load sections as a table, then their RESULT lines (after it, so
 * that the table stays whole). */
static void load_table(const char *scenario, const struct load_row *rows, int n)
{
	report("| when | loop turn max ms | loop request max ms | render "
	       "workers | jobs queued | jobs running | view MiB | view cap "
	       "MiB | session render us |\n"
	       "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
	for (int i = 0; i < n; i++) {
		const struct bc_proto_load *l = &rows[i].st.load;
		if (!rows[i].have) {
			report("| %s | not measured | | | | | | | |\n",
			       rows[i].label);
		} else if (!rows[i].st.has_load) {
			report("| %s | no load section in STATS | | | | | | | "
			       "|\n",
			       rows[i].label);
		} else {
			report("| %s | %.1f | %.1f | %u | %u | %u | %.1f | "
			       "%.1f | %" PRIu64 " |\n",
			       rows[i].label, (double)l->loop_turn_max_ms,
			       (double)l->loop_request_max_ms,
			       l->render_workers, l->jobs_queued,
			       l->jobs_running,
			       (double)l->view_bytes / 1048576.0,
			       (double)l->view_cap / 1048576.0,
			       l->session_render_us);
		}
	}
	report("\n");
	for (int i = 0; i < n; i++) {
		const struct bc_proto_load *l = &rows[i].st.load;
		if (!rows[i].have) {
			continue;
		}
		report("RESULT scenario=%s phase=%s what=load has_load=%d",
		       scenario, rows[i].name, rows[i].st.has_load);
		if (rows[i].st.has_load) {
			report(
			    " loop_turn_max_ms=%.1f loop_request_max_ms=%.1f "
			    "render_workers=%u jobs_queued=%u "
			    "jobs_running=%u view_bytes=%" PRIu64
			    " view_cap=%" PRIu64 " session_render_us=%" PRIu64,
			    (double)l->loop_turn_max_ms,
			    (double)l->loop_request_max_ms, l->render_workers,
			    l->jobs_queued, l->jobs_running, l->view_bytes,
			    l->view_cap, l->session_render_us);
		}
		report("\n");
	}
}

static void report_client_error(const char *who, const char *err)
{
	if (err[0]) {
		error_line("%s: %s", who, err);
	}
}

/* ---- fairness ------------------------------------------------------------ */

static void scenario_fairness(void)
{
	const char *sc = "fairness";
	struct daemon d;
	struct probe probe;
	struct heavy heavy[3];
	struct conn stats = {.fd = -1};
	struct load_row lr[2] = {
	    {.label = "start of b (after its RESET)", .name = "loaded_start"},
	    {.label = "end of b", .name = "loaded_end"}};
	struct phase a = {.name = "alone", .label = "a: probe alone"};
	struct phase b = {.name = "loaded", .label = "b: with heavy A, B, C"};
	struct phase c[RECOVERY_BUCKETS];
	char why[ERRLEN], err[ERRLEN] = "";
	bool exited, back_ok = false;
	int64_t s_us = seconds_us(opt.seconds), t_c;
	double back_at = -1.0;
	memset(&probe, 0, sizeof(probe));
	memset(heavy, 0, sizeof(heavy));
	probe.c.fd = -1;
	for (int i = 0; i < 3; i++) {
		heavy[i].c.fd = -1;
	}
	report("\n### fairness\n\n");
	report("Probe: %s in a %dx%d JPEG view, one sphere moved every %d "
	       "ms (no INTERACTING), each edit timed to the first FRAME "
	       "whose order reaches its EDIT_APPLIED's; a PING every %d ms. "
	       "Phases of %.0f s: (a) alone, (b) beside heavy A (%u spheres, "
	       "%dx%d JPEG, EDITs of %u SETs at 20 Hz, INTERACTING, <= %u "
	       "unacknowledged), B (%u spheres, %u PNG snapshots with depth "
	       "and ids of %dx%d outstanding), C (%u spheres, a VIEW of "
	       "1280x960 or 1312x984 and an orbit CAMERA every %d ms), (c) "
	       "the %d s after they left. Edits count in the phase they "
	       "were sent in.\n\n",
	       "fig18 64 smooth", PROBE_W, PROBE_H, EDIT_PERIOD_US / 1000,
	       PING_PERIOD_US / 1000, opt.seconds, A_SPHERES, A_W, A_H, A_OPS,
	       A_WINDOW, B_SPHERES, B_SNAPSHOTS, B_DIM, B_DIM, C_SPHERES,
	       C_PERIOD_US / 1000, RECOVERY_US / 1000000);
	arm_alarm(2 * opt.seconds + 2);
	if (fair_start(&d, NULL, why, &exited)) {
		error_line("%s: %s", sc, why);
		fair_stop(&d, sc, true);
		disarm_alarm(sc);
		return;
	}
	for (int i = 0; i < 3; i++) {
		if (heavy_setup(&heavy[i], &d, (char)('A' + i))) {
			error_line("%s", heavy[i].err);
		}
	}
	progress("fairness: setting up the probe");
	if (probe_setup(&probe, &d, "probe", "probe", PROBE_SPHERES, PROBE_W,
	                PROBE_H, false) ||
	    client_open(&stats, &d, "stats", err)) {
		error_line("%s: %s%s", sc, probe.err, err);
		goto out;
	}
	/* The daemon settles (the loads' copies, the probe's refinement). */
	t_sleep_ms(1000);
	progress("fairness: (a) probe alone for %.0f s", opt.seconds);
	probe_start(&probe);
	a.from = now_us();
	sleep_until(a.from + s_us);
	a.to = now_us();
	lr[0].have =
	    get_stats(&stats, BC_PROTO_STATS_LOAD | BC_PROTO_STATS_RESET,
	              &lr[0].st, err) == 0;
	if (!lr[0].have) {
		error_line("%s: %s", sc, err);
	}
	progress("fairness: (b) with the heavy clients for %.0f s",
	         opt.seconds);
	b.from = now_us();
	for (int i = 0; i < 3; i++) {
		if (heavy[i].connected) {
			heavy[i].running =
			    pthread_create(&heavy[i].th, NULL, heavy_main,
			                   &heavy[i]) == 0;
		}
	}
	sleep_until(b.from + s_us);
	b.to = now_us();
	lr[1].have =
	    get_stats(&stats, BC_PROTO_STATS_LOAD, &lr[1].st, err) == 0;
	if (!lr[1].have) {
		error_line("%s: %s", sc, err);
	}
	for (int i = 0; i < 3; i++) {
		atomic_store(&heavy[i].stop, true);
	}
	for (int i = 0; i < 3; i++) {
		if (heavy[i].running) {
			pthread_join(heavy[i].th, NULL);
			heavy[i].running = false;
		}
	}
	t_c = now_us();
	progress("fairness: (c) the probe alone again for %d s",
	         RECOVERY_US / 1000000);
	sleep_until(t_c + RECOVERY_US);
	probe_stop(&probe);

	phase_measure(&a, &probe);
	phase_measure(&b, &probe);
	report("| client | scene | load s | frames | requests | notes |\n"
	       "|---|---|---:|---:|---|---|\n");
	for (int i = 0; i < 3; i++) {
		struct heavy *h = &heavy[i];
		char req[64];
		if (!h->sc.t) {
			report("| %c | not loaded | | | | %s |\n", h->tag,
			       h->err);
			continue;
		}
		if (h->tag == 'A') {
			snprintf(req, sizeof(req), "%ld EDITs, %ld applied",
			         h->sent, h->answered);
		} else if (h->tag == 'B') {
			snprintf(req, sizeof(req),
			         "%ld snapshots, %ld answered", h->sent,
			         h->answered);
		} else {
			snprintf(req, sizeof(req), "%ld VIEW+CAMERA", h->sent);
		}
		report("| %c | %s | %.2f | %ld | %s | %ld ERRORs (%ld "
		       "refusing a request)%s%s; closed by the daemon %ld "
		       "times, reconnected each time |\n",
		       h->tag, h->sc.what, h->sc.load_s, h->frames, req,
		       h->errors, h->refused,
		       h->last_error[0] ? "; last: " : "", h->last_error,
		       h->drops);
	}
	{
		char line[ERRLEN];
		long drops =
		    log_first(&d, "dropping client", line, sizeof(line));
		if (drops > 0) {
			report("\nThe daemon's log has %ld \"dropping client\" "
			       "lines; the first: \"%s\"\n",
			       drops, line);
		}
	}
	report("\n");
	for (int i = 0; i < 3; i++) {
		struct heavy *h = &heavy[i];
		if (h->sc.t) {
			report("RESULT scenario=%s phase=loaded what=heavy_%c "
			       "spheres=%u load_s=%.2f frames=%ld sent=%ld "
			       "answered=%ld errors=%ld refused=%ld "
			       "closed_by_daemon=%ld\n",
			       sc, h->tag, h->sc.count, h->sc.load_s, h->frames,
			       h->sent, h->answered, h->errors, h->refused,
			       h->drops);
		}
	}
	report("\n");
	phase_table_head();
	phase_row(&a);
	phase_row(&b);
	for (int i = 0; i < RECOVERY_BUCKETS; i++) {
		static char labels[RECOVERY_BUCKETS][48];
		static char names[RECOVERY_BUCKETS][24];
		int64_t w = RECOVERY_US / RECOVERY_BUCKETS;
		snprintf(labels[i], sizeof(labels[i]), "c: %.1f-%.1f s after",
		         (double)(i * w) / 1e6, (double)((i + 1) * w) / 1e6);
		snprintf(names[i], sizeof(names[i]), "after_%.1f_%.1f",
		         (double)(i * w) / 1e6, (double)((i + 1) * w) / 1e6);
		c[i] = (struct phase){.name = names[i],
		                      .label = labels[i],
		                      .from = t_c + i * w,
		                      .to = t_c + (i + 1) * w};
		phase_measure(&c[i], &probe);
		phase_row(&c[i]);
	}
	report("\nProbe frames: %ld; edits refused: %ld.\n\n", probe.frames,
	       probe.refused);
	load_table(sc, lr, 2);
	phase_results(sc, &a);
	phase_results(sc, &b);
	for (int i = 0; i < RECOVERY_BUCKETS; i++) {
		phase_results(sc, &c[i]);
	}
	probe_bounds(sc, &a, &b);
	/* Back: from the first bucket on whose p50, and every later one's,
	 * is within 2x the alone p50. */
	for (int i = RECOVERY_BUCKETS - 1; i >= 0; i--) {
		if (c[i].edits.n == 0 || a.edits.n == 0 ||
		    c[i].edits.p50 > 2.0 * a.edits.p50) {
			break;
		}
		back_at = (double)(c[i].from - t_c) / 1e6;
	}
	back_ok = back_at >= 0.0;
	if (a.edits.n == 0) {
		report("FAIL %s: back within 2x alone p50 after the heavy "
		       "clients left: no alone sample\n",
		       sc);
	} else if (back_ok) {
		report("PASS %s: back within 2x alone p50 (%.1f ms) from %.1f "
		       "s after the heavy clients left (within 2 s)\n",
		       sc, 2.0 * a.edits.p50, back_at);
	} else {
		report("FAIL %s: not back within 2x alone p50 (%.1f ms) in "
		       "the last 0.5 s bucket of the 2 s after the heavy "
		       "clients left (p50 %.1f ms, %zu edits)\n",
		       sc, 2.0 * a.edits.p50, c[RECOVERY_BUCKETS - 1].edits.p50,
		       c[RECOVERY_BUCKETS - 1].edits.n);
	}
out:
	report_client_error("probe", probe.err);
	for (int i = 0; i < 3; i++) {
		if (heavy[i].sc.t) {
			report_client_error(heavy[i].name, heavy[i].err);
		}
		heavy_finish(&heavy[i]);
	}
	probe_finish(&probe);
	conn_close(&stats);
	fair_stop(&d, sc, false);
	disarm_alarm(sc);
}

/* ---- the probe beside another client (twist, mesh) ------------------------ */

/* A scenario of two phases: the probe alone for --seconds, then beside
 * another client (c, in a session of its own with scene s loaded) doing
 * what the scenario measures. */
struct beside {
	const char *sc;
	struct daemon d;
	bool up; /* the daemon started */
	struct probe probe;
	struct conn c;
	struct scene s;
	struct phase a, b;
	char err[ERRLEN]; /* the other client's first error */
};

/* Starts the daemon, the probe and client (its session and w->s, made
 * by the caller), then runs the probe alone (phase a). False after saying
 * why; beside_finish cleans up either way. */
static bool beside_start(struct beside *w, const char *client, double alarm_s)
{
	char why[ERRLEN];
	bool exited;
	uint32_t member;
	int64_t s_us = seconds_us(opt.seconds);
	w->a = (struct phase){.name = "alone", .label = "probe alone"};
	w->probe.c.fd = -1;
	w->c.fd = -1;
	arm_alarm(alarm_s);
	if (fair_start(&w->d, NULL, why, &exited)) {
		error_line("%s: %s", w->sc, why);
		fair_stop(&w->d, w->sc, true);
		return false;
	}
	w->up = true;
	if (probe_setup(&w->probe, &w->d, "probe", "probe", PROBE_SPHERES,
	                PROBE_W, PROBE_H, false)) {
		error_line("%s: %s", w->sc, w->probe.err);
		return false;
	}
	if (client_session(&w->c, &w->d, client, client, true, &member,
	                   w->err) ||
	    scene_load(&w->c, &w->s, SMALL_LOAD_MS, w->err)) {
		error_line("%s: %s", w->sc, w->err);
		return false;
	}
	t_sleep_ms(500);
	progress("%s: probe alone for %.0f s", w->sc, opt.seconds);
	probe_start(&w->probe);
	w->a.from = now_us();
	sleep_until(w->a.from + s_us);
	w->a.to = now_us();
	return true;
}

/* Phase b has ended: the probe stops, both phases are measured. */
static void beside_measure(struct beside *w)
{
	w->b.to = now_us();
	probe_stop(&w->probe);
	phase_measure(&w->a, &w->probe);
	phase_measure(&w->b, &w->probe);
}

/* The other client's error line, then the phases' table and RESULTs. */
static void beside_tables(const struct beside *w, const char *client)
{
	if (w->err[0]) {
		report("- %s client: %s\n", client, w->err);
	}
	report("\n");
	phase_table_head();
	phase_row(&w->a);
	phase_row(&w->b);
	report("\n");
	phase_results(w->sc, &w->a);
	phase_results(w->sc, &w->b);
}

static void beside_finish(struct beside *w)
{
	report_client_error("probe", w->probe.err);
	probe_finish(&w->probe);
	conn_close(&w->c);
	scene_finish(&w->s);
	if (w->up) {
		fair_stop(&w->d, w->sc, false);
	}
	disarm_alarm(w->sc);
}

/* ---- twist --------------------------------------------------------------- */

static void scenario_twist(void)
{
	static struct beside w;
	bool have_frame = false;
	uint16_t flags = 0;
	int64_t s_us = seconds_us(opt.seconds), first = 0;
	memset(&w, 0, sizeof(w));
	w.sc = "twist";
	w.b =
	    (struct phase){.name = "twist", .label = "probe beside the twist"};
	report("\n### twist\n\n");
	report("The probe (as in fairness) alone for %.0f s, then beside a "
	       "session whose scene is twist(sphere) at rate %s and whose "
	       "client opens an %dx%d JPEG view and waits for its first "
	       "FRAME (bound: %.0f s; INCOMPLETE is fine) for %.0f s at "
	       "most. The daemon is killed (SIGKILL) at the end.\n\n",
	       opt.seconds, TWIST_RATE_NAME, TWIST_W, TWIST_H,
	       TWIST_BOUND_MS / 1000.0, opt.seconds);
	if (scene_twist(&w.s, w.err)) {
		error_line("%s: %s", w.sc, w.err);
		return;
	}
	if (!beside_start(&w, "twist", 2 * opt.seconds)) {
		beside_finish(&w);
		return;
	}
	progress("twist: the twist session's view, for %.0f s at most",
	         opt.seconds);
	w.b.from = now_us();
	if (!conn_view(&w.c, TWIST_W, TWIST_H, BC_PROTO_ENC_JPEG)) {
		seterr(w.err, "the twist client's VIEW could not be sent");
	}
	while (now_us() < w.b.from + s_us) {
		int rc = conn_recv(&w.c, ms_until(w.b.from + s_us, 100));
		if (rc < 0) {
			closed_text(&w.c, w.err, sizeof(w.err));
			break;
		}
		if (rc == 1 && w.c.m.type == BC_MSG_FRAME && !have_frame) {
			have_frame = true;
			first = now_us() - w.b.from;
			flags = w.c.m.flags;
		} else if (rc == 1 && w.c.m.type == BC_MSG_ERROR) {
			error_text(&w.c, w.err, sizeof(w.err));
		}
	}
	beside_measure(&w);
	if (have_frame) {
		report("- twist session: first FRAME after %.1f ms (level %u%s)"
		       "\n",
		       (double)first / 1e3, bc_proto_flags_level(flags),
		       (flags & BC_PROTO_FLAG_INCOMPLETE) ? ", INCOMPLETE"
		                                          : "");
	} else {
		report("- twist session: no frame in %.0f s\n", opt.seconds);
	}
	beside_tables(&w, "twist");
	report("RESULT scenario=%s what=twist_first_frame frame=%d", w.sc,
	       have_frame);
	if (have_frame) {
		report(" ms=%.1f level=%u incomplete=%d\n", (double)first / 1e3,
		       bc_proto_flags_level(flags),
		       (flags & BC_PROTO_FLAG_INCOMPLETE) != 0);
	} else {
		report(" waited_s=%.0f\n", opt.seconds);
	}
	if (have_frame) {
		bound(w.sc, "the twist session's first frame", true,
		      (double)first / 1e3, TWIST_BOUND_MS, NULL);
	} else {
		/* The wait is --seconds: below the bound it cannot show
		 * the bound met, and says so. */
		report("FAIL %s: the twist session's first frame: no frame in "
		       "%.0f s (bound %.0f s)%s\n",
		       w.sc, opt.seconds, TWIST_BOUND_MS / 1000.0,
		       opt.seconds * 1000.0 < TWIST_BOUND_MS
		           ? "; --seconds is below the bound, so it is not "
		             "decided"
		           : "");
	}
	probe_bounds(w.sc, &w.a, &w.b);
	beside_finish(&w);
}

/* ---- mesh ----------------------------------------------------------------- */

/* The mesher's scene and grid: fig18's 1024 smooth spheres at the page's
 * default grid, a 23 MB glTF file each, seconds of work. */
#define MESH_SPHERES 1024u
#define MESH_RESOLUTION 128u

/* The mesh client: MESH after MESH until until_us; how many came back,
 * their bytes, and the first error. */
static void mesh_loop(struct conn *c, int64_t until_us, int *done,
                      uint64_t *bytes, char *err)
{
	while (now_us() < until_us && !err[0]) {
		struct bc_msg m = {.type = BC_MSG_MESH};
		uint32_t seq;
		m.mesh.format = BC_PROTO_MESH_GLB;
		m.mesh.resolution = MESH_RESOLUTION;
		if (!(seq = conn_send(c, &m))) {
			seterr(err, "the MESH could not be sent");
			return;
		}
		for (;;) {
			int rc = conn_recv(c, 1000);
			if (rc < 0) {
				closed_text(c, err, ERRLEN);
				return;
			}
			if (rc == 1 && c->m.type == BC_MSG_MESH_DATA &&
			    c->m.seq == seq) {
				(*done)++;
				*bytes += c->m.mesh_data.file.len;
				break;
			}
			if (rc == 1 && c->m.type == BC_MSG_ERROR) {
				error_text(c, err, ERRLEN);
				return;
			}
		}
	}
}

static void scenario_mesh(void)
{
	static struct beside w;
	uint64_t bytes = 0;
	int done = 0;
	memset(&w, 0, sizeof(w));
	w.sc = "mesh";
	w.b = (struct phase){.name = "meshing",
	                     .label = "probe beside the meshing"};
	report("\n### mesh\n\n");
	report("The probe (as in fairness) alone for %.0f s, then for %.0f s "
	       "beside a client in a session of fig18 %u smooth that asks "
	       "for its glTF mesh at %u cells (MESH) again as soon as one "
	       "comes back. The daemon is killed (SIGKILL) at the end.\n\n",
	       opt.seconds, opt.seconds, MESH_SPHERES, MESH_RESOLUTION);
	if (scene_fig18(&w.s, MESH_SPHERES, BC_GEN_BLEND_SMOOTH, w.err)) {
		error_line("%s: %s", w.sc, w.err);
		return;
	}
	if (!beside_start(&w, "mesher", 3 * opt.seconds + 60)) {
		beside_finish(&w);
		return;
	}
	progress("mesh: beside the meshing for %.0f s", opt.seconds);
	w.b.from = now_us();
	mesh_loop(&w.c, w.b.from + seconds_us(opt.seconds), &done, &bytes,
	          w.err);
	beside_measure(&w);
	report("- mesh client: %d meshes of %.1f MB each in %.1f s "
	       "(the last one may end after the probe's phase)\n",
	       done, done ? (double)bytes / done / 1e6 : 0.0,
	       (double)(w.b.to - w.b.from) / 1e6);
	beside_tables(&w, "mesh");
	report("RESULT scenario=%s what=meshes done=%d bytes=%" PRIu64 "\n",
	       w.sc, done, bytes);
	report("%s %s: meshes made: %d (at least one)\n",
	       done >= 1 ? "PASS" : "FAIL", w.sc, done);
	probe_bounds(w.sc, &w.a, &w.b);
	beside_finish(&w);
}

/* ---- capacity ------------------------------------------------------------ */

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

/* One round of capacity: its row of the table, its sessions' figures. */
struct cap_round {
	int n, measured;
	bool ran, ok;
	size_t edits, censored;
	double median, worst_p99, worst_max, worst_ping;
	struct summary *e, *g; /* per session; n 0: not measured */
};

/* Plays one round: n sessions on a fresh daemon, into r. */
static void capacity_round(int n, struct cap_round *r)
{
	const char *sc = "capacity";
	struct daemon d;
	struct probe *ps = bc_calloc((size_t)n, sizeof(*ps));
	double *p50 = bc_calloc((size_t)n, sizeof(double));
	char why[ERRLEN];
	int ready = 0;
	bool exited;
	int64_t t0, t1;
	memset(r, 0, sizeof(*r));
	r->n = n;
	r->median = r->worst_p99 = r->worst_max = r->worst_ping = -1.0;
	r->e = bc_calloc((size_t)n, sizeof(*r->e));
	r->g = bc_calloc((size_t)n, sizeof(*r->g));
	if (!ps || !p50 || !r->e || !r->g) {
		error_line("%s: out of memory", sc);
		bc_free(ps);
		bc_free(p50);
		return;
	}
	arm_alarm(opt.seconds);
	if (fair_start(&d, NULL, why, &exited)) {
		error_line("%s, %d sessions: %s", sc, n, why);
		fair_stop(&d, sc, true);
		disarm_alarm(sc);
		bc_free(ps);
		bc_free(p50);
		return;
	}
	progress("capacity: setting up %d sessions", n);
	for (int i = 0; i < n; i++) {
		char name[24];
		snprintf(name, sizeof(name), "cap-%d", i);
		if (probe_setup(&ps[i], &d, name, name, CAP_SPHERES, CAP_W,
		                CAP_H, true)) {
			error_line("%s, %d sessions: %s", sc, n, ps[i].err);
			ps[i].err[0] = '\0';
			continue;
		}
		ready++;
	}
	progress("capacity: %d sessions dragging for %.0f s", ready,
	         opt.seconds);
	t0 = now_us();
	for (int i = 0; i < n; i++) {
		if (ps[i].sc.t && ps[i].c.fd >= 0) {
			probe_start(&ps[i]);
		}
	}
	sleep_until(t0 + seconds_us(opt.seconds));
	t1 = now_us();
	for (int i = 0; i < n; i++) {
		probe_signal(&ps[i]);
	}
	for (int i = 0; i < n; i++) {
		probe_stop(&ps[i]);
	}
	r->ran = true;
	r->ok = true;
	for (int i = 0; i < n; i++) {
		summarize(&ps[i].edits, t0, t1, &r->e[i]);
		summarize(&ps[i].pings, t0, t1, &r->g[i]);
		report_client_error(ps[i].name, ps[i].err);
		if (r->e[i].n == 0) {
			r->ok = false;
			continue;
		}
		p50[r->measured++] = r->e[i].p50;
		r->edits += r->e[i].n;
		r->censored += r->e[i].censored;
		if (r->e[i].p99 > r->worst_p99) {
			r->worst_p99 = r->e[i].p99;
		}
		if (r->e[i].max > r->worst_max) {
			r->worst_max = r->e[i].max;
		}
		if (r->g[i].n && r->g[i].p99 > r->worst_ping) {
			r->worst_ping = r->g[i].p99;
		}
		r->ok = r->ok && r->e[i].p99 <= CAP_P99_MS;
	}
	if (r->measured > 0) {
		size_t k = ((size_t)r->measured * 50 + 99) / 100;
		qsort(p50, (size_t)r->measured, sizeof(double), cmp_double);
		r->median = p50[k > 0 ? k - 1 : 0];
	}
	r->ok = r->ok && r->measured == n;
	for (int i = 0; i < n; i++) {
		probe_finish(&ps[i]);
	}
	fair_stop(&d, sc, false);
	disarm_alarm(sc);
	bc_free(ps);
	bc_free(p50);
}

static void scenario_capacity(void)
{
	const char *sc = "capacity";
	enum { NROUNDS = sizeof(cap_sessions) / sizeof(cap_sessions[0]) };
	struct cap_round r[NROUNDS];
	report("\n### capacity\n\n");
	report("For each count of sessions a fresh daemon; each session "
	       "fig18 %u smooth with one member in a %dx%d JPEG view "
	       "dragging one sphere (EDIT with INTERACTING) every %d ms, "
	       "each edit timed to its frame, a PING every %d ms; %.0f s "
	       "each. PASS when every session's p99 <= %.0f ms.\n\n",
	       CAP_SPHERES, CAP_W, CAP_H, EDIT_PERIOD_US / 1000,
	       PING_PERIOD_US / 1000, opt.seconds, CAP_P99_MS);
	for (int i = 0; i < NROUNDS; i++) {
		capacity_round(cap_sessions[i], &r[i]);
	}
	report("| sessions | measured | edits (censored) | median of p50 ms "
	       "| worst p99 ms | worst max ms | worst PING p99 ms | "
	       "verdict |\n"
	       "|---:|---:|---:|---:|---:|---:|---:|---|\n");
	for (int i = 0; i < NROUNDS; i++) {
		if (!r[i].ran) {
			report("| %d | not run | | | | | | |\n", r[i].n);
			continue;
		}
		report("| %d | %d | %zu (%zu) | %.1f | %.1f | %.1f | %.1f | %s "
		       "|\n",
		       r[i].n, r[i].measured, r[i].edits, r[i].censored,
		       r[i].median, r[i].worst_p99, r[i].worst_max,
		       r[i].worst_ping, r[i].ok ? "PASS" : "FAIL");
	}
	report("\n");
	for (int i = 0; i < NROUNDS; i++) {
		if (!r[i].ran) {
			continue;
		}
		for (int k = 0; k < r[i].n; k++) {
			char ph[32];
			snprintf(ph, sizeof(ph), "s%d_of_%d", k, r[i].n);
			result_summary(sc, ph, "edit_frame", &r[i].e[k]);
			result_summary(sc, ph, "ping", &r[i].g[k]);
		}
		report("RESULT scenario=%s what=round sessions=%d measured=%d "
		       "edits=%zu "
		       "censored=%zu median_p50_ms=%.1f worst_p99_ms=%.1f "
		       "worst_max_ms=%.1f worst_ping_p99_ms=%.1f\n",
		       sc, r[i].n, r[i].measured, r[i].edits, r[i].censored,
		       r[i].median, r[i].worst_p99, r[i].worst_max,
		       r[i].worst_ping);
	}
	for (int i = 0; i < NROUNDS; i++) {
		if (!r[i].ran || r[i].measured == 0) {
			report("FAIL %s: %d session%s: not measured\n", sc,
			       r[i].n, r[i].n == 1 ? "" : "s");
		} else {
			report(
			    "%s %s: %d session%s: every session's p99 <= %.0f "
			    "ms (worst %.1f ms, %d of %d measured)\n",
			    r[i].ok ? "PASS" : "FAIL", sc, r[i].n,
			    r[i].n == 1 ? "" : "s", CAP_P99_MS, r[i].worst_p99,
			    r[i].measured, r[i].n);
		}
		bc_free(r[i].e);
		bc_free(r[i].g);
	}
}

/* ---- scaling ------------------------------------------------------------- */

struct orbit {
	bool ran;
	double seconds;
	long frames, matched, given_up;
	struct summary lat;
	char err[ERRLEN];
};

/*
 * One orbit on a fresh daemon started with --render-threads threads (no
 * option when threads is NULL): the next CAMERA as soon as a FRAME for the
 * previous one has come. Returns 0; 1 when the daemon exited at start
 * (an option it does not take, r->err saying which); -1 on another
 * failure (r->err).
 */
static int scaling_run(const char *threads, struct orbit *r)
{
	const char *extra[3] = {threads ? "--render-threads" : NULL, threads,
	                        NULL};
	struct daemon d;
	struct conn c = {.fd = -1};
	struct scene s = {0};
	struct series lat = {0};
	uint32_t member, cseq = 0;
	bool exited, waiting = false;
	int64_t t0, end, t_sent = 0;
	unsigned k = 0;
	int rc = -1;
	memset(r, 0, sizeof(*r));
	if (fair_start(&d, extra, r->err, &exited)) {
		fair_stop(&d, "scaling", !exited);
		return exited ? 1 : -1;
	}
	if (client_session(&c, &d, "orbit", "orbit", true, &member, r->err) ||
	    scene_fig18(&s, SCALE_SPHERES, BC_GEN_BLEND_SMOOTH, r->err) ||
	    scene_load(&c, &s, SMALL_LOAD_MS, r->err) ||
	    !conn_view_scaled(&c, SCALE_W, SCALE_H, BC_PROTO_ENC_JPEG, 1) ||
	    wait_still(&c, STILL_MS, "orbit", r->err)) {
		goto out;
	}
	t0 = now_us();
	end = t0 + seconds_us(opt.seconds);
	while (now_us() < end) {
		int64_t now = now_us();
		int got;
		if (!waiting ||
		    now - t_sent > (int64_t)SCALE_GIVE_UP_MS * 1000) {
			if (waiting) {
				r->given_up++;
				series_add(&lat, t_sent, now - t_sent, true);
			}
			if (!(cseq = send_orbit(&c, &s.cam, SCALE_STEP * k++,
			                        true))) {
				seterr(r->err, "a CAMERA could not be sent");
				goto out;
			}
			t_sent = now;
			waiting = true;
		}
		got = conn_recv(&c, ms_until(end, 100));
		if (got < 0) {
			closed_text(&c, r->err, sizeof(r->err));
			goto out;
		}
		if (got == 1 && c.m.type == BC_MSG_FRAME) {
			r->frames++;
			if (waiting && c.m.frame.camera_seq >= cseq) {
				r->matched++;
				series_add(&lat, t_sent, now_us() - t_sent,
				           false);
				waiting = false;
			}
		} else if (got == 1 && c.m.type == BC_MSG_ERROR) {
			error_text(&c, r->err, sizeof(r->err));
			goto out;
		}
	}
	r->seconds = (double)(now_us() - t0) / 1e6;
	summarize(&lat, t0, end, &r->lat);
	r->ran = true;
	rc = 0;
out:
	conn_close(&c);
	scene_finish(&s);
	series_finish(&lat);
	fair_stop(&d, "scaling", false);
	return rc;
}

static void orbit_row(const char *label, const struct orbit *r)
{
	char l[64];
	report("| %s | %.1f | %.1f | %ld | %s |\n", label,
	       (double)r->matched / r->seconds, (double)r->frames / r->seconds,
	       r->given_up, fmt3(l, sizeof(l), &r->lat));
}

static void orbit_result(const char *threads, const struct orbit *r)
{
	if (r->ran) {
		report("RESULT scenario=scaling what=orbit render_threads=%s "
		       "camera_fps=%.2f all_fps=%.2f given_up=%ld\n",
		       threads, (double)r->matched / r->seconds,
		       (double)r->frames / r->seconds, r->given_up);
		result_summary("scaling", threads, "camera_frame", &r->lat);
	}
}

static void scenario_scaling(void)
{
	const char *sc = "scaling";
	static const char *const threads[2] = {"1", "2"};
	struct orbit r[2];
	char refusal[ERRLEN] = "";
	bool supported = true;
	report("\n### scaling\n\n");
	report("One client orbits fig18 %u smooth in a %dx%d JPEG view "
	       "(downscale 1: every frame at full resolution), sending the "
	       "next CAMERA (INTERACTING, %.1f rad on) as soon as a FRAME "
	       "for the previous one has come; %.0f s on a fresh daemon "
	       "with --render-threads 1, then 2.\n\n",
	       SCALE_SPHERES, SCALE_W, SCALE_H, SCALE_STEP, opt.seconds);
	arm_alarm(2 * opt.seconds);
	for (int i = 0; i < 2 && supported; i++) {
		int rc;
		progress("scaling: --render-threads %s", threads[i]);
		rc = scaling_run(threads[i], &r[i]);
		if (rc == 1) {
			supported = false;
			memcpy(refusal, r[i].err, sizeof(refusal));
		} else if (rc < 0) {
			error_line("%s, --render-threads %s: %s", sc,
			           threads[i], r[i].err);
		}
	}
	if (!supported) {
		/* Today's daemon: its one render thread, as the before. A
		 * daemon that exits without the option too refuses something
		 * else (a --daemon-arg), not --render-threads. */
		int rc;
		progress("scaling: the daemon's default");
		rc = scaling_run(NULL, &r[0]);
		if (rc == 1) {
			error_line("%s: the daemon exits at start even without "
			           "--render-threads: %s",
			           sc, r[0].err);
			disarm_alarm(sc);
			return;
		}
		report("- --render-threads: not supported by this daemon "
		       "(%s)\n",
		       refusal);
		report("RESULT scenario=%s what=orbit render_threads=1 "
		       "supported=0\n",
		       sc);
		if (rc < 0) {
			error_line("%s, default daemon: %s", sc, r[0].err);
		}
	}
	report("\n| render threads | camera frames/s | all frames/s | "
	       "cameras given up (%d s) | CAMERA -> FRAME p50 / p99 / max ms "
	       "|\n|---|---:|---:|---:|---:|\n",
	       SCALE_GIVE_UP_MS / 1000);
	if (!supported) {
		if (r[0].ran) {
			orbit_row("the daemon's default (no option)", &r[0]);
		}
		report("| 1 | not supported by this daemon | | | |\n"
		       "| 2 | not supported by this daemon | | | |\n\n");
		orbit_result("default", &r[0]);
		report("- ratio 2 threads / 1 thread: not measured (the "
		       "option is not supported)\n");
	} else {
		for (int i = 0; i < 2; i++) {
			if (r[i].ran) {
				orbit_row(threads[i], &r[i]);
			}
		}
		report("\n");
		for (int i = 0; i < 2; i++) {
			orbit_result(threads[i], &r[i]);
		}
		if (r[0].ran && r[1].ran && r[0].matched > 0) {
			double ratio = ((double)r[1].matched / r[1].seconds) /
			               ((double)r[0].matched / r[0].seconds);
			report("RESULT scenario=%s what=ratio value=%.3f\n", sc,
			       ratio);
			report("- ratio 2 threads / 1 thread: %.2f\n", ratio);
		}
	}
	disarm_alarm(sc);
}

/* ---- loop ---------------------------------------------------------------- */

struct pinger {
	struct conn c;
	struct series s;
	int64_t period;
	char err[ERRLEN];
	atomic_bool stop;
	pthread_t th;
	bool running;
};

/* A PING every period, answered or not; unanswered ones are censored. */
static void *pinger_main(void *arg)
{
	struct pinger *p = arg;
	int64_t *ring = bc_calloc(PING_RING, sizeof(int64_t));
	size_t head = 0, tail = 0;
	int64_t next = now_us(), now;
	if (!ring) {
		seterr(p->err, "pinger: out of memory");
		return NULL;
	}
	while (!atomic_load(&p->stop)) {
		int rc;
		now = now_us();
		if (now >= next) {
			if (tail - head < PING_RING) {
				if (!send_ping(&p->c, now)) {
					seterr(p->err, "a PING could not be "
					               "sent");
					break;
				}
				ring[tail++ % PING_RING] = now;
			}
			next = next + p->period > now ? next + p->period
			                              : now + p->period;
		}
		rc = conn_recv(&p->c, ms_until(next, 50));
		if (rc < 0) {
			closed_text(&p->c, p->err, sizeof(p->err));
			break;
		}
		if (rc == 1 && p->c.m.type == BC_MSG_PONG) {
			int64_t stamp = (int64_t)p->c.m.ping.stamp;
			if (head != tail) {
				head++;
			}
			series_add(&p->s, stamp, now_us() - stamp, false);
		}
	}
	now = now_us();
	while (head != tail) {
		int64_t t = ring[head++ % PING_RING];
		series_add(&p->s, t, now - t, true);
	}
	bc_free(ring);
	return NULL;
}

/* The largest count that should fit, from a refusal whose sentence ends
 * with the scene's size and the cap ("would take B bytes ... over the C"):
 * count * C / B less 1 %. Without those numbers, 85 % of count. */
static uint32_t fit_count(uint32_t count, const char *text)
{
	double num[2] = {0, 0};
	int have = 0;
	for (const char *p = text; *p;) {
		if (*p >= '0' && *p <= '9') {
			char *e;
			double v = strtod(p, &e);
			num[0] = num[1];
			num[1] = v;
			have++;
			p = e;
		} else {
			p++;
		}
	}
	if (have >= 2 && num[0] > num[1] && num[1] > 0) {
		return (uint32_t)((double)count * num[1] / num[0] * 0.99);
	}
	return (uint32_t)((double)count * 0.85);
}

static void scenario_loop(void)
{
	const char *sc = "loop";
	struct daemon d;
	struct conn c = {.fd = -1}, stats = {.fd = -1};
	struct scene s = {0};
	struct pinger pg;
	struct load_row lr[2] = {
	    {.label = "before the edit (after its RESET)",
	     .name = "before_edit"},
	    {.label = "after its frame", .name = "after_frame"}};
	struct summary before, during;
	struct bc_proto_buf sub;
	char why[ERRLEN], err[ERRLEN] = "";
	uint32_t member, count = LOOP_SPHERES, seq;
	bool exited;
	int64_t t_first = -1, t_still = -1, t_base, t0, t_applied = -1,
	        t_frame = -1, t_end, end;
	uint64_t order = 0;
	int rc = -1;
	memset(&pg, 0, sizeof(pg));
	pg.c.fd = -1;
	atomic_init(&pg.stop, false);
	bc_proto_buf_init(&sub, 0);
	report("\n### loop\n\n");
	report("A session of fig18 %u smooth (or the most the daemon takes) "
	       "in a %dx%d JPEG view receives one structural EDIT: an "
	       "INSERT of a sphere under the root operator. Timed: "
	       "EDIT_APPLIED and the first FRAME whose order reaches it; "
	       "another client (in no session) PINGs every %d ms "
	       "throughout; the daemon's loop maxima from GET_STATS (LOAD, "
	       "RESET before the edit). The loop maxima of fairness (b) "
	       "are in fairness.\n\n",
	       LOOP_SPHERES, LOOP_W, LOOP_H, LOOP_PING_PERIOD_US / 1000);
	arm_alarm(0);
	if (fair_start(&d, NULL, why, &exited)) {
		error_line("%s: %s", sc, why);
		fair_stop(&d, sc, true);
		disarm_alarm(sc);
		bc_proto_buf_finish(&sub);
		return;
	}
	if (client_session(&c, &d, "big", "big", true, &member, err)) {
		error_line("%s: %s", sc, err);
		goto out;
	}
	for (int i = 0; i < LOOP_LOAD_TRIES; i++) {
		if (scene_fig18(&s, count, BC_GEN_BLEND_SMOOTH, err)) {
			error_line("%s: %s", sc, err);
			goto out;
		}
		progress("loop: loading %s", s.what);
		rc = scene_load(&c, &s, BIG_LOAD_MS, err);
		if (rc == 0) {
			break;
		}
		if (!s.refused || rc != BC_ELIMIT) {
			scene_finish(&s);
			error_line("%s: %s", sc, err);
			goto out;
		}
		scene_finish(&s);
		report("- %s\n", err);
		count = fit_count(count, err);
		report("- trying the largest that should fit: %u spheres\n",
		       count);
	}
	if (rc != 0) {
		error_line("%s: no scene size was accepted", sc);
		goto out;
	}
	report("- loaded %s in %.1f s (SCENE_LOAD to its SCENE_STATE)\n",
	       s.what, s.load_s);
	t0 = now_us();
	conn_view_scaled(&c, LOOP_W, LOOP_H, BC_PROTO_ENC_JPEG, 2);
	end = t0 + (int64_t)BIG_STILL_MS * 1000;
	while (t_still < 0 && now_us() < end) {
		int got = conn_recv(&c, ms_until(end, 1000));
		if (got < 0) {
			closed_text(&c, err, sizeof(err));
			error_line("%s: %s", sc, err);
			goto out;
		}
		if (got == 1 && c.m.type == BC_MSG_FRAME) {
			if (t_first < 0) {
				t_first = now_us() - t0;
			}
			if (c.m.flags & BC_PROTO_FLAG_STILL) {
				t_still = now_us() - t0;
			}
		}
	}
	report("- its view: first FRAME after %.1f s, the still after %.1f s"
	       "%s\n",
	       (double)t_first / 1e6, (double)t_still / 1e6,
	       t_still < 0 ? " (none: timed out)" : "");
	if (client_open(&pg.c, &d, "pinger", err) ||
	    client_open(&stats, &d, "stats", err)) {
		error_line("%s: %s", sc, err);
		goto out;
	}
	pg.period = LOOP_PING_PERIOD_US;
	pg.running = pthread_create(&pg.th, NULL, pinger_main, &pg) == 0;
	t_base = now_us();
	t_sleep_ms(1000);
	lr[0].have =
	    get_stats(&stats, BC_PROTO_STATS_LOAD | BC_PROTO_STATS_RESET,
	              &lr[0].st, err) == 0;
	if (!lr[0].have) {
		error_line("%s: %s", sc, err);
	}
	{
		static const float tr[3] = {0, 0, 0}, rot[4] = {0, 0, 0, 1};
		float rad = 0.05f;
		struct bc_proto_edit_op op = {0};
		struct bc_msg m = {.type = BC_MSG_EDIT};
		bc_proto_scene_begin(&sub, NULL, 1);
		bc_proto_scene_prim(&sub, (uint8_t)BC_PRIM_SPHERE, INSERT_ID,
		                    tr, rot, NULL, 1, &rad);
		op.kind = BC_PROTO_EDIT_INSERT;
		op.node = bc_tree_root(s.t);
		op.position = 0;
		op.subtree.ptr = sub.data;
		op.subtree.len = (uint32_t)sub.len;
		m.edit.nops = 1;
		m.edit.ops = &op;
		progress("loop: the INSERT");
		t0 = now_us();
		seq = conn_send(&c, &m);
	}
	end = t0 + (int64_t)BIG_STILL_MS * 1000;
	while (seq && t_frame < 0 && now_us() < end) {
		int got = conn_recv(&c, ms_until(end, 1000));
		int64_t now = now_us();
		if (got < 0) {
			closed_text(&c, err, sizeof(err));
			break;
		}
		if (got == 1 && c.m.type == BC_MSG_EDIT_APPLIED &&
		    c.m.edit_applied.author_seq == seq) {
			t_applied = now - t0;
			order = c.m.edit_applied.order;
		} else if (got == 1 && c.m.type == BC_MSG_FRAME && order &&
		           c.m.frame.order >= order) {
			t_frame = now - t0;
		} else if (got == 1 && c.m.type == BC_MSG_ERROR &&
		           c.m.seq == seq) {
			error_text(&c, err, sizeof(err));
			break;
		}
	}
	t_end = now_us();
	t_sleep_ms(300);
	lr[1].have =
	    get_stats(&stats, BC_PROTO_STATS_LOAD, &lr[1].st, err) == 0;
	if (!lr[1].have) {
		error_line("%s: %s", sc, err);
	}
	atomic_store(&pg.stop, true);
	if (pg.running) {
		pthread_join(pg.th, NULL);
		pg.running = false;
	}
	summarize(&pg.s, t_base, t0, &before);
	summarize(&pg.s, t0, t_end + 1, &during);
	report("\n| measurement | value |\n|---|---:|\n");
	report("| scene | %s |\n", s.what);
	if (t_applied >= 0) {
		report("| EDIT -> EDIT_APPLIED ms | %.1f |\n",
		       (double)t_applied / 1e3);
	} else {
		report("| EDIT -> EDIT_APPLIED ms | none in %d s |\n",
		       BIG_STILL_MS / 1000);
	}
	if (t_frame >= 0) {
		report("| EDIT -> FRAME showing it ms | %.1f |\n",
		       (double)t_frame / 1e3);
	} else {
		report("| EDIT -> FRAME showing it ms | none in %d s |\n",
		       BIG_STILL_MS / 1000);
	}
	{
		char b1[64], b2[64];
		report("| other client's PING p50 / p99 / max ms, before (%zu) "
		       "| %s |\n| the same during the edit (%zu, %zu censored) "
		       "| %s |\n",
		       before.n, fmt3(b1, sizeof(b1), &before), during.n,
		       during.censored, fmt3(b2, sizeof(b2), &during));
	}
	report("\n");
	load_table(sc, lr, 2);
	report("RESULT scenario=%s what=insert spheres=%u load_s=%.2f "
	       "applied_ms=%.1f frame_ms=%.1f\n",
	       sc, s.count, s.load_s, (double)t_applied / 1e3,
	       (double)t_frame / 1e3);
	result_summary(sc, "before_edit", "ping", &before);
	result_summary(sc, "during_edit", "ping", &during);
	if (err[0] && (t_applied < 0 || t_frame < 0)) {
		error_line("%s: %s", sc, err);
	}
out:
	report_client_error("pinger", pg.err);
	atomic_store(&pg.stop, true);
	if (pg.running) {
		pthread_join(pg.th, NULL);
	}
	conn_close(&pg.c);
	series_finish(&pg.s);
	conn_close(&c);
	conn_close(&stats);
	scene_finish(&s);
	bc_proto_buf_finish(&sub);
	fair_stop(&d, sc, false);
	disarm_alarm(sc);
}

/* ---- memory -------------------------------------------------------------- */

/* A new camera (and, when dim changes, a new view size); waits for its
 * first FRAME or an ERROR about either. Returns 1 (frame), 0 (error or
 * timeout: the reason in err), -1 (connection gone). */
static int memory_view(struct conn *c, const struct bc_camera *cam,
                       uint16_t dim, bool new_size, double angle,
                       int timeout_ms, char *err)
{
	uint32_t vseq = 0, cseq;
	int64_t end = now_us() + (int64_t)timeout_ms * 1000;
	if (new_size &&
	    !(vseq = conn_view_scaled(c, dim, dim, BC_PROTO_ENC_JPEG, 2))) {
		return -1;
	}
	if (!(cseq = send_orbit(c, cam, angle, false))) {
		return -1;
	}
	while (now_us() < end) {
		int rc = conn_recv(c, ms_until(end, 1000));
		if (rc < 0) {
			closed_text(c, err, ERRLEN);
			return -1;
		}
		if (rc == 1 && c->m.type == BC_MSG_FRAME &&
		    c->m.frame.camera_seq >= cseq && c->m.frame.width == dim) {
			return 1;
		}
		if (rc == 1 && c->m.type == BC_MSG_ERROR &&
		    (c->m.seq == vseq || c->m.seq == cseq || c->m.seq == 0)) {
			error_text(c, err, ERRLEN);
			return 0;
		}
	}
	seterr(err, "no frame of the %dx%d view within %d s", dim, dim,
	       timeout_ms / 1000);
	return 0;
}

static void scenario_memory(void)
{
	const char *sc = "memory";
	struct daemon d;
	struct conn c = {.fd = -1};
	struct scene s = {0};
	struct bc_msg_stats st;
	char why[ERRLEN], err[ERRLEN] = "";
	uint32_t member;
	bool exited, have_stats;
	int frames[2] = {0, 0}, fails[2] = {0, 0};
	long rss, hwm;
	report("\n### memory\n\n");
	report("One client (fig18 %u smooth) opens %d views of %dx%d at "
	       "different cameras, then %d of %dx%d JPEG at new cameras, "
	       "waiting for a frame of each (or an error); then the "
	       "daemon's VmRSS and VmHWM (/proc/PID/status) and view_cap "
	       "and view_bytes from GET_STATS (LOAD). PASS when RSS <= "
	       "view_cap + %.0f MiB.\n\n",
	       PROBE_SPHERES, MEM_SMALL_VIEWS, MEM_SMALL_DIM, MEM_SMALL_DIM,
	       MEM_BIG_VIEWS, MEM_BIG_DIM, MEM_BIG_DIM, MEM_SLACK_MIB);
	arm_alarm(0);
	if (fair_start(&d, NULL, why, &exited)) {
		error_line("%s: %s", sc, why);
		fair_stop(&d, sc, true);
		disarm_alarm(sc);
		return;
	}
	if (client_session(&c, &d, "mem", "mem", true, &member, err) ||
	    scene_fig18(&s, PROBE_SPHERES, BC_GEN_BLEND_SMOOTH, err) ||
	    scene_load(&c, &s, SMALL_LOAD_MS, err)) {
		error_line("%s: %s", sc, err);
		goto out;
	}
	progress("memory: %d small views, then %d of %d^2", MEM_SMALL_VIEWS,
	         MEM_BIG_VIEWS, MEM_BIG_DIM);
	for (int i = 0; i < MEM_SMALL_VIEWS + MEM_BIG_VIEWS; i++) {
		bool big = i >= MEM_SMALL_VIEWS;
		int rc =
		    memory_view(&c, &s.cam, big ? MEM_BIG_DIM : MEM_SMALL_DIM,
		                i == 0 || i == MEM_SMALL_VIEWS, 0.2 * i,
		                big ? STILL_MS : SMALL_LOAD_MS, err);
		if (rc < 0) {
			error_line("%s: view %d: %s", sc, i, err);
			goto out;
		}
		frames[big] += rc;
		if (rc == 0) {
			fails[big]++;
			report("- view %d (%dx%d): %s\n", i,
			       big ? MEM_BIG_DIM : MEM_SMALL_DIM,
			       big ? MEM_BIG_DIM : MEM_SMALL_DIM, err);
		}
	}
	latency_rss_of(d.pid, &rss, &hwm);
	have_stats = get_stats(&c, BC_PROTO_STATS_LOAD, &st, err) == 0;
	report("| views | frames | errors or timeouts |\n|---|---:|---:|\n"
	       "| %d of %dx%d | %d | %d |\n| %d of %dx%d | %d | %d |\n\n",
	       MEM_SMALL_VIEWS, MEM_SMALL_DIM, MEM_SMALL_DIM, frames[0],
	       fails[0], MEM_BIG_VIEWS, MEM_BIG_DIM, MEM_BIG_DIM, frames[1],
	       fails[1]);
	report("| VmRSS MiB | VmHWM MiB | view_bytes MiB | view_cap MiB |\n"
	       "|---:|---:|---:|---:|\n");
	if (have_stats && st.has_load) {
		report("| %.1f | %.1f | %.1f | %.1f |\n\n",
		       (double)rss / 1024.0, (double)hwm / 1024.0,
		       (double)st.load.view_bytes / 1048576.0,
		       (double)st.load.view_cap / 1048576.0);
	} else {
		report("| %.1f | %.1f | - | - |\n\n", (double)rss / 1024.0,
		       (double)hwm / 1024.0);
	}
	report("RESULT scenario=%s what=rss small_frames=%d big_frames=%d "
	       "errors=%d rss_kib=%ld hwm_kib=%ld",
	       sc, frames[0], frames[1], fails[0] + fails[1], rss, hwm);
	if (have_stats && st.has_load) {
		double cap = (double)st.load.view_cap / 1048576.0;
		report(" view_bytes=%" PRIu64 " view_cap=%" PRIu64 "\n",
		       st.load.view_bytes, st.load.view_cap);
		report("%s %s: VmRSS %.1f MiB <= view_cap %.1f MiB + %.0f MiB "
		       "= %.1f MiB (VmHWM %.1f MiB)\n",
		       rss >= 0 && (double)rss / 1024.0 <= cap + MEM_SLACK_MIB
		           ? "PASS"
		           : "FAIL",
		       sc, (double)rss / 1024.0, cap, MEM_SLACK_MIB,
		       cap + MEM_SLACK_MIB, (double)hwm / 1024.0);
	} else {
		report("\nFAIL %s: no view_cap to hold the RSS against (%s)\n",
		       sc, have_stats ? "the STATS had no load section" : err);
	}
out:
	conn_close(&c);
	scene_finish(&s);
	fair_stop(&d, sc, false);
	disarm_alarm(sc);
}

/* ---- main ---------------------------------------------------------------- */

struct scenario {
	const char *name;
	void (*run)(void);
};

static const struct scenario scenarios[] = {
    {"fairness", scenario_fairness}, {"twist", scenario_twist},
    {"mesh", scenario_mesh},         {"capacity", scenario_capacity},
    {"scaling", scenario_scaling},   {"loop", scenario_loop},
    {"memory", scenario_memory},
};
#define NSCENARIOS (sizeof(scenarios) / sizeof(scenarios[0]))

static void usage(FILE *f)
{
	fprintf(
	    f,
	    "usage: bench_fair --daemon PATH [--daemon-arg ARG]... "
	    "[--scenario NAME]...\n"
	    "                  [--seconds S] [--out FILE]\n"
	    "Plays raw-protocol clients (one thread each) against blobcastd\n"
	    "daemons it starts itself, each on a fresh data directory and\n"
	    "Unix socket under /tmp (--listen none --unix DIR.sock --data "
	    "DIR\n"
	    "--log info, its log in DIR.log), and killed with SIGKILL at "
	    "the\n"
	    "end of its scenario. Prints markdown tables, one RESULT line "
	    "per\n"
	    "measurement (\"RESULT scenario=S [phase=P] what=W "
	    "key=value...\";\n"
	    "times in ms), a PASS or FAIL line per bound, and a \"- error:\"\n"
	    "line for each thing that could not be measured.\n"
	    "\n"
	    "  --daemon PATH     the blobcastd to measure (required)\n"
	    "  --daemon-arg ARG  one more argument for every daemon started;\n"
	    "                    repeat for more (--daemon-arg "
	    "--render-threads\n"
	    "                    --daemon-arg 4). A daemon that refuses one\n"
	    "                    exits at start, and the scenario says so.\n"
	    "  --scenario NAME   run this scenario; repeat for more "
	    "(default:\n"
	    "                    all, in the order below)\n"
	    "  --seconds S       length of each timed phase (default 10)\n"
	    "  --out FILE        also write the report (stdout) to FILE\n"
	    "  --help            this text\n"
	    "\n"
	    "Scenarios:\n"
	    "  fairness  a probe (fig18 64 smooth, 640x480 JPEG) moves a "
	    "sphere\n"
	    "            20 times a second, each edit timed to its FRAME, "
	    "and\n"
	    "            PINGs every 50 ms: (a) alone for S s, (b) for S s\n"
	    "            beside heavy sessions A (100 000 spheres, 1600x1200,\n"
	    "            EDITs of 1024 SETs at 20 Hz), B (4096 spheres, 8 PNG\n"
	    "            snapshots with depth and ids of 2048x2048 "
	    "outstanding)\n"
	    "            and C (20 000 spheres, VIEW and orbit CAMERA every "
	    "30\n"
	    "            ms), (c) the 2 s after they leave, in 0.5 s "
	    "buckets;\n"
	    "            the loop maxima (GET_STATS LOAD) over (b). Bounds: "
	    "(b)\n"
	    "            p50 <= 1.5 alone p50 + 2 ms, p99 <= 3 alone p99 + "
	    "10\n"
	    "            ms, PING p99 <= 20 ms; (c) within 2x alone p50.\n"
	    "  twist     the probe alone for S s, then for S s beside a "
	    "session\n"
	    "            of twist(sphere) at rate 1e6 whose 800x600 view "
	    "waits\n"
	    "            for its first FRAME (bound 5 s) and the probe "
	    "bounds.\n"
	    "  mesh      the probe alone for S s, then for S s beside a "
	    "client\n"
	    "            asking for fig18 1024 smooth's glTF mesh at 128 "
	    "cells\n"
	    "            (MESH) again as each comes: the probe bounds.\n"
	    "  capacity  1, 2, 4, 8, 16 sessions (a fresh daemon each), "
	    "each\n"
	    "            fig18 1024 smooth dragging a sphere at 20 Hz in a\n"
	    "            1024x768 JPEG view for S s: median p50, worst p99;\n"
	    "            PASS when every session's p99 <= 50 ms.\n"
	    "  scaling   an orbit of fig18 1024 smooth at 1024x768 JPEG, "
	    "the\n"
	    "            next CAMERA when the last one's FRAME came, for S "
	    "s,\n"
	    "            with --render-threads 1 and 2 (or, when the daemon\n"
	    "            refuses the option, once with its default).\n"
	    "  loop      an INSERT into fig18 700 000 smooth (the largest "
	    "the\n"
	    "            daemon takes, when it refuses that): time to\n"
	    "            EDIT_APPLIED and to its FRAME, another client's "
	    "PING\n"
	    "            round trips, the loop maxima.\n"
	    "  memory    16 views of 64x64 and 12 of 4096x4096 at new "
	    "cameras;\n"
	    "            VmRSS and VmHWM against view_cap + 150 MiB.\n"
	    "\n"
	    "Latencies are milliseconds; percentiles are nearest rank over "
	    "all\n"
	    "samples of a phase; an answer never received counts as the "
	    "time\n"
	    "waited until the client stopped (\"censored\", a lower bound).\n"
	    "Every wait is bounded; each scenario has an alarm that kills "
	    "its\n"
	    "daemon when it runs %d s past its phases.\n"
	    "Exit status: 0 when every scenario ran (whatever its bounds "
	    "say),\n"
	    "1 when something could not be measured, 2 on a usage error.\n",
	    ALARM_MARGIN_S);
}

static int parse_args(int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
		if (!strcmp(a, "--help")) {
			usage(stdout);
			exit(0);
		}
		if (!v) {
			fprintf(stderr, "bench_fair: %s needs a value\n", a);
			return -1;
		}
		i++;
		if (!strcmp(a, "--daemon")) {
			daemon_path = v;
		} else if (!strcmp(a, "--daemon-arg")) {
			if (opt.nargs == MAX_DAEMON_ARGS) {
				fprintf(stderr,
				        "bench_fair: at most %d "
				        "--daemon-arg\n",
				        MAX_DAEMON_ARGS);
				return -1;
			}
			opt.args[opt.nargs++] = v;
		} else if (!strcmp(a, "--scenario")) {
			bool known = false;
			for (size_t k = 0; k < NSCENARIOS; k++) {
				known = known || !strcmp(v, scenarios[k].name);
			}
			if (!known || opt.nscenarios == MAX_SCENARIOS) {
				fprintf(stderr,
				        "bench_fair: unknown scenario '%s'\n",
				        v);
				return -1;
			}
			opt.scenarios[opt.nscenarios++] = v;
		} else if (!strcmp(a, "--seconds")) {
			char *end;
			opt.seconds = strtod(v, &end);
			if (*end ||
			    !(opt.seconds >= 1 && opt.seconds <= 3600)) {
				fprintf(
				    stderr,
				    "bench_fair: --seconds takes 1..3600\n");
				return -1;
			}
		} else if (!strcmp(a, "--out")) {
			opt.out = v;
		} else {
			fprintf(stderr, "bench_fair: unknown option '%s'\n", a);
			return -1;
		}
	}
	if (!strcmp(daemon_path, BLOBCASTD_PATH)) {
		fprintf(stderr, "bench_fair: --daemon PATH is required\n");
		return -1;
	}
	return 0;
}

static void loadavg(char *buf, size_t n)
{
	FILE *f = fopen("/proc/loadavg", "r");
	double l1 = 0, l5 = 0, l15 = 0;
	if (!f || fscanf(f, "%lf %lf %lf", &l1, &l5, &l15) != 3) {
		snprintf(buf, n, "unknown");
	} else {
		snprintf(buf, n, "%.2f %.2f %.2f", l1, l5, l15);
	}
	if (f) {
		fclose(f);
	}
}

int main(int argc, char **argv)
{
	struct sigaction sa = {0};
	char la[64];
	/* daemon.h's starters are not used: fair_start says why. */
	(void)daemon_start;
	bench_t0 = now_us();
	if (parse_args(argc, argv) != 0) {
		usage(stderr);
		return 2;
	}
	if (access(daemon_path, X_OK) != 0) {
		fprintf(stderr, "bench_fair: %s: %s\n", daemon_path,
		        strerror(errno));
		return 2;
	}
	if (opt.out && !(out_copy = fopen(opt.out, "w"))) {
		fprintf(stderr, "bench_fair: %s: %s\n", opt.out,
		        strerror(errno));
		return 2;
	}
	signal(SIGPIPE, SIG_IGN);
	sa.sa_handler = on_alarm;
	sa.sa_flags = SA_RESTART;
	sigaction(SIGALRM, &sa, NULL);
	sa.sa_handler = on_stop;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	setvbuf(stdout, NULL, _IOLBF, 0);
	if (opt.nscenarios == 0) {
		for (size_t k = 0; k < NSCENARIOS; k++) {
			opt.scenarios[opt.nscenarios++] = scenarios[k].name;
		}
	}
	loadavg(la, sizeof(la));
	report("## bench_fair\n\n- daemon: %s", daemon_path);
	for (int i = 0; i < opt.nargs; i++) {
		report(" %s", opt.args[i]);
	}
	report("\n- phases of %.0f s; %ld processors online; load average "
	       "at the start %s\n",
	       opt.seconds, sysconf(_SC_NPROCESSORS_ONLN), la);
	report("RESULT scenario=machine what=start nproc=%ld "
	       "loadavg_start=\"%s\"\n",
	       sysconf(_SC_NPROCESSORS_ONLN), la);
	for (int i = 0; i < opt.nscenarios; i++) {
		for (size_t k = 0; k < NSCENARIOS; k++) {
			if (!strcmp(opt.scenarios[i], scenarios[k].name)) {
				progress("scenario %s", scenarios[k].name);
				scenarios[k].run();
			}
		}
	}
	loadavg(la, sizeof(la));
	report("\n- load average at the end %s; %d errors\n", la, errors);
	report(
	    "RESULT scenario=machine what=end loadavg_end=\"%s\" errors=%d\n",
	    la, errors);
	if (out_copy) {
		fclose(out_copy);
	}
	return errors ? 1 : 0;
}
