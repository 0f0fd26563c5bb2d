#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Where one nearpointd worker's CPU goes while a client keeps it busy (capacity.sh's setup and
# scenes: --workers 1, 127.0.0.1, `nearpoint load` over gRPC or, with TRANSPORT=dds, `nearpoint
# dds load` over Cyclone DDS): `perf record` on the server process only (capacity.sh's
# PERF_DATA), then each sampled function's self time put into one of a few classes (kernel
# scheduling = thread hand-offs, geometry = the engine, gRPC, protobuf, Cyclone DDS, the DDS
# reports' serialiser, allocation, the server's own bookkeeping). Needs perf (Debian's
# linux-perf) and kernel.perf_event_paranoid ≤ 1 or root.
#   bench/service/profile.sh [demo|cell45] [SECONDS]      (defaults cell45, 5)
# Environment: as capacity.sh's (BUILD_DIR, NEARPOINTD, SERVER_ARGS, TRANSPORT, BATCH, WINDOW), and
# STREAMS (default 2; 1 with TRANSPORT=dds), KEEP=FILE keeps perf.data.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
reference="${1:-cell45}"
seconds="${2:-5}"
command -v perf >/dev/null || { echo "profile.sh: perf not found (apt-get install linux-perf)" >&2; exit 2; }
work="$(mktemp -d /tmp/nearpoint-profile.XXXXXX)"
trap 'rm -rf "$work"' EXIT
default_streams=2
[ "${TRANSPORT:-grpc}" = dds ] && default_streams=1
PERF_DATA="$work/perf.data" "$root/bench/service/capacity.sh" "$reference" \
  "${STREAMS:-$default_streams}" "$seconds"
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
        name = "kernel: scheduling (thread hand-offs)" if scheduling else "kernel: syscalls, TCP/UDP"
    elif dso.startswith("lib") and re.search(
            r"malloc|free|operator new|operator delete|_int_|tcache|consolidate|unlink_chunk", symbol):
        name = "allocation (malloc, free)"
    elif "ddsc" in dso or re.search(r"\bdds_|ddsi_|dds_stream_", symbol):
        name = "Cyclone DDS (serialise, send, receive, waitsets)"
    elif "nearpoint::v1::" in symbol or "protobuf" in dso or "protobuf" in symbol:
        name = "protobuf (build, size, serialise, parse)"
    elif re.search(r"grpc|absl|gpr|upb", dso) or "grpc" in symbol:
        name = "gRPC, absl (framing, polling, locks)"
    elif re.search(r"nearpoint::server::\(anonymous namespace\)::"
                   r"(write_(report|pair|event|sample|header|vector)|CdrOut|serdata_)", symbol):
        name = "DDS reports' CDR (nearpoint's serialiser)"
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
