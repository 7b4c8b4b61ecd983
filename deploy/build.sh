#!/usr/bin/env bash
# Configures and builds palp (Release) into build/ with all cores. Used by run.sh and test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${PALP_BUILD_DIR:-build}
if [[ ! -f "$build_dir/build.ninja" ]]; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
cmake --build "$build_dir" --parallel "$(nproc)"
