// SPDX-License-Identifier: Apache-2.0
// Prometheus metrics of nearpointd (issue 23): the recording hooks the scene service and the
// transports call, and the HTTP endpoint (--metrics-listen) that serves them as text.
//
// Every hook is a no-op until start_metrics() has succeeded, so the tests and the service
// benchmark, which run the same libraries in-process without an endpoint, pay one relaxed atomic
// load per call. Hooks are called per report, per update or per evaluation task, never per pair:
// the pair loop tallies into a PairTally on its own stack and records it once.
//
// Labels are low-cardinality by design (a status, a gRPC code, an RPC name, a direction): never a
// scene, object, geometry or stream id.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/report.hpp"

namespace nearpoint::server {

class SceneService;

namespace metrics {

/// Upper bounds of nearpoint_gjk_iterations' buckets (plus +Inf).
inline constexpr std::array<double, 8> kIterationBounds{1, 2, 4, 8, 16, 32, 64, 128};

/// What one evaluation task's pairs did, tallied without any shared state.
struct PairTally {
  std::uint64_t pairs = 0;
  std::uint64_t warm_started = 0;
  double iteration_sum = 0;
  /// Per bucket (not cumulative): the last one is +Inf.
  std::array<double, kIterationBounds.size() + 1> iteration_buckets{};

  void add(std::uint32_t iterations, bool warm) {
    ++pairs;
    warm_started += warm ? 1 : 0;
    iteration_sum += iterations;
    std::size_t bucket = 0;
    while (bucket < kIterationBounds.size() && double(iterations) > kIterationBounds[bucket])
      ++bucket;
    iteration_buckets[bucket] += 1;
  }
};

/// True once the endpoint serves (the hooks record only then).
bool enabled();

/// One evaluation task's pairs (warm-start hits, the iterations histogram).
void record_pairs(const PairTally& tally);
/// One finished evaluation: a stream update's report or a unary query's.
void record_report(bool query, const model::ReportTiming& timing, const model::ReportCounts& counts,
                   std::uint32_t coalesced_updates);
/// One pose update read from a stream (gRPC or DDS): accepted (`error` null) or rejected.
void record_update(const Error* error);
/// One unary Query call: answered (`error` null) or refused.
void record_query(const Error* error);
/// A gRPC call (unary or stream) ended with `code` (a grpc::StatusCode value); OK is not counted.
void record_grpc_status(const char* rpc, int code);
/// A DDS sample taken (an update, `in`) or written (a report).
void record_dds_sample(bool in);

/// Whether this build has the endpoint (NEARPOINT_WITH_METRICS).
bool built_with_metrics();

/// Checks the shape of a --metrics-listen value (IP:PORT, port 0 … 65535) without binding, so
/// that a malformed value is named as such before any other check looks at its host.
Outcome check_metrics_listen(const std::string& listen);

/// Serves the metrics on `listen` (HOST:PORT, port 0: any free port) and turns the hooks on. The
/// gauges (open streams, scenes, geometries) are read from `scenes` at each scrape, so `scenes`
/// must outlive stop_metrics(). Returns the bound port. The error's field is "--metrics-listen".
Expected<int> start_metrics(const std::string& listen, const SceneService& scenes);
/// Stops serving (idempotent); the hooks become no-ops again.
void stop_metrics();

}  // namespace metrics
}  // namespace nearpoint::server
