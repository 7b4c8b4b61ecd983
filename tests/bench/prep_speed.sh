#!/bin/bash
# Whole `palp prep` speed and peak memory on the two benchmark phantoms (issue 13 "Speed"):
#   A  384x384x160 at 0.8x0.8x1.5 mm: target >= 10x faster than scipy's two signed EDTs (the
#      scipy figure is read from docs/bench/prep_vs_scipy.json, or given with --scipy-s)
#   B  512x512x400 at 0.8x0.8x1.0 mm: target <= 3 s and <= 1.5 GB peak RSS
# Each run is `/usr/bin/time -v palp prep FILE --out DIR --no-cache [--surface S]`; the load
# average (uptime) is recorded before every run, because timings on a shared machine are noisy,
# with the CPU seconds (user + sys: less sensitive to other processes than the wall clock), the
# stages (read CT, bone mask, the maps, the time the main thread waited for writes and for d_surf's
# thread) and the outputs' size.
# With --before OTHER_PALP the runs alternate between that build and --palp, for a comparison
# under the same load. Prints one Markdown row per run and a median per case and build; never
# fails on a time (exit 0 unless a run fails).
#
# Usage: tests/bench/prep_speed.sh [--palp build/server/palp] [--runs 3] [--surface subvoxel|mask]
#                                  [--cases AB] [--work DIR] [--scipy-s SECONDS] [--before PALP]
set -euo pipefail

palp=build/server/palp
runs=3
surface=subvoxel
cases=AB
work=${TMPDIR:-/tmp}/palp_prep_speed
scipy_s=""
before=""
while [ $# -gt 0 ]; do
  case "$1" in
    --palp) palp=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --surface) surface=$2; shift 2 ;;
    --cases) cases=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --scipy-s) scipy_s=$2; shift 2 ;;
    --before) before=$2; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "prep_speed.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
[ -x "$palp" ] || { echo "prep_speed.sh: $palp is not an executable (build first)" >&2; exit 2; }
[ -z "$before" ] || [ -x "$before" ] || { echo "prep_speed.sh: $before is not an executable" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "prep_speed.sh: needs /usr/bin/time (Debian package: time)" >&2; exit 2; }
here=$(cd "$(dirname "$0")/../.." && pwd)
if [ -z "$scipy_s" ] && [ -f "$here/docs/bench/prep_vs_scipy.json" ]; then
  scipy_s=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['case_a']['scipy_two_maps_median_s'])" \
    "$here/docs/bench/prep_vs_scipy.json")
fi
mkdir -p "$work"

# the kernel's transparent huge pages decide much of prep's time (docs/benchmarks.md)
thp=$(sed -n 's/.*\[\(.*\)\].*/\1/p' /sys/kernel/mm/transparent_hugepage/enabled 2>/dev/null || true)
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(uname -sr), transparent huge pages: ${thp:-unknown}"
echo "palp: $palp${before:+ (alternating with --before $before)}, surface: $surface, runs per case: $runs, scipy two maps (case A): ${scipy_s:-unknown} s"
echo
echo "| case | build | run | load (1 min) before | wall s | CPU s | peak RSS MiB | read CT s | bone mask s | d_surf + d_bone s | waited s (writes, d_surf thread) | outputs MB | vs scipy |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"

# One run of build $1 ("after" or "before", binary $2) on case $3 (file $4); appends the wall
# time to the array named walls_<build>.
run_once() {
  local build=$1 bin=$2 name=$3 ct=$4 dims=$5 r=$6
  local out="$work/out_${name}_${build}_$r"
  rm -rf "$out"
  local load
  load=$(cut -d' ' -f1 /proc/loadavg)
  if ! /usr/bin/time -v -o "$work/time.txt" "$bin" prep "$ct" --out "$out" --no-cache \
    --surface "$surface" >"$work/prep.log" 2>&1; then
    cat "$work/prep.log" >&2
    exit 1
  fi
  local wall rss cpu
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n=split($2,t,":"); s=0; for(i=1;i<=n;i++) s=s*60+t[i]; print s}' "$work/time.txt")
  rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2/1024}' "$work/time.txt")
  cpu=$(awk -F': ' '/User time|System time/ {s+=$2} END {printf "%.2f", s}' "$work/time.txt")
  local stages
  stages=$(python3 -c "
import json,sys
j=json.load(open(sys.argv[1])); t=j['timings_s']
writes=sum(v for k,v in t.items() if k.startswith('write ') or k.startswith('wait '))
print('%.3f | %.3f | %.3f | %.3f | %.1f' % (t.get('read CT',0), t.get('bone mask',0),
      t.get('d_surf',0)+t.get('d_bone',0), writes, sum(j['file_bytes'].values())/1e6))" "$out/prep.json")
  local ratio="—"
  if [ "$name" = A ] && [ -n "$scipy_s" ]; then
    ratio=$(python3 -c "print('%.1fx' % ($scipy_s / $wall))")
  fi
  echo "| $name $dims | $build | $r | $load | $wall | $cpu | $rss | $stages | $ratio |"
  eval "walls_$build+=(\"$wall\")"
  rm -rf "$out"
}

median_of() {
  printf '%s\n' "$@" | sort -n | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'
}

run_case() {
  local name=$1 dims=$2 spacing=$3
  local ct="$work/torso_${dims}.nii.gz"
  # Written by the build under test (a file older than it is written again): palp's own gzip
  # members carry their length and are read on all cores, a foreign file's are not.
  [ -f "$ct" ] && [ "$ct" -nt "$palp" ] ||
    "$palp" phantom torso --dims "$dims" --spacing "$spacing" --out "$ct" >/dev/null
  walls_after=()
  walls_before=()
  for r in $(seq 1 "$runs"); do
    [ -z "$before" ] || run_once before "$before" "$name" "$ct" "$dims" "$r"
    run_once after "$palp" "$name" "$ct" "$dims" "$r"
  done
  local build
  for build in before after; do
    eval "local n=\${#walls_$build[@]}"
    [ "$n" -gt 0 ] || continue
    local median
    eval "median=\$(median_of \"\${walls_$build[@]}\")"
    local ratio="—"
    if [ "$name" = A ] && [ -n "$scipy_s" ]; then ratio=$(python3 -c "print('%.1fx' % ($scipy_s / $median))"); fi
    echo "| $name median | $build | | | $median | | | | | | | | $ratio |"
  done
}

case "$cases" in *A*) run_case A 384x384x160 0.8x0.8x1.5 ;; esac
case "$cases" in *B*) run_case B 512x512x400 0.8x0.8x1.0 ;; esac
echo
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
