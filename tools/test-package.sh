#!/usr/bin/env bash
# crumple as another project uses it: installs a build into a temporary prefix, builds apps/examples
# against it (find_package(crumple)) and runs them, and compiles hello-physics through pkg-config.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/test-package.sh [BUILD]
Installs the build folder BUILD (default: build) with `cmake --install` into a temporary prefix, builds
apps/examples against it as a project of its own (find_package(crumple)) and runs hello-physics,
hello-dent (headless OpenGL: llvmpipe without a GPU) and embed-loop; builds a project whose own physics/ and
engine/ headers come first on its include path (crumple's are <crumple/...>); a physics-only project
(COMPONENTS physics) with every GL dependency made unfindable, whose hello-physics must stay under 2 MB (no
debug info installed); then hello-physics with `pkg-config crumple-physics` and `pkg-config crumple`. The prefix is removed at the end. Called by tools/test.sh.
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
echo "== a project with its own physics/ and engine/ headers, first on its include path"
mkdir -p "$tmp/clash/physics" "$tmp/clash/engine"
cat > "$tmp/clash/physics/mesh.h" <<'EOF2'
#pragma once
namespace game { struct Mesh { int triangles = 12; }; }  // the game's own, not crumple's
EOF2
cat > "$tmp/clash/engine/scene.h" <<'EOF2'
#pragma once
namespace game { struct Scene { const char* name = "level 1"; }; }
EOF2
cat > "$tmp/clash/main.cpp" <<'EOF2'
#include "engine/scene.h"
#include "physics/mesh.h"
#include <crumple/engine/scene.h>
#include <crumple/physics/world.h>
#include <cstdio>
int main() {
  crumple::World world;
  crumple::BodyDef box;
  box.shape = crumple::makeBox({1, 1, 1});
  world.addBody(box);
  world.step(1.0 / 60);
  crumple::Scene scene;
  std::printf("%s: %d triangles; crumple: %zu body, scene '%s'\n", game::Scene{}.name, game::Mesh{}.triangles,
              world.size(), scene.name.c_str());
}
EOF2
cat > "$tmp/clash/CMakeLists.txt" <<'EOF2'
cmake_minimum_required(VERSION 3.20)
project(clash LANGUAGES CXX)
find_package(crumple REQUIRED)
add_executable(clash main.cpp)
target_include_directories(clash BEFORE PRIVATE "${CMAKE_CURRENT_SOURCE_DIR}")
target_link_libraries(clash PRIVATE crumple::engine)
EOF2
cmake -S "$tmp/clash" -B "$tmp/clash-build" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$tmp/clash-build" -j2 >/dev/null
"$tmp/clash-build/clash"
echo "== a physics-only project (COMPONENTS physics) on a machine without crumple's GL dependencies"
mkdir -p "$tmp/physics-only"
cp apps/examples/hello_physics.cpp "$tmp/physics-only/"
cat > "$tmp/physics-only/CMakeLists.txt" <<'EOF2'
cmake_minimum_required(VERSION 3.20)
project(physics-only LANGUAGES CXX)
find_package(crumple REQUIRED COMPONENTS physics)
add_executable(hello-physics hello_physics.cpp)
target_link_libraries(hello-physics PRIVATE crumple::physics)
EOF2
# Every package the engine component needs made unfindable (CMake's and pkg-config's): the physics component
# configures; asking for the engine component the same way must not (else the packages were not hidden).
hidden=(-DCMAKE_DISABLE_FIND_PACKAGE_nlohmann_json=ON -DCMAKE_DISABLE_FIND_PACKAGE_TinyGLTF=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_ZLIB=ON -DCMAKE_DISABLE_FIND_PACKAGE_meshoptimizer=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=ON --no-warn-unused-cli)
PKG_CONFIG_PATH=/nonexistent PKG_CONFIG_LIBDIR=/nonexistent cmake -S "$tmp/physics-only" -B "$tmp/physics-only-build" \
  -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release "${hidden[@]}" >/dev/null
cmake --build "$tmp/physics-only-build" -j2 >/dev/null
sed 's/COMPONENTS physics/COMPONENTS physics engine/' "$tmp/physics-only/CMakeLists.txt" > "$tmp/physics-only/c"
mkdir -p "$tmp/engine-hidden" && mv "$tmp/physics-only/c" "$tmp/engine-hidden/CMakeLists.txt"
cp apps/examples/hello_physics.cpp "$tmp/engine-hidden/"
if PKG_CONFIG_PATH=/nonexistent PKG_CONFIG_LIBDIR=/nonexistent cmake -S "$tmp/engine-hidden" \
  -B "$tmp/engine-hidden-build" -DCMAKE_PREFIX_PATH="$prefix" "${hidden[@]}" >/dev/null 2>&1; then
  echo "test-package: the engine component configured with its packages hidden: the check proves nothing" >&2
  exit 1
fi
"$tmp/physics-only-build/hello-physics" | tail -1
size=$(stat -c %s "$tmp/physics-only-build/hello-physics")
echo "hello-physics against crumple::physics: $((size / 1024)) KiB"
if [ "$size" -ge $((2 * 1024 * 1024)) ]; then
  echo "test-package: hello-physics is over 2 MB: the installed libraries carry debug info" >&2
  exit 1
fi
echo "== hello-physics through pkg-config (crumple-physics)"
PKG_CONFIG_PATH="$(dirname "$(find "$prefix" -name crumple-physics.pc)")" g++ -std=c++20 -O1 \
  apps/examples/hello_physics.cpp -o "$tmp/hello-physics-pc-physics" \
  $(PKG_CONFIG_PATH="$(dirname "$(find "$prefix" -name crumple-physics.pc)")" pkg-config --cflags --libs crumple-physics)
"$tmp/hello-physics-pc-physics" | tail -1
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
