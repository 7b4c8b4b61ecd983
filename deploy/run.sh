#!/usr/bin/env bash
# The main job on the embedded default: installs what is missing, builds, and preprocesses the
# synthetic torso phantom (masks + signed distance maps) into out/torso, printing a summary.
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
deploy/build.sh
build_dir=${PALP_BUILD_DIR:-build}
"$build_dir/server/palp" prep phantom:torso --out out/torso "$@"
echo "outputs: $(ls out/torso | tr '\n' ' ')"
