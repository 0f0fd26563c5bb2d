#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Where one nearpointd worker's CPU goes while `nearpoint load` keeps it busy (the same setup as
# capacity.sh: --workers 1, 127.0.0.1, the demo or cell45 reference scene): `perf record` on the
# server process only, then each sampled function's self time put into one of a few classes
# (kernel scheduling = thread hand-offs, geometry = the engine, gRPC, protobuf, allocation, the
# server's own bookkeeping). Needs perf (Debian's linux-perf) and kernel.perf_event_paranoid ≤ 1
# or root.
#   bench/service/profile.sh [demo|cell45] [SECONDS]      (defaults cell45, 5)
# Environment: BUILD_DIR (default build), STREAMS (2), BATCH (pose sets per message, 1:
# StreamPoses; more: StreamPoseBatches), WINDOW (4, with BATCH > 1 two batches), KEEP=FILE keeps
# perf.data.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${BUILD_DIR:-$root/build}"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
reference="${1:-cell45}"
seconds="${2:-5}"
command -v perf >/dev/null || { echo "profile.sh: perf not found (apt-get install linux-perf)" >&2; exit 2; }
work="$(mktemp -d /tmp/nearpoint-profile.XXXXXX)"
scene_args=()
case "$reference" in
  demo) ;;
  cell45)
    python3 "$root/bench/service/cell45.py" "$work"  # capacity.sh's scene and path
    scene_args=("$work/cell45.json" "$work/cell45.jsonl") ;;
  *) echo "usage: profile.sh [demo|cell45] [SECONDS]" >&2; exit 2 ;;
esac
"$build/server/nearpointd" --listen 127.0.0.1:0 --port-file "$work/port" --workers 1 \
  2>"$work/nearpointd.log" &
server=$!
trap 'kill $server 2>/dev/null || true; wait $server 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 200); do [ -s "$work/port" ] && break; sleep 0.05; done
target="127.0.0.1:$(cat "$work/port")"
source "$root/bench/service/load_flags.sh"  # BATCH, WINDOW
perf record -q -F 2000 -g -p "$server" -o "$work/perf.data" -- sleep "$((seconds + 1))" \
  2>"$work/perf.log" &
recorder=$!
"$build/client/nearpoint" load --target "$target" --streams "${STREAMS:-2}" \
  --duration "$seconds" "${load_flags[@]}" --json "${scene_args[@]}" \
  2>"$work/load.log" >"$work/load.json" || { cat "$work/load.log" >&2; exit 1; }
wait "$recorder" || { cat "$work/perf.log" >&2; exit 1; }
[ -n "${KEEP:-}" ] && cp "$work/perf.data" "$KEEP"
perf report -i "$work/perf.data" --no-children --sort dso,symbol -g none --stdio 2>/dev/null \
  >"$work/flat.txt"
python3 - "$work/flat.txt" "$reference" <<'PY'
import collections, re, sys
classes = collections.Counter()
for line in open(sys.argv[1]):
    m = re.match(r"\s*([\d.]+)%\s+(\S+)\s+\[(.)\]\s+(.*)", line)
    if not m:
        continue
    share, dso, kind, symbol = float(m[1]), m[2], m[3], m[4]
    if kind == "k":
        scheduling = re.search(r"task_switch|schedule|futex|wake|spin_unlock|irq", symbol)
        name = "kernel: scheduling (thread hand-offs)" if scheduling else "kernel: syscalls, TCP"
    elif dso.startswith("lib") and re.search(
            r"malloc|free|operator new|operator delete|_int_|tcache|consolidate|unlink_chunk", symbol):
        name = "allocation (malloc, free)"
    elif "nearpoint::v1::" in symbol or "protobuf" in dso or "protobuf" in symbol:
        name = "protobuf (build, size, serialise, parse)"
    elif re.search(r"grpc|absl|gpr|upb", dso) or "grpc" in symbol:
        name = "gRPC, absl (framing, polling, locks)"
    elif "nearpoint::server::" in symbol:
        name = "server (planning, bookkeeping, reports)"
    elif dso == "nearpointd" and "nearpoint::" in symbol:
        name = "geometry (the engine)"
    else:
        name = "other (libc, libstdc++, vdso clock)"
    classes[name] += share
print(f"{sys.argv[2]}: share of nearpointd's sampled CPU")
for name, share in classes.most_common():
    print(f"  {share:5.1f}%  {name}")
PY
