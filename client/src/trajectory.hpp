// SPDX-License-Identifier: Apache-2.0
// Trajectory files for `nearpoint stream` (and any other client that replays poses over time):
// a sequence of steps, each a time and the poses of the objects that move at that step.
//
// Two formats, chosen by content (a first non-blank line starting with '{' is JSON Lines):
//   JSON Lines, one step per line:
//     {"t": 0.0, "poses": {"OBJ": {"rotation": [w,x,y,z], "translation": [x,y,z]}, ...}}
//     "rotation" and "translation" are each optional (identity / zero); "t" is optional and then
//     the line's index. Blank lines are skipped.
//   Robot scenes (`nearpoint stream --joints`): joint positions by name instead of (or beside)
//   poses, and optionally the robot's base pose:
//     {"t": 0.0, "joints": {"joint1": 0.3, "joint2": -1.2, "ball": [w,x,y,z]},
//      "base": {"rotation": [w,x,y,z], "translation": [x,y,z]}}
//     A joint's value is a number (revolute, prismatic: radians, metres) or an array (ball: 4
//     values, free: 7). Joints not named keep their previous positions.
//   CSV with the header  t,object,tx,ty,tz,qw,qx,qy,qz  (columns in that order); consecutive rows
//     with equal t form one step. Blank lines and lines starting with '#' are skipped.
// Units: seconds for t (any monotone parameter works), metres; quaternions (w, x, y, z), checked
// for unit length within 1e-4 as the server does. Times must not decrease.
#pragma once

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace nearpoint::cli {

/// One object's pose at one step: geometry frame → world frame.
struct ObjectPose {
  std::string object_id;
  std::array<double, 4> rotation_wxyz{1, 0, 0, 0};
  std::array<double, 3> translation{0, 0, 0};
};

/// The poses that change at time `time`; objects not listed keep their previous pose.
struct TrajectoryStep {
  double time = 0;
  std::vector<ObjectPose> poses;
  /// Robot scenes: joint positions by name, in the order given, and the base pose (has_base).
  std::vector<std::pair<std::string, std::vector<double>>> joints;
  bool has_base = false;
  ObjectPose base;
};

struct Trajectory {
  std::vector<TrajectoryStep> steps;
};

// JSON Lines: {"t": 0.0, "poses": {"OBJ": {"rotation": [w,x,y,z], "translation": [x,y,z]}, ...}}
// CSV: header t,object,tx,ty,tz,qw,qx,qy,qz; rows with equal t form one step.
// Returns false and a message naming the line on malformed input.
bool load_trajectory(const std::string& path, Trajectory& out, std::string& error);

/// The same from text already in memory; `name` stands for the file in messages.
bool parse_trajectory(const std::string& text, const std::string& name, Trajectory& out,
                      std::string& error);

}  // namespace nearpoint::cli
