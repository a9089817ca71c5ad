# Sourced by the viewer's Xvfb tests that drive one window with synthetic
# events (test_viewer_viewonly.sh, test_viewer_fit.sh, test_viewer_model.sh,
# test_viewer_reconnect.sh):
#
#   vl_enter NAME VIEW DAEMON [CHECK XPOKE [CLI]]
#                              first in the script: outside Xvfb it checks
#                              that every program given is built (else
#                              exit 77, skipped) and runs the script again
#                              under xvfb-run; inside, it sets VIEW,
#                              DAEMON, CHECK, XPOKE and CLI (absolute
#                              paths), makes $tmp with tests/scratch.sh
#                              (fail, stop_daemon, the exit traps, which
#                              also stop the viewer) and VIEWENV
#   vl_daemon [ARGS...]        blobcastd on $VL_LISTEN (a free loopback
#                              port unless set) with $tmp/data; sets
#                              $daemon and $port
#   vl_view LOG [ARGS...]      blobcast-view --verbose on that port, stdout
#                              to LOG (stderr to LOG.err); sets $vpid
#   vl_wait LOG PATTERN TENTHS until a line of LOG matches PATTERN (grep -E)
#   vl_lines LOG               how many lines LOG has now
#   vl_wait_after LOG N PATTERN TENTHS
#                              until a line after the first N matches
#   vl_still LOG N TENTHS      waits for a finished picture (a still
#                              frame at level 0, nothing left to refine)
#                              after the first N lines of LOG (count them
#                              before the key that changes the picture),
#                              and a little more in case the viewer asks
#                              for a whole still after a partial one
#   vl_poke COMMAND...         viewer_xpoke on the window; fails the test
#                              when it fails
#   vl_quit                    Q, and the viewer's exit status checked
#                              (0) within 10 s
#
# Each waiting function returns 1 (and says why) when it gives up; the
# callers stop at the first failure, so one broken step is reported once.

vpid=

vl_abspath() {
  case $1 in
    /*|"") echo "$1" ;;
    *) echo "$(pwd)/$1" ;;
  esac
}

vl_enter() {
  vl_name=$1
  shift
  VIEW=$(vl_abspath "${1:-}")
  DAEMON=$(vl_abspath "${2:-}")
  CHECK=$(vl_abspath "${3:-}")
  XPOKE=$(vl_abspath "${4:-}")
  CLI=$(vl_abspath "${5:-}")
  if [ "${BC_VL_INNER:-}" != 1 ]; then
    for prog in "$@"; do
      prog=$(vl_abspath "$prog")
      if [ -z "$prog" ] || [ ! -x "$prog" ]; then
        echo "skip: blobcast-view, blobcastd and the test tools must be" \
          "built (missing: ${prog:-one of them})"
        exit 77
      fi
    done
    if ! command -v xvfb-run > /dev/null 2>&1; then
      echo "skip: xvfb-run not found (Debian package xvfb)"
      exit 77
    fi
    BC_VL_INNER=1 exec xvfb-run -a -s "-screen 0 640x480x24" \
      sh "$0" "$VIEW" "$DAEMON" "$CHECK" "$XPOKE" "$CLI"
  fi
  . "$(dirname "$0")/../scratch.sh"
  bc_scratch "$vl_name" '[ -n "$vpid" ] && kill "$vpid" 2>/dev/null'
  # VIEWENV: how blobcast-view runs here.
  . "$(dirname "$0")/viewer_env.sh"
}

vl_daemon() {
  # A daemon started again appends to the log: read only its own lines.
  from=0
  [ -f "$tmp/daemon.log" ] && from=$(vl_lines "$tmp/daemon.log")
  "$DAEMON" --listen "${VL_LISTEN:-127.0.0.1:0}" --data "$tmp/data" \
    --backend cpu --log warn "$@" >> "$tmp/daemon.log" 2>&1 &
  daemon=$!
  port=
  i=0
  while [ $i -lt 100 ]; do
    port=$(tail -n +"$((from + 1))" "$tmp/daemon.log" | sed -n \
      's/^blobcastd: listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' |
      head -n 1)
    [ -n "$port" ] && return 0
    kill -0 "$daemon" 2>/dev/null || break
    sleep 0.1
    i=$((i + 1))
  done
  fail "blobcastd did not start"
  sed 's/^/    /' "$tmp/daemon.log"
  exit 1
}

vl_view() {
  log=$1
  shift
  $VIEWENV "$VIEW" --server "127.0.0.1:$port" --verbose "$@" \
    > "$log" 2> "$log.err" &
  vpid=$!
}

vl_wait() {
  vl_wait_after "$1" 0 "$2" "$3"
}

vl_lines() {
  wc -l < "$1" | tr -d ' '
}

vl_wait_after() {
  n=0
  while [ $n -lt "$4" ]; do
    tail -n +"$(($2 + 1))" "$1" 2>/dev/null | grep -qE -- "$3" && return 0
    n=$((n + 1))
    sleep 0.1
  done
  fail "no \"$3\" from the viewer after line $2 within $(($4 / 10)) s"
  sed 's/^/    /' "$1" "$1.err" 2>/dev/null | tail -n 30
  return 1
}

vl_still() {
  vl_wait_after "$1" "$2" \
    ' still [a-z]+ image=[0-9x]+ level=0 rects=[0-9]+ bytes=[0-9]+( refresh)?$' \
    "$3" || return 1
  # A partial still is followed by a whole one (docs/viewer.md, "Stills
  # after a gesture"): let it come.
  sleep 0.5
}

vl_poke() {
  "$XPOKE" blobcast-view "$@" || {
    fail "viewer_xpoke $*"
    return 1
  }
}

vl_quit() {
  "$XPOKE" blobcast-view keydown q > /dev/null 2>&1
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
  [ "$rc" -eq 0 ] || {
    fail "the viewer exited $rc"
    sed 's/^/    /' "$log.err"
    return 1
  }
}
