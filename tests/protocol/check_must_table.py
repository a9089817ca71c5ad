#!/usr/bin/env python3
"""Checks docs/protocol-tests.md against the test sources.

Every row of the table names its tests as `program: function`; each
program must be a test source tests/*/program.c that defines
`static void function(void)` and registers it in its test table, so that
the table cannot name a test that was renamed or removed. A row without a
test must say why, starting with "none:".

usage: check_must_table.py DOC TESTS_DIR
"""
import os
import re
import sys

TEST = re.compile(r"\b(test_\w+): (\w+)")


def sources(tests_dir):
    """Maps each test program name to its C source."""
    found = {}
    for root, _dirs, files in os.walk(tests_dir):
        for name in files:
            if name.startswith("test_") and name.endswith(".c"):
                found[name[:-2]] = os.path.join(root, name)
    return found


def main():
    if len(sys.argv) != 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    doc, tests_dir = sys.argv[1], sys.argv[2]
    progs = sources(tests_dir)
    texts = {}
    errors = []
    rows = 0
    with open(doc, encoding="utf-8") as f:
        lines = f.read().splitlines()
    for number, line in enumerate(lines, 1):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not line.startswith("|") or len(cells) < 3:
            continue
        if cells[0] in ("§", "") or set(cells[0]) <= set("-"):
            continue
        rows += 1
        last = cells[-1]
        pairs = TEST.findall(last)
        if not pairs and not last.startswith("none:"):
            errors.append(f"{doc}:{number}: no test and no reason")
        for prog, fn in pairs:
            path = progs.get(prog)
            if not path:
                errors.append(f"{doc}:{number}: no test program {prog}")
                continue
            if path not in texts:
                with open(path, encoding="utf-8") as src:
                    texts[path] = src.read()
            text = texts[path]
            defined = re.search(
                r"^static void " + re.escape(fn) + r"\(void\)", text,
                re.M)
            registered = re.search(
                r'\{\s*"[^"]+",\s*' + re.escape(fn) + r"\s*\}", text)
            if not defined or not registered:
                errors.append(
                    f"{doc}:{number}: {prog}: {fn} is not a test of "
                    f"{os.path.relpath(path, tests_dir)}")
    if rows == 0:
        errors.append(f"{doc}: no table rows found")
    for e in errors:
        print(e, file=sys.stderr)
    print(f"{rows} requirements, {len(errors)} problems")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
