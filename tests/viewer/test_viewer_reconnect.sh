#!/bin/sh
# blobcast-view across a daemon restart, under Xvfb: the viewer joins a
# private blobcastd (loopback, temporary data directory) and shows a frame;
# the daemon is stopped (SIGTERM, it saves the session) and started again
# on the same port a second later. The viewer must say it lost the
# connection, fail at least one attempt while the daemon is down, rejoin
# the session once it is back, and show a new frame of the restarted
# daemon (frame_no 1 again: frame numbers count per connection); Q then
# quits it with status 0.
#
# usage: test_viewer_reconnect.sh BLOBCAST-VIEW BLOBCASTD XPOKE
# Exits 77 (skipped) when xvfb-run, the viewer, the daemon or xpoke is
# missing.
set -u

abspath() {
  case $1 in
    /*|"") echo "$1" ;;
    *) echo "$(pwd)/$1" ;;
  esac
}
VIEW=$(abspath "${1:-}")
DAEMON=$(abspath "${2:-}")
XPOKE=$(abspath "${3:-}")

if [ "${BC_RECONNECT_INNER:-}" != 1 ]; then
  for prog in "$VIEW" "$DAEMON" "$XPOKE"; do
    if [ -z "$prog" ] || [ ! -x "$prog" ]; then
      echo "skip: blobcast-view, blobcastd and viewer_xpoke must be built"
      exit 77
    fi
  done
  if ! command -v xvfb-run > /dev/null 2>&1; then
    echo "skip: xvfb-run not found (Debian package xvfb)"
    exit 77
  fi
  BC_RECONNECT_INNER=1 exec xvfb-run -a sh "$0" "$VIEW" "$DAEMON" "$XPOKE"
fi

# --- inside Xvfb ---------------------------------------------------------------
vpid=
. "$(dirname "$0")/../scratch.sh"
bc_scratch viewer-rc '[ -n "$vpid" ] && kill "$vpid" 2>/dev/null'

# VIEWENV: how blobcast-view runs here (viewer_env.sh).
. "$(dirname "$0")/viewer_env.sh"

# start_daemon ADDR: blobcastd on ADDR; sets $port.
start_daemon() {
  "$DAEMON" --listen "$1" --data "$tmp/data" --backend cpu --log warn \
    >> "$tmp/daemon.log" 2>&1 &
  daemon=$!
  port=
  i=0
  while [ $i -lt 100 ]; do
    port=$(sed -n 's/^blobcastd: listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' \
      "$tmp/daemon.log" | tail -n 1)
    [ -n "$port" ] && return 0
    kill -0 "$daemon" 2>/dev/null || break
    sleep 0.1
    i=$((i + 1))
  done
  echo "FAIL: blobcastd did not start"
  sed 's/^/    /' "$tmp/daemon.log"
  exit 1
}

# wait_for PATTERN TENTHS: until a line of the viewer's log matches.
wait_for() {
  n=0
  while [ $n -lt "$2" ]; do
    grep -qE -- "$1" "$tmp/v.log" 2>/dev/null && return 0
    n=$((n + 1))
    sleep 0.1
  done
  fail "no \"$1\" from the viewer after $(($2 / 10)) s"
  return 1
}

start_daemon 127.0.0.1:0
$VIEWENV "$VIEW" --server "127.0.0.1:$port" --session default \
  --size 160x120 --verbose > "$tmp/v.log" 2> "$tmp/v.err" &
vpid=$!
wait_for '^frame 1 ' 300
stop_daemon
wait_for '^lost ' 100
# Down for a second: the 250 ms first attempt meets a closed port.
sleep 1
start_daemon "127.0.0.1:$port"
wait_for '^rejoined default attempts=[1-9][0-9]*$' 150
# The first frame of the new connection (frame numbers restart at 1), as
# the viewer's second frame or later.
wait_for '^frame [2-9][0-9]* no=1 ' 300
[ "$failures" -eq 0 ] && sleep 0.3
"$XPOKE" blobcast-view keydown q || fail "xpoke"
n=0
while kill -0 "$vpid" 2>/dev/null && [ $n -lt 100 ]; do
  sleep 0.1
  n=$((n + 1))
done
if kill -0 "$vpid" 2>/dev/null; then
  fail "Q did not close the viewer"
  kill "$vpid"
fi
wait "$vpid"
rc=$?
vpid=
[ "$rc" -eq 0 ] || fail "the viewer exited $rc"
sed 's/^/    /' "$tmp/v.log" "$tmp/v.err" | grep -v '^    applied\|^    latency'
if [ "$failures" -eq 0 ]; then
  echo "all checks passed"
  exit 0
fi
exit 1
