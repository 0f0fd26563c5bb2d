// SPDX-License-Identifier: Apache-2.0
// Entry points shared inside the core: compound queries validate their poses once and then query
// piece pairs without re-checking poses composed from validated ones. Part of the engine for
// Gilbert, Johnson & Keerthi's algorithm (IEEE J. Robotics and Automation 4(2), 1988): the
// citation and the departures are in distance.cpp and gjk.hpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "nearpoint/distance.hpp"

namespace nearpoint::detail {

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

/// R·v and Rᵀ·v written out. Eigen's generic 3×3 product is left out of line by GCC in this loop
/// (a call and a copy per support call, measured: 5% of a query).
template <class S>
[[gnu::always_inline]] inline Vec3<S> rotate(const Mat3<S>& r, const Vec3<S>& v) {
  return Vec3<S>(r(0, 0) * v.x() + r(0, 1) * v.y() + r(0, 2) * v.z(),
                 r(1, 0) * v.x() + r(1, 1) * v.y() + r(1, 2) * v.z(),
                 r(2, 0) * v.x() + r(2, 1) * v.y() + r(2, 2) * v.z());
}
template <class S>
[[gnu::always_inline]] inline Vec3<S> rotate_back(const Mat3<S>& r, const Vec3<S>& v) {
  return Vec3<S>(r(0, 0) * v.x() + r(1, 0) * v.y() + r(2, 0) * v.z(),
                 r(0, 1) * v.x() + r(1, 1) * v.y() + r(2, 1) * v.z(),
                 r(0, 2) * v.x() + r(1, 2) * v.y() + r(2, 2) * v.z());
}

/// A pose applied to a point (Pose::apply) with the product above, for the bounding spheres of a
/// compound query (Eigen's product was a call there). It may differ from Pose::apply in the last
/// bit. Piece poses keep Pose::compose (of the object poses moved to A's position, see
/// compound.cpp), so that a piece is queried exactly as a caller composing those would query it.
template <class S>
[[gnu::always_inline]] inline Vec3<S> apply_pose(const Pose<S>& pose, const Vec3<S>& local) {
  return rotate(pose.rotation, local) + pose.translation;
}

/// Whether rotation columns are orthonormal to within what a rotation built from a float
/// quaternion achieves: column norms and mutual inner products (18 products) rather than the full
/// RᵀR. `r(i, j)` gives entry (i, j) as V, a scalar S or TwoLanes<S> (two rotations at once); the
/// result is a bool or a lane mask. |x − 1| ≤ tol is written as two one-sided tests, which NaN
/// fails as it fails the absolute value's. Bitwise: one branch for the whole test.
template <class S, class V, class Entry>
[[gnu::always_inline]] inline auto orthonormal_lanes(const Entry& r, V* defect = nullptr) {
  const V tolerance = V{} + std::max(S(1e-6), S(1000) * std::numeric_limits<S>::epsilon());
  const V zero = V{}, one = V{} + S(1);
  const auto within = [&](V x, V target) {
    return (x - target <= tolerance) & (target - x <= tolerance);
  };
  const V r00 = r(0, 0), r01 = r(0, 1), r02 = r(0, 2);
  const V r10 = r(1, 0), r11 = r(1, 1), r12 = r(1, 2);
  const V r20 = r(2, 0), r21 = r(2, 1), r22 = r(2, 2);
  const V n0 = r00 * r00 + r10 * r10 + r20 * r20;
  const V n1 = r01 * r01 + r11 * r11 + r21 * r21;
  const V n2 = r02 * r02 + r12 * r12 + r22 * r22;
  const V d01 = r00 * r01 + r10 * r11 + r20 * r21;
  const V d02 = r00 * r02 + r10 * r12 + r20 * r22;
  const V d12 = r01 * r02 + r11 * r12 + r21 * r22;
  if (defect) {
    // ‖RᵀR − I‖_F² from the same products (see rotation_defect2), for the bound: no absolute
    // values or maxima, a few multiply-adds per lane. Meaningful where the mask below holds.
    const V e0 = n0 - one, e1 = n1 - one, e2 = n2 - one;
    *defect = e0 * e0 + e1 * e1 + e2 * e2 + S(2) * (d01 * d01 + d02 * d02 + d12 * d12);
  }
  return within(n0, one) & within(n1, one) & within(n2, one) & within(d01, zero) &
         within(d02, zero) & within(d12, zero);
}

/// Whether a rotation's columns are orthonormal (see orthonormal_lanes).
template <class S>
[[gnu::always_inline]] inline bool orthonormal_columns(const Mat3<S>& rotation) {
  return orthonormal_lanes<S, S>([&](int i, int j) { return rotation(i, j); });
}

/// Whether two poses are rigid transformations (finite translation, orthonormal rotation with
/// determinant +1), one in each lane of a two-lane vector: both poses are checked at the start of
/// every query, and this is half the instructions of two scalar checks. Inline: out of line, the
/// checks were 12% of a query between two spheres.
/// With `defect_a`, pose a's rotation_defect2 is written there (valid when the result is true).
template <class S>
[[gnu::always_inline]] inline bool rigid_poses(const Pose<S>& a, const Pose<S>& b,
                                               S* defect_a = nullptr) {
  using V = typename TwoLanes<S>::type;
  const auto r = [&](int i, int j) { return V{a.rotation(i, j), b.rotation(i, j)}; };
  const auto t = [&](int i) { return V{a.translation[i], b.translation[i]}; };
  const V zero = V{};
  const V tx = t(0), ty = t(1), tz = t(2);
  // det R = r₀·(r₁ × r₂) by rows, written out: Eigen's cross product went through the stack as two
  // 8-byte stores read back as one 16-byte load, a store-forwarding stall on every query.
  const V det = r(0, 0) * (r(1, 1) * r(2, 2) - r(1, 2) * r(2, 1)) +
                r(0, 1) * (r(1, 2) * r(2, 0) - r(1, 0) * r(2, 2)) +
                r(0, 2) * (r(1, 0) * r(2, 1) - r(1, 1) * r(2, 0));
  // x − x is 0 for a finite x, NaN for ±∞ and NaN.
  V defect = zero;
  const auto ok = (tx - tx == zero) & (ty - ty == zero) & (tz - tz == zero) &
                  orthonormal_lanes<S, V>(r, defect_a ? &defect : nullptr) & (det > zero);
  if (defect_a) *defect_a = defect[0];
  return (ok[0] & ok[1]) != 0;
}

/// Whether one pose is a rigid transformation (rigid_poses with the pose in both lanes).
template <class S>
[[gnu::always_inline]] inline bool rigid_pose(const Pose<S>& pose) {
  return rigid_poses(pose, pose);
}

/// The squared defect of a rotation matrix, ‖RᵀR − I‖_F², from the columns' norms and inner
/// products. A's frame is entered through R_Aᵀ, which is R_A⁻¹ only when the defect is 0; the
/// error this makes is added to the bound (see `query` in distance.cpp).
template <class S>
[[gnu::always_inline]] inline S rotation_defect2(const Mat3<S>& r) {
  const auto dot = [&](int i, int j) {
    return r(0, i) * r(0, j) + r(1, i) * r(1, j) + r(2, i) * r(2, j);
  };
  const S e0 = dot(0, 0) - S(1), e1 = dot(1, 1) - S(1), e2 = dot(2, 2) - S(1);
  const S d01 = dot(0, 1), d02 = dot(0, 2), d12 = dot(1, 2);
  return e0 * e0 + e1 * e1 + e2 * e2 + S(2) * (d01 * d01 + d02 * d02 + d12 * d12);
}

/// R_B z_B + p_B − (R_A z_A + p_A) (world frame) with error-free products (fma) and a compensated
/// sum (Ogita, Rump & Oishi's Dot2): its error is ~ε of the result however large the terms that
/// cancel in it, plus what accumulating the exact error terms rounds. That second part is ~ε² of
/// the terms (Dot2's γ_n² term) and stays when the terms cancel to far below them: two points
/// modelled 6.6e5 from their local origins and placed at one spot came 2^-30 apart in float.
/// `pose_a` may be null (then only R_B z_B + p_B). When `residual` is given it receives
/// Σ|running error| over the additions and components, R: each addition to the running error
/// rounds by at most u = ε/2 of its new value, so the result beyond ~ε of itself is off by at most
/// ε/2·R per component, and R is a length for the working magnitude (8ε·R covers it).
template <class S>
Vec3<S> compensated_difference(const Pose<S>& pose_b, const Vec3<S>& z_b, const Pose<S>* pose_a,
                               const Vec3<S>& z_a, S* residual = nullptr) {
  Vec3<S> w;
  S accumulated = 0;
  for (int i = 0; i < 3; ++i) {
    S sum = 0, error = 0;
    const auto accumulate = [&](S exact_error) {
      error += exact_error;
      accumulated += std::abs(error);
    };
    const auto add = [&](S x) {  // TwoSum (Knuth): sum + x = t + e exactly
      const S t = sum + x;
      const S z = t - sum;
      accumulate((sum - (t - z)) + (x - z));
      sum = t;
    };
    const auto add_product = [&](S x, S y) {  // TwoProduct: x·y = p + e exactly
      const S p = x * y;
#ifdef __FMA__
      accumulate(std::fma(x, y, -p));
#else
      // Dekker's product with Veltkamp's split: std::fma without the instruction is a slow
      // library emulation.
      constexpr S split = S(1 << ((std::numeric_limits<S>::digits + 1) / 2)) + S(1);
      // Split scaled down by an exact power of two where split·v would overflow (float vertices
      // at 4e36: inf − inf made δ NaN and the query answered "intersecting", bound 0; found by
      // fuzz_engine). The high half scales back exactly, so v = high + low stays exact.
      constexpr S shrink = S(1) / S(1 << ((std::numeric_limits<S>::digits + 1) / 2 + 1));
      const auto halves = [&](S v, S& high, S& low) {
        if (std::abs(v) <= std::numeric_limits<S>::max() * shrink) [[likely]] {
          const S c = split * v;
          high = c - (c - v);
        } else {
          const S w = v * shrink, c = split * w;
          high = (c - (c - w)) / shrink;
        }
        low = v - high;
      };
      S xh, xl, yh, yl;
      halves(x, xh, xl);
      halves(y, yh, yl);
      accumulate(((xh * yh - p) + xh * yl + xl * yh) + xl * yl);
#endif
      add(p);
    };
    for (int j = 0; j < 3; ++j) add_product(pose_b.rotation(i, j), z_b[j]);
    add(pose_b.translation[i]);
    if (pose_a) {
      for (int j = 0; j < 3; ++j) add_product(-pose_a->rotation(i, j), z_a[j]);
      add(-pose_a->translation[i]);
    }
    w[i] = sum + error;
  }
  if (residual) *residual = accumulated;
  return w;
}

/// The centroid offset δ of eq. (34) in A's frame, formed so that far local coordinates do not
/// round it: w = (R_B z̄_B + p_B) − (R_A z̄_A + p_A), the world-frame difference of the two
/// centroids, compensated (a cube modelled at local x = 1e8 and placed back by its pose: terms of
/// 1e8, w of 1), then δ = R_Aᵀ w. Forming w in the world frame also keeps R_A's defect away from
/// z̄_A: the direct R_Aᵀ(R_B z̄_B + p_B − p_A) − z̄_A carries (R_AᵀR_A − I) z̄_A, which grows with
/// the local coordinates.
/// `residual` as in compensated_difference.
template <class S>
Vec3<S> centroid_offset(const Pose<S>& pose_a, const Vec3<S>& center_a, const Pose<S>& pose_b,
                        const Vec3<S>& center_b, S& residual) {
  return rotate_back(pose_a.rotation,
                     compensated_difference(pose_b, center_b, &pose_a, center_a, &residual));
}

/// The range of D(K) the loop runs in as given: [2^low, 2^high]. Inside it no square, product or
/// Johnson Δ (up to D⁷ for a tetrahedron's ν numerator) under- or overflows, with room for ε²
/// factors; outside it K is rescaled by a power of two first (see rescaled_query). Scaling by 2^k
/// is exact, so the answers of the two paths agree bit for bit wherever both are representable.
template <class S>
struct LoopRange;
template <>
struct LoopRange<double> {
  static constexpr int low = -128, high = 128;  // D⁷ within 2^±896 of 1
};
template <>
struct LoopRange<float> {
  static constexpr int low = -16, high = 16;  // D⁷ within 2^±112 of 1
};

/// What rescaling can bring into that range: K whose working magnitude M (every length whose ulps
/// the bound counts) is at most 2^kMeasurableSpread<S> times D(K). Past it D(K) is too small
/// against M to be measured in this precision and the query is refused ("shapes differ too much
/// in size"); compound queries use it to know, before evaluating a piece pair, whether it could be
/// refused at all.
template <class S>
constexpr int kMeasurableSpread = LoopRange<S>::high - LoopRange<S>::low - 1;

/// Marks a result as rejected input, with the reason.
template <class S>
inline void set_invalid(DistanceResult<S>& result, const char* message) {
  result.status = Status::invalid_input;
  result.message = message;
}

/// Why a pose is unusable (non-finite, not orthonormal, a reflection), or nullptr when
/// rigid_pose(pose).
template <class S>
const char* invalid_pose_reason(const Pose<S>& pose);

/// Why one of two poses is unusable (pose a's reason first), or nullptr when both are rigid: the
/// check of every query, both poses at once, with the reason looked up only on failure.
template <class S>
[[gnu::always_inline]] inline const char* invalid_poses_reason(const Pose<S>& a, const Pose<S>& b,
                                                               S* defect_a = nullptr) {
  if (rigid_poses(a, b, defect_a)) return nullptr;
  const char* why = invalid_pose_reason(a);
  return why ? why : invalid_pose_reason(b);
}

/// `distance` for poses already known to be valid (the shapes and options are still checked),
/// written into `result`, which must be freshly default-constructed: the answer is built where the
/// caller keeps it (a compound query's best result) instead of being returned and copied.
/// `defect2_a` is rotation_defect2(pose_a.rotation), which the pose check computes anyway.
/// `placement` is a length whose few ulps bound how far rounding moved the poses before this call
/// (a compound's piece poses composed from its body poses; 0 for the caller's own poses): the
/// bound covers it (see the working magnitude in distance.cpp).
template <class S>
void distance_with_valid_poses(const Shape<S>& a, const Pose<S>& pose_a, const Shape<S>& b,
                               const Pose<S>& pose_b, const DistanceOptions<S>& options,
                               SimplexCache* cache, DistanceResult<S>& result, S defect2_a,
                               S placement = 0);

}  // namespace nearpoint::detail
