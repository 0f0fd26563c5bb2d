// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <type_traits>
#include <variant>

#include "nearpoint/robots/robot.hpp"

namespace nearpoint::robots {
namespace {

model::PoseInput to_input(const Pose3d& pose) {
  const Eigen::Quaterniond q(pose.rotation);
  model::PoseInput out;
  out.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  out.translation = pose.translation;
  return out;
}

Pose3d from_input(const model::PoseInput& pose) {
  const auto& r = pose.rotation_wxyz;
  return Pose3d::from_quaternion(Eigen::Quaterniond(r[0], r[1], r[2], r[3]), pose.translation);
}

}  // namespace

Pose3d Robot::object_pose(const KinematicState& state, int object) const {
  const RobotObject& o = objects[object];
  return o.link < 0 ? o.offset : state.links[o.link].compose(o.offset);
}

Eigen::VectorXd Robot::joint_gradient(const KinematicState& state, int object_a,
                                      const Vec6d& gradient_a, int object_b,
                                      const Vec6d& gradient_b) const {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(tree.nv());
  tree.add_joint_gradient(state, objects[object_a].link, object_pose(state, object_a).translation,
                          gradient_a, out);
  tree.add_joint_gradient(state, objects[object_b].link, object_pose(state, object_b).translation,
                          gradient_b, out);
  return out;
}

formats::SceneFile Robot::to_scene(const KinematicState& state) const {
  formats::SceneFile out;
  out.scene.name = name;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const RobotObject& o = objects[i];
    out.geometries.emplace_back(o.name, o.geometry);
    out.geometry_names.push_back(o.name);
    model::ObjectInput object;
    object.id = o.name;
    object.pose = to_input(object_pose(state, static_cast<int>(i)));
    object.padding = o.padding;
    out.scene.objects.push_back(std::move(object));
  }
  const std::size_t n = objects.size();
  const std::size_t all = n * (n - (n > 0 ? 1 : 0)) / 2;
  if (pairs.size() == all) {
    out.scene.pair_selection.mode = model::PairSelectionInput::Mode::all_pairs;
  } else if (pairs.size() <= all - pairs.size()) {
    out.scene.pair_selection.mode = model::PairSelectionInput::Mode::listed_pairs;
    for (const auto& [a, b] : pairs)
      out.scene.pair_selection.pairs.emplace_back(objects[a].name, objects[b].name);
  } else {
    out.scene.pair_selection.mode = model::PairSelectionInput::Mode::excluded_pairs;
    std::vector<std::pair<int, int>> sorted = pairs;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = a + 1; b < n; ++b)
        if (!std::binary_search(sorted.begin(), sorted.end(),
                                std::pair<int, int>(static_cast<int>(a), static_cast<int>(b))))
          out.scene.pair_selection.pairs.emplace_back(objects[a].name, objects[b].name);
  }
  return out;
}

std::string make_compound(const model::GeometryInput& geometry, Compound<double>& out) {
  std::vector<Piece<double>> pieces;
  for (const model::PieceInput& input : geometry.pieces) {
    Piece<double> piece;
    piece.offset = from_input(input.offset);
    const bool ok = std::visit(
        [&](const auto& shape) -> bool {
          using T = std::decay_t<decltype(shape)>;
          if constexpr (std::is_same_v<T, std::monostate>) {
            return false;
          } else if constexpr (std::is_same_v<T, model::PolytopeInput>) {
            piece.shape = Shape<double>(Polytope<double>(shape.vertices), input.radius);
            return true;
          } else {
            piece.shape = Shape<double>(shape, input.radius);
            return true;
          }
        },
        input.shape);
    if (!ok) return "geometry '" + geometry.name + "': a piece has no shape";
    if (const char* why = invalid_reason(piece.shape))
      return "geometry '" + geometry.name + "': " + why;
    pieces.push_back(std::move(piece));
  }
  out = Compound<double>(std::move(pieces));
  if (const char* why = out.invalid_reason()) return "geometry '" + geometry.name + "': " + why;
  return {};
}

formats::SceneFile to_robot_scene(const Robot& robot) {
  KinematicState state;
  robot.tree.forward(robot.tree.neutral(), state);
  formats::SceneFile out = robot.to_scene(state);
  // The scene asks for the robot's name as its id (characters outside printable ASCII become
  // '-'), so that `nearpointd --scene` and `nearpoint scene create` name it predictably and a
  // second creation of the same robot is the same scene.
  std::string id = robot.name.substr(0, 128);
  for (char& c : id)
    if (c < 0x21 || c > 0x7E) c = '-';
  out.scene.requested_id = id;
  model::RobotInput& input = out.scene.robot;
  input.name = robot.name;
  for (const Link& link : robot.tree.links) {
    model::RobotLinkInput& l = input.links.emplace_back();
    l.name = link.name;
    if (link.parent >= 0) l.parent = robot.tree.links[std::size_t(link.parent)].name;
    l.offset = to_input(link.offset);
    for (const int j : link.joints) {
      const Joint& joint = robot.tree.joints[std::size_t(j)];
      model::RobotJointInput& in = l.joints.emplace_back();
      in.name = joint.name;
      switch (joint.type) {
        case JointType::fixed:
          in.type = model::JointType::fixed;
          break;
        case JointType::revolute:
          in.type = model::JointType::revolute;
          break;
        case JointType::continuous:
          in.type = model::JointType::continuous;
          break;
        case JointType::prismatic:
          in.type = model::JointType::prismatic;
          break;
        case JointType::ball:
          in.type = model::JointType::ball;
          break;
        case JointType::free:
          in.type = model::JointType::free;
          break;
      }
      in.axis = joint.axis;
      in.anchor = joint.anchor;
      in.reference = joint.reference;
      in.limited = joint.limited;
      in.lower = joint.lower;
      in.upper = joint.upper;
    }
  }
  for (const RobotObject& object : robot.objects)
    if (object.link >= 0)
      input.attachments.push_back(
          {object.name, robot.tree.links[std::size_t(object.link)].name, to_input(object.offset)});
  return out;
}

bool is_robot_file(const std::filesystem::path& file) {
  const std::string ext = file.extension().string();
  if (ext == ".urdf" || ext == ".mjcf") return true;
  if (ext != ".xml") return false;
  // MuJoCo's own models open with a long licence comment: look at the first 64 KiB.
  std::ifstream in(file);
  std::string head(65536, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(std::size_t(in.gcount()));
  return head.find("<mujoco") != std::string::npos;
}

std::string load_robot_scene(const std::filesystem::path& file, const ImportOptions& options,
                             const std::filesystem::path& srdf, formats::SceneFile& out) {
  RobotImport imported;
  if (file.extension() == ".urdf") {
    std::filesystem::path beside = file;
    beside.replace_extension(".srdf");
    std::error_code ignored;
    imported =
        load_urdf(file, options,
                  !srdf.empty()                                       ? srdf
                  : std::filesystem::is_regular_file(beside, ignored) ? beside
                                                                      : std::filesystem::path{});
  } else {
    if (!srdf.empty()) return srdf.string() + ": an SRDF applies to a URDF only";
    imported = load_robot(file, options);
  }
  if (!imported.ok()) return imported.error;
  out = to_robot_scene(imported.robot);
  return {};
}

std::string add_robot_to_scene(formats::SceneFile& file, ImportOptions options) {
  if (!file.robot) return {};
  const formats::RobotReference reference = *file.robot;
  options.search_path.insert(options.search_path.begin(), reference.package_path.begin(),
                             reference.package_path.end());
  formats::SceneFile robot;
  if (std::string error = load_robot_scene(reference.file, options, reference.srdf, robot);
      !error.empty())
    return error;
  using Mode = model::PairSelectionInput::Mode;
  model::PairSelectionInput& pairs = file.scene.pair_selection;
  if (pairs.mode == Mode::listed_pairs)
    return reference.file.string() +
           ": with a \"robot\", \"pairs\" must be \"all\" or {\"excluded\": ...} (a listed "
           "selection would have to name the robot's pairs)";
  // The robot's left-out pairs, as names.
  const model::PairSelectionInput& chosen = robot.scene.pair_selection;
  std::vector<std::pair<std::string, std::string>> left_out;
  if (chosen.mode == Mode::excluded_pairs) {
    left_out = chosen.pairs;
  } else if (chosen.mode == Mode::listed_pairs) {
    std::set<std::pair<std::string, std::string>> listed;
    for (const auto& [a, b] : chosen.pairs) listed.emplace(std::min(a, b), std::max(a, b));
    const std::vector<model::ObjectInput>& objects = robot.scene.objects;
    for (std::size_t a = 0; a < objects.size(); ++a)
      for (std::size_t b = a + 1; b < objects.size(); ++b)
        if (!listed.count(
                {std::min(objects[a].id, objects[b].id), std::max(objects[a].id, objects[b].id)}))
          left_out.emplace_back(objects[a].id, objects[b].id);
  }
  if (!left_out.empty()) {
    pairs.mode = Mode::excluded_pairs;
    pairs.pairs.insert(pairs.pairs.end(), left_out.begin(), left_out.end());
  }
  for (auto& geometry : robot.geometries) file.geometries.push_back(std::move(geometry));
  for (std::size_t i = 0; i < robot.scene.objects.size(); ++i) {
    file.scene.objects.push_back(std::move(robot.scene.objects[i]));
    file.geometry_names.push_back(robot.geometry_names[i]);
  }
  file.scene.robot = std::move(robot.scene.robot);
  if (file.scene.requested_id.empty()) file.scene.requested_id = robot.scene.requested_id;
  file.robot.reset();
  return {};
}

RobotImport load_robot(const std::filesystem::path& file, const ImportOptions& options) {
  const std::string ext = file.extension().string();
  if (ext == ".urdf") return load_urdf(file, options);
  if (ext == ".xml" || ext == ".mjcf") return load_mjcf(file, options);
  RobotImport out;
  out.error =
      file.string() + ": unknown robot description (expected .urdf, or .xml/.mjcf for MJCF)";
  return out;
}

}  // namespace nearpoint::robots
