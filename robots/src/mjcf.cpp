// SPDX-License-Identifier: Apache-2.0
// MJCF (MuJoCo's XML) read with tinyxml2, following MuJoCo's compiler where it decides geometry
// and kinematics: <compiler angle eulerseq meshdir assetdir>, <default> classes with childclass,
// <include>, frames (pos, quat, axisangle, euler, xyaxes, zaxis; fromto for geoms), joints, and
// MuJoCo's collision filtering (contype/conaffinity, weld groups, filterparent, <exclude>, <pair>).
#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include <tinyxml2.h>

#include "common.hpp"

namespace nearpoint::robots {
namespace {

using tinyxml2::XMLElement;
using Attributes = std::map<std::string, std::string>;

// Elements that carry no collision geometry and no kinematics: read past, by name.
const std::set<std::string_view> kIgnoredTop = {"option",   "size",   "visual",   "statistic",
                                                "actuator", "sensor", "tendon",   "equality",
                                                "keyframe", "custom", "extension"};
const std::set<std::string_view> kIgnoredInBody = {"inertial", "site", "camera", "light"};
const std::set<std::string_view> kIgnoredAssets = {"texture", "material", "skin"};
constexpr int kMaxIncludeDepth = 16;
constexpr int kMaxBodyDepth = 1000;

struct DefaultClass {
  std::string parent;
  // element tag ("geom", "joint", "mesh") → attribute → value
  std::map<std::string, Attributes> elements;
};

struct MeshAsset {
  std::string name;
  std::filesystem::path file;
  std::vector<double> vertices;  // inline vertex="…" (x y z …)
  Vec3d scale = Vec3d::Ones();
};

struct GeomInfo {
  int object = -1;  // index in robot.objects, or -1 when the geom can never collide
  int body = 0;     // MuJoCo body id (0: world)
  unsigned contype = 1;
  unsigned conaffinity = 1;
};

class Parser {
 public:
  Parser(const std::string& label, const std::filesystem::path& base_dir,
         const ImportOptions& options, Robot& robot)
      : label_(label), base_dir_(base_dir), options_(options), robot_(robot) {}

  std::string run(const std::string& xml) {
    if (doc_.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS)
      return label_ + ": not valid XML (line " + std::to_string(doc_.ErrorLineNum()) + ": " +
             doc_.ErrorStr() + ")";
    XMLElement* root = doc_.RootElement();
    if (root == nullptr || std::string_view(root->Name()) != "mujoco")
      return label_ + ": the root element must be <mujoco>";
    if (!expand_includes(root, base_dir_, 0)) return error_;
    if (const char* model = root->Attribute("model")) robot_.name = model;
    if (!read_compiler(root) || !read_defaults(root) || !read_assets(root) || !read_option(root))
      return error_;
    // Body 0 is the world.
    bodies_.push_back({"world", -1, false});
    for (XMLElement* e = root->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
      const std::string_view tag = e->Name();
      if (tag == "worldbody") {
        if (!read_body_children(e, 0, "main", 0)) return error_;
      } else if (tag == "compiler" || tag == "default" || tag == "asset" || tag == "contact" ||
                 kIgnoredTop.count(tag)) {
        continue;
      } else {
        return where(e) + ": <" + std::string(tag) + "> is not supported";
      }
    }
    if (std::string why = robot_.tree.finalize(); !why.empty()) return label_ + ": " + why;
    if (!read_contact(root)) return error_;
    std::vector<double> padding;
    if (std::string why = detail::link_padding(robot_.tree, options_, padding); !why.empty())
      return label_ + ": " + why;
    for (RobotObject& object : robot_.objects)
      object.padding = object.link < 0 ? options_.default_padding : padding[object.link];
    select_pairs();
    return {};
  }

 private:
  struct BodyInfo {
    std::string name;
    int parent;  // MuJoCo body id, -1 for the world
    bool has_joints;
  };

  // ---- messages ----
  std::string where(const XMLElement* e) const {
    std::string out = label_ + ": line " + std::to_string(e->GetLineNum()) + " <" + e->Name();
    if (const char* name = e->Attribute("name")) out += " name=\"" + std::string(name) + "\"";
    return out + ">";
  }
  bool fail(const XMLElement* e, const std::string& why) {
    error_ = where(e) + ": " + why;
    return false;
  }

  // ---- <include file="…"/>: the included <mujoco>'s children take the include's place ----
  bool expand_includes(XMLElement* parent, const std::filesystem::path& dir, int depth) {
    for (XMLElement* e = parent->FirstChildElement(); e != nullptr;) {
      if (std::string_view(e->Name()) != "include") {
        if (!expand_includes(e, dir, depth)) return false;
        e = e->NextSiblingElement();
        continue;
      }
      if (depth >= kMaxIncludeDepth)
        return fail(
            e, "includes nested deeper than " + std::to_string(kMaxIncludeDepth) + " (a cycle?)");
      const char* file = e->Attribute("file");
      if (file == nullptr) return fail(e, "no 'file' attribute");
      const std::filesystem::path path = dir / file;
      std::string xml;
      if (std::string why = detail::read_file(path, xml); !why.empty()) return fail(e, why);
      tinyxml2::XMLDocument included;
      if (included.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS)
        return fail(e, path.string() + ": not valid XML (line " +
                           std::to_string(included.ErrorLineNum()) + ": " + included.ErrorStr() +
                           ")");
      const XMLElement* root = included.RootElement();
      if (root == nullptr || std::string_view(root->Name()) != "mujoco")
        return fail(e, path.string() + ": the root element must be <mujoco>");
      XMLElement* const next = e->NextSiblingElement();
      tinyxml2::XMLNode* after = e;
      XMLElement* first = nullptr;
      for (const XMLElement* c = root->FirstChildElement(); c != nullptr;
           c = c->NextSiblingElement()) {
        tinyxml2::XMLNode* copy = c->DeepClone(&doc_);
        after = parent->InsertAfterChild(after, copy);
        if (first == nullptr) first = after->ToElement();
      }
      parent->DeleteChild(e);
      // The copies may include in turn (relative to the included file's directory).
      for (XMLElement* c = first; c != nullptr && c != next; c = c->NextSiblingElement()) {
        if (std::string_view(c->Name()) == "include") {
          // A top-level include of an included file (nested ones below are expanded).
          return fail(c, "an <include> at the top of an included file is not supported");
        }
        if (!expand_includes(c, path.parent_path(), depth + 1)) return false;
      }
      e = next;
    }
    return true;
  }

  // ---- attribute values ----
  bool numbers(const XMLElement* e, const char* attribute, const std::string& text,
               std::vector<double>& out) {
    out.clear();
    const char* p = text.c_str();
    while (true) {
      while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
      if (*p == '\0') break;
      char* end = nullptr;
      const double value = std::strtod(p, &end);
      if (end == p)
        return fail(
            e, std::string("attribute '") + attribute + "': not a number list: \"" + text + "\"");
      if (!std::isfinite(value))
        return fail(e, std::string("attribute '") + attribute + "': not finite: \"" + text + "\"");
      out.push_back(value);
      p = end;
    }
    return true;
  }
  // The attribute as given on the element, else from its class (already resolved).
  std::optional<std::string> get(const XMLElement* e, const Attributes& defaults,
                                 const char* attribute) const {
    if (const char* value = e->Attribute(attribute)) return std::string(value);
    if (auto it = defaults.find(attribute); it != defaults.end()) return it->second;
    return std::nullopt;
  }
  // Exactly `count` numbers (or between min_count and count with `at_most`).
  bool vec(const XMLElement* e, const Attributes& defaults, const char* attribute,
           std::size_t count, std::vector<double>& out, bool& present) {
    const auto text = get(e, defaults, attribute);
    present = text.has_value();
    if (!present) return true;
    if (!numbers(e, attribute, *text, out)) return false;
    if (out.size() != count)
      return fail(e, std::string("attribute '") + attribute + "': expected " +
                         std::to_string(count) + " numbers, got " + std::to_string(out.size()));
    return true;
  }

  // ---- <compiler> ----
  bool read_compiler(XMLElement* root) {
    for (XMLElement* e = root->FirstChildElement("compiler"); e != nullptr;
         e = e->NextSiblingElement("compiler")) {
      if (const char* angle = e->Attribute("angle")) {
        if (std::string_view(angle) == "radian")
          degrees_ = false;
        else if (std::string_view(angle) == "degree")
          degrees_ = true;
        else
          return fail(e, "attribute 'angle' must be degree or radian");
      }
      if (const char* seq = e->Attribute("eulerseq")) {
        const std::string s = seq;
        if (s.size() != 3 || s.find_first_not_of("xyzXYZ") != std::string::npos)
          return fail(e, "attribute 'eulerseq' must be three of x, y, z, X, Y, Z");
        eulerseq_ = s;
      }
      if (const char* dir = e->Attribute("assetdir")) meshdir_ = dir;
      if (const char* dir = e->Attribute("meshdir")) meshdir_ = dir;
      if (const char* autolimits = e->Attribute("autolimits"))
        autolimits_ = std::string_view(autolimits) == "true";
      if (const char* coordinate = e->Attribute("coordinate"))
        if (std::string_view(coordinate) != "local")
          return fail(e, "coordinate=\"" + std::string(coordinate) + "\" is not supported");
      if (const char* fuse = e->Attribute("fusestatic"))
        if (std::string_view(fuse) == "true")
          return fail(e, "fusestatic=\"true\" is not supported");
    }
    return true;
  }

  // ---- <option> ----
  bool read_option(XMLElement* root) {
    for (XMLElement* e = root->FirstChildElement("option"); e != nullptr;
         e = e->NextSiblingElement("option")) {
      if (const char* collision = e->Attribute("collision")) {
        const std::string_view c = collision;
        if (c == "all")
          collision_ = Collision::all;
        else if (c == "predefined")
          collision_ = Collision::predefined;
        else if (c == "dynamic")
          collision_ = Collision::dynamic;
        else
          return fail(e, "attribute 'collision' must be all, predefined or dynamic");
      }
      for (XMLElement* flag = e->FirstChildElement("flag"); flag != nullptr;
           flag = flag->NextSiblingElement("flag")) {
        if (const char* value = flag->Attribute("filterparent"))
          filterparent_ = std::string_view(value) != "disable";
        if (const char* value = flag->Attribute("contact"))
          if (std::string_view(value) == "disable") contact_disabled_ = true;
      }
    }
    return true;
  }

  // ---- <default> ----
  bool read_defaults(XMLElement* root) {
    classes_["main"] = DefaultClass{};
    for (XMLElement* e = root->FirstChildElement("default"); e != nullptr;
         e = e->NextSiblingElement("default")) {
      // The top-level <default> is class "main" (it may also be named so).
      if (!read_default(e, "main", "", true)) return false;
    }
    return true;
  }
  bool read_default(XMLElement* e, const std::string& name, const std::string& parent, bool top) {
    if (!top) {
      if (classes_.count(name)) return fail(e, "default class '" + name + "' is defined twice");
      classes_[name] = classes_[parent];
      classes_[name].parent = parent;
    }
    for (XMLElement* c = e->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
      const std::string tag = c->Name();
      if (tag == "default") {
        const char* child = c->Attribute("class");
        if (child == nullptr) return fail(c, "a nested <default> needs a 'class'");
        if (!read_default(c, child, name, false)) return false;
        continue;
      }
      Attributes& attributes = classes_[name].elements[tag];
      for (const tinyxml2::XMLAttribute* a = c->FirstAttribute(); a != nullptr; a = a->Next())
        attributes[a->Name()] = a->Value();
    }
    return true;
  }
  bool class_attributes(const XMLElement* e, const std::string& inherited, const char* tag,
                        Attributes& out) {
    std::string name = inherited;
    if (const char* c = e->Attribute("class")) name = c;
    const auto it = classes_.find(name);
    if (it == classes_.end()) return fail(e, "unknown default class '" + name + "'");
    const auto element = it->second.elements.find(tag);
    out = element == it->second.elements.end() ? Attributes{} : element->second;
    return true;
  }

  // ---- <asset><mesh> ----
  bool read_assets(XMLElement* root) {
    for (XMLElement* asset = root->FirstChildElement("asset"); asset != nullptr;
         asset = asset->NextSiblingElement("asset")) {
      for (XMLElement* e = asset->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
        const std::string_view tag = e->Name();
        if (kIgnoredAssets.count(tag)) continue;
        if (tag == "hfield") continue;  // only an error if a geom uses it (below)
        if (tag != "mesh") return fail(e, "<" + std::string(tag) + "> is not supported");
        Attributes defaults;
        if (!class_attributes(e, "main", "mesh", defaults)) return false;
        MeshAsset mesh;
        const char* file = e->Attribute("file");
        if (file != nullptr) mesh.file = file;
        if (const char* name = e->Attribute("name"))
          mesh.name = name;
        else if (file != nullptr)
          mesh.name = std::filesystem::path(file).stem().string();
        else
          return fail(e, "a mesh needs a 'name' or a 'file'");
        std::vector<double> values;
        bool present = false;
        if (!vec(e, defaults, "scale", 3, values, present)) return false;
        if (present) mesh.scale = Vec3d(values[0], values[1], values[2]);
        if (const auto vertex = get(e, defaults, "vertex")) {
          if (!numbers(e, "vertex", *vertex, mesh.vertices)) return false;
          if (mesh.vertices.empty() || mesh.vertices.size() % 3 != 0)
            return fail(e, "attribute 'vertex': a positive multiple of 3 numbers expected");
        }
        if (file == nullptr && mesh.vertices.empty())
          return fail(e, "a mesh needs a 'file' or 'vertex'");
        for (const char* unsupported : {"refpos", "refquat", "smoothnormal"})
          if (get(e, defaults, unsupported))
            return fail(e, std::string("attribute '") + unsupported + "' is not supported");
        if (meshes_.count(mesh.name)) return fail(e, "mesh '" + mesh.name + "' defined twice");
        meshes_[mesh.name] = std::move(mesh);
      }
    }
    return true;
  }

  // ---- frames ----
  Eigen::Quaterniond axis_angle(const Vec3d& axis, double angle) const {
    const double n = axis.norm();
    if (!(n > 0)) return Eigen::Quaterniond::Identity();
    return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis / n));
  }
  double angle(double value) const { return degrees_ ? value * M_PI / 180.0 : value; }
  // MuJoCo's mjuu_z2quat: the least rotation taking +z to `v`.
  static Eigen::Quaterniond z_to(const Vec3d& v) {
    Vec3d axis = Vec3d::UnitZ().cross(v);
    const double s = axis.norm();
    if (s < 1e-10)
      axis = Vec3d::UnitX();
    else
      axis /= s;
    const double a = std::atan2(s, v.z());
    return Eigen::Quaterniond(std::cos(a / 2), axis.x() * std::sin(a / 2),
                              axis.y() * std::sin(a / 2), axis.z() * std::sin(a / 2));
  }
  // pos and one of quat/axisangle/euler/xyaxes/zaxis → `out`.
  bool frame(const XMLElement* e, const Attributes& defaults, Pose3d& out) {
    std::vector<double> v;
    bool present = false;
    Vec3d pos = Vec3d::Zero();
    if (!vec(e, defaults, "pos", 3, v, present)) return false;
    if (present) pos = Vec3d(v[0], v[1], v[2]);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    int given = 0;
    if (!vec(e, defaults, "quat", 4, v, present)) return false;
    if (present) {
      ++given;
      q = Eigen::Quaterniond(v[0], v[1], v[2], v[3]);
      if (!(q.norm() > 0)) return fail(e, "attribute 'quat' is zero");
    }
    if (!vec(e, defaults, "axisangle", 4, v, present)) return false;
    if (present) {
      ++given;
      if (!(Vec3d(v[0], v[1], v[2]).norm() > 0)) return fail(e, "attribute 'axisangle': zero axis");
      q = axis_angle(Vec3d(v[0], v[1], v[2]), angle(v[3]));
    }
    if (!vec(e, defaults, "euler", 3, v, present)) return false;
    if (present) {
      ++given;
      // MuJoCo: lower-case axes rotate with the frame (post-multiply), upper-case are fixed.
      q = Eigen::Quaterniond::Identity();
      for (int i = 0; i < 3; ++i) {
        const char c = eulerseq_[i];
        const int axis = std::tolower(c) - 'x';
        const Eigen::Quaterniond r = axis_angle(Vec3d::Unit(axis), angle(v[i]));
        q = std::islower(c) ? q * r : r * q;
      }
    }
    if (!vec(e, defaults, "xyaxes", 6, v, present)) return false;
    if (present) {
      ++given;
      Vec3d x(v[0], v[1], v[2]);
      Vec3d y(v[3], v[4], v[5]);
      if (!(x.norm() > 0)) return fail(e, "attribute 'xyaxes': zero x axis");
      x.normalize();
      y -= x * x.dot(y);
      if (!(y.norm() > 1e-12)) return fail(e, "attribute 'xyaxes': y parallel to x");
      y.normalize();
      Mat3d m;
      m.col(0) = x;
      m.col(1) = y;
      m.col(2) = x.cross(y);
      q = Eigen::Quaterniond(m);
    }
    if (!vec(e, defaults, "zaxis", 3, v, present)) return false;
    if (present) {
      ++given;
      if (!(Vec3d(v[0], v[1], v[2]).norm() > 0)) return fail(e, "attribute 'zaxis' is zero");
      q = z_to(Vec3d(v[0], v[1], v[2]));
    }
    if (given > 1)
      return fail(e, "more than one orientation (quat, axisangle, euler, xyaxes, zaxis)");
    out.rotation = q.normalized().toRotationMatrix();
    out.translation = pos;
    return true;
  }

  // ---- bodies ----
  bool read_body_children(XMLElement* body, int body_id, const std::string& childclass, int depth) {
    if (depth > kMaxBodyDepth)
      return fail(body, "bodies nested deeper than " + std::to_string(kMaxBodyDepth));
    int geom_count = 0;
    for (XMLElement* e = body->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
      const std::string_view tag = e->Name();
      if (tag == "geom") {
        if (!read_geom(e, body_id, childclass, geom_count++)) return false;
      } else if (tag == "joint" || tag == "freejoint") {
        if (body_id == 0) return fail(e, "the world body cannot have joints");
        if (!read_joint(e, body_id, childclass)) return false;
      } else if (tag == "body") {
        if (!read_body(e, body_id, childclass, depth + 1)) return false;
      } else if (kIgnoredInBody.count(tag)) {
        continue;
      } else {
        return fail(e, "<" + std::string(tag) + "> is not supported");
      }
    }
    return true;
  }

  bool read_body(XMLElement* e, int parent, const std::string& inherited, int depth) {
    Link link;
    if (const char* name = e->Attribute("name"))
      link.name = name;
    else
      link.name = "body" + std::to_string(bodies_.size());
    if (body_ids_.count(link.name)) return fail(e, "body name '" + link.name + "' is used twice");
    link.parent = parent - 1;
    if (!frame(e, {}, link.offset)) return false;
    const int id = static_cast<int>(bodies_.size());
    body_ids_[link.name] = id;
    bodies_.push_back({link.name, parent, false});
    robot_.tree.links.push_back(std::move(link));
    std::string childclass = inherited;
    if (const char* c = e->Attribute("childclass")) {
      if (!classes_.count(c)) return fail(e, "unknown default class '" + std::string(c) + "'");
      childclass = c;
    }
    if (const char* c = e->Attribute("class"))
      return fail(e, "a body has no 'class' (use 'childclass'): \"" + std::string(c) + "\"");
    return read_body_children(e, id, childclass, depth);
  }

  bool read_joint(XMLElement* e, int body_id, const std::string& childclass) {
    Attributes defaults;
    const bool free_element = std::string_view(e->Name()) == "freejoint";
    if (!free_element && !class_attributes(e, childclass, "joint", defaults)) return false;
    Joint joint;
    joint.link = body_id - 1;
    if (const char* name = e->Attribute("name"))
      joint.name = name;
    else
      joint.name = bodies_[body_id].name + "/joint" +
                   std::to_string(robot_.tree.links[joint.link].joints.size());
    if (robot_.tree.find_joint(joint.name) >= 0)
      return fail(e, "joint name '" + joint.name + "' is used twice");
    std::string type = free_element ? "free" : get(e, defaults, "type").value_or("hinge");
    if (type == "hinge")
      joint.type = JointType::revolute;
    else if (type == "slide")
      joint.type = JointType::prismatic;
    else if (type == "ball")
      joint.type = JointType::ball;
    else if (type == "free")
      joint.type = JointType::free;
    else
      return fail(e, "joint type '" + type + "' is not one of hinge, slide, ball, free");
    std::vector<double> v;
    bool present = false;
    if (joint.type != JointType::free) {
      if (!vec(e, defaults, "pos", 3, v, present)) return false;
      if (present) joint.anchor = Vec3d(v[0], v[1], v[2]);
      if (!vec(e, defaults, "axis", 3, v, present)) return false;
      if (present) joint.axis = Vec3d(v[0], v[1], v[2]);
      if ((joint.type == JointType::revolute || joint.type == JointType::prismatic) &&
          !(joint.axis.norm() > 0))
        return fail(e, "attribute 'axis' is zero");
      const bool rotational = joint.type == JointType::revolute;
      if (!vec(e, defaults, "ref", 1, v, present)) return false;
      if (present && joint.type != JointType::ball)
        joint.reference = rotational ? angle(v[0]) : v[0];
      if (!vec(e, defaults, "range", 2, v, present)) return false;
      const std::string limited = get(e, defaults, "limited").value_or("auto");
      if (limited != "true" && limited != "false" && limited != "auto")
        return fail(e, "attribute 'limited' must be true, false or auto");
      // limited="auto" (the default) means limited when a range is given only with the
      // compiler's autolimits (false in MuJoCo 2.2, which then refuses a range without
      // `limited`; here the joint is reported unlimited: limits are reports, not geometry).
      if (joint.type != JointType::ball && present &&
          (limited == "true" || (limited == "auto" && autolimits_))) {
        joint.limited = true;
        joint.lower = rotational ? angle(v[0]) : v[0];
        joint.upper = rotational ? angle(v[1]) : v[1];
      } else if (limited == "true" && !present && joint.type != JointType::ball) {
        return fail(e, "limited=\"true\" without a 'range'");
      }
    } else if (!robot_.tree.links[joint.link].joints.empty() || bodies_[body_id].parent != 0) {
      return fail(e, "a free joint must be the only joint of a body whose parent is the world");
    }
    if (joint.type != JointType::free && !robot_.tree.links[joint.link].joints.empty() &&
        robot_.tree.joints[robot_.tree.links[joint.link].joints.front()].type == JointType::free)
      return fail(e, "a body with a free joint can have no other joint");
    bodies_[body_id].has_joints = true;
    robot_.tree.links[joint.link].joints.push_back(static_cast<int>(robot_.tree.joints.size()));
    robot_.tree.joints.push_back(std::move(joint));
    return true;
  }

  bool read_geom(XMLElement* e, int body_id, const std::string& childclass, int index) {
    Attributes defaults;
    if (!class_attributes(e, childclass, "geom", defaults)) return false;
    const std::string type = get(e, defaults, "type").value_or("sphere");
    // MuJoCo fits a primitive to a mesh named on a non-mesh geom: geometry we would not match.
    if (type != "mesh" && get(e, defaults, "mesh"))
      return fail(e, "a " + type + " fitted to a mesh is not supported");
    std::vector<double> size;
    if (const auto text = get(e, defaults, "size")) {
      if (!numbers(e, "size", *text, size)) return false;
      if (size.size() > 3) return fail(e, "attribute 'size': at most 3 numbers");
    }
    size.resize(3, 0.0);
    auto positive = [&](int count, const char* what) {
      for (int i = 0; i < count; ++i)
        if (!(size[i] > 0))
          return fail(e, std::string("attribute 'size': ") + what + " must be > 0");
      return true;
    };
    Pose3d pose;
    if (!frame(e, defaults, pose)) return false;
    std::vector<double> fromto;
    bool has_fromto = false;
    if (!vec(e, defaults, "fromto", 6, fromto, has_fromto)) return false;
    double half_length = size[1];
    if (has_fromto) {
      if (type != "capsule" && type != "cylinder" && type != "box" && type != "ellipsoid")
        return fail(e, "'fromto' is only for capsule, cylinder, box and ellipsoid");
      const Vec3d from(fromto[0], fromto[1], fromto[2]);
      const Vec3d to(fromto[3], fromto[4], fromto[5]);
      // MuJoCo's compiler aligns the geom's z axis with from − to (mjCGeom::Compile).
      const Vec3d d = from - to;
      if (!(d.norm() >= 1e-10)) return fail(e, "'fromto' points coincide");
      pose.translation = (from + to) / 2;
      pose.rotation = z_to(d).normalized().toRotationMatrix();
      half_length = d.norm() / 2;
    }
    model::PieceInput piece;
    if (type == "sphere") {
      if (!positive(1, "the radius")) return false;
      piece.shape = Point{};
      piece.radius = size[0];
    } else if (type == "capsule") {
      if (!positive(1, "the radius")) return false;
      if (!(half_length > 0)) return fail(e, "a capsule needs a half-length > 0 (size or fromto)");
      piece.shape = Segment<double>{Vec3d(0, 0, -half_length), Vec3d(0, 0, half_length)};
      piece.radius = size[0];
    } else if (type == "cylinder") {
      if (!positive(1, "the radius")) return false;
      if (!(half_length > 0)) return fail(e, "a cylinder needs a half-length > 0 (size or fromto)");
      piece.shape = Cylinder<double>{size[0], half_length};
    } else if (type == "box" || type == "ellipsoid") {
      if (has_fromto) size[2] = half_length;
      if (!positive(3, "every half-size")) return false;
      const Vec3d h(size[0], size[1], size[2]);
      if (type == "box")
        piece.shape = Box<double>{h};
      else
        piece.shape = Ellipsoid<double>{h};
    } else if (type == "plane") {
      // MuJoCo's planes are infinite; nearpoint has no unbounded shape. A plane becomes a box
      // under its surface: its half sizes in x and y (0, MuJoCo's "infinite": 100 m), 1 m deep.
      const double hx = size[0] > 0 ? size[0] : 100.0;
      const double hy = size[1] > 0 ? size[1] : 100.0;
      piece.shape = Box<double>{Vec3d(hx, hy, 0.5)};
      piece.offset.translation = Vec3d(0, 0, -0.5);
    } else if (type == "mesh") {
      const auto name = get(e, defaults, "mesh");
      if (!name) return fail(e, "a mesh geom needs a 'mesh'");
      const auto it = meshes_.find(*name);
      if (it == meshes_.end()) return fail(e, "unknown mesh '" + *name + "'");
      const MeshAsset& mesh = it->second;
      if (!mesh.vertices.empty()) {
        model::PolytopeInput polytope;
        for (std::size_t i = 0; i + 2 < mesh.vertices.size(); i += 3)
          polytope.vertices.push_back(
              Vec3d(mesh.vertices[i], mesh.vertices[i + 1], mesh.vertices[i + 2])
                  .cwiseProduct(mesh.scale));
        piece.shape = std::move(polytope);
      } else {
        const std::filesystem::path file =
            mesh.file.is_absolute() ? mesh.file : std::filesystem::path(meshdir_) / mesh.file;
        std::filesystem::path resolved;
        if (std::string why = detail::resolve_mesh(file.string(), base_dir_, options_, resolved);
            !why.empty())
          return fail(e, why);
        if (std::string why = detail::load_mesh_piece(resolved, mesh.scale, options_, piece);
            !why.empty())
          return fail(e, why);
      }
    } else {
      return fail(e, "geom type '" + type + "' is not supported");
    }
    GeomInfo info;
    info.body = body_id;
    for (auto [attribute, field] :
         {std::pair{"contype", &info.contype}, std::pair{"conaffinity", &info.conaffinity}}) {
      std::vector<double> v;
      bool present = false;
      if (!vec(e, defaults, attribute, 1, v, present)) return false;
      if (present) {
        if (v[0] < 0 || v[0] > 4294967295.0 || v[0] != std::floor(v[0]))
          return fail(
              e, std::string("attribute '") + attribute + "' must be a 32-bit unsigned integer");
        *field = static_cast<unsigned>(v[0]);
      }
    }
    std::string name;
    if (const char* n = e->Attribute("name")) {
      name = n;
      if (geom_ids_.count(name)) return fail(e, "geom name '" + name + "' is used twice");
    } else {
      name = bodies_[body_id].name + "/geom" + std::to_string(index);
      while (geom_ids_.count(name)) name += "_";
    }
    RobotObject object;
    object.name = name;
    object.link = body_id - 1;
    object.offset = pose;
    object.geometry.name = name;
    object.geometry.pieces.push_back(std::move(piece));
    info.object = static_cast<int>(robot_.objects.size());
    robot_.objects.push_back(std::move(object));
    geom_ids_[name] = static_cast<int>(geoms_.size());
    geoms_.push_back(info);
    return true;
  }

  // ---- <contact> ----
  bool read_contact(XMLElement* root) {
    for (XMLElement* contact = root->FirstChildElement("contact"); contact != nullptr;
         contact = contact->NextSiblingElement("contact")) {
      for (XMLElement* e = contact->FirstChildElement(); e != nullptr;
           e = e->NextSiblingElement()) {
        const std::string_view tag = e->Name();
        if (tag == "exclude") {
          int ids[2];
          for (int k = 0; k < 2; ++k) {
            const char* attribute = k == 0 ? "body1" : "body2";
            const char* name = e->Attribute(attribute);
            if (name == nullptr) return fail(e, std::string("no '") + attribute + "'");
            const auto it = body_ids_.find(name);
            if (std::string_view(name) == "world")
              ids[k] = 0;
            else if (it == body_ids_.end())
              return fail(e, "unknown body '" + std::string(name) + "'");
            else
              ids[k] = it->second;
          }
          excluded_bodies_.insert(std::minmax(ids[0], ids[1]));
        } else if (tag == "pair") {
          int ids[2];
          for (int k = 0; k < 2; ++k) {
            const char* attribute = k == 0 ? "geom1" : "geom2";
            const char* name = e->Attribute(attribute);
            if (name == nullptr) return fail(e, std::string("no '") + attribute + "'");
            const auto it = geom_ids_.find(name);
            if (it == geom_ids_.end()) return fail(e, "unknown geom '" + std::string(name) + "'");
            ids[k] = it->second;
          }
          if (ids[0] == ids[1]) return fail(e, "a geom cannot pair with itself");
          explicit_pairs_.insert(std::minmax(ids[0], ids[1]));
        } else {
          return fail(e, "<" + std::string(tag) + "> is not supported");
        }
      }
    }
    return true;
  }

  // MuJoCo's weld body: the nearest ancestor-or-self with joints (0: welded to the world).
  int weld(int body) const {
    while (body > 0 && !bodies_[body].has_joints) body = bodies_[body].parent;
    return body < 0 ? 0 : body;
  }

  void select_pairs() {
    std::set<std::pair<int, int>> pairs;
    if (!contact_disabled_) {
      if (collision_ != Collision::dynamic)
        for (const auto& [a, b] : explicit_pairs_)
          pairs.insert(std::minmax(geoms_[a].object, geoms_[b].object));
      if (collision_ != Collision::predefined) {
        std::vector<int> welds(bodies_.size());
        std::vector<int> parent_welds(bodies_.size());
        for (std::size_t b = 0; b < bodies_.size(); ++b) {
          welds[b] = weld(static_cast<int>(b));
          parent_welds[b] = welds[b] == 0 ? 0 : weld(bodies_[welds[b]].parent);
        }
        for (std::size_t a = 0; a < geoms_.size(); ++a)
          for (std::size_t b = a + 1; b < geoms_.size(); ++b) {
            const GeomInfo& ga = geoms_[a];
            const GeomInfo& gb = geoms_[b];
            if (!((ga.contype & gb.conaffinity) || (gb.contype & ga.conaffinity))) continue;
            const int wa = welds[ga.body];
            const int wb = welds[gb.body];
            if (wa == wb) continue;
            if (filterparent_ && wa != 0 && wb != 0 &&
                (wa == parent_welds[gb.body] || wb == parent_welds[ga.body]))
              continue;
            if (excluded_bodies_.count(std::minmax(ga.body, gb.body))) continue;
            pairs.insert({ga.object, gb.object});
          }
      }
    }
    robot_.pairs.assign(pairs.begin(), pairs.end());
  }

  enum class Collision { all, predefined, dynamic };

  const std::string& label_;
  const std::filesystem::path& base_dir_;
  const ImportOptions& options_;
  Robot& robot_;
  tinyxml2::XMLDocument doc_;
  std::string error_;
  bool degrees_ = true;
  bool autolimits_ = false;
  std::string eulerseq_ = "xyz";
  std::string meshdir_;
  Collision collision_ = Collision::all;
  bool filterparent_ = true;
  bool contact_disabled_ = false;
  std::map<std::string, DefaultClass> classes_;
  std::map<std::string, MeshAsset> meshes_;
  std::vector<BodyInfo> bodies_;
  std::map<std::string, int> body_ids_;
  std::vector<GeomInfo> geoms_;
  std::map<std::string, int> geom_ids_;
  std::set<std::pair<int, int>> excluded_bodies_;
  std::set<std::pair<int, int>> explicit_pairs_;
};

}  // namespace

RobotImport parse_mjcf(const std::string& xml, const std::string& label,
                       const std::filesystem::path& base_dir, const ImportOptions& options) {
  RobotImport out;
  Parser parser(label, base_dir, options, out.robot);
  out.error = parser.run(xml);
  if (!out.ok()) out.robot = Robot{};
  return out;
}

RobotImport load_mjcf(const std::filesystem::path& file, const ImportOptions& options) {
  RobotImport out;
  std::string xml;
  if (std::string why = detail::read_file(file, xml); !why.empty()) {
    out.error = why;
    return out;
  }
  return parse_mjcf(xml, file.string(), file.parent_path(), options);
}

}  // namespace nearpoint::robots
