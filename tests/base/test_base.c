/* Tests of the shared base: error table and allocation hook. */
#include "blobcast/alloc.h"
#include "blobcast/error.h"
#include "test.h"

static void error_table_names_every_code(void)
{
	CHECK(strcmp(bc_err_name(BC_ENOMEM), "ENOMEM") == 0);
	/* Error 0 is NONE, never OK: OK is message type 6 (PROTOCOL.md 10). */
	CHECK(strcmp(bc_err_name(0), "NONE") == 0);
	CHECK(BC_NONE == 0);
	CHECK(strcmp(bc_strerror(BC_ENOMEM), "out of memory") == 0);
	CHECK(strcmp(bc_err_name(-9999), "UNKNOWN") == 0);
	for (int i = 0; i < BC_ERR_COUNT; i++) {
		CHECK(strcmp(bc_err_name(-i), "UNKNOWN") != 0);
	}
	CHECK(strcmp(bc_err_name(-BC_ERR_COUNT), "UNKNOWN") == 0);
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

static const struct bc_test tests[] = {
	{"error_table_names_every_code", error_table_names_every_code},
	{"alloc_hook_fails_the_nth_call", alloc_hook_fails_the_nth_call},
};
BC_TEST_MAIN(tests)
