// SPDX-License-Identifier: Apache-2.0
// Errors of the scene API: a code, the offending field and a message. Transports turn them into
// their own form in one place each (gRPC: `to_grpc_status` in the service adapter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/server/limits.hpp"

namespace nearpoint::server {

/// What kind of failure. Each is exactly one gRPC status code, and its value is that code's number
/// (google.rpc.Code), taken from model/vocabulary.hpp's status table by name: gRPC statuses and a
/// rejected DDS update's report carry it (status_code), and proto_convert.cpp checks it against
/// grpc::StatusCode.
enum class ErrorCode : unsigned char {
  /// the request is malformed (names the field)
  invalid_argument = model::status_code_number("INVALID_ARGUMENT"),
  /// an id (geometry, scene, object) is unknown
  not_found = model::status_code_number("NOT_FOUND"),
  /// a requested id is taken
  already_exists = model::status_code_number("ALREADY_EXISTS"),
  /// a configured limit was reached
  resource_exhausted = model::status_code_number("RESOURCE_EXHAUSTED"),
  /// valid, but not in the current state (e.g. a stream bound elsewhere)
  failed_precondition = model::status_code_number("FAILED_PRECONDITION"),
  /// a bug: should never be seen
  internal = model::status_code_number("INTERNAL"),
  /// the server is shutting down
  unavailable = model::status_code_number("UNAVAILABLE"),
};

/// The gRPC status code of `code` (google.rpc.Code numbering).
constexpr std::uint32_t status_code(ErrorCode code) {
  return static_cast<std::uint32_t>(code);
}

/// The status code's name in lower case, as logs and metrics label it ("invalid_argument"):
/// model/vocabulary.hpp's status table.
std::string to_string(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::internal;
  /// The offending field as a path into the request ("geometry.pieces[2].radius"); empty when no
  /// single field is to blame.
  std::string field;
  /// What is wrong, for people.
  std::string message;

  /// "field: message", or the message alone.
  std::string describe() const { return field.empty() ? message : field + ": " + message; }
};

/// Builds a message from streamable parts: text("got ", 3.5, " m").
template <class... Parts>
std::string text(const Parts&... parts) {
  std::ostringstream out;
  out.precision(12);  // enough to tell values apart in a message, short enough to read
  (out << ... << parts);
  return out.str();
}

/// A client-sent id or name for a message or a log line: at most `max_bytes` of it, in single
/// quotes, bytes outside printable ASCII as \xNN, and when cut its length: 'abc…' (8192 bytes).
/// Messages never echo a client's string whole: an 8 kB id would not fit gRPC's metadata, and a
/// 10 MB one would make a 10 MB log line.
std::string quoted(std::string_view value, std::size_t max_bytes = kQuotedBytes);

inline Error invalid_argument(std::string field, std::string message) {
  return {ErrorCode::invalid_argument, std::move(field), std::move(message)};
}
inline Error not_found(std::string field, std::string message) {
  return {ErrorCode::not_found, std::move(field), std::move(message)};
}
inline Error resource_exhausted(std::string field, std::string message) {
  return {ErrorCode::resource_exhausted, std::move(field), std::move(message)};
}

/// A value or the Error that prevented it (std::expected arrives with C++23).
template <class T>
class [[nodiscard]] Expected {
 public:
  Expected(T value) : state_(std::move(value)) {}
  Expected(Error error) : state_(std::move(error)) {}

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() { return std::get<0>(state_); }
  const T& value() const { return std::get<0>(state_); }
  T& operator*() { return value(); }
  T* operator->() { return &value(); }
  const Error& error() const { return std::get<1>(state_); }

 private:
  std::variant<T, Error> state_;
};

/// Success or the Error that prevented it.
class [[nodiscard]] Outcome {
 public:
  Outcome() = default;
  Outcome(Error error) : error_(std::move(error)), failed_(true) {}
  bool ok() const { return !failed_; }
  explicit operator bool() const { return ok(); }
  const Error& error() const { return error_; }

 private:
  Error error_;
  bool failed_ = false;
};

}  // namespace nearpoint::server
