/*
 * `blobcast mesh`: a triangle mesh of a scene's surface (blobcast/mesh.h),
 * written as OBJ, PLY or STL.
 */
#ifndef BLOBCAST_CLI_CMD_MESH_H
#define BLOBCAST_CLI_CMD_MESH_H

/* Runs `blobcast mesh SCENE --out FILE [--resolution N] [--bounds ...]`.
 * argv[0] is the command word ("mesh"). Returns the process exit status: 0
 * on success (and for --help), 1 when loading, meshing or writing fails, 2
 * for a usage error. */
int bc_cli_mesh(int argc, char **argv);

#endif
