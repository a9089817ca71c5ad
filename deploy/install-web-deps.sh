#!/usr/bin/env bash
# Installs the Debian packages the browser client needs to run and to be
# tested: chromium (headless, driven by playwright-core in tests/web),
# websockify (the WebSocket proxy in front of blobcastd), and node with npm
# (the codec tests and the test driver). Idempotent: when everything is
# present it prints nothing and exits 0.
#
# node and npm count as present when the commands exist: NodeSource's
# nodejs package ships npm itself and conflicts with Debian's npm package.
set -euo pipefail

missing=()
for p in chromium websockify; do
	if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null |
		grep -q 'install ok installed'; then
		missing+=("$p")
	fi
done
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)
[ ${#missing[@]} -eq 0 ] && exit 0

SUDO=
[ "$(id -u)" -ne 0 ] && SUDO=sudo
echo "install-web-deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq >/dev/null
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
