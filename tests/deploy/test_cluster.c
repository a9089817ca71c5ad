/*
 * deploy/cluster-demo.sh for real: three blobcastd daemons, a websockify
 * each and nginx terminating TLS on one port, all on loopback. Through
 * that one port (libblobcast over wss://, the path the page takes too):
 * 30 sessions or more are created and spread over all three daemons
 * (more until each daemon holds one: the names' hashes decide), each stored
 * on the daemon that WELCOMEd its client; every session reaches the same
 * daemon again, and the page's WebSocket and codec (browser_route.mjs, in
 * node) reach the same daemon as libblobcast; after kill -9 of one daemon
 * only its sessions fail and the
 * others keep serving; restarted on its data directory, its sessions come
 * back with every acknowledged edit. Skipped (77) without nginx,
 * websockify or openssl.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/client.h"
#include "blobcast/log.h"
#include "test.h"

/* Sessions made: at least NSESS, then more until every daemon holds one.
 * The front door routes by a consistent hash of the name, and the 30
 * names "review-00".."review-29" miss one daemon's arcs altogether for
 * one of the 375 front ports pick_front_port may take (24448: 17, 13
 * and 0 sessions; crc32 of names that differ in two characters is far
 * from random). Computed from nginx's ketama points for every one of
 * those ports, 34 names always reach all three daemons. */
#define NSESS 30
#define NSESS_MAX 64
#define NODES 3

static char dir[96], ca[160];
static int front_port;
static pid_t demo_pid;

static void sleep_ms(long ms)
{
	struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
	nanosleep(&ts, NULL);
}

/* Whether port on 127.0.0.1 can be bound now. */
static bool port_free(int port)
{
	struct sockaddr_in sa = {.sin_family = AF_INET};
	int fd = socket(AF_INET, SOCK_STREAM, 0), one = 1;
	bool ok;
	sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	sa.sin_port = htons((uint16_t)port);
	if (fd < 0) {
		return false;
	}
	setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
	ok = bind(fd, (struct sockaddr *)&sa, sizeof(sa)) == 0;
	close(fd);
	return ok;
}

/* A front port P for cluster-demo.sh such that P, P+10+i and P+20+i are
 * all free. Below 32768, the start of Linux's ephemeral range, so that no
 * outgoing connection of another test can hold one meanwhile; starting
 * from the pid so that parallel runs try different ones first. */
static int pick_front_port(void)
{
	int start = (int)(getpid() % 375);
	for (int k = 0; k < 375; k++) {
		int p = 20000 + ((start + k) % 375) * 32;
		bool ok = port_free(p);
		for (int i = 0; i < NODES && ok; i++) {
			ok = port_free(p + 10 + i) && port_free(p + 20 + i);
		}
		if (ok) {
			return p;
		}
	}
	return 0;
}

static bool have(const char *tool)
{
	char cmd[256];
	snprintf(cmd, sizeof(cmd),
	         "command -v %s >/dev/null 2>&1 || "
	         "test -x /usr/sbin/%s",
	         tool, tool);
	return system(cmd) == 0;
}

struct sess {
	char name[24];
	int node;       /* the daemon that holds it */
	uint64_t order; /* the last acknowledged edit */
	float radius;   /* what that edit set */
};
static struct sess sessions[NSESS_MAX];
static int nsess;

/* Connects through the front door to session s (joining it, creating it
 * when create). Returns 0 or the error, with the daemon's index. */
static int open_session(struct bc_client **c, const struct sess *s, bool create,
                        int *node, struct bc_errinfo *ei)
{
	char addr[128];
	int rc;
	*c = NULL;
	snprintf(addr, sizeof(addr),
	         "wss://127.0.0.1:%d/blobcast?session=%.15s", front_port,
	         s->name);
	rc = bc_client_connect(c,
	                       &(struct bc_client_opts){
	                           .addr = addr,
	                           .name = "test-cluster",
	                           .timeout_ms = 10000,
	                           .ca_file = ca,
	                       },
	                       ei);
	if (rc) {
		return rc;
	}
	*node = -1;
	sscanf(bc_client_info(*c)->server_id, "node-%d", node);
	return bc_client_join(
	    *c, s->name, BC_PROTO_ROLE_EDITOR,
	    create ? BC_CLIENT_JOIN_ANY : BC_CLIENT_JOIN_EXISTING, ei);
}

/* Sets the sphere's radius (node 2) and waits for the acknowledgement. */
static int edit_radius(struct bc_client *c, struct sess *s, float r,
                       struct bc_errinfo *ei)
{
	char kv[64];
	const char *args[1] = {kv};
	uint32_t seq = 0;
	uint64_t order = 0;
	int rc;
	snprintf(kv, sizeof(kv), "radius=%.4f", (double)r);
	if ((rc = bc_client_edit_kv(c, 2, args, 1, false, &seq, ei)) ||
	    (rc = bc_client_wait_applied(c, seq, &order, ei))) {
		return rc;
	}
	s->order = order;
	s->radius = r;
	return 0;
}

static float radius_of(struct bc_client *c)
{
	struct bc_prim_data p;
	const struct bc_tree *t = bc_client_scene(c, NULL);
	if (!t || !bc_tree_get(t, 2, &p, NULL)) {
		return -1.0f;
	}
	return p.params[0];
}

static bool stored_on(const struct sess *s, int node)
{
	char p[256];
	struct stat st;
	snprintf(p, sizeof(p), "%.95s/node-%d/sessions/%.15s", dir, node,
	         s->name);
	return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

static pid_t read_pid(int node)
{
	char p[160];
	long v = 0;
	FILE *f;
	snprintf(p, sizeof(p), "%s/node-%d.pid", dir, node);
	f = fopen(p, "r");
	if (f) {
		if (fscanf(f, "%ld", &v) != 1) {
			v = 0;
		}
		fclose(f);
	}
	return (pid_t)v;
}

/* Starts daemon node again on its data directory, as systemd would. */
static void restart_node(int node)
{
	char listen[32], data[160], id[16], log[160], pidf[160];
	pid_t pid;
	FILE *f;
	snprintf(listen, sizeof(listen), "127.0.0.1:%d",
	         front_port + 10 + node);
	snprintf(data, sizeof(data), "%s/node-%d", dir, node);
	snprintf(id, sizeof(id), "node-%d", node);
	snprintf(log, sizeof(log), "%s/node-%d.restart.log", dir, node);
	pid = fork();
	if (pid == 0) {
		int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
		dup2(fd, 2);
		execl(BLOBCASTD_PATH, "blobcastd", "--listen", listen, "--data",
		      data, "--server-id", id, (char *)NULL);
		_exit(127);
	}
	snprintf(pidf, sizeof(pidf), "%s/node-%d.pid", dir, node);
	if ((f = fopen(pidf, "w"))) {
		fprintf(f, "%d\n", (int)pid);
		fclose(f);
	}
	for (int i = 0; i < 400 && !bc_test_file_has(log, "blobcastd: backend");
	     i++) {
		sleep_ms(25);
	}
}

static void cluster(void)
{
	struct bc_errinfo ei = {0};
	struct bc_client *c;
	char scene[160];
	int per_node[NODES] = {0};
	int node, victim = 1;
	FILE *f;

	snprintf(scene, sizeof(scene), "%s/scene.json", dir);
	f = fopen(scene, "w");
	REQUIRE(f != NULL);
	fputs("{\"blobcast\": 1, \"root\": {\"type\": \"smooth_union\", "
	      "\"id\": 1, \"blend\": 0.3, \"children\": ["
	      "{\"type\": \"sphere\", \"id\": 2, \"radius\": 0.8},"
	      "{\"type\": \"box\", \"id\": 3, \"half_extents\": [0.5, 0.5, "
	      "0.5], \"translate\": [1, 0, 0]}]}}\n",
	      f);
	fclose(f);

	/* 1. 30 sessions or more through the front door: each lands on one
	 *    daemon, stored there, and all three get some. */
	for (int i = 0; i < NSESS_MAX && (i < NSESS || per_node[0] == 0 ||
	                                  per_node[1] == 0 || per_node[2] == 0);
	     i++) {
		struct sess *s = &sessions[i];
		nsess = i + 1;
		snprintf(s->name, sizeof(s->name), "review-%02d", i);
		if (open_session(&c, s, true, &node, &ei) ||
		    bc_client_load_scene_file(c, scene, NULL, NULL, &ei) ||
		    edit_radius(c, s, 0.5f + 0.01f * (float)i, &ei)) {
			fprintf(stderr, "  %s: %s\n", s->name, ei.msg);
			CHECK(false);
			bc_client_destroy(c);
			/* When the first fails, the front door is down and
			 * nothing further can pass: stop here, not at the
			 * timeout. */
			REQUIRE(i > 0);
			continue;
		}
		bc_client_destroy(c);
		CHECK(node >= 0 && node < NODES);
		s->node = node;
		fprintf(stderr, "  %s on node-%d (edit order %llu)\n", s->name,
		        node, (unsigned long long)s->order);
		if (node >= 0 && node < NODES) {
			per_node[node]++;
		}
		for (int k = 0; k < NODES; k++) {
			CHECK(stored_on(s, k) == (k == node));
		}
	}
	fprintf(stderr, "  sessions per daemon: %d %d %d (%d sessions)\n",
	        per_node[0], per_node[1], per_node[2], nsess);
	for (int k = 0; k < NODES; k++) {
		CHECK(per_node[k] > 0);
	}

	/* 2. Every session reaches the same daemon again (it must: the
	 *    session exists nowhere else), and takes a second edit. */
	for (int i = 0; i < nsess; i++) {
		struct sess *s = &sessions[i];
		int rc = open_session(&c, s, false, &node, &ei);
		CHECK_EQ_INT(rc, 0);
		CHECK_EQ_INT(node, s->node);
		if (rc == 0) {
			CHECK_EQ_INT(
			    edit_radius(c, s, 0.6f + 0.01f * (float)i, &ei), 0);
		}
		bc_client_destroy(c);
	}

	/* 2b. The browser's path: the page's WebSocket and codec land on
	 *     the daemon libblobcast reached, for every session. */
	{
		char cmd[4096], line[128];
		size_t at;
		int seen = 0;
		FILE *p;
		at = (size_t)snprintf(cmd, sizeof(cmd),
		                      "NODE_EXTRA_CA_CERTS=%s node "
		                      "--experimental-websocket "
		                      "%s/tests/deploy/browser_route.mjs %d",
		                      ca, SOURCE_DIR, front_port);
		for (int i = 0; i < nsess && at < sizeof(cmd) - 32; i++) {
			at += (size_t)snprintf(cmd + at, sizeof(cmd) - at,
			                       " %s", sessions[i].name);
		}
		p = popen(cmd, "r");
		REQUIRE(p != NULL);
		while (fgets(line, sizeof(line), p)) {
			char name[32];
			int k = -1;
			if (sscanf(line, "%31s node-%d", name, &k) != 2) {
				continue;
			}
			for (int i = 0; i < nsess; i++) {
				if (strcmp(sessions[i].name, name) == 0) {
					CHECK_EQ_INT(k, sessions[i].node);
					seen++;
				}
			}
		}
		CHECK_EQ_INT(pclose(p), 0);
		CHECK_EQ_INT(seen, nsess);
	}

	/* 3. kill -9 one daemon: its sessions fail, the others serve. */
	CHECK(read_pid(victim) > 0);
	kill(read_pid(victim), SIGKILL);
	sleep_ms(200);
	for (int i = 0; i < nsess; i++) {
		struct sess *s = &sessions[i];
		int rc = open_session(&c, s, false, &node, &ei);
		if (s->node == victim) {
			CHECK(rc != 0);
		} else {
			CHECK_EQ_INT(rc, 0);
			CHECK_EQ_INT(node, s->node);
			if (rc == 0) {
				CHECK_EQ_INT(
				    edit_radius(c, s, 0.7f + 0.01f * (float)i,
				                &ei),
				    0);
			}
		}
		bc_client_destroy(c);
	}
	for (int i = 0; i < nsess; i++) {
		/* Nothing was created elsewhere meanwhile. */
		for (int k = 0; k < NODES; k++) {
			CHECK(stored_on(&sessions[i], k) ==
			      (k == sessions[i].node));
		}
	}

	/* 4. Restarted on its data directory: its sessions are back with
	 *    every acknowledged edit. */
	restart_node(victim);
	for (int i = 0; i < nsess; i++) {
		struct sess *s = &sessions[i];
		if (s->node != victim) {
			continue;
		}
		CHECK_EQ_INT(open_session(&c, s, false, &node, &ei), 0);
		CHECK_EQ_INT(node, victim);
		if (c) {
			CHECK(bc_client_info(c)->order == s->order);
			CHECK_NEAR(radius_of(c), s->radius, 1e-6);
		}
		bc_client_destroy(c);
	}
}

static const struct bc_test tests[] = {
    {"cluster", cluster},
};

int main(int argc, char **argv)
{
	char out[160], envp[192], cmd[512];
	int rc, status;
	signal(SIGPIPE, SIG_IGN);
	bc_log_init(BC_LOG_ERROR);
	if (!have("nginx") || !have("websockify") || !have("openssl") ||
	    !have("node")) {
		fprintf(stderr, "skipped: nginx, websockify, openssl or node "
		                "is missing (deploy/install-deps.sh)\n");
		return 77;
	}
	snprintf(dir, sizeof(dir), "/tmp/bc-cluster-test-%d", (int)getpid());
	mkdir(dir, 0700);
	snprintf(ca, sizeof(ca), "%s/tls/ca.pem", dir);
	snprintf(out, sizeof(out), "%s.out", dir);
	front_port = pick_front_port();
	if (front_port == 0) {
		fprintf(stderr, "no free ports for the cluster on 127.0.0.1\n");
		return 1;
	}
	demo_pid = fork();
	if (demo_pid == 0) {
		char port[16];
		int fd = open(out, O_WRONLY | O_CREAT | O_TRUNC, 0600);
		dup2(fd, 1);
		dup2(fd, 2);
		snprintf(port, sizeof(port), "%d", front_port);
		setenv("BLOBCASTD", BLOBCASTD_PATH, 1);
		/* Its own process group: killing it stops every child. */
		setpgid(0, 0);
		execl("/bin/bash", "bash", SOURCE_DIR "/deploy/cluster-demo.sh",
		      "--port", port, "--data", dir, (char *)NULL);
		_exit(127);
	}
	for (int i = 0;
	     i < 1200 && !bc_test_file_has(out, "cluster-demo: ready"); i++) {
		if (waitpid(demo_pid, &status, WNOHANG) == demo_pid) {
			demo_pid = 0;
			break;
		}
		sleep_ms(50);
	}
	if (!bc_test_file_has(out, "cluster-demo: ready")) {
		snprintf(cmd, sizeof(cmd), "cat %s", out);
		fprintf(stderr, "cluster-demo.sh did not start:\n");
		if (system(cmd) != 0) {
			fprintf(stderr, "(no output)\n");
		}
		rc = 1;
	} else {
		rc = bc_test_run(tests, sizeof(tests) / sizeof(tests[0]), argc,
		                 argv);
	}
	if (demo_pid > 0) {
		kill(demo_pid, SIGTERM);
		waitpid(demo_pid, &status, 0);
	}
	snprintf(envp, sizeof(envp), "%s/nginx/error.log", dir);
	if (rc == 0) {
		snprintf(cmd, sizeof(cmd), "rm -rf %s %s", dir, out);
		if (system(cmd) != 0) {
			fprintf(stderr, "could not remove %s\n", dir);
		}
	} else {
		fprintf(stderr, "kept %s (nginx log %s)\n", dir, envp);
	}
	return rc;
}
