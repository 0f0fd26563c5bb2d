// SPDX-License-Identifier: Apache-2.0
// The client's pose session (Session): one stream of updates and reports on one scene, with its
// reader thread and its reconnect-and-replay machinery. Private to the client library.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "channel.hpp"
#include "nearpoint/client/client.hpp"
#include "nearpoint_distance.grpc.pb.h"

namespace nearpoint::client::detail {

namespace v1 = ::nearpoint::v1;

Status from_grpc(const grpc::Status& status);

/// What a session needs of its client: the stub, the connection, and the replay of the scene
/// after a lost stream.
class SessionHost {
 public:
  virtual v1::DistanceService::Stub& stub() = 0;
  virtual bool wait_connected(Clock::time_point deadline) = 0;
  virtual const std::string& target() const = 0;
  /// Whether this client created `scene_id` (and has not deleted it): it can re-create it.
  virtual bool owns_scene(const std::string& scene_id) const = 0;
  /// Re-creates `scene_id` after its server id `stale_server_id` stopped working; returns the
  /// scene's server id now.
  virtual Expected<std::string> replay_scene(const std::string& scene_id,
                                             const std::string& stale_server_id) = 0;

 protected:
  ~SessionHost() = default;
};

class SessionImpl final : public Session {
 public:
  SessionImpl(SessionHost& client, std::string scene_id, std::string server_scene_id,
              SessionOptions options);
  ~SessionImpl() override;

  bool start(Status& error);
  Expected<std::uint64_t> push(const std::vector<ObjectPose>& poses, Clock::time_point deadline,
                               const QueryOptions* options) override;
  Expected<std::uint64_t> push_batch(const std::vector<std::vector<ObjectPose>>& pose_sets,
                                     Clock::time_point deadline,
                                     const QueryOptions* options) override;
  Expected<std::uint64_t> push_joints(const JointPositions& joints, Clock::time_point deadline,
                                      const QueryOptions* options) override;
  Expected<Report> next(Clock::time_point deadline) override;
  Status close(Clock::time_point deadline) override;
  std::uint64_t reconnects() const override { return reconnects_.load(); }
  Status status() const override {
    std::lock_guard lock(mutex_);
    return failure_;
  }
  std::string server_scene_id() const override {
    std::lock_guard lock(mutex_);
    return server_scene_id_;
  }

 private:
  // One gRPC call (one stream). The context outlives the stream (declared first).
  struct Call {
    grpc::ClientContext context;
    // One of the two: StreamPoses, or StreamPoseBatches (SessionOptions::batched).
    std::unique_ptr<grpc::ClientReaderWriter<v1::PoseUpdate, v1::DistanceReport>> stream;
    std::unique_ptr<grpc::ClientReaderWriter<v1::PoseUpdateBatch, v1::DistanceReportBatch>>
        batch_stream;
    bool finished = false;  // Finish() was called: no more writes (guarded by write_mutex_)

    void writes_done() { stream ? stream->WritesDone() : batch_stream->WritesDone(); }
    grpc::Status finish() { return stream ? stream->Finish() : batch_stream->Finish(); }
  };
  struct InFlight {
    std::uint64_t sequence;
    Clock::time_point sent;
  };
  enum class State { connected, reconnecting, closing, closed, failed };

  std::shared_ptr<Call> open_call(const std::string& server_scene_id);
  Expected<std::uint64_t> push_update(const std::vector<ObjectPose>& poses,
                                      const JointPositions* joints, Clock::time_point deadline,
                                      const QueryOptions* options);
  // Waits (on `lock`, of mutex_) until `count` more updates fit in the window: OK, or why not.
  Status wait_for_window(std::unique_lock<std::mutex>& lock, std::size_t count,
                         Clock::time_point deadline);
  // The next update (its sequence number, the session's options and thresholds, and after a
  // reconnect every pose pushed before), now in flight; under mutex_.
  void next_update(const std::vector<ObjectPose>& poses, const JointPositions* joints,
                   const QueryOptions* options, v1::PoseUpdate& update);
  // Writes `updates` on `call`: one message, or one per update (StreamPoses).
  void send(Call& call, const v1::PoseUpdateBatch& updates);
  void read_loop();
  // One report read off the stream (see read_loop); `scene_missing` is the stream's.
  void take_report(Call& call, const v1::DistanceReport& message, bool& scene_missing);
  // The server's answer to the update `report.sequence`, which also answers every update before
  // it that is still in flight (coalesced into it).
  void deliver(Report report);
  // To the caller (on_report or next()); the update has already left in_flight_.
  void hand_over(Report report);
  // Gives every update in flight an UNAVAILABLE error report (they will never be answered).
  // Only once the stream is over and no push can add to in_flight_ (state_ not connected).
  void fail_in_flight(const std::string& why);
  bool reconnect(const Status& cause);

  SessionHost& client_;
  const std::string scene_id_;
  const SessionOptions options_;

  std::mutex push_mutex_;   // serialises push() and close()
  std::mutex write_mutex_;  // serialises Write / WritesDone / Finish on a call
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  State state_ = State::connected;
  bool destroying_ = false;
  std::shared_ptr<Call> call_;
  std::string server_scene_id_;
  std::deque<InFlight> in_flight_;  // sent, not yet answered
  std::size_t outstanding_ = 0;     // pushed, not yet consumed
  std::deque<Report> ready_;
  std::uint64_t next_sequence_ = 1;
  std::map<std::string, ObjectPose> latest_poses_;            // for the resync after a reconnect
  std::map<std::string, std::vector<double>> latest_joints_;  // one-dof joints, likewise
  std::optional<model::PoseInput> latest_base_;
  bool resync_ = false;
  bool send_thresholds_ = true;         // on the first update of each stream
  std::uint64_t resumed_sequence_ = 0;  // the first update on a replacing stream (0: none)
  Status failure_;
  std::atomic<std::uint64_t> reconnects_{0};
  std::thread reader_;
};

}  // namespace nearpoint::client::detail
