#!/usr/bin/env bash
# Installs every Debian package crumple needs to build, test, benchmark, fuzz (clang, its libFuzzer and
# sanitizer runtimes, llvm-symbolizer) and run.
# Idempotent: packages already present are skipped; `apt-get update` runs once
# only when something is missing.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/setup-deps.sh
Installs the Debian packages crumple needs to build, test, benchmark and run (apt-get, with sudo when not
root). Idempotent: does nothing when all are present.
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

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup-deps: done"
