// SPDX-License-Identifier: Apache-2.0
// The exact oracle: the distance between the convex hulls of two point sets, computed by CGAL's
// Polytope_distance_d (a quadratic program solved in exact arithmetic), for the very inputs that
// nearpoint sees.
//
// "The very inputs" matters: a pose holds a rotation matrix and a translation in floating point,
// and the hull nearpoint measures is that of R·v + t with those floating-point entries (the
// rotation need not be exactly orthonormal). The oracle evaluates R·v + t exactly (sums of
// products of doubles are exact in CGAL::Gmpzf, an arbitrary-precision binary float), so its
// answer is the exact distance for the engine's input, not for a rounded copy of it. The only
// roundings are at the very end: the exact rational squared distance goes to 256-bit MPFR, is
// square-rooted there and rounded once to the nearest double.
//
// Speed. CGAL's exact QP costs about a millisecond even for a handful of points and grows with the
// point count, so the oracle solves a small subproblem and proves it is the whole answer
// (column generation): it runs Polytope_distance_d on candidate subsets A' ⊂ A, B' ⊂ B, takes the
// exact realising points p_a, p_b and w = p_b − p_a, and checks exactly that w·a ≤ w·p_a for every
// vertex a of A and w·b ≥ w·p_b for every b of B. When that holds, the slab between the two
// support planes separates the full hulls, so d(A, B) = |w| = d(A', B') exactly; otherwise the
// violating vertices join the subsets and the subproblem is solved again. If the subsets already
// intersect, so do the full hulls. The candidates only affect speed, never the answer: a caller
// may pass any indices as a hint (for instance the support sets of a nearby configuration).
#pragma once

#include <span>
#include <vector>

#include "nearpoint/pose.hpp"

namespace nearpoint::testkit {

struct ExactDistance {
  /// The distance between the two hulls, world frame: √(exact squared distance), rounded to the
  /// nearest double (correctly rounded up to a 2⁻²⁰⁰ relative error from the 256-bit square root).
  double distance = 0;
  /// The exact squared distance, rounded to the nearest double.
  double squared_distance = 0;
  /// The hulls share a point: the exact squared distance is zero. Decided exactly.
  bool intersecting = false;
  /// A pair of points realising the distance (world frame), each coordinate an exact rational
  /// rounded to the nearest double. When intersecting they are one common point.
  Vec3<double> point_a = Vec3<double>::Zero();
  Vec3<double> point_b = Vec3<double>::Zero();
  /// Indices (into the input lists) of the vertices whose convex combination gives the realising
  /// points: a good hint for a nearby configuration.
  std::vector<int> support_a;
  std::vector<int> support_b;
  /// How many exact subproblems were solved (1 when the hint was right).
  int rounds = 0;
};

/// Exact distance between co{pose_a.rotation·v + pose_a.translation : v ∈ local_a} and the same
/// for B, with the transform evaluated exactly from the Scalar entries (float or double).
/// Both vertex lists must be non-empty and finite. `hint_a`, `hint_b`: optional starting candidate
/// indices (out-of-range entries are ignored); they change the run time, not the result.
template <class Scalar>
ExactDistance exact_distance(std::span<const Vec3<Scalar>> local_a, const Pose<Scalar>& pose_a,
                             std::span<const Vec3<Scalar>> local_b, const Pose<Scalar>& pose_b,
                             std::span<const int> hint_a = {}, std::span<const int> hint_b = {});

template <class Scalar>
ExactDistance exact_distance(const std::vector<Vec3<Scalar>>& local_a, const Pose<Scalar>& pose_a,
                             const std::vector<Vec3<Scalar>>& local_b, const Pose<Scalar>& pose_b,
                             std::span<const int> hint_a = {}, std::span<const int> hint_b = {}) {
  return exact_distance<Scalar>(std::span<const Vec3<Scalar>>(local_a), pose_a,
                                std::span<const Vec3<Scalar>>(local_b), pose_b, hint_a, hint_b);
}

/// The support value h(u) = max_v u·(R·v + t) of a posed vertex list, world frame, evaluated in
/// long double (64-bit mantissa): used to check that a reported near point lies in its shape.
template <class Scalar>
long double support_value(std::span<const Vec3<Scalar>> local, const Pose<Scalar>& pose,
                          const Vec3<long double>& direction);

}  // namespace nearpoint::testkit
