#!/usr/bin/env bash
# The GPU run, end to end on llvmpipe, as a GPU host would run it:
#  - bench/gpu/pack.sh --build-dir BUILD packs a kit (small references) and
#    its library check passes;
#  - bench/gpu/run.sh --local runs every step from the kit in an empty
#    environment (env -i) and exits 0, the bigview step's scene drawn in
#    bands of tile rows;
#  - results.json parses, says every step ran and succeeded, and has at
#    least 10 scenes, each correct (checked by bench_gpu verify and, apart
#    from it, by counting in the file);
#  - the checks can fail: a wrong reference makes `check` report the scene
#    incorrect and exit non-zero, and a failed step makes verify fail.
#
# Usage: test_gpu_run.sh SOURCE_DIR RELEASE_BUILD_DIR WORK_DIR
set -euo pipefail
src=${1:?source dir}
build=${2:?release build dir}
work=${3:?work dir}

if [ ! -f "$build/CMakeCache.txt" ]; then
	echo "SKIP: no Release build at $build (tests/run.sh makes one; or"
	echo "configure one and set BLOBCAST_GPU_KIT_BUILD)"
	exit 77
fi
fail() {
	echo "FAIL: $*"
	exit 1
}
mkdir -p "$work"
rm -rf "$work/out" "$work/bad"

echo "== pack (from $build)"
bash "$src/bench/gpu/pack.sh" --build-dir "$build" --kit "$work/kit" \
	--ref-size 64 --jobs 2 || fail "pack.sh failed"
[ -s "$work/kit/kit.json" ] || fail "no kit.json"
[ "$(find "$work/kit/scenes" -name '*.ref' | wc -l)" -ge 10 ] ||
	fail "fewer than 10 reference scenes"

echo "== run.sh --local (env -i)"
env -i PATH=/usr/bin:/bin bash "$src/bench/gpu/run.sh" --local \
	--kit "$work/kit" --out "$work/out" || {
	cat "$work/out/results.md" 2>/dev/null || true
	fail "run.sh --local failed"
}
res="$work/out/results.json"
for f in results.json results.md run.log; do
	[ -s "$work/out/$f" ] || fail "$f missing"
done

drv="$work/kit/bin/bench_gpu"
lp="$work/kit/lib"
env -i LD_LIBRARY_PATH="$lp" "$drv" verify "$res" --min-scenes 10 ||
	fail "results.json does not verify"
# The same facts, counted without the driver.
correct=$(grep -o '"correct":true' "$res" | wc -l)
[ "$correct" -ge 10 ] || fail "$correct scenes correct, 10 expected"
! grep -q '"correct":false' "$res" || fail "a scene is not correct"
for step in loaders libs info check table2 edit daemon bench_gl bigview; do
	grep -q "\"$step\":{\"ran\":true,\"ok\":true" "$res" ||
		fail "step $step did not run and succeed"
done
grep -q '"exact":true' "$res" || fail "the edit step's regions are not exact"
# The big view's scene was drawn in bands (its limit lowered here).
grep -Eq '"scene":"fig18 spheres smooth 64",[^}]*"bands":([2-9]|[1-9][0-9]+)[,}]' "$res" ||
	fail "the bigview step drew no view in bands"
grep -q '"gl_renderer":"[^"]' "$res" || fail "no GL_RENDERER in results.json"

echo "== the checks can fail"
mkdir -p "$work/bad"
cp "$work/kit/scenes"/gears-24.json "$work/kit/scenes"/default.ref "$work/bad/"
mv "$work/bad/default.ref" "$work/bad/gears-24.ref"
if env -i LD_LIBRARY_PATH="$lp" HOME="$work" \
	"$drv" check --dir "$work/bad" --json "$work/bad/check.json" \
	>/dev/null 2>&1; then
	fail "check accepted another scene's reference"
fi
grep -q '"correct":false' "$work/bad/check.json" ||
	fail "check did not mark the wrong scene incorrect"
sed '0,/"ok":true/s//"ok":false/' "$res" >"$work/bad/results.json"
if env -i LD_LIBRARY_PATH="$lp" "$drv" verify "$work/bad/results.json" \
	>/dev/null 2>&1; then
	fail "verify accepted a failed step"
fi
echo "== --only runs the steps named, and says so of the others"
env -i PATH=/usr/bin:/bin bash "$src/bench/gpu/run.sh" --local \
	--kit "$work/kit" --out "$work/only" --only edit --edit-counts 64 \
	>"$work/only.log" 2>&1 || fail "run.sh --only edit failed"
grep -q '"edit":{"ran":true,"ok":true' "$work/only/results.json" ||
	fail "--only edit did not run the edit step"
! grep -q '"check":{"ran":true' "$work/only/results.json" ||
	fail "--only edit ran the check step"
grep -q "check: left out (--only edit)" "$work/only.log" ||
	fail "--only did not say what it left out"
grep -q "spheres smooth *64:" "$work/only.log" ||
	fail "--edit-counts 64 was not the edit step's size"
if env -i PATH=/usr/bin:/bin bash "$src/bench/gpu/run.sh" --local \
	--kit "$work/kit" --out "$work/only2" --only tabel2 >/dev/null 2>&1; then
	fail "run.sh accepted an unknown step in --only"
fi
echo "PASS: every step ran, $correct scenes correct"
