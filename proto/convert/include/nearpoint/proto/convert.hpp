// SPDX-License-Identifier: Apache-2.0
// nearpoint_proto_convert — the one conversion between the scene model's plain structs
// (nearpoint/model) and the nearpoint.v1 protobuf messages, used by the C++ client (model → v1 for
// requests, v1 → model for answers) and by the server's gRPC adapter (the other way round).
// Mechanical: no validation here (the scene API validates, so that every transport rejects the
// same inputs with the same messages); enums go through model/vocabulary.hpp's tables.
#pragma once

#include <vector>

#include <google/protobuf/repeated_ptr_field.h>

#include "nearpoint/model/scene_types.hpp"
#include "nearpoint_distance.pb.h"
#include "nearpoint_geometry.pb.h"
#include "nearpoint_scene.pb.h"

namespace nearpoint::proto {

namespace v1 = ::nearpoint::v1;

void to_proto(const model::Vec3d& v, v1::Vector3& out);
model::Vec3d from_proto(const v1::Vector3& v);

/// (∂/∂translation, ∂/∂rotation vector) ↔ nearpoint.v1.PoseGradient.
void to_proto(const Eigen::Matrix<double, 6, 1>& gradient, v1::PoseGradient& out);
Eigen::Matrix<double, 6, 1> from_proto(const v1::PoseGradient& gradient);

/// One pair's answer ↔ nearpoint.v1.PairDistance, all but the objects' names and the message
/// (the server names objects by index, the client by id).
void to_proto(const model::PairAnswer& answer, v1::PairDistance& out);
void from_proto(const v1::PairDistance& pair, model::PairAnswer& out);

/// Writes both the rotation and the translation; reads the identity for a part not given.
void to_proto(const model::PoseInput& pose, v1::Pose& out);
model::PoseInput from_proto(const v1::Pose& pose);

void to_proto(const model::ObjectPoseInput& pose, v1::ObjectPose& out);
std::vector<model::ObjectPoseInput> from_proto(
    const google::protobuf::RepeatedPtrField<v1::ObjectPose>& poses);

/// A piece without a shape (std::monostate) is written without one and read back as one; the
/// server rejects it, naming the piece.
void to_proto(const model::GeometryInput& geometry, v1::Geometry& out);
model::GeometryInput from_proto(const v1::Geometry& geometry);

void to_proto(const model::GeometryInfo& info, v1::GeometryInfo& out);
model::GeometryInfo from_proto(const v1::GeometryInfo& info);

/// Unset optionals and unspecified enums are left unset (inherit); max_iterations is written
/// capped at the wire's 2^32 − 1.
void to_proto(const model::QueryOptionsInput& options, v1::QueryOptions& out);
model::QueryOptionsInput from_proto(const v1::QueryOptions& options);

void to_proto(const model::ThresholdInput& threshold, v1::Threshold& out);
model::ThresholdInput from_proto(const v1::Threshold& threshold);

/// A scene's robot ↔ nearpoint.v1.Robot (joint types by number; an unknown one reads as unknown).
void to_proto(const model::RobotInput& robot, v1::Robot& out);
model::RobotInput from_proto(const v1::Robot& robot);
/// Joint positions ↔ nearpoint.v1.JointPositions (an absent base pose stays unset).
void to_proto(const model::JointPositionsInput& joints, v1::JointPositions& out);
model::JointPositionsInput from_proto(const v1::JointPositions& joints);
/// Every field but the inline geometries and the fingerprint: which geometries travel inline is
/// the sender's choice (the client sends its own, by the ids the objects name), and the
/// fingerprint is the receiver's digest of the request as received.
void to_proto(const model::SceneInput& scene, v1::CreateSceneRequest& out);
/// Every field, inline geometries included, but the fingerprint.
model::SceneInput from_proto(const v1::CreateSceneRequest& request);

/// One object of a scene as listed (ListScenes): as in a CreateSceneRequest.
model::ObjectInput from_proto(const v1::SceneObject& object);

model::PoseUpdateInput from_proto(const v1::PoseUpdate& update);
model::QueryInput from_proto(const v1::QueryRequest& request);

void to_proto(const model::ReportTiming& timing, v1::ReportTiming& out);
model::ReportTiming from_proto(const v1::ReportTiming& timing);
void to_proto(const model::ReportCounts& counts, v1::ReportCounts& out);
model::ReportCounts from_proto(const v1::ReportCounts& counts);

}  // namespace nearpoint::proto
