#!/usr/bin/env bash
# pip install . into a fresh virtual environment (with the system's site packages: Debian's numpy and
# distributed) and runs the Python suites against what it installed, from outside the source tree.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/test-pip.sh
Makes a virtual environment with --system-site-packages in a temporary folder, installs crumple into it with
`pip install --no-build-isolation .` (CMake builds into build-pip/), checks that `import crumple` finds the
installed package, and runs the python and sweep suites with that environment's python and crumple-sweep.
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "" "$@"
cd "$(dirname "$0")/.."
root=$(pwd)
venv=$(mktemp -d)
trap 'rm -rf "$venv"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$venv"
"$venv/bin/python" -m pip install --quiet --no-build-isolation --no-deps "$root"
cd "$venv"  # away from the sources: the installed package must be the one imported
"$venv/bin/python" - <<'PY'
import os, sys, crumple
where = os.path.dirname(crumple.__file__)
assert where.startswith(sys.prefix), f"crumple imported from {where}, not the environment {sys.prefix}"
assert os.access(os.path.join(where, "bin", "crumple-sim"), os.X_OK), "no packaged crumple-sim"
print(f"test-pip: crumple {crumple.__version__} from {where}")
PY
cd "$root/apps/python/tests"
export CRUMPLE_SIM="$("$venv/bin/python" -c 'import crumple, os; print(os.path.join(os.path.dirname(crumple.__file__), "bin", "crumple-sim"))')"
export CRUMPLE_SWEEP="$venv/bin/crumple-sweep" CRUMPLE_SCENES="$root/scenes" PYTHONDONTWRITEBYTECODE=1
env -u PYTHONPATH xvfb-run -a -s "-screen 0 1280x720x24" "$venv/bin/python" -m unittest test_python test_sweep
