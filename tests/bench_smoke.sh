#!/usr/bin/env bash
# Smoke run of crumple-bench --quick (small scenes, few iterations: 5 physics cases): it must
# finish and print every ratio line with numbers, and both engines' end states.
# It asserts nothing about the figures themselves: speed is for the full bench.
set -euo pipefail
bench=$1
out=$("$bench" --quick)
echo "$out" | sed -n '/== ratios ==/,$p'
expect() {  # count regex what
  local n
  n=$(echo "$out" | grep -cE "$2" || true)
  if [ "$n" -ne "$1" ]; then echo "bench_smoke: expected $1 $3 lines, found $n" >&2; exit 1; fi
}
expect 1 '^cpu: .+, [0-9]+ hardware threads$' "machine"
expect 1 '^crumple [0-9]+\.[0-9]+\.[0-9]+: its physics library at -O3( with link-time optimisation)? \(CMake build type [^)]*\), instructions: SSE2( [A-Z0-9.]+)* \(never FMA\)$' "crumple build"
expect 1 '^bullet: ' "bullet build"
expect 5 '^physics .* crumple/bullet +[0-9]+\.[0-9]+x$' "physics ratio"
expect 5 '^ +at the end: crumple +[0-9]+ awake, top centre [0-9.]+ m; bullet +[0-9]+ awake, top centre [0-9.]+ m$' "end-state"
expect 4 '^deform +address map +[0-9]+ +gather +[0-9.]+ ms +scatter +[0-9.]+ ms +readback +[0-9.]+ ms +gather/scatter +[0-9.]+x +readback/scatter +[0-9.]+x$' "deform ratio"
expect 2 '^deform +address map +[0-9]+ +gather, address pass in compute +[0-9.]+ ms \(GPU +[0-9.]+\) +in the fragment stage +[0-9.]+ ms \(GPU +[0-9.]+\) +compute/fragment +[0-9.]+x \(GPU +[0-9.]+x\)$' "address-raster ratio"
expect 2 '^deform +deform/gather_(compute|fragment)_100events/1024 +[0-9.]+ ms +\(GPU +[0-9.]+ ms, [0-9]+ waves\)$' "batch"
expect 1 '^render +1280x720 +pom +[0-9.]+ ms/frame +no parallax +[0-9.]+ ms/frame +pom/none +[0-9.]+x$' "render ratio"
expect 1 '^render +1280x720 +ibl +[0-9.]+ ms/frame +no ibl +[0-9.]+ ms/frame +ibl/none +[0-9.]+x$' "IBL ratio"
expect 1 '^render +1280x720 +fxaa +[0-9.]+ ms/frame +no aa +[0-9.]+ ms/frame +fxaa/none +[0-9.]+x$' "FXAA ratio"
expect 1 '^render +1280x720 +msaa4 +[0-9.]+ ms/frame +no aa +[0-9.]+ ms/frame +msaa/none +[0-9.]+x +msaa/fxaa +[0-9.]+x$' "MSAA ratio"
expect 1 '^render +1280x720 +displace +[0-9.]+ ms/frame +pom alone +[0-9.]+ ms/frame +displace/pom +[0-9.]+x$' "displacement ratio"
expect 1 '^render +1280x720 +simplified meshes +[0-9.]+ ms/frame +full +[0-9.]+ ms/frame +simplified/full +[0-9.]+x$' "simplified ratio"
expect 1 '^render +sandbox view 336x189 .* +[0-9.]+ ms/frame +\([0-9.]+ frames/s of rendering\)$' "sandbox view"
expect 5 '^threads +pile_[0-9]+boxes +[0-9]+ threads +[0-9.]+ ms/step +speedup over 1 +[0-9.]+x$' "thread-count"
expect 1 '^ +pile_[0-9]+boxes: every thread count ended in the same bits \(state hash\)$' "same-bits"
expect 5 '^ +crumple end state hash [0-9a-f]{16}$' "end state hash"
if echo "$out" | grep -qi nan; then echo "bench_smoke: a figure is NaN" >&2; exit 1; fi
# --timeline: the pile's 24 steps in windows of 6, each engine's ms per step and bodies awake, then the whole run.
out=$("$bench" --quick --no-gl --filter 'crumple/pile' --timeline)
echo "$out" | sed -n '/^timeline/,$p'
expect 1 '^timeline pile_[0-9]+boxes: ms per step ' "timeline"
expect 4 '^  [0-9]+-[0-9]+ +[0-9.]+ \([0-9]+\) +[0-9.]+ \([0-9]+\)' "timeline window"
expect 1 '^  all +[0-9.]+ +[0-9.]+' "timeline total"
# A filter that matches nothing is an error (exit 2), not a table of NaN.
set +e
"$bench" --quick --no-gl --filter 'no-such-benchmark' >/dev/null 2>&1
rc=$?
set -e
if [ "$rc" -ne 2 ]; then echo "bench_smoke: --filter with no match exited $rc, expected 2" >&2; exit 1; fi
