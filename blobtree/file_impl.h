/*
 * Reading scene files whole and writing them atomically, shared by the
 * JSON reader and writer (json.c) and the binary scene file
 * (scene_file.c).
 */
#ifndef BLOBCAST_BLOBTREE_FILE_IMPL_H
#define BLOBCAST_BLOBTREE_FILE_IMPL_H

#include <stddef.h>

#include "blobcast/error.h"

/* Reads the regular file at path whole (refusing one over max bytes
 * before reading it) into a bc_malloc'd, NUL-terminated buffer *out of
 * *len bytes (fewer than its size if it shrank meanwhile). Returns 0,
 * BC_ENOTFOUND, BC_EIO, BC_ELIMIT or BC_ENOMEM with the reason in ei. */
int bc__read_file(const char *path, size_t max, char **out, size_t *len,
                  struct bc_errinfo *ei);

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
