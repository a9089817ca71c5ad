#!/usr/bin/env python3
"""Writes the seed corpora of the protocol fuzzers from the test vectors.

Every valid and invalid encoding in protocol/vectors/ becomes a seed, in the
input format of each harness (see the comment at the top of each
fuzz_proto_*.c). Seeds are named by the SHA-1 of their bytes, so reruns are
stable. Run:  python3 tests/fuzz/make_seeds.py   and commit corpus/proto_*/.
"""

import glob
import hashlib
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
VECTORS = os.path.join(HERE, "..", "..", "protocol", "vectors")
MAX_SEED = 16 * 1024  # keeps -max_len and the corpus small


def put(corpus, data):
    if len(data) > MAX_SEED:
        return
    d = os.path.join(HERE, "corpus", corpus)
    os.makedirs(d, exist_ok=True)
    name = hashlib.sha1(data).hexdigest()
    with open(os.path.join(d, name), "wb") as fp:
        fp.write(data)


def reader_opts(entry):
    """The harness's option byte for a vector's reader options."""
    r = entry.get("reader", {})
    side = {"server": 1, "client": 2}.get(r.get("side"), 0)
    o = side | (4 if r.get("await_hello") else 0)
    if r.get("max_payload") == 4096:
        o |= 8
    return o


def main():
    for path in sorted(glob.glob(os.path.join(VECTORS, "*.json"))):
        doc = json.load(open(path, encoding="utf-8"))
        entries = doc["valid"] + doc["invalid"]
        if os.path.basename(path) == "scene.json":
            for e in entries:
                put("proto_scene", bytes.fromhex(e["hex"]))
            continue
        for e in entries:
            raw = bytes.fromhex(e["hex"])
            # Whole at once, and in small pieces.
            put("proto_reader", bytes([reader_opts(e), 0]) + raw)
            put("proto_reader", bytes([reader_opts(e), 7]) + raw)
            if len(raw) >= 16 and raw[:4] == b"BCST":
                put("proto_payload", bytes([raw[5], raw[6]]) + raw[16:])
            # Scene bytes inside SCENE_LOAD vectors seed the scanner too.
            f = e.get("fields", {})
            if "scene" in f:
                put("proto_scene", bytes.fromhex(f["scene"]))


if __name__ == "__main__":
    main()
