/*
 * What every `blobcast` command shares (cli.c): the exit statuses and the
 * one place that maps a failure to them, the hint that says what to do
 * after a failure, and "did you mean" for a mistyped command, option,
 * key or kind, from one edit distance.
 */
#ifndef BLOBCAST_CLI_CLI_H
#define BLOBCAST_CLI_CLI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "blobcast/args.h"

/* The exit statuses of every command (docs/client.md, "Exit status"). */
enum {
	BC_CLI_EXIT_OK = 0,
	BC_CLI_EXIT_REFUSED = 1, /* the server refused (an ERROR answer) */
	BC_CLI_EXIT_USAGE = 2,   /* bad arguments, found before sending */
	BC_CLI_EXIT_NETWORK = 3, /* connect, TLS, timeout, closed, not a
	                            blobcastd */
	BC_CLI_EXIT_AUTH = 4,    /* EAUTH, EPERM */
};

/* Where a failure happened, for bc_cli_exit_for(). */
enum bc_cli_stage {
	BC_CLI_STAGE_INVALID = 0,
	BC_CLI_STAGE_CONNECT, /* bc_client_connect(): no session yet */
	BC_CLI_STAGE_SESSION, /* on a connection that was made */
	BC_CLI_STAGE_COUNT
};

/* The exit status for a failure with code (a BC_E* value). broken: the
 * connection's sticky error is set (the stream is unusable). */
int bc_cli_exit_for(int code, enum bc_cli_stage stage, bool broken);

/* A sentence saying what to do after a failure with code and message msg,
 * or NULL when the message says it already. */
const char *bc_cli_hint(int code, enum bc_cli_stage stage, const char *msg);

/* The optimal string alignment distance between a and b (insertions,
 * deletions, substitutions and swaps of neighbours, one each); words
 * longer than BC_CLI_MAX_WORD count as far from everything. */
#define BC_CLI_MAX_WORD 64
size_t bc_cli_distance(const char *a, const char *b);

/* Writes " (did you mean 'X'?)", or " (did you mean 'X' or 'Y'?)" (three at
 * most), into buf for the candidates[0..n) closest to word (NULL entries
 * are skipped; prefix, e.g. "--", quotes them as they are typed), or ""
 * when none is close: within 1 edit for words of up to 4 characters, 2 up
 * to 8, 3 beyond, or the one candidate that word (3 characters or more)
 * begins. Returns whether it suggested something. */
bool bc_cli_did_you_mean(const char *word, const char *const *candidates,
                         size_t n, const char *prefix, char *buf, size_t cap);

/* bc_args_parse() that first looks for options the table does not have and
 * refuses the first one with the closest ones it has (git's "did you
 * mean"), worded like the parser's own errors. */
int bc_cli_args_parse(struct bc_args *a, int argc, char **argv);

/* Prints "PROG: MSG" and a newline on out, where msg is the reason a scene
 * file or an edit's key=value list was refused (blobtree's JSON reader,
 * blobcast/edit.h). When msg names an unknown key, primitive or operator
 * kind, the closest valid ones follow as "did you mean", and for a scene
 * file's kind the list of valid kinds on the lines after. */
void bc_cli_explain(FILE *out, const char *prog, const char *msg);

#endif
