/*
 * The one logger. Programs call bc_log(); libraries inside blobcast log only
 * through it too, and a program may redirect everything with
 * bc_log_set_callback() (tests capture messages that way).
 */
#ifndef BLOBCAST_LOG_H
#define BLOBCAST_LOG_H

#include <stdarg.h>
#include <stddef.h>

#include "blobcast/export.h"

enum bc_log_level {
	BC_LOG_SILENT = 0,
	BC_LOG_ERROR,
	BC_LOG_WARN,
	BC_LOG_INFO,
	BC_LOG_DEBUG,
	BC_LOG_LEVEL_COUNT
};

typedef void (*bc_log_fn)(enum bc_log_level level, const char *file, int line,
                          const char *fmt, va_list args);

/* Messages above level are dropped. Default: BC_LOG_WARN, or the value of
 * the environment variable BLOBCAST_LOG (error|warn|info|debug) when set. */
BC_API void bc_log_init(enum bc_log_level level);

/* Replaces the sink (NULL restores stderr). A sink receives the message
 * already escaped (see bc_log_escape), as fmt "%s" and one argument. */
BC_API void bc_log_set_callback(bc_log_fn fn);

/* Returns the current threshold. */
BC_API enum bc_log_level bc_log_level(void);

/* Copies the len bytes of src to dst (cap bytes, NUL included) with each
 * control character (below 0x20, and 0x7f) written as \n, \t or \xNN, so
 * that text from the network cannot start a log line of its own. Stops
 * before an escape that would not fit whole. Returns the length written,
 * without the NUL. */
BC_API size_t bc_log_escape(char *dst, size_t cap, const char *src, size_t len);

#if defined(__GNUC__)
#define BC__PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define BC__PRINTF(a, b)
#endif

BC_API void bc__log(enum bc_log_level level, const char *file, int line,
                    const char *fmt, ...) BC__PRINTF(4, 5);

#define bc_log(level, ...) bc__log(level, __FILE__, __LINE__, __VA_ARGS__)

#endif
