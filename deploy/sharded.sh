#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Scenes spread over three nearpointd replicas behind HAProxy, on this machine (127.0.0.1 only):
#   deploy/sharded.sh            start them, print the address, run until Ctrl-C (then stop all)
#   deploy/sharded.sh smoke      start them, create 30 scenes through the proxy with the CLI, show
#                                each replica's share (from its log), query each scene, stop
# `deploy/run.sh sharded [smoke]` builds first. The proxy listens on 127.0.0.1:$PROXY_PORT
# (default 50050), the replicas on the next three ports; HAProxy's configuration is
# deploy/haproxy/nearpoint.cfg (consistent hashing of the x-nearpoint-scene header, gRPC health
# checks over HTTP/2). Logs and pids go to $SHARD_DIR (default: a fresh temporary directory).
# Environment: BUILD_DIR (default build), PROXY_PORT, SHARD_DIR, WORKERS (per replica, default 1).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
nearpointd="$build/server/nearpointd"
nearpoint="$build/client/nearpoint"
for binary in "$nearpointd" "$nearpoint"; do
  [ -x "$binary" ] || { echo "sharded.sh: $binary is missing: deploy/run.sh sharded builds it" >&2; exit 2; }
done
command -v haproxy >/dev/null ||
  { echo "sharded.sh: haproxy is missing: deploy/install-deps.sh installs it" >&2; exit 2; }

proxy_port="${PROXY_PORT:-50050}"
dir="${SHARD_DIR:-$(mktemp -d /tmp/nearpoint-sharded.XXXXXX)}"
mkdir -p "$dir"
export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-loopback.xml"  # should anything start DDS
export NEARPOINT_PROXY_LISTEN="127.0.0.1:$proxy_port"
pids=()
stop() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
}
trap stop EXIT
trap 'exit 130' INT TERM

for i in 1 2 3; do
  port=$((proxy_port + i))
  export "NEARPOINT_REPLICA_$i=127.0.0.1:$port"
  "$nearpointd" --listen "127.0.0.1:$port" --workers "${WORKERS:-1}" >"$dir/replica$i.log" 2>&1 &
  pids+=($!)
done
for i in 1 2 3; do
  port=$((proxy_port + i))
  for _ in $(seq 100); do
    "$nearpoint" health --target "127.0.0.1:$port" --timeout-ms 200 >/dev/null 2>&1 && break
    sleep 0.1
  done
  "$nearpoint" health --target "127.0.0.1:$port" --timeout-ms 1000 >/dev/null ||
    { echo "sharded.sh: replica $i (127.0.0.1:$port) did not start: $dir/replica$i.log" >&2; exit 1; }
done
haproxy -db -f "$root/deploy/haproxy/nearpoint.cfg" >"$dir/haproxy.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
  "$nearpoint" health --target "$NEARPOINT_PROXY_LISTEN" --timeout-ms 200 >/dev/null 2>&1 && break
  sleep 0.1
done
"$nearpoint" health --target "$NEARPOINT_PROXY_LISTEN" --timeout-ms 1000 >/dev/null ||
  { echo "sharded.sh: haproxy did not start: $dir/haproxy.log" >&2; exit 1; }

echo "sharded: proxy $NEARPOINT_PROXY_LISTEN -> replicas $NEARPOINT_REPLICA_1 $NEARPOINT_REPLICA_2 $NEARPOINT_REPLICA_3"
echo "sharded: logs in $dir"

if [ "${1:-}" = smoke ]; then
  export NEARPOINT_TARGET="$NEARPOINT_PROXY_LISTEN"
  scene="$dir/scene.json"
  for k in $(seq -w 1 30); do
    cat >"$scene" <<JSON
{"id": "cell-$k",
 "geometries": {"arm": {"box": [0.1, 0.1, 0.4]}, "post": {"cylinder": {"radius": 0.2, "half_height": 1}}},
 "objects": [{"id": "arm", "geometry": "arm", "pose": {"translation": [0.$k, 0, 0.5]}},
             {"id": "post", "geometry": "post", "pose": {"translation": [1.5, 0, 0]}}]}
JSON
    "$nearpoint" scene create "$scene" >/dev/null
  done
  for i in 1 2 3; do
    address="NEARPOINT_REPLICA_$i"
    echo "replica $i (${!address}): $(grep -c 'event=scene_created' "$dir/replica$i.log") scenes"
  done
  failed=0
  for k in $(seq -w 1 30); do
    "$nearpoint" query "cell-$k" >/dev/null || failed=$((failed + 1))
  done
  echo "queries through the proxy: $((30 - failed)) of 30 answered"
  [ "$failed" -eq 0 ]
  exit
fi
echo "sharded: export NEARPOINT_TARGET=$NEARPOINT_PROXY_LISTEN; Ctrl-C stops everything"
wait -n "${pids[@]}" || true
echo "sharded: a process ended; stopping the others" >&2
exit 1
