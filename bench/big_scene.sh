# Sourced by the benches of a million-sphere scene (bench_big_view.sh,
# bench_gl_bands.sh): big_scene_prepare NAME BUILD_DIR checks that
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
