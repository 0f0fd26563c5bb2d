// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/formats/scene_file.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <sstream>

#include "nearpoint/model/vocabulary.hpp"

#ifdef NEARPOINT_WITH_YAML
#include <yaml-cpp/yaml.h>
#endif

namespace nearpoint::formats {
namespace {

std::string quoted(const std::string& path) {
  return "\"" + path + "\"";
}

// A key of the file in a field path: cut short, since a path is quoted in every error about the
// field and a hostile file's key (a geometry's name, say) may be megabytes long.
std::string member(const std::string& path, const std::string& key) {
  constexpr std::size_t kMaxKeyBytes = 60;
  const std::string shown = key.size() <= kMaxKeyBytes ? key : short_prefix(key, kMaxKeyBytes);
  return path.empty() ? shown : path + "." + shown;
}

std::string element(const std::string& path, std::size_t index) {
  return path + "[" + std::to_string(index) + "]";
}

std::string unknown_key(const std::string& path, const std::string& key, const char* allowed) {
  return quoted(path) + " has the unknown key " + user_key(key) + " (allowed: " + allowed + ")";
}

std::string read_string(const Json& value, const std::string& path, std::string& out) {
  if (!value.is_string())
    return quoted(path) + " must be a string (got " + describe_type(value) + ")";
  out = value.get<std::string>();
  return {};
}

std::string read_bool(const Json& value, const std::string& path, bool& out) {
  if (!value.is_boolean())
    return quoted(path) + " must be true or false (got " + describe_type(value) + ")";
  out = value.get<bool>();
  return {};
}

// A value for a message: a number or a string as written (cut short), anything else by its type.
// Never the whole value: a hostile file's value may be huge or deeply nested.
std::string short_value(const Json& value) {
  if (value.is_number()) return value.dump();
  if (value.is_string()) return user_key(value.get_ref<const std::string&>());
  return describe_type(value);
}

std::string read_uint32(const Json& value, const std::string& path, std::uint32_t& out) {
  if (!value.is_number_unsigned() && !(value.is_number_integer() && value.get<long long>() >= 0))
    return quoted(path) + " must be an integer in [0, 4294967295] (got " + short_value(value) + ")";
  const auto n = value.get<unsigned long long>();
  if (n > 0xFFFFFFFFull) return quoted(path) + " must be at most 4294967295";
  out = std::uint32_t(n);
  return {};
}

std::string read_pieces(const Json& value, const std::string& path,
                        std::vector<model::PieceInput>& out) {
  if (!value.is_array() || value.empty())
    return quoted(path) + " must be a non-empty array of SHAPEs (got " + describe_type(value) + ")";
  for (std::size_t i = 0; i < value.size(); ++i) {
    ShapeSpec spec;
    if (std::string error = parse_shape_spec(value[i], element(path, i), spec); !error.empty())
      return error;
    out.push_back(to_piece(spec));
  }
  return {};
}

std::string read_mesh(const Json& value, const std::string& path,
                      const std::filesystem::path& base_dir, const MeshLoader& meshes,
                      std::vector<model::PieceInput>& out) {
  MeshRequest request;
  for (const auto& [key, part] : value.items()) {
    const std::string field = member(path, key);
    if (key == "mesh") {
      std::vector<std::string> names;
      if (part.is_string()) {
        names.push_back(part.get<std::string>());
      } else if (part.is_array() && !part.empty()) {
        for (std::size_t i = 0; i < part.size(); ++i) {
          std::string name;
          if (std::string error = read_string(part[i], element(field, i), name); !error.empty())
            return error;
          names.push_back(name);
        }
      } else {
        return quoted(field) + " must be a file name or a non-empty array of them";
      }
      for (const std::string& name : names) {
        const std::filesystem::path file(name);
        request.files.push_back(file.is_absolute() ? file : base_dir / file);
      }
    } else if (key == "scale") {
      if (!part.is_number() || !(part.get<double>() > 0) || !std::isfinite(part.get<double>()))
        return quoted(field) + " must be a positive number";
      request.scale = part.get<double>();
    } else if (key == "merge") {
      if (std::string error = read_bool(part, field, request.merge); !error.empty()) return error;
    } else if (key != "name") {
      return unknown_key(path, key, "mesh, scale, merge, name");
    }
  }
  if (!meshes)
    return quoted(path) +
           ": mesh files are not read here; register meshes with `nearpoint register` or "
           "`nearpoint scene create`, or give the pieces as SHAPEs";
  if (std::string error = meshes(request, out); !error.empty()) return quoted(path) + ": " + error;
  return {};
}

bool read_pair_list(const Json& value, const std::string& path,
                    std::vector<std::pair<std::string, std::string>>& out, std::string& error) {
  if (!value.is_array()) {
    error = quoted(path) + " must be an array of [\"a\", \"b\"] pairs";
    return false;
  }
  for (std::size_t i = 0; i < value.size(); ++i) {
    const Json& pair = value[i];
    if (!pair.is_array() || pair.size() != 2 || !pair[0].is_string() || !pair[1].is_string()) {
      error = quoted(element(path, i)) + " must be a pair of object ids [\"a\", \"b\"]";
      return false;
    }
    out.emplace_back(pair[0].get<std::string>(), pair[1].get<std::string>());
  }
  return true;
}

// The file's top level: "id" and "name" read, every other key one of the sections below.
std::string read_scene_keys(const Json& value, model::SceneInput& scene) {
  for (const auto& [key, part] : value.items()) {
    if (key == "id") {
      if (std::string error = read_string(part, "id", scene.requested_id); !error.empty())
        return error;
    } else if (key == "name") {
      if (std::string error = read_string(part, "name", scene.name); !error.empty()) return error;
    } else if (key != "geometries" && key != "objects" && key != "pairs" && key != "options" &&
               key != "thresholds" && key != "robot") {
      return unknown_key("", key,
                         "id, name, robot, geometries, objects, pairs, options, thresholds");
    }
  }
  return {};
}

// "geometries": {"NAME": GEOMETRY, ...}; a geometry without a name of its own takes its key.
std::string read_geometries(const Json& geometries, const std::filesystem::path& base_dir,
                            const MeshLoader& meshes, SceneFile& file) {
  if (!geometries.is_object()) return "\"geometries\" must be an object {\"NAME\": GEOMETRY, ...}";
  for (const auto& [name, geometry] : geometries.items()) {
    model::GeometryInput input;
    if (std::string error =
            parse_geometry(geometry, member("geometries", name), base_dir, meshes, input);
        !error.empty())
      return error;
    if (input.name.empty()) input.name = name;
    file.geometries.emplace_back(name, std::move(input));
  }
  return {};
}

// One object's keys; `geometry_name` gets its "geometry" (a key of "geometries"), if any.
std::string read_object_keys(const Json& object, const std::string& path, model::ObjectInput& input,
                             std::string& geometry_name) {
  for (const auto& [key, part] : object.items()) {
    const std::string field = member(path, key);
    std::string error;
    if (key == "id") {
      error = read_string(part, field, input.id);
    } else if (key == "geometry") {
      error = read_string(part, field, geometry_name);
    } else if (key == "geometry_id") {
      error = read_string(part, field, input.geometry_id);
    } else if (key == "pose") {
      Vec3<double> translation;
      error = parse_pose_parts(part, field, input.pose.rotation_wxyz, translation);
      input.pose.translation = translation;
    } else if (key == "group" || key == "mask") {
      std::uint32_t bits = 0;
      error = read_uint32(part, field, bits);
      (key == "group" ? input.group : input.mask) = bits;
    } else if (key == "padding" || key == "self_padding") {
      // The server checks the value (finite, >= 0) and names the field.
      if (!part.is_number()) {
        error = quoted(field) + " must be a number";
      } else {
        (key == "padding" ? input.padding : input.self_padding) = part.get<double>();
      }
    } else if (key == "body") {
      error = read_string(part, field, input.body);
    } else {
      error = unknown_key(path, key,
                          "id, geometry, geometry_id, pose, group, mask, padding, self_padding, "
                          "body");
    }
    if (!error.empty()) return error;
  }
  return {};
}

// One object: its keys, then what only the file can check (its geometry names a key of
// "geometries", read before the objects).
std::string read_object(const Json& object, const std::string& path, SceneFile& file) {
  if (!object.is_object()) return quoted(path) + " must be an object";
  model::ObjectInput input;
  std::string geometry_name;
  if (std::string error = read_object_keys(object, path, input, geometry_name); !error.empty())
    return error;
  if (input.id.empty()) return quoted(member(path, "id")) + " is missing (a non-empty string)";
  if (geometry_name.empty() == input.geometry_id.empty())
    return quoted(path) +
           " must name exactly one of \"geometry\" (a key of \"geometries\") and "
           "\"geometry_id\" (a geometry already registered on the server)";
  if (!geometry_name.empty()) {
    bool known = false;
    for (const auto& [name, ignored] : file.geometries) known = known || name == geometry_name;
    if (!known)
      return quoted(member(path, "geometry")) + ": no geometry " + user_key(geometry_name) +
             " in \"geometries\"";
  }
  file.geometry_names.push_back(geometry_name);
  file.scene.objects.push_back(std::move(input));
  return {};
}

// "pairs": "all", {"listed": [["a","b"], ...]} or {"excluded": [...]}.
std::string read_pairs(const Json& pairs, model::PairSelectionInput& selection) {
  std::string error;
  if (pairs.is_string() && pairs.get<std::string>() == "all") {
    selection.mode = model::PairSelectionInput::Mode::all_pairs;
  } else if (pairs.is_object() && pairs.size() == 1 && pairs.contains("listed")) {
    selection.mode = model::PairSelectionInput::Mode::listed_pairs;
    if (!read_pair_list(pairs["listed"], "pairs.listed", selection.pairs, error)) return error;
  } else if (pairs.is_object() && pairs.size() == 1 && pairs.contains("excluded")) {
    selection.mode = model::PairSelectionInput::Mode::excluded_pairs;
    if (!read_pair_list(pairs["excluded"], "pairs.excluded", selection.pairs, error)) return error;
  } else {
    return "\"pairs\" must be \"all\", {\"listed\": [[\"a\",\"b\"], ...]} or "
           "{\"excluded\": [[\"a\",\"b\"], ...]}";
  }
  return {};
}

// "thresholds": [{"name", "distance", "hysteresis", "object_a", "object_b", "groups"}, ...] as in
// nearpoint.v1.Threshold; the server checks the values and names the field.
std::string read_thresholds(const Json& thresholds, std::vector<model::ThresholdInput>& out) {
  if (!thresholds.is_array()) return "\"thresholds\" must be an array of objects";
  for (std::size_t t = 0; t < thresholds.size(); ++t) {
    const std::string path = "thresholds[" + std::to_string(t) + "]";
    if (!thresholds[t].is_object()) return quoted(path) + " must be an object";
    model::ThresholdInput& threshold = out.emplace_back();
    for (const auto& [key, part] : thresholds[t].items()) {
      const std::string field = member(path, key);
      std::string error;
      if (key == "distance" || key == "hysteresis") {
        if (!part.is_number()) return quoted(field) + " must be a number";
        (key == "distance" ? threshold.distance : threshold.hysteresis) = part.get<double>();
      } else if (key == "name" || key == "object_a" || key == "object_b") {
        error = read_string(part, field,
                            key == "name"       ? threshold.name
                            : key == "object_a" ? threshold.object_a
                                                : threshold.object_b);
      } else if (key == "groups") {
        error = read_uint32(part, field, threshold.groups);
      } else {
        error = unknown_key(path, key, "name, distance, hysteresis, object_a, object_b, groups");
      }
      if (!error.empty()) return error;
    }
  }
  return {};
}

// The sections in the order their errors are reported: the top-level keys, then geometries
// (objects refer to them), objects, pairs, options and thresholds.
std::string parse_scene_or_throw(const Json& value, const std::filesystem::path& base_dir,
                                 const MeshLoader& meshes, SceneFile& out) {
  if (!value.is_object())
    return "a scene file must hold an object (got " + describe_type(value) + ")";
  SceneFile file;
  if (std::string error = read_scene_keys(value, file.scene); !error.empty()) return error;
  if (value.contains("geometries")) {
    if (std::string error = read_geometries(value["geometries"], base_dir, meshes, file);
        !error.empty())
      return error;
  }
  if (value.contains("robot")) {
    // A path, or {"file", "srdf", "package_path"}; the robot's objects come on top of "objects".
    const Json& robot = value["robot"];
    RobotReference reference;
    std::string file_name;
    if (robot.is_string()) {
      file_name = robot.get<std::string>();
    } else if (robot.is_object()) {
      for (const auto& [key, part] : robot.items()) {
        std::string text;
        if (key == "file" || key == "srdf") {
          if (std::string error = read_string(part, member("robot", key), text); !error.empty())
            return error;
          if (key == "file")
            file_name = text;
          else
            reference.srdf = text;
        } else if (key == "package_path") {
          if (!part.is_array()) return "\"robot.package_path\" must be an array of directories";
          for (std::size_t i = 0; i < part.size(); ++i) {
            if (std::string error = read_string(part[i], element("robot.package_path", i), text);
                !error.empty())
              return error;
            reference.package_path.push_back(base_dir / text);
          }
        } else {
          return unknown_key("robot", key, "file, srdf, package_path");
        }
      }
    } else {
      return "\"robot\" must be a path or {\"file\": PATH, \"srdf\": PATH, \"package_path\": "
             "[DIR, ...]}";
    }
    if (file_name.empty()) return "\"robot.file\" is missing (a robot description's path)";
    reference.file = base_dir / file_name;
    if (!reference.srdf.empty()) reference.srdf = base_dir / reference.srdf;
    file.robot = std::move(reference);
  }
  const bool robot = file.robot.has_value();
  if (!(robot && !value.contains("objects")) &&
      (!value.contains("objects") || !value["objects"].is_array() ||
       (value["objects"].empty() && !robot)))
    return "\"objects\" must be a non-empty array of objects";
  static const Json kNoObjects = Json::array();
  const Json& objects = value.contains("objects") ? value["objects"] : kNoObjects;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (std::string error = read_object(objects[i], element("objects", i), file); !error.empty())
      return error;
  }
  if (value.contains("pairs")) {
    if (std::string error = read_pairs(value["pairs"], file.scene.pair_selection); !error.empty())
      return error;
  }
  if (value.contains("options")) {
    if (std::string error =
            parse_query_options(value["options"], "options", file.scene.default_options);
        !error.empty())
      return error;
  }
  if (value.contains("thresholds")) {
    if (std::string error = read_thresholds(value["thresholds"], file.scene.thresholds);
        !error.empty())
      return error;
  }
  out = std::move(file);
  return {};
}

#ifdef NEARPOINT_WITH_YAML
// Values a YAML document may expand to when its aliases are copied out: at least this many, and
// four per byte of the file (a file without aliases has fewer values than bytes). A 600-byte
// "billion laughs" document expands to 10⁹ values and grew past 6 GB.
constexpr std::size_t kMinYamlValueBudget = 1'000'000;

// YAML → JSON: plain scalars become numbers or booleans when they read as such (YAML 1.2's core
// schema), quoted scalars stay strings. yaml-cpp keeps an alias as a second reference to its
// anchor's node, so the document is a graph (a cycle for `a: &a [*a]`) that this conversion
// unfolds into a tree: `depth` (of the node being converted, the root's 1) stops cycles and deep
// nesting at kMaxNestingDepth, `budget` (values left) stops exponential alias expansion. Both
// throw a YAML::ParserException at the offending node, so the message has its line.
Json yaml_to_json(const YAML::Node& node, int depth, std::size_t& budget) {
  if (budget == 0)
    throw YAML::ParserException(
        node.Mark(),
        "the document expands to too many values once its aliases are copied out "
        "(an alias bomb?); write the values out instead of aliasing them");
  --budget;
  const bool container =
      node.Type() == YAML::NodeType::Sequence || node.Type() == YAML::NodeType::Map;
  if (container && depth > kMaxNestingDepth)
    throw YAML::ParserException(node.Mark(), "nesting deeper than " +
                                                 std::to_string(kMaxNestingDepth) +
                                                 " levels (or an alias that contains itself)");
  switch (node.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
      return nullptr;
    case YAML::NodeType::Sequence: {
      Json array = Json::array();
      for (const YAML::Node& item : node) array.push_back(yaml_to_json(item, depth + 1, budget));
      return array;
    }
    case YAML::NodeType::Map: {
      Json object = Json::object();
      for (const auto& item : node) {
        if (!item.first.IsScalar())
          throw YAML::ParserException(item.first.Mark(), "a key must be a plain string");
        object[item.first.Scalar()] = yaml_to_json(item.second, depth + 1, budget);
      }
      return object;
    }
    case YAML::NodeType::Scalar:
      break;
  }
  const std::string text = node.Scalar();
  if (node.Tag() == "!") return text;  // quoted
  if (text == "true" || text == "True" || text == "TRUE") return true;
  if (text == "false" || text == "False" || text == "FALSE") return false;
  if (text == "null" || text == "~") return nullptr;
  const Json number = Json::parse(text, nullptr, false);
  if (!number.is_discarded() && number.is_number()) return number;
  return text;
}
#endif

}  // namespace

model::PieceInput to_piece(const ShapeSpec& spec) {
  model::PieceInput piece;
  std::visit(
      [&](const auto& geometry) {
        using G = std::decay_t<decltype(geometry)>;
        if constexpr (std::is_same_v<G, std::vector<Vec3<double>>>)
          piece.shape = model::PolytopeInput{geometry};
        else
          piece.shape = geometry;
      },
      spec.geometry);
  piece.radius = spec.radius;
  piece.offset.rotation_wxyz = spec.rotation_wxyz;
  piece.offset.translation = spec.translation;
  return piece;
}

std::string parse_query_options(const Json& value, const std::string& path,
                                model::QueryOptionsInput& out) {
  if (!value.is_object()) return quoted(path) + " must be an object";
  model::QueryOptionsInput options;
  for (const auto& [key, part] : value.items()) {
    const std::string field = member(path, key);
    std::string error;
    bool flag = false;
    if (key == "epsilon" || key == "distance_cutoff" || key == "change_tolerance") {
      if (!part.is_number()) return quoted(field) + " must be a number";
      (key == "epsilon"           ? options.epsilon
       : key == "distance_cutoff" ? options.distance_cutoff
                                  : options.change_tolerance) = part.get<double>();
    } else if (key == "report_mode") {
      // The CLI's names (--mode).
      std::string mode;
      if (error = read_string(part, field, mode); !error.empty()) return error;
      options.report_mode = model::from_spelling<model::ReportMode>(mode);
      if (options.report_mode == model::ReportMode::unknown)
        return quoted(field) + " must be " + model::spellings<model::ReportMode>("\"");
    } else if (key == "near_points" || key == "gradient" || key == "warm_start") {
      if (error = read_bool(part, field, flag); !error.empty()) return error;
      (key == "near_points" ? options.near_points
       : key == "gradient"  ? options.gradient
                            : options.warm_start) = flag;
    } else if (key == "penetration") {
      std::string mode;
      if (error = read_string(part, field, mode); !error.empty()) return error;
      options.penetration = model::from_spelling<model::PenetrationMode>(mode);
      if (options.penetration == model::PenetrationMode::unknown)
        return quoted(field) + " must be " + model::spellings<model::PenetrationMode>("\"");
    } else if (key == "max_iterations") {
      if (!part.is_number_unsigned()) return quoted(field) + " must be a positive integer";
      options.max_iterations = part.get<std::uint64_t>();
    } else {
      return unknown_key(path, key,
                         "epsilon, near_points, penetration, gradient, distance_cutoff, "
                         "warm_start, max_iterations, report_mode, change_tolerance");
    }
  }
  out = options;
  return {};
}

std::string parse_geometry(const Json& value, const std::string& path,
                           const std::filesystem::path& base_dir, const MeshLoader& meshes,
                           model::GeometryInput& out) {
  try {
    model::GeometryInput geometry;
    std::string error;
    if (value.is_array()) {
      error = read_pieces(value, path, geometry.pieces);
    } else if (looks_like_shape(value)) {
      ShapeSpec spec;
      error = parse_shape_spec(value, path, spec);
      if (error.empty()) geometry.pieces.push_back(to_piece(spec));
    } else if (value.is_object() && value.contains("mesh")) {
      error = read_mesh(value, path, base_dir, meshes, geometry.pieces);
      if (error.empty() && value.contains("name") && value["name"].is_string())
        geometry.name = value["name"].get<std::string>();
    } else if (value.is_object() && value.contains("pieces")) {
      for (const auto& [key, part] : value.items()) {
        if (key == "name")
          error = read_string(part, member(path, "name"), geometry.name);
        else if (key == "pieces")
          error = read_pieces(part, member(path, "pieces"), geometry.pieces);
        else
          error = unknown_key(path, key, "name, pieces");
        if (!error.empty()) break;
      }
    } else {
      error = quoted(path) +
              " must be a GEOMETRY: a SHAPE, an array of SHAPEs, {\"pieces\": [SHAPE, ...]} or "
              "{\"mesh\": FILE}";
    }
    if (!error.empty()) return error;
    out = std::move(geometry);
    return {};
  } catch (const std::exception& e) {
    return quoted(path) + ": " + e.what();
  }
}

std::string parse_scene(const Json& value, const std::filesystem::path& base_dir,
                        const MeshLoader& meshes, SceneFile& out) {
  try {
    return parse_scene_or_throw(value, base_dir, meshes, out);
  } catch (const std::exception& e) {
    return e.what();
  }
}

std::string read_structured_file(const std::filesystem::path& file, Json& out) {
  std::ifstream input(file, std::ios::binary);
  if (!input) return "cannot open " + file.string() + ": " + std::strerror(errno);
  std::ostringstream text;
  text << input.rdbuf();
  const std::string extension = file.extension().string();
  if (extension == ".yaml" || extension == ".yml") {
#ifdef NEARPOINT_WITH_YAML
    try {
      // yaml-cpp's parser bounds its own recursion (YAML::DeepRecursion, a ParserException).
      const std::string content = text.str();
      std::size_t budget = std::max(kMinYamlValueBudget, 4 * content.size());
      out = yaml_to_json(YAML::Load(content), 1, budget);
      return {};
    } catch (const YAML::Exception& e) {
      const std::string where =
          e.mark.is_null() ? std::string() : "line " + std::to_string(e.mark.line + 1) + ": ";
      return file.string() + ": " + where + short_prefix(e.msg, 200);
    } catch (const std::exception& e) {  // exhausted memory
      return file.string() + ": cannot read: " + e.what();
    }
#else
    return file.string() + ": YAML files need nearpoint built with yaml-cpp (libyaml-cpp-dev)";
#endif
  }
  // Every parser failure comes back as a message with the file (and line): nlohmann's
  // out_of_range for 1e999 escaped the catch of parse_error and aborted nearpointd --scene.
  if (std::string error = parse_json(text.str(), out); !error.empty())
    return file.string() + ": not valid JSON: " + error;
  return {};
}

std::string load_scene_file(const std::filesystem::path& file, const MeshLoader& meshes,
                            SceneFile& out) {
  Json value;
  if (std::string error = read_structured_file(file, value); !error.empty()) return error;
  if (std::string error = parse_scene(value, file.parent_path(), meshes, out); !error.empty())
    return file.string() + ": " + error;
  return {};
}

}  // namespace nearpoint::formats
