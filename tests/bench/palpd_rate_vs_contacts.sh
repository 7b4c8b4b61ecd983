#!/usr/bin/env bash
# Fig. 5b as the paper measured it: palpd itself (not the bare tick) running the torso phantom's
# built-in palpation path with tools of 1 to 100 contact points, at a target rate; per tool the
# rate it kept (the target times the fraction of deadlines met), the fraction missed and the
# tick's compute time (mean, max), from palpd's --stats-json. Both models (palp, paper).
#
#   tests/bench/palpd_rate_vs_contacts.sh [--rate HZ] [--seconds S] [--out CSV]
#
# Needs build/server/palpd (PALP_BUILD_DIR); never builds. Without real-time privileges palpd runs
# as an ordinary thread (the CSV says so): on a shared machine the misses measure the machine as
# much as palpd. Writes under /tmp unless --out says otherwise. Measures; gates nothing.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${PALP_BUILD_DIR:-build}
rate=10000
seconds=3
out=${TMPDIR:-/tmp}/palpd_rate_vs_contacts.csv
while (($#)); do
  case $1 in
    --rate) rate=$2; shift 2 ;;
    --seconds) seconds=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h | --help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "usage: $0 [--rate HZ] [--seconds S] [--out CSV]" >&2; exit 2 ;;
  esac
done
palpd=$build/server/palpd
[[ -x $palpd ]] || { echo "$0: $palpd is not built (cmake --build $build --target palpd)" >&2; exit 2; }
work=$(mktemp -d "${TMPDIR:-/tmp}/palpd-rate.XXXXXX")
export PALP_SCENE_CACHE=$work/cache
echo "model,tool,contacts,target_hz,on_time_hz,missed_fraction,tick_mean_us,tick_max_us,realtime" >"$out"
for model in palp paper; do
  for tool in finger:1 finger:7 finger:19 finger:37 probe:9x3 probe:7x7 probe:10x10; do
    case $tool in
      finger:*) n=${tool#finger:} ;;
      probe:*) dims=${tool#probe:}; n=$(( ${dims%x*} * ${dims#*x} )) ;;
    esac
    "$palpd" --scene phantom:torso --device sim --tool "$tool" --model "$model" --rate "$rate" \
      --duration "$seconds" --port 0 -q --stats-json "$work/s.json" >/dev/null 2>&1 || true
    /usr/bin/python3 - "$work/s.json" "$model" "$tool" "$n" "$rate" >>"$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
t = d.get("tick_us", {})
# on time: the target rate times the fraction of deadlines met (skipped ones are misses)
miss = d["deadline_miss_fraction"]
print("%s,%s,%s,%s,%.1f,%.4f,%.2f,%.2f,%d" % (sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5],
      float(sys.argv[5]) * (1.0 - miss), miss, t.get("mean", float("nan")),
      t.get("max", float("nan")), 1 if d.get("realtime") else 0))
PY
  done
done
column -s, -t "$out"
echo "wrote $out"
rm -rf "$work"
