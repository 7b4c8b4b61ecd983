#!/usr/bin/env bash
# Runs a command on a private Xvfb display: with_xvfb.sh COMMAND [ARGS...]
# Xvfb picks a free display number itself (-displayfd) and reports it, so parallel test runs
# never race for the same number (xvfb-run -a can: two runs may pick the same :N). -noreset:
# by default Xvfb resets itself whenever its last client disconnects, and a connection attempted
# during that reset is dropped ("Connection reset by peer"); on a loaded machine that made about
# one XOpenDisplay in three fail (VTK then aborts with "bad X server connection"). The server is
# stopped when the command ends; the command's exit status is returned.
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: with_xvfb.sh COMMAND [ARGS...]" >&2; exit 2; }
command -v Xvfb >/dev/null || { echo "with_xvfb.sh: Xvfb not found (apt-get install xvfb)" >&2; exit 1; }
fifo_dir=$(mktemp -d)
trap 'rm -rf "$fifo_dir"' EXIT
mkfifo "$fifo_dir/displayfd"
Xvfb -displayfd 3 -screen 0 1920x1080x24 -nolisten tcp -noreset 3>"$fifo_dir/displayfd" \
  >"$fifo_dir/xvfb.log" 2>&1 &
xvfb=$!
trap 'kill "$xvfb" 2>/dev/null || true; wait "$xvfb" 2>/dev/null || true; rm -rf "$fifo_dir"' EXIT
display=""
read -r -t 30 display <"$fifo_dir/displayfd" || true
if [[ -z "$display" ]]; then
  echo "with_xvfb.sh: Xvfb did not start:" >&2
  cat "$fifo_dir/xvfb.log" >&2
  exit 1
fi
export DISPLAY=":$display"
status=0
"$@" || status=$?
exit "$status"
