#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# One bounded libFuzzer run (the ctest tests fuzz.NAME.run call this):
#   run_fuzzer.sh BINARY WORK_CORPUS ARTIFACT_DIR SEED_DIR...
# Fuzzes for $NEARPOINT_FUZZ_SECONDS seconds (default 60), or, when $NEARPOINT_FUZZ_RUNS is set,
# for that many inputs; one process, one job. New inputs go to WORK_CORPUS (in the build tree, kept
# between runs so that a longer run continues where the last one stopped); the seed directories
# in the source tree are only read. A finding is written to ARTIFACT_DIR and fails the test:
# minimise it and add it to tests/fuzz/corpus/NAME or tests/fuzz/regressions/NAME (README.md).
set -euo pipefail
binary="$1" corpus="$2" artifacts="$3"
shift 3
mkdir -p "$corpus" "$artifacts"
limit=("-max_total_time=${NEARPOINT_FUZZ_SECONDS:-60}")
if [ -n "${NEARPOINT_FUZZ_RUNS:-}" ]; then limit=("-runs=$NEARPOINT_FUZZ_RUNS"); fi
# -timeout: one input taking 10 s is a hang (every target bounds its per-input work).
# -rss_limit_mb: a leak or a blow-up, not a big machine's allowance.
# -max_len: enough for every seed; larger inputs only slow the search.
# -entropic=0: libFuzzer's default entropic schedule spent 75% of fuzz_engine's time on its own
# bookkeeping (InputCorpus::UpdateFeatureFrequency and AddRareFeature, under perf) once the corpus
# held ~60,000 features; the plain schedule runs 4–5× as many inputs per second (engine: 1,200 →
# 5,500 per second under ASan) and found two new compound findings in its first minute.
exec "$binary" "${limit[@]}" -timeout=10 -rss_limit_mb=2048 -max_len=8192 -print_final_stats=1 \
  -entropic=0 \
  -artifact_prefix="$artifacts/" ${NEARPOINT_FUZZ_ARGS:-} "$corpus" "$@"
