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
# usage: test_viewer_reconnect.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE
# Exits 77 (skipped) when xvfb-run, the viewer, the daemon or xpoke is
# missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-rc "$@"

VL_LISTEN=127.0.0.1:0 vl_daemon
L=$tmp/v.log
vl_view "$L" --session default --size 160x120
vl_wait "$L" '^frame 1 ' 300
stop_daemon
vl_wait "$L" '^lost ' 100
# Down for a second: the 250 ms first attempt meets a closed port.
sleep 1
VL_LISTEN=127.0.0.1:$port vl_daemon
vl_wait "$L" '^rejoined default attempts=[1-9][0-9]*$' 150
# The first frame of the new connection (frame numbers restart at 1), as
# the viewer's second frame or later.
vl_wait "$L" '^frame [2-9][0-9]* no=1 ' 300
[ "$failures" -eq 0 ] && sleep 0.3
vl_quit
sed 's/^/    /' "$L" "$L.err" | grep -v '^    applied\|^    latency'
if [ "$failures" -eq 0 ]; then
  echo "all checks passed"
  exit 0
fi
exit 1
