#!/usr/bin/env bash
# Fuzzes the scene loader and each mesh reader with clang's libFuzzer (tests/fuzz/), in build-fuzz/.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/fuzz.sh [--seconds N] [--parallel N] [--targets LIST] [--no-build]
Builds the libFuzzer targets of tests/fuzz/ with clang into build-fuzz/ (CRUMPLE_FUZZ=ON: ASan and UBSan), replays
every file of tests/fuzz/corpus/<target>/ once (the shipped scenes and assets, and every reproducer kept:
regression cases), then fuzzes each target for N seconds from that corpus.
  --seconds N    fuzzing time per target (default 15; CI runs the default: about two minutes in all)
  --parallel N   targets fuzzed at once (default 1)
  --targets LIST comma-separated, from scene,obj,off,ply,gltf,glb,physics (default all; physics: random
                 physics scenes checked against the step's invariants after every step, tests/physics_scenario.h)
  --seed N       libFuzzer's random seed (default: a new one each run); CI fuzzes with --seed 1, so that a
                 run of the same commit tries the same inputs in the same order
  --no-build     use the targets already in build-fuzz/
Inputs that reach new code go to build-fuzz/corpus/<target>/ (not the repository's corpus); a crash, a leak,
undefined behaviour, an input over 10 s (a physics scene: 60 s) or over 2 GB of memory is written to build-fuzz/findings/<target>/ and
makes the exit status 1 (replay one: build-fuzz/tests/fuzz/fuzz_<target> FILE; once fixed, keep it as
tests/fuzz/corpus/<target>/fuzz-<what>.<ext>, a regression case). Logs: build-fuzz/logs/.
A long run: tools/fuzz.sh --seconds 3600 --parallel 2 (docs/testing.md, "Fuzzing").
USAGE
}
seconds=15
parallel=1
targets="scene,obj,off,ply,gltf,glb,physics"
build=1
seed=
while [ $# -gt 0 ]; do
  case "$1" in
    -h | --help) usage; exit 0 ;;
    --seconds | --parallel | --targets | --seed)
      if [ $# -lt 2 ]; then
        echo "$(basename "$0"): $1 needs a value" >&2
        exit 2
      fi
      case "$1" in
        --seconds) seconds="$2" ;;
        --parallel) parallel="$2" ;;
        --targets) targets="$2" ;;
        --seed) seed="$2" ;;
      esac
      shift 2
      ;;
    --no-build) build=0; shift ;;
    *)
      echo "$(basename "$0"): unknown argument '$1'" >&2
      usage >&2
      exit 2
      ;;
  esac
done
if ! [[ "$seconds" =~ ^[1-9][0-9]*$ && "$parallel" =~ ^[1-9][0-9]*$ ]]; then
  echo "$(basename "$0"): --seconds and --parallel take whole numbers of at least 1" >&2
  exit 2
fi
if [ -n "$seed" ] && ! [[ "$seed" =~ ^[1-9][0-9]{0,8}$ ]]; then
  echo "$(basename "$0"): --seed takes a whole number from 1 to 999999999" >&2
  exit 2
fi
IFS=, read -r -a list <<<"$targets"
for t in "${list[@]}"; do
  case "$t" in
    scene | obj | off | ply | gltf | glb | physics) ;;
    *) echo "$(basename "$0"): unknown target '$t' (scene, obj, off, ply, gltf, glb, physics)" >&2; exit 2 ;;
  esac
done
cd "$(dirname "$0")/.."
root=$(pwd)
out=build-fuzz
bin="$out/tests/fuzz"

if [ "$build" = 1 ]; then
  if ! command -v clang++ >/dev/null; then
    echo "fuzz: clang++ not found (tools/setup-deps.sh installs clang and libFuzzer)" >&2
    exit 1
  fi
  # Only what the targets need: no apps, tests, window or install rules.
  cmake -S . -B "$out" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCRUMPLE_FUZZ=ON -DCRUMPLE_BUILD_TESTS=OFF -DCRUMPLE_BUILD_APPS=OFF -DCRUMPLE_INSTALL=OFF \
    -DCRUMPLE_WITH_GLFW=OFF >/dev/null
  cmake --build "$out" -j"$(nproc)" --target fuzz_targets
fi
mkdir -p "$out/logs"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# libFuzzer's limits: a run over 10 s is a hang, over 2 GB a blow-up. A physics scene is 120 steps of up to 16
# substeps each, its joints solved to their sweep limit in the worst case (about 1 s, 10 s under the sanitizers):
# 60 s for it.
limits_of() {
  if [ "$1" = physics ]; then echo "-timeout=60 -rss_limit_mb=2048"; else echo "-timeout=10 -rss_limit_mb=2048"; fi
}

# 1. Regression: every file of the corpus once, whole (a fuzzing run would cut the long ones to -max_len).
failed=0
for t in "${list[@]}"; do
  mapfile -t files < <(find "tests/fuzz/corpus/$t" -type f | sort)
  [ ${#files[@]} -gt 0 ] || continue
  start=$(date +%s%N)
  read -r -a limits <<<"$(limits_of "$t")"
  if "$bin/fuzz_$t" "${limits[@]}" "${files[@]}" >"$out/logs/$t-replay.log" 2>&1; then
    ms=$((($(date +%s%N) - start) / 1000000))
    printf 'fuzz: %-5s replayed %3d corpus files in %d.%d s: ok\n' "$t" "${#files[@]}" $((ms / 1000)) \
      $((ms % 1000 / 100))
  else
    echo "fuzz: $t: a corpus file fails (log: $out/logs/$t-replay.log):" >&2
    grep -E "ERROR|SUMMARY|Running:" "$out/logs/$t-replay.log" | tail -5 >&2
    failed=1
  fi
done

# 2. Fuzzing, from the repository's corpus; what is new goes to build-fuzz/corpus/<target>/.
fuzz_one() {
  local t=$1
  mkdir -p "$out/corpus/$t" "$out/findings/$t"
  local dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  local limits
  read -r -a limits <<<"$(limits_of "$t")"
  if [ -n "$seed" ]; then limits+=(-seed="$seed"); fi
  "$root/$bin/fuzz_$t" "${limits[@]}" -max_total_time="$seconds" -max_len=16384 "${dict[@]}" \
    -artifact_prefix="$out/findings/$t/" -print_final_stats=1 "$out/corpus/$t" "tests/fuzz/corpus/$t" \
    >"$out/logs/$t.log" 2>&1
}
summary() {
  local t=$1 rc=$2 runs
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$out/logs/$t.log" | tail -1)
  if [ "$rc" = 0 ]; then
    printf 'fuzz: %-5s %8s runs in %s s, corpus %s files: no crash\n' "$t" "${runs:-?}" "$seconds" \
      "$(find "$out/corpus/$t" "tests/fuzz/corpus/$t" -type f | wc -l)"
  else
    echo "fuzz: $t FAILED after ${runs:-?} runs: $(ls "$out/findings/$t" | head -3 | tr '\n' ' ')(log: $out/logs/$t.log)" >&2
    grep -E "ERROR|SUMMARY|runtime error" "$out/logs/$t.log" | head -5 >&2
    failed=1
  fi
}
running=()
for t in "${list[@]}"; do
  fuzz_one "$t" &
  running+=("$t:$!")
  if [ ${#running[@]} -ge "$parallel" ]; then
    entry=${running[0]}
    running=("${running[@]:1}")
    rc=0
    wait "${entry#*:}" || rc=$?
    summary "${entry%%:*}" "$rc"
  fi
done
for entry in "${running[@]}"; do
  rc=0
  wait "${entry#*:}" || rc=$?
  summary "${entry%%:*}" "$rc"
done
exit "$failed"
