#!/bin/sh
# Modelling from blobcast-view's keys, under Xvfb, against a private
# blobcastd; a second client (blobcast nodes) reads the session's scene at
# the daemon after each step, and the window's pictures are compared
# (lossless stills, no overlay):
#  1. A opens the add palette, "b" jumps to box, Enter adds a box at the
#     camera's target under the root: one EDIT; the daemon's scene has the
#     box under operator 1 and the picture changes (more lit pixels);
#  2. a click at the centre picks the new box; W, "t", Enter wraps it in a
#     twist;
#  3. a click on the small sphere at the top, Up (its union 4), M marks
#     the union; a click on the box and G move the box (with its twist)
#     under union 4;
#  4. D duplicates the box with its twist beside it (two boxes at the
#     daemon), Delete removes the copy, a click on the box and X remove it:
#     the daemon's scene is the first one again; M with nothing selected
#     unmarks union 4, and the picture is the first one again, pixel for
#     pixel;
#  5. K on union 4 makes it an intersection at the daemon, K twice more
#     a difference and a union again; a click on the empty centre selects
#     nothing;
#  6. on the left sphere, Alt+Down makes it the root's second child at
#     the daemon, Alt+Up its first again; Alt+Up once more sends nothing.
# Each action is one EDIT: one "model" line and one "applied" line with
# its seq, and the verbose lines name the new ids.
#
# usage: test_viewer_model.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE CLI
# Exits 77 (skipped) when xvfb-run or one of the programs is missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-model "$@"

# Two spheres either side of the centre and a union of two small spheres
# above it, seen from (0, 0, 6): the centre of the picture is empty.
mkdir -p "$tmp/data/sessions/model"
cat > "$tmp/data/sessions/model/snap-0.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "smooth_union", "id": 1, "blend": 0.2, "children": [
   {"type": "sphere", "id": 2, "radius": 0.6, "translate": [-1.6, 0, 0],
    "color": [0.9, 0.25, 0.2]},
   {"type": "sphere", "id": 3, "radius": 0.6, "translate": [1.6, 0, 0],
    "color": [0.2, 0.45, 0.9]},
   {"type": "union", "id": 4, "children": [
     {"type": "sphere", "id": 5, "radius": 0.4, "translate": [0, 1.6, 0],
      "color": [0.3, 0.8, 0.35]},
     {"type": "sphere", "id": 6, "radius": 0.4, "translate": [0.9, 1.6, 0],
      "color": [0.3, 0.8, 0.35]}]}]}}
JSON
vl_daemon
nodes() {
  "$CLI" nodes --server "127.0.0.1:$port" --session model > "$tmp/$1.txt" ||
    fail "blobcast nodes"
}
# parent_of ID FILE: the parent column of node ID in a nodes listing.
parent_of() {
  awk -v id="$1" '$1 == id { print $3 }' "$2"
}
nodes before
cd "$tmp" || exit 1
L=$tmp/v.log
vl_view "$L" --session model --size 240x180 --no-overlay --encoding png
ok=1
vl_wait "$L" '^joined model role=editor$' 100 || ok=
[ -n "$ok" ] && { vl_still "$L" 0 300 || ok=; }
[ -n "$ok" ] && { vl_poke key p || ok=; }
[ -n "$ok" ] && { vl_wait "$L" '^screenshot .*-001.png' 100 || ok=; }

# act WHAT XPOKE-ARGS...: the keys of one action; waits for its "model
# WHAT" line, the EDIT_APPLIED of that seq and the finished picture after
# it. Sets $node (the node the action is about).
act() {
  [ -n "$ok" ] || return
  what=$1
  shift
  mark=$(vl_lines "$L")
  vl_poke "$@" || { ok=; return; }
  vl_wait_after "$L" "$mark" "^model $what seq=" 100 || { ok=; return; }
  line=$(tail -n +"$((mark + 1))" "$L" | grep -m 1 "^model $what seq=")
  seq=$(echo "$line" | sed 's/.* seq=\([0-9]*\) .*/\1/')
  node=$(echo "$line" | sed 's/.* node=\([0-9]*\) .*/\1/')
  vl_wait_after "$L" "$mark" \
    "^applied order=[0-9]+ author=[0-9]+ seq=$seq ops=[0-9]+$" 100 ||
    { ok=; return; }
  at=$(grep -n "^applied order=[0-9]* author=[0-9]* seq=$seq " "$L" |
    head -n 1 | cut -d: -f1)
  vl_still "$L" "$at" 300 || ok=
}
# pick X Y ID: a click at (X, Y) picks node ID.
pick() {
  [ -n "$ok" ] || return
  mark=$(vl_lines "$L")
  vl_poke move "$1" "$2" down 1 sleep 100 up 1 || { ok=; return; }
  vl_wait_after "$L" "$mark" "^pick node=$3$" 100 || ok=
}

# 1. add a box
act add key a key b key Return
box=$node
if [ -n "$ok" ]; then
  vl_poke key p && vl_wait "$L" '^screenshot .*-002.png' 100 || ok=
  nodes added
  [ "$(awk -v id="$box" '$1 == id { print $2, $3 }' "$tmp/added.txt")" = \
    "box 1" ] ||
    fail "the daemon has no box $box under 1: $(cat "$tmp/added.txt")"
  lit1=$("$CHECK" lit blobcast-view-001.png 50)
  lit2=$("$CHECK" lit blobcast-view-002.png 50)
  echo "     lit pixels: $lit1 before, $lit2 with box $box"
  [ "$lit2" -gt $((lit1 + 300)) ] || fail "the box does not show"
fi
# 2. wrap it in a twist
pick 120 90 "$box"
act wrap key w key t key Return
twist=$node
# 3. mark union 4 (Up from the sphere at the top), move the box under it
pick 120 36 5
[ -n "$ok" ] && { vl_poke key Up key m || ok=; }
[ -n "$ok" ] && { vl_wait "$L" '^status regroup parent #4 union' 100 || ok=; }
pick 120 90 "$box"
act move key g
if [ -n "$ok" ]; then
  nodes moved
  [ "$(parent_of "$twist" "$tmp/moved.txt")" = 4 ] &&
    [ "$(parent_of "$box" "$tmp/moved.txt")" = "$twist" ] ||
    fail "box $box in twist $twist is not under union 4: $(cat "$tmp/moved.txt")"
fi
# 4. duplicate, delete the copy, delete the box
act duplicate key d
if [ -n "$ok" ]; then
  nodes copied
  [ "$(awk '$2 == "box"' "$tmp/copied.txt" | wc -l)" -eq 2 ] ||
    fail "D made no second box: $(cat "$tmp/copied.txt")"
fi
act remove key Delete
pick 120 90 "$box"
act remove key x
# 5. K on union 4 (Up from the sphere at the top): intersection at the
# daemon; K twice more: difference, then union again.
pick 120 36 5
[ -n "$ok" ] && { vl_poke key Up || ok=; }
act operator key k
if [ -n "$ok" ]; then
  nodes kinded
  [ "$(awk '$1 == 4 { print $2 }' "$tmp/kinded.txt")" = intersection ] ||
    fail "K did not make union 4 an intersection: $(cat "$tmp/kinded.txt")"
fi
act operator key k
act operator key k
# A click on the empty centre selects nothing (no outline of union 4).
pick 120 90 0
# M with nothing selected unmarks union 4 (its blue outline goes).
[ -n "$ok" ] && { vl_poke key m || ok=; }
[ -n "$ok" ] && { vl_wait "$L" '^status no regroup parent marked$' 100 || ok=; }
if [ -n "$ok" ]; then
  vl_poke key p && vl_wait "$L" '^screenshot .*-003.png' 100 || ok=
  nodes after
  cmp -s "$tmp/before.txt" "$tmp/after.txt" ||
    fail "the scene is not the first one: $(diff "$tmp/before.txt" "$tmp/after.txt")"
  "$CHECK" same blobcast-view-001.png blobcast-view-003.png 2 ||
    fail "the picture is not the first one"
  n=$(grep -c '^model ' "$L")
  [ "$n" -eq 9 ] || fail "$n model actions, not 9"
fi
# 6. Alt+Down moves the left sphere one place later among the root's
# children, Alt+Up back; Alt+Up on the first child sends nothing.
# kids: the root's children in order, at the daemon.
kids() {
  nodes "$1"
  awk '$3 == 1 { printf "%s ", $1 }' "$tmp/$1.txt"
}
pick 62 90 2
act reorder keydown Alt_L key Down keyup Alt_L
if [ -n "$ok" ]; then
  [ "$(kids reordered)" = "3 2 4 " ] ||
    fail "Alt+Down: the root's children are $(kids reordered), not 3 2 4"
fi
act reorder keydown Alt_L key Up keyup Alt_L
if [ -n "$ok" ]; then
  [ "$(kids restored)" = "2 3 4 " ] ||
    fail "Alt+Up: the root's children are $(kids restored), not 2 3 4"
  mark=$(vl_lines "$L")
  vl_poke keydown Alt_L key Up keyup Alt_L || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status reordering: #2 is already the first child of .*; nothing sent$' \
    100 || ok=; }
  [ "$(grep -c '^model ' "$L")" -eq 11 ] ||
    fail "Alt+Up on the first child sent an edit"
fi
vl_quit || ok=
[ -n "$ok" ] || fail "a step failed"
if [ "$failures" -eq 0 ]; then
  echo "ok   add, wrap, regroup, reorder, duplicate, delete and operator kinds, one EDIT each"
  echo "all checks passed"
  exit 0
fi
exit 1
