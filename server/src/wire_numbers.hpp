// SPDX-License-Identifier: Apache-2.0
// The numbers both transports carry for the scene API's enums. They are the values of
// nearpoint.v1's enums (proto/nearpoint/v1), which the DDS IDL (proto/dds) repeats as plain
// integers, so that a report or an option means the same on gRPC and on DDS. Written once here
// for both adapters; proto_convert.cpp checks at compile time that they match the generated
// proto enums and grpc::StatusCode.
#pragma once

#include <cstdint>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/scene_types.hpp"

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

/// nearpoint.v1.PairStatus.
constexpr std::uint8_t pair_status(PairStatus status) {
  switch (status) {
    case PairStatus::separated:
      return 1;
    case PairStatus::intersecting:
      return 2;
    case PairStatus::beyond_cutoff:
      return 3;
    case PairStatus::iteration_limit:
      return 4;
    case PairStatus::engine_error:
      return 5;
  }
  return 5;
}

/// From nearpoint.v1.PenetrationMode; a value this server does not know is `unknown` (rejected
/// by validation, naming the field). Signed and wide: proto3 enums are open int32 values.
constexpr PenetrationMode penetration_mode(std::int64_t value) {
  switch (value) {
    case 0:
      return PenetrationMode::unspecified;
    case 1:
      return PenetrationMode::none;
    case 2:
      return PenetrationMode::bound;
    case 3:
      return PenetrationMode::depth;
    default:
      return PenetrationMode::unknown;
  }
}

/// From nearpoint.v1.FlowControl: 0 (unspecified) means block; an unknown value is `unknown`.
constexpr FlowControl flow_control(std::int64_t value) {
  switch (value) {
    case 0:
    case 1:
      return FlowControl::block;
    case 2:
      return FlowControl::coalesce;
    default:
      return FlowControl::unknown;
  }
}

/// nearpoint.v1.ReportMode → ReportMode.
constexpr ReportMode report_mode(std::int64_t value) {
  switch (value) {
    case 0:
      return ReportMode::unspecified;
    case 1:
      return ReportMode::all_pairs;
    case 2:
      return ReportMode::within_cutoff;
    case 3:
      return ReportMode::nearest_per_object;
    case 4:
      return ReportMode::global_minimum;
    case 5:
      return ReportMode::changed;
    default:
      return ReportMode::unknown;
  }
}

/// ReportMode → nearpoint.v1.ReportMode's number (for transports without the generated enum).
constexpr std::uint8_t report_mode_number(ReportMode mode) {
  switch (mode) {
    case ReportMode::within_cutoff:
      return 2;
    case ReportMode::nearest_per_object:
      return 3;
    case ReportMode::global_minimum:
      return 4;
    case ReportMode::changed:
      return 5;
    default:
      return 1;
  }
}
static_assert(report_mode(report_mode_number(ReportMode::changed)) == ReportMode::changed);
static_assert(report_mode(report_mode_number(ReportMode::within_cutoff)) ==
              ReportMode::within_cutoff);

}  // namespace nearpoint::server::wire
