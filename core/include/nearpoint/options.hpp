// SPDX-License-Identifier: Apache-2.0
// Query options. Every default lives here, once, with what it means physically.
#pragma once

#include <limits>

namespace nearpoint {

/// Which routine computes ν(co Y), the point of the current simplex nearest the origin.
enum class Subalgorithm : unsigned char {
  /// Johnson's distance subalgorithm (paper eq. 29–31) with the Backup Procedure (eq. 38) when it
  /// fails numerically: the paper's method.
  johnson,
  /// The signed-volumes method of Montanari, Petrinic & Barbieri (ACM TOG 36(3), 2017): ν(co Y)
  /// from signed volumes and areas of the simplex's best-conditioned projections. More robust for
  /// small or flat simplices far from the origin; it never fails, so the Backup Procedure is used
  /// only after a failed descent (step 6). The default: as accurate as Johnson's on polytopes,
  /// and on curved shapes near contact it keeps converging where the Δ's of a sliver simplex stall
  /// (cylinder vs ellipsoid, 2000 random poses: worst certified bound 1.3e-13 against 7.9e-8).
  signed_volumes,
};

/// The stopping tolerance ε of eq. (35), g(ν) ≤ ε·D(K)². Theorem 1 turns it into an accuracy:
/// the distance is within min(√ε·D, ε·D²/d) of the truth. The default, machine precision squared
/// (4.9e-32 for doubles), makes the answer as accurate as floating point allows: polytopes then
/// end exactly (the support point repeats a simplex vertex, Section IV's finite termination) and
/// curved shapes at the numerical limit, typically 15–30 iterations. A metre-sized touching contact
/// is then resolved to ~1e-16 m instead of the ~1.5e-7 m that eq. (35) with the paper's choice
/// allows (see kPaperEpsilon).
template <class Scalar>
inline constexpr Scalar kDefaultEpsilon =
    std::numeric_limits<Scalar>::epsilon() * std::numeric_limits<Scalar>::epsilon();

/// The paper's choice, "say 100 × machine error" (Section VI): 2.2e-14 for doubles. It stops
/// curved shapes a few iterations earlier, at a distance error of up to √ε·D ≈ 1.5e-7·D when the
/// shapes touch, and ≈ ε·D²/d when they are a distance d apart.
template <class Scalar>
inline constexpr Scalar kPaperEpsilon = Scalar(100) * std::numeric_limits<Scalar>::epsilon();

/// The ε a caller may ask for at nearpoint's boundaries (nearpointd's QueryOptions, `nearpoint
/// distance`): finite and in [0, 1). One rule for every entry point. ε = 0 is meaningful — eq.
/// (35) then never stops the loop, which ends by its other rules (the support point repeats a
/// simplex vertex, no further descent, the roundoff floor), where the default
/// kDefaultEpsilon ≈ 0 ends too. ε ≥ 1 would accept a gap as large as the shapes themselves: no
/// tolerance at all, surely a mistake.
template <class Scalar>
constexpr bool is_valid_epsilon(Scalar epsilon) {
  return epsilon >= Scalar(0) && epsilon < Scalar(1);  // false for NaN and ±inf as well
}

/// An upper limit on GJK iterations. Polytopes end in 3–6 iterations (paper, Section VII) and never
/// need more than a few dozen; smooth shapes converge geometrically and meet eq. (35) within ~40.
/// The cap only guards against pathological input: a capped run says so in its status.
inline constexpr int kDefaultMaxIterations = 256;

/// How a query without a warm-start cache forms its first simplex V₀.
enum class ColdStart : unsigned char {
  /// Section VI's single-point initialisation: V₀ = {s_K(z̄₂ − z̄₁)}, one support point.
  single_point,
  /// That support point and, unless its support plane already proves the shapes apart, the
  /// centroids' difference z̄₁ − z̄₂: a point of K (z̄₁ ∈ A, z̄₂ ∈ B) known without a support
  /// call, usually deep inside K when the shapes overlap. On the paper's 6000 examples it saves
  /// 0.77 iterations per intersecting pair and 0.49 per touching pair. Its simplex entry has no
  /// vertex (index −1 in the result and the cache). With `penetration_bound` the query starts
  /// from the single point instead: a tetrahedron with an interior corner gives a weaker d⁻.
  with_centroids,
};

/// The width the penetration-depth interval is driven to, relative to D(K) (eq. 37): the
/// expansion stops once depth_upper − depth_lower ≤ depth_tolerance·D(K) (or at the roundoff floor
/// that no certificate beats, a few ulps of D(K)). 4096 ulps: 9.1e-13 in double, 4.9e-4 in
/// float. Polytope pairs end earlier, at their floor (≈1e-14·D), when the nearest face of the
/// expanding polytope is a face of K; curved shapes converge like the mesh that approximates them
/// (the width falls roughly fourfold per refinement of the face nearest the origin) and usually
/// end at the iteration cap with a wider, still certified, interval.
template <class Scalar>
inline constexpr Scalar kDefaultDepthTolerance =
    Scalar(4096) * std::numeric_limits<Scalar>::epsilon();

/// The cap on expansion steps of the penetration-depth polytope (each adds one support point and
/// two faces). Polytopes need a handful to a few dozen; curved shapes use all of them.
inline constexpr int kDefaultDepthMaxIterations = 128;

/// The largest cap a query accepts (the face buffer is sized for it once per thread): larger
/// requests are clamped.
inline constexpr int kLargestDepthMaxIterations = 4096;

template <class Scalar>
struct DistanceOptions {
  /// ε of eq. (35). Smaller is more accurate until roundoff dominates; larger exits earlier for
  /// smooth shapes (polytopes end in finitely many steps either way).
  Scalar epsilon = kDefaultEpsilon<Scalar>;
  /// Iteration cap (see kDefaultMaxIterations).
  int max_iterations = kDefaultMaxIterations;
  /// Move the origin to the midpoint of the two centroids (eq. 34) so that inner products do not
  /// lose precision to large coordinates. Off only for studying its effect.
  bool origin_shift = true;
  /// Subalgorithm used for ν(co Y).
  Subalgorithm subalgorithm = Subalgorithm::signed_volumes;
  /// The first simplex of a query without a warm-start cache (see ColdStart).
  ColdStart cold_start = ColdStart::with_centroids;
  /// Stop as soon as the shapes are proven farther apart than this (a certified lower bound from
  /// a support plane exceeds it by more than its roundoff): the answer is then "separated,
  /// distance > cutoff" and the result says `beyond_cutoff`. 0 turns a query into a yes/no
  /// intersection test; well-separated pairs are then decided by the first support point.
  Scalar distance_cutoff = std::numeric_limits<Scalar>::infinity();

  // What to compute beyond the distance. Each is opt-in: a query pays only for what it asks.
  /// Near points on each shape and the unit normal (eq. 23–24).
  bool near_points = false;
  /// The lower bound d⁻ on the penetration depth when the shapes intersect (eq. 32–33).
  bool penetration_bound = false;
  /// The gradient of the distance with respect to both poses (Section II). With
  /// `penetration_depth`, the gradient of the signed distance, also when intersecting.
  bool gradient = false;
  /// The penetration depth when the shapes intersect, with a certified interval, witness points
  /// and direction, and the signed distance (distance when separated, −depth when intersecting)
  /// with its interval: see DistanceResult. Costs nothing on separated pairs; on intersecting
  /// pairs an expanding polytope (EPA) inside K = A − B runs after GJK.
  bool penetration_depth = false;
  /// See kDefaultDepthTolerance (relative to D(K); 0 runs to the floor or the cap).
  Scalar depth_tolerance = kDefaultDepthTolerance<Scalar>;
  /// See kDefaultDepthMaxIterations (clamped to [0, kLargestDepthMaxIterations]).
  int depth_max_iterations = kDefaultDepthMaxIterations;
};

}  // namespace nearpoint
