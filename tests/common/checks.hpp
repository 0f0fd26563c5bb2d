// SPDX-License-Identifier: Apache-2.0
// Small helpers shared by the oracle tests: finiteness of a whole result, a failure log that keeps
// the first few messages of each kind (so a broken engine prints a readable report instead of
// thousands of lines), and summary statistics.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "nearpoint/result.hpp"

namespace nearpoint::testkit {

/// Whether this build contracts a·b + c into fused multiply-adds (configured with NEARPOINT_ARCH
/// for a CPU with FMA): two evaluations of one formula may then be fused differently and differ in
/// the last bits, so tests that hold two code paths to the same bits compare within rounding.
inline constexpr bool kFusedMultiplyAdd =
#ifdef __FP_FAST_FMA
    true;
#else
    false;
#endif

/// The slack for holding two evaluations of one formula to each other: exactly 0 (bit for bit)
/// in a portable build, `relative` × (1 + |value|) where multiply-adds are fused.
inline double fused_rounding_slack(double value, double relative) {
  return kFusedMultiplyAdd ? relative * (1 + std::abs(value)) : 0.0;
}

/// Every floating-point field of a result is finite (the engine promises "never NaN").
template <class S>
bool all_finite(const DistanceResult<S>& r) {
  using std::isfinite;
  bool ok = isfinite(r.distance) && isfinite(r.error_bound) && isfinite(r.gap) &&
            isfinite(r.diameter_bound) && isfinite(r.penetration_bound) && r.point_a.allFinite() &&
            r.point_b.allFinite() && r.normal.allFinite() && r.gradient_a.allFinite() &&
            r.gradient_b.allFinite();
  for (int i = 0; i < 4; ++i) ok = ok && isfinite(r.weights[i]);
  return ok;
}

/// Why a result's cost counters cannot come from the loop of Section VI, or nullptr. With k
/// iterations: step 2 runs once on V_0 and once per added point, and the Backup Procedure at most
/// once more for each (a failed subalgorithm, or step 6), so k + 1 ≤ runs ≤ 2(k + 1), and more
/// than k + 1 when the Backup Procedure produced the answer. A cold start makes V_0's support
/// call; each pass that tests eq. (35) makes one (k passes added a point, each step-6 pass is
/// paid for by a Backup Procedure run, and the last pass), and the final triangle's normal one
/// more: calls ≤ [cold] + (runs − 1) + 2.
template <class S>
const char* cost_counters_violation(const DistanceResult<S>& r, bool warm_started) {
  const int k = r.iterations;
  if (r.subalgorithm_runs < k + 1 || r.subalgorithm_runs > 2 * (k + 1))
    return "subalgorithm_runs outside [k + 1, 2(k + 1)]";
  if (r.finished_by == FinishedBy::backup_procedure && r.subalgorithm_runs == k + 1)
    return "the Backup Procedure finished but no run of it was counted";
  const int cold = warm_started ? 0 : 1;
  if (r.support_calls < cold) return "a cold start made no support call";
  // In contact, the verdict may take a few expansion steps (at most 12 to grow the simplex to a
  // tetrahedron and 32 more), and the depth its own.
  const int verdict = r.in_contact() ? 12 + 32 : 0;
  const int depth = r.has_penetration_depth ? 12 + r.depth_iterations : 0;
  if (r.support_calls > cold + (r.subalgorithm_runs - 1) + 2 + verdict + depth)
    return "more support calls than the loop's passes allow";
  return nullptr;
}

/// Counts failures per check and keeps the first `keep` messages of each.
class FailureLog {
 public:
  explicit FailureLog(int keep = 5) : keep_(keep) {}

  void add(const std::string& check, const std::string& message) {
    Entry& e = entries_[check];
    if (int(e.messages.size()) < keep_) e.messages.push_back(message);
    ++e.count;
  }
  int count(const std::string& check) const {
    auto it = entries_.find(check);
    return it == entries_.end() ? 0 : it->second.count;
  }
  int total() const {
    int n = 0;
    for (const auto& [name, e] : entries_) n += e.count;
    return n;
  }
  /// All kept messages, one per line, prefixed by the check name and its total count.
  std::string report() const {
    std::string out;
    for (const auto& [name, e] : entries_) {
      out += name + ": " + std::to_string(e.count) + " failure(s)\n";
      for (const std::string& m : e.messages) out += "    " + m + "\n";
    }
    return out;
  }

 private:
  struct Entry {
    int count = 0;
    std::vector<std::string> messages;
  };
  int keep_;
  std::map<std::string, Entry> entries_;
};

/// printf into a std::string.
__attribute__((format(printf, 1, 2))) inline std::string format(const char* fmt, ...) {
  char buffer[1024];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof buffer, fmt, args);
  va_end(args);
  return buffer;
}

inline double median(std::vector<double> values) {
  if (values.empty()) return 0;
  const auto mid = values.begin() + std::ptrdiff_t(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

inline double maximum(const std::vector<double>& values) {
  double m = 0;
  for (double v : values) m = std::max(m, v);
  return m;
}

}  // namespace nearpoint::testkit
