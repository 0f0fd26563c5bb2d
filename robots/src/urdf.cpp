// SPDX-License-Identifier: Apache-2.0
// URDF through urdfdom (its parser, its messages), SRDF through tinyxml2.
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>

#include <console_bridge/console.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include "common.hpp"

namespace nearpoint::robots {
namespace {

// urdfdom reports why a parse failed through console_bridge's process-wide output handler; the
// handler is swapped in under a lock for the length of one parse so that the reason reaches the
// caller instead of stderr.
class CapturedLog : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) {
      if (!errors.empty()) errors += "; ";
      errors += text;
    }
  }
  std::string errors;
};

std::mutex& console_mutex() {
  static std::mutex mutex;
  return mutex;
}

Pose3d to_pose(const urdf::Pose& pose) {
  Pose3d out;
  out.rotation =
      Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
          .normalized()
          .toRotationMatrix();
  out.translation = Vec3d(pose.position.x, pose.position.y, pose.position.z);
  return out;
}

bool finite_pose(const urdf::Pose& pose) {
  const double values[] = {pose.position.x, pose.position.y, pose.position.z, pose.rotation.x,
                           pose.rotation.y, pose.rotation.z, pose.rotation.w};
  for (const double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

Vec3d to_vec(const urdf::Vector3& v) {
  return Vec3d(v.x, v.y, v.z);
}

struct Builder {
  const std::string& label;
  const std::filesystem::path& base_dir;
  const ImportOptions& options;
  Robot& robot;
  std::string error;

  bool fail(const std::string& where, const std::string& why) {
    error = label + ": " + where + ": " + why;
    return false;
  }

  bool add_link(const urdf::LinkConstSharedPtr& link, int parent) {
    Link out;
    out.name = link->name;
    out.parent = parent;
    const int index = static_cast<int>(robot.tree.links.size());
    if (const urdf::JointSharedPtr& joint = link->parent_joint) {
      const std::string where = "joint '" + joint->name + "'";
      if (!finite_pose(joint->parent_to_joint_origin_transform))
        return fail(where + " <origin>", "not finite");
      out.offset = to_pose(joint->parent_to_joint_origin_transform);
      Joint j;
      j.name = joint->name;
      j.link = index;
      switch (joint->type) {
        case urdf::Joint::REVOLUTE:
          j.type = JointType::revolute;
          break;
        case urdf::Joint::CONTINUOUS:
          j.type = JointType::continuous;
          break;
        case urdf::Joint::PRISMATIC:
          j.type = JointType::prismatic;
          break;
        case urdf::Joint::FIXED:
          j.type = JointType::fixed;
          break;
        case urdf::Joint::FLOATING:
          return fail(where, "type 'floating' is not supported (place the robot's base instead)");
        case urdf::Joint::PLANAR:
          return fail(where, "type 'planar' is not supported");
        default:
          return fail(where, "unknown joint type");
      }
      if (joint->mimic) return fail(where + " <mimic>", "mimic joints are not supported");
      if (j.type != JointType::fixed) {
        j.axis = to_vec(joint->axis);
        if (!detail::finite(j.axis) || !(j.axis.norm() > 0))
          return fail(where + " <axis>", "must be finite and non-zero");
      }
      if ((j.type == JointType::revolute || j.type == JointType::prismatic) && joint->limits) {
        j.limited = true;
        j.lower = joint->limits->lower;
        j.upper = joint->limits->upper;
        if (!std::isfinite(j.lower) || !std::isfinite(j.upper))
          return fail(where + " <limit>", "lower and upper must be finite");
      }
      out.joints.push_back(static_cast<int>(robot.tree.joints.size()));
      robot.tree.joints.push_back(std::move(j));
    }
    robot.tree.links.push_back(std::move(out));
    if (!add_geometry(*link, index)) return false;
    // Children in name order: the joint order (and so q's layout) does not depend on urdfdom's
    // container order.
    std::vector<urdf::LinkSharedPtr> children = link->child_links;
    std::sort(children.begin(), children.end(),
              [](const auto& a, const auto& b) { return a->name < b->name; });
    for (const urdf::LinkSharedPtr& child : children)
      if (!add_link(child, index)) return false;
    return true;
  }

  bool add_geometry(const urdf::Link& link, int index) {
    if (link.collision_array.empty()) return true;
    RobotObject object;
    object.name = link.name;
    object.link = index;
    object.geometry.name = link.name;
    for (std::size_t c = 0; c < link.collision_array.size(); ++c) {
      const urdf::Collision& collision = *link.collision_array[c];
      const std::string where = "link '" + link.name + "' <collision> " + std::to_string(c) +
                                (collision.name.empty() ? "" : " ('" + collision.name + "')");
      if (!finite_pose(collision.origin)) return fail(where + " <origin>", "not finite");
      if (!collision.geometry) return fail(where, "no <geometry>");
      model::PieceInput piece;
      piece.offset = detail::to_input(to_pose(collision.origin));
      const urdf::Geometry& geometry = *collision.geometry;
      switch (geometry.type) {
        case urdf::Geometry::SPHERE: {
          const double r = static_cast<const urdf::Sphere&>(geometry).radius;
          if (!std::isfinite(r) || r <= 0) return fail(where + " <sphere>", "radius must be > 0");
          piece.shape = Point{};
          piece.radius = r;
          break;
        }
        case urdf::Geometry::BOX: {
          const Vec3d size = to_vec(static_cast<const urdf::Box&>(geometry).dim);
          if (!detail::finite(size) || (size.array() <= 0).any())
            return fail(where + " <box>", "size must be finite and > 0");
          piece.shape = Box<double>{size / 2};
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const auto& cylinder = static_cast<const urdf::Cylinder&>(geometry);
          if (!std::isfinite(cylinder.radius) || !std::isfinite(cylinder.length) ||
              cylinder.radius <= 0 || cylinder.length <= 0)
            return fail(where + " <cylinder>", "radius and length must be finite and > 0");
          piece.shape = Cylinder<double>{cylinder.radius, cylinder.length / 2};
          break;
        }
        case urdf::Geometry::MESH: {
          const auto& mesh = static_cast<const urdf::Mesh&>(geometry);
          std::filesystem::path file;
          if (std::string why = detail::resolve_mesh(mesh.filename, base_dir, options, file);
              !why.empty())
            return fail(where + " <mesh>", why);
          if (std::string why = detail::load_mesh_piece(file, to_vec(mesh.scale), options, piece);
              !why.empty())
            return fail(where + " <mesh>", why);
          break;
        }
        default:
          return fail(where, "unsupported geometry type");
      }
      object.geometry.pieces.push_back(std::move(piece));
    }
    robot.objects.push_back(std::move(object));
    return true;
  }
};

// Links with two parents and joint cycles (a joint from a link to itself included), refused before
// urdfdom sees them: its link tree holds children by shared pointer, so a cycle is never freed
// (found by fuzz_robots under LeakSanitizer). XML that tinyxml2 refuses is refused here too, not
// left to urdfdom: its parser accepts some of it, and this check must see what urdfdom sees.
std::string check_joint_graph(const std::string& xml, const std::string& label) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS)
    return label + ": not valid XML (line " + std::to_string(doc.ErrorLineNum()) + ": " +
           doc.ErrorStr() + ")";
  const tinyxml2::XMLElement* robot = doc.RootElement();
  if (robot == nullptr) return {};
  std::map<std::string, std::string> parent_of;
  for (const tinyxml2::XMLElement* joint = robot->FirstChildElement("joint"); joint != nullptr;
       joint = joint->NextSiblingElement("joint")) {
    const tinyxml2::XMLElement* parent = joint->FirstChildElement("parent");
    const tinyxml2::XMLElement* child = joint->FirstChildElement("child");
    const char* p = parent != nullptr ? parent->Attribute("link") : nullptr;
    const char* c = child != nullptr ? child->Attribute("link") : nullptr;
    if (p == nullptr || c == nullptr) continue;  // urdfdom names what is missing
    const char* name = joint->Attribute("name");
    const std::string where = label + ": joint '" + (name != nullptr ? name : "") + "'";
    if (!parent_of.emplace(c, p).second)
      return where + ": link '" + c + "' already has a parent joint";
  }
  for (const auto& [start, unused] : parent_of) {
    std::set<std::string> seen{start};
    for (auto it = parent_of.find(start); it != parent_of.end(); it = parent_of.find(it->second))
      if (!seen.insert(it->second).second)
        return label + ": the joints form a cycle through link '" + it->second + "'";
  }
  return {};
}

}  // namespace

RobotImport parse_urdf(const std::string& xml, const std::string& label,
                       const std::filesystem::path& base_dir, const ImportOptions& options) {
  RobotImport out;
  if (std::string why = check_joint_graph(xml, label); !why.empty()) {
    out.error = why;
    return out;
  }
  urdf::ModelInterfaceSharedPtr model;
  {
    std::lock_guard<std::mutex> lock(console_mutex());
    CapturedLog log;
    console_bridge::useOutputHandler(&log);
    try {
      model = urdf::parseURDF(xml);
    } catch (const std::exception& e) {
      log.errors += e.what();
      model.reset();
    }
    console_bridge::restorePreviousOutputHandler();
    // urdfdom logs some errors and carries on without the element (a <collision> whose origin
    // does not parse is dropped): any error it logs refuses the file.
    if (!model || !log.errors.empty()) {
      out.error = label + ": not a valid URDF (urdfdom: " +
                  (log.errors.empty() ? std::string("no reason given") : log.errors) + ")";
      return out;
    }
  }
  // Should the two parsers ever disagree on the joints, a cycle urdfdom built is still freed.
  struct BreakCycles {
    urdf::ModelInterface& model;
    ~BreakCycles() {
      for (auto& [name, link] : model.links_)
        if (link) link->child_links.clear();
    }
  } break_cycles{*model};
  Robot& robot = out.robot;
  robot.name = model->getName();
  const urdf::LinkConstSharedPtr root = model->getRoot();
  if (!root) {
    out.error = label + ": no root link";
    return out;
  }
  Builder builder{label, base_dir, options, robot, {}};
  if (!builder.add_link(root, -1)) {
    out.error = builder.error;
    return out;
  }
  if (std::string why = robot.tree.finalize(); !why.empty()) {
    out.error = label + ": " + why;
    return out;
  }
  std::vector<double> padding;
  if (std::string why = detail::link_padding(robot.tree, options, padding); !why.empty()) {
    out.error = label + ": " + why;
    return out;
  }
  // Pairs: all, minus each object's link and the nearest ancestor link that has an object
  // (links without geometry are transparent, as MoveIt's setup assistant treats them).
  std::vector<int> object_of(robot.tree.links.size(), -1);
  for (std::size_t i = 0; i < robot.objects.size(); ++i) {
    object_of[robot.objects[i].link] = static_cast<int>(i);
    robot.objects[i].padding = padding[robot.objects[i].link];
  }
  std::set<std::pair<int, int>> excluded;
  if (options.exclude_adjacent) {
    for (std::size_t i = 0; i < robot.objects.size(); ++i) {
      int l = robot.tree.links[robot.objects[i].link].parent;
      while (l >= 0 && object_of[l] < 0) l = robot.tree.links[l].parent;
      if (l >= 0) excluded.insert(std::minmax(static_cast<int>(i), object_of[l]));
    }
  }
  for (int a = 0; a < static_cast<int>(robot.objects.size()); ++a)
    for (int b = a + 1; b < static_cast<int>(robot.objects.size()); ++b)
      if (!excluded.count({a, b})) robot.pairs.emplace_back(a, b);
  return out;
}

RobotImport load_urdf(const std::filesystem::path& file, const ImportOptions& options,
                      const std::filesystem::path& srdf) {
  RobotImport out;
  std::string xml;
  if (std::string why = detail::read_file(file, xml); !why.empty()) {
    out.error = why;
    return out;
  }
  out = parse_urdf(xml, file.string(), file.parent_path(), options);
  if (!out.ok() || srdf.empty()) return out;
  std::string srdf_xml;
  if (std::string why = detail::read_file(srdf, srdf_xml); !why.empty()) {
    out.error = why;
    return out;
  }
  out.error = apply_srdf(srdf_xml, srdf.string(), out.robot);
  return out;
}

std::string apply_srdf(const std::string& xml, const std::string& label, Robot& robot) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS)
    return label + ": not valid XML (line " + std::to_string(doc.ErrorLineNum()) + ": " +
           doc.ErrorStr() + ")";
  const tinyxml2::XMLElement* root = doc.RootElement();
  if (root == nullptr || std::string_view(root->Name()) != "robot")
    return label + ": the root element must be <robot>";
  // Object index by link name (URDF objects are named after their links).
  std::map<std::string, int> object_of;
  for (std::size_t i = 0; i < robot.objects.size(); ++i)
    object_of[robot.objects[i].name] = static_cast<int>(i);
  std::set<std::pair<int, int>> pairs(robot.pairs.begin(), robot.pairs.end());
  auto link_object = [&](const tinyxml2::XMLElement* e, const char* attribute, int& object,
                         std::string& error) {
    const char* name = e->Attribute(attribute);
    const std::string where =
        label + ": line " + std::to_string(e->GetLineNum()) + " <" + e->Name() + ">";
    if (name == nullptr) {
      error = where + ": no '" + attribute + "' attribute";
      return false;
    }
    if (robot.tree.find_link(name) < 0) {
      error = where + ": link '" + name + "' is not in the robot";
      return false;
    }
    const auto it = object_of.find(name);
    object = it == object_of.end() ? -1 : it->second;  // a link without geometry: no pairs
    return true;
  };
  for (const tinyxml2::XMLElement* e = root->FirstChildElement(); e != nullptr;
       e = e->NextSiblingElement()) {
    const std::string_view tag = e->Name();
    std::string error;
    if (tag == "disable_collisions" || tag == "enable_collisions") {
      int a = -1;
      int b = -1;
      if (!link_object(e, "link1", a, error) || !link_object(e, "link2", b, error)) return error;
      if (a < 0 || b < 0 || a == b) continue;
      if (tag == "disable_collisions")
        pairs.erase(std::minmax(a, b));
      else
        pairs.insert(std::minmax(a, b));
    } else if (tag == "disable_default_collisions") {
      int a = -1;
      if (!link_object(e, "link", a, error)) return error;
      for (auto it = pairs.begin(); it != pairs.end();)
        it = (it->first == a || it->second == a) ? pairs.erase(it) : std::next(it);
    } else if (tag == "group" || tag == "group_state" || tag == "end_effector" ||
               tag == "virtual_joint" || tag == "passive_joint" ||
               tag == "link_sphere_approximation") {
      // Planning semantics with no bearing on which pairs are checked.
    } else {
      return label + ": line " + std::to_string(e->GetLineNum()) + ": <" + std::string(tag) +
             "> is not supported";
    }
  }
  robot.pairs.assign(pairs.begin(), pairs.end());
  return {};
}

}  // namespace nearpoint::robots
