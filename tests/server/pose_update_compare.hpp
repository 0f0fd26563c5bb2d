// SPDX-License-Identifier: Apache-2.0
// The reference read_plain_pose_updates (server/src/pose_update_wire.hpp) is held to: protobuf's
// parser and proto::from_proto, what nearpointd did with every stream message before. Shared by
// test_pose_update_wire and fuzz_pose_update_wire.
#pragma once

#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "nearpoint/proto/convert.hpp"
#include "nearpoint_distance.pb.h"

namespace nearpoint::testing {

/// protobuf's reading of `bytes` as a PoseUpdate (`batched` false) or a PoseUpdateBatch, through
/// from_proto; false when protobuf refuses the bytes.
inline bool protobuf_pose_updates(std::span<const std::uint8_t> bytes, bool batched,
                                  std::vector<model::PoseUpdateInput>& out) {
  out.clear();
  if (!batched) {
    v1::PoseUpdate update;
    if (!update.ParseFromArray(bytes.data(), int(bytes.size()))) return false;
    out.push_back(proto::from_proto(update));
    return true;
  }
  v1::PoseUpdateBatch batch;
  if (!batch.ParseFromArray(bytes.data(), int(bytes.size()))) return false;
  for (const v1::PoseUpdate& update : batch.updates()) out.push_back(proto::from_proto(update));
  return true;
}

/// "" when `a` and `b` are the same inputs, doubles compared bit for bit (NaN payloads, −0);
/// else the first difference.
inline std::string pose_update_difference(const model::PoseUpdateInput& a,
                                          const model::PoseUpdateInput& b) {
  auto same_bits = [](const double* x, const double* y, std::size_t n) {
    return std::memcmp(x, y, n * sizeof(double)) == 0;
  };
  if (a.scene_id != b.scene_id) return "scene_id";
  if (a.sequence != b.sequence) return "sequence";
  if (a.poses.size() != b.poses.size()) return "the number of poses";
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    const model::ObjectPoseInput& p = a.poses[i];
    const model::ObjectPoseInput& q = b.poses[i];
    const std::string at = "poses[" + std::to_string(i) + "]";
    if (p.object_id != q.object_id) return at + ".object_id";
    if (!same_bits(p.pose.rotation_wxyz.data(), q.pose.rotation_wxyz.data(), 4))
      return at + ".rotation";
    if (!same_bits(p.pose.translation.data(), q.pose.translation.data(), 3))
      return at + ".translation";
  }
  // The rest, through the messages they would be sent as.
  v1::QueryOptions options_a, options_b;
  proto::to_proto(a.options, options_a);
  proto::to_proto(b.options, options_b);
  if (options_a.SerializeAsString() != options_b.SerializeAsString()) return "options";
  if (a.flow_control != b.flow_control) return "flow_control";
  if (a.thresholds.size() != b.thresholds.size()) return "thresholds";
  for (std::size_t i = 0; i < a.thresholds.size(); ++i) {
    v1::Threshold threshold_a, threshold_b;
    proto::to_proto(a.thresholds[i], threshold_a);
    proto::to_proto(b.thresholds[i], threshold_b);
    if (threshold_a.SerializeAsString() != threshold_b.SerializeAsString())
      return "thresholds[" + std::to_string(i) + "]";
  }
  v1::JointPositions joints_a, joints_b;
  proto::to_proto(a.joints, joints_a);
  proto::to_proto(b.joints, joints_b);
  if (joints_a.SerializeAsString() != joints_b.SerializeAsString()) return "joints";
  return "";
}

}  // namespace nearpoint::testing
