#!/bin/sh
# A big scene loaded into a session nobody views, side by side: for each
# BUILD_DIR, a fresh blobcastd (its own data directory) takes `blobcast
# load SCENE --session big` from a client without a view, REPS times, the
# builds taking turns. Prints per run the load's wall seconds and the
# daemon's VmHWM and VmRSS (MiB) three seconds after it was acknowledged
# (the load's snapshot written).
#
#   bench/bench_load_unviewed.sh SCENE BUILD_DIR [BUILD_DIR...] [-- REPS]
#
# SCENE: a scene file (`blobcast scene --out F --binary` of a million
# spheres, or big_scene.sh's JSON); REPS defaults to 2.
set -eu
# shellcheck source=bench/daemon.sh
. "$(dirname "$0")/daemon.sh"
scene=$1
shift
builds=
reps=2
while [ $# -gt 0 ]; do
	if [ "$1" = -- ]; then
		reps=$2
		break
	fi
	builds="$builds $1"
	shift
done
if [ -z "$builds" ] || [ ! -s "$scene" ]; then
	echo "usage: bench_load_unviewed.sh SCENE BUILD_DIR... [-- REPS]" >&2
	exit 2
fi
dir=$(mktemp -d /tmp/bc-load-unviewed.XXXXXX)
pid=
cleanup() {
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT INT TERM
r=0
while [ $r -lt "$reps" ]; do
	r=$((r + 1))
	for b in $builds; do
		rm -rf "$dir/data"
		bench_daemon_start bench_load_unviewed "$b/server/blobcastd" \
			"$dir/sock" "$dir/data" "$dir/daemon.log"
		t0=$(date +%s.%N)
		"$b/client/blobcast" --server "unix:$dir/sock" --timeout 600000 \
			load "$scene" --session big >/dev/null
		t1=$(date +%s.%N)
		sleep 3
		echo "$b: load $(echo "$t0 $t1" | awk '{printf "%.2f", $2 - $1}') s," \
			"VmHWM VmRSS MiB $(awk '/^VmHWM/ {h = $2} /^VmRSS/ {r = $2}
			END {print int(h / 1024), int(r / 1024)}' "/proc/$pid/status")"
		kill "$pid"
		wait "$pid" 2>/dev/null || true
		pid=
	done
done
