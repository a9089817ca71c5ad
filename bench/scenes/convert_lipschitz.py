#!/usr/bin/env python3
"""Converts a Lipschitz Pruning scene (Barbier, Sanchez et al., Eurographics
2025, github.com/wbrbr/LipschitzPruning, scenes/*.json) into a blobcast
version-1 scene file (docs/scene-format.md).

Their format is a binary tree: "binaryOperator" nodes (blendMode union,
inter or sub; blendRadius k; leftChild, rightChild) over "primitive" nodes
(sphere, box, cylinder, cone), each node with a 3x4 row-major "matrix".
Their loader (src/scene.cpp) composes the matrices from the root down, and
their shader applies the product to the world point: it is the
world-to-primitive map, local = M p + m.

What the conversion does, and why (docs/benchmarks.md, section "CPU tracer:
SIMD, threads, libfive, Lipschitz Pruning scenes", has the numbers):

- Transforms. Every operator's matrix is pushed down into its primitives
  (exact: an SDF operator commutes with a rigid motion of all its operands).
  Our primitives take R^T (p - t); so R = M^T and t = -M^T m. A matrix that
  is not a rotation (scale, shear, reflection) is refused: our format has no
  scale.
- Operators. Their smooth operators are the quadratic polynomial smooth
  min/max, min(a, b) - max(k - |a - b|, 0)^2 / (4k); ours are the cubic
  compact ones, min(a, b) - beta/6 max(1 - |a - b|/beta, 0)^3, closed by the
  transition b_r over the range r. The zero set of one of our operators is
  exactly that of its cubic blend with beta (b_r(0) = beta), so beta is
  chosen to make the fillets alike: the offset of the fillet from the sharp
  union at |a - b| = x is the kernel, and beta = 1.44 k minimises both the
  L2 and (within 0.2 %) the largest difference of the two kernels, which is
  then 1.1 % of k. range = 1.25 beta, our default (the smallest continuous
  range is 7/6 beta). k = 0 is the sharp operator.
- Chains. Our operators are n-ary and fold left: ((c0 op c1) op c2) ... So a
  left chain of one operator with one blend radius (Molecule's 1000 pairwise
  smooth unions) is written as one n-ary operator: the same function, not an
  approximation, and 2 levels deep instead of 1001. Sharp union and
  intersection chains are flattened on both sides (min and max are
  associative and commutative); nothing else is reassociated, since smooth
  operators are not associative.
- Primitives. sphere: radius. cylinder: their "height" is the full height
  (half_height = height / 2), axis y in both. cone: theirs has the base
  (radius) at y = -h and the apex at +h: ours with radius_top = 0. box:
  their box is a 2D rounded rectangle in xz (four corner radii "bevel") of
  half sides sides/2, extruded along y with edge radii round_x (top) and
  round_y (bottom). When all roundings are equal and fit the box, that is
  exactly our box with one "round". Otherwise the box is approximated by
  ours with half extents equal to the true extents of their shape along
  its axes (found by bisection on a port of their distance function; their
  corner radii can exceed the half side, as every box of Trees does) and
  round = the smallest of those extents and of their mean rounding.
- Camera. Theirs is interactive (default: from +z looking at the origin,
  90 degrees). The scene gets one from +z (their default direction) aimed
  at the centre of their "aabb", its front face filling a 40 degree view.
- Ids are assigned in pre-order from 1; colours are copied (clamped to
  [0, 1]).

The output nests at most BC_TREE_MAX_DEPTH = 128 levels or the conversion
fails (exit status 1) naming the depth; --no-flatten keeps their binary
nesting (Molecule is then 1001 levels deep and refused).

Usage: convert_lipschitz.py IN.json OUT.json [--blend-scale S]
       [--range-scale R] [--no-flatten]
Standard library only.
"""

import argparse
import json
import math
import sys

MAX_DEPTH = 128  # BC_TREE_MAX_DEPTH: the root is at depth 1.

# beta / k: the least-squares (and nearly minimax) fit of our cubic kernel
# beta/6 (1 - x/beta)^3 to their quadratic k/4 (1 - x/k)^2 over x >= 0.
BLEND_SCALE = 1.44
# r / beta: bc_op_default_range.
RANGE_SCALE = 1.25

# Blend radii at most this are sharp operators (see blend_radius).
SHARP_BELOW = 1e-6

IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]


class ConvertError(Exception):
    pass


def mat_mul(a, b):
    """Product of two 3x4 row-major affine matrices (as 4x4 with 0 0 0 1)."""
    out = []
    for r in range(3):
        row = []
        for c in range(4):
            v = sum(a[r * 4 + i] * b[i * 4 + c] for i in range(3))
            if c == 3:
                v += a[r * 4 + 3]
            row.append(v)
        out.extend(row)
    return out


def rigid_parts(m, where):
    """Our (rotation quaternion, translate) of their world-to-local m."""
    rot = [[m[r * 4 + c] for c in range(3)] for r in range(3)]
    for i in range(3):
        for j in range(3):
            dot = sum(rot[k][i] * rot[k][j] for k in range(3))
            if abs(dot - (1.0 if i == j else 0.0)) > 1e-3:
                raise ConvertError(
                    "%s: matrix is not a rotation (scale or shear); "
                    "blobcast primitives have no scale" % where)
    det = (rot[0][0] * (rot[1][1] * rot[2][2] - rot[1][2] * rot[2][1]) -
           rot[0][1] * (rot[1][0] * rot[2][2] - rot[1][2] * rot[2][0]) +
           rot[0][2] * (rot[1][0] * rot[2][1] - rot[1][1] * rot[2][0]))
    if det < 0:
        raise ConvertError("%s: matrix is a reflection" % where)
    # Ours: local = R^T (p - t), theirs: local = M p + m, so R = M^T.
    rr = [[rot[c][r] for c in range(3)] for r in range(3)]
    mt = [m[3], m[7], m[11]]
    t = [-sum(rr[r][c] * mt[c] for c in range(3)) for r in range(3)]
    return quat_from_matrix(rr), t


def quat_from_matrix(r):
    """Unit quaternion (x, y, z, w) of rotation matrix r (Shepperd)."""
    tr = r[0][0] + r[1][1] + r[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s,
             (r[1][0] - r[0][1]) / s, 0.25 * s]
    elif r[0][0] > r[1][1] and r[0][0] > r[2][2]:
        s = math.sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]) * 2
        q = [0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s,
             (r[2][1] - r[1][2]) / s]
    elif r[1][1] > r[2][2]:
        s = math.sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]) * 2
        q = [(r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s,
             (r[0][2] - r[2][0]) / s]
    else:
        s = math.sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]) * 2
        q = [(r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s,
             (r[1][0] - r[0][1]) / s]
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


def their_box_sdf(p, sides, bevel, round_x, round_y):
    """Port of their eval_prim box (shaders/common.glsl): sdRoundBox in xz
    extruded along y by sdExtrude. bevel is already their decoded radius."""
    hx, hy, hz = sides[0] * 0.5, sides[1] * 0.5, sides[2] * 0.5
    px, py, pz = p
    r = bevel[0:2] if px > 0 else bevel[2:4]
    rc = r[0] if pz > 0 else r[1]
    qx = abs(px) - hx + rc
    qz = abs(pz) - hz + rc
    d2 = (min(max(qx, qz), 0.0) + math.hypot(max(qx, 0.0), max(qz, 0.0)) -
          rc)
    er = round_x if py > 0 else round_y
    ex, ey = d2 + er, abs(py) - (hy - er)
    return min(max(ex, ey), 0.0) + math.hypot(max(ex, 0.0), max(ey, 0.0)) - er


def extent(f, axis, hi):
    """Distance from the origin to f's zero set along +axis (bisection)."""
    lo = 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        p = [0.0, 0.0, 0.0]
        p[axis] = mid
        if f(p) < 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def convert_box(j, where):
    sides = [float(v) for v in j["sides"]]
    bevel = [float(v) for v in j["bevel"]]
    rx, ry = float(j["round_x"]), float(j["round_y"])
    half = [s * 0.5 for s in sides]
    rounds = bevel + [rx, ry]
    if min(half) <= 0:
        raise ConvertError("%s: box with a non-positive side" % where)
    fits = max(bevel) <= min(half[0], half[2]) and max(rx, ry) <= half[1]
    if max(rounds) - min(rounds) <= 1e-6 and fits:
        return {"half_extents": half, "round": min(rounds[0], min(half))}, 1
    f = (lambda p: their_box_sdf(p, sides, bevel, rx, ry))
    ext = [extent(f, a, 2 * max(half)) for a in range(3)]
    rnd = min(min(ext), sum(rounds) / len(rounds))
    return {"half_extents": ext, "round": max(rnd, 0.0)}, 0


def blend_radius(j):
    """Their blendRadius; their exporter writes about 1e-8 for sharp
    operators (Trees' root), which is read as 0: sharp."""
    k = float(j["blendRadius"])
    return 0.0 if abs(k) <= SHARP_BELOW else k


def clamp01(v):
    return min(max(float(v), 0.0), 1.0)


OPS = {"union": ("union", "smooth_union"),
       "inter": ("intersection", "smooth_intersection"),
       "sub": ("difference", "smooth_difference")}


def convert(doc, blend_scale, range_scale, flatten):
    stats = {"prims": 0, "ops": 0, "boxes_exact": 0, "boxes_approx": 0}

    def node(j, parent_mat, where):
        kind = j["nodeType"]
        if kind == "primitive":
            return prim(j, mat_mul(parent_mat, j.get("matrix", IDENTITY)),
                        where)
        if kind != "binaryOperator":
            raise ConvertError("%s: unknown nodeType %r" % (where, kind))
        mode, k = j["blendMode"], blend_radius(j)
        if mode not in OPS:
            raise ConvertError("%s: unknown blendMode %r" % (where, mode))
        if k < 0:
            raise ConvertError("%s: negative blendRadius" % where)
        stats["ops"] += 1
        out = {"type": OPS[mode][1 if k > 0 else 0]}
        if k > 0:
            beta = blend_scale * k
            out["blend"] = beta
            out["range"] = range_scale * beta
        out["children"] = [node(cj, cm, cw)
                           for cj, cm, cw in operands(j, parent_mat, where)]
        return out

    def operands(j, parent_mat, where):
        """The operands of j's operator in fold order: its left chain of
        operators of the same kind and blend radius (and, for the sharp
        union and intersection, its right ones too) is expanded,
        iteratively, since Molecule's chain is 1000 deep."""
        key = (j["blendMode"], blend_radius(j))
        assoc = key[1] == 0 and key[0] in ("union", "inter")
        out = []
        todo = [(j, parent_mat, where, True)]
        while todo:
            cj, cm, cw, expand = todo.pop()
            same = (cj["nodeType"] == "binaryOperator" and
                    (cj["blendMode"], blend_radius(cj)) == key)
            if cj is not j and not (flatten and expand and same):
                out.append((cj, cm, cw))
                continue
            m2 = mat_mul(cm, cj.get("matrix", IDENTITY))
            # LIFO: the whole left fold is emitted before the right operand.
            todo.append((cj["rightChild"], m2, cw + ".rightChild", assoc))
            todo.append((cj["leftChild"], m2, cw + ".leftChild", True))
        return out

    def prim(j, mat, where):
        q, t = rigid_parts(mat, where)
        pt = j["primitiveType"]
        out = {"type": pt}
        if pt == "sphere":
            out["radius"] = float(j["radius"])
        elif pt == "box":
            fields, exact = convert_box(j, where)
            out.update(fields)
            stats["boxes_exact" if exact else "boxes_approx"] += 1
        elif pt == "cylinder":
            out["radius"] = float(j["radius"])
            out["half_height"] = float(j["height"]) * 0.5
        elif pt == "cone":
            out["half_height"] = float(j["height"]) * 0.5
            out["radius_bottom"] = float(j["radius"])
            out["radius_top"] = 0.0
        else:
            raise ConvertError("%s: unknown primitiveType %r" % (where, pt))
        if any(abs(v) > 1e-9 for v in t):
            out["translate"] = t
        if any(abs(q[i] - (0, 0, 0, 1)[i]) > 1e-9 for i in range(4)):
            out["rotate"] = q
        if "color" in j:
            out["color"] = [clamp01(v) for v in j["color"]]
        stats["prims"] += 1
        return out

    root = node(doc, IDENTITY, "root")
    lo = [float(v) for v in doc.get("aabb_min", [-1, -1, -1])]
    hi = [float(v) for v in doc.get("aabb_max", [1, 1, 1])]
    centre = [(a + b) * 0.5 for a, b in zip(lo, hi)]
    # The front face of the box fills the view; a 5 % margin.
    half = [(b - a) * 0.5 for a, b in zip(lo, hi)]
    fov = 40.0
    dist = 1.05 * max(half[0], half[1]) / math.tan(math.radians(fov * 0.5))
    dist += half[2]
    camera = {"eye": [centre[0], centre[1], centre[2] + dist],
              "target": centre, "up": [0.0, 1.0, 0.0], "fov_y_deg": fov}
    return {"blobcast": 1, "camera": camera, "root": root}, stats


def assign_ids_and_depth(root):
    """Pre-order ids from 1; returns the deepest level (root = 1)."""
    next_id, deepest = 1, 0
    stack = [(root, 1)]
    while stack:
        n, depth = stack.pop()
        deepest = max(deepest, depth)
        n["id"] = next_id
        next_id += 1
        for c in reversed(n.get("children", [])):
            stack.append((c, depth + 1))
    return deepest


def fmt(v):
    if isinstance(v, float):
        s = "%.9g" % v
        return s if s not in ("-0", "0") else "0"
    if isinstance(v, list):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    return json.dumps(v)


def write(doc, out):
    """One primitive per line, operators indented (iterative: deep trees)."""
    parts = ['{"blobcast": 1,\n "camera": ',
             "{" + ", ".join('"%s": %s' % (k, fmt(v))
                             for k, v in doc["camera"].items()) + "},\n",
             ' "root":\n']
    stack = [("node", doc["root"], 1, True)]
    while stack:
        item = stack.pop()
        if item[0] == "text":
            parts.append(item[1])
            continue
        _, n, depth, last = item
        pad = " " * min(depth, 40)
        fields = ", ".join('"%s": %s' % (k, fmt(v)) for k, v in n.items()
                           if k != "children")
        tail = "" if last else ","
        if "children" not in n:
            parts.append("%s{%s}%s\n" % (pad, fields, tail))
            continue
        parts.append('%s{%s, "children": [\n' % (pad, fields))
        stack.append(("text", "%s]}%s\n" % (pad, tail)))
        kids = n["children"]
        for i in range(len(kids) - 1, -1, -1):
            stack.append(("node", kids[i], depth + 1, i == len(kids) - 1))
    parts.append("}\n")
    out.write("".join(parts))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--blend-scale", type=float, default=BLEND_SCALE,
                    help="our blend / their blendRadius (default %g)" %
                    BLEND_SCALE)
    ap.add_argument("--range-scale", type=float, default=RANGE_SCALE,
                    help="our range / our blend (default %g; above 1/6)" %
                    RANGE_SCALE)
    ap.add_argument("--no-flatten", action="store_true",
                    help="keep their binary nesting")
    a = ap.parse_args(argv)
    if a.blend_scale <= 0 or a.range_scale <= 1.0 / 6.0:
        ap.error("--blend-scale must be > 0 and --range-scale > 1/6")
    # Their files nest one JSON object per operator (Molecule: 1001 deep).
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 20000))
    try:
        with open(a.input, encoding="utf-8") as f:
            doc = json.load(f)
        scene, stats = convert(doc, a.blend_scale, a.range_scale,
                               not a.no_flatten)
    except (OSError, ValueError, KeyError, TypeError, ConvertError) as e:
        print("convert_lipschitz: %s: %s" % (a.input, e), file=sys.stderr)
        return 1
    depth = assign_ids_and_depth(scene["root"])
    if depth > MAX_DEPTH:
        print("convert_lipschitz: %s: the tree nests %d levels, over "
              "blobcast's limit of %d (BC_TREE_MAX_DEPTH); not written"
              % (a.input, depth, MAX_DEPTH), file=sys.stderr)
        return 1
    with open(a.output, "w", encoding="utf-8") as f:
        write(scene, f)
    print("%s: %d primitives, %d operators, depth %d, boxes exact %d, "
          "approximated %d" % (a.output, stats["prims"], stats["ops"], depth,
                               stats["boxes_exact"], stats["boxes_approx"]),
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
