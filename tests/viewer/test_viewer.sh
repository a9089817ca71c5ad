#!/bin/sh
# blobcast-view against a private blobcastd (free loopback port, temporary
# data directory), under Xvfb:
#  1. `xvfb-run -a blobcast-view ... --screenshot x.png --frames 2`: the
#     program exits 0 and the PNG has the window's size and is not blank;
#  2. without the overlay, the window shows exactly the picture received
#     (screenshot against --dump-frame), on GL 2.1 with JPEG frames and on
#     GLES 2 with H.264 frames (--encoding h264: three pictures, each frame
#     acknowledged after it was drawn when the daemon grants ACKS);
#  3. with synthetic X events (viewer_xpoke): a press on a sphere picks it,
#     a drag moves it, Shift+wheel grows it, Ctrl+wheel changes its
#     operator's blend, S saves a lossless snapshot (and with
#     --snapshot-size a 1100x300 picture in tiles), Ctrl-S and
#     Ctrl-Shift-S the scene as JSON and binary files (equal to the
#     daemon's scene, read back below), Ctrl-M and Ctrl-Shift-M its
#     solid as glTF and OBJ meshes (equal to `blobcast mesh --session`'s
#     of the daemon's scene), P a screenshot showing
#     the selection's outline, Ctrl-Z / Ctrl-Shift-Z / Ctrl-Y undo and
#     redo the last step (the verbose undo/redo lines name the same edit),
#     Shift-F presents and Shift-F again stops (the verbose presenter
#     lines), Alt+wheel on the sphere (no unary node above it) only says
#     so, a click selects a bar under a mirror under a twist and
#     Alt+wheel steps the twist's rate, Q quits; the daemon's saved scene
#     then holds the new position, radius, blend and twist rate, and the
#     mirror and the bar as they were (read back through a restarted
#     daemon with the CLI BLOBCAST).
#
# usage: test_viewer.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK [XPOKE [BLOBCAST]]
# Exits 77 (skipped) when xvfb-run, the viewer or the daemon is missing;
# part 3 is skipped (and said so) without XPOKE. BC_VIEWER_SCREENSHOT=FILE
# copies part 3's screenshot there (docs/viewer.png).
set -u

if [ "${1:-}" = "--inner" ]; then
  inner=1
  shift
else
  inner=
fi
# abspath P: P made absolute (part 3 changes directory); "" stays "".
abspath() {
  case $1 in
    /*|"") echo "$1" ;;
    *) echo "$(pwd)/$1" ;;
  esac
}
VIEW=$(abspath "${1:-}")
DAEMON=$(abspath "${2:-}")
CHECK=$(abspath "${3:-}")
XPOKE=$(abspath "${4:-}")
CLI=$(abspath "${5:-}")

# --- part 3, run inside xvfb-run by the outer script -------------------------
# usage: test_viewer.sh --inner VIEW DAEMON CHECK XPOKE TMP PORT
if [ -n "$inner" ]; then
  tmp=$5
  port=$6
  # wait_for PATTERN FILE TENTHS: until a line of FILE matches PATTERN.
  wait_for() {
    n=0
    while [ $n -lt "$3" ]; do
      grep -q -- "$1" "$2" 2>/dev/null && return 0
      n=$((n + 1))
      sleep 0.1
    done
    echo "FAIL: no \"$1\" in $2 after $(($3 / 10)) s"
    sed 's/^/    /' "$2"
    return 1
  }
  cd "$tmp" || exit 1
  $VIEWENV "$VIEW" --server "127.0.0.1:$port" --session drag \
    --size 320x240 --verbose --snapshot-dir "$tmp" \
    > "$tmp/drag.log" 2> "$tmp/drag.err" &
  vpid=$!
  ok=1
  poke() {
    "$XPOKE" blobcast-view "$@" || ok=
  }
  wait_for '^frame 1 ' "$tmp/drag.log" 300 || ok=
  # The sphere's centre projects to (102, 120) in the 320x240 view.
  [ -n "$ok" ] && poke wait 5000 move 102 120 down 1 sleep 300 \
    drag 182 120 16 sleep 100 up 1
  [ -n "$ok" ] && wait_for '^latency ' "$tmp/drag.log" 200 || ok=
  [ -n "$ok" ] && poke keydown Shift_L wheel 3 keyup Shift_L sleep 700 \
    keydown Control_L wheel -2 keyup Control_L sleep 700 key s
  [ -n "$ok" ] && wait_for '^snapshot ' "$tmp/drag.log" 200 || ok=
  # The last still frame before the screenshot: wait for the daemon to
  # settle, then P.
  [ -n "$ok" ] && sleep 1 && poke key p
  [ -n "$ok" ] && wait_for '^screenshot ' "$tmp/drag.log" 200 || ok=
  # Ctrl-Z takes back the blend (the last step), Ctrl-Shift-Z applies it
  # again; Ctrl-Z and Ctrl-Y once more: the blend checked below stays.
  [ -n "$ok" ] && poke keydown Control_L key z keyup Control_L
  [ -n "$ok" ] && wait_for '^undo order=[0-9]* of=' "$tmp/drag.log" 200 || ok=
  [ -n "$ok" ] && poke keydown Control_L keydown Shift_L key z \
    keyup Shift_L keyup Control_L
  [ -n "$ok" ] && wait_for '^redo order=[0-9]* of=' "$tmp/drag.log" 200 || ok=
  [ -n "$ok" ] && poke keydown Control_L key z keyup Control_L sleep 300 \
    keydown Control_L key y keyup Control_L
  if [ -n "$ok" ]; then
    n=0
    while [ "$(grep -c '^redo order=' "$tmp/drag.log")" -lt 2 ] &&
      [ $n -lt 200 ]; do
      sleep 0.1
      n=$((n + 1))
    done
    [ "$(grep -c '^undo order=' "$tmp/drag.log")" -eq 2 ] &&
      [ "$(grep -c '^redo order=' "$tmp/drag.log")" -eq 2 ] || {
      echo "FAIL: Ctrl-Z, Ctrl-Shift-Z, Ctrl-Z, Ctrl-Y: not 2 undos and 2 redos"
      sed 's/^/    /' "$tmp/drag.log"
      ok=
    }
    # Each redo takes again the edit its undo took back.
    u=$(sed -n 's/^undo order=[0-9]* of=\([0-9]*\) .*/\1/p' "$tmp/drag.log" |
      sort -u)
    r=$(sed -n 's/^redo order=[0-9]* of=\([0-9]*\) .*/\1/p' "$tmp/drag.log" |
      sort -u)
    [ -n "$u" ] && [ "$u" = "$r" ] || {
      echo "FAIL: undo of=$u but redo of=$r"
      ok=
    }
  fi
  # Shift-F presents (the verbose line names this member as presenter),
  # Shift-F again stops; F with nobody presenting sends nothing.
  [ -n "$ok" ] && poke keydown Shift_L key f keyup Shift_L
  [ -n "$ok" ] && wait_for '^presenter [1-9][0-9]* following=0' \
    "$tmp/drag.log" 200 || ok=
  # (The first "presenter 0" line answered the join: nobody presented.)
  [ -n "$ok" ] && poke keydown Shift_L key f keyup Shift_L
  if [ -n "$ok" ]; then
    n=0
    while [ "$(grep -c '^presenter 0 following=0' "$tmp/drag.log")" -lt 2 ] &&
      [ $n -lt 200 ]; do
      sleep 0.1
      n=$((n + 1))
    done
    [ "$(grep -c '^presenter 0 following=0' "$tmp/drag.log")" -eq 2 ] || {
      echo "FAIL: Shift-F did not stop the presentation"
      sed 's/^/    /' "$tmp/drag.log"
      ok=
    }
  fi
  # Alt+wheel: nothing above the sphere has a value to change (a note,
  # no edit); the bar's centre projects to (160, 39), and above it the
  # mirror is passed over for the twist. Its final edit leaves 250 ms
  # after the last notch.
  [ -n "$ok" ] && poke keydown Alt_L wheel 1 keyup Alt_L
  [ -n "$ok" ] && wait_for '^status no unary node with a value above #2$' \
    "$tmp/drag.log" 200 || ok=
  [ -n "$ok" ] && poke move 160 39 down 1 sleep 200 up 1
  [ -n "$ok" ] && wait_for '^pick node=4$' "$tmp/drag.log" 200 || ok=
  [ -n "$ok" ] && poke keydown Alt_L wheel 3 keyup Alt_L sleep 700
  # Q closes the window on its press: no release to send to a window
  # that is gone.
  poke keydown q
  n=0
  while kill -0 "$vpid" 2>/dev/null && [ $n -lt 100 ]; do
    sleep 0.1
    n=$((n + 1))
  done
  if kill -0 "$vpid" 2>/dev/null; then
    echo "FAIL: Q did not close the viewer"
    kill "$vpid"
    ok=
  fi
  wait "$vpid"
  rc=$?
  if [ "$rc" -ne 0 ]; then
    echo "FAIL: the viewer exited $rc"
    sed 's/^/    /' "$tmp/drag.err"
    ok=
  fi
  # With --snapshot-size S asks for a picture larger than the window in
  # tiles (two of 1024 across) while the window keeps drawing.
  mkdir -p "$tmp/big"
  $VIEWENV "$VIEW" --server "127.0.0.1:$port" --session drag \
    --size 160x120 --verbose --snapshot-dir "$tmp/big" \
    --snapshot-size 1100x300 > "$tmp/big.log" 2> "$tmp/big.err" &
  vpid=$!
  [ -n "$ok" ] && wait_for '^frame 1 ' "$tmp/big.log" 300 || ok=
  [ -n "$ok" ] && poke wait 5000 key s
  [ -n "$ok" ] && wait_for '^snapshot .* 1100x300$' "$tmp/big.log" 600 || ok=
  # Ctrl-S and Ctrl-Shift-S save the scene (checked against the daemon's
  # below).
  [ -n "$ok" ] && poke keydown Control_L key s keyup Control_L
  [ -n "$ok" ] && wait_for '^scene .*/blobcast-drag-[0-9]*\.json order=' \
    "$tmp/big.log" 200 || ok=
  [ -n "$ok" ] && poke keydown Control_L keydown Shift_L key s \
    keyup Shift_L keyup Control_L
  [ -n "$ok" ] && wait_for '^scene .*/blobcast-drag-[0-9]*\.bin order=' \
    "$tmp/big.log" 200 || ok=
  # Ctrl-M and Ctrl-Shift-M: the solid as glTF and OBJ meshes, made on a
  # thread while the window goes on (compared with `blobcast mesh
  # --session` below).
  [ -n "$ok" ] && poke keydown Control_L key m keyup Control_L
  [ -n "$ok" ] && wait_for \
    '^mesh .*/blobcast-drag-[0-9]*\.glb vertices=[1-9][0-9]* triangles=[1-9]' \
    "$tmp/big.log" 600 || ok=
  [ -n "$ok" ] && poke keydown Control_L keydown Shift_L key m \
    keyup Shift_L keyup Control_L
  [ -n "$ok" ] && wait_for \
    '^mesh .*/blobcast-drag-[0-9]*\.obj vertices=[1-9][0-9]* triangles=[1-9]' \
    "$tmp/big.log" 600 || ok=
  poke keydown q
  n=0
  while kill -0 "$vpid" 2>/dev/null && [ $n -lt 100 ]; do
    sleep 0.1
    n=$((n + 1))
  done
  kill "$vpid" 2>/dev/null
  wait "$vpid" || { echo "FAIL: the second viewer exited $?"; ok=; }
  [ -n "$ok" ]
  exit $?
fi

# --- the outer script ----------------------------------------------------------
for prog in "$VIEW" "$DAEMON"; do
  if [ -z "$prog" ] || [ ! -x "$prog" ]; then
    echo "skip: blobcast-view and blobcastd must both be built"
    exit 77
  fi
done
if ! command -v xvfb-run > /dev/null 2>&1; then
  echo "skip: xvfb-run not found (Debian package xvfb)"
  exit 77
fi

. "$(dirname "$0")/../scratch.sh"
bc_scratch viewer

# VIEWENV: how blobcast-view runs here (viewer_env.sh).
. "$(dirname "$0")/viewer_env.sh"
export VIEWENV

# The scene of part 3: a red sphere, a blue box and a green bar (a box
# under a mirror under a twist) in a smooth union, seen from (0, 0, 6); the
# session exists on disk before the daemon starts.
mkdir -p "$tmp/data/sessions/drag"
cat > "$tmp/data/sessions/drag/snap-0.json" <<'EOF'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "smooth_union", "id": 1, "blend": 0.3, "range": 0.4,
          "children": [
   {"type": "sphere", "id": 2, "radius": 0.8, "translate": [-1.2, 0, 0],
    "color": [0.9, 0.25, 0.2]},
   {"type": "box", "id": 3, "half_extents": [0.6, 0.6, 0.6],
    "translate": [1.3, 0, 0], "color": [0.2, 0.45, 0.9]},
   {"type": "twist", "id": 5, "rate": 0.5, "children": [
    {"type": "mirror", "id": 6, "axes": "x", "children": [
     {"type": "box", "id": 4, "half_extents": [0.8, 0.3, 0.3],
      "translate": [0, 1.6, 0], "color": [0.3, 0.8, 0.35]}]}]}]}}
EOF

BLOBCASTD=$DAEMON
start_daemon 127.0.0.1:0
echo "blobcastd on 127.0.0.1:$port"

# image_ok FILE W H: FILE is a W x H image with many colours and contrast.
image_ok() {
  set -- "$1" "$2" "$3" "$("$CHECK" info "$1" 2>&1)"
  echo "     $1: $4 (width height colours stddev)"
  echo "$4" | awk -v w="$2" -v h="$3" \
    '{ exit !($1 == w && $2 == h && $3 >= 200 && $4 >= 8.0) }'
}

# --- 1. the screenshot the issue asks for ------------------------------------------
xvfb-run -a $VIEWENV "$VIEW" --server "127.0.0.1:$port" --session default \
  --size 320x240 --screenshot "$tmp/x.png" --frames 2 \
  > "$tmp/1.log" 2>&1
rc=$?
if [ $rc -ne 0 ]; then
  fail "blobcast-view --screenshot exited $rc"
  sed 's/^/    /' "$tmp/1.log"
elif [ ! -s "$tmp/x.png" ]; then
  fail "no screenshot written"
elif ! image_ok "$tmp/x.png" 320 240; then
  fail "x.png is blank or not 320x240"
else
  echo "ok   --screenshot x.png --frames 2"
fi

# --- 2. the window shows the picture received -----------------------------------------
# Mesa can pretend to be an old driver: GL 2.1 with GLSL 1.10, and GLES 2.0.
for api in gl gles; do
  if [ $api = gles ]; then
    flag=--gles
    version="^gl OpenGL ES 2\.0 "
  else
    flag=
    version="^gl 2\.1 "
  fi
  # The GLES run joins as a viewer (looking needs no editor rights) and
  # watches H.264.
  role=editor
  encoding=jpeg
  if [ $api = gles ]; then
    role=viewer
    encoding=h264
  fi
  xvfb-run -a env MESA_GL_VERSION_OVERRIDE=2.1 MESA_GLSL_VERSION_OVERRIDE=110 \
    MESA_GLES_VERSION_OVERRIDE=2.0 $VIEWENV "$VIEW" \
    --server "127.0.0.1:$port" --session default --verbose --role $role \
    --encoding $encoding --size 288x216 --no-overlay --frames 3 --turn 20 \
    $flag \
    --screenshot "$tmp/$api.png" --dump-frame "$tmp/$api-frame.png" \
    > "$tmp/2-$api.log" 2>&1
  rc=$?
  if [ $rc -ne 0 ]; then
    fail "$api: blobcast-view exited $rc"
    sed 's/^/    /' "$tmp/2-$api.log"
  elif ! grep -q "^frame .* $encoding image=288x216 " "$tmp/2-$api.log"; then
    fail "$api: no $encoding frame of 288x216 in the verbose log"
    sed 's/^/    /' "$tmp/2-$api.log"
  elif ! grep -q "$version" "$tmp/2-$api.log"; then
    fail "$api: not the context asked for: $(grep '^gl ' "$tmp/2-$api.log")"
  elif ! image_ok "$tmp/$api.png" 288 216; then
    fail "$api: the screenshot is blank or not 288x216"
  elif ! "$CHECK" same "$tmp/$api.png" "$tmp/$api-frame.png" 2; then
    fail "$api: the window differs from the frame received"
  else
    echo "ok   $(grep '^gl ' "$tmp/2-$api.log" | cut -d'|' -f1): the window" \
      "is the frame received, pixel for pixel"
  fi
done
# Three frames after two 20-degree turns are not the first picture.
if "$CHECK" same "$tmp/gl.png" "$tmp/x.png" 2 > /dev/null 2>&1; then
  fail "--turn did not turn the camera"
fi

# --- 3. direct manipulation ---------------------------------------------------------------
if [ -z "$XPOKE" ] || [ ! -x "$XPOKE" ]; then
  echo "skip: direct manipulation (viewer_xpoke was not built: no Xlib)"
else
  if xvfb-run -a -s "-screen 0 640x480x24" sh "$0" --inner "$VIEW" \
     "$DAEMON" "$CHECK" "$XPOKE" "$tmp" "$port"; then
    echo "ok   pick, drag, Shift+wheel, Ctrl+wheel, S, P, Ctrl-Z/Y, Shift-F," \
      "Alt+wheel, Ctrl-S, Ctrl-M and Q"
  else
    fail "direct manipulation"
  fi
  log=$tmp/drag.log
  grep -q '^pick node=2$' "$log" || fail "the press did not pick the sphere"
  # Edit -> frame latencies the viewer measured (ms), for the record: per
  # frame, of the newest edit it shows and of the oldest.
  sed -n 's/^latency edits=[0-9]* last_ms=\([0-9.]*\) oldest_ms=\([0-9.]*\)$/\1 \2/p' \
    "$log" | sort -n | awk '{ v[NR] = $1; if ($2 > worst) worst = $2 } END {
      if (NR) printf "     edit -> frame latency over %d frames: newest " \
        "edit median %.1f ms, max %.1f ms; oldest edit max %.1f ms\n",
        NR, v[int((NR + 1) / 2)], v[NR], worst;
      else print "     no edit -> frame latency measured" }'
  shot=$tmp/blobcast-view-001.png
  snap=$tmp/blobcast-snapshot-001.png
  if [ -s "$shot" ]; then
    image_ok "$shot" 320 240 || fail "the P screenshot is blank"
    # The selection's outline is drawn in (242, 184, 74).
    outline=$("$CHECK" count "$shot" 242 184 74 12)
    echo "     outline pixels: $outline"
    [ "${outline:-0}" -ge 40 ] || fail "no selection outline in the screenshot"
    if [ -n "${BC_VIEWER_SCREENSHOT:-}" ]; then
      cp "$shot" "$BC_VIEWER_SCREENSHOT"
    fi
  else
    fail "P saved no screenshot"
  fi
  if [ -s "$snap" ]; then
    image_ok "$snap" 320 240 || fail "the S snapshot is blank or mis-sized"
  else
    fail "S saved no snapshot"
  fi
  big=$tmp/big/blobcast-snapshot-001.png
  if [ -s "$big" ]; then
    image_ok "$big" 1100 300 ||
      fail "the --snapshot-size picture is blank or mis-sized"
  else
    fail "S with --snapshot-size saved no picture"
  fi
fi

# --- the daemon saves on SIGTERM: what did the edits leave? ---------------------------
# (The snapshot is binary: a daemon started on it again gives it back as
# JSON through `blobcast scene`.)
stop_daemon
if [ -n "$XPOKE" ] && [ -x "$XPOKE" ]; then
  last=$(ls "$tmp/data/sessions/drag" | sed -n 's/^snap-\([0-9]*\)\.bin$/\1/p' |
    sort -n | tail -n 1)
  scene=$tmp/saved.json
  start_daemon 127.0.0.1:0
  "$CLI" scene --server "127.0.0.1:$port" --session drag > "$scene" ||
    fail "blobcast scene of the restarted session failed"
  # The scene files the second viewer saved (Ctrl-S, Ctrl-Shift-S) hold
  # the daemon's scene at the last order: the JSON byte for byte, the
  # binary one loaded into another session.
  saved=$tmp/big/blobcast-drag-$last
  if cmp -s "$saved.json" "$scene"; then
    echo "ok   Ctrl-S saved the session's scene at order $last"
  else
    fail "Ctrl-S: $saved.json is not the daemon's scene at order $last"
  fi
  "$CLI" load --server "127.0.0.1:$port" --session back "$saved.bin" \
    > /dev/null || fail "blobcast load of the Ctrl-Shift-S file failed"
  "$CLI" scene --server "127.0.0.1:$port" --session back \
    > "$tmp/back.json" || fail "blobcast scene of the loaded file failed"
  if cmp -s "$tmp/back.json" "$scene"; then
    echo "ok   Ctrl-Shift-S saved it as a binary scene file"
  else
    fail "Ctrl-Shift-S: $saved.bin does not load as the daemon's scene"
  fi
  # Ctrl-M and Ctrl-Shift-M wrote the meshes `blobcast mesh --session`
  # writes of that scene, byte for byte.
  for ext in glb obj; do
    "$CLI" mesh --server "127.0.0.1:$port" --session drag --quiet \
      --out "$tmp/ref.$ext" || fail "blobcast mesh --session drag failed"
    if [ -s "$saved.$ext" ] && cmp -s "$saved.$ext" "$tmp/ref.$ext"; then
      echo "ok   Ctrl-M saved the session's mesh as .$ext" \
        "($(wc -c < "$tmp/ref.$ext") bytes)"
    else
      fail "Ctrl-M: $saved.$ext is not blobcast mesh's .$ext of the scene"
    fi
  done
  stop_daemon
  sphere=$(grep '"id": 2,' "$scene" | sed -n \
    's/.*"radius": \([-0-9.e]*\).*"translate": \[\([^]]*\)\].*/\1 \2/p' |
    tr -d ',')
  blend=$(grep '"id": 1,' "$scene" | sed -n 's/.*"blend": \([-0-9.e]*\).*/\1/p')
  echo "     saved (order $last): sphere radius x y z = $sphere; blend $blend"
  # Dragged 80 pixels right at depth ~5.2: x from -1.2 to about 0.2; the
  # wheel: radius 0.8 e^0.3 = 1.080, blend 0.3 e^-0.2 = 0.2456.
  echo "$sphere" | awk '{ exit !($2 > -0.6 && $2 < 0.8 && $3 > -0.1 &&
    $3 < 0.1 && $4 > -0.1 && $4 < 0.1) }' ||
    fail "the sphere did not move right in the view plane: $sphere"
  echo "$sphere" | awk '{ exit !($1 > 1.06 && $1 < 1.10) }' ||
    fail "Shift+wheel did not scale the radius to 1.08: $sphere"
  echo "$blend" | awk '{ exit !($1 > 0.235 && $1 < 0.255) }' ||
    fail "Ctrl+wheel did not scale the blend to 0.2456: $blend"
  # Alt+wheel, 3 notches up on the bar: the twist's rate grows by 3 x 0.3
  # radians over the extent of what it wraps (the bar's ABV turned about
  # y, about 3.9 across: 0.5 + 0.23), the mirror and the bar are as they
  # were.
  rate=$(grep '"id": 5,' "$scene" | sed -n 's/.*"twist".*"rate": \([-0-9.e]*\).*/\1/p')
  echo "     twist rate $rate"
  echo "$rate" | awk '{ exit !($1 > 0.6 && $1 < 1.0) }' ||
    fail "Alt+wheel did not step the twist's rate from 0.5 to about 0.73: $rate"
  grep -q '"type": "mirror", "id": 6, "axes": "x",' "$scene" ||
    fail "the mirror under the twist changed: $(grep '"id": 6,' "$scene")"
  grep '"id": 4,' "$scene" |
    grep -q '"half_extents": \[0.8, 0.3, 0.3\], "translate": \[0, 1.6, 0\]' ||
    fail "the bar changed: $(grep '"id": 4,' "$scene")"
fi

if [ $failures -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all viewer checks passed"
exit 0
