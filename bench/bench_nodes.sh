#!/bin/sh
# `blobcast nodes` on a big session: a scene of COUNT spheres under one
# union (`blobcast gen many-spheres`, COUNT + 1 nodes: the widest operator
# there is, where a per-child lookup would cost COUNT^2) is loaded into a
# private blobcastd, then `blobcast nodes` (text, then --json) is timed
# end to end: connecting, joining (the scene's transfer and decoding) and
# writing every line. Prints one Markdown table row per output form: the
# best of three runs, wall time and the client's CPU time.
#
#   bench/bench_nodes.sh [BUILD_DIR] [COUNT]
#
# BUILD_DIR defaults to build-rel (a Release build: ASan would measure the
# sanitizer); COUNT defaults to 100000.
set -eu
build=${1:-build-rel}
count=${2:-100000}
daemon=$build/server/blobcastd
cli=$build/client/blobcast
if [ ! -x /usr/bin/time ]; then
	echo "bench_nodes: /usr/bin/time is missing (apt install time)" >&2
	exit 1
fi
for f in "$daemon" "$cli"; do
	if [ ! -x "$f" ]; then
		echo "bench_nodes: $f is not built (cmake --build $build)" >&2
		exit 1
	fi
done
dir=$(mktemp -d /tmp/bc-nodes.XXXXXX)
pid=
cleanup() {
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT INT TERM

"$cli" gen many-spheres --count "$count" --out "$dir/scene.json"
"$daemon" --listen none --unix "$dir/sock" --data "$dir/data" \
	--log warn 2> "$dir/daemon.log" &
pid=$!
i=0
until [ -S "$dir/sock" ]; do
	i=$((i + 1))
	if [ $i -gt 200 ]; then
		echo "bench_nodes: blobcastd did not start:" >&2
		cat "$dir/daemon.log" >&2
		exit 1
	fi
	sleep 0.05
done
S="--server unix:$dir/sock --timeout 0"
"$cli" load $S --session big "$dir/scene.json" > /dev/null

# The best of three runs: wall seconds, and the client's CPU seconds
# (user + system), which a busy machine disturbs less.
echo "| output | nodes | lines | wall (s) | client CPU (s) |"
echo "|---|---:|---:|---:|---:|"
for form in text json; do
	opt=
	[ "$form" = json ] && opt=--json
	best=
	for run in 1 2 3; do
		/usr/bin/time -f '%e %U %S' -o "$dir/time" \
			"$cli" nodes $S --session big $opt > "$dir/out"
		t=$(awk '{printf "%.2f %.2f", $1, $2 + $3}' "$dir/time")
		if [ -z "$best" ] || [ "$(echo "$t $best" |
			awk '{print ($1 < $3)}')" = 1 ]; then
			best=$t
		fi
	done
	lines=$(wc -l < "$dir/out")
	echo "$best" | awk -v f="$form" -v n=$((count + 1)) -v l="$lines" \
		'{printf "| %s | %s | %s | %s | %s |\n", f, n, l, $1, $2}'
done
