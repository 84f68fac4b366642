#!/usr/bin/env bash
# One command for the physics figures against Jolt (docs/performance.md): builds Jolt outside the repository,
# builds crumple-bench against it and runs the physics rows.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/bench-vs-jolt.sh [--jolt DIR] [--repetitions N] [--quick] [--timeline] [--instructions]
Builds Jolt Physics from the checkout DIR (default ../JoltPhysics, cloned from GitHub when absent) with
tools/build-jolt.sh into ../jolt-install, configures crumple in build-bench-jolt/ (Release, with
CRUMPLE_JOLT_DIR), builds crumple-bench and runs its physics rows on one thread:
  crumple-bench --no-gl --threads 1 --thread-counts 1 --repetitions N --strict-peers   (default N: 2)
crumple is built for x86-64-v3 (AVX2, as Jolt's build is) where the CPU has it, else for the default x86-64.
It prints the machine, crumple's commit and each peer's configuration above the figures (Jolt's own configuration
string); a Jolt built with its profiler, debug renderer, asserts or without NDEBUG stops it with its WARNING
(exit 1: such figures must not be published). --quick: the smoke run. --timeline: crumple-bench's --timeline as
well (each engine's time per step over every 20 steps of each scene: where in the run the ratios come from).
--instructions: instead of timing, count each engine's instructions under valgrind's callgrind (crumple's
World::step, Jolt's PhysicsSystem::Update, the same binary, one thread) on the pyramid, the pile of 1000, the
heap, the tori and the chains: figures a busy machine does not move (needs valgrind; about ten minutes).
Nothing is installed outside ../JoltPhysics, ../jolt-install and build-bench-jolt/.
USAGE
}
jolt=
repetitions=2
quick=()
timeline=()
instructions=false
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
    --instructions) instructions=true; shift ;;
    *) echo "$(basename "$0"): unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
[[ "$repetitions" =~ ^[1-9][0-9]?$ ]] || { echo "$(basename "$0"): --repetitions takes 1 to 99" >&2; exit 2; }
if $instructions && ! command -v valgrind >/dev/null; then
  echo "$(basename "$0"): --instructions needs valgrind (Debian: apt-get install valgrind)" >&2
  exit 1
fi
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
# The compiler's own CPU check decides (GCC and Clang: __builtin_cpu_supports); /proc/cpuinfo's flags only where
# no probe builds: a virtual machine may run LZCNT yet hide its flag ("abm"), which a grep would take as no AVX2
# generation at all (crumple then built for the baseline against an AVX2 Jolt).
has_v3() {
  local probe rc=2
  probe=$(mktemp -d)
  printf '%s\n' 'int main() { __builtin_cpu_init(); return __builtin_cpu_supports("x86-64-v3") ? 0 : 1; }' >"$probe/v3.cpp"
  if "${CXX:-c++}" -o "$probe/v3" "$probe/v3.cpp" 2>/dev/null; then
    "$probe/v3" && rc=0 || rc=1
  fi
  rm -rf "$probe"
  [ "$rc" = 2 ] || return "$rc"
  local f
  for f in avx2 bmi2 f16c fma movbe abm; do grep -qw "$f" /proc/cpuinfo 2>/dev/null || return 1; done
}
march=
if has_v3; then
  march=-march=x86-64-v3
fi
echo "== building crumple-bench (commit $(git rev-parse --short HEAD)${march:+, $march}) against it"
quietly cmake -S . -B build-bench-jolt -DCMAKE_BUILD_TYPE=Release -DCRUMPLE_JOLT_DIR="$prefix" -DCRUMPLE_BUILD_TESTS=OFF \
  -DCMAKE_CXX_FLAGS="$march"
quietly cmake --build build-bench-jolt -j"$(nproc)" --target crumple-bench
echo "== crumple $(git rev-parse --short HEAD), Jolt $(git -C "$jolt" rev-parse --short HEAD 2>/dev/null || echo '?')"
bench=build-bench-jolt/apps/crumple-bench
if $instructions; then
  echo "== instructions: callgrind, one thread, each row's full run (crumple: World::step; Jolt: PhysicsSystem::Update)"
  out=$(mktemp -d)
  trap 'rm -f "$log"; rm -rf "$out"' EXIT
  # The instructions one engine's steps take on one row (filter: the row's benchmark name).
  count() {
    valgrind --tool=callgrind --callgrind-out-file="$out/cg" --toggle-collect="$1" \
      "$bench" --no-gl --threads 1 --thread-counts 1 --repetitions 1 --filter "$2" 2>&1 |
      sed -n 's/.*Collected : \([0-9]*\).*/\1/p' | tail -1
  }
  printf '%-28s %16s %16s %14s\n' scene crumple Jolt crumple/Jolt
  for row in pyramid20_210boxes pile_1000boxes heap_500mixed tori_200meshes chains_10x20links; do
    c=$(count 'crumple::World::step*' "crumple/$row")
    j=$(count 'JPH::PhysicsSystem::Update*' "jolt/$row")
    if [ -z "$c" ] || [ -z "$j" ] || [ "$j" = 0 ]; then
      echo "$(basename "$0"): no count for $row (crumple '${c}', Jolt '${j}')" >&2
      exit 1
    fi
    printf '%-28s %16s %16s %13sx\n' "$row" "$c" "$j" "$(awk -v c="$c" -v j="$j" 'BEGIN { printf "%.2f", c / j }')"
  done
  exit 0
fi
"$bench" --no-gl --threads 1 --thread-counts 1 --repetitions "$repetitions" --strict-peers "${quick[@]}" "${timeline[@]}"
