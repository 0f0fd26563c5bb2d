// SPDX-License-Identifier: Apache-2.0
// `nearpoint distance`: JSON Lines pairs in, JSON Lines results out (docs/design.md,
// "`nearpoint distance` JSON Lines contract"). Local: no server, one engine call per line.
//
// Input, one JSON object per line (blank lines are skipped):
//   {"id": any, "a": SHAPE, "b": SHAPE,
//    "options": {"epsilon": e, "near_points": bool, "penetration": "none"|"bound"|"depth",
//                "warm": bool}}
// Output, one JSON object per non-blank input line, in input order:
//   {"id": (echoed; null if absent), "status":
//   "separated"|"intersecting"|"iteration_limit"|"error",
//    "distance": d, "point_a": [..], "point_b": [..], "normal": [..], "error_bound": e,
//    "iterations": k, "warm_started": bool, "penetration_bound": p, "message": "…"}
//
// The logic lives here, apart from main(), so that tests run it on string streams.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>

#include "json_shapes.hpp"
#include "nearpoint/model/exit_codes.hpp"
#include "nearpoint/result.hpp"

namespace nearpoint::cli {

/// How `run_distance` is wired to the outside world. The query options themselves come per line.
struct DistanceCommandOptions {
  /// Where to say that the input could not be read or the output not written. May be null.
  std::ostream* diagnostics = nullptr;
  /// The input's name in those messages: a file name, or "<stdin>".
  std::string input_name = "<stdin>";
};

/// Exit codes of the command (from the one table of both binaries, model/exit_codes.hpp).
inline constexpr int kExitOk = model::kExitOk;  ///< every line answered (error lines included)
inline constexpr int kExitIoError = model::kExitUsage;  ///< input unreadable or output unwritable

/// Answers the lines of one input stream, in order, keeping the warm-start state between them.
///
/// Warm start (Section VIII of the paper): a line with "warm": true starts from the simplex cache
/// that the line just before it (blank lines aside) left, when that line was also a warm query
/// and had the same two shapes, kinds, parameters, vertices and radii alike, with only the poses
/// free to change. Otherwise it starts cold, and in both cases its final simplex is kept for the
/// next line. Any other line (warm false, an error, different shapes) ends the chain. So a
/// trajectory of one pair is a run of consecutive lines with "warm": true.
class DistanceSession {
 public:
  /// The output object (one line, no newline) for the input line `line`, numbered `line_number`
  /// (1-based, used in messages). Never throws; an unusable line yields a "status": "error" object.
  /// `line` must not be blank (the caller skips those).
  std::string answer(std::string_view line, long line_number) noexcept;

 private:
  // The two shapes of the last warm query (without their poses) and its final simplex.
  struct WarmChain {
    Json shape_a;
    Json shape_b;
    SimplexCache cache;
  };

  Json answer_json(std::string_view line, long line_number);

  std::optional<WarmChain> chain_;
};

/// Reads JSON Lines from `in` and writes one result line per non-blank input line to `out`.
/// Returns kExitOk when the whole input was read (bad lines are answered with error lines, not
/// failures), kExitIoError when reading or writing failed. Flushes `out` whenever it would
/// otherwise wait for more input, so that a program driving the command over a pipe sees each
/// answer as soon as it is computed. Never throws.
int run_distance(std::istream& in, std::ostream& out, const DistanceCommandOptions& options);

/// Contract spelling of an engine status ("separated", "intersecting", "iteration_limit", "error").
const char* status_name(Status status);

}  // namespace nearpoint::cli
