// SPDX-License-Identifier: Apache-2.0
#include "convert.hpp"

#include <type_traits>

#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::client::detail {
namespace {

void to_proto(const Eigen::Vector3d& v, v1::Vector3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

Eigen::Vector3d from_proto(const v1::Vector3& v) {
  return {v.x(), v.y(), v.z()};
}

Eigen::Matrix<double, 6, 1> from_proto(const v1::PoseGradient& g) {
  Eigen::Matrix<double, 6, 1> out;
  out << g.translation().x(), g.translation().y(), g.translation().z(), g.rotation().x(),
      g.rotation().y(), g.rotation().z();
  return out;
}

}  // namespace

void to_proto(const model::PoseInput& pose, v1::Pose& out) {
  v1::Quaternion& q = *out.mutable_rotation();
  q.set_w(pose.rotation_wxyz[0]);
  q.set_x(pose.rotation_wxyz[1]);
  q.set_y(pose.rotation_wxyz[2]);
  q.set_z(pose.rotation_wxyz[3]);
  to_proto(pose.translation, *out.mutable_translation());
}

void to_proto(const ObjectPose& pose, v1::ObjectPose& out) {
  out.set_object_id(pose.object_id);
  to_proto(to_pose_input(pose.rotation, pose.translation), *out.mutable_pose());
}

void to_proto(const Geometry& geometry, v1::Geometry& out) {
  out.set_name(geometry.name);
  for (const Piece& piece : geometry.pieces) {
    v1::Piece& p = *out.add_pieces();
    std::visit(
        [&](const auto& shape) {
          using S = std::decay_t<decltype(shape)>;
          if constexpr (std::is_same_v<S, model::PolytopeInput>) {
            for (const Eigen::Vector3d& v : shape.vertices)
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
          // std::monostate: no shape; the server rejects the piece, naming it.
        },
        piece.shape);
    p.set_radius(piece.radius);
    to_proto(piece.offset, *p.mutable_offset());
  }
}

void to_proto(const QueryOptions& options, v1::QueryOptions& out) {
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

void to_proto(const Threshold& threshold, v1::Threshold& out) {
  out.set_name(threshold.name);
  out.set_distance(threshold.distance);
  out.set_hysteresis(threshold.hysteresis);
  out.set_object_a(threshold.object_a);
  out.set_object_b(threshold.object_b);
  out.set_groups(threshold.groups);
}

void to_proto(const Scene& scene, v1::CreateSceneRequest& out) {
  out.set_name(scene.name);
  out.set_scene_id(scene.requested_id);
  for (const SceneObject& object : scene.objects) {
    v1::SceneObject& o = *out.add_objects();
    o.set_id(object.id);
    o.set_geometry_id(object.geometry_id);
    to_proto(object.pose, *o.mutable_pose());
    if (object.group) o.set_group(*object.group);
    if (object.mask) o.set_mask(*object.mask);
    o.set_padding(object.padding);
    o.set_self_padding(object.self_padding);
    o.set_body(object.body);
  }
  v1::PairSelection& selection = *out.mutable_pair_selection();
  v1::PairList* list = nullptr;
  switch (scene.pair_selection.mode) {
    case PairSelection::Mode::all_pairs:
      selection.mutable_all_pairs();
      break;
    case PairSelection::Mode::listed_pairs:
      list = selection.mutable_listed_pairs();
      break;
    case PairSelection::Mode::excluded_pairs:
      list = selection.mutable_excluded_pairs();
      break;
  }
  if (list != nullptr)
    for (const auto& [a, b] : scene.pair_selection.pairs) {
      v1::ObjectPair& pair = *list->add_pairs();
      pair.set_object_a(a);
      pair.set_object_b(b);
    }
  to_proto(scene.default_options, *out.mutable_default_options());
  for (const Threshold& threshold : scene.thresholds) to_proto(threshold, *out.add_thresholds());
}

GeometryInfo from_proto(const v1::GeometryInfo& info) {
  GeometryInfo out;
  out.geometry_id = info.geometry_id();
  out.name = info.name();
  out.piece_count = info.piece_count();
  out.vertex_count = info.vertex_count();
  out.bounding_center = from_proto(info.bounding_center());
  out.bounding_radius = info.bounding_radius();
  return out;
}

Report from_proto(const v1::DistanceReport& report) {
  Report out;
  out.sequence = report.sequence();
  if (report.has_error()) {
    out.error = Status::error(int(report.error().code()),
                              report.error().field().empty()
                                  ? report.error().message()
                                  : report.error().field() + ": " + report.error().message());
    if (out.error.code == 0) out.error.code = 2;  // UNKNOWN: an error report without a code
    out.error_field = report.error().field();
  }
  out.pairs.reserve(std::size_t(report.pairs_size()));
  for (const v1::PairDistance& p : report.pairs()) {
    PairDistance& pair = out.pairs.emplace_back();
    pair.object_a = p.object_a();
    pair.object_b = p.object_b();
    pair.status = model::from_wire<PairStatus>(p.status());
    pair.distance = p.distance();
    pair.distance_lower_bound = p.distance_lower_bound();
    pair.error_bound = p.error_bound();
    pair.iterations = p.iterations();
    pair.piece_pairs_evaluated = p.piece_pairs_evaluated();
    pair.piece_a = p.piece_a();
    pair.piece_b = p.piece_b();
    pair.warm_started = p.warm_started();
    if (p.has_near_points())
      pair.near_points = PairDistance::NearPoints{from_proto(p.point_a()), from_proto(p.point_b()),
                                                  from_proto(p.normal())};
    if (p.has_penetration_bound()) pair.penetration_bound = p.penetration_bound();
    if (p.has_gradient())
      pair.gradient = std::pair(from_proto(p.gradient_a()), from_proto(p.gradient_b()));
    pair.message = p.message();
  }
  out.timing = {report.timing().server_us(), report.timing().queue_us(),
                report.timing().evaluation_us(), report.timing().geometry_us()};
  out.coalesced_updates = report.coalesced_updates();
  out.coalesced_from_sequence = report.coalesced_from_sequence();
  out.counts = {report.counts().pairs_evaluated(), report.counts().pairs_pruned(),
                report.counts().pairs_unmoved()};
  // An older server sends 0: its reports hold every pair.
  out.mode = model::from_wire<ReportMode>(report.report_mode());
  if (out.mode == ReportMode::unspecified || out.mode == ReportMode::unknown)
    out.mode = ReportMode::all_pairs;
  out.events.reserve(std::size_t(report.events_size()));
  for (const v1::ThresholdEvent& e : report.events())
    out.events.push_back(ThresholdEvent{e.threshold(), e.threshold_index(), e.object_a(),
                                        e.object_b(), model::from_wire<Crossing>(e.crossing()),
                                        e.distance(), e.sequence()});
  return out;
}

}  // namespace nearpoint::client::detail
