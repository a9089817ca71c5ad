/*
 * `blobcast render`: renders a scene file on this machine with one of the
 * built-in backends and writes the colour, depth and id planes as images.
 */
#ifndef BLOBCAST_CLI_CMD_RENDER_H
#define BLOBCAST_CLI_CMD_RENDER_H

#include <stdio.h>

/* Runs `blobcast render SCENE [options]`. argv[0] is the command word
 * ("render"). Returns the process exit status: 0 on success (and for
 * --help), 1 when loading, rendering or writing fails, 2 for a usage error. */
int bc_cli_render(int argc, char **argv);

/* Prints the command's full help to out. */
void bc_cli_render_usage(FILE *out);

struct bc_tree;
struct bc_camera;
struct bc_errinfo;

/* Loads the scene a command line names: a JSON file path, "-" for stdin
 * (at most BC_SCENE_JSON_MAX_BYTES) or "default" for the embedded scene.
 * cam gets the scene's camera (the default camera when it has none).
 * Returns 0 or an error with the reason in ei. Shared by the commands that
 * read scenes. */
int bc_cli_load_scene(const char *scene, struct bc_tree *t,
                      struct bc_camera *cam, struct bc_errinfo *ei);

#endif
