#!/bin/sh
# blobcast-view's camera keys, under Xvfb, against a private blobcastd: a
# session whose scene (two spheres and a box) is seen from 80 units away,
# where it covers a few pixels. Without the overlay and with lossless
# stills:
#  1. Home (zoom to fit) makes the scene cover many times more of the
#     picture (pixels brighter than the dark background), and every part
#     of it stays in the window (no lit pixel on the border);
#  2. R goes back to the session's camera: the picture is the first one
#     again, pixel for pixel;
#  3. H shows the keys along the bottom of the window (the screenshot
#     differs from the picture received there only).
#
# usage: test_viewer_fit.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE
# Exits 77 (skipped) when xvfb-run or one of the programs is missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-fit "$@"

mkdir -p "$tmp/data/sessions/far"
cat > "$tmp/data/sessions/far/snap-0.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [20, 10, 80], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 40},
 "root": {"type": "union", "id": 1, "children": [
   {"type": "sphere", "id": 2, "radius": 0.8, "translate": [-1.2, 0, 0],
    "color": [0.9, 0.25, 0.2]},
   {"type": "box", "id": 3, "half_extents": [0.6, 0.6, 0.6],
    "translate": [1.3, 0.4, 0], "color": [0.2, 0.45, 0.9]},
   {"type": "sphere", "id": 4, "radius": 0.5, "translate": [0, 1.5, 0.5],
    "color": [0.3, 0.8, 0.35]}]}}
JSON
vl_daemon
cd "$tmp" || exit 1
vl_view "$tmp/v.log" --session far --size 240x180 --no-overlay \
  --encoding png
ok=1
vl_wait "$tmp/v.log" '^joined far role=editor$' 100 || ok=
# shoot N: P, and the screenshot blobcast-view-00N.png written.
shoot() {
  [ -n "$ok" ] && { vl_poke key p || ok=; }
  [ -n "$ok" ] && { vl_wait "$tmp/v.log" "^screenshot .*-00$1.png" 100 ||
    ok=; }
}
[ -n "$ok" ] && { vl_still "$tmp/v.log" 0 300 || ok=; }
shoot 1
# key K STATUS: presses K and waits for the status line and the finished
# picture that follow.
key() {
  [ -n "$ok" ] || return
  mark=$(vl_lines "$tmp/v.log")
  vl_poke key "$1" || { ok=; return; }
  vl_wait_after "$tmp/v.log" "$mark" "^status $2\$" 100 || { ok=; return; }
  vl_still "$tmp/v.log" "$mark" 300 || ok=
}
key Home 'framed the whole scene'
shoot 2
key r "the session's camera"
shoot 3
[ -n "$ok" ] && { vl_poke key h sleep 300 || ok=; }
shoot 4
vl_quit || ok=
if [ -n "$ok" ]; then
  far=$("$CHECK" lit blobcast-view-001.png 50)
  fit=$("$CHECK" lit blobcast-view-002.png 50)
  echo "     lit pixels of 240x180: $far from far away, $fit fitted"
  [ "$far" -gt 0 ] || fail "the scene is not in the first picture"
  [ "$fit" -gt $((far * 8)) ] ||
    fail "Home did not make the scene cover more: $far -> $fit"
  # The fitted scene lies inside the window: its border is background.
  border=$("$CHECK" border blobcast-view-002.png 50)
  [ "$border" -eq 0 ] ||
    fail "Home cut the scene at the window's edge ($border lit pixels)"
  "$CHECK" same blobcast-view-001.png blobcast-view-003.png 2 ||
    fail "R did not go back to the session's camera"
  # The key list covers the bottom left, nothing else.
  "$CHECK" same blobcast-view-003.png blobcast-view-004.png 0 \
    > /dev/null && fail "H showed no keys"
  [ -n "$ok" ] && [ "$failures" -eq 0 ] &&
    echo "ok   Home fits the scene ($far -> $fit lit pixels), R returns"
fi

if [ "$failures" -eq 0 ]; then
  echo "all checks passed"
  exit 0
fi
exit 1
