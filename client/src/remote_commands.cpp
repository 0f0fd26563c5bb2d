// SPDX-License-Identifier: Apache-2.0
#include "remote_commands.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "demo.hpp"
#include "load_driver.hpp"
#include "local_server.hpp"
#include "nearpoint/model/percentile.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "scene_lease.hpp"
#include "trajectory.hpp"
#ifdef NEARPOINT_WITH_ROBOTS
#include "nearpoint/robots/robot.hpp"
#endif

namespace nearpoint::cli {
namespace {

using client::Clock;
using model::percentile;

/// "1 pair", "2 pairs": a count and its noun, singular for one.
std::string counted(std::uint64_t n, const std::string& noun) {
  return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

bool is_mesh_file(const std::filesystem::path& file) {
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return extension == ".obj" || extension == ".stl" || extension == ".off" || extension == ".ply";
}

// True when the server already holds `scene_id` (false when it cannot tell, e.g. a server
// without ListScenes).
bool scene_exists(client::Client& client, const std::string& scene_id) {
  auto scenes = client.list_scenes();
  return scenes && std::any_of(scenes->begin(), scenes->end(), [&](const client::SceneSummary& s) {
           return s.scene_id == scene_id;
         });
}

// Registers a scene file's geometries and creates its scene. Returns the exit code (0 on success).
// `existed`: the file names a scene id the server held already (CreateScene then answers the
// same request again idempotently): the caller must not delete it as its own.
// A robot description (URDF, MJCF) becomes an articulated scene (robots/): its links' objects
// move by joint positions; `robot` gives the search path of package:// and relative meshes, and
// the SRDF (else FILE.srdf beside a URDF).
int create_scene_from_file(client::Client& client, const std::string& path, std::ostream& err,
                           client::SceneInfo& created, bool* existed = nullptr,
                           const RobotFileOptions& robot = {}) {
  formats::SceneFile file;
#ifdef NEARPOINT_WITH_ROBOTS
  if (robots::is_robot_file(path)) {
    robots::ImportOptions import;
    import.meshes = mesh_loader();
    for (const std::string& dir : robot.package_path) import.search_path.emplace_back(dir);
    if (std::string error = robots::load_robot_scene(path, import, robot.srdf, file);
        !error.empty()) {
      err << "nearpoint: " << error << "\n";
      return kExitBadInput;
    }
  } else
#endif
      if (std::string error = formats::load_scene_file(path, mesh_loader(), file); !error.empty()) {
    err << "nearpoint: " << error << "\n";
    return kExitBadInput;
  }
  if (file.robot) {
#ifdef NEARPOINT_WITH_ROBOTS
    robots::ImportOptions import;
    import.meshes = mesh_loader();
    for (const std::string& dir : robot.package_path) import.search_path.emplace_back(dir);
    if (std::string error = robots::add_robot_to_scene(file, import); !error.empty()) {
      err << "nearpoint: " << path << ": robot: " << error << "\n";
      return kExitBadInput;
    }
#else
    err << "nearpoint: " << path << ": \"robot\": this build reads no robot descriptions\n";
    return kExitBadInput;
#endif
  }
  (void)robot;
  if (existed != nullptr)
    *existed = !file.scene.requested_id.empty() && scene_exists(client, file.scene.requested_id);
  std::map<std::string, std::string> ids;
  for (const auto& [name, geometry] : file.geometries) {
    auto info = client.register_geometry(geometry);
    if (!info) {
      err << "nearpoint: " << path << ": registering geometry \"" << name
          << "\": " << info.status().describe() << "\n";
      return exit_code_for(info.status());
    }
    ids[name] = info->geometry_id;
  }
  for (std::size_t i = 0; i < file.scene.objects.size(); ++i)
    if (!file.geometry_names[i].empty())
      file.scene.objects[i].geometry_id = ids.at(file.geometry_names[i]);
  auto scene = client.create_scene(file.scene);
  if (!scene) {
    err << "nearpoint: " << path << ": CreateScene: " << scene.status().describe() << "\n";
    return exit_code_for(scene.status());
  }
  created = *scene;
  return 0;
}

// A scene argument: an existing file is created first (`created` set: the caller owns it);
// anything else is a scene id.
int resolve_scene(client::Client& client, const std::string& scene, std::ostream& err,
                  std::string& scene_id, bool& created, const RobotFileOptions& robot = {}) {
  created = false;
  std::error_code ignored;
  if (std::filesystem::is_regular_file(scene, ignored)) {
    client::SceneInfo info;
    bool existed = false;
    if (int code = create_scene_from_file(client, scene, err, info, &existed, robot); code != 0)
      return code;
    scene_id = info.scene_id;
    created = !existed;
    return 0;
  }
  scene_id = scene;
  return 0;
}

bool options_from_flags(bool near_points, const std::string& penetration, client::QueryOptions& out,
                        std::ostream& err) {
  if (near_points) out.near_points = true;
  if (!penetration.empty()) {
    out.penetration = model::from_spelling<model::PenetrationMode>(penetration);
    if (out.penetration == model::PenetrationMode::unknown) {
      err << "nearpoint: --penetration must be " << model::spellings<model::PenetrationMode>()
          << "\n";
      return false;
    }
  }
  return true;
}

bool options_from_mode_flags(const ReportModeFlags& flags, client::QueryOptions& out,
                             std::ostream& err) {
  if (!flags.mode.empty()) {
    out.report_mode = model::from_spelling<model::ReportMode>(flags.mode);
    if (out.report_mode == model::ReportMode::unknown) {
      err << "nearpoint: --mode must be " << model::spellings<model::ReportMode>() << "\n";
      return false;
    }
  }
  // The server checks the values and names the field; here only "given or not".
  if (!std::isnan(flags.cutoff)) out.distance_cutoff = flags.cutoff;
  if (!std::isnan(flags.change_tolerance)) out.change_tolerance = flags.change_tolerance;
  return true;
}

std::string number(double value, int digits = 6) {
  std::ostringstream text;
  text << std::setprecision(digits) << value;
  return text.str();
}

std::string point(const Eigen::Vector3d& v) {
  return "(" + number(v.x()) + ", " + number(v.y()) + ", " + number(v.z()) + ")";
}

void print_pairs(const client::Report& report, std::ostream& out) {
  for (const client::PairDistance& p : report.pairs) {
    out << std::left << std::setw(24) << (p.object_a + " - " + p.object_b) << std::setw(16)
        << client::to_string(p.status);
    if (p.status == client::PairStatus::beyond_cutoff)
      out << "distance > " << number(p.distance_lower_bound);
    else
      out << "distance " << number(p.distance, 12) << " (± " << number(p.error_bound, 2) << ")";
    if (p.has_penetration_bound) out << "  d⁻ " << number(p.penetration_bound);
    if (p.has_penetration_depth && model::in_contact(p.status))
      out << "  depth " << number(p.depth, 12) << " in [" << number(p.depth_lower, 12) << ", "
          << number(p.depth_upper, 12) << "]";
    if (p.has_near_points) out << "  A " << point(p.point_a) << "  B " << point(p.point_b);
    out << "\n";
  }
}

/// Push (or query) to report, client side, microseconds.
double round_trip_us(const client::Report& report) {
  return std::chrono::duration<double, std::micro>(report.received - report.sent).count();
}

client::ObjectPose to_object_pose(const ObjectPose& pose) {
  const auto& q = pose.rotation_wxyz;
  return client::ObjectPose(
      pose.object_id, Eigen::Quaterniond(q[0], q[1], q[2], q[3]),
      Eigen::Vector3d(pose.translation[0], pose.translation[1], pose.translation[2]));
}

}  // namespace

// ---- register ----

int run_health(const HealthOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  auto status = client->health(options.service);
  if (!status) {
    err << "nearpoint health: " << status.status().describe() << "\n";
    return exit_code_for(status.status());
  }
  if (options.remote.json)
    out << Json{{"target", options.remote.target},
                {"service", options.service},
                {"status", *status}}
               .dump()
        << "\n";
  else
    out << *status << "\n";
  return *status == "SERVING" ? 0 : kExitServerError;
}

// ---- info ----

int run_info(const RemoteOptions& remote, std::ostream& out, std::ostream& err) {
  auto client = connect(remote, err);
  if (!client) return kExitBadInput;
  auto info = client->server_info();
  if (!info) {
    err << "nearpoint info: " << info.status().describe() << "\n";
    return exit_code_for(info.status());
  }
  const client::ServerInfo::Transports& t = info->transports;
  const client::ServerInfo::Limits& l = info->limits;
  if (remote.json) {
    Json transports = {{"grpc",
                        {{"listen", t.grpc_listen},
                         {"port", t.grpc_port},
                         {"tls", t.tls},
                         {"token_required", t.token_required}}},
                       {"dds", {{"enabled", t.dds}}},
                       {"metrics", {{"enabled", !t.metrics_listen.empty()}}}};
    if (t.dds) {
      transports["dds"]["domain"] = t.dds_domain;
      transports["dds"]["prefix"] = t.dds_prefix;
    }
    if (!t.metrics_listen.empty()) {
      transports["metrics"]["listen"] = t.metrics_listen;
      transports["metrics"]["port"] = t.metrics_port;
    }
    out << Json{{"target", remote.target},
                {"version", info->version},
                {"build",
                 {{"grpc", info->build.grpc},
                  {"dds", info->build.dds},
                  {"metrics", info->build.metrics}}},
                {"transports", std::move(transports)},
                {"limits",
                 {{"max_geometries", l.max_geometries},
                  {"max_pieces_per_geometry", l.max_pieces_per_geometry},
                  {"max_vertices_per_geometry", l.max_vertices_per_geometry},
                  {"max_scenes", l.max_scenes},
                  {"max_objects_per_scene", l.max_objects_per_scene},
                  {"max_pairs_per_scene", l.max_pairs_per_scene},
                  {"max_piece_pairs_per_scene", l.max_piece_pairs_per_scene},
                  {"max_streams", l.max_streams},
                  {"max_in_flight_per_stream", l.max_in_flight_per_stream},
                  {"max_concurrent_queries", l.max_concurrent_queries},
                  {"max_message_bytes", l.max_message_bytes},
                  {"workers", l.workers}}}}
               .dump()
        << "\n";
    return 0;
  }
  auto on_off = [](bool on) { return on ? "yes" : "no"; };
  out << "nearpointd " << info->version << " at " << remote.target << "\n"
      << "built with:   gRPC " << on_off(info->build.grpc) << ", DDS " << on_off(info->build.dds)
      << ", metrics " << on_off(info->build.metrics) << "\n"
      << "gRPC:         " << t.grpc_listen << " (port " << t.grpc_port << "), TLS " << t.tls
      << ", token " << (t.token_required ? "required" : "off") << "\n"
      << "DDS:          ";
  if (t.dds)
    out << "on, domain " << t.dds_domain << ", prefix " << t.dds_prefix << "\n";
  else
    out << "off\n";
  out << "metrics:      ";
  if (t.metrics_listen.empty())
    out << "off\n";
  else
    out << t.metrics_listen << " (port " << t.metrics_port << ", /metrics)\n";
  out << "limits:       " << l.max_scenes << " scenes, " << l.max_geometries << " geometries ("
      << l.max_pieces_per_geometry << " pieces, " << l.max_vertices_per_geometry
      << " vertices each), " << l.max_objects_per_scene << " objects, " << l.max_pairs_per_scene
      << " pairs and " << l.max_piece_pairs_per_scene << " piece pairs per scene\n"
      << "              " << l.max_streams << " streams (" << l.max_in_flight_per_stream
      << " updates in flight each), " << l.max_concurrent_queries << " concurrent queries, "
      << l.max_message_bytes << "-byte messages, " << l.workers
      << (l.workers == 1 ? " worker thread\n" : " worker threads\n");
  return 0;
}

int run_register(const RegisterOptions& options, std::ostream& out, std::ostream& err) {
  if (options.files.empty()) {
    err << "nearpoint register: give at least one FILE\n";
    return kExitBadInput;
  }
  std::vector<client::Geometry> geometries;
  std::vector<std::filesystem::path> meshes;
  for (const std::string& name : options.files) {
    const std::filesystem::path file(name);
    if (is_mesh_file(file)) {
      meshes.push_back(file);
      continue;
    }
    Json value;
    if (std::string error = formats::read_structured_file(file, value); !error.empty()) {
      err << "nearpoint register: " << error << "\n";
      return kExitBadInput;
    }
    client::Geometry geometry;
    if (std::string error =
            formats::parse_geometry(value, "geometry", file.parent_path(), mesh_loader(), geometry);
        !error.empty()) {
      err << "nearpoint register: " << name << ": " << error << "\n";
      return kExitBadInput;
    }
    if (geometry.name.empty()) geometry.name = file.stem().string();
    if (!options.name.empty()) geometry.name = options.name;
    geometries.push_back(std::move(geometry));
  }
  if (!meshes.empty()) {
    // Several mesh files (a convex decomposition) make one compound geometry.
    client::Geometry compound;
    compound.name = options.name.empty() ? meshes.front().stem().string() : options.name;
    formats::MeshRequest request{meshes, options.scale, options.merge};
    if (std::string error = mesh_loader()(request, compound.pieces); !error.empty()) {
      err << "nearpoint register: " << error << "\n";
      return kExitBadInput;
    }
    geometries.push_back(std::move(compound));
  }
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  for (const client::Geometry& geometry : geometries) {
    auto info = client->register_geometry(geometry);
    if (!info) {
      err << "nearpoint register: " << options.remote.target << ": " << info.status().describe()
          << "\n";
      return exit_code_for(info.status());
    }
    if (options.remote.json) {
      out << to_json(*info).dump() << "\n";
    } else {
      out << info->geometry_id << "  \"" << info->name << "\": " << info->piece_count
          << (info->piece_count == 1 ? " piece, " : " pieces, ") << info->vertex_count
          << " vertices, bounding sphere radius " << number(info->bounding_radius) << " at "
          << point(info->bounding_center) << "\n";
    }
  }
  return 0;
}

// ---- scene create ----

int run_scene_create(const SceneCreateOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  client::SceneInfo created;
  if (int code =
          create_scene_from_file(*client, options.file, err, created, nullptr, options.robot);
      code != 0)
    return code;
  if (options.remote.json)
    out << Json{{"scene_id", created.scene_id}, {"pair_count", created.pair_count}}.dump() << "\n";
  else
    out << created.scene_id << ": " << created.pair_count
        << (created.pair_count == 1 ? " pair" : " pairs") << "\n";
  return 0;
}

// ---- query ----

int run_query(const QueryCommandOptions& options, std::ostream& out, std::ostream& err) {
  std::vector<client::ObjectPose> poses;
  for (const std::string& text : options.poses) {
    client::ObjectPose pose;
    std::string error;
    if (!parse_pose_argument(text, pose, error)) {
      err << "nearpoint query: " << error << "\n";
      return kExitBadInput;
    }
    poses.push_back(pose);
  }
  client::QueryOptions query_options;
  if (!options_from_flags(options.near_points, options.penetration, query_options, err) ||
      !options_from_mode_flags(options.report, query_options, err))
    return kExitBadInput;
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  install_interrupt_handlers();
  std::string scene_id;
  bool created = false;
  if (int code = resolve_scene(*client, options.scene, err, scene_id, created); code != 0)
    return code;
  SceneLease lease(*client, scene_id, created, options.keep_scene, "nearpoint query", err);
  auto report = client->query(scene_id, poses, query_options);
  if (!report) {
    err << "nearpoint query: " << report.status().describe() << "\n";
    return exit_code_for(report.status());
  }
  if (options.remote.json) {
    Json json = to_json(*report);
    json["round_trip_us"] = round_trip_us(*report);
    json["scene_id"] = scene_id;
    out << json.dump() << "\n";
  } else {
    out << "scene " << scene_id << ": " << counted(report->pairs.size(), "pair") << ", "
        << number(report->timing.server_us, 4) << " µs on the server\n";
    print_pairs(*report, out);
  }
  lease.release();
  return interrupt_signal() != 0 ? interrupted_exit_code() : 0;
}

// ---- stream: parse → run → print ----

namespace {

/// What `nearpoint stream` gathers from its reports for the summary.
struct StreamTally {
  struct PairSummary {
    double min_distance = std::numeric_limits<double>::infinity();
    double min_time = 0;
    std::size_t intersecting_steps = 0;
    double first_hit = -1;
  };
  std::map<std::pair<std::string, std::string>, PairSummary> pairs;
  std::vector<std::pair<std::string, std::string>> pair_order;
  std::vector<double> latencies_us;
  std::vector<client::ThresholdEvent> events;
  std::size_t reports = 0, errors = 0;
  std::string first_error;

  /// Counts the report of the update at trajectory time `time`; false for an error report.
  bool add(const client::Report& report, double time) {
    ++reports;
    if (!report.error.ok()) {
      ++errors;
      if (first_error.empty())
        first_error = "update " + std::to_string(report.sequence) + " (t = " + number(time) +
                      "): " + report.error.describe();
      return false;
    }
    latencies_us.push_back(
        std::chrono::duration<double, std::micro>(report.received - report.sent).count());
    events.insert(events.end(), report.events.begin(), report.events.end());
    for (const client::PairDistance& p : report.pairs) {
      auto key = std::pair(p.object_a, p.object_b);
      auto [it, inserted] = pairs.try_emplace(key);
      if (inserted) pair_order.push_back(key);
      PairSummary& s = it->second;
      // With --penetration depth the signed distance: how deep the pair went, not only that.
      const double distance = p.has_signed_distance ? p.signed_distance : p.distance;
      if (p.status != client::PairStatus::beyond_cutoff && distance < s.min_distance) {
        s.min_distance = distance;
        s.min_time = time;
      }
      if (model::in_contact(p.status)) {  // intersecting or touching
        if (s.intersecting_steps++ == 0) s.first_hit = time;
      }
    }
    return true;
  }
};

/// The trajectory time of update `sequence` (0 when there is no such step).
double step_time(const Trajectory& trajectory, std::uint64_t sequence) {
  return sequence >= 1 && sequence <= trajectory.steps.size() ? trajectory.steps[sequence - 1].time
                                                              : 0;
}

/// Parse: the trajectory and the session's options from the flags; false once `err` says why.
bool parse_stream(const StreamCommandOptions& options, Trajectory& trajectory,
                  client::SessionOptions& session_options, std::ostream& err) {
  if (options.trajectory.empty() == options.joints.empty()) {
    err << "nearpoint stream: give a TRAJECTORY or --joints FILE (one of the two)\n";
    return false;
  }
  const std::string& path = options.joints.empty() ? options.trajectory : options.joints;
  if (std::string error; !load_trajectory(path, trajectory, error)) {
    err << "nearpoint stream: " << error << "\n";
    return false;
  }
  if (!options_from_flags(options.near_points, options.penetration, session_options.options, err) ||
      !options_from_mode_flags(options.report, session_options.options, err))
    return false;
  if (options.gradient) session_options.options.gradient = true;
  for (const std::string& spec : options.thresholds) {
    std::string error;
    if (!parse_threshold_argument(spec, session_options.thresholds.emplace_back(), error)) {
      err << "nearpoint stream: " << error << "\n";
      return false;
    }
  }
  session_options.max_in_flight = std::max<std::size_t>(1, options.window);
  return true;
}

/// Print: the run's totals, each pair's closest approach and intersections, and the threshold
/// events (when the stream watched any).
void print_stream_summary(StreamTally& tally, const Trajectory& trajectory,
                          const std::string& scene_id, double wall, std::uint64_t reconnects,
                          bool watched, std::ostream& out) {
  out << "scene " << scene_id << ": " << counted(tally.reports, "report") << " for "
      << counted(trajectory.steps.size(), "update") << " in " << number(wall, 3) << " s";
  if (reconnects > 0) out << " (" << counted(reconnects, "reconnect") << ")";
  out << "; round trip p50 " << number(percentile(tally.latencies_us, 0.5), 4) << " µs, p99 "
      << number(percentile(tally.latencies_us, 0.99), 4) << " µs\n";
  out << std::left << std::setw(24) << "pair" << std::setw(16) << "min distance" << std::setw(12)
      << "at t"
      << "in contact\n";
  for (const auto& key : tally.pair_order) {
    const StreamTally::PairSummary& s = tally.pairs.at(key);
    out << std::left << std::setw(24) << (key.first + " - " + key.second) << std::setw(16)
        << number(s.min_distance) << std::setw(12) << number(s.min_time);
    if (s.intersecting_steps == 0)
      out << "never\n";
    else
      out << counted(s.intersecting_steps, "step") << ", first at t = " << number(s.first_hit)
          << "\n";
  }
  if (!watched) return;
  out << counted(tally.events.size(), "threshold event") << "\n";
  for (const client::ThresholdEvent& e : tally.events) {
    out << "  t = " << std::left << std::setw(10) << number(step_time(trajectory, e.sequence))
        << (e.crossing == client::Crossing::enter ? "ENTER " : "EXIT  ")
        << (e.threshold.empty() ? "#" + std::to_string(e.threshold_index) : e.threshold) << "  "
        << e.object_a << " - " << e.object_b << " at " << number(e.distance) << " m\n";
  }
}

}  // namespace

int run_stream(const StreamCommandOptions& options, std::ostream& out, std::ostream& err) {
  Trajectory trajectory;
  client::SessionOptions session_options;
  if (!parse_stream(options, trajectory, session_options, err)) return kExitBadInput;
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  install_interrupt_handlers();
  std::string scene_id;
  bool created = false;
  if (int code = resolve_scene(*client, options.scene, err, scene_id, created, options.robot);
      code != 0)
    return code;
  // Declared before the session: the stream is closed before the scene is deleted.
  SceneLease lease(*client, scene_id, created, options.keep_scene, "nearpoint stream", err);

  // Run: every step pushed (the window bounds what is in flight), each report tallied as it comes.
  std::mutex mutex;
  StreamTally tally;
  Clock::time_point last_progress = Clock::now();
  const auto started = Clock::now();
  session_options.on_report = [&](const client::Report& report) {
    std::lock_guard lock(mutex);
    const double time = step_time(trajectory, report.sequence);
    if (options.remote.json) {
      Json json = to_json(report);
      json["t"] = time;
      if (report.error.ok()) json["round_trip_us"] = round_trip_us(report);
      out << json.dump() << "\n";
    }
    if (!tally.add(report, time)) return;
    if (!options.remote.json && options.progress_every > 0 &&
        std::chrono::duration<double>(report.received - last_progress).count() >=
            options.progress_every) {
      last_progress = report.received;
      err << "\r  " << tally.reports << "/" << trajectory.steps.size() << " reports" << std::flush;
    }
  };
  auto session = client->open_session(scene_id, session_options);
  if (!session) {
    err << "nearpoint stream: " << session.status().describe() << "\n";
    return exit_code_for(session.status());
  }
  for (const TrajectoryStep& step : trajectory.steps) {
    // Ctrl-C: stop sending; the updates in flight are still answered (and printed) by close().
    if (interrupt_signal() != 0) break;
    std::vector<client::ObjectPose> poses;
    for (const ObjectPose& pose : step.poses) poses.push_back(to_object_pose(pose));
    client::Expected<std::uint64_t> pushed = std::uint64_t(0);
    if (!step.joints.empty() || step.has_base) {
      // A robot step: its joint positions (and base pose) in one update. Poses of other objects
      // in the same step are not sent: a step is one or the other.
      client::JointPositions joints;
      for (const auto& [name, values] : step.joints) {
        joints.names.push_back(name);
        joints.positions.insert(joints.positions.end(), values.begin(), values.end());
      }
      if (step.has_base) {
        const client::ObjectPose base = to_object_pose(step.base);
        joints.base_pose = client::to_pose_input(base.rotation, base.translation);
      }
      pushed = (*session)->push_joints(joints, Clock::now() + options.remote.timeout);
    } else {
      pushed = (*session)->push(poses, Clock::now() + options.remote.timeout);
    }
    if (!pushed) {
      err << "nearpoint stream: " << pushed.status().describe() << "\n";
      return exit_code_for(pushed.status());
    }
  }
  const client::Status closed = (*session)->close(Clock::now() + options.remote.timeout);
  const double wall = std::chrono::duration<double>(Clock::now() - started).count();

  std::lock_guard lock(mutex);
  if (!options.remote.json) {
    if (options.progress_every > 0) err << "\r" << std::string(40, ' ') << "\r";
    print_stream_summary(tally, trajectory, scene_id, wall, (*session)->reconnects(),
                         !session_options.thresholds.empty(), out);
  }
  if (!tally.first_error.empty())
    err << "nearpoint stream: " << tally.errors
        << " updates rejected; the first: " << tally.first_error << "\n";
  if (interrupt_signal() != 0) {
    err << "nearpoint stream: interrupted after " << tally.reports << " of "
        << trajectory.steps.size() << " updates\n";
    return interrupted_exit_code();  // the session ends before the lease deletes the scene
  }
  if (!closed.ok()) {
    err << "nearpoint stream: " << closed.describe() << "\n";
    return exit_code_for(closed);
  }
  return tally.errors == 0 ? 0 : kExitServerError;
}

// ---- load: parse → run → print ----

namespace {

/// Parse: the flags' bounds and the path the streams replay (the trajectory's steps, or the demo
/// scene's 1001 poses); false once `err` says why.
bool parse_load(const LoadCommandOptions& options,
                std::vector<std::vector<client::ObjectPose>>& path, std::ostream& err) {
  if (options.streams < 1 || options.streams > 256 || !(options.duration_s > 0) ||
      options.duration_s > 600) {
    err << "nearpoint load: --streams must be in [1, 256] and --duration in (0, 600] s\n";
    return false;
  }
  if (options.scene.empty() != options.trajectory.empty()) {
    err << "nearpoint load: give both SCENE and TRAJECTORY, or neither (the demo scene)\n";
    return false;
  }
  if (options.trajectory.empty()) {
    constexpr int kSteps = 1000;
    for (int t = 0; t <= kSteps; ++t) path.push_back({demo_pose(double(t) / kSteps)});
    return true;
  }
  Trajectory trajectory;
  if (std::string error; !load_trajectory(options.trajectory, trajectory, error)) {
    err << "nearpoint load: " << error << "\n";
    return false;
  }
  for (const TrajectoryStep& step : trajectory.steps) {
    std::vector<client::ObjectPose> poses;
    for (const ObjectPose& pose : step.poses) poses.push_back(to_object_pose(pose));
    path.push_back(std::move(poses));
  }
  if (path.empty()) {
    err << "nearpoint load: the trajectory has no steps\n";
    return false;
  }
  return true;
}

/// Run: `options.streams` streams on `scene_id`, each pushing `path` round and round (from its
/// own starting point) for the duration, with a progress line on `err` meanwhile.
LoadResult run_load_streams(const client::ClientOptions& client_options,
                            const std::string& scene_id,
                            const std::vector<std::vector<client::ObjectPose>>& path,
                            const LoadCommandOptions& options, std::ostream& err) {
  LoadPlan plan;
  plan.target = options.remote.target;
  plan.client_options = client_options;
  plan.scene_id = scene_id;
  plan.path = &path;
  plan.streams = options.streams;
  plan.window = options.window;
  plan.batch = options.batch;
  plan.duration_s = options.duration_s;
  plan.progress_every = options.progress_every;
  plan.progress = [&err](double elapsed, std::size_t reports, std::size_t errors) {
    err << "\r  " << number(elapsed, 3) << " s  " << reports << " reports  "
        << number(double(reports) / std::max(elapsed, 1e-9), 4) << " updates/s  " << errors
        << " errors   " << std::flush;
  };
  LoadResult result = drive_load(plan);
  if (options.progress_every > 0) err << "\n";
  return result;
}

/// Print: the rate and the round-trip latency percentiles, as text or one JSON object.
void print_load_summary(LoadResult& result, const std::string& scene_id,
                        const LoadCommandOptions& options, std::ostream& out) {
  std::vector<double>& latencies_us = result.latencies_us;
  const std::size_t count = latencies_us.size();
  const double p50 = percentile(latencies_us, 0.5), p90 = percentile(latencies_us, 0.9),
               p99 = percentile(latencies_us, 0.99);
  const double max = count ? *std::max_element(latencies_us.begin(), latencies_us.end()) : 0;
  const double rate = double(count) / std::max(options.duration_s, 1e-9);
  if (options.remote.json) {
    out << Json{{"scene_id", scene_id},
                {"streams", options.streams},
                {"window", options.window},
                {"batch", options.batch},
                {"duration_s", result.elapsed_s},
                {"reports", count},
                {"errors", result.errors},
                {"updates_per_s", rate},
                {"geometry_us_per_report", count ? result.geometry_us / double(count) : 0.0},
                {"latency_us", {{"p50", p50}, {"p90", p90}, {"p99", p99}, {"max", max}}}}
               .dump()
        << "\n";
    return;
  }
  out << "scene " << scene_id << ": " << counted(options.streams, "stream") << " × "
      << options.window << " in flight"
      << (options.batch > 1 ? ", " + std::to_string(options.batch) + " per message," : "")
      << " for " << number(options.duration_s, 3) << " s: " << counted(count, "report") << ", "
      << number(rate, 5) << " updates/s\n"
      << "round-trip latency (push to report): p50 " << number(p50, 4) << " µs, p90 "
      << number(p90, 4) << " µs, p99 " << number(p99, 4) << " µs, max " << number(max, 4)
      << " µs\n";
}

}  // namespace

int run_load(const LoadCommandOptions& options, std::ostream& out, std::ostream& err) {
  std::vector<std::vector<client::ObjectPose>> path;
  if (!parse_load(options, path, err)) return kExitBadInput;
  const std::optional<client::ClientOptions> client_options =
      cli::client_options(options.remote, err);
  if (!client_options) return kExitBadInput;
  auto client = client::Client::connect(options.remote.target, *client_options);
  install_interrupt_handlers();
  std::string scene_id;
  bool created = false;
  if (options.scene.empty()) {
    auto demo = create_demo_scene(*client);
    if (!demo) {
      err << "nearpoint load: " << options.remote.target << ": " << demo.status().describe()
          << "\n";
      return exit_code_for(demo.status());
    }
    scene_id = *demo;
    created = true;
  } else if (int code = resolve_scene(*client, options.scene, err, scene_id, created); code != 0) {
    return code;
  }
  SceneLease lease(*client, scene_id, created, options.keep_scene, "nearpoint load", err);
  LoadResult result = run_load_streams(*client_options, scene_id, path, options, err);
  lease.release();
  if (interrupt_signal() != 0) {
    err << "nearpoint load: interrupted\n";
    return interrupted_exit_code();
  }
  print_load_summary(result, scene_id, options, out);
  if (result.errors > 0) {
    err << "nearpoint load: " << result.errors << " errors; the first: " << result.first_error
        << "\n";
    return kExitServerError;
  }
  return 0;
}

}  // namespace nearpoint::cli
