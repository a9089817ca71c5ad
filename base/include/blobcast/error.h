/*
 * The project's one error list. Every function that can fail returns 0 or a
 * negative BC_E* code from this table; the same numbers travel in the wire
 * protocol's ERROR message, so codes are append-only: never renumber one.
 */
#ifndef BLOBCAST_ERROR_H
#define BLOBCAST_ERROR_H

#include "blobcast/export.h"

/* X(NAME, number, human sentence). Numbers are positive here; the C return
 * value is the negation (BC_ENOMEM == -2). */
#define BC_ERRNO_MAP(X)                                                        \
	X(NONE, 0, "no error (success)")                                       \
	X(EINVAL, 1, "invalid argument")                                       \
	X(ENOMEM, 2, "out of memory")                                          \
	X(ERANGE, 3, "value out of range")                                     \
	X(ELIMIT, 4, "a named limit was exceeded")                             \
	X(EIO, 5, "input/output error")                                        \
	X(EPARSE, 6, "malformed input")                                        \
	X(ENOTFOUND, 7, "no such object")                                      \
	X(EEXIST, 8, "object already exists")                                  \
	X(ENOTSUP, 9, "operation not supported")                               \
	X(ESTATE, 10, "operation not allowed in this state")                   \
	X(EAGAIN, 11, "more input needed")                                     \
	X(EPROTO_MAGIC, 12, "bad protocol magic")                              \
	X(EPROTO_VERSION, 13, "unsupported protocol version")                  \
	X(EPROTO_TYPE, 14, "unknown message type")                             \
	X(EPROTO_LENGTH, 15, "payload length invalid or over the limit")       \
	X(EPROTO_TRUNCATED, 16, "message body shorter than its fields")        \
	X(EPROTO_TRAILING, 17, "bytes left after the message's fields")        \
	X(EPROTO_COUNT, 18, "a count exceeds its limit or the bytes left")     \
	X(EPROTO_FLAGS, 19, "reserved flag bits set")                          \
	X(ENONFINITE, 20,                                                      \
	  "NaN or infinite number where a finite one is required")             \
	X(EDEPTH, 21, "nesting deeper than the limit")                         \
	X(EAUTH, 22, "authentication failed")                                  \
	X(EPERM, 23, "not permitted for this role")                            \
	X(ENOSESSION, 24, "no such session")                                   \
	X(ENONODE, 25, "no node with that id")                                 \
	X(EDUPID, 26, "duplicate node id")                                     \
	X(EBUSY, 27, "resource busy, try again")                               \
	X(ETIMEOUT, 28, "timed out")                                           \
	X(EGL, 29, "graphics driver error")                                    \
	X(ECODEC, 30, "image encoding or decoding failed")                     \
	X(ESTRING, 31, "string not valid UTF-8 or contains NUL")               \
	X(EENUM, 32, "enumeration value out of range")                         \
	X(ECLOSED, 33, "connection closed")

enum bc_err {
#define BC__ERR_ENUM(name, num, msg) BC_##name = -(num),
	BC_ERRNO_MAP(BC__ERR_ENUM)
#undef BC__ERR_ENUM
};

/* Number of codes in the table; codes are 0..BC_ERR_COUNT-1 in magnitude. */
#define BC_ERR_COUNT 34

/* Returns a static human sentence for code (negative or positive); unknown
 * codes get "unknown error". Never NULL, never to be freed. */
BC_API const char *bc_strerror(int code);

/* Returns the static symbolic name ("ENOMEM") of code, "UNKNOWN" if none. */
BC_API const char *bc_err_name(int code);

/* An error with a reason, for APIs whose failures need a sentence (scene
 * files, edits). code is 0 or a BC_E* value; msg is NUL-terminated. */
struct bc_errinfo {
	int code;
	char msg[256];
};

#if defined(__GNUC__)
#define BC__ERRINFO_PRINTF __attribute__((format(printf, 3, 4)))
#else
#define BC__ERRINFO_PRINTF
#endif

/* Records code and a printf-formatted reason in ei (which may be NULL) and
 * returns code, so callers can write `return bc_errinfo_set(ei, ...)`. */
BC_API int bc_errinfo_set(struct bc_errinfo *ei, int code, const char *fmt,
                          ...) BC__ERRINFO_PRINTF;

#endif
