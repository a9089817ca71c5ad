/*
 * Writing scene files atomically, shared by the JSON writer (json.c) and
 * the binary scene file (scene_file.c).
 */
#ifndef BLOBCAST_BLOBTREE_FILE_IMPL_H
#define BLOBCAST_BLOBTREE_FILE_IMPL_H

#include "blobcast/error.h"

/* Fills the open file fd: 0, or a BC_E* code (BC_EIO with errno set). */
typedef int (*bc__file_fill)(int fd, void *ctx);

/* Writes path atomically: fill writes a temporary file beside it, which
 * is fsynced and renamed over path, and the directory fsynced. Returns 0
 * or fill's error (BC_EIO, BC_ENOMEM, BC_ELIMIT: a scene over
 * BC_SCENE_FILE_MAX_BYTES) with the reason in ei; on failure path is as
 * it was and the temporary file is gone. */
int bc__save_atomic(const char *path, bc__file_fill fill, void *ctx,
                    struct bc_errinfo *ei);

#endif
