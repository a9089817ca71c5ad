#!/bin/sh
# The gl backend on a view whose A-buffer lists are many: a million smooth
# fig18 spheres through `blobcast render --backend gl`, at one or more
# sizes, with one or more builds side by side (each size's rows of every
# build run next to each other). Past the A-buffer's limit (2^24
# fragments, or the driver's storage block size: about 5.6 million on
# llvmpipe) the frame is drawn in bands of tile rows; below it, a first
# frame whose lists overflow the starting capacity is drawn again.
#
#   bench/bench_gl_bands.sh BUILD_DIR [BUILD_DIR ...]
#
# Release builds. The scene is made once with the first build's
# `blobcast gen` and kept in $BC_BIG_SCENE (default
# /tmp/bc-fig18-1m.json, 166 MB); $BC_SIZES lists the sizes (default
# "1920x1080 2560x1440"). Prints per build and size the frame's total,
# A-buffer and trace times (--stats), its bands, the wall time with the
# scene's load and the peak RSS, or the error; then whether every build
# wrote the same image.
set -u
[ $# -ge 1 ] || {
	echo "usage: bench/bench_gl_bands.sh BUILD_DIR [BUILD_DIR ...]" >&2
	exit 2
}
# shellcheck source=bench/big_scene.sh
. "$(dirname "$0")/big_scene.sh"
big_scene_prepare bench_gl_bands "$1"
sizes=${BC_SIZES:-1920x1080 2560x1440}
dir=$(mktemp -d /tmp/bc-glbands.XXXXXX)
trap 'rm -rf "$dir"' EXIT INT TERM

echo "$(lscpu | sed -n 's/^Model name: *//p'), load average $(cut -d' ' -f1-3 /proc/loadavg)"
for size in $sizes; do
	n=0
	for build in "$@"; do
		n=$((n + 1))
		rev=$(git -C "$build/.." rev-parse --short HEAD 2>/dev/null ||
			echo '?')
		/usr/bin/time -f '%e %M' -o "$dir/time" \
			"$build/client/blobcast" render "$scene" --backend gl \
			--size "$size" --stats --quiet --out "$dir/$n.png" \
			2>"$dir/err"
		rc=$?
		# The last line: time puts a line of its own before it
		# when the command fails.
		last=$(tail -n 1 "$dir/time")
		wall=${last% *} kb=${last#* }
		if [ $rc -eq 0 ]; then
			echo "$size $build ($rev): $(grep -o 'total [0-9.]* ms, a-buffer [0-9.]* ms, trace [0-9.]* ms' "$dir/err"), $(grep -o '[0-9]* bands*' "$dir/err"), ${wall} s with the load, peak $((kb / 1024)) MiB"
		else
			rm -f "$dir/$n.png"
			echo "$size $build ($rev): exit $rc after ${wall} s: $(grep -v '^  ' "$dir/err" | tail -n 1)"
		fi
	done
	same=yes
	for i in $(seq 2 $n); do
		if [ -f "$dir/1.png" ] && [ -f "$dir/$i.png" ]; then
			cmp -s "$dir/1.png" "$dir/$i.png" || same=no
		fi
	done
	echo "$size: images of the builds that drew it equal: $same"
done
