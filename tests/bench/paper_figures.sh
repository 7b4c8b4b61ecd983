#!/usr/bin/env bash
# Reproduces the paper's results (Fig. 4a, 4b, 5a-like, 5b-like; docs/paper_results.md): runs
# `palp traj` / `palp run` on the cube and torso phantoms and on the real CT in ../shared/data
# (when present), times the tick against the number of contact points, writes the CSVs into
# FIGURES/data, renders the charts into FIGURES with palpchart (under xvfb-run when there is no
# display) and prints the numbers the docs quote (also in FIGURES/data/summary.txt).
#
#   tests/bench/paper_figures.sh [BUILD_DIR] [--charts-only] [--build] [--docs]
#
# FIGURES is outside the repository unless told: $PALP_FIGURES_DIR, default
# ${TMPDIR:-/tmp}/palp-paper-figures/figures; --docs writes docs/figures, where the docs show them.
# BUILD_DIR (or $PALP_BUILD_DIR, default build) must hold server/palp, client/palpchart and
# tests/bench/{tick_vs_contacts,bone_along_path}; what is missing is named, and built only with
# --build (-j$PALP_JOBS, default 1).
# Environment: PALP_FIGURES_DIR, PALP_CT (default ../shared/data/
# ct_abdomen_3mm.nii.gz), PALP_PAPER_TICKS (timed ticks per tool, default 20000). Scratch files go
# to a work directory under /tmp (kept, printed). Takes about a minute on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
source tests/bench/ensure_built.sh
build=${PALP_BUILD_DIR:-build}
charts_only=0
build_missing=0
figures=${PALP_FIGURES_DIR:-${TMPDIR:-/tmp}/palp-paper-figures/figures}
for arg in "$@"; do
  case $arg in
    --charts-only) charts_only=1 ;;
    --build) build_missing=1 ;;
    --docs) figures=docs/figures ;;
    -h | --help) sed -n '2,18p' "$0"; exit 0 ;;
    -*) echo "usage: $0 [BUILD_DIR] [--charts-only] [--build] [--docs]" >&2; exit 2 ;;
    *) build=$arg ;;
  esac
done
data=$figures/data
ct=${PALP_CT:-../shared/data/ct_abdomen_3mm.nii.gz}
ticks=${PALP_PAPER_TICKS:-20000}
jobs=${PALP_JOBS:-1}
palp=$build/server/palp
chart=$build/client/palpchart
py=/usr/bin/python3
export PYTHONDONTWRITEBYTECODE=1
helper=tests/bench/paper_figures.py
work=${PALP_PAPER_WORK:-/tmp/palp-paper-figures}
export PALP_SCENE_CACHE=$work/cache

charts() {
  mkdir -p "$figures"
  local c=(--size 1100x640 --style line)
  local fingers="finger:1|finger:7|finger:19|finger:37"
  # Fig. 4a
  "$chart" "${c[@]}" --csv "$data/fig4a_slide_ramp.csv" --where "tool=$fingers" --x t \
    --y f_lateral,f_total --names "lateral friction,total |f|" --group tool --legend tl \
    --xlabel "time (s); indentation ramps 0 to 6 mm while sliding at 10 mm/s" \
    --ylabel "force (N, mean over the points in contact)" \
    --title "Fig. 4a: cube, slide with increasing indentation, 1/7/19/37 points (curves coincide)" \
    --out "$figures/fig4a_slide_ramp.png"
  "$chart" "${c[@]}" --csv "$data/fig4a_friction_vs_depth.csv" --x depth \
    --y f_lateral,law_sliding,f_surf --names "lateral friction (finger:37),steady sliding friction of the law (k z*),skin force f_s" \
    --legend tl --xlabel "indentation of the pad (mm)" --ylabel "force (N)" \
    --title "Fig. 4a: friction grows with indentation (cube, 10 mm/s)" \
    --out "$figures/fig4a_friction_vs_depth.png"
  # Fig. 4b
  "$chart" "${c[@]}" --csv "$data/fig4b_slide_speed.csv" --where "tool=$fingers" --x t \
    --y f_lateral,f_total --names "lateral friction,total |f|" --group tool --legend tl \
    --xlabel "time (s); press 0.5 s, slide 10 / 40 / 10 mm/s for 1 s each, hold 0.5 s" \
    --ylabel "force (N, mean over the points in contact)" --yrange 0, \
    --title "Fig. 4b: cube, 3 mm indentation, changing velocity, 1/7/19/37 points (coincide)" \
    --out "$figures/fig4b_slide_speed.png"
  "$chart" "${c[@]}" --csv "$data/fig4b_slide_speed.csv" --where tool=finger:37 --x t \
    --y speed,depth --names "device speed (mm/s),pad indentation (mm)" --legend tl \
    --xlabel "time (s)" --ylabel "speed (mm/s) / indentation (mm)" --yrange 0, \
    --title "Fig. 4b: the path - device speed and indentation" \
    --out "$figures/fig4b_path.png"
  # Fig. 5a-like
  local scene
  for scene in torso ct; do
    [[ -f "$data/fig5a_$scene.csv" ]] || continue
    local what="torso phantom (1.25 x 1.25 x 2 mm)"
    [[ $scene == ct ]] && what="real CT (3 mm), lower right ribs"
    "$chart" "${c[@]}" --csv "$data/fig5a_$scene.csv" --x t --y f_normal,f_bone,f_lateral \
      --names "pressing force,of it: bone (ribs),lateral friction" --mark over_rib \
      --mark-label "pad over a rib" --legend tr --yrange 0, \
      --xlabel "time (s); finger:37 slides inferior to superior at 20 mm/s, 5 mm deep" \
      --ylabel "force (N, mean over the points in contact)" \
      --title "Fig. 5a-like: $what" --out "$figures/fig5a_${scene}_forces.png"
    "$chart" "${c[@]}" --csv "$data/fig5a_$scene.csv" --x t --y depth,rib_pct,bone_dist \
      --names "pad depth under the skin (mm),points above a rib (% with bone within 30 mm),pad centre to nearest bone (mm)" \
      --legend tr --yrange 0,110 --xlabel "time (s)" --ylabel "mm / %" \
      --title "Fig. 5a-like: $what - where the ribs are (from D_bone)" \
      --out "$figures/fig5a_${scene}_ribs.png"
  done
  # Fig. 5b-like
  "$chart" --size 1100x640 --csv "$data/fig5b_tick_vs_contacts.csv" --where scene=phantom:torso \
    --x contacts --y p25_ns,p50_ns,p75_ns,whisker_hi_ns \
    --names "25th percentile,median,75th percentile,75th + 1.5 IQR" --mark finger \
    --mark-label "finger:1/7/19/37 (others: probe grids)" --legend tl --yrange 0, \
    --xlabel "contact points (finger:N, probe:NXxNY; torso ribs path)" \
    --ylabel "tick time (ns, this 2-core VM, shared)" \
    --title "Fig. 5b-like: force-model tick time against the number of contact points" \
    --out "$figures/fig5b_tick_vs_contacts.png"
  "$chart" --size 1100x640 --csv "$data/fig5b_tick_vs_contacts.csv" --x contacts \
    --y rate_p50_khz --group scene --logy --legend tr \
    --xlabel "contact points" --ylabel "update rate from the median tick (kHz, log)" \
    --title "Fig. 5b-like: update rate of the bare tick (paper: 1-2 kHz for its whole simulator)" \
    --out "$figures/fig5b_rate.png"
  ls -1 "$figures"/fig*.png
}

if [[ $charts_only == 1 ]]; then
  if [[ ! -x "$chart" ]]; then
    echo "palpchart was not built (VTK missing?): CSVs are in $data, no charts" >&2
    exit 1
  fi
  if [[ -n ${DISPLAY:-} ]]; then
    charts
  elif command -v xvfb-run >/dev/null; then
    # One virtual display for all charts (DISPLAY is set inside, so this runs charts).
    PALP_FIGURES_DIR=$figures xvfb-run -a "$0" "$build" --charts-only
  else
    echo "no display and no xvfb-run: install xvfb (deploy/install-deps.sh) to render charts" >&2
    exit 1
  fi
  exit 0
fi

targets=()
[[ -x $palp ]] || targets+=(palp)
[[ -x $chart ]] || targets+=(palpchart)
[[ -x $build/tests/bench/tick_vs_contacts ]] || targets+=(tick_vs_contacts)
[[ -x $build/tests/bench/bone_along_path ]] || targets+=(bone_along_path)
ensure_built "$build" "$build_missing" "$jobs" "${targets[@]}"

mkdir -p "$work" "$data"
summary=$data/summary.txt
{
  echo "# tests/bench/paper_figures.sh $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "# machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), load $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "# $("$palp" version 2>/dev/null || echo '?'), build $build"
} >"$summary"
SECONDS=0
w=$work

# Fig. 4a / 4b: the cube, finger:1/7/19/37.
"$palp" traj slide-ramp -q --scene phantom:cube --out "$w/ramp.csv"
"$palp" traj slide-speed -q --scene phantom:cube --out "$w/speed.csv"
pairs_ramp=() pairs_speed=()
for n in 1 7 19 37; do
  "$palp" run -q --model paper --scene phantom:cube --tool finger:$n --trajectory "$w/ramp.csv" \
    --out "$w/ramp_f$n.csv"
  "$palp" run -q --model paper --scene phantom:cube --tool finger:$n --trajectory "$w/speed.csv" \
    --out "$w/speed_f$n.raw.csv"
  $py $helper add-speed "$w/speed_f$n.raw.csv" "$w/speed.csv" "$w/speed_f$n.csv"
  pairs_ramp+=("finger:$n=$w/ramp_f$n.csv")
  pairs_speed+=("finger:$n=$w/speed_f$n.csv")
done
echo "## Fig. 4a: palp traj slide-ramp --scene phantom:cube; palp run --model paper --tool finger:N" >>"$summary"
$py $helper fig4 "$data/fig4a_slide_ramp.csv" "$summary" "${pairs_ramp[@]}"
$py $helper ramp-stats "$summary" "$w/ramp_f37.csv" ramp
# Friction against indentation for the second chart: finger:37, with the law's sliding value.
$py - "$w/ramp_f37.csv" "$data/fig4a_friction_vs_depth.csv" <<'EOF'
import sys
sys.path.insert(0, "tests/bench")
import numpy as np
import paper_figures as pf
c = pf.read(sys.argv[1])
m = c["n_contact"] > 0
d = c["depth"][m]
law = np.array([0.4 * pf.breakaway(2.0 * pf.surface_force(x) + 1.0) for x in d])
pf.write(sys.argv[2], ["depth", "f_lateral", "law_sliding", "f_surf"],
         [d, c["f_lateral"][m], law, pf.surface_force(d)], every=10)
EOF
echo "## Fig. 4b: palp traj slide-speed --scene phantom:cube; palp run --model paper --tool finger:N" >>"$summary"
$py $helper fig4 "$data/fig4b_slide_speed.csv" "$summary" "${pairs_speed[@]}"
$py $helper speed-stats "$summary" "$w/speed_f37.csv" "$w/speed.csv" speed

# Fig. 5a-like: finger:37 across the ribs, with and without the bone terms, and where the bone is.
fig5a() {  # label scene traj-options...
  local label=$1 scene=$2
  shift 2
  "$palp" traj ribs -q --scene "$scene" "$@" --out "$w/ribs_$label.csv"
  "$palp" run -q --model paper --scene "$scene" --tool finger:37 --trajectory "$w/ribs_$label.csv" \
    --out "$w/ribs_${label}_f.csv"
  "$palp" run -q --model paper --scene "$scene" --tool finger:37 --trajectory "$w/ribs_$label.csv" \
    --param bone_enabled=0 --out "$w/ribs_${label}_nobone.csv"
  "$build/tests/bench/bone_along_path" --scene "$scene" --tool finger:37 \
    --trajectory "$w/ribs_$label.csv" --out "$w/ribs_${label}_bone.csv" >/dev/null
  echo "## Fig. 5a-like ($label): palp traj ribs --scene $scene $*; palp run --model paper --tool finger:37" \
    "(and --param bone_enabled=0); bone_along_path" >>"$summary"
  $py $helper fig5a "$data/fig5a_$label.csv" "$summary" "$label" "$w/ribs_${label}_f.csv" \
    "$w/ribs_${label}_nobone.csv" "$w/ribs_${label}_bone.csv" "$w/ribs_$label.csv"
}
fig5a torso phantom:torso
if [[ -f $ct ]]; then
  # The CT's ribs lie in its top quarter (its lower 3/4 is abdomen and pelvis): slide over them
  # on the patient's right, straight lateral.
  fig5a ct "$ct" --from 0.76 --to 0.95 --azimuth 0
else
  echo "no CT at $ct: Fig. 5a on the real CT skipped" | tee -a "$summary"
  rm -f "$data/fig5a_ct.csv"
fi

# Fig. 5b-like: tick time against the number of contact points.
echo "## Fig. 5b-like: tick_vs_contacts --ticks $ticks (torso ribs path; cube slide-speed path)" \
  >>"$summary"
"$build/tests/bench/tick_vs_contacts" --scene phantom:torso --ticks "$ticks" \
  --out "$w/ticks_torso.csv" | tee -a "$summary"
"$build/tests/bench/tick_vs_contacts" --scene phantom:cube --ticks "$ticks" \
  --out "$w/ticks_cube.csv" | tee -a "$summary"
{ cat "$w/ticks_torso.csv"; tail -n +2 "$w/ticks_cube.csv"; } >"$w/ticks.csv"
$py $helper fig5b "$data/fig5b_tick_vs_contacts.csv" "$w/ticks.csv"
echo "# measured in ${SECONDS} s wall, load afterwards $(cut -d' ' -f1-3 /proc/loadavg)" \
  >>"$summary"

PALP_FIGURES_DIR="$figures" "$0" "$build" --charts-only
echo "== summary ($summary; work files in $work)"
cat "$summary"
