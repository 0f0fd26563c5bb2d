// SPDX-License-Identifier: Apache-2.0
// `nearpoint dds topics` and `nearpoint dds echo`: what a ROS 2 user would see with
// `ros2 topic list -t` / `ros2 topic info` and `ros2 topic echo`, without ROS 2.
#pragma once

#include <chrono>
#include <cstdint>
#include <iosfwd>
#include <string>

#include "dds_stream.hpp"

namespace nearpoint::cli {

struct DdsTopicsOptions {
  DdsPoseClient::Config dds;
  /// How long to listen for discovery before listing.
  std::chrono::milliseconds wait{2000};
  /// Only topics whose DDS name starts with this (empty: every topic).
  std::string filter;
};

/// Lists the topics discovered on the domain, one line each: the ROS 2 name and type (as ROS 2
/// tools show them), the DDS topic and type names, and how many publishers and subscribers were
/// seen. Exit status 0, or kStreamCannotRun / kStreamBadConfiguration.
int run_dds_topics(const DdsTopicsOptions& options, std::ostream& out, std::ostream& err);

struct DdsEchoOptions {
  DdsPoseClient::Config dds;
  /// Only reports of this scene (empty: every scene).
  std::string scene_id;
  /// Stop after this many reports (0: until the timeout).
  std::uint64_t count = 0;
  /// Stop when no report arrived for this long.
  std::chrono::milliseconds timeout{10000};
};

/// Prints every DistanceReport on <prefix>distance_reports as a JSON line (the CLI's report
/// schema, plus "scene_id" and "client_id"). Exit status 0 when `count` reports were printed
/// (or any, without a count), kStreamIncomplete when fewer arrived before the timeout.
int run_dds_echo(const DdsEchoOptions& options, std::ostream& out, std::ostream& err);

}  // namespace nearpoint::cli
