#!/bin/sh
# The client subcommands of the blobcast CLI without a server: every
# --help exits 0 and says what the command takes, bad or inapplicable
# arguments exit 2 with a message before anything is sent (a mistyped
# command, option or kind with git's "did you mean"), the global options
# work before and after the command word alike, and a server that cannot
# be reached exits 3.
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

for cmd in load edit camera present follow snapshot watch bench-latency \
  nodes scene delete sessions undo redo; do
  expect 0 "usage: blobcast $cmd" "$cmd" --help
done
expect 0 "usage: blobcast load" load -h
expect 0 "--server ADDR" load --help
expect 0 "  --out FILE" scene --help
expect 0 "  --out IMG" follow --help
expect 0 "  --for SECONDS" present --help

# each command's help lists only the options it takes (the table is
# shared; the others are hidden).
# lacks CMD OPTION: blobcast CMD --help does not mention OPTION.
lacks() {
  if "$BLOBCAST" "$1" --help | grep -qF -- "$2"; then
    echo "FAIL: blobcast $1 --help lists $2"
    failures=$((failures + 1))
  else
    echo "ok   blobcast $1 --help leaves out $2"
  fi
}
lacks load --eye
lacks load --size
lacks sessions --session
lacks watch --edits
lacks scene --depth
lacks camera --frames
expect 0 "+inf where nothing is hit" snapshot --help
expect 0 "latency_ms" watch --help

# Missing or malformed arguments.
expect 2 "--session NAME is required" load scene.json
expect 2 "blobcast load: missing arguments (usage: blobcast load" \
  load --session s
expect 2 "blobcast load: unexpected argument 'b.json'" \
  load --session s a.json b.json
# A parent given as a second id: the usage says where it goes.
expect 2 "unexpected argument '1' (usage: blobcast move --session NAME ID --parent ID" \
  move --session s 7 1
expect 2 "blobcast edit: missing arguments" edit --session s 5
expect 2 "not a node id" edit --session s 0 radius=1
expect 2 "not a node id" edit --session s x radius=1
expect 2 "--eye and --target are required" camera --session s --eye 1,2,3
expect 2 "blobcast camera: --eye '1,2' is not x,y,z" \
  camera --session s --eye 1,2 --target 0,0,0
expect 2 "(see 'blobcast camera --help')" \
  camera --session s --eye 1,2 --target 0,0,0
expect 2 "--eye '1,2,3,4' is not x,y,z" camera --session s --eye 1,2,3,4 \
  --target 0,0,0
expect 2 "--fov '180' is out of range" camera --session s --eye 1,2,3 \
  --target 0,0,0 --fov 180
expect 2 "--eye 'nan,0,0' is not x,y,z" camera --session s --eye nan,0,0 \
  --target 0,0,0
expect 2 "blobcast camera: --eye is out of range" camera --session s \
  --eye 1e30,0,0 --target 0,0,0
expect 2 "--size and --out are required" snapshot --session s --out a.png
expect 2 "--size '0x10' is out of range (width and height 1..8192)" \
  snapshot --session s --size 0x10 --out a.png
expect 2 "--size '10x99999' is out of range" snapshot --session s \
  --size 10x99999 --out a.png
expect 2 "--size '10' is not WxH" snapshot --session s --size 10 --out a.png
expect 2 "no image format" snapshot --session s --size 8x8 \
  --out "$tmp/a.nosuchformat"
expect 2 "depth needs a float format" snapshot --session s \
  --size 8x8 --out "$tmp/a.png" --depth "$tmp/d.png"
expect 2 "ids need a uint32 format" snapshot --session s \
  --size 8x8 --out "$tmp/a.png" --ids "$tmp/i.png"
expect 2 "blobcast watch: --frames '0' is out of range" \
  watch --session s --frames 0
expect 2 "--encoding 'gif' is not one of jpeg, png, raw" \
  watch --session s --encoding gif
expect 2 "--downscale '9' is out of range (1..8)" \
  watch --session s --downscale 9
expect 2 "--edits N is required" bench-latency --session s
expect 2 "--edits '0' is out of range (1..1000000)" \
  bench-latency --session s --edits 0
expect 2 "--node '0' is out of range" \
  bench-latency --session s --edits 10 --node 0
expect 2 "--session needs a non-empty value" load --session "" a.json
expect 2 "--timeout '-5' is not a whole decimal number" \
  load --session s --timeout -5 a.json
expect 2 "--session needs a value (NAME)" load --session
expect 2 "--name is longer than 64 bytes" load --session s \
  --name 01234567890123456789012345678901234567890123456789012345678901234 a
# Numbers follow the shared rules (base/num.h): decimal, the whole
# string, no sign on counts, finite floats.
expect 2 "--frames '+5' is not a whole decimal number" \
  watch --session s --frames +5
expect 2 "--frames '1e3' is not a whole decimal number" \
  watch --session s --frames 1e3
expect 2 "--frames ' 5' is not a whole decimal number" \
  watch --session s --frames " 5"
expect 2 "--size '8x8x8' is not WxH" snapshot --session s --size 8x8x8 \
  --out a.png
expect 2 "--eye '1,2,inf' is not x,y,z" camera --session s --eye 1,2,inf \
  --target 0,0,0
expect 2 "--eye '0x1p3,0,0' is not x,y,z" camera --session s \
  --eye 0x1p3,0,0 --target 0,0,0
expect 2 "--fov '0' is out of range" camera --session s --eye 1,2,3 \
  --target 0,0,0 --fov 0
# Options of other commands are refused, not ignored.
expect 2 "blobcast load: --eye does not apply to load" \
  load --session s --eye 1,2,3 a.json
expect 2 "--size does not apply to edit" edit --session s --size 8x8 1 \
  radius=1
expect 2 "--edits does not apply to watch" watch --session s --edits 3
expect 2 "--session does not apply to sessions" sessions --session s
expect 2 "blobcast watch: unknown option '--bogus'" watch --session s --bogus
expect 2 "--json takes no value" nodes --session s --json=1
# Bad server addresses are usage errors; unreachable servers are network
# failures (status 3), with the reason and what to check.
expect 2 "port must be a number" edit --server host:0 --session s 1 radius=1
expect 2 "IPv6" edit --server ::1 --session s 1 radius=1
expect 2 "http:// is not a blobcastd address" \
  sessions --server http://127.0.0.1:8080
expect 3 "cannot connect" edit --server 127.0.0.1:1 --session s 1 radius=1
expect 3 "connection refused: nothing listens on port 1" \
  sessions --server 127.0.0.1:1
printf '{"blobcast": 1, "root": {"type": "sphere", "radius": 1}}' \
  > "$tmp/s.json"
expect 3 "cannot connect" load --server "unix:$tmp/none.sock" --session s \
  "$tmp/s.json"
expect 3 "no such socket" load --server "unix:$tmp/none.sock" --session s \
  "$tmp/s.json"
# main passes a global --server after the command word.
expect 3 "cannot connect" --server 127.0.0.1:1 watch --session s --frames 1

# Did you mean: a command, an option (the command's or a global one), a
# primitive kind and a key of a scene file (read before connecting).
expect 2 "blobcast: unknown command 'edti' (did you mean 'edit'?)" edti
expect 2 "unknown command 'sesions' (did you mean 'sessions'?)" sesions
expect 2 "unknown command 'edti' (did you mean 'edit'?)" help edti
expect 2 "unknown command 'frobnicate'" frobnicate
expect 2 "blobcast watch: unknown option '--sever' (did you mean '--server'?)" \
  watch --session s --sever 127.0.0.1:1
expect 2 "unknown option '--sesion' (did you mean '--session'?)" \
  load --sesion s a.json
expect 2 "unknown option '--tiemout' (did you mean '--timeout'?)" \
  sessions --tiemout 5
expect 2 "blobcast: unknown option '--sever' (did you mean '--server'?)" \
  --sever 127.0.0.1:1 sessions
expect 2 "unknown option '--sizee' (did you mean '--size'?)" \
  render default --sizee 8x8
printf '{"blobcast": 1, "root": {"type": "spere", "radius": 1}}' \
  > "$tmp/kind.json"
expect 2 "unknown primitive type \"spere\" (did you mean 'sphere'?)" \
  load --server 127.0.0.1:1 --session s "$tmp/kind.json"
expect 2 "primitive kinds: sphere, box," \
  load --server 127.0.0.1:1 --session s "$tmp/kind.json"
expect 2 "operator kinds: union, intersection," \
  load --server 127.0.0.1:1 --session s "$tmp/kind.json"
printf '{"blobcast": 1, "root": {"type": "sphere", "raduis": 1}}' \
  > "$tmp/key.json"
expect 2 "unknown key \"raduis\" for sphere (did you mean 'radius'?)" \
  load --server 127.0.0.1:1 --session s "$tmp/key.json"
expect 1 "(did you mean 'radius'?)" render "$tmp/key.json" --size 8x8 \
  --out "$tmp/k.png"

# Every global option may stand before the command or after it: the same
# status and the same words either way.
# same ARGS_BEFORE -- ARGS_AFTER: both command lines give one result.
same() {
  before=
  while [ "$1" != "--" ]; do
    before="$before $1"
    shift
  done
  shift
  # shellcheck disable=SC2086
  "$BLOBCAST" $before > "$tmp/before" 2>&1
  s1=$?
  "$BLOBCAST" "$@" > "$tmp/after" 2>&1
  s2=$?
  if [ "$s1" -ne "$s2" ] || ! cmp -s "$tmp/before" "$tmp/after"; then
    echo "FAIL: blobcast$before (exit $s1) differs from blobcast $* (exit $s2)"
    sed 's/^/    before: /' "$tmp/before"
    sed 's/^/    after:  /' "$tmp/after"
    failures=$((failures + 1))
  else
    echo "ok   blobcast$before = blobcast $* (exit $s1)"
  fi
}
same --timeout 50 sessions --server 127.0.0.1:1 -- \
  sessions --timeout 50 --server 127.0.0.1:1
same --token t --name n --timeout 50 --server 127.0.0.1:1 nodes --session s \
  -- nodes --session s --token t --name n --timeout 50 --server 127.0.0.1:1
same --ca "$tmp/none.pem" --server tls://127.0.0.1:1 sessions -- \
  sessions --ca "$tmp/none.pem" --server tls://127.0.0.1:1
same --insecure --server tls://127.0.0.1:1 sessions -- \
  sessions --insecure --server tls://127.0.0.1:1
same --timeout -5 load --session s a.json -- \
  load --session s --timeout -5 a.json
same --name 01234567890123456789012345678901234567890123456789012345678901234 \
  watch --session s -- watch --session s \
  --name 01234567890123456789012345678901234567890123456789012345678901234
same --server host:0 edit --session s 1 radius=1 -- \
  edit --server host:0 --session s 1 radius=1
# --session too: every server command that takes a session takes it
# before the command word; one that takes none says so either way.
same --session s --timeout 50 --server 127.0.0.1:1 nodes -- \
  nodes --session s --timeout 50 --server 127.0.0.1:1
same --session s sessions --server 127.0.0.1:1 -- \
  sessions --session s --server 127.0.0.1:1
expect 2 "--session does not apply to sessions" --session s sessions
expect 2 "--session applies to the server commands only, not 'gen'" \
  --session s gen fig18
expect 2 "--session is longer than 64 bytes" \
  --session 01234567890123456789012345678901234567890123456789012345678901234 \
  nodes --server 127.0.0.1:1
expect 2 "--timeout '-5' is not a whole decimal number" \
  --timeout -5 load --session s a.json
expect 2 "--token applies to the server commands only, not 'render'" \
  --token t render default
# After the command, the later of two wins (the global one comes first).
expect 3 "port 1 " --server 127.0.0.1:2 sessions --server 127.0.0.1:1

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
