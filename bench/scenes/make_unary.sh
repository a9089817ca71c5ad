#!/bin/sh
# Writes the unary-node benchmark scenes of bench/bench_simd.c into
# bench/scenes/unary/: generated Fig. 18 scenes wrapped in unary and domain
# nodes (docs/scene-format.md), so that the packet tracer's handling of
# them is timed on trees of a realistic size.
#   twist.json   256 smooth spheres under a twist (rate 0.35: the tree's
#                Lipschitz bound is above 1) and an offset of 0.02
#   repeat.json  64 smooth spheres under a scale of 0.3 and a repeat of
#                3 x 1 x 3 copies 2.2 apart, mirrored on x
# Usage: bench/scenes/make_unary.sh BUILD_DIR (a build with client/blobcast)
set -eu
build=${1:?usage: make_unary.sh BUILD_DIR}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/client/blobcast" gen fig18 --count 256 --kind spheres \
	--blend smooth --out "$tmp/f256.json" >/dev/null
"$build/client/blobcast" gen fig18 --count 64 --kind spheres \
	--blend smooth --out "$tmp/f64.json" >/dev/null
python3 - "$tmp" "$here/unary" <<'PY'
import json, sys
src, out = sys.argv[1], sys.argv[2]

def wrap(node, *layers):
    # layers outermost first: each a dict of the node's own fields
    for layer in reversed(layers):
        node = dict(layer, children=[node])
    return node

d = json.load(open(src + "/f256.json"))
d["root"] = wrap(d["root"], {"type": "offset", "amount": 0.02},
                 {"type": "twist", "rate": 0.35})
json.dump(d, open(out + "/twist.json", "w"), indent=1)
d = json.load(open(src + "/f64.json"))
d["root"] = wrap(d["root"], {"type": "mirror", "axes": "x"},
                 {"type": "repeat", "spacing": [2.2, 1, 2.2],
                  "count": [3, 1, 3]},
                 {"type": "scale", "factor": 0.3})
d["camera"] = {"eye": [4.4, 4.6, 6.8], "target": [0, 0, 0],
               "up": [0, 1, 0], "fov_y_deg": 40}
json.dump(d, open(out + "/repeat.json", "w"), indent=1)
PY
echo "wrote $here/unary/twist.json and repeat.json"
