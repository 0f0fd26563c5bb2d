// SPDX-License-Identifier: Apache-2.0
// The gRPC adapters: DistanceService and Diagnostics on the async generic server (grpc_async.hpp):
// one reactor class per streaming RPC, state in members, OnDone cleans up.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <unordered_set>

#include "grpc_async.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "nearpoint_diagnostics.grpc.pb.h"
#include "nearpoint_distance.grpc.pb.h"

namespace nearpoint::server {

/// How a call that arrives once the drain has begun is refused (UNAVAILABLE), and how a call that
/// was open when it began ends (UNAVAILABLE; clients look for "draining"): one wording for every
/// service the server has.
inline constexpr const char* kShuttingDown = "server is shutting down";
inline constexpr const char* kDraining = "server is draining (shutting down)";

/// A streaming call that can be asked to wind down at shutdown.
class DrainableStream {
 public:
  virtual void Drain() = 0;

 protected:
  ~DrainableStream() = default;
};

/// The open calls of a service, so that shutdown can drain them and know when they are over.
/// Once draining, it refuses new calls (the service answers them UNAVAILABLE).
class CallRegistry {
 public:
  /// False when draining: the caller must end the stream at once.
  bool add(DrainableStream* stream);
  void remove(DrainableStream* stream);
  /// A unary call begins (false when draining: refuse it) or has been finished.
  bool begin_unary();
  void end_unary();
  /// Refuses new calls and asks every open stream to drain.
  void drain_all();
  /// Waits until no stream and no unary call is open, or until `deadline`; true when idle.
  bool wait_idle(std::chrono::steady_clock::time_point deadline);

 private:
  std::mutex mutex_;
  std::condition_variable idle_;
  std::unordered_set<DrainableStream*> streams_;
  std::size_t unary_calls_ = 0;
  bool draining_ = false;
};

/// nearpoint.v1.DistanceService on the async generic server. Every method is raw: we parse the
/// requests ourselves (wire_parse.hpp), so that one that does not parse is answered
/// INVALID_ARGUMENT with the reason (gRPC's typed handlers answer a unary request UNIMPLEMENTED
/// without a message, and end a stream's reads like a half-close).
class DistanceServiceImpl final {
 public:
  /// `max_message_bytes`: the server's send limit; a report larger than that is answered with an
  /// error instead (see the service's send-time check).
  DistanceServiceImpl(SceneService& scenes, std::size_t max_message_bytes)
      : scenes_(scenes), max_message_bytes_(max_message_bytes) {}

  /// Routes the service's methods on `server` (before it starts). The unary methods parse their
  /// request, then run the typed handler of the same name in grpc_services.cpp. StreamPoses
  /// parses nearpoint.v1.PoseUpdate messages: one that does not parse ends the stream with
  /// INVALID_ARGUMENT once the updates read before it are answered. StreamPoseBatches is the same
  /// with PoseUpdateBatch and DistanceReportBatch messages, each update in a batch handled as if
  /// it had arrived alone. GetServerInfo answers set_server_info()'s description with the bound
  /// port filled in.
  void register_methods(AsyncGrpcServer& server);

  /// What GetServerInfo answers (set once, before the server starts); `port`: the bound gRPC
  /// port, known only after the bind, so set apart.
  void set_server_info(v1::ServerInfo info) { server_info_ = std::move(info); }
  void set_port(int port) { port_.store(port); }

  SceneService& scenes() { return scenes_; }
  CallRegistry& calls() { return calls_; }
  std::size_t max_message_bytes() const { return max_message_bytes_; }

 private:
  SceneService& scenes_;
  const std::size_t max_message_bytes_;
  CallRegistry calls_;
  std::atomic<std::uint64_t> next_stream_number_{1};
  v1::ServerInfo server_info_;
  std::atomic<int> port_{0};
};

/// nearpoint.v1.Diagnostics: Echo writes back every message it reads, one at a time (the
/// transport's floor, for benchmarks).
class DiagnosticsServiceImpl final {
 public:
  void register_methods(AsyncGrpcServer& server);
  CallRegistry& calls() { return calls_; }

 private:
  CallRegistry calls_;
};

}  // namespace nearpoint::server
