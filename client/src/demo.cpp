// SPDX-License-Identifier: Apache-2.0
#include "demo.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <sstream>

#include "local_server.hpp"
#include "nearpoint/scenes/moving_object.hpp"
#include "scene_lease.hpp"

namespace nearpoint::cli {
namespace {

using client::Clock;

constexpr const char* kMover = "object";
constexpr const char* kObstacleIds[5] = {"K1", "K2", "K3", "K4", "K5"};

struct Pass {
  // [obstacle][step]
  std::vector<std::vector<client::PairDistance>> pairs;
  double geometry_us = 0;
  double wall_s = 0;
  double iterations = 0;
  client::Status error;
};

Eigen::Quaterniond rotation_at(const scenes::MovingObjectScene& scene, double s) {
  return scene.rotation_start.slerp(s, scene.rotation_end).normalized();
}

// Streams the path once; `warm` selects warm starts or single-point initialisation.
Pass stream_path(client::Client& client, const std::string& scene_id, int steps, bool warm) {
  Pass pass;
  pass.pairs.assign(5, std::vector<client::PairDistance>(std::size_t(steps) + 1));
  std::mutex mutex;
  client::SessionOptions options;
  options.max_in_flight = 64;
  options.options.warm_start = warm;
  options.reconnect = false;  // a demo run is short: a dropped server is reported, not hidden
  options.on_report = [&](const client::Report& report) {
    std::lock_guard lock(mutex);
    if (!report.error.ok()) {
      if (pass.error.ok()) pass.error = report.error;
      return;
    }
    const std::size_t step = std::size_t(report.sequence - 1);
    for (const client::PairDistance& pair : report.pairs) {
      for (std::size_t k = 0; k < 5; ++k)
        if (pair.object_b == kObstacleIds[k] && step < pass.pairs[k].size())
          pass.pairs[k][step] = pair;
      pass.iterations += pair.iterations;
    }
    pass.geometry_us += report.timing.geometry_us;
  };
  auto session = client.open_session(scene_id, options);
  if (!session) {
    pass.error = session.status();
    return pass;
  }
  const auto start = Clock::now();
  for (int t = 0; t <= steps; ++t) {
    if (interrupt_signal() != 0) break;  // Ctrl-C: run_demo cleans up and exits
    const double s = double(t) / steps;
    auto pushed = (*session)->push({demo_pose(s)}, Clock::now() + std::chrono::seconds(30));
    if (!pushed) {
      pass.error = pushed.status();
      return pass;
    }
  }
  const client::Status closed = (*session)->close(Clock::now() + std::chrono::seconds(60));
  pass.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  std::lock_guard lock(mutex);
  if (pass.error.ok() && !closed.ok()) pass.error = closed;
  pass.iterations /= double(5 * (steps + 1));
  return pass;
}

std::string default_plot_path() {
  std::error_code error;
  const std::filesystem::path here = std::filesystem::current_path(error);
  if (!error && access(here.c_str(), W_OK) == 0) return (here / "demo.svg").string();
  return (std::filesystem::temp_directory_path() / "nearpoint-demo.svg").string();
}

std::string fixed(double value, int digits) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(digits) << value;
  return text.str();
}

void print_human(const DemoResult& r, const std::string& target, bool started_here,
                 std::ostream& out) {
  out << "nearpoint demo: the paper's Section VIII path (Fig. 5) — a two-piece object (K6 ∪ K7)\n"
         "moving along a straight line with a slerp in orientation past five obstacles K1 … K5\n"
      << "server " << target << (started_here ? " (started for this demo)" : "")
      << "; T = " << r.steps << " steps, s = t/T; 5 pairs per pose, streamed with warm starts\n\n";
  out << std::left << std::setw(24) << "obstacle" << std::setw(15) << "min distance" << std::setw(9)
      << "at s"
      << "collisions: [s0, s1] and the largest penetration bound d⁻\n";
  for (const ObstacleProfile& o : r.obstacles) {
    out << std::left << std::setw(24) << o.name << std::setw(15) << fixed(o.min_distance, 6)
        << std::setw(9) << fixed(o.min_s, 3);
    if (o.collisions.empty()) out << "none";
    for (std::size_t i = 0; i < o.collisions.size(); ++i) {
      const CollisionInterval& c = o.collisions[i];
      out << (i ? "; " : "") << "[" << fixed(c.s0, 3) << ", " << fixed(c.s1, 3)
          << "] d⁻ = " << fixed(c.max_penetration_bound, 4);
    }
    out << "\n";
  }
  const double n = r.steps + 1;
  out << "\nTable I (warm start against single-point initialisation), server-side geometry time "
         "for the whole path:\n"
      << "  warm start     " << std::setw(10) << fixed(r.warm_geometry_us, 1) << " µs  ("
      << fixed(r.warm_geometry_us / n, 2) << " µs per pose, " << fixed(r.warm_mean_iterations, 2)
      << " iterations per pair)\n"
      << "  single-point   " << std::setw(10) << fixed(r.cold_geometry_us, 1) << " µs  ("
      << fixed(r.cold_geometry_us / n, 2) << " µs per pose, " << fixed(r.cold_mean_iterations, 2)
      << " iterations per pair)\n"
      << "  ratio          " << fixed(r.cold_geometry_us / std::max(r.warm_geometry_us, 1e-9), 2)
      << "×   (the paper: 1.7×, 2.9×, 3.1× at T = 10, 100, 1000)\n"
      << "  wall time      warm " << fixed(r.warm_wall_s, 3) << " s, single-point "
      << fixed(r.cold_wall_s, 3)
      << " s (round trips over gRPC included, which dwarf the geometry)\n";
  out << (r.warm_cold_agree ? "  warm and single-point distances agree within their error bounds"
                            : "  WARNING: warm and single-point distances differ beyond their "
                              "error bounds")
      << " (largest difference " << r.max_warm_cold_difference << ")\n";
  if (!r.plot_path.empty())
    out << "\nplot of the five distance curves (Fig. 6): " << r.plot_path << "\n";
}

Json to_json(const DemoResult& r, const std::string& target) {
  Json out;
  out["target"] = target;
  out["steps"] = r.steps;
  Json obstacles = Json::array();
  for (const ObstacleProfile& o : r.obstacles) {
    Json collisions = Json::array();
    for (const CollisionInterval& c : o.collisions)
      collisions.push_back(
          {{"s0", c.s0}, {"s1", c.s1}, {"max_penetration_bound", c.max_penetration_bound}});
    obstacles.push_back({{"object_id", o.object_id},
                         {"name", o.name},
                         {"min_distance", o.min_distance},
                         {"min_s", o.min_s},
                         {"collisions", collisions}});
  }
  out["obstacles"] = obstacles;
  out["table1"] = {{"warm_geometry_us", r.warm_geometry_us},
                   {"single_point_geometry_us", r.cold_geometry_us},
                   {"ratio", r.cold_geometry_us / std::max(r.warm_geometry_us, 1e-9)},
                   {"warm_wall_s", r.warm_wall_s},
                   {"single_point_wall_s", r.cold_wall_s},
                   {"warm_mean_iterations", r.warm_mean_iterations},
                   {"single_point_mean_iterations", r.cold_mean_iterations}};
  out["warm_cold_agree"] = r.warm_cold_agree;
  out["max_warm_cold_difference"] = r.max_warm_cold_difference;
  if (!r.plot_path.empty()) out["plot"] = r.plot_path;
  return out;
}

}  // namespace

client::ObjectPose demo_pose(double s) {
  static const scenes::MovingObjectScene scene = scenes::moving_object_scene();
  const Eigen::Vector3d p = (1 - s) * scene.translation_start + s * scene.translation_end;
  return client::ObjectPose(kMover, rotation_at(scene, s), p);
}

client::Expected<std::string> create_demo_scene(client::Client& client) {
  const scenes::MovingObjectScene scene = scenes::moving_object_scene();
  client::Geometry mover;
  mover.name = "moving object K6 + K7";
  for (const auto& vertices : scene.object_piece_vertices)
    mover.pieces.push_back(client::polytope_piece(vertices));
  auto mover_info = client.register_geometry(mover);
  if (!mover_info) return mover_info.status();
  client::Scene definition;
  definition.name = "nearpoint demo: Section VIII moving object";
  definition.default_options.penetration = client::PenetrationMode::bound;
  definition.objects.push_back(
      {kMover,
       mover_info->geometry_id,
       client::to_pose_input(rotation_at(scene, 0), scene.translation_start),
       {},
       {}});
  definition.pair_selection.mode = client::PairSelection::Mode::listed_pairs;
  for (std::size_t k = 0; k < 5; ++k) {
    client::Geometry obstacle;
    obstacle.name = scene.obstacle_names[k];
    obstacle.pieces.push_back(client::polytope_piece(scene.obstacle_vertices[k]));
    auto info = client.register_geometry(obstacle);
    if (!info) return info.status();
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = scene.obstacle_poses[k].rotation;
    pose.translation() = scene.obstacle_poses[k].translation;
    definition.objects.push_back(
        {kObstacleIds[k], info->geometry_id, client::to_pose_input(pose), {}, {}});
    definition.pair_selection.pairs.emplace_back(kMover, kObstacleIds[k]);
  }
  auto created = client.create_scene(definition);
  if (!created) return created.status();
  return created->scene_id;
}

std::string distance_plot_svg(const DemoResult& r) {
  constexpr double kWidth = 960, kHeight = 540, kLeft = 70, kRight = 200, kTop = 50, kBottom = 60;
  constexpr const char* kColours[5] = {"#1f77b4", "#ff7f0e", "#d62728", "#2ca02c", "#9467bd"};
  const double plot_w = kWidth - kLeft - kRight, plot_h = kHeight - kTop - kBottom;
  double top = 0;
  for (const ObstacleProfile& o : r.obstacles)
    for (double d : o.distances) top = std::max(top, d);
  top = std::max(1.0, std::ceil(top));
  auto x = [&](double s) { return kLeft + s * plot_w; };
  auto y = [&](double d) { return kTop + plot_h * (1 - d / top); };
  std::ostringstream svg;
  svg << std::fixed << std::setprecision(2);
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kWidth << "\" height=\"" << kHeight
      << "\" font-family=\"sans-serif\" font-size=\"13\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << kLeft
      << "\" y=\"28\" font-size=\"16\">Distance from the moving object "
         "to each obstacle along the path (T = "
      << r.steps << ")</text>\n";
  // Collision intervals, shaded per obstacle in its colour.
  for (std::size_t k = 0; k < r.obstacles.size(); ++k)
    for (const CollisionInterval& c : r.obstacles[k].collisions)
      svg << "<rect x=\"" << x(c.s0) << "\" y=\"" << kTop << "\" width=\""
          << std::max(1.0, x(c.s1) - x(c.s0)) << "\" height=\"" << plot_h << "\" fill=\""
          << kColours[k % 5] << "\" opacity=\"0.12\"/>\n";
  // Axes, ticks and grid.
  svg << "<g stroke=\"#888\" stroke-width=\"1\">\n";
  for (int i = 0; i <= 5; ++i) {
    const double s = i / 5.0, d = top * i / 5.0;
    svg << "<line x1=\"" << x(s) << "\" y1=\"" << kTop << "\" x2=\"" << x(s) << "\" y2=\""
        << kTop + plot_h << "\" stroke=\"#eee\"/>\n"
        << "<line x1=\"" << kLeft << "\" y1=\"" << y(d) << "\" x2=\"" << kLeft + plot_w
        << "\" y2=\"" << y(d) << "\" stroke=\"#eee\"/>\n";
  }
  svg << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << plot_w << "\" height=\""
      << plot_h << "\" fill=\"none\"/>\n</g>\n";
  for (int i = 0; i <= 5; ++i) {
    const double s = i / 5.0, d = top * i / 5.0;
    svg << "<text x=\"" << x(s) << "\" y=\"" << kTop + plot_h + 18 << "\" text-anchor=\"middle\">"
        << std::setprecision(1) << s << "</text>\n"
        << "<text x=\"" << kLeft - 8 << "\" y=\"" << y(d) + 4 << "\" text-anchor=\"end\">"
        << std::setprecision(2) << d << "</text>\n";
  }
  svg << "<text x=\"" << kLeft + plot_w / 2 << "\" y=\"" << kHeight - 18
      << "\" text-anchor=\"middle\">s = t/T</text>\n"
      << "<text x=\"20\" y=\"" << kTop + plot_h / 2 << "\" transform=\"rotate(-90 20 "
      << kTop + plot_h / 2 << ")\" text-anchor=\"middle\">distance</text>\n";
  // The curves.
  for (std::size_t k = 0; k < r.obstacles.size(); ++k) {
    const ObstacleProfile& o = r.obstacles[k];
    svg << "<polyline fill=\"none\" stroke=\"" << kColours[k % 5]
        << "\" stroke-width=\"1.8\" points=\"";
    for (std::size_t t = 0; t < o.distances.size(); ++t)
      svg << x(double(t) / std::max(1, r.steps)) << "," << y(o.distances[t]) << " ";
    svg << "\"/>\n";
    const double ly = kTop + 20 + 22 * double(k);
    svg << "<line x1=\"" << kWidth - kRight + 15 << "\" y1=\"" << ly << "\" x2=\""
        << kWidth - kRight + 40 << "\" y2=\"" << ly << "\" stroke=\"" << kColours[k % 5]
        << "\" stroke-width=\"3\"/>\n"
        << "<text x=\"" << kWidth - kRight + 46 << "\" y=\"" << ly + 4 << "\">" << o.name
        << "</text>\n";
  }
  svg << "<text x=\"" << kWidth - kRight + 15 << "\" y=\"" << kTop + 20 + 22 * 5 + 10
      << "\" font-size=\"11\" fill=\"#555\">shaded: distance 0</text>\n</svg>\n";
  return svg.str();
}

int run_demo(const DemoOptions& options, std::ostream& out, std::ostream& err) {
  if (options.steps < 1 || options.steps > 1'000'000) {
    err << "nearpoint demo: --steps must be in [1, 1000000]\n";
    return kExitBadInput;
  }
  const int steps = options.steps;
  install_interrupt_handlers();
  LocalServer local;
  std::string target = options.target;
  if (target.empty()) {
    const std::string binary = find_nearpointd(options.nearpointd);
    if (std::string error = local.start(binary, 0, {}); !error.empty()) {
      err << "nearpoint demo: " << error << "\n";
      return kExitUnreachable;
    }
    target = local.target();
    if (!options.json) err << "== started " << binary << " on " << target << "\n";
  }

  auto client = client::Client::connect(target);
  auto created = create_demo_scene(*client);
  if (!created) {
    err << "nearpoint demo: setting up the scene on " << target << ": "
        << created.status().describe() << "\n";
    return exit_code_for(created.status());
  }
  const std::string scene_id = *created;
  // A server of our own goes away with its scenes; on a --target server the scene is deleted.
  SceneLease lease(*client, scene_id, !options.target.empty(), options.keep_scene, "nearpoint demo",
                   err);

  if (!options.json)
    err << "== streaming " << steps + 1
        << " poses with warm starts, then with single-point starts\n";
  const Pass warm = stream_path(*client, scene_id, steps, true);
  const Pass cold = warm.error.ok() && interrupt_signal() == 0
                        ? stream_path(*client, scene_id, steps, false)
                        : Pass{};
  if (interrupt_signal() != 0) {
    err << "nearpoint demo: interrupted\n";
    return interrupted_exit_code();
  }
  for (const Pass* pass : {&warm, &cold}) {
    if (!pass->error.ok()) {
      err << "nearpoint demo: streaming the path: " << pass->error.describe() << "\n";
      return exit_code_for(pass->error);
    }
  }

  const scenes::MovingObjectScene scene = scenes::moving_object_scene();
  DemoResult result;
  result.steps = steps;
  result.warm_geometry_us = warm.geometry_us;
  result.cold_geometry_us = cold.geometry_us;
  result.warm_wall_s = warm.wall_s;
  result.cold_wall_s = cold.wall_s;
  result.warm_mean_iterations = warm.iterations;
  result.cold_mean_iterations = cold.iterations;
  for (std::size_t k = 0; k < 5; ++k) {
    ObstacleProfile profile;
    profile.name = scene.obstacle_names[k];
    profile.object_id = kObstacleIds[k];
    profile.min_distance = std::numeric_limits<double>::infinity();
    bool inside = false;
    for (int t = 0; t <= steps; ++t) {
      const double s = double(t) / steps;
      const client::PairDistance& pair = warm.pairs[k][std::size_t(t)];
      const client::PairDistance& other = cold.pairs[k][std::size_t(t)];
      const double difference = std::abs(pair.distance - other.distance);
      result.max_warm_cold_difference = std::max(result.max_warm_cold_difference, difference);
      if (difference > pair.error_bound + other.error_bound) result.warm_cold_agree = false;
      profile.distances.push_back(pair.distance);
      if (pair.distance < profile.min_distance) {
        profile.min_distance = pair.distance;
        profile.min_s = s;
      }
      const bool hit = model::in_contact(pair.status);
      if (hit && !inside) profile.collisions.push_back({s, s, 0});
      if (hit) {
        profile.collisions.back().s1 = s;
        profile.collisions.back().max_penetration_bound =
            std::max(profile.collisions.back().max_penetration_bound,
                     pair.has_penetration_bound ? pair.penetration_bound : 0.0);
      }
      inside = hit;
    }
    result.obstacles.push_back(std::move(profile));
  }

  if (options.plot_path != "-") {
    result.plot_path = options.plot_path.empty() ? default_plot_path() : options.plot_path;
    std::ofstream plot(result.plot_path, std::ios::trunc);
    if (!(plot << distance_plot_svg(result))) {
      err << "nearpoint demo: cannot write the plot to " << result.plot_path << "\n";
      result.plot_path.clear();
    }
  }
  if (options.json)
    out << to_json(result, target).dump() << "\n";
  else
    print_human(result, target, local.running(), out);
  if (local.running()) {
    const int status = local.stop();
    if (!options.json) err << "== nearpointd stopped (exit status " << status << ")\n";
  }
  return out ? 0 : kExitBadInput;
}

}  // namespace nearpoint::cli
