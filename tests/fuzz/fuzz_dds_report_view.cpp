// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: `nearpoint dds load`'s reader of DistanceReport bytes (client/src/
// dds_report_view.hpp), which walks a report's pairs without decoding them. The first byte picks
// a report (even) or a batch of reports (odd); the rest is the serialised sample, header first.
// Invariants: every input is answered (no read past the bytes: ASan), a refusal says why, an
// acceptance delivers exactly the report or the batch's count of reports, and a report carries a
// message only when it is an error report.
#include <cstdint>
#include <cstring>
#include <string>

#include "dds_report_view.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool batch = (data[0] & 1) != 0;
  const std::uint8_t* bytes = data + 1;
  const std::size_t length = size - 1;
  std::uint32_t delivered = 0;
  std::string error;
  const bool ok = nearpoint::cli::read_report_views(
      bytes, length, batch,
      [&](const nearpoint::cli::ReportView& view) {
        ++delivered;
        NEARPOINT_FUZZ_CHECK(view.status != 0 || view.message.empty(),
                             "a message on an accepted report");
      },
      error);
  NEARPOINT_FUZZ_CHECK(ok == error.empty(), "refused without a reason, or a reason when accepted");
  if (ok) {
    std::uint32_t expected = 1;
    if (batch) std::memcpy(&expected, bytes + 4, sizeof expected);  // the batch's count
    NEARPOINT_FUZZ_CHECK(delivered == expected, "accepted " + std::to_string(delivered) +
                                                    " reports of " + std::to_string(expected));
  }
  return 0;
}
