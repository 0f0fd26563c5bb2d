// SPDX-License-Identifier: Apache-2.0
// nearpointd's gRPC server: the DistanceService and Diagnostics services over one SceneService,
// plus health checking and reflection. ServerConfig's `workers` and `limits` describe the
// SceneService and apply to every transport. Used by main() and, in-process, by the tests and the
// service benchmark.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/limits.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "nearpoint/server/security.hpp"

namespace nearpoint::server {

/// What nearpointd is besides its gRPC configuration, for GetServerInfo: its release and build,
/// and the other transports this process serves. main() fills it; the server only reports it.
struct ProcessDescription {
  std::string version;  ///< "1.0.0" (nearpoint/version.hpp)
  bool built_grpc = false, built_dds = false, built_metrics = false;
  bool dds = false;  ///< --dds
  int dds_domain = 0;
  std::string dds_prefix;
  std::string metrics_listen;  ///< empty: no metrics endpoint
  int metrics_port = 0;        ///< the bound metrics port
};

struct ServerConfig {
  /// host:port to listen on. Port 0 picks a free port (see GrpcServer::port()).
  std::string listen = "127.0.0.1:50051";
  /// Geometry worker threads; 0 = one per hardware thread.
  std::size_t workers = 0;
  /// Threads serving gRPC's completion queue (every call's reads and writes, and the small
  /// evaluations a stream runs on the thread that read the update). One is the cheapest per
  /// message; more only help when one thread's share of a core is the limit.
  std::size_t grpc_threads = 1;
  ServiceLimits limits;
  /// Largest message received or sent, bytes. Larger requests fail with RESOURCE_EXHAUSTED.
  std::size_t max_message_bytes = kDefaultMaxMessageBytes;
  /// At shutdown, how long streams get to answer the updates already read before they are
  /// cancelled.
  std::chrono::milliseconds drain_timeout{5000};
  /// At shutdown, once the streams have ended, how long the connections stay open so that what
  /// the streams wrote (reports held back by HTTP/2 flow control, final statuses) reaches clients
  /// that are still reading; connections their clients close end sooner. gRPC's "write done"
  /// only means the transport took the bytes, so closing at once would drop them.
  std::chrono::milliseconds flush_timeout{1000};
  /// Serve nearpoint.v1.Diagnostics (the echo stream that measures the transport floor).
  bool diagnostics = true;
  /// TLS and the bearer token (load_server_security); empty: plaintext, no token.
  ServerSecurity security;
  /// Reported by GetServerInfo.
  ProcessDescription process;
};

class GrpcServer {
 public:
  /// Binds and starts serving, or says why it could not (the address is in use, malformed …).
  /// Serves `scenes` when given (shared with other transports, e.g. the DDS bridge); otherwise a
  /// SceneService of its own built from `config.limits` and `config.workers`.
  static Expected<std::unique_ptr<GrpcServer>> start(const ServerConfig& config,
                                                     std::shared_ptr<SceneService> scenes = {});
  /// Shuts down (see shutdown()) if still running.
  ~GrpcServer();

  /// The bound port (the chosen one when the configuration asked for port 0).
  int port() const;
  /// Graceful shutdown: health goes NOT_SERVING, new calls are refused, every open stream stops
  /// reading, answers the updates it has read and ends with UNAVAILABLE; streams still busy
  /// after `drain_timeout` are cancelled; then the connections get `flush_timeout` to deliver
  /// what was written before they are closed. Returns when every connection is closed.
  /// Idempotent and thread-safe.
  void shutdown();
  SceneService& scenes();

 private:
  GrpcServer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace nearpoint::server
