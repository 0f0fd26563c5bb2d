#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The whole benchmark suite in one command: configures a Release build in build-bench (with the
# peers FCL, libccd and Bullet), builds it, runs the experiments one after another (never two
# at once: they would disturb each other's timings), then writes the tables, the plots and
# bench/RESULTS.md from what the run measured.
#
#   bench/run.sh            full run (a few minutes; RESULTS.md states how long it took) into
#                           bench/results/ and bench/RESULTS.md
#   bench/run.sh --quick    smoke test: small samples, few rounds, into build-bench/quick-results/
#                           (bench/results/ and bench/RESULTS.md are left alone)
#   bench/run.sh --peers DIR  where the openGJK / coal snapshots are (bench/README.md, "Peers
#                           built from source"); also NEARPOINT_PEERS_DIR. No default: without
#                           either, openGJK and coal are left out, saying so, and the rest runs.
#                           They are built once into the build tree; a missing one is named.
#   bench/run.sh --only depth[,paper,…]  run only these experiments, keeping the other results
#                           (and machine.csv) of the last full run; RESULTS.md is rewritten from
#                           all of them. Each experiment's own date, commit and load are in
#                           run_EXPERIMENT.csv.
#
# Environment: BUILD_DIR (default build-bench), JOBS (build parallelism, default 1: the machine is
# shared), PYTHON (default /usr/bin/python3, which needs python3-matplotlib: deploy/install-deps.sh
# --bench installs it), NEARPOINT_ARCH (default empty, the portable build; e.g. x86-64-v3 to
# measure a build for this CPU, see CMakeLists.txt; use another BUILD_DIR for it).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

quick=0
only=""
all_experiments="paper table1 error-time large stability primitives depth"
peers="${NEARPOINT_PEERS_DIR:-}"
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --peers) [ $# -ge 2 ] || { echo "bench/run.sh: --peers needs a folder" >&2; exit 2; }
             peers="$2"; shift ;;
    --peers=*) peers="${1#--peers=}" ;;
    --only) [ $# -ge 2 ] || { echo "bench/run.sh: --only needs a list of experiments" >&2; exit 2; }
            only="$2"; shift ;;
    --only=*) only="${1#--only=}" ;;
    -h|--help) sed -n '3,24p' "$0"; exit 0 ;;
    *) echo "bench/run.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
experiments="$all_experiments"
if [ -n "$only" ]; then
  experiments="${only//,/ }"
  for e in $experiments; do
    case " $all_experiments " in
      *" $e "*) ;;
      *) echo "bench/run.sh: unknown experiment '$e' in --only (one of: $all_experiments)" >&2; exit 2 ;;
    esac
  done
fi
if [ -z "$peers" ]; then
  echo "bench/run.sh: no peers folder given (--peers DIR or NEARPOINT_PEERS_DIR): the bench runs" \
       "without openGJK and coal (bench/README.md, \"Peers built from source\", says how to make" \
       "their snapshots)" >&2
elif [ ! -d "$peers" ]; then
  echo "bench/run.sh: the peers folder $peers does not exist (--peers / NEARPOINT_PEERS_DIR)" >&2
  exit 2
else
  peers="$(cd "$peers" && pwd)"
  for snapshot in openGJK coal jrl-cmakemodules; do
    if ! compgen -G "$peers/$snapshot-*.tar.gz" >/dev/null; then
      echo "bench/run.sh: no $snapshot snapshot in $peers: the bench runs without" \
           "$([ "$snapshot" = openGJK ] && echo openGJK || echo coal) (see --peers)" >&2
    fi
  done
fi

build="${BUILD_DIR:-build-bench}"
jobs="${JOBS:-1}"
python="${PYTHON:-/usr/bin/python3}"
if ! "$python" -c 'import matplotlib' 2>/dev/null; then
  echo "bench/run.sh: $python cannot import matplotlib (deploy/install-deps.sh --bench)" >&2
  exit 1
fi

start=$(date +%s)
options=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DNEARPOINT_BUILD_BENCH=ON -DNEARPOINT_BENCH_PEERS=ON
         -DNEARPOINT_BUILD_CLIENT=OFF -DNEARPOINT_WITH_GRPC=OFF -DNEARPOINT_ARCH="${NEARPOINT_ARCH:-}"
         -DNEARPOINT_PEERS_DIR="$peers")
# The bench links the tests' kit (tests/CMakeLists.txt). Should the test tree not configure (it
# needs GoogleTest, and is work in progress at times), the bench builds the kit from the same
# sources instead.
mkdir -p "$build"
log="$build/configure.log"
if ! cmake -S . -B "$build" "${options[@]}" -DNEARPOINT_BUILD_TESTS=ON >"$log" 2>&1; then
  echo "bench/run.sh: the test tree does not configure (see $log); building the bench without it" >&2
  cmake -S . -B "$build" "${options[@]}" -DNEARPOINT_BUILD_TESTS=OFF >>"$log" 2>&1 ||
    { cat "$log" >&2; exit 1; }
fi
cmake --build "$build" -j "$jobs" --target nearpoint-bench
built=$(date +%s)

# One run at a time on this machine.
exec 9>"$build/.bench-lock"
if ! flock -n 9; then
  echo "bench/run.sh: another benchmark run holds $build/.bench-lock" >&2
  exit 1
fi

if [ "$quick" = 1 ]; then
  out="$build/quick-results"
  results_md="$out/RESULTS.md"
  flags=(--quick)
else
  out="bench/results"
  results_md="bench/RESULTS.md"
  flags=()
fi
if [ -z "$only" ]; then
  rm -rf "$out"
fi
mkdir -p "$out"

# The machine, as the report states it (a run of some experiments only keeps the full run's).
[ -n "$only" ] || {
  echo "key,value"
  echo "cpu,\"$(lscpu | sed -n 's/^Model name: *//p' | head -n 1)\""
  echo "cores,$(nproc)"
  echo "kernel,$(uname -r)"
  echo "compiler,\"$(c++ --version | head -n 1)\""
  # NEARPOINT_ARCH from the build's cache (a build configured for a known CPU; see CMakeLists.txt).
  arch=$(sed -n 's/^NEARPOINT_ARCH:STRING=//p' "$build/CMakeCache.txt")
  echo "arch,\"${arch:+-march=$arch -ffp-contract=fast}${arch:-portable (compiler default)}\""
  echo "date,$(date -u +%Y-%m-%dT%H:%MZ)"
  echo "commit,$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  # The run's own outputs (results of an earlier run, or of this one so far) do not count.
  echo "working_tree,$(git status --porcelain -- . ':!bench/results' ':!bench/RESULTS.md' \
    2>/dev/null | grep -q . && echo modified || echo clean)"
  echo "load_before,\"$(cut -d' ' -f1-3 /proc/loadavg)\""
  echo "command,bench/run.sh${flags[*]:+ ${flags[*]}}"
  # The snapshots used, by name (the folder is the caller's: nothing outside the repository is named).
  echo "peer_snapshots,\"$( [ -n "$peers" ] && cd "$peers" 2>/dev/null && ls *.tar.gz 2>/dev/null | tr '\n' ' ')\""
  echo "build_seconds,$((built - start))"
} >"$out/machine.csv"

for experiment in $experiments; do
  t0=$(date +%s)
  load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
  "$build/bench/nearpoint-bench" "$experiment" --out "$out" "${flags[@]}"
  [ -n "$only" ] || echo "seconds_$experiment,$(($(date +%s) - t0))" >>"$out/machine.csv"
  # This experiment's own run (what the report states for it when it was run alone).
  {
    echo "key,value"
    echo "date,$(date -u +%Y-%m-%dT%H:%MZ)"
    echo "commit,$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
    echo "working_tree,$(git status --porcelain -- . ':!bench/results' ':!bench/RESULTS.md' \
      2>/dev/null | grep -q . && echo modified || echo clean)"
    echo "load_before,\"$load_before\""
    echo "load_after,\"$(cut -d' ' -f1-3 /proc/loadavg)\""
    echo "seconds,$(($(date +%s) - t0))"
    echo "command,bench/run.sh${flags[*]:+ ${flags[*]}}${only:+ --only $only}"
  } >"$out/run_${experiment//-/_}.csv"
done
if [ -z "$only" ]; then
  echo "load_after,\"$(cut -d' ' -f1-3 /proc/loadavg)\"" >>"$out/machine.csv"
  echo "total_seconds,$(($(date +%s) - start))" >>"$out/machine.csv"
fi

"$python" bench/tools/report.py --results "$out" --summary "$results_md"
echo "bench/run.sh: results in $out, summary in $results_md ($(($(date +%s) - start)) s)"
