#!/bin/sh
# svo against libfive's heightmap renderer, side by side in one run: fig18
# sharp spheres at 64, 1024 and 4096 primitives, SIZE x SIZE, one thread
# each. Every repetition runs libfive once and svo once, alternately, so
# both see the same load on a shared machine; the table gives each side's
# median CPU time and the median of the per-repetition ratios.
#
# libfive renders with libfive::Heightmap (interval subdivision, tapes
# pruned per region; docs/benchmarks.md says how /tmp/bench_libfive is
# built); untimed on its side is compiling the tape, on ours compiling the
# RPN. svo's time includes building the octree for the frame.
#
# Usage: bench/libfive/svo_vs_libfive.sh BUILD_DIR [REPS] [SIZE] [COUNTS]
#   BUILD_DIR  a Release build with client/blobcast and bench/bench_svo
#   REPS       repetitions (default 7)
#   SIZE       image edge (default 512)
#   COUNTS     sphere counts (default "64 1024 4096")
# Environment: BENCH_LIBFIVE (default /tmp/bench_libfive), WORK (scratch
# directory for the scenes, default a fresh mktemp -d), BEFORE (a second
# build, e.g. of an earlier commit, whose bench_svo runs in the same
# rotation: two more columns, its time and its time over BUILD_DIR's).
set -eu
build=${1:?usage: svo_vs_libfive.sh BUILD_DIR [REPS] [SIZE] [COUNTS]}
reps=${2:-7}
size=${3:-512}
counts=${4:-64 1024 4096}
lf=${BENCH_LIBFIVE:-/tmp/bench_libfive}
work=${WORK:-$(mktemp -d)}
for exe in "$lf" "$build/client/blobcast" "$build/bench/bench_svo"; do
	if [ ! -x "$exe" ]; then
		echo "svo_vs_libfive: $exe is missing (see docs/benchmarks.md)" >&2
		exit 1
	fi
done
before=${BEFORE:-}
if [ -n "$before" ] && [ ! -x "$before/bench/bench_svo" ]; then
	echo "svo_vs_libfive: $before/bench/bench_svo is missing" >&2
	exit 1
fi
if [ -n "$before" ]; then
	echo "| fig18 sharp spheres | libfive (ms) | svo (ms) | libfive / svo (median of $reps ratios) | range of ratios | svo before (ms) | before / svo |"
	echo "|---:|---:|---:|---:|---:|---:|---:|"
else
	echo "| fig18 sharp spheres | libfive (ms) | svo (ms) | libfive / svo (median of $reps ratios) | range of ratios |"
	echo "|---:|---:|---:|---:|---:|"
fi
for n in $counts; do
	scene=$work/fig18-sharp-$n.json
	ortho=$work/ortho-$n.json
	"$build/client/blobcast" gen fig18 --count "$n" --kind spheres \
		--blend sharp --out "$scene" >/dev/null
	"$lf" "$scene" --size "$size" --reps 1 --ortho "$ortho" >/dev/null
	: >"$work/times-$n"
	i=0
	while [ "$i" -lt "$reps" ]; do
		a=$("$lf" "$scene" --size "$size" --reps 1 |
			sed -n 's/.*best of 1 \([0-9.]*\) ms CPU.*/\1/p')
		b=$("$build/bench/bench_svo" files --size "$size" --reps 1 \
			"$ortho" | sed -n 's/.*median of 1 \([0-9.]*\) ms CPU.*/\1/p')
		c=0
		if [ -n "$before" ]; then
			c=$("$before/bench/bench_svo" files --size "$size" \
				--reps 1 "$ortho" |
				sed -n 's/.*median of 1 \([0-9.]*\) ms CPU.*/\1/p')
		fi
		if [ -z "$a" ] || [ -z "$b" ] || [ -z "$c" ]; then
			echo "svo_vs_libfive: a run printed no time" >&2
			exit 1
		fi
		echo "$a $b $c" >>"$work/times-$n"
		i=$((i + 1))
	done
	awk -v n="$n" -v before="$before" '
	function median(v, k,   i, j, t) {
		for (i = 1; i <= k; i++)
			for (j = i + 1; j <= k; j++)
				if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
		return k % 2 ? v[(k + 1) / 2] : (v[k / 2] + v[k / 2 + 1]) / 2
	}
	{ a[NR] = $1; b[NR] = $2; r[NR] = $1 / $2; c[NR] = $3; q[NR] = $3 / $2 }
	END {
		lo = r[1]; hi = r[1]
		for (i = 2; i <= NR; i++) {
			if (r[i] < lo) lo = r[i]
			if (r[i] > hi) hi = r[i]
		}
		printf "| %d | %.1f | %.1f | **%.2fx** | %.2f-%.2fx |", n,
		    median(a, NR), median(b, NR), median(r, NR), lo, hi
		if (before != "")
			printf " %.1f | %.2fx |", median(c, NR), median(q, NR)
		printf "\n"
	}' "$work/times-$n"
done
