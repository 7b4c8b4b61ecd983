#!/usr/bin/env bash
# palpd's loop against its subscriber count, DDS against palp.v1's TCP fan-out (issue 17;
# docs/palpd_benchmarks.md, docs/dds.md): palpd on the torso phantom, the sim device, finger:37,
# at 1 kHz (PALP_DDS_RATE), and N subscribers on loopback taking every tick:
#   tcp  N `palp probe 127.0.0.1:PORT` (palp.v1; palpd serves at most 16: larger N is reported
#        as not possible and not run)
#   dds     N `palp probe --dds DOMAIN --rig bench` processes (palpd --dds DOMAIN --rig bench),
#           Cyclone on the loopback interface, unicast (PALP_DDS_URI)
#   dds_mc  the same with Cyclone's default interface and multicast (one send per sample for
#           every subscriber; the kernel loops it back to this host's sockets; PALP_DDS_MC_URI)
#   dds_batch, dds_mc_batch  as dds and dds_mc, the subscribers `palp probe --dds --batch`
#           (rt/palp/<rig>/frame_batch: every frame, PALP_DDS_BATCH_MS of them per sample; palpd
#           --dds-batch-ms PALP_DDS_BATCH_MS)
# PALP_DDS_PROBE_ARGS: more `palp probe --dds` options (e.g. "--take-ms 10": batched takes,
# "--contacts": frames with their contacts); PALP_DDS_PALPD_ARGS: more palpd options (e.g.
# "--rt-cpu 1 --net-cpu 0").
# For each: palpd's deadline misses (overruns / deadlines), wake-up lateness (p99 bound, max),
# the subscribers' worst and median p99 tick-to-subscriber latency, the smallest delivered
# fraction and frames/s, the machine's CPU use (palpd and all subscribers), palpd's own CPU
# seconds and the load average at the start. One JSON line per run to OUT/results.jsonl, a
# Markdown table to stdout and OUT/table.md.
#
#   tests/bench/palpd_dds.sh [BUILD_DIR]
#
# Environment: PALP_DDS_COUNTS ("1 16 64"), PALP_DDS_TRANSPORTS ("tcp dds dds_mc dds_batch
# dds_mc_batch"), PALP_DDS_BATCH_MS (10), PALP_DDS_RCVBUF (Cyclone's socket receive buffer for
# every DDS transport, e.g. 4MB: <Internal><SocketReceiveBufferSize min=...>; the kernel's
# net.core.rmem_max may cap it; default: Cyclone's, 1 MiB if allowed), PALP_DDS_SECONDS
# (10 per run), PALP_DDS_WARMUP_S (12: DDS subscribers count nothing until this long after the
# last has started), PALP_DDS_RATE (1000), PALP_DDS_REPEATS (1), PALP_DDS_DOMAIN (42),
# PALP_DDS_OUT (/tmp/palp-dds), PALP_DDS_URI (the Cyclone configuration; default: the loopback
# interface, no multicast, unicast discovery of localhost, up to 100 participants),
# PALP_DDS_MC_URI (the multicast one). The rows carry palpd's own count of frames it numbered
# and dropped before publishing (palpd_dds_dropped; they are gaps the subscribers count too).
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-${PALP_BUILD_DIR:-build}}
case $build in -h | --help) sed -n '2,33p' "$0"; exit 0 ;; esac
counts=${PALP_DDS_COUNTS:-1 16 64}
transports=${PALP_DDS_TRANSPORTS:-tcp dds dds_mc dds_batch dds_mc_batch}
batch_ms=${PALP_DDS_BATCH_MS:-10}
rcvbuf=${PALP_DDS_RCVBUF:-}
seconds=${PALP_DDS_SECONDS:-10}
settle=${PALP_DDS_WARMUP_S:-12}
rate=${PALP_DDS_RATE:-1000}
repeats=${PALP_DDS_REPEATS:-1}
domain=${PALP_DDS_DOMAIN:-42}
out=${PALP_DDS_OUT:-/tmp/palp-dds}
palpd=$build/server/palpd
palp=$build/server/palp
uri_lo=${PALP_DDS_URI:-'<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><Peers><Peer address="localhost"/></Peers><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>100</MaxAutoParticipantIndex></Discovery></Domain></CycloneDDS>'}
uri_mc=${PALP_DDS_MC_URI:-'<CycloneDDS><Domain id="any"><Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>100</MaxAutoParticipantIndex></Discovery></Domain></CycloneDDS>'}
if [[ -n $rcvbuf ]]; then  # the same socket receive buffer in both configurations
  internal="<Internal><SocketReceiveBufferSize min=\"$rcvbuf\"/></Internal>"
  uri_lo=${uri_lo/<\/Domain>/$internal<\/Domain>}
  uri_mc=${uri_mc/<\/Domain>/$internal<\/Domain>}
fi
read -r -a probe_args <<<"${PALP_DDS_PROBE_ARGS:-}"
read -r -a palpd_args <<<"${PALP_DDS_PALPD_ARGS:-}"
source tests/bench/palpd_bench_lib.sh  # helper, cleanup, child_cpu, start_palpd

"$palp" prep phantom:torso >/dev/null 2>&1 || true  # the scene cache, warmed once

for ((rep = 1; rep <= repeats; rep++)); do
  for n in $counts; do
    for transport in $transports; do
      name=${transport}_${n}sub_${rate}hz_r$rep
      if [[ $transport == tcp && $n -gt 16 ]]; then
        echo "{\"scenario\":\"$name\",\"not_possible\":\"palpd serves at most 16 palp.v1 clients\"}" |
          tee -a "$out/results.jsonl"
        continue
      fi
      load=$(cut -d' ' -f1-3 /proc/loadavg)
      dir=$out/$name
      rm -rf "$dir"; mkdir -p "$dir"
      child_cpu; cpu0=$cpu_s; wall0=$(date +%s.%N)
      # Subscribers start 50 ms apart: palpd runs long enough for the last to finish.
      # DDS subscribers skip a warm-up so all of them measure the same window, after every one
      # has joined (joining 64 Cyclone participants at once is a burst of discovery traffic).
      run_s=$(awk -v s="$seconds" -v n="$n" -v w="$settle" 'BEGIN{printf "%d", s + 6 + w + n * 0.05}')
      dds_args=(--dds "$domain" --rig bench --dds-batch-ms "$batch_ms")
      sub_args=()
      case $transport in
        tcp) dds_args=() ;;
        dds) export CYCLONEDDS_URI=$uri_lo ;;
        dds_mc) export CYCLONEDDS_URI=$uri_mc ;;
        dds_batch) export CYCLONEDDS_URI=$uri_lo; sub_args=(--batch) ;;
        dds_mc_batch) export CYCLONEDDS_URI=$uri_mc; sub_args=(--batch) ;;
        *) echo "unknown transport $transport" >&2; exit 2 ;;
      esac
      start_palpd "$dir/palpd.log" --scene phantom:torso --device sim --tool finger:37 \
        --rate "$rate" --port 0 --max-clients 16 --duration "$run_s" \
        --stats-json "$dir/stats.json" "${dds_args[@]}" "${palpd_args[@]}"
      palpd_pid=${pids[-1]}
      sleep 0.5
      probes=()
      for ((i = 0; i < n; i++)); do
        if [[ $transport != tcp ]]; then
          warmup=$(awk -v n="$n" -v i="$i" -v w="$settle" 'BEGIN{printf "%.2f", (n - i) * 0.05 + w}')
          "$palp" probe --dds "$domain" --rig bench --duration "$seconds" --stall 10 \
            --warmup "$warmup" "${sub_args[@]}" \
            "${probe_args[@]}" >"$dir/probe$i.log" 2>&1 &
        else
          "$palp" probe "127.0.0.1:$port" --duration "$seconds" --stall 5 --name "obs$i" \
            >"$dir/probe$i.log" 2>&1 &
        fi
        probes+=($!)
        sleep 0.05
      done
      pids+=("${probes[@]}")
      for pid in "${probes[@]}"; do wait "$pid" || true; done
      palpd_cpu=$(awk -v hz="$(getconf CLK_TCK)" '{ printf "%.2f", ($14 + $15) / hz }' \
        "/proc/$palpd_pid/stat" 2>/dev/null || echo null)
      wait "$palpd_pid" || true
      child_cpu
      cpu=$(awk -v c0="$cpu0" -v c1="$cpu_s" -v w0="$wall0" -v w1="$(date +%s.%N)" \
        -v n="$(nproc)" 'BEGIN{printf "%.1f", 100 * (c1 - c0) / ((w1 - w0) * n)}')
      row=$("$py" "$helper" summary "$name" "$dir/stats.json" "$dir"/probe*.log)
      dropped=$(sed -n 's/.*, \([0-9]*\) dropped before publishing.*/\1/p' "$dir/palpd.log" | tail -1)
      echo "${row%\}},\"palpd_dds_dropped\":${dropped:-null},\"transport\":\"$transport\",\"subscribers\":$n,\"cpu_used_pct\":$cpu,\"palpd_cpu_s\":$palpd_cpu,\"load\":\"$load\",\"seconds\":$seconds}" |
        tee -a "$out/results.jsonl"
    done
  done
done

"$py" - "$out/results.jsonl" <<'PY' | tee "$out/table.md"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
f = lambda v, d=1: "n/a" if v is None else f"{v:.{d}f}"
na = lambda v: "n/a" if v is None else v
print("\n| run | ticks | misses (overruns) | lateness p99 (bound) / max, us | latency p99 worst / "
      "median subscriber, us | min delivered | min frames/s | subscribers ok | CPU used | "
      "palpd CPU s | palpd DDS drops | load at start |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    if "not_possible" in r:
        print(f"| {r['scenario']} | {r['not_possible']} ||||||||||")
        continue
    print(f"| {r['scenario']} | {r['ticks']} | {f(r['miss_pct'], 3)} % ({r['overruns']}) | "
          f"<= {f(r['late_p99_us_at_most'], 0)} / {f(r['late_max_us'])} | "
          f"{f(r['latency_p99_us_max'])} / {f(r['latency_p99_us_median'])} | "
          f"{f(r['delivered_min'], 4)} | {f(r['frames_per_s_min'])} | "
          f"{r['observers_ok']}/{r['observers']} | {r['cpu_used_pct']} % | "
          f"{na(r.get('palpd_cpu_s'))} | {na(r.get('palpd_dds_dropped'))} | "
          f"{r.get('load', 'n/a')} |")
PY
