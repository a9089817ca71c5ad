#!/bin/sh
# Checks that every tracked C source and header is formatted as
# .clang-format says (STYLE.md 5). Prints the offending places and exits 1
# when one is not; exits 77 when clang-format is not installed. There are
# no generated or vendored C files in the tree (generated headers live in
# build folders), so nothing is skipped.
#
# usage: sh tests/check_format.sh   (from anywhere inside the checkout)
set -u
cd "$(git rev-parse --show-toplevel)" || exit 1
if ! command -v clang-format > /dev/null 2>&1; then
  echo "skip: clang-format is not installed"
  exit 77
fi
files=$(git ls-files '*.c' '*.h')
# shellcheck disable=SC2086 # file names in the tree have no spaces
if clang-format --style=file --dry-run --Werror $files; then
  echo "ok   $(echo "$files" | wc -l) files formatted as .clang-format says"
  exit 0
fi
echo "FAIL: the files above differ from .clang-format; 'clang-format -i FILE' fixes one"
exit 1
