#!/bin/sh
# A daemon restarting with a big session, side by side: each
# BUILD_DIR's blobcastd loads a million smooth fig18 spheres
# (big_scene.sh) into session "big" of a data directory of its own and
# stops, leaving the session's snapshot (in the format that build
# writes); then each starts on a copy of its directory REPS times, the
# builds taking turns. It restores every session before it listens. Prints one
# Markdown table row per build: medians of the seconds from start to
# listening, the daemon's peak resident memory (VmHWM) and its resident
# memory a second after it listens (VmRSS), then the seconds `blobcast
# snapshot` takes for the restored session's first picture (1024x768)
# and VmRSS after it.
#
#   bench/bench_restore.sh BUILD_DIR [BUILD_DIR...] [-- REPS]
#
# BUILD_DIRs are Release builds; REPS defaults to 3. $BC_BIG_SCENE: where
# the scene is made once.
set -eu
# shellcheck source=bench/big_scene.sh
. "$(dirname "$0")/big_scene.sh"
# shellcheck source=bench/daemon.sh
. "$(dirname "$0")/daemon.sh"
big_scene_builds bench_restore 3 "$@"
first=${builds%% *}
big_scene_prepare bench_restore "$first"
dir=$(mktemp -d /tmp/bc-restore.XXXXXX)
pid=
cleanup() {
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT INT TERM

# start B DATA: B's daemon on DATA; sets pid and the seconds it took to
# listen in $dir/took.
start() {
	t0=$(date +%s.%N)
	bench_daemon_start bench_restore "$1/server/blobcastd" "$dir/sock" "$2" \
		"$dir/daemon.log"
	t1=$(date +%s.%N)
	echo "$t0 $t1" | awk '{printf "%.2f\n", $2 - $1}' >"$dir/took"
}
stop() {
	kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	pid=
}

# prepare K B: build B's daemon loads the scene into a data directory of
# its own ($dir/dataK, in the snapshot format B writes) and stops.
prepare() {
	start "$2" "$dir/data$1"
	"$2/client/blobcast" --server "unix:$dir/sock" --timeout 600000 \
		load "$scene" --session big >/dev/null
	# The store writes the loaded scene's snapshot (order 1) after the
	# load: restoring should read it, not a journal.
	i=0
	until [ -s "$dir/data$1/sessions/big/snap-1.bin" ] ||
		[ -s "$dir/data$1/sessions/big/snap-1.json" ]; do
		i=$((i + 1))
		if [ $i -gt 600 ]; then
			echo "bench_restore: no snapshot of the session after 60 s" >&2
			exit 1
		fi
		sleep 0.1
	done
	sleep 1
	stop
	echo "bench_restore: $2: the session's files $(du -sm \
		"$dir/data$1/sessions/big" | cut -f1) MiB" >&2
}
k=0
for b in $builds; do
	k=$((k + 1))
	prepare $k "$b"
done

# round K B R: build B's daemon restoring a copy of its data.
round() {
	rm -rf "$dir/copy"
	cp -r "$dir/data$1" "$dir/copy"
	start "$2" "$dir/copy"
	sleep 1
	before=$(awk '/^VmHWM/ {h = $2} /^VmRSS/ {r = $2}
		END {print int(h / 1024), int(r / 1024)}' "/proc/$pid/status")
	# The first picture of the restored session (its first view).
	t0=$(date +%s.%N)
	"$2/client/blobcast" --server "unix:$dir/sock" --timeout 600000 \
		snapshot --session big --size 1024x768 --out "$dir/first.png" \
		>/dev/null
	t1=$(date +%s.%N)
	echo "$(cat "$dir/took") $before $(echo "$t0 $t1" |
		awk '{printf "%.2f", $2 - $1}') $(awk '/^VmRSS/ {print int($2 / 1024)}' \
		"/proc/$pid/status")" >>"$dir/$1"
	stop
}
big_scene_rounds round

echo "| build | start to listening s | VmHWM MiB | VmRSS after MiB |" \
	"first snapshot s | VmRSS after it MiB |"
echo "|---|---:|---:|---:|---:|---:|"
k=0
for b in $builds; do
	k=$((k + 1))
	echo "| $b | $(big_scene_medians "$dir/$k" 5) |"
done
