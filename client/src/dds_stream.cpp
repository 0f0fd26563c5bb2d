// SPDX-License-Identifier: Apache-2.0
#include "dds_stream.hpp"

#include <dds/ddsi/ddsi_serdata.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <map>
#include <ostream>
#include <vector>

#include <nlohmann/json.hpp>

#include "nearpoint/model/percentile.hpp"
#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::cli {
namespace {

using Json = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;
using model::percentile;

dds_duration_t to_dds(Clock::duration d) {
  return std::max<dds_duration_t>(0,
                                  std::chrono::duration_cast<std::chrono::nanoseconds>(d).count());
}

template <typename Xyz>  // geometry_msgs Point_ or Vector3_
Json vec(const Xyz& v) {
  return Json::array({v.x, v.y, v.z});
}

}  // namespace

// One schema for every report the CLI prints (client/schema/report.schema.json), the same keys as
// remote_common.cpp's to_json over gRPC: a change here needs the same change there and in the
// schema.
nlohmann::ordered_json report_json(const DistanceReportSample& report) {
  Json out;
  out["sequence"] = report.sequence_number;
  if (report.status != 0) {
    out["status"] = "error";
    out["error"] = {{"code", model::status_code_spelling(report.status)},
                    {"field", report.error_field ? report.error_field : ""},
                    {"message", report.message ? report.message : ""}};
    return out;
  }
  out["status"] = "ok";
  // A report's mode is never unspecified; 0 (an older server) means every pair.
  const std::string_view mode =
      model::spelling_of(model::from_dds<model::ReportMode>(report.report_mode));
  out["report_mode"] = mode.empty() ? model::spelling_of(model::ReportMode::all_pairs) : mode;
  Json pairs = Json::array();
  for (std::uint32_t i = 0; i < report.pairs._length; ++i) {
    const nearpoint_msgs_msg_dds__PairDistance_& p = report.pairs._buffer[i];
    Json pair;
    pair["object_a"] = p.object_a ? p.object_a : "";
    pair["object_b"] = p.object_b ? p.object_b : "";
    pair["status"] = model::spelling_of(model::from_dds<model::PairStatus>(p.status));
    pair["distance"] = p.distance;
    pair["distance_lower_bound"] = p.distance_lower_bound;
    pair["error_bound"] = p.error_bound;
    pair["iterations"] = p.iterations;
    pair["warm_started"] = p.warm_started;
    if (p.has_near_points) {
      pair["point_a"] = vec(p.point_a);
      pair["point_b"] = vec(p.point_b);
      pair["normal"] = vec(p.normal);
    }
    if (p.has_penetration_bound) pair["penetration_bound"] = p.penetration_bound;
    if (p.has_signed_distance) {
      pair["signed_distance"] = p.signed_distance;
      pair["signed_distance_lower"] = p.signed_distance_lower;
      pair["signed_distance_upper"] = p.signed_distance_upper;
    }
    if (p.has_penetration_depth) {
      pair["penetration_depth"] = p.penetration_depth;
      pair["penetration_depth_lower"] = p.penetration_depth_lower;
      pair["penetration_depth_upper"] = p.penetration_depth_upper;
      const auto& d = p.depth_direction;
      if (d.x != 0 || d.y != 0 || d.z != 0) {  // left out where undefined (see the schema)
        pair["depth_point_a"] = vec(p.depth_point_a);
        pair["depth_point_b"] = vec(p.depth_point_b);
        pair["depth_direction"] = vec(d);
      }
      pair["depth_termination"] =
          model::spelling_of(model::from_dds<model::DepthTermination>(p.depth_termination));
      pair["depth_iterations"] = p.depth_iterations;
    }
    if (p.message && *p.message) pair["message"] = p.message;
    pairs.push_back(std::move(pair));
  }
  out["pairs"] = std::move(pairs);
  Json events = Json::array();
  for (std::uint32_t i = 0; i < report.events._length; ++i) {
    const nearpoint_msgs_msg_dds__ThresholdEvent_& e = report.events._buffer[i];
    events.push_back(
        {{"threshold", e.threshold ? e.threshold : ""},
         {"threshold_index", e.threshold_index},
         {"object_a", e.object_a ? e.object_a : ""},
         {"object_b", e.object_b ? e.object_b : ""},
         {"crossing", model::spelling_of(model::from_dds<model::Crossing>(e.crossing))},
         {"distance", e.distance},
         {"sequence", e.sequence_number}});
  }
  out["events"] = std::move(events);
  out["coalesced_updates"] = report.coalesced_updates;
  out["coalesced_from_sequence"] =
      report.coalesced_updates > 0 ? report.coalesced_from_sequence : std::uint64_t(0);
  out["counts"] = {{"pairs_evaluated", report.counts.pairs_evaluated},
                   {"pairs_pruned", report.counts.pairs_pruned},
                   {"pairs_unmoved", report.counts.pairs_unmoved}};
  out["server_us"] = report.timing.server_us;
  out["queue_us"] = report.timing.queue_us;
  out["evaluation_us"] = report.timing.evaluation_us;
  out["geometry_us"] = report.timing.geometry_us;
  return out;
}

// ---- DdsPoseClient ----

std::unique_ptr<DdsPoseClient> DdsPoseClient::create(const Config& config, std::string& error) {
  if (error = dds::check_configuration(config.allow_default_config); !error.empty()) return nullptr;
  if (std::string problem = dds::check_topic_prefix(config.topic_prefix); !problem.empty()) {
    error = "--dds-prefix '" + config.topic_prefix + "' " + problem;
    return nullptr;
  }
  std::unique_ptr<DdsPoseClient> self(new DdsPoseClient());
  auto fail = [&](const char* what, dds_return_t code) {
    error = dds::describe(what, code) + " (domain " + std::to_string(config.domain_id) +
            "; is CYCLONEDDS_URI a readable, valid Cyclone DDS configuration?)";
    return nullptr;
  };
  self->participant_ = dds_create_participant(config.domain_id, nullptr, nullptr);
  if (self->participant_ < 0) {
    const dds_return_t code = self->participant_;
    self->participant_ = 0;
    return fail("dds_create_participant", code);
  }
  const dds::QosPtr qos = dds::stream_qos(config.history_depth, config.best_effort);
  const dds::QosPtr read_qos = dds::reader_qos(config.history_depth, config.best_effort);
  self->batched_ = config.batched;
  const std::string update_topic_name = config.batched
                                            ? dds::pose_update_batches_topic(config.topic_prefix)
                                            : dds::pose_updates_topic(config.topic_prefix);
  const std::string report_topic_name =
      config.batched ? dds::distance_report_batches_topic(config.topic_prefix)
                     : dds::distance_reports_topic(config.topic_prefix);
  const dds_entity_t update_topic =
      dds_create_topic(self->participant_,
                       config.batched ? &nearpoint_msgs_msg_dds__PoseUpdateBatch__desc
                                      : &nearpoint_msgs_msg_dds__PoseUpdate__desc,
                       update_topic_name.c_str(), qos.get(), nullptr);
  if (update_topic < 0) return fail("dds_create_topic(updates)", update_topic);
  const dds_entity_t report_topic =
      dds_create_topic(self->participant_,
                       config.batched ? &nearpoint_msgs_msg_dds__DistanceReportBatch__desc
                                      : &nearpoint_msgs_msg_dds__DistanceReport__desc,
                       report_topic_name.c_str(), qos.get(), nullptr);
  if (report_topic < 0) return fail("dds_create_topic(reports)", report_topic);
  self->writer_ = dds_create_writer(self->participant_, update_topic, qos.get(), nullptr);
  if (self->writer_ < 0) return fail("dds_create_writer", self->writer_);
  self->reader_ = dds_create_reader(self->participant_, report_topic, read_qos.get(), nullptr);
  if (self->reader_ < 0) return fail("dds_create_reader", self->reader_);
  dds_guid_t guid;
  if (const dds_return_t rc = dds_get_guid(self->writer_, &guid); rc < 0)
    return fail("dds_get_guid", rc);
  std::memcpy(self->writer_guid_.data(), guid.v, self->writer_guid_.size());
  self->waitset_ = dds_create_waitset(self->participant_);
  if (self->waitset_ < 0) return fail("dds_create_waitset", self->waitset_);
  if (const dds_return_t rc = dds_waitset_attach(self->waitset_, self->reader_, 0); rc < 0)
    return fail("dds_waitset_attach(reader)", rc);
  if (const dds_return_t rc = dds_waitset_attach(self->waitset_, self->writer_, 0); rc < 0)
    return fail("dds_waitset_attach(writer)", rc);
  return self;
}

DdsPoseClient::~DdsPoseClient() {
  if (participant_ > 0) dds_delete(participant_);
}

bool DdsPoseClient::wait_matched(std::chrono::milliseconds timeout, std::string& error) {
  dds_set_status_mask(writer_, DDS_PUBLICATION_MATCHED_STATUS);
  dds_set_status_mask(reader_, DDS_SUBSCRIPTION_MATCHED_STATUS);
  const Clock::time_point deadline = Clock::now() + timeout;
  bool matched = false;
  for (;;) {
    dds_publication_matched_status_t publication{};
    dds_subscription_matched_status_t subscription{};
    dds_get_publication_matched_status(writer_, &publication);  // also resets the status
    dds_get_subscription_matched_status(reader_, &subscription);
    matched = publication.current_count > 0 && subscription.current_count > 0;
    const Clock::time_point now = Clock::now();
    if (matched || now >= deadline) break;
    dds_waitset_wait(waitset_, nullptr, 0, to_dds(deadline - now));
  }
  dds_set_status_mask(writer_, 0);
  dds_set_status_mask(reader_, DDS_DATA_AVAILABLE_STATUS);
  if (!matched)
    error = "no nearpointd matched on the DDS topics within " + std::to_string(timeout.count()) +
            " ms (is it running with --dds on the same domain and prefix, and CYCLONEDDS_URI "
            "the same configuration?)";
  return matched;
}

bool DdsPoseClient::publish(const PoseUpdateSample& update, std::string& error) {
  if (batched_) {
    error = "a batched client publishes PoseUpdateBatch samples (publish_batch)";
    return false;
  }
  if (const dds_return_t rc = dds_write(writer_, &update); rc < 0) {
    error = dds::describe("dds_write", rc);
    return false;
  }
  return true;
}

bool DdsPoseClient::publish_batch(const PoseUpdateBatchSample& batch, std::string& error) {
  if (!batched_) {
    error = "an unbatched client publishes PoseUpdate samples (publish)";
    return false;
  }
  if (const dds_return_t rc = dds_write(writer_, &batch); rc < 0) {
    error = dds::describe("dds_write", rc);
    return false;
  }
  return true;
}

int DdsPoseClient::take_reports(std::chrono::milliseconds timeout,
                                const std::function<void(const DistanceReportSample&)>& on_report,
                                std::string& error) {
  return take(timeout, /*own_only=*/true, on_report, error);
}

int DdsPoseClient::take_any_reports(
    std::chrono::milliseconds timeout,
    const std::function<void(const DistanceReportSample&)>& on_report, std::string& error) {
  return take(timeout, /*own_only=*/false, on_report, error);
}

int DdsPoseClient::take(std::chrono::milliseconds timeout, bool own_only,
                        const std::function<void(const DistanceReportSample&)>& on_report,
                        std::string& error) {
  return take_until_delivered(
      timeout,
      [&](bool& full, std::string& round_error) {
        constexpr std::size_t kBatch = 32;
        std::array<void*, kBatch> samples{};
        std::array<dds_sample_info_t, kBatch> infos{};
        const dds_return_t taken = dds_take(reader_, samples.data(), infos.data(), kBatch, kBatch);
        if (taken < 0) {
          round_error = dds::describe("dds_take", taken);
          return -1;
        }
        int delivered = 0;
        for (dds_return_t i = 0; i < taken; ++i) {
          if (!infos[std::size_t(i)].valid_data) continue;
          // One report, or a batch of them: each in turn.
          const DistanceReportSample* reports =
              static_cast<const DistanceReportSample*>(samples[std::size_t(i)]);
          std::uint32_t count = 1;
          if (batched_) {
            const auto& batch = *static_cast<const nearpoint_msgs_msg_dds__DistanceReportBatch_*>(
                samples[std::size_t(i)]);
            reports = batch.reports._buffer;
            count = batch.reports._length;
          }
          bool ours = false;
          for (std::uint32_t k = 0; k < count; ++k) {
            const DistanceReportSample& report = reports[k];
            // Reports for other clients of the same scene share the topic.
            if (own_only &&
                std::memcmp(report.writer_guid, writer_guid_.data(), writer_guid_.size()) != 0)
              continue;
            on_report(report);
            ++delivered;
            ours = true;
          }
          if (ours) ++report_samples_;
        }
        if (taken > 0) dds_return_loan(reader_, samples.data(), taken);
        full = taken == dds_return_t(kBatch);
        return delivered;
      },
      error);
}

int DdsPoseClient::take_report_views(std::chrono::milliseconds timeout,
                                     const std::function<void(const ReportView&)>& on_report,
                                     std::string& error) {
  return take_until_delivered(
      timeout,
      [&](bool& full, std::string& round_error) {
        constexpr std::uint32_t kBatch = 32;
        std::array<ddsi_serdata*, kBatch> samples{};
        std::array<dds_sample_info_t, kBatch> infos{};
        const dds_return_t taken =
            dds_takecdr(reader_, samples.data(), kBatch, infos.data(), DDS_ANY_STATE);
        if (taken < 0) {
          round_error = dds::describe("dds_takecdr", taken);
          return -1;
        }
        int delivered = 0;
        bool malformed = false;
        for (dds_return_t i = 0; i < taken; ++i) {
          ddsi_serdata* sample = samples[std::size_t(i)];
          if (infos[std::size_t(i)].valid_data && !malformed) {
            // The bytes as received (Cyclone has validated them and put them in host order).
            const std::uint32_t size = ddsi_serdata_size(sample);
            ddsrt_iovec_t bytes;
            ddsi_serdata* const ref = ddsi_serdata_to_ser_ref(sample, 0, size, &bytes);
            bool ours = false;
            malformed = !read_report_views(
                static_cast<const std::uint8_t*>(bytes.iov_base), bytes.iov_len, batched_,
                [&](const ReportView& report) {
                  // Reports for other clients of the same scene share the topic.
                  if (report.writer_guid != writer_guid_) return;
                  on_report(report);
                  ++delivered;
                  ours = true;
                },
                round_error);
            ddsi_serdata_to_ser_unref(ref, &bytes);
            if (ours) ++report_samples_;
          }
          ddsi_serdata_unref(sample);
        }
        full = taken == dds_return_t(kBatch);
        return malformed ? -1 : delivered;
      },
      error);
}

int DdsPoseClient::take_until_delivered(
    std::chrono::milliseconds timeout,
    const std::function<int(bool& full, std::string& error)>& round, std::string& error) {
  const Clock::time_point deadline = Clock::now() + timeout;
  int delivered = 0;
  for (;;) {
    bool full = false;
    const int got = round(full, error);
    if (got < 0) return -1;
    delivered += got;
    if (full) continue;  // more may be waiting
    if (delivered > 0) return delivered;
    const Clock::time_point now = Clock::now();
    if (now >= deadline) return 0;
    const dds_return_t woken = dds_waitset_wait(waitset_, nullptr, 0, to_dds(deadline - now));
    if (woken < 0) {
      error = dds::describe("dds_waitset_wait", woken);
      return -1;
    }
  }
}

// ---- StepPublisher ----

StepPublisher::StepPublisher(const Trajectory& trajectory, const DdsStreamOptions& options)
    : trajectory_(trajectory),
      options_(options),
      client_id_(options.client_id.empty() ? "nearpoint-cli-" + std::to_string(getpid())
                                           : options.client_id) {
  for (const model::ThresholdInput& t : options.thresholds)
    thresholds_.push_back({const_cast<char*>(t.name.c_str()), t.distance, t.hysteresis,
                           const_cast<char*>(t.object_a.c_str()),
                           const_cast<char*>(t.object_b.c_str()), t.groups});
}

PoseUpdateSample StepPublisher::sample(std::uint64_t index) {
  return fill(index, poses_);
}

PoseUpdateBatchSample StepPublisher::batch(std::uint64_t first, std::size_t count) {
  if (batch_poses_.size() < count) batch_poses_.resize(count);
  batch_updates_.resize(count);
  for (std::size_t k = 0; k < count; ++k) batch_updates_[k] = fill(first + k, batch_poses_[k]);
  PoseUpdateBatchSample out{};
  out.updates._buffer = batch_updates_.data();
  out.updates._length = out.updates._maximum = std::uint32_t(count);
  out.updates._release = false;
  return out;
}

PoseUpdateSample StepPublisher::fill(std::uint64_t index,
                                     std::vector<nearpoint_msgs_msg_dds__ObjectPose_>& poses) {
  const TrajectoryStep& step = trajectory_.steps[index % trajectory_.steps.size()];
  poses.assign(step.poses.size(), {});
  for (std::size_t i = 0; i < step.poses.size(); ++i) {
    const ObjectPose& in = step.poses[i];
    nearpoint_msgs_msg_dds__ObjectPose_& pose = poses[i];
    pose.object_id = const_cast<char*>(in.object_id.c_str());
    pose.pose.position = {in.translation[0], in.translation[1], in.translation[2]};
    pose.pose.orientation = {in.rotation_wxyz[1], in.rotation_wxyz[2], in.rotation_wxyz[3],
                             in.rotation_wxyz[0]};
  }
  PoseUpdateSample update{};
  update.scene_id = const_cast<char*>(options_.scene_id.c_str());
  update.client_id = const_cast<char*>(client_id_.c_str());
  update.sequence_number = index + 1;
  update.poses._buffer = poses.data();
  update.poses._length = update.poses._maximum = std::uint32_t(poses.size());
  update.poses._release = false;
  if (options_.near_points) {
    update.options.has_near_points = true;
    update.options.near_points = true;
  }
  update.options.penetration = model::to_dds(options_.penetration);
  update.options.report_mode = model::to_dds(options_.report_mode);
  if (!std::isnan(options_.cutoff)) {
    update.options.has_distance_cutoff = true;
    update.options.distance_cutoff = options_.cutoff;
  }
  if (!std::isnan(options_.change_tolerance)) {
    update.options.has_change_tolerance = true;
    update.options.change_tolerance = options_.change_tolerance;
  }
  if (index == 0) {
    update.thresholds._buffer = thresholds_.data();
    update.thresholds._length = update.thresholds._maximum = std::uint32_t(thresholds_.size());
  }
  update.thresholds._release = false;
  update.flow_control = options_.flow_control == model::FlowControl::coalesce
                            ? model::to_dds(model::FlowControl::coalesce)
                            : 0;  // unspecified: block
  return update;
}

bool publish_steps(DdsPoseClient& client, StepPublisher& publisher, std::uint64_t next,
                   std::size_t count, bool batched,
                   std::map<std::uint64_t, std::chrono::steady_clock::time_point>& published,
                   std::string& error) {
  const Clock::time_point now = Clock::now();
  if (!batched) {
    const PoseUpdateSample update = publisher.sample(next);
    published.emplace(update.sequence_number, now);
    return client.publish(update, error);
  }
  const PoseUpdateBatchSample batch = publisher.batch(next, count);
  for (std::uint32_t k = 0; k < batch.updates._length; ++k)
    published.emplace(batch.updates._buffer[k].sequence_number, now);
  return client.publish_batch(batch, error);
}

// ---- nearpoint stream --dds: parse → run → print ----

namespace {

constexpr const char* kPrefix = "nearpoint stream --dds: ";

/// The updates in flight and what their reports showed: every report is checked against them
/// (answers only what is awaited, in order, merged updates accounted for) and printed as a line.
struct ReportCheck {
  /// Sent and not yet answered, in sequence order, with the time each was published.
  std::map<std::uint64_t, Clock::time_point> outstanding;
  std::vector<double> round_trips_us;
  std::uint64_t last_ok_sequence = 0;
  std::size_t reports = 0, rejected = 0, coalesced = 0, problems = 0;

  void take(const DistanceReportSample& report, const Trajectory& trajectory, std::ostream& out,
            std::ostream& err) {
    const std::uint64_t sequence = report.sequence_number;
    Json line = report_json(report);
    // The step's trajectory time, as `nearpoint stream --json` prints it over gRPC.
    if (sequence >= 1 && sequence <= trajectory.steps.size())
      line["t"] = trajectory.steps[sequence - 1].time;
    const auto found = outstanding.find(sequence);
    if (found == outstanding.end()) {
      err << kPrefix << "report for sequence " << sequence
          << ", which is not awaiting an answer (a duplicate, or never sent)\n";
      ++problems;
    } else {
      const double us =
          std::chrono::duration<double, std::micro>(Clock::now() - found->second).count();
      if (report.status != 0) {
        ++rejected;  // error reports may overtake earlier updates still being evaluated
        outstanding.erase(found);
      } else {
        line["round_trip_us"] = us;  // ok reports only, as over gRPC
        round_trips_us.push_back(us);
        answered(report, sequence, err);
      }
    }
    ++reports;
    out << line.dump() << '\n';
  }

 private:
  /// A report of `sequence`, which answers every earlier update still outstanding: those must
  /// have been merged into it.
  void answered(const DistanceReportSample& report, std::uint64_t sequence, std::ostream& err) {
    if (sequence <= last_ok_sequence) {
      err << kPrefix << "report " << sequence << " arrived after report " << last_ok_sequence
          << " (out of order)\n";
      ++problems;
    }
    last_ok_sequence = std::max(last_ok_sequence, sequence);
    const std::uint64_t merged_from =
        report.coalesced_updates > 0 ? report.coalesced_from_sequence : sequence;
    for (auto it = outstanding.begin(); it != outstanding.end() && it->first < sequence;) {
      if (it->first >= merged_from) {
        ++coalesced;
      } else {
        err << kPrefix << "no report for sequence " << it->first << " before report " << sequence
            << " (missing)\n";
        ++problems;
      }
      it = outstanding.erase(it);
    }
    outstanding.erase(sequence);
  }
};

}  // namespace

int run_dds_stream(const Trajectory& trajectory, const DdsStreamOptions& options, std::ostream& out,
                   std::ostream& err) {
  if (options.scene_id.empty()) {
    err << kPrefix << "--scene is required (the scene id on the server)\n";
    return kStreamBadConfiguration;
  }
  std::string error;
  // A missing DDS configuration is the user's to fix (exit 2); the failures below may pass.
  if (error = dds::check_configuration(options.dds.allow_default_config); !error.empty()) {
    err << kPrefix << error << '\n';
    return kStreamBadConfiguration;
  }
  const std::size_t batch = std::max<std::size_t>(1, options.batch);
  if (batch > dds::kMaxUpdatesPerBatch) {
    err << kPrefix << "--batch is at most " << dds::kMaxUpdatesPerBatch << '\n';
    return kStreamBadConfiguration;
  }
  DdsPoseClient::Config config = options.dds;
  config.batched = batch > 1;
  std::unique_ptr<DdsPoseClient> client = DdsPoseClient::create(config, error);
  if (!client) {
    err << kPrefix << error << '\n';
    return kStreamCannotRun;
  }
  if (!client->wait_matched(options.match_timeout, error)) {
    err << kPrefix << error << '\n';
    return kStreamCannotRun;
  }
  const std::size_t window = std::max(batch, options.window);
  const std::size_t total = trajectory.steps.size();

  // Run: publish up to `window` steps ahead of the reports, check each report as it arrives.
  StepPublisher publisher(trajectory, options);
  ReportCheck check;
  auto on_report = [&](const DistanceReportSample& report) {
    check.take(report, trajectory, out, err);
  };
  std::uint64_t next = 0;  // index of the next step to publish
  while (next < total || !check.outstanding.empty()) {
    // A whole batch at a time (the last one may be shorter), within the window.
    while (next < total && check.outstanding.size() + std::min(batch, total - next) <= window) {
      const std::size_t count = std::min(batch, total - next);
      if (!publish_steps(*client, publisher, next, count, config.batched, check.outstanding,
                         error)) {
        err << kPrefix << error << '\n';
        return kStreamCannotRun;
      }
      next += count;
    }
    const int got = client->take_reports(options.report_timeout, on_report, error);
    if (got < 0) {
      err << kPrefix << error << '\n';
      return kStreamCannotRun;
    }
    if (got == 0) {
      err << kPrefix << "no report within " << options.report_timeout.count()
          << " ms; unanswered sequence numbers:";
      for (const auto& [sequence, sent] : check.outstanding) err << ' ' << sequence;
      err << '\n';
      check.problems += check.outstanding.size();
      break;
    }
  }

  // Print: the totals.
  out.flush();
  err << kPrefix << total << " updates, " << check.reports << " reports (" << check.rejected
      << " rejected, " << check.coalesced << " merged into later reports), " << check.problems
      << " problems; round trip p50 " << percentile(check.round_trips_us, 0.5) << " us, p99 "
      << percentile(check.round_trips_us, 0.99) << " us\n";
  return check.problems == 0 && check.rejected == 0 ? kStreamOk : kStreamIncomplete;
}

}  // namespace nearpoint::cli
