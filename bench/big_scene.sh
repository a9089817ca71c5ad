# Sourced by the benches of a million-sphere scene (bench_big_view.sh,
# bench_gl_bands.sh, bench_cli_big.sh, bench_restore.sh,
# bench_viewer_big.sh).
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

# big_scene_daemons NAME: a scratch directory $dir (removed at exit, with
# the daemons), and for build K of $builds (from 1) a blobcastd of its
# own on the Unix socket $dir/K/sock (bench_daemon_start of daemon.sh,
# which the caller sources; its pid in $dir/K/pid) holding $scene in
# session "big".
big_scene_daemons() {
	dir=$(mktemp -d "/tmp/bc-$1.XXXXXX")
	pids=
	trap big_scene_cleanup EXIT INT TERM
	bsd_k=0
	for bsd_b in $builds; do
		bsd_k=$((bsd_k + 1))
		mkdir -p "$dir/$bsd_k"
		bench_daemon_start "$1" "$bsd_b/server/blobcastd" \
			"$dir/$bsd_k/sock" "$dir/$bsd_k/data" "$dir/$bsd_k/daemon.log"
		# shellcheck disable=SC2154 # pid: set by bench_daemon_start
		pids="$pids $pid"
		echo "$pid" >"$dir/$bsd_k/pid"
		"$bsd_b/client/blobcast" --server "unix:$dir/$bsd_k/sock" \
			--timeout 600000 load "$scene" --session big >/dev/null
	done
}

big_scene_cleanup() {
	for bsc_p in $pids; do kill "$bsc_p" 2>/dev/null || :; done
	wait 2>/dev/null || :
	rm -rf "$dir"
}
