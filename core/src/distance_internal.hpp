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
/// determinant +1. Inline: out of line, the checks were 12% of a query between two spheres (a
/// query now checks both of its poses at once with rigid_poses, below).
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

/// Two lanes of S (GCC ignores vector_size on a dependent type, hence one type per scalar).
template <class S>
struct TwoLanes;
template <>
struct TwoLanes<double> {
  typedef double type __attribute__((vector_size(16)));
};
template <>
struct TwoLanes<float> {
  typedef float type __attribute__((vector_size(8)));
};

/// rigid_pose of two poses at once, one in each lane of a two-lane vector: the same tests with
/// half the instructions (both poses are checked at the start of every query). |x − 1| ≤ tol is
/// written as two one-sided tests, which NaN fails as it fails the absolute value's.
template <class S>
[[gnu::always_inline]] inline bool rigid_poses(const Pose<S>& a, const Pose<S>& b) {
  using V = typename TwoLanes<S>::type;
  const auto r = [&](int i, int j) { return V{a.rotation(i, j), b.rotation(i, j)}; };
  const auto t = [&](int i) { return V{a.translation[i], b.translation[i]}; };
  const V tolerance = V{} + std::max(S(1e-6), S(1000) * std::numeric_limits<S>::epsilon());
  const V zero = V{}, one = V{} + S(1);
  const auto within = [&](V x, V target) {
    return (x - target <= tolerance) & (target - x <= tolerance);
  };
  const V r00 = r(0, 0), r01 = r(0, 1), r02 = r(0, 2);
  const V r10 = r(1, 0), r11 = r(1, 1), r12 = r(1, 2);
  const V r20 = r(2, 0), r21 = r(2, 1), r22 = r(2, 2);
  const V tx = t(0), ty = t(1), tz = t(2);
  const V det =
      r00 * (r11 * r22 - r12 * r21) + r01 * (r12 * r20 - r10 * r22) + r02 * (r10 * r21 - r11 * r20);
  const auto ok = (tx - tx == zero) & (ty - ty == zero) & (tz - tz == zero) &
                  within(r00 * r00 + r10 * r10 + r20 * r20, one) &
                  within(r01 * r01 + r11 * r11 + r21 * r21, one) &
                  within(r02 * r02 + r12 * r12 + r22 * r22, one) &
                  within(r00 * r01 + r10 * r11 + r20 * r21, zero) &
                  within(r00 * r02 + r10 * r12 + r20 * r22, zero) &
                  within(r01 * r02 + r11 * r12 + r21 * r22, zero) & (det > zero);
  return (ok[0] & ok[1]) != 0;
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
