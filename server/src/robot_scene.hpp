// SPDX-License-Identifier: Apache-2.0
// Robot scenes (CreateSceneRequest.robot): a kinematic forest whose links carry some of the
// scene's objects. An update may give joint positions by name instead of those objects' poses;
// the forward kinematics (nearpoint::kinematics, double) place the objects, and the evaluation
// runs as for any pose update. With gradients, each reported pair gets ∂d/∂q by the chain rule.
//
// Transport-neutral: PoseStream::prepare (model::PoseUpdateInput::joints) and SceneService::query
// (model::QueryInput::joints) call apply_joint_positions; the gRPC adapter fills those fields from
// nearpoint.v1.JointPositions, and any other transport (a DDS JointState topic) fills the same
// fields and calls the same two entry points.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "nearpoint/robots/kinematics.hpp"
#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/report.hpp"

namespace nearpoint::server {

class SceneDefinition;

/// A scene's robot, immutable once the scene exists.
struct SceneRobot {
  std::string name;
  robots::KinematicTree tree;
  /// Per scene object: the link that carries it (-1: none; the object moves by pose updates),
  /// and the link frame → geometry frame offset.
  std::vector<int> object_link;
  std::vector<robots::Pose3d> object_offset;
  /// Joint index by name (updates name joints; a linear search per name would cost a
  /// 600-joint forest 360,000 string comparisons per update).
  std::unordered_map<std::string, std::uint32_t> joint_by_name;
  /// Per velocity coordinate (gradient entry): its joint's index and the coordinate within it.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> coordinates;
  /// Report size bounds (report_size.hpp's style): the most a pair's joint gradient and a
  /// report's limit violations take on the wire.
  std::size_t gradient_bytes_per_pair = 0;
  std::size_t violation_bytes = 0;
};

/// Where a robot is: its joint positions (the tree's q layout) and its base pose (base → world).
struct RobotPosition {
  std::vector<double> q;
  Pose<double> base;
};

/// One update's robot state: the positions, the forward kinematics in the base frame, and the
/// joints outside their limits.
struct RobotUpdate {
  RobotPosition position;
  robots::KinematicState state;
  std::vector<model::JointLimitViolation> violations;
};

/// The scene's robot from the request, its attachments resolved against the scene's objects
/// (`scene.objects` and `index_by_id` filled). Errors name "robot.links[i]…",
/// "robot.attachments[i]…".
Expected<std::shared_ptr<const SceneRobot>> build_scene_robot(const model::RobotInput& input,
                                                              const SceneDefinition& scene);

/// Every joint at its reference position, the base at the identity (where streams start).
RobotPosition initial_position(const SceneRobot& robot);

/// THE joint-position entry point: `joints` applied on top of `previous` (joints not named keep
/// their positions, an absent base pose keeps the base), the forward kinematics run, and the
/// pose of every object the robot carries written into `poses` (scene object order). Errors are
/// INVALID_ARGUMENT naming `field` + ".names[i]" (an unknown, repeated or fixed joint),
/// ".positions" (a count that does not match, a non-finite value, a zero quaternion) or
/// ".base_pose"; nothing is changed then. A scene without a robot: FAILED_PRECONDITION.
Expected<std::shared_ptr<const RobotUpdate>> apply_joint_positions(
    const SceneDefinition& scene, const RobotPosition& previous,
    const model::JointPositionsInput& joints, std::vector<Pose<double>>& poses,
    const std::string& field);

/// Fills `report.joint_gradients` (one entry per reported pair with a gradient whose objects a
/// link carries) from the pairs' pose gradients and `update`'s kinematics.
void add_joint_gradients(const SceneDefinition& scene, const RobotUpdate& update, Report& report);

}  // namespace nearpoint::server
