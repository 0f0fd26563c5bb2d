// SPDX-License-Identifier: Apache-2.0
#include "pose_update_wire.hpp"

#include <bit>
#include <cstring>

#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/proto/convert.hpp"
#include "nearpoint_distance.pb.h"

namespace nearpoint::server {
namespace {

static_assert(std::endian::native == std::endian::little,
              "fixed64 fields are read as the host's doubles");

// Wire types (protobuf's encoding guide).
constexpr std::uint32_t kVarint = 0;
constexpr std::uint32_t kFixed64 = 1;
constexpr std::uint32_t kLength = 2;

constexpr std::uint32_t key(std::uint32_t field, std::uint32_t wire_type) {
  return field << 3 | wire_type;
}

/// The bytes of one message. Every read returns false where protobuf might read differently
/// than the plain reading below (then the whole message goes to protobuf): varints longer than
/// protobuf's limits or the 64-bit ones of 10 bytes (whose last byte protobuf reads in part),
/// lengths past the end.
class Bytes {
 public:
  explicit Bytes(std::span<const std::uint8_t> bytes)
      : at_(bytes.data()), end_(bytes.data() + bytes.size()) {}
  bool empty() const { return at_ == end_; }

  /// A varint of at most `max_bytes` bytes.
  bool varint(std::uint64_t& value, int max_bytes) {
    value = 0;
    for (int i = 0; i < max_bytes && at_ != end_; ++i) {
      const std::uint8_t byte = *at_++;
      value |= std::uint64_t(byte & 0x7F) << (7 * i);
      if (!(byte & 0x80)) return true;
    }
    return false;
  }
  bool key(std::uint32_t& out) {
    std::uint64_t value = 0;
    if (!varint(value, 5) || value > 0xFFFFFFFFu) return false;
    out = std::uint32_t(value);
    return true;
  }
  bool sequence(std::uint64_t& out) { return varint(out, 9); }
  /// A length-delimited field's contents.
  bool nested(Bytes& out) {
    std::uint64_t size = 0;
    if (!varint(size, 5) || size > std::uint64_t(end_ - at_)) return false;
    out = Bytes({at_, std::size_t(size)});
    at_ += size;
    return true;
  }
  bool fixed_double(double& out) {
    if (end_ - at_ < 8) return false;
    std::memcpy(&out, at_, 8);
    at_ += 8;
    return true;
  }
  /// A string field whose bytes are all ASCII (valid UTF-8 whatever protobuf checks; anything
  /// else is protobuf's to accept or refuse).
  bool ascii(std::string& out) {
    Bytes text({at_, 0});
    if (!nested(text)) return false;
    for (const std::uint8_t* c = text.at_; c != text.end_; ++c)
      if (*c & 0x80) return false;
    out.assign(reinterpret_cast<const char*>(text.at_), std::size_t(text.end_ - text.at_));
    return true;
  }

 private:
  const std::uint8_t* at_;
  const std::uint8_t* end_;
};

/// Vector3 (fields 1–3) or Quaternion (fields 1–4: w, x, y, z), as doubles in field order; a
/// field given twice keeps its last value, as protobuf does.
bool read_doubles(Bytes bytes, double* values, std::uint32_t count) {
  while (!bytes.empty()) {
    std::uint32_t k = 0;
    if (!bytes.key(k) || (k & 7) != kFixed64) return false;
    const std::uint32_t field = k >> 3;
    if (field < 1 || field > count || !bytes.fixed_double(values[field - 1])) return false;
  }
  return true;
}

/// Pose: a sub-message given twice would be merged by protobuf; left to it.
bool read_pose(Bytes bytes, model::PoseInput& out) {
  bool rotation = false, translation = false;
  while (!bytes.empty()) {
    std::uint32_t k = 0;
    Bytes inner({});
    if (!bytes.key(k) || (k & 7) != kLength || !bytes.nested(inner)) return false;
    if (k == key(1, kLength) && !rotation) {
      rotation = true;
      out.rotation_wxyz = {0, 0, 0, 0};  // a Quaternion's fields default to 0
      if (!read_doubles(inner, out.rotation_wxyz.data(), 4)) return false;
    } else if (k == key(2, kLength) && !translation) {
      translation = true;
      out.translation = model::Vec3d::Zero();
      if (!read_doubles(inner, out.translation.data(), 3)) return false;
    } else {
      return false;
    }
  }
  return true;
}

bool read_object_pose(Bytes bytes, const model::PoseInput& no_pose, model::ObjectPoseInput& out) {
  out.pose = no_pose;
  bool pose = false;
  while (!bytes.empty()) {
    std::uint32_t k = 0;
    if (!bytes.key(k)) return false;
    if (k == key(1, kLength)) {
      if (!bytes.ascii(out.object_id)) return false;
    } else if (k == key(2, kLength) && !pose) {
      pose = true;
      Bytes inner({});
      if (!bytes.nested(inner) || !read_pose(inner, out.pose)) return false;
    } else {
      return false;
    }
  }
  return true;
}

/// QueryOptions: every field a scalar, so a field given twice (or the options twice, which
/// protobuf merges) keeps its last value. Read into the generated message, which allocates
/// nothing for scalars, so that proto::from_proto converts it exactly as before.
bool read_options(Bytes bytes, v1::QueryOptions& out) {
  while (!bytes.empty()) {
    std::uint32_t k = 0;
    if (!bytes.key(k)) return false;
    double real = 0;
    std::uint64_t number = 0;
    if ((k & 7) == kFixed64) {
      if (!bytes.fixed_double(real)) return false;
    } else if ((k & 7) == kVarint) {
      // Protobuf reads 10-byte varints too (negative enums), keeping the low bits: left to it.
      if (!bytes.varint(number, 9)) return false;
    } else {
      return false;
    }
    // As protobuf converts what it reads: bool = nonzero, uint32 and enums the low 32 bits.
    const bool truth = number != 0;
    const auto low = std::uint32_t(number);
    switch (k) {
      case key(1, kFixed64):
        out.set_epsilon(real);
        break;
      case key(2, kVarint):
        out.set_near_points(truth);
        break;
      case key(3, kVarint):
        out.set_penetration(v1::PenetrationMode(std::int32_t(low)));
        break;
      case key(4, kVarint):
        out.set_gradient(truth);
        break;
      case key(5, kFixed64):
        out.set_distance_cutoff(real);
        break;
      case key(6, kVarint):
        out.set_warm_start(truth);
        break;
      case key(7, kVarint):
        out.set_max_iterations(low);
        break;
      case key(8, kVarint):
        out.set_report_mode(v1::ReportMode(std::int32_t(low)));
        break;
      case key(9, kFixed64):
        out.set_change_tolerance(real);
        break;
      default:
        return false;  // an unknown field, or a known one with another wire type
    }
  }
  return true;
}

/// What proto::from_proto makes of the absent parts: an empty PoseUpdate, a Pose left out.
struct Defaults {
  model::PoseUpdateInput update = proto::from_proto(v1::PoseUpdate::default_instance());
  model::PoseInput pose = proto::from_proto(v1::Pose::default_instance());
};

bool read_update(Bytes bytes, const Defaults& defaults, model::PoseUpdateInput& out) {
  out = defaults.update;
  v1::QueryOptions options;  // scalars only: nothing allocated
  bool has_options = false;
  while (!bytes.empty()) {
    std::uint32_t k = 0;
    if (!bytes.key(k)) return false;
    if (k == key(1, kLength)) {
      if (!bytes.ascii(out.scene_id)) return false;
    } else if (k == key(2, kVarint)) {
      if (!bytes.sequence(out.sequence)) return false;
    } else if (k == key(3, kLength)) {
      Bytes inner({});
      if (!bytes.nested(inner) || !read_object_pose(inner, defaults.pose, out.poses.emplace_back()))
        return false;
    } else if (k == key(4, kLength)) {
      has_options = true;
      Bytes inner({});
      if (!bytes.nested(inner) || !read_options(inner, options)) return false;
    } else if (k == key(5, kVarint)) {
      std::uint64_t number = 0;
      if (!bytes.varint(number, 9)) return false;
      // As from_proto converts the enum protobuf read (its low 32 bits).
      out.flow_control = model::from_wire<model::FlowControl>(std::int32_t(std::uint32_t(number)));
    } else {
      return false;  // thresholds, joints, unknown fields: protobuf's
    }
  }
  if (has_options) out.options = proto::from_proto(options);
  return true;
}

}  // namespace

bool read_plain_pose_updates(std::span<const std::uint8_t> bytes, bool batched,
                             std::vector<model::PoseUpdateInput>& out) {
  static const Defaults defaults;
  // The updates of the previous message are overwritten in place: their vectors and strings keep
  // their capacity, so a stream's steady flow of updates allocates nothing here.
  std::size_t count = 0;
  auto next = [&]() -> model::PoseUpdateInput& {
    if (count == out.size()) out.emplace_back();
    return out[count++];
  };
  Bytes message(bytes);
  bool read = true;
  if (!batched) {
    read = read_update(message, defaults, next());
  } else {
    while (read && !message.empty()) {
      std::uint32_t k = 0;
      Bytes inner({});
      read = message.key(k) && k == key(1, kLength) && message.nested(inner) &&
             read_update(inner, defaults, next());
    }
  }
  out.resize(count);
  return read;
}

}  // namespace nearpoint::server
