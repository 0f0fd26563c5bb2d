// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/formats/json_shapes.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <utility>
#include <vector>

namespace nearpoint::formats {
namespace {

// Paths and keys are quoted in messages the way they appear in JSON, so "a.pose" reads as a name.
// Built by appending: a literal prepended to a temporary (`"\"" + std::string(path)`) draws a
// false -Wrestrict warning from GCC 12 in -O3 builds.
std::string in_quotes(std::string_view path) {
  std::string quoted;
  quoted.reserve(path.size() + 2);
  quoted += '"';
  quoted += path;
  quoted += '"';
  return quoted;
}

std::string member(std::string_view path, std::string_view key) {
  return std::string(path) + "." + std::string(key);
}

std::string element(std::string_view path, std::size_t index) {
  return std::string(path) + "[" + std::to_string(index) + "]";
}

std::string kind_list() {
  std::string out;
  for (const char* kind : kShapeKinds) {
    if (!out.empty()) out += ", ";
    out += kind;
  }
  return out;
}

// Each reader returns "" on success or a message naming `path`.

std::string read_number(const Json& value, const std::string& path, double& out) {
  if (!value.is_number())
    return in_quotes(path) + " must be a number (got " + describe_type(value) + ")";
  out = value.get<double>();
  // The JSON parser cannot produce a non-finite number, but a Json built in code can.
  if (!std::isfinite(out)) return in_quotes(path) + " must be a finite number";
  return {};
}

std::string read_non_negative(const Json& value, const std::string& path, double& out) {
  if (!value.is_number())
    return in_quotes(path) + " must be a non-negative number (got " + describe_type(value) + ")";
  if (std::string error = read_number(value, path, out); !error.empty()) return error;
  if (out < 0) return in_quotes(path) + " must be a non-negative number (got " + value.dump() + ")";
  return {};
}

// An array of exactly N numbers; `shape` is how the user writes it, e.g. "[x,y,z]".
template <int N>
std::string read_numbers(const Json& value, const std::string& path, const char* shape,
                         Eigen::Matrix<double, N, 1>& out) {
  const std::string expected =
      in_quotes(path) + " must be an array of " + std::to_string(N) + " numbers " + shape;
  if (!value.is_array() || value.size() != static_cast<std::size_t>(N))
    return expected + " (got " + describe_type(value) + ")";
  for (int i = 0; i < N; ++i) {
    const std::size_t index = static_cast<std::size_t>(i);
    if (std::string error = read_number(value[index], element(path, index), out[i]); !error.empty())
      return error;
  }
  return {};
}

std::string read_vec3(const Json& value, const std::string& path, const char* shape,
                      Vec3<double>& out) {
  return read_numbers<3>(value, path, shape, out);
}

std::string read_non_negative_vec3(const Json& value, const std::string& path, const char* shape,
                                   Vec3<double>& out) {
  if (std::string error = read_vec3(value, path, shape, out); !error.empty()) return error;
  for (int i = 0; i < 3; ++i) {
    if (out[i] < 0) {
      const std::size_t index = static_cast<std::size_t>(i);
      return in_quotes(element(path, index)) + " must be non-negative (got " + value[index].dump() +
             ")";
    }
  }
  return {};
}

using SpecGeometry = decltype(ShapeSpec::geometry);

std::string read_polytope(const Json& value, const std::string& path, SpecGeometry& out) {
  if (!value.is_array() || value.empty())
    return in_quotes(path) + " must be a non-empty array of [x,y,z] (got " + describe_type(value) +
           ")";
  std::vector<Vec3<double>> vertices(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    if (std::string error = read_vec3(value[i], element(path, i), "[x,y,z]", vertices[i]);
        !error.empty())
      return error;
  }
  out = std::move(vertices);
  return {};
}

std::string read_sphere(const Json& value, const std::string& path, std::string_view shape_path,
                        SpecGeometry& out) {
  if (!value.is_object())
    return in_quotes(path) + " must be {} (got " + describe_type(value) + "); give the radius as " +
           in_quotes(member(shape_path, "radius"));
  if (!value.empty()) {
    const std::string& key = value.begin().key();
    if (key == "radius")
      return in_quotes(path) + " must be {}: give the sphere's radius beside it, as " +
             in_quotes(member(shape_path, "radius"));
    return in_quotes(path) + " must be {} (got the key " + user_key(key) + ")";
  }
  out = Point{};
  return {};
}

std::string read_segment(const Json& value, const std::string& path, SpecGeometry& out) {
  if (!value.is_array() || value.size() != 2)
    return in_quotes(path) + " must be an array of 2 points [[x,y,z],[x,y,z]] (got " +
           describe_type(value) + ")";
  Segment<double> segment;
  if (std::string error = read_vec3(value[0], element(path, 0), "[x,y,z]", segment.a);
      !error.empty())
    return error;
  if (std::string error = read_vec3(value[1], element(path, 1), "[x,y,z]", segment.b);
      !error.empty())
    return error;
  out = segment;
  return {};
}

// {"radius": r, "half_height": h}, both required: the cylinder's and the cone's parameters.
std::string read_radius_half_height(const Json& value, const std::string& path, double& radius,
                                    double& half_height) {
  const std::string expected = in_quotes(path) + R"( must be {"radius": r, "half_height": h})";
  if (!value.is_object()) return expected + " (got " + describe_type(value) + ")";
  for (const auto& [key, ignored] : value.items()) {
    if (key != "radius" && key != "half_height")
      return expected + " (got the unknown key " + user_key(key) + ")";
  }
  if (!value.contains("radius")) return expected + R"( (missing "radius"))";
  if (!value.contains("half_height")) return expected + R"( (missing "half_height"))";
  if (std::string error = read_non_negative(value["radius"], member(path, "radius"), radius);
      !error.empty())
    return error;
  return read_non_negative(value["half_height"], member(path, "half_height"), half_height);
}

std::string read_geometry(std::string_view kind, const Json& value, std::string_view shape_path,
                          SpecGeometry& out) {
  const std::string path = member(shape_path, kind);
  if (kind == "polytope") return read_polytope(value, path, out);
  if (kind == "sphere") return read_sphere(value, path, shape_path, out);
  if (kind == "segment") return read_segment(value, path, out);
  if (kind == "box") {
    Box<double> box;
    if (std::string error = read_non_negative_vec3(value, path, "[hx,hy,hz]", box.half_extents);
        !error.empty())
      return error;
    out = box;
    return {};
  }
  if (kind == "ellipsoid") {
    Ellipsoid<double> ellipsoid;
    if (std::string error = read_non_negative_vec3(value, path, "[rx,ry,rz]", ellipsoid.radii);
        !error.empty())
      return error;
    out = ellipsoid;
    return {};
  }
  if (kind == "cylinder") {
    Cylinder<double> cylinder;
    if (std::string error =
            read_radius_half_height(value, path, cylinder.radius, cylinder.half_height);
        !error.empty())
      return error;
    out = cylinder;
    return {};
  }
  if (kind == "cone") {
    Cone<double> cone;
    if (std::string error = read_radius_half_height(value, path, cone.radius, cone.half_height);
        !error.empty())
      return error;
    out = cone;
    return {};
  }
  return in_quotes(shape_path) + " has an unknown shape kind " + user_key(std::string(kind));
}

bool is_shape_kind(std::string_view key) {
  for (const char* kind : kShapeKinds) {
    if (key == kind) return true;
  }
  return false;
}

// The engine's shape for a spec (polytopes are built, and so validated, here).
Shape<double> engine_shape(const ShapeSpec& spec) {
  Shape<double> shape;
  std::visit(
      [&](const auto& geometry) {
        using G = std::decay_t<decltype(geometry)>;
        if constexpr (std::is_same_v<G, std::vector<Vec3<double>>>)
          shape.geometry = Polytope<double>(geometry);
        else
          shape.geometry = geometry;
      },
      spec.geometry);
  shape.radius = spec.radius;
  return shape;
}

std::string parse_spec_or_throw(const Json& value, std::string_view path, ShapeSpec& out,
                                Shape<double>* engine) {
  if (!value.is_object())
    return in_quotes(path) + R"( must be a SHAPE object such as {"box": [1,1,1]} (got )" +
           describe_type(value) + ")";
  std::string kind;
  for (const auto& [key, ignored] : value.items()) {
    if (is_shape_kind(key)) {
      if (!kind.empty())
        return in_quotes(path) + " names two shape kinds, \"" + kind + "\" and \"" + key +
               "\"; a SHAPE has exactly one";
      kind = key;
    } else if (key != "radius" && key != "pose") {
      return in_quotes(path) + " has an unknown key " + user_key(key) + "; a SHAPE has one of " +
             kind_list() + ", and optionally radius and pose";
    }
  }
  if (kind.empty())
    return in_quotes(path) + " names no shape kind; a SHAPE has one of " + kind_list();

  ShapeSpec spec;
  if (std::string error = read_geometry(kind, value[kind], path, spec.geometry); !error.empty())
    return error;
  if (value.contains("radius")) {
    if (std::string error = read_non_negative(value["radius"], member(path, "radius"), spec.radius);
        !error.empty())
      return error;
  }
  if (value.contains("pose")) {
    if (std::string error = parse_pose_parts(value["pose"], member(path, "pose"),
                                             spec.rotation_wxyz, spec.translation);
        !error.empty())
      return error;
  }
  // The engine's validation has the last word (it knows limits the syntax cannot see).
  Shape<double> shape = engine_shape(spec);
  if (const char* why = invalid_reason(shape); why != nullptr) return in_quotes(path) + ": " + why;
  if (engine != nullptr) *engine = std::move(shape);
  out = std::move(spec);
  return {};
}

std::string parse_shape_or_throw(const Json& value, std::string_view path, PlacedShape& out) {
  ShapeSpec spec;
  PlacedShape placed;
  if (std::string error = parse_spec_or_throw(value, path, spec, &placed.shape); !error.empty())
    return error;
  const auto& q = spec.rotation_wxyz;
  if (const char* why =
          pose_from_quaternion_checked(q[0], q[1], q[2], q[3], spec.translation, placed.pose);
      why != nullptr)
    return in_quotes(member(path, "pose")) + ": " + why;
  out = std::move(placed);
  return {};
}

std::string parse_pose_parts_or_throw(const Json& value, std::string_view path,
                                      std::array<double, 4>& rotation_wxyz,
                                      Vec3<double>& translation_out) {
  const std::string expected =
      in_quotes(path) + R"( must be {"rotation": [w,x,y,z], "translation": [x,y,z]})";
  if (!value.is_object()) return expected + " (got " + describe_type(value) + ")";
  for (const auto& [key, ignored] : value.items()) {
    if (key != "rotation" && key != "translation")
      return expected + " (got the unknown key " + user_key(key) + ")";
  }
  Eigen::Vector4d wxyz(1, 0, 0, 0);
  Vec3<double> translation = Vec3<double>::Zero();
  if (value.contains("rotation")) {
    if (std::string error =
            read_numbers<4>(value["rotation"], member(path, "rotation"), "[w,x,y,z]", wxyz);
        !error.empty())
      return error;
  }
  if (value.contains("translation")) {
    if (std::string error =
            read_vec3(value["translation"], member(path, "translation"), "[x,y,z]", translation);
        !error.empty())
      return error;
  }
  Pose<double> pose;
  if (const char* why =
          pose_from_quaternion_checked(wxyz[0], wxyz[1], wxyz[2], wxyz[3], translation, pose);
      why != nullptr)
    return in_quotes(path) + ": " + why;
  rotation_wxyz = {wxyz[0], wxyz[1], wxyz[2], wxyz[3]};
  translation_out = translation;
  return {};
}

std::string parse_pose_or_throw(const Json& value, std::string_view path, Pose<double>& out) {
  std::array<double, 4> q;
  Vec3<double> translation;
  if (std::string error = parse_pose_parts_or_throw(value, path, q, translation); !error.empty())
    return error;
  // Checked above; this normalises the quaternion.
  pose_from_quaternion_checked(q[0], q[1], q[2], q[3], translation, out);
  return {};
}

}  // namespace

std::string short_prefix(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return std::string(text);
  std::size_t cut = max_bytes;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return std::string(text.substr(0, cut)) + "...";
}

std::string user_key(const std::string& key) {
  constexpr std::size_t kMaxBytes = 60;
  // Replace, not throw, on invalid UTF-8: keys from YAML files are not validated by a JSON parser.
  std::string cut = key.size() <= kMaxBytes ? key : short_prefix(key, kMaxBytes);
  return Json(std::move(cut)).dump(-1, ' ', false, Json::error_handler_t::replace);
}

namespace {

// One pass over the text before nlohmann's parser sees it: the nesting depth of arrays and
// objects (outside strings) and numbers that overflow a double, each reported with its line and
// column. nlohmann parses any depth without recursion, but the values it builds are then copied,
// compared and dumped recursively; and its overflow error (out_of_range 406) names no position.
// Brackets are only counted, not matched: the parser reports mismatches.
std::string scan_json(std::string_view text, int* error_id) {
  int depth = 0;
  std::size_t line = 1, line_start = 0;
  auto where = [&](std::size_t at) {
    return " at line " + std::to_string(line) + ", column " + std::to_string(at - line_start + 1);
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = i + 1;
    } else if (c == '"') {
      // Skip the string (escapes included); an unterminated one is the parser's to report.
      for (++i; i < text.size() && text[i] != '"'; ++i)
        if (text[i] == '\\') ++i;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxNestingDepth) {
        if (error_id != nullptr) *error_id = 0;
        return "nesting deeper than " + std::to_string(kMaxNestingDepth) + " levels" + where(i);
      }
    } else if (c == ']' || c == '}') {
      if (depth > 0) --depth;
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      std::size_t end = i + 1;
      while (end < text.size() &&
             (std::isdigit(static_cast<unsigned char>(text[end])) || text[end] == '.' ||
              text[end] == 'e' || text[end] == 'E' || text[end] == '+' || text[end] == '-'))
        ++end;
      const std::string token(text.substr(i, end - i));
      if (std::isinf(std::strtod(token.c_str(), nullptr))) {
        if (error_id != nullptr) *error_id = 406;
        return "number " + short_prefix(token, 40) +
               " is out of range (JSON numbers must be finite doubles)" + where(i);
      }
      i = end - 1;
    }
  }
  return {};
}

}  // namespace

std::string parse_json(std::string_view text, Json& out, int* error_id) noexcept {
  try {
    if (std::string error = scan_json(text, error_id); !error.empty()) return error;
    out = Json::parse(text);
    return {};
  } catch (const Json::exception& e) {
    if (error_id != nullptr) *error_id = e.id;
    std::string message = e.what();
    if (const std::size_t bracket = message.find("] "); bracket != std::string::npos)
      message.erase(0, bracket + 2);  // "[json.exception.parse_error.101] "
    return short_prefix(message, 200);
  } catch (const std::exception& e) {  // exhausted memory
    if (error_id != nullptr) *error_id = 0;
    return std::string("cannot parse: ") + e.what();
  }
}

std::string describe_type(const Json& value) {
  switch (value.type()) {
    case Json::value_t::null:
      return "null";
    case Json::value_t::boolean:
      return "a boolean";
    case Json::value_t::number_integer:
    case Json::value_t::number_unsigned:
    case Json::value_t::number_float:
      return "a number";
    case Json::value_t::string:
      return "a string";
    case Json::value_t::array:
      if (value.empty()) return "an empty array";
      return "an array of " + std::to_string(value.size()) +
             (value.size() == 1 ? " element" : " elements");
    case Json::value_t::object:
      return value.empty() ? "an empty object" : "an object";
    case Json::value_t::binary:
    case Json::value_t::discarded:
      break;
  }
  return "an unusable value";
}

std::string parse_shape(const Json& value, std::string_view path, PlacedShape& out) noexcept {
  try {
    return parse_shape_or_throw(value, path, out);
  } catch (const std::exception& e) {
    // Only reachable through a bug or exhausted memory: the checks above guard every access.
    return in_quotes(path) + ": " + e.what();
  }
}

std::string parse_shape_spec(const Json& value, std::string_view path, ShapeSpec& out) noexcept {
  try {
    return parse_spec_or_throw(value, path, out, nullptr);
  } catch (const std::exception& e) {
    return in_quotes(path) + ": " + e.what();
  }
}

bool looks_like_shape(const Json& value) {
  if (!value.is_object()) return false;
  for (const auto& [key, ignored] : value.items())
    if (is_shape_kind(key)) return true;
  return false;
}

std::string parse_pose_parts(const Json& value, std::string_view path,
                             std::array<double, 4>& rotation_wxyz,
                             Vec3<double>& translation) noexcept {
  try {
    return parse_pose_parts_or_throw(value, path, rotation_wxyz, translation);
  } catch (const std::exception& e) {
    return in_quotes(path) + ": " + e.what();
  }
}

std::string parse_pose(const Json& value, std::string_view path, Pose<double>& out) noexcept {
  try {
    return parse_pose_or_throw(value, path, out);
  } catch (const std::exception& e) {
    return in_quotes(path) + ": " + e.what();
  }
}

}  // namespace nearpoint::formats
