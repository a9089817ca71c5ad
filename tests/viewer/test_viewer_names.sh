#!/bin/sh
# Naming a node from blobcast-view's keys, under Xvfb, against a private
# blobcastd; `blobcast nodes --json` reads the name at the daemon:
#  1. a click picks the left sphere; F2 opens the name entry; "x qz",
#     Backspace and Enter send one NAME: the daemon's sphere is named
#     "x q". The keys typed are shortcuts elsewhere (X deletes, Q quits,
#     Backspace deletes): inside the entry they only type;
#  2. F2 again holds "x q"; "!" and Escape close the entry unsent: Escape
#     does not quit, the name is unchanged and no other edit was made;
#  3. F2, Backspace three times and Enter take the name away.
# Each rename is one EDIT: one "model rename" line and its "applied" line.
#
# usage: test_viewer_names.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE CLI
# Exits 77 (skipped) when xvfb-run or one of the programs is missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-names "$@"

# Two spheres either side of the centre, seen from (0, 0, 6).
mkdir -p "$tmp/data/sessions/names"
cat > "$tmp/data/sessions/names/snap-0.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "union", "id": 1, "children": [
   {"type": "sphere", "id": 2, "radius": 0.6, "translate": [-1.2, 0, 0]},
   {"type": "sphere", "id": 3, "radius": 0.6, "translate": [1.2, 0, 0],
    "name": "right"}]}}
JSON
vl_daemon
# name_of ID: node ID's name at the daemon ("" when it has none).
name_of() {
  "$CLI" nodes --server "127.0.0.1:$port" --session names --json \
    > "$tmp/nodes.json" || fail "blobcast nodes --json"
  python3 -c '
import json, sys
for n in json.load(open(sys.argv[1])):
    if n["id"] == int(sys.argv[2]):
        print(n.get("name", ""))' "$tmp/nodes.json" "$1"
}
cd "$tmp" || exit 1
L=$tmp/v.log
vl_view "$L" --session names --size 240x180 --no-overlay --encoding png
ok=1
vl_wait "$L" '^joined names role=editor$' 100 || ok=
[ -n "$ok" ] && { vl_still "$L" 0 300 || ok=; }

# rename KEYS...: F2 was pressed; types KEYS and waits for the rename's
# EDIT to be applied.
rename() {
  [ -n "$ok" ] || return
  mark=$(vl_lines "$L")
  vl_poke "$@" key Return || { ok=; return; }
  vl_wait_after "$L" "$mark" '^model rename seq=' 100 || { ok=; return; }
  seq=$(tail -n +"$((mark + 1))" "$L" | grep -m 1 '^model rename seq=' |
    sed 's/.* seq=\([0-9]*\) .*/\1/')
  vl_wait_after "$L" "$mark" \
    "^applied order=[0-9]+ author=[0-9]+ seq=$seq ops=1$" 100 || ok=
}
# f2 NODE: F2 opens the entry on NODE.
f2() {
  [ -n "$ok" ] || return
  mark=$(vl_lines "$L")
  vl_poke key F2 || { ok=; return; }
  vl_wait_after "$L" "$mark" "^rename open node=$1\$" 100 || ok=
}

# 1. pick the left sphere, name it "x q".
[ -n "$ok" ] && { vl_poke move 77 90 down 1 sleep 100 up 1 || ok=; }
[ -n "$ok" ] && { vl_wait "$L" '^pick node=2$' 100 || ok=; }
f2 2
rename key x key space key q key z key BackSpace
if [ -n "$ok" ]; then
  [ "$(name_of 2)" = "x q" ] ||
    fail "sphere 2 is not named \"x q\": $(cat "$tmp/nodes.json")"
  [ "$(name_of 3)" = right ] || fail "sphere 3 lost its name"
  grep -q '^status named #2 "x q"$' "$L" || fail "no status for the name"
fi

# 2. F2, "!", Escape: nothing sent, the window stays.
f2 2
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key exclam key Escape || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^status renaming cancelled$' \
    100 || ok=; }
  kill -0 "$vpid" 2>/dev/null || { fail "Escape in the entry quit"; ok=; }
fi
[ -n "$ok" ] && [ "$(name_of 2)" != "x q" ] &&
  fail "Escape changed the name: $(cat "$tmp/nodes.json")"

# 3. F2, erase the three characters, Enter: no name.
f2 2
rename key BackSpace key BackSpace key BackSpace
if [ -n "$ok" ]; then
  [ -z "$(name_of 2)" ] ||
    fail "sphere 2 is still named: $(cat "$tmp/nodes.json")"
  n=$(grep -c '^model ' "$L")
  [ "$n" -eq 2 ] || fail "$n model actions, not 2: $(grep '^model ' "$L")"
  [ "$(grep -c '^applied ' "$L")" -eq 2 ] ||
    fail "not 2 edits applied: $(grep '^applied ' "$L")"
fi
vl_quit || ok=
[ -n "$ok" ] || fail "a step failed"
if [ "$failures" -eq 0 ]; then
  echo "ok   F2 names the picked sphere, Escape cancels, an empty name removes it"
  echo "all checks passed"
  exit 0
fi
exit 1
