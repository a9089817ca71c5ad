#!/bin/sh
# A big snapshot end to end: blobcastd on its embedded default scene and
# `blobcast snapshot --size SIZE` through it (in tiles over the daemon's
# max_dim, 4096), timed, with the peak resident memory of the client
# (GNU time) and of the daemon (VmHWM, read before it stops; a fresh
# daemon per size, and its peak after start-up alone for comparison).
#
#   bench/bench_big_snapshot.sh [BUILD_DIR] [SIZE ...]
#
# BUILD_DIR defaults to build-rel (a Release build: ASan would measure the
# sanitizer); SIZEs default to 2048 4096 4096:1024 8192 (square; :T asks
# for tiles of T even where one snapshot would do). Extra daemon
# options come from $BC_DAEMON_OPTS (e.g. "--backend gl"). Prints one
# Markdown table row per size.
set -eu
build=${1:-build-rel}
[ $# -gt 0 ] && shift
sizes=${*:-2048 4096 4096:1024 8192}
daemon=$build/server/blobcastd
cli=$build/client/blobcast
for f in "$daemon" "$cli"; do
	if [ ! -x "$f" ]; then
		echo "bench_big_snapshot: $f is not built (cmake --build $build)" >&2
		exit 1
	fi
done
if [ ! -x /usr/bin/time ]; then
	echo "bench_big_snapshot: /usr/bin/time is missing (apt install time)" >&2
	exit 1
fi
# shellcheck source=bench/daemon.sh
. "$(dirname "$0")/daemon.sh"
dir=$(mktemp -d /tmp/bc-bigsnap.XXXXXX)
pid=
cleanup() {
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT INT TERM

start_daemon() {
	rm -rf "$dir/data"
	# shellcheck disable=SC2086
	bench_daemon_start bench_big_snapshot "$daemon" "$dir/sock" \
		"$dir/data" "$dir/daemon.log" ${BC_DAEMON_OPTS:-}
}
stop_daemon() {
	kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	pid=
}
hwm() { awk '/^VmHWM/ {print int($2 / 1024)}' "/proc/$pid/status"; }

# One daemon per size, so that each peak is that picture's.
start_daemon
echo "daemon peak after start-up: $(hwm) MiB ($(sed -n 's/^blobcastd: backend \([a-z]*\).*/\1/p' "$dir/daemon.log") backend)"
stop_daemon
echo "| size | tiles | wall s | client peak MiB | daemon peak MiB | bytes from the server |"
echo "|---:|---:|---:|---:|---:|---:|"
for spec in $sizes; do
	s=${spec%%:*}
	tile=
	[ "$spec" != "$s" ] && tile="--tile ${spec#*:}"
	start_daemon
	# shellcheck disable=SC2086
	/usr/bin/time -f '%e %M' -o "$dir/time" "$cli" snapshot \
		--server "unix:$dir/sock" --session default --size "${s}x${s}" \
		--timeout 600000 $tile --out "$dir/out.png" >"$dir/out" \
		2>"$dir/err" || {
		echo "bench_big_snapshot: snapshot at $spec failed:" >&2
		cat "$dir/err" >&2
		exit 1
	}
	tiles=$(sed -n 's/.*tile [0-9]* of \([0-9]*\).*/\1/p' "$dir/err" | tail -1)
	bytes=$(sed -n 's/.*order [0-9]*, \([0-9]*\) bytes.*/\1/p' "$dir/out")
	read -r wall kb <"$dir/time"
	echo "| ${s}²${tile:+ ($tile)} | ${tiles:-1} | $wall | $((kb / 1024)) | $(hwm) | $bytes |"
	stop_daemon
done
