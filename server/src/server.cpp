// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/server/server.hpp"

#include <grpcpp/grpcpp.h>

#include <mutex>

#include "grpc_async.hpp"
#include "grpc_health.hpp"
#include "grpc_reflection.hpp"
#include "grpc_security.hpp"
#include "grpc_services.hpp"
#include "nearpoint/server/log.hpp"

namespace nearpoint::server {

namespace {

/// Threads for unary requests, off the completion queue (a large geometry's hull, a scene's
/// pairs): two, so that one long request does not hold up every other.
constexpr int kControlThreads = 2;

/// GetServerInfo's answer, all but the bound port: the process's description, the gRPC
/// transport's security and the limits the scene service enforces.
v1::ServerInfo describe_server(const ServerConfig& config, const ServiceLimits& limits,
                               std::size_t workers) {
  const ProcessDescription& process = config.process;
  v1::ServerInfo info;
  info.set_version(process.version);
  v1::ServerInfo::BuildOptions& build = *info.mutable_build();
  build.set_grpc(process.built_grpc);
  build.set_dds(process.built_dds);
  build.set_metrics(process.built_metrics);
  v1::ServerInfo::Transports& transports = *info.mutable_transports();
  transports.set_grpc_listen(config.listen);
  transports.set_tls(!config.security.tls()                      ? "off"
                     : config.security.tls_client_ca_pem.empty() ? "on"
                                                                 : "mutual");
  transports.set_token_required(!config.security.token.empty());
  transports.set_dds(process.dds);
  if (process.dds) {
    transports.set_dds_domain(std::uint32_t(process.dds_domain));
    transports.set_dds_prefix(process.dds_prefix);
  }
  transports.set_metrics_listen(process.metrics_listen);
  transports.set_metrics_port(std::uint32_t(process.metrics_port));
  v1::ServerInfo::Limits& out = *info.mutable_limits();
  out.set_max_geometries(limits.max_geometries);
  out.set_max_pieces_per_geometry(limits.max_pieces_per_geometry);
  out.set_max_vertices_per_geometry(limits.max_vertices_per_geometry);
  out.set_max_scenes(limits.max_scenes);
  out.set_max_objects_per_scene(limits.max_objects_per_scene);
  out.set_max_pairs_per_scene(limits.max_pairs_per_scene);
  out.set_max_piece_pairs_per_scene(limits.max_piece_pairs_per_scene);
  out.set_max_streams(limits.max_streams);
  out.set_max_in_flight_per_stream(limits.max_in_flight_per_stream);
  out.set_max_concurrent_queries(limits.max_concurrent_queries);
  out.set_max_message_bytes(config.max_message_bytes);
  out.set_workers(std::uint32_t(workers));
  return info;
}

}  // namespace

struct GrpcServer::Impl {
  ServerConfig config;
  // Destroyed in reverse order: the gRPC server first (no call can reach the services any more),
  // then the services, then the scene service (whose pool finishes any queued work).
  std::shared_ptr<SceneService> scenes;
  std::unique_ptr<DistanceServiceImpl> distance;
  std::unique_ptr<DiagnosticsServiceImpl> diagnostics;
  std::unique_ptr<HealthStatus> health;
  std::unique_ptr<ServerReflection> reflection;
  // Every method's calls (grpc_async.hpp); stopped after the gRPC server has shut down, and
  // destroyed before the services it routes to.
  std::unique_ptr<AsyncGrpcServer> calls;
  std::unique_ptr<grpc::Server> server;
  int port = 0;
  std::mutex shutdown_mutex;
  bool shut_down = false;
};

GrpcServer::GrpcServer() : impl_(std::make_unique<Impl>()) {}

GrpcServer::~GrpcServer() {
  shutdown();
}

Expected<std::unique_ptr<GrpcServer>> GrpcServer::start(const ServerConfig& config,
                                                        std::shared_ptr<SceneService> scenes) {
  std::unique_ptr<GrpcServer> self(new GrpcServer());
  Impl& impl = *self->impl_;
  impl.config = config;
  if (!scenes) {
    // Scenes are refused when their reports could not be sent (ServiceLimits::max_report_bytes).
    ServiceLimits limits = config.limits;
    limits.max_report_bytes = std::min(limits.max_report_bytes, config.max_message_bytes);
    scenes = std::make_shared<SceneService>(limits, config.workers);
  }
  impl.scenes = std::move(scenes);
  impl.distance = std::make_unique<DistanceServiceImpl>(*impl.scenes, config.max_message_bytes);
  impl.distance->set_server_info(
      describe_server(config, impl.scenes->limits(), impl.scenes->worker_count()));
  if (config.diagnostics) impl.diagnostics = std::make_unique<DiagnosticsServiceImpl>();

  // No callback or sync service anywhere (grpc_async.hpp): gRPC's default health service is a
  // callback one and its reflection plugin a sync one, so both are served by us.
  grpc::EnableDefaultHealthCheckService(false);
  impl.health = std::make_unique<HealthStatus>();
  std::vector<std::string> services{v1::DistanceService::service_full_name()};
  if (impl.diagnostics) services.emplace_back(v1::Diagnostics::service_full_name());
  services.emplace_back(HealthStatus::kServiceName);
  impl.reflection = std::make_unique<ServerReflection>(std::move(services));
  grpc::ServerBuilder builder;
  // gRPC sets SO_REUSEPORT by default, which lets a second server bind a port already in use
  // without an error; we want "address in use" to be an error.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  const int max_message =
      static_cast<int>(std::min<std::size_t>(config.max_message_bytes, INT32_MAX));
  builder.SetMaxReceiveMessageSize(max_message);
  builder.SetMaxSendMessageSize(max_message);
  builder.AddListeningPort(config.listen, make_server_credentials(config.security), &impl.port);
  impl.calls = std::make_unique<AsyncGrpcServer>(builder);
  impl.distance->register_methods(*impl.calls);
  if (impl.diagnostics) impl.diagnostics->register_methods(*impl.calls);
  impl.health->register_methods(*impl.calls);
  impl.reflection->register_methods(*impl.calls);
  impl.server = builder.BuildAndStart();
  if (!impl.server || impl.port == 0) {
    if (impl.server) impl.server->Shutdown();
    impl.server.reset();
    impl.calls->stop();
    impl.shut_down = true;
    return Error{
        ErrorCode::unavailable, "listen",
        text("cannot listen on '", config.listen, "' (malformed, or the address is in use",
             config.security.tls() ? ", or the TLS key does not match the certificate" : "", ")")};
  }
  impl.distance->set_port(impl.port);
  impl.calls->start(int(std::max<std::size_t>(config.grpc_threads, 1)), kControlThreads);
  impl.health->set_serving("", true);
  impl.health->set_serving(v1::DistanceService::service_full_name(), true);
  return self;
}

int GrpcServer::port() const {
  return impl_->port;
}

SceneService& GrpcServer::scenes() {
  return *impl_->scenes;
}

void GrpcServer::shutdown() {
  std::lock_guard lock(impl_->shutdown_mutex);
  Impl& impl = *impl_;
  if (impl.shut_down) return;
  impl.shut_down = true;
  const auto begin = Clock::now();
  log_info("shutdown_begin")
      .kv("open_streams", impl.scenes->open_streams())
      .kv("drain_timeout_ms", impl.config.drain_timeout.count());
  // Health first, so that load balancers stop sending before the listener closes.
  impl.health->shutdown();
  // New calls are refused (UNAVAILABLE); every open stream stops reading, answers what it has
  // read and ends (UNAVAILABLE); unary calls in flight finish.
  impl.distance->calls().drain_all();
  if (impl.diagnostics) impl.diagnostics->calls().drain_all();
  impl.health->calls().drain_all();
  impl.reflection->calls().drain_all();
  const auto deadline = Clock::now() + impl.config.drain_timeout;
  bool drained = impl.distance->calls().wait_idle(deadline);
  drained = impl.health->calls().wait_idle(deadline) && drained;
  drained = impl.reflection->calls().wait_idle(deadline) && drained;
  if (impl.diagnostics) drained = impl.diagnostics->calls().wait_idle(deadline) && drained;
  // Our calls are over (or the drain timed out), but over means only that gRPC has taken their
  // last reports and final statuses: bytes held back by HTTP/2 flow control (a client that reads
  // slowly) are still in the transport, and closing the connections at once drops them (the
  // client sees "Broken pipe" and fewer reports than were written). So shut down gracefully:
  // GOAWAY, then give the transport flush_timeout to deliver while clients read and close their
  // connections; connections still open then (idle clients keep theirs) are closed by force.
  impl.server->Shutdown(std::chrono::system_clock::now() + impl.config.flush_timeout);
  impl.server->Wait();
  impl.calls->stop();
  log_info("shutdown_complete")
      .kv("drained", drained ? "all" : "timed_out")
      .kv("ms", std::chrono::duration<double, std::milli>(Clock::now() - begin).count());
}

}  // namespace nearpoint::server
