#!/usr/bin/env bash
# Runs the force-model studies (speed against accuracy, pop-through, passivity, stability of the
# default force chain, the palp model beside the paper's), writes their CSVs and logs and renders
# the charts with palpchart (under xvfb-run when there is no display). Prints the figures it
# measured. Naming studies (speed_accuracy, pop_through, passivity, stability, force_model) runs
# and charts only those.
#
#   tests/bench/run_studies.sh [--quick] [--charts-only] [--build] [--docs] [STUDY...]
#
# Writes outside the repository unless told: CSVs and logs into $PALP_STUDIES_DIR (default
# ${TMPDIR:-/tmp}/palp-studies), charts into $PALP_FIGURES_DIR (default that directory's figures/);
# --docs puts the charts into docs/figures, where the docs show them. Never builds on its own: a
# missing study binary is named with the command that builds it; --build builds what is missing
# (in $PALP_BUILD_DIR, default build, -j$PALP_JOBS, default 1). The studies measure; nothing here
# gates CI.
set -euo pipefail
cd "$(dirname "$0")/../.."
source tests/bench/ensure_built.sh
build=${PALP_BUILD_DIR:-build}
data=${PALP_STUDIES_DIR:-${TMPDIR:-/tmp}/palp-studies}
figures=${PALP_FIGURES_DIR:-$data/figures}
jobs=${PALP_JOBS:-1}
quick=()
charts_only=0
build_missing=0
studies=()
for arg in "$@"; do
  case $arg in
    --quick) quick=(--quick) ;;
    --charts-only) charts_only=1 ;;
    --build) build_missing=1 ;;
    --docs) figures=docs/figures ;;
    -h | --help) sed -n '2,16p' "$0"; exit 0 ;;
    speed_accuracy|pop_through|passivity|stability|force_model) studies+=("$arg") ;;
    *) echo "usage: $0 [--quick] [--charts-only] [--build] [--docs] [speed_accuracy|pop_through|passivity|stability|force_model]..." >&2; exit 2 ;;
  esac
done
[[ ${#studies[@]} -gt 0 ]] || studies=(speed_accuracy pop_through passivity stability force_model)
want() { [[ " ${studies[*]} " == *" $1 "* ]]; }
chart=$build/client/palpchart

charts() {
  mkdir -p "$figures"
  local c=(--size 1000x640)
  local sa_y=(--y err_rel_pct --ylabel "force error (% of the reference force)" --logy)
  local sa_x=(--x tick_ns --xlabel "median tick time (ns, finger:37, this 2-core VM)")
  want speed_accuracy && for phantom in sphere torso; do
    grep -q "^$phantom," "$data/speed_accuracy.csv" || continue
    local ref="exact distances at 0.25 mm"
    [[ $phantom == torso ]] && ref="0.25 mm maps of a 24 mm slab"
    "$chart" "${c[@]}" --csv "$data/speed_accuracy.csv" --where phantom=$phantom \
      "${sa_x[@]}" "${sa_y[@]}" --group gradient,storage --style points \
      --mark pareto --mark-label "Pareto front" \
      --title "Speed vs accuracy, $phantom: 0.5 / 1 / 2 / 3 mm maps from the bottom (ref.: $ref)" \
      --out "$figures/speed_accuracy_$phantom.png"
  done

  want pop_through && for tool in 1 37; do
    "$chart" "${c[@]}" --csv "$data/pop_through_chart.csv" --where tool=finger:$tool \
      --x indentation_mm --y pct --group series --legend tl --yrange 0,140 \
      --xlabel "nominal indentation (mm; hand push = skin law force there)" \
      --ylabel "% of ticks over the rib" \
      --title "finger:$tool slid across a thin rib at 100 mm/s: bone force flips or vanishes" \
      --out "$figures/pop_through_slide_finger$tool.png"
    "$chart" "${c[@]}" --csv "$data/pop_through_push.csv" --where tool=finger:$tool \
      --where "rate_hz=0|2000|10000" --x push_N --y depth_mm --group series --style line \
      --legend tl --xlabel "hand push (N), ramped 0 to 100 N in 3 s" \
      --ylabel "pad centre depth under the skin (mm)" \
      --title "finger:$tool pushed onto a thin rib: printed bone law vs robust mode" \
      --out "$figures/pop_through_push_finger$tool.png"
  done
  want pop_through && "$chart" "${c[@]}" --csv "$data/pop_through_speed.csv" --where tool=finger:37 \
    --x speed_mm_s --y pct --group series --logx --legend bl --yrange 0,105 \
    --xlabel "slide speed (mm/s)" --ylabel "% of ticks over the rib" \
    --title "finger:37 across a thin rib at 12 mm indentation, against speed" \
    --out "$figures/pop_through_speed.png"

  want passivity && for profile in touch falcon phantom-premium omega; do
    "$chart" "${c[@]}" --csv "$data/passivity_boundary.csv" --where profile=$profile \
      --where "limits=saturation|limiter|coupling" --x hand_N --y min_stable_rate_hz --group series \
      --logy --legend tr --xlabel "hand push (N)" \
      --ylabel "lowest stable update rate (Hz; 20000 = unstable at 10 kHz)" \
      --title "$profile: stable above each line (skin / bone 10 mm under skin)" \
      --out "$figures/passivity_$profile.png"
  done
  want passivity && "$chart" "${c[@]}" --csv "$data/passivity.csv" --where scene=bone --where hand_frac=0.2 \
    --where "limits=saturation|limiter|coupling" --x rate_hz --y inj_mW --group profile,limits --logx \
    --logy --legend bl --xlabel "update rate (Hz)" \
    --ylabel "energy injected by the rendering (mW)" \
    --title "Hand pushing 20% of max force onto skin over bone (2.5 N step at contact)" \
    --out "$figures/passivity_energy.png"

  # The palp model beside the paper's (study_force_model, docs/force_model.md).
  want force_model && for scene in torso ct; do
    grep -q "^$scene," "$data/force_model_contrast_ratio.csv" || continue
    local what="torso phantom, 4 paths, 3 ribs each"
    [[ $scene == ct ]] && what="real CT (3 mm; palp's maps at 1.5 mm in memory), lower right ribs"
    "$chart" "${c[@]}" --csv "$data/force_model_contrast_ratio.csv" --where scene=$scene \
      --x depth_mm --y ratio_median --group series --style line --legend tr --logy \
      --xlabel "pad depth under the skin (mm), pressed along the skin normal" \
      --ylabel "pressing force over a rib / over the next space (median)" \
      --title "Rib contrast, $what (goal for palp: >= 1.5 at 6 mm)" \
      --out "$figures/force_model_contrast_$scene.png"
  done
  want force_model && "$chart" "${c[@]}" --csv "$data/force_model_friction.csv" --where sweep=speed \
    --x speed_mm_s --y change_pct --group model --style line --legend bl \
    --xlabel "slide speed (mm/s), 1 kHz, 4 mm deep, flat skin" \
    --ylabel "sliding friction against 100 mm/s (%)" \
    --title "Friction against speed (goal: within +-5 %)" --out "$figures/force_model_friction_speed.png"
  want force_model && "$chart" "${c[@]}" --csv "$data/force_model_friction.csv" --where sweep=rate \
    --x rate_hz --y change_pct --group model,speed_mm_s --style line --logx --legend bl \
    --xlabel "update rate (Hz), 4 mm deep, flat skin" \
    --ylabel "sliding friction against 10 kHz (%)" \
    --title "Friction against the loop rate (goal: within +-5 %)" --out "$figures/force_model_friction_rate.png"
  want force_model && [[ -s $data/force_model_smooth.csv ]] &&
    "$chart" "${c[@]}" --csv "$data/force_model_smooth.csv" \
      --x depth_mm --y detrended_std_N,max_step_N --names "detrended std","largest tick step" \
      --group model --style linepoints --logy --legend br \
      --xlabel "true depth below the -500 HU iso-surface (mm), finger:1, 20 mm/s, bone off" \
      --ylabel "force (N)" \
      --title "Skin smoothness on the real CT (goal for palp: both <= 0.1 N)" \
      --out "$figures/force_model_smooth_ct.png"
  want force_model && "$chart" "${c[@]}" --csv "$data/force_model_creep.csv" \
    --x depth_mm --y decay_pct --group model --style line --legend tr \
    --xlabel "pad depth (mm); shifted by half the breakaway distance, held 5 s, +-0.05 mm jitter" \
    --ylabel "decay of the holding force over the hold (%)" \
    --title "Creep under jitter (goal: none at 1-8 mm)" --out "$figures/force_model_creep.png"

  # Stability of palpd's default chain (study_stability, docs/stability.md).
  want stability || { ls -1 "$figures"/*.png; return; }
  local chains="saturation|limiter|palpd-limiter|palpd|palpd-engaged"
  for profile in touch falcon phantom-premium omega; do
    "$chart" "${c[@]}" --csv "$data/stability_summary.csv" --where profile=$profile \
      --where "chain=$chains" --x rate_hz --y p2p_worst_mm --group chain --logx --logy \
      --legend bl --xlabel "update rate (Hz)" \
      --ylabel "worst peak-to-peak over 3.5-4 s (mm; a, b30, b90, d, r, s)" \
      --title "$profile: device motion at the end of a press (goal: < 0.1 mm at >= 1 kHz)" \
      --out "$figures/stability_p2p_$profile.png"
  done
  "$chart" "${c[@]}" --csv "$data/stability_summary.csv" --where profile=all \
    --where "chain=$chains" --x rate_hz --y inj_worst_mJ --group chain --logx --logy \
    --legend bl --xlabel "update rate (Hz)" \
    --ylabel "worst energy injected (mJ; a, b30, b90, d, r, s; <= 0 not drawn)" \
    --title "Energy the rendering injects, worst over the four profiles (goal: <= 0)" \
    --out "$figures/stability_energy.png"
  "$chart" "${c[@]}" --csv "$data/stability_summary.csv" --where profile=all \
    --where "chain=$chains" --x rate_hz --y step_ratio_worst --group chain --logx --logy \
    --legend tl --xlabel "update rate (Hz)" \
    --ylabel "largest per-tick force step / (max_force_rate x tick)" \
    --title "Largest force step against the profile's bound, worst over profiles (goal: <= 1)" \
    --out "$figures/stability_step.png"
  for run in "touch b30" "touch s" "phantom-premium d"; do
    set -- $run
    "$chart" "${c[@]}" --csv "$data/stability_trace.csv" --where profile=$1 --where scenario=$2 \
      --x t_s --y depth_mm --group chain --style line --legend tr \
      --xlabel "time (s); hand force ramped in over 0.5 s" --where "chain=$chains" \
      --ylabel "pad depth under the skin (mm; the device's stop at 25 mm)" \
      --title "$1, scenario $2, 1 kHz: depth of the press per chain" \
      --out "$figures/stability_trace_${1}_$2.png"
  done
  ls -1 "$figures"/*.png
}

# What is missing is built only when asked (--build); otherwise named.
missing=()
if [[ $charts_only == 0 ]]; then
  for study in "${studies[@]}"; do
    [[ -x $build/tests/bench/study_$study ]] || missing+=("study_$study")
  done
fi
[[ -x $chart ]] || missing+=(palpchart)
ensure_built "$build" "$build_missing" "$jobs" "${missing[@]}"

if [[ $charts_only == 0 ]]; then
  mkdir -p "$data"
  for study in "${studies[@]}"; do
    echo "== study_$study ${quick[*]}"
    SECONDS=0
    "$build/tests/bench/study_$study" --out "$data" "${quick[@]}" | tee "$data/$study.log"
    echo "   (${SECONDS} s wall)"
  done
fi

if [[ ! -x "$chart" ]]; then
  echo "palpchart was not built (VTK missing?): CSVs are in $data, no charts" >&2
  exit 1
fi
if [[ -n ${DISPLAY:-} ]]; then
  charts
elif command -v xvfb-run >/dev/null; then
  # One virtual display for all charts.
  PALP_BUILD_DIR=$build PALP_FIGURES_DIR=$figures PALP_STUDIES_DIR=$data \
    xvfb-run -a "$0" --charts-only "${studies[@]}"
else
  echo "no display and no xvfb-run: install xvfb (deploy/install-deps.sh) to render charts" >&2
  exit 1
fi

if [[ $charts_only == 0 ]]; then
  echo "== measured (this machine: $(nproc) cores, $(uname -m))"
  want speed_accuracy &&
    { sed -n '/Pareto front/,/^  [a-z]*: \|^wrote/p' "$data/speed_accuracy.log" | grep -v "^wrote" || true; }
  want pop_through && { grep -h -E "static threshold|push  finger" "$data/pop_through.log" || true; }
  # (each line above is skipped when its study was not asked for)
  want passivity && awk '/stable from/ { key = $1 " " $2 " " $3; n[key]++; if ($0 ~ /never/) bad[key]++ }
       END { for (k in n) printf "passivity %-32s %d of %d hand forces unstable at every rate\n",
                                 k, bad[k], n[k] }' "$data/passivity.log" | sort
  want force_model && { grep -h -E "^  (paper|palp|bone N)|^friction|^creep|^bound|^smooth" "$data/force_model.log" || true; }
  want pop_through && { grep -h "^  tunnel" "$data/pop_through.log" || true; }
  want stability && awk -F, 'NR > 1 && $1 == "all" && $3 >= 1000 {
       printf "stability %-13s %5d Hz: worst p2p %.3g mm (%s), worst step %.3g x bound, %d of %d runs not held\n",
              $2, $3, $4, $5, $7, $8, $9 }' "$data/stability_summary.csv" || true
fi
