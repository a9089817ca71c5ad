/*
 * `blobcast mesh`: a triangle mesh of a scene's surface (blobcast/mesh.h),
 * of a scene file or a live session's scene, written as OBJ, PLY, STL or
 * binary glTF.
 */
#ifndef BLOBCAST_CLI_CMD_MESH_H
#define BLOBCAST_CLI_CMD_MESH_H

/* Runs `blobcast mesh SCENE|--session NAME --out FILE [options]`. argv[0]
 * is the command word ("mesh"). Returns the process exit status: 0 on
 * success (and for --help), 1 when loading, meshing or writing fails or
 * the server refuses, 2 for a usage error, 3 and 4 for network and
 * authentication failures (as the server commands). */
int bc_cli_mesh(int argc, char **argv);

#endif
