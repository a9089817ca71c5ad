#!/bin/sh
# libblobcast as its users get it: installs the "client" component of a
# build into a temporary prefix, then builds the example client/lib/
# examples/nudge.c from the installed headers with the flags blobcast.pc
# gives, against libblobcast.so and against libblobcast.a, and as a CMake
# project that finds the package (find_package(blobcast), target
# blobcast::blobcast), and runs each:
# without arguments (usage, exit 2) and, when blobcastd is built, against a
# private daemon, where its edit must show up in a frame.
#
# usage: test_client_install.sh BUILD_DIR SOURCE_DIR CC SANITIZE [BLOBCASTD]
# Exits 77 when the installed libraries have not been built.
set -u
build=$1 src=$2 cc=$3 sanitize=$4 blobcastd=${5:-}
if [ ! -f "$build/client/lib/libblobcast.a" ] ||
  ! ls "$build"/client/lib/libblobcast.so* > /dev/null 2>&1; then
  echo "skip: libblobcast.so and libblobcast.a are not built"
  exit 77
fi
if ! command -v pkg-config > /dev/null 2>&1; then
  echo "skip: no pkg-config"
  exit 77
fi
tmp=$(mktemp -d /tmp/bc-client-install.XXXXXX) || exit 1
daemon=
trap 'if [ -n "$daemon" ]; then kill -TERM "$daemon"; wait "$daemon"; fi;
      rm -rf "$tmp"' EXIT
trap 'exit 1' INT TERM

fail() {
  echo "FAIL: $*"
  exit 1
}

cmake --install "$build" --component client --prefix "$tmp/prefix" \
  > "$tmp/install.log" 2>&1 || fail "install: $(cat "$tmp/install.log")"
pc=$(find "$tmp/prefix" -name blobcast.pc | head -n 1)
[ -n "$pc" ] || fail "blobcast.pc was not installed"
export PKG_CONFIG_PATH="${pc%/*}"
cflags=$(pkg-config --cflags blobcast) || fail "pkg-config --cflags"
libs=$(pkg-config --libs blobcast) || fail "pkg-config --libs"
static_libs=$(pkg-config --static --libs-only-l blobcast | sed 's/-lblobcast//')
libdir=$(pkg-config --variable=libdir blobcast)
[ -f "$libdir/libblobcast.a" ] || fail "no libblobcast.a in $libdir"
# H.264 frames: the decoder module beside the library, which libblobcast
# opens on first use and does not link (client/lib/h264_module.h).
[ -f "$libdir/blobcast/bc_client_h264.so" ] ||
  fail "no blobcast/bc_client_h264.so in $libdir"
if ldd "$libdir/libblobcast.so" | grep -q libavcodec; then
  fail "libblobcast.so links libavcodec"
fi
for h in client.h proto.h proto_limits.h blobtree.h scene.h error.h export.h; do
  [ -f "$(pkg-config --variable=includedir blobcast)/blobcast/$h" ] ||
    fail "header blobcast/$h not installed"
done
extra=
if [ "$sanitize" = ON ]; then
  extra="-fsanitize=address,undefined"
fi
# shellcheck disable=SC2086
"$cc" -std=c11 -Wall -Wextra -Werror $extra $cflags \
  "$src/client/lib/examples/nudge.c" -o "$tmp/nudge" $libs \
  > "$tmp/cc.log" 2>&1 || fail "shared build: $(cat "$tmp/cc.log")"
# shellcheck disable=SC2086
"$cc" -std=c11 -Wall -Wextra -Werror $extra $cflags \
  "$src/client/lib/examples/nudge.c" -o "$tmp/nudge-static" \
  "$libdir/libblobcast.a" $static_libs \
  > "$tmp/cc.log" 2>&1 || fail "static build: $(cat "$tmp/cc.log")"
if ldd "$tmp/nudge-static" | grep -q libblobcast; then
  fail "the static build links libblobcast.so"
fi
# The CMake package, found through CMAKE_PREFIX_PATH as a user would.
mkdir -p "$tmp/consumer"
cp "$src/client/lib/examples/nudge.c" "$tmp/consumer/"
cat > "$tmp/consumer/CMakeLists.txt" << 'CMAKE'
cmake_minimum_required(VERSION 3.18)
project(nudge_consumer C)
find_package(blobcast 0.1 REQUIRED)
add_executable(nudge nudge.c)
target_link_libraries(nudge PRIVATE blobcast::blobcast)
CMAKE
cmake -S "$tmp/consumer" -B "$tmp/consumer/build" \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_C_COMPILER="$cc" \
  -DCMAKE_C_FLAGS="-std=c11 -Wall -Wextra -Werror $extra" \
  > "$tmp/cmake.log" 2>&1 &&
  cmake --build "$tmp/consumer/build" >> "$tmp/cmake.log" 2>&1 ||
  fail "find_package build: $(cat "$tmp/cmake.log")"
cp "$tmp/consumer/build/nudge" "$tmp/nudge-cmake"
ldd "$tmp/nudge-cmake" | grep -q "libblobcast.so" ||
  fail "the find_package build does not link libblobcast.so"
export LD_LIBRARY_PATH="$libdir"
for prog in nudge nudge-static nudge-cmake; do
  "$tmp/$prog" > "$tmp/out" 2>&1
  [ $? -eq 2 ] && grep -q "usage: nudge" "$tmp/out" ||
    fail "$prog without arguments: $(cat "$tmp/out")"
  echo "ok   $prog builds and runs"
done

# The installed libblobcast.so opens the installed module at the first
# H.264 KEY frame: bytes that are not H.264 then fail to decode (ECODEC),
# where a missing module would say ENOTSUP.
cat > "$tmp/key.c" << 'C'
#include <blobcast/client.h>
#include <stdio.h>
int main(void)
{
	static const uint8_t junk[] = {0, 0, 0, 1, 0x65, 0x88, 0x84, 0x21};
	struct bc_proto_rect r = {.w = 16, .h = 16, .data = {junk, 8}};
	struct bc_msg m = {.type = BC_MSG_FRAME, .flags = BC_PROTO_FLAG_KEY};
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	int rc;
	m.frame.encoding = BC_PROTO_ENC_H264;
	m.frame.width = m.frame.image_width = 16;
	m.frame.height = m.frame.image_height = 16;
	m.frame.rects = &r;
	m.frame.nrects = 1;
	bc_client_image_init(&img);
	rc = bc_client_image_apply(&img, &m, &ei);
	printf("%s: %s\n", bc_err_name(rc), ei.msg);
	bc_client_image_finish(&img);
	return rc == BC_ECODEC ? 0 : 1;
}
C
# shellcheck disable=SC2086
"$cc" -std=c11 -Wall -Wextra -Werror $extra $cflags "$tmp/key.c" \
  -o "$tmp/key" $libs > "$tmp/cc.log" 2>&1 ||
  fail "H.264 program build: $(cat "$tmp/cc.log")"
LD_LIBRARY_PATH="$libdir" LD_DEBUG=files "$tmp/key" > "$tmp/out" \
  2> "$tmp/key.files" || fail "an H.264 KEY frame: $(cat "$tmp/out")"
grep -q "file=$libdir/blobcast/bc_client_h264.so" "$tmp/key.files" ||
  fail "the installed module was not the one opened: $(grep \
    bc_client_h264 "$tmp/key.files" | head -n 3)"
echo "ok   the installed library opens its H.264 module: $(cat "$tmp/out")"

if [ -z "$blobcastd" ] || [ ! -x "$blobcastd" ]; then
  echo "blobcastd not built: the example is not run against a server"
  exit 0
fi
"$blobcastd" --listen 127.0.0.1:0 --data "$tmp/data" --backend cpu \
  --log warn > "$tmp/daemon.log" 2>&1 &
daemon=$!
port=
i=0
while [ $i -lt 100 ] && [ -z "$port" ] && kill -0 "$daemon" 2>/dev/null; do
  sleep 0.1
  port=$(sed -n 's/^blobcastd: listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' \
    "$tmp/daemon.log" | head -n 1)
  i=$((i + 1))
done
[ -n "$port" ] || fail "blobcastd did not start: $(cat "$tmp/daemon.log")"
# Node 32 of the default scene is a sphere.
for prog in nudge nudge-static nudge-cmake; do
  "$tmp/$prog" "127.0.0.1:$port" default 32 translate=1.2,-0.4,0.2 \
    > "$tmp/out" 2>&1 || fail "$prog: $(cat "$tmp/out")"
  grep -q "^edit order [0-9]* shown in frame [0-9]* (320x240, complete)$" \
    "$tmp/out" || fail "$prog printed: $(cat "$tmp/out")"
  echo "ok   $prog: $(cat "$tmp/out")"
done
echo "all checks passed"
