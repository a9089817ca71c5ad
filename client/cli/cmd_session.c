/*
 * `blobcast nodes|scene|delete|sessions`: the client commands that read a
 * session's scene without changing it (its node list, its scene file) and
 * those that handle sessions as a whole (delete one, list them all).
 */
#include "cmd_client.h"

#include <errno.h>
#include <jansson.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/scene.h"
#include "cmd_inspect.h"

/* ---- nodes, scene -------------------------------------------------------- */

/* Both read the scene mirror that joining as a viewer fills from the
 * session's SCENE_STATE: nothing is changed on the server, and the other
 * members see a viewer come and go. */
static int run_nodes(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	const struct bc_tree *t;
	int status, rc;
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_VIEWER,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (!(t = bc_client_scene(c, NULL))) {
		fprintf(stderr, "blobcast nodes: the session's scene did not "
		                "decode (see the log above)\n");
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if ((rc = bc_cli_print_nodes(stdout, t, a->json))) {
		fprintf(stderr, "blobcast nodes: %s\n", bc_strerror(rc));
		status = BC_CLI_EXIT_FAIL;
	}
out:
	bc_client_destroy(c);
	return status;
}

static int run_scene(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	const struct bc_tree *t;
	struct bc_camera cam;
	char *text = NULL;
	int status;
	if (a->binary && (!a->out || strcmp(a->out, "-") == 0)) {
		fprintf(stderr, "blobcast scene: --binary writes a file: give "
		                "it with --out FILE\n");
		return BC_CLI_EXIT_USAGE;
	}
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_VIEWER,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (!(t = bc_client_scene(c, &cam))) {
		fprintf(stderr, "blobcast scene: the session's scene did not "
		                "decode (see the log above)\n");
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (a->out && strcmp(a->out, "-") != 0) {
		if (a->binary ? bc_scene_save_binary(a->out, t, &cam, &ei)
		              : bc_scene_save_json(a->out, t, &cam, &ei)) {
			fprintf(stderr, "blobcast scene: %s\n", ei.msg);
			status = BC_CLI_EXIT_FAIL;
			goto out;
		}
		printf("session %s: wrote %s (%u nodes, edit order %llu)\n",
		       a->session, a->out, bc_tree_node_count(t),
		       (unsigned long long)bc_client_info(c)->order);
		goto out;
	}
	if (!(text = bc_scene_to_json(t, &cam))) {
		/* The binary form carries trees the JSON writer refuses. */
		fprintf(
		    stderr,
		    "blobcast scene: the scene (%u nodes, nesting %u) cannot "
		    "be written as JSON (nesting limit %u, or out of "
		    "memory)\n",
		    bc_tree_node_count(t), bc_tree_nesting(t),
		    BC_SCENE_JSON_MAX_DEPTH);
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (fputs(text, stdout) == EOF || fflush(stdout) != 0) {
		fprintf(stderr, "blobcast scene: writing to stdout: %s\n",
		        strerror(errno));
		status = BC_CLI_EXIT_FAIL;
	}
out:
	bc_free(text);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_nodes = {
    .name = "nodes",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--json]",
    .summary = "list a session's nodes: id, type, parent, parameters",
    .help =
        "Joins session NAME as a viewer and lists its scene's nodes in\n"
        "pre-order, one line each: id, type, parent id ('-' for the root),\n"
        "its name in double quotes when it has one ('blobcast rename'),\n"
        "then the parameters with the keys 'blobcast edit' takes (operators:\n"
        "children=N and, when smooth, blend and range; primitives: their\n"
        "kind's parameters, translate and rotate unless at rest, color when\n"
        "set). Floats are printed so that they read back exactly.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"json", NULL,
             "one JSON array instead: objects with id, "
             "type,\nparent (0 for the root), children "
             "(operators) and\nevery parameter, "
             "translate and rotate included;\nname on "
             "named nodes only"},
            {NULL, NULL, NULL}},
    .run = run_nodes};

const struct bc_cli_cmd bc_cli_cmd_scene = {
    .name = "scene",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_OUT | BC_CLI_O_BINARY,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--out FILE [--binary]]",
    .summary = "write a session's scene as a JSON scene file",
    .help =
        "Joins session NAME as a viewer and writes its scene, with the\n"
        "session's camera, as a JSON scene file (docs/scene-format.md) that\n"
        "'blobcast load' takes back unchanged: every id and float is kept.\n"
        "With --binary, a binary scene file instead: a third of the size\n"
        "or less, read back 14 to 21 times faster (a million spheres:\n"
        "51 MB against 167 MB); 'blobcast load', 'render' and 'mesh' take\n"
        "either.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"out", "FILE",
             "write to FILE (atomically) instead of "
             "stdout\n(\"-\": stdout)"},
            {"binary", NULL,
             "write FILE as a binary scene file (the\n"
             "protocol's scene encoding with a checksum)"},
            {NULL, NULL, NULL}},
    .run = run_scene};

/* ---- delete, sessions ---------------------------------------------------- */

static int run_delete(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	char what[128];
	int status = bc_cli_connect(a, &c);
	if (status == 0 && bc_client_delete_session(c, a->session, &ei)) {
		snprintf(what, sizeof(what), "session %s", a->session);
		status = bc_cli_failed(a, c, what, &ei);
	}
	if (status == 0) {
		printf("deleted session %s\n", a->session);
	}
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_delete = {
    .name = "delete",
    .opts = BC_CLI_O_SESSION,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME",
    .summary = "delete a session and its saved scene",
    .help =
        "Deletes session NAME on the server: its members are sent back out\n"
        "of it (they stay connected), its scene and edits are no longer\n"
        "served, and a later 'load' or join of that name starts anew. The\n"
        "server keeps the files aside (docs/operations.md). Needs a token\n"
        "granting the editor role when the server has tokens.",
    .run = run_delete};

/* Unix milliseconds as UTC "YYYY-MM-DDTHH:MM:SSZ", or "-" for 0. */
static void put_time(char *buf, size_t n, uint64_t ms)
{
	time_t t = (time_t)(ms / 1000u);
	struct tm tm;
	if (ms == 0 || !gmtime_r(&t, &tm) ||
	    strftime(buf, n, "%Y-%m-%dT%H:%M:%SZ", &tm) == 0) {
		snprintf(buf, n, "-");
	}
}

/* The line under the table: the nodes the loaded sessions' scenes hold
 * against the server's cap, from STATS's memory section, where the
 * server grants it (PROTOCOL.md 7.18; an earlier server does not). */
static int print_scene_memory(struct bc_cli_call *a, struct bc_client *c)
{
	struct bc_errinfo ei = {0};
	struct bc_msg_stats st;
	if (!(bc_client_info(c)->features & BC_PROTO_FEATURE_MEMORY)) {
		return 0;
	}
	if (bc_client_stats_parts(c, BC_PROTO_STATS_MEMORY, &st, &ei)) {
		return bc_cli_failed(a, c, "stats", &ei);
	}
	printf("scene memory: %llu of %llu nodes held by the %u loaded "
	       "session%s (the server's --scene-memory)\n",
	       (unsigned long long)st.memory.scene_nodes,
	       (unsigned long long)st.memory.scene_nodes_cap,
	       st.memory.sessions_loaded,
	       st.memory.sessions_loaded == 1 ? "" : "s");
	return 0;
}

static int run_sessions(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_session *list = NULL;
	size_t n = 0;
	int status = bc_cli_connect(a, &c);
	if (status == 0 && bc_client_sessions(c, &list, &n, &ei)) {
		status = bc_cli_failed(a, c, NULL, &ei);
	}
	if (status == 0 && a->json) {
		json_t *arr = json_array();
		char *text;
		for (size_t i = 0; arr && i < n; i++) {
			const struct bc_client_session *s = &list[i];
			json_t *o = json_pack(
			    "{s:s, s:I, s:b}", "name", s->name, "members",
			    (json_int_t)s->members, "loaded", s->loaded);
			if (o && s->known) {
				json_object_set_new(
				    o, "primitives",
				    json_integer((json_int_t)s->prims));
				json_object_set_new(
				    o, "order",
				    json_integer((json_int_t)s->order));
				json_object_set_new(
				    o, "last_edit_ms",
				    json_integer((json_int_t)s->last_edit_ms));
			}
			json_array_append_new(arr, o);
		}
		if (!arr || !(text = json_dumps(arr, JSON_INDENT(2)))) {
			fprintf(stderr, "blobcast sessions: out of memory\n");
			status = BC_CLI_EXIT_FAIL;
		} else {
			printf("%s\n", text);
			free(text);
		}
		json_decref(arr);
	} else if (status == 0) {
		printf("%-24s %7s %10s %8s  %-20s %s\n", "NAME", "MEMBERS",
		       "PRIMITIVES", "ORDER", "LAST EDIT (UTC)", "STATE");
		for (size_t i = 0; i < n; i++) {
			const struct bc_client_session *s = &list[i];
			char when[32], prims[16], order[24];
			put_time(when, sizeof(when),
			         s->known ? s->last_edit_ms : 0);
			snprintf(prims, sizeof(prims), "%s", "-");
			snprintf(order, sizeof(order), "%s", "-");
			if (s->known) {
				snprintf(prims, sizeof(prims), "%u", s->prims);
				snprintf(order, sizeof(order), "%llu",
				         (unsigned long long)s->order);
			}
			printf("%-24s %7u %10s %8s  %-20s %s\n", s->name,
			       s->members, prims, order, when,
			       s->loaded ? "loaded" : "on disk");
		}
		status = print_scene_memory(a, c);
	}
	bc_free(list);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_sessions = {
    .name = "sessions",
    .opts = BC_CLI_O_JSON,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "[--json]",
    .summary = "list the server's sessions",
    .help =
        "Lists every session of the server by name: connected members,\n"
        "primitives, last edit order, when it last changed (UTC) and whether\n"
        "it is loaded or only on disk. For a session on disk that the server\n"
        "has not loaded since it started, '-' stands for what it does not\n"
        "know without loading it. At most 1024 sessions are listed. A line\n"
        "under the table says how many scene nodes the loaded sessions hold\n"
        "of the most the server lets them hold together (blobcastd\n"
        "--scene-memory; a server older than that figure leaves it out).",
    .texts =
        (const struct bc_cli_opt_text[]){{"json", NULL,
                                          "one JSON array of objects: name, "
                                          "members, loaded\nand, when known, "
                                          "primitives, order, last_edit_ms"},
                                         {NULL, NULL, NULL}},
    .run = run_sessions};
