#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Per-replica capacity for the sharded deployment (docs/operations.md, "Sharded replicas"): how
# many pose updates per second one core of nearpointd answers for a reference scene, measured as
#   updates answered / CPU seconds nearpointd used
# while a client keeps it busy from another process: `nearpoint load` over gRPC, or with
# TRANSPORT=dds `nearpoint dds load` over Cyclone DDS (nearpointd --dds; each stream a DDS
# participant publishing PoseUpdates and reading the reports). nearpointd runs with --workers 1
# as a child on 127.0.0.1; its CPU time is read from /proc before and after, so the client's CPU
# (same machine) is not counted, nor the other users of a shared machine. Reference scenes:
#   demo   `nearpoint load`'s default: the paper's Fig. 5 (a two-piece mover, five obstacles,
#          5 pairs) along its path, one object moving
#   cell45 the shape of nearpoint_service_bench's scene: 10 random convex polytopes of 20-100
#          vertices (about 550 in all), all 45 pairs, every object moving every update along a
#          smooth path (period 1000 updates), no cutoff
#   bench/service/capacity.sh [demo|cell45] [STREAMS] [SECONDS]     (defaults cell45, 4, 5)
# BATCH (pose sets per message, default 1: StreamPoses; more: StreamPoseBatches, or over DDS
# PoseUpdateBatch samples on pose_update_batches), WINDOW (updates in flight per stream,
# default 4, with BATCH > 1 two batches). DDS cannot hold a publisher back, so with BATCH > 1
# nearpointd runs with --max-in-flight WINDOW (at least its default 8): a window beyond it would
# make the server merge updates instead of answering each.
# Also prints the geometry share: the reports' geometry_us (time in the engine) over nearpointd's
# CPU time per update. Over DDS the report topic is keyless, so nearpointd sends every report to
# every stream's reader: STREAMS 1 with a WINDOW measures one update's cost without that fan-out.
# Environment: BUILD_DIR (default build), NEARPOINTD (the server binary; default
# BUILD_DIR/server/nearpointd, e.g. an older build's to compare), SERVER_ARGS (more nearpointd
# flags, e.g. --no-inline-evaluation), WINDOW (updates in flight per stream, default 4),
# TRANSPORT (grpc or dds, default grpc), DDS_DOMAIN (default a random one in 100-199),
# CYCLONEDDS_URI (default the repository's loopback configuration), PERF_DATA (a file: `perf
# record -g` of nearpointd while the load runs, for profile.sh).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${BUILD_DIR:-$root/build}"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
server_binary="${NEARPOINTD:-$build/server/nearpointd}"
transport="${TRANSPORT:-grpc}"
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
server_args=(--listen 127.0.0.1:0 --port-file "$work/port" --workers 1)
source "$root/bench/service/load_flags.sh"  # BATCH, WINDOW: load_flags, batch, window
case "$transport" in
  grpc) ;;
  dds)
    # Loopback only, never Cyclone's default (the external interface, multicast).
    export CYCLONEDDS_URI="${CYCLONEDDS_URI:-file://$root/deploy/cyclonedds-loopback.xml}"
    domain="${DDS_DOMAIN:-$((100 + RANDOM % 100))}"
    server_args+=(--dds --dds-domain "$domain")
    # cell45 is preloaded (its id is "cell45"); the demo scene is created over gRPC below.
    [ "$reference" = cell45 ] && server_args+=(--scene "$work/cell45.json")
    [ "$batch" -gt 1 ] && server_args+=(--max-in-flight "$((window > 8 ? window : 8))")
    ;;
  *) echo "capacity.sh: TRANSPORT is grpc or dds" >&2; exit 2 ;;
esac
# shellcheck disable=SC2086 # SERVER_ARGS is a list of flags
"$server_binary" "${server_args[@]}" ${SERVER_ARGS:-} 2>"$work/nearpointd.log" &
server=$!
trap 'kill $server 2>/dev/null || true; wait $server 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 200); do [ -s "$work/port" ] && break; sleep 0.05; done
target="127.0.0.1:$(cat "$work/port")"
load=("$build/client/nearpoint" load --target "$target" --streams "$streams" --duration "$seconds"
      "${load_flags[@]}" --json "${scene_args[@]}")
if [ "$transport" = dds ]; then
  if [ "$reference" = demo ]; then
    # The demo scene, kept on the server by a short gRPC load; `dds load` replays its path.
    "$build/client/nearpoint" load --target "$target" --streams 1 --duration 0.05 --keep-scene \
      --json 2>"$work/setup.log" >"$work/setup.json" || { cat "$work/setup.log" >&2; exit 1; }
    scene_id="$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["scene_id"])' \
      "$work/setup.json")"
    load=("$build/client/nearpoint" dds load "$scene_id")
  else
    load=("$build/client/nearpoint" dds load cell45 "$work/cell45.jsonl")
  fi
  load+=(--dds-domain "$domain" --streams "$streams" --duration "$seconds"
         "${load_flags[@]}" --json)
fi
ticks() { awk '{print $14 + $15}' "/proc/$server/stat"; }  # utime + stime, clock ticks
hz="$(getconf CLK_TCK)"
if [ -n "${PERF_DATA:-}" ]; then
  perf record -q -F 2000 ${PERF_CALL_GRAPH:--g} -p "$server" -o "$PERF_DATA" 2>"$work/perf.log" &
  recorder=$!
fi
before="$(ticks)"
# The load client's own CPU (user and system seconds, bash's `time`): what loading costs.
TIMEFORMAT='%U %S'
{ time "${load[@]}" 2>"$work/load.log" >"$work/load.json"; } 2>"$work/client-cpu" ||
  { cat "$work/load.log" >&2; exit 1; }
after="$(ticks)"
if [ -n "${PERF_DATA:-}" ]; then
  kill -INT "$recorder"
  wait "$recorder" || true  # perf's status after SIGINT is not its success
  [ -s "$PERF_DATA" ] || { cat "$work/perf.log" >&2; exit 1; }
fi
python3 - "$work/load.json" "$before" "$after" "$hz" "$seconds" "$streams" "$reference" \
  "$transport" "$work/client-cpu" <<'PY'
import json, sys
result = json.load(open(sys.argv[1]))
client_cpu = sum(float(v) for v in open(sys.argv[9]).read().split())
before, after, hz, seconds, streams = (float(v) for v in sys.argv[2:7])
cpu = (after - before) / hz
reports, errors = result["reports"], result["errors"]
latency = result["latency_us"]
print(f"{sys.argv[7]} over {sys.argv[8]}: {streams:.0f} streams x {result.get('window', '?')} in "
      f"flight, batch {result.get('batch', 1)}, for {seconds:.0f} s: {reports} reports "
      f"({errors} errors), {reports / result['duration_s']:.0f} updates/s, nearpointd CPU "
      f"{cpu:.2f} s ({100 * cpu / result['duration_s']:.0f}% of one core); the load client's CPU "
      f"{client_cpu:.2f} s ({1e6 * client_cpu / max(reports, 1):.1f} us per update)")
cpu_us_per_update = 1e6 * cpu / max(reports, 1)
geometry_us = result.get("geometry_us_per_report")  # absent from builds before batching
print(f"capacity: {reports / cpu:.0f} updates per CPU-second of nearpointd (--workers 1); "
      f"latency p50 {latency['p50']:.0f} us, p99 {latency['p99']:.0f} us")
if geometry_us is not None:
    print(f"geometry share: {geometry_us:.1f} us of geometry per update over "
          f"{cpu_us_per_update:.1f} us of CPU = {100 * geometry_us / cpu_us_per_update:.0f}%")
elif "geometry_us_total" in result:
    geometry = result["geometry_us_total"] / 1e6
    print(f"geometry: {1e6 * geometry / max(reports, 1):.1f} us per update, "
          f"{100 * geometry / cpu:.0f}% of nearpointd's CPU; server_us "
          f"{result['server_us_total'] / max(reports, 1):.1f} per update; "
          f"{result.get('merged', 0)} updates merged")
PY
