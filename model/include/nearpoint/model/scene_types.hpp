// SPDX-License-Identifier: Apache-2.0
// The scene model: the plain inputs and outputs of the scene API, shared by the server, the client
// and the file formats. They mirror the wire messages of nearpoint.v1 field for field (so error
// paths such as "poses[2].pose.rotation" read the same on every transport) but depend on no
// transport, no thread and no server: the gRPC service and the DDS bridge convert their messages
// to and from these, the client builds requests from them, and formats/ reads files into them.
// Header-only over the core; link nearpoint::model.
//
// Units: metres and radians. Frames: world; an object's geometry frame; a piece's piece frame.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "nearpoint/pose.hpp"
#include "nearpoint/shapes.hpp"

namespace nearpoint::model {

using Vec3d = Vec3<double>;

/// The largest gRPC message nearpointd receives or sends by default (its --max-message-bytes),
/// and the default receive limit of the C++ client, the CLI and the Python client, so that any
/// report the server can send reaches them (gRPC's own default receive limit is 4 MiB). Part of
/// the model because both ends of the wire must agree on it.
inline constexpr std::size_t kDefaultMaxMessageBytes = 16u << 20;

/// A rigid transformation as received: quaternion (w, x, y, z) and translation (metres), not yet
/// checked. The default is the identity.
struct PoseInput {
  std::array<double, 4> rotation_wxyz = {1, 0, 0, 0};
  Vec3d translation = Vec3d::Zero();
};

/// A polytope piece as received: its vertices, metres, piece frame.
struct PolytopeInput {
  std::vector<Vec3d> vertices;
};

/// One convex piece (see nearpoint.v1.Piece). `std::monostate`: no shape was given.
struct PieceInput {
  std::variant<std::monostate, PolytopeInput, Point, Segment<double>, Box<double>, Cylinder<double>,
               Cone<double>, Ellipsoid<double>>
      shape;
  /// Spherical-extension radius, metres.
  double radius = 0;
  /// Piece frame → geometry frame.
  PoseInput offset;
};

struct GeometryInput {
  std::string name;
  std::vector<PieceInput> pieces;
};

struct GeometryInfo {
  std::string geometry_id;
  std::string name;
  std::size_t piece_count = 0;
  std::size_t vertex_count = 0;
  /// Sphere enclosing the geometry: centre (geometry frame, metres) and radius (metres).
  Vec3d bounding_center = Vec3d::Zero();
  double bounding_radius = 0;
};

/// `unknown`: a value this server does not know (a newer client); rejected naming the field.
enum class PenetrationMode : unsigned char { unspecified, none, bound, depth, unknown };

/// Which pairs a report holds (see nearpoint.v1.ReportMode). `unknown`: a value this server does
/// not know; rejected naming the field.
enum class ReportMode : unsigned char {
  unspecified,
  all_pairs,
  within_cutoff,
  nearest_per_object,
  global_minimum,
  changed,
  unknown
};

/// Option overrides; an unset field inherits (update → scene defaults → engine defaults).
struct QueryOptionsInput {
  std::optional<double> epsilon;
  std::optional<bool> near_points;
  PenetrationMode penetration = PenetrationMode::unspecified;
  std::optional<bool> gradient;
  std::optional<double> distance_cutoff;
  std::optional<bool> warm_start;
  std::optional<std::uint64_t> max_iterations;
  ReportMode report_mode = ReportMode::unspecified;
  /// REPORT_MODE_CHANGED: how far (metres, >= 0, +inf allowed) a pair's distance may move from
  /// the one last reported before it is reported again. Default 0 (any change).
  std::optional<double> change_tolerance;
};

struct ObjectInput {
  std::string id;
  std::string geometry_id;
  /// Initial pose: geometry frame → world frame.
  PoseInput pose;
  std::optional<std::uint32_t> group;
  std::optional<std::uint32_t> mask;
  /// MoveIt's padding (see nearpoint.v1.SceneObject): metres, finite, >= 0. `padding` inflates
  /// the object in its pairs with objects of other bodies, `self_padding` in its pairs with
  /// objects of the same non-empty `body` (an id, like the object's).
  double padding = 0;
  double self_padding = 0;
  std::string body{};
};

struct PairSelectionInput {
  enum class Mode : unsigned char { all_pairs, listed_pairs, excluded_pairs };
  Mode mode = Mode::all_pairs;
  /// (object_a, object_b) ids: the pairs listed (listed_pairs) or left out (excluded_pairs).
  std::vector<std::pair<std::string, std::string>> pairs;
};

/// A watched distance (see nearpoint.v1.Threshold): a stream's reports carry an ENTER event when
/// a watched pair comes closer than `distance`, an EXIT event when it gets farther than
/// `distance + hysteresis`. Which pairs: both ids, that pair; `object_a` alone, its pairs; no id,
/// every selected pair; a non-zero `groups` further keeps the pairs whose other object (with no id:
/// either object) has a group bit in it.
struct ThresholdInput {
  /// Echoed in events; at most 256 bytes of UTF-8, may be empty.
  std::string name;
  /// Metres, finite; > 0 unless the stream's penetration mode is depth (then the signed distance
  /// is compared, and a negative threshold watches a penetration deeper than −distance).
  double distance = 0;
  /// Metres, finite, >= 0.
  double hysteresis = 0;
  std::string object_a;
  std::string object_b;
  std::uint32_t groups = 0;
};

/// The kind of a robot joint (see nearpoint.v1.JointType, same numbers). `unspecified` and
/// `unknown` (a number this side does not know) are refused naming the field.
enum class JointType : unsigned char {
  unspecified,
  fixed,
  revolute,
  continuous,
  prismatic,
  ball,
  free,
  unknown
};

/// One robot joint as sent (see nearpoint.v1.RobotJoint): axis and anchor in the link's frame.
struct RobotJointInput {
  std::string name;
  JointType type = JointType::unspecified;
  Vec3d axis = Vec3d::UnitZ();
  Vec3d anchor = Vec3d::Zero();
  double reference = 0;
  bool limited = false;
  double lower = 0;
  double upper = 0;
};

/// One link (see nearpoint.v1.RobotLink): its parent by name ("" = the world), its placement on
/// the parent, the joints that move it.
struct RobotLinkInput {
  std::string name;
  std::string parent;
  PoseInput offset;
  std::vector<RobotJointInput> joints;
};

/// A scene object carried by a link: link frame → the object's geometry frame.
struct RobotAttachmentInput {
  std::string object_id;
  std::string link;
  PoseInput offset;
};

/// A scene's kinematic forest (see nearpoint.v1.Robot); no links: the scene has no robot.
struct RobotInput {
  std::string name;
  std::vector<RobotLinkInput> links;
  std::vector<RobotAttachmentInput> attachments;
  bool empty() const { return links.empty() && attachments.empty(); }
};

struct SceneInput {
  std::string name;
  /// The id the client asks for ("" = the server assigns "scene-N"). Taken: ALREADY_EXISTS.
  std::string requested_id;
  std::vector<ObjectInput> objects;
  PairSelectionInput pair_selection;
  QueryOptionsInput default_options;
  /// Thresholds every stream on the scene watches unless its first update names its own.
  std::vector<ThresholdInput> thresholds;
  /// Geometries sent with the scene (nearpoint.v1.CreateSceneRequest.geometries), by a key that
  /// objects may name as their geometry_id; stored as by RegisterGeometry before the objects are
  /// resolved.
  std::map<std::string, GeometryInput> geometries;
  /// The scene's robot (empty: none); its attachments name objects of `objects`.
  RobotInput robot;
  /// Opaque digest of the whole request as received (the gRPC adapter: SHA-256 of its
  /// deterministic serialization); empty when there is none. A creation under a taken
  /// requested_id whose fingerprint equals the existing scene's is the same request again: it is
  /// answered as the first was instead of ALREADY_EXISTS (idempotent re-creation).
  std::string fingerprint;
};

struct SceneInfo {
  std::string scene_id;
  std::size_t pair_count = 0;
  /// The stored id of each inline geometry (SceneInput::geometries), by its key.
  std::map<std::string, std::string> geometry_ids;
};

struct ObjectPoseInput {
  std::string object_id;
  /// Geometry frame → world frame.
  PoseInput pose;
};

/// Joint positions by name (see nearpoint.v1.JointPositions): each name takes its joint's
/// number of position values (1; ball 4; free 7) from `positions`, in order. Joints not named
/// keep their previous positions; `base_pose` unset keeps the previous base pose.
struct JointPositionsInput {
  std::vector<std::string> names;
  std::vector<double> positions;
  std::optional<PoseInput> base_pose;
  bool empty() const { return names.empty() && positions.empty() && !base_pose; }
};

/// See nearpoint.v1.FlowControl. `unknown`: a value this server does not know; rejected.
enum class FlowControl : unsigned char { block, coalesce, unknown };

struct PoseUpdateInput {
  std::string scene_id;
  std::uint64_t sequence = 0;
  std::vector<ObjectPoseInput> poses;
  QueryOptionsInput options;
  /// Read from a stream's first update only.
  FlowControl flow_control = FlowControl::block;
  /// The stream's watched thresholds; set by its first update only (later updates: empty).
  std::vector<ThresholdInput> thresholds;
  /// Robot scenes: joint positions instead of the poses of the objects the robot carries.
  JointPositionsInput joints;
};

struct QueryInput {
  std::string scene_id;
  std::vector<ObjectPoseInput> poses;
  QueryOptionsInput options;
  std::uint64_t sequence = 0;
  /// Robot scenes: joint positions (joints not named at their reference positions).
  JointPositionsInput joints;
};

// ---- outputs ----

enum class PairStatus : unsigned char {
  separated,
  intersecting,
  beyond_cutoff,
  iteration_limit,
  engine_error,
  /// Contact within the bound: the signed distance's certified interval contains 0 (see
  /// nearpoint.v1.PAIR_STATUS_TOUCHING). "In contact" is intersecting or touching: in_contact().
  touching,
};

/// Whether `status` says the pair is in contact: proven overlapping (intersecting) or within its
/// error bound of touching (touching). Every "counts as a collision" test uses this.
constexpr bool in_contact(PairStatus status) {
  return status == PairStatus::intersecting || status == PairStatus::touching;
}

/// How a pair's penetration-depth computation ended (see nearpoint.v1.DepthTermination and
/// nearpoint::DepthTermination). `unknown`: a number the reader does not know (a newer server).
enum class DepthTermination : unsigned char {
  unspecified,
  closed_form,
  tolerance,
  iteration_limit,
  degenerate,
  unknown,
};

/// What the engine answered for one object pair, whoever names the pair (see
/// nearpoint.v1.PairDistance for every field's meaning). The server's PairReport names the
/// objects by their index in the scene; the client's PairDistance by their ids, as the wire does.
struct PairAnswer {
  PairStatus status = PairStatus::engine_error;
  double distance = 0;
  double distance_lower_bound = 0;
  double error_bound = 0;
  std::uint32_t iterations = 0;
  std::uint32_t piece_pairs_evaluated = 0;
  std::uint32_t piece_a = 0;
  std::uint32_t piece_b = 0;
  bool warm_started = false;
  bool has_near_points = false;
  /// World frame, metres.
  Vec3d point_a = Vec3d::Zero();
  Vec3d point_b = Vec3d::Zero();
  /// Unit vector A → B, world frame (zero when the cores overlap).
  Vec3d normal = Vec3d::Zero();
  bool has_penetration_bound = false;
  double penetration_bound = 0;
  bool has_gradient = false;
  /// (∂/∂translation, ∂/∂rotation vector), world frame.
  Eigen::Matrix<double, 6, 1> gradient_a = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> gradient_b = Eigen::Matrix<double, 6, 1>::Zero();
  /// With PENETRATION_MODE_DEPTH: the signed distance (distance when apart, −depth when
  /// overlapping), metres, and its certified interval [lower, upper].
  bool has_signed_distance = false;
  double signed_distance = 0;
  double signed_distance_lower = 0;
  double signed_distance_upper = 0;
  /// With PENETRATION_MODE_DEPTH: the penetration depth (>= 0), metres, its certified interval,
  /// witness points on A and B (world frame, point_a − point_b = depth·direction), the unit
  /// direction A → B along which moving B by `depth` separates the pair, how the computation
  /// ended and its expansion steps.
  bool has_penetration_depth = false;
  double depth = 0;
  double depth_lower = 0;
  double depth_upper = 0;
  Vec3d depth_point_a = Vec3d::Zero();
  Vec3d depth_point_b = Vec3d::Zero();
  Vec3d depth_direction = Vec3d::Zero();
  DepthTermination depth_termination = DepthTermination::unspecified;
  std::uint32_t depth_iterations = 0;
};

/// The answer for one object pair of a scene, as the server computes it.
struct PairReport : PairAnswer {
  /// Indices into the scene's objects.
  std::uint32_t object_a = 0;
  std::uint32_t object_b = 0;
  /// Static text for engine_error, else nullptr.
  const char* engine_message = nullptr;
};

/// One entry of a pair's joint-space gradient (see nearpoint.v1.JointDerivative).
struct JointDerivative {
  std::string joint;
  /// 0 for one-dof joints; 0–2 ball, 0–5 free.
  std::uint32_t coordinate = 0;
  double value = 0;
};

/// A joint outside its limits at an update's positions (reported, not enforced).
struct JointLimitViolation {
  std::string joint;
  double position = 0;
  double lower = 0;
  double upper = 0;
};

enum class Crossing : unsigned char { enter, exit };

/// A watched pair crossed a threshold (see nearpoint.v1.ThresholdEvent).
struct ThresholdEvent {
  /// Index in the stream's thresholds.
  std::uint32_t threshold = 0;
  /// Index in the scene's pairs, and the pair's objects (indices into the scene's objects).
  std::uint32_t pair = 0;
  std::uint32_t object_a = 0;
  std::uint32_t object_b = 0;
  Crossing crossing = Crossing::enter;
  /// The distance that crossed, metres: the pair's distance (0 when in contact; with
  /// PENETRATION_MODE_DEPTH the signed distance, negative when overlapping), or for a pair proven
  /// beyond the cutoff the lower bound that proves it.
  double distance = 0;
  /// The update whose poses crossed (an absorbed one's when coalesced).
  std::uint64_t sequence = 0;
};

/// Server-side timing of one report, microseconds (steady clock).
struct ReportTiming {
  double server_us = 0;
  double queue_us = 0;
  double evaluation_us = 0;
  double geometry_us = 0;
};

/// What one report cost: every selected pair is counted in exactly one of these.
struct ReportCounts {
  /// Pairs handed to the distance engine.
  std::uint32_t pairs_evaluated = 0;
  /// Pairs the broad phase proved farther apart than the cutoff (reported BEYOND_CUTOFF with the
  /// boxes' gap as the lower bound); the engine never saw them.
  std::uint32_t pairs_pruned = 0;
  /// Pairs of two objects whose poses equal (bitwise) those of the stream's previous report, under
  /// the same options: their previous result is repeated.
  std::uint32_t pairs_unmoved = 0;
};

}  // namespace nearpoint::model
