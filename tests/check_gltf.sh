#!/usr/bin/env bash
# ctest gltf_validator: crumple-sim --export gltf of three shipped scenes (the default scene, the highway past its
# crash with --animate, the wrecking ball's baked clay and concrete textures) through the Khronos glTF validator: 0 errors and 0 warnings. Skipped (exit 77) where node is
# missing, or the validator (npm could not fetch it).
# Usage: check_gltf.sh CRUMPLE_SIM SCENES_DIR
set -euo pipefail
sim=$1 scenes=$2
here=$(cd "$(dirname "$0")" && pwd)
if ! command -v node > /dev/null; then
  echo "check_gltf: node is not installed (tools/setup-deps.sh installs nodejs): the exports are not validated"
  exit 77
fi
if [ ! -f "$here/../.cache/gltf-validator/node_modules/gltf-validator/package.json" ]; then
  echo "check_gltf: the Khronos glTF validator is not installed (tools/setup-deps.sh installs it with npm, which needs"
  echo "the npm registry): the exports are not validated"
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$sim" "$scenes/sphere-into-plate.json" --steps 60 --quiet --export gltf --out "$tmp/plate"
"$sim" "$scenes/highway.json" --steps 720 --quiet --export gltf --animate --out "$tmp/highway"
"$sim" "$scenes/wrecking-ball.json" --steps 2 --quiet --export gltf --out "$tmp/wrecking"
node "$here/validate_gltf.js" "$tmp/plate/export/scene.gltf" "$tmp/highway/export/scene.gltf" \
  "$tmp/wrecking/export/scene.gltf"
