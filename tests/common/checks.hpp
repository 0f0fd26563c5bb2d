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
