// SPDX-License-Identifier: Apache-2.0
// Kinematic trees (a forest of links hanging from the world) with their forward kinematics in
// double and the Jacobians that turn the engine's pose gradient of a distance into its gradient
// with respect to the joint positions. One model for URDF and MJCF: a link is placed on its parent
// by a fixed offset, then moved by its joints in order, as MuJoCo's mj_kinematics does (a URDF
// link has at most one joint, at the link's origin).
//
// Positions and velocities (MuJoCo's qpos/qvel layout): revolute, continuous, prismatic, hinge and
// slide joints have one of each; a ball joint has a unit quaternion (w, x, y, z) as position and
// an angular velocity in the joint's frame (after its rotation) as velocity; a free joint has
// (x, y, z, qw, qx, qy, qz) and (linear velocity in the world frame, angular velocity in the
// link's frame). Gradients are per velocity coordinate: for one-dof joints that is ∂d/∂q.
// Units: metres and radians.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "nearpoint/pose.hpp"

namespace nearpoint::robots {

using Vec3d = Vec3<double>;
using Mat3d = Mat3<double>;
using Pose3d = Pose<double>;
using Vec6d = Eigen::Matrix<double, 6, 1>;

enum class JointType : unsigned char { fixed, revolute, continuous, prismatic, ball, free };

/// "fixed", "revolute", … (the URDF names; MJCF hinge is revolute, slide prismatic).
const char* to_string(JointType type);

struct Joint {
  std::string name;
  JointType type = JointType::fixed;
  /// The link this joint moves.
  int link = -1;
  /// Unit axis in the link's frame as it is when the joint acts (revolute/prismatic).
  Vec3d axis = Vec3d::UnitZ();
  /// A point of the axis (the centre of a ball joint), link frame. URDF: the link origin.
  Vec3d anchor = Vec3d::Zero();
  /// The position at which the joint is at rest (MJCF `ref`): motion is q − reference.
  double reference = 0;
  /// Limits are carried and reported (`limit_violations`), never enforced.
  bool limited = false;
  double lower = 0;
  double upper = 0;
  /// Offsets of this joint's coordinates in the position and velocity vectors.
  int q_index = 0;
  int v_index = 0;
  int nq() const;
  int nv() const;
};

struct Link {
  std::string name;
  /// Index of the parent link, or -1 for the world.
  int parent = -1;
  /// Parent frame → this link's frame before its joints act (URDF: the joint origin).
  Pose3d offset;
  /// Indices into KinematicTree::joints, applied in this order.
  std::vector<int> joints;
};

/// Where everything is for one vector of joint positions (see KinematicTree::forward).
struct KinematicState {
  /// Link frame → world, per link.
  std::vector<Pose3d> links;
  /// Per joint, world frame: the axis (revolute/prismatic), the anchor, and the frame just after
  /// the joint acted (whose columns are a ball's or a free joint's angular velocity axes).
  std::vector<Vec3d> joint_axes;
  std::vector<Vec3d> joint_anchors;
  std::vector<Mat3d> joint_frames;
};

class KinematicTree {
 public:
  /// Links in an order where parents come first; joints listed in link order. `finalize` checks
  /// that and assigns q_index/v_index; returns "" or the reason.
  std::vector<Link> links;
  std::vector<Joint> joints;

  std::string finalize();

  int nq() const { return nq_; }
  int nv() const { return nv_; }
  /// The positions at which every joint is at its reference (identity quaternions).
  std::vector<double> neutral() const;
  int find_link(const std::string& name) const;
  int find_joint(const std::string& name) const;
  /// Whether `ancestor` is `link` or one of its ancestors.
  bool is_ancestor(int ancestor, int link) const;

  /// Forward kinematics. Returns "" or why not (wrong size, a non-finite position, a zero
  /// quaternion); quaternions are normalised as MuJoCo does.
  std::string forward(std::span<const double> q, KinematicState& state) const;

  /// q advanced by velocity `v` for `dt` (ball/free rotations on the manifold, as MuJoCo's
  /// mj_integratePos): the step of finite differences and of gradient descent on q.
  std::vector<double> integrate(std::span<const double> q, std::span<const double> v,
                                double dt) const;

  /// The 6×nv Jacobian of a frame attached to `link` whose origin is at `origin` (world): rows
  /// (origin velocity, angular velocity), world frame — the layout of the engine's pose gradient,
  /// so ∂d/∂v = Jᵀ g. `link` −1 (the world) gives zeros.
  Eigen::Matrix<double, 6, Eigen::Dynamic> jacobian(const KinematicState& state, int link,
                                                    const Vec3d& origin) const;

  /// Adds Jᵀ·gradient to `out` (size nv) without forming J: the joint-space gradient of a
  /// distance from one side's pose gradient (core distance_gradient convention:
  /// (∂/∂translation, ∂/∂rotation vector about the body origin), world frame).
  void add_joint_gradient(const KinematicState& state, int link, const Vec3d& origin,
                          const Vec6d& gradient, Eigen::VectorXd& out) const;

  /// Joints whose position lies outside their limits at q: "name: q=… outside [lo, hi]".
  std::vector<std::string> limit_violations(std::span<const double> q) const;

 private:
  int nq_ = 0;
  int nv_ = 0;
};

}  // namespace nearpoint::robots
