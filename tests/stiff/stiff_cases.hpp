// SPDX-License-Identifier: Apache-2.0
// The named suite of stiff and extreme cases (issue: numerical stability). Every case has polytope
// cores (a point, a segment and a box are polytopes too) plus optional radii, so its truth is the
// exact distance of CGAL's oracle on the very inputs the engine sees, minus the radii (eq. 8).
//
// Shared by the test suite (tests/stiff/test_stiff.cpp) and the stability report (bench/).
#pragma once

#include <string>
#include <vector>

#include "nearpoint/pose.hpp"

namespace nearpoint::stiff {

template <class Scalar>
struct StiffCase {
  std::string family;  ///< far, scale, thin, contact, degenerate, large, rounded
  std::string name;    ///< family/what_and_parameter, readable in the test output
  std::vector<Vec3<Scalar>> a, b;
  Scalar radius_a = 0, radius_b = 0;
  Pose<Scalar> pose_a, pose_b;
  /// Characteristic size of the two shapes (largest extent), not of their placement: errors are
  /// stated relative to this, as the eq. (34) shift promises.
  double size = 1;
  /// The shapes overlap by much more than any error bound: the verdict must be "intersecting".
  bool deep_overlap = false;
};

/// All cases, built in double.
std::vector<StiffCase<double>> make_stiff_cases();

/// The same cases with inputs rounded to float (truths are recomputed for the rounded inputs).
std::vector<StiffCase<float>> to_float(const std::vector<StiffCase<double>>& cases);

}  // namespace nearpoint::stiff
