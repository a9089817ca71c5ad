#!/usr/bin/env python3
"""Reads triangle meshes back from OBJ, PLY (binary little endian or
ASCII), binary STL and binary glTF 2.0 (.glb) files and checks, without
any of the mesher's code, that each is a closed 2-manifold:

* every undirected edge is used by exactly two triangles (none by one: a
  boundary edge; none by three or more: a non-manifold edge), and every
  directed edge once, with its reverse once (consistent orientation);
* no triangle is degenerate (a repeated vertex, or zero area computed in
  double precision from the file's coordinates);
* no two vertices share a position (STL has no indices: its triangles are
  welded by exact position, so such vertices would be merged there).

A .glb is also checked against the glTF 2.0 rules it must follow: header,
chunk types and lengths, 4-byte alignment, the JSON chunk padded with
spaces and the BIN chunk with zeros, bufferViews inside the buffer,
accessor types and counts inside their views, POSITION's min and max equal
to the data's, indices below the vertex count, unit normals.

Usage: check_mesh.py [--same] FILE...
  --same   also require all files to hold the same mesh: the same
           triangle count and the same set of vertex positions.
Prints one line per file; exit status 1 when a check fails.
"""
import json
import math
import struct
import sys
from collections import Counter


class Bad(Exception):
    pass


def need(cond, what):
    if not cond:
        raise Bad(what)


# ---- readers: each returns (positions, triangles) ----------------------


def read_obj(data):
    pos, tris = [], []
    for line in data.decode("ascii").splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "v":
            need(len(w) >= 4, "OBJ: short v line: %r" % line)
            # Round to float32: the other formats store that.
            pos.append(tuple(struct.unpack("<3f", struct.pack(
                "<3f", *(float(x) for x in w[1:4])))))
        elif w[0] == "f":
            need(len(w) == 4, "OBJ: face is not a triangle: %r" % line)
            idx = []
            for x in w[1:]:
                i = int(x.split("/")[0])
                idx.append(i - 1 if i > 0 else len(pos) + i)
            tris.append(tuple(idx))
    return pos, tris


PLY_TYPES = {
    "char": "b", "int8": "b", "uchar": "B", "uint8": "B",
    "short": "h", "int16": "h", "ushort": "H", "uint16": "H",
    "int": "i", "int32": "i", "uint": "I", "uint32": "I",
    "float": "f", "float32": "f", "double": "d", "float64": "d",
}


def read_ply(data):
    end = data.find(b"end_header\n")
    need(data.startswith(b"ply\n") and end > 0, "PLY: no header")
    head = data[:end].decode("ascii").splitlines()
    body = data[end + len(b"end_header\n"):]
    fmt, elements = None, []
    for line in head[1:]:
        w = line.split()
        if not w or w[0] in ("comment", "obj_info"):
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            need(elements, "PLY: property before element")
            elements[-1][2].append(w[1:])
    need(fmt in ("binary_little_endian", "ascii"), "PLY: format %s" % fmt)
    pos, tris = [], []
    at = 0
    words = body.decode("ascii").split() if fmt == "ascii" else None

    def take(t):
        nonlocal at
        if words is not None:
            v = words[at]
            at += 1
            return float(v) if PLY_TYPES[t] in "fd" else int(v)
        c = PLY_TYPES[t]
        size = struct.calcsize("<" + c)
        need(at + size <= len(body), "PLY: body too short")
        v = struct.unpack_from("<" + c, body, at)[0]
        at += size
        return v

    for name, count, props in elements:
        for _ in range(count):
            rec = {}
            for p in props:
                if p[0] == "list":
                    n = take(p[1])
                    rec[p[3]] = [take(p[2]) for _ in range(n)]
                else:
                    rec[p[1]] = take(p[0])
            if name == "vertex":
                xyz = (rec["x"], rec["y"], rec["z"])
                pos.append(tuple(struct.unpack(
                    "<3f", struct.pack("<3f", *xyz))))
            elif name == "face":
                f = rec.get("vertex_indices", rec.get("vertex_index"))
                need(f is not None and len(f) == 3,
                     "PLY: face is not a triangle")
                tris.append(tuple(f))
    need(words is not None or at == len(body),
         "PLY: %d bytes after the last element" % (len(body) - at))
    return pos, tris


def read_stl(data):
    need(len(data) >= 84, "STL: shorter than its header")
    n = struct.unpack_from("<I", data, 80)[0]
    need(len(data) == 84 + 50 * n,
         "STL: %d bytes for %d facets" % (len(data), n))
    index, pos, tris = {}, [], []
    for i in range(n):
        rec = 84 + 50 * i + 12
        t = []
        for k in range(3):
            key = data[rec + 12 * k:rec + 12 * k + 12]
            if key not in index:
                index[key] = len(pos)
                pos.append(struct.unpack("<3f", key))
            t.append(index[key])
        tris.append(tuple(t))
    return pos, tris


GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
COMP = {5120: ("b", 1), 5121: ("B", 1), 5122: ("h", 2), 5123: ("H", 2),
        5125: ("I", 4), 5126: ("f", 4)}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_glb(data):
    need(len(data) >= 20, "GLB: shorter than a header")
    magic, version, length = struct.unpack_from("<3I", data, 0)
    need(magic == GLB_MAGIC, "GLB: magic")
    need(version == 2, "GLB: version %d" % version)
    need(length == len(data), "GLB: length %d, file %d" % (length,
                                                          len(data)))
    need(length % 4 == 0, "GLB: length not a multiple of 4")
    chunks, at = [], 12
    while at < length:
        need(at + 8 <= length, "GLB: truncated chunk header")
        clen, ctype = struct.unpack_from("<2I", data, at)
        need(clen % 4 == 0, "GLB: chunk length %d not aligned" % clen)
        need(at + 8 + clen <= length, "GLB: chunk past the end")
        chunks.append((ctype, data[at + 8:at + 8 + clen]))
        at += 8 + clen
    need(chunks and chunks[0][0] == JSON_CHUNK, "GLB: first chunk not JSON")
    text = chunks[0][1]
    stripped = text.rstrip(b" ")
    need(len(text) - len(stripped) < 4, "GLB: JSON padding over 3 bytes")
    need(b"\0" not in text, "GLB: JSON chunk padded with zeros")
    gl = json.loads(stripped.decode("utf-8"))
    need(gl.get("asset", {}).get("version") == "2.0", "glTF: asset.version")
    binc = chunks[1][1] if len(chunks) > 1 else b""
    need(len(chunks) < 2 or chunks[1][0] == BIN_CHUNK,
         "GLB: second chunk not BIN")
    buffers = gl.get("buffers", [])
    if binc or buffers:
        need(len(buffers) == 1 and "uri" not in buffers[0],
             "glTF: one buffer, the BIN chunk")
        blen = buffers[0]["byteLength"]
        need(blen <= len(binc) and len(binc) - blen < 4,
             "glTF: buffer %d bytes, BIN chunk %d" % (blen, len(binc)))
        need(binc[blen:] == b"\0" * (len(binc) - blen),
             "GLB: BIN padding not zeros")
    views = gl.get("bufferViews", [])
    for v in views:
        off = v.get("byteOffset", 0)
        need(v["buffer"] == 0, "glTF: bufferView buffer")
        need(off % 4 == 0, "glTF: bufferView offset %d unaligned" % off)
        need(off + v["byteLength"] <= len(binc),
             "glTF: bufferView past the buffer")
        need(v.get("target") in (None, 34962, 34963),
             "glTF: bufferView target")

    def accessor(i, types):
        a = gl["accessors"][i]
        need(a["type"] in types, "glTF: accessor %d type %s" % (i,
                                                                a["type"]))
        c, size = COMP[a["componentType"]]
        nc = NCOMP[a["type"]]
        need(a["count"] >= 1, "glTF: accessor %d count 0" % i)
        v = views[a["bufferView"]]
        off = a.get("byteOffset", 0)
        stride = v.get("byteStride", size * nc)
        need(off % size == 0 and stride % size == 0,
             "glTF: accessor %d unaligned" % i)
        need(off + stride * (a["count"] - 1) + size * nc <= v["byteLength"],
             "glTF: accessor %d past its bufferView" % i)
        base = v.get("byteOffset", 0) + off
        f = "<%d%s" % (nc, c)
        if stride == size * nc:
            end = base + stride * a["count"]
            return a, list(struct.iter_unpack(f, binc[base:end]))
        return a, [struct.unpack_from(f, binc, base + stride * k)
                   for k in range(a["count"])]

    meshes = gl.get("meshes", [])
    pos, tris = [], []
    for mesh in meshes:
        for prim in mesh["primitives"]:
            need(prim.get("mode", 4) == 4, "glTF: mode not TRIANGLES")
            at = prim["attributes"]
            pa, p = accessor(at["POSITION"], ("VEC3",))
            need(pa["componentType"] == 5126, "glTF: POSITION not float")
            f32 = lambda v: struct.unpack("<f", struct.pack("<f", v))[0]
            for k in range(3):
                lo = min(x[k] for x in p)
                hi = max(x[k] for x in p)
                # JSON numbers are compared as the component type
                # (float32), as glTF validators do.
                need(f32(pa["min"][k]) == lo and f32(pa["max"][k]) == hi,
                     "glTF: POSITION min/max %s %s, data %s %s" %
                     (pa["min"], pa["max"], lo, hi))
            need(views[gl["accessors"][at["POSITION"]]["bufferView"]]
                 .get("target") == 34962, "glTF: POSITION view target")
            if "NORMAL" in at:
                na, nrm = accessor(at["NORMAL"], ("VEC3",))
                need(na["count"] == pa["count"], "glTF: NORMAL count")
                need(all(abs(math.hypot(*x) - 1) < 1e-3 for x in nrm),
                     "glTF: NORMAL not unit length")
            if "COLOR_0" in at:
                ca, col = accessor(at["COLOR_0"], ("VEC3", "VEC4"))
                need(ca["count"] == pa["count"], "glTF: COLOR_0 count")
                need(ca["componentType"] == 5126 or
                     (ca["componentType"] in (5121, 5123) and
                      ca.get("normalized")), "glTF: COLOR_0 type")
            ia, idx = accessor(prim["indices"], ("SCALAR",))
            need(ia["componentType"] in (5121, 5123, 5125),
                 "glTF: indices componentType")
            need(views[ia["bufferView"]].get("target") == 34963,
                 "glTF: indices view target")
            need(ia["count"] % 3 == 0, "glTF: indices not triangles")
            need(max(x[0] for x in idx) < pa["count"],
                 "glTF: index past the vertices")
            base = len(pos)
            pos += p
            tris += [(base + idx[k][0], base + idx[k + 1][0],
                      base + idx[k + 2][0]) for k in range(0, len(idx), 3)]
    return pos, tris


READERS = {"obj": read_obj, "ply": read_ply, "stl": read_stl,
           "glb": read_glb}


# ---- the counts ----------------------------------------------------------


def count(pos, tris):
    a_, b_, c_ = zip(*tris)
    # Directed edges (u, v) and undirected ones (min, max), counted.
    us, vs = a_ + b_ + c_, b_ + c_ + a_
    dire = Counter(zip(us, vs))
    und = Counter(zip(map(min, us, vs), map(max, us, vs)))
    degenerate = 0
    for a, b, c in tris:
        if a == b or b == c or a == c:
            degenerate += 1
            continue
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = pos[a], pos[b], pos[c]
        ux, uy, uz = bx - ax, by - ay, bz - az
        vx, vy, vz = cx - ax, cy - ay, cz - az
        degenerate += (uy * vz - uz * vy == 0.0 and uz * vx - ux * vz == 0.0
                       and ux * vy - uy * vx == 0.0)
    boundary = sum(1 for n in und.values() if n == 1)
    nonmanifold = sum(1 for n in und.values() if n > 2)
    misoriented = sum(1 for (u, v), n in dire.items()
                      if n != 1 or dire.get((v, u)) != 1)
    used = set(us)
    return {
        "vertices": len(pos), "triangles": len(tris), "edges": len(und),
        "boundary": boundary, "nonmanifold": nonmanifold,
        "misoriented": misoriented, "degenerate": degenerate,
        "duplicate_positions": len(pos) - len(set(pos)),
        "unused_vertices": len(pos) - len(used),
        "euler": len(used) - len(und) + len(tris),
    }


def main(argv):
    same = "--same" in argv
    files = [a for a in argv if a != "--same"]
    if not files:
        print(__doc__.strip().splitlines()[-5], file=sys.stderr)
        return 2
    failed = False
    meshes = []
    for path in files:
        ext = path.rsplit(".", 1)[-1].lower()
        try:
            need(ext in READERS, "unknown extension .%s" % ext)
            with open(path, "rb") as f:
                pos, tris = READERS[ext](f.read())
            need(tris, "no triangles")
            need(all(0 <= i < len(pos) for t in tris for i in t),
                 "an index past the vertices")
            c = count(pos, tris)
        except (Bad, KeyError, ValueError, IndexError, struct.error) as e:
            print("%s: FAIL %s" % (path, e))
            failed = True
            continue
        bad = [k for k in ("boundary", "nonmanifold", "misoriented",
                           "degenerate", "duplicate_positions",
                           "unused_vertices") if c[k]]
        print("%s: %s %s" % (path, "FAIL" if bad else "ok",
                             " ".join("%s=%d" % kv for kv in c.items())))
        failed |= bool(bad)
        meshes.append((path, len(tris), set(pos)))
    if same and len(meshes) > 1:
        for path, nt, ps in meshes[1:]:
            if nt != meshes[0][1] or ps != meshes[0][2]:
                print("%s: FAIL not the same mesh as %s" % (path,
                                                           meshes[0][0]))
                failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
