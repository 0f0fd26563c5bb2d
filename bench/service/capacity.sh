#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Per-replica capacity for the sharded deployment (docs/operations.md, "Sharded replicas"): how
# many pose updates per second one core of nearpointd answers for a reference scene, measured as
#   updates answered / CPU seconds nearpointd used
# while `nearpoint load` keeps it busy from another process. nearpointd runs with --workers 1 as
# a child on 127.0.0.1; its CPU time is read from /proc before and after, so the client's CPU
# (same machine) is not counted, nor the other users of a shared machine. Reference scenes:
#   demo   `nearpoint load`'s default: the paper's Fig. 5 (a two-piece mover, five obstacles,
#          5 pairs) along its path, one object moving
#   cell45 the shape of nearpoint_service_bench's scene: 10 random convex polytopes of 20-100
#          vertices (about 550 in all), all 45 pairs, every object moving every update along a
#          smooth path (period 1000 updates), no cutoff
#   bench/service/capacity.sh [demo|cell45] [STREAMS] [SECONDS]     (defaults cell45, 4, 5)
# Environment: BUILD_DIR (default build), BATCH (pose sets per message, default 1: StreamPoses;
# more: StreamPoseBatches), WINDOW (updates in flight per stream, default 4, with BATCH > 1 two
# batches).
# Also prints the geometry share: the reports' geometry_us (time in the engine) over nearpointd's
# CPU time per update.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${BUILD_DIR:-$root/build}"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
reference="${1:-cell45}"
streams="${2:-4}"
seconds="${3:-5}"
work="$(mktemp -d /tmp/nearpoint-capacity.XXXXXX)"
scene_args=()
case "$reference" in
  demo) ;;
  cell45)
    python3 "$root/bench/service/cell45.py" "$work"
    scene_args=("$work/cell45.json" "$work/cell45.jsonl") ;;
  *) echo "usage: capacity.sh [demo|cell45] [STREAMS] [SECONDS]" >&2; exit 2 ;;
esac
"$build/server/nearpointd" --listen 127.0.0.1:0 --port-file "$work/port" --workers 1 \
  2>"$work/nearpointd.log" &
server=$!
trap 'kill $server 2>/dev/null || true; wait $server 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 200); do [ -s "$work/port" ] && break; sleep 0.05; done
target="127.0.0.1:$(cat "$work/port")"
ticks() { awk '{print $14 + $15}' "/proc/$server/stat"; }  # utime + stime, clock ticks
hz="$(getconf CLK_TCK)"
source "$root/bench/service/load_flags.sh"  # BATCH, WINDOW
before="$(ticks)"
"$build/client/nearpoint" load --target "$target" --streams "$streams" --duration "$seconds" \
  "${load_flags[@]}" --json "${scene_args[@]}" 2>"$work/load.log" \
  >"$work/load.json" ||
  { cat "$work/load.log" >&2; exit 1; }
after="$(ticks)"
python3 - "$work/load.json" "$before" "$after" "$hz" "$seconds" "$streams" "$reference" <<'PY'
import json, sys
result = json.load(open(sys.argv[1]))
before, after, hz, seconds, streams = (float(v) for v in sys.argv[2:7])
cpu = (after - before) / hz
reports, errors = result["reports"], result["errors"]
latency = result["latency_us"]
print(f"{sys.argv[7]}: {streams:.0f} streams x {result['window']} in flight, batch "
      f"{result.get('batch', 1)}, for {seconds:.0f} s: {reports} reports "
      f"({errors} errors), {reports / result['duration_s']:.0f} updates/s, nearpointd CPU "
      f"{cpu:.2f} s ({100 * cpu / result['duration_s']:.0f}% of one core)")
cpu_us_per_update = 1e6 * cpu / max(reports, 1)
geometry_us = result.get("geometry_us_per_report")  # absent from builds before batching
print(f"capacity: {reports / cpu:.0f} updates per CPU-second of nearpointd (--workers 1); "
      f"latency p50 {latency['p50']:.0f} us, p99 {latency['p99']:.0f} us")
if geometry_us is not None:
    print(f"geometry share: {geometry_us:.1f} us of geometry per update over "
          f"{cpu_us_per_update:.1f} us of CPU = {100 * geometry_us / cpu_us_per_update:.0f}%")
PY
