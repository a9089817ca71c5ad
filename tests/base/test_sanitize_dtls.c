/*
 * The sanitizer build's leak check in a process with a library of dynamic
 * TLS opened by dlopen (base/asan_defaults.c says why it matters: Mesa
 * opens libLLVM so): the process ends with threads alive whose dynamic TLS
 * is in use and with threads that used it and ended. LeakSanitizer must get
 * through its exit-time check (its tracer crashed there, signal 11, every
 * time with the runtime's own defaults), report nothing when nothing leaked
 * and still report a real leak.
 * Each case runs in a child process of this program (self_child.h); the
 * parent reads its exit status and what it wrote. Built only in sanitizer
 * builds.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "self_child.h"
#include "test.h"

#ifndef BC_DTLS_MODULE
#error "BC_DTLS_MODULE names the library with dynamic TLS"
#endif

enum { HOLDERS = 8, PASSERS = 8 };

static void *(*dtls_keep)(void *);
static int hold_pipe[2];

/* Keeps a block in its dynamic TLS and waits for a byte that never comes:
 * the thread is alive when the process ends. */
static void *holder(void *arg)
{
	char c;
	(void)arg;
	dtls_keep(malloc(64));
	while (read(hold_pipe[0], &c, 1) < 0) {
	}
	return NULL;
}

/* Uses its dynamic TLS and ends, freeing what it kept. */
static void *passer(void *arg)
{
	(void)arg;
	dtls_keep(malloc(32));
	free(dtls_keep(NULL));
	return NULL;
}

/* The lost block of the "leak" case: overwritten, so only the heap has it. */
static void *volatile lost;

static int child(int leak)
{
	void *h = dlopen(BC_DTLS_MODULE, RTLD_NOW);
	pthread_t t;
	if (!h) {
		fprintf(stderr, "dlopen: %s\n", dlerror());
		return 2;
	}
	dtls_keep = (void *(*)(void *))dlsym(h, "bc_dtls_keep");
	if (!dtls_keep || pipe(hold_pipe) != 0) {
		return 2;
	}
	for (int i = 0; i < HOLDERS; i++) {
		if (pthread_create(&t, NULL, holder, NULL) != 0) {
			return 2;
		}
	}
	for (int i = 0; i < PASSERS; i++) {
		if (pthread_create(&t, NULL, passer, NULL) != 0 ||
		    pthread_join(t, NULL) != 0) {
			return 2;
		}
	}
	if (leak) {
		lost = malloc(4096);
		memset(lost, 1, 4096);
		lost = NULL;
	}
	/* The holders have kept their blocks before the process ends. */
	usleep(20000);
	return 0;
}

static char err[1 << 16];

static void threads_with_dynamic_tls_end_cleanly(void)
{
	int st = 0;
	REQUIRE(self_child("test_sanitize_dtls", "clean", "detect_leaks=1", &st,
	                   err, sizeof(err)) == 0);
	if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) {
		fprintf(stderr, "  child's standard error:\n%s\n", err);
	}
	CHECK(strstr(err, "Tracer caught") == NULL);
	CHECK(strstr(err, "LeakSanitizer has encountered a fatal error") ==
	      NULL);
	/* The holders' blocks, kept in their dynamic TLS, are not leaks. */
	CHECK(strstr(err, "detected memory leaks") == NULL);
	CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

static void a_leak_is_still_reported(void)
{
	int st = 0;
	REQUIRE(self_child("test_sanitize_dtls", "leak", "detect_leaks=1", &st,
	                   err, sizeof(err)) == 0);
	CHECK(strstr(err, "Tracer caught") == NULL);
	CHECK(strstr(err, "detected memory leaks") != NULL);
	CHECK(strstr(err, "4096 byte(s) in 1 object(s)") != NULL);
	CHECK(WIFEXITED(st) && WEXITSTATUS(st) != 0);
	if (strstr(err, "4096 byte(s)") == NULL) {
		fprintf(stderr, "  child's standard error:\n%s\n", err);
	}
}

static const struct bc_test tests[] = {
    {"threads_with_dynamic_tls_end_cleanly",
     threads_with_dynamic_tls_end_cleanly},
    {"a_leak_is_still_reported", a_leak_is_still_reported},
};

int main(int argc, char **argv)
{
	if (argc == 3 && strcmp(argv[1], "--child") == 0) {
		return child(strcmp(argv[2], "leak") == 0);
	}
	return bc_test_run(tests, sizeof(tests) / sizeof(tests[0]), argc, argv);
}
