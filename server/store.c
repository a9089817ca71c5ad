/*
 * The data directory: session snapshots and edit journals (see store.h for
 * the layout and the crash-safety argument).
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

struct bc_store_session {
	struct bc_store *st;
	char *path; /* DIR/sessions/NAME */
	int journal_fd;
	uint64_t base; /* order of the snapshot the journal follows */
	uint64_t records;
	off_t size; /* journal bytes known good */
};

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
		bool tmp = len > 4 && (strstr(e->d_name, ".tmp") != NULL);
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

/* Replays journal-<base>.bin; cuts a torn or corrupt tail. */
static int replay(struct bc_store_session *ss, bc_store_replay_fn fn,
		  void *ud, uint64_t *order, struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	uint8_t hdr[RECORD_HEADER];
	uint8_t *rec = NULL;
	off_t good = 0;
	int fd, rc = 0;
	fmt_path(file, "%s/journal-%llu.bin", ss->path,
		 (unsigned long long)ss->base);
	fd = open(file, O_RDWR | O_CLOEXEC);
	if (fd < 0) {
		return errno == ENOENT ? 0 : sys_error(ei, "cannot open", file);
	}
	for (;;) {
		ssize_t n = read(fd, hdr, sizeof(hdr));
		uint32_t len, crc;
		uint64_t ord;
		uint8_t *grown;
		if (n != (ssize_t)sizeof(hdr) || get32(hdr) != JOURNAL_MAGIC) {
			break;
		}
		len = get32(hdr + 4);
		ord = (uint64_t)get32(hdr + 8) | (uint64_t)get32(hdr + 12) << 32;
		crc = get32(hdr + 16);
		if (len > MAX_RECORD || ord <= *order) {
			break;
		}
		if (!(grown = bc_realloc(rec, len))) {
			rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
			goto out;
		}
		rec = grown;
		if (read(fd, rec, len) != (ssize_t)len ||
		    (uint32_t)crc32(0L, rec, len) != crc) {
			break;
		}
		if ((rc = fn(ud, ord, rec, len))) {
			rc = bc_errinfo_set(ei, rc,
					    "journal %s: record for edit %llu "
					    "does not apply",
					    file, (unsigned long long)ord);
			goto out;
		}
		*order = ord;
		ss->records++;
		good = lseek(fd, 0, SEEK_CUR);
	}
	if (lseek(fd, 0, SEEK_END) != good) {
		bc_log(BC_LOG_WARN, "journal %s: cutting a torn tail at %lld",
		       file, (long long)good);
		if (ftruncate(fd, good) != 0 || fsync(fd) != 0) {
			rc = sys_error(ei, "cannot truncate", file);
		}
	}
out:
	bc_free(rec);
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

int bc_store_session_open(struct bc_store *st, const char *name,
			  struct bc_store_session **out, struct bc_tree *t,
			  struct bc_camera *cam, uint64_t *order, bool *created,
			  bc_store_replay_fn fn, void *ud, struct bc_errinfo *ei)
{
	struct bc_store_session *ss;
	char path[PATH_LEN], file[PATH_LEN];
	bool have_snap = false;
	uint64_t newest = 0;
	DIR *d;
	struct dirent *e;
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
	if (!(d = opendir(path))) {
		rc = sys_error(ei, "cannot read", path);
		goto fail;
	}
	while ((e = readdir(d))) {
		uint64_t n;
		if (parse_numbered(e->d_name, "snap-", ".json", &n) &&
		    (!have_snap || n > newest)) {
			newest = n;
			have_snap = true;
		}
	}
	closedir(d);
	tidy(path, newest);
	if (!have_snap) {
		*created = true;
		*out = ss;
		return 0;
	}
	fmt_path(file, "%s/snap-%llu.json", path,
		 (unsigned long long)newest);
	if ((rc = bc_scene_load_json(file, t, cam, ei))) {
		goto fail;
	}
	ss->base = newest;
	*order = newest;
	if ((rc = replay(ss, fn, ud, order, ei)) ||
	    (rc = open_journal(ss, ei))) {
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

int bc_store_snapshot(struct bc_store_session *ss, const struct bc_tree *t,
		      const struct bc_camera *cam, uint64_t order,
		      struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	int rc;
	fmt_path(file, "%s/snap-%llu.json", ss->path,
		 (unsigned long long)order);
	if ((rc = bc_scene_save_json(file, t, cam, ei))) {
		return rc;
	}
	if (ss->journal_fd >= 0) {
		close(ss->journal_fd);
		ss->journal_fd = -1;
	}
	ss->base = order;
	ss->records = 0;
	if ((rc = open_journal(ss, ei))) {
		return rc;
	}
	tidy(ss->path, order);
	return 0;
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
