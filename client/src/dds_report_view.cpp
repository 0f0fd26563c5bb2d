// SPDX-License-Identifier: Apache-2.0
#include "dds_report_view.hpp"

#include <bit>
#include <cstring>
#include <type_traits>

namespace nearpoint::cli {
namespace {

// XCDR1 read from the payload after the encapsulation header: each primitive aligned to its
// size from the payload's start, strings as a uint32 length that counts the terminating NUL.
// The first fault stops every later read (each then returns zero), so callers check ok() once.
class CdrIn {
 public:
  CdrIn(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  bool ok() const { return fault_ == nullptr; }
  const char* fault() const { return fault_; }

  template <class T>
  T get() {
    static_assert(std::is_arithmetic_v<T>);
    pos_ = (pos_ + sizeof(T) - 1) & ~(sizeof(T) - 1);
    if (!take(sizeof(T), "truncated")) return T{};
    T value;
    std::memcpy(&value, data_ + pos_ - sizeof(T), sizeof(T));
    return value;
  }
  template <class T>
  void skip(std::size_t count) {
    for (std::size_t i = 0; i < count; ++i) get<T>();
  }
  void octets(std::uint8_t* out, std::size_t n) {
    if (take(n, "truncated")) std::memcpy(out, data_ + pos_ - n, n);
  }
  // A string; copied into `out` when given.
  void string(std::string* out = nullptr) {
    const std::uint32_t length = get<std::uint32_t>();
    if (!ok()) return;
    if (length == 0) {
      fail("a string without its terminating NUL");
      return;
    }
    if (!take(length, "a string longer than the bytes left")) return;
    const char* text = reinterpret_cast<const char*>(data_ + pos_ - length);
    if (text[length - 1] != '\0') {
      fail("a string without its terminating NUL");
      return;
    }
    if (out != nullptr) out->assign(text, length - 1);
  }

 private:
  bool take(std::size_t n, const char* why) {
    if (!ok()) return false;
    if (pos_ > size_ || n > size_ - pos_) {
      fail(why);
      return false;
    }
    pos_ += n;
    return true;
  }
  void fail(const char* why) {
    if (ok()) fault_ = why;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  const char* fault_ = nullptr;
};

// The fields of one PairDistance, in order (ros/nearpoint_msgs/msg/PairDistance.msg), read past.
void skip_pair(CdrIn& in) {
  in.string();                // object_a
  in.string();                // object_b
  in.get<std::uint8_t>();     // status
  in.skip<double>(3);         // distance, its lower bound, error bound
  in.skip<std::uint32_t>(4);  // iterations, piece pairs, piece_a, piece_b
  in.skip<std::uint8_t>(2);   // warm_started, has_near_points
  in.skip<double>(9);         // point_a, point_b, normal
  in.get<std::uint8_t>();     // has_penetration_bound
  in.get<double>();           // penetration_bound
  in.get<std::uint8_t>();     // has_gradient
  in.skip<double>(12);        // gradient_a, gradient_b
  in.string();                // message
  in.get<std::uint8_t>();     // has_signed_distance
  in.skip<double>(3);         // signed distance and its interval
  in.get<std::uint8_t>();     // has_penetration_depth
  in.skip<double>(3);         // depth and its interval
  in.skip<double>(9);         // depth points and direction
  in.get<std::uint8_t>();     // depth_termination
  in.get<std::uint32_t>();    // depth_iterations
}

void skip_header(CdrIn& in) {
  in.get<std::int32_t>();   // stamp.sec
  in.get<std::uint32_t>();  // stamp.nanosec
  in.string();              // frame_id
}

// ThresholdEvent.msg, read past.
void skip_event(CdrIn& in) {
  skip_header(in);
  in.string();  // scene_id
  in.string();  // client_id
  in.string();  // threshold
  in.get<std::uint32_t>();
  in.string();  // object_a
  in.string();  // object_b
  in.get<std::uint8_t>();
  in.get<double>();
  in.get<std::uint64_t>();
}

// DistanceReport.msg, field by field; the pairs and events only walked.
void read_report(CdrIn& in, ReportView& out) {
  skip_header(in);
  in.string();  // scene_id
  in.string();  // client_id
  in.octets(out.writer_guid.data(), out.writer_guid.size());
  out.sequence_number = in.get<std::uint64_t>();
  out.status = in.get<std::uint32_t>();
  in.string();  // error_field
  out.message.clear();
  in.string(out.status != 0 ? &out.message : nullptr);
  out.pair_count = in.get<std::uint32_t>();
  for (std::uint32_t i = 0; i < out.pair_count && in.ok(); ++i) skip_pair(in);
  out.server_us = in.get<double>();
  in.get<double>();  // queue_us
  in.get<double>();  // evaluation_us
  out.geometry_us = in.get<double>();
  out.coalesced_updates = in.get<std::uint32_t>();
  out.coalesced_from_sequence = in.get<std::uint64_t>();
  in.skip<std::uint32_t>(3);  // counts
  in.get<std::uint8_t>();     // report_mode
  const std::uint32_t events = in.get<std::uint32_t>();
  for (std::uint32_t i = 0; i < events && in.ok(); ++i) skip_event(in);
}

}  // namespace

bool read_report_views(const std::uint8_t* data, std::size_t size, bool batch,
                       const std::function<void(const ReportView&)>& on_report,
                       std::string& error) {
  // The encapsulation header: the representation (big-endian on the wire), then two option
  // bytes. XCDR1 in this host's byte order only: what Cyclone DDS hands a reader (it puts
  // received samples in host order), for the encoding nearpointd and Cyclone write.
  constexpr std::uint8_t kHostOrder = std::endian::native == std::endian::little ? 1 : 0;
  if (size < 4 || data[0] != 0 || data[1] != kHostOrder) {
    error =
        "not XCDR1 in this host's byte order (the encapsulation header is missing or names "
        "another encoding)";
    return false;
  }
  CdrIn in(data + 4, size - 4);
  ReportView view;
  const std::uint32_t count = batch ? in.get<std::uint32_t>() : 1;
  for (std::uint32_t i = 0; i < count && in.ok(); ++i) {
    read_report(in, view);
    if (in.ok()) on_report(view);
  }
  if (!in.ok()) {
    error = std::string("a malformed report: ") + in.fault();
    return false;
  }
  return true;
}

}  // namespace nearpoint::cli
