#!/usr/bin/env bash
# docs/devices.md's Falcon force chart: the force a Falcon can render with palp's effort cap
# (4095 counts a motor), along the three axes through the workspace centre, in the worst
# direction and along y. Writes docs/figures/data/falcon_force_reach.csv and
# docs/figures/falcon_force_reach.png, and prints falcon_force_reach's summary.
#
#   tests/bench/falcon_force_reach.sh [BUILD_DIR]     (default: build)
#
# Needs the targets falcon_force_reach and palpchart (cmake --build build --target
# falcon_force_reach palpchart).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
csv=$root/docs/figures/data/falcon_force_reach.csv
png=$root/docs/figures/falcon_force_reach.png
mkdir -p "$(dirname "$csv")"
"$build/tests/bench/falcon_force_reach" "$csv"
"$build/client/palpchart" --csv "$csv" --x offset_mm --y worst_N,y_N \
  --names "every direction","along y (up/down)" --group axis --style line \
  --title "Falcon: largest force with efforts capped at 4095 a motor" \
  --xlabel "handle moved from the workspace centre along the axis after the colon (mm)" --ylabel "force (N)" \
  --yrange 0, --legend tr --out "$png"
echo "wrote $csv and $png"
