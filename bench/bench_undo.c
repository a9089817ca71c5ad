/*
 * blobcastd's undo history on a big scene, through its Unix socket with the
 * raw protocol: a session of N spheres (60 000 by default) under one union,
 * one structural edit (an INSERT of a sphere), then UNDO and REDO in turn,
 * every one a structural step, each applied, journaled and broadcast like
 * an EDIT. Prints:
 *  - the bytes each UNDO/REDO adds to the session's journal and the
 *    subtree bytes its EDIT_APPLIED carries, and its time from request to
 *    EDIT_APPLIED (median, p99);
 *  - the time a restart takes to give a joiner the scene, on the same data
 *    directory (daemon killed, so that no snapshot is written on the way
 *    out): first with the snapshot alone (right after the load), then with
 *    the snapshot and the journal of the steps -- the difference is the
 *    replay. Steps stop one record short of the periodic snapshot
 *    (BC_SRV_SNAPSHOT_EVERY, 1000 edits), so that all of them replay.
 *
 * Usage: bench_undo PATH/TO/blobcastd [spheres [steps]]
 */
#include <dirent.h>
#include <stdint.h>

#include "../tests/server/daemon.h"
#include "blobcast/alloc.h"
#include "blobcast/scene.h"

static const float T0[3] = {0, 0, 0}, R0[4] = {0, 0, 0, 1};

/* Waits for the EDIT_APPLIED answering seq; returns its subtree bytes,
 * -1 on an ERROR or a timeout. */
static long long await_applied(struct conn *c, uint32_t seq)
{
	for (;;) {
		if (conn_recv(c, 120000) != 1) {
			return -1;
		}
		if (c->m.type == BC_MSG_ERROR && c->m.seq == seq) {
			fprintf(stderr, "refused: %.*s\n",
			        (int)c->m.error.text.len, c->m.error.text.ptr);
			return -1;
		}
		if (c->m.type == BC_MSG_EDIT_APPLIED &&
		    c->m.edit_applied.author_seq == seq) {
			long long n = 0;
			for (uint32_t i = 0; i < c->m.edit_applied.nops; i++) {
				n += c->m.edit_applied.ops[i].subtree.len;
			}
			return n;
		}
	}
}

/* Loads n spheres under union 1 (ids 100..) into c's session. */
static int load(struct conn *c, uint32_t n)
{
	struct bc_proto_buf b;
	struct bc_msg m = {.type = BC_MSG_SCENE_LOAD};
	float r = 0.004f;
	uint32_t seq;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, n + 1);
	bc_proto_scene_op(&b, BC_OP_UNION, 1, 0, 0, n);
	for (uint32_t i = 0; i < n; i++) {
		float at[3] = {(float)(i % 250) * 0.008f - 1.0f,
		               (float)(i / 250) * 0.008f - 1.0f, 0.0f};
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 100 + i, at, R0, NULL,
		                    1, &r);
	}
	m.scene_load.scene.ptr = b.data;
	m.scene_load.scene.len = (uint32_t)b.len;
	seq = conn_send(c, &m);
	bc_proto_buf_finish(&b);
	do {
		if (conn_expect(c, BC_MSG_SCENE_STATE, 120000) != 1) {
			return -1;
		}
	} while (c->m.scene_state.author_seq != seq);
	return 0;
}

/* Starts the daemon on dir and times a joiner's wait for the scene. */
static double restart_ms(struct daemon *d, const char *dir)
{
	struct conn c;
	int64_t t0 = t_now_ms();
	double ms = -1;
	/* The daemon restores its sessions before it listens: past
	 * daemon_start's 10 s, wait on. */
	if (daemon_start(d, dir) != 0 && d->pid <= 0) {
		return -1;
	}
	while (conn_open(&c, d) != 0) {
		if (t_now_ms() - t0 > 600000) {
			return -1;
		}
		t_sleep_ms(25);
	}
	if (conn_hello(&c, "joiner") == 0 &&
	    conn_join(&c, "bench", BC_PROTO_ROLE_VIEWER, false) == 0 &&
	    conn_expect(&c, BC_MSG_SCENE_STATE, 600000) == 1) {
		ms = (double)(t_now_ms() - t0);
	}
	conn_close(&c);
	return ms;
}

static int cmp_ll(const void *a, const void *b)
{
	long long x = *(const long long *)a, y = *(const long long *)b;
	return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
	uint32_t n = argc > 2 ? (uint32_t)atoi(argv[2]) : 60000u;
	int steps = argc > 3 ? atoi(argv[3]) : 998;
	struct daemon d;
	struct conn c;
	struct bc_proto_buf sub;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT, .node = 1};
	struct bc_msg m = {.type = BC_MSG_EDIT};
	long long *ms, j0, j1, carried = 0;
	double base_ms, replay_ms;
	char dir[64];
	float r = 0.01f;
	if (argc < 2) {
		fprintf(stderr,
		        "usage: bench_undo blobcastd [spheres [steps]]\n");
		return 2;
	}
	daemon_path = argv[1];
	signal(SIGPIPE, SIG_IGN);
	snprintf(dir, sizeof(dir), "/tmp/bc-bench-undo-%d", (int)getpid());
	mkdir(dir, 0700);
	if (!(ms = bc_calloc((size_t)steps + 1, sizeof(*ms))) ||
	    daemon_start(&d, dir) != 0 || conn_open(&c, &d) != 0 ||
	    conn_hello(&c, "bench") != 0 ||
	    conn_join(&c, "bench", BC_PROTO_ROLE_EDITOR, true) != 0 ||
	    load(&c, n) != 0) {
		fprintf(stderr, "setup failed\n");
		return 1;
	}
	/* The snapshot alone. */
	conn_close(&c);
	daemon_stop(&d, SIGKILL);
	base_ms = restart_ms(&d, dir);
	if (conn_open(&c, &d) != 0 || conn_hello(&c, "bench") != 0 ||
	    conn_join(&c, "bench", BC_PROTO_ROLE_EDITOR, false) != 0 ||
	    conn_expect(&c, BC_MSG_SCENE_STATE, 120000) != 1) {
		fprintf(stderr, "rejoin failed\n");
		return 1;
	}
	bc_proto_buf_init(&sub, 0);
	bc_proto_scene_begin(&sub, NULL, 1);
	bc_proto_scene_prim(&sub, BC_PRIM_SPHERE, 3, T0, R0, NULL, 1, &r);
	op.position = n / 2;
	op.subtree.ptr = sub.data;
	op.subtree.len = (uint32_t)sub.len;
	m.edit.nops = 1;
	m.edit.ops = &op;
	if (await_applied(&c, conn_send(&c, &m)) < 0) {
		return 1;
	}
	j0 = session_journal_bytes(dir, "bench");
	for (int i = 0; i < steps; i++) {
		struct bc_msg u = {.type = i % 2 ? BC_MSG_REDO : BC_MSG_UNDO};
		int64_t t0 = t_now_ms();
		long long k = await_applied(&c, conn_send(&c, &u));
		if (k < 0) {
			return 1;
		}
		ms[i] = t_now_ms() - t0;
		carried += k;
	}
	j1 = session_journal_bytes(dir, "bench");
	conn_close(&c);
	daemon_stop(&d, SIGKILL);
	replay_ms = restart_ms(&d, dir);
	daemon_stop(&d, SIGTERM);
	qsort(ms, (size_t)steps, sizeof(*ms), cmp_ll);
	printf("spheres=%u steps=%d journal_bytes_per_step=%.0f "
	       "edit_applied_subtree_bytes_per_step=%.0f step_ms_p50=%lld "
	       "step_ms_p99=%lld\n",
	       n, steps, (double)(j1 - j0) / steps, (double)carried / steps,
	       ms[steps / 2], ms[(steps * 99) / 100]);
	printf("restart_ms snapshot_only=%.0f with_%d_records=%.0f "
	       "replay_ms=%.0f\n",
	       base_ms, steps + 1, replay_ms, replay_ms - base_ms);
	bc_proto_buf_finish(&sub);
	bc_free(ms);
	{
		char cmd[192];
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s.sock", dir, dir);
		if (system(cmd) != 0) {
			fprintf(stderr, "could not remove %s\n", dir);
		}
	}
	return 0;
}
