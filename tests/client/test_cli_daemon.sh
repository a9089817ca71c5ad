#!/bin/sh
# The blobcast CLI against a real blobcastd: a private daemon on a free
# loopback port (and a Unix socket) with a temporary data directory; load,
# edit, camera, present, follow, snapshot, watch and bench-latency are run
# against it and their outputs checked; then the daemon is stopped with
# SIGTERM.
#
# usage: test_cli_daemon.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"

bc_scratch cli-daemon

# run STATUS PATTERN ARGS...: blobcast ARGS must exit STATUS and print
# PATTERN (fixed string, "" for any); output is kept in $tmp/out.
run() {
  want=$1 pattern=$2
  shift 2
  "$BLOBCAST" "$@" > "$tmp/out" 2>&1
  got=$?
  if [ "$got" -ne "$want" ]; then
    fail "blobcast $*: exit $got, wanted $want"
    sed 's/^/    /' "$tmp/out"
  elif [ -n "$pattern" ] && ! grep -qF -- "$pattern" "$tmp/out"; then
    fail "blobcast $*: output lacks \"$pattern\""
    sed 's/^/    /' "$tmp/out"
  else
    echo "ok   blobcast $*"
  fi
}

# png_size FILE: prints "W H" from a PNG's IHDR (big-endian at byte 16).
png_size() {
  od -An -tu1 -j16 -N8 "$1" |
    awk '{ print ($1*16777216 + $2*65536 + $3*256 + $4), \
                 ($5*16777216 + $6*65536 + $7*256 + $8) }'
}

# --- start the daemon on a free port (port 0: the kernel picks) --------------
"$BLOBCASTD" --listen 127.0.0.1:0 --unix "$tmp/d.sock" --data "$tmp/data" \
  --backend cpu --log warn > "$tmp/daemon.log" 2>&1 &
daemon=$!
port=
i=0
while [ $i -lt 100 ]; do
  port=$(sed -n 's/^blobcastd: listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' \
    "$tmp/daemon.log" | head -n 1)
  if [ -n "$port" ] && [ -S "$tmp/d.sock" ]; then
    break
  fi
  if ! kill -0 "$daemon" 2>/dev/null; then
    break
  fi
  sleep 0.1
  i=$((i + 1))
done
if [ -z "$port" ]; then
  echo "FAIL: blobcastd did not start"
  sed 's/^/    /' "$tmp/daemon.log"
  exit 1
fi
S="--server 127.0.0.1:$port"
U="--server unix:$tmp/d.sock"
echo "blobcastd on 127.0.0.1:$port (pid $daemon)"

cat > "$tmp/scene.json" <<'EOF'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 40},
 "root": {"type": "smooth_union", "id": 1, "blend": 0.3, "children": [
   {"type": "sphere", "id": 2, "radius": 0.8, "color": [0.9, 0.3, 0.2]},
   {"type": "box", "id": 3, "half_extents": [0.5, 0.5, 0.5],
    "translate": [1, 0, 0], "color": [0.2, 0.5, 0.9]}]}}
EOF

# --- load: creates the session ------------------------------------------------
run 0 "loaded $tmp/scene.json (3 nodes), edit order 1" \
  $S load --session review "$tmp/scene.json"
run 2 "missing.json" $S load --session review "$tmp/missing.json"
printf '{"blobcast": 1, "root": {"type": "sphere", "radius": -1}}' \
  > "$tmp/bad.json"
run 2 "radius" $S load --session review "$tmp/bad.json"
run 1 "no session named nosuch" $S edit --session nosuch 2 radius=0.5

# --- snapshot before and after an edit -----------------------------------------
run 0 "wrote $tmp/a.png (96x64" \
  $S snapshot --session review --size 96x64 --out "$tmp/a.png" \
  --depth "$tmp/a.exr" --ids "$tmp/a.tif"
if [ "$(png_size "$tmp/a.png" 2>/dev/null)" != "96 64" ]; then
  fail "a.png is not a 96x64 PNG: $(png_size "$tmp/a.png" 2>&1)"
fi
# The snapshot's colour, depth and ids are those of a local whole render of
# the same scene and camera (the daemon's cpu backend is the tiled one).
if command -v oiiotool > /dev/null 2>&1; then
  run 0 "" render "$tmp/scene.json" --size 96x64 --backend tiled \
    --out "$tmp/r.png" --depth "$tmp/r.exr" --ids "$tmp/r.tif"
  if ! oiiotool --info "$tmp/a.exr" | grep -q "96 x  *64, 1 channel, float"
  then
    fail "a.exr: $(oiiotool --info "$tmp/a.exr" 2>&1)"
  fi
  for p in png exr tif; do
    if ! oiiotool "$tmp/a.$p" "$tmp/r.$p" --diff > "$tmp/diff" 2>&1; then
      fail "snapshot a.$p and local render r.$p differ: $(cat "$tmp/diff")"
    fi
  done
fi
# In 16x16 tiles (ragged at the right: 96 = 6 x 16, 64 = 4 x 16; then 40,
# ragged both ways) the picture and its planes are the same.
run 0 "wrote $tmp/t.png (96x64" \
  $S snapshot --session review --size 96x64 --tile 16 --out "$tmp/t.png" \
  --depth "$tmp/t.exr" --ids "$tmp/t.tif"
grep -q "tile 24 of 24" "$tmp/out" || fail "no progress line: $(cat "$tmp/out")"
run 0 "wrote $tmp/u.png (96x64" \
  $S snapshot --session review --size 96x64 --tile 40 --out "$tmp/u.png"
if command -v oiiotool > /dev/null 2>&1; then
  for f in t.png t.exr t.tif u.png; do
    if ! oiiotool "$tmp/$f" "$tmp/a.${f#*.}" --diff > "$tmp/diff" 2>&1; then
      fail "tiled $f and whole a.${f#*.} differ: $(cat "$tmp/diff")"
    fi
  done
fi
run 2 "out of range (8..8192)" $S snapshot --session review --size 96x64 \
  --tile 4 --out "$tmp/x.png"
run 2 "depth needs a float format" $S snapshot --session review \
  --size 96x64 --out "$tmp/x.png" --depth "$tmp/x.png"

run 0 "node 2: edit applied, edit order 2" \
  $S edit --session review 2 radius=0.5 translate=-0.3,0,0
run 0 "edit order 3" $U edit --session review 1 blend=0.1
run 2 "has no \"radiuss\"" $S edit --session review 2 radiuss=0.5
run 2 "no node with id 99" $S edit --session review 99 radius=0.5
run 1 "must be > 0" $S edit --session review 2 radius=-1

run 0 "wrote $tmp/b.tif (96x64" \
  $S snapshot --session review --size 96x64 --out "$tmp/b.tif"
run 0 "wrote $tmp/b.png (96x64, frame" \
  $U snapshot --session review --size 96x64 --out "$tmp/b.png"
if cmp -s "$tmp/a.png" "$tmp/b.png"; then
  fail "the edit did not change the snapshot"
fi
if command -v oiiotool > /dev/null 2>&1; then
  if ! oiiotool --info "$tmp/b.tif" | grep -q "96 x  *64, 4 channel"; then
    fail "b.tif: $(oiiotool --info "$tmp/b.tif" 2>&1)"
  fi
  # The same picture through two encodings and two sockets.
  if ! oiiotool "$tmp/b.png" "$tmp/b.tif" --diff > "$tmp/diff" 2>&1; then
    fail "b.png and b.tif differ: $(cat "$tmp/diff")"
  fi
fi

# A camera for one snapshot only, then the session's camera for good.
run 0 "wrote" $S snapshot --session review --size 96x64 --out "$tmp/c.png" \
  --eye 4,0,0 --target 0,0,0
if cmp -s "$tmp/b.png" "$tmp/c.png"; then
  fail "--eye did not change the snapshot"
fi
run 0 "wrote" $S snapshot --session review --size 96x64 --out "$tmp/d.png"
if ! cmp -s "$tmp/b.png" "$tmp/d.png"; then
  fail "a snapshot with its own camera changed the session's camera"
fi
run 0 "camera eye 4,0,0 target 0,0,0 up 0,1,0 fov 40, edit order 4" \
  $S camera --session review --eye 4,0,0 --target 0,0,0
run 0 "wrote" $S snapshot --session review --size 96x64 --out "$tmp/e.png"
if ! cmp -s "$tmp/c.png" "$tmp/e.png"; then
  fail "the session's camera is not the one set"
fi
run 2 "blobcast camera:" $S camera --session review --eye 0,0,0 \
  --target 0,0,0 --fov 30

# --- present and follow: the follower gets the presenter's camera at its own
# size; the presentation ends when the presenter's --for runs out.
"$BLOBCAST" $S follow --session review --frames 2 --size 48x32 \
  > "$tmp/follow" 2>&1 &
follower=$!
i=0
while [ $i -lt 100 ] && ! grep -q "^presenter none" "$tmp/follow"; do
  sleep 0.1
  i=$((i + 1))
done
run 0 "end=time" $S present --session review --name presenter \
  --eye 0,4,4 --target 0,0,0 --for 1
wait $follower
st=$?
if [ $st -ne 0 ] || ! grep -q "^following member=" "$tmp/follow" ||
  ! grep -q "^camera member=[0-9]* eye=0,4,4 target=0,0,0" "$tmp/follow" ||
  ! grep -q "^frame 2 .* view=48x32 " "$tmp/follow"; then
  fail "follow: exit $st, no follow of the presenter's camera at 48x32"
  sed 's/^/    /' "$tmp/follow"
else
  echo "ok   blobcast follow sees blobcast present's camera at its size"
fi
run 1 "ENOSESSION" $S present --session nosuch --for 1

# --- watch: sees the first frame, then a frame per edit ---------------------------
"$BLOBCAST" $S watch --session review --frames 3 --size 64x48 \
  > "$tmp/watch" 2>&1 &
watcher=$!
i=0
while [ $i -lt 100 ] && ! grep -q "^frame 1 " "$tmp/watch"; do
  sleep 0.1
  i=$((i + 1))
done
run 0 "edit order 5" $S edit --session review 3 translate=0.9,0.1,0
# One edit per frame: two edits before a render would share one frame.
i=0
while [ $i -lt 100 ] && ! grep -q "^frame 2 " "$tmp/watch"; do
  sleep 0.1
  i=$((i + 1))
done
run 0 "edit order 6" $S edit --session review 3 translate=1,0,0
i=0
while [ $i -lt 150 ] && kill -0 "$watcher" 2>/dev/null; do
  sleep 0.1
  i=$((i + 1))
done
if kill -0 "$watcher" 2>/dev/null; then
  kill "$watcher"
  fail "watch did not finish"
fi
wait "$watcher"
status=$?
sed 's/^/    /' "$tmp/watch"
if [ "$status" -ne 0 ]; then
  fail "watch exited $status"
fi
if [ "$(grep -c '^frame [0-9]* no=[0-9]* order=[0-9]* bytes=[0-9]* rects=[0-9]* image=64x48 level=0 ' "$tmp/watch")" -ne 3 ]; then
  fail "watch did not print three frame lines"
fi
if ! grep -q '^frame 1 .*latency_ms=[0-9.]* after=view$' "$tmp/watch"; then
  fail "watch: no latency for the first frame"
fi
if ! grep -q '^frame [23] .*order=[56] .*latency_ms=[0-9.]* after=edit$' \
  "$tmp/watch"; then
  fail "watch: no edit latency"
fi
if ! grep -q '^stats frames=3 ' "$tmp/watch"; then
  fail "watch: no stats line"
fi

# --- bench-latency -------------------------------------------------------------------
run 0 '"bench":"edit_to_frame_latency"' \
  $S bench-latency --session review --edits 5 --size 64x64
cp "$tmp/out" "$tmp/bench"
if command -v python3 > /dev/null 2>&1; then
  if ! python3 - "$tmp/bench" <<'EOF'
import json, sys
r = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
assert r["edits"] == 5 and r["width"] == 64 and r["node"] == 2, r
assert 0 < r["min_ms"] <= r["p50_ms"] <= r["p99_ms"] <= r["max_ms"], r
assert r["frames"] >= 5 and r["bytes_per_frame"] > 0, r
EOF
  then
    fail "bench-latency JSON: $(cat "$tmp/bench")"
  fi
fi
# Five edits moved node 2 back and forth and back: it is where it was.
run 0 "wrote" $S snapshot --session review --size 96x64 --out "$tmp/f.png"
if ! cmp -s "$tmp/e.png" "$tmp/f.png"; then
  fail "bench-latency did not put the primitive back"
fi

# --- stop ------------------------------------------------------------------------------
kill -TERM "$daemon"
wait "$daemon"
status=$?
daemon=
if [ "$status" -ne 0 ]; then
  fail "blobcastd exited $status on SIGTERM"
  sed 's/^/    /' "$tmp/daemon.log"
fi
if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
