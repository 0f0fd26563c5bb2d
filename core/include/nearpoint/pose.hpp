// SPDX-License-Identifier: Apache-2.0
// Poses: where a shape sits in the world. K(q) = T(q)·C + p(q), the paper's eq. (9)–(10).
#pragma once

#include <cmath>
#include <type_traits>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace nearpoint {

template <class Scalar>
using Vec3 = Eigen::Matrix<Scalar, 3, 1>;
template <class Scalar>
using Mat3 = Eigen::Matrix<Scalar, 3, 3>;

/// A rigid transformation: a point x given in the shape's own (local) frame sits at
/// `rotation * x + translation` in the world frame. Units are the caller's (metres by convention).
///
/// The engine never transforms a shape's vertices: it applies the pose to the search direction
/// instead, s_{TC+p}(η) = T·s_C(Tᵀη) + p, so a pose costs a few flops per support call however many
/// vertices a shape has.
template <class Scalar>
struct Pose {
  /// Orthonormal rotation matrix with determinant +1 (local → world).
  ///
  /// How orthonormal: a query accepts a rotation whose defect e = max |(RᵀR − I)ᵢⱼ| is at most
  /// 1e-6 in double (1.2e-4 in float), enough for a matrix built from a single-precision
  /// quaternion, and refuses larger defects. An accepted defect is covered by the result's
  /// `error_bound`, not corrected: the shape is taken to be R·x + t with R exactly as given, and
  /// the bound grows by 3·(‖RᵀR − I‖_F − 8ε)·D(K) for pose A's rotation (A's frame is entered
  /// through Rᵀ, which is R⁻¹ only when RᵀR = I); B's rotation is applied as given and costs
  /// nothing. A rotation computed in the working precision (‖RᵀR − I‖_F ≈ 1e-16 in double) adds
  /// nothing; one from a float quaternion used in double (≈ 1e-7) makes the bound ~3e-7 relative
  /// to D(K).
  /// Normalise quaternions in the working precision (`from_quaternion` does) to keep the bound
  /// tight.
  Mat3<Scalar> rotation = Mat3<Scalar>::Identity();
  /// Position of the local origin in the world frame.
  Vec3<Scalar> translation = Vec3<Scalar>::Zero();

  static Pose identity() { return Pose{}; }

  /// From a unit quaternion (w, x, y, z) and a translation. The quaternion is normalised here;
  /// use `pose_from_quaternion_checked` to reject quaternions that are far from unit length.
  static Pose from_quaternion(const Eigen::Quaternion<Scalar>& q, const Vec3<Scalar>& t) {
    Pose pose;
    pose.rotation = q.normalized().toRotationMatrix();
    pose.translation = t;
    return pose;
  }

  Vec3<Scalar> apply(const Vec3<Scalar>& local) const { return rotation * local + translation; }

  /// The pose of `child`'s frame seen from the world, when `child` is given in this pose's frame.
  Pose compose(const Pose& child) const {
    Pose out;
    out.rotation = rotation * child.rotation;
    out.translation = rotation * child.translation + translation;
    return out;
  }

  Pose inverse() const {
    Pose out;
    out.rotation = rotation.transpose();
    out.translation = -(out.rotation * translation);
    return out;
  }
};

/// How far from unit length a quaternion may be and still be accepted (and normalised). Beyond
/// this, the input is almost certainly not a rotation (a unit mix-up, a zero quaternion, garbage)
/// and is rejected. 1e-4 accepts quaternions written with single-precision floats or 6 digits.
inline constexpr double kQuaternionNormTolerance = 1e-4;

/// Builds a pose from a quaternion (w, x, y, z) and a translation, refusing non-finite values and
/// quaternions whose norm differs from 1 by more than `kQuaternionNormTolerance`.
/// Returns nullptr on success, otherwise a static message naming the problem.
template <class Scalar>
const char* pose_from_quaternion_checked(Scalar w, Scalar x, Scalar y, Scalar z,
                                         const std::type_identity_t<Vec3<Scalar>>& translation,
                                         Pose<Scalar>& out) {
  using std::abs;
  using std::isfinite;
  using std::sqrt;
  if (!isfinite(w) || !isfinite(x) || !isfinite(y) || !isfinite(z))
    return "rotation quaternion has a non-finite component";
  if (!translation.allFinite()) return "translation has a non-finite component";
  const double norm = sqrt(double(w) * w + double(x) * x + double(y) * y + double(z) * z);
  if (abs(norm - 1.0) > kQuaternionNormTolerance)
    return "rotation quaternion is not of unit length (|q| differs from 1 by more than 1e-4)";
  out = Pose<Scalar>::from_quaternion(Eigen::Quaternion<Scalar>(w, x, y, z), translation);
  return nullptr;
}

}  // namespace nearpoint
