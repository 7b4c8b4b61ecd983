#!/bin/bash
# Packs what palpview needs to run on the device machine (docs/palpview.md, "On a GPU"): its
# image (Ubuntu 24.04, NVIDIA driver, no X server, no VTK) gets palpd, palpview and their Debian
# libraries, Xvfb with Mesa's software GLX for the server side (NVIDIA's libGLX then renders on
# the GPU, client side), glxinfo and xdpyinfo. A call carries at most 64 MiB with the repository,
# so it is two archives: .devA (Mesa's DRI driver and LLVM, ~44 MB) and .devB (the rest, ~27 MB),
# both ignored by git. Then, on the device (two calls in a row, the second within 30 s):
#   run: python3 -c "import tarfile as t; [t.open('.devA/'+a).extractall('/opt/palpdev/'+a[:2]) for a in ('A1.tar.xz','A2.tar.xz')]"   carry [.devA]
#   run: python3 -c "import tarfile as t; t.open('.devB/B.tar.xz').extractall('/opt/palpdev/B')" && bash tests/bench/palpview_gpu_run.sh   carry [.devB]
# usage: tests/bench/palpview_gpu_bundle.sh [BUILD_DIR]   (needs xvfb, mesa-utils-bin and
# x11-utils .debs: fetched with apt-get download into a scratch folder)
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
apt-get download mesa-utils-bin x11-utils >/dev/null 2>&1 || { echo "apt-get download failed" >&2; exit 1; }
dpkg -x mesa-utils-bin_*.deb x && dpkg -x x11-utils_*.deb x
mkdir -p B/bin B/lib B/xbin A1/lib A2/lib A2/dri
cp "$root/$build/server/palpd" "$root/$build/server/palp" "$root/$build/client/palpview" B/bin/
cp "$root/tests/bench/palpview_frames.sh" B/
[ -f "$root/../shared/data/ct_abdomen_3mm.nii.gz" ] && cp "$root/../shared/data/ct_abdomen_3mm.nii.gz" B/
cp x/usr/bin/glxinfo.x86_64-linux-gnu B/xbin/glxinfo
cp x/usr/bin/xdpyinfo /usr/bin/Xvfb /usr/bin/xkbcomp B/xbin/
cp -r /usr/share/X11/xkb B/xkb
system='/(libc|libm|libpthread|libdl|librt|libstdc\+\+|libgcc_s)\.so|ld-linux'
libs_of() { ldd "$@" | awk '{print $3}' | grep / | grep -v -E "$system" | sort -u; }
libs_of B/bin/* B/xbin/* | xargs cp -L -t B/lib/
# glvnd and the X client libraries GLX and GLFW open at run time (dlopen: not in ldd's list)
for f in libGL.so.1 libGLX.so.0 libGLdispatch.so.0 libOpenGL.so.0 libEGL.so.1 libGLX_mesa.so.0 \
  libxcb-glx.so.0 libX11-xcb.so.1 libxcb-dri2.so.0 libxcb-dri3.so.0 libXext.so.6 libXfixes.so.3 \
  libXxf86vm.so.1 libxcb-shm.so.0 libxshmfence.so.1 libxcb-present.so.0 libxcb-sync.so.1 \
  libxcb-xfixes.so.0 libxcb-randr.so.0 libXrandr.so.2 libXi.so.6 libXcursor.so.1 libXinerama.so.1 \
  libXrender.so.1; do
  cp -L -n "/usr/lib/x86_64-linux-gnu/$f" B/lib/
done
cp -L /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so A2/dri/
for l in $(libs_of /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so); do
  b=$(basename "$l")
  [ -f "B/lib/$b" ] && continue
  if [ "$b" = "${b#libLLVM}" ]; then cp -L "$l" A2/lib/; else cp -L "$l" A1/lib/; fi
done
mkdir -p "$root/.devA" "$root/.devB"
for d in A1 A2; do tar -C $d -cf - . | xz -9 -T2 >"$root/.devA/$d.tar.xz"; done
tar -C B -cf - . | xz -9 -T2 >"$root/.devB/B.tar.xz"
grep -q '^/.devA/' "$root/.git/info/exclude" 2>/dev/null || printf '/.devA/\n/.devB/\n' >>"$root/.git/info/exclude"
ls -la "$root/.devA" "$root/.devB"
