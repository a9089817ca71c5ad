/*
 * The options every program of a sanitizer build (BLOBCAST_SANITIZE)
 * starts with; ASAN_OPTIONS in the environment is read after them and wins
 * where both name an option. The top-level CMakeLists.txt compiles this
 * file into each executable of such a build, and only there.
 *
 * intercept_tls_get_addr=0: AddressSanitizer's interceptor of
 * __tls_get_addr records the threads' dynamic TLS blocks, and
 * LeakSanitizer's exit-time tracer then crashed reading them ("Tracer caught
 * signal 11", a fault of the sanitizer runtime GCC 12 ships) in a process
 * that had opened a library with dynamic TLS by dlopen while other threads
 * were alive: libLLVM (the one library of Mesa's stack whose TLS is not
 * static), which Mesa's drivers and libOSMesa open. Without the
 * interceptor those blocks are ordinary heap blocks that glibc allocates
 * for the threads that use them. The gl backend's tests pass with no
 * report, and a real leak is still reported; tests/base/
 * test_sanitize_dtls.c checks both on a library of its own, where the
 * tracer crashed every time without this option. Before it, sanitizer
 * builds linked libOSMesa so that libLLVM's TLS was static, and paid about
 * 90 ms of libLLVM's relocation at every start of every program.
 *
 * handle_sigill=1: UBSan's checks trap with an illegal instruction
 * (BLOBCAST_UBSAN_TRAP, the default of sanitizer builds); with this option
 * AddressSanitizer reports the trap with the stack, whose first frame is
 * the file and line of the check that failed, instead of the bare signal.
 */
const char *__asan_default_options(void);

const char *__asan_default_options(void)
{
	return "intercept_tls_get_addr=0:handle_sigill=1";
}
