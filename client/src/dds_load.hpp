// SPDX-License-Identifier: Apache-2.0
// `nearpoint dds load`: `nearpoint load` over DDS. Concurrent pose streams to nearpointd --dds for
// a bounded time, each with a window of updates in flight, replaying a trajectory in a loop; then
// the rate, the push-to-report latency and what the reports say the server spent (server_us and
// geometry_us summed), so that bench/service/capacity.sh can measure the DDS path as it measures
// gRPC's (updates per CPU-second of nearpointd, geometry share).
//
// Each stream is its own DDS participant with one PoseUpdate_ writer and one DistanceReport_
// reader, as separate robot processes would be. The report topic is keyless, so every stream's
// reader receives every stream's reports (and nearpointd sends each report to each of them):
// measure the server's per-update cost with one stream and a window. With a batch size each
// stream publishes that many consecutive updates per PoseUpdateBatch_ sample.
#pragma once

#include <chrono>
#include <cstddef>
#include <iosfwd>
#include <string>

#include "dds_stream.hpp"
#include "trajectory.hpp"

namespace nearpoint::cli {

struct DdsLoadOptions {
  DdsPoseClient::Config dds;
  /// The scene id on the server (e.g. preloaded with nearpointd --scene FILE).
  std::string scene_id;
  int streams = 1;
  double duration_s = 3;
  /// Updates in flight per stream. Keep it within nearpointd's --max-in-flight (default 8), or
  /// the server merges updates (the summary counts them).
  std::size_t window = 4;
  /// Consecutive updates per sample (more than 1: the batch topics, PoseUpdateBatch_ in and
  /// DistanceReportBatch_ out); the window counts updates and holds at least one batch.
  std::size_t batch = 1;
  /// One JSON object instead of text.
  bool json = false;
  std::chrono::milliseconds match_timeout{10000};
  /// How long a stream waits for a report before giving up on the missing ones.
  std::chrono::milliseconds report_timeout{10000};
};

/// Runs the streams over `trajectory` (not empty) and prints the summary to `out`: reports
/// (answered updates), merged updates, error reports, updates/s, latency p50/p90/p99/max and the
/// reports' server_us and geometry_us totals (as text, or with `json` one object with the keys of
/// `nearpoint load --json` plus "merged", "server_us_total" and "geometry_us_total"). Exit status
/// as `nearpoint stream --dds`: 0 every update answered, kStreamIncomplete error reports or missing
/// reports, kStreamBadConfiguration, kStreamCannotRun.
int run_dds_load(const Trajectory& trajectory, const DdsLoadOptions& options, std::ostream& out,
                 std::ostream& err);

}  // namespace nearpoint::cli
