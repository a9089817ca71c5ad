#!/bin/sh
# libblobcast.so exports its API and nothing else: the functions its
# installed headers declare (as a user's compiler sees them) are exactly the
# functions `nm -D --defined-only` lists, so an internal helper that leaks
# out, or a declared function the library hides, fails here. Every
# declaration in the installed headers must carry BC_API.
#
# usage: test_client_exports.sh BUILD_DIR CC
# Exits 77 when libblobcast.so has not been built or nm is missing.
set -u
build=$1 cc=$2
so=$build/client/lib/libblobcast.so
if [ ! -f "$so" ]; then
  echo "skip: $so is not built"
  exit 77
fi
if ! command -v nm > /dev/null 2>&1; then
  echo "skip: no nm"
  exit 77
fi
tmp=$(mktemp -d /tmp/bc-client-exports.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' INT TERM

fail() {
  echo "FAIL: $*"
  exit 1
}

cmake --install "$build" --component client --prefix "$tmp/prefix" \
  > "$tmp/install.log" 2>&1 || fail "install: $(cat "$tmp/install.log")"
inc=$(find "$tmp/prefix" -type d -name blobcast -path '*/include/*' | head -n 1)
[ -n "$inc" ] || fail "no include/blobcast installed"
: > "$tmp/tu.c"
for h in "$inc"/*.h; do
  echo "#include <blobcast/${h##*/}>" >> "$tmp/tu.c"
done
# BC_API is defined to a marker so that the declarations show it.
"$cc" -std=c11 -E -DBC_API=BC_API_MARK -I"${inc%/blobcast}" "$tmp/tu.c" \
  > "$tmp/tu.i" 2> "$tmp/cc.log" || fail "preprocess: $(cat "$tmp/cc.log")"

# Statements at brace depth 0 that end in ';', do not start with typedef or
# static, and name bc_something( are function declarations. Prints
# "name header marked|unmarked".
awk '
/^# [0-9]+ "/ { file = $3; gsub(/"/, "", file); next }
{
  line = $0
  for (i = 1; i <= length(line); i++) {
    c = substr(line, i, 1)
    if (c == "{") { depth++; stmt = ""; continue }
    if (c == "}") { depth--; stmt = ""; continue }
    if (depth > 0) continue
    if (c == ";") {
      s = stmt; stmt = ""
      sub(/^[ \t]+/, "", s)
      if (s ~ /^(typedef|static)[ \t]/) continue
      if (match(s, /bc_[A-Za-z0-9_]*[ \t]*\(/)) {
        name = substr(s, RSTART, RLENGTH)
        sub(/[ \t]*\($/, "", name)
        n = split(file, parts, "/")
        print name, parts[n], (s ~ /BC_API_MARK/ ? "marked" : "unmarked")
      }
      continue
    }
    stmt = stmt c
  }
  stmt = stmt " "
}' "$tmp/tu.i" | sort -u > "$tmp/decls"
[ -s "$tmp/decls" ] || fail "no declarations found in the installed headers"

awk '$3 == "unmarked"' "$tmp/decls" > "$tmp/unmarked"
[ -s "$tmp/unmarked" ] &&
  fail "declared without BC_API: $(tr '\n' ' ' < "$tmp/unmarked")"

awk '{ print $1 }' "$tmp/decls" | sort -u > "$tmp/declared"
nm -D --defined-only "$so" | awk '$2 ~ /^[TWDBRVui]$/ { print $3 }' |
  sed 's/@.*//' | sort -u > "$tmp/exported"
[ -s "$tmp/exported" ] || fail "nm lists nothing in $so"
comm -13 "$tmp/declared" "$tmp/exported" > "$tmp/stray"
comm -23 "$tmp/declared" "$tmp/exported" > "$tmp/missing"
[ -s "$tmp/stray" ] &&
  fail "exported but declared in no installed header: $(tr '\n' ' ' < "$tmp/stray")"
[ -s "$tmp/missing" ] &&
  fail "declared but not exported: $(tr '\n' ' ' < "$tmp/missing")"
echo "ok   $(wc -l < "$tmp/exported") exported symbols, each declared in an installed header"
exit 0
