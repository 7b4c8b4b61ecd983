#!/usr/bin/env bash
# The loop's own cost (issue 41; docs/palpd_benchmarks.md): palpd's step against the force model
# and palpd's deadline misses against palp probe --check-rate's, each pair measured in one run,
# back to back, on the same machine. Per repeat and per build (a build is a directory holding
# palpd and palp; several compare a before and an after):
#   bench      palp bench --scene phantom:torso --tool finger:37: the force model's tick, p50
#   alone      palpd --scene phantom:torso --device sim --rate RATE, no client, --stats-json:
#              its mean and max step (tick_us), misses, eventfd writes a tick (net_signals)
#   check      palp probe --check-rate RATE (palpd's wake-up and hand-off, a stand-in tick):
#              its misses
# A row per run goes to OUT/results.jsonl (with the 1-minute load average at its start); the
# table (median and range of the repeats) to stdout and OUT/table.md.
#
#   tests/bench/palpd_loop_cost.sh [NAME=DIR ...]     (default: after=build/server)
#
# Environment: PALP_COST_REPEATS (3), PALP_COST_SECONDS (10), PALP_COST_RATE (4000),
# PALP_COST_OUT (/tmp/palp-loop-cost). About repeats x builds x (2 x seconds + 15) s.
set -euo pipefail
cd "$(dirname "$0")/../.."
case ${1:-} in -h | --help) sed -n '2,18p' "$0"; exit 0 ;; esac
builds=("$@")
((${#builds[@]})) || builds=(after=build/server)
repeats=${PALP_COST_REPEATS:-3}
seconds=${PALP_COST_SECONDS:-10}
rate=${PALP_COST_RATE:-4000}
out=${PALP_COST_OUT:-/tmp/palp-loop-cost}
mkdir -p "$out"
: >"$out/results.jsonl"
export PALP_SCENE_CACHE=${PALP_SCENE_CACHE:-$out/cache}
first_palp=${builds[0]#*=}/palp
"$first_palp" prep phantom:torso >/dev/null 2>&1 || true

for ((rep = 1; rep <= repeats; rep++)); do
  for entry in "${builds[@]}"; do
    name=${entry%%=*} dir=${entry#*=}
    run=$out/$name/$rep
    rm -rf "$run"; mkdir -p "$run"
    load1=$(cut -d' ' -f1 /proc/loadavg)
    "$dir/palp" bench --scene phantom:torso --tool finger:37 --ticks 50000 -q >"$run/bench.json"
    "$dir/palpd" --scene phantom:torso --device sim --tool finger:37 --rate "$rate" \
      --port 0 --duration "$seconds" --stats-json "$run/palpd.json" -q >"$run/palpd.log" 2>&1
    "$dir/palp" probe --check-rate "$rate" --duration "$seconds" -q >"$run/check.json" || true
    /usr/bin/python3 - "$run" "$name" "$rep" "$load1" <<'PY' | tee -a "$out/results.jsonl"
import json, sys
run, name, rep, load1 = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
bench = json.loads(open(f"{run}/bench.json").read().strip().splitlines()[-1])
d = json.load(open(f"{run}/palpd.json"))
check = json.loads(open(f"{run}/check.json").read().strip().splitlines()[-1])
print(json.dumps({"build": name, "repeat": rep, "load1": load1,
                  "model_p50_us": bench["tick_ns_p50"] / 1e3,
                  "step_mean_us": d["tick_us"]["mean"], "step_max_us": d["tick_us"]["max"],
                  "palpd_miss_pct": 100 * d["deadline_miss_fraction"],
                  "signals_per_tick": d["net_signals"] / max(d["ticks"], 1),
                  "check_miss_pct": check["miss_pct"],
                  "check_signals": check.get("net_signals")}))
PY
  done
done

/usr/bin/python3 - "$out/results.jsonl" "$rate" <<'PY' | tee "$out/table.md"
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
rate = sys.argv[2]
def cell(vals, fmt):
    return f"{fmt % statistics.median(vals)} ({fmt % min(vals)}–{fmt % max(vals)})"
print(f"| build | runs | force model p50 us | palpd step mean us | step / model p50 | palpd step max us"
      f" | eventfd writes a tick | palpd misses % at {rate} Hz | check-rate misses % | load |")
print("|---|---|---|---|---|---|---|---|---|---|")
for name in dict.fromkeys(r["build"] for r in rows):
    rs = [r for r in rows if r["build"] == name]
    ratio = [r["step_mean_us"] / r["model_p50_us"] for r in rs]
    print(f"| {name} | {len(rs)} | {cell([r['model_p50_us'] for r in rs], '%.2f')} | "
          f"{cell([r['step_mean_us'] for r in rs], '%.2f')} | {cell(ratio, '%.2f')} | "
          f"{cell([r['step_max_us'] for r in rs], '%.0f')} | "
          f"{cell([r['signals_per_tick'] for r in rs], '%.3f')} | "
          f"{cell([r['palpd_miss_pct'] for r in rs], '%.3f')} | "
          f"{cell([r['check_miss_pct'] for r in rs], '%.3f')} | "
          f"{cell([r['load1'] for r in rs], '%.2f')} |")
PY
echo
echo "$(nproc) CPUs, $(uname -r); load average now: $(cut -d' ' -f1-3 /proc/loadavg)"
