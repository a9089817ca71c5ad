#!/usr/bin/env bash
# Runs the browser page on this machine: websockify in front of a
# blobcastd, and a static file server for client/web/, all on 127.0.0.1.
# Prints the page's URL and stops what it started on Ctrl-C (or when one
# of them dies).
#
#   deploy/web-demo.sh [--daemon HOST:PORT] [--session NAME] [--port P]
#                      [--data DIR]
#
# --daemon HOST:PORT fronts a blobcastd that is already running (the one of
# README "Using it", 127.0.0.1:7878): the page shows its sessions. Without
# it the script starts its own blobcastd on P+2 (session "default", the
# built-in scene; --data DIR keeps its sessions, else a temporary
# directory removed at exit). The page is served on P (default 8080),
# websockify listens on P+1 (where the page looks by default). --session
# names the session in the printed URL (default "default"). blobcastd is
# $BLOBCASTD or the first build*/server/blobcastd; websockify and python3
# come from Debian (deploy/install-web-deps.sh). docs/web.md says how to
# put the page behind TLS and tokens.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
port=8080
data=
target=
session=default
while [ $# -gt 0 ]; do
	case "$1" in
	--port) port=${2:?--port needs a number}; shift 2 ;;
	--data) data=${2:?--data needs a directory}; shift 2 ;;
	--daemon) target=${2:?--daemon needs HOST:PORT}; shift 2 ;;
	--session) session=${2:?--session needs a name}; shift 2 ;;
	-h|--help) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
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
case "$session" in
''|.*|*[!A-Za-z0-9._-]*)
	echo "web-demo: --session wants letters, digits, '-', '_', '.'" >&2
	exit 2 ;;
esac
if [ -n "$data" ] && [ -n "$target" ]; then
	echo "web-demo: --data is for the daemon this script starts, not" \
		"with --daemon" >&2
	exit 2
fi
ws_port=$((port + 1))
daemon_port=$((port + 2))

if [ -n "$target" ]; then
	# HOST:PORT or [IPV6]:PORT, as websockify takes its target.
	thost=${target%:*}
	tport=${target##*:}
	case "$tport" in
	''|*[!0-9]*) echo "web-demo: --daemon wants HOST:PORT" >&2; exit 2 ;;
	esac
	[ -n "$thost" ] || { echo "web-demo: --daemon wants HOST:PORT" >&2; exit 2; }
	thost=${thost#[}
	thost=${thost%]}
	if ! timeout 3 bash -c "exec 3<>/dev/tcp/$thost/$tport" 2>/dev/null; then
		echo "web-demo: nothing accepts connections at $target (start" \
			"blobcastd first, or leave out --daemon)" >&2
		exit 1
	fi
fi

daemon=${BLOBCASTD:-}
if [ -z "$daemon" ] && [ -z "$target" ]; then
	for d in "$root"/build*/server/blobcastd; do
		if [ -x "$d" ]; then
			daemon=$d
			break
		fi
	done
fi
if [ -z "$target" ] && { [ -z "$daemon" ] || [ ! -x "$daemon" ]; }; then
	echo "web-demo: blobcastd is not built; build it with" >&2
	echo "  cmake -S $root -B $root/build && cmake --build $root/build --target blobcastd" >&2
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
if [ -z "$data" ] && [ -z "$target" ]; then
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

if [ -z "$target" ]; then
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
	target=127.0.0.1:$daemon_port
	started="blobcastd on :$daemon_port"
else
	started="blobcastd at $target"
fi
websockify "127.0.0.1:$ws_port" "$target" >/dev/null 2>&1 &
pids+=($!)
"$python" -m http.server "$port" --bind 127.0.0.1 \
	--directory "$root/client/web" >/dev/null 2>&1 &
pids+=($!)

# Ready when both listen (websockify and Python take a moment to start,
# seconds on a busy machine). The address is printed only then: a page
# asked for earlier would not load.
listens() {
	timeout 1 bash -c "exec 3<>/dev/tcp/127.0.0.1/$1" 2>/dev/null
}
ready=
for _ in $(seq 600); do
	if listens "$ws_port" && listens "$port"; then
		ready=1
		break
	fi
	for pid in "${pids[@]}"; do
		if ! kill -0 "$pid" 2>/dev/null; then
			echo "web-demo: a server it started exited (is port" \
				"$port or $ws_port taken? try --port)" >&2
			exit 1
		fi
	done
	sleep 0.1
done
if [ -z "$ready" ]; then
	echo "web-demo: websockify on :$ws_port and the page server on" \
		":$port did not listen within a minute" >&2
	exit 1
fi
echo "blobcast web demo: http://127.0.0.1:$port/?session=$session&name=${USER:-guest}"
echo "  ($started, websockify on :$ws_port; Ctrl-C stops what this started)"
# Whichever exits first ends the demo.
wait -n "${pids[@]}" || true
