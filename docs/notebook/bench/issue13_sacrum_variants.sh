#!/bin/bash
# The sacrum variants of docs/notebook/prep.md ("The sacrum's marrow: variants measured, none adopted").
# Historical scratch code, not the method (kept beside the notebook entry it measured): run from the root of a scratch checkout of commit 51aaf12 (the
# patch's paths are common/prep's before its files moved into bone/, segment/ and maps/) with
# docs/notebook/bench/issue13_sacrum_variants.patch applied and built
# (at commit 51aaf12 this patch and script lay in docs/bench/; from a later checkout, copy them into
# the scratch checkout's docs/notebook/bench/ first)
#   git apply docs/notebook/bench/issue13_sacrum_variants.patch
#   cmake --build build --target bone_segmentation_test bone_mask_timing
#   docs/notebook/bench/issue13_sacrum_variants.sh
# The patch reads each variant's settings from environment variables (PALP_PLATE: plate radius
# mm; PALP_PLATE_N: lines the plate rule needs; PALP_AXIS_R: the axis line's own radius mm;
# PALP_TUBE: also both sagittal diagonals; PALP_CANAL: not where only the axial plane voted;
# PALP_PIECE: a plate-only piece stays when this share of its faces lies on bone; PALP_ITER: extra
# enclosure passes; PALP_SHELL_LINES / PALP_SHELL_ML: cavities of the bone plus the voxels
# bracketed along that many lines, up to that many ml) and prints Dice to four digits.
# One row per variant: the shared CT's figures (bone_segmentation_test) and the torso phantom's
# bone Dice at 384x384x160 (0.8x0.8x1.5 mm) and at the default grid 384x256x96 (1.25x1.25x2 mm).
set -u  # a variant may fail the test's bounds: its row is printed all the same
row() {
  local name=$1 envs=$2 ct d a t1 t2
  ct=$(env $envs build/tests/bone_segmentation_test --gtest_filter='*Against*' 2>&1)
  d=$(echo "$ct" | sed -n 's/.*Dice \([0-9.]*\), precision \([0-9.]*\), recall \([0-9.]*\), mean symmetric surface distance \([0-9.]*\) mm, superficial anterolateral (rib region) recall \([0-9.]*\).*/\1 | \2 \/ \3 | \4 | \5/p')
  a=$(echo "$ct" | sed -n 's/farther than 50 mm from metal: Dice \([0-9.]*\), ASSD \([0-9.]*\) mm/\1 \/ \2/p')
  t1=$(env $envs build/tests/bench/bone_mask_timing 1 384 384 160 0.8 0.8 1.5 2>&1 |
       sed -n 's/bone mask with enclosure:.*bone Dice \([0-9.]*\)/\1/p')
  t2=$(env $envs build/tests/bench/bone_mask_timing 1 384 256 96 1.25 1.25 2 2>&1 |
       sed -n 's/bone mask with enclosure:.*bone Dice \([0-9.]*\)/\1/p')
  echo "| $name | \`$envs\` | $d | $a | $t1 / $t2 |"
}
row "default (plates 20 mm)" "PALP_X=0"
for r in 25 30 35 40; do row "plates $r mm" "PALP_PLATE=$r"; done
for n in 11 12 13; do row "plates 30 mm, $n of 13 lines" "PALP_PLATE=30 PALP_PLATE_N=$n"; done
row "plates 35 mm, 11 of 13 lines" "PALP_PLATE=35 PALP_PLATE_N=11"
for n in 11 12 13; do row "plates 40 mm, $n of 13 lines" "PALP_PLATE=40 PALP_PLATE_N=$n"; done
for r in 20 15; do row "plates 30 mm, the axis line within $r mm" "PALP_PLATE=30 PALP_AXIS_R=$r"; done
row "plates 30 mm, both sagittal diagonals too" "PALP_PLATE=30 PALP_TUBE=1"
row "plates 30 mm, not where only the axial plane voted" "PALP_PLATE=30 PALP_CANAL=1"
for f in 0.4 0.45 0.5; do row "plates 30 mm, pieces >= $f on bone" "PALP_PLATE=30 PALP_PIECE=$f"; done
for r in 25 35; do row "plates $r mm, pieces >= 0.45 on bone" "PALP_PLATE=$r PALP_PIECE=0.45"; done
row "plates 30 mm, 11 of 13, pieces >= 0.5 on bone" "PALP_PLATE=30 PALP_PLATE_N=11 PALP_PIECE=0.5"
row "plates 35 mm, 11 of 13, pieces >= 0.5 on bone" "PALP_PLATE=35 PALP_PLATE_N=11 PALP_PIECE=0.5"
row "plates 40 mm, 12 of 13, pieces >= 0.5 on bone" "PALP_PLATE=40 PALP_PLATE_N=12 PALP_PIECE=0.5"
for f in 0.5 0.6; do row "plates 20 mm, pieces >= $f on bone" "PALP_PIECE=$f"; done
row "enclosure run twice" "PALP_ITER=1"
row "enclosure run twice, no plate rule" "PALP_ITER=1 PALP_PLATE=0"
for m in 5 7 9; do row "shell cavities, >= $m lines, <= 300 ml" "PALP_SHELL_LINES=$m PALP_SHELL_ML=300"; done
