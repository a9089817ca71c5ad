#!/usr/bin/env python3
"""The daemon's layers call only down, and its functions stay short.

docs/architecture.md draws blobcastd as layers -- transport, dispatch,
sessions, work, with link.c shared by all -- each calling only the ones
below it; a lower layer reports up by callback (link.h) or queue. This
reads the symbols of the server's static library (nm): every function an
object uses and the object that defines it. A call from a layer into one
above it fails the check, naming both sides. A source file of server/ that
the table below does not place fails it too, so a new file must be given
its layer.

It also fails when a function of server/*.c is longer than MAX_LINES
lines (from its name to its closing brace, as .clang-format lays them out).

Usage: check_layers.py LIBBC_SERVER.a SERVER_SOURCE_DIR
"""
import os
import re
import subprocess
import sys

# Lower numbers are higher layers: a file may call its own layer and those
# with larger numbers.
LAYERS = {
    "transport": 0, "dispatch": 1, "sessions": 2, "work": 3, "shared": 4,
}
FILES = {
    "net": "transport", "listen": "transport", "admit": "transport",
    "tls": "transport", "addr": "transport", "acks": "transport",
    "dispatch": "dispatch",
    "session": "sessions", "members": "sessions", "index": "sessions",
    "frames": "sessions", "edits": "sessions", "undo": "sessions",
    "present": "sessions", "store": "sessions", "snapshot": "sessions",
    "journal": "sessions", "check": "sessions", "meshes": "sessions",
    "work": "work", "flow": "work", "views": "work", "job": "work",
    "encode": "work", "vstream": "work",
    "link": "shared",
}
# main.c is not in the library: it makes the layers and wires them.
NOT_LAYERED = {"main", "h264_module"}
MAX_LINES = 120


def symbols(lib):
    """{object: (defined, used)} from nm's archive listing."""
    out = subprocess.run(["nm", "-A", lib], check=True, capture_output=True,
                         text=True).stdout
    objs = {}
    for line in out.splitlines():
        m = re.match(r"^[^:]+:([^:]+)\.c\.o:\s*(?:[0-9a-f]+)?\s+(\w)\s+(\S+)$",
                     line)
        if not m:
            continue
        obj, kind, name = m.group(1), m.group(2), m.group(3)
        defined, used = objs.setdefault(obj, (set(), set()))
        if kind == "U":
            used.add(name)
        elif kind in "TDBR":
            defined.add(name)
    return objs


def check_calls(lib):
    objs = symbols(lib)
    owner = {}
    for obj, (defined, _) in objs.items():
        for name in defined:
            owner[name] = obj
    errors = []
    for obj in sorted(objs):
        if obj not in FILES:
            errors.append(f"{obj}.c is in no layer: give it one in "
                          f"{os.path.basename(__file__)}")
            continue
        mine = LAYERS[FILES[obj]]
        for name in sorted(objs[obj][1]):
            other = owner.get(name)
            if other is None or other == obj or other not in FILES:
                continue
            if LAYERS[FILES[other]] < mine:
                errors.append(f"{obj}.c ({FILES[obj]}) calls {name} of "
                              f"{other}.c ({FILES[other]}), a layer above "
                              f"it: report up by callback or queue instead")
    return errors, len(objs)


def check_lengths(src):
    errors = []
    count = 0
    for fname in sorted(os.listdir(src)):
        if not fname.endswith(".c"):
            continue
        stem = fname[:-2]
        if stem not in FILES and stem not in NOT_LAYERED:
            errors.append(f"{fname} is in no layer: give it one in "
                          f"{os.path.basename(__file__)}")
        with open(os.path.join(src, fname), encoding="utf-8") as f:
            lines = f.read().split("\n")
        start = None
        for i, line in enumerate(lines):
            if line == "{" and i > 0 and re.match(r"^[a-z_].*",
                                                  lines[i - 1].lstrip()):
                # The signature may take several lines: back to the one
                # at column 0 that starts it.
                start = i - 1
                while start > 0 and lines[start].startswith((" ", "\t")):
                    start -= 1
            elif line == "}" and start is not None:
                count += 1
                n = i - start + 1
                name = re.search(r"(\w+)\(", lines[start] + lines[start + 1])
                if n > MAX_LINES:
                    errors.append(f"{fname}:{start + 1}: "
                                  f"{name.group(1) if name else '?'} is "
                                  f"{n} lines, over {MAX_LINES}: split it")
                start = None
    return errors, count


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    errors, nobjs = check_calls(sys.argv[1])
    more, nfuncs = check_lengths(sys.argv[2])
    errors += more
    for e in errors:
        print("FAIL", e)
    if nobjs < len(FILES) or nfuncs < 100:
        print(f"FAIL only {nobjs} objects and {nfuncs} functions read: "
              f"is this the server library?")
        return 1
    print(f"{nobjs} objects, {nfuncs} functions: "
          f"{'no' if not errors else len(errors)} problems")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
