#!/usr/bin/env bash
# Sets up, builds and runs the built-in default scene with rendered frames.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j"$(nproc)" --target crumple-sim
build/apps/crumple-sim --out out/sphere-into-plate --render "$@"
echo "Look at out/sphere-into-plate/frames/ and out/sphere-into-plate/heightmaps/plate.png"
