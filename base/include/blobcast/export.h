/*
 * BC_API marks the functions libblobcast exports. The library is built with
 * hidden visibility, so a function without the mark stays internal to it
 * (the bc__* helpers, the test hooks, modules the client does not install)
 * and the shared library's symbol table is exactly its documented API.
 * Inside static archives and the daemon the mark changes nothing. A build
 * may define BC_API itself (tests/client/test_client_exports.sh does, to
 * see which declarations carry it).
 */
#ifndef BLOBCAST_EXPORT_H
#define BLOBCAST_EXPORT_H

#ifndef BC_API
#if defined(__GNUC__) || defined(__clang__)
#define BC_API __attribute__((visibility("default")))
#else
#define BC_API
#endif
#endif

#endif
