// SPDX-License-Identifier: Apache-2.0
// What the DDS server bridge and the DDS client must agree on, in one place: topic names, QoS,
// and the rule that Cyclone DDS never runs without a configuration here.
//
// Topics (ROS 2 convention: a ROS 2 topic /nearpoint/pose_updates is the DDS topic
// rt/nearpoint/pose_updates, and type nearpoint/msg/PoseUpdate is
// nearpoint::msg::dds_::PoseUpdate_):
//   <prefix>pose_updates      nearpoint::msg::dds_::PoseUpdate_       client -> server
//   <prefix>distance_reports  nearpoint::msg::dds_::DistanceReport_   server -> client
// with <prefix> = "rt/nearpoint/" by default.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <memory>
#include <string>

#include "nearpoint_distance_report.h"
#include "nearpoint_pose_update.h"

namespace nearpoint::dds {

inline constexpr const char* kDefaultTopicPrefix = "rt/nearpoint/";
inline constexpr const char* kPoseUpdatesSuffix = "pose_updates";
inline constexpr const char* kDistanceReportsSuffix = "distance_reports";

/// Keep-last depth of every reader and writer on both topics, per instance (= per scene id).
/// 64 updates are ~0.6 s of a 100 Hz control loop: the server's bridge thread takes samples as
/// they arrive (no geometry on it), so its history fills only if that thread is starved for that
/// long; a client that does not take its reports loses the oldest beyond 64.
inline constexpr std::int32_t kHistoryDepth = 64;

/// How long a reliable write may wait for history space before failing (keep-last writers
/// replace their oldest sample instead, so this bounds only transient resource waits).
inline constexpr dds_duration_t kMaxBlockingTime = DDS_MSECS(100);

/// The QoS of both topics, readers and writers alike: reliable, keep-last kHistoryDepth,
/// volatile (a late joiner sees no old updates or reports).
struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;
QosPtr stream_qos();

/// The full topic names for a prefix.
std::string pose_updates_topic(const std::string& prefix);
std::string distance_reports_topic(const std::string& prefix);

/// Empty when `prefix` makes legal topic names; otherwise what is wrong with it.
std::string check_topic_prefix(const std::string& prefix);

/// Without a configuration Cyclone DDS joins the machine's external interface and multicasts
/// discovery off the machine. Empty when CYCLONEDDS_URI is set (or `allow_default` says the
/// operator accepts Cyclone's defaults); otherwise the message to print and refuse with.
std::string check_configuration(bool allow_default);

/// "what: DDS_RETCODE_…" for a failed Cyclone call.
std::string describe(const char* what, dds_return_t code);

/// The 16 bytes of a GUID from `guid`, as 32 lowercase hex digits.
std::string guid_hex(const std::uint8_t* guid);

}  // namespace nearpoint::dds
