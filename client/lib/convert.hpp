// SPDX-License-Identifier: Apache-2.0
// The client's own structs ↔ nearpoint.v1 messages: an Eigen pose and the report of an update,
// whose pairs name their objects. The scene model's structs convert through
// nearpoint_proto_convert, shared with the server.
#pragma once

#include "nearpoint/client/client.hpp"
#include "nearpoint/proto/convert.hpp"
#include "nearpoint_distance.pb.h"

namespace nearpoint::client::detail {

namespace v1 = ::nearpoint::v1;

using proto::from_proto;
using proto::to_proto;

void to_proto(const ObjectPose& pose, v1::ObjectPose& out);
Report from_proto(const v1::DistanceReport& report);
/// A rejected update's error: "field: message" (or the message alone), code UNKNOWN when the
/// server gave none.
Status from_proto(const v1::UpdateError& error);

}  // namespace nearpoint::client::detail
