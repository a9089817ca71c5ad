/*
 * The allocation hook behind bc_malloc and friends (see blobcast/alloc.h).
 */
#include "blobcast/alloc.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static unsigned long count;
static unsigned long fail_at;

static int should_fail(void)
{
	count++;
	return fail_at != 0 && count >= fail_at;
}

unsigned long bc_alloc_fail_after(unsigned long n)
{
	unsigned long made = count;
	count = 0;
	fail_at = n;
	return made;
}

void *bc_malloc(size_t size)
{
	if (should_fail()) {
		return NULL;
	}
	return malloc(size ? size : 1);
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
