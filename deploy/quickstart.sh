#!/usr/bin/env bash
# Quick start: installs the Debian dependencies, builds blobcast (Release)
# and renders the embedded default scene to out.png with the CPU tile
# tracer. Usage: bash deploy/quickstart.sh [WxH] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
size=${1:-800x600}
out=${2:-out.png}

bash deploy/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target blobcast
./build/client/blobcast render default --size "$size" --backend tiled \
	--out "$out"
echo "quickstart: wrote $out"
