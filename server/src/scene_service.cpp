// SPDX-License-Identifier: Apache-2.0
// The scene service's shared pieces: its construction and its errors' spelling. The rest lives by
// seam: geometry_store.cpp, scenes.cpp (creation and lookup), evaluation_job.cpp (the pool's
// evaluations and unary queries) and pose_stream.cpp.
#include "nearpoint/server/scene_service.hpp"

#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::server {

SceneService::SceneService(const ServiceLimits& limits, std::size_t workers)
    : limits_(limits), pool_(workers) {}

SceneService::~SceneService() = default;

std::string to_string(ErrorCode code) {
  return model::status_code_spelling(status_code(code));
}

std::string quoted(std::string_view value, std::size_t max_bytes) {
  const std::string_view shown = value.substr(0, max_bytes);
  std::string out;
  out.reserve(shown.size() + 32);
  out.push_back('\'');
  for (const char c : shown) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte < 0x7F) {
      out.push_back(c);
    } else {
      // Escaped so that a quoted value never carries a line break, a terminal escape or a
      // partial UTF-8 sequence into a log line or a message.
      constexpr char kHex[] = "0123456789abcdef";
      out.append("\\x");
      out.push_back(kHex[byte >> 4]);
      out.push_back(kHex[byte & 15]);
    }
  }
  if (shown.size() < value.size()) out.append("\u2026");  // …
  out.push_back('\'');
  if (shown.size() < value.size()) out.append(text(" (", value.size(), " bytes)"));
  return out;
}

}  // namespace nearpoint::server
