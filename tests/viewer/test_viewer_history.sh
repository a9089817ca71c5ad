#!/bin/sh
# The history panel, the two undo scopes, Shift-R (the session's camera)
# and Ctrl-O (loading a scene file) of blobcast-view, under Xvfb,
# against a private blobcastd; `blobcast` (the CLI, as bob and as alice)
# makes changes beside the window (named alice):
#  1. bob changes a sphere; the window's Ctrl-Z takes back its own changes
#     only: the status line shows the daemon's words ("nothing to undo:
#     no change of yours is left") and bob's change stays;
#  2. I opens the history panel: its rows are `blobcast history --name
#     alice --json`'s, field for field;
#  3. a change by alice from the CLI (the same name: the window's too)
#     reaches the open panel by itself, marked yours and next; Ctrl-Z
#     takes it back (not bob's), and the panel shows it undone;
#  4. Ctrl-Alt-Z (the session's newest, whoever made it) is refused with
#     EPERM while alice neither owns the session nor presents; after
#     Shift-F (present) it takes back bob's change;
#  5. after a wheel zoom, Shift-R makes the view the session's camera:
#     the daemon's scene (blobcast scene) carries the new eye;
#  6. Ctrl-O: a path that does not read is refused before anything is
#     sent; Escape right after Enter drops the file being read (nothing
#     sent, the history kept); other.json then loads, read first on the
#     reader's thread: the session's scene equals `blobcast load`'s of
#     the same file, and the history starts again;
#  7. Escape closes the panel without quitting; Q then quits.
#
# usage: test_viewer_history.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE CLI
# Exits 77 (skipped) when xvfb-run or one of the programs is missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-history "$@"

mkdir -p "$tmp/data/sessions/hist"
cat > "$tmp/data/sessions/hist/snap-0.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "union", "id": 1, "children": [
   {"type": "sphere", "id": 2, "radius": 0.6, "translate": [-1.2, 0, 0]},
   {"type": "sphere", "id": 3, "radius": 0.6, "translate": [1.2, 0, 0]}]}}
JSON
vl_daemon
cli() {
  "$CLI" --server "127.0.0.1:$port" "$@"
}
# state_of ORDER: "applied" or "undone", as the daemon's history says.
state_of() {
  cli history --session hist --json > "$tmp/h.json" || fail "blobcast history"
  python3 -c '
import json, sys
for c in json.load(open(sys.argv[1]))["changes"]:
    if c["order"] == int(sys.argv[2]):
        print(c["state"])' "$tmp/h.json" "$1"
}
cd "$tmp" || exit 1
ok=1
cli --name bob edit --session hist 3 radius=0.7 > /dev/null ||
  { fail "bob's edit"; ok=; }
L=$tmp/v.log
vl_view "$L" --session hist --name alice --size 240x180 --encoding png
[ -n "$ok" ] && { vl_wait "$L" '^joined hist role=editor$' 100 || ok=; }
[ -n "$ok" ] && { vl_still "$L" 0 300 || ok=; }

# 1. Ctrl-Z: nothing of alice's to take back; bob's change stays.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke keydown Control_L key z keyup Control_L || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status nothing to undo: no change of yours is left' 100 || ok=; }
  [ "$(state_of 1)" = applied ] || fail "Ctrl-Z took back bob's change"
fi

# 2. I: the panel lists what `blobcast history` lists for alice.
# panel_matches MARK: the last "history" listing after line MARK holds
# the daemon's changes as alice sees them.
panel_matches() {
  cli --name alice history --session hist --json > "$tmp/ha.json" ||
    fail "blobcast history --name alice"
  tail -n +"$(($1 + 1))" "$L" > "$tmp/part.log"
  python3 - "$tmp/ha.json" "$tmp/part.log" <<'PY' || return 1
import json, sys
want = json.load(open(sys.argv[1]))
lines = open(sys.argv[2]).read().splitlines()
heads = [i for i, l in enumerate(lines) if l.startswith("history ")]
if not heads:
    sys.exit("no history listing")
i = heads[-1]
n, order = lines[i].split()[1], lines[i].split()[2]
got = []
for l in lines[i + 1:i + 1 + int(n)]:
    w = l.split(" what=", 1)
    f = w[0].split()
    kv = dict(x.split("=", 1) for x in f[3:])
    got.append({"order": int(f[1]), "state": f[2], "author": kv["author"],
                "yours": kv["yours"] == "1", "next": kv["next"] == "1",
                "built_on": int(kv["built_on"]), "what": w[1]})
exp = [{"order": c["order"], "state": c["state"], "author": c["author"],
        "yours": c["yours"], "next": c["next"], "built_on": c["built_on"],
        "what": c["what"]} for c in want["changes"]]
if order != "order=%d" % want["order"] or got != exp:
    sys.exit("panel %s %s\n%s\ndaemon %d\n%s" % (n, order, got,
             want["order"], exp))
PY
}
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key i || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^history 1 order=1$' 100 ||
    ok=; }
  [ -n "$ok" ] && { panel_matches "$mark" || { fail "I: the panel"; ok=; }; }
fi

# 3. alice's change from the CLI reaches the open panel; Ctrl-Z takes it
# back, not bob's.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  cli --name alice edit --session hist 2 radius=0.5 > /dev/null ||
    { fail "alice's edit"; ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^history 2 order=2$' 100 ||
    ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^change 2 applied author=alice yours=1 next=1 built_on=0 what=SET node 2' \
    10 || ok=; }
  [ -n "$ok" ] && { panel_matches "$mark" ||
    { fail "the panel after alice's change"; ok=; }; }
fi
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke keydown Control_L key z keyup Control_L || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^undo order=3 of=2 ' 100 ||
    ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^change 2 undone .* next=1 ' \
    100 || ok=; }
  [ -n "$ok" ] && { panel_matches "$mark" ||
    { fail "the panel after Ctrl-Z"; ok=; }; }
  [ "$(state_of 1)" = applied ] || fail "Ctrl-Z took back bob's change"
fi

# 4. Ctrl-Alt-Z: EPERM for a member who neither owns nor presents; after
# Shift-F it takes back the session's newest applied change, bob's.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke keydown Control_L keydown Alt_L key z keyup Alt_L keyup Control_L ||
    ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^status server: .*\(EPERM\)$' \
    100 || ok=; }
  [ "$(state_of 1)" = applied ] || fail "a refused Ctrl-Alt-Z took it back"
fi
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke keydown Shift_L key f keyup Shift_L || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^presenter ' 100 || ok=; }
  mark=$(vl_lines "$L")
  [ -n "$ok" ] && { vl_poke keydown Control_L keydown Alt_L key z keyup Alt_L \
    keyup Control_L || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^undo order=4 of=1 ' 100 ||
    ok=; }
  [ -n "$ok" ] && { [ "$(state_of 1)" = undone ] ||
    fail "Ctrl-Alt-Z did not take back bob's change"; }
fi

# 5. A wheel zoom, then Shift-R: the view becomes the session's camera at
# the daemon (its scene carries it), and the status line says so.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke move 120 90 wheel 2 sleep 500 keydown Shift_L key r keyup Shift_L ||
    ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^session_camera order=[0-9]+ by=[0-9]+$' 100 || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    "^status the session's camera is now this view" 100 || ok=; }
  eye=$(cli scene --session hist | python3 -c '
import json, sys
print(" ".join(str(v) for v in json.load(sys.stdin)["camera"]["eye"]))')
  echo "$eye" | awk '{ exit !(($3 < 5.99 || $3 > 6.01) && $1 > -0.01 &&
    $1 < 0.01 && $2 > -0.01 && $2 < 0.01) }' ||
    fail "Shift-R: the daemon's camera eye is $eye, not the zoomed view's"
fi

# 6. Ctrl-O: a path that does not read is refused before anything is sent
# (the entry stays open); other.json then loads: the session's scene is
# `blobcast load`'s of the same file, and its history starts again.
cat > "$tmp/other.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 1, 8], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 40},
 "root": {"type": "smooth_union", "id": 1, "blend": 0.25, "children": [
   {"type": "sphere", "id": 2, "radius": 0.5, "translate": [-1, 0, 0]},
   {"type": "box", "id": 3, "half_extents": [0.4, 0.3, 0.2],
    "translate": [1, 0, 0], "color": [0.2, 0.6, 0.9]},
   {"type": "sphere", "id": 7, "radius": 0.3, "translate": [0, 1, 0]}]}}
JSON
# typed WORD: key names typing WORD (letters, digits and '.').
typed() {
  echo "$1" | sed 's/./& /g; s/\./period/g' | awk '{ for (i = 1; i <= NF;
    i++) printf "key %s ", $i }'
}
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  # shellcheck disable=SC2046
  vl_poke keydown Control_L key o keyup Control_L $(typed nothere.json) \
    key Return || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status not loaded: .*nothere\.json' 100 || ok=; }
  i=0
  while [ -n "$ok" ] && [ $i -lt 12 ]; do
    vl_poke key BackSpace || ok=
    i=$((i + 1))
  done
  # Escape right after Enter: while the file is still being read (the
  # usual case) nothing is sent and the session keeps its history; if
  # the read and the load were quicker than the key, the load stands.
  mark=$(vl_lines "$L")
  # shellcheck disable=SC2046
  [ -n "$ok" ] && { vl_poke $(typed other.json) key Return key Escape ||
    ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status loading cancelled: other\.json is not sent$|^load other\.json ' \
    100 || ok=; }
  if [ -n "$ok" ] && tail -n +"$((mark + 1))" "$L" |
    grep -q '^status loading cancelled: other\.json is not sent$'; then
    sleep 0.5
    tail -n +"$((mark + 1))" "$L" | grep -q '^load other\.json ' &&
      fail "Escape while reading: the file was loaded all the same"
    cli history --session hist --json > "$tmp/h0.json" ||
      fail "blobcast history"
    python3 -c 'import json, sys
sys.exit(len(json.load(open(sys.argv[1]))["changes"]) == 0)' "$tmp/h0.json" ||
      fail "Escape while reading: the session's history started again"
  fi
  # Ctrl-O again: read on the reader's thread (the status line says so),
  # then loaded.
  mark=$(vl_lines "$L")
  # shellcheck disable=SC2046
  [ -n "$ok" ] && { vl_poke keydown Control_L key o keyup Control_L \
    $(typed other.json) key Return || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^load other\.json nodes=4 order=[0-9]+$' 100 || ok=; }
  [ -n "$ok" ] && { tail -n +"$((mark + 1))" "$L" |
    grep -q '^status reading other\.json \.\.\.$' ||
    fail "Ctrl-O: no \"reading other.json ...\" before the load"; }
  [ -n "$ok" ] && { tail -n +"$((mark + 1))" "$L" |
    grep -q '^status loading other\.json (4 nodes): waiting for the daemon$' ||
    fail "Ctrl-O: no \"waiting for the daemon\" before the load"; }
fi
if [ -n "$ok" ]; then
  cli load --session ref "$tmp/other.json" > /dev/null || fail "blobcast load"
  cli scene --session hist > "$tmp/hist.json" &&
    cli scene --session ref > "$tmp/ref.json" || fail "blobcast scene"
  cmp -s "$tmp/hist.json" "$tmp/ref.json" ||
    fail "Ctrl-O: the session's scene is not blobcast load's of the file"
  cli history --session hist --json > "$tmp/h.json" || fail "blobcast history"
  python3 -c 'import json, sys
sys.exit(len(json.load(open(sys.argv[1]))["changes"]) != 0)' "$tmp/h.json" ||
    fail "the history did not start again: $(cat "$tmp/h.json")"
fi

# 7. Escape closes the panel, not the window.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key Escape sleep 300 || ok=
  kill -0 "$vpid" 2>/dev/null || { fail "Escape on the panel quit"; ok=; }
fi
vl_quit || ok=
[ -n "$ok" ] || fail "a step failed"
if [ "$failures" -eq 0 ]; then
  echo "ok   Ctrl-Z takes back alice's own change only, I lists the" \
    "daemon's history and follows it, Ctrl-Alt-Z needs the presenter," \
    "Shift-R sets the session's camera, Ctrl-O loads a file"
  echo "all checks passed"
  exit 0
fi
exit 1
