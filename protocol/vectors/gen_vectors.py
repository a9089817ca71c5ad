#!/usr/bin/env python3
"""Generates the protocol test vectors in this folder from PROTOCOL.md.

This is a second, independent encoder of the wire format, written from the
specification with nothing but the Python standard library: the C tests
check that the C codec decodes these bytes to these fields and re-encodes
the fields to the same bytes, and the browser codec runs the same files.

Run from anywhere:  python3 protocol/vectors/gen_vectors.py
It rewrites every *.json file here; commit the result.
"""

import json
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

# ---- Constants from PROTOCOL.md ---------------------------------------------

MAGIC = b"BCST"
VERSION = 1
TYPES = {
    "HELLO": 1, "WELCOME": 2, "ERROR": 3, "PING": 4, "PONG": 5, "OK": 6,
    "SESSION_CREATE": 7, "SESSION_JOIN": 8, "SESSION_LEAVE": 9,
    "SESSION_INFO": 10, "SCENE_LOAD": 11, "SCENE_STATE": 12, "EDIT": 13,
    "EDIT_APPLIED": 14, "CAMERA": 15, "VIEW": 16, "FRAME": 17, "PICK": 18,
    "PICK_RESULT": 19, "SNAPSHOT": 20, "GET_STATS": 21, "STATS": 22,
    "SESSION_DELETE": 23, "UNDO": 24, "REDO": 25, "SESSION_LIST": 26,
    "SESSIONS": 27, "PRESENT": 28, "FOLLOW": 29, "PRESENTER": 30,
    "FOLLOW_CAMERA": 31, "SESSION_CAMERA": 32, "SESSION_CAMERA_SET": 33,
    "HISTORY_GET": 34, "HISTORY": 35, "FRAME_ACK": 36, "MESH": 37,
    "MESH_DATA": 38,
}
MAX_PAYLOAD = 64 * 1024 * 1024
HELLO_MAX_PAYLOAD = 4096
MAX_NAME, MAX_TOKEN, MAX_ERROR_TEXT = 64, 1024, 1024
MAX_MEMBERS, MAX_DIM, MAX_RECTS = 64, 8192, 4096
MAX_SESSIONS_LISTED = 1024
# HISTORY (section 7.26): entries listed, description bytes.
MAX_HISTORY, MAX_HISTORY_TEXT = 200, 128
MAX_EDIT_OPS, MAX_SET_FIELDS = 1024, 14
MIN_FRAME_BYTES = 65536
# FRAME header flags (section 2): STILL, SNAPSHOT, INCOMPLETE, the
# refinement level in bits 3..4, and the planes of a snapshot, DEPTH and IDS.
STILL, SNAPSHOT, INCOMPLETE = 1, 2, 4
# EDIT_APPLIED: UNDO and REDO (the payload ends with the target edit).
UNDO, REDO = 2, 4
DEPTH, IDS = 0x20, 0x40
# FRAME of encoding 4 (H.264): the access unit is an IDR.
KEY = 0x80
# SNAPSHOT's planes byte.
PLANE_DEPTH, PLANE_IDS = 1, 2
LEVEL_SHIFT = 3


def level(n):
    """The FRAME flags bits of refinement level n."""
    return n << LEVEL_SHIFT


def level_dim(dim, n):
    """ceil(dim / 2^n): the image size of a level-n frame."""
    return -(-dim // (1 << n))
MAX_ABS = 1.0e6
SCENE_MAX_DEPTH = 1 << 20  # nodes on a path from the root, the root counting 1


def strmax(n):
    return 2 + n


TYPE_MAX = {
    "HELLO": 2 + 2 + 1 + 4 + strmax(MAX_NAME) + strmax(MAX_TOKEN) + 4,
    "WELCOME": 2 + 4 * 4 + 2 * 3 + strmax(MAX_NAME) + 4,
    "ERROR": 2 + strmax(MAX_ERROR_TEXT),
    "PING": 8, "PONG": 8, "OK": 0,
    "SESSION_CREATE": 1 + strmax(MAX_NAME),
    "SESSION_JOIN": 1 + strmax(MAX_NAME),
    "SESSION_LEAVE": 0,
    "SESSION_INFO": 4 + 4 + 1 + strmax(MAX_NAME) + 2
    + MAX_MEMBERS * (4 + 1 + strmax(MAX_NAME)),
    "SCENE_LOAD": MAX_PAYLOAD, "SCENE_STATE": MAX_PAYLOAD,
    "EDIT": MAX_PAYLOAD, "EDIT_APPLIED": MAX_PAYLOAD,
    "CAMERA": 40, "VIEW": 9, "FRAME": MAX_PAYLOAD, "PICK": 4,
    "PICK_RESULT": 24, "SNAPSHOT": 14, "GET_STATS": 1,
    "STATS": 64 + 44 + 9 + 32 + 28,
    "SESSION_DELETE": strmax(MAX_NAME), "UNDO": 1, "REDO": 1,
    "SESSION_LIST": 0,
    "SESSIONS": 2 + MAX_SESSIONS_LISTED * (strmax(MAX_NAME) + 2 + 4 + 8 + 8 + 1),
    "PRESENT": 1, "FOLLOW": 1, "PRESENTER": 5, "FOLLOW_CAMERA": 44,
    "SESSION_CAMERA": 40, "SESSION_CAMERA_SET": 56,
    "HISTORY_GET": 0, "FRAME_ACK": 4, "MESH": 4, "MESH_DATA": MAX_PAYLOAD,
    "HISTORY": 8 + 2 + MAX_HISTORY * (8 + 8 + 8 + 1 + 1 + strmax(MAX_NAME)
                                      + strmax(MAX_HISTORY_TEXT)),
}

# ---- Byte helpers --------------------------------------------------------------


def u8(v):
    return struct.pack("<B", v)


def u16(v):
    return struct.pack("<H", v)


def u32(v):
    return struct.pack("<I", v)


def u64(v):
    return struct.pack("<Q", v)


def f32(v):
    return struct.pack("<f", v)


def f32bits(bits):
    return struct.pack("<I", bits)


def fl(v):
    """The float32 nearest to v, as a Python float (exact in JSON)."""
    return struct.unpack("<f", struct.pack("<f", v))[0]


def sstr(s):
    b = s.encode("utf-8") if isinstance(s, str) else s
    return u16(len(b)) + b


def blob(b):
    return u32(len(b)) + b


def header(mtype, length, flags=0, seq=1, version=VERSION, magic=MAGIC):
    t = TYPES[mtype] if isinstance(mtype, str) else mtype
    return magic + u8(version) + u8(t) + u16(flags) + u32(length) + u32(seq)


def frame(mtype, payload, flags=0, seq=1, **kw):
    return header(mtype, len(payload), flags, seq, **kw) + payload


# ---- Scene encoding ------------------------------------------------------------

IDENT = [0.0, 0.0, 0.0, 1.0]


def scene_prim(kind, nid, params, translate=(0, 0, 0), rotate=IDENT,
               color=None):
    b = u8(kind) + u32(nid)
    b += b"".join(f32(v) for v in translate)
    b += b"".join(f32(v) for v in rotate)
    if color is None:
        b += u8(0)
    else:
        b += u8(1) + b"".join(f32(v) for v in color)
    b += u8(len(params)) + b"".join(f32(v) for v in params)
    return b


def scene_op(kind, nid, blend, rng, children):
    return u8(0x80 | kind) + u32(nid) + f32(blend) + f32(rng) + u32(children)


def scene_unary(kind, nid, params):
    """A unary or domain node (kinds 7..14): its one child follows."""
    return u8(0x80 | kind) + u32(nid) + u8(len(params)) + b"".join(
        f32(v) for v in params)


def names_table(names):
    """The names table (section 8): (id, name) pairs, ids increasing."""
    return u32(len(names)) + b"".join(u32(i) + sstr(s) for i, s in names)


def scene(nodes, camera=None, names=None):
    b = u8((1 if camera else 0) | (2 if names else 0))
    if camera:
        b += b"".join(f32(v) for v in camera)
    b += u32(len(nodes)) + b"".join(nodes)
    return b + (names_table(names) if names else b"")


CAM = [0.0, 1.0, 6.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 45.0]
SPHERE = scene_prim(1, 0, [1.0])
SCENE_SMALL = scene([
    scene_op(4, 1, 0.5, 0.5, 2),
    scene_prim(1, 2, [1.0], translate=(-0.6, 0, 0), color=(1.0, 0.5, 0.25)),
    scene_prim(2, 3, [0.5, 0.5, 0.5, 0.1], translate=(0.6, 0, 0)),
], camera=CAM)
SUBTREE = scene([scene_prim(3, 0, [0, 0, 0, 0, 1, 0, 0.25])])
# A named subtree (section 8: a subtree brings its nodes' names).
SUBTREE_NAMED = scene([scene_op(1, 40, 0, 0, 2),
                       scene_prim(1, 41, [0.5]),
                       scene_prim(1, 42, [0.5], translate=(1, 0, 0))],
                      names=[(40, "pair"), (42, "right \u00e9")])


def deep_scene(depth):
    """A left comb of `depth` nested unions, each with a sphere sibling:
    its deepest path has depth + 1 nodes."""
    nodes = []
    for i in range(depth):
        nodes.append(scene_op(1, 0, 0.0, 0.0, 2))
    for i in range(depth + 1):
        nodes.append(SPHERE)
    # Pre-order: op1, op2, ..., op_depth, s, s, then one sphere closing
    # every enclosing operator in turn.
    order = nodes[:depth] + [SPHERE, SPHERE] + [SPHERE] * (depth - 1)
    return scene(order)


# ---- Payload writers (fields -> bytes) -------------------------------------------


def w_hello(f):
    return (u16(f["version_min"]) + u16(f["version_max"]) + u8(f["encodings"])
            + u32(f["max_frame_bytes"]) + sstr(f["client_name"])
            + sstr(f["token"])
            # features: absent in an earlier client's HELLO (section 4).
            + (u32(f["features"]) if "features" in f else b""))


def w_welcome(f):
    return (u16(f["version"]) + u32(f["connection_id"]) + u32(f["max_payload"])
            + u32(f["max_frame_bytes"]) + u32(f["max_nodes"])
            + u16(f["max_dim"]) + u16(f["max_members"])
            + u16(f["max_edit_ops"]) + sstr(f["server_id"])
            # Granted features: only when the HELLO announced some.
            + (u32(f["features"]) if "features" in f else b""))


def w_error(f):
    return u16(f["code"]) + sstr(f["text"])


def w_ping(f):
    return u64(int(f["stamp"]))


def w_empty(f):
    return b""


def w_session(f):
    return u8(f["role"]) + sstr(f["name"])


def w_session_delete(f):
    return sstr(f["name"])


def w_session_entry(e):
    return (sstr(e["name"]) + u16(e["members"]) + u32(e["prims"])
            + u64(int(e["order"])) + u64(int(e["last_edit_ms"]))
            + u8(e["flags"]))


def w_sessions(f):
    return u16(len(f["sessions"])) + b"".join(
        w_session_entry(e) for e in f["sessions"])


def w_undo(f):
    # The scope byte is optional (section 7.20): absent, the first text's
    # empty UNDO and REDO.
    return u8(f["scope"]) if "scope" in f else b""


def w_history_entry(e):
    return (u64(int(e["order"])) + u64(int(e["time_ms"]))
            + u64(int(e["built_on"])) + u8(e["state"]) + u8(e["flags"])
            + sstr(e["author"]) + sstr(e["what"]))


def w_history(f):
    return u64(int(f["order"])) + u16(len(f["entries"])) + b"".join(
        w_history_entry(e) for e in f["entries"])


def w_session_info(f):
    b = (u32(f["session_id"]) + u32(f["member_id"]) + u8(f["role"])
         + sstr(f["name"]) + u16(len(f["members"])))
    for m in f["members"]:
        b += u32(m["id"]) + u8(m["role"]) + sstr(m["name"])
    return b


def w_scene_load(f):
    return blob(bytes.fromhex(f["scene"]))


def w_scene_state(f):
    return (u64(int(f["order"])) + u32(f["author"]) + u32(f["author_seq"])
            + blob(bytes.fromhex(f["scene"])))


def w_ops(ops):
    b = u16(len(ops))
    for op in ops:
        k = op["kind"]
        b += u8(k)
        if k == 1:
            b += u32(op["node"]) + u8(len(op["fields"]))
            for fd in op["fields"]:
                b += u8(fd["field"]) + u8(len(fd["values"]))
                b += b"".join(f32(v) for v in fd["values"])
        elif k == 2:
            b += (u32(op["parent"]) + u32(op["position"])
                  + blob(bytes.fromhex(op["subtree"])))
        elif k == 3:
            b += u32(op["node"])
        elif k == 4:
            b += u32(op["node"]) + blob(bytes.fromhex(op["subtree"]))
        elif k == 5:
            b += u32(op["node"]) + sstr(op["name"])
    return b


def w_edit(f):
    return w_ops(f["ops"])


def w_edit_applied(f):
    b = (u64(int(f["order"])) + u32(f["author"]) + u32(f["author_seq"])
         + w_ops(f["ops"]))
    if "target_order" in f:  # with the UNDO or REDO flag only
        b += u64(int(f["target_order"])) + sstr(f["target_author"])
    return b


def w_camera(f):
    return b"".join(f32(v) for v in f["eye"] + f["target"] + f["up"]
                    + [f["fov_y_deg"]])


def w_toggle(f):
    return u8(f["on"])


def w_presenter(f):
    return u32(f["presenter"]) + u8(f["following"])


def w_follow_camera(f):
    return u32(f["presenter"]) + w_camera(f)


def w_session_camera_set(f):
    return (u64(int(f["order"])) + u32(f["author"]) + u32(f["author_seq"])
            + w_camera(f))


def w_view(f):
    return (u16(f["width"]) + u16(f["height"]) + u8(f["encoding"])
            + u8(f["quality_interactive"]) + u8(f["quality_still"])
            + u8(f["downscale"])
            + (u8(f["still_encoding"]) if "still_encoding" in f else b""))


def w_frame_ack(f):
    return u32(f["frame_no"])


def w_rects(rects):
    b = u16(len(rects))
    for r in rects:
        b += (u16(r["x"]) + u16(r["y"]) + u16(r["w"]) + u16(r["h"])
              + blob(bytes.fromhex(r["data"])))
    return b


def w_frame(f):
    return (u32(f["frame_no"]) + u64(int(f["order"])) + u32(f["camera_seq"])
            + u8(f["encoding"]) + u16(f["width"]) + u16(f["height"])
            + u16(f["image_width"]) + u16(f["image_height"])
            + w_rects(f["rects"]))


def w_pick(f):
    return u16(f["x"]) + u16(f["y"])


def w_pick_result(f):
    return (u16(f["x"]) + u16(f["y"]) + u32(f["node"])
            + b"".join(f32(v) for v in f["position"]) + f32(f["depth"]))


TILE_F = ["full_width", "full_height", "tile_x", "tile_y", "tile_width",
          "tile_height"]


def w_snapshot(f):
    # planes is optional and left out when 0 (colour only), except in the
    # tile form, which always has it (section 7.17).
    if "full_width" in f:
        return (u8(f["encoding"]) + u8(f["planes"])
                + b"".join(u16(f[k]) for k in TILE_F))
    return u8(f["encoding"]) + (u8(f["planes"]) if f["planes"] else b"")


STATS_F = ["render_ms_last", "render_ms_avg", "encode_ms_last",
           "encode_ms_avg", "edit_ms_avg", "fps"]


LOAD_F32 = ["loop_turn_max_ms", "loop_request_max_ms"]
LOAD_U32 = ["render_workers", "jobs_queued", "jobs_running"]
LOAD_U64 = ["view_bytes", "view_cap", "session_render_us"]


def w_stats(f):
    b = b"".join(u64(int(f[k])) for k in ("uptime_ms", "frames", "bytes",
                                            "order"))
    b += u32(f["sessions"]) + u32(f["clients"])
    b += b"".join(f32(f[k]) for k in STATS_F)
    # The load section only answers a GET_STATS that asked for it.
    if f.get("has_load"):
        b += b"".join(f32(f[k]) for k in LOAD_F32)
        b += b"".join(u32(f[k]) for k in LOAD_U32)
        b += b"".join(u64(int(f[k])) for k in LOAD_U64)
    # The TLS section likewise, after the load section when both.
    if f.get("has_tls"):
        b += u64(int(f["tls_not_after_ms"])) + u8(f["tls_expiring"])
    # The link section after those.
    if f.get("has_link"):
        b += (u32(f["rtt_us"]) + u32(f["min_rtt_us"])
              + u64(int(f["delivery_bps"])) + u32(f["unacked_bytes"])
              + u32(f["frames_paced"]) + u64(int(f["frames_spoiled"])))
    # The memory section last.
    if f.get("has_memory"):
        b += (u64(int(f["scene_nodes"])) + u64(int(f["scene_nodes_cap"]))
              + u64(int(f["session_nodes"])) + u32(f["sessions_loaded"]))
    return b


def w_mesh(f):
    return u8(f["format"]) + u8(f["options"]) + u16(f["resolution"])


def w_mesh_data(f):
    return (w_mesh(f) + u64(int(f["order"])) + u32(f["vertices"])
            + u32(f["triangles"]) + blob(bytes.fromhex(f["file"])))


def w_get_stats(f):
    # parts is optional and left out when 0 (the client's figures only).
    return u8(f["parts"]) if f["parts"] else b""


WRITERS = {
    "HELLO": w_hello, "WELCOME": w_welcome, "ERROR": w_error,
    "PING": w_ping, "PONG": w_ping, "OK": w_empty,
    "SESSION_CREATE": w_session, "SESSION_JOIN": w_session,
    "SESSION_LEAVE": w_empty, "SESSION_INFO": w_session_info,
    "SCENE_LOAD": w_scene_load, "SCENE_STATE": w_scene_state,
    "EDIT": w_edit, "EDIT_APPLIED": w_edit_applied, "CAMERA": w_camera,
    "VIEW": w_view, "FRAME": w_frame, "FRAME_ACK": w_frame_ack, "PICK": w_pick,
    "PICK_RESULT": w_pick_result, "SNAPSHOT": w_snapshot,
    "GET_STATS": w_get_stats, "STATS": w_stats,
    "SESSION_DELETE": w_session_delete, "UNDO": w_undo, "REDO": w_undo,
    "SESSION_LIST": w_empty, "SESSIONS": w_sessions,
    "PRESENT": w_toggle, "FOLLOW": w_toggle, "PRESENTER": w_presenter,
    "FOLLOW_CAMERA": w_follow_camera, "SESSION_CAMERA": w_camera,
    "SESSION_CAMERA_SET": w_session_camera_set,
    "HISTORY_GET": w_empty, "HISTORY": w_history,
    "MESH": w_mesh, "MESH_DATA": w_mesh_data,
}

# ---- Vector tables -----------------------------------------------------------


class Table:
    def __init__(self, mtype):
        self.mtype = mtype
        self.valid = []
        self.invalid = []

    def ok(self, name, fields, flags=0, seq=1):
        payload = WRITERS[self.mtype](fields)
        assert len(payload) <= TYPE_MAX[self.mtype], name
        full = dict(seq=seq, flags=flags)
        full.update(fields)
        self.valid.append({"name": name,
                           "hex": frame(self.mtype, payload, flags,
                                        seq).hex(),
                           "fields": full})
        return payload

    def bad(self, name, raw, error, reader=None, messages=0):
        e = {"name": name, "hex": raw.hex(), "error": error}
        if reader:
            e["reader"] = reader
        if messages:
            e["messages"] = messages
        self.invalid.append(e)

    def badp(self, name, payload, error, flags=0, **kw):
        """An invalid payload under a correct header."""
        self.bad(name, frame(self.mtype, payload, flags), error, **kw)

    def common(self, payload):
        """Cases every type gets: truncations, trailing byte, length over
        the type's maximum, 2^31 and 2^32-1."""
        t = self.mtype
        if payload:
            self.badp("payload one byte short", payload[:-1],
                      "EPROTO_TRUNCATED")
            self.badp("empty payload", b"", "EPROTO_TRUNCATED")
        self.badp("one trailing byte", payload + b"\x00", "EPROTO_TRAILING"
                  if len(payload) + 1 <= TYPE_MAX[t] else "EPROTO_LENGTH")
        self.bad("length = type maximum + 1",
                 header(t, TYPE_MAX[t] + 1), "EPROTO_LENGTH")
        self.bad("length 2^31", header(t, 2 ** 31), "EPROTO_LENGTH")
        self.bad("length 2^32-1", header(t, 2 ** 32 - 1), "EPROTO_LENGTH")
        full = frame(t, payload)
        self.bad("stream ends inside the header", full[:9],
                 "EPROTO_TRUNCATED")
        if payload:
            self.bad("stream ends inside the payload", full[:-1],
                     "EPROTO_TRUNCATED")

    def dump(self, fname):
        doc = {"type": self.mtype, "type_id": TYPES[self.mtype],
               "valid": self.valid, "invalid": self.invalid}
        write_json(fname, doc)


def write_json(fname, doc):
    with open(os.path.join(HERE, fname), "w", encoding="utf-8") as fp:
        json.dump(doc, fp, indent=1, ensure_ascii=False)
        fp.write("\n")


SERVER = {"side": "server"}
CLIENT = {"side": "client"}
PRE_HELLO = {"side": "server", "await_hello": True}

# ---- Per type ------------------------------------------------------------------


def pad64(s):
    """s padded with 'x' to exactly 64 UTF-8 bytes."""
    return s + "x" * (64 - len(s.encode("utf-8")))


def gen_hello():
    t = Table("HELLO")
    base = dict(version_min=1, version_max=1, encodings=15,
                max_frame_bytes=8 * 1024 * 1024, client_name="viewer",
                token="s3cret", features=0xff)
    p = t.ok("viewer, all encodings, every feature of this text", base,
             seq=1)
    old = dict(base)
    del old["features"]
    t.ok("an earlier client's HELLO: no features field", old, seq=1)
    t.ok("features a later text adds (unknown bits are no error)",
         dict(base, features=0xffffffff), seq=2)
    t.ok("features 0: announced, none of them", dict(base, features=0),
         seq=3)
    t.ok("H.264 and JPEG, acknowledging frames",
         dict(base, encodings=0x09, features=0x80), seq=4)
    t.ok("no encodings, no name, no token, server's frame limit",
         dict(base, encodings=0, max_frame_bytes=0, client_name="",
              token=""), seq=1)
    t.ok("non-ASCII name at 64 bytes, token at 1024 bytes",
         dict(base, version_max=3, encodings=1,
              max_frame_bytes=MIN_FRAME_BYTES,
              client_name=pad64("Zoë's 🌐 viewer "),
              token="t" * MAX_TOKEN), seq=7)
    t.common(p)
    t.badp("features cut short (3 bytes)", w_hello(old) + b"\x0f\x00\x00",
           "EPROTO_TRUNCATED")
    hdr = u16(1) + u16(1) + u8(7) + u32(0)
    t.badp("version_min 0", u16(0) + u16(1) + u8(7) + u32(0) + sstr("")
           + sstr(""), "ERANGE")
    t.badp("version_max below version_min", u16(2) + u16(1) + u8(7)
           + u32(0) + sstr("") + sstr(""), "ERANGE")
    t.badp("reserved encoding bit 4", u16(1) + u16(1) + u8(16) + u32(0)
           + sstr("") + sstr(""), "EPROTO_FLAGS")
    t.badp("reserved encoding bit 7", u16(1) + u16(1) + u8(0x8f) + u32(0)
           + sstr("") + sstr(""), "EPROTO_FLAGS")
    t.badp("max_frame_bytes under 64 KiB", u16(1) + u16(1) + u8(7)
           + u32(65535) + sstr("") + sstr(""), "ERANGE")
    t.badp("client_name of 65 bytes", hdr + sstr("n" * 65) + sstr(""),
           "EPROTO_LENGTH")
    t.badp("token of 1025 bytes", hdr + sstr("") + sstr("t" * 1025),
           "EPROTO_LENGTH")
    t.badp("name length larger than the bytes left", hdr + u16(40) + b"ab",
           "EPROTO_TRUNCATED")
    for why, raw in [("NUL", b"a\x00b"), ("overlong '/'", b"\xc0\xaf"),
                     ("UTF-16 surrogate", b"\xed\xa0\x80"),
                     ("stray continuation byte", b"\x80"),
                     ("code point over U+10FFFF", b"\xf4\x90\x80\x80"),
                     ("sequence cut short", b"ab\xe2\x82")]:
        t.badp("client_name with " + why, hdr + sstr(raw) + sstr(""),
               "ESTRING")
    # Stream rules that HELLO exercises.
    t.bad("accepted by a server before HELLO", frame("HELLO", p),
          None, reader=PRE_HELLO, messages=1)
    t.bad("refused by a client reader", frame("HELLO", p), "EPROTO_TYPE",
          reader=CLIENT)
    t.bad("header flags set", frame("HELLO", p, flags=1), "EPROTO_FLAGS")
    t.dump("hello.json")


def gen_welcome():
    t = Table("WELCOME")
    base = dict(version=1, connection_id=17, max_payload=MAX_PAYLOAD,
                max_frame_bytes=8 * 1024 * 1024, max_nodes=4194303,
                max_dim=8192, max_members=64, max_edit_ops=1024,
                server_id="blobcastd@render-01", features=0x0f)
    p = t.ok("default limits, every feature granted", base)
    old = dict(base)
    del old["features"]
    t.ok("answer to an earlier client's HELLO: no features field", old)
    t.ok("answer to a HELLO that announced none", dict(base, features=0))
    t.ok("smallest limits", dict(base, max_payload=HELLO_MAX_PAYLOAD,
                                 max_frame_bytes=MIN_FRAME_BYTES,
                                 max_nodes=1, max_dim=1, max_members=1,
                                 max_edit_ops=1, server_id=""), seq=3)
    t.common(p)

    def wl(**kw):
        return w_welcome(dict(base, **kw))
    t.badp("version 0", wl(version=0), "ERANGE")
    t.badp("connection_id 0", wl(connection_id=0), "ERANGE")
    t.badp("max_payload over 64 MiB", wl(max_payload=MAX_PAYLOAD + 1),
           "ERANGE")
    t.badp("max_payload under 4 KiB", wl(max_payload=4095), "ERANGE")
    t.badp("max_frame_bytes under 64 KiB", wl(max_frame_bytes=65535),
           "ERANGE")
    t.badp("max_nodes 2^22", wl(max_nodes=1 << 22), "ERANGE")
    t.badp("max_dim 8193", wl(max_dim=8193), "ERANGE")
    t.badp("max_members 65", wl(max_members=65), "ERANGE")
    t.badp("max_edit_ops 0", wl(max_edit_ops=0), "ERANGE")
    t.ok("every feature of this text granted", dict(base, features=0x7ff))
    t.ok("PARTS granted (bit 8)", dict(base, features=0x100))
    t.ok("MEMORY granted (bit 9)", dict(base, features=0x200))
    t.ok("MESH granted (bit 10)", dict(base, features=0x400))
    t.badp("a feature this text does not define", wl(features=0x800),
           "EPROTO_FLAGS")
    t.badp("features cut short (2 bytes)", w_welcome(old) + b"\x0f\x00",
           "EPROTO_TRUNCATED")
    t.bad("refused by a server reader", frame("WELCOME", p),
          "EPROTO_TYPE", reader=SERVER)
    t.dump("welcome.json")


def gen_error():
    t = Table("ERROR")
    p = t.ok("fatal authentication failure",
             dict(code=22, text="authentication failed: unknown token"),
             flags=1, seq=1)
    t.ok("not tied to a request", dict(code=14, text=""), seq=0)
    t.ok("code from a newer server, longest text",
         dict(code=65535, text="é" * 512), seq=9)
    t.common(p)
    t.badp("code 0", u16(0) + sstr("x"), "ERANGE")
    t.badp("text of 1025 bytes", u16(1) + sstr("e" * 1025), "EPROTO_LENGTH")
    t.badp("undefined flag bit 1", p, "EPROTO_FLAGS", flags=2)
    t.badp("FRAME's level bits (level 2)", p, "EPROTO_FLAGS",
           flags=level(2))
    t.dump("error.json")


def gen_ping(name):
    t = Table(name)
    p = t.ok("stamp", dict(stamp=str(1234567890123)), seq=5)
    t.ok("largest stamp", dict(stamp=str(2 ** 64 - 1)))
    t.common(p)
    if name == "PING":
        t.bad("accepted by a server before HELLO", frame("PING", p), None,
              reader=PRE_HELLO, messages=1)
    else:
        t.bad("refused by a server before HELLO", frame("PONG", p),
              "ESTATE", reader=PRE_HELLO)
    t.dump(name.lower() + ".json")


def gen_empty(name, side):
    t = Table(name)
    t.ok("empty", {}, seq=12)
    t.common(b"")
    # A reader on the sending side never accepts the type.
    wrong = SERVER if side == "server" else CLIENT
    t.bad("sent by the wrong side", frame(name, b""), "EPROTO_TYPE",
          reader=wrong)
    if side == "client":
        t.bad("refused by a server before HELLO", frame(name, b""),
              "ESTATE", reader=PRE_HELLO)
    t.dump(name.lower() + ".json")


def gen_undo(name):
    t = Table(name)
    t.ok("empty: the first text's form", {}, seq=12)
    t.ok("scope MINE", dict(scope=1), seq=13)
    t.ok("scope SESSION", dict(scope=2), seq=14)
    t.badp("scope 0", u8(0), "EENUM")
    t.badp("scope 3", u8(3), "EENUM")
    t.badp("scope 255", u8(255), "EENUM")
    t.bad("two bytes: over the type's maximum", frame(name, u8(1) + u8(1)),
          "EPROTO_LENGTH")
    t.bad("length = type maximum + 1", header(name, 2), "EPROTO_LENGTH")
    t.bad("length 2^32-1", header(name, 2 ** 32 - 1), "EPROTO_LENGTH")
    t.bad("stream ends inside the payload", frame(name, u8(1))[:-1],
          "EPROTO_TRUNCATED")
    t.bad("sent by the wrong side", frame(name, u8(1)), "EPROTO_TYPE",
          reader=CLIENT)
    t.bad("refused by a server before HELLO", frame(name, b""), "ESTATE",
          reader=PRE_HELLO)
    t.dump(name.lower() + ".json")


def gen_history():
    t = Table("HISTORY")
    mine = dict(order="41", time_ms="1764547200000", built_on="0", state=1,
                flags=3, author="alice", what="SET node 12 translate")
    built = dict(order="40", time_ms="1764547100000", built_on="42",
                 state=1, flags=1, author="alice", what="REMOVE node 7")
    undone = dict(order="39", time_ms="0", built_on="0", state=2, flags=0,
                  author="", what="INSERT under node 3")
    p = t.ok("three changes, newest first",
             dict(order="44", entries=[mine, built, undone]), seq=21)
    t.ok("no history", dict(order="0", entries=[]), seq=22)
    t.ok("largest: 200 entries with the longest strings",
         dict(order=str(2 ** 64 - 1),
              entries=[dict(mine, order=str(i + 1), author="a" * 64,
                            what="w" * MAX_HISTORY_TEXT)
                       for i in range(MAX_HISTORY)]), seq=23)
    t.common(p)
    t.badp("entry_count 201", u64(1) + u16(201), "EPROTO_COUNT")
    t.badp("entry_count larger than the bytes left",
           u64(1) + u16(2) + w_history_entry(mine), "EPROTO_COUNT")
    t.badp("entry order 0",
           u64(1) + u16(1) + w_history_entry(dict(mine, order="0")),
           "ERANGE")
    t.badp("state 0", u64(1) + u16(1) + w_history_entry(dict(mine, state=0)),
           "EENUM")
    t.badp("state 3", u64(1) + u16(1) + w_history_entry(dict(mine, state=3)),
           "EENUM")
    t.badp("flags with bit 2",
           u64(1) + u16(1) + w_history_entry(dict(mine, flags=4)),
           "EPROTO_FLAGS")
    t.badp("author of 65 bytes",
           u64(1) + u16(1) + w_history_entry(dict(mine, author="a" * 65)),
           "EPROTO_LENGTH")
    t.badp("description of 129 bytes",
           u64(1) + u16(1) + w_history_entry(dict(mine, what="w" * 129))
           , "EPROTO_LENGTH")
    t.bad("refused by a server reader", frame("HISTORY", p), "EPROTO_TYPE",
          reader=SERVER)
    t.dump("history.json")


def gen_session(name):
    t = Table(name)
    p = t.ok("editor", dict(role=1, name="design-review"), seq=2)
    t.ok("viewer, 64-byte name", dict(role=2, name="ü" * 32), seq=3)
    t.common(p)
    t.badp("role 0", u8(0) + sstr("x"), "EENUM")
    t.badp("role 3", u8(3) + sstr("x"), "EENUM")
    t.badp("empty name", u8(1) + sstr(""), "EPROTO_LENGTH")
    t.badp("name of 65 bytes", u8(1) + sstr("s" * 65), "EPROTO_LENGTH")
    t.badp("name with NUL", u8(1) + sstr(b"a\x00"), "ESTRING")
    t.bad("refused by a server before HELLO", frame(name, p), "ESTATE",
          reader=PRE_HELLO)
    t.dump(name.lower() + ".json")


def gen_session_delete():
    t = Table("SESSION_DELETE")
    p = t.ok("a name", dict(name="design-review"), seq=9)
    t.ok("64-byte name", dict(name="d" * 64), seq=10)
    t.common(p)
    t.badp("empty name", sstr(""), "EPROTO_LENGTH")
    t.badp("name of 65 bytes", sstr("s" * 65), "EPROTO_LENGTH")
    t.badp("name with NUL", sstr(b"a\x00"), "ESTRING")
    t.bad("refused by a server before HELLO", frame("SESSION_DELETE", p),
          "ESTATE", reader=PRE_HELLO)
    t.dump("session_delete.json")


def gen_sessions():
    t = Table("SESSIONS")
    review = dict(name="review", members=3, prims=1024, order="77",
                  last_edit_ms="1764547200000", flags=3)
    stored = dict(name="old", members=0, prims=0, order="0",
                  last_edit_ms="0", flags=0)
    p = t.ok("a loaded and a stored session", dict(sessions=[review, stored]),
             seq=14)
    t.ok("no sessions", dict(sessions=[]), seq=15)
    t.ok("largest: 1024 sessions with 64-byte names",
         dict(sessions=[dict(review, name="%064d" % i)
                        for i in range(MAX_SESSIONS_LISTED)]), seq=16)
    t.common(p)
    t.badp("session_count 1025", u16(1025), "EPROTO_COUNT")
    t.badp("session_count larger than the bytes left",
           u16(2) + w_session_entry(review), "EPROTO_COUNT")
    t.badp("empty name", u16(1) + w_session_entry(dict(review, name=""))
           + b"\x00", "EPROTO_LENGTH")
    t.badp("flags with bit 2", u16(1) + w_session_entry(dict(review, flags=4)),
           "EPROTO_FLAGS")
    t.dump("sessions.json")


def gen_session_info():
    t = Table("SESSION_INFO")
    base = dict(session_id=3, member_id=8, role=2, name="design-review",
                members=[dict(id=5, role=1, name="alice's editor"),
                         dict(id=8, role=2, name="viewer")])
    p = t.ok("two members", base, seq=2)
    t.ok("largest: 64 members with 64-byte names",
         dict(base, name="n" * 64,
              members=[dict(id=i + 1, role=1 + i % 2, name="%064d" % i)
                       for i in range(MAX_MEMBERS)]), seq=0)
    t.common(p)
    head = u32(3) + u32(8) + u8(2) + sstr("s")
    t.badp("session_id 0", u32(0) + u32(8) + u8(2) + sstr("s") + u16(1)
           + u32(1) + u8(1) + sstr(""), "ERANGE")
    t.badp("member_count 0", head + u16(0), "EPROTO_COUNT")
    t.badp("member_count 65", head + u16(65), "EPROTO_COUNT")
    t.badp("member_count larger than the bytes left",
           head + u16(3) + (u32(1) + u8(1) + sstr("")) * 2, "EPROTO_COUNT")
    t.badp("member id 0", head + u16(1) + u32(0) + u8(1) + sstr(""),
           "ERANGE")
    t.badp("member role 9", head + u16(1) + u32(1) + u8(9) + sstr(""),
           "EENUM")
    t.dump("session_info.json")


def gen_scene_load():
    t = Table("SCENE_LOAD")
    p = t.ok("three nodes with camera", dict(scene=SCENE_SMALL.hex()),
             seq=4)
    t.ok("one sphere", dict(scene=scene([SPHERE]).hex()), seq=5)
    t.ok("opaque bytes are not parsed here", dict(scene="ff"), seq=6)
    t.common(p)
    t.badp("scene length 0", u32(0), "EPROTO_LENGTH")
    t.badp("scene length larger than the bytes left", u32(100) + b"\x00" * 10,
           "EPROTO_TRUNCATED")
    t.bad("refused by a server before HELLO", frame("SCENE_LOAD", p),
          "ESTATE", reader=PRE_HELLO)
    t.bad("over a reader limit of 64 bytes", frame("SCENE_LOAD", p),
          "EPROTO_LENGTH", reader={"max_payload": 64})
    # Scenes in parts (section 7.10.1): each part is a SCENE_LOAD of the
    # usual layout; a piece may end anywhere in the encoding.
    half = len(SCENE_SMALL) // 2
    t.ok("first part of a scene in parts (MORE)",
         dict(scene=SCENE_SMALL[:half].hex()), flags=0x0001, seq=7)
    t.ok("middle part (MORE and CONT)", dict(scene="00"), flags=0x0003,
         seq=8)
    t.ok("last part (CONT)", dict(scene=SCENE_SMALL[half:].hex()),
         flags=0x0002, seq=9)
    t.badp("flag bit 2 is not defined for it", p, "EPROTO_FLAGS",
           flags=0x0004)
    t.badp("a part's piece of length 0", u32(0), "EPROTO_LENGTH",
           flags=0x0002)
    t.dump("scene_load.json")


def gen_scene_state():
    t = Table("SCENE_STATE")
    p = t.ok("after a load", dict(order="42", author=5, author_seq=4,
                                  scene=SCENE_SMALL.hex()), seq=0)
    t.ok("sent to a joiner", dict(order="0", author=0, author_seq=0,
                                  scene=scene([SPHERE]).hex()), seq=0)
    t.common(p)
    t.badp("scene length 0", u64(1) + u32(0) + u32(0) + u32(0),
           "EPROTO_LENGTH")
    # Parts (section 7.10.1): the same fields in every part, the pieces
    # concatenated make the scene.
    half = len(SCENE_SMALL) // 2
    t.ok("first part of a scene in parts (MORE)",
         dict(order="42", author=5, author_seq=9,
              scene=SCENE_SMALL[:half].hex()), flags=0x0001, seq=0)
    t.ok("last part (CONT)",
         dict(order="42", author=5, author_seq=9,
              scene=SCENE_SMALL[half:].hex()), flags=0x0002, seq=0)
    t.badp("flag bit 2 is not defined for it", p, "EPROTO_FLAGS",
           flags=0x0004)
    first = frame("SCENE_STATE", u64(42) + u32(5) + u32(9)
                  + blob(SCENE_SMALL[:half]), flags=0x0001, seq=0)
    last = frame("SCENE_STATE", u64(42) + u32(5) + u32(9)
                 + blob(SCENE_SMALL[half:]), flags=0x0002, seq=0)
    t.bad("a scene in two parts, one after the other (a stream)",
          first + last, None, reader=CLIENT, messages=2)
    t.dump("scene_state.json")


OPS = [
    dict(kind=1, node=2, fields=[
        dict(field=1, values=[0.25, -1.5, 3.0]),
        dict(field=16, values=[fl(0.75)]),
        dict(field=3, values=[1.0, 0.0, fl(0.1)]),
    ]),
    dict(kind=1, node=1, fields=[dict(field=32, values=[0.5]),
                                 dict(field=33, values=[0.75]),
                                 dict(field=34, values=[5.0])]),
    dict(kind=2, parent=1, position=2, subtree=SUBTREE.hex()),
    dict(kind=3, node=3),
    dict(kind=4, node=2, subtree=SUBTREE.hex()),
    dict(kind=5, node=2, name="front wheel"),
    dict(kind=5, node=3, name=""),
    dict(kind=2, parent=1, position=0, subtree=SUBTREE_NAMED.hex()),
]


def edit_bad_cases(t, prefix):
    """Invalid operation lists; prefix is the payload before op_count."""
    def one(op):
        return prefix + u16(1) + op

    def setop(fields, node=2):
        return one(u8(1) + u32(node) + u8(len(fields)) + b"".join(fields))

    def fld(num, vals):
        return u8(num) + u8(len(vals)) + b"".join(f32(v) for v in vals)
    t.badp("op_count 0", prefix + u16(0), "EPROTO_COUNT")
    t.badp("op_count 1025", prefix + u16(1025) + (u8(3) + u32(1)) * 1025,
           "EPROTO_COUNT")
    t.badp("op_count larger than the bytes left",
           prefix + u16(4) + (u8(3) + u32(1)) * 3, "EPROTO_COUNT")
    t.badp("op kind 0", one(u8(0) + u32(1)), "EENUM")
    t.badp("op kind 6", one(u8(6) + u32(1)), "EENUM")
    t.badp("name of node 0", one(u8(5) + u32(0) + sstr("a")), "ERANGE")
    t.badp("name of 65 bytes", one(u8(5) + u32(2) + sstr("n" * 65)),
           "EPROTO_LENGTH")
    t.badp("name that is not UTF-8", one(u8(5) + u32(2) + sstr(b"a\xc3(")),
           "ESTRING")
    t.badp("name with a NUL byte", one(u8(5) + u32(2) + sstr(b"a\x00b")),
           "ESTRING")
    t.badp("name longer than the bytes left",
           one(u8(5) + u32(2) + u16(9) + b"abc"), "EPROTO_TRUNCATED")
    t.badp("remove node 0", one(u8(3) + u32(0)), "ERANGE")
    t.badp("set with no fields", one(u8(1) + u32(2) + u8(0)),
           "EPROTO_COUNT")
    t.badp("set with 15 fields", one(u8(1) + u32(2) + u8(15)
                                     + fld(1, [0, 0, 0]) * 15),
           "EPROTO_COUNT")
    t.badp("field count larger than the bytes left",
           one(u8(1) + u32(2) + u8(3) + fld(1, [0, 0, 0])), "EPROTO_COUNT")
    t.badp("unknown field 4", setop([fld(4, [0])]), "EENUM")
    t.badp("unknown field 24", setop([fld(24, [0])]), "EENUM")
    t.badp("field given twice", setop([fld(1, [0, 0, 0]),
                                       fld(1, [1, 1, 1])]), "EPARSE")
    t.badp("translate with 2 values", setop([fld(1, [0, 0])]),
           "EPROTO_COUNT")
    t.badp("parameter with 5 values", setop([fld(17, [1] * 5)]),
           "EPROTO_COUNT")
    t.badp("value count larger than the bytes left",
           one(u8(1) + u32(2) + u8(1) + u8(2) + u8(4) + f32(0) * 2),
           "EPROTO_COUNT")
    t.badp("NaN translate", setop([u8(1) + u8(3) + f32bits(0x7fc00000)
                                   + f32(0) + f32(0)]), "ENONFINITE")
    t.badp("+inf parameter", setop([u8(16) + u8(1) + f32bits(0x7f800000)]),
           "ENONFINITE")
    t.badp("-inf blend", setop([u8(32) + u8(1) + f32bits(0xff800000)],
                               node=1), "ENONFINITE")
    t.badp("translate over 1e6", setop([fld(1, [0, 2.0e6, 0])]), "ERANGE")
    t.badp("insert with empty subtree",
           one(u8(2) + u32(1) + u32(0) + u32(0)), "EPROTO_LENGTH")
    t.badp("replace subtree longer than the bytes left",
           one(u8(4) + u32(1) + u32(50) + b"\x00" * 8), "EPROTO_TRUNCATED")
    t.badp("insert under parent 0",
           one(u8(2) + u32(0) + u32(0) + blob(SUBTREE)), "ERANGE")


def gen_edit():
    t = Table("EDIT")
    p = t.ok("every operation kind", dict(ops=OPS), seq=21)
    t.ok("drag: one translate", dict(ops=[dict(kind=1, node=7, fields=[
        dict(field=1, values=[fl(0.1), 0.0, -0.0])])]), flags=1, seq=22)
    t.ok("every field at once", dict(ops=[dict(kind=1, node=9, fields=[
        dict(field=1, values=[1.0, 2.0, 3.0]),
        dict(field=2, values=[0.0, 0.0, fl(0.7071068), fl(0.7071068)]),
        dict(field=3, values=[0.5, 0.5, 0.5]),
    ] + [dict(field=16 + k, values=[float(k + 1)] * (1 + k % 4))
         for k in range(8)] + [
        dict(field=32, values=[0.25]), dict(field=33, values=[1e6]),
        dict(field=34, values=[1.0])])]), seq=23)
    # An operator kind's value is meaning (PROTOCOL.md 9): it decodes, and
    # the server refuses it with a non-fatal EENUM when it applies the SET.
    t.ok("operator kind 7 decodes", dict(ops=[dict(kind=1, node=1, fields=[
        dict(field=34, values=[7.0])])]), seq=25)
    t.ok("operator kind 4.5 decodes", dict(ops=[dict(kind=1, node=1, fields=[
        dict(field=34, values=[4.5])])]), seq=26)
    t.ok("largest batch: 1024 removes",
         dict(ops=[dict(kind=3, node=i + 1) for i in range(1024)]), seq=24)
    t.common(p)
    edit_bad_cases(t, b"")
    t.badp("undefined flag bit 1", p, "EPROTO_FLAGS", flags=2)
    t.badp("FRAME's level bits (level 3) with INTERACTING", p,
           "EPROTO_FLAGS", flags=level(3) | 1)
    t.bad("refused by a client reader", frame("EDIT", p), "EPROTO_TYPE",
          reader=CLIENT)
    t.dump("edit.json")


def gen_edit_applied():
    t = Table("EDIT_APPLIED")
    p = t.ok("every operation kind", dict(order="1001", author=5,
                                          author_seq=21, ops=OPS), seq=0)
    t.ok("a drag step", dict(order="1002", author=5, author_seq=22, ops=[
        dict(kind=1, node=7, fields=[dict(field=1,
                                          values=[fl(0.1), 0.0, 0.0])])]),
         flags=1, seq=0)
    undo_ops = [dict(kind=1, node=7, fields=[dict(field=1,
                                                  values=[0.0, 0.0, 0.0])])]
    t.ok("an undo of carol's edit 1002",
             dict(order="1003", author=6, author_seq=3, ops=undo_ops,
                  target_order="1002", target_author="carol"),
             flags=UNDO, seq=0)
    t.ok("a redo, author name empty",
         dict(order="1004", author=6, author_seq=4, ops=undo_ops,
              target_order="1002", target_author=""),
         flags=REDO, seq=0)
    t.common(p)
    t.badp("order 0", u64(0) + u32(5) + u32(1) + u16(1) + u8(3) + u32(1),
           "ERANGE")
    body = u64(1003) + u32(6) + u32(3) + w_ops(undo_ops)
    t.badp("UNDO without its target", body, "EPROTO_TRUNCATED", flags=UNDO)
    t.badp("UNDO and REDO", body + u64(1002) + sstr("carol"),
           "EPROTO_FLAGS", flags=UNDO | REDO)
    t.badp("target_order 0", body + u64(0) + sstr("carol"), "ERANGE",
           flags=UNDO)
    t.badp("target after an edit without UNDO", body + u64(1002)
           + sstr("carol"), "EPROTO_TRAILING")
    t.bad("a target_author of 65 bytes", frame("EDIT_APPLIED",
          body + u64(1002) + sstr("c" * 65), flags=UNDO), "EPROTO_LENGTH")
    t.badp("author 0", u64(1) + u32(0) + u32(1) + u16(1) + u8(3) + u32(1),
           "ERANGE")
    edit_bad_cases(t, u64(1) + u32(5) + u32(1))
    t.dump("edit_applied.json")


def gen_camera():
    t = Table("CAMERA")
    base = dict(eye=[0.0, 1.0, 6.0], target=[0.0, 0.0, 0.0],
                up=[0.0, 1.0, 0.0], fov_y_deg=45.0)
    p = t.ok("default view", base, seq=30)
    t.ok("dragging, extreme but valid values",
         dict(eye=[1e6, -1e6, fl(0.1)], target=[-0.0, 0.0, 0.0],
              up=[0.0, 0.0, 1.0], fov_y_deg=fl(179.9)), flags=1, seq=31)
    t.common(p)

    def cam(vals):
        return b"".join(f32(v) if isinstance(v, float) else f32bits(v)
                        for v in vals)
    good = [0.0, 1.0, 6.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 45.0]
    for i, bits, name in [(0, 0x7fc00000, "NaN eye.x"),
                          (4, 0x7f800000, "+inf target.y"),
                          (8, 0xff800000, "-inf up.z"),
                          (9, 0x7fc00000, "NaN fov")]:
        v = list(good)
        v[i] = bits
        t.badp(name, cam(v), "ENONFINITE")
    v = list(good)
    v[0] = 1.5e6
    t.badp("eye.x over 1e6", cam(v), "ERANGE")
    for fov in (0.0, 180.0, -10.0):
        v = list(good)
        v[9] = fov
        t.badp("fov %g" % fov, cam(v), "ERANGE")
    v = list(good)
    v[0] = 0x7fc00000
    t.badp("NaN eye.x in a short payload", cam(v)[:39],
           "ENONFINITE")
    t.badp("FRAME's level bits (level 1)", p, "EPROTO_FLAGS",
           flags=level(1))
    t.dump("camera.json")


def gen_toggle(name):
    """PRESENT and FOLLOW: one byte, 0 or 1; in a session only."""
    t = Table(name)
    p = t.ok("on", dict(on=1), seq=40)
    t.ok("off", dict(on=0), seq=41)
    t.common(p)
    t.badp("on = 2", u8(2), "ERANGE")
    t.badp("on = 255", u8(255), "ERANGE")
    t.bad("sent by the wrong side", frame(name, p), "EPROTO_TYPE",
          reader=CLIENT)
    t.bad("refused by a server before HELLO", frame(name, p), "ESTATE",
          reader=PRE_HELLO)
    t.badp("INTERACTING is not defined for it", p, "EPROTO_FLAGS", flags=1)
    t.dump(name.lower() + ".json")


CAM_A = dict(eye=[0.0, 1.0, 6.0], target=[0.0, 0.0, 0.0],
             up=[0.0, 1.0, 0.0], fov_y_deg=45.0)


def gen_presenter():
    t = Table("PRESENTER")
    p = t.ok("member 4 presents, the receiver follows",
             dict(presenter=4, following=1), seq=0)
    t.ok("member 4 presents, the receiver does not follow",
         dict(presenter=4, following=0), seq=0)
    t.ok("nobody presents", dict(presenter=0, following=0), seq=0)
    t.common(p)
    t.badp("following 2", u32(4) + u8(2), "ERANGE")
    t.badp("following while nobody presents", u32(0) + u8(1), "ERANGE")
    t.bad("sent by the wrong side", frame("PRESENTER", p), "EPROTO_TYPE",
          reader=SERVER)
    t.dump("presenter.json")


def gen_follow_camera():
    t = Table("FOLLOW_CAMERA")
    p = t.ok("the presenter's camera", dict(presenter=4, **CAM_A), seq=0)
    t.ok("during the presenter's drag",
         dict(presenter=9, eye=[1e6, -2.5, fl(0.1)], target=[-0.0, 0.0, 0.0],
              up=[0.0, 0.0, 1.0], fov_y_deg=fl(179.9)), flags=1, seq=0)
    t.common(p)
    t.badp("presenter 0", u32(0) + w_camera(CAM_A), "ERANGE")
    t.badp("NaN eye.y", u32(4) + f32(0.0) + f32bits(0x7fc00000)
           + w_camera(CAM_A)[8:], "ENONFINITE")
    t.badp("fov 180", u32(4) + w_camera(dict(CAM_A, fov_y_deg=180.0)),
           "ERANGE")
    t.badp("flag 2 is not defined for it", p, "EPROTO_FLAGS", flags=2)
    t.bad("sent by the wrong side", frame("FOLLOW_CAMERA", p), "EPROTO_TYPE",
          reader=SERVER)
    t.dump("follow_camera.json")


def gen_session_camera():
    t = Table("SESSION_CAMERA")
    p = t.ok("a camera for the session", CAM_A, seq=42)
    t.common(p)
    t.badp("eye.z over 1e6", w_camera(dict(CAM_A, eye=[0.0, 1.0, 2e6])),
           "ERANGE")
    t.badp("+inf fov", w_camera(CAM_A)[:36] + f32bits(0x7f800000),
           "ENONFINITE")
    t.badp("INTERACTING is not defined for it", p, "EPROTO_FLAGS", flags=1)
    t.bad("sent by the wrong side", frame("SESSION_CAMERA", p),
          "EPROTO_TYPE", reader=CLIENT)
    t.bad("refused by a server before HELLO", frame("SESSION_CAMERA", p),
          "ESTATE", reader=PRE_HELLO)
    t.dump("session_camera.json")


def gen_session_camera_set():
    t = Table("SESSION_CAMERA_SET")
    p = t.ok("member 3's camera at order 12",
             dict(order="12", author=3, author_seq=42, **CAM_A), seq=0)
    t.ok("largest order", dict(order=str(2 ** 64 - 1), author=0xffffffff,
                               author_seq=0, **CAM_A), seq=0)
    t.common(p)
    t.badp("order 0", u64(0) + u32(3) + u32(42) + w_camera(CAM_A), "ERANGE")
    t.badp("author 0", u64(12) + u32(0) + u32(42) + w_camera(CAM_A),
           "ERANGE")
    t.badp("fov 0", u64(12) + u32(3) + u32(42)
           + w_camera(dict(CAM_A, fov_y_deg=0.0)), "ERANGE")
    t.bad("sent by the wrong side", frame("SESSION_CAMERA_SET", p),
          "EPROTO_TYPE", reader=SERVER)
    t.dump("session_camera_set.json")


def gen_view():
    t = Table("VIEW")
    base = dict(width=1280, height=720, encoding=1, quality_interactive=60,
                quality_still=92, downscale=2)
    p = t.ok("720p JPEG", base, seq=40)
    t.ok("largest raw", dict(base, width=8192, height=8192, encoding=3,
                             quality_interactive=100, quality_still=100,
                             downscale=8), seq=41)
    t.ok("smallest png", dict(base, width=1, height=1, encoding=2,
                              quality_interactive=1, quality_still=1,
                              downscale=1), seq=42)
    # Encoding 4 (H.264); odd sizes are the server's to pad (section 7.14).
    t.ok("1080p H.264", dict(base, width=1920, height=1080, encoding=4,
                             downscale=4), seq=43)
    t.ok("odd-sized H.264 with a PNG still",
         dict(base, width=1281, height=721, encoding=4, still_encoding=2),
         seq=44)
    t.ok("JPEG with a raw still", dict(base, still_encoding=3), seq=45)
    long = t.ok("H.264 with a JPEG still",
                dict(base, encoding=4, still_encoding=1), seq=46)
    # still_encoding is an optional ninth byte, so Table.common's
    # "one trailing byte" (a ninth byte of 0) is written out here.
    t.badp("payload one byte short", p[:-1], "EPROTO_TRUNCATED")
    t.badp("empty payload", b"", "EPROTO_TRUNCATED")
    t.badp("still_encoding 0 (leave it out)", p + b"\x00", "EENUM")
    t.badp("still_encoding 4 (leave it out)", p + b"\x04", "EENUM")
    t.badp("still_encoding 5", p + b"\x05", "EENUM")
    t.badp("ten bytes", long + b"\x00", "EPROTO_LENGTH")
    t.bad("length = type maximum + 1", header("VIEW", 10), "EPROTO_LENGTH")
    t.bad("length 2^31", header("VIEW", 2 ** 31), "EPROTO_LENGTH")
    t.bad("length 2^32-1", header("VIEW", 2 ** 32 - 1), "EPROTO_LENGTH")
    t.bad("stream ends inside the header", frame("VIEW", p)[:9],
          "EPROTO_TRUNCATED")
    t.bad("stream ends inside the payload", frame("VIEW", p)[:-1],
          "EPROTO_TRUNCATED")

    def vw(**kw):
        return w_view(dict(base, **kw))
    t.badp("width 0", vw(width=0), "ERANGE")
    t.badp("height 8193", vw(height=8193), "ERANGE")
    t.badp("encoding 0", vw(encoding=0), "EENUM")
    t.badp("encoding 5", vw(encoding=5), "EENUM")
    t.badp("quality 0", vw(quality_interactive=0), "ERANGE")
    t.badp("quality 101", vw(quality_still=101), "ERANGE")
    t.badp("downscale 0", vw(downscale=0), "ERANGE")
    t.badp("downscale 9", vw(downscale=9), "ERANGE")
    t.dump("view.json")


def gen_frame():
    t = Table("FRAME")
    jpeg = "ffd8ffe000104a464946" + "00" * 6 + "ffd9"
    base = dict(frame_no=77, order="1002", camera_seq=31, encoding=1,
                width=1280, height=720, image_width=640, image_height=360,
                rects=[dict(x=0, y=0, w=640, h=360, data=jpeg)])
    p = t.ok("interactive, downscaled", base, seq=0)
    t.ok("still, two damaged tiles",
         dict(base, frame_no=78, image_width=1280, image_height=720,
              rects=[dict(x=8, y=16, w=8, h=8, data=jpeg),
                     dict(x=1272, y=712, w=8, h=8, data=jpeg)]),
         flags=1, seq=0)
    raw = bytes(range(16)).hex()
    t.ok("snapshot, raw 2x2", dict(frame_no=79, order="1002", camera_seq=31,
                                  encoding=3, width=2, height=2,
                                  image_width=2, image_height=2,
                                  rects=[dict(x=0, y=0, w=2, h=2,
                                              data=raw)]),
         flags=2 | 1, seq=55)
    t.ok("snapshot, png", dict(frame_no=80, order="0", camera_seq=0,
                              encoding=2, width=3, height=1,
                              image_width=3, image_height=1,
                              rects=[dict(x=0, y=0, w=3, h=1,
                                          data="89504e47")]),
         flags=2, seq=56)
    # Refinement levels: one rectangle, image ceil(view / 2^n).
    t.ok("level 1, 1280x720 as 640x360",
         dict(base, frame_no=81, image_width=640, image_height=360),
         flags=level(1), seq=0)
    t.ok("level 1, odd 1281x721 as 641x361",
         dict(base, frame_no=82, width=1281, height=721, image_width=641,
              image_height=361,
              rects=[dict(x=0, y=0, w=641, h=361, data=jpeg)]),
         flags=level(1), seq=0)
    t.ok("level 2, incomplete, raw 7x5 as 2x2",
         dict(frame_no=83, order="6", camera_seq=9, encoding=3, width=7,
              height=5, image_width=2, image_height=2,
              rects=[dict(x=0, y=0, w=2, h=2, data=(
                  "ff000080" "00ff00ff" "0000ffff" "ffffffff"))]),
         flags=level(2) | INCOMPLETE, seq=0)
    t.ok("level 3, 8192x8192 as 1024x1024 png",
         dict(frame_no=84, order="7", camera_seq=10, encoding=2,
              width=8192, height=8192, image_width=1024, image_height=1024,
              rects=[dict(x=0, y=0, w=1024, h=1024, data="89504e47")]),
         flags=level(3), seq=0)
    t.ok("level 3, a 1x1 view as 1x1",
         dict(frame_no=85, order="7", camera_seq=10, encoding=3, width=1,
              height=1, image_width=1, image_height=1,
              rects=[dict(x=0, y=0, w=1, h=1, data="01020304")]),
         flags=level(3) | INCOMPLETE, seq=0)
    t.common(p)

    def fr(flags=0, rects=None, **kw):
        f = dict(base, **kw)
        if rects is not None:
            f["rects"] = rects
        return w_frame(f)
    one = [dict(x=0, y=0, w=640, h=360, data="00")]
    t.badp("encoding 0", fr(encoding=0), "EENUM")
    t.badp("width 0", fr(width=0), "ERANGE")
    t.badp("width 8193", fr(width=8193), "ERANGE")
    t.badp("image wider than the frame", fr(image_width=1281), "ERANGE")
    t.badp("still but downscaled", fr(), "ERANGE", flags=1)
    t.badp("snapshot as JPEG", fr(image_width=1280, image_height=720),
           "EENUM", flags=2)
    t.badp("rect_count 0", fr(rects=[]), "EPROTO_COUNT")
    t.badp("rect_count 4097",
           fr(rects=[dict(x=0, y=0, w=1, h=1, data="00")] * 4097),
           "EPROTO_COUNT")
    t.badp("rect_count larger than the bytes left",
           w_frame(dict(base, rects=[]))[:-2] + u16(3)
           + w_rects(one)[2:] * 2, "EPROTO_COUNT")
    t.badp("rect width 0", fr(rects=[dict(x=0, y=0, w=0, h=1, data="00")]),
           "ERANGE")
    t.badp("rect past the right edge",
           fr(rects=[dict(x=600, y=0, w=41, h=1, data="00")]), "ERANGE")
    t.badp("rect past the bottom edge",
           fr(rects=[dict(x=0, y=359, w=1, h=2, data="00")]), "ERANGE")
    # One byte more, so that the count check (13 bytes per rectangle)
    # passes and the length itself is what fails.
    t.badp("rect data length 0",
           fr(rects=[dict(x=0, y=0, w=1, h=1, data="")]) + b"\x00",
           "EPROTO_LENGTH")
    t.badp("raw rect of the wrong length",
           fr(encoding=3, rects=[dict(x=0, y=0, w=2, h=2, data="00" * 15)]),
           "EPROTO_LENGTH")
    t.badp("rect data longer than the bytes left",
           fr(rects=[dict(x=0, y=0, w=1, h=1, data="0011")])[:-1],
           "EPROTO_TRUNCATED")
    snap = dict(frame_no=1, order="0", camera_seq=0, encoding=2, width=4,
                height=4, image_width=4, image_height=4)
    t.badp("snapshot with two rects", w_frame(dict(snap, rects=[
        dict(x=0, y=0, w=4, h=4, data="00")] * 2)), "EPROTO_COUNT", flags=2)
    t.badp("snapshot rect not the whole image", w_frame(dict(snap, rects=[
        dict(x=0, y=0, w=4, h=3, data="00")])), "ERANGE", flags=2)
    t.badp("undefined flag bit 8", p, "EPROTO_FLAGS", flags=0x100)
    t.badp("undefined flag bit 15", p, "EPROTO_FLAGS", flags=0x8000)

    # Refinement levels. A level above 0 is never STILL or SNAPSHOT, and
    # that is a header rule: decided before the length, like any flag.
    lv1 = fr(image_width=640, image_height=360)
    t.badp("level 1 with STILL", lv1, "EPROTO_FLAGS",
           flags=level(1) | STILL)
    t.badp("level 2 with SNAPSHOT", w_frame(dict(
        snap, image_width=1, image_height=1,
        rects=[dict(x=0, y=0, w=1, h=1, data="00")])), "EPROTO_FLAGS",
        flags=level(2) | SNAPSHOT)
    t.badp("level 3 with STILL and SNAPSHOT", lv1, "EPROTO_FLAGS",
           flags=level(3) | STILL | SNAPSHOT)
    t.bad("level 1 with STILL, refused before the length",
          header("FRAME", 2 ** 32 - 1, flags=level(1) | STILL, seq=0)[:8],
          "EPROTO_FLAGS")
    t.badp("level 1, image one column narrow",
           fr(image_width=639, image_height=360,
              rects=[dict(x=0, y=0, w=639, h=360, data="00")]),
           "ERANGE", flags=level(1))
    t.badp("level 1, image one row tall",
           fr(image_width=640, image_height=361,
              rects=[dict(x=0, y=0, w=640, h=361, data="00")]),
           "ERANGE", flags=level(1))
    t.badp("level 1, full-size image", fr(image_width=1280,
                                          image_height=720), "ERANGE",
           flags=level(1))
    t.badp("level 2, image rounded down (7 / 4 = 1)",
           w_frame(dict(base, width=7, height=5, image_width=1,
                        image_height=2,
                        rects=[dict(x=0, y=0, w=1, h=2, data="00")])),
           "ERANGE", flags=level(2))
    t.badp("level 3, the image of level 2",
           fr(image_width=level_dim(1280, 2), image_height=level_dim(720, 2),
              rects=[dict(x=0, y=0, w=320, h=180, data="00")]),
           "ERANGE", flags=level(3))
    t.badp("level 1 with two rects", fr(
        image_width=640, image_height=360,
        rects=[dict(x=0, y=0, w=640, h=180, data="00"),
               dict(x=0, y=180, w=640, h=180, data="00")]),
        "EPROTO_COUNT", flags=level(1))
    t.badp("level 2, rect narrower than the image",
           fr(image_width=320, image_height=180,
              rects=[dict(x=0, y=0, w=319, h=180, data="00")]),
           "ERANGE", flags=level(2))
    t.badp("level 2, rect shorter than the image",
           fr(image_width=320, image_height=180,
              rects=[dict(x=0, y=0, w=320, h=179, data="00")]),
           "ERANGE", flags=level(2))
    t.badp("level 1, raw rect of the wrong length",
           w_frame(dict(base, encoding=3, width=3, height=3,
                        image_width=2, image_height=2,
                        rects=[dict(x=0, y=0, w=2, h=2, data="00" * 15)])),
           "EPROTO_LENGTH", flags=level(1))
    # Snapshot planes: after the colour rectangle, depth (f32) then ids
    # (u32), each covering the image at exactly 4 bytes a pixel.
    depth_px = f32(1.5) + f32bits(0x7f800000)  # a hit at 1.5, a miss
    ids_px = u32(7) + u32(0)
    colour_raw = "ff000080" "00ff00ff"
    snap2 = dict(frame_no=90, order="12", camera_seq=4, width=2, height=1,
                 image_width=2, image_height=1)

    def rect2(data):
        return dict(x=0, y=0, w=2, h=1, data=data)
    t.ok("snapshot with depth, raw 2x1",
         dict(snap2, encoding=3, rects=[rect2(colour_raw),
                                        rect2(depth_px.hex())]),
         flags=SNAPSHOT | STILL | DEPTH, seq=57)
    t.ok("snapshot with ids, png 2x1",
         dict(snap2, frame_no=91, encoding=2,
              rects=[rect2("89504e47"), rect2(ids_px.hex())]),
         flags=SNAPSHOT | STILL | IDS, seq=58)
    t.ok("snapshot with depth and ids, raw 2x1",
         dict(snap2, frame_no=92, encoding=3,
              rects=[rect2(colour_raw), rect2(depth_px.hex()),
                     rect2(ids_px.hex())]),
         flags=SNAPSHOT | STILL | DEPTH | IDS, seq=59)
    both = dict(snap2, encoding=2, rects=[
        rect2("89504e47"), rect2(depth_px.hex()), rect2(ids_px.hex())])
    t.badp("DEPTH without SNAPSHOT", w_frame(dict(both, rects=[
        rect2("89504e47"), rect2(depth_px.hex())])), "EPROTO_FLAGS",
        flags=STILL | DEPTH)
    t.badp("IDS without SNAPSHOT", w_frame(dict(both, rects=[
        rect2("89504e47")])), "EPROTO_FLAGS", flags=IDS)
    t.badp("DEPTH at level 1 without SNAPSHOT", lv1, "EPROTO_FLAGS",
           flags=level(1) | DEPTH)
    t.bad("IDS without SNAPSHOT, refused before the length",
          header("FRAME", 2 ** 32 - 1, flags=IDS, seq=0)[:8],
          "EPROTO_FLAGS")
    t.badp("DEPTH and IDS but two rects", w_frame(dict(both, rects=[
        rect2("89504e47"), rect2(depth_px.hex())])), "EPROTO_COUNT",
        flags=SNAPSHOT | DEPTH | IDS)
    t.badp("DEPTH but one rect", w_frame(dict(both, rects=[
        rect2("89504e47")])), "EPROTO_COUNT", flags=SNAPSHOT | DEPTH)
    t.badp("DEPTH but three rects", w_frame(both), "EPROTO_COUNT",
           flags=SNAPSHOT | DEPTH)
    t.badp("SNAPSHOT without planes but three rects", w_frame(both),
           "EPROTO_COUNT", flags=SNAPSHOT)
    t.badp("depth plane one byte short", w_frame(dict(both, rects=[
        rect2("89504e47"), rect2(depth_px.hex()[:-2]),
        rect2(ids_px.hex())])), "EPROTO_LENGTH",
        flags=SNAPSHOT | DEPTH | IDS)
    t.badp("ids plane one byte long", w_frame(dict(both, rects=[
        rect2("89504e47"), rect2(depth_px.hex()),
        rect2(ids_px.hex() + "00")])), "EPROTO_LENGTH",
        flags=SNAPSHOT | DEPTH | IDS)
    t.badp("ids plane of a png's length", w_frame(dict(both, rects=[
        rect2("89504e47"), rect2("89504e47")])), "EPROTO_LENGTH",
        flags=SNAPSHOT | IDS)
    t.badp("depth plane not the whole image", w_frame(dict(both, rects=[
        rect2("89504e47"), dict(x=0, y=0, w=1, h=1, data="0000c03f")])),
        "ERANGE", flags=SNAPSHOT | DEPTH)
    # Encoding 4 (H.264): one access unit covering the image, the view's
    # size at every level; KEY marks an IDR and belongs to encoding 4 only.
    au = "00000001" "6764001eacd940" "00000001" "68ebe3cb" "00000165888480"
    h264 = dict(frame_no=100, order="20", camera_seq=5, encoding=4,
                width=1281, height=721, image_width=1281, image_height=721,
                rects=[dict(x=0, y=0, w=1281, h=721, data=au)])
    t.ok("H.264 IDR, odd size", h264, flags=KEY, seq=0)
    t.ok("H.264 at level 2: still the view's size",
         dict(h264, frame_no=101, rects=[dict(x=0, y=0, w=1281, h=721,
                                               data="0000000141")]),
         flags=level(2) | INCOMPLETE, seq=0)
    t.ok("H.264 still", dict(h264, frame_no=102), flags=STILL | KEY, seq=0)

    def hv(**kw):
        return w_frame(dict(h264, **kw))
    t.badp("H.264 at level 1 at the level's size",
           hv(image_width=641, image_height=361,
              rects=[dict(x=0, y=0, w=641, h=361, data=au)]),
           "ERANGE", flags=level(1))
    t.badp("H.264 image narrower than the view",
           hv(image_width=1280, rects=[dict(x=0, y=0, w=1280, h=721,
                                            data=au)]), "ERANGE")
    t.badp("H.264 in two rects", hv(rects=[
        dict(x=0, y=0, w=1281, h=360, data=au),
        dict(x=0, y=360, w=1281, h=361, data=au)]), "EPROTO_COUNT")
    t.badp("H.264 rect shorter than the image", hv(rects=[
        dict(x=0, y=0, w=1281, h=720, data=au)]), "ERANGE")
    t.badp("KEY on a JPEG frame", p, "EPROTO_FLAGS", flags=KEY)
    t.badp("KEY on a PNG still", hv(encoding=2), "EPROTO_FLAGS",
           flags=STILL | KEY)
    t.badp("snapshot as H.264", w_frame(dict(snap, encoding=4, rects=[
        dict(x=0, y=0, w=4, h=4, data=au)])), "EENUM", flags=SNAPSHOT)
    t.badp("encoding 5", fr(encoding=5), "EENUM")
    t.bad("over the client's 64 KiB frame limit",
          header("FRAME", 65537), "EPROTO_LENGTH",
          reader={"side": "client", "max_payload": 65536})
    t.bad("refused by a server reader", frame("FRAME", p), "EPROTO_TYPE",
          reader=SERVER)
    t.dump("frame.json")


def gen_pick():
    t = Table("PICK")
    p = t.ok("pixel", dict(x=640, y=360), seq=50)
    t.ok("corner", dict(x=65535, y=0), seq=51)
    t.common(p)
    t.dump("pick.json")


def gen_pick_result():
    t = Table("PICK_RESULT")
    p = t.ok("hit", dict(x=640, y=360, node=2, position=[fl(-0.6), 0.0,
                                                        1.0],
                         depth=fl(5.08)), seq=50)
    t.ok("miss", dict(x=0, y=0, node=0, position=[0.0, 0.0, 0.0],
                      depth=0.0), seq=51)
    t.common(p)
    t.badp("NaN position", u16(0) + u16(0) + u32(2) + f32bits(0x7fc00000)
           + f32(0) + f32(0) + f32(1), "ENONFINITE")
    t.badp("infinite depth", u16(0) + u16(0) + u32(2) + f32(0) * 3
           + f32bits(0x7f800000), "ENONFINITE")
    t.badp("negative depth", u16(0) + u16(0) + u32(2) + f32(0) * 3
           + f32(-1), "ERANGE")
    t.badp("a miss with a position", u16(0) + u16(0) + u32(0) + f32(1)
           + f32(0) * 2 + f32(0), "ERANGE")
    t.badp("a miss with a depth", u16(0) + u16(0) + u32(0) + f32(0) * 3
           + f32(2), "ERANGE")
    t.dump("pick_result.json")


def gen_frame_ack():
    t = Table("FRAME_ACK")
    p = t.ok("frame 1", dict(frame_no=1), seq=70)
    t.ok("the last frame number", dict(frame_no=2 ** 32 - 1), seq=71)
    t.common(p)
    t.badp("frame_no 0", u32(0), "ERANGE")
    t.bad("sent by the wrong side", frame("FRAME_ACK", p), "EPROTO_TYPE",
          reader={"side": "client"})
    t.bad("refused by a server before HELLO", frame("FRAME_ACK", p),
          "ESTATE", reader={"side": "server", "await_hello": True})
    t.dump("frame_ack.json")


def gen_mesh():
    t = Table("MESH")
    p = t.ok("glTF binary at the default resolution",
             dict(format=4, options=0, resolution=0), seq=80)
    t.ok("OBJ, raw, 5 cells", dict(format=1, options=1, resolution=5),
         seq=81)
    t.ok("PLY at 4096", dict(format=2, options=0, resolution=4096), seq=82)
    t.ok("STL at 300", dict(format=3, options=0, resolution=300), seq=83)
    t.common(p)
    t.badp("format 0", w_mesh(dict(format=0, options=0, resolution=0)),
           "EENUM")
    t.badp("format 5", w_mesh(dict(format=5, options=0, resolution=0)),
           "EENUM")
    t.badp("options bit 1", w_mesh(dict(format=4, options=2,
                                        resolution=0)), "EPROTO_FLAGS")
    t.badp("resolution 1", w_mesh(dict(format=4, options=0,
                                       resolution=1)), "ERANGE")
    t.badp("resolution 4: no cell inside the margins",
           w_mesh(dict(format=4, options=0, resolution=4)), "ERANGE")
    t.badp("resolution 4097", w_mesh(dict(format=4, options=0,
                                          resolution=4097)), "ERANGE")
    t.bad("sent by the wrong side", frame("MESH", p), "EPROTO_TYPE",
          reader={"side": "client"})
    t.bad("refused by a server before HELLO", frame("MESH", p),
          "ESTATE", reader={"side": "server", "await_hello": True})
    t.dump("mesh.json")


def gen_mesh_data():
    t = Table("MESH_DATA")
    obj = b"v 0 0 0 1 1 1\nv 1 0 0 1 1 1\nv 0 1 0 1 1 1\nv 0 0 1 1 1 1\n" \
        b"f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    base = dict(format=1, options=0, resolution=128, order="12",
                vertices=4, triangles=4, file=obj.hex())
    p = t.ok("a tetrahedron as OBJ", base, seq=80)
    t.ok("raw glTF bytes at 5 cells, order 0",
         dict(base, format=4, options=1, resolution=5, order="0",
              file="676c5446"), seq=81)
    t.ok("an empty mesh: STL's 84 bytes",
         dict(base, format=3, resolution=4096, order=str(2 ** 64 - 1),
              vertices=0, triangles=0, file=(b"\0" * 84).hex()), seq=82)
    t.common(p)

    def md(**kw):
        return w_mesh_data(dict(base, **kw))
    t.badp("format 0", md(format=0), "EENUM")
    t.badp("format 5", md(format=5), "EENUM")
    t.badp("options bit 7", md(options=0x80), "EPROTO_FLAGS")
    t.badp("resolution 0 (a MESH's default is never an answer)",
           md(resolution=0), "ERANGE")
    t.badp("resolution 4", md(resolution=4), "ERANGE")
    t.badp("resolution 4097", md(resolution=4097), "ERANGE")
    t.badp("an empty file (bytes has at least one)",
           w_mesh(base) + u64(12) + u32(4) + u32(4) + u32(0),
           "EPROTO_LENGTH")
    t.bad("refused by a server reader", frame("MESH_DATA", p),
          "EPROTO_TYPE", reader=SERVER)
    t.dump("mesh_data.json")


def gen_snapshot():
    t = Table("SNAPSHOT")
    # planes is an optional second byte, so the cases of Table.common
    # that shorten or lengthen a payload are written out here.
    t.ok("png", dict(encoding=2, planes=0), seq=55)
    t.ok("raw", dict(encoding=3, planes=0), seq=56)
    t.ok("raw with depth", dict(encoding=3, planes=PLANE_DEPTH), seq=57)
    t.ok("png with ids", dict(encoding=2, planes=PLANE_IDS), seq=58)
    p = t.ok("raw with depth and ids",
             dict(encoding=3, planes=PLANE_DEPTH | PLANE_IDS), seq=59)
    # Colour only leaves the byte out, so each SNAPSHOT has one encoding.
    t.badp("planes byte 0", u8(2) + u8(0), "ERANGE")
    t.badp("empty payload", b"", "EPROTO_TRUNCATED")
    # A third byte starts the tile form, which needs 14.
    t.badp("one byte after the planes: a tile form cut short",
           p + b"\x00", "EPROTO_TRUNCATED")
    t.bad("length = type maximum + 1", header("SNAPSHOT", 15),
          "EPROTO_LENGTH")
    # The tile form (feature TILES): the planes byte, then the picture's
    # size and the tile inside it.
    tile = dict(encoding=2, planes=0, full_width=8192, full_height=8192,
                tile_x=7168, tile_y=7168, tile_width=1024,
                tile_height=1024)
    t.ok("tile form: the last 1024^2 tile of 8192^2, colour only", tile,
         seq=60)
    tp = t.ok("tile form: a ragged edge tile with depth and ids",
              dict(tile, encoding=3, planes=3, full_width=1000,
                   full_height=700, tile_x=768, tile_y=512,
                   tile_width=232, tile_height=188), seq=61)
    t.ok("tile form: one pixel", dict(tile, full_width=1, full_height=1,
                                      tile_x=0, tile_y=0, tile_width=1,
                                      tile_height=1), seq=62)
    w = w_snapshot

    def tb(**k):
        return w(dict(tile, **k))
    t.badp("tile form cut short (13 bytes)", tp[:-1], "EPROTO_TRUNCATED")
    t.badp("tile form with only the size", tp[:6], "EPROTO_TRUNCATED")
    t.badp("tile form, full_width 0", tb(full_width=0), "ERANGE")
    t.badp("tile form, full_height 8193", tb(full_height=8193), "ERANGE")
    t.badp("tile form, tile_x at the width", tb(tile_x=8192), "ERANGE")
    t.badp("tile form, tile_y past the height", tb(tile_y=9000), "ERANGE")
    t.badp("tile form, tile_width 0", tb(tile_width=0), "ERANGE")
    t.badp("tile form, tile past the right edge", tb(tile_width=1025),
           "ERANGE")
    t.badp("tile form, tile past the bottom edge", tb(tile_height=1025),
           "ERANGE")
    t.badp("tile form, planes bit 2", tb(planes=4), "EPROTO_FLAGS")
    t.badp("tile form, jpeg", tb(encoding=1), "EENUM")
    t.badp("tile form and one trailing byte", tp + b"\x00", "EPROTO_LENGTH")
    t.bad("length 2^31", header("SNAPSHOT", 2 ** 31), "EPROTO_LENGTH")
    t.bad("length 2^32-1", header("SNAPSHOT", 2 ** 32 - 1),
          "EPROTO_LENGTH")
    t.bad("stream ends inside the header", frame("SNAPSHOT", p)[:9],
          "EPROTO_TRUNCATED")
    t.bad("stream ends inside the payload", frame("SNAPSHOT", p)[:-1],
          "EPROTO_TRUNCATED")
    t.badp("planes bit 2", u8(3) + u8(4), "EPROTO_FLAGS")
    t.badp("planes 0xff", u8(2) + u8(0xff), "EPROTO_FLAGS")
    t.badp("jpeg with planes", u8(1) + u8(3), "EENUM")
    t.badp("jpeg", u8(1), "EENUM")
    t.badp("encoding 0", u8(0), "EENUM")
    t.badp("encoding 200", u8(200), "EENUM")
    t.dump("snapshot.json")


def gen_stats():
    t = Table("STATS")
    base = dict(uptime_ms="3600000", frames="5400", bytes="812345678",
                order="1002", sessions=2, clients=5,
                render_ms_last=fl(11.5), render_ms_avg=fl(12.25),
                encode_ms_last=fl(1.75), encode_ms_avg=fl(1.5),
                edit_ms_avg=fl(0.03125), fps=fl(29.5))
    p = t.ok("typical", base, seq=60)
    t.ok("zeros", dict(uptime_ms="0", frames="0", bytes="0", order="0",
                       sessions=0, clients=0, render_ms_last=0.0,
                       render_ms_avg=0.0, encode_ms_last=0.0,
                       encode_ms_avg=0.0, edit_ms_avg=0.0, fps=0.0),
         seq=61)
    t.common(p)
    pre = p[:40]
    t.badp("NaN render time", pre + f32bits(0x7fc00000) + p[44:],
           "ENONFINITE")
    t.badp("negative fps", p[:60] + f32(-1.0), "ERANGE")
    load = dict(base, has_load=True, loop_turn_max_ms=fl(3.25),
                loop_request_max_ms=fl(1.5), render_workers=2,
                jobs_queued=3, jobs_running=2, view_bytes="402653184",
                view_cap="402653184", session_render_us="123456789")
    q = t.ok("with the load section", load, seq=62)
    t.badp("load section one byte short", q[:-1], "EPROTO_TRAILING")
    t.badp("half a load section", q[:64 + 20], "EPROTO_TRAILING")
    t.badp("load section, NaN loop turn", q[:64] + f32bits(0x7fc00000)
           + q[68:], "ENONFINITE")
    t.badp("load section, negative request time", q[:68] + f32(-1.0)
           + q[72:], "ERANGE")
    tls = dict(base, has_tls=True, tls_not_after_ms="1796083200000",
               tls_expiring=0)
    r = t.ok("with the TLS section", tls, seq=63)
    t.ok("with both sections, the certificate expiring",
         dict(load, has_tls=True, tls_not_after_ms="1796083200000",
              tls_expiring=1), seq=64)
    t.ok("TLS section of a daemon without TLS",
         dict(tls, tls_not_after_ms="0"), seq=65)
    t.badp("TLS section, tls_expiring 2", r[:-1] + u8(2), "ERANGE")
    t.badp("TLS section one byte short", r[:-1], "EPROTO_TRAILING")
    link_f = dict(has_link=True, rtt_us=50213, min_rtt_us=48007,
                  delivery_bps="1250000", unacked_bytes=65536,
                  frames_paced=17, frames_spoiled="9")
    k = t.ok("with the link section", dict(base, **link_f), seq=66)
    t.ok("with every section", dict(load, has_tls=True,
                                    tls_not_after_ms="1796083200000",
                                    tls_expiring=0, **link_f), seq=67)
    t.ok("link section of a Unix socket",
         dict(tls, **dict(link_f, rtt_us=0, min_rtt_us=0,
                          delivery_bps="0")), seq=68)
    t.badp("link section one byte short", k[:-1], "EPROTO_TRAILING")
    t.badp("link section one byte long", k + u8(0), "EPROTO_TRAILING")
    mem_f = dict(has_memory=True, scene_nodes="100001",
                 scene_nodes_cap="149796", session_nodes="60001",
                 sessions_loaded=3)
    m = t.ok("with the memory section", dict(base, **mem_f), seq=69)
    t.ok("with every section, memory last",
         dict(load, has_tls=True, tls_not_after_ms="1796083200000",
              tls_expiring=0, **link_f, **mem_f), seq=70)
    t.ok("memory section outside a session, past the cap",
         dict(base, **dict(mem_f, scene_nodes="149800",
                           session_nodes="0")), seq=71)
    t.ok("with the link and memory sections", dict(base, **link_f, **mem_f),
         seq=72)
    t.badp("memory section one byte short", m[:-1], "EPROTO_TRAILING")
    t.badp("memory section one byte long", m + u8(0), "EPROTO_TRAILING")
    t.dump("stats.json")


def gen_get_stats():
    t = Table("GET_STATS")
    t.ok("empty", dict(parts=0), seq=12)
    t.ok("load", dict(parts=1), seq=13)
    p = t.ok("load and reset", dict(parts=3), seq=14)
    t.ok("TLS", dict(parts=4), seq=15)
    t.ok("load, reset and TLS", dict(parts=7), seq=16)
    t.ok("link", dict(parts=8), seq=17)
    t.ok("every part", dict(parts=15), seq=18)
    t.ok("memory", dict(parts=16), seq=19)
    t.ok("every part, memory too", dict(parts=31), seq=20)
    # parts is an optional byte, so Table.common's shortened and
    # lengthened payloads are written out here.
    t.badp("parts 0", u8(0), "ERANGE")
    t.badp("reset without load", u8(2), "ERANGE")
    t.badp("TLS and reset without load", u8(6), "ERANGE")
    t.badp("parts bit 5", u8(0x21), "EPROTO_FLAGS")
    t.badp("parts 0xff", u8(0xff), "EPROTO_FLAGS")
    t.badp("one trailing byte", p + b"\x00", "EPROTO_LENGTH")
    t.bad("length = type maximum + 1", header("GET_STATS", 2),
          "EPROTO_LENGTH")
    t.bad("length 2^31", header("GET_STATS", 2 ** 31), "EPROTO_LENGTH")
    t.bad("length 2^32-1", header("GET_STATS", 2 ** 32 - 1),
          "EPROTO_LENGTH")
    t.bad("stream ends inside the header", frame("GET_STATS", p)[:9],
          "EPROTO_TRUNCATED")
    t.bad("stream ends inside the payload", frame("GET_STATS", p)[:-1],
          "EPROTO_TRUNCATED")
    t.bad("sent by the wrong side", frame("GET_STATS", b""), "EPROTO_TYPE",
          reader=CLIENT)
    t.bad("refused by a server before HELLO", frame("GET_STATS", b""),
          "ESTATE", reader=PRE_HELLO)
    t.dump("get_stats.json")


# ---- Stream-level cases ------------------------------------------------------


def gen_framing():
    """Header and stream rules that do not belong to one type."""
    ping = frame("PING", u64(1))
    inv = []

    def bad(name, raw, error, reader=None, messages=0):
        e = {"name": name, "hex": raw.hex(), "error": error}
        if reader:
            e["reader"] = reader
        if messages:
            e["messages"] = messages
        inv.append(e)
    bad("empty stream is a clean end", b"", None)
    bad("two messages back to back", ping + frame("OK", b"", seq=1), None,
        messages=2)
    bad("first byte is not the magic", b"G", "EPROTO_MAGIC")
    bad("an HTTP request", b"GET / HTTP/1.1\r\n\r\n", "EPROTO_MAGIC")
    bad("third magic byte wrong", b"BCX", "EPROTO_MAGIC")
    bad("magic only, then the stream ends", MAGIC, "EPROTO_TRUNCATED")
    bad("version 0", header("PING", 8, version=0) + u64(0),
        "EPROTO_VERSION")
    bad("version 2", header("PING", 8, version=2) + u64(0),
        "EPROTO_VERSION")
    bad("version 255, header cut after it", MAGIC + u8(255),
        "EPROTO_VERSION")
    bad("type 0", header(0, 0), "EPROTO_TYPE")
    bad("type 39", header(39, 0), "EPROTO_TYPE")
    bad("type 255", header(255, 0), "EPROTO_TYPE")
    bad("unknown type is reported before the rest of the header",
        MAGIC + u8(1) + u8(99), "EPROTO_TYPE")
    bad("flags checked before the length", header("PING", 2 ** 32 - 1,
                                                  flags=0x8000),
        "EPROTO_FLAGS")
    bad("truncated header (15 bytes)", ping[:15], "EPROTO_TRUNCATED")
    bad("bad message after a good one", ping + b"XBCST", "EPROTO_MAGIC",
        messages=1)
    bad("good message, then a truncated one", ping + ping[:20],
        "EPROTO_TRUNCATED", messages=1)
    bad("before HELLO: EDIT", frame("EDIT", u16(1) + u8(3) + u32(1)),
        "ESTATE", reader=PRE_HELLO)
    bad("before HELLO: CAMERA", frame("CAMERA", b"\x00" * 40), "ESTATE",
        reader=PRE_HELLO)
    bad("before HELLO: a server-only type is EPROTO_TYPE, not ESTATE",
        header("FRAME", 0), "EPROTO_TYPE", reader=PRE_HELLO)
    bad("length over a reader's limit", header("SCENE_LOAD", 1025),
        "EPROTO_LENGTH", reader={"max_payload": 1024})
    bad("length at a reader's limit waits for the payload",
        header("SCENE_LOAD", 1024), "EPROTO_TRUNCATED",
        reader={"max_payload": 1024})
    bad("64 MiB + 1 is over every limit", header("SCENE_LOAD",
                                                  MAX_PAYLOAD + 1),
        "EPROTO_LENGTH")
    bad("64 MiB header waits for the payload", header("SCENE_LOAD",
                                                       MAX_PAYLOAD),
        "EPROTO_TRUNCATED")
    write_json("framing.json", {"type": None, "valid": [], "invalid": inv})


# ---- Scene encoding --------------------------------------------------------------


def gen_scene():
    valid, inv = [], []

    def ok(name, b, nodes, prims, ops, depth, camera, names=None):
        fields = dict(has_camera=camera, nodes=nodes, prims=prims, ops=ops,
                      depth=depth)
        if names is not None:
            fields["names"] = names
        valid.append({"name": name, "hex": b.hex(), "fields": fields})

    def bad(name, b, error):
        inv.append({"name": name, "hex": b.hex(), "error": error})
    ok("one sphere", scene([SPHERE]), 1, 1, 0, 1, False)
    ok("smooth union with camera and colour", SCENE_SMALL, 3, 2, 1, 2, True)
    ok("n-ary union of four", scene([scene_op(1, 10, 0, 0, 4)]
                                    + [SPHERE] * 4), 5, 4, 1, 2, False)
    ok("nested: difference of a union", scene([
        scene_op(3, 1, 0, 0, 2), scene_op(1, 2, 0, 0, 2), SPHERE, SPHERE,
        SPHERE]), 5, 3, 2, 3, False)
    ok("depth 128: 127 nested operators",
       deep_scene(127), 255, 128, 127, 128, False)
    # Deep chains are valid far past 128 (Lipschitz Pruning's Molecule is
    # 1001 levels); the limit itself (2^20) is checked by the C tests.
    ok("depth 1001: 1000 nested operators",
       deep_scene(1000), 2001, 1001, 1000, 1001, False)
    ok("primitive with 8 floats", scene([scene_prim(7, 4, [0.5] * 8)]),
       1, 1, 0, 1, False)
    ok("offset over a twist over a sphere",
       scene([scene_unary(7, 5, [0.1]), scene_unary(10, 6, [1.5]), SPHERE]),
       3, 1, 2, 3, False)
    ok("repeat of a union, mirrored",
       scene([scene_unary(12, 0, [5.0]),
              scene_unary(13, 0, [1.0, 0.0, 1.5, 3.0, 1.0, 2.0]),
              scene_op(1, 0, 0, 0, 2), SPHERE, SPHERE]), 5, 2, 3, 4, False)
    ok("the last kind, 32 (revolve_star)",
       scene([scene_prim(32, 4, [0.35, 5.0, 0.5, 0.75])]), 1, 1, 0, 1, False)
    ok("named nodes, with camera",
       scene([scene_op(4, 1, 0.5, 0.5, 2), scene_prim(1, 2, [1.0]),
              scene_prim(1, 3, [1.0])], camera=CAM,
             names=[(1, "blob"), (3, "\u6a5f\u68b0 " + "x" * 57)]),
       3, 2, 1, 2, True, names=2)
    ok("a subtree with names", SUBTREE_NAMED, 3, 2, 1, 2, False, names=2)
    bad("empty", b"", "EPROTO_TRUNCATED")
    bad("flags bit 2", u8(4) + u32(1) + SPHERE, "EPROTO_FLAGS")
    union = u32(3) + scene_op(1, 1, 0, 0, 2) + scene_prim(1, 2, [1.0]) \
        + scene_prim(1, 3, [1.0])
    named = u8(2) + union
    bad("names bit without a table", named, "EPROTO_TRUNCATED")
    bad("name_count 0", named + u32(0), "EPROTO_COUNT")
    bad("name_count above node_count", named + u32(4)
        + (u32(1) + sstr("abc")) * 4, "EPROTO_COUNT")
    bad("name_count above the bytes left / 7", named + u32(2)
        + u32(1) + sstr("abcdefg"), "EPROTO_COUNT")
    bad("name id 0", named + u32(1) + u32(0) + sstr("a"), "ERANGE")
    bad("name ids decreasing", named + u32(2) + u32(3) + sstr("a")
        + u32(2) + sstr("b"), "ERANGE")
    bad("name id twice", named + u32(2) + u32(2) + sstr("a")
        + u32(2) + sstr("b"), "EDUPID")
    bad("empty name", named + u32(1) + u32(2) + sstr("") + u8(0),
        "EPROTO_LENGTH")
    bad("name of 65 bytes", named + u32(1) + u32(2) + sstr("n" * 65),
        "EPROTO_LENGTH")
    bad("name cut short", named + u32(1) + u32(2) + u16(5) + b"abc",
        "EPROTO_TRUNCATED")
    bad("entry cut inside its length", named + u32(2) + u32(1)
        + sstr("abcdefgh") + u32(2) + u8(1), "EPROTO_TRUNCATED")
    bad("name that is not UTF-8", named + u32(1) + u32(2)
        + sstr(b"\xed\xa0\x80"), "ESTRING")
    bad("byte after the names", named + u32(1) + u32(2) + sstr("a")
        + u8(0), "EPROTO_TRAILING")
    bad("camera with NaN", u8(1) + f32bits(0x7fc00000) + f32(0) * 9
        + u32(1) + SPHERE, "ENONFINITE")
    bad("node_count 0", u8(0) + u32(0), "EPROTO_COUNT")
    bad("node_count 2^22", u8(0) + u32(1 << 22), "EPROTO_COUNT")
    bad("node_count larger than the bytes left / 5",
        u8(0) + u32(100) + SPHERE, "EPROTO_COUNT")
    bad("tag 0", u8(0) + u32(1) + u8(0) + SPHERE[1:], "EENUM")
    bad("tag 33", u8(0) + u32(1) + u8(33) + SPHERE[1:], "EENUM")
    bad("operator tag 0x8f", u8(0) + u32(3) + u8(0x8f) + scene_op(
        1, 0, 0, 0, 2)[1:] + SPHERE * 2, "EENUM")
    bad("unary node without its child",
        u8(0) + u32(1) + scene_unary(7, 0, [0.1]), "EPROTO_COUNT")
    bad("unary node with nfloats 7",
        scene([scene_unary(13, 0, [1.0] * 7), SPHERE]), "EPROTO_COUNT")
    bad("unary node with a NaN parameter",
        scene([u8(0x87) + u32(0) + u8(1) + f32bits(0x7fc00000), SPHERE]),
        "ENONFINITE")
    bad("operator with one child", scene([scene_op(1, 0, 0, 0, 1),
                                          SPHERE, SPHERE]), "EPROTO_COUNT")
    bad("children beyond node_count", u8(0) + u32(3) + scene_op(
        1, 0, 0, 0, 3) + SPHERE * 3, "EPROTO_COUNT")
    bad("tree ends before node_count", u8(0) + u32(2) + SPHERE * 2,
        "EPROTO_COUNT")
    bad("has_color 2", u8(0) + u32(1) + SPHERE[:33] + u8(2) + u8(0),
        "EPROTO_FLAGS")
    bad("sharp union with a blend", scene([scene_op(1, 0, 0.5, 0.5, 2),
                                           SPHERE, SPHERE]), "ERANGE")
    # The tag and the id are read before the tag is judged.
    bad("unknown tag, then the bytes end inside its id",
        u8(0) + u32(3) + scene_op(1, 0, 0, 0, 2) + SPHERE + u8(0x8f)
        + u16(0), "EPROTO_TRUNCATED")
    bad("nfloats 9", scene([scene_prim(1, 0, [1.0] * 9)]), "EPROTO_COUNT")
    # A box has 4 parameter floats; one is there.
    bad("params longer than the bytes left",
        u8(0) + u32(1) + u8(2) + SPHERE[1:34] + u8(4) + f32(1),
        "EPROTO_TRUNCATED")
    bad("translate cut short, NaN in what is there",
        u8(0) + u32(1) + SPHERE[:5] + f32bits(0x7fc00000) + f32(0),
        "EPROTO_TRUNCATED")
    bad("infinite radius", u8(0) + u32(1) + SPHERE[:35]
        + f32bits(0x7f800000), "ENONFINITE")
    bad("NaN blend", u8(0) + u32(3) + u8(0x81) + u32(0)
        + f32bits(0x7fc00000) + f32(0) + u32(2) + SPHERE * 2, "ENONFINITE")
    bad("trailing byte", scene([SPHERE]) + b"\x00", "EPROTO_TRAILING")
    # 113 bytes precede the last node of SCENE_SMALL; 25 more end inside
    # its rotation.
    bad("bytes end inside a rotation", SCENE_SMALL[:113 + 25],
        "EPROTO_TRUNCATED")
    bad("last parameter cut short", scene([SPHERE])[:-1],
        "EPROTO_TRUNCATED")
    write_json("scene.json", {"type": None, "valid": valid, "invalid": inv})


# ---- Transcripts of earlier clients (section 4.1) -----------------------------


def gen_earlier():
    """Byte transcripts of clients of the first text of version 1
    (2026-11-22): every message such a client sends, with the answers it
    waits for. A server must serve them; while replaying, every message the
    server sends must be one that text defines (types 1..22, its flags,
    STATS of 64 bytes, scenes of primitive kinds 1..16 and binary
    operators only). These bytes follow that text's diagrams; its HELLO
    has no features field."""
    out = []

    def script(name, about):
        steps = []
        out.append({"name": name, "about": about, "steps": steps})
        seq = [0]

        def send(mtype, payload, flags=0):
            seq[0] += 1
            steps.append({"send": frame(mtype, payload, flags=flags,
                                        seq=seq[0]).hex(), "type": mtype,
                          "seq": seq[0]})
            return seq[0]

        def expect(mtype, **kw):
            e = {"expect": mtype}
            e.update(kw)
            steps.append(e)
        return send, expect

    hello = dict(version_min=1, version_max=1, encodings=7,
                 max_frame_bytes=0, token="")
    cam_a = [0.0, 1.0, 6.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 45.0]
    cam_b = [1.0, 1.0, 6.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 45.0]
    send, expect = script(
        "editor", "creates a session, loads a scene, views it with "
        "downscale 4 through a drag, edits (SET, INSERT, REMOVE, an "
        "unknown node), picks, takes a snapshot and its figures, leaves")
    q = send("HELLO", w_hello(dict(hello, client_name="first-text editor")))
    expect("WELCOME", seq=q)
    send("SESSION_CREATE", u8(1) + sstr("first-text"))
    expect("SESSION_INFO")
    expect("SCENE_STATE")
    q = send("SCENE_LOAD", blob(SCENE_SMALL))
    expect("SCENE_STATE", author_seq=q)
    send("VIEW", w_view(dict(width=96, height=64, encoding=2,
                             quality_interactive=70, quality_still=90,
                             downscale=4)))
    expect("FRAME", still=True)
    q = send("CAMERA", b"".join(f32(v) for v in cam_b), flags=1)
    expect("FRAME", camera_seq=q)
    q = send("CAMERA", b"".join(f32(v) for v in cam_a))
    expect("FRAME", camera_seq=q, still=True)
    q = send("EDIT", w_ops([{"kind": 1, "node": 2, "fields": [
        {"field": 1, "values": [-0.5, 0.25, 0.0]}]}]))
    expect("EDIT_APPLIED", author_seq=q)
    q = send("EDIT", w_ops([{"kind": 2, "parent": 1, "position": 2,
                             "subtree": scene([scene_prim(
                                 1, 10, [0.5], translate=(0, 0.8, 0))]
                             ).hex()}]))
    expect("EDIT_APPLIED", author_seq=q)
    expect("FRAME", still=True)
    q = send("EDIT", w_ops([{"kind": 3, "node": 10}]))
    expect("EDIT_APPLIED", author_seq=q)
    q = send("EDIT", w_ops([{"kind": 1, "node": 99, "fields": [
        {"field": 1, "values": [0.0, 0.0, 0.0]}]}]))
    expect("ERROR", seq=q, code="ENONODE")
    q = send("PICK", u16(48) + u16(32))
    expect("PICK_RESULT", seq=q)
    q = send("SNAPSHOT", u8(2))
    expect("FRAME", seq=q, snapshot=True)
    q = send("GET_STATS", b"")
    expect("STATS", seq=q)
    q = send("PING", u64(7))
    expect("PONG", seq=q)
    q = send("SESSION_LEAVE", b"")
    expect("OK", seq=q)

    send, expect = script(
        "viewer", "joins that session as a viewer, is refused an edit, "
        "watches and leaves")
    q = send("HELLO", w_hello(dict(hello, client_name="first-text viewer")))
    expect("WELCOME", seq=q)
    send("SESSION_JOIN", u8(2) + sstr("first-text"))
    expect("SESSION_INFO")
    expect("SCENE_STATE")
    send("VIEW", w_view(dict(width=64, height=48, encoding=1,
                             quality_interactive=60, quality_still=85,
                             downscale=2)))
    expect("FRAME", still=True)
    q = send("EDIT", w_ops([{"kind": 3, "node": 3}]))
    expect("ERROR", seq=q, code="EPERM")
    q = send("SESSION_LEAVE", b"")
    expect("OK", seq=q)
    os.makedirs(os.path.join(HERE, "earlier"), exist_ok=True)
    write_json(os.path.join("earlier", "first_text.json"),
               {"text": "version 1 as of 2026-11-22", "transcripts": out})


def main():
    gen_hello()
    gen_welcome()
    gen_error()
    gen_ping("PING")
    gen_ping("PONG")
    gen_empty("OK", "server")
    gen_session("SESSION_CREATE")
    gen_session("SESSION_JOIN")
    gen_empty("SESSION_LEAVE", "client")
    gen_session_info()
    gen_scene_load()
    gen_scene_state()
    gen_edit()
    gen_edit_applied()
    gen_camera()
    gen_view()
    gen_frame()
    gen_pick()
    gen_pick_result()
    gen_snapshot()
    gen_get_stats()
    gen_stats()
    gen_session_delete()
    gen_undo("UNDO")
    gen_undo("REDO")
    gen_empty("SESSION_LIST", "client")
    gen_sessions()
    gen_toggle("PRESENT")
    gen_toggle("FOLLOW")
    gen_presenter()
    gen_follow_camera()
    gen_session_camera()
    gen_session_camera_set()
    gen_empty("HISTORY_GET", "client")
    gen_history()
    gen_frame_ack()
    gen_mesh()
    gen_mesh_data()
    gen_framing()
    gen_scene()
    gen_earlier()


if __name__ == "__main__":
    main()
