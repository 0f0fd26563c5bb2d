// The distance query: the paper's Numerical Algorithm (Section VI) on K = A − B.
#pragma once

#include "nearpoint/options.hpp"
#include "nearpoint/pose.hpp"
#include "nearpoint/result.hpp"
#include "nearpoint/shapes.hpp"

namespace nearpoint {

/// Distance, near points and friends between shape `a` at `pose_a` and shape `b` at `pose_b`.
///
/// Works in A's frame with B's pose relative to it, and with the origin moved to the midpoint of
/// the two centroids (eq. 34), so that a large common offset of both poses cancels exactly and the
/// error scales with the shapes' size, not with their distance from the world origin.
///
/// `cache` (optional, may be null) is read as a warm start and overwritten with the final simplex
/// (Section VIII). Pass a zeroed cache for a cold start (single-point initialisation, Section VI).
///
/// Never throws, never allocates, never returns NaN: bad input gives `Status::invalid_input`.
template <class Scalar>
DistanceResult<Scalar> distance(const Shape<Scalar>& a, const Pose<Scalar>& pose_a,
                                const Shape<Scalar>& b, const Pose<Scalar>& pose_b,
                                const DistanceOptions<Scalar>& options = {},
                                SimplexCache* cache = nullptr);

/// The gradient of the distance between two separated bodies with respect to their poses, from
/// the near points and the unit normal (A → B), world frame. Body X's origin is `origin_x`.
/// Layout (∂d/∂translation, ∂d/∂rotation-vector). Used by `distance` and by compound queries.
template <class Scalar>
void distance_gradient(const Vec3<Scalar>& point_a, const Vec3<Scalar>& point_b,
                       const Vec3<Scalar>& normal, const Vec3<Scalar>& origin_a,
                       const Vec3<Scalar>& origin_b, Eigen::Matrix<Scalar, 6, 1>& gradient_a,
                       Eigen::Matrix<Scalar, 6, 1>& gradient_b);

}  // namespace nearpoint
