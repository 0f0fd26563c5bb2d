#!/usr/bin/env bash
# The README's two commands.
#   deploy/run.sh demo   installs what is missing, builds, and runs the main job
#   deploy/run.sh test   installs what is missing, builds, and runs the whole test suite
# Environment: BUILD_DIR (default build), JOBS (default: number of cores), CTEST_ARGS (extra),
# DEMO_PLOT (the demo's SVG, default demo.svg here), DEMO_ARGS (e.g. "--steps 100 --json").
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
    # The main job: `nearpoint demo` starts nearpointd on a free port of 127.0.0.1, streams the
    # paper's Section VIII path through it (T = 1000) and prints the distance profiles, the
    # collision intervals and the Table I ratio; the plot goes to demo.svg (or $DEMO_PLOT).
    "$build/client/nearpoint" demo --nearpointd "$build/server/nearpointd" \
      --plot "${DEMO_PLOT:-$root/demo.svg}" ${DEMO_ARGS:-}
    echo
    echo "== nearpoint distance examples/pairs.jsonl (the engine locally, JSON Lines)"
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
