// Entry points shared inside the core: compound queries validate their poses once and then query
// piece pairs without re-checking poses composed from validated ones.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "nearpoint/distance.hpp"

namespace nearpoint::detail {

/// Whether a rotation's columns are orthonormal to within what a rotation built from a float
/// quaternion achieves. Column norms and mutual inner products (18 products) rather than the full
/// RᵀR; NaN fails every comparison. Bitwise: one branch for the whole test.
template <class S>
[[gnu::always_inline]] inline bool orthonormal_columns(const Mat3<S>& rotation) {
  const S tolerance = std::max(S(1e-6), S(1000) * std::numeric_limits<S>::epsilon());
  const auto c0 = rotation.col(0), c1 = rotation.col(1), c2 = rotation.col(2);
  using std::abs;
  return (abs(c0.squaredNorm() - 1) <= tolerance) & (abs(c1.squaredNorm() - 1) <= tolerance) &
         (abs(c2.squaredNorm() - 1) <= tolerance) & (abs(c0.dot(c1)) <= tolerance) &
         (abs(c0.dot(c2)) <= tolerance) & (abs(c1.dot(c2)) <= tolerance);
}

/// Whether a pose is a rigid transformation: finite translation, orthonormal rotation with
/// determinant +1. Inline, so that a query checks its two poses interleaved (out of line, the two
/// calls were 12% of a query between two spheres).
template <class S>
[[gnu::always_inline]] inline bool rigid_pose(const Pose<S>& pose) {
  const Vec3<S>& t = pose.translation;
  // x − x is 0 for a finite x, NaN for ±∞ and NaN.
  const bool finite = (t.x() - t.x() == 0) & (t.y() - t.y() == 0) & (t.z() - t.z() == 0);
  // det R = r₀·(r₁ × r₂) by rows, written out: Eigen's cross product went through the stack as two
  // 8-byte stores read back as one 16-byte load, a store-forwarding stall on every query.
  const Mat3<S>& r = pose.rotation;
  const S det = r(0, 0) * (r(1, 1) * r(2, 2) - r(1, 2) * r(2, 1)) +
                r(0, 1) * (r(1, 2) * r(2, 0) - r(1, 0) * r(2, 2)) +
                r(0, 2) * (r(1, 0) * r(2, 1) - r(1, 1) * r(2, 0));
  return finite & orthonormal_columns(pose.rotation) & (det > 0);
}

/// Why a pose is unusable (non-finite, not orthonormal, a reflection), or nullptr when
/// rigid_pose(pose).
template <class S>
const char* invalid_pose_reason(const Pose<S>& pose);

/// `distance` for poses already known to be valid (the shapes and options are still checked).
template <class S>
DistanceResult<S> distance_with_valid_poses(const Shape<S>& a, const Pose<S>& pose_a,
                                            const Shape<S>& b, const Pose<S>& pose_b,
                                            const DistanceOptions<S>& options, SimplexCache* cache);

}  // namespace nearpoint::detail
