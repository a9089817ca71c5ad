# Sourced by the benches of a million-sphere scene (bench_big_view.sh,
# bench_gl_bands.sh, bench_cli_big.sh, bench_restore.sh).
#
# big_scene_prepare NAME BUILD_DIR checks that
# /usr/bin/time is there and makes the scene once with BUILD_DIR's
# `blobcast gen` (a million smooth fig18 spheres, 166 MB of JSON) in
# $BC_BIG_SCENE (default /tmp/bc-fig18-1m.json), whose path it leaves
# in $scene. Exits the script when either fails.
# shellcheck shell=sh
big_scene_prepare() {
	scene=${BC_BIG_SCENE:-/tmp/bc-fig18-1m.json}
	if [ ! -x /usr/bin/time ]; then
		echo "$1: /usr/bin/time is missing (apt install time)" >&2
		exit 1
	fi
	if [ ! -s "$scene" ]; then
		"$2/client/blobcast" gen fig18 --count 1000000 --kind spheres \
			--blend smooth --out "$scene" || exit 1
	fi
}

# big_scene_builds NAME REPS ARGS...: reads ARGS, BUILD_DIR... [-- REPS],
# into $builds (the directories, space-separated) and $reps (REPS as
# given, or the default passed); exits with the usage when no build is
# given, or saying which one lacks blobcastd or blobcast.
# shellcheck disable=SC2034 # builds and reps are the sourcing bench's
big_scene_builds() {
	name=$1
	reps=$2
	shift 2
	builds=
	while [ $# -gt 0 ]; do
		case $1 in
		--) reps=${2:?REPS after --}; break ;;
		*) builds="$builds $1" ;;
		esac
		shift
	done
	builds=${builds# }
	if [ -z "$builds" ]; then
		echo "usage: bench/$name.sh BUILD_DIR [BUILD_DIR...] [-- REPS]" >&2
		exit 2
	fi
	for b in $builds; do
		for f in "$b/server/blobcastd" "$b/client/blobcast"; do
			if [ ! -x "$f" ]; then
				echo "$name: $f is not built (cmake --build $b)" >&2
				exit 1
			fi
		done
	done
}

# big_scene_rounds FUNC: calls FUNC K BUILD R for round R = 1..$reps and
# each build of $builds (K its place in the list, from 1), the builds
# taking turns.
big_scene_rounds() {
	r=0
	while [ $r -lt "$reps" ]; do
		r=$((r + 1))
		k=0
		for b in $builds; do
			k=$((k + 1))
			"$1" $k "$b" $r
		done
	done
}

# big_scene_medians FILE N: the medians of the first N columns of FILE's
# numbers, as Markdown table cells ("a | b | c").
big_scene_medians() {
	c=1
	cells=
	while [ $c -le "$2" ]; do
		m=$(sort -n -k"$c" "$1" | awk -v c="$c" '{v[NR] = $c}
			END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}')
		cells="$cells${cells:+ | }$m"
		c=$((c + 1))
	done
	echo "$cells"
}
