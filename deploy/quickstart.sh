#!/usr/bin/env bash
# Quick start: installs the Debian dependencies, builds blobcast (Release:
# the daemon, the `blobcast` CLI and the desktop viewer), starts blobcastd on its embedded default scene (session "default",
# 127.0.0.1:7878, data in ./blobcast-data) and fetches a lossless snapshot
# of it through the `blobcast` client into out.png. The daemon is stopped
# afterwards unless --keep is given.
#
# Usage: bash deploy/quickstart.sh [--keep] [WxH] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
keep=0
if [ "${1:-}" = "--keep" ]; then
	keep=1
	shift
fi
size=${1:-800x600}
out=${2:-out.png}
addr=127.0.0.1:7878

bash deploy/install-deps.sh
# build/ uses CMake's default generator, as tests/run.sh does; one made by
# another generator is reconfigured from scratch.
if [ -f build/CMakeCache.txt ] &&
	! grep -q '^CMAKE_GENERATOR:INTERNAL=Unix Makefiles$' build/CMakeCache.txt; then
	rm -rf build/CMakeCache.txt build/CMakeFiles
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
# The viewer too: README "Using it" runs it from build/client/viewer/.
cmake --build build -j "$(nproc)" --target blobcastd blobcast_cli \
	blobcast_view

log=$(mktemp)
./build/server/blobcastd --listen "$addr" --data blobcast-data 2>"$log" &
pid=$!
stop() {
	if [ "$keep" = 0 ] && kill -0 "$pid" 2>/dev/null; then
		kill -TERM "$pid"
		wait "$pid" || true
	fi
	rm -f "$log"
}
trap stop EXIT
for _ in $(seq 1 100); do
	grep -q "listening on" "$log" && break
	if ! kill -0 "$pid" 2>/dev/null; then
		cat "$log" >&2
		echo "quickstart: blobcastd did not start (is $addr in use?)" >&2
		exit 1
	fi
	sleep 0.1
done
./build/client/blobcast --server "$addr" snapshot --session default \
	--size "$size" --out "$out"
echo "quickstart: $out rendered by blobcastd (pid $pid) at $addr"
if [ "$keep" = 1 ]; then
	echo "quickstart: blobcastd keeps running; stop it with: kill $pid"
fi
