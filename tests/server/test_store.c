/*
 * The data directory's recovery (server/store.c, snapshot.c, journal.c):
 * a restore never goes back in time: a snapshot that does not load is
 * recovered from the previous one and the journals; a session whose files
 * cannot give back every acknowledged edit is refused with its files
 * unchanged, checked and repaired on from its highest order; other
 * sessions carry on; a snapshot that failed at any step (injected) leaves
 * nothing on disk; periodic snapshots back off after a failure; journal write
 * failures are logged as errors; a journaled whole scene is safe before
 * the snapshot it makes due.
 */
#include <dirent.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "store.h"
#include "test.h"

#define NREC 100u

struct replayed {
	uint64_t orders[4 * NREC];
	uint32_t n;
};

/* A record "applies" unless its payload starts with 'X'. */
static int collect(void *ud, uint64_t order, const uint8_t *rec, size_t len)
{
	struct replayed *r = ud;
	if (len && rec[0] == 'X') {
		return BC_EINVAL;
	}
	if (r->n < 4 * NREC) {
		r->orders[r->n++] = order;
	}
	return 0;
}

static char *make_dir(void)
{
	char tmpl[] = "/tmp/bc-store.XXXXXX";
	char *d = mkdtemp(tmpl);
	return d ? strdup(d) : NULL;
}

static void rm_rf(const char *path)
{
	char cmd[512];
	snprintf(cmd, sizeof(cmd), "rm -rf '%s'", path);
	if (system(cmd) != 0) {
		fprintf(stderr, "  cannot remove %s\n", path);
	}
}

/* Number of entries of dir whose name contains part. */
static int count_named(const char *dir, const char *part)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	int n = 0;
	if (!d) {
		return 0;
	}
	while ((e = readdir(d))) {
		n += strstr(e->d_name, part) != NULL;
	}
	closedir(d);
	return n;
}

static struct bc_tree *default_tree(void)
{
	struct bc_tree *t = bc_tree_create();
	const char *json = bc_scene_default_json();
	if (t && bc_scene_parse_json(json, strlen(json), t, NULL, NULL)) {
		bc_tree_destroy(t);
		t = NULL;
	}
	return t;
}

/* Opens session name in dir, replaying into r. */
/* A store and one of its sessions, opened by open_session() with what it
 * replayed, its order and whether it was made, and closed by shut(). */
struct opened {
	struct bc_store *st;
	struct bc_store_session *ss;
	struct replayed r;
	uint64_t order;
	bool created;
};

static int open_session(struct opened *o, const char *dir, const char *name,
                        struct bc_tree *t)
{
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	int rc = bc_store_open(&o->st, dir, &ei);
	if (rc) {
		return rc;
	}
	memset(&o->r, 0, sizeof(o->r));
	rc = bc_store_session_open(o->st, name, &o->ss, t, &cam, &o->order,
	                           &o->created, collect, &o->r, &ei);
	if (rc) {
		fprintf(stderr, "  open %s: %s\n", name, ei.msg);
		bc_store_close(o->st);
	}
	return rc;
}

static void shut(struct opened *o)
{
	bc_store_session_close(o->ss);
	bc_store_close(o->st);
}

/* A session with a snapshot at 0 and records 1..n ("rec-K"; bad, when not
 * 0, is written as "X..." so that it does not apply). */
static void make_session(const char *dir, const char *name, uint32_t n,
                         uint32_t bad)
{
	struct opened o;
	struct bc_tree *t = default_tree();
	REQUIRE(t);
	REQUIRE(open_session(&o, dir, name, t) == 0);
	CHECK(o.created);
	REQUIRE(bc_store_snapshot(o.ss, t, NULL, 0, NULL) == 0);
	for (uint32_t k = 1; k <= n; k++) {
		char rec[64];
		int len = snprintf(rec, sizeof(rec), "%srec-%u-padding-padding",
		                   k == bad ? "X" : "", k);
		REQUIRE(bc_store_append(o.ss, k, (const uint8_t *)rec,
		                        (size_t)len, NULL) == 0);
	}
	shut(&o);
	bc_tree_destroy(t);
}

/* Byte offset of record k (1-based) in a journal of make_session's. */
static long record_offset(uint32_t k)
{
	long off = 0;
	for (uint32_t i = 1; i < k; i++) {
		char rec[64];
		off += 20 +
		       snprintf(rec, sizeof(rec), "rec-%u-padding-padding", i);
	}
	return off;
}

static void flip(const char *file, long off, int n)
{
	FILE *f = fopen(file, "r+b");
	REQUIRE(f);
	for (int i = 0; i < n; i++) {
		int c;
		fseek(f, off + i, SEEK_SET);
		c = fgetc(f);
		fseek(f, off + i, SEEK_SET);
		fputc(c ^ 0x5a, f);
	}
	fclose(f);
}

/* Size of file (-1 when it cannot be read). */
static long file_size(const char *file)
{
	struct stat sb;
	return stat(file, &sb) == 0 ? (long)sb.st_size : -1;
}

/* What bc_store_session_check says of session name in dir. */
static void check_session(const char *dir, const char *name,
                          struct bc_store_check *c)
{
	struct bc_store *st;
	struct bc_tree *t = default_tree();
	struct bc_camera cam;
	struct replayed r = {0};
	REQUIRE(t && bc_store_open(&st, dir, NULL) == 0);
	REQUIRE(bc_store_session_check(st, name, t, &cam, collect, &r, c,
	                               NULL) == 0);
	bc_store_close(st);
	bc_tree_destroy(t);
}

/* A session that is not whole is refused (BC_EIO) with its files as they
 * were; the check names what is lost; a repair goes on from the highest
 * order its files named, its old files kept aside. */
static void refused_then_repaired(const char *dir, const char *name,
                                  const char *file, uint64_t frontier,
                                  uint64_t lost, bool loaded)
{
	char sdir[512], aside[512];
	struct opened o;
	struct bc_tree *t = default_tree();
	struct bc_store_check c;
	long size = file_size(file);
	REQUIRE(t);
	snprintf(sdir, sizeof(sdir), "%s/sessions/%s", dir, name);
	CHECK_EQ_INT(open_session(&o, dir, name, t), BC_EIO);
	CHECK_EQ_INT(count_named(sdir, ".damaged-"), 0);
	CHECK(file_size(file) == size);
	check_session(dir, name, &c);
	CHECK(!c.whole);
	CHECK(c.loaded == loaded);
	CHECK_EQ_INT(c.frontier, frontier);
	CHECK_EQ_INT(c.lost, lost);
	CHECK(c.why[0] != '\0');
	/* (A tree that a failed load left alone; the state is the test's.) */
	bc_tree_destroy(t);
	REQUIRE((t = default_tree()) && bc_store_open(&o.st, dir, NULL) == 0);
	REQUIRE(bc_store_session_repair(o.st, name, t, NULL, c.frontier,
	                                NULL) == 0);
	bc_store_close(o.st);
	snprintf(aside, sizeof(aside), "%s/sessions/.damaged", dir);
	CHECK_EQ_INT(count_named(aside, name), 1);
	/* It goes on after the highest order: none is used twice. */
	REQUIRE(open_session(&o, dir, name, t) == 0);
	CHECK(!o.created);
	CHECK_EQ_INT(o.order, frontier);
	CHECK_EQ_INT(o.r.n, 0);
	REQUIRE(bc_store_append(o.ss, frontier + 1, (const uint8_t *)"next", 4,
	                        NULL) == 0);
	shut(&o);
	check_session(dir, name, &c);
	CHECK(c.whole);
	CHECK_EQ_INT(c.order, frontier + 1);
	bc_tree_destroy(t);
}

/* Damage at offset delta into record 50 (payload: CRC fails; length
 * field: the framing is lost): edit 50 cannot be given back, so the
 * session is not served from the rest (which would show a state that
 * never was under order numbers already given out). */
static void damaged_record(long delta)
{
	char *dir = make_dir(), file[600];
	REQUIRE(dir);
	make_session(dir, "a", NREC, 0);
	snprintf(file, sizeof(file), "%s/sessions/a/journal-0.bin", dir);
	flip(file, record_offset(50) + delta, 4);
	refused_then_repaired(dir, "a", file, NREC, 1, true);
	rm_rf(dir);
	free(dir);
}

static void a_flipped_payload_is_not_served(void)
{
	damaged_record(24);
}

static void a_flipped_length_field_is_not_served(void)
{
	damaged_record(4);
}

/* The last record damaged in place (its header and length intact, its
 * payload flipped) was written whole: a loss, not a torn tail to cut. A
 * repair goes on after its order. */
static void a_damaged_last_record_is_not_a_torn_tail(void)
{
	char *dir = make_dir(), file[600];
	REQUIRE(dir);
	make_session(dir, "a", NREC, 0);
	snprintf(file, sizeof(file), "%s/sessions/a/journal-0.bin", dir);
	flip(file, record_offset(NREC) + 24, 4);
	refused_then_repaired(dir, "a", file, NREC, 1, true);
	rm_rf(dir);
	free(dir);
}

static void a_record_that_does_not_apply_is_not_served(void)
{
	char *dir = make_dir(), file[600];
	REQUIRE(dir);
	make_session(dir, "a", NREC, 30);
	snprintf(file, sizeof(file), "%s/sessions/a/journal-0.bin", dir);
	refused_then_repaired(dir, "a", file, NREC, 1, true);
	rm_rf(dir);
	free(dir);
}

static void a_torn_tail_is_cut(void)
{
	char *dir = make_dir(), file[600];
	struct opened o;
	struct bc_tree *t = default_tree();
	REQUIRE(dir && t);
	make_session(dir, "a", 10, 0);
	snprintf(file, sizeof(file), "%s/sessions/a/journal-0.bin", dir);
	REQUIRE(truncate(file, record_offset(10) + 25) == 0);
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK_EQ_INT(o.r.n, 9);
	CHECK_EQ_INT(o.order, 9);
	shut(&o);
	bc_tree_destroy(t);
	rm_rf(dir);
	free(dir);
}

static void write_file(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");
	REQUIRE(f);
	fputs(text, f);
	fclose(f);
}

/* A corrupt snapshot of one session, its only one: the other restores;
 * the bad one is refused, its files unchanged, and a repair goes on from
 * the last edit its journal holds (5), not from 0. */
static void a_corrupt_snapshot_spares_the_other_session(void)
{
	char *dir = make_dir(), file[600];
	struct opened o;
	struct bc_tree *t = default_tree();
	REQUIRE(dir && t);
	make_session(dir, "a", 5, 0);
	make_session(dir, "b", 7, 0);
	snprintf(file, sizeof(file), "%s/sessions/a/snap-0.bin", dir);
	write_file(file, "BCS1 and then not a scene");
	REQUIRE(open_session(&o, dir, "b", t) == 0);
	CHECK_EQ_INT(o.order, 7);
	shut(&o);
	refused_then_repaired(dir, "a", file, 5, 0, false);
	bc_tree_destroy(t);
	rm_rf(dir);
	free(dir);
}

/* Session "a" in dir: make_session's snapshot 0 and edits 1..10, a
 * snapshot at 10 and edits 11..15 after it. */
static void two_generations(const char *dir, struct bc_tree *t)
{
	struct opened o;
	make_session(dir, "a", 10, 0);
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	REQUIRE(bc_store_snapshot(o.ss, t, NULL, 10, NULL) == 0);
	for (uint32_t k = 11; k <= 15; k++) {
		REQUIRE(bc_store_append(o.ss, k, (const uint8_t *)"later", 5,
		                        NULL) == 0);
	}
	shut(&o);
}

/* The newest snapshot corrupt -- not a snapshot at all, or one byte
 * flipped anywhere (a float of the scene, the middle, its length, its
 * checksum), which the checksum finds: the previous one and both journals
 * give back every edit, and the damaged file is kept aside. */
static void a_corrupt_snapshot_falls_back_to_the_previous(void)
{
	static const long at[] = {-2, 20, -1, 5, 9};
	for (size_t i = 0; i < sizeof(at) / sizeof(at[0]); i++) {
		char *dir = make_dir(), file[600], sdir[512];
		struct opened o;
		struct bc_tree *t = default_tree();
		REQUIRE(dir && t);
		two_generations(dir, t);
		snprintf(sdir, sizeof(sdir), "%s/sessions/a", dir);
		snprintf(file, sizeof(file), "%s/snap-10.bin", sdir);
		if (at[i] == -2) {
			write_file(file, "not a snapshot");
		} else {
			flip(file, at[i] < 0 ? file_size(file) / 2 : at[i], 1);
		}
		REQUIRE(open_session(&o, dir, "a", t) == 0);
		CHECK(!o.created);
		CHECK_EQ_INT(o.order, 15);
		CHECK_EQ_INT(o.r.n, 15);
		CHECK_EQ_INT(count_named(sdir, "snap-10.bin.damaged-"), 1);
		/* Later edits and restarts keep following that chain. */
		REQUIRE(bc_store_append(o.ss, 16, (const uint8_t *)"more", 4,
		                        NULL) == 0);
		shut(&o);
		REQUIRE(open_session(&o, dir, "a", t) == 0);
		CHECK_EQ_INT(o.order, 16);
		CHECK_EQ_INT(o.r.n, 16);
		REQUIRE(bc_store_snapshot(o.ss, t, NULL, 16, NULL) == 0);
		shut(&o);
		REQUIRE(open_session(&o, dir, "a", t) == 0);
		CHECK_EQ_INT(o.order, 16);
		CHECK_EQ_INT(o.r.n, 0);
		shut(&o);
		bc_tree_destroy(t);
		rm_rf(dir);
		free(dir);
	}
}

/* A restore keeps the generation before the snapshot it loaded, as
 * writing a snapshot does (docs/operations.md): after a restart, an
 * emptied newest snapshot is recovered from the previous one and the
 * journals, with no acknowledged edit lost. */
static void a_restore_keeps_the_previous_generation(void)
{
	char *dir = make_dir(), file[600], sdir[512];
	struct opened o;
	struct bc_tree *t = default_tree();
	REQUIRE(dir && t);
	two_generations(dir, t);
	/* A restart (as after kill -9): the session comes back whole... */
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK_EQ_INT(o.order, 15);
	shut(&o);
	/* ... and the generation before its snapshot is still there. */
	snprintf(sdir, sizeof(sdir), "%s/sessions/a", dir);
	CHECK_EQ_INT(count_named(sdir, "snap-0.bin"), 1);
	CHECK_EQ_INT(count_named(sdir, "journal-0.bin"), 1);
	/* The newest snapshot emptied, another restart: the previous
	 * snapshot and the journals give back every edit. */
	snprintf(file, sizeof(file), "%s/snap-10.bin", sdir);
	write_file(file, "");
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK(!o.created);
	CHECK_EQ_INT(o.order, 15);
	CHECK_EQ_INT(o.r.n, 15);
	shut(&o);
	bc_tree_destroy(t);
	rm_rf(dir);
	free(dir);
}

/* Scene and camera through a snapshot and back: the same bytes. */
static void a_snapshot_gives_back_scene_and_camera(void)
{
	char *dir = make_dir();
	struct bc_store *st;
	struct bc_store_session *ss;
	struct bc_tree *t = default_tree(), *back = bc_tree_create();
	struct bc_camera cam = {{1.5f, -2.25f, 7},
	                        {0.125f, 0, -1},
	                        {0, 1, 0},
	                        33.5f},
	                 got;
	uint8_t *a = NULL, *b = NULL;
	size_t alen = 0, blen = 0;
	uint64_t order;
	bool created;
	REQUIRE(dir && t && back);
	REQUIRE(bc_store_open(&st, dir, NULL) == 0);
	REQUIRE(bc_store_session_open(st, "a", &ss, back, &got, &order,
	                              &created, collect, &(struct replayed){0},
	                              NULL) == 0);
	REQUIRE(bc_tree_set_name(t, bc_tree_lin(t)->node_id[0], "first", 5,
	                         NULL) == 0);
	REQUIRE(bc_store_snapshot(ss, t, &cam, 3, NULL) == 0);
	bc_store_session_close(ss);
	REQUIRE(bc_store_session_open(st, "a", &ss, back, &got, &order,
	                              &created, collect, &(struct replayed){0},
	                              NULL) == 0);
	CHECK(!created);
	CHECK_EQ_INT(order, 3);
	CHECK(memcmp(&got, &cam, sizeof(cam)) == 0);
	REQUIRE(bc_scene_encode(t, &cam, &a, &alen) == 0);
	REQUIRE(bc_scene_encode(back, &got, &b, &blen) == 0);
	CHECK(alen == blen && memcmp(a, b, alen) == 0);
	bc_free(a);
	bc_free(b);
	bc_store_session_close(ss);
	bc_store_close(st);
	bc_tree_destroy(t);
	bc_tree_destroy(back);
	rm_rf(dir);
	free(dir);
}

/* A data directory of an earlier version (JSON snapshots) restores; the
 * next snapshot is binary, and one of the same order replaces the JSON
 * file. */
static void a_json_snapshot_of_an_earlier_version_restores(void)
{
	char *dir = make_dir(), file[600], sdir[512];
	struct opened o;
	struct bc_tree *t = bc_tree_create();
	REQUIRE(dir && t);
	snprintf(sdir, sizeof(sdir), "%s/sessions", dir);
	REQUIRE(mkdir(sdir, 0755) == 0);
	snprintf(sdir, sizeof(sdir), "%s/sessions/a", dir);
	REQUIRE(mkdir(sdir, 0755) == 0);
	snprintf(file, sizeof(file), "%s/snap-4.json", sdir);
	write_file(file, bc_scene_default_json());
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK(!o.created);
	CHECK_EQ_INT(o.order, 4);
	CHECK(bc_tree_prim_count(t) > 1);
	REQUIRE(bc_store_snapshot(o.ss, t, NULL, 4, NULL) == 0);
	CHECK_EQ_INT(count_named(sdir, "snap-4.json"), 0);
	CHECK_EQ_INT(count_named(sdir, "snap-4.bin"), 1);
	shut(&o);
	/* A JSON file placed beside the binary one of its order is not
	 * read: the binary one is. */
	write_file(file, "not json");
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK_EQ_INT(o.order, 4);
	CHECK_EQ_INT(count_named(sdir, ".damaged-"), 0);
	shut(&o);
	bc_tree_destroy(t);
	rm_rf(dir);
	free(dir);
}

struct inject {
	const char *step;
	int calls;
};

static bool fail_step(void *ud, const char *step, const char *path)
{
	struct inject *in = ud;
	(void)path;
	in->calls++;
	return in->step && strcmp(step, in->step) == 0;
}

/* A snapshot refused at any step before its rename leaves no file behind
 * and the session restores as it was; past the rename (directory sync) it
 * is the state. The size step stands for a snapshot over the reader's
 * 384 MiB (too big to build in a unit test). */
static void a_failed_snapshot_leaves_no_trace(void)
{
	static const char *steps[] = {"snapshot-size",  "snapshot-create",
	                              "snapshot-write", "snapshot-fsync",
	                              "journal-create", "snapshot-rename",
	                              "dir-fsync"};
	for (size_t i = 0; i < sizeof(steps) / sizeof(steps[0]); i++) {
		char *dir = make_dir(), sdir[512];
		struct opened o;
		struct bc_tree *t = default_tree();
		struct inject in = {steps[i], 0};
		struct bc_errinfo ei = {0};
		bool after = strcmp(steps[i], "dir-fsync") == 0;
		int rc;
		REQUIRE(dir && t);
		make_session(dir, "a", 10, 0);
		REQUIRE(open_session(&o, dir, "a", t) == 0);
		bc_store_set_fail_hook(fail_step, &in);
		rc = bc_store_snapshot(o.ss, t, NULL, 11, &ei);
		bc_store_set_fail_hook(NULL, NULL);
		CHECK(rc < 0);
		snprintf(sdir, sizeof(sdir), "%s/sessions/a", dir);
		CHECK_EQ_INT(count_named(sdir, "snap-11"), after ? 1 : 0);
		CHECK_EQ_INT(count_named(sdir, "journal-11"), after ? 1 : 0);
		CHECK_EQ_INT(count_named(sdir, ".tmp"), 0);
		shut(&o);
		REQUIRE(open_session(&o, dir, "a", t) == 0);
		if (o.order != (after ? 11u : 10u)) {
			fprintf(stderr, "  step %s: order %llu\n", steps[i],
			        (unsigned long long)o.order);
		}
		CHECK(o.order == (after ? 11u : 10u));
		shut(&o);
		bc_tree_destroy(t);
		rm_rf(dir);
		free(dir);
	}
}

static int errors_logged;

static void count_errors(enum bc_log_level level, const char *file, int line,
                         const char *fmt, va_list args)
{
	(void)file;
	(void)line;
	(void)fmt;
	(void)args;
	errors_logged += level == BC_LOG_ERROR;
}

/* With the disk full, the periodic snapshot is not retried on every edit;
 * journal write failures are errors in the log. */
static void failures_back_off_and_are_logged_as_errors(void)
{
	char *dir = make_dir();
	struct opened o;
	struct bc_tree *t = default_tree();
	struct inject in = {"snapshot-create", 0};
	REQUIRE(dir && t);
	make_session(dir, "a", 10, 0);
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	bc_log_set_callback(count_errors);
	bc_store_set_fail_hook(fail_step, &in);
	CHECK(bc_store_snapshot_due(o.ss, 5, t, NULL, 10, NULL) < 0);
	in.calls = 0;
	for (int i = 0; i < 100; i++) {
		CHECK_EQ_INT(bc_store_snapshot_due(o.ss, 5, t, NULL, 10, NULL),
		             0);
	}
	CHECK_EQ_INT(in.calls, 0);
	CHECK(errors_logged >= 1);
	errors_logged = 0;
	in.step = "journal-write";
	CHECK(bc_store_append(o.ss, 11, (const uint8_t *)"x", 1, NULL) < 0);
	CHECK(errors_logged >= 1);
	bc_store_set_fail_hook(NULL, NULL);
	bc_log_set_callback(NULL);
	/* The failed append left no half record. */
	REQUIRE(bc_store_append(o.ss, 11, (const uint8_t *)"y", 1, NULL) == 0);
	shut(&o);
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK_EQ_INT(o.order, 11);
	shut(&o);
	bc_tree_destroy(t);
	rm_rf(dir);
	free(dir);
}

/* The last record a restore replays, whole. */
struct last_record {
	uint64_t order;
	uint8_t rec[64];
	size_t len;
};

static int keep_last(void *ud, uint64_t order, const uint8_t *rec, size_t len)
{
	struct last_record *l = ud;
	l->order = order;
	l->len = len < sizeof(l->rec) ? len : sizeof(l->rec);
	memcpy(l->rec, rec, l->len);
	return 0;
}

/* A record holding a whole scene (a SCENE_LOAD) is safe once appended:
 * its snapshot, due at once, may come later or never (kill -9), and a
 * restore gives the record back whole; the snapshot taken clears it. */
static void a_journaled_scene_is_safe_before_its_snapshot(void)
{
	static const uint8_t head[2] = {0xff, 0xff};
	static const char scene[] = "a-whole-scene";
	char *dir = make_dir();
	struct opened o;
	struct bc_tree *t = default_tree();
	struct bc_camera cam;
	struct last_record last = {0};
	REQUIRE(dir && t);
	make_session(dir, "a", 3, 0);
	REQUIRE(open_session(&o, dir, "a", t) == 0);
	CHECK(!bc_store_snapshot_is_due(o.ss, 1000));
	REQUIRE(bc_store_append_scene(o.ss, 4, head, sizeof(head),
	                              (const uint8_t *)scene, strlen(scene),
	                              NULL) == 0);
	CHECK(bc_store_snapshot_is_due(o.ss, 1000));
	/* No snapshot: as after a crash right after the load's answer. */
	shut(&o);
	REQUIRE(bc_store_open(&o.st, dir, NULL) == 0);
	REQUIRE(bc_store_session_open(o.st, "a", &o.ss, t, &cam, &o.order,
	                              &o.created, keep_last, &last, NULL) == 0);
	CHECK_EQ_INT(o.order, 4);
	CHECK_EQ_INT(last.order, 4);
	REQUIRE(last.len == sizeof(head) + strlen(scene));
	CHECK(memcmp(last.rec, head, sizeof(head)) == 0);
	CHECK(memcmp(last.rec + sizeof(head), scene, strlen(scene)) == 0);
	/* The snapshot, once taken, is no longer due. */
	REQUIRE(bc_store_append_scene(o.ss, 5, head, sizeof(head),
	                              (const uint8_t *)scene, strlen(scene),
	                              NULL) == 0);
	CHECK(bc_store_snapshot_is_due(o.ss, 1000));
	CHECK_EQ_INT(bc_store_snapshot_due(o.ss, 1000, t, NULL, 5, NULL), 0);
	CHECK(!bc_store_snapshot_is_due(o.ss, 1000));
	CHECK_EQ_INT(bc_store_journal_records(o.ss), 0);
	shut(&o);
	memset(&last, 0, sizeof(last));
	REQUIRE(bc_store_open(&o.st, dir, NULL) == 0);
	REQUIRE(bc_store_session_open(o.st, "a", &o.ss, t, &cam, &o.order,
	                              &o.created, keep_last, &last, NULL) == 0);
	CHECK_EQ_INT(o.order, 5);
	CHECK_EQ_INT(last.order, 0); /* nothing replayed after it */
	shut(&o);
	bc_tree_destroy(t);
	rm_rf(dir);
	free(dir);
}

static const struct bc_test tests[] = {
    {"a_flipped_payload_is_not_served", a_flipped_payload_is_not_served},
    {"a_flipped_length_field_is_not_served",
     a_flipped_length_field_is_not_served},
    {"a_record_that_does_not_apply_is_not_served",
     a_record_that_does_not_apply_is_not_served},
    {"a_torn_tail_is_cut", a_torn_tail_is_cut},
    {"a_damaged_last_record_is_not_a_torn_tail",
     a_damaged_last_record_is_not_a_torn_tail},
    {"a_corrupt_snapshot_spares_the_other_session",
     a_corrupt_snapshot_spares_the_other_session},
    {"a_corrupt_snapshot_falls_back_to_the_previous",
     a_corrupt_snapshot_falls_back_to_the_previous},
    {"a_failed_snapshot_leaves_no_trace", a_failed_snapshot_leaves_no_trace},
    {"a_restore_keeps_the_previous_generation",
     a_restore_keeps_the_previous_generation},
    {"a_snapshot_gives_back_scene_and_camera",
     a_snapshot_gives_back_scene_and_camera},
    {"a_json_snapshot_of_an_earlier_version_restores",
     a_json_snapshot_of_an_earlier_version_restores},
    {"failures_back_off_and_are_logged_as_errors",
     failures_back_off_and_are_logged_as_errors},
    {"a_journaled_scene_is_safe_before_its_snapshot",
     a_journaled_scene_is_safe_before_its_snapshot},
};

BC_TEST_MAIN(tests)
