// SPDX-License-Identifier: Apache-2.0
#include "remote_common.hpp"

#include <cmath>
#include <cstdlib>
#include <ostream>
#include <sstream>

#include "nearpoint/model/vocabulary.hpp"

#ifdef NEARPOINT_WITH_MESH_IMPORT
#include "nearpoint/client/mesh_import.hpp"
#include "nearpoint/client/mesh_loader.hpp"
#endif

namespace nearpoint::cli {
namespace {

Json vec(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

}  // namespace

int exit_code_for(const client::Status& status) {
  if (status.ok()) return 0;
  return status.code == client::kUnavailable || status.code == client::kDeadlineExceeded
             ? kExitUnreachable
             : kExitServerError;
}

std::optional<client::ClientOptions> client_options(const RemoteOptions& remote,
                                                    std::ostream& err) {
  client::ClientOptions options;
  options.call_timeout = remote.timeout;
  options.tls_server_name = remote.tls_server_name;
  const client::Status loaded = client::load_credentials(options, remote.tls_ca, remote.tls_cert,
                                                         remote.tls_key, remote.token_file);
  if (!loaded.ok()) {
    err << "nearpoint: " << loaded.message << "\n";
    return std::nullopt;
  }
  return options;
}

std::unique_ptr<client::Client> connect(const RemoteOptions& remote, std::ostream& err) {
  const std::optional<client::ClientOptions> options = client_options(remote, err);
  return options ? client::Client::connect(remote.target, *options) : nullptr;
}

std::string default_target() {
  const char* env = std::getenv("NEARPOINT_TARGET");
  return env != nullptr && *env != '\0' ? env : "127.0.0.1:50051";
}

bool have_mesh_import() {
#ifdef NEARPOINT_WITH_MESH_IMPORT
  return true;
#else
  return false;
#endif
}

formats::MeshLoader mesh_loader() {
#ifdef NEARPOINT_WITH_MESH_IMPORT
  return client::mesh_loader();
#else
  return [](const formats::MeshRequest&, std::vector<model::PieceInput>&) -> std::string {
    return "this nearpoint was built without mesh import (assimp); give the pieces as SHAPEs";
  };
#endif
}

Json to_json(const client::GeometryInfo& info) {
  Json out;
  out["geometry_id"] = info.geometry_id;
  out["name"] = info.name;
  out["piece_count"] = info.piece_count;
  out["vertex_count"] = info.vertex_count;
  out["bounding_center"] = vec(info.bounding_center);
  out["bounding_radius"] = info.bounding_radius;
  return out;
}

// One schema for every report the CLI prints (client/schema/report.schema.json), the same keys as
// dds_stream.cpp's report_json: a change here needs the same change there and in the schema.
Json to_json(const client::Report& report) {
  Json out;
  out["sequence"] = report.sequence;
  if (!report.error.ok()) {
    out["status"] = "error";
    out["error"] = {{"code", model::status_code_spelling(report.error.code)},
                    {"field", report.error_field},
                    {"message", report.error.message}};
    return out;
  }
  out["status"] = "ok";
  out["report_mode"] = client::to_string(report.mode);
  Json pairs = Json::array();
  for (const client::PairDistance& p : report.pairs) {
    Json pair;
    pair["object_a"] = p.object_a;
    pair["object_b"] = p.object_b;
    pair["status"] = client::to_string(p.status);
    // The bound on every pair, whatever its status (beyond_cutoff: distance_lower_bound is the
    // meaningful value; the others say what the server sent).
    pair["distance"] = p.distance;
    pair["distance_lower_bound"] = p.distance_lower_bound;
    pair["error_bound"] = p.error_bound;
    pair["iterations"] = p.iterations;
    pair["warm_started"] = p.warm_started;
    if (p.has_near_points) {
      pair["point_a"] = vec(p.point_a);
      pair["point_b"] = vec(p.point_b);
      pair["normal"] = vec(p.normal);
    }
    if (p.has_penetration_bound) pair["penetration_bound"] = p.penetration_bound;
    if (p.has_signed_distance) {
      pair["signed_distance"] = p.signed_distance;
      pair["signed_distance_lower"] = p.signed_distance_lower;
      pair["signed_distance_upper"] = p.signed_distance_upper;
    }
    if (p.has_penetration_depth) {
      pair["penetration_depth"] = p.depth;
      pair["penetration_depth_lower"] = p.depth_lower;
      pair["penetration_depth_upper"] = p.depth_upper;
      if (p.depth_direction.squaredNorm() > 0) {  // left out where undefined (see the schema)
        pair["depth_point_a"] = vec(p.depth_point_a);
        pair["depth_point_b"] = vec(p.depth_point_b);
        pair["depth_direction"] = vec(p.depth_direction);
      }
      pair["depth_termination"] = client::to_string(p.depth_termination);
      pair["depth_iterations"] = p.depth_iterations;
    }
    if (!p.message.empty()) pair["message"] = p.message;
    if (!p.joint_gradient.empty()) {
      // By joint name: a number for one-dof joints, an array for ball and free joints.
      Json gradient = Json::object();
      for (const client::JointDerivative& d : p.joint_gradient) {
        Json& entry = gradient[d.joint];
        if (d.coordinate == 0 && entry.is_null()) {
          entry = d.value;
        } else {
          if (!entry.is_array()) entry = Json::array({entry});
          entry.push_back(d.value);
        }
      }
      pair["joint_gradient"] = std::move(gradient);
    }
    pairs.push_back(std::move(pair));
  }
  out["pairs"] = std::move(pairs);
  Json events = Json::array();
  for (const client::ThresholdEvent& e : report.events)
    events.push_back({{"threshold", e.threshold},
                      {"threshold_index", e.threshold_index},
                      {"object_a", e.object_a},
                      {"object_b", e.object_b},
                      {"crossing", client::to_string(e.crossing)},
                      {"distance", e.distance},
                      {"sequence", e.sequence}});
  out["events"] = std::move(events);
  if (!report.joint_limit_violations.empty()) {
    Json violations = Json::array();
    for (const client::JointLimitViolation& v : report.joint_limit_violations)
      violations.push_back(
          {{"joint", v.joint}, {"position", v.position}, {"lower", v.lower}, {"upper", v.upper}});
    out["joint_limit_violations"] = std::move(violations);
  }
  out["coalesced_updates"] = report.coalesced_updates;
  out["coalesced_from_sequence"] =
      report.coalesced_updates > 0 ? report.coalesced_from_sequence : 0;
  out["counts"] = {{"pairs_evaluated", report.counts.pairs_evaluated},
                   {"pairs_pruned", report.counts.pairs_pruned},
                   {"pairs_unmoved", report.counts.pairs_unmoved}};
  out["server_us"] = report.timing.server_us;
  out["queue_us"] = report.timing.queue_us;
  out["evaluation_us"] = report.timing.evaluation_us;
  out["geometry_us"] = report.timing.geometry_us;
  return out;
}

bool parse_threshold_argument(const std::string& text, client::Threshold& out, std::string& error) {
  out = client::Threshold{};
  const std::string where = "--threshold " + text + ": ";
  auto number = [&](const std::string& value, double& into) {
    char* end = nullptr;
    into = std::strtod(value.c_str(), &end);
    if (value.empty() || end != value.c_str() + value.size()) {
      error = where + "\"" + value + "\" is not a number";
      return false;
    }
    return true;
  };
  bool has_distance = false;
  std::istringstream input(text);
  std::string item;
  for (bool first = true; std::getline(input, item, ','); first = false) {
    const auto equals = item.find('=');
    if (equals == std::string::npos) {
      if (!first) {
        error = where + "\"" + item + "\" is not KEY=VALUE";
        return false;
      }
      if (!number(item, out.distance)) return false;
      has_distance = true;
      continue;
    }
    const std::string key = item.substr(0, equals), value = item.substr(equals + 1);
    if (key == "distance") {
      if (!number(value, out.distance)) return false;
      has_distance = true;
    } else if (key == "hysteresis") {
      if (!number(value, out.hysteresis)) return false;
    } else if (key == "pair") {
      const auto colon = value.find(':');
      if (colon == std::string::npos) {
        error = where + "pair=" + value + " is not A:B";
        return false;
      }
      out.object_a = value.substr(0, colon);
      out.object_b = value.substr(colon + 1);
    } else if (key == "object") {
      out.object_a = value;
    } else if (key == "groups") {
      char* end = nullptr;
      const unsigned long groups = std::strtoul(value.c_str(), &end, 0);
      if (value.empty() || end != value.c_str() + value.size() || groups > 0xFFFFFFFFul) {
        error = where + "groups=" + value + " is not a 32-bit number";
        return false;
      }
      out.groups = std::uint32_t(groups);
    } else if (key == "name") {
      out.name = value;
    } else {
      error =
          where + "unknown key \"" + key + "\" (distance, hysteresis, pair, object, groups, name)";
      return false;
    }
  }
  if (!has_distance) {
    error = where + "no distance (a number first, or distance=D)";
    return false;
  }
  return true;
}

bool parse_pose_argument(const std::string& text, client::ObjectPose& out, std::string& error) {
  const auto equals = text.find('=');
  if (equals == std::string::npos || equals == 0) {
    error = "--pose " + text + ": expected OBJECT=tx,ty,tz[,qw,qx,qy,qz]";
    return false;
  }
  std::vector<double> numbers;
  std::istringstream input(text.substr(equals + 1));
  std::string cell;
  while (std::getline(input, cell, ',')) {
    char* end = nullptr;
    const double value = std::strtod(cell.c_str(), &end);
    if (cell.empty() || end != cell.c_str() + cell.size() || !std::isfinite(value)) {
      error = "--pose " + text + ": \"" + cell + "\" is not a finite number";
      return false;
    }
    numbers.push_back(value);
  }
  if (numbers.size() != 3 && numbers.size() != 7) {
    error = "--pose " + text + ": expected 3 numbers (translation) or 7 (and a quaternion w,x,y,z)";
    return false;
  }
  out.object_id = text.substr(0, equals);
  out.translation = Eigen::Vector3d(numbers[0], numbers[1], numbers[2]);
  out.rotation = numbers.size() == 7
                     ? Eigen::Quaterniond(numbers[3], numbers[4], numbers[5], numbers[6])
                     : Eigen::Quaterniond::Identity();
  return true;
}

}  // namespace nearpoint::cli
