#!/bin/sh
# README.md "Using it", run as written: the ```sh block under that heading
# is read from the README itself (so the two cannot drift apart) and each
# command is run in order in an empty directory, with three changes that
# keep it private and bounded:
#  - `build/` is the build directory under test, and the daemon listens on
#    a free loopback port instead of 7878 (BLOBCAST_SERVER points the CLI
#    and the viewer at it; 127.0.0.1:7878 in a command becomes that port);
#  - the viewer runs under Xvfb and is asked to save its window after the
#    first finished picture and exit (--screenshot view.png --frames 1);
#  - web-demo.sh gets a free --port and runs until the page and websockify
#    answer, then is stopped.
# Every command must exit 0; then the files the README promises are
# checked: review.png (1024x768), review.json (loads back into another
# session), review.glb (what `blobcast mesh` makes here of review.json),
# s.png/s.exr/s.tif, the viewer's screenshot, watch's frame line.
#
# usage: using_it.sh BUILD_DIR SOURCE_DIR
# Exits 77 (skipped) naming what is missing: a program the README runs that
# was not built, xvfb-run, websockify, python3 or curl.
set -u
BUILD=${1:?usage: using_it.sh BUILD_DIR SOURCE_DIR}
SRC=${2:?usage: using_it.sh BUILD_DIR SOURCE_DIR}
BUILD=$(cd "$BUILD" && pwd)
SRC=$(cd "$SRC" && pwd)

for p in "$BUILD/server/blobcastd" "$BUILD/client/blobcast" \
  "$BUILD/client/viewer/blobcast-view"; do
  if [ ! -x "$p" ]; then
    echo "skip: $p is not built"
    exit 77
  fi
done
for tool in xvfb-run websockify python3 curl; do
  if ! command -v "$tool" > /dev/null 2>&1; then
    echo "skip: $tool not found"
    exit 77
  fi
done

tmp=$(mktemp -d /tmp/bc-readme.XXXXXX) || exit 1
daemon=
demo=
cleanup() {
  [ -n "$demo" ] && kill -TERM "$demo" 2> /dev/null && wait "$demo" 2> /dev/null
  if [ -n "$daemon" ]; then
    kill -TERM "$daemon" 2> /dev/null
    wait "$daemon" 2> /dev/null
  fi
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

free_port() {
  python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
# web-demo.sh takes --port P and P + 1 (its websockify): a port whose
# next one is free too, both bound while looking, in 12000..19999: below
# the range the kernel hands out for other tests' connections (one once
# took P + 1) and test_cluster's ports (20000 and up).
free_pair() {
  python3 - <<'PY'
import random, socket
for _ in range(200):
    p = random.randrange(12000, 19999)
    held = []
    try:
        for q in (p, p + 1):
            s = socket.socket()
            s.bind(("127.0.0.1", q))
            held.append(s)
    except OSError:
        continue
    finally:
        for s in held:
            s.close()
    if len(held) == 2:
        print(p)
        break
PY
}
port=$(free_port)
web_port=$(free_pair)
export BLOBCAST_SERVER="127.0.0.1:$port"

# The block: lines between "## Using it", its ```sh and the closing ```.
awk '/^## Using it/ { s = 1; next } s == 1 && /^```sh/ { s = 2; next }
     s == 2 && /^```/ { exit } s == 2 { print }' "$SRC/README.md" \
  > "$tmp/block"
if [ "$(grep -c . "$tmp/block")" -lt 5 ]; then
  fail "no \"Using it\" block in README.md"
  exit 1
fi

# As in test_viewer.sh: under AddressSanitizer keep Mesa's driver loaded so
# that its allocations are not reported as leaks of an unloaded module.
VIEWENV=
if ldd "$BUILD/client/viewer/blobcast-view" 2> /dev/null | grep -q libasan; then
  for d in /usr/lib/x86_64-linux-gnu/dri /usr/lib/*/dri /usr/lib/dri; do
    if [ -f "$d/swrast_dri.so" ]; then
      VIEWENV="env ASAN_OPTIONS=verify_asan_link_order=0 LD_PRELOAD=$d/swrast_dri.so"
      break
    fi
  done
fi

cd "$tmp" || exit 1
n=0
while IFS= read -r line; do
  # The comment at the end of a line is the README's, not the command's.
  cmd=$(printf '%s\n' "$line" | sed 's/[[:space:]][[:space:]]*#.*$//')
  [ -z "$(printf '%s' "$cmd" | tr -d '[:space:]')" ] && continue
  n=$((n + 1))
  cmd=$(printf '%s\n' "$cmd" | sed -e "s#^build/#$BUILD/#" \
    -e "s#^bash deploy/#bash $SRC/deploy/#" \
    -e "s#127\.0\.0\.1:7878#127.0.0.1:$port#g")
  t0=$(date +%s.%N)
  case "$cmd" in
  *"/server/blobcastd"*"&")
    cmd=${cmd%&}
    echo "run  $cmd--listen 127.0.0.1:$port &"
    $cmd --listen "127.0.0.1:$port" > daemon.log 2>&1 &
    daemon=$!
    i=0
    while [ $i -lt 150 ] && ! grep -q 'listening on' daemon.log; do
      kill -0 "$daemon" 2> /dev/null || break
      sleep 0.1
      i=$((i + 1))
    done
    grep -q 'listening on' daemon.log || {
      fail "blobcastd did not start: $(cat daemon.log)"
      exit 1
    }
    ;;
  *"/blobcast-view"*)
    echo "run  xvfb-run -a $cmd --screenshot view.png --frames 1"
    # shellcheck disable=SC2086
    timeout 60 xvfb-run -a $VIEWENV $cmd --screenshot view.png --frames 1 \
      > view.log 2>&1 || fail "the viewer: exit $? ($(tail -n 3 view.log))"
    ;;
  *"deploy/web-demo.sh"*)
    echo "run  $cmd --port $web_port"
    $cmd --port "$web_port" > demo.log 2>&1 &
    demo=$!
    i=0
    # web-demo.sh prints its address once its servers listen (it waits up
    # to a minute for them on a busy machine).
    while [ $i -lt 700 ] && ! grep -q '^blobcast web demo: http' demo.log; do
      kill -0 "$demo" 2> /dev/null || break
      sleep 0.1
      i=$((i + 1))
    done
    if ! grep -q "^blobcast web demo: http://127.0.0.1:$web_port/?session=review" demo.log; then
      fail "web-demo.sh: $(cat demo.log)"
    elif ! curl -fs "http://127.0.0.1:$web_port/app.js" > /dev/null; then
      fail "web-demo.sh: the page is not served"
    elif ! curl -s --max-time 2 -o /dev/null -w '%{http_code}' \
      -H 'Connection: Upgrade' -H 'Upgrade: websocket' \
      -H 'Sec-WebSocket-Version: 13' -H 'Sec-WebSocket-Protocol: binary' \
      -H 'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==' \
      "http://127.0.0.1:$((web_port + 1))/" | grep -q 101; then
      fail "web-demo.sh: websockify does not upgrade a WebSocket"
    fi
    kill -TERM "$demo" 2> /dev/null
    wait "$demo" 2> /dev/null
    demo=
    ;;
  *)
    echo "run  $cmd"
    sh -c "$cmd" > "out.$n" 2>&1 || fail "$cmd: exit $? ($(tail -n 3 "out.$n"))"
    ;;
  esac
  echo "     $(echo "$(date +%s.%N) - $t0" | bc 2> /dev/null || echo '?') s"
done < "$tmp/block"

# What the commands promised.
png_size() {
  od -An -tu1 -j16 -N8 "$1" |
    awk '{ print ($1*16777216 + $2*65536 + $3*256 + $4), \
                 ($5*16777216 + $6*65536 + $7*256 + $8) }'
}
[ "$(png_size review.png 2> /dev/null)" = "1024 768" ] ||
  fail "review.png is not a 1024x768 PNG"
[ -s view.png ] || fail "the viewer saved no screenshot"
for f in s.json s.png s.exr s.tif review.json review.glb; do
  [ -s "$f" ] || fail "$f was not written"
done
grep -q '^frame 1 .* level=0 ' out.* || fail "watch printed no frame"
grep -q '^id  *type  *parent' out.* || fail "nodes printed no listing"
"$BUILD/client/blobcast" load --session copy review.json > /dev/null ||
  fail "review.json does not load back"
"$BUILD/client/blobcast" mesh review.json --out here.glb --quiet ||
  fail "blobcast mesh of review.json failed"
cmp -s review.glb here.glb ||
  fail "the daemon's review.glb is not blobcast mesh's of review.json"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all $n commands of README \"Using it\" ran"
