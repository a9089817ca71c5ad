/*
 * The `blobcast` subcommands that talk to a blobcastd through libblobcast:
 * load, edit, camera, present, follow, snapshot, watch, bench-latency,
 * nodes, scene, delete, sessions, undo and redo.
 */
#ifndef BLOBCAST_CLI_CMD_CLIENT_H
#define BLOBCAST_CLI_CMD_CLIENT_H

#include <stdio.h>

/* Runs one client subcommand. argv[0] is the subcommand's name (the same
 * string as subcommand); argv[1..argc) are its arguments, where
 * `--server ADDR` may appear anywhere (main passes a global --server that
 * way; a later one wins). Output goes to stdout, messages to stderr.
 * Returns the process exit status: 0 on success (and for --help), 1 when
 * the server or the connection fails (the server's ERROR text is printed),
 * 2 for a usage error (worded like every command's, blobcast/args.h). */
int bc_cli_client(const char *subcommand, int argc, char **argv);

/* Prints one help line per client subcommand, for the overview. */
void bc_cli_client_usage(FILE *out);

#endif
