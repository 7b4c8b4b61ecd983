# Sourced by the bench scripts: ensure_built BUILD BUILD_MISSING JOBS TARGET... builds the
# targets that are missing when BUILD_MISSING is 1 (configuring BUILD first if it is empty), and
# otherwise stops with the command that would build them.
ensure_built() {
  local build=$1 build_missing=$2 jobs=$3
  shift 3
  (($#)) || return 0
  if [[ $build_missing == 0 ]]; then
    echo "$0: not built in $build: $*; build them with" >&2
    echo "  cmake --build $build --target $*" >&2
    echo "or run this script with --build" >&2
    exit 2
  fi
  if [[ ! -f "$build/build.ninja" && ! -f "$build/Makefile" ]]; then
    cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  fi
  cmake --build "$build" --parallel "$jobs" --target "$@"
}
