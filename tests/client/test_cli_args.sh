#!/bin/sh
# The client subcommands of the blobcast CLI without a server: every
# --help exits 0 and says what the command takes, bad or inapplicable
# arguments exit 2 with a message before anything is sent, and a server
# that cannot be reached exits 1.
#
# usage: test_cli_args.sh BLOBCAST   (exit 77 when BLOBCAST is not built)
set -u
BLOBCAST=${1:-}
if [ -z "$BLOBCAST" ] || [ ! -x "$BLOBCAST" ]; then
  echo "skip: the blobcast CLI is not built"
  exit 77
fi

tmp=$(mktemp -d /tmp/bc-cli-args.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT INT TERM
failures=0

# expect STATUS PATTERN ARGS...: runs blobcast ARGS, checks the exit status
# and that stdout+stderr contain PATTERN (a fixed string; "" for any).
expect() {
  want=$1 pattern=$2
  shift 2
  "$BLOBCAST" "$@" > "$tmp/out" 2>&1
  got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL: blobcast $*: exit $got, wanted $want"
    sed 's/^/    /' "$tmp/out"
    failures=$((failures + 1))
  elif [ -n "$pattern" ] && ! grep -qF -- "$pattern" "$tmp/out"; then
    echo "FAIL: blobcast $*: output lacks \"$pattern\""
    sed 's/^/    /' "$tmp/out"
    failures=$((failures + 1))
  else
    echo "ok   blobcast $*"
  fi
}

for cmd in load edit camera snapshot watch bench-latency; do
  expect 0 "usage: blobcast $cmd" "$cmd" --help
done
expect 0 "--server ADDR" load --help
expect 0 "+inf where nothing is hit" snapshot --help
expect 0 "latency_ms" watch --help

# Missing or malformed arguments.
expect 2 "--session NAME is required" load scene.json
expect 2 "usage: blobcast load" load --session s
expect 2 "unexpected argument" load --session s a.json b.json
expect 2 "usage: blobcast edit" edit --session s 5
expect 2 "not a node id" edit --session s 0 radius=1
expect 2 "not a node id" edit --session s x radius=1
expect 2 "--eye and --target are required" camera --session s --eye 1,2,3
expect 2 "needs a valid value" camera --session s --eye 1,2 --target 0,0,0
expect 2 "needs a valid value" camera --session s --eye 1,2,3,4 \
  --target 0,0,0
expect 2 "needs a valid value" camera --session s --eye 1,2,3 \
  --target 0,0,0 --fov 180
expect 2 "needs a valid value" camera --session s --eye nan,0,0 \
  --target 0,0,0
expect 2 "--size and --out are required" snapshot --session s --out a.png
expect 2 "needs a valid value" snapshot --session s --size 0x10 --out a.png
expect 2 "needs a valid value" snapshot --session s --size 10x99999 \
  --out a.png
expect 2 "needs a valid value" snapshot --session s --size 10 --out a.png
expect 2 "no image format" snapshot --session s --size 8x8 \
  --out "$tmp/a.nosuchformat"
expect 2 "depth needs a float format" snapshot --session s \
  --size 8x8 --out "$tmp/a.png" --depth "$tmp/d.png"
expect 2 "ids need a uint32 format" snapshot --session s \
  --size 8x8 --out "$tmp/a.png" --ids "$tmp/i.png"
expect 2 "needs a valid value" watch --session s --frames 0
expect 2 "needs a valid value" watch --session s --encoding gif
expect 2 "needs a valid value" watch --session s --downscale 9
expect 2 "--edits N is required" bench-latency --session s
expect 2 "needs a valid value" bench-latency --session s --edits 0
expect 2 "needs a valid value" bench-latency --session s --edits 10 --node 0
expect 2 "needs a valid value" load --session "" a.json
expect 2 "needs a valid value" load --session s --timeout -5 a.json
expect 2 "needs a valid value" load --session
# Numbers follow the shared rules (base/num.h): decimal, the whole
# string, no sign on counts, finite floats.
expect 2 "needs a valid value" watch --session s --frames +5
expect 2 "needs a valid value" watch --session s --frames 1e3
expect 2 "needs a valid value" watch --session s --frames " 5"
expect 2 "needs a valid value" snapshot --session s --size 0x10 --out a.png
expect 2 "needs a valid value" snapshot --session s --size 8x8x8 --out a.png
expect 2 "needs a valid value" camera --session s --eye 1,2,inf \
  --target 0,0,0
expect 2 "needs a valid value" camera --session s --eye 0x1p3,0,0 \
  --target 0,0,0
expect 2 "needs a valid value" camera --session s --eye 1,2,3 \
  --target 0,0,0 --fov 0
# Options of other commands are refused, not ignored.
expect 2 "does not apply" load --session s --eye 1,2,3 a.json
expect 2 "does not apply" edit --session s --size 8x8 1 radius=1
expect 2 "does not apply" watch --session s --edits 3
expect 2 "unknown option" watch --session s --bogus
# Bad server addresses are usage errors; unreachable servers are not.
expect 2 "port must be a number" edit --server host:0 --session s 1 radius=1
expect 2 "IPv6" edit --server ::1 --session s 1 radius=1
expect 1 "cannot connect" edit --server 127.0.0.1:1 --session s 1 radius=1
printf '{"blobcast": 1, "root": {"type": "sphere", "radius": 1}}' \
  > "$tmp/s.json"
expect 1 "cannot connect" load --server "unix:$tmp/none.sock" --session s \
  "$tmp/s.json"
# main passes a global --server after the command word.
expect 1 "cannot connect" --server 127.0.0.1:1 watch --session s --frames 1

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
