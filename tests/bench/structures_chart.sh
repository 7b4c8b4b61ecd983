#!/usr/bin/env bash
# Issue 39's measurement: the structure layers felt (docs/force_model.md "Structures as layers").
# Builds study_structures, palp and palpchart (incrementally) and
#   1. runs study_structures on SCENE (default phantom:torso,structures): the pulse over the
#      scene's most superficial artery at 2 / 3.5 / 5 N and 0 / 8 / 16 mm across the vessel, its
#      amplitude table against 0.02-0.5 N, the press that occludes it, and a slide across each
#      organ layer's inferior edge;
#   2. replays the 3.5 N press over the vessel through `palp run` (the command a user runs) and
#      prints the amplitude of its f_normal column over the last two beats;
#   3. draws OUT/pulse_force.png (pressing force against time, the nine presses) and
#      OUT/organ_slide.png with palpchart.
#
#   tests/bench/structures_chart.sh [--build DIR] [--out DIR] [--scene SCENE] [--tool TOOL]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$root/build
out=$root/build/studies/structures
scene="phantom:torso,structures"
tool="finger:1"
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --scene) scene=$2; shift 2 ;;
    --tool) tool=$2; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "structures_chart.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
cd "$root"
# shellcheck source=tests/bench/ensure_built.sh
. "$root/tests/bench/ensure_built.sh"
ensure_built "$build" 1 2 study_structures palp palpchart >&2
mkdir -p "$out"
"$build/tests/bench/study_structures" --scene "$scene" --tool "$tool" --out "$out"
"$build/server/palp" run --scene "$scene" --tool "$tool" --trajectory "$out/press_3.5N.csv" \
  --out "$out/press_3.5N_forces.csv" -q
python3 - "$out/press_3.5N_forces.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
f = [float(r["f_normal"]) for r in rows[-1667:]]
print("palp run, 3.5 N over the vessel: f_normal %.3f N mean, pulse amplitude %.3f N "
      "(max - min over the last two beats)" % (sum(f) / len(f), max(f) - min(f)))
PY
cols=$(head -1 "$out/pulse_force.csv" | cut -d, -f2-)
"$build/client/palpchart" --csv "$out/pulse_force.csv" --x t --y "$cols" --style line \
  --xrange 1.0,3.5 --title "Pressing force over the artery ($scene, $tool, 72 bpm)" \
  --xlabel "t (s)" --ylabel "pressing force (N)" --out "$out/pulse_force.png"
if [ -f "$out/organ_slide.csv" ]; then
  cols=$(head -1 "$out/organ_slide.csv" | cut -d, -f2-)
  "$build/client/palpchart" --csv "$out/organ_slide.csv" --x along_mm --y "$cols" --style line \
    --title "Sliding across the organ's inferior edge at 8 mm ($tool)" \
    --xlabel "along the body axis from the edge (mm, + superior)" \
    --ylabel "pressing force (N)" --out "$out/organ_slide.png"
fi
echo "written: $out/pulse_force.png $out/pulse_table.csv $out/organ_slide.png" >&2
