#!/usr/bin/env bash
# Rewrites the renderer's golden images (tests/golden/*.png) on purpose, after a
# deliberate change to the renderer. Look at them before committing.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/update-golden.sh
Rewrites the renderer's golden images (tests/golden/*.png) on purpose, after a deliberate change to the
renderer; look at them before committing.
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "" "$@"
cd "$(dirname "$0")/.."
cmake --build build -j"$(nproc)" --target test_render_pom
CRUMPLE_UPDATE_GOLDEN=1 build/tests/test_render_pom --test-case="golden*"
git status --short tests/golden
