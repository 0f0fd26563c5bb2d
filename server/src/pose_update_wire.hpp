// SPDX-License-Identifier: Apache-2.0
// A pose stream's messages read straight from protobuf's wire format into the model's inputs,
// for the messages that carry only what a stream sends on every update: the scene id, the
// sequence number, object poses, the options and the flow control. Parsing them into the
// generated messages first (arena allocations for every pose's ObjectPose, Pose, Quaternion and
// Vector3, then a copy into the model) was the largest cost of a batched cell45 update outside
// the engine and the transport. Anything else — thresholds and joints (a stream's first update,
// a robot's), an unknown field, a field repeated where protobuf would merge sub-messages, a
// string that is not ASCII, bytes that do not parse — is left to protobuf: the reader says it
// did not read the message, and the caller parses it as before, so every refusal and every
// unusual message is protobuf's, with the same reason.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::server {

/// Reads `bytes` as a nearpoint.v1.PoseUpdate (`batched` false) or a PoseUpdateBatch (true) into
/// `out` (replaced), exactly as proto::from_proto would convert what protobuf parses, when the
/// message holds only PoseUpdate fields 1–5 (scene_id, sequence, poses, options, flow_control)
/// with ObjectPose, Pose, Quaternion and Vector3 inside. Returns false, with `out` unspecified,
/// for any other message; the caller then parses it with protobuf.
bool read_plain_pose_updates(std::span<const std::uint8_t> bytes, bool batched,
                             std::vector<model::PoseUpdateInput>& out);

}  // namespace nearpoint::server
