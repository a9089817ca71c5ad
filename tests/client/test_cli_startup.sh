#!/bin/sh
# The CLI starts without OpenImageIO: `blobcast --help` (and every command
# that reads or writes no image file) must not load libOpenImageIO, which
# render/image loads on first use (docs/benchmarks.md, CLI start-up), nor
# FFmpeg's libavcodec, which libblobcast's H.264 module brings. A
# render to a PNG file must still load it and write the file.
#
# usage: test_cli_startup.sh BLOBCAST
# Exits 77 when the CLI was not built.
set -u
cli=${1:-}
if [ -z "$cli" ] || [ ! -x "$cli" ]; then
  echo "skip: blobcast not built"
  exit 77
fi
tmp=$(mktemp -d /tmp/bc-cli-startup.XXXXXX) || exit 1
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' INT TERM

fail() {
  echo "FAIL: $*"
  exit 1
}

LD_DEBUG=libs "$cli" --help > /dev/null 2> "$tmp/libs" ||
  fail "blobcast --help failed: $(tail -n 5 "$tmp/libs")"
grep -q 'calling init:' "$tmp/libs" ||
  fail "LD_DEBUG=libs printed nothing to check"
if grep -q 'calling init:.*libOpenImageIO' "$tmp/libs"; then
  fail "blobcast --help loads OpenImageIO"
fi
echo "ok   --help loads $(grep -c 'calling init:' "$tmp/libs") shared objects, OpenImageIO not among them"
# FFmpeg's libraries come with libblobcast's H.264 module, opened at the
# first H.264 frame (client/lib/h264_module.h), in every build.
if grep -q 'calling init:.*libavcodec' "$tmp/libs"; then
  fail "blobcast --help loads libavcodec"
fi
echo "ok   --help does not load libavcodec"

LD_DEBUG=libs "$cli" render default --size 32x24 --backend tiled \
  --out "$tmp/out.png" > "$tmp/render.out" 2> "$tmp/render.libs" ||
  fail "render: $(grep -v '^ *[0-9]*:' "$tmp/render.libs" | tail -n 5)"
grep -q 'calling init:.*libOpenImageIO' "$tmp/render.libs" ||
  fail "render to a PNG did not load OpenImageIO"
[ -s "$tmp/out.png" ] || fail "render wrote no PNG"
echo "ok   render loads OpenImageIO on first use and writes the PNG"

# libOSMesa (and the libLLVM it brings) is the gl backend's last resort,
# opened with dlopen when a context is asked of it (render/gl/osmesa.c), in
# every build: linked, libLLVM's relocation cost each start some 80 ms (90
# in a sanitizer build).
if ldd "$cli" 2> /dev/null | grep -q 'libOSMesa'; then
  fail "blobcast links libOSMesa: $(ldd "$cli" | grep libOSMesa)"
fi
if grep -qE 'calling init:.*lib(OSMesa|LLVM)' "$tmp/libs"; then
  fail "blobcast --help loads libOSMesa or libLLVM"
fi
echo "ok   --help loads neither libOSMesa nor libLLVM"
LD_DEBUG=libs "$cli" render default --size 16x16 --backend gl \
  --gl-platform osmesa --quiet --out "$tmp/gl.png" > /dev/null \
  2> "$tmp/gl.libs"
rc=$?
if grep -q 'is not built into this blobcast' "$tmp/gl.libs"; then
  echo "ok   (no gl backend in this build)"
  exit 0
fi
if [ "$rc" -ne 0 ]; then
  # A machine without libOSMesa: the failure must say why.
  grep -q 'OSMesa: cannot load' "$tmp/gl.libs" ||
    fail "render --gl-platform osmesa: $(grep -v '^ *[0-9]*:' "$tmp/gl.libs" | tail -n 3)"
  echo "ok   no libOSMesa here, and the error says so"
  exit 0
fi
grep -q 'calling init:.*libOSMesa' "$tmp/gl.libs" ||
  fail "render --gl-platform osmesa did not load libOSMesa"
[ -s "$tmp/gl.png" ] || fail "the OSMesa render wrote no PNG"
echo "ok   render --gl-platform osmesa opens libOSMesa on first use"
