/*
 * Runs the test program itself as a child ("PROG --child MODE") and brings
 * back how it ended and what it wrote: for the checks of what the
 * sanitizer runtimes do to a whole process (a crash, a report at exit).
 */
#ifndef BLOBCAST_TESTS_SELF_CHILD_H
#define BLOBCAST_TESTS_SELF_CHILD_H

#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

/* Runs /proc/self/exe as name with "--child mode"; *status and its
 * standard output and error together (NUL-terminated, at most cap - 1
 * bytes) come back in out. asan_options, when not NULL, replaces the
 * environment's ASAN_OPTIONS (and LSAN_OPTIONS goes). 0, or -1 when the
 * child could not be run. */
static inline int self_child(const char *name, const char *mode,
                             const char *asan_options, int *status, char *out,
                             size_t cap)
{
	char path[] = "/tmp/bc-self-child.XXXXXX";
	int fd = mkstemp(path);
	pid_t pid;
	ssize_t n;
	if (fd < 0) {
		return -1;
	}
	unlink(path);
	fflush(stdout);
	fflush(stderr);
	pid = fork();
	if (pid == 0) {
		dup2(fd, 1);
		dup2(fd, 2);
		if (asan_options) {
			setenv("ASAN_OPTIONS", asan_options, 1);
			unsetenv("LSAN_OPTIONS");
		}
		execl("/proc/self/exe", name, "--child", mode, (char *)NULL);
		_exit(127);
	}
	if (pid < 0 || waitpid(pid, status, 0) != pid) {
		close(fd);
		return -1;
	}
	n = pread(fd, out, cap - 1, 0);
	out[n > 0 ? n : 0] = '\0';
	close(fd);
	return 0;
}

#endif
