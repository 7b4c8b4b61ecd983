#!/usr/bin/env bash
# Installs the Debian 12 packages palp needs to build and test, and nothing else.
# Idempotent and quiet when everything is present; only Debian packages are ever fetched.
set -euo pipefail

packages=(
  cmake ninja-build g++ pkg-config
  zlib1g-dev libdeflate-dev libisal-dev libgdcm-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev
  libprotobuf-dev protobuf-compiler libasio-dev libtomlplusplus-dev
  libvtk9-dev libglfw3-dev xvfb xauth libgl1-mesa-dri
  chromium
  libusb-1.0-0-dev libumockdev-dev umockdev
  libssl-dev openssl
  libopenigtlink-dev openigtlink-examples cyclonedds-dev cyclonedds-tools python3
)

missing=()
for pkg in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$pkg")
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

echo "palp: installing missing Debian packages: ${missing[*]}" >&2
sudo=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "palp: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
