// SPDX-License-Identifier: Apache-2.0
// An exact bracket on the distance between two bodies of polytope-representable pieces (point,
// segment, box, polytope; each with a spherical radius), cheap enough for a fuzz target that runs
// millions of inputs (CGAL's full QP, `exact_distance`, costs about a millisecond).
//
// Everything is exact: the world vertices W = R_body·(R_offset·v + t_offset) + t_body are
// evaluated from the very Scalar entries in CGAL::Gmpzf (exact +, −, ×), and every comparison
// that would need |u| or a square root is made between squares. Nothing is rounded, so a check
// built on this bracket needs no slack at all:
//   - lower: for a direction u and every piece pair (i, j),
//       L_ij(u) = (min_{b ∈ B_j} u·b − max_{a ∈ A_i} u·a) / |u| − r_i − r_j
//     is at most the pair's distance, so (min_ij L_ij(u))⁺ ≤ the bodies' distance;
//   - upper: points of the pieces (convex combinations Σλ·W of their vertices, index −1 being the
//     vertex mean) are at least the distance apart, so (|q − p| − r_i − r_j)⁺ ≥ the distance;
//   - within: a point lies within r + slack of a piece's core along u;
//   - truth: the exact distance itself (CGAL's Polytope_distance_d on the exact points), for the
//     inputs a caller can afford it on.
// Thresholds are given as short sums of doubles (distance + error_bound, distance −
// error_bound), added exactly. The header is CGAL-free; the number type lives in the .cpp.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <vector>

#include "nearpoint/pose.hpp"
#include "nearpoint/shapes.hpp"

namespace nearpoint::testkit {

/// One convex piece: the hull of `vertices` (its local frame) grown by `radius`, placed in its
/// body's frame by `offset` (identity for a single shape).
template <class Scalar>
struct BracketPiece {
  std::vector<Vec3<Scalar>> vertices;
  Scalar radius = 0;
  Pose<Scalar> offset;
};

/// The core's vertices in the engine's index order (point: the origin; segment: a, b; box: the 8
/// corners, coordinate k positive when bit k of the index is set; polytope: as given), or false
/// for a curved shape (cylinder, cone, ellipsoid), which has none.
template <class Scalar>
bool core_vertices(const Shape<Scalar>& shape, std::vector<Vec3<Scalar>>& out);

/// A threshold: a sum of up to four doubles (floats convert exactly), evaluated exactly.
struct ExactSum {
  double terms[4] = {0, 0, 0, 0};
  int count = 0;
  ExactSum(std::initializer_list<double> list) {
    for (double x : list)
      if (count < 4) terms[count++] = x;
  }
  double approx() const {
    long double s = 0;
    for (int i = 0; i < count; ++i) s += terms[i];
    return double(s);
  }
};

class ExactBracket {
 public:
  template <class Scalar>
  ExactBracket(const std::vector<BracketPiece<Scalar>>& a, const Pose<Scalar>& pose_a,
               const std::vector<BracketPiece<Scalar>>& b, const Pose<Scalar>& pose_b);
  ~ExactBracket();
  ExactBracket(const ExactBracket&) = delete;
  ExactBracket& operator=(const ExactBracket&) = delete;

  /// (min over piece pairs of L_ij(u))⁺ ≤ threshold, decided exactly. u must be finite and
  /// nonzero (else true: no bound). `approx` (optional): the bound, rounded, for messages.
  bool lower_at_most(const double u[3], const ExactSum& threshold, double* approx = nullptr) const;

  enum class Upper { holds, fails, out_of_range, unusable };
  /// The exact points p = Σλ_k W_a[index_a[k]] / Σλ_k on A's piece `piece_a` and q likewise on
  /// B's piece `piece_b` (index −1: the piece's vertex mean): is (|q − p| − r_a − r_b)⁺ ≥
  /// threshold? `out_of_range` for an index that is not a vertex of its piece, `unusable` for
  /// weights that are not finite and ≥ 0 with a positive sum (or no simplex).
  Upper upper_at_least(int piece_a, int piece_b, int count, const std::int32_t* index_a,
                       const std::int32_t* index_b, const double* weights,
                       const ExactSum& threshold, double* approx = nullptr) const;

  /// Does `point` lie within radius + slack of the core of piece `piece` of body `side` (0: A,
  /// 1: B) along u, i.e. u·point − max_W u·W ≤ (radius + slack)·|u|? Exact; true for u = 0.
  bool within_along(int side, int piece, const double point[3], const double u[3],
                    const ExactSum& slack) const;

  /// The bracket's own closest point on the reported simplex, independent of the engine's
  /// subalgorithm: the point of least norm in the hull of d_k = q_k − p_k (p_k the point of
  /// A's piece `piece_a` named by index_a[k], q_k likewise on B; index −1: the vertex mean), the
  /// differences formed exactly and rounded to double, tried over every subset of the ≤ 4
  /// points. Writes its weights (≥ 0, 0 for points left out) and the direction Σλ_k·d_k, which
  /// points from A to B. False (nothing written) for unusable indices or a zero direction.
  bool closest_on_simplex(int piece_a, int piece_b, int count, const std::int32_t* index_a,
                          const std::int32_t* index_b, double weights[4],
                          double direction[3]) const;

  /// The exact distance t = min_ij (d(A_i, B_j) − r_i − r_j)⁺ (CGAL's QP per piece pair, ~1 ms
  /// each, far more when the exact world coordinates are long): whether lo ≤ t and t ≤ hi, and t
  /// rounded for messages.
  struct Truth {
    bool at_least_lo = true;
    bool at_most_hi = true;
    double approx = 0;
    int qp_pairs = 0;  // piece pairs that needed CGAL's QP
  };
  Truth truth(const ExactSum& lo, const ExactSum& hi) const;

  /// The same verdicts, with the QP only where exact witnesses do not already give them: a piece
  /// pair is at least lo when its support-plane bound L_ij(u) along one of `directions` (or the
  /// pair's vertex means' difference) is, and t ≤ hi is taken as given when `hi_known` (the
  /// caller has shape points within hi). The remaining pairs get the QP, B's piece `prefer_b`
  /// and A's `prefer_a` first for hi. `approx` is then the least QP result (0 when none ran).
  Truth truth_where_needed(const ExactSum& lo, const ExactSum& hi,
                           const std::vector<std::array<double, 3>>& directions, bool hi_known,
                           int prefer_a, int prefer_b) const;

  int pieces(int side) const;
  int vertices(int side, int piece) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace nearpoint::testkit
