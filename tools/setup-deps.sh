#!/usr/bin/env bash
# Installs every Debian package crumple needs to build, test, benchmark, fuzz (clang, its libFuzzer and
# sanitizer runtimes, llvm-symbolizer) and run, and the one tool that exists only as an npm package (the Khronos
# glTF validator).
# Idempotent: packages already present are skipped; `apt-get update` runs once
# only when something is missing.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/setup-deps.sh
Installs the Debian packages crumple needs to build, test, benchmark and run (apt-get, with sudo when not
root), and the Khronos glTF validator (npm) into .cache/gltf-validator/. Idempotent: does nothing when all are
present.
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "" "$@"

PACKAGES=(
  build-essential cmake pkg-config git
  zlib1g-dev libglm-dev libtinygltf-dev nlohmann-json3-dev libstb-dev libmeshoptimizer-dev
  libglfw3-dev libepoxy-dev libegl-dev libopengl-dev libgl-dev
  libegl-mesa0 libgl1-mesa-dri mesa-utils
  doctest-dev libcli11-dev libimgui-dev
  libbullet-dev libbenchmark-dev
  python3-dev pybind11-dev python3-numpy python3-distributed python3-venv python3-pip python3-setuptools python3-wheel python3-matplotlib
  xvfb xauth
  clang libclang-rt-dev llvm
)
# node and npm (for the glTF validator): Debian's, unless the machine has them already (NodeSource's nodejs
# bundles npm and conflicts with Debian's npm package).
command -v node > /dev/null || PACKAGES+=(nodejs)
command -v npm > /dev/null || PACKAGES+=(npm)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup-deps: all ${#PACKAGES[@]} packages present"
else
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "setup-deps: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  echo "setup-deps: done"
fi

# The Khronos glTF validator exists only as an npm package: into .cache/gltf-validator/ (the project's own
# folder, ignored by git; the test gltf_validator runs it on crumple-sim's exports).
VALIDATOR_VERSION=2.0.0-dev.3.10
validator="$(dirname "$0")/../.cache/gltf-validator"
if ! grep -qs "\"version\": \"$VALIDATOR_VERSION\"" "$validator/node_modules/gltf-validator/package.json"; then
  echo "setup-deps: installing gltf-validator $VALIDATOR_VERSION (npm) into .cache/gltf-validator"
  mkdir -p "$validator"
  if ! npm install --silent --no-audit --no-fund --prefix "$validator" "gltf-validator@$VALIDATOR_VERSION" >/dev/null; then
    echo "setup-deps: WARNING: npm could not install gltf-validator (no registry?): the test gltf_validator is skipped" >&2
  fi
fi
