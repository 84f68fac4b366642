#!/usr/bin/env bash
# Renders the pictures of the README (docs/images/) from the shipped scenes.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/make-readme-images.sh
Re-renders the README's pictures (docs/images/*.png) from the shipped scenes with crumple-sim.
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "" "$@"
cd "$(dirname "$0")/.."
cmake --build build -j"$(nproc)" --target crumple-sim >/dev/null
tmp=$(mktemp -d)
mkdir -p docs/images
shoot() {  # scene camera frame-seconds
  local scene=$1 camera=$2 at=$3
  build/apps/crumple-sim "scenes/$scene.json" --out "$tmp/$scene" --render --fps 2 --size 640x360 --duration "$at" -q
  local last
  last=$(ls "$tmp/$scene/frames/${camera}"_*.png | tail -1)
  cp "$last" "docs/images/$scene.png"
}
shoot highway rail 6
shoot sphere-into-plate main 1.5
shoot pattern-box wall 3
shoot pyramid front 2
shoot brick-wall front 5
shoot mixed-pile main 3
shoot tank-tracks side 4
shoot bump-ramp main 1.5
shoot cow-drop main 2
rm -rf "$tmp"
ls -la docs/images
