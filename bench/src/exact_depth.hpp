// SPDX-License-Identifier: Apache-2.0
// The exact penetration depth of two posed polytopes, for the depth experiment: the approach of
// tests/oracle/test_penetration_depth.cpp as a small bench-local helper (the bench must not depend
// on a test target). K = A − B is the convex hull of all vertex differences (R_A a + t_A) −
// (R_B b + t_B), evaluated exactly from the double inputs with CGAL's exact kernel; the depth is
// the least distance from the origin to K's facet planes when the origin is strictly inside K,
// else 0. Everything a caller asks of it (is x above or below the truth, how far) is decided in
// exact arithmetic; only the reported double values are rounded.
#pragma once

#include <memory>
#include <vector>

#include "nearpoint/pose.hpp"

namespace nearpoint::bench {

class ExactDepth {
 public:
  ExactDepth(const std::vector<Vec3<double>>& a, const Pose<double>& pose_a,
             const std::vector<Vec3<double>>& b, const Pose<double>& pose_b);
  ~ExactDepth();
  ExactDepth(ExactDepth&&) noexcept;
  ExactDepth& operator=(ExactDepth&&) noexcept;

  /// The origin lies strictly inside K (the depth is positive).
  bool intersecting() const { return intersecting_; }
  /// The depth, √(exact depth²) rounded to double (about an ulp from the truth).
  double depth() const { return depth_; }
  /// x ≥ 0 lies strictly below / above the exact depth (decided exactly).
  bool below(double x) const;
  bool above(double x) const;
  /// |x − depth|, from the exact |x² − depth²| / (x + depth): accurate to a few ulps of the
  /// error itself, so errors far below an ulp of the depth are still measured. NaN for NaN x.
  double error(double x) const;

 private:
  struct Exact;
  std::unique_ptr<Exact> exact_;
  bool intersecting_ = false;
  double depth_ = 0;
};

}  // namespace nearpoint::bench
