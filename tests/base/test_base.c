/* Tests of the shared base: error table, allocation hook, logger. */
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <string.h>
#include <sys/resource.h>

#include "blobcast/alloc.h"
#include "blobcast/error.h"
#include "blobcast/log.h"
#include "test.h"

static void error_table_names_every_code(void)
{
	CHECK_STREQ(bc_err_name(BC_ENOMEM), "ENOMEM");
	/* Error 0 is NONE, never OK: OK is message type 6 (PROTOCOL.md 10). */
	CHECK_STREQ(bc_err_name(0), "NONE");
	CHECK(BC_NONE == 0);
	CHECK_STREQ(bc_strerror(BC_ENOMEM), "out of memory");
	CHECK_STREQ(bc_err_name(-9999), "UNKNOWN");
	for (int i = 0; i < BC_ERR_COUNT; i++) {
		CHECK(strcmp(bc_err_name(-i), "UNKNOWN") != 0);
	}
	CHECK_STREQ(bc_err_name(-BC_ERR_COUNT), "UNKNOWN");
}

static void alloc_hook_fails_the_nth_call(void)
{
	bc_alloc_fail_after(2);
	void *a = bc_malloc(8);
	void *b = bc_malloc(8);
	CHECK(a != NULL);
	CHECK(b == NULL);
	CHECK(bc_alloc_fail_after(0) == 2);
	bc_free(a);
	CHECK(bc_calloc((size_t)-1, 16) == NULL);
}

/* bc_malloc_lines gives whole cache lines, writable to the end, freed by
 * bc_free, and the failure hook counts it like any allocation. */
static void malloc_lines_starts_a_line(void)
{
	static const size_t sizes[] = {0, 1, 63, 64, 1000, 3u << 20};
	for (size_t i = 0; i < sizeof(sizes) / sizeof(sizes[0]); i++) {
		unsigned char *p = bc_malloc_lines(sizes[i]);
		REQUIRE(p != NULL);
		CHECK((uintptr_t)p % BC_CACHE_LINE == 0);
		memset(p, 0xab, sizes[i]);
		bc_free(p);
	}
	bc_alloc_fail_after(1);
	CHECK(bc_malloc_lines(64) == NULL);
	CHECK(bc_alloc_fail_after(0) == 1);
}

enum { ALLOC_THREADS = 4, ALLOC_EACH = 50000 };

static void *allocate_many(void *arg)
{
	(void)arg;
	for (int i = 0; i < ALLOC_EACH; i++) {
		bc_free(bc_malloc(16));
	}
	return NULL;
}

/* The hook's counter is shared by every thread (the daemon's workers, a
 * client's reader): concurrent allocations are all counted, none lost. */
static void alloc_hook_counts_every_thread(void)
{
	pthread_t t[ALLOC_THREADS];
	bc_alloc_fail_after(0);
	for (int i = 0; i < ALLOC_THREADS; i++) {
		REQUIRE(pthread_create(&t[i], NULL, allocate_many, NULL) == 0);
	}
	for (int i = 0; i < ALLOC_THREADS; i++) {
		pthread_join(t[i], NULL);
	}
	CHECK_EQ_INT(bc_alloc_fail_after(0), ALLOC_THREADS * ALLOC_EACH);
}

/* The last message a sink received, as it would be written, and how many
 * messages came. */
static char logged[16384];
static int nlogged;

static void capture(enum bc_log_level level, const char *file, int line,
                    const char *fmt, va_list args) BC__PRINTF(4, 0);

static void capture(enum bc_log_level level, const char *file, int line,
                    const char *fmt, va_list args)
{
	(void)level;
	(void)file;
	(void)line;
	vsnprintf(logged, sizeof(logged), fmt, args);
	nlogged++;
}

/* A client name with a newline cannot start a log line of its own: every
 * control character reaches the sink escaped, other bytes (UTF-8) as they
 * are. */
static void log_escapes_control_characters(void)
{
	bc_log_init(BC_LOG_INFO);
	bc_log_set_callback(capture);
	nlogged = 0;
	bc_log(BC_LOG_INFO, "client %u (%s) joined", 7u,
	       "eve\n[warn] [net.c:1] forged");
	CHECK_EQ_INT(nlogged, 1);
	CHECK_STREQ(logged, "client 7 (eve\\n[warn] [net.c:1] forged) joined");
	bc_log(BC_LOG_WARN, "%s", "a\tb\rc\001d\177e\x1b[2J\xc3\xa9\x1f");
	CHECK_STREQ(logged, "a\\tb\\x0dc\\x01d\\x7fe\\x1b[2J\xc3\xa9\\x1f");
	/* The format string's own text is escaped too. */
	bc_log(BC_LOG_WARN, "two\nlines");
	CHECK_STREQ(logged, "two\\nlines");
	/* Dropped below the threshold: the sink sees nothing. */
	nlogged = 0;
	bc_log(BC_LOG_DEBUG, "x\n");
	CHECK_EQ_INT(nlogged, 0);
	bc_log_set_callback(NULL);
}

/* Messages longer than the logger's stack buffer arrive whole, escaped. */
static void log_escapes_long_messages_whole(void)
{
	char big[3001];
	memset(big, '\n', 3000);
	big[3000] = '\0';
	bc_log_init(BC_LOG_INFO);
	bc_log_set_callback(capture);
	bc_log(BC_LOG_ERROR, "<%s>", big);
	bc_log_set_callback(NULL);
	REQUIRE(strlen(logged) == 6002);
	CHECK(logged[0] == '<' && logged[6001] == '>');
	CHECK(strchr(logged, '\n') == NULL);
	CHECK_MEMEQ(logged + 5999, "\\n>", 3);
}

/* bc_log_escape never cuts an escape in half and always ends the string. */
static void log_escape_stops_before_a_partial_escape(void)
{
	char out[8];
	memset(out, 'z', sizeof(out));
	CHECK_EQ_INT(bc_log_escape(out, 5, "ab\001cd", 5), 2);
	CHECK_STREQ(out, "ab");
	CHECK_EQ_INT(bc_log_escape(out, sizeof(out), "ab\001cd", 5), 7);
	CHECK_STREQ(out, "ab\\x01c");
	CHECK_EQ_INT(bc_log_escape(out, sizeof(out), "ab\ncd", 5), 6);
	CHECK_STREQ(out, "ab\\ncd");
	CHECK_EQ_INT(bc_log_escape(out, 1, "abc", 3), 0);
	CHECK(out[0] == '\0');
	/* A NUL byte inside the span is escaped as well. */
	CHECK_EQ_INT(bc_log_escape(out, sizeof(out), "a\0b", 3), 6);
	CHECK_STREQ(out, "a\\x00b");
}

static long minor_faults(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return ru.ru_minflt;
}

/* bc_populate keeps the bytes, refuses small and NULL ranges, and, where
 * the kernel takes it, leaves the first writes of every page without a
 * fault. */
static void populate_backs_pages_and_keeps_bytes(void)
{
	size_t n = 16u << 20, pages = n / 4096u;
	uint8_t *p = bc_malloc(n);
	long before;
	bool took;
	REQUIRE(p);
	CHECK(!bc_populate(NULL, n));
	CHECK(!bc_populate(p, BC_POPULATE_MIN - 1));
	p[0] = 7;
	p[n - 1] = 9;
	took = bc_populate(p + 1, n - 2); /* unaligned ends */
	before = minor_faults();
	for (size_t i = 0; i < n; i += 4096u) {
		p[i] = (uint8_t)(p[i] + 1u);
	}
	p[n - 1]++;
	CHECK_EQ_INT(p[0], 8);
	CHECK_EQ_INT(p[n - 1], 10);
	if (took) {
		/* Not one a page: under ASan its shadow's (one page per
		 * 8 of these) and the unaligned ends fault, nothing else. */
		long faults = minor_faults() - before;
		printf("  %ld faults writing %zu pages after populate\n",
		       faults, pages);
		CHECK(faults < (long)pages / 4);
	} else {
		printf("  this kernel has no MADV_POPULATE_WRITE\n");
	}
	bc_free(p);
}

static const struct bc_test tests[] = {
    {"populate_backs_pages_and_keeps_bytes",
     populate_backs_pages_and_keeps_bytes},
    {"error_table_names_every_code", error_table_names_every_code},
    {"alloc_hook_fails_the_nth_call", alloc_hook_fails_the_nth_call},
    {"malloc_lines_starts_a_line", malloc_lines_starts_a_line},
    {"alloc_hook_counts_every_thread", alloc_hook_counts_every_thread},
    {"log_escapes_control_characters", log_escapes_control_characters},
    {"log_escapes_long_messages_whole", log_escapes_long_messages_whole},
    {"log_escape_stops_before_a_partial_escape",
     log_escape_stops_before_a_partial_escape},
};
BC_TEST_MAIN(tests)
