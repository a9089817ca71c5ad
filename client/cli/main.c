/*
 * The `blobcast` command: dispatches the subcommands to their files in
 * client/cli/ and prints the overview help. The global options of the
 * server commands (--server, --token, --name, --timeout, --ca,
 * --insecure) may stand before the command word; they are passed on
 * after it, where the command's own parser checks them as if given there.
 * It also holds what every command shares (cli.h): the exit statuses,
 * hints and "did you mean".
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/log.h"
#include "cli.h"
#include "cmd_client.h"
#include "cmd_evalbench.h"
#include "cmd_gen.h"
#include "cmd_mesh.h"
#include "cmd_render.h"

#ifndef BLOBCAST_VERSION
#define BLOBCAST_VERSION "unknown"
#endif

/* The subcommands that talk to a blobcastd (cmd_client.c). */
static const char *const client_cmds[] = {
    "load",          "edit",     "camera",  "snapshot", "watch",
    "bench-latency", "nodes",    "scene",   "delete",   "undo",
    "redo",          "sessions", "present", "follow",
};

/* The commands that run here, and help. */
static const char *const local_cmds[] = {"render", "mesh", "gen", "eval-bench",
                                         "help"};

#define N_CLIENT_CMDS (sizeof(client_cmds) / sizeof(client_cmds[0]))
#define N_LOCAL_CMDS (sizeof(local_cmds) / sizeof(local_cmds[0]))

static bool is_client_cmd(const char *s)
{
	for (size_t i = 0; i < N_CLIENT_CMDS; i++) {
		if (strcmp(s, client_cmds[i]) == 0) {
			return true;
		}
	}
	return false;
}

static const char main_about[] =
    "Local commands:\n"
    "  render      render a scene file to images on this machine\n"
    "  mesh        write a triangle mesh (.obj, .ply, .stl) of a scene\n"
    "  gen         print a generated scene (the paper's synthetic\n"
    "              families and more) as JSON\n"
    "  eval-bench  measure interval pruning and pruned evaluation\n"
    "              on a scene (prints JSON)\n"
    "  help [COMMAND]  this overview, or a command's full help\n"
    "\n"
    "Options (those of the server commands may also follow the command):";

/* After the option table: the server commands, then where to read more. */
static void more_help(FILE *out)
{
	fprintf(out, "\nCommands for a blobcastd server (--server HOST:PORT, "
	             "tls://HOST:PORT,\nws[s]://HOST/PATH or unix:PATH):\n");
	bc_cli_client_usage(out);
	fprintf(out,
	        "\n'blobcast COMMAND --help' describes each command's "
	        "options.\n"
	        "Exit status: 0 done, 1 the server refused, 2 usage error, "
	        "3 network (cannot\nconnect, TLS, timeout, closed, not a "
	        "blobcastd), 4 authentication (token, role).\n");
}

/* What main parses before the command word. */
struct globals {
	const char *server, *token, *name, *timeout, *ca;
	bool insecure, version;
};

/* The options before the command word: those of the server commands
 * (kept as text: the command's parser checks them) and --version. */
#define MAIN_OPTS(g)                                                           \
	{                                                                      \
		{.name = "server",                                             \
		 .kind = BC_OPT_STRING,                                        \
		 .dst = &(g)->server,                                          \
		 .arg = "ADDR",                                                \
		 .help = "the blobcastd of the server commands\n"              \
		         "(HOST:PORT, tls://HOST:PORT, ws[s]://HOST/PATH\n"    \
		         "or unix:PATH; default $BLOBCAST_SERVER, else\n"      \
		         "127.0.0.1:7878)"},                                   \
		    {.name = "token",                                          \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(g)->token,                                       \
		     .arg = "TOKEN",                                           \
		     .flags = BC_OPT_EMPTY,                                    \
		     .help =                                                   \
		         "authentication token (default $BLOBCAST_TOKEN)"},    \
		    {.name = "name",                                           \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(g)->name,                                        \
		     .arg = "NAME",                                            \
		     .flags = BC_OPT_EMPTY,                                    \
		     .help = "client name shown to other members"},            \
		    {.name = "timeout",                                        \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(g)->timeout,                                     \
		     .arg = "MS",                                              \
		     .help = "limit for connecting and for each answer\n"      \
		             "(default 10000; 0 waits forever)"},              \
		    {.name = "ca",                                             \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(g)->ca,                                          \
		     .arg = "FILE",                                            \
		     .help = "TLS: trust the CA certificates in FILE"},        \
		    {.name = "insecure",                                       \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(g)->insecure,                                    \
		     .help = "TLS: do not check the server's certificate"},    \
		    {.name = "version",                                        \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(g)->version,                                     \
		     .help = "print the version"},                             \
		    {.kind = BC_OPT_INVALID},                                  \
	}

static struct bc_args main_args(const struct bc_opt *opts)
{
	return (struct bc_args){.prog = "blobcast",
	                        .usage = "blobcast [options] COMMAND [options]",
	                        .about = main_about,
	                        .opts = opts,
	                        .stop_at_positional = true,
	                        .more_help = more_help};
}

static void usage(FILE *out)
{
	struct globals g = {0};
	const struct bc_opt opts[] = MAIN_OPTS(&g);
	struct bc_args a = main_args(opts);
	bc_args_help(&a, out);
}

/* Refuses an unknown command with the closest known ones. */
static int unknown_command(const char *cmd)
{
	const char *names[N_CLIENT_CMDS + N_LOCAL_CMDS];
	char hint[160];
	size_t n = 0;
	for (size_t i = 0; i < N_LOCAL_CMDS; i++) {
		names[n++] = local_cmds[i];
	}
	for (size_t i = 0; i < N_CLIENT_CMDS; i++) {
		names[n++] = client_cmds[i];
	}
	bc_cli_did_you_mean(cmd, names, n, "", hint, sizeof(hint));
	fprintf(stderr,
	        "blobcast: unknown command '%s'%s\n(see 'blobcast --help')\n",
	        cmd, hint);
	return BC_CLI_EXIT_USAGE;
}

/* Runs one subcommand. argv[0] is its name. */
static int dispatch(int argc, char **argv)
{
	const char *cmd = argv[0];
	if (strcmp(cmd, "render") == 0) {
		return bc_cli_render(argc, argv);
	}
	if (strcmp(cmd, "mesh") == 0) {
		return bc_cli_mesh(argc, argv);
	}
	if (strcmp(cmd, "gen") == 0) {
		return bc_cli_gen(argc, argv);
	}
	if (strcmp(cmd, "eval-bench") == 0) {
		return bc_cli_eval_bench(argc, argv);
	}
	if (is_client_cmd(cmd)) {
		return bc_cli_client(cmd, argc, argv);
	}
	return unknown_command(cmd);
}

static int help(const char *cmd)
{
	char *args[3] = {NULL, "--help", NULL};
	if (!cmd) {
		usage(stdout);
		return 0;
	}
	args[0] = (char *)cmd;
	return dispatch(2, args);
}

/* The global options given, as "--NAME=VALUE" words for the command's
 * parser (the attached form keeps an empty value or one that starts with
 * '-' a value). Returns how many were written to words (at most 6) and
 * sets *first to the first one's name. */
static int global_words(const struct globals *g, char buf[6][320], char **words,
                        const char **first)
{
	const struct {
		const char *name, *value;
	} strs[] = {{"server", g->server},
	            {"token", g->token},
	            {"name", g->name},
	            {"timeout", g->timeout},
	            {"ca", g->ca}};
	int n = 0;
	*first = NULL;
	for (size_t i = 0; i < sizeof(strs) / sizeof(strs[0]); i++) {
		if (!strs[i].value) {
			continue;
		}
		*first = *first ? *first : strs[i].name;
		words[n] = buf[n];
		if (snprintf(buf[n], sizeof(buf[n]), "--%s=%s", strs[i].name,
		             strs[i].value) >= (int)sizeof(buf[n])) {
			/* Longer than any valid value: the command refuses
			 * the truncated word just as well. */
			buf[n][sizeof(buf[n]) - 1] = '\0';
		}
		n++;
	}
	if (g->insecure) {
		*first = *first ? *first : "insecure";
		words[n++] = "--insecure";
	}
	return n;
}

int main(int argc, char **argv)
{
	struct globals g = {0};
	const struct bc_opt opts[] = MAIN_OPTS(&g);
	struct bc_args a = main_args(opts);
	char buf[6][320], *words[6];
	const char *first;
	int status, nwords;
	char **sub;
	bc_log_init(BC_LOG_WARN);
	/* Global options before the command; the command's own follow it
	 * in a.pos and are the command's to parse. */
	if (bc_cli_args_parse(&a, argc, argv)) {
		return a.status;
	}
	if (g.version) {
		printf("blobcast %s\n", BLOBCAST_VERSION);
		return 0;
	}
	if (a.npos == 0) {
		usage(stderr);
		return BC_CLI_EXIT_USAGE;
	}
	nwords = global_words(&g, buf, words, &first);
	if (strcmp(a.pos[0], "help") == 0) {
		if (nwords || a.npos > 2) {
			return bc_args_error(&a, "%s",
			                     "help takes at most one command "
			                     "and no options");
		}
		return help(a.npos > 1 ? a.pos[1] : NULL);
	}
	if (nwords == 0) {
		return dispatch(a.npos, a.pos);
	}
	if (!is_client_cmd(a.pos[0])) {
		bool known = false;
		for (size_t i = 0; i < N_LOCAL_CMDS; i++) {
			known = known || strcmp(a.pos[0], local_cmds[i]) == 0;
		}
		if (!known) {
			return unknown_command(a.pos[0]);
		}
		return bc_args_error(&a,
		                     "--%s applies to the server commands "
		                     "only, not '%s'",
		                     first, a.pos[0]);
	}
	/* The command parses its options itself: the globals go right after
	 * the command word, so that the same option given after them wins
	 * (a repeated option keeps its last value). */
	sub = bc_calloc((size_t)a.npos + (size_t)nwords + 1, sizeof(*sub));
	if (!sub) {
		fprintf(stderr, "blobcast: out of memory\n");
		return BC_CLI_EXIT_REFUSED;
	}
	sub[0] = a.pos[0];
	for (int i = 0; i < nwords; i++) {
		sub[1 + i] = words[i];
	}
	for (int i = 1; i < a.npos; i++) {
		sub[i + nwords] = a.pos[i];
	}
	status = dispatch(a.npos + nwords, sub);
	bc_free(sub);
	return status;
}

/* ---- shared by the commands (cli.h) ----------------------------------------
 */

int bc_cli_exit_for(int code, enum bc_cli_stage stage, bool broken)
{
	switch (code) {
	case 0:
		return BC_CLI_EXIT_OK;
	case BC_EAUTH:
	case BC_EPERM:
		return BC_CLI_EXIT_AUTH;
	case BC_EIO:
	case BC_ETIMEOUT:
	case BC_ECLOSED:
	case BC_EPROTO_MAGIC:
		return BC_CLI_EXIT_NETWORK;
	case BC_EPROTO_VERSION:
	case BC_ELIMIT:
	case BC_EBUSY:
		/* Answers of a blobcastd: a version it does not speak, a
		 * limit reached, busy. */
		return BC_CLI_EXIT_REFUSED;
	case BC_EINVAL:
		/* Before HELLO: our own options (a --ca file that does not
		 * load, a name). */
		return stage == BC_CLI_STAGE_CONNECT ? BC_CLI_EXIT_USAGE
		                                     : BC_CLI_EXIT_REFUSED;
	default:
		/* While connecting, the rest are the stream's (a truncated
		 * or malformed answer, a failed WebSocket upgrade) or the
		 * TLS port's ENOTSUP to plain bytes; later, a stream that
		 * broke is the network's, an ERROR answer the server's. */
		return stage == BC_CLI_STAGE_CONNECT || broken
		           ? BC_CLI_EXIT_NETWORK
		           : BC_CLI_EXIT_REFUSED;
	}
}

const char *bc_cli_hint(int code, enum bc_cli_stage stage, const char *msg)
{
	switch (code) {
	case BC_EAUTH:
		/* libblobcast's own words for a certificate say what to do
		 * (--ca FILE); the server's refusal of a token does not. */
		if (strncmp(msg, "TLS", 3) == 0) {
			return NULL;
		}
		return "give the token the server expects: --token TOKEN or "
		       "$BLOBCAST_TOKEN";
	case BC_EPERM:
		return "this needs the editor role: use a token that grants "
		       "it (--token TOKEN)";
	case BC_ENOSESSION:
		return "'blobcast sessions' lists the sessions; 'blobcast "
		       "load' creates one";
	case BC_ENONODE:
		return "'blobcast nodes --session NAME' lists the node ids";
	case BC_ETIMEOUT:
		return "the server did not answer in time: --timeout MS waits "
		       "longer (0: forever)";
	case BC_ECLOSED:
		return stage == BC_CLI_STAGE_CONNECT
		           ? NULL
		           : "the connection was lost (a daemon restart?): run "
		             "the command again";
	case BC_EPROTO_VERSION:
		return "the daemon speaks another protocol version: use a "
		       "client of its release";
	case BC_EBUSY:
		return "the server is busy: try again in a moment";
	case BC_ELIMIT:
		return "a limit of the server was reached (see above): ask "
		       "less, or ask its operator";
	default:
		return NULL;
	}
}

size_t bc_cli_distance(const char *a, const char *b)
{
	size_t n = strlen(a), m = strlen(b);
	/* Three rows of the dynamic programme: i-2, i-1 and i. */
	size_t row[3][BC_CLI_MAX_WORD + 1];
	if (n > BC_CLI_MAX_WORD || m > BC_CLI_MAX_WORD) {
		return SIZE_MAX;
	}
	for (size_t j = 0; j <= m; j++) {
		row[0][j] = j;
	}
	for (size_t i = 1; i <= n; i++) {
		size_t *cur = row[i % 3], *prev = row[(i + 2) % 3],
		       *prev2 = row[(i + 1) % 3];
		cur[0] = i;
		for (size_t j = 1; j <= m; j++) {
			size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
			size_t d = prev[j] + 1;
			if (cur[j - 1] + 1 < d) {
				d = cur[j - 1] + 1;
			}
			if (prev[j - 1] + cost < d) {
				d = prev[j - 1] + cost;
			}
			if (i > 1 && j > 1 && a[i - 1] == b[j - 2] &&
			    a[i - 2] == b[j - 1] && prev2[j - 2] + 1 < d) {
				d = prev2[j - 2] + 1;
			}
			cur[j] = d;
		}
	}
	return row[n % 3][m];
}

bool bc_cli_did_you_mean(const char *word, const char *const *candidates,
                         size_t n, const char *prefix, char *buf, size_t cap)
{
	size_t len = strlen(word), best = SIZE_MAX, nbest = 0, used;
	size_t limit = len <= 4 ? 1 : len <= 8 ? 2 : 3;
	const char *prefixed = NULL;
	size_t nprefixed = 0;
	buf[0] = '\0';
	for (size_t i = 0; i < n; i++) {
		size_t d;
		if (!candidates[i] || strcmp(candidates[i], word) == 0) {
			continue;
		}
		d = bc_cli_distance(word, candidates[i]);
		/* Not as many edits as the candidate has letters: "ab"
		 * is not a typo of "x". */
		if (d <= limit && d < strlen(candidates[i]) && d < best) {
			best = d;
		}
		if (len >= 3 && strncmp(candidates[i], word, len) == 0) {
			prefixed = candidates[i];
			nprefixed++;
		}
	}
	if (best == SIZE_MAX && nprefixed != 1) {
		return false;
	}
	used = (size_t)snprintf(buf, cap, " (did you mean ");
	/* Three at most: more is no suggestion. */
	for (size_t i = 0; i < n && used < cap && nbest < 3; i++) {
		bool pick =
		    candidates[i] && strcmp(candidates[i], word) != 0 &&
		    (best == SIZE_MAX
		         ? candidates[i] == prefixed
		         : bc_cli_distance(word, candidates[i]) == best);
		if (!pick) {
			continue;
		}
		used += (size_t)snprintf(buf + used, cap - used, "%s'%s%s'",
		                         nbest ? " or " : "", prefix,
		                         candidates[i]);
		nbest++;
	}
	if (used < cap) {
		snprintf(buf + used, cap - used, "?)");
	}
	return true;
}

/* Refuses the unknown option arg of a's table with the closest ones it
 * lists in its help. Returns 1 with a->status 2. */
static int unknown_option(struct bc_args *a, const char *arg)
{
	const char *names[BC_ARGS_MAX_OPTS + 1];
	char word[BC_CLI_MAX_WORD + 1], hint[160];
	const char *eq = strchr(arg, '=');
	size_t len = eq ? (size_t)(eq - arg) : strlen(arg), n = 0;
	for (int i = 0; a->opts && a->opts[i].kind != BC_OPT_INVALID &&
	                n < BC_ARGS_MAX_OPTS;
	     i++) {
		if (!(a->opts[i].flags & BC_OPT_HIDDEN)) {
			names[n++] = a->opts[i].name;
		}
	}
	names[n++] = "help";
	hint[0] = '\0';
	if (arg[1] == '-' && len - 2 <= BC_CLI_MAX_WORD) {
		memcpy(word, arg + 2, len - 2);
		word[len - 2] = '\0';
		bc_cli_did_you_mean(word, names, n, "--", hint, sizeof(hint));
	}
	a->status =
	    bc_args_error(a, "unknown option '%.*s'%s", (int)len, arg, hint);
	return 1;
}

int bc_cli_args_parse(struct bc_args *a, int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		const char *arg = argv[i];
		const struct bc_opt *o;
		if (arg[0] != '-' || arg[1] == '\0') {
			if (a->stop_at_positional) {
				break;
			}
			continue;
		}
		if (strcmp(arg, "--") == 0 || strcmp(arg, "-h") == 0 ||
		    strcmp(arg, "--help") == 0) {
			/* The rest is positional, or the help wins. */
			break;
		}
		const char *val;
		int index;
		if (!(o = bc_args_find(a->opts, arg, &val, &index))) {
			return unknown_option(a, arg);
		}
		if (o->kind != BC_OPT_FLAG && !val) {
			i++; /* its value, whatever it looks like */
		}
	}
	return bc_args_parse(a, argc, argv);
}

/* Copies the word between the double quotes that follow the first
 * occurrence of lead in msg into word; false when there is none. */
static bool quoted_after(const char *msg, const char *lead, char *word,
                         size_t cap)
{
	const char *p = strstr(msg, lead), *end;
	if (!p) {
		return false;
	}
	p += strlen(lead);
	if (!(end = strchr(p, '"')) || (size_t)(end - p) >= cap) {
		return false;
	}
	memcpy(word, p, (size_t)(end - p));
	word[end - p] = '\0';
	return true;
}

/* Every primitive kind's name, then every operator's; returns the count. */
static size_t kind_names(const char **names, size_t cap)
{
	size_t n = 0;
	for (int k = 1; k < BC_PRIM_COUNT && n < cap; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		if (info) {
			names[n++] = info->name;
		}
	}
	for (int k = 1; k < BC_OP_COUNT && n < cap; k++) {
		const char *name = bc_op_name((enum bc_op)k);
		if (name) {
			names[n++] = name;
		}
	}
	return n;
}

/* The keys a scene file's node of kind what ("sphere", "smooth_union",
 * "twist") takes, as blobtree's JSON reader lists them; returns the count
 * (0 for an unknown kind). */
static size_t scene_keys(const char *what, const char **keys, size_t cap)
{
	enum bc_prim pk = bc_prim_from_name(what);
	enum bc_op op = bc_op_from_name(what);
	size_t n = 0;
	if (cap < 5 + BC_PRIM_MAX_PARAMS) {
		return 0;
	}
	keys[n++] = "type";
	keys[n++] = "id";
	if (pk != BC_PRIM_INVALID) {
		const struct bc_prim_info *info = bc_prim_info(pk);
		keys[n++] = "translate";
		keys[n++] = "rotate";
		keys[n++] = "color";
		for (uint32_t i = 0; info && i < info->nparams; i++) {
			keys[n++] = info->params[i].name;
		}
		return n;
	}
	if (op == BC_OP_INVALID) {
		return 0;
	}
	keys[n++] = "children";
	if (op == BC_OP_REPEAT) {
		keys[n++] = "spacing";
		keys[n++] = "count";
	} else if (bc_op_is_unary(op)) {
		keys[n++] = bc_unary_info(op)->param;
	} else if (bc_op_is_smooth(op)) {
		keys[n++] = "blend";
		keys[n++] = "range";
	}
	return n;
}

/* Prints names[0..n) on out as "PROG: LABEL: a, b, c", wrapped. */
static void print_list(FILE *out, const char *prog, const char *label,
                       const char *const *names, size_t n)
{
	size_t col = (size_t)fprintf(out, "%s: %s:", prog, label);
	for (size_t i = 0; i < n; i++) {
		size_t w = strlen(names[i]) + 2;
		if (col + w > 78) {
			col = (size_t)fprintf(out, "\n   ");
		}
		col += (size_t)fprintf(out, " %s%s", names[i],
		                       i + 1 < n ? "," : "");
	}
	fputc('\n', out);
}

/* Copies the name (letters, digits, '_') at the start of s into buf. */
static void name_at(const char *s, char *buf, size_t cap)
{
	size_t n = 0;
	while (n + 1 < cap && ((s[n] >= 'a' && s[n] <= 'z') ||
	                       (s[n] >= '0' && s[n] <= '9') || s[n] == '_')) {
		buf[n] = s[n];
		n++;
	}
	buf[n] = '\0';
}

void bc_cli_explain(FILE *out, const char *prog, const char *msg)
{
	const char *names[BC_PRIM_COUNT + BC_OP_COUNT + 8];
	const size_t cap = sizeof(names) / sizeof(names[0]);
	char word[BC_CLI_MAX_WORD + 1], what[BC_CLI_MAX_WORD + 1];
	char hint[200] = "", list[512];
	const char *keys, *p;
	size_t n = 0, nprims = 0;
	bool kinds = false;
	if (quoted_after(msg, "unknown primitive type \"", word,
	                 sizeof(word)) ||
	    quoted_after(msg, "unknown operator type \"", word, sizeof(word))) {
		/* A scene file's "type": any kind. */
		n = kind_names(names, cap);
		while (nprims < n &&
		       bc_prim_from_name(names[nprims]) != BC_PRIM_INVALID) {
			nprims++;
		}
		kinds = true;
	} else if (quoted_after(msg, "kind: \"", word, sizeof(word))) {
		/* An edit's kind=: operators and unary nodes (the message
		 * lists them). */
		size_t all = kind_names(names, cap);
		while (nprims < all &&
		       bc_prim_from_name(names[nprims]) != BC_PRIM_INVALID) {
			nprims++;
		}
		memmove(names, names + nprims,
		        (all - nprims) * sizeof(names[0]));
		n = all - nprims;
	} else if (quoted_after(msg, "unknown key \"", word, sizeof(word)) &&
	           (p = strstr(msg, "\" for "))) {
		/* A scene file's key: "... for sphere". */
		name_at(p + strlen("\" for "), what, sizeof(what));
		n = scene_keys(what, names, cap);
	} else if (quoted_after(msg, " has no \"", word, sizeof(word)) &&
	           (keys = strstr(msg, "; keys: "))) {
		/* An edit's key: the message lists those the node takes. */
		char *save = NULL, *tok;
		snprintf(list, sizeof(list), "%s", keys + strlen("; keys: "));
		for (tok = strtok_r(list, " ", &save); tok && n < cap;
		     tok = strtok_r(NULL, " ", &save)) {
			names[n++] = tok;
		}
	}
	if (n) {
		bc_cli_did_you_mean(word, names, n, "", hint, sizeof(hint));
	}
	fprintf(out, "%s: %s%s\n", prog, msg, hint);
	if (kinds) {
		print_list(out, prog, "primitive kinds", names, nprims);
		print_list(out, prog, "operator kinds", names + nprims,
		           n - nprims);
	}
}
