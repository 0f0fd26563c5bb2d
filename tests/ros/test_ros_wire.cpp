// SPDX-License-Identifier: Apache-2.0
// Golden bytes: the samples of our DDS types (generated from the .msg files, see
// ros/generate_dds_idl.py) as Cyclone DDS puts them on the wire, against the bytes ROS 2 writes
// for the same messages, and the reverse.
//
// What ROS 2 writes (rmw_cyclonedds with the rosidl introspection type support): the 4-byte
// encapsulation header 00 01 00 00 (CDR, little endian, no options), then the message's fields
// in .msg order, nested messages inline, as XCDR1 (classic CDR): every primitive aligned to its
// own size (8 for float64, int64, uint64), offsets counted from the byte after the header; bool,
// byte, uint8 one byte; a string as a uint32 length counting its terminating NUL, the bytes, the
// NUL; an unbounded sequence (T[]) as a uint32 element count and the elements; a fixed array
// (T[N]) as its N elements with no count. No key, no member header (final types, no XCDR2
// DHEADER). The expected bytes below are written by hand from those rules, field by field, in a
// builder that shares nothing with Cyclone's serialiser; JointState's are also spelled out as a
// literal hex string.
//
// The sample goes through the real path: dds_write on a writer, dds_takecdr on a reader of the
// same participant (the serialised sample Cyclone would send), and back: the golden bytes made
// into a serialised sample, dds_writecdr, dds_take as our C type.
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "nearpoint_dds.hpp"

namespace {

// 131-140: this file's domain ids (101-130: tests/dds).
constexpr dds_domainid_t kDomain = 131;

/// XCDR1 little-endian bytes, written field by field (alignment relative to the payload).
class Cdr {
 public:
  Cdr() : bytes_{0x00, 0x01, 0x00, 0x00} {}
  Cdr& u8(std::uint8_t v) { return raw(&v, 1, 1); }
  Cdr& boolean(bool v) { return u8(v ? 1 : 0); }
  Cdr& i32(std::int32_t v) { return raw(&v, 4, 4); }
  Cdr& u32(std::uint32_t v) { return raw(&v, 4, 4); }
  Cdr& u64(std::uint64_t v) { return raw(&v, 8, 8); }
  Cdr& f64(double v) { return raw(&v, 8, 8); }
  Cdr& str(const std::string& s) {
    u32(std::uint32_t(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
    return *this;
  }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  Cdr& raw(const void* v, std::size_t size, std::size_t align) {
    while ((bytes_.size() - 4) % align != 0) bytes_.push_back(0);
    const auto* p = static_cast<const std::uint8_t*>(v);
    bytes_.insert(bytes_.end(), p, p + size);  // this machine is little endian (x86-64, arm64)
    return *this;
  }
  std::vector<std::uint8_t> bytes_;
};

std::string hex(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i > 0) out += (i % 16 == 0) ? '\n' : ' ';
    out += kDigits[bytes[i] >> 4];
    out += kDigits[bytes[i] & 15];
  }
  return out;
}

std::vector<std::uint8_t> from_hex(const std::string& text) {
  std::vector<std::uint8_t> out;
  int high = -1;
  for (const char c : text) {
    int v = -1;
    if (c >= '0' && c <= '9') v = c - '0';
    if (c >= 'a' && c <= 'f') v = c - 'a' + 10;
    if (v < 0) continue;
    if (high < 0) {
      high = v;
    } else {
      out.push_back(std::uint8_t(high * 16 + v));
      high = -1;
    }
  }
  return out;
}

/// A writer and a reader of one topic on one participant: what Cyclone serialises, and what it
/// makes of given bytes.
class Loop {
 public:
  Loop(const dds_topic_descriptor_t* descriptor, const char* topic) {
    participant_ = dds_create_participant(kDomain, nullptr, nullptr);
    EXPECT_GT(participant_, 0) << dds_strretcode(participant_);
    const nearpoint::dds::QosPtr qos = nearpoint::dds::stream_qos();
    const dds_entity_t t = dds_create_topic(participant_, descriptor, topic, qos.get(), nullptr);
    EXPECT_GT(t, 0) << dds_strretcode(t);
    writer_ = dds_create_writer(participant_, t, qos.get(), nullptr);
    reader_ = dds_create_reader(participant_, t, qos.get(), nullptr);
    EXPECT_GT(writer_, 0);
    EXPECT_GT(reader_, 0);
  }
  ~Loop() { dds_delete(participant_); }

  /// The serialised sample (with its encapsulation header) that dds_write makes of `sample`.
  std::vector<std::uint8_t> serialise(const void* sample) {
    EXPECT_EQ(dds_write(writer_, sample), DDS_RETCODE_OK);
    struct ddsi_serdata* data = nullptr;
    dds_sample_info_t info;
    EXPECT_EQ(dds_takecdr(reader_, &data, 1, &info, 0), 1);
    if (data == nullptr) return {};
    std::vector<std::uint8_t> out(ddsi_serdata_size(data));
    ddsi_serdata_to_ser(data, 0, out.size(), out.data());
    type_ = data->type;
    ddsi_serdata_unref(data);
    return out;
  }

  /// Whether Cyclone makes a serialised sample of `bytes` (it checks them against the type).
  bool accepts(const std::vector<std::uint8_t>& bytes) {
    EXPECT_NE(type_, nullptr) << "serialise() first: it finds the sertype";
    if (type_ == nullptr) return false;
    ddsrt_iovec_t iov;
    iov.iov_base = const_cast<std::uint8_t*>(bytes.data());
    iov.iov_len = static_cast<ddsrt_iov_len_t>(bytes.size());
    struct ddsi_serdata* data = ddsi_serdata_from_ser_iov(type_, SDK_DATA, 1, &iov, bytes.size());
    if (data == nullptr) return false;
    ddsi_serdata_unref(data);
    return true;
  }

  /// `bytes` written as a serialised sample and taken as our C type, which `check` inspects.
  template <typename Sample, typename Check>
  void deserialise(const std::vector<std::uint8_t>& bytes, Check check) {
    ASSERT_NE(type_, nullptr) << "serialise() first: it finds the sertype";
    ddsrt_iovec_t iov;
    iov.iov_base = const_cast<std::uint8_t*>(bytes.data());
    iov.iov_len = static_cast<ddsrt_iov_len_t>(bytes.size());
    struct ddsi_serdata* data = ddsi_serdata_from_ser_iov(type_, SDK_DATA, 1, &iov, bytes.size());
    ASSERT_NE(data, nullptr) << "Cyclone refused the bytes";
    ASSERT_EQ(dds_writecdr(writer_, data), DDS_RETCODE_OK);
    void* samples[1] = {nullptr};
    dds_sample_info_t info;
    ASSERT_EQ(dds_take(reader_, samples, &info, 1, 1), 1);
    ASSERT_TRUE(info.valid_data);
    check(*static_cast<const Sample*>(samples[0]));
    dds_return_loan(reader_, samples, 1);
  }

 private:
  dds_entity_t participant_ = 0, writer_ = 0, reader_ = 0;
  const struct ddsi_sertype* type_ = nullptr;
};

char* text(const char* s) {
  return const_cast<char*>(s);
}

// sensor_msgs/JointState: header (stamp sec, nanosec; frame_id), name[], position[],
// velocity[], effort[].
TEST(RosWire, JointStateMatchesRos2Bytes) {
  char* names[] = {text("shoulder"), text("elbow")};
  double position[] = {0.5, -1.25};
  double velocity[] = {0.125};
  sensor_msgs_msg_dds__JointState_ sample{};
  sample.header.stamp = {42, 500000000};
  sample.header.frame_id = text("base");
  sample.name = {2, 2, names, false};
  sample.position = {2, 2, position, false};
  sample.velocity = {1, 1, velocity, false};
  sample.effort = {0, 0, nullptr, false};

  // Offsets from the payload's start (after the 4 header bytes).
  // Offsets from the payload's start (after the 4 header bytes).
  const std::vector<std::uint8_t> ros = from_hex(
      "00 01 00 00"                             // encapsulation: CDR_LE, options 0
      "2a 00 00 00"                             // 0  header.stamp.sec = 42
      "00 65 cd 1d"                             // 4  header.stamp.nanosec = 500000000
      "05 00 00 00 62 61 73 65 00"              // 8  header.frame_id: length 5, "base", NUL
      "00 00 00"                                // 17 padding to 20
      "02 00 00 00"                             // 20 name: 2 strings
      "09 00 00 00 73 68 6f 75 6c 64 65 72 00"  // 24 "shoulder"
      "00 00 00"                                // 37 padding to 40
      "06 00 00 00 65 6c 62 6f 77 00"           // 40 "elbow"
      "00 00"                                   // 50 padding to 52
      "02 00 00 00"                             // 52 position: 2 doubles
      "00 00 00 00 00 00 e0 3f"                 // 56 0.5 (56 is 8-aligned)
      "00 00 00 00 00 00 f4 bf"                 // 64 -1.25
      "01 00 00 00"                             // 72 velocity: 1 double
      "00 00 00 00"                             // 76 padding to 80
      "00 00 00 00 00 00 c0 3f"                 // 80 0.125
      "00 00 00 00");                           // 88 effort: empty
  // The same message from the builder (the rules applied mechanically) must agree.
  const std::vector<std::uint8_t> expected = Cdr()
                                                 .i32(42)
                                                 .u32(500000000)
                                                 .str("base")
                                                 .u32(2)
                                                 .str("shoulder")
                                                 .str("elbow")
                                                 .u32(2)
                                                 .f64(0.5)
                                                 .f64(-1.25)
                                                 .u32(1)
                                                 .f64(0.125)
                                                 .u32(0)
                                                 .bytes();
  ASSERT_EQ(hex(ros), hex(expected));

  Loop loop(&sensor_msgs_msg_dds__JointState__desc, "rt/ros_wire_joint_states");
  const std::vector<std::uint8_t> ours = loop.serialise(&sample);
  EXPECT_EQ(hex(ours), hex(expected));

  loop.deserialise<sensor_msgs_msg_dds__JointState_>(
      expected, [](const sensor_msgs_msg_dds__JointState_& back) {
        EXPECT_EQ(back.header.stamp.sec, 42);
        EXPECT_EQ(back.header.stamp.nanosec, 500000000u);
        EXPECT_STREQ(back.header.frame_id, "base");
        ASSERT_EQ(back.name._length, 2u);
        EXPECT_STREQ(back.name._buffer[0], "shoulder");
        EXPECT_STREQ(back.name._buffer[1], "elbow");
        ASSERT_EQ(back.position._length, 2u);
        EXPECT_EQ(back.position._buffer[0], 0.5);
        EXPECT_EQ(back.position._buffer[1], -1.25);
        ASSERT_EQ(back.velocity._length, 1u);
        EXPECT_EQ(back.velocity._buffer[0], 0.125);
        EXPECT_EQ(back.effort._length, 0u);
      });
}

// geometry_msgs/PoseStamped: header, pose (position x y z, orientation x y z w).
TEST(RosWire, PoseStampedMatchesRos2Bytes) {
  geometry_msgs_msg_dds__PoseStamped_ sample{};
  sample.header.stamp = {-3, 7};
  sample.header.frame_id = text("world");
  sample.pose.position = {1.0, 2.0, 3.0};
  sample.pose.orientation = {0.0, 0.0, 0.6, 0.8};
  // frame_id "world" ends at offset 8 + 4 + 6 = 18; position.x is padded to 24.
  const std::vector<std::uint8_t> expected = Cdr()
                                                 .i32(-3)
                                                 .u32(7)
                                                 .str("world")
                                                 .f64(1.0)
                                                 .f64(2.0)
                                                 .f64(3.0)
                                                 .f64(0.0)
                                                 .f64(0.0)
                                                 .f64(0.6)
                                                 .f64(0.8)
                                                 .bytes();
  EXPECT_EQ(expected.size(), 4u + 24u + 56u);
  Loop loop(&geometry_msgs_msg_dds__PoseStamped__desc, "rt/ros_wire_pose");
  EXPECT_EQ(hex(loop.serialise(&sample)), hex(expected));
  loop.deserialise<geometry_msgs_msg_dds__PoseStamped_>(
      expected, [](const geometry_msgs_msg_dds__PoseStamped_& back) {
        EXPECT_EQ(back.header.stamp.sec, -3);
        EXPECT_STREQ(back.header.frame_id, "world");
        EXPECT_EQ(back.pose.position.z, 3.0);
        EXPECT_EQ(back.pose.orientation.z, 0.6);
        EXPECT_EQ(back.pose.orientation.w, 0.8);
      });
}

// nearpoint_msgs/ThresholdEvent: header, scene_id, client_id, threshold, threshold_index,
// object_a, object_b, crossing (uint8), distance (float64), sequence_number (uint64).
TEST(RosWire, ThresholdEventMatchesRos2Bytes) {
  nearpoint_msgs_msg_dds__ThresholdEvent_ sample{};
  sample.header.stamp = {1, 2};
  sample.header.frame_id = text("");
  sample.scene_id = text("cell-1");
  sample.client_id = text("arm");
  sample.threshold = text("slow");
  sample.threshold_index = 3;
  sample.object_a = text("gripper");
  sample.object_b = text("table");
  sample.crossing = 1;
  sample.distance = 0.05;
  sample.sequence_number = 77;
  const std::vector<std::uint8_t> expected = Cdr()
                                                 .i32(1)
                                                 .u32(2)
                                                 .str("")
                                                 .str("cell-1")
                                                 .str("arm")
                                                 .str("slow")
                                                 .u32(3)
                                                 .str("gripper")
                                                 .str("table")
                                                 .u8(1)
                                                 .f64(0.05)
                                                 .u64(77)
                                                 .bytes();
  Loop loop(&nearpoint_msgs_msg_dds__ThresholdEvent__desc, "rt/ros_wire_events");
  EXPECT_EQ(hex(loop.serialise(&sample)), hex(expected));
  loop.deserialise<nearpoint_msgs_msg_dds__ThresholdEvent_>(
      expected, [](const nearpoint_msgs_msg_dds__ThresholdEvent_& back) {
        EXPECT_STREQ(back.scene_id, "cell-1");
        EXPECT_STREQ(back.object_b, "table");
        EXPECT_EQ(back.crossing, 1);
        EXPECT_EQ(back.distance, 0.05);
        EXPECT_EQ(back.sequence_number, 77u);
      });
}

// nearpoint_msgs/PoseUpdate, the message a ROS 2 node publishes to nearpointd: header,
// scene_id, client_id, sequence_number, poses[] (object_id, geometry_msgs/Pose), options
// (QueryOptions, 19 fields), flow_control, thresholds[].
TEST(RosWire, PoseUpdateMatchesRos2Bytes) {
  nearpoint_msgs_msg_dds__ObjectPose_ pose{};
  pose.object_id = text("arm");
  pose.pose.position = {0.1, 0.2, 0.3};
  pose.pose.orientation = {0, 0, 0, 1};
  nearpoint_msgs_msg_dds__PoseUpdate_ sample{};
  sample.header.frame_id = text("world");
  sample.scene_id = text("s");
  sample.client_id = text("ros");
  sample.sequence_number = 5;
  sample.poses = {1, 1, &pose, false};
  sample.options.has_near_points = true;
  sample.options.near_points = true;
  sample.options.has_distance_cutoff = true;
  sample.options.distance_cutoff = 0.5;
  sample.options.max_iterations = 9;
  sample.options.report_mode = 2;
  sample.flow_control = 2;
  sample.thresholds = {0, 0, nullptr, false};
  Cdr cdr;
  cdr.i32(0).u32(0).str("world").str("s").str("ros").u64(5);
  cdr.u32(1).str("arm").f64(0.1).f64(0.2).f64(0.3).f64(0).f64(0).f64(0).f64(1);
  // QueryOptions: has_epsilon, epsilon, has_near_points, near_points, penetration,
  // has_gradient, gradient, has_distance_cutoff, distance_cutoff, has_warm_start, warm_start,
  // has_max_iterations, max_iterations, report_mode, has_change_tolerance, change_tolerance.
  cdr.boolean(false).f64(0).boolean(true).boolean(true).u8(0).boolean(false).boolean(false);
  cdr.boolean(true).f64(0.5).boolean(false).boolean(false).boolean(false).u32(9).u8(2);
  cdr.boolean(false).f64(0);
  cdr.u8(2).u32(0);
  Loop loop(&nearpoint_msgs_msg_dds__PoseUpdate__desc, "rt/ros_wire_updates");
  EXPECT_EQ(hex(loop.serialise(&sample)), hex(cdr.bytes()));
  loop.deserialise<nearpoint_msgs_msg_dds__PoseUpdate_>(
      cdr.bytes(), [](const nearpoint_msgs_msg_dds__PoseUpdate_& back) {
        EXPECT_STREQ(back.scene_id, "s");
        ASSERT_EQ(back.poses._length, 1u);
        EXPECT_EQ(back.poses._buffer[0].pose.position.y, 0.2);
        EXPECT_EQ(back.poses._buffer[0].pose.orientation.w, 1.0);
        EXPECT_EQ(back.options.distance_cutoff, 0.5);
        EXPECT_EQ(back.options.max_iterations, 9u);
        EXPECT_EQ(back.flow_control, 2);
      });
}

// nearpoint_msgs/PoseUpdateBatch: updates[] — a uint32 count, then each PoseUpdate inline, its
// 8-byte fields aligned from the start of the payload (so the second update's padding differs
// from the first's: its strings end at other offsets).
TEST(RosWire, PoseUpdateBatchMatchesRos2Bytes) {
  nearpoint_msgs_msg_dds__ObjectPose_ poses[2]{};
  nearpoint_msgs_msg_dds__PoseUpdate_ updates[2]{};
  const char* scenes[2] = {"s", "scene-2"};
  for (int k = 0; k < 2; ++k) {
    poses[k].object_id = text("arm");
    poses[k].pose.position = {0.1 * (k + 1), 0.2, 0.3};
    poses[k].pose.orientation = {0, 0, 0, 1};
    updates[k].header.stamp = {k, 0};
    updates[k].header.frame_id = text("");
    updates[k].scene_id = text(scenes[k]);
    updates[k].client_id = text("ros");
    updates[k].sequence_number = std::uint64_t(5 + k);
    updates[k].poses = {1, 1, &poses[k], false};
    updates[k].thresholds = {0, 0, nullptr, false};
  }
  nearpoint_msgs_msg_dds__PoseUpdateBatch_ sample{};
  sample.updates = {2, 2, updates, false};
  Cdr cdr;
  cdr.u32(2);
  for (int k = 0; k < 2; ++k) {
    cdr.i32(k).u32(0).str("").str(scenes[k]).str("ros").u64(std::uint64_t(5 + k));
    cdr.u32(1).str("arm").f64(0.1 * (k + 1)).f64(0.2).f64(0.3).f64(0).f64(0).f64(0).f64(1);
    cdr.boolean(false).f64(0).boolean(false).boolean(false).u8(0).boolean(false).boolean(false);
    cdr.boolean(false).f64(0).boolean(false).boolean(false).boolean(false).u32(0).u8(0);
    cdr.boolean(false).f64(0);
    cdr.u8(0).u32(0);
  }
  Loop loop(&nearpoint_msgs_msg_dds__PoseUpdateBatch__desc, "rt/ros_wire_update_batches");
  EXPECT_EQ(hex(loop.serialise(&sample)), hex(cdr.bytes()));
  loop.deserialise<nearpoint_msgs_msg_dds__PoseUpdateBatch_>(
      cdr.bytes(), [](const nearpoint_msgs_msg_dds__PoseUpdateBatch_& back) {
        ASSERT_EQ(back.updates._length, 2u);
        EXPECT_STREQ(back.updates._buffer[1].scene_id, "scene-2");
        EXPECT_EQ(back.updates._buffer[1].sequence_number, 6u);
        ASSERT_EQ(back.updates._buffer[1].poses._length, 1u);
        EXPECT_EQ(back.updates._buffer[1].poses._buffer[0].pose.position.x, 0.2);
      });
}

// Bytes that do not hold the type (a peer with another idea of it, or a malformed sample) are
// refused when Cyclone reads them, never read past.
TEST(RosWire, MalformedSamplesAreRefused) {
  Loop loop(&sensor_msgs_msg_dds__JointState__desc, "rt/ros_wire_malformed");
  sensor_msgs_msg_dds__JointState_ sample{};
  sample.header.frame_id = text("");
  ASSERT_FALSE(loop.serialise(&sample).empty());
  // A name sequence claiming 1000 strings in no bytes.
  EXPECT_FALSE(loop.accepts(Cdr().i32(0).u32(0).str("").u32(1000).bytes()));
  // A string whose length runs past the end.
  EXPECT_FALSE(loop.accepts(Cdr().i32(0).u32(0).u32(4000).bytes()));
  // Cut inside the header.
  EXPECT_FALSE(loop.accepts(Cdr().i32(0).bytes()));
  // The complete empty message is accepted.
  EXPECT_TRUE(loop.accepts(Cdr().i32(0).u32(0).str("").u32(0).u32(0).u32(0).u32(0).bytes()));
}

}  // namespace
