#!/usr/bin/env bash
# The main job on the embedded default: installs what is missing, builds, preprocesses the
# synthetic torso phantom into out/torso (masks + signed distance maps, with a summary), then
# runs the real-time server palpd on it with the simulated device for a few seconds while the
# headless observer `palp probe` reports what a render client would receive.
#   deploy/run.sh [SECONDS]        (default 5; extra palpd options via PALPD_OPTIONS)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-5}
deploy/install-deps.sh
deploy/build.sh
bin=${PALP_BUILD_DIR:-build}/server

"$bin/palp" prep phantom:torso --out out/torso
echo "outputs: $(ls out/torso | tr '\n' ' ')"

port=${PALP_PORT:-7400}
echo
echo "palpd: finger:37 on the torso at 1 kHz, sim device, port $port, for ${seconds} s"
# shellcheck disable=SC2086
"$bin/palpd" --scene out/torso --device sim --port "$port" --duration "$((seconds + 2))" \
  ${PALPD_OPTIONS:-} &
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
sleep 1
"$bin/palp" probe "127.0.0.1:$port" --duration "$seconds"
wait "$server"
trap - EXIT
