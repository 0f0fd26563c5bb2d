// SPDX-License-Identifier: Apache-2.0
// The DDS bridge: nearpointd's second transport, a thin adapter over the scene API exactly as the
// gRPC service is. It reads nearpoint_msgs::msg::dds_::PoseUpdate_ samples on
// <prefix>pose_updates and answers each with a nearpoint_msgs::msg::dds_::DistanceReport_ on
// <prefix>distance_reports, and writes each threshold crossing on <prefix>threshold_events too
// (ROS 2 topics /nearpoint/...; names, types and QoS: proto/dds/nearpoint_dds.hpp).
//
// Batches. A client may instead publish nearpoint_msgs::msg::dds_::PoseUpdateBatch_ samples on
// <prefix>pose_update_batches, each carrying several consecutive updates, and read
// DistanceReportBatch_ samples on <prefix>distance_report_batches, so that it pays DDS's
// per-sample cost once per batch. Every update of a batch is accepted exactly as if it had been
// published alone, in the order listed (sequence numbers, error reports in their place, merging
// under overload counted in updates, thresholds); a batch of more than dds::kMaxUpdatesPerBatch
// updates is refused whole with one error report. A batch writer's stream holds its answers
// (reports and error reports, in order) and writes them together once it has nothing more to
// evaluate, 2 ms after the oldest was ready, or when they fill a sample
// (dds::kMaxReportsPerBatch, dds::kMaxReportBatchBytes).
//
// Streams. A stream is one DDS writer (its publication handle) publishing for one scene id:
// each such pair owns a PoseStream, so warm-start caches, sequence numbers and "objects not
// listed keep their previous pose" are per client and per scene — two robots sharing a scene
// never disturb each other's caches, and a client may stream to several scenes with one writer.
// A stream ends when its writer is no longer matched (deleted, or lost by liveliness); streams
// count against --max-streams like gRPC streams.
//
// Semantics, as on gRPC's StreamPoses: every accepted update yields exactly one report with its
// sequence number, in order per stream; a rejected update (unknown scene, NaN pose, bad option,
// sequence not increasing) yields a report with a non-zero status naming the field and the
// sequence number, and the stream goes on. A stream's reports, error reports included, are
// written in the order its updates were taken.
//
// Overload. DDS cannot hold a publisher back the way HTTP/2 flow control does (keep-last
// writers overwrite, they do not block), so a stream never queues more than --max-in-flight
// accepted updates: an update arriving when that many wait is merged with the newest waiting one
// (its poses already include the older one's), and its report says so (coalesced_updates,
// coalesced_from_sequence). With flow_control = 2 (coalesce) every update arriving while the
// stream is busy is merged. Nothing is dropped silently by the bridge.
//
// Threads. One bridge thread waits on a waitset (data available, writers matched/unmatched,
// shutdown), takes samples, validates them (PoseStream::prepare: no geometry) and queues them.
// A stream's update whose evaluation is small (PoseStream::evaluates_inline: one task's worth of
// pairs) is evaluated on the bridge thread, which then writes its report, as the gRPC service
// evaluates on the thread that read the update: a worker's wake-up and the hand-back would cost
// more than the geometry. Between two such evaluations the bridge thread takes the samples that
// arrived meanwhile. Larger evaluations run on the SceneService's worker pool, whose thread
// writes the report; so do all with --no-inline-evaluation.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// A scene that takes sensor_msgs/JointState samples from a topic (--dds-joint-states; see
/// dds_joint_states.hpp).
struct JointStateBinding {
  std::string scene_id;
  /// The DDS topic (rt/ + the ROS 2 name).
  std::string topic = "rt/joint_states";
};

/// "SCENE" or "SCENE=TOPIC" (TOPIC as a ROS 2 name, /joint_states, or as the DDS topic,
/// rt/joint_states); INVALID_ARGUMENT naming `field` when the scene id or topic is not legal.
Expected<JointStateBinding> parse_joint_state_binding(const std::string& spec,
                                                      const std::string& field);

struct DdsConfig {
  /// DDS domain id (0–230 with Cyclone's default port mapping).
  std::uint32_t domain_id = 0;
  /// Topic names are prefix + "pose_updates", "distance_reports" and "threshold_events".
  std::string topic_prefix = "rt/nearpoint/";
  /// Keep-last depth of every reader and writer (ROS 2's default profile: 10). The topics are
  /// keyless, so it is shared by every client of a topic; the bridge thread takes updates as they
  /// arrive (between small evaluations at most), so it matters only if that thread is starved.
  std::int32_t history_depth = 10;
  /// Best-effort instead of reliable (ROS 2's sensor data profile): lost updates are not
  /// resent. A reliable ROS 2 reader does not match a best-effort writer.
  bool best_effort = false;
  /// Scenes fed by sensor_msgs/JointState topics, one topic each.
  std::vector<JointStateBinding> joint_states;
  /// Start even when CYCLONEDDS_URI is unset (Cyclone's defaults: the external interface and
  /// multicast). Off by default: see deploy/cyclonedds-loopback.xml.
  bool allow_default_config = false;
};

/// Counters for logs and tests.
struct DdsBridgeStats {
  std::uint64_t updates_taken = 0;
  std::uint64_t updates_rejected = 0;
  std::uint64_t updates_coalesced = 0;
  std::uint64_t reports_written = 0;
  std::uint64_t write_failures = 0;
  std::size_t open_streams = 0;
};

/// The configuration checks of DdsBridge::start, without starting anything: CYCLONEDDS_URI set
/// (or --dds-allow-default-config) and, when it names a file (file://PATH), that file readable;
/// the domain id and topic prefix valid. nearpointd runs them before any transport binds, so
/// that a bad DDS configuration stops it before it signals readiness.
Outcome check_dds_config(const DdsConfig& config);

class DdsBridge {
 public:
  /// Creates the participant, topics, reader and writer and starts the bridge thread, or says
  /// why it could not (no configuration, bad prefix, Cyclone refused).
  static Expected<std::unique_ptr<DdsBridge>> start(SceneService& scenes, const DdsConfig& config);
  /// Shuts down (see shutdown()).
  ~DdsBridge();
  DdsBridge(const DdsBridge&) = delete;
  DdsBridge& operator=(const DdsBridge&) = delete;

  /// Stops taking samples, answers every update already taken, then deletes the DDS entities.
  /// Idempotent.
  void shutdown();

  DdsBridgeStats stats() const;
  const DdsConfig& config() const;

 private:
  DdsBridge();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace nearpoint::server
