// SPDX-License-Identifier: Apache-2.0
// Upper bounds on the size of a report on the wire: the protobuf encoding of
// nearpoint.v1.DistanceReport (proto/nearpoint/v1/nearpoint_distance.proto). The scene API uses
// them to refuse, up front, a scene or a request whose report could not be sent in one message
// (ServiceLimits::max_report_bytes). Plain arithmetic, no protobuf: the scene API knows no
// transport. tests/server checks the bounds against protobuf's own ByteSizeLong on worst-case
// reports, and that the messages still have the fields counted here.
//
// Worst cases throughout: every field present, every varint at its longest (a uint32 takes 5
// bytes, a uint64 10), doubles 8 bytes plus their tag. Field numbers up to 15 take a one-byte tag,
// 16–2047 two.
#pragma once

#include <cstddef>
#include <cstdint>

namespace nearpoint::server::report_size {

constexpr std::size_t varint_bytes(std::uint64_t value) {
  std::size_t bytes = 1;
  while (value >= 0x80) value >>= 7, ++bytes;
  return bytes;
}
constexpr std::size_t tag_bytes(int field) {
  return field < 16 ? 1 : 2;
}
constexpr std::size_t fixed64_field(int field) {
  return tag_bytes(field) + 8;
}
constexpr std::size_t uint32_field(int field) {
  return tag_bytes(field) + 5;
}
constexpr std::size_t uint64_field(int field) {
  return tag_bytes(field) + 10;
}
/// bool, and enums whose values are below 128.
constexpr std::size_t small_field(int field) {
  return tag_bytes(field) + 1;
}
/// A length-delimited field (string, bytes, message) with `length` bytes of content.
constexpr std::size_t delimited_field(int field, std::size_t length) {
  return tag_bytes(field) + varint_bytes(length) + length;
}

/// Vector3 {double x = 1, y = 2, z = 3}.
constexpr std::size_t kVector3 = 3 * fixed64_field(1);
/// PoseGradient {Vector3 translation = 1, rotation = 2}.
constexpr std::size_t kPoseGradient = 2 * delimited_field(1, kVector3);
/// ReportTiming: four doubles (fields 1–4).
constexpr std::size_t kTiming = 4 * fixed64_field(1);

/// ReportCounts: three uint32 (fields 1–3).
constexpr std::size_t kCounts = 3 * uint32_field(1);

/// DistanceReport without its pairs and without `error` (reports with pairs have none):
/// sequence = 1, timing = 4, coalesced_updates = 5, coalesced_from_sequence = 6, counts = 7,
/// report_mode = 8.
constexpr std::size_t kReportEnvelope = uint64_field(1) + delimited_field(4, kTiming) +
                                        uint32_field(5) + uint64_field(6) +
                                        delimited_field(7, kCounts) + small_field(8);

/// The content of one PairDistance whatever the options: status = 3, distance = 4,
/// distance_lower_bound = 5, error_bound = 6, iterations = 7, piece_pairs_evaluated = 8,
/// piece_a = 9, piece_b = 10, warm_started = 11. The object ids (1, 2) come on top.
constexpr std::size_t kPairFixed =
    small_field(3) + 3 * fixed64_field(4) + 4 * uint32_field(7) + small_field(11);
/// What near points add: has_near_points = 12, point_a = 13, point_b = 14, normal = 15.
constexpr std::size_t kPairNearPoints = small_field(12) + 3 * delimited_field(13, kVector3);
/// What the penetration bound adds: has_penetration_bound = 16, penetration_bound = 17.
constexpr std::size_t kPairPenetration = small_field(16) + fixed64_field(17);
/// What the gradient adds: has_gradient = 18, gradient_a = 19, gradient_b = 20.
constexpr std::size_t kPairGradient = small_field(18) + 2 * delimited_field(19, kPoseGradient);

/// What PENETRATION_MODE_DEPTH adds: has_signed_distance = 22, signed_distance = 23,
/// signed_distance_lower = 24, signed_distance_upper = 25, has_penetration_depth = 26,
/// penetration_depth = 27, penetration_depth_lower = 28, penetration_depth_upper = 29,
/// depth_point_a = 30, depth_point_b = 31, depth_direction = 32, depth_termination = 33,
/// depth_iterations = 34.
constexpr std::size_t kPairDepth = small_field(22) + 3 * fixed64_field(23) + small_field(26) +
                                   3 * fixed64_field(27) + 3 * delimited_field(30, kVector3) +
                                   small_field(33) + uint32_field(34);

/// The object ids of one pair: object_a = 1, object_b = 2.
constexpr std::size_t pair_ids(std::size_t id_a_bytes, std::size_t id_b_bytes) {
  return delimited_field(1, id_a_bytes) + delimited_field(2, id_b_bytes);
}

/// One entry of DistanceReport.pairs (field 3) around `content` bytes of PairDistance. A pair's
/// content stays below 16 KiB (ids are at most 128 bytes), so its length takes at most 2 bytes;
/// counting 2 keeps the bound independent of the options.
constexpr std::size_t kPairEntryOverhead = tag_bytes(3) + 2;

/// What the options asked for add to every pair at most.
constexpr std::size_t pair_options(bool near_points, bool penetration_bound, bool gradient,
                                   bool penetration_depth) {
  return (near_points ? kPairNearPoints : 0) + (penetration_bound ? kPairPenetration : 0) +
         (gradient ? kPairGradient : 0) + (penetration_depth ? kPairDepth : 0);
}

/// One entry of DistanceReport.events (field 9): a ThresholdEvent with threshold = 1 (the
/// name), threshold_index = 2, object_a = 3, object_b = 4, crossing = 5, distance = 6,
/// sequence = 7.
constexpr std::size_t event_entry(std::size_t name_bytes, std::size_t id_a_bytes,
                                  std::size_t id_b_bytes) {
  const std::size_t content = delimited_field(1, name_bytes) + uint32_field(2) +
                              delimited_field(3, id_a_bytes) + delimited_field(4, id_b_bytes) +
                              small_field(5) + fixed64_field(6) + uint64_field(7);
  return delimited_field(9, content);
}

/// Robot scenes. One PairDistance.joint_gradient entry (field 35): a JointDerivative with
/// joint = 1 (the name), coordinate = 2, value = 3. A pair's gradient entries can take its
/// content past 16 KiB: kJointGradientLength is the third byte its length may then take.
constexpr std::size_t joint_derivative_entry(std::size_t name_bytes) {
  return delimited_field(35, delimited_field(1, name_bytes) + uint32_field(2) + fixed64_field(3));
}
constexpr std::size_t kJointGradientLength = 1;
/// One DistanceReport.joint_limit_violations entry (field 10): joint = 1, position = 2,
/// lower = 3, upper = 4.
constexpr std::size_t joint_limit_entry(std::size_t name_bytes) {
  return delimited_field(10, delimited_field(1, name_bytes) + 3 * fixed64_field(2));
}

// PairDistance.message (21), the engine's text for PAIR_STATUS_ENGINE_ERROR, is not counted: the
// engine refuses only what the server's validation already refuses, so it marks a server bug.
// Should it ever make a report too large, the transport answers with an error report instead
// (the send-time check in the gRPC service).

}  // namespace nearpoint::server::report_size
