#!/usr/bin/env bash
# deploy/systemd: the unit passes `systemd-analyze verify` (with ExecStart
# pointed at the blobcastd just built, since the unit names its installed
# path), keeps the hardening docs/deploy.md promises, and the example
# configuration starts a daemon (its TLS files replaced by ones made here)
# that tells systemd when it is ready and when it stops (sd_notify).
#
#   test_systemd_unit.sh BLOBCASTD
set -euo pipefail

daemon=${1:?usage: test_systemd_unit.sh BLOBCASTD}
root=$(cd "$(dirname "$0")/../.." && pwd)
unit=$root/deploy/systemd/blobcastd.service
example=$root/deploy/systemd/blobcastd.json
fail=0

if [ ! -x "$daemon" ]; then
	echo "skipped: blobcastd not built" >&2
	exit 77
fi
if ! command -v systemd-analyze >/dev/null 2>&1; then
	echo "skipped: systemd-analyze is missing (Debian package systemd;" \
		"deploy/install-deps.sh installs it)" >&2
	exit 77
fi
tmp=$(mktemp -d /tmp/bc-unit-test.XXXXXX)
pid=
listener=
cleanup() {
	if [ -n "$pid" ]; then kill "$pid" 2>/dev/null || true; fi
	if [ -n "$listener" ]; then kill "$listener" 2>/dev/null || true; fi
	rm -rf "$tmp"
}
trap cleanup EXIT

# 1. systemd's own check: syntax, directives, the executable.
sed "s|/usr/local/bin/blobcastd|$daemon|" "$unit" > "$tmp/blobcastd.service"
if ! out=$(systemd-analyze verify "$tmp/blobcastd.service" 2>&1); then
	echo "FAIL systemd-analyze verify:" >&2
	echo "$out" >&2
	fail=1
elif [ -n "$out" ]; then
	# verify exits 0 on some warnings: any output is a finding.
	echo "FAIL systemd-analyze verify printed:" >&2
	echo "$out" >&2
	fail=1
else
	echo "ok   systemd-analyze verify"
fi

# 2. The hardening the documentation promises.
for want in '^DynamicUser=yes' '^StateDirectory=blobcast' '^Type=notify' \
	'^ProtectSystem=strict' '^NoNewPrivileges=yes' \
	'^ExecReload=/bin/kill -HUP \$MAINPID' '^CapabilityBoundingSet=$' \
	'^ProtectHome=yes' '^PrivateTmp=yes' '--data \${STATE_DIRECTORY}'; do
	if ! grep -q -- "$want" "$unit"; then
		echo "FAIL the unit lacks $want" >&2
		fail=1
	fi
done
[ $fail -eq 0 ] && echo "ok   hardening directives"

# 3. The example configuration loads: listen on loopback, TLS files made
#    here, a data directory here; the daemon starts with TLS.
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
	-keyout "$tmp/tls.key" -out "$tmp/tls.crt" -days 1 \
	-subj /CN=localhost 2>/dev/null
sed -e "s|/run/credentials/blobcastd.service/|$tmp/|" \
	-e "s|\"0.0.0.0:7878\"|\"127.0.0.1:0\"|" \
	-e "s|/run/blobcast/blobcastd.sock|$tmp/sock|" "$example" \
	> "$tmp/blobcastd.json"
# A notification socket as systemd gives one (Type=notify).
/usr/bin/python3 - "$tmp/notify" "$tmp/notified" <<'PY' &
import socket, sys
s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
s.bind(sys.argv[1])
s.settimeout(20)
with open(sys.argv[2], "w") as out:
    try:
        while True:
            msg = s.recv(4096).decode()
            out.write(msg + "\n")
            out.flush()
            if "STOPPING=1" in msg:
                break
    except socket.timeout:
        pass
PY
listener=$!
for _ in $(seq 1 100); do [ -S "$tmp/notify" ] && break; sleep 0.05; done
NOTIFY_SOCKET=$tmp/notify "$daemon" --config "$tmp/blobcastd.json" \
	--data "$tmp/data" 2> "$tmp/log" &
pid=$!
for _ in $(seq 1 100); do
	grep -q 'blobcastd: backend' "$tmp/log" 2>/dev/null && break
	kill -0 "$pid" 2>/dev/null || break
	sleep 0.05
done
if grep -q 'listening on 127.0.0.1:0 (TLS)' "$tmp/log" &&
	kill -0 "$pid" 2>/dev/null; then
	echo "ok   the example configuration starts a TLS daemon"
else
	echo "FAIL the example configuration did not start a daemon:" >&2
	cat "$tmp/log" >&2
	fail=1
fi
# SIGHUP, as `systemctl reload` sends it: tokens and certificate reread.
kill -HUP "$pid"
for _ in $(seq 1 100); do
	grep -q 'reloaded the TLS certificate' "$tmp/log" && break
	sleep 0.05
done
if grep -q 'SIGHUP: reloaded 2 tokens' "$tmp/log" &&
	grep -q 'reloaded the TLS certificate' "$tmp/log"; then
	echo "ok   reload (SIGHUP) rereads the tokens and the certificate"
else
	echo "FAIL reload:" >&2
	cat "$tmp/log" >&2
	fail=1
fi
kill "$pid"
wait "$pid" || true
pid=
wait "$listener" || true
if grep -qx 'READY=1' "$tmp/notified" && grep -qx 'STOPPING=1' "$tmp/notified" &&
	[ "$(head -1 "$tmp/notified")" = READY=1 ]; then
	echo "ok   sd_notify: READY=1 after start, STOPPING=1 at SIGTERM"
else
	echo "FAIL sd_notify: the daemon told systemd:" >&2
	cat "$tmp/notified" >&2
	fail=1
fi
exit $fail
