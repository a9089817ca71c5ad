#!/bin/sh
# `blobcast mesh --session` against a private blobcastd: the live scene of
# a session (the catalogue, every primitive kind, loaded with `blobcast
# load`) meshes to the same bytes as its scene file, and that mesh is a
# closed 2-manifold (tests/blobtree/check_mesh.py); an edit made in the
# session shows in the next mesh; --on-daemon gives the same files in
# every format, and its refusals; a session that does not exist is
# refused with status 1 and its name.
#
# usage: test_cli_mesh.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when a program has not been built or python3 is
# missing.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"
if ! command -v python3 > /dev/null; then
  echo "skip: python3 is missing"
  exit 77
fi
here=$(dirname "$0")
bc_scratch cli-mesh

"$BLOBCASTD" --listen 127.0.0.1:0 --unix "$tmp/d.sock" --data "$tmp/data" \
  --backend cpu --log warn > "$tmp/daemon.log" 2>&1 &
daemon=$!
i=0
while [ ! -S "$tmp/d.sock" ] && [ $i -lt 100 ] && kill -0 "$daemon"; do
  sleep 0.1
  i=$((i + 1))
done
if [ ! -S "$tmp/d.sock" ]; then
  echo "FAIL: blobcastd did not start"
  sed 's/^/    /' "$tmp/daemon.log"
  exit 1
fi
U="--server unix:$tmp/d.sock"

# blob STATUS ARGS...: blobcast ARGS must exit STATUS (its output in
# $tmp/out).
blob() {
  want=$1
  shift
  "$BLOBCAST" "$@" > "$tmp/out" 2>&1
  got=$?
  if [ "$got" -eq "$want" ]; then
    echo "ok   blobcast $*"
    return 0
  fi
  fail "blobcast $*: exit $got, wanted $want"
  sed 's/^/    /' "$tmp/out"
  return 1
}

blob 0 gen catalogue --out "$tmp/cat.json"
blob 0 $U load --session m "$tmp/cat.json"
blob 0 mesh "$tmp/cat.json" --resolution 40 \
  --out "$tmp/file.ply"
blob 0 mesh $U --session m --resolution 40 \
  --out "$tmp/live.ply"
if ! cmp -s "$tmp/file.ply" "$tmp/live.ply"; then
  fail "the session's mesh differs from the scene file's"
fi
if python3 "$here/../blobtree/check_mesh.py" --same "$tmp/file.ply" \
  "$tmp/live.ply" > "$tmp/check" 2>&1; then
  echo "ok   check_mesh.py: closed 2-manifolds, the same mesh"
else
  fail "check_mesh.py"
fi
sed 's/^/    /' "$tmp/check"

# An edit shows: the first primitive (id 2, a sphere) grows.
blob 0 $U edit --session m 2 radius=1.5
# (--server before the command word, as a global option, works too.)
blob 0 $U mesh --session m --resolution 40 --out "$tmp/edited.glb"
if python3 "$here/../blobtree/check_mesh.py" "$tmp/edited.glb" \
  > "$tmp/check" 2>&1; then
  echo "ok   check_mesh.py edited.glb"
else
  fail "check_mesh.py edited.glb"
  sed 's/^/    /' "$tmp/check"
fi
n_live=$(sed -n 's/^element face \([0-9]*\)$/\1/p' "$tmp/live.ply" | head -n 1)
n_edit=$(sed -n 's/.*triangles=\([0-9]*\) .*/\1/p' "$tmp/check")
if [ -z "$n_edit" ] || [ "$n_edit" -le "$n_live" ]; then
  fail "a bigger sphere gave $n_edit triangles, before $n_live"
fi

# --on-daemon: the daemon's file is the same, the edited session's at
# every format; its options' refusals (usage, 2) and the daemon's (1).
for f in glb obj ply stl; do
  blob 0 mesh $U --session m --resolution 40 --on-daemon --quiet \
    --out "$tmp/daemon.$f"
  blob 0 mesh $U --session m --resolution 40 --quiet --out "$tmp/here.$f"
  cmp -s "$tmp/daemon.$f" "$tmp/here.$f" ||
    fail "--on-daemon: the daemon's .$f differs from the one made here"
done
blob 2 mesh "$tmp/cat.json" --on-daemon --out "$tmp/x.glb" &&
  grep -q -- "--on-daemon applies with --session only" "$tmp/out" ||
  fail "--on-daemon without --session: not said so"
blob 2 mesh $U --session m --on-daemon --bounds 0,0,0,1,1,1 \
  --out "$tmp/x.glb"
blob 1 mesh $U --session m --on-daemon --resolution 300 --out "$tmp/x.glb" &&
  grep -q "ELIMIT" "$tmp/out" && grep -q "256" "$tmp/out" ||
  fail "--on-daemon at 300 cells: no ELIMIT naming the daemon's 256"
[ -e "$tmp/x.glb" ] && fail "a refused mesh left $tmp/x.glb"

blob 1 mesh $U --session nosuch --out "$tmp/x.obj" &&
  ! grep -q nosuch "$tmp/out" && fail "the refusal does not name the session"
[ -e "$tmp/x.obj" ] && fail "a failed mesh left $tmp/x.obj"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
