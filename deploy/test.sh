#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
deploy/build.sh
build_dir=${PALP_BUILD_DIR:-build}
# Twice as many tests at once as there are cores: most end-to-end tests wait on a server, a
# renderer or a timer for much of their time (on the 2-core VM ctest used 340 s of CPU in 255 s
# with two at a time; four at a time took 175 s, docs/test_run.md).
ctest --test-dir "$build_dir" --output-on-failure --parallel "$((2 * $(nproc)))" "$@"
