#!/usr/bin/env bash
# The real CT's maps on its own 3 mm grid (--map-spacing 0, the default) against refinement
# (--map-spacing 2: 1.5 mm nodes) and 1 mm (--map-spacing 1): prep's wall time and peak memory,
# the maps' size, palpd's resident memory with the sim device, `palp run`'s peak memory, and
# palp bench's tick (finger:37, paper and palp) on each (docs/prep.md, "Finer maps for coarse
# CTs"; docs/force_model.md). Runs alternate between the settings; prints markdown tables.
# Measures; gates nothing.
#
#   tests/bench/map_refine_ct.sh [RUNS]          (default 3; PALP_CT, PALP_BUILD_DIR)
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${PALP_BUILD_DIR:-build}
palp=$build/server/palp
palpd=$build/server/palpd
ct=${PALP_CT:-../shared/data/ct_abdomen_3mm.nii.gz}
runs=${1:-3}
spacings=${PALP_MAP_SPACINGS:-0 2 1}
[[ -f $ct ]] || { echo "no CT at $ct: skipped"; exit 0; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "## prep (palp prep CT --no-cache --map-spacing S), $runs runs alternating"
echo "| --map-spacing | map grid | d_surf+d_bone MiB in memory | wall s | peak RSS MiB | load |"
echo "|---|---|---|---|---|---|"
for r in $(seq 1 "$runs"); do
  for s in $spacings; do
    out=$work/prep_$s
    /usr/bin/time -f "%e %M" -o "$work/time" "$palp" prep "$ct" --out "$out" --no-cache -q \
      --map-spacing "$s"
    read -r wall kb <"$work/time"
    python3 - "$out/prep.json" "$s" "$wall" "$kb" "$(cut -d' ' -f1-3 /proc/loadavg)" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); g = j["map_grid"]; d = g["dimensions"]
n = d[0] * d[1] * d[2]
print(f"| {sys.argv[2]} | {d[0]}x{d[1]}x{d[2]} at {g['spacing_mm'][0]:g} mm | "
      f"{2 * 4 * n / 2**20:.0f} | {float(sys.argv[3]):.2f} | {int(sys.argv[4]) / 1024:.0f} | {sys.argv[5]} |")
PY
  done
done

echo
echo "## palpd (sim device, 6 s; RSS at 4 s) and palp run (finger:37, the ribs path) peak RSS"
echo "| --map-spacing | palpd load s | palpd RSS MiB | palp run peak RSS MiB | load |"
echo "|---|---|---|---|---|"
for s in $spacings; do
  dir=$work/prep_$s
  log=$work/palpd_$s.log
  /usr/bin/time -f "%e" -o "$work/load_time" "$palp" bench --scene "$dir" --tool finger:1 \
    --ticks 1 --warmup 0 -q >/dev/null
  "$palpd" --scene "$dir" --device sim --port 0 --no-realtime --duration 6 >"$log" 2>&1 &
  pid=$!
  for _ in $(seq 1 300); do
    grep -q "listening on" "$log" && break
    kill -0 $pid 2>/dev/null || break
    sleep 0.1
  done
  sleep 4
  rss=$(awk '/VmRSS/{print $2}' /proc/$pid/status 2>/dev/null || echo 0)
  wait $pid || true
  "$palp" traj ribs --scene "$dir" --out "$work/ribs_$s.csv" -q >/dev/null 2>&1 || true
  run_kb=0
  if [[ -s $work/ribs_$s.csv ]]; then
    /usr/bin/time -f "%M" -o "$work/run_time" "$palp" run --scene "$dir" --tool finger:37 \
      --trajectory "$work/ribs_$s.csv" --out "$work/run_$s.csv" -q >/dev/null
    run_kb=$(cat "$work/run_time")
  fi
  echo "| $s | $(cat "$work/load_time") (bench, 1 tick) | $((rss / 1024)) | $((run_kb / 1024)) | $(cut -d' ' -f1-3 /proc/loadavg) |"
done

echo
echo "## palp bench --scene DIR --tool finger:37 --model M (100000 ticks, 2000 warm-up), $runs runs alternating"
echo "| --map-spacing | model | p50 ns | p99 ns | load |"
echo "|---|---|---|---|---|"
for r in $(seq 1 "$runs"); do
  for s in $spacings; do
    for m in paper palp; do
      "$palp" bench --scene "$work/prep_$s" --tool finger:37 --model $m -q | tail -1 |
        python3 -c 'import json, sys
j = json.loads(sys.stdin.read())
print("| %s | %s | %.0f | %.0f | %s |" % (sys.argv[1], sys.argv[2], j["tick_ns_p50"], j["tick_ns_p99"], sys.argv[3]))' \
          "$s" "$m" "$(cut -d' ' -f1-3 /proc/loadavg)"
    done
  done
done
