/*
 * Which peers count as loopback (server/addr.c): IPv4 127/8, ::1, and IPv4
 * loopback as a listener on :: sees it, v4-mapped ::ffff:127.x.y.z.
 */
#include <arpa/inet.h>
#include <netinet/in.h>

#include "addr.h"
#include "test.h"

static bool v4(const char *text)
{
	struct sockaddr_in in = {.sin_family = AF_INET};
	if (inet_pton(AF_INET, text, &in.sin_addr) != 1) {
		fprintf(stderr, "  bad test address %s\n", text);
		return false;
	}
	return bc_addr_is_loopback((const struct sockaddr *)&in);
}

static bool v6(const char *text)
{
	/* Through sockaddr_storage, as accept() and getpeername() give. */
	struct sockaddr_storage ss = {0};
	struct sockaddr_in6 in6 = {.sin6_family = AF_INET6};
	if (inet_pton(AF_INET6, text, &in6.sin6_addr) != 1) {
		fprintf(stderr, "  bad test address %s\n", text);
		return false;
	}
	memcpy(&ss, &in6, sizeof(in6));
	return bc_addr_is_loopback((const struct sockaddr *)&ss);
}

static void ipv4_loopback_is_the_whole_127_network(void)
{
	CHECK(v4("127.0.0.1"));
	CHECK(v4("127.255.255.254"));
	CHECK(v4("127.1.2.3"));
	CHECK(!v4("0.0.0.0"));
	CHECK(!v4("128.0.0.1"));
	CHECK(!v4("126.255.255.255"));
	CHECK(!v4("10.0.0.127"));
	CHECK(!v4("192.168.1.1"));
}

static void ipv6_loopback_is_only_double_colon_one(void)
{
	CHECK(v6("::1"));
	CHECK(!v6("::"));
	CHECK(!v6("::2"));
	CHECK(!v6("fe80::1"));
	CHECK(!v6("2001:db8::1"));
	/* IPv4-compatible (deprecated) ::127.0.0.1 is not a mapped address. */
	CHECK(!v6("::127.0.0.1"));
}

/* A listener on [::] sees 127.0.0.1 as ::ffff:127.0.0.1. */
static void v4_mapped_loopback_is_loopback(void)
{
	CHECK(v6("::ffff:127.0.0.1"));
	CHECK(v6("::ffff:127.9.8.7"));
	CHECK(!v6("::ffff:10.0.0.1"));
	CHECK(!v6("::ffff:0.0.0.0"));
	CHECK(!v6("::fffe:127.0.0.1"));
	CHECK(!v6("64:ff9b::127.0.0.1"));
}

static void other_families_are_not_loopback(void)
{
	struct sockaddr_storage ss = {0};
	ss.ss_family = AF_UNIX;
	CHECK(!bc_addr_is_loopback((const struct sockaddr *)&ss));
	ss.ss_family = AF_UNSPEC;
	CHECK(!bc_addr_is_loopback((const struct sockaddr *)&ss));
	CHECK(!bc_addr_is_loopback(NULL));
}

static const struct bc_test tests[] = {
    {"ipv4_loopback_is_the_whole_127_network",
     ipv4_loopback_is_the_whole_127_network},
    {"ipv6_loopback_is_only_double_colon_one",
     ipv6_loopback_is_only_double_colon_one},
    {"v4_mapped_loopback_is_loopback", v4_mapped_loopback_is_loopback},
    {"other_families_are_not_loopback", other_families_are_not_loopback},
};
BC_TEST_MAIN(tests)
