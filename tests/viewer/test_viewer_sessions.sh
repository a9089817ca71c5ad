#!/bin/sh
# blobcast-view's sessions panel (L), under Xvfb, against a private
# blobcastd with sessions "alpha" (joined) and "beta":
#  1. L lists every session the daemon has, as `blobcast sessions` does:
#     alpha with one member and two shapes, beta with none and two; the
#     cursor starts on the window's own session;
#  2. Escape closes the panel and does not quit; L opens it again, F5 asks
#     again;
#  3. Down to beta and Enter joins it over a new connection: the window
#     says so, shows beta's finished picture, and at the daemon alpha has
#     no member left and beta one;
#  4. an edit from the window now reaches beta (D duplicates the picked
#     shape there), not alpha;
#  5. Enter on the window's own session says so and keeps the connection;
#  6. N, a name and Enter create a session and join it;
#  7. Delete on the window's own session is refused; on another, a first
#     press only asks, a second deletes it (the daemon and the panel's
#     list lose it); Q quits with the panel open.
#
# usage: test_viewer_sessions.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE CLI
# Exits 77 (skipped) when xvfb-run or one of the programs is missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-sessions "$@"

# alpha: two spheres either side of the centre; beta: a box in the middle
# and a small sphere to its right; both seen from (0, 0, 6).
for s in alpha beta; do
  mkdir -p "$tmp/data/sessions/$s"
done
cat > "$tmp/data/sessions/alpha/snap-0.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "union", "id": 1, "children": [
   {"type": "sphere", "id": 2, "radius": 0.6, "translate": [-1.2, 0, 0]},
   {"type": "sphere", "id": 3, "radius": 0.6, "translate": [1.2, 0, 0]}]}}
JSON
cat > "$tmp/data/sessions/beta/snap-0.json" <<'JSON'
{"blobcast": 1,
 "camera": {"eye": [0, 0, 6], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 45},
 "root": {"type": "union", "id": 1, "children": [
   {"type": "box", "id": 2, "half_extents": [0.7, 0.7, 0.7]},
   {"type": "sphere", "id": 3, "radius": 0.3, "translate": [1.8, 0, 0]}]}}
JSON
vl_daemon
cd "$tmp" || exit 1

# members_of NAME: the members `blobcast sessions --json` counts in NAME.
members_of() {
  "$CLI" sessions --server "127.0.0.1:$port" --json > "$tmp/sessions.json" ||
    fail "blobcast sessions --json"
  python3 -c '
import json, sys
for s in json.load(open(sys.argv[1])):
    if s["name"] == sys.argv[2]:
        print(s["members"])' "$tmp/sessions.json" "$1"
}
# prims_of NAME: the shapes of NAME's scene at the daemon.
prims_of() {
  "$CLI" nodes --server "127.0.0.1:$port" --session "$1" --json \
    > "$tmp/nodes.json" || fail "blobcast nodes --json"
  python3 -c '
import json, sys
print(sum(1 for n in json.load(open(sys.argv[1]))
          if n["type"] not in ("union",)))' "$tmp/nodes.json"
}

# down_keys MARK FROM TO: the xpoke words that move the panel's cursor
# from session FROM to session TO, Down at a time (round), in the list
# the panel printed after line MARK of the log.
down_keys() {
  rows=$(tail -n +"$(($1 + 1))" "$L" | grep '^session ' | cut -d' ' -f2)
  from=$(echo "$rows" | grep -n "^$2\$" | cut -d: -f1)
  to=$(echo "$rows" | grep -n "^$3\$" | cut -d: -f1)
  # (not n: the waiting functions use it)
  rowcount=$(echo "$rows" | wc -l)
  i=$(((to - from + rowcount) % rowcount))
  while [ "$i" -gt 0 ]; do
    printf ' key Down'
    i=$((i - 1))
  done
}

L=$tmp/v.log
vl_view "$L" --session alpha --size 240x180 --no-overlay --encoding png
ok=1
vl_wait "$L" '^joined alpha role=editor$' 100 || ok=
[ -n "$ok" ] && { vl_still "$L" 0 300 || ok=; }

# 1. L: the daemon's sessions.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key l || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^session beta ' 100 || ok=; }
fi
if [ -n "$ok" ]; then
  listed=$(tail -n +"$((mark + 1))" "$L")
  echo "$listed" | grep -q '^session alpha members=1 prims=2 order=0 loaded=1$' ||
    fail "alpha is not listed loaded with one member: $listed"
  echo "$listed" | grep -q '^session beta members=0 prims=2 order=0 loaded=1$' ||
    fail "beta is not listed without members: $listed"
  want=$("$CLI" sessions --server "127.0.0.1:$port" --json |
    python3 -c 'import json, sys; print(len(json.load(sys.stdin)))')
  echo "$listed" | grep -q "^sessions $want\$" ||
    fail "the panel does not count the daemon's $want sessions: $listed"
fi

# 2. Escape closes the panel (the window stays), L and F5 ask again.
if [ -n "$ok" ]; then
  vl_poke key Escape sleep 300 || ok=
  kill -0 "$vpid" 2>/dev/null || { fail "Escape in the panel quit"; ok=; }
fi
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key l || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^session beta ' 100 || ok=; }
  mark=$(vl_lines "$L")
  [ -n "$ok" ] && { vl_poke key F5 || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^session beta ' 100 || ok=; }
fi

# 3. Down to beta (the cursor starts on alpha), Enter joins it.
if [ -n "$ok" ]; then
  keys=$(down_keys "$mark" alpha beta)
  mark=$(vl_lines "$L")
  # shellcheck disable=SC2086
  vl_poke $keys key Return || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^joined beta role=editor$' 100 ||
    ok=; }
  [ -n "$ok" ] && { vl_still "$L" "$mark" 300 || ok=; }
fi
if [ -n "$ok" ]; then
  grep -q '^status joined session beta as editor$' "$L" ||
    fail "no status for the join"
  [ "$(members_of beta)" = 1 ] || fail "beta has not the window as member"
  [ "$(members_of alpha)" = 0 ] || fail "alpha still has a member"
  kill -0 "$vpid" 2>/dev/null || { fail "the viewer is gone"; ok=; }
fi

# 4. A click picks beta's box and D duplicates it in beta.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke move 120 90 down 1 sleep 100 up 1 || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^pick node=2$' 100 || ok=; }
  mark=$(vl_lines "$L")
  [ -n "$ok" ] && { vl_poke key d || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^applied order=1 ' 100 || ok=; }
fi
if [ -n "$ok" ]; then
  [ "$(prims_of beta)" = 3 ] || fail "beta has not three shapes: $(cat nodes.json)"
  [ "$(prims_of alpha)" = 2 ] || fail "alpha changed: $(cat nodes.json)"
fi

# 5. Enter on the window's own session: said, nothing else.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key l || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^session beta ' 100 || ok=; }
  mark=$(vl_lines "$L")
  [ -n "$ok" ] && { vl_poke key Return || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status this window is in session beta already$' 100 || ok=; }
  [ "$(members_of beta)" = 1 ] || fail "beta lost the window's membership"
  tail -n +"$((mark + 1))" "$L" | grep -q '^joined ' &&
    fail "Enter on the own session joined again"
fi

# 6. N, "gamma", Enter: a new session, created by the join.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key n key g key a key m key m key a key Return || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^joined gamma role=editor$' 100 ||
    ok=; }
fi
if [ -n "$ok" ]; then
  [ "$(members_of gamma)" = 1 ] || fail "gamma was not created with the window in it"
  [ "$(members_of beta)" = 0 ] || fail "beta still has a member"
fi

# 7. Delete on the window's own session is refused; on alpha, twice,
#    deletes it for everyone.
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  vl_poke key l || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^session gamma ' 100 || ok=; }
fi
if [ -n "$ok" ]; then
  keys=$(down_keys "$mark" gamma alpha)
  mark=$(vl_lines "$L")
  vl_poke key Delete || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status this window is in session gamma: join another to delete it$' \
    100 || ok=; }
fi
if [ -n "$ok" ]; then
  mark=$(vl_lines "$L")
  # shellcheck disable=SC2086
  vl_poke $keys key Delete || ok=
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" \
    '^status Delete again deletes session alpha for everyone' 100 || ok=; }
  [ -n "$ok" ] && [ "$(members_of alpha)" = 0 ] ||
    fail "a first Delete changed alpha"
  mark=$(vl_lines "$L")
  [ -n "$ok" ] && { vl_poke key Delete || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^status deleted session alpha$' \
    100 || ok=; }
  [ -n "$ok" ] && { vl_wait_after "$L" "$mark" '^sessions ' 100 || ok=; }
fi
if [ -n "$ok" ]; then
  [ -z "$(members_of alpha)" ] || fail "alpha is still listed by the daemon"
  tail -n +"$((mark + 1))" "$L" | grep -q '^session alpha ' &&
    fail "the panel still lists alpha after deleting it"
fi
vl_quit || ok=
[ -n "$ok" ] || fail "a step failed"
if [ "$failures" -eq 0 ]; then
  echo "ok   L lists the daemon's sessions, Enter joins, N creates, Delete twice deletes"
  echo "all checks passed"
  exit 0
fi
exit 1
