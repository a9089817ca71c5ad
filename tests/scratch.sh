# Sourced by the shell tests that run blobcastd (tests/client, tests/viewer):
# the scratch folder, starting and stopping the daemon, the exit traps, fail()
# and bc_need.
#
#   . "$(dirname "$0")/../scratch.sh"
#   bc_scratch NAME [ON_EXIT]
#
# bc_scratch makes $tmp (/tmp/bc-NAME.XXXXXX) and sets the traps: at exit
# ON_EXIT runs (a command, e.g. killing a viewer the test started), then
# the daemon whose pid is in $daemon stops, then $tmp is removed unless
# BC_KEEP_TMP (or the viewer tests' BC_VIEWER_KEEP) is set; Ctrl-C and
# SIGTERM exit through the same path. fail() says why and counts in
# $failures.

daemon=
failures=0

stop_daemon() {
  if [ -n "$daemon" ]; then
    kill -TERM "$daemon" 2>/dev/null
    wait "$daemon" 2>/dev/null
    daemon=
  fi
}

fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

bc_scratch() {
  tmp=$(mktemp -d "/tmp/bc-$1.XXXXXX") || exit 1
  bc_on_exit=${2:-:}
  trap 'eval "$bc_on_exit"; stop_daemon
    [ -n "${BC_KEEP_TMP:-}${BC_VIEWER_KEEP:-}" ] || rm -rf "$tmp"' EXIT
  trap 'exit 1' INT TERM
}

# bc_need PROG...: exits 77 (skipped) unless every PROG is an executable
# that has been built.
bc_need() {
  for prog in "$@"; do
    if [ -z "$prog" ] || [ ! -x "$prog" ]; then
      echo "skip: blobcast and blobcastd must both be built"
      exit 77
    fi
  done
}

# start_daemon ADDR [OPTION...]: starts $BLOBCASTD on ADDR (CPU backend,
# data in $tmp/data, log appended to $tmp/daemon.log, the OPTIONs after
# those), sets $daemon and $port; exits 1 with the log when it does not
# start.
start_daemon() {
  bc_addr=$1
  shift
  # The port is read from what this start adds to the log (a restart
  # must not take the previous daemon's).
  bc_from=1
  [ -f "$tmp/daemon.log" ] && bc_from=$(($(wc -c < "$tmp/daemon.log") + 1))
  "$BLOBCASTD" --listen "$bc_addr" --data "$tmp/data" --backend cpu \
    --log warn "$@" >> "$tmp/daemon.log" 2>&1 &
  daemon=$!
  port=
  i=0
  while [ $i -lt 100 ]; do
    port=$(tail -c +"$bc_from" "$tmp/daemon.log" | sed -n \
      's/^blobcastd: listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' |
      tail -n 1)
    [ -n "$port" ] && break
    kill -0 "$daemon" 2>/dev/null || break
    sleep 0.1
    i=$((i + 1))
  done
  if [ -z "$port" ]; then
    echo "FAIL: blobcastd did not start"
    sed 's/^/    /' "$tmp/daemon.log"
    exit 1
  fi
}
