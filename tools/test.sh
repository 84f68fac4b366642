#!/usr/bin/env bash
# Sets up (Debian packages), builds and runs the whole test suite with ctest.
# Usage: tools/test.sh [--sanitize]
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/test.sh [--sanitize]
Installs the Debian packages (tools/setup-deps.sh), builds into build/ and runs every test suite with
ctest under Xvfb, then builds and runs apps/examples against an install of it (tools/test-package.sh) and runs
the Python suites against a pip install in a fresh virtual environment (tools/test-pip.sh).
With CI=true (.ci/run sets it) it also fuzzes the loaders and the physics for about two minutes (tools/fuzz.sh, build-fuzz/).
--sanitize builds into build-asan/ with address and undefined-behaviour sanitizers (no package check).
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "--sanitize" "$@"
cd "$(dirname "$0")/.."
build=build
extra=()
if [ "${1:-}" = "--sanitize" ]; then
  build=build-asan
  extra=(-DCRUMPLE_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo)
  export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=0"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  export LSAN_OPTIONS="suppressions=$(pwd)/tools/lsan.supp"
fi
tools/setup-deps.sh
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo "${extra[@]}" >/dev/null
cmake --build "$build" -j"$(nproc)"
# Tests that need a window run under a virtual X server.
cd "$build"
xvfb-run -a -s "-screen 0 1280x720x24" ctest --output-on-failure -j"$(nproc)"
# The installed package, as another project uses it (apps/examples built against a temporary install).
if [ "$build" = build ]; then
  cd ..
  tools/test-package.sh "$build"
  tools/test-pip.sh
  # In CI, a short fuzzing run of the scene loader, each mesh reader and the physics (clang's libFuzzer, build-fuzz/; about
  # two minutes of fuzzing, after its build).
  if [ "${CI:-}" = true ]; then
    tools/fuzz.sh --seed 1
  fi
fi
