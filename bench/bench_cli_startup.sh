#!/bin/sh
# CLI start-up, two blobcast binaries side by side: CPU time (task-clock)
# and wall time of `blobcast --help` and, when a blobcastd is given, of
# `blobcast --server unix:SOCK sessions` against it, as the mean of N runs
# under `perf stat -r N`, with the ratio A / B. The shared objects each one
# loads are counted with LD_DEBUG=libs.
#
# usage: bench/bench_cli_startup.sh BLOBCAST_A BLOBCAST_B [BLOBCASTD] [N]
# (A is typically the older build; N defaults to 30)
set -eu
a=$1
b=$2
daemon=${3:-}
n=${4:-30}
command -v perf > /dev/null || { echo "needs perf (linux-perf)"; exit 1; }
tmp=$(mktemp -d /tmp/bc-bench-startup.XXXXXX)
pid=
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2> /dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT INT TERM

# stat BIN ARGS...: prints "CPU_MS WALL_MS" (means over n runs).
stat() {
  perf stat -x, -e task-clock -r "$n" "$@" 2> "$tmp/perf" > /dev/null
  cpu=$(awk -F, '/task-clock/ { printf "%.2f", $1 }' "$tmp/perf")
  # -x output has no elapsed line: time the same runs once more in bulk.
  start=$(date +%s%N)
  i=0
  while [ "$i" -lt "$n" ]; do
    "$@" > /dev/null 2>&1
    i=$((i + 1))
  done
  end=$(date +%s%N)
  wall=$(awk -v s="$start" -v e="$end" -v n="$n" \
    'BEGIN { printf "%.2f", (e - s) / 1e6 / n }')
  echo "$cpu $wall"
}

libs() {
  LD_DEBUG=libs "$@" 2>&1 > /dev/null | grep -c 'calling init:'
}

row() {
  label=$1
  shift
  set -- "$@"
  ra=$(stat "$a" "$@")
  rb=$(stat "$b" "$@")
  la=$(libs "$a" "$@")
  lb=$(libs "$b" "$@")
  echo "$label $ra $rb $la $lb" | awk '{
    printf "%-10s A cpu_ms=%.2f wall_ms=%.2f libs=%d | B cpu_ms=%.2f wall_ms=%.2f libs=%d | cpu A/B=%.1f\n",
      $1, $2, $3, $6, $4, $5, $7, $2 / $4 }'
}

echo "runs=$n A=$a B=$b"
row help --help
if [ -n "$daemon" ]; then
  "$daemon" --listen none --unix "$tmp/d.sock" --data "$tmp/data" \
    --log error > "$tmp/d.log" 2>&1 &
  pid=$!
  i=0
  while [ ! -S "$tmp/d.sock" ] && [ "$i" -lt 100 ]; do
    sleep 0.1
    i=$((i + 1))
  done
  [ -S "$tmp/d.sock" ] || { echo "blobcastd did not start"; exit 1; }
  row sessions --server "unix:$tmp/d.sock" sessions
fi
