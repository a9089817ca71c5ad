/*
 * Strings for the project's error table (see blobcast/error.h).
 */
#include "blobcast/error.h"

#include <stdarg.h>
#include <stdio.h>

static int magnitude(int code)
{
	return code < 0 ? -code : code;
}

const char *bc_strerror(int code)
{
	switch (magnitude(code)) {
#define BC__ERR_MSG(name, num, msg)                                            \
	case num:                                                              \
		return msg;
		BC_ERRNO_MAP(BC__ERR_MSG)
#undef BC__ERR_MSG
	default:
		return "unknown error";
	}
}

const char *bc_err_name(int code)
{
	switch (magnitude(code)) {
#define BC__ERR_NAME(name, num, msg)                                           \
	case num:                                                              \
		return #name;
		BC_ERRNO_MAP(BC__ERR_NAME)
#undef BC__ERR_NAME
	default:
		return "UNKNOWN";
	}
}

int bc_errinfo_set(struct bc_errinfo *ei, int code, const char *fmt, ...)
{
	va_list args;
	if (!ei) {
		return code;
	}
	ei->code = code;
	va_start(args, fmt);
	vsnprintf(ei->msg, sizeof(ei->msg), fmt, args);
	va_end(args);
	return code;
}
