#!/usr/bin/env bash
# Installs every Debian package blobcast needs to build, test and run.
# Idempotent: when everything is present it prints nothing and exits 0.
set -euo pipefail

pkgs=(
	build-essential cmake ninja-build pkg-config clang clang-format
	libjansson-dev
	libopenimageio-dev openimageio-tools
	libturbojpeg0-dev libpng-dev zlib1g-dev
	libavcodec-dev libavutil-dev libswscale-dev
	libuv1-dev
	libegl-dev libgl-dev libgles-dev libegl1-mesa-dev libgl1-mesa-dev
	libgl1-mesa-dri libosmesa6-dev python3-glad glslang-tools
	libglfw3-dev xvfb
	libssl-dev openssl
	systemd nginx python3-yaml
)

missing=()
for p in "${pkgs[@]}"; do
	if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null |
		grep -q 'install ok installed'; then
		missing+=("$p")
	fi
done
here=$(dirname "$0")
if [ ${#missing[@]} -eq 0 ]; then
	bash "$here/install-web-deps.sh"
	exit 0
fi

SUDO=
[ "$(id -u)" -ne 0 ] && SUDO=sudo
echo "install-deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq >/dev/null
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null

# The browser client and its tests: chromium, websockify, node and npm.
bash "$here/install-web-deps.sh"
