#!/bin/sh
# blobcast-view joining a big session, side by side: each BUILD_DIR's
# blobcastd (a private one on a Unix socket) loads a million smooth fig18
# spheres (big_scene.sh) and draws one picture of them, then that build's
# blobcast-view (under xvfb-run, 640x480, --verbose) joins the session
# REPS times, the builds taking turns. Each run is timed from the viewer's
# start to its "joined" line (the session's SCENE_STATE taken into the
# viewer's mirror of the scene) and to its first still; the viewer's peak
# resident memory (VmHWM) is read once the still has come, and the viewer
# is then stopped. Prints one Markdown table row per build: medians.
#
#   bench/bench_viewer_big.sh BUILD_DIR [BUILD_DIR...] [-- REPS]
#
# BUILD_DIRs are Release builds with the viewer (client/viewer); REPS
# defaults to 3. Needs xvfb-run. $BC_BIG_SCENE: where the scene is made.
set -eu
# shellcheck source=bench/big_scene.sh
. "$(dirname "$0")/big_scene.sh"
# shellcheck source=bench/daemon.sh
. "$(dirname "$0")/daemon.sh"
big_scene_builds bench_viewer_big 3 "$@"
big_scene_prepare bench_viewer_big "${builds%% *}"
if ! command -v xvfb-run >/dev/null; then
	echo "bench_viewer_big: xvfb-run is missing (apt install xvfb)" >&2
	exit 1
fi
for b in $builds; do
	if [ ! -x "$b/client/viewer/blobcast-view" ]; then
		echo "bench_viewer_big: $b/client/viewer/blobcast-view is not" \
			"built" >&2
		exit 1
	fi
done
big_scene_daemons bench_viewer_big
# The daemons' copies and lists of this view are made before the runs:
# each run then times the viewer, not the first picture.
k=0
for b in $builds; do
	k=$((k + 1))
	"$b/client/blobcast" --server "unix:$dir/$k/sock" --timeout 600000 \
		snapshot --session big --size 640x480 --out "$dir/$k/first.png"
done

now_ms() { echo $(($(date +%s%N) / 1000000)); }

# wait_line LOG PATTERN: until a line of LOG matches (120 s at most).
wait_line() {
	i=0
	until grep -Eq "$2" "$1" 2>/dev/null; do
		i=$((i + 1))
		if [ $i -gt 6000 ]; then
			echo "bench_viewer_big: no '$2' in $1:" >&2
			cat "$1" "$1.err" >&2
			exit 1
		fi
		sleep 0.02
	done
}

# run K B R: build B's viewer against daemon K, its figures appended to
# $dir/K/runs.
run() {
	log=$dir/$1/view-$3.log
	t0=$(now_ms)
	xvfb-run -a "$2/client/viewer/blobcast-view" \
		--server "unix:$dir/$1/sock" --session big --size 640x480 \
		--verbose >"$log" 2>"$log.err" &
	xpid=$!
	wait_line "$log" '^joined big '
	t1=$(now_ms)
	wait_line "$log" ' still [a-z]+ image=[0-9x]+ level=0 '
	t2=$(now_ms)
	vp=$(pgrep -n -f "blobcast-view --server unix:$dir/$1/sock")
	hwm=$(awk '/^VmHWM/ {print int($2 / 1024)}' "/proc/$vp/status")
	kill "$vp"
	wait "$xpid" || :
	echo "$((t1 - t0)) $((t2 - t0)) $hwm" >>"$dir/$1/runs"
}
big_scene_rounds run

echo "| build | start to joined, ms | start to first still, ms | viewer VmHWM, MiB |"
echo "|---|---:|---:|---:|"
k=0
for b in $builds; do
	k=$((k + 1))
	echo "| $b | $(big_scene_medians "$dir/$k/runs" 3) |"
done
