#!/usr/bin/env bash
# The test command (README, CI): installs the Debian dependencies, builds
# everything with AddressSanitizer + UBSan and warnings as errors, runs every
# test, checks that the optimized build (benchmarks included) compiles with
# warnings as errors too, and, when clang is present, that everything
# compiles with clang as well and fuzzes each decoder for a bounded time
# (before the tests, so ctest's summary closes the log).
#
# Usage: bash tests/run.sh [--no-fuzz] [ctest -R regex]
set -euo pipefail
cd "$(dirname "$0")/.."

fuzz=1
if [ "${1:-}" = "--no-fuzz" ]; then
	fuzz=0
	shift
fi
filter=${1:-}

bash deploy/install-deps.sh

jobs=$(nproc)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# The daemons the tests start open no H.264 module: the tests' clients
# list H.264 in their HELLO, which has a daemon load FFmpeg's ~90
# libraries (about 120 ms of CPU sanitized, and the suite starts about a
# thousand daemons); the tests of video name the built module in their
# ctest ENVIRONMENT, which wins.
export BLOBCASTD_H264_MODULE=none

# phase TITLE: starts a phase of the log, saying how long the last one
# took, so that a slow run shows where its time went.
phase_title=
phase_start=0
phase() {
	if [ -n "$phase_title" ]; then
		echo "   ($phase_title: $((SECONDS - phase_start)) s)"
	fi
	phase_title=$1
	phase_start=$SECONDS
	echo "== $1"
}

# Layout first: it takes a second and says which file to run clang-format
# on (the formatting commit is listed in .git-blame-ignore-revs).
phase "format (.clang-format)"
sh tests/check_format.sh

# The tests build in folders of their own (build-asan, build-check), never
# in build/, which is the user's (the quick start's daemon and CLI).
release=build-check

phase "sanitizer build (ASan + UBSan, -Werror)"
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	-DBLOBCAST_SANITIZE=ON -DBLOBCAST_WERROR=ON \
	-DBLOBCAST_GPU_KIT_BUILD="$PWD/$release" >/dev/null
cmake --build build-asan -j "$jobs"

# The optimized build uses CMake's default generator (Unix Makefiles), the
# sanitizer build Ninja, so that both keep working. test_rss and
# test_gpu_run use its programs. The test programs themselves are built
# once, in the sanitizer build (also -O2 and -Werror): building them again
# here took more than a third of this build's time.
phase "optimized build (-Werror, default generator)"
cmake -S . -B "$release" -DCMAKE_BUILD_TYPE=Release \
	-DBLOBCAST_WERROR=ON -DBLOBCAST_TESTS=OFF >/dev/null
cmake --build "$release" -j "$jobs"

# clang warns where GCC does not (a string literal as a truth value, | under
# ?:): the whole tree, tests included, compiles with it too, warnings as
# errors, where clang is present. Unoptimized: its warnings do not depend
# on -O, and the build is the faster for it. Nothing of it runs.
if command -v clang >/dev/null 2>&1; then
	phase "clang build (-Werror, unoptimized, not run)"
	CC=clang cmake -S . -B build-clang -G Ninja -DCMAKE_BUILD_TYPE=Debug \
		-DBLOBCAST_WERROR=ON >/dev/null
	cmake --build build-clang -j "$jobs"
fi

# 12 s a harness (BLOBCAST_FUZZ_SECONDS): coverage of the decoders stops
# growing within seconds (docs/fuzzing.md); a longer campaign is
# `bash tests/fuzz/run.sh 300`.
if [ "$fuzz" = 1 ] && [ -f tests/fuzz/run.sh ]; then
	phase "fuzzing"
	bash tests/fuzz/run.sh "${BLOBCAST_FUZZ_SECONDS:-12}"
fi

# One test more than there are cores: the tests wait for part of their
# time (timers, sockets, the browser; at -j2 they used 149 % of 2 cores),
# and each must pass on a loaded machine anyway. On 2 cores -j3 took the
# phase from 537 to 503 s (docs/benchmarks.md, "The test command's time").
phase "tests (ctest -j $((jobs + 1)))"
if [ -n "$filter" ]; then
	ctest --test-dir build-asan --output-on-failure -j $((jobs + 1)) \
		-R "$filter"
else
	ctest --test-dir build-asan --output-on-failure -j $((jobs + 1))
fi
