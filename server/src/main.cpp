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
// accepting, drain streams), exit status 0. Other exit statuses: the table both binaries share
// (nearpoint/model/exit_codes.hpp): 2 bad flags or configuration, 3 an address, a port or DDS
// unavailable, 1 any other failure. Every configured transport is checked and bound before any
// readiness signal (the port files, the `listening` line, health SERVING), so a supervisor never
// sees a start that then fails.
#include <netdb.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <thread>

#include "metrics.hpp"
#include "nearpoint/model/exit_codes.hpp"
#include "nearpoint/server/log.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "nearpoint/server/server.hpp"
#include "nearpoint/version.hpp"
#include "scene_file.hpp"
#if NEARPOINT_HAVE_DDS
#include "dds_bridge.hpp"
#endif
#if NEARPOINT_HAVE_GRPC
#include <absl/synchronization/mutex.h>
#endif

namespace {

using nearpoint::model::kExitOk;
using nearpoint::model::kExitUnavailable;
using nearpoint::model::kExitUsage;
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

#if NEARPOINT_HAVE_GRPC
/// Whether `listen` (host:port, [v6]:port) can be bound right now; asked only after gRPC failed to
/// start with TLS, to tell an address in use (exit 3) from a key that does not match its
/// certificate (exit 2), which gRPC reports alike.
bool address_bindable(const std::string& listen) {
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos) return false;
  std::string host = listen.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.empty() ? nullptr : host.c_str(), listen.substr(colon + 1).c_str(), &hints,
                  &found) != 0)
    return false;
  bool bound = false;
  for (addrinfo* a = found; a != nullptr && !bound; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (fd < 0) continue;
    const int on = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    bound = bind(fd, a->ai_addr, a->ai_addrlen) == 0;
    close(fd);
  }
  freeaddrinfo(found);
  return bound;
}
#endif

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
  std::vector<std::string> dds_joint_states;
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
  app.add_option("--grpc-threads", flags.config.grpc_threads,
                 "Threads serving gRPC's completion queue (1 costs least per message)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
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
                 "Topic prefix: <prefix>pose_updates, <prefix>distance_reports and "
                 "<prefix>threshold_events (rt/ + a ROS 2 namespace)")
      ->capture_default_str();
  app.add_option("--dds-history-depth", flags.dds_config.history_depth,
                 "Keep-last depth of the DDS readers and writers (ROS 2's default: 10)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--dds-joint-states", flags.dds_joint_states,
                 "SCENE[=TOPIC]: take sensor_msgs/JointState for the scene from TOPIC (default "
                 "/joint_states) and answer on the reports topic (repeatable; robot scenes)");
  app.add_flag("--dds-best-effort", flags.dds_config.best_effort,
               "Best-effort DDS topics (ROS 2's sensor data profile) instead of reliable");
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
  app.add_flag("--no-inline-evaluation{false}", flags.config.limits.inline_evaluation,
               "Evaluate every stream update on the worker pool, even a small one that would "
               "cost less on the thread that read it (then --workers bounds the geometry threads)");
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
      return kExitUsage;
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
    return kExitUsage;
  }
  if (!flags.metrics_listen.empty() && !flags.security.insecure &&
      !nearpoint::server::is_loopback_listen(flags.metrics_listen)) {
    nearpoint::server::log_error("start_failed")
        .kv("flag", "--metrics-listen")
        .kv("message", "'" + flags.metrics_listen +
                           "' is not a loopback address and metrics are plaintext HTTP: pass "
                           "--insecure to serve them there");
    return kExitUsage;
  }
#endif
  if (!flags.metrics_listen.empty() && !nearpoint::server::metrics::built_with_metrics()) {
    nearpoint::server::log_error("start_failed")
        .kv("flag", "--metrics-listen")
        .kv("message",
            "this nearpointd was built without metrics (NEARPOINT_WITH_METRICS=OFF): install "
            "prometheus-cpp-dev and rebuild, or drop --metrics-listen");
    return kExitUsage;
  }

  // The port files' directories, so that a path that cannot be written stops the start before
  // anything binds rather than after one port file is already out.
  for (const std::string* path : {&flags.port_file, &flags.metrics_port_file}) {
    if (path->empty()) continue;
    const std::string probe = *path + ".tmp";
    if (!std::ofstream(probe, std::ios::app)) {
      nearpoint::server::log_error("start_failed")
          .kv("flag", path == &flags.port_file ? "--port-file" : "--metrics-port-file")
          .kv("message", "cannot write '" + probe + "'");
      return kExitUsage;
    }
    std::error_code ignored;
    std::filesystem::remove(probe, ignored);
  }

#if NEARPOINT_HAVE_DDS
  // DDS's configuration now, before anything binds: `--dds` without CYCLONEDDS_URI must not
  // first write the port file and log `listening`.
  if (flags.dds) {
    for (const std::string& spec : flags.dds_joint_states) {
      nearpoint::server::Expected<nearpoint::server::JointStateBinding> binding =
          nearpoint::server::parse_joint_state_binding(spec, "--dds-joint-states");
      if (!binding) {
        nearpoint::server::log_error("start_failed")
            .kv("transport", "dds")
            .kv("field", binding.error().field)
            .kv("message", binding.error().message);
        return kExitUsage;
      }
      flags.dds_config.joint_states.push_back(std::move(binding.value()));
    }
    if (nearpoint::server::Outcome checked = nearpoint::server::check_dds_config(flags.dds_config);
        !checked) {
      nearpoint::server::log_error("start_failed")
          .kv("transport", "dds")
          .kv("field", checked.error().field)
          .kv("message", checked.error().message);
      return kExitUsage;
    }
  }
#endif
#if NEARPOINT_HAVE_DDS && !NEARPOINT_HAVE_GRPC
  if (!flags.dds) {
    nearpoint::server::log_error("start_failed")
        .kv("message",
            "this nearpointd was built without gRPC (NEARPOINT_WITH_GRPC=OFF): pass "
            "--dds to serve pose streams over DDS");
    return kExitUsage;
  }
#endif

  return kExitOk;
}

/// Loads the --scene files into `scenes` (before any transport serves, so that a client's first
/// update finds them); exit status 2 after logging why one could not be: a scene file that is
/// missing (refused by the flag's check) and one that is malformed are the same kind of failure.
int preload_scenes(SceneService& scenes, const std::vector<std::string>& files) {
  for (const std::string& file : files) {
    auto preloaded = nearpoint::server::preload_scene_file(scenes, file);
    if (!preloaded) {
      nearpoint::server::log_error("start_failed")
          .kv("scene_file", file)
          .kv("message", preloaded.error().describe());
      return kExitUsage;
    }
    nearpoint::server::log_info("scene_loaded")
        .kv("scene_file", file)
        .kv("scene_id", preloaded->scene_id)
        .kv("pairs", preloaded->pair_count);
  }

  return kExitOk;
}

/// Binds the metrics endpoint when --metrics-listen asks for it (its port goes to `port`); the
/// exit status after logging why it could not: 2 for a bad address, 3 when it cannot be bound.
int start_metrics_endpoint(const Flags& flags, SceneService& scenes, int& port) {
  if (!flags.metrics_listen.empty()) {
    auto serving = nearpoint::server::metrics::start_metrics(flags.metrics_listen, scenes);
    if (!serving) {
      nearpoint::server::log_error("start_failed")
          .kv("flag", serving.error().field)
          .kv("message", serving.error().message);
      return serving.error().code == nearpoint::server::ErrorCode::invalid_argument
                 ? kExitUsage
                 : kExitUnavailable;
    }
    port = serving.value();
  }

  return kExitOk;
}

/// The readiness signals, once every transport is up: the metrics and gRPC port files, then the
/// log lines. kExitUsage when a port file cannot be written (its path is configuration).
int announce(const Flags& flags, const SceneService& scenes, int metrics_port, int grpc_port) {
  if (!flags.metrics_listen.empty() && !flags.metrics_port_file.empty() &&
      !write_port_file(flags.metrics_port_file, metrics_port)) {
    nearpoint::server::log_error("start_failed")
        .kv("metrics_port_file", flags.metrics_port_file)
        .kv("message", "cannot write the metrics port file");
    return kExitUsage;
  }
#if NEARPOINT_HAVE_GRPC
  if (!flags.port_file.empty() && !write_port_file(flags.port_file, grpc_port)) {
    nearpoint::server::log_error("start_failed")
        .kv("port_file", flags.port_file)
        .kv("message", "cannot write the port file");
    return kExitUsage;
  }
#endif
  if (!flags.metrics_listen.empty())
    nearpoint::server::log_info("metrics_listening")
        .kv("metrics_listen", flags.metrics_listen)
        .kv("port", metrics_port)
        .kv("path", "/metrics");
#if NEARPOINT_HAVE_GRPC
  nearpoint::server::log_info("listening")
      .kv("version", nearpoint::kVersion)
      .kv("listen", flags.config.listen)
      .kv("port", grpc_port)
      .kv("workers", scenes.worker_count())
      .kv("max_streams", flags.config.limits.max_streams)
      .kv("max_in_flight", flags.config.limits.max_in_flight_per_stream)
      .kv("max_message_bytes", flags.config.max_message_bytes)
      .kv("tls", !flags.config.security.tls()                      ? "off"
                 : flags.config.security.tls_client_ca_pem.empty() ? "on"
                                                                   : "mutual")
      .kv("token", flags.config.security.token.empty() ? "off" : "required");
#else
  (void)grpc_port;
  (void)scenes;
#endif
  return kExitOk;
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

  nearpoint::server::log_info("starting")
      .kv("version", nearpoint::kVersion)
      .kv("grpc", nearpoint::kBuildOptions.grpc)
      .kv("dds", nearpoint::kBuildOptions.dds)
      .kv("metrics", nearpoint::kBuildOptions.metrics);
  // A scene whose reports could not be sent in one gRPC message is refused at creation.
  flags.config.limits.max_report_bytes = flags.config.max_message_bytes;
  auto scenes = std::make_shared<SceneService>(flags.config.limits, flags.config.workers);
  if (int code = preload_scenes(*scenes, flags.scene_files); code != kExitOk) return code;
  // Every transport is bound before any readiness signal: metrics, DDS, then gRPC, whose health
  // service reports SERVING as soon as it starts.
  int metrics_port = 0;
  if (int code = start_metrics_endpoint(flags, *scenes, metrics_port); code != kExitOk) return code;

  nearpoint::server::ProcessDescription& process = flags.config.process;
  process.version = nearpoint::kVersion;
  process.built_grpc = nearpoint::kBuildOptions.grpc;
  process.built_dds = nearpoint::kBuildOptions.dds;
  process.built_metrics = nearpoint::kBuildOptions.metrics;
  process.metrics_listen = flags.metrics_listen;
  process.metrics_port = metrics_port;
#if NEARPOINT_HAVE_DDS
  std::unique_ptr<nearpoint::server::DdsBridge> bridge;
  if (flags.dds) {
    auto bridged = nearpoint::server::DdsBridge::start(*scenes, flags.dds_config);
    if (!bridged) {
      nearpoint::server::log_error("start_failed")
          .kv("transport", "dds")
          .kv("field", bridged.error().field)
          .kv("message", bridged.error().message);
      nearpoint::server::metrics::stop_metrics();
      return bridged.error().code == nearpoint::server::ErrorCode::unavailable ? kExitUnavailable
                                                                               : kExitUsage;
    }
    bridge = std::move(bridged.value());
    process.dds = true;
    process.dds_domain = int(flags.dds_config.domain_id);
    process.dds_prefix = flags.dds_config.topic_prefix;
  }
#endif
  // Whatever fails from here on undoes what started.
  auto stop_all = [&] {
#if NEARPOINT_HAVE_DDS
    if (bridge) bridge->shutdown();
#endif
    nearpoint::server::metrics::stop_metrics();
  };

  int grpc_port = 0;
#if NEARPOINT_HAVE_GRPC
  auto started = nearpoint::server::GrpcServer::start(flags.config, scenes);
  if (!started) {
    // Unavailable (retry later) when the address is taken; with TLS, gRPC fails the same way for
    // a key that does not match its certificate, which is configuration.
    const bool bad_key = flags.config.security.tls() && address_bindable(flags.config.listen);
    nearpoint::server::log_error("start_failed")
        .kv("listen", flags.config.listen)
        .kv("message", bad_key ? "the TLS key (--tls-key) does not match the certificate "
                                 "(--tls-cert), or gRPC refused them"
                               : started.error().message);
    stop_all();
    return bad_key ? kExitUsage : kExitUnavailable;
  }
  nearpoint::server::GrpcServer& server = *started.value();
  grpc_port = server.port();
#endif
  if (int code = announce(flags, *scenes, metrics_port, grpc_port); code != kExitOk) {
#if NEARPOINT_HAVE_GRPC
    server.shutdown();
#endif
    stop_all();
    return code;
  }

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
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Flags flags;
  CLI::App app{"nearpointd: distances between registered geometries, over gRPC and DDS",
               "nearpointd"};
  app.set_version_flag("--version", std::string("nearpointd ") + nearpoint::kVersion);
  app.footer(std::string("\n") + nearpoint::model::kExitStatusHelp);
  add_transport_flags(app, flags);
  add_service_flags(app, flags);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);  // prints the help, the version or what is wrong
    return code == 0 ? kExitOk : kExitUsage;
  }
  if (int code = apply_flags(flags); code != kExitOk) return code;
#if NEARPOINT_HAVE_GRPC
  // Debian builds abseil without NDEBUG, so every absl::Mutex lock (all of gRPC's) also ran
  // abseil's debug-only deadlock detection: a global spin lock and a lock-graph update per lock,
  // 1-2 % of a pose update's CPU. It checks gRPC's internal lock order, not ours (TSan does).
  // Set here, for the process, not in the server library that tests and benchmarks embed.
  absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore);
#endif
  return serve(flags);
}
