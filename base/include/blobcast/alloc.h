/*
 * Allocation through one hook, so tests can fail the Nth allocation and prove
 * that every error path frees what it took (the "torture" loop in tests/).
 * All blobcast code allocates with bc_malloc/bc_calloc/bc_realloc/bc_free.
 */
#ifndef BLOBCAST_ALLOC_H
#define BLOBCAST_ALLOC_H

#include <stdbool.h>
#include <stddef.h>

#include "blobcast/export.h"

/* Each returns NULL on failure (or when the failure hook says so); sizes that
 * overflow (n * size) fail instead of wrapping. bc_free(NULL) is a no-op. */
BC_API void *bc_malloc(size_t size);
/* bc_malloc at an address that is a multiple of BC_CACHE_LINE (freed with
 * bc_free): for arrays that threads write in parts side by side, so that
 * parts cut at multiples of the line share none. */
BC_API void *bc_malloc_lines(size_t size);
#define BC_CACHE_LINE 64u
BC_API void *bc_calloc(size_t n, size_t size);
BC_API void *bc_realloc(void *ptr, size_t size);
/* Grows ptr to n elements of size bytes, failing on overflow. */
BC_API void *bc_reallocarray(void *ptr, size_t n, size_t size);
BC_API void bc_free(void *ptr);
/* Returns a bc_malloc'd copy of the NUL-terminated s, or NULL. */
BC_API char *bc_strdup(const char *s);
/* Backs p[0..n) with memory now, in one call to the kernel, instead of a
 * page fault for each page as the bytes are first written
 * (MADV_POPULATE_WRITE, Linux 5.14). For arrays about to be written whole;
 * the contents do not change. Does nothing for ranges under
 * BC_POPULATE_MIN or where the kernel cannot; returns whether the kernel
 * took it. */
BC_API bool bc_populate(void *p, size_t n);
#define BC_POPULATE_MIN (1u << 20)

#ifdef BLOBCAST_ALLOC_HOOK
/* Test hook, declared only inside the project's build (bc_base defines
 * BLOBCAST_ALLOC_HOOK for the code that links it) and not exported by
 * libblobcast. The allocation numbered fail_at (1-based, counted from this
 * call) and every later one fail; 0 disables. Returns how many allocations
 * were made since the previous call. Counting starts with the first call,
 * so programs that never call it pay one relaxed load per allocation. Safe
 * to call while other threads allocate, though what they count then depends
 * on timing: torture loops call it from one thread around one operation. */
unsigned long bc_alloc_fail_after(unsigned long fail_at);
#endif

#endif
