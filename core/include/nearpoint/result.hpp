// SPDX-License-Identifier: Apache-2.0
// What a distance query returns, and the warm-start cache it reads and writes.
#pragma once

#include <cstdint>

#include "nearpoint/options.hpp"
#include "nearpoint/pose.hpp"

namespace nearpoint {

/// The verdict of a query.
enum class Status : unsigned char {
  /// The shapes are disjoint: `distance` > 0 (or, with a cutoff, proven beyond it).
  separated,
  /// The shapes overlap, proven: the signed distance is certified below 0 (`distance` is 0).
  intersecting,
  /// The iteration cap was reached before eq. (35) held. `distance` is an upper bound on the
  /// true distance and `error_bound` still bounds the error; the verdict is unknown.
  iteration_limit,
  /// The input was unusable (non-finite pose, empty polytope, negative radius …): see `message`.
  invalid_input,
  /// Contact within the bound: the shapes touch, or are closer than `error_bound` can tell apart
  /// from touching, or overlap by less than can be proven (`distance` is 0, the true distance is
  /// at most `error_bound`). The signed distance's certified interval contains 0. Callers that
  /// only need "in contact or not" test `status != Status::separated` (with a valid verdict).
  /// (Last in the enum so that the values of the others keep their meaning.)
  touching,
};

const char* to_string(Status status);

/// Which routine produced the final simplex (paper Section VI, step 2: alg = DS or BP).
enum class FinishedBy : unsigned char {
  distance_subalgorithm,  ///< Johnson's subalgorithm succeeded (the normal case)
  backup_procedure,       ///< the Backup Procedure, eq. (38), after a numerical failure
};

/// How the loop of Section VI ended. Every exit returns a point ν of K with its certified bound.
enum class Termination : unsigned char {
  /// ν = 0: the origin is in the simplex, so the cores intersect (g = 0).
  origin_enclosed,
  /// Eq. (35): g(ν) ≤ ε·D(K)².
  tolerance,
  /// The new support point is already a vertex of the simplex, so g = 0 in exact arithmetic: the
  /// finite termination of polytopes (Section IV), taken when g is at its roundoff level.
  repeated_support,
  /// Step 5 with g zero to within its roundoff: no further descent is possible and the optimality
  /// condition of Theorem 1 holds in floating point. The usual end for curved shapes when ε is
  /// below what roundoff allows; also the end for polytopes whose support point ties with the
  /// current face (g within roundoff, the interval [L, |ν|] at the bound's roundoff allowance).
  roundoff_floor,
  /// Step 5 with g clearly above its roundoff: descent stalled (a near-degenerate simplex). The
  /// best iterate is returned and the error bound says how good it is.
  numerical_limit,
  /// The support plane proved the distance larger than `options.distance_cutoff`.
  beyond_cutoff,
  /// `options.max_iterations` was reached first.
  iteration_limit,
  /// |ν| fell so low that the verdict is settled and further iterations could not change it:
  /// within the roundoff allowance of r_A + r_B ("touching"), or below half of the radii's sum
  /// less the allowance (rounded shapes: "intersecting", the overlap proven). Taken only when
  /// near points, d⁻, depth and the gradient were not asked for (they need the converged
  /// simplex).
  contact,
};

const char* to_string(Termination termination);

/// How the penetration-depth computation ended (DistanceResult::depth_termination).
enum class DepthTermination : unsigned char {
  /// Nothing to expand: the shapes are separated (depth 0), or only their rounded shells overlap
  /// (cores apart: the depth is r_A + r_B − d, from the distance's own certified interval), or
  /// their cores are within the error bound of touching.
  closed_form,
  /// The interval is within `depth_tolerance`·D(K) (or the roundoff floor): converged.
  tolerance,
  /// The iteration cap (`depth_max_iterations`) or the face buffer was reached first: the
  /// interval is certified but wider than asked. The usual end for curved shapes at the default
  /// tolerance.
  iteration_limit,
  /// K has no interior (flat or needle-thin: two coplanar faces, crossing segments …) or the
  /// expansion met a configuration rounding cannot resolve: the interval is certified and honest
  /// (its lower end may be 0), no further expansion could narrow it.
  degenerate,
};

const char* to_string(DepthTermination termination);

/// The warm-start cache of Section VIII: which vertex pairs (index on A, index on B) made up the
/// final simplex. Indices, not points, so the cache stays meaningful when the poses change and can
/// be stored per object pair. A zero-initialised cache (`count == 0`) is a cold start. Entries with
/// an index of -1 (smooth shapes have no vertices) are skipped on reuse.
struct SimplexCache {
  std::uint8_t count = 0;
  std::int32_t index_a[4] = {0, 0, 0, 0};
  std::int32_t index_b[4] = {0, 0, 0, 0};
};

template <class Scalar>
struct DistanceResult {
  Status status = Status::invalid_input;
  /// Euclidean distance between the two (rounded) shapes, ≥ 0; 0 when intersecting or touching
  /// (touching: the true distance is at most `error_bound`). With
  /// `beyond_cutoff()`, a certified lower bound above the cutoff: the true distance lies in
  /// [distance, distance + error_bound].
  Scalar distance = 0;
  /// Certified bound on |distance − true distance|, the truth being the distance of the shapes
  /// posed exactly as given (R·x + t in exact arithmetic): Theorem 1 and the support-plane bound,
  /// min(√g, g/|ν|), plus an allowance for rounding of a few ulps of the largest coordinate the
  /// query forms (D(K) of eq. 37 with the origin shift; the centroids' size too without it) and
  /// for pose A's rotation defect.
  Scalar error_bound = 0;
  /// The certified gap at exit (≥ 0; units: length²): min(g(ν), |ν|² − L²), where g(ν) =
  /// |ν|² + h_K(−ν) is the duality gap of eq. (25) and L the best support-plane lower bound found.
  /// Theorem 1's |ν − ν(K)|² ≤ gap holds for both terms.
  Scalar gap = 0;
  /// The bound D(K) of eq. (37) used in the stopping rule (length).
  Scalar diameter_bound = 0;
  /// GJK iterations: support points added after the initial simplex.
  int iterations = 0;
  /// What the query cost, counted in the paper's two operations: support calls of K (each one
  /// support query on both shapes, eq. 21) and runs of step 2 on a simplex (the distance
  /// subalgorithm, and the Backup Procedure each time it ran). A warm start whose simplex is still
  /// optimal typically costs one of each.
  int support_calls = 0;
  int subalgorithm_runs = 0;
  /// How the loop ended.
  Termination termination = Termination::tolerance;
  /// The simplex came from the warm-start cache.
  bool warm_started = false;
  FinishedBy finished_by = FinishedBy::distance_subalgorithm;

  /// Simplex of the final representation (eq. 22): `simplex_size` vertex pairs and weights λ
  /// (positive, summing to 1). Index -1 marks a support point of a smooth shape.
  int simplex_size = 0;
  std::int32_t index_a[4] = {-1, -1, -1, -1};
  std::int32_t index_b[4] = {-1, -1, -1, -1};
  Scalar weights[4] = {0, 0, 0, 0};

  /// With `options.near_points`: near points, world frame (eq. 23–24), on the rounded surfaces.
  /// When separated, |point_b − point_a| = distance. When the cores intersect both are one common
  /// point; when only the rounded shapes overlap they are each shape's deepest point along the
  /// normal; when the pair is reported intersecting only because it is within its error bound of
  /// touching, they are the near points found, at most `error_bound` apart. `normal` is the unit
  /// vector from A towards B (zero when it is undefined: cores intersecting).
  bool has_near_points = false;
  Vec3<Scalar> point_a = Vec3<Scalar>::Zero();
  Vec3<Scalar> point_b = Vec3<Scalar>::Zero();
  Vec3<Scalar> normal = Vec3<Scalar>::Zero();

  /// With `options.penetration_bound`, when in contact: d⁻, a lower bound on the penetration
  /// depth (the translation needed to separate the shapes), eq. (32)–(33). 0 is always a valid
  /// bound; it is positive when the final simplex is a tetrahedron around the origin, and includes
  /// the radii of rounded shapes.
  bool has_penetration_bound = false;
  Scalar penetration_bound = 0;

  /// With `options.penetration_depth` (and a verdict, separated or intersecting): the signed
  /// distance φ, the distance when separated and −depth when intersecting, with a certified
  /// interval [signed_distance_lower, signed_distance_upper] containing the true φ of the shapes
  /// posed exactly as given. Separated: [distance − error_bound, distance + error_bound], above 0.
  /// Intersecting: [−depth_upper, −depth_lower] when a positive depth is proven, otherwise
  /// [−depth_upper, error_bound] (too close to tell from touching: φ may be slightly positive).
  /// The three-way verdict follows from the interval's sign: `status` is separated when it lies
  /// above 0, intersecting when below 0, touching (contact within the bound) when it contains 0.
  bool has_signed_distance = false;
  Scalar signed_distance = 0;
  Scalar signed_distance_lower = 0;
  Scalar signed_distance_upper = 0;

  /// With `options.penetration_depth`: the penetration depth, the shortest translation of one
  /// shape that makes the two touch without overlapping (0 when separated). [depth_lower,
  /// depth_upper] is certified to contain the true depth of the shapes posed exactly as given,
  /// and `depth` (the estimate) lies in it. For intersecting cores the lower end is the nearest
  /// face of the expanded polytope inside K = A − B (its normal's and offset's rounding taken
  /// off), the upper end the least support value h_K(n) over the face normals tried (any unit n
  /// bounds the depth from above), rounding added; rounded shapes add r_A + r_B to both.
  /// `depth_direction` is the unit direction, world frame, A → B: translating B by depth along
  /// it (or A by −depth) separates the shapes, and it continues the separated `normal`.
  /// `depth_point_a` and `depth_point_b` are witness points (world frame) on A and B with
  /// depth_point_a − depth_point_b = depth·depth_direction (so point_b − point_a = φ·direction
  /// as when separated): each shape's deepest point in the other along the direction. For
  /// polytopes they lie on the surfaces; for curved shapes they lie inside each shape, within
  /// the interval's width of its surface. `depth_termination` says whether the interval met the
  /// tolerance (see DepthTermination); `depth_iterations` counts expansion steps.
  bool has_penetration_depth = false;
  Scalar depth = 0;
  Scalar depth_lower = 0;
  Scalar depth_upper = 0;
  Vec3<Scalar> depth_point_a = Vec3<Scalar>::Zero();
  Vec3<Scalar> depth_point_b = Vec3<Scalar>::Zero();
  Vec3<Scalar> depth_direction = Vec3<Scalar>::Zero();
  DepthTermination depth_termination = DepthTermination::closed_form;
  int depth_iterations = 0;

  /// With `options.gradient`, when separated: the gradient of `distance` with respect to each
  /// body's pose as (∂/∂translation, ∂/∂rotation), world frame; rotation is a small rotation
  /// vector applied on the left about the body's origin (`pose.translation`). When near points
  /// are not unique (parallel faces) this is one element of the generalised gradient. With
  /// `options.penetration_depth` also when in contact: the gradient of the signed distance
  /// φ = −depth, from the depth's witness points and direction by the same formula
  /// (distance_gradient with the A → B direction; in terms of the depth the sign is reversed),
  /// so that it is continuous through contact.
  bool has_gradient = false;
  Eigen::Matrix<Scalar, 6, 1> gradient_a = Eigen::Matrix<Scalar, 6, 1>::Zero();
  Eigen::Matrix<Scalar, 6, 1> gradient_b = Eigen::Matrix<Scalar, 6, 1>::Zero();

  /// With `Status::invalid_input`: why (a static string). Otherwise nullptr.
  const char* message = nullptr;

  /// The loop ended on one of its convergence tests (not at the numerical limit, the cutoff or
  /// the cap).
  bool converged() const {
    return termination == Termination::origin_enclosed || termination == Termination::tolerance ||
           termination == Termination::repeated_support ||
           termination == Termination::roundoff_floor || termination == Termination::contact;
  }
  /// The shapes touch or overlap: the verdict is intersecting or touching (not separated, not
  /// an iteration limit or an invalid input).
  bool in_contact() const { return status == Status::intersecting || status == Status::touching; }
  /// The penetration-depth interval met its tolerance (or needed no expansion).
  bool depth_converged() const {
    return depth_termination == DepthTermination::closed_form ||
           depth_termination == DepthTermination::tolerance;
  }
  /// The query stopped early because the distance was proven larger than `distance_cutoff`.
  bool beyond_cutoff() const { return termination == Termination::beyond_cutoff; }
};

}  // namespace nearpoint
