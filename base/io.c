#include "blobcast/io.h"

#include <errno.h>
#include <unistd.h>

bool bc_write_all(int fd, const void *p, size_t len)
{
	const char *b = p;
	while (len > 0) {
		ssize_t n = write(fd, b, len);
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

bool bc_read_all(int fd, void *p, size_t len)
{
	char *b = p;
	while (len > 0) {
		ssize_t n = read(fd, b, len);
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
