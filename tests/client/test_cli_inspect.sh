#!/bin/sh
# What a session holds and how watch behaves over time, against a private
# blobcastd (free loopback port, temporary data directory):
#  - `gen default` is the daemon's built-in scene: `scene` of a fresh
#    session prints the same file;
#  - round trip: load -> scene -> load into another session -> scene gives
#    the same file (every id and float survives), for a random scene with
#    every primitive and operator kind; `nodes --json` lists its nodes in
#    pre-order with their parents and types; the same through a binary
#    scene file (scene --binary, load, render), and a damaged one refused;
#  - `nodes` lists ids, types, parents and parameters as edit keys;
#  - watch names the author of an edit made with --name;
#  - `watch --frames N` on a still session ends after --timeout with
#    end=timeout and status 1;
#  - watch prints an undo and a redo with who sent it, the edit taken back
#    (the order `blobcast undo` names) and that edit's author;
#  - watch survives a daemon restart on the same port: it reports the loss,
#    rejoins, and counts the frames of the restarted daemon.
#
# usage: test_cli_inspect.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"

watcher=
bc_scratch cli-inspect '[ -n "$watcher" ] && kill "$watcher" 2>/dev/null'

# wait_for PATTERN FILE [TENTHS]: waits until FILE has a line matching
# PATTERN (grep -E); returns 1 after TENTHS/10 seconds (default 10 s).
wait_for() {
  j=0
  while [ $j -lt "${3:-100}" ]; do
    grep -qE "$1" "$2" && return 0
    sleep 0.1
    j=$((j + 1))
  done
  return 1
}

start_daemon 127.0.0.1:0
S="--server 127.0.0.1:$port"
echo "blobcastd on 127.0.0.1:$port"

# --- gen default is the daemon's built-in scene ------------------------------
"$BLOBCAST" gen default > "$tmp/default.json" || fail "gen default"
"$BLOBCAST" $S scene --session default > "$tmp/s-default.json" ||
  fail "scene --session default"
if ! cmp -s "$tmp/default.json" "$tmp/s-default.json"; then
  fail "scene of a fresh session differs from gen default"
  diff "$tmp/default.json" "$tmp/s-default.json" | head -n 10
fi
"$BLOBCAST" gen default --count 3 > /dev/null 2>&1
[ $? -eq 2 ] || fail "gen default --count 3 was not refused"

# --- round trips ----------------------------------------------------------------
"$BLOBCAST" gen random --count 60 --seed 7 > "$tmp/random.json" ||
  fail "gen random"
for scene in random; do
  "$BLOBCAST" $S load --session "$scene-a" "$tmp/$scene.json" > /dev/null ||
    fail "load $scene-a"
  "$BLOBCAST" $S scene --session "$scene-a" --out "$tmp/$scene-a.json" \
    > "$tmp/out" || fail "scene --out for $scene-a"
  grep -q "^session $scene-a: wrote $tmp/$scene-a.json (" "$tmp/out" ||
    fail "scene --out said: $(cat "$tmp/out")"
  "$BLOBCAST" $S load --session "$scene-b" "$tmp/$scene-a.json" > /dev/null ||
    fail "load $scene-b"
  "$BLOBCAST" $S scene --session "$scene-b" > "$tmp/$scene-b.json" ||
    fail "scene $scene-b"
  if ! cmp -s "$tmp/$scene-a.json" "$tmp/$scene-b.json"; then
    fail "$scene: the scene changed through scene -> load"
  fi
  # The file given to load comes back as it was written by gen.
  if ! cmp -s "$tmp/$scene.json" "$tmp/$scene-a.json"; then
    fail "$scene: load -> scene changed the scene"
  fi
done
# The same through a binary scene file: scene --binary -> load -> scene
# gives the JSON file back; render takes it as it takes the JSON file; a
# damaged one is refused, naming why; --binary needs --out.
"$BLOBCAST" $S scene --session random-a --out "$tmp/random.bin" --binary \
  > /dev/null || fail "scene --binary"
[ "$(head -c 4 "$tmp/random.bin")" = BCS1 ] ||
  fail "scene --binary did not write a binary scene file"
[ "$(wc -c < "$tmp/random.bin")" -lt "$(wc -c < "$tmp/random.json")" ] ||
  fail "the binary scene file is not smaller than the JSON one"
"$BLOBCAST" $S load --session random-c "$tmp/random.bin" > /dev/null ||
  fail "load of the binary scene file"
"$BLOBCAST" $S scene --session random-c > "$tmp/random-c.json" ||
  fail "scene random-c"
cmp -s "$tmp/random.json" "$tmp/random-c.json" ||
  fail "the scene changed through a binary scene file"
"$BLOBCAST" render "$tmp/random.bin" --size 48x32 --out "$tmp/bin.png" \
  > /dev/null 2>&1 || fail "render of the binary scene file"
"$BLOBCAST" render "$tmp/random.json" --size 48x32 --out "$tmp/json.png" \
  > /dev/null 2>&1 || fail "render of the JSON scene file"
cmp -s "$tmp/bin.png" "$tmp/json.png" ||
  fail "the binary and JSON scene files render differently"
"$BLOBCAST" render - --size 48x32 --out "$tmp/stdin.png" \
  < "$tmp/random.bin" > /dev/null 2>&1 ||
  fail "render of a binary scene file from stdin"
cmp -s "$tmp/stdin.png" "$tmp/json.png" ||
  fail "the binary scene file from stdin renders differently"
cp "$tmp/random.bin" "$tmp/bad.bin"
printf 'X' | dd of="$tmp/bad.bin" bs=1 seek=40 conv=notrunc 2> /dev/null
"$BLOBCAST" $S load --session random-d "$tmp/bad.bin" > "$tmp/out" 2>&1
[ $? -eq 2 ] || fail "load of a damaged binary scene file did not exit 2"
grep -q "checksum" "$tmp/out" ||
  fail "load of a damaged scene file said: $(cat "$tmp/out")"
"$BLOBCAST" $S scene --session random-a --binary > "$tmp/out" 2>&1
[ $? -eq 2 ] || fail "scene --binary without --out was not refused"
grep -q -- "--out FILE" "$tmp/out" ||
  fail "scene --binary without --out said: $(cat "$tmp/out")"
"$BLOBCAST" $S nodes --session random-b --json > "$tmp/random-b.nodes" ||
  fail "nodes --json"
if command -v python3 > /dev/null 2>&1; then
  python3 - "$tmp/random-b.nodes" "$tmp/random.json" <<'EOF' ||
import json, sys
nodes = json.load(open(sys.argv[1]))
scene = json.load(open(sys.argv[2]))
# Every node of the file, in pre-order, with its parent and type.
want = []
def walk(n, parent):
    want.append((n["id"], n["type"], parent))
    for c in n.get("children", []):
        walk(c, n["id"])
walk(scene["root"], 0)
got = [(n["id"], n["type"], n["parent"]) for n in nodes]
assert got == want, (got[:5], want[:5])
assert len(nodes) == 60 + sum(1 for n in nodes if "children" in n)
EOF
    fail "nodes --json does not list the random scene's nodes in pre-order"
fi

# The text listing: the default scene's sphere 23 under operator 21.
"$BLOBCAST" $S nodes --session default > "$tmp/nodes.txt" || fail "nodes"
grep -qE '^23 +sphere +21 +radius=0\.75 translate=-1\.15,-0\.33,0\.1 color=0\.86,0\.25,0\.22$' \
  "$tmp/nodes.txt" || fail "nodes: no line for sphere 23: $(sed -n 1,8p "$tmp/nodes.txt")"
grep -qE '^1 +union +- +children=7$' "$tmp/nodes.txt" ||
  fail "nodes: the root line is wrong"
"$BLOBCAST" $S nodes --session nosuch > "$tmp/out" 2>&1
[ $? -eq 1 ] && grep -q ENOSESSION "$tmp/out" ||
  fail "nodes of a missing session: $(cat "$tmp/out")"

# --- watch names an edit's author; --frames ends on a timeout ---------------
# The timeout counts from the last frame: long enough for carol's edit to
# come in time on a busy machine.
"$BLOBCAST" $S watch --session default --frames 5 --size 48x32 \
  --timeout 4000 > "$tmp/watch1" 2> "$tmp/watch1.err" &
watcher=$!
wait_for '^frame 1 ' "$tmp/watch1" || fail "watch: no first frame"
"$BLOBCAST" $S edit --name carol --session default 50 radius=0.15 \
  > /dev/null || fail "edit as carol"
wait "$watcher"
status=$?
watcher=
sed 's/^/    /' "$tmp/watch1" "$tmp/watch1.err"
grep -qE '^members 1: "blobcast-cli" \(viewer, [0-9]+, this client\)$' \
  "$tmp/watch1" || fail "watch: no member line"
grep -qE '^members 2: .*"carol" \(editor, [0-9]+\)' "$tmp/watch1" ||
  fail "watch: carol not listed when she joined"
grep -qE '^edit order=[0-9]+ by="carol" member=[0-9]+ ops=1$' \
  "$tmp/watch1" || fail "watch: the edit does not name carol"
[ "$status" -eq 1 ] || fail "watch that timed out exited $status, not 1"
grep -qE '^stats frames=[234] .* end=timeout$' "$tmp/watch1" ||
  fail "watch: no end=timeout"
grep -qE 'timed out: [234] of 5 frames, none for 4000 ms' "$tmp/watch1.err" ||
  fail "watch: the timeout is not reported"

# --- watch prints undo and redo lines ----------------------------------------
"$BLOBCAST" $S watch --session default --size 48x32 > "$tmp/watch3" \
  2> "$tmp/watch3.err" &
watcher=$!
wait_for '^frame 1 ' "$tmp/watch3" || fail "watch: no first frame"
"$BLOBCAST" $S edit --name carol --session default 50 radius=0.2 \
  > /dev/null || fail "edit as carol"
"$BLOBCAST" $S undo --name carol --session default > "$tmp/undo" 2>&1 ||
  fail "undo as carol: $(cat "$tmp/undo")"
"$BLOBCAST" $S redo --name carol --session default > "$tmp/redo" 2>&1 ||
  fail "redo as carol: $(cat "$tmp/redo")"
wait_for '^redo ' "$tmp/watch3" || fail "watch: no redo line"
kill -TERM "$watcher" 2>/dev/null
wait "$watcher"
watcher=
sed 's/^/    /' "$tmp/undo" "$tmp/redo" "$tmp/watch3" "$tmp/watch3.err"
# "undid edit E by "carol": edit order U"
e=$(sed -n 's/^undid edit \([0-9]*\) by "carol": edit order [0-9]*$/\1/p' \
  "$tmp/undo")
u=$(sed -n 's/^undid edit [0-9]* by "carol": edit order \([0-9]*\)$/\1/p' \
  "$tmp/undo")
r=$(sed -n 's/^redid edit [0-9]* by "carol": edit order \([0-9]*\)$/\1/p' \
  "$tmp/redo")
if [ -z "$e" ] || [ -z "$u" ] || [ -z "$r" ]; then
  fail "undo/redo output not understood"
else
  grep -qE "^edit order=$e by=\"carol\" member=[0-9]+ ops=1\$" \
    "$tmp/watch3" || fail "watch: no line for carol's edit $e"
  grep -qE "^undo order=$u of=$e by=\"carol\" author=\"carol\" member=[0-9]+ ops=[0-9]+\$" \
    "$tmp/watch3" || fail "watch: no undo line naming carol and edit $e"
  grep -qE "^redo order=$r of=$e by=\"carol\" author=\"carol\" member=[0-9]+ ops=[0-9]+\$" \
    "$tmp/watch3" || fail "watch: no redo line naming carol and edit $e"
  grep -qE '^edit order=('"$u|$r"') ' "$tmp/watch3" &&
    fail "watch: an undo or redo printed as a plain edit"
fi

# --- watch across a daemon restart -------------------------------------------
"$BLOBCAST" $S watch --session default --frames 3 --size 48x32 \
  --timeout 20000 > "$tmp/watch2" 2> "$tmp/watch2.err" &
watcher=$!
wait_for '^frame 1 ' "$tmp/watch2" || fail "watch: no first frame"
stop_daemon
start_daemon "127.0.0.1:$port"
wait_for '^rejoined session=default$' "$tmp/watch2" 100 ||
  fail "watch did not rejoin the restarted daemon"
wait_for '^frame 2 ' "$tmp/watch2" || fail "watch: no frame after rejoining"
"$BLOBCAST" $S edit --session default 50 radius=0.12 > /dev/null ||
  fail "edit after the restart"
i=0
while [ $i -lt 100 ] && kill -0 "$watcher" 2>/dev/null; do
  sleep 0.1
  i=$((i + 1))
done
kill "$watcher" 2>/dev/null && fail "watch did not finish"
wait "$watcher"
status=$?
watcher=
sed 's/^/    /' "$tmp/watch2" "$tmp/watch2.err"
[ "$status" -eq 0 ] || fail "watch across the restart exited $status"
grep -q '^lost reason=' "$tmp/watch2" || fail "watch: the loss is not shown"
grep -qE '^frame 2 .*after=view$' "$tmp/watch2" ||
  fail "watch: the first frame after rejoining is not measured from the view"
grep -qE '^stats frames=3 .* rtt_ms=[0-9.]+ link_mbit=[0-9.]+ paced=[0-9]+ spoiled=[0-9]+ end=frames$' "$tmp/watch2" ||
  fail "watch: no end=frames"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
