// SPDX-License-Identifier: Apache-2.0
// nearpoint_dds_bench: round-trip latency of one pose stream over gRPC and over DDS, against the
// same nearpointd process and the same scene, with each transport's floor measured in the same
// run:
//   dds ping-pong (floor) — 48-byte samples between this process and a pong child process, with
//                           the bridge's QoS (reliable, keep-last 64, volatile);
//   grpc echo (floor)     — nearpoint.v1.Diagnostics/Echo on the server;
//   grpc stream           — StreamPoses, warm starts;
//   dds stream            — PoseUpdate_ → DistanceReport_ through the DDS bridge, warm starts.
// Lock step: write one message, wait for its answer. nearpointd runs as a child process (as a
// robot would reach it), on 127.0.0.1:0 and the DDS domain given. Bounded: --updates round trips
// per row and --max-seconds per row. Needs CYCLONEDDS_URI (loopback configuration).
//
//   export CYCLONEDDS_URI=file://$PWD/deploy/cyclonedds-loopback.xml
//   nearpoint_dds_bench [--updates 2000] [--max-seconds 20] [--workers 2] [--domain 150]
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_scene.hpp"
#include "bench_support.hpp"
#include "common/child_process.hpp"
#include "dds_ping.h"
#include "dds_stream.hpp"
#include "nearpoint_diagnostics.grpc.pb.h"
#include "nearpoint_distance.grpc.pb.h"

namespace {

namespace v1 = ::nearpoint::v1;
namespace dds = ::nearpoint::dds;
using Clock = std::chrono::steady_clock;
using bench_support::cpu_model;
using bench_support::micros;
using bench_support::percentile;
using nearpoint::testkit::ChildProcess;

constexpr std::uint64_t kStopPong = ~std::uint64_t{0};

struct Row {
  const char* transport;
  const char* kind;
  std::vector<double> latency_us;
  double server_us = 0;    // mean, from the reports
  double geometry_us = 0;  // mean, from the reports
  std::string error;
};

dds_duration_t to_dds(Clock::duration d) {
  return std::max<dds_duration_t>(0,
                                  std::chrono::duration_cast<std::chrono::nanoseconds>(d).count());
}

// ---- raw DDS ping-pong ----

/// Two topics (<prefix>ping, <prefix>pong) with the bridge's QoS, on one participant.
struct PingEndpoints {
  dds_entity_t participant = 0, writer = 0, reader = 0, waitset = 0;
  ~PingEndpoints() {
    if (participant > 0) dds_delete(participant);
  }
  bool open(std::uint32_t domain, const std::string& prefix, bool pong) {
    participant = dds_create_participant(domain, nullptr, nullptr);
    if (participant < 0) return false;
    const dds::QosPtr qos = dds::stream_qos();
    const dds_entity_t ping = dds_create_topic(participant, &nearpoint_bench_Ping_desc,
                                               (prefix + "ping").c_str(), qos.get(), nullptr);
    const dds_entity_t pong_topic = dds_create_topic(participant, &nearpoint_bench_Ping_desc,
                                                     (prefix + "pong").c_str(), qos.get(), nullptr);
    if (ping < 0 || pong_topic < 0) return false;
    writer = dds_create_writer(participant, pong ? pong_topic : ping, qos.get(), nullptr);
    reader = dds_create_reader(participant, pong ? ping : pong_topic, qos.get(), nullptr);
    waitset = dds_create_waitset(participant);
    if (writer < 0 || reader < 0 || waitset < 0) return false;
    dds_set_status_mask(reader, DDS_DATA_AVAILABLE_STATUS);
    return dds_waitset_attach(waitset, reader, 0) >= 0;
  }
  /// Waits for one sample (up to `timeout`); false on timeout.
  bool take_one(nearpoint_bench_Ping& out, Clock::duration timeout) {
    const Clock::time_point deadline = Clock::now() + timeout;
    for (;;) {
      void* samples[1] = {&out};
      dds_sample_info_t info;
      if (dds_take(reader, samples, &info, 1, 1) == 1 && info.valid_data) return true;
      const Clock::time_point now = Clock::now();
      if (now >= deadline) return false;
      dds_waitset_wait(waitset, nullptr, 0, to_dds(deadline - now));
    }
  }
};

/// The pong child: echoes every ping until the stop sample (or 10 minutes, a bound in case the
/// parent dies).
int run_pong(std::uint32_t domain, const std::string& prefix) {
  PingEndpoints endpoints;
  if (!endpoints.open(domain, prefix, /*pong=*/true)) return 1;
  std::fprintf(stderr, "pong_ready\n");
  const Clock::time_point end = Clock::now() + std::chrono::minutes(10);
  nearpoint_bench_Ping ping{};
  while (Clock::now() < end) {
    if (!endpoints.take_one(ping, std::chrono::seconds(1))) continue;
    if (ping.sequence_number == kStopPong) return 0;
    dds_write(endpoints.writer, &ping);
  }
  return 0;
}

Row measure_ping_pong(std::uint32_t domain, const std::string& prefix, int updates,
                      Clock::time_point stop_at) {
  Row row{"DDS", "ping-pong, 48 B (floor)", {}, 0, 0, {}};
  PingEndpoints endpoints;
  if (!endpoints.open(domain, prefix, /*pong=*/false)) {
    row.error = "cannot create the ping endpoints";
    return row;
  }
  nearpoint_bench_Ping ping{}, pong{};
  // Until the pong's writer knows our reader, its echoes are lost (volatile): ping until one
  // comes back, then measure.
  bool connected = false;
  for (int attempt = 0; attempt < 100 && !connected; ++attempt) {
    ping.sequence_number = std::uint64_t(attempt);
    dds_write(endpoints.writer, &ping);
    connected = endpoints.take_one(pong, std::chrono::milliseconds(100));
  }
  if (!connected) {
    row.error = "the pong process never answered";
    return row;
  }
  while (endpoints.take_one(pong, std::chrono::milliseconds(50))) {  // drain late echoes
  }
  for (int k = 0; k < updates + 50 && Clock::now() < stop_at; ++k) {
    ping.sequence_number = 1000 + std::uint64_t(k);
    const Clock::time_point begin = Clock::now();
    dds_write(endpoints.writer, &ping);
    do {
      if (!endpoints.take_one(pong, std::chrono::seconds(5))) {
        row.error = "a ping was not answered within 5 s";
        return row;
      }
    } while (pong.sequence_number != ping.sequence_number);
    if (k >= 50) row.latency_us.push_back(micros(Clock::now() - begin));  // 50 warm-up
  }
  ping.sequence_number = kStopPong;
  dds_write(endpoints.writer, &ping);
  return row;
}

// ---- gRPC ----

Row measure_grpc_echo(const std::shared_ptr<grpc::Channel>& channel, int updates,
                      Clock::time_point stop_at) {
  Row row{"gRPC", "echo, empty (floor)", {}, 0, 0, {}};
  auto stub = v1::Diagnostics::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  auto stream = stub->Echo(&context);
  v1::EchoMessage message, echoed;
  for (int k = 0; k < updates + 50 && Clock::now() < stop_at; ++k) {
    message.set_sequence(std::uint64_t(k));
    const Clock::time_point begin = Clock::now();
    if (!stream->Write(message) || !stream->Read(&echoed)) {
      row.error = "echo stream failed";
      break;
    }
    if (k >= 50) row.latency_us.push_back(micros(Clock::now() - begin));
  }
  stream->WritesDone();
  stream->Finish();
  return row;
}

Row measure_grpc_stream(const std::shared_ptr<grpc::Channel>& channel, const std::string& scene,
                        int updates, Clock::time_point stop_at) {
  Row row{"gRPC", "pose stream, 45 pairs, warm", {}, 0, 0, {}};
  auto stub = v1::DistanceService::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  auto stream = stub->StreamPoses(&context);
  std::vector<v1::PoseUpdate> messages;
  for (int k = 0; k < updates + 50; ++k)
    messages.push_back(bench_support::pose_update(scene, std::uint64_t(k) + 1, k, 0));
  v1::DistanceReport report;
  for (int k = 0; k < updates + 50 && Clock::now() < stop_at; ++k) {
    const Clock::time_point begin = Clock::now();
    if (!stream->Write(messages[std::size_t(k)]) || !stream->Read(&report)) {
      row.error = "pose stream failed";
      break;
    }
    if (report.has_error()) {
      row.error = report.error().message();
      break;
    }
    if (k < 50) continue;
    row.latency_us.push_back(micros(Clock::now() - begin));
    row.server_us += report.timing().server_us();
    row.geometry_us += report.timing().geometry_us();
  }
  stream->WritesDone();
  while (stream->Read(&report)) {
  }
  stream->Finish();
  const double n = std::max<double>(1, double(row.latency_us.size()));
  row.server_us /= n;
  row.geometry_us /= n;
  return row;
}

// ---- DDS bridge ----

Row measure_dds_stream(std::uint32_t domain, const std::string& prefix, const std::string& scene,
                       int updates, Clock::time_point stop_at) {
  Row row{"DDS", "pose stream, 45 pairs, warm", {}, 0, 0, {}};
  nearpoint::cli::DdsPoseClient::Config config;
  config.domain_id = domain;
  config.topic_prefix = prefix;
  std::string error;
  auto client = nearpoint::cli::DdsPoseClient::create(config, error);
  if (!client || !client->wait_matched(std::chrono::seconds(10), error)) {
    row.error = error;
    return row;
  }
  std::vector<std::string> ids;
  for (int i = 0; i < 10; ++i) ids.push_back("object-" + std::to_string(i));
  std::vector<nearpoint_msgs_msg_dds__ObjectPose_> poses(10);
  std::string client_id = "dds-bench";
  for (int k = 0; k < updates + 50 && Clock::now() < stop_at; ++k) {
    for (int i = 0; i < 10; ++i) {
      const auto [q, t] = bench_scene::object_pose(i, k, 0);
      poses[std::size_t(i)].object_id = ids[std::size_t(i)].data();
      poses[std::size_t(i)].pose.position = {t.x(), t.y(), t.z()};
      poses[std::size_t(i)].pose.orientation = {q.x(), q.y(), q.z(), q.w()};
    }
    nearpoint::cli::PoseUpdateSample update{};
    update.scene_id = const_cast<char*>(scene.c_str());
    update.client_id = client_id.data();
    update.sequence_number = std::uint64_t(k) + 1;
    update.poses._buffer = poses.data();
    update.poses._length = update.poses._maximum = 10;
    update.poses._release = false;
    const Clock::time_point begin = Clock::now();
    if (!client->publish(update, error)) {
      row.error = error;
      break;
    }
    bool answered = false;
    double server_us = 0, geometry_us = 0;
    while (!answered) {
      const int got = client->take_reports(
          std::chrono::seconds(5),
          [&](const nearpoint::cli::DistanceReportSample& report) {
            if (report.sequence_number != update.sequence_number) return;
            answered = true;
            if (report.status != 0) error = report.message;
            server_us = report.timing.server_us;
            geometry_us = report.timing.geometry_us;
          },
          error);
      if (got <= 0) {
        row.error = got < 0 ? error : "no report within 5 s";
        return row;
      }
    }
    if (!error.empty()) {
      row.error = error;
      break;
    }
    if (k < 50) continue;
    row.latency_us.push_back(micros(Clock::now() - begin));
    row.server_us += server_us;
    row.geometry_us += geometry_us;
  }
  const double n = std::max<double>(1, double(row.latency_us.size()));
  row.server_us /= n;
  row.geometry_us /= n;
  return row;
}

int usage(int code) {
  std::fprintf(stderr,
               "usage: nearpoint_dds_bench [--updates N] [--max-seconds S] [--workers W] "
               "[--domain D]\n(CYCLONEDDS_URI must name a configuration, e.g. "
               "file://$PWD/deploy/cyclonedds-loopback.xml)\n");
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 4 && std::string(argv[1]) == "--pong")
    return run_pong(std::uint32_t(std::atoi(argv[2])), argv[3]);

  int updates = 2000;
  double max_seconds = 20;
  int workers = 2;
  std::uint32_t domain = 150;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) return usage(arg == "--help" || arg == "-h" ? 0 : 2);
    const char* value = argv[++i];
    if (arg == "--updates")
      updates = std::max(1, std::atoi(value));
    else if (arg == "--max-seconds")
      max_seconds = std::max(0.1, std::atof(value));
    else if (arg == "--workers")
      workers = std::max(0, std::atoi(value));
    else if (arg == "--domain")
      domain = std::uint32_t(std::clamp(std::atoi(value), 0, 230));
    else
      return usage(2);
  }
  if (std::string problem = dds::check_configuration(false); !problem.empty()) {
    std::fprintf(stderr, "nearpoint_dds_bench: %s\n", problem.c_str());
    return 2;
  }
  const std::string prefix = "rt/nearpoint_bench_" + std::to_string(getpid()) + "/";
  const std::filesystem::path port_file = std::filesystem::temp_directory_path() /
                                          ("nearpoint_dds_bench_port_" + std::to_string(getpid()));

  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file",
                       port_file.string(), "--workers", std::to_string(workers), "--dds",
                       "--dds-domain", std::to_string(domain), "--dds-prefix", prefix,
                       "--log-level", "info"});
  if (server.wait_for_stderr("event=listening", std::chrono::seconds(20)).empty() ||
      server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)).empty()) {
    std::fprintf(stderr, "nearpointd did not start:\n%s", server.stderr_text().c_str());
    return 1;
  }
  int port = 0;
  std::ifstream(port_file) >> port;
  std::filesystem::remove(port_file);
  ChildProcess pong({std::filesystem::read_symlink("/proc/self/exe").string(), "--pong",
                     std::to_string(domain), prefix});
  if (pong.wait_for_stderr("pong_ready", std::chrono::seconds(20)).empty()) {
    std::fprintf(stderr, "the pong process did not start:\n%s", pong.stderr_text().c_str());
    return 1;
  }

  // The scene, over gRPC.
  auto channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  auto stub = v1::DistanceService::NewStub(channel);
  v1::CreateSceneResponse scene;
  if (const std::string error = bench_support::create_scene(*stub, "dds-bench", scene);
      !error.empty()) {
    std::fprintf(stderr, "nearpoint_dds_bench: %s\n", error.c_str());
    return 1;
  }

  const auto row_budget =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(max_seconds));
  std::vector<Row> rows;
  rows.push_back(measure_ping_pong(domain, prefix, updates, Clock::now() + row_budget));
  rows.push_back(measure_grpc_echo(channel, updates, Clock::now() + row_budget));
  rows.push_back(
      measure_grpc_stream(channel, scene.scene_id(), updates, Clock::now() + row_budget));
  rows.push_back(
      measure_dds_stream(domain, prefix, scene.scene_id(), updates, Clock::now() + row_budget));

  std::printf("nearpoint_dds_bench, %s\n", bench_support::utc_date().c_str());
  std::printf(
      "machine: %s, %u hardware threads; nearpointd (child process) workers: %d; lock-step round "
      "trips, 1 stream, up to %d per row after 50 unmeasured\n\n",
      cpu_model().c_str(), std::thread::hardware_concurrency(), workers, updates);
  std::printf(
      "| transport | messages | round trips | p50 µs | p99 µs | server µs/update | geometry "
      "µs/update |\n|---|---|---:|---:|---:|---:|---:|\n");
  int failures = 0;
  for (const Row& row : rows) {
    const bool stream = row.server_us > 0;
    char server_us[32] = "–", geometry_us[32] = "–";
    if (stream) {
      std::snprintf(server_us, sizeof server_us, "%.0f", row.server_us);
      std::snprintf(geometry_us, sizeof geometry_us, "%.1f", row.geometry_us);
    }
    std::printf("| %s | %s | %zu | %.0f | %.0f | %s | %s |\n", row.transport, row.kind,
                row.latency_us.size(), percentile(row.latency_us, 0.5),
                percentile(row.latency_us, 0.99), server_us, geometry_us);
    if (!row.error.empty()) {
      std::printf("  error: %s\n", row.error.c_str());
      ++failures;
    }
  }
  server.signal(SIGTERM);
  const int server_exit = server.wait_exit(std::chrono::seconds(30));
  pong.wait_exit(std::chrono::seconds(5));
  if (server_exit != 0) {
    std::fprintf(stderr, "nearpointd exited with %d\n", server_exit);
    ++failures;
  }
  return failures == 0 ? 0 : 1;
}
