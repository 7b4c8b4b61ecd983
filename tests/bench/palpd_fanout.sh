#!/usr/bin/env bash
# palpd fan-out on loopback (docs/palpd_benchmarks.md): the torso phantom, the sim device,
# finger:37, and N observers (`palp probe`, every tick) at each rate, in three scenarios:
#   plain    N observers
#   stalled  N observers + a client that says Hello and never reads (4 KiB receive buffer)
#   garbage  N observers + a client sending random bytes, undecodable messages and bad length
#            prefixes, reconnecting whenever it is dropped
#   tls      N observers over TLS 1.3 (palpd --tls-cert/--tls-key, probes --tls-ca; certificates
#            made by deploy/make-certs.sh into OUT/pki): compare with plain at the same rate
# For each: palpd's deadline misses (overruns / deadlines), wake-up lateness (histogram bound
# for p99, and the max), the observers' p99 tick-to-client latency, the smallest delivered
# fraction and frames/s over the observers, the machine's CPU use, palpd's own CPU seconds (read
# from /proc after the observers end, palpd still running) and the load average at the start of
# each scenario. One JSON line per scenario goes to OUT/results.jsonl, a Markdown table to stdout.
#
#   tests/bench/palpd_fanout.sh [BUILD_DIR]
#
# BUILD_DIR (or $PALP_BUILD_DIR, default build) holds server/palpd and server/palp.
# Environment: PALP_FANOUT_RATES (default "1000 4000"), PALP_FANOUT_OBSERVERS (8),
# PALP_FANOUT_SECONDS (10 per scenario), PALP_FANOUT_SCENARIOS ("plain stalled garbage"),
# PALP_FANOUT_OUT (default /tmp/palp-fanout; logs and JSON kept there), PALP_FANOUT_PALPD_ARGS
# (more palpd options, e.g. "--wake sleep --net-wake poll" for palpd's pre-issue-18 timing; the
# before/after table of those is tests/bench/palpd_wake.sh). Loopback only; every process is
# bounded by a duration and everything started here is stopped on exit.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-${PALP_BUILD_DIR:-build}}
case $build in -h | --help) sed -n '2,25p' "$0"; exit 0 ;; esac
rates=${PALP_FANOUT_RATES:-1000 4000}
observers=${PALP_FANOUT_OBSERVERS:-8}
seconds=${PALP_FANOUT_SECONDS:-10}
scenarios=${PALP_FANOUT_SCENARIOS:-plain stalled garbage}
out=${PALP_FANOUT_OUT:-/tmp/palp-fanout}
read -r -a palpd_args <<<"${PALP_FANOUT_PALPD_ARGS:-}"
palpd=$build/server/palpd
palp=$build/server/palp
source tests/bench/palpd_bench_lib.sh  # helper, cleanup, child_cpu, start_palpd

# Certificates for the tls scenario, made afresh (the script never overwrites a key).
if [[ " $scenarios " == *" tls "* ]]; then
  rm -rf "$out/pki"
  deploy/make-certs.sh "$out/pki" ca >/dev/null
  deploy/make-certs.sh "$out/pki" server 127.0.0.1 >/dev/null
fi

# Warm the scene cache once so no run pays for the torso's prep.
"$palp" prep phantom:torso >/dev/null 2>&1 || true

for rate in $rates; do
  for scenario in $scenarios; do
    name=${scenario}_${rate}hz_${observers}obs
    load=$(cut -d' ' -f1-3 /proc/loadavg)
    child_cpu; cpu0=$cpu_s; wall0=$(date +%s.%N)
    dir=$out/$name
    rm -rf "$dir"; mkdir -p "$dir"
    server_tls=() client_tls=()
    if [[ $scenario == tls ]]; then
      server_tls=(--tls-cert "$out/pki/server.crt" --tls-key "$out/pki/server.key")
      client_tls=(--tls-ca "$out/pki/ca.crt")
    fi
    start_palpd "$dir/palpd.log" --scene phantom:torso --device sim --tool finger:37 \
      --rate "$rate" --port 0 --duration $((seconds + 4)) --stats-json "$dir/stats.json" \
      "${palpd_args[@]}" "${server_tls[@]}"
    palpd_pid=${pids[-1]}
    extra=()
    case $scenario in
      stalled) "$py" "$helper" stall 127.0.0.1 "$port" $((seconds + 2)) >"$dir/extra.log" 2>&1 &
        extra+=($!) ;;
      garbage) "$py" "$helper" garbage 127.0.0.1 "$port" $((seconds + 2)) >"$dir/extra.log" 2>&1 &
        extra+=($!) ;;
      plain | tls) ;;
      *) echo "unknown scenario $scenario" >&2; exit 2 ;;
    esac
    pids+=("${extra[@]}")
    sleep 0.5
    probes=()
    for ((i = 0; i < observers; i++)); do
      "$palp" probe "127.0.0.1:$port" --duration "$seconds" --stall 5 --name "obs$i" \
        "${client_tls[@]}" >"$dir/probe$i.log" 2>&1 &
      probes+=($!)
      # palpd admits 4 connections per address before their Hello: a TLS handshake on a busy
      # machine takes long enough for 16 simultaneous probes to exceed it, so start them apart
      sleep 0.05
    done
    pids+=("${probes[@]}")
    for pid in "${probes[@]}"; do wait "$pid" || true; done
    for pid in "${extra[@]}"; do wait "$pid" || true; done
    palpd_cpu=$(awk -v hz="$(getconf CLK_TCK)" '{ printf "%.2f", ($14 + $15) / hz }' \
      "/proc/$palpd_pid/stat" 2>/dev/null || echo null)
    wait "$palpd_pid" || true
    # palpd, the observers and the extra client: CPU time over (wall time x cores)
    child_cpu
    cpu=$(awk -v c0="$cpu0" -v c1="$cpu_s" -v w0="$wall0" -v w1="$(date +%s.%N)" \
      -v n="$(nproc)" 'BEGIN{printf "%.1f", 100 * (c1 - c0) / ((w1 - w0) * n)}')
    row=$("$py" "$helper" summary "$name" "$dir/stats.json" "$dir"/probe*.log)
    echo "${row%\}},\"cpu_used_pct\":$cpu,\"palpd_cpu_s\":$palpd_cpu,\"load\":\"$load\",\"seconds\":$seconds}" |
      tee -a "$out/results.jsonl"
  done
done

"$py" - "$out/results.jsonl" <<'EOF'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
f = lambda v, d=1: "n/a" if v is None else f"{v:.{d}f}"
print("\n| scenario | ticks | misses (overruns) | lateness p99 (bound) / max, us | "
      "latency p99 (worst observer), us | min delivered | min frames/s | CPU used | "
      "palpd CPU s | load at start |")
print("|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r['scenario']} | {r['ticks']} | {f(r['miss_pct'], 3)} % ({r['overruns']}) | "
          f"<= {f(r['late_p99_us_at_most'], 0)} / {f(r['late_max_us'])} | "
          f"{f(r['latency_p99_us_max'])} | {f(r['delivered_min'], 4)} | "
          f"{f(r['frames_per_s_min'])} | {r['cpu_used_pct']} % | "
          f"{r.get('palpd_cpu_s', 'n/a')} | {r.get('load', 'n/a')} |")
EOF
