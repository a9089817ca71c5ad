#!/bin/sh
# Per-person undo from the command line, against a private blobcastd (free
# loopback port, temporary data directory; PROTOCOL.md 7.20, 7.26):
#  - `load --name alice` creates session rev: alice owns it;
#  - `undo --name alice` takes back alice's edit, not bob's newer one --
#    each run joins anew, the --name is the person;
#  - `undo --any` is refused to bob (exit 1, EPERM, naming the owner) and
#    takes bob's change for alice, the owner;
#  - `history` lists both changes (who, what, when) and marks the one
#    `redo --name bob` takes; `history --json` gives the same as JSON;
#  - after a SIGTERM restart of the daemon, `history` is the same and
#    `redo --name bob` still takes bob's change.
#
# usage: test_cli_undo.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"
bc_scratch cli-undo

start_daemon 127.0.0.1:0
S="--server 127.0.0.1:$port"
R="--session rev"

"$BLOBCAST" gen default > "$tmp/default.json" || fail "gen default"
"$BLOBCAST" $S load $R --name alice "$tmp/default.json" > /dev/null ||
  fail "load as alice"
"$BLOBCAST" $S edit $R --name alice 11 translate=0.1,0,0 > "$tmp/ea" ||
  fail "edit as alice"
"$BLOBCAST" $S edit $R --name bob 50 radius=0.2 > "$tmp/eb" ||
  fail "edit as bob"
ea=$(sed -n 's/^node 11: edit applied, edit order \([0-9]*\)$/\1/p' "$tmp/ea")
eb=$(sed -n 's/^node 50: edit applied, edit order \([0-9]*\)$/\1/p' "$tmp/eb")
[ -n "$ea" ] && [ -n "$eb" ] || fail "edit output not understood"

# alice's undo takes hers, though bob's is newer.
"$BLOBCAST" $S undo $R --name alice > "$tmp/u1" 2>&1 ||
  fail "undo as alice: $(cat "$tmp/u1")"
grep -qE "^undid edit $ea by \"alice\": edit order [0-9]+\$" "$tmp/u1" ||
  fail "alice's undo did not take her edit $ea: $(cat "$tmp/u1")"

# bob may not take back the session's change; alice, the owner, may.
"$BLOBCAST" $S undo $R --name bob --any > "$tmp/u2" 2>&1
st=$?
[ "$st" -eq 1 ] || fail "undo --any as bob exited $st, not 1"
grep -q "only the session's owner (alice) or its presenter.*(EPERM)" \
  "$tmp/u2" || fail "undo --any as bob: $(cat "$tmp/u2")"
"$BLOBCAST" $S undo $R --name alice --any > "$tmp/u3" 2>&1 ||
  fail "undo --any as alice: $(cat "$tmp/u3")"
grep -qE "^undid edit $eb by \"bob\": edit order [0-9]+\$" "$tmp/u3" ||
  fail "the owner's undo --any did not take bob's $eb: $(cat "$tmp/u3")"

# history: both undone, bob's marked as what his redo takes.
"$BLOBCAST" $S history $R --name bob > "$tmp/h1" 2>&1 ||
  fail "history: $(cat "$tmp/h1")"
sed 's/^/    /' "$tmp/h1"
grep -qE "^ +$eb  [0-9-]+ [0-9:]+  undone   bob +SET node 50 radius  <- your redo\$" \
  "$tmp/h1" || fail "history: no line for bob's $eb"
grep -qE "^ +$ea  [0-9-]+ [0-9:]+  undone   alice +SET node 11 translate\$" \
  "$tmp/h1" || fail "history: no line for alice's $ea"
"$BLOBCAST" $S history $R --name bob --json > "$tmp/h1.json" ||
  fail "history --json"
python3 - "$tmp/h1.json" "$ea" "$eb" <<'PY' || fail "history --json"
import json, sys
doc = json.load(open(sys.argv[1]))
ch = {c["order"]: c for c in doc["changes"]}
a, b = ch[int(sys.argv[2])], ch[int(sys.argv[3])]
assert a["author"] == "alice" and a["state"] == "undone", a
assert b["author"] == "bob" and b["yours"] and b["next"], b
assert b["time_ms"] > 1700000000000 and b["built_on"] == 0, b
PY

# A restart keeps the history and who owns what.
stop_daemon
: > "$tmp/daemon.log" # start_daemon waits for the new daemon's line
start_daemon "127.0.0.1:$port"
"$BLOBCAST" $S history $R --name bob > "$tmp/h2" 2>&1 ||
  fail "history after the restart: $(cat "$tmp/h2")"
cmp -s "$tmp/h1" "$tmp/h2" || fail "history changed across a restart"
"$BLOBCAST" $S redo $R --name bob > "$tmp/r1" 2>&1 ||
  fail "redo as bob: $(cat "$tmp/r1")"
grep -qE "^redid edit $eb by \"bob\": edit order [0-9]+\$" "$tmp/r1" ||
  fail "bob's redo after the restart: $(cat "$tmp/r1")"

[ "$failures" -eq 0 ] || exit 1
echo "ok: per-person undo, --any, history and a restart from the CLI"
