// SPDX-License-Identifier: Apache-2.0
// `nearpoint stream --dds`: replays a trajectory to nearpointd's DDS bridge and checks every
// report. Also the DDS client the tests and the benchmark use (DdsPoseClient).
//
// The client publishes nearpoint_msgs::msg::dds_::PoseUpdate_ on <prefix>pose_updates and takes
// nearpoint_msgs::msg::dds_::DistanceReport_ from <prefix>distance_reports, keeping only the
// reports addressed to its own writer (DistanceReport_.writer_guid), with the QoS of
// proto/dds/nearpoint_dds.hpp; batched (--batch N), PoseUpdateBatch_ on
// <prefix>pose_update_batches and DistanceReportBatch_ from <prefix>distance_report_batches
// instead. Like the server it refuses to start without CYCLONEDDS_URI.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dds_report_view.hpp"
#include "nearpoint/model/exit_codes.hpp"
#include "nearpoint/model/scene_types.hpp"
#include "nearpoint_dds.hpp"
#include "trajectory.hpp"

namespace nearpoint::cli {

using PoseUpdateSample = nearpoint_msgs_msg_dds__PoseUpdate_;
using DistanceReportSample = nearpoint_msgs_msg_dds__DistanceReport_;
using PoseUpdateBatchSample = nearpoint_msgs_msg_dds__PoseUpdateBatch_;

/// A PoseUpdate_ writer and a DistanceReport_ reader on one participant, or with
/// Config::batched a PoseUpdateBatch_ writer and a DistanceReportBatch_ reader.
class DdsPoseClient {
 public:
  struct Config {
    std::uint32_t domain_id = 0;
    std::string topic_prefix = dds::kDefaultTopicPrefix;
    /// Keep-last depth of the writer (the reader keeps at least dds::kMinReaderHistoryDepth), and
    /// best-effort instead of reliable: as nearpointd's --dds-history-depth, --dds-best-effort.
    std::int32_t history_depth = dds::kDefaultHistoryDepth;
    bool best_effort = false;
    /// Start without CYCLONEDDS_URI (Cyclone's defaults: external interface, multicast).
    bool allow_default_config = false;
    /// The batch topics: publish_batch() instead of publish(), reports taken out of
    /// DistanceReportBatch_ samples.
    bool batched = false;
  };

  /// The endpoints, or nullptr and `error` saying why not.
  static std::unique_ptr<DdsPoseClient> create(const Config& config, std::string& error);
  ~DdsPoseClient();
  DdsPoseClient(const DdsPoseClient&) = delete;
  DdsPoseClient& operator=(const DdsPoseClient&) = delete;

  /// Waits until the writer has matched a reader and the reader a writer on the two topics (the
  /// server's), so that no early (volatile) update or report is lost. False on timeout.
  bool wait_matched(std::chrono::milliseconds timeout, std::string& error);

  bool publish(const PoseUpdateSample& update, std::string& error);
  /// Batched clients only.
  bool publish_batch(const PoseUpdateBatchSample& batch, std::string& error);

  /// Waits up to `timeout` for reports addressed to this client's writer and passes each to
  /// `on_report` (the sample is valid during the call only). Returns how many were passed (0 on
  /// timeout), or -1 and `error` when DDS fails.
  int take_reports(std::chrono::milliseconds timeout,
                   const std::function<void(const DistanceReportSample&)>& on_report,
                   std::string& error);

  /// As take_reports, for every report on the topic (any client's): `nearpoint dds echo`.
  int take_any_reports(std::chrono::milliseconds timeout,
                       const std::function<void(const DistanceReportSample&)>& on_report,
                       std::string& error);

  /// As take_reports, with each report read from its serialised bytes into a ReportView (its
  /// pairs walked, not decoded): what a load needs, at a fraction of the decoding's cost.
  /// -1 and `error` also for a sample that is no well-formed report.
  int take_report_views(std::chrono::milliseconds timeout,
                        const std::function<void(const ReportView&)>& on_report,
                        std::string& error);

  /// This client's writer GUID, as the server echoes it in DistanceReport_.writer_guid.
  const std::array<std::uint8_t, 16>& writer_guid() const { return writer_guid_; }

  /// Report samples taken so far that held at least one report for this client (batched: one
  /// DistanceReportBatch_ may hold several).
  std::uint64_t report_samples() const { return report_samples_; }

 private:
  DdsPoseClient() = default;
  int take(std::chrono::milliseconds timeout, bool own_only,
           const std::function<void(const DistanceReportSample&)>& on_report, std::string& error);
  // Calls `round` (reports delivered, or -1; `full` when it took as many samples as it could
  // and more may wait) until it delivers one, waiting on the waitset in between, up to
  // `timeout`. Returns what the rounds delivered (0 on timeout), or -1.
  int take_until_delivered(std::chrono::milliseconds timeout,
                           const std::function<int(bool& full, std::string& error)>& round,
                           std::string& error);
  dds_entity_t participant_ = 0;
  dds_entity_t writer_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t waitset_ = 0;
  bool batched_ = false;
  std::uint64_t report_samples_ = 0;
  std::array<std::uint8_t, 16> writer_guid_{};
};

struct DdsStreamOptions {
  DdsPoseClient::Config dds;
  std::string scene_id;
  /// Echoed in the reports (empty: "nearpoint-cli-<pid>").
  std::string client_id;
  /// Updates published before their reports arrive; 1 = lock step (each update waits for its
  /// report, so round-trip times are meaningful).
  std::size_t window = 1;
  /// Consecutive updates per sample (more than 1: the batch topics, dds.batched). The window
  /// counts updates and is at least one batch.
  std::size_t batch = 1;
  /// PoseUpdate_.flow_control: block (sent as 0, unspecified, which means block) or coalesce.
  model::FlowControl flow_control = model::FlowControl::block;
  bool near_points = false;
  /// QueryOptions_.penetration (unspecified: inherit).
  model::PenetrationMode penetration = model::PenetrationMode::unspecified;
  /// QueryOptions_.report_mode (unspecified: inherit), distance_cutoff and change_tolerance
  /// (NaN: not sent, inherit).
  model::ReportMode report_mode = model::ReportMode::unspecified;
  double cutoff = std::numeric_limits<double>::quiet_NaN();
  double change_tolerance = std::numeric_limits<double>::quiet_NaN();
  /// Sent with the first update (PoseUpdate_.thresholds).
  std::vector<model::ThresholdInput> thresholds;
  std::chrono::milliseconds match_timeout{10000};
  /// How long to wait for the next report before giving up on the missing ones.
  std::chrono::milliseconds report_timeout{10000};
};

/// Builds each step's PoseUpdate_ from a trajectory and the stream's options (`nearpoint stream
/// --dds`, `nearpoint dds load`). The sample borrows the publisher's buffers: valid until the next
/// call.
class StepPublisher {
 public:
  StepPublisher(const Trajectory& trajectory, const DdsStreamOptions& options);
  /// The update of step `index` modulo the trajectory's length, so that a load replays it in a
  /// loop (sequence number index + 1; the thresholds with index 0). The trajectory is not empty.
  PoseUpdateSample sample(std::uint64_t index);
  /// The updates of steps first … first + count − 1 as one PoseUpdateBatch_ sample (each as
  /// sample() makes it); valid until the next call.
  PoseUpdateBatchSample batch(std::uint64_t first, std::size_t count);

 private:
  PoseUpdateSample fill(std::uint64_t index,
                        std::vector<nearpoint_msgs_msg_dds__ObjectPose_>& poses);
  const Trajectory& trajectory_;
  const DdsStreamOptions& options_;
  const std::string client_id_;
  std::vector<nearpoint_msgs_msg_dds__ObjectPose_> poses_;
  std::vector<nearpoint_msgs_msg_dds__Threshold_> thresholds_;
  std::vector<std::vector<nearpoint_msgs_msg_dds__ObjectPose_>> batch_poses_;
  std::vector<PoseUpdateSample> batch_updates_;
};

/// Publishes the steps next … next + count − 1 (count ≥ 1): one PoseUpdate_ sample, or with a
/// batched client one PoseUpdateBatch_; false and `error` when DDS refuses. Each step's
/// sequence number and publication time go into `published` (sequence → time).
bool publish_steps(DdsPoseClient& client, StepPublisher& publisher, std::uint64_t next,
                   std::size_t count, bool batched,
                   std::map<std::uint64_t, std::chrono::steady_clock::time_point>& published,
                   std::string& error);

/// Exit codes of `nearpoint stream --dds` (the table of model/exit_codes.hpp).
inline constexpr int kStreamOk =
    model::kExitOk;  ///< every update answered, in order, none rejected
inline constexpr int kStreamIncomplete = model::kExitFailure;      ///< rejected updates, or reports
                                                                   ///< missing or out of order
inline constexpr int kStreamBadConfiguration = model::kExitUsage;  ///< no scene id, no DDS config
inline constexpr int kStreamCannotRun = model::kExitUnavailable;  ///< no server matched, DDS failed

/// A report as one JSON object in the CLI's report schema (client/schema/report.schema.json).
nlohmann::ordered_json report_json(const DistanceReportSample& report);

/// Publishes one PoseUpdate_ per trajectory step (sequence numbers 1, 2, …) and writes one JSON
/// line per report to `out`, in the schema of every report the CLI prints, over gRPC as well
/// (client/schema/report.schema.json): "sequence", "status" ("ok" or "error"), then either the
/// pairs (each with distance, distance_lower_bound and error_bound), events, coalescing, counts
/// and server timings (*_us), or "error": {"code", "field", "message"}; plus the step's "t" and,
/// for ok reports, "round_trip_us".
/// Checks that every update is answered exactly once — by its report, an error report, or as
/// merged into a later report (coalesced_from_sequence) — and that reports come in sequence
/// order; problems and a summary go to `err`.
int run_dds_stream(const Trajectory& trajectory, const DdsStreamOptions& options, std::ostream& out,
                   std::ostream& err);

}  // namespace nearpoint::cli
