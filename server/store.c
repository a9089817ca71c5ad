/*
 * The data directory: session snapshots and edit journals (see store.h for
 * the layout and the crash-safety argument), and recovery from damaged
 * files: a journal is read past damaged records (resynchronising on the
 * next record whose header and checksum hold), a snapshot that does not
 * load is set aside for an older one or the session's files are, and
 * nothing damaged is ever deleted -- it is renamed "*.damaged-TIME".
 */
#include "store.h"

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
#include <zlib.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"

#define PATH_LEN 4096
/* 'BCJ1' little-endian: the first bytes of every journal record. */
#define JOURNAL_MAGIC 0x314a4342u
#define RECORD_HEADER 20u
/* A journal record carries one EDIT's operations: at most one protocol
 * payload. */
#define MAX_RECORD (64u * 1024u * 1024u)

struct bc_store {
	char *dir;
	int lock_fd;
};

/* Test hook: asked before each file system step that can fail. */
static bc_store_fail_fn fail_fn;
static void *fail_ud;

void bc_store_set_fail_hook(bc_store_fail_fn fn, void *ud)
{
	fail_fn = fn;
	fail_ud = ud;
}

/* True (errno set to EIO) when the hook fails this step. */
static bool injected(const char *step, const char *path)
{
	if (fail_fn && fail_fn(fail_ud, step, path)) {
		errno = EIO;
		return true;
	}
	return false;
}

struct bc_store_session {
	struct bc_store *st;
	char *path; /* DIR/sessions/NAME */
	int journal_fd;
	uint64_t base; /* order of the snapshot the journal follows */
	uint64_t records;
	off_t size; /* journal bytes known good */
	/* Periodic snapshots after a failure wait backoff_ms (doubling). */
	uint64_t retry_at_ms, backoff_ms;
	char name[72];
};

static uint64_t mono_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

/* Renames path to base.damaged-YYYYMMDDTHHMMSSZ(-k) (base NULL: path
 * itself), keeping it as evidence; writes the new name into aside
 * (PATH_LEN). */
static int set_aside_as(const char *path, const char *base, char *aside)
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
	for (unsigned k = 0; k < 100; k++) {
		int n =
		    k ? snprintf(aside, PATH_LEN, "%s.damaged-%s-%u", base,
		                 stamp, k)
		      : snprintf(aside, PATH_LEN, "%s.damaged-%s", base, stamp);
		if (n < 0 || n >= PATH_LEN) {
			return -1;
		}
		if (lstat(aside, &st) != 0 && errno == ENOENT) {
			return rename(path, aside);
		}
	}
	return -1;
}

static int set_aside(const char *path, char *aside)
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
static bool __attribute__((format(printf, 2, 3)))
fmt_path(char *buf, const char *fmt, ...)
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

static int sys_error(struct bc_errinfo *ei, const char *what, const char *path)
{
	return bc_errinfo_set(ei, BC_EIO, "%s %s: %s", what, path,
			      strerror(errno));
}

static int make_dir(const char *path, struct bc_errinfo *ei)
{
	if (mkdir(path, 0755) != 0 && errno != EEXIST) {
		return sys_error(ei, "cannot create", path);
	}
	return 0;
}

static int sync_dir(const char *path)
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
	fmt_path(path, "%s/sessions", dir);
	if ((rc = make_dir(path, ei))) {
		return rc;
	}
	st = bc_calloc(1, sizeof(*st));
	if (!st || !(st->dir = bc_strdup(dir))) {
		bc_free(st);
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	fmt_path(path, "%s/LOCK", dir);
	st->lock_fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
	if (st->lock_fd < 0) {
		rc = sys_error(ei, "cannot open", path);
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

int bc_store_list(struct bc_store *st,
		  void (*fn)(void *ud, const char *name), void *ud)
{
	char path[PATH_LEN];
	DIR *d;
	struct dirent *e;
	fmt_path(path, "%s/sessions", st->dir);
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
static void tidy(const char *path, uint64_t keep)
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
		bool old = (parse_numbered(e->d_name, "snap-", ".json", &n) ||
			    parse_numbered(e->d_name, "journal-", ".bin", &n)) &&
			   n < keep;
		bool tmp = len > 4 && (strstr(e->d_name, ".tmp") != NULL) &&
		           strstr(e->d_name, ".damaged-") == NULL;
		if (old || tmp) {
			fmt_path(file, "%s/%s", path, e->d_name);
			if (unlink(file) == 0) {
				bc_log(BC_LOG_DEBUG, "removed %s", file);
			}
		}
	}
	closedir(d);
}

static void put32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++) {
		p[i] = (uint8_t)(v >> (8 * i));
	}
}

static uint32_t get32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	       (uint32_t)p[3] << 24;
}

/* Reads exactly n bytes at off; false on a short read. */
static bool read_at(int fd, void *buf, size_t n, off_t off)
{
	size_t done = 0;
	while (done < n) {
		ssize_t r = pread(fd, (uint8_t *)buf + done, n - done,
		                  off + (off_t)done);
		if (r < 0 && errno == EINTR) {
			continue;
		}
		if (r <= 0) {
			return false;
		}
		done += (size_t)r;
	}
	return true;
}

/* A whole, checksummed record at off (header fields in *len, *ord); its
 * payload is read into *buf (grown). 0: yes; 1: no; < 0: out of memory. */
static int record_at(int fd, off_t off, off_t size, uint8_t **buf, size_t *cap,
                     uint32_t *len, uint64_t *ord)
{
	uint8_t hdr[RECORD_HEADER];
	uint32_t crc;
	if (size - off < (off_t)RECORD_HEADER ||
	    !read_at(fd, hdr, sizeof(hdr), off) ||
	    get32(hdr) != JOURNAL_MAGIC) {
		return 1;
	}
	*len = get32(hdr + 4);
	*ord = (uint64_t)get32(hdr + 8) | (uint64_t)get32(hdr + 12) << 32;
	crc = get32(hdr + 16);
	if (*len > MAX_RECORD ||
	    (off_t)*len > size - off - (off_t)RECORD_HEADER) {
		return 1;
	}
	if (*len > *cap) {
		uint8_t *grown = bc_realloc(*buf, *len);
		if (!grown) {
			return -1;
		}
		*buf = grown;
		*cap = *len;
	}
	if (!read_at(fd, *buf, *len, off + (off_t)RECORD_HEADER) ||
	    (uint32_t)crc32(0L, *buf, *len) != crc) {
		return 1;
	}
	return 0;
}

/* The next offset after off where a whole record with an order above
 * after starts, or size. A damaged length cannot be trusted, so the
 * search goes byte by byte for the magic; a false match must also pass
 * the length bound and the CRC32 of its payload. */
static int resync(int fd, off_t off, off_t size, uint64_t after, uint8_t **buf,
                  size_t *cap, off_t *next)
{
	uint8_t win[4096];
	for (off_t at = off; at + (off_t)RECORD_HEADER <= size;) {
		size_t n = (size_t)(size - at < (off_t)sizeof(win)
		                        ? size - at
		                        : (off_t)sizeof(win));
		if (!read_at(fd, win, n, at)) {
			break;
		}
		for (size_t i = 0; i + 4 <= n; i++) {
			uint32_t len;
			uint64_t ord;
			int rc;
			if (get32(win + i) != JOURNAL_MAGIC) {
				continue;
			}
			rc = record_at(fd, at + (off_t)i, size, buf, cap, &len,
			               &ord);
			if (rc < 0) {
				return rc;
			}
			if (rc == 0 && ord > after) {
				*next = at + (off_t)i;
				return 0;
			}
		}
		/* Overlap by 3 so a magic across windows is seen. */
		at += (off_t)(n > 3 ? n - 3 : n);
	}
	*next = size;
	return 0;
}

/* One record of the rebuilt journal: where it lies in the old file. */
struct kept {
	off_t off;
	uint32_t len;
};

/*
 * Replays journal-<base>.bin. Records are applied in file order while
 * their order numbers rise. A record that fails its checks is skipped and
 * the reader resynchronises on the next whole record; a record that does
 * not apply is skipped; both are logged with the file, the byte offsets
 * and the orders, since later edits then apply to a state that lacks them
 * (the best the journal still knows). Damage with nothing valid after it is
 * a torn tail (a crash mid-write) and is cut. When anything in the middle
 * was skipped, the file is kept as evidence (renamed *.damaged-TIME) and a
 * clean journal of the records that applied takes its place.
 */
static int replay(struct bc_store_session *ss, bc_store_replay_fn fn,
		  void *ud, uint64_t *order, struct bc_errinfo *ei)
{
	char file[PATH_LEN], tmp[PATH_LEN], aside[PATH_LEN];
	uint8_t *rec = NULL;
	size_t cap = 0;
	struct kept *kept = NULL;
	size_t nkept = 0, kcap = 0;
	off_t off = 0, size, good = 0;
	uint64_t skipped = 0;
	struct stat st;
	int fd, rc = 0;
	fmt_path(file, "%s/journal-%llu.bin", ss->path,
		 (unsigned long long)ss->base);
	fd = open(file, O_RDWR | O_CLOEXEC);
	if (fd < 0) {
		return errno == ENOENT ? 0 : sys_error(ei, "cannot open", file);
	}
	if (fstat(fd, &st) != 0) {
		rc = sys_error(ei, "cannot stat", file);
		goto out;
	}
	size = st.st_size;
	while (off < size) {
		uint32_t len;
		uint64_t ord;
		off_t next = size; /* resync sets it; GCC cannot tell */
		int r = record_at(fd, off, size, &rec, &cap, &len, &ord);
		if (r < 0) {
			rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
			goto out;
		}
		if (r == 0 && ord > *order) {
			if ((r = fn(ud, ord, rec, len))) {
				bc_log(
				    BC_LOG_ERROR,
				    "session %s: journal %s: record at bytes "
				    "%lld..%lld (edit %llu) does not apply "
				    "(%s): skipped",
				    ss->name, file, (long long)off,
				    (long long)(off + RECORD_HEADER + len),
				    (unsigned long long)ord, bc_strerror(r));
				skipped++;
			} else {
				if (ord != *order + 1 && *order >= ss->base) {
					bc_log(BC_LOG_ERROR,
					       "session %s: journal %s: edits "
					       "%llu..%llu are missing before "
					       "byte %lld",
					       ss->name, file,
					       (unsigned long long)(*order + 1),
					       (unsigned long long)(ord - 1),
					       (long long)off);
				}
				*order = ord;
				ss->records++;
				if (nkept == kcap) {
					size_t c = kcap ? 2 * kcap : 64;
					struct kept *g = bc_reallocarray(
					    kept, c, sizeof(*kept));
					if (!g) {
						rc = bc_errinfo_set(
						    ei, BC_ENOMEM,
						    "out of memory");
						goto out;
					}
					kept = g;
					kcap = c;
				}
				kept[nkept].off = off;
				kept[nkept++].len = len;
			}
			off += (off_t)RECORD_HEADER + len;
			good = off;
			continue;
		}
		/* Damaged, or an order already restored: find the next whole
		 * record after it. */
		if ((r = resync(fd, off + 1, size, *order, &rec, &cap, &next)) <
		    0) {
			rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
			goto out;
		}
		if (next == size) {
			break; /* nothing valid follows: a torn tail */
		}
		bc_log(BC_LOG_ERROR,
		       "session %s: journal %s: bytes %lld..%lld are damaged "
		       "or out of order: skipped",
		       ss->name, file, (long long)off, (long long)next);
		skipped++;
		off = next;
	}
	if (skipped) {
		/* Keep the evidence; install the records that applied. */
		int out_fd;
		fmt_path(tmp, "%s/journal-%llu.bin.tmp", ss->path,
		         (unsigned long long)ss->base);
		out_fd =
		    open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
		if (out_fd < 0) {
			rc = sys_error(ei, "cannot create", tmp);
			goto out;
		}
		good = 0;
		for (size_t i = 0; i < nkept && !rc; i++) {
			size_t n = RECORD_HEADER + kept[i].len;
			if (n > cap) {
				uint8_t *g = bc_realloc(rec, n);
				if (!g) {
					rc = bc_errinfo_set(ei, BC_ENOMEM,
					                    "out of memory");
					break;
				}
				rec = g;
				cap = n;
			}
			if (!read_at(fd, rec, n, kept[i].off) ||
			    write(out_fd, rec, n) != (ssize_t)n) {
				rc = sys_error(ei, "cannot write", tmp);
			}
			good += (off_t)n;
		}
		if (!rc && fsync(out_fd) != 0) {
			rc = sys_error(ei, "cannot sync", tmp);
		}
		close(out_fd);
		if (!rc && set_aside(file, aside) != 0) {
			rc = sys_error(ei, "cannot set aside", file);
		}
		if (!rc && rename(tmp, file) != 0) {
			rc = sys_error(ei, "cannot rename", tmp);
		}
		if (rc) {
			unlink(tmp);
			goto out;
		}
		sync_dir(ss->path);
		bc_log(BC_LOG_ERROR,
		       "session %s: journal %s: %llu damaged part(s) skipped, "
		       "%llu records restored; the damaged file is kept as %s",
		       ss->name, file, (unsigned long long)skipped,
		       (unsigned long long)ss->records, aside);
	} else if (good != size) {
		bc_log(BC_LOG_WARN,
		       "session %s: journal %s: cutting a torn tail at byte "
		       "%lld (%lld bytes)",
		       ss->name, file, (long long)good,
		       (long long)(size - good));
		if (ftruncate(fd, good) != 0 || fsync(fd) != 0) {
			rc = sys_error(ei, "cannot truncate", file);
		}
	}
out:
	bc_free(rec);
	bc_free(kept);
	close(fd);
	return rc;
}

static int open_journal(struct bc_store_session *ss, struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	fmt_path(file, "%s/journal-%llu.bin", ss->path,
		 (unsigned long long)ss->base);
	ss->journal_fd = open(file, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC,
			      0644);
	if (ss->journal_fd < 0) {
		return sys_error(ei, "cannot open", file);
	}
	ss->size = lseek(ss->journal_fd, 0, SEEK_END);
	if (ss->size < 0 || sync_dir(ss->path) != 0) {
		return sys_error(ei, "cannot sync", ss->path);
	}
	return 0;
}

/* Snapshot orders in the session directory, newest first (at most cap). */
static size_t list_snapshots(const char *path, uint64_t *orders, size_t cap)
{
	DIR *d = opendir(path);
	struct dirent *e;
	size_t n = 0;
	if (!d) {
		return 0;
	}
	while ((e = readdir(d))) {
		uint64_t v;
		size_t i;
		if (!parse_numbered(e->d_name, "snap-", ".json", &v)) {
			continue;
		}
		/* Insertion into a short descending list. */
		for (i = n; i > 0 && orders[i - 1] < v; i--) {
			if (i < cap) {
				orders[i] = orders[i - 1];
			}
		}
		if (i < cap) {
			orders[i] = v;
			if (n < cap) {
				n++;
			}
		}
	}
	closedir(d);
	return n;
}

/* Moves the whole session directory to DIR/sessions/.damaged/NAME-TIME
 * (a name bc_store_list never lists), so that the session starts anew and
 * its files stay for inspection. */
static void set_session_aside(struct bc_store *st, const char *name,
                              const char *path)
{
	char parent[PATH_LEN], base[PATH_LEN], aside[PATH_LEN];
	fmt_path(parent, "%s/sessions/.damaged", st->dir);
	mkdir(parent, 0755);
	fmt_path(base, "%s/%s", parent, name);
	if (set_aside_as(path, base, aside) == 0) {
		bc_log(BC_LOG_ERROR,
		       "session %s: no snapshot loads; its files are kept in "
		       "%s and the session starts anew",
		       name, aside);
	} else {
		bc_log(BC_LOG_ERROR, "session %s: cannot set %s aside: %s",
		       name, path, strerror(errno));
	}
}

int bc_store_session_open(struct bc_store *st, const char *name,
			  struct bc_store_session **out, struct bc_tree *t,
			  struct bc_camera *cam, uint64_t *order, bool *created,
			  bc_store_replay_fn fn, void *ud, struct bc_errinfo *ei)
{
	struct bc_store_session *ss;
	char path[PATH_LEN], file[PATH_LEN], aside[PATH_LEN];
	uint64_t snaps[BC_STORE_SNAPSHOTS_TRIED];
	size_t nsnaps, used = SIZE_MAX;
	int rc;
	*out = NULL;
	*order = 0;
	*created = false;
	if (!bc_store_name_ok(name, strlen(name))) {
		return bc_errinfo_set(ei, BC_EINVAL, "bad session name");
	}
	fmt_path(path, "%s/sessions/%s", st->dir, name);
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
	snprintf(ss->name, sizeof(ss->name), "%s", name);
	nsnaps = list_snapshots(path, snaps, BC_STORE_SNAPSHOTS_TRIED);
	/* The newest snapshot that loads; the ones that do not are set
	 * aside (never deleted) with the session and file named. */
	for (size_t i = 0; i < nsnaps && used == SIZE_MAX; i++) {
		struct bc_errinfo lei = {0};
		fmt_path(file, "%s/snap-%llu.json", path,
		         (unsigned long long)snaps[i]);
		if (bc_scene_load_json(file, t, cam, &lei) == 0) {
			used = i;
			break;
		}
		if (lei.code == BC_ENOMEM) {
			rc = bc_errinfo_set(ei, BC_ENOMEM,
			                    "session %s: %s: out of memory",
			                    name, file);
			goto fail;
		}
		if (set_aside(file, aside) == 0) {
			bc_log(BC_LOG_ERROR,
			       "session %s: snapshot %s does not load (%s); "
			       "kept as %s",
			       name, file, lei.msg, aside);
		} else {
			bc_log(BC_LOG_ERROR,
			       "session %s: snapshot %s does not load (%s)",
			       name, file, lei.msg);
		}
	}
	if (nsnaps && used == SIZE_MAX) {
		/* Nothing loads: the session's files go aside whole. */
		set_session_aside(st, name, path);
		if ((rc = make_dir(path, ei))) {
			goto fail;
		}
	}
	if (used == SIZE_MAX) {
		*created = true;
		*out = ss;
		return 0;
	}
	fmt_path(file, "%s/snap-%llu.json", path,
	         (unsigned long long)snaps[used]);
	ss->base = snaps[used];
	*order = snaps[used];
	if ((rc = replay(ss, fn, ud, order, ei))) {
		goto fail;
	}
	/* Journals chain by order: journal-N follows edit N, whether or not
	 * snap-N loaded (a damaged one was set aside), so the edits after a
	 * damaged snapshot are still restored from the older one. */
	for (;;) {
		char next[PATH_LEN];
		struct stat jst;
		if (*order == ss->base) {
			break;
		}
		fmt_path(next, "%s/journal-%llu.bin", path,
		         (unsigned long long)*order);
		if (stat(next, &jst) != 0) {
			break;
		}
		ss->base = *order;
		ss->records = 0;
		if ((rc = replay(ss, fn, ud, order, ei))) {
			goto fail;
		}
	}
	if (used > 0) {
		bc_log(BC_LOG_ERROR,
		       "session %s: restored from the older snapshot %s and "
		       "the journals after it, up to edit %llu",
		       name, file, (unsigned long long)*order);
	}
	/* Files older than the snapshot that loaded go; it and every journal
	 * from it stay (the chain the next restore follows). */
	tidy(path, snaps[used]);
	if ((rc = open_journal(ss, ei))) {
		goto fail;
	}
	*out = ss;
	return 0;
fail:
	bc_store_session_close(ss);
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

/* Writes len bytes to fd; false on failure (errno set). */
static bool write_all(int fd, const char *p, size_t len)
{
	size_t off = 0;
	while (off < len) {
		ssize_t n = write(fd, p + off, len - off);
		if (n < 0 && errno == EINTR) {
			continue;
		}
		if (n <= 0) {
			if (n == 0) {
				errno = EIO;
			}
			return false;
		}
		off += (size_t)n;
	}
	return true;
}

/*
 * Writes snap-ORDER.json and starts journal-ORDER.bin, or changes nothing
 * on disk: the text is made and its size checked against the reader's
 * limit first; then the temporary file is written and fsynced and the new
 * journal created, and only then is the snapshot renamed into place (the
 * step that makes it the session's state) and the directory fsynced. A
 * failure before the rename removes the temporary file and the new
 * journal; the old snapshot and journal stay the session's state.
 */
int bc_store_snapshot(struct bc_store_session *ss, const struct bc_tree *t,
		      const struct bc_camera *cam, uint64_t order,
		      struct bc_errinfo *ei)
{
	char file[PATH_LEN], tmp[PATH_LEN], jfile[PATH_LEN];
	char *text = NULL;
	size_t len;
	int fd = -1, jfd = -1, rc = 0;
	bool new_journal = false, renamed = false;
	uint64_t previous = ss->base;
	struct stat jst;
	fmt_path(file, "%s/snap-%llu.json", ss->path,
		 (unsigned long long)order);
	fmt_path(tmp, "%s/snap-%llu.json.tmp", ss->path,
	         (unsigned long long)order);
	fmt_path(jfile, "%s/journal-%llu.bin", ss->path,
	         (unsigned long long)order);
	if (bc_tree_nesting(t) > BC_SCENE_JSON_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_EDEPTH,
		                      "the scene nests %u levels; a snapshot "
		                      "holds at most %u",
		                      bc_tree_nesting(t),
		                      BC_SCENE_JSON_MAX_DEPTH);
	}
	if (!(text = bc_scene_to_json(t, cam))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	len = strlen(text);
	/* What the daemon cannot read back is refused before anything is
	 * replaced. */
	if (len > BC_SCENE_JSON_MAX_BYTES || injected("snapshot-size", file)) {
		rc = bc_errinfo_set(ei, BC_ELIMIT,
		                    "the scene's snapshot would be %zu bytes, "
		                    "over the %u a restore reads",
		                    len, BC_SCENE_JSON_MAX_BYTES);
		goto out;
	}
	fd = injected("snapshot-create", tmp)
	         ? -1
	         : open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
	if (fd < 0) {
		rc = sys_error(ei, "cannot create", tmp);
		goto out;
	}
	if (injected("snapshot-write", tmp) || !write_all(fd, text, len)) {
		rc = sys_error(ei, "cannot write", tmp);
		goto out;
	}
	if (injected("snapshot-fsync", tmp) || fsync(fd) != 0) {
		rc = sys_error(ei, "cannot sync", tmp);
		goto out;
	}
	/* The journal that will follow the snapshot exists before the
	 * snapshot does (no inode left fails here, not after the rename). */
	new_journal = stat(jfile, &jst) != 0;
	jfd =
	    injected("journal-create", jfile)
	        ? -1
	        : open(jfile, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
	if (jfd < 0) {
		new_journal = false;
		rc = sys_error(ei, "cannot create", jfile);
		goto out;
	}
	if (injected("snapshot-rename", file) || rename(tmp, file) != 0) {
		rc = sys_error(ei, "cannot rename to", file);
		goto out;
	}
	renamed = true;
	/* From here the snapshot is the state; a failing directory sync
	 * cannot be undone, so it is an error the session must not ignore. */
	if (injected("dir-fsync", ss->path) || sync_dir(ss->path) != 0) {
		rc = sys_error(ei, "cannot sync", ss->path);
	}
	if (ss->journal_fd >= 0) {
		close(ss->journal_fd);
	}
	ss->journal_fd = jfd;
	jfd = -1;
	ss->base = order;
	ss->records = 0;
	ss->size = lseek(ss->journal_fd, 0, SEEK_END);
	ss->retry_at_ms = 0;
	ss->backoff_ms = 0;
	/* The previous generation stays: a snapshot found damaged later is
	 * recovered from it and its journal. */
	tidy(ss->path, previous < order ? previous : order);
out:
	if (fd >= 0) {
		close(fd);
	}
	if (jfd >= 0) {
		close(jfd);
	}
	if (rc && !renamed) {
		unlink(tmp);
		if (new_journal) {
			unlink(jfile);
		}
	}
	bc_free(text);
	return rc;
}

int bc_store_snapshot_due(struct bc_store_session *ss, uint64_t every,
                          const struct bc_tree *t, const struct bc_camera *cam,
                          uint64_t order, struct bc_errinfo *ei)
{
	uint64_t now = mono_ms();
	int rc;
	if (ss->records < every || now < ss->retry_at_ms) {
		return 0;
	}
	if ((rc = bc_store_snapshot(ss, t, cam, order, ei))) {
		ss->backoff_ms = ss->backoff_ms
		                     ? ss->backoff_ms * 2u
		                     : BC_STORE_SNAPSHOT_RETRY_MIN_MS;
		if (ss->backoff_ms > BC_STORE_SNAPSHOT_RETRY_MAX_MS) {
			ss->backoff_ms = BC_STORE_SNAPSHOT_RETRY_MAX_MS;
		}
		ss->retry_at_ms = now + ss->backoff_ms;
		bc_log(BC_LOG_ERROR,
		       "session %s: snapshot failed (%s); next try in %llu ms, "
		       "edits stay journaled meanwhile",
		       ss->name, ei ? ei->msg : bc_strerror(rc),
		       (unsigned long long)ss->backoff_ms);
	}
	return rc;
}

int bc_store_append(struct bc_store_session *ss, uint64_t order,
		    const uint8_t *rec, size_t len, struct bc_errinfo *ei)
{
	uint8_t hdr[RECORD_HEADER];
	const uint8_t *parts[2] = {hdr, rec};
	size_t sizes[2] = {sizeof(hdr), len};
	if (ss->journal_fd < 0) {
		return bc_errinfo_set(ei, BC_ESTATE,
				      "the session's journal is not open");
	}
	if (len > MAX_RECORD) {
		return bc_errinfo_set(ei, BC_ELIMIT, "journal record too large");
	}
	put32(hdr, JOURNAL_MAGIC);
	put32(hdr + 4, (uint32_t)len);
	put32(hdr + 8, (uint32_t)order);
	put32(hdr + 12, (uint32_t)(order >> 32));
	put32(hdr + 16, (uint32_t)crc32(0L, rec, (uInt)len));
	if (injected("journal-write", ss->path)) {
		goto fail;
	}
	for (int i = 0; i < 2; i++) {
		size_t done = 0;
		while (done < sizes[i]) {
			ssize_t n = write(ss->journal_fd, parts[i] + done,
					  sizes[i] - done);
			if (n < 0 && errno == EINTR) {
				continue;
			}
			if (n <= 0) {
				goto fail;
			}
			done += (size_t)n;
		}
	}
	if (fdatasync(ss->journal_fd) != 0) {
		goto fail;
	}
	ss->records++;
	ss->size += (off_t)(sizeof(hdr) + len);
	return 0;
fail:
	{
		int rc = sys_error(ei, "cannot append to the journal of",
				   ss->path);
	        bc_log(BC_LOG_ERROR, "session %s: journal write failed: %s",
	               ss->name, strerror(errno));
	        /* Never leave half a record in front of the next one. */
		if (ftruncate(ss->journal_fd, ss->size) != 0) {
			bc_log(BC_LOG_ERROR, "cannot cut the journal of %s",
			       ss->path);
		}
		return rc;
	}
}

uint64_t bc_store_journal_records(const struct bc_store_session *ss)
{
	return ss->records;
}
