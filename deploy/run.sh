#!/usr/bin/env bash
# The main job on the embedded default: installs what is missing, builds, preprocesses the
# synthetic torso phantom into out/torso (masks + signed distance maps, with a summary), runs the
# real-time server palpd on it with the simulated device (a finger pressing and sliding across
# the ribs), and shows it being palpated in palpview:
#   - with a display (DISPLAY set): a palpview window for SECONDS seconds;
#   - without one: palpview renders under xvfb-run and writes screenshots
#     out/palpview/torso-N.png through the press, plus the frame-time split.
# Meanwhile the headless observer `palp probe` reports rate and latency.
#   deploy/run.sh [SECONDS]        (default 8; extra palpd options via PALPD_OPTIONS)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-8}
deploy/install-deps.sh
deploy/build.sh palp palpd palpview palpchart   # the programs only; deploy/test.sh builds the rest
build=${PALP_BUILD_DIR:-build}
bin=$build/server

"$bin/palp" prep phantom:torso --out out/torso
echo "outputs: $(ls out/torso | tr '\n' ' ')"

port=${PALP_PORT:-7400}
echo
echo "palpd: finger:37 on the torso at 1 kHz, sim device, port $port, for ${seconds} s"
# With a display palpd runs for the window's SECONDS (+4); without one it runs until the
# screenshots are written (a software renderer takes seconds a frame) and is stopped then.
duration=$((seconds + 4))
[[ -z "${DISPLAY:-}" ]] && duration=$((seconds + 300))
# shellcheck disable=SC2086
"$bin/palpd" --scene out/torso --device sim --port "$port" --duration "$duration" \
  ${PALPD_OPTIONS:-} &
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
# Clients start once palpd listens (it loads the scene and calibrates its wake-up first).
for _ in $(seq 1 150); do
  if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then break; fi
  kill -0 "$server" 2>/dev/null || { echo "palpd exited before listening" >&2; exit 1; }
  sleep 0.1
done

viewer=$build/client/palpview
if [[ ! -x "$viewer" ]]; then
  echo "palpview was not built (VTK or GLFW missing): showing the stream with palp probe only"
  "$bin/palp" probe "127.0.0.1:$port" --duration "$seconds"
elif [[ -n "${DISPLAY:-}" ]]; then
  echo "palpview: a window for ${seconds} s (mouse orbits, P switches preset, Esc quits)"
  "$bin/palp" probe "127.0.0.1:$port" --duration "$seconds" -q &
  probe=$!
  "$viewer" --connect "127.0.0.1:$port" --duration "$seconds"
  wait "$probe"
else
  echo "no display: palpview renders under xvfb-run into out/palpview/"
  mkdir -p out/palpview
  "$bin/palp" probe "127.0.0.1:$port" --duration "$seconds" -q &
  probe=$!
  shots=4
  for n in $(seq 1 "$shots"); do
    # One screenshot about every (seconds / shots) s of the sim path: approach, press, slide.
    xvfb-run -a -s "-screen 0 1280x800x24 -noreset" "$viewer" --connect "127.0.0.1:$port" \
      --width 1280 --height 800 --screenshot "out/palpview/torso-$n.png" \
      --frames 3 --stats-json "out/palpview/torso-$n.json" | tail -n 2
    sleep "$(awk -v s="$seconds" -v n="$shots" 'BEGIN { d = s / n - 1.5; print (d > 0 ? d : 0) }')"
  done
  wait "$probe"
  echo "screenshots: $(ls out/palpview/*.png | tr '\n' ' ')"
  kill -INT "$server" 2>/dev/null || true  # palpd prints its summary and exits
fi
wait "$server"
trap - EXIT
if [[ -x "$viewer" && -z "${DISPLAY:-}" ]]; then
  # The palpation sequence (approach, press over a rib, across the intercostal spaces) as PNGs
  # and one contact sheet: on the torso and, when the shared data is there, on the real CT.
  echo
  echo "palpation sequence: out/palpview/sequence/"
  deploy/view_sequence.sh out/torso torso out/palpview/sequence
  if [[ -f ../shared/data/ct_abdomen_3mm.nii.gz ]]; then
    deploy/view_sequence.sh ../shared/data/ct_abdomen_3mm.nii.gz ct out/palpview/sequence
  fi
fi
