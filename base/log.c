/*
 * Logger: a level threshold and a replaceable sink. The default sink writes
 * "[level] [file:line] message" lines to stderr.
 *
 * Messages carry bytes from clients (names, paths), so the formatted
 * message is escaped before any sink sees it: a control character becomes
 * \n, \t or \xNN, and one call always makes exactly one line.
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

/* Messages up to this long are formatted on the stack; longer ones in a
 * heap buffer (plain malloc: the allocation hook must not count log lines,
 * and a failed one only truncates the message). */
#define LOG_STACK_BYTES 1024

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

size_t bc_log_escape(char *dst, size_t cap, const char *src, size_t len)
{
	static const char hex[] = "0123456789abcdef";
	size_t n = 0;
	for (size_t i = 0; i < len; i++) {
		unsigned char ch = (unsigned char)src[i];
		char esc[4];
		size_t k = 0;
		if (ch == '\n') {
			esc[k++] = '\\';
			esc[k++] = 'n';
		} else if (ch == '\t') {
			esc[k++] = '\\';
			esc[k++] = 't';
		} else if (ch < 0x20 || ch == 0x7f) {
			esc[k++] = '\\';
			esc[k++] = 'x';
			esc[k++] = hex[ch >> 4];
			esc[k++] = hex[ch & 15];
		} else {
			esc[k++] = (char)ch;
		}
		/* Whole escapes only: a cut "\x1" would read as another
		 * byte. */
		if (cap == 0 || n + k > cap - 1) {
			break;
		}
		memcpy(dst + n, esc, k);
		n += k;
	}
	if (cap > 0) {
		dst[n] = '\0';
	}
	return n;
}

/* Hands the finished message to the sink through its printf interface. */
static void emit(enum bc_log_level level, const char *file, int line,
                 const char *fmt, ...) BC__PRINTF(4, 5);

static void emit(enum bc_log_level level, const char *file, int line,
                 const char *fmt, ...)
{
	va_list args;
	va_start(args, fmt);
	(sink ? sink : stderr_sink)(level, file, line, fmt, args);
	va_end(args);
}

void bc__log(enum bc_log_level level, const char *file, int line,
             const char *fmt, ...)
{
	char raw_stack[LOG_STACK_BYTES], out_stack[LOG_STACK_BYTES];
	char *raw = raw_stack, *out = out_stack;
	size_t raw_len, out_cap = sizeof(out_stack);
	va_list args;
	int n;
	if (level <= BC_LOG_SILENT || level > threshold ||
	    level >= BC_LOG_LEVEL_COUNT) {
		return;
	}
	va_start(args, fmt);
	n = vsnprintf(raw_stack, sizeof(raw_stack), fmt, args);
	va_end(args);
	if (n < 0) {
		emit(level, file, line, "(unformattable log message: %s)", fmt);
		return;
	}
	raw_len = (size_t)n;
	if (raw_len >= sizeof(raw_stack)) {
		char *big = malloc(raw_len + 1);
		if (big) {
			va_start(args, fmt);
			vsnprintf(big, raw_len + 1, fmt, args);
			va_end(args);
			raw = big;
		} else {
			raw_len = sizeof(raw_stack) - 1;
		}
	}
	/* Each byte becomes at most four. */
	if (raw_len >= sizeof(out_stack) / 4) {
		char *big = malloc(raw_len * 4 + 1);
		if (big) {
			out = big;
			out_cap = raw_len * 4 + 1;
		}
	}
	bc_log_escape(out, out_cap, raw, raw_len);
	emit(level, file, line, "%s", out);
	if (raw != raw_stack) {
		free(raw);
	}
	if (out != out_stack) {
		free(out);
	}
}
