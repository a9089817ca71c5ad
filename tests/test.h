/*
 * The in-tree test runner: a test file lists its tests in a table and ends
 * with BC_TEST_MAIN(table). Each test executable is one ctest entry; it runs
 * every test (or those named on the command line), prints one line per test
 * and exits 1 if any failed, 77 if every test asked to be skipped.
 */
#ifndef BLOBCAST_TESTS_TEST_H
#define BLOBCAST_TESTS_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct bc_test {
	const char *name;
	void (*fn)(void);
};

/* Failures in the running test; a test that calls BC_SKIP() is skipped. */
static int bc_test_failures;
static int bc_test_skipped;

#define CHECK(cond)                                                            \
	do {                                                                   \
		if (!(cond)) {                                                 \
			fprintf(stderr, "  %s:%d: CHECK failed: %s\n",         \
			        __FILE__, __LINE__, #cond);                    \
			bc_test_failures++;                                    \
		}                                                              \
	} while (0)

/* Like CHECK but ends the test on failure. */
#define REQUIRE(cond)                                                          \
	do {                                                                   \
		if (!(cond)) {                                                 \
			fprintf(stderr, "  %s:%d: REQUIRE failed: %s\n",       \
			        __FILE__, __LINE__, #cond);                    \
			bc_test_failures++;                                    \
			return;                                                \
		}                                                              \
	} while (0)

#define CHECK_EQ_INT(a, b)                                                     \
	do {                                                                   \
		long long va_ = (long long)(a), vb_ = (long long)(b);          \
		if (va_ != vb_) {                                              \
			fprintf(stderr,                                        \
			        "  %s:%d: %s == %s failed: %lld vs %lld\n",    \
			        __FILE__, __LINE__, #a, #b, va_, vb_);         \
			bc_test_failures++;                                    \
		}                                                              \
	} while (0)

#define CHECK_NEAR(a, b, tol)                                                  \
	do {                                                                   \
		double va_ = (double)(a), vb_ = (double)(b);                   \
		if (!(fabs(va_ - vb_) <= (double)(tol))) {                     \
			fprintf(                                               \
			    stderr,                                            \
			    "  %s:%d: |%s - %s| <= %s failed: %.9g vs %.9g\n", \
			    __FILE__, __LINE__, #a, #b, #tol, va_, vb_);       \
			bc_test_failures++;                                    \
		}                                                              \
	} while (0)

/* Prints label and s on stderr, quoted, control and non-ASCII bytes as \xNN,
 * cut after BC_TEST_SHOW bytes (with the full length then), NULL as NULL. */
#define BC_TEST_SHOW 160
static inline void bc_test_show_str(const char *label, const char *s)
{
	if (!s) {
		fprintf(stderr, "    %s: NULL\n", label);
		return;
	}
	size_t len = strlen(s);
	fprintf(stderr, "    %s: \"", label);
	for (size_t i = 0; i < len && i < BC_TEST_SHOW; i++) {
		unsigned char c = (unsigned char)s[i];
		if (c == '"' || c == '\\') {
			fprintf(stderr, "\\%c", c);
		} else if (c < 0x20 || c >= 0x7f) {
			fprintf(stderr, "\\x%02x", c);
		} else {
			fputc(c, stderr);
		}
	}
	if (len > BC_TEST_SHOW) {
		fprintf(stderr, "\"... (%zu bytes)\n", len);
	} else {
		fprintf(stderr, "\"\n");
	}
}

/* Returns 1 when a and b are equal strings (both NULL counts as equal);
 * otherwise prints both with the check's text and returns 0. */
static inline int bc_test_streq(const char *a, const char *b, const char *ea,
                                const char *eb, const char *file, int line)
{
	if ((!a && !b) || (a && b && strcmp(a, b) == 0)) {
		return 1;
	}
	fprintf(stderr, "  %s:%d: %s == %s failed:\n", file, line, ea, eb);
	bc_test_show_str(ea, a);
	bc_test_show_str(eb, b);
	return 0;
}

/* Whether the file at path holds needle in its first 64 KiB (a log, say). */
static inline int bc_test_file_has(const char *path, const char *needle)
{
	static char buf[1 << 16];
	FILE *f = fopen(path, "r");
	size_t n = f ? fread(buf, 1, sizeof(buf) - 1, f) : 0;
	if (f) {
		fclose(f);
	}
	buf[n] = '\0';
	return strstr(buf, needle) != NULL;
}

/* Returns 1 when the n bytes at a and b are equal; otherwise prints the
 * first differing offset and up to 16 bytes of each from 8 before it. */
static inline int bc_test_memeq(const void *a, const void *b, size_t n,
                                const char *ea, const char *eb,
                                const char *file, int line)
{
	const unsigned char *pa = a, *pb = b;
	if (n == 0 || memcmp(pa, pb, n) == 0) {
		return 1;
	}
	size_t at = 0;
	while (pa[at] == pb[at]) {
		at++;
	}
	size_t from = at > 8 ? at - 8 : 0;
	size_t to = from + 16 < n ? from + 16 : n;
	fprintf(stderr,
	        "  %s:%d: %s == %s (%zu bytes) failed: first difference at "
	        "byte %zu\n",
	        file, line, ea, eb, n, at);
	const unsigned char *sides[2] = {pa, pb};
	const char *names[2] = {ea, eb};
	for (int s = 0; s < 2; s++) {
		fprintf(stderr, "    %s [%zu..%zu):", names[s], from, to);
		for (size_t i = from; i < to; i++) {
			fprintf(stderr, i == at ? " [%02x]" : " %02x",
			        sides[s][i]);
		}
		fprintf(stderr, "\n");
	}
	return 0;
}

/* String equality (strcmp) that prints both strings on failure. */
#define CHECK_STREQ(a, b)                                                      \
	do {                                                                   \
		if (!bc_test_streq((a), (b), #a, #b, __FILE__, __LINE__)) {    \
			bc_test_failures++;                                    \
		}                                                              \
	} while (0)

/* Equality of n bytes (memcmp) that prints where they first differ. */
#define CHECK_MEMEQ(a, b, n)                                                   \
	do {                                                                   \
		if (!bc_test_memeq((a), (b), (n), #a, #b, __FILE__,            \
		                   __LINE__)) {                                \
			bc_test_failures++;                                    \
		}                                                              \
	} while (0)

#define BC_SKIP(why)                                                           \
	do {                                                                   \
		fprintf(stderr, "  skipped: %s\n", why);                       \
		bc_test_skipped = 1;                                           \
		return;                                                        \
	} while (0)

static int bc_test_selected(int argc, char **argv, const char *name)
{
	if (argc < 2) {
		return 1;
	}
	for (int i = 1; i < argc; i++) {
		if (strcmp(argv[i], name) == 0) {
			return 1;
		}
	}
	return 0;
}

static int bc_test_run(const struct bc_test *tests, size_t n, int argc,
                       char **argv)
{
	int failed = 0, skipped = 0, ran = 0;
	for (size_t i = 0; i < n; i++) {
		if (!bc_test_selected(argc, argv, tests[i].name)) {
			continue;
		}
		bc_test_failures = 0;
		bc_test_skipped = 0;
		tests[i].fn();
		ran++;
		if (bc_test_failures) {
			failed++;
			printf("FAIL %s\n", tests[i].name);
		} else if (bc_test_skipped) {
			skipped++;
			printf("skip %s\n", tests[i].name);
		} else {
			printf("ok   %s\n", tests[i].name);
		}
	}
	printf("%d passed, %d failed, %d skipped\n", ran - failed - skipped,
	       failed, skipped);
	if (failed) {
		return 1;
	}
	return (ran > 0 && skipped == ran) ? 77 : 0;
}

#define BC_TEST_MAIN(table)                                                    \
	int main(int argc, char **argv)                                        \
	{                                                                      \
		return bc_test_run(table, sizeof(table) / sizeof(table[0]),    \
		                   argc, argv);                                \
	}

#endif
