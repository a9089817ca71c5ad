/*
 * Persistence of sessions under the data directory:
 *
 *   DIR/sessions/NAME/snap-ORDER.bin    the scene after edit ORDER (atomic;
 *                                       snap-ORDER.json, a JSON scene
 *                                       file, from earlier versions or an
 *                                       operator, is read too)
 *   DIR/sessions/NAME/journal-ORDER.bin edits after that snapshot
 *   DIR/sessions/NAME/history-ORDER.bin the undo history as of it
 *   DIR/sessions/NAME/owner             who created the session
 *
 * A snapshot is written to a temporary file, fsynced, renamed and the
 * directory fsynced; then a new journal starts and older files go. Journal
 * records are appended and fdatasynced before the edit is acknowledged, so
 * a crash loses no acknowledged edit; a torn last record (crash mid-write)
 * fails its checksum and is cut off on restore. The previous snapshot and
 * its journal are kept until the next snapshot, for recovery.
 *
 * A restore never goes back in time. A snapshot that does not load is
 * recovered from the previous snapshot and the journals after it (a
 * SCENE_LOAD is journaled too, so that no state is held by one snapshot
 * alone, and its snapshot follows its answer: bc_store_append_scene); it
 * is then kept as snap-N.bin.damaged-TIME. When the files
 * cannot give back every edit they acknowledged (records damaged,
 * missing or not applying, or a newest state no older file reaches), the
 * session is not served and its files are not touched: opening it fails
 * with BC_EIO and a sentence naming `blobcastd --check`, which reports
 * (bc_store_session_check) and repairs (bc_store_session_repair: the old
 * files go to sessions/.damaged/NAME.damaged-TIME and the best state
 * they give goes on from the highest order number they named, so no
 * order number is used twice). A torn tail (a crash mid-write, never
 * acknowledged) is cut.
 */
#ifndef BLOBCAST_SERVER_STORE_H
#define BLOBCAST_SERVER_STORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"

/* Snapshots tried, newest first, when restoring a session. */
#define BC_STORE_SNAPSHOTS_TRIED 8u
/* After a periodic snapshot fails (disk full), the next is tried no sooner
 * than this, doubling per failure up to the maximum: a full disk must not
 * make every edit pay for a failed 1000-edit snapshot (measured: 0.03 ->
 * 146 ms per edit), and a minute bounds how long a freed disk waits. */
#define BC_STORE_SNAPSHOT_RETRY_MIN_MS 1000u
#define BC_STORE_SNAPSHOT_RETRY_MAX_MS 60000u

struct bc_store;
struct bc_store_session;

/* Opens (creating) the data directory and takes its lock file, so that two
 * daemons never share one. Leftover temporary files are removed. */
int bc_store_open(struct bc_store **out, const char *dir,
                  struct bc_errinfo *ei);
void bc_store_close(struct bc_store *st);

/* Calls fn for each stored session name. */
int bc_store_list(struct bc_store *st, void (*fn)(void *ud, const char *name),
                  void *ud);

/* Called for each journal record on restore, in order. */
typedef int (*bc_store_replay_fn)(void *ud, uint64_t order, const uint8_t *rec,
                                  size_t len);

/* Opens session name: loads its newest snapshot into t and cam and replays
 * its journal through fn; *order is the last order restored. A session that
 * does not exist yet is created empty (*order = 0, t untouched) and
 * *created set. BC_EIO (files unchanged) when it cannot be restored whole
 * (see above). */
int bc_store_session_open(struct bc_store *st, const char *name,
                          struct bc_store_session **out, struct bc_tree *t,
                          struct bc_camera *cam, uint64_t *order, bool *created,
                          bc_store_replay_fn fn, void *ud,
                          struct bc_errinfo *ei);
void bc_store_session_close(struct bc_store_session *ss);

/* What a session's files give back (bc_store_session_check). */
struct bc_store_check {
	bool loaded;       /* a snapshot loaded */
	bool whole;        /* every acknowledged edit can be given back */
	uint64_t order;    /* the last edit restored */
	uint64_t frontier; /* the highest edit any of its files names */
	uint64_t lost;     /* journal records damaged, missing or refused */
	uint32_t snapshots, damaged_snapshots;
	char why[512]; /* when not whole: the first reason */
};

/* Restores session name into t and cam as bc_store_session_open would,
 * changing nothing on disk, and says how far it got in *out. */
int bc_store_session_check(struct bc_store *st, const char *name,
                           struct bc_tree *t, struct bc_camera *cam,
                           bc_store_replay_fn fn, void *ud,
                           struct bc_store_check *out, struct bc_errinfo *ei);

/* An operator's repair of a session that is not whole: its directory goes
 * to sessions/.damaged/NAME.damaged-TIME (kept), and t and cam become its
 * snapshot at order (the highest order its files named), from which it
 * goes on. */
int bc_store_session_repair(struct bc_store *st, const char *name,
                            const struct bc_tree *t,
                            const struct bc_camera *cam, uint64_t order,
                            struct bc_errinfo *ei);

/* 0 when a session may hold scene t, else BC_EDEPTH with the reason: it
 * nests deeper than a JSON scene file holds (BC_SCENE_JSON_MAX_DEPTH), so
 * that a session's scene can always be saved as one (`blobcast scene`).
 * A change that fails it is refused before it applies. */
int bc_store_scene_depth_ok(const struct bc_tree *t, struct bc_errinfo *ei);

/* Writes the whole scene as of order (atomic) and starts a new journal.
 * On failure nothing on disk has changed (the old snapshot and journal are
 * the state): BC_EIO, BC_ENOMEM, BC_ELIMIT (the snapshot would pass
 * BC_SCENE_FILE_MAX_BYTES, which restoring reads) or BC_EDEPTH
 * (bc_store_scene_depth_ok). */
int bc_store_snapshot(struct bc_store_session *ss, const struct bc_tree *t,
                      const struct bc_camera *cam, uint64_t order,
                      struct bc_errinfo *ei);
/* As bc_store_snapshot, and keeps hist[0..hlen) (the session's undo
 * history as of order) in history-ORDER.bin beside it, written before the
 * snapshot is renamed into place: a restore from snap-ORDER hands it to
 * the replay function as a record of order 0 before the journal's. */
int bc_store_snapshot_with(struct bc_store_session *ss, const struct bc_tree *t,
                           const struct bc_camera *cam, uint64_t order,
                           const uint8_t *hist, size_t hlen,
                           struct bc_errinfo *ei);
/* The periodic snapshot: taken when every or more records were journaled
 * since the last one, or a whole scene was (bc_store_append_scene),
 * unless a failed attempt is still backing off
 * (BC_STORE_SNAPSHOT_RETRY_*). Returns 0 when nothing was due or it
 * succeeded; a failure is logged as an error and also returned. */
int bc_store_snapshot_due(struct bc_store_session *ss, uint64_t every,
                          const struct bc_tree *t, const struct bc_camera *cam,
                          uint64_t order, struct bc_errinfo *ei);
/* As bc_store_snapshot_due, keeping hist as bc_store_snapshot_with does. */
int bc_store_snapshot_due_with(struct bc_store_session *ss, uint64_t every,
                               const struct bc_tree *t,
                               const struct bc_camera *cam, uint64_t order,
                               const uint8_t *hist, size_t hlen,
                               struct bc_errinfo *ei);
/* Whether the periodic snapshot is due now (bc_store_snapshot_due would
 * write one). */
bool bc_store_snapshot_is_due(const struct bc_store_session *ss,
                              uint64_t every);

/* The client name that created a session, kept in its directory's
 * "owner" file (written once, when a SESSION_CREATE makes it). */
#define BC_STORE_OWNER_MAX 64u
int bc_store_owner_write(struct bc_store_session *ss, const char *owner,
                         struct bc_errinfo *ei);
/* The owner, or "" when none was written. */
void bc_store_owner_read(const struct bc_store_session *ss,
                         char out[BC_STORE_OWNER_MAX + 1]);

/* Appends one record and syncs it to disk before returning 0. */
int bc_store_append(struct bc_store_session *ss, uint64_t order,
                    const uint8_t *rec, size_t len, struct bc_errinfo *ei);
/* Appends a record that holds a whole scene (a SCENE_LOAD): head[0..hlen)
 * then scene[0..len), as one record, synced as bc_store_append. Once it is
 * on disk the scene is safe; the snapshot that takes its place becomes due
 * at once (bc_store_snapshot_is_due), to be written after the load is
 * answered rather than before, and the journal holds it until then. */
int bc_store_append_scene(struct bc_store_session *ss, uint64_t order,
                          const uint8_t *head, size_t hlen,
                          const uint8_t *scene, size_t len,
                          struct bc_errinfo *ei);

/* Records appended since the last snapshot. */
uint64_t bc_store_journal_records(const struct bc_store_session *ss);

/* Test hook: fn is asked before each file system step that can fail
 * ("snapshot-size": as if the text passed the reader's limit,
 * "snapshot-create", "snapshot-write", "snapshot-fsync", "journal-create",
 * "snapshot-rename", "dir-fsync", "journal-write") and fails it (EIO) by
 * returning true. NULL removes it. Not for the daemon. */
typedef bool (*bc_store_fail_fn)(void *ud, const char *step, const char *path);
void bc_store_set_fail_hook(bc_store_fail_fn fn, void *ud);

/* When session ss last changed on disk: the newest modification time of
 * its files, Unix milliseconds (0 when none can be read). */
uint64_t bc_store_session_mtime_ms(const struct bc_store_session *ss);

/* Whether session name has a directory in the store (loaded or not). */
bool bc_store_session_exists(struct bc_store *st, const char *name);

/* Deletes session name (closed first by the caller): its directory moves
 * to DIR/sessions/.deleted/NAME.deleted-TIME, which bc_store_list never
 * lists, so a session of that name starts anew; the files stay until an
 * operator removes them. */
int bc_store_session_delete(struct bc_store *st, const char *name,
                            struct bc_errinfo *ei);

/* Is name usable as a session name (and directory name)? */
bool bc_store_name_ok(const char *name, size_t len);

#endif
