#!/bin/sh
# Big scenes in one daemon, one session after another, each watched by a
# member at 1024x768 (its render copy and lists made): with
# --scene-memory MIB the load that would pass it is refused (ELIMIT) while
# the sessions holding the memory are watched, and goes in once one is
# left (that session unloaded for it); without the option every load goes
# in. Prints per session the load's outcome and seconds and the daemon's
# VmRSS and VmHWM (MiB) once its first frame has come.
#
#   bench/bench_scene_memory.sh SCENE BUILD_DIR SESSIONS [MIB]
#
# SCENE: a scene file (`blobcast scene --out F --binary` of a million
# spheres); SESSIONS: how many to load (e.g. 4); MIB: the daemon's
# --scene-memory (none: its default, half the machine's memory).
set -eu
# shellcheck source=bench/daemon.sh
. "$(dirname "$0")/daemon.sh"
if [ $# -lt 3 ] || [ ! -s "$1" ]; then
	echo "usage: bench_scene_memory.sh SCENE BUILD_DIR SESSIONS [MIB]" >&2
	exit 2
fi
scene=$1 b=$2 n=$3
cap=${4:+--scene-memory $4}
cli=$b/client/blobcast
dir=$(mktemp -d /tmp/bc-scene-memory.XXXXXX)
pid=
watchers=
cleanup() {
	for w in $watchers; do kill "$w" 2>/dev/null || true; done
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT INT TERM
# shellcheck disable=SC2086 # $cap is one option and its value, or nothing
bench_daemon_start bench_scene_memory "$b/server/blobcastd" "$dir/sock" \
	"$dir/data" "$dir/daemon.log" $cap
grep 'scenes: at most' "$dir/daemon.log"
mem() {
	awk '/^VmHWM/ {h = $2} /^VmRSS/ {r = $2}
		END {printf "VmRSS %d MiB, VmHWM %d MiB", r / 1024, h / 1024}' \
		"/proc/$pid/status"
}
# load K: loads SCENE into session sK; prints the outcome.
load() {
	t0=$(date +%s.%N)
	if "$cli" --server "unix:$dir/sock" --timeout 600000 load "$scene" \
		--session "s$1" >"$dir/out" 2>&1; then
		what=loaded
	else
		what="refused: $(tr "\n" " " <"$dir/out")"
	fi
	t1=$(date +%s.%N)
	echo "s$1: $what ($(echo "$t0 $t1" | awk '{printf "%.1f", $2 - $1}') s)"
}
# watch K: a member of sK with a view until the end; returns after its
# first frame.
watch() {
	"$cli" --server "unix:$dir/sock" --timeout 600000 watch --session "s$1" \
		--size 1024x768 >"$dir/watch$1" 2>&1 &
	watchers="$watchers $!"
	until grep -q '^frame' "$dir/watch$1"; do
		if ! kill -0 "$!" 2>/dev/null; then
			echo "s$1: no watcher: $(cat "$dir/watch$1")"
			return
		fi
		sleep 0.2
	done
}
k=0
while [ $k -lt "$n" ]; do
	k=$((k + 1))
	load $k
	if [ "$what" = loaded ]; then
		watch $k
		echo "  watched: $(mem)"
	fi
done
# The first watcher leaves: the last session's load goes in now when it
# was refused.
if [ "$what" != loaded ]; then
	first=${watchers# }
	first=${first%% *}
	kill "$first"
	wait "$first" 2>/dev/null || true
	sleep 1
	load "$n"
	watch "$n"
	echo "  watched: $(mem)"
	grep -c 'unloaded (its memory is needed)' "$dir/daemon.log" |
		sed 's/^/sessions unloaded for room: /'
fi
