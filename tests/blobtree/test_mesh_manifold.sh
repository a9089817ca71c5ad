#!/bin/sh
# `blobcast mesh` writes closed 2-manifolds, counted by a reader that shares
# no code with the mesher (check_mesh.py): the default scene in each format
# (OBJ, PLY, STL welded by position, glb checked against the glTF rules),
# the same mesh in all four; fig18 with 1024 smoothly blended spheres (glb,
# with and without --raw: the same V - E + F, fewer triangles without)
# and the catalogue, every primitive kind (STL); a box that cuts the
# surface, or lies wholly inside a solid, still gives a closed mesh;
# --format overrides the extension; bad arguments are refused; the checker
# itself fails on a boundary edge, an edge of three triangles, a
# degenerate triangle and a broken glb.
#
# usage: test_mesh_manifold.sh BLOBCAST
# Exits 77 (skipped) when blobcast has not been built or python3 is missing.
set -u
BLOBCAST=${1:-}
if [ -z "$BLOBCAST" ] || [ ! -x "$BLOBCAST" ]; then
  echo "skip: blobcast must be built"
  exit 77
fi
if ! command -v python3 > /dev/null; then
  echo "skip: python3 is missing"
  exit 77
fi
here=$(dirname "$0")
. "$here/../scratch.sh"
bc_scratch mesh-manifold
CHECK="python3 $here/check_mesh.py"

# check WANT FILE...: check_mesh.py must exit WANT (0: all closed
# 2-manifolds) on the files.
check() {
  want=$1
  shift
  $CHECK "$@" > "$tmp/check" 2>&1
  got=$?
  sed 's/^/    /' "$tmp/check"
  if [ "$got" -ne "$want" ]; then
    fail "check_mesh.py $*: exit $got, wanted $want"
  else
    echo "ok   check_mesh.py $*"
  fi
}

# mesh ARGS...: blobcast mesh ARGS --quiet must succeed.
mesh() {
  if ! "$BLOBCAST" mesh "$@" --quiet > "$tmp/out" 2>&1; then
    fail "blobcast mesh $*"
    sed 's/^/    /' "$tmp/out"
  fi
}

"$BLOBCAST" gen default --out "$tmp/default.json" &&
  "$BLOBCAST" gen fig18 --count 1024 --kind spheres --blend smooth \
    --out "$tmp/fig18.json" &&
  "$BLOBCAST" gen catalogue --out "$tmp/catalogue.json" ||
  fail "blobcast gen"

# The default scene in every format: each a closed 2-manifold, the same
# mesh (triangle count, vertex positions) in all four.
for ext in obj ply stl glb; do
  mesh "$tmp/default.json" --resolution 40 --out "$tmp/default.$ext"
done
check 0 --same "$tmp/default.obj" "$tmp/default.ply" "$tmp/default.stl" \
  "$tmp/default.glb"

# fig18-1024 smooth (a foam of blended spheres, many thin necks) and the
# catalogue, whose boxes, cones, tori and the rest meet the grid every way.
mesh "$tmp/fig18.json" --resolution 32 --out "$tmp/fig18.glb"
mesh "$tmp/fig18.json" --resolution 32 --raw --out "$tmp/fig18-raw.glb"
mesh "$tmp/catalogue.json" --resolution 48 --out "$tmp/catalogue.stl"

# A box through the middle of the default scene: the cut solids are closed
# along its faces. --format wins over the extension.
mesh "$tmp/default.json" --resolution 40 --bounds -1,-1,-1,1,0.2,1 \
  --format glb --out "$tmp/cut.bin"
cp "$tmp/cut.bin" "$tmp/cut.glb"

# A box wholly inside a solid (a sphere of radius 10, the box 2 wide at
# the centre): no surface crosses it, yet the mesh is the closed box, a
# sphere's topology (V - E + F = 2).
printf '{"blobcast": 1, "root": {"type": "sphere", "id": 1, "radius": 10}}\n' \
  > "$tmp/big.json"
mesh "$tmp/big.json" --resolution 24 --bounds -1,-1,-1,1,1,1 \
  --out "$tmp/inside.stl"
check 0 "$tmp/fig18.glb" "$tmp/fig18-raw.glb" "$tmp/catalogue.stl" \
  "$tmp/cut.glb" "$tmp/inside.stl"
# Collapsing short edges keeps the topology (V - E + F) and thins out.
euler() { sed -n "s|^.*$1: ok .*euler=\(-*[0-9]*\)$|\1|p" "$tmp/check"; }
tris() { sed -n "s|^.*$1: ok .*triangles=\([0-9]*\) .*|\1|p" "$tmp/check"; }
if [ -z "$(euler fig18.glb)" ] ||
  [ "$(euler fig18.glb)" != "$(euler fig18-raw.glb)" ] ||
  [ "$(tris fig18.glb)" -ge "$(tris fig18-raw.glb)" ]; then
  fail "fig18: collapsed $(tris fig18.glb) triangles, euler $(euler fig18.glb); raw $(tris fig18-raw.glb), euler $(euler fig18-raw.glb)"
fi
grep -q "inside.stl: ok .*euler=2$" "$tmp/check" ||
  fail "the box inside a solid: euler=2"

# The checker finds what it looks for: a hole (an open tetrahedron), a fin
# (an edge of three triangles), a flat triangle, a glb of version 3.
tet='v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\n'
printf "$tet" > "$tmp/boundary.obj"
printf "${tet}v 0 -1 0\nf 3 1 4\nf 1 2 5\n" > "$tmp/nonmanifold.obj"
printf 'v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 3 2 4\nf 2 1 4\n' \
  > "$tmp/degenerate.obj"
cp "$tmp/default.glb" "$tmp/broken.glb"
printf '\003' | dd of="$tmp/broken.glb" bs=1 seek=4 conv=notrunc 2> /dev/null
check 1 "$tmp/boundary.obj" "$tmp/nonmanifold.obj" "$tmp/degenerate.obj" \
  "$tmp/broken.glb"
for want in "boundary.obj: FAIL .* boundary=3 " \
  "nonmanifold.obj: FAIL .* nonmanifold=1 " \
  "degenerate.obj: FAIL .* degenerate=1 " "broken.glb: FAIL GLB: version 3"; do
  grep -q "$want" "$tmp/check" || fail "check_mesh.py did not say: $want"
done

# Bad arguments.
"$BLOBCAST" mesh "$tmp/default.json" --out "$tmp/x.mesh" > "$tmp/out" 2>&1
[ $? -eq 2 ] && grep -q "give --format" "$tmp/out" ||
  fail "an unknown extension without --format is a usage error"
"$BLOBCAST" mesh "$tmp/default.json" --token x --out "$tmp/x.obj" \
  > "$tmp/out" 2>&1
[ $? -eq 2 ] && grep -q "with --session only" "$tmp/out" ||
  fail "--token without --session is a usage error"
"$BLOBCAST" mesh "$tmp/default.json" --session s --out "$tmp/x.obj" \
  > "$tmp/out" 2>&1
[ $? -eq 2 ] && grep -q "not both" "$tmp/out" ||
  fail "SCENE and --session together are a usage error"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
