/*
 * The `blobcast` command: dispatches the subcommands to their files in
 * client/cli/ and prints the overview help. The global options of the
 * server commands (--server, --token, --name, --timeout, --ca,
 * --insecure) may stand before the command word; they are passed on
 * after it, where the command's own parser checks them as if given there.
 * What every command shares (exit statuses, hints, "did you mean") is in
 * cli.c.
 */
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
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
    "load",      "edit",   "camera",  "snapshot", "watch", "bench-latency",
    "nodes",     "scene",  "delete",  "undo",     "redo",  "sessions",
    "present",   "follow", "add",     "remove",   "move",  "wrap",
    "duplicate", "rename", "history",
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
    "  mesh        write a closed mesh (.obj .ply .stl .glb) of a scene\n"
    "              or a live session's (--session; --on-daemon: the\n"
    "              daemon makes it)\n"
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
	const char *server, *session, *token, *name, *timeout, *ca;
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
		    {.name = "session",                                        \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(g)->session,                                     \
		     .arg = "NAME",                                            \
		     .help = "the session of the commands that take one"},     \
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
 * '-' a value). Returns how many were written to words (at most 7) and
 * sets *first to the first one's name. */
static int global_words(const struct globals *g, char buf[7][320], char **words,
                        const char **first)
{
	const struct {
		const char *name, *value;
	} strs[] = {{"server", g->server},   {"session", g->session},
	            {"token", g->token},     {"name", g->name},
	            {"timeout", g->timeout}, {"ca", g->ca}};
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
	char buf[7][320], *words[7];
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
	/* mesh takes them too, for --session. */
	if (!is_client_cmd(a.pos[0]) && strcmp(a.pos[0], "mesh") != 0) {
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
