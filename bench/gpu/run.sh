#!/usr/bin/env bash
# The GPU run, from the kit bench/gpu/pack.sh made (.gpu-kit/): one call on
# a GPU host answers the correctness check and the paper's tables in at
# most 8 minutes. Steps, each reported whatever the others did:
#   loaders  unpack the EGL/GLVND loader .debs (dpkg -x, no root); on a GPU
#            host find the NVIDIA EGL vendor file and library
#   libs     ldd of every packed program: everything resolves; the host's
#            C library is as new as the tools need
#   info     the gl context (EGL device platform on a GPU): GL_RENDERER
#   check    gl against the CPU tiled references shipped in the kit
#   table2   Zanni 2024 Table 2 at 1024x1024, A-buffer / tracing split
#   edit     parameter edits on the GPU: bytes, ms, damaged regions
#   daemon   edit -> frame through blobcastd --backend gl, 1920x1080 and
#            1024x768 JPEG, p50/p99
#   bench_gl gl against the tiled CPU renderer side by side, and GPU
#            tree updates against full uploads (bench/bench_gl.c)
#   bigview  a view over the A-buffer's limit: a million fig18 smooth
#            spheres at 4096x4096, drawn in bands of tile rows (last, so
#            that it never takes the time of the others)
# and writes results.json, results.md and run.log into the output folder.
# Programs run under `env -i` with the kit's library path only.
#
# Usage: bench/gpu/run.sh --out DIR [--local] [--kit DIR] [--platform P]
#                         [--only STEPS] [--edit-counts LIST]
#                         [--daemon-counts N]
#   --out DIR     where results.json, results.md and run.log go (created)
#   --local       run here on llvmpipe (EGL surfaceless) with small sizes:
#                 the same steps, to prove the scripts and the kit work
#   --kit DIR     the kit (default: .gpu-kit at the repository root)
#   --platform P  gl platform (default: device on a GPU host, auto --local)
#   --only STEPS  run only these of check,table2,edit,daemon,bench_gl,
#                 bigview
#                 (comma-separated; loaders, libs and info always run): a
#                 second, shorter call for what the first one left
#   --edit-counts LIST   the edit step's scene sizes (default
#                 1024,65536,1048576 on a GPU, 256 with --local)
#   --daemon-counts N    the daemon step's scene size (default 1024, 64
#                 with --local)
# Exit status: 0 when every step ran and succeeded, 1 otherwise, 2 usage.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
kit="$root/.gpu-kit"
out=
local_run=false
platform=
only=
edit_counts=
daemon_counts=

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
	--out) out=${2:?}; shift 2 ;;
	--kit) kit=${2:?}; shift 2 ;;
	--local) local_run=true; shift ;;
	--platform) platform=${2:?}; shift 2 ;;
	--only) only=${2:?}; shift 2 ;;
	--edit-counts) edit_counts=${2:?}; shift 2 ;;
	--daemon-counts) daemon_counts=${2:?}; shift 2 ;;
	-h | --help) usage 0 ;;
	*) echo "run.sh: unknown option $1" >&2; usage ;;
	esac
done
[ -n "$out" ] || usage
mkdir -p "$out"
out=$(cd "$out" && pwd)
if [ ! -d "$kit" ]; then
	echo "run.sh: no kit at $kit (make it with bench/gpu/pack.sh)" >&2
	exit 1
fi
kit=$(cd "$kit" && pwd)
# A copy that lost its modes (carried as plain files) still runs.
for f in "$kit"/bin/*; do
	[ -x "$f" ] || chmod u+x "$f" 2>/dev/null || true
done

t_start=$(date +%s)
# The whole run must end within 8 minutes; steps get what is left.
deadline=$((t_start + 470))
work=$(mktemp -d "${TMPDIR:-/tmp}/bc-gpu-run.XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/home" "$work/steps"
log="$out/run.log"
: >"$log"
md="$out/results.md"

if $local_run; then
	mode=local
	platform=${platform:-auto}
	t2_args=(--size 64 --reps 3 --warmup 1 --counts 16 --lens-counts 12
		--levels "1,2")
	edit_args=(--size 64 --counts 256 --edits 4)
	daemon_args=(--counts 64 --sizes "128x96,96x64" --edits 4)
	bench_gl_args=(--quick --size 64 --reps 1)
	# A small view with the limit lowered so that it bands.
	big_args=(--size 96 --counts 64 --lens-counts "" --levels ""
		--smooth-spheres --reps 1 --warmup 0 --abuffer-limit 200)
	hw_args=()
else
	mode=gpu
	platform=${platform:-device}
	t2_args=(--size 1024 --reps 20 --warmup 5 --budget-s 170)
	edit_args=(--size 1024 --counts "1024,65536,1048576" --edits 50)
	daemon_args=(--counts 1024 --sizes "1920x1080,1024x768" --edits 100)
	bench_gl_args=(--size 1024 --reps 5)
	big_args=(--size 4096 --counts 1000000 --lens-counts "" --levels ""
		--smooth-spheres --reps 3 --warmup 1 --budget-s 30)
	# Every gl step refuses a software context at once.
	hw_args=(--expect-hardware)
fi
# Sizes asked for on the command line replace the defaults (the driver
# takes the last --counts it is given).
[ -z "$edit_counts" ] || edit_args+=(--counts "$edit_counts")
[ -z "$daemon_counts" ] || daemon_args+=(--counts "$daemon_counts")
for s in ${only//,/ }; do
	case $s in
	check | table2 | edit | daemon | bench_gl | bigview) ;;
	*) echo "run.sh: --only: unknown step $s" >&2; usage ;;
	esac
done

# ---- Helpers ----------------------------------------------------------------
say() { printf '%s\n' "$*" | tee -a "$log"; }

# A JSON string of $1 (control characters dropped).
jstr() {
	local s
	s=$(printf '%s' "$1" | tr -d '\000-\010\013\014\016-\037')
	s=${s//\\/\\\\}
	s=${s//\"/\\\"}
	s=${s//$'\t'/\\t}
	s=${s//$'\n'/\\n}
	s=${s//$'\r'/}
	printf '"%s"' "$s"
}

steps=()
declare -A step_ok=() step_ran=() step_rc=() step_secs=() step_err=()
all_ok=true

# The environment every program runs in: nothing but this.
run_env=(PATH=/usr/bin:/bin HOME="$work/home")
ld_path="$kit/lib"

# Records step $1 as failed with message $2 without running anything.
not_run() {
	steps+=("$1")
	step_ran[$1]=false step_ok[$1]=false step_rc[$1]=-1 step_secs[$1]=0
	step_err[$1]=$2
	all_ok=false
	say "== $1: NOT RUN: $2"
}

# run_step NAME TIMEOUT_S COMMAND...: runs the command in the clean
# environment with at most TIMEOUT_S seconds (less if the run's deadline is
# nearer), logs its output, and records how it went. The command writes
# its JSON to $work/steps/NAME.json and Markdown to $work/steps/NAME.md.
run_step() {
	local name=$1 limit=$2 left rc=0 t0 err
	shift 2
	if [ -n "$only" ] && [ "$name" != info ] &&
		[[ ",$only," != *",$name,"* ]]; then
		say "== $name: left out (--only $only)"
		return 0
	fi
	left=$((deadline - $(date +%s)))
	if [ "$left" -lt 15 ]; then
		not_run "$name" "the run's 8 minutes are spent"
		return 0
	fi
	[ "$limit" -le "$left" ] || limit=$left
	steps+=("$name")
	say "== $name (at most ${limit} s)"
	t0=$(date +%s)
	env -i "${run_env[@]}" LD_LIBRARY_PATH="$ld_path" \
		timeout -k 10 "$limit" "$@" >"$work/$name.log" 2>&1 || rc=$?
	tee -a "$log" <"$work/$name.log"
	step_ran[$name]=true
	step_rc[$name]=$rc
	step_secs[$name]=$(($(date +%s) - t0))
	# A program that prints text only (bench_gl): its output is the data.
	if [ "$rc" = 0 ] && [ -n "${text_step:-}" ]; then
		printf '{"text":%s}\n' "$(jstr "$(cat "$work/$name.log")")" \
			>"$work/steps/$name.json"
		{
			echo '```'
			cat "$work/$name.log"
			echo '```'
		} >"$work/steps/$name.md"
	fi
	if [ "$rc" = 0 ] && [ -s "$work/steps/$name.json" ]; then
		step_ok[$name]=true
		step_err[$name]=
	else
		step_ok[$name]=false
		all_ok=false
		case $rc in
		124 | 137) err="timed out after ${limit} s" ;;
		0) err="no results written" ;;
		*) err="exit status $rc" ;;
		esac
		# The lines that say what went wrong: the first ones (often
		# the cause) and the last ones.
		err="$err; $(grep -E 'bench_gpu:|error|Error|ERROR|not found' \
			"$work/$name.log" | awk '{ l[NR] = $0 } END {
				for (i = 1; i <= NR; i++)
					if (i <= 3 || i > NR - 5) print l[i];
					else if (i == 4) print "..."
			}' || true)"
		step_err[$name]=$err
		say "== $name FAILED: $err"
	fi
}

# Shell steps: run a function, same bookkeeping.
shell_step() {
	local name=$1 rc=0 t0
	shift
	steps+=("$name")
	say "== $name"
	t0=$(date +%s)
	"$@" >"$work/$name.log" 2>&1 || rc=$?
	tee -a "$log" <"$work/$name.log"
	step_ran[$name]=true
	step_rc[$name]=$rc
	step_secs[$name]=$(($(date +%s) - t0))
	if [ "$rc" = 0 ]; then
		step_ok[$name]=true
		step_err[$name]=
	else
		step_ok[$name]=false
		all_ok=false
		step_err[$name]=$(grep -E '^(error|missing)' "$work/$name.log" | tail -n 8 || true)
		say "== $name FAILED: ${step_err[$name]}"
	fi
}

# ---- loaders ----------------------------------------------------------------
egl_vendor=
nvidia_lib=
loaders() {
	local d n=0 rc=0 f
	mkdir -p "$work/loaders"
	for d in "$kit"/debs/*.deb; do
		[ -e "$d" ] || continue
		if command -v dpkg-deb >/dev/null 2>&1; then
			dpkg-deb -x "$d" "$work/loaders" || { echo "error: dpkg-deb -x $d failed"; rc=1; }
		elif command -v ar >/dev/null 2>&1; then
			(cd "$work/loaders" && ar p "$d" data.tar.xz | tar -xJ) ||
				{ echo "error: cannot unpack $d (ar/tar)"; rc=1; }
		else
			echo "error: neither dpkg-deb nor ar to unpack $d"
			rc=1
		fi
		n=$((n + 1))
	done
	echo "unpacked $n loader packages into $work/loaders"
	local lib="$work/loaders/usr/lib/x86_64-linux-gnu"
	if [ ! -e "$lib/libEGL.so.1" ]; then
		echo "error: libEGL.so.1 missing from the loader packages"
		rc=1
	fi
	if [ "$mode" = gpu ]; then
		for f in /usr/local/nvidia/share/glvnd/egl_vendor.d/*nvidia*.json \
			/usr/share/glvnd/egl_vendor.d/*nvidia*.json \
			/etc/glvnd/egl_vendor.d/*nvidia*.json; do
			if [ -e "$f" ]; then
				egl_vendor=$f
				break
			fi
		done
		for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib \
			/usr/lib/x86_64-linux-gnu /usr/lib64; do
			if [ -e "$d/libEGL_nvidia.so.0" ]; then
				nvidia_lib=$d
				break
			fi
		done
		if [ -z "$egl_vendor" ]; then
			echo "error: no NVIDIA EGL vendor file (glvnd egl_vendor.d/*nvidia*.json)"
			rc=1
		fi
		if [ -z "$nvidia_lib" ]; then
			# Elsewhere, but known to the loader's cache: found too.
			f=$(ldconfig -p 2>/dev/null | awk '$1 == "libEGL_nvidia.so.0" { print $NF; exit }')
			if [ -n "$f" ]; then
				echo "libEGL_nvidia.so.0 from the loader's cache: $f"
			else
				echo "error: libEGL_nvidia.so.0 not found (/usr/local/nvidia/lib64, /usr/local/nvidia/lib, the loader's cache)"
				rc=1
			fi
		fi
		echo "NVIDIA EGL vendor file: ${egl_vendor:-none}; library folder: ${nvidia_lib:-none}"
		if compgen -G '/dev/nvidia*' >/dev/null; then
			echo "device nodes:" /dev/nvidia*
		else
			echo "error: no /dev/nvidia* device nodes"
			rc=1
		fi
		if command -v nvidia-smi >/dev/null 2>&1; then
			nvidia-smi -L || true
		fi
	fi
	return "$rc"
}
shell_step loaders loaders
# The loaders first, then the kit's libraries, then the NVIDIA driver's.
ld_path="$kit/lib:$work/loaders/usr/lib/x86_64-linux-gnu${nvidia_lib:+:$nvidia_lib}"
if [ -n "$egl_vendor" ]; then
	run_env+=(__EGL_VENDOR_LIBRARY_FILENAMES="$egl_vendor")
fi

# ---- libs -------------------------------------------------------------------
host_glibc=$(getconf GNU_LIBC_VERSION 2>/dev/null | awk '{print $2}' || true)
need_glibc=$(sed -n 's/.*"glibc_needed":"\([^"]*\)".*/\1/p' "$kit/kit.json" 2>/dev/null || true)
libs() {
	local rc=0 b missing
	for b in "$kit"/bin/*; do
		missing=$(env -i LD_LIBRARY_PATH="$ld_path" ldd "$b" 2>&1 | grep 'not found' || true)
		if [ -n "$missing" ]; then
			echo "missing for $(basename "$b"): $(echo "$missing" | tr '\n' ' ')"
			rc=1
		else
			echo "$(basename "$b"): every library resolves"
		fi
	done
	echo "glibc: host ${host_glibc:-unknown}, tools need ${need_glibc:-unknown}"
	if [ -n "$host_glibc" ] && [ -n "$need_glibc" ] &&
		[ "$(printf '%s\n%s\n' "$need_glibc" "$host_glibc" | sort -V | head -1)" != "$need_glibc" ]; then
		echo "error: the host's glibc $host_glibc is older than $need_glibc"
		rc=1
	fi
	if [ "$mode" = gpu ] && ! grep -q '"gpu_ready":true' "$kit/kit.json"; then
		echo "error: this kit was packed from a build that links OSMesa (--local only); pack without --build-dir"
		rc=1
	fi
	return "$rc"
}
shell_step libs libs

# ---- The driver's steps -----------------------------------------------------
drv="$kit/bin/bench_gpu"
S="$work/steps"
run_step info 60 "$drv" info --platform "$platform" "${hw_args[@]}" \
	--json "$S/info.json" --md "$S/info.md"
gl_renderer=$(sed -n 's/^GL_RENDERER: //p' "$work/info.log" | head -1)
say "GL_RENDERER: ${gl_renderer:-(no context)}"
run_step check 90 "$drv" check --platform "$platform" "${hw_args[@]}" \
	--dir "$kit/scenes" \
	--min-scenes 10 --json "$S/check.json" --md "$S/check.md"
run_step table2 210 "$drv" table2 --platform "$platform" "${hw_args[@]}" \
	"${t2_args[@]}" \
	--json "$S/table2.json" --md "$S/table2.md"
run_step edit 60 "$drv" edit --platform "$platform" "${hw_args[@]}" \
	"${edit_args[@]}" \
	--json "$S/edit.json" --md "$S/edit.md"
# The daemon makes its own context: on a GPU host, only once the info step
# has found a hardware one (else it would render in software or not at all
# and spend its minutes waiting for frames).
if [ "$mode" = gpu ] && [ "${step_ok[info]}" != true ]; then
	not_run daemon "no hardware gl context (see the info step)"
else
	run_step daemon $((90 + ${daemon_counts:-0} / 10000)) "$drv" daemon --platform "$platform" \
		--blobcastd "$kit/bin/blobcastd" "${daemon_args[@]}" \
		--json "$S/daemon.json" --md "$S/daemon.md"
fi
# gl against the tiled CPU renderer side by side (bench_gl: 7 scenes, and
# edits against full uploads as the tree grows to 262144 primitives).
if [ "$mode" = gpu ] && [ "${step_ok[info]}" != true ]; then
	not_run bench_gl "no hardware gl context (see the info step)"
else
	text_step=1 run_step bench_gl 90 "$kit/bin/bench_gl" --platform "$platform" \
		"${bench_gl_args[@]}"
fi
# A view over the A-buffer's limit, drawn in bands (table2's driver on one
# scene: a million smooth spheres at 4096x4096 on a GPU). It came after
# the others' timings were set, so when they leave it under a minute of
# the run's 8 it is left out, not failed: a second call runs it.
big_left=$((deadline - $(date +%s)))
if [ -z "$only" ] && [ "$big_left" -lt 60 ]; then
	say "== bigview: left out, ${big_left} s of the run's 8 minutes left (run it alone: --only bigview)"
elif [ "$mode" = gpu ] && [ "${step_ok[info]}" != true ]; then
	not_run bigview "no hardware gl context (see the info step)"
else
	run_step bigview 90 "$drv" table2 --platform "$platform" "${hw_args[@]}" \
		"${big_args[@]}" \
		--json "$S/bigview.json" --md "$S/bigview.md"
fi

# The daemon's renderer, from its log: on a GPU host it must not be software.
daemon_gl=$(grep -m1 -o 'gl: [a-z]* platform.*; robust access' "$work/daemon.log" 2>/dev/null || true)
if [ "${step_ran[daemon]:-false}" = true ]; then
	if [ -z "$daemon_gl" ]; then
		step_ok[daemon]=false all_ok=false
		step_err[daemon]="${step_err[daemon]:-}; the daemon's log names no gl context"
	elif [ "$mode" = gpu ] && echo "$daemon_gl" | grep -qiE 'llvmpipe|software|surfaceless|osmesa'; then
		step_ok[daemon]=false all_ok=false
		step_err[daemon]="${step_err[daemon]:-}; the daemon rendered in software: $daemon_gl"
	fi
fi

# ---- results.json and results.md -------------------------------------------
total=$(($(date +%s) - t_start))
{
	printf '{"mode":"%s","platform":%s,"seconds":%s,' "$mode" "$(jstr "$platform")" "$total"
	printf '"started":"%s",' "$(date -u -d "@$t_start" +%Y-%m-%dT%H:%M:%SZ 2>/dev/null || echo unknown)"
	printf '"gl_renderer":%s,"daemon_gl":%s,' "$(jstr "$gl_renderer")" "$(jstr "$daemon_gl")"
	printf '"host":{"uname":%s,"glibc":%s,"egl_vendor":%s,"nvidia_lib":%s},' \
		"$(jstr "$(uname -srm)")" "$(jstr "$host_glibc")" "$(jstr "$egl_vendor")" \
		"$(jstr "$nvidia_lib")"
	printf '"kit":'
	if [ -s "$kit/kit.json" ]; then cat "$kit/kit.json"; else printf 'null'; fi
	printf ',"steps":{'
	first=1
	for s in "${steps[@]}"; do
		[ $first = 1 ] || printf ','
		first=0
		printf '"%s":{"ran":%s,"ok":%s,"rc":%s,"seconds":%s,"error":%s,"data":' \
			"$s" "${step_ran[$s]}" "${step_ok[$s]}" "${step_rc[$s]}" \
			"${step_secs[$s]}" "$(jstr "${step_err[$s]}")"
		if [ -s "$S/$s.json" ]; then cat "$S/$s.json"; else printf 'null'; fi
		printf '}'
	done
	printf '},"ok":%s}\n' "$all_ok"
} >"$out/results.json"

{
	echo "# GPU run ($mode), $(date -u +%Y-%m-%d)"
	echo
	echo "GL_RENDERER: \`${gl_renderer:-none}\`; blobcastd: \`${daemon_gl:-none}\`;"
	echo "kit $(sed -n 's/.*"commit":"\([0-9a-f]\{10\}\).*/\1/p' "$kit/kit.json" 2>/dev/null);"
	echo "$total s in all; every step: $([ "$all_ok" = true ] && echo succeeded || echo '**not all succeeded**')."
	for s in "${steps[@]}"; do
		echo
		echo "## $s: $([ "${step_ok[$s]}" = true ] && echo ok || echo '**FAILED**') (${step_secs[$s]} s)"
		if [ -n "${step_err[$s]}" ]; then
			echo
			printf '%s\n' "${step_err[$s]}" | sed 's/^/    /'
		fi
		if [ -s "$S/$s.md" ]; then
			echo
			cat "$S/$s.md"
		fi
	done
} >"$md"

# results.json must parse, and agree with the steps' verdict (a run of some
# steps only has no check to verify).
if [ -n "$only" ]; then
	say "results.json not verified: --only $only left steps out"
elif ! env -i "${run_env[@]}" LD_LIBRARY_PATH="$ld_path" "$drv" verify \
	"$out/results.json" --min-scenes 10 >>"$log" 2>&1; then
	if [ "$all_ok" = true ]; then
		say "results.json does not verify (see run.log)"
		all_ok=false
	fi
fi
say "results: $out/results.json, $out/results.md ($total s)"
[ "$all_ok" = true ]
