#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Two nearpointd builds side by side in the same minutes: every setting of capacity.sh that
# issue 36's targets name, the older build first then the newer, ROUNDS times, one line per run.
# On a shared or noisy machine only ratios taken this way mean anything.
#   bench/service/compare.sh OLD_NEARPOINTD [NEW_NEARPOINTD]
# NEW_NEARPOINTD defaults to BUILD_DIR/server/nearpointd (BUILD_DIR default build); the load
# client is BUILD_DIR's `nearpoint`, for the old build too unless OLD_CLIENT_BUILD names the build
# directory whose `nearpoint` loads it (to compare load clients as well). Environment: ROUNDS
# (default 3), SECONDS_PER_RUN (default 4), ONLY (a grep -E pattern of the settings to run, e.g.
# ONLY=dds), OLD_CLIENT_BUILD. Columns: setting,
# build, updates per CPU-second, latency p50 and p99 (µs), then geometry µs per update and the
# geometry share (%), with gRPC's CPU µs per update between them.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${BUILD_DIR:-$root/build}"
old="${1:?usage: compare.sh OLD_NEARPOINTD [NEW_NEARPOINTD]}"
new="${2:-$build/server/nearpointd}"
rounds="${ROUNDS:-3}"
seconds="${SECONDS_PER_RUN:-4}"
for binary in "$old" "$new"; do
  [ -x "$binary" ] || { echo "compare.sh: $binary is not an executable" >&2; exit 2; }
done
# Loopback only, never Cyclone's default (the external interface, multicast).
export CYCLONEDDS_URI="${CYCLONEDDS_URI:-file://$root/deploy/cyclonedds-loopback.xml}"

# run LABEL "SCENE STREAMS" VAR=VALUE…: one capacity.sh run per build.
run() {
  local label="$1" scene_streams="$2"
  shift 2
  grep -qE "${ONLY:-.}" <<<"$label" || return 0
  local which binary client_build out capacity geometry
  for which in old new; do
    binary="$old"
    client_build="${OLD_CLIENT_BUILD:-$build}"
    [ "$which" = new ] && binary="$new" && client_build="$build"
    # shellcheck disable=SC2086  # "SCENE STREAMS" splits into two arguments
    out="$(env "$@" NEARPOINTD="$binary" BUILD_DIR="$client_build" \
      "$root/bench/service/capacity.sh" $scene_streams \
      "$seconds" 2>&1 | grep -E '^(capacity|geometry share|geometry):' || true)"
    capacity="$(sed -n 's/^capacity: \([0-9]*\) updates.*p50 \([0-9]*\) us, p99 \([0-9]*\) us.*/\1 \2 \3/p' <<<"$out")"
    geometry="$(sed -n -e 's/^geometry share: \([0-9.]*\) us of geometry per update over \([0-9.]*\) us of CPU = \([0-9]*\)%.*/\1 \2 \3/p' \
      -e "s/^geometry: \([0-9.]*\) us per update, \([0-9]*\)% of nearpointd's CPU.*/\1 \2/p" <<<"$out")"
    echo "$label $which ${capacity:-failed} $geometry"
  done
}

echo "# compare.sh $(date -u '+%F %T') UTC, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# old $old"
echo "# new $new"
echo "# load client: old $(realpath "${OLD_CLIENT_BUILD:-$build}")/client/nearpoint, new $(realpath "$build")/client/nearpoint"
echo "# setting build updates/CPU-s p50_us p99_us geometry_us [cpu_us] share_%"
for _ in $(seq "$rounds"); do
  run demo-4x4 "demo 4" WINDOW=4
  run cell45-4x4 "cell45 4" WINDOW=4
  run demo-1x1 "demo 1" WINDOW=1
  run cell45-1x1 "cell45 1" WINDOW=1
  run demo-4x4-batch8 "demo 4" BATCH=8
  run cell45-4x4-batch8 "cell45 4" BATCH=8
  run dds-cell45-1x4 "cell45 1" TRANSPORT=dds
  run dds-cell45-1x4-batch8 "cell45 1" TRANSPORT=dds BATCH=8
  run dds-demo-1x4 "demo 1" TRANSPORT=dds
  run dds-demo-1x4-batch8 "demo 1" TRANSPORT=dds BATCH=8
done
echo "# done $(date -u '+%F %T') UTC, load $(cut -d' ' -f1-3 /proc/loadavg)"
