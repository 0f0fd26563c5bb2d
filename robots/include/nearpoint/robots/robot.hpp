// SPDX-License-Identifier: Apache-2.0
// Robot descriptions (URDF, MJCF; an SRDF beside a URDF) → a kinematic tree, the collision
// objects attached to its links, and the pairs robot users expect to be checked — in the scene
// model's vocabulary (nearpoint/model/scene_types.hpp), so that a robot becomes a scene.
//
// URDF (read by urdfdom): one object per link that has <collision> elements, a compound of them
// (box, cylinder, sphere; a mesh becomes the convex hull of the whole file times its `scale`).
// Pairs: all, minus parent–child links and an SRDF's <disable_collisions>.
// MJCF (read with tinyxml2): one object per geom (MuJoCo collides geoms), <default> classes,
// childclass, <include>, compiler angle/eulerseq/meshdir, body pos/quat/euler/axisangle/xyaxes/
// zaxis, fromto. Pairs by MuJoCo's rules: contype/conaffinity, bodies welded together, parent–child
// bodies (filterparent), <exclude>, and explicit <pair>s.
// Errors name the file, the element and the reason; unsupported elements and attributes that
// change geometry are errors, not silently skipped.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "nearpoint/compound.hpp"
#include "nearpoint/formats/scene_file.hpp"
#include "nearpoint/model/scene_types.hpp"
#include "nearpoint/robots/kinematics.hpp"

namespace nearpoint::robots {

/// One collision object of a robot: a geometry rigidly attached to a link.
struct RobotObject {
  /// The scene object id: the URDF link's name, or the MJCF geom's name (else "body/geomN").
  std::string name;
  /// The link it rides on, or -1 for the world (static geometry).
  int link = -1;
  /// Link frame → the object's geometry frame.
  Pose3d offset;
  model::GeometryInput geometry;
  /// Metres, >= 0: ObjectInput::padding.
  double padding = 0;
};

struct Robot {
  std::string name;
  KinematicTree tree;
  std::vector<RobotObject> objects;
  /// The object pairs (i < j) to check; every other pair is excluded.
  std::vector<std::pair<int, int>> pairs;

  /// Object i's pose (geometry frame → world) in `state`.
  Pose3d object_pose(const KinematicState& state, int object) const;

  /// The joint-space gradient (size nv) of a pair's distance from the engine's pose gradients of
  /// its two objects (DistanceResult::gradient_a/gradient_b with the objects' poses).
  Eigen::VectorXd joint_gradient(const KinematicState& state, int object_a, const Vec6d& gradient_a,
                                 int object_b, const Vec6d& gradient_b) const;

  /// The robot as a scene at `state`: a geometry per object (keyed by the object's name), the
  /// objects with their poses, group/mask unset, padding per object, and the pair selection
  /// (listed or excluded pairs, whichever list is shorter).
  formats::SceneFile to_scene(const KinematicState& state) const;
};

struct ImportOptions {
  /// Directories where `package://NAME/…` resolves to DIR/NAME/… (the first that exists), and
  /// where relative mesh paths are looked up after the description file's own directory.
  std::vector<std::filesystem::path> search_path;
  /// Reads mesh files into convex pieces (the client's assimp importer; formats::MeshLoader).
  /// Empty: a mesh is an error saying so.
  formats::MeshLoader meshes;
  /// URDF: leave out parent–child link pairs (MoveIt's "Adjacent"). MJCF follows MuJoCo's rules.
  bool exclude_adjacent = true;
  /// Padding of every object of a link, by link name; others get `default_padding`.
  std::map<std::string, double> link_padding;
  double default_padding = 0;
};

/// The outcome of an import: the robot, or an error message naming the file, element and reason.
struct RobotImport {
  Robot robot;
  std::string error;
  bool ok() const { return error.empty(); }
};

/// A URDF file (and, if `srdf` is not empty, the SRDF whose <disable_collisions> remove pairs).
RobotImport load_urdf(const std::filesystem::path& file, const ImportOptions& options = {},
                      const std::filesystem::path& srdf = {});
/// URDF text; mesh paths relative to `base_dir`; `label` names it in messages.
RobotImport parse_urdf(const std::string& xml, const std::string& label,
                       const std::filesystem::path& base_dir, const ImportOptions& options = {});
/// Applies an SRDF's <disable_collisions link1 link2/> to an imported URDF robot.
std::string apply_srdf(const std::string& xml, const std::string& label, Robot& robot);

/// An MJCF (MuJoCo XML) file; <include> files are read relative to it.
RobotImport load_mjcf(const std::filesystem::path& file, const ImportOptions& options = {});
/// MJCF text (<include> resolved against `base_dir`).
RobotImport parse_mjcf(const std::string& xml, const std::string& label,
                       const std::filesystem::path& base_dir, const ImportOptions& options = {});

/// By extension: .urdf → URDF, .xml/.mjcf → MJCF.
RobotImport load_robot(const std::filesystem::path& file, const ImportOptions& options = {});

/// The robot as an articulated scene for nearpointd (nearpoint.v1.Robot): to_scene at the
/// neutral positions plus the kinematic forest (model::RobotInput), every object of a link
/// attached to it (objects of the world stay static), so that updates carry joint positions.
formats::SceneFile to_robot_scene(const Robot& robot);

/// Whether `file` names a robot description by its extension (.urdf, .mjcf; .xml when its root
/// element is <mujoco>).
bool is_robot_file(const std::filesystem::path& file);

/// load_robot, for a URDF with `srdf` applied (empty: FILE.srdf beside it when that exists),
/// then to_robot_scene. Returns "" or the error naming the file, element and reason.
std::string load_robot_scene(const std::filesystem::path& file, const ImportOptions& options,
                             const std::filesystem::path& srdf, formats::SceneFile& out);

/// A scene file's "robot" (SceneFile::robot, set) loaded with load_robot_scene and merged in: its
/// geometries and objects after the file's, its kinematic forest, its left-out pairs added to the
/// file's "pairs" ("all" or "excluded" only: a listed selection is refused, it would have to name
/// the robot's pairs), its name as the scene id when the file asks for none. `options`'s search
/// path gets the reference's package_path first. Returns "" or the error.
std::string add_robot_to_scene(formats::SceneFile& file, ImportOptions options);

/// The engine's compound for a geometry of the scene model (for evaluating distances in-process,
/// as the server does); "" or why the geometry is unusable.
std::string make_compound(const model::GeometryInput& geometry, Compound<double>& out);

}  // namespace nearpoint::robots
