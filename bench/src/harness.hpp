// SPDX-License-Identifier: Apache-2.0
// What every experiment shares: one interface for the implementations under test (nearpoint and
// the peers), the per-query timer, order statistics, the command line and CSV output.
//
// Every implementation is driven through the same virtual `Runner::run(i)` so that the harness's
// own cost (one indirect call, one Outcome written) is identical for all of them and cancels in the
// ratios. Inputs (shapes, poses in each library's native form) are prepared before timing starts.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "nearpoint/distance.hpp"

namespace nearpoint::bench {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// How a query ended, for the stability report. nearpoint reports DS / BP / numerical limit / cap
/// (paper Section VI, steps 2, 5 and the iteration cap); peers that say nothing get `unknown`.
enum class Exit : unsigned char {
  unknown,
  distance_subalgorithm,  ///< eq. (35) held, last ν from the distance subalgorithm (DS)
  backup_procedure,       ///< eq. (35) held, last ν from the Backup Procedure (BP)
  numerical_limit,        ///< step 5: no descent even with the Backup Procedure
  iteration_cap,          ///< the iteration cap was reached
  beyond_cutoff,          ///< a cutoff query proved the distance above the cutoff
  invalid_input,          ///< the implementation refused the input
};
const char* to_string(Exit exit);

/// What one query answered, in the same form for every implementation.
struct Outcome {
  /// Reported distance; 0 when the implementation reports intersection. NaN when it reported a
  /// NaN (counted, never hidden) or gave no distance (a yes/no query).
  double distance = kNaN;
  bool intersecting = false;
  /// Iterations as the implementation counts them; -1 when it does not report them.
  int iterations = -1;
  /// nearpoint's certified error bound; NaN for peers (they report none).
  double error_bound = kNaN;
  Exit exit = Exit::unknown;
  /// nearpoint: which test ended the loop (to_string(Termination): "tolerance", "repeated_support"
  /// …); "" for peers. A static string, so filling it costs nothing.
  const char* termination = "";
  /// Implementation-specific exit codes for the stability report, -1 when none: Bullet's
  /// m_lastUsedMethod and m_degenerateSimplex. Plain ints, so that filling them costs nothing.
  int code_a = -1, code_b = -1;
  /// The depth experiment: the reported penetration depth (0 when the implementation reports no
  /// penetration), and nearpoint's certified interval and D(K) (NaN for peers: they report none).
  double depth = kNaN;
  double depth_lower = kNaN, depth_upper = kNaN;
  double diameter_bound = kNaN;
  /// nearpoint's signed distance interval (distance when separated, −depth when intersecting).
  double signed_lower = kNaN, signed_upper = kNaN;
};

/// One implementation with fixed settings, prepared on a fixed list of inputs.
class Runner {
 public:
  virtual ~Runner() = default;
  /// Runs query `i`. Called inside the timed region: must do nothing the query does not need.
  virtual void run(std::size_t i, Outcome& out) = 0;
  /// Forget warm-start state (cached simplices) so that the next run is cold.
  virtual void reset() {}
};

/// Two polytopes (vertex lists in their local frames, shared between examples) at their poses,
/// with optional spherical-extension radii. The common input of all runners.
struct PairInput {
  std::shared_ptr<const std::vector<Vec3<double>>> a, b;
  Pose<double> pose_a, pose_b;
  double radius_a = 0, radius_b = 0;
};

// ---- timing ----

using Clock = std::chrono::steady_clock;

/// The median cost (ns) of two back-to-back clock reads: subtracted from every timed query, so a
/// reported time is the query's own cost. Measured once per process.
double clock_overhead_ns();

/// Times `runner.run(i)` for every i in `indices` (in that order), writing the query's cost in ns
/// (clock overhead subtracted, floored at 0) to `ns[i]` and, when `outcomes` is not empty, the
/// answer to `outcomes[i]`.
void time_queries(Runner& runner, std::span<const std::uint32_t> indices, std::span<float> ns,
                  std::span<Outcome> outcomes = {});

// ---- statistics ----

/// The q-quantile (0 ≤ q ≤ 1) by linear interpolation between order statistics; NaN when empty.
/// Reorders `values`.
double quantile(std::vector<float>& values, double q);
double quantile(std::vector<double>& values, double q);
inline double median(std::vector<float>& values) {
  return quantile(values, 0.5);
}
inline double median(std::vector<double>& values) {
  return quantile(values, 0.5);
}

// ---- command line and output ----

struct Args {
  std::string
      experiment;  ///< paper | table1 | error-time | large | stability | primitives | depth | all
  std::string out_dir = "bench/results";
  bool quick = false;  ///< smoke test: a small sample, few rounds
  int rounds = 0;      ///< 0: the experiment's default
};

/// A CSV file written row by row; numbers with 17 significant digits where precision matters.
class Csv {
 public:
  Csv(const std::string& path, const std::vector<std::string>& header);
  ~Csv();
  Csv(const Csv&) = delete;
  Csv& operator=(const Csv&) = delete;
  Csv& operator<<(const std::string& field);
  Csv& operator<<(const char* field) { return *this << std::string(field); }
  Csv& operator<<(double value);
  Csv& operator<<(int value);
  Csv& operator<<(long value);
  Csv& operator<<(std::size_t value);
  /// Ends the current row.
  void end_row();

 private:
  void separator();
  std::FILE* file_ = nullptr;
  bool row_started_ = false;
};

/// `dir/name`, creating `dir` when missing.
std::string output_path(const Args& args, const std::string& name);

/// printf to stderr with the experiment's name in front: progress, never results.
void progress(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace nearpoint::bench
