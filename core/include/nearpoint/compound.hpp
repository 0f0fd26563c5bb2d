// SPDX-License-Identifier: Apache-2.0
// Objects made of several convex pieces (paper eq. 2–4): the distance between two such objects is
// the minimum over piece pairs, and the pieces may each carry a radius (eq. 7–8).
#pragma once

#include <span>
#include <vector>

#include "nearpoint/distance.hpp"

namespace nearpoint {

/// One convex piece of a compound object: a shape placed in the object's frame by `offset`.
template <class Scalar>
struct Piece {
  Shape<Scalar> shape;
  Pose<Scalar> offset;
};

/// A union of convex pieces. Construction precomputes a bounding sphere per piece (object frame,
/// radius included) so that queries can skip piece pairs that cannot beat the best distance found.
template <class Scalar>
class Compound {
 public:
  Compound() = default;
  explicit Compound(std::vector<Piece<Scalar>> pieces);

  std::size_t size() const { return pieces_.size(); }
  const Piece<Scalar>& piece(std::size_t i) const { return pieces_[i]; }
  /// Bounding sphere of piece i in the object's frame.
  const Vec3<Scalar>& sphere_center(std::size_t i) const { return centers_[i]; }
  Scalar sphere_radius(std::size_t i) const { return radii_[i]; }
  /// Whether piece i's offset is exactly the identity: its pose is then the object's, and a query
  /// uses that pose as it is instead of composing the two.
  bool at_origin(std::size_t i) const { return at_origin_[i] != 0; }
  /// nullptr when usable; otherwise why not (no pieces, an invalid piece or offset).
  const char* invalid_reason() const { return invalid_reason_; }

 private:
  std::vector<Piece<Scalar>> pieces_;
  std::vector<Vec3<Scalar>> centers_;
  std::vector<Scalar> radii_;
  std::vector<unsigned char> at_origin_;
  const char* invalid_reason_ = "compound has no pieces";
};

template <class Scalar>
struct CompoundResult {
  /// The result for the nearest piece pair (its near points and gradient refer to the whole
  /// objects' poses). Its `error_bound` covers the objects' distance, not only this pair's: when
  /// another evaluated pair's interval [distance − error_bound, distance + error_bound] reaches
  /// lower, the bound is widened to reach it. When intersecting and a penetration bound was asked
  /// for, `penetration_bound` is the largest d⁻ over the intersecting piece pairs (paper, Section
  /// VIII).
  ///
  /// With `penetration_depth`: every piece pair that may intersect is evaluated, and `nearest` is
  /// the deepest pair (the least signed distance, as Drake defines it for geometry sets); its
  /// signed-distance interval is [least lower end, least upper end] over the pairs, certified
  /// to contain the least signed distance over piece pairs, and depth_lower/depth_upper are its
  /// negation. What that certifies about the union: its depth (the translation separating every
  /// piece pair at once) is at least the deepest pair's, so `depth_lower` is a certified lower
  /// bound on the objects' depth; `depth_upper` bounds the deepest pair's depth only (the union's
  /// can be larger when the pairs push apart in different directions). The witnesses, direction
  /// and gradient are the deepest pair's.
  ///
  /// When a piece pair is refused (`invalid_input`, e.g. pieces that differ too much in size from
  /// their separation to be measured in this precision), so is the query, with that pair's reason.
  /// Every pair that could be refused is evaluated whatever the best distance found before it, so
  /// whether a query is refused does not depend on the warm-start caches.
  DistanceResult<Scalar> nearest;
  int piece_a = -1;
  int piece_b = -1;
  /// Piece pairs on which GJK ran, and those skipped because their bounding spheres could not
  /// beat the best distance already found (or lie beyond the cutoff).
  int pairs_evaluated = 0;
  int pairs_pruned = 0;
  /// Of the evaluated pairs, those that stopped as soon as a support plane proved them farther
  /// than the best distance found before them (their GJK ran with that as its cutoff).
  int pairs_stopped_at_best = 0;
  /// DistanceResult::support_calls and subalgorithm_runs summed over the evaluated pairs: the
  /// whole query's cost (`nearest` counts only its own pair's).
  int support_calls = 0;
  int subalgorithm_runs = 0;
};

/// Distance between compound objects. `caches` is either empty (cold starts) or holds one
/// SimplexCache per piece pair, indexed piece_a * b.size() + piece_b, read and updated.
///
/// Piece poses are composed with the scene moved to A's position, (R_A, 0) and
/// (R_B, p_B − p_A), as the single-shape query places B relative to A: objects far from the world
/// origin keep their pieces' placement to the ulps of their size, not of their world coordinates.
/// A piece pair is skipped only when its bounding spheres' gap, less its rounding, exceeds the
/// best distance plus that distance's error bound: the answer is then certified as a single
/// query's is.
template <class Scalar>
CompoundResult<Scalar> distance(const Compound<Scalar>& a, const Pose<Scalar>& pose_a,
                                const Compound<Scalar>& b, const Pose<Scalar>& pose_b,
                                const DistanceOptions<Scalar>& options = {},
                                std::span<SimplexCache> caches = {});

}  // namespace nearpoint
