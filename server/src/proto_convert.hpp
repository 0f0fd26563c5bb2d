// SPDX-License-Identifier: Apache-2.0
// The gRPC adapter's conversions: the requests it reads (the model ↔ protobuf conversion itself is
// nearpoint_proto_convert's, shared with the client; a scene request also gets its fingerprint
// here), the reports it writes (a server Report names objects through its scene), and the one
// mapping from scene API errors to gRPC status codes. Mechanical: no validation here (the scene
// API validates, so every transport rejects the same inputs with the same messages).
#pragma once

#include <grpcpp/support/status.h>

#include "nearpoint/proto/convert.hpp"
#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/report.hpp"
#include "nearpoint_diagnostics.pb.h"
#include "nearpoint_distance.pb.h"
#include "nearpoint_geometry.pb.h"
#include "nearpoint_scene.pb.h"

namespace nearpoint::server {

/// THE mapping of scene API errors to gRPC: INVALID_ARGUMENT and NOT_FOUND name the field in the
/// message ("field: what is wrong"), limits are RESOURCE_EXHAUSTED.
grpc::Status to_grpc_status(const Error& error);

model::PoseInput to_input(const v1::Pose& pose);
model::GeometryInput to_input(const v1::Geometry& geometry);
model::QueryOptionsInput to_input(const v1::QueryOptions& options);
model::SceneInput to_input(const v1::CreateSceneRequest& request);
model::PoseUpdateInput to_input(const v1::PoseUpdate& update);
model::QueryInput to_input(const v1::QueryRequest& request);

using proto::to_proto;  // GeometryInfo and the rest of the model
/// DistanceReport.report_mode of a report chosen in `mode`: never unspecified, which would read
/// as all pairs, which it then is (to_proto below and report_wire.cpp both write it).
v1::ReportMode report_mode_on_wire(model::ReportMode mode);
void to_proto(const Report& report, v1::DistanceReport& out);
/// The report of a rejected update: its sequence number and why.
void to_proto(const Error& error, std::uint64_t sequence, v1::DistanceReport& out);

}  // namespace nearpoint::server
