// SPDX-License-Identifier: Apache-2.0
// The scene API's vocabulary (model/vocabulary.hpp): every row reads back as itself by number and
// by spelling, unknown numbers and spellings read as each enum's documented fallback, and the
// status names follow gRPC's numbering.
#include <gtest/gtest.h>

#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::model {
namespace {

template <class Enum>
void expect_rows_round_trip() {
  for (const Term<Enum>& term : Vocabulary<Enum>::terms) {
    SCOPED_TRACE(std::string(term.name));
    EXPECT_EQ(from_wire<Enum>(term.wire), term.value);
    EXPECT_EQ(from_dds<Enum>(term.dds), term.value);
    EXPECT_EQ(term.wire, term.dds);  // the DDS IDL repeats nearpoint.v1's numbers
    if (!term.spelling.empty()) {
      EXPECT_EQ(from_spelling<Enum>(term.spelling), term.value);
      EXPECT_TRUE(is_spelling<Enum>(term.spelling));
    }
    // The first row of a value is the one it is written with.
    if (find_term(term.value) == &term) {
      EXPECT_EQ(to_wire(term.value), term.wire);
      EXPECT_EQ(to_dds(term.value), term.dds);
      EXPECT_EQ(name_of(term.value), term.name);
      EXPECT_EQ(spelling_of(term.value), term.spelling);
    }
  }
}

TEST(Vocabulary, EveryRowReadsBackAsItself) {
  expect_rows_round_trip<ReportMode>();
  expect_rows_round_trip<PenetrationMode>();
  expect_rows_round_trip<FlowControl>();
  expect_rows_round_trip<PairStatus>();
  expect_rows_round_trip<Crossing>();
  expect_rows_round_trip<DepthTermination>();
}

TEST(Vocabulary, TheWireNumbersStayAsTheProtosHaveThem) {
  EXPECT_EQ(to_wire(ReportMode::all_pairs), 1);
  EXPECT_EQ(to_wire(ReportMode::within_cutoff), 2);
  EXPECT_EQ(to_wire(ReportMode::nearest_per_object), 3);
  EXPECT_EQ(to_wire(ReportMode::global_minimum), 4);
  EXPECT_EQ(to_wire(ReportMode::changed), 5);
  EXPECT_EQ(to_wire(PenetrationMode::none), 1);
  EXPECT_EQ(to_wire(PenetrationMode::bound), 2);
  EXPECT_EQ(to_wire(PenetrationMode::depth), 3);
  EXPECT_EQ(to_wire(FlowControl::block), 1);
  EXPECT_EQ(to_wire(FlowControl::coalesce), 2);
  EXPECT_EQ(to_wire(PairStatus::separated), 1);
  EXPECT_EQ(to_wire(PairStatus::engine_error), 5);
  EXPECT_EQ(to_wire(PairStatus::touching), 6);  // appended: 1-5 keep their meaning
  EXPECT_EQ(to_dds(PairStatus::touching), 6);
  EXPECT_EQ(spelling_of(PairStatus::touching), "touching");
  EXPECT_TRUE(in_contact(PairStatus::touching));
  EXPECT_TRUE(in_contact(PairStatus::intersecting));
  EXPECT_FALSE(in_contact(PairStatus::separated));
  EXPECT_FALSE(in_contact(PairStatus::engine_error));
  EXPECT_EQ(to_wire(DepthTermination::closed_form), 1);
  EXPECT_EQ(to_wire(DepthTermination::degenerate), 4);
  EXPECT_EQ(to_wire(Crossing::enter), 1);
  EXPECT_EQ(to_wire(Crossing::exit), 2);
}

TEST(Vocabulary, UnknownNumbersAndSpellingsReadAsTheDocumentedFallback) {
  EXPECT_EQ(from_wire<ReportMode>(6), ReportMode::unknown);
  EXPECT_EQ(from_wire<ReportMode>(-1), ReportMode::unknown);
  EXPECT_EQ(from_dds<PenetrationMode>(200), PenetrationMode::unknown);
  EXPECT_EQ(from_wire<FlowControl>(0), FlowControl::block);  // unspecified means block
  EXPECT_EQ(from_wire<FlowControl>(3), FlowControl::unknown);
  EXPECT_EQ(from_wire<PairStatus>(0), PairStatus::engine_error);
  EXPECT_EQ(from_dds<PairStatus>(9), PairStatus::engine_error);
  EXPECT_EQ(from_wire<DepthTermination>(7), DepthTermination::unknown);
  EXPECT_EQ(from_wire<Crossing>(0), Crossing::enter);
  EXPECT_EQ(from_spelling<ReportMode>(""), ReportMode::unknown);
  EXPECT_EQ(from_spelling<ReportMode>("all_pairs"), ReportMode::unknown);
  EXPECT_FALSE(is_spelling<ReportMode>(""));
  // Values without a row are written as 0, named and spelled "" (never a null pointer).
  EXPECT_EQ(to_wire(ReportMode::unknown), 0);
  EXPECT_EQ(to_dds(ReportMode::unspecified), 0);
  EXPECT_NE(spelling_of(ReportMode::unknown).data(), nullptr);
  EXPECT_EQ(spelling_of(ReportMode::unknown), "");
}

TEST(Vocabulary, SpellingsListEveryChoiceInTableOrder) {
  EXPECT_EQ(spellings<ReportMode>(), "all, within-cutoff, nearest, global or changed");
  EXPECT_EQ(spellings<PenetrationMode>("\""), "\"none\", \"bound\" or \"depth\"");
  EXPECT_EQ(spelling_list<FlowControl>(), (std::vector<std::string>{"block", "coalesce"}));
}

TEST(Vocabulary, StatusCodesAreNamedByGrpcNumbering) {
  EXPECT_EQ(status_code_name(0), "OK");
  EXPECT_EQ(status_code_name(3), "INVALID_ARGUMENT");
  EXPECT_EQ(status_code_name(14), "UNAVAILABLE");
  EXPECT_EQ(status_code_name(16), "UNAUTHENTICATED");
  EXPECT_EQ(status_code_name(17), "CODE_17");
  EXPECT_EQ(status_code_name(-1), "CODE_-1");
  EXPECT_EQ(status_code_spelling(8), "resource_exhausted");
}

}  // namespace
}  // namespace nearpoint::model
