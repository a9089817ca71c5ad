/*
 * Recovery never goes back in time (docs/operations.md, store.h), seen
 * from outside the daemon:
 *  - a SCENE_LOAD is journaled: with the snapshot it wrote emptied after
 *    kill -9, the load and the 100 acknowledged edits after it come back
 *    (they used to restart from the snapshot before the load, at order 0,
 *    and order numbers were used again);
 *  - a SCENE_LOAD is safe once answered: its snapshot is written after its
 *    SCENE_STATE, and a kill -9 right after that answer restores the
 *    loaded scene, whole, from the journal;
 *  - a session whose journal lost an acknowledged edit (a flipped record)
 *    is not served from what is left: JOIN is refused with EIO naming
 *    `blobcastd --check`, its files stay as they were, other sessions are
 *    served; `blobcastd --check DIR` says which is not whole (exit 1);
 *    `--check DIR --repair` sets its files aside and it goes on from the
 *    highest order it had acknowledged, so that no order number is given
 *    out twice.
 */
#include <dirent.h>
#include <sys/stat.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
#include "daemon.h"

static char base_dir[64];

#define SMALL_SCENE                                                            \
	"{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 5], \"target\": [0, "  \
	"0, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 40}, \"root\": {\"type\": "  \
	"\"union\", \"id\": 1, \"children\": [{\"type\": \"sphere\", \"id\": " \
	"2, \"radius\": 0.5, \"translate\": [-0.6, 0, 0]}, {\"type\": "        \
	"\"sphere\", \"id\": 3, \"radius\": 0.4, \"translate\": [0.6, 0, "     \
	"0]}]}}"

static void editor(struct conn *c, const struct daemon *d, const char *s,
                   bool create)
{
	REQUIRE(conn_open(c, d) == 0);
	REQUIRE(conn_hello(c, "editor") == 0);
	REQUIRE(conn_join(c, s, BC_PROTO_ROLE_EDITOR, create) == 0);
}

/* Moves node 2 to x = k / 100 and waits for its acknowledgement; the
 * order it got in *order. */
static void move_to(struct conn *c, int k, uint64_t *order)
{
	uint32_t seq = conn_move(c, 2, (float)k / 100.0f, 0, 0, false);
	*order = 0;
	REQUIRE(seq);
	do {
		REQUIRE(conn_expect(c, BC_MSG_EDIT_APPLIED, 30000) == 1);
	} while (c->m.edit_applied.author_seq != seq);
	*order = c->m.edit_applied.order;
}

/* A joiner's SCENE_STATE of session s: its order and node 2's x. */
static void joined_state(const struct daemon *d, const char *s, uint64_t *order,
                         float *x)
{
	struct conn j;
	struct bc_tree *t;
	struct bc_prim_data p;
	struct bc_op_data op;
	REQUIRE(conn_open(&j, d) == 0);
	REQUIRE(conn_hello(&j, "joiner") == 0);
	REQUIRE(conn_join(&j, s, BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&j, BC_MSG_SCENE_STATE, 30000) == 1);
	*order = j.m.scene_state.order;
	REQUIRE((t = scene_of(&j)));
	bc_tree_get(t, 2, &p, &op);
	*x = p.translate[0];
	bc_tree_destroy(t);
	conn_close(&j);
}

/* Empties the file at path, which must be there. */
static void empty_file(const char *path)
{
	FILE *f;
	REQUIRE(access(path, F_OK) == 0);
	f = fopen(path, "w");
	REQUIRE(f);
	fclose(f);
}

static void a_damaged_load_snapshot_loses_nothing(void)
{
	struct daemon d;
	struct conn a;
	char dir[128], snap[256];
	uint64_t load_order, last = 0, order;
	float x;
	snprintf(dir, sizeof(dir), "%s/load", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	editor(&a, &d, "ld", true);
	conn_load_json(&a, SMALL_SCENE);
	load_order = a.m.scene_state.order;
	for (int k = 1; k <= 100; k++) {
		move_to(&a, k, &last);
	}
	CHECK_EQ_INT(last, load_order + 100);
	conn_close(&a);
	daemon_stop(&d, SIGKILL);
	/* The snapshot the load wrote, emptied (a torn write, a bad disk). */
	snprintf(snap, sizeof(snap), "%s/sessions/ld/snap-%llu.bin", dir,
	         (unsigned long long)load_order);
	empty_file(snap);
	REQUIRE(daemon_start(&d, dir) == 0);
	joined_state(&d, "ld", &order, &x);
	CHECK_EQ_INT(order, last);
	CHECK(x == 1.0f);
	/* The next edit takes the next number. */
	editor(&a, &d, "ld", false);
	move_to(&a, 101, &order);
	CHECK_EQ_INT(order, last + 1);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Flips bytes in the middle of session s's newest journal. */
static void flip_newest_journal(const char *dir, const char *s)
{
	char sdir[256], file[512];
	DIR *dd;
	struct dirent *e;
	unsigned long long best = 0, n;
	struct stat sb;
	FILE *f;
	snprintf(sdir, sizeof(sdir), "%s/sessions/%s", dir, s);
	REQUIRE((dd = opendir(sdir)));
	while ((e = readdir(dd))) {
		if (sscanf(e->d_name, "journal-%llu.bin", &n) == 1 &&
		    !strstr(e->d_name, ".damaged") && n >= best) {
			best = n;
		}
	}
	closedir(dd);
	snprintf(file, sizeof(file), "%s/journal-%llu.bin", sdir, best);
	REQUIRE(stat(file, &sb) == 0 && sb.st_size > 400);
	REQUIRE((f = fopen(file, "r+b")));
	fseek(f, sb.st_size / 2, SEEK_SET);
	fputc(0x5a, f);
	fputc(0xa5, f);
	fputc(0x5a, f);
	fclose(f);
}

/* blobcastd --check dir (and --repair): exit status in *status, output
 * in out. */
static void check_cmd(const char *dir, bool repair, char *out, size_t cap,
                      int *status)
{
	char cmd[512];
	FILE *p;
	size_t n;
	snprintf(cmd, sizeof(cmd), "%s --check %s%s 2>/dev/null",
	         BLOBCASTD_PATH, dir, repair ? " --repair" : "");
	REQUIRE((p = popen(cmd, "r")));
	n = fread(out, 1, cap - 1, p);
	out[n] = '\0';
	*status = pclose(p);
	*status = WIFEXITED(*status) ? WEXITSTATUS(*status) : -1;
}

static void a_session_that_lost_an_edit_is_not_served(void)
{
	struct daemon d;
	struct conn a, b;
	char dir[128], out[4096];
	uint64_t last = 0, order;
	float x;
	int code = 0, status = -1;
	snprintf(dir, sizeof(dir), "%s/lost", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	editor(&a, &d, "dm", true);
	conn_load_json(&a, SMALL_SCENE);
	editor(&b, &d, "fine", true);
	conn_load_json(&b, SMALL_SCENE);
	for (int k = 1; k <= 40; k++) {
		move_to(&a, k, &last);
		move_to(&b, k, &order);
	}
	conn_close(&a);
	conn_close(&b);
	daemon_stop(&d, SIGKILL);
	flip_newest_journal(dir, "dm");
	REQUIRE(daemon_start(&d, dir) == 0);
	/* Refused with the reason and what to do; the other is served. */
	REQUIRE(conn_open(&a, &d) == 0);
	REQUIRE(conn_hello(&a, "editor") == 0);
	{
		struct bc_msg m = {.type = BC_MSG_SESSION_JOIN};
		uint32_t seq;
		m.session.role = BC_PROTO_ROLE_VIEWER;
		m.session.name.ptr = "dm";
		m.session.name.len = 2;
		seq = conn_send(&a, &m);
		do {
			REQUIRE(conn_expect(&a, BC_MSG_ERROR, 30000) == 1);
		} while (a.m.seq != seq);
		code = a.m.error.code;
		snprintf(out, sizeof(out), "%.*s", (int)a.m.error.text.len,
		         a.m.error.text.ptr);
		CHECK(strstr(out, "--check") != NULL);
	}
	CHECK_EQ_INT(code, -BC_EIO);
	conn_close(&a);
	joined_state(&d, "fine", &order, &x);
	CHECK(x == 0.4f);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	/* The operator's check names it; the repair goes on from the last
	 * order it acknowledged. */
	check_cmd(dir, false, out, sizeof(out), &status);
	CHECK_EQ_INT(status, 1);
	CHECK(strstr(out, "dm: NOT WHOLE") != NULL);
	CHECK(strstr(out, "fine: whole") != NULL);
	check_cmd(dir, true, out, sizeof(out), &status);
	CHECK_EQ_INT(status, 0);
	CHECK(strstr(out, "dm: repaired") != NULL);
	check_cmd(dir, false, out, sizeof(out), &status);
	CHECK_EQ_INT(status, 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	joined_state(&d, "dm", &order, &x);
	CHECK_EQ_INT(order, last);
	editor(&a, &d, "dm", false);
	move_to(&a, 99, &order);
	CHECK_EQ_INT(order, last + 1);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* The scene of session s as a joiner sees it, in the encoding without
 * camera, and its order. */
static void joined_bytes(const struct daemon *d, const char *s, uint64_t *order,
                         uint8_t **bytes, size_t *len)
{
	struct conn j;
	struct bc_tree *t;
	REQUIRE(conn_open(&j, d) == 0);
	REQUIRE(conn_hello(&j, "joiner") == 0);
	REQUIRE(conn_join(&j, s, BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_expect(&j, BC_MSG_SCENE_STATE, 60000) == 1);
	*order = j.m.scene_state.order;
	REQUIRE((t = scene_of(&j)));
	REQUIRE(bc_tree_encode(t, bytes, len) == 0);
	bc_tree_destroy(t);
	conn_close(&j);
}

static void a_load_is_safe_once_answered(void)
{
	struct bc_gen_opts o = {.count = 20000,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SMOOTH};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct daemon d;
	struct conn a;
	char dir[128];
	uint8_t *want = NULL, *got = NULL;
	size_t want_len = 0, got_len = 0;
	uint64_t load_order, order = 0;
	snprintf(dir, sizeof(dir), "%s/answered", base_dir);
	REQUIRE(t && bc_gen("fig18", &o, t, &cam, NULL) == 0);
	REQUIRE(bc_tree_encode(t, &want, &want_len) == 0);
	REQUIRE(daemon_start(&d, dir) == 0);
	editor(&a, &d, "kl", true);
	/* Big enough that its snapshot is likely still being written. */
	conn_load_tree(&a, t, &cam);
	load_order = a.m.scene_state.order;
	daemon_stop(&d, SIGKILL);
	conn_close(&a);
	REQUIRE(daemon_start(&d, dir) == 0);
	joined_bytes(&d, "kl", &order, &got, &got_len);
	CHECK_EQ_INT(order, load_order);
	CHECK(got_len == want_len && memcmp(got, want, want_len) == 0);
	/* The next edit takes the next number. */
	editor(&a, &d, "kl", false);
	move_to(&a, 5, &order);
	CHECK_EQ_INT(order, load_order + 1);
	conn_close(&a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	bc_free(want);
	bc_free(got);
}

static const struct bc_test tests[] = {
    {"a_damaged_load_snapshot_loses_nothing",
     a_damaged_load_snapshot_loses_nothing},
    {"a_session_that_lost_an_edit_is_not_served",
     a_session_that_lost_an_edit_is_not_served},
    {"a_load_is_safe_once_answered", a_load_is_safe_once_answered},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("recover", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
