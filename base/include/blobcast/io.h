/*
 * Writing and reading a whole buffer through a file descriptor: the one
 * loop that retries short writes or reads and EINTR, for the files the
 * project writes whole (scene files, snapshots, their history).
 */
#ifndef BLOBCAST_IO_H
#define BLOBCAST_IO_H

#include <stdbool.h>
#include <stddef.h>

/* Writes len bytes of p to fd. Returns false on failure with errno set
 * (EIO when write(2) wrote nothing and said nothing). */
bool bc_write_all(int fd, const void *p, size_t len);
/* Reads exactly len bytes from fd into p. Returns false on failure with
 * errno set (EIO when the file ended first). */
bool bc_read_all(int fd, void *p, size_t len);

#endif
