// SPDX-License-Identifier: Apache-2.0
// Structured logs: one line per event, key=value pairs, to stderr.
//   ts=2026-11-21T19:44:36.123456Z level=info event=stream_closed stream=3 updates=412 ...
// Values with spaces, quotes or '=' are double-quoted with backslash escapes.
#pragma once

#include <sstream>
#include <string>
#include <string_view>

namespace nearpoint::server {

enum class LogLevel : unsigned char { debug, info, warn, error };

/// Lines below this level are dropped. Default: info.
void set_log_level(LogLevel level);
LogLevel log_level();
bool parse_log_level(std::string_view text, LogLevel& out);

/// One log line, written (with a single write(2)) when it goes out of scope.
class LogLine {
 public:
  LogLine(LogLevel level, std::string_view event);
  ~LogLine();
  LogLine(const LogLine&) = delete;
  LogLine& operator=(const LogLine&) = delete;

  LogLine& kv(std::string_view key, std::string_view value);
  LogLine& kv(std::string_view key, const std::string& value) {
    return kv(key, std::string_view(value));
  }
  LogLine& kv(std::string_view key, const char* value) { return kv(key, std::string_view(value)); }
  template <class Number>
  LogLine& kv(std::string_view key, Number value) {
    if (!enabled_) return *this;
    std::ostringstream out;
    out << value;
    return kv(key, std::string_view(out.str()));
  }

 private:
  bool enabled_;
  std::string line_;
};

inline LogLine log_info(std::string_view event) {
  return LogLine(LogLevel::info, event);
}
inline LogLine log_warn(std::string_view event) {
  return LogLine(LogLevel::warn, event);
}
inline LogLine log_error(std::string_view event) {
  return LogLine(LogLevel::error, event);
}
inline LogLine log_debug(std::string_view event) {
  return LogLine(LogLevel::debug, event);
}

}  // namespace nearpoint::server
