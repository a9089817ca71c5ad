/*
 * The data directory: its lock, session directories and snapshots (see
 * store.h for the layout and the crash-safety argument), and recovery from
 * damaged files: a snapshot that does not load is set aside for an older
 * one or the session's files are, and nothing damaged is ever deleted --
 * it is renamed "*.damaged-TIME". Writing snapshots is snapshot.c's; the
 * edit journals (appending, and replaying past damaged records) are
 * journal.c's.
 */
#include "store_impl.h"

#include <dirent.h>
#include <errno.h>
#include <stdarg.h>
#include <stdbool.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/io.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"

/* Test hook: asked before each file system step that can fail. */
static bc_store_fail_fn fail_fn;
static void *fail_ud;

void bc_store_set_fail_hook(bc_store_fail_fn fn, void *ud)
{
	fail_fn = fn;
	fail_ud = ud;
}

/* True (errno set to EIO) when the hook fails this step. */
bool bc__store_injected(const char *step, const char *path)
{
	if (fail_fn && fail_fn(fail_ud, step, path)) {
		errno = EIO;
		return true;
	}
	return false;
}

/* Names set aside per base and second, at most. */
#define ASIDE_NAMES 100000u

/* Renames path to base.WHY-YYYYMMDDTHHMMSSZ(-k) (base NULL: path itself),
 * keeping it as evidence; writes the new name into aside (PATH_LEN). k
 * counts the names of that second already taken: a name deleted and
 * created again many times a second gets as many (it ran out at 100 and
 * the 101st SESSION_DELETE answered EIO). */
static int set_aside_why(const char *path, const char *base, const char *why,
                         char *aside)
{
	char stamp[32];
	time_t now = time(NULL);
	struct tm tm;
	struct stat st;
	if (!base) {
		base = path;
	}
	gmtime_r(&now, &tm);
	strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%SZ", &tm);
	for (unsigned k = 0; k < ASIDE_NAMES; k++) {
		int n =
		    k ? snprintf(aside, PATH_LEN, "%s.%s-%s-%u", base, why,
		                 stamp, k)
		      : snprintf(aside, PATH_LEN, "%s.%s-%s", base, why, stamp);
		if (n < 0 || n >= PATH_LEN) {
			return -1;
		}
		if (lstat(aside, &st) != 0 && errno == ENOENT) {
			return rename(path, aside);
		}
	}
	errno = EEXIST;
	return -1;
}

static int set_aside_as(const char *path, const char *base, char *aside)
{
	return set_aside_why(path, base, "damaged", aside);
}

int bc__store_set_aside(const char *path, char *aside)
{
	return set_aside_as(path, NULL, aside);
}

bool bc_store_name_ok(const char *name, size_t len)
{
	if (len == 0 || len > 64 || name[0] == '.') {
		return false;
	}
	for (size_t i = 0; i < len; i++) {
		char c = name[i];
		bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
		          (c >= '0' && c <= '9') || c == '-' || c == '_' ||
		          c == '.';
		if (!ok) {
			return false;
		}
	}
	return true;
}

/* snprintf into a PATH_LEN buffer; false (and an empty path) when the
 * result would not fit, so no call works on a truncated name. */
bool __attribute__((format(printf, 2, 3)))
bc__store_fmt_path(char *buf, const char *fmt, ...)
{
	va_list args;
	int n;
	va_start(args, fmt);
	n = vsnprintf(buf, PATH_LEN, fmt, args);
	va_end(args);
	if (n < 0 || n >= PATH_LEN) {
		buf[0] = '\0';
		return false;
	}
	return true;
}

int bc__store_sys_error(struct bc_errinfo *ei, const char *what,
                        const char *path)
{
	return bc_errinfo_set(ei, BC_EIO, "%s %s: %s", what, path,
	                      strerror(errno));
}

static int make_dir(const char *path, struct bc_errinfo *ei)
{
	if (mkdir(path, 0755) != 0 && errno != EEXIST) {
		return bc__store_sys_error(ei, "cannot create", path);
	}
	return 0;
}

int bc__store_sync_dir(const char *path)
{
	int fd = open(path, O_RDONLY | O_DIRECTORY);
	int rc;
	if (fd < 0) {
		return -1;
	}
	rc = fsync(fd);
	close(fd);
	return rc;
}

int bc_store_open(struct bc_store **out, const char *dir, struct bc_errinfo *ei)
{
	struct bc_store *st;
	char path[PATH_LEN];
	struct flock lk = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
	int rc;
	*out = NULL;
	/* Every path is DIR plus at most a session name (64) and a file name
	 * (40): bounding DIR keeps them all far inside PATH_LEN. */
	if (strlen(dir) > 1024) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "data directory path over 1024 bytes");
	}
	if ((rc = make_dir(dir, ei))) {
		return rc;
	}
	bc__store_fmt_path(path, "%s/sessions", dir);
	if ((rc = make_dir(path, ei))) {
		return rc;
	}
	st = bc_calloc(1, sizeof(*st));
	if (!st || !(st->dir = bc_strdup(dir))) {
		bc_free(st);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	bc__store_fmt_path(path, "%s/LOCK", dir);
	st->lock_fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
	if (st->lock_fd < 0) {
		rc = bc__store_sys_error(ei, "cannot open", path);
		goto fail;
	}
	if (fcntl(st->lock_fd, F_SETLK, &lk) != 0) {
		rc = bc_errinfo_set(ei, BC_EBUSY,
		                    "data directory %s is in use by another "
		                    "daemon",
		                    dir);
		goto fail;
	}
	*out = st;
	return 0;
fail:
	if (st->lock_fd >= 0) {
		close(st->lock_fd);
	}
	bc_free(st->dir);
	bc_free(st);
	return rc;
}

void bc_store_close(struct bc_store *st)
{
	if (!st) {
		return;
	}
	close(st->lock_fd);
	bc_free(st->dir);
	bc_free(st);
}

int bc_store_list(struct bc_store *st, void (*fn)(void *ud, const char *name),
                  void *ud)
{
	char path[PATH_LEN];
	DIR *d;
	struct dirent *e;
	bc__store_fmt_path(path, "%s/sessions", st->dir);
	if (!(d = opendir(path))) {
		return BC_EIO;
	}
	while ((e = readdir(d))) {
		if (bc_store_name_ok(e->d_name, strlen(e->d_name))) {
			fn(ud, e->d_name);
		}
	}
	closedir(d);
	return 0;
}

uint64_t bc_store_session_mtime_ms(const struct bc_store_session *ss)
{
	char file[PATH_LEN];
	uint64_t newest = 0;
	struct dirent *e;
	struct stat sb;
	DIR *d = opendir(ss->path);
	if (!d) {
		return 0;
	}
	while ((e = readdir(d))) {
		uint64_t ms;
		if (e->d_name[0] == '.' ||
		    !bc__store_fmt_path(file, "%s/%s", ss->path, e->d_name) ||
		    stat(file, &sb) != 0) {
			continue;
		}
		ms = (uint64_t)sb.st_mtim.tv_sec * 1000u +
		     (uint64_t)sb.st_mtim.tv_nsec / 1000000u;
		if (ms > newest) {
			newest = ms;
		}
	}
	closedir(d);
	return newest;
}

bool bc_store_session_exists(struct bc_store *st, const char *name)
{
	char path[PATH_LEN];
	struct stat sb;
	return bc_store_name_ok(name, strlen(name)) &&
	       bc__store_fmt_path(path, "%s/sessions/%s", st->dir, name) &&
	       stat(path, &sb) == 0 && S_ISDIR(sb.st_mode);
}

int bc_store_session_delete(struct bc_store *st, const char *name,
                            struct bc_errinfo *ei)
{
	char path[PATH_LEN], parent[PATH_LEN], base[PATH_LEN], aside[PATH_LEN];
	bc__store_fmt_path(path, "%s/sessions/%s", st->dir, name);
	bc__store_fmt_path(parent, "%s/sessions/.deleted", st->dir);
	if (mkdir(parent, 0755) != 0 && errno != EEXIST) {
		return bc__store_sys_error(ei, "cannot create", parent);
	}
	bc__store_fmt_path(base, "%s/%s", parent, name);
	if (set_aside_why(path, base, "deleted", aside) != 0) {
		return bc__store_sys_error(ei, "cannot move aside", path);
	}
	bc__store_fmt_path(path, "%s/sessions", st->dir);
	if (bc__store_sync_dir(path) != 0 || bc__store_sync_dir(parent) != 0) {
		bc_log(BC_LOG_WARN, "session %s: moved to %s, not yet synced",
		       name, aside);
	}
	bc_log(BC_LOG_INFO, "session %s deleted: its files are kept in %s",
	       name, aside);
	return 0;
}

/* Parses "PREFIX<digits>SUFFIX" into *order. */
static bool parse_numbered(const char *name, const char *prefix,
                           const char *suffix, uint64_t *order)
{
	size_t lp = strlen(prefix), ls = strlen(suffix), ln = strlen(name);
	uint64_t v = 0;
	if (ln <= lp + ls || strncmp(name, prefix, lp) != 0 ||
	    strcmp(name + ln - ls, suffix) != 0) {
		return false;
	}
	for (size_t i = lp; i < ln - ls; i++) {
		if (name[i] < '0' || name[i] > '9' || v > UINT64_MAX / 10) {
			return false;
		}
		v = v * 10 + (uint64_t)(name[i] - '0');
	}
	*order = v;
	return true;
}

/* Removes temporary files and every snapshot or journal older than keep. */
void bc__store_tidy(const char *path, uint64_t keep)
{
	DIR *d = opendir(path);
	struct dirent *e;
	char file[PATH_LEN];
	if (!d) {
		return;
	}
	while ((e = readdir(d))) {
		uint64_t n;
		size_t len = strlen(e->d_name);
		bool old =
		    (parse_numbered(e->d_name, "snap-", ".bin", &n) ||
		     parse_numbered(e->d_name, "snap-", ".json", &n) ||
		     parse_numbered(e->d_name, "journal-", ".bin", &n) ||
		     parse_numbered(e->d_name, "history-", ".bin", &n)) &&
		    n < keep;
		bool tmp = len > 4 && (strstr(e->d_name, ".tmp") != NULL) &&
		           strstr(e->d_name, ".damaged-") == NULL;
		if (old || tmp) {
			bc__store_fmt_path(file, "%s/%s", path, e->d_name);
			if (unlink(file) == 0) {
				bc_log(BC_LOG_DEBUG, "removed %s", file);
			}
		}
	}
	closedir(d);
}

/* Snapshots in the session directory, newest first (at most cap): their
 * orders, and whether each is a JSON scene file. Where one order has
 * both, the binary one (written after the other) is read. */
static size_t list_snapshots(const char *path, uint64_t *orders, bool *json,
                             size_t cap)
{
	DIR *d = opendir(path);
	struct dirent *e;
	size_t n = 0;
	if (!d) {
		return 0;
	}
	while ((e = readdir(d))) {
		uint64_t v;
		bool j = false;
		size_t i;
		if (!parse_numbered(e->d_name, "snap-", ".bin", &v) &&
		    !(j = parse_numbered(e->d_name, "snap-", ".json", &v))) {
			continue;
		}
		for (i = 0; i < n && orders[i] != v; i++) {
		}
		if (i < n) {
			/* The same order's other file: the binary one is
			 * read. */
			json[i] = json[i] && j;
			continue;
		}
		/* Insertion into a short descending list. */
		for (i = n; i > 0 && orders[i - 1] < v; i--) {
			if (i < cap) {
				orders[i] = orders[i - 1];
				json[i] = json[i - 1];
			}
		}
		if (i < cap) {
			orders[i] = v;
			json[i] = j;
			if (n < cap) {
				n++;
			}
		}
	}
	closedir(d);
	return n;
}

/* Moves the whole session directory to DIR/sessions/.damaged/NAME-TIME
 * (a name bc_store_list never lists), keeping its files for inspection.
 * 0, or -1 with errno set. */
static int set_session_aside(struct bc_store *st, const char *name,
                             const char *path, char *aside)
{
	char parent[PATH_LEN], base[PATH_LEN];
	bc__store_fmt_path(parent, "%s/sessions/.damaged", st->dir);
	mkdir(parent, 0755);
	bc__store_fmt_path(base, "%s/%s", parent, name);
	return set_aside_as(path, base, aside);
}

/* The highest N of the journal-N.bin files in path (0 when none). */
static uint64_t newest_journal(const char *path)
{
	DIR *d = opendir(path);
	struct dirent *e;
	uint64_t newest = 0, v;
	if (!d) {
		return 0;
	}
	while ((e = readdir(d))) {
		if (parse_numbered(e->d_name, "journal-", ".bin", &v) &&
		    v > newest) {
			newest = v;
		}
	}
	closedir(d);
	return newest;
}

/* What a restore read, for deciding whether it may be served. */
struct restore {
	uint64_t snaps[BC_STORE_SNAPSHOTS_TRIED];
	bool json[BC_STORE_SNAPSHOTS_TRIED]; /* snap-N.json, not .bin */
	size_t nsnaps, used; /* used: SIZE_MAX when none loads */
	struct bc_store_check c;
	uint64_t newest_journal; /* the highest N of the journal-N.bin files */
};

/* The frontier raised to the last record of the newest journal: the
 * highest order number the session ever acknowledged, which a repair
 * goes on from (never using one twice). */
static void frontier_of_journals(const struct bc_store_session *ss,
                                 struct restore *r)
{
	uint64_t last = bc__store_journal_last(ss, r->newest_journal);
	if (last > r->c.frontier) {
		r->c.frontier = last;
	}
}

/* Loads the newest snapshot that loads into t and cam, then every journal
 * that follows it (by order: journal-N follows edit N, whether or not
 * snap-N loaded), changing nothing on disk. r->c says how far it got and
 * what the files promised. */
static int restore(struct bc_store_session *ss, struct bc_tree *t,
                   struct bc_camera *cam, uint64_t *order,
                   bc_store_replay_fn fn, void *ud, struct restore *r,
                   struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	int rc;
	r->used = SIZE_MAX;
	r->nsnaps = list_snapshots(ss->path, r->snaps, r->json,
	                           BC_STORE_SNAPSHOTS_TRIED);
	for (size_t i = 0; i < r->nsnaps; i++) {
		struct bc_errinfo lei = {0};
		bc__store_snap_path(file, ss, r->snaps[i], r->json[i]);
		if ((r->json[i]
		         ? bc_scene_load_json(file, t, cam, &lei)
		         : bc_scene_load_binary(file, t, cam, &lei)) == 0) {
			r->used = i;
			break;
		}
		if (lei.code == BC_ENOMEM) {
			return bc_errinfo_set(ei, BC_ENOMEM,
			                      "session %s: %s: out of memory",
			                      ss->name, file);
		}
		r->c.damaged_snapshots++;
		bc_log(BC_LOG_ERROR,
		       "session %s: snapshot %s does not load (%s)", ss->name,
		       file, lei.msg);
		if (i == 0) {
			snprintf(r->c.why, sizeof(r->c.why),
			         "its newest snapshot snap-%llu.%s does not "
			         "load (%.300s)",
			         (unsigned long long)r->snaps[i],
			         r->json[i] ? "json" : "bin", lei.msg);
		}
	}
	r->c.snapshots = (uint32_t)r->nsnaps;
	r->c.frontier = r->nsnaps ? r->snaps[0] : 0;
	r->newest_journal = newest_journal(ss->path);
	if (r->newest_journal > r->c.frontier) {
		r->c.frontier = r->newest_journal;
	}
	if (r->used == SIZE_MAX) {
		frontier_of_journals(ss, r);
		return 0;
	}
	r->c.loaded = true;
	ss->base = *order = r->snaps[r->used];
	if ((rc = bc__store_history_give(ss, fn, ud))) {
		return bc_errinfo_set(ei, rc, "session %s: out of memory",
		                      ss->name);
	}
	if ((rc = bc__store_replay(ss, fn, ud, order, ei))) {
		return rc;
	}
	for (;;) {
		char next[PATH_LEN];
		struct stat jst;
		if (*order == ss->base) {
			break;
		}
		bc__store_fmt_path(next, "%s/journal-%llu.bin", ss->path,
		                   (unsigned long long)*order);
		if (stat(next, &jst) != 0) {
			break;
		}
		ss->base = *order;
		ss->records = 0;
		if ((rc = bc__store_replay(ss, fn, ud, order, ei))) {
			return rc;
		}
	}
	r->c.order = *order;
	r->c.lost = ss->skipped;
	if (*order > r->c.frontier) {
		r->c.frontier = *order;
	}
	r->c.whole = r->c.lost == 0 && *order >= r->c.frontier;
	if (!r->c.whole) {
		frontier_of_journals(ss, r);
		/* A lost record past the last one read (a damaged last
		 * record) named an order too: never give it out again. */
		if (*order + ss->skipped_last > r->c.frontier) {
			r->c.frontier = *order + ss->skipped_last;
		}
	}
	if (!r->c.whole && !r->c.why[0]) {
		snprintf(r->c.why, sizeof(r->c.why),
		         "%llu acknowledged edit(s) cannot be given back "
		         "(journal records damaged, missing or not applying)",
		         (unsigned long long)r->c.lost);
	}
	return 0;
}

/* A whole restore becomes the session's files: the snapshots that did
 * not load go aside (kept, never deleted), a torn tail is cut, files
 * older than the generation before the snapshot that loaded go (that
 * generation stays, so that a file damaged after this restart still has
 * a backup), and the journal opens for appending. */
static int settle(struct bc_store_session *ss, const struct restore *r,
                  struct bc_errinfo *ei)
{
	char file[PATH_LEN], aside[PATH_LEN];
	int rc;
	for (size_t i = 0; i < r->used; i++) {
		bc__store_snap_path(file, ss, r->snaps[i], r->json[i]);
		if (bc__store_set_aside(file, aside) == 0) {
			bc_log(BC_LOG_ERROR,
			       "session %s: snapshot %s is kept as %s; the "
			       "older snapshot and the journals gave back "
			       "every edit, up to %llu",
			       ss->name, file, aside,
			       (unsigned long long)r->c.order);
		}
	}
	if ((rc = bc__store_cut_tail(ss, ei))) {
		return rc;
	}
	bc__store_tidy(ss->path, r->used + 1 < r->nsnaps ? r->snaps[r->used + 1]
	                                                 : r->snaps[r->used]);
	return bc__store_open_journal(ss, ei);
}

static int new_session(struct bc_store *st, const char *name,
                       struct bc_store_session **out, struct bc_errinfo *ei)
{
	struct bc_store_session *ss;
	char path[PATH_LEN];
	int rc;
	*out = NULL;
	if (!bc_store_name_ok(name, strlen(name))) {
		return bc_errinfo_set(ei, BC_EINVAL, "bad session name");
	}
	bc__store_fmt_path(path, "%s/sessions/%s", st->dir, name);
	if ((rc = make_dir(path, ei))) {
		return rc;
	}
	ss = bc_calloc(1, sizeof(*ss));
	if (!ss || !(ss->path = bc_strdup(path))) {
		bc_free(ss);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	ss->st = st;
	ss->journal_fd = -1;
	ss->tail_good = -1;
	snprintf(ss->name, sizeof(ss->name), "%s", name);
	*out = ss;
	return 0;
}

int bc_store_session_open(struct bc_store *st, const char *name,
                          struct bc_store_session **out, struct bc_tree *t,
                          struct bc_camera *cam, uint64_t *order, bool *created,
                          bc_store_replay_fn fn, void *ud,
                          struct bc_errinfo *ei)
{
	struct bc_store_session *ss;
	struct restore r = {0};
	int rc;
	*order = 0;
	*created = false;
	if ((rc = new_session(st, name, &ss, ei))) {
		return rc;
	}
	if ((rc = restore(ss, t, cam, order, fn, ud, &r, ei))) {
		goto fail;
	}
	if (r.nsnaps == 0 && r.c.frontier == 0) {
		*created = true;
		*out = ss;
		return 0;
	}
	if (!r.c.whole) {
		/* Never an older state under order numbers already given
		 * out: the files stay as they are for an operator. */
		rc = bc_errinfo_set(
		    ei, BC_EIO,
		    "session %s cannot be restored whole: %s (its files name "
		    "edits up to %llu). Its files are kept unchanged and it "
		    "is not served: see `blobcastd --check %s`",
		    name, r.c.why[0] ? r.c.why : "no snapshot loads",
		    (unsigned long long)r.c.frontier, st->dir);
		bc_log(BC_LOG_ERROR, "%s", ei ? ei->msg : "session damaged");
		goto fail;
	}
	if ((rc = settle(ss, &r, ei))) {
		goto fail;
	}
	*out = ss;
	return 0;
fail:
	bc_store_session_close(ss);
	*out = NULL;
	return rc;
}

int bc_store_session_check(struct bc_store *st, const char *name,
                           struct bc_tree *t, struct bc_camera *cam,
                           bc_store_replay_fn fn, void *ud,
                           struct bc_store_check *out, struct bc_errinfo *ei)
{
	struct bc_store_session *ss;
	struct restore r = {0};
	uint64_t order = 0;
	int rc;
	memset(out, 0, sizeof(*out));
	if ((rc = new_session(st, name, &ss, ei))) {
		return rc;
	}
	rc = restore(ss, t, cam, &order, fn, ud, &r, ei);
	*out = r.c;
	if (r.nsnaps == 0 && r.c.frontier == 0) {
		out->whole = true;
	}
	bc_store_session_close(ss);
	return rc;
}

int bc_store_session_repair(struct bc_store *st, const char *name,
                            const struct bc_tree *t,
                            const struct bc_camera *cam, uint64_t order,
                            struct bc_errinfo *ei)
{
	struct bc_store_session *ss;
	char path[PATH_LEN], aside[PATH_LEN];
	int rc;
	bc__store_fmt_path(path, "%s/sessions/%s", st->dir, name);
	if (set_session_aside(st, name, path, aside) != 0) {
		return bc__store_sys_error(ei, "cannot move aside", path);
	}
	if ((rc = new_session(st, name, &ss, ei))) {
		return rc;
	}
	rc = bc_store_snapshot(ss, t, cam, order, ei);
	bc_store_session_close(ss);
	if (!rc) {
		bc_log(BC_LOG_WARN,
		       "session %s repaired: its old files are kept in %s; it "
		       "goes on from edit %llu",
		       name, aside, (unsigned long long)order);
	}
	return rc;
}

void bc_store_session_close(struct bc_store_session *ss)
{
	if (!ss) {
		return;
	}
	if (ss->journal_fd >= 0) {
		close(ss->journal_fd);
	}
	bc_free(ss->path);
	bc_free(ss);
}

/* The session's owner: one line, the client name, in DIR/.../owner. */
int bc_store_owner_write(struct bc_store_session *ss, const char *owner,
                         struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	size_t len = strlen(owner);
	int fd;
	bool ok;
	bc__store_fmt_path(file, "%s/owner", ss->path);
	if ((fd = open(file, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)) <
	    0) {
		return bc__store_sys_error(ei, "cannot create", file);
	}
	ok = bc_write_all(fd, owner, len) && fsync(fd) == 0;
	close(fd);
	if (!ok || bc__store_sync_dir(ss->path) != 0) {
		return bc__store_sys_error(ei, "cannot write", file);
	}
	return 0;
}

void bc_store_owner_read(const struct bc_store_session *ss,
                         char out[BC_STORE_OWNER_MAX + 1])
{
	char file[PATH_LEN];
	ssize_t n = -1;
	int fd;
	out[0] = '\0';
	bc__store_fmt_path(file, "%s/owner", ss->path);
	if ((fd = open(file, O_RDONLY | O_CLOEXEC)) >= 0) {
		n = read(fd, out, BC_STORE_OWNER_MAX);
		close(fd);
	}
	out[n > 0 ? n : 0] = '\0';
	/* A name with a NUL in it is no name (the file was damaged). */
	if (n > 0 && strlen(out) != (size_t)n) {
		out[0] = '\0';
	}
}
