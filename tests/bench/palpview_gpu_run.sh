#!/bin/bash
# On the device machine, after tests/bench/palpview_gpu_bundle.sh's archives are unpacked into
# /opt/palpdev/{A1,A2,B}: Xvfb with Mesa's GLX on the server side, NVIDIA's libGLX on the client
# side (glvnd, __GLX_VENDOR_LIBRARY_NAME=nvidia), then tests/bench/palpview_frames.sh per case.
# Prints palpview's summary lines and the GPU's utilisation; writes $OUT/res.tar.gz (the JSONs,
# screenshots and logs). VENDOR=mesa renders with llvmpipe on the machine's CPUs instead.
# usage: bash tests/bench/palpview_gpu_run.sh   (CASES: lines "SCENE WxH MAX_DIM NAME"; FRAMES)
set -u
D=/opt/palpdev
final=${OUT:-/tmp/out}
res=/tmp/palpview_gpu
mkdir -p "$res" "$final"
mkdir -p /usr/lib/x86_64-linux-gnu/dri /usr/share/X11
cp $D/A2/dri/swrast_dri.so /usr/lib/x86_64-linux-gnu/dri/  # the X server's GLX loads it from here
cp $D/B/xbin/xkbcomp /usr/bin/xkbcomp
[ -d /usr/share/X11/xkb ] || cp -r $D/B/xkb /usr/share/X11/xkb
export LD_LIBRARY_PATH=$D/B/lib:$D/A2/lib:$D/A1/lib
mkdir -p $D/build/server $D/build/client
ln -sf $D/B/bin/palpd $D/build/server/palpd
ln -sf $D/B/bin/palp $D/build/server/palp
ln -sf $D/B/bin/palpview $D/build/client/palpview
$D/B/xbin/Xvfb :97 -screen 0 1920x1080x24 -nolisten tcp +extension GLX >"$res/xvfb.log" 2>&1 &
xvfb=$!
sleep 3
export DISPLAY=:97 __GLX_VENDOR_LIBRARY_NAME=${VENDOR:-nvidia}
$D/B/xbin/xdpyinfo | grep -c GLX >/dev/null || echo "Xvfb has no GLX extension"
renderer=$($D/B/xbin/glxinfo -B 2>&1 | grep "OpenGL renderer string")
echo "== $renderer; $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader); $(nproc) CPUs"
[ -n "$renderer" ] || { echo "no GLX context: $($D/B/xbin/glxinfo -B 2>&1 | head -3)"; kill $xvfb; exit 1; }
CT=$D/B/ct_abdomen_3mm.nii.gz
CASES=${CASES:-"phantom:torso 1920x1080 256 torso256_1080
phantom:torso 1920x1080 512 torso512_1080
phantom:torso 960x540 512 torso512_540
phantom:torso 480x270 512 torso512_270
$CT 1920x1080 256 ct_1080"}
while read -r scene size dim name; do
  [ -n "$name" ] || continue
  [ -e "$scene" ] || [ "${scene#phantom:}" != "$scene" ] || continue
  echo "== $name: scene $(basename "$scene"), window $size, --volume-max-dim $dim"
  (timeout 60 nvidia-smi --query-gpu=utilization.gpu --format=csv,noheader,nounits -lms 250 \
    >"$res/$name.util" 2>/dev/null &)
  PALPVIEW_MAX_DIM=$dim timeout 150 bash $D/B/palpview_frames.sh $D/build "$scene" "$size" \
    "${FRAMES:-30}" "$res/$name" </dev/null 2>&1 | grep -E "^palpview: [0-9]"
  pkill -f "nvidia-smi --query-gpu=utilization" 2>/dev/null
  for m in deform nodeform; do
    [ -f "$res/$name/$m.json" ] && python3 - "$res/$name/$m.json" "$name/$m" "$res/$name.util" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
r = j["render_ms"]
u = [int(x) for x in open(sys.argv[3]).read().split() if x.isdigit()]
busy = [x for x in u if x > 0]
print("%s: volume %s, render ms mean %.1f p50 %.1f p95 %.1f (n %d), %.1f frames/s; GPU busy %s %%"
      % (sys.argv[2], j["volume_dims"], r["mean"], r["p50"], r["p95"], r["n"], j["frames_per_s"],
         "%d-%d (median %d)" % (min(busy), max(busy), sorted(busy)[len(busy) // 2]) if busy else "-"))
PY
  done
done <<<"$CASES"
kill $xvfb 2>/dev/null
tar -C /tmp -czf "$final/res.tar.gz" palpview_gpu
