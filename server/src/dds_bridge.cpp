// SPDX-License-Identifier: Apache-2.0
#include "dds_bridge.hpp"

#include <algorithm>
#include <array>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string_view>
#include <thread>
#include <vector>

#include "dds_joint_states.hpp"
#include "dds_report_sertype.hpp"
#include "metrics.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/server/log.hpp"
#include "nearpoint_dds.hpp"
#include "validation.hpp"

namespace nearpoint::server {
namespace {

using UpdateSample = nearpoint_msgs_msg_dds__PoseUpdate_;
using ReportSample = nearpoint_msgs_msg_dds__DistanceReport_;
using UpdateBatchSample = nearpoint_msgs_msg_dds__PoseUpdateBatch_;
using ReportBatchSample = nearpoint_msgs_msg_dds__DistanceReportBatch_;
using PairSample = nearpoint_msgs_msg_dds__PairDistance_;
using EventSample = nearpoint_msgs_msg_dds__ThresholdEvent_;
using Guid = std::array<std::uint8_t, 16>;

/// The highest domain id Cyclone's default port mapping allows (7400 + 250·d + … < 65536).
constexpr std::uint32_t kMaxDomainId = 230;
/// A keep-last depth beyond this is a resource limit, not a history.
constexpr std::int32_t kMaxHistoryDepth = 100000;
/// Samples taken per dds_take call.
constexpr std::int32_t kTakeBatch = 32;
/// How long the bridge thread evaluates small updates (and takes the samples that arrive
/// meanwhile) before it turns to its other duties again: writers gone, streams whose reader wait
/// is over, shutdown. A steady stream of updates must not keep them waiting.
constexpr auto kInlineSlice = std::chrono::milliseconds(2);
/// How long a new stream's first evaluation waits for the report writer to discover a reader of
/// the client's participant (see StreamState::ready).
constexpr auto kReaderMatchWait = std::chrono::seconds(2);
/// How long a batched stream's ready report may wait for the stream's next ones before they are
/// written together: as long as one inline slice, so that a stream kept busy by a steady flow of
/// updates still sees its reports every few milliseconds.
constexpr auto kReportHold = kInlineSlice;

/// Cyclone serialises strings through char*; the sample only borrows ours for dds_write.
char* borrow(const std::string& text) {
  return const_cast<char*>(text.c_str());
}
char* borrow(const char* text) {
  static char empty[] = "";
  return text ? const_cast<char*>(text) : empty;
}
std::string own(const char* text) {
  return text ? std::string(text) : std::string();
}

geometry_msgs_msg_dds__Vector3_ to_vector(const model::Vec3d& v) {
  return {v.x(), v.y(), v.z()};
}

geometry_msgs_msg_dds__Point_ to_point(const model::Vec3d& v) {
  return {v.x(), v.y(), v.z()};
}

nearpoint_msgs_msg_dds__PoseGradient_ to_sample(const Eigen::Matrix<double, 6, 1>& gradient) {
  return {to_vector(model::Vec3d(gradient.head<3>())), to_vector(model::Vec3d(gradient.tail<3>()))};
}

/// An update's std_msgs/Header, echoed in its report and events (not interpreted).
struct Header {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  std::string frame_id;
};

Header own(const std_msgs_msg_dds__Header_& header) {
  return {header.stamp.sec, header.stamp.nanosec, own(header.frame_id)};
}

std_msgs_msg_dds__Header_ borrow(const Header& header) {
  return {{header.sec, header.nanosec}, borrow(header.frame_id)};
}

/// The sample as the scene API's input, written over `out` (the bridge thread reuses one, so
/// that its strings and vectors keep their capacity from update to update). Mechanical, like
/// proto_convert: the scene API validates, so both transports reject the same inputs with the
/// same messages.
void to_input(const UpdateSample& sample, model::PoseUpdateInput& out) {
  out.scene_id.assign(borrow(sample.scene_id));
  out.sequence = sample.sequence_number;
  out.poses.resize(sample.poses._length);
  for (std::uint32_t i = 0; i < sample.poses._length; ++i) {
    const nearpoint_msgs_msg_dds__ObjectPose_& in = sample.poses._buffer[i];
    model::ObjectPoseInput& pose = out.poses[i];
    pose.object_id.assign(borrow(in.object_id));
    const geometry_msgs_msg_dds__Quaternion_& q = in.pose.orientation;
    pose.pose.rotation_wxyz = {q.w, q.x, q.y, q.z};
    const geometry_msgs_msg_dds__Point_& t = in.pose.position;
    pose.pose.translation = model::Vec3d(t.x, t.y, t.z);
  }
  const nearpoint_msgs_msg_dds__QueryOptions_& options = sample.options;
  out.options = {};
  out.thresholds.clear();
  out.joints = {};
  if (options.has_epsilon) out.options.epsilon = options.epsilon;
  if (options.has_near_points) out.options.near_points = options.near_points;
  out.options.penetration = model::from_dds<model::PenetrationMode>(options.penetration);
  if (options.has_gradient) out.options.gradient = options.gradient;
  if (options.has_distance_cutoff) out.options.distance_cutoff = options.distance_cutoff;
  if (options.has_warm_start) out.options.warm_start = options.warm_start;
  if (options.has_max_iterations) out.options.max_iterations = options.max_iterations;
  out.options.report_mode = model::from_dds<model::ReportMode>(options.report_mode);
  if (options.has_change_tolerance) out.options.change_tolerance = options.change_tolerance;
  out.flow_control = model::from_dds<model::FlowControl>(sample.flow_control);
  out.thresholds.reserve(sample.thresholds._length);
  for (std::uint32_t i = 0; i < sample.thresholds._length; ++i) {
    const nearpoint_msgs_msg_dds__Threshold_& in = sample.thresholds._buffer[i];
    out.thresholds.push_back(model::ThresholdInput{own(in.name), in.distance, in.hysteresis,
                                                   own(in.object_a), own(in.object_b), in.groups});
  }
}

/// Who a report goes to: the update's scene, its client id and writer (and its header, echoed),
/// and whether that writer publishes batches (then its reports go on the batch report topic).
struct Addressee {
  std::string scene_id;
  std::string client_id;
  Guid writer_guid{};
  Header header;
  bool batched = false;
};

void address(const Addressee& to, ReportSample& out) {
  out.header = borrow(to.header);
  out.scene_id = borrow(to.scene_id);
  out.client_id = borrow(to.client_id);
  std::memcpy(out.writer_guid, to.writer_guid.data(), sizeof out.writer_guid);
}

/// An error report that is written once the bridge's lock is released.
struct PendingError {
  Addressee to;
  std::uint64_t sequence = 0;
  Error error;
};

struct StreamKey {
  dds_instance_handle_t publication = 0;
  std::string scene_id;
  auto operator<=>(const StreamKey&) const = default;
};

/// What a stream answers next, in arrival order: an accepted update waiting for its evaluation,
/// or the error report of a rejected one.
struct Waiting {
  PreparedUpdate update;
  std::string client_id;
  Header header;
  std::optional<PendingError> error;
};

/// A batched stream's answer that waits to be written with the stream's next ones: an
/// evaluation's report (with its update's client id and header) or an error report.
struct HeldReport {
  std::optional<Report> report;
  Addressee to;
  std::optional<PendingError> error;
  /// About its size in a DistanceReportBatch_ (estimated_bytes).
  std::size_t bytes = 0;
};

/// About the XCDR1 size of a report: its fixed fields and strings, each PairDistance_ (~330 bytes
/// of fields and two object ids) and each event. Only to keep report batches near
/// dds::kMaxReportBatchBytes: an estimate, not a bound.
constexpr std::size_t kReportFixedBytes = 400;
constexpr std::size_t kPairSampleBytes = 400;
constexpr std::size_t kEventSampleBytes = 200;
std::size_t estimated_bytes(const Report& report) {
  return kReportFixedBytes + kPairSampleBytes * report.pairs.size() +
         kEventSampleBytes * report.events.size();
}

/// One writer's stream on one scene. Lives in Impl::streams; erased only while no evaluation
/// references it.
struct StreamState {
  StreamKey key;
  std::uint64_t number = 0;
  std::unique_ptr<PoseStream> stream;
  /// `client_id` and `header` are the ones of the update being evaluated (read by the pool thread
  /// while `evaluating`, written only while not).
  Addressee to;
  /// The DDS participant of the stream's writer: its reports are for a reader there.
  Guid participant{};
  std::deque<Waiting> waiting;
  /// Accepted updates in `waiting` (the rest are error reports).
  std::size_t waiting_updates = 0;
  /// Reports are volatile: one written before our writer has discovered the client's reader is
  /// lost to it. Discovery runs separately in each direction, so a client that waited for its
  /// own matched statuses may still be unknown to our writer for a moment. A new stream therefore
  /// starts evaluating only once our writer has matched a reader of the client's participant, or
  /// after kReaderMatchWait (a client that does not read reports).
  bool ready = false;
  Clock::time_point ready_deadline;
  bool evaluating = false;
  /// An evaluation small enough for the bridge thread (PoseStream::evaluates_inline): taken by
  /// pump() under the lock, run by evaluate_inline() without it.
  std::shared_ptr<EvaluationJob> inline_job;
  /// The report's samples, reused from report to report (the stream's evaluations never
  /// overlap, so neither do its writes).
  std::vector<PairSample> pair_samples;
  std::vector<EventSample> event_samples;
  /// A batched stream (its writer publishes PoseUpdateBatch_): answers wait in `held` until
  /// they are written together in one DistanceReportBatch_ (Impl::flush_if_due says when), in
  /// the order the updates were taken. The samples' buffers, one per held answer, are reused.
  bool batched = false;
  /// The PoseUpdateBatch_ sample whose updates are being accepted (its serial number, 0: none
  /// yet) and whether it arrived while fewer than the limit waited: then it is admitted whole,
  /// as gRPC's FLOW_CONTROL_BLOCK admits a batch read whole (Impl::accept).
  std::uint64_t batch_serial = 0;
  bool batch_admitted_whole = false;
  std::vector<HeldReport> held;
  std::size_t held_bytes = 0;
  Clock::time_point held_since;
  std::vector<ReportSample> batch_samples;
  std::vector<std::vector<PairSample>> batch_pair_samples;
  std::vector<std::vector<EventSample>> batch_event_samples;
  bool announced = false;
  /// The writer is no longer matched: erase once everything taken has been answered.
  bool closing = false;
  std::uint64_t updates = 0;
  std::uint64_t rejected = 0;
  std::uint64_t coalesced = 0;
  std::uint64_t reports = 0;
};

}  // namespace

struct DdsBridge::Impl {
  Impl(SceneService& service, DdsConfig configuration)
      : scenes(service), config(std::move(configuration)) {}

  SceneService& scenes;
  DdsConfig config;
  std::size_t max_waiting = 1;
  /// Numbers the PoseUpdateBatch_ samples taken (only the bridge thread takes samples).
  std::uint64_t batches_taken = 0;

  dds_entity_t participant = 0;
  dds_entity_t reader = 0;
  dds_entity_t writer = 0;
  dds_entity_t event_writer = 0;
  /// The batched pair: PoseUpdateBatch_ in, DistanceReportBatch_ out.
  dds_entity_t batch_reader = 0;
  dds_entity_t batch_writer = 0;
  dds_entity_t guard = 0;
  /// One reader per --dds-joint-states binding, with its scene and, per writer, the sequence
  /// number of its last JointState (JointState has none; the reports count them from 1).
  struct JointReader {
    dds_entity_t reader = 0;
    std::string scene_id;
    std::map<dds_instance_handle_t, std::uint64_t> sequences;
    std::set<dds_instance_handle_t> warned;
  };
  std::vector<JointReader> joint_readers;
  /// Discovery of other participants' endpoints: one whose topic is ours but whose type is not
  /// (a peer built from other message definitions) never matches, silently on DDS's side, so
  /// the bridge logs it, once per endpoint.
  dds_entity_t publications = 0;
  dds_entity_t subscriptions = 0;
  std::set<std::string> mismatches_logged;
  dds_entity_t waitset = 0;
  std::thread thread;

  mutable std::mutex mutex;
  std::condition_variable idle;
  using Streams = std::map<StreamKey, std::unique_ptr<StreamState>>;
  Streams streams;
  std::size_t evaluating = 0;
  /// Streams whose `inline_job` waits for the bridge thread (or, once it has stopped, for
  /// shutdown()), in the order pump() took them.
  std::deque<StreamState*> inline_due;
  /// The bridge thread's PoseUpdate_ in the scene API's terms (to_input), reused.
  model::PoseUpdateInput update_scratch;
  std::uint64_t next_stream_number = 1;
  bool stopping = false;
  bool shut_down = false;
  DdsBridgeStats stats;

  ~Impl() {
    if (participant > 0) dds_delete(participant);
  }

  // ---- the bridge thread ----

  void run() {
    std::array<dds_attach_t, 6> triggered{};
    bool inline_left = false;  // evaluations still due: look at the waitset without waiting
    for (;;) {
      const dds_return_t woken = dds_waitset_wait(waitset, triggered.data(), triggered.size(),
                                                  inline_left ? 0 : time_until_next_deadline());
      if (woken < 0) {
        log_error("dds_waitset_failed").kv("message", dds::describe("dds_waitset_wait", woken));
        return;
      }
      {
        std::lock_guard lock(mutex);
        if (stopping) return;
      }
      reconcile_writers();
      take_samples();
      check_types(publications, /*publication=*/true);
      check_types(subscriptions, /*publication=*/false);
      // Reading the writer's matched status resets it, so that its condition stops triggering.
      dds_publication_matched_status_t publication{};
      dds_get_publication_matched_status(writer, &publication);
      dds_get_publication_matched_status(batch_writer, &publication);
      check_readiness();
      inline_left = evaluate_inline();
    }
  }

  /// Takes every update and joint state waiting in the readers.
  void take_samples() {
    take_updates();
    take_update_batches();
    for (JointReader& joints : joint_readers) take_joint_states(joints);
  }

  /// Runs the evaluations pump() left for the bridge thread, one at a time with the lock
  /// released, and takes the samples that arrived meanwhile after each: the readers' keep-last
  /// history is shared by every writer of a topic, so the bridge thread never leaves it for
  /// longer than one (small) evaluation. Returns after kInlineSlice at most; true when
  /// evaluations are still due.
  bool evaluate_inline() {
    const Clock::time_point until = Clock::now() + kInlineSlice;
    std::unique_lock lock(mutex);
    while (!inline_due.empty() && !stopping) {
      run_inline_evaluation(lock);
      lock.unlock();
      take_samples();
      lock.lock();
      if (Clock::now() >= until) break;
    }
    return !inline_due.empty();
  }

  /// Runs the first evaluation of `inline_due` on this thread with `lock` (on `mutex`) released,
  /// writes its report and starts the stream's next update.
  void run_inline_evaluation(std::unique_lock<std::mutex>& lock) {
    StreamState& stream = *inline_due.front();
    inline_due.pop_front();
    std::shared_ptr<EvaluationJob> job = std::move(stream.inline_job);
    lock.unlock();
    Report report = stream.stream->run_evaluation(*job);
    job.reset();
    if (stream.batched) {
      lock.lock();
      hold(stream, std::move(report));
      evaluated(stream);
      return;
    }
    const Written written = write_report(stream, report);
    lock.lock();
    counted(stream, report.sequence, written);
    evaluated(stream);
  }

  /// The waitset's timeout: until the earliest deadline of a stream not yet ready.
  dds_duration_t time_until_next_deadline() {
    std::lock_guard lock(mutex);
    std::optional<Clock::time_point> earliest;
    for (const auto& [key, stream] : streams)
      if (!stream->ready && (!earliest || stream->ready_deadline < *earliest))
        earliest = stream->ready_deadline;
    if (!earliest) return DDS_INFINITY;
    const auto left = *earliest - Clock::now();
    return std::max<dds_duration_t>(
        0, std::chrono::duration_cast<std::chrono::nanoseconds>(left).count() + 1000);
  }

  /// The participants of the readers `writer` (one of our report writers) has matched. Requires
  /// `mutex` (only to keep the DDS calls off the pool threads' way; they do not call back).
  static std::vector<Guid> reader_participants(dds_entity_t writer) {
    std::vector<dds_instance_handle_t> handles(16);
    dds_return_t count = dds_get_matched_subscriptions(writer, handles.data(), handles.size());
    if (count > dds_return_t(handles.size())) {
      handles.resize(std::size_t(count) + 16);
      count = dds_get_matched_subscriptions(writer, handles.data(), handles.size());
    }
    std::vector<Guid> out;
    for (dds_return_t i = 0; i < std::min<dds_return_t>(count, dds_return_t(handles.size())); ++i) {
      dds_builtintopic_endpoint_t* endpoint =
          dds_get_matched_subscription_data(writer, handles[std::size_t(i)]);
      if (!endpoint) continue;
      Guid& guid = out.emplace_back();
      std::memcpy(guid.data(), endpoint->participant_key.v, guid.size());
      dds_builtintopic_free_endpoint(endpoint);
    }
    return out;
  }

  /// Marks streams ready whose client reader our writer now knows, or whose wait is over, and
  /// starts their answers.
  void check_readiness() {
    std::lock_guard lock(mutex);
    bool any = false;
    for (const auto& [key, stream] : streams) any = any || !stream->ready;
    if (!any) return;
    const std::vector<Guid> readers = reader_participants(writer);
    const std::vector<Guid> batch_readers = reader_participants(batch_writer);
    const Clock::time_point now = Clock::now();
    for (auto it = streams.begin(); it != streams.end();) {
      StreamState& stream = *it->second;
      const std::vector<Guid>& ours = stream.batched ? batch_readers : readers;
      const bool matched = std::find(ours.begin(), ours.end(), stream.participant) != ours.end();
      if (stream.ready || (!matched && now < stream.ready_deadline)) {
        ++it;
        continue;
      }
      stream.ready = true;
      if (!matched)
        log_warn("dds_no_reader_for_stream")
            .kv("stream", stream.number)
            .kv("scene", stream.to.scene_id)
            .kv("message",
                "no reader of the client's participant after the wait; reports are "
                "written anyway");
      pump(stream);
      it = erase_if_finished(it);
    }
    stats.open_streams = streams.size();
  }

  /// Erases the stream at `it` when its writer has gone and everything taken from it has been
  /// answered; the next stream either way. Requires `mutex`.
  Streams::iterator erase_if_finished(Streams::iterator it) {
    StreamState& stream = *it->second;
    if (!stream.closing || stream.evaluating || !stream.waiting.empty()) return std::next(it);
    if (stream.batched) write_held(stream);
    log_closed(stream);
    return streams.erase(it);
  }

  /// Ends the streams of writers that are no longer matched (deleted, or lost by liveliness).
  /// A stream's writer may be matched by the pose reader or, for joint states, by a JointState
  /// reader: the writers still there are those any of them matches.
  void reconcile_writers() {
    bool changed = false;
    std::vector<dds_instance_handle_t> matched;
    std::vector<dds_entity_t> readers{reader, batch_reader};
    for (const JointReader& joints : joint_readers) readers.push_back(joints.reader);
    for (const dds_entity_t source : readers) {
      dds_subscription_matched_status_t status{};
      if (dds_get_subscription_matched_status(source, &status) < 0) return;
      changed = changed || status.current_count_change != 0 || status.total_count_change != 0;
      std::vector<dds_instance_handle_t> some(std::size_t(status.current_count) + 8);
      const dds_return_t count = dds_get_matched_publications(source, some.data(), some.size());
      if (count < 0) return;
      some.resize(std::min<std::size_t>(some.size(), std::size_t(count)));
      matched.insert(matched.end(), some.begin(), some.end());
    }
    if (!changed) return;
    std::sort(matched.begin(), matched.end());
    std::lock_guard lock(mutex);
    for (auto it = streams.begin(); it != streams.end();) {
      if (!std::binary_search(matched.begin(), matched.end(), it->first.publication))
        it->second->closing = true;
      it = erase_if_finished(it);
    }
    stats.open_streams = streams.size();
  }

  void take_updates() {
    for (;;) {
      std::array<void*, kTakeBatch> samples{};
      std::array<dds_sample_info_t, kTakeBatch> infos{};
      const dds_return_t taken =
          dds_take(reader, samples.data(), infos.data(), samples.size(), kTakeBatch);
      if (taken < 0) {
        log_error("dds_take_failed").kv("message", dds::describe("dds_take", taken));
        return;
      }
      std::vector<PendingError> errors;
      for (dds_return_t i = 0; i < taken; ++i) {
        // Samples without data announce instance state changes (a writer unregistering).
        if (!infos[std::size_t(i)].valid_data) continue;
        if (std::optional<PendingError> error =
                accept(*static_cast<const UpdateSample*>(samples[std::size_t(i)]),
                       infos[std::size_t(i)].publication_handle))
          errors.push_back(std::move(*error));
      }
      dds_return_loan(reader, samples.data(), taken);
      for (const PendingError& error : errors) write_error(error);
      if (taken < kTakeBatch) return;
    }
  }

  /// Takes the PoseUpdateBatch_ samples: each update is accepted exactly as if it had been
  /// published alone (accept, in the order listed), so sequence numbers, error reports, merging
  /// under overload (counted in updates) and thresholds are those of the unbatched topic. A batch
  /// of more than dds::kMaxUpdatesPerBatch updates is refused whole (refuse_batch).
  void take_update_batches() {
    for (;;) {
      std::array<void*, kTakeBatch> samples{};
      std::array<dds_sample_info_t, kTakeBatch> infos{};
      const dds_return_t taken =
          dds_take(batch_reader, samples.data(), infos.data(), samples.size(), kTakeBatch);
      if (taken < 0) {
        log_error("dds_take_failed").kv("message", dds::describe("dds_take(batches)", taken));
        return;
      }
      std::vector<PendingError> errors;
      for (dds_return_t i = 0; i < taken; ++i) {
        const dds_sample_info_t& info = infos[std::size_t(i)];
        if (!info.valid_data) continue;
        const auto& batch = *static_cast<const UpdateBatchSample*>(samples[std::size_t(i)]);
        if (batch.updates._length > dds::kMaxUpdatesPerBatch) {
          if (std::optional<PendingError> error = refuse_batch(batch, info.publication_handle))
            errors.push_back(std::move(*error));
          continue;
        }
        const std::uint64_t serial = ++batches_taken;
        for (std::uint32_t k = 0; k < batch.updates._length; ++k) {
          const UpdateSample& update = batch.updates._buffer[k];
          to_input(update, update_scratch);
          if (std::optional<PendingError> error =
                  accept(update_scratch, own(update.client_id), own(update.header), batch_reader,
                         info.publication_handle, serial))
            errors.push_back(std::move(*error));
        }
      }
      if (taken > 0) dds_return_loan(batch_reader, samples.data(), taken);
      for (const PendingError& error : errors) write_error(error);
      if (taken < kTakeBatch) return;
    }
  }

  /// A batch of more than dds::kMaxUpdatesPerBatch updates: none of them is read, and one error
  /// report (RESOURCE_EXHAUSTED, field "updates", the first update's sequence number) says so,
  /// in its turn behind the stream's earlier answers when the writer streams to the first
  /// update's scene, at once otherwise (the returned error). Counted as that many rejected
  /// updates.
  std::optional<PendingError> refuse_batch(const UpdateBatchSample& batch,
                                           dds_instance_handle_t publication) {
    const UpdateSample& first = batch.updates._buffer[0];
    const UpdateSample& last = batch.updates._buffer[batch.updates._length - 1];
    const std::string scene_id = own(first.scene_id);
    const Error error{
        ErrorCode::resource_exhausted, "updates",
        text("the batch holds ", batch.updates._length, " updates (sequence numbers ",
             first.sequence_number, " to ", last.sequence_number, "); at most ",
             dds::kMaxUpdatesPerBatch, " per PoseUpdateBatch sample: none of them was read")};
    std::lock_guard lock(mutex);
    stats.updates_taken += batch.updates._length;
    stats.updates_rejected += batch.updates._length - 1;  // reject() counts one more
    const auto open = streams.find(StreamKey{publication, scene_id});
    if (open != streams.end()) {
      StreamState& stream = *open->second;
      stream.updates += batch.updates._length;
      stream.rejected += batch.updates._length - 1;
      Addressee to{stream.to.scene_id, own(first.client_id).substr(0, kMaxNameBytes),
                   stream.to.writer_guid, own(first.header), /*batched=*/true};
      queue_error(stream, *reject(&stream, std::move(to), first.sequence_number, error));
      return std::nullopt;
    }
    dds_builtintopic_endpoint_t* endpoint =
        dds_get_matched_publication_data(batch_reader, publication);
    if (!endpoint) return std::nullopt;  // the writer has gone: nobody to answer
    Addressee to{scene_id.substr(0, kQuotedBytes),
                 own(first.client_id).substr(0, kMaxNameBytes),
                 {},
                 own(first.header),
                 /*batched=*/true};
    std::memcpy(to.writer_guid.data(), endpoint->key.v, to.writer_guid.size());
    dds_builtintopic_free_endpoint(endpoint);
    return reject(nullptr, std::move(to), first.sequence_number, error);
  }

  /// The type each of our topics carries, for the endpoints of other participants: what a
  /// publication (`publication`) or a subscription on it must name to match ours.
  std::string expected_type(const std::string& topic, bool publication) const {
    if (publication && topic == dds::pose_updates_topic(config.topic_prefix))
      return dds::kPoseUpdateType;
    if (!publication && topic == dds::distance_reports_topic(config.topic_prefix))
      return dds::kDistanceReportType;
    if (!publication && topic == dds::threshold_events_topic(config.topic_prefix))
      return dds::kThresholdEventType;
    if (publication && topic == dds::pose_update_batches_topic(config.topic_prefix))
      return dds::kPoseUpdateBatchType;
    if (!publication && topic == dds::distance_report_batches_topic(config.topic_prefix))
      return dds::kDistanceReportBatchType;
    if (publication)
      for (const JointStateBinding& binding : config.joint_states)
        if (topic == binding.topic) return "sensor_msgs::msg::dds_::JointState_";
    return {};
  }

  /// Logs the endpoints discovered on our topics with another type (they will never match).
  void check_types(dds_entity_t discovery, bool publication) {
    if (discovery <= 0) return;
    for (;;) {
      std::array<void*, kTakeBatch> samples{};
      std::array<dds_sample_info_t, kTakeBatch> infos{};
      const dds_return_t taken =
          dds_take(discovery, samples.data(), infos.data(), samples.size(), kTakeBatch);
      if (taken <= 0) return;
      for (dds_return_t i = 0; i < taken; ++i) {
        if (!infos[std::size_t(i)].valid_data) continue;
        const auto* e = static_cast<const dds_builtintopic_endpoint_t*>(samples[std::size_t(i)]);
        const std::string topic = own(e->topic_name), type = own(e->type_name);
        const std::string expected = expected_type(topic, publication);
        if (expected.empty() || type == expected) continue;
        const std::string key = dds::guid_hex(e->key.v);
        if (!mismatches_logged.insert(key).second) continue;
        log_warn("dds_type_mismatch")
            .kv("endpoint", publication ? "publication" : "subscription")
            .kv("topic", topic)
            .kv("type", type)
            .kv("expected", expected)
            .kv("participant", dds::guid_hex(e->participant_key.v))
            .kv("message",
                "an endpoint on our topic with another type never matches ours; build it from "
                "ros/nearpoint_msgs (ROS 2 types are matched by name)");
      }
      dds_return_loan(discovery, samples.data(), taken);
      if (taken < kTakeBatch) return;
    }
  }

  /// Takes the JointState samples of one binding. Each is decoded and checked
  /// (decode_joint_state) and becomes an update of the bound scene with joint positions by name,
  /// on the stream of its writer (sequence numbers counted per writer); one that cannot be
  /// decoded is answered at once with INVALID_ARGUMENT naming the field (logged once per
  /// writer).
  void take_joint_states(JointReader& joints) {
    for (;;) {
      std::array<void*, kTakeBatch> samples{};
      std::array<dds_sample_info_t, kTakeBatch> infos{};
      const dds_return_t taken =
          dds_take(joints.reader, samples.data(), infos.data(), samples.size(), kTakeBatch);
      if (taken < 0) {
        log_error("dds_take_failed").kv("message", dds::describe("dds_take(joint_states)", taken));
        return;
      }
      std::vector<PendingError> errors;
      for (dds_return_t i = 0; i < taken; ++i) {
        const dds_sample_info_t& info = infos[std::size_t(i)];
        if (!info.valid_data) continue;
        const auto& sample =
            *static_cast<const sensor_msgs_msg_dds__JointState_*>(samples[std::size_t(i)]);
        dds_builtintopic_endpoint_t* endpoint =
            dds_get_matched_publication_data(joints.reader, info.publication_handle);
        if (!endpoint) continue;  // the writer has gone: nobody to answer
        Addressee to{joints.scene_id, kJointStatesClientId, {}, own(sample.header)};
        std::memcpy(to.writer_guid.data(), endpoint->key.v, to.writer_guid.size());
        dds_builtintopic_free_endpoint(endpoint);
        const std::uint64_t sequence = ++joints.sequences[info.publication_handle];
        Expected<JointPositions> positions = decode_joint_state(sample);
        if (positions) {
          // The joint positions by name are the update (the scene API applies them to the
          // scene's robot, or refuses a scene without one); the JointState's writer is a stream
          // like a PoseUpdate writer.
          model::PoseUpdateInput input;
          input.scene_id = joints.scene_id;
          input.sequence = sequence;
          input.joints.names = std::move(positions->names);
          input.joints.positions = std::move(positions->positions);
          if (std::optional<PendingError> error =
                  accept(std::move(input), kJointStatesClientId, std::move(to.header),
                         joints.reader, info.publication_handle))
            errors.push_back(std::move(*error));
          continue;
        }
        // Not decodable (fewer positions than names, a repeated name, …): answered without an
        // evaluation, but in its turn: behind the writer's earlier samples when its stream is
        // open (their reports come first, as on gRPC), at once otherwise.
        const Error& error = positions.error();
        std::lock_guard lock(mutex);
        ++stats.updates_taken;
        ++stats.updates_rejected;
        metrics::record_dds_sample(/*in=*/true);
        if (joints.warned.insert(info.publication_handle).second)
          log_warn("dds_joint_state_rejected")
              .kv("scene", joints.scene_id)
              .kv("writer", dds::guid_hex(to.writer_guid.data()))
              .kv("code", to_string(error.code))
              .kv("field", error.field)
              .kv("message", error.message);
        const auto open = streams.find(StreamKey{info.publication_handle, joints.scene_id});
        if (open != streams.end()) {
          StreamState& stream = *open->second;
          ++stream.updates;
          ++stream.rejected;
          queue_error(stream, PendingError{std::move(to), sequence, error});
          continue;
        }
        errors.push_back(PendingError{std::move(to), sequence, error});
      }
      if (taken > 0) dds_return_loan(joints.reader, samples.data(), taken);
      for (const PendingError& error : errors) write_error(error);
      if (taken < kTakeBatch) return;
    }
  }

  /// Validates one update and queues it on its stream; returns the error report to write when
  /// it is rejected. Cheap: no geometry.
  std::optional<PendingError> accept(const UpdateSample& sample,
                                     dds_instance_handle_t publication) {
    to_input(sample, update_scratch);
    return accept(update_scratch, own(sample.client_id), own(sample.header), reader, publication);
  }

  /// As above for an update already in the scene API's terms (from a PoseUpdate or, for a robot
  /// scene, a JointState), taken by `source` (the reader that matched its writer); `batch`: the
  /// serial number of the PoseUpdateBatch_ sample it came in (0: published alone).
  std::optional<PendingError> accept(const model::PoseUpdateInput& input, std::string client_id,
                                     Header header, dds_entity_t source,
                                     dds_instance_handle_t publication, std::uint64_t batch = 0) {
    const Clock::time_point received = Clock::now();
    // A writer on the batch topic is answered on the batch report topic.
    const bool batched = source == batch_reader;
    std::lock_guard lock(mutex);
    ++stats.updates_taken;
    metrics::record_dds_sample(/*in=*/true);
    // The same id and name rules as on gRPC, checked before the strings become a stream key, a
    // log value or the key of a report: an over-long or malformed scene id is answered (keyed by
    // its first bytes, for the writer's GUID) without opening a stream.
    std::optional<Error> malformed = check_id(input.scene_id, "scene_id");
    if (!malformed) malformed = check_name(client_id, "client_id");
    if (malformed) {
      dds_builtintopic_endpoint_t* endpoint = dds_get_matched_publication_data(source, publication);
      if (!endpoint) return std::nullopt;  // the writer has gone: nobody to answer
      Addressee to{input.scene_id.substr(0, kQuotedBytes),
                   client_id.substr(0, kMaxNameBytes),
                   {},
                   std::move(header),
                   batched};
      std::memcpy(to.writer_guid.data(), endpoint->key.v, to.writer_guid.size());
      dds_builtintopic_free_endpoint(endpoint);
      return reject(nullptr, std::move(to), input.sequence, *malformed);
    }
    const StreamKey key{publication, input.scene_id};
    auto found = streams.find(key);
    if (found == streams.end()) {
      // The writer's GUID addresses the reports; a writer no longer matched has gone (its
      // samples arrived just before its deletion was seen) and cannot be answered.
      dds_builtintopic_endpoint_t* endpoint = dds_get_matched_publication_data(source, publication);
      if (!endpoint) {
        log_warn("dds_update_from_unmatched_writer")
            .kv("scene", input.scene_id)
            .kv("sequence", input.sequence);
        return std::nullopt;
      }
      Addressee to{input.scene_id, client_id, {}, header, batched};
      std::memcpy(to.writer_guid.data(), endpoint->key.v, to.writer_guid.size());
      Guid participant{};
      std::memcpy(participant.data(), endpoint->participant_key.v, participant.size());
      dds_builtintopic_free_endpoint(endpoint);
      Expected<std::unique_ptr<PoseStream>> opened = scenes.open_stream();
      if (!opened) return reject(nullptr, std::move(to), input.sequence, opened.error());
      auto state = std::make_unique<StreamState>();
      state->key = key;
      state->number = next_stream_number++;
      state->stream = std::move(opened.value());
      state->to = std::move(to);
      state->participant = participant;
      state->batched = batched;
      const std::vector<Guid> readers = reader_participants(batched ? batch_writer : writer);
      state->ready = std::find(readers.begin(), readers.end(), participant) != readers.end();
      state->ready_deadline = received + kReaderMatchWait;
      found = streams.emplace(key, std::move(state)).first;
      stats.open_streams = streams.size();
    }
    StreamState& stream = *found->second;
    ++stream.updates;
    Expected<PreparedUpdate> prepared = stream.stream->prepare(input, received);
    metrics::record_update(prepared ? nullptr : &prepared.error());
    if (!prepared) {
      // The error report is queued behind the stream's earlier answers, so that a stream's
      // reports, errors included, come in the order its updates were taken. (A stream whose
      // scene is unknown stays open, unbound and without caches, until its writer goes.)
      Addressee to{stream.to.scene_id, client_id, stream.to.writer_guid, std::move(header),
                   stream.batched};
      queue_error(stream, *reject(&stream, std::move(to), input.sequence, prepared.error()));
      return std::nullopt;
    }
    if (!stream.announced) {
      // Logged once bound, so that samples for unknown scenes do not log a stream each.
      stream.announced = true;
      log_info("dds_stream_open")
          .kv("stream", stream.number)
          .kv("scene", stream.to.scene_id)
          .kv("client", client_id)
          .kv("writer", dds::guid_hex(stream.to.writer_guid.data()))
          .kv("reader_matched", stream.ready ? "yes" : "not_yet");
    }
    Waiting next{std::move(prepared.value()), std::move(client_id), std::move(header),
                 std::nullopt};
    // DDS cannot hold the publisher back: beyond the limit the newest update absorbs the newest
    // one waiting (its poses already include the older one's) and takes its place at the back,
    // and its report says so.
    const bool coalescing = stream.stream->flow_control() == model::FlowControl::coalesce;
    const std::size_t limit = coalescing ? 1 : max_waiting;
    // A batch is admitted whole when it arrives while fewer than the limit wait, as gRPC's
    // FLOW_CONTROL_BLOCK reads a batch whole while fewer than N are in flight: at most N − 1
    // plus one batch's updates wait, and a batch larger than N sent to an idle stream is not
    // merged down for want of room it never needed. One arriving while N wait merges, update by
    // update, as samples published alone would. (A coalescing stream merges whatever arrives.)
    if (batch != 0 && stream.batch_serial != batch) {
      stream.batch_serial = batch;
      stream.batch_admitted_whole = !coalescing && stream.waiting_updates < limit;
    }
    const bool admitted_whole = batch != 0 && stream.batch_admitted_whole;
    if (!admitted_whole && stream.waiting_updates >= limit) {
      const auto older = std::find_if(stream.waiting.rbegin(), stream.waiting.rend(),
                                      [](const Waiting& w) { return !w.error; });
      PoseStream::coalesce(next.update, older->update);
      stream.waiting.erase(std::next(older).base());
      --stream.waiting_updates;
      ++stream.coalesced;
      ++stats.updates_coalesced;
    }
    stream.waiting.push_back(std::move(next));
    ++stream.waiting_updates;
    pump(stream);
    return std::nullopt;
  }

  /// Counts and logs a rejected update; requires `mutex`.
  std::optional<PendingError> reject(StreamState* stream, Addressee to, std::uint64_t sequence,
                                     const Error& error) {
    ++stats.updates_rejected;
    if (stream) ++stream->rejected;
    log_warn("dds_update_rejected")
        .kv("stream", stream ? stream->number : 0)
        .kv("scene", to.scene_id)
        .kv("sequence", sequence)
        .kv("code", to_string(error.code))
        .kv("field", error.field)
        .kv("message", error.message);
    return PendingError{std::move(to), sequence, error};
  }

  /// Queues an error report behind the stream's earlier answers (its reports, errors included,
  /// leave in the order the stream's samples were taken) and writes what is due. Requires
  /// `mutex`.
  void queue_error(StreamState& stream, PendingError error) {
    Waiting entry;
    entry.error = std::move(error);
    stream.waiting.push_back(std::move(entry));
    pump(stream);
  }

  /// Writes the stream's error reports that are due and starts its next evaluation, if none is
  /// running. Requires `mutex` (error reports are written under it, which keeps them in order
  /// with the evaluations' reports).
  void pump(StreamState& stream) {
    advance(stream);
    if (stream.batched) flush_if_due(stream);
  }

  /// pump() without the batched stream's write.
  void advance(StreamState& stream) {
    while (stream.ready && !stream.evaluating && !stream.waiting.empty() &&
           stream.waiting.front().error) {
      if (stream.batched)
        hold(stream, std::move(*stream.waiting.front().error));
      else
        write_error_locked(*stream.waiting.front().error);
      stream.waiting.pop_front();
    }
    if (!stream.ready || stream.evaluating || stream.waiting.empty()) return;
    Waiting next = std::move(stream.waiting.front());
    stream.waiting.pop_front();
    --stream.waiting_updates;
    stream.evaluating = true;
    stream.to.client_id = std::move(next.client_id);
    stream.to.header = std::move(next.header);
    ++evaluating;
    if (stream.stream->evaluates_inline()) {
      // Small enough that a worker's wake-up and the hand-back would cost more than the
      // evaluation: the bridge thread runs it once the lock is released (evaluate_inline).
      stream.inline_job = stream.stream->take_evaluation(std::move(next.update));
      inline_due.push_back(&stream);
      return;
    }
    stream.stream->evaluate(std::move(next.update), [this, &stream](Report report) {
      on_report(stream, std::move(report));
    });
  }

  // ---- a batched stream's answers: held, then written together ----

  /// Keeps an evaluation's report (addressed as the update being evaluated) for the stream's
  /// next DistanceReportBatch_. Requires `mutex`.
  void hold(StreamState& stream, Report report) {
    if (stream.held.empty()) stream.held_since = Clock::now();
    const std::size_t bytes = estimated_bytes(report);
    stream.held_bytes += bytes;
    stream.held.push_back(HeldReport{std::move(report), stream.to, std::nullopt, bytes});
  }

  /// Keeps an error report for the stream's next DistanceReportBatch_. Requires `mutex`.
  void hold(StreamState& stream, PendingError error) {
    if (stream.held.empty()) stream.held_since = Clock::now();
    stream.held_bytes += kReportFixedBytes;
    stream.held.push_back(HeldReport{std::nullopt, {}, std::move(error), kReportFixedBytes});
  }

  /// Writes a batched stream's held answers when nothing more of the stream is about to be
  /// answered (no evaluation running or due), when the oldest has waited kReportHold, or when
  /// they would fill a sample (dds::kMaxReportsPerBatch, dds::kMaxReportBatchBytes). A stream that
  /// is kept busy thus still sees its reports every few milliseconds, and an idle one at once:
  /// nothing waits for a batch to fill. Requires `mutex` (the stream's answers are written under
  /// it, in order).
  void flush_if_due(StreamState& stream) {
    if (stream.held.empty()) return;
    const bool busy = stream.evaluating;
    if (busy && stream.held.size() < dds::kMaxReportsPerBatch &&
        stream.held_bytes < dds::kMaxReportBatchBytes &&
        Clock::now() - stream.held_since < kReportHold)
      return;
    write_held(stream);
  }

  /// Writes every held answer of the stream, in order, as few samples as the limits of one allow
  /// (dds::kMaxReportsPerBatch, dds::kMaxReportBatchBytes; at least one report each), then each
  /// report's threshold crossings on their own topic too. Requires `mutex`.
  void write_held(StreamState& stream) {
    std::size_t begin = 0;
    while (begin < stream.held.size()) {
      std::size_t count = 1, bytes = stream.held[begin].bytes;
      while (begin + count < stream.held.size() && count < dds::kMaxReportsPerBatch &&
             bytes + stream.held[begin + count].bytes <= dds::kMaxReportBatchBytes)
        bytes += stream.held[begin + count++].bytes;
      if (stream.batch_samples.size() < count) {
        stream.batch_samples.resize(count);
        stream.batch_pair_samples.resize(count);
        stream.batch_event_samples.resize(count);
      }
      for (std::size_t k = 0; k < count; ++k) {
        const HeldReport& held = stream.held[begin + k];
        ReportSample& sample = stream.batch_samples[k];
        if (held.report)
          sample = fill_report(*held.report, held.to, stream.batch_pair_samples[k],
                               stream.batch_event_samples[k]);
        else
          sample = fill_error(*held.error);
      }
      ReportBatchSample batch{};
      batch.reports._buffer = stream.batch_samples.data();
      batch.reports._length = batch.reports._maximum = std::uint32_t(count);
      batch.reports._release = false;
      const dds_return_t written = dds_write(batch_writer, &batch);
      std::uint64_t event_failures = 0;
      for (std::size_t k = 0; k < count; ++k) {
        const HeldReport& held = stream.held[begin + k];
        const bool ok =
            count_write(written, held.report ? held.report->sequence : held.error->sequence,
                        &stream, /*log=*/k == 0);
        if (ok && held.report) ++stream.reports;
        if (held.report)
          for (std::size_t e = 0; e < held.report->events.size(); ++e)
            if (dds_write(event_writer, &stream.batch_event_samples[k][e]) < 0) ++event_failures;
      }
      count_event_failures(stream, event_failures);
      begin += count;
    }
    stream.held.clear();
    stream.held_bytes = 0;
  }

  // ---- the report's way out: the worker pool's side, or the bridge thread's ----

  /// An evaluation's report, on a pool thread: written from here, then the stream's next update
  /// starts.
  void on_report(StreamState& stream, Report report) {
    if (stream.batched) {
      std::lock_guard lock(mutex);
      hold(stream, std::move(report));
      evaluated(stream);
      return;
    }
    const Written written = write_report(stream, report);
    std::lock_guard lock(mutex);
    counted(stream, report.sequence, written);
    evaluated(stream);
  }

  /// dds_write's result for a report, and how many of its events failed to be written.
  struct Written {
    dds_return_t report = 0;
    std::uint64_t event_failures = 0;
  };

  /// Writes an evaluation's report and its events, without the lock: the samples borrow the
  /// report's strings and live in the stream's reused buffers.
  Written write_report(StreamState& stream, const Report& report) {
    const ReportSample sample =
        fill_report(report, stream.to, stream.pair_samples, stream.event_samples);
    Written written;
    written.report = dds_write(writer, &sample);
    // Each crossing also on its own topic, for subscribers that want the events alone.
    for (const EventSample& event : stream.event_samples)
      if (dds_write(event_writer, &event) < 0) ++written.event_failures;
    return written;
  }

  /// An evaluation's report as a sample addressed `to`, whose pairs and events live in `pairs`
  /// and `events` (reused from report to report) and borrow the report's strings and `to`'s.
  static ReportSample fill_report(const Report& report, const Addressee& to,
                                  std::vector<PairSample>& pairs,
                                  std::vector<EventSample>& events) {
    pairs.resize(report.pairs.size());
    for (std::size_t i = 0; i < report.pairs.size(); ++i) {
      const model::PairReport& in = report.pairs[i];
      PairSample& out = pairs[i];
      out = PairSample{};  // no field left from the previous report
      out.object_a = borrow(report.scene->objects[in.object_a].id);
      out.object_b = borrow(report.scene->objects[in.object_b].id);
      out.status = model::to_dds(in.status);
      out.distance = in.distance;
      out.distance_lower_bound = in.distance_lower_bound;
      out.error_bound = in.error_bound;
      out.iterations = in.iterations;
      out.piece_pairs_evaluated = in.piece_pairs_evaluated;
      out.piece_a = in.piece_a;
      out.piece_b = in.piece_b;
      out.warm_started = in.warm_started;
      out.has_near_points = in.has_near_points;
      out.point_a = to_point(in.point_a);
      out.point_b = to_point(in.point_b);
      out.normal = to_vector(in.normal);
      out.has_penetration_bound = in.has_penetration_bound;
      out.penetration_bound = in.penetration_bound;
      out.has_gradient = in.has_gradient;
      out.gradient_a = to_sample(in.gradient_a);
      out.gradient_b = to_sample(in.gradient_b);
      out.message = borrow(in.engine_message);
      out.has_signed_distance = in.has_signed_distance;
      out.signed_distance = in.signed_distance;
      out.signed_distance_lower = in.signed_distance_lower;
      out.signed_distance_upper = in.signed_distance_upper;
      out.has_penetration_depth = in.has_penetration_depth;
      out.penetration_depth = in.depth;
      out.penetration_depth_lower = in.depth_lower;
      out.penetration_depth_upper = in.depth_upper;
      out.depth_point_a = to_point(in.depth_point_a);
      out.depth_point_b = to_point(in.depth_point_b);
      out.depth_direction = to_vector(in.depth_direction);
      out.depth_termination = model::to_dds(in.depth_termination);
      out.depth_iterations = in.depth_iterations;
    }
    ReportSample sample{};
    address(to, sample);
    sample.sequence_number = report.sequence;
    sample.status = 0;
    sample.error_field = borrow("");
    sample.message = borrow("");
    sample.pairs._buffer = pairs.data();
    sample.pairs._length = sample.pairs._maximum = std::uint32_t(pairs.size());
    sample.pairs._release = false;
    sample.timing = {report.timing.server_us, report.timing.queue_us, report.timing.evaluation_us,
                     report.timing.geometry_us};
    sample.coalesced_updates = report.coalesced_updates;
    sample.coalesced_from_sequence = report.coalesced_from_sequence;
    sample.counts = {report.counts.pairs_evaluated, report.counts.pairs_pruned,
                     report.counts.pairs_unmoved};
    sample.report_mode = model::to_dds(report.mode);
    events.resize(report.events.size());
    for (std::size_t i = 0; i < report.events.size(); ++i) {
      const model::ThresholdEvent& in = report.events[i];
      EventSample& out = events[i];
      out = EventSample{};
      out.header = sample.header;
      out.scene_id = sample.scene_id;
      out.client_id = sample.client_id;
      out.threshold = borrow(
          report.threshold_names ? (*report.threshold_names)[in.threshold].c_str() : nullptr);
      out.threshold_index = in.threshold;
      out.object_a = borrow(report.scene->objects[in.object_a].id);
      out.object_b = borrow(report.scene->objects[in.object_b].id);
      out.crossing = model::to_dds(in.crossing);
      out.distance = in.distance;
      out.sequence_number = in.sequence;
    }
    sample.events._buffer = events.data();
    sample.events._length = sample.events._maximum = std::uint32_t(events.size());
    sample.events._release = false;
    return sample;
  }

  /// Counts the report of `sequence`, `written` on the unbatched topic. Requires `mutex`.
  void counted(StreamState& stream, std::uint64_t sequence, const Written& written) {
    if (count_write(written.report, sequence, &stream)) ++stream.reports;
    count_event_failures(stream, written.event_failures);
  }

  /// Requires `mutex`.
  void count_event_failures(const StreamState& stream, std::uint64_t failures) {
    if (failures == 0) return;
    stats.write_failures += failures;
    log_warn("dds_event_write_failed").kv("stream", stream.number).kv("events", failures);
  }

  /// The stream's evaluation is over (its report written or held): starts the stream's next
  /// update (or erases a closing stream with nothing left). Requires `mutex`.
  void evaluated(StreamState& stream) {
    stream.evaluating = false;
    --evaluating;
    if (stream.closing && stream.waiting.empty()) {
      if (stream.batched) write_held(stream);
      log_closed(stream);
      streams.erase(stream.key);
      stats.open_streams = streams.size();
    } else {
      pump(stream);
    }
    if (evaluating == 0) idle.notify_all();
  }

  void write_error(const PendingError& pending) {
    std::lock_guard lock(mutex);
    write_error_locked(pending);
  }

  /// Writes an error report on its addressee's report topic (a batched writer's: as a batch of
  /// one). Requires `mutex`.
  void write_error_locked(const PendingError& pending) {
    ReportSample sample = fill_error(pending);
    if (!pending.to.batched) {
      count_write(dds_write(writer, &sample), pending.sequence, nullptr);
      return;
    }
    ReportBatchSample batch{};
    batch.reports._buffer = &sample;
    batch.reports._length = batch.reports._maximum = 1;
    batch.reports._release = false;
    count_write(dds_write(batch_writer, &batch), pending.sequence, nullptr);
  }

  /// An error report as a sample; it borrows `pending`'s strings.
  static ReportSample fill_error(const PendingError& pending) {
    ReportSample sample{};
    address(pending.to, sample);
    sample.sequence_number = pending.sequence;
    sample.status = status_code(pending.error.code);
    sample.error_field = borrow(pending.error.field);
    sample.message = borrow(pending.error.message);
    sample.pairs._release = false;
    sample.events._release = false;
    return sample;
  }

  /// Counts a report's dds_write result and logs a failure (naming the stream when the report
  /// has one; `log` false for the further reports of a failed batch); true when written.
  /// Requires `mutex`.
  bool count_write(dds_return_t written, std::uint64_t sequence, const StreamState* stream,
                   bool log = true) {
    if (written >= 0) {
      ++stats.reports_written;
      metrics::record_dds_sample(/*in=*/false);
      return true;
    }
    ++stats.write_failures;
    if (!log) return false;
    LogLine warning = log_warn("dds_write_failed");
    if (stream) warning.kv("stream", stream->number);
    warning.kv("sequence", sequence).kv("message", dds::describe("dds_write", written));
    return false;
  }

  void log_closed(const StreamState& stream) {
    if (!stream.announced) return;
    log_info("dds_stream_closed")
        .kv("stream", stream.number)
        .kv("scene", stream.to.scene_id)
        .kv("updates", stream.updates)
        .kv("rejected", stream.rejected)
        .kv("coalesced", stream.coalesced)
        .kv("reports", stream.reports);
  }
};

DdsBridge::DdsBridge() = default;

DdsBridge::~DdsBridge() {
  shutdown();
}

Outcome check_dds_config(const DdsConfig& config) {
  if (std::string problem = dds::check_configuration(config.allow_default_config); !problem.empty())
    return Error{ErrorCode::failed_precondition, "CYCLONEDDS_URI", problem};
  // A configuration file that is not there would otherwise surface later as Cyclone's bare
  // "dds_create_participant failed"; several comma-separated URIs are left to Cyclone.
  if (const char* uri = std::getenv("CYCLONEDDS_URI");
      uri != nullptr && std::string_view(uri).starts_with("file://") &&
      std::string_view(uri).find(',') == std::string_view::npos) {
    const std::string path(std::string_view(uri).substr(7));
    if (std::FILE* file = std::fopen(path.c_str(), "r"))
      std::fclose(file);
    else
      return Error{ErrorCode::failed_precondition, "CYCLONEDDS_URI",
                   text("names the file '", path, "', which cannot be read")};
  }
  if (config.domain_id > kMaxDomainId)
    return invalid_argument(
        "dds.domain",
        text("is ", config.domain_id, "; Cyclone DDS's port mapping allows 0-", kMaxDomainId));
  if (std::string problem = dds::check_topic_prefix(config.topic_prefix); !problem.empty())
    return invalid_argument("dds.prefix", problem);
  std::set<std::string> joint_topics;
  for (const JointStateBinding& binding : config.joint_states) {
    if (std::string problem = dds::check_ros_topic(binding.topic); !problem.empty())
      return invalid_argument("dds.joint_states.topic", "'" + binding.topic + "' " + problem);
    if (std::optional<Error> bad = check_id(binding.scene_id, "dds.joint_states.scene"))
      return *bad;
    if (!joint_topics.insert(binding.topic).second)
      return invalid_argument("dds.joint_states.topic",
                              text("'", binding.topic, "' is bound to two scenes; one each"));
    for (const std::string& own_topic : {dds::pose_updates_topic(config.topic_prefix),
                                         dds::distance_reports_topic(config.topic_prefix),
                                         dds::threshold_events_topic(config.topic_prefix),
                                         dds::pose_update_batches_topic(config.topic_prefix),
                                         dds::distance_report_batches_topic(config.topic_prefix)})
      if (binding.topic == own_topic)
        return invalid_argument("dds.joint_states.topic",
                                text("'", binding.topic, "' is one of nearpointd's own topics"));
  }
  if (config.history_depth < 1 || config.history_depth > kMaxHistoryDepth)
    return invalid_argument("dds.history_depth", text("is ", config.history_depth, "; 1-",
                                                      kMaxHistoryDepth, " samples"));
  return {};
}

Expected<std::unique_ptr<DdsBridge>> DdsBridge::start(SceneService& scenes,
                                                      const DdsConfig& config) {
  if (Outcome checked = check_dds_config(config); !checked) return checked.error();

  std::unique_ptr<DdsBridge> self(new DdsBridge());
  self->impl_ = std::make_unique<Impl>(scenes, config);
  Impl& impl = *self->impl_;
  impl.max_waiting = std::max<std::size_t>(1, scenes.limits().max_in_flight_per_stream);
  auto fail = [&](const char* what, dds_return_t code) -> Error {
    impl.shut_down = true;
    return Error{ErrorCode::unavailable, "dds",
                 dds::describe(what, code) + " (domain " + std::to_string(config.domain_id) +
                     "; is CYCLONEDDS_URI a readable, valid Cyclone DDS configuration?)"};
  };

  impl.participant = dds_create_participant(config.domain_id, nullptr, nullptr);
  if (impl.participant < 0) {
    const dds_return_t code = impl.participant;
    impl.participant = 0;
    return fail("dds_create_participant", code);
  }
  const dds::QosPtr qos = dds::stream_qos(config.history_depth, config.best_effort);
  const dds_entity_t update_topic =
      dds_create_topic(impl.participant, &nearpoint_msgs_msg_dds__PoseUpdate__desc,
                       dds::pose_updates_topic(config.topic_prefix).c_str(), qos.get(), nullptr);
  if (update_topic < 0) return fail("dds_create_topic(pose_updates)", update_topic);
  // The report topics' samples are serialised by our own code (dds_report_sertype.hpp).
  const dds_entity_t report_topic =
      create_report_topic(impl.participant, ReportTopicType::report,
                          dds::distance_reports_topic(config.topic_prefix).c_str(), qos.get());
  if (report_topic < 0) return fail("dds_create_topic(distance_reports)", report_topic);
  const dds_entity_t event_topic = dds_create_topic(
      impl.participant, &nearpoint_msgs_msg_dds__ThresholdEvent__desc,
      dds::threshold_events_topic(config.topic_prefix).c_str(), qos.get(), nullptr);
  if (event_topic < 0) return fail("dds_create_topic(threshold_events)", event_topic);
  const dds::QosPtr read_qos = dds::reader_qos(config.history_depth, config.best_effort);
  impl.reader = dds_create_reader(impl.participant, update_topic, read_qos.get(), nullptr);
  if (impl.reader < 0) return fail("dds_create_reader", impl.reader);
  impl.writer = dds_create_writer(impl.participant, report_topic, qos.get(), nullptr);
  if (impl.writer < 0) return fail("dds_create_writer", impl.writer);
  impl.event_writer = dds_create_writer(impl.participant, event_topic, qos.get(), nullptr);
  if (impl.event_writer < 0) return fail("dds_create_writer(threshold_events)", impl.event_writer);
  const dds_entity_t update_batch_topic = dds_create_topic(
      impl.participant, &nearpoint_msgs_msg_dds__PoseUpdateBatch__desc,
      dds::pose_update_batches_topic(config.topic_prefix).c_str(), qos.get(), nullptr);
  if (update_batch_topic < 0)
    return fail("dds_create_topic(pose_update_batches)", update_batch_topic);
  const dds_entity_t report_batch_topic = create_report_topic(
      impl.participant, ReportTopicType::report_batch,
      dds::distance_report_batches_topic(config.topic_prefix).c_str(), qos.get());
  if (report_batch_topic < 0)
    return fail("dds_create_topic(distance_report_batches)", report_batch_topic);
  impl.batch_reader =
      dds_create_reader(impl.participant, update_batch_topic, read_qos.get(), nullptr);
  if (impl.batch_reader < 0) return fail("dds_create_reader(batches)", impl.batch_reader);
  impl.batch_writer = dds_create_writer(impl.participant, report_batch_topic, qos.get(), nullptr);
  if (impl.batch_writer < 0) return fail("dds_create_writer(batches)", impl.batch_writer);
  if (const dds_return_t rc = dds_set_status_mask(
          impl.reader, DDS_DATA_AVAILABLE_STATUS | DDS_SUBSCRIPTION_MATCHED_STATUS);
      rc < 0)
    return fail("dds_set_status_mask", rc);
  if (const dds_return_t rc = dds_set_status_mask(impl.writer, DDS_PUBLICATION_MATCHED_STATUS);
      rc < 0)
    return fail("dds_set_status_mask(writer)", rc);
  if (const dds_return_t rc = dds_set_status_mask(
          impl.batch_reader, DDS_DATA_AVAILABLE_STATUS | DDS_SUBSCRIPTION_MATCHED_STATUS);
      rc < 0)
    return fail("dds_set_status_mask(batch reader)", rc);
  if (const dds_return_t rc =
          dds_set_status_mask(impl.batch_writer, DDS_PUBLICATION_MATCHED_STATUS);
      rc < 0)
    return fail("dds_set_status_mask(batch writer)", rc);
  impl.guard = dds_create_guardcondition(impl.participant);
  if (impl.guard < 0) return fail("dds_create_guardcondition", impl.guard);
  impl.waitset = dds_create_waitset(impl.participant);
  if (impl.waitset < 0) return fail("dds_create_waitset", impl.waitset);
  if (const dds_return_t rc = dds_waitset_attach(impl.waitset, impl.reader, impl.reader); rc < 0)
    return fail("dds_waitset_attach(reader)", rc);
  if (const dds_return_t rc = dds_waitset_attach(impl.waitset, impl.writer, impl.writer); rc < 0)
    return fail("dds_waitset_attach(writer)", rc);
  if (const dds_return_t rc = dds_waitset_attach(impl.waitset, impl.guard, impl.guard); rc < 0)
    return fail("dds_waitset_attach(guard)", rc);
  if (const dds_return_t rc =
          dds_waitset_attach(impl.waitset, impl.batch_reader, impl.batch_reader);
      rc < 0)
    return fail("dds_waitset_attach(batch reader)", rc);
  if (const dds_return_t rc =
          dds_waitset_attach(impl.waitset, impl.batch_writer, impl.batch_writer);
      rc < 0)
    return fail("dds_waitset_attach(batch writer)", rc);
  for (const JointStateBinding& binding : config.joint_states) {
    const dds_entity_t topic =
        dds_create_topic(impl.participant, &sensor_msgs_msg_dds__JointState__desc,
                         binding.topic.c_str(), qos.get(), nullptr);
    if (topic < 0) return fail("dds_create_topic(joint_states)", topic);
    Impl::JointReader& joints = impl.joint_readers.emplace_back();
    joints.scene_id = binding.scene_id;
    joints.reader = dds_create_reader(impl.participant, topic, read_qos.get(), nullptr);
    if (joints.reader < 0) return fail("dds_create_reader(joint_states)", joints.reader);
    if (const dds_return_t rc = dds_set_status_mask(
            joints.reader, DDS_DATA_AVAILABLE_STATUS | DDS_SUBSCRIPTION_MATCHED_STATUS);
        rc < 0)
      return fail("dds_set_status_mask(joint_states)", rc);
    if (const dds_return_t rc = dds_waitset_attach(impl.waitset, joints.reader, joints.reader);
        rc < 0)
      return fail("dds_waitset_attach(joint_states)", rc);
    log_info("dds_joint_states")
        .kv("scene", binding.scene_id)
        .kv("topic", binding.topic)
        .kv("type", "sensor_msgs::msg::dds_::JointState_");
  }

  impl.publications =
      dds_create_reader(impl.participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  impl.subscriptions =
      dds_create_reader(impl.participant, DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, nullptr, nullptr);
  if (impl.publications < 0) return fail("dds_create_reader(DCPSPublication)", impl.publications);
  if (impl.subscriptions < 0)
    return fail("dds_create_reader(DCPSSubscription)", impl.subscriptions);
  for (const dds_entity_t discovery : {impl.publications, impl.subscriptions}) {
    if (const dds_return_t rc = dds_set_status_mask(discovery, DDS_DATA_AVAILABLE_STATUS); rc < 0)
      return fail("dds_set_status_mask(discovery)", rc);
    if (const dds_return_t rc = dds_waitset_attach(impl.waitset, discovery, discovery); rc < 0)
      return fail("dds_waitset_attach(discovery)", rc);
  }

  impl.thread = std::thread([&impl] { impl.run(); });
  log_info("dds_ready")
      .kv("domain", config.domain_id)
      .kv("updates_topic", dds::pose_updates_topic(config.topic_prefix))
      .kv("reports_topic", dds::distance_reports_topic(config.topic_prefix))
      .kv("events_topic", dds::threshold_events_topic(config.topic_prefix))
      .kv("update_batches_topic", dds::pose_update_batches_topic(config.topic_prefix))
      .kv("report_batches_topic", dds::distance_report_batches_topic(config.topic_prefix))
      .kv("history_depth", config.history_depth)
      .kv("reliability", config.best_effort ? "best_effort" : "reliable")
      .kv("max_in_flight", impl.max_waiting)
      .kv("config", std::getenv("CYCLONEDDS_URI") ? std::getenv("CYCLONEDDS_URI") : "(default)");
  return self;
}

void DdsBridge::shutdown() {
  if (!impl_) return;
  Impl& impl = *impl_;
  {
    std::lock_guard lock(impl.mutex);
    if (impl.shut_down) return;
    impl.shut_down = true;
    impl.stopping = true;
  }
  dds_set_guardcondition(impl.guard, true);
  if (impl.thread.joinable()) impl.thread.join();
  // Answer every update already taken (at most --max-in-flight per stream), then end.
  std::unique_lock lock(impl.mutex);
  for (const auto& [key, stream] : impl.streams) {
    stream->ready = true;
    impl.pump(*stream);
  }
  // The bridge thread has stopped: the small evaluations are this thread's to run now.
  while (!impl.inline_due.empty()) impl.run_inline_evaluation(lock);
  impl.idle.wait(lock, [&] { return impl.evaluating == 0; });
  for (const auto& [key, stream] : impl.streams) {
    if (stream->batched) impl.write_held(*stream);  // already written when idle; to be sure
    impl.log_closed(*stream);
  }
  impl.streams.clear();
  impl.stats.open_streams = 0;
  log_info("dds_shutdown")
      .kv("updates", impl.stats.updates_taken)
      .kv("rejected", impl.stats.updates_rejected)
      .kv("coalesced", impl.stats.updates_coalesced)
      .kv("reports", impl.stats.reports_written)
      .kv("write_failures", impl.stats.write_failures);
  lock.unlock();
  dds_delete(impl.participant);
  impl.participant = 0;
}

DdsBridgeStats DdsBridge::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

const DdsConfig& DdsBridge::config() const {
  return impl_->config;
}

}  // namespace nearpoint::server
