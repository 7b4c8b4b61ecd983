#!/usr/bin/env bash
# Runs a libFuzzer binary for a fixed time over a copy of its seed corpus (the corpus in the tree
# is never written), with per-input time and memory limits. Exit status: the fuzzer's (non-zero
# on a crash, a sanitizer report, a timeout or an out-of-memory input).
#   run_fuzz.sh FUZZER CORPUS_DIR SECONDS
set -euo pipefail
fuzzer=$1 corpus=$2 seconds=$3
work=$(mktemp -d "${TMPDIR:-/tmp}/palp-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT
cp -r "$corpus"/. "$work/"
cd "$work"
"$fuzzer" -max_total_time="$seconds" -timeout=5 -rss_limit_mb=2048 -print_final_stats=1 \
  -artifact_prefix="$work/" "$work"
