// SPDX-License-Identifier: Apache-2.0
#include "dds_load.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <ostream>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "nearpoint/model/percentile.hpp"

namespace nearpoint::cli {
namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kPrefix = "nearpoint dds load: ";

/// What one stream measured.
struct StreamTally {
  std::vector<double> latencies_us;
  std::size_t reports = 0, merged = 0, errors = 0, missing = 0;
  double server_us = 0, geometry_us = 0;
  std::string first_problem;

  void add(const StreamTally& other) {
    latencies_us.insert(latencies_us.end(), other.latencies_us.begin(), other.latencies_us.end());
    reports += other.reports;
    merged += other.merged;
    errors += other.errors;
    missing += other.missing;
    server_us += other.server_us;
    geometry_us += other.geometry_us;
    if (first_problem.empty()) first_problem = other.first_problem;
  }
};

/// One stream: publishes `options.window` updates ahead of their reports until `stop_at`, then
/// waits for the reports still due.
StreamTally run_stream(DdsPoseClient& client, const Trajectory& trajectory,
                       const DdsStreamOptions& stream, std::uint64_t first_step,
                       Clock::time_point stop_at, std::chrono::milliseconds report_timeout) {
  StreamTally tally;
  StepPublisher publisher(trajectory, stream);
  std::map<std::uint64_t, Clock::time_point> outstanding;  // sequence → published
  auto on_report = [&](const ReportView& report) {
    const auto found = outstanding.find(report.sequence_number);
    if (found == outstanding.end()) return;  // not awaited (a duplicate): ignored
    if (report.status != 0) {
      ++tally.errors;
      if (tally.first_problem.empty())
        tally.first_problem = "error report for sequence " +
                              std::to_string(report.sequence_number) + ": " + report.message;
      outstanding.erase(found);
      return;
    }
    tally.latencies_us.push_back(
        std::chrono::duration<double, std::micro>(Clock::now() - found->second).count());
    ++tally.reports;
    tally.server_us += report.server_us;
    tally.geometry_us += report.geometry_us;
    // A report answers every earlier update still outstanding: merged into it (coalesced), or
    // missing.
    const std::uint64_t merged_from =
        report.coalesced_updates > 0 ? report.coalesced_from_sequence : report.sequence_number;
    for (auto it = outstanding.begin(); it != outstanding.end() && it->first < found->first;) {
      ++(it->first >= merged_from ? tally.merged : tally.missing);
      it = outstanding.erase(it);
    }
    outstanding.erase(found);
  };
  std::uint64_t next = first_step;
  std::string error;
  const std::size_t batch = std::max<std::size_t>(1, stream.batch);
  for (;;) {
    const bool publishing = Clock::now() < stop_at;
    if (!publishing && outstanding.empty()) break;
    while (publishing && outstanding.size() + batch <= stream.window) {
      if (!publish_steps(client, publisher, next, batch, batch > 1, outstanding, error)) {
        tally.first_problem = error;
        tally.missing += outstanding.size();
        return tally;
      }
      next += batch;
    }
    const int got = client.take_report_views(report_timeout, on_report, error);
    if (got <= 0) {
      if (tally.first_problem.empty())
        tally.first_problem =
            got < 0 ? error : "no report within " + std::to_string(report_timeout.count()) + " ms";
      tally.missing += outstanding.size();
      return tally;
    }
  }
  return tally;
}

}  // namespace

int run_dds_load(const Trajectory& trajectory, const DdsLoadOptions& options, std::ostream& out,
                 std::ostream& err) {
  if (options.scene_id.empty() || trajectory.steps.empty() || options.streams < 1 ||
      !(options.duration_s > 0)) {
    err << kPrefix << "needs a scene id, a trajectory with steps, --streams >= 1, --duration > 0\n";
    return kStreamBadConfiguration;
  }
  std::string error;
  if (error = dds::check_configuration(options.dds.allow_default_config); !error.empty()) {
    err << kPrefix << error << '\n';
    return kStreamBadConfiguration;
  }
  const std::size_t batch = std::max<std::size_t>(1, options.batch);
  if (batch > dds::kMaxUpdatesPerBatch || options.window < batch) {
    err << kPrefix << "--batch is 1-" << dds::kMaxUpdatesPerBatch
        << " and --window at least one batch (got --batch " << batch << ", --window "
        << options.window << ")\n";
    return kStreamBadConfiguration;
  }
  DdsPoseClient::Config config = options.dds;
  config.batched = batch > 1;
  // Every stream's endpoints matched before any publishes, so that discovery is not measured.
  std::vector<std::unique_ptr<DdsPoseClient>> clients;
  std::vector<DdsStreamOptions> streams(std::size_t(options.streams));
  for (int k = 0; k < options.streams; ++k) {
    std::unique_ptr<DdsPoseClient> client = DdsPoseClient::create(config, error);
    if (!client || !client->wait_matched(options.match_timeout, error)) {
      err << kPrefix << error << '\n';
      return kStreamCannotRun;
    }
    clients.push_back(std::move(client));
    DdsStreamOptions& stream = streams[std::size_t(k)];
    stream.dds = options.dds;
    stream.scene_id = options.scene_id;
    stream.client_id = "nearpoint-load-" + std::to_string(getpid()) + "-" + std::to_string(k);
    stream.window = std::max<std::size_t>(1, options.window);
    stream.batch = batch;
  }
  const Clock::time_point start = Clock::now();
  const Clock::time_point stop_at = start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(options.duration_s));
  std::mutex mutex;
  StreamTally total;
  std::vector<std::thread> threads;
  for (int k = 0; k < options.streams; ++k)
    threads.emplace_back([&, k] {
      // Streams start at different points of the path, so they do not run in lock step.
      const std::uint64_t first =
          std::uint64_t(k) * trajectory.steps.size() / std::uint64_t(options.streams);
      const StreamTally tally =
          run_stream(*clients[std::size_t(k)], trajectory, streams[std::size_t(k)], first, stop_at,
                     options.report_timeout);
      std::lock_guard lock(mutex);
      total.add(tally);
    });
  for (std::thread& thread : threads) thread.join();
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();

  std::vector<double>& latencies = total.latencies_us;
  const double p50 = model::percentile(latencies, 0.5), p90 = model::percentile(latencies, 0.9),
               p99 = model::percentile(latencies, 0.99);
  const double max = latencies.empty() ? 0 : *std::max_element(latencies.begin(), latencies.end());
  const double rate = double(total.reports) / std::max(elapsed_s, 1e-9);
  if (options.json) {
    out << nlohmann::ordered_json{{"scene_id", options.scene_id},
                                  {"transport", "dds"},
                                  {"streams", options.streams},
                                  {"window", options.window},
                                  {"batch", batch},
                                  {"duration_s", elapsed_s},
                                  {"reports", total.reports},
                                  {"merged", total.merged},
                                  {"errors", total.errors + total.missing},
                                  {"updates_per_s", rate},
                                  {"server_us_total", total.server_us},
                                  {"geometry_us_total", total.geometry_us},
                                  {"latency_us",
                                   {{"p50", p50}, {"p90", p90}, {"p99", p99}, {"max", max}}}}
               .dump()
        << '\n';
  } else {
    out << "scene " << options.scene_id << " over DDS: " << options.streams << " stream(s) x "
        << options.window << " in flight (" << batch << " per sample) for " << elapsed_s
        << " s: " << total.reports << " reports (" << total.merged << " merged updates), " << rate
        << " updates/s\n"
        << "round-trip latency (publish to report): p50 " << p50 << " us, p90 " << p90
        << " us, p99 " << p99 << " us, max " << max << " us\n"
        << "per report: server "
        << total.server_us / double(std::max<std::size_t>(1, total.reports)) << " us, geometry "
        << total.geometry_us / double(std::max<std::size_t>(1, total.reports)) << " us\n";
  }
  if (total.errors + total.missing > 0) {
    err << kPrefix << total.errors << " error reports, " << total.missing
        << " updates unanswered; the first problem: " << total.first_problem << '\n';
    return kStreamIncomplete;
  }
  return kStreamOk;
}

}  // namespace nearpoint::cli
