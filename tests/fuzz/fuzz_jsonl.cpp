// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the JSON Lines reader of `nearpoint distance` (run_distance on string
// streams, as the tests and the binary run it). Invariants: the whole input is read (exit 0: bad
// lines are answered, not fatal), one answer per non-blank input line, every answer a JSON object
// with a known status; an answered query has a finite distance ≥ 0 and error bound ≥ 0, an error
// a message, and no line reaches the "internal error" fallback (an exception the command did not
// turn into a message).
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include "distance_command.hpp"
#include "fuzz_support.hpp"

namespace {

using nearpoint::formats::Json;

bool blank(const std::string& line) {
  return line.find_first_not_of(" \t\r\n\f\v") == std::string::npos;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::istringstream in(text);
  std::ostringstream out, diagnostics;
  nearpoint::cli::DistanceCommandOptions options;
  options.diagnostics = &diagnostics;
  options.input_name = "<fuzz>";
  const int code = nearpoint::cli::run_distance(in, out, options);
  NEARPOINT_FUZZ_CHECK(code == nearpoint::cli::kExitOk,
                       "exit " + std::to_string(code) + ": " + diagnostics.str());

  std::size_t expected = 0;
  {
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);)
      if (!blank(line)) ++expected;
  }
  std::istringstream answers(out.str());
  std::size_t count = 0;
  for (std::string line; std::getline(answers, line); ++count) {
    // The answers are the command's own output: small nesting unless an id was echoed, and the
    // parser is not recursive, so parsing them back is safe.
    Json answer;
    try {
      answer = Json::parse(line);
    } catch (const std::exception& e) {
      nearpoint::fuzz::fail(__FILE__, __LINE__, "answer is not JSON: " + line.substr(0, 300));
    }
    NEARPOINT_FUZZ_CHECK(
        answer.is_object() && answer.contains("status") && answer["status"].is_string(),
        "answer without a status: " + line.substr(0, 300));
    const std::string status = answer["status"];
    if (status == "error") {
      NEARPOINT_FUZZ_CHECK(answer.contains("message") && answer["message"].is_string(),
                           "error without a message: " + line.substr(0, 300));
      const std::string message = answer["message"];
      // "line N: internal error: …" is the fallback's prefix (the rest may quote the input).
      const std::size_t colon = message.find(": ");
      NEARPOINT_FUZZ_CHECK(
          colon == std::string::npos || message.compare(colon, 17, ": internal error:") != 0,
          "an exception escaped the line's parsing: " + message.substr(0, 300));
      continue;
    }
    const bool contact = status == "intersecting" || status == "touching";
    NEARPOINT_FUZZ_CHECK(status == "separated" || contact || status == "iteration_limit",
                         "unknown status: " + line.substr(0, 300));
    NEARPOINT_FUZZ_CHECK(answer["distance"].is_number() && answer["error_bound"].is_number(),
                         "answer without distance or error_bound: " + line.substr(0, 300));
    const double d = answer["distance"], e = answer["error_bound"];
    NEARPOINT_FUZZ_CHECK(std::isfinite(d) && d >= 0 && std::isfinite(e) && e >= 0,
                         "bad distance or error bound: " + line.substr(0, 300));
    NEARPOINT_FUZZ_CHECK(contact == (d == 0) || status == "iteration_limit",
                         "distance 0 if and only if in contact: " + line.substr(0, 300));
    if (answer.contains("signed_distance")) {  // "penetration": "depth"
      const double s = answer["signed_distance"], lower = answer["signed_distance_lower"],
                   upper = answer["signed_distance_upper"], h = answer["penetration_depth"],
                   h_lower = answer["penetration_depth_lower"],
                   h_upper = answer["penetration_depth_upper"];
      NEARPOINT_FUZZ_CHECK(lower <= s && s <= upper && 0 <= h_lower && h_lower <= h &&
                               h <= h_upper && (status != "separated" || lower >= 0),
                           "signed distance or depth outside its interval: " + line.substr(0, 300));
    }
  }
  NEARPOINT_FUZZ_CHECK(count == expected, "answered " + std::to_string(count) + " of " +
                                              std::to_string(expected) + " non-blank lines");
  return 0;
}
