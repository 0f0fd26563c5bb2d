// SPDX-License-Identifier: Apache-2.0
#include "session.hpp"

#include <algorithm>
#include <chrono>

#include "convert.hpp"

namespace nearpoint::client::detail {

Status from_grpc(const grpc::Status& status) {
  return Status{int(status.error_code()), status.error_message()};
}

namespace {

// A dropped connection, as opposed to an answer: worth reconnecting for. Behind a proxy two more
// codes mean it: CANCELLED when this client did not cancel (its own cancellations are handled
// before this is asked), and UNKNOWN ("No status received"): HAProxy ends the streams of a
// backend that died with a reset or without any gRPC status, and nearpointd itself never ends
// a call with UNKNOWN.
bool is_connection_loss(const grpc::Status& status) {
  return status.error_code() == grpc::StatusCode::UNAVAILABLE ||
         status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED ||
         status.error_code() == grpc::StatusCode::CANCELLED ||
         status.error_code() == grpc::StatusCode::UNKNOWN;
}

}  // namespace

SessionImpl::SessionImpl(SessionHost& client, std::string scene_id, std::string server_scene_id,
                         SessionOptions options)
    : client_(client),
      scene_id_(std::move(scene_id)),
      options_(std::move(options)),
      server_scene_id_(std::move(server_scene_id)) {}

std::shared_ptr<SessionImpl::Call> SessionImpl::open_call(const std::string& server_scene_id) {
  auto call = std::make_shared<Call>();
  if (routable(server_scene_id)) call->context.AddMetadata(kSceneRoutingHeader, server_scene_id);
  if (options_.batched)
    call->batch_stream = client_.stub().StreamPoseBatches(&call->context);
  else
    call->stream = client_.stub().StreamPoses(&call->context);
  return call;
}

bool SessionImpl::start(Status& /*error*/) {
  // A stream to an unreachable server fails on its first read, which the reader thread handles
  // like any dropped connection (reconnect or fail), so starting cannot fail here.
  call_ = open_call(server_scene_id_);
  reader_ = std::thread([this] { read_loop(); });
  return true;
}

SessionImpl::~SessionImpl() {
  {
    std::lock_guard lock(mutex_);
    destroying_ = true;
    if (call_ && state_ != State::closed && state_ != State::failed) call_->context.TryCancel();
  }
  changed_.notify_all();
  if (reader_.joinable()) reader_.join();
}

void SessionImpl::deliver(Report report) {
  {
    std::lock_guard lock(mutex_);
    // In order: every update up to this report's sequence number is answered now (coalesced
    // ones by this report; they will get none of their own and leave the window here).
    while (!in_flight_.empty() && in_flight_.front().sequence <= report.sequence) {
      if (in_flight_.front().sequence == report.sequence) {
        report.sent = in_flight_.front().sent;
      } else {
        --outstanding_;
      }
      in_flight_.pop_front();
    }
  }
  hand_over(std::move(report));
}

void SessionImpl::hand_over(Report report) {
  report.received = Clock::now();
  {
    std::lock_guard lock(mutex_);
    if (resumed_sequence_ != 0 && report.sequence >= resumed_sequence_) {
      report.resumed = true;  // the first report of the stream that replaced a lost one
      resumed_sequence_ = 0;
    }
    if (!options_.on_report) {
      ready_.push_back(std::move(report));
      changed_.notify_all();
      return;
    }
  }
  options_.on_report(report);
  std::lock_guard lock(mutex_);
  --outstanding_;
  changed_.notify_all();
}

void SessionImpl::fail_in_flight(const std::string& why) {
  std::deque<InFlight> lost;
  {
    std::lock_guard lock(mutex_);
    lost.swap(in_flight_);
  }
  // Each failed update is handed over directly: putting it back into in_flight_ for deliver()
  // to pop once let an update pushed meanwhile sit in front of it, unanswered for good, while
  // the window count went below zero (every later push then waited for a full window).
  for (const InFlight& update : lost) {
    Report report;
    report.sequence = update.sequence;
    report.sent = update.sent;
    report.error = Status::error(kUnavailable, why);
    hand_over(std::move(report));
  }
}

bool SessionImpl::reconnect(const Status& cause) {
  const Clock::time_point give_up = Clock::now() + options_.reconnect_timeout;
  auto backoff = options_.initial_backoff;
  std::string stale;
  {
    std::lock_guard lock(mutex_);
    stale = server_scene_id_;
  }
  Status last = Status::error(kUnavailable, "no attempt made");
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (destroying_) return false;
    }
    const Clock::time_point attempt_end = std::min(give_up, Clock::now() + backoff);
    if (client_.wait_connected(attempt_end)) {
      Expected<std::string> server_id = client_.replay_scene(scene_id_, stale);
      if (server_id) {
        auto call = open_call(*server_id);
        const ResumeEvent event{reconnects_.load() + 1, cause, *server_id};
        // Before the new stream is published: no update goes out on it before the caller knows.
        if (options_.on_resumed) options_.on_resumed(event);
        std::lock_guard lock(mutex_);
        call_ = std::move(call);
        server_scene_id_ = *server_id;
        resync_ = true;
        send_thresholds_ = true;
        state_ = State::connected;
        reconnects_.fetch_add(1);
        changed_.notify_all();
        return true;
      }
      last = server_id.status();
      // An answer is final; a lost connection is not (through a proxy also CANCELLED or
      // UNKNOWN: the replica went away during the call, e.g. while it drained).
      if (!is_connection_loss(grpc::Status(grpc::StatusCode(last.code), last.message))) break;
    }
    if (Clock::now() >= give_up) break;
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, std::min(give_up, Clock::now() + backoff),
                        [&] { return destroying_; });
    backoff = std::min(options_.max_backoff, backoff * 2);
  }
  std::lock_guard lock(mutex_);
  failure_ =
      last.code == kUnavailable || last.ok()
          ? Status::error(kUnavailable, "could not reconnect to " + client_.target() + " within " +
                                            std::to_string(options_.reconnect_timeout.count()) +
                                            " ms: " + last.message)
          : Status::error(last.code, "replaying the scene after a reconnect: " + last.message);
  state_ = State::failed;
  changed_.notify_all();
  return false;
}

void SessionImpl::take_report(Call& call, const v1::DistanceReport& message, bool& scene_missing) {
  Report report = detail::from_proto(message);
  // The server does not hold our scene (restarted; or a sharding proxy routed the stream to a
  // replica that does not have it): the stream can never work, so replace it.
  const bool missing = report.error.code == kNotFound && report.error_field == "scene_id";
  const bool replaced = missing && options_.reconnect && client_.owns_scene(scene_id_);
  if (replaced && !scene_missing) {
    scene_missing = true;
    {
      // Before the caller sees the report: a push made after it waits for the new stream
      // instead of going out on this one.
      std::lock_guard lock(mutex_);
      if (state_ == State::connected) state_ = State::reconnecting;
    }
    call.context.TryCancel();
  }
  if (replaced)
    // Lost to routing like an update in flight when a replica dies, and answered the same way
    // (UNAVAILABLE: never evaluated, push it again), whichever replica the proxy chose while
    // its ring changed; the server's words stay in the message.
    report.error =
        Status::error(kUnavailable,
                      "not evaluated: the replica that answered does not hold the scene; the "
                      "session re-creates it and resumes the stream (" +
                          report.error.describe() + ")");
  deliver(std::move(report));
}

void SessionImpl::read_loop() {
  for (;;) {
    std::shared_ptr<Call> call;
    {
      std::lock_guard lock(mutex_);
      call = call_;
    }
    bool scene_missing = false;
    if (call->batch_stream) {
      v1::DistanceReportBatch batch;
      while (call->batch_stream->Read(&batch))
        for (const v1::DistanceReport& message : batch.reports())
          take_report(*call, message, scene_missing);
    } else {
      v1::DistanceReport message;
      while (call->stream->Read(&message)) take_report(*call, message, scene_missing);
    }
    grpc::Status status;
    {
      std::lock_guard write(write_mutex_);
      call->finished = true;
      status = call->finish();
    }
    if (scene_missing)
      status = grpc::Status(grpc::StatusCode::NOT_FOUND,
                            "the server that answered does not hold the scene (a restarted "
                            "server, or a proxy routing it to another replica); re-creating it");
    bool closing = false;
    {
      std::lock_guard lock(mutex_);
      if (destroying_) {
        state_ = State::closed;
        changed_.notify_all();
        return;
      }
      closing = state_ == State::closing;
      if (closing && status.ok()) {
        state_ = State::closed;
        changed_.notify_all();
      } else if (state_ == State::connected) {
        // The stream is over: from here a push waits (for the next stream, or to be refused)
        // instead of adding to in_flight_ an update that this stream will neither send nor
        // answer, while the updates in flight on it are answered below.
        state_ = State::reconnecting;
      }
    }
    if (closing && status.ok()) {
      fail_in_flight("the stream ended before this update was answered");
      return;
    }
    const bool lost = scene_missing || is_connection_loss(status);
    // A drain answers every update the server read, so the ones still in flight were never
    // evaluated; after a crash nobody knows. The caller needs to tell the two apart.
    if (is_server_drain(from_grpc(status)))
      fail_in_flight("not evaluated: " + client_.target() +
                     " is draining (shutting down) and did not read this update; push it again (" +
                     status.error_message() + ")");
    else
      fail_in_flight(
          lost ? "connection to " + client_.target() +
                     " lost before this update was answered; it may or may not have been "
                     "evaluated (" +
                     from_grpc(status).describe() + ")"
               : "the stream failed before this update was answered: " + status.error_message());
    if (closing || !lost || !options_.reconnect) {
      std::lock_guard lock(mutex_);
      failure_ = status.ok() ? Status::error(kUnavailable, "the server ended the stream")
                             : from_grpc(status);
      state_ = State::failed;
      changed_.notify_all();
      return;
    }
    {
      std::lock_guard lock(mutex_);
      state_ = State::reconnecting;
    }
    if (!reconnect(from_grpc(status))) return;
  }
}

Expected<std::uint64_t> SessionImpl::push(const std::vector<ObjectPose>& poses,
                                          Clock::time_point deadline, const QueryOptions* options) {
  return push_update(poses, nullptr, deadline, options);
}

Expected<std::uint64_t> SessionImpl::push_joints(const JointPositions& joints,
                                                 Clock::time_point deadline,
                                                 const QueryOptions* options) {
  return push_update({}, &joints, deadline, options);
}

Expected<std::uint64_t> SessionImpl::push_batch(
    const std::vector<std::vector<ObjectPose>>& pose_sets, Clock::time_point deadline,
    const QueryOptions* options) {
  if (pose_sets.empty())
    return Status::error(3, "push_batch needs a pose set");  // INVALID_ARGUMENT
  std::lock_guard pushing(push_mutex_);
  std::unique_lock lock(mutex_);
  if (Status waited = wait_for_window(lock, pose_sets.size(), deadline); !waited.ok())
    return waited;
  v1::PoseUpdateBatch batch;
  for (const std::vector<ObjectPose>& poses : pose_sets)
    next_update(poses, nullptr, options, *batch.add_updates());
  std::shared_ptr<Call> call = call_;
  lock.unlock();
  send(*call, batch);
  return batch.updates(0).sequence();
}

Expected<std::uint64_t> SessionImpl::push_update(const std::vector<ObjectPose>& poses,
                                                 const JointPositions* joints,
                                                 Clock::time_point deadline,
                                                 const QueryOptions* options) {
  std::lock_guard pushing(push_mutex_);
  std::unique_lock lock(mutex_);
  if (Status waited = wait_for_window(lock, 1, deadline); !waited.ok()) return waited;
  v1::PoseUpdateBatch batch;
  next_update(poses, joints, options, *batch.add_updates());
  std::shared_ptr<Call> call = call_;
  lock.unlock();
  send(*call, batch);
  return batch.updates(0).sequence();
}

Status SessionImpl::wait_for_window(std::unique_lock<std::mutex>& lock, std::size_t count,
                                    Clock::time_point deadline) {
  const bool ready = changed_.wait_until(lock, deadline, [&] {
    return state_ == State::failed || state_ == State::closing || state_ == State::closed ||
           (state_ == State::connected &&
            (outstanding_ + count <= options_.max_in_flight || outstanding_ == 0));
  });
  if (state_ == State::failed) return failure_;
  if (state_ == State::closing || state_ == State::closed)
    return Status::error(9, "the session is closed");  // FAILED_PRECONDITION
  if (!ready)
    return Status::error(kDeadlineExceeded, state_ == State::reconnecting
                                                ? "still reconnecting"
                                                : "the in-flight window stayed full");
  return {};
}

void SessionImpl::send(Call& call, const v1::PoseUpdateBatch& updates) {
  std::lock_guard write(write_mutex_);
  // A failed write means the stream is gone; the reader thread sees that too and answers these
  // updates with UNAVAILABLE error reports.
  if (call.finished) return;
  if (call.batch_stream) {
    call.batch_stream->Write(updates);
    return;
  }
  for (const v1::PoseUpdate& update : updates.updates())
    if (!call.stream->Write(update)) return;
}

void SessionImpl::next_update(const std::vector<ObjectPose>& poses, const JointPositions* joints,
                              const QueryOptions* options, v1::PoseUpdate& update) {
  const std::uint64_t sequence = next_sequence_++;
  update.set_scene_id(server_scene_id_);
  update.set_sequence(sequence);
  update.set_flow_control(options_.coalesce ? v1::FLOW_CONTROL_COALESCE : v1::FLOW_CONTROL_BLOCK);
  detail::to_proto(options != nullptr ? *options : options_.options, *update.mutable_options());
  if (send_thresholds_) {
    for (const Threshold& threshold : options_.thresholds)
      detail::to_proto(threshold, *update.add_thresholds());
    send_thresholds_ = false;
  }
  for (const ObjectPose& pose : poses) {
    detail::to_proto(pose, *update.add_poses());
    latest_poses_[pose.object_id] = pose;
  }
  if (resync_) {
    // A new stream starts from the scene's initial poses: send every pose pushed before.
    for (const auto& [id, pose] : latest_poses_) {
      // An init-capture, not the binding itself: clang 14 (the fuzz and sanitizer builds)
      // cannot capture structured bindings.
      const bool listed =
          std::any_of(poses.begin(), poses.end(),
                      [&object_id = id](const ObjectPose& p) { return p.object_id == object_id; });
      if (!listed) detail::to_proto(pose, *update.add_poses());
    }
    resumed_sequence_ = sequence;
  }
  if (joints != nullptr || (resync_ && (!latest_joints_.empty() || latest_base_))) {
    // Joint positions as pushed, then (on a new stream, which starts from the reference
    // positions) every joint pushed before that this update does not name.
    JointPositions sent = joints != nullptr ? *joints : JointPositions{};
    if (joints != nullptr) {
      // Replayed after a reconnect: updates whose joints take one value each (one-dof joints;
      // the server tells the rest apart, the client does not know the robot).
      if (joints->positions.size() == joints->names.size())
        for (std::size_t i = 0; i < joints->names.size(); ++i)
          latest_joints_[joints->names[i]] = {joints->positions[i]};
      if (joints->base_pose) latest_base_ = joints->base_pose;
    }
    if (resync_) {
      for (const auto& [name, values] : latest_joints_)
        if (std::find(sent.names.begin(), sent.names.end(), name) == sent.names.end()) {
          sent.names.push_back(name);
          sent.positions.insert(sent.positions.end(), values.begin(), values.end());
        }
      if (!sent.base_pose) sent.base_pose = latest_base_;
    }
    proto::to_proto(sent, *update.mutable_joints());
  }
  resync_ = false;
  in_flight_.push_back({sequence, Clock::now()});
  ++outstanding_;
}

Expected<Report> SessionImpl::next(Clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  changed_.wait_until(lock, deadline, [&] {
    return !ready_.empty() || state_ == State::failed || state_ == State::closed;
  });
  if (!ready_.empty()) {
    Report report = std::move(ready_.front());
    ready_.pop_front();
    --outstanding_;
    changed_.notify_all();
    return report;
  }
  if (state_ == State::failed) return failure_;
  if (state_ == State::closed)
    return Status::error(kOutOfRange, "the session is closed and every report was taken");
  return Status::error(kDeadlineExceeded, "no report arrived in time");
}

Status SessionImpl::close(Clock::time_point deadline) {
  std::lock_guard pushing(push_mutex_);
  std::shared_ptr<Call> call;
  {
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, deadline, [&] { return state_ != State::reconnecting; });
    if (state_ == State::failed) return failure_;
    if (state_ == State::closed) return {};
    if (state_ == State::reconnecting)
      return Status::error(kDeadlineExceeded, "still reconnecting");
    state_ = State::closing;
    call = call_;
  }
  {
    std::lock_guard write(write_mutex_);
    if (!call->finished) call->writes_done();
  }
  std::unique_lock lock(mutex_);
  if (!changed_.wait_until(lock, deadline,
                           [&] { return state_ == State::closed || state_ == State::failed; })) {
    call->context.TryCancel();
    changed_.wait(lock, [&] { return state_ == State::closed || state_ == State::failed; });
  }
  return state_ == State::failed ? failure_ : Status{};
}

}  // namespace nearpoint::client::detail
