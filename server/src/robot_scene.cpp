// SPDX-License-Identifier: Apache-2.0
#include "robot_scene.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

#include "nearpoint/server/scene_service.hpp"
#include "report_size.hpp"
#include "validation.hpp"

namespace nearpoint::server {
namespace {

robots::JointType to_tree_type(model::JointType type) {
  switch (type) {
    case model::JointType::revolute:
      return robots::JointType::revolute;
    case model::JointType::continuous:
      return robots::JointType::continuous;
    case model::JointType::prismatic:
      return robots::JointType::prismatic;
    case model::JointType::ball:
      return robots::JointType::ball;
    case model::JointType::free:
      return robots::JointType::free;
    default:
      return robots::JointType::fixed;
  }
}

bool finite(const Vec3<double>& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

}  // namespace

Expected<std::shared_ptr<const SceneRobot>> build_scene_robot(const model::RobotInput& input,
                                                              const SceneDefinition& scene) {
  auto robot = std::make_shared<SceneRobot>();
  robot->name = input.name;
  if (auto error = check_name(input.name, "robot.name")) return *error;
  if (input.links.empty()) return invalid_argument("robot.links", "a robot needs a link");
  std::unordered_map<std::string, int> link_index;
  std::unordered_set<std::string> joint_names;
  robots::KinematicTree& tree = robot->tree;
  for (std::size_t l = 0; l < input.links.size(); ++l) {
    const model::RobotLinkInput& in = input.links[l];
    const std::string field = text("robot.links[", l, ']');
    if (auto error = check_id(in.name, field + ".name")) return *error;
    if (!link_index.emplace(in.name, int(l)).second)
      return invalid_argument(field + ".name", text("link ", quoted(in.name), " is listed twice"));
    robots::Link link;
    link.name = in.name;
    if (!in.parent.empty()) {
      const auto parent = link_index.find(in.parent);
      if (parent == link_index.end() || parent->second == int(l))
        return invalid_argument(field + ".parent",
                                text("no link ", quoted(in.parent), " listed before this one"));
      link.parent = parent->second;
    }
    Expected<Pose<double>> offset = check_pose(in.offset, field + ".offset");
    if (!offset) return offset.error();
    link.offset = offset.value();
    for (std::size_t k = 0; k < in.joints.size(); ++k) {
      const model::RobotJointInput& j = in.joints[k];
      const std::string joint_field = text(field, ".joints[", k, ']');
      if (auto error = check_id(j.name, joint_field + ".name")) return *error;
      if (!joint_names.insert(j.name).second)
        return invalid_argument(joint_field + ".name",
                                text("joint ", quoted(j.name), " is named twice"));
      if (j.type == model::JointType::unspecified || j.type == model::JointType::unknown)
        return invalid_argument(joint_field + ".type", "unspecified or unknown JointType");
      if (!finite(j.axis) || !finite(j.anchor) || !std::isfinite(j.reference))
        return invalid_argument(joint_field, "axis, anchor and reference must be finite");
      if (j.limited && !(std::isfinite(j.lower) && std::isfinite(j.upper) && j.lower <= j.upper))
        return invalid_argument(
            joint_field + ".lower",
            text("limits must be finite with lower <= upper, got [", j.lower, ", ", j.upper, ']'));
      robots::Joint joint;
      joint.name = j.name;
      joint.type = to_tree_type(j.type);
      joint.link = int(l);
      joint.axis = j.axis;
      joint.anchor = j.anchor;
      joint.reference = j.reference;
      joint.limited = j.limited;
      joint.lower = j.lower;
      joint.upper = j.upper;
      link.joints.push_back(int(tree.joints.size()));
      tree.joints.push_back(std::move(joint));
    }
    tree.links.push_back(std::move(link));
  }
  if (const std::string why = tree.finalize(); !why.empty())
    return invalid_argument("robot.links", why);

  robot->object_link.assign(scene.objects.size(), -1);
  robot->object_offset.assign(scene.objects.size(), robots::Pose3d{});
  for (std::size_t a = 0; a < input.attachments.size(); ++a) {
    const model::RobotAttachmentInput& in = input.attachments[a];
    const std::string field = text("robot.attachments[", a, ']');
    const std::int64_t object = scene.find_object(in.object_id);
    if (object < 0)
      return not_found(field + ".object_id",
                       text("no object ", quoted(in.object_id), " in the scene"));
    if (robot->object_link[object] >= 0)
      return invalid_argument(field + ".object_id",
                              text("object ", quoted(in.object_id), " is attached twice"));
    const auto link = link_index.find(in.link);
    if (link == link_index.end())
      return not_found(field + ".link", text("no link ", quoted(in.link), " in the robot"));
    Expected<Pose<double>> offset = check_pose(in.offset, field + ".offset");
    if (!offset) return offset.error();
    robot->object_link[object] = link->second;
    robot->object_offset[object] = offset.value();
  }

  for (std::size_t j = 0; j < tree.joints.size(); ++j)
    robot->joint_by_name.emplace(tree.joints[j].name, std::uint32_t(j));
  robot->coordinates.resize(std::size_t(tree.nv()));
  std::size_t longest = 0;
  for (std::size_t j = 0; j < tree.joints.size(); ++j) {
    const robots::Joint& joint = tree.joints[j];
    for (int c = 0; c < joint.nv(); ++c)
      robot->coordinates[std::size_t(joint.v_index + c)] = {std::uint32_t(j), std::uint32_t(c)};
    longest = std::max(longest, joint.name.size());
  }
  // A pair's gradient names the coordinates on its two objects' chains: at most twice the
  // longest chain's (a humanoid's limb, not the whole forest of 100 humanoids).
  std::vector<std::size_t> chain(tree.links.size(), 0);
  std::size_t longest_chain = 0;
  for (std::size_t l = 0; l < tree.links.size(); ++l) {
    const robots::Link& link = tree.links[l];
    chain[l] = link.parent >= 0 ? chain[std::size_t(link.parent)] : 0;
    for (const int j : link.joints) chain[l] += std::size_t(tree.joints[std::size_t(j)].nv());
    longest_chain = std::max(longest_chain, chain[l]);
  }
  const std::size_t entries = std::min(std::size_t(tree.nv()), 2 * longest_chain);
  robot->gradient_bytes_per_pair =
      entries * report_size::joint_derivative_entry(longest) + report_size::kJointGradientLength;
  std::size_t limited = 0;
  for (const robots::Joint& joint : tree.joints) limited += joint.limited && joint.nq() == 1;
  robot->violation_bytes = limited * report_size::joint_limit_entry(longest);
  return std::shared_ptr<const SceneRobot>(std::move(robot));
}

RobotPosition initial_position(const SceneRobot& robot) {
  return RobotPosition{robot.tree.neutral(), Pose<double>{}};
}

Expected<std::shared_ptr<const RobotUpdate>> apply_joint_positions(
    const SceneDefinition& scene, const RobotPosition& previous,
    const model::JointPositionsInput& joints, std::vector<Pose<double>>& poses,
    const std::string& field) {
  if (!scene.robot)
    return Error{ErrorCode::failed_precondition, field,
                 text("scene ", quoted(scene.id),
                      " has no robot: move its objects by their poses (CreateSceneRequest.robot "
                      "makes a scene whose links take joint positions)")};
  const SceneRobot& robot = *scene.robot;
  const robots::KinematicTree& tree = robot.tree;
  auto update = std::make_shared<RobotUpdate>();
  update->position = previous;
  std::vector<double>& q = update->position.q;
  std::vector<char> named(tree.joints.size(), 0);
  std::size_t at = 0;
  for (std::size_t i = 0; i < joints.names.size(); ++i) {
    const std::string& name = joints.names[i];
    const std::string name_field = text(field, ".names[", i, ']');
    const auto found = robot.joint_by_name.find(name);
    const int j = found == robot.joint_by_name.end() ? -1 : int(found->second);
    if (j < 0)
      return invalid_argument(
          name_field, text("no joint ", quoted(name), " in robot ", quoted(robot.name), " (",
                           tree.joints.size(), " joints)"));
    if (named[std::size_t(j)]++)
      return invalid_argument(name_field, text("joint ", quoted(name), " is named twice"));
    const robots::Joint& joint = tree.joints[std::size_t(j)];
    if (joint.nq() == 0)
      return invalid_argument(name_field, text("joint ", quoted(name), " is fixed: no position"));
    if (at + std::size_t(joint.nq()) > joints.positions.size())
      return invalid_argument(field + ".positions",
                              text("has ", joints.positions.size(), " values; the names up to ",
                                   quoted(name), " need ", at + std::size_t(joint.nq()),
                                   " (1 per one-dof joint, 4 per ball joint, "
                                   "7 per free joint)"));
    for (int c = 0; c < joint.nq(); ++c) {
      const double value = joints.positions[at + std::size_t(c)];
      if (!std::isfinite(value))
        return invalid_argument(
            text(field, ".positions[", at + std::size_t(c), ']'),
            text("joint ", quoted(name), ": position must be finite, got ", value));
      q[std::size_t(joint.q_index + c)] = value;
    }
    at += std::size_t(joint.nq());
  }
  if (at != joints.positions.size())
    return invalid_argument(field + ".positions",
                            text("has ", joints.positions.size(), " values; the ",
                                 joints.names.size(), " names take ", at));
  if (joints.base_pose) {
    Expected<Pose<double>> base = check_pose(*joints.base_pose, field + ".base_pose");
    if (!base) return base.error();
    update->position.base = base.value();
  }
  if (const std::string why = tree.forward(q, update->state); !why.empty())
    return invalid_argument(field + ".positions", why);
  for (const robots::Joint& joint : tree.joints) {
    if (!joint.limited || joint.nq() != 1) continue;
    const double value = q[std::size_t(joint.q_index)];
    if (value < joint.lower || value > joint.upper)
      update->violations.push_back({joint.name, value, joint.lower, joint.upper});
  }
  const Pose<double>& base = update->position.base;
  for (std::size_t o = 0; o < robot.object_link.size(); ++o) {
    const int link = robot.object_link[o];
    if (link < 0) continue;
    poses[o] = base.compose(update->state.links[std::size_t(link)].compose(robot.object_offset[o]));
  }
  return std::shared_ptr<const RobotUpdate>(std::move(update));
}

void add_joint_gradients(const SceneDefinition& scene, const RobotUpdate& update, Report& report) {
  const SceneRobot& robot = *scene.robot;
  const robots::KinematicTree& tree = robot.tree;
  // The engine's gradients are in the world frame, about each object's origin; the kinematics
  // are in the robot's base frame. Jᵀg is the same number with both in the base frame.
  const Mat3<double> to_base = update.position.base.rotation.transpose();
  report.joint_gradients.assign(report.pairs.size(), {});
  Eigen::VectorXd gradient(tree.nv());
  std::vector<char> moves(tree.joints.size(), 0);
  for (std::size_t i = 0; i < report.pairs.size(); ++i) {
    const model::PairReport& pair = report.pairs[i];
    if (!pair.has_gradient) continue;
    const int link_a = robot.object_link[pair.object_a];
    const int link_b = robot.object_link[pair.object_b];
    if (link_a < 0 && link_b < 0) continue;
    gradient.setZero();
    std::fill(moves.begin(), moves.end(), 0);
    auto add = [&](int link, std::uint32_t object, const Eigen::Matrix<double, 6, 1>& g) {
      if (link < 0) return;
      // A joint on both objects' chains moves the pair rigidly: its derivative is exactly 0.
      for (int l = link; l >= 0; l = tree.links[std::size_t(l)].parent)
        for (const int j : tree.links[std::size_t(l)].joints) moves[std::size_t(j)] ^= 1;
      robots::Vec6d local;
      local << to_base * g.head<3>(), to_base * g.tail<3>();
      const Vec3<double> origin =
          update.state.links[std::size_t(link)].apply(robot.object_offset[object].translation);
      tree.add_joint_gradient(update.state, link, origin, local, gradient);
    };
    add(link_a, pair.object_a, pair.gradient_a);
    add(link_b, pair.object_b, pair.gradient_b);
    std::vector<std::pair<std::uint32_t, double>>& out = report.joint_gradients[i];
    for (std::size_t v = 0; v < robot.coordinates.size(); ++v)
      if (moves[robot.coordinates[v].first])
        out.emplace_back(std::uint32_t(v), gradient[Eigen::Index(v)]);
  }
}

}  // namespace nearpoint::server
