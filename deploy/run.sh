#!/usr/bin/env bash
# The README's two commands, and a developer's third.
#   deploy/run.sh demo   installs what is missing, builds, and runs the main job
#   deploy/run.sh test   installs what is missing, builds, and runs the whole test suite
#   deploy/run.sh sanitize [address|thread]
#                        the whole test suite (ctest -LE soak) under ASan+UBSan (default) or TSan,
#                        in its own build tree (build-asan or build-tsan, or $BUILD_DIR). Slow (a
#                        first build takes 10-20 minutes on 2 cores): not part of CI.
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
  sanitize)
    kind="${2:-address}"
    supp="$root/tests/sanitizers"
    case "$kind" in
      address)
        build="${BUILD_DIR:-build-asan}"
        sanitizers=address,undefined
        # Every report stops the process that made it (the test fails); leaks are checked at exit.
        export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:detect_stack_use_after_return=1:check_initialization_order=1:strict_init_order=1:print_stacktrace=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
        export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
        ;;
      thread)
        build="${BUILD_DIR:-build-tsan}"
        sanitizers=thread
        # tsan.supp: races TSan reports inside Debian's uninstrumented gRPC/protobuf/Abseil/Cyclone
        # DDS, whose synchronisation it cannot see (the file says why, entry by entry).
        export TSAN_OPTIONS="halt_on_error=1:history_size=7:second_deadlock_stack=1:suppressions=$supp/tsan.supp${TSAN_OPTIONS:+:$TSAN_OPTIONS}"
        ;;
      *)
        echo "usage: deploy/run.sh sanitize [address|thread]" >&2
        exit 2
        ;;
    esac
    configure_and_build -DNEARPOINT_SANITIZE="$sanitizers"
    # The ctest definitions set CYCLONEDDS_URI for the DDS tests; this covers anything else that
    # starts Cyclone DDS, which must never run without the loopback configuration.
    export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-loopback.xml"
    ctest --test-dir "$build" --output-on-failure -j "$jobs" -LE soak ${CTEST_ARGS:-}
    ;;
  *)
    echo "usage: deploy/run.sh demo|test|sanitize [address|thread]" >&2
    exit 2
    ;;
esac
