/*
 * Socket addresses as the daemon's access rules see them: which peers are
 * loopback (trusted without a token, docs/operations.md "Access").
 */
#ifndef BLOBCAST_SERVER_ADDR_H
#define BLOBCAST_SERVER_ADDR_H

#include <stdbool.h>
#include <sys/socket.h>

/* Returns whether sa is a loopback address: 127.0.0.0/8, ::1, or
 * 127.0.0.0/8 mapped into IPv6 (::ffff:127.0.0.0/104, what an IPv4 client
 * of a listener on :: looks like). NULL and other families: false. */
bool bc_addr_is_loopback(const struct sockaddr *sa);

#endif
