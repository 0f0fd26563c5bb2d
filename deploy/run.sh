#!/usr/bin/env bash
# The README's two commands.
#   deploy/run.sh demo   installs what is missing, builds, and runs the main job
#   deploy/run.sh test   installs what is missing, builds, and runs the whole test suite
# Environment: BUILD_DIR (default build), JOBS (default: number of cores), CTEST_ARGS (extra).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${BUILD_DIR:-build}"
jobs="${JOBS:-$(nproc)}"

configure_and_build() {
  deploy/install-deps.sh
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@"
  cmake --build "$build" -j "$jobs"
}

case "${1:-}" in
  demo)
    configure_and_build
    echo "== nearpoint distance examples/pairs.jsonl"
    "$build/client/nearpoint" distance examples/pairs.jsonl
    ;;
  test)
    configure_and_build
    # Long soaks carry the label 'soak' and run only when asked (CTEST_ARGS="-L soak").
    ctest --test-dir "$build" --output-on-failure -j "$jobs" -LE soak ${CTEST_ARGS:-}
    ;;
  *)
    echo "usage: deploy/run.sh demo|test" >&2
    exit 2
    ;;
esac
