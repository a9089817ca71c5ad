/*
 * Logger: a level threshold and a replaceable sink. The default sink writes
 * "[level] [file:line] message" lines to stderr.
 */
#include "blobcast/log.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static enum bc_log_level threshold = BC_LOG_WARN;
static bc_log_fn sink;

static const char *const level_names[BC_LOG_LEVEL_COUNT] = {
	"silent", "error", "warn", "info", "debug",
};

static const char *basename_of(const char *path)
{
	const char *slash = strrchr(path, '/');
	return slash ? slash + 1 : path;
}

static void stderr_sink(enum bc_log_level level, const char *file, int line,
			const char *fmt, va_list args) BC__PRINTF(4, 0);

static void stderr_sink(enum bc_log_level level, const char *file, int line,
			const char *fmt, va_list args)
{
	fprintf(stderr, "[%s] [%s:%d] ", level_names[level], basename_of(file),
		line);
	vfprintf(stderr, fmt, args);
	fputc('\n', stderr);
}

void bc_log_init(enum bc_log_level level)
{
	const char *env = getenv("BLOBCAST_LOG");
	threshold = level;
	if (!env) {
		return;
	}
	for (int i = 0; i < BC_LOG_LEVEL_COUNT; i++) {
		if (strcmp(env, level_names[i]) == 0) {
			threshold = (enum bc_log_level)i;
		}
	}
}

void bc_log_set_callback(bc_log_fn fn)
{
	sink = fn;
}

enum bc_log_level bc_log_level(void)
{
	return threshold;
}

void bc__log(enum bc_log_level level, const char *file, int line,
	     const char *fmt, ...)
{
	va_list args;
	if (level <= BC_LOG_SILENT || level > threshold ||
	    level >= BC_LOG_LEVEL_COUNT) {
		return;
	}
	va_start(args, fmt);
	(sink ? sink : stderr_sink)(level, file, line, fmt, args);
	va_end(args);
}
