// SPDX-License-Identifier: Apache-2.0
// sensor_msgs/JointState in (`nearpointd --dds --dds-joint-states SCENE[=TOPIC]`): the binding of a
// ROS 2 joint-state topic (rt/joint_states by default) to a scene, and the decoding of a
// JointState sample into joint positions by name, checked before anything uses them.
//
// The bridge subscribes each binding's topic and answers every JointState with a DistanceReport
// on <prefix>distance_reports (scene_id = the bound scene, client_id "joint_states", the
// JointState's header echoed, writer_guid = its writer, sequence numbers counted per writer from
// 1), through the same stream path as a PoseUpdate: the scene API applies the positions to the
// scene's robot (model::PoseUpdateInput::joints); a scene without a robot is answered
// FAILED_PRECONDITION naming "joints".
#pragma once

#include <string>
#include <vector>

#include "dds_bridge.hpp"
#include "nearpoint/server/errors.hpp"
#include "nearpoint_ros.h"

namespace nearpoint::server {

inline constexpr const char* kJointStatesClientId = "joint_states";

/// Joint positions by name, as a JointState carries them.
struct JointPositions {
  std::vector<std::string> names;
  std::vector<double> positions;
};

/// The sample's names and positions, or INVALID_ARGUMENT naming the field ("joint_states.name[2]"
/// for an empty, over-long or repeated name; "joint_states.position" when the counts differ;
/// "joint_states.position[1]" for a value that is not finite). Velocities and efforts are not
/// read (distances depend on positions only).
Expected<JointPositions> decode_joint_state(const sensor_msgs_msg_dds__JointState_& sample);

}  // namespace nearpoint::server
