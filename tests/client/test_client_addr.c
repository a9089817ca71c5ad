/*
 * Server address parsing: every accepted form gives the host, port or path
 * it names, and every malformed one is refused with a reason, leaving the
 * output zeroed.
 */
#include <string.h>

#include "blobcast/client.h"
#include "test.h"

static void parses(const char *s, enum bc_client_addr_kind kind,
                   const char *host_or_path, unsigned port)
{
	struct bc_client_addr a;
	struct bc_errinfo ei = {0};
	int rc = bc_client_addr_parse(s, &a, &ei);
	if (rc != 0) {
		fprintf(stderr, "  \"%s\": %s\n", s ? s : "(null)", ei.msg);
	}
	CHECK_EQ_INT(rc, 0);
	CHECK_EQ_INT(a.kind, kind);
	if (kind == BC_CLIENT_ADDR_TCP) {
		CHECK_STREQ(a.host, host_or_path);
		CHECK_EQ_INT(a.port, port);
	} else {
		CHECK_STREQ(a.path, host_or_path);
	}
}

static void refuses(const char *s)
{
	struct bc_client_addr a;
	struct bc_errinfo ei = {0};
	memset(&a, 0x55, sizeof(a));
	CHECK_EQ_INT(bc_client_addr_parse(s, &a, &ei), BC_EINVAL);
	CHECK_EQ_INT(ei.code, BC_EINVAL);
	CHECK(ei.msg[0] != '\0');
	CHECK_EQ_INT(a.kind, BC_CLIENT_ADDR_INVALID);
	CHECK_EQ_INT(a.port, 0);
}

static void test_defaults_fill_missing_parts(void)
{
	parses(NULL, BC_CLIENT_ADDR_TCP, "127.0.0.1", 7878);
	parses("", BC_CLIENT_ADDR_TCP, "127.0.0.1", 7878);
	parses("example.org", BC_CLIENT_ADDR_TCP, "example.org", 7878);
	parses(":9000", BC_CLIENT_ADDR_TCP, "127.0.0.1", 9000);
}

static void test_host_and_port_forms(void)
{
	parses("127.0.0.1:7878", BC_CLIENT_ADDR_TCP, "127.0.0.1", 7878);
	parses("render-1.lab:1", BC_CLIENT_ADDR_TCP, "render-1.lab", 1);
	parses("localhost:65535", BC_CLIENT_ADDR_TCP, "localhost", 65535);
	parses("[::1]:8000", BC_CLIENT_ADDR_TCP, "::1", 8000);
	parses("[fe80::1%eth0]", BC_CLIENT_ADDR_TCP, "fe80::1%eth0", 7878);
}

static void test_unix_paths(void)
{
	char longest[5 + BC_CLIENT_MAX_UNIX_PATH + 1];
	parses("unix:/run/blobcast.sock", BC_CLIENT_ADDR_UNIX,
	       "/run/blobcast.sock", 0);
	parses("unix:relative.sock", BC_CLIENT_ADDR_UNIX, "relative.sock", 0);
	memcpy(longest, "unix:", 5);
	memset(longest + 5, 'a', BC_CLIENT_MAX_UNIX_PATH);
	longest[5 + BC_CLIENT_MAX_UNIX_PATH] = '\0';
	parses(longest, BC_CLIENT_ADDR_UNIX, longest + 5, 0);
}

static void test_bad_ports_are_refused(void)
{
	refuses("host:0");
	refuses("host:65536");
	refuses("host:123456");
	refuses("host:");
	refuses("host:80x");
	refuses("host:-1");
	refuses("host: 80");
	refuses("[::1]:");
	refuses("[::1]:99999");
}

static void test_bad_hosts_are_refused(void)
{
	char big[BC_CLIENT_MAX_HOST + 8];
	refuses("::1"); /* bare IPv6: ambiguous with a port */
	refuses("a:b:c");
	refuses("[::1"); /* unclosed bracket */
	refuses("[::1]x");
	refuses("[]:80");
	refuses("ho st:80");
	refuses("host/x:80");
	refuses("unix:"); /* no path */
	memset(big, 'h', sizeof(big) - 1);
	big[sizeof(big) - 1] = '\0';
	refuses(big);
}

static void test_unix_path_over_sun_path_is_refused(void)
{
	char over[5 + BC_CLIENT_MAX_UNIX_PATH + 2];
	memcpy(over, "unix:", 5);
	memset(over + 5, 'p', BC_CLIENT_MAX_UNIX_PATH + 1);
	over[sizeof(over) - 1] = '\0';
	refuses(over);
}

static const struct bc_test tests[] = {
    {"defaults_fill_missing_parts", test_defaults_fill_missing_parts},
    {"host_and_port_forms", test_host_and_port_forms},
    {"unix_paths", test_unix_paths},
    {"bad_ports_are_refused", test_bad_ports_are_refused},
    {"bad_hosts_are_refused", test_bad_hosts_are_refused},
    {"unix_path_over_sun_path_is_refused",
     test_unix_path_over_sun_path_is_refused},
};

BC_TEST_MAIN(tests)
