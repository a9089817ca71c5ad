/*
 * Persistence of sessions under the data directory:
 *
 *   DIR/sessions/NAME/snap-ORDER.json   the scene after edit ORDER (atomic)
 *   DIR/sessions/NAME/journal-ORDER.bin edits after that snapshot
 *
 * A snapshot is written to a temporary file, fsynced, renamed and the
 * directory fsynced; then a new journal starts and older files go. Journal
 * records are appended and fdatasynced before the edit is acknowledged, so
 * a crash loses no acknowledged edit; a torn last record (crash mid-write)
 * fails its checksum and is cut off on restore.
 */
#ifndef BLOBCAST_SERVER_STORE_H
#define BLOBCAST_SERVER_STORE_H

#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"

struct bc_store;
struct bc_store_session;

/* Opens (creating) the data directory and takes its lock file, so that two
 * daemons never share one. Leftover temporary files are removed. */
int bc_store_open(struct bc_store **out, const char *dir, struct bc_errinfo *ei);
void bc_store_close(struct bc_store *st);

/* Calls fn for each stored session name. */
int bc_store_list(struct bc_store *st,
		  void (*fn)(void *ud, const char *name), void *ud);

/* Called for each journal record on restore, in order. */
typedef int (*bc_store_replay_fn)(void *ud, uint64_t order, const uint8_t *rec,
				  size_t len);

/* Opens session name: loads its newest snapshot into t and cam and replays
 * its journal through fn; *order is the last order restored. A session that
 * does not exist yet is created empty (*order = 0, t untouched) and
 * *created set. */
int bc_store_session_open(struct bc_store *st, const char *name,
			  struct bc_store_session **out, struct bc_tree *t,
			  struct bc_camera *cam, uint64_t *order, bool *created,
			  bc_store_replay_fn fn, void *ud, struct bc_errinfo *ei);
void bc_store_session_close(struct bc_store_session *ss);

/* Writes the whole scene as of order (atomic) and starts a new journal. */
int bc_store_snapshot(struct bc_store_session *ss, const struct bc_tree *t,
		      const struct bc_camera *cam, uint64_t order,
		      struct bc_errinfo *ei);

/* Appends one record and syncs it to disk before returning 0. */
int bc_store_append(struct bc_store_session *ss, uint64_t order,
		    const uint8_t *rec, size_t len, struct bc_errinfo *ei);

/* Records appended since the last snapshot. */
uint64_t bc_store_journal_records(const struct bc_store_session *ss);

/* Is name usable as a session name (and directory name)? */
bool bc_store_name_ok(const char *name, size_t len);

#endif
