#!/usr/bin/env bash
# The skin preset before and after the sub-voxel skin, as palpview shows a scene: one palpd, then
# palpview screenshots with --skin-hu (the CT's HU inside the body mask, before) and without it
# (d_surf's zero level, after), side by side in one contact sheet per camera. No tool, HUD or
# deformation: the skin alone. Makes pictures; never gates anything.
#
# usage: tests/bench/skin_before_after.sh BUILD_DIR SCENE OUT_PREFIX [WxH] [AZ,EL,DIST ...]
#   e.g. tests/tools/with_xvfb.sh tests/bench/skin_before_after.sh build \
#          ../shared/data/ct_abdomen_3mm.nii.gz docs/figures/skin_ct 400x300 30,20,0 30,10,450
# Writes OUT_PREFIX_N.png (N = 1, 2, ... for the cameras; default one, 30,20,0: 30 degrees round
# and 20 up from the anterior view, the whole volume fitted). Needs a display (DISPLAY, or run it
# under tests/tools/with_xvfb.sh).
set -euo pipefail
build=${1:?build dir}
scene=${2:?scene}
prefix=${3:?output prefix}
size=${4:-480x360}
shift $(($# < 4 ? $# : 4))
cameras=("$@")
[[ ${#cameras[@]} -gt 0 ]] || cameras=("30,20,0")
width=${size%x*} height=${size#*x}
mkdir -p "$(dirname "$prefix")"
work=$(mktemp -d)
server=""
cleanup() {
  [[ -n $server ]] && kill "$server" 2>/dev/null && wait "$server" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

"$build/server/palpd" --scene "$scene" --device sim --port 0 --no-realtime --duration 3600 \
  >"$work/palpd.log" 2>&1 &
server=$!
port=""
for _ in $(seq 1 1200); do  # a CT input is prepped first (seconds)
  port=$(sed -n 's/^palpd: listening on [^:]*:\([0-9]*\),.*/\1/p' "$work/palpd.log")
  [[ -n $port ]] && break
  kill -0 "$server" 2>/dev/null || { cat "$work/palpd.log" >&2; exit 1; }
  sleep 0.1
done
[[ -n $port ]] || { echo "palpd did not start" >&2; exit 1; }

n=0
for camera in "${cameras[@]}"; do
  n=$((n + 1))
  for kind in before after; do
    flags=()
    [[ $kind == before ]] && flags=(--skin-hu)
    "$build/client/palpview" --connect "127.0.0.1:$port" --width "$width" --height "$height" \
      --preset skin "${flags[@]}" --no-tool --no-overlays --no-deformation --camera "$camera" \
      --screenshot "$work/$n-$kind.png" --frames 2 --timeout 300 | tail -n 1
  done
  "$build/client/palpchart" --sheet "${prefix}_$n.png" --columns 2 \
    "$work/$n-before.png" "$work/$n-after.png"
  echo "${prefix}_$n.png: camera $camera, --skin-hu (left) and the sub-voxel skin (right)"
done
