#!/usr/bin/env bash
# Bounded fuzzing of every harness in tests/fuzz (the protocol's and
# blobtree's): configures and builds a clang libFuzzer build in build-fuzz/,
# runs each fuzz_*.c binary for SECONDS_EACH seconds (as many at once as
# there are cores, BLOBCAST_FUZZ_JOBS to change it) on a scratch copy of its
# committed seed corpus (tests/fuzz/corpus/NAME for fuzz_NAME, so the repo
# is never dirtied), prints executions, coverage and crashes per harness,
# copies any crashing input to fuzz-out/, and exits 1 on a crash.
# Without clang it says so and exits 0.
#
# Usage: bash tests/fuzz/run.sh [SECONDS_EACH]   (default 20)
set -euo pipefail
cd "$(dirname "$0")/../.."

secs=${1:-20}
build=${BLOBCAST_FUZZ_BUILD:-build-fuzz}
jobs=${BLOBCAST_FUZZ_JOBS:-$(nproc)}

if ! command -v clang >/dev/null 2>&1; then
	echo "fuzz: clang not found; skipping fuzzing (install clang to fuzz)"
	exit 0
fi

harnesses=()
for src in tests/fuzz/fuzz_*.c; do
	[ -e "$src" ] || continue
	harnesses+=("$(basename "$src" .c)")
done
if [ ${#harnesses[@]} -eq 0 ]; then
	echo "fuzz: no harnesses"
	exit 0
fi

echo "fuzz: building ${harnesses[*]} in $build"
# The libraries get coverage instrumentation (fuzzer-no-link); the harness
# executables add the libFuzzer runtime themselves. Warnings are errors here
# too.
cmake -S . -B "$build" -G Ninja -DCMAKE_C_COMPILER=clang \
	-DCMAKE_BUILD_TYPE=RelWithDebInfo -DBLOBCAST_FUZZ=ON \
	-DBLOBCAST_SANITIZE=ON -DBLOBCAST_WERROR=ON -DBLOBCAST_GL=OFF \
	"-DCMAKE_C_FLAGS=-fsanitize=fuzzer-no-link" \
	>/dev/null
cmake --build "$build" -j "$jobs" --target "${harnesses[@]}"

work=$(mktemp -d "${TMPDIR:-/tmp}/blobcast-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# fuzz_one H: runs harness H for $secs seconds and leaves its summary
# line in $work/H/summary and, when it crashed, a file $work/H/crashed.
fuzz_one() {
	local h=$1 name seeds log rc execs rate cov ft corp ncrash
	name=${h#fuzz_}
	mkdir -p "$work/$h/corpus" "$work/$h/artifacts"
	seeds=0
	if [ -d "tests/fuzz/corpus/$name" ]; then
		cp -r "tests/fuzz/corpus/$name/." "$work/$h/corpus/"
		seeds=$(find "$work/$h/corpus" -type f | wc -l)
	fi
	log="$work/$h/log"
	set +e
	"$build/tests/fuzz/$h" "$work/$h/corpus" \
		-max_total_time="$secs" -print_final_stats=1 -timeout=10 \
		-rss_limit_mb=2048 -max_len=16384 \
		-artifact_prefix="$work/$h/artifacts/" >"$log" 2>&1
	rc=$?
	set -e
	execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
	rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
	cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
	ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
	corp=$(find "$work/$h/corpus" -type f | wc -l)
	ncrash=$(find "$work/$h/artifacts" -type f | wc -l)
	if [ "$rc" -ne 0 ] || [ "$ncrash" -ne 0 ]; then
		echo "$rc" >"$work/$h/crashed"
	fi
	printf '%-22s %6ss %12s %9s %7s %7s %6s->%-6s %7s\n' \
		"$h" "$secs" "${execs:-?}" "${rate:-?}" "${cov:-?}" \
		"${ft:-?}" "$seeds" "$corp" "$ncrash" >"$work/$h/summary"
}

# The harnesses run $jobs at a time (each is one process on one core): on
# two cores the phase takes half the time for the same seconds each.
running=0
for h in "${harnesses[@]}"; do
	if [ "$running" -ge "$jobs" ]; then
		wait -n || true
		running=$((running - 1))
	fi
	fuzz_one "$h" &
	running=$((running + 1))
done
wait

crashed=0
for h in "${harnesses[@]}"; do
	if [ -e "$work/$h/crashed" ]; then
		crashed=1
		mkdir -p "fuzz-out/$h"
		cp "$work/$h/artifacts/"* "fuzz-out/$h/" 2>/dev/null || true
		echo "fuzz: $h FAILED (exit $(cat "$work/$h/crashed")); inputs in fuzz-out/$h/, log tail:"
		tail -40 "$work/$h/log"
	fi
done

echo
printf '%-22s %7s %12s %9s %7s %7s %14s %7s\n' harness time executions \
	'exec/s' cov ft corpus crashes
for h in "${harnesses[@]}"; do
	cat "$work/$h/summary" 2>/dev/null || echo "$h: no summary (see above)"
done
exit "$crashed"
