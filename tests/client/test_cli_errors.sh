#!/bin/sh
# The blobcast CLI's errors, as a new user meets them: a failed connect
# returns quickly with its reason (nothing listens, a web server, a
# WebSocket proxy, a port that only closes, TLS expected or not), every
# failure class has its exit status (1 refused, 2 usage, 3 network, 4
# authentication), a mistyped edit key gets "did you mean", and the
# global options work before and after the command word alike.
#
# Servers that are not blobcastd are small python3 scripts (and
# websockify, when installed); the TLS checks need openssl. What is
# missing is skipped with a note, the rest still runs.
#
# usage: test_cli_errors.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
for prog in "$BLOBCAST" "$BLOBCASTD"; do
  if [ -z "$prog" ] || [ ! -x "$prog" ]; then
    echo "skip: blobcast and blobcastd must both be built"
    exit 77
  fi
done

tmp=$(mktemp -d /tmp/bc-cli-errors.XXXXXX) || exit 1
pids=
stop_all() {
  for p in $pids; do
    kill -TERM "$p" 2>/dev/null
    wait "$p" 2>/dev/null
  done
  pids=
}
trap 'stop_all; rm -rf "$tmp"' EXIT
trap 'exit 1' INT TERM
failures=0

fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

# A connect that fails must say why well before the old 10 s timeout;
# this bound is generous for a loaded machine (the checks take about 1 s).
QUICK_S=5

# run STATUS PATTERN ARGS...: blobcast ARGS must exit STATUS and print
# PATTERN (fixed string, "" for any); output in $tmp/out, the seconds it
# took in $took.
run() {
  want=$1 pattern=$2
  shift 2
  t0=$(date +%s)
  "$BLOBCAST" "$@" > "$tmp/out" 2>&1
  got=$?
  took=$(($(date +%s) - t0))
  if [ "$got" -ne "$want" ]; then
    fail "blobcast $*: exit $got, wanted $want"
    sed 's/^/    /' "$tmp/out"
  elif [ -n "$pattern" ] && ! grep -qF -- "$pattern" "$tmp/out"; then
    fail "blobcast $*: output lacks \"$pattern\""
    sed 's/^/    /' "$tmp/out"
  else
    echo "ok   blobcast $* (exit $got, ${took} s)"
  fi
}

# quick: the last run took less than QUICK_S seconds.
quick() {
  if [ "$took" -ge "$QUICK_S" ]; then
    fail "$1 took $took s (wanted under $QUICK_S s)"
  else
    echo "ok   $1 answered in under $QUICK_S s"
  fi
}

# wait_port FILE PID: prints the port number that a server started in the
# background writes as the first line of FILE (python scripts) or in its
# "listening on" line (blobcastd), once it is there.
wait_port() {
  i=0
  while [ $i -lt 100 ]; do
    port=$(sed -n \
      -e 's/^blobcastd: listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' \
      -e 's/^port \([0-9][0-9]*\)$/\1/p' "$1" 2> /dev/null | head -n 1)
    if [ -n "$port" ]; then
      echo "$port"
      return 0
    fi
    kill -0 "$2" 2>/dev/null || break
    sleep 0.1
    i=$((i + 1))
  done
  return 1
}

# --- a daemon with tokens: an editor's and a viewer's ------------------------
cat > "$tmp/config.json" <<'EOF'
{"tokens": [{"token": "editor-secret", "role": "editor"},
            {"token": "viewer-secret", "role": "viewer"}]}
EOF
"$BLOBCASTD" --listen 127.0.0.1:0 --data "$tmp/data" --backend cpu \
  --log warn --config "$tmp/config.json" > "$tmp/daemon.log" 2>&1 &
daemon=$!
pids="$pids $daemon"
if ! port=$(wait_port "$tmp/daemon.log" "$daemon"); then
  echo "FAIL: the daemon did not start"
  cat "$tmp/daemon.log"
  exit 1
fi
D="--server 127.0.0.1:$port"
ED="--token editor-secret"

# A node of the default scene with a radius.
"$BLOBCAST" nodes $D $ED --session default > "$tmp/nodes" 2>&1 ||
  fail "nodes: $(cat "$tmp/nodes")"
cyl=$(awk '$2 == "cylinder" { print $1; exit }' "$tmp/nodes")
[ -n "$cyl" ] || fail "the default scene has no cylinder"
cyl=${cyl:-12}

# --- exit status per class ---------------------------------------------------
run 0 "edit applied" edit $D $ED --session default "$cyl" radius=0.09
# 1: the server refused (an ERROR answer).
run 1 "must be > 0 (ERANGE)" edit $D $ED --session default "$cyl" \
  radius=-1
run 1 "ENOSESSION" edit $D $ED --session nosuch "$cyl" radius=0.1
run 1 "'blobcast sessions' lists the sessions" \
  edit $D $ED --session nosuch "$cyl" radius=0.1
# The line under the sessions table: the scene memory held and its cap.
run 0 "scene memory:" sessions $D $ED
run 0 "nodes held by the 1 loaded session (the server's --scene-memory)" \
  sessions $D $ED
run 1 "ESTATE" redo $D $ED --session default
# 2: usage, before anything is sent; a mistyped key gets a suggestion.
run 2 "has no \"raduis\"" edit $D $ED --session default "$cyl" raduis=0.1
run 2 "(did you mean 'radius'?)" edit $D $ED --session default "$cyl" \
  raduis=0.1
run 2 "(did you mean 'smooth_union'?)" edit $D $ED --session default 1 \
  kind=smoth_union
run 2 "unknown option '--sesion' (did you mean '--session'?)" \
  edit $D $ED --sesion default "$cyl" radius=0.1
# 3: the network: nothing listens there.
run 3 "connection refused" edit --server 127.0.0.1:1 $ED --session default \
  "$cyl" radius=0.1
quick "a closed port"
# 4: authentication: a wrong token, a viewer's token for an edit.
run 4 "EAUTH" sessions $D --token wrong-secret
run 4 "--token TOKEN" sessions $D --token wrong-secret
run 4 "EAUTH" sessions $D
run 4 "EPERM" edit $D --token viewer-secret --session default "$cyl" \
  radius=0.1
run 4 "editor role" edit $D --token viewer-secret --session default "$cyl" \
  radius=0.1
# The same with the global options before the command word.
run 4 "EPERM" --token viewer-secret $D edit --session default "$cyl" \
  radius=0.1
run 0 "edit applied" --token editor-secret --name early --timeout 5000 \
  $D edit --session default "$cyl" radius=0.1
run 4 "EAUTH" --token wrong-secret --server "127.0.0.1:$port" sessions

# --- what listens there, when it is not blobcastd ----------------------------
if command -v python3 > /dev/null 2>&1; then
  # serve.py MODE: listens on a free loopback port, prints "port N", and
  #   http    is python's http.server (silent until a request line ends);
  #   http400 answers every connection "HTTP/1.1 400" at once, as nginx
  #           answers bytes that are not HTTP;
  #   close   closes every connection without a word.
  cat > "$tmp/serve.py" <<'EOF'
import http.server, socket, sys
mode = sys.argv[1]
if mode == "http":
    srv = http.server.HTTPServer(("127.0.0.1", 0),
                                 http.server.SimpleHTTPRequestHandler)
    print("port", srv.server_address[1], flush=True)
    srv.serve_forever()
s = socket.socket()
s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind(("127.0.0.1", 0))
s.listen(8)
print("port", s.getsockname()[1], flush=True)
while True:
    c, _ = s.accept()
    if mode == "http400":
        c.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n"
                  b"Connection: close\r\n\r\n")
    c.close()
EOF
  for mode in http http400 close; do
    (cd "$tmp" && exec python3 "$tmp/serve.py" "$mode") \
      > "$tmp/$mode.log" 2>&1 &
    pid=$!
    pids="$pids $pid"
    if ! p=$(wait_port "$tmp/$mode.log" "$pid"); then
      fail "python3 serve.py $mode did not start: $(cat "$tmp/$mode.log")"
      continue
    fi
    case $mode in
    http)
      run 3 "127.0.0.1:$p answers HTTP (\"HTTP/1.0 200 OK\")" \
        sessions --server "127.0.0.1:$p"
      quick "python3 -m http.server"
      run 3 "a web server, not blobcastd" sessions --server "127.0.0.1:$p"
      run 3 "answers HTTP" --server "127.0.0.1:$p" watch --session s \
        --frames 1
      run 3 "in plain it answers HTTP" sessions --server "tls://127.0.0.1:$p" \
        --timeout 1000
      ;;
    http400)
      run 3 "answers HTTP (\"HTTP/1.1 400 Bad Request\")" \
        sessions --server "127.0.0.1:$p"
      quick "a server answering HTTP/1.1 400"
      run 3 "not blobcastd" edit --server "127.0.0.1:$p" --session s 1 \
        radius=1
      ;;
    close)
      run 3 "closed the connection without answering HELLO" \
        sessions --server "127.0.0.1:$p"
      quick "a server that closes at once"
      ;;
    esac
  done
else
  echo "note: no python3: the checks against web servers are skipped"
fi

if command -v websockify > /dev/null 2>&1 &&
  command -v python3 > /dev/null 2>&1; then
  wsport=$(python3 -c 'import socket; s = socket.socket();
s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  websockify "127.0.0.1:$wsport" "127.0.0.1:$port" > "$tmp/ws.log" 2>&1 &
  pids="$pids $!"
  i=0
  while [ $i -lt 100 ] &&
    ! grep -q "proxying\|Listen" "$tmp/ws.log" 2> /dev/null; do
    sleep 0.1
    i=$((i + 1))
  done
  sleep 0.2
  run 3 "is a WebSocket endpoint" sessions --server "127.0.0.1:$wsport" $ED
  quick "websockify"
  run 3 "ws://127.0.0.1:$wsport/" sessions --server "127.0.0.1:$wsport" $ED
  # Through it, as the message says, it works.
  run 0 "default" sessions --server "ws://127.0.0.1:$wsport/" $ED
else
  echo "note: no websockify: the WebSocket endpoint check is skipped"
fi

# --- TLS expected, or not ----------------------------------------------------
if command -v openssl > /dev/null 2>&1; then
  openssl req -x509 -newkey rsa:2048 -nodes -keyout "$tmp/key.pem" \
    -out "$tmp/cert.pem" -days 2 -subj /CN=localhost \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    > "$tmp/openssl.log" 2>&1 || fail "openssl: $(cat "$tmp/openssl.log")"
  "$BLOBCASTD" --listen 127.0.0.1:0 --data "$tmp/tlsdata" --backend cpu \
    --log error --tls-cert "$tmp/cert.pem" --tls-key "$tmp/key.pem" \
    > "$tmp/tls.log" 2>&1 &
  tlsd=$!
  pids="$pids $tlsd"
  if tport=$(wait_port "$tmp/tls.log" "$tlsd"); then
    # A plain client on the TLS port: the daemon says so in plain.
    run 3 "tls://" sessions --server "127.0.0.1:$tport"
    quick "a plain client on a TLS port"
    run 0 "default" sessions --server "tls://127.0.0.1:$tport" \
      --ca "$tmp/cert.pem"
    run 0 "default" --ca "$tmp/cert.pem" --server "tls://127.0.0.1:$tport" \
      sessions
    # An untrusted certificate is authentication; the message says what
    # to do instead of a token hint.
    run 4 "--ca FILE" sessions --server "tls://127.0.0.1:$tport"
    if grep -qF -- "--token" "$tmp/out"; then
      fail "an untrusted certificate was answered with a token hint"
    fi
  else
    fail "the TLS daemon did not start: $(cat "$tmp/tls.log")"
  fi
  # A TLS client on the plain port.
  run 3 "speaks the blobcast protocol without TLS" \
    sessions --server "tls://127.0.0.1:$port" $ED
  quick "a TLS client on a plain port"
  run 3 "connect with 127.0.0.1:$port (no tls://)" \
    sessions --server "tls://127.0.0.1:$port" $ED
else
  echo "note: no openssl: the TLS checks are skipped"
fi

# --- a server's refusal, said once --------------------------------------------
# A daemon whose scenes may hold 1 497 nodes (--scene-memory 1) refuses a
# load of 2 000 spheres; the CLI says "scene not loaded" once, then the
# server's reason and what to do.
"$BLOBCASTD" --listen 127.0.0.1:0 --data "$tmp/small" --backend cpu \
  --log warn --scene-memory 1 > "$tmp/small.log" 2>&1 &
small=$!
pids="$pids $small"
if ! sport=$(wait_port "$tmp/small.log" "$small"); then
  fail "the daemon with --scene-memory 1 did not start: $(cat "$tmp/small.log")"
else
  "$BLOBCAST" gen fig18 --count 2000 --kind spheres --out "$tmp/2000.json" ||
    fail "gen fig18 --count 2000"
  run 1 "scene not loaded: a scene of 2001 nodes is more than this server" \
    load "$tmp/2000.json" --server "127.0.0.1:$sport" --session big
  run 1 "--scene-memory" load "$tmp/2000.json" \
    --server "127.0.0.1:$sport" --session big
  if grep -q "not loaded: scene not loaded" "$tmp/out"; then
    fail "the refusal says \"scene not loaded\" twice: $(cat "$tmp/out")"
  fi
fi

# The daemons served on through all of it.
run 0 "default" sessions $D $ED
stop_all

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "all checks passed"
