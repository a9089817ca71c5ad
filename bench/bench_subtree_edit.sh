#!/bin/sh
# Event-loop time of edits that carry a big subtree, side by side: each
# BUILD_DIR's blobcastd (a private one on a Unix socket) loads N sharp
# fig18 spheres and wraps their union in a union with one more sphere;
# then `blobcast duplicate` copies the N-sphere union REPS times (an
# INSERT of N + 1 nodes each, applied on a task: the session's scene grows
# by as much each time), the builds taking turns. After each duplicate,
# bench/loop_turn.mjs reads the longest turn of the daemon's event loop
# since the one before (STATS's load section, LOAD and RESET): the time
# every other session's requests could have waited. Prints one Markdown
# table row per build: the median and the range over the repetitions
# after the first (which also meets the session's first structural edit).
#
#   bench/bench_subtree_edit.sh BUILD_DIR [BUILD_DIR...] [-- REPS [N]]
#
# BUILD_DIRs are Release builds; REPS defaults to 5, N to 60000. Needs
# node (deploy/install-web-deps.sh).
set -eu
here=$(dirname "$0")
# shellcheck source=bench/daemon.sh
. "$here/daemon.sh"
builds=""
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
	builds="$builds $1"
	shift
done
[ $# -gt 0 ] && shift
reps=${1:-5}
n=${2:-60000}
if [ -z "$builds" ]; then
	echo "usage: bench/bench_subtree_edit.sh BUILD_DIR... [-- REPS [N]]" >&2
	exit 2
fi
dir=$(mktemp -d)
pids=""
stop_all() {
	for p in $pids; do
		kill "$p" 2>/dev/null || :
	done
	rm -rf "$dir"
}
trap stop_all EXIT
first=${builds# }
first=${first%% *}
"$first/client/blobcast" gen fig18 --count "$n" --kind spheres \
	--blend sharp --out "$dir/scene.json" >/dev/null
k=0
for b in $builds; do
	k=$((k + 1))
	mkdir -p "$dir/$k/data"
	bench_daemon_start bench_subtree_edit "$b/server/blobcastd" \
		"$dir/$k/sock" "$dir/$k/data" "$dir/$k/log" --log warn
	pids="$pids $pid"
	s="--server unix:$dir/$k/sock --session big --timeout 600000"
	# shellcheck disable=SC2086
	"$b/client/blobcast" load $s "$dir/scene.json" >/dev/null
	# shellcheck disable=SC2086
	"$b/client/blobcast" wrap $s 1 union --child sphere >/dev/null
	node "$here/loop_turn.mjs" "unix:$dir/$k/sock" >/dev/null
	: >"$dir/$k/turns"
done
i=0
while [ $i -lt "$reps" ]; do
	k=0
	for b in $builds; do
		k=$((k + 1))
		s="--server unix:$dir/$k/sock --session big --timeout 600000"
		# shellcheck disable=SC2086
		"$b/client/blobcast" duplicate $s 1 >/dev/null
		t=$(node "$here/loop_turn.mjs" "unix:$dir/$k/sock")
		[ $i -gt 0 ] && echo "$t" >>"$dir/$k/turns"
	done
	i=$((i + 1))
done
echo "| build | longest loop turn per duplicate of $n spheres (ms): median | range |"
echo "|---|---:|---:|"
k=0
for b in $builds; do
	k=$((k + 1))
	sort -n "$dir/$k/turns" | awk -v b="$b" '
	{ v[NR] = $1 }
	END {
		m = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2
		printf "| %s | %.1f | %.1f-%.1f |\n", b, m, v[1], v[NR]
	}'
done
