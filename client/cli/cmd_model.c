/*
 * `blobcast add|remove|move|wrap|duplicate|rename`: modelling a session's tree
 * from the command line, each verb one edit through libblobcast's
 * modelling actions (blobcast/model.h), which refuse impossible changes
 * before sending anything. Each waits until the server has applied the
 * edit and prints what changed, or with --json one object a script can
 * read the new ids from.
 */
#include "cmd_client.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/model.h"
#include "blobcast/num.h"
#include "cli.h"
#include "cmd_inspect.h"

/* ---- shared ------------------------------------------------------------------ */

/* A node id argument, or BC_CLI_EXIT_USAGE after saying why. */
static int node_arg(const struct bc_cli_call *a, const char *s, uint32_t *id)
{
	if (bc_num_u32(s, 1, UINT32_MAX, id)) {
		fprintf(stderr,
		        "blobcast %s: \"%s\" is not a node id (1..%u; "
		        "'blobcast nodes' lists them)\n",
		        a->cmd, s, UINT32_MAX);
		return BC_CLI_EXIT_USAGE;
	}
	return 0;
}

/* --position N: has is false when not given. */
static int position_opt(const struct bc_cli_call *a, bool *has, uint32_t *pos)
{
	*has = a->position != NULL;
	*pos = 0;
	if (*has && bc_num_u32(a->position, 0, BC_PROTO_SCENE_MAX_NODES, pos)) {
		fprintf(stderr,
		        "blobcast %s: --position '%s' is not a child index "
		        "(0 first, up to the parent's child count)\n",
		        a->cmd, a->position);
		return BC_CLI_EXIT_USAGE;
	}
	return 0;
}

/* --at or --offset x,y,z: has is false when not given. */
static int vec_opt(const struct bc_cli_call *a, const char *name, const char *s,
                   bool *has, float v[3])
{
	*has = s != NULL;
	if (*has && bc_num_vec3(s, v)) {
		fprintf(stderr,
		        "blobcast %s: --%s '%s' is not x,y,z (three finite "
		        "numbers)\n",
		        a->cmd, name, s);
		return BC_CLI_EXIT_USAGE;
	}
	for (int i = 0; *has && i < 3; i++) {
		if (v[i] > BC_PROTO_MAX_ABS || v[i] < -BC_PROTO_MAX_ABS) {
			fprintf(stderr,
			        "blobcast %s: --%s is out of range (each |x| "
			        "<= %g)\n",
			        a->cmd, name, (double)BC_PROTO_MAX_ABS);
			return BC_CLI_EXIT_USAGE;
		}
	}
	return 0;
}

/* Takes name=TEXT out of the key=value arguments kv[0..n): the others,
 * the new node's parameters, go to rest (*nrest of them), TEXT to *name
 * (NULL when not given). A second name= is a usage error. */
static int split_name(const struct bc_cli_call *a, const char *const *kv,
                      size_t n, const char **rest, size_t *nrest,
                      const char **name)
{
	static const char key[] = "name=";
	*nrest = 0;
	*name = NULL;
	for (size_t i = 0; i < n; i++) {
		if (strncmp(kv[i], key, sizeof(key) - 1) != 0) {
			rest[(*nrest)++] = kv[i];
		} else if (*name) {
			fprintf(stderr,
			        "blobcast %s: name= is given twice: a node has "
			        "one name\n",
			        a->cmd);
			return BC_CLI_EXIT_USAGE;
		} else {
			*name = kv[i] + sizeof(key) - 1;
		}
	}
	return 0;
}

/* A kind the library will not know: said here with "did you mean", the
 * library's own sentence listing what there is. */
static void kind_hint(const struct bc_cli_call *a, const char *kind)
{
	const char *names[BC_PRIM_COUNT + BC_OP_COUNT];
	char hint[200];
	size_t n = 0;
	if (!kind || bc_prim_from_name(kind) != BC_PRIM_INVALID ||
	    bc_op_from_name(kind) != BC_OP_INVALID) {
		return;
	}
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		names[n++] = bc_prim_info((enum bc_prim)k)->name;
	}
	for (int k = 1; k < BC_OP_COUNT; k++) {
		names[n++] = bc_op_name((enum bc_op)k);
	}
	if (bc_cli_did_you_mean(kind, names, n, "", hint, sizeof(hint))) {
		fprintf(stderr, "blobcast %s: '%s'%s\n", a->cmd, kind, hint);
	}
}

/* The model action's failure: the connection's or the server's (their
 * statuses), or a refusal made before sending (usage, 2). */
static int action_failed(const struct bc_cli_call *a, struct bc_client *c,
                         const struct bc_errinfo *ei)
{
	const char *hint;
	char prog[64];
	if (bc_client_error(c, NULL)) {
		return bc_cli_failed(a, c, NULL, ei);
	}
	snprintf(prog, sizeof(prog), "blobcast %s", a->cmd);
	bc_cli_explain(stderr, prog, ei->msg);
	hint = bc_cli_hint(ei->code, BC_CLI_STAGE_SESSION, ei->msg);
	if (hint) {
		fprintf(stderr, "%s: %s\n", prog, hint);
	}
	return BC_CLI_EXIT_USAGE;
}

/* Waits for the edit and prints it: "VERB: SENTENCE, edit order N", or
 * the JSON object {"seq", "order", "node", "ids", "parent", "position"}. */
static int finish(const struct bc_cli_call *a, struct bc_client *c,
                  const struct bc_model_result *r, const char *sentence)
{
	struct bc_errinfo ei = {0};
	uint64_t order;
	if (bc_client_wait_applied(c, r->seq, &order, &ei)) {
		return bc_cli_failed(a, c, NULL, &ei);
	}
	if (!a->json) {
		printf("%s, edit order %llu\n", sentence,
		       (unsigned long long)order);
		return 0;
	}
	printf("{\"seq\": %u, \"order\": %llu, \"node\": %u, \"ids\": [",
	       r->seq, (unsigned long long)order, r->node);
	for (uint32_t i = 0; i < r->nids; i++) {
		printf("%s%u", i ? ", " : "", r->first_id + i);
	}
	printf("], \"parent\": %u, \"position\": %u}\n", r->parent,
	       r->position);
	return 0;
}

/* "ids 8..10" or "id 8" for sentences. */
static void ids_text(const struct bc_model_result *r, char *buf, size_t cap)
{
	if (r->nids == 1) {
		snprintf(buf, cap, "id %u", r->first_id);
	} else {
		snprintf(buf, cap, "ids %u..%u", r->first_id,
		         r->first_id + r->nids - 1u);
	}
}

/* One modelling call with its argument: the verbs' shared part. */
typedef int (*action_fn)(struct bc_client *c, const void *arg,
                         struct bc_model_result *r, struct bc_errinfo *ei);

/* Joins the session as an editor and runs fn; on a refusal says why (and
 * "did you mean" for kinds[0..2), which may be NULL). Returns 0 or the
 * exit status; *c is the connection either way, for the caller to
 * destroy. */
static int perform(const struct bc_cli_call *a, action_fn fn, const void *arg,
                   const char *const kinds[2], struct bc_client **c,
                   struct bc_model_result *r)
{
	struct bc_errinfo ei = {0};
	int status = bc_cli_open_session(a, BC_PROTO_ROLE_EDITOR,
	                                 BC_CLIENT_JOIN_EXISTING, c);
	if (status) {
		return status;
	}
	if (fn(*c, arg, r, &ei)) {
		status = action_failed(a, *c, &ei);
		kind_hint(a, kinds ? kinds[0] : NULL);
		kind_hint(a, kinds ? kinds[1] : NULL);
	}
	return status;
}

static int do_add(struct bc_client *c, const void *arg,
                  struct bc_model_result *r, struct bc_errinfo *ei)
{
	return bc_model_add(c, arg, r, ei);
}

static int do_remove(struct bc_client *c, const void *arg,
                     struct bc_model_result *r, struct bc_errinfo *ei)
{
	return bc_model_remove(c, *(const uint32_t *)arg, r, ei);
}

static int do_move(struct bc_client *c, const void *arg,
                   struct bc_model_result *r, struct bc_errinfo *ei)
{
	return bc_model_move(c, arg, r, ei);
}

static int do_wrap(struct bc_client *c, const void *arg,
                   struct bc_model_result *r, struct bc_errinfo *ei)
{
	return bc_model_wrap(c, arg, r, ei);
}

static int do_duplicate(struct bc_client *c, const void *arg,
                        struct bc_model_result *r, struct bc_errinfo *ei)
{
	return bc_model_duplicate(c, arg, r, ei);
}

/* ---- add --------------------------------------------------------------------- */

static int run_add(struct bc_cli_call *a)
{
	const char *kv[BC_CLI_MAX_POSITIONAL];
	struct bc_model_add add = {.kind = a->pos[0],
	                           .kv = kv,
	                           .parent = a->parent,
	                           .child_kind = a->child};
	struct bc_client *c = NULL;
	struct bc_model_result r;
	char ids[48], sentence[200];
	int status;
	if ((status = split_name(a, a->pos + 1, (size_t)(a->npos - 1), kv,
	                         &add.nkv, &add.name)) ||
	    (status = position_opt(a, &add.has_position, &add.position)) ||
	    (status = vec_opt(a, "at", a->at, &add.has_at, add.at))) {
		return status;
	}
	if ((status = perform(a, do_add, &add,
	                      (const char *const[]){add.kind, add.child_kind},
	                      &c, &r))) {
		goto out;
	}
	ids_text(&r, ids, sizeof(ids));
	snprintf(sentence, sizeof(sentence),
	         "added %s %u (%s) under node %u at position %u", add.kind,
	         r.node, ids, r.parent, r.position);
	status = finish(a, c, &r, sentence);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_add = {
    .name = "add",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON | BC_CLI_O_PARENT |
            BC_CLI_O_POSITION | BC_CLI_O_AT | BC_CLI_O_CHILD,
    .min_pos = 1,
    .max_pos = BC_CLI_MAX_POSITIONAL,
    .synopsis = "--session NAME KIND [key=value...]",
    .summary = "add a primitive, operator or unary node",
    .help =
        "Adds a node of KIND under an operator, as one edit, and waits until\n"
        "the server has applied it. KIND is a primitive (sphere, box, ...,\n"
        "docs/primitives.md), an operator (union, smooth_union, ...; it\n"
        "starts with two primitives of --child's kind, side by side) or a\n"
        "unary node (offset, twist, ...; it starts with one primitive of\n"
        "--child's kind inside). key=value sets the new node's parameters\n"
        "as 'blobcast edit' does (radius=0.4, translate=x,y,z, blend=0.2);\n"
        "name=TEXT names it (up to 64 bytes of UTF-8) in the same edit.\n"
        "Without translate= new primitives go to --at, else to the session\n"
        "camera's target: the middle of what members look at. Without\n"
        "--parent the node goes under the root operator; a scene that has\n"
        "none (one shape) gets a new union holding its root and the node.\n"
        "Refused before sending: a parent that is a primitive or a unary\n"
        "node, unknown kinds and keys, values out of range, a result over\n"
        "the depth or node limits.\n"
        "\n"
        "examples:\n"
        "  blobcast add --session demo sphere radius=0.3 translate=0,1,0\n"
        "  blobcast add --session demo torus name=wheel\n"
        "  blobcast add --session demo box --parent 5 --position 0\n"
        "  blobcast add --session demo smooth_union blend=0.2 --child "
        "torus\n"
        "  blobcast add --session demo twist rate=2 --json\n"
        "prints 'added KIND ID (ids ...) under node P at position N, edit\n"
        "order O'; with --json one object: {\"seq\", \"order\", \"node\",\n"
        "\"ids\" (every new id, the node's first), \"parent\",\n"
        "\"position\"}.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"json", NULL,
             "print one JSON object with the new ids "
             "(above)"},
            {NULL, NULL, NULL}},
    .run = run_add};

/* ---- remove ------------------------------------------------------------------ */

static int run_remove(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_model_result r;
	char sentence[160];
	uint32_t id;
	int status;
	if ((status = node_arg(a, a->pos[0], &id))) {
		return status;
	}
	if ((status = perform(a, do_remove, &id, NULL, &c, &r))) {
		goto out;
	}
	if (r.node == id) {
		snprintf(sentence, sizeof(sentence), "removed node %u", id);
	} else {
		snprintf(sentence, sizeof(sentence),
		         "removed node %u with the unary nodes above it (up "
		         "to %u)",
		         id, r.node);
	}
	status = finish(a, c, &r, sentence);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_remove = {
    .name = "remove",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON,
    .min_pos = 1,
    .max_pos = 1,
    .synopsis = "--session NAME ID",
    .summary = "remove a node and its subtree",
    .help =
        "Removes node ID and everything under it, as one edit. An operator\n"
        "left with one child is replaced by that child; a node inside unary\n"
        "nodes (twist(ID)) goes with them. The root, and a node wrapped by\n"
        "unary nodes up to the root, are refused: a scene is never empty.\n"
        "\n"
        "examples:\n"
        "  blobcast remove --session demo 7\n"
        "  blobcast remove --session demo 7 --json\n"
        "prints 'removed node ID, edit order O'; with --json\n"
        "{\"seq\", \"order\", \"node\" (the node removed: the top of its\n"
        "unary chain), \"ids\": [], \"parent\", \"position\" (where it\n"
        "was)}.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"json", NULL, "print one JSON object"}, {NULL, NULL, NULL}},
    .run = run_remove};

/* ---- move -------------------------------------------------------------------- */

static int run_move(struct bc_cli_call *a)
{
	struct bc_model_move mv = {.parent = a->parent};
	struct bc_client *c = NULL;
	struct bc_model_result r;
	char sentence[160];
	int status;
	if ((status = node_arg(a, a->pos[0], &mv.node)) ||
	    (status = position_opt(a, &mv.has_position, &mv.position))) {
		return status;
	}
	if (!mv.parent) {
		fprintf(stderr,
		        "blobcast move: --parent ID is required: the operator "
		        "to move node %u under\n",
		        mv.node);
		return BC_CLI_EXIT_USAGE;
	}
	if ((status = perform(a, do_move, &mv, NULL, &c, &r))) {
		goto out;
	}
	snprintf(sentence, sizeof(sentence),
	         "moved node %u under node %u at position %u", r.node, r.parent,
	         r.position);
	status = finish(a, c, &r, sentence);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_move = {
    .name = "move",
    .opts =
        BC_CLI_O_SESSION | BC_CLI_O_JSON | BC_CLI_O_PARENT | BC_CLI_O_POSITION,
    .min_pos = 1,
    .max_pos = 1,
    .synopsis = "--session NAME ID --parent ID",
    .summary = "move a node under another operator",
    .help =
        "Moves node ID, with its subtree and its ids, under operator\n"
        "--parent, as one edit (a removal and an insertion of the same\n"
        "nodes). --position counts the parent's children as they are now,\n"
        "the node itself included when it moves within its parent; without\n"
        "it the node goes last. A node inside unary nodes moves with them.\n"
        "Refused before sending: moving the root, moving a node under\n"
        "itself or one of its descendants, a parent that is a primitive or\n"
        "a unary node, a result over the depth limits.\n"
        "\n"
        "examples:\n"
        "  blobcast move --session demo 7 --parent 1\n"
        "  blobcast move --session demo 7 --parent 5 --position 0 --json\n"
        "prints 'moved node ID under node P at position N, edit order O';\n"
        "with --json {\"seq\", \"order\", \"node\", \"ids\": [], \"parent\",\n"
        "\"position\"}.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"parent", NULL, "the operator to move it under (required)"},
            {"json", NULL, "print one JSON object"},
            {NULL, NULL, NULL}},
    .run = run_move};

/* ---- wrap -------------------------------------------------------------------- */

static int run_wrap(struct bc_cli_call *a)
{
	const char *kv[BC_CLI_MAX_POSITIONAL];
	struct bc_model_wrap w = {
	    .kind = a->pos[1], .kv = kv, .child_kind = a->child};
	struct bc_client *c = NULL;
	struct bc_model_result r;
	char ids[48], sentence[200];
	int status;
	if ((status = split_name(a, a->pos + 2, (size_t)(a->npos - 2), kv,
	                         &w.nkv, &w.name)) ||
	    (status = node_arg(a, a->pos[0], &w.node)) ||
	    (status = vec_opt(a, "at", a->at, &w.has_at, w.at))) {
		return status;
	}
	if ((status = perform(a, do_wrap, &w,
	                      (const char *const[]){w.kind, w.child_kind}, &c,
	                      &r))) {
		goto out;
	}
	ids_text(&r, ids, sizeof(ids));
	snprintf(sentence, sizeof(sentence), "wrapped node %u in %s %u (%s)",
	         w.node, w.kind, r.node, ids);
	status = finish(a, c, &r, sentence);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_wrap = {
    .name = "wrap",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON | BC_CLI_O_AT | BC_CLI_O_CHILD,
    .min_pos = 2,
    .max_pos = BC_CLI_MAX_POSITIONAL,
    .synopsis = "--session NAME ID KIND [key=value...]",
    .summary = "wrap a node in a unary node or an operator",
    .help =
        "Puts a new node of KIND where node ID is, with ID (its subtree and\n"
        "ids kept) inside, as one edit. KIND is a unary node (offset, onion,\n"
        "elongate, twist, bend, mirror, repeat, scale), or an operator: ID\n"
        "becomes its first child and a new primitive of --child's kind (at\n"
        "--at, else the session camera's target) its second. key=value sets\n"
        "the new node's parameters, name=TEXT its name. Wrapping a\n"
        "primitive in union is how a one-shape scene gets an operator to\n"
        "add under.\n"
        "\n"
        "examples:\n"
        "  blobcast wrap --session demo 4 twist rate=1.5\n"
        "  blobcast wrap --session demo 2 smooth_difference blend=0.1 "
        "--child box\n"
        "  blobcast wrap --session demo 1 union name=body --json\n"
        "prints 'wrapped node ID in KIND N (ids ...), edit order O'; with\n"
        "--json {\"seq\", \"order\", \"node\" (the new node), \"ids\",\n"
        "\"parent\", \"position\"}.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"json", NULL, "print one JSON object with the new ids"},
            {NULL, NULL, NULL}},
    .run = run_wrap};

/* ---- duplicate --------------------------------------------------------------- */

static int run_duplicate(struct bc_cli_call *a)
{
	struct bc_model_duplicate d = {0};
	struct bc_client *c = NULL;
	struct bc_model_result r;
	char ids[48], sentence[200];
	int status;
	if ((status = node_arg(a, a->pos[0], &d.node)) ||
	    (status =
	         vec_opt(a, "offset", a->offset, &d.has_offset, d.offset))) {
		return status;
	}
	if ((status = perform(a, do_duplicate, &d, NULL, &c, &r))) {
		goto out;
	}
	ids_text(&r, ids, sizeof(ids));
	snprintf(sentence, sizeof(sentence),
	         "copied node %u to %u (%s) under node %u at position %u",
	         d.node, r.node, ids, r.parent, r.position);
	status = finish(a, c, &r, sentence);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_duplicate = {
    .name = "duplicate",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON | BC_CLI_O_OFFSET,
    .min_pos = 1,
    .max_pos = 1,
    .synopsis = "--session NAME ID",
    .summary = "copy a node and its subtree next to it",
    .help =
        "Inserts a copy of node ID, its subtree included, with new ids\n"
        "right after it under the same operator, as one edit. A node inside\n"
        "unary nodes is copied with them. The copied nodes keep their\n"
        "names, except that the copy of a named ID is named \"NAME copy\".\n"
        "The root is refused (wrap it in an operator first).\n"
        "\n"
        "examples:\n"
        "  blobcast duplicate --session demo 7 --offset 1,0,0\n"
        "  blobcast duplicate --session demo 5 --json\n"
        "prints 'copied node ID to N (ids ...) under node P at position K,\n"
        "edit order O'; with --json {\"seq\", \"order\", \"node\" (the\n"
        "copy), \"ids\" (the copy's, in pre-order), \"parent\",\n"
        "\"position\"}.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"json", NULL, "print one JSON object with the new ids"},
            {NULL, NULL, NULL}},
    .run = run_duplicate};

/* ---- rename ------------------------------------------------------------------ */

struct rename_arg {
	uint32_t node;
	const char *name;
};

static int do_rename(struct bc_client *c, const void *arg,
                     struct bc_model_result *r, struct bc_errinfo *ei)
{
	const struct rename_arg *n = arg;
	return bc_model_rename(c, n->node, n->name, r, ei);
}

static int run_rename(struct bc_cli_call *a)
{
	struct rename_arg n = {.name = a->pos[1]};
	struct bc_client *c = NULL;
	struct bc_model_result r;
	char quoted[BC_CLI_QUOTED_NAME], sentence[BC_CLI_QUOTED_NAME + 64];
	int status;
	if ((status = node_arg(a, a->pos[0], &n.node))) {
		return status;
	}
	if ((status = perform(a, do_rename, &n, NULL, &c, &r))) {
		goto out;
	}
	if (n.name[0]) {
		snprintf(sentence, sizeof(sentence), "named node %u %s", n.node,
		         bc_cli_quote_name(n.name, quoted, sizeof(quoted)));
	} else {
		snprintf(sentence, sizeof(sentence),
		         "took the name of node %u away", n.node);
	}
	status = finish(a, c, &r, sentence);
out:
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_rename = {
    .name = "rename",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_JSON,
    .min_pos = 2,
    .max_pos = 2,
    .synopsis = "--session NAME ID TEXT",
    .summary = "name a node, or take its name away",
    .help =
        "Gives node ID the name TEXT, as one edit (one step of undo): a label\n"
        "for people, shown by 'blobcast nodes', the history and every client;\n"
        "nodes are still addressed by id, and names need not be unique. TEXT\n"
        "is up to 64 bytes of UTF-8; \"\" takes the name away. Refused before\n"
        "sending: an unknown node, a name over 64 bytes or not UTF-8, the\n"
        "name the node already has, and a server that does not know names\n"
        "(an older blobcastd: upgrade it).\n"
        "\n"
        "examples:\n"
        "  blobcast rename --session demo 7 wheel\n"
        "  blobcast rename --session demo 7 'front wheel' --json\n"
        "  blobcast rename --session demo 7 ''\n"
        "prints 'named node ID \"TEXT\", edit order O'; with --json {\"seq\",\n"
        "\"order\", \"node\", \"ids\": [], \"parent\", \"position\"}. "
        "'blobcast\n"
        "undo' gives the earlier name back.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"json", NULL, "print one JSON object"}, {NULL, NULL, NULL}},
    .run = run_rename};
