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
    # The server on a free loopback port, a demo client streaming poses to it, then a clean
    # shutdown (SIGTERM drains the streams and exits 0).
    port_file="$(mktemp)"
    rm -f "$port_file"
    "$build/server/nearpointd" --listen 127.0.0.1:0 --port-file "$port_file" --log-level warn &
    server_pid=$!
    trap 'kill -TERM "$server_pid" 2>/dev/null || true; rm -f "$port_file"' EXIT
    for _ in $(seq 100); do [ -s "$port_file" ] && break; sleep 0.1; done
    [ -s "$port_file" ] || { echo "run.sh: nearpointd did not start" >&2; exit 1; }
    port="$(cat "$port_file")"
    echo "== nearpointd listening on 127.0.0.1:$port; streaming the demo scene"
    "$build/server/nearpoint_stream_demo" --target "127.0.0.1:$port" --updates 20
    kill -TERM "$server_pid"
    wait "$server_pid" && echo "== nearpointd drained and exited 0"
    trap - EXIT
    rm -f "$port_file"
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
