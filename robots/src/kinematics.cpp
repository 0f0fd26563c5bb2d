// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/robots/kinematics.hpp"

#include <cmath>
#include <sstream>

#include <Eigen/Geometry>

namespace nearpoint::robots {
namespace {

Eigen::Quaterniond quat_at(std::span<const double> q, int index) {
  return Eigen::Quaterniond(q[index], q[index + 1], q[index + 2], q[index + 3]);
}

// exp of a rotation vector as a quaternion (MuJoCo's mju_quatIntegrate step).
Eigen::Quaterniond rotation_exp(const Vec3d& w) {
  const double angle = w.norm();
  if (angle == 0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

}  // namespace

const char* to_string(JointType type) {
  switch (type) {
    case JointType::fixed:
      return "fixed";
    case JointType::revolute:
      return "revolute";
    case JointType::continuous:
      return "continuous";
    case JointType::prismatic:
      return "prismatic";
    case JointType::ball:
      return "ball";
    case JointType::free:
      return "free";
  }
  return "unknown";
}

int Joint::nq() const {
  switch (type) {
    case JointType::fixed:
      return 0;
    case JointType::ball:
      return 4;
    case JointType::free:
      return 7;
    default:
      return 1;
  }
}

int Joint::nv() const {
  switch (type) {
    case JointType::fixed:
      return 0;
    case JointType::ball:
      return 3;
    case JointType::free:
      return 6;
    default:
      return 1;
  }
}

std::string KinematicTree::finalize() {
  nq_ = nv_ = 0;
  std::vector<int> seen(joints.size(), 0);
  for (std::size_t l = 0; l < links.size(); ++l) {
    const Link& link = links[l];
    if (link.parent >= static_cast<int>(l) || link.parent < -1)
      return "link '" + link.name + "': its parent must come before it";
    for (std::size_t k = 0; k < link.joints.size(); ++k) {
      const int j = link.joints[k];
      if (j < 0 || j >= static_cast<int>(joints.size()) || seen[j]++)
        return "link '" + link.name + "': bad joint index";
      Joint& joint = joints[j];
      if (joint.link != static_cast<int>(l))
        return "joint '" + joint.name + "' does not name its link";
      if (joint.type == JointType::free && (k != 0 || link.parent != -1 || link.joints.size() != 1))
        return "joint '" + joint.name +
               "': a free joint must be the only joint of a link whose parent is the world";
      if ((joint.type == JointType::revolute || joint.type == JointType::continuous ||
           joint.type == JointType::prismatic)) {
        const double n = joint.axis.norm();
        if (!(n > 0) || !std::isfinite(n)) return "joint '" + joint.name + "': axis is zero";
        joint.axis /= n;
      }
      joint.q_index = nq_;
      joint.v_index = nv_;
      nq_ += joint.nq();
      nv_ += joint.nv();
    }
  }
  for (std::size_t j = 0; j < joints.size(); ++j)
    if (!seen[j]) return "joint '" + joints[j].name + "' is on no link";
  return {};
}

std::vector<double> KinematicTree::neutral() const {
  std::vector<double> q(nq_, 0.0);
  for (const Joint& joint : joints) {
    if (joint.type == JointType::ball)
      q[joint.q_index] = 1;
    else if (joint.type == JointType::free)
      q[joint.q_index + 3] = 1;
    else if (joint.nq() == 1)
      q[joint.q_index] = joint.reference;
  }
  return q;
}

int KinematicTree::find_link(const std::string& name) const {
  for (std::size_t i = 0; i < links.size(); ++i)
    if (links[i].name == name) return static_cast<int>(i);
  return -1;
}

int KinematicTree::find_joint(const std::string& name) const {
  for (std::size_t i = 0; i < joints.size(); ++i)
    if (joints[i].name == name) return static_cast<int>(i);
  return -1;
}

bool KinematicTree::is_ancestor(int ancestor, int link) const {
  for (; link >= 0; link = links[link].parent)
    if (link == ancestor) return true;
  return false;
}

std::string KinematicTree::forward(std::span<const double> q, KinematicState& state) const {
  if (q.size() != static_cast<std::size_t>(nq_)) {
    std::ostringstream out;
    out << "expected " << nq_ << " joint positions, got " << q.size();
    return out.str();
  }
  for (std::size_t i = 0; i < q.size(); ++i)
    if (!std::isfinite(q[i])) {
      std::ostringstream out;
      out << "joint position " << i << " is not finite";
      return out.str();
    }
  state.links.resize(links.size());
  state.joint_axes.assign(joints.size(), Vec3d::Zero());
  state.joint_anchors.assign(joints.size(), Vec3d::Zero());
  state.joint_frames.assign(joints.size(), Mat3d::Identity());
  for (std::size_t l = 0; l < links.size(); ++l) {
    const Link& link = links[l];
    Pose3d pose = link.parent < 0 ? link.offset : state.links[link.parent].compose(link.offset);
    for (const int j : link.joints) {
      const Joint& joint = joints[j];
      switch (joint.type) {
        case JointType::fixed:
          state.joint_anchors[j] = pose.apply(joint.anchor);
          state.joint_frames[j] = pose.rotation;
          break;
        case JointType::revolute:
        case JointType::continuous: {
          const Vec3d anchor = pose.apply(joint.anchor);
          state.joint_axes[j] = pose.rotation * joint.axis;
          state.joint_anchors[j] = anchor;
          pose.rotation =
              pose.rotation *
              Eigen::AngleAxisd(q[joint.q_index] - joint.reference, joint.axis).toRotationMatrix();
          pose.translation = anchor - pose.rotation * joint.anchor;
          state.joint_frames[j] = pose.rotation;
          break;
        }
        case JointType::prismatic: {
          state.joint_axes[j] = pose.rotation * joint.axis;
          state.joint_anchors[j] = pose.apply(joint.anchor);
          pose.translation += state.joint_axes[j] * (q[joint.q_index] - joint.reference);
          state.joint_frames[j] = pose.rotation;
          break;
        }
        case JointType::ball: {
          const Eigen::Quaterniond rotation = quat_at(q, joint.q_index);
          if (!(rotation.norm() > 0)) return "joint '" + joint.name + "': zero quaternion";
          const Vec3d anchor = pose.apply(joint.anchor);
          state.joint_anchors[j] = anchor;
          pose.rotation = pose.rotation * rotation.normalized().toRotationMatrix();
          pose.translation = anchor - pose.rotation * joint.anchor;
          state.joint_frames[j] = pose.rotation;
          break;
        }
        case JointType::free: {
          const Eigen::Quaterniond rotation = quat_at(q, joint.q_index + 3);
          if (!(rotation.norm() > 0)) return "joint '" + joint.name + "': zero quaternion";
          pose.translation = Vec3d(q[joint.q_index], q[joint.q_index + 1], q[joint.q_index + 2]);
          pose.rotation = rotation.normalized().toRotationMatrix();
          state.joint_anchors[j] = pose.translation;
          state.joint_frames[j] = pose.rotation;
          break;
        }
      }
    }
    state.links[l] = pose;
  }
  return {};
}

std::vector<double> KinematicTree::integrate(std::span<const double> q, std::span<const double> v,
                                             double dt) const {
  std::vector<double> out(q.begin(), q.end());
  for (const Joint& joint : joints) {
    const int qi = joint.q_index;
    const int vi = joint.v_index;
    switch (joint.type) {
      case JointType::fixed:
        break;
      case JointType::revolute:
      case JointType::continuous:
      case JointType::prismatic:
        out[qi] += v[vi] * dt;
        break;
      case JointType::ball:
      case JointType::free: {
        int rq = qi;
        int rv = vi;
        if (joint.type == JointType::free) {
          for (int k = 0; k < 3; ++k) out[qi + k] += v[vi + k] * dt;
          rq += 3;
          rv += 3;
        }
        const Eigen::Quaterniond next =
            (quat_at(q, rq).normalized() * rotation_exp(Vec3d(v[rv], v[rv + 1], v[rv + 2]) * dt))
                .normalized();
        out[rq] = next.w();
        out[rq + 1] = next.x();
        out[rq + 2] = next.y();
        out[rq + 3] = next.z();
        break;
      }
    }
  }
  return out;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> KinematicTree::jacobian(const KinematicState& state,
                                                                 int link,
                                                                 const Vec3d& origin) const {
  Eigen::Matrix<double, 6, Eigen::Dynamic> jac =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, nv_);
  for (int l = link; l >= 0; l = links[l].parent) {
    for (const int j : links[l].joints) {
      const Joint& joint = joints[j];
      const int v = joint.v_index;
      switch (joint.type) {
        case JointType::fixed:
          break;
        case JointType::revolute:
        case JointType::continuous: {
          const Vec3d& a = state.joint_axes[j];
          jac.col(v).head<3>() = a.cross(origin - state.joint_anchors[j]);
          jac.col(v).tail<3>() = a;
          break;
        }
        case JointType::prismatic:
          jac.col(v).head<3>() = state.joint_axes[j];
          break;
        case JointType::ball:
        case JointType::free: {
          int rv = v;
          if (joint.type == JointType::free) {
            jac.block<3, 3>(0, v).setIdentity();
            rv += 3;
          }
          for (int k = 0; k < 3; ++k) {
            const Vec3d a = state.joint_frames[j].col(k);
            jac.col(rv + k).head<3>() = a.cross(origin - state.joint_anchors[j]);
            jac.col(rv + k).tail<3>() = a;
          }
          break;
        }
      }
    }
  }
  return jac;
}

void KinematicTree::add_joint_gradient(const KinematicState& state, int link, const Vec3d& origin,
                                       const Vec6d& gradient, Eigen::VectorXd& out) const {
  const Vec3d g_t = gradient.head<3>();
  const Vec3d g_r = gradient.tail<3>();
  // Jᵀg column by column: for a rotation about axis a through c, g_t·(a × (o − c)) + g_r·a =
  // a·((o − c) × g_t + g_r).
  for (int l = link; l >= 0; l = links[l].parent) {
    for (const int j : links[l].joints) {
      const Joint& joint = joints[j];
      const int v = joint.v_index;
      switch (joint.type) {
        case JointType::fixed:
          break;
        case JointType::revolute:
        case JointType::continuous:
          out[v] += state.joint_axes[j].dot((origin - state.joint_anchors[j]).cross(g_t) + g_r);
          break;
        case JointType::prismatic:
          out[v] += state.joint_axes[j].dot(g_t);
          break;
        case JointType::ball:
        case JointType::free: {
          int rv = v;
          if (joint.type == JointType::free) {
            out.segment<3>(v) += g_t;
            rv += 3;
          }
          const Vec3d moment = (origin - state.joint_anchors[j]).cross(g_t) + g_r;
          out.segment<3>(rv) += state.joint_frames[j].transpose() * moment;
          break;
        }
      }
    }
  }
}

std::vector<std::string> KinematicTree::limit_violations(std::span<const double> q) const {
  std::vector<std::string> out;
  for (const Joint& joint : joints) {
    if (!joint.limited || joint.nq() != 1 || joint.q_index >= static_cast<int>(q.size())) continue;
    const double value = q[joint.q_index];
    if (value < joint.lower || value > joint.upper) {
      std::ostringstream text;
      text << joint.name << ": q=" << value << " outside [" << joint.lower << ", " << joint.upper
           << "]";
      out.push_back(text.str());
    }
  }
  return out;
}

}  // namespace nearpoint::robots
