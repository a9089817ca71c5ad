/*
 * The edit journals of the data directory (see store.h for the layout):
 * appending a record (framed by a magic, length, order and CRC32, synced
 * before the edit is acknowledged), and replaying journal-N.bin on
 * restore without changing it -- resynchronising past damaged records and
 * counting what could not be given back, finding a torn tail to cut.
 * Snapshots, session files and what a restore decides are store.c's.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/io.h"
#include "blobcast/log.h"
#include "srv_limits.h"
#include "store_impl.h"

/* 'BCJ1' little-endian: the first bytes of every journal record. */
#define JOURNAL_MAGIC 0x314a4342u
#define RECORD_HEADER 20u
/* A journal record carries one EDIT's operations (at most one protocol
 * payload) and, for its undo history, the operations that undo it (at
 * most the scene, at most BC_SRV_MAX_SCENE_BYTES_LIMIT) and who made it;
 * or a SCENE_LOAD's scene (at most BC_SRV_MAX_SCENE_BYTES_LIMIT). */
#define MAX_RECORD                                                             \
	((size_t)BC_PROTO_MAX_PAYLOAD + BC_SRV_MAX_SCENE_BYTES_LIMIT + 4096u)

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
	    bc_get_le32(hdr) != JOURNAL_MAGIC) {
		return 1;
	}
	*len = bc_get_le32(hdr + 4);
	*ord = bc_get_le64(hdr + 8);
	crc = bc_get_le32(hdr + 16);
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

/* Whether a record header with the magic lies at off and the length it
 * gives ends within the file: a record written whole, damaged if its
 * checksum fails (a crash leaves a record short, never long). */
static bool whole_length_at(int fd, off_t off, off_t size)
{
	uint8_t hdr[RECORD_HEADER];
	uint32_t len;
	if (size - off < (off_t)RECORD_HEADER ||
	    !read_at(fd, hdr, sizeof(hdr), off) ||
	    bc_get_le32(hdr) != JOURNAL_MAGIC) {
		return false;
	}
	len = bc_get_le32(hdr + 4);
	return len <= MAX_RECORD &&
	       (off_t)len <= size - off - (off_t)RECORD_HEADER;
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
			if (bc_get_le32(win + i) != JOURNAL_MAGIC) {
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

/* Applies the record of edit ord at off (len bytes in rec) through fn.
 * Returns 1 when it applied, 0 when it did not (logged and counted in
 * ss->skipped: an acknowledged edit the restore cannot give back). */
static int apply_record(struct bc_store_session *ss, const char *file,
                        bc_store_replay_fn fn, void *ud, uint64_t *order,
                        const uint8_t *rec, uint32_t len, uint64_t ord,
                        off_t off)
{
	int r = fn(ud, ord, rec, len);
	if (r) {
		bc_log(BC_LOG_ERROR,
		       "session %s: journal %s: record at bytes %lld..%lld "
		       "(edit %llu) does not apply (%s)",
		       ss->name, file, (long long)off,
		       (long long)(off + RECORD_HEADER + len),
		       (unsigned long long)ord, bc_strerror(r));
		ss->skipped++;
		*order = ord; /* lost, and counted once */
		return 0;
	}
	if (ord != *order + 1 && *order >= ss->base) {
		bc_log(BC_LOG_ERROR,
		       "session %s: journal %s: edits %llu..%llu are missing "
		       "before byte %lld",
		       ss->name, file, (unsigned long long)(*order + 1),
		       (unsigned long long)(ord - 1), (long long)off);
		ss->skipped += ord - *order - 1;
	}
	*order = ord;
	ss->records++;
	return 1;
}

/*
 * Replays journal-<base>.bin without changing it. Records are applied in
 * file order while their order numbers rise. A record that fails its
 * checks is skipped and the reader resynchronises on the next whole
 * record; a record that does not apply is skipped; both are logged with
 * the file, the byte offsets and the orders, and counted in ss->skipped:
 * the restore is then not whole, and the caller does not serve it
 * (store.c). Damage with nothing valid after it is a torn tail (a crash
 * mid-write, never acknowledged): where it starts goes to ss->tail_good,
 * for the caller to cut once it knows the restore is whole.
 */
int bc__store_replay(struct bc_store_session *ss, bc_store_replay_fn fn,
                     void *ud, uint64_t *order, struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	uint8_t *rec = NULL;
	size_t cap = 0;
	off_t off = 0, size, good = 0;
	struct stat st;
	int fd, r = 0, rc = 0;
	bc__store_fmt_path(file, "%s/journal-%llu.bin", ss->path,
	                   (unsigned long long)ss->base);
	ss->tail_good = -1;
	fd = open(file, O_RDONLY | O_CLOEXEC);
	if (fd < 0) {
		return errno == ENOENT
		           ? 0
		           : bc__store_sys_error(ei, "cannot open", file);
	}
	if (fstat(fd, &st) != 0) {
		rc = bc__store_sys_error(ei, "cannot stat", file);
		goto out;
	}
	size = st.st_size;
	while (off < size) {
		uint32_t len;
		uint64_t ord;
		off_t next = size; /* resync sets it; GCC cannot tell */
		r = record_at(fd, off, size, &rec, &cap, &len, &ord);
		if (r == 0 && ord > *order) {
			/* Whole and new: applied, or skipped when fn refuses
			 * it; the next record follows it either way. */
			apply_record(ss, file, fn, ud, order, rec, len, ord,
			             off);
			off += (off_t)RECORD_HEADER + len;
			good = off;
			continue;
		}
		if (r < 0) {
			break;
		}
		/* Damaged, or an order already restored: find the next whole
		 * record after it. */
		if ((r = resync(fd, off + 1, size, *order, &rec, &cap, &next)) <
		    0) {
			break;
		}
		if (next == size) {
			/* Nothing valid follows: a torn tail (a crash
			 * mid-write, never acknowledged) -- unless the record
			 * there is whole in length with a valid header: then
			 * its bytes were damaged after it was written, and
			 * the edit it held is lost. */
			if (whole_length_at(fd, off, size)) {
				bc_log(
				    BC_LOG_ERROR,
				    "session %s: journal %s: the last record "
				    "(bytes %lld..%lld) is damaged",
				    ss->name, file, (long long)off,
				    (long long)size);
				ss->skipped++;
				ss->skipped_last++;
			}
			break;
		}
		/* What it held shows as a gap in the order numbers. */
		bc_log(BC_LOG_ERROR,
		       "session %s: journal %s: bytes %lld..%lld are damaged "
		       "or out of order",
		       ss->name, file, (long long)off, (long long)next);
		off = next;
	}
	if (r < 0) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	} else if (good != size) {
		ss->tail_good = good;
	}
out:
	bc_free(rec);
	close(fd);
	return rc;
}

uint64_t bc__store_journal_last(const struct bc_store_session *ss,
                                uint64_t base)
{
	char file[PATH_LEN];
	uint8_t *rec = NULL;
	size_t cap = 0;
	uint64_t last = base;
	struct stat st;
	off_t off = 0;
	int fd;
	bc__store_fmt_path(file, "%s/journal-%llu.bin", ss->path,
	                   (unsigned long long)base);
	if ((fd = open(file, O_RDONLY | O_CLOEXEC)) < 0) {
		return base;
	}
	while (fstat(fd, &st) == 0 && off < st.st_size) {
		uint32_t len;
		uint64_t ord;
		off_t next = st.st_size;
		if (record_at(fd, off, st.st_size, &rec, &cap, &len, &ord) ==
		    0) {
			last = ord > last ? ord : last;
			off += (off_t)RECORD_HEADER + len;
		} else if (resync(fd, off + 1, st.st_size, 0, &rec, &cap,
		                  &next) < 0 ||
		           next == st.st_size) {
			break;
		} else {
			off = next;
		}
	}
	bc_free(rec);
	close(fd);
	return last;
}

/* Cuts the torn tail replay found in the journal it read last. */
int bc__store_cut_tail(struct bc_store_session *ss, struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	if (ss->tail_good < 0) {
		return 0;
	}
	bc__store_fmt_path(file, "%s/journal-%llu.bin", ss->path,
	                   (unsigned long long)ss->base);
	bc_log(BC_LOG_WARN,
	       "session %s: journal %s: cutting a torn tail at byte %lld",
	       ss->name, file, (long long)ss->tail_good);
	if (truncate(file, ss->tail_good) != 0) {
		return bc__store_sys_error(ei, "cannot truncate", file);
	}
	ss->tail_good = -1;
	return 0;
}

int bc__store_open_journal(struct bc_store_session *ss, struct bc_errinfo *ei)
{
	char file[PATH_LEN];
	bc__store_fmt_path(file, "%s/journal-%llu.bin", ss->path,
	                   (unsigned long long)ss->base);
	ss->journal_fd =
	    open(file, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
	if (ss->journal_fd < 0) {
		return bc__store_sys_error(ei, "cannot open", file);
	}
	ss->size = lseek(ss->journal_fd, 0, SEEK_END);
	if (ss->size < 0 || bc__store_sync_dir(ss->path) != 0) {
		return bc__store_sys_error(ei, "cannot sync", ss->path);
	}
	return 0;
}

/* Appends one record made of the n pieces parts[i] (sizes[i] bytes). */
static int append_parts(struct bc_store_session *ss, uint64_t order,
                        const uint8_t *const *parts, const size_t *sizes, int n,
                        struct bc_errinfo *ei)
{
	uint8_t hdr[RECORD_HEADER];
	uLong crc = crc32(0L, Z_NULL, 0);
	size_t len = 0;
	if (ss->journal_fd < 0) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "the session's journal is not open");
	}
	for (int i = 0; i < n; i++) {
		len += sizes[i];
		crc = crc32(crc, parts[i], (uInt)sizes[i]);
	}
	if (len > MAX_RECORD) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "journal record too large");
	}
	bc_put_le32(hdr, JOURNAL_MAGIC);
	bc_put_le32(hdr + 4, (uint32_t)len);
	bc_put_le64(hdr + 8, order);
	bc_put_le32(hdr + 16, (uint32_t)crc);
	if (bc__store_injected("journal-write", ss->path)) {
		goto fail;
	}
	for (int i = -1; i < n; i++) {
		if (!bc_write_all(ss->journal_fd, i < 0 ? hdr : parts[i],
		                  i < 0 ? sizeof(hdr) : sizes[i])) {
			goto fail;
		}
	}
	if (fdatasync(ss->journal_fd) != 0) {
		goto fail;
	}
	ss->records++;
	ss->size += (off_t)(sizeof(hdr) + len);
	return 0;
fail : {
	int rc = bc__store_sys_error(ei, "cannot append to the journal of",
	                             ss->path);
	bc_log(BC_LOG_ERROR, "session %s: journal write failed: %s", ss->name,
	       strerror(errno));
	/* Never leave half a record in front of the next one. */
	if (ftruncate(ss->journal_fd, ss->size) != 0) {
		bc_log(BC_LOG_ERROR, "cannot cut the journal of %s", ss->path);
	}
	return rc;
}
}

int bc_store_append(struct bc_store_session *ss, uint64_t order,
                    const uint8_t *rec, size_t len, struct bc_errinfo *ei)
{
	return append_parts(ss, order, &rec, &len, 1, ei);
}

int bc_store_append_scene(struct bc_store_session *ss, uint64_t order,
                          const uint8_t *head, size_t hlen,
                          const uint8_t *scene, size_t len,
                          struct bc_errinfo *ei)
{
	const uint8_t *parts[2] = {head, scene};
	size_t sizes[2] = {hlen, len};
	int rc = append_parts(ss, order, parts, sizes, 2, ei);
	if (rc == 0) {
		ss->scene_journaled = true;
	}
	return rc;
}

uint64_t bc_store_journal_records(const struct bc_store_session *ss)
{
	return ss->records;
}
