#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The README's two commands, and a developer's others.
#   deploy/run.sh demo   installs what is missing, builds, and runs the main job
#   deploy/run.sh test   installs what is missing, builds, and runs every stage of CI (what .ci/run
#                        runs), each in its own build tree, each printing ctest's summary:
#                          main   the whole suite (ctest -LE soak) in build/, seeds and saved fuzz
#                                 findings replayed included (label fuzz-replay)
#                          fuzz   the libFuzzer targets (clang, build-fuzz/): every corpus input
#                                 once, then 20,000 inputs per target from seed 1 (reproducible;
#                                 NEARPOINT_FUZZ_RUNS / NEARPOINT_FUZZ_ARGS change it)
#                          asan   the suite under ASan+UBSan, in the same clang tree as the fuzz
#                                 stage (build-fuzz/: one instrumented build serves both), without
#                                 the soaks, the fuzz runs and the container image
#                          tsan   the server, client and DDS tests under TSan (build-tsan/)
#                        All stages run; the command fails if any failed, and says which.
#                        TEST_STAGES="main fuzz" (say) runs a subset.
#   deploy/run.sh fuzz [SECONDS]
#                        the fuzz stage alone, each target for SECONDS (default 60); the 10⁷-input
#                        run is in tests/fuzz/README.md (NEARPOINT_FUZZ_RUNS, and
#                        NEARPOINT_FUZZ_SANITIZE=undefined for build-fuzz-ub, UBSan without ASan).
#   deploy/run.sh sharded [smoke]
#                        three nearpointd behind HAProxy (consistent hashing on the scene id) on
#                        127.0.0.1 until Ctrl-C; `smoke` spreads 30 scenes and stops (sharded.sh)
#   deploy/run.sh sanitize [address|thread]
#                        the whole test suite (ctest -LE soak) under ASan+UBSan (default) or TSan,
#                        built with g++ in its own build tree (build-asan or build-tsan).
# Environment: BUILD_DIR (default build; the main tree only), JOBS (default: number of cores),
# CTEST_ARGS (extra, every stage), DEMO_PLOT (the demo's SVG, default demo.svg here), DEMO_ARGS
# (e.g. "--steps 100 --json"), NEARPOINT_FUZZ_SECONDS / NEARPOINT_FUZZ_RUNS /
# NEARPOINT_FUZZ_SANITIZE (tests/fuzz/README.md).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${BUILD_DIR:-build}"
jobs="${JOBS:-$(nproc)}"

# Chained with &&, here and in the stages: `test` runs them in an && list, where set -e is off.
configure_and_build() {
  deploy/install-deps.sh &&
    cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" &&
    cmake --build "$build" -j "$jobs" ${BUILD_TARGETS:+--target $BUILD_TARGETS}
}

# Cyclone DDS must never run without the loopback configuration: the ctest definitions set it for
# the DDS tests, and this covers anything else that starts it.
export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-loopback.xml"

# The sanitizers' options. Every report stops the process that made it (the test fails).
asan_env() {
  # Leaks are checked at exit.
  export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:detect_stack_use_after_return=1:check_initialization_order=1:strict_init_order=1:print_stacktrace=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
  export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
}
tsan_env() {
  # tsan.supp: races TSan reports inside Debian's uninstrumented gRPC/protobuf/Abseil/Cyclone
  # DDS, whose synchronisation it cannot see (the file says why, entry by entry).
  export TSAN_OPTIONS="halt_on_error=1:history_size=7:second_deadlock_stack=1:suppressions=$root/tests/sanitizers/tsan.supp${TSAN_OPTIONS:+:$TSAN_OPTIONS}"
}

# build-fuzz: clang, everything instrumented for coverage and ASan+UBSan, the tests included, so
# that the fuzz stage and the asan stage configure it alike and share its objects.
# With $1 = undefined: build-fuzz-ub, UBSan without ASan (the long runs: more inputs per second).
configure_and_build_fuzz_tree() {
  local sanitize="${1:-address,undefined}"
  build=build-fuzz
  if [ "$sanitize" = undefined ]; then build=build-fuzz-ub; fi
  configure_and_build -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang -DNEARPOINT_FUZZ=ON \
    -DNEARPOINT_FUZZ_SANITIZE="$sanitize" -DNEARPOINT_BUILD_TESTS=ON -DNEARPOINT_WITH_DDS=ON
}

# The fuzz stage: the libFuzzer targets of tests/fuzz in build-fuzz (clang; ASan+UBSan), every
# corpus input once and then each target for $NEARPOINT_FUZZ_SECONDS, one process per target.
fuzz_stage() {
  local seconds="${NEARPOINT_FUZZ_SECONDS:-60}"
  # The ctest timeout only catches a wedged run: libFuzzer stops itself after the time (or the
  # number of inputs, NEARPOINT_FUZZ_RUNS, which has no time bound: two days then).
  local timeout=$((seconds + 600))
  if [ -n "${NEARPOINT_FUZZ_RUNS:-}" ]; then timeout=172800; fi
  # Subshells, here and below: one stage's build directory and options stay out of the next.
  # The DDS bridge is not fuzzed (the asan stage runs its tests).
  # NEARPOINT_FUZZ_SANITIZE=undefined: the same targets without ASan, in build-fuzz-ub.
  ( asan_env
    BUILD_TARGETS="fuzz_engine fuzz_jsonl fuzz_scene_file fuzz_requests fuzz_robots fuzz_dds_report_view fuzz_pose_update_wire" \
      configure_and_build_fuzz_tree "${NEARPOINT_FUZZ_SANITIZE:-}" &&
    NEARPOINT_FUZZ_SECONDS="$seconds" ctest --test-dir "$build" --output-on-failure -j "$jobs" \
      -L fuzz --timeout "$timeout" ${CTEST_ARGS:-} )
}

# The sanitizer stages. ASan+UBSan: the suite as in the main stage, in build-fuzz (the fuzz runs
# and the container image, which holds its own Release build, are the other stages' and left
# out). TSan: the tests of the threaded parts (server, client, DDS), with only their targets built.
asan_stage() {
  ( asan_env
    configure_and_build_fuzz_tree &&
    ctest --test-dir build-fuzz --output-on-failure -j "$jobs" -LE "^(soak|fuzz|container)$" \
      ${CTEST_ARGS:-} )
}
tsan_stage() {
  ( tsan_env
    build=build-tsan
    BUILD_TARGETS="test_server_scene_service test_server_broad_phase test_server_grpc
                   test_server_health_reflection test_server_report_wire test_server_pose_update_wire
                   test_server_boundary test_server_process test_server_sharded test_server_depth
                   test_client test_robot_wire
                   test_dds_bridge test_dds_report_sertype test_ros_wire test_ros_peer ros_peer
                   test_joint_states test_dds_end_to_end nearpointd nearpoint nearpoint_python nearpoint_stream_demo" \
      configure_and_build -DNEARPOINT_SANITIZE=thread &&
    ctest --test-dir build-tsan --output-on-failure -j "$jobs" -L "^(server|client|dds)$" \
      ${CTEST_ARGS:-} )
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
    # Each stage runs whatever the one before it did; the command fails if any failed.
    failed=()
    for stage in ${TEST_STAGES:-main fuzz asan tsan}; do
      start=$SECONDS
      echo "== deploy/run.sh test: stage $stage"
      case "$stage" in
        # Long soaks carry the label 'soak' and run only when asked (CTEST_ARGS="-L soak").
        main) (configure_and_build &&
                 ctest --test-dir "$build" --output-on-failure -j "$jobs" -LE soak ${CTEST_ARGS:-}) ;;
        # CI's fuzzing is reproducible: a fixed seed and a fixed number of inputs per target
        # (seconds each; the same inputs on every run and machine), so that a red stage is a
        # change's doing, not a lucky draw. `deploy/run.sh fuzz` is the open-ended search.
        fuzz) NEARPOINT_FUZZ_RUNS="${NEARPOINT_FUZZ_RUNS:-20000}" \
                NEARPOINT_FUZZ_ARGS="${NEARPOINT_FUZZ_ARGS:--seed=1}" fuzz_stage ;;
        asan) asan_stage ;;
        tsan) tsan_stage ;;
        *) echo "deploy/run.sh test: unknown stage '$stage' (main fuzz asan tsan)" >&2; false ;;
      esac && status=passed || { status=FAILED; failed+=("$stage"); }
      echo "== deploy/run.sh test: stage $stage $status in $((SECONDS - start)) s"
    done
    if [ ${#failed[@]} -gt 0 ]; then
      echo "== deploy/run.sh test: FAILED stages: ${failed[*]}" >&2
      exit 1
    fi
    echo "== deploy/run.sh test: every stage passed"
    ;;
  sharded)
    # Three nearpointd behind HAProxy on 127.0.0.1 (deploy/sharded.sh; `sharded smoke` creates
    # 30 scenes through the proxy, shows each replica's share and stops).
    BUILD_TARGETS="nearpointd nearpoint" configure_and_build
    BUILD_DIR="$build" exec deploy/sharded.sh "${@:2}"
    ;;
  fuzz)
    NEARPOINT_FUZZ_SECONDS="${2:-${NEARPOINT_FUZZ_SECONDS:-60}}" fuzz_stage
    ;;
  sanitize)
    kind="${2:-address}"
    case "$kind" in
      address)
        build="${BUILD_DIR:-build-asan}"
        sanitizers=address,undefined
        asan_env
        ;;
      thread)
        build="${BUILD_DIR:-build-tsan}"
        sanitizers=thread
        tsan_env
        ;;
      *)
        echo "usage: deploy/run.sh sanitize [address|thread]" >&2
        exit 2
        ;;
    esac
    configure_and_build -DNEARPOINT_SANITIZE="$sanitizers"
    ctest --test-dir "$build" --output-on-failure -j "$jobs" -LE soak ${CTEST_ARGS:-}
    ;;
  *)
    echo "usage: deploy/run.sh demo|test|sharded [smoke]|fuzz [SECONDS]|sanitize [address|thread]" >&2
    exit 2
    ;;
esac
