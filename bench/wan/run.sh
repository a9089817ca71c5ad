#!/bin/sh
# The WAN bench: blobcastd in one network namespace, the client in another,
# joined by a veth pair shaped with tc tbf (bandwidth) and a user-space
# relay on the client's side that adds the round-trip time (this kernel has
# no netem). For each link profile and encoding it orbits the camera at
# 30 Hz through the link and prints what the client got and decoded
# (bench_wan_client's JSON), with the daemon's frame pacing on and, with
# --no-pace, off.
#
# usage (as root): bench/wan/run.sh BUILD_DIR [SIZE [SECONDS [PROFILES
#                  [DOWNSCALE [ENCODINGS [PACES [PLOT]]]]]]]
#   BUILD_DIR  a Release build with blobcastd and bench_wan_client
#   SIZE       view size, default 1280x720
#   SECONDS    orbit length per run, default 10
#   PROFILES   "MBIT/RTT_MS ...", default "100/5 20/30 10/50 4/80"
#   DOWNSCALE  the VIEW's coarsest block, default 1 (full resolution
#              only); 2, 4, 8 let interactive frames go coarser
#   ENCODINGS  of the runs, default "jpeg h264" (also h264-png: H.264
#              moving frames, a PNG still)
#   PACES      "on off" (default) or either
#   PLOT       a PNG of latency and frames/s per profile (needs Debian's
#              python3-matplotlib), default wan.png; "" for none
# BC_WAN_SCENE: a JSON scene the client loads first (default: the daemon's
# default scene); bench/wan/light.json is one the CPU renderer draws at
# 30 frames/s and more, so that the link, not the renderer, is measured.
# Output: one line per run, "profile encoding pace JSON"; a markdown table
# follows.
set -eu
B=${1:?usage: bench/wan/run.sh BUILD_DIR [SIZE [SECONDS [PROFILES]]]}
SIZE=${2:-1280x720}
SECS=${3:-10}
PROFILES=${4:-"100/5 20/30 10/50 4/80"}
DOWN=${5:-1}
ENCODINGS=${6:-"jpeg h264"}
PACES=${7:-"on off"}
PLOT=${8-wan.png}
HERE=$(cd "$(dirname "$0")" && pwd)
DAEMON=$B/server/blobcastd
CLIENT=$B/bench/bench_wan_client
[ "$(id -u)" = 0 ] || { echo "run.sh: needs root (network namespaces, tc)" >&2; exit 2; }
for f in "$DAEMON" "$CLIENT"; do
	[ -x "$f" ] || { echo "run.sh: $f is missing: build it first" >&2; exit 2; }
done
TMP=$(mktemp -d /tmp/bc-wan.XXXXXX)
# A client from another host needs a token; plaintext is fine on a veth.
BLOBCAST_TOKEN=wan-bench-token-0123456789abcdef
export BLOBCAST_TOKEN
printf '{"tokens": [{"token": "%s", "role": "editor"}]}\n' "$BLOBCAST_TOKEN" >"$TMP/config.json"
SRV=bcwan-s$$
CLI=bcwan-c$$
DPID=
RPID=
cleanup() {
	[ -n "$RPID" ] && kill "$RPID" 2>/dev/null || true
	[ -n "$DPID" ] && kill "$DPID" 2>/dev/null || true
	wait 2>/dev/null || true
	ip netns del "$SRV" 2>/dev/null || true
	ip netns del "$CLI" 2>/dev/null || true
	rm -rf "$TMP"
}
trap cleanup EXIT INT TERM
ip netns add "$SRV"
ip netns add "$CLI"
ip link add bcw0 netns "$SRV" type veth peer name bcw1 netns "$CLI"
ip -n "$SRV" addr add 10.77.0.1/24 dev bcw0
ip -n "$CLI" addr add 10.77.0.2/24 dev bcw1
for ns in "$SRV" "$CLI"; do
	ip -n "$ns" link set lo up
done
ip -n "$SRV" link set bcw0 up
ip -n "$CLI" link set bcw1 up

wait_port() { # ns host port
	i=0
	while ! ip netns exec "$1" python3 -c "import socket,sys; socket.create_connection(('$2', $3), 1)" 2>/dev/null; do
		i=$((i + 1))
		[ $i -lt 100 ] || { echo "run.sh: nothing listens on $2:$3" >&2; exit 1; }
		sleep 0.1
	done
}

echo "# $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg), view $SIZE, orbit ${SECS}s at 30 Hz, JPEG q80, downscale $DOWN"
RESULTS=$TMP/results
: >"$RESULTS"
for prof in $PROFILES; do
	mbit=${prof%/*}
	rtt=${prof#*/}
	for ns_dev in "$SRV bcw0" "$CLI bcw1"; do
		set -- $ns_dev
		# burst: a few ms at the rate; latency bounds tbf's own queue.
		ip netns exec "$1" tc qdisc replace dev "$2" root tbf \
			rate "${mbit}mbit" burst 32kb latency 200ms
	done
	for run in $(for e in $ENCODINGS; do for p in $PACES; do echo "$e:$p"; done; done); do
		enc=${run%:*}
		pace=${run#*:}
		flag=
		[ "$pace" = off ] && flag=--no-pace
		rm -rf "$TMP/data"
		ip netns exec "$SRV" "$DAEMON" --listen 10.77.0.1:7878 \
			--data "$TMP/data" --config "$TMP/config.json" \
			--allow-plaintext --log "${BC_WAN_LOG:-error}" $flag &
		DPID=$!
		ip netns exec "$CLI" python3 "$HERE/delay_relay.py" \
			127.0.0.1:7879 10.77.0.1:7878 $((rtt / 2)) &
		RPID=$!
		wait_port "$SRV" 10.77.0.1 7878
		wait_port "$CLI" 127.0.0.1 7879
		line=$(ip netns exec "$CLI" env BC_WAN_SCENE="${BC_WAN_SCENE:-}" "$CLIENT" 127.0.0.1:7879 wan "$SIZE" "$SECS" 30 80 "$DOWN" "$enc")
		echo "$prof $enc $pace $line"
		echo "$prof $enc $pace $line" >>"$RESULTS"
		kill "$RPID" "$DPID" 2>/dev/null || true
		wait "$RPID" "$DPID" 2>/dev/null || true
		RPID=
		DPID=
	done
done
# Debian's python3 (its python3-matplotlib) even where another is first
# on PATH.
PY=python3
[ -x /usr/bin/python3 ] && PY=/usr/bin/python3
"$PY" "$HERE/report.py" "$RESULTS" "$SIZE" "$PLOT"
