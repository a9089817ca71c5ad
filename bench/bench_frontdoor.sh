#!/usr/bin/env bash
# The cost of the front door (docs/deploy.md): edit -> frame latency of one
# session measured side by side, in alternating rounds, over
#   direct   plain TCP to the daemon that holds the session (loopback)
#   ws       ws:// to that daemon's websockify (the WebSocket hop alone)
#   front    wss:// through nginx (TLS, consistent hashing) and websockify:
#            what every client of deploy/cluster-demo.sh takes
# with `blobcast bench-latency` (edits of one primitive, each timed until
# the first frame that includes it). Prints each round and a table of the
# medians over the rounds of p50, p99 and the minimum, with their ratios to
# direct. On a shared machine the minimum is the steadiest measure of what
# a path adds; p50 and p99 include whatever else the cores were doing.
#
#   bench/bench_frontdoor.sh [--build DIR] [--edits N] [--rounds R]
#                            [--size WxH] [--port P]
#
# DIR (default build-rel) holds a Release build of blobcastd and blobcast.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build-rel
edits=100
rounds=3
size=320x240
port=23443
while [ $# -gt 0 ]; do
	case "$1" in
	--build) build=$(cd "${2:?}" && pwd); shift 2 ;;
	--edits) edits=${2:?}; shift 2 ;;
	--rounds) rounds=${2:?}; shift 2 ;;
	--size) size=${2:?}; shift 2 ;;
	--port) port=${2:?}; shift 2 ;;
	-h|--help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
	*) echo "bench_frontdoor: unknown argument $1" >&2; exit 2 ;;
	esac
done
cli=$build/client/blobcast
daemon=$build/server/blobcastd
for f in "$cli" "$daemon"; do
	[ -x "$f" ] || { echo "bench_frontdoor: $f is not built" >&2; exit 1; }
done

data=$(mktemp -d /tmp/bc-frontdoor.XXXXXX)
demo=
cleanup() {
	if [ -n "$demo" ]; then kill "$demo" 2>/dev/null || true; wait "$demo" 2>/dev/null || true; fi
	rm -rf "$data"
}
trap cleanup EXIT
BLOBCASTD=$daemon setsid "$root/deploy/cluster-demo.sh" --port "$port" \
	--data "$data/cluster" > "$data/demo.log" 2>&1 &
demo=$!
for _ in $(seq 1 400); do
	grep -q 'cluster-demo: ready' "$data/demo.log" && break
	sleep 0.05
done
grep -q 'cluster-demo: ready' "$data/demo.log" || {
	cat "$data/demo.log" >&2; exit 1; }

session=bench
ca=$data/cluster/tls/ca.pem
front="wss://127.0.0.1:$port/blobcast?session=$session"
cat > "$data/scene.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 40},
 "root": {"type": "smooth_union", "id": 1, "blend": 0.3, "children": [
   {"type": "sphere", "id": 2, "radius": 0.8, "color": [0.9, 0.3, 0.2]},
   {"type": "box", "id": 3, "half_extents": [0.5, 0.5, 0.5],
    "translate": [1, 0, 0], "color": [0.2, 0.5, 0.9]}]}}
JSON
"$cli" load --server "$front" --ca "$ca" --session "$session" \
	"$data/scene.json" > /dev/null
node=
for d in "$data"/cluster/node-*; do
	[ -d "$d/sessions/$session" ] && node=${d##*/node-}
done
[ -n "$node" ] || { echo "bench_frontdoor: the session is on no daemon" >&2; exit 1; }
direct="127.0.0.1:$((port + 10 + node))"
ws="ws://127.0.0.1:$((port + 20 + node))/"

run() { # NAME ADDR [options...]
	local name=$1 addr=$2
	shift 2
	printf '%s ' "$name"
	"$cli" bench-latency --server "$addr" "$@" --session "$session" \
		--edits "$edits" --size "$size"
}
: > "$data/results"
for r in $(seq 1 "$rounds"); do
	run direct "$direct" | tee -a "$data/results"
	run ws "$ws" | tee -a "$data/results"
	run front "$front" --ca "$ca" | tee -a "$data/results"
done

python3 - "$data/results" "$edits" "$rounds" "$size" <<'PY'
import json, statistics, sys
path, edits, rounds, size = sys.argv[1:]
runs = {}
for line in open(path):
    name, js = line.split(' ', 1)
    runs.setdefault(name, []).append(json.loads(js))
def med(name, key):
    return statistics.median(r[key] for r in runs[name])
base50, base99 = med('direct', 'p50_ms'), med('direct', 'p99_ms')
basemin = med('direct', 'min_ms')
print(f"\nedit -> frame, {size} JPEG, {edits} edits x {rounds} rounds "
      "(median of the rounds)\n")
print("| path | p50 ms | p99 ms | min ms | p50 / direct | p99 / direct "
      "| min / direct |")
print("|---|---|---|---|---|---|---|")
for name, what in (('direct', 'TCP to the daemon'),
                   ('ws', 'ws:// to its websockify'),
                   ('front', 'wss:// through nginx (TLS) + websockify')):
    p50, p99, mn = med(name, 'p50_ms'), med(name, 'p99_ms'), med(name, 'min_ms')
    print(f"| {what} | {p50:.2f} | {p99:.2f} | {mn:.2f} | "
          f"{p50 / base50:.2f} | {p99 / base99:.2f} | {mn / basemin:.2f} |")
PY
