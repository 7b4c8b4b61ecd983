#!/usr/bin/env bash
# The shared-CT training session of docs/tasks.md, from one command: landmarks, a scripted
# trainee for each task (palp traj search), each session scored (palp task), the report pages,
# the cohort CSV and a screenshot of the PTCD report (headless Chromium, when installed).
#
#   tests/bench/task_session.sh [OUT_DIR]      (default build/task_session; needs ../shared/data)
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-build/task_session}
palp=${PALP:-build/server/palp}
ct=../shared/data/ct_abdomen_3mm.nii.gz
[[ -x "$palp" ]] || { echo "task_session: no $palp (build first)" >&2; exit 2; }
[[ -f "$ct" ]] || { echo "task_session: no $ct" >&2; exit 2; }
rm -rf "$out" && mkdir -p "$out"
export PALP_SCENE_CACHE="$out/cache"
step() {  # NAME COMMAND...: runs it quietly, prints its wall time
  local name=$1; shift
  local t0=$(date +%s.%N)
  "$@" > "$out/$name.log" 2>&1 || { cat "$out/$name.log" >&2; exit 1; }
  printf '%-16s %6.2f s\n' "$name" "$(echo "$(date +%s.%N) - $t0" | bc)"
}
session() {  # TASK TASK_OPTIONS START_MM MISSES SESSION_ID
  local task=$1 opts=$2 start=$3 misses=$4 id=$5
  # shellcheck disable=SC2086
  step "traj-$task" "$palp" traj search --scene "$ct" --landmarks "$out/ct_landmarks.json" \
    --task "$task" $opts --start "$start" --miss "$misses" \
    --out "$out/${task}_run.csv" --marks "$out/${task}_marks.csv"
  # shellcheck disable=SC2086
  step "task-$task" "$palp" task "$task" $opts --scene "$ct" \
    --landmarks "$out/ct_landmarks.json" --trajectory "$out/${task}_run.csv" \
    --marks "$out/${task}_marks.csv" --out "$out/$task" --csv "$out/cohort.csv" \
    --session "$id" --trainee scripted
  sed -n '/^  trial/,/^  report/p' "$out/task-$task.log"
}
step landmarks "$palp" landmarks "$ct" --out "$out/ct_landmarks.json"
sed -n '/^vertebrae/,/^Tuffier/p' "$out/landmarks.log"
# PTCD starts 25 mm above the space: 35 mm would start 2 mm under the scan's top edge.
session ptcd "--side right --space 9" 25 0,25,12 ct-ptcd
session lumbar "--interspace L3/L4" 35 0,25,10 ct-lumbar
session femoral "--side right" 35 0,20 ct-femoral
if command -v chromium > /dev/null; then
  step screenshot chromium --headless --no-sandbox --disable-gpu \
    --screenshot="$out/ptcd_report.png" --window-size=1200,1600 "file://$(realpath "$out/ptcd/report.html")"
fi
echo "wrote $out: ptcd/ lumbar/ femoral/ report.html each, cohort.csv, ct_landmarks.json"
