#!/usr/bin/env bash
# Configures and builds palp (Release) into build/ with all cores. Used by run.sh and test.sh.
#   deploy/build.sh            everything: the programs, the tests and the benchmarks
#   deploy/build.sh TARGET...  only these and what they need (run.sh: palp palpd palpview
#                              palpchart); a target this configuration does not have (palpview
#                              without VTK or GLFW) is left out with a note
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${PALP_BUILD_DIR:-build}
if [[ ! -f "$build_dir/build.ninja" ]]; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
if [[ $# -eq 0 ]]; then
  cmake --build "$build_dir" --parallel "$(nproc)"
  exit 0
fi
targets=()
for target in "$@"; do
  if ninja -C "$build_dir" -t query "$target" >/dev/null 2>&1; then
    targets+=("$target")
  else
    echo "palp: $target is not part of this build (a dependency was not found): left out" >&2
  fi
done
[[ ${#targets[@]} -gt 0 ]] || { echo "palp: none of $* can be built here" >&2; exit 1; }
cmake --build "$build_dir" --parallel "$(nproc)" --target "${targets[@]}"
