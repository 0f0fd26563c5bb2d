// SPDX-License-Identifier: Apache-2.0
#include "trajectory.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

namespace nearpoint::cli {
namespace {

using Json = nlohmann::ordered_json;

// The server accepts quaternions within 1e-4 of unit length; rejecting the same ones here names
// the line, where the server could only name the update's sequence number.
constexpr double kUnitTolerance = 1e-4;

std::string at_line(const std::string& name, long line) {
  return name + ":" + std::to_string(line) + ": ";
}

bool check_rotation(const std::array<double, 4>& q, std::string& why) {
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(std::abs(norm - 1) <= kUnitTolerance)) {
    std::ostringstream text;
    text << "rotation quaternion is not of unit length (|q| = " << norm
         << "; accepted within 1e-4 of 1)";
    why = text.str();
    return false;
  }
  return true;
}

template <std::size_t N>
bool read_array(const Json& value, const char* what, std::array<double, N>& out, std::string& why) {
  if (!value.is_array() || value.size() != N) {
    why = std::string("\"") + what + "\" must be an array of " + std::to_string(N) + " numbers";
    return false;
  }
  for (std::size_t i = 0; i < N; ++i) {
    if (!value[i].is_number()) {
      why = std::string("\"") + what + "[" + std::to_string(i) + "]\" must be a number";
      return false;
    }
    out[i] = value[i].get<double>();
  }
  return true;
}

bool parse_json_lines(const std::string& text, const std::string& name, Trajectory& out,
                      std::string& error) {
  std::istringstream input(text);
  std::string line;
  long number = 0;
  Trajectory result;
  while (std::getline(input, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const Json value = Json::parse(line, nullptr, /*allow_exceptions=*/false);
    const std::string where = at_line(name, number);
    if (value.is_discarded()) return error = where + "not valid JSON", false;
    if (!value.is_object()) return error = where + "must be a JSON object", false;
    TrajectoryStep step;
    step.time = double(result.steps.size());
    for (const auto& [key, member] : value.items()) {
      if (key == "t") {
        if (!member.is_number()) return error = where + "\"t\" must be a number", false;
        step.time = member.get<double>();
      } else if (key == "joints") {
        if (!member.is_object())
          return error = where + "\"joints\" must be an object {\"JOINT\": position, ...}", false;
        for (const auto& [joint, position] : member.items()) {
          std::vector<double> values;
          if (position.is_number()) {
            values.push_back(position.get<double>());
          } else if (position.is_array() && !position.empty()) {
            for (const Json& v : position) {
              if (!v.is_number()) break;
              values.push_back(v.get<double>());
            }
            if (values.size() != position.size()) values.clear();
          }
          if (values.empty())
            return error = where + "\"joints." + joint +
                           "\" must be a number or an array of numbers (ball: [w,x,y,z])",
                   false;
          step.joints.emplace_back(joint, std::move(values));
        }
      } else if (key == "base") {
        std::string why;
        if (!member.is_object())
          return error =
                     where + "\"base\" must be {\"rotation\": [w,x,y,z], \"translation\": [x,y,z]}",
                 false;
        for (const auto& [part_key, part] : member.items()) {
          bool ok = true;
          if (part_key == "rotation")
            ok = read_array(part, "base.rotation", step.base.rotation_wxyz, why) &&
                 check_rotation(step.base.rotation_wxyz, why);
          else if (part_key == "translation")
            ok = read_array(part, "base.translation", step.base.translation, why);
          else
            return error = where + "\"base\" has the unknown key \"" + part_key + "\"", false;
          if (!ok) return error = where + why, false;
        }
        step.has_base = true;
      } else if (key != "poses") {
        return error = where + "unknown key \"" + key +
                       "\" (a step has \"t\", \"poses\", \"joints\" and \"base\")",
               false;
      }
    }
    const bool robot_step = value.contains("joints") || value.contains("base");
    if ((!robot_step || value.contains("poses")) &&
        (!value.contains("poses") || !value["poses"].is_object()))
      return error = where + "\"poses\" must be an object {\"OBJECT\": POSE, ...}", false;
    static const Json kNoPoses = Json::object();
    const Json& poses = value.contains("poses") ? value["poses"] : kNoPoses;
    for (const auto& [object, pose] : poses.items()) {
      ObjectPose entry;
      entry.object_id = object;
      const std::string field = "poses." + object;
      if (!pose.is_object())
        return error = where + "\"" + field +
                       "\" must be {\"rotation\": [w,x,y,z], "
                       "\"translation\": [x,y,z]}",
               false;
      std::string why;
      for (const auto& [key, part] : pose.items()) {
        bool ok = true;
        if (key == "rotation")
          ok = read_array(part, (field + ".rotation").c_str(), entry.rotation_wxyz, why) &&
               check_rotation(entry.rotation_wxyz, why);
        else if (key == "translation")
          ok = read_array(part, (field + ".translation").c_str(), entry.translation, why);
        else
          return error = where + "\"" + field + "\" has the unknown key \"" + key + "\"", false;
        if (!ok) return error = where + why, false;
      }
      step.poses.push_back(std::move(entry));
    }
    if (!result.steps.empty() && step.time < result.steps.back().time)
      return error = where + "\"t\" decreases (times must not decrease)", false;
    result.steps.push_back(std::move(step));
  }
  out = std::move(result);
  return true;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream input(line);
  while (std::getline(input, cell, ',')) {
    const auto first = cell.find_first_not_of(" \t\r");
    const auto last = cell.find_last_not_of(" \t\r");
    cells.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
  }
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

bool parse_number(const std::string& cell, double& out) {
  if (cell.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtod(cell.c_str(), &end);
  return errno == 0 && end == cell.c_str() + cell.size() && std::isfinite(out);
}

bool parse_csv(const std::string& text, const std::string& name, Trajectory& out,
               std::string& error) {
  static const char* const kColumns[] = {"t", "tx", "ty", "tz", "qw", "qx", "qy", "qz"};
  std::istringstream input(text);
  std::string line;
  long number = 0;
  bool header_seen = false;
  Trajectory result;
  while (std::getline(input, line)) {
    ++number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::vector<std::string> cells = split_csv(line);
    const std::string where = at_line(name, number);
    if (!header_seen) {
      const std::vector<std::string> expected = {"t",  "object", "tx", "ty", "tz",
                                                 "qw", "qx",     "qy", "qz"};
      if (cells != expected)
        return error = where + "the header must be t,object,tx,ty,tz,qw,qx,qy,qz", false;
      header_seen = true;
      continue;
    }
    if (cells.size() != 9)
      return error = where + "expected 9 columns t,object,tx,ty,tz,qw,qx,qy,qz (got " +
                     std::to_string(cells.size()) + ")",
             false;
    double values[8];
    for (std::size_t i = 0, column = 0; i < 9; ++i) {
      if (i == 1) continue;
      if (!parse_number(cells[i], values[column]))
        return error = where + "column \"" + kColumns[column] +
                       "\" must be a finite number (got \"" + cells[i] + "\")",
               false;
      ++column;
    }
    if (cells[1].empty()) return error = where + "column \"object\" is empty", false;
    ObjectPose pose;
    pose.object_id = cells[1];
    pose.translation = {values[1], values[2], values[3]};
    pose.rotation_wxyz = {values[4], values[5], values[6], values[7]};
    if (std::string why; !check_rotation(pose.rotation_wxyz, why))
      return error = where + why, false;
    const double t = values[0];
    if (!result.steps.empty() && t < result.steps.back().time)
      return error = where + "t decreases (times must not decrease)", false;
    if (result.steps.empty() || t != result.steps.back().time) {
      TrajectoryStep step;
      step.time = t;
      result.steps.push_back(std::move(step));
    } else {
      for (const ObjectPose& earlier : result.steps.back().poses)
        if (earlier.object_id == pose.object_id)
          return error =
                     where + "object \"" + pose.object_id + "\" appears twice at t = " + cells[0],
                 false;
    }
    result.steps.back().poses.push_back(std::move(pose));
  }
  if (!header_seen)
    return error = name + ": empty file (expected the CSV header or JSON Lines)", false;
  out = std::move(result);
  return true;
}

}  // namespace

bool parse_trajectory(const std::string& text, const std::string& name, Trajectory& out,
                      std::string& error) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return error = name + ": the trajectory is empty", false;
  if (text[first] == '{') return parse_json_lines(text, name, out, error);
  return parse_csv(text, name, out, error);
}

bool load_trajectory(const std::string& path, Trajectory& out, std::string& error) {
  std::ifstream input(path, std::ios::binary);
  if (!input) return error = "cannot open " + path + ": " + std::strerror(errno), false;
  std::ostringstream text;
  text << input.rdbuf();
  if (input.bad()) return error = "cannot read " + path, false;
  return parse_trajectory(text.str(), path, out, error);
}

}  // namespace nearpoint::cli
