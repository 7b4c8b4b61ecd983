#!/usr/bin/env bash
# palpd and a remote render station across an impaired link (docs/palpd_benchmarks.md): two
# network namespaces, palp-server (palpd and a local observer) and palp-station (the render
# station's probe), joined by a point-to-point link that delays every packet by DELAY ms and
# drops LOSS % of them, in each direction (192.0.2.1 and 192.0.2.2, TEST-NET-1, existing only
# in these namespaces; the host's own network is not touched). The link is tc netem on a veth pair
# when the kernel has sch_netem, otherwise a user-space emulator on two TUN devices
# (tests/bench/palpd_bench.py link: the same per-packet delay and Bernoulli loss).
#
# Two runs of palpd (torso phantom, sim device, finger:37, --bind 192.0.2.1) at RATE:
#   local    one observer on this host only (the baseline)
#   station  the same observer + `palp probe` inside the namespace, through the link
# Reported: the loop's overruns and lateness in both runs (the loop must not care), and the
# station's delivered fraction, seq gaps, longest silence and latency percentiles (both ends
# share CLOCK_MONOTONIC: same machine, so --same-host latency is meaningful).
#
#   tests/bench/palpd_netem.sh [BUILD_DIR]          (root: creates a namespace and links)
#
# Environment: PALP_NETEM_RATE (1000), PALP_NETEM_SECONDS (20), PALP_NETEM_DELAY_MS (20),
# PALP_NETEM_LOSS_PCT (1), PALP_NETEM_OUT (/tmp/palp-netem). The namespaces, the links and every
# process started here are removed on exit.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-${PALP_BUILD_DIR:-build}}
case $build in -h | --help) sed -n '2,22p' "$0"; exit 0 ;; esac
rate=${PALP_NETEM_RATE:-1000}
seconds=${PALP_NETEM_SECONDS:-20}
delay=${PALP_NETEM_DELAY_MS:-20}
loss=${PALP_NETEM_LOSS_PCT:-1}
out=${PALP_NETEM_OUT:-/tmp/palp-netem}
palpd=$(realpath "$build/server/palpd")
palp=$(realpath "$build/server/palp")
py=/usr/bin/python3
helper=tests/bench/palpd_bench.py
export PYTHONDONTWRITEBYTECODE=1
export PALP_SCENE_CACHE=${PALP_SCENE_CACHE:-$out/cache}
ns=palp-station
sns=palp-server
host_ip=192.0.2.1
station_ip=192.0.2.2
mkdir -p "$out"

pids=()
cleanup() {
  local pid
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  ip netns del "$ns" 2>/dev/null || true
  ip netns del "$sns" 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 130' INT TERM

ip netns del "$ns" 2>/dev/null || true
ip netns del "$sns" 2>/dev/null || true
ip netns add "$ns"
ip netns add "$sns"
ip -n "$ns" link set lo up
ip -n "$sns" link set lo up
link_kind=""
link_pid=""
# tc netem on a veth pair when the kernel has it ...
ip -n "$sns" link add palp-h type veth peer name palp-s
ip -n "$sns" link set palp-s netns "$ns"
if ip netns exec "$sns" tc qdisc add dev palp-h root netem delay "${delay}ms" loss "${loss}%" \
    2>/dev/null &&
  ip netns exec "$ns" tc qdisc add dev palp-s root netem delay "${delay}ms" loss "${loss}%" \
    2>/dev/null; then
  link_kind="veth + tc netem"
  ip -n "$sns" addr add "$host_ip/24" dev palp-h
  ip -n "$sns" link set palp-h up
  ip -n "$ns" addr add "$station_ip/24" dev palp-s
  ip -n "$ns" link set palp-s up
else
  # ... else the TUN emulator (it removes its devices when it exits, after the runs).
  ip -n "$sns" link del palp-h
  link_kind="TUN pair + user-space delay/loss (no sch_netem in this kernel)"
  "$py" -u "$helper" link palp-th palp-ts $((2 * seconds + 40)) "$delay" "$loss" \
    >"$out/link.log" 2>&1 &
  link_pid=$!
  pids+=("$link_pid")
  for ((i = 0; i < 100; i++)); do grep -qs ready "$out/link.log" && break; sleep 0.1; done
  grep -qs ready "$out/link.log" || { cat "$out/link.log" >&2; exit 1; }
  ip link set palp-th netns "$sns"
  ip link set palp-ts netns "$ns"
  ip -n "$sns" addr add "$host_ip" peer "$station_ip" dev palp-th
  ip -n "$sns" link set palp-th up
  ip -n "$ns" addr add "$station_ip" peer "$host_ip" dev palp-ts
  ip -n "$ns" link set palp-ts up
fi
echo "link: $link_kind, ${delay} ms each way, ${loss} % loss each way"
if command -v ping >/dev/null; then ip netns exec "$ns" ping -c 3 -i 0.2 -W 2 "$host_ip" | tail -1; fi

"$palp" prep phantom:torso >/dev/null 2>&1 || true

run() {
  local name=$1 with_station=$2 dir=$out/$1 port="" i
  rm -rf "$dir"; mkdir -p "$dir"
  ip netns exec "$sns" "$palpd" --scene phantom:torso --device sim --tool finger:37 --rate "$rate" --bind "$host_ip" \
    --port 0 --duration $((seconds + 5)) --stats-json "$dir/stats.json" >"$dir/palpd.log" 2>&1 \
    </dev/null &
  local palpd_pid=$!
  pids+=("$palpd_pid")
  for ((i = 0; i < 1200; i++)); do
    port=$(sed -n 's/.*listening on [^ ]*:\([0-9]*\),.*/\1/p' "$dir/palpd.log" 2>/dev/null | head -1)
    [[ -n $port ]] && break
    kill -0 "$palpd_pid" 2>/dev/null || { cat "$dir/palpd.log" >&2; exit 1; }
    sleep 0.1
  done
  [[ -n $port ]] || { echo "palpd did not start" >&2; exit 1; }
  local probes=()
  ip netns exec "$sns" "$palp" probe "$host_ip:$port" --same-host --duration "$seconds" --stall 5 --name local \
    >"$dir/local.log" 2>&1 &
  probes+=($!)
  if [[ $with_station == 1 ]]; then
    ip netns exec "$ns" "$palp" probe "$host_ip:$port" --same-host --duration "$seconds" \
      --stall 5 --name station >"$dir/station.log" 2>&1 &
    probes+=($!)
  fi
  pids+=("${probes[@]}")
  for i in "${probes[@]}"; do wait "$i" || true; done
  wait "$palpd_pid" || true
  "$py" "$helper" summary "$name" "$dir/stats.json" "$dir/local.log" | tee -a "$out/results.jsonl"
  if [[ $with_station == 1 ]]; then
    echo "station: $(tail -1 "$dir/station.log")" | tee -a "$out/results.jsonl"
    grep -E "frames  |latency|arrivals" "$dir/station.log" || true
  fi
}

: >"$out/results.jsonl"
run "local_${rate}hz" 0
run "station_${rate}hz" 1
if [[ -n $link_pid ]]; then
  kill "$link_pid"; wait "$link_pid" || true
  echo "link: $(tail -1 "$out/link.log")" | tee -a "$out/results.jsonl"
fi
