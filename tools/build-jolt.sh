#!/usr/bin/env bash
# Builds Jolt Physics outside the repository, for crumple-bench's Jolt rows (never needed by CI or the library).
#   tools/build-jolt.sh JOLT_SOURCE_DIR [INSTALL_PREFIX]
# JOLT_SOURCE_DIR: a checkout of https://github.com/jrouwe/JoltPhysics (the bench was measured with v5.5.0).
# Builds at -O3 (Jolt's Release) without its profiler and debug renderer, installs to INSTALL_PREFIX
# (default: JOLT_SOURCE_DIR/../jolt-install), then prints the cmake line that gives crumple-bench the Jolt rows.
set -euo pipefail
if [[ $# -lt 1 || "$1" == -h || "$1" == --help ]]; then
  sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'
  [[ $# -lt 1 ]] && exit 2 || exit 0
fi
src=$(cd "$1" && pwd)
[[ -f "$src/Build/CMakeLists.txt" ]] || { echo "build-jolt.sh: $src/Build/CMakeLists.txt: not a Jolt checkout" >&2; exit 2; }
prefix=${2:-$(dirname "$src")/jolt-install}
build=$(mktemp -d)
trap 'rm -rf "$build"' EXIT
cmake -S "$src/Build" -B "$build" -DCMAKE_BUILD_TYPE=Release -DDEBUG_RENDERER_IN_DEBUG_AND_RELEASE=OFF \
  -DPROFILER_IN_DEBUG_AND_RELEASE=OFF -DTARGET_UNIT_TESTS=OFF -DTARGET_HELLO_WORLD=OFF -DTARGET_PERFORMANCE_TEST=OFF \
  -DTARGET_SAMPLES=OFF -DTARGET_VIEWER=OFF -DJPH_ENABLE_VULKAN=OFF -DENABLE_ALL_WARNINGS=OFF \
  -DCMAKE_INSTALL_PREFIX="$prefix"
cmake --build "$build" -j"$(nproc)"
cmake --install "$build"
echo "Jolt installed in $prefix. Then: cmake -B build -DCRUMPLE_JOLT_DIR=$prefix && cmake --build build --target crumple-bench"
