#!/bin/sh
# The modelling verbs end to end against a private blobcastd (Unix socket,
# temporary data directory):
#  - add (a primitive at the session camera's target, an operator with its
#    two children, at a --parent and --position), wrap, move, duplicate and
#    remove, each with --json parsed and checked against `nodes --json`;
#  - their text output names the new ids and the edit order;
#  - refusals made before sending exit 2 with what to do (adding under a
#    primitive, moving under a descendant, removing the root, an unknown
#    kind or key with "did you mean", a missing --parent, a bad
#    --position); no daemon there exits 3;
#  - another member (watch) sees the edit's author by its --name, and in
#    the roster;
#  - `nodes --json` lists every operator's children as the scene file has
#    them, in order.
#
# usage: test_cli_model.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built or python3 is
# missing.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"
if ! command -v python3 > /dev/null 2>&1; then
  echo "skip: python3 is needed to read --json"
  exit 77
fi

watcher=
bc_scratch cli-model '[ -n "$watcher" ] && kill "$watcher" 2>/dev/null'

"$BLOBCASTD" --listen none --unix "$tmp/sock" --data "$tmp/data" \
  --backend cpu --log warn > "$tmp/daemon.log" 2>&1 &
daemon=$!
i=0
until [ -S "$tmp/sock" ]; do
  i=$((i + 1))
  if [ $i -gt 100 ] || ! kill -0 "$daemon" 2>/dev/null; then
    echo "FAIL: blobcastd did not start"
    sed 's/^/    /' "$tmp/daemon.log"
    exit 1
  fi
  sleep 0.1
done
S="--server unix:$tmp/sock"
M="--session model"

# union 1 [sphere 2, twist 3 (sphere 4), smooth_union 5 [box 6, sphere 7]],
# the camera looking at (0.5, 0.25, 0).
cat > "$tmp/scene.json" <<'EOF'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0.5, 0.25, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "union", "id": 1, "children": [
   {"type": "sphere", "id": 2, "radius": 0.5},
   {"type": "twist", "id": 3, "rate": 1, "children": [
     {"type": "sphere", "id": 4, "radius": 0.3}]},
   {"type": "smooth_union", "id": 5, "blend": 0.2, "children": [
     {"type": "box", "id": 6, "half_extents": [0.3, 0.3, 0.3]},
     {"type": "sphere", "id": 7, "radius": 0.4}]}]}}
EOF
"$BLOBCAST" $S load $M "$tmp/scene.json" > /dev/null || fail "load"

# run NAME ARGS...: runs blobcast ARGS, stdout to $tmp/NAME, stderr to
# $tmp/NAME.err; sets $status.
run() {
  name=$1
  shift
  "$BLOBCAST" "$@" > "$tmp/$name" 2> "$tmp/$name.err"
  status=$?
}

# verb NAME ARGS...: run, and the verb must succeed.
verb() {
  run "$@"
  [ $status -eq 0 ] || fail "$*: exit $status: $(cat "$tmp/$1.err")"
}

# The verbs, each checked at the end against the scene they left.
verb add1 $S add $M sphere radius=0.3 --json
verb add2 $S add $M smooth_union blend=0.15 --parent 5 --position 0 \
  --child box --at 1,2,3 --json
verb add3 $S add $M torus major=0.5 minor=0.1 translate=0,1,0
grep -qE '^added torus 12 \(id 12\) under node 1 at position 4, edit order [0-9]+$' \
  "$tmp/add3" || fail "add: text output: $(cat "$tmp/add3")"
verb wrap $S wrap $M 2 offset amount=0.05 --json
verb move $S move $M 7 --parent 1 --position 0 --json
verb dup $S duplicate $M 4 --offset 1,0,0 --json
verb remove $S remove $M 12 --json
verb remove2 $S remove $M 4
grep -qE '^removed node 4 with the unary nodes above it \(up to 3\), edit order [0-9]+$' \
  "$tmp/remove2" || fail "remove: text output: $(cat "$tmp/remove2")"
"$BLOBCAST" $S nodes $M --json > "$tmp/nodes.json" 2>&1 ||
  fail "nodes --json: $(cat "$tmp/nodes.json")"
"$BLOBCAST" $S scene $M --out "$tmp/now.json" > /dev/null || fail "scene"
python3 - "$tmp" > "$tmp/check.out" 2>&1 <<'EOF' ||
import json, sys
tmp = sys.argv[1]
j = {k: json.load(open(f"{tmp}/{k}"))
     for k in ("add1", "add2", "wrap", "move", "dup", "remove")}
nodes = json.load(open(f"{tmp}/nodes.json"))
byid = {n["id"]: n for n in nodes}
# Each verb was one edit: the orders follow one another (add3 between).
orders = [j[k]["order"] for k in ("add1", "add2", "wrap", "move", "dup",
                                  "remove")]
assert orders == [orders[0], orders[0] + 1, orders[0] + 3, orders[0] + 4,
                  orders[0] + 5, orders[0] + 6], orders
# add: a sphere appended under the root at the camera's target.
a = j["add1"]
assert a["ids"] == [8] and a["node"] == 8, a
assert a["parent"] == 1 and a["position"] == 3 and a["seq"] > 0, a
n = byid[8]
assert n["type"] == "sphere" and n["parent"] == 1 and n["radius"] == 0.3, n
assert n["translate"] == [0.5, 0.25, 0], n
# An operator with its two boxes, first under 5, around --at.
op, b1, b2 = j["add2"]["ids"]
assert j["add2"]["node"] == op and b2 == b1 + 1 == op + 2, j["add2"]
assert byid[op]["type"] == "smooth_union" and byid[op]["blend"] == 0.15
assert byid[op]["children"] == [b1, b2]
assert byid[b1]["type"] == "box" and byid[b2]["type"] == "box"
assert byid[5]["children"] == [op, 6], byid[5]
mid = [(x + y) / 2 for x, y in zip(byid[b1]["translate"],
                                   byid[b2]["translate"])]
assert all(abs(m - w) < 1e-5 for m, w in zip(mid, [1, 2, 3])), mid
# wrap: an offset in 2's place, 2 inside.
w = j["wrap"]["node"]
assert j["wrap"]["ids"] == [w] and j["wrap"]["position"] == 0, j["wrap"]
assert byid[w]["type"] == "offset" and byid[w]["children"] == [2]
assert byid[2]["parent"] == w and byid[w]["parent"] == 1
# move: 7 first under the root, no new ids.
assert j["move"]["ids"] == [] and j["move"]["node"] == 7, j["move"]
assert j["move"]["parent"] == 1 and j["move"]["position"] == 0
# duplicate: twist 3 (4's chain) copied right after it, moved by 1 in x.
t, s = j["dup"]["ids"]
assert j["dup"]["node"] == t and j["dup"]["parent"] == 1, j["dup"]
assert j["dup"]["position"] == 3, j["dup"]
assert byid[t]["type"] == "twist" and byid[t]["children"] == [s]
assert byid[s]["translate"][0] == 1.0, byid[s]
# remove: the torus, then 4 with its twist 3.
assert j["remove"]["node"] == 12 and j["remove"]["ids"] == []
assert 12 not in byid and 3 not in byid and 4 not in byid
assert byid[1]["children"] == [7, w, t, 5, 8], byid[1]
# nodes --json lists every operator's children as the scene file has them.
want = []
def walk(n):
    kids = n.get("children", [])
    want.append((n["id"], [c["id"] for c in kids] if kids else None))
    for c in kids:
        walk(c)
walk(json.load(open(f"{tmp}/now.json"))["root"])
assert [(n["id"], n.get("children")) for n in nodes] == want
EOF
  fail "the verbs' results: $(cat "$tmp/check.out")"

# --- refusals before sending: exit 2 ---------------------------------------------
# expect STATUS PATTERN ARGS...: runs blobcast ARGS; checks the exit status
# and that stderr contains PATTERN (fixed string).
expect() {
  want=$1 pattern=$2
  shift 2
  run refused "$@"
  if [ $status -ne "$want" ]; then
    fail "blobcast $*: exit $status, wanted $want: $(cat "$tmp/refused.err")"
  elif ! grep -qF -- "$pattern" "$tmp/refused.err"; then
    fail "blobcast $*: no '$pattern' in: $(cat "$tmp/refused.err")"
  fi
}
before=$("$BLOBCAST" $S nodes $M --json)
expect 2 "wrap it in one first" $S add $M sphere --parent 2
expect 2 "did you mean 'sphere'" $S add $M spehre
expect 2 "did you mean 'radius'" $S add $M sphere radus=0.2
expect 2 "descendants" $S move $M 5 --parent 6
expect 2 "--parent ID is required" $S move $M 5
expect 2 "--position 'x'" $S move $M 7 --parent 5 --position x
expect 2 "never empty" $S remove $M 1
expect 2 "'blobcast nodes' lists them" $S remove $M 99x
expect 2 "does not apply to remove" $S remove $M 7 --parent 1
after=$("$BLOBCAST" $S nodes $M --json)
[ "$before" = "$after" ] || fail "a refused verb changed the scene"
expect 3 "" --server "unix:$tmp/nosuch" add $M sphere

# --- the author's --name, as another member sees it -----------------------------
"$BLOBCAST" $S watch $M --frames 100000 --timeout 10000 > "$tmp/watch" 2>&1 &
watcher=$!
i=0
until grep -q '^members' "$tmp/watch" 2>/dev/null; do
  i=$((i + 1))
  [ $i -gt 100 ] && break
  sleep 0.1
done
"$BLOBCAST" $S add $M sphere --name alice --json > "$tmp/named" ||
  fail "add --name alice"
order=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["order"])' \
  "$tmp/named")
i=0
until grep -q "^edit order=$order " "$tmp/watch"; do
  i=$((i + 1))
  [ $i -gt 100 ] && break
  sleep 0.1
done
grep -qE "^edit order=$order by=\"alice\" member=[0-9]+ ops=1\$" "$tmp/watch" ||
  fail "watch does not name alice as the author: $(grep -v '^frame' "$tmp/watch")"
grep -qE '^members 2: .*"alice" \(editor, [0-9]+\)' "$tmp/watch" ||
  fail "alice is not in the roster: $(grep '^members' "$tmp/watch")"
kill "$watcher" 2>/dev/null
wait "$watcher" 2>/dev/null
watcher=

if [ $failures -ne 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "ok"
