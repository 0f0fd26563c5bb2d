// SPDX-License-Identifier: Apache-2.0
// `nearpoint demo`: the paper's Section VIII experiment against a server. The moving object of
// Fig. 5 (two convex pieces) passes five obstacles along a straight line with a slerp in
// orientation (scenes/include/nearpoint/scenes/moving_object.hpp, the scene of bench's Table I);
// the path is streamed at T + 1 poses s = t/T, twice: with warm starts and with single-point
// (cold) starts. Printed: per obstacle the distance profile (minimum and where), the collision
// intervals with the largest penetration bound d⁻ inside, the warm/cold time ratio (Table I), and
// an SVG plot of the five distance curves (Fig. 6).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "remote_common.hpp"

namespace nearpoint::cli {

struct DemoOptions {
  /// Empty: start a nearpointd child on 127.0.0.1:0 (found by find_nearpointd(nearpointd)).
  std::string target;
  std::string nearpointd;
  int steps = 1000;
  /// Where to write the SVG plot; empty: demo.svg in the working directory (or the temporary
  /// directory when that is not writable). "-": no plot.
  std::string plot_path;
  bool json = false;
  /// With --target: keep the demo scene on that server rather than delete it at the end.
  bool keep_scene = false;
};

struct CollisionInterval {
  double s0 = 0, s1 = 0;
  /// The largest d⁻ (penetration lower bound, eq. 32–33) over the interval's steps.
  double max_penetration_bound = 0;
};

struct ObstacleProfile {
  std::string name;       // "K1 box", …
  std::string object_id;  // "K1", …
  double min_distance = 0;
  double min_s = 0;
  std::vector<CollisionInterval> collisions;
  std::vector<double> distances;  // at s = t/T, t = 0 … T
};

struct DemoResult {
  int steps = 0;
  std::vector<ObstacleProfile> obstacles;
  /// Server-side geometry time summed over the path (ReportTiming.geometry_us), and wall time.
  double warm_geometry_us = 0, cold_geometry_us = 0;
  double warm_wall_s = 0, cold_wall_s = 0;
  double warm_mean_iterations = 0, cold_mean_iterations = 0;
  /// max over steps and pairs of |d_warm − d_cold| and of the bound it must stay within.
  double max_warm_cold_difference = 0;
  bool warm_cold_agree = true;
  std::string plot_path;
};

/// Registers the demo scene's six geometries and creates its scene (object "object", obstacles
/// "K1" … "K5", the five pairs (object, Ki), penetration bounds on). Returns the scene id.
client::Expected<std::string> create_demo_scene(client::Client& client);
/// The moving object's pose at s ∈ [0, 1] (the scene's pose_at, as an ObjectPose).
client::ObjectPose demo_pose(double s);

/// Runs the demo; prints to `out` (human or JSON), progress and problems to `err`. Exit code.
int run_demo(const DemoOptions& options, std::ostream& out, std::ostream& err);

/// The SVG of the distance curves (Fig. 6): one polyline per obstacle against s, collision
/// intervals shaded. Our own small writer; no dependency.
std::string distance_plot_svg(const DemoResult& result);

}  // namespace nearpoint::cli
