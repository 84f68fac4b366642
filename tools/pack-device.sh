#!/usr/bin/env bash
# Packs the built programs and test binaries with the shared libraries they need
# (not glibc's) into .devlib/, for a machine that has a GPU but none of the
# project's Debian packages (for example Ubuntu with NVIDIA's EGL driver). Copy the
# repository with .devlib/ there; then, from the repository root:
#   . .devlib/env.sh && .devlib/bin/crumple-bench --filter 'deform|render' --deform-profile
# or the prepared check: bash .devlib/check.sh [tests] [gpu] [cpu] (outputs in $OUT, else out/device).
# A script of your own should live in .devlib/ too, when only the repository and .devlib/ are copied.
# Tests that run crumple-sim find it at build/apps/crumple-sim: .devlib/env.sh puts it there.
set -euo pipefail
usage() {
  cat <<'USAGE'
Usage: tools/pack-device.sh
Packs the built programs and test binaries with their shared libraries into .devlib/ for a GPU machine
without the Debian packages; there: . .devlib/env.sh && .devlib/bin/crumple-bench ...
USAGE
}
. "$(dirname "$0")/args.sh"
tool_args "" "$@"
cd "$(dirname "$0")/.."
cmake --build build -j"$(nproc)" >/dev/null
rm -rf .devlib
mkdir -p .devlib/bin .devlib/lib .devlib/compat
cp build/apps/crumple-bench build/apps/crumple-sim build/tests/test_* .devlib/bin/
rm -f .devlib/bin/test_sandbox  # needs a display
strip .devlib/bin/*
for b in .devlib/bin/*; do ldd "$b" | awk '/=>/ {print $3}'; done | sort -u |
  grep -v -E '/(libc|libm|libdl|libpthread|librt|libgcc_s|ld-linux[^/]*)\.so' | xargs -I{} cp -L {} .devlib/lib/
# glvnd front ends, so that libepoxy finds desktop GL through the vendor's EGL
for l in libOpenGL.so.0 libGL.so.1 libGLX.so.0; do cp -L "/lib/x86_64-linux-gnu/$l" .devlib/lib/ 2>/dev/null || true; done
# Our libstdc++ only if the machine's is older
mv .devlib/lib/libstdc++.so.6 .devlib/compat/ 2>/dev/null || true
cat > .devlib/env.sh <<'ENV'
# sourced on the device machine, in the repository root
export LD_LIBRARY_PATH=$PWD/.devlib/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
for f in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /usr/share/glvnd/egl_vendor.d/10_nvidia.json; do
  if [ -f "$f" ]; then export __EGL_VENDOR_LIBRARY_FILENAMES=$f; break; fi
done
if ! .devlib/bin/crumple-sim --help >/dev/null 2>&1; then export LD_LIBRARY_PATH=$LD_LIBRARY_PATH:$PWD/.devlib/compat; fi
mkdir -p build/apps && cp .devlib/bin/crumple-sim build/apps/crumple-sim
ENV
# The prepared device check: `bash .devlib/check.sh [tests] [gpu] [cpu]` (all three without arguments) writes
# each part's output to $OUT (or out/device): the test binaries, the GPU rows with their phase profiles, and the
# physics rows on 1 to 16 threads beside Jolt where the bench was built with it.
cat > .devlib/check.sh <<'CHECK'
#!/usr/bin/env bash
set -uo pipefail
cd "$(dirname "$0")/.."
. .devlib/env.sh
[ -d /usr/local/nvidia/lib64 ] && export LD_LIBRARY_PATH=$LD_LIBRARY_PATH:/usr/local/nvidia/lib64
out=${OUT:-out/device}
mkdir -p "$out"
parts=${*:-tests gpu cpu}
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv > "$out/device.txt" 2>&1 || true
for part in $parts; do
  start=$(date +%s)
  case $part in
    tests)  # the binaries at once (each has its own GL context); their summaries, and every failure's context
      mkdir -p /tmp/crumple-tests
      for t in .devlib/bin/test_*; do
        (timeout 300 "$t" > "/tmp/crumple-tests/$(basename "$t").txt" 2>&1; echo "rc $?" >> "/tmp/crumple-tests/$(basename "$t").txt") &
      done
      wait
      for f in /tmp/crumple-tests/*.txt; do echo "== $f" && tail -5 "$f"; done > "$out/tests.txt"
      grep -h -B3 -A12 -E 'ERROR|FAILED|GL \[' /tmp/crumple-tests/*.txt | head -400 > "$out/testfail.txt" ;;
    gpu)
      timeout 400 .devlib/bin/crumple-bench --filter 'deform|render' --deform-profile --render-profile \
        --repetitions 3 > "$out/gpu.txt" 2>&1 ;;
    cpu)
      timeout 400 .devlib/bin/crumple-bench --no-gl --repetitions 2 --thread-counts 1,2,4,8,16 \
        > "$out/cpu.txt" 2>&1 ;;
  esac
  echo "$part: $(( $(date +%s) - start )) s"
done
CHECK
chmod +x .devlib/check.sh
du -sh .devlib
