// SPDX-License-Identifier: Apache-2.0
#include "metrics.hpp"

#include <atomic>
#include <memory>
#include <mutex>

#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/server/scene_service.hpp"

#if NEARPOINT_HAVE_METRICS
#include <prometheus/collectable.h>
#include <prometheus/counter.h>
#include <prometheus/exposer.h>
#include <prometheus/histogram.h>
#include <prometheus/metric_family.h>
#include <prometheus/registry.h>

#include <exception>
#include <vector>
#endif

namespace nearpoint::server::metrics {

Outcome check_metrics_listen(const std::string& listen) {
  const char* flag = "--metrics-listen";
  // civetweb takes "IP:PORT" or "[IPv6]:PORT"; check the shape here so that the message names
  // the flag rather than a civetweb internal.
  const auto colon = listen.rfind(':');
  const std::string port = colon == std::string::npos ? "" : listen.substr(colon + 1);
  const bool digits = !port.empty() && port.size() <= 5 &&
                      port.find_first_not_of("0123456789") == std::string::npos;
  if (colon == 0 || colon == std::string::npos || !digits || std::stol(port) > 65535)
    return invalid_argument(
        flag, text("'", listen, "' is not HOST:PORT (e.g. 127.0.0.1:9464; port 0: any free port)"));
  return {};
}

#if NEARPOINT_HAVE_METRICS

namespace {

using prometheus::BuildCounter;
using prometheus::BuildHistogram;
using prometheus::Counter;
using prometheus::Histogram;

/// The gauges are read at scrape time from the scene service, so they cost nothing between
/// scrapes and can never drift from the truth.
class SceneGauges : public prometheus::Collectable {
 public:
  explicit SceneGauges(const SceneService& scenes) : scenes_(scenes) {}
  std::vector<prometheus::MetricFamily> Collect() const override {
    std::vector<prometheus::MetricFamily> out;
    auto gauge = [&](const char* name, const char* help, double value) {
      prometheus::MetricFamily family;
      family.name = name;
      family.help = help;
      family.type = prometheus::MetricType::Gauge;
      prometheus::ClientMetric metric;
      metric.gauge.value = value;
      family.metric.push_back(metric);
      out.push_back(std::move(family));
    };
    gauge("nearpoint_streams_active", "Open pose streams (gRPC and DDS)",
          double(scenes_.open_streams()));
    gauge("nearpoint_scenes", "Live scenes", double(scenes_.scene_count()));
    gauge("nearpoint_geometries", "Registered geometries", double(scenes_.geometry_count()));
    return out;
  }

 private:
  const SceneService& scenes_;
};

Histogram::BucketBoundaries seconds_buckets() {
  // 10 µs … 1 s: a within-cutoff update of a small scene takes tens of µs, a cold all-pairs
  // query of a large one hundreds of ms.
  return {1e-5, 2.5e-5, 5e-5, 1e-4, 2.5e-4, 5e-4, 1e-3, 2.5e-3, 5e-3, 1e-2, 2.5e-2, 0.1, 0.25, 1};
}

std::string lower_code_status(ErrorCode code) {
  return to_string(code);
}

struct State {
  std::shared_ptr<prometheus::Registry> registry = std::make_shared<prometheus::Registry>();
  std::shared_ptr<SceneGauges> gauges;
  std::unique_ptr<prometheus::Exposer> exposer;

  prometheus::Family<Counter>& updates =
      BuildCounter()
          .Name("nearpoint_updates_total")
          .Help("Pose updates read from streams (gRPC and DDS), by status: ok or the error code")
          .Register(*registry);
  prometheus::Family<Counter>& queries =
      BuildCounter()
          .Name("nearpoint_queries_total")
          .Help("Unary Query calls, by status: ok or the error code")
          .Register(*registry);
  prometheus::Family<Counter>& reports =
      BuildCounter()
          .Name("nearpoint_reports_total")
          .Help("Evaluations finished, by kind: stream (an update's report) or query")
          .Register(*registry);
  prometheus::Family<Histogram>& report_seconds =
      BuildHistogram()
          .Name("nearpoint_report_latency_seconds")
          .Help("Server-side time of a report, from reading its update to the report, by kind")
          .Register(*registry);
  prometheus::Family<Counter>& geometry_seconds =
      BuildCounter()
          .Name("nearpoint_geometry_seconds_total")
          .Help("Time spent in the distance engine, summed over worker threads")
          .Register(*registry);
  prometheus::Family<Counter>& pairs =
      BuildCounter()
          .Name("nearpoint_pairs_total")
          .Help(
              "Selected pairs of finished reports, by outcome: evaluated (by the engine), "
              "pruned (by the broad phase) or unmoved (previous result repeated)")
          .Register(*registry);
  prometheus::Family<Counter>& warm_hits =
      BuildCounter()
          .Name("nearpoint_warm_start_hits_total")
          .Help("Pair evaluations whose warm-start cache was used")
          .Register(*registry);
  prometheus::Family<Histogram>& iterations = BuildHistogram()
                                                  .Name("nearpoint_gjk_iterations")
                                                  .Help("GJK iterations of one pair evaluation")
                                                  .Register(*registry);
  prometheus::Family<Counter>& coalesced =
      BuildCounter()
          .Name("nearpoint_coalesced_updates_total")
          .Help("Updates folded into a newer one before evaluation (flow control COALESCE)")
          .Register(*registry);
  prometheus::Family<Counter>& grpc_errors =
      BuildCounter()
          .Name("nearpoint_grpc_errors_total")
          .Help("gRPC calls that ended with a status other than OK, by RPC and code")
          .Register(*registry);
  prometheus::Family<Counter>& dds_samples =
      BuildCounter()
          .Name("nearpoint_dds_samples_total")
          .Help("DDS samples, by direction: in (updates taken) or out (reports written)")
          .Register(*registry);

  // The hot counters, resolved once (a Family::Add takes the family's lock).
  Counter& updates_ok = updates.Add({{"status", "ok"}});
  Counter& queries_ok = queries.Add({{"status", "ok"}});
  Counter& reports_stream = reports.Add({{"kind", "stream"}});
  Counter& reports_query = reports.Add({{"kind", "query"}});
  Histogram& latency_stream = report_seconds.Add({{"kind", "stream"}}, seconds_buckets());
  Histogram& latency_query = report_seconds.Add({{"kind", "query"}}, seconds_buckets());
  Counter& geometry = geometry_seconds.Add({});
  Counter& pairs_evaluated = pairs.Add({{"outcome", "evaluated"}});
  Counter& pairs_pruned = pairs.Add({{"outcome", "pruned"}});
  Counter& pairs_unmoved = pairs.Add({{"outcome", "unmoved"}});
  Counter& warm = warm_hits.Add({});
  Histogram& iteration_histogram = iterations.Add(
      {}, Histogram::BucketBoundaries(kIterationBounds.begin(), kIterationBounds.end()));
  Counter& coalesced_updates = coalesced.Add({});
  Counter& dds_in = dds_samples.Add({{"direction", "in"}});
  Counter& dds_out = dds_samples.Add({{"direction", "out"}});
};

// Set (release) once the state is complete; hooks load it (acquire) and do nothing while null.
// Never freed while the process runs: a hook on a pool thread may still hold it after
// stop_metrics(), and one State per process is nothing.
std::atomic<State*> g_state{nullptr};
std::mutex g_start_mutex;

State* state() {
  return g_state.load(std::memory_order_acquire);
}

}  // namespace

bool built_with_metrics() {
  return true;
}

bool enabled() {
  return state() != nullptr;
}

void record_pairs(const PairTally& tally) {
  State* s = state();
  if (!s || tally.pairs == 0) return;
  if (tally.warm_started) s->warm.Increment(double(tally.warm_started));
  s->iteration_histogram.ObserveMultiple(
      std::vector<double>(tally.iteration_buckets.begin(), tally.iteration_buckets.end()),
      tally.iteration_sum);
}

void record_report(bool query, const model::ReportTiming& timing, const model::ReportCounts& counts,
                   std::uint32_t coalesced_updates) {
  State* s = state();
  if (!s) return;
  (query ? s->reports_query : s->reports_stream).Increment();
  (query ? s->latency_query : s->latency_stream).Observe(timing.server_us * 1e-6);
  s->geometry.Increment(timing.geometry_us * 1e-6);
  if (counts.pairs_evaluated) s->pairs_evaluated.Increment(counts.pairs_evaluated);
  if (counts.pairs_pruned) s->pairs_pruned.Increment(counts.pairs_pruned);
  if (counts.pairs_unmoved) s->pairs_unmoved.Increment(counts.pairs_unmoved);
  if (coalesced_updates) s->coalesced_updates.Increment(coalesced_updates);
}

void record_update(const Error* error) {
  State* s = state();
  if (!s) return;
  if (!error) return s->updates_ok.Increment();
  s->updates.Add({{"status", lower_code_status(error->code)}}).Increment();
}

void record_query(const Error* error) {
  State* s = state();
  if (!s) return;
  if (!error) return s->queries_ok.Increment();
  s->queries.Add({{"status", lower_code_status(error->code)}}).Increment();
}

void record_grpc_status(const char* rpc, int code) {
  State* s = state();
  if (!s || code == 0) return;
  s->grpc_errors.Add({{"rpc", rpc}, {"code", model::status_code_name(code)}}).Increment();
}

void record_dds_sample(bool in) {
  State* s = state();
  if (!s) return;
  (in ? s->dds_in : s->dds_out).Increment();
}

Expected<int> start_metrics(const std::string& listen, const SceneService& scenes) {
  const char* flag = "--metrics-listen";
  if (Outcome shape = check_metrics_listen(listen); !shape) return shape.error();
  std::lock_guard lock(g_start_mutex);
  if (state()) return invalid_argument(flag, "the metrics endpoint is already serving");
  auto fresh = std::make_unique<State>();
  try {
    fresh->exposer = std::make_unique<prometheus::Exposer>(listen, /*num_threads=*/1);
  } catch (const std::exception& error) {
    return Error{ErrorCode::unavailable, flag,
                 text("cannot serve metrics on '", listen,
                      "' (malformed: the host must be an IP address; or the address is in use): ",
                      error.what())};
  }
  const std::vector<int> ports = fresh->exposer->GetListeningPorts();
  if (ports.empty())
    return Error{ErrorCode::unavailable, flag, text("cannot serve metrics on '", listen, "'")};
  fresh->gauges = std::make_shared<SceneGauges>(scenes);
  fresh->exposer->RegisterCollectable(fresh->registry);
  fresh->exposer->RegisterCollectable(fresh->gauges);
  g_state.store(fresh.release(), std::memory_order_release);
  return ports.front();
}

void stop_metrics() {
  std::lock_guard lock(g_start_mutex);
  State* s = state();
  if (!s) return;
  // Stop serving; the state itself stays (see g_state), its hooks now unobserved.
  s->exposer.reset();
}

#else  // !NEARPOINT_HAVE_METRICS

bool built_with_metrics() {
  return false;
}
bool enabled() {
  return false;
}
void record_pairs(const PairTally&) {}
void record_report(bool, const model::ReportTiming&, const model::ReportCounts&, std::uint32_t) {}
void record_update(const Error*) {}
void record_query(const Error*) {}
void record_grpc_status(const char*, int) {}
void record_dds_sample(bool) {}
Expected<int> start_metrics(const std::string&, const SceneService&) {
  return invalid_argument("--metrics-listen",
                          "this nearpointd was built without metrics (NEARPOINT_WITH_METRICS=OFF; "
                          "install prometheus-cpp-dev and rebuild)");
}
void stop_metrics() {}

#endif

}  // namespace nearpoint::server::metrics
