// SPDX-License-Identifier: Apache-2.0
// SHAPE objects of the JSON shape syntax (docs/design.md, the `nearpoint distance` contract) →
// engine shapes and poses, or the shapes as written (for geometry files, scene files and the
// wire). One syntax for shapes everywhere: `nearpoint distance`, `nearpoint register`, scene files
// and `nearpointd --scene` all parse SHAPEs here.
//
//   SHAPE = {"polytope": [[x,y,z], ...]} | {"sphere": {}} | {"segment": [[x,y,z],[x,y,z]]}
//         | {"box": [hx,hy,hz]} | {"ellipsoid": [rx,ry,rz]}
//         | {"cylinder": {"radius": r, "half_height": h}} | {"cone": {"radius": r, "half_height":
//         h}}
//   plus optional "radius": r (spherical extension, ≥ 0) and
//   "pose": {"rotation": [w,x,y,z], "translation": [x,y,z]} (each part optional: identity / zero).
//
// Parsing never throws: every problem comes back as a message that names the offending field by
// its path ("a.polytope[2]", "b.pose.rotation"), so that a bad input line becomes one error line.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "nearpoint/pose.hpp"
#include "nearpoint/shapes.hpp"

namespace nearpoint::formats {

/// The JSON value type used throughout the command-line tool. Ordered, so that output objects keep
/// the field order of the contract and echoed ids keep the caller's key order.
using Json = nlohmann::ordered_json;

/// A shape and where it sits in the world.
struct PlacedShape {
  Shape<double> shape;
  Pose<double> pose;
};

/// A SHAPE as written, before the engine builds anything from it: polytope vertices as given (the
/// engine's Polytope stores them centred), the quaternion as given (checked to be within 1e-4 of
/// unit length). What a client sends to the server.
struct ShapeSpec {
  std::variant<std::vector<Vec3<double>>, Point, Segment<double>, Box<double>, Cylinder<double>,
               Cone<double>, Ellipsoid<double>>
      geometry;
  /// Spherical-extension radius, >= 0.
  double radius = 0;
  /// "pose": local → world (for a geometry's piece: piece frame → geometry frame).
  std::array<double, 4> rotation_wxyz = {1, 0, 0, 0};
  Vec3<double> translation = Vec3<double>::Zero();
};

/// The shape kinds, in the order the help text lists them.
inline constexpr const char* kShapeKinds[] = {"polytope",  "sphere",   "segment", "box",
                                              "ellipsoid", "cylinder", "cone"};

/// Parses the SHAPE object `value`, found at `path` in its line (e.g. "a"), into `out`.
/// Returns an empty string on success; otherwise a message naming the problem, e.g.
/// `"a.polytope" must be a non-empty array of [x,y,z]`. Unknown keys are errors (a misspelt
/// "radius" must not silently give a radius of 0). After the syntax checks the engine's own
/// `invalid_reason` has the last word. Never throws.
std::string parse_shape(const Json& value, std::string_view path, PlacedShape& out) noexcept;

/// Parses the SHAPE object `value` at `path` into `out`, with the same checks and messages as
/// `parse_shape` (the engine's validation included). Never throws.
std::string parse_shape_spec(const Json& value, std::string_view path, ShapeSpec& out) noexcept;

/// True when `value` is an object naming one of the shape kinds (a SHAPE rather than some other
/// object).
bool looks_like_shape(const Json& value);

/// Parses a "pose" object at `path` into its quaternion (checked) and translation, as written.
std::string parse_pose_parts(const Json& value, std::string_view path,
                             std::array<double, 4>& rotation_wxyz,
                             Vec3<double>& translation) noexcept;

/// Parses a "pose" object at `path` into `out`; the quaternion goes through
/// `pose_from_quaternion_checked` (rejected when its norm is off by more than 1e-4).
/// Returns an empty string on success, else a message naming the problem. Never throws.
std::string parse_pose(const Json& value, std::string_view path, Pose<double>& out) noexcept;

/// The JSON type of `value` as a user would say it ("a string", "an object", "null" …), for
/// messages of the form "must be … (got a string)".
std::string describe_type(const Json& value);

/// The deepest nesting of arrays and objects accepted in a JSON line or a structured file (JSON or
/// YAML). Real inputs nest 6 levels at most; the bound keeps the recursive code that copies,
/// compares, dumps and converts values far from the end of the stack on hostile input (a line
/// nested 100,000 deep overflowed it).
inline constexpr int kMaxNestingDepth = 64;

/// Parses the JSON text `text` into `out`. Before the parser builds anything, refuses nesting
/// deeper than kMaxNestingDepth and numbers beyond the range of a double (`1e999`), with the line
/// and column. Returns "" or a message such as "nesting deeper than 64 levels at line 1, column
/// 65", "number 1e999 is out of range (JSON numbers must be finite doubles) at line 3, column 12"
/// or the parser's own "parse error at line 1, column 5: …" (without nlohmann's "[json.exception…]"
/// prefix, cut to a short prefix). `error_id`, when given, gets nlohmann's exception id (101 a
/// syntax error, 406 a number out of range) or 0 (too deep, or another failure). Never throws.
std::string parse_json(std::string_view text, Json& out, int* error_id = nullptr) noexcept;

/// At most `max_bytes` of `text`, cut at a UTF-8 boundary and marked "...": for quoting user input
/// in messages without flooding them.
std::string short_prefix(std::string_view text, std::size_t max_bytes = 120);

/// A key written by the user, JSON-escaped and cut to 60 bytes (at a UTF-8 boundary, marked
/// "..."), for messages such as `unknown key "colour"`: a hostile key cannot flood or break them.
std::string user_key(const std::string& key);

}  // namespace nearpoint::formats
