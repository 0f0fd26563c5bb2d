// The distance query: validation, the relative frame, dispatch to the specialised loop, and the
// result (near points, spherical extensions, error bound, penetration bound, gradient).
#include "nearpoint/distance.hpp"

#include <cmath>
#include <limits>

#include "distance_internal.hpp"
#include "gjk.hpp"

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

// Writes into `result`, which the caller has just default-constructed (see
// detail::distance_with_valid_poses).
template <class S, class GA, class GB>
void query(const GA& ga, S radius_a, const Pose<S>& pose_a, const GB& gb, S radius_b,
           const Pose<S>& pose_b, const DistanceOptions<S>& options, SimplexCache* cache,
           DistanceResult<S>& result) {
  using SA = detail::Support<GA, S>;
  using SB = detail::Support<GB, S>;
  const SA support_a{ga};
  const SB support_b{gb};

  // B relative to A: t = R_Aᵀ(p_B − p_A). A common offset of both poses cancels in p_B − p_A.
  // Written out (detail::rotate_back per column): Eigen's 3×3 products were left out of line here,
  // on the path to the first support point.
  Mat3<S> rotation;
  for (int j = 0; j < 3; ++j)
    rotation.col(j) = detail::rotate_back(pose_a.rotation, Vec3<S>(pose_b.rotation.col(j)));
  const Vec3<S> translation =
      detail::rotate_back(pose_a.rotation, Vec3<S>(pose_b.translation - pose_a.translation));
  const Vec3<S> a_center = support_a.center();
  const Vec3<S> b_center_rel = detail::rotate(rotation, support_b.center()) + translation;
  // Every member given its value here: an aggregate with members left to `{}` was zeroed first
  // (a `rep stos` of 168 bytes per query).
  const detail::MinkowskiDifference<S, SA, SB> k_set{
      support_a,
      support_b,
      rotation,
      Vec3<S>(b_center_rel - a_center),  // δ, eq. (34)
      a_center,
      b_center_rel,
      options.origin_shift};

  // D(K) ≤ D(A − z̄_A) + D(B − z̄_B) + |z̄_A − z̄_B|, eq. (37).
  const S diameter = detail::diameter_bound(k_set);
  // Squared lengths of D(K) must stay finite: beyond ~1e150 (double) or ~1e18 (float) the inner
  // products overflow and no answer could be trusted.
  using std::sqrt;
  if (!(diameter <= sqrt(std::numeric_limits<S>::max()) / S(64))) {
    return set_invalid(result,
                       "shapes and their separation are too large for this precision (inner "
                       "products would overflow: keep coordinates below ~1e150 in double, ~1e17 "
                       "in float)");
  }
  const S epsilon = options.epsilon > 0 ? options.epsilon : S(0);
  const S radii = radius_a + radius_b;
  const S cutoff = options.distance_cutoff + radii;  // the loop works on the cores

  // Below this core distance the verdict can only be "intersecting" (see the verdict below:
  // separation needs |ν| − radii above the error bound, which is at least `roundoff`), so a query
  // that wants no near points, d⁻ or gradient can stop there instead of converging further.
  const S roundoff = detail::distance_roundoff(diameter);
  const bool needs_simplex = options.near_points || options.penetration_bound || options.gradient;
  const S settled_below = needs_simplex ? S(-1) : radii + roundoff;

  // d⁻ (eq. 32) comes from the faces of the tetrahedron that encloses the origin; an interior
  // corner (the centroids' point) would pull them inwards and weaken it.
  const ColdStart cold_start =
      options.penetration_bound ? ColdStart::single_point : options.cold_start;
  detail::LoopOutcome<S> loop;
  detail::run_numerical_algorithm(k_set, diameter, epsilon * diameter * diameter,
                                  std::max(0, options.max_iterations), cutoff, settled_below,
                                  options.subalgorithm, cold_start, cache, loop);

  const detail::Nearest<S>& nearest = loop.nearest;
  const detail::Simplex<S>& simplex = loop.simplex;
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
    result.error_bound = roundoff;
  }

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

  // The verdict needs a proof. The distance is within error_bound of |ν| − r_A − r_B, so
  // "separated" is certain when that exceeds the bound; otherwise the shapes touch, overlap, or
  // are too close to tell from touching at this precision or tolerance, and touching counts as
  // intersecting. (This also keeps a numerical-limit exit deep inside an overlap, where |ν| can
  // be 1e-17 rather than 0, "intersecting", and a loose ε from claiming a separation it cannot
  // back.)
  const bool cores_intersect = !(nearest.nu_norm2 > 0);
  const bool separated = !cores_intersect && core_distance - radii > result.error_bound;
  result.distance = separated ? core_distance - radii : S(0);  // eq. (8): (d − r_A − r_B)⁺
  if (!separated) result.error_bound += std::max(S(0), core_distance - radii);
  if (loop.termination == Termination::iteration_limit)
    result.status = Status::iteration_limit;
  else
    result.status = separated ? Status::separated : Status::intersecting;

  if (options.near_points || options.gradient) {
    // eq. (23)–(24): near points from the simplex weights, in A's frame relative to z̄_A.
    Vec3<S> on_a = Vec3<S>::Zero(), on_b = Vec3<S>::Zero();
    for (int i = 0; i < 4; ++i) {
      if (!(nearest.subset & (1u << i))) continue;
      on_a += nearest.lambda[i] * simplex.a[i];
      on_b += nearest.lambda[i] * simplex.b[i];
    }
    Vec3<S> point_a = k_set.a_center + on_a;
    Vec3<S> point_b = k_set.a_center + k_set.offset + on_b;
    Vec3<S> normal = Vec3<S>::Zero();  // A → B, A's frame: −ν/|ν|
    if (!cores_intersect) {
      normal = -nearest.nu / core_distance;
      point_a += radius_a * normal;
      point_b -= radius_b * normal;
    } else {
      point_b = point_a;  // one common point of the cores
    }
    result.has_near_points = true;
    result.point_a = detail::rotate(pose_a.rotation, point_a) + pose_a.translation;
    result.point_b = detail::rotate(pose_a.rotation, point_b) + pose_a.translation;
    result.normal = detail::rotate(pose_a.rotation, normal);
  }

  if (options.penetration_bound && result.status == Status::intersecting) {
    // eq. (32)–(33) on the cores, plus the radii; for rounded shapes whose cores are apart the
    // overlap r_A + r_B − d is the exact penetration depth.
    result.has_penetration_bound = true;
    result.penetration_bound =
        cores_intersect ? detail::penetration_lower_bound(simplex, nearest.subset) + radii
                        : std::max(S(0), radii - core_distance);
  }

  if (options.gradient && result.status == Status::separated && !result.beyond_cutoff()) {
    distance_gradient(result.point_a, result.point_b, result.normal, pose_a.translation,
                      pose_b.translation, result.gradient_a, result.gradient_b);
    result.has_gradient = true;
  }
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
  if (const char* why = detail::invalid_poses_reason(pose_a, pose_b)) {
    set_invalid(result, why);
    return result;
  }
  detail::distance_with_valid_poses(a, pose_a, b, pose_b, options, cache, result);
  return result;
}

template <class S>
void detail::distance_with_valid_poses(const Shape<S>& a, const Pose<S>& pose_a, const Shape<S>& b,
                                       const Pose<S>& pose_b, const DistanceOptions<S>& options,
                                       SimplexCache* cache, DistanceResult<S>& result) {
  const char* why = invalid_reason(a);
  if (!why) why = invalid_reason(b);
  if (!why && !(options.epsilon >= 0)) why = "options.epsilon must be >= 0";
  if (!why && std::isnan(options.distance_cutoff)) why = "options.distance_cutoff is NaN";
  if (why) return set_invalid(result, why);
  // One dispatch per query; the loop below is specialised for the two concrete shapes.
  std::visit(
      [&](const auto& ga, const auto& gb) {
        query<S>(ga, a.radius, pose_a, gb, b.radius, pose_b, options, cache, result);
      },
      a.geometry, b.geometry);
}

template const char* detail::invalid_pose_reason(const Pose<double>&);
template const char* detail::invalid_pose_reason(const Pose<float>&);
template void detail::distance_with_valid_poses(const Shape<double>&, const Pose<double>&,
                                                const Shape<double>&, const Pose<double>&,
                                                const DistanceOptions<double>&, SimplexCache*,
                                                DistanceResult<double>&);
template void detail::distance_with_valid_poses(const Shape<float>&, const Pose<float>&,
                                                const Shape<float>&, const Pose<float>&,
                                                const DistanceOptions<float>&, SimplexCache*,
                                                DistanceResult<float>&);
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
  }
  return "unknown";
}

}  // namespace nearpoint
