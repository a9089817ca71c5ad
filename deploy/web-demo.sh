#!/usr/bin/env bash
# Runs the browser demo on this machine: blobcastd (session "default" with
# the built-in scene), websockify in front of it, and a static file server
# for client/web/, all on 127.0.0.1. Prints the page's URL and stops all
# three on Ctrl-C (or when one of them dies).
#
#   deploy/web-demo.sh [--port P] [--data DIR]
#
# The page is served on P (default 8080), websockify listens on P+1 (where
# the page looks by default) and blobcastd on P+2. Without --data the
# session lives in a temporary directory removed at exit. blobcastd is
# $BLOBCASTD or the first build*/server/blobcastd; websockify and python3
# come from Debian (deploy/install-web-deps.sh).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
port=8080
data=
while [ $# -gt 0 ]; do
	case "$1" in
	--port) port=${2:?--port needs a number}; shift 2 ;;
	--data) data=${2:?--data needs a directory}; shift 2 ;;
	-h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
	*) echo "web-demo: unknown argument $1 (try --help)" >&2; exit 2 ;;
	esac
done
case "$port" in
''|*[!0-9]*) echo "web-demo: --port wants a number" >&2; exit 2 ;;
esac
if [ "$port" -lt 1024 ] || [ "$port" -gt 65533 ]; then
	echo "web-demo: --port must be 1024..65533" >&2
	exit 2
fi
ws_port=$((port + 1))
daemon_port=$((port + 2))

daemon=${BLOBCASTD:-}
if [ -z "$daemon" ]; then
	for d in "$root"/build*/server/blobcastd; do
		if [ -x "$d" ]; then
			daemon=$d
			break
		fi
	done
fi
if [ -z "$daemon" ] || [ ! -x "$daemon" ]; then
	echo "web-demo: blobcastd is not built; build it with" >&2
	echo "  cmake -S $root -B $root/build -G Ninja && cmake --build $root/build --target blobcastd" >&2
	exit 1
fi
for tool in websockify python3; do
	if ! command -v "$tool" >/dev/null 2>&1; then
		echo "web-demo: $tool is missing (deploy/install-web-deps.sh)" >&2
		exit 1
	fi
done
# Debian's python3 (PLATFORM.md: a python3 earlier on PATH may not be it).
python=/usr/bin/python3
[ -x "$python" ] || python=$(command -v python3)

tmp=
if [ -z "$data" ]; then
	tmp=$(mktemp -d /tmp/blobcast-demo.XXXXXX)
	data=$tmp
fi
pids=()
stop() {
	trap - INT TERM EXIT
	for pid in "${pids[@]}"; do
		kill "$pid" 2>/dev/null || true
	done
	for pid in "${pids[@]}"; do
		wait "$pid" 2>/dev/null || true
	done
	[ -n "$tmp" ] && rm -rf "$tmp"
	echo "web-demo: stopped" >&2
}
trap stop INT TERM EXIT

log=$(mktemp /tmp/blobcast-demo-log.XXXXXX)
"$daemon" --listen "127.0.0.1:$daemon_port" --data "$data" 2>"$log" &
pids+=($!)
for _ in $(seq 100); do
	grep -q 'listening on' "$log" && break
	if ! kill -0 "${pids[0]}" 2>/dev/null; then
		cat "$log" >&2
		rm -f "$log"
		exit 1
	fi
	sleep 0.1
done
rm -f "$log"
websockify "127.0.0.1:$ws_port" "127.0.0.1:$daemon_port" >/dev/null 2>&1 &
pids+=($!)
"$python" -m http.server "$port" --bind 127.0.0.1 \
	--directory "$root/client/web" >/dev/null 2>&1 &
pids+=($!)

sleep 0.5
echo "blobcast web demo: http://127.0.0.1:$port/?session=default&name=${USER:-guest}"
echo "  (blobcastd on :$daemon_port, websockify on :$ws_port; Ctrl-C stops all)"
# Whichever exits first ends the demo.
wait -n "${pids[@]}" || true
