// SPDX-License-Identifier: Apache-2.0
// What the server-side fuzz targets share: a scene service with small limits (so that one input's
// work stays bounded and a libFuzzer timeout means a real hang), evaluations waited for in the
// calling thread, and the invariants every answer of the scene API must meet.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

#include "fuzz_support.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "proto_convert.hpp"

namespace nearpoint::fuzz {

inline server::ServiceLimits small_limits() {
  server::ServiceLimits limits;
  limits.max_geometries = 16;
  limits.max_pieces_per_geometry = 8;
  limits.max_vertices_per_geometry = 256;
  limits.max_scenes = 8;
  limits.max_objects_per_scene = 16;
  limits.max_pairs_per_scene = 64;
  limits.max_piece_pairs_per_scene = 512;
  limits.max_streams = 4;
  limits.max_in_flight_per_stream = 2;
  limits.max_concurrent_queries = 4;
  return limits;
}

/// The default gRPC message limit of nearpointd (ServerConfig::max_message_bytes): a report that
/// does not fit could never be sent.
inline constexpr std::size_t kMaxMessageBytes = 16u << 20;

/// The longest error (field and message) a client should get back.
inline constexpr std::size_t kMaxErrorBytes = 2048;

/// A rejected request: a known code that is not a bug, a message, and a gRPC status a client can
/// act on (never OK, UNKNOWN, INTERNAL or UNIMPLEMENTED).
inline void check_error(const server::Error& error, const char* what) {
  const std::string where = std::string(what) + ": " + error.describe();
  NEARPOINT_FUZZ_CHECK(error.code != server::ErrorCode::internal, "internal error; " + where);
  NEARPOINT_FUZZ_CHECK(!error.message.empty(), "an error without a message; " + where);
  // Messages quote what the client sent (ids, keys); quoting it whole lets a client make every
  // error and log line as large as its request. 2 KiB is far more than any message needs.
  NEARPOINT_FUZZ_CHECK(error.describe().size() <= kMaxErrorBytes,
                       "an error message of " + std::to_string(error.describe().size()) +
                           " bytes (unbounded echo of the request?); " + where.substr(0, 600));
  const grpc::StatusCode code = server::to_grpc_status(error).error_code();
  NEARPOINT_FUZZ_CHECK(code != grpc::StatusCode::OK && code != grpc::StatusCode::UNKNOWN &&
                           code != grpc::StatusCode::INTERNAL &&
                           code != grpc::StatusCode::UNIMPLEMENTED,
                       "an error mapped to an unhelpful gRPC status; " + where);
}

/// The entries a report mode allows (nearpoint.v1.ReportMode): distinct selected pairs of the
/// scene in the scene's pair order, every pair for REPORT_MODE_ALL_PAIRS (and for a unary query
/// in REPORT_MODE_CHANGED), no BEYOND_CUTOFF pair where the mode leaves those out, at most one
/// per object or one in all for the nearest modes.
inline void check_report_pairs(const server::Report& report, bool unary, const char* what) {
  const std::vector<server::ScenePair>& selected = report.scene->pairs;
  // Built only for a message: this runs for every report of every input.
  const auto where = [&] {
    return std::string(what) + ", mode " + std::to_string(int(report.mode)) + ", " +
           std::to_string(report.pairs.size()) + " of " + std::to_string(selected.size()) +
           " pairs";
  };
  NEARPOINT_FUZZ_CHECK(
      report.mode != model::ReportMode::unspecified && report.mode != model::ReportMode::unknown,
      "a report whose mode was not resolved; " + where());
  const bool cutoff_mode = report.mode == model::ReportMode::within_cutoff ||
                           report.mode == model::ReportMode::nearest_per_object ||
                           report.mode == model::ReportMode::global_minimum;
  std::size_t next = 0;  // the first scene pair an entry may still be
  for (const model::PairReport& p : report.pairs) {
    while (next < selected.size() &&
           (selected[next].object_a != p.object_a || selected[next].object_b != p.object_b))
      ++next;
    NEARPOINT_FUZZ_CHECK(next < selected.size(),
                         "an entry that is not a selected pair, a repeated one or one out of the "
                         "scene's order; " +
                             where());
    ++next;
    NEARPOINT_FUZZ_CHECK(!cutoff_mode || p.status != model::PairStatus::beyond_cutoff,
                         "a BEYOND_CUTOFF entry in a mode that leaves them out; " + where());
  }
  switch (report.mode) {
    case model::ReportMode::all_pairs:
      NEARPOINT_FUZZ_CHECK(report.pairs.size() == selected.size(),
                           "a report without one entry per pair; " + where());
      break;
    case model::ReportMode::changed:
      NEARPOINT_FUZZ_CHECK(!unary || report.pairs.size() == selected.size(),
                           "a unary query in changed mode without every pair; " + where());
      break;
    case model::ReportMode::nearest_per_object:
      NEARPOINT_FUZZ_CHECK(report.pairs.size() <= report.scene->objects.size(),
                           "more nearest pairs than objects; " + where());
      break;
    case model::ReportMode::global_minimum:
      NEARPOINT_FUZZ_CHECK(report.pairs.size() <= 1, "more than one global minimum; " + where());
      break;
    default:
      break;
  }
}

/// A report: the entries its mode allows, finite numbers, distance ≥ 0, an engine error only with
/// a message, and small enough to be sent. `unary`: the answer to Query, not to a stream update.
inline void check_report(const server::Report& report, bool unary, const char* what) {
  NEARPOINT_FUZZ_CHECK(report.scene != nullptr, std::string(what) + ": a report without its scene");
  check_report_pairs(report, unary, what);
  for (const model::PairReport& p : report.pairs) {
    const std::string where = std::string(what) + ": pair " + std::to_string(p.object_a) + "-" +
                              std::to_string(p.object_b) + ", distance " +
                              std::to_string(p.distance) + ", error_bound " +
                              std::to_string(p.error_bound);
    if (p.status == model::PairStatus::engine_error) {
      NEARPOINT_FUZZ_CHECK(p.engine_message != nullptr && *p.engine_message != '\0',
                           "an engine error without a message; " + where);
      continue;
    }
    NEARPOINT_FUZZ_CHECK(std::isfinite(p.distance) && std::isfinite(p.distance_lower_bound) &&
                             std::isfinite(p.error_bound) && p.point_a.allFinite() &&
                             p.point_b.allFinite() && p.normal.allFinite() &&
                             std::isfinite(p.penetration_bound) && p.gradient_a.allFinite() &&
                             p.gradient_b.allFinite(),
                         "a non-finite number in a report; " + where);
    NEARPOINT_FUZZ_CHECK(
        p.distance >= 0 && p.error_bound >= 0 && p.distance_lower_bound >= 0 &&
            (p.distance_lower_bound <= p.distance || p.status == model::PairStatus::beyond_cutoff),
        "negative distance or bound, or lower bound above distance; " + where);
  }
  v1::DistanceReport message;
  server::to_proto(report, message);
  NEARPOINT_FUZZ_CHECK(message.ByteSizeLong() <= kMaxMessageBytes,
                       std::string(what) + ": a report larger than the message limit");
}

/// Waits in the calling thread for the one report an evaluation delivers on a pool thread.
class ReportWaiter {
 public:
  server::ReportCallback callback() {
    return [this](server::Report report) {
      std::lock_guard lock(mutex_);
      ++calls_;
      report_ = std::move(report);
      done_.notify_all();
    };
  }
  server::Report wait() {
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return calls_ > 0; });
    NEARPOINT_FUZZ_CHECK(calls_ == 1, "an evaluation reported more than once");
    calls_ = 0;
    return std::move(*report_);
  }

 private:
  std::mutex mutex_;
  std::condition_variable done_;
  int calls_ = 0;
  std::optional<server::Report> report_;
};

}  // namespace nearpoint::fuzz
