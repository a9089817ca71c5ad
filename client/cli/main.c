/*
 * The `blobcast` command: dispatches the subcommands to their files in
 * client/cli/ and prints the overview help.
 */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/log.h"
#include "cmd_mesh.h"
#include "cmd_render.h"
#include "cmd_gen.h"
#include "cmd_evalbench.h"
#include "cmd_client.h"

#ifndef BLOBCAST_VERSION
#define BLOBCAST_VERSION "unknown"
#endif

/* The subcommands that talk to a blobcastd (cmd_client.c). */
static const char *const client_cmds[] = {
    "load",          "edit",     "camera",  "snapshot", "watch",
    "bench-latency", "nodes",    "scene",   "delete",   "undo",
    "redo",          "sessions", "present", "follow",
};

static bool is_client_cmd(const char *s)
{
	for (size_t i = 0; i < sizeof(client_cmds) / sizeof(client_cmds[0]);
	     i++) {
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
    "Options (before the command):";

/* After the option table: the server commands, then where to read more. */
static void more_help(FILE *out)
{
	fprintf(out,
	        "\nCommands for a blobcastd server (--server HOST:PORT or\n"
	        "unix:PATH, before or after the command):\n");
	bc_cli_client_usage(out);
	fprintf(out, "\n'blobcast COMMAND --help' describes each command's "
	             "options.\n");
}

/* The options before the command word, over server and version. */
#define MAIN_OPTS(server, version)                                             \
	{                                                                      \
		{.name = "server",                                             \
		 .kind = BC_OPT_STRING,                                        \
		 .dst = (server),                                              \
		 .arg = "ADDR",                                                \
		 .help = "the blobcastd of the server commands\n"              \
		         "(HOST:PORT, tls://HOST:PORT or unix:PATH)"},         \
		    {.name = "version",                                        \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = (version),                                         \
		     .help = "print the version"},                             \
		    {.kind = BC_OPT_INVALID},                                  \
	}

static struct bc_args main_args(const struct bc_opt *opts)
{
	return (struct bc_args){
	    .prog = "blobcast",
	    .usage = "blobcast [--server ADDR] COMMAND [options]",
	    .about = main_about,
	    .opts = opts,
	    .stop_at_positional = true,
	    .more_help = more_help};
}

static void usage(FILE *out)
{
	const char *server = NULL;
	bool version = false;
	const struct bc_opt opts[] = MAIN_OPTS(&server, &version);
	struct bc_args a = main_args(opts);
	bc_args_help(&a, out);
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
	fprintf(stderr,
	        "blobcast: unknown command '%s' (see 'blobcast --help')\n",
	        cmd);
	return 2;
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

int main(int argc, char **argv)
{
	const char *server = NULL;
	bool version = false;
	const struct bc_opt opts[] = MAIN_OPTS(&server, &version);
	struct bc_args a = main_args(opts);
	int status;
	char **sub;
	bc_log_init(BC_LOG_WARN);
	/* Global options before the command; the command's own follow it
	 * in a.pos and are the command's to parse. */
	if (bc_args_parse(&a, argc, argv)) {
		return a.status;
	}
	if (version) {
		printf("blobcast %s\n", BLOBCAST_VERSION);
		return 0;
	}
	if (a.npos == 0) {
		usage(stderr);
		return 2;
	}
	if (strcmp(a.pos[0], "help") == 0) {
		if (server || a.npos > 2) {
			return bc_args_error(&a, "%s",
			                     "help takes at most one command "
			                     "and no --server");
		}
		return help(a.npos > 1 ? a.pos[1] : NULL);
	}
	if (!server) {
		return dispatch(a.npos, a.pos);
	}
	if (!is_client_cmd(a.pos[0])) {
		return bc_args_error(&a,
		                     "--server applies to the server commands "
		                     "only, not '%s'",
		                     a.pos[0]);
	}
	/* The client commands parse --server themselves: pass it after the
	 * command word. */
	sub = bc_calloc((size_t)a.npos + 3, sizeof(*sub));
	if (!sub) {
		fprintf(stderr, "blobcast: out of memory\n");
		return 1;
	}
	sub[0] = a.pos[0];
	sub[1] = "--server";
	sub[2] = (char *)server;
	for (int i = 1; i < a.npos; i++) {
		sub[i + 2] = a.pos[i];
	}
	status = dispatch(a.npos + 2, sub);
	bc_free(sub);
	return status;
}
