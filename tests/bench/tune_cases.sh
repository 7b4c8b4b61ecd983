#!/usr/bin/env bash
# Runs `palp tune` for the cases of docs/tuning.md: finger:1, finger:37, twofinger:19 and
# probe:9x3 on the torso phantom and the real CT (../shared/data, when present) at 1, 4 and
# 10 kHz, and prints one markdown table of the choices (also written as SUMMARY.md beside them).
#
#   tests/bench/tune_cases.sh [--docs] [--build]
#
# Writes the configurations, CSVs and charts into $PALP_TUNE_DIR (default ${TMPDIR:-/tmp}/
# palp-tune); --docs writes them into docs/figures/tuning, where docs/tuning.md shows them.
# Never builds unless --build. Measures; gates nothing. Takes ~5-8 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${PALP_BUILD_DIR:-build}
out=${PALP_TUNE_DIR:-${TMPDIR:-/tmp}/palp-tune}
for arg in "$@"; do
  case $arg in
    --docs) out=docs/figures/tuning ;;
    --build) cmake --build "$build" --target palp palpchart -j"${PALP_JOBS:-1}" ;;
    -h | --help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "usage: $0 [--docs] [--build]" >&2; exit 2 ;;
  esac
done
palp=$build/server/palp
[[ -x $palp ]] || { echo "no $palp: cmake --build $build --target palp palpchart (or --build)" >&2; exit 1; }
ct=${PALP_CT:-../shared/data/ct_abdomen_3mm.nii.gz}
mkdir -p "$out"
scenes=(torso)
[[ -f $ct ]] && scenes+=(ct)
for scene in "${scenes[@]}"; do
  input=phantom:torso
  [[ $scene == ct ]] && input=$ct
  for tool in finger:1 finger:37 twofinger:19 probe:9x3; do
    for rate in 1000 4000 10000; do
      name="${scene}_${tool/:/-}_${rate}"
      echo "== $name (load $(cut -d' ' -f1-3 /proc/loadavg))" >&2
      "$palp" tune --scene "$input" --tool "$tool" --rate "$rate" --out "$out/$name.toml" -q || true
    done
  done
done
python3 - "$out" <<'PY' | tee "$out/SUMMARY.md"
import csv, glob, os, sys
out = sys.argv[1]
print("| scene | tool | rate | chosen | tick p50 chosen / reference (us) | speed-up | maps MiB chosen / reference | ticks beyond tolerance (%) / worst (tolerances) | RMS / largest error (N) | cheaper candidates rejected |")
print("|---|---|---|---|---|---|---|---|---|---|")
def key(p):
    s, t, r = os.path.basename(p)[:-4].split("_")
    return (s != "torso", t, int(r))
# Only the cases' CSVs (SCENE_TOOL_RATE.csv): docs/figures/tuning holds other charts' data too.
cases = [p for p in glob.glob(os.path.join(out, "*.csv")) if len(os.path.basename(p)[:-4].split("_")) == 3]
for path in sorted(cases, key=key):
    scene, tool, rate = os.path.basename(path)[:-4].split("_")
    rows = list(csv.DictReader(open(path)))
    ref, chosen = rows[0], next(r for r in rows if r["chosen"] == "1")
    p_ref, p_ch = float(ref["tick_p50_us"]), float(chosen["tick_p50_us"])
    ok = "" if chosen["verdict"] != "reference" or chosen["reason"] == "accepted" else " (nothing passes)"
    cheaper = [r for r in rows if r["verdict"].startswith("rejected") and float(r["tick_p50_us"]) < p_ch]
    why = {}
    for r in cheaper:
        k = "too slow" if "too slow" in r["reason"] else ("step" if "step" in r["reason"] else "force error")
        why[k] = why.get(k, 0) + 1
    why_text = ", ".join(f"{n} {k}" for k, n in sorted(why.items())) or "none"
    print(f"| {scene} | {tool.replace('-', ':')} | {int(rate)//1000} kHz | {chosen['candidate']}{ok} | "
          f"{p_ch:.2f} / {p_ref:.2f} | {p_ref / p_ch:.1f}x | {float(chosen['map_mib']):.0f} / {float(ref['map_mib']):.0f} | "
          f"{100 * float(chosen['beyond_share']):.2f} / {float(chosen['worst_ratio']):.2f} | "
          f"{float(chosen['rms_error_n']):.3f} / {float(chosen['max_error_n']):.3f} | {why_text} |")
PY
