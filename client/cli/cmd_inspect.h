/*
 * What `blobcast nodes` and `blobcast scene` print about a session's scene
 * (the scene mirror a join receives): a node listing, as text or JSON, and
 * the scene file. Kept apart from cmd_session.c, which runs the commands,
 * so that the formats can be read in one place.
 */
#ifndef BLOBCAST_CLI_CMD_INSPECT_H
#define BLOBCAST_CLI_CMD_INSPECT_H

#include <stdbool.h>
#include <stdio.h>

#include "blobcast/blobtree.h"

/*
 * Writes the nodes of t to out in pre-order: as text, a header line and
 * one line per node (id, type, parent or "-", then its parameters as
 * key=value, the keys of `blobcast edit`); as JSON, one array of objects
 * {"id", "type", "parent" (0 for the root), "children" (operators), then
 * the parameters}. Floats are written with 9 significant digits, enough to
 * give the same float back. Returns 0, or BC_ENOMEM / BC_EIO (out could not
 * be written).
 */
int bc_cli_print_nodes(FILE *out, const struct bc_tree *t, bool json);

#endif
