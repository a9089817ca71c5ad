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

# big_scene_median FILE COLUMN: the median of that column's numbers.
big_scene_median() {
	sort -n -k"$2" "$1" | awk -v c="$2" '{v[NR] = $c}
		END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'
}
