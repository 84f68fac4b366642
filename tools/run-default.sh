#!/usr/bin/env bash
# Sets up, builds and runs the built-in default scene with rendered frames.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/run-default.sh [crumple-sim options]
Installs the packages, builds crumple-sim and runs the built-in default scene (a steel ball into a clay
plate) with rendered frames into out/sphere-into-plate/. Further options go to crumple-sim
(build/apps/crumple-sim --help lists them).
USAGE
}
case "${1:-}" in  # anything else goes to crumple-sim
  -h | --help) usage; exit 0 ;;
esac
cd "$(dirname "$0")/.."
tools/setup-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j"$(nproc)" --target crumple-sim
build/apps/crumple-sim --out out/sphere-into-plate --render "$@"
echo "Look at out/sphere-into-plate/frames/ and out/sphere-into-plate/heightmaps/plate.png"
