// SPDX-License-Identifier: Apache-2.0
// The status code both transports carry for a scene API error: gRPC's status and a rejected DDS
// update's report. Written once here for both adapters; proto_convert.cpp checks at compile time
// that it matches grpc::StatusCode. (The API enums' numbers are model/vocabulary.hpp's tables.)
#pragma once

#include <cstdint>

#include "nearpoint/server/errors.hpp"

namespace nearpoint::server::wire {

/// The gRPC status code of `code` (google.rpc.Code numbering): what a rejected update's report
/// carries on DDS and what the gRPC status carries.
constexpr std::uint32_t status_code(ErrorCode code) {
  switch (code) {
    case ErrorCode::invalid_argument:
      return 3;
    case ErrorCode::not_found:
      return 5;
    case ErrorCode::already_exists:
      return 6;
    case ErrorCode::resource_exhausted:
      return 8;
    case ErrorCode::failed_precondition:
      return 9;
    case ErrorCode::internal:
      return 13;
    case ErrorCode::unavailable:
      return 14;
  }
  return 13;
}

}  // namespace nearpoint::server::wire
