#!/usr/bin/env bash
# One command for the physics figures against Jolt (docs/performance.md): builds Jolt outside the repository,
# builds crumple-bench against it and runs the physics rows.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/bench-vs-jolt.sh [--jolt DIR] [--repetitions N] [--quick] [--timeline]
Builds Jolt Physics from the checkout DIR (default ../JoltPhysics, cloned from GitHub when absent) with
tools/build-jolt.sh into ../jolt-install, configures crumple in build-bench-jolt/ (Release, with
CRUMPLE_JOLT_DIR), builds crumple-bench and runs its physics rows on one thread:
  crumple-bench --no-gl --threads 1 --thread-counts 1 --repetitions N --strict-peers   (default N: 2)
crumple is built for x86-64-v3 (AVX2, as Jolt's build is) where the CPU has it, else for the default x86-64.
It prints the machine, crumple's commit and each peer's configuration above the figures (Jolt's own configuration
string); a Jolt built with its profiler, debug renderer, asserts or without NDEBUG stops it with its WARNING
(exit 1: such figures must not be published). --quick: the smoke run. --timeline: crumple-bench's --timeline as
well (each engine's time per step over every 20 steps of each scene: where in the run the ratios come from).
Nothing is installed outside ../JoltPhysics, ../jolt-install and build-bench-jolt/.
USAGE
}
jolt=
repetitions=2
quick=()
timeline=()
while [ $# -gt 0 ]; do
  case "$1" in
    -h | --help) usage; exit 0 ;;
    --jolt | --repetitions)
      [ $# -ge 2 ] || { echo "$(basename "$0"): $1 needs a value" >&2; exit 2; }
      if [ "$1" = --jolt ]; then jolt="$2"; else repetitions="$2"; fi
      shift 2
      ;;
    --quick) quick=(--quick); shift ;;
    --timeline) timeline=(--timeline); shift ;;
    *) echo "$(basename "$0"): unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
[[ "$repetitions" =~ ^[1-9][0-9]?$ ]] || { echo "$(basename "$0"): --repetitions takes 1 to 99" >&2; exit 2; }
cd "$(dirname "$0")/.."
root=$(pwd)
jolt=${jolt:-$(dirname "$root")/JoltPhysics}
if [ ! -f "$jolt/Build/CMakeLists.txt" ]; then
  echo "== cloning Jolt Physics into $jolt"
  git clone --depth 1 https://github.com/jrouwe/JoltPhysics "$jolt"
fi
prefix=$(dirname "$root")/jolt-install
echo "== building Jolt ($(git -C "$jolt" describe --tags --always 2>/dev/null || echo 'no git')) into $prefix"
# The builds' output goes to a log, shown only when a build fails (a Release build's compiler notes are not the
# figures' business).
log=$(mktemp)
trap 'rm -f "$log"' EXIT
quietly() {
  if ! "$@" >"$log" 2>&1; then
    cat "$log" >&2
    echo "$(basename "$0"): failed: $*" >&2
    exit 1
  fi
}
quietly tools/build-jolt.sh "$jolt" "$prefix"
# Jolt's build uses the CPU's AVX2 generation (its CMake defaults); crumple gets the same instruction sets where
# the CPU has them (x86-64-v3; crumple never fuses multiply-adds, whatever the level: the same bits either way).
march=
if grep -qw avx2 /proc/cpuinfo 2>/dev/null && grep -qw bmi2 /proc/cpuinfo && grep -qw f16c /proc/cpuinfo &&
  grep -qw fma /proc/cpuinfo && grep -qw movbe /proc/cpuinfo && grep -qw abm /proc/cpuinfo; then
  march=-march=x86-64-v3
fi
echo "== building crumple-bench (commit $(git rev-parse --short HEAD)${march:+, $march}) against it"
quietly cmake -S . -B build-bench-jolt -DCMAKE_BUILD_TYPE=Release -DCRUMPLE_JOLT_DIR="$prefix" -DCRUMPLE_BUILD_TESTS=OFF \
  -DCMAKE_CXX_FLAGS="$march"
quietly cmake --build build-bench-jolt -j"$(nproc)" --target crumple-bench
echo "== crumple $(git rev-parse --short HEAD), Jolt $(git -C "$jolt" rev-parse --short HEAD 2>/dev/null || echo '?')"
build-bench-jolt/apps/crumple-bench --no-gl --threads 1 --thread-counts 1 --repetitions "$repetitions" --strict-peers "${quick[@]}" "${timeline[@]}"
