// SPDX-License-Identifier: Apache-2.0
// nearpoint_service_bench: end-to-end latency and throughput of pose streams against nearpointd.
//
// Starts the server in-process on 127.0.0.1:0 (the same GrpcServer that nearpointd runs), registers
// a scene of 10 paper-family polytopes (12–100 vertices, 45 pairs) and, for 1, 4 and 16
// concurrent streams, sends poses along a smooth trajectory in lock step (write an update, wait
// for its report), measuring each round trip on the client. Three kinds of stream, measured in
// the same run:
//   echo  — nearpoint.v1.Diagnostics/Echo with an empty message: the transport floor;
//   warm  — StreamPoses with warm-start caches (paper, Section VIII);
//   cold  — StreamPoses with options.warm_start = false (every pair starts from one point).
// Bounded: --updates round trips per stream and --max-seconds per configuration.
//
//   nearpoint_service_bench [--updates 2000] [--max-seconds 20] [--workers 0] [--streams 1,4,16]
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_scene.hpp"
#include "bench_support.hpp"
#include "nearpoint/server/log.hpp"
#include "nearpoint/server/server.hpp"
#include "nearpoint_diagnostics.grpc.pb.h"
#include "nearpoint_distance.grpc.pb.h"

namespace {

namespace v1 = ::nearpoint::v1;
using Clock = std::chrono::steady_clock;
using Vec3 = Eigen::Vector3d;
using bench_support::cpu_model;
using bench_support::micros;
using bench_support::percentile;

/// The update of the 10 objects at `step`, warm-started or not.
v1::PoseUpdate make_update(const std::string& scene, std::uint64_t sequence, int step, double phase,
                           bool warm) {
  v1::PoseUpdate update = bench_support::pose_update(scene, sequence, step, phase);
  update.mutable_options()->set_warm_start(warm);
  return update;
}

// ---- measurement ----

enum class Kind { echo, warm, cold };
const char* name(Kind kind) {
  return kind == Kind::echo ? "echo (floor)" : kind == Kind::warm ? "warm" : "cold";
}

struct StreamResult {
  std::vector<double> latency_us;
  double geometry_us = 0;    // sum over reports of server geometry time
  double evaluation_us = 0;  // sum over reports of server wall time on the pool
  double server_us = 0;      // sum over reports of server time (arrival → report ready)
  long iterations = 0;
  long pairs = 0;
  long warm_pairs = 0;
  long intersecting = 0;
  bool failed = false;
  std::string error;
};

struct Row {
  Kind kind = Kind::echo;
  int streams = 1;
  std::size_t updates = 0;
  double seconds = 0;
  double p50 = 0, p99 = 0;
  double geometry_us = 0, evaluation_us = 0, server_us = 0;
  double iterations_per_pair = 0, warm_fraction = 0, intersecting_fraction = 0;
  std::string error;
};

StreamResult run_stream(const std::shared_ptr<grpc::Channel>& channel, const std::string& scene,
                        Kind kind, int stream_index, int updates, Clock::time_point stop_at) {
  StreamResult result;
  result.latency_us.reserve(std::size_t(updates));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  const double phase = 0.37 * stream_index;
  if (kind == Kind::echo) {
    auto stub = v1::Diagnostics::NewStub(channel);
    auto stream = stub->Echo(&context);
    v1::EchoMessage message, echoed;
    for (int step = 0; step < updates && Clock::now() < stop_at; ++step) {
      message.set_sequence(std::uint64_t(step));
      const auto begin = Clock::now();
      if (!stream->Write(message) || !stream->Read(&echoed)) {
        result.failed = true;
        break;
      }
      result.latency_us.push_back(micros(Clock::now() - begin));
    }
    stream->WritesDone();
    const grpc::Status status = stream->Finish();
    if (!status.ok()) result.error = status.error_message();
    return result;
  }
  auto stub = v1::DistanceService::NewStub(channel);
  auto stream = stub->StreamPoses(&context);
  // Build the messages first, so the timed loop holds only the round trip.
  std::vector<v1::PoseUpdate> messages;
  messages.reserve(std::size_t(updates));
  for (int step = 0; step < updates; ++step)
    messages.push_back(
        make_update(scene, std::uint64_t(step) + 1, step, phase, kind == Kind::warm));
  v1::DistanceReport report;
  for (int step = 0; step < updates && Clock::now() < stop_at; ++step) {
    const auto begin = Clock::now();
    if (!stream->Write(messages[std::size_t(step)]) || !stream->Read(&report)) {
      result.failed = true;
      break;
    }
    result.latency_us.push_back(micros(Clock::now() - begin));
    if (report.has_error()) {
      result.error = report.error().field() + ": " + report.error().message();
      break;
    }
    result.geometry_us += report.timing().geometry_us();
    result.evaluation_us += report.timing().evaluation_us();
    result.server_us += report.timing().server_us();
    for (const v1::PairDistance& pair : report.pairs()) {
      result.iterations += pair.iterations();
      ++result.pairs;
      result.warm_pairs += pair.warm_started();
      result.intersecting += pair.status() == v1::PAIR_STATUS_INTERSECTING;
    }
  }
  stream->WritesDone();
  while (stream->Read(&report)) {
  }
  const grpc::Status status = stream->Finish();
  if (!status.ok() && result.error.empty()) result.error = status.error_message();
  return result;
}

Row run_configuration(const std::shared_ptr<grpc::Channel>& channel, const std::string& scene,
                      Kind kind, int streams, int updates, double max_seconds) {
  std::vector<StreamResult> results(static_cast<std::size_t>(streams));
  const auto begin = Clock::now();
  const auto stop_at = begin + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(max_seconds));
  std::vector<std::thread> threads;
  for (int s = 0; s < streams; ++s)
    threads.emplace_back([&, s] {
      results[std::size_t(s)] = run_stream(channel, scene, kind, s, updates, stop_at);
    });
  for (std::thread& t : threads) t.join();
  Row row;
  row.kind = kind;
  row.streams = streams;
  row.seconds = std::chrono::duration<double>(Clock::now() - begin).count();
  std::vector<double> all;
  long pairs = 0, iterations = 0, warm = 0, intersecting = 0;
  double geometry = 0, evaluation = 0, server = 0;
  for (StreamResult& r : results) {
    all.insert(all.end(), r.latency_us.begin(), r.latency_us.end());
    pairs += r.pairs;
    iterations += r.iterations;
    warm += r.warm_pairs;
    intersecting += r.intersecting;
    geometry += r.geometry_us;
    evaluation += r.evaluation_us;
    server += r.server_us;
    if (!r.error.empty()) row.error = r.error;
    if (r.failed && row.error.empty()) row.error = "stream failed";
  }
  row.updates = all.size();
  const double n = std::max<double>(1, double(all.size()));
  row.geometry_us = geometry / n;
  row.evaluation_us = evaluation / n;
  row.server_us = server / n;
  row.iterations_per_pair = pairs ? double(iterations) / double(pairs) : 0;
  row.warm_fraction = pairs ? double(warm) / double(pairs) : 0;
  row.intersecting_fraction = pairs ? double(intersecting) / double(pairs) : 0;
  row.p50 = percentile(all, 0.50);
  row.p99 = percentile(all, 0.99);
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  int updates = 2000;
  double max_seconds = 20;
  std::size_t workers = 0;
  std::vector<int> stream_counts = {1, 4, 16};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "missing value after %s\n", arg.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--updates") {
      updates = std::max(1, std::atoi(value().c_str()));
    } else if (arg == "--max-seconds") {
      max_seconds = std::max(0.1, std::atof(value().c_str()));
    } else if (arg == "--workers") {
      workers = std::size_t(std::max(0, std::atoi(value().c_str())));
    } else if (arg == "--streams") {
      stream_counts.clear();
      std::stringstream list(value());
      for (std::string item; std::getline(list, item, ',');)
        stream_counts.push_back(std::clamp(std::atoi(item.c_str()), 1, 256));
    } else {
      std::fprintf(stderr,
                   "usage: nearpoint_service_bench [--updates N] [--max-seconds S] [--workers W] "
                   "[--streams 1,4,16]\n");
      return arg == "--help" || arg == "-h" ? 0 : 2;
    }
  }

  nearpoint::server::set_log_level(nearpoint::server::LogLevel::warn);
  nearpoint::server::ServerConfig config;
  config.listen = "127.0.0.1:0";
  config.workers = workers;
  config.limits.max_streams = 1024;
  auto started = nearpoint::server::GrpcServer::start(config);
  if (!started) {
    std::fprintf(stderr, "server: %s\n", started.error().describe().c_str());
    return 1;
  }
  auto& server = *started.value();
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server.port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = v1::DistanceService::NewStub(channel);

  v1::CreateSceneResponse scene;
  if (const std::string error = bench_support::create_scene(*stub, "service-bench", scene);
      !error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  std::size_t vertex_total = 0;
  for (const std::vector<Vec3>& polytope : bench_scene::paper_like_polytopes())
    vertex_total += polytope.size();

  std::printf("nearpoint_service_bench, %s\n", bench_support::utc_date().c_str());
  std::printf(
      "machine: %s, %u hardware threads; server workers: %zu; client and server share the "
      "machine\n",
      cpu_model().c_str(), std::thread::hardware_concurrency(), server.scenes().worker_count());
  std::printf(
      "scene: 10 polytopes, %zu vertices in all (12-100 each), %u pairs; lock-step round "
      "trips, up to %d per stream, at most %.0f s per row\n\n",
      vertex_total, scene.pair_count(), updates, max_seconds);
  std::printf(
      "| streams | kind | round trips | p50 µs | p99 µs | updates/s | server µs/update | "
      "evaluation µs/update | geometry µs/update | GJK iterations/pair | warm-started pairs | "
      "intersecting pairs |\n");
  std::printf("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  std::vector<Row> rows;
  for (const int streams : stream_counts) {
    for (const Kind kind : {Kind::echo, Kind::warm, Kind::cold}) {
      // A short unmeasured warm-up on a fresh connection state (threads, allocations).
      run_configuration(channel, scene.scene_id(), kind, 1, std::min(updates, 50), max_seconds);
      Row row = run_configuration(channel, scene.scene_id(), kind, streams, updates, max_seconds);
      if (kind == Kind::echo) {
        std::printf("| %d | %s | %zu | %.0f | %.0f | %.0f | – | – | – | – | – | – |\n", row.streams,
                    name(kind), row.updates, row.p50, row.p99, double(row.updates) / row.seconds);
      } else {
        std::printf(
            "| %d | %s | %zu | %.0f | %.0f | %.0f | %.0f | %.0f | %.1f | %.2f | %.0f%% | %.0f%% "
            "|\n",
            row.streams, name(kind), row.updates, row.p50, row.p99,
            double(row.updates) / row.seconds, row.server_us, row.evaluation_us, row.geometry_us,
            row.iterations_per_pair, 100 * row.warm_fraction, 100 * row.intersecting_fraction);
      }
      if (!row.error.empty()) std::printf("  error: %s\n", row.error.c_str());
      std::fflush(stdout);
      rows.push_back(row);
    }
  }

  // The targets, from the rows of each stream count.
  std::printf("\n");
  for (const int streams : stream_counts) {
    const Row* echo = nullptr;
    const Row* warm = nullptr;
    const Row* cold = nullptr;
    for (const Row& row : rows)
      if (row.streams == streams)
        (row.kind == Kind::echo ? echo : row.kind == Kind::warm ? warm : cold) = &row;
    if (!echo || !warm || !cold) continue;
    std::printf(
        "%d stream(s): warm p50 %.0f µs vs floor p50 + geometry = %.0f + %.1f µs "
        "(ratio %.2f; target <= 2); geometry time cold/warm = %.2f (target >= 3)\n",
        streams, warm->p50, echo->p50, warm->geometry_us,
        warm->p50 / (echo->p50 + warm->geometry_us), cold->geometry_us / warm->geometry_us);
  }
  server.shutdown();
  return 0;
}
