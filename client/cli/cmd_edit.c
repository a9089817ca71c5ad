/*
 * `blobcast load|edit|camera|undo|redo|history`: the client commands that
 * change a session, each as an editor: a whole scene file, one node's
 * parameters, the session's saved camera, or a change taken back and
 * applied again; and the undo history they act on (as a viewer). Each waits for
 * the server's answer and prints the edit order it gave the change.
 */
#include "cmd_client.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <jansson.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/num.h"
#include "blobcast/scene.h"
#include "cli.h"
#include "cmd_inspect.h"

/* ---- load ---------------------------------------------------------------- */

static int run_load(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint64_t order;
	uint32_t nodes;
	int status = 0, rc;
	/* The file is read before connecting: a bad file is the caller's
	 * mistake (status 2) and costs the server nothing. */
	if ((rc = bc_client_read_scene_file(a->pos[0], &bytes, &len, &nodes,
	                                    &ei))) {
		bc_cli_explain(stderr, "blobcast load", ei.msg);
		status = rc == BC_ENOMEM ? BC_CLI_EXIT_FAIL : BC_CLI_EXIT_USAGE;
		goto out;
	}
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_EDITOR,
	                                  BC_CLIENT_JOIN_ANY, &c))) {
		goto out;
	}
	if (bc_client_load_scene(c, bytes, len, &order, &ei)) {
		status = bc_cli_failed(a, c, "scene not loaded", &ei);
		goto out;
	}
	printf("session %s: loaded %s (%u nodes), edit order %llu\n",
	       a->session, a->pos[0], nodes, (unsigned long long)order);
out:
	bc_free(bytes);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_load = {
    .name = "load",
    .opts = BC_CLI_O_SESSION,
    .min_pos = 1,
    .max_pos = 1,
    .synopsis = "--session NAME SCENE",
    .summary = "load a scene file into a session (created if missing)",
    .help = "Loads the scene file SCENE, with its camera, into session NAME,\n"
            "replacing its scene; every member sees it at once. Creates the\n"
            "session when it does not exist. SCENE is a JSON scene file or a\n"
            "binary one ('blobcast scene --binary'; docs/scene-format.md).",
    .run = run_load};

/* ---- edit ---------------------------------------------------------------- */

/* The shared number rules (blobcast/num.h), with the protocol's bounds. */
static bool parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
	return bc_num_u64(s, lo, hi, out) == 0;
}

static int run_edit(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	uint64_t id, order;
	uint32_t seq;
	int status;
	if (!parse_u64(a->pos[0], 1, UINT32_MAX, &id)) {
		fprintf(stderr,
		        "blobcast edit: \"%s\" is not a node id (1..%u)\n",
		        a->pos[0], UINT32_MAX);
		return BC_CLI_EXIT_USAGE;
	}
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_EDITOR,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (bc_client_edit_kv(c, (uint32_t)id, a->pos + 1,
	                      (size_t)(a->npos - 1), a->interacting, &seq,
	                      &ei)) {
		/* Bad key=value text is the user's mistake, not the server's;
		 * the connection failing is not. */
		if (bc_client_error(c, NULL)) {
			status = bc_cli_failed(a, c, NULL, &ei);
		} else {
			const char *hint =
			    bc_cli_hint(ei.code, BC_CLI_STAGE_SESSION, ei.msg);
			bc_cli_explain(stderr, "blobcast edit", ei.msg);
			if (hint) {
				fprintf(stderr, "blobcast edit: %s\n", hint);
			}
			status = BC_CLI_EXIT_USAGE;
		}
		goto out;
	}
	if (bc_client_wait_applied(c, seq, &order, &ei)) {
		status = bc_cli_failed(a, c, NULL, &ei);
		goto out;
	}
	printf("node %llu: edit applied, edit order %llu\n",
	       (unsigned long long)id, (unsigned long long)order);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_edit = {
    .name = "edit",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_INTERACTING,
    .min_pos = 2,
    .max_pos = BC_CLI_MAX_POSITIONAL,
    .synopsis = "--session NAME ID key=value...",
    .summary = "set parameters of one node",
    .help =
        "Sets fields of node ID and waits until the server has applied the\n"
        "edit. Primitives: translate=x,y,z rotate=x,y,z,w (unit quaternion)\n"
        "color=r,g,b and their kind's parameters (radius=0.4,\n"
        "half_extents=0.5,0.5,0.5, ...; see docs/primitives.md). Operators:\n"
        "blend=B range=R kind=NAME (union, smooth_union, ...).",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"interacting", NULL,
             "mark the edit as part of a drag (the "
             "server\nanswers with fast interactive "
             "frames)"},
            {NULL, NULL, NULL}},
    .run = run_edit};

/* ---- camera -------------------------------------------------------------- */

/*
 * The server keeps a camera per connection (CAMERA changes only the
 * sender's view) and one per session: the scene's, which members start
 * with and which is saved with the scene. SESSION_CAMERA sets the latter
 * alone: the scene's nodes are not sent, so edits other members make at
 * the same moment stand.
 */
static int run_camera(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	uint64_t order;
	int status;
	if (!a->has_eye || !a->has_target) {
		fprintf(stderr, "blobcast camera: --eye and --target are "
		                "required (see blobcast camera --help)\n");
		return BC_CLI_EXIT_USAGE;
	}
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_EDITOR,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if ((status = bc_cli_camera_from_opts(a, c, &cam))) {
		goto out;
	}
	if (bc_client_session_camera(c, &cam, &order, &ei)) {
		status = bc_cli_failed(a, c, "camera not set", &ei);
		goto out;
	}
	printf("session %s: camera eye %g,%g,%g target %g,%g,%g up %g,%g,%g "
	       "fov %g, edit order %llu\n",
	       a->session, (double)cam.eye[0], (double)cam.eye[1],
	       (double)cam.eye[2], (double)cam.target[0], (double)cam.target[1],
	       (double)cam.target[2], (double)cam.up[0], (double)cam.up[1],
	       (double)cam.up[2], (double)cam.fov_y_deg,
	       (unsigned long long)order);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_camera = {
    .name = "camera",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_CAMERA,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis =
        "--session NAME --eye x,y,z --target x,y,z [--up x,y,z] [--fov DEG]",
    .summary = "set the session's camera",
    .help =
        "Sets the session's saved camera: the view members who join from\n"
        "now on start with, saved with the scene (and given back by\n"
        "'blobcast scene'). Members already in the session keep their own\n"
        "cameras (to take viewers along, use 'present'). Only the camera is\n"
        "sent, so edits other members make meanwhile stand. Needs the\n"
        "editor role. --up and --fov default to the session's current\n"
        "values.",
    .run = run_camera};

/* ---- undo, redo, history ----------------------------------------------- */

static int run_undo(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_undone u;
	bool redo = strcmp(a->cmd, "redo") == 0;
	int status, rc;
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_EDITOR,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	/* Without --any: this name's own change (or, from a server without
	 * per-person undo, the session's, as such a server does). */
	rc = a->any ? bc_client_undo_session(c, redo, &u, &ei)
	            : bc_client_undo(c, redo, &u, &ei);
	if (rc == BC_EPERM && a->any) {
		/* Not a token's role: the server named who may (the owner
		 * or the presenter). */
		fprintf(stderr, "blobcast %s: %s (EPERM)\n", a->cmd, ei.msg);
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (rc) {
		status = bc_cli_failed(a, c, NULL, &ei);
		goto out;
	}
	printf("%s edit %llu by \"%s\": edit order %llu\n",
	       redo ? "redid" : "undid", (unsigned long long)u.target_order,
	       u.target_author, (unsigned long long)u.order);
out:
	bc_client_destroy(c);
	return status;
}

#define UNDO_WHO                                                               \
	"Whose change: the connection's client name (--name, default\n"        \
	"\"blobcast-cli\") is the person, since every run joins anew: runs\n"  \
	"with the same --name share one history with a page or viewer of\n"    \
	"that name. A change another member has since built on (changed the\n" \
	"same node, or the subtree around it) is skipped and stays; when\n"    \
	"only such changes are left the server refuses (exit status 1, "       \
	"ESTATE)"                                                              \
	"\nnaming the change built on it. --any takes the session's newest\n"  \
	"change whoever made it; only the session's owner (the name that\n"    \
	"created it) or its presenter may (EPERM otherwise). The history\n"    \
	"survives restarts and keeps 100 steps ('blobcast history')."

const struct bc_cli_cmd bc_cli_cmd_undo = {
    .name = "undo",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_ANY,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--name WHO] [--any]",
    .summary = "take back your newest change (--any: anyone's)",
    .help = "Undoes the newest change of yours in session NAME that is not\n"
            "undone yet: a parameter edit, a structural edit, or a whole\n"
            "drag. It is applied as an edit of its own, seen by every\n"
            "member, and prints\n"
            "  undid edit ORDER by \"AUTHOR\": edit order NEW\n" UNDO_WHO
            "\nExample: blobcast undo --session review --name alice",
    .run = run_undo};

const struct bc_cli_cmd bc_cli_cmd_redo = {
    .name = "redo",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_ANY,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--name WHO] [--any]",
    .summary = "apply again your change undone last (--any: anyone's)",
    .help = "Redoes your change undone last in session NAME, as 'undo' takes\n"
            "it back; a new edit of yours in between leaves nothing to\n"
            "redo.\n" UNDO_WHO,
    .run = run_undo};

/* "2026-12-03 16:20:05" (UTC) of Unix ms, or "-" when unknown. */
static void when(char *out, size_t n, uint64_t ms)
{
	time_t s = (time_t)(ms / 1000u);
	struct tm tm;
	if (!ms || !gmtime_r(&s, &tm) ||
	    !strftime(out, n, "%Y-%m-%d %H:%M:%S", &tm)) {
		snprintf(out, n, "-");
	}
}

static int print_history_json(const struct bc_client_change *h, size_t n,
                              uint64_t order)
{
	json_t *arr = json_array(), *doc;
	char *text;
	for (size_t i = 0; arr && i < n; i++) {
		json_array_append_new(
		    arr, json_pack("{s:I,s:I,s:I,s:s,s:s,s:s,s:b,s:b}", "order",
		                   (json_int_t)h[i].order, "time_ms",
		                   (json_int_t)h[i].time_ms, "built_on",
		                   (json_int_t)h[i].built_on, "state",
		                   h[i].undone ? "undone" : "applied", "author",
		                   h[i].author, "what", h[i].what, "yours",
		                   h[i].yours, "next", h[i].next));
	}
	doc =
	    json_pack("{s:I,s:o}", "order", (json_int_t)order, "changes", arr);
	if (!doc || !(text = json_dumps(doc, JSON_INDENT(2)))) {
		json_decref(doc);
		fprintf(stderr, "blobcast history: out of memory\n");
		return BC_CLI_EXIT_FAIL;
	}
	printf("%s\n", text);
	free(text);
	json_decref(doc);
	return 0;
}

static int run_history(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_change *h = NULL;
	size_t n = 0;
	uint64_t order = 0;
	int status;
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_VIEWER,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (bc_client_history(c, &h, &n, &order, &ei)) {
		status = bc_cli_failed(a, c, NULL, &ei);
		goto out;
	}
	if (a->json) {
		status = print_history_json(h, n, order);
		goto out;
	}
	printf("session %s: edit order %llu, %zu change%s kept, newest first\n",
	       a->session, (unsigned long long)order, n, n == 1 ? "" : "s");
	for (size_t i = 0; i < n; i++) {
		/* Names reach what and author as their members typed them. */
		char t[32], on[48] = "", what[4 * sizeof(h[i].what)],
		            who[4 * sizeof(h[i].author)];
		when(t, sizeof(t), h[i].time_ms);
		if (h[i].built_on) {
			snprintf(on, sizeof(on), " built on by %llu",
			         (unsigned long long)h[i].built_on);
		}
		printf("%6llu  %s  %-7s  %-16s  %s%s%s\n",
		       (unsigned long long)h[i].order, t,
		       h[i].undone ? "undone" : "applied",
		       h[i].author[0]
		           ? bc_cli_printable(h[i].author, who, sizeof(who))
		           : "(anonymous)",
		       bc_cli_printable(h[i].what, what, sizeof(what)), on,
		       h[i].next
		           ? (h[i].undone ? "  <- your redo" : "  <- your undo")
		           : "");
	}
out:
	bc_free(h);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_history = {
    .name = "history",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--name WHO] [--json]",
    .summary = "list the recent changes: who, what, when, undoable by whom",
    .help =
        "Lists the changes of session NAME that undo and redo can still\n"
        "take, newest first (at most 200: 100 applied, 100 undone):\n"
        "  ORDER  DATE TIME (UTC)  applied|undone  AUTHOR  WHAT\n"
        "followed by \"built on by N\" when a later change N was made on top\n"
        "of it (its author's undo skips it) and \"<- your undo\" (redo) on\n"
        "the change 'blobcast undo' ('redo') with this --name would take.\n"
        "Joins as a viewer. --json prints {\"order\", \"changes\": "
        "[{\"order\",\n"
        "\"time_ms\", \"built_on\", \"state\", \"author\", \"what\", "
        "\"yours\",\n"
        "\"next\"}]}.\n"
        "Example: blobcast history --session review --name alice",
    .run = run_history};
