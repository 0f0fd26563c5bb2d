// SPDX-License-Identifier: Apache-2.0
#include "report_wire.hpp"

#include <bit>
#include <cstring>
#include <string_view>

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/wire_format_lite.h>

#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "nearpoint_distance.pb.h"
#include "proto_convert.hpp"
#include "robot_scene.hpp"

namespace nearpoint::server {
namespace {

namespace v1 = ::nearpoint::v1;

using google::protobuf::internal::WireFormatLite;
using google::protobuf::io::CodedOutputStream;

constexpr auto kVarint = WireFormatLite::WIRETYPE_VARINT;
constexpr auto kFixed64 = WireFormatLite::WIRETYPE_FIXED64;
constexpr auto kLengthDelimited = WireFormatLite::WIRETYPE_LENGTH_DELIMITED;

std::size_t varint_size(std::uint64_t value) {
  return CodedOutputStream::VarintSize64(value);
}

constexpr std::uint32_t tag(std::uint32_t field, WireFormatLite::WireType type) {
  return WireFormatLite::MakeTag(int(field), type);
}

/// Protobuf writes an enum as its int32 value sign-extended to 64 bits (10 bytes when negative).
std::uint64_t enum_bits(std::int32_t value) {
  return std::uint64_t(std::int64_t(value));
}

// Two passes over the same encode_* functions, as protobuf's ByteSizeLong and
// _InternalSerialize: the Sizer adds up sizes and records each nested message's in write order,
// the Writer reads them back to put each length prefix down before the message. The rules are
// proto3's: a scalar is left out when zero (a double when all its bits are, so −0.0 is written),
// a string when empty; a message is written whenever present, even if empty.

class Sizer {
 public:
  explicit Sizer(std::vector<std::uint32_t>& nested) : nested_(nested) { nested_.clear(); }
  std::size_t size() const { return size_; }

  void varint(std::uint32_t field, std::uint64_t value) {
    if (value != 0) size_ += varint_size(tag(field, kVarint)) + varint_size(value);
  }
  void boolean(std::uint32_t field, bool value) { varint(field, value ? 1 : 0); }
  void fixed_double(std::uint32_t field, double value) {
    if (std::bit_cast<std::uint64_t>(value) != 0) size_ += varint_size(tag(field, kFixed64)) + 8;
  }
  void string(std::uint32_t field, std::string_view text) {
    if (!text.empty())
      size_ += varint_size(tag(field, kLengthDelimited)) + varint_size(text.size()) + text.size();
  }
  template <class Content>
  void message(std::uint32_t field, Content&& content) {
    const std::size_t index = nested_.size();
    nested_.push_back(0);
    const std::size_t outer = size_;
    size_ = 0;
    content(*this);
    const std::size_t inner = size_;
    size_ = outer + varint_size(tag(field, kLengthDelimited)) + varint_size(inner) + inner;
    nested_[index] = std::uint32_t(inner);  // a report is far below 4 GB (--max-message-bytes)
  }

 private:
  std::vector<std::uint32_t>& nested_;
  std::size_t size_ = 0;
};

class Writer {
 public:
  Writer(const std::vector<std::uint32_t>& nested, std::uint8_t* out)
      : nested_(nested), out_(out) {}
  std::uint8_t* end() const { return out_; }

  void varint(std::uint32_t field, std::uint64_t value) {
    if (value == 0) return;
    put_varint(tag(field, kVarint));
    put_varint(value);
  }
  void boolean(std::uint32_t field, bool value) { varint(field, value ? 1 : 0); }
  void fixed_double(std::uint32_t field, double value) {
    const auto bits = std::bit_cast<std::uint64_t>(value);
    if (bits == 0) return;
    put_varint(tag(field, kFixed64));
    out_ = WireFormatLite::WriteDoubleNoTagToArray(value, out_);
  }
  void string(std::uint32_t field, std::string_view text) {
    if (text.empty()) return;
    put_varint(tag(field, kLengthDelimited));
    put_varint(text.size());
    std::memcpy(out_, text.data(), text.size());
    out_ += text.size();
  }
  template <class Content>
  void message(std::uint32_t field, Content&& content) {
    put_varint(tag(field, kLengthDelimited));
    put_varint(nested_[next_++]);
    content(*this);
  }

 private:
  void put_varint(std::uint64_t value) {
    out_ = CodedOutputStream::WriteVarint64ToArray(value, out_);
  }

  const std::vector<std::uint32_t>& nested_;
  std::size_t next_ = 0;
  std::uint8_t* out_;
};

// The fields below follow to_proto(const Report&, v1::DistanceReport&) (proto_convert.cpp) and
// proto::to_proto(const model::PairAnswer&, v1::PairDistance&) one for one, in field-number
// order: what those set is what is written here.

template <class Out>
void encode_vector(Out& out, std::uint32_t field, const model::Vec3d& v) {
  out.message(field, [&](Out& o) {
    o.fixed_double(1, v.x());
    o.fixed_double(2, v.y());
    o.fixed_double(3, v.z());
  });
}

template <class Out>
void encode_gradient(Out& out, std::uint32_t field, const Eigen::Matrix<double, 6, 1>& g) {
  out.message(field, [&](Out& o) {
    encode_vector(o, 1, model::Vec3d(g.template head<3>()));  // translation
    encode_vector(o, 2, model::Vec3d(g.template tail<3>()));  // rotation
  });
}

template <class Out>
void encode_pair(Out& out, const Report& report, std::size_t index) {
  const model::PairReport& pair = report.pairs[index];
  const SceneDefinition& scene = *report.scene;
  out.message(3, [&](Out& p) {  // DistanceReport.pairs
    p.string(1, scene.objects[pair.object_a].id);
    p.string(2, scene.objects[pair.object_b].id);
    p.varint(3, enum_bits(model::to_wire(pair.status)));
    p.fixed_double(4, pair.distance);
    p.fixed_double(5, pair.distance_lower_bound);
    p.fixed_double(6, pair.error_bound);
    p.varint(7, pair.iterations);
    p.varint(8, pair.piece_pairs_evaluated);
    p.varint(9, pair.piece_a);
    p.varint(10, pair.piece_b);
    p.boolean(11, pair.warm_started);
    if (pair.has_near_points) {
      p.boolean(12, true);
      encode_vector(p, 13, pair.point_a);
      encode_vector(p, 14, pair.point_b);
      encode_vector(p, 15, pair.normal);
    }
    if (pair.has_penetration_bound) {
      p.boolean(16, true);
      p.fixed_double(17, pair.penetration_bound);
    }
    if (pair.has_gradient) {
      p.boolean(18, true);
      encode_gradient(p, 19, pair.gradient_a);
      encode_gradient(p, 20, pair.gradient_b);
    }
    if (pair.engine_message) p.string(21, pair.engine_message);
    if (pair.has_signed_distance) {
      p.boolean(22, true);
      p.fixed_double(23, pair.signed_distance);
      p.fixed_double(24, pair.signed_distance_lower);
      p.fixed_double(25, pair.signed_distance_upper);
    }
    if (pair.has_penetration_depth) {
      p.boolean(26, true);
      p.fixed_double(27, pair.depth);
      p.fixed_double(28, pair.depth_lower);
      p.fixed_double(29, pair.depth_upper);
      encode_vector(p, 30, pair.depth_point_a);
      encode_vector(p, 31, pair.depth_point_b);
      encode_vector(p, 32, pair.depth_direction);
      p.varint(33, enum_bits(model::to_wire(pair.depth_termination)));
      p.varint(34, pair.depth_iterations);
    }
    const SceneRobot* robot = scene.robot.get();
    if (robot && index < report.joint_gradients.size())
      for (const std::pair<std::uint32_t, double>& entry : report.joint_gradients[index])
        p.message(35, [&](Out& d) {  // PairDistance.joint_gradient (entry: coordinate, value)
          const auto& [joint, within] = robot->coordinates[entry.first];
          d.string(1, robot->tree.joints[joint].name);
          d.varint(2, within);
          d.fixed_double(3, entry.second);
        });
  });
}

template <class Out>
void encode_report(Out& out, const Report& report) {
  out.varint(1, report.sequence);
  for (std::size_t i = 0; i < report.pairs.size(); ++i) encode_pair(out, report, i);
  out.message(4, [&](Out& t) {
    t.fixed_double(1, report.timing.server_us);
    t.fixed_double(2, report.timing.queue_us);
    t.fixed_double(3, report.timing.evaluation_us);
    t.fixed_double(4, report.timing.geometry_us);
  });
  out.varint(5, report.coalesced_updates);
  out.varint(6, report.coalesced_from_sequence);
  out.message(7, [&](Out& c) {
    c.varint(1, report.counts.pairs_evaluated);
    c.varint(2, report.counts.pairs_pruned);
    c.varint(3, report.counts.pairs_unmoved);
  });
  out.varint(8, enum_bits(report_mode_on_wire(report.mode)));
  for (const model::ThresholdEvent& event : report.events)
    out.message(9, [&](Out& e) {
      if (report.threshold_names) e.string(1, (*report.threshold_names)[event.threshold]);
      e.varint(2, event.threshold);
      e.string(3, report.scene->objects[event.object_a].id);
      e.string(4, report.scene->objects[event.object_b].id);
      e.varint(5, enum_bits(model::to_wire(event.crossing)));
      e.fixed_double(6, event.distance);
      e.varint(7, event.sequence);
    });
  for (const model::JointLimitViolation& violation : report.joint_limit_violations)
    out.message(10, [&](Out& v) {
      v.string(1, violation.joint);
      v.fixed_double(2, violation.position);
      v.fixed_double(3, violation.lower);
      v.fixed_double(4, violation.upper);
    });
}

}  // namespace

std::size_t ReportEncoder::measure(const Report& report) {
  Sizer sizer(nested_sizes_);
  encode_report(sizer, report);
  return sizer.size();
}

std::uint8_t* ReportEncoder::write(const Report& report, std::uint8_t* out) const {
  Writer writer(nested_sizes_, out);
  encode_report(writer, report);
  return writer.end();
}

}  // namespace nearpoint::server
