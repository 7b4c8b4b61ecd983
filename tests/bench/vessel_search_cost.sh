#!/bin/bash
# What the contrast-filled vessel search costs the whole `palp prep` (docs/anatomy.md, "Cost of
# the vessel search"): on each input, runs alternate between the default (search on),
# `--vessels off` and, with --before OTHER_PALP, that build's default, so all three share the
# machine's load. Each run is `/usr/bin/time -f "%e %U %M" palp prep INPUT --out DIR --no-cache -q`.
# Prints per input and build the median and range of wall seconds, user CPU seconds and peak
# RSS, and the search's cost: the default's median wall over the `--vessels off` one. Never
# fails on a time (exit 0 unless a run fails).
#
# Inputs: the shared CTs (../shared/data, when there), the torso phantom on its own grid and on
# the speed benchmark's 384x384x160 at 0.8x0.8x1.5 mm (drawn into --work), or the files given.
#
# Usage: tests/bench/vessel_search_cost.sh [--palp build/server/palp] [--runs 5]
#                                          [--before PALP] [--work DIR] [INPUT ...]
set -euo pipefail

palp=build/server/palp
runs=5
before=""
work=${TMPDIR:-/tmp}/palp_vessel_cost
inputs=()
while [ $# -gt 0 ]; do
  case "$1" in
    --palp) palp=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --before) before=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    -*) echo "vessel_search_cost.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) inputs+=("$1"); shift ;;
  esac
done
[ -x "$palp" ] || { echo "vessel_search_cost.sh: $palp is not an executable (build first)" >&2; exit 2; }
[ -z "$before" ] || [ -x "$before" ] || { echo "vessel_search_cost.sh: $before is not an executable" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "vessel_search_cost.sh: needs /usr/bin/time (Debian package: time)" >&2; exit 2; }
mkdir -p "$work"
if [ ${#inputs[@]} -eq 0 ]; then
  shared=$(cd "$(dirname "$0")/../.." && pwd)/../shared/data
  for f in ct_abdomen_3mm.nii.gz ct_aorta_contrast_1.5mm.nii.gz; do
    [ -f "$shared/$f" ] && inputs+=("$shared/$f")
  done
  "$palp" phantom torso --out "$work/torso.nii.gz" > /dev/null
  "$palp" phantom torso --dims 384x384x160 --spacing 0.8x0.8x1.5 --out "$work/torso_384.nii.gz" > /dev/null
  inputs+=("$work/torso.nii.gz" "$work/torso_384.nii.gz")
fi

# the kernel's transparent huge pages decide much of prep's time (docs/benchmarks.md)
thp=$(sed -n 's/.*\[\(.*\)\].*/\1/p' /sys/kernel/mm/transparent_hugepage/enabled 2>/dev/null || true)
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(uname -sr), transparent huge pages: ${thp:-unknown}"
echo "palp: $palp${before:+, before: $before}, runs per build and input: $runs, load (1 min) at start: $(cut -d' ' -f1 /proc/loadavg)"
echo
echo "| input | build | wall s, median [range] | user CPU s, median | peak RSS MiB, median [range] |"
echo "|---|---|---|---|---|"
for input in "${inputs[@]}"; do
  times="$work/times.txt"
  rm -f "$times"
  builds=(default off)
  [ -n "$before" ] && builds=(before default off)
  for r in $(seq "$runs"); do
    for build in "${builds[@]}"; do
      bin=$palp
      extra=()
      [ "$build" = before ] && bin=$before
      [ "$build" = off ] && extra=(--vessels off)
      rm -rf "$work/out"
      /usr/bin/time -f "$build %e %U %M" -a -o "$times" \
        "$bin" prep "$input" --out "$work/out" --no-cache -q "${extra[@]}" > /dev/null
    done
  done
  python3 - "$times" "$(basename "$input")" <<'PY'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
name = sys.argv[2]
median = {}
for build in ("before", "default", "off"):
    r = [x for x in rows if x[0] == build]
    if not r:
        continue
    wall = sorted(float(x[1]) for x in r)
    user = statistics.median(float(x[2]) for x in r)
    rss = sorted(int(x[3]) / 1024 for x in r)
    median[build] = statistics.median(wall)
    label = {"before": "--before, default", "default": "default (search on)", "off": "--vessels off"}[build]
    print(f"| {name} | {label} | {median[build]:.2f} [{wall[0]:.2f}-{wall[-1]:.2f}] | {user:.2f} | "
          f"{statistics.median(rss):.0f} [{rss[0]:.0f}-{rss[-1]:.0f}] |")
for build in ("before", "default"):
    if build in median:
        print(f"| {name} | search cost ({build}) | +{100 * (median[build] / median['off'] - 1):.0f} % "
              f"(+{median[build] - median['off']:.2f} s) | | |")
PY
done
