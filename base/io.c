#include "blobcast/io.h"

#include <errno.h>
#include <stdint.h>
#include <unistd.h>

/* write(2) or read(2) until len bytes went, retrying short transfers and
 * EINTR; a transfer of nothing (a full disk, the end of a file) is EIO. */
static bool transfer_all(int fd, char *b, size_t len, bool writing)
{
	while (len > 0) {
		ssize_t n = writing ? write(fd, b, len) : read(fd, b, len);
		if (n < 0 && errno == EINTR) {
			continue;
		}
		if (n <= 0) {
			if (n == 0) {
				errno = EIO;
			}
			return false;
		}
		b += n;
		len -= (size_t)n;
	}
	return true;
}

bool bc_write_all(int fd, const void *p, size_t len)
{
	/* transfer_all only reads from b when writing. */
	return transfer_all(fd, (char *)(uintptr_t)p, len, true);
}

bool bc_read_all(int fd, void *p, size_t len)
{
	return transfer_all(fd, p, len, false);
}
