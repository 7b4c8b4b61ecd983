#!/usr/bin/env bash
# palpd's maps cut to its device's reach (--map-window) against the whole maps: palpd's resident
# memory and tick, and palp bench's tick p50/p99 on the same window, for the shared CT and a
# 512x512x400 CT (docs/tuning.md, "Keeping only what the device can reach").
#
#   tests/bench/palpd_maps.sh [BIG_SCENE]
#
# BIG_SCENE: a prep directory or CT of 512x512x400 voxels (default: made here with
# `palp phantom torso --dims 512x512x400 --spacing 0.8x0.8x1.0` and prepped into the cache).
# Per scene: palpd with the sim device (its built-in path; --map-window off, then 10 mm) for
# ${PALP_MAPS_SECONDS:-12} s, its RSS read from /proc at 2/3 of the run, its peak (VmHWM) and
# mean/max tick from --stats-json; palpd with a usb-haptic device placed on the patient (absent:
# only the memory; --map-window off, then auto = Falcon workspace +-50 mm + 50 mm); palp bench
# (finger:37, 50000 ticks) whole and --window-mm 10. Prints a markdown table. Measures; gates
# nothing. Needs ~8 GB of memory for the big scene's whole maps.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${PALP_BUILD_DIR:-build}
palp=$build/server/palp
palpd=$build/server/palpd
secs=${PALP_MAPS_SECONDS:-12}
ct=${PALP_CT:-../shared/data/ct_abdomen_3mm.nii.gz}
work=${TMPDIR:-/tmp}/palp-maps
mkdir -p "$work"
export PALP_SCENE_CACHE=${PALP_SCENE_CACHE:-$work/cache}
big=${1:-}
if [[ -z $big ]]; then
  big=$work/torso512.nii.gz
  [[ -f $big ]] || "$palp" phantom torso --dims 512x512x400 --spacing 0.8x0.8x1.0 --out "$big"
fi
scenes=()
[[ -f $ct ]] && scenes+=("ct=$ct")
scenes+=("512x512x400=$big")

# palpd NAME SCENE ARGS...: prints "rss_mib hwm_mib mean_us max_us window-note"
run_palpd() {
  local name=$1 scene=$2
  shift 2
  local log=$work/$name.log json=$work/$name.json
  rm -f "$json"
  "$palpd" --scene "$scene" --port 0 --no-realtime --duration "$secs" --stats-json "$json" "$@" \
    >"$log" 2>&1 &
  local pid=$! rss=""
  # the scene loads first (seconds for the big one): sample once it listens, 2/3 into the run
  for _ in $(seq 1 1200); do
    grep -q "listening on" "$log" && break
    kill -0 $pid 2>/dev/null || break
    sleep 0.1
  done
  sleep "$(python3 -c "print($secs*2/3)")"
  rss=$(awk '/VmRSS/{print $2}' /proc/$pid/status 2>/dev/null || echo 0)
  hwm=$(awk '/VmHWM/{print $2}' /proc/$pid/status 2>/dev/null || echo 0)
  wait $pid || true
  python3 - "$json" "$rss" "$hwm" "$log" <<'PY'
import json, re, sys
path, rss, hwm, log = sys.argv[1], int(sys.argv[2] or 0), int(sys.argv[3] or 0), sys.argv[4]
try:
    j = json.load(open(path)); mean, mx = j["tick_us"]["mean"], j["tick_us"]["max"]
except Exception:
    mean = mx = float("nan")
note = ""
for line in open(log):
    m = re.search(r"maps cut to .*", line)
    if m: note = m.group(0)
print(f"{rss/1024:.0f} {hwm/1024:.0f} {mean:.2f} {mx:.1f} {note}")
PY
}

bench() {  # bench SCENE [ARGS]: "p50 p99 maps_mib"
  "$palp" bench --scene "$1" --tool finger:37 --ticks 50000 -q "${@:2}" | tail -1 |
    python3 -c 'import json,sys; j=json.loads(sys.stdin.read()); print(j["tick_ns_p50"], j["tick_ns_p99"], round(j.get("maps_mib", 0), 1))'
}

echo "| scene | device | maps | palpd RSS MiB (peak) | palpd tick mean / max (us) | palp bench tick p50 / p99 (ns), maps MiB | load |"
echo "|---|---|---|---|---|---|---|"
for entry in "${scenes[@]}"; do
  label=${entry%%=*} scene=${entry#*=}
  for mode in off 10; do
    load=$(cut -d' ' -f1 /proc/loadavg)
    read -r rss hwm mean mx note < <(run_palpd "${label}_sim_$mode" "$scene" --device sim --map-window $mode)
    if [[ $mode == off ]]; then b=$(bench "$scene"); else b=$(bench "$scene" --window-mm 10); fi
    echo "| $label | sim | ${note:-whole} | $rss ($hwm) | $mean / $mx | $b | $load |"
  done
  for mode in off auto; do
    load=$(cut -d' ' -f1 /proc/loadavg)
    read -r rss hwm mean mx note < <(run_palpd "${label}_placed_$mode" "$scene" --device usb-haptic \
      --device-profile falcon --map-window $mode)
    echo "| $label | usb-haptic placed (absent: no ticks) | ${note:-whole} | $rss ($hwm) | - | - | $load |"
  done
done
