// SPDX-License-Identifier: Apache-2.0
// The few fields of a nearpoint_msgs DistanceReport that a load generator needs, read straight
// from the sample's serialised bytes (XCDR1, as Cyclone DDS keeps a received sample) without
// decoding its pairs. Decoding a 45-pair report into the idlc C structs (90 strings allocated
// and freed, every field converted) cost `nearpoint dds load` more CPU than nearpointd spent
// answering it, so the load could not keep the server busy; here the pairs are only walked.
// No Cyclone DDS types: the reader is plain C++ over bytes (and fuzzed as such).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace nearpoint::cli {

/// What a load counts of one DistanceReport (ros/nearpoint_msgs/msg/DistanceReport.msg).
struct ReportView {
  std::array<std::uint8_t, 16> writer_guid{};
  std::uint64_t sequence_number = 0;
  std::uint32_t status = 0;
  std::string message;  // only for rejected updates (status ≠ 0)
  std::uint32_t pair_count = 0;
  double server_us = 0, geometry_us = 0;
  std::uint32_t coalesced_updates = 0;
  std::uint64_t coalesced_from_sequence = 0;
};

/// Calls `on_report` for the report in `data` (a serialised DistanceReport with its 4-byte
/// encapsulation header, XCDR1 in host byte order as Cyclone hands it over), or for each report
/// of a serialised DistanceReportBatch when `batch`. False, with `error` saying what, when the
/// bytes are not one: truncated, a string without its terminating NUL, a count beyond the
/// bytes, another encoding; the reports before the fault have been delivered.
bool read_report_views(const std::uint8_t* data, std::size_t size, bool batch,
                       const std::function<void(const ReportView&)>& on_report, std::string& error);

}  // namespace nearpoint::cli
