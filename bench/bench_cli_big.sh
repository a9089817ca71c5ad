#!/bin/sh
# One-shot CLI commands on a big session, side by side: each BUILD_DIR's
# blobcastd (a private one on a Unix socket) loads a million smooth fig18
# spheres (big_scene.sh), then its `blobcast edit` (a primitive's
# translate), `blobcast add` (a sphere appended to the union) and
# `blobcast load` (the 166 MB JSON file again) run REPS times, the builds
# taking turns. Each command connects, joins (the session's SCENE_STATE:
# sent by the daemon, taken in by the client), checks and sends its edit
# and waits for its EDIT_APPLIED (load: reads the file first, and waits
# for the new scene's SCENE_STATE). Prints one
# Markdown table row per build and command: medians of wall time, the
# client's CPU time and peak resident memory (GNU time), and the daemon's
# CPU time over the command (/proc/PID/stat).
#
#   bench/bench_cli_big.sh BUILD_DIR [BUILD_DIR...] [-- REPS]
#
# BUILD_DIRs are Release builds (ASan would measure the sanitizer); REPS
# defaults to 5. $BC_BIG_SCENE: where the scene is made once.
set -eu
# shellcheck source=bench/big_scene.sh
. "$(dirname "$0")/big_scene.sh"
# shellcheck source=bench/daemon.sh
. "$(dirname "$0")/daemon.sh"
big_scene_builds bench_cli_big 5 "$@"
big_scene_prepare bench_cli_big "${builds%% *}"
big_scene_daemons bench_cli_big
tck=$(getconf CLK_TCK)

cpu_ticks() { awk '{print $14 + $15}' "/proc/$(cat "$1/pid")/stat"; }

# run K B NAME ARGS...: one command of build B against daemon K, its
# figures appended to $dir/K/NAME.
run() {
	kd=$dir/$1
	b=$2
	name=$3
	shift 3
	t0=$(cpu_ticks "$kd")
	/usr/bin/time -f '%e %U %S %M' -o "$kd/time" "$b/client/blobcast" \
		--server "unix:$kd/sock" --timeout 600000 "$@" >/dev/null
	# The daemon may still be sending frames or writing its journal.
	sleep 0.3
	t1=$(cpu_ticks "$kd")
	read -r wall user sys kb <"$kd/time"
	echo "$wall $user $sys $kb $(((t1 - t0) * 1000 / tck))" |
		awk '{print $1, $2 + $3, int($4 / 1024), $5}' >>"$kd/$name"
}

# round K B R: build B's commands against daemon K.
round() {
	run "$1" "$2" edit edit --session big 5 "translate=0,0.$3,0"
	run "$1" "$2" add add --session big sphere radius=0.01
	run "$1" "$2" load load "$scene" --session big
}
big_scene_rounds round

echo "| build | command | wall s | client CPU s | client peak MiB | daemon CPU ms |"
echo "|---|---|---:|---:|---:|---:|"
k=0
for b in $builds; do
	k=$((k + 1))
	for name in edit add load; do
		f=$dir/$k/$name
		echo "| $b | $name | $(big_scene_medians "$f" 4) |"
	done
done
