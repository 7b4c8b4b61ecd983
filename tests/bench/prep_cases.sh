#!/usr/bin/env bash
# Issue 38's scorer: builds tests/bench/prep_cases (incrementally) and runs it: the whole prep,
# default parameters and no cache, on the torso phantom's cases (default, contrast none /
# arterial / portal-venous, aorta 150 / 250 / 400 HU, a 20-slice slab at 1.5 mm with and without
# aorta 400, 5 mm slices, both arms, a metal implant) and, when ../shared/data has them, the real
# CTs with their labels; prints one Markdown table (case, structure, Dice, ASSD mm, the goal
# figures with their goals and whether met) on stdout, progress on stderr. Exit 0 unless the build
# fails: a missed goal is a figure, not a failure.
#
#   tests/bench/prep_cases.sh [--build DIR] [--jobs N] [prep_cases options]
#
# prep_cases options: --only TEXT (cases whose name contains TEXT), --keep DIR (keep each case's
# prep output in DIR/<n>), --shared-data DIR (default $PALP_SHARED_DATA_DIR, else ../shared/data).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$root/build
jobs=2
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) break ;;
  esac
done
cd "$root"
# shellcheck source=tests/bench/ensure_built.sh
. "$root/tests/bench/ensure_built.sh"
ensure_built "$build" 1 "$jobs" prep_cases >&2
exec "$build/tests/bench/prep_cases" "$@"
