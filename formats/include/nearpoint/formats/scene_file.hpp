// SPDX-License-Identifier: Apache-2.0
// Geometry and scene files: JSON (or YAML with the same structure) → the scene API's plain
// structs (the scene model, nearpoint/model/scene_types.hpp). Transport-free, so that the client
// (`nearpoint register`, `nearpoint scene create`) and the server (`nearpointd --scene`) read the
// same files with the same messages.
//
// GEOMETRY (a union of convex pieces), one of:
//   SHAPE                                    one piece; its "pose" places it in the geometry frame
//   [SHAPE, ...]                             several pieces
//   {"name": "...", "pieces": [SHAPE, ...]}
//   {"mesh": "part.obj" | ["a.obj", ...], "scale": 1.0, "merge": false}
//                                            convex hulls of mesh parts (one piece per part, or one
//                                            hull of everything with "merge": true); paths are
//                                            relative to the file that names them
// SCENE:
//   {"id": "cell-1",                         optional: the scene id to request from the server
//    "name": "work cell",                    optional label
//    "geometries": {"NAME": GEOMETRY, ...},
//    "objects": [{"id": "arm", "geometry": "NAME" | "geometry_id": "geom-4",
//                 "pose": {"rotation": [w,x,y,z], "translation": [x,y,z]},
//                 "group": 1, "mask": 4294967295,
//                 "padding": 0.02, "self_padding": 0, "body": "robot"}, ...],
//    "pairs": "all" | {"listed": [["a","b"], ...]} | {"excluded": [["a","b"], ...]},
//    "options": {"epsilon": e, "near_points": bool, "penetration": "none"|"bound"|"depth",
//                "gradient": bool, "distance_cutoff": d, "warm_start": bool, "max_iterations": n,
//                "report_mode": "all"|"within-cutoff"|"nearest"|"global"|"changed",
//                "change_tolerance": t},
//    "thresholds": [{"name": "near", "distance": d, "hysteresis": h, "object_a": "arm",
//                    "object_b": "table", "groups": 2}, ...]}   watched by every stream
//                    (with "penetration": "depth" a distance may be <= 0: a depth to watch)
// Units: metres and radians. Unknown keys are errors (a misspelt key must not silently vanish).
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "nearpoint/formats/json_shapes.hpp"
#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::formats {

/// Reads the convex pieces of mesh files (the client links a mesh importer; nearpointd does not).
/// Returns "" and fills `pieces` (polytope pieces, identity offsets), or a message.
struct MeshRequest {
  std::vector<std::filesystem::path> files;
  double scale = 1.0;
  bool merge = false;
};
using MeshLoader =
    std::function<std::string(const MeshRequest& request, std::vector<model::PieceInput>& pieces)>;

/// A scene file's content. Objects name their geometry by `geometry_names[i]` (a key of
/// `geometries`), or, when that is empty, by `scene.objects[i].geometry_id` (already registered).
/// The requested scene id ("id") is `scene.requested_id`.
/// A scene file's "robot": a robot description whose links become objects of the scene beside
/// the file's own (read by robots/, which formats/ does not link: robots::add_robot_to_scene).
/// Either a path, or {"file": PATH, "srdf": PATH, "package_path": [DIR, ...]}; paths relative to
/// the scene file.
struct RobotReference {
  std::filesystem::path file;
  std::filesystem::path srdf;
  std::vector<std::filesystem::path> package_path;
};

struct SceneFile {
  std::vector<std::pair<std::string, model::GeometryInput>> geometries;
  std::vector<std::string> geometry_names;
  model::SceneInput scene;
  /// Set when the file names a robot; its objects are not in `scene.objects` yet.
  std::optional<RobotReference> robot;
};

/// The file's text as JSON: JSON directly, or YAML (by extension .yaml/.yml) converted when the
/// library was built with yaml-cpp. Returns "" or a message naming the file (and line).
std::string read_structured_file(const std::filesystem::path& file, Json& out);

/// GEOMETRY at `path` (for messages) → `out`. Mesh paths are resolved against `base_dir`;
/// `meshes` may be empty (then a mesh geometry is an error saying so).
std::string parse_geometry(const Json& value, const std::string& path,
                           const std::filesystem::path& base_dir, const MeshLoader& meshes,
                           model::GeometryInput& out);

/// SCENE → `out`. Never throws; messages name the field ("objects[2].pose.rotation").
std::string parse_scene(const Json& value, const std::filesystem::path& base_dir,
                        const MeshLoader& meshes, SceneFile& out);

/// read_structured_file + parse_scene, messages prefixed with the file name.
std::string load_scene_file(const std::filesystem::path& file, const MeshLoader& meshes,
                            SceneFile& out);

/// QueryOptions as in a scene's "options" (also used for per-query options).
std::string parse_query_options(const Json& value, const std::string& path,
                                model::QueryOptionsInput& out);

/// The scene API's piece for a parsed SHAPE.
model::PieceInput to_piece(const ShapeSpec& spec);

}  // namespace nearpoint::formats
