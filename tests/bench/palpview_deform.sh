#!/bin/bash
# The deformation update in palpview (issue 15: "deformation update <= 5 ms"), measured where it
# runs: RUNS palpview runs against a live palpd (tests/bench/palpview_frames.sh, deformation on
# only), each FRAMES live frames, then one line per run and one over all of them: the update's
# wall time (what the frame waits for), the render thread's CPU time across it (what it cost,
# whoever else held the cores: llvmpipe's render threads and, on a shared machine, other jobs),
# the ChainMail solve and the resampling (wall), and the ChainMail box's elements. Measures;
# never gates anything.
#
# usage: tests/bench/palpview_deform.sh BUILD_DIR SCENE [RUNS] [WIDTHxHEIGHT] [FRAMES] [OUT_DIR]
#   e.g. PALPVIEW_MAX_DIM=512 tests/bench/palpview_deform.sh build /tmp/torso512 3 640x400 10
#   (SCENE: the 512 x 512 x 400 torso, `palp phantom torso --dims 512x512x400 --spacing
#   0.8x0.8x1.0 --out torso512.nii.gz` then `palp prep torso512.nii.gz --out /tmp/torso512`)
# Writes OUT_DIR/run-N/deform.{json,png}.
set -euo pipefail
build=${1:?build dir}
scene=${2:?scene}
runs=${3:-3}
size=${4:-640x400}
frames=${5:-10}
out=${6:-$(mktemp -d)}
here=$(dirname "$0")
for r in $(seq 1 "$runs"); do
  echo "run $r: load before $(uptime | sed 's/.*load average: //')"
  PALPVIEW_MODES=deform "$here/palpview_frames.sh" "$build" "$scene" "$size" "$frames" \
    "$out/run-$r" | grep -E "^load"
done
python3 - "$out" "$runs" <<'PY'
import json, os, statistics, sys
out, runs = sys.argv[1], int(sys.argv[2])
def p50(v):
    return statistics.median(v) if v else float("nan")
every = {"cpu_ms": [], "solve_ms": [], "resample_ms": [], "roi_elements": []}
walls = []
for r in range(1, runs + 1):
    j = json.load(open(os.path.join(out, "run-%d" % r, "deform.json")))
    split = j["deformation_split"]["per_frame"]
    wall = j["deformation_ms"]
    walls.append(wall["p50"])
    for k in every:
        every[k] += split[k]
    print("run %d: wall p50 %.2f mean %.2f max %.2f ms | thread CPU p50 %.2f max %.2f ms | "
          "solve p50 %.2f, resample p50 %.2f ms | ROI elements p50 %.0f max %.0f | %d active of %d"
          % (r, wall["p50"], wall["mean"], wall["max"], p50(split["cpu_ms"]),
             max(split["cpu_ms"] or [0]), p50(split["solve_ms"]), p50(split["resample_ms"]),
             p50(split["roi_elements"]), max(split["roi_elements"] or [0]),
             len(split["cpu_ms"]), wall["n"]))
print("all %d runs: wall p50 of the runs' p50 %.2f ms | thread CPU p50 %.2f, p95 %.2f ms | "
      "solve p50 %.2f, resample p50 %.2f ms | ROI elements p50 %.0f"
      % (runs, p50(walls), p50(every["cpu_ms"]),
         sorted(every["cpu_ms"])[int(0.95 * (len(every["cpu_ms"]) - 1))] if every["cpu_ms"] else 0,
         p50(every["solve_ms"]), p50(every["resample_ms"]), p50(every["roi_elements"])))
PY
echo "load after: $(uptime | sed 's/.*load average: //')"
echo "results in $out"
