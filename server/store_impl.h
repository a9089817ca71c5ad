/*
 * The data directory's private types and file helpers, shared by store.c
 * (the directory, session files, restoring and recovery from damaged
 * ones), snapshot.c (writing snapshots) and journal.c (appending and
 * replaying the edit journals).
 */
#ifndef BLOBCAST_SERVER_STORE_IMPL_H
#define BLOBCAST_SERVER_STORE_IMPL_H

#include <sys/types.h>

#include "store.h"

#define PATH_LEN 4096

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
	/* A record holding a whole scene (a load) was journaled since the
	 * last snapshot: a snapshot is due at once. */
	bool scene_journaled;
	/* Restoring: acknowledged edits the journals could not give back
	 * (damaged, missing or not applying records), and where a torn tail
	 * starts in the journal read last (-1: none). */
	uint64_t skipped;
	uint64_t skipped_last; /* of them, damaged last records */
	off_t tail_good;
	off_t size; /* journal bytes known good */
	/* Periodic snapshots after a failure wait backoff_ms (doubling). */
	uint64_t retry_at_ms, backoff_ms;
	char name[72];
};

/* ---- store.c ---- */

/* True (errno set to EIO) when the test hook fails this step. */
bool bc__store_injected(const char *step, const char *path);

/* Renames path to path.damaged-TIME, keeping it as evidence; writes the
 * new name into aside (PATH_LEN). 0, or -1 with errno set. */
int bc__store_set_aside(const char *path, char *aside);

/* snprintf into a PATH_LEN buffer; false (and an empty path) when the
 * result would not fit. */
bool __attribute__((format(printf, 2, 3)))
bc__store_fmt_path(char *buf, const char *fmt, ...);

/* Sets ei to BC_EIO "what path: strerror(errno)" and returns BC_EIO. */
int bc__store_sys_error(struct bc_errinfo *ei, const char *what,
                        const char *path);

/* fsyncs the directory path: 0, or -1 with errno set. */
int bc__store_sync_dir(const char *path);

/* Removes temporary files and every snapshot or journal older than keep. */
void bc__store_tidy(const char *path, uint64_t keep);
/* Hands the history kept with snapshot ss->base (history-N.bin) to fn as
 * a record of order 0, when its file is there and whole; a damaged one
 * is logged and left out. Returns 0 or BC_ENOMEM. */
int bc__store_history_give(struct bc_store_session *ss, bc_store_replay_fn fn,
                           void *ud);
/* Writes history-ORDER.bin (synced, renamed into place) from len bytes;
 * with len 0 removes a stale one. Returns 0 or an error in ei. */
int bc__store_history_write(struct bc_store_session *ss, uint64_t order,
                            const uint8_t *p, size_t len,
                            struct bc_errinfo *ei);

/* ---- snapshot.c ---- */

/* DIR/sessions/NAME/snap-ORDER.bin (or .json) into buf (PATH_LEN). */
bool bc__store_snap_path(char *buf, const struct bc_store_session *ss,
                         uint64_t order, bool json);

/* ---- journal.c ---- */

/* Replays journal-<ss->base>.bin through fn after *order (raised to the
 * last order applied), changing nothing on disk; what could not be given
 * back is counted in ss->skipped (see journal.c). */
int bc__store_replay(struct bc_store_session *ss, bc_store_replay_fn fn,
                     void *ud, uint64_t *order, struct bc_errinfo *ei);
/* The highest order of a whole record in journal-<base>.bin (base when
 * none), read without applying anything. */
uint64_t bc__store_journal_last(const struct bc_store_session *ss,
                                uint64_t base);
/* Cuts the torn tail that the last bc__store_replay found (if any). */
int bc__store_cut_tail(struct bc_store_session *ss, struct bc_errinfo *ei);

/* Opens journal-<ss->base>.bin for appending (creating it) and syncs the
 * session's directory. */
int bc__store_open_journal(struct bc_store_session *ss, struct bc_errinfo *ei);

#endif
