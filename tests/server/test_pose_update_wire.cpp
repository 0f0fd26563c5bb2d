// SPDX-License-Identifier: Apache-2.0
// read_plain_pose_updates (server/src/pose_update_wire.hpp) against protobuf's parser and
// proto::from_proto: whatever it reads must be exactly what they make of the same bytes, and what
// it leaves to them must include every message outside its subset. The messages are written by
// protobuf's serialiser (random ids, sequence numbers at every varint length, NaN, infinities,
// −0, denormals, poses and their parts left out, every option on or off, enum values beyond the
// defined ones), then changed the ways a client or the network could: concatenated (protobuf
// merges), cut short, given other fields.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "pose_update_compare.hpp"
#include "pose_update_wire.hpp"

namespace {

namespace model = nearpoint::model;
namespace v1 = nearpoint::v1;
using nearpoint::server::read_plain_pose_updates;
using nearpoint::testing::pose_update_difference;
using nearpoint::testing::protobuf_pose_updates;

std::span<const std::uint8_t> bytes_of(const std::string& bytes) {
  return {reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()};
}

/// What the reader makes of `bytes`: nothing (left to protobuf), or updates that must equal
/// protobuf's, which must accept the bytes. Returns whether the reader read them.
bool read_and_compare(const std::string& bytes, bool batched) {
  std::vector<model::PoseUpdateInput> plain, reference;
  if (!read_plain_pose_updates(bytes_of(bytes), batched, plain)) return false;
  EXPECT_TRUE(protobuf_pose_updates(bytes_of(bytes), batched, reference))
      << "read bytes protobuf refuses";
  EXPECT_EQ(plain.size(), reference.size());
  for (std::size_t i = 0; i < std::min(plain.size(), reference.size()); ++i)
    EXPECT_EQ(pose_update_difference(plain[i], reference[i]), "") << "update " << i;
  return true;
}

class RandomUpdates {
 public:
  explicit RandomUpdates(std::uint32_t seed) : rng_(seed) {}

  v1::PoseUpdate update() {
    v1::PoseUpdate out;
    if (coin(0.9)) out.set_scene_id(id());
    if (coin(0.9)) out.set_sequence(sequence());
    if (coin(0.5)) options(*out.mutable_options());
    if (coin(0.5)) out.set_flow_control(v1::FlowControl(enum_value()));
    const int poses = int(rng_() % 12);
    for (int i = 0; i < poses; ++i) {
      v1::ObjectPose& pose = *out.add_poses();
      if (coin(0.95)) pose.set_object_id(id());
      if (coin(0.05)) continue;  // no pose: the identity
      v1::Pose& p = *pose.mutable_pose();
      if (coin(0.9)) {
        v1::Quaternion& q = *p.mutable_rotation();
        if (coin(0.9)) q.set_w(value());
        if (coin(0.9)) q.set_x(value());
        if (coin(0.9)) q.set_y(value());
        if (coin(0.9)) q.set_z(value());
      }
      if (coin(0.9)) {
        v1::Vector3& t = *p.mutable_translation();
        if (coin(0.9)) t.set_x(value());
        if (coin(0.9)) t.set_y(value());
        if (coin(0.9)) t.set_z(value());
      }
    }
    return out;
  }
  v1::PoseUpdateBatch batch() {
    v1::PoseUpdateBatch out;
    const int count = int(rng_() % 9);
    for (int i = 0; i < count; ++i) *out.add_updates() = update();
    return out;
  }

 private:
  /// Every field of QueryOptions on or off, enums beyond the defined values too.
  void options(v1::QueryOptions& out) {
    if (coin(0.5)) out.set_epsilon(value());
    if (coin(0.5)) out.set_near_points(coin(0.5));
    if (coin(0.5)) out.set_penetration(v1::PenetrationMode(enum_value()));
    if (coin(0.5)) out.set_gradient(coin(0.5));
    if (coin(0.5)) out.set_distance_cutoff(value());
    if (coin(0.5)) out.set_warm_start(coin(0.5));
    if (coin(0.5)) out.set_max_iterations(std::uint32_t(rng_()));
    if (coin(0.5)) out.set_report_mode(v1::ReportMode(enum_value()));
    if (coin(0.5)) out.set_change_tolerance(value());
  }
  /// 0–9 and, rarely, a large positive value (negative ones take 10 varint bytes: protobuf's).
  int enum_value() { return coin(0.9) ? int(rng_() % 10) : int(rng_() % 0x7FFFFFFF); }
  bool coin(double p) { return std::uniform_real_distribution<double>(0, 1)(rng_) < p; }
  std::string id() {
    static const char* ids[] = {"a", "", "mover", "part_12345678901234567890", "tab\tand\0nul"};
    const std::size_t pick = rng_() % 6;
    if (pick == 5) return std::string(200, 'o');  // a two-byte length
    if (pick == 4) return std::string(ids[4], 11);
    return ids[pick];
  }
  std::uint64_t sequence() {
    const int bits = int(rng_() % 64);  // 1 to 9 bytes of varint (63 bits at most)
    return rng_() & ((std::uint64_t(1) << bits) - 1);
  }
  double value() {
    switch (rng_() % 10) {
      case 0:
        return std::numeric_limits<double>::quiet_NaN();
      case 1:
        return -std::numeric_limits<double>::infinity();
      case 2:
        return -0.0;
      case 3:
        return std::numeric_limits<double>::denorm_min();
      default:
        return std::normal_distribution<double>(0, 100)(rng_);
    }
  }
  std::mt19937_64 rng_;
};

// Random updates and batches as protobuf writes them: all read, all the same as protobuf's.
TEST(PoseUpdateWire, ReadsWhatProtobufWritesAsProtobufReadsIt) {
  RandomUpdates random(7);
  for (int i = 0; i < 500; ++i) {
    EXPECT_TRUE(read_and_compare(random.update().SerializeAsString(), false)) << "update " << i;
    EXPECT_TRUE(read_and_compare(random.batch().SerializeAsString(), true)) << "batch " << i;
  }
  EXPECT_TRUE(read_and_compare("", false));  // an empty update
  EXPECT_TRUE(read_and_compare("", true));   // an empty batch: no update
}

// Two messages one after the other are one message to protobuf (repeated fields appended, the
// last scalar kept): read the same. A pose given twice in one ObjectPose would be merged by
// protobuf, field by field: left to it.
TEST(PoseUpdateWire, ConcatenatedMessagesAreReadAsProtobufMergesThem) {
  RandomUpdates random(8);
  for (int i = 0; i < 200; ++i) {
    EXPECT_TRUE(read_and_compare(
        random.update().SerializeAsString() + random.update().SerializeAsString(), false));
    EXPECT_TRUE(read_and_compare(
        random.batch().SerializeAsString() + random.batch().SerializeAsString(), true));
  }
  v1::ObjectPose first, second;
  first.set_object_id("a");
  first.mutable_pose()->mutable_translation()->set_x(1);
  second.mutable_pose()->mutable_rotation()->set_w(1);
  // One ObjectPose (PoseUpdate field 3) whose bytes hold two poses.
  const std::string object = first.SerializeAsString() + second.SerializeAsString();
  const std::string merged_pose = std::string("\x1A") + char(object.size()) + object;
  EXPECT_FALSE(read_and_compare(merged_pose, false));
  std::vector<model::PoseUpdateInput> reference;
  ASSERT_TRUE(protobuf_pose_updates(bytes_of(merged_pose), false, reference));
  EXPECT_EQ(reference[0].poses[0].pose.translation.x(), 1);  // protobuf merged both
}

// Every field outside the subset, unknown fields, wrong wire types and strings that are not ASCII
// go to protobuf, which then accepts or refuses them with its own reasons.
TEST(PoseUpdateWire, LeavesEveryOtherMessageToProtobuf) {
  v1::PoseUpdate base;
  base.set_scene_id("s");
  base.set_sequence(3);
  base.add_poses()->set_object_id("a");
  ASSERT_TRUE(read_and_compare(base.SerializeAsString(), false));

  auto with = [&](auto change) {
    v1::PoseUpdate update = base;
    change(update);
    return update.SerializeAsString();
  };
  // Options and flow control are read (what clients send on every update); a negative enum
  // (10 varint bytes) is protobuf's.
  EXPECT_TRUE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.mutable_options()->set_near_points(true); }), false));
  EXPECT_TRUE(read_and_compare(with([](v1::PoseUpdate& u) { u.mutable_options(); }), false));
  EXPECT_TRUE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.set_flow_control(v1::FLOW_CONTROL_COALESCE); }), false));
  EXPECT_FALSE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.set_flow_control(v1::FlowControl(-1)); }), false));
  EXPECT_FALSE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.mutable_options()->set_report_mode(v1::ReportMode(-2)); }),
      false));
  // An unknown field inside the options; epsilon as a varint.
  EXPECT_FALSE(read_and_compare(base.SerializeAsString() + "\x22\x02\x50\x01", false));
  EXPECT_FALSE(read_and_compare(base.SerializeAsString() + "\x22\x02\x08\x01", false));
  EXPECT_FALSE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.add_thresholds()->set_distance(0.1); }), false));
  EXPECT_FALSE(
      read_and_compare(with([](v1::PoseUpdate& u) { u.mutable_joints()->add_names("j"); }), false));
  // Unknown field 99 (varint); sequence as fixed64 (a known number, the wrong wire type: protobuf
  // keeps it as an unknown field).
  EXPECT_FALSE(read_and_compare(base.SerializeAsString() + "\x98\x06\x01", false));
  EXPECT_FALSE(read_and_compare(base.SerializeAsString() + "\x11" + std::string(8, '\1'), false));
  // A Vector3 coordinate as a varint.
  EXPECT_FALSE(read_and_compare("\x1A\x06\x12\x04\x12\x02\x08\x01", false));
  // Ids that are valid UTF-8 but not ASCII, and ones that are not UTF-8 (protobuf refuses these).
  EXPECT_FALSE(read_and_compare(with([](v1::PoseUpdate& u) { u.set_scene_id("κύβος"); }), false));
  EXPECT_FALSE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.mutable_poses(0)->set_object_id("é"); }), false));
  const std::string not_utf8 = "\x0A\x01\xFF";
  EXPECT_FALSE(read_and_compare(not_utf8, false));
  std::vector<model::PoseUpdateInput> reference;
  EXPECT_FALSE(protobuf_pose_updates(bytes_of(not_utf8), false, reference));
  // A sequence number of 10 varint bytes (2^63 and above): protobuf's to read.
  EXPECT_FALSE(read_and_compare(
      with([](v1::PoseUpdate& u) { u.set_sequence(std::uint64_t(1) << 63); }), false));
  // A batch holding anything but updates.
  EXPECT_FALSE(read_and_compare("\x10\x01", true));
}

// Every prefix of a message: read only if protobuf reads it the same (a cut at a field's end is
// a valid shorter message), never past the end (ASan in the sanitizer builds).
TEST(PoseUpdateWire, CutMessagesAreReadOnlyWhereProtobufReadsThemTheSame) {
  RandomUpdates random(9);
  int read = 0, left = 0;
  for (int i = 0; i < 40; ++i) {
    const std::string update = random.update().SerializeAsString();
    const std::string batch = random.batch().SerializeAsString();
    for (std::size_t n = 0; n < update.size(); ++n)
      (read_and_compare(update.substr(0, n), false) ? read : left)++;
    for (std::size_t n = 0; n < batch.size(); ++n)
      (read_and_compare(batch.substr(0, n), true) ? read : left)++;
  }
  // Both kinds occur: a cut inside a field is refused, one between fields is a message.
  EXPECT_GT(read, 0);
  EXPECT_GT(left, 0);
}

}  // namespace
