/*
 * The sanitizer build's undefined-behaviour checks still stop a program
 * and say where: signed overflow, an out-of-range shift and an index past
 * an array's end each end the child process that does them, before it
 * goes on, with a report on standard error that names the function and
 * this file's line (a trap that AddressSanitizer reports, handle_sigill in
 * base/asan_defaults.c, when BLOBCAST_UBSAN_TRAP is on; the UBSan
 * runtime's message when it is off), and a child that does nothing
 * undefined exits 0 with no report. Built only in sanitizer builds.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "self_child.h"
#include "test.h"

/* Inputs the compiler cannot see through. */
static volatile int big = 0x7fffffff, wide = 40, past = 8;
static int table[8];

static int ub_overflow(void)
{
	return big + 1;
}

static int ub_shift(void)
{
	return 1 << wide;
}

static int ub_index(void)
{
	return table[past];
}

static int child(const char *mode)
{
	int v = 0;
	if (strcmp(mode, "overflow") == 0) {
		v = ub_overflow();
	} else if (strcmp(mode, "shift") == 0) {
		v = ub_shift();
	} else if (strcmp(mode, "index") == 0) {
		v = ub_index();
	} else if (strcmp(mode, "none") != 0) {
		return 2;
	}
	printf("survived %d\n", v);
	return 0;
}

static char out[1 << 16];

/* The child in mode stops with a report naming fn in this file. */
static void stops_and_says_where(const char *mode, const char *fn)
{
	int st = 0;
	REQUIRE(self_child("test_sanitize_ub", mode, NULL, &st, out,
	                   sizeof(out)) == 0);
	CHECK(!(WIFEXITED(st) && WEXITSTATUS(st) == 0));
	CHECK(strstr(out, "survived") == NULL);
	CHECK(strstr(out, fn) != NULL);
	CHECK(strstr(out, "test_sanitize_ub.c:") != NULL);
	if (!strstr(out, fn) || !strstr(out, "test_sanitize_ub.c:")) {
		fprintf(stderr, "  %s: the child's output:\n%s\n", mode, out);
	}
}

static void signed_overflow_stops(void)
{
	stops_and_says_where("overflow", "ub_overflow");
}

static void a_shift_past_the_width_stops(void)
{
	stops_and_says_where("shift", "ub_shift");
}

static void an_index_past_the_end_stops(void)
{
	stops_and_says_where("index", "ub_index");
}

static void defined_code_runs_on(void)
{
	int st = 0;
	REQUIRE(self_child("test_sanitize_ub", "none", NULL, &st, out,
	                   sizeof(out)) == 0);
	CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0);
	CHECK(strstr(out, "survived 0") != NULL);
	CHECK(strstr(out, "ERROR") == NULL &&
	      strstr(out, "runtime error") == NULL);
}

static const struct bc_test tests[] = {
    {"signed_overflow_stops", signed_overflow_stops},
    {"a_shift_past_the_width_stops", a_shift_past_the_width_stops},
    {"an_index_past_the_end_stops", an_index_past_the_end_stops},
    {"defined_code_runs_on", defined_code_runs_on},
};

int main(int argc, char **argv)
{
	if (argc == 3 && strcmp(argv[1], "--child") == 0) {
		return child(argv[2]);
	}
	return bc_test_run(tests, sizeof(tests) / sizeof(tests[0]), argc, argv);
}
