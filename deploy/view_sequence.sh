#!/usr/bin/env bash
# A palpation sequence as palpview shows it, without a display: approach, press over a rib,
# slide across the intercostal spaces (palp traj ribs: inferior -> superior over the lateral
# chest wall), one PNG per pose and one contact sheet of them all.
#   deploy/view_sequence.sh SCENE NAME OUT_DIR [WxH] [PRESET]
# SCENE: a prep directory, a CT or phantom:NAME. Writes OUT_DIR/NAME-1-approach.png ...,
# OUT_DIR/NAME-sheet.png and the force along the path (NAME-force.csv, palp run).
# Each pose is held by palpd's sim device (a one-row trajectory), so every picture shows the
# pose it names however slowly the software renderer draws.
set -euo pipefail
scene=$1 name=$2 out=$3 size=${4:-960x600} preset=${5:-bone}
build=${PALP_BUILD_DIR:-build}
bin=$build/server
width=${size%x*} height=${size#*x}
port=${PALP_SEQUENCE_PORT:-7431}
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# The path: 30 mm above the skin, press to 6 mm, slide across the ribs at 20 mm/s (50 rows/s).
"$bin/palp" traj ribs --scene "$scene" --out "$work/ribs.csv" --approach 30 --depth 6 \
  --press-time 1 --rate 50 -q
"$bin/palp" run --scene "$scene" --tool finger:37 --trajectory "$work/ribs.csv" \
  --out "$out/$name-force.csv" -q
# The poses: the approach (row 1), the press (end of the press, 1 s), the strongest force on the
# slide (over a rib), the weakest after it (an intercostal space) and the next strongest.
picks=$(awk -F, 'NR == 1 { next }
  { t[NR] = $1; f[NR] = sqrt($2 * $2 + $3 * $3 + $4 * $4); n = NR }
  END {
    press = 2; while (press < n && t[press] < 1.0) press++
    rib = press + 1; for (i = press + 1; i <= n - 2; i++) if (f[i] > f[rib]) rib = i
    gap = rib + 1; for (i = rib + 1; i <= n - 2 && i <= rib + 75; i++) if (f[i] < f[gap]) gap = i
    next_rib = gap + 1; for (i = gap + 1; i <= n - 2 && i <= gap + 75; i++) if (f[i] > f[next_rib]) next_rib = i
    printf "2 approach\n%d press\n%d rib\n%d intercostal\n%d next-rib\n", press, rib, gap, next_rib
  }' "$out/$name-force.csv")
shots=()
n=0
while read -r row label; do
  n=$((n + 1))
  { head -n 1 "$work/ribs.csv"; sed -n "${row}p" "$work/ribs.csv"; } >"$work/pose.csv"
  "$bin/palpd" --scene "$scene" --device "sim:$work/pose.csv" --port "$port" --no-realtime \
    --duration 600 >"$work/palpd.log" 2>&1 &
  server=$!
  for _ in $(seq 1 600); do
    grep -q "listening" "$work/palpd.log" 2>/dev/null && break
    sleep 0.1
  done
  png="$out/$name-$n-$label.png"
  xvfb-run -a -s "-screen 0 ${width}x${height}x24" "$build/client/palpview" \
    --connect "127.0.0.1:$port" --width "$width" --height "$height" --preset "$preset" \
    --volume-max-dim "${PALP_SEQUENCE_MAX_DIM:-256}" --screenshot "$png" --frames 2 \
    --timeout 300 | tail -n 1
  kill "$server" 2>/dev/null || true
  wait "$server" 2>/dev/null || true
  shots+=("$png")
  echo "$png: row $row of the path ($label)"
done <<<"$picks"
"$build/client/palpchart" --sheet "$out/$name-sheet.png" --columns 3 "${shots[@]}"
echo "contact sheet: $out/$name-sheet.png"
