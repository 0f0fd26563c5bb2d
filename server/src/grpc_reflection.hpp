// SPDX-License-Identifier: Apache-2.0
// gRPC's server reflection protocol on AsyncGrpcServer, in place of
// grpc::reflection::InitProtoReflectionServerBuilderPlugin, whose service is a sync one and would
// double the CPU of every stream in the process (grpc_async.hpp says why). Served as both
// grpc.reflection.v1alpha and grpc.reflection.v1 (the same wire format; newer clients ask v1
// first), answered from protobuf's generated pool as gRPC's implementation does. The messages are
// proto/grpc/reflection_v1alpha.proto's.
#pragma once

#include <string>
#include <vector>

#include "grpc_async.hpp"
#include "grpc_services.hpp"
#include "reflection_v1alpha.pb.h"

namespace nearpoint::server {

/// Answers reflection requests. Thread-safe once constructed. Must outlive the AsyncGrpcServer it
/// is registered on (until stop() returns).
///
/// Shutdown: calls().drain_all() ends each open stream UNAVAILABLE once the response it is
/// writing (if any) is sent, and refuses new ones; then calls().wait_idle(deadline).
class ServerReflection {
 public:
  static constexpr const char* kServiceNameV1Alpha = "grpc.reflection.v1alpha.ServerReflection";
  static constexpr const char* kServiceNameV1 = "grpc.reflection.v1.ServerReflection";

  /// `services`: the fully qualified names list_services answers besides the two reflection
  /// services (which are always listed), e.g. "nearpoint.v1.DistanceService",
  /// "grpc.health.v1.Health".
  explicit ServerReflection(std::vector<std::string> services);
  ServerReflection(const ServerReflection&) = delete;
  ServerReflection& operator=(const ServerReflection&) = delete;

  /// Adds ServerReflectionInfo of both versions to `server` (before server.start()).
  void register_methods(AsyncGrpcServer& server);

  /// The response to one request (also what the stream sends).
  grpc::reflection::v1alpha::ServerReflectionResponse answer(
      const grpc::reflection::v1alpha::ServerReflectionRequest& request) const;

  const std::vector<std::string>& services() const { return services_; }
  /// The open streams, for the server's drain.
  CallRegistry& calls() { return calls_; }

 private:
  std::vector<std::string> services_;
  CallRegistry calls_;
};

}  // namespace nearpoint::server
