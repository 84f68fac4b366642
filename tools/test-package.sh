#!/usr/bin/env bash
# crumple as another project uses it: installs a build into a temporary prefix, builds apps/examples
# against it (find_package(crumple)) and runs them, and compiles hello-physics through pkg-config.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/test-package.sh [BUILD]
Installs the build folder BUILD (default: build) with `cmake --install` into a temporary prefix, builds
apps/examples against it as a project of its own (find_package(crumple)) and runs hello-physics,
hello-dent (headless OpenGL: llvmpipe without a GPU) and embed-loop; then builds hello-physics with
`pkg-config crumple`. The prefix is removed at the end. Called by tools/test.sh.
USAGE
}
case "${1:-}" in
  -h | --help) usage; exit 0 ;;
  -*) echo "$(basename "$0"): unknown argument '$1'" >&2; usage >&2; exit 2 ;;
esac
[ $# -le 1 ] || { usage >&2; exit 2; }
cd "$(dirname "$0")/.."
build="${1:-build}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
prefix="$tmp/prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
cmake -S apps/examples -B "$tmp/build" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$tmp/build" -j2
for example in hello-physics hello-dent embed-loop; do
  echo "== $example"
  "$tmp/build/$example"
done
echo "== hello-physics through pkg-config"
export PKG_CONFIG_PATH="$(dirname "$(find "$prefix" -name crumple.pc)")"
# shellcheck disable=SC2046
g++ -std=c++20 -O1 apps/examples/hello_physics.cpp -o "$tmp/hello-physics-pc" $(pkg-config --cflags --libs crumple)
"$tmp/hello-physics-pc" | tail -1
if [ -x "$prefix/bin/crumple-sweep" ]; then
  echo "== the Python module and crumple-sweep, installed"
  python="$(head -1 "$prefix/bin/crumple-sweep" | cut -c3-)"
  PYTHONPATH="$(dirname "$(dirname "$(find "$prefix" -name '_crumple*.so')")")" "$python" -c \
    'import crumple; s = crumple.Simulation(overrides={"duration": 0.1}); s.run(); print("dent", 0.5 - s.height_map("plate").min())'
  "$prefix/bin/crumple-sweep" --help >/dev/null
fi
echo "test-package: the installed package builds and runs the examples"
