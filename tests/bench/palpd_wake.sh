#!/usr/bin/env bash
# The loop's wake-up and the loop -> network hand-off, before and after (issue 18;
# docs/palpd_benchmarks.md): one command, one table. palpd on the torso phantom, the sim device,
# finger:37, on loopback, in four cases:
#   4k_4obs        4000 Hz, 4 observers taking every tick
#   10k_4obs       10000 Hz, 4 observers taking every tick
#   1k_16obs_hog   1000 Hz, 16 observers, a CPU hog pinned to CPU 0 (taskset) all along
#   1k_16obs       1000 Hz, 16 observers (the tick-to-client latency case)
# each with every variant, repeated; the variants of one repeat run back to back, so a
# disturbance of the machine falls on all of them alike:
#   before         --wake sleep --net-wake poll   (the plain sleep and the 500 us poll)
#   after          palpd's defaults               (hybrid wake-up, eventfd hand-off)
#   pinned         after + --rt-cpu 1 --net-cpu 0 (the loop keeps CPU 1 to itself)
# and, to tell the two changes apart, hybrid-poll (--net-wake poll), sleep-event (--wake sleep)
# and every (--net-wake event-every: the eventfd written every tick, not coalesced).
# A row per run goes to OUT/results.jsonl (with the 1-minute load average at its start); the
# table (median and worst of the repeats per case and variant: misses, lateness, wake-up
# latency, latency p99, palpd's CPU and the loop thread's, of it spinning) to stdout and
# OUT/table.md.
#
#   tests/bench/palpd_wake.sh [BUILD_DIR]
#
# Environment: PALP_WAKE_REPEATS (3), PALP_WAKE_SECONDS (10 per run), PALP_WAKE_CASES (all four),
# PALP_WAKE_VARIANTS ("before after pinned"), PALP_WAKE_OUT (/tmp/palp-wake). About
# repeats x cases x variants x (seconds + 3) s: 6 minutes with the defaults.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-${PALP_BUILD_DIR:-build}}
case $build in -h | --help) sed -n '2,29p' "$0"; exit 0 ;; esac
repeats=${PALP_WAKE_REPEATS:-3}
seconds=${PALP_WAKE_SECONDS:-10}
cases=${PALP_WAKE_CASES:-4k_4obs 10k_4obs 1k_16obs_hog 1k_16obs}
variants=${PALP_WAKE_VARIANTS:-before after pinned}
out=${PALP_WAKE_OUT:-/tmp/palp-wake}
palpd=$build/server/palpd
palp=$build/server/palp
source tests/bench/palpd_bench_lib.sh  # helper, cleanup, child_cpu, start_palpd

variant_args() {
  case $1 in
    before) echo "--wake sleep --net-wake poll" ;;
    after) echo "" ;;
    pinned) echo "--rt-cpu 1 --net-cpu 0" ;;
    hybrid-poll) echo "--net-wake poll" ;;
    sleep-event) echo "--wake sleep" ;;
    every) echo "--net-wake event-every" ;;
    *) echo "unknown variant $1" >&2; return 2 ;;
  esac
}

hog_cmd=("$py" "$helper" hog)
if command -v taskset >/dev/null; then hog_cmd=(taskset -c 0 "${hog_cmd[@]}"); fi

"$palp" prep phantom:torso >/dev/null 2>&1 || true

for ((rep = 1; rep <= repeats; rep++)); do
  for case_name in $cases; do
    case $case_name in
      4k_4obs) rate=4000 observers=4 hog=0 ;;
      10k_4obs) rate=10000 observers=4 hog=0 ;;
      1k_16obs_hog) rate=1000 observers=16 hog=1 ;;
      1k_16obs) rate=1000 observers=16 hog=0 ;;
      *) echo "unknown case $case_name" >&2; exit 2 ;;
    esac
    for variant in $variants; do
      read -r -a extra <<<"$(variant_args "$variant")"
      dir=$out/$case_name/$variant/$rep
      rm -rf "$dir"; mkdir -p "$dir"
      load1=$(cut -d' ' -f1 /proc/loadavg)
      start_palpd "$dir/palpd.log" --scene phantom:torso --device sim --tool finger:37 \
        --rate "$rate" --port 0 --max-clients 32 --duration $((seconds + 2)) \
        --stats-json "$dir/stats.json" "${extra[@]}"
      palpd_pid=${pids[-1]}
      helpers=()
      if ((hog)); then
        "${hog_cmd[@]}" $((seconds + 2)) >"$dir/hog.log" 2>&1 &
        helpers+=($!)
      fi
      pids+=("${helpers[@]}")
      sleep 0.3
      for ((i = 0; i < observers; i++)); do
        "$palp" probe "127.0.0.1:$port" --duration "$seconds" --stall 5 --name "obs$i" \
          >"$dir/probe$i.log" 2>&1 &
        helpers+=($!)
      done
      pids+=("${helpers[@]}")
      for pid in "${helpers[@]}"; do wait "$pid" || true; done
      wait "$palpd_pid" || true
      row=$("$py" "$helper" summary "$case_name" "$dir/stats.json" "$dir"/probe*.log)
      echo "${row%\}},\"case\":\"$case_name\",\"variant\":\"$variant\",\"repeat\":$rep,\"load1\":$load1}" \
        | tee -a "$out/results.jsonl"
    done
  done
done

echo
"$py" "$helper" wake-table "$out/results.jsonl" | tee "$out/table.md"
echo
echo "$(nproc) CPUs, $(uname -r); load average now: $(cut -d' ' -f1-3 /proc/loadavg)"
