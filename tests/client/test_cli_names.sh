#!/bin/sh
# Node names from the command line, against a private blobcastd (free
# loopback port, temporary data directory; PROTOCOL.md 8, 9):
#  - `rename ID TEXT --json` names a node in one edit and prints the
#    modelling verbs' object; `nodes --json` has "name" on that node only,
#    `nodes` shows it quoted (control characters escaped);
#  - `undo` takes the name back off; `rename ID ""` removes a name, and
#    again is refused (nothing to remove);
#  - refused before sending, exit 2, with the reason: 65 bytes (64 of
#    UTF-8 pass), bytes that are not UTF-8, an unknown node;
#  - `history` shows a name with its control characters escaped;
#  - `add ... name=TEXT` and `wrap ... name=TEXT` name the new node; move
#    and wrap keep the names of what they move; duplicate names the copy
#    "NAME copy".
#
# usage: test_cli_names.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"
bc_scratch cli-names

start_daemon 127.0.0.1:0
S="--server 127.0.0.1:$port"
R="--session names"

cat > "$tmp/scene.json" <<'JSON'
{"blobcast": 1,
 "root": {"type": "union", "id": 1, "children": [
   {"type": "sphere", "id": 2, "radius": 0.5, "translate": [-1, 0, 0],
    "name": "left"},
   {"type": "sphere", "id": 3, "radius": 0.5, "translate": [1, 0, 0]},
   {"type": "union", "id": 4, "name": "arm", "children": [
     {"type": "sphere", "id": 5, "radius": 0.3, "translate": [0, 1, 0]},
     {"type": "twist", "id": 6, "rate": 1, "children": [
       {"type": "sphere", "id": 7, "radius": 0.3, "translate": [0, -1, 0],
        "name": "tip"}]}]}]}}
JSON
"$BLOBCAST" $S load $R "$tmp/scene.json" > /dev/null || fail "load"

# snap: the session's nodes now, for name_of.
snap() {
  "$BLOBCAST" $S nodes $R --json > "$tmp/nodes.json" || fail "nodes --json"
}
# name_of ID: node ID's "name" in the last snap ("" when it has none).
name_of() {
  python3 -c '
import json, sys
for n in json.load(open(sys.argv[1])):
    if n["id"] == int(sys.argv[2]):
        print(n.get("name", ""))' "$tmp/nodes.json" "$1"
}

# rename --json: one edit, the verbs' object.
"$BLOBCAST" $S rename $R 3 wheel --json > "$tmp/r1" 2>&1 ||
  fail "rename 3 wheel: $(cat "$tmp/r1")"
snap
grep -qE '^\{"seq": [0-9]+, "order": [0-9]+, "node": 3, "ids": \[\], "parent": 1, "position": 1\}$' \
  "$tmp/r1" || fail "rename --json: $(cat "$tmp/r1")"
[ "$(name_of 3)" = wheel ] || fail "node 3 is not named wheel: $(cat "$tmp/nodes.json")"
# "name" only on named nodes.
[ "$(grep -c '"name"' "$tmp/nodes.json")" -eq 4 ] ||
  fail "nodes --json: not 4 named nodes: $(cat "$tmp/nodes.json")"
"$BLOBCAST" $S nodes $R > "$tmp/nodes.txt" || fail "nodes"
grep -qE '^3 +sphere +1 +"wheel" radius=0.5 ' "$tmp/nodes.txt" ||
  fail "nodes: no quoted name on node 3: $(cat "$tmp/nodes.txt")"
echo "ok   rename 3 wheel: named at the daemon, in nodes and nodes --json"

# undo takes it back off; the file's names stay.
"$BLOBCAST" $S undo $R > "$tmp/u1" 2>&1 || fail "undo: $(cat "$tmp/u1")"
snap
[ -z "$(name_of 3)" ] && [ "$(name_of 2)" = left ] ||
  fail "after undo: $(cat "$tmp/nodes.json")"
echo "ok   undo takes the name back off"

# Refusals before sending: exit 2 and the reason.
# expect_refusal TEXT ARGS...: rename ARGS exits 2 saying TEXT.
expect_refusal() {
  text=$1
  shift
  "$BLOBCAST" $S rename $R "$@" > "$tmp/out" 2>&1
  st=$?
  if [ "$st" -ne 2 ]; then
    fail "rename $1: exit $st, not 2: $(cat "$tmp/out")"
  elif ! grep -qF -- "$text" "$tmp/out"; then
    fail "rename $1: no \"$text\" in: $(cat "$tmp/out")"
  else
    echo "ok   refused: $(head -n 1 "$tmp/out")"
  fi
}
long=$(printf '%065d' 0)
expect_refusal "the name is 65 bytes, over the limit of 64 bytes" 3 "$long"
expect_refusal "no node 99 in the session's scene" 99 wheel
expect_refusal "not valid UTF-8 (byte 2 breaks it)" 3 "$(printf 'a\377')"
expect_refusal "node 3 has no name: nothing to remove" 3 ""
# 64 bytes of UTF-8 (32 two-byte characters) pass.
e64=$(python3 -c 'print("\u00e9" * 32)')
"$BLOBCAST" $S rename $R 3 "$e64" > "$tmp/r2" 2>&1 ||
  fail "rename to 64 bytes: $(cat "$tmp/r2")"
snap
[ "$(name_of 3)" = "$e64" ] || fail "64-byte name: $(cat "$tmp/nodes.json")"
expect_refusal "node 3 already has that name" 3 "$e64"
# Quotes, backslashes and control characters are escaped in text.
"$BLOBCAST" $S rename $R 3 "$(printf 'a"b\\c\033d')" > "$tmp/r3" 2>&1 ||
  fail "rename with a quote: $(cat "$tmp/r3")"
grep -qF 'named node 3 "a\"b\\c\x1bd", edit order' "$tmp/r3" ||
  fail "rename sentence: $(cat "$tmp/r3")"
# history prints the daemon's words for it, the escape character escaped.
"$BLOBCAST" $S history $R > "$tmp/h1" 2>&1 || fail "history: $(cat "$tmp/h1")"
grep -qF 'NAME node 3 "a"b\c\x1bd"' "$tmp/h1" &&
  ! grep -q "$(printf '\033')" "$tmp/h1" ||
  fail "history: $(cat "$tmp/h1")"
"$BLOBCAST" $S rename $R 3 "" > "$tmp/r4" 2>&1 &&
  grep -q "^took the name of node 3 away, edit order" "$tmp/r4" ||
  fail "rename 3 '': $(cat "$tmp/r4")"
snap
[ -z "$(name_of 3)" ] || fail "node 3 still named: $(cat "$tmp/nodes.json")"
echo "ok   64 bytes pass, escaping, \"\" takes the name away"

# add and wrap name what they make; move and wrap keep names; a copy is
# "NAME copy".
"$BLOBCAST" $S add $R sphere radius=0.2 name=hub --json > "$tmp/a1" 2>&1 ||
  fail "add name=hub: $(cat "$tmp/a1")"
hub=$(sed -n 's/^{"seq": [0-9]*, "order": [0-9]*, "node": \([0-9]*\),.*/\1/p' \
  "$tmp/a1")
# Within union 4 of two children a move is a REPLACE of the union by
# itself reordered: the union keeps its name.
"$BLOBCAST" $S move $R 5 --parent 4 > "$tmp/m0" 2>&1 ||
  fail "move 5: $(cat "$tmp/m0")"
"$BLOBCAST" $S move $R 2 --parent 4 > "$tmp/m1" 2>&1 ||
  fail "move 2: $(cat "$tmp/m1")"
snap
grep -q '"id":4,"type":"union","parent":1,"children":\[6,5,2\],"name":"arm"' \
  "$tmp/nodes.json" || fail "the swap lost union 4's name: $(cat "$tmp/nodes.json")"
[ -n "$hub" ] && [ "$(name_of "$hub")" = hub ] ||
  fail "add name=hub: $(cat "$tmp/a1") $(cat "$tmp/nodes.json")"
grep -q '"id":2,"type":"sphere","parent":4,.*"name":"left"' "$tmp/nodes.json" ||
  fail "move lost the name: $(cat "$tmp/nodes.json")"
"$BLOBCAST" $S wrap $R 2 offset amount=0.1 name=shell --json > "$tmp/w1" 2>&1 ||
  fail "wrap name=shell: $(cat "$tmp/w1")"
shell=$(sed -n 's/^{"seq": [0-9]*, "order": [0-9]*, "node": \([0-9]*\),.*/\1/p' \
  "$tmp/w1")
"$BLOBCAST" $S duplicate $R 7 --json > "$tmp/d1" 2>&1 ||
  fail "duplicate 7: $(cat "$tmp/d1")"
snap
[ -n "$shell" ] && [ "$(name_of "$shell")" = shell ] &&
  [ "$(name_of 2)" = left ] ||
  fail "wrap name=shell: $(cat "$tmp/w1") $(cat "$tmp/nodes.json")"
# The copy of twist 6 with tip 7 inside: ids [T, T+1], tip's copy T+1.
copy=$(sed -n 's/.*"ids": \[[0-9]*, \([0-9]*\)\].*/\1/p' "$tmp/d1")
[ -n "$copy" ] && [ "$(name_of "$copy")" = "tip copy" ] &&
  [ "$(name_of 7)" = tip ] ||
  fail "duplicate: $(cat "$tmp/d1") $(cat "$tmp/nodes.json")"
"$BLOBCAST" $S add $R sphere name=a name=b > "$tmp/a2" 2>&1
st=$?
[ "$st" -eq 2 ] && grep -q "name= is given twice" "$tmp/a2" ||
  fail "add with two names: exit $st: $(cat "$tmp/a2")"
echo "ok   add and wrap name= , move and wrap keep names, \"tip copy\""

stop_daemon
if [ "$failures" -eq 0 ]; then
  echo "all checks passed"
  exit 0
fi
exit 1
