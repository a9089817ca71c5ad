#!/usr/bin/env python3
"""Checks that formatting changed nothing a compiler sees: for every C/H
file, a revision's text (default HEAD) and the working tree's reduce to the
same token text once line continuations, whitespace outside literals and
comments are removed and adjacent string literals are joined (clang-format
only moves whitespace, rewraps comments and may split a long literal in
two). Run from the top of the checkout after `clang-format -i`, before
committing; exits 1 and names the files that differ otherwise.

usage: python3 tests/format_equiv.py [REV]"""
import re, subprocess, sys
TOK = re.compile(r'''
  (?P<str>"(?:\\.|[^"\\\n])*")
 |(?P<chr>'(?:\\.|[^'\\\n])*')
 |(?P<com>/\*.*?\*/|//[^\n]*)
 |(?P<ws>\s+)
 |(?P<other>.)''', re.S | re.X)
def reduce(text):
    text = text.replace('\\\n', '')
    out, pending = [], None
    for m in TOK.finditer(text):
        k = m.lastgroup
        if k in ('com', 'ws'):
            continue
        if k == 'str':
            pending = (pending or '') + m.group()[1:-1]
            continue
        if pending is not None:
            out.append('"' + pending + '"')
            pending = None
        out.append(m.group())
    if pending is not None:
        out.append('"' + pending + '"')
    return ''.join(out)
rev = sys.argv[1] if len(sys.argv) > 1 else 'HEAD'
files = subprocess.run(['git', 'ls-files', '*.c', '*.h'], capture_output=True,
                       text=True, check=True).stdout.split()
changed = bad = 0
for f in files:
    old = subprocess.run(['git', 'show', rev + ':' + f], capture_output=True,
                         text=True, check=True).stdout
    new = open(f).read()
    if old != new:
        changed += 1
        if reduce(old) != reduce(new):
            bad += 1
            print('differs beyond whitespace:', f)
print(f'{len(files)} files, {changed} reformatted, {bad} with other changes')
sys.exit(1 if bad else 0)
