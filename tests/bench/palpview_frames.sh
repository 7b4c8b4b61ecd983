#!/bin/bash
# palpview's frame-time split (receive / deformation / render) against a live palpd, with and
# without the skin deformation, at a given window size. Measures; never gates anything.
#
# usage: tests/bench/palpview_frames.sh BUILD_DIR SCENE [WIDTHxHEIGHT] [FRAMES] [OUT_DIR]
#   BUILD_DIR  a build with palpd and palpview (e.g. build)
#   SCENE      any palpd scene (phantom:torso, a prep directory, a CT file)
# Writes OUT_DIR/{deform,nodeform}.json (palpview --stats-json) and .png, prints palpview's
# summary lines. PALPVIEW_MAX_DIM (default 256) is palpview's --volume-max-dim (512: a 512-voxel
# CT at full resolution); PALPVIEW_MODES (default "deform nodeform") the runs to make. The JSON's
# volume_received_s is palpview's start -> whole volume; deformation_split holds the deformation
# update's thread CPU time, solve/resample split and ROI (tests/bench/palpview_deform.sh). Runs
# palpview under xvfb-run (screen as large as the window) when DISPLAY is unset; the render time
# is then llvmpipe's (CPU), not a GPU's.
set -euo pipefail
build=${1:?build dir}
scene=${2:?scene}
size=${3:-1920x1080}
frames=${4:-12}
out=${5:-$(mktemp -d)}
width=${size%x*}
height=${size#*x}
mkdir -p "$out"

"$build/server/palpd" --scene "$scene" --device sim --port 0 --no-realtime --duration 3600 \
  >"$out/palpd.log" 2>&1 &
palpd_pid=$!
trap 'kill $palpd_pid 2>/dev/null || true' EXIT
for _ in $(seq 1 1200); do
  grep -q "listening on" "$out/palpd.log" && break
  kill -0 $palpd_pid 2>/dev/null || { cat "$out/palpd.log"; exit 1; }
  sleep 0.5
done
port=$(grep -o "127.0.0.1:[0-9]*" "$out/palpd.log" | head -1 | cut -d: -f2)

run() {
  if [ -z "${DISPLAY:-}" ]; then
    xvfb-run -a -s "-screen 0 ${width}x${height}x24" "$@"
  else
    "$@"
  fi
}
for mode in ${PALPVIEW_MODES:-deform nodeform}; do
  extra=()
  [ "$mode" = nodeform ] && extra=(--no-deformation)
  run "$build/client/palpview" --connect "127.0.0.1:$port" --width "$width" --height "$height" \
    --screenshot "$out/$mode.png" --frames "$frames" --timeout 600 \
    --volume-max-dim "${PALPVIEW_MAX_DIM:-256}" \
    --stats-json "$out/$mode.json" "${extra[@]}"
  # palpview start -> the whole volume at the station (the second run finds palpd's encoded
  # chunks cached: server/net/volume_cache.hpp)
  python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print("%s: volume at the station %.2f s, dims %s" % (sys.argv[2], j["volume_received_s"], j.get("volume_dims")))' \
    "$out/$mode.json" "$mode"
done
echo "load: $(uptime | sed 's/.*load average: //')"
echo "results in $out"
