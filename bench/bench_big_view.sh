#!/bin/sh
# A big view: a million smooth fig18 spheres at 3840x2160, whose 23.6
# million pairs of tile and primitive rectangle pass the tiled
# A-buffer's limit (2^24) and were drawn in bands, until the tiles'
# candidates were the pairs their cones keep (11.8 million: it fits at
# once now; a bigger $BC_SIZE or scene bands). Through `blobcast render`
# (local) and through blobcastd (a SNAPSHOT of the view, twice, and a
# drag of one sphere in a view of that size), with one or more builds
# side by side so that each row of one build is measured next to the
# others'.
#
#   bench/bench_big_view.sh BUILD_DIR [BUILD_DIR ...]
#
# Release builds (ASan would measure the sanitizer). The scene is made
# once with the first build's `blobcast gen` and kept in
# $BC_BIG_SCENE (default /tmp/bc-fig18-1m.json, 166 MB). $BC_SIZE sets
# the view (default 3840x2160), $BC_EDITS the drag's edits (default 20).
# Prints one line per measurement; a step that fails prints its error
# and the script goes on to the next.
set -u
[ $# -ge 1 ] || {
	echo "usage: bench/bench_big_view.sh BUILD_DIR [BUILD_DIR ...]" >&2
	exit 2
}
# shellcheck source=bench/big_scene.sh
. "$(dirname "$0")/big_scene.sh"
big_scene_prepare bench_big_view "$1"
size=${BC_SIZE:-3840x2160}
edits=${BC_EDITS:-20}
dir=$(mktemp -d /tmp/bc-bigview.XXXXXX)
pid=
cleanup() {
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT INT TERM

echo "$(lscpu | sed -n 's/^Model name: *//p'), load average $(cut -d' ' -f1-3 /proc/loadavg)"
for build in "$@"; do
	cli=$build/client/blobcast
	daemon=$build/server/blobcastd
	echo "== $build ($(git -C "$build/.." rev-parse --short HEAD 2>/dev/null || echo '?'))"
	/usr/bin/time -f '%e %M' -o "$dir/time" "$cli" render "$scene" \
		--size "$size" --stats --quiet --out "$dir/local.png" \
		2>"$dir/err"
	read -r wall kb <"$dir/time"
	echo "render (local): $(grep -o 'total [0-9.]* ms, a-buffer [0-9.]* ms' "$dir/err"), $(grep -o '[0-9]* bands*' "$dir/err"), ${wall} s with the scene's load, peak $((kb / 1024)) MiB"
	grep -v '^render:' "$dir/err"

	rm -rf "$dir/data" "$dir/sock"
	"$daemon" --listen none --unix "$dir/sock" --data "$dir/data" \
		2>"$dir/daemon.log" &
	pid=$!
	i=0
	until [ -S "$dir/sock" ]; do
		i=$((i + 1))
		[ $i -gt 400 ] && break
		sleep 0.05
	done
	"$cli" --server "unix:$dir/sock" --timeout 0 load --session big \
		"$scene" >/dev/null
	for n in 1 2; do
		if /usr/bin/time -f '%e' -o "$dir/time" "$cli" --server \
			"unix:$dir/sock" --timeout 0 snapshot --session big \
			--size "$size" --out "$dir/snap.png" >"$dir/out" 2>"$dir/err"; then
			same=different
			idiff "$dir/snap.png" "$dir/local.png" >/dev/null 2>&1 &&
				same="the same pixels as the local render"
			echo "snapshot $n: $(cat "$dir/time") s, $same"
		else
			echo "snapshot $n: failed: $(tail -1 "$dir/err")"
		fi
	done
	"$cli" --server "unix:$dir/sock" --timeout 0 bench-latency \
		--session big --edits "$edits" --size "$size" --interacting \
		2>"$dir/err" | sed 's/^/drag: /' || true
	grep -i 'error\|elimit' "$dir/err" | tail -1
	echo "daemon peak: $(awk '/^VmHWM/ {print int($2 / 1024)}' "/proc/$pid/status") MiB"
	kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	pid=
done
