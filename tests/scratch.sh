# Sourced by the shell tests that run blobcastd (tests/client, tests/viewer):
# the scratch folder, stopping the daemon and the exit traps, and fail().
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
