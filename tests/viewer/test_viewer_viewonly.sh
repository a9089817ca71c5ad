#!/bin/sh
# blobcast-view with a token that grants viewing only, under Xvfb, against a
# private blobcastd whose configuration has an editor and a viewer token:
#  1. with the viewer token and no --role the window opens view-only (the
#     verbose "joined default role=view-only token=viewer" line), shows the
#     picture (a screenshot that is not blank) and its overlay says why
#     (a screenshot with the overlay differs from one without);
#  2. edit keys say so instead of sending: Ctrl-Z, Shift+wheel on a
#     picked shape, A (add), Delete and F2 (name) print "view-only (the
#     token grants viewing only): ... is off" and no edit is applied (no
#     "applied" line; the session's scene, read with blobcast nodes, is
#     unchanged);
#  3. --role editor with the viewer token exits 1 and says that without
#     --role editor the window opens view-only;
#  4. the editor token still joins as an editor.
#
# usage: test_viewer_viewonly.sh BLOBCAST-VIEW BLOBCASTD IMGCHECK XPOKE CLI
# Exits 77 (skipped) when xvfb-run or one of the programs is missing.
set -u

. "$(dirname "$0")/viewer_lib.sh"
vl_enter viewer-vo "$@"

cat > "$tmp/config.json" <<'JSON'
{"tokens": [{"token": "edit-0123456789", "role": "editor"},
            {"token": "look-0123456789", "role": "viewer"}]}
JSON
vl_daemon --config "$tmp/config.json"
nodes() {
  "$CLI" nodes --server "127.0.0.1:$port" --token look-0123456789 \
    --session default
}
nodes > "$tmp/before.txt" || fail "blobcast nodes"

# 1 and 2. --- the viewer token, no --role ----------------------------------------
cd "$tmp" || exit 1
vl_view "$tmp/v.log" --token look-0123456789 --session default \
  --size 320x240
ok=1
vl_wait "$tmp/v.log" '^joined default role=view-only token=viewer$' 100 || ok=
[ -n "$ok" ] && { vl_still "$tmp/v.log" 0 300 || ok=; }
# The window with the overlay (P), then without it (O, P).
[ -n "$ok" ] && { vl_poke key p || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" '^screenshot .*-001.png' 100 || ok=; }
[ -n "$ok" ] && { vl_poke key o sleep 200 key p || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" '^screenshot .*-002.png' 100 || ok=; }
# Edit keys: Ctrl-Z, then a click on the shape at the centre and
# Shift+wheel on it.
[ -n "$ok" ] && { vl_poke keydown Control_L key z keyup Control_L || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" \
  '^status view-only \(the token grants viewing only\): undo is off$' 100 ||
  ok=; }
[ -n "$ok" ] && { vl_poke move 160 120 down 1 sleep 200 up 1 || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" '^pick node=[1-9]' 100 || ok=; }
[ -n "$ok" ] && { vl_poke keydown Shift_L wheel 2 keyup Shift_L || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" \
  '^status view-only \(the token grants viewing only\): editing with the wheel is off$' \
  100 || ok=; }
# The modelling keys: A (the palette does not open) and Delete.
[ -n "$ok" ] && { vl_poke key a || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" \
  '^status view-only \(the token grants viewing only\): adding is off$' 100 ||
  ok=; }
[ -n "$ok" ] && { vl_poke key Delete || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" \
  '^status view-only \(the token grants viewing only\): deleting is off$' \
  100 || ok=; }
[ -n "$ok" ] && { vl_poke key F2 || ok=; }
[ -n "$ok" ] && { vl_wait "$tmp/v.log" \
  '^status view-only \(the token grants viewing only\): renaming is off$' \
  100 || ok=; }
vl_quit
if [ -n "$ok" ]; then
  s1=$tmp/blobcast-view-001.png
  s2=$tmp/blobcast-view-002.png
  info=$("$CHECK" info "$s2")
  echo "     without the overlay: $info (width height colours stddev)"
  echo "$info" | awk '{ exit !($1 == 320 && $2 == 240 && $3 >= 100 &&
    $4 >= 5.0) }' || fail "the view-only window shows no picture: $info"
  "$CHECK" same "$s1" "$s2" 0 > /dev/null &&
    fail "the overlay is not drawn in the view-only window"
  grep -q '^applied ' "$tmp/v.log" &&
    fail "an edit was applied: $(grep '^applied ' "$tmp/v.log")"
  nodes > "$tmp/after.txt" || fail "blobcast nodes"
  cmp -s "$tmp/before.txt" "$tmp/after.txt" ||
    fail "the scene changed: $(diff "$tmp/before.txt" "$tmp/after.txt")"
  echo "ok   a viewer token opens view-only; edit keys say so"
fi

# 3. --- --role editor with the viewer token -----------------------------------------
$VIEWENV "$VIEW" --server "127.0.0.1:$port" --token look-0123456789 \
  --role editor --size 80x60 --screenshot "$tmp/no.png" > "$tmp/3.log" 2>&1
rc=$?
if [ $rc -ne 1 ]; then
  fail "--role editor with a viewer token exited $rc, not 1"
elif ! grep -q 'without --role editor the window opens view-only' \
  "$tmp/3.log"; then
  fail "--role editor with a viewer token: $(cat "$tmp/3.log")"
else
  echo "ok   --role editor with a viewer token: $(grep blobcast-view "$tmp/3.log")"
fi

# 4. --- the editor token ------------------------------------------------------------
$VIEWENV "$VIEW" --server "127.0.0.1:$port" --token edit-0123456789 \
  --verbose --size 80x60 --screenshot "$tmp/ed.png" > "$tmp/4.log" 2>&1
rc=$?
grep -q '^joined default role=editor$' "$tmp/4.log" && [ $rc -eq 0 ] ||
  fail "the editor token: status $rc, $(grep '^joined' "$tmp/4.log")"

if [ "$failures" -eq 0 ]; then
  echo "all checks passed"
  exit 0
fi
exit 1
