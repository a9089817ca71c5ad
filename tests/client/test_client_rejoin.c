/*
 * libblobcast's reconnect (rejoin.c): the back-off's delays, which errors
 * make another attempt pointless, and bc_client_rejoin() against a real
 * blobcastd that is stopped and started again on the same data directory,
 * into a session that persisted, one that was deleted, and none; and
 * bc_client_disconnect(), which lets the daemon drop the member at once.
 */
#include <limits.h>

#include "blobcast/client.h"
#include "test.h" /* before daemon.h: its test runner needs it */
/* Not every helper of daemon.h is used here. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include "daemon.h"
#pragma GCC diagnostic pop

static char base_dir[96];

#define SCENE                                                                  \
	"{\"blobcast\": 1, \"root\": {\"type\": \"union\", \"id\": 1, "        \
	"\"children\": [{\"type\": \"sphere\", \"id\": 2, \"radius\": 0.5}, "  \
	"{\"type\": \"sphere\", \"id\": 3, \"radius\": 0.4, \"translate\": "   \
	"[0.6, 0, 0]}]}}"

static void backoff_doubles_from_first_to_longest(void)
{
	static const int want[] = {500, 1000, 2000, 4000, 4000};
	struct bc_client_backoff b;
	double now = 1000.0;
	bc_client_backoff_init(&b, 0, 0);
	CHECK_EQ_INT(b.first_ms, BC_CLIENT_BACKOFF_FIRST_MS);
	CHECK_EQ_INT(b.longest_ms, BC_CLIENT_BACKOFF_LONGEST_MS);
	CHECK_EQ_INT(b.attempts, 0);
	/* Nothing lost yet: an attempt would be due at once. */
	CHECK(bc_client_backoff_due(&b, 0.0));
	bc_client_backoff_reset(&b, now);
	CHECK_EQ_INT(b.delay_ms, 250);
	CHECK(!bc_client_backoff_due(&b, now + 249.0));
	CHECK(bc_client_backoff_due(&b, now + 250.0));
	for (size_t i = 0; i < sizeof(want) / sizeof(want[0]); i++) {
		now += 1.0;
		CHECK_EQ_INT(bc_client_backoff_next(&b, now), want[i]);
		CHECK_EQ_INT(b.attempts, i + 1);
		CHECK(!bc_client_backoff_due(&b, now + want[i] - 1.0));
		CHECK(bc_client_backoff_due(&b, now + want[i]));
	}
	/* A loss after a reconnect starts from the first delay again. */
	bc_client_backoff_reset(&b, now);
	CHECK_EQ_INT(b.attempts, 0);
	CHECK_EQ_INT(b.delay_ms, 250);
	CHECK_EQ_INT(bc_client_backoff_next(&b, now), 500);
}

static void backoff_takes_other_delays(void)
{
	struct bc_client_backoff b;
	bc_client_backoff_init(&b, 100, 350);
	bc_client_backoff_reset(&b, 0.0);
	CHECK_EQ_INT(b.delay_ms, 100);
	CHECK_EQ_INT(bc_client_backoff_next(&b, 0.0), 200);
	CHECK_EQ_INT(bc_client_backoff_next(&b, 0.0), 350);
	CHECK_EQ_INT(bc_client_backoff_next(&b, 0.0), 350);
	/* A longest below the first is raised to it. */
	bc_client_backoff_init(&b, 500, 100);
	CHECK_EQ_INT(b.longest_ms, 500);
	bc_client_backoff_reset(&b, 0.0);
	CHECK_EQ_INT(bc_client_backoff_next(&b, 0.0), 500);
	/* Doubling near INT_MAX stops at the ceiling, not past it. */
	bc_client_backoff_init(&b, 1 << 30, INT_MAX);
	bc_client_backoff_reset(&b, 0.0);
	CHECK_EQ_INT(bc_client_backoff_next(&b, 0.0), INT_MAX);
	CHECK_EQ_INT(bc_client_backoff_next(&b, 0.0), INT_MAX);
}

static void retry_useless_only_for_errors_that_repeat(void)
{
	static const int useless[] = {BC_EAUTH, BC_EPERM, BC_EPROTO_VERSION,
	                              BC_ENOSESSION, BC_EINVAL};
	static const int worth[] = {
	    0,        BC_EIO,    BC_ECLOSED, BC_ETIMEOUT,        BC_ELIMIT,
	    BC_EBUSY, BC_ENOMEM, BC_EEXIST,  BC_EPROTO_TRUNCATED};
	for (size_t i = 0; i < sizeof(useless) / sizeof(useless[0]); i++) {
		CHECK(bc_client_retry_useless(useless[i]));
	}
	for (size_t i = 0; i < sizeof(worth) / sizeof(worth[0]); i++) {
		CHECK(!bc_client_retry_useless(worth[i]));
	}
}

/* A connection to daemon d's socket. */
static int connect_to(const struct daemon *d, const char *name,
                      struct bc_client **c, struct bc_errinfo *ei)
{
	char addr[128];
	snprintf(addr, sizeof(addr), "unix:%s", d->sock);
	return bc_client_connect(
	    c, &(struct bc_client_opts){.addr = addr, .name = name}, ei);
}

/* Waits until c sees its connection fail; returns that error. */
static int wait_lost(struct bc_client *c)
{
	struct bc_msg m;
	for (int i = 0; i < 100; i++) {
		int rc = bc_client_recv(c, &m, 100);
		if (rc < 0) {
			return rc;
		}
	}
	return 0;
}

static void rejoin_after_restart_on_same_data(void)
{
	struct daemon d = {0};
	struct bc_client *c = NULL, *again = NULL;
	struct bc_errinfo ei = {0};
	const struct bc_client_member *list;
	const struct bc_client_info *info;
	char dir[160], scene[200];
	uint64_t order = 0;
	uint32_t nodes = 0;
	size_t n;
	FILE *f;
	int rc;
	snprintf(dir, sizeof(dir), "%s/restart", base_dir);
	snprintf(scene, sizeof(scene), "%s/scene.json", base_dir);
	REQUIRE((f = fopen(scene, "w")) != NULL);
	fputs(SCENE, f);
	fclose(f);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "rejoiner", &c, &ei) == 0);
	/* Created here: the rejoin must not create it a second time. */
	REQUIRE(bc_client_join(c, "kept", BC_PROTO_ROLE_EDITOR,
	                       BC_CLIENT_JOIN_CREATE, &ei) == 0);
	REQUIRE(bc_client_load_scene_file(c, scene, &order, &nodes, &ei) == 0);
	CHECK_EQ_INT(nodes, 3);

	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	rc = wait_lost(c);
	CHECK(rc < 0 && !bc_client_retry_useless(rc));
	/* The daemon is down: an error worth retrying, and no client. */
	rc = bc_client_rejoin(c, 0, &again, &ei);
	CHECK(rc < 0 && !bc_client_retry_useless(rc));
	CHECK(again == NULL);

	REQUIRE(daemon_start(&d, dir) == 0);
	memset(&ei, 0, sizeof(ei));
	rc = bc_client_rejoin(c, 2000, &again, &ei);
	if (rc) {
		fprintf(stderr, "  rejoin: %s (%s)\n", ei.msg, bc_err_name(rc));
	}
	REQUIRE(rc == 0 && again);
	info = bc_client_info(again);
	CHECK(strcmp(info->session, "kept") == 0);
	CHECK_EQ_INT(info->role, BC_PROTO_ROLE_EDITOR);
	CHECK(info->member_id != 0);
	/* The scene mirror and the order came back from the data directory. */
	CHECK_EQ_INT(info->order, order);
	CHECK(bc_client_scene(again, NULL) != NULL);
	CHECK(bc_client_scene(again, NULL) &&
	      bc_tree_node_count(bc_client_scene(again, NULL)) == 3);
	/* The roster is the new connection's: this client alone. */
	bc_client_members(again, &list, &n);
	REQUIRE(n == 1);
	CHECK_EQ_INT(list[0].id, info->member_id);
	CHECK(strcmp(list[0].name, "rejoiner") == 0);
	/* The new client remembers as the old one did. */
	bc_client_destroy(c);
	c = again;
	again = NULL;
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
	wait_lost(c);
	REQUIRE(daemon_start(&d, dir) == 0);
	CHECK(bc_client_rejoin(c, 0, &again, &ei) == 0);
	CHECK(again && strcmp(bc_client_info(again)->session, "kept") == 0);
	bc_client_destroy(again);
	bc_client_destroy(c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void rejoin_a_deleted_session_is_useless(void)
{
	struct daemon d = {0};
	struct bc_client *viewer = NULL, *editor = NULL, *again = NULL;
	struct bc_errinfo ei = {0};
	char dir[160];
	int rc;
	snprintf(dir, sizeof(dir), "%s/deleted", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "editor", &editor, &ei) == 0);
	REQUIRE(bc_client_join(editor, "gone", BC_PROTO_ROLE_EDITOR,
	                       BC_CLIENT_JOIN_ANY, &ei) == 0);
	REQUIRE(connect_to(&d, "viewer", &viewer, &ei) == 0);
	REQUIRE(bc_client_join(viewer, "gone", BC_PROTO_ROLE_VIEWER,
	                       BC_CLIENT_JOIN_EXISTING, &ei) == 0);
	REQUIRE(bc_client_delete_session(editor, "gone", &ei) == 0);
	/* A viewer cannot create the session again: connecting works, the
	 * join does not, and trying again is pointless. */
	memset(&ei, 0, sizeof(ei));
	rc = bc_client_rejoin(viewer, 0, &again, &ei);
	CHECK_EQ_INT(rc, BC_ENOSESSION);
	CHECK(bc_client_retry_useless(rc));
	CHECK(again != NULL);
	CHECK(ei.msg[0] != '\0');
	bc_client_destroy(again);
	bc_client_destroy(viewer);
	bc_client_destroy(editor);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void rejoin_without_a_session_only_connects(void)
{
	struct daemon d = {0};
	struct bc_client *c = NULL, *again = NULL;
	struct bc_errinfo ei = {0};
	char dir[160];
	snprintf(dir, sizeof(dir), "%s/nosession", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "plain", &c, &ei) == 0);
	CHECK(bc_client_rejoin(c, 0, &again, &ei) == 0);
	CHECK(again && bc_client_info(again)->session[0] == '\0');
	CHECK(again && bc_client_info(again)->connection_id !=
	                   bc_client_info(c)->connection_id);
	bc_client_destroy(again);
	bc_client_destroy(c);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Receives on c until its roster has n members (at most 5 s). */
static bool roster_reaches(struct bc_client *c, size_t n)
{
	const struct bc_client_member *list;
	size_t have = 0;
	struct bc_msg m;
	for (int i = 0; i < 50; i++) {
		bc_client_members(c, &list, &have);
		if (have == n || bc_client_recv(c, &m, 100) < 0) {
			break;
		}
	}
	bc_client_members(c, &list, &have);
	return have == n;
}

static void disconnect_lets_the_member_go_and_keeps_the_rest(void)
{
	struct daemon d = {0};
	struct bc_client *a = NULL, *b = NULL, *again = NULL;
	struct bc_errinfo ei = {0};
	uint32_t a_member;
	char dir[160];
	snprintf(dir, sizeof(dir), "%s/disconnect", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "a", &a, &ei) == 0);
	REQUIRE(bc_client_join(a, "pair", BC_PROTO_ROLE_EDITOR,
	                       BC_CLIENT_JOIN_ANY, &ei) == 0);
	REQUIRE(connect_to(&d, "b", &b, &ei) == 0);
	REQUIRE(bc_client_join(b, "pair", BC_PROTO_ROLE_VIEWER,
	                       BC_CLIENT_JOIN_EXISTING, &ei) == 0);
	CHECK(roster_reaches(b, 2));
	a_member = bc_client_info(a)->member_id;

	bc_client_disconnect(a);
	/* The daemon lets a's member go at once ... */
	CHECK(roster_reaches(b, 1));
	CHECK(bc_client_member_find(b, a_member) == NULL);
	/* ... while a keeps what it knew, refuses more work, and can be
	 * disconnected again. */
	CHECK_EQ_INT(bc_client_fd(a), -1);
	CHECK_EQ_INT(bc_client_error(a, &ei), BC_ECLOSED);
	CHECK(strcmp(bc_client_info(a)->session, "pair") == 0);
	CHECK_EQ_INT(bc_client_stats(a, &(struct bc_msg_stats){0}, NULL),
	             BC_ECLOSED);
	bc_client_disconnect(a);
	bc_client_disconnect(NULL);
	/* It still knows where to go back to. */
	memset(&ei, 0, sizeof(ei));
	REQUIRE(bc_client_rejoin(a, 0, &again, &ei) == 0);
	CHECK(strcmp(bc_client_info(again)->session, "pair") == 0);
	CHECK(roster_reaches(b, 2));
	bc_client_destroy(again);
	bc_client_destroy(a);
	bc_client_destroy(b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"backoff_doubles_from_first_to_longest",
     backoff_doubles_from_first_to_longest},
    {"backoff_takes_other_delays", backoff_takes_other_delays},
    {"retry_useless_only_for_errors_that_repeat",
     retry_useless_only_for_errors_that_repeat},
    {"rejoin_after_restart_on_same_data", rejoin_after_restart_on_same_data},
    {"rejoin_a_deleted_session_is_useless",
     rejoin_a_deleted_session_is_useless},
    {"rejoin_without_a_session_only_connects",
     rejoin_without_a_session_only_connects},
    {"disconnect_lets_the_member_go_and_keeps_the_rest",
     disconnect_lets_the_member_go_and_keeps_the_rest},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("rejoin", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
