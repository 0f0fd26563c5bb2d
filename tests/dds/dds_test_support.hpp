// SPDX-License-Identifier: Apache-2.0
// Shared pieces of the DDS tests: domain ids, topic prefixes, update samples that own their
// strings, and a client loop that collects this client's reports.
//
// Isolation. ctest runs test cases in parallel and a DDS domain is shared by every process on the
// machine, so every test case uses its own domain id (the constants below; 101–130 are reserved
// for DDS tests), and every topic prefix carries the process id, so that another checkout running
// the same tests at the same time cannot cross-talk either. CYCLONEDDS_URI is set by ctest to
// deploy/cyclonedds-loopback.xml (tests/CMakeLists.txt): loopback only.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "dds_stream.hpp"

namespace nearpoint::dds_testing {

// One domain per test case.
inline constexpr std::uint32_t kDomainStream = 101;
inline constexpr std::uint32_t kDomainBadSamples = 102;
inline constexpr std::uint32_t kDomainOverload = 103;
inline constexpr std::uint32_t kDomainSharedScene = 104;
inline constexpr std::uint32_t kDomainNoConfiguration = 105;
inline constexpr std::uint32_t kDomainEvents = 106;
inline constexpr std::uint32_t kDomainDepth = 107;
inline constexpr std::uint32_t kDomainInline = 108;
inline constexpr std::uint32_t kDomainBatchStream = 109;
inline constexpr std::uint32_t kDomainBatchErrors = 110;
inline constexpr std::uint32_t kDomainBatchOverload = 113;
inline constexpr std::uint32_t kDomainBatchEvents = 114;
inline constexpr std::uint32_t kDomainBatchOversized = 115;
inline constexpr std::uint32_t kDomainBatchShutdown = 116;
inline constexpr std::uint32_t kDomainEndToEnd = 111;
inline constexpr std::uint32_t kDomainPreloaded = 112;
inline constexpr std::uint32_t kDomainReportSertype = 117;  // test_dds_report_sertype.cpp
// 118: tests/cli/check_edges.py (load: `nearpoint dds load`)
// 121: tests/cli/check_scene_lifecycle.py (cli.report_schema).

inline std::string unique_prefix(const std::string& test) {
  return "rt/nearpoint_test_" + std::to_string(getpid()) + "_" + test + "/";
}

/// A PoseUpdate_ sample with storage for everything it points to.
struct UpdateMessage {
  struct Pose {
    std::string object_id;
    std::array<double, 4> rotation_wxyz{1, 0, 0, 0};
    std::array<double, 3> translation{0, 0, 0};
  };
  std::string scene_id;
  std::string client_id = "test";
  std::uint64_t sequence = 0;
  std::vector<Pose> poses;
  nearpoint_msgs_msg_dds__QueryOptions_ options{};
  std::uint8_t flow_control = 0;
  struct Threshold {
    std::string name, object_a, object_b;
    double distance = 0, hysteresis = 0;
    std::uint32_t groups = 0;
  };
  std::vector<Threshold> thresholds;

  /// The sample; valid while this object is alive and unchanged.
  const cli::PoseUpdateSample& sample() {
    buffer_.resize(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      buffer_[i].object_id = poses[i].object_id.data();
      const auto& q = poses[i].rotation_wxyz;
      buffer_[i].pose.orientation = {q[1], q[2], q[3], q[0]};  // geometry_msgs: x, y, z, w
      const auto& t = poses[i].translation;
      buffer_[i].pose.position = {t[0], t[1], t[2]};
    }
    sample_ = {};
    sample_.scene_id = scene_id.data();
    sample_.client_id = client_id.data();
    sample_.sequence_number = sequence;
    sample_.poses._buffer = buffer_.data();
    sample_.poses._length = sample_.poses._maximum = std::uint32_t(buffer_.size());
    sample_.poses._release = false;
    sample_.options = options;
    sample_.flow_control = flow_control;
    threshold_buffer_.resize(thresholds.size());
    for (std::size_t i = 0; i < thresholds.size(); ++i)
      threshold_buffer_[i] = {thresholds[i].name.data(),     thresholds[i].distance,
                              thresholds[i].hysteresis,      thresholds[i].object_a.data(),
                              thresholds[i].object_b.data(), thresholds[i].groups};
    sample_.thresholds._buffer = threshold_buffer_.data();
    sample_.thresholds._length = sample_.thresholds._maximum =
        std::uint32_t(threshold_buffer_.size());
    sample_.thresholds._release = false;
    return sample_;
  }

 private:
  std::vector<nearpoint_msgs_msg_dds__ObjectPose_> buffer_;
  std::vector<nearpoint_msgs_msg_dds__Threshold_> threshold_buffer_;
  cli::PoseUpdateSample sample_{};
};

/// A PoseUpdateBatch_ sample of UpdateMessages, each owning its strings.
struct BatchMessage {
  std::vector<UpdateMessage> updates;

  /// The sample; valid while this object is alive and unchanged.
  const cli::PoseUpdateBatchSample& sample() {
    samples_.clear();
    for (UpdateMessage& update : updates) samples_.push_back(update.sample());
    sample_ = {};
    sample_.updates._buffer = samples_.data();
    sample_.updates._length = sample_.updates._maximum = std::uint32_t(samples_.size());
    sample_.updates._release = false;
    return sample_;
  }

 private:
  std::vector<cli::PoseUpdateSample> samples_;
  cli::PoseUpdateBatchSample sample_{};
};

/// A report copied out of its sample.
struct ReceivedPair {
  std::string object_a, object_b;
  std::uint8_t status = 0;
  double distance = 0, error_bound = 0, distance_lower_bound = 0;
  bool warm_started = false;
  // PENETRATION_MODE_DEPTH's fields.
  bool has_signed_distance = false;
  double signed_distance = 0, signed_distance_lower = 0, signed_distance_upper = 0;
  bool has_penetration_depth = false;
  double depth = 0, depth_lower = 0, depth_upper = 0;
  std::array<double, 3> depth_point_a{}, depth_point_b{}, depth_direction{};
  std::uint8_t depth_termination = 0;
  std::uint32_t depth_iterations = 0;
};
struct ReceivedReport {
  std::uint64_t sequence = 0;
  std::uint32_t status = 0;
  std::string client_id, error_field, message;
  std::vector<ReceivedPair> pairs;
  std::uint32_t coalesced_updates = 0;
  std::uint64_t coalesced_from_sequence = 0;
  std::uint32_t pairs_evaluated = 0, pairs_pruned = 0, pairs_unmoved = 0;
  std::uint8_t report_mode = 0;
  struct Event {
    std::string threshold, object_a, object_b;
    std::uint32_t threshold_index = 0;
    std::uint8_t crossing = 0;
    double distance = 0;
    std::uint64_t sequence = 0;
  };
  std::vector<Event> events;
};

inline ReceivedReport copy_report(const cli::DistanceReportSample& sample) {
  ReceivedReport out;
  out.sequence = sample.sequence_number;
  out.status = sample.status;
  out.client_id = sample.client_id;
  out.error_field = sample.error_field;
  out.message = sample.message;
  out.coalesced_updates = sample.coalesced_updates;
  out.coalesced_from_sequence = sample.coalesced_from_sequence;
  out.pairs_evaluated = sample.counts.pairs_evaluated;
  out.pairs_pruned = sample.counts.pairs_pruned;
  out.pairs_unmoved = sample.counts.pairs_unmoved;
  out.report_mode = sample.report_mode;
  for (std::uint32_t i = 0; i < sample.events._length; ++i) {
    const auto& e = sample.events._buffer[i];
    out.events.push_back({e.threshold, e.object_a, e.object_b, e.threshold_index, e.crossing,
                          e.distance, e.sequence_number});
  }
  for (std::uint32_t i = 0; i < sample.pairs._length; ++i) {
    const auto& p = sample.pairs._buffer[i];
    ReceivedPair& pair = out.pairs.emplace_back();
    pair.object_a = p.object_a;
    pair.object_b = p.object_b;
    pair.status = p.status;
    pair.distance = p.distance;
    pair.error_bound = p.error_bound;
    pair.distance_lower_bound = p.distance_lower_bound;
    pair.warm_started = p.warm_started;
    pair.has_signed_distance = p.has_signed_distance;
    pair.signed_distance = p.signed_distance;
    pair.signed_distance_lower = p.signed_distance_lower;
    pair.signed_distance_upper = p.signed_distance_upper;
    pair.has_penetration_depth = p.has_penetration_depth;
    pair.depth = p.penetration_depth;
    pair.depth_lower = p.penetration_depth_lower;
    pair.depth_upper = p.penetration_depth_upper;
    auto array = [](const auto& v) { return std::array{v.x, v.y, v.z}; };
    pair.depth_point_a = array(p.depth_point_a);
    pair.depth_point_b = array(p.depth_point_b);
    pair.depth_direction = array(p.depth_direction);
    pair.depth_termination = p.depth_termination;
    pair.depth_iterations = p.depth_iterations;
  }
  return out;
}

/// Takes this client's reports until `count` have arrived or `timeout` passes without one.
inline std::vector<ReceivedReport> collect_reports(
    cli::DdsPoseClient& client, std::size_t count,
    std::chrono::milliseconds timeout = std::chrono::milliseconds(10000)) {
  std::vector<ReceivedReport> out;
  std::string error;
  while (out.size() < count) {
    const int got = client.take_reports(
        timeout, [&](const cli::DistanceReportSample& s) { out.push_back(copy_report(s)); }, error);
    if (got < 0) ADD_FAILURE() << error;
    if (got <= 0) break;
  }
  return out;
}

/// A connected client (fails the test if it cannot match the server within 10 s); `batched`:
/// on the batch topics.
inline std::unique_ptr<cli::DdsPoseClient> connect(std::uint32_t domain, const std::string& prefix,
                                                   bool batched = false) {
  cli::DdsPoseClient::Config config;
  config.domain_id = domain;
  config.topic_prefix = prefix;
  config.batched = batched;
  std::string error;
  std::unique_ptr<cli::DdsPoseClient> client = cli::DdsPoseClient::create(config, error);
  if (!client) {
    ADD_FAILURE() << error;
    return nullptr;
  }
  if (!client->wait_matched(std::chrono::seconds(10), error)) {
    ADD_FAILURE() << error;
    return nullptr;
  }
  return client;
}

}  // namespace nearpoint::dds_testing
