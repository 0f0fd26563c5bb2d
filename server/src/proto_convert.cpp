// SPDX-License-Identifier: Apache-2.0
#include "proto_convert.hpp"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include "content_hash.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "wire_numbers.hpp"

namespace nearpoint::server {
namespace {

// wire_numbers.hpp writes the status codes as numbers and model/vocabulary.hpp the API enums'
// for the DDS bridge as well; these checks keep them in step with grpc::StatusCode and the
// generated enums.
constexpr bool same(std::int64_t wire_value, std::int64_t generated) {
  return wire_value == generated;
}
static_assert(same(wire::status_code(ErrorCode::invalid_argument),
                   grpc::StatusCode::INVALID_ARGUMENT));
static_assert(same(wire::status_code(ErrorCode::not_found), grpc::StatusCode::NOT_FOUND));
static_assert(same(wire::status_code(ErrorCode::already_exists), grpc::StatusCode::ALREADY_EXISTS));
static_assert(same(wire::status_code(ErrorCode::resource_exhausted),
                   grpc::StatusCode::RESOURCE_EXHAUSTED));
static_assert(same(wire::status_code(ErrorCode::failed_precondition),
                   grpc::StatusCode::FAILED_PRECONDITION));
static_assert(same(wire::status_code(ErrorCode::internal), grpc::StatusCode::INTERNAL));
static_assert(same(wire::status_code(ErrorCode::unavailable), grpc::StatusCode::UNAVAILABLE));
static_assert(same(model::to_wire(model::PairStatus::separated), v1::PAIR_STATUS_SEPARATED));
static_assert(same(model::to_wire(model::PairStatus::intersecting), v1::PAIR_STATUS_INTERSECTING));
static_assert(same(model::to_wire(model::PairStatus::beyond_cutoff),
                   v1::PAIR_STATUS_BEYOND_CUTOFF));
static_assert(same(model::to_wire(model::PairStatus::iteration_limit),
                   v1::PAIR_STATUS_ITERATION_LIMIT));
static_assert(same(model::to_wire(model::PairStatus::engine_error), v1::PAIR_STATUS_ENGINE_ERROR));
static_assert(same(model::to_wire(model::PenetrationMode::unspecified),
                   v1::PENETRATION_MODE_UNSPECIFIED));
static_assert(same(model::to_wire(model::PenetrationMode::none), v1::PENETRATION_MODE_NONE));
static_assert(same(model::to_wire(model::PenetrationMode::bound), v1::PENETRATION_MODE_BOUND));
static_assert(same(model::to_wire(model::PenetrationMode::depth), v1::PENETRATION_MODE_DEPTH));
static_assert(same(model::to_wire(model::ReportMode::unspecified), v1::REPORT_MODE_UNSPECIFIED));
static_assert(same(model::to_wire(model::ReportMode::all_pairs), v1::REPORT_MODE_ALL_PAIRS));
static_assert(same(model::to_wire(model::ReportMode::within_cutoff),
                   v1::REPORT_MODE_WITHIN_CUTOFF));
static_assert(same(model::to_wire(model::ReportMode::nearest_per_object),
                   v1::REPORT_MODE_NEAREST_PER_OBJECT));
static_assert(same(model::to_wire(model::ReportMode::global_minimum),
                   v1::REPORT_MODE_GLOBAL_MINIMUM));
static_assert(same(model::to_wire(model::ReportMode::changed), v1::REPORT_MODE_CHANGED));
static_assert(model::from_wire<model::FlowControl>(v1::FLOW_CONTROL_UNSPECIFIED) ==
              model::FlowControl::block);
static_assert(same(model::to_wire(model::FlowControl::block), v1::FLOW_CONTROL_BLOCK));
static_assert(same(model::to_wire(model::FlowControl::coalesce), v1::FLOW_CONTROL_COALESCE));
static_assert(same(model::to_wire(model::Crossing::enter), v1::THRESHOLD_CROSSING_ENTER));
static_assert(same(model::to_wire(model::Crossing::exit), v1::THRESHOLD_CROSSING_EXIT));

model::Vec3d to_vec(const v1::Vector3& v) {
  return model::Vec3d(v.x(), v.y(), v.z());
}

void set_vec(const model::Vec3d& v, v1::Vector3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

void set_gradient(const Eigen::Matrix<double, 6, 1>& gradient, v1::PoseGradient& out) {
  set_vec(gradient.head<3>(), *out.mutable_translation());
  set_vec(gradient.tail<3>(), *out.mutable_rotation());
}

std::vector<model::ObjectPoseInput> to_pose_inputs(
    const google::protobuf::RepeatedPtrField<v1::ObjectPose>& poses) {
  std::vector<model::ObjectPoseInput> out;
  out.reserve(std::size_t(poses.size()));
  for (const v1::ObjectPose& pose : poses) out.push_back({pose.object_id(), to_input(pose.pose())});
  return out;
}

}  // namespace

grpc::Status to_grpc_status(const Error& error) {
  return grpc::Status(grpc::StatusCode(wire::status_code(error.code)), error.describe());
}

model::PoseInput to_input(const v1::Pose& pose) {
  model::PoseInput out;  // the identity unless given
  if (pose.has_rotation()) {
    const v1::Quaternion& q = pose.rotation();
    out.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  }
  if (pose.has_translation()) out.translation = to_vec(pose.translation());
  return out;
}

model::GeometryInput to_input(const v1::Geometry& geometry) {
  model::GeometryInput out;
  out.name = geometry.name();
  out.pieces.reserve(std::size_t(geometry.pieces_size()));
  for (const v1::Piece& piece : geometry.pieces()) {
    model::PieceInput& in = out.pieces.emplace_back();
    in.radius = piece.radius();
    in.offset = to_input(piece.offset());
    switch (piece.shape_case()) {
      case v1::Piece::kPolytope: {
        model::PolytopeInput polytope;
        polytope.vertices.reserve(std::size_t(piece.polytope().vertices_size()));
        for (const v1::Vector3& v : piece.polytope().vertices())
          polytope.vertices.push_back(to_vec(v));
        in.shape = std::move(polytope);
        break;
      }
      case v1::Piece::kPoint:
        in.shape = Point{};
        break;
      case v1::Piece::kSegment:
        in.shape = Segment<double>{to_vec(piece.segment().a()), to_vec(piece.segment().b())};
        break;
      case v1::Piece::kBox:
        in.shape = Box<double>{to_vec(piece.box().half_extents())};
        break;
      case v1::Piece::kCylinder:
        in.shape = Cylinder<double>{piece.cylinder().radius(), piece.cylinder().half_height()};
        break;
      case v1::Piece::kCone:
        in.shape = Cone<double>{piece.cone().radius(), piece.cone().half_height()};
        break;
      case v1::Piece::kEllipsoid:
        in.shape = Ellipsoid<double>{to_vec(piece.ellipsoid().radii())};
        break;
      case v1::Piece::SHAPE_NOT_SET:
        break;  // monostate: validation names the missing shape
    }
  }
  return out;
}

model::QueryOptionsInput to_input(const v1::QueryOptions& options) {
  model::QueryOptionsInput out;
  if (options.has_epsilon()) out.epsilon = options.epsilon();
  if (options.has_near_points()) out.near_points = options.near_points();
  out.penetration = model::from_wire<model::PenetrationMode>(options.penetration());
  out.report_mode = model::from_wire<model::ReportMode>(options.report_mode());
  if (options.has_gradient()) out.gradient = options.gradient();
  if (options.has_distance_cutoff()) out.distance_cutoff = options.distance_cutoff();
  if (options.has_warm_start()) out.warm_start = options.warm_start();
  if (options.has_max_iterations()) out.max_iterations = options.max_iterations();
  if (options.has_change_tolerance()) out.change_tolerance = options.change_tolerance();
  return out;
}

model::SceneInput to_input(const v1::CreateSceneRequest& request) {
  model::SceneInput out;
  out.name = request.name();
  out.requested_id = request.scene_id();
  out.objects.reserve(std::size_t(request.objects_size()));
  for (const v1::SceneObject& object : request.objects()) {
    model::ObjectInput& in = out.objects.emplace_back();
    in.id = object.id();
    in.geometry_id = object.geometry_id();
    in.pose = to_input(object.pose());
    if (object.has_group()) in.group = object.group();
    if (object.has_mask()) in.mask = object.mask();
    in.padding = object.padding();
    in.self_padding = object.self_padding();
    in.body = object.body();
  }
  const v1::PairSelection& selection = request.pair_selection();
  const v1::PairList* list = nullptr;
  switch (selection.selection_case()) {
    case v1::PairSelection::kListedPairs:
      out.pair_selection.mode = model::PairSelectionInput::Mode::listed_pairs;
      list = &selection.listed_pairs();
      break;
    case v1::PairSelection::kExcludedPairs:
      out.pair_selection.mode = model::PairSelectionInput::Mode::excluded_pairs;
      list = &selection.excluded_pairs();
      break;
    case v1::PairSelection::kAllPairs:
    case v1::PairSelection::SELECTION_NOT_SET:
      out.pair_selection.mode = model::PairSelectionInput::Mode::all_pairs;
      break;
  }
  if (list)
    for (const v1::ObjectPair& pair : list->pairs())
      out.pair_selection.pairs.emplace_back(pair.object_a(), pair.object_b());
  out.default_options = to_input(request.default_options());
  out.thresholds.reserve(std::size_t(request.thresholds_size()));
  for (const v1::Threshold& threshold : request.thresholds())
    out.thresholds.push_back(model::ThresholdInput{threshold.name(), threshold.distance(),
                                                   threshold.hysteresis(), threshold.object_a(),
                                                   threshold.object_b(), threshold.groups()});
  for (const auto& [key, geometry] : request.geometries())
    out.geometries.emplace(key, to_input(geometry));
  // The whole request, bit for bit, in a canonical order (maps sorted): the same request again
  // has the same fingerprint, and any difference, in fields this server knows or not, another.
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    request.SerializeToCodedStream(&coded);
  }
  Sha256 hash;
  hash.update(bytes);
  out.fingerprint = hex_prefix(hash.finish(), 32);
  return out;
}

model::PoseUpdateInput to_input(const v1::PoseUpdate& update) {
  model::PoseUpdateInput out;
  out.scene_id = update.scene_id();
  out.sequence = update.sequence();
  out.poses = to_pose_inputs(update.poses());
  out.options = to_input(update.options());
  out.flow_control = model::from_wire<model::FlowControl>(update.flow_control());
  out.thresholds.reserve(std::size_t(update.thresholds_size()));
  for (const v1::Threshold& threshold : update.thresholds())
    out.thresholds.push_back(model::ThresholdInput{threshold.name(), threshold.distance(),
                                                   threshold.hysteresis(), threshold.object_a(),
                                                   threshold.object_b(), threshold.groups()});
  return out;
}

model::QueryInput to_input(const v1::QueryRequest& request) {
  model::QueryInput out;
  out.scene_id = request.scene_id();
  out.poses = to_pose_inputs(request.poses());
  out.options = to_input(request.options());
  out.sequence = request.sequence();
  return out;
}

void to_proto(const model::GeometryInfo& info, v1::GeometryInfo& out) {
  out.set_geometry_id(info.geometry_id);
  out.set_name(info.name);
  out.set_piece_count(std::uint32_t(info.piece_count));
  out.set_vertex_count(info.vertex_count);
  set_vec(info.bounding_center, *out.mutable_bounding_center());
  out.set_bounding_radius(info.bounding_radius);
}

void to_proto(const Report& report, v1::DistanceReport& out) {
  out.Clear();
  out.set_sequence(report.sequence);
  out.mutable_pairs()->Reserve(int(report.pairs.size()));
  for (const model::PairReport& pair : report.pairs) {
    v1::PairDistance& p = *out.add_pairs();
    p.set_object_a(report.scene->objects[pair.object_a].id);
    p.set_object_b(report.scene->objects[pair.object_b].id);
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
      set_vec(pair.point_a, *p.mutable_point_a());
      set_vec(pair.point_b, *p.mutable_point_b());
      set_vec(pair.normal, *p.mutable_normal());
    }
    if (pair.has_penetration_bound) {
      p.set_has_penetration_bound(true);
      p.set_penetration_bound(pair.penetration_bound);
    }
    if (pair.has_gradient) {
      p.set_has_gradient(true);
      set_gradient(pair.gradient_a, *p.mutable_gradient_a());
      set_gradient(pair.gradient_b, *p.mutable_gradient_b());
    }
    if (pair.engine_message) p.set_message(pair.engine_message);
  }
  v1::ReportTiming& timing = *out.mutable_timing();
  timing.set_server_us(report.timing.server_us);
  timing.set_queue_us(report.timing.queue_us);
  timing.set_evaluation_us(report.timing.evaluation_us);
  timing.set_geometry_us(report.timing.geometry_us);
  out.set_coalesced_updates(report.coalesced_updates);
  out.set_coalesced_from_sequence(report.coalesced_from_sequence);
  v1::ReportCounts& counts = *out.mutable_counts();
  counts.set_pairs_evaluated(report.counts.pairs_evaluated);
  counts.set_pairs_pruned(report.counts.pairs_pruned);
  counts.set_pairs_unmoved(report.counts.pairs_unmoved);
  // A report's mode is never unspecified: that would read as all pairs, which it is then.
  out.set_report_mode(report.mode == model::ReportMode::unspecified ||
                              report.mode == model::ReportMode::unknown
                          ? v1::REPORT_MODE_ALL_PAIRS
                          : v1::ReportMode(model::to_wire(report.mode)));
  out.mutable_events()->Reserve(int(report.events.size()));
  for (const model::ThresholdEvent& event : report.events) {
    v1::ThresholdEvent& e = *out.add_events();
    if (report.threshold_names) e.set_threshold((*report.threshold_names)[event.threshold]);
    e.set_threshold_index(event.threshold);
    e.set_object_a(report.scene->objects[event.object_a].id);
    e.set_object_b(report.scene->objects[event.object_b].id);
    e.set_crossing(v1::ThresholdCrossing(model::to_wire(event.crossing)));
    e.set_distance(event.distance);
    e.set_sequence(event.sequence);
  }
}

void to_proto(const Error& error, std::uint64_t sequence, v1::DistanceReport& out) {
  out.Clear();
  out.set_sequence(sequence);
  v1::UpdateError& e = *out.mutable_error();
  // The same code a unary call would fail with: derived from the one mapping above.
  e.set_code(static_cast<v1::ErrorCode>(to_grpc_status(error).error_code()));
  e.set_field(error.field);
  e.set_message(error.message);
}

}  // namespace nearpoint::server
