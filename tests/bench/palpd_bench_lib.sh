# What palpd's loopback benchmarks share (sourced by palpd_fanout.sh, palpd_wake.sh and
# palpd_dds.sh, from the repository root, after they set `out`, `palpd` and `palp`): the Python
# helper, the scene cache, the background processes stopped on exit, bash's child CPU time, and
# palpd started in the background until it listens.
py=/usr/bin/python3
helper=tests/bench/palpd_bench.py
export PYTHONDONTWRITEBYTECODE=1
export PALP_SCENE_CACHE=${PALP_SCENE_CACHE:-$out/cache}
mkdir -p "$out"
: >"$out/results.jsonl"

pids=()
cleanup() {
  local pid
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# CPU seconds (user + system) used so far by this script's finished children (bash's times,
# run in this shell: a command substitution would see only its own children).
child_cpu() {
  times >"$out/times.txt"
  cpu_s=$(tail -1 "$out/times.txt" | awk '{ s = 0; for (i = 1; i <= 2; i++) {
    split($i, a, "m"); sub("s", "", a[2]); s += 60 * a[1] + a[2] } printf "%.3f", s }')
}

# Starts palpd (background, pid appended to pids); sets port once it listens.
start_palpd() {
  local log=$1; shift
  "$palpd" "$@" >"$log" 2>&1 </dev/null &
  pids+=($!)
  local i
  for ((i = 0; i < 1200; i++)); do
    if grep -qs "listening on" "$log"; then
      port=$(sed -n 's/.*listening on [^ ]*:\([0-9]*\),.*/\1/p' "$log" | head -1)
      return 0
    fi
    kill -0 "${pids[-1]}" 2>/dev/null || { cat "$log" >&2; return 1; }
    sleep 0.1
  done
  echo "palpd did not start" >&2
  return 1
}
