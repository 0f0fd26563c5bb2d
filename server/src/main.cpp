// SPDX-License-Identifier: Apache-2.0
// nearpointd: the nearpoint distance server, over gRPC and/or DDS (whichever the build has).
//
//   nearpointd [--listen 127.0.0.1:50051] [--workers N] [--port-file PATH] [limits…]
//   nearpointd --dds [--dds-domain 0] [--dds-prefix rt/nearpoint/]   (needs CYCLONEDDS_URI)
//   nearpointd --config nearpointd.toml
//   nearpointd --scene cell.json [--scene other.yaml]   (preloads scenes under their ids)
//   nearpointd --listen 0.0.0.0:50051 --tls-cert server.pem --tls-key server.key
//              [--tls-client-ca clients-ca.pem] [--token-file token]   (or --insecure)
//   nearpointd --metrics-listen 127.0.0.1:9464   (Prometheus text at /metrics; off by default)
//
// Both transports serve one SceneService: a scene created over gRPC is streamed to over DDS.
// Logs one key=value line per event to stderr. SIGTERM or SIGINT: graceful shutdown (stop
// accepting, drain streams), exit status 0. Exit status 1: could not start; 2: bad flags.
#include <signal.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <thread>

#include "metrics.hpp"
#include "nearpoint/server/log.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "nearpoint/server/server.hpp"
#include "scene_file.hpp"
#if NEARPOINT_HAVE_DDS
#include "dds_bridge.hpp"
#endif

namespace {

using nearpoint::server::LogLevel;
using nearpoint::server::SceneService;
using nearpoint::server::ServerConfig;

/// Writes the port atomically (temporary file, then rename), so a reader never sees a partial
/// number.
bool write_port_file(const std::string& path, int port) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::trunc);
    if (!(out << port << '\n')) return false;
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  return !error;
}

/// nearpointd's command line, as parsed.
struct Flags {
  ServerConfig config;
  std::string port_file;
  std::string metrics_listen;
  std::string metrics_port_file;
  std::string log_level = "info";
  long long drain_timeout_ms = config.drain_timeout.count();
  long long flush_timeout_ms = config.flush_timeout.count();
  bool no_diagnostics = false;
  std::vector<std::string> scene_files;
#if NEARPOINT_HAVE_GRPC
  // Transport security (issue 23): checked before anything binds (load_server_security).
  nearpoint::server::SecurityFlags security;
#endif
#if NEARPOINT_HAVE_DDS
  bool dds = false;
  nearpoint::server::DdsConfig dds_config;
#endif
};

/// The flags of the transports, their security and the metrics endpoint.
void add_transport_flags(CLI::App& app, Flags& flags) {
  app.set_config("--config", "", "Read these options from a TOML or INI file");
  app.add_option("--workers", flags.config.workers, "Geometry worker threads (0: one per core)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1024));
#if NEARPOINT_HAVE_GRPC
  app.add_option("--listen", flags.config.listen, "host:port to listen on (port 0: any free port)")
      ->capture_default_str()
      ->envname("NEARPOINT_LISTEN");
  app.add_option("--port-file", flags.port_file,
                 "Write the bound port to this file once listening");
  app.add_option("--max-message-bytes", flags.config.max_message_bytes,
                 "Largest gRPC message received or sent")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t(1024), std::size_t(INT32_MAX)));
  // Each also from the environment (a container's configuration): NEARPOINT_LISTEN,
  // NEARPOINT_TLS_CERT, NEARPOINT_TLS_KEY, NEARPOINT_TLS_CLIENT_CA, NEARPOINT_TOKEN_FILE,
  // NEARPOINT_INSECURE (1 or true; 0 or false leaves it off); a flag wins over its variable.
  app.add_option("--tls-cert", flags.security.tls_cert,
                 "PEM certificate chain: serve gRPC over TLS only (with --tls-key)")
      ->envname("NEARPOINT_TLS_CERT");
  app.add_option("--tls-key", flags.security.tls_key, "PEM private key of --tls-cert")
      ->envname("NEARPOINT_TLS_KEY");
  app.add_option("--tls-client-ca", flags.security.tls_client_ca,
                 "PEM CA certificates: require client certificates they signed (mutual TLS)")
      ->envname("NEARPOINT_TLS_CLIENT_CA");
  app.add_option("--token-file", flags.security.token_file,
                 "File holding the bearer token every call but health checks must carry "
                 "(authorization: Bearer ...); needs TLS")
      ->envname("NEARPOINT_TOKEN_FILE");
  app.add_flag("--insecure", flags.security.insecure,
               "Allow plaintext on a non-loopback --listen address (without it, TLS is required "
               "there)")
      ->envname("NEARPOINT_INSECURE");
#endif
  app.add_option("--metrics-listen", flags.metrics_listen,
                 "Serve Prometheus metrics (plaintext HTTP, /metrics) on this IP:PORT (port 0: any "
                 "free port); off when empty. A non-loopback address needs --insecure")
      ->envname("NEARPOINT_METRICS_LISTEN");
  app.add_option("--metrics-port-file", flags.metrics_port_file,
                 "Write the bound metrics port to this file once serving");
#if NEARPOINT_HAVE_DDS
  app.add_flag("--dds", flags.dds,
               "Serve pose streams over DDS too (Cyclone DDS; needs CYCLONEDDS_URI, e.g. "
               "file://$PWD/deploy/cyclonedds-loopback.xml)");
  app.add_option("--dds-domain", flags.dds_config.domain_id, "DDS domain id")
      ->capture_default_str()
      ->check(CLI::Range(0, 230));
  app.add_option("--dds-prefix", flags.dds_config.topic_prefix,
                 "Topic prefix: <prefix>pose_updates and <prefix>distance_reports")
      ->capture_default_str();
  app.add_flag("--dds-allow-default-config", flags.dds_config.allow_default_config,
               "Start DDS without CYCLONEDDS_URI (Cyclone's defaults use the external network "
               "interface and multicast)");
#endif
}

/// The flags of the service's limits, shutdown, preloaded scenes and logs.
void add_service_flags(CLI::App& app, Flags& flags) {
  app.add_option("--max-geometries", flags.config.limits.max_geometries, "Stored geometries")
      ->capture_default_str();
  app.add_option("--max-pieces-per-geometry", flags.config.limits.max_pieces_per_geometry,
                 "Convex pieces of one geometry")
      ->capture_default_str();
  app.add_option("--max-vertices-per-geometry", flags.config.limits.max_vertices_per_geometry,
                 "Polytope vertices of one geometry, over its pieces")
      ->capture_default_str();
  app.add_option("--max-scenes", flags.config.limits.max_scenes, "Live scenes")
      ->capture_default_str();
  app.add_option("--max-objects-per-scene", flags.config.limits.max_objects_per_scene,
                 "Objects of one scene")
      ->capture_default_str();
  app.add_option("--max-pairs-per-scene", flags.config.limits.max_pairs_per_scene,
                 "Selected object pairs of one scene")
      ->capture_default_str();
  app.add_option("--max-piece-pairs-per-scene", flags.config.limits.max_piece_pairs_per_scene,
                 "Piece pairs of one scene (36 bytes of cache each, per stream)")
      ->capture_default_str();
  app.add_option("--max-streams", flags.config.limits.max_streams, "Concurrent pose streams")
      ->capture_default_str();
  app.add_option("--max-in-flight", flags.config.limits.max_in_flight_per_stream,
                 "Updates a stream may have read but not yet answered")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  app.add_option("--max-concurrent-queries", flags.config.limits.max_concurrent_queries,
                 "Unary queries evaluated at once")
      ->capture_default_str();
  app.add_option("--drain-timeout-ms", flags.drain_timeout_ms,
                 "At shutdown, time streams get to answer what they have read")
      ->capture_default_str()
      ->check(CLI::Range(0LL, 600'000LL));
  app.add_option("--flush-timeout-ms", flags.flush_timeout_ms,
                 "At shutdown, after the streams have ended, time their connections get to "
                 "deliver what was written before they are closed")
      ->capture_default_str()
      ->check(CLI::Range(0LL, 600'000LL));
  app.add_option("--scene", flags.scene_files,
                 "Preload a scene file (JSON or YAML, as for `nearpoint scene create`) under the "
                 "id it requests; repeatable (how a DDS-only client gets its scene)")
      ->check(CLI::ExistingFile);
#if NEARPOINT_HAVE_GRPC
  app.add_flag("--no-diagnostics", flags.no_diagnostics,
               "Do not serve nearpoint.v1.Diagnostics (Echo)");
#endif
  app.add_option("--log-level", flags.log_level, "debug, info, warn or error")
      ->capture_default_str()
      ->check(CLI::IsMember({"debug", "info", "warn", "error"}));
}

/// Applies the parsed flags (log level, timeouts, TLS and token files) and checks what CLI11
/// cannot; 0, or the exit status 2 after logging which flag is wrong.
int apply_flags(Flags& flags) {
  LogLevel level = LogLevel::info;
  nearpoint::server::parse_log_level(flags.log_level, level);
  nearpoint::server::set_log_level(level);
  flags.config.drain_timeout = std::chrono::milliseconds(flags.drain_timeout_ms);
  flags.config.flush_timeout = std::chrono::milliseconds(flags.flush_timeout_ms);
  flags.config.diagnostics = !flags.no_diagnostics;
#if NEARPOINT_HAVE_GRPC
  {
    auto security = nearpoint::server::load_server_security(flags.security, flags.config.listen);
    if (!security) {
      nearpoint::server::log_error("start_failed")
          .kv("flag", security.error().field)
          .kv("message", security.error().message);
      return 2;
    }
    flags.config.security = std::move(security.value());
  }
  // The metrics endpoint is plaintext HTTP whatever the gRPC port uses, so off this machine it
  // needs the same acknowledgement as a plaintext --listen.
  if (nearpoint::server::Outcome shape =
          nearpoint::server::metrics::check_metrics_listen(flags.metrics_listen);
      !flags.metrics_listen.empty() && !shape) {
    nearpoint::server::log_error("start_failed")
        .kv("flag", "--metrics-listen")
        .kv("message", shape.error().message);
    return 2;
  }
  if (!flags.metrics_listen.empty() && !flags.security.insecure &&
      !nearpoint::server::is_loopback_listen(flags.metrics_listen)) {
    nearpoint::server::log_error("start_failed")
        .kv("flag", "--metrics-listen")
        .kv("message", "'" + flags.metrics_listen +
                           "' is not a loopback address and metrics are plaintext HTTP: pass "
                           "--insecure to serve them there");
    return 2;
  }
#endif
  if (!flags.metrics_listen.empty() && !nearpoint::server::metrics::built_with_metrics()) {
    nearpoint::server::log_error("start_failed")
        .kv("flag", "--metrics-listen")
        .kv("message",
            "this nearpointd was built without metrics (NEARPOINT_WITH_METRICS=OFF): install "
            "prometheus-cpp-dev and rebuild, or drop --metrics-listen");
    return 2;
  }

  return 0;
}

/// Loads the --scene files into `scenes` (before any transport serves, so that a client's first
/// update finds them); 1 after logging why one could not be.
int preload_scenes(SceneService& scenes, const std::vector<std::string>& files) {
  for (const std::string& file : files) {
    auto preloaded = nearpoint::server::preload_scene_file(scenes, file);
    if (!preloaded) {
      nearpoint::server::log_error("start_failed")
          .kv("scene_file", file)
          .kv("message", preloaded.error().describe());
      return 1;
    }
    nearpoint::server::log_info("scene_loaded")
        .kv("scene_file", file)
        .kv("scene_id", preloaded->scene_id)
        .kv("pairs", preloaded->pair_count);
  }

  return 0;
}

/// Serves the metrics endpoint when --metrics-listen asks for it; the exit status (1, or 2 for a
/// bad address) after logging why it could not.
int start_metrics_endpoint(const Flags& flags, SceneService& scenes) {
  if (!flags.metrics_listen.empty()) {
    auto serving = nearpoint::server::metrics::start_metrics(flags.metrics_listen, scenes);
    if (!serving) {
      nearpoint::server::log_error("start_failed")
          .kv("flag", serving.error().field)
          .kv("message", serving.error().message);
      return serving.error().code == nearpoint::server::ErrorCode::invalid_argument ? 2 : 1;
    }
    if (!flags.metrics_port_file.empty() &&
        !write_port_file(flags.metrics_port_file, serving.value())) {
      nearpoint::server::log_error("start_failed")
          .kv("metrics_port_file", flags.metrics_port_file)
          .kv("message", "cannot write the metrics port file");
      return 1;
    }
    nearpoint::server::log_info("metrics_listening")
        .kv("metrics_listen", flags.metrics_listen)
        .kv("port", serving.value())
        .kv("path", "/metrics");
  }

  return 0;
}

/// Serves until SIGTERM or SIGINT, then shuts down gracefully; the exit status.
int serve(Flags& flags) {
  // Block the shutdown signals in every thread (gRPC's and the pool's inherit this mask); this
  // thread then waits for them synchronously, outside any signal handler.
  sigset_t shutdown_signals;
  sigemptyset(&shutdown_signals);
  sigaddset(&shutdown_signals, SIGTERM);
  sigaddset(&shutdown_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &shutdown_signals, nullptr);

  // A scene whose reports could not be sent in one gRPC message is refused at creation.
  flags.config.limits.max_report_bytes = flags.config.max_message_bytes;
  auto scenes = std::make_shared<SceneService>(flags.config.limits, flags.config.workers);
  if (int code = preload_scenes(*scenes, flags.scene_files); code != 0) return code;
  if (int code = start_metrics_endpoint(flags, *scenes); code != 0) return code;

#if NEARPOINT_HAVE_GRPC
  auto started = nearpoint::server::GrpcServer::start(flags.config, scenes);
  if (!started) {
    nearpoint::server::log_error("start_failed")
        .kv("listen", flags.config.listen)
        .kv("message", started.error().message);
    return 1;
  }
  nearpoint::server::GrpcServer& server = *started.value();
  if (!flags.port_file.empty() && !write_port_file(flags.port_file, server.port())) {
    nearpoint::server::log_error("start_failed")
        .kv("port_file", flags.port_file)
        .kv("message", "cannot write the port file");
    server.shutdown();
    return 1;
  }
  nearpoint::server::log_info("listening")
      .kv("listen", flags.config.listen)
      .kv("port", server.port())
      .kv("workers", scenes->worker_count())
      .kv("max_streams", flags.config.limits.max_streams)
      .kv("max_in_flight", flags.config.limits.max_in_flight_per_stream)
      .kv("max_message_bytes", flags.config.max_message_bytes)
      .kv("tls", !flags.config.security.tls()                      ? "off"
                 : flags.config.security.tls_client_ca_pem.empty() ? "on"
                                                                   : "mutual")
      .kv("token", flags.config.security.token.empty() ? "off" : "required");
#endif
#if NEARPOINT_HAVE_DDS
  std::unique_ptr<nearpoint::server::DdsBridge> bridge;
  if (flags.dds) {
    auto bridged = nearpoint::server::DdsBridge::start(*scenes, flags.dds_config);
    if (!bridged) {
      nearpoint::server::log_error("start_failed")
          .kv("transport", "dds")
          .kv("field", bridged.error().field)
          .kv("message", bridged.error().message);
#if NEARPOINT_HAVE_GRPC
      server.shutdown();
#endif
      return 1;
    }
    bridge = std::move(bridged.value());
  }
#if !NEARPOINT_HAVE_GRPC
  if (!bridge) {
    nearpoint::server::log_error("start_failed")
        .kv("message",
            "this nearpointd was built without gRPC (NEARPOINT_WITH_GRPC=OFF): pass "
            "--dds to serve pose streams over DDS");
    return 2;
  }
#endif
#endif

  int signal_number = 0;
  sigwait(&shutdown_signals, &signal_number);
  nearpoint::server::log_info("signal").kv("signal",
                                           signal_number == SIGTERM ? "SIGTERM" : "SIGINT");
  // DDS first: it answers the updates it has taken while the gRPC streams are still served.
#if NEARPOINT_HAVE_DDS
  if (bridge) bridge->shutdown();
#endif
#if NEARPOINT_HAVE_GRPC
  server.shutdown();
#endif
  // Last: a scrape during the drain still sees the streams end.
  nearpoint::server::metrics::stop_metrics();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Flags flags;
  CLI::App app{"nearpointd: distances between registered geometries, over gRPC and DDS"};
  add_transport_flags(app, flags);
  add_service_flags(app, flags);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);
    return code == 0 ? 0 : 2;
  }
  if (int code = apply_flags(flags); code != 0) return code;
  return serve(flags);
}
