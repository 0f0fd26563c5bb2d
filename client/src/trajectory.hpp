// Trajectories for `nearpoint stream`: the poses of scene objects over time, read from a file.
//
//   JSON Lines, one step per line (blank lines skipped; "rotation" and "translation" optional):
//     {"t": 0.0, "poses": {"OBJ": {"rotation": [w,x,y,z], "translation": [x,y,z]}, ...}}
//   CSV: the header t,object,tx,ty,tz,qw,qx,qy,qz, then one row per object pose; consecutive
//     rows with equal t form one step.
// The format is chosen by the extension: .csv is CSV, anything else JSON Lines. Units: seconds,
// metres; rotation a unit quaternion (w, x, y, z), geometry frame -> world frame.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace nearpoint::cli {

struct ObjectPose {
  std::string object_id;
  std::array<double, 4> rotation_wxyz{1, 0, 0, 0};
  std::array<double, 3> translation{0, 0, 0};
};

struct TrajectoryStep {
  double time = 0;
  std::vector<ObjectPose> poses;
};

struct Trajectory {
  std::vector<TrajectoryStep> steps;
};

/// Reads `path` into `out`. Returns false and a message naming the line on malformed input
/// (not JSON, a missing or non-numeric field, a non-finite number, a wrong array length, a
/// time going backwards, an object listed twice in one step).
bool load_trajectory(const std::string& path, Trajectory& out, std::string& error);

}  // namespace nearpoint::cli
