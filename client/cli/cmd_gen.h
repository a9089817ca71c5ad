/*
 * `blobcast gen`: prints a generated scene (blobcast/gen.h) as a JSON scene
 * file, or writes it atomically with --out.
 */
#ifndef BLOBCAST_CLI_CMD_GEN_H
#define BLOBCAST_CLI_CMD_GEN_H

/* Runs `blobcast gen NAME [options] [--out FILE]`. argv[0] is the command
 * word ("gen"); argv[1..argc) are its arguments. Writes the scene to stdout
 * (or FILE), messages to stderr. Returns the process exit status: 0 on
 * success (and for --help), 1 when generating or writing fails, 2 for a
 * usage error (unknown generator, bad or inapplicable option). */
int bc_cli_gen(int argc, char **argv);

#endif
