// SPDX-License-Identifier: Apache-2.0
// The distance query: the paper's Numerical Algorithm (Section VI) on K = A − B.
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
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
/// Scales. Shapes of any size from the smallest to about 1e306 in double (1e36 in float) are
/// accepted: when D(K) (eq. 37) lies outside [2^-128, 2^128] in double ([2^-16, 2^16] in float),
/// where squares and the subalgorithm's products would under- or overflow, K is scaled by a power
/// of two before the loop and the answer scaled back; both are exact, so the answer is the one
/// the loop would give at a comfortable scale. Larger shapes, radii or separations, radii more
/// than ~1e300 times the cores' size and separation, and answers that are not representable
/// (near points beyond the largest number) give `Status::invalid_input` with a message.
/// Shapes modelled far from their local origin (CAD meshes in world coordinates placed back by
/// a pose) are placed with compensated arithmetic, so their error scales with their size, not
/// with their local coordinates; a rotation's defect is in the bound (see Pose::rotation).
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
