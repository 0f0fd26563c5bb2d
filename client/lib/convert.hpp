// SPDX-License-Identifier: Apache-2.0
// The client's plain structs ↔ nearpoint.v1 protobuf messages (mechanical; the server validates).
#pragma once

#include "nearpoint/client/client.hpp"
#include "nearpoint_distance.pb.h"

namespace nearpoint::client::detail {

namespace v1 = ::nearpoint::v1;

void to_proto(const model::PoseInput& pose, v1::Pose& out);
void to_proto(const ObjectPose& pose, v1::ObjectPose& out);
void to_proto(const Geometry& geometry, v1::Geometry& out);
void to_proto(const QueryOptions& options, v1::QueryOptions& out);
void to_proto(const Threshold& threshold, v1::Threshold& out);
void to_proto(const Scene& scene, v1::CreateSceneRequest& out);
GeometryInfo from_proto(const v1::GeometryInfo& info);
Report from_proto(const v1::DistanceReport& report);

}  // namespace nearpoint::client::detail
