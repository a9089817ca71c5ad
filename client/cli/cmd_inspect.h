/*
 * What `blobcast nodes` and `blobcast scene` print about a session's scene
 * (the scene mirror a join receives): a node listing, as text or JSON, and
 * the scene file. Kept apart from cmd_session.c, which runs the commands,
 * so that the formats can be read in one place.
 */
#ifndef BLOBCAST_CLI_CMD_INSPECT_H
#define BLOBCAST_CLI_CMD_INSPECT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "blobcast/blobtree.h"

/* Room for a node name quoted by bc_cli_quote_name(): BC_TREE_NAME_MAX
 * bytes, each at most 4 characters once escaped (\x1b), two quotes, NUL. */
#define BC_CLI_QUOTED_NAME (4u * BC_TREE_NAME_MAX + 3u)

/* Writes name into out (cap bytes, BC_CLI_QUOTED_NAME holds any node
 * name) in double quotes for a terminal: '"' and '\' escaped with '\',
 * control characters as \xHH (C1 controls as \u00HH), so that a name
 * cannot move the cursor or break a line. Returns out. */
const char *bc_cli_quote_name(const char *name, char *out, size_t cap);
/* Writes text into out (cap bytes; 4 times text's length and 1 hold any)
 * with its control characters escaped as bc_cli_quote_name() does, for
 * text from the server that may hold a name (a history entry's what).
 * Returns out. */
const char *bc_cli_printable(const char *text, char *out, size_t cap);

/*
 * Writes the nodes of t to out in pre-order: as text, a header line and
 * one line per node (id, type, parent or "-", the node's name quoted
 * (bc_cli_quote_name) when it has one, then its parameters as key=value,
 * the keys of `blobcast edit`); as JSON, one array of objects {"id",
 * "type", "parent" (0 for the root), "children" (operators), then the
 * parameters, and "name" on named nodes only}. Floats are written with 9
 * significant digits, enough to give the same float back. Returns 0, or
 * BC_ENOMEM / BC_EIO (out could not be written).
 */
int bc_cli_print_nodes(FILE *out, const struct bc_tree *t, bool json);

#endif
