// SPDX-License-Identifier: Apache-2.0
// The gRPC adapters: DistanceService and Diagnostics as callback services (one reactor class per
// streaming RPC, state in members, OnDone cleans up — as in gRPC's route_guide example).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <unordered_set>

#include "nearpoint/server/scene_service.hpp"
#include "nearpoint_diagnostics.grpc.pb.h"
#include "nearpoint_distance.grpc.pb.h"

namespace nearpoint::server {

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

/// DistanceService with every method raw (requests and responses as grpc::ByteBuffer). With
/// the generated typed handlers gRPC parses before our code runs: a unary request that does not
/// parse is answered UNIMPLEMENTED without a message (read as "no such method"), and a stream
/// message that does not parse ends the reads like a half-close, so the stream ended OK. Parsing
/// ourselves (wire_parse.hpp) answers INVALID_ARGUMENT with the reason instead.
using RawDistanceService = v1::DistanceService::WithRawCallbackMethod_RegisterGeometry<
    v1::DistanceService::WithRawCallbackMethod_RemoveGeometry<
        v1::DistanceService::WithRawCallbackMethod_ListGeometries<
            v1::DistanceService::WithRawCallbackMethod_CreateScene<
                v1::DistanceService::WithRawCallbackMethod_DeleteScene<
                    v1::DistanceService::WithRawCallbackMethod_ListScenes<
                        v1::DistanceService::WithRawCallbackMethod_Query<
                            v1::DistanceService::WithRawCallbackMethod_StreamPoses<
                                v1::DistanceService::WithRawCallbackMethod_StreamPoseBatches<
                                    v1::DistanceService::WithRawCallbackMethod_GetServerInfo<
                                        v1::DistanceService::Service>>>>>>>>>>;

class DistanceServiceImpl final : public RawDistanceService {
 public:
  /// `max_message_bytes`: the server's send limit; a report larger than that is answered with an
  /// error instead (see the service's send-time check).
  DistanceServiceImpl(SceneService& scenes, std::size_t max_message_bytes)
      : scenes_(scenes), max_message_bytes_(max_message_bytes) {}

  // Each parses its request (INVALID_ARGUMENT when it does not parse), then runs the typed
  // handler of the same name in grpc_services.cpp.
  grpc::ServerUnaryReactor* RegisterGeometry(grpc::CallbackServerContext* context,
                                             const grpc::ByteBuffer* request,
                                             grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* RemoveGeometry(grpc::CallbackServerContext* context,
                                           const grpc::ByteBuffer* request,
                                           grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* ListGeometries(grpc::CallbackServerContext* context,
                                           const grpc::ByteBuffer* request,
                                           grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* CreateScene(grpc::CallbackServerContext* context,
                                        const grpc::ByteBuffer* request,
                                        grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* DeleteScene(grpc::CallbackServerContext* context,
                                        const grpc::ByteBuffer* request,
                                        grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* ListScenes(grpc::CallbackServerContext* context,
                                       const grpc::ByteBuffer* request,
                                       grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* Query(grpc::CallbackServerContext* context,
                                  const grpc::ByteBuffer* request,
                                  grpc::ByteBuffer* response) override;
  /// Messages are parsed as nearpoint.v1.PoseUpdate; one that does not parse ends the stream
  /// with INVALID_ARGUMENT once the updates read before it are answered.
  grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* StreamPoses(
      grpc::CallbackServerContext* context) override;
  /// StreamPoses with nearpoint.v1.PoseUpdateBatch and DistanceReportBatch messages: the same
  /// reactor, each update in a batch handled as if it had arrived alone.
  grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* StreamPoseBatches(
      grpc::CallbackServerContext* context) override;
  /// Answers set_server_info()'s description with the bound port filled in.
  grpc::ServerUnaryReactor* GetServerInfo(grpc::CallbackServerContext* context,
                                          const grpc::ByteBuffer* request,
                                          grpc::ByteBuffer* response) override;

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

class DiagnosticsServiceImpl final : public v1::Diagnostics::CallbackService {
 public:
  grpc::ServerBidiReactor<v1::EchoMessage, v1::EchoMessage>* Echo(
      grpc::CallbackServerContext* context) override;
  CallRegistry& calls() { return calls_; }

 private:
  CallRegistry calls_;
};

}  // namespace nearpoint::server
