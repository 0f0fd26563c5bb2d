// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/server/log.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>

namespace nearpoint::server {
namespace {

std::atomic<LogLevel> g_level{LogLevel::info};

/// The longest value a line carries. Callers quote client-sent strings short already (see
/// `quoted`); this is the backstop that keeps one line one write of bounded size whatever a
/// caller passes.
constexpr std::size_t kMaxValueBytes = 1024;

const char* name(LogLevel level) {
  switch (level) {
    case LogLevel::debug:
      return "debug";
    case LogLevel::info:
      return "info";
    case LogLevel::warn:
      return "warn";
    case LogLevel::error:
      return "error";
  }
  return "info";
}

bool needs_quotes(std::string_view value) {
  if (value.empty()) return true;
  for (const char c : value)
    if (c == ' ' || c == '"' || c == '=' || c == '\\' || static_cast<unsigned char>(c) < 0x20 ||
        c == 0x7F)
      return true;
  return false;
}

}  // namespace

void set_log_level(LogLevel level) {
  g_level.store(level);
}
LogLevel log_level() {
  return g_level.load();
}

bool parse_log_level(std::string_view text, LogLevel& out) {
  for (LogLevel level : {LogLevel::debug, LogLevel::info, LogLevel::warn, LogLevel::error})
    if (text == name(level)) {
      out = level;
      return true;
    }
  return false;
}

LogLine::LogLine(LogLevel level, std::string_view event) : enabled_(level >= g_level.load()) {
  if (!enabled_) return;
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto micros = std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch() %
                                                                            std::chrono::seconds(1))
                          .count();
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char stamp[48];
  const std::size_t length = std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &utc);
  line_.reserve(160);
  line_.append("ts=").append(stamp, length);
  char fraction[32];
  std::snprintf(fraction, sizeof fraction, ".%06ldZ", static_cast<long>(micros));
  line_.append(fraction);
  line_.append(" level=").append(name(level));
  line_.append(" event=").append(event);
}

LogLine& LogLine::kv(std::string_view key, std::string_view whole) {
  if (!enabled_) return *this;
  if (whole.size() > kMaxValueBytes) {
    // Cut, and say so inside the value: "…" and the length (the suffix fits the room left).
    std::string cut(whole.substr(0, kMaxValueBytes - 32));
    cut.append("\u2026 (").append(std::to_string(whole.size())).append(" bytes)");
    return kv(key, std::string_view(cut));
  }
  const std::string_view value = whole;
  line_.append(" ").append(key).append("=");
  if (!needs_quotes(value)) {
    line_.append(value);
    return *this;
  }
  line_.push_back('"');
  for (const char c : value) {
    if (c == '"' || c == '\\') {
      line_.push_back('\\');
      line_.push_back(c);
    } else if (c == '\n') {
      line_.append("\\n");
    } else if (c == '\t') {
      line_.append("\\t");
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) {
      // Other control characters (a carriage return, a terminal escape) as \xNN, so that a
      // value can neither forge a line nor drive a terminal.
      constexpr char kHex[] = "0123456789abcdef";
      line_.append("\\x");
      line_.push_back(kHex[static_cast<unsigned char>(c) >> 4]);
      line_.push_back(kHex[c & 15]);
    } else {
      line_.push_back(c);
    }
  }
  line_.push_back('"');
  return *this;
}

LogLine::~LogLine() {
  if (!enabled_) return;
  line_.push_back('\n');
  // One write(2) per line: lines from different threads never interleave (stderr is unbuffered
  // and a write of a few hundred bytes to a pipe or file is not split).
  const char* data = line_.data();
  std::size_t left = line_.size();
  while (left > 0) {
    const ssize_t written = ::write(STDERR_FILENO, data, left);
    if (written <= 0) break;  // nowhere to log to: nothing sensible left to do
    data += written;
    left -= std::size_t(written);
  }
}

}  // namespace nearpoint::server
