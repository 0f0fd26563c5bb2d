#include "trajectory.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

namespace nearpoint::cli {
namespace {

using Json = nlohmann::json;

std::string at_line(const std::string& path, std::size_t line) {
  return path + ":" + std::to_string(line) + ": ";
}

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Reads a JSON array of `N` finite numbers into `out`; an error message otherwise.
template <std::size_t N>
std::string read_numbers(const Json& value, std::array<double, N>& out) {
  if (!value.is_array() || value.size() != N)
    return "must be an array of " + std::to_string(N) + " numbers";
  for (std::size_t i = 0; i < N; ++i) {
    if (!value[i].is_number()) return "element " + std::to_string(i) + " is not a number";
    out[i] = value[i].get<double>();
    if (!std::isfinite(out[i])) return "element " + std::to_string(i) + " is not finite";
  }
  return {};
}

/// Appends `pose` to `step` unless its object is already there.
std::string add_pose(TrajectoryStep& step, ObjectPose pose) {
  for (const ObjectPose& existing : step.poses)
    if (existing.object_id == pose.object_id)
      return "object '" + pose.object_id + "' is given twice at t = " + std::to_string(step.time);
  step.poses.push_back(std::move(pose));
  return {};
}

bool load_json_lines(std::istream& in, const std::string& path, Trajectory& out,
                     std::string& error) {
  std::string text;
  for (std::size_t line = 1; std::getline(in, text); ++line) {
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = at_line(path, line);
    Json value = Json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (value.is_discarded()) return error = where + "not valid JSON", false;
    if (!value.is_object()) return error = where + "must be a JSON object", false;
    for (const auto& [key, unused] : value.items())
      if (key != "t" && key != "poses")
        return error = where + "unknown key \"" + key + "\" (expected \"t\" and \"poses\")",
               false;
    TrajectoryStep step;
    const auto time = value.find("t");
    if (time == value.end() || !time->is_number())
      return error = where + "\"t\" must be a number (seconds)", false;
    step.time = time->get<double>();
    if (!std::isfinite(step.time)) return error = where + "\"t\" is not finite", false;
    const auto poses = value.find("poses");
    if (poses == value.end() || !poses->is_object())
      return error = where + "\"poses\" must be an object: {\"OBJECT\": {\"rotation\": ..., "
                             "\"translation\": ...}}",
             false;
    for (const auto& [object, pose_value] : poses->items()) {
      const std::string field = where + "\"poses\".\"" + object + "\"";
      if (!pose_value.is_object()) return error = field + ": must be an object", false;
      ObjectPose pose;
      pose.object_id = object;
      for (const auto& [key, part] : pose_value.items()) {
        std::string problem;
        if (key == "rotation")
          problem = read_numbers(part, pose.rotation_wxyz);
        else if (key == "translation")
          problem = read_numbers(part, pose.translation);
        else
          problem = "unknown key (expected \"rotation\" and \"translation\")";
        if (!problem.empty()) return error = field + ".\"" + key + "\": " + problem, false;
      }
      step.poses.push_back(std::move(pose));
    }
    if (!out.steps.empty() && step.time < out.steps.back().time)
      return error = where + "\"t\" goes backwards", false;
    out.steps.push_back(std::move(step));
  }
  return true;
}

/// Splits a CSV row at commas (no quoting: every cell is a name or a number).
std::vector<std::string> split_row(const std::string& row) {
  std::vector<std::string> cells;
  std::stringstream in(row);
  std::string cell;
  while (std::getline(in, cell, ',')) {
    const auto begin = cell.find_first_not_of(" \t\r");
    const auto end = cell.find_last_not_of(" \t\r");
    cells.push_back(begin == std::string::npos ? std::string() : cell.substr(begin, end - begin + 1));
  }
  if (!row.empty() && row.back() == ',') cells.emplace_back();
  return cells;
}

bool load_csv(std::istream& in, const std::string& path, Trajectory& out, std::string& error) {
  static const std::vector<std::string> kHeader = {"t",  "object", "tx", "ty", "tz",
                                                   "qw", "qx",     "qy", "qz"};
  std::string text;
  std::size_t line = 0;
  bool header_seen = false;
  while (std::getline(in, text)) {
    ++line;
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = at_line(path, line);
    const std::vector<std::string> cells = split_row(text);
    if (!header_seen) {
      if (cells != kHeader)
        return error = where + "the header must be t,object,tx,ty,tz,qw,qx,qy,qz", false;
      header_seen = true;
      continue;
    }
    if (cells.size() != kHeader.size())
      return error = where + "has " + std::to_string(cells.size()) + " cells; expected 9", false;
    std::array<double, 9> numbers{};
    for (std::size_t i = 0; i < cells.size(); ++i) {
      if (i == 1) continue;
      const char* begin = cells[i].c_str();
      char* end = nullptr;
      errno = 0;
      numbers[i] = std::strtod(begin, &end);
      if (cells[i].empty() || end != begin + cells[i].size() || errno == ERANGE)
        return error = where + kHeader[i] + ": '" + cells[i] + "' is not a number", false;
      if (!std::isfinite(numbers[i])) return error = where + kHeader[i] + ": is not finite", false;
    }
    if (cells[1].empty()) return error = where + "object: is empty", false;
    ObjectPose pose;
    pose.object_id = cells[1];
    pose.translation = {numbers[2], numbers[3], numbers[4]};
    pose.rotation_wxyz = {numbers[5], numbers[6], numbers[7], numbers[8]};
    const double time = numbers[0];
    if (out.steps.empty() || time != out.steps.back().time) {
      if (!out.steps.empty() && time < out.steps.back().time)
        return error = where + "t goes backwards", false;
      out.steps.push_back(TrajectoryStep{time, {}});
    }
    if (std::string problem = add_pose(out.steps.back(), std::move(pose)); !problem.empty())
      return error = where + problem, false;
  }
  if (!header_seen) return error = path + ": empty (no header t,object,tx,ty,tz,qw,qx,qy,qz)", false;
  return true;
}

}  // namespace

bool load_trajectory(const std::string& path, Trajectory& out, std::string& error) {
  out.steps.clear();
  std::ifstream in(path);
  if (!in) return error = path + ": cannot open: " + std::strerror(errno), false;
  const bool ok = ends_with(path, ".csv") ? load_csv(in, path, out, error)
                                          : load_json_lines(in, path, out, error);
  if (ok && in.bad()) return error = path + ": read error", false;
  return ok;
}

}  // namespace nearpoint::cli
