#!/bin/sh
# The options of blobcastd and of the local blobcast commands, all parsed by
# base/args.c from one table per program: every option --help lists is one
# the parser takes, unknown options and bad numbers exit 2 with the same
# wording everywhere ("PROG: SENTENCE" and "(see 'PROG --help')"), and
# nothing starts or is written on a bad command line.
#
# usage: test_options.sh BLOBCAST BLOBCASTD [BLOBCAST_VIEW]
# (exit 77 when the first two are not built; the viewer is checked when
# given)
set -u
cli=${1:-}
daemon=${2:-}
viewer=${3:-}
if [ -z "$cli" ] || [ ! -x "$cli" ] || [ -z "$daemon" ] ||
  [ ! -x "$daemon" ]; then
  echo "skip: blobcast or blobcastd not built"
  exit 77
fi
# The commands run from a scratch folder: make the paths absolute.
case $cli in /*) ;; *) cli=$PWD/$cli ;; esac
case $daemon in /*) ;; *) daemon=$PWD/$daemon ;; esac
case $viewer in /* | '') ;; *) viewer=$PWD/$viewer ;; esac
tmp=$(mktemp -d /tmp/bc-options.XXXXXX) || exit 1
cfgs=$(mktemp -d /tmp/bc-options-cfg.XXXXXX) || exit 1
trap 'rm -rf "$tmp" "$cfgs"' EXIT
trap 'exit 1' INT TERM
failures=0

fail() {
  echo "FAIL: $*"
  sed 's/^/    /' "$tmp/out"
  failures=$((failures + 1))
}

# expect STATUS TEXT PROG ARGS...: runs PROG ARGS (from the scratch folder,
# so that nothing it might write lands elsewhere) and checks the exit status
# and that the output holds TEXT (fixed string).
expect() {
  want=$1 text=$2
  shift 2
  (cd "$tmp" && "$@") > "$tmp/out" 2>&1
  got=$?
  if [ "$got" -ne "$want" ]; then
    fail "$*: exit $got, wanted $want"
  elif ! grep -qF -- "$text" "$tmp/out"; then
    fail "$*: output lacks \"$text\""
  else
    echo "ok   $*"
  fi
}

# Every option named in PROG's help is known to its parser: given with a
# value and followed by an unknown option, the parser gets past it and
# stops at the unknown one (or at the value) -- never at the option itself.
# $1 is the program as the messages name it, the rest its command line.
help_options_are_parsed() {
  name=$1
  shift
  "$@" --help > "$tmp/help" 2>&1 || {
    cp "$tmp/help" "$tmp/out"
    fail "$* --help exits non-zero"
    return
  }
  opts=$(sed -n 's/^  \(-[a-zA-Z0-9], \)\{0,1\}\(--[a-z0-9-]*\).*/\2/p' \
    "$tmp/help")
  [ -n "$opts" ] || {
    cp "$tmp/help" "$tmp/out"
    fail "$* --help lists no options"
    return
  }
  n=0
  for opt in $opts; do
    [ "$opt" = "--help" ] && continue
    n=$((n + 1))
    (cd "$tmp" && "$@" "$opt" 1 --no-such-option) > "$tmp/out" 2>&1
    got=$?
    if grep -qF -- "unknown option '$opt'" "$tmp/out" ||
      grep -qF -- "$opt does not apply" "$tmp/out"; then
      fail "$name: --help lists $opt but the parser refuses it"
    elif [ "$got" -ne 2 ]; then
      fail "$name $opt 1 --no-such-option: exit $got, wanted 2"
    fi
  done
  echo "ok   $name: the $n options --help lists are all parsed"
}

help_options_are_parsed blobcastd "$daemon"
for cmd in render mesh gen eval-bench; do
  help_options_are_parsed "blobcast $cmd" "$cli" "$cmd"
done
# The client commands share one table; each --help lists only the part
# its command takes (the rest is refused as not applying).
for cmd in load edit camera present follow snapshot watch bench-latency \
  nodes scene delete sessions undo redo add remove move wrap duplicate rename \
  history; do
  help_options_are_parsed "blobcast $cmd" "$cli" "$cmd"
done
expect 2 "blobcast watch: --edits does not apply to watch" \
  "$cli" watch --session s --edits 3
expect 2 "(see 'blobcast watch --help')" "$cli" watch --session s --bogus

# blobcast-view parses its options before it opens a window, so this
# needs no display.
if [ -n "$viewer" ]; then
  help_options_are_parsed blobcast-view "$viewer"
  expect 2 "blobcast-view: unknown option '--bogus'" "$viewer" --bogus
  expect 2 "blobcast-view: --quality '101' is out of range (1..100)" \
    "$viewer" --quality 101
  expect 2 "blobcast-view: --turn 'x' is not a finite decimal number" \
    "$viewer" --turn x
  expect 2 "blobcast-view: --role 'owner' is not one of auto, editor, viewer" \
    "$viewer" --role owner
  expect 2 "blobcast-view: --dump-frame needs --screenshot" \
    "$viewer" --dump-frame f.png
fi

# The same mistakes get the same sentences in every program.
expect 2 "blobcastd: unknown option '--bogus'" "$daemon" --bogus
expect 2 "(see 'blobcastd --help')" "$daemon" --bogus=1
expect 2 "blobcastd: --frame-budget 'x' is not a whole decimal number" \
  "$daemon" --frame-budget x
expect 2 "blobcastd: --frame-budget '0' is out of range (1..600000)" \
  "$daemon" --frame-budget=0
expect 2 "blobcastd: --frame-budget needs a value (MS)" \
  "$daemon" --frame-budget
expect 2 "blobcastd: --backend 'cuda' is not one of auto, cpu, tiled" \
  "$daemon" --backend cuda
expect 2 "blobcastd: --no-damage takes no value" "$daemon" --no-damage=1
expect 2 "blobcastd: --no-pace takes no value" "$daemon" --no-pace=1
expect 2 "blobcastd: unexpected argument 'serve'" "$daemon" serve
# The configuration file takes the options by name ('_' for '-') under
# the same rules, and says which key is wrong; nothing starts.
config() {
  printf '%s\n' "$2" > "$cfgs/$1.json"
  echo "$cfgs/$1.json"
}
expect 1 "view_cache: expected a whole number in 16..1048576 (as --view-cache)" \
  "$daemon" --config "$(config range '{"view_cache": 8}')"
expect 1 "render_idle: expected a whole number in 1..86400" \
  "$daemon" --config "$(config text '{"render_idle": "5"}')"
expect 1 "no_damage: expected true or false" \
  "$daemon" --config "$(config flag '{"no_damage": 1}')"
expect 1 "simd: expected one of auto, off" \
  "$daemon" --config "$(config choice '{"simd": "sse"}')"
expect 1 "unknown key frame-budget (keys write an option's '-' as '_')" \
  "$daemon" --config "$(config dash '{"frame-budget": 5}')"
expect 1 "unknown key check" \
  "$daemon" --config "$(config check '{"check": "d"}')"
expect 1 "unknown key repair" \
  "$daemon" --config "$(config repair '{"repair": true}')"
expect 2 "blobcast render: unknown option '--bogus'" \
  "$cli" render default --bogus
expect 2 "(see 'blobcast render --help')" "$cli" render default --bogus
expect 2 "blobcast render: --threads '-2' is not a whole decimal number" \
  "$cli" render default --size 8x8 --out o.png --threads -2
expect 2 "blobcast render: --threads '1025' is out of range (0..1024)" \
  "$cli" render default --size 8x8 --out o.png --threads=1025
expect 2 "blobcast mesh: unknown option '--bogus'" "$cli" mesh default --bogus
expect 2 "blobcast mesh: --resolution '1' is out of range (2..4096)" \
  "$cli" mesh default --out m.obj --resolution 1
expect 2 "blobcast gen: unknown option '--bogus'" "$cli" gen comb --bogus
expect 2 "blobcast gen: --count '1e3' is not a whole decimal number" \
  "$cli" gen comb --count 1e3
expect 2 "blobcast eval-bench: unknown option '--bogus'" \
  "$cli" eval-bench default --bogus
expect 2 "blobcast eval-bench: --points '0' is out of range" \
  "$cli" eval-bench default --points 0
expect 2 "blobcast: unknown option '--bogus'" "$cli" --bogus
# '--' ends the options: what follows is a scene name, not an option.
expect 1 "--size" "$cli" render --size 8x8 --out o.png -- --size
[ -e "$tmp/o.png" ] && fail "a refused command line wrote o.png"
left=
for f in "$tmp"/* "$tmp"/.[!.]*; do
  [ -e "$f" ] || continue
  case ${f##*/} in out | help) ;; *) left="$left ${f##*/}" ;; esac
done
[ -z "$left" ] || fail "a refused command line left files:$left"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
