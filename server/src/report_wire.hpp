// SPDX-License-Identifier: Apache-2.0
// A stream's DistanceReport in protobuf's wire format, encoded straight from the server's Report
// without building the nearpoint.v1 message first.
//
// Why: a cell45 report is 45 PairDistance messages. Building them (two id strings copied per
// pair, sub-messages, Clear() of the previous report's) and then sizing and serialising them cost
// about 6 % of nearpointd's CPU per update over gRPC, several times what writing the bytes takes.
// The bytes are exactly those of to_proto(report) serialised by protobuf (field order, proto3's
// omitted zeros, −0.0 kept, minimal varints): tests/server/test_report_wire.cpp holds the two
// side by side for random reports.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "nearpoint/server/report.hpp"

namespace nearpoint::server {

/// Encodes reports like protobuf does: measure() sizes the message and remembers every nested
/// message's size (protobuf's cached sizes), then write() puts the bytes down in one pass. One
/// encoder per stream, reused: after the first report it allocates nothing.
class ReportEncoder {
 public:
  /// The encoded size of `report` in bytes (of DistanceReport, without any outer tag).
  std::size_t measure(const Report& report);
  /// Writes the report measure() was last called with (the same object, unchanged) to `out`,
  /// which has room for measure()'s bytes; returns the end of what was written.
  std::uint8_t* write(const Report& report, std::uint8_t* out) const;

 private:
  std::vector<std::uint32_t> nested_sizes_;  // every nested message's size, in write order
};

}  // namespace nearpoint::server
