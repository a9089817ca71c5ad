/*
 * The monotonic clock (blobcast/clock.h). POSIX guarantees CLOCK_MONOTONIC
 * on every system the project builds for, so a failure of clock_gettime is
 * a programmer error and returns 0 rather than a code nobody would check.
 */
#include "blobcast/clock.h"

#include <time.h>

uint64_t bc_clock_ns(void)
{
	struct timespec ts;
	if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
		return 0;
	}
	return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

double bc_clock_ms(void)
{
	return (double)bc_clock_ns() / 1e6;
}
