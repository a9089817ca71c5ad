/*
 * The allocation hook behind bc_malloc and friends (see blobcast/alloc.h).
 * The counter and the failure point are C11 atomics: the daemon's worker
 * threads and a client's reader allocate concurrently, and a test arming
 * the hook must not race with them.
 */
/* madvise is not POSIX (posix_madvise has no POPULATE). */
#define _DEFAULT_SOURCE
#include "blobcast/alloc.h"

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

/* Linux 5.14; older headers lack it, older kernels refuse it (EINVAL). */
#ifndef MADV_POPULATE_WRITE
#define MADV_POPULATE_WRITE 23
#endif

/* Set by the first bc_alloc_fail_after(); until then nothing is counted. */
static atomic_bool hooked;
static atomic_ulong count;
static atomic_ulong fail_at;

static int should_fail(void)
{
	if (!atomic_load_explicit(&hooked, memory_order_relaxed)) {
		return 0;
	}
	unsigned long n =
	    atomic_fetch_add_explicit(&count, 1, memory_order_relaxed) + 1;
	unsigned long at = atomic_load_explicit(&fail_at, memory_order_relaxed);
	return at != 0 && n >= at;
}

unsigned long bc_alloc_fail_after(unsigned long n)
{
	/* Disarm first so that the reset of the counter cannot make a
	 * concurrent allocation fail against the old failure point. */
	atomic_store(&fail_at, 0);
	unsigned long made = atomic_exchange(&count, 0);
	atomic_store(&fail_at, n);
	atomic_store(&hooked, true);
	return made;
}

void *bc_malloc(size_t size)
{
	if (should_fail()) {
		return NULL;
	}
	return malloc(size ? size : 1);
}

void *bc_malloc_lines(size_t size)
{
	void *p = NULL;
	if (should_fail() ||
	    posix_memalign(&p, BC_CACHE_LINE, size ? size : 1) != 0) {
		return NULL;
	}
	return p;
}

void *bc_calloc(size_t n, size_t size)
{
	if (size && n > SIZE_MAX / size) {
		return NULL;
	}
	if (should_fail()) {
		return NULL;
	}
	return calloc(n ? n : 1, size ? size : 1);
}

void *bc_realloc(void *ptr, size_t size)
{
	if (should_fail()) {
		return NULL;
	}
	return realloc(ptr, size ? size : 1);
}

void *bc_reallocarray(void *ptr, size_t n, size_t size)
{
	if (size && n > SIZE_MAX / size) {
		return NULL;
	}
	return bc_realloc(ptr, n * size);
}

void bc_free(void *ptr)
{
	free(ptr);
}

char *bc_strdup(const char *s)
{
	size_t n = strlen(s) + 1;
	char *copy = bc_malloc(n);
	if (copy) {
		memcpy(copy, s, n);
	}
	return copy;
}

bool bc_populate(void *p, size_t n)
{
	/* A first write to a page costs a trap; on virtual machines a large
	 * one (about 10 us a page measured on the 2-core test machine: 1.4 s
	 * for 512 MiB written page by page, 0.7 s after one populate). */
	long page;
	uintptr_t lo, hi;
	if (!p || n < BC_POPULATE_MIN) {
		return false;
	}
	/* Asked each time: decodes on two threads call this at once, and a
	 * cached value would be a data race. */
	page = sysconf(_SC_PAGESIZE);
	if (page <= 0) {
		page = 4096;
	}
	lo = ((uintptr_t)p + (uintptr_t)page - 1) & ~((uintptr_t)page - 1);
	hi = ((uintptr_t)p + n) & ~((uintptr_t)page - 1);
	return hi > lo &&
	       madvise((void *)lo, hi - lo, MADV_POPULATE_WRITE) == 0;
}
