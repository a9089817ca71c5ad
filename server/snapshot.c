/*
 * Writing a session's snapshot (see store.h for the layout): the scene as
 * a binary scene file (blobcast/scene.h), written to a temporary file,
 * fsynced and renamed into place with the journal that follows it
 * created first, so a failure at any step leaves the previous snapshot
 * and journal as the state; and the periodic snapshot, which backs off
 * after a failure (a full disk). A million spheres are 40 MB of it
 * (170 MB as JSON), read back without a JSON document, which took a
 * restarting daemon to 1.4 GiB.
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
#include "blobcast/clock.h"
#include "blobcast/io.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "store_impl.h"

bool bc__store_snap_path(char *buf, const struct bc_store_session *ss,
                         uint64_t order, bool json)
{
	return bc__store_fmt_path(buf, "%s/snap-%llu.%s", ss->path,
	                          (unsigned long long)order,
	                          json ? "json" : "bin");
}

int bc_store_scene_depth_ok(const struct bc_tree *t, struct bc_errinfo *ei)
{
	uint32_t n = bc_tree_nesting(t);
	if (n <= BC_SCENE_JSON_MAX_DEPTH) {
		return 0;
	}
	return bc_errinfo_set(ei, BC_EDEPTH,
	                      "the scene would nest %u levels; a session's "
	                      "scene is saved as a JSON scene file, which "
	                      "holds at most %u",
	                      n, BC_SCENE_JSON_MAX_DEPTH);
}

/*
 * Writes snap-ORDER.bin and starts journal-ORDER.bin, or changes nothing
 * on disk: the scene is streamed to the temporary file as it is encoded
 * (refused once it passes what a restore reads) and fsynced; the new
 * journal is created, and only then is the snapshot renamed into place
 * (the step that makes it the session's state) and the directory
 * fsynced. A failure before the rename removes the temporary file and
 * the new journal; the old snapshot and journal stay the session's
 * state.
 */
int bc_store_snapshot(struct bc_store_session *ss, const struct bc_tree *t,
                      const struct bc_camera *cam, uint64_t order,
                      struct bc_errinfo *ei)
{
	return bc_store_snapshot_with(ss, t, cam, order, NULL, 0, ei);
}

/* The snapshot, header and scene, into a new temporary file tmp (file
 * names the snapshot for the test hook), streamed as it is encoded (a
 * million spheres' 51 MB are never whole in memory), and fsynced. */
static int write_snapshot(const char *tmp, const char *file,
                          const struct bc_tree *t, const struct bc_camera *cam,
                          struct bc_errinfo *ei)
{
	int fd, rc = 0;
	if (bc__store_injected("snapshot-size", file)) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "the scene's snapshot would be over the "
		                      "%u bytes a restore reads",
		                      BC_SCENE_FILE_MAX_BYTES);
	}
	fd = bc__store_injected("snapshot-create", tmp)
	         ? -1
	         : open(tmp, O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
	if (fd < 0) {
		return bc__store_sys_error(ei, "cannot create", tmp);
	}
	if (bc__store_injected("snapshot-write", tmp)) {
		rc = bc__store_sys_error(ei, "cannot write", tmp);
	} else if ((rc = bc_scene_file_write_fd(fd, t, cam)) == BC_EIO) {
		rc = bc__store_sys_error(ei, "cannot write", tmp);
	} else if (rc == BC_ELIMIT) {
		rc = bc_errinfo_set(ei, BC_ELIMIT,
		                    "the scene's snapshot would be over the "
		                    "%u bytes a restore reads",
		                    BC_SCENE_FILE_MAX_BYTES);
	} else if (rc) {
		rc = bc_errinfo_set(ei, rc, "cannot write the snapshot: %s",
		                    bc_strerror(rc));
	} else if (bc__store_injected("snapshot-fsync", tmp) ||
	           fsync(fd) != 0) {
		rc = bc__store_sys_error(ei, "cannot sync", tmp);
	}
	close(fd);
	return rc;
}

int bc_store_snapshot_with(struct bc_store_session *ss, const struct bc_tree *t,
                           const struct bc_camera *cam, uint64_t order,
                           const uint8_t *hist, size_t hlen,
                           struct bc_errinfo *ei)
{
	char file[PATH_LEN], tmp[PATH_LEN], jfile[PATH_LEN], old[PATH_LEN];
	int jfd = -1, rc = 0;
	bool new_journal = false, renamed = false;
	uint64_t previous = ss->base;
	struct stat jst;
	bc__store_snap_path(file, ss, order, false);
	bc__store_fmt_path(tmp, "%s/snap-%llu.bin.tmp", ss->path,
	                   (unsigned long long)order);
	bc__store_fmt_path(jfile, "%s/journal-%llu.bin", ss->path,
	                   (unsigned long long)order);
	if ((rc = bc_store_scene_depth_ok(t, ei))) {
		return rc;
	}
	if ((rc = write_snapshot(tmp, file, t, cam, ei))) {
		goto out;
	}
	/* The journal that will follow the snapshot exists before the
	 * snapshot does (no inode left fails here, not after the rename). */
	new_journal = stat(jfile, &jst) != 0;
	jfd =
	    bc__store_injected("journal-create", jfile)
	        ? -1
	        : open(jfile, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
	if (jfd < 0) {
		new_journal = false;
		rc = bc__store_sys_error(ei, "cannot create", jfile);
		goto out;
	}
	/* The history that goes with it is in place before it is. */
	if ((rc = bc__store_history_write(ss, order, hist, hlen, ei))) {
		goto out;
	}
	if (bc__store_injected("snapshot-rename", file) ||
	    rename(tmp, file) != 0) {
		rc = bc__store_sys_error(ei, "cannot rename to", file);
		goto out;
	}
	renamed = true;
	/* A JSON snapshot of the same order (a data directory of an
	 * earlier version, or one an operator placed) is superseded. */
	if (bc__store_snap_path(old, ss, order, true)) {
		unlink(old);
	}
	/* From here the snapshot is the state; a failing directory sync
	 * cannot be undone, so it is an error the session must not ignore. */
	if (bc__store_injected("dir-fsync", ss->path) ||
	    bc__store_sync_dir(ss->path) != 0) {
		rc = bc__store_sys_error(ei, "cannot sync", ss->path);
	}
	if (ss->journal_fd >= 0) {
		close(ss->journal_fd);
	}
	ss->journal_fd = jfd;
	jfd = -1;
	ss->base = order;
	ss->records = 0;
	ss->scene_journaled = false;
	ss->size = lseek(ss->journal_fd, 0, SEEK_END);
	ss->retry_at_ms = 0;
	ss->backoff_ms = 0;
	/* The previous generation stays: a snapshot found damaged later is
	 * recovered from it and its journal. */
	bc__store_tidy(ss->path, previous < order ? previous : order);
out:
	if (jfd >= 0) {
		close(jfd);
	}
	if (rc && !renamed) {
		unlink(tmp);
		if (new_journal) {
			unlink(jfile);
		}
	}
	return rc;
}

bool bc_store_snapshot_is_due(const struct bc_store_session *ss, uint64_t every)
{
	return (ss->records >= every || ss->scene_journaled) &&
	       bc_clock_ns() / 1000000u >= ss->retry_at_ms;
}

int bc_store_snapshot_due(struct bc_store_session *ss, uint64_t every,
                          const struct bc_tree *t, const struct bc_camera *cam,
                          uint64_t order, struct bc_errinfo *ei)
{
	return bc_store_snapshot_due_with(ss, every, t, cam, order, NULL, 0,
	                                  ei);
}

int bc_store_snapshot_due_with(struct bc_store_session *ss, uint64_t every,
                               const struct bc_tree *t,
                               const struct bc_camera *cam, uint64_t order,
                               const uint8_t *hist, size_t hlen,
                               struct bc_errinfo *ei)
{
	uint64_t now = bc_clock_ns() / 1000000u;
	int rc;
	if (!bc_store_snapshot_is_due(ss, every)) {
		return 0;
	}
	if ((rc = bc_store_snapshot_with(ss, t, cam, order, hist, hlen, ei))) {
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

/* history-N.bin: 'BCH1', u32 length, u32 CRC32 of what follows, then the
 * history (undo.c's carried form). */
#define HISTORY_MAGIC 0x31484342u
#define HISTORY_HEADER 12u
/* The history is bounded by BC_SRV_UNDO_BYTES in memory; its carried form
 * adds a few bytes per node and step. */
#define HISTORY_MAX_BYTES (256u * 1024u * 1024u)

int bc__store_history_write(struct bc_store_session *ss, uint64_t order,
                            const uint8_t *p, size_t len, struct bc_errinfo *ei)
{
	char file[PATH_LEN], tmp[PATH_LEN];
	uint8_t hdr[HISTORY_HEADER];
	int fd;
	bool ok;
	bc__store_fmt_path(file, "%s/history-%llu.bin", ss->path,
	                   (unsigned long long)order);
	bc__store_fmt_path(tmp, "%s/history-%llu.bin.tmp", ss->path,
	                   (unsigned long long)order);
	if (len == 0 || len > HISTORY_MAX_BYTES) {
		unlink(file);
		return 0;
	}
	bc_put_le32(hdr, HISTORY_MAGIC);
	bc_put_le32(hdr + 4, (uint32_t)len);
	bc_put_le32(hdr + 8, (uint32_t)crc32(0L, p, (uInt)len));
	if ((fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)) <
	    0) {
		return bc__store_sys_error(ei, "cannot create", tmp);
	}
	ok = !bc__store_injected("history-write", tmp) &&
	     bc_write_all(fd, hdr, sizeof(hdr)) && bc_write_all(fd, p, len) &&
	     fsync(fd) == 0;
	close(fd);
	if (!ok || rename(tmp, file) != 0) {
		int rc = bc__store_sys_error(ei, "cannot write", tmp);
		unlink(tmp);
		return rc;
	}
	return 0;
}

int bc__store_history_give(struct bc_store_session *ss, bc_store_replay_fn fn,
                           void *ud)
{
	char file[PATH_LEN];
	uint8_t hdr[HISTORY_HEADER], *p = NULL;
	struct stat st;
	uint32_t len = 0;
	bool ok;
	int fd;
	bc__store_fmt_path(file, "%s/history-%llu.bin", ss->path,
	                   (unsigned long long)ss->base);
	if ((fd = open(file, O_RDONLY | O_CLOEXEC)) < 0) {
		return 0;
	}
	ok = fstat(fd, &st) == 0 && st.st_size >= (off_t)HISTORY_HEADER &&
	     read(fd, hdr, sizeof(hdr)) == (ssize_t)sizeof(hdr) &&
	     bc_get_le32(hdr) == HISTORY_MAGIC &&
	     (len = bc_get_le32(hdr + 4)) <= HISTORY_MAX_BYTES &&
	     (off_t)len == st.st_size - (off_t)HISTORY_HEADER;
	if (ok && !(p = bc_malloc(len ? len : 1))) {
		close(fd);
		return BC_ENOMEM;
	}
	ok = ok && read(fd, p, len) == (ssize_t)len &&
	     (uint32_t)crc32(0L, p, len) == bc_get_le32(hdr + 8);
	close(fd);
	if (ok) {
		fn(ud, 0, p, len);
	} else {
		bc_log(BC_LOG_WARN,
		       "session %s: %s is damaged; the undo history before "
		       "the snapshot is lost (the scene is not)",
		       ss->name, file);
	}
	bc_free(p);
	return 0;
}
