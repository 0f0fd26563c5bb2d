// SPDX-License-Identifier: Apache-2.0
// The scene API's vocabulary: one table per API enum, written once, from which every layer
// converts and parses (the gRPC adapters, the DDS bridge and client, the CLI, the file formats),
// and one table of the gRPC status codes' names.
//
// Each row of an enum's table holds what the enum is called everywhere:
//   value    — the model's enumerator (scene_types.hpp);
//   name     — the nearpoint.v1 enumerator's name ("REPORT_MODE_WITHIN_CUTOFF"), for messages;
//   spelling — how the CLI's flags, the scene files and the JSON outputs spell it
//              ("within-cutoff"); empty for a row no one spells (REPORT_MODE_UNSPECIFIED);
//   wire     — the nearpoint.v1 enum's number (proto/nearpoint/v1/*.proto);
//   dds      — the number the DDS messages (ros/nearpoint_msgs/msg/*.msg) carry for it.
// The proto adapters check at compile time that `wire` equals the generated enums.
//
// Unknown values, one rule everywhere: a number or a spelling that no row holds reads as the
// enum's `Vocabulary<E>::unknown`. For the enums of a request (ReportMode, PenetrationMode,
// FlowControl) that is their `unknown` enumerator, which validation rejects naming the field; a
// PairStatus the reader does not know (a newer server) reads as engine_error, a Crossing as enter,
// a DepthTermination as its `unknown`.
// Going the other way, a value without a row (unspecified, unknown) has wire and DDS number 0,
// the name "" and the spelling "". A gRPC status code outside the table is named "CODE_<n>".
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::model {

template <class Enum>
struct Term {
  Enum value;
  std::string_view name;
  std::string_view spelling;
  std::int32_t wire;
  std::uint8_t dds;
};

/// The table of one enum (`terms`) and what a number or spelling without a row reads as
/// (`unknown`). Specialised below for every API enum.
template <class Enum>
struct Vocabulary;

template <>
struct Vocabulary<ReportMode> {
  static constexpr std::array<Term<ReportMode>, 6> terms{{
      {ReportMode::unspecified, "REPORT_MODE_UNSPECIFIED", "", 0, 0},
      {ReportMode::all_pairs, "REPORT_MODE_ALL_PAIRS", "all", 1, 1},
      {ReportMode::within_cutoff, "REPORT_MODE_WITHIN_CUTOFF", "within-cutoff", 2, 2},
      {ReportMode::nearest_per_object, "REPORT_MODE_NEAREST_PER_OBJECT", "nearest", 3, 3},
      {ReportMode::global_minimum, "REPORT_MODE_GLOBAL_MINIMUM", "global", 4, 4},
      {ReportMode::changed, "REPORT_MODE_CHANGED", "changed", 5, 5},
  }};
  static constexpr ReportMode unknown = ReportMode::unknown;
};

template <>
struct Vocabulary<PenetrationMode> {
  static constexpr std::array<Term<PenetrationMode>, 4> terms{{
      {PenetrationMode::unspecified, "PENETRATION_MODE_UNSPECIFIED", "", 0, 0},
      {PenetrationMode::none, "PENETRATION_MODE_NONE", "none", 1, 1},
      {PenetrationMode::bound, "PENETRATION_MODE_BOUND", "bound", 2, 2},
      {PenetrationMode::depth, "PENETRATION_MODE_DEPTH", "depth", 3, 3},
  }};
  static constexpr PenetrationMode unknown = PenetrationMode::unknown;
};

/// FLOW_CONTROL_UNSPECIFIED means block: the second row of `block` is found only by its number.
template <>
struct Vocabulary<FlowControl> {
  static constexpr std::array<Term<FlowControl>, 3> terms{{
      {FlowControl::block, "FLOW_CONTROL_BLOCK", "block", 1, 1},
      {FlowControl::coalesce, "FLOW_CONTROL_COALESCE", "coalesce", 2, 2},
      {FlowControl::block, "FLOW_CONTROL_UNSPECIFIED", "", 0, 0},
  }};
  static constexpr FlowControl unknown = FlowControl::unknown;
};

template <>
struct Vocabulary<PairStatus> {
  static constexpr std::array<Term<PairStatus>, 6> terms{{
      {PairStatus::separated, "PAIR_STATUS_SEPARATED", "separated", 1, 1},
      {PairStatus::intersecting, "PAIR_STATUS_INTERSECTING", "intersecting", 2, 2},
      {PairStatus::beyond_cutoff, "PAIR_STATUS_BEYOND_CUTOFF", "beyond_cutoff", 3, 3},
      {PairStatus::iteration_limit, "PAIR_STATUS_ITERATION_LIMIT", "iteration_limit", 4, 4},
      {PairStatus::engine_error, "PAIR_STATUS_ENGINE_ERROR", "engine_error", 5, 5},
      {PairStatus::touching, "PAIR_STATUS_TOUCHING", "touching", 6, 6},
  }};
  static constexpr PairStatus unknown = PairStatus::engine_error;
};

template <>
struct Vocabulary<DepthTermination> {
  static constexpr std::array<Term<DepthTermination>, 5> terms{{
      {DepthTermination::unspecified, "DEPTH_TERMINATION_UNSPECIFIED", "", 0, 0},
      {DepthTermination::closed_form, "DEPTH_TERMINATION_CLOSED_FORM", "closed_form", 1, 1},
      {DepthTermination::tolerance, "DEPTH_TERMINATION_TOLERANCE", "tolerance", 2, 2},
      {DepthTermination::iteration_limit, "DEPTH_TERMINATION_ITERATION_LIMIT", "iteration_limit", 3,
       3},
      {DepthTermination::degenerate, "DEPTH_TERMINATION_DEGENERATE", "degenerate", 4, 4},
  }};
  static constexpr DepthTermination unknown = DepthTermination::unknown;
};

template <>
struct Vocabulary<Crossing> {
  static constexpr std::array<Term<Crossing>, 2> terms{{
      {Crossing::enter, "THRESHOLD_CROSSING_ENTER", "enter", 1, 1},
      {Crossing::exit, "THRESHOLD_CROSSING_EXIT", "exit", 2, 2},
  }};
  static constexpr Crossing unknown = Crossing::enter;
};

/// The first row of `value`; nullptr when it has none (unspecified, unknown).
template <class Enum>
constexpr const Term<Enum>* find_term(Enum value) {
  for (const Term<Enum>& term : Vocabulary<Enum>::terms)
    if (term.value == value) return &term;
  return nullptr;
}

/// The nearpoint.v1 number of `value` (0 without a row).
template <class Enum>
constexpr std::int32_t to_wire(Enum value) {
  const Term<Enum>* term = find_term(value);
  return term ? term->wire : 0;
}

/// The DDS number of `value` (0 without a row).
template <class Enum>
constexpr std::uint8_t to_dds(Enum value) {
  const Term<Enum>* term = find_term(value);
  return term ? term->dds : 0;
}

/// The nearpoint.v1 enumerator's name of `value` ("" without a row; data() is never null).
template <class Enum>
constexpr std::string_view name_of(Enum value) {
  const Term<Enum>* term = find_term(value);
  return term ? term->name : std::string_view("");
}

/// How the CLI and the files spell `value` ("" without a row; data() is never null).
template <class Enum>
constexpr std::string_view spelling_of(Enum value) {
  const Term<Enum>* term = find_term(value);
  return term ? term->spelling : std::string_view("");
}

/// The value of a nearpoint.v1 number; Vocabulary<Enum>::unknown without a row. Signed and wide:
/// proto3 enums are open int32 values.
template <class Enum>
constexpr Enum from_wire(std::int64_t number) {
  for (const Term<Enum>& term : Vocabulary<Enum>::terms)
    if (term.wire == number) return term.value;
  return Vocabulary<Enum>::unknown;
}

/// The value of a DDS number; Vocabulary<Enum>::unknown without a row.
template <class Enum>
constexpr Enum from_dds(std::int64_t number) {
  for (const Term<Enum>& term : Vocabulary<Enum>::terms)
    if (term.dds == number) return term.value;
  return Vocabulary<Enum>::unknown;
}

/// The value spelled `spelling`; Vocabulary<Enum>::unknown when no row spells it ("" included).
template <class Enum>
constexpr Enum from_spelling(std::string_view spelling) {
  for (const Term<Enum>& term : Vocabulary<Enum>::terms)
    if (!term.spelling.empty() && term.spelling == spelling) return term.value;
  return Vocabulary<Enum>::unknown;
}

/// Whether some row spells `spelling`.
template <class Enum>
constexpr bool is_spelling(std::string_view spelling) {
  for (const Term<Enum>& term : Vocabulary<Enum>::terms)
    if (!term.spelling.empty() && term.spelling == spelling) return true;
  return false;
}

/// The spellings in table order, for help texts and messages: `quote` around each, the last two
/// joined by " or " ("all, within-cutoff, nearest, global or changed").
template <class Enum>
std::string spellings(std::string_view quote = "") {
  std::string out;
  std::size_t count = 0;
  for (const Term<Enum>& term : Vocabulary<Enum>::terms) count += !term.spelling.empty();
  std::size_t index = 0;
  for (const Term<Enum>& term : Vocabulary<Enum>::terms) {
    if (term.spelling.empty()) continue;
    if (index > 0) out += index + 1 == count ? " or " : ", ";
    out.append(quote).append(term.spelling).append(quote);
    ++index;
  }
  return out;
}

/// The spellings in table order, as a list (for a command line's choices).
template <class Enum>
std::vector<std::string> spelling_list() {
  std::vector<std::string> out;
  for (const Term<Enum>& term : Vocabulary<Enum>::terms)
    if (!term.spelling.empty()) out.emplace_back(term.spelling);
  return out;
}

/// The gRPC status codes by number (grpc::StatusCode, google.rpc.Code): the one table of their
/// names, for the client's Status, the server's metrics and the DDS client's output.
inline constexpr std::array<std::string_view, 17> kStatusCodeNames{
    "OK",        "CANCELLED",      "UNKNOWN",           "INVALID_ARGUMENT",   "DEADLINE_EXCEEDED",
    "NOT_FOUND", "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION",
    "ABORTED",   "OUT_OF_RANGE",   "UNIMPLEMENTED",     "INTERNAL",           "UNAVAILABLE",
    "DATA_LOSS", "UNAUTHENTICATED"};

/// The number of the status code named `name` ("NOT_FOUND" → 5), for constants that name a code
/// rather than write its number; -1 for a name outside the table (which an unsigned constant
/// initialised from it refuses to compile).
constexpr std::int32_t status_code_number(std::string_view name) {
  for (std::size_t code = 0; code < kStatusCodeNames.size(); ++code)
    if (kStatusCodeNames[code] == name) return std::int32_t(code);
  return -1;
}

/// "INVALID_ARGUMENT" for 3, …; "CODE_<n>" for a code outside the table.
inline std::string status_code_name(std::int64_t code) {
  if (code >= 0 && code < std::int64_t(kStatusCodeNames.size()))
    return std::string(kStatusCodeNames[std::size_t(code)]);
  return "CODE_" + std::to_string(code);
}

/// status_code_name in lower case ("invalid_argument"), as the server's logs and metrics label
/// rejected updates.
inline std::string status_code_spelling(std::int64_t code) {
  std::string out = status_code_name(code);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
  return out;
}

}  // namespace nearpoint::model
