// SPDX-License-Identifier: Apache-2.0
// gRPC's health checking protocol (grpc.health.v1.Health: Check and Watch) on AsyncGrpcServer,
// in place of grpc::EnableDefaultHealthCheckService, which is a callback service on gRPC 1.51
// and would double the CPU of every stream in the process (grpc_async.hpp says why).
//
// The two messages are read and written by hand: HealthCheckRequest { string service = 1; } and
// HealthCheckResponse { ServingStatus status = 1; } (proto/grpc/health_v1.proto is their schema,
// compiled in for server reflection only).
#pragma once

#include <grpcpp/support/status.h>

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>

#include "grpc_async.hpp"
#include "grpc_services.hpp"

namespace nearpoint::server {

/// HealthCheckResponse.ServingStatus, with the protocol's numbers.
enum class ServingStatus : std::uint8_t {
  unknown = 0,
  serving = 1,
  not_serving = 2,
  service_unknown = 3,  // Watch only: Check answers NOT_FOUND instead
};

/// HealthCheckRequest's `service`, or why the bytes are not a HealthCheckRequest (unknown fields
/// are skipped, as protobuf does).
struct HealthCheckRequest {
  std::string service;
};
std::optional<HealthCheckRequest> parse_health_check_request(std::string_view bytes,
                                                             std::string& why_not);
/// HealthCheckResponse { status } in protobuf's wire format.
std::string serialize_health_check_response(ServingStatus status);

class HealthWatchReactor;

/// The serving status of the server ("") and of each service, served as grpc.health.v1.Health.
/// Thread-safe. Must outlive the AsyncGrpcServer it is registered on (until stop() returns).
///
/// Shutdown, in order: shutdown() (every status NOT_SERVING; watchers are told), then
/// calls().drain_all() (each watcher sends NOT_SERVING unless it has, then ends UNAVAILABLE; new
/// Watch calls are refused UNAVAILABLE), then calls().wait_idle(deadline). Check keeps answering
/// (NOT_SERVING) until the gRPC server stops accepting calls, so that a load balancer probing
/// during the drain reads NOT_SERVING rather than an error.
class HealthStatus {
 public:
  static constexpr const char* kServiceName = "grpc.health.v1.Health";
  static constexpr const char* kCheckMethod = "/grpc.health.v1.Health/Check";
  static constexpr const char* kWatchMethod = "/grpc.health.v1.Health/Watch";

  HealthStatus() = default;
  HealthStatus(const HealthStatus&) = delete;
  HealthStatus& operator=(const HealthStatus&) = delete;

  /// Adds Check and Watch to `server` (before server.start()).
  void register_methods(AsyncGrpcServer& server);

  /// `service` ("" for the server as a whole) is SERVING or NOT_SERVING from now on; watchers of
  /// it are told. A service never set is unknown (Check: NOT_FOUND; Watch: SERVICE_UNKNOWN).
  /// Ignored after shutdown().
  void set_serving(const std::string& service, bool serving);
  /// Every known service NOT_SERVING from now on (watchers are told), and set_serving ignored:
  /// what grpc::HealthCheckServiceInterface::Shutdown does. Idempotent.
  void shutdown();

  /// The status Watch would send for `service` now.
  ServingStatus status(const std::string& service) const;

  /// The open Watch streams, for the server's drain.
  CallRegistry& calls() { return calls_; }

 private:
  friend class HealthWatchReactor;
  /// Adds `watcher` and tells it the current status of its service (under mutex_, so that no
  /// change can come between the two).
  void subscribe(HealthWatchReactor* watcher);
  void unsubscribe(HealthWatchReactor* watcher);
  ServingStatus status_locked(const std::string& service) const;
  void publish_locked(const std::string& service, ServingStatus status);

  mutable std::mutex mutex_;  // before any watcher's own mutex
  std::map<std::string, bool> serving_;
  bool shut_down_ = false;
  std::unordered_set<HealthWatchReactor*> watchers_;
  CallRegistry calls_;
};

}  // namespace nearpoint::server
