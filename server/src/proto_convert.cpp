// SPDX-License-Identifier: Apache-2.0
#include "proto_convert.hpp"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include "content_hash.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "robot_scene.hpp"

namespace nearpoint::server {
namespace {

// errors.hpp writes the status codes as ErrorCode's values, for the DDS bridge as well; these
// checks keep them in step with grpc::StatusCode. (The API enums' numbers are checked in
// proto/convert.)
constexpr bool same(std::int64_t wire_value, std::int64_t generated) {
  return wire_value == generated;
}
static_assert(same(status_code(ErrorCode::invalid_argument), grpc::StatusCode::INVALID_ARGUMENT));
static_assert(same(status_code(ErrorCode::not_found), grpc::StatusCode::NOT_FOUND));
static_assert(same(status_code(ErrorCode::already_exists), grpc::StatusCode::ALREADY_EXISTS));
static_assert(same(status_code(ErrorCode::resource_exhausted),
                   grpc::StatusCode::RESOURCE_EXHAUSTED));
static_assert(same(status_code(ErrorCode::failed_precondition),
                   grpc::StatusCode::FAILED_PRECONDITION));
static_assert(same(status_code(ErrorCode::internal), grpc::StatusCode::INTERNAL));
static_assert(same(status_code(ErrorCode::unavailable), grpc::StatusCode::UNAVAILABLE));

}  // namespace

grpc::Status to_grpc_status(const Error& error) {
  return grpc::Status(grpc::StatusCode(status_code(error.code)), error.describe());
}

model::PoseInput to_input(const v1::Pose& pose) {
  return proto::from_proto(pose);
}

model::GeometryInput to_input(const v1::Geometry& geometry) {
  return proto::from_proto(geometry);
}

model::QueryOptionsInput to_input(const v1::QueryOptions& options) {
  return proto::from_proto(options);
}

model::SceneInput to_input(const v1::CreateSceneRequest& request) {
  model::SceneInput out = proto::from_proto(request);
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
  return proto::from_proto(update);
}

model::QueryInput to_input(const v1::QueryRequest& request) {
  return proto::from_proto(request);
}

v1::ReportMode report_mode_on_wire(model::ReportMode mode) {
  return mode == model::ReportMode::unspecified || mode == model::ReportMode::unknown
             ? v1::REPORT_MODE_ALL_PAIRS
             : v1::ReportMode(model::to_wire(mode));
}

void to_proto(const Report& report, v1::DistanceReport& out) {
  out.Clear();
  out.set_sequence(report.sequence);
  out.mutable_pairs()->Reserve(int(report.pairs.size()));
  const SceneRobot* robot = report.scene->robot.get();
  for (std::size_t i = 0; i < report.pairs.size(); ++i) {
    const model::PairReport& pair = report.pairs[i];
    v1::PairDistance& p = *out.add_pairs();
    p.set_object_a(report.scene->objects[pair.object_a].id);
    p.set_object_b(report.scene->objects[pair.object_b].id);
    proto::to_proto(pair, p);
    if (pair.engine_message) p.set_message(pair.engine_message);
    if (robot && i < report.joint_gradients.size())
      for (const auto& [coordinate, value] : report.joint_gradients[i]) {
        v1::JointDerivative& d = *p.add_joint_gradient();
        const auto& [joint, within] = robot->coordinates[coordinate];
        d.set_joint(robot->tree.joints[joint].name);
        d.set_coordinate(within);
        d.set_value(value);
      }
  }
  for (const model::JointLimitViolation& violation : report.joint_limit_violations) {
    v1::JointLimitViolation& v = *out.add_joint_limit_violations();
    v.set_joint(violation.joint);
    v.set_position(violation.position);
    v.set_lower(violation.lower);
    v.set_upper(violation.upper);
  }
  proto::to_proto(report.timing, *out.mutable_timing());
  out.set_coalesced_updates(report.coalesced_updates);
  out.set_coalesced_from_sequence(report.coalesced_from_sequence);
  proto::to_proto(report.counts, *out.mutable_counts());
  out.set_report_mode(report_mode_on_wire(report.mode));
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
