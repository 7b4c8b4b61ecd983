#!/bin/bash
# Several palpview observers and a controller on one palpd: does each viewer keep its rate, and
# is the haptic loop's jitter unchanged? Measures; never gates anything.
#
# usage: tests/bench/palpview_observers.sh BUILD_DIR [SECONDS] [OBSERVERS] [SCENE] [OUT_DIR]
#   BUILD_DIR  a build with palp, palpd and palpview (e.g. build)
#   SECONDS    length of each run (default 20)
#   OBSERVERS  palpview observers in the loaded runs (default 3)
#   SCENE      palpd scene (default phantom:torso)
# Three runs of palpd at 1 kHz, each writing its loop counters (--stats-json):
#   alone      --device sim, no client
#   observers  --device sim, OBSERVERS palpview observers
#   controller --device remote, one palpview controller replaying a press-and-slide trajectory
#              (palp traj) plus OBSERVERS observers
# Every palpview renders 640x400 windows on one shared Xvfb display (without DISPLAY) or on the
# current display, and writes --stats-json. The summary table (render frames/s per viewer,
# stream frames/s, delivered, loop lateness p99/max, overruns) is printed and written to
# OUT_DIR/summary.json. On a machine without a GPU the viewers render with llvmpipe on the CPU,
# competing with palpd for cores; palpd runs SCHED_FIFO when permitted (root or LimitRTPRIO).
set -euo pipefail
build=${1:?build dir}
seconds=${2:-20}
observers=${3:-3}
scene=${4:-phantom:torso}
out=${5:-$(mktemp -d)}
mkdir -p "$out"
bin_palp="$build/server/palp"
bin_palpd="$build/server/palpd"
bin_view="$build/client/palpview"
for b in "$bin_palp" "$bin_palpd" "$bin_view"; do
  [ -x "$b" ] || { echo "missing $b (build it first)" >&2; exit 2; }
done

pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

if [ -z "${DISPLAY:-}" ]; then
  display=:$((90 + RANDOM % 400))
  Xvfb "$display" -screen 0 1920x1080x24 -nolisten tcp -noreset >"$out/xvfb.log" 2>&1 &
  pids+=($!)
  export DISPLAY=$display
  sleep 1
fi

# The controller's path: the paper's slide across the ribs (palp traj ribs), or a sliding press
# where the scene has no ribs.
"$bin_palp" traj ribs --scene "$scene" --out "$out/controller.csv" >/dev/null 2>&1 ||
  "$bin_palp" traj slide-ramp --scene "$scene" --out "$out/controller.csv" >/dev/null

start_palpd() {  # name device
  "$bin_palpd" --scene "$scene" --device "$2" --port 0 --duration "$((seconds + 4))" \
    --stats-json "$out/$1.palpd.json" >"$out/$1.palpd.log" 2>&1 &
  palpd_pid=$!
  pids+=("$palpd_pid")
  for _ in $(seq 1 600); do
    grep -q "listening on" "$out/$1.palpd.log" && break
    kill -0 "$palpd_pid" 2>/dev/null || { cat "$out/$1.palpd.log" >&2; exit 1; }
    sleep 0.2
  done
  port=$(grep -o "127.0.0.1:[0-9]*" "$out/$1.palpd.log" | head -1 | cut -d: -f2)
}

viewer() {  # run index extra-args...
  local run=$1 index=$2
  shift 2
  "$bin_view" --connect "127.0.0.1:$port" --width 640 --height 400 --duration "$seconds" \
    --name "$run-$index" --stats-json "$out/$run.view$index.json" "$@" \
    >"$out/$run.view$index.log" 2>&1 &
  view_pids+=($!)
}

for run in alone observers controller; do
  echo "run: $run (${seconds} s)"
  device=sim
  [ "$run" = controller ] && device=remote
  start_palpd "$run" "$device"
  view_pids=()
  if [ "$run" = controller ]; then
    viewer "$run" 0 --controller --script "$out/controller.csv"
  fi
  if [ "$run" != alone ]; then
    for i in $(seq 1 "$observers"); do viewer "$run" "$i" --camera "$((i * 60)),20,0"; done
  fi
  for p in "${view_pids[@]}"; do wait "$p" || echo "  a viewer exited with $?" >&2; done
  wait "$palpd_pid" || true
done

/usr/bin/python3 - "$out" "$observers" <<'EOF'
import glob, json, os, sys
out, observers = sys.argv[1], int(sys.argv[2])
rows = {}
for run in ("alone", "observers", "controller"):
    p = json.load(open(os.path.join(out, run + ".palpd.json")))
    loop = p
    views = []
    for f in sorted(glob.glob(os.path.join(out, run + ".view*.json"))):
        v = json.load(open(f))
        views.append({"name": os.path.basename(f), "controller": v.get("controller"),
                      "render_fps": v.get("frames_per_s"), "stream_fps": v.get("stream_frames_per_s"),
                      "delivered": v.get("delivered"), "render_ms_p50": v["render_ms"].get("p50")})
    rows[run] = {"ticks": loop.get("ticks"), "overruns": loop.get("overruns"),
                 "faults": loop.get("faults"), "lateness_p99_us_bound": loop["lateness_us"]["p99_at_most"],
                 "lateness_max_us": loop["lateness_us"]["max"], "realtime": loop.get("realtime"),
                 "viewers": views}
json.dump(rows, open(os.path.join(out, "summary.json"), "w"), indent=2)
for run, r in rows.items():
    print(f"{run:10s} ticks {r['ticks']} overruns {r['overruns']} faults {r['faults']} "
          f"lateness p99 <= {r['lateness_p99_us_bound']} us, max {r['lateness_max_us']} us, "
          f"realtime {r['realtime']}")
    for v in r["viewers"]:
        print(f"    {v['name']:28s} render {v['render_fps']} frames/s, stream "
              f"{v['stream_fps']} frames/s, delivered {v['delivered']}, render p50 {v['render_ms_p50']} ms")
print("results in", out)
EOF
