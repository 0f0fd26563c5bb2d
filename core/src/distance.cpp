// SPDX-License-Identifier: Apache-2.0
// The distance query: validation, the relative frame, dispatch to the specialised loop, and the
// result (near points, spherical extensions, error bound, penetration bound, gradient).
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
//
// Where it departs from the paper: B is placed in A's frame (as Box2D does) besides the origin
// shift of eq. (34), with shapes far from their local origins placed by compensated arithmetic;
// K is rescaled by a power of two when D(K) would under- or overflow the loop's products; the
// reported bound covers the rounding of placing the shapes (the working magnitude) and pose A's
// rotation defect; beyond a cutoff the answer is the certified lower bound, not |ν|.
#include "nearpoint/distance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include "distance_internal.hpp"
#include "gjk.hpp"
#include "penetration.hpp"

namespace nearpoint {

template <class S>
const char* detail::invalid_pose_reason(const Pose<S>& pose) {
  if (rigid_pose(pose)) return nullptr;
  if (!pose.translation.allFinite()) return "pose translation has a non-finite component";
  if (!pose.rotation.allFinite()) return "pose rotation has a non-finite entry";
  if (!orthonormal_columns(pose.rotation)) return "pose rotation is not orthonormal";
  return "pose rotation is a reflection (determinant < 0)";
}

namespace {

using detail::set_invalid;

using detail::LoopRange;
using detail::power_of_two;

/// The largest radius sum and size accepted: the answer (a distance, a penetration bound, near
/// points a radius away from the cores) must stay representable.
template <class S>
constexpr S kLargestLength = std::numeric_limits<S>::max() / S(256);

constexpr const char* kTooLarge =
    "shapes, radii and their separation are too large for this precision (keep them below ~1e306 "
    "in double, ~1e36 in float)";

constexpr const char* kNotRepresentable = "the answer is too large to represent in this precision";

/// One shape of a query as the loop sees it: its core geometry, its radius and its pose.
template <class S, class G>
struct Placed {
  const G& geometry;
  S radius;
  const Pose<S>& pose;
};

/// A query's inputs (as Box2D's b2DistanceInput groups them), for two concrete core geometries.
template <class S, class GA, class GB>
struct QueryInput {
  Placed<S, GA> a;
  Placed<S, GB> b;
  const DistanceOptions<S>& options;
  /// ‖R_AᵀR_A − I‖_F² (the pose check computes it anyway): the bound's allowance for it.
  S defect2_a;
  /// A length whose rounding placed the shapes before the query saw them (a compound's piece
  /// poses, composed from its body poses): it enters the working magnitude M (0 for a query on
  /// the caller's own poses).
  S placement;
};

/// The certified error and the verdict from the loop's outcome, written into `result`: Theorem 1
/// and the support-plane interval, the roundoff allowance (ulps of the working magnitude) and
/// pose A's rotation defect, the radii by eq. (8), and a cutoff's lower bound.
template <class S>
[[gnu::always_inline]] inline void certify(const detail::LoopOutcome<S>& loop, S diameter,
                                           S roundoff, S defect_allowance, S radii,
                                           DistanceResult<S>& result) {
  using std::sqrt;
  const detail::Nearest<S>& nearest = loop.nearest;
  const S core_distance = loop.nu_length;
  result.gap = loop.gap;
  result.diameter_bound = diameter;
  result.iterations = loop.iterations;
  result.support_calls = loop.support_calls;
  result.subalgorithm_runs = loop.subalgorithm_runs;
  result.termination = loop.termination;
  result.warm_started = loop.warm_started;
  result.finished_by = loop.finished_by;

  // The certified error. The distance lies in [L, |ν|], L the best support-plane lower bound
  // found; and Theorem 1 gives |ν − ν(K)| ≤ √g. Both hold for the computed values up to roundoff
  // in y, ν and the inner products, which the allowance covers (a few ulps of D(K), the largest
  // magnitude in the loop).
  if (core_distance > 0) {
    const S interval = std::max(S(0), core_distance - loop.lower_bound);
    result.error_bound = std::min(sqrt(loop.gap), interval) + roundoff;
  } else {
    result.error_bound = sqrt(loop.gap) + roundoff;  // the enclosure's residual (see the loop)
  }
  // A rotation that is not quite one (accepted up to max |(RᵀR − I)ᵢⱼ| ≤ 1e-6 in double, 1.2e-4
  // in float: see Pose). B is placed in A's frame with R_Aᵀ, which is R_A⁻¹ only when E = R_AᵀR_A
  // − I is 0; the loop measures R_Aᵀ(a − b) − E(a − z̄_A) for world points a, b instead of a − b:
  // lengths scaled by a singular value of R_A (within ‖E‖₂ of 1) and A's points moved by at most
  // ‖E‖₂·extent(A), so the distance moves by at most ‖E‖₂·(d + extent(A)) ≤ 2‖E‖_F·D(K). δ formed
  // directly carries E·z̄_A besides, |z̄_A| ≤ D/8 (see above): 3‖E‖_F·D(K) covers both. R_B's
  // defect is part of the input itself: B's points are R_B b + p_B either way. Up to 8ε the
  // defect is what rounding an exact rotation's entries leaves and what RᵀR computed in floating
  // point cannot tell from 0: the roundoff allowance has always absorbed it (the paper set's and
  // the stiff suite's bounds stay tight); the excess is added. One predictable branch.
  // Without the origin shift A's points enter the loop at their local size: M, not D(K), is
  // what the defect moves (M = D(K) with the shift).
  result.error_bound += defect_allowance;

  // The verdict needs a proof either way. The distance is within error_bound of |ν| − r_A − r_B,
  // so "separated" is certain when that exceeds the bound. "intersecting" needs a proof that
  // the signed distance φ is below 0: rounded shapes whose cores are closer than r_A + r_B by
  // more than the bound (φ ≤ |ν| + e − r_A − r_B), or a tetrahedron of K's points around the
  // origin whose faces are all farther from it than the bound (d⁻ of eq. 32–33, certified, as
  // `penetration_bound` reports it). Otherwise the shapes touch, or are too close to tell from
  // touching at this precision or tolerance: "touching". (A numerical-limit exit deep inside an
  // overlap, where |ν| can be 1e-17 rather than 0, and a loose ε are kept from claiming a
  // separation they cannot back; penetration_depth settles the rest from its interval.)
  const bool cores_intersect = !(nearest.nu_norm2 > 0);
  const S core_bound = result.error_bound;
  const bool separated = !cores_intersect && core_distance - radii > core_bound;
  result.distance = separated ? core_distance - radii : S(0);  // eq. (8): (d − r_A − r_B)⁺
  if (!separated) result.error_bound += std::max(S(0), core_distance - radii);
  if (loop.termination == Termination::iteration_limit) {
    result.status = Status::iteration_limit;
  } else if (separated) {
    result.status = Status::separated;
  } else {
    bool overlap = radii - core_distance > core_bound;
    if (!overlap && cores_intersect)
      overlap = detail::penetration_lower_bound(loop.simplex, nearest.subset) + radii > core_bound;
    result.status = overlap ? Status::intersecting : Status::touching;
  }
  // Beyond the cutoff the loop stopped on a support plane's proof, d ≥ L, before |ν| converged:
  // the answer is that certified lower bound, with the interval up to |ν| as its bound, so the
  // truth lies in [distance, distance + error_bound] (what a caller filtering on the cutoff
  // needs; |ν| alone may be far above the truth). L carries the loop's roundoff and the defect's.
  if (loop.termination == Termination::beyond_cutoff) {
    const S lower = loop.lower_bound - roundoff - defect_allowance - radii;
    // |ν| bounds d from above; a computed L may pass it by a rounding, and the interval then
    // keeps its roundoff on both sides of L (the closed forms, whose L is |ν|, answer the same).
    const S upper = std::max(core_distance, loop.lower_bound) - radii + roundoff + defect_allowance;
    if (lower > 0) {
      result.status = Status::separated;
      result.distance = lower;
      result.error_bound = std::max(S(0), upper - lower);
    }
  }
}

/// The final simplex into the result (eq. 22) and the warm-start cache (Section VIII).
template <class S>
[[gnu::always_inline]] inline void write_simplex(const detail::LoopOutcome<S>& loop,
                                                 DistanceResult<S>& result, SimplexCache* cache) {
  const detail::Nearest<S>& nearest = loop.nearest;
  const detail::Simplex<S>& simplex = loop.simplex;
  result.simplex_size = 0;
  for (int i = 0; i < 4; ++i) {
    if (!(nearest.subset & (1u << i))) continue;
    const int n = result.simplex_size++;
    result.index_a[n] = simplex.index_a[i];
    result.index_b[n] = simplex.index_b[i];
    result.weights[n] = nearest.lambda[i];
  }
  // Written field by field: a whole SimplexCache assembled on the stack and copied read its
  // single-field stores back with wider loads (a store-forwarding stall per warm query).
  if (cache) {
    cache->count = static_cast<std::uint8_t>(result.simplex_size);
    for (int n = 0; n < 4; ++n) {
      const bool kept = n < result.simplex_size;
      cache->index_a[n] = kept ? result.index_a[n] : 0;
      cache->index_b[n] = kept ? result.index_b[n] : 0;
    }
  }
}

/// Near points on each shape and the normal, world frame (eq. 23–24), into the result.
template <class S, class K>
[[gnu::always_inline]] inline void write_near_points(const K& k_set, bool far_centers,
                                                     const Pose<S>& pose_a, S radius_a, S radius_b,
                                                     const detail::LoopOutcome<S>& loop,
                                                     DistanceResult<S>& result) {
  const detail::Nearest<S>& nearest = loop.nearest;
  const detail::Simplex<S>& simplex = loop.simplex;
  const bool cores_intersect = !(nearest.nu_norm2 > 0);
  // eq. (23)–(24): near points from the simplex weights, in A's frame relative to z̄_A.
  Vec3<S> on_a = Vec3<S>::Zero(), on_b = Vec3<S>::Zero();
  for (int i = 0; i < 4; ++i) {
    if (!(nearest.subset & (1u << i))) continue;
    on_a += nearest.lambda[i] * simplex.a[i];
    on_b += nearest.lambda[i] * simplex.b[i];
  }
  // Relative to z̄_A in A's frame, which is placed in the world with p_A; or, when the
  // centroids are far from their local origins, relative to A's world-frame centroid formed
  // with compensated arithmetic (the points are then as accurate as their world coordinates
  // can be, not ulps of the local coordinates worse).
  Vec3<S> base = k_set.a_center, origin = pose_a.translation;
  if (far_centers) {
    base = Vec3<S>::Zero();
    origin = detail::compensated_difference(pose_a, k_set.a_center,
                                            static_cast<const Pose<S>*>(nullptr), base);
  }
  Vec3<S> point_a = base + on_a;
  Vec3<S> point_b = base + k_set.offset + on_b;
  Vec3<S> normal = Vec3<S>::Zero();  // A → B, A's frame: −ν/|ν|
  if (!cores_intersect) {
    // Scaled before it is squared: ν/|ν| with |ν|² formed as is would be no unit vector when
    // |ν|² lies among the subnormals (a float pair reported intersecting 1e-21 apart).
    normal = -nearest.nu.stableNormalized();
    point_a += radius_a * normal;
    point_b -= radius_b * normal;
  } else {
    point_b = point_a;  // one common point of the cores
  }
  result.has_near_points = true;
  result.point_a = detail::rotate(pose_a.rotation, point_a) + origin;
  result.point_b = detail::rotate(pose_a.rotation, point_b) + origin;
  // A unit vector in the world too: R_A may be a rotation only to within its accepted defect.
  result.normal = detail::rotate(pose_a.rotation, normal);
  if (!cores_intersect) result.normal = result.normal.stableNormalized();
}

// Writes into `result`, which the caller has just default-constructed (see
// detail::distance_with_valid_poses). Placing B in A's frame stays written out here, before the
// loop: returned from a function as one struct, the frame (a rotation, five vectors) was read
// back through memory on the way to the first support point (measured: 4.7% of a query on the
// paper set, paired runs). Returns false without touching `result` or `cache` when
// `may_rescale` and D(K) or the radii lie outside the loop's range: the caller then rescales K
// (rescaled_query). `scale_out` receives D(K) and the working magnitude M computed here.
template <class S>
struct QueryScale {
  S diameter = 0;
  S magnitude = 0;
};
template <class S, class GA, class GB>
bool query(const QueryInput<S, GA, GB>& in, SimplexCache* cache, DistanceResult<S>& result,
           bool may_rescale, QueryScale<S>& scale_out) {
  const GA& ga = in.a.geometry;
  const GB& gb = in.b.geometry;
  const S radius_a = in.a.radius, radius_b = in.b.radius;
  const Pose<S>&pose_a = in.a.pose, &pose_b = in.b.pose;
  const DistanceOptions<S>& options = in.options;
  const S defect2_a = in.defect2_a;
  using SA = detail::Support<GA, S>;
  using SB = detail::Support<GB, S>;
  const SA support_a{ga};
  const SB support_b{gb};

  // B relative to A: t = R_Aᵀ(p_B − p_A). A common offset of both poses cancels in p_B − p_A.
  // Written out (detail::rotate_back per column): Eigen's 3×3 products were left out of line here,
  // on the path to the first support point.
  // Two points (spheres' cores) need no relative rotation: B's support is its centre whatever
  // the direction, so K is known from the translation alone (detail::point_pair_outcome).
  constexpr bool point_pair = std::is_same_v<GA, Point> && std::is_same_v<GB, Point>;
  Mat3<S> rotation = Mat3<S>::Identity();
  if constexpr (!point_pair)
    for (int j = 0; j < 3; ++j)
      rotation.col(j) = detail::rotate_back(pose_a.rotation, Vec3<S>(pose_b.rotation.col(j)));
  const Vec3<S> translation =
      detail::rotate_back(pose_a.rotation, Vec3<S>(pose_b.translation - pose_a.translation));
  const Vec3<S> a_center = support_a.center();
  const Vec3<S> b_center = support_b.center();
  const Vec3<S> b_center_rel = detail::rotate(rotation, b_center) + translation;
  const S extents = support_a.extent() + support_b.extent();
  // δ = z̄_B − z̄_A in A's frame, eq. (34). Formed directly its rounding is a few ulps of the
  // terms |z̄_A|, |z̄_B|, |p_B − p_A|, which is within the roundoff allowance (a few ulps of D(K))
  // while the centroids are small against D(K): always for boxes, spheres, cylinders, whose
  // centre is their local origin. A shape modelled far from its local origin and placed back by
  // its pose (CAD meshes exported in world coordinates) has centroids far larger than D(K), and
  // δ is then formed from the world-frame centroids with compensated arithmetic instead.
  Vec3<S> offset = b_center_rel - a_center;
  S diameter = extents + offset.norm();  // D(K) ≤ D(A − z̄_A) + D(B − z̄_B) + |δ|, eq. (37)
  const bool far_centers =
      !(a_center.cwiseAbs().sum() + b_center.cwiseAbs().sum() <= S(0.125) * diameter);
  S compensation = 0;
  if (far_centers) {
    offset = detail::centroid_offset(pose_a, a_center, pose_b, b_center, compensation);
    diameter = extents + offset.norm();
  }
  // |δ|² underflows below ~1e-154 (double): two points 7e-301 apart had D(K) = 0 and were
  // answered "at one place". Scaled, the norm is not lost (the query is then rescaled).
  if (!(diameter > 0) && offset != Vec3<S>::Zero()) [[unlikely]]
    diameter = extents + offset.stableNorm();
  // The working magnitude M that every roundoff term is a few ulps of (gjk.hpp,
  // distance_roundoff): the one place where the rounding of placing the shapes enters the bound.
  // With the origin shift every point of K is formed relative to the centroids, and the placement
  // rounds by ulps of the vertices' offsets from their centres (≤ the extents), of the relative
  // rotation applied to them, and of δ, each within D(K). Without it the loop adds the centroids
  // back (MinkowskiDifference::difference): it rounds by ulps of z̄_A, of z̄_B and of the
  // translation that places z̄_B in A's frame, so those enter M in full (1-norms: a bound on each
  // component's rounding whatever the rotation).
  // Far centroids add what their compensated offset may still be off by (the rounding of its
  // accumulated error terms: detail::compensated_difference).
  S magnitude = diameter + in.placement + compensation;
  if (!options.origin_shift)
    magnitude += S(2) * (a_center.cwiseAbs().sum() + b_center.cwiseAbs().sum() +
                         translation.cwiseAbs().sum());
  scale_out = {diameter, magnitude};
  // Among subnormals posing rounds by an absolute half unit per operation, not by ulps of its
  // terms: a float polytope at 2.8e-45 turned by a near-permutation lands 8.3e-52 from a point,
  // which every float computation of the offset puts at 0 ("touching", bound 0; found by
  // fuzz_engine). denorm_min/ε in M makes the roundoff terms, a few ulps of M, cover it; beside
  // any normal magnitude it vanishes. (Not in scale_out: the rescale is chosen from the shapes.)
  magnitude += std::numeric_limits<S>::denorm_min() / std::numeric_limits<S>::epsilon();
  const S radii = radius_a + radius_b;
  // One branch decides whether K is in the loop's range (and the radii representable): outside
  // it, tiny shapes would square to subnormals (1e-170 boxes came back "intersecting", bound 0)
  // and large ones overflow (NaN weights in float from ~1e7 with Johnson's Δ's), so K is first
  // rescaled by a power of two (rescaled_query), or refused.
  constexpr S smallest = power_of_two<S>(LoopRange<S>::low);
  constexpr S largest = power_of_two<S>(LoopRange<S>::high);
  if (!(diameter >= smallest && magnitude <= largest && radii <= kLargestLength<S>)) [[unlikely]] {
    if (may_rescale) return false;
    if (!(magnitude <= kLargestLength<S>) || !(radii <= kLargestLength<S>)) {
      set_invalid(result, kTooLarge);
      return true;
    }
    if (diameter != 0) {
      set_invalid(result,
                  "shapes differ too much in size from their separation or from each other to be "
                  "measured in this precision");
      return true;
    }
    // D(K) = 0: two points at one place. The loop handles it (every length is 0).
  }
  // Every member given its value here: an aggregate with members left to `{}` was zeroed first
  // (a `rep stos` of 168 bytes per query).
  const detail::MinkowskiDifference<S, SA, SB> k_set{
      support_a, support_b, rotation, offset, a_center, b_center_rel, options.origin_shift};

  using std::sqrt;
  const S epsilon = options.epsilon > 0 ? options.epsilon : S(0);
  // The allowance for pose A's rotation defect (see the bound below), known before the loop so
  // that a cutoff is proven past it too.
  constexpr S tight = S(8) * std::numeric_limits<S>::epsilon();
  const S defect_allowance =
      defect2_a > tight * tight ? S(3) * (sqrt(defect2_a) - tight) * magnitude : S(0);
  // The loop works on the cores, and proves a cutoff past its own roundoff (run_numerical_
  // algorithm); the defect is added here.
  const S cutoff = options.distance_cutoff + radii + defect_allowance;

  // Below this core distance the verdict is settled (see certify's verdict: separation needs
  // |ν| − radii above the error bound, which is at least `roundoff`; the bound is at most
  // |ν| + roundoff + the defect's allowance, so below half of what remains of the radii the
  // overlap is proven), so a query that wants no near points, d⁻ or gradient can stop there
  // instead of converging further. Between the two the loop converges and certify decides.
  const S roundoff = detail::distance_roundoff(magnitude);
  const bool needs_simplex = options.near_points || options.penetration_bound || options.gradient ||
                             options.penetration_depth;
  const S settled_below =
      needs_simplex ? S(-1)
                    : std::max(roundoff, S(0.5) * (radii - S(2) * roundoff - defect_allowance));

  // d⁻ (eq. 32) comes from the faces of the tetrahedron that encloses the origin; an interior
  // corner (the centroids' point) would pull them inwards and weaken it.
  const ColdStart cold_start =
      options.penetration_bound ? ColdStart::single_point : options.cold_start;
  detail::LoopOutcome<S> loop;
  constexpr bool segment_pair = std::is_same_v<GA, Segment<S>> && std::is_same_v<GB, Segment<S>>;
  bool answered = false;
  if constexpr (point_pair) {
    detail::point_pair_outcome(k_set, magnitude, cutoff, settled_below, cache, loop);
    answered = true;
  } else if constexpr (segment_pair) {
    answered = detail::segment_pair_outcome(k_set, magnitude, epsilon * diameter * diameter, cutoff,
                                            settled_below, loop);
    if (!answered) [[unlikely]] {  // the loop starts from an empty simplex
      loop.simplex.used = 0;
      loop.simplex.newest = -1;
      loop.simplex.tables_valid = true;
      loop.warm_started = false;
    }
  }
  if (!answered)
    detail::run_numerical_algorithm(
        k_set,
        detail::LoopInput<S>{magnitude, epsilon * diameter * diameter,
                             std::max(0, options.max_iterations), cutoff, settled_below,
                             options.subalgorithm, cold_start},
        cache, loop);

  certify(loop, diameter, roundoff, defect_allowance, radii, result);
  write_simplex(loop, result, cache);
  const detail::Nearest<S>& nearest = loop.nearest;
  const S core_distance = loop.nu_length;
  const bool cores_intersect = !(nearest.nu_norm2 > 0);
  if (options.near_points || options.gradient || options.penetration_depth)
    write_near_points(k_set, far_centers, pose_a, radius_a, radius_b, loop, result);

  // Cores at the origin whose overlap the loop could not prove: a few expansion steps decide
  // between touching and intersecting (the depth, when asked for, decides below). Enclosed
  // (ν = 0) on a point, segment or triangle, or a thin tetrahedron; or ν ≈ 0 without enclosure,
  // the usual end inside a curved shape, where g(ν) ≤ ε·D² holds once |ν| is at roundoff level.
  if (result.status == Status::touching && !(core_distance > result.error_bound) &&
      !options.penetration_depth &&
      detail::overlap_proven_by_expansion(k_set, loop, magnitude, roundoff + defect_allowance,
                                          result.support_calls)) [[unlikely]]
    result.status = Status::intersecting;

  if (options.penetration_bound && result.in_contact()) {
    // eq. (32)–(33) on the cores, plus the radii; for rounded shapes whose cores are apart the
    // overlap r_A + r_B − d is the exact penetration depth. The tetrahedron's corners are the
    // computed support points, each within the error bound's roundoff of a true point of K, and
    // the origin is inside it up to the enclosure's residual (both in error_bound, which is the
    // cores' here): a ball that fits in the computed tetrahedron fits in the true one once shrunk
    // by that much.
    result.has_penetration_bound = true;
    result.penetration_bound =
        cores_intersect
            ? std::max(S(0), detail::penetration_lower_bound(loop.simplex, nearest.subset) -
                                 result.error_bound) +
                  radii
            : std::max(S(0), radii - core_distance);
  }

  if (options.gradient && result.status == Status::separated && !result.beyond_cutoff()) {
    distance_gradient(result.point_a, result.point_b, result.normal, pose_a.translation,
                      pose_b.translation, result.gradient_a, result.gradient_b);
    result.has_gradient = true;
  }
  if (options.penetration_depth && !result.beyond_cutoff()) [[unlikely]] {
    detail::write_penetration_depth(
        k_set, loop,
        detail::DepthPlacement<S>{pose_a, pose_b, far_centers, radius_a, radius_b, magnitude,
                                  roundoff, defect_allowance, diameter},
        options, result);
    // The gradient of the signed distance through contact: distance_gradient's formula with the
    // depth's witnesses and A → B direction (−∂depth), continuous with the separated one.
    if (options.gradient && result.in_contact() && result.has_penetration_depth) {
      distance_gradient(result.depth_point_a, result.depth_point_b, result.depth_direction,
                        pose_a.translation, pose_b.translation, result.gradient_a,
                        result.gradient_b);
      result.has_gradient = true;
    }
    if (!options.near_points && !options.gradient) result.has_near_points = false;
  }
  return true;
}

/// A shape's geometry at scale 2^k (exact): the parameters of the simple shapes multiplied, a
/// polytope wrapped (its vertices are not copied: the query allocates nothing).
template <class S>
Vec3<S> scale_vector(const Vec3<S>& v, int k) {
  return Vec3<S>(std::ldexp(v.x(), k), std::ldexp(v.y(), k), std::ldexp(v.z(), k));
}
template <class S>
Point scale_geometry(const Point& g, int) {
  return g;
}
template <class S>
Segment<S> scale_geometry(const Segment<S>& g, int k) {
  return {scale_vector(g.a, k), scale_vector(g.b, k)};
}
template <class S>
Box<S> scale_geometry(const Box<S>& g, int k) {
  return {scale_vector(g.half_extents, k)};
}
template <class S>
Cylinder<S> scale_geometry(const Cylinder<S>& g, int k) {
  return {std::ldexp(g.radius, k), std::ldexp(g.half_height, k)};
}
template <class S>
Cone<S> scale_geometry(const Cone<S>& g, int k) {
  return {std::ldexp(g.radius, k), std::ldexp(g.half_height, k)};
}
template <class S>
Ellipsoid<S> scale_geometry(const Ellipsoid<S>& g, int k) {
  return {scale_vector(g.radii, k)};
}
template <class S>
detail::ScaledPolytope<S> scale_geometry(const Polytope<S>& g, int k) {
  // A direction can carry 2^k only while that is a normal number (see the adaptor).
  constexpr int limit = std::numeric_limits<S>::max_exponent - 8;
  return {&g, k, std::clamp(k, -limit, limit)};
}

/// The size of a shape's core about its centre, by the largest parameter (no squares, so that
/// it neither under- nor overflows): what the rescale is chosen from.
template <class S>
S magnitude(const Point&) {
  return 0;
}
template <class S>
S magnitude(const Segment<S>& g) {
  // The ends as the query stores them, about their rounded centre: a segment of one point one
  // subnormal off the origin has a centre that rounds to 0 and |b − a| = 0, yet an end 2^-149
  // from it (its extent's square underflowed too, and the pair was answered "at one place").
  const detail::Support<Segment<S>, S> adaptor{g};
  return std::max(adaptor.end(0).cwiseAbs().maxCoeff(), adaptor.end(1).cwiseAbs().maxCoeff());
}
template <class S>
S magnitude(const Box<S>& g) {
  return g.half_extents.cwiseAbs().maxCoeff();
}
template <class S>
S magnitude(const Polytope<S>& g) {
  return g.extent();
}
template <class S>
S magnitude(const Cylinder<S>& g) {
  return std::max(g.radius, g.half_height);
}
template <class S>
S magnitude(const Cone<S>& g) {
  return std::max(g.radius, g.half_height);
}
template <class S>
S magnitude(const Ellipsoid<S>& g) {
  return g.radii.maxCoeff();
}

/// The query for K outside the loop's range (see LoopRange). K is scaled by 2^k: both shapes and
/// radii, the translations (see below) and the placement magnitude. The loop
/// then sees D(K) near 1; its answer is scaled back, which is exact but for numbers that land in
/// the subnormal range, whose rounding (≤ 2^-1075 in double) is added to the bound. When the
/// first scale, chosen from the shapes' size and their centroids' distance, leaves D(K) out of
/// range (the centroids cancel to much less), it is corrected from the D(K) found, twice at most.
template <class S, class GA, class GB>
[[gnu::noinline, gnu::cold]] void rescaled_query(const QueryInput<S, GA, GB>& in,
                                                 SimplexCache* cache, DistanceResult<S>& result) {
  const GA& ga = in.a.geometry;
  const GB& gb = in.b.geometry;
  const S radius_a = in.a.radius, radius_b = in.b.radius;
  const Pose<S>&pose_a = in.a.pose, &pose_b = in.b.pose;
  const DistanceOptions<S>& options = in.options;
  if (!(radius_a + radius_b <= kLargestLength<S>)) return set_invalid(result, kTooLarge);
  const Vec3<S> center_a = detail::Support<GA, S>{ga}.center();
  const Vec3<S> center_b = detail::Support<GB, S>{gb}.center();
  // The centres' offset compensated, as the query forms δ for far centroids: two one-point
  // segments 4e-53 from their local origins, both placed at 8e301 and turned apart by 3e-54,
  // had a plainly rounded offset of 0, were scaled by their translations, and came back
  // "intersecting" with bound 0 (found by fuzz_engine). This is the cold path: exactness first.
  const Vec3<S> between = detail::compensated_difference(pose_b, center_b, &pose_a, center_a);
  if (!between.allFinite()) return set_invalid(result, kTooLarge);
  S size = std::max({magnitude<S>(ga), magnitude<S>(gb), between.cwiseAbs().maxCoeff()});
  // Two point cores whose `between` rounded to 0: their places may still differ by less than the
  // subnormals resolve (float points 4e-45 from the origin, B turned by its pose, 6e-46 apart,
  // were answered "at one place" with bound 0). Scaled by their coordinates instead, the
  // placement is formed among normal numbers and the loop sees their true offset.
  // The centres first: they are what the poses turn (segments of one point 2e-323 from their
  // origins, placed at 8e301 and turned apart, were scaled by the translations and vanished:
  // "intersecting", bound 0; the translations, scaled past the largest number, are then kept
  // exact as hi + lo). Without centres, the translations.
  // (At most the largest length: points that coincide far out are no reason to refuse.)
  if (!(size > 0)) size = std::max(center_a.cwiseAbs().maxCoeff(), center_b.cwiseAbs().maxCoeff());
  if (!(size > 0))
    size = std::min(kLargestLength<S>, std::max(pose_a.translation.cwiseAbs().maxCoeff(),
                                                pose_b.translation.cwiseAbs().maxCoeff()));
  if (!(size <= kLargestLength<S>)) return set_invalid(result, kTooLarge);
  int k = size > 0 ? -std::ilogb(size) : 0;
  Vec3<S> translation_hi, translation_lo;
  for (int i = 0; i < 3; ++i) {
    const S x = pose_b.translation[i], y = -pose_a.translation[i];
    const S sum = x + y, z = sum - x;
    translation_hi[i] = sum;
    translation_lo[i] = (x - (sum - z)) + (y - z);
  }
  bool moved_world = false;
  Pose<S> scaled_a, scaled_b;
  scaled_a.rotation = pose_a.rotation;
  scaled_b.rotation = pose_b.rotation;
  DistanceOptions<S> scaled_options = options;
  for (int attempt = 0;; ++attempt) {
    const S scaled_radius_a = std::ldexp(radius_a, k), scaled_radius_b = std::ldexp(radius_b, k);
    if (!(scaled_radius_a + scaled_radius_b <= kLargestLength<S>))
      return set_invalid(result,
                         "radii too large against the shapes' cores and separation to be "
                         "measured in this precision");
    // The translations scaled as they are when both stay finite (always when shrinking): exact,
    // so the query places the shapes, their centroids and its near points exactly as it would at
    // the caller's scale, compensated where they cancel. Otherwise (tiny shapes far out) the
    // world is moved to A's position with p_B − p_A kept exact as hi + lo (TwoSum): rounded, it
    // would be off by an ulp of the translations, far more than the distance for shapes modelled
    // far from their local origins and placed back by their poses (found by an outside fuzzer:
    // vertices at 1e76 answered 2% off). B is placed at hi and A at −lo, each scaled exactly.
    scaled_a.translation = scale_vector(pose_a.translation, k);
    scaled_b.translation = scale_vector(pose_b.translation, k);
    moved_world = !(scaled_a.translation.allFinite() && scaled_b.translation.allFinite());
    if (moved_world) {
      scaled_b.translation = scale_vector(translation_hi, k);
      scaled_a.translation = scale_vector(Vec3<S>(-translation_lo), k);
    }
    scaled_options.distance_cutoff = std::ldexp(options.distance_cutoff, k);
    QueryScale<S> scale;
    const auto scaled_ga = scale_geometry<S>(ga, k);
    const auto scaled_gb = scale_geometry<S>(gb, k);
    // Shapes modelled far from their local origins (centres near the largest number) cannot be
    // scaled up to a separation far below the subnormals' resolution: their centres or the
    // translations leave the range. Refused, not answered: the query would see them "at one
    // place" (float points at 4e36 placed back to 7e-45 apart were "intersecting", bound 0).
    if (!(detail::Support<std::decay_t<decltype(scaled_ga)>, S>{scaled_ga}.center().allFinite() &&
          detail::Support<std::decay_t<decltype(scaled_gb)>, S>{scaled_gb}.center().allFinite() &&
          scaled_a.translation.allFinite() && scaled_b.translation.allFinite()))
      return set_invalid(result,
                         "shapes modelled this far from their local origins cannot be measured at "
                         "so small a separation in this precision");
    const QueryInput<S, std::decay_t<decltype(scaled_ga)>, std::decay_t<decltype(scaled_gb)>>
        scaled{{scaled_ga, scaled_radius_a, scaled_a},
               {scaled_gb, scaled_radius_b, scaled_b},
               scaled_options,
               in.defect2_a,
               std::ldexp(in.placement, k)};
    const bool done = query<S>(scaled, cache, result, attempt < 2, scale);
    if (done) break;
    if (!(scale.magnitude > 0 && scale.magnitude <= kLargestLength<S>)) {
      attempt = 1;  // zero or non-finite: the next pass decides without rescaling
      continue;
    }
    // M near 1, unless that leaves D(K) below the range: then D(K) at the range's low end, as far
    // as M allows. The range holds any K with M/D(K) below 2^(high − low − 1); scaling M to 1
    // alone refused pairs whose D(K) lay 2^17 below M in float (a compound's piece posed 3e4 from
    // its object's origin, 1.5e-5 from the other piece: found by fuzz_engine, refused only when a
    // warm start led the query to that pair).
    int correction = -std::ilogb(scale.magnitude);
    if (scale.diameter > 0 && std::ilogb(scale.diameter) + correction < LoopRange<S>::low)
      correction = std::min(LoopRange<S>::low - std::ilogb(scale.diameter),
                            LoopRange<S>::high - 1 - std::ilogb(scale.magnitude));
    k += correction;
  }
  if (result.status == Status::invalid_input) return;

  // Back to the caller's scale.
  const int back = -k;
  const S subnormal_rounding = back < 0 ? S(2) * std::numeric_limits<S>::denorm_min() : S(0);
  result.distance = std::ldexp(result.distance, back);
  result.error_bound = std::ldexp(result.error_bound, back) + subnormal_rounding;
  result.gap = std::min(std::ldexp(result.gap, 2 * back), std::numeric_limits<S>::max());
  result.diameter_bound = std::ldexp(result.diameter_bound, back);
  result.penetration_bound = std::ldexp(result.penetration_bound, back);
  // A separation certified at the loop's scale may not survive the way back: below the smallest
  // normal numbers the distance rounds to a subnormal or to 0 while the bound gains the rounding.
  // The verdict then follows the rule of the normal path: "separated" only when the distance
  // exceeds its bound; otherwise too close to tell from touching ("touching"),
  // with the distance folded into the bound (found by fuzz_engine: float shapes 1e-45 apart
  // answered "separated" with distance 0). Beyond the cutoff the distance is a lower bound: it is
  // lowered by the rounding (so that it stays one) and separates while it stays above 0.
  if (result.beyond_cutoff() && result.status == Status::separated) {
    result.distance = std::max(S(0), result.distance - subnormal_rounding);
    result.error_bound += subnormal_rounding;
    if (!(result.distance > 0)) result.status = Status::touching;
  } else if (result.status == Status::separated && !(result.distance > result.error_bound)) {
    result.status = Status::touching;
    result.error_bound += result.distance;
    result.distance = 0;
  }
  if (result.has_near_points) {
    // A moved world placed A at −lo: its frame is the caller's moved by −(p_A + lo).
    const Vec3<S> origin =
        moved_world ? Vec3<S>(pose_a.translation + translation_lo) : Vec3<S>::Zero();
    result.point_a = scale_vector(result.point_a, back) + origin;
    result.point_b = scale_vector(result.point_b, back) + origin;
  }
  if (result.has_signed_distance) {
    result.signed_distance = std::ldexp(result.signed_distance, back);
    result.signed_distance_lower = std::ldexp(result.signed_distance_lower, back) -
                                   (result.signed_distance_lower > 0 ? S(0) : subnormal_rounding);
    result.signed_distance_upper =
        std::ldexp(result.signed_distance_upper, back) + subnormal_rounding;
    result.depth = std::ldexp(result.depth, back);
    result.depth_lower = std::max(S(0), std::ldexp(result.depth_lower, back) - subnormal_rounding);
    result.depth_upper = std::ldexp(result.depth_upper, back) + subnormal_rounding;
    const Vec3<S> origin =
        moved_world ? Vec3<S>(pose_a.translation + translation_lo) : Vec3<S>::Zero();
    result.depth_point_a = scale_vector(result.depth_point_a, back) + origin;
    result.depth_point_b = scale_vector(result.depth_point_b, back) + origin;
    if (result.status == Status::separated) {
      result.signed_distance = result.distance;
      result.signed_distance_lower = std::max(S(0), result.distance - result.error_bound);
      result.signed_distance_upper = result.distance + result.error_bound;
    } else if (result.status == Status::touching && result.signed_distance_lower > 0) {
      // A separation lost on the way back (below): touching, to within the bound.
      result.signed_distance_lower = 0;
    }
  }
  if (result.has_gradient) {  // ∂/∂rotation is a length (a lever arm × the unit normal)
    result.gradient_a.template tail<3>() =
        scale_vector(Vec3<S>(result.gradient_a.template tail<3>()), back);
    result.gradient_b.template tail<3>() =
        scale_vector(Vec3<S>(result.gradient_b.template tail<3>()), back);
  }
  using std::isfinite;
  if (!(isfinite(result.distance) && isfinite(result.error_bound) &&
        isfinite(result.penetration_bound) && isfinite(result.gap) &&
        isfinite(result.depth_upper) && isfinite(result.signed_distance_lower) &&
        result.depth_point_a.allFinite() && result.depth_point_b.allFinite()))
    set_invalid(result, kNotRepresentable);
}

}  // namespace

template <class S>
void distance_gradient(const Vec3<S>& point_a, const Vec3<S>& point_b, const Vec3<S>& normal,
                       const Vec3<S>& origin_a, const Vec3<S>& origin_b,
                       Eigen::Matrix<S, 6, 1>& gradient_a, Eigen::Matrix<S, 6, 1>& gradient_b) {
  // d = n·(x_B − x_A) to first order. Translating A by τ moves x_A by τ: ∂d/∂τ_A = −n. Rotating A
  // by a small θ about its origin moves x_A by θ × (x_A − o_A): ∂d/∂θ_A = −(x_A − o_A) × n.
  gradient_a.template head<3>() = -normal;
  gradient_a.template tail<3>() = -(point_a - origin_a).cross(normal);
  gradient_b.template head<3>() = normal;
  gradient_b.template tail<3>() = (point_b - origin_b).cross(normal);
}

template <class S>
DistanceResult<S> distance(const Shape<S>& a, const Pose<S>& pose_a, const Shape<S>& b,
                           const Pose<S>& pose_b, const DistanceOptions<S>& options,
                           SimplexCache* cache) {
  DistanceResult<S> result;  // the one object returned, built in the caller's storage
  S defect2_a = 0;  // ‖R_AᵀR_A − I‖_F², for the bound: the pose check computes it anyway
  if (const char* why = detail::invalid_poses_reason(pose_a, pose_b, &defect2_a)) {
    set_invalid(result, why);
    return result;
  }
  detail::distance_with_valid_poses(a, pose_a, b, pose_b, options, cache, result, defect2_a);
  return result;
}

template <class S>
void detail::distance_with_valid_poses(const Shape<S>& a, const Pose<S>& pose_a, const Shape<S>& b,
                                       const Pose<S>& pose_b, const DistanceOptions<S>& options,
                                       SimplexCache* cache, DistanceResult<S>& result, S defect2_a,
                                       S placement) {
  const char* why = invalid_reason(a);
  if (!why) why = invalid_reason(b);
  if (!why && !(options.epsilon >= 0)) why = "options.epsilon must be >= 0";
  if (!why && std::isnan(options.distance_cutoff)) why = "options.distance_cutoff is NaN";
  if (why) return set_invalid(result, why);
  // A refused query leaves the warm-start cache as it found it: the checks below can refuse an
  // answer after the loop has written its simplex there.
  SimplexCache cache_before;  // copied only when there is a cache (no cost on the plain query)
  if (cache) cache_before = *cache;
  // One dispatch per query; the loop below is specialised for the two concrete shapes.
  std::visit(
      [&](const auto& ga, const auto& gb) {
        using GA = std::decay_t<decltype(ga)>;
        using GB = std::decay_t<decltype(gb)>;
        const QueryInput<S, GA, GB> in{
            {ga, a.radius, pose_a}, {gb, b.radius, pose_b}, options, defect2_a, placement};
        QueryScale<S> scale;
        if (!query<S>(in, cache, result, true, scale)) rescaled_query<S>(in, cache, result);
      },
      a.geometry, b.geometry);
  // The promise of no non-finite output. Inside the loop's range distances, bounds and d⁻ are
  // finite by construction (D(K) ≤ 2^128, radii ≤ max/256; rescaled_query checks its own); near
  // points are p_A plus a length and overflow when p_A is near the largest number.
  if ((result.has_near_points && !(result.point_a.allFinite() && result.point_b.allFinite())) ||
      (result.has_penetration_depth &&
       !(result.depth_point_a.allFinite() && result.depth_point_b.allFinite() &&
         std::isfinite(result.depth_upper))) ||
      (result.has_gradient && !(result.gradient_a.allFinite() && result.gradient_b.allFinite())))
      [[unlikely]]
    set_invalid(result, kNotRepresentable);
  if (cache && result.status == Status::invalid_input) [[unlikely]]
    *cache = cache_before;
}

template const char* detail::invalid_pose_reason(const Pose<double>&);
template const char* detail::invalid_pose_reason(const Pose<float>&);
template void detail::distance_with_valid_poses(const Shape<double>&, const Pose<double>&,
                                                const Shape<double>&, const Pose<double>&,
                                                const DistanceOptions<double>&, SimplexCache*,
                                                DistanceResult<double>&, double, double);
template void detail::distance_with_valid_poses(const Shape<float>&, const Pose<float>&,
                                                const Shape<float>&, const Pose<float>&,
                                                const DistanceOptions<float>&, SimplexCache*,
                                                DistanceResult<float>&, float, float);
template DistanceResult<double> distance(const Shape<double>&, const Pose<double>&,
                                         const Shape<double>&, const Pose<double>&,
                                         const DistanceOptions<double>&, SimplexCache*);
template DistanceResult<float> distance(const Shape<float>&, const Pose<float>&,
                                        const Shape<float>&, const Pose<float>&,
                                        const DistanceOptions<float>&, SimplexCache*);
template void distance_gradient(const Vec3<double>&, const Vec3<double>&, const Vec3<double>&,
                                const Vec3<double>&, const Vec3<double>&,
                                Eigen::Matrix<double, 6, 1>&, Eigen::Matrix<double, 6, 1>&);
template void distance_gradient(const Vec3<float>&, const Vec3<float>&, const Vec3<float>&,
                                const Vec3<float>&, const Vec3<float>&, Eigen::Matrix<float, 6, 1>&,
                                Eigen::Matrix<float, 6, 1>&);

const char* to_string(Termination termination) {
  switch (termination) {
    case Termination::origin_enclosed:
      return "origin_enclosed";
    case Termination::tolerance:
      return "tolerance";
    case Termination::repeated_support:
      return "repeated_support";
    case Termination::roundoff_floor:
      return "roundoff_floor";
    case Termination::numerical_limit:
      return "numerical_limit";
    case Termination::beyond_cutoff:
      return "beyond_cutoff";
    case Termination::iteration_limit:
      return "iteration_limit";
    case Termination::contact:
      return "contact";
  }
  return "unknown";
}

const char* to_string(Status status) {
  switch (status) {
    case Status::separated:
      return "separated";
    case Status::intersecting:
      return "intersecting";
    case Status::iteration_limit:
      return "iteration_limit";
    case Status::invalid_input:
      return "invalid_input";
    case Status::touching:
      return "touching";
  }
  return "unknown";
}

const char* to_string(DepthTermination termination) {
  switch (termination) {
    case DepthTermination::closed_form:
      return "closed_form";
    case DepthTermination::tolerance:
      return "tolerance";
    case DepthTermination::iteration_limit:
      return "iteration_limit";
    case DepthTermination::degenerate:
      return "degenerate";
  }
  return "unknown";
}

}  // namespace nearpoint
