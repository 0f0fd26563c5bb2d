// SPDX-License-Identifier: Apache-2.0
// What the DDS server bridge and the DDS client must agree on, in one place: topic names, QoS,
// and the rule that Cyclone DDS never runs without a configuration here.
//
// The topics are ROS 2 topics (the types: ros/nearpoint_msgs, generated into nearpoint_ros.h),
// each as ROS 2 name, then DDS topic and DDS type (nearpoint_msgs::msg::dds_::<type>_):
//   /nearpoint/pose_updates              rt/nearpoint/pose_updates              PoseUpdate_
//   /nearpoint/distance_reports          rt/nearpoint/distance_reports          DistanceReport_
//   /nearpoint/threshold_events          rt/nearpoint/threshold_events          ThresholdEvent_
//   /nearpoint/pose_update_batches       rt/nearpoint/pose_update_batches       PoseUpdateBatch_
//   /nearpoint/distance_report_batches   rt/nearpoint/distance_report_batches
//                                                                       DistanceReportBatch_
// with "rt/nearpoint/" the default prefix (rt/ + the ROS 2 namespace, as rmw_cyclonedds maps
// it). The types are keyless and plain XCDR1, as ROS 2 requires; scenes are told apart by the
// scene_id field, which lets one reader serve every scene (scene ids are free text, not ROS
// names).
#pragma once

#include <dds/dds.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "nearpoint_ros.h"

namespace nearpoint::dds {

inline constexpr const char* kDefaultTopicPrefix = "rt/nearpoint/";
inline constexpr const char* kPoseUpdatesSuffix = "pose_updates";
inline constexpr const char* kDistanceReportsSuffix = "distance_reports";
inline constexpr const char* kThresholdEventsSuffix = "threshold_events";
/// The batched pair: several updates per sample in, several reports per sample out (a writer on
/// the batch topic is answered on the batch report topic, and only there).
inline constexpr const char* kPoseUpdateBatchesSuffix = "pose_update_batches";
inline constexpr const char* kDistanceReportBatchesSuffix = "distance_report_batches";

/// The DDS type names, as ROS 2 tools show them (ros2 topic info: nearpoint_msgs/msg/PoseUpdate).
inline constexpr const char* kPoseUpdateType = "nearpoint_msgs::msg::dds_::PoseUpdate_";
inline constexpr const char* kDistanceReportType = "nearpoint_msgs::msg::dds_::DistanceReport_";
inline constexpr const char* kThresholdEventType = "nearpoint_msgs::msg::dds_::ThresholdEvent_";
inline constexpr const char* kPoseUpdateBatchType = "nearpoint_msgs::msg::dds_::PoseUpdateBatch_";
inline constexpr const char* kDistanceReportBatchType =
    "nearpoint_msgs::msg::dds_::DistanceReportBatch_";

/// The most updates one PoseUpdateBatch_ sample may carry. A larger one is refused whole, with
/// one error report (RESOURCE_EXHAUSTED, field "updates"): the bridge thread accepts a sample's
/// updates in one go, and this bounds how long one client's sample holds it from the others.
inline constexpr std::uint32_t kMaxUpdatesPerBatch = 1024;
/// The most reports the server puts in one DistanceReportBatch_ sample, and about the most bytes
/// (estimated from the reports' pairs, at least one report each): a DDS sample is cut into
/// fragments of about 1.3 kB, all of which must arrive (or be resent) before the reader sees any
/// report, so a few large reports (45 pairs: ~17 kB each) gain nothing from one sample while the
/// burst's latency grows with it.
inline constexpr std::uint32_t kMaxReportsPerBatch = 64;
inline constexpr std::size_t kMaxReportBatchBytes = 64 * 1024;

/// ROS 2's default QoS profile: KEEP_LAST 10, RELIABLE, VOLATILE (rmw_qos_profile_default).
/// The types are keyless, so the depth is shared by every writer of a topic: a reader that does
/// not take its samples within 10 of them loses the oldest.
inline constexpr std::int32_t kDefaultHistoryDepth = 10;

/// How long a reliable write may wait for history space before failing (keep-last writers
/// replace their oldest sample instead, so this bounds only transient resource waits).
inline constexpr dds_duration_t kMaxBlockingTime = DDS_MSECS(100);

/// The QoS of every topic, readers and writers alike: keep-last `depth`, volatile (a late
/// joiner sees no old updates or reports), reliable unless `best_effort` (ROS 2's sensor data
/// profile; a reliable reader does not match a best-effort writer).
struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;
QosPtr stream_qos(std::int32_t depth = kDefaultHistoryDepth, bool best_effort = false);

/// Our readers keep at least this many samples: on a keyless topic one history holds the samples
/// of every writer (every client of the prefix, every scene), and a reader's depth is local (not
/// part of QoS matching), so a deep one costs a peer nothing and keeps bursts from many clients.
inline constexpr std::int32_t kMinReaderHistoryDepth = 256;
QosPtr reader_qos(std::int32_t depth = kDefaultHistoryDepth, bool best_effort = false);

/// The full topic names for a prefix.
std::string pose_updates_topic(const std::string& prefix);
std::string distance_reports_topic(const std::string& prefix);
std::string threshold_events_topic(const std::string& prefix);
std::string pose_update_batches_topic(const std::string& prefix);
std::string distance_report_batches_topic(const std::string& prefix);

/// Empty when `prefix` makes legal topic names; otherwise what is wrong with it.
std::string check_topic_prefix(const std::string& prefix);

/// Empty when `name` is a legal full DDS topic name for a ROS 2 topic (rt/ followed by a ROS 2
/// name without its leading '/': tokens of letters, digits and '_' separated by '/', none
/// starting with a digit); otherwise what is wrong with it.
std::string check_ros_topic(const std::string& name);

/// The ROS 2 view of a DDS endpoint: topic "rt/a/b" is /a/b, type "pkg::msg::dds_::Name_" is
/// pkg/msg/Name; names not in that form are returned unchanged.
std::string ros_topic_name(const std::string& dds_topic);
std::string ros_type_name(const std::string& dds_type);

/// Without a configuration Cyclone DDS joins the machine's external interface and multicasts
/// discovery off the machine. Empty when CYCLONEDDS_URI is set (or `allow_default` says the
/// operator accepts Cyclone's defaults); otherwise the message to print and refuse with.
std::string check_configuration(bool allow_default);

/// "what: DDS_RETCODE_…" for a failed Cyclone call.
std::string describe(const char* what, dds_return_t code);

/// The 16 bytes of a GUID from `guid`, as 32 lowercase hex digits.
std::string guid_hex(const std::uint8_t* guid);

}  // namespace nearpoint::dds
