#!/bin/sh
# blobcast-view --screenshot when the picture never finishes, and the VIEW
# size against the framebuffer, under Xvfb against a private blobcastd with
# a frame budget of 1 ms (loopback, temporary data directory):
#  1. a crawling scene (a twist at a rate of 10^6): the daemon sends a few
#     INCOMPLETE level-1 frames and then stops refining. The viewer must
#     exit by itself (well within the hang guard) with status 5, say on
#     stderr which level and INCOMPLETE, and write a PNG of the window's
#     size that shows the amber "refining" tag; its VIEW is the
#     framebuffer's size;
#  2. the same with --screenshot-wait 1: the wait runs out first (status
#     5, "after 1 s" or "within 1 s" on stderr);
#  3. a window wider than the daemon's max_dim (4096): the VIEW keeps the
#     framebuffer's aspect ratio under the cap, stderr says so once, and
#     the screenshot is the framebuffer's size.
#
# usage: test_viewer_shot.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK
# Exits 77 (skipped) when xvfb-run, the viewer or the daemon is missing.
# BC_VIEWER_KEEP=1 keeps the temporary directory.
set -u

abspath() {
  case $1 in
    /*|"") echo "$1" ;;
    *) echo "$(pwd)/$1" ;;
  esac
}
VIEW=$(abspath "${1:-}")
DAEMON=$(abspath "${2:-}")
CHECK=$(abspath "${3:-}")

for prog in "$VIEW" "$DAEMON" "$CHECK"; do
  if [ -z "$prog" ] || [ ! -x "$prog" ]; then
    echo "skip: blobcast-view, blobcastd and viewer_imgcheck must be built"
    exit 77
  fi
done
if ! command -v xvfb-run > /dev/null 2>&1; then
  echo "skip: xvfb-run not found (Debian package xvfb)"
  exit 77
fi

# The hang guard of one viewer run, in seconds: generous, since before the
# fix the viewer waited forever; a run takes seconds.
GUARD=120

. "$(dirname "$0")/../scratch.sh"
bc_scratch viewer-shot

# VIEWENV: how blobcast-view runs here (viewer_env.sh).
. "$(dirname "$0")/viewer_env.sh"

# A scene whose rays crawl: every ray runs out of field evaluations, so
# the picture stays INCOMPLETE once the daemon has retried what it allows.
mkdir -p "$tmp/data/sessions/crawl"
cat > "$tmp/data/sessions/crawl/snap-0.json" <<'EOF'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "twist", "id": 1, "rate": 1000000, "children": [
   {"type": "box", "id": 2, "half_extents": [1, 1, 1]}]}}
EOF

BLOBCASTD=$DAEMON
start_daemon 127.0.0.1:0 --frame-budget 1
echo "blobcastd --frame-budget 1 on 127.0.0.1:$port"

# shot NAME SCREEN ARGS...: one viewer run under Xvfb (screen SCREEN) and
# the hang guard; stdout to NAME.log, stderr to NAME.err, the status in
# $rc and the seconds taken in $took.
shot() {
  name=$1
  screen=$2
  shift 2
  t0=$(date +%s)
  timeout -k 5 $GUARD xvfb-run -a -s "-screen 0 ${screen}x24" \
    $VIEWENV "$VIEW" --server "127.0.0.1:$port" --verbose "$@" \
    > "$tmp/$name.log" 2> "$tmp/$name.err"
  rc=$?
  took=$(($(date +%s) - t0))
  echo "     $name: status $rc after ${took} s"
}
show() {
  sed 's/^/    /' "$tmp/$1.err"
  grep -v '^frame ' "$tmp/$1.log" | sed 's/^/    /'
}

# --- 1. the picture that stays INCOMPLETE -----------------------------------
shot crawl 640x480 --session crawl --size 320x240 --screenshot "$tmp/crawl.png"
if [ $rc -eq 124 ] || [ $rc -eq 137 ]; then
  fail "--screenshot of a picture that stays INCOMPLETE did not return" \
    "within $GUARD s"
  show crawl
elif [ $rc -ne 5 ]; then
  fail "--screenshot of an unfinished picture exited $rc, not 5"
  show crawl
else
  ok=1
  grep -q 'not finished: level [0-3], INCOMPLETE' "$tmp/crawl.err" || {
    fail "stderr does not say the level and INCOMPLETE"
    ok=
  }
  grep -q '^frame .* incomplete$' "$tmp/crawl.log" || {
    fail "no frame was INCOMPLETE: the scene no longer tests this"
    ok=
  }
  info=$("$CHECK" info "$tmp/crawl.png" 2>&1)
  echo "     crawl.png: $info (width height colours stddev)"
  echo "$info" | awk '{ exit !($1 == 320 && $2 == 240) }' || {
    fail "crawl.png is not a 320x240 image"
    ok=
  }
  # The amber tag at the bottom right: "refining (level 1, cut by budget)".
  amber=$("$CHECK" count "$tmp/crawl.png" 242 184 74 12)
  [ "${amber:-0}" -ge 40 ] || {
    fail "the screenshot does not show the refining tag ($amber pixels)"
    ok=
  }
  grep -q '^view 320x240 framebuffer 320x240 ' "$tmp/crawl.log" || {
    fail "the VIEW is not the framebuffer's size: $(grep '^view' "$tmp/crawl.log")"
    ok=
  }
  [ -n "$ok" ] && echo "ok   --screenshot of a picture that stays INCOMPLETE:" \
    "$(sed -n 's/^blobcast-view: picture 1 of 1 not finished: \(.*\);.*/\1/p' \
      "$tmp/crawl.err")"
fi

# --- 2. --screenshot-wait runs out first -----------------------------------
shot wait 640x480 --session crawl --size 160x120 --screenshot-wait 1 \
  --screenshot "$tmp/wait.png"
if [ $rc -ne 5 ]; then
  fail "--screenshot-wait 1 exited $rc, not 5"
  show wait
elif ! grep -q 'not finished: .*\(after\|within\) 1 s' "$tmp/wait.err"; then
  fail "--screenshot-wait 1: stderr does not say the wait ran out"
  show wait
elif ! "$CHECK" info "$tmp/wait.png" | awk '{ exit !($1 == 160 && $2 == 120) }'
then
  fail "wait.png is not a 160x120 image"
else
  echo "ok   --screenshot-wait 1 in ${took} s"
fi

# --- 3. a framebuffer wider than the daemon renders -----------------------------
# blobcastd's max_dim is 4096 (BC_SRV_MAX_DIM): 4200x60 becomes 4096x59.
shot wide 4400x300 --session crawl --size 4200x60 --screenshot-wait 20 \
  --screenshot "$tmp/wide.png"
if [ $rc -ne 0 ] && [ $rc -ne 5 ]; then
  fail "a 4200x60 window: exited $rc"
  show wide
else
  ok=1
  grep -q '^view 4096x59 framebuffer 4200x60 .* capped$' "$tmp/wide.log" || {
    fail "a 4200x60 framebuffer did not ask for 4096x59:" \
      "$(grep '^view' "$tmp/wide.log")"
    ok=
  }
  n=$(grep -c 'the daemon renders at most 4096 a side' "$tmp/wide.err")
  [ "$n" -eq 1 ] || {
    fail "the cap was said $n times on stderr, not once"
    show wide
    ok=
  }
  "$CHECK" info "$tmp/wide.png" | awk '{ exit !($1 == 4200 && $2 == 60) }' || {
    fail "wide.png is not the framebuffer's 4200x60"
    ok=
  }
  [ -n "$ok" ] && echo "ok   a 4200x60 framebuffer: VIEW 4096x59, said once," \
    "screenshot 4200x60"
fi

stop_daemon
if [ $failures -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all screenshot checks passed"
exit 0
