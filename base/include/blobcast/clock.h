/*
 * The one monotonic clock. Every duration the project measures (frame
 * budgets, idle timeouts, latencies, benchmarks) comes from here, so they
 * all share one epoch and one unit rule: nanoseconds as integers for
 * arithmetic, milliseconds as doubles for printing and budgets.
 */
#ifndef BLOBCAST_CLOCK_H
#define BLOBCAST_CLOCK_H

#include <stdint.h>

/* CLOCK_MONOTONIC in nanoseconds since an unspecified start; never goes
 * back, unaffected by changes to the wall clock. */
uint64_t bc_clock_ns(void);
/* The same clock in milliseconds. */
double bc_clock_ms(void);

#endif
