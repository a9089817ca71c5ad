/*
 * A library with dynamic TLS, for test_sanitize_dtls: opened by dlopen, its
 * thread-local variables live in each thread's dynamic TLS (general
 * dynamic model; no DF_STATIC_TLS), as libLLVM's do when Mesa opens it.
 */
#include <stddef.h>

void *bc_dtls_keep(void *p);
extern __thread unsigned char bc_dtls_pad[24];
extern __thread void *bc_dtls_kept;

__thread unsigned char bc_dtls_pad[24];
__thread void *bc_dtls_kept;

/* Keeps p in the calling thread's dynamic TLS only; gives the last one. */
void *bc_dtls_keep(void *p)
{
	void *last = bc_dtls_kept;
	bc_dtls_pad[0]++;
	bc_dtls_kept = p;
	return last;
}
