/*
 * Loopback test for peer and listener addresses (see addr.h). A listener
 * on :: takes IPv4 clients too, and they arrive as v4-mapped IPv6
 * addresses, so 127.0.0.1 must be recognized in that form as well.
 */
#include "addr.h"

#include <netinet/in.h>
#include <stdint.h>
#include <string.h>

bool bc_addr_is_loopback(const struct sockaddr *sa)
{
	if (!sa) {
		return false;
	}
	if (sa->sa_family == AF_INET) {
		struct sockaddr_in in;
		const uint8_t *b = (const uint8_t *)&in.sin_addr.s_addr;
		/* Copied, not cast: the caller's storage may be any struct. */
		memcpy(&in, sa, sizeof(in));
		return b[0] == 127;
	}
	if (sa->sa_family == AF_INET6) {
		static const uint8_t lo[16] = {[15] = 1};
		static const uint8_t mapped[12] = {[10] = 0xff, [11] = 0xff};
		struct sockaddr_in6 in6;
		const uint8_t *b;
		memcpy(&in6, sa, sizeof(in6));
		b = in6.sin6_addr.s6_addr;
		return memcmp(b, lo, 16) == 0 ||
		       (memcmp(b, mapped, 12) == 0 && b[12] == 127);
	}
	return false;
}
