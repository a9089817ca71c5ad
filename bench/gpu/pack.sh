#!/usr/bin/env bash
# Packs the GPU run: builds its tools in Release (blobcastd, bench_gl and the
# driver bench_gpu, with the gl backend on EGL alone) and gathers into one
# folder, .gpu-kit/ at the repository root by default, everything a bare
# GPU host lacks:
#   bin/      the tools
#   lib/      every shared library they need except the C library and the
#             GL loader (checked with ldd: nothing else may resolve outside)
#   debs/     the EGL/GLVND loader packages (libegl1, libglvnd0, libopengl0,
#             libgles2), unpacked by run.sh on the host without root
#   scenes/   the correctness scenes (NAME.json) and their references from
#             the CPU tiled renderer (NAME.ref: depth and ids; mask = hits)
#   kit.json  what was packed, from which commit, and whether it is fit for
#             a GPU host; ldd.txt the library check's output
# then checks that the kit stays under 64 MiB (what the GPU host's call may
# carry). bench/gpu/run.sh runs it; docs/gpu-run.md says how.
#
# Usage: bench/gpu/pack.sh [--build-dir DIR] [--kit DIR] [--ref-size N]
#                          [--jobs N]
#   --build-dir DIR  reuse a configured Release build (e.g. the `build`
#                    folder tests/run.sh makes) instead of configuring
#                    build-gpu-kit; its tools are rebuilt if stale. A build
#                    that links OSMesa gives a kit for --local runs only
#                    (kit.json: gpu_ready false): OSMesa is absent on a GPU
#                    host and is not packed.
#   --kit DIR        where to pack (default: .gpu-kit); emptied first, except
#                    debs/, which is kept and reused when complete
#   --ref-size N     edge of the reference images (default 512)
#   --jobs N         build jobs (default: the number of cores)
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
build_dir=
kit="$root/.gpu-kit"
ref_size=512
jobs=$(nproc 2>/dev/null || echo 2)
max_bytes=$((64 * 1024 * 1024))
debs=(libegl1 libglvnd0 libopengl0 libgles2)

# The Usage block above; to stdout and status 0 for --help, else to
# stderr and status 2.
usage() {
	if [ "${1:-2}" = 0 ]; then
		sed -n '/^# Usage:/,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'
		exit 0
	fi
	sed -n '/^# Usage:/,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//' >&2
	exit 2
}

while [ $# -gt 0 ]; do
	case $1 in
	--build-dir) build_dir=${2:?}; shift 2 ;;
	--kit) kit=${2:?}; shift 2 ;;
	--ref-size) ref_size=${2:?}; shift 2 ;;
	--jobs) jobs=${2:?}; shift 2 ;;
	-h | --help) usage 0 ;;
	*) echo "pack.sh: unknown option $1" >&2; usage ;;
	esac
done
case $ref_size in '' | *[!0-9]*) echo "pack.sh: bad --ref-size" >&2; exit 2 ;; esac

say() { printf 'pack: %s\n' "$*"; }
die() { printf 'pack: error: %s\n' "$*" >&2; exit 1; }

tools=(blobcastd bench_gl bench_gpu)

# ---- Build ------------------------------------------------------------------
launcher=()
if command -v ccache >/dev/null 2>&1; then
	launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache
		-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
if [ -z "$build_dir" ]; then
	build_dir="$root/build-gpu-kit"
	say "configuring $build_dir (Release, gl on EGL only, no tests)"
	generator=()
	if [ ! -f "$build_dir/CMakeCache.txt" ] && command -v ninja >/dev/null 2>&1; then
		generator=(-G Ninja)
	fi
	cmake -S "$root" -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
		-DBLOBCAST_WERROR=ON -DBLOBCAST_TESTS=OFF -DBLOBCAST_BENCH=ON \
		-DBLOBCAST_GL=ON \
		-DPKG_CONFIG_EXECUTABLE="$root/bench/gpu/pkg-config-no-osmesa" \
		"${launcher[@]}" >/dev/null
else
	case $build_dir in /*) ;; *) build_dir="$root/$build_dir" ;; esac
	[ -f "$build_dir/CMakeCache.txt" ] ||
		die "$build_dir is not a configured build (no CMakeCache.txt)"
	if grep -q '^BLOBCAST_SANITIZE:BOOL=ON' "$build_dir/CMakeCache.txt"; then
		say "warning: $build_dir is a sanitizer build; timings from it mean little"
	fi
fi
say "building ${tools[*]} in $build_dir"
cmake --build "$build_dir" -j "$jobs" --target "${tools[@]}" >/dev/null ||
	die "the build failed (cmake --build $build_dir --target ${tools[*]})"

# ---- Folder -----------------------------------------------------------------
mkdir -p "$kit"
kit=$(cd "$kit" && pwd)
find "$kit" -mindepth 1 -maxdepth 1 ! -name debs -exec rm -rf {} +
mkdir -p "$kit/bin" "$kit/lib" "$kit/scenes" "$kit/debs"

bins=()
for t in "${tools[@]}"; do
	src=$(find "$build_dir" -type f -name "$t" -perm -u+x -print -quit)
	[ -n "$src" ] || die "$t was not built in $build_dir"
	cp "$src" "$kit/bin/$t"
	bins+=("$kit/bin/$t")
done

# ---- Shared libraries -------------------------------------------------------
# The C library's own parts: every Linux host has them (the glibc version
# the tools need is recorded and run.sh compares it with the host's).
is_libc() {
	case $1 in
	linux-vdso.so.* | ld-linux*.so.* | libc.so.* | libm.so.* | \
		libpthread.so.* | libdl.so.* | librt.so.* | libresolv.so.* | \
		libutil.so.*) return 0 ;;
	esac
	return 1
}
# The GL loader (GLVND): it comes as the .debs; the vendor library behind it
# is the host's driver.
is_gl_loader() {
	case $1 in
	libEGL.so.1 | libGLdispatch.so.0 | libOpenGL.so.0 | libGLESv2.so.2 | \
		libGL.so.1 | libGLX.so.0) return 0 ;;
	esac
	return 1
}
# A GL implementation of this host (OSMesa, in a build that links it): not
# packed, nor what only it needs; the kit is then for --local runs only.
is_host_gl() {
	case $1 in libOSMesa.so.*) return 0 ;; esac
	return 1
}
gpu_ready=true
host_gl_closure=()

# The libraries to pack: the NEEDED entries of the tools, and of every
# library packed, that are neither the C library, the GL loader nor the
# host's GL; each resolved where ldd resolves it for the tool.
declare -A where=()
for b in "${bins[@]}"; do
	while read -r line; do
		case $line in
		*"not found"*) die "$(basename "$b"): $line" ;;
		esac
		read -r name _ path _ <<<"$line"
		case ${path:-} in /*) where[$name]=$path ;; esac
	done < <(ldd "$b")
done
queue=("${bins[@]}")
while [ ${#queue[@]} -gt 0 ]; do
	f=${queue[0]}
	queue=("${queue[@]:1}")
	while read -r name; do
		if is_libc "$name" || is_gl_loader "$name" ||
			[ -e "$kit/lib/$name" ]; then
			continue
		fi
		if is_host_gl "$name"; then
			gpu_ready=false
			mapfile -t -O "${#host_gl_closure[@]}" host_gl_closure < <(
				ldd "${where[$name]}" | awk '$3 ~ /^\// {print $1}')
			host_gl_closure+=("$name")
			continue
		fi
		[ -n "${where[$name]:-}" ] ||
			die "$(basename "$f") needs $name, which ldd did not resolve"
		cp -L "${where[$name]}" "$kit/lib/$name"
		queue+=("$kit/lib/$name")
	done < <(readelf -d "$f" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
done
# In the check below, what only the host's GL needs may resolve outside.
in_host_gl() {
	local h
	for h in "${host_gl_closure[@]}"; do
		[ "$h" = "$1" ] && return 0
	done
	return 1
}

# ---- The loader packages ----------------------------------------------------
have_debs() {
	local p
	for p in "${debs[@]}"; do
		compgen -G "$kit/debs/${p}_*.deb" >/dev/null || return 1
	done
}
if ! have_debs; then
	say "downloading ${debs[*]}"
	rm -f "$kit"/debs/*.deb
	if ! (cd "$kit/debs" && apt-get download "${debs[@]}" >/dev/null 2>&1); then
		# Offline: packages apt still holds in its cache.
		for p in "${debs[@]}"; do
			f=$(compgen -G "/var/cache/apt/archives/${p}_*_amd64.deb" | tail -1 || true)
			[ -n "$f" ] && cp "$f" "$kit/debs/"
		done
	fi
	have_debs || die "could not get ${debs[*]} (apt-get download failed and apt's cache lacks them)"
fi
for so in libEGL.so.1 libGLdispatch.so.0; do
	found=false
	for d in "$kit"/debs/*.deb; do
		if dpkg-deb -c "$d" | grep -q "/$so\( \|$\)"; then
			found=true
		fi
	done
	$found || die "the loader packages do not hold $so"
done

# ---- Scenes and references --------------------------------------------------
say "rendering the references (${ref_size}x${ref_size}, tiled CPU renderer)"
env -i PATH=/usr/bin:/bin LD_LIBRARY_PATH="$kit/lib" \
	"$kit/bin/bench_gpu" refs --dir "$kit/scenes" --size "$ref_size" \
	--json "$kit/scenes.json" >/dev/null ||
	die "bench_gpu refs failed"
nscenes=$(find "$kit/scenes" -name '*.ref' | wc -l)
[ "$nscenes" -ge 10 ] || die "only $nscenes reference scenes"

# ---- The library check ------------------------------------------------------
# With the kit's lib/ as the only library path, every library a packed
# program or library needs must resolve, and into lib/ unless it is the C
# library, the GL loader (from debs/) or, in a --local kit, the host's GL.
check_log="$kit/ldd.txt"
: >"$check_log"
bad=0
for f in "${bins[@]}" "$kit"/lib/*; do
	[ -e "$f" ] || continue
	in_kit=0 libc=() loader=() hostgl=()
	while read -r line; do
		read -r name _ path _ <<<"$line"
		case $line in
		*"not found"*)
			echo "  $(basename "$f"): $name NOT FOUND" >>"$check_log"
			bad=1
			continue
			;;
		esac
		case ${path:-} in /*) ;; *) continue ;; esac
		if [ "${path#"$kit"/lib/}" != "$path" ]; then
			in_kit=$((in_kit + 1))
		elif is_libc "$name"; then
			libc+=("$name")
		elif is_gl_loader "$name"; then
			loader+=("$name")
		elif in_host_gl "$name"; then
			hostgl+=("$name")
		else
			echo "  $(basename "$f"): $name resolves outside the kit ($path)" >>"$check_log"
			bad=1
		fi
	done < <(env -i LD_LIBRARY_PATH="$kit/lib" ldd "$f")
	printf '%-22s %2d from lib/; C library: %s; GL loader: %s%s\n' \
		"$(basename "$f")" "$in_kit" "${libc[*]:-none}" "${loader[*]:-none}" \
		"${hostgl[*]:+; host GL (not packed): ${#hostgl[@]} libraries}" \
		>>"$check_log"
done
cat "$check_log"
[ "$bad" = 0 ] || die "the library check failed (see above)"

# ---- Manifest ---------------------------------------------------------------
glibc=$(for f in "${bins[@]}" "$kit"/lib/*; do objdump -T "$f" 2>/dev/null; done |
	grep -o 'GLIBC_[0-9.]*' | sed 's/GLIBC_//' | sort -uV | tail -1)
commit=$(git -C "$root" rev-parse HEAD 2>/dev/null || echo unknown)
dirty=false
if [ -n "$(git -C "$root" status --porcelain --untracked-files=no 2>/dev/null)" ]; then
	dirty=true
fi
# The names in folder $1 as a JSON list.
list_json() {
	local first=1 x
	printf '['
	for x in "$1"/*; do
		[ -e "$x" ] || continue
		[ $first = 1 ] || printf ','
		first=0
		printf '"%s"' "${x##*/}"
	done
	printf ']'
}
bytes=$(du -sb "$kit" | cut -f1)
(
	cd "$kit"
	printf '{"commit":"%s","dirty":%s,"packed":"%s","build_dir":"%s",' \
		"$commit" "$dirty" "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$build_dir"
	printf '"gpu_ready":%s,"glibc_needed":"%s","ref_size":%s,"scenes":%s,' \
		"$gpu_ready" "${glibc:-unknown}" "$ref_size" "$nscenes"
	printf '"bytes":%s,' "$bytes"
	printf '"bin":%s,' "$(list_json bin)"
	printf '"lib":%s,' "$(list_json lib)"
	printf '"debs":%s}\n' "$(list_json debs)"
) >"$kit/kit.json"

bytes=$(du -sb "$kit" | cut -f1)
say "kit: $kit, $((bytes / 1024)) KiB; $nscenes scenes; glibc >= ${glibc:-?}; gpu_ready $gpu_ready"
[ "$bytes" -lt "$max_bytes" ] || die "the kit is $bytes bytes, over 64 MiB"
if [ "$gpu_ready" != true ]; then
	say "note: $build_dir links OSMesa: this kit runs with --local only"
fi
