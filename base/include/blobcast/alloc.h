/*
 * Allocation through one hook, so tests can fail the Nth allocation and prove
 * that every error path frees what it took (the "torture" loop in tests/).
 * All blobcast code allocates with bc_malloc/bc_calloc/bc_realloc/bc_free.
 */
#ifndef BLOBCAST_ALLOC_H
#define BLOBCAST_ALLOC_H

#include <stddef.h>

/* Each returns NULL on failure (or when the failure hook says so); sizes that
 * overflow (n * size) fail instead of wrapping. bc_free(NULL) is a no-op. */
void *bc_malloc(size_t size);
void *bc_calloc(size_t n, size_t size);
void *bc_realloc(void *ptr, size_t size);
/* Grows ptr to n elements of size bytes, failing on overflow. */
void *bc_reallocarray(void *ptr, size_t n, size_t size);
void bc_free(void *ptr);
/* Returns a bc_malloc'd copy of the NUL-terminated s, or NULL. */
char *bc_strdup(const char *s);

/* Test hook: the allocation numbered fail_at (1-based, counted from this
 * call) and every later one fail; 0 disables. Returns how many allocations
 * were made since the previous call. Not thread-safe; tests only. */
unsigned long bc_alloc_fail_after(unsigned long fail_at);

#endif
