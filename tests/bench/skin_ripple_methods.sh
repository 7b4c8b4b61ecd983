#!/bin/bash
# Issue 13's chart: the force ripple of a slide at a constant true depth below the real CT's skin
# with each surface method, measured with `palp run` as a user would run it.
#   1. palp prep CT --surface mask | subvoxel (the CT's own 3 mm grid, as the spec's files are)
#   2. the slide: finger:1 at 20 mm/s (1 kHz) along the anterior abdomen, 100 mm, its pad at a
#      constant global distance (2, 4, 6 mm) below the trilinear CT's -500 HU iso-surface, written
#      by study_force_model (PALP_SMOOTH_TRAJ_DIR; docs/notebook/force_model.md "The path at a constant
#      true depth")
#   3. palp run --tool finger:1 --param bone_enabled=0 on each prep directory with each model:
#      paper; palp on the maps as prepped (--map-spacing 0); palp as it runs by default (a coarse
#      CT's maps refined in memory: only the sub-voxel maps can be, the mask maps load as prepped)
#   4. |f| detrended by a centred 10 mm moving average: its standard deviation and the largest
#      change between two ticks, per series and depth (CSV and one Markdown row each); the 6 mm
#      traces; charts with palpchart.
# Deterministic (no timing): one run gives the figures. Never gates CI.
#
# Usage: tests/bench/skin_ripple_methods.sh [--build DIR] [--work DIR] [--docs]
#   --docs   charts into docs/figures (default: WORK/figures)
set -euo pipefail
cd "$(dirname "$0")/../.."
build=build
work=${TMPDIR:-/tmp}/palp_skin_ripple
figures=""
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --docs) figures=docs/figures; shift ;;
    -h|--help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "skin_ripple_methods.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
ct=${PALP_CT:-../shared/data/ct_abdomen_3mm.nii.gz}
palp=$build/server/palp
study=$build/tests/bench/study_force_model
chart=$build/client/palpchart
for exe in "$palp" "$study"; do
  [ -x "$exe" ] || { echo "skin_ripple_methods.sh: $exe is missing (cmake --build $build)" >&2; exit 2; }
done
[ -f "$ct" ] || { echo "skin_ripple_methods.sh: no CT at $ct (set PALP_CT)" >&2; exit 2; }
figures=${figures:-$work/figures}
mkdir -p "$work" "$figures"

echo "== prep, both surface methods (the CT's own grid)"
for method in mask subvoxel; do
  "$palp" prep "$ct" --out "$work/$method" --surface "$method" -q
done

echo "== the slides at a constant true depth (study_force_model, PALP_SMOOTH_TRAJ_DIR)"
PALP_SCENE_CACHE="$work/cache" PALP_STUDY_PARTS=smooth PALP_SMOOTH_TRAJ_DIR="$work" \
  "$study" --out "$work/study" > "$work/study.log"

echo "== palp run"
# series: name | prep directory | palp run's model options
series=(
  "paper, mask|mask|--model paper"
  "paper, subvoxel|subvoxel|--model paper"
  "palp, mask|mask|--model palp --map-spacing 0"
  "palp, subvoxel|subvoxel|--model palp --map-spacing 0"
  "palp, subvoxel, default (1.5 mm in memory)|subvoxel|--model palp"
)
runs=()
for depth in 2 4 6; do
  path="$work/skin_path_${depth}mm.csv"
  [ -f "$path" ] || { echo "skin_ripple_methods.sh: $path was not written" >&2; exit 1; }
  for s in "${series[@]}"; do
    IFS='|' read -r name dir options <<< "$s"
    out="$work/force_${dir}_$(echo "$options" | tr -dc 'a-z0-9')_${depth}mm.csv"
    # shellcheck disable=SC2086
    "$palp" run --scene "$work/$dir" --tool finger:1 --param bone_enabled=0 $options \
      --trajectory "$path" --out "$out" -q
    runs+=("$name|$depth|$out")
  done
done

printf '%s\n' "${runs[@]}" > "$work/runs.txt"
python3 - "$work/runs.txt" "$work/skin_ripple.csv" "$work/skin_ripple_trace.csv" <<'EOF'
import csv, math, sys
runs_path, summary_path, trace_path = sys.argv[1], sys.argv[2], sys.argv[3]
rows, trace = [], []
half = 250  # 5 mm each side at 20 mm/s and 1 kHz: the centred 10 mm moving average
for line in open(runs_path).read().splitlines():
    name, depth, path = line.split('|')
    with open(path) as f:
        r = csv.DictReader(f)
        force = [math.sqrt(float(x['fx'])**2 + float(x['fy'])**2 + float(x['fz'])**2) for x in r]
    prefix = [0.0]
    for v in force:
        prefix.append(prefix[-1] + v)
    dev = []
    for t in range(half, len(force) - half):
        avg = (prefix[t + half + 1] - prefix[t - half]) / (2 * half + 1)
        dev.append(force[t] - avg)
    std = math.sqrt(sum(d * d for d in dev) / len(dev))
    step = max(abs(force[t] - force[t - 1]) for t in range(1, len(force)))
    mean = sum(force[half:len(force) - half]) / len(dev)
    rows.append((name, float(depth), mean, std, step))
    if depth == '6':
        trace += [(name, 20.0 * t / 1000.0, force[t]) for t in range(len(force))]
with open(summary_path, 'w', newline='') as f:
    w = csv.writer(f)
    w.writerow(['series', 'depth_mm', 'mean_N', 'detrended_std_N', 'max_step_N'])
    for row in rows:
        w.writerow(row)
with open(trace_path, 'w', newline='') as f:
    w = csv.writer(f)
    w.writerow(['series', 'along_mm', 'force_N'])
    for row in trace:
        w.writerow(row)
print('| series | true depth | mean | detrended std | largest tick step |')
print('|---|---|---|---|---|')
for name, depth, mean, std, step in rows:
    print(f'| {name} | {depth:g} mm | {mean:.3f} N | {std:.3f} N | {step:.3f} N |')
EOF

if [ -x "$chart" ]; then
  "$chart" --csv "$work/skin_ripple.csv" --x depth_mm --y detrended_std_N --group series \
    --style linepoints --logy --legend br \
    --xlabel "true depth below the -500 HU iso-surface (mm), finger:1, 20 mm/s, bone off" \
    --ylabel "detrended force std (N)" \
    --title "Skin ripple on the real CT, mask against sub-voxel maps (palp run; goal 0.1 N)" \
    --out "$figures/skin_ripple_methods.png"
  "$chart" --csv "$work/skin_ripple_trace.csv" --x along_mm --y force_N --group series \
    --style line --legend tl \
    --xlabel "along the slide (mm), finger:1 at 6 mm true depth, 20 mm/s, bone off" \
    --ylabel "|f| (N)" \
    --title "The 6 mm slide on the real CT with each surface method (palp run)" \
    --out "$figures/skin_ripple_trace_6mm.png"
  echo "charts: $figures/skin_ripple_methods.png, $figures/skin_ripple_trace_6mm.png"
else
  echo "palpchart not built: CSVs in $work" >&2
fi
