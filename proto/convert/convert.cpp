// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/proto/convert.hpp"

#include <algorithm>
#include <cstdint>
#include <type_traits>

#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::proto {
namespace {

// The vocabulary's wire numbers are the generated enums' values.
constexpr bool same(std::int64_t wire_value, std::int64_t generated) {
  return wire_value == generated;
}
using model::Crossing;
using model::FlowControl;
using model::PairStatus;
using model::PenetrationMode;
using model::ReportMode;
static_assert(same(model::to_wire(PairStatus::separated), v1::PAIR_STATUS_SEPARATED));
static_assert(same(model::to_wire(PairStatus::intersecting), v1::PAIR_STATUS_INTERSECTING));
static_assert(same(model::to_wire(PairStatus::beyond_cutoff), v1::PAIR_STATUS_BEYOND_CUTOFF));
static_assert(same(model::to_wire(PairStatus::iteration_limit), v1::PAIR_STATUS_ITERATION_LIMIT));
static_assert(same(model::to_wire(PairStatus::engine_error), v1::PAIR_STATUS_ENGINE_ERROR));
static_assert(same(model::to_wire(PairStatus::touching), v1::PAIR_STATUS_TOUCHING));
using model::DepthTermination;
static_assert(same(model::to_wire(DepthTermination::unspecified),
                   v1::DEPTH_TERMINATION_UNSPECIFIED));
static_assert(same(model::to_wire(DepthTermination::closed_form),
                   v1::DEPTH_TERMINATION_CLOSED_FORM));
static_assert(same(model::to_wire(DepthTermination::tolerance), v1::DEPTH_TERMINATION_TOLERANCE));
static_assert(same(model::to_wire(DepthTermination::iteration_limit),
                   v1::DEPTH_TERMINATION_ITERATION_LIMIT));
static_assert(same(model::to_wire(DepthTermination::degenerate), v1::DEPTH_TERMINATION_DEGENERATE));
static_assert(same(model::to_wire(PenetrationMode::unspecified), v1::PENETRATION_MODE_UNSPECIFIED));
static_assert(same(model::to_wire(PenetrationMode::none), v1::PENETRATION_MODE_NONE));
static_assert(same(model::to_wire(PenetrationMode::bound), v1::PENETRATION_MODE_BOUND));
static_assert(same(model::to_wire(PenetrationMode::depth), v1::PENETRATION_MODE_DEPTH));
static_assert(same(model::to_wire(ReportMode::unspecified), v1::REPORT_MODE_UNSPECIFIED));
static_assert(same(model::to_wire(ReportMode::all_pairs), v1::REPORT_MODE_ALL_PAIRS));
static_assert(same(model::to_wire(ReportMode::within_cutoff), v1::REPORT_MODE_WITHIN_CUTOFF));
static_assert(same(model::to_wire(ReportMode::nearest_per_object),
                   v1::REPORT_MODE_NEAREST_PER_OBJECT));
static_assert(same(model::to_wire(ReportMode::global_minimum), v1::REPORT_MODE_GLOBAL_MINIMUM));
static_assert(same(model::to_wire(ReportMode::changed), v1::REPORT_MODE_CHANGED));
static_assert(model::from_wire<FlowControl>(v1::FLOW_CONTROL_UNSPECIFIED) == FlowControl::block);
static_assert(same(model::to_wire(FlowControl::block), v1::FLOW_CONTROL_BLOCK));
static_assert(same(model::to_wire(FlowControl::coalesce), v1::FLOW_CONTROL_COALESCE));
static_assert(same(model::to_wire(Crossing::enter), v1::THRESHOLD_CROSSING_ENTER));
static_assert(same(model::to_wire(Crossing::exit), v1::THRESHOLD_CROSSING_EXIT));

void write_piece(const model::PieceInput& piece, v1::Piece& p) {
  std::visit(
      [&](const auto& shape) {
        using S = std::decay_t<decltype(shape)>;
        if constexpr (std::is_same_v<S, model::PolytopeInput>) {
          for (const model::Vec3d& v : shape.vertices)
            to_proto(v, *p.mutable_polytope()->add_vertices());
        } else if constexpr (std::is_same_v<S, Point>) {
          p.mutable_point();
        } else if constexpr (std::is_same_v<S, Segment<double>>) {
          to_proto(shape.a, *p.mutable_segment()->mutable_a());
          to_proto(shape.b, *p.mutable_segment()->mutable_b());
        } else if constexpr (std::is_same_v<S, Box<double>>) {
          to_proto(shape.half_extents, *p.mutable_box()->mutable_half_extents());
        } else if constexpr (std::is_same_v<S, Cylinder<double>>) {
          p.mutable_cylinder()->set_radius(shape.radius);
          p.mutable_cylinder()->set_half_height(shape.half_height);
        } else if constexpr (std::is_same_v<S, Cone<double>>) {
          p.mutable_cone()->set_radius(shape.radius);
          p.mutable_cone()->set_half_height(shape.half_height);
        } else if constexpr (std::is_same_v<S, Ellipsoid<double>>) {
          to_proto(shape.radii, *p.mutable_ellipsoid()->mutable_radii());
        }
        // std::monostate: no shape.
      },
      piece.shape);
  p.set_radius(piece.radius);
  to_proto(piece.offset, *p.mutable_offset());
}

model::PieceInput read_piece(const v1::Piece& piece) {
  model::PieceInput in;
  in.radius = piece.radius();
  in.offset = from_proto(piece.offset());
  switch (piece.shape_case()) {
    case v1::Piece::kPolytope: {
      model::PolytopeInput polytope;
      polytope.vertices.reserve(std::size_t(piece.polytope().vertices_size()));
      for (const v1::Vector3& v : piece.polytope().vertices())
        polytope.vertices.push_back(from_proto(v));
      in.shape = std::move(polytope);
      break;
    }
    case v1::Piece::kPoint:
      in.shape = Point{};
      break;
    case v1::Piece::kSegment:
      in.shape = Segment<double>{from_proto(piece.segment().a()), from_proto(piece.segment().b())};
      break;
    case v1::Piece::kBox:
      in.shape = Box<double>{from_proto(piece.box().half_extents())};
      break;
    case v1::Piece::kCylinder:
      in.shape = Cylinder<double>{piece.cylinder().radius(), piece.cylinder().half_height()};
      break;
    case v1::Piece::kCone:
      in.shape = Cone<double>{piece.cone().radius(), piece.cone().half_height()};
      break;
    case v1::Piece::kEllipsoid:
      in.shape = Ellipsoid<double>{from_proto(piece.ellipsoid().radii())};
      break;
    case v1::Piece::SHAPE_NOT_SET:
      break;  // monostate: validation names the missing shape
  }
  return in;
}

void write_object(const model::ObjectInput& object, v1::SceneObject& o) {
  o.set_id(object.id);
  o.set_geometry_id(object.geometry_id);
  to_proto(object.pose, *o.mutable_pose());
  if (object.group) o.set_group(*object.group);
  if (object.mask) o.set_mask(*object.mask);
  o.set_padding(object.padding);
  o.set_self_padding(object.self_padding);
  o.set_body(object.body);
}

model::ObjectInput read_object(const v1::SceneObject& object) {
  model::ObjectInput in;
  in.id = object.id();
  in.geometry_id = object.geometry_id();
  in.pose = from_proto(object.pose());
  if (object.has_group()) in.group = object.group();
  if (object.has_mask()) in.mask = object.mask();
  in.padding = object.padding();
  in.self_padding = object.self_padding();
  in.body = object.body();
  return in;
}

void write_selection(const model::PairSelectionInput& in, v1::PairSelection& selection) {
  v1::PairList* list = nullptr;
  switch (in.mode) {
    case model::PairSelectionInput::Mode::all_pairs:
      selection.mutable_all_pairs();
      break;
    case model::PairSelectionInput::Mode::listed_pairs:
      list = selection.mutable_listed_pairs();
      break;
    case model::PairSelectionInput::Mode::excluded_pairs:
      list = selection.mutable_excluded_pairs();
      break;
  }
  if (list != nullptr)
    for (const auto& [a, b] : in.pairs) {
      v1::ObjectPair& pair = *list->add_pairs();
      pair.set_object_a(a);
      pair.set_object_b(b);
    }
}

model::PairSelectionInput read_selection(const v1::PairSelection& selection) {
  model::PairSelectionInput out;
  const v1::PairList* list = nullptr;
  switch (selection.selection_case()) {
    case v1::PairSelection::kListedPairs:
      out.mode = model::PairSelectionInput::Mode::listed_pairs;
      list = &selection.listed_pairs();
      break;
    case v1::PairSelection::kExcludedPairs:
      out.mode = model::PairSelectionInput::Mode::excluded_pairs;
      list = &selection.excluded_pairs();
      break;
    case v1::PairSelection::kAllPairs:
    case v1::PairSelection::SELECTION_NOT_SET:
      out.mode = model::PairSelectionInput::Mode::all_pairs;
      break;
  }
  if (list)
    for (const v1::ObjectPair& pair : list->pairs())
      out.pairs.emplace_back(pair.object_a(), pair.object_b());
  return out;
}

std::vector<model::ThresholdInput> read_thresholds(
    const google::protobuf::RepeatedPtrField<v1::Threshold>& thresholds) {
  std::vector<model::ThresholdInput> out;
  out.reserve(std::size_t(thresholds.size()));
  for (const v1::Threshold& threshold : thresholds) out.push_back(from_proto(threshold));
  return out;
}

}  // namespace

model::ObjectInput from_proto(const v1::SceneObject& object) {
  return read_object(object);
}

void to_proto(const model::Vec3d& v, v1::Vector3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

model::Vec3d from_proto(const v1::Vector3& v) {
  return model::Vec3d(v.x(), v.y(), v.z());
}

void to_proto(const Eigen::Matrix<double, 6, 1>& gradient, v1::PoseGradient& out) {
  to_proto(model::Vec3d(gradient.head<3>()), *out.mutable_translation());
  to_proto(model::Vec3d(gradient.tail<3>()), *out.mutable_rotation());
}

Eigen::Matrix<double, 6, 1> from_proto(const v1::PoseGradient& g) {
  Eigen::Matrix<double, 6, 1> out;
  out << g.translation().x(), g.translation().y(), g.translation().z(), g.rotation().x(),
      g.rotation().y(), g.rotation().z();
  return out;
}

void to_proto(const model::PairAnswer& pair, v1::PairDistance& p) {
  p.set_status(v1::PairStatus(model::to_wire(pair.status)));
  p.set_distance(pair.distance);
  p.set_distance_lower_bound(pair.distance_lower_bound);
  p.set_error_bound(pair.error_bound);
  p.set_iterations(pair.iterations);
  p.set_piece_pairs_evaluated(pair.piece_pairs_evaluated);
  p.set_piece_a(pair.piece_a);
  p.set_piece_b(pair.piece_b);
  p.set_warm_started(pair.warm_started);
  if (pair.has_near_points) {
    p.set_has_near_points(true);
    to_proto(pair.point_a, *p.mutable_point_a());
    to_proto(pair.point_b, *p.mutable_point_b());
    to_proto(pair.normal, *p.mutable_normal());
  }
  if (pair.has_penetration_bound) {
    p.set_has_penetration_bound(true);
    p.set_penetration_bound(pair.penetration_bound);
  }
  if (pair.has_gradient) {
    p.set_has_gradient(true);
    to_proto(pair.gradient_a, *p.mutable_gradient_a());
    to_proto(pair.gradient_b, *p.mutable_gradient_b());
  }
  if (pair.has_signed_distance) {
    p.set_has_signed_distance(true);
    p.set_signed_distance(pair.signed_distance);
    p.set_signed_distance_lower(pair.signed_distance_lower);
    p.set_signed_distance_upper(pair.signed_distance_upper);
  }
  if (pair.has_penetration_depth) {
    p.set_has_penetration_depth(true);
    p.set_penetration_depth(pair.depth);
    p.set_penetration_depth_lower(pair.depth_lower);
    p.set_penetration_depth_upper(pair.depth_upper);
    to_proto(pair.depth_point_a, *p.mutable_depth_point_a());
    to_proto(pair.depth_point_b, *p.mutable_depth_point_b());
    to_proto(pair.depth_direction, *p.mutable_depth_direction());
    p.set_depth_termination(v1::DepthTermination(model::to_wire(pair.depth_termination)));
    p.set_depth_iterations(pair.depth_iterations);
  }
}

void from_proto(const v1::PairDistance& p, model::PairAnswer& pair) {
  pair.status = model::from_wire<model::PairStatus>(p.status());
  pair.distance = p.distance();
  pair.distance_lower_bound = p.distance_lower_bound();
  pair.error_bound = p.error_bound();
  pair.iterations = p.iterations();
  pair.piece_pairs_evaluated = p.piece_pairs_evaluated();
  pair.piece_a = p.piece_a();
  pair.piece_b = p.piece_b();
  pair.warm_started = p.warm_started();
  pair.has_near_points = p.has_near_points();
  if (pair.has_near_points) {
    pair.point_a = from_proto(p.point_a());
    pair.point_b = from_proto(p.point_b());
    pair.normal = from_proto(p.normal());
  }
  pair.has_penetration_bound = p.has_penetration_bound();
  if (pair.has_penetration_bound) pair.penetration_bound = p.penetration_bound();
  pair.has_gradient = p.has_gradient();
  if (pair.has_gradient) {
    pair.gradient_a = from_proto(p.gradient_a());
    pair.gradient_b = from_proto(p.gradient_b());
  }
  pair.has_signed_distance = p.has_signed_distance();
  if (pair.has_signed_distance) {
    pair.signed_distance = p.signed_distance();
    pair.signed_distance_lower = p.signed_distance_lower();
    pair.signed_distance_upper = p.signed_distance_upper();
  }
  pair.has_penetration_depth = p.has_penetration_depth();
  if (pair.has_penetration_depth) {
    pair.depth = p.penetration_depth();
    pair.depth_lower = p.penetration_depth_lower();
    pair.depth_upper = p.penetration_depth_upper();
    pair.depth_point_a = from_proto(p.depth_point_a());
    pair.depth_point_b = from_proto(p.depth_point_b());
    pair.depth_direction = from_proto(p.depth_direction());
    pair.depth_termination = model::from_wire<model::DepthTermination>(p.depth_termination());
    pair.depth_iterations = p.depth_iterations();
  }
}

void to_proto(const model::PoseInput& pose, v1::Pose& out) {
  v1::Quaternion& q = *out.mutable_rotation();
  q.set_w(pose.rotation_wxyz[0]);
  q.set_x(pose.rotation_wxyz[1]);
  q.set_y(pose.rotation_wxyz[2]);
  q.set_z(pose.rotation_wxyz[3]);
  to_proto(pose.translation, *out.mutable_translation());
}

model::PoseInput from_proto(const v1::Pose& pose) {
  model::PoseInput out;  // the identity unless given
  if (pose.has_rotation()) {
    const v1::Quaternion& q = pose.rotation();
    out.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  }
  if (pose.has_translation()) out.translation = from_proto(pose.translation());
  return out;
}

void to_proto(const model::ObjectPoseInput& pose, v1::ObjectPose& out) {
  out.set_object_id(pose.object_id);
  to_proto(pose.pose, *out.mutable_pose());
}

std::vector<model::ObjectPoseInput> from_proto(
    const google::protobuf::RepeatedPtrField<v1::ObjectPose>& poses) {
  std::vector<model::ObjectPoseInput> out;
  out.reserve(std::size_t(poses.size()));
  for (const v1::ObjectPose& pose : poses)
    out.push_back({pose.object_id(), from_proto(pose.pose())});
  return out;
}

void to_proto(const model::GeometryInput& geometry, v1::Geometry& out) {
  out.set_name(geometry.name);
  for (const model::PieceInput& piece : geometry.pieces) write_piece(piece, *out.add_pieces());
}

model::GeometryInput from_proto(const v1::Geometry& geometry) {
  model::GeometryInput out;
  out.name = geometry.name();
  out.pieces.reserve(std::size_t(geometry.pieces_size()));
  for (const v1::Piece& piece : geometry.pieces()) out.pieces.push_back(read_piece(piece));
  return out;
}

void to_proto(const model::GeometryInfo& info, v1::GeometryInfo& out) {
  out.set_geometry_id(info.geometry_id);
  out.set_name(info.name);
  out.set_piece_count(std::uint32_t(info.piece_count));
  out.set_vertex_count(info.vertex_count);
  to_proto(info.bounding_center, *out.mutable_bounding_center());
  out.set_bounding_radius(info.bounding_radius);
}

model::GeometryInfo from_proto(const v1::GeometryInfo& info) {
  model::GeometryInfo out;
  out.geometry_id = info.geometry_id();
  out.name = info.name();
  out.piece_count = info.piece_count();
  out.vertex_count = info.vertex_count();
  out.bounding_center = from_proto(info.bounding_center());
  out.bounding_radius = info.bounding_radius();
  return out;
}

void to_proto(const model::QueryOptionsInput& options, v1::QueryOptions& out) {
  if (options.epsilon) out.set_epsilon(*options.epsilon);
  if (options.near_points) out.set_near_points(*options.near_points);
  // unspecified (inherit) and unknown have no wire value: left unset.
  if (const std::int32_t penetration = model::to_wire(options.penetration); penetration != 0)
    out.set_penetration(v1::PenetrationMode(penetration));
  if (options.gradient) out.set_gradient(*options.gradient);
  if (options.distance_cutoff) out.set_distance_cutoff(*options.distance_cutoff);
  if (options.warm_start) out.set_warm_start(*options.warm_start);
  if (const std::int32_t mode = model::to_wire(options.report_mode); mode != 0)
    out.set_report_mode(v1::ReportMode(mode));
  if (options.change_tolerance) out.set_change_tolerance(*options.change_tolerance);
  if (options.max_iterations)
    out.set_max_iterations(
        std::uint32_t(std::min<std::uint64_t>(*options.max_iterations, 0xFFFFFFFFull)));
}

model::QueryOptionsInput from_proto(const v1::QueryOptions& options) {
  model::QueryOptionsInput out;
  if (options.has_epsilon()) out.epsilon = options.epsilon();
  if (options.has_near_points()) out.near_points = options.near_points();
  out.penetration = model::from_wire<PenetrationMode>(options.penetration());
  out.report_mode = model::from_wire<ReportMode>(options.report_mode());
  if (options.has_gradient()) out.gradient = options.gradient();
  if (options.has_distance_cutoff()) out.distance_cutoff = options.distance_cutoff();
  if (options.has_warm_start()) out.warm_start = options.warm_start();
  if (options.has_max_iterations()) out.max_iterations = options.max_iterations();
  if (options.has_change_tolerance()) out.change_tolerance = options.change_tolerance();
  return out;
}

void to_proto(const model::ThresholdInput& threshold, v1::Threshold& out) {
  out.set_name(threshold.name);
  out.set_distance(threshold.distance);
  out.set_hysteresis(threshold.hysteresis);
  out.set_object_a(threshold.object_a);
  out.set_object_b(threshold.object_b);
  out.set_groups(threshold.groups);
}

model::ThresholdInput from_proto(const v1::Threshold& threshold) {
  return model::ThresholdInput{threshold.name(),     threshold.distance(), threshold.hysteresis(),
                               threshold.object_a(), threshold.object_b(), threshold.groups()};
}

void to_proto(const model::RobotInput& robot, v1::Robot& out) {
  out.set_name(robot.name);
  for (const model::RobotLinkInput& link : robot.links) {
    v1::RobotLink& l = *out.add_links();
    l.set_name(link.name);
    l.set_parent(link.parent);
    to_proto(link.offset, *l.mutable_offset());
    for (const model::RobotJointInput& joint : link.joints) {
      v1::RobotJoint& j = *l.add_joints();
      j.set_name(joint.name);
      j.set_type(v1::JointType(static_cast<int>(joint.type)));
      to_proto(joint.axis, *j.mutable_axis());
      to_proto(joint.anchor, *j.mutable_anchor());
      j.set_reference(joint.reference);
      j.set_limited(joint.limited);
      j.set_lower(joint.lower);
      j.set_upper(joint.upper);
    }
  }
  for (const model::RobotAttachmentInput& attachment : robot.attachments) {
    v1::RobotAttachment& a = *out.add_attachments();
    a.set_object_id(attachment.object_id);
    a.set_link(attachment.link);
    to_proto(attachment.offset, *a.mutable_offset());
  }
}

model::RobotInput from_proto(const v1::Robot& robot) {
  model::RobotInput out;
  out.name = robot.name();
  for (const v1::RobotLink& l : robot.links()) {
    model::RobotLinkInput& link = out.links.emplace_back();
    link.name = l.name();
    link.parent = l.parent();
    link.offset = from_proto(l.offset());
    for (const v1::RobotJoint& j : l.joints()) {
      model::RobotJointInput& joint = link.joints.emplace_back();
      joint.name = j.name();
      // Same numbers as nearpoint.v1.JointType; a newer value reads as unknown (refused).
      const int type = j.type();
      joint.type = type >= 0 && type <= static_cast<int>(model::JointType::free)
                       ? model::JointType(type)
                       : model::JointType::unknown;
      if (j.has_axis()) joint.axis = from_proto(j.axis());
      if (j.has_anchor()) joint.anchor = from_proto(j.anchor());
      joint.reference = j.reference();
      joint.limited = j.limited();
      joint.lower = j.lower();
      joint.upper = j.upper();
    }
  }
  for (const v1::RobotAttachment& a : robot.attachments())
    out.attachments.push_back({a.object_id(), a.link(), from_proto(a.offset())});
  return out;
}

void to_proto(const model::JointPositionsInput& joints, v1::JointPositions& out) {
  for (const std::string& name : joints.names) out.add_names(name);
  for (const double position : joints.positions) out.add_positions(position);
  if (joints.base_pose) to_proto(*joints.base_pose, *out.mutable_base_pose());
}

model::JointPositionsInput from_proto(const v1::JointPositions& joints) {
  model::JointPositionsInput out;
  out.names.assign(joints.names().begin(), joints.names().end());
  out.positions.assign(joints.positions().begin(), joints.positions().end());
  if (joints.has_base_pose()) out.base_pose = from_proto(joints.base_pose());
  return out;
}

void to_proto(const model::SceneInput& scene, v1::CreateSceneRequest& out) {
  out.set_name(scene.name);
  out.set_scene_id(scene.requested_id);
  for (const model::ObjectInput& object : scene.objects) write_object(object, *out.add_objects());
  write_selection(scene.pair_selection, *out.mutable_pair_selection());
  to_proto(scene.default_options, *out.mutable_default_options());
  for (const model::ThresholdInput& threshold : scene.thresholds)
    to_proto(threshold, *out.add_thresholds());
  if (!scene.robot.empty()) to_proto(scene.robot, *out.mutable_robot());
}

model::SceneInput from_proto(const v1::CreateSceneRequest& request) {
  model::SceneInput out;
  out.name = request.name();
  out.requested_id = request.scene_id();
  out.objects.reserve(std::size_t(request.objects_size()));
  for (const v1::SceneObject& object : request.objects())
    out.objects.push_back(read_object(object));
  out.pair_selection = read_selection(request.pair_selection());
  out.default_options = from_proto(request.default_options());
  out.thresholds = read_thresholds(request.thresholds());
  for (const auto& [key, geometry] : request.geometries())
    out.geometries.emplace(key, from_proto(geometry));
  if (request.has_robot()) out.robot = from_proto(request.robot());
  return out;
}

model::PoseUpdateInput from_proto(const v1::PoseUpdate& update) {
  model::PoseUpdateInput out;
  out.scene_id = update.scene_id();
  out.sequence = update.sequence();
  out.poses = from_proto(update.poses());
  out.options = from_proto(update.options());
  out.flow_control = model::from_wire<FlowControl>(update.flow_control());
  out.thresholds = read_thresholds(update.thresholds());
  if (update.has_joints()) out.joints = from_proto(update.joints());
  return out;
}

model::QueryInput from_proto(const v1::QueryRequest& request) {
  model::QueryInput out;
  out.scene_id = request.scene_id();
  out.poses = from_proto(request.poses());
  out.options = from_proto(request.options());
  out.sequence = request.sequence();
  if (request.has_joints()) out.joints = from_proto(request.joints());
  return out;
}

void to_proto(const model::ReportTiming& timing, v1::ReportTiming& out) {
  out.set_server_us(timing.server_us);
  out.set_queue_us(timing.queue_us);
  out.set_evaluation_us(timing.evaluation_us);
  out.set_geometry_us(timing.geometry_us);
}

model::ReportTiming from_proto(const v1::ReportTiming& timing) {
  return {timing.server_us(), timing.queue_us(), timing.evaluation_us(), timing.geometry_us()};
}

void to_proto(const model::ReportCounts& counts, v1::ReportCounts& out) {
  out.set_pairs_evaluated(counts.pairs_evaluated);
  out.set_pairs_pruned(counts.pairs_pruned);
  out.set_pairs_unmoved(counts.pairs_unmoved);
}

model::ReportCounts from_proto(const v1::ReportCounts& counts) {
  return {counts.pairs_evaluated(), counts.pairs_pruned(), counts.pairs_unmoved()};
}

}  // namespace nearpoint::proto
