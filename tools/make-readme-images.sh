#!/usr/bin/env bash
# Renders the pictures of the README and docs/ (docs/images/) from the shipped scenes.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/make-readme-images.sh
Re-renders the pictures of the README and docs/ (docs/images/*.png) from the shipped scenes with crumple-sim.
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "" "$@"
cd "$(dirname "$0")/.."
cmake --build build -j"$(nproc)" --target crumple-sim >/dev/null
tmp=$(mktemp -d)
mkdir -p docs/images
shoot() {  # scene camera frame-seconds [picture name]
  local scene=$1 camera=$2 at=$3 name=${4:-$1}
  build/apps/crumple-sim "scenes/$scene.json" --out "$tmp/$scene" --render --fps 2 --size 640x360 --duration "$at" -q
  local last
  last=$(ls "$tmp/$scene/frames/${camera}"_*.png | tail -1)
  cp "$last" "docs/images/$name.png"
  rm -rf "$tmp/$scene"
}
shoot highway side 3.5
shoot highway torn 4.5 highway-rail
# The car's crease in its height map: the per-texel gather (left) and the paper's scatter (right).
for path in gather scatter; do
  build/apps/crumple-sim scenes/highway.json --out "$tmp/dent-$path" --duration 2.5 --deform-path $path -q
done
tools/dent-view.py "$tmp/dent-gather/heightmaps/car.png" --compare "$tmp/dent-scatter/heightmaps/car.png" --k 0.2 \
  --crop 0,1115,190,1250 --scale 2 --png docs/images/highway-dent-gather-vs-scatter.png
shoot sphere-into-plate main 1.5
shoot pattern-box wall 3
shoot pyramid front 2
shoot arch main 5
shoot card-house main 10
shoot brick-wall front 5
shoot mixed-pile main 3
shoot tank-tracks side 4
# The ball on a plane that looks flat: a strobe of its first 3 s (every 0.5 s) shows it rolling down the
# slope that exists only in the bump map.
build/apps/crumple-sim scenes/bump-ramp.json --out "$tmp/bump-ramp" --render --fps 4 --size 640x360 --duration 3 -q
tools/strobe.py docs/images/bump-ramp.png $(ls "$tmp"/bump-ramp/frames/main_*.png | awk 'NR % 2 == 1')
# The cow stands in its prints: beside the frame, the turf's height map under it (four hoof prints).
build/apps/crumple-sim scenes/cow-drop.json --out "$tmp/cow-drop" --render --fps 2 --size 640x360 --duration 2 -q
tools/dent-view.py "$tmp/cow-drop/heightmaps/ground.png" --crop 196,168,316,347 --scale 2 --png "$tmp/cow-turf.png"
tools/side-by-side.py docs/images/cow-drop.png "$(ls "$tmp"/cow-drop/frames/main_*.png | tail -1)" "$tmp/cow-turf.png"
build/apps/crumple-sim scenes/crater-marbles.json --out "$tmp/crater-marbles" --render --fps 1 --size 960x540 -q
cp "$(ls "$tmp"/crater-marbles/frames/main_*.png | tail -1)" docs/images/crater-marbles-above.png
cp "$(ls "$tmp"/crater-marbles/frames/low_*.png | tail -1)" docs/images/crater-marbles.png
shoot car-doors main 3
shoot wrecking-ball main 1.3
shoot wrecking-ball wall 2.4 wrecking-ball-dent
shoot ragdoll main 0.4
shoot chain-bridge main 1.5
shoot crate-drop main 2
# A dented edge under POM alone (left) and with displacement (right): the default scene's ball dropped on the
# plate's edge, seen along it (crumple-sim --displace).
for mode in pom displace; do
  build/apps/crumple-sim scenes/sphere-into-plate.json --out "$tmp/edge-$mode" --render --fps 2 --size 640x360 \
    --duration 1.5 -q $([ $mode = displace ] && echo --displace) \
    --set 'bodies[ball].position=[1.02,0.6,0.0]' --set 'bodies[ball].velocity=[0.3,-9,0]' \
    --set 'materials.clay.kappa=0.0002' --set 'cameras[main].position=[1.12,0.06,0.9]' \
    --set 'cameras[main].target=[0.98,-0.01,-0.1]' --set 'cameras[main].fov=30'
done
tools/side-by-side.py docs/images/displace-edge.png "$tmp/edge-pom/frames/main_00003.png" \
  "$tmp/edge-displace/frames/main_00003.png"
rm -rf "$tmp"
ls -la docs/images
