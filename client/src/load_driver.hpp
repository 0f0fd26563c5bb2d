// SPDX-License-Identifier: Apache-2.0
// `nearpoint load`'s streams: pose updates replayed on StreamPoses (or StreamPoseBatches) with a
// window in flight, driven from one completion queue by the calling thread alone.
//
// Why not the client library's Session: a Session is a pushing thread and a reader thread whose
// blocking calls take turns at gRPC's one poller, so every update hands work from thread to
// thread. That suits a control loop at 1 kHz; a load generator on the server's machine then
// takes three times the server's CPU for each update and leaves the server idle half the time,
// which is not a load. Here one thread keeps every stream's window full, as a load balancer or a
// fleet of robots would, and costs a fraction of the server.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "nearpoint/client/client.hpp"

namespace nearpoint::cli {

/// What the load's streams measured.
struct LoadResult {
  /// Push to report, one per answered update (updates merged by the server have none).
  std::vector<double> latencies_us;
  /// The reports' ReportTiming::geometry_us, summed: the engine's share of the server's work.
  double geometry_us = 0;
  /// Error reports, plus the updates still in flight on a stream that failed.
  std::size_t errors = 0;
  std::string first_error;
  double elapsed_s = 0;
};

struct LoadPlan {
  std::string target;
  client::ClientOptions client_options;
  /// The scene's id on the server (also its routing header).
  std::string scene_id;
  /// The pose sets each stream replays round and round, from its own starting point.
  const std::vector<std::vector<client::ObjectPose>>* path = nullptr;
  int streams = 1;
  /// Updates in flight per stream (at least one batch).
  std::size_t window = 1;
  /// Pose sets per message: 1 on StreamPoses, more on StreamPoseBatches.
  std::size_t batch = 1;
  double duration_s = 1;
  /// Called every `progress_every` seconds (0: never) with the seconds elapsed, the reports
  /// and the errors so far.
  double progress_every = 0;
  std::function<void(double, std::size_t, std::size_t)> progress;
};

/// Runs `plan` to its end (or until interrupt_signal()); each stream's reports are all read and
/// its call finished before this returns.
LoadResult drive_load(const LoadPlan& plan);

}  // namespace nearpoint::cli
